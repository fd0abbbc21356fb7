"""batchveh's fused constraint solver (batchveh.solver) and small Cholesky (batchveh.linalg).

The fused solver is the GPU default; it must solve MuJoCo's problem as MuJoCo does.
Tolerances (measured, then given margin):
- linalg: float64 solves of random SPD systems to LINALG_RTOL.
- float64: with the fused solver, MJX torque series match MuJoCo C to F64_SERIES_ATOL N m
  at every step (measured 3.9e-7; MJX's own solver: 2.5e-6).
- float32: series RMS difference to MuJoCo C below F32_SERIES_RTOL of the RMS torque, and
  the four-wheel mean within 1% of m g sin(slope) r, as for MJX's own solver (test_mjx.py).
"""

import json
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg
from conftest import slope_torque

from batchveh import linalg
from batchveh.run import simulate
from batchveh.scenarios import make_scenario
from batchveh.solver import fused_solver
from batchveh.vehicle import MOTORS

LINALG_RTOL = 1e-4  # float32 on well-conditioned 14 x 14 systems
F64_SERIES_ATOL = 1e-5  # N m
F32_SERIES_RTOL = 0.05


@pytest.fixture(scope="module")
def spd():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(6, 14, 14))
    return a @ a.transpose(0, 2, 1) + 14 * np.eye(14), rng.normal(size=(6, 14))


@pytest.mark.parametrize("lower", [False, True])
def test_cho_factor_solve_match_numpy(spd, lower):
    a, b = spd
    c, low = linalg.cho_factor(jnp.asarray(a, jnp.float32), lower=lower)
    assert low == lower
    tri = np.asarray(c) if lower else np.asarray(c).transpose(0, 2, 1)
    np.testing.assert_allclose(tri @ tri.transpose(0, 2, 1), a, rtol=LINALG_RTOL, atol=LINALG_RTOL * 14)
    assert not np.any(np.triu(tri, 1)), "the unused triangle is zero"
    x = jax.vmap(lambda cc, bb: linalg.cho_solve((cc, lower), bb))(c, jnp.asarray(b, jnp.float32))
    np.testing.assert_allclose(np.asarray(x), np.linalg.solve(a, b[..., None])[..., 0], rtol=10 * LINALG_RTOL)


def test_cho_solve_ignores_the_other_triangle(spd):
    # SciPy (and JAX) leave the other triangle unspecified; MJX passes such factors in
    a, b = spd
    c, _ = scipy.linalg.cho_factor(a[0])
    c = c + np.tril(np.full_like(c, 7.0), -1)
    x = linalg.cho_solve((jnp.asarray(c, jnp.float32), False), jnp.asarray(b[0], jnp.float32))
    np.testing.assert_allclose(np.asarray(x), np.linalg.solve(a[0], b[0]), rtol=10 * LINALG_RTOL)


def test_small_cholesky_patch_is_scoped():
    before = jax.scipy.linalg.cho_factor
    with linalg.small_cholesky():
        assert jax.scipy.linalg.cho_factor is linalg.cho_factor
    assert jax.scipy.linalg.cho_factor is before


def test_fused_solver_float32_agrees_with_mujoco_c(vehicle):
    sc = make_scenario("straight_line", slope_deg=10, friction=0.9, total_time=3.0, ramp_time=1.0)
    c = simulate(vehicle, sc, backend="mujoco")
    with fused_solver():
        f = simulate(vehicle, sc, backend="mjx")
    a, b = c.series[list(MOTORS)].to_numpy(), f.series[list(MOTORS)].to_numpy()
    assert np.sqrt(np.mean((a - b) ** 2)) <= F32_SERIES_RTOL * np.sqrt(np.mean(a**2))
    np.testing.assert_allclose(f.stats["drive_sum_mean"], slope_torque(vehicle, 10), rtol=0.01)
    np.testing.assert_allclose(f.stats["drive_sum_mean"], c.stats["drive_sum_mean"], rtol=1e-3)


_F64 = """
import json, jax
jax.config.update("jax_enable_x64", True)
import numpy as np
from batchveh.run import simulate
from batchveh.scenarios import make_scenario
from batchveh.solver import fused_solver
from batchveh.vehicle import MOTORS, Vehicle
sc = make_scenario("straight_line", slope_deg=10, friction=0.9, total_time=2.0, ramp_time=1.0)
c = simulate(Vehicle(), sc, backend="mujoco").series[list(MOTORS)].to_numpy()
with fused_solver():
    j = simulate(Vehicle(), sc, backend="mjx").series[list(MOTORS)].to_numpy()
print(json.dumps({"max_abs": float(np.abs(c - j).max()), "steps": len(c), "torque": float(np.abs(c).max())}))
"""


def test_fused_solver_float64_matches_mujoco_c_step_by_step():
    out = subprocess.run([sys.executable, "-c", _F64], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    res = json.loads(out.stdout.strip().splitlines()[-1])
    assert res["steps"] == 400 and res["torque"] > 10
    assert res["max_abs"] <= F64_SERIES_ATOL, res
