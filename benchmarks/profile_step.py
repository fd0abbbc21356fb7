"""One vmapped MJX step of the vehicle, timed under each speed option, with a kernel profile.

    python benchmarks/profile_step.py --n 65536 --solvers newton6ls4 newton4 --modes mjx chol --trace

Each mode times jit(vmap(step)) over n slope variants from a settled state (best of 10
after a warm-up). Modes: 'mjx' (mjx.step as it is), 'chol' (mjx.step traced under
batchveh.linalg.small_cholesky: MJX's Cholesky calls unrolled in element-wise JAX), 'fused'
(MJX's solver replaced by batchveh.solver's fused Newton solver, plus 'chol').
With --trace, a JAX profiler trace of 3 steps is summarised: device time per kernel
name, the top rows printed, all rows written with --out. This is the profiler evidence
the speed work in benchmarks/NOTES.md cites.
"""

from __future__ import annotations

import argparse
import collections
import glob
import gzip
import json
import sys
import tempfile
import time
from pathlib import Path

import jax.numpy as jnp

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def kernel_table(trace_dir: str, top: int = 25) -> list[dict]:
    """Device events of a perfetto trace, total microseconds per name, largest first."""
    files = glob.glob(f"{trace_dir}/**/perfetto_trace.json.gz", recursive=True)
    if not files:
        return []
    with gzip.open(files[0], "rt") as f:
        trace = json.load(f)
    events = trace["traceEvents"] if isinstance(trace, dict) else trace
    procs = {e["pid"]: e["args"]["name"] for e in events if e.get("ph") == "M" and e.get("name") == "process_name"}
    device_pids = {p for p, name in procs.items() if "GPU" in name or "gpu" in name or "/device:" in name}
    tot, cnt = collections.Counter(), collections.Counter()
    for e in events:
        if e.get("ph") == "X" and e.get("pid") in device_pids:
            tot[e["name"]] += e.get("dur", 0.0)
            cnt[e["name"]] += 1
    total = sum(tot.values()) or 1.0
    return [
        {"kernel": k, "us": us, "calls": cnt[k], "share": us / total} for k, us in tot.most_common(top if top else None)
    ]


HESSIANS = {
    # H = J' diag(w) J for J (rows, nv), w (rows,): formulations XLA compiles differently
    "broadcast_reduce": lambda j, w: jnp.sum((j * w[:, None])[:, :, None] * j[:, None, :], 0),
    "einsum_highest": lambda j, w: jnp.einsum("ri,rj->ij", j * w[:, None], j, precision="highest"),
    "row_outer_loop": lambda j, w: sum((w[r] * j[r])[:, None] * j[r][None, :] for r in range(j.shape[0])),
    "transposed_rows": lambda j, w: jnp.sum((j.T * w)[:, None, :] * j.T[None, :, :], -1),
}


def time_hessians(n: int, rows: int = 48, nv: int = 14) -> list[dict]:
    """Each HESSIANS formulation, jit(vmap) over n random (rows, nv) Jacobians: best of 20."""
    import jax
    import numpy as np

    rng = np.random.default_rng(0)
    j = jax.device_put(rng.normal(size=(n, rows, nv)).astype(np.float32))
    w = jax.device_put(rng.uniform(size=(n, rows)).astype(np.float32))
    ref = np.einsum("bri,br,brj->bij", np.asarray(j[:64], np.float64), np.asarray(w[:64]), np.asarray(j[:64]))
    from bench import best_time

    out = []
    for name, fn in HESSIANS.items():
        f = jax.jit(jax.vmap(fn))
        h = np.asarray(f(j, w)[:64])
        best = best_time(f, j, w, repeat=20)
        out.append({"hessian": name, "ms": best * 1e3, "max_rel_err": float(np.abs(h - ref).max() / np.abs(ref).max())})
        print(f"hessian {name:18s} {best * 1e3:8.3f} ms  rel err {out[-1]['max_rel_err']:.1e}")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=65536)
    ap.add_argument("--solvers", nargs="+", default=["newton6ls4"])
    ap.add_argument("--modes", nargs="+", default=["mjx", "chol"])
    ap.add_argument("--wheel-collision", default="cylinder", choices=["cylinder", "sphere"])
    ap.add_argument("--trace", action="store_true", help="summarise a profiler trace of each mode")
    ap.add_argument("--out", default=None, help="JSON file for the results")
    ap.add_argument("--hessians", action="store_true", help="also time formulations of J' diag(w) J")
    ap.add_argument("--dump-hlo", default=None, help="folder for each mode's optimised HLO text")
    args = ap.parse_args()
    import bench

    bench.WHEEL_COLLISION = args.wheel_collision
    import jax
    from bench import mjx_model, slope_table

    spec, table = slope_table(args.n, seed=3)
    results = {"n": args.n, "device": jax.devices()[0].device_kind, "rows": []}
    if args.hessians:
        results["hessians"] = time_hessians(args.n)
    for solver in args.solvers:
        results["rows"] += profile(*mjx_model(spec, table, solver), solver, args)
    if args.out:
        Path(args.out).write_text(json.dumps(results, indent=1))


def profile(m, axes, solver, args):
    import jax
    import jax.numpy as jnp
    from bench import best_time, settled
    from mujoco import mjx

    from batchveh.linalg import small_cholesky
    from batchveh.solver import fused_solver

    patches = {"mjx": lambda: small_cholesky(False), "chol": small_cholesky, "fused": fused_solver}
    rows = []
    with jax.default_matmul_precision("highest"):
        data = settled(m, axes)
        ref_qacc = jax.jit(jax.vmap(mjx.step, in_axes=(axes, 0)))(m, data).qacc  # MJX as it is
        for mode in args.modes:
            t0 = time.perf_counter()
            with patches[mode]():
                f = jax.jit(jax.vmap(mjx.step, in_axes=(axes, 0))).lower(m, data).compile()
            compile_s = time.perf_counter() - t0
            if args.dump_hlo:
                Path(args.dump_hlo).mkdir(parents=True, exist_ok=True)
                (Path(args.dump_hlo) / f"{solver}-{mode}.hlo.txt").write_text(f.as_text())
            err = float(jnp.max(jnp.abs(f(m, data).qacc - ref_qacc)))
            best = best_time(f, m, data)
            row = {
                "solver": solver,
                "mode": mode,
                "ms": best * 1e3,
                "rate": args.n / best,
                "max_qacc_diff_vs_mjx": err,
                "compile_s": compile_s,
            }
            if args.trace:
                with tempfile.TemporaryDirectory() as tmp:
                    jax.profiler.start_trace(tmp, create_perfetto_trace=True)
                    for _ in range(3):
                        jax.block_until_ready(f(m, data))
                    jax.profiler.stop_trace()
                    kernels = kernel_table(tmp, top=0)
                    row["kernels_per_step"] = sum(k["calls"] for k in kernels) // 3
                    row["kernel_ms_per_step"] = sum(k["us"] for k in kernels) / 3e3
                    row["kernels"] = kernels[:40]
            rows.append(row)
            rate = f"{row['rate']:.3g} variant-steps/s"
            head = f"{solver:12s} {mode:6s} {row['ms']:8.2f} ms/step  {rate}"
            print(f"{head}  max|dqacc| {err:.2e}  compile {compile_s:.1f} s")
            for k in row.get("kernels", [])[:25]:
                ms, share = k["us"] / 3e3, 100 * k["share"]
                print(f"    {ms:8.3f} ms/step {share:5.1f}%  x{k['calls'] // 3:<4d} {k['kernel'][:90]}")
    return rows


if __name__ == "__main__":
    main()
