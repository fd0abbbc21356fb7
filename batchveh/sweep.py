"""Run a parameter sweep and write per-variant motor-torque statistics to Parquet.

    python -m batchveh.sweep sweeps/slope.yaml
    python -m batchveh.sweep sweeps/slope.yaml --backend mjx --limit 100 --out /tmp/s
    python -m batchveh.sweep sweeps/slope.yaml --resume      # after an interruption
    python -m batchveh.sweep sweeps/slope.yaml --executor ray --address HEAD:6379 --out s3://bucket/slope
    python -m batchveh.sweep sweeps/slope.yaml --executor gpus   # one process per local GPU, no Ray

The warp engine on 2 or more local GPUs uses them all by itself where a second GPU pays
(batchveh/sweeping/gpus.py; BATCHVEH_GPU_PROCESSES=0: one GPU, in this process).

Exit codes: 0 done (all ok or some flagged), 2 bad spec, arguments or files (one
line), 3 results exist (give --resume or --overwrite) or another sweep is writing
there, 4 partial: some chunks kept failing on the Ray workers or worker processes
(named; the others are written, --resume retries the rest), 130 interrupted
(finished chunks kept).
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from batchveh.sweeping import prestart  # light: it imports nothing heavy

if __name__ == "__main__":  # the command line: the other GPUs' workers start before this process's imports
    prestart.start(sys.argv[1:])

import pandas as pd  # noqa: E402

from batchveh.cli import run_main  # noqa: E402
from batchveh.config import ConfigError, OneLineParser  # noqa: E402
from batchveh.stepping.motor_stats import MOTOR_STATUS  # noqa: E402
from batchveh.sweeping.chunks import ChunkRunner  # noqa: E402
from batchveh.sweeping.results import PART, Locked, ResultError, ResultFolder, load  # noqa: E402
from batchveh.sweeping.retry import Finished, Note, quiet  # noqa: E402
from batchveh.sweeping.spec import MAX_VARIANTS, SweepSpec, load_spec, saltelli_block  # noqa: E402

if TYPE_CHECKING:
    from batchveh.sweeping.cluster import RayExecutor
    from batchveh.sweeping.gpus import GpuProcesses

START_NOTE_S = 2.0  # a sweep's engine start longer than this is named in a line
EXIT_OK, EXIT_INPUT, EXIT_EXISTS, EXIT_PARTIAL, EXIT_INTERRUPTED = 0, 2, 3, 4, 130

# Rough rates in variant-steps/s for the dry run's estimate (docs/performance.md). MuJoCo C per thread, the
# main job on 2 threads (benchmarks/results/cpu-2core-tyres-cpu-slope.json): slip 1.43e5, rigid 1.0e5; the
# soil's step costs about the slip tyre's (cpu-2core-wheel-ground-step.json in benchmarks/results/archive.json:
# 11.1 against 11.4 ms per step at
# 2,048 variants, MuJoCo's step included). With an elliptic contact: MJX on the CPU 1.0e4 on 2 cores; the warp
# engine 4.5e3 on 2 CPU cores (256 variants); on one H200, MJX (JAX implementation) 1.4e6 and the warp
# engine 6.74e6 with the rigid contact (h200-warp-soft.json in benchmarks/results/archive.json); with the slip
# tyre (the default) MJX 2.87e6 (8,192 variants, benchmarks/results/h200-tyres-mjx.json) and the warp engine
# 1.73e7-1.85e7 (benchmarks/results/h200-tyres-indexing.json; h200-tyres*.json in the archive)
MUJOCO_RATE_PER_THREAD = {"rigid": 5.0e4, "slip": 7.1e4, "soil": 7.1e4}
RATE_PER_CPU = {"mjx": 5.0e3, "warp": 2.2e3}  # per CPU core
# the soil model: the warp engine 1.14e7 and 1.43e7 on two H200 (benchmarks/results/h200-soil.json and
# h200-soil-unforwarded.json in benchmarks/results/archive.json), the lower taken; MJX 7.9e5 at 8,192 variants
# (h200-soil-mjx.json in the archive, whose slip row read 4.3e5, not the 2.87e6 above: not
# explained yet)
RATE_PER_GPU = {
    "rigid": {"mjx": 1.4e6, "warp": 6.7e6},
    "slip": {"mjx": 2.9e6, "warp": 1.7e7},
    "soil": {"mjx": 7.9e5, "warp": 1.1e7},
}
# Preparing structural variants (stepping/fields.py: closed forms and mj_setConst), CPU thread-seconds per
# variant: 9.7-10.1 us a variant on 2 threads quiet, 21-22 us with another job on the machine
# (benchmarks/results/cpu-2core-structural-prepare.json and its earlier run); this takes about their middle
PREPARE_S_PER_VARIANT = 2.8e-5
COMPILE_S = {"mujoco": 2.0, "mjx-cpu": 60.0, "mjx-gpu": 15.0, "warp-cpu": 40.0, "warp-gpu": 60.0}
# a GPU process with warm caches (JAX's compile cache filled, Warp's kernels built): imports, the first GPU work,
# trace and cache load, about 7 s on one H200 (h200-warm-compile.json in benchmarks/results/archive.json)
WARM_START_S = 8.0


def compile_cache_dir() -> str:
    """JAX's persistent compile cache of batchveh: $BATCHVEH_CACHE or ~/.cache/batchveh/jax."""
    return os.environ.get("BATCHVEH_CACHE", os.path.join(os.path.expanduser("~"), ".cache", "batchveh", "jax"))


