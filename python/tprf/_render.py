"""tprf.render and tprf.Renderer: a render request built from keyword arguments, run
by tprf-core (``tprf._tprf``) with the GIL released, with a progress bar."""

from __future__ import annotations

import json
import math
import sys
import warnings
from os import PathLike
from typing import Any, Callable, Iterator, Optional, Union

from . import _tprf
from ._tprf import Cube

Time = Union[float, int, str]
"""A time: seconds (a number), or text with a unit as the command line takes it:
``"50ps"``, ``"3 ns"``, ``"1.5m"`` (metres of optical path, t = opl / c)."""

# tprf-core's default samples per pixel when nothing else says when to stop
# (request::DEFAULT_SPP); only the progress bar's total depends on it.
_DEFAULT_SPP = 64


def _request_json(scene: Union[str, PathLike], fields: dict) -> str:
    """The request as JSON with tprf render's option names; unset (None) fields left
    out so that they take the core's defaults."""
    request = {"scene": str(scene)}
    for name, value in fields.items():
        if value is None:
            continue
        if isinstance(value, PathLike):
            value = str(value)
        if isinstance(value, tuple):
            value = list(value)
        if isinstance(value, float) and not math.isfinite(value):
            # JSON has no NaN or infinity: say which field, as the core would.
            raise ValueError(f"{name} = {value} must be a finite number")
        request[name] = value
    try:
        return json.dumps(request)
    except TypeError as e:
        raise TypeError(f"a render setting is not a number, text or list: {e}") from None


