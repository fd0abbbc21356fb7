"""MuJoCo Warp (`mujoco_warp`) as the physics of a JAX scan: one model and one data of `n` worlds, kept on
the device between calls, and two JAX calls (Warp's `jax_callable`) that advance them.

The scan keeps in JAX only what the tyre, the drive and the statistics read (`WarpState`): each
call copies the controls and applied wrenches into the worlds, runs MuJoCo Warp's own `forward` or
`step` on all of them, and copies those fields out. Everything else (contacts, the solver's warm start,
the constraint rows) stays in MuJoCo Warp's data, so a step moves a few hundred bytes per world
through JAX instead of MuJoCo Warp's whole data (MJX's Warp implementation passes its 168 arrays in and
out of every step). On a GPU, Warp captures each call as a CUDA graph and replays it.

The vehicle's per-variant parameters are MuJoCo Warp's own per-world model fields
(`mujoco_warp.put_model(mjm, batch_sizes=...)`): a chunk writes them in place (`load`) before its
program runs, so one compiled program serves every chunk of its shape.

Inside `jax.vmap` the per-variant calls become one call on all worlds (`jax.custom_batching`); the worlds
are the variants, in order, so the vmapped axis must be the chunk.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np


class WarpState(NamedTuple):
    """What the scan reads of MuJoCo Warp's data after a call (per world), and the inputs of the next
    one (`ctrl`, `xfrc_applied`). Field names and shapes are MJX's, so the rollout reads either."""

    qpos: jax.Array
    qvel: jax.Array
    qfrc_actuator: jax.Array
    actuator_force: jax.Array
    actuator_velocity: jax.Array
    xpos: jax.Array
    xmat: jax.Array
    cfrc_ext: jax.Array
    solver_niter: jax.Array
    overflow: jax.Array  # MuJoCo Warp's per-world overflow bits (a contact or constraint buffer ran out)
    ctrl: jax.Array
    xfrc_applied: jax.Array

    def replace(self, **kw) -> WarpState:
        return self._replace(**kw)

    @property
    def _impl(self) -> WarpState:  # MJX keeps cfrc_ext and solver_niter in its data's `_impl`
        return self


OUTPUTS = WarpState._fields[:10]
INTS = ("solver_niter", "overflow")


