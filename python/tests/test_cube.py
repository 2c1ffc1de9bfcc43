"""tprf.load against the files tprf render writes: the same numbers, no copies, and the
core's messages as Python exceptions."""

import json
import subprocess

import numpy as np
import pytest

import tprf


def render(tprf_bin, out, *flags):
    subprocess.run([tprf_bin, "render", "builtin:cornell", "--out", str(out), "--width", "12",
                    "--height", "8", "--spp", "4", "--bins", "32", *flags],
                   check=True, capture_output=True)


def test_a_loaded_cube_is_the_rendered_files_bit_for_bit(tprf_bin, tmp_path):
    render(tprf_bin, tmp_path / "c", "--bounces-separate", "2")
    cube = tprf.load(tmp_path / "c")
    npy = np.load(tmp_path / "c" / "tprf.npy")
    assert cube.data.dtype == np.float32 and cube.data.shape == (8, 12, 32) == cube.shape
    assert np.array_equal(cube.data, npy)
    assert np.array_equal(cube.bounces, np.load(tmp_path / "c" / "tprf_bounces.npy"))
    # The layers add up to the cube; the steady image is the sum over time.
    assert np.allclose(cube.bounces.sum(axis=0), npy, rtol=1e-5, atol=1e-7)
    assert np.allclose(cube.steady, npy.sum(axis=2, dtype=np.float64), rtol=1e-5, atol=1e-7)
    meta = json.loads((tmp_path / "c" / "tprf.json").read_text())
    assert cube.metadata == meta
    assert cube.t0_s == meta["t0_s"] and cube.dt_s == meta["dt_s"]
    assert np.allclose(cube.times_s, meta["t0_s"] + (np.arange(32) + 0.5) * meta["dt_s"])
    assert cube.error_estimate == meta["error_estimate"]


def test_data_is_one_array_not_a_copy_per_access(tprf_bin, tmp_path):
    render(tprf_bin, tmp_path / "c")
    cube = tprf.load(tmp_path / "c")
    a, b = cube.data, np.asarray(cube)
    assert np.shares_memory(a, b) and np.shares_memory(a, cube.data)
    assert not np.shares_memory(a, np.asarray(cube, dtype=np.float64))


def test_a_zarr_cube_loads_as_the_npy_one(tprf_bin, tmp_path):
    render(tprf_bin, tmp_path / "n", "--format", "npy")
    render(tprf_bin, tmp_path / "z", "--format", "zarr")
    assert np.array_equal(tprf.load(tmp_path / "n").data, tprf.load(tmp_path / "z").data)


def test_errors_are_python_exceptions_with_the_core_message(tmp_path):
    with pytest.raises(FileNotFoundError, match="tprf.json"):
        tprf.load(tmp_path / "nothing")
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "tprf.json").write_text("{not json")
    (tmp_path / "bad" / "tprf.npy").write_bytes(b"\x93NUMPY")
    with pytest.raises(ValueError):
        tprf.load(tmp_path / "bad")
