"""Size the drive motors of a sweep in one command: from a vehicle spec and a motor catalogue to the motor to buy.

    python -m batchveh.size sweeps/delivery_robot.yaml --catalogue notebooks/motors.yaml
    python -m batchveh.size sweeps/slope.yaml --catalogue notebooks/motors.yaml --limit 500 --share 0.99 --out S
    python -m batchveh.size sweeps/slope.yaml --catalogue notebooks/motors.yaml --dry-run

Three phases, one progress bar:
1. the sweep with the ideal servo (the demand), in OUT/servo: reused where it is there and was made from the
   same spec (the sweep's resume), else run;
2. the screen: every catalogue motor against that demand (`batchveh.analysis.motors.screen`), for the drives
   and, unless --steer names one, for the steering; a straight line on its steady window, a mission on its whole
   cycle and each segment (--span picks one segment);
3. in the loop (`in_loop`): the screen's choice (and the next smaller motor where its screen lies within 5
   points of --share), then larger ones, smallest first, as DC motors driven by batchveh's drive, from the hot
   steady state of the run repeated (the spec's `duty`: the share of the time it runs, 1 for back to back), until
   one covers --share of the variants it could simulate. The candidates run as one batch (`batch_of`), each run a
   sweep of its own in OUT/loop/<digest of its inputs> (`sweep_runner`): --executor gpus or ray spreads it, and a
   session killed and started again reads back every finished chunk.
   Each run also confirms the steering motor: where the steering misses more than 1 - share of the variants on
   its own criteria (STEER_REASONS: lost its angle, at its current limit or voltage line for more than 5% of the
   run, RMS, heat, gearhead), the next larger steering motor runs with the same drive. A steering miss is never
   counted against a drive.
It ends with one line: the chosen motor and gearhead, its coverage, and where the report is (OUT/report.html,
report.md, figures/, verdicts.parquet: batchveh/sizing/report.py).

Exit codes: 0 done (a motor chosen, or none covers: the report says why), 2 bad spec, catalogue, argument or file
(one line), 3 a report exists in OUT (give --overwrite), 130 interrupted.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path
from typing import Any

from batchveh.cli import run_main
from batchveh.config import ConfigError, OneLineParser

EXIT_OK, EXIT_INPUT, EXIT_EXISTS, EXIT_INTERRUPTED = 0, 2, 3, 130
NEAR = 0.05  # without a screen choice, the loop runs the motors within 5 points of the best screen coverage
BATCH = 2  # the loop's drives per batch where the screen cannot say which covers (`batch_of`)
HOT_RUNS = 2  # in_loop's runs per candidate (`iterations` 1): from ambient, then from the hot start in closed form


def loop_runs(spec: Any) -> int:
    """The runs of every condition a candidate takes in the loop: one where its hot run comes in closed form from
    it (`analysis.motors.closed_form`: a straight line; run again only for the conditions it cannot say), else
    HOT_RUNS."""
    from batchveh.analysis.motors import closed_form

    return 1 if closed_form(spec) else HOT_RUNS


def servo_spec(spec: Any, out: Path) -> Any:
    """The spec with the ideal servo (the demand) writing to out/servo."""
    motors = dataclasses.replace(spec.vehicle.motors, model="servo")
    return dataclasses.replace(
        spec, vehicle=dataclasses.replace(spec.vehicle, motors=motors), output=str(out / "servo")
    )


def catalogue_of(path: str) -> dict[str, Any]:
    """The catalogue's motors (one ConfigError line for a missing file, a bad entry or none at all)."""
    from batchveh.model.motors import load_catalogue

    if not Path(path).is_file():
        raise ConfigError(
            f"--catalogue: {path}: file not found; allowed: a motor catalogue YAML (notebooks/motors.yaml)"
        )
    cat = load_catalogue(path)
    if not cat:
        raise ConfigError(f"--catalogue: {path}: motors: no motor; allowed: a list of datasheet motors under motors:")
    return cat


def battery_of(path: str) -> Any:
    """The catalogue's battery, or None where it has no `battery:` section (one that is there and wrong is a
    ConfigError line, as the rest of the catalogue's)."""
    from batchveh.analysis.motors import load_battery
    from batchveh.config import load_yaml

    data = load_yaml(path)
    return load_battery(path) if isinstance(data, dict) and "battery" in data else None


def _column(df: Any, name: str, default: float) -> Any:
    """A swept parameter's values per row of `df`, or its fixed value where it was not swept."""
    import numpy as np

    return df[name].to_numpy(float) if name in df else np.full(len(df), float(default))


