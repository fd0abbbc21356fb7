"""Motor sizing from a servo sweep, against a datasheet catalogue of DC motors with their gearheads.

One catalogue format, `notebooks/motors.yaml`'s, serves every pass: a `motors:` list, each entry a motor
as its datasheet gives it at the motor shaft with its gearhead nested under `gearhead:`, and an optional
`battery:` section:

```yaml
motors:
  - name: maxon-EC45flat-70W-48V_NPT015-i40   # unique: the name that screen, in_loop and a sweep use
    nominal_voltage: 48.0               # V: the bus, unless bus_voltage is given
    terminal_resistance: 6.89           # Ohm; or the triple nominal_voltage, stall_torque, no_load_speed
    torque_constant: 0.131              # N m/A
    max_continuous_current: 0.936       # A
    rotor_inertia: 1.81e-5              # kg m^2
    thermal_resistance_winding_housing: 4.1    # K/W
    thermal_resistance_housing_ambient: 3.56   # K/W
    thermal_time_constant_winding: 29.6        # s
    max_winding_temperature: 125.0             # deg C
    gearhead: {ratio: 40.0, efficiency: 0.95, max_continuous_torque: 22.0, max_intermittent_torque: 42.0,
               max_input_speed: 1047.2}  # N m at its output; rad/s at its input
battery: {nominal_voltage: 48.0, capacity: 20.0, internal_resistance: 0.3, max_continuous_discharge_current: 20.0}
```

The loaders, also public as `batchveh.load_catalogue` and `batchveh.load_battery`:
- `batchveh.model.motors.load_catalogue(path)` -> {name: DCMotor}, the `motors:` list by name;
- `load_battery(path)` (here) -> Battery, the `battery:` section.

Two passes over the rows of a servo sweep (`batchveh.load(folder)`), the drive's demand taken on the
worst of the four drive motors:
1. `screen(df, catalogue, share=...)`: the fast screen, closed forms per variant (RMS current, steady
   winding temperature, the voltage at the peak, the no-load speed, the gearhead's ratings; `REASONS`).
   `share=1.0` gives the smallest motor that covers every variant; `span="mission"` (or a segment's
   prefix, `seg2_climb`) reads a mission's columns over that span instead of the steady window's RMS,
   the whole run's low-pass peak and the mean wheel speed.
2. `in_loop(spec, df, path, candidates, steer=...)`: the screen's survivors run as MuJoCo dcmotors on
   the same variants, from the hot steady state of back-to-back runs (`IN_LOOP_REASONS`).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from batchveh.config import ConfigError, did_you_mean, field, from_mapping, load_yaml
from batchveh.stepping.motor_stats import SHORT_SHARE  # a window's mean speed this far below the imposed: short

WHEELS = ("drive_lf", "drive_rf", "drive_lr", "drive_rr")
GROUPS = {"drive": WHEELS, "steer": ("steer_lf", "steer_rf", "steer_lr", "steer_rr")}
GROUP_RISES = {"motors.drive_start_rise": WHEELS, "motors.steer_start_rise": GROUPS["steer"]}  # each group's start


# --- DC motors from datasheets (batchveh.model.motors): the fast screen, with the reason of each failure ---

# One list of criteria for both passes (the screen on the servo's demand, the loop on the motor's own run), so
# that each reason is counted the same way in both; `DIFFER` says where the two passes read a reason differently.
REASONS = ("rms", "thermal", "voltage", "peak", "speed", "gear_torque", "gear_speed", "energy", "tracking")
REASON_TEXT = {
    "rms": "RMS current, at the spec's duty, above the continuous current",
    "thermal": "steady winding temperature, at the spec's duty, above its maximum (one-node model with R(T))",
    "voltage": "the steady window's peak torque (at most the current's bound) at speed needs more than the bus "
    "voltage (the voltage line); a duty cycle's: each wheel's driving peak at 98% of its peak speed, segment by "
    "segment",
    "peak": "the low-pass peak torque needs more than the current limit allows (eta N K i_max): a drive's over the "
    "steady window, a steering motor's over the whole run",
    "speed": "the wheel speed needs more than the no-load speed at the bus voltage",
    "gear_torque": "wheel torque above the gearhead's continuous or intermittent rating",
    "gear_speed": "motor speed above the gearhead's input speed",
    "energy": "the battery's energy or power (the loop only: the servo's run has no electrical power)",
    "tracking": "short of the imposed speed with no limit held (the loop only: the drive's own loop)",
}


def bound_at_wheel(c: dict[str, float], none: float = np.inf) -> float:
    """The most the drive gives at the wheel, eta N K i_max (N m), from a motor's `resolved()` constants; `none`
    where it has no current limit."""
    return c["eta"] * c["N"] * c["K"] * c["i_max"] if c["i_max"] > 0 else none


def terminal_voltage(torque: Any, speed: Any, c: dict[str, float]) -> Any:
    """The voltage a motor needs (V) to give `torque` (N m at the wheel) at `speed` (rad/s at the wheel), from its
    `resolved()` constants: i R + K N w, with i = torque / (eta N K)."""
    return torque / (c["eta"] * c["N"] * c["K"]) * c["R"] + c["K"] * c["N"] * speed


def best_in_loop(table: pd.DataFrame) -> str | None:
    """The motor of an `in_loop` table with the highest coverage (the last run of equals); None for no rows."""
    return str(table.sort_values("coverage", kind="stable")["motor"].iloc[-1]) if len(table) else None


def demand(df: pd.DataFrame, group: str = "drive", span: str | None = None) -> pd.DataFrame:
    """Each variant's demand on the worst of the group's four motors, at the wheel: RMS and peak torque
    (N m), and speed (rad/s): the steady window's RMS, the whole run's low-pass peak and the mean
    wheel speed; or a mission span's RMS, peak and peak speed. A group or span with no such columns is one
    ConfigError line."""
    if group not in GROUPS:
        raise ConfigError(f"group: {group!r} is not allowed; allowed: {', '.join(GROUPS)}")
    names = GROUPS[group]
    need = [f"{m}_rms" for m in names] if span is None else [f"{span}_{m}_rms" for m in names]
    if need[0] not in df:
        spans = sorted({c.removesuffix("_drive_lf_rms") for c in df.columns if c.endswith("_drive_lf_rms")})
        allowed = ", ".join(x for x in spans if x.startswith(("mission", "seg"))) or "none (not a mission result)"
        raise ConfigError(f"span: {span!r} has no column {need[0]}; allowed: None or a mission span: {allowed}")
    out = pd.DataFrame(index=df.index)
    if span is None:
        out["rms"] = df[[f"{m}_rms" for m in names]].abs().max(axis=1)
        out["peak"] = df[[f"{m}_peak_lp_all" for m in names]].abs().max(axis=1)
        # the current's bound against a drive's steady-window peak (a ramp's peak it rides through, falling behind
        # for a moment), but against the steering's whole-run peak: a steering motor at its bound loses its angle
        # (the 250 kg AGV's 4.24 N m steering against the drive's force at the scrub radius, 8.6 N m on its ramp,
        # turned its wheels 80-315 deg). A frame without the window's columns (made by hand): the whole run's.
        window = [f"{m}_peak_lp" for m in names]
        steady = group == "drive" and window[0] in df
        out["peak_window"] = df[window].abs().max(axis=1) if steady else out["peak"]
        if steady:  # what the four drives can share (screen_one)
            out["rms_mean"] = df[[f"{m}_rms" for m in names]].abs().mean(axis=1)
            out["peak_window_mean"] = df[window].abs().mean(axis=1)
            for j, m in enumerate(names):  # each wheel's own, for the share the others can take (screen_one)
                out[f"rms_{j}"], out[f"peak_window_{j}"] = df[f"{m}_rms"].abs(), df[f"{m}_peak_lp"].abs()
        out["speed"] = df["wheel_speed"].abs() if group == "drive" else 0.0
    else:
        out["rms"] = df[[f"{span}_{m}_rms" for m in names]].abs().max(axis=1)
        out["peak"] = df[[f"{span}_{m}_peak_lp" for m in names]].abs().max(axis=1)
        out["peak_window"] = out["peak"]
        out["speed"] = df[[f"{span}_{m}_speed_peak" for m in names]].abs().max(axis=1)
    return out


RAMP_STEPS = 400  # the ramp model's time grid over [0, the window's end]


def ramp_shortfall(speed: Any, ramp_time: Any, window: tuple[float, float], a_max: Any, law: str = "smooth_step"):
    """Per variant, how far below the imposed speed a vehicle that can accelerate its wheels at most at `a_max`
    (rad/s^2) runs over the steady window, relative to the imposed speed (0: on speed; SHORT_SHARE: short).

    The imposed wheel speed rises from 0 to `speed` (rad/s) over `ramp_time` (s) along `law` ('smooth_step':
    6 x^5 - 15 x^4 + 10 x^3, its peak acceleration 15/8 of the mean; 'ramp' or 'unbounded_ramp': linear, the
    latter still rising past the ramp). The wheel follows it while its acceleration is within a_max, else it
    accelerates at a_max until it meets the imposed speed again: w(t + dt) = min(w_ref(t + dt), w(t) + a_max dt),
    the drive at its current's bound for as long as it is behind. The mean over the window [start, end] (s of law
    time) against the imposed speed's mean there. Arrays of one shape (or scalars); RAMP_STEPS time steps."""
    speed, ramp_time, a_max = np.broadcast_arrays(*(np.asarray(x, float) for x in (speed, ramp_time, a_max)))
    # a wheel whose bound passes the law's peak acceleration never falls behind (0): only the others are stepped
    peak = np.abs(speed) / np.maximum(ramp_time, 1e-12) * (15 / 8 if law == "smooth_step" else 1.0)
    behind = ~(a_max >= peak)
    out = np.zeros(speed.shape)
    if behind.any():
        out[behind] = _ramp_shortfall(speed[behind], ramp_time[behind], window, a_max[behind], law)
    return out


