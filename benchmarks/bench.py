"""Speed and accuracy of batchveh against its peers, measured in one run.

    python benchmarks/bench.py                       # CPU: peers + mjx on CPU (small)
    python benchmarks/bench.py --mjx-sizes 1024 8192 65536 --solvers newton4 newton8 default

Rows: a serial mj_step loop, raw mujoco.batch.Batch on all threads, batchveh's
mujoco backend, batchveh mjx at each batch size and solver setting. Rates are
variant-steps/s (and simulated seconds per wall second); ratios are against raw
mujoco.batch measured in the same run. Accuracy: mean and peak (steady window,
raw and 50 ms low-pass) torques of a fixed sample of the slope variants against
MuJoCo C in float64 with tolerance 1e-12 and 200 iterations; relative errors,
non-slipping and slipping variants reported apart. Results are printed as a
table and written to benchmarks/results/<tag>.json; render.py folds them into
RESULTS.md.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

SOLVERS = {  # name -> (solver, iterations, ls_iterations)
    "default": ("newton", 100, 50),
    "newton4": ("newton", 4, 8),
    "newton8": ("newton", 8, 16),
    "cg16": ("cg", 16, 8),
    "newton8ls4": ("newton", 8, 4),
    "newton6ls6": ("newton", 6, 6),
    "newton6ls4": ("newton", 6, 4),
    "newton5ls4": ("newton", 5, 4),
    "newton5ls3": ("newton", 5, 3),
    "newton4ls4": ("newton", 4, 4),
    "newton3ls4": ("newton", 3, 4),
    "newton2ls4": ("newton", 2, 4),
    "newton4ls2": ("newton", 4, 2),
}


WHEEL_COLLISION = "cylinder"  # --wheel-collision


def slope_table(n: int, seed: int = 0):
    """n variants drawn (fixed seed) from sweeps/slope.yaml's grid, on the chosen wheel collision shape."""
    import dataclasses

    from batchveh.spec import load_spec, variants

    spec = load_spec(Path(__file__).resolve().parent.parent / "sweeps" / "slope.yaml")
    wheel = dataclasses.replace(spec.vehicle.wheel, collision=WHEEL_COLLISION)
    spec = dataclasses.replace(spec, vehicle=dataclasses.replace(spec.vehicle, wheel=wheel))
    grid = variants(spec)
    idx = np.random.default_rng(seed).choice(len(grid), size=n, replace=n > len(grid))
    return spec, grid.iloc[idx].drop(columns="variant").reset_index(drop=True)


def _cols(table, spec):
    cols = {k: table[k].to_numpy() for k in table.columns}
    cols.update({k: np.full(len(table), v) for k, v in spec.fixed.items() if k not in ("time_step", "total_time")})
    return cols


def set_solver(m, name: str, tolerance: float | None = None):
    """The named SOLVERS setting (and a tolerance, for the reference) through batchveh's own setter."""
    from batchveh.variants import apply_solver

    solver, it, ls = SOLVERS[name]
    apply_solver(
        m,
        {
            "type": solver,
            "iterations": it,
            "ls_iterations": ls,
            **({} if tolerance is None else {"tolerance": tolerance}),
        },
    )


def mjx_model(spec, table, solver: str):
    """The batched MJX model of the table's variants with the named SOLVERS setting, and its in_axes."""
    from batchveh.rollout import put_batch
    from batchveh.variants import make_batch

    batch = make_batch(spec.vehicle, spec.scenario, _cols(table, spec))
    set_solver(batch.model, solver)
    return put_batch(batch)


def settled(m, axes, steps: int = 100):
    """Every variant after `steps` MJX steps with the drive servos holding speed (a steady state)."""
    import jax
    import jax.numpy as jnp
    from mujoco import mjx

    def settle(mm):
        d = mjx.make_data(mm)
        ctrl = jnp.zeros(mm.nu).at[:4].set(1.0).at[8:12].set(1.0)
        return jax.lax.scan(lambda d, _: (mjx.step(mm, d.replace(ctrl=ctrl)), None), d, None, length=steps)[0]

    return jax.block_until_ready(jax.jit(jax.vmap(settle, in_axes=(axes,)))(m))


def best_time(fn, *args, repeat: int = 10) -> float:
    """Fastest of `repeat` timed calls of fn(*args) after one warm-up, s."""
    import jax

    jax.block_until_ready(fn(*args))
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        jax.block_until_ready(fn(*args))
        best = min(best, time.perf_counter() - t0)
    return best


def bench_serial(spec, table, n_steps):
    import mujoco

    from batchveh.variants import make_batch

    batch = make_batch(spec.vehicle, spec.scenario, _cols(table, spec))
    m = batch.model
    d = mujoco.MjData(m)
    t0 = time.perf_counter()
    for i in range(batch.n):
        for name, values in batch.fields.items():
            target = m.opt.gravity if name == "opt.gravity" else getattr(m, name)
            target[:] = values[i]
        mujoco.mj_resetData(m, d)
        for _ in range(n_steps):
            d.ctrl[:4] = d.ctrl[8:12] = 1.0
            mujoco.mj_step(m, d)
    return batch.n * n_steps / (time.perf_counter() - t0)