def wheel_accel(spec: Any, df: Any) -> Any:
    """Each variant's imposed wheel acceleration over its speed ramp (rad/s^2), for the screen's rotor inertia:
    speed / (radius x ramp time), where the scenario has both; else 0."""
    import numpy as np

    sc = spec.scenario
    if not hasattr(sc, "speed_kmh") or not getattr(sc, "ramp_time", 0):
        return 0.0
    ramp = np.maximum(_column(df, "ramp_time", sc.ramp_time), 1e-9)
    return _column(df, "speed_kmh", sc.speed_kmh) / 3.6 / _column(df, "wheel.radius", spec.vehicle.wheel.radius) / ramp


def ramp_of(spec: Any, df: Any) -> dict[str, Any] | None:
    """The straight line's ramp for the screen (`motors.screen_one`'s `ramp`), each variant's own: the imposed
    wheel speed (rad/s), what each drive accelerates without its rotor (kg m^2: a quarter of the vehicle's mass,
    the payload's with it, at the wheel's radius, and the wheel as a solid disc), the ramp time, the window, the
    drive law, and the four wheels' grip at the wheel, mu M g cos(slope) r (N m); None for a scenario without a
    speed ramp (a mission, a steer in place)."""
    import numpy as np

    sc = spec.scenario
    if sc.kind == "mission":
        return mission_ramp(spec, df)
    if sc.kind != "straight_line" or not getattr(sc, "ramp_time", 0):
        return None
    v = spec.vehicle

    def col(name: str, default: float) -> Any:
        return _column(df, name, default)

    radius = col("wheel.radius", v.wheel.radius)
    mass = _mass(spec, df)
    total = float(sc.total_time)
    return {
        "speed": col("speed_kmh", sc.speed_kmh) / 3.6 / radius,
        "inertia": _drive_inertia(spec, df),
        "ramp_time": col("ramp_time", sc.ramp_time),
        "window": tuple(spec.window) if spec.window is not None else (total / 2, total),
        "law": sc.drive_law,
        "grip": col("friction", sc.friction)
        * mass
        * col("gravity", sc.gravity)
        * np.cos(np.deg2rad(col("slope_deg", sc.slope_deg)))
        * radius,
    }


def _mass(spec: Any, df: Any) -> Any:
    """Each variant's vehicle mass (kg): chassis, four wheels and hubs, payload."""
    v = spec.vehicle
    wheel = _column(df, "wheel.mass", v.wheel.mass)
    mass = _column(df, "chassis.mass", v.chassis.mass) + 4 * (wheel + _column(df, "hub.mass", v.hub.mass))
    return mass + _column(df, "payload.mass", v.payload.mass)


def _drive_inertia(spec: Any, df: Any) -> Any:
    """What each drive accelerates without its rotor (kg m^2, per variant): a quarter of the vehicle at the wheel's
    radius, and the wheel as a solid disc."""
    v = spec.vehicle
    radius = _column(df, "wheel.radius", v.wheel.radius)
    return _mass(spec, df) * radius**2 / 4 + 0.5 * _column(df, "wheel.mass", v.wheel.mass) * radius**2


ACCELERATING = ("accelerate",)  # a duty cycle's segments the screen's ramp model reads (`segment_ramp`)
CARRIES_SPEED = ("accelerate", "cruise", "climb")  # segments that end at their own speed (else from standstill)
STANDING = ("steer",)  # segments that ask the drives to hold their wheels still while the steering turns them


def mission_ramp(spec: Any, df: Any) -> dict[str, Any]:
    """A duty cycle's ramp for the screen (`analysis.motors.segment_ramp`): each accelerating segment's transition,
    duration and the span it starts from (the previous one where it ends at its speed, else None: standstill),
    the spans where the vehicle stands while it steers (`standing`: a drive's peak there is not judged), each
    variant's drive inertia (`_drive_inertia`) and the servo's armature."""
    from batchveh.model.missions import mission_of

    m = mission_of(spec.scenario)
    spans = m.spans[1:]
    segments = {}
    for k, seg in enumerate(m.segments):
        if seg.kind not in ACCELERATING:
            continue
        before = m.segments[k - 1].kind if k else None
        segments[spans[k]] = {
            "transition": m.transition(k),
            "duration": (m.boundaries[k + 1] - m.boundaries[k]) * m.dt,
            "previous": spans[k - 1] if before in CARRIES_SPEED else None,
        }
    standing = [spans[k] for k, seg in enumerate(m.segments) if seg.kind in STANDING]
    return {
        "segments": segments,
        "standing": standing,
        "inertia": _drive_inertia(spec, df),
        "armature": spec.vehicle.motors.armature,
    }


