"""A chunk of variants -> the model fields that differ between them, and the control knobs.

`make_batch` turns a table of values (one (n,) array per swept parameter) into

- `fields`: the MjModel fields that differ between variants, (n, ...) each. Mass
  and geometry parameters are applied without a compile per variant
  (`stepping/fields.py`: the compiler's part in closed form, mj_setConst's by
  MuJoCo per variant), equal to a compile per variant (`compiled_fields`, the
  reference the tests hold it to).
- `params`: the flat control knobs, (n,) each, read by the scenario's controls.

Which fields vary follows from the swept names alone (`varying_fields`), never
from one chunk's values, so every chunk of a sweep has the same structure and
one compiled program serves them all.

Gravity, friction and servo gains are written directly: they derive nothing.
The friction is the ground geom's, which has priority over the wheels, so the
value set is the value that acts (MuJoCo otherwise takes the larger of two).

`mjx_model` turns a batch into an MJX model with batched fields and its
`in_axes` tree: a sweep is a batched model plus an `in_axes` tree.
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from batchveh.config import ConfigError, did_you_mean
from batchveh.model import course, drive
from batchveh.model.params import (
    DRIVE,
    GAINS,
    STATIC,
    base_params,
    motor_names,
    parameter_specs,
    structural,
    variant_setup,
)
from batchveh.model.scenarios import Scenario, check_layout, gravity_vector
from batchveh.model.soil import check_ground
from batchveh.model.tyres import DRIVE_ARMATURE, STEER_MASS
from batchveh.model.vehicle import Vehicle, build_model, hinge_xy, layout, rolling_resistance_torque
from batchveh.stepping import fields as structure

# MjModel fields that are only fast-path flags: 0 ("not the same frame") is always correct
SAMEFRAME = ("body_sameframe", "geom_sameframe", "site_sameframe")
# two probes per structural parameter: value * scale + shift (both away from the base value)
_PROBES = ((1.1, 0.011), (1.27, 0.023))
# the parameters the steering hinges' place depends on (vehicle.hinge_xy)
HINGE_INPUTS = ("steering.axis_x", "steering.axis_y", "chassis.length", "chassis.width")


def model_for(vehicle: Vehicle, scenario: Scenario) -> mujoco.MjModel:
    """The MjModel of one vehicle and scenario, towing wheels included."""
    m = build_model(
        vehicle,
        time_step=scenario.time_step,
        friction=scenario.friction,
        gravity=tuple(scenario.gravity_vector()),
        ground=course.ground(vehicle, scenario),
    )
    course.write_heights(m, scenario)
    gainprm, biasprm = _gains(m, base_params(vehicle, scenario), scenario.towing)
    m.actuator_gainprm[:] = gainprm
    m.actuator_biasprm[:] = biasprm
    return m


def _gains(m: mujoco.MjModel, p: Mapping[str, Any], towing, gain0=None) -> tuple[np.ndarray, np.ndarray]:
    """actuator_gainprm, biasprm (n, nu, 10) for the servo's gains in p (arrays of shape (n,) or scalars), over
    each variant's own gainprm where given ((n, nu, 10): swept dcmotors)."""
    lay = layout(m)
    n = np.broadcast(*[np.asarray(p[k]) for k in GAINS]).shape
    base = m.actuator_gainprm if gain0 is None else gain0
    gain = np.broadcast_to(base, (*n, *m.actuator_gainprm.shape)).copy()
    bias = np.broadcast_to(m.actuator_biasprm, (*n, *m.actuator_biasprm.shape)).copy()
    free = np.array([0.0 if tow else 1.0 for tow in towing])
    if lay.dcmotor:  # the dcmotors' gains are the drive's (model/drive.py, `drive_gains`)
        return gain, bias
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


