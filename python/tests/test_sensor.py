"""tprf.Sensor and tprf.Measurement against tprf sensor's own files (every array bit for
bit), against a measurement computed here in numpy, and the core's messages as Python
exceptions."""

import json
import subprocess
import threading
import time

import numpy as np
import pytest

import tprf

# A small render with bounce layers (the AMCW reference depth comes from the
# single-scattering layer) and a sky (an ambient image the gates add).
RENDER = ["--width", "12", "--height", "8", "--spp", "4", "--bins", "96", "--seed", "3",
          "--bounces-separate", "2", "--sky", "0.25"]

# tprf sensor's .npy files and the Measurement's attribute holding each.
ARRAYS = {
    "sensor.npy": "images", "depth.npy": "depth", "amcw_phase.npy": "amcw_phase",
    "amcw_amplitude.npy": "amcw_amplitude", "amcw_depth.npy": "amcw_depth",
    "true_depth.npy": "true_depth", "multipath_error.npy": "multipath_error",
    "spad_histogram.npy": "spad_histogram", "spad_counts.npy": "spad_counts",
    "spad_coates.npy": "spad_coates", "spad_depth_histogram.npy": "spad_depth_histogram",
    "spad_depth_counts.npy": "spad_depth_counts", "spad_depth_coates.npy": "spad_depth_coates",
    "depth_strongest.npy": "depth_strongest", "depth_last.npy": "depth_last",
    "depth_returns.npy": "depth_returns", "return_intensity.npy": "return_intensity",
    "return_count.npy": "return_count",
}


def same_bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.fixture(scope="module")
def render_dir(tprf_bin, tmp_path_factory):
    out = tmp_path_factory.mktemp("render") / "cube"
    subprocess.run([tprf_bin, "render", "builtin:cornell", "--out", str(out), *RENDER],
                   check=True, capture_output=True)
    return out


def without_timings(meta):
    """sensor.json less what depends on when and where it was run."""
    meta = json.loads(json.dumps(meta))
    meta.pop("seconds")
    meta["cube"].pop("dir")
    spad = meta["derived"].get("spad")
    if spad:
        spad.pop("seconds")
        spad.pop("bands")
    return meta


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("preset, flags, kwargs", [
    ("gated", ["--noise-sigma", "1e-13", "--photons-per-energy", "1e14", "--seed", "9",
               "--pixel", "3,4"],
     dict(noise_sigma=1e-13, photons_per_energy=1e14, seed=9, pixels=[(3, 4)])),
    ("lidar", [], {}),
    ("amcw", ["--ambient-exposure", "2ms"], dict(ambient_exposure="2ms")),
    ("spad", ["--seed", "7", "--cycles", "500"], dict(seed=7, cycles=500)),
])
def test_measure_is_tprf_sensor_bit_for_bit(tprf_bin, render_dir, tmp_path, preset, flags,
                                            kwargs):
    cli = tmp_path / "cli"
    run = subprocess.run([tprf_bin, "sensor", str(render_dir), "--preset",
                          f"builtin:{preset}", "--out", str(cli), *flags],
                         check=True, capture_output=True, text=True)
    sensor = tprf.Sensor.preset(f"builtin:{preset}")
    m = sensor.measure(tprf.load(render_dir), **kwargs)
    # tprf sensor's notes are the measurement's (and were warnings).
    notes = [line[len("note: "):] for line in run.stderr.splitlines()
             if line.startswith("note: ")]
    assert m.notes == notes
    written = sorted(p.name for p in cli.iterdir())
    npys = [n for n in written if n.endswith(".npy")]
    assert "sensor.npy" in npys
    # Every array in memory is tprf sensor's file, bit for bit.
    for name in npys:
        assert same_bits(getattr(m, ARRAYS[name]), np.load(cli / name)), name
    for name in set(ARRAYS) - set(npys):
        assert getattr(m, ARRAYS[name]) is None, name
    if preset == "lidar":
        # Multi-echo's first return is the first-return depth image.
        assert same_bits(m.depth_returns[0], m.depth)
        assert m.depth_returns.shape[0] == 3 and m.return_count.dtype == np.uint16
    # Read-only arrays lent by the measurement: no copy per access.
    assert m.images.flags.writeable is False
    assert np.shares_memory(m.images, m.images)
    assert m.shape == np.load(cli / "sensor.npy").shape
    # save writes the same folder: the same files, the same bytes (but sensor.json's
    # timings and the cube's name).
    m.save(tmp_path / "py")
    assert sorted(p.name for p in (tmp_path / "py").iterdir()) == written
    for name in written:
        if name != "sensor.json":
            assert (tmp_path / "py" / name).read_bytes() == (cli / name).read_bytes(), name
    meta = [json.loads((d / "sensor.json").read_text()) for d in (cli, tmp_path / "py")]
    assert without_timings(meta[0]) == without_timings(meta[1])
    # A render folder read as tprf sensor reads it, a tile at a time: the same numbers,
    # and the folder named in sensor.json.
    from_dir = sensor.measure(render_dir, **kwargs)
    assert same_bits(from_dir.images, m.images)
    from_dir.save(tmp_path / "py_dir")
    saved = json.loads((tmp_path / "py_dir" / "sensor.json").read_text())
    assert saved["cube"]["dir"] == meta[0]["cube"]["dir"]