def caches_warm(backend: str) -> bool:
    """Whether a GPU run would find its caches filled: JAX's compile cache, and for warp Warp's kernel
    cache ($WARP_CACHE_PATH or ~/.cache/warp) with built kernels."""

    def filled(path: str) -> bool:
        return os.path.isdir(path) and any(os.scandir(path))

    warp_cache = os.environ.get("WARP_CACHE_PATH", os.path.join(os.path.expanduser("~"), ".cache", "warp"))
    return filled(compile_cache_dir()) and (backend != "warp" or filled(warp_cache))


def enable_compile_cache() -> None:
    """JAX's persistent compilation cache, so a repeated sweep does not recompile (process-wide:
    the CLI's `main` calls it). The folder is $BATCHVEH_CACHE or ~/.cache/batchveh/jax."""
    import jax

    path = compile_cache_dir()
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


def init_warp_without_cuda() -> None:
    """Initialise Warp quietly on a machine without the CUDA driver (process-wide: the CLI's `main` calls
    it before a warp sweep). Warp's native library looks for libcuda when it initialises and, where
    there is none, writes 'Warp CUDA warning: Could not find or load the NVIDIA CUDA driver' to file
    descriptor 2, past sys.stderr and Warp's log level. Here descriptor 2 goes to a temporary file for
    that one call, and every other line it wrote is passed on."""
    import ctypes
    import tempfile

    for lib in ("libcuda.so", "libcuda.so.1", "nvcuda.dll"):  # where Warp looks
        try:
            ctypes.CDLL(lib)
            return  # a driver: Warp finds it and has nothing to warn about
        except OSError:
            pass
    try:
        import warp
    except (ImportError, RuntimeError):
        return  # the engine says what is missing
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            with warp.ScopedLogLevel(warp.LOG_ERROR):
                warp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        tmp.seek(0)
        lines = tmp.read().decode(errors="replace").splitlines()
    for line in lines:
        if "Could not find or load the NVIDIA CUDA driver" not in line:
            print(line, file=sys.stderr)


def engine_settings(executor: str | None, backend: str | None, spec: SweepSpec) -> str:
    """The process-wide settings the engines need, made once by a command line's `main` before JAX or Warp
    starts (`executor`: --executor's value; `backend`: --backend's, or None for the spec's); returns the backend
    resolved. The warp engine on several local GPUs shows JAX the first only (`gpus.own_gpu_only`), and Warp
    starts without making a CUDA context of its own."""
    from batchveh.engines import resolve_backend
    from batchveh.sweeping import gpus

    if executor != "ray" and gpus.own_gpu_only(backend or spec.backend):
        import jax

        jax.config.update("jax_cuda_visible_devices", "0")  # before JAX starts: see own_gpu_only
    resolved = resolve_backend(backend or spec.backend)
    if resolved == "warp" and executor != "ray":
        init_warp_without_cuda()
    return resolved


