"""The energy per cycle the size report gives (issue 54): a mission's bus energy (`mission_bus_energy_wh`, the
engine's statistic, what `report.energy_line` reads) against the energy the motors' mechanical power needs through
their gearheads and windings, integrated step by step on MuJoCo C from MuJoCo's own state:

    E = sum over the 8 motors of the integral of (tau omega / eta + i^2 R(T)) dt

with tau the torque the motor gave at its joint (actuator force x N), omega the joint's speed, eta the gearhead's
efficiency, i the winding's current (actuator force / (K eta)) and R(T) the winding's resistance at the drive's
winding temperature (model/motors.py, R' = R / eta for the simulated motor). Within ENERGY_RTOL."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from batchveh.engines.mujoco import MujocoEngine
from batchveh.model.motors import COPPER_TEMPCOEF, REFERENCE_TEMP
from batchveh.model.params import variant_setup
from batchveh.model.vehicle import layout
from batchveh.stepping.batch import make_batch
from batchveh.stepping.rollout import mujoco_steps
from batchveh.sweeping.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
MOTOR = "maxon-353297-48V_NPT025-i28"
ENERGY_RTOL = 0.05  # the bound. Measured: -1.2e-2 (sweeps/mission.yaml at 25 kg and friction 0.7: the bus
# 904.6 J against 719.5 J mechanical through the gears and 195.9 J in the windings)


@pytest.fixture(scope="module")
def run():
    spec = load_spec(ROOT / "sweeps" / "mission.yaml")
    catalogue = str(ROOT / "notebooks" / "motors.yaml")
    motors = dataclasses.replace(spec.vehicle.motors, model="dcmotor", catalogue=catalogue, drive=MOTOR, steer=MOTOR)
    vehicle, scenario = variant_setup(dataclasses.replace(spec.vehicle, motors=motors), spec.scenario,
                                      {"payload.mass": 25.0, "friction": 0.7})  # fmt: skip
    return spec, vehicle, scenario


def test_the_cycles_energy_is_its_mechanical_power_through_the_gears_and_windings(run):
    spec, vehicle, scenario = run
    b = make_batch(vehicle, scenario, {})
    m, lay = b.model, layout(b.model)
    p = {k: float(v[0]) if np.ndim(v) == 1 else np.asarray(v[0]) for k, v in b.params.items()}
    n, k, eta, r = p["_dc.N"], p["_dc.K"], p["_dc.eta"], p["_dc.R"]
    rec, mech, copper, dt = {}, 0.0, 0.0, m.opt.timestep
    for i, (d, ctrl) in enumerate(mujoco_steps(m, p, scenario=scenario, n_steps=scenario.n_steps, record=rec)):
        if ctrl is None or i <= scenario.settle_steps:  # the mission's columns count from law time 0
            continue
        force = d.actuator_force[lay.motor_act]
        current = force / (k * eta)
        r_t = r * (1 + COPPER_TEMPCOEF * (rec["T"] - REFERENCE_TEMP))
        mech += float(np.sum(force * n * d.qvel[lay.motor_dof] / eta)) * dt
        copper += float(np.sum(current**2 * r_t)) * dt
    cfg = dataclasses.replace(spec, vehicle=vehicle, scenario=scenario).stats_config()
    out = MujocoEngine(scenario, cfg, 1).run(make_batch(vehicle, scenario, {}))
    reported = float(np.asarray(out["mission_bus_energy_wh"])[0]) * 3600.0
    expected = mech + copper
    assert reported > 0 and abs(reported - expected) <= ENERGY_RTOL * abs(expected), (reported, mech, copper)
