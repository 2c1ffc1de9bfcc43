"""tprf.nlos: non-line-of-sight captures and reconstructions from Python.

``capture`` is ``tprf nlos`` (a ``CaptureRequest`` built from keyword arguments with the
command's option names) and ``reconstruct`` is ``tprf nlos reconstruct`` (a
``ReconstructRequest``), run by tprf-core (``tprf._tprf``) with the GIL released, with a
progress bar; their results hold numpy arrays.

>>> c = tprf.nlos.capture("builtin:nlos-z", grid=(32, 32), confocal=True, spp=64)
>>> c.H.shape                      # (T, Sx, Sy), float32
>>> v = tprf.nlos.reconstruct(c, method="fk")
>>> v.values.shape, v.peak_m       # (Z, Y, X) and the brightest voxel's centre, metres
"""

from __future__ import annotations

import json
import sys
from os import PathLike
from typing import Any, Optional, Sequence, Union

from . import _tprf
from ._render import Time, _request_json
from ._tprf import NlosCapture as Capture
from ._tprf import NlosVolume as Volume

__all__ = ["Capture", "Volume", "capture", "reconstruct"]


class _Points:
    """A progress bar over the sensor points: tqdm's where it is installed, else one
    line on stderr rewritten in place."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.bar = None
        self.started = False
        self.last_line = 0

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        if not self.started:
            self.started = True
            try:
                from tqdm.auto import tqdm

                self.bar = tqdm(total=total, unit="point", desc="tprf nlos", leave=False)
            except ImportError:
                self.bar = None
        if self.bar is not None:
            self.bar.n = done
            self.bar.refresh()
        else:
            line = f"tprf nlos: {done}/{total} sensor points"
            sys.stderr.write("\r" + line.ljust(self.last_line))
            sys.stderr.flush()
            self.last_line = len(line)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        elif self.enabled and self.last_line:
            sys.stderr.write("\r" + " " * self.last_line + "\r")
            sys.stderr.flush()


def capture(scene: Union[str, PathLike], *, grid: Optional[Sequence[int]] = None,
            confocal: bool = False, exhaustive: bool = False,
            laser_grid: Optional[Sequence[int]] = None,
            laser_point: Optional[Sequence[float]] = None,
            laser_origin: Optional[Sequence[float]] = None,
            sensor_origin: Optional[Sequence[float]] = None,
            bins: Optional[int] = None, dt: Optional[Time] = None, t0: Optional[Time] = None,
            unwarped: bool = False, spp: Optional[int] = None, seed: Optional[int] = None,
            max_bounces: Optional[int] = None, channel: Optional[str] = None,
            relay_wall: Optional[str] = None, threads: Optional[int] = None,
            progress: bool = True) -> Capture:
    """Capture ``scene`` (``"builtin:nlos-z"``, ``"builtin:nlos-shapes"``, a glTF or a
    Mitsuba NLOS scene) in memory: the transients ``tprf nlos`` renders with the same
    settings and seed (``H.npy`` bit for bit).

    grid: sensor points on the relay wall along its u and v (default 64 x 64).
    confocal: the laser at each sensor point in turn; exhaustive: every point of
    ``laser_grid`` (default 8 x 8) with every sensor point; else one laser point,
    ``laser_point`` (metres, default the wall's centre). laser_origin, sensor_origin: the
    devices (metres; default tal's). bins (default: up to the longest three-bounce
    path), dt (default 3 mm of optical path), t0 (default 0): each seconds or text with a
    unit (``"3mm"``, ``"10ps"``). unwarped: times without the device-to-wall legs. spp:
    samples per sensor point (default 256); max_bounces: scattering events in the hidden
    scene (default 1024); channel: ``red``, ``green``, ``blue``, ``gray``. A Mitsuba NLOS
    scene's capture meter and integrator stand in for the settings not given, as for
    ``tprf nlos`` (said on stderr with ``progress``).

    Returns a ``Capture``: ``H`` (float32 ``[T, Sx, Sy]``, or ``[T, Lx, Ly, Sx, Sy]``
    exhaustive), ``sensor_grid`` and ``laser_grid`` (``[X, Y, 3]`` metres),
    ``wall_normal``, ``t0_s``, ``dt_s``, ``bins``, ``metadata`` (``nlos.json``),
    ``save(folder)``. Ctrl-C raises KeyboardInterrupt at once (the sensor points running
    end first); bad settings raise ValueError naming the setting.
    """
    fields = dict(grid=grid, confocal=confocal or None, exhaustive=exhaustive or None,
                  laser_grid=laser_grid, laser_point=laser_point, laser_origin=laser_origin,
                  sensor_origin=sensor_origin, bins=bins, dt=dt, t0=t0,
                  unwarped=unwarped or None, spp=spp, seed=seed, max_bounces=max_bounces,
                  channel=channel, relay_wall=relay_wall, threads=threads)
    request = _request_json(scene, {k: _listed(v) for k, v in fields.items()})
    bar = _Points(progress)
    try:
        result, from_file = _tprf.capture(request, bar)
    finally:
        bar.close()
    if progress:
        for line in from_file:
            sys.stderr.write(f"tprf: from the scene file: {line}\n")
    return result


def reconstruct(capture_or_folder: Union[Capture, str, PathLike], *, method: str = "fbp",
                volume: Optional[Union[str, dict]] = None,
                center: Optional[Sequence[float]] = None,
                size: Optional[Sequence[float]] = None,
                voxels: Optional[Sequence[int]] = None,
                wavelength: Optional[Union[float, str]] = None,
                threads: Optional[int] = None) -> Volume:
    """Reconstruct the hidden scene of a capture (a ``Capture`` in memory, a ``tprf nlos``
    folder or a tal HDF5 file) onto a voxel volume: the volume ``tprf nlos reconstruct``
    makes with the same settings.

    method: ``bp``, ``fbp`` (the default), ``fk`` (f-k migration, confocal captures) or
    ``pf`` (phasor fields). The volume: ``center`` (world, metres), ``size`` (along the
    wall's u, v and normal, metres) and ``voxels`` (along them) together, or ``volume``
    as ``tprf nlos reconstruct --volume`` takes it (``"CX,CY,CZ:SX,SY,SZ:NX,NY,NZ"``) or
    as a dict of the three; none: the sensor grid's extent and lattice, from the wall to
    the farthest depth the time axis reaches. wavelength: the phasor-field kernel's
    (fbp, pf), metres or text with a unit (``"5cm"``).

    Returns a ``Volume``: ``values`` (float32 ``[Z, Y, X]``, X along the wall's u, Y
    along v, Z along its normal), ``axes`` (the voxel centres along u, v, n from
    ``center``), ``u``, ``v``, ``n``, ``peak_m``, ``metadata`` (``volume.json``),
    ``save(folder)``. Ctrl-C raises KeyboardInterrupt at once.
    """
    parts = (center, size, voxels)
    if any(p is not None for p in parts):
        if volume is not None or any(p is None for p in parts):
            raise TypeError("give the volume as center, size and voxels together, or as "
                            "volume, not both")
        volume = dict(center=list(center), size=list(size), voxels=list(voxels))
    in_memory = isinstance(capture_or_folder, Capture)
    fields = dict(method=method, volume=volume, wavelength=wavelength, threads=threads)
    request = {"capture": "" if in_memory else str(capture_or_folder)}
    request.update({k: _listed(v) for k, v in fields.items() if v is not None})
    text = json.dumps(request)
    if in_memory:
        return _tprf.reconstruct(text, capture_or_folder)
    return _tprf.reconstruct(text)


def _listed(value: Any) -> Any:
    """Tuples (and numpy arrays) as lists, for the request's JSON."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, tuple):
        return list(value)
    return value