def servo_damping(p: Mapping[str, Any], towing, xp=np, dcmotor: bool = False):
    """kv of each motor's servo, (..., 8) in MOTORS order, N m s/rad (0 on a towing wheel); with dcmotors
    (`dcmotor`), the back-EMF's damping that MuJoCo integrates implicitly (drive.damping, each variant's)."""
    if dcmotor:
        return drive.damping({k: xp.asarray(p[f"_dc.{k}"]) for k in ("N", "K", "R")}, xp)
    free = np.array([0.0 if tow else 1.0 for tow in towing])
    drive_kv = xp.asarray(p["motors.drive_kv"])[..., None] * free
    steer = xp.asarray(p["motors.steer_kv"])[..., None] * xp.ones(4)
    return xp.concatenate([drive_kv, steer], axis=-1)


def apply_solver(m: mujoco.MjModel, solver: Any) -> None:
    """Set MuJoCo solver options on `m` from `solver` (attributes or keys type, iterations,
    ls_iterations, tolerance; None or absent keeps MuJoCo's)."""
    get = solver.get if isinstance(solver, Mapping) else lambda k: getattr(solver, k, None)
    if get("type") is not None:
        m.opt.solver = {"newton": mujoco.mjtSolver.mjSOL_NEWTON, "cg": mujoco.mjtSolver.mjSOL_CG}[get("type")]
    for key in ("iterations", "ls_iterations", "tolerance"):
        if get(key) is not None:
            setattr(m.opt, key, get(key))


def _numeric_fields(m: mujoco.MjModel) -> dict[str, np.ndarray]:
    out = {}
    for name in dir(m):
        value = getattr(m, name, None)
        if not name.startswith("_") and isinstance(value, np.ndarray) and value.dtype.kind in "fiu":
            out[name] = value
    return out


_VARYING: dict[str, tuple[str, ...]] = {}


def varying_fields(vehicle: Vehicle, scenario: Scenario, names: Sequence[str]) -> tuple[str, ...]:
    """The MjModel fields that structural parameters `names` change, found from the names alone.

    The vehicle is compiled at its base values and at two probes away from them; a field
    that differs in either probe varies. Gains are excluded (written directly) and the
    SAMEFRAME flags included (they are switched off in the batch's model)."""
    key = repr((vehicle, scenario, tuple(names)))
    if key not in _VARYING:
        base = _numeric_fields(model_for(vehicle, scenario))
        p = base_params(vehicle, scenario)
        found: set[str] = set()
        for scale, shift in _PROBES:
            probe = _numeric_fields(
                model_for(*variant_setup(vehicle, scenario, {k: p[k] * scale + shift for k in names}))
            )
            for name, values in probe.items():
                if values.shape != base[name].shape:
                    raise ConfigError(
                        f"parameters {', '.join(names)} change the size of {name}; "
                        "they cannot vary inside one compiled program"
                    )
                if not np.array_equal(values, base[name]):
                    found.add(name)
        found -= {"actuator_gainprm", "actuator_biasprm"}
        _VARYING[key] = tuple(sorted(found | set(SAMEFRAME)))
    return _VARYING[key]


@dataclass
class VariantBatch:
    """n variants of one compiled structure."""

    model: mujoco.MjModel  # the base model; fields below override it per variant
    fields: dict[str, np.ndarray]  # MjModel field ('opt.gravity' for options) -> (n, ...)
    params: dict[str, np.ndarray]  # control knobs -> (n,)
    n: int


