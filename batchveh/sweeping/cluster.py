"""Sweeps on a Ray cluster: long-lived workers that build the engine once and run chunks.

    ray start --head                                    # on the head node; prints its address
    ray start --address=HEAD:6379                       # on every other node
    python -m batchveh.sweep SPEC --executor ray --address HEAD:6379 --out s3://bucket/sweep

`connect` joins a cluster, or arranges a local Ray instance; `RayExecutor` is what
`run_sweep(..., executor=...)` runs chunks with: one worker (a Ray actor) per GPU on
GPU nodes, else one per CPU slot, each holding a `chunks.ChunkRunner` (one compile per
worker). Workers write their chunks' parts into the result folder themselves (a path
every node shares, or an object-store URI) and hand the parts' records to the driver,
which keeps the manifest, the lock and the progress bar.

One host with GPUs (no --address, a GPU engine). Ray's start (ray.init, then each worker's
imports, engine and compile) costs about 7 s before the first chunk lands (RAY_START_S,
measured on two H200). A sweep that a second GPU would not finish sooner by more than that
(`alone_reason`: one GPU, one chunk, or under 2 x RAY_START_S of simulation on one GPU) runs
in this process exactly as without Ray, and Ray is not started. Larger sweeps get one Ray
worker per GPU. This process can also run chunks itself beside the workers, handing each
worker its next chunk before it needs it (`driver_works`, BATCHVEH_RAY_DRIVER=1; the chunk
size is then `shared_chunk`): that hides Ray's start behind work, but the warp engine fails
in a process connected to Ray ('Warp error: unknown stream', measured on two H200), so it is
refused there and off by default (docs/multi-gpu.md).

Faults. A worker that dies is restarted by Ray (up to MAX_RESTARTS times), and the chunk
it was running goes back into the queue, to whichever worker is free first (or to this
process, where it works beside them). A chunk runs at most MAX_ATTEMPTS times on Ray workers; after
that it is reported by name and the others go on (`retry.Retries`, the policy the GPU processes share);
an error in this process's own chunk stops the sweep, as without Ray. Nothing is written twice: a part
is renamed into place whole, and the driver records a chunk once, when it is reported written. A driver
that dies takes its workers with it; `--resume` then skips the parts in the manifest, whoever wrote them.

Ray is imported only here, and only when a sweep runs on it: `pip install -e ".[ray]"`.
For tests and benchmarks: BATCHVEH_FAIL_CHUNKS=2,5 in the workers' environment makes
chunks 2 and 5 raise; BATCHVEH_RAY_ALONE=0 starts Ray's workers on one host even where
`alone_reason` says not to; BATCHVEH_TIMELINE=PATH writes the executor's events (Ray's start, each
worker ready, each chunk's start and end, where) as JSON to PATH as they happen.
"""

from __future__ import annotations

import importlib.util
import json
import logging
import os
import socket
import sys
import threading
import time
from collections import Counter, deque
from typing import TYPE_CHECKING, Any

from batchveh.config import ConfigError
from batchveh.sweeping.prestart import local_gpus
from batchveh.sweeping.retry import MAX_ATTEMPTS, MAX_RESTARTS, Finished, Note, Retries, quiet

if TYPE_CHECKING:
    from batchveh.sweeping.results import ResultFolder
    from batchveh.sweeping.spec import SweepSpec

