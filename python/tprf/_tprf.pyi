"""Type stubs of tprf's native module."""

from os import PathLike
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

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
    @property
    def phasor(self) -> Optional[npt.NDArray[np.float32]]:
        """float32 [H, W, F, 2] (real, imaginary): the phasors at the frequencies of
        metadata["phasor"] (a render with phasor="WL_MEAN:WL_SIGMA"), or None."""
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

def resolve_request(request_json: str) -> Tuple[str, List[str]]:
    """The request (JSON) with a Mitsuba scene file's settings in the keys it does not
    give, validated, as JSON; and what came from the file, one line each."""

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

class Differentiable:
    """A request differentiable with respect to named parameters; tprf.Differentiable
    wraps it."""

    def __init__(self, request_json: str, wrt: list[str]) -> None: ...
    @property
    def names(self) -> list[str]: ...
    @property
    def values(self) -> list[float]: ...
    @property
    def axis(self) -> tuple[float, float, int]: ...
    @property
    def shape(self) -> tuple[int, int, int]: ...
    def forward(self, values: list[tuple[str, float]], seed: int,
                progress: Optional[Progress] = None) -> Cube: ...
    def backward(self, weights: Any, seed: int,
                 progress: Optional[Progress] = None) -> list[float]: ...

Time = Union[float, int, str]
"""Seconds, or text with a unit: "2ns", "150ps", "30cm" (of optical path, t = opl / c)."""

class SensorPart:
    """One part of a sensor (sensor.light, .exposure, .noise, .spad). Its numbers are
    attributes in SI units (seconds, hertz, joules, 1/s, degrees, counts); a time may be
    set as text with a unit ("2ns"). A value the sensor refuses raises ValueError naming
    the field (exposure.count = 0: ...) and leaves the sensor as it was."""

    @property
    def kind(self) -> Optional[str]:
        """The kind of pulse or gates ("gaussian", "box", "amcw", "tdc", ...); None for
        the noise and the SPAD."""
    @property
    def fields(self) -> list[dict[str, Any]]:
        """The numbers: dicts with key, label, help, unit, value, min, max, integer."""
    @property
    def knots(self) -> Optional[list[Tuple[float, float]]]:
        """A piecewise_linear envelope's knots [(t_s, value)]; None for other kinds."""
    @knots.setter
    def knots(self, knots: list[Tuple[float, float]]) -> None: ...
    def __getattr__(self, key: str) -> Union[float, int]: ...
    def __setattr__(self, key: str, value: Union[Time, int]) -> None: ...

