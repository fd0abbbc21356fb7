"""From named parameters to per-variant MuJoCo model fields and control knobs.

A sweep names parameters as in the YAML: scenario fields (`slope_deg`,
`friction`, `speed_kmh`, ...) and vehicle paths (`chassis.mass`, `wheel.radius`,
`payload.mass`, `motors.drive_kv`, ...). `make_batch` turns a table of values
(one array per name) into

- `fields`: the MjModel fields that differ between variants, (n, ...) each. Mass
  and geometry parameters are applied by compiling the vehicle once per distinct
  combination, so every derived constant (inertia, invweight0, acc0, subtree
  mass, bounding radii) is MuJoCo's own: MJX has no mj_setConst.
- `params`: the flat control knobs, (n,) each, read by the scenario's controls.

Gravity, friction and servo gains are written directly: they derive nothing.
The friction is the ground geom's, which has priority over the wheels, so the
value set is the value that acts (MuJoCo otherwise takes the larger of two).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from batchveh.config import ConfigError, did_you_mean
from batchveh.scenarios import Scenario, gravity_vector, numeric_fields
from batchveh.vehicle import Vehicle, build_model, layout, numeric_paths, replace_path

GAINS = ("motors.drive_kp", "motors.drive_kv", "motors.steer_kp", "motors.steer_kv")
# parameters that change array shapes or the step count: one compiled program each
STATIC = ("time_step", "total_time")
# MjModel fields that are only fast-path flags: 0 ("not the same frame") is always correct
SAMEFRAME = ("body_sameframe", "geom_sameframe", "site_sameframe")


def parameter_specs(vehicle: Vehicle | None = None) -> dict[str, dict[str, Any]]:
    """Every sweepable parameter name with its unit and bounds."""
    return {**numeric_fields(), **numeric_paths(vehicle or Vehicle())}


def base_params(vehicle: Vehicle, scenario: Scenario) -> dict[str, float]:
    """The flat parameter mapping of one vehicle and scenario."""
    out = {k: float(getattr(scenario, k)) for k in numeric_fields()}
    for path in numeric_paths(vehicle):
        obj = vehicle
        for part in path.split("."):
            obj = getattr(obj, part)
        out[path] = float(obj)
    return out


def model_for(vehicle: Vehicle, scenario: Scenario) -> mujoco.MjModel:
    """The MjModel of one vehicle and scenario, towing wheels included."""
    m = build_model(
        vehicle, time_step=scenario.time_step, friction=scenario.friction, gravity=tuple(scenario.gravity_vector())
    )
    lay = layout(m)
    gainprm, biasprm = _gains(m, lay, base_params(vehicle, scenario), scenario.towing)
    m.actuator_gainprm[:] = gainprm
    m.actuator_biasprm[:] = biasprm
    return m


def _gains(m, lay, p: Mapping[str, Any], towing) -> tuple[np.ndarray, np.ndarray]:
    """actuator_gainprm, biasprm (n, nu, 10) for gains in p (arrays of shape (n,) or scalars)."""
    n = np.broadcast(*[np.asarray(p[k]) for k in GAINS]).shape
    gain = np.broadcast_to(m.actuator_gainprm, (*n, *m.actuator_gainprm.shape)).copy()
    bias = np.broadcast_to(m.actuator_biasprm, (*n, *m.actuator_biasprm.shape)).copy()
    free = np.array([0.0 if tow else 1.0 for tow in towing])
    for ids, key, col, scale in (
        (lay.drive_vel_act, "motors.drive_kv", 2, free),
        (lay.drive_pos_act, "motors.drive_kp", 1, free),
        (lay.steer_pos_act, "motors.steer_kp", 1, 1.0),
        (lay.steer_vel_act, "motors.steer_kv", 2, 1.0),
    ):
        k = np.asarray(p[key], float)[..., None] * scale
        gain[..., ids, 0] = k
        bias[..., ids, col] = -k
    return gain, bias


def apply_solver(m: mujoco.MjModel, solver: Mapping[str, Any]) -> None:
    """Set MuJoCo solver options (type newton|cg, iterations, ls_iterations, tolerance) on `m`.

    ('impl' chooses the MJX backend's solver code and is not a model option.)"""
    if "type" in solver:
        m.opt.solver = {"newton": mujoco.mjtSolver.mjSOL_NEWTON, "cg": mujoco.mjtSolver.mjSOL_CG}[solver["type"]]
    for key in ("iterations", "ls_iterations", "tolerance"):
        if key in solver:
            setattr(m.opt, key, solver[key])


@dataclass
class VariantBatch:
    """n variants of one compiled structure."""

    model: mujoco.MjModel  # the base model; fields below override it per variant
    fields: dict[str, np.ndarray]  # MjModel field ('opt.gravity' for options) -> (n, ...)
    params: dict[str, np.ndarray]  # control knobs -> (n,)
    n: int


def make_batch(vehicle: Vehicle, scenario: Scenario, table: Mapping[str, Any]) -> VariantBatch:
    """Build n variants from `table` (name -> (n,) values); unnamed parameters keep their base values."""
    specs = parameter_specs(vehicle)
    for name in table:
        if name not in specs:
            raise ConfigError(f"unknown parameter {name!r}{did_you_mean(name, specs)}; allowed: {', '.join(specs)}")
    lengths = {len(np.atleast_1d(v)) for v in table.values()}
    if len(lengths) > 1:
        raise ConfigError(f"parameter columns have different lengths: {sorted(lengths)}")
    n = lengths.pop() if lengths else 1
    for name in STATIC:
        if name in table and np.unique(np.asarray(table[name])).size > 1:
            raise ConfigError(f"{name} cannot vary inside one compiled program; split the sweep by it")
    base = base_params(vehicle, scenario)
    params = {k: np.full(n, v, float) for k, v in base.items()}
    for k, v in table.items():
        params[k] = np.broadcast_to(np.asarray(v, float), (n,)).copy()
    scenario = dataclasses.replace(scenario, **{k: float(params[k][0]) for k in STATIC})
    model = model_for(vehicle, scenario)
    lay = layout(model)
    fields: dict[str, np.ndarray] = {}

    structural = [k for k in table if k in numeric_paths(vehicle) and k not in GAINS]
    if structural:
        _structural_fields(vehicle, scenario, model, params, structural, fields)
    if "slope_deg" in table or "gravity" in table:
        fields["opt.gravity"] = np.asarray(gravity_vector(params["gravity"], params["slope_deg"], xp=np))
    if "friction" in table:
        fr = np.broadcast_to(model.geom_friction, (n, *model.geom_friction.shape)).copy()
        fr[:, lay.ground_geom, 0] = params["friction"]
        fields["geom_friction"] = fr
    if any(k in table for k in GAINS):
        fields["actuator_gainprm"], fields["actuator_biasprm"] = _gains(model, lay, params, scenario.towing)
    return VariantBatch(model=model, fields=fields, params=params, n=n)


def _structural_fields(vehicle, scenario, model, params, names, fields) -> None:
    """Compile the vehicle once per distinct combination of `names`; keep the fields that differ."""
    combos, index = np.unique(np.stack([params[k] for k in names], axis=1), axis=0, return_inverse=True)
    models = []
    for row in combos:
        v = vehicle
        for k, val in zip(names, row, strict=True):
            v = replace_path(v, k, float(val))
        try:
            v.validate("vehicle")
        except ConfigError as err:
            raise ConfigError(f"variant with {dict(zip(names, row.tolist(), strict=True))}: {err}") from None
        models.append(model_for(v, scenario))
    for name in dir(model):
        base = getattr(model, name, None)
        if name.startswith("_") or not isinstance(base, np.ndarray) or base.dtype.kind not in "fiu":
            continue
        values = np.stack([getattr(m, name) for m in models])
        if values.shape[1:] != base.shape:
            raise ConfigError(
                f"parameters {', '.join(names)} change the size of {name}; they cannot vary inside one compiled program"
            )
        if np.array_equal(values, np.broadcast_to(base, values.shape)):
            continue
        if name in SAMEFRAME:
            getattr(model, name)[:] = 0  # fast-path flag: off for everyone
            continue
        if name.startswith("actuator_gainprm") or name.startswith("actuator_biasprm"):
            continue
        fields[name] = values[index.ravel()]