PROBE_WAIT = 0.1  # s between readiness probes of a worker that Ray is restarting
# This process beside the workers: chunks of at least MIN_SHARED_CHUNK variants (the warp engine's rate is flat from
# 65k variants up on the elliptic contact: benchmarks/results/archive.json: h200-warp-elliptic10.json), up to
# CHUNKS_PER_GPU of them per GPU, so that a worker that joins late still evens out the end (docs/multi-gpu.md). On the
# slip tyre chunks of 66,816 ran 1.13x slower per variant than chunks of 125,184: 1,000,000 x 10 s on two GPUs took
# 0.585x one GPU's wall in 15 chunks (8 per GPU), 0.557x and 0.579x in 10 chunks of 100,096 (5 per GPU), 0.584x in 8
# of 125,184 (two H100s, the code before chunks.Pipeline; benchmarks/results/archive.json:
# h100x2-gpu-processes-100096.json, h100x2-gpu-processes-repeat.json)
MIN_SHARED_CHUNK = 65536
CHUNKS_PER_GPU = 5
POLL = 0.02  # s: a short sleep where nothing is there to wait on
# One host's GPUs: what Ray's start costs before the first chunk lands, against the same chunk in-process: two
# Ray workers, 100,000 variants x 10 s in chunks of 50,176, first part at 20.2 s against 12.8-14.6 s (ray.init
# 3.9 s, the workers' imports and engines 5.2 s, their compile 3.1-3.4 s), on two H200
# (h200x2-ray-scaling.json in benchmarks/results/archive.json). A sweep whose simulation on one GPU is shorter
# than twice this gains nothing from a second GPU and runs in this process alone, Ray not started.
RAY_START_S = 7.4
# variant-steps/s of one GPU, slip tyre: warp 1.93e7 between the parts of 1,000,000 x 10 s (same file), MJX's JAX
# implementation 2.9e6 (h200-tyres-mjx.json); slower models only make the estimate run in this process more often
GPU_RATE = {"warp": 1.9e7, "mjx": 2.9e6}

_local = {"wanted": False}  # connect(None) asked for a local Ray instance, started by the executor


class Timeline(list):
    """An executor's events, each a dict with its time `t` (time.time()) and `event`; with BATCHVEH_TIMELINE=PATH
    in the environment the whole list is written to PATH as JSON at each event (atomically: a reader sees the
    old list or the new one)."""

    def __init__(self) -> None:
        super().__init__()
        self.path = os.environ.get("BATCHVEH_TIMELINE")
        self._lock = threading.Lock()

    def add(self, what: str, **info: Any) -> None:
        with self._lock:
            self.append({"t": time.time(), "event": what, **info})
            if self.path:
                tmp = f"{self.path}.tmp"
                with open(tmp, "w") as f:
                    json.dump(self, f)
                os.replace(tmp, self.path)


class ChunkWorker:
    """A Ray actor's state: the engine, built once, and the result folder it writes parts into.

    A setting the backend cannot run is kept and told by `describe`, so that the driver
    reports it in one line (an actor whose constructor raises is dead, its error buried)."""

    def __init__(
        self,
        spec: SweepSpec,
        backend: str,
        n: int,
        chunk_size: int | None,
        workers: int,
        nthread: int,
        out: str,
        gpu: str | None = None,
    ):
        if gpu is not None:  # one host shared with the driver: this worker's GPU, before JAX starts
            os.environ["CUDA_VISIBLE_DEVICES"] = gpu
        from batchveh.sweeping.chunks import ChunkRunner
        from batchveh.sweeping.results import ResultFolder

        self.error = None
        try:
            self.runner = ChunkRunner(spec, backend, n, chunk_size, workers=workers, nthread=nthread)
            self.folder = ResultFolder(out)
        except ConfigError as err:
            self.error = str(err)

    def describe(self) -> dict[str, Any]:
        if self.error:
            return {"error": self.error}
        return {
            "error": None,
            "manifest": self.runner.manifest,
            "device": self.runner.device,
            "pid": os.getpid(),
            "node": socket.gethostname(),
        }

    def check(self, c: int) -> None:
        """Raise where chunk `c` cannot run here: an engine that could not be built, or a test's injected fault."""
        if self.error:  # a restarted worker whose engine could not be built this time
            raise ConfigError(self.error)
        if str(c) in os.environ.get("BATCHVEH_FAIL_CHUNKS", "").split(","):
            raise RuntimeError(f"chunk {c} is in BATCHVEH_FAIL_CHUNKS (injected fault)")

    def run(self, c: int) -> tuple[str, dict[str, Any]]:
        """Run chunk `c` and write its part; return (part name, record) for the manifest."""
        self.check(c)
        return self.folder.write_file(c, self.runner.run(c))

    def engine_stats(self) -> dict[str, Any]:
        return self.runner.engine_stats()


