"""Run tprf renders on a Dask.distributed cluster.

The ``tprf`` binary does the work; this package only schedules it. A task runs
``tprf render --shard K/N`` (or ``tprf batch MANIFEST --only JOB``) as a subprocess
on a worker, into a folder of its own, and renames the result into place, so a retried
task never sees half of a shard. Dask retries a task that failed or whose worker was
lost; ``tprf merge`` puts the shards together into the cube one process would have
written, bit for bit.

Every worker must see the same file system at the same paths (NFS or Lustre on a
Slurm cluster, a ReadWriteMany volume on Kubernetes): shards are written there and
merged from there. See docs/distributed.md.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import signal
import subprocess
import sys
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional, Sequence

__all__ = [
    "BatchFailed",
    "BatchResult",
    "TprfError",
    "find_tprf",
    "list_jobs",
    "merge_shards",
    "render_args_to_flags",
    "render_shard",
    "render_sharded",
    "run_batch",
    "run_batch_job",
]

__version__ = "0.1.0"


class TprfError(RuntimeError):
    """The tprf binary exited with an error; the message is its stderr's last lines."""


class BatchFailed(RuntimeError):
    """Some jobs of a batch failed (the others ran); ``result`` says which."""

    def __init__(self, result: "BatchResult"):
        self.result = result
        failed = ", ".join(f"{k}: {v}" for k, v in result.failed.items())
        super().__init__(f"{len(result.failed)} job(s) failed: {failed}")


@dataclass
class BatchResult:
    """What :func:`run_batch` did, by job name."""

    done: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    failed: dict = field(default_factory=dict)


def find_tprf(binary: Optional[str] = None) -> str:
    """The tprf binary: ``binary``, else ``$TPRF_BIN``, else ``tprf`` on the PATH."""
    for candidate in (binary, os.environ.get("TPRF_BIN"), shutil.which("tprf")):
        if candidate and os.access(candidate, os.X_OK):
            return str(Path(candidate).resolve())
    raise TprfError(
        "the tprf binary was not found: pass binary=..., set TPRF_BIN, or put tprf on "
        "the PATH (cargo build --release makes target/release/tprf)"
    )


def _die_with_parent() -> None:
    """In the child, before exec: be killed when the worker that started it dies
    (Linux), so a lost worker leaves no render running."""
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        PR_SET_PDEATHSIG = 1
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except OSError:
        pass


def _run(argv: Sequence[str]) -> str:
    """Run tprf; its stderr, or :class:`TprfError` with its last lines."""
    preexec = _die_with_parent if sys.platform.startswith("linux") else None
    proc = subprocess.run(
        list(argv),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=preexec,
    )
    if proc.returncode != 0:
        tail = "\n".join(proc.stderr.strip().splitlines()[-5:])
        raise TprfError(f"{' '.join(argv[:3])} ... exited {proc.returncode}: {tail}")
    return proc.stderr + proc.stdout


def render_args_to_flags(render_args: dict) -> list:
    """``{"width": 64, "t0": "3m", "bounces_separate": 2}`` as ``tprf render`` flags
    (``--width 64 --t0 3m --bounces-separate 2``); ``True`` gives a bare flag."""
    flags = []
    for key, value in render_args.items():
        if value is None or value is False:
            continue
        name = "--" + key.replace("_", "-")
        if key in ("shard", "out", "seconds", "frames"):
            raise ValueError(
                f"{key}= cannot be given to a sharded render: "
                + {
                    "shard": "the shards are made by render_sharded",
                    "out": "give out as render_sharded's second argument",
                    "seconds": "a time budget gives each shard other passes; give spp",
                    "frames": "frames are not written by shards",
                }[key]
            )
        flags.append(name)
        if value is not True:
            flags.append(str(value))
    return flags


def _is_shard(folder: Path, k: int, n: int) -> bool:
    import json

    try:
        meta = json.loads((folder / "tprf.json").read_text())
    except (OSError, ValueError):
        return False
    shard = meta.get("shard") or {}
    return shard.get("k") == k and shard.get("n") == n


def render_shard(
    binary: str, scene: str, parts: str, k: int, n: int, flags: Sequence[str]
) -> str:
    """Task: render shard ``k`` of ``n`` into ``parts/shard-K-of-N`` and return that
    path. The render goes into a folder of this attempt's own and is renamed into
    place whole; a shard already in place (an earlier attempt that finished, whose
    worker was lost afterwards) is kept: shards are deterministic."""
    parts_dir = Path(parts)
    parts_dir.mkdir(parents=True, exist_ok=True)
    final = parts_dir / f"shard-{k}-of-{n}"
    if _is_shard(final, k, n):
        return str(final)
    attempt = parts_dir / f".shard-{k}-of-{n}.attempt-{os.getpid()}-{uuid.uuid4().hex}"
    try:
        uniform = [] if "--uniform" in flags else ["--uniform"]
        _run([binary, "render", scene, "--out", str(attempt / "cube"), *uniform,
              "--shard", f"{k}/{n}", *flags])
        try:
            os.rename(attempt / "cube", final)
        except OSError:
            # Another attempt put its (identical) shard there first.
            if not _is_shard(final, k, n):
                raise
    finally:
        shutil.rmtree(attempt, ignore_errors=True)
    return str(final)


