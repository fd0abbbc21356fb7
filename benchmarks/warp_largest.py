"""The largest batch the warp engine holds on one GPU, and its rate there.

    python benchmarks/warp_largest.py --sizes 524288 1048576 2097152 4194304

Slope variants of sweeps/slope.yaml (as bench.py draws them), 100 steps of 5 ms after no
settle, each size run twice (the first compiles; the second is timed). A size that fails (out
of memory) is recorded with its error and ends the scan. Writes results/<tag>.json.
"""

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[524288, 1048576, 2097152, 4194304])
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--tag", default="h200-warp-largest")
    args = ap.parse_args()
    import dataclasses

    import jax
    from bench import _cols, slope_table

    from batchveh.engines.warp import WarpEngine
    from batchveh.stepping import stats
    from batchveh.stepping.batch import make_batch

    rows = []
    for n in args.sizes:
        spec, table = slope_table(n, seed=3)
        sc = dataclasses.replace(spec.scenario, total_time=args.steps * spec.scenario.time_step, settle_time=0.0)
        cfg = stats.StatsConfig.for_scenario(sc)
        try:
            eng = WarpEngine(sc, cfg, n)
            batch = make_batch(spec.vehicle, sc, _cols(table, spec))
            eng.run(batch)
            t0 = time.perf_counter()
            out = eng.run(batch)
            wall = time.perf_counter() - t0
        except Exception as err:  # out of memory: record it and stop
            rows.append({"variants": n, "error": str(err)[:300]})
            print(rows[-1], flush=True)
            break
        mem = jax.devices()[0].memory_stats() or {}
        rows.append(
            {
                "variants": n,
                "steps": sc.n_steps,
                "rate": n * sc.n_steps / wall,
                "wall_s": wall,
                "compile_s": eng.compile_s,
                "peak_mem_gb": mem.get("peak_bytes_in_use", 0) / 1e9,
                "limit_gb": mem.get("bytes_limit", 0) / 1e9,
                "ok_share": float((out["status_code"] == 0).mean()),
            }
        )
        print(rows[-1], flush=True)
    info = {"device": jax.devices()[0].device_kind, "command": " ".join(sys.argv), "date": time.strftime("%Y-%m-%d")}
    path = Path(__file__).resolve().parent / "results" / f"{args.tag}.json"
    path.write_text(json.dumps({"info": info, "rows": rows}, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
