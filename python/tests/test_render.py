"""tprf.render and tprf.Renderer against tprf render's own files: the same numbers bit
for bit, the core's messages as Python exceptions, Ctrl-C, the GIL released."""

import json
import os
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

import tprf

SETTINGS = dict(width=12, height=8, spp=6, bins=32, seed=3, bounces_separate=2)
# The same settings as tprf render's flags.
FLAGS = ["--width", "12", "--height", "8", "--spp", "6", "--bins", "32", "--seed", "3",
         "--bounces-separate", "2"]
# tprf.json's fields that say what was rendered (not how long it took or where).
SAME = ["t0_s", "dt_s", "bins", "width", "height", "spp", "seed", "channel", "value",
        "scene", "camera", "max_bounces", "bounces_separate", "paths_traced", "rays_traced",
        "first_bounce_splits", "light_vertex", "adaptive", "error_estimate", "passes",
        "left_out", "store", "notes", "shard", "ambient"]


def cli_render(tprf_bin, out, *flags, scene="builtin:cornell"):
    subprocess.run([tprf_bin, "render", scene, "--out", str(out), *flags], check=True,
                   capture_output=True)
    return json.loads((out / "tprf.json").read_text())


def test_render_is_tprf_render_bit_for_bit(tprf_bin, tmp_path):
    meta = cli_render(tprf_bin, tmp_path / "cli", *FLAGS)
    cube = tprf.render("builtin:cornell", progress=False, **SETTINGS)
    assert np.array_equal(cube.data, np.load(tmp_path / "cli" / "tprf.npy"))
    assert np.array_equal(cube.bounces, np.load(tmp_path / "cli" / "tprf_bounces.npy"))
    for key in SAME:
        assert cube.metadata.get(key) == meta.get(key), key
    assert cube.data.flags.writeable is False
    # Unit strings as the command line takes them, and a scene with an ambient image.
    meta = cli_render(tprf_bin, tmp_path / "sky", "--width", "10", "--height", "6", "--spp",
                      "2", "--bins", "16", "--t0", "3ns", "--dt", "0.1m", "--sky", "0.5")
    cube = tprf.render("builtin:cornell", width=10, height=6, spp=2, bins=16, t0="3ns",
                       dt="0.1m", sky=0.5, progress=False)
    assert np.array_equal(cube.data, np.load(tmp_path / "sky" / "tprf.npy"))
    assert np.array_equal(cube.ambient, np.load(tmp_path / "sky" / "ambient.npy"))
    assert cube.t0_s == meta["t0_s"] == pytest.approx(3e-9) and cube.dt_s == meta["dt_s"]
    # In memory the ambient image has no file yet.
    assert cube.metadata["ambient"] == dict(meta["ambient"], file="")
    for key in SAME:
        if key != "ambient":
            assert cube.metadata.get(key) == meta.get(key), key


# A Mitsuba scene whose film says every setting a file can: 6 x 4 pixels, 20 bins from
# 9 m of optical path counted from a near plane 0.5 m in front of the pinhole, bins of
# 0.1 m, 2 samples, depth 3 (2 scattering events).
FILM_XML = """<scene version="3.0.0">
    <integrator type="transient_path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <float name="near_clip" value="0.5"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="2"/></sampler>
        <film type="transient_hdr_film">
            <integer name="width" value="6"/>
            <integer name="height" value="4"/>
            <integer name="temporal_bins" value="20"/>
            <float name="start_opl" value="9"/>
            <float name="bin_width_opl" value="0.1"/>
        </film>
    </sensor>
    <emitter type="point"><point name="position" x="0" y="0" z="5"/><rgb name="intensity" value="1"/></emitter>
    <shape type="rectangle"><bsdf type="diffuse"/></shape>
</scene>
"""