class _Progress:
    """A progress bar fed by the core after each pass: tqdm's where it is installed
    (tqdm.auto: a widget in notebooks), else one line on stderr rewritten in place."""

    def __init__(self, total_spp: Optional[int], seconds: Optional[float], enabled: bool):
        self.enabled = enabled
        self.total_spp, self.seconds = total_spp, seconds
        self.bar = None
        self.started = False
        self.last_line = 0

    def _start(self) -> None:
        """The bar, made at the first pass (a request refused shows none)."""
        self.started = True
        try:
            from tqdm.auto import tqdm
        except ImportError:
            return
        total_spp, seconds = self.total_spp, self.seconds
        if total_spp is not None:
            self.bar = tqdm(total=total_spp, unit="spp", desc="tprf render", leave=False)
        elif seconds is not None:
            self.bar = tqdm(total=round(seconds, 1), unit="s", desc="tprf render", leave=False,
                            bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s {postfix}")
        else:
            self.bar = tqdm(unit="spp", desc="tprf render", leave=False)

    def __call__(self, spp: int, passes: int, error: Optional[float], wall_s: float) -> None:
        if not self.enabled:
            return
        if not self.started:
            self._start()
        err = "" if error is None else f"{100 * error:.2f} %"
        if self.bar is not None:
            if self.total_spp is None and self.seconds is not None:
                self.bar.n = min(round(wall_s, 1), self.bar.total)
            else:
                self.bar.n = spp
            self.bar.set_postfix_str(f"{spp} spp, {passes} passes" + (f", error {err}" if err else ""),
                                     refresh=False)
            self.bar.refresh()
        else:
            line = f"tprf render: {spp} spp, {passes} passes, {wall_s:.1f} s" + (
                f", error estimate {err}" if err else "")
            sys.stderr.write("\r" + line.ljust(self.last_line))
            sys.stderr.flush()
            self.last_line = len(line)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        elif self.enabled and self.last_line:
            sys.stderr.write("\r" + " " * self.last_line + "\r")
            sys.stderr.flush()


def render(scene: Union[str, PathLike], *, width: Optional[int] = None,
           height: Optional[int] = None,
           spp: Optional[int] = None, seconds: Optional[float] = None,
           bins: Optional[int] = None, t0: Optional[Time] = None, dt: Optional[Time] = None,
           seed: int = 0, uniform: bool = False, max_bounces: Optional[int] = None,
           bounces_separate: int = 0, threads: Optional[int] = None,
           progress: bool = True, **options: Any) -> Cube:
    """Render ``scene`` (``"builtin:cornell"``, ``"builtin:flim"``..., a ``.gltf``/``.glb`` path) into a
    transient cube in memory: the same passes, numbers and metadata as ``tprf render``
    with the same settings and seed (``tprf.npy`` bit for bit).

    width, height: pixels (default 256). spp: samples per pixel to stop at; seconds:
    wall time after which the render stops at the end of its pass (with neither, nor
    ``error_target``, 64 spp). bins: time bins (default 256); t0: start of the window,
    dt: bin width, each seconds or text with a unit (``"50ps"``, ``"1.5m"`` of optical
    path); unset, a pilot render chooses them. A Mitsuba scene file's film (size,
    ``temporal_bins``, ``start_opl``, ``bin_width_opl``), ``sample_count`` and
    ``max_depth`` stand in for the settings not given, as for ``tprf render``; with
    ``progress``, what was taken is said on stderr. uniform: every pixel draws every sample (default: adaptive).
    max_bounces: scattering events per path (default 1024). bounces_separate: K > 0 adds
    layers for light seen directly, after 1..K events and more (``Cube.bounces``).
    threads: worker threads (default one per core; the cube does not depend on it).
    progress: a progress bar on stderr (tqdm where installed).

    Any other setting of ``tprf render`` by its name: ``error_target=0.01``,
    ``camera_position=(x, y, z)``, ``look_at=(x, y, z)``, ``up``, ``fov`` (degrees),
    ``time_origin`` (``"pinhole"``, ``"near-plane"``, ``"first-hit"``),
    ``sky`` (W m^-2 sr^-1), ``channel``, ``nee``, ``splits``, ``filter``,
    ``min_bounces`` (fewest scattering events of a recorded path), ...

    Ctrl-C raises KeyboardInterrupt at once (the render stops at the end of its pass).
    Bad settings raise ValueError naming the setting; a missing scene FileNotFoundError.

    Memory: ``max_memory`` (bytes, or text with a unit: ``"2GiB"``) bounds the film, as
    do free memory, a cgroup and ``ulimit -v``. A render whose first pass cannot fit
    raises ValueError with the size foreseen; one whose next pass would not fit stops at
    its last whole pass and returns the cube of the passes made, with a RuntimeWarning
    and ``metadata["stopped"]`` saying so (as ``tprf render`` exits with status 3).
    """
    fields = dict(width=width, height=height, spp=spp, seconds=seconds, bins=bins, t0=t0,
                  dt=dt, seed=seed, uniform=uniform, max_bounces=max_bounces,
                  bounces_separate=bounces_separate, threads=threads, **options)
    request, from_file = _tprf.resolve_request(_request_json(scene, fields))
    if progress:
        for line in from_file:
            sys.stderr.write(f"tprf: from the scene file: {line}\n")
    resolved = json.loads(request)
    total = resolved.get("spp")
    if total is None and seconds is None and resolved.get("error_target") is None:
        total = _DEFAULT_SPP
    bar = _Progress(total, seconds, progress)
    try:
        cube = _tprf.render(request, bar)
    finally:
        bar.close()
    stopped = cube.metadata.get("stopped")
    if stopped:
        warnings.warn(f"tprf: {stopped['message']}", RuntimeWarning, stacklevel=2)
    return cube


class Renderer:
    """A render made progressively, for watching it converge: ``run`` adds passes,
    ``cube()`` is the film so far, and iterating yields the film after every pass.

    The settings are ``tprf.render``'s, but for ``seconds``, which is ``run``'s: with no
    ``spp`` and no ``error_target`` the render goes on as long as it is run.

    >>> r = tprf.Renderer("builtin:cornell", width=64, height=64, error_target=0.02)
    >>> for cube in r:                      # a pass at a time, until 2 %
    ...     print(cube.metadata["spp"], cube.error_estimate)
    """

    def __init__(self, scene: Union[str, PathLike], *, width: Optional[int] = None,
                 height: Optional[int] = None,
                 spp: Optional[int] = None, error_target: Optional[float] = None,
                 bins: Optional[int] = None, t0: Optional[Time] = None,
                 dt: Optional[Time] = None, seed: int = 0, uniform: bool = False,
                 max_bounces: Optional[int] = None, bounces_separate: int = 0,
                 threads: Optional[int] = None, **options: Any):
        if "seconds" in options:
            raise TypeError("Renderer takes no seconds: give them to run(seconds=...)")
        fields = dict(width=width, height=height, spp=spp, error_target=error_target,
                      bins=bins, t0=t0, dt=dt, seed=seed, uniform=uniform,
                      max_bounces=max_bounces, bounces_separate=bounces_separate,
                      threads=threads, until_stopped=spp is None and error_target is None,
                      **options)
        self._target_spp = spp
        self._native = _tprf.Renderer(_request_json(scene, fields))

    def run(self, seconds: Optional[float] = None, *, spp: Optional[int] = None,
            passes: Optional[int] = None, progress: bool = True) -> Cube:
        """Add passes until ``seconds`` of wall time, ``spp`` samples per pixel in the
        film, ``passes`` passes, or the render's own target, whichever comes first (a
        pass is never cut); the film then, as a Cube. Ctrl-C raises KeyboardInterrupt at
        once: the film keeps every pass made, and the next call goes on from it. A next
        pass that would not fit in memory (``max_memory``, free memory) raises
        MemoryError saying so, the film keeping the passes made (``cube()``)."""
        if seconds is None and spp is None and passes is None and self._target_spp is None \
                and not self._has_error_target():
            raise ValueError("this render has no target (spp or error_target): give run "
                             "seconds, spp or passes")
        total = spp if spp is not None else self._target_spp
        bar = _Progress(total, seconds, progress)
        try:
            self._native.run(seconds=seconds, spp=spp, passes=passes, progress=bar)
        finally:
            bar.close()
        return self._native.cube()

    def step(self) -> Cube:
        """One more pass; the film then."""
        self._native.run(passes=1)
        return self._native.cube()

    def __iter__(self) -> Iterator[Cube]:
        """The film after each pass, until the render's target (forever without one:
        break out of the loop)."""
        while not self._native.done:
            yield self.step()

    def cube(self) -> Cube:
        """The film so far."""
        return self._native.cube()

    def _has_error_target(self) -> bool:
        return self._native.request.get("error_target") is not None

    @property
    def spp(self) -> int:
        """Samples per pixel in the film."""
        return self._native.spp

    @property
    def passes(self) -> int:
        """Passes made."""
        return self._native.passes

    @property
    def error_estimate(self) -> Optional[float]:
        """Relative RMS error of the film from two independent halves (None before two
        passes)."""
        return self._native.error_estimate

    @property
    def done(self) -> bool:
        """Whether the render's target (spp, error_target) is met."""
        return self._native.done

    @property
    def request(self) -> dict:
        """The settings, by tprf render's option names."""
        return self._native.request

    def __repr__(self) -> str:
        return repr(self._native).replace("tprf.Renderer", f"tprf.Renderer at {self.spp} spp")
