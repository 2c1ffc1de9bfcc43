"""tprf.torch: a differentiable render as a ``torch.autograd.Function`` (optional:
needs PyTorch, which tprf does not depend on).

>>> d = tprf.Differentiable("builtin:cornell", wrt=["material:white.albedo"], spp=16)
>>> albedo = torch.tensor(0.5, requires_grad=True)
>>> cube = tprf.torch.render(d, {"material:white.albedo": albedo}, seed=1)
>>> loss = ((cube - target) ** 2).sum(); loss.backward()   # albedo.grad

The backward pass is ``Differentiable.backward`` with the incoming gradient as the
weights (the vector-Jacobian product), with its own seed (``backward_seed``, default
``seed + 1``), so that the gradient of a loss of the cube is unbiased.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np
import torch

from ._differentiable import Differentiable

__all__ = ["render"]


class _Render(torch.autograd.Function):
    @staticmethod
    def forward(ctx, d: Differentiable, seed: int, backward_seed: int, *params):
        values = {n: float(p) for n, p in zip(d.names, params)}
        cube = d.forward(values, seed=seed)
        ctx.d, ctx.values, ctx.seed, ctx.fwd_seed = d, values, backward_seed, seed
        ctx.dtype = params[0].dtype if params else torch.float32
        return torch.from_numpy(np.array(cube.data, dtype=np.float32))

    @staticmethod
    def backward(ctx, grad_cube):
        d = ctx.d
        if d.values != ctx.values:
            # Another forward ran since: the gradient is taken where this one rendered.
            d.forward(ctx.values, seed=ctx.fwd_seed)
        weights = grad_cube.detach().to("cpu", torch.float32).numpy()
        grads = d.backward(weights, seed=ctx.seed)
        return (None, None, None, *[torch.tensor(grads[n], dtype=ctx.dtype) for n in d.names])


def render(d: Differentiable, params: Mapping[str, torch.Tensor], *, seed: int = 1,
           backward_seed: int | None = None) -> torch.Tensor:
    """The cube ``[H, W, T]`` of ``d`` at ``params`` (``{name: scalar tensor}``, every
    name of ``d.names``), differentiable with respect to them."""
    missing = [n for n in d.names if n not in params]
    if missing:
        raise ValueError(f"params: no value for {', '.join(missing)}")
    extra = [n for n in params if n not in d.names]
    if extra:
        raise ValueError(f"params: {', '.join(extra)} not among the Differentiable's names")
    tensors = [torch.as_tensor(params[n]).reshape(()) for n in d.names]
    bseed = seed + 1 if backward_seed is None else backward_seed
    return _Render.apply(d, seed, bseed, *tensors)
