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


def test_phasors_are_the_files_and_a_dft_of_the_cube(tprf_bin, tmp_path):
    # A band whose frequencies fall inside the window's 32 bins.
    render(tprf_bin, tmp_path / "p", "--phasor", "0.5:1")
    cube = tprf.load(tmp_path / "p")
    file = np.load(tmp_path / "p" / "phasor.npy")
    meta = json.loads((tmp_path / "p" / "tprf.json").read_text())["phasor"]
    assert cube.phasor.shape == file.shape == (8, 12, len(meta["frequencies_per_m"]), 2)
    np.testing.assert_allclose(cube.phasor, file, rtol=1e-5, atol=1e-7 * np.abs(file).max())
    # Worked out here from the cube: each bin at its centre's phase (from the window's
    # start) times sinc(f dt), the exact integral of a bin of uniform light.
    dt = meta["bin_width_opl_m"]
    t = (np.arange(cube.data.shape[2]) + 0.5) * dt
    for k, f in enumerate(meta["frequencies_per_m"]):
        w = np.exp(-2j * np.pi * f * t) * np.sinc(f * dt)
        want = (cube.data.astype(np.float64) * w).sum(axis=2)
        got = cube.phasor[:, :, k, 0] + 1j * cube.phasor[:, :, k, 1]
        assert np.abs(got - want).max() <= 1e-5 * np.abs(want).max() + 1e-9
    render(tprf_bin, tmp_path / "none")
    assert tprf.load(tmp_path / "none").phasor is None


def test_errors_are_python_exceptions_with_the_core_message(tmp_path):
    with pytest.raises(FileNotFoundError, match="tprf.json"):
        tprf.load(tmp_path / "nothing")
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "tprf.json").write_text("{not json")
    (tmp_path / "bad" / "tprf.npy").write_bytes(b"\x93NUMPY")
    with pytest.raises(ValueError):
        tprf.load(tmp_path / "bad")