def _ramp_shortfall(speed: np.ndarray, ramp_time: np.ndarray, window: tuple[float, float], a_max: np.ndarray, law: str):
    """`ramp_shortfall` stepped (1-D arrays; the law's fraction computed once per step where every variant ramps
    over the same time)."""
    start, end = window
    dt = end / RAMP_STEPS
    w = np.zeros_like(speed)
    got, want, ref = np.zeros_like(speed), np.zeros_like(speed), np.empty_like(speed)
    ramp = np.maximum(ramp_time, 1e-12)
    one = ramp[:1] if len(ramp) and np.all(ramp == ramp[0]) else ramp  # one ramp time: the fraction a scalar
    climb = a_max * dt
    for i in range(1, RAMP_STEPS + 1):
        t = i * dt
        x = t / one
        if law == "smooth_step":
            x = np.clip(x, 0.0, 1.0)
            frac = x**3 * (10 - 15 * x + 6 * x * x)
        elif law == "ramp":
            frac = np.clip(x, 0.0, 1.0)
        else:
            frac = x
        np.multiply(speed, frac, out=ref)  # in place: the same arithmetic, no array made per step
        w += climb
        np.minimum(ref, w, out=w)
        if t >= start:
            got += w
            want += ref
    return np.where(want > 0, 1.0 - got / np.where(want > 0, want, 1.0), 0.0)


def _can_share(need: pd.DataFrame, what: str, bound: float, grip: Any = None) -> pd.Series:
    """Per variant, whether the four drives can give the four wheels' `what` (`rms` or `peak_window`) together
    with each at most `bound` and at most its grip: sum_j min(bound, T_j / u) >= sum_j T_j, where u = sum_j T_j /
    grip is the friction the wheels use (each wheel's grip T_j / u: the slip tyre's force is its load times one
    common slip, so each wheel's torque is its share of the load); without `grip`, sum_j min(bound, T_j) = the
    mean within the bound."""
    t = np.stack([need[f"{what}_{j}"].to_numpy(float) for j in range(4)], axis=-1)
    total = t.sum(axis=-1)
    if grip is None:
        cap = np.full_like(t, bound)
    else:
        used = total / np.maximum(np.asarray(grip, float), 1e-12)
        cap = np.minimum(bound, t / np.maximum(used, 1e-12)[:, None])
    return pd.Series(cap.sum(axis=-1) >= total * (1 - 1e-12), index=need.index)


def screen_one(
    need: pd.DataFrame,
    motor: Any,
    *,
    armature: float = 0.0,
    accel: Any = 0.0,
    duty: float = 1.0,
    ramp: dict[str, Any] | None = None,
) -> pd.DataFrame:
    """Per variant, whether `motor` (a batchveh.model.motors.DCMotor with its gearhead) covers the demand
    `need` (`demand`'s columns), and why not (one boolean column per REASONS entry, True = fails).

    The demand was simulated with an ideal servo whose reflected inertia was `armature` (kg m^2 at
    the wheel: the vehicle's motors.armature); the candidate's rotor reflects J N^2, so its peak
    torque is the demand's plus (J N^2 - armature) x `accel` (rad/s^2 at the wheel, each variant's
    own, e.g. its speed over its ramp time). At the motor: i = T / (eta N K), reported as current_rms and
    current_peak (the whole run's, the rotor's share with it). The drive clips the current at i_max, so the
    motor gives at most the bound eta N K i_max at the wheel, and the checks read what the loop reads:
    - peak: the steady window's low-pass peak (`peak_window`; a steering motor's: the whole run's) above the
      bound: short of torque where the speed must be held (a ramp's peak only puts the ramp behind);
    - voltage: the window's peak, at most the bound, at the variant's mean speed: v = i R + K N w above the bus;
    - rms and thermal: the run repeated for `duty` of the time (the spec's `duty`, 1: back to back): the RMS
      current over time sqrt(duty) i_rms against i_max, and the winding's steady rise dT = R_T duty i_rms^2 R0
      (1 + alpha (T_a + dT - 25)), solved in closed form (runaway where R_T duty i^2 R0 alpha >= 1);
    - gear_torque: the RMS and the whole run's peak, each at most the bound, against the gearhead's ratings;
    - the ramp (`ramp`: {'speed': the imposed wheel speed (rad/s), 'inertia': what each drive accelerates
      without its rotor (kg m^2: a quarter of the vehicle at the wheel's radius and the wheel), 'ramp_time',
      'window': (start, end) s of law time, 'law'}, per variant or one value): a drive at its bound accelerates
      its wheel at most at (bound - the steady torque) / (inertia + J N^2); where that leaves the window's mean
      speed more than SHORT_SHARE below the imposed (`ramp_shortfall`), the motor fails on `peak`, as the loop
      counts a drive short at its current limit. Without it, a ramp's peak is not judged.

    The four drives share (`need` with each wheel's `rms_<j>` and `peak_window_<j>`): where the other wheels can
    take what the worst cannot give, the worst wheel's RMS and window peak are taken at most at the bound: the
    drive clips it there and the other wheels' speed loops take the rest, as the loop measured on the seed's
    climbs (the worst wheel at its bound, the four-wheel sum the servo's, the speed held). Each wheel can take at
    most the bound, and at most its grip (`ramp['grip']`, mu M g cos(slope) r over the four wheels, shared in
    proportion to each wheel's torque: the slip tyre's force is its load times one common slip); `_can_share`.
    Where they cannot, the worst wheel is judged on its own."""
    from batchveh.model.motors import COPPER_TEMPCOEF, REFERENCE_TEMP

    c = motor.resolved()
    n, eta, k, r = c["N"], c["eta"], c["K"], c["R"]
    bound = bound_at_wheel(c)
    peak = need["peak"] + np.maximum(c["J"] * n * n - armature, 0.0) * np.abs(accel)
    window = need["peak_window"] if "peak_window" in need else need["peak"]
    rms = need["rms"]
    if "rms_mean" in need:  # drives: the four share what one clipped wheel cannot give
        grip = None if ramp is None else ramp.get("grip")
        shared = _can_share(need, "rms", bound, grip) & _can_share(need, "peak_window", bound, grip)
        rms, window = rms.where(~shared, np.minimum(rms, bound)), window.where(~shared, np.minimum(window, bound))
    i_rms, i_peak = np.sqrt(duty) * rms / (eta * n * k), peak / (eta * n * k)
    w_motor = need["speed"] * n
    out = pd.DataFrame(index=need.index)
    out["current_rms"], out["current_peak"], out["motor_speed"] = i_rms, i_peak, w_motor
    out["voltage_peak"] = terminal_voltage(np.minimum(window, bound), need["speed"], c)
    heat = c["R_T"] * i_rms**2 * r
    denominator = 1 - heat * COPPER_TEMPCOEF
    rise = np.where(denominator > 0, heat * (1 + COPPER_TEMPCOEF * (c["T_amb"] - REFERENCE_TEMP)) / denominator, np.inf)
    out["winding_temperature"] = c["T_amb"] + rise if c["R_T"] > 0 else np.nan
    out["rms"] = i_rms > c["i_max"] if c["i_max"] > 0 else False
    out["thermal"] = out["winding_temperature"] > c["T_max"] if c["R_T"] > 0 else False
    out["voltage"] = out["voltage_peak"] > c["V"]
    out["peak"] = window > bound
    if ramp is not None and c["i_max"] > 0:
        steady = need["rms_mean"] if "rms_mean" in need else need["rms"]  # the four share the vehicle's pull
        a_max = np.maximum(bound - steady.to_numpy(), 0.0) / (np.asarray(ramp["inertia"], float) + c["J"] * n * n)
        out["ramp_shortfall"] = ramp_shortfall(ramp["speed"], ramp["ramp_time"], ramp["window"], a_max, ramp["law"])
        out["peak"] |= out["ramp_shortfall"] > SHORT_SHARE
    out["speed"] = w_motor > c["V"] / k
    gear_torque = np.zeros(len(need), bool)
    if motor.gear_max_continuous_torque is not None:  # the torque the motor gives: at most its bound
        gear_torque |= np.minimum(rms, bound).to_numpy() > motor.gear_max_continuous_torque
    if motor.gear_max_intermittent_torque is not None:
        gear_torque |= np.minimum(peak, bound).to_numpy() > motor.gear_max_intermittent_torque
    out["gear_torque"] = gear_torque
    out["gear_speed"] = w_motor > motor.gear_max_input_speed if motor.gear_max_input_speed is not None else False
    out["energy"] = False
    out["tracking"] = False
    out["fits"] = ~out[list(REASONS)].any(axis=1)
    return out


