#!/usr/bin/env python3
"""Error per second of tprf binaries on one scene, whole process counted, in one run.

Each binary renders the scene with each of two seeds at the same samples per pixel
(rounds interleaved, so the machine's load falls on all alike). Per binary:

- noise: one render's relative cube error, estimated from the two seeds' cubes as
  |a - b| / (sqrt(2) |(a + b) / 2|) (the two are independent draws of one estimator);
- time: the process's wall time (loading, BVH, pilot, render, writing), its CPU time
  (user + system: less sensitive to other processes on a shared machine) and the
  render's own `render_seconds`;
- efficiency 1 / (noise^2 x time): proportional to the inverse of the time to a given
  error, so the ratio of two binaries' efficiencies is how much sooner one gets there.

    python benches/race/staircase.py /path/to/mitransient out/staircase
    python benches/race/staircase_ab.py out/staircase/staircase.xml OLD/tprf NEW/tprf \\
        --spp 256 --seeds 1,3 --rounds 2

Used for the staircase's figures in docs/benchmarks.md. Needs numpy.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

try:
    import numpy as np
except ImportError:  # pragma: no cover
    np = None


def render(exe: str, scene: str, spp: int, seed: int, threads: int, out: Path):
    """One render: (cube, wall s, cpu s, render s, metadata)."""
    cmd = [exe, "render", scene, "--spp", str(spp), "--seed", str(seed),
           "--threads", str(threads), "--out", str(out)]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    meta = json.loads((out / "tprf.json").read_text())
    cube = np.load(out / "tprf.npy").astype(np.float64)
    return cube, wall, cpu, float(meta["render_seconds"]), meta


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("binaries", nargs="+", help="tprf executables to compare")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--seeds", default="1,3", help="the two seeds (default 1,3)")
    ap.add_argument("--rounds", type=int, default=2, help="times each binary renders each seed")
    ap.add_argument("--threads", type=int, default=2)
    cfg = ap.parse_args(argv)
    if np is None:
        print("skipped: numpy is not installed")
        return 0
    seeds = [int(s) for s in cfg.seeds.split(",")]
    if len(seeds) != 2:
        raise SystemExit("--seeds takes two seeds, e.g. 1,3")
    work = Path(tempfile.mkdtemp(prefix="tprf-ab-"))
    rows = {b: [] for b in cfg.binaries}
    for r in range(cfg.rounds):
        for i, b in enumerate(cfg.binaries):
            runs = [render(b, cfg.scene, cfg.spp, s, cfg.threads, work / f"b{i}_s{s}") for s in seeds]
            (a, *_), (c, *_) = runs
            noise = float(np.linalg.norm(a - c) / np.sqrt(2) / np.linalg.norm((a + c) / 2))
            wall, cpu, rend = (sum(x[k] for x in runs) / 2 for k in (1, 2, 3))
            splits = [x[4].get("first_bounce_splits") for x in runs]
            rows[b].append((noise, wall, cpu, rend))
            print(f"round {r} {b}: noise {noise:.4f}, per render wall {wall:.2f} s, cpu {cpu:.2f} s, "
                  f"render {rend:.2f} s, splits {splits}, load {os.getloadavg()[0]:.1f}", flush=True)
    print(f"\n{cfg.scene}, {cfg.spp} spp, seeds {seeds}, {cfg.threads} threads, {cfg.rounds} rounds")
    print("| binary | noise | wall s | cpu s | render s | eff. wall | eff. cpu | eff. render | vs the first |")
    print("| --- | --: | --: | --: | --: | --: | --: | --: | --: |")
    first = None
    for b in cfg.binaries:
        x = np.array(rows[b])
        n2 = float(np.mean(x[:, 0] ** 2))
        wall, cpu, rend = (float(np.mean(x[:, k])) for k in (1, 2, 3))
        eff = [1 / (n2 * t) for t in (wall, cpu, rend)]
        first = first or eff
        rel = " / ".join(f"{e / f:.2f}x" for e, f in zip(eff, first))
        print(f"| {b} | {np.sqrt(n2):.4f} | {wall:.2f} | {cpu:.2f} | {rend:.2f} | "
              f"{eff[0]:.3f} | {eff[1]:.3f} | {eff[2]:.3f} | {rel} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
