"""A fixed hub (steering.layout skid or front) with model dcmotor: HUB_LOCK holds it; the bus counts the motors only.

The 50 kg skid robot below has light hubs (2 kg, about 3e-3 kg m^2 about the hinge): with HUB_LOCK's first rotor
inertia (1e-4 kg m^2) its back-EMF damping made the derived angle gain negative and the hubs spun away (every loop
run of the size command diverged); the lock's power, a few percent of a pivot's, was counted in the bus columns.
"""

import dataclasses

import numpy as np
import pytest
import yaml

from batchveh.engines.mujoco import MujocoEngine
from batchveh.model.scenarios import make_scenario
from batchveh.model.vehicle import CORNERS, Chassis, Hub, Motors, Steering, Vehicle, Wheel
from batchveh.run import simulate
from batchveh.stepping import stats
from batchveh.stepping.batch import make_batch
from batchveh.stepping.motor_stats import MotorStatsConfig

HOLD_RAD = 1e-3  # a fixed hub's largest angle in a pivot at mu 0.6 (measured: below 1e-5 rad with the lock)
# the drives' steady pivot torque, dcmotor (limits off) against the servo: the same physics, another loop
PIVOT_RTOL = 0.02
BUS_RTOL = 1e-9  # the bus columns against the drives' own energy columns (a sum of the same steps' numbers)

ROBOT = Vehicle(
    chassis=Chassis(length=0.60, width=0.46, height=0.20, mass=36.0, z_cg=0.22),
    wheel=Wheel(radius=0.11, width=0.07, mass=1.5, x_cg=0.25, y_cg=0.28),
    hub=Hub(radius=0.04, length=0.10, mass=2.0, y_cg=0.20),
)


@pytest.fixture(scope="module")
def catalogue(tmp_path_factory):
    """Two motors with every limit off (24 kV, no current limit, no thermal model), as tests/test_dcmotor.py's."""
    base = {"nominal_voltage": 24000.0, "terminal_resistance": 0.5, "torque_constant": 0.05}
    motors = [
        {"name": "drive-test", **base, "rotor_inertia": 0.2 / 400, "gearhead": {"ratio": 20.0, "efficiency": 1.0}},
        {"name": "steer-test", **base, "rotor_inertia": 0.2 / 2500, "gearhead": {"ratio": 50.0, "efficiency": 1.0}},
    ]
    path = tmp_path_factory.mktemp("lock") / "catalogue.yaml"
    path.write_text(yaml.safe_dump({"motors": motors}))
    return str(path)


def _dc(layout, catalogue):
    steer = "steer-test" if layout == "front" else ""
    return dataclasses.replace(
        ROBOT,
        steering=Steering(layout=layout),
        motors=Motors(model="dcmotor", catalogue=catalogue, drive="drive-test", steer=steer),
    )


def test_the_lock_holds_a_light_fixed_hub_in_a_skid_pivot(catalogue):
    """Skid pivot at 20 deg/s, mu 0.6: every hub within HOLD_RAD; the drives' steady torque as the servo's."""
    sc = make_scenario("pivot", total_time=4.0, ramp_time=1.0, friction=0.6)
    dc = simulate(_dc("skid", catalogue), sc)
    servo = simulate(dataclasses.replace(ROBOT, steering=Steering(layout="skid")), sc)
    assert int(dc.stats["status_code"]) == 0
    angles = dc.series[[f"alpha_{c}" for c in CORNERS]].to_numpy()
    assert np.abs(angles).max() < HOLD_RAD, np.abs(angles).max()
    for c in CORNERS:
        np.testing.assert_allclose(
            float(dc.stats[f"drive_{c}_mean"]), float(servo.stats[f"drive_{c}_mean"]), rtol=PIVOT_RTOL, err_msg=c
        )


@pytest.mark.parametrize("layout", ["skid", "front"])
def test_the_bus_counts_the_motors_and_not_the_locks(catalogue, layout):
    """bus_energy_wh is the motors' net energy: the drives' (and a front layout's two steering motors') drawn less
    regenerated energy, read from their own columns; a fixed hub's lock is not on the bus."""
    sc = make_scenario("ackermann", total_time=3.0, ramp_time=1.0, friction=0.6, turn_radius=1.5, speed_kmh=3.0)
    v = _dc(layout, catalogue)
    cfg = dataclasses.replace(stats.StatsConfig.for_scenario(sc), motors=MotorStatsConfig.for_vehicle(v))
    out = MujocoEngine(sc, cfg, 1).run(make_batch(v, sc, {"friction": np.array([0.6])}))
    assert int(out["status_code"][0]) == 0
    steered = zip(CORNERS, v.steering.steered, strict=True)
    motors = [f"drive_{c}" for c in CORNERS] + [f"steer_{c}" for c, s in steered if s]
    net = sum(float(out[f"{m}_energy_drawn"][0]) - float(out[f"{m}_energy_regen"][0]) for m in motors)
    locks = [f"steer_{c}" for c, s in zip(CORNERS, v.steering.steered, strict=True) if not s]
    lock = sum(float(out[f"{m}_energy_drawn"][0]) - float(out[f"{m}_energy_regen"][0]) for m in locks)
    np.testing.assert_allclose(float(out["bus_energy_wh"][0]) * 3600.0, net, rtol=BUS_RTOL)
    assert abs(lock) > 1e-6 * abs(net)  # the locks did draw: counting them would move the bus
