"""Fixtures: the tprf binary built by cargo, and a local Dask cluster of two worker
processes with one thread each."""

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _binary():
    candidates = [os.environ.get("TPRF_BIN")]
    target = os.environ.get("CARGO_TARGET_DIR")
    if target:
        candidates.append(str(Path(target) / "release" / "tprf"))
    candidates.append(str(REPO / "target" / "release" / "tprf"))
    for c in candidates:
        if c and os.access(c, os.X_OK):
            return c
    return None


@pytest.fixture(scope="session")
def tprf_bin():
    b = _binary()
    if b is None:
        pytest.fail("no tprf binary: run cargo build --release or set TPRF_BIN")
    return b


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
    ) as cluster, Client(cluster) as c:
        yield c
