"""The parameter registry: every sweepable name, its unit and bounds, and where it acts.

A parameter is named as in the YAML: a scenario field (`slope_deg`, `friction`,
`speed_kmh`, ...) or a vehicle path (`chassis.mass`, `wheel.radius`,
`motors.drive_kv`, ...). Where it acts decides how a batch varies it:

- `static`: fixes array shapes or the step count (`time_step`, `total_time`); one
  compiled program each, so it can be fixed but not swept;
- `model`: written straight into a model field that derives nothing (gravity,
  the ground's friction, servo gains);
- `structure`: mass and geometry, the vehicle's and the ground's (`course.FIELDS`);
  their model fields come from `stepping/fields.py` (closed forms and MuJoCo's
  mj_setConst, no compile per variant; the ground's shape compiled once per
  distinct shape), equal to a compile per variant;
- `control`: read by the scenario's controls, as a traced value.

`base_params` and `variant_setup` go between the flat name -> value mapping and
the (Vehicle, Scenario) pair. spec.py and batch.py both stand on this module.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, Literal

from batchveh.model import course
from batchveh.model.motors import SWEEPABLE
from batchveh.model.scenarios import Scenario, numeric_fields
from batchveh.model.vehicle import LAYOUT_KEY, LAYOUTS, Vehicle, numeric_paths, replace_path

Acts = Literal["static", "model", "structure", "control"]

STATIC = ("time_step", "total_time")
GAINS = (
    "motors.drive_kp",
    "motors.drive_kv",
    "motors.steer_kp",
    "motors.steer_kv",
)
MODEL = ("slope_deg", "gravity", "friction", *GAINS)
START_RISE = ("motors.drive_start_rise", "motors.steer_start_rise")
# the dcmotor drive's gains and bandwidths (model/drive.py): read by the drive each step, as traced values
DRIVE = tuple(
    f"motors.dc_{k}" for k in ("drive_kp", "drive_kv", "drive_bandwidth", "steer_kp", "steer_kv", "steer_ki",
                               "steer_bandwidth")
)  # fmt: skip


GROUPS = ("drive", "steer")


def motor_names(vehicle: Vehicle) -> dict[str, dict[str, Any]]:
    """The dcmotors' parameters (model dcmotor; none for the servo): `motors.drive` and `motors.steer`,
    categorical (a catalogue name: `choices`; the flat value is its index there), and `motors.drive.<field>`,
    `motors.steer.<field>` for every field of motors.SWEEPABLE. All act as structure, one compile per distinct
    combination of their values (batch._structural_fields): a sweep gives them as lists (grid or zip)."""
    if vehicle.motors.model != "dcmotor":
        return {}
    out: dict[str, dict[str, Any]] = {}
    names = vehicle.motors.catalogue_names()
    for group in GROUPS:
        out[f"motors.{group}"] = {"unit": "", "doc": f"the {group} motors' catalogue entry", "choices": names,
                                  "acts": "structure", "motor": True}  # fmt: skip
        for key, (unit, rule) in SWEEPABLE.items():
            meta = {"unit": unit, "doc": f"the {group} motors' {key.replace('_', ' ')}", rule: 0.0}
            if key == "gear_efficiency":
                meta["le"] = 1.0
            out[f"motors.{group}.{key}"] = {**meta, "acts": "structure", "motor": True}
    return out


def parameter_specs(vehicle: Vehicle | None = None) -> dict[str, dict[str, Any]]:
    """Every sweepable parameter name with its unit, bounds and `acts`."""
    vehicle = vehicle or Vehicle()
    out = {k: {**meta, "acts": _acts(k, scenario=True)} for k, meta in numeric_fields().items()}
    out.update({k: {**meta, "acts": _acts(k, scenario=False)} for k, meta in numeric_paths(vehicle).items()})
    out.update(motor_names(vehicle))
    return out


def _acts(name: str, scenario: bool) -> Acts:
    if name in STATIC:
        return "static"
    if name in MODEL:
        return "model"
    if name.startswith(("tyre.", "soil.")):  # read by the slip tyre or the soil each step, as a traced value
        return "control"
    if name in START_RISE or name in DRIVE:  # the dcmotor drive's state at t = 0 and its gains
        return "control"
    if name in course.FIELDS:  # the ground's shape: compiled per combination, as the vehicle's geometry
        return "structure"
    return "control" if scenario else "structure"


def structural(names: Any, vehicle: Vehicle | None = None) -> list[str]:
    """The names among `names` that need a rebuild of the vehicle (mass and geometry)."""
    specs = parameter_specs(vehicle)
    return [k for k in names if specs[k]["acts"] == "structure"]


def base_params(vehicle: Vehicle, scenario: Scenario) -> dict[str, float]:
    """The flat parameter mapping of one vehicle and scenario."""
    out = {k: float(getattr(scenario, k)) for k in numeric_fields()}
    for path in numeric_paths(vehicle):
        obj = vehicle
        for part in path.split("."):
            obj = getattr(obj, part)
        out[path] = float(obj)
    out[LAYOUT_KEY] = float(LAYOUTS.index(vehicle.steering.layout))  # the controls' layout (scenarios.steered)
    if vehicle.motors.model == "dcmotor":  # each dcmotor parameter's own value (NaN: the sheet gives none)
        names = vehicle.motors.catalogue_names()
        for group, motor in zip(GROUPS, vehicle.motors.dcmotors(steer=bool(vehicle.motors.steer)), strict=True):
            if not getattr(vehicle.motors, group):  # no steering motor (a skid layout)
                continue
            out[f"motors.{group}"] = float(names.index(getattr(vehicle.motors, group)))
            for key in SWEEPABLE:
                value = getattr(motor, key)
                out[f"motors.{group}.{key}"] = float("nan") if value is None else float(value)
    return out


def variant_setup(vehicle: Vehicle, scenario: Scenario, values: Mapping[str, Any]) -> tuple[Vehicle, Scenario]:
    """The vehicle and scenario with `values` (parameter name -> number) applied."""
    scenario_keys = numeric_fields()
    scenario = dataclasses.replace(scenario, **{k: float(v) for k, v in values.items() if k in scenario_keys})
    paths = numeric_paths(vehicle)
    for k, v in values.items():
        if k in paths:
            vehicle = replace_path(vehicle, k, float(v))
    motors = {k: v for k, v in values.items() if k.startswith(("motors.drive", "motors.steer")) and k not in paths}
    if motors and vehicle.motors.model == "dcmotor":
        vehicle = dataclasses.replace(vehicle, motors=_motors_with(vehicle.motors, motors))
    return vehicle, scenario


def _motors_with(mo: Any, values: Mapping[str, Any]) -> Any:
    """vehicle.motors with dcmotor parameters applied: a catalogue name (or its index) for motors.drive /
    motors.steer, a field's value for motors.drive.<field>, motors.steer.<field>."""
    names = mo.catalogue_names()
    changes: dict[str, Any] = {}
    for group in GROUPS:
        if f"motors.{group}" in values:
            v = values[f"motors.{group}"]
            changes[group] = v if isinstance(v, str) else names[int(round(float(v)))]
        fields = tuple((k.rsplit(".", 1)[1], float(v)) for k, v in values.items() if k.startswith(f"motors.{group}."))
        if fields:
            changes[f"{group}_set"] = tuple(dict((*getattr(mo, f"{group}_set"), *fields)).items())
    return dataclasses.replace(mo, **changes)
