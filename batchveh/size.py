"""Size the drive motors of a sweep in one command: from a vehicle spec and a motor catalogue to the motor to buy.

    python -m batchveh.size sweeps/delivery_robot.yaml --catalogue notebooks/motors.yaml
    python -m batchveh.size sweeps/slope.yaml --catalogue notebooks/motors.yaml --limit 500 --share 0.99 --out S
    python -m batchveh.size sweeps/slope.yaml --catalogue notebooks/motors.yaml --dry-run

Three phases, one progress bar:
1. the sweep with the ideal servo (the demand), in OUT/servo: reused where it is there and was made from the
   same spec (the sweep's resume), else run;
2. the screen: every catalogue motor against that demand (`batchveh.sizing.screening.screen`), for the drives
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
The steering group is the vehicle's `steering.layout`'s (`batchveh.analysis.demand.groups`): four_wheel, the four
hubs' motors; front, the two front hubs' (steer_lf, steer_rf); skid, none: no steering screen, window, choice,
confirmation or sheet, the loop runs the drives alone (vehicle.HUB_LOCK holds every hub) and --steer is refused.
A fixed hub's `steer_<corner>` columns are the moment its mounting carries: no steering figure reads them.
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
HOT_RUNS = 2  # in_loop's runs per candidate (`iterations` 1): from ambient, then from the hot start in closed form


def loop_runs(spec: Any) -> int:
    """The runs of every condition a candidate takes in the loop: one where its hot run comes in closed form from
    it (`sizing.thermal.closed_form`: a straight line; run again only for the conditions it cannot say), else
    HOT_RUNS."""
    from batchveh.sizing.thermal import closed_form

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
    from batchveh.config import load_yaml
    from batchveh.model.battery import load_battery

    data = load_yaml(path)
    return load_battery(path) if isinstance(data, dict) and "battery" in data else None


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
    """The loop's Runner (`batchveh.sizing.loop.Runner`): each run a sweep of its table (method zip) in
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


def trace(spec: Any, catalogue: str, drive: str, steer: str | None, values: dict[str, float], rise: float) -> Any:
    """One variant's time series on MuJoCo C with `drive` and `steer` as DC motors (`steer` None: a skid layout,
    none), its drive windings started `rise` above ambient: each drive's winding temperature, the bus power (W,
    the motors: the four drives and the steered hubs' motors, a fixed hub's HUB_LOCK no motor) and energy (Wh),
    and each drive's torque at the wheel and its wheel's speed."""
    import numpy as np
    import pandas as pd

    from batchveh.model.params import variant_setup
    from batchveh.model.vehicle import layout
    from batchveh.stepping.batch import make_batch
    from batchveh.stepping.rollout import mujoco_steps

    motors = dataclasses.replace(
        spec.vehicle.motors, model="dcmotor", catalogue=str(catalogue), drive=drive, steer=steer or "",
        drive_start_rise=rise,
    )  # fmt: skip
    vehicle, scenario = variant_setup(dataclasses.replace(spec.vehicle, motors=motors), spec.scenario, values)
    b = make_batch(vehicle, scenario, {})
    m, lay = b.model, layout(b.model)
    p = {k: float(v[0]) if np.ndim(v) == 1 else np.asarray(v[0]) for k, v in b.params.items()}
    k_eta = p["_dc.K"] * p["_dc.eta"]
    on_bus = p["_dc.bus"]  # the motors' slots, as the statistics' bus reads them (a fixed hub's HUB_LOCK: 0)
    rec: dict[str, Any] = {}
    rows = []
    for i, (d, ctrl) in enumerate(mujoco_steps(m, p, scenario=scenario, n_steps=scenario.n_steps, record=rec)):
        if ctrl is None:
            continue
        current = d.actuator_force[lay.motor_act] / k_eta
        power = rec["v"] * current
        torque = d.actuator_force[lay.motor_act[:4]] * p["_dc.N"][:4]  # at the wheel
        speed = d.qvel[lay.motor_dof[:4]]
        bus = float(np.sum(power * on_bus))
        rows.append([i * m.opt.timestep, *rec["T"][:4], bus, *torque, *speed])
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


