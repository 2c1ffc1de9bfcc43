"""tprf from Python: transient cubes, time-of-flight sensors and NLOS captures as numpy
arrays.

The computing is tprf-core's own Rust code (the module ``tprf._tprf``), the same
functions the ``tprf`` command calls, with the GIL released; ``tprf.dist`` runs renders
on a Dask cluster.

Conventions (as in tprf's files): lengths in metres, times in seconds; a cube is float32
``[H, W, T]``, row 0 = the top of the image; bin ``b`` covers ``[t0_s + b dt_s, t0_s +
(b + 1) dt_s)`` and holds the integral over the bin of the pixel's radiance for a
unit-energy pulse leaving the light at t = 0.

``tprf.Differentiable`` renders cubes at parameter values and their gradients;
``tprf.torch`` (needs PyTorch, imported on its own) wraps them for autograd.
"""

from . import nlos
from ._differentiable import Differentiable
from ._render import Renderer, render
from ._tprf import Cube, Measurement, Sensor, __version__, load

__all__ = ["Cube", "Differentiable", "Measurement", "Renderer", "Sensor", "load", "nlos", "render", "__version__"]
