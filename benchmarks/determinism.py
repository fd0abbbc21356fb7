"""Do two runs give the same bits on a GPU? MuJoCo Warp alone, with and without its Option.deterministic.

    python benchmarks/determinism.py --size 8192 --steps 400 --label h100

MuJoCo Warp stepped by hand (bench.bench_mjwarp_direct: sweeps/slope.yaml's vehicle with the slip tyre's
frictionless contacts, per-world gravity and friction, one CUDA graph per 50 steps), from a fresh model and
data each run, twice per --det setting (DeterminismType bits; 7: all). Per setting: the rate of each run,
and how many worlds end with other bits in qpos, qvel or qfrc_actuator, and the largest difference.
The warp engine's own reruns are in benchmarks/warp_native.py ('reruns').

JSON: benchmarks/results/LABEL-determinism.json.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench  # noqa: E402


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=8192)
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--det", type=int, nargs="+", default=[0, 7])
    ap.add_argument("--label", default=None)
    args = ap.parse_args(argv)

    from batchveh.model.scenarios import gravity_vector
    from batchveh.stepping.batch import make_batch

    bench.TYRE = "slip"
    spec, table = bench.slope_table(args.size, seed=3)
    cols = bench._cols(table, spec)
    model = make_batch(spec.vehicle, spec.scenario, {}).model
    gravity = np.asarray(gravity_vector(np.full(args.size, spec.scenario.gravity), cols["slope_deg"], xp=np))
    omega = cols["speed_kmh"] / 3.6 / spec.vehicle.wheel.radius
    rows = []
    for det in args.det:
        finals, rates = [], []
        for _ in range(2):
            final: dict = {}
            rate, _ = bench.bench_mjwarp_direct(
                model, gravity, cols["friction"], omega, args.steps, deterministic=det, final=final
            )
            finals.append(final)
            rates.append(rate)
        row = {"deterministic": det, "rates": rates}
        for k in ("qpos", "qvel", "qfrc_actuator"):
            a, b = finals[0][k], finals[1][k]
            row[f"{k}_worlds_differ"] = int(np.any(a != b, axis=1).sum())
            row[f"{k}_largest"] = float(np.max(np.abs(a - b)))
        rows.append(row)
        print(row, flush=True)
    bench.write_result({"machine": bench.machine(), "size": args.size, "steps": args.steps, "rows": rows},
                       bench.result_path("determinism", args.label))  # fmt: skip


if __name__ == "__main__":
    main()
