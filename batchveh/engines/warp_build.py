"""MuJoCo Warp's kernels built ahead, in worker processes, the first time a vehicle runs on a machine.

Warp builds a kernel module at its first launch. MuJoCo Warp's step launches some thirty-five modules:
its per-file ones (smooth, forward, solver, ...) and about twenty-seven that it makes per model
("unique": the broadphase, the contact Jacobian, two tile Cholesky solves linked against libmathdx).
In one process they build one after another: Warp holds one code-generation lock per process, and
the step launches them in order. On a fresh H200 that took about 30 of the 50 s of the first
`benchmarks/slope_100k.yaml` run (benchmarks/results/h200-first-gpu-run.json), against 20 s warm.

Here, while the engine's first chunk compiles, a pool of spawned processes runs parts of MuJoCo Warp's
step for real on a one-world copy of the chunk's model, each part in its own process
(`STAGES`), and loads the per-file modules the step uses (`FILE_MODULES`) spread over the others. Each
module then lands in Warp's kernel cache (on disk) from whichever process built it first, and the
engine's own first launch loads it from there. Nothing is assigned into Warp or MuJoCo Warp: the
workers call MuJoCo Warp's public functions (`mujoco_warp.fwd_acceleration`, `solve`, ...) and
`warp.load_module`. A module that no stage reaches still builds at its first launch, as before: what
the engine computes does not change, only where its kernels were built.

A marker in Warp's kernel cache (`batchveh-ahead-<key>`, keyed on MuJoCo's and Warp's versions, the
model's structure and the chunk's batched fields) records that a vehicle's kernels were built, so a
warm machine starts no workers; deleting Warp's cache (`python -c "import warp; warp.clear_kernel_cache()"`)
deletes the marker with it. BATCHVEH_WARP_PREBUILD=0 turns the whole thing off
(benchmarks/end_to_end.py start --fresh compares both).
"""

from __future__ import annotations

import hashlib
import os
import pickle
import time
from typing import Any

import mujoco
import numpy as np

from batchveh.engines.common import spawn_safe

MUJOCO_WARP = "mujoco_warp"
# parts of the step, each run in a process of its own, longest first: the constraint solver (two
# libmathdx tile Cholesky solves), the smooth acceleration's factor-solve of M (another), collision,
# the constraint rows, passive forces; then what MuJoCo Warp 4.0's step also makes per model: the implicit
# integrator's actuator and passive derivative, the actuator forces, the transmission, the contact forces on the
# bodies (cfrc_ext). None of them launches the per-file modules' kernels that another needs first (on one H100, a
# position stage that did waited 10 s for `smooth`)
STAGES = (
    "solve", "fwd_acceleration", "collision", "make_constraint", "passive", "implicit", "fwd_actuation",
    "transmission", "rne_postconstraint",
)  # fmt: skip
# MuJoCo Warp's per-file modules that its step launches, the largest first (each also builds at a stage
# that reaches it first); any other builds at its first launch, as before
FILE_MODULES = (
    f"{MUJOCO_WARP}._src.smooth",
    f"{MUJOCO_WARP}._src.sensor",
    f"{MUJOCO_WARP}._src.derivative",
    f"{MUJOCO_WARP}._src.forward",
    f"{MUJOCO_WARP}._src.passive",
    f"{MUJOCO_WARP}._src.solver",
    f"{MUJOCO_WARP}._src.constraint",
    f"{MUJOCO_WARP}._src.support",
)
WAIT_S = 180.0  # the longest the engine waits for the workers before it launches (and builds what is left)
SETTLE_STEPS = 100  # MuJoCo C steps before the copy: the wheels on the ground, so the solver iterates


# batched fields whose leading size (the chunk's) is part of a kernel's key: MuJoCo Warp's broadphase is
# made per shape of these; other batched fields key nothing by their size (checked for opt.gravity and
# geom_friction: the same modules at 1 and 100,096 variants)
SIZED = ("geom_aabb", "geom_rbound", "geom_margin", "geom_gap", "pair_margin", "pair_gap", "geom_dataid")


