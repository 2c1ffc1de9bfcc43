"""tprf.Differentiable and tprf.torch: gradients against what is known without them
(the cube is linear in a light's intensity: dL/dI = L / I), names refused with their
reasons, the inverse example converging."""

import re
import warnings
import subprocess
import sys

import numpy as np
import pytest

import tprf
from conftest import REPO

LIGHT = "light:ceiling point light.intensity"
WHITE = "material:white.albedo"


def _box(**kw):
    settings = dict(width=16, height=16, spp=32, bins=32, progress=False, threads=2)
    settings.update(kw)
    return tprf.Differentiable("builtin:cornell", wrt=[WHITE, LIGHT], **settings)


def test_intensity_gradient_is_the_cube_per_unit_intensity():
    d = _box()
    rng = np.random.default_rng(3)
    w = rng.uniform(0.5, 2.0, size=d.shape).astype(np.float32)
    i = d.values[LIGHT]
    per_unit, grads = [], []
    for seed in range(1, 5):
        cube = d.forward({WHITE: 0.6}, seed=seed)
        assert cube.data.shape == tuple(d.shape)
        per_unit.append(float(np.sum(w * cube.data)) / i)
        grads.append(d.backward(w, seed=100 + seed)[LIGHT])
    a, b = np.mean(per_unit), np.mean(grads)
    se = np.sqrt(np.var(per_unit, ddof=1) / 4 + np.var(grads, ddof=1) / 4)
    assert abs(a - b) < 4 * se + 0.01 * a, (a, b, se)
    assert d.values == {WHITE: 0.6, LIGHT: i}


def test_zero_albedo_still_has_a_gradient():
    d = _box()
    d.forward({WHITE: 0.0}, seed=1)
    g = d.backward(np.ones(d.shape, np.float32), seed=2)
    assert g[WHITE] > 0


def test_names_are_refused_with_their_reasons():
    with pytest.raises(ValueError, match=r"no material named \"wall\".*known: .*material:white\.albedo"):
        tprf.Differentiable("builtin:cornell", wrt=["material:wall.albedo"], width=4, height=4,
                            spp=1, bins=4, progress=False)
    with pytest.raises(ValueError, match="edge sampling"):
        tprf.Differentiable("builtin:cornell", wrt=["camera.position"], width=4, height=4,
                            spp=1, bins=4, progress=False)


def test_bad_calls_say_what_is_wrong():
    d = _box(width=4, height=4, spp=2, bins=8)
    with pytest.raises(RuntimeError, match="forward"):
        d.backward(np.ones(d.shape, np.float32))
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        d.forward({WHITE: 1.5})
    d.forward({})
    with pytest.raises(ValueError, match="shape"):
        d.backward(np.ones((4, 4, 7), np.float32))


def test_torch_autograd_matches_backward():
    torch = pytest.importorskip("torch")
    import tprf.torch as tt

    d = _box(width=8, height=8, spp=8, bins=16)
    albedo = torch.tensor(0.5, dtype=torch.float64, requires_grad=True)
    light = torch.tensor(d.values[LIGHT], dtype=torch.float64, requires_grad=True)
    cube = tt.render(d, {WHITE: albedo, LIGHT: light}, seed=1, backward_seed=2)
    cube.sum().backward()
    d.forward({WHITE: 0.5}, seed=1)
    want = d.backward(np.ones(d.shape, np.float32), seed=2)
    assert albedo.grad.item() == pytest.approx(want[WHITE], rel=1e-9)
    assert light.grad.item() == pytest.approx(want[LIGHT], rel=1e-9)


def test_inverse_example_recovers_the_albedos(tmp_path):
    run = subprocess.run([sys.executable, str(REPO / "python" / "examples" / "inverse_albedo.py"), "--out",
                          str(tmp_path), "--size", "32", "--spp", "16", "--steps", "40"],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    errors = [float(e) for e in re.findall(r"error ([0-9.]+) %", run.stdout)]
    assert len(errors) == 2 and max(errors) < 2.0, run.stdout
    history = np.loadtxt(tmp_path / "history.csv", delimiter=",")
    assert history[-1, 1] < 0.3 * history[0, 1]


def test_sensor_measure_vjp_against_the_measurement():
    cube = tprf.render("builtin:cornell", width=8, height=8, spp=8, bins=64, dt="100ps",
                       progress=False)
    s = tprf.Sensor.preset("builtin:lidar")
    s.exposure = "box:start=3ns,width=0.4ns,count=24"
    s.light.fwhm_s = 1e-9
    s.light.centre_s = 0.6e-9

    def loss(sensor, w):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = sensor.measure(cube, noise_sigma=0, photons_per_energy=0)
        return float(np.sum(w.astype(np.float64) * m.images))

    rng = np.random.default_rng(5)
    w = rng.uniform(0.1, 1.0, size=(24, 8, 8)).astype(np.float32)
    grads, d_cube = s.measure_vjp(cube, w, ["light.centre_s", "light.fwhm_s", "light.energy"])
    assert d_cube.shape == cube.data.shape
    l = loss(s, w)
    # The measurement is linear in the cube and in the energy.
    assert np.sum(d_cube.astype(np.float64) * cube.data) == pytest.approx(l, rel=1e-5)
    assert grads["light.energy"] == pytest.approx(l, rel=1e-6)
    # Central differences of Sensor.measure (float32 images: a step of 10 ps).
    for name, value in [("centre_s", 0.6e-9), ("fwhm_s", 1e-9)]:
        step = 1e-11
        setattr(s.light, name, value + step)
        up = loss(s, w)
        setattr(s.light, name, value - step)
        down = loss(s, w)
        setattr(s.light, name, value)
        fd = (up - down) / (2 * step)
        assert grads[f"light.{name}"] == pytest.approx(fd, rel=2e-3), name
    with pytest.raises(ValueError, match="noise.sigma"):
        s.measure_vjp(cube, w, ["noise.sigma"])