def screen(
    df: pd.DataFrame,
    catalogue: dict[str, Any],
    *,
    share: float = 0.99,
    group: str = "drive",
    span: str | None = None,
    armature: float = 0.0,
    accel: Any = 0.0,
    params: list[str] | None = None,
    duty: float = 1.0,
    ramp: dict[str, Any] | None = None,
    judged: Any = None,
) -> tuple[str | None, pd.DataFrame, dict[str, pd.DataFrame]]:
    """The fast screen of a sweep's ideal-servo demand against DC motors with their gearheads.

    `df`: the rows of a servo sweep (`batchveh.load(folder)`); `catalogue`: {name: DCMotor}, as
    `batchveh.load_catalogue(path)` returns it. Each variant's demand is `demand(df, group, span)`: on the
    worst of the group's four motors ('drive' or 'steer'), the steady window's RMS, the whole run's
    low-pass peak and the mean wheel speed, or, with `span` ('mission' or a segment's prefix such as
    'seg2_climb'), the span's RMS, low-pass peak and peak speed. Each motor is checked per variant by
    `screen_one` (the reasons: REASONS, REASON_TEXT).

    The rotor's inertia: the servo sweep simulated a reflected inertia of `armature` at each drive joint
    (kg m^2 at the wheel: pass the sweep's `spec.vehicle.motors.armature`); a candidate reflects J N^2
    (its rotor inertia J through its ratio N). Each variant's peak torque is taken as the demand's peak
    plus max(J N^2 - armature, 0) x |accel|, with `accel` the wheel's angular acceleration (rad/s^2; one
    number, or one per row of `df`, e.g. the speed over the ramp time). With the defaults (armature 0,
    accel 0) nothing is added: the rotor's inertia is not reflected unless `accel` is given.

    Returns a 3-tuple (best, table, failing):
    - best: the name of the smallest candidate, by its continuous torque at the wheel eta N K i_max,
      whose coverage is at least `share` (the share of `df`'s rows it covers, or of the rows `judged` marks: a
      boolean per row, as the loop counts a drive over the runs whose steering held; None: every row), or None
      where none does.
      `share=1.0`: the smallest motor that covers every variant;
    - table: a DataFrame, one row per candidate sorted by that torque: motor, gear_ratio,
      continuous_torque_at_wheel (N m), coverage (0-1) and fails_<reason> for each of REASONS (the count
      of variants failing for it; a variant may fail for several);
    - failing: {name: DataFrame} per candidate, its failing variants (index of `df`): the `params`
      columns of `df` (default: every sweepable parameter's column in `df`), one boolean column per
      reason (True = fails) and `where`, the span (a mission's segment) and reason it fails for first."""
    if not 0 < share <= 1:
        raise ConfigError(f"share: {share!r} is not allowed; allowed: 0 < share <= 1")
    need = demand(df, group, span)
    if params is None:
        from batchveh.model.params import parameter_specs

        params = [col for col in df.columns if col in parameter_specs()]
    keep = list(params)
    segments = mission_segments(df) if span == "mission" else []
    counted = np.ones(len(df), bool) if judged is None else np.asarray(judged, bool)

    def one(name: str, motor: Any) -> tuple[dict, pd.DataFrame]:
        c = motor.resolved(name)
        cycle = ramp if ramp is not None and "segments" in ramp else None  # a duty cycle's: its segments'
        straight = None if cycle is not None else ramp
        res = screen_one(need, motor, armature=armature, accel=accel, duty=duty, ramp=straight)
        if span not in (None, "mission") and f"{span}_{GROUPS[group][0]}_drive_peak_lp" in df:  # one segment: its
            res["voltage"] = _segment_voltage(df, group, span, c) > c["V"]  # voltage as the mission's segments read it
            res["fits"] = ~res[list(REASONS)].any(axis=1)
        where = _segments(df, group, segments, motor, res, cycle) if segments else _where(res, span or "window")
        row = {
            "motor": name,
            "gear_ratio": c["N"],
            "continuous_torque_at_wheel": bound_at_wheel(c, np.nan),
            "coverage": float(res["fits"].to_numpy()[counted].mean()) if counted.any() else 0.0,
            "judged": int(counted.sum()),
            **{f"fails_{why}": int(res[why].to_numpy()[counted].sum()) for why in REASONS},
            "limiting": _limiting(where[~res["fits"] & counted]),
        }
        bad = ~res["fits"] & counted
        return row, pd.concat([df.loc[bad, keep], res.loc[bad, list(REASONS)], where[bad].rename("where")], axis=1)

    # the motors in threads: numpy lets go of the GIL in its array loops, which are most of a motor's screen
    # (100,000 rows, 10 motors: 1.3 s in one thread on 2 cores)
    with ThreadPoolExecutor(max(1, min(len(catalogue), os.cpu_count() or 1))) as pool:
        done = list(pool.map(one, catalogue, catalogue.values()))
    rows = [row for row, _ in done]
    failing = {name: bad for name, (_, bad) in zip(catalogue, done, strict=True)}
    table = pd.DataFrame(rows).sort_values("continuous_torque_at_wheel").reset_index(drop=True)
    ok = table[table["coverage"] >= share]
    return (ok["motor"].iloc[0] if len(ok) else None), table, failing


INSTANT = ("voltage", "peak", "speed", "gear_speed")  # a segment's own demand: these, and the gearhead's peak


def mission_segments(df: pd.DataFrame) -> list[str]:
    """A mission result's segment spans (`seg1_accelerate`, ...), in mission order."""
    spans = {c.removesuffix("_drive_lf_rms") for c in df.columns if c.startswith("seg") and c.endswith("_drive_lf_rms")}
    return sorted(spans, key=lambda x: int(x[3:].split("_")[0]))


def _where(res: pd.DataFrame, span: str | pd.Series) -> pd.Series:
    """Per variant, the first reason it fails for, named with its span ("window: voltage"; `span` one name, or
    one per variant); "" where it fits."""
    spans = pd.Series(span, index=res.index, dtype=object).to_numpy(dtype=object)
    out = np.full(len(res), "", dtype=object)
    free = np.ones(len(res), bool)
    for why in REASONS:
        hit = free & res[why].to_numpy(bool)
        out[hit] = spans[hit] + f": {why}"
        free &= ~hit
    return pd.Series(out, index=res.index, dtype=object)


