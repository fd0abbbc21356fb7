"""The electrical and thermal statistics of dcmotors (vehicle.motors.model: dcmotor), in the carry.

Each motor's constants are the vehicle's (its catalogue motors; `MotorStatsConfig.for_vehicle`), so
they are static; the per-step samples come from MuJoCo's actuator state (`sample`). At the motor,
with the simulated motor's resistance R' = R / eta (batchveh/model/motors.py, the gearhead's
efficiency), per step:

- the simulated current i' = F / K from the actuator's force F (the torque the motor gives: with
  MuJoCo's current limit, the limited current), the real current i = i' / eta;
- the winding's temperature T and the terminal voltage v: the drive's (model/drive.py), the temperature
  this step ran with (its resistance R'(T) = R' (1 + alpha (T - T_ref)) is the one the motor saw), heated by
  the current the motor carried;
- the electrical power v i, drawn where positive, regenerated where negative;
- at the voltage line: |v| >= V (the controller's clamp, the bus voltage); at the current limit:
  |F| >= K eta i_max.

Columns, per motor (`drive_lf_current_rms`, ...): current RMS over the steady window and peak over
the run (A), winding temperature peak and at the end (deg C), energy drawn and regenerated over the
run (J), the share of the run's steps at the voltage line and at the current limit; for the
vehicle: the bus's peak power (W, the 8 motors' sum) and its net energy over the run (Wh), and
`motor_limited`, true where a drive motor spent more than LIMITED_SHARE of the run at a limit; per drive,
its speed shortfall against the imposed speed over the steady window; and `motor_status`: ok, limited, short
(could not keep up), stalled or unstable.

Physics checks, per variant and motor, on the torque each step applied (stats.sample's, with implicitfast's
end-of-step damping): its peak against N K i'_max (the most the current limit allows at the joint); the
share of steps whose torque changes sign with a jump of more than FLIP_JUMP of that bound (chatter); its
RMS against the RMS of N K i', the torque the carried current gives. A variant past TORQUE_TOL, FLIP_SHARE
or RMS_RATIO is `unstable`: its numbers are not the motor's, whatever its other flags (`motor_check`
names which check).
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
MOTOR_STATUS = ("ok", "limited", "short", "stalled", "unstable")  # motor_status_code -> motor_status
TORQUE_TOL = 0.01  # a motor's applied torque more than 1% above N K i_max: unstable
FLIP_JUMP = 0.5  # a step-to-step sign change counts as chatter when the torque jumps by half the bound or more
FLIP_SHARE = 0.02  # ... on more than 2% of the run's steps: unstable
RMS_RATIO = 1.2  # the applied torque's RMS more than 1.2x the RMS the carried current gives: unstable
RMS_FLOOR = 0.01  # of the bound: the current's RMS counts at least this much (a motor at rest)
AT_LIMIT_RTOL = 1e-6  # |v| >= V (1 - this), |F| >= F_max (1 - this)
_PER_MOTOR = {
    "current_rms": ("A", "RMS motor current over the steady window"),
    "current_peak": ("A", "peak |motor current| over the run after the settle"),
    "current_sq_time": (
        "A^2 s",
        "integral of the squared motor current over every step but the last, the settle too (the steps whose heat "
        "winding_temp_end holds): times R, the winding's copper loss at 25 deg C (the hot start's closed form)",
    ),
    "winding_temp_peak": ("deg C", "peak winding temperature over the run (one-node thermal model)"),
    "winding_temp_end": ("deg C", "winding temperature the run's last step ran with"),
    "energy_drawn": ("J", "electrical energy drawn from the bus over the run after the settle"),
    "energy_regen": ("J", "electrical energy returned to the bus over the run after the settle"),
    "at_voltage_share": ("1", "share of the run's steps at the voltage line (the bus voltage)"),
    "at_current_share": ("1", "share of the run's steps at the current limit"),
}
HOT_GRID = (5.0, 10.0, 20.0, 35.0, 55.0, 80.0, 110.0)  # K: the start rises each winding's peak is also kept at
# MotorStatsConfig.hot: how the run's columns move with its windings' start rise (sizing.thermal.hot_columns)
HOT_COLUMNS = {
    "temp_gain": (
        "1",
        "d winding_temp_end / d start rise: the product over the run of each step's 1 + dt (alpha R i^2 "
        "- 1 / R_T) / C (exact where the current does not depend on the temperature)",
    ),
    "voltage_margin": (
        "K",
        "the least start rise above this run's at which a step would reach the voltage line "
        "(0: a step did): below it the current, and so the run, does not depend on the start rise",
    ),
    "heat_gain_drawn": (
        "J/K",
        "d energy_drawn / d start rise over the steps that drew: the integral of alpha R i^2 "
        "times the step's temperature gain",
    ),
    "heat_gain_regen": ("J/K", "the same over the steps that regenerated (their regen falls by it)"),
    **{
        f"winding_temp_peak_{g:g}K": ("deg C", f"peak winding temperature over the run had it started {g:g} K hotter")
        for g in HOT_GRID
    },
}
_EACH = {**_PER_MOTOR, **HOT_COLUMNS}  # every per-motor column
_DRIVE = {
    "speed_shortfall": ("1", "steady mean wheel speed below the imposed speed, relative to it (negative: faster)"),
}
_VEHICLE = {
    "bus_power_peak": (
        "W",
        "peak electrical power of the motors together (drawn; a fixed hub has none), run after the settle",
    ),
    "bus_energy_wh": ("Wh", "net electrical energy of the motors over the run after the settle (a fixed hub has none)"),
    "motor_limited": ("", "a drive motor spent more than 1% of the run at its voltage line or current limit"),
    "motor_status": (
        "",
        "ok; limited (a drive at a limit for more than 1% of the run, speeds within 2%); short (a drive's steady "
        "speed more than 2% below the imposed); stalled (more than 90% below); unstable (a physics check failed: "
        "motor_check)",
    ),
    "motor_torque_ratio": ("1", "largest peak |applied torque| of the 8 motors over N K i_max (at most 1)"),
    "motor_flip_share": ("1", "largest share of steps whose torque flipped sign by half the bound or more"),
    "motor_rms_ratio": ("1", "largest RMS of the applied torque over the RMS the carried current gives"),
    "motor_check": ("", "the first physics check failed: '', 'torque above the current limit', 'chatter', 'rms'"),
    "bus_power_gain_drive": (
        "W/K",
        "the most the bus power of a step rises per K of the drives' start rise (MotorStatsConfig.hot)",
    ),
    "bus_power_gain_steer": ("W/K", "the same for the steering's start rise"),
}


@dataclass(frozen=True)
class MotorStatsConfig:
    """Each motor's constants, MOTORS order, as the simulated dcmotor has them."""

    K: tuple[float, ...]  # N m/A
    R: tuple[float, ...]  # Ohm, the simulated R' = R / eta at T_ref
    eta: tuple[float, ...]
    V: tuple[float, ...]  # V, the bus voltage
    force_max: tuple[float, ...]  # N m at the motor, 0: no current limit
    T_amb: tuple[float, ...]  # deg C
    R_T: tuple[float, ...] = (0.0,) * 8  # K/W, the winding's one-node thermal resistance (0: no thermal model)
    C: tuple[float, ...] = (0.0,) * 8  # J/K, its capacitance
    N: tuple[float, ...] = (1.0,) * 8  # the gear ratio
    # 1.0 where the slot is a motor on the bus, 0.0 for a fixed hub's HUB_LOCK (its power is no motor's): the bus
    # columns (bus_power_peak, bus_energy_wh) sum the motors only
    bus: tuple[float, ...] = (1.0,) * 8
    hot: bool = False  # also the start-rise gains (HOT_COLUMNS): a run's columns from any other start rise

    def constants(self) -> dict[str, np.ndarray]:
        """CONSTANTS, (8,) each."""
        return {k: np.asarray(getattr(self, k), float) for k in CONSTANTS}

    @staticmethod
    def for_vehicle(vehicle: Any) -> MotorStatsConfig | None:
        """The constants of the vehicle's dcmotors as `motors.dcmotor_xml` builds them (None for the
        servo): drives then steering."""
        if vehicle.motors.model != "dcmotor":
            return None
        each = [x.resolved() for x in vehicle.dc_motors()]  # a fixed hub's slot: vehicle.HUB_LOCK
        on_bus = (1.0,) * 4 + tuple(1.0 if s else 0.0 for s in vehicle.steering.steered)
        return MotorStatsConfig(
            K=tuple(c["K"] for c in each),
            R=tuple(c["R"] / c["eta"] for c in each),
            eta=tuple(c["eta"] for c in each),
            V=tuple(c["V"] for c in each),
            force_max=tuple(c["K"] * c["eta"] * c["i_max"] for c in each),
            T_amb=tuple(c["T_amb"] if c["R_T"] > 0 else REFERENCE_TEMP for c in each),
            R_T=tuple(c["R_T"] for c in each),
            C=tuple(c["C"] if c["R_T"] > 0 else 0.0 for c in each),
            N=tuple(c["N"] for c in each),
            bus=on_bus,
            hot=bool(vehicle.motors.hot_columns),
        )


