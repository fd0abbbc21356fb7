"""The loop's candidates as one batch (issue 52): `python -m batchveh.size` against the sequential path it replaced (one
candidate at a time, as at commit 99dbea3), on the same conditions. Writes validation/results/batched_loop.json.

    git worktree add /tmp/sequential 99dbea3
    python validation/batched_loop.py --sequential /tmp/sequential [--out DIR]

Per vehicle, both trees run the command in a fresh folder (MuJoCo C, this machine), and the script compares:
the chosen drive and steering motors; every row of verdicts.parquet (the same variants and motors; the booleans and
the reason strings equal; the numbers within 1e-9 relative); the loop's table (coverage, not simulated, each reason's
count, the hot start's median and residual); and each command's wall. What the issue asks: every row and choice
equal, or each difference explained.
The vehicles: issue 51's sidewalk robot (sweeps/sidewalk_robot.yaml, 400 LHS conditions), the 180-300 kg AGV
(sweeps/warehouse_agv.yaml drawn at 400 conditions, the spec written into --out) and the AGV's duty cycle
(sweeps/agv_mission.yaml, its 48 conditions).
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

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
JSON = ROOT / "validation" / "results" / "batched_loop.json"
SEQUENTIAL_COMMIT = "99dbea3"
VEHICLES = ("sidewalk_robot", "warehouse_agv_400", "agv_mission")
RTOL = 1e-9


def spec_path(name: str, out: Path) -> Path:
    if name != "warehouse_agv_400":
        return ROOT / "sweeps" / f"{name}.yaml"
    raw = yaml.safe_load((ROOT / "sweeps" / "warehouse_agv.yaml").read_text())
    raw["name"], raw["sweep"]["n"] = name, 400
    raw["output"] = str(out / name / "results")
    path = out / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def size(tree: Path, spec: Path, folder: Path) -> tuple[float, str]:
    """The command from the source tree `tree` in a fresh process: (wall, last line)."""
    t0 = time.perf_counter()
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(tree)}
    done = subprocess.run(
        [sys.executable, "-m", "batchveh.size", str(spec), "--catalogue", str(CATALOGUE), "--out", str(folder),
         "--quiet", "--overwrite"],
        cwd=tree, capture_output=True, text=True, env=env,
    )  # fmt: skip
    wall = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(f"{spec.name} ({tree}): exit {done.returncode}: {done.stderr[-2000:]}")
    return wall, done.stdout.strip().splitlines()[-1]


def differences(a: pd.DataFrame, b: pd.DataFrame) -> dict[str, str]:
    """Column by column, where two frames of the same rows differ: {column: what}."""
    out = {}
    for col in sorted(set(a) | set(b)):
        if col not in a or col not in b:
            out[col] = "only in " + ("the batch" if col in b else "the sequential")
            continue
        x, y = a[col], b[col]
        if pd.api.types.is_numeric_dtype(x) and not pd.api.types.is_bool_dtype(x):
            xa, ya = x.to_numpy(float), y.to_numpy(float)
            same = np.isclose(xa, ya, rtol=RTOL, atol=0.0) | (np.isnan(xa) & np.isnan(ya))
            if not same.all():
                out[col] = f"{int((~same).sum())} rows, largest |diff| {float(np.nanmax(np.abs(xa - ya))):.3g}"
        elif not (x.astype(str).to_numpy() == y.astype(str).to_numpy()).all():
            out[col] = f"{int((x.astype(str).to_numpy() != y.astype(str).to_numpy()).sum())} rows"
    return out


def compare(name: str, sequential: Path, out: Path) -> dict:
    spec = spec_path(name, out)
    walls, lines, got = {}, {}, {}
    for label, tree in (("sequential", sequential), ("batch", ROOT)):
        folder = out / name / label
        walls[label], lines[label] = size(tree, spec, folder)
        got[label] = (json.loads((folder / "sizing.json").read_text()), pd.read_parquet(folder / "verdicts.parquet"))
    (s_sum, s_v), (b_sum, b_v) = got["sequential"], got["batch"]
    key = ["motor", "variant"]
    # the motors both ran; one the sequential path ran and the batch not: the batch's report says why
    both = sorted(set(s_v["motor"]) & set(b_v["motor"]))
    only = {m: b_sum["not_run"].get(m, "?") for m in sorted(set(s_v["motor"]) - set(b_v["motor"]))}
    only_batch = sorted(set(b_v["motor"]) - set(s_v["motor"]))
    s_v = s_v[s_v["motor"].isin(both)].sort_values(key).reset_index(drop=True)
    b_v = b_v[b_v["motor"].isin(both)].sort_values(key).reset_index(drop=True)
    same_rows = len(s_v) == len(b_v) and (s_v[key].to_numpy() == b_v[key].to_numpy()).all()
    loop_cols = ["motor", "coverage", "judged", "not_simulated", "steer", "steer_misses", "start_rise_median",
                 "residual_K"]  # fmt: skip
    s_loop, b_loop = pd.DataFrame(s_sum["loop"]), pd.DataFrame(b_sum["loop"])
    s_loop = s_loop[s_loop["motor"].isin(both)].reset_index(drop=True)
    b_loop = b_loop[b_loop["motor"].isin(both)].reset_index(drop=True)
    reasons = [c for c in s_loop if c.startswith(("fails_", "steer_fails_"))]
    return {
        "spec": str(spec.relative_to(ROOT)) if spec.is_relative_to(ROOT) else spec.name,
        "variants": int(b_sum["variants"]),
        "chosen": {"sequential": s_sum["chosen"], "batch": b_sum["chosen"]},
        "steer": {"sequential": s_sum["steer"], "batch": b_sum["steer"]},
        "choices_equal": s_sum["chosen"] == b_sum["chosen"] and s_sum["steer"] == b_sum["steer"],
        "motors_in_both": both,
        "run_by_the_sequential_path_only": only,  # {motor: why the batch did not run it (its report)}
        "run_by_the_batch_only": only_batch,
        "verdict_rows_compared": {"sequential": len(s_v), "batch": len(b_v)},
        "verdict_rows_same_variants_and_motors": bool(same_rows),
        "verdict_differences": differences(s_v, b_v) if same_rows else "rows differ",
        "loop_differences": differences(s_loop[loop_cols + reasons], b_loop[loop_cols + reasons])
        if len(s_loop) == len(b_loop)
        else "rows differ",
        "loop": b_loop[["motor", "coverage", "not_simulated", "residual_K"]].to_dict("records"),
        "wall_s": {k: round(v, 1) for k, v in walls.items()},
        "phases_s": {"sequential": s_sum["wall_s"], "batch": b_sum["wall_s"]},
        "last_line": lines["batch"],
    }


def layout_effect(out: Path) -> dict:
    """What a variant's numbers move by when only its batch's size changes (MuJoCo C, one motor, from ambient):
    the sidewalk robot's 400 servo rows run alone and as the first half of the same rows twice; per column the
    largest |difference|. The batch's differences from the sequential path are of this kind and size."""
    import batchveh
    from batchveh.sizing import in_loop

    spec = batchveh.load_spec(ROOT / "sweeps" / "sidewalk_robot.yaml")
    df = batchveh.load(out / "sidewalk_robot" / "batch" / "servo")
    motor = "faulhaber-3863H048CR_NPT015-i28"
    _, _, alone = in_loop(spec, df, CATALOGUE, [motor], steer=motor, hot=False)
    _, _, twice = in_loop(spec, pd.concat([df, df], ignore_index=True), CATALOGUE, [motor], steer=motor, hot=False)
    a, b = alone[motor], twice[motor].iloc[: len(df)].reset_index(drop=True)
    num = [c for c in a if pd.api.types.is_numeric_dtype(a[c]) and not pd.api.types.is_bool_dtype(a[c])]
    diff = {c: float(np.nanmax(np.abs(a[c].to_numpy(float) - b[c].to_numpy(float)))) for c in num}
    moved = {c: v for c, v in diff.items() if v > 0}
    return {
        "variants": len(df),
        "columns_compared": len(num),
        "columns_that_move": len(moved),
        "largest_abs": max(moved.values(), default=0.0),
        "steer_track_err_deg_abs": diff.get("steer_track_err_deg", 0.0),
        "booleans_and_strings_equal": all(
            (a[c].astype(str).to_numpy() == b[c].astype(str).to_numpy()).all() for c in a if c not in num
        ),
    }


