"""MJX against MuJoCo C on the same scenario, and against closed form.

Tolerances (measured on CPU, then a small margin; the measured value is next to each):
- float64 (simulate(..., precision="f64")): torque series agree to F64_SERIES_ATOL N m at
  every step, and the run is shown to be float64 (the dtypes of the arrays MJX hands back).
- float32: steady-window mean torques agree to F32_MEAN_ATOL N m, and the whole
  series' RMS difference is below F32_SERIES_RTOL of the RMS torque. Single
  float32 steps differ more (startup transients, solver noise: up to 1.6 N m).
"""

import numpy as np
from conftest import SLOPE_SUM_RTOL, slope_torque

from batchveh.model.scenarios import make_scenario
from batchveh.model.vehicle import MOTORS
from batchveh.run import simulate

F64_SERIES_ATOL = 5e-4  # N m: measured 1.8e-4 with the elliptic cone (1.9e-6 pyramidal): MJX and C stop
# their elliptic Newton iterations at the same tolerance on differently assembled cones
# Per-motor steady means: measured up to 0.98 N m apart (drive_lr; steering 0.56 N m). Four wheels
# locked to one speed are over-constrained, and with the elliptic cone's stiffer friction float32
# round-off breaks the mirror symmetry that C keeps, so the split between wheels drifts (4e-3 N m
# with MuJoCo's default contact). The sum that physics fixes agrees to F32_SUM_VS_C_RTOL.
F32_MEAN_ATOL = 1.5  # N m
# Regression bound by motor kind (issue 35), |MJX - C| <= atol + rtol |C| on the steady means. Measured with
# today's default contact (the slip tyre) on the project's 2-core machine: drive 1.4e-4 N m (1.0e-5 of 13.3 N m),
# steering 7.0e-5 N m (9.1e-6 of 7.7 N m). The same bound for both kinds here: on this 10 deg climb the steering
# means are 6.4-7.7 N m, not near 0
F32_MOTOR_MEAN_TOL = {"drive": (5e-5, 1e-4), "steer": (5e-5, 1e-4)}  # (rtol, atol N m)
F32_SUM_VS_C_RTOL = 1e-4  # measured 2.6e-5
F32_SERIES_RTOL = 0.08  # measured 4.1% (0.95% with MuJoCo's default contact: the stiffer friction rows
# amplify float32 round-off, mostly in the start-up transient; the steady means are checked to F32_MEAN_ATOL)
F32_SERIES_REGRESSION = 5e-4  # regression bound: measured 1.2e-4 with the slip tyre on the project's 2-core machine
# four-wheel mean vs m g sin(s) r: measured -4.2e-4, as MuJoCo C (-4.3e-4; contact penetration,
# tests/test_physics.py); MJX float32 vs MuJoCo C: measured 1.3e-5
SUM_RTOL = SLOPE_SUM_RTOL  # measured -3.5e-3 (float32, 10 deg)


def _scenario():
    return make_scenario("straight_line", slope_deg=10, friction=0.9, total_time=3.0, ramp_time=1.0)


def test_mjx_float32_agrees_with_mujoco_c(vehicle):
    sc = _scenario()
    c = simulate(vehicle, sc, backend="mujoco")
    j = simulate(vehicle, sc, backend="mjx")
    a, b = c.series[list(MOTORS)].to_numpy(), j.series[list(MOTORS)].to_numpy()
    rms_diff = np.sqrt(np.mean((a - b) ** 2))
    assert rms_diff <= F32_SERIES_RTOL * np.sqrt(np.mean(a**2)), rms_diff
    assert rms_diff <= F32_SERIES_REGRESSION * np.sqrt(np.mean(a**2)), rms_diff
    for m in MOTORS:
        np.testing.assert_allclose(j.stats[f"{m}_mean"], c.stats[f"{m}_mean"], atol=F32_MEAN_ATOL, err_msg=m)
        rtol, atol = F32_MOTOR_MEAN_TOL[m.split("_")[0]]
        np.testing.assert_allclose(j.stats[f"{m}_mean"], c.stats[f"{m}_mean"], rtol=rtol, atol=atol, err_msg=m)
    np.testing.assert_allclose(j.stats["drive_sum_mean"], slope_torque(vehicle, 10), rtol=SUM_RTOL)
    np.testing.assert_allclose(j.stats["drive_sum_mean"], c.stats["drive_sum_mean"], rtol=F32_SUM_VS_C_RTOL)


def test_mjx_float64_matches_mujoco_c_step_by_step(vehicle, mjx_output_dtypes):
    sc = _scenario()
    c = simulate(vehicle, sc, backend="mujoco").series[list(MOTORS)].to_numpy()
    j = simulate(vehicle, sc, backend="mjx", precision="f64").series[list(MOTORS)].to_numpy()
    # the floating arrays MJX returned are float64, all of them (and there are some)
    assert sorted(d for d in mjx_output_dtypes if d.startswith("float")) == ["float64"], mjx_output_dtypes
    assert len(c) == len(j) == 600 and np.abs(c).max() > 10
    max_abs = np.abs(c - j).max()
    assert max_abs <= F64_SERIES_ATOL, max_abs
