#!/usr/bin/env python3
"""The race: tprf against mitransient 1.3 (Mitsuba 3's transient_path integrator).

One script, one output folder. For each scene it

1. writes the scene twice from one triangle list: a glTF file for tprf and PLY meshes
   plus a Mitsuba scene dict for mitransient (grey Lambertian walls, a point light, a
   pinhole camera, the same time axis);
2. checks the twin: single-bounce cubes from both renderers must agree within their
   noise (steady image, cube, mean arrival time per pixel, and where the hot spot under
   the light lands in the image: catches flipped images and FOV-axis mistakes);
3. renders a reference: a long tprf render and a long mitransient render, each as two
   independent halves (so each one's noise is measured), checked against each other and
   combined with inverse-variance weights; cached in the output folder for reruns;
4. races: spp = 1, 2, 4, ... for both renderers, runs interleaved, each renderer until
   its cube error is below --stop-error or one run takes longer than --cap seconds;
   records cube and steady-image error against wall time;
5. writes race_<scene>.csv, summary.md (time to 5 %, 2 %, 1 % cube error and the ratio
   mitransient / tprf) and summary.json, and a plot if matplotlib is there.

mitransient runs in this Python process (one persistent process, as its users run it);
tprf runs as a subprocess (`tprf render`). Both at --threads (default 2).

Needs numpy; for mitransient: `pip install mitsuba==3.9.1 mitransient==1.3.1` and LLVM
(Debian: `apt-get install libllvm19`, then DRJIT_LIBLLVM_PATH=.../libLLVM.so.19.1; the
script looks for it in the usual places). `--setup` makes a venv with the pinned versions.
Where mitsuba, its llvm_ad_mono variant or mitransient cannot be loaded the script prints
"skipped: ..." and exits 0. See README.md beside this file and docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import base64
import csv
import hashlib
import json
import math
import os
import platform
import resource
import struct
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

C = 299_792_458.0  # m/s, tprf's and SI's speed of light
MITSUBA_VERSION = "3.9.1"
MITRANSIENT_VERSION = "1.3.1"
REPO = Path(__file__).resolve().parents[2]
LLVM_CANDIDATES = [
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/aarch64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/llvm-19/lib/libLLVM.so.19.1",
    "/usr/lib/llvm-19/lib/libLLVM.so.1",
    "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
    "/usr/lib/llvm-19/lib/libLLVM-19.so",
]
TARGETS = (0.05, 0.02, 0.01)

try:
    import numpy as np
except ImportError:  # numpy is needed by both sides; nothing to race without it
    np = None


def log(msg: str = "") -> None:
    print(msg, flush=True)


# --------------------------------------------------------------------------------------
# Scenes: one triangle list, two files
# --------------------------------------------------------------------------------------


def quad(a, b, c, d):
    """Two triangles (a, b, c), (a, c, d); orient() winds them toward the camera."""
    return [(a, b, c), (a, c, d)]


def box_inward(x0, x1, y0, y1, z0, z1):
    """The six walls of an axis-aligned box (orient() turns them inward)."""
    p = lambda x, y, z: (x, y, z)  # noqa: E731
    tris = []
    tris += quad(p(x0, y0, z0), p(x1, y0, z0), p(x1, y0, z1), p(x0, y0, z1))  # floor
    tris += quad(p(x0, y1, z0), p(x0, y1, z1), p(x1, y1, z1), p(x1, y1, z0))  # ceiling
    tris += quad(p(x0, y0, z0), p(x0, y0, z1), p(x0, y1, z1), p(x0, y1, z0))  # left
    tris += quad(p(x1, y0, z0), p(x1, y1, z0), p(x1, y1, z1), p(x1, y0, z1))  # right
    tris += quad(p(x0, y0, z0), p(x0, y1, z0), p(x1, y1, z0), p(x1, y0, z0))  # back
    tris += quad(p(x0, y0, z1), p(x1, y0, z1), p(x1, y1, z1), p(x0, y1, z1))  # front
    return tris


@dataclass
class Scene:
    name: str
    about: str
    groups: list  # [(albedo, [(v0, v1, v2), ...])]
    light_pos: tuple
    light_w_per_sr: float
    cam_origin: tuple
    cam_target: tuple
    cam_up: tuple
    yfov_deg: float
    hotspot: tuple  # a point the single-bounce image must show brightest, near it
    bin_width_opl: float  # metres, for the default 256 bins; scaled for other counts
    # A homogeneous medium (sigma_s, sigma_a per metre, Henyey-Greenstein g) filling the
    # closed box `fog_box` (triangles wound outward: the medium is behind their normals),
    # whose faces are index-matched boundaries (tprf: an untransmissive material with a
    # medium; Mitsuba: a null BSDF with the medium as interior, the walls inside it with
    # it as exterior). mitransient's transient_prbvolpath starts camera rays in vacuum
    # ("TODO: support sensors inside media"), so the camera stays outside the box.
    medium: tuple | None = None
    fog_box: list | None = None
    in_fog: list | None = None  # per group: whether it lies in the fog (Mitsuba exterior)
    # The twin check's spp at least: a fog pixel's mean arrival is spread over many bins
    # and needs more samples than a wall's to be measured to 0.1 bin.
    twin_spp: int = 0
    window_opl: float = field(init=False)

    def __post_init__(self):
        self.window_opl = 256 * self.bin_width_opl


def scene_room(albedo=0.5, name="room"):
    # 4 x 3 x 5 m, x in [-2, 2], y in [0, 3], z in [-2.5, 2.5]; camera near the front
    # wall looking down the room, light under the ceiling, to the camera's upper left.
    return Scene(
        name=name,
        about=f"closed box room 4 x 3 x 5 m, albedo {albedo}, point light 0.5 m under the "
        "ceiling, camera inside",
        groups=[(albedo, box_inward(-2.0, 2.0, 0.0, 3.0, -2.5, 2.5))],
        light_pos=(-1.0, 2.5, -1.0),
        light_w_per_sr=10.0,
        cam_origin=(0.0, 1.5, 2.3),
        cam_target=(0.0, 1.5, -2.5),
        cam_up=(0.0, 1.0, 0.0),
        yfov_deg=60.0,
        hotspot=(-1.0, 3.0, -1.0),  # the ceiling right above the light
        bin_width_opl=0.08,  # 256 bins: 0 to 20.48 m of optical path
    )


def scene_corner(albedo=0.7):
    # floor y = 0 (x in [-2, 2], z in [-3, 1]), back wall z = -3, left wall x = -2;
    # open to the right, the front and the sky: most paths leave after a few bounces.
    p = lambda x, y, z: (x, y, z)  # noqa: E731
    tris = []
    tris += quad(p(-2, 0, -3), p(-2, 0, 1), p(2, 0, 1), p(2, 0, -3))  # floor
    tris += quad(p(-2, 0, -3), p(2, 0, -3), p(2, 3, -3), p(-2, 3, -3))  # back
    tris += quad(p(-2, 0, -3), p(-2, 3, -3), p(-2, 3, 1), p(-2, 0, 1))  # left
    return Scene(
        name="corner",
        about=f"open corner: floor, back wall and left wall (4 x 4 m, 3 m high), albedo "
        f"{albedo}, point light 0.6 m from the left wall",
        groups=[(albedo, tris)],
        light_pos=(-1.4, 1.8, -2.2),
        light_w_per_sr=10.0,
        cam_origin=(1.5, 1.6, 3.0),
        cam_target=(-0.5, 0.8, -1.5),
        cam_up=(0.0, 1.0, 0.0),
        yfov_deg=55.0,
        hotspot=(-2.0, 1.8, -2.2),  # the left wall next to the light
        bin_width_opl=0.06,  # 256 bins: 0 to 15.36 m
    )


def box_outward(x0, x1, y0, y1, z0, z1):
    """The six faces of an axis-aligned box, each triangle's normal pointing out."""
    tris = []
    for t in box_inward(x0, x1, y0, y1, z0, z1):
        a, b, c = t
        n = cross(sub(b, a), sub(c, a))
        centre = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
        if dot(n, sub(a, centre)) < 0:
            b, c = c, b
        tris.append((a, b, c))
    return tris