def merged_stats(stats: list[dict[str, Any]]) -> dict[str, Any]:
    """Engine statistics of several processes (`ChunkRunner.engine_stats` each) as one: the longest compile,
    the compiles summed, MuJoCo's first five warnings."""
    return {
        "compile_s": max((s["compile_s"] for s in stats), default=0.0),
        "compiles": sum(s["compiles"] for s in stats),
        "warnings": [w for s in stats for w in s["warnings"]][:5],
    }


def differs(manifest: dict[str, Any], theirs: dict[str, Any]) -> str | None:
    """Why a worker whose engine records `theirs` cannot write parts of the sweep whose manifest is `manifest`: the
    first setting that differs, in words; None where none does."""
    for k in manifest:
        if theirs.get(k) != manifest[k]:
            return f"it differs in {k}: {theirs.get(k)!r}, here {manifest[k]!r}"
    return None


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def connect(address: str | None = None) -> bool:
    """Join the Ray cluster at `address` ('auto', 'HOST:PORT' or 'ray://HOST:PORT'), or, where
    `address` is None, arrange a local Ray instance on this machine's CPUs and GPUs, which
    `RayExecutor.start` starts once it knows it needs one (a GPU sweep that Ray would not speed up
    runs without it). Returns whether this call connected or arranged one (then `disconnect` ends
    it); a process already connected stays as it is.

    ConfigError (one line) without Ray installed, for a malformed address, or where no cluster
    answers; Ray's own logs are kept to errors."""
    if not _ray_installed():
        raise ConfigError("--executor ray: Ray is not installed; pip install -e '.[ray]'")
    if address is not None:
        _check_reachable(address)
    if address is None:  # not imported here: `import ray` takes a second, and a small sweep needs no Ray
        ray = sys.modules.get("ray")
        if ray is not None and ray.is_initialized():
            return False
        _local["wanted"] = True
        return True
    import ray

    if ray.is_initialized():
        return False
    try:
        ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False)
    except (ConnectionError, ValueError, RuntimeError) as err:
        raise ConfigError(f"--address {address}: {str(err).splitlines()[0]}") from None
    return True


def _ray_installed() -> bool:
    if "ray" in sys.modules:
        return sys.modules["ray"] is not None
    return importlib.util.find_spec("ray") is not None


def _start_local() -> None:
    import warnings

    import ray

    with warnings.catch_warnings():  # Ray starts its processes by fork and exec, which JAX warns of
        warnings.filterwarnings("ignore", message="os.fork", category=RuntimeWarning)
        ray.init(
            address="local",
            num_cpus=_cpus(),
            include_dashboard=False,
            logging_level=logging.ERROR,
            log_to_driver=False,
        )