def sized(batched: dict[str, int]) -> dict[str, int]:
    """The batched fields with the leading size that keys MuJoCo Warp's kernels: the chunk's for SIZED, else 1."""
    return {k: (n if k in SIZED else 1) for k, n in batched.items()}


# the model's integer arrays that decide which kernels MuJoCo Warp makes (types, trees, transmissions), in `key`
STRUCTURE = (
    "geom_type",
    "geom_condim",
    "geom_contype",
    "geom_conaffinity",
    "jnt_type",
    "body_parentid",
    "dof_parentid",
    "actuator_trntype",
    "actuator_dyntype",
    "actuator_gaintype",
    "actuator_biastype",
    "sensor_type",
)


def key(model: mujoco.MjModel, batched: dict[str, int], njmax: int, naconmax: int, deterministic: int = 0) -> str:
    """What decides which kernels MuJoCo Warp makes for a model: MuJoCo's and Warp's versions, the
    model's sizes, types and options, the batched fields with their leading sizes, the constraint
    and contact buffers and the determinism bits (hashed)."""
    import warp

    opt = model.opt
    parts = [
        mujoco.__version__,
        warp.__version__,
        {k: getattr(model, k) for k in dir(model) if k.startswith("n") and isinstance(getattr(model, k), int)},
        *(getattr(model, field).tolist() for field in STRUCTURE),
        [opt.timestep, opt.solver, opt.cone, opt.integrator, opt.jacobian, opt.iterations, opt.ls_iterations],
        [opt.disableflags, opt.enableflags],
        sorted(sized(batched).items()),
        njmax,
        naconmax,
        *([deterministic] if deterministic else []),
    ]
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:16]


def marker(k: str) -> str:
    """The marker file of key `k` in Warp's kernel cache."""
    import warp

    warp.init()
    return os.path.join(warp.config.kernel_cache_dir, f"batchveh-ahead-{k}")


_POOL: dict[str, Any] = {}  # the worker processes, started ahead (`start_workers`) or by AheadBuild


def _workers():
    """The pool of worker processes: one per task, at most a core each but one (left to JAX's compile). A
    multiprocessing Pool: `terminate` ends a build that overran WAIT_S, where the interpreter's exit would
    otherwise wait for it."""
    if "pool" not in _POOL:
        import multiprocessing

        from batchveh.engines.mujoco import cpus

        n = max(1, min(len(STAGES) + len(FILE_MODULES), cpus() - 1))
        _POOL["n"], _POOL["started"] = n, time.time()
        _POOL["pool"] = multiprocessing.get_context("spawn").Pool(n)
    return _POOL["pool"]


def cold() -> bool:
    """Whether no vehicle's kernels were built ahead on this machine yet (no marker in Warp's cache), so
    that the workers are worth starting before the engine knows its model."""
    import glob

    return not glob.glob(marker("*"))


def start_workers(device: str) -> None:
    """Start the worker processes now and let each import MuJoCo Warp and open `device` (about 5 s on an
    H100 host), so that they are ready when the engine's first chunk has its model (AheadBuild)."""
    pool = _workers()
    _POOL["warming"] = [pool.apply_async(_warm, (device,)) for _ in range(_POOL["n"])]


def stop_workers() -> None:
    """Let the worker processes go (those `start_workers` began for a model that turned out not to need them)."""
    pool = _POOL.pop("pool", None)
    _POOL.clear()
    if pool is not None:
        pool.terminate()  # idle by now, or a build past WAIT_S: it ends here, not at the interpreter's exit


