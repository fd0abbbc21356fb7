"""The sweep engine: run chunks of variants on MJX or on MuJoCo C (`mujoco.batch`).

Both backends return the same columns (`stats.finalize`), one (n,) array each.

- `MjxBackend`: one `jit(vmap(rollout))` per chunk shape; the model fields that
  vary are batched with an `in_axes` tree; time runs in `lax.scan` and the
  statistics live in its carry. A short last chunk is padded to the chunk shape
  (no second compile). Variants are sharded over all local devices. On a GPU the
  constraint solve is batchveh.solver's fused Newton solver (`solver.impl`). On the CPU,
  `lax.map` runs the vmap in blocks of 64: wider Newton vmaps hung in jaxlib's
  batched Cholesky there.
- `MujocoBackend`: `mujoco.batch.Batch` on all CPU threads; per-variant model
  fields through `expand()`; `Batch.rollout` steps a block of 100 steps while a
  worker thread folds the previous block into the same statistics (numpy).
"""

from __future__ import annotations

import os
import time
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from batchveh import stats
from batchveh.scenarios import Scenario, control_schedule
from batchveh.variants import VariantBatch
from batchveh.vehicle import layout

CPU_BLOCK = 64


def has_gpu() -> bool:
    """Whether JAX sees an accelerator."""
    try:
        return any(d.platform != "cpu" for d in jax.devices())
    except RuntimeError:
        return False


def resolve_backend(name: str) -> str:
    """'auto' is mjx when JAX sees a GPU, otherwise mujoco."""
    if name == "auto":
        return "mjx" if has_gpu() else "mujoco"
    return name


def resolve_solver_impl(name: str) -> str:
    """The MJX backend's solver code: 'auto' is 'fused' (batchveh.solver) when JAX sees a GPU,
    else 'mjx' (MJX's own: on the CPU it is faster and compiles sooner)."""
    if name == "auto":
        return "fused" if has_gpu() else "mjx"
    return name


def _pad(batch: VariantBatch, size: int) -> VariantBatch:
    """Repeat the last variant so the chunk has `size` variants (same compiled shape)."""
    extra = size - batch.n
    if extra <= 0:
        return batch

    def pad(a):
        return np.concatenate([a, np.repeat(a[-1:], extra, axis=0)], axis=0)

    return VariantBatch(
        batch.model, {k: pad(v) for k, v in batch.fields.items()}, {k: pad(v) for k, v in batch.params.items()}, size
    )


