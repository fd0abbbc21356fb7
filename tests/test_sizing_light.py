"""Sizing agrees with itself on a light vehicle (sweeps/delivery_robot.yaml, validation/sizing_light.py): the fast
screen's choice, run in the loop with the drive's default gains, covers within AGREE_POINTS of the screen's own
coverage; no variant's run fails a physics check; no variant fails on the gearhead's torque with a drive torque
above what the motor can deliver, eta N K i_max.

Measured on all 400 variants (validation/results/sizing_light.json, MuJoCo C, 2-core CPU): the screen chooses
faulhaber-3863H048CR_NPT015-i28 at 99.0%, the loop covers 99.0% (the same 4 variants rejected, none unstable,
no gear-torque failure); the largest motor_torque_ratio 1.0, motor_flip_share 0."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "validation" / "sizing_light.py"
AGREE_POINTS = 2.0  # the bound: the screen's choice in the loop within 2 points of the screen's coverage
TORQUE_RATIO_MAX = 1.01  # motor_stats.TORQUE_TOL: a motor's applied torque at most 1% above N K i_max
# the screen's choice on all 400 variants (validation/results/sizing_light.json)
CHOICE = "faulhaber-3863H048CR_NPT015-i28"


def _script():
    spec = importlib.util.spec_from_file_location("sizing_light", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_the_screens_choice_in_the_loop_is_stable_and_within_its_current():
    """12 corners of the robot's range (payload 0, 20 kg x slope 0, 10 deg x 0.5, 3, 6 km/h) in the loop on the
    screen's choice, from the hot steady state: none unstable, every motor's torque within its current limit.
    About 10 s on 2 cores (no servo sweep: in_loop reads only the rows' parameters)."""
    import batchveh
    from batchveh import sizing

    sl = _script()
    spec = batchveh.load_spec(sl.SPEC)
    grid = np.array(np.meshgrid([0.0, 20.0], [0.0, 10.0], [0.5, 3.0, 6.0], indexing="ij")).reshape(3, -1)
    rows = pd.DataFrame(dict(zip(["payload.mass", "slope_deg", "speed_kmh"], grid, strict=True)))
    assert list(rows.columns) == list(spec.params)
    _, table, detail = sizing.in_loop(
        spec, rows, sl.CATALOGUE, [CHOICE], steer=sl.STEER, backend="mujoco", stop_at_first=False
    )
    d = detail[CHOICE]
    assert int(table["not_simulated"].iloc[0]) == 0, d[["motor_status", "motor_check"]]
    assert not (d["motor_status"] == "unstable").any()
    assert d["motor_torque_ratio"].max() <= TORQUE_RATIO_MAX, d["motor_torque_ratio"].max()
    cap = sl.deliverable(CHOICE)
    assert (sl.drive_torque(d).max(axis=1) <= cap * TORQUE_RATIO_MAX).all()


@pytest.mark.slow
def test_sizing_agrees_with_itself_on_a_light_vehicle(tmp_path):
    """The first 60 variants: servo sweep, screen at 0.99, in the loop on its choice and the next smaller motor."""
    rep = _script().run(60, tmp_path / "servo")
    assert rep["servo_sweep"]["status"] == {"ok": 60}
    chosen = rep["in_loop"][0]
    assert chosen["motor"] == rep["screen"]["choice"]
    assert abs(chosen["points"]) <= AGREE_POINTS, (chosen["screen_coverage"], chosen["in_loop_coverage"])
    for c in rep["in_loop"]:  # the choice and the next smaller motor alike
        assert c["not_simulated"] == 0, c["motor_check"]
        assert c["gear_torque_fails_above_deliverable"] == 0, c["rejected"]
        assert c["motor_torque_ratio_max"] <= TORQUE_RATIO_MAX
    assert rep["agrees"]