def segment_ramp(df: pd.DataFrame, seg: str, motor: Any, ramp: dict[str, Any]) -> np.ndarray:
    """Per variant, how far a drive at its current's bound falls behind over an accelerating segment `seg` of a
    duty cycle, relative to the segment's imposed distance (the loop's `segment_shortfall` reads the same share).

    The segment takes the wheels from the previous segment's speed w0 (a cruise's, a climb's or an accelerate's
    peak; 0 after a stop, a steer or at the start) to its own peak w1 along the quintic smooth step over its
    transition tau, in a segment of duration D. Per variant, on the mean of the four wheels (the four drives share
    the vehicle's pull, as on a straight line): the law's peak acceleration a = 15/8 (w1 - w0) / tau, the steady
    torque T_s = the mean low-pass peak less (inertia + armature) a (what the servo's wheel needed beyond the
    acceleration), and a drive at its bound eta N K i_max accelerates at most at (bound - T_s) / (inertia + J N^2)
    (`ramp['inertia']`: a quarter of the vehicle at the wheel and the wheel, per variant). The ramp model of the
    straight line (`ramp_shortfall`) gives the shortfall over the ramp's distance, w1-w0 over D - tau / 2, and the
    segment's share adds the distance w0 D."""
    c = motor.resolved()
    info = ramp["segments"][seg]
    names = GROUPS["drive"]
    w1 = df[[f"{seg}_{m}_speed_peak" for m in names]].abs().mean(axis=1).to_numpy(float)
    prev = info.get("previous")
    w0 = df[[f"{prev}_{m}_speed_peak" for m in names]].abs().mean(axis=1).to_numpy(float) if prev else 0.0
    dw = np.maximum(w1 - w0, 0.0)
    tau, dur = float(info["transition"]), float(info["duration"])
    inertia = np.asarray(ramp["inertia"], float)
    a_law = 15.0 / 8.0 * dw / tau
    peak = df[[f"{seg}_{m}_peak_lp" for m in names]].abs().mean(axis=1).to_numpy(float)
    steady = np.maximum(peak - (inertia + float(ramp.get("armature", 0.0))) * a_law, 0.0)
    a_max = np.maximum(bound_at_wheel(c) - steady, 0.0) / (inertia + c["J"] * c["N"] ** 2)
    short = ramp_shortfall(dw, tau, (0.0, dur), a_max, "smooth_step")
    ramped = dw * (dur - tau / 2)
    whole = ramped + w0 * dur
    return np.where(whole > 0, short * ramped / np.where(whole > 0, whole, 1.0), 0.0)


def _segments(
    df: pd.DataFrame, group: str, segments: list[str], motor: Any, res: pd.DataFrame, ramp: dict | None = None
) -> pd.Series:
    """A mission's duty cycle on the screen: each segment's own demand (its RMS, low-pass peak and peak speed)
    against the motor's instantaneous limits (INSTANT: a climb at speed is a point on the torque-speed plane,
    not an average; and the gearhead's intermittent rating), ORed into `res` in place; the cycle's RMS and heat
    stay the whole mission's. Per variant, the first segment and reason it fails for ("seg3_climb: voltage at
    16.5 rad/s"), or the cycle's ("mission: thermal"); "" where it fits."""
    c = motor.resolved()
    bound = bound_at_wheel(c)
    where = pd.Series("", index=res.index, dtype=object)
    wheel_by_wheel = f"{segments[0]}_{GROUPS[group][0]}_drive_peak_lp" in df if segments else False
    if wheel_by_wheel:  # the voltage is each segment's (below), not the cycle's peak torque at its peak speed
        res["voltage"] = False
    # the cycle's peak is its segments' largest: each segment judges its own (an accelerating one with its ramp)
    res["peak"] = False
    for seg in segments:
        need = demand(df, group, seg)
        got = screen_one(need, motor)
        if ramp is not None and group == "drive" and seg in ramp.get("standing", ()):
            # a steer in place: the drives hold their wheels still against the patch's scrub; one at its bound lets
            # its wheel roll a little, and no distance is asked (the loop's segment_shortfall reads none there)
            got["peak"] = False
        if ramp is not None and group == "drive" and seg in ramp["segments"] and c["i_max"] > 0:
            # an accelerating segment: its peak above the bound fails only where the drive at its bound falls more
            # than SHORT_SHARE behind over the segment, as the loop counts it
            got["peak"] &= segment_ramp(df, seg, motor, ramp) > SHORT_SHARE
        if motor.gear_max_intermittent_torque is not None:
            got["gear_torque"] = np.minimum(need["peak"], bound) > motor.gear_max_intermittent_torque
        if wheel_by_wheel:  # the voltage wheel by wheel, on the torque that drives
            got["voltage"] = _segment_voltage(df, group, seg, c) > c["V"]
        for why in (*INSTANT, "gear_torque"):
            hit = got[why].to_numpy(bool)
            res[why] = res[why].to_numpy(bool) | hit
            new = hit & (where == "").to_numpy()
            speeds = need["speed"].to_numpy()[new]
            where[new] = [f"{seg}: {why} at {w:.3g} rad/s" for w in speeds]
    res["fits"] = ~res[list(REASONS)].any(axis=1)
    rest = _where(res, "mission")
    where[(where == "") & (rest != "")] = rest
    return where


def _segment_voltage(df: pd.DataFrame, group: str, seg: str, c: dict[str, float]) -> np.ndarray:
    """Per variant, the largest terminal voltage a segment asks of one of the group's motors: each wheel's peak
    low-pass torque while it drives (a braking torque needs less voltage, not more), at most the bound, with that
    wheel's own peak speed: i R + K N w, the largest over the wheels. Still an upper bound (the two peaks need not
    fall at one instant), but it no longer pairs one wheel's torque with another's speed, or a stop's braking with
    the speed it brakes from. Counted as the loop counts a voltage miss: a drive at its voltage line is short only
    where it falls more than SHORT_SHARE behind its speed (`segment_shortfall`), so a drive's speed is taken
    SHORT_SHARE below the peak (a steering motor's at its peak: the loop judges it on its time at the line)."""
    bound = bound_at_wheel(c)
    forgiven = SHORT_SHARE if group == "drive" else 0.0
    out = np.zeros(len(df))
    for m in GROUPS[group]:
        torque = np.minimum(df[f"{seg}_{m}_drive_peak_lp"].abs().to_numpy(), bound)
        speed = (1.0 - forgiven) * df[f"{seg}_{m}_speed_peak"].abs().to_numpy()
        out = np.maximum(out, terminal_voltage(torque, speed, c))
    return out


def _limiting(where: pd.Series) -> str:
    """The commonest segment and reason among a motor's failing variants, and how many fail there."""
    if not len(where):
        return ""
    # the same reason at another speed counts as one: the regex on the distinct strings, in the order they first
    # come (ties go to the reason met first, as value_counts on every string's key would)
    first = pd.unique(where.to_numpy())
    counts = where.value_counts().reindex(first)
    top = counts.groupby(pd.Index(first).str.replace(r" at .*", "", regex=True), sort=False).sum()
    top = top.sort_values(ascending=False, kind="stable")
    return f"{top.index[0]} ({int(top.iloc[0])} of {len(where)})"


# --- the second pass: the screen's survivors in the loop, from the hot steady state ---