def new_executor(
    kind: str | None, spec: SweepSpec, backend: str, n: int, chunk_size: int | None = None
) -> InProcess | RayExecutor | GpuProcesses | None:
    """A fresh executor for one `run_sweep` (which closes it): --executor's `kind` ('ray': on the Ray cluster
    this process joined, `cluster.connect`; 'gpus': one process per local GPU; 'local' or None: this process,
    but the warp engine on several local GPUs where a second one pays, `gpus.automatic`)."""
    from batchveh.sweeping import gpus

    if kind == "ray":
        from batchveh.sweeping import cluster

        return cluster.RayExecutor()
    if kind == "gpus":
        return gpus.GpuProcesses()
    if backend == "warp" and kind is None:  # every local GPU where a second one pays
        return gpus.automatic(spec, backend, n, chunk_size)
    return None


def count_variants(spec: SweepSpec, limit: int | None = None, max_variants: int = MAX_VARIANTS) -> int:
    """The number of variants to run; ConfigError above `max_variants`."""
    n = len(spec.table())
    n = n if limit is None else min(limit, n)
    if n > max_variants:
        raise ConfigError(
            f"{spec.where}: sweep: {n:,} variants exceed the limit of {max_variants:,}; allowed: fewer values, "
            "--limit N, or --max-variants N to raise the limit"
        )
    return n


class InProcess:
    """The default executor: the chunks run one after another in this process, on one engine."""

    spreads = False  # the automatic chunk size does not depend on a number of workers

    def start(
        self, spec: SweepSpec, backend: str, n: int, chunk_size: int | None, folder: ResultFolder
    ) -> tuple[dict[str, Any], str]:
        """Build the engine; return (what the manifest records, the device in words)."""
        self.runner, self.folder = ChunkRunner(spec, backend, n, chunk_size), folder
        return self.runner.manifest, self.runner.device

    def run(self, todo: list[int], finished: Finished, note: Note, phase: Note = quiet) -> dict[int, str]:
        """Run and write the chunks in `todo`, calling finished(chunk, part name, record) after each and
        phase(what) as each phase of a chunk starts; return the chunks that failed (none: an error here
        stops the sweep)."""
        return self.runner.run_here(todo, self.folder, finished, phase)

    def engine_stats(self) -> dict[str, Any]:
        return self.runner.engine_stats()

    def close(self) -> None:
        pass


