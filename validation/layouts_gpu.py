"""The warp engine against MuJoCo C on each steering layout, on a CUDA GPU (issue 64, "MuJoCo C against warp on
each layout"), and the warp engine's speed per layout.

For each case (a layout and a scenario on a 50 kg robot and a 250 kg AGV unlike the seed), N_COMPARE variants
(friction 0.4-0.9, payload 0-40% of the mass, Latin hypercube, seed 0) run on both engines: statuses must be
equal; per motor and statistic, |warp - C| is reported against C's magnitude (the bounds are tests/test_warp.py's
MOTOR_TOL, by motor kind). Then the warp engine's time on N_TIME variants, warm (the second run), per layout:
the layouts change the controls only, so their speeds should match.

    python validation/layouts_gpu.py OUT_DIR     (writes OUT_DIR/layouts_gpu.json)
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
from scipy.stats import qmc

from batchveh.engines.mujoco import MujocoEngine
from batchveh.engines.warp import WarpEngine
from batchveh.model.scenarios import make_scenario
from batchveh.model.vehicle import MOTORS, Chassis, Hub, Steering, Vehicle, Wheel
from batchveh.stepping import stats
from batchveh.stepping.batch import make_batch

N_COMPARE = int(os.environ.get("N_COMPARE", "256"))
N_TIME = int(os.environ.get("N_TIME", "16384"))
MOTOR_TOL = {"drive": (2e-3, 1e-2), "steer": (2e-3, 5e-3)}  # tests/test_warp.py: (rtol, atol N m)
SUFFIXES = ("_mean", "_rms", "_peak", "_peak_lp")

ROBOT = Vehicle(
    chassis=Chassis(length=0.60, width=0.46, height=0.20, mass=36.0, z_cg=0.22),
    wheel=Wheel(radius=0.11, width=0.07, mass=1.5, x_cg=0.25, y_cg=0.28),
    hub=Hub(radius=0.04, length=0.10, mass=2.0, y_cg=0.20),
)
AGV = Vehicle(
    chassis=Chassis(length=1.2, width=0.8, height=0.3, mass=200.0, z_cg=0.35),
    wheel=Wheel(radius=0.15, width=0.08, mass=4.0, x_cg=0.5, y_cg=0.42),
    hub=Hub(radius=0.06, length=0.15, mass=8.5, y_cg=0.3),
)
CASES = (
    ("robot", "four_wheel", "pivot", {}),
    ("robot", "skid", "pivot", {}),
    ("robot", "skid", "ackermann", {"turn_radius": 1.5, "speed_kmh": 3.0}),
    ("robot", "front", "ackermann", {"turn_radius": 2.0, "speed_kmh": 3.0}),
    ("robot", "front", "steer_in_place_rolling", {}),
    ("agv", "skid", "pivot", {"yaw_rate_dps": 15.0}),
    ("agv", "front", "ackermann", {"turn_radius": -3.0, "speed_kmh": 4.0}),
    ("agv", "four_wheel", "pivot", {"yaw_rate_dps": 15.0}),
    ("agv", "four_wheel", "ackermann", {"turn_radius": -3.0, "speed_kmh": 4.0}),
)


def _vehicle(name: str, layout: str) -> Vehicle:
    v = {"robot": ROBOT, "agv": AGV}[name]
    return dataclasses.replace(v, steering=Steering(layout=layout))


def _table(v: Vehicle, n: int) -> dict[str, np.ndarray]:
    u = qmc.LatinHypercube(d=2, seed=0).random(n)
    return {"friction": 0.4 + 0.5 * u[:, 0], "payload.mass": 0.4 * v.total_mass * u[:, 1]}


def _run(engine_cls, v, sc, table):
    n = len(table["friction"])
    cfg = stats.StatsConfig.for_scenario(sc)
    engine = engine_cls(sc, cfg, n)
    batch = make_batch(v, sc, table)
    t0 = time.perf_counter()
    out = engine.run(batch)
    return out, time.perf_counter() - t0, engine


def compare(name, layout, kind, kw) -> dict:
    v = _vehicle(name, layout)
    sc = make_scenario(kind, total_time=6.0, **kw)
    table = _table(v, N_COMPARE)
    w, _, _ = _run(WarpEngine, v, sc, table)
    c, _, _ = _run(MujocoEngine, v, sc, table)
    row = {"vehicle": name, "layout": layout, "scenario": kind, **kw, "n": N_COMPARE,
           "status_equal": bool(np.array_equal(w["status_code"], c["status_code"])),
           "status_ok_c": int((np.asarray(c["status_code"]) == 0).sum())}  # fmt: skip
    for group in ("drive", "steer"):
        rtol, atol = MOTOR_TOL[group]
        worst, excess, scale = 0.0, -np.inf, 0.0
        for m in (m for m in MOTORS if m.startswith(group)):
            for s in SUFFIXES:
                a, b = np.asarray(w[m + s], float), np.asarray(c[m + s], float)
                d = np.abs(a - b)
                worst = max(worst, float(d.max()))
                excess = max(excess, float((d - (atol + rtol * np.abs(b))).max()))
                scale = max(scale, float(np.abs(b).max()))
            for s in SUFFIXES:  # the statistic that sets it: its largest difference and C's largest value
                d = max(float(np.abs(np.asarray(w[m + s], float) - np.asarray(c[m + s], float)).max())
                        for m in MOTORS if m.startswith(group))  # fmt: skip
                big = max(float(np.abs(np.asarray(c[m + s], float)).max()) for m in MOTORS if m.startswith(group))
                row.setdefault(f"{group}_by_statistic", {})[s] = [d, big]
        row[f"{group}_max_abs_diff"] = worst
        row[f"{group}_largest_c"] = scale
        row[f"{group}_within_motor_tol"] = bool(excess <= 0)
    return row


def timing(name, layout, kind, kw) -> dict:
    v = _vehicle(name, layout)
    sc = make_scenario(kind, total_time=6.0, **kw)
    table = _table(v, N_TIME)
    n = N_TIME
    cfg = stats.StatsConfig.for_scenario(sc)
    engine = WarpEngine(sc, cfg, n)
    times = []
    for _ in range(3):
        batch = make_batch(v, sc, table)
        t0 = time.perf_counter()
        engine.run(batch)
        times.append(time.perf_counter() - t0)
    steps = n * sc.n_steps
    return {"vehicle": name, "layout": layout, "scenario": kind, "n": n, "steps": sc.n_steps,
            "first_s": times[0], "warm_s": sorted(times[1:]),
            "variant_steps_per_s": steps / min(times[1:])}  # fmt: skip


def main() -> None:
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    import jax

    result = {"machine": f"{jax.devices()[0].device_kind} ({platform.node()})", "compare": [], "timing": []}
    chosen = os.environ.get("CASES", "")  # e.g. "agv": the cases of that vehicle only
    for case in [c for c in CASES if not chosen or c[0] == chosen][: int(os.environ.get("N_CASES", len(CASES)))]:
        result["compare"].append(compare(*case))
        print(json.dumps(result["compare"][-1]), flush=True)
    for case in CASES[: int(os.environ.get("N_TIMED", "5"))]:
        result["timing"].append(timing(*case))
        print(json.dumps(result["timing"][-1]), flush=True)
    (out / "layouts_gpu.json").write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
