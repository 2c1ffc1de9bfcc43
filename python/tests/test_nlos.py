"""tprf.nlos: captures and reconstructions from Python against the geometry of the
built-in NLOS scene (tal's Z, 1 m in front of a 2 m x 2 m relay wall in the plane z = 0),
and against the files tprf nlos writes."""

import os
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

import tprf

# tal's Z (its examples/render/meshes/Z.obj): six triangles in the plane z = 1 m, the
# outline the builtin:nlos-z scene is documented to hold (metres).
Z_DEPTH_M = 1.0
Z_TRIANGLES = [
    [(0.364878, 0.296774), (-0.4, 0.4), (0.364878, 0.4)],
    [(0.364878, 0.296774), (-0.164553, 0.296774), (-0.4, 0.4)],
    [(-0.164553, 0.296774), (0.164553, -0.296774), (-0.4, 0.4)],
    [(0.4, -0.4), (0.164553, -0.296774), (-0.164553, 0.296774)],
    [(0.4, -0.4), (-0.4, -0.296774), (0.164553, -0.296774)],
    [(0.4, -0.4), (-0.4, -0.4), (-0.4, -0.296774)],
]


def _inside(p, tri):
    """Whether the 2-D point p lies in the triangle (either winding)."""
    (ax, ay), (bx, by), (cx, cy) = tri
    d = [(bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax),
         (cx - bx) * (p[1] - by) - (cy - by) * (p[0] - bx),
         (ax - cx) * (p[1] - cy) - (ay - cy) * (p[0] - cx)]
    return all(v >= 0 for v in d) or all(v <= 0 for v in d)


def _z_distance(x, y):
    """The distance from the wall point (x, y, 0) to the Z, metres: its depth where the
    point faces the Z, else (over a fine sampling of the Z's outline) more."""
    if any(_inside((x, y), t) for t in Z_TRIANGLES):
        return Z_DEPTH_M
    best = np.inf
    for t in Z_TRIANGLES:
        for i in range(3):
            (ax, ay), (bx, by) = t[i], t[(i + 1) % 3]
            s = np.linspace(0.0, 1.0, 2001)
            px, py = ax + s * (bx - ax), ay + s * (by - ay)
            best = min(best, float(np.min(np.sqrt((px - x) ** 2 + (py - y) ** 2 + Z_DEPTH_M ** 2))))
    return best


@pytest.fixture(scope="module")
def confocal():
    return tprf.nlos.capture("builtin:nlos-z", grid=(8, 8), confocal=True, unwarped=True,
                             spp=256, dt="3mm", progress=False)


def test_a_confocal_capture_returns_first_at_twice_the_distance_to_the_z(confocal):
    c = confocal
    assert c.scan == "confocal" and not c.device_legs
    assert c.H.shape == (c.bins, 8, 8) and c.H.dtype == np.float32
    assert not c.H.flags.writeable
    g = c.sensor_grid
    assert g.shape == (8, 8, 3)
    assert np.all(g[:, :, 2] == 0.0) and np.all(np.abs(g[:, :, :2]) < 1.0)
    assert c.laser_grid.shape == (8, 8, 3) and np.array_equal(c.laser_grid, g)
    assert tuple(c.wall_normal) == (0.0, 0.0, 1.0)
    dt_m = c.dt_s * 299_792_458.0
    assert abs(dt_m - 0.003) < 1e-12 and c.t0_s == 0.0
    facing = 0
    for i in range(8):
        for j in range(8):
            x, y = float(g[i, j, 0]), float(g[i, j, 1])
            first = np.flatnonzero(c.H[:, i, j] > 0)
            # Unwarped and confocal: the light leaves the wall point and returns to it,
            # at the earliest after twice its distance to the Z.
            expected = int(np.floor(2.0 * _z_distance(x, y) / dt_m))
            assert first.size > 0, (i, j)
            assert first[0] >= expected - 1, (i, j, first[0], expected)
            if _z_distance(x, y) == Z_DEPTH_M:
                facing += 1
                # Facing the Z the nearest point's neighbourhood is wide: light arrives
                # in the bin of 2 m itself.
                assert first[0] <= expected + 1, (i, j, first[0], expected)
    assert facing >= 4