# per motor, MotorStatsConfig's numbers
CONSTANTS = ("K", "R", "eta", "V", "force_max", "T_amb", "R_T", "C", "N", "bus")


def constants_of(cfg: MotorStatsConfig, params: Any = None, xp=np, dtype=None) -> dict[str, Any]:
    """The motors' numbers, (..., 8) each: each variant's from `params` (`_dc.<name>`, batch.motor_constants)
    where it has them, else the config's."""
    out = {}
    for k in CONSTANTS:
        value = params.get(f"_dc.{k}") if params is not None else None
        out[k] = xp.asarray(getattr(cfg, k) if value is None else value, dtype)
    return out


def sample(force, velocity, temp, volt, cfg: MotorStatsConfig, xp=np, consts=None) -> dict[str, Any]:
    """Per step (..., B, 8): the real current, the winding temperature, the power and the limit flags, from
    the motors' actuator force and velocity and the drive's record (its winding temperature and terminal
    voltage, model/drive.py), each (..., B, 8). consts: `constants_of`'s (each variant's numbers, (..., 8),
    broadcast over B); default the config's."""
    c = constants_of(cfg, xp=xp, dtype=force.dtype) if consts is None else consts
    c = {k: xp.asarray(v, force.dtype)[..., None, :] for k, v in c.items()}  # over the steps' axis
    K, eta, V, fmax = c["K"], c["eta"], c["V"], c["force_max"]
    current = force / K / eta
    out = {
        "current": current,
        "temp": temp,
        "power": volt * current,
        "on_bus": c["bus"],  # (..., 1, 8): 0 at a fixed hub's lock
        "at_v": xp.abs(volt) >= V * (1 - AT_LIMIT_RTOL),
        "at_i": (fmax > 0) & (xp.abs(force) >= fmax * (1 - AT_LIMIT_RTOL)),
        "joint": force * c["N"],  # the torque the current gives at the joint
        "bound": xp.where(fmax > 0, fmax * c["N"], xp.inf),  # the most the current limit allows there
    }
    if cfg.hot:  # the start-rise gains (update): per K of winding temperature, a step's heat and its voltage
        thermal = c["C"] > 0
        # d heat / dT = d power / dT: the real current i in the real R = R' eta (drive.step's heat)
        q = xp.where(thermal, COPPER_TEMPCOEF * c["R"] * eta * current * current, 0.0)
        cool = xp.where(thermal & (c["R_T"] > 0), 1.0 / xp.where(c["R_T"] > 0, c["R_T"], 1.0), 0.0)
        out["gain_rate"] = xp.where(thermal, (q - cool) / xp.where(thermal, c["C"], 1.0), 0.0)  # 1/s
        out["q"] = q
        # a step's voltage moves by alpha R' eta |i| per K, towards the line of its current's sign
        slope = COPPER_TEMPCOEF * c["R"] * eta * xp.abs(current)
        room = xp.where(current >= 0, V - volt, V + volt)
        safe = thermal & (slope > 0)
        out["margin"] = xp.where(out["at_v"] & thermal, 0.0, xp.where(safe, room / xp.where(safe, slope, 1.0), xp.inf))
    return out


