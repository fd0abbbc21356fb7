"""The loop: the screen's survivors run as MuJoCo dcmotors on the servo sweep's variants, batched, from the hot
steady state of back-to-back runs (`in_loop`, worded by `in_loop_lines`; the reasons: IN_LOOP_REASONS for the
drives, STEER_REASONS for the steering, and DIFFER where the screen and the loop read a reason differently). The
hot start's closed forms are `batchveh.sizing.thermal`'s."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from batchveh.analysis.demand import GROUPS, WHEELS, group_rises
from batchveh.analysis.demand import groups as layout_groups
from batchveh.config import ConfigError
from batchveh.model.battery import Battery
from batchveh.sizing.screening import REASONS, _limiting, _where, bound_at_wheel, mission_segments
from batchveh.sizing.thermal import _hot_start, _without_gains, closed_form, hot_columns
from batchveh.stepping.motor_stats import SHORT_SHARE  # a window's mean speed this far below the imposed: short

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


def _steering(cat: dict[str, Any], steer: str | None) -> Any:
    """The steering motor `steer` of the catalogue, or vehicle.HUB_LOCK where there is none (a skid layout)."""
    from batchveh.model.vehicle import HUB_LOCK

    return HUB_LOCK if steer is None else cat[steer]


def best_in_loop(table: pd.DataFrame) -> str | None:
    """The motor of an `in_loop` table with the highest coverage (the last run of equals); None for no rows."""
    return str(table.sort_values("coverage", kind="stable")["motor"].iloc[-1]) if len(table) else None


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
        spec.vehicle.motors, model="dcmotor", catalogue=str(catalogue), drive=batch[0], steer=steer or "",
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
    rises_of = group_rises(spec.vehicle.steering.layout)  # each group's windings: a fixed hub's slot is none
    keys = tuple(rises_of)
    steer_c = _steering(cat, steer).resolved(steer or "steer")
    consts = [dict(zip(keys, (cat[b].resolved(b), steer_c), strict=False)) for b in batch]
    start = [{key: np.zeros(n) for key in keys} for _ in batch]
    ran, parts = [-1] * k, []
    for r in range(runs):
        rises = {key: np.concatenate([s[key] for s in start]) for key in keys}
        if closed and r == 1:  # the hot run from the cold one, run only where the closed form cannot say
            hot = [hot_columns(res, s, c, battery, rises_of) for res, s, c in zip(parts, start, consts, strict=True)]
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
                key: (res[[f"{m}_winding_temp_end" for m in rises_of[key]]].max(axis=1).to_numpy() - c[key]["T_amb"])
                * (np.exp(-rest / c[key]["t_T"]) if c[key]["t_T"] > 0 else 0.0)
                for key in keys
            }
            residual.append(max(float(np.max(np.abs(end[key] - s[key]))) for key in keys))
        if r < runs - 1:  # the next start: the back-to-back fixed point, in closed form from this run
            start = [
                {key: _hot_start(res, rises_of[key], c[key], s[key], heated, rest) for key in keys}
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
    steer: str | None,
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
    `steer`: the catalogue name of the steering motors (None on a skid-steered vehicle: no hub steers, each held
    by vehicle.HUB_LOCK; with the front layout the rear hubs are too, and only the steered hubs' motors are judged:
    `steer_reasons`). A name not in the catalogue is one ConfigError line
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

    if not 0 < share <= 1:
        raise ConfigError(f"share: {share!r} is not allowed; allowed: 0 < share <= 1")
    if isinstance(spec, str | Path):  # the YAML's path, not the spec: read it as batchveh.load_spec does
        from batchveh.sweeping.spec import load_spec

        spec = load_spec(spec)
    cat = load_catalogue(catalogue)
    if steer is not None:
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
    steer_names = layout_groups(spec.vehicle.steering.layout)["steer"]  # the steered hubs' motors
    steer_motor = _steering(cat, steer)
    cs = steer_motor.resolved(steer or "steer")
    # stop_at_first: one candidate at a time, none run past the first that covers; else as few batches as fit
    groups = [[name] for name in candidates] if stop_at_first else batches(cat, list(candidates))
    for batch in groups:
        hot = _hot_runs(spec, servo, catalogue, cat, batch, steer, runs, duty, run, battery, closed)
        for name, (res, start, residual, ran) in zip(batch, hot, strict=True):
            c = cat[name].resolved(name)
            verdict = _judge(servo, res, cat[name], c, steer_motor, cs, battery, battery_apart, duty, steer_names)
            rows.append(_row(name, c, steer, verdict, start, residual, runs, ran))
            detail[name] = _detail(servo[list(spec.params)], res, verdict)
            if verdict.coverage() >= share and best is None:
                best = name
                if stop_at_first:
                    return best, pd.DataFrame(rows), detail
    return best, pd.DataFrame(rows), detail


@dataclass(frozen=True)
class _Verdict:
    """One candidate's verdicts on its run in the loop (`_judge`), per variant: its drives' reasons `why` and its
    steering's `steer_why` (True = fails), the span and reason it fails for first (`where`), whether its run could
    not be simulated (`lost`), whether its drive is judged (`judged`: simulated, its steering held) and whether the
    run passed the battery's energy or power (`over`); `why_lost`: the lost runs' causes, counted."""

    why: pd.DataFrame
    steer_why: pd.DataFrame
    where: pd.Series
    lost: np.ndarray
    judged: np.ndarray
    over: np.ndarray
    why_lost: pd.Series

    def fits(self) -> pd.Series:
        return ~self.why.any(axis=1)

    def coverage(self) -> Any:
        """The share of the judged variants the drive covers (0 where none is judged)."""
        return self.fits()[self.judged].sum() / max(int(self.judged.sum()), 1)


def _judge(
    servo: pd.DataFrame,
    res: pd.DataFrame,
    motor: Any,
    c: dict,
    steer_motor: Any,
    cs: dict,
    battery: Battery | None,
    battery_apart: bool,
    duty: float,
    steer_names: tuple[str, ...] = GROUPS["steer"],
) -> _Verdict:
    """A candidate's verdicts on its run in the loop `res` (a row per row of the servo's run `servo`, in order):
    its drives' reasons (`_in_loop_reasons`; the battery's `energy` given apart with `battery_apart`), where each
    variant fails first, its steering's reasons (`steer_reasons`), and which runs are judged. `c`, `cs`: the drive's
    and the steering's resolved constants."""
    from batchveh.stepping.motor_stats import LIMITED_SHARE

    # a variant whose run failed a physics check (or diverged) says nothing of the motor: apart, never a reason
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
    # named by a mission's segment it fell behind in, or whose servo speed passed the no-load speed (as the screen
    # names it); else the cycle's ("mission"), or a straight line's window
    fast = _first_segment_above(servo, c["V"] / (c["K"] * c["N"]))
    span = behind.where(behind != "", fast.where(why["speed"], ""))
    where = _where(why, span.where(span != "", "mission" if cycle[0] in servo else "window"))
    why.loc[lost, :] = False
    steer_why = steer_reasons(res, steer_motor, cs, duty, steer_names)
    steer_why.loc[lost, :] = False
    judged = ~lost & ~steer_why.any(axis=1).to_numpy()  # the drive is judged where simulated and its steering held
    over &= judged
    return _Verdict(why, steer_why, where, lost, judged, over, why_lost)


