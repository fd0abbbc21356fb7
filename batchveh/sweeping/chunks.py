"""One chunk of a sweep, from its rows of the variant table to its Parquet part table.

`ChunkRunner` is what runs chunks, in the sweep's own process or in a Ray worker
(`batchveh.sweeping.cluster`): it builds the engine once, so each process compiles once, and
`run(c)` turns chunk number `c` into the part's table, with units on the columns,
the spec, versions, device and timings in the file metadata, and the part's own record
(`results.seal`: chunk, variants, settings, checksum of its data). It also says what the
result folder's manifest records about it (`manifest`), which a resume must match.
"""

from __future__ import annotations

import os
import platform
import threading
import time
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from batchveh.config import ConfigError
from batchveh.model import course
from batchveh.model.params import parameter_specs
from batchveh.stepping import motor_stats, stats
from batchveh.stepping.batch import apply_solver, make_batch
from batchveh.sweeping.results import ResultFolder, part_table, seal
from batchveh.sweeping.spec import SweepSpec, sampler_version

TABLE_VERSION = 2  # how variant rows are drawn from a spec; a resume must match it
# one chunk prepared at a time in a process: make_batch keeps per-process state that two threads must not use at
# once (stepping/fields.py's set_const keeps one Batch per vehicle, whose inputs and outputs a second chunk's
# preparation overwrote mid-call: the first chunks' dof_M0, body_subtreemass, ... were another chunk's, issue 62)
PREPARING = threading.Lock()