def test_the_capture_is_tprf_nlos_bit_for_bit(confocal, tprf_bin, tmp_path):
    out = tmp_path / "cli"
    subprocess.run([tprf_bin, "nlos", "builtin:nlos-z", "--grid", "8x8", "--confocal",
                    "--unwarped", "--spp", "256", "--dt", "3mm", "--out", str(out)],
                   check=True, capture_output=True)
    h = np.load(out / "H.npy")
    assert np.array_equal(h, confocal.H)
    saved = tmp_path / "saved"
    confocal.save(saved)
    assert (saved / "H.npy").read_bytes() == (out / "H.npy").read_bytes()
    assert (saved / "nlos.hdf5").read_bytes() == (out / "nlos.hdf5").read_bytes()
    assert confocal.metadata["request"]["grid"] == [8, 8]
    assert confocal.request["confocal"] is True


def test_the_reconstruction_peaks_at_the_z(confocal, tmp_path):
    # A volume 2 cm deep per voxel around the Z's depth.
    v = tprf.nlos.reconstruct(confocal, method="bp", center=(0, 0, 1.0), size=(1.2, 1.2, 0.6),
                              voxels=(12, 12, 30))
    assert v.values.shape == (30, 12, 12) and v.values.dtype == np.float32
    ax_u, ax_v, ax_n = v.axes
    assert len(ax_u) == 12 and len(ax_n) == 30
    assert abs(ax_n[1] - ax_n[0] - 0.02) < 1e-9
    px, py, pz = v.peak_m
    assert abs(pz - Z_DEPTH_M) <= 0.03, v.peak_m
    assert abs(px) <= 0.45 and abs(py) <= 0.45, v.peak_m
    # The brightest depth plane is the Z's.
    iz = int(np.argmax(v.values.max(axis=(1, 2))))
    assert abs(v.center[2] + ax_n[iz] - Z_DEPTH_M) <= 0.03
    # From the folder, the same volume.
    confocal.save(tmp_path / "cap")
    w = tprf.nlos.reconstruct(tmp_path / "cap", method="bp",
                              volume="0,0,1:1.2,1.2,0.6:12,12,30")
    assert np.array_equal(w.values, v.values)
    assert w.metadata["request"]["method"] == "bp"


def test_the_reconstruction_is_tprf_nlos_reconstructs(confocal, tprf_bin, tmp_path):
    confocal.save(tmp_path / "cap")
    out = tmp_path / "rec"
    subprocess.run([tprf_bin, "nlos", "reconstruct", str(tmp_path / "cap"), "--method", "fk",
                    "--out", str(out)], check=True, capture_output=True)
    v = tprf.nlos.reconstruct(confocal, method="fk")
    assert np.array_equal(np.load(out / "volume.npy"), v.values)


def test_bad_settings_name_the_setting():
    with pytest.raises(ValueError, match="grid 0x4: a grid needs"):
        tprf.nlos.capture("builtin:nlos-z", grid=(0, 4), progress=False)
    with pytest.raises(ValueError, match="dt"):
        tprf.nlos.capture("builtin:nlos-z", dt="5 furlongs", progress=False)
    with pytest.raises(ValueError, match="unknown method"):
        tprf.nlos.reconstruct("nowhere", method="xyz")
    with pytest.raises(TypeError, match="together"):
        tprf.nlos.reconstruct("nowhere", center=(0, 0, 1))


def test_ctrl_c_interrupts_a_capture_at_once():
    # Far more samples than a test has time for: only the interrupt ends it, and the
    # points running stop too (the next capture is not slowed by them).
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        tprf.nlos.capture("builtin:nlos-z", grid=(2, 2), spp=1 << 31, threads=2,
                          progress=False)
    timer.join()
    assert time.monotonic() - start < 30
    c = tprf.nlos.capture("builtin:nlos-z", grid=(2, 2), spp=8, progress=False)
    assert c.H.shape[1:] == (2, 2)