@dataclasses.dataclass
class Session:
    """A sizing session's state, filled phase by phase (`size`): the inputs, then each phase's tables."""

    args: Any
    spec: Any
    cat: dict[str, Any]  # the catalogue: every (motor, ratio) by name
    battery: Any
    catalogue: str  # the catalogue's absolute path (the loop's runs read it, on Ray's workers too)
    out: Path
    executor: Any
    bar: Any = None
    n: int = 0  # the conditions
    per: int = 1  # the runs of each condition a candidate takes in the loop
    walls: dict[str, float] = dataclasses.field(default_factory=dict)
    df: Any = None  # the servo sweep's rows: the demand
    span: str | None = None
    common: dict[str, Any] = dataclasses.field(default_factory=dict)  # the screen's arguments of both groups
    drive_kw: dict[str, Any] = dataclasses.field(default_factory=dict)  # and the drives' (rotor, ramp)
    ratios: Any = None  # the screen of every (motor, ratio), drives; `windows`, `table` (one ratio a motor), `best`
    wins: Any = None
    table: Any = None
    best: str | None = None
    steer_ratios: Any = None
    steer_wins: Any = None
    steer_table: Any = None
    steer: str | None = ""  # None: no steering motor (a skid layout)
    runs: list[str] = dataclasses.field(default_factory=list)  # the drives the loop may run, smallest first
    rows: list[Any] = dataclasses.field(default_factory=list)
    steer_rows: list[Any] = dataclasses.field(default_factory=list)
    detail: dict[str, Any] = dataclasses.field(default_factory=dict)
    chosen: str | None = None


def steering_group(spec: Any) -> tuple[str, ...]:
    """The spec's steering motors (`analysis.demand.groups` of its steering.layout): four, the front two, or none
    (skid)."""
    from batchveh.analysis.demand import groups

    return groups(spec.vehicle.steering.layout)["steer"]


def start(args: Any, executor: Any) -> Session:
    """The inputs read and checked before any simulation: the spec, the catalogue and its battery, --steer,
    --share, the report's folder."""
    from batchveh.model.motors import pick
    from batchveh.sweeping.spec import load_spec

    spec = load_spec(args.spec)
    cat = catalogue_of(args.catalogue)
    # the battery's energy and power are checked in the loop, apart (its limits are not a motor's); a bad
    # `battery:` section is one line here, before any simulation
    battery = battery_of(args.catalogue)
    if args.steer is not None and not steering_group(spec):
        raise ConfigError(
            f"--steer: {args.steer!r} names a steering motor, and {args.spec} is skid-steered (steering.layout skid: "
            "every hub fixed, no steering motor); allowed: no --steer with steering.layout skid"
        )
    if args.steer is not None:
        pick(cat, args.steer, "--steer")
    if not 0 < args.share <= 1:
        raise ConfigError(f"--share: {args.share!r} is not allowed; allowed: 0 < share <= 1")
    out = Path(args.out or f"{spec.output}-sizing")
    if (out / "report.md").exists() and not args.overwrite:
        raise FileExistsError(f"{out} holds a report; give --overwrite to replace it (its servo sweep is reused)")
    return Session(args, spec, cat, battery, str(Path(args.catalogue).resolve()), out, executor)


def servo_phase(ses: Session) -> None:
    """The servo sweep (the demand) into OUT/servo, resumed where it is there; its rows."""
    from tqdm.auto import tqdm

    from batchveh.sweep import count_variants, run_sweep
    from batchveh.sweeping.results import load

    args, spec = ses.args, ses.spec
    demand = servo_spec(spec, ses.out)
    ses.n, ses.per = count_variants(demand, args.limit), loop_runs(spec)
    ses.bar = tqdm(total=ses.n * (1 + ses.per * 2), unit="run", disable=args.quiet, desc=f"{spec.name}: servo sweep")
    t0 = time.perf_counter()
    try:
        servo_run = run_sweep(
            demand,
            out=ses.out / "servo",
            backend=args.backend,
            resume=True,
            limit=args.limit,
            progress=False,
            executor=ses.executor(demand, ses.n) if ses.executor is not None else None,
        )
    except ConfigError as err:
        raise ConfigError(
            f"{err} (the servo sweep's results in {ses.out / 'servo'}: remove them or give another --out)"
        ) from None
    unwritten(servo_run, ses.out / "servo")
    ses.df = load(ses.out / "servo")
    ses.walls["servo sweep"] = time.perf_counter() - t0
    ses.walls["servo sweep: its chunks"] = servo_run["wall_s"]  # the rest: the engine's start and the rows' load
    ses.bar.update(ses.n)