def make_batch(
    vehicle: Vehicle, scenario: Scenario, table: Mapping[str, Any], swept: Sequence[str] | None = None
) -> VariantBatch:
    """Build n variants from `table` (name -> (n,) values); unnamed parameters keep their base values.

    `swept`: the names that vary over the whole sweep (default: the table's). They, not the
    values, decide which fields the batch carries."""
    specs = parameter_specs(vehicle)
    for name in table:
        if name not in specs:
            raise ConfigError(f"unknown parameter {name!r}{did_you_mean(name, specs)}; allowed: {', '.join(specs)}")
        if name in STATIC:
            raise ConfigError(f"{name} fixes the compiled program and cannot be swept; give it under fixed")
    lengths = {len(np.atleast_1d(v)) for v in table.values()}
    if len(lengths) > 1:
        raise ConfigError(f"parameter columns have different lengths: {sorted(lengths)}")
    n = lengths.pop() if lengths else 1
    swept = list(table if swept is None else swept)
    params = {k: np.full(n, v, float) for k, v in base_params(vehicle, scenario).items()}
    for k, v in table.items():
        params[k] = np.broadcast_to(np.asarray(v, float), (n,)).copy()
    check_ground(vehicle.tyre.model, scenario.obstacle, "scenario")
    check_layout(vehicle.steering.layout, scenario, "scenario")
    course.check(params, scenario.obstacle, "scenario")  # every variant, swept or not (a single run too)
    model = model_for(vehicle, scenario)
    fields: dict[str, np.ndarray] = {}
    struct = structural(swept, vehicle)
    if struct:
        _structural_fields(vehicle, scenario, model, params, struct, fields)
    if "slope_deg" in swept or "gravity" in swept:
        fields["opt.gravity"] = np.asarray(gravity_vector(params["gravity"], params["slope_deg"], xp=np))
    if "friction" in swept:
        fr = np.broadcast_to(model.geom_friction, (n, *model.geom_friction.shape)).copy()
        fr[:, course.ground_geoms(model), 0] = params["friction"][:, None]
        fields["geom_friction"] = fr
    if any(k in swept for k in GAINS):
        fields["actuator_gainprm"], fields["actuator_biasprm"] = _gains(
            model, params, scenario.towing, fields.get("actuator_gainprm")
        )
    if vehicle.motors.model == "dcmotor":  # each variant's motor constants and drive gains (model/drive.py)
        params.update(motor_constants(vehicle, scenario, params, [k for k in swept if k in motor_names(vehicle)], n))
        params.update(drive_gains(model, fields, params, scenario, n))
    # the rigid contact's rolling resistance is the drive joints' friction loss; the slip tyre's its own
    rolls = "wheel.rolling_resistance" in swept or vehicle.wheel.rolling_resistance > 0
    if vehicle.tyre.model == "rigid" and rolls and any(k in swept for k in ROLLING_INPUTS):
        fields["dof_frictionloss"] = _rolling(model, params, n)
    params[DRIVE_ARMATURE] = drive_armature(model, fields, n)
    params[STEER_MASS] = steer_mass(model, fields, params, n)
    return VariantBatch(model=model, fields=fields, params=params, n=n)


def drive_gains(model: mujoco.MjModel, fields: Mapping[str, np.ndarray], params, scenario, n: int) -> dict:
    """Each variant's drive gains `_dc.kp`, `_dc.kv`, `_dc.ki` (n, 8) (drive.gains): from its own inertia at
    each motor joint (dof_M0: the wheel's or hub's with the rotor's J N^2), its mass over four wheels at its
    wheel radius, its motors' constants, the time step and the gains and bandwidths the user set; the steering's
    kp also from the tyre's moment (drive.tyre_moment_stiffness) at its own slip stiffness, LOAD_FACTOR times its
    static wheel load and its contact's lead along the vehicle from the steering axis. A towing wheel's drive
    gets none."""
    lay = layout(model)
    m0 = np.broadcast_to(fields.get("dof_M0", model.dof_M0), (n, model.nv))[:, lay.motor_dof]
    mass = np.broadcast_to(fields.get("body_mass", model.body_mass), (n, model.nbody)).sum(-1)
    r = np.broadcast_to(np.asarray(params["wheel.radius"], float), (n,))
    load = m0[:, :4] + (mass * r * r / 4)[:, None]
    p = {k: np.broadcast_to(np.asarray(params[k], float), (n,)) for k in DRIVE}
    c = {k: np.asarray(params[f"_dc.{k}"], float) for k in ("N", "K", "R")}

    def col(k):
        return np.broadcast_to(np.asarray(params[k], float), (n,))

    wheel_load = drive.LOAD_FACTOR * mass * col("gravity") / 4
    hinge_x, _ = hinge_xy({k: col(k) for k in HINGE_INPUTS})
    lead = col("wheel.x_cg") - hinge_x  # the contact from the steering axis, along the vehicle
    tyre = drive.tyre_moment_stiffness(col("tyre.slip_stiffness"), wheel_load, lead)[:, None]
    g = drive.gains(
        c,
        m0,
        load,
        float(scenario.time_step),
        (p["motors.dc_drive_bandwidth"], p["motors.dc_steer_bandwidth"]),
        {
            "kp": (p["motors.dc_drive_kp"], p["motors.dc_steer_kp"]),
            "kv": (p["motors.dc_drive_kv"], p["motors.dc_steer_kv"]),
            "ki": (np.zeros(n), p["motors.dc_steer_ki"]),
        },
        tyre,
    )
    free = np.array([0.0 if tow else 1.0 for tow in scenario.towing] + [1.0] * 4)
    return {f"_dc.{k}": np.broadcast_to(v * free, (n, 8)).copy() for k, v in g.items()}