def test_an_xml_scenes_film_stands_in_for_the_settings_not_given(tprf_bin, tmp_path, capsys):
    xml = tmp_path / "film.xml"
    xml.write_text(FILM_XML)
    c = 299_792_458.0
    cube = tprf.render(xml, width=5)
    said = capsys.readouterr().err
    assert cube.data.shape == (4, 5, 20)
    m = cube.metadata
    assert (m["spp"], m["max_bounces"]) == (2, 2)
    assert m["t0_s"] == (9.0 + 0.5) / c and m["dt_s"] == 0.1 / c
    assert "from the scene file: height 4 (" in said and "width 6" not in said
    # tprf render with the same option: the same cube, bit for bit.
    cli_render(tprf_bin, tmp_path / "cli", "--width", "5", scene=str(xml))
    assert np.array_equal(cube.data, np.load(tmp_path / "cli" / "tprf.npy"))
    # A setting given wins; another end of the render keeps the file's sample count out.
    r = tprf.Renderer(xml, bins=10)
    assert (r.request["bins"], r.request["width"], r.request.get("spp")) == (10, 6, None)


def test_save_writes_what_tprf_render_writes(tprf_bin, tmp_path):
    cli_render(tprf_bin, tmp_path / "cli", *FLAGS, "--sky", "0.25")
    cube = tprf.render("builtin:cornell", sky=0.25, progress=False, **SETTINGS)
    cube.save(tmp_path / "saved")
    for name in ["tprf.npy", "tprf_bounces.npy", "ambient.npy"]:
        assert np.array_equal(np.load(tmp_path / "saved" / name),
                              np.load(tmp_path / "cli" / name)), name
    saved = json.loads((tmp_path / "saved" / "tprf.json").read_text())
    cli = json.loads((tmp_path / "cli" / "tprf.json").read_text())
    assert saved["format"] == cli["format"]
    for key in SAME:
        assert saved.get(key) == cli.get(key), key
    # Zarr, read back by tprf.load as the same cube; saved again over an earlier output.
    cube.save(tmp_path / "z", format="zarr")
    back = tprf.load(tmp_path / "z")
    assert np.array_equal(back.data, cube.data) and np.array_equal(back.ambient, cube.ambient)
    cube.save(tmp_path / "saved")
    # A folder of the user's is refused and left as it was.
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "thesis.tex").write_text("x")
    with pytest.raises(ValueError, match="thesis.tex"):
        cube.save(tmp_path / "mine")
    assert (tmp_path / "mine" / "thesis.tex").read_text() == "x"
    with pytest.raises(ValueError, match="format"):
        cube.save(tmp_path / "f", format="tiff")


def test_renderer_passes_make_the_same_film_as_one_render():
    one = tprf.render("builtin:cornell", progress=False, **SETTINGS)
    r = tprf.Renderer("builtin:cornell", **SETTINGS)
    cubes = list(r)
    assert r.done and r.spp == 6 and r.passes == len(cubes) == one.metadata["passes"]
    spp = [c.metadata["spp"] for c in cubes]
    assert spp == sorted(spp) and spp[-1] == 6
    assert np.array_equal(cubes[-1].data, one.data)
    assert cubes[-1].metadata["paths_traced"] == one.metadata["paths_traced"]
    # The error estimate falls as passes come (two independent halves).
    errors = [c.error_estimate for c in cubes[1:]]
    assert all(e is not None for e in errors) and errors[-1] < errors[0]
    # Done: nothing more is added.
    r.run(passes=3, progress=False)
    assert r.spp == 6


def test_renderer_runs_until_told_to_stop():
    r = tprf.Renderer("builtin:cornell", width=16, height=16, bins=32)
    assert not r.done
    with pytest.raises(ValueError, match="no target"):
        r.run(progress=False)
    r.run(spp=4, progress=False)
    assert r.spp >= 4
    before = r.passes
    cube = r.run(passes=1, progress=False)
    assert r.passes == before + 1 and cube.metadata["spp"] == r.spp
    cube = r.run(seconds=0.2, progress=False)
    assert cube.metadata["passes"] == r.passes > before + 1


def test_bad_settings_are_value_errors_naming_the_setting():
    for kwargs, field in [(dict(dt=-1e-9), "dt"), (dict(dt="abc"), "dt"), (dict(width=0), "width"),
                          (dict(bins=0), "bins"), (dict(bogus=1), "bogus"),
                          (dict(fov=float("nan")), "fov"), (dict(spp=-1), "spp"),
                          (dict(look_at=(0, 1)), "look_at")]:
        args = dict(width=8, height=8)
        args.update(kwargs)
        with pytest.raises(ValueError, match=field):
            tprf.render("builtin:cornell", progress=False, **args)
    with pytest.raises(FileNotFoundError, match="nothing.gltf"):
        tprf.render("nothing.gltf", width=8, height=8, progress=False)
    with pytest.raises(ValueError, match="built-in scene 'nothing'"):
        tprf.render("builtin:nothing", width=8, height=8, progress=False)
    with pytest.raises(TypeError, match="seconds"):
        tprf.Renderer("builtin:cornell", width=8, height=8, seconds=1)


