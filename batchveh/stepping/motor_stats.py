"""The electrical and thermal statistics of dcmotors (vehicle.motors.model: dcmotor), in the carry.

Each motor's constants are the vehicle's (its catalogue motors; `MotorStatsConfig.for_vehicle`), so
they are static; the per-step samples come from MuJoCo's actuator state (`sample`). At the motor,
with the simulated motor's resistance R' = R / eta (batchveh/model/motors.py, the gearhead's
efficiency), per step:

- the simulated current i' = F / K from the actuator's force F (the torque the motor gives: with
  MuJoCo's current limit, the limited current), the real current i = i' / eta;
- the winding's temperature T = T_amb + the thermal state (MuJoCo's act), R'(T) = R' (1 + alpha
  (T - T_ref)): the resistance the simulated motor sees. The temperature columns come from batchveh's
  own integration of the same one-node model with the current the motor delivered (`windings`): MuJoCo
  3.17's state heats with the current before its current limit clips it;
- the terminal voltage v = i' R'(T) + K w (w: the motor's speed), and the electrical power v i,
  drawn where positive, regenerated where negative;
- at the voltage line: |v| >= V (the controller's clamp, the bus voltage); at the current limit:
  |F| >= K eta i_max.

Columns, per motor (`drive_lf_current_rms`, ...): current RMS over the steady window and peak over
the run (A), winding temperature peak and at the end (deg C), energy drawn and regenerated over the
run (J), the share of the run's steps at the voltage line and at the current limit; for the
vehicle: the bus's peak power (W, the 8 motors' sum) and its net energy over the run (Wh), and
`motor_limited`, true where a drive motor spent more than LIMITED_SHARE of the run at a limit; per drive,
its speed shortfall against the imposed speed over the steady window; and `motor_status`: ok, limited, short
(could not keep up) or stalled.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from batchveh.model.motors import COPPER_TEMPCOEF, REFERENCE_TEMP
from batchveh.model.vehicle import MOTORS

LIMITED_SHARE = 0.01  # a drive motor at its voltage line or current limit for more than 1% of the run
SHORT_SHARE = 0.02  # a drive's steady mean speed more than 2% below the imposed speed: the vehicle could not keep up
STALL_SHARE = 0.9  # ... more than 90% below it: stalled
MOTOR_STATUS = ("ok", "limited", "short", "stalled")  # motor_status_code -> motor_status (finalize's docstring)
AT_LIMIT_RTOL = 1e-6  # |v| >= V (1 - this), |F| >= F_max (1 - this)
_PER_MOTOR = {
    "current_rms": ("A", "RMS motor current over the steady window"),
    "current_peak": ("A", "peak |motor current| over the run after the settle"),
    "winding_temp_peak": ("deg C", "peak winding temperature over the run (one-node thermal model)"),
    "winding_temp_end": ("deg C", "winding temperature at the end of the run"),
    "energy_drawn": ("J", "electrical energy drawn from the bus over the run after the settle"),
    "energy_regen": ("J", "electrical energy returned to the bus over the run after the settle"),
    "at_voltage_share": ("1", "share of the run's steps at the voltage line (the bus voltage)"),
    "at_current_share": ("1", "share of the run's steps at the current limit"),
}
_DRIVE = {
    "speed_shortfall": ("1", "steady mean wheel speed below the imposed speed, relative to it (negative: faster)"),
}
_VEHICLE = {
    "bus_power_peak": ("W", "peak electrical power of the 8 motors together (drawn), run after the settle"),
    "bus_energy_wh": ("Wh", "net electrical energy of the 8 motors over the run after the settle"),
    "motor_limited": ("", "a drive motor spent more than 1% of the run at its voltage line or current limit"),
    "motor_status": (
        "",
        "ok; limited (a drive at a limit for more than 1% of the run, speeds within 2%); short (a drive's steady "
        "speed more than 2% below the imposed); stalled (more than 90% below)",
    ),
}


@dataclass(frozen=True)
class MotorStatsConfig:
    """Each motor's constants, MOTORS order, as the simulated dcmotor has them."""

    K: tuple[float, ...]  # N m/A
    R: tuple[float, ...]  # Ohm, the simulated R' = R / eta at T_ref
    eta: tuple[float, ...]
    V: tuple[float, ...]  # V, the controller's clamp
    force_max: tuple[float, ...]  # N m at the motor, 0: no current limit
    T_amb: tuple[float, ...]  # deg C
    thermal: tuple[bool, ...]
    act: tuple[int, ...]
    R_T: tuple[float, ...] = (0.0,) * 8  # K/W, the winding's one-node thermal resistance (0: no thermal model)
    C: tuple[float, ...] = (0.0,) * 8  # J/K, its capacitance  # each motor's thermal state in MjData.act (-1: none)

    def constants(self) -> dict[str, np.ndarray]:
        """CONSTANTS, (8,) each."""
        return {k: np.asarray(getattr(self, k), float) for k in CONSTANTS}

    @staticmethod
    def for_vehicle(vehicle: Any) -> MotorStatsConfig | None:
        """The constants of the vehicle's dcmotors as `motors.dcmotor_xml` builds them (None for the
        servo): drives then steering, each motor's thermal state next in MjData.act where it has one."""
        if vehicle.motors.model != "dcmotor":
            return None
        drive, steer = (x.resolved() for x in vehicle.motors.dcmotors())
        each = [drive] * 4 + [steer] * 4
        thermal = tuple(c["R_T"] > 0 for c in each)
        act = tuple(int(np.cumsum(thermal)[j]) - 1 if t else -1 for j, t in enumerate(thermal))
        return MotorStatsConfig(
            K=tuple(c["K"] for c in each),
            R=tuple(c["R"] / c["eta"] for c in each),
            eta=tuple(c["eta"] for c in each),
            V=tuple(c["V"] for c in each),
            force_max=tuple(c["K"] * c["eta"] * c["i_max"] for c in each),
            T_amb=tuple(c["T_amb"] if c["R_T"] > 0 else REFERENCE_TEMP for c in each),
            thermal=thermal,
            act=act,
            R_T=tuple(c["R_T"] for c in each),
            C=tuple(c["C"] for c in each),
        )


