"""The `warp` engine: MJX's Warp implementation (MuJoCo Warp, vendored in mujoco-mjx), float32.

The same `jit(vmap(rollout))` as the `mjx` engine, with the statistics in the scan's
carry: MJX hands the vmapped step to MuJoCo Warp as one batch of worlds, and the
batched model fields (`batch.mjx_model(..., 'warp')`) as per-world fields. It
collides every geom pair MuJoCo C does (cylinder wheels on boxes included).

- Solver health is data, not output: Warp's overflow and iteration-limit messages are
  off, and the column `solver_limit_share` gives each variant's share of steps whose
  solve stopped on `opt.iterations` rather than on the tolerance.
- Contact buffers are sized per world (`contacts_per_world`); a world that runs out of
  them (a vehicle on its back) is reported `diverged`.
- One device: MuJoCo Warp's JAX call has no sharding rule (under `shard_map` over two
  GPUs the process died), so a host with several GPUs runs one process per GPU
  (`CUDA_VISIBLE_DEVICES`).
- On the CPU it runs too (slowly): that is how CI checks it against MuJoCo C. Warp compiles
  its kernels once per machine (about 30 s on 2 cores, kept in Warp's kernel cache).
"""

from __future__ import annotations

import threading
from typing import Any

import jax
import mujoco
import numpy as np

from batchveh.config import ConfigError
from batchveh.engines.common import warp_installed
from batchveh.engines.mjx import MjxEngine
from batchveh.model.vehicle import layout
from batchveh.stepping.batch import SAMEFRAME, WARP_UNREAD, VariantBatch, import_mjx
from batchveh.stepping.rollout import mjx_stats

# contacts a world may hold: 2 per cylinder wheel (MuJoCo Warp), 1 per sphere wheel, and room for a
# chassis and hubs that touch the ground on a flipped vehicle
CONTACTS_PER_WORLD = 24


def constraint_rows(m: mujoco.MjModel, contacts: int) -> int:
    """Constraint rows a world may need: friction-loss dofs, limits, equality rows and `contacts`
    contacts at the model's largest condim (pyramidal: 2 (condim - 1) rows; elliptic: condim)."""
    condim = int(m.geom_condim.max())
    per_contact = condim if m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC else max(1, 2 * (condim - 1))
    limits = int(np.count_nonzero(m.jnt_limited)) * 2
    return int(np.count_nonzero(m.dof_frictionloss)) + limits + 6 * m.neq + contacts * per_contact


class WarpEngine(MjxEngine):
    """MJX's Warp implementation on the first JAX device (a CUDA GPU, or the CPU), float32."""

    name = "warp"
    impl = "warp"

    def __init__(self, scenario, cfg, chunk_size: int, precision: str = "f32", contacts_per_world: int = 0):
        if precision != "f32":
            raise ConfigError(
                f"precision: {precision!r} is not available on the warp backend (MuJoCo Warp computes in float32); "
                "allowed: f32, or the mjx or mujoco backend for f64"
            )
        if not warp_installed():
            raise ConfigError(
                "the warp backend needs warp-lang 1.18.0; allowed: pip install -e '.[gpu]' (or warp-lang==1.18.0), "
                "or the mjx or mujoco backend"
            )
        super().__init__(scenario, cfg, chunk_size, precision="f32")
        self.devices = self.devices[:1]
        self.chunk_size = chunk_size
        self.contacts_per_world = contacts_per_world or CONTACTS_PER_WORLD
        # steps per iteration of the scan's loop: 2, 3 and 5 ran no faster than 1 on one H200 (11.06-11.11 s for
        # 100,000 variants x 2,100 steps, benchmarks/results/archive.json: h200-warp-unroll.json) and compile longer
        self.scan_unroll = 1
        self.ahead: dict[str, Any] = {}  # what building the kernels ahead took (warp_build.AheadBuild.wait)
        self._built = None  # the AheadBuild of the program compiled last, until a chunk has run on it
        if self.devices[0].platform == "gpu":
            from batchveh.engines import warp_build

            # a machine that never built a vehicle's kernels: the workers start now, and import while the
            # engine prepares its first chunk
            try:
                if warp_build.enabled() and warp_build.may_spawn() and warp_build.cold():
                    warp_build.start_workers(f"cuda:{self.devices[0].id}")
            except Exception:  # noqa: BLE001 - a head start only: the first launch builds what is missing
                warp_build.stop_workers()

    @property
    def implementation(self) -> str:
        import warp

        return f"MuJoCo MJX {mujoco.__version__}, Warp implementation (MuJoCo Warp), warp-lang {warp.__version__}"

    def _call_context(self):
        """Warp's own messages (initialisation, kernel loading) off, errors still shown: Warp's
        scoped log level, restored when the chunk is done."""
        import warp

        return warp.ScopedLogLevel(warp.LOG_ERROR)

    def _compiled(self, batch: VariantBatch, mx, axes, params):
        """The chunk's program; on a GPU whose Warp kernel cache lacks this vehicle's kernels, worker processes
        build them while JAX compiles (`warp_build`), and the first launch waits for them."""
        ahead = None
        first = (tuple(sorted(batch.fields)), batch.n) not in self._fn
        if first and self.devices[0].platform == "gpu":
            from batchveh.engines import warp_build

            batched = {k: batch.n for k in batch.fields if k not in WARP_UNREAD and k not in SAMEFRAME}
            sizes = (constraint_rows(batch.model, self.contacts_per_world), self.contacts_per_world)
            device = f"cuda:{self.devices[0].id}"
            try:
                if warp_build.wanted(batch.model, batched, *sizes):
                    ahead = warp_build.AheadBuild(batch.model, batched, *sizes, device=device)
                else:
                    warp_build.stop_workers()  # started with the engine, not needed for this model
                    if warp_build.thread_wanted(batch.model, batched, *sizes):
                        threading.Thread(target=warp_build.load_file_modules, args=(device,), daemon=True).start()
            except Exception:  # noqa: BLE001 - a head start only: the first launch builds what is missing
                ahead = None
                warp_build.stop_workers()
        try:
            compiled = super()._compiled(batch, mx, axes, params)
        finally:
            if ahead is not None:
                self.ahead = ahead.wait()
        self._built = ahead  # its marker is written once a chunk has run on the compiled program
        return compiled

    def run(self, batch: VariantBatch) -> dict[str, np.ndarray]:
        try:
            out = super().run(batch)
        except BaseException:
            self._built = None  # no chunk ran: no marker
            raise
        built, self._built = self._built, None
        if built is not None:  # the first chunk ran: this vehicle's kernels are all in Warp's cache now
            built.done()
        return out

    def _program(self, batch: VariantBatch, mx, axes):
        mjx = import_mjx()
        lay = layout(batch.model)
        data = mjx.make_data(
            batch.model,
            impl="warp",
            naconmax=batch.n * self.contacts_per_world,
            njmax=constraint_rows(batch.model, self.contacts_per_world),
        )

        one = lambda m, p: mjx_stats(  # noqa: E731
            m, p, scenario=self.scenario, cfg=self.cfg, lay=lay, data=data, unroll=self.scan_unroll
        )
        return jax.vmap(one, in_axes=(axes, 0))