def drive_armature(model: mujoco.MjModel, fields: Mapping[str, np.ndarray], n: int) -> np.ndarray:
    """(n,) the front-left drive joint's armature of each variant, as the compiled program has it: the
    servo's `motors.armature`, or a dcmotor's rotor J N^2 (its catalogue entry's and gear ratio's, which
    may differ per variant). All four drives carry the same."""
    dof = layout(model).motor_dof[0]
    arm = np.asarray(fields["dof_armature"])[:, dof] if "dof_armature" in fields else model.dof_armature[dof]
    return np.broadcast_to(np.asarray(arm, float), (n,)).copy()


def steer_mass(model: mujoco.MjModel, fields: Mapping[str, np.ndarray], params, n: int) -> np.ndarray:
    """(n,) each variant's steering inertia (dof_M0 of the front-left steering hinge: the hub's and wheel's with
    the rotor's) over the squared lever of its wheel's contact about the steering axis (the wheel's centre from
    its hinge, vehicle.hinge_xy, in the ground plane), kg: the mass the tyre's force meets through the steering (1e30
    where the wheel sits on its axis)."""
    dof = layout(model).motor_dof[4]
    m0 = np.broadcast_to(fields.get("dof_M0", model.dof_M0), (n, model.nv))[:, dof]

    def p(k):
        return np.broadcast_to(np.asarray(params[k], float), (n,))

    hinge_x, hinge_y = hinge_xy({k: p(k) for k in HINGE_INPUTS})
    lever2 = (p("wheel.x_cg") - hinge_x) ** 2 + (p("wheel.y_cg") - hinge_y) ** 2
    return np.where(lever2 > 1e-12, m0 / np.maximum(lever2, 1e-12), 1e30)


# the parameters the rolling-resistance torque depends on (vehicle.rolling_resistance_torque)
ROLLING_INPUTS = (
    "wheel.rolling_resistance",
    "wheel.radius",
    "slope_deg",
    "gravity",
    "chassis.mass",
    "wheel.mass",
    "hub.mass",
    "payload.mass",
)


# MJX keeps a friction-loss row for every dof the base model has one on, and a row whose bound
# is exactly 0 went wrong there (four-wheel sum 1433 N m for 48.1 on a 10 deg climb, status ok);
# a bound of 1e-6 N m stands for zero on both engines.
FRICTIONLOSS_ZERO = 1e-6  # N m


