"""Rollouts: pure functions that step one vehicle model through a scenario.

- `mjx_stats(model, params, ...)`: MJX, `lax.scan` over steps, statistics reduced
  in the carry; the sweep driver `jit(vmap(...))`s it over a batched model.
- `mjx_series(...)`: MJX, the per-step samples (single runs and tests).
- `mujoco_series(...)`: MuJoCo C, one MjData, the same samples (the reference).

A step: ctrl = controls(p, t); mj_step; sample. The sample after step i is at
t = (i + 1) dt; its torques are the ones applied during that step.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from batchveh.model import drive, wheels
from batchveh.model.indexing import take
from batchveh.model.missions import body_forces_fn
from batchveh.model.scenarios import Scenario, control_schedule, controls_fn
from batchveh.model.vehicle import Layout, layout
from batchveh.stepping import motor_stats, stats
from batchveh.stepping.batch import import_mjx, servo_damping

if TYPE_CHECKING:  # imported where MJX runs (MjxPhysics): MuJoCo C and the warp engine never load it (its copy of
    from mujoco import mjx  # MuJoCo Warp and its JAX modules are 3-7 s of a process's start on a GPU machine)


def float_precision(name: str):
    """A context in which JAX computes in `name` ('f32' or 'f64'): scoped, never process-wide.

    Trace, compile and call an MJX program inside it; arrays made outside keep their dtype."""
    if name not in ("f32", "f64"):
        raise ValueError(f"precision {name!r}; allowed: f32, f64")
    if hasattr(jax, "enable_x64"):  # JAX >= 0.8
        return jax.enable_x64(name == "f64")
    from jax.experimental import disable_x64, enable_x64

    return enable_x64() if name == "f64" else disable_x64()


def host_cpu() -> jax.Device:
    """The host's CPU as a JAX device: where the `mujoco` engine's JAX work (controls, the wheel-ground step
    between MuJoCo C's steps) runs, on a GPU host too, instead of one small GPU call and copy per step."""
    return jax.devices("cpu")[0]


class MjxPhysics:
    """The physics of one variant's scan in MJX: what `physics_stats` needs of it.

    The protocol (the warp engine's view of MuJoCo Warp, engines/warp.py, is the other): `dt`, `body_mass`,
    `iterations` (the solver's limit where the implementation reports its iteration count, else None), `start()`
    (the first data, forwarded), `step(d)` and `fault(d)` (per variant, whether the step lost part of its physics,
    e.g. contacts past a buffer; None where the implementation cannot tell)."""

    def __init__(self, model: mjx.Model, data: mjx.Data | None = None):
        self.model, self.data = model, data
        self.dt, self.body_mass = model.opt.timestep, model.body_mass
        self.iterations = None  # MJX's JAX solver leaves its iteration count at 0

    def fault(self, d: mjx.Data) -> None:
        return None

    def start(self) -> mjx.Data:
        """The initial data at the variant's own qpos0 (a swept chassis position moves it), forwarded."""
        mjx = import_mjx()
        m, d = self.model, self.data
        d0 = mjx.make_data(m) if d is None else d.replace(qpos=m.qpos0.astype(d.qpos.dtype))
        return mjx.forward(m, d0)

    def step(self, d: mjx.Data) -> mjx.Data:
        return import_mjx().step(self.model, d)


def _scan(phys, params: Mapping[str, Any], scenario: Scenario, lay: Layout, body_out, motors=None):
    """The scan's body over ((data, tyre state, drive state), reductions). `body_out(d, acc, sample, i)`
    returns ((d, acc), output) as a scan body would. With dcmotors, the drive (model/drive.py) turns the
    scenario's servo controls into each motor's voltage, step by step."""
    ctrl_fn = controls_fn(scenario)
    forces_fn = body_forces_fn(scenario)  # a mission's slope in time; None otherwise
    dt = phys.dt
    tp = wheels.params(params, lay.wheel_ground, jnp)

    damping = servo_damping(params, scenario.towing, xp=jnp, dcmotor=lay.dcmotor)

    dc = drive.constants(params, jnp, dt.dtype) if lay.dcmotor else None
    consts = motor_stats.constants_of(motors, params, jnp) if motors is not None else None

    def body(carry, i):
        (d, ts, ds), acc = carry
        ctrl = ctrl_fn(params, i * dt).astype(d.qvel.dtype)
        sim_ctrl, record = ctrl, None
        if dc is not None:
            q_steer, qvel = take(d.qpos, lay.motor_qpos[4:]), take(d.qvel, lay.motor_dof)
            sim_ctrl, ds, record = drive.step(ds, ctrl, q_steer, qvel, dc, dt, jnp)
        xfrc = None
        if forces_fn is not None:
            xfrc = forces_fn(params, phys.body_mass, i * dt).astype(d.xfrc_applied.dtype)
        if tp is not None:
            ts, on_wheels = tyre_step(d, ts, tp, lay, dt)
            xfrc = on_wheels if xfrc is None else xfrc + on_wheels
        if xfrc is not None:
            d = d.replace(xfrc_applied=xfrc)
        qvel_prev = d.qvel
        d = phys.step(d.replace(ctrl=sim_ctrl.astype(d.ctrl.dtype)))
        dv = take(d.qvel - qvel_prev, lay.motor_dof)
        electric = None
        if motors is not None:  # the dcmotors' electrical sample (motor_stats), a block of one step
            force, speed = take(d.actuator_force, lay.motor_act), take(d.actuator_velocity, lay.motor_act)
            electric = motor_stats.sample(force[None], speed[None], record["T"][None], record["v"][None], motors,
                                          jnp, consts)  # fmt: skip
            electric = jax.tree_util.tree_map(lambda v: v[0], electric)
        s = stats.sample(d.qpos, d.qvel, d.qfrc_actuator, ctrl, params["wheel.radius"], lay, damping, dv, electric)
        (d, acc), out = body_out(d, acc, s, i)
        return ((d, ts, ds), acc), out

    return body


def tyre_step(d: mjx.Data, ts, tp, lay: Layout, dt):
    """The wheel-ground model's next state and its wrenches as xfrc_applied (nbody, 6) from MJX data
    after a step: positions and contact forces of that step's forward pass, velocities now."""
    cfrc = d._impl.cfrc_ext if lay.wheel_ground == "slip" else None
    nbody = d.xfrc_applied.shape[-2]
    ts, xfrc = wheels.step_xfrc(ts, d.xpos, d.xmat, d.qvel, cfrc, d.xfrc_applied, tp, lay, dt, nbody, jnp)
    return ts, xfrc.astype(d.xfrc_applied.dtype)


def _init(phys, params: Mapping[str, Any], lay: Layout):
    """The scan's first (data, wheel-ground state, drive state). The data is forwarded, as MuJoCo C's is
    before its first step: a wheel-ground model reads the last forward pass's positions and contact forces,
    and those of unforwarded data are zeros (the soil saw each wheel sunk to its axle). The drive's state
    (dcmotors): its loops' integrals at 0, each winding at its start rise."""
    d0 = phys.start()
    dtype = d0.qvel.dtype
    ds = ()
    if lay.dcmotor:
        rise = (params["motors.drive_start_rise"], params["motors.steer_start_rise"])
        ds = drive.init(drive.constants(params, jnp, dtype), rise, jnp, dtype)
    return d0, wheels.init_state((), jnp, dtype), ds


def mjx_stats(
    model: mjx.Model,
    params: Mapping[str, Any],
    *,
    scenario: Scenario,
    cfg: stats.StatsConfig,
    lay: Layout,
    data: mjx.Data | None = None,
    unroll: int = 1,
) -> dict[str, jax.Array]:
    """Statistics columns of one variant in MJX (pure; vmap it over a batched model): `physics_stats`.

    data: the initial data; default `mjx.make_data(model)`. Either way it starts at the variant's own qpos0."""
    return physics_stats(MjxPhysics(model, data), params, scenario=scenario, cfg=cfg, lay=lay, unroll=unroll)


def physics_stats(
    phys, params: Mapping[str, Any], *, scenario: Scenario, cfg: stats.StatsConfig, lay: Layout, unroll: int = 1
) -> dict[str, jax.Array]:
    """Statistics columns of one variant (pure; vmap it), and, where the implementation reports it,
    `solver_limit_share`: the share of steps whose solve used all of its iterations (stopped on the
    limit rather than the tolerance). phys: the variant's physics (`MjxPhysics`' protocol). unroll: steps
    per iteration of the scan's loop (`lax.scan`'s)."""
    dtype = phys.dt.dtype
    health = phys.iterations is not None
    zero = jnp.zeros((), jnp.int32)

    def out(d, carry, s, i):
        acc, at_limit, faults = carry
        block = jax.tree_util.tree_map(lambda v: v[None], s)  # a block of one step: time axis -2
        if health:
            at_limit = at_limit + (d._impl.solver_niter >= phys.iterations).astype(jnp.int32)
        fault = phys.fault(d)
        if fault is not None:
            faults = faults + fault.astype(jnp.int32)
        return (d, (stats.update(acc, block, i[None], cfg, xp=jnp), at_limit, faults)), None

    body = _scan(phys, params, scenario, lay, out, cfg.motors)
    init = (_init(phys, params, lay), (stats.init(cfg, (), xp=jnp, dtype=dtype), zero, zero))
    (_, (acc, at_limit, faults)), _ = jax.lax.scan(body, init, jnp.arange(cfg.n_steps), unroll=unroll)
    cols = stats.finalize(acc, cfg, xp=jnp)
    # a step that lost part of its physics (contacts past the buffer) makes the variant diverged (stats.STATUS 1)
    cols["status_code"] = jnp.where(faults > 0, jnp.ones_like(cols["status_code"]), cols["status_code"])
    if health:
        cols["solver_limit_share"] = at_limit.astype(dtype) / cfg.n_steps
    return cols


def mjx_series(
    model: mjx.Model,
    params: Mapping[str, Any],
    *,
    scenario: Scenario,
    n_steps: int,
    lay: Layout,
    data: mjx.Data | None = None,
) -> dict[str, jax.Array]:
    """Per-step samples of one variant, each (n_steps, ...); `data` as in `mjx_stats`."""

    def out(d, acc, s, i):
        return (d, acc), s

    phys = MjxPhysics(model, data)
    body = _scan(phys, params, scenario, lay, out)
    _, series = jax.lax.scan(body, (_init(phys, params, lay), ()), jnp.arange(n_steps))
    return series


def mujoco_steps(
    m: mujoco.MjModel, params: Mapping[str, Any], *, scenario: Scenario, n_steps: int, record: dict | None = None
) -> Iterator[tuple[mujoco.MjData, np.ndarray]]:
    """Step MuJoCo C (float64) through the scenario; yield (data, controls) after each step.

    Before the first step the data is forwarded (for a first frame, say) and yielded with
    controls None. The same data object is yielded every time. With dcmotors, `record` (a dict, if
    given) holds the drive's record of the step just taken (drive.step: T, v, held) and its state."""
    d = mujoco.MjData(m)
    times = np.arange(n_steps) * m.opt.timestep
    forces_fn = body_forces_fn(scenario)
    with float_precision("f64"):  # MuJoCo C is the float64 reference: so are its controls
        p = {k: np.asarray(v, np.float64) for k, v in params.items()}
        ctrls = np.asarray(jax.jit(control_schedule(scenario))(p, times))
        if forces_fn is not None:
            forces = np.asarray(jax.jit(jax.vmap(forces_fn, in_axes=(None, None, 0)))(p, m.body_mass, times))
    lay = layout(m)
    tyre = MujocoTyre(m, lay, p) if lay.applied else None
    motor_drive = MujocoDrive(lay, p, m.opt.timestep) if lay.dcmotor else None
    mujoco.mj_forward(m, d)
    yield d, None
    for i in range(n_steps):
        if motor_drive is not None:
            d.ctrl[:] = motor_drive.voltages(ctrls[i], d.qpos, d.qvel)
            if record is not None:
                record.update(motor_drive.record, state=motor_drive.state)
        else:
            d.ctrl[:] = ctrls[i]
        xfrc = forces[i] if forces_fn is not None else np.zeros_like(d.xfrc_applied)
        if tyre is not None:
            xfrc = xfrc + tyre.wrench(d.xpos, d.xmat.reshape(-1, 3, 3), d.qvel, d.cfrc_ext, d.xfrc_applied)
        d.xfrc_applied[:] = xfrc
        mujoco.mj_step(m, d)
        yield d, ctrls[i]


class MujocoDrive:
    """The dcmotors' drive (model/drive.py) between MuJoCo C steps, in float64 numpy, for one simulation or a
    batch (leading axes of `params`' values). `voltages` steps it; `record` is the last step's record."""

    def __init__(self, lay: Layout, params: Mapping[str, Any], dt: float):
        self.lay, self.dt = lay, float(dt)
        self.c = drive.constants(params, np, np.float64)
        rise = (params["motors.drive_start_rise"], params["motors.steer_start_rise"])
        self.state = drive.init(self.c, tuple(np.asarray(r, np.float64) for r in rise), np, np.float64)
        self.record: dict[str, np.ndarray] = {}

    def voltages(self, servo_ctrl, qpos, qvel) -> np.ndarray:
        """The motors' voltages (..., 8) for the scenario's controls (..., 16) and the state now."""
        q_steer, rate = qpos[..., self.lay.motor_qpos[4:]], qvel[..., self.lay.motor_dof]
        u, self.state, self.record = drive.step(self.state, servo_ctrl, q_steer, rate, self.c, self.dt, np)
        return u.reshape(*np.shape(rate)[:-1], 8)


class MujocoTyre:
    """The slip tyre or the soil between MuJoCo C steps, for one simulation or a batch (leading
    axes). `wrench` takes the last forward pass's positions and contact forces, the velocities now,
    and the xfrc_applied that forward pass ran with; it returns xfrc_applied for the tyres alone
    and advances the tyre state.

    The array code is `wheels.step`, the one the MJX and warp scans run, compiled by XLA for the
    CPU in float64: one fused loop instead of some two hundred numpy passes over the batch (3.0x
    less time per step at 2,048 variants; wrenches equal to numpy's within 6e-14 N,
    benchmarks/results/archive.json: cpu-2core-wheel-ground-step.json)."""

    def __init__(self, m: mujoco.MjModel, lay: Layout, params: Mapping[str, Any]):
        self.nbody = m.nbody
        self._step = _c_step(lay, float(m.opt.timestep), m.nbody)
        tp = wheels.params({k: np.asarray(v, np.float64) for k, v in params.items()}, lay.wheel_ground, np)
        with float_precision("f64"):  # committed to the CPU: the jitted step runs there
            self.tp = jax.device_put(tp, host_cpu())
            self.state = jax.device_put(wheels.init_state(np.shape(params["friction"]), np), host_cpu())

    def wrench(self, xpos, xmat, qvel, cfrc_ext, xfrc_applied) -> np.ndarray:
        with float_precision("f64"):
            self.state, xfrc = self._step(self.state, xpos, xmat, qvel, cfrc_ext, xfrc_applied, self.tp)
        return np.asarray(xfrc)


_C_STEPS: dict[tuple, Any] = {}


def _c_step(lay: Layout, dt: float, nbody: int):
    """The jitted wheel-ground step of MujocoTyre, one per vehicle structure and time step (a sweep's
    chunks share it; XLA compiles it once per batch shape, about 0.6 s)."""
    key = (dt, nbody, *(tuple(v.ravel().tolist()) if isinstance(v, np.ndarray) else v for v in vars(lay).values()))
    if key not in _C_STEPS:
        _C_STEPS[key] = jax.jit(functools.partial(wheels.step_xfrc, lay=lay, dt=dt, nbody=nbody, xp=jnp))
    return _C_STEPS[key]


def mujoco_series(
    m: mujoco.MjModel, params: Mapping[str, Any], *, scenario: Scenario, n_steps: int
) -> dict[str, np.ndarray]:
    """Per-step samples from MuJoCo C (float64), the reference for MJX."""
    lay = layout(m)
    radius = float(params["wheel.radius"])
    damping = servo_damping(params, scenario.towing, dcmotor=lay.dcmotor)
    rows, prev = [], None
    for d, ctrl in mujoco_steps(m, params, scenario=scenario, n_steps=n_steps):
        if ctrl is not None:
            state = d.qpos.copy(), d.qvel.copy(), d.qfrc_actuator.copy()
            dv = (d.qvel - prev)[lay.motor_dof]
            rows.append(stats.sample(*state, ctrl, radius, lay, damping, dv))
        prev = d.qvel.copy()
    return {k: np.stack([r[k] for r in rows]) for k in rows[0]}


def series_stats(series: Mapping[str, np.ndarray], cfg: stats.StatsConfig) -> dict[str, Any]:
    """Statistics of a recorded series, by the same reduction the sweeps use."""
    acc = stats.init(cfg, ())
    block = {k: np.asarray(v[: cfg.n_steps], np.float64) for k, v in series.items()}
    acc = stats.update(acc, block, np.arange(cfg.n_steps), cfg)
    return stats.finalize(acc, cfg)
