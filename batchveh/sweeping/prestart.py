"""The other GPUs' worker processes, started by the command line before its own imports (issue 33).

On a host of several GPUs `python -m batchveh.sweep` runs chunks in its own process on the first GPU and in one
worker process per other GPU (`gpus.GpuProcesses`). A worker spawned once this process has made its imports makes
them again (1.3-2.2 s from its spawn to its own code on the two-H100 hosts measured), and it ended 1.0-4.8 s after
this process (benchmarks/results/h100x2-gpu-processes-final.json). So the command line calls `start` first thing,
from its arguments alone: each worker makes its imports beside this process's, sets its GPU
(CUDA_VISIBLE_DEVICES) before JAX starts, then waits. `GpuProcesses` hands each one the sweep (`take`); those
not needed after all (a sweep too small for a second GPU, another executor, an error) are told to stop
(`release`). Only light modules are imported here: this module runs before the package's heavy imports.

Started where: two or more local GPUs, no --dry-run or --help, and --executor gpus, or no --executor with the warp
engine (--backend warp, or the spec's backend warp or auto with warp-lang installed); BATCHVEH_GPU_PROCESSES=0
or BATCHVEH_PRESTART=0: never.
"""

from __future__ import annotations

import importlib.util
import multiprocessing
import os
import re
import threading
import time
from typing import Any

_started: dict[str, tuple[Any, Any, float]] = {}  # GPU -> (process, this end of its pipe, time spawned)


def local_gpus() -> list[str]:
    """This machine's GPUs as CUDA_VISIBLE_DEVICES names them (its value where set, else 0..k-1 for the k
    devices /dev/nvidiaN: CUDA numbers what it sees from 0, where a container's files may be /dev/nvidia2 and
    /dev/nvidia3), without starting CUDA."""
    visible = os.environ.get("CUDA_VISIBLE_DEVICES")
    if visible is not None:
        return [v.strip() for v in visible.split(",") if v.strip() and v.strip() != "-1"]
    try:
        names = os.listdir("/dev")
    except OSError:
        return []
    found = [m for m in map(re.compile(r"nvidia(\d+)$").match, names) if m]
    return [str(i) for i in range(len(found))]


def warp_on_several_gpus(backend: str) -> bool:
    """Whether a sweep of `backend` ('warp', or 'auto' with warp-lang found: the warp engine) runs on a host of
    several local GPUs (without importing warp: `importlib.util.find_spec`)."""
    return backend in ("warp", "auto") and len(local_gpus()) > 1 and importlib.util.find_spec("warp") is not None


def _option(argv: list[str], name: str) -> str | None:
    """The value of `--name VALUE` or `--name=VALUE` in argv (the last one), else None."""
    value = None
    for i, a in enumerate(argv):
        if a == name and i + 1 < len(argv):
            value = argv[i + 1]
        elif a.startswith(name + "="):
            value = a.split("=", 1)[1]
    return value


def _spec_backend(argv: list[str]) -> str:
    """The backend the spec file (the first argument that is not an option) names; 'auto' where unreadable
    (the command line reports a bad file itself)."""
    takes_value = {"--out", "--backend", "--limit", "--chunk-size", "--max-variants", "--executor", "--address"}
    i = 0
    while i < len(argv):
        a = argv[i]
        if a in takes_value:
            i += 2
            continue
        if not a.startswith("-"):
            try:
                import yaml

                with open(a) as f:
                    raw = yaml.safe_load(f)
                return str(raw.get("backend", "auto")) if isinstance(raw, dict) else "auto"
            except Exception:  # noqa: BLE001 - the command line says what is wrong with the file
                return "auto"
        i += 1
    return "auto"


def wanted(argv: list[str]) -> tuple[list[str], bool]:
    """The GPUs (as CUDA_VISIBLE_DEVICES names them) to start worker processes for, from the command line's
    arguments: every local GPU but the first where a sweep may use them (see the module's docstring), else [];
    and whether the sweep is likely the warp engine's (the workers then import it while they wait)."""
    if "0" in (os.environ.get("BATCHVEH_GPU_PROCESSES"), os.environ.get("BATCHVEH_PRESTART")):
        return [], False
    if any(a in ("-h", "--help", "--dry-run") for a in argv):
        return [], False
    gpus = local_gpus()
    executor = _option(argv, "--executor")
    if len(gpus) < 2 or executor in ("local", "ray"):
        return [], False
    warp = warp_on_several_gpus(_option(argv, "--backend") or _spec_backend(argv))
    if executor != "gpus" and not warp:
        return [], False
    return gpus[1:], warp


def start(argv: list[str]) -> None:
    """Start a waiting worker process for each GPU that `wanted` names (spawned, daemonic: it ends with this
    process)."""
    ctx = multiprocessing.get_context("spawn")
    gpus, warp = wanted(argv)
    for gpu in gpus:
        here, there = ctx.Pipe()
        proc = ctx.Process(target=_wait, args=(there, gpu, warp), name=f"batchveh-gpu-{gpu}", daemon=True)
        spawned = time.time()
        proc.start()
        there.close()
        _started[gpu] = (proc, here, spawned)


def take(gpu: str) -> tuple[Any, Any, float] | None:
    """The waiting worker process started for `gpu`, its pipe and when it was spawned, taken (once); None where
    there is none or it has died."""
    got = _started.pop(gpu, None)
    if got is not None and not got[0].is_alive():
        got[1].close()
        return None
    return got


def release() -> None:
    """Tell every waiting worker process not taken to stop (each exits at once, or after its imports)."""
    while _started:
        _, (proc, conn, _) = _started.popitem()
        try:
            conn.send(None)
        except (OSError, ValueError):
            pass
        conn.close()


def _open_jax() -> None:
    """Start JAX's backend on this process's GPU (thread-safe: JAX holds a lock while it starts one). Warp's own
    start is not thread-safe and stays where the engine makes it."""
    try:
        import jax

        jax.devices()
    except Exception:  # noqa: BLE001 - a head start only: the engine starts JAX itself and says what fails
        pass


def _wait(conn: Any, gpu: str, warp: bool) -> None:
    """A worker process started ahead: its GPU set before JAX starts, the warp engine's module imported and JAX's
    backend started beside it (with `warp`), then ("go", work, args, jax cache settings) from `GpuProcesses`: it
    goes on as work(conn, args, gpu, jax_cache, entry) (`gpus._work`, handed over so that this light module never
    imports it); None: stop."""
    entry = time.time()
    os.environ["CUDA_VISIBLE_DEVICES"] = gpu
    # as the command line's own process (batchveh.sweep.tune_process_for_one_job), which has not run yet here
    os.environ.setdefault("XLA_PYTHON_CLIENT_PREALLOCATE", "false")
    if warp:
        # JAX's GPU opened on a thread (its PJRT client is made with the GIL released) while this one imports
        # MuJoCo MJX and MuJoCo Warp (about 2 s, holding it): go may come before both are done
        threading.Thread(target=_open_jax, name="batchveh-open-gpu", daemon=True).start()
        import batchveh.engines.warp  # noqa: F401
    try:
        msg = conn.recv()
    except (EOFError, OSError):  # the command line is gone
        return
    if msg is None:
        return
    _, work, args, jax_cache = msg
    work(conn, args, gpu, jax_cache, entry)
