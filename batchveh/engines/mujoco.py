"""The `mujoco` engine: MuJoCo C through `mujoco.batch.Batch` on the CPU threads (float64).

Per-variant model fields go in through `expand()`; `Batch.rollout` steps a block of
100 steps while a worker thread folds the previous block into the statistics (the
same `stats` reduction as MJX's, in numpy) and another computes the next block's
controls. A simulation whose MuJoCo warning counters rise (NaN, Inf or huge qpos,
qvel or qacc: MuJoCo would reset it) stops stepping in `rollout`; it is reported
`diverged`, and MuJoCo's warning text is kept as data (`warnings`), not printed.
`progress`, where set, hears the variant-steps simulated as each block is stepped (a
progress bar that moves within a chunk); it reads nothing of the simulation's numbers.
"""

from __future__ import annotations

import atexit
import contextlib
import copy
import os
from collections.abc import Callable, Iterator
from functools import partial
from typing import Any

import jax
import mujoco
import numpy as np

from batchveh.engines.common import spawn_safe
from batchveh.model.missions import body_forces_fn
from batchveh.model.scenarios import Scenario, control_schedule
from batchveh.model.vehicle import layout
from batchveh.stepping import motor_stats, stats
from batchveh.stepping.batch import VariantBatch, servo_damping
from batchveh.stepping.rollout import MujocoDrive, MujocoTyre, float_precision, host_cpu

# Steps per Batch.rollout call. The statistics add each block's sums to the carry, so the block
# length fixes the order of the float additions: another length changes results in the last bits.
BLOCK = 100
TILE = 256  # variants per fold call (see MujocoEngine.run)
MIN_PART = 64  # variants: a smaller chunk runs as one part (MujocoEngine.parts)
# parts from which a chunk's parts run in worker processes, not threads: each part's Python between MuJoCo's
# steps (the wheel-ground step's call, the records) holds the GIL, and with 15 parts on 16 cores the threads
# queued on it (0.74x raw MuJoCo on the rigid contact, 9.7 of 16 cores busy: benchmarks/results/archive.json,
# h200-cpu16-overhead-threads.json; processes: h100-cpu16-overhead.json); on 2 cores two threads ran as fast
PROCESS_PARTS = 4
MAX_PROCESSES = 32  # worker processes at most (each holds its own JAX runtime, about 0.4 GB)
# model fields mujoco.batch shares between all simulations (asset data): a chunk runs one batch per value
SHARED_ASSETS = ("hfield_data",)
# warnings that mean the simulation's state is no longer valid
UNSTABLE = [
    int(w)
    for w in (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)
]


def cpus() -> int:
    """The CPUs this process may run on (its affinity mask: taskset, cgroups), else all."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def default_threads() -> int:
    """MuJoCo threads for the C engine: every CPU but one on machines of 8 or more.

    The fold and control threads need about half a core on a 16-core host. Through run_sweep,
    alternated with raw mujoco.batch at its best (benchmarks/bench.py overhead, 16 cores, chunks
    of 4096, median of 4 pairs, before the tail fold ran on every CPU): 15 threads 0.81x, 16
    threads 0.80x (benchmarks/results/archive.json: h200-cpu16-overhead.json). On 2 cores, 1 thread would
    halve the speed."""
    n = cpus()
    return n - 1 if n >= 8 else n


@contextlib.contextmanager
def captured_warnings() -> Iterator[list[str]]:
    """Collect MuJoCo's warning messages instead of printing them; restores the previous handler."""
    got: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(got.append)
    try:
        yield got
    finally:
        mujoco.set_mju_user_warning(previous)