def scene_fog(sigma_s=0.15, sigma_a=0.01, g=0.9):
    # A road (y = 0, x in [-4, 4], z in [-14, 0]) that runs into fog filling the box x in
    # [-5, 5], y in [-0.5, 6], z in [-15, -5]; a target wall (2 x 2 m, albedo 0.7) at
    # z = -10, 5 m into the fog; a lamp above the road 1.5 m before the fog; the camera
    # at z = 1 (mitransient cannot start camera rays in a medium). The road is two
    # shapes, in clear air and in the fog (Mitsuba's exterior medium is per shape).
    p = lambda x, y, z: (x, y, z)  # noqa: E731
    road_clear = quad(p(-4, 0, -5), p(-4, 0, 0), p(4, 0, 0), p(4, 0, -5))
    road_fog = quad(p(-4, 0, -14), p(-4, 0, -5), p(4, 0, -5), p(4, 0, -14))
    target = quad(p(-1, 0.01, -10), p(1, 0.01, -10), p(1, 2, -10), p(-1, 2, -10))
    sigma_t = sigma_s + sigma_a
    return Scene(
        name="fog",
        about=f"a road running into fog (sigma_s {sigma_s}/m, sigma_a {sigma_a}/m: visibility "
        f"{3.912 / sigma_t:.1f} m, g {g}) and a target wall 5 m into it, a point lamp 1.5 m "
        "before the fog, the camera in clear air",
        groups=[(0.3, road_clear), (0.3, road_fog), (0.7, target)],
        in_fog=[False, True, True],
        light_pos=(0.8, 2.2, -3.5),
        light_w_per_sr=10.0,
        cam_origin=(0.0, 1.5, 1.0),
        cam_target=(0.0, 1.0, -10.0),
        cam_up=(0.0, 1.0, 0.0),
        yfov_deg=40.0,
        hotspot=(0.8, 0.0, -3.5),  # the road under the lamp
        bin_width_opl=0.15625,  # 256 bins: 0 to 40 m
        medium=(sigma_s, sigma_a, g),
        fog_box=box_outward(-5.0, 5.0, -0.5, 6.0, -15.0, -5.0),
        twin_spp=4096,
    )


SCENES = {
    "room": lambda: scene_room(0.5, "room"),
    "fog": lambda: scene_fog(),
    "corner": lambda: scene_corner(0.7),
    "bright-room": lambda: scene_room(0.8, "bright-room"),
}
DEFAULT_SCENES = "room,corner"
# Scenes read from a mitransient checkout (--mitransient PATH) rather than written here:
# not in 'all', and their film is the file's.
FILE_SCENES = ("staircase",)
# The staircase's errors are larger (an area light, many bounces, 400 bins over 32 x 56
# pixels): issue 48 compares at 20, 10 and 5 %.
STAIRCASE_TARGETS = (0.2, 0.1, 0.05)


@dataclass
class FileScene:
    """A scene both renderers read from one XML file that this script does not write."""

    name: str
    about: str
    xml: Path
    width: int
    height: int
    bins: int
    bin_width_opl: float
    window_opl: float = field(init=False)

    def __post_init__(self):
        self.window_opl = self.bins * self.bin_width_opl


def scene_staircase(checkout: Path, out: Path) -> FileScene:
    """mitransient's staircase made comparable by staircase.py beside this file."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import staircase

    try:
        xml, changed = staircase.build(checkout, out)
    except staircase.BuildError as e:
        raise SystemExit(f"--mitransient {checkout}: {e}")
    return FileScene(
        "staircase",
        "mitransient's staircase example (Bitterli: 774 OBJ meshes, 10 JPEG textures, a "
        f"rectangle area light), its {changed['roughplastic_to_diffuse']} rough plastics as "
        "diffuse, camera_unwarp off (benches/race/staircase.py)",
        xml, staircase.WIDTH_PX, staircase.HEIGHT_PX, staircase.BINS, staircase.BIN_WIDTH_OPL_M,
    )  # fmt: skip


def normalize(v):
    n = math.sqrt(sum(x * x for x in v))
    return tuple(x / n for x in v)


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def camera_frame(s: Scene):
    f = normalize(sub(s.cam_target, s.cam_origin))
    r = normalize(cross(f, s.cam_up))
    u = cross(r, f)
    return r, u, f


def project(s: Scene, p, width, height):
    """Image position (column, row; row 0 = top) of world point p, tprf's and glTF's
    camera model (y field of view, square pixels)."""
    r, u, f = camera_frame(s)
    d = sub(p, s.cam_origin)
    z = dot(d, f)
    th = math.tan(math.radians(s.yfov_deg) / 2)
    sx = dot(d, r) / z / (th * width / height)
    sy = dot(d, u) / z / th
    return (sx + 1) / 2 * width, (1 - sy) / 2 * height


def orient(s: Scene):
    """Wind every triangle so that its normal (v1 - v0) x (v2 - v0) faces the camera
    (Mitsuba's diffuse BSDF is one-sided), and refuse a scene where a wall would face the
    camera but not the light."""
    groups = []
    for albedo, tris in s.groups:
        out = []
        for a, b, c in tris:
            n = cross(sub(b, a), sub(c, a))
            if dot(n, sub(s.cam_origin, a)) < 0:
                b, c = c, b
                n = tuple(-x for x in n)
            if dot(n, sub(s.light_pos, a)) <= 0:
                raise SystemExit(f"scene {s.name}: a triangle faces the camera but not the light")
            out.append((a, b, c))
        groups.append((albedo, out))
    s.groups = groups


def write_gltf(s: Scene, path: Path, width: int, height: int):
    """The glTF twin: metres, KHR_lights_punctual intensity in W/sr, Lambertian =
    metallic 0 + KHR_materials_specular specularFactor 0, double-sided."""
    buf = bytearray()
    accessors, views, prims, materials = [], [], [], []

    def add_positions(tris):
        """The triangles' corners as a buffer view and a VEC3 float accessor."""
        flat = [x for t in tris for v in t for x in v]
        off = len(buf)
        buf.extend(struct.pack(f"<{len(flat)}f", *flat))
        views.append({"buffer": 0, "byteOffset": off, "byteLength": 4 * len(flat)})
        xs, ys, zs = flat[0::3], flat[1::3], flat[2::3]
        accessors.append(
            {
                "bufferView": len(views) - 1,
                "componentType": 5126,
                "count": len(flat) // 3,
                "type": "VEC3",
                "min": [min(xs), min(ys), min(zs)],
                "max": [max(xs), max(ys), max(zs)],
            }
        )

    for albedo, tris in s.groups:
        add_positions(tris)
        materials.append(
            {
                "name": f"grey {albedo}",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [albedo, albedo, albedo, 1.0],
                    "metallicFactor": 0.0,
                    "roughnessFactor": 1.0,
                },
                "doubleSided": True,
                "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}},
            }
        )
        prims.append({"attributes": {"POSITION": len(accessors) - 1}, "material": len(materials) - 1})
    if s.fog_box:
        sigma_s, sigma_a, g = s.medium
        add_positions(s.fog_box)
        # Untransmissive with a medium: an index-matched boundary (docs/media.md).
        materials.append(
            {
                "name": "fog",
                "extras": {"tprf": {"medium": {"sigma_s_per_m": sigma_s, "sigma_a_per_m": sigma_a, "g": g}}},
            }
        )
        prims.append({"attributes": {"POSITION": len(accessors) - 1}, "material": len(materials) - 1})
    r, u, f = camera_frame(s)
    o = s.cam_origin
    matrix = [*r, 0.0, *u, 0.0, *(-x for x in f), 0.0, *o, 1.0]  # column-major
    doc = {
        "asset": {"version": "2.0", "generator": "tprf benches/race/race.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_specular"],
        "extensions": {
            "KHR_lights_punctual": {
                "lights": [{"type": "point", "color": [1, 1, 1], "intensity": s.light_w_per_sr}]
            }
        },
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"name": "walls", "mesh": 0},
            {"name": "light", "translation": list(s.light_pos), "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "camera", "camera": 0, "matrix": matrix},
        ],
        "cameras": [
            {
                "type": "perspective",
                "perspective": {
                    "yfov": math.radians(s.yfov_deg),
                    "aspectRatio": width / height,
                    "znear": 1e-4,
                },
            }
        ],
        "meshes": [{"name": "walls", "primitives": prims}],
        "materials": materials,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [
            {
                "byteLength": len(buf),
                "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buf)).decode(),
            }
        ],
    }
    path.write_text(json.dumps(doc, indent=1))


