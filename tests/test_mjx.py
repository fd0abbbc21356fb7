"""MJX against MuJoCo C on the same scenario, and against closed form.

Tolerances (measured, then given margin; README "Validation"):
- float64: torque series agree to F64_SERIES_ATOL N m at every step.
- float32: steady-window mean torques agree to F32_MEAN_ATOL N m, and the whole
  series' RMS difference is below F32_SERIES_RTOL of the RMS torque. Single
  float32 steps differ more (startup transients, solver noise).
"""

import json
import subprocess
import sys

import numpy as np
from conftest import slope_torque

from batchveh.run import simulate
from batchveh.scenarios import make_scenario
from batchveh.vehicle import MOTORS

F64_SERIES_ATOL = 1e-4  # N m (measured 2.5e-6: solver tolerance; 1e-5 of a 12 N m torque)
F32_MEAN_ATOL = 0.01  # N m (measured 1.5e-3)
F32_SERIES_RTOL = 0.05  # RMS difference / RMS torque


def _scenario():
    return make_scenario("straight_line", slope_deg=10, friction=0.9, total_time=3.0, ramp_time=1.0)


def test_mjx_float32_agrees_with_mujoco_c(vehicle):
    sc = _scenario()
    c = simulate(vehicle, sc, backend="mujoco")
    j = simulate(vehicle, sc, backend="mjx")
    a, b = c.series[list(MOTORS)].to_numpy(), j.series[list(MOTORS)].to_numpy()
    rms_diff = np.sqrt(np.mean((a - b) ** 2))
    assert rms_diff <= F32_SERIES_RTOL * np.sqrt(np.mean(a**2)), rms_diff
    for m in MOTORS:
        np.testing.assert_allclose(j.stats[f"{m}_mean"], c.stats[f"{m}_mean"], atol=F32_MEAN_ATOL, err_msg=m)
    np.testing.assert_allclose(j.stats["drive_sum_mean"], slope_torque(vehicle, 10), rtol=0.01)


_F64 = """
import json, jax
jax.config.update("jax_enable_x64", True)
import numpy as np
from batchveh.run import simulate
from batchveh.scenarios import make_scenario
from batchveh.vehicle import MOTORS, Vehicle
sc = make_scenario("straight_line", slope_deg=10, friction=0.9, total_time=3.0, ramp_time=1.0)
c = simulate(Vehicle(), sc, backend="mujoco").series[list(MOTORS)].to_numpy()
j = simulate(Vehicle(), sc, backend="mjx").series[list(MOTORS)].to_numpy()
print(json.dumps({"max_abs": float(np.abs(c - j).max()), "steps": len(c), "dtype_ok": True}))
"""


def test_mjx_float64_matches_mujoco_c_step_by_step():
    # x64 is process-wide in JAX, so the float64 check runs in its own process
    out = subprocess.run([sys.executable, "-c", _F64], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    res = json.loads(out.stdout.strip().splitlines()[-1])
    assert res["steps"] == 600
    assert res["max_abs"] <= F64_SERIES_ATOL, res
