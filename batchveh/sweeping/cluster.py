"""Sweeps on a Ray cluster: long-lived workers that build the engine once and run chunks.

    ray start --head                                    # on the head node; prints its address
    ray start --address=HEAD:6379                       # on every other node
    python -m batchveh.sweep SPEC --executor ray --address HEAD:6379 --out s3://bucket/sweep

`connect` joins a cluster, or starts a local Ray instance; `RayExecutor` is what
`run_sweep(..., executor=...)` runs chunks with: one worker (a Ray actor) per GPU on
GPU nodes, else one per CPU slot, each holding a `chunks.ChunkRunner` (one compile per
worker). Workers write their chunks' parts into the result folder themselves (a path
every node shares, or an object-store URI) and hand the parts' records to the driver,
which keeps the manifest, the lock and the progress bar.

Faults. A worker that dies is restarted by Ray (up to MAX_RESTARTS times), and the chunk
it was running goes back into the queue, to whichever worker is free first. A chunk runs
at most MAX_ATTEMPTS times; after that it is reported by name and the others go on.
Nothing is written twice: a part is renamed into place whole, and the driver records a
chunk once, when a worker reports it written. A driver that dies takes its workers with
it; `--resume` then skips the parts in the manifest, whoever wrote them.

Ray is imported only here, and only when a sweep runs on it: `pip install -e ".[ray]"`.
Fault injection for the tests: BATCHVEH_FAIL_CHUNKS=2,5 in the workers' environment makes
chunks 2 and 5 raise.
"""

from __future__ import annotations

import logging
import os
import socket
import time
from collections import Counter, deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from batchveh.config import ConfigError

if TYPE_CHECKING:
    from batchveh.sweeping.results import ResultFolder
    from batchveh.sweeping.spec import SweepSpec

MAX_ATTEMPTS = 3  # runs of one chunk before it is reported failed
MAX_RESTARTS = 3  # restarts of one worker after its process died
PROBE_WAIT = 0.1  # s between readiness probes of a worker that Ray is restarting


class ChunkWorker:
    """A Ray actor's state: the engine, built once, and the result folder it writes parts into.

    A setting the backend cannot run is kept and told by `describe`, so that the driver
    reports it in one line (an actor whose constructor raises is dead, its error buried)."""

    def __init__(
        self, spec: SweepSpec, backend: str, n: int, chunk_size: int | None, workers: int, nthread: int, out: str
    ):
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

    def run(self, c: int) -> tuple[str, dict[str, Any]]:
        """Run chunk `c` and write its part; return (part name, record) for the manifest."""
        if self.error:  # a restarted worker whose engine could not be built this time
            raise ConfigError(self.error)
        if str(c) in os.environ.get("BATCHVEH_FAIL_CHUNKS", "").split(","):
            raise RuntimeError(f"chunk {c} is in BATCHVEH_FAIL_CHUNKS (injected fault)")
        return self.folder.write_file(c, self.runner.run(c))

    def engine_stats(self) -> dict[str, Any]:
        e = self.runner.engine
        return {"compile_s": e.compile_s, "compiles": e.compiles, "warnings": list(getattr(e, "warnings", []))}


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def connect(address: str | None = None) -> bool:
    """Join the Ray cluster at `address` ('auto', 'HOST:PORT' or 'ray://HOST:PORT'), or start a
    local Ray instance on this machine's CPUs (and GPUs) where `address` is None. Returns whether
    this call connected (then `disconnect` ends it); a process already connected stays as it is.

    ConfigError (one line) without Ray installed, for a malformed address, or where no cluster
    answers; Ray's own logs are kept to errors."""
    try:
        import ray
    except ImportError:
        raise ConfigError("--executor ray: Ray is not installed; pip install -e '.[ray]'") from None
    if address is not None:
        _check_reachable(address)
    if ray.is_initialized():
        return False
    quiet = {"logging_level": logging.ERROR, "log_to_driver": False}
    if address is None:
        ray.init(address="local", num_cpus=_cpus(), include_dashboard=False, **quiet)
        return True
    try:
        ray.init(address=address, **quiet)
    except (ConnectionError, ValueError, RuntimeError) as err:
        raise ConfigError(f"--address {address}: {str(err).splitlines()[0]}") from None
    return True


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
    import ray

    ray.shutdown()