def test_a_box_gate_sums_the_cube_over_its_opening():
    """A unit delta pulse at t = 0 and box gates of gain g over [s + i w, s + (i + 1) w):
    K_i(tau) = Exposure_i(tau), so M_i = g sum_b cube[b] |bin b n gate i| / dt (a bin's
    value spread evenly over it), computed here in numpy from cube.data. The gate edges
    fall inside bins."""
    cube = tprf.render("builtin:cornell", width=10, height=6, spp=4, bins=80, t0="3ns",
                       dt="80ps", seed=2, progress=False)
    start_s, width_s, count, gain = 4.03e-9, 0.47e-9, 9, 0.8
    sensor = tprf.Sensor(f"box:start={start_s * 1e9}ns,width={width_s * 1e9}ns,"
                         f"count={count},gain={gain}")
    m = sensor.measure(cube)
    edges = cube.t0_s + cube.dt_s * np.arange(cube.shape[2] + 1)
    data = cube.data.astype(np.float64)
    for i in range(count):
        lo, hi = start_s + i * width_s, start_s + (i + 1) * width_s
        overlap = np.clip(np.minimum(edges[1:], hi) - np.maximum(edges[:-1], lo), 0, None)
        want = gain * (data * (overlap / cube.dt_s)).sum(axis=2)
        assert want.max() > 0
        np.testing.assert_allclose(m.images[i], want, rtol=1e-5, atol=1e-7 * want.max())
        assert m.gate_centres_s[i] == pytest.approx(0.5 * (lo + hi), rel=1e-12)
    # No noise, no ambient image: the gates are the clean measurement.
    assert same_bits(m.images, m.clean)


