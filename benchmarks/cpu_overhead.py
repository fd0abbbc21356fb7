"""batchveh's MuJoCo C backend against raw mujoco.batch, alternated, on all CPU threads.

    python benchmarks/cpu_overhead.py --n 4096 --repeat 5

The two peers vary by 10-30% between runs on shared machines, so they are measured in
alternation and the ratio is reported per pair, with the median (the first pair, which
includes JAX's compile of the control schedule, left out). Prints one JSON line
(also written with --out).
"""

import argparse
import json
import os
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=4096, help="variants (one chunk)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", default=None)
    ap.add_argument("--threads", type=int, nargs="+", default=[0], help="batchveh MuJoCo threads (0: its default)")
    args = ap.parse_args()
    from bench import bench_raw_batch, run_backend, slope_table

    from batchveh.engine import default_threads

    spec, table = slope_table(args.n, seed=2)
    steps = spec.scenario.n_steps
    pairs = []
    for _ in range(args.repeat):
        raw, nthread = bench_raw_batch(spec, table, steps)
        pair = {"raw": raw}
        for th in args.threads:
            _, wall, _, _ = run_backend("mujoco", spec, table, args.n, nthread=th)
            pair[f"batchveh_{th or default_threads()}"] = args.n * steps / wall
            pair[f"ratio_{th or default_threads()}"] = args.n * steps / wall / raw
        pairs.append(pair)
    res = {
        "cpu_threads": os.cpu_count(),
        "mujoco_threads": nthread,
        "variants": args.n,
        "steps": steps,
        "pairs": pairs,
        "median_ratio": {
            k: statistics.median(p[k] for p in pairs[1:] or pairs) for k in pairs[0] if k.startswith("ratio")
        },
    }
    print(json.dumps(res))
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