def _row(name: str, c: dict, steer: str, v: _Verdict, start: dict, residual: float, runs: int, ran: int) -> dict:
    """A candidate's row of the `in_loop` table, from its verdicts `v` and its hot runs (`_hot_runs`: the start
    rises, the residual, the variants its hot run ran for)."""
    fits = v.fits()
    steer_bad = v.steer_why.any(axis=1).to_numpy()
    simulated = max(int((~v.lost).sum()), 1)
    return {
        "motor": name,
        "gear_ratio": c["N"],
        "continuous_torque_at_wheel": bound_at_wheel(c, np.nan),
        "coverage": float(v.coverage()),
        "judged": int(v.judged.sum()),  # the variants the drive's coverage is over: simulated, steering held
        "not_simulated": int(v.lost.sum()),
        "not_simulated_why": ", ".join(f"{n} {k}" for k, n in v.why_lost.items()),
        **{f"fails_{r}": int(v.why[r].to_numpy()[v.judged].sum()) for r in IN_LOOP_REASONS},
        "limiting": _limiting(v.where[v.judged & ~fits.to_numpy()]),
        "steer": steer,
        "steer_misses": int(steer_bad.sum()),
        "steer_coverage": float(1.0 - steer_bad.sum() / simulated),
        **{f"steer_fails_{r}": int(v.steer_why[r].sum()) for r in STEER_REASONS},
        "start_rise_median": float(np.median(start["motors.drive_start_rise"])),
        "residual_K": residual,
        "runs": runs,
        "hot_runs": ran,  # the variants its hot run ran for (-1: all; else the closed form's rest)
        "battery_over": int(v.over.sum()),  # judged runs past the battery's energy or power
    }


def _detail(params: pd.DataFrame, res: pd.DataFrame, v: _Verdict) -> pd.DataFrame:
    """A candidate's detail table: each variant's parameters `params`, its columns in the loop `res`, its reasons
    (fails_<reason>, steer_fails_<reason>), `where`, `judged` and `battery_over`."""
    return pd.concat(
        [
            params,
            res,
            v.why.add_prefix("fails_"),
            v.steer_why.add_prefix("steer_fails_"),
            v.where.rename("where"),
            pd.Series(v.judged, name="judged"),
            pd.Series(v.over, name="battery_over"),
        ],
        axis=1,
    )


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


def steer_reasons(
    res: pd.DataFrame, motor: Any, c: dict, duty: float = 1.0, names: tuple[str, ...] = GROUPS["steer"]
) -> pd.DataFrame:
    """Per variant of an in-the-loop result, each STEER_REASONS entry for its steering motors `names` (the steered
    hubs', `analysis.demand.groups`; a fixed hub's slot carries its mounting's moment, no motor's: never read;
    none on a skid-steered vehicle: nothing fails) (True = fails)."""
    if not names:
        return pd.DataFrame(False, index=res.index, columns=list(STEER_REASONS))
    out = _rms_and_heat(res, names, c, duty)
    out["voltage"] = res[[f"{m}_at_voltage_share" for m in names]].max(axis=1).to_numpy() > STEER_LIMIT_SHARE
    out["peak"] = res[[f"{m}_at_current_share" for m in names]].max(axis=1).to_numpy() > STEER_LIMIT_SHARE
    out["gear_torque"] = _gear_torque(res, names, motor)
    out["lost"] = res["steer_track_err_deg"].to_numpy() > STEER_LOST_DEG
    return out[list(STEER_REASONS)]