class RayExecutor:
    """Runs a sweep's chunks on Ray workers (see the module's docstring), in a process that has
    joined a cluster (`connect`).

    `workers`: how many (default: one per GPU of the cluster, else one per CPU). `runtime_env`:
    Ray's runtime environment for the workers (environment variables, say). After `start`,
    `workers_info` lists each worker's process id, node and device."""

    spreads = True  # the automatic chunk size gives each worker a chunk at least

    def __init__(self, workers: int | None = None, max_attempts: int = MAX_ATTEMPTS, runtime_env: dict | None = None):
        self.n_workers, self.max_attempts, self.runtime_env = workers, max_attempts, runtime_env
        self.actors: list[Any] = []
        self.workers_info: list[dict[str, Any]] = []

    def start(
        self, spec: SweepSpec, backend: str, n: int, chunk_size: int | None, folder: ResultFolder
    ) -> tuple[dict[str, Any], str]:
        """Start the workers and build their engines; return (what the manifest records, the
        devices in words). ConfigError where a worker cannot run the spec, or workers differ."""
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
        nodes = len({i["node"] for i in infos})
        device = f"Ray, {count} workers on {nodes} node{'s' * (nodes > 1)}, each {first['device']}"
        return first["manifest"], device

    def run(
        self,
        todo: list[int],
        finished: Callable[[int, str, dict], None],
        note: Callable[[str], None],
        phase: Callable[[str], None] = lambda _: None,
    ) -> dict[int, str]:
        """Run the chunks in `todo`, one at a time on each worker, calling finished(chunk, part
        name, record) as each is written; return {chunk: why} for those that kept failing. `phase`
        hears how many chunks are running."""
        import ray
        from ray.exceptions import ActorDiedError, RayActorError, RayError, RayTaskError

        queue, idle = deque(todo), deque(self.actors)
        # object ref -> (worker, chunk); chunk None: a readiness probe of a worker Ray is restarting
        running: dict[Any, tuple[Any, int | None]] = {}
        attempts: Counter[int] = Counter()
        failed: dict[int, str] = {}
        while queue or running:
            while idle and queue:
                a, c = idle.popleft(), queue.popleft()
                running[a.run.remote(c)] = (a, c)
            phase(f"{len(running)} chunk{'s' * (len(running) > 1)} running on {len(self.actors)} workers")
            if not running:  # every worker is gone for good
                failed.update({c: "no Ray worker left to run it" for c in queue})
                break
            [ref], _ = ray.wait(list(running), num_returns=1)
            a, c = running.pop(ref)
            if c is None:  # a restarting worker's probe: it takes chunks once it answers
                try:
                    ray.get(ref)
                    idle.append(a)
                except ActorDiedError:
                    pass  # gone for good
                except RayActorError:
                    time.sleep(PROBE_WAIT)
                    running[a.__ray_ready__.remote()] = (a, None)
                continue
            try:
                finished(c, *ray.get(ref))
                idle.append(a)
                continue
            except RayTaskError as err:  # the chunk raised
                cause = err.cause if getattr(err, "cause", None) is not None else err
                why = f"{type(cause).__name__}: {str(cause).strip().splitlines()[-1]}"
                idle.append(a)
            except RayActorError as err:  # the worker's process died, or its node
                why = "its Ray worker died"
                if not isinstance(err, ActorDiedError):  # restarting: it takes chunks again once up;
                    # a chunk sent before then would fail at once and spend an attempt of its own
                    running[a.__ray_ready__.remote()] = (a, None)
            except RayError as err:  # Ray lost the result (an object store or a node failed)
                why = f"{type(err).__name__} in Ray"
                idle.append(a)
            attempts[c] += 1
            if attempts[c] < self.max_attempts:
                note(f"chunk {c}: {why}; it runs again (attempt {attempts[c] + 1} of {self.max_attempts})")
                queue.append(c)
            else:
                failed[c] = f"failed {attempts[c]} times, last: {why}"
        return failed

    def engine_stats(self) -> dict[str, Any]:
        """Compiles summed over the workers, the longest compile, MuJoCo's first warnings."""
        import ray
        from ray.exceptions import RayActorError

        stats = []
        for a in self.actors:
            try:
                stats.append(ray.get(a.engine_stats.remote()))
            except RayActorError:
                pass
        return {
            "compile_s": max((s["compile_s"] for s in stats), default=0.0),
            "compiles": sum(s["compiles"] for s in stats),
            "warnings": [w for s in stats for w in s["warnings"]][:5],
        }

    def close(self) -> None:
        import ray

        for a in self.actors:
            ray.kill(a)
        self.actors = []