def alone_reason(
    n: int,
    steps: int,
    backend: str,
    gpus: int,
    chunk: int | None = None,
    start_s: float = RAY_START_S,
    starter: str = "Ray's start",
) -> str | None:
    """Why a sweep of `n` variants x `steps` steps on `gpus` GPUs of this host should run in this process
    alone, or None where workers on the other GPUs would finish it sooner: one GPU, one chunk, or less than
    2 x `start_s` of simulation on one GPU (`start_s`: what `starter` costs before a second GPU works;
    RAY_START_S for Ray's workers)."""
    if gpus < 2:
        return "one GPU"
    if chunk and -(-n // chunk) < 2:
        return "one chunk"
    seconds = n * steps / GPU_RATE.get(backend, GPU_RATE["warp"])
    if seconds < 2 * start_s:
        return f"about {seconds:.0f} s of simulation on one GPU, less than {starter} saves ({2 * start_s:.0f} s)"
    return None


def shared_chunk(n: int, gpus: int, largest: int | None = None) -> int:
    """Variants per chunk where `gpus` GPUs of one host share a sweep of `n` variants: equal chunks,
    at most `largest` (the engine's: GPU_CHUNK_MAX), at least MIN_SHARED_CHUNK, up to CHUNKS_PER_GPU
    per GPU; a multiple of 256. One chunk (n < 2 x MIN_SHARED_CHUNK) means no sharing."""
    if largest is None:
        from batchveh.engines.common import GPU_CHUNK_MAX

        largest = GPU_CHUNK_MAX
    k = max(1, -(-n // largest), min(CHUNKS_PER_GPU * gpus, n // MIN_SHARED_CHUNK))
    per = -(-n // k)
    return -(-per // 256) * 256


def _check_reachable(address: str) -> None:
    """Fail at once where nothing listens at HOST:PORT (ray.init would retry for minutes)."""
    if address == "auto":
        return
    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        raise ConfigError(
            f"--address: {address!r} is not allowed; allowed: auto, HOST:PORT (as `ray start --head` prints "
            "it) or ray://HOST:PORT"
        )
    try:
        socket.create_connection((host, int(port)), timeout=5).close()
    except OSError as err:
        raise ConfigError(
            f"--address {address}: no Ray cluster answers there ({err.strerror or err}); start one with "
            "`ray start --head`, or leave --address out for a local Ray instance"
        ) from None


def disconnect() -> None:
    """End what `connect` began (a local instance that was never needed was never started)."""
    _local["wanted"] = False
    ray = sys.modules.get("ray")
    if ray is not None and ray.is_initialized():
        ray.shutdown()


def _why(err: BaseException) -> str:
    """Why a chunk failed on a Ray worker, in words, from the RayError its result raised."""
    from ray.exceptions import RayActorError, RayTaskError

    if isinstance(err, RayTaskError):  # the chunk raised
        cause = err.cause if getattr(err, "cause", None) is not None else err
        return f"{type(cause).__name__}: {str(cause).strip().splitlines()[-1]}"
    if isinstance(err, RayActorError):  # the worker's process died, or its node
        return "its Ray worker died"
    return f"{type(err).__name__} in Ray"  # Ray lost the result (an object store or a node failed)


def _probed(ref: Any, a: Any, probes: dict[Any, tuple[Any, int | None]]) -> bool | None:
    """A restarting worker `a` has answered its readiness probe `ref`: True, it is up again; False, it is gone for
    good; None, Ray is still restarting it (then it is probed again, in `probes`, after PROBE_WAIT)."""
    import ray
    from ray.exceptions import ActorDiedError, RayActorError

    try:
        ray.get(ref)
        return True
    except ActorDiedError:
        return False
    except RayActorError:
        time.sleep(PROBE_WAIT)
        probes[a.__ray_ready__.remote()] = (a, None)
        return None


class RayExecutor:
    """Runs a sweep's chunks on Ray workers (see the module's docstring), in a process that has
    joined a cluster or arranged a local instance (`connect`).

    `workers`: how many Ray workers (default: one per GPU of the cluster, else one per CPU; beside
    this process (`driver_works`), one per GPU but the one it uses). `runtime_env`: Ray's runtime
    environment for the workers (environment variables, say). `driver_works`: whether this process
    runs chunks too, beside the workers (default: only with BATCHVEH_RAY_DRIVER=1; not with warp).
    After `start`, `workers_info` lists each ready worker's process id, node and device, and
    `timeline` the events with their times (time.time())."""

    spreads = True  # the automatic chunk size gives each worker a chunk at least

    def __init__(
        self,
        workers: int | None = None,
        max_attempts: int = MAX_ATTEMPTS,
        runtime_env: dict | None = None,
        driver_works: bool | None = None,
    ):
        self.n_workers, self.max_attempts, self.runtime_env = workers, max_attempts, runtime_env
        self.driver_works = driver_works
        self.actors: list[Any] = []
        self.workers_info: list[dict[str, Any]] = []
        self.timeline = Timeline()
        self.runner = None  # this process's own ChunkRunner, where it works too
        self.folder: ResultFolder | None = None
        self.starting: dict[Any, Any] = {}  # describe ref -> actor, for workers still building their engines
        self.ready: list[Any] = []  # workers that have built their engines
        self.manifest: dict[str, Any] = {}

    def event(self, what: str, **info: Any) -> None:
        self.timeline.add(what, **info)

    def start(
        self, spec: SweepSpec, backend: str, n: int, chunk_size: int | None, folder: ResultFolder
    ) -> tuple[dict[str, Any], str]:
        """Start the workers and build their engines; return (what the manifest records, the
        devices in words). ConfigError where a worker cannot run the spec, or workers differ.

        On a local instance with a GPU engine, a sweep that Ray would not speed up (`alone_reason`)
        runs in this process, exactly as without Ray, and Ray is not started."""
        from batchveh.engines import resolve_backend

        self.event("start")
        self.folder = folder
        backend = resolve_backend(backend)
        ray = sys.modules.get("ray")
        local = _local["wanted"] and not (ray is not None and ray.is_initialized())
        if local and backend != "mujoco" and os.environ.get("BATCHVEH_RAY_ALONE", "1") != "0":
            gpus = local_gpus()
            if not gpus:  # no /dev/nvidiaN: ask JAX
                import jax

                gpus = [str(i) for i, d in enumerate(jax.devices()) if d.platform == "gpu"]
            steps = spec.stats_config().n_steps
            why = alone_reason(n, steps, backend, len(gpus), chunk_size or spec.chunk_size)
            if why:
                from batchveh.sweeping.chunks import ChunkRunner

                self.runner = ChunkRunner(spec, backend, n, chunk_size)
                self.manifest = self.runner.manifest
                self.event("alone", why=why)
                return self.manifest, f"{self.runner.device}, in this process alone ({why}); Ray not started"
        works = self.driver_works
        if works is None:
            works = os.environ.get("BATCHVEH_RAY_DRIVER") == "1"
        if works and backend == "warp":
            raise ConfigError(
                "this process running chunks beside Ray's workers (BATCHVEH_RAY_DRIVER=1): the warp engine fails "
                "in a process connected to Ray ('Warp error: unknown stream', docs/multi-gpu.md); allowed: leave "
                "it off (every GPU gets a Ray worker)"
            )
        if not works:
            if local:
                self.event("ray init")
                _start_local()
                self.event("ray ready")
            return self._start_workers(spec, backend, n, chunk_size, folder)
        return self._start_shared(spec, backend, n, chunk_size, folder, local)

    def _start_workers(
        self, spec: SweepSpec, backend: str, n: int, chunk_size: int | None, folder: ResultFolder
    ) -> tuple[dict[str, Any], str]:
        """Every chunk on Ray workers: start them all and wait until each has built its engine."""
        import ray

        resources = ray.cluster_resources()
        gpus = int(resources.get("GPU", 0)) if backend != "mujoco" else 0
        if gpus:  # one GPU each; the GPU engines use the whole device
            count, options, nthread = gpus, {"num_gpus": 1, "num_cpus": 1}, 0
        else:  # one CPU slot each, and one MuJoCo thread
            count, options, nthread = int(resources.get("CPU", 1)), {"num_cpus": 1}, 1
        count = min(self.n_workers or count, n if chunk_size is None else -(-n // chunk_size))
        if self.runtime_env:
            options["runtime_env"] = self.runtime_env
        actor = ray.remote(ChunkWorker).options(max_restarts=MAX_RESTARTS, max_task_retries=0, **options)
        self.actors = [actor.remote(spec, backend, n, chunk_size, count, nthread, folder.shared) for _ in range(count)]
        infos = ray.get([a.describe.remote() for a in self.actors])
        for info in infos:
            if info["error"]:
                raise ConfigError(info["error"])
        first = infos[0]
        for info in infos[1:]:
            differ = [k for k in first["manifest"] if info["manifest"][k] != first["manifest"][k]]
            if differ:
                k = differ[0]
                raise ConfigError(
                    f"Ray workers differ in {k}: {first['manifest'][k]!r} on {first['node']}, "
                    f"{info['manifest'][k]!r} on {info['node']}; install the same versions on every node"
                )
        self.workers_info = [{k: i[k] for k in ("pid", "node", "device")} for i in infos]
        self.ready = list(self.actors)
        for a, i in zip(self.actors, infos, strict=True):
            self.event("worker ready", where=self._where(a), pid=i["pid"], device=i["device"])
        nodes = len({i["node"] for i in infos})
        device = f"Ray, {count} workers on {nodes} node{'s' * (nodes > 1)}, each {first['device']}"
        self.manifest = first["manifest"]
        return first["manifest"], device

    def _start_shared(
        self, spec: SweepSpec, backend: str, n: int, chunk_size: int | None, folder: ResultFolder, local: bool
    ) -> tuple[dict[str, Any], str]:
        """This process works too: Ray is started (where it is local) and the workers asked for, then
        this process builds its own engine while they build theirs; the workers are not waited for.
        Everything here runs on this thread, as in a Ray worker (a Warp chunk run beside other Python
        threads in a process connected to Ray failed with 'Warp error: unknown stream')."""
        from batchveh.sweeping.chunks import ChunkRunner

        gpu_engine = backend != "mujoco"
        gpus = local_gpus() if local and gpu_engine else []
        if local and gpu_engine and not gpus:  # no /dev/nvidiaN: ask JAX
            import jax

            gpus = [str(i) for i, d in enumerate(jax.devices()) if d.platform == "gpu"]
        if local:
            share = len(gpus) if gpu_engine else _cpus()
        else:
            import ray

            resources = ray.cluster_resources()
            share = (int(resources.get("GPU", 0)) if gpu_engine else 0) or int(resources.get("CPU", 1))
            share += 1  # this process besides
        if self.n_workers is not None:
            share = self.n_workers + 1
        chunk_size = chunk_size or spec.chunk_size
        if chunk_size is None and gpu_engine:
            chunk_size = shared_chunk(n, max(share, 1))
        chunks = -(-n // chunk_size) if chunk_size else None
        count = max(0, share - 1)
        if chunks is not None:
            count = min(count, chunks - 1)  # one chunk: this process alone
        if count:
            if local:
                self.event("ray init")
                _start_local()
                self.event("ray ready")
            self._ask_workers(spec, backend, n, chunk_size, folder, count, gpus[1:] if local and gpu_engine else [])
        self.runner = ChunkRunner(spec, backend, n, chunk_size, workers=count + 1, nthread=0 if gpu_engine else 1)
        self.manifest = self.runner.manifest
        self.event("engine built", chunk_size=self.runner.chunk)
        if not count:
            return self.manifest, f"{self.runner.device}, in this process alone (one chunk); Ray not started"
        more = f"{count} Ray worker{'s' * (count > 1)}"
        return self.manifest, f"this process and {more}, each {self.runner.device}"

    def _ask_workers(
        self,
        spec: SweepSpec,
        backend: str,
        n: int,
        chunk_size: int | None,
        folder: ResultFolder,
        count: int,
        gpus: list[str],
    ) -> None:
        import ray

        options: dict[str, Any] = {"num_cpus": 1}
        if backend != "mujoco":
            options["num_gpus"] = 1 if int(ray.cluster_resources().get("GPU", 0)) >= count else 0
        if self.runtime_env:
            options["runtime_env"] = self.runtime_env
        actor = ray.remote(ChunkWorker).options(max_restarts=MAX_RESTARTS, max_task_retries=0, **options)
        nthread = 0 if backend != "mujoco" else 1
        for i in range(count):
            gpu = gpus[i] if i < len(gpus) else None
            a = actor.remote(spec, backend, n, chunk_size, count + 1, nthread, folder.shared, gpu)
            self.actors.append(a)
            self.starting[a.describe.remote()] = a
        self.event("workers asked", count=count, gpus=gpus[:count])

    def run(self, todo: list[int], finished: Finished, note: Note, phase: Note = quiet) -> dict[int, str]:
        """Run the chunks in `todo`, one at a time on each worker, calling finished(chunk, part
        name, record) as each is written; return {chunk: why} for those that kept failing. `phase`
        hears how many chunks are running."""
        if self.runner is None:
            return self._dispatch(deque(todo), finished, note, phase)
        if not self.actors:  # this process alone, as without Ray (the next chunk prepared ahead)
            return self.runner.run_here(todo, self.folder, finished, phase)
        return self._run_shared(deque(todo), finished, note, phase)

    def worth_it(self, warm: bool, queued: int, outstanding: int = 0) -> bool:
        """Whether a Ray worker with `outstanding` chunks (running or queued on it) should take one more
        of `queued` left, where this process runs chunks too: it should where it would finish that chunk
        before this process, running them one after another, would reach the end of the queue (`warm`:
        its engine has compiled). Before this process has timed a chunk, yes."""
        if self._chunk_s is None:
            return True
        c = self._chunk_s
        own = self._own
        left = max(0.0, own[1] + c - time.perf_counter()) if own else 0.0
        return (outstanding + 1) * c + (0.0 if warm else self._compile_s or 0.0) < left + queued * c

    def _run_shared(self, queue: deque[int], finished: Finished, note: Note, phase: Note) -> dict[int, str]:
        """This process takes chunks from the front of the queue and runs them here; before each, it
        collects what the Ray workers have finished and gives each worker chunks to hold (one while it
        starts, DEPTH once ready), so a worker never waits for this process."""
        self._chunk_s = self._compile_s = self._own = None
        self._out: dict[Any, tuple[Any, int | None]] = {}  # ref -> (worker, chunk); None: a restart probe
        self._load: Counter[Any] = Counter()  # chunks held by each worker
        self._warm: set[Any] = set()  # workers that have run a chunk (compiled)
        self._restarting: set[Any] = set()
        self._dropped: set[Any] = set()
        self._retries = Retries(note, self.max_attempts)
        runner, first = self.runner, True
        while True:
            self._collect(queue, finished, timeout=0)
            self._hand_out(queue)
            if queue:
                c = queue.popleft()
                self._own = (c, time.perf_counter())
                phase(f"chunk {c + 1}/{runner.n_chunks} here, {sum(self._load.values())} on Ray workers")
                self.event("chunk start", chunk=c, where="driver")
                part = self.folder.write_file(c, runner.run(c))
                self.event("chunk end", chunk=c, where="driver")
                seconds = time.perf_counter() - self._own[1]
                finished(c, *part)
                self._own = None
                if first:
                    self._compile_s = runner.engine.compile_s
                    self._chunk_s = max(seconds - self._compile_s, 1e-3)
                else:
                    self._chunk_s = seconds
                first = False
                continue
            if not any(c is not None for _, c in self._out.values()):
                return self._retries.failed
            phase(f"{sum(self._load.values())} chunks on Ray workers")
            self._collect(queue, finished, timeout=1.0)

    DEPTH = 2  # chunks a ready worker holds: one running, the next waiting on it

    def _hand_out(self, queue: deque[int]) -> None:
        for a in self.actors:
            if a in self._dropped or a in self._restarting:
                continue
            depth = self.DEPTH if a in self.ready else 1  # a call waits for the worker's engine
            while queue and self._load[a] < depth and self.worth_it(a in self._warm, len(queue), self._load[a]):
                c = queue.popleft()
                self._out[a.run.remote(c)] = (a, c)
                self._load[a] += 1
                self.event("chunk start", chunk=c, where=self._where(a))

    def _collect(self, queue: deque[int], finished: Finished, timeout: float) -> None:
        """Take in what is ready (a worker's engine built, a chunk written or failed, a restart done),
        waiting up to `timeout` s for the first."""
        import ray
        from ray.exceptions import ActorDiedError, RayActorError, RayError

        refs = list(self._out) + list(self.starting)
        if not refs:
            if timeout:
                time.sleep(min(timeout, POLL))
            return
        ready, rest = ray.wait(refs, num_returns=1, timeout=timeout)
        if ready and rest:
            more, _ = ray.wait(rest, num_returns=len(rest), timeout=0)
            ready += more
        for ref in ready:
            if ref in self.starting:
                self._joined(self.starting.pop(ref), ref, self._retries.note)
                continue
            a, c = self._out.pop(ref)
            if c is None:  # a restarting worker's probe
                up = _probed(ref, a, self._out)
                if up:
                    self._restarting.discard(a)
                elif up is not None:
                    self._dropped.add(a)
                continue
            self._load[a] -= 1
            try:
                part = ray.get(ref)
            except RayError as err:
                if isinstance(err, RayActorError):  # the worker's process died, or its node
                    if a in self._dropped:  # let go here: its chunks go back, no attempt spent
                        queue.appendleft(c)
                        continue
                    self._warm.discard(a)  # a restarted worker compiles again
                    self.event("worker died", chunk=c, where=self._where(a))
                    if isinstance(err, ActorDiedError):
                        self._dropped.add(a)
                    elif a not in self._restarting:  # it takes chunks again once up
                        self._restarting.add(a)
                        self._out[a.__ray_ready__.remote()] = (a, None)
                if self._retries.again(c, _why(err)):
                    queue.appendleft(c)
                continue
            self.event("chunk end", chunk=c, where=self._where(a))
            finished(c, *part)
            self._warm.add(a)

    def _joined(self, a: Any, ref: Any, note: Note) -> None:
        """A worker has answered `describe`: it takes chunks where it runs the sweep as this process
        does, else it is let go with a note (the chunks it holds go back to the queue)."""
        import ray
        from ray.exceptions import RayError

        try:
            info = ray.get(ref)
        except RayError as err:
            why = f"it did not start ({type(err).__name__})"
        else:
            why = info["error"] or differs(self.manifest, info["manifest"])
        if why:
            note(f"a Ray worker is not used: {why}")
            self._dropped.add(a)
            ray.kill(a)
            return
        self.workers_info.append({k: info[k] for k in ("pid", "node", "device")})
        self.ready.append(a)
        self.event("worker ready", where=self._where(a), pid=info["pid"], device=info["device"])

    def _dispatch(self, queue: deque[int], finished: Finished, note: Note, phase: Note) -> dict[int, str]:
        """Every chunk on the Ray workers, one at a time each."""
        import ray
        from ray.exceptions import ActorDiedError, RayActorError, RayError

        idle = deque(self.actors)
        # object ref -> (worker, chunk); chunk None: a readiness probe of a worker Ray is restarting
        running: dict[Any, tuple[Any, int | None]] = {}
        retries = Retries(note, self.max_attempts)
        while queue or running:
            while idle and queue:
                a, c = idle.popleft(), queue.popleft()
                running[a.run.remote(c)] = (a, c)
                self.event("chunk start", chunk=c, where=self._where(a))
            phase(f"{len(running)} chunk{'s' * (len(running) > 1)} running on {len(self.actors)} workers")
            if not running:  # every worker is gone for good
                retries.failed.update({c: "no Ray worker left to run it" for c in queue})
                break
            [ref], _ = ray.wait(list(running), num_returns=1)
            a, c = running.pop(ref)
            if c is None:  # a restarting worker's probe: it takes chunks once it answers (not at all once gone)
                if _probed(ref, a, running):
                    idle.append(a)
                continue
            try:
                part = ray.get(ref)
            except RayError as err:
                if not isinstance(err, RayActorError):  # the chunk raised, or Ray lost its result: the worker is up
                    idle.append(a)
                else:  # the worker's process died, or its node
                    self.event("worker died", chunk=c, where=self._where(a))
                    if not isinstance(err, ActorDiedError):  # restarting: it takes chunks again once up;
                        # a chunk sent before then would fail at once and spend an attempt of its own
                        running[a.__ray_ready__.remote()] = (a, None)
                if retries.again(c, _why(err)):
                    queue.append(c)
                continue
            self.event("chunk end", chunk=c, where=self._where(a))
            finished(c, *part)
            idle.append(a)
        return retries.failed

    def _where(self, a: Any) -> str:
        return f"worker {self.actors.index(a)}" if a in self.actors else "worker"

    def engine_stats(self) -> dict[str, Any]:
        """Compiles summed over the workers (this process's included), the longest compile,
        MuJoCo's first warnings."""
        stats = [] if self.runner is None else [self.runner.engine_stats()]
        if self.ready:
            import ray
            from ray.exceptions import GetTimeoutError, RayActorError

            for a in self.ready:
                try:
                    stats.append(ray.get(a.engine_stats.remote(), timeout=30))
                except (RayActorError, GetTimeoutError, AttributeError):
                    pass  # gone, or its engine not built again after a restart
        return merged_stats(stats)

    def close(self) -> None:
        if not self.actors:
            return
        import ray

        for a in self.actors:
            ray.kill(a)
        self.actors, self.ready, self.starting = [], [], {}
        self.event("closed")
