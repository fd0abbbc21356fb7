"""The warp engine's scan with several steps per loop iteration (`lax.scan`'s unroll): the run's
time, the trace and lower, the compile, and the columns against one step per iteration.

    python benchmarks/warp_unroll.py benchmarks/slope_100k.yaml --unroll 1 2 5 --out unroll.json
    python benchmarks/warp_unroll.py benchmarks/slope_100k.yaml --n 64 --steps 100 --unroll 1 2   # a CPU

For each unroll, on the spec's first --n variants: trace + lower of the engine's program (what a
warm process pays before the compile cache's load), then the engine's first run (compile
included, no persistent cache) and its second run (timed). Columns are compared with unroll 1's:
the largest |difference| over the variants, relative to max(|x|, 1 N m) for the torque columns.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from warp_iterations import batch_of, spec_of, timed_runs  # noqa: E402

from batchveh.engines.warp import WarpEngine  # noqa: E402
from batchveh.stepping.batch import mjx_model  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("spec")
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--steps", type=int, help="shorter runs, to try it on a CPU")
    ap.add_argument("--unroll", type=int, nargs="+", default=[1, 2, 5])
    ap.add_argument("--out")
    args = ap.parse_args()
    import jax
    import jax.numpy as jnp

    spec = spec_of(args.spec, args.steps)
    cfg = spec.stats_config()
    batch = batch_of(spec, 0, args.n)
    rows, base = [], None
    for u in args.unroll:
        engine = WarpEngine(spec.scenario, cfg, args.n)
        engine.scan_unroll = u
        with engine._call_context():
            mx, axes = mjx_model(batch, "warp")
            params = {k: jnp.asarray(v, jnp.float32) for k, v in batch.params.items()}
            prog = engine._program(batch, mx, axes)
            t = time.perf_counter()
            jax.jit(prog).trace(mx, params).lower()
            trace_lower = time.perf_counter() - t
        first, run, cols = timed_runs(engine, batch)
        if base is None:
            base = cols
        diff = 0.0
        for k, v in cols.items():
            a, b = np.asarray(v, float), np.asarray(base[k], float)
            if k.startswith(("drive_", "steer_")):
                diff = max(diff, float(np.nanmax(np.abs(a - b) / np.maximum(np.abs(b), 1.0))))
        row = {
            "unroll": u,
            "variants": args.n,
            "steps": cfg.n_steps,
            "trace_lower_s": trace_lower,
            "first_run_s": first,
            "compile_s": engine.compile_s,
            "run_s": run,
            "variant_steps_per_s": args.n * cfg.n_steps / run,
            "largest_torque_difference_vs_first": diff,
        }
        rows.append(row)
        print(json.dumps(row), flush=True)
    info = {"spec": args.spec, "device": str(jax.devices()[0].device_kind), "date": time.strftime("%Y-%m-%d %H:%M")}
    if args.out:
        Path(args.out).write_text(json.dumps({"info": info, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