IN_LOOP_REASONS = REASONS  # the loop counts the screen's reasons (kept under its old name too)
STEER_LOST_DEG = 5.0  # a steering angle more than this far from the imposed one: the steering motor lost it
STEER_LIMIT_SHARE = 0.05  # a steering motor at its current limit or voltage line for more than 5% of the run
IN_LOOP_TEXT = {
    "rms": "a drive's RMS current over the steady window, at the spec's duty, above its continuous current",
    "thermal": "a winding above its maximum temperature, in the hot steady state of the run repeated at the duty",
    "voltage": "fell short of the imposed speed with a drive at its voltage line (the bus voltage)",
    "peak": "fell short of the imposed speed with a drive at its current limit (not torque enough)",
    "speed": "the servo's wheel speed above the no-load speed at the bus voltage (as the screen)",
    "gear_torque": "wheel torque above the gearhead's continuous (RMS) or intermittent (peak) rating",
    "gear_speed": "motor speed above the gearhead's input speed",
    "energy": "the run's bus energy above the battery's, or its peak power above the battery's",
    "tracking": "fell short of the imposed speed with neither limit held for more than 1% of the run",
}
# where the two passes read a reason differently (the report prints it beside each reason's two counts)
DIFFER = {
    "rms": "screen: the servo's torque over eta N K, the four wheels sharing up to the bound; loop: the current "
    "the motor carried, which the drive clips at i_max, so a motor short of it falls short at its current limit "
    "there (counted as peak)",
    "thermal": "screen: the steady window's (a duty cycle's: the cycle's) RMS held for ever; loop: the whole run "
    "(its ramp too), repeated",
    "voltage": "screen: the window's peak torque (at most the bound) at the mean speed (a duty cycle's: each "
    "wheel's driving peak at 98% of its peak speed, both peaks taken together though they need not coincide); "
    "loop: short of speed at the line",
    "peak": "screen: the window's low-pass peak above the current's bound, or the ramp, at the bound's "
    "acceleration, still short in the window (a straight line's); loop: short of speed at that bound",
    "speed": "the same: the servo's mean wheel speed (a duty cycle's peak) against the no-load speed",
    "gear_torque": "the same ratings; screen on the servo's torque, loop on the motor's",
    "gear_speed": "the same rating; screen: the servo's mean wheel speed, loop: the motor's own (a wheel may spin)",
    "energy": "the loop only (the servo's run draws no current)",
    "tracking": "the loop only (the servo holds its speed by construction)",
}
# the steering motor's criteria in the loop: the screen's, where they apply, and `lost`, which only the loop sees
STEER_REASONS = ("rms", "thermal", "voltage", "peak", "gear_torque", "lost")
STEER_TEXT = {
    "rms": "a steering motor's RMS current, at the duty, above its continuous current",
    "thermal": "a steering winding above its maximum temperature in the hot steady state",
    "voltage": "a steering motor at its voltage line for more than 5% of the run",
    "peak": "a steering motor at its current limit for more than 5% of the run",
    "gear_torque": "steering torque above the gearhead's continuous (RMS) or intermittent (peak) rating",
    "lost": "a steering angle more than 5 deg off the imposed one",
}


@dataclass(frozen=True)
class Battery:
    """The battery of a catalogue's `battery:` section (notebooks/motors.yaml; SI, at its terminals)."""

    name: str = "battery"
    nominal_voltage: float = field(48.0, unit="V", gt=0)
    capacity: float = field(10.0, unit="A h", gt=0)
    internal_resistance: float = field(0.1, unit="Ohm", ge=0)
    max_continuous_discharge_current: float = field(20.0, unit="A", gt=0)

    @property
    def energy_wh(self) -> float:
        return self.nominal_voltage * self.capacity

    @property
    def max_power(self) -> float:
        """Power at the terminals at the continuous discharge current: (V - I R) I (W)."""
        i = self.max_continuous_discharge_current
        return (self.nominal_voltage - i * self.internal_resistance) * i


def load_battery(path: str | Path) -> Battery:
    """The `battery:` section of a catalogue YAML (notebooks/motors.yaml) as a Battery (its nominal_voltage,
    capacity, internal_resistance and max_continuous_discharge_current, each required; energy_wh and max_power
    derived); other keys of the section are ignored, and a missing section or field is one ConfigError line."""
    data = load_yaml(path)
    raw = data.get("battery") if isinstance(data, dict) else None
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: battery: missing; allowed: a mapping of Battery's fields")
    keep = {k: v for k, v in raw.items() if k in Battery.__dataclass_fields__}
    for need in ("nominal_voltage", "capacity", "internal_resistance", "max_continuous_discharge_current"):
        if need not in keep:  # never a default in its place: a misspelt key would size against another battery
            other = [k for k in raw if k not in Battery.__dataclass_fields__]
            raise ConfigError(f"{path}: battery: {need}: missing{did_you_mean(need, other)}; allowed: a number")
    return from_mapping(Battery, keep, f"{path}: battery")


def _hot_start(res: pd.DataFrame, names: tuple[str, ...], c: dict, start: np.ndarray, duration: float, rest: float):
    """Per variant, the start rise (K above ambient) at which a run repeated back to back, `rest` s at standstill
    between runs, ends where it started: the fixed point of the one-node winding's run-to-run map, in closed form
    from one run `res` that started at `start`, for the hottest of the motors `names` (constants `c`, resolved).

    Over a run the rise s obeys C ds/dt = i^2 R (1 + alpha (T_a + s - 25)) - s / R_T: linear in s, so the run maps
    its start onto its end as end = Phi start + Gamma, with Phi = exp((alpha R Q - D / R_T) / C), Q the integral of
    i^2 over the steps whose heat `<motor>_winding_temp_end` holds (`<motor>_current_sq_time`: every step but the
    last) and D their duration (the run's less one step); Gamma = end - Phi start from the run itself. The rest
    cools by E = exp(-rest / tau). Back to back: s = E (Phi s + Gamma), so
    s = E Gamma / (1 - E Phi) (a winding whose copper loss grows faster with heat than it sheds runs away: it has
    none, and the run repeated once, E end, stands in; its heat fails it anyway).
    Exact where the current does not depend on the temperature, the drive passing MuJoCo the voltage that gives
    the asked current; at its voltage line the hot winding carries a little less, and the next run says how much
    (its residual). No thermal model: 0."""
    from batchveh.model.motors import COPPER_TEMPCOEF

    if c["t_T"] <= 0 or c["C"] <= 0:
        return np.zeros(len(res))
    e = np.exp(-rest / c["t_T"])
    out = np.zeros(len(res))
    for m in names:
        q = res[f"{m}_current_sq_time"].to_numpy(float)
        end = res[f"{m}_winding_temp_end"].to_numpy(float) - c["T_amb"]
        phi = np.exp((COPPER_TEMPCOEF * c["R"] * q - duration / c["R_T"]) / c["C"])
        gamma = end - phi * start
        with np.errstate(divide="ignore", invalid="ignore"):  # a runaway has no fixed point: the run repeated once
            s = np.where(e * phi < 1.0, e * gamma / (1.0 - e * phi), e * end)
        out = np.maximum(out, np.nan_to_num(s, nan=0.0, posinf=0.0, neginf=0.0))
    return np.maximum(out, 0.0)


HOT_MARGIN = 0.99  # a run in closed form only where its start rise stays below this share of its voltage margin


def closed_form(spec: Any) -> bool:
    """Whether the loop takes a candidate's hot run in closed form from its cold one (`hot_columns`): on a straight
    line; a mission's spans' electric columns (each segment's peak and energies) have none here."""
    return spec.stats_config().mission is None