def steering(table: Any, share: float) -> str:
    """The steering motor to start the loop with: the smallest that the steering's screen (`table`, the screen of
    group 'steer', whose `peak` reason holds the demand's low-pass peak against the current's bound) passes on
    `share` of the variants; else the largest. The loop then confirms it (`size`)."""
    ok = table[table["coverage"] >= share]
    return (ok if len(ok) else table)["motor"].iloc[0 if len(ok) else -1]


def not_run(table: Any, runs: list[str], ran: list[str], chosen: str | None, best: str | None) -> dict[str, str]:
    """Why each motor of the screen's `table` did not run in the loop: {name: why}."""
    ranked = list(table["motor"])
    cover = dict(zip(table["motor"], table["coverage"], strict=True))
    out = {}
    for name in ranked:
        if name in ran:
            continue
        if chosen is not None and ranked.index(name) > ranked.index(chosen):
            out[name] = f"a smaller motor ({chosen}) covers in the loop"
        elif name not in runs and best is None:
            out[name] = f"screen {cover[name]:.1%}, more than {NEAR * 100:.0f} points below the best screen coverage"
        elif name not in runs and best is not None and ranked.index(name) == ranked.index(best) - 1:
            out[name] = (
                f"screen {cover[name]:.1%}, more than {NEAR * 100:.0f} points below the share: the loop starts at "
                f"the screen's choice ({best})"
            )
        elif name not in runs:
            out[name] = f"screen {cover[name]:.1%}: below the loop's first, the one under the screen's {best}"
        else:
            out[name] = "not reached"
    return out


def batch_of(pending: list[str], best: str | None) -> list[str]:
    """The drives of the loop's next batch (run as one sweep, `in_loop`), from `pending` (smallest first): up
    to the screen's choice `best` where it is pending (the one below it and it, as the screen expects it to
    cover), else the next BATCH of them (the screen has no choice, or the loop found it short: it cannot tell
    which covers). The loop reads the batch in order and stops at the first that covers, so its verdicts are those of
    one candidate at a time; a batch's drives after the first that covers ran for nothing."""
    return pending[: pending.index(best) + 1] if best in pending else pending[:BATCH]


def read_batch(batch: list[str], table: Any, steer: str, ranked_steer: list[str], share: float) -> dict[str, Any]:
    """A batch's loop table (`in_loop`'s, a row per drive of `batch`, in order) read as one drive at a time would
    be: each row is the steering's run (`steer_rows`); where the steering `steer` misses more than 1 - share and
    `ranked_steer` holds a larger one, the steering walks up and the batch stops there (that drive runs again with
    it); else the row is the drive's (`rows`, `judged`), and the first that covers `share` is `chosen`. `done`:
    the drives of the batch read to the end (the pending list goes on after them)."""
    out: dict[str, Any] = {"steer_rows": [], "rows": [], "judged": [], "chosen": None, "steer": steer}
    out["done"] = len(batch)
    for j, name in enumerate(batch):
        row = table.iloc[[j]].reset_index(drop=True)
        out["steer_rows"].append(row.assign(drive=name))
        larger = ranked_steer[ranked_steer.index(out["steer"]) + 1 :]
        if row["steer_coverage"].iloc[0] < share and larger:
            out["steer"], out["done"] = larger[0], j  # the steering's own miss: the next larger, from this drive
            break
        out["rows"].append(row)
        out["judged"].append(name)
        if row["coverage"].iloc[0] >= share:
            out["chosen"] = name
            break
    return out


def candidates(screen_table: Any, best: str | None, share: float | None = None) -> list[str]:
    """The motors to run in the loop, smallest first: from the one next below the screen's choice (the screen is
    conservative: the loop may take it) upwards, that one only where its screen coverage lies within NEAR of
    `share` (None: always; screen and loop agree within 2 points on every vehicle validated, so a motor the screen
    puts further below cannot cover in the loop); without a screen choice, those within NEAR of the best screen
    coverage (the loop decides between them)."""
    ranked = list(screen_table["motor"])
    cover = dict(zip(ranked, screen_table["coverage"], strict=True))
    if best is None:
        top = screen_table["coverage"].max()
        return [m for m in ranked if cover[m] >= top - NEAR]
    i = ranked.index(best)
    below = i > 0 and (share is None or cover[ranked[i - 1]] >= share - NEAR)
    return ranked[i - 1 if below else i :]


