"""Sizing in one command (issue 45), what it shows: a new user's vehicle from an empty folder to the report, timed,
and on the seed's main job restricted to 500 variants, the command's choice against the screen and in-the-loop
functions called by hand on the same rows. Writes validation/results/size_checks.json.

    python validation/size_checks.py [--out DIR]

1. `python -m batchveh.size sweeps/delivery_robot.yaml --catalogue notebooks/motors.yaml` in a fresh folder
   (400 variants of a 60 kg robot on 0.10 m wheels), as a user runs it: the process's wall time and its last line.
2. `python -m batchveh.size sweeps/slope.yaml --catalogue notebooks/motors.yaml --limit 500 --share 0.9` (no
   catalogue motor covers 99% of them), then by hand:
   `screen` on the servo rows it wrote, and `in_loop` from the motor next below the screen's choice upwards.
"""

import argparse
import json
import os
import subprocess
import sys
import time
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "notebooks" / "motors.yaml"


def run(spec: Path, out: Path, *extra: str) -> tuple[float, str]:
    """The command in a fresh process: (wall time, its last line)."""
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "batchveh.size", str(spec), "--catalogue", str(CATALOGUE), "--out", str(out),
         "--quiet", *extra],
        cwd=ROOT, capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"},
    )  # fmt: skip
    wall = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(f"{spec.name}: exit {done.returncode}: {done.stderr[-2000:]}")
    return wall, done.stdout.strip().splitlines()[-1]


SLOPE_SHARE = "0.9"  # on the main job's first 500 variants no catalogue motor covers 99% (the screen's best: 94.6%)


def by_hand(spec_path: Path, out: Path, share: float = 0.99) -> str | None:
    """The screen and the loop called by hand on the servo rows the command wrote."""
    import batchveh
    from batchveh.sizing import in_loop, screen
    from batchveh.sizing.plan import candidates
    from batchveh.sizing.ramps import ramp_of, wheel_accel

    spec = batchveh.load_spec(spec_path)
    df = batchveh.load(out / "servo")
    cat = batchveh.load_catalogue(CATALOGUE)
    arm, accel, ramp = spec.vehicle.motors.armature, wheel_accel(spec, df), ramp_of(spec, df)
    best, table, _ = screen(df, cat, share=share, armature=arm, accel=accel, duty=spec.duty, ramp=ramp)
    steer = json.loads((out / "sizing.json").read_text())["steer"]
    for name in candidates(table, best):
        got, _, _ = in_loop(spec, df, CATALOGUE, [name], steer=steer, share=share)
        if got is not None:
            return got
    return None


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default="/tmp/size_checks")
    args = p.parse_args()
    out = Path(args.out)
    if out.exists():
        raise SystemExit(f"{out} exists: give another --out")
    robot_wall, robot_line = run(ROOT / "sweeps" / "delivery_robot.yaml", out / "robot")
    robot = json.loads((out / "robot" / "sizing.json").read_text())
    print(f"robot, 400 variants: {robot_wall:.1f} s\n  {robot_line}")
    slope_wall, slope_line = run(
        ROOT / "sweeps" / "slope.yaml", out / "slope", "--limit", "500", "--share", SLOPE_SHARE
    )
    command = json.loads((out / "slope" / "sizing.json").read_text())["chosen"]
    t0 = time.perf_counter()
    hand = by_hand(ROOT / "sweeps" / "slope.yaml", out / "slope", float(SLOPE_SHARE))
    hand_wall = time.perf_counter() - t0
    print(f"slope, 500 variants: {slope_wall:.1f} s; the command chose {command}, by hand {hand} ({hand_wall:.1f} s)")
    result = {
        "date": str(date.today()),
        "machine": f"this project's 2-core machine ({os.cpu_count()} CPUs)",
        "robot": {"variants": robot["variants"], "wall_s": robot_wall, "line": robot_line, "chosen": robot["chosen"],
                  "steer": robot["steer"], "phases_s": robot["wall_s"],
                  "loop": [{k: r[k] for k in ("motor", "coverage", "not_simulated")} for r in robot["loop"]],
                  "screen": [{k: r[k] for k in ("motor", "coverage")} for r in robot["screen"]]},
        "slope_500": {"share": float(SLOPE_SHARE), "wall_s": slope_wall, "line": slope_line,
                      "command_chose": command, "by_hand": hand,
                      "equal": command == hand, "by_hand_s": hand_wall},
    }  # fmt: skip
    path = ROOT / "validation" / "results" / "size_checks.json"
    path.write_text(json.dumps(result, indent=1) + "\n")
    print(f"written: {path}")


if __name__ == "__main__":
    main()
