"""Inverse transient rendering: recover the albedos of the Cornell box's white and red
walls from a target cube rendered at other values, by gradient descent on
``L = sum((cube - target)^2)`` with tprf.Differentiable (docs/gradients.md).

Each step renders the cube at the current values (``forward``, its own seed) and the
gradient ``dL/dtheta = backward(2 (cube - target))`` with another seed, so that the
product of the two noisy factors is unbiased. Adam steps on the parameters; the estimate is the mean of the last 10 iterates.

    python python/examples/inverse_albedo.py --out out/inverse --size 32 --spp 16 --steps 40
"""

import argparse
import math
from pathlib import Path

import numpy as np

import tprf

TRUTH = {"material:white.albedo": 0.45, "material:red.albedo": 0.7}
START = {"material:white.albedo": 0.8, "material:red.albedo": 0.3}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("out/inverse_albedo"))
    ap.add_argument("--size", type=int, default=32)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--lr", type=float, default=0.05)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    names = list(TRUTH)
    d = tprf.Differentiable("builtin:cornell", wrt=names, width=args.size, height=args.size,
                            spp=args.spp, bins=48, progress=False)
    # The target: the truth rendered with 4x the samples and a seed of its own.
    target_d = tprf.Differentiable("builtin:cornell", wrt=names, width=args.size,
                                   height=args.size, spp=4 * args.spp,
                                   t0=d.axis[0], dt=d.axis[1], bins=d.axis[2], progress=False)
    target = np.array(target_d.forward(TRUTH, seed=1000).data)

    theta = np.array([START[n] for n in names])
    m, v = np.zeros_like(theta), np.zeros_like(theta)
    b1, b2, eps = 0.5, 0.9, 1e-12
    history = []
    for step in range(args.steps):
        cube = np.array(d.forward(dict(zip(names, theta)), seed=2 * step + 1).data)
        residual = cube - target
        loss = float(np.sum(residual ** 2))
        grads = d.backward(2.0 * residual, seed=2 * step + 2)
        g = np.array([grads[n] for n in names])
        history.append((step, loss, *theta))
        print(f"step {step:3d}  loss {loss:.4e}  "
              + "  ".join(f"{n.split(':')[1]} {t:.4f}" for n, t in zip(names, theta)))
        # Adam, with the step size decaying so that the noise of the last steps averages.
        m = b1 * m + (1 - b1) * g
        v = b2 * v + (1 - b2) * g * g
        lr = args.lr / math.sqrt(1 + step / 10)
        mhat, vhat = m / (1 - b1 ** (step + 1)), v / (1 - b2 ** (step + 1))
        theta = np.clip(theta - lr * mhat / (np.sqrt(vhat) + eps), 0.0, 1.0)

    # The estimate: the mean of the last 10 iterates (they scatter by the gradient's noise).
    final = dict(zip(names, np.mean([h[2:] for h in history[-10:]], axis=0)))
    for n in names:
        err = abs(final[n] - TRUTH[n]) / TRUTH[n]
        print(f"{n}: {final[n]:.4f} (truth {TRUTH[n]}, error {100 * err:.2f} %)")
    np.savetxt(args.out / "history.csv", np.array(history), delimiter=",",
               header="step,loss," + ",".join(names))
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print(f"wrote {args.out / 'history.csv'} (no matplotlib: no plot)")
        return
    h = np.array(history)
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.5))
    a.semilogy(h[:, 0], h[:, 1])
    a.set_xlabel("step")
    a.set_ylabel("loss  sum (cube - target)^2")
    for i, n in enumerate(names):
        line, = b.plot(h[:, 0], h[:, 2 + i], label=n)
        b.axhline(TRUTH[n], color=line.get_color(), ls="--", lw=0.8)
    b.set_xlabel("step")
    b.set_ylabel("albedo (dashed: truth)")
    b.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out / "inverse_albedo.png", dpi=110)
    print(f"wrote {args.out / 'inverse_albedo.png'} and {args.out / 'history.csv'}")


if __name__ == "__main__":
    main()