class ChunkRunner:
    """Chunks of `n` variants of `spec` on one engine, built once.

    `chunk_size` None: the engine's automatic size for `n / workers` variants, so that a sweep
    spread over `workers` processes has at least one chunk for each. `nthread`: MuJoCo C threads
    (0: the engine's default). Raises ConfigError, naming the spec file, for a setting the
    backend cannot run.

    `progress`, where set, hears progress(chunk, variant-steps) as the engine steps a chunk (the MuJoCo C
    engine, block by block; the others say nothing before the chunk ends)."""

    progress: Callable[[int, int], None] | None = None

    def __init__(
        self,
        spec: SweepSpec,
        backend: str,
        n: int,
        chunk_size: int | None = None,
        *,
        workers: int = 1,
        nthread: int = 0,
    ):
        from batchveh.engines import make_engine, resolve_backend
        from batchveh.stepping.batch import model_for

        self.spec, self.n = spec, n
        self.backend = resolve_backend(backend)
        self.cfg = spec.stats_config()
        base = model_for(spec.vehicle, spec.scenario)
        try:  # a course or motor the backend cannot run is refused before any work
            course.check_backend(base, self.backend, spec.params)
            if self.backend == "mjx" and spec.vehicle.motors.model == "dcmotor":
                raise ConfigError(
                    "vehicle.motors.model: dcmotor is not run by MJX's JAX implementation (backend mjx); "
                    "allowed: backend mujoco or warp, or motors.model: servo"
                )
            self.engine = make_engine(
                self.backend,
                spec.scenario,
                self.cfg,
                chunk_size or spec.chunk_size,
                n_variants=-(-n // workers),
                precision=spec.precision,
                nthread=nthread,
            )
        except ConfigError as err:  # a course or setting the backend cannot run: name the file
            raise ConfigError(f"{spec.where}: {err}") from None
        self.chunk = self.engine.chunk_size
        self.n_chunks = -(-n // self.chunk)
        self.table = spec.table()
        specs = parameter_specs(spec.vehicle)
        self.param_units = {k: specs[k].get("unit", "") for k in spec.params}
        self.choices = {k: specs[k]["choices"] for k in spec.params if "choices" in specs[k]}
        engine_meta = {"implementation": self.engine.implementation, "solver": solver_settings(base, spec.solver)}
        self.manifest = {
            "spec": spec.raw,
            "n_variants": n,
            "chunk_size": self.chunk,
            "backend": self.backend,
            "precision": spec.precision,
            "table_version": TABLE_VERSION,
            "settle_time": spec.scenario.settle_time,  # the default may change: a resume must match it
            **engine_meta,
        }
        sampler = sampler_version(spec.method)
        if sampler is not None:  # a Sobol' sample is drawn by SALib and scipy: a resume must draw the same
            self.manifest["sampler"] = sampler
        self.device = device(self.backend, getattr(self.engine, "nthread", None))
        self.meta = {
            "spec": spec.raw,
            "versions": versions(),
            "device": self.device,
            "backend": self.backend,
            **engine_meta,
            "precision": spec.precision,
            "window_s": [self.cfg.window_start, self.cfg.window_end],
            "lowpass_s": self.cfg.lowpass_s,
            "p95_stride": self.cfg.stride,
            "time_step": spec.scenario.time_step,
            "total_time": spec.scenario.total_time,
        }
        if self.cfg.mission is not None:  # each span's law times in s: 'mission' and the segments
            self.meta["mission_spans_s"] = self.cfg.mission.times()

    def size(self, c: int) -> int:
        """Variants in chunk `c` (the last one may be short)."""
        return min(self.chunk, self.n - c * self.chunk)

    def prepare(self, c: int) -> tuple[int, pd.DataFrame, Any, float]:
        """Chunk `c`'s variant rows and batched model, CPU work only (array work and mj_setConst on the
        CPU threads): a sweep prepares chunk c + 1 while the engine runs chunk c."""
        spec = self.spec
        t0 = time.perf_counter()
        rows = self.table.rows(c * self.chunk, c * self.chunk + self.size(c))
        with PREPARING:
            try:  # an impossible variant (a wheel no larger than its hub): one line naming the spec
                table = {k: rows[k].to_numpy() for k in spec.params}
                batch = make_batch(spec.vehicle, spec.scenario, table, spec.params)
            except ConfigError as err:
                raise ConfigError(f"{spec.where}: sweep.params: {err}") from None
            apply_solver(batch.model, spec.solver)
        return c, rows, batch, time.perf_counter() - t0

    def finish(self, prepared: tuple[int, pd.DataFrame, Any, float]) -> pa.Table:
        """The prepared chunk run on the engine: its rows, then the statistics columns and `status`."""
        c, rows, batch, prepare_s = prepared
        t0 = time.perf_counter()
        if hasattr(self.engine, "progress"):  # the engine tells the variant-steps it simulates, block by block
            self.engine.progress = None if self.progress is None else partial(self.progress, c)
        res = course.flag(self.engine.run(batch), batch.params, self.spec.scenario.obstacle)
        cols = {k: np.asarray(v) for k, v in motor_stats.named(res).items() if k != "status_code"}
        cols["status"] = [stats.STATUS[int(s)] for s in np.asarray(res["status_code"])]
        frame = pd.concat([rows.reset_index(drop=True), pd.DataFrame(cols)], axis=1)
        for k, names in self.choices.items():  # a categorical parameter's column holds its names
            frame[k] = np.asarray(names, dtype=object)[np.rint(frame[k].to_numpy()).astype(int)]
        meta = {
            **self.meta,
            "chunk": c,
            "chunk_wall_s": time.perf_counter() - t0 + prepare_s,
            "prepare_s": prepare_s,
            "compile_s": self.engine.compile_s,
        }
        # the part carries its own record (chunk, variants, settings, checksum): a lost manifest is rebuilt from it
        return seal(part_table(frame, self.param_units, meta), c, c * self.chunk, self.manifest)

    def run(self, c: int) -> pa.Table:
        """Chunk `c`'s rows: the variant table's rows, then the statistics columns and `status`."""
        return self.finish(self.prepare(c))

    def engine_stats(self) -> dict[str, Any]:
        """This process's engine: its compile time, its compiles and MuJoCo's first warnings."""
        e = self.engine
        return {"compile_s": e.compile_s, "compiles": e.compiles, "warnings": list(getattr(e, "warnings", []))}

    def run_here(
        self,
        todo: list[int],
        folder: ResultFolder,
        finished: Callable[[int, str, dict], None],
        phase: Callable[[str], None] = lambda _: None,
    ) -> dict[int, str]:
        """Run and write the chunks of `todo` in this process, each next chunk prepared and each finished one
        written while the engine runs (`Pipeline`), calling finished(chunk, part name, record) as each is
        written (on the writing thread) and phase(what) as each chunk's phase starts: what every executor
        does where it runs alone. Returns the chunks that failed: none (an error here stops the sweep, once
        the chunks already simulated are written and recorded)."""
        with Pipeline(self, folder) as pipe:
            for i, c in enumerate(todo):
                if i == 0:  # the first chunk on the preparing thread too, before the next: one after the other
                    pipe.ahead(c)
                if i + 1 < len(todo):
                    pipe.ahead(todo[i + 1])
                where = f"chunk {c + 1}/{self.n_chunks}"
                if not pipe.ready(c):
                    phase(f"{where}: preparing {self.size(c):,} variants")
                first = self.engine.compiles == 0 and self.backend != "mujoco"
                phase(f"{where}: {'compiling, then ' if first else ''}simulating on {self.backend}")
                pipe.write(c, pipe.simulate(c), finished)
            phase("writing")
        return {}


class Pipeline:
    """One process's chunks, overlapped with its engine: `ahead(c)` prepares chunk c on a thread while the
    engine runs another (MuJoCo's set_const, JAX and XLA release the GIL), one chunk after another in the order
    asked (`PREPARING`: a chunk's variants never depend on which chunk was prepared beside it; ask for the chunk
    to simulate first), `simulate(c)` runs it (prepared on that thread where it was not asked ahead), and
    `write(c, table, then)` writes its part on a second thread while the engine runs the next, then calls
    then(c, part name, record) on that thread. Leaving the `with` block waits for every write, also on an
    error: a chunk simulated is written and recorded. A write that raised raises in the next `simulate` or
    at the end, unless `write` was given `failed`."""

    def __init__(self, runner: ChunkRunner, folder: ResultFolder):
        from concurrent.futures import ThreadPoolExecutor

        self.runner, self.folder = runner, folder
        self._prepare = ThreadPoolExecutor(1, thread_name_prefix="batchveh-prepare")
        self._writer = ThreadPoolExecutor(1, thread_name_prefix="batchveh-write")
        self._prepared: dict[int, Any] = {}
        self._writes: list[Any] = []

    def __enter__(self) -> Pipeline:
        return self

    def __exit__(self, kind: Any, *_: Any) -> None:
        for f in self._prepared.values():
            f.cancel()
        self._prepare.shutdown(wait=True)
        self._writer.shutdown(wait=True)  # every write done, and recorded by its `then`
        if kind is None:
            self._check()

    def ahead(self, c: int) -> None:
        if c not in self._prepared:
            self._prepared[c] = self._prepare.submit(self.runner.prepare, c)

    def ready(self, c: int) -> bool:
        """Whether chunk c is prepared already."""
        f = self._prepared.get(c)
        return f is not None and f.done()

    def simulate(self, c: int) -> pa.Table:
        """Chunk c's table (prepared ahead or now, on the preparing thread); raises a write that failed before."""
        self._check()
        self.ahead(c)
        return self.runner.finish(self._prepared.pop(c).result())

    def write(
        self,
        c: int,
        table: pa.Table,
        then: Callable[[int, str, dict], None],
        failed: Callable[[int, BaseException], None] | None = None,
    ) -> None:
        def job() -> None:
            try:
                part = self.folder.write_file(c, table)
            except Exception as err:
                if failed is None:
                    raise
                failed(c, err)
                return
            then(c, *part)

        self._writes.append(self._writer.submit(job))

    def _check(self) -> None:
        for f in [f for f in self._writes if f.done()]:
            self._writes.remove(f)
            f.result()


def versions() -> dict[str, str]:
    import jax
    import mujoco

    from batchveh import __version__

    return {
        "batchveh": __version__,
        "mujoco": mujoco.__version__,
        "jax": jax.__version__,
        "python": platform.python_version(),
    }


def device(backend: str, threads: int | None = None) -> str:
    """The devices a chunk runs on, in words; `threads`: MuJoCo C's threads (default: every CPU)."""
    if backend in ("mjx", "warp"):
        import jax

        devs = jax.devices()[: 1 if backend == "warp" else None]
        return f"{len(devs)} x {devs[0].device_kind} ({devs[0].platform})"
    threads = threads or os.cpu_count() or 1
    return f"{threads} CPU thread{'s' * (threads > 1)} ({platform.processor() or platform.machine()})"


def solver_settings(m: Any, solver: Any) -> dict[str, Any]:
    """The constraint solver and contact options every variant runs with (MuJoCo's names): those of
    the sweep's base MjModel `m` with the spec's `solver` options applied (to `m`)."""
    import mujoco

    apply_solver(m, solver)
    return {
        "solver": mujoco.mjtSolver(m.opt.solver).name.removeprefix("mjSOL_").lower(),
        "iterations": int(m.opt.iterations),
        "ls_iterations": int(m.opt.ls_iterations),
        "tolerance": float(m.opt.tolerance),
        "cone": mujoco.mjtCone(m.opt.cone).name.removeprefix("mjCONE_").lower(),
        "impratio": float(m.opt.impratio),
        "integrator": mujoco.mjtIntegrator(m.opt.integrator).name.removeprefix("mjINT_").lower(),
    }
