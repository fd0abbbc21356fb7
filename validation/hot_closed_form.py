"""The loop's hot run in closed form (issue 52) against running it: `in_loop` with the size command's motors, by
default (the hot run in closed form from the cold one, run only where that cannot say) and with `closed=False`
(every variant run hot, the two runs it replaced), on the same servo rows. Per column the largest and the p99
|difference| over the variants, the peaks' signed range (the closed form's is an upper bound), every verdict column
compared, the variants run hot, and the loop's walls.

    python validation/hot_closed_form.py                        # MuJoCo C, this machine: 400 conditions a vehicle
    python validation/hot_closed_form.py --backend warp --n 20000 --cases seed robot agv --label h100 --floor

Writes validation/results/hot_closed_form.json (MuJoCo C) or hot_closed_form-LABEL.json. The vehicles: the seed
(benchmarks/slope_100k.yaml, the drive at the 90% share the benchmark sizes at), the 60-80 kg robot with friction
swept, the 30 kg robot and the 250 kg AGV (their motors as the size command chose them:
validation/results/sizing_vehicles.json), each drawn at --n LHS conditions.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from datetime import date
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
CASES = {  # spec, drive, steering
    "seed": ("benchmarks/slope_100k.yaml", "maxon-353297-48V_NPT025-i28", "maxon-353297-48V_NPT025-i40"),
    "robot": ("sweeps/delivery_robot.yaml", "faulhaber-3863H048CR_NPT015-i28", "faulhaber-3863H048CR_NPT015-i28"),
    "robot_30kg": ("sweeps/robot_30kg.yaml", "faulhaber-3863H048CR_NPT015-i28", "faulhaber-3564K024B_NPT015-i40"),
    "agv": ("sweeps/warehouse_agv.yaml", "maxon-353297-48V_NPT025-i28", "maxon-578298-RE50-48V_GP52C-i26"),
}
VERDICTS = ("fails_", "steer_fails_", "where", "judged", "motor_status")


def spec_of(name: str, n: int, folder: Path):
    """The case's spec at n LHS conditions (the robot with friction swept too), written into folder."""
    import batchveh

    raw = yaml.safe_load((ROOT / CASES[name][0]).read_text())
    if name == "robot":
        raw["fixed"].pop("friction", None)
        raw["sweep"]["params"]["friction"] = {"low": 0.4, "high": 0.9}
    raw["name"], raw["output"] = f"{name}_{n}", str(folder / "results")
    raw["sweep"]["method"], raw["sweep"]["n"] = "lhs", n
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return batchveh.load_spec(path)


def compare(a: pd.DataFrame, b: pd.DataFrame) -> dict:
    """The closed form's detail `a` against every variant run hot `b`, column by column."""
    numbers, verdicts = {}, {}
    for col in a.columns:
        x, y = a[col], b[col]
        if col.startswith(VERDICTS) or not pd.api.types.is_numeric_dtype(x) or pd.api.types.is_bool_dtype(x):
            differ = int((x.astype(str).to_numpy() != y.astype(str).to_numpy()).sum())
            if col.startswith(VERDICTS) or differ:
                verdicts[col] = differ
            continue
        d = x.to_numpy(float) - y.to_numpy(float)
        d = d[np.isfinite(d)]
        if len(d) and np.abs(d).max() > 0:
            numbers[col] = {"max": float(np.abs(d).max()), "p99": float(np.quantile(np.abs(d), 0.99)),
                            "min_signed": float(d.min())}  # fmt: skip
    return {"numbers": numbers, "verdict_rows_differing": verdicts}


def family(numbers: dict) -> dict:
    """Per kind of column (the motor's name dropped), the largest max, p99 and least signed difference."""
    out: dict = {}
    for col, v in numbers.items():
        key = col.split("_", 2)[2] if col.startswith(("drive_", "steer_")) else col
        key = ("drive " if col.startswith("drive_") else "steer " if col.startswith("steer_") else "") + key
        o = out.setdefault(key, {"max": 0.0, "p99": 0.0, "min_signed": 0.0})
        o["max"], o["p99"] = max(o["max"], v["max"]), max(o["p99"], v["p99"])
        o["min_signed"] = min(o["min_signed"], v["min_signed"])
    return out