def bench_raw_batch(spec, table, n_steps):
    from mujoco.batch import Batch

    from batchveh.variants import make_batch

    batch = make_batch(spec.vehicle, spec.scenario, _cols(table, spec))
    b = Batch(batch.model, nsim=batch.n)
    for name, values in batch.fields.items():
        b.expand(name)[:] = values
    b.reset()
    ctrl = np.zeros((batch.n, batch.model.nu))
    t0 = time.perf_counter()
    for i in range(n_steps):
        ctrl[:, :4] = ctrl[:, 8:12] = min(1.0, i / 100)
        b.ctrl = ctrl
        b.step()
    return batch.n * n_steps / (time.perf_counter() - t0), b.nthread


def run_backend(kind, spec, table, chunk, solver="default", x64=False, matmul="highest", impl="auto", nthread=0):
    """(columns, wall s, compile s, peak device bytes) of batchveh's backend on the table."""
    import jax

    from batchveh import engine, stats
    from batchveh.variants import make_batch

    sc = spec.scenario
    cfg = stats.StatsConfig.make(sc.time_step, sc.n_steps, spec.window, wheel_radius=spec.vehicle.wheel.radius)
    be = engine.make_backend(kind, sc, cfg, chunk, matmul_precision=matmul, solver_impl=impl, nthread=nthread)
    out, t_run = [], 0.0
    for start in range(0, len(table), be.chunk_size):
        batch = make_batch(spec.vehicle, sc, _cols(table.iloc[start : start + be.chunk_size], spec))
        set_solver(batch.model, solver, 1e-12 if kind == "mujoco" and x64 else None)
        t0 = time.perf_counter()
        out.append(be.run(batch))
        t_run += time.perf_counter() - t0
    cols = {k: np.concatenate([o[k] for o in out]) for k in out[0]}
    peak = 0
    if kind == "mjx":
        stats_ = jax.devices()[0].memory_stats() or {}
        peak = stats_.get("peak_bytes_in_use", 0)
    return cols, t_run - be.compile_s, be.compile_s, peak


FLOOR_NM = 1.0  # below 1 N m, errors are compared in absolute terms