def init(batch: tuple[int, ...], xp=np, dtype=None, hot: bool = False) -> dict[str, Any]:
    dtype = dtype or xp.float64

    def z(*shape, fill=0.0):
        return xp.full((*batch, *shape), fill, dtype=dtype)

    gains = {
        "gain": z(8, fill=1.0),  # d T / d start rise of the step to come
        "gain_end": z(8, fill=1.0),  # ... of the last step's temperature (t_end's)
        "peak_at": z(len(HOT_GRID), 8, fill=-np.inf),
        "margin": z(8, fill=np.inf),
        "h_drawn": z(8),
        "h_regen": z(8),
        "bus_gain": z(2),  # drives, steering
    }
    return {
        **(gains if hot else {}),
        "n_run": z(),
        "i_sumsq": z(8),
        "i_sq_dt": z(8),  # over every step, the settle too (the winding heats through it)
        "i_sq_last": z(8),  # the last step's share of it (winding_temp_end ran before that step's heat)
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
        "tau_peak": z(8),  # the physics checks: peak |applied torque| over the bound
        "tau_prev": z(8, fill=np.nan),  # the last step's applied torque (NaN: none yet)
        "n_flip": z(8),
        "tau_sumsq": z(8),
        "joint_sumsq": z(8),
        "bound_sumsq": z(8),
    }


