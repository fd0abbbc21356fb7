"""batchveh's fused constraint solver (batchveh.solver) and small Cholesky (batchveh.linalg).

The fused solver is the GPU default; it must solve MuJoCo's problem as MuJoCo does.
Tolerances (measured on CPU, then a small margin; the measured value is next to each):
- linalg: float32 Cholesky of well-conditioned random SPD 14 x 14 systems against NumPy's
  float64, within float32's error budget.
- float64: with the fused solver, MJX torque series match MuJoCo C to F64_SERIES_ATOL N m
  at every step, and the run is shown to be float64.
- float32: series RMS difference to MuJoCo C below F32_SERIES_RTOL of the RMS torque, the
  four-wheel mean against m g sin(slope) r and against MuJoCo C.
"""

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

# float32 Cholesky, cond(A) <= 4.8, max |A| = 42. Backward-error budget n eps32 max|A| = 7e-5.
LINALG_RECON_ATOL = 2e-5  # |L L^T - A|: measured 4.7e-6
LINALG_SOLVE_RTOL = 2e-5  # elementwise, x vs float64 solve: measured 7.5e-6 (the smallest |x| is 3e-4)
LINALG_OTHER_TRI_RTOL = 1e-6  # one system, the SciPy factor: measured 1.5e-7 (garbage use would be O(1))
F64_SERIES_ATOL = 2e-6  # N m: measured 9.2e-7 against MuJoCo C with float64 controls (test_mjx.py)
F32_SERIES_RTOL = 0.025  # RMS difference / RMS torque: measured 0.95%, nearly all in the startup transient
SUM_RTOL = 1e-3  # four-wheel mean vs m g sin(s) r: measured -4.3e-4 (contact penetration, test_physics.py)
SUM_VS_C_RTOL = 1e-5  # four-wheel mean vs MuJoCo C's: measured 2.1e-6 (MJX's own solver: 1.3e-5)


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
    np.testing.assert_allclose(tri.astype(np.float64) @ tri.transpose(0, 2, 1), a, rtol=0, atol=LINALG_RECON_ATOL)
    assert not np.any(np.triu(tri, 1)), "the unused triangle is zero"
    x = jax.vmap(lambda cc, bb: linalg.cho_solve((cc, lower), bb))(c, jnp.asarray(b, jnp.float32))
    np.testing.assert_allclose(np.asarray(x), np.linalg.solve(a, b[..., None])[..., 0], rtol=LINALG_SOLVE_RTOL)


def test_cho_solve_ignores_the_other_triangle(spd):
    # SciPy (and JAX) leave the other triangle unspecified; MJX passes such factors in
    a, b = spd
    c, _ = scipy.linalg.cho_factor(a[0])
    c = c + np.tril(np.full_like(c, 7.0), -1)
    x = linalg.cho_solve((jnp.asarray(c, jnp.float32), False), jnp.asarray(b[0], jnp.float32))
    np.testing.assert_allclose(np.asarray(x), np.linalg.solve(a[0], b[0]), rtol=LINALG_OTHER_TRI_RTOL)


def test_small_cholesky_patch_is_scoped():
    before = jax.scipy.linalg.cho_factor
    with linalg.small_cholesky():
        assert jax.scipy.linalg.cho_factor is linalg.cho_factor
    assert jax.scipy.linalg.cho_factor is before


@pytest.fixture(scope="module")
def pyramidal(vehicle):
    """The fused solver handles pyramidal cones (an elliptic one goes to MJX's own solver); its
    tolerances below were measured with MuJoCo's own contact defaults (impratio 1)."""
    import dataclasses

    cm = dataclasses.replace(vehicle.contact_model, cone="pyramidal", impratio=1.0)
    return dataclasses.replace(vehicle, contact_model=cm)


def test_elliptic_cone_falls_back_to_mjx_solver(vehicle):
    from batchveh import solver

    sc = make_scenario("straight_line", total_time=0.1, ramp_time=0.05)
    before = dict(solver.TRACES)
    with fused_solver():
        simulate(vehicle, sc, backend="mjx")
    assert vehicle.contact_model.cone == "elliptic"
    assert solver.TRACES["fused"] == before["fused"] and solver.TRACES["mjx"] > before["mjx"]


def test_fused_solver_float32_agrees_with_mujoco_c(pyramidal):
    from batchveh import solver

    vehicle = pyramidal
    sc = make_scenario("straight_line", slope_deg=10, friction=0.9, total_time=3.0, ramp_time=1.0)
    c = simulate(vehicle, sc, backend="mujoco")
    before = solver.TRACES["fused"]
    with fused_solver():
        f = simulate(vehicle, sc, backend="mjx")
    assert solver.TRACES["fused"] > before  # the fused solve was traced into the program that ran
    a, b = c.series[list(MOTORS)].to_numpy(), f.series[list(MOTORS)].to_numpy()
    assert np.sqrt(np.mean((a - b) ** 2)) <= F32_SERIES_RTOL * np.sqrt(np.mean(a**2))
    np.testing.assert_allclose(f.stats["drive_sum_mean"], slope_torque(vehicle, 10), rtol=SUM_RTOL)
    np.testing.assert_allclose(f.stats["drive_sum_mean"], c.stats["drive_sum_mean"], rtol=SUM_VS_C_RTOL)


def test_fused_solver_float64_matches_mujoco_c_step_by_step(pyramidal, mjx_output_dtypes):
    vehicle = pyramidal
    sc = make_scenario("straight_line", slope_deg=10, friction=0.9, total_time=2.0, ramp_time=1.0)
    c = simulate(vehicle, sc, backend="mujoco").series[list(MOTORS)].to_numpy()
    with fused_solver():
        j = simulate(vehicle, sc, backend="mjx", precision="f64").series[list(MOTORS)].to_numpy()
    # the floating arrays MJX returned are float64, all of them (and there are some)
    assert sorted(d for d in mjx_output_dtypes if d.startswith("float")) == ["float64"], mjx_output_dtypes
    assert len(c) == len(j) == 400 and np.abs(c).max() > 10
    max_abs = np.abs(c - j).max()
    assert max_abs <= F64_SERIES_ATOL, max_abs
