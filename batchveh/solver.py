"""A fused Newton constraint solver for MJX: MuJoCo's problem, written for the GPU.

MJX's own solver (`mujoco.mjx._src.solver.solve`) minimises MuJoCo's convex cost
    f(qacc) = 1/2 (qacc - qacc_smooth)' M (qacc - qacc_smooth)
            + sum_r 1/2 D_r (J_r qacc - aref_r)^2  over active rows r,
a row being active when J_r qacc - aref_r < 0 (equality and friction-loss-free rows always).
On a GPU, for this vehicle (nv = 14, 48 pyramidal contact rows), its Newton iterations are
about 850 kernels per step, and each reads and writes whole batch-sized arrays: 28% of a
step went to batched cuSOLVER/cuBLAS Cholesky calls, and the zoom line search evaluates
three points per round (benchmarks/NOTES.md). This module solves the same problem with:

- the gradient and the other products as element-wise products and sums (XLA fuses them;
  no `dot`, so no TF32 on GPU float32), and the Hessian M + J' diag(D active) J as one
  batched product at explicit HIGHEST precision (`_hessian`);
- the Cholesky factor and solve unrolled on scalars (`batchveh.linalg`), one fused kernel;
- an exact line search: along the Newton direction f is a convex piecewise quadratic, and a
  safeguarded 1-D Newton iteration on its derivative (one evaluation per round, bracket kept)
  lands on the minimiser once the active set settles;
- MuJoCo's stopping rule per variant (improvement or gradient below `opt.tolerance`, scaled
  by trace M) applied as a freeze; the loop ends when all have converged or after
  `opt.iterations`.

It returns what MJX's solver returns (qacc, qfrc_constraint, efc_force) and handles what this
vehicle needs: pyramidal cones, the Newton solver, no friction loss. Anything else goes to
MJX's own solver. `fused_solver()` installs it while a step is traced.
"""

from __future__ import annotations

import contextlib

import jax
import jax.numpy as jnp
import mujoco
from mujoco.mjx._src import solver as _mjx_solver
from mujoco.mjx._src import support
from mujoco.mjx._src.types import ConeType, DisableBit, SolverType

from batchveh import linalg

_mjx_solve = _mjx_solver.solve
UNROLL = 8  # line searches this short are unrolled


def supported(m) -> bool:
    """Whether `solve` handles this MJX model (else MJX's own solver runs)."""
    impl = m._impl
    frictionloss = bool(impl.dof_hasfrictionloss.any()) or bool(impl.tendon_hasfrictionloss.any())
    frictionloss = frictionloss and not (m.opt.disableflags & DisableBit.FRICTIONLOSS)
    return m.opt.cone == ConeType.PYRAMIDAL and m.opt.solver == SolverType.NEWTON and not frictionloss


def _rows_dot(a: jax.Array, x: jax.Array) -> jax.Array:
    """a @ x for a (r, n), x (n,), as an element-wise product and a sum."""
    return jnp.sum(a * x, axis=-1)


TRACES = {"fused": 0, "mjx": 0}  # how often each solve was traced: tests prove which one ran


def solve(m, d):
    """MJX `solver.solve` replacement: same cost, same outputs (see the module docstring)."""
    if not supported(m):
        TRACES["mjx"] += 1
        return _mjx_solve(m, d)
    TRACES["fused"] += 1
    impl = d._impl
    jac, dd, aref = impl.efc_J, impl.efc_D, impl.efc_aref
    mass = support.full_m(m, d)
    nfix = impl.ne + impl.nf  # always-active rows lead
    forced = jnp.arange(jac.shape[0]) < nfix
    qacc_smooth, qfrc_smooth = d.qacc_smooth, d.qfrc_smooth
    scale = 1.0 / jnp.maximum(jnp.trace(mass), mujoco.mjMINVAL)
    tol = m.opt.tolerance

    def point(qacc):
        """(jaref, M qacc, cost) at qacc."""
        jaref = _rows_dot(jac, qacc) - aref
        ma = _rows_dot(mass, qacc)
        return jaref, ma, _cost(jaref, ma, qacc)

    def _cost(jaref, ma, qacc):
        active = (jaref < 0) | forced
        return 0.5 * jnp.sum(dd * jaref * jaref * active) + 0.5 * jnp.sum((ma - qfrc_smooth) * (qacc - qacc_smooth))

    # warm start: the better of last step's qacc and the unconstrained one (as MuJoCo)
    qacc = qacc_smooth
    if not m.opt.disableflags & DisableBit.WARMSTART:
        warm, smooth = point(d.qacc_warmstart), point(qacc_smooth)
        qacc = jnp.where(warm[2] < smooth[2], d.qacc_warmstart, qacc_smooth)
    jaref, ma, cost = point(qacc)

    def iteration(carry):
        qacc, jaref, ma, cost, done = carry
        active = (jaref < 0) | forced
        w = dd * active
        grad = ma - qfrc_smooth + jnp.sum(jac * (w * jaref)[:, None], axis=0)
        done = done | (jnp.sqrt(jnp.sum(grad * grad)) * scale < tol)
        hess = _hessian(mass, jac, w)
        # the barrier materialises the factor: fused into the solve, XLA recomputed entries
        search = -linalg.solve(jax.lax.optimization_barrier(linalg.factor(hess)), grad)
        jv, mv = _rows_dot(jac, search), _rows_dot(mass, search)
        alpha = _linesearch(jaref, jv, dd, forced, search, ma, qfrc_smooth, mv, m.opt.ls_iterations)
        step = jnp.where(done, 0.0, alpha)
        qacc, jaref, ma = qacc + step * search, jaref + step * jv, ma + step * mv
        new_cost = _cost(jaref, ma, qacc)
        return qacc, jaref, ma, new_cost, done | ((cost - new_cost) * scale < tol)

    # up to opt.iterations rounds; under vmap the loop ends when every variant has converged
    carry = (qacc, jaref, ma, cost, jnp.zeros((), bool))
    carry = jax.lax.while_loop(
        lambda c: (c[0] < max(1, m.opt.iterations)) & ~c[1][4], lambda c: (c[0] + 1, iteration(c[1])), (0, carry)
    )[1]
    qacc, jaref = carry[0], carry[1]

    active = (jaref < 0) | forced
    efc_force = -dd * jaref * active
    qfrc_constraint = jnp.sum(jac * efc_force[:, None], axis=0)
    return d.tree_replace({"qacc": qacc, "qfrc_constraint": qfrc_constraint, "_impl.efc_force": efc_force})


