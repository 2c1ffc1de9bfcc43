#!/usr/bin/env python3
"""mitransient's staircase made comparable: one Mitsuba 3 XML that tprf and mitransient read.

The scene is Bitterli's staircase as mitransient ships it (examples/diff-transient/staircase:
774 OBJ meshes, 10 JPEG textures, a window-sized `rectangle` area light of radiance 30).
It is not vendored: this script builds the variant of issue 48 from a mitransient
checkout (a work tree, or a bare git repository, read with `git archive`), so that

- its six `roughplastic` BSDFs become `diffuse` ones with the same diffuse reflectance
  (texture or colour; tprf has no rough plastic, so both renderers see the same surfaces),
- `camera_unwarp` is false (arrival times counted from the camera, tprf's convention),
- the film is 32 x 56 px (its default `resx` / `resy`; the original is 720 x 1280, same
  aspect within 2 %), 400 bins of 0.1 m optical path from 0 (the original's axis),
- the sensor's `near_clip` is 0.1 mm, as the race's scenes have it: mitransient counts the
  optical path from the near plane, so its default 1 cm would make every arrival early.

Everything else (the camera, the other materials, the meshes and textures, `max_depth` 65)
is the original's. The XML, `models/` and `textures/` go to OUT (links to the checkout's
folders for a work tree; extracted files for a bare repository).

    python benches/race/staircase.py /path/to/mitransient out/staircase
    tprf render out/staircase/staircase.xml --spp 64 --out out/staircase/render

Used by the engine profile and the error-per-sample measurement in docs/benchmarks.md
("The staircase"); `build()` is importable.
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
import tarfile
import xml.etree.ElementTree as ET
from pathlib import Path

SCENE_DIR = "examples/diff-transient/staircase"
WIDTH_PX = 32
HEIGHT_PX = 56
BINS = 400
BIN_WIDTH_OPL_M = 0.1
NEAR_CLIP_M = 1e-4


class BuildError(Exception):
    """A checkout without the staircase, or a scene file this script cannot rewrite."""


def _is_bare_git(path: Path) -> bool:
    return (path / "HEAD").is_file() and (path / "objects").is_dir() and not (path / ".git").exists()


def _source_files(checkout: Path, out: Path) -> Path:
    """The staircase's folder: in the work tree, or extracted from a bare repository into
    OUT/_source. Returns the folder holding scene.xml, models/ and textures/."""
    if _is_bare_git(checkout):
        dest = out / "_source"
        if not (dest / SCENE_DIR / "scene.xml").is_file():
            dest.mkdir(parents=True, exist_ok=True)
            archive = subprocess.run(
                ["git", "-C", str(checkout), "archive", "HEAD", SCENE_DIR],
                capture_output=True,
            )
            if archive.returncode != 0:
                raise BuildError(
                    f"{checkout}: `git archive HEAD {SCENE_DIR}` failed: "
                    f"{archive.stderr.decode(errors='replace').strip()}"
                )
            with tarfile.open(fileobj=io.BytesIO(archive.stdout)) as tar:
                tar.extractall(dest, filter="data")
        return dest / SCENE_DIR
    folder = checkout / SCENE_DIR
    if not (folder / "scene.xml").is_file():
        raise BuildError(f"{folder / 'scene.xml'}: not found (give a mitransient checkout)")
    return folder


def _set_default(root: ET.Element, name: str, value) -> None:
    for d in root.findall("default"):
        if d.get("name") == name:
            d.set("value", str(value))
            return
    raise BuildError(f"scene.xml: no <default name=\"{name}\">")


def _diffuse_from_roughplastic(bsdf: ET.Element) -> None:
    """Rewrite a `roughplastic` element in place as a `diffuse` one whose `reflectance`
    is the plastic's `diffuse_reflectance` (a texture or a colour)."""
    reflectance = None
    for child in list(bsdf):
        if child.get("name") == "diffuse_reflectance":
            reflectance = child
        bsdf.remove(child)
    if reflectance is None:
        raise BuildError(f"roughplastic {bsdf.get('id')!r}: no diffuse_reflectance")
    reflectance.set("name", "reflectance")
    bsdf.attrib = {k: v for k, v in bsdf.attrib.items() if k == "id"}
    bsdf.set("type", "diffuse")
    bsdf.append(reflectance)


