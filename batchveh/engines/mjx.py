"""The `mjx` engine: MuJoCo MJX (JAX implementation), one `jit(vmap(rollout))` per chunk shape.

The model fields that vary are batched with an `in_axes` tree (`batch.mjx_model`);
time runs in `lax.scan` and the statistics live in its carry. A short last chunk is
padded to the chunk shape (no second compile). Variants are sharded over all local
devices. The constraint solve is MJX's own. On the CPU, `lax.map` runs the vmap in blocks of 64: wider Newton
vmaps hung in jaxlib's batched Cholesky there. The whole chunk (model upload,
trace, compile and call) runs inside `rollout.float_precision`, so float64 is
scoped to the engine and never switched on for the process.
"""

from __future__ import annotations

import contextlib
import time
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from batchveh.engines.common import pad
from batchveh.model.scenarios import Scenario
from batchveh.model.vehicle import layout
from batchveh.stepping import stats
from batchveh.stepping.batch import VariantBatch, mjx_model
from batchveh.stepping.rollout import float_precision, mjx_stats

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
        precision: str = "f32",
    ):
        self.scenario, self.cfg, self.precision = scenario, cfg, precision
        # 'highest': true float32 products; JAX's GPU default may use reduced-precision (TF32) units
        self.matmul_precision = matmul_precision
        self.devices = jax.devices()
        self.on_cpu = self.devices[0].platform == "cpu"
        nd = len(self.devices)
        self.chunk_size = max(nd, (chunk_size // nd) * nd)
        self._fn: dict[Any, Any] = {}
        self.compile_s = 0.0

    @property
    def compiles(self) -> int:
        """Programs compiled so far (one per set of varying fields and chunk shape)."""
        return len(self._fn)

    @property
    def implementation(self) -> str:
        """What steps the variants, for the manifest and the Parquet metadata."""
        return f"MuJoCo MJX {mujoco.__version__}, JAX implementation"

    def _program(self, batch: VariantBatch, mx, axes):
        """The function of (model, params) to compile for the chunk."""
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

            return run
        return jax.vmap(one, in_axes=(axes, 0))

    def _compiled(self, batch: VariantBatch, mx, axes, params):
        key = (tuple(sorted(batch.fields)), batch.n)
        if key in self._fn:
            return self._fn[key]
        fn = jax.jit(self._program(batch, mx, axes))
        t0 = time.perf_counter()
        with jax.default_matmul_precision(self.matmul_precision):
            compiled = fn.lower(mx, params).compile()
        self.compile_s += time.perf_counter() - t0
        self._fn[key] = compiled
        return compiled

    def _call_context(self):
        """The context around a chunk's upload, compile and call."""
        return contextlib.nullcontext()

    def run(self, batch: VariantBatch) -> dict[str, np.ndarray]:
        """Statistics columns of the chunk's variants, (n,) each."""
        n = batch.n
        batch = pad(batch, self.chunk_size)
        with float_precision(self.precision), self._call_context():
            mx, axes = mjx_model(batch)
            params = host_params(batch, jnp.result_type(float))
            if len(self.devices) > 1:
                from jax.sharding import Mesh, NamedSharding, PartitionSpec

                # variants split over the devices; everything else replicated on each
                mesh = Mesh(np.array(self.devices), ("v",))
                split, whole = NamedSharding(mesh, PartitionSpec("v")), NamedSharding(mesh, PartitionSpec())
                params = jax.device_put(params, split)
                mx = jax.tree_util.tree_map(
                    lambda x, a: jax.device_put(x, split if a == 0 else whole), mx, axes, is_leaf=lambda x: x is None
                )
            else:
                params = jax.device_put(params)
            fn = self._compiled(batch, mx, axes, params)
            out = jax.device_get(fn(mx, params))
        return {k: np.asarray(v)[:n] for k, v in out.items()}


def host_params(batch: VariantBatch, dtype) -> dict[str, np.ndarray]:
    """The chunk's parameters in `dtype`, converted on the host, to be sent as they are: a conversion on the device
    copied each array (the warp engine, one H100: 90 ms of copies a chunk of 131,072; 0.884-0.885x MuJoCo Warp alone
    against 0.874-0.877x, benchmarks/results/h100-params-ab-warp-profile.json)."""
    return {k: np.asarray(v, dtype) for k, v in batch.params.items()}
