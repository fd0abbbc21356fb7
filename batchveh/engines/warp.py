"""The `warp` engine: MuJoCo Warp (`mujoco_warp`) stepping every variant of a chunk as one world, float32.

The same scan as the `mjx` engine (`rollout.physics_stats`: the controls, the drive, the tyre, the
statistics in the carry, vmapped), with MuJoCo Warp itself as the physics (`engines/warp_physics.py`):
its model and data stay on the device, the variant's parameters are its per-world model fields, and each
step is one Warp call on all worlds, captured as a CUDA graph. It collides every geom pair MuJoCo C does
(cylinder wheels on boxes included).

- Solver health is data, not output: the column `solver_limit_share` gives each variant's share of steps
  whose solve stopped on `opt.iterations` rather than on the tolerance.
- Contact buffers: `contacts_per_world` (24) times the chunk's worlds, shared by all of them (MuJoCo Warp's
  `naconmax`), and the constraint rows those contacts need per world. A world whose buffer ran out (MuJoCo
  Warp's `overflow` bits: it dropped what did not fit) is reported `diverged`. The vehicle on its wheels uses
  2 contacts per cylinder wheel.
- One device: a host with several GPUs runs one process per GPU (`CUDA_VISIBLE_DEVICES`).
- `deterministic`: MuJoCo Warp's `Option.deterministic` (stable contact order, canonical constraint rows,
  invariant atomic sums), so that two runs give the same bits.
- On the CPU it runs too (slowly): that is how CI checks it against MuJoCo C. Warp compiles its kernels
  once per machine (kept in Warp's kernel cache).
"""

from __future__ import annotations

import time
from typing import Any

import jax
import mujoco
import numpy as np

from batchveh.config import ConfigError
from batchveh.engines.common import pad, warp_installed
from batchveh.engines.mjx import MjxEngine, host_params
from batchveh.model import course
from batchveh.model.vehicle import layout
from batchveh.stepping.batch import SAMEFRAME, WARP_UNREAD, VariantBatch
from batchveh.stepping.rollout import float_precision, physics_stats

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


class _View:
    """One variant's view of a `WarpPhysics` for `rollout.physics_stats` (inside the vmap)."""

    def __init__(self, phys, dt, body_mass, nu: int, nbody: int):
        self.phys, self.dt, self.body_mass, self.nu, self.nbody = phys, dt, body_mass, nu, nbody
        self.iterations = phys.iterations

    def start(self):
        return self.phys.start(self.nu, self.nbody, self.dt)

    def step(self, d):
        return self.phys.step(d)

    def fault(self, d):
        """A contact or constraint buffer ran out in this world (MuJoCo Warp dropped what did not fit)."""
        return d.overflow != 0


def batched_fields(batch: VariantBatch) -> dict[str, np.ndarray]:
    """The chunk's model fields that MuJoCo Warp reads per world, each (n, ...); a field it keeps one per
    model is refused (ConfigError) with what is allowed."""
    import dataclasses

    import mujoco_warp as mjw

    per_world = {f.name for f in dataclasses.fields(mjw.Model) if getattr(f.type, "shape", (None,))[:1] == ("*",)}
    # options MuJoCo Warp holds per world and reads as they are (put_model derives others from theirs)
    options = {"gravity", "timestep"}
    out = {}
    for name, values in batch.fields.items():
        if name in WARP_UNREAD or name in SAMEFRAME:
            continue
        if name.startswith("opt."):
            ok = name[4:] in options
        else:
            ok = name in per_world  # its field spec leads with "*": one value per world
        if not ok:
            raise ConfigError(
                f"model field {name} is one per model in MuJoCo Warp, so the parameters that change it cannot vary "
                "on the warp backend; allowed: the mujoco or mjx backend, or fixed values"
            )
        out[name] = values
    return out


