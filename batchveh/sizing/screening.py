"""The screen: closed-form verdicts per (motor, ratio) and variant on a servo sweep's demand, with no new
simulation (`screen`, `screen_one`; the reasons: REASONS, REASON_TEXT): a straight line's ramp (`ramp_shortfall`)
and a duty cycle's segments (`mission_segments`, `segment_ramp`) included."""

from __future__ import annotations

import functools
import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import pandas as pd

from batchveh.analysis.demand import GROUPS, demand, groups
from batchveh.config import ConfigError
from batchveh.stepping.motor_stats import SHORT_SHARE  # a window's mean speed this far below the imposed: short

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


THRESHOLD_GRID = 512  # the candidates of each round of `ramp_threshold`'s search
THRESHOLD_ROUNDS = 4  # rounds: the threshold within (its bracket / THRESHOLD_GRID) ** 4, about 1e-11 of it
MANY_RAMPS = 64  # more distinct (ramp time, window) pairs than this: the stepped model per variant instead


@functools.lru_cache(maxsize=256)
def ramp_threshold(ramp_time: float, window: tuple[float, float], law: str, share: float) -> float:
    """The bounded acceleration, as a share of the ramp's mean (a_max T / speed), at which `ramp_shortfall` falls to
    `share`: below it the wheel falls more than `share` behind. The stepped model scales exactly with speed (its
    grid is the window's, its steps a_max dt): its shortfall is a function of a_max T / speed, the window over T
    and the law alone, and it falls as a_max grows. Found by searching that function on grids of THRESHOLD_GRID
    candidates, THRESHOLD_ROUNDS rounds, each within the bracket of the last; inf where even the law's peak
    acceleration leaves the wheel `share` behind (it never does: at the peak it is on speed), 0 where none does."""
    lo, hi = 1e-6, 1e3
    for _ in range(THRESHOLD_ROUNDS):
        alphas = np.geomspace(lo, hi, THRESHOLD_GRID)
        short = ramp_shortfall(
            np.ones(THRESHOLD_GRID), np.full(THRESHOLD_GRID, ramp_time), window, alphas / ramp_time, law
        )
        over = np.flatnonzero(short > share)
        if not len(over):
            return 0.0 if lo == 1e-6 else lo
        k = over[-1]  # the largest candidate still short
        if k == THRESHOLD_GRID - 1:
            return hi
        lo, hi = alphas[k], alphas[k + 1]
    return float(hi)


def ramp_short(speed: Any, ramp_time: Any, window: tuple[float, float], a_max: Any, law: str, share: float):
    """Per variant, whether `ramp_shortfall` exceeds `share`: a_max below `ramp_threshold` x speed / ramp time, the
    threshold found once per distinct ramp time (the stepped model per variant where they are more than
    MANY_RAMPS). The same verdicts as the stepped model's but at its threshold's last digits, in a comparison per
    variant instead of RAMP_STEPS steps: the screen of every (motor, ratio) of a catalogue at 100,000 conditions."""
    speed, ramp_time, a_max = np.broadcast_arrays(*(np.asarray(x, float) for x in (speed, ramp_time, a_max)))
    times = np.unique(ramp_time)
    if len(times) > MANY_RAMPS:
        return ramp_shortfall(speed, ramp_time, window, a_max, law) > share
    alpha = np.empty(speed.shape)
    for t in times:
        alpha[ramp_time == t] = ramp_threshold(float(t), tuple(float(x) for x in window), law, float(share))
    mean = np.abs(speed) / np.maximum(ramp_time, 1e-12)
    return a_max < alpha * mean


