"""Run one scenario and write its time series and the seed's four figures.

    python -m batchveh.run straight_line --slope-deg 10 --out runs/demo
    python -m batchveh.run my_scenario.yaml --vehicle my_vehicle.yaml --backend mjx

Exit codes: 0 done, 2 bad input (one line on stderr), 3 the output exists
(give --overwrite), 4 the run diverged (results still written).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from batchveh.cli import run_main
from batchveh.config import ConfigError, OneLineParser
from batchveh.model import course
from batchveh.model.params import base_params
from batchveh.model.scenarios import SCENARIOS, Scenario, check_layout, load_scenario
from batchveh.model.vehicle import CORNERS, MOTORS, Vehicle, geometry_line, load_vehicle
from batchveh.stepping import stats
from batchveh.stepping.batch import make_batch

UNITS = {
    "time": "s",
    **{m: "N m" for m in MOTORS},
    **{f"omega_{c}": "rad/s" for c in CORNERS},
    **{f"alpha_{c}": "rad" for c in CORNERS},
    **{f"omega_ref_{c}": "rad/s" for c in CORNERS},
    **{f"alpha_ref_{c}": "rad" for c in CORNERS},
    "x": "m",
    "y": "m",
    "z": "m",
    "roll": "rad",
    "pitch": "rad",
    "yaw": "rad",
    "vx": "m/s",
    "vy": "m/s",
    "vz": "m/s",
    "v_forward": "m/s",
    "slip": "1",
}


def series_frame(series: dict[str, np.ndarray], dt: float) -> pd.DataFrame:
    """Per-step samples as a DataFrame with the columns of UNITS."""
    s = {k: np.asarray(v, np.float64) for k, v in series.items()}
    n = len(s["tau"])
    cols: dict[str, Any] = {"time": (np.arange(n) + 1) * dt}
    for k, m in enumerate(MOTORS):
        cols[m] = s["tau"][:, k]
    for k, c in enumerate(CORNERS):
        cols[f"omega_{c}"] = s["omega"][:, k]
        cols[f"alpha_{c}"] = s["alpha"][:, k]
        cols[f"omega_ref_{c}"] = s["ref"][:, k]
        cols[f"alpha_ref_{c}"] = s["ref"][:, 4 + k]
    cols["x"], cols["y"], cols["z"] = s["pos"].T
    roll, pitch, yaw = stats._roll_pitch_yaw(s["quat"], np)
    cols["roll"], cols["pitch"], cols["yaw"] = roll, pitch, yaw
    cols["vx"], cols["vy"], cols["vz"] = s["vel"].T
    cols["v_forward"] = s["vel"][:, 0] * np.cos(yaw) + s["vel"][:, 1] * np.sin(yaw)
    rim = s["rim"]
    moving = np.abs(rim) > 1e-3
    cols["slip"] = np.where(moving, 1 - cols["v_forward"] / np.where(moving, rim, 1.0), 0.0)
    return pd.DataFrame(cols)


@dataclasses.dataclass
class RunResult:
    """One scenario's time series (DataFrame, units in UNITS) and its statistics."""

    series: pd.DataFrame
    stats: dict[str, Any]
    scenario: Scenario
    vehicle: Vehicle


def simulate(
    vehicle: Vehicle,
    scenario: Scenario,
    backend: str = "mujoco",
    window: tuple[float, float] | None = None,
    precision: str = "f32",
) -> RunResult:
    """Run one scenario on MuJoCo C ('mujoco', float64) or MJX ('mjx', `precision` f32 or f64);
    record every step after the settle (the series' time is law time: its first sample is at
    t = time_step, the state after the first step of the laws; `window` is in law time too)."""
    cfg = stats.StatsConfig.for_scenario(scenario, window, slip_limit=stats.slip_limit(vehicle))
    batch = make_batch(vehicle, scenario, {})
    params = {k: float(v[0]) if np.ndim(v) == 1 else np.asarray(v[0]) for k, v in batch.params.items()}  # _dc.*: (8,)
    n = scenario.n_steps
    if backend == "mujoco":
        from batchveh.stepping.rollout import mujoco_series

        series = mujoco_series(batch.model, params, scenario=scenario, n_steps=n)
    elif backend == "mjx":
        import jax
        import jax.numpy as jnp

        from batchveh.model.vehicle import layout
        from batchveh.stepping.batch import mjx_model
        from batchveh.stepping.rollout import float_precision, mjx_series

        lay = layout(batch.model)
        with float_precision(precision):
            mx, _ = mjx_model(batch)
            fn = jax.jit(lambda m, p: mjx_series(m, p, scenario=scenario, n_steps=n, lay=lay))
            series = jax.device_get(fn(mx, {k: jnp.asarray(v) for k, v in params.items()}))
    else:
        raise ConfigError(f"--backend: {backend!r} is not allowed; allowed: mujoco, mjx")
    from batchveh.stepping.rollout import series_stats

    st = series_stats(series, cfg)  # over every step: the reduction leaves the settle out itself
    st = course.flag(st, params, scenario.obstacle)  # stuck or short: an obstacle not got over
    frame = series_frame({k: v[cfg.settle_steps :] for k, v in series.items()}, scenario.time_step)
    return RunResult(frame, st, scenario, vehicle)