def inputs_digest(catalogue: bytes, run_spec: Any, table: dict, backend: str | None) -> str:
    """The sha256 of what a run in the loop reads: the catalogue's bytes, the vehicle, the scenario, the window,
    the filter, the spec's YAML (its solver, its precision, ...), the backend, batchveh's version and the table's
    names and values."""
    import hashlib
    import json

    import numpy as np

    import batchveh

    h = hashlib.sha256(catalogue)
    h.update(repr((run_spec.vehicle, run_spec.scenario, run_spec.window, run_spec.lowpass_s, backend)).encode())
    h.update(batchveh.__version__.encode())  # another release may model the motors otherwise
    h.update(json.dumps(run_spec.raw, sort_keys=True, default=str).encode())
    for k in sorted(table):
        h.update(k.encode())
        h.update(np.ascontiguousarray(table[k], float).tobytes())
    return h.hexdigest()


def unwritten(done: dict[str, Any], where: Path) -> None:
    """One ConfigError line where a sweep (`run_sweep`'s summary `done`, in `where`) left chunks unwritten (an
    executor's that kept failing): a sizing on fewer variants than asked would say nothing of the rest."""
    if done.get("failed"):
        chunks = ", ".join(f"{c} ({why})" for c, why in sorted(done["failed"].items()))
        raise ConfigError(f"{where}: chunks not written: {chunks}; run the command again to retry them")


def sweep_runner(folder: Path, catalogue: str, backend: str | None, executor: Any = None) -> Any:
    """The loop's Runner (`batchveh.analysis.motors.Runner`): each run a sweep of its table (method zip) in
    `folder`/<its inputs' digest>, on `backend`, through `executor(spec, n)` (a fresh executor per run, or
    None: this process), resumed where it was left: a killed session runs again only the chunks not written.
    The digest covers the table, the vehicle, the scenario, the spec's YAML, the catalogue's bytes and the
    backend, so a run whose inputs changed never reads another's results."""
    from batchveh.stepping.stats import STATUS
    from batchveh.sweep import run_sweep
    from batchveh.sweeping.results import load

    codes = {v: k for k, v in STATUS.items()}
    cat_bytes = Path(catalogue).read_bytes()

    def run(run_spec: Any, table: dict) -> Any:
        digest = inputs_digest(cat_bytes, run_spec, table, backend)
        n = len(next(iter(table.values())))
        where = folder / digest[:16]
        loop_spec = dataclasses.replace(
            run_spec,
            method="zip",
            params=dict(table),
            n=None,
            output=str(where),
            raw={
                **run_spec.raw,
                "in_loop": {
                    "inputs_sha256": digest,
                    "drive": run_spec.vehicle.motors.drive,
                    "steer": run_spec.vehicle.motors.steer,
                },
            },  # fmt: skip
        )
        try:
            done = run_sweep(
                loop_spec,
                out=where,
                backend=backend,
                resume=True,
                progress=False,
                max_variants=n,
                executor=executor(loop_spec, n) if executor is not None else None,
            )
        except ConfigError as err:  # results made with other settings (a version, a chunk size) from these inputs
            why = f"a run in the loop: remove {where}, its inputs are these, and run again"
            raise ConfigError(f"{err} ({why})") from None
        unwritten(done, where)
        run.chunks_s.append(done["wall_s"])
        res = load(where)
        if len(res) != n:
            raise ConfigError(f"{where}: {len(res)} rows for {n} variants; allowed: remove it and run again")
        res["status_code"] = res["status"].map(codes).to_numpy()
        return res.drop(columns=["variant", "status", *table])

    run.chunks_s = []  # each run's chunks' wall (s), for the command's timings
    return run


def trace(spec: Any, catalogue: str, drive: str, steer: str, values: dict[str, float], rise: float) -> Any:
    """One variant's time series on MuJoCo C with `drive` and `steer` as DC motors, its drive windings started
    `rise` above ambient: each drive's winding temperature, the bus power (W, the 8 motors) and energy (Wh), and
    each drive's torque at the wheel and its wheel's speed."""
    import numpy as np
    import pandas as pd

    from batchveh.model.params import variant_setup
    from batchveh.model.vehicle import layout
    from batchveh.stepping.batch import make_batch
    from batchveh.stepping.rollout import mujoco_steps

    motors = dataclasses.replace(
        spec.vehicle.motors, model="dcmotor", catalogue=str(catalogue), drive=drive, steer=steer, drive_start_rise=rise
    )
    vehicle, scenario = variant_setup(dataclasses.replace(spec.vehicle, motors=motors), spec.scenario, values)
    b = make_batch(vehicle, scenario, {})
    m, lay = b.model, layout(b.model)
    p = {k: float(v[0]) if np.ndim(v) == 1 else np.asarray(v[0]) for k, v in b.params.items()}
    k_eta = p["_dc.K"] * p["_dc.eta"]
    rec: dict[str, Any] = {}
    rows = []
    for i, (d, ctrl) in enumerate(mujoco_steps(m, p, scenario=scenario, n_steps=scenario.n_steps, record=rec)):
        if ctrl is None:
            continue
        current = d.actuator_force[lay.motor_act] / k_eta
        torque = d.actuator_force[lay.motor_act[:4]] * p["_dc.N"][:4]  # at the wheel
        speed = d.qvel[lay.motor_dof[:4]]
        rows.append([i * m.opt.timestep, *rec["T"][:4], float(np.sum(rec["v"] * current)), *torque, *speed])
    wheels = ("lf", "rf", "lr", "rr")
    t = pd.DataFrame(
        rows,
        columns=[
            "time",
            *(f"drive_{c}_winding_temp" for c in wheels),
            "bus_power",
            *(f"drive_{c}_torque" for c in wheels),  # at the wheel (N m)
            *(f"drive_{c}_speed" for c in wheels),  # the wheel's (rad/s)
        ],
    )
    t["bus_energy_wh"] = np.cumsum(t["bus_power"]) * m.opt.timestep / 3600.0
    return t