def update(c: dict[str, Any], e: dict[str, Any], tau, w, wr, dt: float, xp=np) -> dict[str, Any]:
    """Fold a block's samples `e` (..., B, 8) and the torques the steps applied `tau` (..., B, 8); w, wr (B,):
    1.0 at steps inside the steady window, past the settle."""
    wk, wrk = w[:, None], wr[:, None]
    cur, power, temps = e["current"], e["power"], e["temp"]
    run = wr > 0
    bus = (power * e["on_bus"]).sum(-1)  # the motors' own, never a fixed hub's lock
    out = dict(c)
    out["n_run"] = c["n_run"] + wr.sum()
    out["i_sumsq"] = c["i_sumsq"] + (wk * cur * cur).sum(-2)
    out["i_sq_dt"] = c["i_sq_dt"] + (cur * cur).sum(-2) * dt
    out["i_sq_last"] = cur[..., -1, :] * cur[..., -1, :] * dt
    out["i_peak"] = xp.maximum(c["i_peak"], xp.where(run[:, None], xp.abs(cur), 0.0).max(-2))
    out["T"] = temps[..., -1, :]
    out["t_peak"] = xp.maximum(c["t_peak"], xp.where(run[:, None], temps, -np.inf).max(-2))
    out["t_end"] = out["T"]
    out["drawn"] = c["drawn"] + (wrk * xp.maximum(power, 0.0)).sum(-2) * dt
    out["regen"] = c["regen"] + (wrk * xp.maximum(-power, 0.0)).sum(-2) * dt
    out["n_v"] = c["n_v"] + (wrk * e["at_v"]).sum(-2)
    out["n_i"] = c["n_i"] + (wrk * e["at_i"]).sum(-2)
    out["bus_peak"] = xp.maximum(c["bus_peak"], xp.where(run, bus, 0.0).max(-1))
    out["bus_energy"] = c["bus_energy"] + (wr * bus).sum(-1) * dt
    # the physics checks, over the run after the settle
    bound = e["bound"][..., 0, :]
    finite = xp.isfinite(bound)
    scale = xp.where(finite, bound, 1.0)
    ratio = xp.where(finite[..., None, :], xp.abs(tau) / scale[..., None, :], 0.0)
    out["tau_peak"] = xp.maximum(c["tau_peak"], xp.where(run[:, None], ratio, 0.0).max(-2))
    prev = xp.concatenate([c["tau_prev"][..., None, :], tau[..., :-1, :]], axis=-2)
    jump = xp.abs(tau - prev)
    flip = (tau * prev < 0) & finite[..., None, :] & (jump >= FLIP_JUMP * scale[..., None, :])
    out["n_flip"] = c["n_flip"] + (wrk * flip).sum(-2)
    out["tau_prev"] = tau[..., -1, :]
    out["tau_sumsq"] = c["tau_sumsq"] + (wrk * tau * tau).sum(-2)
    out["joint_sumsq"] = c["joint_sumsq"] + (wrk * e["joint"] * e["joint"]).sum(-2)
    out["bound_sumsq"] = c["bound_sumsq"] + wr.sum() * xp.where(finite, scale * scale, 0.0)
    if "gain" in c:
        out.update(_gains(c, e, run, wrk, dt, xp))
    return out


