"""The hot start in closed form (issue 52) against the three runs it replaced: per variant, the chosen motor's
hottest winding over its last run in the loop (the thermal verdict's temperature), from both, on three vehicles
unlike each other. MuJoCo C on this machine.

    PYTHONPATH=OLD python validation/hot_start.py record BASE.json  # OLD: a checkout of the three runs (c6aa6fe)
    python validation/hot_start.py compare BASE.json                # this code: validation/results/hot_start.json

Each case: the spec's variants (its first --limit), the drive and steering motor the size command chose there.
"""

import argparse
import json
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
OUT = ROOT / "validation" / "results" / "hot_start.json"
CASES = {  # spec, drive, steering, variants
    "sidewalk_robot": ("sweeps/sidewalk_robot.yaml", "faulhaber-3863H048CR_NPT015-i28",
                       "faulhaber-3564K024B_NPT015-i40", 100),
    "robot_mission": ("sweeps/robot_mission.yaml", "maxon-578298-RE50-48V_GP52C-i26",
                      "maxon-353297-48V_NPT025-i28", 48),
    "agv_mission": ("sweeps/agv_mission.yaml", "maxon-353297-48V_NPT025-i28", "maxon-353297-48V_NPT025-i40", 48),
}  # fmt: skip
WHEELS = ("lf", "rf", "lr", "rr")


def measure(name: str) -> dict:
    import batchveh
    from batchveh.size import servo_spec
    from batchveh.sizing import in_loop
    from batchveh.sweep import run_sweep

    path, drive, steer, n = CASES[name]
    spec = batchveh.load_spec(ROOT / path)
    servo = Path("/tmp/hot_start") / name
    run_sweep(servo_spec(spec, servo), out=servo / "servo", resume=True, limit=n, progress=False)
    df = batchveh.load(servo / "servo")
    t0 = time.perf_counter()
    _, table, detail = in_loop(spec, df, ROOT / CATALOGUE, [drive], steer=steer, share=0.99, duty=spec.duty)
    wall = time.perf_counter() - t0
    d = detail[drive]
    peak = d[[f"drive_{c}_winding_temp_peak" for c in WHEELS]].max(axis=1).to_numpy(float)
    end = d[[f"drive_{c}_winding_temp_end" for c in WHEELS]].max(axis=1).to_numpy(float)
    steer_peak = d[[f"steer_{c}_winding_temp_peak" for c in WHEELS]].max(axis=1).to_numpy(float)
    row = table.iloc[0]
    return {"drive": drive, "steer": steer, "variants": len(df), "runs": int(row["runs"]),
            "residual_K": float(row["residual_K"]), "loop_wall_s": round(wall, 1),
            "drive_winding_peak": peak.tolist(), "drive_winding_end": end.tolist(),
            "steer_winding_peak": steer_peak.tolist(), "coverage": float(row["coverage"])}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mode", choices=["record", "compare"])
    ap.add_argument("base")
    args = ap.parse_args()
    import batchveh

    got = {name: measure(name) for name in CASES}
    code = Path(batchveh.__file__).resolve().parent.parent  # the checkout whose batchveh ran (PYTHONPATH may differ)
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=code, capture_output=True, text=True).stdout.strip()
    if args.mode == "record":
        Path(args.base).write_text(json.dumps({"commit": commit, "cases": got}))
        return
    base = json.loads(Path(args.base).read_text())
    rows = {}
    print(f"{'case':16} {'runs':>9} {'drive |dT| p50/p99/max K':>28} {'steer max K':>12} {'loop wall s':>14}")
    for name, new in got.items():
        old = base["cases"][name]
        dd = np.abs(np.subtract(new["drive_winding_peak"], old["drive_winding_peak"]))
        ds = np.abs(np.subtract(new["steer_winding_peak"], old["steer_winding_peak"]))
        rows[name] = {
            "spec": CASES[name][0], "drive": new["drive"], "steer": new["steer"], "variants": new["variants"],
            "runs": [old["runs"], new["runs"]], "loop_wall_s": [old["loop_wall_s"], new["loop_wall_s"]],
            "residual_K": [old["residual_K"], new["residual_K"]], "coverage": [old["coverage"], new["coverage"]],
            "drive_peak_rise_max_K": float(np.max(np.subtract(new["drive_winding_peak"], 25.0))),
            "drive_dT_K": {"p50": float(np.percentile(dd, 50)), "p99": float(np.percentile(dd, 99)),
                           "max": float(dd.max())},
            "steer_dT_max_K": float(ds.max()),
        }  # fmt: skip
        r = rows[name]
        dt = r["drive_dT_K"]
        print(f"{name:16} {old['runs']:>4} -> {new['runs']:<2} {dt['p50']:8.3f} {dt['p99']:8.3f} {dt['max']:8.3f} "
              f"{r['steer_dT_max_K']:12.3f} {old['loop_wall_s']:6.1f} -> {new['loop_wall_s']:<6.1f}")  # fmt: skip
    OUT.write_text(json.dumps({
        "what": __doc__.split("\n\n")[0], "date": time.strftime("%Y-%m-%d"), "commit": commit,
        "base_commit": base["commit"], "machine": f"{platform.machine()}, 2 CPUs (this project's 2-core machine)",
        "bound_K": 0.5, "cases": rows}, indent=1))  # fmt: skip
    print(f"written: {OUT}")


if __name__ == "__main__":
    sys.exit(main())