def hot_columns(res: pd.DataFrame, start: dict, consts: dict, battery: Battery | None = None):
    """A run's columns had it started at the rises `start` ({'motors.drive_start_rise': (n,), 'motors.steer_start_rise':
    (n,)} K, each group's windings), in closed form from `res`, a run from ambient with `motors.hot_columns`
    (motor_stats.HOT_COLUMNS's columns), and which variants it cannot answer for. Returns (the columns, redo (n,) bool).

    Off the voltage line the drive carries the current it asks whatever the winding's resistance, so the run
    started hotter is the same run: its currents, torques and speeds are these, and the winding, linear in its
    temperature at a given current, runs at T + s g (`<motor>_temp_gain`, g at the last step). So: the end
    exactly; the peak, a convex function of s kept at 0 and motor_stats.HOT_GRID, interpolated (an upper bound;
    the true one is at least max(f(a) + g (s - a), f(b) - (b - s)) between the points a, b around s); the net
    energy exactly (the power rises by alpha R i^2 g s); the bus's peak power below P + s (its gains) and at least
    P. A variant is redone (`redo`) where a step would reach the voltage line (s at HOT_MARGIN of
    `<motor>_voltage_margin` or above: its current would depend on s), where its thermal verdict lies inside the
    peak's bounds, and where the battery's power does. `consts`: the groups' resolved catalogue constants."""
    from batchveh.stepping.motor_stats import HOT_GRID

    out = res.copy()
    n = len(res)
    rows = np.arange(n)
    redo = np.zeros(n, bool)
    grid = np.array((0.0, *HOT_GRID))
    last = len(grid) - 1
    net = res["bus_energy_wh"].to_numpy(float).copy()
    bus_hi = res["bus_power_peak"].to_numpy(float).copy()
    for (key, names), side in zip(GROUP_RISES.items(), ("drive", "steer"), strict=True):
        s = np.asarray(start[key], float)
        t_max = consts[key]["T_max"]
        bus_hi += s * res[f"bus_power_gain_{side}"].to_numpy(float)
        for m in names:
            g = res[f"{m}_temp_gain"].to_numpy(float)
            out[f"{m}_winding_temp_end"] = res[f"{m}_winding_temp_end"].to_numpy(float) + s * g
            f = np.stack(
                [res[f"{m}_winding_temp_peak{x}"].to_numpy(float) for x in ("", *(f"_{v:g}K" for v in HOT_GRID))], 1
            )
            j = np.clip(np.searchsorted(grid, s, side="right") - 1, 0, last)
            k = np.minimum(j + 1, last)
            a, b, fa, fb = grid[j], grid[k], f[rows, j], f[rows, k]
            beyond = j == last
            width = np.where(beyond, 1.0, b - a)
            hi = np.where(beyond, fa + (s - a), fa + (fb - fa) * (s - a) / width)
            lo = np.where(beyond, fa + g * (s - a), np.maximum(fa + g * (s - a), fb - (b - s)))
            out[f"{m}_winding_temp_peak"] = hi
            heated = s > 0
            redo |= heated & (lo <= t_max) & (t_max < hi)  # its thermal verdict is not in the bounds
            redo |= heated & (s >= HOT_MARGIN * res[f"{m}_voltage_margin"].to_numpy(float))  # at the voltage line
            hd, hr = (res[f"{m}_heat_gain_{x}"].to_numpy(float) for x in ("drawn", "regen"))
            drawn, regen = (res[f"{m}_energy_{x}"].to_numpy(float) for x in ("drawn", "regen"))
            # the net exact; a regenerating step that turns to drawing moves as much from one to the other
            out[f"{m}_energy_regen"] = np.maximum(regen - s * hr, 0.0)
            out[f"{m}_energy_drawn"] = drawn - regen + s * (hd + hr) + out[f"{m}_energy_regen"].to_numpy()
            net += s * (hd + hr) / 3600.0
    out["bus_energy_wh"] = net
    out["bus_power_peak"] = bus_hi
    if battery is not None:  # the battery's power verdict inside [P, P + its gains]
        p0 = res["bus_power_peak"].to_numpy(float)
        redo |= (p0 <= battery.max_power) & (battery.max_power < bus_hi)
    return out, redo


def _without_gains(res: pd.DataFrame) -> pd.DataFrame:
    """A run's columns less motor_stats' start-rise gains (MotorStatsConfig.hot)."""
    from batchveh.stepping.motor_stats import HOT_COLUMNS

    gains = tuple(f"_{k}" for k in HOT_COLUMNS)
    return res.drop(columns=[c for c in res if c.endswith(gains) or c.startswith("bus_power_gain_")])


Runner = Callable[[Any, dict], pd.DataFrame]
"""How the loop's runs are run: (the run's SweepSpec, with the dcmotors; its table, name -> (n,) values: the
spec's parameters, `motors.drive` (a catalogue index) where the batch holds several drives, and the two start
rises) -> its results, a row per table row in order, `motor_stats.named`'s columns (status_code among them).
`engine_runner` runs on one engine in this process; `batchveh.size` runs each as a sweep (executors, resume)."""


def engine_runner(backend: str | None = None) -> Runner:
    """A Runner on one engine in this process: MuJoCo C (None, 'mujoco') or MuJoCo Warp ('warp'; MJX's JAX
    implementation has no dcmotor)."""
    from batchveh.engines import make_engine, resolve_backend
    from batchveh.stepping.batch import apply_solver, make_batch
    from batchveh.stepping.motor_stats import named

    name_of = resolve_backend(backend or "mujoco")

    def run(run_spec: Any, table: dict) -> pd.DataFrame:
        n = len(next(iter(table.values())))
        engine = make_engine(name_of, run_spec.scenario, run_spec.stats_config(), None, n, precision=run_spec.precision)
        batch = make_batch(run_spec.vehicle, run_spec.scenario, table)
        apply_solver(batch.model, run_spec.solver)  # the spec's solver settings, as a sweep's chunks take them
        cols = engine.run(batch)
        return pd.DataFrame({key: np.asarray(v) for key, v in named(cols).items()})

    return run


def batches(cat: dict[str, Any], names: list[str]) -> list[list[str]]:
    """`names` in order, cut into runs of motors that one compiled program holds: all with a thermal model or
    none, all with a current limit or none (the model's sizes differ otherwise)."""
    out: list[list[str]] = []
    last = None
    for name in names:
        c = cat[name].resolved(name)
        kind = (c["R_T"] > 0, c["i_max"] > 0)
        if out and kind == last:
            out[-1].append(name)
        else:
            out.append([name])
        last = kind
    return out


def _hot_runs(spec, df, catalogue, cat, batch, steer, runs, duty, run, battery=None, closed=True) -> list[tuple]:
    """The drives `batch` (catalogue names) run in the loop on every variant of `df` in one batch: the
    (candidate, variant) pairs are its rows, each with its drive's constants, gearhead, rotor and gains
    (`motors.drive` per row). `runs` runs: from ambient, then from the closed-form hot start (`_hot_start`) of
    the run before. With two (the default), the second is taken in closed form from the first (`hot_columns`),
    and run only for the variants it cannot answer for; a mission's (its spans' electric columns have no closed
    form here) runs whole. Per candidate: (its last run's rows, the start rises it ran from, |end - start| left (K),
    the variants its hot run ran for (-1: all))."""
    import dataclasses

    n, k = len(df), len(batch)
    closed = closed and runs == 2 and closed_form(spec)
    motors = dataclasses.replace(
        spec.vehicle.motors, model="dcmotor", catalogue=str(catalogue), drive=batch[0], steer=steer,
        hot_columns=closed,
    )  # fmt: skip
    run_spec = dataclasses.replace(spec, vehicle=dataclasses.replace(spec.vehicle, motors=motors))
    table = {p: np.tile(df[p].to_numpy(float), k) for p in spec.params}
    if k > 1:  # the candidates as one sweep over motors.drive
        names = motors.catalogue_names()
        table["motors.drive"] = np.repeat([float(names.index(b)) for b in batch], n)
    duration = run_spec.stats_config().n_steps * float(spec.scenario.time_step)
    rest = duration * (1.0 / duty - 1.0)
    heated = duration - float(spec.scenario.time_step)  # winding_temp_end holds every step's heat but the last
    keys = tuple(GROUP_RISES)
    consts = [dict(zip(keys, (cat[b].resolved(b), cat[steer].resolved(steer)), strict=True)) for b in batch]
    start = [{key: np.zeros(n) for key in keys} for _ in batch]
    ran, parts = [-1] * k, []
    for r in range(runs):
        rises = {key: np.concatenate([s[key] for s in start]) for key in keys}
        if closed and r == 1:  # the hot run from the cold one, run only where the closed form cannot say
            hot = [hot_columns(res, s, c, battery) for res, s, c in zip(parts, start, consts, strict=True)]
            whole = pd.concat([h[0] for h in hot], ignore_index=True)
            redo = np.concatenate([h[1] for h in hot])
            ran = [int(h[1].sum()) for h in hot]
            if redo.any():
                at = np.flatnonzero(redo)
                again = run(run_spec, {key: v[at] for key, v in {**table, **rises}.items()})
                again = again[list(whole.columns)].set_axis(at)
                whole = pd.concat([whole.drop(index=at), again]).sort_index()
        else:
            whole = run(run_spec, {**table, **rises})
        parts = [whole.iloc[j * n : (j + 1) * n].reset_index(drop=True) for j in range(k)]
        residual = []
        for res, s, c in zip(parts, start, consts, strict=True):
            # the next run starts from this one's end, cooled over the rest between runs
            end = {
                key: (res[[f"{m}_winding_temp_end" for m in GROUP_RISES[key]]].max(axis=1).to_numpy() - c[key]["T_amb"])
                * (np.exp(-rest / c[key]["t_T"]) if c[key]["t_T"] > 0 else 0.0)
                for key in keys
            }
            residual.append(max(float(np.max(np.abs(end[key] - s[key]))) for key in keys))
        if r < runs - 1:  # the next start: the back-to-back fixed point, in closed form from this run
            start = [
                {key: _hot_start(res, GROUP_RISES[key], c[key], s[key], heated, rest) for key in keys}
                for res, s, c in zip(parts, start, consts, strict=True)
            ]
    parts = [_without_gains(res) for res in parts] if closed else parts
    return list(zip(parts, start, residual, ran, strict=True))