def merge_shards(binary: str, out: str, shard_dirs: Sequence[str]) -> str:
    """Task: ``tprf merge OUT SHARD_DIRS...``; returns ``out``."""
    _run([binary, "merge", str(out), *map(str, shard_dirs)])
    return str(out)


def render_sharded(
    scene: str,
    out: str,
    n_shards: int,
    *,
    client: Any,
    binary: Optional[str] = None,
    retries: int = 3,
    parts: Optional[str] = None,
    keep_shards: bool = False,
    **render_args: Any,
) -> str:
    """Render ``scene`` into the cube folder ``out`` as ``n_shards`` Dask tasks, then
    merge them (a task as well). ``render_args`` are ``tprf render``'s options
    (``width=512, spp=1024, bins=512, format="zarr", threads=8, band_rows=32``...).
    A failed task, or one whose worker is lost, is retried up to ``retries`` times.
    Shards go to ``parts`` (default ``OUT.parts``, beside ``out``; it must be on a file
    system every worker sees) and are removed after the merge unless ``keep_shards``.
    Returns ``out``; raises the task's error (a :class:`TprfError`) if it kept failing.
    Shards sample uniformly (``--uniform``: adaptive sampling needs the whole image's
    noise), so the cube is the one ``tprf render --uniform`` writes.
    """
    if n_shards < 1:
        raise ValueError(f"n_shards must be at least 1 (got {n_shards})")
    # Refused here rather than by every task (each retried): too few bands.
    height = int(render_args.get("height", 256))
    band_rows = int(render_args.get("band_rows", 32))
    bands = -(-height // max(band_rows, 1))
    if bands < n_shards:
        raise ValueError(
            f"{height} rows in bands of {band_rows} make {bands} band(s), fewer than the "
            f"{n_shards} shards: use fewer shards or a smaller band_rows"
        )
    binary = find_tprf(binary)
    flags = render_args_to_flags(render_args)
    if not scene.startswith("builtin:"):
        # Workers may run in another folder: the scene by its absolute path.
        scene = str(Path(scene).resolve())
    out_path = Path(out).resolve()
    parts_dir = Path(parts).resolve() if parts else out_path.with_name(out_path.name + ".parts")
    run_id = uuid.uuid4().hex[:8]
    futures = [
        client.submit(
            render_shard, binary, scene, str(parts_dir), k, n_shards, flags,
            key=f"tprf-shard-{k}-of-{n_shards}-{run_id}", retries=retries, pure=False,
        )
        for k in range(n_shards)
    ]
    merged = client.submit(
        merge_shards, binary, str(out_path), futures,
        key=f"tprf-merge-{run_id}", retries=retries, pure=False,
    )
    result = merged.result()
    if not keep_shards:
        _remove_shards(parts_dir, n_shards)
    return result


def _remove_shards(parts_dir: Path, n: int) -> None:
    """Remove the shard folders of an ``n``-shard render from ``parts_dir`` (each one
    recognised by its ``tprf.json``), then ``parts_dir`` itself if nothing else is in
    it: what tprf did not write there (``parts`` may name a user's folder) is kept."""
    for k in range(n):
        shard = parts_dir / f"shard-{k}-of-{n}"
        if _is_shard(shard, k, n) and not shard.is_symlink():
            shutil.rmtree(shard, ignore_errors=True)
    try:
        parts_dir.rmdir()
    except OSError:
        pass


def list_jobs(manifest: str, binary: Optional[str] = None) -> list:
    """The jobs of a batch manifest: ``(name, state, out)``, state ``complete`` or
    ``to do`` (``tprf batch MANIFEST --list``)."""
    text = _run([find_tprf(binary), "batch", str(manifest), "--list"])
    jobs = []
    for line in text.splitlines():
        parts = line.split("\t")
        if len(parts) == 3:
            jobs.append((parts[0], parts[1], parts[2]))
    return jobs


def run_batch_job(binary: str, manifest: str, name: str, threads: Optional[int]) -> str:
    """Task: one job of a manifest (``tprf batch MANIFEST --only NAME``); its output
    is swapped in whole by tprf, so a retried job never sees half of one."""
    argv = [binary, "batch", str(manifest), "--only", name]
    if threads:
        argv += ["--threads", str(threads)]
    _run(argv)
    return name


def run_batch(
    manifest: str,
    *,
    client: Any,
    binary: Optional[str] = None,
    retries: int = 3,
    threads: Optional[int] = None,
) -> BatchResult:
    """Run every job of a ``tprf batch`` manifest as a Dask task (jobs whose output is
    complete are skipped, so a re-run resumes). A job's failure is reported and the
    others go on; raises :class:`BatchFailed` at the end if any failed."""
    from distributed import wait

    binary = find_tprf(binary)
    manifest = str(Path(manifest).resolve())
    result = BatchResult()
    futures = {}
    run_id = uuid.uuid4().hex[:8]
    for name, state, _out in list_jobs(manifest, binary):
        if state == "complete":
            result.skipped.append(name)
            continue
        futures[name] = client.submit(
            run_batch_job, binary, manifest, name, threads,
            key=f"tprf-job-{name}-{run_id}", retries=retries, pure=False,
        )
    wait(list(futures.values()))
    for name, fut in futures.items():
        if fut.status == "finished":
            result.done.append(name)
        else:
            try:
                fut.result()
            except Exception as e:  # noqa: BLE001 - reported per job
                result.failed[name] = str(e)
    if result.failed:
        raise BatchFailed(result)
    return result
