"""Run a parameter sweep and write per-variant motor-torque statistics to Parquet.

    python -m batchveh.sweep sweeps/slope.yaml
    python -m batchveh.sweep sweeps/slope.yaml --backend mjx --limit 100 --out /tmp/s
    python -m batchveh.sweep sweeps/slope.yaml --resume      # after an interruption

Exit codes: 0 done (all ok or some flagged), 2 bad spec or arguments (one line),
3 results exist (give --resume or --overwrite), 130 interrupted (finished chunks kept).
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from batchveh import io, stats
from batchveh.config import ConfigError
from batchveh.spec import SweepSpec, load_spec, variants
from batchveh.variants import apply_solver, make_batch, parameter_specs

EXIT_OK, EXIT_INPUT, EXIT_EXISTS, EXIT_INTERRUPTED = 0, 2, 3, 130


def _versions() -> dict[str, str]:
    import jax
    import mujoco

    from batchveh import __version__

    return {
        "batchveh": __version__,
        "mujoco": mujoco.__version__,
        "jax": jax.__version__,
        "python": platform.python_version(),
    }


def _device(backend: str) -> str:
    if backend == "mjx":
        import jax

        devs = jax.devices()
        return f"{len(devs)} x {devs[0].device_kind} ({devs[0].platform})"
    import os

    return f"{os.cpu_count()} CPU threads ({platform.processor() or platform.machine()})"


def enable_compile_cache() -> None:
    """JAX's persistent compilation cache, so a repeated sweep does not recompile.

    The folder is $BATCHVEH_CACHE or ~/.cache/batchveh/jax.
    """
    import os

    import jax

    path = os.environ.get("BATCHVEH_CACHE", os.path.join(os.path.expanduser("~"), ".cache", "batchveh", "jax"))
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


def run_sweep(
    spec: SweepSpec,
    *,
    out: Path | None = None,
    backend: str | None = None,
    resume: bool = False,
    overwrite: bool = False,
    limit: int | None = None,
    chunk_size: int | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """Run `spec`, writing part files under `out`; return a summary dict.

    Raises FileExistsError where results exist and neither resume nor overwrite is given.
    """
    from batchveh.engine import make_backend, resolve_backend

    out = Path(out or spec.output)
    table = variants(spec)
    if limit is not None:
        table = table.iloc[:limit]
    backend = resolve_backend(backend or spec.backend)
    if spec.precision == "f64":
        import jax

        jax.config.update("jax_enable_x64", True)
    sc = spec.scenario
    cfg = stats.StatsConfig.make(
        sc.time_step, sc.n_steps, spec.window, wheel_radius=spec.vehicle.wheel.radius, lowpass_s=spec.lowpass_s
    )
    enable_compile_cache()
    engine = make_backend(
        backend,
        sc,
        cfg,
        chunk_size or spec.chunk_size,
        n_variants=len(table),
        solver_impl=spec.solver.get("impl", "auto"),
    )
    chunk = engine.chunk_size
    manifest = {
        "spec": spec.raw,
        "n_variants": len(table),
        "chunk_size": chunk,
        "backend": backend,
        "precision": spec.precision,
        "solver_impl": engine.solver_impl,
    }
    existing = io.parts(out) if out.exists() else []
    if (existing or (out / io.MANIFEST).exists()) and not resume:
        if not overwrite:
            raise FileExistsError(f"{out} holds results; give --resume to continue or --overwrite to replace them")
        io.remove_results(out)  # only what a sweep writes: never the folder's other files
        existing = []
    if resume and (out / io.MANIFEST).exists():
        old = json.loads((out / io.MANIFEST).read_text())
        if {k: old.get(k) for k in manifest} != json.loads(json.dumps(manifest)):
            raise ConfigError(
                f"{out}: the results there come from another spec, chunk size or backend; "
                "give --overwrite to replace them"
            )
    out.mkdir(parents=True, exist_ok=True)
    (out / io.MANIFEST).write_text(json.dumps(manifest, indent=1))
    specs = parameter_specs(spec.vehicle)
    param_units = {k: specs[k].get("unit", "") for k in table.columns if k in specs}
    fixed = {k: np.full(len(table), v) for k, v in spec.fixed.items() if k not in ("time_step", "total_time")}
    n_chunks = -(-len(table) // chunk)
    done = {int(p.stem.split("-")[1]) for p in existing}
    todo = [c for c in range(n_chunks) if c not in done]
    base_meta = {
        "spec": spec.raw,
        "versions": _versions(),
        "device": _device(backend),
        "backend": backend,
        "precision": spec.precision,
        "window_s": [cfg.window_start, cfg.window_end],
        "lowpass_s": cfg.lowpass_s,
        "p95_stride": cfg.stride,
        "time_step": sc.time_step,
        "total_time": sc.total_time,
    }
    from tqdm.auto import tqdm

    bar = tqdm(
        total=len(table),
        initial=len(table) - sum(min(chunk, len(table) - c * chunk) for c in todo),
        unit="variant",
        desc=spec.name,
        disable=not progress,
        dynamic_ncols=True,
    )
    t_start = time.perf_counter()
    ran = 0
    for c in todo:
        rows = table.iloc[c * chunk : (c + 1) * chunk]
        t0 = time.perf_counter()
        cols_in = {k: rows[k].to_numpy() for k in rows.columns if k != "variant"}
        cols_in.update({k: v[: len(rows)] for k, v in fixed.items()})
        batch = make_batch(spec.vehicle, sc, cols_in)
        apply_solver(batch.model, spec.solver)
        res = engine.run(batch)
        wall = time.perf_counter() - t0
        cols = {k: np.asarray(v) for k, v in res.items() if k != "status_code"}
        cols["status"] = [stats.STATUS[int(s)] for s in np.asarray(res["status_code"])]
        frame = pd.concat([rows.reset_index(drop=True), pd.DataFrame(cols)], axis=1)
        meta = {**base_meta, "chunk": c, "chunk_wall_s": wall, "compile_s": engine.compile_s}
        io.write_part(frame, out / f"part-{c:05d}.parquet", param_units, meta)
        ran += len(rows)
        bar.update(len(rows))
    bar.close()
    wall = time.perf_counter() - t_start
    result = io.load(out)
    counts = result["status"].value_counts().to_dict()
    return {
        "rows": len(result),
        "ran": ran,
        "ok": counts.get("ok", 0),
        "diverged": counts.get("diverged", 0),
        "flipped": counts.get("flipped", 0),
        "slipping": int(result["slipping"].sum()),
        "wall_s": wall,
        "compile_s": engine.compile_s,
        "compiles": engine.compiles,
        "variant_steps_per_s": ran * sc.n_steps / wall if wall > 0 else 0.0,
        "out": out,
        "backend": backend,
        "device": base_meta["device"],
    }


def dry_run(spec: SweepSpec, limit: int | None, backend: str) -> str:
    """Variant count and a rough memory and time estimate, without simulating."""
    from batchveh.engine import resolve_backend

    n = len(variants(spec))
    if limit is not None:
        n = min(limit, n)
    backend = resolve_backend(backend)
    steps = spec.scenario.n_steps
    # variant-steps/s measured here: mujoco.batch on 2 CPU threads ~1e5; MJX on one H100/H200 is higher
    rate = 1.0e5 if backend == "mujoco" else 2.0e6
    mem_mb = n * 4e-3 if backend == "mujoco" else min(n, 8192) * 0.2
    return (
        f"{spec.name}: {n} variants x {steps} steps on {backend}; about {n * steps / rate:.0f} s "
        f"and {mem_mb:.0f} MB; results would go to {spec.output}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m batchveh.sweep",
        description=__doc__.split("\n\n")[0],
        epilog="Exit codes: 0 done, 2 bad spec, 3 results exist, 130 interrupted. The spec format is in README.md.",
    )
    parser.add_argument("spec", help="sweep YAML, e.g. sweeps/slope.yaml")
    parser.add_argument("--out", type=Path, help="result directory (default: the spec's output)")
    parser.add_argument(
        "--backend",
        choices=("auto", "mjx", "mujoco"),
        help="auto: mjx when JAX sees a GPU, else mujoco (MuJoCo C on all CPU threads)",
    )
    parser.add_argument("--resume", action="store_true", help="keep finished chunks and run the rest")
    parser.add_argument("--overwrite", action="store_true", help="delete existing results first")
    parser.add_argument("--dry-run", action="store_true", help="print the variant count and estimates, then stop")
    parser.add_argument("--limit", type=int, help="run only the first N variants")
    parser.add_argument("--chunk-size", type=int, help="variants per chunk (default: by backend)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--plots", action="store_true", help="also write envelope/heatmap PNGs into the results")
    args = parser.parse_args(argv)
    try:
        spec = load_spec(args.spec)
        if args.limit is not None and args.limit < 1:
            raise ConfigError(f"--limit: {args.limit} is not allowed; allowed: an integer >= 1")
        if args.dry_run:
            print(dry_run(spec, args.limit, args.backend or spec.backend))
            return EXIT_OK
        summary = run_sweep(
            spec,
            out=args.out,
            backend=args.backend,
            resume=args.resume,
            overwrite=args.overwrite,
            limit=args.limit,
            chunk_size=args.chunk_size,
            progress=not args.quiet,
        )
    except ConfigError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_INPUT
    except FileExistsError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_EXISTS
    except KeyboardInterrupt:
        print("\ninterrupted: finished chunks are kept; run again with --resume", file=sys.stderr)
        return EXIT_INTERRUPTED
    s = summary
    if args.plots:
        from batchveh.plot import sweep_figures

        figs = sweep_figures(io.load(s["out"]), spec.name, s["out"], swept=list(spec.params))
        print("figures: " + ", ".join(str(p) for p in figs))
    print(
        f"{s['rows']} rows ({s['ran']} run now): {s['ok']} ok, {s['diverged']} diverged, {s['flipped']} flipped, "
        f"{s['slipping']} slipping | {s['wall_s']:.1f} s wall, compile {s['compile_s']:.1f} s, "
        f"{s['variant_steps_per_s']:.3g} variant-steps/s on {s['backend']} ({s['device']})"
    )
    print(f"results: {s['out']}  (pandas: batchveh.load({str(s['out'])!r}))")
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