CONSTANTS = ("K", "R", "eta", "V", "force_max", "T_amb", "R_T", "C")  # per motor, MotorStatsConfig's numbers


def constants_of(cfg: MotorStatsConfig, params: Any = None, xp=np, dtype=None) -> dict[str, Any]:
    """The motors' numbers, (..., 8) each: each variant's from `params` (`_dc.<name>`, batch.motor_constants)
    where it has them, else the config's."""
    out = {}
    for k in CONSTANTS:
        value = params.get(f"_dc.{k}") if params is not None else None
        out[k] = xp.asarray(getattr(cfg, k) if value is None else value, dtype)
    return out


def start_act(params: Any, index: np.ndarray, na: int, xp=np, dtype=None) -> Any:
    """MjData.act at t = 0 (..., na): each thermal state at its motor's start rise (params
    `motors.drive_start_rise`, `motors.steer_start_rise`, per variant), the rest 0."""
    drive = xp.asarray(params["motors.drive_start_rise"], dtype)
    steer = xp.asarray(params["motors.steer_start_rise"], dtype)
    act = xp.zeros((*xp.shape(drive), na), dtype=dtype or drive.dtype)
    for j, k in enumerate(index):
        if k >= 0:
            value = drive if j < 4 else steer
            act = act.at[..., int(k)].set(value) if xp is not np else _set(act, int(k), value)
    return act


def _set(act: np.ndarray, k: int, value: Any) -> np.ndarray:
    act[..., k] = value
    return act


def sample(force, velocity, act, cfg: MotorStatsConfig, xp=np, consts=None) -> dict[str, Any]:
    """Per step (..., B, 8): the real current, the winding temperature, the voltage, the power and the
    limit flags, from the motors' actuator force and velocity (..., B, 8) and MjData.act (..., B, na;
    None where no motor has a thermal state). consts: `constants_of`'s (each variant's numbers, (..., 8),
    broadcast over B); default the config's."""
    c = constants_of(cfg, xp=xp, dtype=force.dtype) if consts is None else consts
    c = {k: xp.asarray(v, force.dtype)[..., None, :] for k, v in c.items()}  # over the steps' axis
    K, R, eta, V = (c[k] for k in ("K", "R", "eta", "V"))
    fmax, t_amb = c["force_max"], c["T_amb"]
    if any(cfg.thermal) and act is not None:
        idx = np.maximum(np.asarray(cfg.act), 0)
        rise = xp.where(xp.asarray(cfg.thermal), act[..., idx], 0.0)
    else:
        rise = xp.zeros_like(force)
    temp = t_amb + rise
    i_sim = force / K
    r_t = R * (1 + COPPER_TEMPCOEF * (temp - REFERENCE_TEMP))
    volt = i_sim * r_t + K * velocity
    current = i_sim / eta
    return {
        "current": current,
        "temp": temp,
        "power": volt * current,
        "at_v": xp.abs(volt) >= V * (1 - AT_LIMIT_RTOL),
        "at_i": (fmax > 0) & (xp.abs(force) >= fmax * (1 - AT_LIMIT_RTOL)),
        "consts": c,  # the motors' numbers, (..., 1, 8): update integrates the windings with them
    }


