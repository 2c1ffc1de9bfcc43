"""tprf.dist on a local cluster (two worker processes): a sharded render merged
through Dask is the one-process render bit for bit, also when a worker is killed in
the middle of a shard; a batch runs, and a re-run skips what is complete."""

import json
import os
import signal
import subprocess
import threading
import time
from pathlib import Path

import psutil
import pytest

from tprf import dist

# Small enough for CI, long enough (about a second a shard) to be caught running.
ARGS = dict(width=48, height=48, spp=96, bins=64, seed=5, band_rows=4, format="npy",
            threads=1)
TIMINGS = ("wall_seconds", "render_seconds", "threads")


def one_process(tprf_bin, out, args):
    """The reference: one tprf render of the whole image, sampled uniformly as shards are."""
    flags = dist.render_args_to_flags({k: v for k, v in args.items() if k != "band_rows"})
    subprocess.run([tprf_bin, "render", "builtin:cornell", "--out", str(out), "--uniform", *flags],
                   check=True, capture_output=True)


def meta(folder):
    m = json.loads((Path(folder) / "tprf.json").read_text())
    for k in TIMINGS:
        m.pop(k)
    # How many rows a shard writes at a time is how its files were written, not what
    # they hold.
    m.get("request", {}).pop("band_rows", None)
    return m


def assert_same_cube(a, b):
    for name in ("tprf.npy", "steady.png"):
        assert (Path(a) / name).read_bytes() == (Path(b) / name).read_bytes(), name
    assert meta(a) == meta(b)


def test_sharded_render_is_the_one_process_render(client, tprf_bin, tmp_path):
    one_process(tprf_bin, tmp_path / "one", ARGS)
    out = dist.render_sharded("builtin:cornell", str(tmp_path / "merged"), 3,
                                   client=client, binary=tprf_bin, **ARGS)
    assert_same_cube(tmp_path / "one", out)
    assert not (tmp_path / "merged.parts").exists()


def test_a_parts_folder_of_the_users_and_a_user_out_are_never_emptied(client, tprf_bin, tmp_path):
    args = dict(ARGS, spp=4)
    parts = tmp_path / "scratch"
    parts.mkdir()
    (parts / "keep.txt").write_text("mine")
    out = dist.render_sharded("builtin:cornell", str(tmp_path / "merged"), 2,
                                   client=client, binary=tprf_bin, parts=str(parts), **args)
    assert (Path(out) / "tprf.npy").is_file()
    assert (parts / "keep.txt").read_text() == "mine"
    assert sorted(p.name for p in parts.iterdir()) == ["keep.txt"]
    # An out holding a user's file is refused by the merge, and the file stays.
    user = tmp_path / "user"
    user.mkdir()
    (user / "thesis.tex").write_text("x")
    with pytest.raises(dist.TprfError, match="thesis.tex"):
        dist.render_sharded("builtin:cornell", str(user), 2, client=client,
                                 binary=tprf_bin, retries=0, **args)
    assert sorted(p.name for p in user.iterdir()) == ["thesis.tex"]


def test_sharded_zarr_render_is_the_one_process_store(client, tprf_bin, tmp_path):
    # Bands of 4 rows share each 32-row chunk among the 3 shards.
    args = dict(ARGS, format="zarr", spp=8)
    one_process(tprf_bin, tmp_path / "one", args)
    out = dist.render_sharded("builtin:cornell", str(tmp_path / "merged"), 3,
                                   client=client, binary=tprf_bin, **args)
    one = tmp_path / "one" / "tprf.zarr"
    files = sorted(p.relative_to(one) for p in one.rglob("*") if p.is_file())
    merged = Path(out) / "tprf.zarr"
    assert files == sorted(p.relative_to(merged) for p in merged.rglob("*") if p.is_file())
    chunks = [f for f in files if f.parts[:2] == ("cube", "c")]
    assert chunks
    for f in files:
        if f.name != "zarr.json" or f.parent != Path("."):
            assert (one / f).read_bytes() == (merged / f).read_bytes(), f
    assert meta(tmp_path / "one") == meta(out)


def test_a_split_without_enough_bands_is_refused_before_any_task(client, tprf_bin, tmp_path):
    with pytest.raises(ValueError, match="fewer than the 16 shards"):
        dist.render_sharded("builtin:cornell", str(tmp_path / "x"), 16, client=client,
                                 binary=tprf_bin, **ARGS)


def _worker_pids(client):
    return set(client.run(os.getpid).values())


def test_a_worker_killed_mid_shard_is_retried_and_the_cube_is_still_exact(
        client, tprf_bin, tmp_path):
    one_process(tprf_bin, tmp_path / "one", ARGS)
    workers = _worker_pids(client)
    killed = []

    def kill_a_worker_running_tprf():
        # The first worker seen running a tprf shard is killed (SIGKILL: no clean-up).
        deadline = time.time() + 60
        while time.time() < deadline and not killed:
            for pid in workers:
                try:
                    children = psutil.Process(pid).children(recursive=True)
                except psutil.NoSuchProcess:
                    continue
                if any("--shard" in " ".join(c.cmdline()) for c in children
                       if c.is_running()):
                    os.kill(pid, signal.SIGKILL)
                    killed.append(pid)
                    return
            time.sleep(0.01)

    killer = threading.Thread(target=kill_a_worker_running_tprf)
    killer.start()
    out = dist.render_sharded("builtin:cornell", str(tmp_path / "merged"), 4,
                                   client=client, binary=tprf_bin, retries=2, **ARGS)
    killer.join()
    assert killed, "no worker was seen running a shard"
    assert killed[0] not in _worker_pids(client), "the killed worker is still there"
    assert_same_cube(tmp_path / "one", out)


def test_batch_runs_then_resumes(client, tprf_bin, tmp_path):
    manifest = tmp_path / "batch.toml"
    manifest.write_text(
        """
[defaults]
width = 16
height = 12
spp = 4
bins = 16

[[sweep]]
scenes = ["builtin:cornell"]
out = "out/{scene}-{settings}"
settings = [{ name = "a", seed = 1 }, { name = "b", seed = 2 }]

[[job]]
name = "broken"
scene = "builtin:nosuchscene"
out = "out/broken"
"""
    )
    with pytest.raises(dist.BatchFailed) as failed:
        dist.run_batch(str(manifest), client=client, binary=tprf_bin, retries=0)
    r = failed.value.result
    assert sorted(r.done) == ["cornell-a", "cornell-b"]
    assert list(r.failed) == ["broken"] and "nosuchscene" in r.failed["broken"]
    for name in ("cornell-a", "cornell-b"):
        assert (tmp_path / "out" / name / "tprf.npy").exists()
    # Re-run without the broken job: all complete, nothing rendered.
    manifest.write_text(manifest.read_text().split("[[job]]")[0])
    r = dist.run_batch(str(manifest), client=client, binary=tprf_bin)
    assert r.done == [] and sorted(r.skipped) == ["cornell-a", "cornell-b"]
