"""tprf from Python: render the Cornell box's light in flight, scrub it with a slider,
plot one pixel's TPRF, and watch a progressive render's error fall.

    pip install ./python matplotlib
    python examples/cornell.py            # a window with a time slider
    python examples/cornell.py --out figs # or: the figures as PNG files, no window

Units as in tprf's files: times in seconds, a bin holds the integral over the bin of the
pixel's radiance for a unit-energy pulse (W m^-2 sr^-1 s per J).
"""

import argparse
from pathlib import Path

import matplotlib
import matplotlib.ticker
import numpy as np

import tprf


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, help="write the figures here instead of showing them")
    ap.add_argument("--size", type=int, default=96, help="image side, pixels")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel")
    args = ap.parse_args()
    if args.out:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.widgets import Slider

    # The transient cube: [H, W, T] float32, the window chosen by a pilot render.
    # bounces_separate=2: also per-bounce layers (seen directly, 1, 2, more events).
    cube = tprf.render("builtin:cornell", width=args.size, height=args.size, spp=args.spp,
                       bins=128, bounces_separate=2)
    print(cube)
    times_ns = cube.times_s * 1e9

    # Light in flight: one time bin at a time, the slider scrubs it.
    fig, (ax_img, ax_tprf) = plt.subplots(1, 2, figsize=(11, 4.8))
    fig.subplots_adjust(bottom=0.2)
    scale = np.quantile(cube.data[cube.data > 0], 0.98)
    # Start where the most pixels are lit: the wavefront across the walls.
    peak_bin = int(np.argmax((cube.data > 0).sum(axis=(0, 1))))
    image = ax_img.imshow(cube.data[:, :, peak_bin], cmap="inferno", vmin=0, vmax=scale)
    ax_img.set_title(f"t = {times_ns[peak_bin]:.3f} ns")
    fig.colorbar(image, ax=ax_img, label="W m$^{-2}$ sr$^{-1}$ s per J")
    slider = Slider(fig.add_axes([0.12, 0.06, 0.35, 0.04]), "bin", 0, cube.shape[2] - 1,
                    valinit=peak_bin, valstep=1)

    def show(b):
        image.set_data(cube.data[:, :, int(b)])
        ax_img.set_title(f"t = {times_ns[int(b)]:.3f} ns")
        fig.canvas.draw_idle()

    slider.on_changed(show)

    # One pixel's TPRF: the back wall's centre, and its light by scattering events.
    y, x = args.size // 2, args.size // 2
    per_ns = 1 / (cube.dt_s * 1e9)
    ax_tprf.plot(times_ns, cube.data[y, x] * per_ns, "k", lw=3, alpha=0.35,
                 label="all light")
    for layer, name in [(1, "1 event (direct)"), (2, "2 events"), (3, "3 or more")]:
        ax_tprf.plot(times_ns, cube.bounces[layer, y, x] * per_ns, label=name)
    ax_tprf.set_xlabel("arrival time (ns)")
    ax_tprf.set_ylabel("radiance per ns (W m$^{-2}$ sr$^{-1}$ per J)")
    ax_tprf.set_title(f"TPRF of pixel (row {y}, column {x})")
    ax_tprf.legend()

    # A progressive render: the error estimate after each pass.
    renderer = tprf.Renderer("builtin:cornell", width=48, height=48, bins=64, spp=64)
    spp, error = [], []
    for snapshot in renderer:
        if snapshot.error_estimate is not None:
            spp.append(snapshot.metadata["spp"])
            error.append(snapshot.error_estimate)
    fig2, ax = plt.subplots(figsize=(5, 4))
    ax.loglog(spp, error, "o-", label="estimated relative RMS error")
    ax.loglog(spp, error[0] * np.sqrt(spp[0] / np.asarray(spp)), "--", label="1/sqrt(spp)")
    ax.set_xlabel("samples per pixel")
    ax.set_ylabel("relative error")
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.legend()
    fig2.tight_layout()
    print(f"error {100 * error[0]:.1f} % at {spp[0]} spp, {100 * error[-1]:.1f} % at {spp[-1]} spp")

    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        fig.savefig(args.out / "light_in_flight.png", dpi=100)
        slider.set_val(min(peak_bin + 10, cube.shape[2] - 1))
        fig.savefig(args.out / "light_in_flight_later.png", dpi=100)
        fig2.savefig(args.out / "convergence.png", dpi=100)
        print(f"wrote {args.out}/light_in_flight.png, light_in_flight_later.png, convergence.png")
    else:
        plt.show()


if __name__ == "__main__":
    main()