def size(args: Any, executor: Any = None) -> tuple[Any, dict[str, Path]]:
    """The three phases and the report (the module's docstring); returns (the Sizing, the report's paths).
    `executor(spec, n)`: a fresh executor for each sweep (the servo's and each run in the loop), or None: this
    process (`main` makes it from --executor)."""
    import platform

    import mujoco
    import numpy as np
    from tqdm.auto import tqdm

    import batchveh
    from batchveh.analysis.motors import IN_LOOP_REASONS, STEER_REASONS, best_in_loop, in_loop, screen
    from batchveh.model.motors import pick
    from batchveh.sizing import report
    from batchveh.sizing.windows import best_of, loop_table, windows, with_entry
    from batchveh.sweep import count_variants, run_sweep
    from batchveh.sweeping.results import load
    from batchveh.sweeping.spec import load_spec

    spec = load_spec(args.spec)
    cat = catalogue_of(args.catalogue)
    # the battery's energy and power are checked in the loop, apart (its limits are not a motor's); a bad
    # `battery:` section is one line here, before any simulation
    battery = battery_of(args.catalogue)
    catalogue = str(Path(args.catalogue).resolve())  # the runs read it, on Ray's workers too: a path from anywhere
    if args.steer is not None:
        pick(cat, args.steer, "--steer")
    if not 0 < args.share <= 1:
        raise ConfigError(f"--share: {args.share!r} is not allowed; allowed: 0 < share <= 1")
    out = Path(args.out or f"{spec.output}-sizing")
    if (out / "report.md").exists() and not args.overwrite:
        raise FileExistsError(f"{out} holds a report; give --overwrite to replace it (its servo sweep is reused)")
    demand = servo_spec(spec, out)
    n = count_variants(demand, args.limit)
    per = loop_runs(spec)
    bar = tqdm(total=n * (1 + per * 2), unit="run", disable=args.quiet, desc=f"{spec.name}: servo sweep")
    walls: dict[str, float] = {}
    t0 = time.perf_counter()
    try:
        servo_run = run_sweep(
            demand,
            out=out / "servo",
            backend=args.backend,
            resume=True,
            limit=args.limit,
            progress=False,
            executor=executor(demand, n) if executor is not None else None,
        )
    except ConfigError as err:
        raise ConfigError(
            f"{err} (the servo sweep's results in {out / 'servo'}: remove them or give another --out)"
        ) from None
    unwritten(servo_run, out / "servo")
    df = load(out / "servo")
    walls["servo sweep"] = time.perf_counter() - t0
    walls["servo sweep: its chunks"] = servo_run["wall_s"]  # the rest: the engine's start and the rows' load
    bar.update(n)
    bar.set_description(f"{spec.name}: screen")
    t0 = time.perf_counter()
    accel = wheel_accel(spec, df)
    armature = spec.vehicle.motors.armature
    params = list(spec.params)
    ramp = ramp_of(spec, df)
    span = args.span or ("mission" if spec.scenario.kind == "mission" else None)  # a duty cycle: the whole of it
    if span is not None and f"{span}_drive_lf_rms" not in df:
        from batchveh.analysis.motors import mission_segments

        allowed = ", ".join(["mission", *mission_segments(df)]) if "mission_drive_lf_rms" in df else "none"
        raise ConfigError(f"--span: {span!r} is not a span of {args.spec}'s results; allowed: {allowed}")
    common = {"share": args.share, "params": params, "duty": spec.duty, "span": span}
    # every (motor, ratio) of the catalogue, then each motor's window; the loop walks one ratio a motor
    _, ratios, _ = screen(df, cat, armature=armature, accel=accel, ramp=ramp, **common)
    wins = windows(ratios, cat, args.share)
    table, best = loop_table(ratios, wins), best_of(wins)
    _, steer_ratios, _ = screen(df, cat, group="steer", **common)
    steer_wins = windows(steer_ratios, cat, args.share)
    steer_table = loop_table(steer_ratios, steer_wins)
    if args.steer is not None:  # the (motor, ratio) given stands for its motor
        steer_table = with_entry(steer_table, steer_ratios, args.steer, cat)
    steer = args.steer or steering(steer_table, args.share)
    walls["screen"] = time.perf_counter() - t0
    runs = candidates(table, best, args.share)
    rows, detail, chosen, steer_rows = [], {}, None, []
    ranked_steer = list(steer_table["motor"])
    from batchveh.engines import resolve_backend

    looped = resolve_backend(args.backend or spec.backend)
    looped = "mujoco" if looped == "mjx" else looped  # MJX's JAX implementation has no dcmotor: MuJoCo C runs it
    runner = sweep_runner(out / "loop", catalogue, looped, executor)
    t0 = time.perf_counter()
    pending = list(runs)
    while pending and chosen is None:  # the drives smallest first, a batch at a time (`batch_of`)
        batch = batch_of(pending, best)
        bar.total = bar.n + n * per * len(batch)
        bar.set_description(f"{spec.name}: in the loop, {', '.join(batch)}, steering {steer}")
        bar.refresh()
        _, t, d = in_loop(
            spec, df, catalogue, batch, steer=steer, share=args.share, duty=spec.duty, stop_at_first=False,
            run=runner, battery=battery, battery_apart=True,
        )  # fmt: skip
        bar.update(n * per * len(batch))
        read = read_batch(batch, t, steer, ranked_steer if args.steer is None else [steer], args.share)
        steer_rows += read["steer_rows"]
        rows += read["rows"]
        detail.update({name: d[name] for name in read["judged"]})
        chosen, steer, pending = read["chosen"], read["steer"], pending[read["done"] :]
    bar.total = bar.n
    bar.set_description(f"{spec.name}: report")
    bar.refresh()
    walls["in the loop"] = time.perf_counter() - t0
    walls["in the loop: its chunks"] = sum(runner.chunks_s)
    import pandas as pd

    for name, run in detail.items():  # a motor run in the loop: its screen over the variants that run judged
        _, one, _ = screen(
            df, {name: cat[name]}, armature=armature, accel=accel, ramp=ramp, judged=run["judged"], **common
        )
        table = pd.concat([table[table["motor"] != name], one])
    order = {name: i for i, name in enumerate(wins["chosen"])}  # the windows' order: smallest motor first
    table = table.assign(_o=[order.get(m, len(order)) for m in table["motor"]]).sort_values("_o", kind="stable")
    table = table.drop(columns="_o").reset_index(drop=True)

    loop = pd.concat(rows, ignore_index=True)
    hottest = chosen or best_in_loop(loop)
    d = detail[hottest]
    temps = d[[f"drive_{c}_winding_temp_peak" for c in ("lf", "rf", "lr", "rr")]].max(axis=1).to_numpy()
    if d["judged"].any():  # the hottest of the variants the drive is judged on (not a run its steering lost)
        temps = np.where(d["judged"].to_numpy(bool), temps, -np.inf)
    worst = int(np.argmax(temps))
    values = {k: float(df[k].iloc[worst]) for k in spec.params if np.issubdtype(df[k].dtype, np.number)}
    # its own hot start: back to back, a run ends where it started (in_loop's last run, within its residual)
    ends = d[[f"drive_{c}_winding_temp_end" for c in ("lf", "rf", "lr", "rr")]].max(axis=1).to_numpy()
    c = cat[hottest].resolved()
    rest = spec.stats_config().n_steps * float(spec.scenario.time_step) * (1.0 / spec.duty - 1.0)
    cooled = np.exp(-rest / c["t_T"]) if c["t_T"] > 0 else 0.0  # over the rest between runs, at a duty below 1
    rise = max(float(ends[worst]) - c["T_amb"], 0.0) * cooled
    reasons = [r for r in IN_LOOP_REASONS if bool(d[f"fails_{r}"].iloc[worst])]
    reasons += [f"steering {r}" for r in STEER_REASONS if bool(d[f"steer_fails_{r}"].iloc[worst])]
    worst_note = f"{hottest} misses it: {', '.join(reasons)}" if reasons else f"{hottest} covers it"
    t0 = time.perf_counter()
    series = trace(spec, args.catalogue, hottest, steer, values, rise)
    walls["trace"] = time.perf_counter() - t0
    needs = requirement_sheets(df, spec, span, args.share, cat, chosen or hottest, steer, wins)
    s = report.Sizing(
        name=spec.name,
        spec_text=Path(args.spec).read_text(),
        params=list(spec.params),
        servo=df,
        screen=table,
        loop=loop,
        detail=detail,
        chosen=chosen,
        steer=steer,
        share=args.share,
        steer_screen=steer_table,
        steer_loop=pd.concat(steer_rows, ignore_index=True),
        not_run=not_run(table, runs, list(loop["motor"]), chosen, best),
        duty=spec.duty,
        span=span,
        steer_given=args.steer is not None,
        ratios=ratios,
        windows=wins,
        steer_ratios=steer_ratios,
        steer_windows=steer_wins,
        requirements=needs,
        catalogue=cat,
        battery=battery,
        trace=series,
        worst=values,
        worst_note=worst_note,
        versions={
            "batchveh": batchveh.__version__,
            "MuJoCo": mujoco.__version__,
            "Python": platform.python_version(),
            "machine": f"{platform.machine()}, {__import__('os').cpu_count()} CPUs",
            "date": time.strftime("%Y-%m-%d %H:%M"),
        },
        wall_s=walls,
    )
    paths = report.write(out, s)
    bar.close()
    return s, paths


