"""Sweeps over the motors themselves (issue 31): a catalogue name as a categorical parameter (`motors.drive:
[A, B]`) and a motor's datasheet fields (`motors.drive.gear_ratio: [...]`), each distinct combination compiled
once. Checked against the vehicle built with each motor alone."""

import dataclasses
from pathlib import Path

import mujoco
import numpy as np
import pytest

import batchveh
from batchveh.config import ConfigError
from batchveh.engines.mujoco import MujocoEngine
from batchveh.model.vehicle import MOTORS
from batchveh.stepping.batch import make_batch, model_for
from batchveh.sweep import run_sweep

CATALOGUE = str(Path(__file__).resolve().parent.parent / "notebooks" / "motors.yaml")
SMALL = "maxon-EC45flat-70W-48V_NPT015-i40"
BIG = "maxon-353297-48V_NPT025-i28"
FIELDS_RTOL = 1e-12  # the swept motors' model fields against the vehicle compiled with each: measured 0
ROWS_RTOL = 1e-9  # a swept variant's statistics against the same vehicle run alone: measured 0


def _raw(tmp_path, method="grid", params=None, **extra):
    return {
        "name": "motor_sweep",
        "scenario": "straight_line",
        "fixed": {"total_time": 3.0, "ramp_time": 1.0, "slope_deg": 4.0},
        "vehicle": {
            "tyre": {"model": "rigid"},
            "motors": {"model": "dcmotor", "catalogue": CATALOGUE, "drive": SMALL, "steer": BIG},
        },
        "sweep": {
            "method": method,
            "params": params or {"motors.drive": [SMALL, BIG], "motors.drive.gear_ratio": [30, 40]},
            **extra,
        },
        "output": str(tmp_path / "out"),
    }


def _alone(spec, name, ratio):
    """The spec's vehicle with its drive motors set to `name` on a `ratio` gearhead, built from scratch."""
    motors = dataclasses.replace(spec.vehicle.motors, drive=name, drive_set=(("gear_ratio", float(ratio)),))
    return dataclasses.replace(spec.vehicle, motors=motors)


def test_a_sweep_over_motors_and_ratios_equals_each_motor_alone(tmp_path):
    """Two catalogue motors x two gear ratios, a grid of 4: each row's model fields (the actuators' gear, gains,
    dynamics and force range, the joints' armature J N^2, and what mj_setConst derives) and its statistics
    (current, winding, energy, torques, status) equal those of the vehicle compiled with that motor alone; the
    result names each row's motor."""
    spec = batchveh.spec_from_mapping(_raw(tmp_path), "test")
    rows = spec.table().rows()
    table = {k: rows[k].to_numpy() for k in spec.params}
    batch = make_batch(spec.vehicle, spec.scenario, table)
    out = MujocoEngine(spec.scenario, spec.stats_config(), 4).run(batch)
    catalogue = spec.vehicle.motors.catalogue_names()
    ids = [mujoco.mj_name2id(batch.model, mujoco.mjtObj.mjOBJ_ACTUATOR, m) for m in MOTORS]
    for i in range(4):
        name = catalogue[int(table["motors.drive"][i])]
        assert name in (SMALL, BIG)
        vehicle = _alone(spec, name, table["motors.drive.gear_ratio"][i])
        ref = model_for(vehicle, spec.scenario)
        for field in ("actuator_gear", "actuator_gainprm", "actuator_dynprm", "actuator_forcerange", "dof_armature",
                      "dof_invweight0", "actuator_acc0"):  # fmt: skip
            got = batch.fields.get(field, np.broadcast_to(getattr(batch.model, field), (4, *getattr(ref, field).shape)))
            want = getattr(ref, field)
            assert np.abs(got[i] - want).max() <= FIELDS_RTOL * max(np.abs(want).max(), 1e-300), (i, field)
        assert ref.actuator_gear[ids[0], 0] == table["motors.drive.gear_ratio"][i]
        alone = MujocoEngine(spec.scenario, dataclasses.replace(spec, vehicle=vehicle).stats_config(), 1).run(
            make_batch(vehicle, spec.scenario, {})
        )
        for k, v in alone.items():
            a, b = np.asarray(out[k])[i], np.asarray(v)[0]
            if np.asarray(a).dtype.kind == "f":
                assert abs(a - b) <= ROWS_RTOL * max(abs(b), 1e-3), (i, k, a, b)
            else:
                assert a == b, (i, k)
    # the big motor holds the 4 deg climb at its imposed speed, the small one does not (different motors ran)
    speed = np.asarray(out["wheel_speed"])
    big, small = table["motors.drive"] == catalogue.index(BIG), table["motors.drive"] == catalogue.index(SMALL)
    assert big.sum() == small.sum() == 2
    assert min(speed[big]) > 1.0 and max(speed[small]) < 1.0
    run_sweep(spec, progress=False)
    df = batchveh.load(spec.output)
    assert set(df["motors.drive"]) == {SMALL, BIG}
    assert sorted(df["motors.drive.gear_ratio"]) == [30.0, 30.0, 40.0, 40.0]


@pytest.mark.parametrize(
    "params, method, words",
    [
        ({"motors.drive": ["maxon-EC45flat-70W-48V_NPT015-i4"], "slope_deg": [1.0]}, "grid", "did you mean"),
        (
            {"motors.drive.gear_ratio": {"low": 20, "high": 40}, "slope_deg": {"low": 0, "high": 1}},
            "random",
            "grid or zip",
        ),
        ({"motors.drive.gear_ratio": [-3.0]}, "grid", "> 0"),
        ({"motors.drive.gear_efficiency": [1.2]}, "grid", "<= 1"),
    ],
)
def test_a_bad_motor_parameter_is_one_line(tmp_path, params, method, words):
    raw = _raw(tmp_path, method=method, params=params, **({"n": 4} if method == "random" else {}))
    with pytest.raises(ConfigError) as err:
        batchveh.spec_from_mapping(raw, "spec.yaml")
    msg = str(err.value)
    assert "\n" not in msg and words in msg and "spec.yaml" in msg and next(iter(params)) in msg, msg


def test_motor_parameters_on_the_servo_are_unknown(tmp_path):
    raw = _raw(tmp_path)
    raw["vehicle"] = {"tyre": {"model": "rigid"}}
    with pytest.raises(ConfigError, match="unknown parameter 'motors.drive'"):
        batchveh.spec_from_mapping(raw, "spec.yaml")
