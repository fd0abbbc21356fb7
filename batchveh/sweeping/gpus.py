"""Sweeps on one host's GPUs without Ray: this process on the first GPU, one worker process on each other.

    python -m batchveh.sweep SPEC --executor gpus      # also the default for warp on 2 or more GPUs (below)

The warp engine uses one GPU per process, so a host's other GPUs need processes of their own
(multiprocessing's spawn: a fresh interpreter, nothing of JAX inherited). The command line starts them before
its own imports (`prestart`), and `GpuProcesses` hands each the sweep; elsewhere (a library caller, a worker
started again after a death) `GpuProcesses` starts them first thing. Either way their imports and engines are
built while this process builds its own engine and runs its first chunk. This process (the driver) runs chunks
on its main thread, on GPU 0 as JAX sees it (the only GPU its JAX sees, from the command line: `own_gpu_only`),
as `--executor local` does; each worker holds a `cluster.ChunkWorker` on its GPU (CUDA_VISIBLE_DEVICES set
before JAX starts) and writes its parts itself. Ray is not used: its start (ray.init, the workers'
imports) cost 7 s before a second GPU worked, and the warp engine fails in a process connected to Ray, so
there the driver could not work beside the workers (docs/multi-gpu.md).

One queue of chunks, held by the driver: the driver takes its next chunk from the front as it starts one of
its own, and a background thread hands the next chunk to each worker as it reports its last one written
(over a pipe per worker: milliseconds, so a worker never waits for the driver's chunk), records it in the
manifest at once (`finished`, under one lock with the driver's own), and watches the worker processes.
Every process works as `--executor local` does (`chunks.Pipeline`): its next chunk prepared and its last one
written while its engine runs, so each holds up to two chunks (one ahead) while the queue holds more chunks
than there are processes; the last ones go to whichever is free first. The driver knows at every moment
which process holds which chunks and which one each simulates, so a chunk is never lost and never recorded
twice. Chunks are `shared_chunk(n, gpus)` variants unless the spec or the caller sets them.

Faults. A worker process that dies: the chunks it held go back to the front of the queue (the one it
simulated counts an attempt), and a new worker
starts on that GPU (up to MAX_RESTARTS times). A chunk that raises in a worker goes back too. A chunk runs
at most MAX_ATTEMPTS times on workers; after that it is reported by name (`run` returns it) and the others
go on (`retry.Retries`, the policy the Ray executor shares). An error in the driver's own chunk stops the
sweep, as `--executor local`. A worker whose engine cannot run the spec (ConfigError) or whose manifest
differs from the driver's (`cluster.differs`) is not used, with a note. A driver that dies takes its workers
with it (each ends when its pipe closes, at the latest after its chunk).

Small sweeps: where `alone_reason` (with GPU_PROCESS_START_S) says a second GPU would not pay, no worker is
started and the sweep runs in this process exactly as `--executor local`; the device words say so. The CLI
picks this executor by itself for the warp engine on 2 or more local GPUs where a second GPU pays
(`automatic`; BATCHVEH_GPU_PROCESSES=0 turns that off).

The mujoco backend runs too, each worker with one MuJoCo thread and the names in `gpus` naming worker slots
only: CPU worker processes, so that this module is tested on a machine without GPUs. For tests and
benchmarks, from the environment: BATCHVEH_FAIL_CHUNKS=2,5 makes chunks 2 and 5 raise in the workers
(`ChunkWorker.run`); BATCHVEH_KILL_CHUNK=3 makes the worker process that runs chunk 3 exit abruptly
(os._exit) after simulating it, before writing it, once. While any worker is up, the driver leaves those
chunks to the workers. BATCHVEH_TIMELINE=PATH writes the events (start, each worker ready, each chunk's
start and end with where, each worker's death) as JSON to PATH as they happen.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import signal
import sys
import threading
import time
from collections import Counter, deque
from multiprocessing.connection import wait
from typing import TYPE_CHECKING, Any

from batchveh.config import ConfigError
from batchveh.engines.common import spawn_safe, warp_installed
from batchveh.sweeping import prestart
from batchveh.sweeping.chunks import Pipeline
from batchveh.sweeping.cluster import (
    ChunkWorker,
    Timeline,
    alone_reason,
    differs,
    local_gpus,
    merged_stats,
    shared_chunk,
)
from batchveh.sweeping.retry import MAX_ATTEMPTS, MAX_RESTARTS, Finished, Note, Retries, quiet

if TYPE_CHECKING:
    from batchveh.sweeping.results import ResultFolder
    from batchveh.sweeping.spec import SweepSpec

# What a worker process costs before its GPU works, beyond what this process spends anyway: it repeats the
# imports this process made before its executor started (1.8 s on one H200: the 'start' event of
# h200x2-ray-scaling-1m.json, 1m_ray_2gpu, came 1.76 s after the process began) and the interpreter's start;
# its engine and compile run while this process builds and compiles its own. Estimated, not yet measured on
# its own: about 2.5 s. Below 2 x this of simulation on one GPU a sweep runs in this process alone.
GPU_PROCESS_START_S = 2.5
WAIT = 0.5  # s: the longest a wait on the workers or on the queue lasts before it looks again (closing, errors)


def _work(conn: Any, args: tuple, gpu: str | None, jax_cache: dict[str, Any], entry: float | None = None) -> None:
    """A worker process: build a ChunkWorker, say whether it is ready (with the times of its phases), then run
    the chunks the driver sends, in order, each next one prepared and each finished one written while the
    engine runs (`chunks.Pipeline`); it says ("started", chunk) as a chunk's simulation starts, then ("done",
    chunk, part name, record, engine stats) once its part is written, or ("failed", chunk, why); None: stop."""
    entry = entry or time.time()  # a worker started ahead (prestart): when it entered its own code
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the terminal's whole group: the driver ends us
    import gc

    gc.set_threshold(50_000, 20, 100)  # as the CLI's own process (batchveh.sweep.tune_process_for_one_job)
    phases = {"entry": entry}
    try:
        if jax_cache:  # the driver's persistent compile cache (the CLI's enable_compile_cache); starts no backend
            import jax

            for k, v in jax_cache.items():
                jax.config.update(k, v)
        worker = ChunkWorker(*args, gpu=gpu)
        info = worker.describe()
    except Exception as err:  # an engine that cannot start here: the driver goes on without this worker
        info = {"error": f"{type(err).__name__}: {_last_line(err)}"}
    phases["built"] = time.time()
    lock = threading.Lock()  # the writing thread says "done" while this one may say "started" or "failed"

    def say(msg: tuple) -> None:
        with lock:
            conn.send(msg)

    try:
        say(("ready", {**info, "phases": phases}))
        if info["error"]:  # held until the driver has read why (it then lets this worker go, not restart it)
            conn.recv()
            return
        with Pipeline(worker.runner, worker.folder) as pipe:
            inbox: queue.SimpleQueue = queue.SimpleQueue()

            def receive() -> None:  # each chunk is prepared as soon as it is handed (ahead of its turn)
                try:
                    while (msg := conn.recv()) is not None:
                        pipe.ahead(msg[0])
                        inbox.put(msg)
                except (EOFError, OSError):  # the driver is gone
                    pass
                inbox.put(None)

            threading.Thread(target=receive, name="batchveh-receive", daemon=True).start()
            while (msg := inbox.get()) is not None:
                c, die = msg
                say(("started", c))
                try:
                    worker.check(c)
                    table = pipe.simulate(c)
                    if die:  # BATCHVEH_KILL_CHUNK: simulated, not written
                        os._exit(1)
                    pipe.write(
                        c,
                        table,
                        lambda c, name, rec: say(("done", c, name, rec, worker.engine_stats())),
                        lambda c, err: say(("failed", c, f"{type(err).__name__}: {_last_line(err)}")),
                    )
                except Exception as err:
                    say(("failed", c, f"{type(err).__name__}: {_last_line(err)}"))
    except (EOFError, OSError):  # the driver is gone
        return


def _last_line(err: BaseException) -> str:
    lines = str(err).strip().splitlines()
    return lines[-1] if lines else ""


class _Slot:
    """One GPU's worker: its process (replaced after a death), the driver's end of its pipe, its state
    ('starting', 'ready', 'gone': not used or not restarted), the chunks it holds in the order handed (being
    written, simulated, handed ahead) and the one it simulates."""

    def __init__(self, index: int, gpu: str):
        self.index, self.gpu = index, gpu
        self.where = f"worker {index}"
        self.proc: Any = None
        self.conn: Any = None
        self.state = "starting"
        self.info: dict[str, Any] | None = None  # its answer to the start, until the driver's manifest is known
        self.chunks: list[int] = []
        self.running: int | None = None
        self.spawned = 0.0
        self.ahead = False  # its process was started by the command line before its imports (prestart)
        self.restarts = 0
        self.stats: dict[str, Any] | None = None


class GpuProcesses:
    """Runs a sweep's chunks in this process and in one worker process per other GPU of this host (see the
    module's docstring).

    `gpus`: the GPUs as CUDA_VISIBLE_DEVICES names them (default: `local_gpus()`); the first is this
    process's (JAX's device 0), each other gets a worker. With the mujoco backend they only name worker
    slots (CPU processes of one MuJoCo thread). After `start`, `workers_info` lists each ready worker's
    process id, GPU and device, and `timeline` the events with their times (time.time())."""

    spreads = True  # the automatic chunk size follows the number of GPUs

    def __init__(
        self, gpus: list[str] | None = None, max_attempts: int = MAX_ATTEMPTS, max_restarts: int = MAX_RESTARTS
    ):
        self.gpus = gpus
        self.max_attempts, self.max_restarts = max_attempts, max_restarts
        self.timeline = Timeline()
        self.workers_info: list[dict[str, Any]] = []
        self.slots: list[_Slot] = []
        self.runner: Any = None
        self.folder: ResultFolder | None = None
        self.manifest: dict[str, Any] | None = None
        self._cond = threading.Condition(threading.RLock())  # guards everything below, and `finished`
        self._queue: deque[int] = deque()
        self._running = False  # `run` has filled the queue
        self._mine: list[int] = []  # the chunks this process holds: handed ahead, simulated, being written
        self._ahead: int | None = None  # of them, the one handed to it ahead, not begun
        self._finished: Finished | None = None
        self._notes: list[str] = []  # notes before `run` gives the callback
        self._note: Note = self._notes.append
        self._retries = Retries(lambda text: self._note(text), max_attempts)
        self._error: BaseException | None = None  # from the background thread, raised in `run`
        self._stopping = self._closing = False
        self._thread: threading.Thread | None = None
        fail = os.environ.get("BATCHVEH_FAIL_CHUNKS", "")
        self._fail = {int(c) for c in fail.split(",") if c.strip().isdigit()}
        kill = os.environ.get("BATCHVEH_KILL_CHUNK", "").strip()
        self._kill = int(kill) if kill.isdigit() else None

    def start(
        self, spec: SweepSpec, backend: str, n: int, chunk_size: int | None, folder: ResultFolder
    ) -> tuple[dict[str, Any], str]:
        """Start the worker processes (not waited for), then build this process's engine; return (what the
        manifest records, the devices in words). ConfigError where this process cannot run the spec."""
        from batchveh.engines import resolve_backend
        from batchveh.sweeping.chunks import ChunkRunner

        self.timeline.add("start")
        self.folder = folder
        backend = resolve_backend(backend)
        if backend == "mjx":
            raise ConfigError(
                "--executor gpus: MJX's JAX implementation (backend mjx) already shards each chunk over every "
                "local GPU in one process; allowed: --executor local, or backend warp"
            )
        gpu_engine = backend != "mujoco"
        gpus = local_gpus() if self.gpus is None else list(self.gpus)
        chunk = chunk_size or spec.chunk_size
        if chunk is None and gpu_engine and len(gpus) > 1:
            chunk = shared_chunk(n, len(gpus))
        # the mujoco engine (CPU worker processes, for tests) is never estimated: only one slot or one chunk
        start_s = GPU_PROCESS_START_S if gpu_engine else 0.0
        why = "no GPU found" if not gpus else None
        why = why or alone_reason(n, spec.stats_config().n_steps, backend, len(gpus), chunk, start_s, "its start")
        if why:  # exactly as --executor local
            prestart.release()  # the workers the command line started ahead are not needed
            self.runner = ChunkRunner(spec, backend, n, chunk_size)
            self.manifest = self.runner.manifest
            self.timeline.add("alone", why=why)
            return self.manifest, f"{self.runner.device}, in this process alone ({why})"
        jax_cache = {}
        jax = sys.modules.get("jax")
        if jax is not None and jax.config.jax_compilation_cache_dir:
            jax_cache = {
                "jax_compilation_cache_dir": jax.config.jax_compilation_cache_dir,
                "jax_persistent_cache_min_compile_time_secs": jax.config.jax_persistent_cache_min_compile_time_secs,
            }
        nthread = 0 if gpu_engine else 1
        self._args = (spec, backend, n, chunk, len(gpus), nthread, folder.shared)
        self._jax_cache, self._gpu_engine = jax_cache, gpu_engine
        self._ctx = multiprocessing.get_context("spawn")
        with self._cond:
            self.slots = [_Slot(i, g) for i, g in enumerate(gpus[1:])]
            for slot in self.slots:
                self._spawn(slot)
        self.timeline.add("workers asked", count=len(self.slots), gpus=gpus[1:])
        self._thread = threading.Thread(target=self._watch, name="batchveh-gpu-workers", daemon=True)
        self._thread.start()
        self.runner = ChunkRunner(spec, backend, n, chunk, workers=len(gpus), nthread=nthread)
        with self._cond:
            self.manifest = self.runner.manifest
            self.timeline.add("engine built", chunk_size=self.runner.chunk)
            self._hand_out()  # admits the workers that were ready first
        k = len(self.slots)
        return self.manifest, f"this process and {k} worker process{'es' * (k > 1)}, each {self.runner.device}"

    def _spawn(self, slot: _Slot) -> None:
        """Start slot's worker: the one the command line started ahead for its GPU (`prestart`), handed the
        sweep, where there is one (not after a death), else a new process."""
        ahead = prestart.take(slot.gpu) if not slot.restarts else None
        if ahead is not None:
            proc, here, slot.spawned = ahead
            if not self._send_to(here, ("go", _work, self._args, self._jax_cache)):
                here.close()
                proc.terminate()
                ahead = None
        if ahead is None:
            here, there = self._ctx.Pipe()
            gpu = slot.gpu if self._gpu_engine else None
            proc = self._ctx.Process(
                target=_work, args=(there, self._args, gpu, self._jax_cache), name=f"batchveh-{slot.where}", daemon=True
            )
            slot.spawned = time.time()
            proc.start()
            there.close()  # the worker's end lives in the worker: its death closes the pipe
        slot.ahead = ahead is not None
        slot.proc, slot.conn, slot.state, slot.info, slot.chunks, slot.running = proc, here, "starting", None, [], None

    @property
    def _attempts(self) -> Counter[int]:
        """How often each chunk has failed on a worker (`retry.Retries`)."""
        return self._retries.attempts

    def run(self, todo: list[int], finished: Finished, note: Note, phase: Note = quiet) -> dict[int, str]:
        """Run the chunks in `todo`, here and on the workers, calling finished(chunk, part name, record) as
        each is written; return {chunk: why} for those that kept failing on the workers. An error in this
        process's own chunk stops the sweep. Each process, this one too, is handed its next chunk while it
        runs one (so that it prepares it ahead: `chunks.Pipeline`) while the queue holds more chunks than
        there are processes to take them; the last ones go to whichever process is free first."""
        if not self.slots:  # this process alone, as --executor local (the next chunk prepared ahead)
            return self.runner.run_here(todo, self.folder, finished, phase)
        with self._cond:
            self._finished, self._note = finished, note
            for text in self._notes:
                note(text)
            self._queue, self._running = deque(todo), True
            self._hand_out()
        try:
            with Pipeline(self.runner, self.folder) as pipe:
                while True:
                    with self._cond:
                        c = self._next_here()
                        while c is None and not self._all_done():
                            phase(f"{self._held()} chunk{'s' * (self._held() != 1)} on worker processes")
                            self._cond.wait(WAIT)
                            c = self._next_here()
                        if c is None:
                            break
                        ahead = self._ahead_here()
                        phase(f"chunk {c + 1}/{self.runner.n_chunks} here, {self._held()} on worker processes")
                        self.timeline.add("chunk start", chunk=c, where="driver")
                    pipe.ahead(c)  # prepared before the next (one chunk at a time: chunks.Pipeline)
                    if ahead is not None:
                        pipe.ahead(ahead)
                    pipe.write(c, pipe.simulate(c), self._written_here)
            with self._cond:
                return dict(self._retries.failed)
        finally:
            with self._cond:
                self._stopping = True  # every chunk is written or failed, or this process's chunk raised
                for slot in self.slots:
                    self._send(slot, None)

    def _written_here(self, c: int, name: str, rec: dict[str, Any]) -> None:
        """This process's chunk `c` is written (on the pipeline's writing thread)."""
        with self._cond:
            self.timeline.add("chunk end", chunk=c, where="driver")
            self._mine.remove(c)
            self._finished(c, name, rec)
            self._cond.notify_all()

    def _up(self) -> int:
        """The processes that take chunks: this one and each worker not let go."""
        return 1 + sum(s.state != "gone" for s in self.slots)

    def _next_here(self) -> int | None:
        """The chunk this process runs next: the one handed to it ahead, else the first of the queue it may
        take (not one a test hook leaves to the workers while one is up); raises what the background thread
        met."""
        if self._error is not None:
            raise self._error
        c, self._ahead = self._ahead, None
        return c if c is not None else self._take_here()

    def _take_here(self) -> int | None:
        up = self._up() > 1  # a worker is up
        for c in self._queue:
            # a chunk that failed on a worker (or killed it) is not run here while a worker is up: it could
            # take this process, and the whole sweep, with it
            if not up or not (c in self._fail or c == self._kill or self._retries.tried(c)):
                self._queue.remove(c)
                self._mine.append(c)
                return c
        return None

    def _ahead_here(self) -> int | None:
        """This process's next chunk, taken now to be prepared ahead, where the queue holds more chunks than
        processes; else None."""
        if len(self._queue) > self._up():
            self._ahead = self._take_here()
        return self._ahead

    def _held(self) -> int:
        return sum(len(s.chunks) for s in self.slots)

    def _all_done(self) -> bool:
        return not self._queue and not self._mine and not self._held()

    def _send(self, slot: _Slot, msg: Any) -> bool:
        return self._send_to(slot.conn, msg)

    @staticmethod
    def _send_to(conn: Any, msg: Any) -> bool:
        try:
            conn.send(msg)
            return True
        except (OSError, ValueError):  # it died (its death is taken in by `_watch`), or its pipe is closed
            return False

    def _hand_out(self) -> None:
        """Admit the workers that are ready (once this process's manifest is known) and hand chunks out. Under
        the lock."""
        if self._stopping:
            return
        if self.manifest is not None:
            for slot in self.slots:
                if slot.state == "starting" and slot.info is not None:
                    self._admit(slot)
        if not self._running:
            return
        for slot in self.slots:
            # an idle worker gets the first chunk; one with a single chunk its next ahead while the queue holds
            # more than there are processes
            while (
                slot.state == "ready"
                and self._queue
                and (not slot.chunks or (len(slot.chunks) == 1 and len(self._queue) > self._up()))
            ):
                c = self._queue.popleft()
                die = c == self._kill
                if die:
                    self._kill = None  # once
                if not self._send(slot, (c, die)):
                    self._queue.appendleft(c)  # no attempt spent: it never started
                    break
                slot.chunks.append(c)
                self.timeline.add("chunk handed", chunk=c, where=slot.where)

    def _admit(self, slot: _Slot) -> None:
        info = slot.info
        why = info["error"] or differs(self.manifest, info["manifest"])
        if why:
            self._note(f"the worker process on GPU {slot.gpu} is not used: {why}")
            slot.state = "gone"
            self._send(slot, None)
            return
        slot.state = "ready"
        self.workers_info.append({"pid": info["pid"], "gpu": slot.gpu, "device": info["device"]})
        # its phases: spawned here, its own code entered (interpreter, imports, arguments), its engine built
        phases = {"spawned": slot.spawned, **info.get("phases", {})}
        self.timeline.add(
            "worker ready",
            where=slot.where,
            pid=info["pid"],
            gpu=slot.gpu,
            device=info["device"],
            phases=phases,
            started_ahead=slot.ahead,
        )

    def _watch(self) -> None:
        """The background thread: take in what the workers say, and their deaths, as they come."""
        try:
            while not self._closing:
                with self._cond:
                    live = [s for s in self.slots if s.proc is not None]
                if not live:
                    return
                ready = wait([s.conn for s in live] + [s.proc.sentinel for s in live], timeout=WAIT)
                with self._cond:
                    if self._closing:
                        return
                    for slot in live:
                        if slot.conn in ready or slot.proc.sentinel in ready:
                            self._receive(slot)  # what it said before it died counts
                        if slot.proc.sentinel in ready:
                            self._died(slot)
                    self._hand_out()
                    self._cond.notify_all()
        except BaseException as err:  # noqa: BLE001 (a `finished` that raised, say): `run` raises it
            with self._cond:
                if not self._closing:  # closing: a pipe closed under the wait
                    self._error = err
                self._cond.notify_all()

    def _receive(self, slot: _Slot) -> None:
        try:
            while slot.conn.poll():
                msg = slot.conn.recv()
                if msg[0] == "ready":
                    slot.info = msg[1]
                    continue
                c = msg[1]
                if msg[0] == "started":
                    slot.running = c
                    self.timeline.add("chunk start", chunk=c, where=slot.where)
                    continue
                slot.chunks.remove(c)
                if slot.running == c:
                    slot.running = None
                if msg[0] == "done":
                    _, _, name, rec, slot.stats = msg
                    self.timeline.add("chunk end", chunk=c, where=slot.where)
                    self._finished(c, name, rec)
                else:
                    self._again(c, msg[2])
        except (EOFError, OSError):  # its end is closed: it died, which its sentinel tells
            pass

    def _died(self, slot: _Slot) -> None:
        slot.proc.join()
        code = slot.proc.exitcode
        slot.conn.close()
        slot.proc = None
        c, held = slot.running, slot.chunks
        slot.running, slot.chunks = None, []
        if self._stopping or slot.state == "gone":  # stopped, or let go
            slot.state = "gone"
            return
        self.timeline.add("worker died", where=slot.where, chunk=c, exitcode=code)
        for other in reversed([h for h in held if h != c]):  # written or not yet begun: no attempt spent
            self._queue.appendleft(other)
        if c is not None:
            self._again(c, f"its worker process (GPU {slot.gpu}) died (exit code {code})")
        if slot.restarts < self.max_restarts:
            slot.restarts += 1
            self._spawn(slot)
            self.timeline.add("worker restarted", where=slot.where, restarts=slot.restarts)
        else:
            slot.state = "gone"
            self._note(f"the worker process on GPU {slot.gpu} died {slot.restarts + 1} times; not started again")

    def _again(self, c: int, why: str) -> None:
        """Chunk `c` failed on a worker: back to the front of the queue, or reported after max_attempts."""
        if self._retries.again(c, why):
            self._queue.appendleft(c)

    def engine_stats(self) -> dict[str, Any]:
        """Compiles summed over this process and the workers (each worker's as of its last chunk), the longest
        compile, MuJoCo's first warnings."""
        with self._cond:
            return merged_stats([self.runner.engine_stats(), *(s.stats for s in self.slots if s.stats)])

    def close(self) -> None:
        """End the workers: those told to stop exit by themselves, not waited for (each has written all it
        held); the others (still starting, or running a chunk of a sweep that stopped on an error) are
        terminated."""
        if not self.slots or self._closing:
            return
        with self._cond:  # the background thread, woken by the deaths, finds `_closing` and touches nothing
            self._closing = self._stopping = True
            for slot in self.slots:
                if slot.proc is None:
                    continue
                idle = slot.state == "ready" and not slot.chunks
                if not (idle and self._send(slot, None)):
                    slot.proc.terminate()
                    slot.proc.join(timeout=5.0)
                    if slot.proc.is_alive():
                        slot.proc.kill()
                        slot.proc.join()
                slot.conn.close()
                slot.proc = None
        # the background thread finds `_closing` within WAIT and ends; it touches nothing after that
        self.timeline.add("closed")


def own_gpu_only(backend: str) -> bool:
    """Whether a sweep process should show JAX only the first local GPU (the CLI's `main` then sets
    jax_cuda_visible_devices to 0 before JAX starts): the warp engine (`backend` 'warp', or 'auto' with
    warp-lang installed) on a host of several GPUs. The warp engine runs on JAX's first device only, and the
    other GPUs are the worker processes' (GpuProcesses); a JAX that starts on every GPU makes a context on
    each, beside the workers' own. Measured on two H100s, 1,000,000 x 10 s (h100x2-gpu-processes-own-gpu.json):
    this process's first chunk took 15.8 s against 17.7 s with JAX on both GPUs (its compile-cache load 2.6 s
    against 4.5 s)."""
    return prestart.warp_on_several_gpus(backend) and warp_installed()


def automatic(spec: SweepSpec, backend: str, n: int, chunk_size: int | None = None) -> GpuProcesses | None:
    """The executor of a plain `python -m batchveh.sweep`: GpuProcesses for the warp engine (`backend`
    resolved) on 2 or more local GPUs where a second GPU pays (`alone_reason` with GPU_PROCESS_START_S), else
    None (in-process). MJX already shards each chunk over every local GPU. BATCHVEH_GPU_PROCESSES=0, or a
    main script that a spawned process would run again (`spawn_safe`): None."""
    if backend != "warp" or os.environ.get("BATCHVEH_GPU_PROCESSES", "1") == "0" or not spawn_safe():
        return None
    gpus = local_gpus()
    if len(gpus) < 2:
        return None
    chunk = chunk_size or spec.chunk_size or shared_chunk(n, len(gpus))
    steps = spec.stats_config().n_steps
    if alone_reason(n, steps, backend, len(gpus), chunk, GPU_PROCESS_START_S, "its start") is not None:
        return None
    return GpuProcesses(gpus)
