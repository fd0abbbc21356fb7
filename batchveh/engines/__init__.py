"""The engines that run a chunk of variants: one small protocol, one module each.

An engine is built for one scenario and reduction (`stats.StatsConfig`) and has
`run(batch: VariantBatch) -> dict[str, (n,) array]`: the statistics columns of
`stats.finalize`, the same for every engine. It also tells its `name`, `implementation`,
`chunk_size`, `compiles` and `compile_s`.

- `mujoco` (engines/mujoco.py): MuJoCo C through mujoco.batch, on the CPU; the reference.
- `mjx` (engines/mjx.py): MuJoCo MJX, JAX implementation, on JAX's devices.
- `warp` (engines/warp.py): MuJoCo Warp 4.0 (`mujoco_warp`, engines/warp_physics.py) as the physics of
  the same scan, float32, on one CUDA GPU or the CPU.

`implementation` is a line for the manifest and the Parquet metadata.
"""

from __future__ import annotations

from batchveh.engines.common import auto_chunk, has_gpu, resolve_backend
from batchveh.model.scenarios import Scenario
from batchveh.stepping import stats

ENGINES = ("mujoco", "mjx", "warp")

__all__ = ["ENGINES", "auto_chunk", "has_gpu", "make_engine", "resolve_backend"]


def make_engine(
    name: str,
    scenario: Scenario,
    cfg: stats.StatsConfig,
    chunk_size: int | None,
    n_variants: int | None = None,
    *,
    precision: str = "f32",
    matmul_precision: str = "highest",
    nthread: int = 0,
):
    """Build the named engine ('mujoco', 'mjx' or 'warp'); chunk size automatic unless given.

    precision (mjx): 'f32' or 'f64', scoped to the engine's calls (warp: f32 only). nthread (mujoco): MuJoCo
    threads; 0 for `engines.mujoco.default_threads()`."""
    chunk = chunk_size or auto_chunk(name, n_variants)
    if name == "warp":
        from batchveh.engines.warp import WarpEngine

        return WarpEngine(scenario, cfg, chunk, precision)
    if name == "mjx":
        from batchveh.engines.mjx import MjxEngine

        return MjxEngine(scenario, cfg, chunk, matmul_precision, precision)
    from batchveh.engines.mujoco import MujocoEngine

    return MujocoEngine(scenario, cfg, chunk, nthread)
