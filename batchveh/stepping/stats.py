"""Per-variant motor-torque statistics, reduced step by step in a fixed-size carry.

`init`, `update` and `finalize` are written once over an array module `xp` (numpy
or jax.numpy) and leading batch dimensions `...`: the MJX rollout calls them
inside `lax.scan` (vmapped, no batch dims, blocks of one step), the MuJoCo C
backend on (n, ...) numpy arrays, a block of steps at a time. Memory does not
grow with the number of steps.

Windows and filters (all recorded in the Parquet metadata):
- the settle: the first `settle_steps` steps, before law time 0 (scenarios: the laws held at
  their t = 0 values while the vehicle settles onto its contacts). They enter no statistic,
  `*_all`, energy, distance and max roll and pitch included; the low-pass filter runs
  through them, so it starts the motion at the holding torque, and a diverged state in them
  still marks the variant diverged. Step indices `i` count from the settle's first step;
  times (the window, the time step's samples) count from law time 0;
- the steady window [window_start, window_end] in s of law time (default: second half of
  the run after the settle);
- the 95th percentile of |torque| is taken over at most `p95_samples` samples of
  the steady window, evenly strided (the stride is recorded; exact when the
  window has fewer steps);
- `lowpass_s`: time constant of a first-order low-pass filter applied to each
  torque before `peak_lp` (default 0.05 s: a motor and its drive respond to
  tens of ms, not to one 5 ms step, and the filter removes float32 chatter);
- a mission (`StatsConfig.mission`): its statistics over the whole mission and each segment,
  folded by `mission_stats` in the same carry, after the filter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from batchveh.config import ConfigError
from batchveh.model import soil
from batchveh.model.indexing import take
from batchveh.model.vehicle import CHANNELS, CORNERS, Vehicle
from batchveh.stepping import mission_stats, motor_stats

N_CH = len(CHANNELS)
STATUS = {0: "ok", 1: "diverged", 2: "flipped", 3: "stuck", 4: "short"}  # stuck, short: set by course.flag
FLIP_DEG = 60.0  # roll or pitch beyond which the vehicle counts as flipped
SLIP_LIMIT = 0.1  # |slip ratio| above which a variant is flagged as slipping
MIN_WINDOW_STEPS = 5  # fewer steps in the steady window give no meaningful mean, RMS or percentile
STEADY_ACCEL = 0.05  # m/s^2: |window_accel| below which the window counts as steady
# Beyond these a state is diverged, whether or not it is still finite (MuJoCo's own check,
# mjMAXVAL, is 1e10 on qpos, qvel and qacc; these are far past anything physical here)
HUGE_TORQUE = 1e8  # N m
HUGE_SPEED = 1e3  # m/s, chassis
HUGE_POSITION = 1e6  # m


def slip_limit(vehicle: Vehicle) -> float:
    """The |slip ratio| above which a variant of `vehicle` is flagged as slipping: SLIP_LIMIT on
    rigid ground; on soil, where a wheel drives at tens of percent of slip, soil.SLIP_LIMIT."""
    return soil.SLIP_LIMIT if vehicle.tyre.model == "soil" else SLIP_LIMIT


@dataclass(frozen=True)
class StatsConfig:
    """Static settings of the reduction (they fix array shapes)."""

    dt: float  # time step, s
    n_steps: int  # every step the engine takes, the settle's included
    window_start: float  # s of law time (from the end of the settle)
    window_end: float  # s of law time
    lowpass_s: float = 0.05
    p95_samples: int = 256
    settle_steps: int = 0  # the first steps, left out of every statistic
    mission: mission_stats.MissionStatsConfig | None = None  # a mission's spans (scenario kind mission)
    slip_limit: float = SLIP_LIMIT  # |slip ratio| above which the variant is flagged as slipping
    motors: motor_stats.MotorStatsConfig | None = None  # dcmotors' constants (vehicle.motors.model dcmotor)

    @staticmethod
    def make(
        dt: float, n_steps: int, window: tuple[float, float] | None = None, settle_steps: int = 0, **kw: Any
    ) -> StatsConfig:
        """Settings for `n_steps` steps of `dt` s, of which the first `settle_steps` settle; the
        window (law time, from the end of the settle) defaults to the second half of the rest.

        Raises ConfigError where the statistics could not be valid: no steps after the settle, a
        window outside (0, total time], or fewer than MIN_WINDOW_STEPS steps in it."""
        run = n_steps - settle_steps
        total = dt * run
        if run < 1 or settle_steps < 0:
            raise ConfigError(f"total_time gives {run} steps of {dt:g} s; allowed: at least one step")
        start, end = window if window is not None else (total / 2, total)
        if not 0 <= start < end <= total * (1 + 1e-9):
            raise ConfigError(
                f"window: [{start:g}, {end:g}] s is not allowed; allowed: 0 <= start < end <= total_time ({total:g} s)"
            )
        cfg = StatsConfig(
            dt=dt, n_steps=n_steps, window_start=start, window_end=min(end, total), settle_steps=settle_steps, **kw
        )
        if cfg.window_steps < MIN_WINDOW_STEPS:
            raise ConfigError(
                f"window: [{start:g}, {end:g}] s holds {cfg.window_steps} steps of {dt:g} s; "
                f"allowed: at least {MIN_WINDOW_STEPS} (a longer window or total_time, or a shorter time_step)"
            )
        return cfg

    @staticmethod
    def for_scenario(scenario: Any, window: tuple[float, float] | None = None, **kw: Any) -> StatsConfig:
        """`make` for a scenario's steps and settle (a scenarios.Scenario), with a mission's spans."""
        kw.setdefault("mission", mission_stats.MissionStatsConfig.for_scenario(scenario))
        return StatsConfig.make(scenario.time_step, scenario.n_steps, window, scenario.settle_steps, **kw)

    @property
    def first(self) -> int:
        """First step index inside the window (0-based from the settle's first step; the sample
        after step i is at law time t = (i + 1 - settle_steps) dt)."""
        return self.settle_steps + max(0, math.ceil(self.window_start / self.dt - 1 - 1e-9))

    @property
    def last(self) -> int:
        return min(self.n_steps - 1, self.settle_steps + math.floor(self.window_end / self.dt - 1 + 1e-9))

    @property
    def window_steps(self) -> int:
        return max(0, self.last - self.first + 1)

    @property
    def stride(self) -> int:
        return max(1, math.ceil(self.window_steps / self.p95_samples))

    @property
    def n_buf(self) -> int:
        return max(1, math.ceil(self.window_steps / self.stride))


def sample(
    qpos, qvel, qfrc_actuator, ctrl, wheel_radius, lay, damping=None, motor_dv=None, motors=None
) -> dict[str, Any]:
    """The quantities `update` folds, read from MuJoCo state arrays of any leading shape.

    qpos, qvel, qfrc_actuator: (..., nq / nv) after a step; ctrl: (..., nu); wheel_radius: the
    variant's own wheel radius in m, broadcastable to the leading shape; lay: the vehicle's Layout.

    The motor torque is the torque the step applied. `implicitfast` integrates each servo's
    damping kv at the end-of-step speed, while `qfrc_actuator` holds it at the start-of-step
    speed, so with `damping` (..., 8) (kv per motor, N m s/rad) and `motor_dv` (..., 8) (each
    motor joint's speed change over the step, rad/s) the applied torque is qfrc_actuator -
    kv dv: 3.6 N m less per wheel at 5 ms on a 1 s ramp to 1 km/h (validation/PEAKS.md).
    Without them, qfrc_actuator as it is. `motors`: the dcmotors' sample (`motor_stats.sample`), kept
    as it is for the electrical statistics; there `damping` is the back-EMF's (model/drive.py), which MuJoCo
    leaves out of a step where its saturation clipped the motor (`at_i`).
    """
    rate = take(qvel, lay.motor_dof)  # the 8 motor joints' speeds, drives first
    omega = rate[..., :4]
    tau = take(qfrc_actuator, lay.motor_dof)
    if damping is not None:
        if motors is not None:
            damping = damping * (1.0 - motors["at_i"])
        tau = tau - damping * motor_dv
    extra = {} if motors is None else {"motors": motors}
    return {
        **extra,
        "tau": tau,
        "omega": omega,
        "rate": rate,
        "rim": omega.mean(-1) * wheel_radius,
        "alpha": take(qpos, lay.motor_qpos[4:]),
        "ref": ctrl[..., :8],
        "pos": qpos[..., 0:3],
        "quat": qpos[..., 3:7],
        "vel": qvel[..., 0:3],
    }


def init(cfg: StatsConfig, batch: tuple[int, ...], xp=np, dtype=None) -> dict[str, Any]:
    """Empty carry for `batch` leading dims."""
    dtype = dtype or xp.float64

    def z(*shape, fill=0.0):
        return xp.full((*batch, *shape), fill, dtype=dtype)

    mission = {}
    if cfg.mission is not None:
        mission["mission"] = mission_stats.init(cfg.mission, batch, xp, dtype, motors=cfg.motors is not None)
    if cfg.motors is not None:
        mission["motors"] = motor_stats.init(batch, xp, dtype, hot=cfg.motors.hot)
    return {
        **mission,
        "n": z(),
        "sum": z(N_CH),
        "sumsq": z(N_CH),
        "min": z(N_CH, fill=np.inf),
        "max": z(N_CH, fill=-np.inf),
        "buf": z(cfg.n_buf, N_CH),
        "peak_all": z(N_CH),
        "lp": z(N_CH),
        "lp_peak": z(N_CH),
        "lp_peak_all": z(N_CH),
        "energy": z(4),
        "power_peak": z(4),
        "distance": z(),
        "roll": z(),
        "pitch": z(),
        "bad": z(),
        "v_fwd": z(),
        "v_rim": z(),
        "omega": z(),
        "speed_err": z(4),
        "speed_ref": z(4),
        "steer_err": z(4),
        "tv": z(),
        "t": z(),
        "tt": z(),
        "pose": z(3),
    }


def _roll_pitch_yaw(q, xp):
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    roll = xp.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = xp.arcsin(xp.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = xp.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def _lowpass(y0, x, a, xp):
    """First-order filter y_k = y_{k-1} + a (x_k - y_{k-1}) along the time axis -2; returns all y."""
    if x.shape[-2] == 1:
        return (y0 + a * (x[..., 0, :] - y0))[..., None, :]
    from scipy.signal import lfilter  # numpy blocks only

    y, _ = lfilter([a], [1.0, a - 1.0], x, axis=-2, zi=((1.0 - a) * y0)[..., None, :])
    return y


def _span(inw, xp) -> str | None:
    """'all' or 'none' where a numpy block lies wholly inside or outside the window; None for a
    mixed block or traced (JAX) values. The fast paths it selects give the same bits as the
    masked forms: 1.0 * x is x, and 0.0 * x is a signed zero, or NaN where x is not finite."""
    if xp is not np:
        return None
    if inw.all():
        return "all"
    return None if inw.any() else "none"


def _bsum(w, x, span, axis, xp):
    """(w * x).sum(axis) for step weights w of 0 or 1, with the masks skipped where `span` allows."""
    if span == "all":
        return x.sum(axis)
    if span == "none":  # every term 0 * x: 0 unless some x is not finite
        return xp.where(xp.isfinite(x).all(axis), 0.0, np.nan)
    return (w * x).sum(axis)


def _wsum(c, w, x, span, axis, xp):
    """c + (w * x).sum(axis) for step weights w of 0 or 1, with the masks skipped where `span` allows."""
    return c + _bsum(w, x, span, axis, xp)


def _wmax(c, inw, x, span, xp, axis=-2):
    """max(c, largest x over the block's steps where inw (B,)); x (..., B, K) (axis -2) or (..., B)
    (axis -1) is >= 0."""
    if span == "none":
        return c
    mask = inw[:, None] if axis == -2 else inw
    return xp.maximum(c, (x if span == "all" else xp.where(mask, x, 0.0)).max(axis))


def _store(buf, slot, absx, xp):
    """buf with row slot[b] set to absx[..., b, :] for each step b of the block with slot[b] >= 0."""
    if xp is np:  # numpy: write the rows that are hit, nothing else (the slots of a block are distinct)
        b = np.flatnonzero(slot >= 0)
        if not b.size:
            return buf
        buf, k, d = buf.copy(), slot[b], (b[1] - b[0] if b.size > 1 else 1)
        if (np.diff(b) == d).all() and (np.diff(k) == 1).all():  # every stride-th step: slices, not a gather
            buf[..., k[0] : k[-1] + 1, :] = absx[..., b[0] : b[-1] + 1 : d, :]
        else:
            buf[..., k, :] = absx[..., b, :]
        return buf
    if slot.shape[-1] == 1:
        # the MJX scan's block of one step: one row read and written in place, not all K rows rewritten
        # (a select over the whole buffer moved 2 x 9 KB per variant and step: 1.8 GB a step at 100,000)
        from jax import lax

        k, axis = xp.maximum(slot[0], 0), buf.ndim - 2
        row = xp.where(slot[0] >= 0, absx[..., 0, :], lax.dynamic_index_in_dim(buf, k, axis, keepdims=False))
        return lax.dynamic_update_index_in_dim(buf, row, k, axis)
    hit = xp.arange(buf.shape[-2])[:, None] == slot[None, :]  # (K, B): slot k takes step b of the block
    taken = xp.take(absx, xp.argmax(hit, axis=-1), axis=-2)  # a gather: cost n K C, not n K B C
    return xp.where(hit.any(-1)[:, None], taken, buf)


def update(c: dict[str, Any], s: dict[str, Any], i, cfg: StatsConfig, xp=np) -> dict[str, Any]:
    """Fold a block of B steps' samples `s` (after steps i, shape (B,)) into carry `c`.

    Every sample array has a time axis -2 of length B: tau (..., B, 8) N m; omega
    (..., B, 4) wheel speed rad/s; ref (..., B, 8) imposed omega (rad/s) and alpha
    (rad); alpha (..., B, 4) steering angle rad; pos (..., B, 3) m; quat (..., B, 4);
    vel (..., B, 3) chassis linear velocity m/s (world). The MJX scan folds blocks
    of one step; the MuJoCo C backend folds blocks of a rollout, cheapest when each
    block lies wholly inside or outside the steady window and the settle (`_span`).
    Steps i < cfg.settle_steps (the settle) enter no statistic; only the low-pass state,
    the divergence flag and the final pose follow them.
    """
    tau = xp.concatenate([s["tau"], s["tau"][..., :4].sum(-1, keepdims=True)], axis=-1)
    absx = xp.abs(tau)
    inw = (i >= cfg.first) & (i <= cfg.last)  # (B,)
    span = _span(inw, xp)
    run = i >= cfg.settle_steps  # (B,): past the settle
    span_r = "all" if cfg.settle_steps == 0 else _span(run, xp)
    wr = xp.where(run, 1.0, 0.0)
    w = xp.where(inw, 1.0, 0.0)
    wk = w[:, None]
    out = dict(c)
    out["n"] = c["n"] + w.sum()
    out["sum"] = _wsum(c["sum"], wk, tau, span, -2, xp)
    if span is None:
        out["sumsq"] = c["sumsq"] + (wk * tau * tau).sum(-2)
    else:  # (w tau) tau: tau * tau inside, 0 * tau (then * tau: the same zero or NaN) outside
        out["sumsq"] = _wsum(c["sumsq"], wk, tau * tau if span == "all" else tau, span, -2, xp)
    if span != "none":
        out["min"] = xp.minimum(c["min"], (tau if span == "all" else xp.where(inw[:, None], tau, np.inf)).min(-2))
        out["max"] = xp.maximum(c["max"], (tau if span == "all" else xp.where(inw[:, None], tau, -np.inf)).max(-2))
    slot = xp.where(inw & ((i - cfg.first) % cfg.stride == 0), (i - cfg.first) // cfg.stride, -1)  # (B,)
    out["buf"] = _store(c["buf"], slot, absx, xp)
    out["peak_all"] = _wmax(c["peak_all"], run, absx, span_r, xp)
    lp = _lowpass(c["lp"], tau, cfg.dt / (cfg.lowpass_s + cfg.dt), xp)
    out["lp"] = lp[..., -1, :]
    abs_lp = xp.abs(lp)
    out["lp_peak"] = _wmax(c["lp_peak"], inw, abs_lp, span, xp)
    out["lp_peak_all"] = _wmax(c["lp_peak_all"], run, abs_lp, span_r, xp)
    power = s["tau"][..., :4] * s["omega"]
    out["energy"] = c["energy"] + _bsum(wr[:, None], power, span_r, -2, xp) * cfg.dt
    out["power_peak"] = _wmax(c["power_peak"], run, xp.abs(power), span_r, xp)
    vel = s["vel"]
    speed = xp.sqrt(vel[..., 0] ** 2 + vel[..., 1] ** 2)
    out["distance"] = c["distance"] + _bsum(wr, speed, span_r, -1, xp) * cfg.dt
    roll, pitch, yaw = _roll_pitch_yaw(s["quat"], xp)  # (..., B)
    out["roll"] = _wmax(c["roll"], run, xp.abs(roll), span_r, xp, axis=-1)
    out["pitch"] = _wmax(c["pitch"], run, xp.abs(pitch), span_r, xp, axis=-1)
    sane = (
        xp.all(absx < HUGE_TORQUE, axis=(-2, -1))  # False for NaN too
        & xp.all(xp.abs(s["vel"]) < HUGE_SPEED, axis=(-2, -1))
        & xp.all(xp.abs(s["pos"]) < HUGE_POSITION, axis=(-2, -1))
    )
    out["bad"] = xp.maximum(c["bad"], xp.where(sane, 0.0, 1.0))
    v_fwd = vel[..., 0] * xp.cos(yaw) + vel[..., 1] * xp.sin(yaw)
    out["v_fwd"] = _wsum(c["v_fwd"], w, v_fwd, span, -1, xp)
    # least-squares trend of the forward speed over the window (t relative to its start)
    if span == "none":  # tw is a signed zero at every step: t and tt keep their values
        out["tv"] = _wsum(c["tv"], w, v_fwd, span, -1, xp)
    else:
        tw = w * (i - cfg.first) * cfg.dt
        out["tv"] = c["tv"] + (tw * v_fwd).sum(-1)
        out["t"] = c["t"] + tw.sum()
        out["tt"] = c["tt"] + (tw * tw).sum()
    out["v_rim"] = _wsum(c["v_rim"], w, s["rim"], span, -1, xp)
    out["omega"] = _wsum(c["omega"], w, s["omega"].mean(-1), span, -1, xp)
    ref_w = s["ref"][..., :4]
    out["speed_err"] = _wsum(c["speed_err"], wk, s["omega"] - ref_w, span, -2, xp)
    out["speed_ref"] = _wsum(c["speed_ref"], wk, ref_w, span, -2, xp)
    if span != "none":
        out["steer_err"] = _wmax(c["steer_err"], inw, xp.abs(s["alpha"] - s["ref"][..., 4:]), span, xp)
    out["pose"] = xp.stack([s["pos"][..., -1, 0], s["pos"][..., -1, 1], yaw[..., -1]], axis=-1)
    if cfg.motors is not None:
        out["motors"] = motor_stats.update(c["motors"], s["motors"], s["tau"], w, wr, cfg.dt, xp)
    if cfg.mission is not None:
        out["mission"] = mission_stats.update(c["mission"], tau, lp, s, i, cfg.mission, xp)
    return out


def finalize(c: dict[str, Any], cfg: StatsConfig, xp=np) -> dict[str, Any]:
    """Turn the carry into named columns, each of shape (...)."""
    n = xp.maximum(c["n"], 1.0)[..., None]
    mean = c["sum"] / n
    rms = xp.sqrt(xp.maximum(c["sumsq"] / n, 0.0))
    p95 = xp.percentile(c["buf"], 95.0, axis=-2)
    peak = xp.maximum(xp.abs(c["min"]), xp.abs(c["max"]))
    cols: dict[str, Any] = {}
    for k, name in enumerate(CHANNELS):
        cols[f"{name}_mean"] = mean[..., k]
        cols[f"{name}_rms"] = rms[..., k]
        cols[f"{name}_min"] = c["min"][..., k]
        cols[f"{name}_max"] = c["max"][..., k]
        cols[f"{name}_peak"] = peak[..., k]
        cols[f"{name}_p95"] = p95[..., k]
        cols[f"{name}_peak_all"] = c["peak_all"][..., k]
        cols[f"{name}_peak_lp"] = c["lp_peak"][..., k]
        cols[f"{name}_peak_lp_all"] = c["lp_peak_all"][..., k]
    for k, corner in enumerate(CORNERS):
        cols[f"drive_{corner}_energy"] = c["energy"][..., k]
        cols[f"drive_{corner}_power_peak"] = c["power_peak"][..., k]
    nw = xp.maximum(c["n"], 1.0)
    v_fwd, v_rim = c["v_fwd"] / nw, c["v_rim"] / nw
    moving = xp.abs(v_rim) > 1e-3
    cols["distance"] = c["distance"]
    cols["wheel_speed"] = c["omega"] / nw
    cols["mean_speed"] = v_fwd
    cols["slip_ratio"] = xp.where(moving, 1.0 - v_fwd / xp.where(moving, v_rim, 1.0), 0.0)
    cols["slipping"] = xp.abs(cols["slip_ratio"]) > cfg.slip_limit
    denom = c["n"] * c["tt"] - c["t"] ** 2
    trend = (c["n"] * c["tv"] - c["t"] * c["v_fwd"]) / xp.where(denom > 0, denom, 1.0)
    cols["window_accel"] = xp.where(denom > 0, trend, 0.0)
    cols["steady"] = xp.abs(cols["window_accel"]) < STEADY_ACCEL
    ref = xp.abs(c["speed_ref"] / n)
    err = xp.abs(c["speed_err"] / n)
    cols["speed_track_err"] = xp.max(xp.where(ref > 1e-6, err / xp.where(ref > 1e-6, ref, 1.0), err), axis=-1)
    cols["steer_track_err_deg"] = xp.rad2deg(xp.max(c["steer_err"], axis=-1))
    cols["max_roll_deg"] = xp.rad2deg(c["roll"])
    cols["max_pitch_deg"] = xp.rad2deg(c["pitch"])
    cols["final_x"] = c["pose"][..., 0]
    cols["final_y"] = c["pose"][..., 1]
    cols["final_yaw_deg"] = xp.rad2deg(c["pose"][..., 2])
    flipped = (cols["max_roll_deg"] > FLIP_DEG) | (cols["max_pitch_deg"] > FLIP_DEG)
    # a statistic that is not finite can only come from a bad state: never report it as ok
    finite = c["n"] > 0
    for name in cols:
        if name.startswith(CHANNELS) or name in ("distance", "mean_speed", "wheel_speed"):
            finite = finite & xp.isfinite(cols[name])
    cols["status_code"] = xp.where((c["bad"] > 0) | ~finite, 1, xp.where(flipped, 2, 0))
    if cfg.mission is not None:
        cols.update(mission_stats.finalize(c["mission"], cfg.mission, xp))
    if cfg.motors is not None:
        cols.update(motor_stats.finalize(c["motors"], c["n"], c["speed_err"], c["speed_ref"], xp))
    return cols