class MujocoEngine:
    """MuJoCo C through mujoco.batch.Batch on the CPU threads (float64)."""

    name = "mujoco"
    implementation = f"MuJoCo C {mujoco.__version__} through mujoco.batch, float64"
    compile_s = 0.0
    compiles = 0
    # progress(k): k more variant-steps simulated, called after each block of each part (from the part's thread;
    # from this thread as each part in a worker process ends); None: nobody listens
    progress: Callable[[int], None] | None = None

    def __init__(
        self,
        scenario: Scenario,
        cfg: stats.StatsConfig,
        chunk_size: int,
        nthread: int = 0,
        block: int = BLOCK,
        processes: bool | None = None,
    ):
        self.scenario, self.cfg, self.chunk_size, self.block = scenario, cfg, chunk_size, block
        self.nthread = nthread or default_threads()
        # parts in worker processes: None is from PROCESS_PARTS parts on, where a spawned process is safe (below)
        self.processes = processes
        self.warnings: list[str] = []  # MuJoCo's messages, first few of the sweep
        # controls (n, block, nu) for a block of steps of every variant, computed by JAX
        self._ctrl = jax.jit(jax.vmap(control_schedule(scenario), in_axes=(0, None)))
        # a mission's slope in time: xfrc_applied (n, block, nbody, 6) from each variant's body masses
        forces = body_forces_fn(scenario)
        self._forces = None if forces is None else jax.jit(jax.vmap(jax.vmap(forces, (None, None, 0)), (0, 0, None)))

    def run(self, batch: VariantBatch) -> dict[str, np.ndarray]:
        """Statistics columns of the chunk's variants, (n,) each. Variants that differ in asset data
        (a terrain's heights), which mujoco.batch shares between all simulations, run as one batch
        per distinct value, each on a copy of the model holding it."""
        shared = [k for k in SHARED_ASSETS if k in batch.fields]
        if not shared:
            return self._run(batch)
        rows = np.concatenate([batch.fields[k].reshape(batch.n, -1) for k in shared], axis=1)
        _, group = np.unique(rows, axis=0, return_inverse=True)
        out: dict[str, np.ndarray] = {}
        for g in range(group.max() + 1):
            ids = np.flatnonzero(group.ravel() == g)
            m = copy.copy(batch.model)
            for k in shared:
                getattr(m, k)[:] = batch.fields[k][ids[0]]
            fields = {k: v[ids] for k, v in batch.fields.items() if k not in shared}
            cols = self._run(VariantBatch(m, fields, {k: v[ids] for k, v in batch.params.items()}, len(ids)))
            for k, v in cols.items():
                out.setdefault(k, np.empty(batch.n, np.asarray(v).dtype))[ids] = v
        return out

    def _run(self, batch: VariantBatch) -> dict[str, np.ndarray]:
        """The chunk's columns. With a wheel-ground model applied between steps (the slip tyre, the
        soil), the chunk runs as one part per thread, each with its own single-threaded Batch and
        its own wheel-ground step, side by side: that step (XLA, one thread) and the Python between
        steps then run on every CPU instead of one. Each variant's statistics are its own, so the
        parts give the same columns."""
        from concurrent.futures import ThreadPoolExecutor

        lay = layout(batch.model)
        parts = self.parts(batch.n, lay.applied or lay.dcmotor)
        with captured_warnings() as messages:
            if parts == 1:
                out = self._run_part(batch, self.nthread)
            else:
                edges = np.linspace(0, batch.n, parts + 1).astype(int)
                pieces = [_rows(batch, slice(lo, hi)) for lo, hi in zip(edges[:-1], edges[1:], strict=True)]
                done = self._in_processes(pieces) if self._use_processes(parts) else None
                if done is not None:
                    cols = [c for c, _ in done]
                    messages.extend(m for _, found in done for m in found)
                else:
                    with ThreadPoolExecutor(parts) as pool:
                        cols = list(pool.map(lambda piece: self._run_part(piece, 1), pieces))
                out = {k: np.concatenate([c[k] for c in cols]) for k in cols[0]}
        self.warnings.extend(messages[: max(0, 5 - len(self.warnings))])
        return out

    def _use_processes(self, parts: int) -> bool:
        """The engine's `processes`, else: from PROCESS_PARTS parts on, where BATCHVEH_CPU_PROCESSES is 1 (a
        script that guards its main, as benchmarks/bench.py overhead) or, unset, where spawning is safe."""
        if self.processes is not None:
            return self.processes
        wanted = os.environ.get("BATCHVEH_CPU_PROCESSES", "")
        return parts >= PROCESS_PARTS and wanted != "0" and (wanted == "1" or spawn_safe())

    def _in_processes(self, pieces: list[VariantBatch]) -> list | None:
        """Each piece's (columns, MuJoCo's warnings) from the worker processes, or None where the pool broke (a
        worker killed, say, or one that could not start): the pool is dropped and the chunk runs in threads."""
        from concurrent.futures.process import BrokenProcessPool

        pool = _process_pool(min(self.nthread, MAX_PROCESSES))
        try:
            done = []
            for piece, got in zip(
                pieces, pool.map(partial(_run_part_alone, self.scenario, self.cfg, self.block), pieces), strict=True
            ):
                done.append(got)
                if self.progress is not None:
                    self.progress(piece.n * self.cfg.n_steps)
            return done
        except BrokenProcessPool:
            _drop_pool()
            return None

    def parts(self, n: int, applied: bool) -> int:
        """Parts a chunk of n variants runs as: one per thread where a wheel-ground model or the dcmotors' drive
        steps between MuJoCo's steps (`applied`) and each part keeps at least MIN_PART variants, else one (on
        nthread threads)."""
        return max(1, min(self.nthread, n // MIN_PART)) if applied else 1

    def _run_part(self, batch: VariantBatch, nthread: int) -> dict[str, np.ndarray]:
        """Step the chunk in blocks; while MuJoCo steps block k on its threads, two worker threads
        fold block k-1's records into the statistics and compute block k+1's controls (all
        release the GIL while they compute). The last block's fold and the finalize, which no
        stepping hides, run tile by tile on every CPU."""
        from concurrent.futures import ThreadPoolExecutor

        from mujoco.batch import Batch, SimulationError

        m = batch.model
        lay = layout(m)
        b = Batch(m, nsim=batch.n, nthread=nthread)
        for name, values in batch.fields.items():
            b.expand(name)[:] = values
        # the slip tyre and the dcmotors' drive act between steps: bound before the reset, so its forward pass
        # fills them
        stepper = _Stepper(b, m, lay, batch.params) if lay.applied or lay.dcmotor else None
        b.reset()
        radius = np.asarray(batch.params["wheel.radius"], np.float64)[:, None]
        damping = servo_damping(batch.params, self.scenario.towing, dcmotor=lay.dcmotor)[:, None, :]  # (n, 1, 8)
        # motor joint speeds before each block's first step: after reset, then each block's last
        first = np.array(b.qvel)[:, lay.motor_dof]
        dt = m.opt.timestep
        sizes = {"qpos": m.nq, "qvel": m.nv, "qfrc_actuator": m.nv, "solver_niter": mujoco.mjNISLAND}
        if self.cfg.motors is not None:  # the dcmotors' state and their drive's record, for their statistics
            sizes.update({"actuator_force": m.nactuator, "actuator_velocity": m.nactuator})
            sizes.update({f"drive_{k}": 8 for k in _Stepper.DRIVE})
        kinds = {"solver_niter": np.int32}  # the other records are float64
        edges = [*range(0, self.cfg.n_steps, self.block), self.cfg.n_steps]
        longest = int(max(np.diff(edges)))
        params: dict[str, jax.Array] = {}  # filled by the first controls call, off the main thread
        body_mass = np.broadcast_to(batch.fields.get("body_mass", m.body_mass), (batch.n, m.nbody))
        spec = mujoco.mjtState.mjSTATE_CTRL | (mujoco.mjtState.mjSTATE_XFRC_APPLIED if self._forces else 0)
        consts = motor_stats.constants_of(self.cfg.motors, batch.params) if self.cfg.motors is not None else None

        def controls(k):
            # float64, as MuJoCo C steps (the x64 scope is per thread: this worker's own)
            with float_precision("f64"):
                if not params:
                    cpu = host_cpu()  # on a GPU host too: these small calls stay beside MuJoCo C
                    params.update(
                        {key: jax.device_put(np.asarray(v, np.float64), cpu) for key, v in batch.params.items()}
                    )
                steps = np.arange(edges[k], edges[k + 1])
                # times padded to one length (one compiled shape); the schedule is element-wise, so
                # the padding changes none of the other values
                t = np.append(steps, np.full(longest - len(steps), steps[-1])) * dt
                ctrl = np.asarray(self._ctrl(params, np.asarray(t, np.float64)), np.float64)[:, : len(steps)]
                sim = ctrl  # with dcmotors, the drive turns them into voltages step by step (_Stepper)
                if self._forces is not None:  # the rollout's inputs: ctrl, then xfrc_applied
                    xfrc = np.asarray(self._forces(params, body_mass, np.asarray(t, np.float64)), np.float64)
                    sim = np.concatenate([sim, xfrc[:, : len(steps)].reshape(*sim.shape[:2], -1)], axis=-1)
            # the simulation's inputs, and the scenario's controls (the statistics' reference)
            return steps, (np.ascontiguousarray(sim), ctrl)

        def fold(acc, rec, steps, ctrls, failed, first, tile):
            part = {r: v[tile] for r, v in rec.items()}
            dv = np.diff(part["qvel"][..., lay.motor_dof], axis=1, prepend=first[tile, None])  # speed change per step
            motors = None
            if self.cfg.motors is not None:
                ids = lay.motor_act
                motors = motor_stats.sample(
                    part["actuator_force"][..., ids],
                    part["actuator_velocity"][..., ids],
                    part["drive_T"],
                    part["drive_v"],
                    self.cfg.motors,
                    consts={k: np.broadcast_to(v, (batch.n, 8))[tile] for k, v in consts.items()},
                )
            sample = stats.sample(
                part["qpos"],
                part["qvel"],
                part["qfrc_actuator"],
                ctrls[tile],
                radius[tile],
                lay,
                damping[tile],
                dv,
                motors,
            )
            if failed[tile].any():
                sample["tau"] = np.where(failed[tile, None, None], np.nan, sample["tau"])
            # steps whose solve stopped on the iteration limit (the largest island's count)
            at_limit[tile] += (part["solver_niter"].max(-1) >= m.opt.iterations).sum(-1)
            return stats.update(acc, sample, steps, self.cfg)

        def fold_all(accs, *block):
            return [fold(acc, *block, tile) for acc, tile in zip(accs, tiles, strict=True)]

        # the statistics are kept per tile of TILE variants: a tile's temporaries stay in the CPU's
        # cache (the fold took 25-45% less CPU in tiles of 256 than on 2048 variants at once), and each
        # variant's statistics are its own, so tiles give the same bits
        tiles = [slice(lo, min(lo + TILE, batch.n)) for lo in range(0, batch.n, TILE)]
        accs = [stats.init(self.cfg, (t.stop - t.start,)) for t in tiles]
        # two record buffers, used in turn: flat, so that each block's records are a contiguous prefix
        flat = [
            {r: np.empty(batch.n * longest * d, kinds.get(r, np.float64)) for r, d in sizes.items()} for _ in range(2)
        ]
        failed = np.zeros(batch.n, bool)
        at_limit = np.zeros(batch.n, np.int64)
        # two workers: one folds block k-1, the other computes block k+1's controls (JAX), both
        # while MuJoCo steps block k (two fold workers, each with half the tiles, ran no faster
        # on 2 cores)
        with ThreadPoolExecutor(2) as pool:
            pending = None
            next_ctrls = pool.submit(controls, 0)
            for k in range(len(edges) - 1):
                steps, (sim, ctrls) = next_ctrls.result()
                if k + 2 < len(edges):
                    next_ctrls = pool.submit(controls, k + 1)
                out = {
                    r: f[: batch.n * len(steps) * sizes[r]].reshape(batch.n, len(steps), -1)
                    for r, f in flat[k % 2].items()
                }
                if stepper is not None:
                    rec = stepper.rollout(sim, out)
                else:
                    try:
                        rec = b.rollout(len(steps), control=sim, control_spec=spec, record=tuple(sizes), out=out)
                    except SimulationError:
                        rec = out  # failed simulations are marked below; their records repeat
                failed = failed | (np.asarray(b.status) != 0) | (b.warning[:, UNSTABLE, 1].sum(-1) > 0)
                if self.progress is not None:
                    self.progress(batch.n * len(steps))
                if pending is not None:
                    accs = pending.result()
                if k + 2 < len(edges):
                    pending = pool.submit(fold_all, accs, rec, steps, ctrls, failed.copy(), first)
                    first = rec["qvel"][:, -1, lay.motor_dof]  # fancy indexing: a copy
        with ThreadPoolExecutor(min(cpus(), len(tiles))) as tail:  # every CPU is free now
            accs = list(tail.map(lambda acc, tile: fold(acc, rec, steps, ctrls, failed, first, tile), accs, tiles))
            cols = list(tail.map(lambda acc: stats.finalize(acc, self.cfg), accs))
        out = {k: np.concatenate([c[k] for c in cols]) for k in cols[0]}
        out["solver_limit_share"] = at_limit / self.cfg.n_steps
        return out


_POOL: dict[str, Any] = {}  # the worker processes, kept for the process's life (their imports and compiles)
_ALONE: dict[bytes, MujocoEngine] = {}  # in a worker process: its engine per (scenario, statistics, block)


def _process_pool(workers: int):
    """The worker processes, at least `workers` of them (started fresh, not forked: JAX's threads do not survive
    a fork); made once, grown by replacing it."""
    pool = _POOL.get("pool")
    if pool is None or _POOL["workers"] < workers:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        _drop_pool()
        pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"), initializer=_worker_start)
        _POOL.update(pool=pool, workers=workers)
    return pool


def _drop_pool() -> None:
    pool = _POOL.pop("pool", None)
    _POOL.pop("workers", None)
    if pool is not None:
        pool.shutdown(wait=False, cancel_futures=True)


# the pool goes before the interpreter's teardown, while the modules its clean-up needs are still there
atexit.register(_drop_pool)


def _worker_start() -> None:
    """A worker process's JAX on the CPU alone: on a GPU host it would otherwise start the GPU backend (and
    reserve its memory) in every worker. The worker is this engine's own process: its settings are its own."""
    jax.config.update("jax_platforms", "cpu")


def _run_part_alone(scenario: Scenario, cfg: stats.StatsConfig, block: int, batch: VariantBatch):
    """One part's columns in a worker process, on one MuJoCo thread, and MuJoCo's warnings there."""
    import pickle

    key = pickle.dumps((scenario, cfg, block))
    engine = _ALONE.get(key)
    if engine is None:
        _ALONE.clear()
        engine = _ALONE[key] = MujocoEngine(scenario, cfg, batch.n, nthread=1, block=block, processes=False)
    with captured_warnings() as messages:
        cols = engine._run_part(batch, 1)
    return cols, messages[:5]


def _rows(batch: VariantBatch, rows: slice) -> VariantBatch:
    """The variants `rows` of a batch."""
    fields = {k: v[rows] for k, v in batch.fields.items()}
    params = {k: np.asarray(v)[rows] for k, v in batch.params.items()}
    return VariantBatch(batch.model, fields, params, rows.stop - rows.start)


class _Stepper:
    """Steps a Batch one step at a time with what acts between MuJoCo's steps: the slip tyre's or the soil's
    wrenches, and the dcmotors' drive (their voltages from the scenario's controls); records what
    `Batch.rollout` would (qpos, qvel, qfrc_actuator, solver_niter, ... after each step) and the drive's
    record (`drive_T`, `drive_v`)."""

    DRIVE = ("T", "v")  # the drive's record kept (drive.step)

    def __init__(self, b, m: mujoco.MjModel, lay, params):
        self.b, self.nu, self.nbody = b, m.nu, m.nbody
        self.tyre = MujocoTyre(m, lay, params) if lay.applied else None
        self.drive = MujocoDrive(lay, params, m.opt.timestep) if lay.dcmotor else None
        names = ("qpos", "qvel", "qfrc_actuator", "solver_niter", "actuator_force", "actuator_velocity", "act")
        self.live = {k: b.bind(k) for k in names}
        self.ctrl, self.xfrc = b.bind("ctrl"), b.bind("xfrc_applied")
        self.xpos, self.xmat, self.cfrc = b.bind("xpos"), b.bind("xmat"), b.bind("cfrc_ext")
        self.width = 16 if lay.dcmotor else self.nu  # the scenario's controls: the servo's 16 with dcmotors

    def rollout(self, ctrls: np.ndarray, out: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """ctrls (n, nstep, width [+ nbody * 6 of a mission's xfrc_applied]); records into `out`."""
        from mujoco.batch import SimulationError

        n, w = ctrls.shape[0], self.width
        for k in range(ctrls.shape[1]):
            if self.drive is not None:
                self.ctrl[:] = self.drive.voltages(ctrls[:, k, :w], self.live["qpos"], self.live["qvel"])
            else:
                self.ctrl[:] = ctrls[:, k, :w]
            wrench = None
            if self.tyre is not None:
                xmat = self.xmat.reshape(n, self.nbody, 3, 3)
                wrench = self.tyre.wrench(self.xpos, xmat, self.live["qvel"], self.cfrc, self.xfrc)
            if ctrls.shape[2] > w:  # a mission's slope forces
                slope = ctrls[:, k, w:].reshape(n, self.nbody, 6)
                wrench = slope if wrench is None else wrench + slope
            if wrench is not None:
                self.xfrc[:] = wrench
            try:
                self.b.step()
            except SimulationError:
                pass  # failed simulations are marked by the caller from the batch's status
            for name, arr in out.items():
                if name.startswith("drive_"):
                    arr[:, k] = self.drive.record[name[6:]]
                else:
                    arr[:, k] = self.live[name].reshape(n, -1)
        return out
