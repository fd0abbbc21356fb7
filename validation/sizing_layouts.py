"""Sizing on each steering layout (issue 64): `python -m batchveh.size` as a new user runs it, on a skid-steered robot,
a front-steered rover and a four-wheel-steered robot, on MuJoCo C. Writes validation/results/sizing_layouts.json and
prints a table.

    python validation/sizing_layouts.py [--out DIR] [--only NAME ...] [--section NAME --note TEXT]

The vehicles (sweeps/): skid_robot (steering.layout skid: no steering motor), front_rover (front: two steering
motors, the rear hubs fixed), campus_robot (four_wheel, the default). Per session: the command's wall and last line;
the chosen drive (and steering) motor and ratio; for the chosen (or the best) drive its screen and loop coverage and
their difference in points; the share of variants not simulated and why; the steering group the session sized and
its requirement sheet at the hinge; from verdicts.parquet, over every run in the loop, how many were unstable and
the steering error's p99. What the issue asks: each session ends with a motor, or with none for reasons that are the
motor's; the chosen (or best) motor's screen and loop within 2 points; not simulated at most 0.5%.

`--section` writes the sessions under that key of the JSON, beside the others there (default 'sessions'), with
`--note` saying what the tree was (a run on a tree with a change not committed, say).
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

from batchveh.sizing import best_in_loop

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
JSON = ROOT / "validation" / "results" / "sizing_layouts.json"
VEHICLES = ("skid_robot", "front_rover", "campus_robot")
NOT_SIMULATED_MAX = 0.005  # the bound: share of the variants
AGREE_POINTS = 2.0  # the chosen motor's screen and loop coverage, points apart


def size(name: str, out: Path) -> dict:
    spec = ROOT / "sweeps" / f"{name}.yaml"
    folder = out / name
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "batchveh.size", str(spec), "--catalogue", str(CATALOGUE), "--out", str(folder),
         "--quiet", "--overwrite"],
        cwd=ROOT, capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"},
    )  # fmt: skip
    wall = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(f"{name}: exit {done.returncode}: {done.stderr[-2000:]}")
    s = json.loads((folder / "sizing.json").read_text())
    loop = pd.DataFrame(s["loop"])
    screen = pd.DataFrame(s["screen"]).set_index("motor")
    focus = s["chosen"] or best_in_loop(loop)
    row = loop.set_index("motor").loc[focus]
    v = pd.read_parquet(folder / "verdicts.parquet")
    err = v["steer_track_err_deg"].to_numpy(float)
    n = int(s["variants"])
    steer_sheet = (s["requirements"] or {}).get("steer")
    points = round(100 * abs(float(screen.loc[focus, "coverage"]) - float(row["coverage"])), 2)
    return {
        "spec": str(spec.relative_to(ROOT)),
        "layout": s.get("layout", "four_wheel"),
        "steering": s.get("steering", "four-wheel steering: four steering motors (every hub steers)"),
        "steering_motors": s.get("steering_motors", ["steer_lf", "steer_rf", "steer_lr", "steer_rr"]),
        "share": s["share"],
        "variants": n,
        "wall_s": round(wall, 1),
        "last_line": done.stdout.strip().splitlines()[-1],
        "chosen": s["chosen"],
        "drive_ratio": float(row["gear_ratio"]) if s["chosen"] else None,
        "steer": s["steer"],
        "steer_ratio": _ratio(s),
        "focus": focus,
        "screen_coverage": float(screen.loc[focus, "coverage"]),  # over the variants its loop judged
        "screen_coverage_every_variant": next(
            (w["chosen_coverage"] for w in s["windows"] or [] if w["chosen"] == focus), None
        ),
        "loop_coverage": float(row["coverage"]),
        "points_apart": points,
        "not_simulated": int(row["not_simulated"]),
        "not_simulated_share": int(row["not_simulated"]) / n,
        "not_simulated_why": row["not_simulated_why"],
        "loop_fails": {k.removeprefix("fails_"): int(row[k]) for k in row.index if k.startswith("fails_") and row[k]},
        "steer_misses": int(row["steer_misses"]),
        "candidates_run": list(loop["motor"]),
        "steering_runs": [(r["steer"], r["drive"], r["steer_coverage"]) for r in s["steer_loop"] or []],
        "every_run_in_the_loop": {
            "runs": len(v),
            "unstable": int((v["motor_status"] == "unstable").sum()),
            "steer_err_deg_p99": float(np.percentile(err, 99)),
            "steer_err_deg_max": float(err.max()),
        },
        "sheet_at_wheel": {k: round(f["value"], 4) for k, f in s["requirements"]["drive"]["at_wheel"].items()},
        "steer_sheet_at_hinge": None
        if steer_sheet is None
        else {k: round(f["value"], 4) for k, f in steer_sheet["at_wheel"].items()},
        "figures": s["figures"],
        "wall_phases_s": s["wall_s"],
        "checks": {
            "ends_with_a_motor": s["chosen"] is not None,
            "within_2_points": points <= AGREE_POINTS,
            "not_simulated_within_0.5%": int(row["not_simulated"]) / n <= NOT_SIMULATED_MAX,
        },
    }


def _ratio(s: dict) -> float | None:
    """The steering motor's gear ratio, from the steering's screen table (None: no steering motor)."""
    rows = [r for r in s["steer_screen"] or [] if r["motor"] == s["steer"]]
    return float(rows[0]["gear_ratio"]) if rows else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "sizing_layouts"))
    ap.add_argument("--only", nargs="*", choices=VEHICLES)
    ap.add_argument("--json", default=str(JSON), help="the JSON to write (default: validation/results/...)")
    ap.add_argument("--section", default="sessions", help="the JSON's key the sessions go under")
    ap.add_argument("--note", default="", help="what the tree was, written beside the section")
    args = ap.parse_args()
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    got = {name: size(name, out) for name in (args.only or VEHICLES)}
    print(f"{'vehicle':14} {'layout':10} {'chosen':40} {'steering':42} {'screen':>7} {'loop':>7} {'apart':>6} "
          f"{'not sim':>7} {'wall':>6}")  # fmt: skip
    for name, r in got.items():
        print(f"{name:14} {r['layout']:10} {str(r['chosen']):40} {str(r['steer']):42} {r['screen_coverage']:7.1%} "
              f"{r['loop_coverage']:7.1%} {r['points_apart']:6.2f} {r['not_simulated_share']:7.2%} "
              f"{r['wall_s']:6.1f}")  # fmt: skip
    path = Path(args.json)
    old = json.loads(path.read_text()) if path.exists() else {}
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    section = {"commit": commit or None, "note": args.note, "date": str(date.today()), "vehicles": got}
    doc = {
        "what": __doc__.split("\n\n")[0],
        "machine": f"{platform.machine()}, {os.cpu_count()} CPUs (this project's 2-core machine)",
        "catalogue": "notebooks/motors.yaml",
        "bounds": {"not_simulated_share_max": NOT_SIMULATED_MAX, "agree_points": AGREE_POINTS},
        **{k: v for k, v in old.items() if k not in ("what", "machine", "catalogue", "bounds")},
        args.section: section,
    }
    path.write_text(json.dumps(doc, indent=1, default=str) + "\n")


if __name__ == "__main__":
    main()
