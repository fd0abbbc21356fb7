"""Longer checks, outside the default run: `python -m pytest -m slow`."""

import numpy as np
import pytest
from conftest import slope_torque

import batchveh
from batchveh.spec import spec_from_mapping

pytestmark = pytest.mark.slow


def test_mjx_sums_on_every_validation_slope(tmp_path, vehicle):
    """The closed-form check of tests/test_physics.py, on MJX (float32, one compile) for all five slopes."""
    raw = {
        "name": "slow",
        "scenario": "straight_line",
        "fixed": {"total_time": 4.0, "ramp_time": 1.0, "friction": 0.9},
        "sweep": {"method": "grid", "params": {"slope_deg": [0, 5, 10, 15, 20]}},
    }
    batchveh.run_sweep(spec_from_mapping(raw, "slow"), out=tmp_path / "o", backend="mjx", progress=False)
    df = batchveh.load(tmp_path / "o")
    for _, row in df.iterrows():
        expect = slope_torque(vehicle, row.slope_deg)
        if row.slope_deg == 0:
            assert abs(row.drive_sum_mean) < 0.05
        else:
            rtol = 0.04 if row.slope_deg == 5 else 0.01
            np.testing.assert_allclose(row.drive_sum_mean, expect, rtol=rtol, err_msg=str(row.slope_deg))


def test_seed_scenario_1_full_length(vehicle):
    """The seed's scenario 1 as written: 10 s, its unbounded ramp; the speed keeps growing, and the vehicle follows."""
    sc = batchveh.make_scenario("straight_line", drive_law="unbounded_ramp")
    res = batchveh.simulate(vehicle, sc)
    omega = 1.0 / 3.6 / vehicle.wheel.radius
    last = res.series.iloc[-1]
    np.testing.assert_allclose(last.omega_ref_lf, omega * 10 / 3, rtol=1e-3)  # 3.3x the "constant" target
    assert res.stats["status_code"] == 0
    np.testing.assert_allclose(last.v_forward, last.omega_lf * vehicle.wheel.radius, rtol=0.02)