class Sensor:
    """A time-of-flight sensor as tprf sensor takes it (docs/sensor.md): a light pulse
    Light(t), gates Exposure_i(t) (or a SPAD's TDC bins), noise, derived outputs. A
    measurement is M_i = max(0, Noise + sum_b TPRF[b] K_i[b]), K_i the bin-averaged
    correlation of the light and gate i."""

    PRESETS: list[str]
    """"builtin:gated", "builtin:lidar", "builtin:amcw", "builtin:spad"."""

    def __init__(self, exposure: str, light: Optional[str] = None) -> None:
        """Gates and light as tprf sensor's --exposure and --light take them:
        "box:start=10ns,width=1ns,count=32", "gaussian:centre=5ns,fwhm=2ns" (default
        light: a unit delta at t = 0)."""
    @staticmethod
    def preset(spec: Union[str, PathLike[str]]) -> Sensor:
        """A preset as tprf sensor --preset takes it: "builtin:NAME" or a TOML file."""
    @staticmethod
    def from_toml(path: Union[str, PathLike[str]]) -> Sensor:
        """A sensor file (TOML)."""
    def to_toml(self) -> str:
        """The sensor as a TOML file (times in seconds)."""
    def copy(self) -> Sensor: ...
    name: str
    description: str
    @property
    def light(self) -> SensorPart:
        """The light pulse (a power envelope of integral energy J); set a new one as
        text: sensor.light = "gaussian:centre=5ns,fwhm=2ns"."""
    @light.setter
    def light(self, spec: str) -> None: ...
    @property
    def exposure(self) -> SensorPart:
        """The gates (dimensionless sensitivities); set new ones as text:
        sensor.exposure = "box:start=10ns,width=1ns,count=32"."""
    @exposure.setter
    def exposure(self, spec: str) -> None: ...
    @property
    def noise(self) -> SensorPart:
        """sigma (Gaussian, measurement units), photons_per_energy (0: no photon noise)."""
    @property
    def spad(self) -> Optional[SensorPart]:
        """The SPAD (cycles, pde, photons_per_unit, rates in 1/s, dead_time_s, ...), or None."""
    seed: int
    """Seed of the noise and of the SPAD's realisation."""
    ambient_scale: float
    """Scale of the cube's ambient image, dimensionless (1: as rendered, 0: off)."""
    @property
    def ambient_exposure_s(self) -> Optional[float]:
        """AMCW only: seconds of ambient light per unit of emitted energy, or None."""
    @ambient_exposure_s.setter
    def ambient_exposure_s(self, value: Optional[Time]) -> None: ...
    def measure_vjp(self, cube: Cube, weights: npt.NDArray[np.float32],
                    fields: Sequence[str] = ()) -> Tuple[Dict[str, float], npt.NDArray[np.float32]]:
        """The gradient of sum(weights * clean measurement) with respect to the light's and
        gates' fields ("light.centre_s", "exposure.start_s", ...) and to the cube."""
    def measure(self, cube: Union[Cube, str, PathLike[str]], *, seed: Optional[int] = None,
                ambient_scale: Optional[float] = None, ambient_exposure: Optional[Time] = None,
                cycles: Optional[int] = None, noise_sigma: Optional[float] = None,
                photons_per_energy: Optional[float] = None,
                pixels: Sequence[Tuple[int, int]] = ()) -> Measurement:
        """Measure a cube (or a render folder) as tprf sensor does, bit for bit; the
        keywords override the sensor's settings for this measurement, as tprf sensor's
        options do. The GIL is released meanwhile."""

class Measurement:
    """A sensor's measurement: tprf sensor's arrays as read-only numpy arrays (no copies)."""

    @property
    def images(self) -> npt.NDArray[np.float32]:
        """M_i, float32 [N, H, W] (sensor.npy): ambient light and noise included, in the
        unit of a cube bin (W m^-2 sr^-1 s per unit pulse energy) times the light's energy."""
    @property
    def clean(self) -> npt.NDArray[np.float32]:
        """sum_b TPRF[b] K_i[b], float32 [N, H, W]: before ambient light and noise."""
    @property
    def depth(self) -> Optional[npt.NDArray[np.float32]]:
        """First-return depth [H, W], metres (NaN: no return), or None."""
    @property
    def amcw_phase(self) -> Optional[npt.NDArray[np.float32]]:
        """AMCW phase [H, W], radians in [0, 2 pi), or None."""
    @property
    def amcw_amplitude(self) -> Optional[npt.NDArray[np.float32]]:
        """AMCW amplitude [H, W], measurement units, or None."""
    @property
    def amcw_depth(self) -> Optional[npt.NDArray[np.float32]]:
        """AMCW depth [H, W], metres in [0, c / 2f), or None."""
    @property
    def true_depth(self) -> Optional[npt.NDArray[np.float32]]:
        """The AMCW depth's reference [H, W], metres, or None."""
    @property
    def multipath_error(self) -> Optional[npt.NDArray[np.float32]]:
        """amcw_depth - true_depth wrapped into [-c/4f, c/4f), metres, [H, W], or None."""
    @property
    def flim_lifetime(self) -> Optional[npt.NDArray[np.float32]]:
        """FLIM's two-gate lifetime dt / ln(M1 / M2) [H, W], seconds, or None."""
    @property
    def spad_histogram(self) -> Optional[npt.NDArray[np.float32]]:
        """Expected SPAD counts over all cycles, [B, H, W], or None."""
    @property
    def spad_counts(self) -> Optional[npt.NDArray[np.float32]]:
        """One seeded realisation of the SPAD's counts, [B, H, W], or None."""
    @property
    def spad_coates(self) -> Optional[npt.NDArray[np.float32]]:
        """Coates estimate of spad_counts (NaN: bin never armed), [B, H, W], or None."""
    @property
    def spad_depth_histogram(self) -> Optional[npt.NDArray[np.float32]]:
        """First-return depth of spad_histogram [H, W], metres, or None."""
    @property
    def spad_depth_counts(self) -> Optional[npt.NDArray[np.float32]]:
        """First-return depth of spad_counts [H, W], metres, or None."""
    @property
    def spad_depth_coates(self) -> Optional[npt.NDArray[np.float32]]:
        """First-return depth of spad_coates [H, W], metres, or None."""
    @property
    def spad_bin_centres_s(self) -> Optional[npt.NDArray[np.float64]]:
        """TDC bin centres in the first cycle, seconds, [B], or None."""
    @property
    def gate_centres_s(self) -> npt.NDArray[np.float64]:
        """Each gate's centre, seconds after the trigger (NaN: none), [N]."""
    @property
    def sensor(self) -> Sensor:
        """The sensor measured with, measure's keywords applied."""
    @property
    def notes(self) -> list[str]:
        """tprf sensor's notes (also given as warnings)."""
    @property
    def shape(self) -> Tuple[int, int, int]:
        """(N, H, W)."""
    def save(self, dir: Union[str, PathLike[str]]) -> None:
        """Write tprf sensor's output folder (the same files); dir must be new, empty or
        an earlier tprf output, and not the measured render folder."""