def two_in_one_batch(out: Path) -> dict:
    """Two drives in one batch against each alone (`in_loop`, MuJoCo C, hot): the sidewalk robot's 400 servo rows
    with the Faulhaber 3564K024B and 3863H048CR (the two the sequential path ran). Per motor: its verdict booleans
    (fails_<reason>, steer_fails_<reason>, judged) equal, its coverage and hot start equal, and the largest
    |difference| of any number (the engine's batch-layout effect, `layout_effect`)."""
    import batchveh
    from batchveh.sizing import in_loop

    spec = batchveh.load_spec(ROOT / "sweeps" / "sidewalk_robot.yaml")
    df = batchveh.load(out / "sidewalk_robot" / "batch" / "servo")
    pair = ["faulhaber-3564K024B_NPT015-i40", "faulhaber-3863H048CR_NPT015-i28"]
    _, table, together = in_loop(spec, df, CATALOGUE, pair, steer=pair[1], stop_at_first=False)
    got = {}
    for name in pair:
        _, alone_table, alone = in_loop(spec, df, CATALOGUE, [name], steer=pair[1])
        a, b = together[name], alone[name]
        flags = [c for c in a if c.startswith(("fails_", "steer_fails_")) or c == "judged"]
        num = [c for c in a if pd.api.types.is_numeric_dtype(a[c]) and not pd.api.types.is_bool_dtype(a[c])]
        row, one = table.set_index("motor").loc[name], alone_table.iloc[0]
        got[name] = {
            "verdict_flags_equal": bool((a[flags].to_numpy() == b[flags].to_numpy()).all()),
            "coverage": [float(row["coverage"]), float(one["coverage"])],
            "start_rise_median_K": [float(row["start_rise_median"]), float(one["start_rise_median"])],
            "largest_abs_number_difference": float(
                max(np.nanmax(np.abs(a[c].to_numpy(float) - b[c].to_numpy(float))) for c in num)
            ),
        }
    return got


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sequential", required=True, help=f"a checkout of {SEQUENTIAL_COMMIT} (git worktree add)")
    ap.add_argument("--out", default=str(ROOT / "results" / "batched_loop"))
    ap.add_argument("--only", nargs="*", choices=VEHICLES)
    args = ap.parse_args()
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    got = {name: compare(name, Path(args.sequential).resolve(), out) for name in (args.only or VEHICLES)}
    for name, r in got.items():
        print(f"{name:20} chosen {r['chosen']['batch']} (sequential {r['chosen']['sequential']}); verdict rows "
              f"{r['verdict_rows_compared']['batch']}/{r['verdict_rows_compared']['sequential']} of "
              f"{r['motors_in_both']}, differences "
              f"{r['verdict_differences'] or 'none'}; loop {r['loop_differences'] or 'the same'}; wall "
              f"{r['wall_s']['batch']} s against {r['wall_s']['sequential']} s; sequential only: "
              f"{r['run_by_the_sequential_path_only']}")  # fmt: skip
    if args.only:
        return
    JSON.write_text(
        json.dumps(
            {
                "what": __doc__.split("\n\n")[0],
                "date": str(date.today()),
                "machine": f"this project's {os.cpu_count()}-core machine ({platform.machine()}), MuJoCo C",
                "sequential_commit": SEQUENTIAL_COMMIT,
                "rtol": RTOL,
                "vehicles": got,
                "engine_layout_effect": layout_effect(out),
                "two_drives_in_one_batch": two_in_one_batch(out),
            },
            indent=1,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