def requirement_sheets(
    df: Any, spec: Any, span: str | None, share: float, cat: dict, drive: str, steer: str, wins: Any
) -> dict[str, Any]:
    """The requirement sheet (`sizing.requirements`): the drive's at the wheel and at the shaft of `drive`, the
    steering's at the hinge and at the shaft of `steer`; with each motor's shortfall against the drive's sheet at
    the ratio where it comes nearest (`would`: {motor: line}) and the (motor, ratio) nearest to covering."""
    from batchveh.sizing import requirements

    params = list(spec.params)
    out = {
        "drive": requirements.sheet(df, "drive", span, spec.duty, share, params, cat[drive]),
        "steer": requirements.sheet(df, "steer", span, spec.duty, share, params, cat[steer]),
    }
    wheel = out["drive"]["at_wheel"]
    by_motor: dict[str, list] = {}
    for m in cat.values():
        by_motor.setdefault(m.motor_name, []).append(m)
    # each motor at the ratio where it comes nearest the sheet: the least of its worst factor
    out["would"] = {  # smallest motor first, as the windows
        name: requirements.short_line(
            min(by_motor[name], key=lambda m: max(requirements.shortfall(m, wheel).values())), wheel
        )
        for name in wins["motor_name"]
    }
    near = wins.sort_values("chosen_coverage", ascending=False, kind="stable").iloc[0]
    out["nearest"] = {"motor": near["chosen"], "ratio": near["chosen_ratio"], "coverage": near["chosen_coverage"],
                      "binding": near["binding"] or near["closed_below"]}  # fmt: skip
    return out