class WarpEngine(MjxEngine):
    """MuJoCo Warp on the first JAX device (a CUDA GPU, or the CPU), float32."""

    name = "warp"

    def __init__(
        self,
        scenario,
        cfg,
        chunk_size: int,
        precision: str = "f32",
        contacts_per_world: int = 0,
        deterministic: bool | int = False,
        graph_mode: str = "WARP",
    ):
        if precision != "f32":
            raise ConfigError(
                f"precision: {precision!r} is not available on the warp backend (MuJoCo Warp computes in float32); "
                "allowed: f32, or the mjx or mujoco backend for f64"
            )
        if not warp_installed():
            raise ConfigError(
                "the warp backend needs mujoco-warp and warp-lang; allowed: pip install -e '.[gpu]', "
                "or the mjx or mujoco backend"
            )
        super().__init__(scenario, cfg, chunk_size, precision="f32")
        self.devices = self.devices[:1]
        self.chunk_size = chunk_size
        self.contacts_per_world = contacts_per_world or CONTACTS_PER_WORLD
        if deterministic is True:  # all of MuJoCo Warp's DeterminismType bits; an int: those bits
            import mujoco_warp as mjw

            deterministic = mjw.DeterminismType.ALL
        self.deterministic = int(deterministic)
        self.graph_mode = graph_mode
        self.warm_s = 0.0  # Warp's first launches of each new program (kernels loaded or built)
        self.ahead: dict[str, Any] = {}  # what building the kernels ahead took (warp_build.AheadBuild.wait)
        self._phys: dict[Any, Any] = {}
        if self.devices[0].platform == "gpu":
            from batchveh.engines import warp_build

            # a machine that never built a vehicle's kernels: the workers start now, and import while the
            # engine prepares its first chunk
            try:
                if warp_build.enabled() and warp_build.may_spawn() and warp_build.cold():
                    warp_build.start_workers(self._device())
            except Exception:  # noqa: BLE001 - a head start only: the first launch builds what is missing
                warp_build.stop_workers()

    def close(self) -> None:
        """Let go of every program's MuJoCo Warp model and data (device memory), and the compiled programs."""
        for phys in self._phys.values():
            phys.close()
        self._phys.clear()
        self._fn.clear()

    def __del__(self):
        try:
            self.close()
        except Exception:  # noqa: BLE001 - at interpreter exit Warp may be gone already
            pass

    @property
    def implementation(self) -> str:
        import mujoco_warp
        import warp

        det = f", deterministic {self.deterministic}" if self.deterministic else ""
        return f"MuJoCo Warp {mujoco_warp.__version__} (MuJoCo {mujoco.__version__}), warp-lang {warp.__version__}{det}"

    def _device(self) -> str:
        d = self.devices[0]
        return "cpu" if d.platform == "cpu" else f"cuda:{d.id}"

    def _sizes(self, batch: VariantBatch) -> tuple[int, int]:
        """(constraint rows per world, contacts of all worlds)."""
        return constraint_rows(batch.model, self.contacts_per_world), batch.n * self.contacts_per_world

    def _program(self, batch: VariantBatch, fields: dict[str, np.ndarray]):
        """The chunk's WarpPhysics (its fields written) and the function of (dt, body_mass, params) to compile."""
        from batchveh.engines.warp_physics import WarpPhysics

        mjm = batch.model
        njmax, naconmax = self._sizes(batch)
        phys = WarpPhysics(
            mjm, batch.n, tuple(fields), naconmax=naconmax, njmax=njmax, device=self._device(),
            graph_mode=self.graph_mode, deterministic=self.deterministic,
        )  # fmt: skip
        phys.load(fields)
        lay = layout(mjm)
        scenario, cfg = self.scenario, self.cfg

        def one(dt, body_mass, p):
            view = _View(phys, dt, body_mass, mjm.nu, mjm.nbody)
            return physics_stats(view, p, scenario=scenario, cfg=cfg, lay=lay)

        return phys, jax.vmap(one, in_axes=(0, 0, 0))

    def _ahead(self, batch: VariantBatch, fields):
        """On a GPU whose Warp kernel cache lacks this vehicle's kernels: worker processes build them while JAX
        compiles (`warp_build`), and the first launch loads them. None where nothing is built ahead."""
        if self.devices[0].platform != "gpu":
            return None
        from batchveh.engines import warp_build

        batched = {k: batch.n for k in fields}
        njmax, _ = self._sizes(batch)
        args = (batch.model, batched, njmax, self.contacts_per_world)  # the workers' copy has one world
        try:
            if warp_build.wanted(*args, self.deterministic):
                return warp_build.AheadBuild(*args, device=self._device(), deterministic=self.deterministic)
            warp_build.stop_workers()  # started with the engine, not needed for this model
            if warp_build.thread_wanted(*args, self.deterministic):
                import threading

                threading.Thread(target=warp_build.load_file_modules, args=(self._device(),), daemon=True).start()
        except Exception:  # noqa: BLE001 - a head start only: the first launch builds what is missing
            warp_build.stop_workers()
        return None

    def _inputs(self, batch: VariantBatch, fields) -> tuple[jax.Array, jax.Array]:
        n, mjm = batch.n, batch.model
        dt = fields.get("opt.timestep", np.full(n, mjm.opt.timestep))
        mass = fields.get("body_mass", np.broadcast_to(mjm.body_mass, (n, mjm.nbody)))
        return jax.device_put((np.asarray(np.reshape(dt, n), np.float32), np.asarray(mass, np.float32)))

    def run(self, batch: VariantBatch) -> dict[str, np.ndarray]:
        n = batch.n
        batch = pad(batch, self.chunk_size)
        course.check_backend(batch.model, "warp")
        with float_precision("f32"), _quiet():
            fields = batched_fields(batch)
            key = (tuple(sorted(batch.fields)), batch.n, fingerprint(batch.model))
            dt, mass = self._inputs(batch, fields)
            params = jax.device_put(host_params(batch, np.float32))
            ahead = None
            if key not in self._fn:
                ahead = self._ahead(batch, fields)
                try:
                    phys, prog = self._program(batch, fields)
                    t0 = time.perf_counter()
                    compiled = jax.jit(prog).lower(dt, mass, params).compile()
                    self.compile_s += time.perf_counter() - t0
                finally:
                    if ahead is not None:
                        self.ahead = ahead.wait()
                t0 = time.perf_counter()
                phys.warm()  # every kernel loaded before Warp captures a graph
                self.warm_s += time.perf_counter() - t0
                self._fn[key], self._phys[key] = compiled, phys
            else:
                self._phys[key].load(fields)
            out = jax.device_get(self._fn[key](dt, mass, params))
        if ahead is not None:  # the first chunk ran: this vehicle's kernels are all in Warp's cache now
            ahead.done()
        return {k: np.asarray(v)[:n] for k, v in out.items()}


def fingerprint(m: mujoco.MjModel) -> str:
    """A hash of the whole base model (MuJoCo's binary form): a program and its MuJoCo Warp model serve only the
    model they were built from (its values that are not per-world fields, its options and its layout)."""
    import hashlib

    buf = np.empty(mujoco.mj_sizeModel(m), np.uint8)
    mujoco.mj_saveModel(m, None, buf)
    return hashlib.sha1(buf.tobytes()).hexdigest()


def _quiet():
    """Warp's own messages (initialisation, kernel loading) off, errors still shown."""
    import warp

    return warp.ScopedLogLevel(warp.LOG_ERROR)