def accuracy(cols, ref):
    """Median / p99 / max relative error against the reference, non-slipping and slipping apart.

    Errors are |x - ref| / max(|ref|, 1 N m). 'sum' is the four-wheel drive sum, which
    physics fixes; 'wheel' pools the four drive motors, whose split among wheels locked
    to one speed is ill-conditioned (README "The over-constraint").
    """
    out = {}
    slip = np.asarray(ref["slipping"], bool)
    for label, sel in (("noslip", ~slip), ("slip", slip)):
        if not sel.any():
            continue
        for stat in ("mean", "peak", "peak_lp"):
            for group, motors in (("sum", ("drive_sum",)), ("wheel", ("drive_lf", "drive_rf", "drive_lr", "drive_rr"))):
                e = np.concatenate(
                    [
                        np.abs(np.asarray(cols[f"{m}_{stat}"])[sel] - np.asarray(ref[f"{m}_{stat}"])[sel])
                        / np.maximum(np.abs(np.asarray(ref[f"{m}_{stat}"])[sel]), FLOOR_NM)
                        for m in motors
                    ]
                )
                out[f"{label}_{group}_{stat}"] = {
                    "median": float(np.median(e)),
                    "p99": float(np.percentile(e, 99)),
                    "max": float(e.max()),
                    "n": int(sel.sum()),
                }
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tag", default=None, help="result name (default: device kind)")
    ap.add_argument("--cpu-variants", type=int, default=512, help="variants for the CPU peers")
    ap.add_argument("--serial-variants", type=int, default=8)
    ap.add_argument("--ref-variants", type=int, default=256, help="sample for the accuracy reference")
    ap.add_argument("--mjx-sizes", type=int, nargs="*", default=[256])
    ap.add_argument("--solvers", nargs="*", default=["default"], choices=list(SOLVERS))
    ap.add_argument("--precisions", nargs="*", default=["f32"], choices=["f32", "f64"], help="mjx float precisions")
    ap.add_argument("--skip-cpu", action="store_true")
    ap.add_argument(
        "--impls",
        nargs="*",
        default=["auto"],
        choices=["auto", "fused", "mjx"],
        help="mjx constraint solver code: batchveh.solver's fused Newton, MJX's own, or auto (fused on GPU)",
    )
    ap.add_argument(
        "--matmul",
        nargs="*",
        default=["highest"],
        choices=["default", "high", "highest"],
        help="JAX matmul precisions to compare for mjx (GPU float32 'default' may use TF32)",
    )
    ap.add_argument("--wheel-collision", default="cylinder", choices=["cylinder", "sphere"])
    args = ap.parse_args()
    global WHEEL_COLLISION
    WHEEL_COLLISION = args.wheel_collision
    import jax
    import mujoco

    spec, _ = slope_table(1)
    n_steps = spec.scenario.n_steps
    sim_s = spec.scenario.total_time
    dev = jax.devices()[0]
    tag = args.tag or dev.device_kind.replace(" ", "_")
    rows = []
    info = {
        "date": time.strftime("%Y-%m-%d"),
        "device": f"{len(jax.devices())} x {dev.device_kind}",
        "cpu_threads": os.cpu_count(),
        "mujoco": mujoco.__version__,
        "jax": jax.__version__,
        "python": platform.python_version(),
        "command": " ".join(sys.argv),
        "steps": n_steps,
        "time_step": spec.scenario.time_step,
        "wheel_collision": args.wheel_collision,
    }

    # the converged reference on a fixed sample
    _, ref_table = slope_table(args.ref_variants, seed=1)
    t0 = time.perf_counter()
    ref, *_ = run_backend("mujoco", spec, ref_table, args.ref_variants, "default", x64=True)
    print(f"reference: {args.ref_variants} variants in {time.perf_counter() - t0:.1f} s", flush=True)

    raw_rate = None
    if not args.skip_cpu:
        _, cpu_table = slope_table(args.cpu_variants, seed=2)
        raw_rate, nthread = bench_raw_batch(spec, cpu_table, n_steps)
        rows.append({"name": f"raw mujoco.batch ({nthread} threads)", "rate": raw_rate})
        ser = bench_serial(spec, cpu_table.iloc[: args.serial_variants], n_steps)
        rows.append({"name": "serial mj_step loop (1 thread)", "rate": ser})
        cols, wall, _, _ = run_backend("mujoco", spec, cpu_table, args.cpu_variants)
        from batchveh.engine import default_threads

        label = f"batchveh mujoco ({default_threads()} threads)"
        rows.append({"name": label, "rate": len(cpu_table) * n_steps / wall})
        cols_ref, *_ = run_backend("mujoco", spec, ref_table, args.ref_variants)
        rows[-1]["accuracy"] = accuracy(cols_ref, ref)
        print(rows[-3:], flush=True)

    from batchveh.engine import resolve_solver_impl

    configs = [
        (p == "f64", s, mm, resolve_solver_impl(i))
        for p in args.precisions
        for s in args.solvers
        for mm in args.matmul
        for i in args.impls
    ]
    for x64, solver, mm, impl in configs:
        jax.config.update("jax_enable_x64", x64)
        cols_acc, *_ = run_backend("mjx", spec, ref_table, args.ref_variants, solver, matmul=mm, impl=impl)
        acc = accuracy(cols_acc, ref)
        label = f"batchveh mjx {solver} {impl} {'f64' if x64 else 'f32'}{'' if mm == 'highest' else ' mm=' + mm}"
        for size in args.mjx_sizes:
            _, table = slope_table(size, seed=3)
            try:
                _, wall, comp, peak = run_backend("mjx", spec, table, size, solver, matmul=mm, impl=impl)
            except Exception as err:  # out of memory: record and go on
                rows.append({"name": f"{label} n={size}", "error": str(err)[:200]})
                continue
            row = {
                "name": f"{label} n={size}",
                "rate": size * n_steps / wall,
                "compile_s": comp,
                "peak_mem_gb": peak / 1e9,
                "accuracy": acc,
            }
            rows.append(row)
            print(row, flush=True)
    for r in rows:
        if "rate" in r:
            r["sim_s_per_s"] = r["rate"] / n_steps * sim_s
            r["vs_raw_batch"] = r["rate"] / raw_rate if raw_rate else None
    print(
        f"\n{'row':50s} {'var-steps/s':>11s} {'x raw':>6s} {'comp s':>6s} {'mem GB':>6s} | non-slipping, "
        "median/p99 rel. error: sum mean, wheel mean, wheel peak, wheel peak_lp"
    )
    for r in rows:
        if "rate" not in r:
            print(f"{r['name']:50s} failed: {r['error']}")
            continue
        a = r.get("accuracy", {})
        ratio = f"{r['vs_raw_batch']:.2f}" if r.get("vs_raw_batch") else "-"
        errs = " ".join(
            f"{a[k]['median']:.1e}/{a[k]['p99']:.1e}" if k in a else "-"
            for k in ("noslip_sum_mean", "noslip_wheel_mean", "noslip_wheel_peak", "noslip_wheel_peak_lp")
        )
        print(
            f"{r['name']:50s} {r['rate']:11.3g} {ratio:>6s} {r.get('compile_s', 0):6.1f} "
            f"{r.get('peak_mem_gb', 0):6.2f} | {errs}"
        )
    path = Path(__file__).resolve().parent / "results" / f"{tag}.json"
    path.write_text(json.dumps({"info": info, "rows": rows}, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