def _gains(c: dict[str, Any], e: dict[str, Any], run, wrk, dt: float, xp=np) -> dict[str, Any]:
    """The start-rise gains over a block (MotorStatsConfig.hot). The drive's winding step, T' = T + dt (i^2 R (1 +
    alpha (T - 25)) - (T - T_a) / R_T) / C, is linear in T for a given current, so a run started s hotter runs
    at T + s g with g the product of the steps' 1 + dt (alpha R i^2 - 1 / R_T) / C so far, wherever its current is
    the same: off the voltage line, where the drive asks the current it carries whatever the winding's
    resistance. The steps' voltages move by alpha R' eta |i| s g (`margin`: the s at which one would reach the
    line); their power by q s g, q = alpha R i^2."""
    step = 1.0 + dt * e["gain_rate"]
    cum = xp.cumprod(step, axis=-2)
    before = xp.concatenate([xp.ones_like(cum[..., :1, :]), cum[..., :-1, :]], axis=-2)
    g = c["gain"][..., None, :] * before  # each step's temperature gain (its T's)
    grid = xp.asarray(HOT_GRID, g.dtype)[:, None, None]
    shifted = e["temp"][..., None, :, :] + grid * g[..., None, :, :]  # (..., G, B, 8)
    peak = xp.where(run[:, None], shifted, -np.inf).max(-2)
    qg = e["q"] * g
    drew = e["power"] > 0
    bus = xp.stack([qg[..., :4].sum(-1), qg[..., 4:].sum(-1)], axis=-1)  # (..., B, 2)
    margin = xp.where(g > 0, e["margin"] / xp.where(g > 0, g, 1.0), xp.inf)
    return {
        "gain": c["gain"] * cum[..., -1, :],
        "gain_end": g[..., -1, :],
        "peak_at": xp.maximum(c["peak_at"], peak),
        "margin": xp.minimum(c["margin"], margin.min(-2)),
        "h_drawn": c["h_drawn"] + (wrk * xp.where(drew, qg, 0.0)).sum(-2) * dt,
        "h_regen": c["h_regen"] + (wrk * xp.where(drew, 0.0, qg)).sum(-2) * dt,
        "bus_gain": xp.maximum(c["bus_gain"], xp.where(run[:, None], bus, 0.0).max(-2)),
    }