class AheadBuild:
    """The workers building one model's kernels; `wait` for them, then `done` once the engine's
    first chunk has run (writes the marker)."""

    def __init__(
        self, model: mujoco.MjModel, batched: dict[str, int], njmax: int, naconmax: int, device: str, deterministic=0
    ):
        self.marker = marker(key(model, batched, njmax, naconmax, deterministic))
        self.start, self.created = time.perf_counter(), time.time()
        payload = pickle.dumps((model, sized(batched), njmax, naconmax, deterministic))
        tasks = [("stage", s) for s in STAGES] + [("module", m) for m in FILE_MODULES]
        pool = _workers()
        self.results = [pool.apply_async(_build, (kind, name, payload, device)) for kind, name in tasks]

    def wait(self, timeout: float = WAIT_S) -> dict[str, Any]:
        """Wait for the workers (at most `timeout` s), then end them; returns what each took (s) or why it
        failed. A failed or late part only means its modules build at their first launch."""
        deadline, waited = time.perf_counter() + timeout, time.time()
        report, marks = {}, {}
        for i, r in enumerate(self.results):
            r.wait(max(0.0, deadline - time.perf_counter()))
            if not r.ready():
                report[f"task {i}"] = "not done in time"
                continue
            try:
                name, seconds, marks[name] = r.get()
                report[name] = round(seconds, 2)
            except Exception as err:  # noqa: BLE001 - a head start only: the first launch builds what is missing
                report[f"task {i}"] = f"{type(err).__name__}: {err}"
        warmed = [w.get() for w in _POOL.get("warming", []) if w.ready() and w.successful()]
        times = {"pool_started": _POOL.get("started"), "created": self.created, "waited": waited}
        stop_workers()
        report["wall_s"] = round(time.perf_counter() - self.start, 2)
        log = os.environ.get("BATCHVEH_WARP_AHEAD_LOG")  # for benchmarks/end_to_end.py start: what each part took
        if log:  # with when (time.time()) this build began, each worker's warm-up and each task's steps
            import json

            with open(log, "a") as f:
                f.write(json.dumps({**report, **times, "warm": warmed, "marks": marks}) + "\n")
        return report

    def done(self) -> None:
        """Record that this model's kernels are in Warp's cache."""
        try:
            with open(self.marker, "w") as f:
                f.write("built ahead by batchveh.engines.warp_build\n")
        except OSError:
            pass  # a read-only cache: the next run builds ahead again


def enabled() -> bool:
    """Whether kernels are built ahead in worker processes (BATCHVEH_WARP_PREBUILD=0: each at its first launch;
    =threads: Warp's own parallel loading of the per-file modules, `load_file_modules`, and nothing else)."""
    return os.environ.get("BATCHVEH_WARP_PREBUILD", "1") not in ("0", "threads")


def threads_only() -> bool:
    """BATCHVEH_WARP_PREBUILD=threads: Warp's own parallel module loading on a thread instead of the workers."""
    return os.environ.get("BATCHVEH_WARP_PREBUILD") == "threads"


def wanted(model: mujoco.MjModel, batched: dict[str, int], njmax: int, naconmax: int, deterministic=0) -> bool:
    """Whether this model's kernels still need building on this machine (no marker in Warp's cache),
    in worker processes (`may_spawn`; where it is False, `thread_wanted` says whether a thread loads them)."""
    return enabled() and may_spawn() and not built(model, batched, njmax, naconmax, deterministic)


def thread_wanted(model: mujoco.MjModel, batched: dict[str, int], njmax: int, naconmax: int, deterministic=0) -> bool:
    """Whether this process should run `load_file_modules` on a thread: this model's kernels not built on this
    machine yet (no marker), and no worker process may be spawned here (a daemonic `gpus` worker, an unguarded
    script). On a machine that built them the first launch loads them from Warp's cache, as in a process that
    may spawn: the thread's module hashing then only took the GIL from JAX's trace (on two H100s a `gpus`
    worker's first chunk, with the thread, took 0.0-2.7 s longer than the driver's, its trace and compile-cache
    load 0.2-1.6 s longer: h100x2-gpu-processes-prestart.json and the files before it)."""
    return (threads_only() or (enabled() and not may_spawn())) and not built(
        model, batched, njmax, naconmax, deterministic
    )


def built(model: mujoco.MjModel, batched: dict[str, int], njmax: int, naconmax: int, deterministic=0) -> bool:
    """Whether this model's kernels were built on this machine: its marker is in Warp's kernel cache."""
    return os.path.exists(marker(key(model, batched, njmax, naconmax, deterministic)))


def may_spawn() -> bool:
    """Whether this process may start worker processes: `spawn_safe`, and not itself a daemonic worker
    (the `gpus` executor's per-GPU processes are: Python refuses them children)."""
    import multiprocessing

    return spawn_safe() and not multiprocessing.current_process().daemon