def interrupt_after(seconds):
    timer = threading.Timer(seconds, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    return timer


def test_ctrl_c_interrupts_a_render_at_once():
    # Far more samples than a test has time for: only the interrupt ends it.
    timer = interrupt_after(0.5)
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        tprf.render("builtin:cornell", width=64, height=64, spp=1 << 30, progress=False)
    timer.join()
    assert time.monotonic() - start < 30
    # A Renderer keeps the passes it made and goes on from them.
    r = tprf.Renderer("builtin:cornell", width=32, height=32, bins=32)
    timer = interrupt_after(0.5)
    with pytest.raises(KeyboardInterrupt):
        r.run(seconds=3600, progress=False)
    timer.join()
    made = r.passes
    assert made >= 1 and r.spp >= 1
    r.run(passes=1, progress=False)
    assert r.passes == made + 1


def test_the_gil_is_released_while_rendering():
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    try:
        tprf.render("builtin:cornell", width=48, height=48, spp=32, progress=False)
    finally:
        stop.set()
        t.join()
    # A thread that needs the GIL every millisecond ran throughout the render.
    assert len(ticks) > 10


def test_data_is_handed_out_without_copies():
    psutil = pytest.importorskip("psutil")
    cube = tprf.render("builtin:cornell", width=64, height=64, bins=4096, spp=1,
                       progress=False)
    nbytes = cube.data.nbytes
    assert nbytes == 64 * 64 * 4096 * 4
    rss = psutil.Process().memory_info().rss
    arrays = [cube.data for _ in range(20)] + [np.asarray(cube) for _ in range(20)]
    assert all(np.shares_memory(a, arrays[0]) for a in arrays)
    # Forty views of a 64 MiB cube: no copy of it.
    assert psutil.Process().memory_info().rss - rss < nbytes // 2


# The memory budget (issue 30): cornell at 32 x 32 x 1024 bins, whose store grows with
# every pass toward its 16 MiB dense size, asked for far more than 4 MiB lets it take.
BUDGET = dict(width=32, height=32, bins=1024, seed=7, threads=2, uniform=True,
              max_memory="4MiB", progress=False)


def test_a_render_over_its_memory_budget_returns_the_passes_made_with_a_warning(
        tprf_bin, tmp_path):
    with pytest.warns(RuntimeWarning, match="max_memory"):
        cube = tprf.render("builtin:cornell", spp=4096, **BUDGET)
    stopped = cube.metadata["stopped"]
    assert stopped["reason"] == "memory" and stopped["limited_by"] == "max_memory"
    spp = cube.metadata["spp"]
    assert 1 <= spp < 4096
    # The passes made, whole: tprf render asked for that many samples writes this cube.
    out = tmp_path / "whole"
    cli_render(tprf_bin, out, "--width", "32", "--height", "32", "--bins", "1024",
               "--seed", "7", "--uniform", "--spp", str(spp))
    assert np.array_equal(cube.data, np.load(out / "tprf.npy"))


def test_a_renderer_over_its_memory_budget_raises_memory_error_and_keeps_its_film():
    r = tprf.Renderer("builtin:cornell", spp=4096,
                      **{k: v for k, v in BUDGET.items() if k != "progress"})
    with pytest.raises(MemoryError, match="max_memory"):
        r.run(progress=False)
    spp = r.spp
    assert 1 <= spp < 4096 and r.cube().metadata["spp"] == spp
    # Tried again, the pass still does not fit: no pass over the budget.
    with pytest.raises(MemoryError):
        r.run(progress=False)
    assert r.spp == spp


def test_a_first_pass_over_the_memory_budget_is_a_value_error():
    with pytest.raises(ValueError, match="max_memory"):
        tprf.render("builtin:cornell", spp=4, **dict(BUDGET, max_memory="64KiB"))
