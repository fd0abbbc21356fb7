"""Reading and writing MuJoCo arrays at a Layout's constant indices, in the form XLA fuses best.

On JAX arrays, fancy indexing with a constant index array lowers to a gather (reading) or a
scatter (writing). Under `vmap` the gather puts its index axis first and the variants after it,
so XLA's fusions ran in a (wheel, variant, component) layout that reads MuJoCo's
(variant, body, component) arrays with a stride per thread: on one H200 the warp engine's tyre
and statistics took 0.50 ms of XLA kernels per step of 100,000 variants, the largest fusion 0.11
ms (benchmarks/results/archive.json: h200-step-profile-indexing.json). Runs of evenly spaced indices (every Layout
index array is one or two such runs: the bodies alternate hub and wheel, the motor joints
steer and drive) are read as strided slices instead, and written by `lax.pad` with interior
padding: elementwise in the arrays' own layout.

On numpy arrays both are plain fancy indexing: a copy, never a view of MuJoCo's buffers.
"""

from __future__ import annotations

import numpy as np


def runs(idx) -> list[slice]:
    """`idx` (a 1-d sequence of non-negative ints) as the fewest slices of evenly spaced indices,
    in order: [3, 5, 7, 9] -> [3:10:2]; [7, 9, 11, 13, 6, 8, 10, 12] -> [7:14:2, 6:13:2]."""
    idx = [int(i) for i in np.asarray(idx).ravel()]
    out, start = [], 0
    while start < len(idx):
        end = start + 1
        if end < len(idx) and idx[end] > idx[start]:
            step = idx[end] - idx[start]
            while end < len(idx) and idx[end] - idx[end - 1] == step:
                end += 1
        else:
            step = 1
        out.append(slice(idx[start], idx[end - 1] + 1, step))
        start = end
    return out


def _at(idx, axis: int) -> tuple:
    """The index tuple that picks `idx` along `axis` (negative) of any array."""
    return (Ellipsis, idx) + (slice(None),) * (-axis - 1)


def take(x, idx, axis: int = -1):
    """x's entries at the constant indices `idx` along `axis` (negative, counted from the end)."""
    if isinstance(x, np.ndarray) or np.ndim(idx) == 0:
        return x[_at(idx, axis)]
    import jax.numpy as jnp

    parts = [x[_at(s, axis)] for s in runs(idx)]
    return parts[0] if len(parts) == 1 else jnp.concatenate(parts, axis=axis)


def place(values, idx, size: int, axis: int = -2):
    """An array of zeros, `size` long along `axis` (negative), holding `values` at the indices `idx`
    (`values` has len(idx) entries along that axis)."""
    shape = list(values.shape)
    shape[axis] = size
    if isinstance(values, np.ndarray):
        out = np.zeros(shape, values.dtype)
        out[_at(idx, axis)] = values
        return out
    import jax.numpy as jnp
    from jax import lax

    spans = runs(idx)
    if len(spans) != 1:
        return jnp.zeros(shape, values.dtype).at[_at(idx, axis)].set(values)
    first, step = spans[0].start, spans[0].step
    last = first + (values.shape[axis] - 1) * step
    pads = [(0, 0, 0)] * values.ndim
    pads[axis] = (first, size - 1 - last, step - 1)
    return lax.pad(values, jnp.zeros((), values.dtype), pads)