def load_file_modules(device: str) -> None:
    """Build (or load from Warp's kernel cache) MuJoCo Warp's per-file modules in this process, all of them
    at once on a thread per core (Warp's code generation still takes them one at a time; 50.1-53.9 s for
    the first run on one H200: archive.json, h200-first-gpu-run.json): the head start where no worker
    process may be spawned. The unique modules build at their first launch."""
    import importlib

    import warp

    from batchveh.engines.mujoco import cpus

    try:
        importlib.import_module(MUJOCO_WARP)  # registers its modules with Warp
        with warp.ScopedLogLevel(warp.LOG_ERROR):
            warp.load_module(f"{MUJOCO_WARP}._src", device=device, recursive=True, max_workers=cpus())
    except Exception:  # noqa: BLE001 - a head start only: the first launch builds whatever is missing, and says why
        pass


_WORLD: dict[str, Any] = {}  # in a worker process: the one-world model and data it built, per payload


def _warm(device: str) -> tuple[int, float, float, float]:
    """A worker's start: MuJoCo Warp imported, `device` opened. Returns (pid, start, imported, end) (time.time())."""
    import importlib

    t0 = time.time()
    import warp

    with warp.ScopedLogLevel(warp.LOG_ERROR):
        warp.init()
        importlib.import_module(MUJOCO_WARP)
        imported = time.time()
        warp.get_device(device).context  # noqa: B018 - opens the device's CUDA context here, once
    end = time.time()
    time.sleep(0.5)  # held a moment: each warm-up then lands on a process of its own
    return os.getpid(), t0, imported, end


def _build(kind: str, name: str, payload: bytes, device: str) -> tuple[str, float, dict[str, Any]]:
    """One worker's task: load per-file module `name`, or run MuJoCo Warp's stage `name` once on a
    one-world copy of the model (its data from MuJoCo C after SETTLE_STEPS steps). Returns (what, s, marks):
    marks are when (time.time()) it began, had its model (a stage) and ended, and the worker's pid."""
    import importlib

    import warp

    t0 = time.perf_counter()
    marks = {"pid": os.getpid(), "start": time.time()}
    with warp.ScopedLogLevel(warp.LOG_ERROR):
        warp.init()
        mjw = importlib.import_module(MUJOCO_WARP)  # registers its per-file modules with Warp
        if kind == "module":
            importlib.import_module(name)
            warp.load_module(name, device=device, recursive=False)
            return name.rsplit(".", 1)[-1], time.perf_counter() - t0, {**marks, "end": time.time()}
        with warp.ScopedDevice(device):
            m, d = _world(mjw, payload)
            marks["world"] = time.time()
            stage = getattr(mjw, name)
            if name == "fwd_acceleration":
                stage(m, d, factorize=True)  # as forward() calls it: M's factor-solve
            else:
                stage(m, d)
            warp.synchronize_device(device)
    return name, time.perf_counter() - t0, {**marks, "end": time.time()}


def _world(mjw, payload: bytes):
    """The one-world MuJoCo Warp model and data of a payload, made once per worker process."""
    key_ = hashlib.sha256(payload).hexdigest()
    if key_ not in _WORLD:
        import warp

        model, batched, njmax, naconmax, deterministic = pickle.loads(payload)
        m = mjw.put_model(model)
        m.opt.warn_overflow = 0  # as WarpPhysics sets it: the value is baked into three kernels
        m.opt.deterministic = deterministic  # so is the choice of deterministic kernels
        for field, size in batched.items():  # batched fields with the chunk's leading size (it keys the broadphase)
            owner, attr = (m.opt, field[4:]) if field.startswith("opt.") else (m, field)
            a = getattr(owner, attr)
            first = a.numpy()[:1]
            setattr(owner, attr, warp.array(np.repeat(first, size, axis=0), dtype=a.dtype))
        data = mujoco.MjData(model)
        for _ in range(SETTLE_STEPS):
            mujoco.mj_step(model, data)
        d = mjw.put_data(model, data, nworld=1, naconmax=naconmax, njmax=njmax)
        d.qacc_warmstart.zero_()  # the solver then iterates, and builds its loop's kernels
        _WORLD.clear()
        _WORLD[key_] = (m, d)
    return _WORLD[key_]