def screen_phase(ses: Session) -> None:
    """Every (motor, ratio) of the catalogue against the demand, drives and steering; each motor's window; the
    table the loop walks (one ratio a motor), the screen's choice and the steering to start with."""
    from batchveh.sizing.plan import candidates, steering
    from batchveh.sizing.ramps import ramp_of, wheel_accel
    from batchveh.sizing.screening import mission_segments, screen
    from batchveh.sizing.windows import best_of, loop_table, windows, with_entry

    args, spec, df, cat = ses.args, ses.spec, ses.df, ses.cat
    ses.bar.set_description(f"{spec.name}: screen")
    t0 = time.perf_counter()
    span = args.span or ("mission" if spec.scenario.kind == "mission" else None)  # a duty cycle: the whole of it
    if span is not None and f"{span}_drive_lf_rms" not in df:
        allowed = ", ".join(["mission", *mission_segments(df)]) if "mission_drive_lf_rms" in df else "none"
        raise ConfigError(f"--span: {span!r} is not a span of {args.spec}'s results; allowed: {allowed}")
    ses.span = span
    layout = spec.vehicle.steering.layout  # the steering group: its steered hubs' motors (analysis.demand.groups)
    ses.common = {"share": args.share, "params": list(spec.params), "duty": spec.duty, "span": span, "layout": layout}
    ses.drive_kw = {"armature": spec.vehicle.motors.armature, "accel": wheel_accel(spec, df), "ramp": ramp_of(spec, df)}
    # every (motor, ratio) of the catalogue (counts only), then each motor's window; the loop walks one ratio a
    # motor, those rows screened again in detail (the commonest first miss)
    _, ses.ratios, _ = screen(df, cat, detail=False, **ses.drive_kw, **ses.common)
    ses.wins = windows(ses.ratios, cat, args.share)
    ses.best = best_of(ses.wins)
    ses.table = loop_table(detailed(df, cat, ses.wins, ses.drive_kw, ses.common), ses.wins)
    ses.runs = candidates(ses.table, ses.best, args.share)
    if not steering_group(spec):  # skid: no steering motor to screen, window or choose (HUB_LOCK holds the hubs)
        ses.steer = None
        ses.walls["screen"] = time.perf_counter() - t0
        return
    _, ses.steer_ratios, _ = screen(df, cat, group="steer", detail=False, **ses.common)
    ses.steer_wins = windows(ses.steer_ratios, cat, args.share)
    given = [args.steer] if args.steer is not None else []
    steer_rows = detailed(df, cat, ses.steer_wins, {"group": "steer"}, ses.common, given)
    ses.steer_table = loop_table(steer_rows, ses.steer_wins)
    if args.steer is not None:  # the (motor, ratio) given stands for its motor
        ses.steer_table = with_entry(ses.steer_table, steer_rows, args.steer, cat)
    ses.steer = args.steer or steering(ses.steer_table, args.share)
    ses.walls["screen"] = time.perf_counter() - t0


def detailed(df: Any, cat: dict, wins: Any, kw: dict, common: dict, extra: list[str] = ()) -> Any:
    """The screen's rows, in detail, of each motor's ratio in `wins` (and the names in `extra`)."""
    from batchveh.sizing import screen

    names = list(dict.fromkeys([*wins["chosen"], *extra]))
    _, table, _ = screen(df, {name: cat[name] for name in names}, **kw, **common)
    return table