def write_ply(tris, path: Path):
    """Binary PLY, three vertices per triangle (flat walls; Mitsuba told face_normals)."""
    nv = 3 * len(tris)
    head = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(tris)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    body = bytearray()
    for t in tris:
        for v in t:
            body += struct.pack("<3f", *v)
    for i in range(len(tris)):
        body += struct.pack("<B3i", 3, 3 * i, 3 * i + 1, 3 * i + 2)
    path.write_bytes(head.encode() + bytes(body))


def mitsuba_dict(mi, s: Scene, plys, width, height, bins, bin_width_opl, max_depth, fog_ply=None):
    integrator = "transient_prbvolpath" if s.medium else "transient_path"
    d = {
        "type": "scene",
        "integrator": {"type": integrator, "max_depth": max_depth, "camera_unwarp": False},
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": s.yfov_deg,
            # Mitsuba starts camera rays at the near clip plane and mitransient counts the
            # optical path from there: keep it negligible (default 1 cm = 1/8 bin here).
            "near_clip": 1e-4,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=list(s.cam_origin), target=list(s.cam_target), up=list(s.cam_up)
            ),
            "sampler": {"type": "independent", "sample_count": 1},
            "film": {
                "type": "transient_hdr_film",
                "width": width,
                "height": height,
                "temporal_bins": bins,
                "start_opl": 0.0,
                "bin_width_opl": bin_width_opl,
                "rfilter": {"type": "box"},
            },
        },
        "light": {
            "type": "point",
            "position": list(s.light_pos),
            "intensity": {"type": "spectrum", "value": s.light_w_per_sr},
        },
    }
    for i, ((albedo, _), ply) in enumerate(zip(s.groups, plys)):
        d[f"walls{i}"] = {
            "type": "ply",
            "filename": str(ply),
            "face_normals": True,
            "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": albedo}},
        }
        if s.medium and s.in_fog[i]:
            d[f"walls{i}"]["exterior"] = {"type": "ref", "id": "fog"}
    if s.medium:
        sigma_s, sigma_a, g = s.medium
        sigma_t = sigma_s + sigma_a
        d["fog"] = {
            "type": "homogeneous",
            "sigma_t": {"type": "spectrum", "value": sigma_t},
            "albedo": {"type": "spectrum", "value": sigma_s / sigma_t},
            "phase": {"type": "hg", "g": g},
        }
        d["fogbox"] = {
            "type": "ply",
            "filename": str(fog_ply),
            "face_normals": True,
            "bsdf": {"type": "null"},
            "interior": {"type": "ref", "id": "fog"},
        }
    return d


def write_mitsuba_xml(s: Scene, plys, path: Path, width, height, bins, bin_width_opl):
    """The scene as a Mitsuba 3 XML file both renderers read (`tprf render FILE.xml`,
    mitransient's `mi.load_file`): what `mitsuba_dict` builds, for scenes in vacuum;
    `max_depth` a `<default>` that mitransient's runs set when they load it (tprf's runs
    give `--max-bounces`). The fog scene stays two files: tprf reads a shape's exterior
    medium as the whole scene's, mitransient's camera rays start in vacuum."""
    v = lambda x: ", ".join(repr(float(c)) for c in x)  # noqa: E731
    shapes = "".join(
        f"""    <shape type="ply">
        <string name="filename" value="{ply.name}"/>
        <boolean name="face_normals" value="true"/>
        <bsdf type="diffuse"><spectrum name="reflectance" value="{float(albedo)!r}"/></bsdf>
    </shape>
"""
        for (albedo, _), ply in zip(s.groups, plys)
    )
    path.write_text(f"""<scene version="3.0.0">
    <default name="max_depth" value="-1"/>
    <integrator type="transient_path">
        <integer name="max_depth" value="$max_depth"/>
        <boolean name="camera_unwarp" value="false"/>
    </integrator>
    <sensor type="perspective">
        <string name="fov_axis" value="y"/>
        <float name="fov" value="{float(s.yfov_deg)!r}"/>
        <!-- mitransient counts the optical path from the near plane: keep it negligible -->
        <float name="near_clip" value="0.0001"/>
        <transform name="to_world">
            <lookat origin="{v(s.cam_origin)}" target="{v(s.cam_target)}" up="{v(s.cam_up)}"/>
        </transform>
        <sampler type="independent"><integer name="sample_count" value="1"/></sampler>
        <film type="transient_hdr_film">
            <integer name="width" value="{width}"/>
            <integer name="height" value="{height}"/>
            <integer name="temporal_bins" value="{bins}"/>
            <float name="start_opl" value="0"/>
            <float name="bin_width_opl" value="{float(bin_width_opl)!r}"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <emitter type="point">
        <point name="position" value="{v(s.light_pos)}"/>
        <spectrum name="intensity" value="{float(s.light_w_per_sr)!r}"/>
    </emitter>
{shapes}</scene>
""")


# --------------------------------------------------------------------------------------
# Renderers
# --------------------------------------------------------------------------------------


@dataclass
class Run:
    renderer: str
    spp: int
    seed: int
    cube: object  # np.ndarray [H, W, T] float32 (float64 for the reference)
    wall_s: float  # the time the race uses
    raw_wall_s: float  # wall time around the call / process
    render_s: float  # tprf: render_seconds from tprf.json; mitransient: = wall_s
    cpu_s: float  # CPU time used (all threads)
    compile_s: float = 0.0  # mitransient: Dr.Jit kernel compilation in this call
    steady_own: object = None  # mitransient's own steady image (all arrival times)


class Tprf:
    name = "tprf"

    def __init__(self, exe, scene: Path, work: Path, width, height, bins, bin_width_opl, threads):
        self.exe, self.scene, self.work = exe, scene, work
        self.args = [
            "--width", str(width), "--height", str(height), "--bins", str(bins),
            "--t0", "0m", "--dt", f"{bin_width_opl:.9f}m", "--threads", str(threads),
        ]  # fmt: skip

    def run(self, spp, seed, max_bounces=None) -> Run:
        out = self.work / "tprf_run"
        cmd = [str(self.exe), "render", str(self.scene), "--out", str(out), "--spp", str(spp)]
        cmd += self.args + ["--seed", str(seed)]
        if max_bounces is not None:
            cmd += ["--max-bounces", str(max_bounces)]
        cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wall = time.perf_counter() - t0
        cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        if p.returncode != 0:
            raise SystemExit(f"tprf failed ({p.returncode}): {' '.join(cmd)}\n{p.stderr}")
        meta = json.loads((out / "tprf.json").read_text())
        cube = np.load(out / "tprf.npy")
        if meta.get("notes"):
            self.notes = meta["notes"]
        cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
        return Run("tprf", spp, seed, cube, wall, wall, float(meta["render_seconds"]), cpu)


