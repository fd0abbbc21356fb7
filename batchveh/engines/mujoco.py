"""The `mujoco` engine: MuJoCo C through `mujoco.batch.Batch` on the CPU threads (float64).

Per-variant model fields go in through `expand()`; `Batch.rollout` steps a block of
100 steps while a worker thread folds the previous block into the statistics (the
same `stats` reduction as MJX's, in numpy) and another computes the next block's
controls. A simulation whose MuJoCo warning counters rise (NaN, Inf or huge qpos,
qvel or qacc: MuJoCo would reset it) stops stepping in `rollout`; it is reported
`diverged`, and MuJoCo's warning text is kept as data (`warnings`), not printed.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from batchveh import stats
from batchveh.batch import VariantBatch
from batchveh.scenarios import Scenario, control_schedule
from batchveh.vehicle import layout

# warnings that mean the simulation's state is no longer valid
UNSTABLE = [
    int(w)
    for w in (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)
]


def default_threads() -> int:
    """MuJoCo threads for the C engine: every CPU but one on machines of 8 or more.

    The fold and control threads need a core: with all 16 cores of a GPU host stepping, a
    worker that shares its core with them straggles and the whole block waits. Alternated
    with raw mujoco.batch (benchmarks/cpu_overhead.py, 16 cores): 16 threads 0.90x (median
    of 4), 15 threads 1.02x. On 2 cores, 1 thread would halve the speed."""
    n = os.cpu_count() or 1
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
    solver_impl = "mujoco"  # MuJoCo C's own solver
    compile_s = 0.0
    compiles = 0

    def __init__(self, scenario: Scenario, cfg: stats.StatsConfig, chunk_size: int, nthread: int = 0):
        self.scenario, self.cfg, self.chunk_size = scenario, cfg, chunk_size
        self.nthread = nthread or default_threads()
        self.warnings: list[str] = []  # MuJoCo's messages, first few of the sweep
        # controls (n, block, nu) for a block of steps of every variant, computed by JAX
        self._ctrl = jax.jit(jax.vmap(control_schedule(scenario), in_axes=(0, None)))

    def run(self, batch: VariantBatch, block: int = 100) -> dict[str, np.ndarray]:
        """Step the chunk in blocks; while MuJoCo steps block k on all threads, worker threads
        fold block k-1's records into the statistics and compute block k+1's controls (all
        release the GIL)."""
        from concurrent.futures import ThreadPoolExecutor

        from mujoco.batch import Batch, SimulationError

        m = batch.model
        lay = layout(m)
        b = Batch(m, nsim=batch.n, nthread=self.nthread)
        for name, values in batch.fields.items():
            b.expand(name)[:] = values
        b.reset()
        params = {k: jnp.asarray(v) for k, v in batch.params.items()}
        radius = np.asarray(batch.params["wheel.radius"], np.float64)[:, None]
        dt = m.opt.timestep
        sizes = {"qpos": m.nq, "qvel": m.nv, "qfrc_actuator": m.nv}
        starts = list(range(0, self.cfg.n_steps, block))

        def controls(start):
            steps = np.arange(start, min(start + block, self.cfg.n_steps))
            return steps, np.asarray(self._ctrl(params, jnp.asarray(steps * dt)), np.float64)

        def fold(acc, rec, steps, ctrls, failed):
            sample = stats.sample(rec["qpos"], rec["qvel"], rec["qfrc_actuator"], ctrls, radius, lay)
            if failed.any():
                sample["tau"] = np.where(failed[:, None, None], np.nan, sample["tau"])
            return stats.update(acc, sample, steps, self.cfg)

        acc = stats.init(self.cfg, (batch.n,))
        bufs = [None, None]
        failed = np.zeros(batch.n, bool)
        # two workers: one folds block k-1, the other computes block k+1's controls (JAX),
        # both while MuJoCo steps block k
        with ThreadPoolExecutor(2) as pool, captured_warnings() as messages:
            pending = None
            next_ctrls = pool.submit(controls, starts[0])
            for k in range(len(starts)):
                steps, ctrls = next_ctrls.result()
                if k + 1 < len(starts):
                    next_ctrls = pool.submit(controls, starts[k + 1])
                if bufs[k % 2] is None or bufs[k % 2]["qpos"].shape[1] != len(steps):
                    bufs[k % 2] = {r: np.empty((batch.n, len(steps), n)) for r, n in sizes.items()}
                try:
                    rec = b.rollout(len(steps), control=ctrls, record=tuple(sizes), out=bufs[k % 2])
                except SimulationError:
                    rec = bufs[k % 2]  # failed simulations are marked below; their records repeat
                failed = failed | (np.asarray(b.status) != 0) | (b.warning[:, UNSTABLE, 1].sum(-1) > 0)
                if pending is not None:
                    acc = pending.result()
                pending = pool.submit(fold, acc, rec, steps, ctrls, failed.copy())
            acc = pending.result()
        self.warnings.extend(messages[: max(0, 5 - len(self.warnings))])
        return stats.finalize(acc, self.cfg)
