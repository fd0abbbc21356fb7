"""The main job with each wheel-ground model, side by side in one run, on this machine's CPU.

    python benchmarks/tyres_cpu.py                    # sweeps/slope.yaml, 2 rounds
    python benchmarks/tyres_cpu.py --limit 512 --rounds 1

Issue 20 asks that the slip tyre cost the MuJoCo C main job no more time than the rigid contact.
Each run is `python -m batchveh.sweep SPEC` in a fresh process (end_to_end.run_once), the spec
as given (the vehicle's default tyre, `slip`) and a copy of it with `vehicle: {tyre: {model:
rigid}}`. The two alternate (slip, rigid, slip, rigid, ...) so that a change of load on the
machine falls on both. The JSON (--out, default benchmarks/results/LABEL-tyres-cpu-SPEC.json)
holds every run and, per model, the best and median wall and sweep times and their ratios.
"""

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from cpu_overhead import cpu_model  # noqa: E402
from end_to_end import run_once, version  # noqa: E402


def with_tyre(spec: Path, model: str, folder: Path) -> Path:
    """A copy of `spec` whose vehicle runs the wheel-ground model `model`."""
    text = yaml.safe_load(spec.read_text())
    vehicle = dict(text.get("vehicle") or {})
    vehicle["tyre"] = {**(vehicle.get("tyre") or {}), "model": model}
    out = folder / f"{spec.stem}-{model}.yaml"
    out.write_text(yaml.safe_dump({**text, "vehicle": vehicle}, sort_keys=False))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("spec", nargs="?", default="sweeps/slope.yaml", help="sweep YAML (default: the main job)")
    ap.add_argument("--limit", type=int, help="run only the first N variants")
    ap.add_argument("--rounds", type=int, default=2, help="slip-then-rigid rounds (default 2)")
    ap.add_argument("--label", default=f"cpu-{os.cpu_count()}core")
    ap.add_argument("--out")
    args = ap.parse_args()
    spec = Path(args.spec)
    out = Path(args.out) if args.out else ROOT / "benchmarks" / "results" / f"{args.label}-tyres-cpu-{spec.stem}.json"
    runs = {"slip": [], "rigid": []}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        specs = {m: with_tyre(ROOT / spec, m, tmp) for m in runs}
        env = {**os.environ, "BATCHVEH_CACHE": str(tmp / "jax-cache")}
        for r in range(args.rounds):
            for model in runs:
                cmd = [sys.executable, "-m", "batchveh.sweep", str(specs[model]), "--quiet", "--overwrite"]
                cmd += ["--backend", "mujoco", "--out", str(tmp / "results")]
                cmd += ["--limit", str(args.limit)] if args.limit else []
                runs[model].append(run_once(f"{model} {r + 1}", cmd, env, tmp / "jax-cache"))
    summary = {}
    for model, rows in runs.items():
        walls = [row["wall_s"] for row in rows]
        sweeps = [row["sweep_wall_s"] for row in rows if "sweep_wall_s" in row]
        summary[model] = {
            "wall_best_s": min(walls),
            "wall_median_s": statistics.median(walls),
            "sweep_best_s": min(sweeps) if sweeps else None,
            "sweep_median_s": statistics.median(sweeps) if sweeps else None,
            "status": rows[-1].get("status"),
        }
    ok = all(summary[m]["sweep_best_s"] for m in runs)
    ratios = (
        {
            "sweep_best_slip_over_rigid": summary["slip"]["sweep_best_s"] / summary["rigid"]["sweep_best_s"],
            "wall_best_slip_over_rigid": summary["slip"]["wall_best_s"] / summary["rigid"]["wall_best_s"],
            "wall_median_slip_over_rigid": summary["slip"]["wall_median_s"] / summary["rigid"]["wall_median_s"],
        }
        if ok
        else {}
    )
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    res = {
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "spec": str(spec),
        "limit": args.limit,
        "backend": "mujoco",
        "machine": f"{cpu_model()}, {os.cpu_count()} CPUs, {platform.system()}",
        "code": commit.stdout.strip(),
        "versions": {"python": platform.python_version(), "mujoco": version("mujoco")},
        "order": "slip then rigid, alternating, each a fresh process",
        "summary": summary,
        "ratios": ratios,
        "runs": runs,
    }
    print(f"{'model':6} {'best wall s':>12} {'median wall s':>14} {'best sweep s':>13}  status")
    for model, s in summary.items():
        best = f"{s['wall_best_s']:12.1f} {s['wall_median_s']:14.1f} {s['sweep_best_s'] or 0:13.1f}"
        print(f"{model:6} {best}  {s['status']}")
    for k, v in ratios.items():
        print(f"{k}: {v:.3f}")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