class Mitransient:
    name = "mitransient"

    def __init__(self, mi, dr, scene_for_depth, threads, max_lanes=1 << 26):
        self.mi, self.dr = mi, dr
        self.make = scene_for_depth
        self.scenes = {}
        self.max_lanes = max_lanes
        dr.set_thread_count(threads)
        dr.set_flag(dr.JitFlag.KernelHistory, True)

    def scene(self, max_depth):
        if max_depth not in self.scenes:
            self.scenes[max_depth] = self.make(max_depth)
        return self.scenes[max_depth]

    def run(self, spp, seed, max_depth=-1) -> Run:
        mi, dr = self.mi, self.dr
        scene = self.scene(max_depth)
        film = scene.sensors()[0].film()
        pixels = film.size().x * film.size().y
        # One mi.render call holds width x height x spp lanes; split very large runs.
        chunks = max(1, math.ceil(pixels * spp / self.max_lanes))
        while spp % chunks:
            chunks += 1
        dr.kernel_history()  # clear
        cpu0 = time.process_time()
        t0 = time.perf_counter()
        steady = cube = None
        for k in range(chunks):
            st, tr = mi.render(scene, spp=spp // chunks, seed=seed * 1009 + k)
            st, tr = np.array(st, dtype=np.float64), np.array(tr, dtype=np.float64)
            steady = st if steady is None else steady + st
            cube = tr if cube is None else cube + tr
        wall = time.perf_counter() - t0
        cpu = time.process_time() - cpu0
        compile_ms = sum(
            k.get("codegen_time", 0.0) + k.get("backend_time", 0.0)
            for k in dr.kernel_history()
            if k.get("cache_hit", 1) == 0
        )
        compile_s = compile_ms / 1e3
        cube = (cube / chunks)[..., 0].astype(np.float32)
        steady = (steady / chunks)[..., 0]
        # The time the race uses: mi.render's wall time less kernel compilation (what a
        # warm Dr.Jit kernel cache gives; 0 after the first call at a given spp, or on
        # a rerun of this script, since Dr.Jit caches kernels on disk).
        timed = max(wall - compile_s, 1e-6)
        return Run("mitransient", spp, seed, cube, timed, wall, timed, cpu, compile_s, steady)


def load_mitsuba():
    """(mi, dr, versions) or a reason it cannot run."""
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        for c in LLVM_CANDIDATES:
            if os.path.exists(c):
                os.environ["DRJIT_LIBLLVM_PATH"] = c
                break
    try:
        import mitsuba as mi
    except Exception as e:  # noqa: BLE001
        return None, (
            f"cannot import mitsuba ({type(e).__name__}: {e}); install it with "
            f"`pip install mitsuba=={MITSUBA_VERSION} mitransient=={MITRANSIENT_VERSION}` "
            "or run with --setup"
        )
    try:
        mi.set_variant("llvm_ad_mono")
    except Exception as e:  # noqa: BLE001
        return None, (
            f"mitsuba's llvm_ad_mono variant does not load ({type(e).__name__}: {e}); it "
            "needs LLVM: `sudo apt-get install libllvm19` (Debian/Ubuntu), then "
            "`export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1`"
        )
    try:
        import drjit as dr
        import mitransient  # noqa: F401  (registers transient_path, transient_hdr_film)
    except Exception as e:  # noqa: BLE001
        return None, (
            f"cannot import mitransient ({type(e).__name__}: {e}); "
            f"`pip install mitransient=={MITRANSIENT_VERSION}`"
        )
    try:
        from importlib.metadata import version

        mtv = version("mitransient")
    except Exception:  # noqa: BLE001
        mtv = getattr(mitransient, "__version__", "?")
    versions = {"mitsuba": mi.__version__, "mitransient": mtv, "drjit": dr.__version__}
    return (mi, dr, versions), None


# --------------------------------------------------------------------------------------
# Statistics
# --------------------------------------------------------------------------------------


def rel_l2(x, ref):
    return float(np.linalg.norm((x - ref).ravel()) / np.linalg.norm(ref.ravel()))


def sq(x):
    x = np.asarray(x, dtype=np.float64).ravel()
    return float(x @ x)


def halves(a1, a2):
    """Mean of two independent renders and the estimated squared error of that mean:
    E|a1 - a2|^2 = 2 var(one), var(mean) = var(one) / 2 = |a1 - a2|^2 / 4."""
    a1 = np.asarray(a1, dtype=np.float64)
    a2 = np.asarray(a2, dtype=np.float64)
    return (a1 + a2) / 2, sq(a1 - a2) / 4


def compare(a, var_a, b, var_b):
    """|a - b|^2 against the noise expected from the two: ~1 when they agree."""
    d2 = sq(a - b)
    return d2 / max(var_a + var_b, 1e-300), math.sqrt(d2) / math.sqrt(sq((a + b) / 2))


def mean_arrival(cube, min_frac=1e-3):
    """Per-pixel mean arrival bin (centre of mass over T), and the mask of pixels with
    enough signal to have one."""
    cube = np.asarray(cube, dtype=np.float64)
    tot = cube.sum(axis=2)
    b = np.arange(cube.shape[2]) + 0.5
    with np.errstate(invalid="ignore", divide="ignore"):
        m = (cube * b).sum(axis=2) / tot
    mask = tot > min_frac * tot.max()
    return m, mask


def hot_spot(steady):
    """Brightness-weighted centroid (column, row) of the brightest 2 % of pixels."""
    s = np.asarray(steady, dtype=np.float64)
    thr = np.quantile(s, 0.98)
    w = np.where(s >= thr, s, 0.0)
    rows, cols = np.indices(s.shape)
    return float((w * (cols + 0.5)).sum() / w.sum()), float((w * (rows + 0.5)).sum() / w.sum())


def time_to(points, target):
    """Time at which error reaches `target`: log-log interpolation between the two ladder
    points that bracket it; else err = a t^-1/2 fitted to the last three points
    (extrapolated, marked). points: [(time, error)] in ladder order."""
    pts = [(t, e) for t, e in points if t > 0 and e > 0 and math.isfinite(e)]
    if not pts:
        return None, "none"
    for i, (t, e) in enumerate(pts):
        if e <= target:
            if i == 0:
                # already below at the first point: back-extrapolate with t^-1/2
                return t * (e / target) ** 2, "fit"
            t0, e0 = pts[i - 1]
            if e0 <= e:
                return t, "interp"
            f = math.log(e0 / target) / math.log(e0 / e)
            return math.exp(math.log(t0) + f * math.log(t / t0)), "interp"
    tail = pts[-3:]
    a = sorted(e * math.sqrt(t) for t, e in tail)[len(tail) // 2]
    return (a / target) ** 2, "fit"


def tail_constant(points):
    """a in err = a t^-1/2 (median over the last three points): the lower, the faster."""
    pts = [(t, e) for t, e in points if t > 0 and e > 0]
    tail = pts[-3:]
    if not tail:
        return float("nan")
    return sorted(e * math.sqrt(t) for t, e in tail)[len(tail) // 2]


# --------------------------------------------------------------------------------------
# The steps
# --------------------------------------------------------------------------------------


def machine_line():
    """The machine, with the widest vector units the CPU offers: Dr.Jit's kernels use
    them (mitransient's cost per sample on AVX-512 is about 0.6x that on AVX2), tprf's
    build does not, so the race's ratio depends on them."""
    cpu, flags = "?", set()
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name") and cpu == "?":
                cpu = line.split(":", 1)[1].strip()
            elif line.startswith("flags") and not flags:
                flags = set(line.split(":", 1)[1].split())
    except OSError:
        pass
    vector = next((v for f, v in [("avx512f", "AVX-512"), ("avx2", "AVX2"), ("avx", "AVX")]
                   if f in flags), "no AVX" if flags else "?")
    return (f"{platform.node()}: {os.cpu_count()} logical CPUs ({cpu}, {vector}), "
            f"Linux {platform.release()}")


def loadavg():
    try:
        return " ".join(open("/proc/loadavg").read().split()[:3])
    except OSError:
        return "?"


def twin_check(s, tprf, mt, cfg, report):
    """Single-bounce cubes from both: they must agree within their noise."""
    spp = max(cfg.twin_spp, s.twin_spp)
    log(f"[{s.name}] twin check: single bounce (tprf --max-bounces 1, mitransient max_depth 2), "
        f"{spp} spp x 2 seeds each")
    a = [tprf.run(spp, 101 + k, max_bounces=1) for k in range(2)]
    b = [mt.run(spp, 101 + k, max_depth=2) for k in range(2)]
    ta, va = halves(a[0].cube, a[1].cube)
    tb, vb = halves(b[0].cube, b[1].cube)
    chi_cube, d_cube = compare(ta, va, tb, vb)
    sa, sva = halves(a[0].cube.sum(2), a[1].cube.sum(2))
    sb, svb = halves(b[0].cube.sum(2), b[1].cube.sum(2))
    chi_st, d_st = compare(sa, sva, sb, svb)
    noise_st = math.sqrt(sva + svb) / math.sqrt(sq((sa + sb) / 2))
    noise_cube = math.sqrt(va + vb) / math.sqrt(sq((ta + tb) / 2))
    ma, mask_a = mean_arrival(ta)
    mb, mask_b = mean_arrival(tb)
    mask = mask_a & mask_b
    dm = np.abs(ma - mb)[mask]
    mean_dm, max_dm = float(dm.mean()), float(dm.max())
    bias_dm = float((ma - mb)[mask].mean())
    # The noise of that difference, from each renderer's two seeds: a pixel whose light
    # is spread over many bins (fog) has a noisy mean arrival. Expected mean |a - b| for
    # Gaussian noise: sqrt(2 / pi) x the rms of the difference of the two means.
    seeds = [mean_arrival(r.cube)[0] for r in a + b]
    var_a = np.square(seeds[0] - seeds[1])[mask] / 4
    var_b = np.square(seeds[2] - seeds[3])[mask] / 4
    noise_dm = float(np.sqrt(2 / np.pi) * np.nanmean(np.sqrt(var_a + var_b)))
    # orientation: the hot spot under the light, seen by both where the camera model says
    h, w = ta.shape[:2]
    ex, ey = project(s, s.hotspot, w, h)
    (ax, ay), (bx, by) = hot_spot(sa), hot_spot(sb)
    tol = 0.12 * max(w, h)
    orient_ok = all(math.hypot(x - ex, y - ey) < tol for x, y in ((ax, ay), (bx, by)))
    # mitransient's own steady image holds light arriving after the window too: with one
    # bounce everything must be inside it.
    own = np.mean([r.steady_own for r in b], axis=0)
    past = 1 - sb.sum() / own.sum()
    r = {
        "spp": spp,
        "steady_rel_diff": d_st,
        "steady_noise": noise_st,
        "steady_chi2_ratio": chi_st,
        "cube_rel_diff": d_cube,
        "cube_noise": noise_cube,
        "cube_chi2_ratio": chi_cube,
        "arrival_bins_mean_abs_diff": mean_dm,
        "arrival_bins_max_abs_diff": max_dm,
        "arrival_bins_mean_diff_tprf_minus_mt": bias_dm,
        "arrival_bins_mean_abs_diff_noise": noise_dm,
        "hotspot_expected_px": [ex, ey],
        "hotspot_tprf_px": [ax, ay],
        "hotspot_mitransient_px": [bx, by],
        "steady_sum_ratio_tprf_over_mt": float(sa.sum() / sb.sum()),
        "mt_energy_past_window": float(past),
    }
    log(f"  steady image: rel. L2 difference {100 * d_st:.3f} % (noise {100 * noise_st:.3f} %, "
        f"|a-b|^2 / expected {chi_st:.2f}); total tprf / mitransient = {r['steady_sum_ratio_tprf_over_mt']:.5f}")
    log(f"  cube:         rel. L2 difference {100 * d_cube:.2f} % (noise {100 * noise_cube:.2f} %, "
        f"|a-b|^2 / expected {chi_cube:.2f})")
    log(f"  mean arrival per pixel: |tprf - mitransient| mean {mean_dm:.4f} bins, max {max_dm:.4f} "
        f"bins, signed mean {bias_dm:+.4f} bins ({mask.sum()} pixels; noise of the mean |difference| "
        f"{noise_dm:.4f} bins)")
    log(f"  hot spot under the light (column, row): expected ({ex:.1f}, {ey:.1f}), tprf ({ax:.1f}, "
        f"{ay:.1f}), mitransient ({bx:.1f}, {by:.1f})")
    problems = []
    if not orient_ok:
        problems.append("the hot spot is not where the camera model puts it (flipped image or FOV axis?)")
    if d_st > 3 * noise_st + cfg.twin_tol:
        problems.append(f"steady images differ by {100 * d_st:.2f} % (noise {100 * noise_st:.2f} %)")
    if d_cube > 1.5 * noise_cube + cfg.twin_tol:
        problems.append(f"cubes differ by {100 * d_cube:.2f} % (noise {100 * noise_cube:.2f} %)")
    if mean_dm > 0.1 + 1.5 * noise_dm or abs(bias_dm) > 0.05:
        problems.append(f"mean arrival times differ by {mean_dm:.3f} bins (signed {bias_dm:+.3f})")
    r["problems"] = problems
    r["passed"] = not problems
    report["twin_check"] = r
    if problems:
        log("  TWIN CHECK FAILED: " + "; ".join(problems))
        if not cfg.ignore_twin:
            raise SystemExit(f"[{s.name}] twin check failed (use --ignore-twin-check to race anyway)")
    else:
        log("  twin check passed")


def reference(s, tprf, mt, cfg, report, ref_path: Path, key: str):
    if ref_path.exists() and not cfg.new_reference:
        z = np.load(ref_path, allow_pickle=False)
        if str(z["key"]) == key:
            info = json.loads(str(z["info"]))
            report["reference"] = info | {"cached": str(ref_path)}
            log(f"[{s.name}] reference: reused {ref_path} (cube error {100 * info['ref_cube_err']:.3f} %)")
            return z["cube"], info["ref_cube_err"], info["ref_steady_err"]
        log(f"[{s.name}] reference: {ref_path} is for other settings; rendering a new one")
    # Pilot: the cost and the noise of a sample of each (this also warms mitransient up),
    # from two runs of about a second each: a few-spp run is mostly tprf's process start
    # and Dr.Jit's tracing.
    def pilot(runner):
        p = cfg.pilot_spp
        while True:
            r = runner.run(p, 7)
            if r.wall_s > 0.5 or p >= 1 << 16:
                break
            p = max(2 * p, int(1.0 / (max(r.render_s, 1e-6) / p)))
        r2 = runner.run(p, 8)
        m, v = halves(r.cube, r2.cube)
        e1 = math.sqrt(2 * v / sq(m))  # relative error of one p-spp run
        per = (r.render_s + r2.render_s) / (2 * p)  # s per spp, inside the render
        fixed = (r.wall_s + r2.wall_s) / 2 - per * p  # tprf: start-up, scene, BVH, output
        return per, max(fixed, 0.0), e1 * e1 * per * p  # a^2 in err^2 = a^2 / t

    per_a, fixed_a, a2_a = pilot(tprf)
    per_b, fixed_b, a2_b = pilot(mt)
    # Equal render time T for each, combined with inverse-variance weights:
    # err_ref^2 = 1 / (T (1/a_tprf^2 + 1/a_mt^2)).
    t_each = 1 / (cfg.ref_error**2 * (1 / a2_a + 1 / a2_b))
    t_each = min(t_each, cfg.ref_seconds / 2)
    spp_a = max(cfg.pilot_spp, int(t_each / 2 / per_a))
    spp_b = max(cfg.pilot_spp, int(t_each / 2 / per_b))
    if cfg.ref_max_spp:
        spp_a, spp_b = min(spp_a, cfg.ref_max_spp), min(spp_b, cfg.ref_max_spp)
    expect = 1 / math.sqrt(2 * spp_a * per_a / a2_a + 2 * spp_b * per_b / a2_b)
    log(f"[{s.name}] reference: tprf 2 x {spp_a} spp, mitransient 2 x {spp_b} spp, about "
        f"{2 * (spp_a * per_a + fixed_a + spp_b * per_b):.0f} s in all for an "
        f"expected cube error of {100 * expect:.2f} % (target {100 * cfg.ref_error:.2f} %, at most "
        f"{cfg.ref_seconds:.0f} s)")
    t0 = time.perf_counter()
    a = [tprf.run(spp_a, 1_000_001 + k) for k in range(2)]
    b = [mt.run(spp_b, 1_000_001 + k) for k in range(2)]
    ta, va = halves(a[0].cube, a[1].cube)
    tb, vb = halves(b[0].cube, b[1].cube)
    chi, d = compare(ta, va, tb, vb)
    wa, wb = 1 / va, 1 / vb
    ref = (wa * ta + wb * tb) / (wa + wb)
    nref = math.sqrt(sq(ref))
    ref_err = math.sqrt(1 / (wa + wb)) / nref
    sa, sva = halves(a[0].cube.sum(2), a[1].cube.sum(2))
    sb, svb = halves(b[0].cube.sum(2), b[1].cube.sum(2))
    s_chi, s_d = compare(sa, sva, sb, svb)
    sref = ref.sum(2)
    # the same weights as the cube, so the steady reference is the reference's sum
    sref_var = (wa**2 * sva + wb**2 * svb) / (wa + wb) ** 2
    sref_err = math.sqrt(sref_var) / math.sqrt(sq(sref))
    own = np.mean([r.steady_own for r in b], axis=0)
    past = float(1 - sb.sum() / own.sum())
    info = {
        "tprf_spp": 2 * spp_a,
        "mitransient_spp": 2 * spp_b,
        "seconds": time.perf_counter() - t0,
        "tprf_cube_err": math.sqrt(va) / math.sqrt(sq(ta)),
        "mitransient_cube_err": math.sqrt(vb) / math.sqrt(sq(tb)),
        "cube_rel_diff": d,
        "cube_chi2_ratio": chi,
        "steady_rel_diff": s_d,
        "steady_chi2_ratio": s_chi,
        "ref_cube_err": ref_err,
        "ref_steady_err": sref_err,
        "weights": [wa / (wa + wb), wb / (wa + wb)],
        "steady_sum_ratio_tprf_over_mt": float(sa.sum() / sb.sum()),
        "mt_energy_past_window": past,
    }
    log(f"  tprf {info['tprf_spp']} spp: cube error {100 * info['tprf_cube_err']:.3f} %; "
        f"mitransient {info['mitransient_spp']} spp: {100 * info['mitransient_cube_err']:.3f} %")
    log(f"  tprf vs mitransient: cube differs by {100 * d:.3f} % (|a-b|^2 / expected {chi:.2f}), "
        f"steady by {100 * s_d:.3f} % ({s_chi:.2f}); totals tprf / mitransient "
        f"{info['steady_sum_ratio_tprf_over_mt']:.5f}")
    log(f"  light mitransient records after the window: {100 * past:.2f} % of its steady image")
    log(f"  reference (inverse-variance weights {info['weights'][0]:.2f} tprf, "
        f"{info['weights'][1]:.2f} mitransient): cube error {100 * ref_err:.3f} %, steady "
        f"{100 * sref_err:.3f} %")
    if chi > 1.5 or s_chi > 1.5:
        log("  WARNING: the two long renders differ by more than their noise (ratio > 1.5): "
            "a convention or a bias to look into before trusting the race")
    np.savez_compressed(ref_path, cube=ref.astype(np.float64), key=key, info=json.dumps(info))
    report["reference"] = info
    return ref, ref_err, sref_err


def race(s, tprf, mt, cfg, ref, ref_err, sref_err, csv_path: Path, report, stop_error=None):
    stop_error = cfg.stop_error if stop_error is None else stop_error
    sref = ref.sum(2)
    rows = []
    active = {"tprf": True, "mitransient": True}
    runners = {"tprf": tprf, "mitransient": mt}
    spp, step = 1, 0
    log(f"[{s.name}] race: spp 1, 2, 4, ... until cube error < {100 * stop_error:.2f} % or a "
        f"run takes > {cfg.cap:.0f} s (reference error {100 * ref_err:.3f} % subtracted in quadrature)")
    while any(active.values()) and spp <= cfg.max_spp:
        order = ["tprf", "mitransient"] if step % 2 == 0 else ["mitransient", "tprf"]
        for name in order:
            if not active[name]:
                continue
            load = loadavg()
            r = runners[name].run(spp, 1 + step)
            e_raw = rel_l2(r.cube, ref)
            se_raw = rel_l2(r.cube.sum(2), sref)
            e = math.sqrt(max(e_raw**2 - ref_err**2, 0.0))
            se = math.sqrt(max(se_raw**2 - sref_err**2, 0.0))
            row = {
                "scene": s.name, "renderer": name, "spp": spp, "seed": r.seed,
                "wall_s": r.wall_s, "raw_wall_s": r.raw_wall_s, "render_s": r.render_s,
                "cpu_s": r.cpu_s, "compile_s": r.compile_s,
                "cube_err": e, "steady_err": se, "cube_err_raw": e_raw, "steady_err_raw": se_raw,
                "loadavg": load,
            }  # fmt: skip
            rows.append(row)
            extra = f", compile {r.compile_s:.2f} s left out" if r.compile_s > 0.01 else ""
            render = f", render passes {r.render_s:.3f} s" if name == "tprf" else ""
            log(f"  {name:11s} {spp:6d} spp  {r.wall_s:8.3f} s{render}{extra}  cube {100 * e:7.3f} %  "
                f"steady {100 * se:7.3f} %  (CPU/wall {r.cpu_s / max(r.raw_wall_s, 1e-9):.2f})")
            if e <= stop_error or r.wall_s > cfg.cap:
                active[name] = False
        spp *= 2
        step += 1
    with open(csv_path, "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        wr.writeheader()
        wr.writerows(rows)
    report["rows"] = rows
    return rows


def summarize(s, rows, report, targets=TARGETS):
    by = {n: [r for r in rows if r["renderer"] == n] for n in ("tprf", "mitransient")}
    out = {}
    for n, rs in by.items():
        d = {}
        for key, tcol in (("wall", "wall_s"), ("render", "render_s")):
            pts = [(r[tcol], r["cube_err"]) for r in rs]
            d[key] = {f"{int(100 * x)}%": time_to(pts, x) for x in targets}
            d[key + "_tail_a"] = tail_constant(pts)
        spts = [(r["wall_s"], r["steady_err"]) for r in rs]
        d["steady"] = {f"{int(100 * x)}%": time_to(spts, x) for x in targets}
        big = rs[-1]
        d["per_spp_s"] = big["wall_s"] / big["spp"]
        d["largest_spp"] = big["spp"]
        out[n] = d
    # error at equal spp: mitransient / tprf, geometric mean over the spp both ran (>= 4)
    common = sorted({r["spp"] for r in by["tprf"]} & {r["spp"] for r in by["mitransient"]})
    ratios = []
    for spp in common:
        if spp < 4:
            continue
        et = next(r["cube_err"] for r in by["tprf"] if r["spp"] == spp)
        em = next(r["cube_err"] for r in by["mitransient"] if r["spp"] == spp)
        if et > 0 and em > 0:
            ratios.append(em / et)
    out["err_ratio_equal_spp"] = math.exp(sum(map(math.log, ratios)) / len(ratios)) if ratios else None
    out["err_ratio_spps"] = [x for x in common if x >= 4]
    report["summary"] = out
    return out


def fmt_t(v):
    t, how = v
    if t is None:
        return "n/a"
    s = f"{t:.3g} s" if t < 100 else f"{t:.0f} s"
    return s + (" (fit)" if how == "fit" else "")


def write_markdown(path: Path, cfg, reports, env):
    L = []
    L.append("# tprf vs mitransient: the race\n")
    L.append(f"Run {time.strftime('%Y-%m-%d %H:%M')}; {env['machine']}; {cfg.threads} threads each; "
             f"{env['versions']}; tprf `{env['tprf']}`.\n")
    film = (f"Film {cfg.width} x {cfg.height}, {cfg.bins} bins" if any("film" not in r for r in reports)
            else "Film: the scene file's (below)")
    if any("film" not in r for r in reports) and any("film" in r for r in reports):
        film += " (a scene read from a file: its own, below)"
    L.append(f"{film}; load average at the start {env['load_start']}, at the end {loadavg()}.\n")
    L.append("Times: tprf = wall time of the `tprf render` process (start-up, scene load, BVH, "
             "render, writing the cube); tprf render = `render_seconds` of tprf.json (inside the "
             "render passes); mitransient = wall time of `mi.render` + reading the tensors back, "
             "in one persistent Python process, less Dr.Jit kernel compilation. Cube error = "
             "||x - ref||_2 / ||ref||_2 over [H, W, T], the reference's own error subtracted in "
             "quadrature. *(fit)*: not bracketed by the ladder, from err = a t^-1/2 on the last "
             "three points.\n")
    L.append("## Time to a given cube error\n")
    L.append("| scene | error | tprf | tprf (render passes) | mitransient | mitransient / tprf | mitransient / tprf render |")
    L.append("|---|--:|--:|--:|--:|--:|--:|")
    for rep in reports:
        sm = rep["summary"]
        for x in rep.get("targets", TARGETS):
            k = f"{int(100 * x)}%"
            a, ar, b = sm["tprf"]["wall"][k], sm["tprf"]["render"][k], sm["mitransient"]["wall"][k]
            ratio = b[0] / a[0] if a[0] and b[0] else None
            ratio_r = b[0] / ar[0] if ar[0] and b[0] else None
            L.append(f"| {rep['scene']} | {k} | {fmt_t(a)} | {fmt_t(ar)} | {fmt_t(b)} | "
                     f"{'%.2f' % ratio if ratio else 'n/a'} | {'%.2f' % ratio_r if ratio_r else 'n/a'} |")
    L.append("")
    L.append("## Time to a given steady-image error\n")
    L.append("| scene | error | tprf | mitransient | mitransient / tprf |")
    L.append("|---|--:|--:|--:|--:|")
    for rep in reports:
        sm = rep["summary"]
        for x in rep.get("targets", TARGETS):
            k = f"{int(100 * x)}%"
            a, b = sm["tprf"]["steady"][k], sm["mitransient"]["steady"][k]
            ratio = b[0] / a[0] if a[0] and b[0] else None
            L.append(f"| {rep['scene']} | {k} | {fmt_t(a)} | {fmt_t(b)} | {'%.2f' % ratio if ratio else 'n/a'} |")
    L.append("")
    L.append("## Per sample\n")
    L.append("| scene | tprf s / spp | mitransient s / spp | cost ratio | cube error ratio at equal spp (mt / tprf) | tail a = err sqrt(t): tprf | mitransient | (a_mt / a_tprf)^2 |")
    L.append("|---|--:|--:|--:|--:|--:|--:|--:|")
    for rep in reports:
        sm = rep["summary"]
        ct, cm = sm["tprf"]["per_spp_s"], sm["mitransient"]["per_spp_s"]
        er = sm["err_ratio_equal_spp"]
        at, am = sm["tprf"]["wall_tail_a"], sm["mitransient"]["wall_tail_a"]
        L.append(f"| {rep['scene']} | {ct:.3g} (at {sm['tprf']['largest_spp']} spp) | {cm:.3g} "
                 f"(at {sm['mitransient']['largest_spp']} spp) | {cm / ct:.2f} | "
                 f"{'%.2f' % er if er else 'n/a'} | {at:.3g} | {am:.3g} | {(am / at) ** 2:.2f} |")
    L.append("")
    L.append("## Checks\n")
    L.append("| scene | twin: steady diff (noise) | twin: cube diff (noise) | twin: arrival diff, bins | "
             "ref: tprf vs mt cube, ratio to noise | ref cube error | light after the window (mt) |")
    L.append("|---|--:|--:|--:|--:|--:|--:|")
    for rep in reports:
        tw, rf = rep.get("twin_check", {}), rep["reference"]
        tws = (f"{100 * tw['steady_rel_diff']:.2f} % ({100 * tw['steady_noise']:.2f} %)" if tw else "skipped")
        twc = (f"{100 * tw['cube_rel_diff']:.2f} % ({100 * tw['cube_noise']:.2f} %)" if tw else "skipped")
        twa = f"{tw['arrival_bins_mean_abs_diff']:.3f}" if tw else "skipped"
        L.append(f"| {rep['scene']} | {tws} | {twc} | {twa} | {100 * rf['cube_rel_diff']:.2f} %, "
                 f"{rf['cube_chi2_ratio']:.2f} | {100 * rf['ref_cube_err']:.3f} % | "
                 f"{100 * rf['mt_energy_past_window']:.2f} % |")
    L.append("")
    L.append("## Scenes\n")
    for rep in reports:
        film = f"{rep['film'][0]} x {rep['film'][1]}, " if "film" in rep else ""
        L.append(f"- **{rep['scene']}**: {rep['about']}; {film}window 0 to {rep['window_opl']:.2f} m of "
                 f"optical path ({rep.get('bins', cfg.bins)} bins of {rep['bin_width_opl'] * 100:.3f} cm).")
    L.append("")
    path.write_text("\n".join(L) + "\n")


def maybe_plot(path: Path, reports):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except Exception:  # noqa: BLE001
        return False
    fig, axes = plt.subplots(1, len(reports), figsize=(5 * len(reports), 4), squeeze=False)
    for ax, rep in zip(axes[0], reports):
        for n, style in (("tprf", "o-"), ("mitransient", "s-")):
            rs = [r for r in rep["rows"] if r["renderer"] == n]
            ax.loglog([r["wall_s"] for r in rs], [100 * r["cube_err"] for r in rs], style, label=f"{n} cube")
            ax.loglog([r["wall_s"] for r in rs], [100 * r["steady_err"] for r in rs], style, alpha=0.4,
                      label=f"{n} steady")
        for x in rep.get("targets", TARGETS):
            ax.axhline(100 * x, color="grey", lw=0.5)
        ax.set_title(rep["scene"])
        ax.set_xlabel("wall time, s")
        ax.set_ylabel("relative L2 error, %")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return True


# --------------------------------------------------------------------------------------


PRESETS = {
    # a minute or two: checks that everything works end to end
    "quick": dict(width=32, height=24, bins=64, twin_spp=256, pilot_spp=4, ref_error=0.005,
                  ref_seconds=40, cap=4.0, stop_error=0.01, max_spp=1 << 14),
    # the race proper (about 10-20 minutes on 2 cores for the two default scenes)
    "full": dict(width=64, height=48, bins=256, twin_spp=256, pilot_spp=8, ref_error=0.0035,
                 ref_seconds=600, cap=120.0, stop_error=0.01, max_spp=1 << 16),
}  # fmt: skip


def setup_venv(venv: Path):
    log(f"creating a venv in {venv} with mitsuba=={MITSUBA_VERSION} mitransient=={MITRANSIENT_VERSION} numpy")
    subprocess.check_call([sys.executable, "-m", "venv", str(venv)])
    py = venv / "bin" / "python"
    subprocess.check_call([str(py), "-m", "pip", "install", "--upgrade", "pip"])
    subprocess.check_call([str(py), "-m", "pip", "install", f"mitsuba=={MITSUBA_VERSION}",
                           f"mitransient=={MITRANSIENT_VERSION}", "numpy"])
    log("mitsuba's LLVM variants also need libLLVM, which pip does not install. On Debian/Ubuntu:")
    log("    sudo apt-get install libllvm19")
    log("    export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
    return py


def find_tprf(arg):
    if arg:
        return Path(arg)
    if os.environ.get("TPRF"):
        return Path(os.environ["TPRF"])
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    return target / "release" / "tprf"


def race_file_scene(n, exe, mi, dr, versions, tprf_version, cfg, out: Path):
    """Reference and race on a scene read from a mitransient checkout (the staircase):
    its film, time axis and max_depth are the file's; no twin check (its light is an
    area light, not the point light the check looks for under; the reference's two long
    renders are still compared against their noise). Targets 20, 10 and 5 % cube error."""
    sdir = out / n
    s = scene_staircase(Path(cfg.mitransient), sdir)
    tprf = Tprf(exe, s.xml, sdir, s.width, s.height, s.bins, s.bin_width_opl, cfg.threads)
    # The file fixes max_depth (65); load it once, whatever depth is asked for.
    mt = Mitransient(mi, dr, lambda depth, f=s.xml: mi.load_file(str(f)), cfg.threads)
    rep = {"scene": n, "about": s.about, "window_opl": s.window_opl, "bin_width_opl": s.bin_width_opl,
           "film": [s.width, s.height], "bins": s.bins, "targets": list(STAIRCASE_TARGETS)}  # fmt: skip
    log(f"\n[{n}] {s.about}; {s.width} x {s.height}, {s.bins} bins of {100 * s.bin_width_opl:.3f} cm; "
        f"files in {sdir}; twin check skipped (an area light)")
    t0 = time.perf_counter()
    mt.scene(-1)
    log(f"  mitransient load_file: {time.perf_counter() - t0:.2f} s (left out of its times)")
    if cfg.twin_only:
        return rep
    key = hashlib.sha256(
        json.dumps([s.xml.read_text(), s.width, s.height, s.bins, versions, tprf_version]).encode()
    ).hexdigest()
    ref, ref_err, sref_err = reference(s, tprf, mt, cfg, rep, sdir / "reference.npz", key)
    rows = race(s, tprf, mt, cfg, ref, ref_err, sref_err, out / f"race_{n}.csv", rep,
                stop_error=STAIRCASE_TARGETS[-1])
    summarize(s, rows, rep, STAIRCASE_TARGETS)
    return rep


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--setup", nargs="?", const=str(REPO / "target" / "race-venv"), metavar="VENV",
                    help="create VENV (default target/race-venv) with the pinned mitsuba, mitransient "
                    "and numpy, then run this script with it")
    ap.add_argument("--preset", choices=PRESETS, default="full")
    ap.add_argument("--scenes", default=DEFAULT_SCENES,
                    help=f"comma-separated, from {', '.join(SCENES)} (default {DEFAULT_SCENES}); 'all' "
                    f"(those four); or {', '.join(FILE_SCENES)} (needs --mitransient)")
    ap.add_argument("--mitransient", metavar="CHECKOUT",
                    help="a mitransient checkout (work tree or bare git repository): the staircase "
                    "scene is built from its examples/ by staircase.py")
    ap.add_argument("--out", default=str(REPO / "out" / "race"), help="output folder (default out/race)")
    ap.add_argument("--tprf", help="tprf binary (default $TPRF, else $CARGO_TARGET_DIR or target/ + release/tprf)")
    ap.add_argument("--build", action="store_true", help="cargo build --release --bin tprf first")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--width", type=int)
    ap.add_argument("--height", type=int)
    ap.add_argument("--bins", type=int)
    ap.add_argument("--twin-spp", type=int)
    ap.add_argument("--pilot-spp", type=int)
    ap.add_argument("--ref-error", type=float, help="cube error the reference aims at (0.0035 = 0.35 %%)")
    ap.add_argument("--ref-seconds", type=float, help="... spending at most this long on it, both renderers")
    ap.add_argument("--ref-max-spp", type=int, default=0)
    ap.add_argument("--cap", type=float, help="a renderer stops climbing the ladder after a run this long, s")
    ap.add_argument("--stop-error", type=float, help="... or once its cube error is at or below this (default 0.01: the 1 %% point is then bracketed)")
    ap.add_argument("--max-spp", type=int)
    ap.add_argument("--twin-tol", type=float, default=0.005,
                    help="systematic difference allowed in the twin check on top of noise (default 0.5 %%)")
    ap.add_argument("--twin-only", action="store_true", help="stop after the twin check")
    ap.add_argument("--skip-twin-check", action="store_true")
    ap.add_argument("--ignore-twin-check", action="store_true", help="race even if the twin check fails")
    ap.add_argument("--new-reference", action="store_true", help="render the reference even if cached")
    cfg = ap.parse_args(argv)

    if cfg.setup:
        venv = Path(cfg.setup)
        py = venv / "bin" / "python"
        if not py.exists():
            py = setup_venv(venv)
        rest = [a for a in (argv if argv is not None else sys.argv[1:]) if not a.startswith("--setup")]
        if cfg.setup in rest:
            rest.remove(cfg.setup)
        log(f"running {py} {__file__} {' '.join(rest)}")
        return subprocess.call([str(py), __file__, *rest])

    for k, v in PRESETS[cfg.preset].items():
        if getattr(cfg, k, None) is None:
            setattr(cfg, k, v)
    cfg.ignore_twin = cfg.ignore_twin_check

    if np is None:
        log("skipped: numpy is not installed (pip install numpy, or run with --setup)")
        return 0
    names = list(SCENES) if cfg.scenes == "all" else [x.strip() for x in cfg.scenes.split(",") if x.strip()]
    for n in names:
        if n not in SCENES and n not in FILE_SCENES:
            raise SystemExit(f"unknown scene '{n}' (have {', '.join((*SCENES, *FILE_SCENES))})")
        if n in FILE_SCENES and not cfg.mitransient:
            raise SystemExit(f"--scenes {n}: give a mitransient checkout with --mitransient PATH")

    loaded, why = load_mitsuba()
    if loaded is None:
        log(f"skipped: {why}")
        return 0
    mi, dr, versions = loaded
    if versions["mitsuba"] != MITSUBA_VERSION or not str(versions["mitransient"]).startswith(MITRANSIENT_VERSION):
        log(f"note: the race is pinned to mitsuba {MITSUBA_VERSION} / mitransient {MITRANSIENT_VERSION}; "
            f"this is {versions}")

    if cfg.build:
        subprocess.check_call(["cargo", "build", "--release", "--bin", "tprf"], cwd=REPO)
    exe = find_tprf(cfg.tprf)
    if not exe.exists():
        raise SystemExit(f"no tprf binary at {exe}: build it (cargo build --release) or pass --tprf PATH")

    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    tprf_version = subprocess.run([str(exe), "--version"], capture_output=True, text=True).stdout.strip()
    env = {
        "machine": machine_line(),
        "versions": ", ".join(f"{k} {v}" for k, v in versions.items()) + f", {tprf_version}",
        "tprf": str(exe),
        "load_start": loadavg(),
        "llvm": os.environ.get("DRJIT_LIBLLVM_PATH", ""),
    }
    log(f"the race: {env['machine']}; {env['versions']}; LLVM {env['llvm']}")
    log(f"preset {cfg.preset}: film {cfg.width} x {cfg.height}, {cfg.bins} bins (a scene read from a file: "
        f"its own), {cfg.threads} threads; output in {out}")

    reports = []
    for n in names:
        if n in FILE_SCENES:
            reports.append(race_file_scene(n, exe, mi, dr, versions, tprf_version, cfg, out))
            (out / "summary.json").write_text(json.dumps({"config": vars(cfg), "env": env, "scenes": reports},
                                                         indent=1, default=str))
            continue
        s = SCENES[n]()
        orient(s)
        bw = s.window_opl / cfg.bins
        sdir = out / n
        sdir.mkdir(exist_ok=True)
        plys = []
        for i, (_, tris) in enumerate(s.groups):
            ply = sdir / f"{n}_walls{i}.ply"
            write_ply(tris, ply)
            plys.append(ply)
        fog_ply = None
        if s.fog_box:
            fog_ply = sdir / f"{n}_fogbox.ply"
            write_ply(s.fog_box, fog_ply)
        if s.medium:
            # Two files (see write_mitsuba_xml): glTF for tprf, a dict for mitransient.
            scene_file = sdir / f"{n}.gltf"
            write_gltf(s, scene_file, cfg.width, cfg.height)
            make = lambda depth, s=s, plys=plys, fp=fog_ply: mi.load_dict(mitsuba_dict(  # noqa: E731
                mi, s, plys, cfg.width, cfg.height, cfg.bins, bw, depth, fp))
        else:
            # One Mitsuba XML file that both renderers read.
            scene_file = sdir / f"{n}.xml"
            write_mitsuba_xml(s, plys, scene_file, cfg.width, cfg.height, cfg.bins, bw)
            make = lambda depth, f=scene_file: mi.load_file(str(f), max_depth=depth)  # noqa: E731
        tprf = Tprf(exe, scene_file, sdir, cfg.width, cfg.height, cfg.bins, bw, cfg.threads)
        mt = Mitransient(mi, dr, make, cfg.threads)
        rep = {"scene": n, "about": s.about, "window_opl": s.window_opl, "bin_width_opl": bw}
        log(f"\n[{n}] {s.about}; {cfg.width} x {cfg.height}, {cfg.bins} bins of {100 * bw:.3f} cm "
            f"(0 to {s.window_opl:.2f} m of optical path = {1e9 * s.window_opl / C:.3f} ns); files in {sdir}")
        if not cfg.skip_twin_check:
            twin_check(s, tprf, mt, cfg, rep)
        if cfg.twin_only:
            reports.append(rep)
            continue
        key = hashlib.sha256(
            json.dumps([scene_file.read_text(), cfg.width, cfg.height, cfg.bins, versions, tprf_version]).encode()
        ).hexdigest()
        ref, ref_err, sref_err = reference(s, tprf, mt, cfg, rep, sdir / "reference.npz", key)
        rows = race(s, tprf, mt, cfg, ref, ref_err, sref_err, out / f"race_{n}.csv", rep)
        summarize(s, rows, rep)
        reports.append(rep)
        (out / "summary.json").write_text(json.dumps({"config": vars(cfg), "env": env, "scenes": reports},
                                                     indent=1, default=str))

    if cfg.twin_only:
        (out / "twin_check.json").write_text(json.dumps(reports, indent=1, default=str))
        log(f"\ntwin check written to {out / 'twin_check.json'}")
        return 0
    write_markdown(out / "summary.md", cfg, reports, env)
    plotted = maybe_plot(out / "race.png", reports)
    log("\n" + (out / "summary.md").read_text())
    log(f"results: {out / 'summary.md'}, {out / 'summary.json'}, "
        + ", ".join(str(out / f"race_{r['scene']}.csv") for r in reports)
        + (f", {out / 'race.png'}" if plotted else " (no plot: matplotlib is not installed)"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