def loop_phase(ses: Session) -> None:
    """The candidates in the loop, a batch at a time, smallest first, until one covers (`sizing.plan`); then each
    motor run there screened again over the variants its run judged."""
    import pandas as pd

    from batchveh.engines import resolve_backend
    from batchveh.sizing.loop import in_loop
    from batchveh.sizing.plan import batch_of, read_batch
    from batchveh.sizing.screening import screen

    args, spec, n, per, bar = ses.args, ses.spec, ses.n, ses.per, ses.bar
    if ses.steer is None:  # skid: no steering motor to walk up
        ranked_steer = []
    else:
        ranked_steer = list(ses.steer_table["motor"]) if args.steer is None else [ses.steer]
    looped = resolve_backend(args.backend or spec.backend)
    looped = "mujoco" if looped == "mjx" else looped  # MJX's JAX implementation has no dcmotor: MuJoCo C runs it
    runner = sweep_runner(ses.out / "loop", ses.catalogue, looped, ses.executor)
    t0 = time.perf_counter()
    pending = list(ses.runs)
    while pending and ses.chosen is None:  # the drives smallest first, a batch at a time (`batch_of`)
        batch = batch_of(pending, ses.best)
        bar.total = bar.n + n * per * len(batch)
        steering = "skid steering" if ses.steer is None else f"steering {ses.steer}"
        bar.set_description(f"{spec.name}: in the loop, {', '.join(batch)}, {steering}")
        bar.refresh()
        _, t, d = in_loop(
            spec, ses.df, ses.catalogue, batch, steer=ses.steer, share=args.share, duty=spec.duty,
            stop_at_first=False, run=runner, battery=ses.battery, battery_apart=True,
        )  # fmt: skip
        bar.update(n * per * len(batch))
        read = read_batch(batch, t, ses.steer, ranked_steer, args.share)
        ses.steer_rows += read["steer_rows"]
        ses.rows += read["rows"]
        ses.detail.update({name: d[name] for name in read["judged"]})
        ses.chosen, ses.steer, pending = read["chosen"], read["steer"], pending[read["done"] :]
    bar.total = bar.n
    bar.set_description(f"{spec.name}: report")
    bar.refresh()
    ses.walls["in the loop"] = time.perf_counter() - t0
    ses.walls["in the loop: its chunks"] = sum(runner.chunks_s)
    table = ses.table
    for name, run in ses.detail.items():  # a motor run in the loop: its screen over the variants that run judged
        _, one, _ = screen(ses.df, {name: ses.cat[name]}, judged=run["judged"], **ses.drive_kw, **ses.common)
        table = pd.concat([table[table["motor"] != name], one])
    order = {name: i for i, name in enumerate(ses.wins["chosen"])}  # the windows' order: smallest motor first
    table = table.assign(_o=[order.get(m, len(order)) for m in table["motor"]]).sort_values("_o", kind="stable")
    ses.table = table.drop(columns="_o").reset_index(drop=True)


def hottest_phase(ses: Session, loop: Any) -> tuple[str, dict[str, float], str, Any]:
    """The chosen drive's (or the best's) hottest variant judged: its name, its parameters, whether the motor
    covers it and why not, and its time series from its own hot start (`trace`)."""
    import numpy as np

    from batchveh.sizing.loop import IN_LOOP_REASONS, STEER_REASONS, best_in_loop, not_simulated

    spec, df = ses.spec, ses.df
    hottest = ses.chosen or best_in_loop(loop)
    d = ses.detail[hottest]
    temps = d[[f"drive_{c}_winding_temp_peak" for c in ("lf", "rf", "lr", "rr")]].max(axis=1).to_numpy()
    if d["judged"].any():  # the hottest of the variants the drive is judged on (not a run its steering lost)
        temps = np.where(d["judged"].to_numpy(bool), temps, -np.inf)
    worst = int(np.argmax(temps))
    values = {k: float(df[k].iloc[worst]) for k in spec.params if np.issubdtype(df[k].dtype, np.number)}
    # its own hot start: back to back, a run ends where it started (in_loop's last run, within its residual)
    ends = d[[f"drive_{c}_winding_temp_end" for c in ("lf", "rf", "lr", "rr")]].max(axis=1).to_numpy()
    c = ses.cat[hottest].resolved()
    rest = spec.stats_config().n_steps * float(spec.scenario.time_step) * (1.0 / spec.duty - 1.0)
    cooled = np.exp(-rest / c["t_T"]) if c["t_T"] > 0 else 0.0  # over the rest between runs, at a duty below 1
    rise = max(float(ends[worst]) - c["T_amb"], 0.0) * cooled
    reasons = [r for r in IN_LOOP_REASONS if bool(d[f"fails_{r}"].iloc[worst])]
    reasons += [f"steering {r}" for r in STEER_REASONS if bool(d[f"steer_fails_{r}"].iloc[worst])]
    note = f"{hottest} misses it: {', '.join(reasons)}" if reasons else f"{hottest} covers it"
    if not_simulated(d)[worst]:  # no variant judged: its run says nothing of the motor (nor does its trace)
        check = d["motor_check"].iloc[worst]
        why = "diverged" if int(d["status_code"].iloc[worst]) == 1 else f"failed its check: {check}"
        note = f"{hottest}:\nits run in the loop could not be simulated ({why}): not judged"
    t0 = time.perf_counter()
    series = trace(spec, ses.args.catalogue, hottest, ses.steer, values, rise)
    ses.walls["trace"] = time.perf_counter() - t0
    return hottest, values, note, series


