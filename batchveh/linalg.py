"""Cholesky factor and solve for the small dense matrices of a vehicle (n of about 14).

MJX factors small SPD matrices with `jax.scipy.linalg.cho_factor` / `cho_solve`: the mass
matrix (`factor_m`), the Newton solver's Hessian (every iteration) and the implicit
integrator's M - dt D. Under `vmap` on a GPU those lower to batched cuSOLVER / cuBLAS calls
(`potrf_cta_lower_batch`, `trsm_batch_*`) that XLA cannot fuse: on one H200 they were 28% of
a vehicle step (benchmarks/NOTES.md). Here the factorisation is written out entry by entry
on scalars (about n^3/6 multiply-adds, each an element-wise op on the batch axis), so XLA
fuses a whole factor-and-solve into one kernel. Products are element-wise, never `dot`, so
GPU float32 stays true float32 (no TF32).

`small_cholesky()` is a context manager that, while a function is traced, makes
`jax.scipy.linalg.cho_factor` / `cho_solve` these functions for matrices up to `MAX_N`
(larger ones go to JAX's own). They follow JAX's conventions: an upper factor U with
A = U^T U when `lower=False` (the default), a lower L with A = L L^T otherwise; the unused
triangle is zero.
"""

from __future__ import annotations

import contextlib

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl

MAX_N = 24  # above this, unrolling costs more compile time than it saves

_jax_cho_factor = jsl.cho_factor
_jax_cho_solve = jsl.cho_solve

Factor = list[list[jax.Array]]  # L[i][j] for j <= i, each an array of the batch shape


def factor(a: jax.Array) -> Factor:
    """Entries of L with a = L L^T for SPD a (..., n, n); only a's lower triangle is read.

    A non-positive pivot gives NaN, as JAX's own factorisation does."""
    n = a.shape[-1]
    l_: Factor = [[] for _ in range(n)]
    for j in range(n):
        d = jnp.sqrt(a[..., j, j] - sum((l_[j][k] ** 2 for k in range(j)), jnp.zeros(())))
        inv = 1.0 / d
        l_[j].append(d)
        for i in range(j + 1, n):
            s = a[..., i, j] - sum((l_[i][k] * l_[j][k] for k in range(j)), jnp.zeros(()))
            l_[i].append(s * inv)
    return l_


def solve(l_: Factor, b: jax.Array) -> jax.Array:
    """x with L L^T x = b, for b (..., n)."""
    n = len(l_)
    y: list[jax.Array] = []
    for i in range(n):
        y.append((b[..., i] - sum((l_[i][k] * y[k] for k in range(i)), jnp.zeros(()))) / l_[i][i])
    x: list[jax.Array | None] = [None] * n
    for i in reversed(range(n)):
        x[i] = (y[i] - sum((l_[k][i] * x[k] for k in range(i + 1, n)), jnp.zeros(()))) / l_[i][i]
    return jnp.stack(x, axis=-1)


def _matrix(l_: Factor, like: jax.Array) -> jax.Array:
    n = len(l_)
    zero = jnp.zeros(like.shape[:-2], like.dtype)
    return jnp.stack([jnp.stack([l_[i][j] if j <= i else zero for j in range(n)], -1) for i in range(n)], -2)


def _entries(l_: jax.Array) -> Factor:
    return [[l_[..., i, j] for j in range(i + 1)] for i in range(l_.shape[-1])]


def cho_factor(a, lower: bool = False, overwrite_a: bool = False, check_finite: bool = True):
    """Drop-in for `jax.scipy.linalg.cho_factor` (unrolled for n <= MAX_N)."""
    a = jnp.asarray(a)
    if a.shape[-1] > MAX_N:
        return _jax_cho_factor(a, lower=lower, overwrite_a=overwrite_a, check_finite=check_finite)
    l_ = _matrix(factor(a), a)
    return (l_, True) if lower else (jnp.swapaxes(l_, -1, -2), False)


def cho_solve(c_and_lower, b, overwrite_b: bool = False, check_finite: bool = True):
    """Drop-in for `jax.scipy.linalg.cho_solve` with a factor from either cho_factor."""
    c, lower = c_and_lower
    c, b = jnp.asarray(c), jnp.asarray(b)
    if c.shape[-1] > MAX_N:
        return _jax_cho_solve((c, lower), b, overwrite_b=overwrite_b, check_finite=check_finite)
    # only the factor's own triangle is read: the other, from JAX or SciPy, may hold anything
    l_ = _entries(c if lower else jnp.swapaxes(c, -1, -2))
    if b.ndim == c.ndim - 1:
        return solve(l_, b)
    return jnp.stack([solve(l_, b[..., k]) for k in range(b.shape[-1])], axis=-1)


@contextlib.contextmanager
def small_cholesky(enabled: bool = True):
    """While active, `jax.scipy.linalg.cho_factor`/`cho_solve` are this module's (trace-time)."""
    if not enabled:
        yield
        return
    jsl.cho_factor, jsl.cho_solve = cho_factor, cho_solve
    try:
        yield
    finally:
        jsl.cho_factor, jsl.cho_solve = _jax_cho_factor, _jax_cho_solve
