"""The figures of docs/distributed.md: speed-up of a sharded render with 1 and 2 local
Dask workers against one process, the per-task overhead, and the merge's cost.

    TPRF_BIN=target/release/tprf python python/bench_dist.py [--quick]

Prints Markdown tables. Each timing is the best of --repeat runs (the machine may be
shared).
"""

import argparse
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from tprf import dist


def best(f, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)


def run(argv):
    subprocess.run(argv, check=True, capture_output=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    binary = dist.find_tprf()
    tmp = Path(tempfile.mkdtemp(prefix="tprf-bench-"))
    side, spp = (64, 64) if a.quick else (128, 256)
    args = dict(width=side, height=side, spp=spp, bins=256, seed=1, format="npy", band_rows=4,
                t0="3m", dt="2.5cm")
    flags = dist.render_args_to_flags({k: v for k, v in args.items() if k != "band_rows"})
    from distributed import Client, LocalCluster

    print(f"render: builtin:cornell {side}x{side}, {spp} spp, 256 bins (fixed window); "
          f"load average at start {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores\n")
    # Every configuration once per round, rounds repeated, best kept: on a shared
    # machine a quiet or busy moment then falls on all of them alike.
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=None) as c1, Client(c1) as one_worker, \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                         dashboard_address=None) as c2, Client(c2) as two_workers:
        for c in (one_worker, two_workers):
            c.run(lambda: None)

        def one(threads):
            return lambda: run([binary, "render", "builtin:cornell", "--out",
                                str(tmp / "one"), "--threads", str(threads), *flags])

        def dist(client, n):
            return lambda: dist.render_sharded(
                "builtin:cornell", str(tmp / "dist"), n, client=client, binary=binary,
                threads=1, **args)

        configs = [("one process, 1 thread", one(1)), ("one process, 2 threads", one(2))]
        for name, client, workers in (("1 worker", one_worker, 1),
                                      ("2 workers", two_workers, 2)):
            for n in sorted({workers, 2 * workers, 8}):
                configs.append((f"Dask, {name} x 1 thread, {n} shards (+ merge)",
                                dist(client, n)))
        times = {name: [] for name, _ in configs}
        for _ in range(a.repeat):
            for name, f in configs:
                times[name].append(best(f, 1))
        rows = [(name, min(times[name])) for name, _ in configs]
    # Work added by splitting: the shards' time inside render passes, summed, against
    # one single-threaded process's (both from tprf.json; not wall time, so less
    # sensitive to other load).
    import json

    def render_s(folder):
        return json.loads((Path(folder) / "tprf.json").read_text())["render_seconds"]

    run([binary, "render", "builtin:cornell", "--out", str(tmp / "one1"), "--threads", "1",
         "--uniform", *flags])
    work = [("one process, 1 thread", render_s(tmp / "one1"))]
    for n in (2, 8):
        for k in range(n):
            run([binary, "render", "builtin:cornell", "--out", str(tmp / f"w{n}-{k}"),
                 "--threads", "1", "--band-rows", "4", "--uniform", "--shard", f"{k}/{n}",
                 *flags])
        work.append((f"{n} shards, 1 thread each, summed",
                     sum(render_s(tmp / f"w{n}-{k}") for k in range(n))))
    base = rows[1][1]
    print("| run | wall s | speed-up vs one process, 2 threads |")
    print("| --- | --- | --- |")
    for name, t in rows:
        print(f"| {name} | {t:.2f} | {base / t:.2f} |")

    print("\n| render passes | s |")
    print("| --- | --- |")
    for name, t in work:
        print(f"| {name} | {t:.2f} |")
    print(f"\nload average at the end {os.getloadavg()[0]:.1f}")

    # Per-task overhead: a render that does almost nothing, run directly and as a task.
    tiny = ["builtin:cornell", "--width", "4", "--height", "4", "--spp", "1", "--bins", "4",
            "--t0", "3m", "--dt", "1m", "--threads", "1"]
    direct = best(lambda: run([binary, "render", *tiny, "--out", str(tmp / "tiny")]), 10)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        client.run(lambda: None)
        noop = best(lambda: client.submit(lambda: None, pure=False).result(), 20)
        task = best(lambda: client.submit(
            dist.render_shard, binary, "builtin:cornell", str(tmp / "tinyparts"), 0, 1,
            tiny[1:], pure=False).result() and shutil.rmtree(tmp / "tinyparts"), 10)
    print("\n| per task | ms |")
    print("| --- | --- |")
    print(f"| an empty Dask task (submit to result) | {noop * 1e3:.1f} |")
    print(f"| tprf render of 4x4 px, 1 spp, run directly (process start, scene, files) | {direct * 1e3:.1f} |")
    print(f"| the same as a render_shard task (own folder, rename) | {task * 1e3:.1f} |")

    # Merge cost against the cube's size.
    print("\n| merge | cube MiB | shards | s | MiB/s |")
    print("| --- | --- | --- | --- | --- |")
    for fmt, (w, h, bins) in (("npy", (256, 256, 512)), ("zarr", (256, 256, 512))):
        n = 4
        parts = []
        for k in range(n):
            out = tmp / f"m-{fmt}-{k}"
            run([binary, "render", "builtin:cornell", "--out", str(out), "--width", str(w),
                 "--height", str(h), "--spp", "4", "--bins", str(bins), "--t0", "3m",
                 "--dt", "1cm", "--format", fmt, "--uniform", "--shard", f"{k}/{n}"])
            parts.append(str(out))
        t = best(lambda: run([binary, "merge", str(tmp / f"merged-{fmt}"), *parts]), a.repeat)
        mib = w * h * bins * 4 / 2**20
        on_disk = sum(f.stat().st_blocks * 512 for p in parts for f in Path(p).rglob("*")
                      if f.is_file()) / 2**20
        print(f"| {fmt} ({on_disk:.0f} MiB of shards on disk) | {mib:.0f} | {n} | {t:.2f} | {mib / t:.0f} |")
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    os.environ.setdefault("DASK_DISTRIBUTED__LOGGING__DISTRIBUTED", "error")
    main()