def measure(name: str, n: int, backend: str | None, folder: Path, floor: bool = False) -> dict:
    import batchveh
    from batchveh.size import servo_spec
    from batchveh.sizing import in_loop
    from batchveh.sweep import run_sweep

    _, drive, steer = CASES[name]
    folder.mkdir(parents=True, exist_ok=True)
    spec = spec_of(name, n, folder)
    run_sweep(servo_spec(spec, folder), out=folder / "servo", backend=backend, resume=True, progress=False)
    df = batchveh.load(folder / "servo")
    got, walls = {}, {}
    for closed in (True, False, None) if floor else (True, False):  # None: every variant hot once more
        t0 = time.perf_counter()
        _, table, detail = in_loop(spec, df, CATALOGUE, [drive], steer=steer, share=0.9, duty=spec.duty,
                                   backend=backend, closed=bool(closed))  # fmt: skip
        walls[{True: "closed", False: "every variant hot", None: "every variant hot again"}[closed]] = round(
            time.perf_counter() - t0, 1
        )
        got[closed] = (table.iloc[0], detail[drive])
    (t_c, d_c), (t_h, d_h) = got[True], got[False]
    diff = compare(d_c, d_h)
    noise = {}
    if floor:  # two runs of the same variants: what the engine's own run-to-run differences are (a GPU's)
        again = compare(got[None][1], d_h)
        noise = {"verdict_rows_differing": again["verdict_rows_differing"],
                 "differences_by_kind": family(again["numbers"])}  # fmt: skip
    return {
        "spec": CASES[name][0], "conditions": len(df), "drive": drive, "steer": steer,
        "run_hot": int(t_c["hot_runs"]),
        "coverage": {"closed": float(t_c["coverage"]), "every variant hot": float(t_h["coverage"])},
        "steer_misses": {"closed": int(t_c["steer_misses"]), "every variant hot": int(t_h["steer_misses"])},
        "start_rise_median": {"closed": float(t_c["start_rise_median"]),
                              "every variant hot": float(t_h["start_rise_median"])},
        "residual_K": {"closed": float(t_c["residual_K"]), "every variant hot": float(t_h["residual_K"])},
        "verdict_rows_differing": diff["verdict_rows_differing"],
        "differences_by_kind": family(diff["numbers"]),
        "loop_wall_s": walls,
        **({"floor_every_variant_hot_twice": noise} if floor else {}),
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=sorted(CASES))
    ap.add_argument("--n", type=int, default=400)
    ap.add_argument("--backend", choices=("mujoco", "warp"), default="mujoco")
    ap.add_argument("--label", default="", help="machine label: the JSON's name gets -LABEL")
    ap.add_argument("--out", default="/tmp/hot_closed_form")
    ap.add_argument("--floor", action="store_true", help="also every variant hot twice: the engine's own noise")
    ap.add_argument("--json", help="default: validation/results/hot_closed_form[-LABEL].json")
    args = ap.parse_args()
    backend = None if args.backend == "mujoco" else args.backend
    cases = {}
    for name in args.cases:
        cases[name] = measure(name, args.n, backend, Path(args.out) / f"{name}-{args.n}-{args.backend}", args.floor)
        c = cases[name]
        peak = c["differences_by_kind"].get("drive winding_temp_peak", {})
        print(
            f"{name:11} {c['conditions']:6} run hot {c['run_hot']:5}  verdict rows differing "
            f"{sum(c['verdict_rows_differing'].values()):3}  drive peak {peak.get('min_signed', 0):+.3g}.."
            f"{peak.get('max', 0):.3g} K (p99 {peak.get('p99', 0):.3g})  walls {c['loop_wall_s']}",
            flush=True,
        )
    suffix = f"-{args.label}" if args.label else ""
    path = Path(args.json or ROOT / "validation" / "results" / f"hot_closed_form{suffix}.json")
    path.write_text(json.dumps({
        "what": __doc__.split("\n\n")[0], "date": str(date.today()), "backend": args.backend,
        "machine": {"label": args.label or "this machine", "cpus": os.cpu_count(), "python": platform.python_version()},
        "cases": cases,
    }, indent=1) + "\n")  # fmt: skip
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
