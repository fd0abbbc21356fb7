"""The `mjx` engine: MuJoCo MJX (JAX implementation), one `jit(vmap(rollout))` per chunk shape.

The model fields that vary are batched with an `in_axes` tree (`batch.mjx_model`);
time runs in `lax.scan` and the statistics live in its carry. A short last chunk is
padded to the chunk shape (no second compile). Variants are sharded over all local
devices. On a GPU the constraint solve is batchveh.solver's fused Newton solver
(`solver.impl`). On the CPU, `lax.map` runs the vmap in blocks of 64: wider Newton
vmaps hung in jaxlib's batched Cholesky there. The whole chunk (model upload,
trace, compile and call) runs inside `rollout.float_precision`, so float64 is
scoped to the engine and never switched on for the process.
"""

from __future__ import annotations

import time
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from batchveh import stats
from batchveh.batch import VariantBatch, mjx_model
from batchveh.engines.common import pad, resolve_solver_impl
from batchveh.rollout import float_precision, mjx_stats
from batchveh.scenarios import Scenario
from batchveh.vehicle import layout

CPU_BLOCK = 64


class MjxEngine:
    """MJX on the default JAX device(s)."""

    name = "mjx"

    def __init__(
        self,
        scenario: Scenario,
        cfg: stats.StatsConfig,
        chunk_size: int,
        matmul_precision: str = "highest",
        solver_impl: str = "auto",
        precision: str = "f32",
    ):
        self.scenario, self.cfg, self.precision = scenario, cfg, precision
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
        """Statistics columns of the chunk's variants, (n,) each."""
        n = batch.n
        batch = pad(batch, self.chunk_size)
        with float_precision(self.precision):
            mx, axes = mjx_model(batch)
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
