"""What a sweep's 'compile' costs with a warm JAX cache: the engine's program traced, lowered and
loaded from the persistent compile cache, in a fresh process, nothing run.

    python benchmarks/warm_compile.py benchmarks/slope_100k.yaml --cache /tmp/jc      # fills the cache
    python benchmarks/warm_compile.py benchmarks/slope_100k.yaml --cache /tmp/jc      # warm: times the load

Prints one JSON line: seconds for the imports, the batch, the model's upload (`mjx_model`), the
program's build (the initial data), trace, lower and compile, and whether the compile cache held
the program before (files in it). Run it under `py-spy record --native` to see where a warm
compile spends its time below Python.
"""

import argparse
import json
import sys
import time
from pathlib import Path

T0 = time.perf_counter()
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("spec")
    ap.add_argument("--cache", required=True)
    ap.add_argument("--limit", type=int)
    ap.add_argument("--backend", default="warp")
    args = ap.parse_args()
    t = {}
    import jax

    jax.config.update("jax_compilation_cache_dir", args.cache)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
    import jax.numpy as jnp

    from batchveh.engines import make_engine
    from batchveh.engines.common import pad
    from batchveh.stepping.batch import apply_solver, make_batch, mjx_model
    from batchveh.stepping.rollout import float_precision
    from batchveh.sweeping.spec import load_spec

    t["imports_s"] = time.perf_counter() - T0
    files_before = len(list(Path(args.cache).glob("*-cache"))) if Path(args.cache).exists() else 0
    spec = load_spec(args.spec)
    n = min(args.limit or len(spec.table()), len(spec.table()))
    engine = make_engine(args.backend, spec.scenario, spec.stats_config(), None, n)
    n = min(n, engine.chunk_size)
    s = time.perf_counter()
    rows = spec.table().rows(0, n)
    batch = make_batch(spec.vehicle, spec.scenario, {k: rows[k].to_numpy() for k in spec.params}, spec.params)
    apply_solver(batch.model, spec.solver)
    batch = pad(batch, engine.chunk_size)
    t["batch_s"] = time.perf_counter() - s
    with float_precision(engine.precision), engine._call_context():
        s = time.perf_counter()
        mx, axes = mjx_model(batch, engine.impl)
        jax.block_until_ready(mx)
        t["upload_s"] = time.perf_counter() - s
        params = {k: jnp.asarray(v, jnp.float32) for k, v in batch.params.items()}
        s = time.perf_counter()
        prog = engine._program(batch, mx, axes)
        t["program_s"] = time.perf_counter() - s
        s = time.perf_counter()
        traced = jax.jit(prog).trace(mx, params)
        t["trace_s"] = time.perf_counter() - s
        s = time.perf_counter()
        lowered = traced.lower()
        t["lower_s"] = time.perf_counter() - s
        s = time.perf_counter()
        lowered.compile()
        t["compile_s"] = time.perf_counter() - s
    t["total_s"] = time.perf_counter() - T0
    print(json.dumps({"variants": engine.chunk_size, "cache_files_before": files_before, **t}))


if __name__ == "__main__":
    main()
