"""What tprf's Python package costs over the command line, measured in one run:

1. time: tprf.render of a 64 x 64 x 256 cube at 64 spp against `tprf render` with the
   same settings (the CLI also writes its files; Python's cube stays in memory), runs
   interleaved, the median of each;
2. memory: the peak RSS of loading a 1 GiB cube (tprf.load) and of handing out its
   `.data` and `np.asarray(cube)` many times, against the cube's size.

    pip install ./python psutil
    python benches/python/overhead.py [--tprf target/release/tprf] [--repeats 7]
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SETTINGS = dict(width=64, height=64, bins=256, spp=64, seed=0, threads=None)


def cli_seconds(tprf_bin, out):
    flags = ["--width", "64", "--height", "64", "--bins", "256", "--spp", "64", "--seed", "0"]
    start = time.perf_counter()
    subprocess.run([tprf_bin, "render", "builtin:cornell", "--out", str(out), *flags],
                   check=True, capture_output=True)
    return time.perf_counter() - start


def py_seconds():
    import tprf

    start = time.perf_counter()
    tprf.render("builtin:cornell", progress=False, **{k: v for k, v in SETTINGS.items() if v is not None})
    return time.perf_counter() - start


def peak_rss_of(code):
    """Peak RSS (bytes) of a fresh interpreter running `code`, from its own
    ru_maxrss."""
    prog = code + "\nimport resource; print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"
    out = subprocess.run([sys.executable, "-c", prog], check=True, capture_output=True,
                         text=True).stdout.split()
    return int(out[-1]) * 1024


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tprf", default=str(Path(__file__).resolve().parents[2] / "target" / "release" / "tprf"))
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="tprf-py-overhead-"))
    try:
        py_seconds()  # the import and the first scene load, outside the timings
        cli, py = [], []
        for i in range(args.repeats):
            cli.append(cli_seconds(args.tprf, tmp / f"cli{i}"))
            py.append(py_seconds())
        c, p = statistics.median(cli), statistics.median(py)
        print(f"64 x 64 x 256 at 64 spp, median of {args.repeats}: tprf render {c:.3f} s "
              f"(process, render and files), tprf.render {p:.3f} s: ratio {p / c:.3f}")

        # A 1 GiB cube: 512 x 512 pixels x 1024 bins of float32.
        big = tmp / "big"
        subprocess.run([args.tprf, "render", "builtin:cornell", "--out", str(big), "--width",
                        "512", "--height", "512", "--bins", "1024", "--spp", "1", "--uniform"],
                       check=True, capture_output=True)
        gib = (big / "tprf.npy").stat().st_size / 2**30
        base = peak_rss_of("import numpy, tprf")
        load = peak_rss_of(f"import tprf; c = tprf.load({str(big)!r})")
        many = peak_rss_of(f"import numpy as np, tprf; c = tprf.load({str(big)!r}); "
                           "v = [c.data for _ in range(50)] + [np.asarray(c) for _ in range(50)]")
        print(f"a {gib:.2f} GiB cube: peak RSS over the interpreter's own ({base / 2**30:.2f} GiB): "
              f"tprf.load {(load - base) / 2**30:.2f} GiB, with 100 views of .data "
              f"{(many - base) / 2**30:.2f} GiB")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