def _rolling(model: mujoco.MjModel, p: Mapping[str, np.ndarray], n: int) -> np.ndarray:
    """dof_frictionloss (n, nv): each variant's own rolling-resistance torque on its drive joints.

    The base model gets a positive placeholder where it had none: MJX decides from the base
    model which dofs have friction loss at all."""
    mass = p["chassis.mass"] + 4 * (p["wheel.mass"] + p["hub.mass"]) + p["payload.mass"]
    g_normal = p["gravity"] * np.cos(np.deg2rad(p["slope_deg"]))
    torque = rolling_resistance_torque(p["wheel.rolling_resistance"], p["wheel.radius"], mass, g_normal)
    drive = layout(model).motor_dof[:4]
    out = np.broadcast_to(model.dof_frictionloss, (n, model.nv)).copy()
    out[:, drive] = np.maximum(torque, FRICTIONLOSS_ZERO)[:, None]
    model.dof_frictionloss[drive] = np.where(model.dof_frictionloss[drive] > 0, model.dof_frictionloss[drive], 1.0)
    return out


def _structural_fields(vehicle, scenario, model, params, names, fields) -> None:
    """The varying fields of structural parameters `names`, without a compile per variant (`fields`):
    the compiler's part in closed form, mj_setConst's by MuJoCo on every thread; the ground's shape and
    the dcmotors compiled once per distinct combination of the names that shape them."""
    motors = [k for k in names if k in motor_names(vehicle)]
    others = [k for k in names if k not in motors]
    varying = set(varying_fields(vehicle, scenario, others)) if others else set(SAMEFRAME)
    structure.check_variants(params, names, vehicle)
    n = len(params[names[0]])
    inputs = structure.vehicle_inputs(model, params, n)
    extra: dict[str, np.ndarray] = {}
    shaping = structure.course_names(names, scenario.obstacle)
    if shaping:
        index, models = _compiled_models(vehicle, scenario, params, shaping)
        extra = structure.course_inputs(model, index, models, inputs)
    if motors:  # one compile per distinct motor: its actuators' rows and rotors' armature, mj_setConst the rest
        index, models = _compiled_models(vehicle, scenario, params, motors)
        structure.motor_inputs(model, index, models, inputs)
        varying |= _differing(model, models)
    varying = sorted(varying)
    for name in SAMEFRAME:
        getattr(model, name)[:] = 0  # fast-path flags: off for everyone
    given = {**inputs, **extra}
    outputs = [k for k in varying if k not in given and k not in SAMEFRAME]
    derived = structure.set_const(model, inputs, outputs, n, key=repr((vehicle, scenario)))
    for name in varying:
        if name not in SAMEFRAME:
            fields[name] = given[name] if name in given else derived[name]


def _differing(model: mujoco.MjModel, models: Sequence[mujoco.MjModel]) -> set[str]:
    """The numeric fields in which some of `models` differs from `model` (one ConfigError line where a size
    differs: those cannot vary inside one compiled program)."""
    base = _numeric_fields(model)
    found = set()
    for mm in models:
        for name, values in _numeric_fields(mm).items():
            if values.shape != base[name].shape:
                raise ConfigError(
                    f"the swept motors change the size of {name} (a thermal model or current limit on some "
                    "and not others); allowed: motors that all give both, or one sweep per motor"
                )
            if name not in SAMEFRAME and not np.array_equal(values, base[name]):
                found.add(name)
    return found


def motor_constants(vehicle: Vehicle, scenario: Scenario, params: Mapping[str, np.ndarray], names, n: int) -> dict:
    """Each variant's dcmotor constants for the statistics (MotorStatsConfig.constants, MOTORS order), as
    params `_dc.<name>`, (n, 8) each: the vehicle's motors, or where motor parameters `names` vary, each
    distinct combination's (a catalogue read per combination, not per variant)."""
    from batchveh.stepping.motor_stats import MotorStatsConfig

    if names:
        combos, index = np.unique(np.stack([params[k] for k in names], axis=1), axis=0, return_inverse=True)
        index = index.ravel()
    else:
        combos, index = np.zeros((1, 0)), np.zeros(n, int)
    rows = []
    for row in combos:
        v, _ = variant_setup(vehicle, scenario, dict(zip(names, row.tolist(), strict=True)))
        rows.append(MotorStatsConfig.for_vehicle(v).constants())
    return {f"_dc.{k}": np.stack([r[k] for r in rows])[index] for k in rows[0]}