def verdict_line(s: Any, paths: dict[str, Path]) -> str:
    """The command's last line: the choice, its coverage, the report."""
    from batchveh.sizing.report import battery_over, steering_lost

    if s.chosen is None:
        none_judged = "judged" in s.loop and len(s.loop) > 0 and not (s.loop["judged"] > 0).any()
        why = f"; no drive could be judged: the steering ({s.steer}) lost every run" if none_judged else ""
        near = s.requirements["nearest"] if s.requirements else None
        would = (
            f"; nearest: {near['motor']} ({near['coverage']:.1%} on the screen, {near['binding']} binds); a motor "
            f"must give {_sheet_brief(s)}"
            if near
            else ""
        )
        return f"no motor of the catalogue covers {s.share:.0%} in the loop{why}{would}; report: {paths['html']}"
    row = s.loop.set_index("motor").loc[s.chosen]
    c = s.catalogue[s.chosen].resolved()
    lost = f", {int(row['not_simulated'])} variants not simulated" if row["not_simulated"] else ""
    steered = steering_lost(row, len(s.servo))
    lost += f", {steered} the steering lost (not counted for the drive)" if steered else ""
    over = battery_over(s)
    lost += f", {over} past the battery's energy or power (the battery's, not counted)" if over else ""
    return (
        f"chosen: {s.chosen} (gearhead {c['N']:g}:1), covers {row['coverage']:.1%} in the loop "
        f"(screen {float(s.screen.set_index('motor').loc[s.chosen, 'coverage']):.1%}){lost}; steering {s.steer}; "
        f"report: {paths['html']}"
    )