def in_loop(
    spec: Any,
    df: pd.DataFrame,
    catalogue: str | Path,
    candidates: list[str],
    *,
    steer: str,
    share: float = 0.99,
    hot: bool = True,
    iterations: int = 1,
    battery: Battery | None = None,
    backend: str | None = None,
    stop_at_first: bool = True,
    duty: float | None = None,
    run: Runner | None = None,
    closed: bool = True,
    battery_apart: bool = False,
) -> tuple[str | None, pd.DataFrame, dict[str, pd.DataFrame]]:
    """The second pass: `candidates` run as the drive motors in the loop (MuJoCo's dcmotor), on the variants
    of the servo sweep `df`, all in one batch: each (candidate, variant) pair is a variant of one sweep, its
    motor's constants, gearhead, rotor inertia and drive gains its own (cut where the motors' models differ in
    size: `batches`). Results equal one run per candidate.

    `spec`: the servo sweep's SweepSpec, `batchveh.load_spec(path)` (a YAML path given here is read with
    it); `df`: its rows, `batchveh.load(folder)`, holding a column per swept parameter (`spec.params`), or
    the rows to re-run (e.g. a `screen`'s failing variants); `catalogue`: the catalogue YAML's path (the
    runs read it, as a sweep's `motors.catalogue` does; not the dict of `batchveh.load_catalogue`);
    `candidates`: catalogue names, smallest first (e.g. the `screen` table's motors with enough coverage);
    `steer`: the catalogue name of the steering motors. A name not in the catalogue is one ConfigError line
    with did-you-mean. `battery`: a Battery (`batchveh.load_battery(path)`), or None for no energy check;
    `battery_apart`: its verdict (the run's bus energy or peak power above the battery's) is not counted against
    the drive but given apart, as the row's and the detail's `battery_over` (the size command's: the battery's
    limits are not the motor's).

    Returns a 3-tuple (best, table, detail): the first candidate that covers `share` of the variants
    simulated, or None; a DataFrame with one row per candidate run (motor, gear_ratio,
    continuous_torque_at_wheel, coverage, judged, not_simulated, not_simulated_why, fails_<reason> for each of
    IN_LOOP_REASONS, start_rise_median, residual_K, runs, hot_runs, battery_over; `in_loop_lines` words it);
    {name: DataFrame} per candidate, each variant's parameters, its in-the-loop columns, fails_<reason> (True =
    fails), judged and battery_over. A
    variant whose run diverged, or failed a physics check (`motor_status` unstable) with its steering held, could
    not be simulated (`not_simulated`): it is counted in the row's `not_simulated`, never as a reason, and the
    coverage is over the variants simulated.

    With `hot`, a candidate runs first from ambient, then `iterations` times from the start rise that makes its
    run end where it started (`_hot_start`: the one-node winding's back-to-back fixed point in closed form from
    the previous run, each drive and steering group at its hottest winding): the thermal state of back-to-back
    runs, in two runs; with `closed` (the default) on a straight line, the second in closed form from the first
    (`hot_columns`), run only for the variants it cannot answer for (the row's `hot_runs`; -1: every variant ran
    hot). The row gives the median start
    rise and the largest |end - start| left (K). `stop_at_first`: the candidates one at a time, none run after the
    first that covers (else all in one batch, each reported). `run`: how the runs are run (a Runner; default
    `engine_runner(backend)`: `backend` None for 'mujoco', or 'warp'; MJX's JAX implementation has no dcmotor)."""
    from batchveh.model.motors import load_catalogue, pick
    from batchveh.stepping.motor_stats import LIMITED_SHARE

    if not 0 < share <= 1:
        raise ConfigError(f"share: {share!r} is not allowed; allowed: 0 < share <= 1")
    if isinstance(spec, str | Path):  # the YAML's path, not the spec: read it as batchveh.load_spec does
        from batchveh.sweeping.spec import load_spec

        spec = load_spec(spec)
    cat = load_catalogue(catalogue)
    pick(cat, steer, "steer")
    for name in candidates:
        pick(cat, name, "candidates")
    duty = float(getattr(spec, "duty", 1.0) if duty is None else duty)
    if not 0 < duty <= 1:
        raise ConfigError(f"duty: {duty!r} is not allowed; allowed: 0 < duty <= 1")
    run = run or engine_runner(backend)
    runs = 1 + (iterations if hot else 0)
    servo = df.reset_index(drop=True)
    rows, detail, best = [], {}, None
    cs = cat[steer].resolved(steer)
    # stop_at_first: one candidate at a time, none run past the first that covers; else as few batches as fit
    groups = [[name] for name in candidates] if stop_at_first else batches(cat, list(candidates))
    for batch in groups:
        hot = _hot_runs(spec, servo, catalogue, cat, batch, steer, runs, duty, run, battery, closed)
        for name, (res, start, residual, ran) in zip(batch, hot, strict=True):
            motor = cat[name]
            c = motor.resolved(name)
            # a variant whose run failed a physics check (or diverged) says nothing of the motor: apart, never a
            # reason
            diverged = res["status_code"].to_numpy() == 1
            lost = not_simulated(res)
            why_lost = pd.Series(np.where(diverged, "diverged", res["motor_check"].to_numpy()))[lost].value_counts()
            # the speed the servo's run asked, as the screen reads it: a duty cycle's peak, a straight line's mean
            cycle = [f"mission_{m}_speed_peak" for m in WHEELS]
            if cycle[0] in servo:
                servo_speed = servo[cycle].abs().max(axis=1).to_numpy(float)
            else:
                servo_speed = servo["wheel_speed"].to_numpy(float) if "wheel_speed" in servo else None
            behind = segment_shortfall(servo, res)
            why = _in_loop_reasons(res, motor, c, battery, LIMITED_SHARE, duty, servo_speed, behind != "")
            over = why["energy"].to_numpy().copy()  # past the battery's energy or power (all False without one)
            if battery_apart:
                why["energy"] = False
            # named by a mission's segment it fell behind in, or whose servo speed passed the no-load speed (as
            # the screen names it); else the cycle's ("mission"), or a straight line's window
            fast = _first_segment_above(servo, c["V"] / (c["K"] * c["N"]))
            span = behind.where(behind != "", fast.where(why["speed"], ""))
            where = _where(why, span.where(span != "", "mission" if cycle[0] in servo else "window"))
            why.loc[lost, :] = False
            steer_why = steer_reasons(res, cat[steer], cs, duty)
            steer_why.loc[lost, :] = False
            steer_bad = steer_why.any(axis=1).to_numpy()
            judged = ~lost & ~steer_bad  # the drive is judged where the run was simulated and its steering held
            over &= judged
            fits = ~why.any(axis=1)
            simulated = max(int((~lost).sum()), 1)
            counted = max(int(judged.sum()), 1)
            rows.append(
                {
                    "motor": name,
                    "gear_ratio": c["N"],
                    "continuous_torque_at_wheel": bound_at_wheel(c, np.nan),
                    "coverage": float(fits[judged].sum() / counted),
                    "judged": int(judged.sum()),  # the variants the drive's coverage is over: simulated, steering held
                    "not_simulated": int(lost.sum()),
                    "not_simulated_why": ", ".join(f"{v} {k}" for k, v in why_lost.items()),
                    **{f"fails_{r}": int(why[r].to_numpy()[judged].sum()) for r in IN_LOOP_REASONS},
                    "limiting": _limiting(where[judged & ~fits.to_numpy()]),
                    "steer": steer,
                    "steer_misses": int(steer_bad.sum()),
                    "steer_coverage": float(1.0 - steer_bad.sum() / simulated),
                    **{f"steer_fails_{r}": int(steer_why[r].sum()) for r in STEER_REASONS},
                    "start_rise_median": float(np.median(start["motors.drive_start_rise"])),
                    "residual_K": residual,
                    "runs": runs,
                    "hot_runs": ran,  # the variants its hot run ran for (-1: all; else the closed form's rest)
                    "battery_over": int(over.sum()),  # judged runs past the battery's energy or power
                }
            )
            detail[name] = pd.concat(
                [
                    servo[list(spec.params)],
                    res,
                    why.add_prefix("fails_"),
                    steer_why.add_prefix("steer_fails_"),
                    where.rename("where"),
                    pd.Series(judged, name="judged"),
                    pd.Series(over, name="battery_over"),
                ],
                axis=1,
            )
            if fits[judged].sum() / counted >= share and best is None:
                best = name
                if stop_at_first:
                    return best, pd.DataFrame(rows), detail
    return best, pd.DataFrame(rows), detail


