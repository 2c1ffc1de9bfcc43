"""tprf.Differentiable: a render request differentiable with respect to named scene
parameters (material albedo and emission, light intensity), run by tprf-core with the
GIL released. docs/gradients.md says what is differentiable and how."""

from __future__ import annotations

from os import PathLike
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np

from . import _tprf
from ._render import Time, _Progress, _request_json
from ._tprf import Cube


class Differentiable:
    """``scene`` rendered at parameter values (``forward``) and the gradient of
    ``L = sum(weights * cube)`` with respect to them (``backward``).

    >>> d = tprf.Differentiable("builtin:cornell", wrt=["material:white.albedo"],
    ...                         width=32, height=32, spp=16, bins=64)
    >>> cube = d.forward({"material:white.albedo": 0.6}, seed=1)
    >>> grads = d.backward(np.ones(d.shape, np.float32), seed=2)  # {name: dL/dtheta}

    wrt: parameter names, ``material:NAME.albedo`` (the base colour factor set grey, in
    [0, 1]), ``material:NAME.emission`` (emitted radiance, W m^-2 sr^-1, > 0),
    ``light:NAME.intensity`` (W/sr, > 0); NAME is everything between the prefix and the
    last dot. An unknown name raises ValueError listing the known ones; geometry and the
    camera are refused by name (docs/gradients.md says why).

    The other settings are ``tprf.render``'s; ``spp`` (default 64) is the sample count of
    every forward and backward. The time window is fixed at construction (``t0``/``dt``,
    or a pilot render's), so every cube has the shape ``self.shape``. Give forward and
    backward different seeds: the same seed correlates their noise and biases a
    gradient taken through a loss of the forward cube.
    """

    def __init__(self, scene: Union[str, PathLike], wrt: Sequence[str], *,
                 width: Optional[int] = None, height: Optional[int] = None,
                 spp: int = 64, bins: Optional[int] = None, t0: Optional[Time] = None,
                 dt: Optional[Time] = None, max_bounces: Optional[int] = None,
                 threads: Optional[int] = None, progress: bool = True, **options: Any):
        if isinstance(wrt, str):
            wrt = [wrt]
        fields = dict(width=width, height=height, spp=spp, bins=bins, t0=t0, dt=dt,
                      max_bounces=max_bounces, threads=threads, **options)
        self._native = _tprf.Differentiable(_request_json(scene, fields), list(wrt))
        self._spp = spp
        self.progress = progress

    @property
    def names(self) -> list[str]:
        """The parameters, in ``wrt``'s order."""
        return self._native.names

    @property
    def values(self) -> dict[str, float]:
        """The values the next forward renders at (the last given, else the scene's)."""
        return dict(zip(self._native.names, self._native.values))

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(H, W, T)``: every cube's shape, and the weights'."""
        return self._native.shape

    @property
    def axis(self) -> tuple[float, float, int]:
        """``(t0_s, dt_s, bins)`` of every cube."""
        return self._native.axis

    def forward(self, values: Optional[Mapping[str, float]] = None, *, seed: int = 1) -> Cube:
        """The cube at ``values`` (``{name: value}``; names not given keep their last
        values). Ctrl-C raises KeyboardInterrupt."""
        pairs = [(str(k), float(v)) for k, v in (values or {}).items()]
        bar = _Progress(self._spp, None, self.progress)
        try:
            return self._native.forward(pairs, seed, bar)
        finally:
            bar.close()

    def backward(self, weights: Any, *, seed: int = 2) -> dict[str, float]:
        """``{name: dL/dtheta}`` for ``L = sum(weights * cube)`` at the last forward's
        values; ``weights`` an array of shape ``self.shape``."""
        w = np.ascontiguousarray(weights, dtype=np.float32)
        if w.shape != tuple(self.shape):
            raise ValueError(f"weights: shape {w.shape}; the cube is {tuple(self.shape)}")
        if not np.all(np.isfinite(w)):
            raise ValueError("weights: NaN or infinite values")
        bar = _Progress(self._spp, None, self.progress)
        try:
            grads = self._native.backward(w, seed, bar)
        finally:
            bar.close()
        return dict(zip(self._native.names, grads))
