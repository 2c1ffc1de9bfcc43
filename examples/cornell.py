"""tprf from Python: render the Cornell box's light in flight, scrub it with a slider,
plot one pixel's TPRF, watch a progressive render's error fall, and measure the cube
with the full-waveform LiDAR preset (its gates, edited to fit the cube, and the depth
from each pixel's first return).

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

    # The LiDAR preset measures the cube: a Gaussian pulse, box gates, first-return
    # depth. Its fields are attributes; here a shorter pulse and finer gates, enough of
    # them to cover the cube's window and the pulse's delay.
    lidar = tprf.Sensor.preset("builtin:lidar")
    lidar.light.centre_s = "1ns"
    lidar.light.fwhm_s = "0.3ns"
    lidar.exposure.width_s = 2 * cube.dt_s
    window_s = cube.shape[2] * cube.dt_s + lidar.light.centre_s + 2 * lidar.light.fwhm_s
    lidar.exposure.count = int(np.ceil(window_s / lidar.exposure.width_s))
    print(lidar)
    measurement = lidar.measure(cube)
    print(measurement)
    depth = measurement.depth  # [H, W], metres; NaN: no return
    fig3, (ax_depth, ax_wave) = plt.subplots(1, 2, figsize=(11, 4.4))
    shown = ax_depth.imshow(depth, cmap="viridis")
    fig3.colorbar(shown, ax=ax_depth, label="first-return depth (m); white: no return")
    ax_depth.set_title("LiDAR: depth from the first return")
    # A pixel's waveform: each gate's measurement at its centre, the return's arrival
    # (2 depth / c after the pulse's centre) marked.
    gates_ns = measurement.gate_centres_s * 1e9
    ax_wave.plot(gates_ns, measurement.images[:, y, x], ".-", label="gates $M_i$")
    arrival_ns = (2 * depth[y, x] / 299792458.0 + lidar.light.centre_s) * 1e9
    ax_wave.axvline(arrival_ns, color="C3", ls="--",
                    label=f"first return: depth {depth[y, x]:.3f} m")
    lit = np.nonzero(measurement.images[:, y, x] > 0)[0]
    if lit.size:
        first, last = max(lit[0] - 4, 0), min(lit[-1] + 4, len(gates_ns) - 1)
        ax_wave.set_xlim(gates_ns[first], gates_ns[last])
    ax_wave.set_xlabel("gate centre (ns after the trigger)")
    ax_wave.set_ylabel("measurement (W m$^{-2}$ sr$^{-1}$ s)")
    ax_wave.set_title(f"LiDAR waveform of pixel (row {y}, column {x})")
    ax_wave.legend()
    fig3.tight_layout()
    finite = depth[np.isfinite(depth)]
    print(f"LiDAR: {finite.size} of {depth.size} pixels with a return, depth "
          f"{finite.min():.3f} .. {finite.max():.3f} m")

    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        fig.savefig(args.out / "light_in_flight.png", dpi=100)
        slider.set_val(min(peak_bin + 10, cube.shape[2] - 1))
        fig.savefig(args.out / "light_in_flight_later.png", dpi=100)
        fig2.savefig(args.out / "convergence.png", dpi=100)
        fig3.savefig(args.out / "lidar.png", dpi=100)
        print(f"wrote {args.out}/light_in_flight.png, light_in_flight_later.png, "
              "convergence.png, lidar.png")
    else:
        plt.show()


if __name__ == "__main__":
    main()