def init(batch: tuple[int, ...], xp=np, dtype=None) -> dict[str, Any]:
    dtype = dtype or xp.float64

    def z(*shape, fill=0.0):
        return xp.full((*batch, *shape), fill, dtype=dtype)

    return {
        "n_run": z(),
        "i_sumsq": z(8),
        "i_peak": z(8),
        "t_peak": z(8, fill=-np.inf),
        "t_end": z(8),
        "T": z(8, fill=np.nan),  # the winding's temperature, batchveh's integration (update); NaN: not started
        "drawn": z(8),
        "regen": z(8),
        "n_v": z(8),
        "n_i": z(8),
        "bus_peak": z(),
        "bus_energy": z(),
    }


def windings(temp, current, cfg: MotorStatsConfig, dt: float, xp=np, consts=None):
    """The windings' temperatures (..., B, 8) after each step of `dt` of a block, from `temp` (..., 8) with
    the motors' real currents (..., B, 8): C dT/dt = i^2 R (1 + alpha (T - 25)) - (T - T_amb) / R_T, explicit
    Euler (dt / tau < 3e-4 for the catalogue's windings at 5 ms). MuJoCo 3.17's own thermal state heats with
    the current before the current limit clips it (model/motors.py); this one heats with the current the
    motor delivered. Each step is linear in T, T' = a T + b, so T after step k is A_k (T_0 + sum_{j<=k}
    b_j / A_j) with A_k = a_0 ... a_k (a close to 1 - dt / tau: the products stay near 1 over a block)."""
    c = constants_of(cfg, xp=xp, dtype=current.dtype) if consts is None else consts
    thermal = xp.asarray(cfg.thermal)
    r_t = xp.where(thermal, xp.asarray(c["R_T"], current.dtype), 1.0)[..., None, :]
    cap = xp.where(thermal, xp.asarray(c["C"], current.dtype), 1.0)[..., None, :]
    r0 = (xp.asarray(c["R"], current.dtype) * xp.asarray(c["eta"], current.dtype))[..., None, :]
    t_amb = xp.asarray(c["T_amb"], current.dtype)
    heat = current * current * r0  # W at 25 deg C
    a = 1 + dt * (heat * COPPER_TEMPCOEF - 1 / r_t) / cap
    b = dt * (heat * (1 - COPPER_TEMPCOEF * REFERENCE_TEMP) + t_amb[..., None, :] / r_t) / cap
    prod = xp.cumprod(a, axis=-2)
    temps = prod * (temp[..., None, :] + xp.cumsum(b / prod, axis=-2))
    return xp.where(thermal[..., None, :], temps, t_amb[..., None, :])


def block_windings(c: dict[str, Any], e: dict[str, Any], cfg: MotorStatsConfig, dt: float, xp=np):
    """The windings' temperatures after each step of a block (..., B, 8) (`windings`), from the carry's, or at
    the first block from MuJoCo's thermal state after the first step (its start rise, `start_act`)."""
    consts = {k: v[..., 0, :] for k, v in e["consts"].items()}
    start = xp.where(xp.isnan(c["T"]), e["temp"][..., 0, :], c["T"])
    return windings(start, e["current"], cfg, dt, xp, consts)