def finalize(c: dict[str, Any], n_window, speed_err, speed_ref, xp=np) -> dict[str, Any]:
    """The columns: per motor and for the vehicle (the module's docstring). speed_err, speed_ref (..., 4):
    the drives' wheel speed less the imposed, and the imposed, summed over the steady window (stats' carry).
    `motor_status_code` indexes MOTOR_STATUS: 3 stalled if a drive's shortfall exceeds STALL_SHARE, else 2
    short past SHORT_SHARE, else 1 limited where motor_limited, else 0."""
    n_run = xp.maximum(c["n_run"], 1.0)[..., None]
    per = {
        "current_rms": xp.sqrt(c["i_sumsq"] / xp.maximum(n_window, 1.0)[..., None]),
        "current_peak": c["i_peak"],
        "current_sq_time": c["i_sq_dt"] - c["i_sq_last"],
        "winding_temp_peak": c["t_peak"],
        "winding_temp_end": c["t_end"],
        "energy_drawn": c["drawn"],
        "energy_regen": c["regen"],
        "at_voltage_share": c["n_v"] / n_run,
        "at_current_share": c["n_i"] / n_run,
    }
    if "gain" in c:
        per["temp_gain"] = c["gain_end"]
        per["voltage_margin"] = c["margin"]
        per["heat_gain_drawn"] = c["h_drawn"]
        per["heat_gain_regen"] = c["h_regen"]
        per.update({f"winding_temp_peak_{g:g}K": c["peak_at"][..., k, :] for k, g in enumerate(HOT_GRID)})
    cols = {f"{m}_{k}": v[..., j] for k, v in per.items() for j, m in enumerate(MOTORS)}
    if "gain" in c:
        cols["bus_power_gain_drive"], cols["bus_power_gain_steer"] = c["bus_gain"][..., 0], c["bus_gain"][..., 1]
    cols["bus_power_peak"] = c["bus_peak"]
    cols["bus_energy_wh"] = c["bus_energy"] / 3600.0
    limited = xp.maximum(per["at_voltage_share"], per["at_current_share"])[..., :4]
    cols["motor_limited"] = xp.max(limited, axis=-1) > LIMITED_SHARE
    moving = xp.abs(speed_ref) > 1e-9
    shortfall = xp.where(moving, -speed_err / xp.where(moving, xp.abs(speed_ref), 1.0), 0.0)
    for j, m in enumerate(MOTORS[:4]):
        cols[f"{m}_speed_shortfall"] = shortfall[..., j]
    worst = xp.max(shortfall, axis=-1)
    status = xp.where(worst > STALL_SHARE, 3, xp.where(worst > SHORT_SHARE, 2, xp.where(cols["motor_limited"], 1, 0)))
    floor = RMS_FLOOR * RMS_FLOOR * c["bound_sumsq"]
    rms_ratio = xp.sqrt(c["tau_sumsq"] / xp.maximum(xp.maximum(c["joint_sumsq"], floor), 1e-30))
    cols["motor_torque_ratio"] = xp.max(c["tau_peak"], axis=-1)
    cols["motor_flip_share"] = xp.max(c["n_flip"] / n_run, axis=-1)
    cols["motor_rms_ratio"] = xp.max(xp.where(c["bound_sumsq"] > 0, rms_ratio, 0.0), axis=-1)
    cols["motor_check_code"] = xp.where(
        cols["motor_torque_ratio"] > 1 + TORQUE_TOL,
        1,
        xp.where(cols["motor_flip_share"] > FLIP_SHARE, 2, xp.where(cols["motor_rms_ratio"] > RMS_RATIO, 3, 0)),
    )
    cols["motor_status_code"] = xp.where(cols["motor_check_code"] > 0, 4, status)
    return cols


MOTOR_CHECK = ("", "torque above the current limit", "chatter", "rms")  # motor_check_code -> motor_check
CODES = {"motor_status_code": ("motor_status", MOTOR_STATUS), "motor_check_code": ("motor_check", MOTOR_CHECK)}


def named(cols: dict[str, Any]) -> dict[str, Any]:
    """The columns with each code (`motor_status_code`, `motor_check_code`) turned into its names."""
    out = {k: v for k, v in cols.items() if k not in CODES}
    for code, (name, names) in CODES.items():
        if code in cols:
            out[name] = np.asarray(names, dtype=object)[np.asarray(cols[code], int)]
    return out


def column_doc(name: str) -> tuple[str, str] | None:
    """(unit, description) of a motor column, or None."""
    if name in _VEHICLE:
        return _VEHICLE[name]
    for m in MOTORS[:4]:
        if name.startswith(m + "_") and name[len(m) + 1 :] in _DRIVE:
            unit, doc = _DRIVE[name[len(m) + 1 :]]
            return unit, f"{m}: {doc}"
    for m in MOTORS:
        if name.startswith(m + "_") and name[len(m) + 1 :] in _EACH:
            unit, doc = _EACH[name[len(m) + 1 :]]
            return unit, f"{m}: {doc}"
    return None