def test_fields_are_attributes_and_bad_values_name_the_field(tmp_path):
    s = tprf.Sensor.preset("builtin:lidar")
    assert s.light.kind == "gaussian" and s.exposure.kind == "box"
    keys = [f["key"] for f in s.light.fields]
    assert keys == ["centre_s", "fwhm_s", "energy"]
    assert {f["key"]: f["unit"] for f in s.light.fields}["fwhm_s"] == "s"
    s.light.fwhm_s = "1.5ns"
    assert s.light.fwhm_s == pytest.approx(1.5e-9)
    s.exposure.count = 64
    assert s.exposure.count == 64 and isinstance(s.exposure.count, int)
    s.noise.sigma = 0.5
    s.seed = 2**63 + 5
    assert s.seed == 2**63 + 5
    # Refused values leave the sensor as it was.
    before = s.to_toml()
    with pytest.raises(ValueError, match="exposure.count"):
        s.exposure.count = 0
    with pytest.raises(ValueError, match="exposure.count .* whole"):
        s.exposure.count = 2.5
    with pytest.raises(ValueError, match="light.fwhm_s"):
        s.light.fwhm_s = "-1ns"
    with pytest.raises(ValueError, match="light.fwhm_s"):
        s.light.fwhm_s = "two ns"
    # In the field's range, refused by the sensor's own checks: gates of no width all
    # share one centre, which the return detector cannot read.
    with pytest.raises(ValueError, match="derived.returns needs at least two gates"):
        s.exposure.width_s = 0
    with pytest.raises(AttributeError, match="centre_s, fwhm_s, energy"):
        s.light.fwhm = 1e-9
    assert s.to_toml() == before
    # The TOML written is read back as the same sensor, by tprf and by Sensor.from_toml.
    (tmp_path / "mine.toml").write_text(s.to_toml())
    assert tprf.Sensor.from_toml(tmp_path / "mine.toml") == s
    assert tprf.Sensor.preset(str(tmp_path / "mine.toml")) == s
    # New pulses and gates as tprf sensor's --light and --exposure take them.
    s.light = "rect:start=1ns,width=2ns"
    assert s.light.kind == "rect" and s.light.width_s == pytest.approx(2e-9)
    with pytest.warns(UserWarning, match="derived"):
        s.exposure = "amcw:freq=20MHz,phase_steps=4"
    assert s.exposure.freq_hz == 20e6
    t = s.copy()
    t.exposure.phase_steps = 8
    assert s.exposure.phase_steps == 4
    assert "rect" in repr(s) and "amcw" in repr(s.exposure)
    free = tprf.Sensor("piecewise_linear:step=1ns,count=4,points=0ns:0;1ns:1;2ns:0")
    assert free.exposure.knots == [(0.0, 0.0), (pytest.approx(1e-9), 1.0),
                                   (pytest.approx(2e-9), 0.0)]
    free.exposure.knots = [(0, 0), (1e-9, 1), (3e-9, 0)]
    assert len(free.exposure.knots) == 3
    assert tprf.Sensor.preset("builtin:spad").spad.cycles > 0
    assert s.spad is None
    assert set(tprf.Sensor.PRESETS) >= {"builtin:gated", "builtin:lidar", "builtin:amcw",
                                        "builtin:spad"}


def test_errors_carry_the_cores_messages(render_dir, tmp_path):
    with pytest.raises(ValueError, match="no built-in sensor preset 'nope'.*lidar"):
        tprf.Sensor.preset("builtin:nope")
    with pytest.raises(ValueError, match="cannot read sensor file"):
        tprf.Sensor.from_toml(tmp_path / "missing.toml")
    with pytest.raises(ValueError, match="exposure.width_s = .*>= 0"):
        tprf.Sensor("box:width=-1ns")
    with pytest.raises(ValueError, match="cycles needs a sensor with a SPAD"):
        tprf.Sensor.preset("builtin:gated").measure(render_dir, cycles=5)
    with pytest.raises(ValueError, match="ambient_scale"):
        tprf.Sensor.preset("builtin:gated").measure(render_dir, ambient_scale=-1)
    with pytest.raises(FileNotFoundError, match="tprf.json"):
        tprf.Sensor.preset("builtin:gated").measure(tmp_path / "nothing")
    with pytest.raises(TypeError, match="tprf.Cube or the path"):
        tprf.Sensor.preset("builtin:gated").measure(np.zeros((2, 2, 2)))
    with pytest.warns(UserWarning, match="4 of 8 gates see no light"):
        m = tprf.Sensor.preset("builtin:gated").measure(render_dir)
    # A folder of the user's is refused and left as it was; so is the cube's own.
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("x")
    with pytest.raises(ValueError, match="notes.txt"):
        m.save(tmp_path / "mine")
    assert (tmp_path / "mine" / "notes.txt").read_text() == "x"
    with pytest.raises(ValueError):
        m.save(render_dir)
    assert (render_dir / "tprf.npy").exists()


def test_the_gil_is_released_while_measuring():
    cube = tprf.render("builtin:cornell", width=64, height=64, spp=1, bins=2048,
                       progress=False)
    sensor = tprf.Sensor("gaussian:centre=0ns,fwhm=30ps,step=5ps,count=4096")
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    try:
        with pytest.warns(UserWarning, match="see no light"):
            sensor.measure(cube)  # 4096 gates of 64 x 64 pixels: 0.4 s here
    finally:
        stop.set()
        t.join()
    # A thread that needs the GIL every millisecond ran throughout the measurement.
    assert len(ticks) > 20
