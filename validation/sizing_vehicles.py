"""Sizing answers on any vehicle (issue 51): `python -m batchveh.size` as a new user runs it, on five vehicles unlike
each other, on MuJoCo C. Writes validation/results/sizing_vehicles.json and prints a table.

    python validation/sizing_vehicles.py [--out DIR] [--only NAME ...]

The vehicles (sweeps/):
- sidewalk_robot: issue 51's 60-80 kg robot, friction 0.4-0.9 swept, its contacts 0.025 m outboard of the steering
  axes and 0.05 m along the vehicle from them (the rear ones lead: the geometry whose rear steering ran away);
- delivery_robot_friction: sweeps/delivery_robot.yaml (wheels 0.05 m outboard of the axes) with friction 0.4-0.9
  swept too (the spec is written into --out);
- robot_30kg, warehouse_agv (180-300 kg), seed_sizing (the seed's vehicle, 300 LHS of benchmarks/slope_100k.yaml's
  ranges), rover_1t, cart_110kg (issue 61's rear-heavy cart on 0.22 m wheels);
- and with `--only mission robot_mission robot_mission_share95 agv_mission --json
  validation/results/sizing_missions.json`, issue 54's duty cycles (sweeps/mission.yaml, sweeps/robot_mission.yaml,
  the same at --share 0.95, sweeps/agv_mission.yaml).

Per vehicle: the command's wall and last line; the chosen drive and steering motor; for the chosen (or the best) drive
its screen and loop coverage and their difference in points; the share of variants not simulated; from
verdicts.parquet, over every variant run in the loop: the largest motor_torque_ratio, the steering error's p50, p99
and max, the steering motors' largest share of the run at the current limit, and how many runs were unstable.
What the issue asks: not simulated at most 0.5%; the chosen motor's screen and loop within 2 points.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from datetime import date
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from batchveh.sizing import best_in_loop
from batchveh.sizing.windows import window_text

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
JSON = ROOT / "validation" / "results" / "sizing_vehicles.json"
VEHICLES = (
    "sidewalk_robot", "delivery_robot_friction", "robot_30kg", "warehouse_agv", "seed_sizing", "rover_1t", "cart_110kg",
)  # fmt: skip
MISSIONS = ("mission", "robot_mission", "robot_mission_share95", "agv_mission")  # issue 54's duty cycles: --only
# them --json ...missions.json
SHARES = {"robot_mission_share95": ("robot_mission", 0.95)}  # a name for a spec sized at another --share
NOT_SIMULATED_MAX = 0.005  # the bound: share of the variants
AGREE_POINTS = 2.0  # the chosen motor's screen and loop coverage, points apart


def spec_path(name: str, out: Path) -> Path:
    """The vehicle's spec: sweeps/NAME.yaml, or delivery_robot.yaml with friction swept, written into out."""
    if name != "delivery_robot_friction":
        return ROOT / "sweeps" / f"{name}.yaml"
    raw = yaml.safe_load((ROOT / "sweeps" / "delivery_robot.yaml").read_text())
    raw["name"] = name
    raw["fixed"].pop("friction")
    raw["sweep"]["params"]["friction"] = {"low": 0.4, "high": 0.9}
    raw["output"] = str(out / name / "results")
    path = out / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def size(name: str, out: Path) -> dict:
    base, share = SHARES.get(name, (name, None))
    spec = spec_path(base, out)
    folder = out / name
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "batchveh.size", str(spec), "--catalogue", str(CATALOGUE), "--out", str(folder),
         "--quiet", "--overwrite", *(["--share", str(share)] if share else [])],
        cwd=ROOT, capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"},
    )  # fmt: skip
    wall = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(f"{name}: exit {done.returncode}: {done.stderr[-2000:]}")
    summary = json.loads((folder / "sizing.json").read_text())
    loop = pd.DataFrame(summary["loop"])
    screen = pd.DataFrame(summary["screen"]).set_index("motor")
    focus = summary["chosen"] or best_in_loop(loop)
    row = loop.set_index("motor").loc[focus]
    v = pd.read_parquet(folder / "verdicts.parquet")
    err = v["steer_track_err_deg"].to_numpy(float)
    n = int(summary["variants"])
    return {
        "spec": str(spec.relative_to(ROOT)) if spec.is_relative_to(ROOT) else spec.name,
        "share": summary["share"],
        "variants": n,
        "wall_s": round(wall, 1),
        "last_line": done.stdout.strip().splitlines()[-1],
        "chosen": summary["chosen"],
        "steer": summary["steer"],
        "focus": focus,
        "screen_coverage": float(screen.loc[focus, "coverage"]),
        "loop_coverage": float(row["coverage"]),
        "points_apart": round(100 * abs(float(screen.loc[focus, "coverage"]) - float(row["coverage"])), 2),
        "not_simulated": int(row["not_simulated"]),
        "not_simulated_share": int(row["not_simulated"]) / n,
        "loop_fails": {k.removeprefix("fails_"): int(row[k]) for k in row.index if k.startswith("fails_") and row[k]},
        "steer_misses": int(row["steer_misses"]),
        "candidates_run": list(loop["motor"]),
        "steering_runs": [(r["steer"], r["drive"], r["steer_coverage"]) for r in summary["steer_loop"]],
        "every_run_in_the_loop": {
            "runs": len(v),
            "unstable": int((v["motor_status"] == "unstable").sum()),
            "torque_ratio_max": float(v["motor_torque_ratio"].max()),
            "steer_err_deg_p50": float(np.percentile(err, 50)),
            "steer_err_deg_p99": float(np.percentile(err, 99)),
            "steer_err_deg_max": float(err.max()),
            "steer_at_current_share_max": float(v["steer_at_current_share"].max()),
        },
        "wall_phases_s": summary["wall_s"],
        # issue 61: each motor's ratio window, the requirement sheet at the wheel, each motor against it
        "windows": {w["motor_name"]: window_text(w) for w in summary.get("windows") or []},
        "sheet_at_wheel": {k: round(f["value"], 4) for k, f in summary["requirements"]["drive"]["at_wheel"].items()},
        "steer_sheet_at_hinge": {
            k: round(f["value"], 4) for k, f in summary["requirements"]["steer"]["at_wheel"].items()
        },
        "against_the_sheet": summary["requirements"]["would"],
        "nearest": summary["requirements"]["nearest"],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "sizing_vehicles"))
    ap.add_argument("--only", nargs="*", choices=VEHICLES + MISSIONS)
    ap.add_argument("--json", help="write the JSON there (default: validation/results/sizing_vehicles.json for all)")
    args = ap.parse_args()
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    got = {name: size(name, out) for name in (args.only or VEHICLES)}
    print(f"{'vehicle':24} {'chosen':34} {'screen':>7} {'loop':>7} {'apart':>6} {'not sim':>7} {'ratio':>6} "
          f"{'err p99':>8} {'wall':>6}")  # fmt: skip
    for name, r in got.items():
        e = r["every_run_in_the_loop"]
        print(f"{name:24} {str(r['chosen']):34} {r['screen_coverage']:7.1%} {r['loop_coverage']:7.1%} "
              f"{r['points_apart']:6.2f} {r['not_simulated_share']:7.2%} {e['torque_ratio_max']:6.3f} "
              f"{e['steer_err_deg_p99']:8.3f} {r['wall_s']:6.1f}")  # fmt: skip
    if args.only and not args.json:
        return
    Path(args.json or JSON).write_text(
        json.dumps(
            {
                "what": (
                    "Sizing against a duty cycle (issue 54): `python -m batchveh.size` on three missions, on MuJoCo C."
                    if set(got) <= set(MISSIONS)
                    else __doc__.split("\n\n")[0]
                ),
                "date": str(date.today()),
                "commit": subprocess.run(
                    ["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True
                ).stdout.strip(),
                "machine": f"{platform.machine()}, {os.cpu_count()} CPUs (this project's 2-core machine)",
                "bounds": {"not_simulated_share_max": NOT_SIMULATED_MAX, "agree_points": AGREE_POINTS},
                "vehicles": got,
            },
            indent=1,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