class WarpPhysics:
    """MuJoCo Warp's model and data for one structure and chunk size, and the JAX calls that run them.

    mjm: the batch's MjModel (structure and base values). batched: the model fields that vary per world,
    names starting 'opt.' are options. naconmax, njmax: contact and
    constraint-row buffers (all worlds, per world). graph_mode: a name of `warp.JaxCallableGraphMode`
    (GPU); the CPU runs without graphs. deterministic: MuJoCo Warp's `DeterminismType` bits (0: off)."""

    def __init__(
        self,
        mjm: mujoco.MjModel,
        n: int,
        batched: tuple[str, ...],
        *,
        naconmax: int,
        njmax: int,
        device: str,
        graph_mode: str = "WARP",
        deterministic: int = 0,
    ):
        import mujoco_warp as mjw
        import warp as wp

        self.n, self.device = n, wp.get_device(device)
        with wp.ScopedDevice(self.device):
            self.m = mjw.put_model(mjm, batch_sizes={k: n for k in batched if not k.startswith("opt.")})
            for k in (k for k in batched if k.startswith("opt.")):
                self._widen_option(k[4:], n)
            self.m.opt.deterministic = deterministic
            # overflow and iteration-limit messages off: the engine reports both per variant (`solver_limit_share`;
            # a world whose contact or constraint buffer ran out is `diverged`, from its `overflow` bits)
            self.m.opt.warn_overflow = 0
            if graph_mode == "JAX":  # JAX captures the call into its own graph, which holds no conditional nodes
                self.m.opt.graph_conditional = False
            self.d = mjw.make_data(mjm, nworld=n, naconmax=naconmax, njmax=njmax)
        self.batched = tuple(batched)
        self.iterations = int(mjm.opt.iterations)
        self.shapes = {
            "qpos": (n, mjm.nq), "qvel": (n, mjm.nv), "qfrc_actuator": (n, mjm.nv), "actuator_force": (n, mjm.nu),
            "actuator_velocity": (n, mjm.nu), "xpos": (n, mjm.nbody), "xmat": (n, mjm.nbody),
            "cfrc_ext": (n, mjm.nbody), "solver_niter": (n,), "overflow": (n,),
        }  # fmt: skip
        on_cpu = self.device.is_cpu
        mode = wp.JaxCallableGraphMode.NONE if on_cpu else wp.JaxCallableGraphMode[graph_mode]
        self._slot = {"m": self.m, "d": self.d}
        self._step = self._callable(mjw.step, mode)
        self._forward = self._callable(self._reset_forward, mode)
        self._mjw = mjw

    def close(self) -> None:
        """Let the device memory go: Warp's registry of JAX callables keeps each `call` (and its captured graphs)
        for the process's life, so the model and data are dropped from the slot it reads and its graphs cleared."""
        import warp as wp

        for c in (self._step, self._forward):
            wp.clear_jax_callable_graph_cache(c)
        self._slot.clear()
        self.m = self.d = None

    def _widen_option(self, name: str, n: int) -> None:
        import warp as wp

        cur = getattr(self.m.opt, name)
        arr = cur.numpy()
        setattr(self.m.opt, name, wp.array(np.repeat(arr[:1], n, axis=0), dtype=cur.dtype))

    def _reset_forward(self, m, d) -> None:
        self._mjw.reset_data(m, d)
        self._mjw.forward(m, d)

    def _callable(self, advance, mode):
        """A jax_callable: copy ctrl and xfrc_applied in, `advance(m, d)`, copy the outputs out."""
        import warp as wp

        slot = self._slot  # not the model and data themselves: `close` empties it, Warp's registry keeps `call`

        def call(
            ctrl: wp.array2d(dtype=wp.float32),
            xfrc_applied: wp.array2d(dtype=wp.spatial_vector),
            qpos: wp.array2d(dtype=wp.float32),
            qvel: wp.array2d(dtype=wp.float32),
            qfrc_actuator: wp.array2d(dtype=wp.float32),
            actuator_force: wp.array2d(dtype=wp.float32),
            actuator_velocity: wp.array2d(dtype=wp.float32),
            xpos: wp.array2d(dtype=wp.vec3),
            xmat: wp.array2d(dtype=wp.mat33),
            cfrc_ext: wp.array2d(dtype=wp.spatial_vector),
            solver_niter: wp.array(dtype=wp.int32),
            overflow: wp.array(dtype=wp.int32),
        ):
            m, d = slot["m"], slot["d"]
            wp.copy(d.ctrl, ctrl)
            wp.copy(d.xfrc_applied, xfrc_applied)
            advance(m, d)
            outs = (qpos, qvel, qfrc_actuator, actuator_force, actuator_velocity, xpos, xmat, cfrc_ext, solver_niter,
                    overflow)  # fmt: skip
            for out, name in zip(outs, OUTPUTS, strict=True):
                wp.copy(out, getattr(d, name))

        return wp.jax_callable(
            call, num_outputs=len(OUTPUTS), output_dims=self.shapes, graph_mode=mode, has_side_effect=True
        )

    def load(self, fields: dict[str, np.ndarray]) -> None:
        """Write a chunk's per-world model fields (the names given at construction, n values each) in place."""
        import warp as wp

        for name in self.batched:
            values = fields[name]
            target = getattr(self.m.opt, name[4:]) if name.startswith("opt.") else getattr(self.m, name)
            inner = tuple(getattr(target.dtype, "_shape_", ()))  # vec3: (3,), mat33: (3, 3), quat: (4,)
            target.assign(np.ascontiguousarray(values).reshape(*target.shape, *inner))
        wp.synchronize_device(self.device)

    def warm(self) -> None:
        """Run each call's Warp work once outside JAX: Warp loads (or builds) every kernel the step uses, so no
        module is loaded while a CUDA graph is being captured. The data is reset by the program's first call."""
        import warp as wp

        with wp.ScopedDevice(self.device):
            self._reset_forward(self.m, self.d)
            self._mjw.step(self.m, self.d)
            wp.synchronize_device(self.device)

    def _batched_call(self, fn, ctrl, xfrc):
        def one(ctrl, xfrc):  # outside vmap: NaN (the worlds are the vmapped variants; the engine always vmaps)
            return tuple(jnp.full(self._one_shape(k), -1 if k in INTS else jnp.nan,
                                  jnp.int32 if k in INTS else jnp.float32) for k in OUTPUTS)  # fmt: skip

        f = jax.custom_batching.custom_vmap(one)

        @f.def_vmap
        def rule(axis_size, in_batched, ctrl, xfrc):
            if axis_size != self.n:
                raise ValueError(f"vmapped over {axis_size} variants; this physics has {self.n} worlds")
            ctrl = ctrl if in_batched[0] else jnp.broadcast_to(ctrl, (self.n, *ctrl.shape))
            xfrc = xfrc if in_batched[1] else jnp.broadcast_to(xfrc, (self.n, *xfrc.shape))
            out = fn(ctrl.astype(jnp.float32), xfrc.astype(jnp.float32))
            return tuple(out), (True,) * len(OUTPUTS)

        return f(ctrl, xfrc)

    def _one_shape(self, name: str) -> tuple[int, ...]:
        """One world's shape of an output, as JAX holds it (vec3: 3, mat33: 3 x 3, spatial vector: 6)."""
        inner = {"xpos": (3,), "xmat": (3, 3), "cfrc_ext": (6,)}.get(name, ())
        return (*self.shapes[name][1:], *inner)

    def _state(self, outs, ctrl, xfrc) -> WarpState:
        return WarpState(*outs, ctrl=ctrl, xfrc_applied=xfrc)

    def start(self, nu: int, nbody: int, like: jax.Array) -> WarpState:
        """Each world reset (at its own qpos0) and forwarded, with zero controls and wrenches (per variant:
        call inside the vmap, with `like` a per-variant scalar, so that the call is batched)."""
        zero = like * 0  # batched under the vmap (zeros_like is a constant there): a call on constants is not
        ctrl, xfrc = jnp.zeros((nu,), like.dtype) + zero, jnp.zeros((nbody, 6), like.dtype) + zero
        return self._state(self._batched_call(self._forward, ctrl, xfrc), ctrl, xfrc)

    def step(self, d: WarpState) -> WarpState:
        """One MuJoCo Warp step of every world with the state's ctrl and xfrc_applied (per variant)."""
        return self._state(self._batched_call(self._step, d.ctrl, d.xfrc_applied), d.ctrl, d.xfrc_applied)