class NlosCapture:
    """An NLOS capture (tprf.nlos.Capture): the transients of the relay wall's sensor
    points for a unit-energy laser pulse at its laser points."""
    @property
    def H(self) -> np.ndarray: ...
    @property
    def sensor_grid(self) -> np.ndarray: ...
    @property
    def laser_grid(self) -> np.ndarray: ...
    @property
    def wall_normal(self) -> Tuple[float, float, float]: ...
    @property
    def sensor_origin(self) -> Tuple[float, float, float]: ...
    @property
    def laser_origin(self) -> Tuple[float, float, float]: ...
    @property
    def t0_s(self) -> float: ...
    @property
    def dt_s(self) -> float: ...
    @property
    def bins(self) -> int: ...
    @property
    def device_legs(self) -> bool: ...
    @property
    def scan(self) -> str: ...
    @property
    def metadata(self) -> Dict[str, Any]: ...
    @property
    def request(self) -> Dict[str, Any]: ...
    def save(self, folder: Union[str, PathLike[str]]) -> None: ...


class NlosVolume:
    """A reconstruction (tprf.nlos.Volume): values [Z, Y, X] on a voxel volume in the
    relay wall's frame."""
    @property
    def values(self) -> np.ndarray: ...
    @property
    def center(self) -> Tuple[float, float, float]: ...
    @property
    def size_m(self) -> Tuple[float, float, float]: ...
    @property
    def voxels(self) -> Tuple[int, int, int]: ...
    @property
    def u(self) -> Tuple[float, float, float]: ...
    @property
    def v(self) -> Tuple[float, float, float]: ...
    @property
    def n(self) -> Tuple[float, float, float]: ...
    @property
    def axes(self) -> Tuple[np.ndarray, np.ndarray, np.ndarray]: ...
    @property
    def peak_voxel(self) -> Tuple[int, int, int]: ...
    @property
    def peak_m(self) -> Tuple[float, float, float]: ...
    @property
    def method(self) -> str: ...
    @property
    def metadata(self) -> Dict[str, Any]: ...
    @property
    def request(self) -> Dict[str, Any]: ...
    def save(self, folder: Union[str, PathLike[str]]) -> None: ...


def capture(request_json: str, progress: Optional[Callable[[int, int], None]] = None) -> Tuple[NlosCapture, List[str]]: ...
def reconstruct(request_json: str, capture: Optional[NlosCapture] = None) -> NlosVolume: ...