def shares(need: pd.DataFrame, what: str, grip: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """What `_can_share` reads of the demand whatever the motor: each wheel's `what` (n, 4), over the friction the
    wheels use where `grip` is given, and the four wheels' sum (less a rounding margin). `screen` makes it once for
    all its motors."""
    t = np.stack([need[f"{what}_{j}"].to_numpy(float) for j in range(4)], axis=-1)
    total = t.sum(axis=-1)
    if grip is not None:
        used = total / np.maximum(np.asarray(grip, float), 1e-12)
        t = t / np.maximum(used, 1e-12)[:, None]
    return t, total * (1 - 1e-12)


def _can_share(need: pd.DataFrame, what: str, bound: float, grip: Any = None, pre: dict | None = None) -> pd.Series:
    """Per variant, whether the four drives can give the four wheels' `what` (`rms` or `peak_window`) together
    with each at most `bound` and at most its grip: sum_j min(bound, T_j / u) >= sum_j T_j, where u = sum_j T_j /
    grip is the friction the wheels use (each wheel's grip T_j / u: the slip tyre's force is its load times one
    common slip, so each wheel's torque is its share of the load); without `grip`, sum_j min(bound, T_j) = the
    mean within the bound."""
    t, total = shares(need, what, grip) if pre is None else pre[what]
    if grip is None:
        return pd.Series(np.full(t.shape, bound).sum(axis=-1) >= total, index=need.index)
    return pd.Series(np.minimum(bound, t).sum(axis=-1) >= total, index=need.index)


def screen_one(
    need: pd.DataFrame,
    motor: Any,
    *,
    armature: float = 0.0,
    accel: Any = 0.0,
    duty: float = 1.0,
    ramp: dict[str, Any] | None = None,
    pre: dict[str, Any] | None = None,
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
    Where they cannot, the worst wheel is judged on its own. `pre`: `shares` of `need` for both (`rms`,
    `peak_window`), made once by `screen` for all its motors (None: made here)."""
    from batchveh.model.motors import COPPER_TEMPCOEF, REFERENCE_TEMP

    c = motor.resolved()
    n, eta, k, r = c["N"], c["eta"], c["K"], c["R"]
    bound = bound_at_wheel(c)
    peak = need["peak"] + np.maximum(c["J"] * n * n - armature, 0.0) * np.abs(accel)
    window = need["peak_window"] if "peak_window" in need else need["peak"]
    rms = need["rms"]
    if "rms_mean" in need:  # drives: the four share what one clipped wheel cannot give
        grip = None if ramp is None else ramp.get("grip")
        shared = _can_share(need, "rms", bound, grip, pre) & _can_share(need, "peak_window", bound, grip, pre)
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
        out["peak"] |= ramp_short(ramp["speed"], ramp["ramp_time"], ramp["window"], a_max, ramp["law"], SHORT_SHARE)
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
    detail: bool = True,
    layout: str = "four_wheel",
) -> tuple[str | None, pd.DataFrame, dict[str, pd.DataFrame]]:
    """The fast screen of a sweep's ideal-servo demand against DC motors with their gearheads.

    `df`: the rows of a servo sweep (`batchveh.load(folder)`); `catalogue`: {name: DCMotor}, as
    `batchveh.load_catalogue(path)` returns it. Each variant's demand is `demand(df, group, span, layout)`: on the
    worst of the group's motors ('drive': the four; 'steer': those of the hubs that steer on the vehicle's
    steering `layout`, never a fixed hub's mounting moment), the steady window's RMS, the whole run's
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
      reason (True = fails) and `where`, the span (a mission's segment) and reason it fails for first.
    `detail` False: the table's counts alone (its `limiting` empty, no `failing`): the screen of every (motor, ratio)
    of a catalogue, whose rows of interest are screened again with it."""
    if not 0 < share <= 1:
        raise ConfigError(f"share: {share!r} is not allowed; allowed: 0 < share <= 1")
    need = demand(df, group, span, layout)
    names = groups(layout)[group]
    if params is None:
        from batchveh.model.params import parameter_specs

        params = [col for col in df.columns if col in parameter_specs()]
    keep = list(params)
    segments = mission_segments(df) if span == "mission" else []
    counted = np.ones(len(df), bool) if judged is None else np.asarray(judged, bool)

    straight_ramp = ramp if ramp is not None and "segments" not in ramp else None
    grip = None if straight_ramp is None else straight_ramp.get("grip")
    # what the four drives share, whatever the motor: once for all of them (`shares`)
    pre = {what: shares(need, what, grip) for what in ("rms", "peak_window")} if "rms_mean" in need else None

    def one(name: str, motor: Any) -> tuple[dict, pd.DataFrame]:
        c = motor.resolved(name)
        cycle = ramp if ramp is not None and "segments" in ramp else None  # a duty cycle's: its segments'
        straight = None if cycle is not None else ramp
        res = screen_one(need, motor, armature=armature, accel=accel, duty=duty, ramp=straight, pre=pre)
        if span not in (None, "mission") and f"{span}_{names[0]}_drive_peak_lp" in df:  # one segment: its
            res["voltage"] = _segment_voltage(df, names, span, c) > c["V"]  # voltage as the mission's segments read it
            res["fits"] = ~res[list(REASONS)].any(axis=1)
        where = _segments(df, group, segments, motor, res, cycle, layout) if segments else None
        if detail and where is None:
            where = _where(res, span or "window")
        row = {
            "motor": name,
            "gear_ratio": c["N"],
            "continuous_torque_at_wheel": bound_at_wheel(c, np.nan),
            "coverage": float(res["fits"].to_numpy()[counted].mean()) if counted.any() else 0.0,
            "judged": int(counted.sum()),
            **{f"fails_{why}": int(res[why].to_numpy()[counted].sum()) for why in REASONS},
            "limiting": _limiting(where[~res["fits"] & counted]) if detail else "",
        }
        if not detail:
            return row, None
        bad = ~res["fits"] & counted
        return row, pd.concat([df.loc[bad, keep], res.loc[bad, list(REASONS)], where[bad].rename("where")], axis=1)

    # the motors in threads: numpy lets go of the GIL in its array loops, which are most of a motor's screen
    # (100,000 rows, 10 motors: 1.3 s in one thread on 2 cores)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    with ThreadPoolExecutor(max(1, min(len(catalogue), cores))) as pool:  # the cores this process may use
        done = list(pool.map(one, catalogue, catalogue.values()))
    rows = [row for row, _ in done]
    failing = {name: bad for name, (_, bad) in zip(catalogue, done, strict=True)} if detail else {}
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
    df: pd.DataFrame,
    group: str,
    segments: list[str],
    motor: Any,
    res: pd.DataFrame,
    ramp: dict | None = None,
    layout: str = "four_wheel",
) -> pd.Series:
    """A mission's duty cycle on the screen: each segment's own demand (its RMS, low-pass peak and peak speed)
    against the motor's instantaneous limits (INSTANT: a climb at speed is a point on the torque-speed plane,
    not an average; and the gearhead's intermittent rating), ORed into `res` in place; the cycle's RMS and heat
    stay the whole mission's. Per variant, the first segment and reason it fails for ("seg3_climb: voltage at
    16.5 rad/s"), or the cycle's ("mission: thermal"); "" where it fits. `layout`: the steering layout, whose
    steering group is its steered hubs' motors (`demand`)."""
    c = motor.resolved()
    names = groups(layout)[group]
    bound = bound_at_wheel(c)
    where = pd.Series("", index=res.index, dtype=object)
    wheel_by_wheel = f"{segments[0]}_{names[0]}_drive_peak_lp" in df if segments else False
    if wheel_by_wheel:  # the voltage is each segment's (below), not the cycle's peak torque at its peak speed
        res["voltage"] = False
    # the cycle's peak is its segments' largest: each segment judges its own (an accelerating one with its ramp)
    res["peak"] = False
    for seg in segments:
        need = demand(df, group, seg, layout)
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
            got["voltage"] = _segment_voltage(df, names, seg, c) > c["V"]
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


def _segment_voltage(df: pd.DataFrame, names: tuple[str, ...], seg: str, c: dict[str, float]) -> np.ndarray:
    """Per variant, the largest terminal voltage a segment asks of one of a group's motors `names` (the drives, or
    the steered hubs' steering motors): each wheel's peak
    low-pass torque while it drives (a braking torque needs less voltage, not more), at most the bound, with that
    wheel's own peak speed: i R + K N w, the largest over the wheels. Still an upper bound (the two peaks need not
    fall at one instant), but it no longer pairs one wheel's torque with another's speed, or a stop's braking with
    the speed it brakes from. Counted as the loop counts a voltage miss: a drive at its voltage line is short only
    where it falls more than SHORT_SHARE behind its speed (`segment_shortfall`), so a drive's speed is taken
    SHORT_SHARE below the peak (a steering motor's at its peak: the loop judges it on its time at the line)."""
    bound = bound_at_wheel(c)
    forgiven = SHORT_SHARE if names == GROUPS["drive"] else 0.0
    out = np.zeros(len(df))
    for m in names:
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