class MjxBackend:
    """MJX on the default JAX device(s)."""

    name = "mjx"

    def __init__(
        self,
        scenario: Scenario,
        cfg: stats.StatsConfig,
        chunk_size: int,
        matmul_precision: str = "highest",
        solver_impl: str = "auto",
    ):
        self.scenario, self.cfg = scenario, cfg
        # 'highest': true float32 products; JAX's GPU default may use reduced-precision (TF32) units
        self.matmul_precision = matmul_precision
        self.devices = jax.devices()
        self.on_cpu = self.devices[0].platform == "cpu"
        self.solver_impl = resolve_solver_impl(solver_impl)
        nd = len(self.devices)
        self.chunk_size = max(nd, (chunk_size // nd) * nd)
        self._fn: dict[Any, Any] = {}
        self.compile_s = 0.0

    @property
    def compiles(self) -> int:
        """Programs compiled so far (one per set of varying fields and chunk shape)."""
        return len(self._fn)

    def _compiled(self, batch: VariantBatch, mx, axes, params):
        from batchveh.rollout import mjx_stats
        from batchveh.solver import fused_solver

        key = (tuple(sorted(batch.fields)), batch.n)
        if key in self._fn:
            return self._fn[key]
        lay = layout(batch.model)
        one = lambda m, p: mjx_stats(m, p, scenario=self.scenario, cfg=self.cfg, lay=lay)  # noqa: E731
        if self.on_cpu and batch.n > CPU_BLOCK:
            # lax.map scans over blocks of CPU_BLOCK variants, vmapping `one` within a block
            tree = jax.tree_util.tree_structure(mx)
            varying = [i for i, a in enumerate(tree.flatten_up_to(axes)) if a == 0]

            def run(m, p):
                leaves_all = jax.tree_util.tree_leaves(m)

                def one_of(x):
                    leaves = list(leaves_all)
                    for j, i in enumerate(varying):
                        leaves[i] = x[0][j]
                    return one(tree.unflatten(leaves), x[1])

                return jax.lax.map(one_of, ([leaves_all[i] for i in varying], p), batch_size=CPU_BLOCK)

            fn = jax.jit(run)
        else:
            fn = jax.jit(jax.vmap(one, in_axes=(axes, 0)))
        t0 = time.perf_counter()
        with jax.default_matmul_precision(self.matmul_precision), fused_solver(self.solver_impl == "fused"):
            compiled = fn.lower(mx, params).compile()
        self.compile_s += time.perf_counter() - t0
        self._fn[key] = compiled
        return compiled

    def run(self, batch: VariantBatch) -> dict[str, np.ndarray]:
        from batchveh.rollout import put_batch

        n = batch.n
        batch = _pad(batch, self.chunk_size)
        mx, axes = put_batch(batch)
        dtype = jnp.result_type(float)
        params = {k: jnp.asarray(v, dtype) for k, v in batch.params.items()}
        if len(self.devices) > 1:
            from jax.sharding import Mesh, NamedSharding, PartitionSpec

            # variants split over the devices; everything else replicated on each
            mesh = Mesh(np.array(self.devices), ("v",))
            split, whole = NamedSharding(mesh, PartitionSpec("v")), NamedSharding(mesh, PartitionSpec())
            params = jax.device_put(params, split)
            mx = jax.tree_util.tree_map(
                lambda x, a: jax.device_put(x, split if a == 0 else whole), mx, axes, is_leaf=lambda x: x is None
            )
        fn = self._compiled(batch, mx, axes, params)
        out = jax.device_get(fn(mx, params))
        return {k: np.asarray(v)[:n] for k, v in out.items()}


def default_threads() -> int:
    """MuJoCo threads for the C backend: every CPU but one on machines of 8 or more.

    The fold and control threads need a core: with all 16 cores of a GPU host stepping, a
    worker that shares its core with them straggles and the whole block waits. Alternated
    with raw mujoco.batch (benchmarks/cpu_overhead.py, 16 cores): 16 threads 0.90x (median
    of 4), 15 threads 1.02x. On 2 cores, 1 thread would halve the speed."""
    n = os.cpu_count() or 1
    return n - 1 if n >= 8 else n


class MujocoBackend:
    """MuJoCo C through mujoco.batch.Batch on all CPU threads (float64)."""

    name = "mujoco"
    solver_impl = "mujoco"  # MuJoCo C's own solver
    compile_s = 0.0
    compiles = 0

    def __init__(self, scenario: Scenario, cfg: stats.StatsConfig, chunk_size: int, nthread: int = 0):
        self.scenario, self.cfg, self.chunk_size = scenario, cfg, chunk_size
        self.nthread = nthread or default_threads()
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
        dt = m.opt.timestep
        sizes = {"qpos": m.nq, "qvel": m.nv, "qfrc_actuator": m.nv}
        starts = list(range(0, self.cfg.n_steps, block))

        def controls(start):
            steps = np.arange(start, min(start + block, self.cfg.n_steps))
            return steps, np.asarray(self._ctrl(params, jnp.asarray(steps * dt)), np.float64)

        def fold(acc, rec, steps, ctrls, failed):
            sample = stats.sample(rec["qpos"], rec["qvel"], rec["qfrc_actuator"], ctrls, lay)
            if failed.any():
                sample["tau"] = np.where(failed[:, None, None], np.nan, sample["tau"])
            return stats.update(acc, sample, steps, self.cfg)

        acc = stats.init(self.cfg, (batch.n,))
        bufs = [None, None]
        # two workers: one folds block k-1, the other computes block k+1's controls (JAX),
        # both while MuJoCo steps block k
        with ThreadPoolExecutor(2) as pool:
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
                failed = np.asarray(b.status) != 0
                if pending is not None:
                    acc = pending.result()
                pending = pool.submit(fold, acc, rec, steps, ctrls, failed)
            acc = pending.result()
        return stats.finalize(acc, self.cfg)


GPU_CHUNK_MAX = 131072  # fused solver: 131k ran 8-11% faster than 65k on one H200 (benchmarks/RESULTS.md)
GPU_BYTES_PER_VARIANT = 19e3  # measured peak device memory per variant (2.47 GB at 131072)


def auto_chunk(name: str, n_variants: int | None) -> int:
    """Variants per chunk: as many as fit (GPU) in equal chunks, with little padding."""
    if name == "mujoco":
        return 1024
    if not has_gpu():
        return 256
    limit = GPU_CHUNK_MAX
    stats_ = jax.devices()[0].memory_stats() or {}
    if "bytes_limit" in stats_:
        limit = min(limit, int(0.5 * stats_["bytes_limit"] / GPU_BYTES_PER_VARIANT))
    limit *= len(jax.devices())
    if not n_variants:
        return limit
    n_chunks = -(-n_variants // limit)
    per = -(-n_variants // n_chunks)
    return -(-per // 256) * 256


def make_backend(
    name: str,
    scenario: Scenario,
    cfg: stats.StatsConfig,
    chunk_size: int | None,
    n_variants: int | None = None,
    matmul_precision: str = "highest",
    solver_impl: str = "auto",
    nthread: int = 0,
):
    """Build the named backend ('mjx' or 'mujoco'); chunk size automatic unless given.

    solver_impl (mjx): 'fused' (batchveh.solver), 'mjx' (MJX's own), 'auto' (fused on a GPU).
    nthread (mujoco): MuJoCo threads; 0 for `default_threads()`."""
    chunk = chunk_size or auto_chunk(name, n_variants)
    if name == "mjx":
        return MjxBackend(scenario, cfg, chunk, matmul_precision, solver_impl)
    return MujocoBackend(scenario, cfg, chunk, nthread)