def rewrite(xml_text: str) -> tuple[str, dict]:
    """The comparable variant of the staircase's scene.xml, and what was changed."""
    root = ET.fromstring(xml_text)
    changed = {"roughplastic_to_diffuse": 0}
    for bsdf in root.iter("bsdf"):
        if bsdf.get("type") == "roughplastic":
            _diffuse_from_roughplastic(bsdf)
            changed["roughplastic_to_diffuse"] += 1
    unwarp = [b for b in root.iter("boolean") if b.get("name") == "camera_unwarp"]
    if not unwarp:
        raise BuildError("scene.xml: no camera_unwarp in the integrator")
    for b in unwarp:
        b.set("value", "false")
    _set_default(root, "resx", WIDTH_PX)
    _set_default(root, "resy", HEIGHT_PX)
    sensor = root.find("sensor")
    film = sensor.find("film") if sensor is not None else None
    if film is None:
        raise BuildError("scene.xml: no sensor with a film")
    for tag, name, value in [
        ("integer", "temporal_bins", BINS),
        ("float", "start_opl", 0),
        ("float", "bin_width_opl", BIN_WIDTH_OPL_M),
    ]:
        el = next((e for e in film.findall(tag) if e.get("name") == name), None)
        if el is None:
            el = ET.SubElement(film, tag, {"name": name})
        el.set("value", repr(value) if isinstance(value, float) else str(value))
    clip = next((e for e in sensor.findall("float") if e.get("name") == "near_clip"), None)
    if clip is None:
        clip = ET.Element("float", {"name": "near_clip"})
        sensor.insert(0, clip)
    clip.set("value", repr(NEAR_CLIP_M))
    changed["shapes"] = sum(1 for _ in root.iter("shape"))
    changed["emitters"] = sum(1 for _ in root.iter("emitter"))
    ET.indent(root, space="    ")
    return ET.tostring(root, encoding="unicode") + "\n", changed


def build(checkout: Path, out: Path) -> tuple[Path, dict]:
    """Write OUT/staircase.xml (and OUT/models, OUT/textures) from a mitransient checkout;
    returns the XML's path and what was changed."""
    checkout, out = Path(checkout), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    src = _source_files(checkout, out)
    xml, changed = rewrite((src / "scene.xml").read_text())
    if changed["roughplastic_to_diffuse"] != 6 or changed["emitters"] != 1:
        raise BuildError(
            f"{src / 'scene.xml'}: expected 6 rough plastics and 1 emitter, found "
            f"{changed['roughplastic_to_diffuse']} and {changed['emitters']} "
            "(another version of the staircase?)"
        )
    for folder in ("models", "textures"):
        link = out / folder
        target = (src / folder).resolve()
        if link.is_symlink() or link.exists():
            if link.resolve() == target:
                continue
            if link.is_symlink():
                link.unlink()
            else:
                raise BuildError(f"{link}: exists and is not the checkout's {folder}/")
        os.symlink(target, link, target_is_directory=True)
    path = out / "staircase.xml"
    path.write_text(xml)
    return path, changed


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("checkout", help="mitransient checkout: a work tree or a bare git repository")
    ap.add_argument("out", help="output folder (staircase.xml, models/, textures/)")
    args = ap.parse_args(argv)
    try:
        path, changed = build(Path(args.checkout), Path(args.out))
    except (BuildError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(f"{path}: {changed['shapes']} shapes, {changed['roughplastic_to_diffuse']} rough "
          f"plastics made diffuse, {WIDTH_PX} x {HEIGHT_PX} px, {BINS} bins of "
          f"{BIN_WIDTH_OPL_M} m, camera_unwarp false, near_clip {NEAR_CLIP_M} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
