"""How long does the screen take with every (motor, ratio) of the catalogue? Issue 61: the screen of
notebooks/motors.yaml's gearhead series at 100,000 conditions, beside its peer in the same run, the screen of the
catalogue's paired entries alone (the nine motor+gearhead pairings the size command screened before, in detail),
and the windows. As the size command screens: every pair's counts (`screen(detail=False)`), the windows, then each
motor's chosen ratio again in detail; the time of all three is the row's.

    python benchmarks/screen_ratios.py SERVO_FOLDER --spec sweeps/delivery_robot.yaml --n 100000 --label cpu-2core

SERVO_FOLDER: a servo sweep's results (e.g. a size session's OUT/servo), its rows tiled to --n. The screen reads
what the size command gives it (the ramp, the rotor's acceleration, the spec's duty) at --share. Each is timed
--repeat times, in one process, alternating; the JSON (benchmarks/results/LABEL-screen-ratios-N.json) gives every
time, the median and the ratio of the medians.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import time
from datetime import date
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "notebooks" / "motors.yaml"


def main() -> None:
    import batchveh
    from batchveh.model.motors import load_catalogue
    from batchveh.sizing import screen
    from batchveh.sizing.ramps import ramp_of, wheel_accel
    from batchveh.sizing.windows import windows

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("servo")
    ap.add_argument("--spec", default=str(ROOT / "sweeps" / "delivery_robot.yaml"))
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--share", type=float, default=0.99)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--label", default="cpu")
    args = ap.parse_args()
    spec = batchveh.load_spec(args.spec)
    rows = batchveh.load(args.servo)
    df = pd.concat([rows] * (-(-args.n // len(rows))), ignore_index=True).iloc[: args.n].reset_index(drop=True)
    full = load_catalogue(CATALOGUE)
    paired = {k: m for k, m in full.items() if not m.series}
    kw = dict(share=args.share, armature=spec.vehicle.motors.armature, accel=wheel_accel(spec, df),
              ramp=ramp_of(spec, df), duty=spec.duty, params=list(spec.params))  # fmt: skip
    times: dict[str, list[float]] = {"every (motor, ratio)": [], "paired entries only": [], "windows": []}
    for _ in range(args.repeat):
        # as the size command: every pair's counts, the windows, each motor's chosen ratio again in detail
        t0 = time.perf_counter()
        _, table, _ = screen(df, full, detail=False, **kw)
        t1 = time.perf_counter()
        wins = windows(table, full, args.share)
        t2 = time.perf_counter()
        screen(df, {name: full[name] for name in wins["chosen"]}, **kw)
        times["every (motor, ratio)"].append(time.perf_counter() - t0)
        times["windows"].append(t2 - t1)
        t0 = time.perf_counter()
        screen(df, paired, **kw)  # the nine pairings in detail, as the size command screened them before
        times["paired entries only"].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    out = {
        "what": __doc__.split("\n\n")[0],
        "date": str(date.today()),
        "commit": subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip(),
        "machine": f"{platform.machine()}, {os.cpu_count()} CPUs",
        "conditions": args.n,
        "servo_rows": len(rows),
        "pairs": {"every (motor, ratio)": len(full), "paired entries only": len(paired)},
        "motors": len({m.motor_name for m in full.values()}),
        "times_s": times,
        "median_s": med,
        "ratio_of_medians": med["every (motor, ratio)"] / med["paired entries only"],
        "per_pair_ms": {
            k: 1000 * med[k] / len(c) for k, c in (("every (motor, ratio)", full), ("paired entries only", paired))
        },
    }
    path = ROOT / "benchmarks" / "results" / f"{args.label}-screen-ratios-{args.n}.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    for k, v in times.items():
        print(f"{k:24} median {med[k]:7.2f} s  ({', '.join(f'{x:.2f}' for x in v)})")
    print(f"ratio of medians {out['ratio_of_medians']:.2f}x; {path.relative_to(ROOT)}")
    assert np.isfinite(out["ratio_of_medians"])


if __name__ == "__main__":
    main()