def _compiled_models(vehicle, scenario, params, names) -> tuple[np.ndarray, list[mujoco.MjModel]]:
    """(index (n,), models): the vehicle compiled once per distinct combination of `names`; variant i's
    is models[index[i]]."""
    combos, index = np.unique(np.stack([params[k] for k in names], axis=1), axis=0, return_inverse=True)
    models = []
    for row in combos:
        values = dict(zip(names, row.tolist(), strict=True))
        v, sc = variant_setup(vehicle, scenario, values)
        try:  # the obstacle's rules were checked on every variant's values (make_batch)
            v.validate("vehicle")
        except ConfigError as err:
            raise ConfigError(f"variant with {values}: {err}") from None
        models.append(model_for(v, sc))
    return index.ravel(), models


def compiled_fields(vehicle, scenario, model, params, names) -> dict[str, np.ndarray]:
    """The reference for `_structural_fields`: the vehicle compiled once per distinct combination of
    `names`, every numeric field that differs from `model`'s in some variant, (n, ...) each (the
    SAMEFRAME flags and the gains aside). About 4 ms a variant; tests/test_fields.py compares."""
    index, models = _compiled_models(vehicle, scenario, params, names)
    out = {}
    for name, base in _numeric_fields(model).items():
        if name in SAMEFRAME or name in ("actuator_gainprm", "actuator_biasprm"):
            continue
        values = np.stack([getattr(m, name) for m in models])
        if not np.array_equal(values, np.broadcast_to(base, values.shape)):
            out[name] = values[index]
    return out


def import_mjx():
    """mujoco.mjx, imported without the line it prints when warp-lang is missing."""
    with contextlib.redirect_stdout(io.StringIO()):
        from mujoco import mjx
    return mjx


# Fields a structural sweep changes that MuJoCo Warp never reads for this vehicle (the warp engine leaves them
# out of its per-world fields): the mass matrix
# diagonal at qpos0 (nothing in mujoco_warp reads dof_M0), the dofs' lengths (read only by sleeping,
# which is off) and the mesh bounding volumes (the vehicle has no mesh). They stay at the base values.
WARP_UNREAD = ("dof_M0", "dof_length", "bvh_aabb")


def mjx_model(batch: VariantBatch) -> tuple[Any, Any]:
    """The MJX model (JAX implementation) with batched fields, and its `in_axes` tree (0 where a field varies).

    The warp engine does not use it: it writes the fields into MuJoCo Warp's own per-world model
    (engines/warp_physics.py)."""
    import jax
    import jax.numpy as jnp

    mjx = import_mjx()
    course.check_backend(batch.model, "mjx")
    m = mjx.put_model(batch.model, impl="jax")
    axes = jax.tree_util.tree_map(lambda _: None, m)
    opt, opt_axes = {}, {}
    top, top_axes = {}, {}
    for name, values in batch.fields.items():
        if name.startswith("opt."):
            opt[name[4:]], opt_axes[name[4:]] = jnp.asarray(values), 0
            continue
        if isinstance(getattr(m, name, None), np.ndarray):
            raise ConfigError(
                f"model field {name} is static in MJX, so the parameters that change it cannot vary on the "
                "mjx backend; allowed: the mujoco backend, or fixed values"
            )
        if not hasattr(m, name):
            continue  # a field MJX does not use (e.g. dof_length)
        top[name], top_axes[name] = jnp.asarray(values), 0
    m = m.replace(opt=m.opt.replace(**opt), **top)
    axes = axes.replace(opt=axes.opt.replace(**opt_axes), **top_axes)
    return m, axes
