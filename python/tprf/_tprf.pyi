"""Type stubs of tprf's native module."""

from os import PathLike
from typing import Any, Callable, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class Cube:
    """A transient cube: per pixel the radiance against arrival time for a unit-energy
    pulse leaving the light at t = 0."""

    @property
    def data(self) -> npt.NDArray[np.float32]:
        """float32 [H, W, T], row 0 = top; a bin holds the integral over the bin of the
        pixel's radiance (W m^-2 sr^-1 s per unit pulse energy). No copy."""
    @property
    def steady(self) -> npt.NDArray[np.float32]:
        """float32 [H, W]: the steady radiance (W m^-2 sr^-1), each pixel's sum over time."""
    @property
    def bounces(self) -> Optional[npt.NDArray[np.float32]]:
        """float32 [K + 2, H, W, T] per-bounce layers, or None."""
    @property
    def ambient(self) -> Optional[npt.NDArray[np.float32]]:
        """float32 [H, W]: the steady radiance of the scene's unpulsed light (sky,
        lamps), W m^-2 sr^-1, or None."""
    def save(self, dir: Union[str, PathLike[str]], format: str = "auto",
             frames: bool = False) -> None:
        """Write the cube folder tprf render writes (tprf.npy or tprf.zarr, tprf.json,
        steady.png, bounce layers, ambient image); dir must be new, empty or an earlier
        tprf output."""
    @property
    def t0_s(self) -> float:
        """Start of the time window, seconds."""
    @property
    def dt_s(self) -> float:
        """Bin width, seconds."""
    @property
    def times_s(self) -> npt.NDArray[np.float64]:
        """Bin centres, seconds, [T]."""
    @property
    def error_estimate(self) -> Optional[float]:
        """Relative RMS error from two independent sample halves, or None."""
    @property
    def metadata(self) -> dict[str, Any]:
        """The tprf.json of the cube, as a dict."""
    @property
    def shape(self) -> Tuple[int, int, int]:
        """(H, W, T)."""
    def __array__(self, dtype: Any = None, copy: Optional[bool] = None) -> np.ndarray: ...

def load(dir: Union[str, PathLike[str]]) -> Cube:
    """Read a cube folder written by tprf render (tprf.npy or tprf.zarr, tprf.json)."""

Progress = Callable[[int, int, Optional[float], float], None]
"""progress(spp, passes, error_estimate, wall_s), called after each pass."""

def render(request_json: str, progress: Optional[Progress] = None) -> Cube:
    """Render a request (JSON, tprf render's option names) in memory; tprf.render builds
    it from keyword arguments."""

class Renderer:
    """A progressive render of a request (JSON); tprf.Renderer wraps it."""

    def __init__(self, request_json: str) -> None: ...
    def run(self, seconds: Optional[float] = None, spp: Optional[int] = None,
            passes: Optional[int] = None, progress: Optional[Progress] = None) -> bool:
        """Add passes until a limit or the request's target; whether the target is met."""
    def cube(self) -> Cube:
        """The film so far."""
    @property
    def spp(self) -> int: ...
    @property
    def passes(self) -> int: ...
    @property
    def error_estimate(self) -> Optional[float]: ...
    @property
    def done(self) -> bool: ...
    @property
    def request(self) -> dict[str, Any]: ...