def run_sweep(
    spec: SweepSpec,
    *,
    out: str | Path | None = None,
    backend: str | None = None,
    resume: bool = False,
    overwrite: bool = False,
    limit: int | None = None,
    chunk_size: int | None = None,
    max_variants: int = MAX_VARIANTS,
    progress: bool = True,
    report: Callable[[str], None] | None = None,
    executor: InProcess | RayExecutor | GpuProcesses | None = None,
) -> dict[str, Any]:
    """Run `spec`, writing part files under `out` (a local path or a URI pyarrow.fs understands);
    return a summary dict.

    `executor`: None runs the chunks in this process; a `batchveh.sweeping.cluster.RayExecutor` runs them
    on Ray workers, a `batchveh.sweeping.gpus.GpuProcesses` here and in one process per other local GPU,
    and chunks that kept failing there are named in the summary's "failed" ({chunk: why}) while the
    others are written. Raises FileExistsError where results exist and
    neither resume nor overwrite is given, results.Locked where another sweep writes there,
    ConfigError for a bad spec or setting. `report` receives notes for the user (damaged parts
    that run again, chunks retried)."""
    from tqdm.auto import tqdm

    n = count_variants(spec, limit, max_variants)
    folder = ResultFolder(out or spec.output)
    executor = executor or InProcess()
    note = report or (lambda _: None)
    folder.refuse_existing(resume=resume, overwrite=overwrite)  # before workers start, which takes a while
    if resume and chunk_size is None and executor.spreads:
        # the automatic chunk size follows the number of workers, which may have changed since
        chunk_size = folder.resume_chunk_size()  # the manifest's, or a part's where the manifest was lost
    # the engine's start (imports, the device, Ray's workers) can take several seconds: a line says so,
    # unless it is done (or refused, in one line of its own) sooner
    starting = threading.Timer(
        START_NOTE_S, lambda: print(f"{spec.name}: starting the engine ...", file=sys.stderr, flush=True)
    )
    if progress:
        starting.start()
    try:
        try:
            manifest, device = executor.start(spec, backend or spec.backend, n, chunk_size, folder)
        finally:
            starting.cancel()
        backend, chunk = manifest["backend"], manifest["chunk_size"]
        rigid_elliptic = spec.vehicle.tyre.model == "rigid" and spec.vehicle.contact_model.cone == "elliptic"
        if backend == "mjx" and spec.precision == "f32" and rigid_elliptic:
            note(
                "MJX in float32 with the rigid contact's elliptic friction cone: four-wheel sums hold (1e-4), "
                "per-wheel torques drift by 6% (median) on a GPU; for per-wheel values use the slip tyre "
                "(vehicle.tyre.model: slip, the default), or give precision: f64 (docs/user-guide.md, Backends)"
            )
        if spec.scenario.obstacle == "terrain":
            note(
                "terrain (a height field) is approximate on every engine: each keeps its own contacts per wheel "
                "(MuJoCo C up to 50, warp and mjx 4), which move a wheel's sinkage and so the fight of four locked "
                "wheels: per-wheel torques are not resolved, four-wheel values carry +10-35% against exact geometry "
                "and differ 2-38% between engines (validation/TERRAIN.md); size single motors on a step or bump"
            )
        n_chunks = -(-n // chunk)
        with folder.lock():
            done, bad = folder.open(manifest, resume=resume, overwrite=overwrite)
            for line in folder.notes:  # a manifest rebuilt from the parts
                note(line)
            for name, why in bad.items():
                note(f"{folder.where(name)}: {why}; its chunk runs again")
            todo = [c for c in range(n_chunks) if c not in done]
            size = {c: min(chunk, n - c * chunk) for c in range(n_chunks)}
            bar = tqdm(
                total=n,
                initial=n - sum(size[c] for c in todo),
                unit="variant",
                desc=spec.name,
                disable=not progress,
                dynamic_ncols=True,
            )
            t_start = time.perf_counter()
            ran = 0
            # the bar moves within a chunk: the variant-steps this process's engine reports (MuJoCo C, block by
            # block), shown as variants; the rest of a chunk's variants once it is written
            n_steps, shown, stepped, counting = spec.stats_config().n_steps, Counter(), Counter(), threading.Lock()

            def simulated(c: int, variant_steps: int) -> None:
                with counting:
                    stepped[c] += variant_steps
                    now = min(size[c], stepped[c] // n_steps)
                    if now > shown[c]:
                        bar.update(now - shown[c])
                        shown[c] = now

            def finished(c: int, name: str, rec: dict[str, Any]) -> None:
                nonlocal ran
                folder.record(name, rec)
                ran += size[c]
                with counting:
                    bar.update(size[c] - shown.pop(c, 0))
                    stepped.pop(c, None)

            runner = getattr(executor, "runner", None)  # this process's engine, where it runs chunks
            if progress and runner is not None:
                runner.progress = simulated

            try:
                failed = executor.run(todo, finished, note, phase=lambda what: bar.set_postfix_str(what, refresh=True))
            except BaseException:
                executor.close()  # its workers stop writing while this process still holds the folder's lock
                raise
            bar.set_postfix_str("done")
            bar.close()
            wall = time.perf_counter() - t_start
            engine = executor.engine_stats()
            executor.close()  # no worker writes any more: what a killed one left behind can go
            folder.remove_temporaries()
    finally:
        executor.close()
    # the parts were verified when the folder was opened and hashed as they were written
    dcmotor = spec.vehicle.motors.model == "dcmotor"
    try:
        result = load(folder.path, columns=["status", "slipping", *(["motor_status"] * dcmotor)], verify=False)
    except ResultError:  # not one part: every chunk failed
        result = pd.DataFrame({"status": pd.Series(dtype=str), "slipping": pd.Series(dtype=bool)})
    counts = result["status"].value_counts().to_dict()
    motors = result["motor_status"].value_counts().to_dict() if "motor_status" in result else None
    return {
        "motor_status": None if motors is None else {k: motors.get(k, 0) for k in MOTOR_STATUS},
        "rows": len(result),
        "ran": ran,
        "ok": counts.get("ok", 0),
        "diverged": counts.get("diverged", 0),
        "flipped": counts.get("flipped", 0),
        "stuck": counts.get("stuck", 0),
        "short": counts.get("short", 0),
        "slipping": int(result["slipping"].sum()),
        "wall_s": wall,
        "compile_s": engine["compile_s"],
        "compiles": engine["compiles"],
        "variant_steps_per_s": ran * spec.stats_config().n_steps / wall if wall > 0 else 0.0,
        "out": folder.path,
        "backend": backend,
        "device": device,
        "engine_warnings": engine["warnings"],
        "failed": failed,
        "chunk_size": chunk,
        "folder": folder,
    }


def estimate(
    backend: str, variant_steps: int, tyre: str = "slip", structural: int = 0, chunk: int = 0
) -> tuple[float, str]:
    """(seconds, on what) for `variant_steps` on the backend and the devices this process sees, with
    the wheel-ground model `tyre` ('slip', 'rigid' or 'soil'), `structural` variants of a sweep over the
    vehicle to prepare (on the CPU threads: on a GPU only the first `chunk` of them is not hidden behind
    the simulation of the chunk before)."""
    from batchveh.engines import has_gpu
    from batchveh.engines.mujoco import cpus

    prepare = structural * PREPARE_S_PER_VARIANT / cpus()

    if backend == "mujoco":
        from batchveh.engines.mujoco import default_threads

        threads = default_threads()
        rate, where, compile_s = MUJOCO_RATE_PER_THREAD[tyre] * threads, f"{threads} CPU threads", COMPILE_S["mujoco"]
    elif has_gpu():
        import jax

        gpus = 1 if backend == "warp" else len(jax.devices())
        compile_s = WARM_START_S if caches_warm(backend) else COMPILE_S[f"{backend}-gpu"]
        rate, where = RATE_PER_GPU[tyre][backend] * gpus, f"{gpus} GPU"
    else:
        cores = os.cpu_count() or 1
        rate, where, compile_s = RATE_PER_CPU[backend] * cores, f"{cores} CPU cores", COMPILE_S[f"{backend}-cpu"]
    simulate = variant_steps / rate
    if backend != "mujoco" and has_gpu():  # hidden behind the GPU but for the first chunk, or where it is longer
        first = prepare * min(1.0, chunk / structural) if structural else 0.0
        prepare = max(first, prepare - simulate)
    basis = f"{backend} on {where}, about {rate:.2g} variant-steps/s"
    if structural:
        basis += f", {prepare:.0f} s preparing the vehicle variants"
    return compile_s + simulate + prepare, basis


def dry_run(spec: SweepSpec, limit: int | None, backend: str, max_variants: int = MAX_VARIANTS) -> str:
    """Variant count and a rough memory and time estimate, without building the variants."""
    from batchveh.engines import resolve_backend
    from batchveh.engines.common import CPU_CHUNK, auto_chunk
    from batchveh.model.params import structural

    n = count_variants(spec, limit, max_variants)
    backend = resolve_backend(backend)
    steps = spec.scenario.n_steps
    vehicle = n if structural(spec.params, spec.vehicle) else 0
    chunk = spec.chunk_size or auto_chunk(backend, n)
    seconds, basis = estimate(backend, n * steps, spec.vehicle.tyre.model, vehicle, chunk)
    # about 0.2 MB per variant of a MuJoCo C chunk (records of a 100-step block, statistics)
    mem_mb = min(n, CPU_CHUNK["mujoco"]) * 0.2 + 200 if backend == "mujoco" else min(n, 131072) * 0.02 + 500
    design = ""
    if spec.method == "sobol":
        d = len(spec.params)
        design = f" (Saltelli: N = {spec.n:,} base points x (2D + 2) = {saltelli_block(d)} for D = {d})"
    return (
        f"{spec.name}: {n:,} variants{design} x {steps:,} steps; about {_duration(seconds)} ({basis}) "
        f"and {mem_mb:,.0f} MB; results would go to {spec.output}"
    )


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def _positive(flag: str) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = 0
        if value < 1:
            raise argparse.ArgumentTypeError(f"{text!r} is not allowed; allowed: an integer >= 1")
        return value

    parse.__name__ = flag
    return parse


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(
        prog="python -m batchveh.sweep",
        description=__doc__.split("\n\n")[0],
        epilog="Exit codes: 0 done, 2 bad spec, argument or file, 3 results exist or another sweep writes "
        "there, 4 partial (with --executor ray or gpus: chunks that kept failing are named, the others are written; "
        "--resume runs the rest), 130 interrupted. The spec format: docs/user-guide.md.",
    )
    parser.add_argument("spec", help="sweep YAML, e.g. sweeps/slope.yaml")
    parser.add_argument(
        "--out",
        help="result folder, a local path or a URI pyarrow.fs understands such as s3://bucket/sweep "
        "(default: the spec's output)",
    )
    parser.add_argument(
        "--backend",
        choices=("auto", "mujoco", "mjx", "warp"),
        help="auto: warp (MuJoCo Warp) on a CUDA GPU with mujoco-warp installed, mjx (MJX's JAX "
        "implementation) on another GPU, else mujoco (MuJoCo C on the CPU threads)",
    )
    parser.add_argument("--resume", action="store_true", help="keep finished chunks and run the rest")
    parser.add_argument("--overwrite", action="store_true", help="delete existing results first")
    parser.add_argument("--dry-run", action="store_true", help="print the variant count and estimates, then stop")
    parser.add_argument("--limit", type=_positive("limit"), help="run only the first N variants")
    parser.add_argument("--chunk-size", type=_positive("chunk size"), help="variants per chunk (default: by backend)")
    parser.add_argument(
        "--max-variants",
        type=_positive("max variants"),
        default=MAX_VARIANTS,
        help=f"refuse sweeps larger than this (default {MAX_VARIANTS:,})",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--plots", action="store_true", help="also write envelope/heatmap PNGs into the results")
    parser.add_argument(
        "--executor",
        choices=("local", "ray", "gpus"),
        default=None,
        help="local: the chunks run in this process; by default the same, but the warp engine on 2 or more local "
        "GPUs uses gpus where a second GPU pays (unless BATCHVEH_GPU_PROCESSES=0); ray: on Ray workers, one per GPU or "
        "else per CPU, which write the parts themselves (pip install -e '.[ray]'); gpus: one process per local "
        "GPU, this one on the first, no Ray",
    )
    parser.add_argument(
        "--address",
        help="with --executor ray: the cluster to join (auto, HOST:PORT as `ray start --head` prints it, or "
        "ray://HOST:PORT); default: start a local Ray instance on this machine",
    )
    return run_main(
        parser,
        lambda args: _sweep(parser, args),
        argv,
        codes={(FileExistsError, Locked): EXIT_EXISTS},
        where=lambda args: args.out or "the output",
        interrupted="finished chunks are kept; run again with --resume",
    )


def _sweep(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    """The command on its parsed arguments; `run_main` turns its input errors into one line."""
    if args.address is not None and args.executor != "ray":
        parser.error("--address: needs --executor ray")
    started_ray = False
    try:
        spec = load_spec(args.spec)
        if args.dry_run:
            print(dry_run(spec, args.limit, args.backend or spec.backend, args.max_variants))
            return EXIT_OK
        if args.plots and "://" in str(args.out or spec.output):
            raise ConfigError("--plots: figures are written to a local folder; give a local --out for them")
        enable_compile_cache()
        from batchveh.sweeping import gpus

        backend = engine_settings(args.executor, args.backend, spec)
        if args.executor == "ray":
            from batchveh.sweeping import cluster

            started_ray = cluster.connect(args.address)
        n = count_variants(spec, args.limit, args.max_variants)
        executor = new_executor(args.executor, spec, backend, n, args.chunk_size)
        if not isinstance(executor, gpus.GpuProcesses):
            prestart.release()  # the workers started ahead are not needed
        s = run_sweep(
            spec,
            out=args.out,
            backend=args.backend,
            resume=args.resume,
            overwrite=args.overwrite,
            limit=args.limit,
            chunk_size=args.chunk_size,
            max_variants=args.max_variants,
            progress=not args.quiet,
            report=lambda msg: print(f"note: {msg}", file=sys.stderr),
            executor=executor,
        )
        if args.plots:
            from batchveh.analysis.plot import sweep_figures
            from batchveh.sweeping.spec import SAMPLED

            figs = sweep_figures(
                load(s["out"]), spec.name, s["out"], swept=list(spec.params), sampled=spec.method in SAMPLED
            )
            s["folder"].record_files(figs)
            print("figures: " + ", ".join(str(p) for p in figs))
    finally:
        prestart.release()  # any not taken (a sweep that runs in this process alone, an error)
        if started_ray:
            cluster.disconnect()
    if s["engine_warnings"]:
        print(f"MuJoCo reported unstable simulations (marked diverged), e.g.: {s['engine_warnings'][0]}")
    stuck = "".join(f"{s[k]} {k}, " for k in ("stuck", "short") if s[k])  # obstacle sweeps only
    # model dcmotor: the motors' statuses (unstable: a physics check failed, motor_check says which)
    counted = s.get("motor_status") or {}
    motors = "; motors " + ", ".join(f"{v} {k}" for k, v in counted.items()) if counted else ""
    print(
        f"{s['rows']} rows ({s['ran']} run now): {s['ok']} ok, {s['diverged']} diverged, {s['flipped']} flipped, "
        f"{stuck}{s['slipping']} slipping{motors} | {s['wall_s']:.1f} s wall, compile {s['compile_s']:.1f} s, "
        f"{s['variant_steps_per_s']:.3g} variant-steps/s on {s['backend']} ({s['device']})"
    )
    print(f"results: {s['out']}  (pandas: batchveh.load({str(s['out'])!r}))")
    for c, why in sorted(s["failed"].items()):
        print(f"error: chunk {c} ({PART.format(c)}) not written: {why}", file=sys.stderr)
    if s["failed"]:
        k = len(s["failed"])
        print(f"partial: {k} chunk{'s' * (k > 1)} not written, the others are; --resume runs them", file=sys.stderr)
        return EXIT_PARTIAL
    return EXIT_OK


def tune_process_for_one_job() -> None:
    """Process-wide settings for one batch job; the command's entry point calls this, not `main`,
    which tests call in their own process.

    - Python's cyclic garbage collector: imports and JAX's tracing make millions of long-lived
      objects, and the default (the young generation after every 700 net allocations, the older
      ones after 10 and 100 of those) walked them again and again: 1.1 s of a 4.3 s sweep of 16
      variants on 2 CPU cores. A young generation of 50,000 collects the same garbage less often;
      cycles are still found.
    - JAX's GPU memory: by default it reserves 75% of each GPU when its backend starts. Growing the
      pool on demand instead saved 1.0 s of a warm 100,000-variant sweep process on one H200
      (median 21.0 s -> 19.9 s, benchmarks/results/archive.json: h200-gpu-start.json); a sweep allocates its
      buffers once per chunk shape, and the chunk size still follows the same memory limit. A value
      the user set is kept.
    """
    gc.set_threshold(50_000, 20, 100)
    os.environ.setdefault("XLA_PYTHON_CLIENT_PREALLOCATE", "false")


if __name__ == "__main__":
    tune_process_for_one_job()
    code = main()
    # the interpreter's last collection at exit would walk every object the run made (1-2 s);
    # frozen objects are left to the operating system, which frees the process's memory at once
    gc.freeze()
    sys.exit(code)
