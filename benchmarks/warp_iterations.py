"""How many constraint-solver iterations the warp engine's steps take, and what the solver's
tolerance costs and buys: rate and per-wheel accuracy against MuJoCo C, on one sweep's variants.

    python benchmarks/warp_iterations.py benchmarks/slope_100k.yaml --n 100000 --ref 2048 --out it.json
    python benchmarks/warp_iterations.py benchmarks/slope_100k.yaml --n 64 --ref 16 --steps 200   # a CPU

MuJoCo Warp solves every world of a batch in one loop of kernel launches, which runs until the
last world has converged (or `opt.iterations`): a step costs about the largest iteration count
of its batch, not the typical one. For each tolerance in --tolerances (MuJoCo's default 1e-8
first), on the spec's first --n variants, the warp engine runs the sweep's program twice (the
first run compiles), and the second is timed. A second program of the same rollout records each
world's `solver_niter` at every step: the table gives, over the steps, the mean and the largest
of the batch's largest count, and the mean count of a world. Accuracy: the first --ref variants
on MuJoCo C (float64, tolerance 1e-12, all CPU threads) against each setting's float32 columns,
per-wheel drive mean and peak, relative to max(|C|, 1 N m), median / p99 / largest, over the
variants C calls ok and not slipping.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench import accuracy  # noqa: E402

from batchveh.engines import make_engine  # noqa: E402
from batchveh.stepping.batch import VariantBatch, apply_solver, make_batch  # noqa: E402
from batchveh.sweeping.spec import load_spec  # noqa: E402


def spec_of(path: str, steps: int | None = None):
    """The sweep spec at `path`, its runs cut to `steps` steps where given (to try a study on a CPU)."""
    spec = load_spec(path)
    if steps:
        import dataclasses

        sc = spec.scenario
        spec = dataclasses.replace(spec, scenario=dataclasses.replace(sc, total_time=steps * sc.time_step))
    return spec


def batch_of(spec, start: int, n: int, tolerance: float | None = None) -> VariantBatch:
    """Variants start..start+n of the spec's table, with the spec's solver (and `tolerance`)."""
    rows = spec.table().rows(start, start + n)
    b = make_batch(spec.vehicle, spec.scenario, {k: rows[k].to_numpy() for k in spec.params}, spec.params)
    apply_solver(b.model, spec.solver)
    if tolerance is not None:
        apply_solver(b.model, {"tolerance": tolerance})
    return b


def timed_runs(engine, batch: VariantBatch) -> tuple[float, float, dict]:
    """(first run s, second run s, the second run's columns): the first compiles, the second is the rate's."""
    t = time.perf_counter()
    engine.run(batch)
    first = time.perf_counter() - t
    t = time.perf_counter()
    cols = engine.run(batch)
    return first, time.perf_counter() - t, cols


def iteration_counts(engine, batch: VariantBatch, cfg) -> dict[str, float]:
    """Each world's solver iterations at every step, reduced on the device: the same rollout as the
    engine's (its model, initial data and wheel-ground step), with `solver_niter` as the output."""
    import jax
    import jax.numpy as jnp

    from batchveh.engines.warp import constraint_rows
    from batchveh.model.vehicle import layout
    from batchveh.stepping import rollout
    from batchveh.stepping.batch import import_mjx, mjx_model

    mjx = import_mjx()
    lay = layout(batch.model)
    with engine._call_context():
        mx, axes = mjx_model(batch, "warp")
        data = mjx.make_data(
            batch.model,
            impl="warp",
            naconmax=batch.n * engine.contacts_per_world,
            njmax=constraint_rows(batch.model, engine.contacts_per_world),
        )

        def one(m, p):
            body = rollout._scan(m, p, engine.scenario, lay, lambda d, acc, s, i: ((d, acc), d._impl.solver_niter))
            _, niter = jax.lax.scan(body, (rollout._init(m, data), ()), jnp.arange(cfg.n_steps))
            return niter

        params = {k: jnp.asarray(v, jnp.float32) for k, v in batch.params.items()}
        niter = jax.jit(jax.vmap(one, in_axes=(axes, 0)))(mx, params)  # (n, steps)
        largest = niter.max(axis=0)
        out = {
            "batch_largest_mean": float(largest.mean()),
            "batch_largest_max": int(largest.max()),
            "batch_largest_p50": float(jnp.median(largest)),
            "world_mean": float(niter.mean()),
            "world_p99": float(jnp.percentile(niter.astype(jnp.float32), 99)),
            "steps_at_limit_share": float((largest >= batch.model.opt.iterations).mean()),
        }
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("spec")
    ap.add_argument("--n", type=int, default=100_000, help="variants on the warp engine")
    ap.add_argument("--ref", type=int, default=2048, help="variants on MuJoCo C for the accuracy")
    ap.add_argument("--steps", type=int, help="shorter runs (total_time from steps) to try it on a CPU")
    ap.add_argument("--tolerances", type=float, nargs="*", default=[1e-8, 1e-7, 1e-6])
    ap.add_argument(
        "--contacts", type=int, nargs="*", default=[], help="also: contact buffers per world (the engine's is 24)"
    )
    ap.add_argument("--out")
    args = ap.parse_args()
    import jax

    spec = spec_of(args.spec, args.steps)
    cfg = spec.stats_config()
    t0 = time.perf_counter()
    ref_engine = make_engine("mujoco", spec.scenario, cfg, args.ref, args.ref)
    ref = ref_engine.run(batch_of(spec, 0, args.ref, 1e-12))
    ref_s = time.perf_counter() - t0
    ok = np.asarray([s == 0 for s in ref["status_code"]]) if "status_code" in ref else None
    print(f"reference: {args.ref} variants on MuJoCo C in {ref_s:.1f} s", flush=True)
    rows = []
    from batchveh.engines.warp import CONTACTS_PER_WORLD, WarpEngine

    runs = [(tol, CONTACTS_PER_WORLD) for tol in args.tolerances] + [(args.tolerances[0], c) for c in args.contacts]
    for tol, contacts in runs:
        engine = WarpEngine(spec.scenario, cfg, args.n, contacts_per_world=contacts)
        batch = batch_of(spec, 0, args.n, tol)
        first, wall, cols = timed_runs(engine, batch)
        its = iteration_counts(engine, batch, cfg)
        sel = {k: np.asarray(v)[: args.ref] for k, v in cols.items()}
        refsel = dict(ref)
        if ok is not None:
            sel = {k: v[ok] for k, v in sel.items()}
            refsel = {k: np.asarray(v)[ok] for k, v in ref.items()}
        acc = accuracy(sel, refsel)
        row = {
            "tolerance": tol,
            "contacts_per_world": contacts,
            "variants": args.n,
            "steps": cfg.n_steps,
            "first_run_s": first,
            "run_s": wall,
            "variant_steps_per_s": args.n * cfg.n_steps / wall,
            "iterations": its,
            "accuracy_vs_c": acc,
        }
        rows.append(row)
        w = acc.get("noslip_wheel_mean", {})
        p = acc.get("noslip_wheel_peak", {})
        print(
            f"tol {tol:7.0e}, {contacts} contacts/world: {row['variant_steps_per_s']:.3g} variant-steps/s "
            f"({wall:.2f} s), iterations: batch's "
            f"largest mean {its['batch_largest_mean']:.1f} max {its['batch_largest_max']}, world mean "
            f"{its['world_mean']:.2f}; wheel mean err med/p99 {w.get('median', 0):.1e}/{w.get('p99', 0):.1e}, "
            f"peak {p.get('median', 0):.1e}/{p.get('p99', 0):.1e}",
            flush=True,
        )
    info = {
        "spec": args.spec,
        "device": str(jax.devices()[0].device_kind),
        "machine": f"{platform.processor() or platform.machine()}, {platform.system()}",
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "reference": {"variants": args.ref, "engine": "mujoco (MuJoCo C float64, tolerance 1e-12)", "wall_s": ref_s},
    }
    if args.out:
        Path(args.out).write_text(json.dumps({"info": info, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