def not_simulated(res: pd.DataFrame) -> np.ndarray:
    """Per variant of an in-the-loop result, whether its run says nothing of the motors: it diverged, or failed a
    physics check (`motor_status` unstable) with its steering held. A run whose steering lost its angle (more
    than STEER_LOST_DEG off) and then failed a check is the steering's miss, not a lost run: the wheel whipped
    round by its steering is what the check caught (a drive's torque above its bound: `implicitfast`'s back-EMF
    damping at the end-of-step speed of a wheel slowed hard within one step; docs/motors.md)."""
    diverged = res["status_code"].to_numpy() == 1
    steer_lost = res["steer_track_err_deg"].to_numpy() > STEER_LOST_DEG
    return diverged | ((res["motor_status"] == "unstable").to_numpy() & ~steer_lost)


def in_loop_lines(table: pd.DataFrame) -> list[str]:
    """One line per candidate of an `in_loop` table: its coverage over the variants simulated, the counted
    reasons its misses fail for, and, apart, the variants that could not be simulated (never a reason)."""
    lines = []
    for _, row in table.iterrows():
        fails = ", ".join(f"{r} {int(row[f'fails_{r}'])}" for r in IN_LOOP_REASONS if row[f"fails_{r}"])
        line = f"{row['motor']}: covers {row['coverage']:.1%}" + (f"; fails: {fails}" if fails else "")
        if row.get("steer_misses", 0):
            why = ", ".join(f"{r} {int(row[f'steer_fails_{r}'])}" for r in STEER_REASONS if row[f"steer_fails_{r}"])
            line += f"; the steering ({row['steer']}) missed {int(row['steer_misses'])}, not counted: {why}"
        if row.get("not_simulated", 0):
            k = int(row["not_simulated"])
            line += f"; {k} variant{'s' * (k > 1)} could not be simulated: {row['not_simulated_why']}"
        lines.append(line)
    return lines


def _first_segment_above(servo: pd.DataFrame, speed: float) -> pd.Series:
    """Per variant of a mission's servo run, the first segment whose peak wheel speed (rad/s) passes `speed`;
    "" where none does, and for a run that is no mission."""
    out = pd.Series("", index=servo.index, dtype=object)
    for seg in mission_segments(servo):
        over = servo[[f"{seg}_{m}_speed_peak" for m in WHEELS]].abs().max(axis=1).to_numpy(float) > speed
        out[over & (out == "").to_numpy()] = seg
    return out


def segment_shortfall(servo: pd.DataFrame, res: pd.DataFrame) -> pd.Series:
    """Per variant of a mission run in the loop, the first segment whose distance falls more than SHORT_SHARE
    short of the servo's over the same segment (the motor could not keep the cycle's pace there: its steady
    window alone does not say, a mission's window being one part of the cycle); "" where none does, and for a
    run that is no mission. Segments the servo moves less than 0.05 m in (a stop, a steer in place) are not read."""
    out = pd.Series("", index=res.index, dtype=object)
    for seg in mission_segments(res) if mission_segments(servo) else []:
        want, got = servo[f"{seg}_distance"].to_numpy(float), res[f"{seg}_distance"].to_numpy(float)
        short = (want > 0.05) & (got < (1 - SHORT_SHARE) * want) & (out == "").to_numpy()
        out[short] = seg
    return out


def _in_loop_reasons(
    res: pd.DataFrame,
    motor: Any,
    c: dict,
    battery: Battery | None,
    limited: float,
    duty: float = 1.0,
    speed: Any = None,
    behind: Any = False,
) -> pd.DataFrame:
    """Per variant of an in-the-loop result, each REASONS entry for its drives (True = fails); `speed`: the
    servo's mean wheel speed per variant (rad/s; default: the loop's own); `behind`: short of the servo's pace in
    a mission's segment (`segment_shortfall`), counted as short as the steady window's shortfall is."""
    short = res["motor_status"].isin(["short", "stalled"]).to_numpy() | np.asarray(behind, bool)
    v_share = res[[f"{m}_at_voltage_share" for m in WHEELS]].max(axis=1).to_numpy()
    i_share = res[[f"{m}_at_current_share" for m in WHEELS]].max(axis=1).to_numpy()
    at_v, at_i = v_share > limited, i_share > limited
    out = _rms_and_heat(res, WHEELS, c, duty)
    out["voltage"] = short & at_v & (v_share > i_share)  # the limit it spent longer at
    out["peak"] = short & at_i & (i_share >= v_share)
    wanted = np.abs(np.asarray(res["wheel_speed"] if speed is None else speed, float))
    out["speed"] = wanted * c["N"] > c["V"] / c["K"]
    out["gear_torque"] = _gear_torque(res, WHEELS, motor)
    speed = res["wheel_speed"].abs().to_numpy() * c["N"]
    out["gear_speed"] = speed > motor.gear_max_input_speed if motor.gear_max_input_speed is not None else False
    energy = np.zeros(len(res), bool)
    if battery is not None:
        energy |= res["bus_energy_wh"].to_numpy() > battery.energy_wh
        energy |= res["bus_power_peak"].to_numpy() > battery.max_power
    out["energy"] = energy
    out["tracking"] = short & ~at_v & ~at_i
    return out[list(REASONS)]


def _rms_and_heat(res: pd.DataFrame, names: tuple[str, ...], c: dict, duty: float) -> pd.DataFrame:
    """Per variant, `rms` (the motors' largest RMS current at the duty above i_max: a duty cycle's over the whole
    cycle, else the steady window's) and `thermal` (a winding's peak above its maximum), for the motors `names`."""
    cycle = "mission_" if f"mission_{names[0]}_current_rms" in res else ""
    out = pd.DataFrame(index=res.index)
    i_rms = np.sqrt(duty) * res[[f"{cycle}{m}_current_rms" for m in names]].max(axis=1).to_numpy()
    out["rms"] = i_rms > c["i_max"] if c["i_max"] > 0 else False
    out["thermal"] = res[[f"{m}_winding_temp_peak" for m in names]].max(axis=1).to_numpy() > c["T_max"]
    return out


def _gear_torque(res: pd.DataFrame, names: tuple[str, ...], motor: Any) -> np.ndarray:
    """Per variant, whether a motor of `names` exceeds its gearhead's continuous (RMS) or intermittent (low-pass
    peak) torque rating."""
    gear = np.zeros(len(res), bool)
    if motor.gear_max_continuous_torque is not None:
        gear |= res[[f"{m}_rms" for m in names]].abs().max(axis=1).to_numpy() > motor.gear_max_continuous_torque
    if motor.gear_max_intermittent_torque is not None:
        peak = res[[f"{m}_peak_lp_all" for m in names]].abs().max(axis=1).to_numpy()
        gear |= peak > motor.gear_max_intermittent_torque
    return gear


def steer_reasons(res: pd.DataFrame, motor: Any, c: dict, duty: float = 1.0) -> pd.DataFrame:
    """Per variant of an in-the-loop result, each STEER_REASONS entry for its steering motors (True = fails)."""
    names = GROUPS["steer"]
    out = _rms_and_heat(res, names, c, duty)
    out["voltage"] = res[[f"{m}_at_voltage_share" for m in names]].max(axis=1).to_numpy() > STEER_LIMIT_SHARE
    out["peak"] = res[[f"{m}_at_current_share" for m in names]].max(axis=1).to_numpy() > STEER_LIMIT_SHARE
    out["gear_torque"] = _gear_torque(res, names, motor)
    out["lost"] = res["steer_track_err_deg"].to_numpy() > STEER_LOST_DEG
    return out[list(STEER_REASONS)]