def write(result: RunResult, out: Path, overwrite: bool = False) -> list[Path]:
    """Write series.parquet and the four figures under `out`."""
    target = out / "series.parquet"
    if target.exists() and not overwrite:
        raise FileExistsError(f"{target} exists; give --overwrite to replace it")
    out.mkdir(parents=True, exist_ok=True)
    from batchveh.sweeping.results import annotated_table
    from batchveh.sweeping.storage import write_table

    fields = {name: {"unit": UNITS.get(name, "")} for name in result.series.columns}
    meta = {
        "scenario": repr(result.scenario),
        "vehicle": repr(result.vehicle),
        "steering_geometry": json.dumps(result.vehicle.steering_geometry()),  # each wheel's trail, scrub radius (m)
    }
    write_table(annotated_table(result.series, fields, meta), target)
    from batchveh.analysis.plot import seed_figures

    title = f"{result.scenario.kind}, slope {result.scenario.slope_deg:g} deg, mu {result.scenario.friction:g}"
    return [target, *seed_figures(result.series, out, title)]


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(
        prog="python -m batchveh.run",
        description=__doc__.split("\n\n")[0],
        epilog=f"Scenarios: {', '.join(SCENARIOS)}. Exit codes: 0 ok, 2 bad input, 3 output exists, 4 diverged.",
    )
    parser.add_argument("scenario", help="a scenario name or a scenario YAML file")
    parser.add_argument("--vehicle", help="vehicle YAML (default: the seed's vehicle)")
    parser.add_argument("--slope-deg", type=float, help="slope in deg (overrides the scenario)")
    parser.add_argument("--friction", type=float, help="friction coefficient")
    parser.add_argument("--speed-kmh", type=float, help="target speed in km/h")
    parser.add_argument("--total-time", type=float, help="simulated time in s")
    parser.add_argument(
        "--backend", choices=("mujoco", "mjx"), default="mujoco", help="MuJoCo C (default) or MJX (JAX)"
    )
    parser.add_argument("--precision", choices=("f32", "f64"), default="f32", help="MJX float precision")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default runs/<scenario>)")
    parser.add_argument("--overwrite", action="store_true", help="replace existing results")
    return run_main(
        parser,
        _run,
        argv,
        codes={FileExistsError: 3},
        where=lambda args: args.out or "the output",
        interrupted="the results are written only at the end; run again",
    )


def _run(args: argparse.Namespace) -> int:
    """The command on its parsed arguments; `run_main` turns its input errors into one line."""
    vehicle = load_vehicle(args.vehicle)
    scenario = load_scenario(args.scenario)
    over = {
        k: getattr(args, k)
        for k in ("slope_deg", "friction", "speed_kmh", "total_time")
        if getattr(args, k) is not None
    }
    if over:
        scenario = dataclasses.replace(scenario, **over)
        from batchveh.config import check_dataclass

        check_dataclass(scenario, "command line")
        scenario.validate("command line")
    out = args.out or Path("runs") / Path(args.scenario).stem
    if (out / "series.parquet").exists() and not args.overwrite:
        raise FileExistsError(f"{out / 'series.parquet'} exists; give --overwrite to replace it")
    course.check(base_params(vehicle, scenario), scenario.obstacle, str(args.scenario))  # names the file
    where = f"{args.scenario} on {args.vehicle or 'the seed vehicle'} (steering.layout {vehicle.steering.layout})"
    check_layout(vehicle.steering.layout, scenario, where)  # names both files
    t0 = time.perf_counter()
    result = simulate(vehicle, scenario, backend=args.backend, precision=args.precision)
    paths = write(result, out, overwrite=args.overwrite)
    s = result.stats
    print(
        f"{scenario.kind} on {args.backend}: {scenario.n_steps} steps in {time.perf_counter() - t0:.2f} s, "
        f"status {stats.STATUS[int(s['status_code'])]}, slip ratio {float(s['slip_ratio']):.3f}"
    )
    print(geometry_line(vehicle))
    print("steady mean torque [N m]: " + ", ".join(f"{m} {float(s[m + '_mean']):.3f}" for m in MOTORS))
    closed_form = vehicle.total_mass * scenario.gravity * np.sin(np.deg2rad(scenario.slope_deg)) * vehicle.wheel.radius
    print(f"four-wheel drive sum {float(s['drive_sum_mean']):.3f} N m (m g sin(slope) r = {closed_form:.3f})")
    print("wrote: " + ", ".join(str(p) for p in paths))
    return 4 if int(s["status_code"]) == 1 else 0


if __name__ == "__main__":
    sys.exit(main())