def _hessian(mass: jax.Array, jac: jax.Array, w: jax.Array) -> jax.Array:
    """M + J' diag(w) J as a float32-exact batched product: on one H200 at 65,536 variants
    0.34 ms, where a broadcast-and-reduce over rows took 1.8 ms and a sum of row outer
    products 1.0 ms (and a 4x longer compile); benchmarks/profile_step.py --hessians."""
    return mass + jnp.einsum("ri,rj->ij", jac * w[:, None], jac, precision=jax.lax.Precision.HIGHEST)


def _linesearch(jaref, jv, dd, forced, search, ma, qfrc_smooth, mv, rounds: int) -> jax.Array:
    """Step alpha minimising f(qacc + alpha search); f is convex piecewise quadratic in alpha.

    f'(a) = g1 + 2 g2 a + sum_r D_r jv_r (jaref_r + a jv_r) [active at a] is continuous, piecewise
    linear and increasing. From a = 0, each round evaluates f, f', f'' at the newest point (one
    fused reduction), keeps the bracket [lo, hi] of the minimiser, and takes the Newton step on
    f' (exact once the active set is right), or the bracket's midpoint when that step leaves it.
    The evaluated point of lowest cost is returned (a = 0 at worst: f never rises)."""
    g1 = jnp.sum(search * (ma - qfrc_smooth))
    g2 = 0.5 * jnp.sum(search * mv)
    base = dd * jaref * jaref * ((jaref < 0) | forced)

    def evaluate(a):  # f(a) - f(0), f'(a), f''(a)
        x = jaref + a * jv
        w = dd * ((x < 0) | forced)
        cost = g1 * a + g2 * a * a + 0.5 * jnp.sum(w * x * x - base)
        d1 = g1 + 2 * g2 * a + jnp.sum(w * jv * x)
        d2 = 2 * g2 + jnp.sum(w * jv * jv)
        return cost, d1, jnp.maximum(d2, mujoco.mjMINVAL)

    zero = jnp.zeros_like(g1)
    _, d1, d2 = evaluate(zero)  # d1 < 0 along a descent direction

    def round_(carry):
        a, lo, hi, best, best_cost = carry
        cost, d1, d2 = evaluate(a)
        better = cost < best_cost
        best, best_cost = jnp.where(better, a, best), jnp.where(better, cost, best_cost)
        lo, hi = jnp.where(d1 < 0, a, lo), jnp.where(d1 >= 0, a, hi)
        nxt = a - d1 / d2
        a = jnp.where((nxt > lo) & (nxt < hi), nxt, jnp.where(jnp.isfinite(hi), 0.5 * (lo + hi), 2 * lo))
        return a, lo, hi, best, best_cost

    carry = (-d1 / d2, zero, jnp.full_like(g1, jnp.inf), zero, zero)
    rounds = max(1, rounds)
    if rounds <= UNROLL:
        for _ in range(rounds):
            carry = round_(carry)
    else:
        carry = jax.lax.fori_loop(0, rounds, lambda _, c: round_(c), carry)
    return carry[3]


@contextlib.contextmanager
def fused_solver(enabled: bool = True):
    """While active (trace time), MJX's constraint solve is `solve` and its small Cholesky
    calls (mass matrix, implicit integrator) are `batchveh.linalg`'s."""
    if not enabled:
        yield
        return
    _mjx_solver.solve = solve
    try:
        with linalg.small_cholesky():
            yield
    finally:
        _mjx_solver.solve = _mjx_solve