def record(ses: Session) -> Any:
    """The session's result (`sizing.report.Sizing`): every phase's tables, the requirement sheets, the versions."""
    import platform

    import mujoco
    import pandas as pd

    import batchveh
    from batchveh.sizing import report
    from batchveh.sizing.plan import not_run
    from batchveh.sizing.requirements import sheets

    args, spec = ses.args, ses.spec
    loop = pd.concat(ses.rows, ignore_index=True)
    hottest, values, note, series = hottest_phase(ses, loop)
    needs = sheets(ses.df, spec, ses.span, args.share, ses.cat, ses.chosen or hottest, ses.steer, ses.wins)
    return report.Sizing(
        name=spec.name,
        spec_text=Path(args.spec).read_text(),
        params=list(spec.params),
        servo=ses.df,
        screen=ses.table,
        loop=loop,
        detail=ses.detail,
        chosen=ses.chosen,
        steer=ses.steer,
        share=args.share,
        steer_screen=ses.steer_table,
        steer_loop=pd.concat(ses.steer_rows, ignore_index=True) if ses.steer is not None else None,
        not_run=not_run(ses.table, ses.runs, list(loop["motor"]), ses.chosen, ses.best),
        duty=spec.duty,
        span=ses.span,
        steer_given=args.steer is not None,
        ratios=ses.ratios,
        windows=ses.wins,
        steer_ratios=ses.steer_ratios,
        steer_windows=ses.steer_wins,
        requirements=needs,
        geometry=geometry_of(spec),
        layout=spec.vehicle.steering.layout,
        catalogue=ses.cat,
        battery=ses.battery,
        trace=series,
        worst=values,
        worst_note=note,
        versions={
            "batchveh": batchveh.__version__,
            "MuJoCo": mujoco.__version__,
            "Python": platform.python_version(),
            "machine": f"{platform.machine()}, {__import__('os').cpu_count()} CPUs",
            "date": time.strftime("%Y-%m-%d %H:%M"),
        },
        wall_s=ses.walls,
    )


def geometry_of(spec: Any) -> str:
    """The steering geometry the session sized (`model.vehicle.geometry_line`), and the swept keys that move it."""
    from batchveh.model.vehicle import geometry_line

    moving = [p for p in spec.params if p.startswith(("steering.", "chassis.length", "chassis.width", "wheel.x_cg",
                                                      "wheel.y_cg"))]  # fmt: skip
    return geometry_line(spec.vehicle) + (f" (the base vehicle's; swept: {', '.join(moving)})" if moving else "")


def size(args: Any, executor: Any = None) -> tuple[Any, dict[str, Path]]:
    """The session (the module's docstring), one phase after another, and the report; returns (the Sizing, the
    report's paths). `executor(spec, n)`: a fresh executor for each sweep (the servo's and each run in the loop),
    or None: this process (`main` makes it from --executor)."""
    from batchveh.sizing import report

    ses = start(args, executor)
    servo_phase(ses)
    screen_phase(ses)
    loop_phase(ses)
    s = record(ses)
    paths = report.write(ses.out, s)
    ses.bar.close()
    return s, paths


def verdict_line(s: Any, paths: dict[str, Path]) -> str:
    """The command's last line: the choice, its coverage, the report."""
    from batchveh.sizing.report import battery_over, steering_lost, steering_words

    if s.chosen is None:
        none_judged = "judged" in s.loop and len(s.loop) > 0 and not (s.loop["judged"] > 0).any()
        unsimulated = none_judged and (s.loop["not_simulated"] == len(s.servo)).all()
        why = f"; no drive could be judged: the steering ({s.steer}) lost every run" if none_judged else ""
        if unsimulated:  # not the steering's, nor the motor's: every run in the loop diverged or failed its checks
            lost = s.loop["not_simulated_why"].iloc[-1]
            why = f"; no drive could be judged: no run in the loop could be simulated ({lost})"
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
        f"(screen {float(s.screen.set_index('motor').loc[s.chosen, 'coverage']):.1%}){lost}; {steering_words(s)}; "
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