def _sheet_brief(s: Any) -> str:
    """The drive's sheet at the wheel in a few words: RMS, peak and top speed."""
    w = s.requirements["drive"]["at_wheel"]
    return (
        f"{w['rms_torque']['value']:.3g} N m RMS, {w['peak_torque']['value']:.3g} N m peak, "
        f"{w['top_speed']['value']:.3g} rad/s at the wheel (the report's requirement sheet)"
    )


def dry_run(args: Any) -> str:
    """The work the command would do, estimated, without simulating."""
    from batchveh.engines import resolve_backend
    from batchveh.sweep import count_variants, estimate
    from batchveh.sweeping.spec import load_spec

    spec = load_spec(args.spec)
    cat = catalogue_of(args.catalogue)
    n = count_variants(spec, args.limit)
    backend = resolve_backend(args.backend or spec.backend)
    seconds, basis = estimate(backend, n * spec.scenario.n_steps, spec.vehicle.tyre.model, 0, n)
    per = loop_runs(spec)
    loop = seconds * per
    motors = len({m.motor_name for m in cat.values()})
    return (
        f"{spec.name}: the servo sweep, {n:,} variants ({seconds:.0f} s, {basis}); the screen of {len(cat)} (motor, "
        f"ratio) pairs of {motors} motors; then one ratio a motor in the loop, {per} run{'s' * (per > 1)}, about "
        f"{loop:.0f} s each (two to all {motors}: {2 * loop:.0f}-{motors * loop:.0f} s); report in "
        f"{args.out or f'{spec.output}-sizing'}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(
        prog="python -m batchveh.size",
        description=__doc__.split("\n\n")[0],
        epilog="Exit codes: 0 done, 2 bad spec, catalogue, argument or file, 3 a report exists (--overwrite), "
        "130 interrupted. The report: docs/motors.md, 'Sizing in one command'.",
    )
    parser.add_argument("spec", help="sweep YAML: the vehicle and the conditions to cover, e.g. sweeps/slope.yaml")
    parser.add_argument("--catalogue", required=True, help="motor catalogue YAML, e.g. notebooks/motors.yaml")
    parser.add_argument("--share", type=float, default=0.99, help="share of the variants to cover (default 0.99)")
    parser.add_argument("--out", help="the sizing's folder (default: the spec's output + '-sizing')")
    parser.add_argument("--steer", help="the steering motor's catalogue name (default: the screen's choice)")
    parser.add_argument("--backend", choices=("auto", "mujoco", "warp"), help="as batchveh.sweep's")
    parser.add_argument(
        "--span",
        help="the span the screen reads: a mission's 'mission' (the default for a mission: the whole cycle, each "
        "segment checked on its own) or one segment's ('seg2_climb'); a straight line reads its steady window",
    )
    parser.add_argument(
        "--executor",
        choices=("local", "ray", "gpus"),
        help="as batchveh.sweep's, for the servo sweep and every run in the loop (each a sweep of its own in "
        "OUT/loop, resumed: a killed session runs again only what it had not written)",
    )
    parser.add_argument("--address", help="with --executor ray: the cluster to join, as batchveh.sweep's")
    parser.add_argument("--limit", type=int, help="the first N variants only")
    parser.add_argument("--overwrite", action="store_true", help="replace a report in --out")
    parser.add_argument("--dry-run", action="store_true", help="estimate the whole run, then stop")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return run_main(
        parser,
        lambda args: _size(parser, args),
        argv,
        codes={FileExistsError: EXIT_EXISTS},
        where=lambda args: args.spec,
        interrupted="the finished chunks (the servo sweep's, the loop's) are kept; run again to reuse them",
    )


def _size(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    """The command on its parsed arguments; `run_main` turns its input errors into one line."""
    if args.limit is not None and args.limit < 1:
        parser.error(f"--limit: {args.limit!r} is not allowed; allowed: an integer >= 1")
    if args.address is not None and args.executor != "ray":
        parser.error("--address: needs --executor ray")
    started_ray = False
    try:
        if args.dry_run:
            print(dry_run(args))
            return EXIT_OK
        from batchveh.sweep import enable_compile_cache, engine_settings, new_executor
        from batchveh.sweeping.spec import load_spec

        enable_compile_cache()
        backend = engine_settings(args.executor, args.backend, load_spec(args.spec))
        if args.executor == "ray":
            from batchveh.sweeping import cluster

            started_ray = cluster.connect(args.address)

        def executor(spec: Any, n: int) -> Any:
            return new_executor(args.executor, spec, backend, n)

        s, paths = size(args, executor)
    finally:
        if started_ray:
            cluster.disconnect()
    print(verdict_line(s, paths))
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