def update(
    c: dict[str, Any], e: dict[str, Any], w, wr, dt: float, cfg: MotorStatsConfig, xp=np, temps=None
) -> dict[str, Any]:
    """Fold a block's samples `e` (..., B, 8); w, wr (B,): 1.0 at steps inside the steady window, past
    the settle. temps: `block_windings` (computed here when not given)."""
    wk, wrk = w[:, None], wr[:, None]
    cur, power = e["current"], e["power"]
    run = wr > 0
    bus = power.sum(-1)
    out = dict(c)
    out["n_run"] = c["n_run"] + wr.sum()
    out["i_sumsq"] = c["i_sumsq"] + (wk * cur * cur).sum(-2)
    out["i_peak"] = xp.maximum(c["i_peak"], xp.where(run[:, None], xp.abs(cur), 0.0).max(-2))
    temps = block_windings(c, e, cfg, dt, xp) if temps is None else temps
    out["T"] = temps[..., -1, :]
    out["t_peak"] = xp.maximum(c["t_peak"], xp.where(run[:, None], temps, -np.inf).max(-2))
    out["t_end"] = out["T"]
    out["drawn"] = c["drawn"] + (wrk * xp.maximum(power, 0.0)).sum(-2) * dt
    out["regen"] = c["regen"] + (wrk * xp.maximum(-power, 0.0)).sum(-2) * dt
    out["n_v"] = c["n_v"] + (wrk * e["at_v"]).sum(-2)
    out["n_i"] = c["n_i"] + (wrk * e["at_i"]).sum(-2)
    out["bus_peak"] = xp.maximum(c["bus_peak"], xp.where(run, bus, 0.0).max(-1))
    out["bus_energy"] = c["bus_energy"] + (wr * bus).sum(-1) * dt
    return out


def finalize(c: dict[str, Any], n_window, speed_err, speed_ref, xp=np) -> dict[str, Any]:
    """The columns: per motor and for the vehicle (the module's docstring). speed_err, speed_ref (..., 4):
    the drives' wheel speed less the imposed, and the imposed, summed over the steady window (stats' carry).
    `motor_status_code` indexes MOTOR_STATUS: 3 stalled if a drive's shortfall exceeds STALL_SHARE, else 2
    short past SHORT_SHARE, else 1 limited where motor_limited, else 0."""
    n_run = xp.maximum(c["n_run"], 1.0)[..., None]
    per = {
        "current_rms": xp.sqrt(c["i_sumsq"] / xp.maximum(n_window, 1.0)[..., None]),
        "current_peak": c["i_peak"],
        "winding_temp_peak": c["t_peak"],
        "winding_temp_end": c["t_end"],
        "energy_drawn": c["drawn"],
        "energy_regen": c["regen"],
        "at_voltage_share": c["n_v"] / n_run,
        "at_current_share": c["n_i"] / n_run,
    }
    cols = {f"{m}_{k}": v[..., j] for k, v in per.items() for j, m in enumerate(MOTORS)}
    cols["bus_power_peak"] = c["bus_peak"]
    cols["bus_energy_wh"] = c["bus_energy"] / 3600.0
    limited = xp.maximum(per["at_voltage_share"], per["at_current_share"])[..., :4]
    cols["motor_limited"] = xp.max(limited, axis=-1) > LIMITED_SHARE
    moving = xp.abs(speed_ref) > 1e-9
    shortfall = xp.where(moving, -speed_err / xp.where(moving, xp.abs(speed_ref), 1.0), 0.0)
    for j, m in enumerate(MOTORS[:4]):
        cols[f"{m}_speed_shortfall"] = shortfall[..., j]
    worst = xp.max(shortfall, axis=-1)
    cols["motor_status_code"] = xp.where(
        worst > STALL_SHARE, 3, xp.where(worst > SHORT_SHARE, 2, xp.where(cols["motor_limited"], 1, 0))
    )
    return cols


def column_doc(name: str) -> tuple[str, str] | None:
    """(unit, description) of a motor column, or None."""
    if name in _VEHICLE:
        return _VEHICLE[name]
    for m in MOTORS[:4]:
        if name.startswith(m + "_") and name[len(m) + 1 :] in _DRIVE:
            unit, doc = _DRIVE[name[len(m) + 1 :]]
            return unit, f"{m}: {doc}"
    for m in MOTORS:
        if name.startswith(m + "_") and name[len(m) + 1 :] in _PER_MOTOR:
            unit, doc = _PER_MOTOR[name[len(m) + 1 :]]
            return unit, f"{m}: {doc}"
    return None
