"""The engines that run a chunk of variants: one small protocol, one module each.

An engine is built for one scenario and reduction (`stats.StatsConfig`) and has
`run(batch: VariantBatch) -> dict[str, (n,) array]`: the statistics columns of
`stats.finalize`, the same for every engine. It also tells its `name`,
`solver_impl`, `chunk_size`, `compiles` and `compile_s`.

- `mujoco` (engines/mujoco.py): MuJoCo C through mujoco.batch, on the CPU; the reference.
- `mjx` (engines/mjx.py): MuJoCo MJX, JAX implementation, on JAX's devices.
"""

from __future__ import annotations

from batchveh import stats
from batchveh.engines.common import auto_chunk, has_gpu, resolve_backend, resolve_solver_impl
from batchveh.scenarios import Scenario

ENGINES = ("mujoco", "mjx")

__all__ = ["ENGINES", "auto_chunk", "has_gpu", "make_engine", "resolve_backend", "resolve_solver_impl"]


def make_engine(
    name: str,
    scenario: Scenario,
    cfg: stats.StatsConfig,
    chunk_size: int | None,
    n_variants: int | None = None,
    *,
    precision: str = "f32",
    matmul_precision: str = "highest",
    solver_impl: str = "auto",
    nthread: int = 0,
):
    """Build the named engine ('mjx' or 'mujoco'); chunk size automatic unless given.

    precision (mjx): 'f32' or 'f64', scoped to the engine's calls. solver_impl (mjx): 'fused'
    (batchveh.solver), 'mjx' (MJX's own), 'auto' (fused on a GPU). nthread (mujoco): MuJoCo
    threads; 0 for `engines.mujoco.default_threads()`."""
    chunk = chunk_size or auto_chunk(name, n_variants)
    if name == "mjx":
        from batchveh.engines.mjx import MjxEngine

        return MjxEngine(scenario, cfg, chunk, matmul_precision, solver_impl, precision)
    from batchveh.engines.mujoco import MujocoEngine

    return MujocoEngine(scenario, cfg, chunk, nthread)
