"""One process per local GPU without Ray (issue 33, batchveh/sweeping/gpus.py), on the CPU: backend mujoco
(float64, so the in-process sweep of the same spec is the exact reference), two 'GPU' names, so this process
and one spawned worker process of one MuJoCo thread. Equal rows, each chunk recorded once; a worker process
killed in a chunk (BATCHVEH_KILL_CHUNK); a chunk that keeps failing in the worker (BATCHVEH_FAIL_CHUNKS);
the automatic choice and the sweep alone in this process.

A worker process starts in about 3-5 s on 2 cores (its imports and engine). So that it surely runs
chunks, this process waits for it before its second chunk (`_patient`).
"""

import json
import os
import sys
import time
import types
from collections import Counter

import pandas as pd
import pytest
from conftest import size_here_and_on
from conftest import sweep_spec as _spec

import batchveh
from batchveh.sweep import main, run_sweep
from batchveh.sweeping import gpus
from batchveh.sweeping.chunks import Pipeline
from batchveh.sweeping.results import ResultFolder
from batchveh.sweeping.spec import load_spec

pytestmark = pytest.mark.xdist_group("gpu_processes")  # one test worker: the module's shared fixtures run once

NAMES = ["0", "1"]  # this process and one worker process
# the spec: conftest.sweep_spec, 8 variants of 1 s (300 steps of 5 ms with the settle), here in 4 chunks of 2


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The spec swept in this process in chunks of 2: the exact reference."""
    tmp = tmp_path_factory.mktemp("reference")
    run_sweep(load_spec(_spec(tmp)), out=tmp / "ref", chunk_size=2, progress=False)
    return batchveh.load(tmp / "ref")


def _parts(out):
    return sorted(p.name for p in out.glob("part-*.parquet"))


def _patient(monkeypatch, ex):
    """This process runs its first chunk, then waits (up to 60 s) until the worker process is ready."""
    run, calls = Pipeline.simulate, []

    def here(self, c):  # in this process only: the worker process imports its own Pipeline
        calls.append(c)
        deadline = time.time() + 60
        while len(calls) == 2 and not ex.workers_info and time.time() < deadline:
            time.sleep(0.01)
        return run(self, c)

    monkeypatch.setattr(Pipeline, "simulate", here)


def _sweep(tmp_path, monkeypatch, name, chunk_size=2, **env):
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    timeline = tmp_path / f"{name}.timeline.json"
    monkeypatch.setenv("BATCHVEH_TIMELINE", str(timeline))
    ex, notes, out = gpus.GpuProcesses(NAMES), [], tmp_path / name
    _patient(monkeypatch, ex)
    spec = load_spec(_spec(tmp_path))
    s = run_sweep(spec, out=out, chunk_size=chunk_size, progress=False, report=notes.append, executor=ex)
    assert s["device"].startswith("this process and 1 worker process, each 1 CPU thread"), s["device"]
    assert not list(out.glob(".*.tmp"))
    assert json.loads(timeline.read_text())[-1]["event"] == "closed"  # written out as it happened
    assert all(not s.proc for s in ex.slots)  # the workers ended
    return s, ex, notes, out


def _ends(ex):
    return [(e["chunk"], e["where"]) for e in ex.timeline if e["event"] == "chunk end"]


def test_equals_the_in_process_sweep(tmp_path, monkeypatch, reference):
    s, ex, notes, out = _sweep(tmp_path, monkeypatch, "two")
    assert s["rows"] == s["ran"] == 8 and not s["failed"] and not notes, (s, notes)
    pd.testing.assert_frame_equal(batchveh.load(out), reference)  # bit-identical; verifies the checksums
    # each chunk recorded once, both processes ran chunks, and the worker is another process
    names = [f"part-0000{c}.parquet" for c in range(4)]
    assert sorted(ResultFolder(out).read_manifest()["parts"]) == _parts(out) == names
    ends = _ends(ex)
    assert sorted(c for c, _ in ends) == [0, 1, 2, 3], ends
    where = Counter(w for _, w in ends)
    assert where["driver"] >= 1 and where["worker 0"] >= 1, where
    [info] = ex.workers_info
    assert info["gpu"] == "1" and info["pid"] != os.getpid()


def test_each_process_holds_its_next_chunk_while_the_queue_is_long(tmp_path, monkeypatch, reference):
    """Eight chunks of one variant: while the queue holds more chunks than the two processes, each is handed
    its next chunk while it runs one (prepared ahead); the last two go to whichever is free first."""
    s, ex, notes, out = _sweep(tmp_path, monkeypatch, "ahead", chunk_size=1)
    assert s["rows"] == s["ran"] == 8 and not s["failed"] and not notes, (s, notes)
    pd.testing.assert_frame_equal(batchveh.load(out), reference)
    assert sorted(c for c, _ in _ends(ex)) == list(range(8))
    held, most = set(), 0  # the worker's chunks handed and not yet ended
    for e in ex.timeline:
        if e.get("where") == "worker 0" and e["event"] in ("chunk handed", "chunk end"):
            (held.add if e["event"] == "chunk handed" else held.remove)(e["chunk"])
            most = max(most, len(held))
    assert most == 2, ex.timeline


def test_a_dead_worker_gives_back_every_chunk_it_held(tmp_path):
    """Its chunk being written, the one it simulated and the one handed ahead go back to the front of the
    queue; only the one it simulated counts an attempt."""
    ex = gpus.GpuProcesses(NAMES, max_restarts=0)
    notes = []
    ex._note, ex._queue = notes.append, gpus.deque([7])
    slot = gpus._Slot(0, "1")
    ex.slots = [slot]
    slot.state, slot.chunks, slot.running = "ready", [3, 4, 5], 4
    slot.proc = type("Dead", (), {"join": lambda self: None, "exitcode": -9})()
    slot.conn = type("Closed", (), {"close": lambda self: None})()
    ex._died(slot)
    assert list(ex._queue) == [4, 3, 5, 7]
    assert ex._attempts == {4: 1} and slot.chunks == [] and slot.running is None
    assert notes[0] == "chunk 4: its worker process (GPU 1) died (exit code -9); it runs again (attempt 2 of 3)"


def test_hand_out_ahead_only_while_the_queue_is_long():
    ex = gpus.GpuProcesses(NAMES)
    sent = []
    slot = gpus._Slot(0, "1")
    slot.state, slot.conn = "ready", type("Pipe", (), {"send": lambda self, msg: sent.append(msg)})()
    ex.slots, ex.manifest, ex._running = [slot], {}, True
    ex._queue = gpus.deque(range(5))
    ex._hand_out()  # idle: the first chunk, and the next ahead (3 left, more than the 2 processes)
    assert slot.chunks == [0, 1] and sent == [(0, False), (1, False)]
    slot.chunks.remove(0)
    ex._hand_out()  # one held, 3 in the queue: one more ahead
    assert slot.chunks == [1, 2]
    slot.chunks.remove(1)
    ex._hand_out()  # 2 left for 2 processes: none ahead
    assert slot.chunks == [2] and list(ex._queue) == [3, 4]
    slot.chunks.remove(2)
    ex._hand_out()  # idle: the first chunk, whatever is left
    assert slot.chunks == [3] and list(ex._queue) == [4]


@pytest.mark.slow
def test_killed_worker_chunk_runs_again(tmp_path, monkeypatch, reference):
    s, ex, notes, out = _sweep(tmp_path, monkeypatch, "killed", BATCHVEH_KILL_CHUNK="1")
    assert s["rows"] == 8 and not s["failed"], s
    assert any("chunk 1: its worker process (GPU 1) died (exit code 1); it runs again" in n for n in notes), notes
    died = [e for e in ex.timeline if e["event"] == "worker died"]
    assert [(e["chunk"], e["exitcode"]) for e in died] == [(1, 1)], died
    assert any(e["event"] == "worker restarted" for e in ex.timeline)
    pd.testing.assert_frame_equal(batchveh.load(out), reference)
    assert sorted(ResultFolder(out).read_manifest()["parts"]) == _parts(out) and len(_parts(out)) == 4
    assert sorted(c for c, _ in _ends(ex)) == [0, 1, 2, 3]  # chunk 1 ended once, after its run again


def test_chunk_that_keeps_failing_is_reported(tmp_path, monkeypatch, reference):
    s, ex, notes, out = _sweep(tmp_path, monkeypatch, "failing", BATCHVEH_FAIL_CHUNKS="2")
    assert list(s["failed"]) == [2] and "failed 3 times" in s["failed"][2] and "injected fault" in s["failed"][2]
    assert sum("chunk 2: RuntimeError" in n and "it runs again" in n for n in notes) == 2, notes
    assert _parts(out) == ["part-00000.parquet", "part-00001.parquet", "part-00003.parquet"]
    expect = reference[~reference.variant.isin([4, 5])].reset_index(drop=True)
    pd.testing.assert_frame_equal(batchveh.load(out), expect)


def test_one_gpu_runs_alone_in_this_process(tmp_path, monkeypatch, capsys, reference):
    path = _spec(tmp_path)
    ex = gpus.GpuProcesses(["0"])
    s = run_sweep(load_spec(path), out=tmp_path / "one", chunk_size=2, progress=False, executor=ex)
    assert s["device"].endswith("in this process alone (one GPU)") and not ex.slots, s["device"]
    pd.testing.assert_frame_equal(batchveh.load(tmp_path / "one"), reference)
    # the command line: --executor gpus with one GPU visible
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "0")
    argv = [str(path), "--executor", "gpus", "--chunk-size", "2", "--out", str(tmp_path / "cli"), "--quiet"]
    assert main(argv) == 0
    assert "in this process alone (one GPU))" in capsys.readouterr().out


def test_automatic_choice(tmp_path, monkeypatch):
    spec = load_spec(_spec(tmp_path, fixed={"total_time": 10.0, "ramp_time": 2.0}))  # 2,100 steps
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "0,1")
    monkeypatch.delenv("BATCHVEH_GPU_PROCESSES", raising=False)
    script = types.ModuleType("__main__")  # a user's script (not batchveh's command line, not a notebook)
    script.__file__, script.__spec__ = str(tmp_path / "my_sweep.py"), None
    monkeypatch.setitem(sys.modules, "__main__", script)
    assert not gpus.spawn_safe()  # an unguarded script: no worker processes unless asked for
    assert gpus.automatic(load_spec(_spec(tmp_path, "unguarded")), "warp", 1_000_000) is None
    monkeypatch.setattr(gpus, "spawn_safe", lambda: True)  # as under python -m batchveh.sweep
    ex = gpus.automatic(spec, "warp", 1_000_000)
    assert isinstance(ex, gpus.GpuProcesses) and ex.gpus == ["0", "1"]
    assert gpus.automatic(spec, "warp", 100_000) is None  # one chunk of shared_chunk's
    assert gpus.automatic(spec, "warp", 200_000, chunk_size=4096) is not None  # 22 s of simulation on one GPU
    assert gpus.automatic(spec, "warp", 40_000, chunk_size=4096) is None  # 4 s: less than 2 x the start
    assert gpus.automatic(spec, "mjx", 1_000_000) is None  # MJX shards over every GPU itself
    assert gpus.automatic(spec, "mujoco", 1_000_000) is None
    monkeypatch.setenv("BATCHVEH_GPU_PROCESSES", "0")
    assert gpus.automatic(spec, "warp", 1_000_000) is None
    monkeypatch.setenv("BATCHVEH_GPU_PROCESSES", "1")
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "0")
    assert gpus.automatic(spec, "warp", 1_000_000) is None


def test_the_driver_shows_jax_its_own_gpu_only_for_warp_on_several_gpus(monkeypatch):
    monkeypatch.setattr(gpus, "warp_installed", lambda: True)
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "2,3")
    assert gpus.own_gpu_only("warp") and gpus.own_gpu_only("auto")
    assert not gpus.own_gpu_only("mjx") and not gpus.own_gpu_only("mujoco")  # MJX shards over every GPU
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "3")
    assert not gpus.own_gpu_only("warp")
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "2,3")
    monkeypatch.setattr(gpus, "warp_installed", lambda: False)
    assert not gpus.own_gpu_only("auto")


def _cli_sweep(tmp_path, name):
    """The spec through `python -m batchveh.sweep --executor gpus` on two 'GPUs' (CPU worker processes), in a
    fresh process: its timeline's 'worker ready' event and the rows."""
    import subprocess
    import sys

    timeline, out = tmp_path / f"{name}.timeline.json", tmp_path / name
    env = {**os.environ, "CUDA_VISIBLE_DEVICES": "0,1", "BATCHVEH_TIMELINE": str(timeline)}
    env.pop("BATCHVEH_PRESTART", None)
    cmd = [sys.executable, "-m", "batchveh.sweep", str(_spec(tmp_path)), "--executor", "gpus", "--chunk-size", "2"]
    done = subprocess.run([*cmd, "--out", str(out), "--quiet"], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    events = json.loads(timeline.read_text())
    [ready] = [e for e in events if e["event"] == "worker ready"]
    built = next(e["t"] for e in events if e["event"] == "engine built")
    return ready, built, batchveh.load(out)


def test_the_command_line_starts_the_worker_before_its_own_imports(tmp_path, reference):
    """`prestart`: the worker process is spawned before the command line's imports (before the executor's
    'start'), set up while they run, and handed the sweep (BATCHVEH_PRESTART=0, or a library caller: spawned at
    the start, as in the tests above)."""
    ready, built, rows = _cli_sweep(tmp_path, "ahead")
    assert ready["started_ahead"] and ready["phases"]["spawned"] < built - 0.2, ready
    pd.testing.assert_frame_equal(rows, reference)


def test_which_command_lines_start_workers_ahead(tmp_path, monkeypatch):
    from batchveh.sweeping import prestart

    spec = _spec(tmp_path)  # backend mujoco
    warp = tmp_path / "warp.yaml"
    warp.write_text(spec.read_text().replace("backend: mujoco", "backend: warp"))
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "0,2,3")
    monkeypatch.delenv("BATCHVEH_PRESTART", raising=False)
    monkeypatch.delenv("BATCHVEH_GPU_PROCESSES", raising=False)
    has_warp = prestart.importlib.util.find_spec("warp") is not None
    assert prestart.wanted([str(spec), "--executor", "gpus"]) == (["2", "3"], False)
    assert prestart.wanted([str(warp)]) == ((["2", "3"], True) if has_warp else ([], False))
    assert prestart.wanted([str(spec)]) == ([], False)  # MuJoCo C, no --executor: in this process
    assert prestart.wanted(["--backend", "warp", str(spec), "--executor=local"]) == ([], False)
    assert prestart.wanted([str(warp), "--dry-run"]) == ([], False)
    assert prestart.wanted([str(spec), "--executor", "gpus", "--executor", "ray"]) == ([], False)
    monkeypatch.setenv("BATCHVEH_PRESTART", "0")
    assert prestart.wanted([str(spec), "--executor", "gpus"]) == ([], False)
    monkeypatch.setenv("BATCHVEH_PRESTART", "1")
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "1")
    assert prestart.wanted([str(spec), "--executor", "gpus"]) == ([], False)


def test_mjx_is_refused_in_one_line(tmp_path, capsys):
    argv = [str(_spec(tmp_path)), "--executor", "gpus", "--backend", "mjx", "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "already shards each chunk" in err and "Traceback" not in err, err


def test_a_worker_that_differs_is_not_used():
    ex = gpus.GpuProcesses(NAMES)
    ex.manifest, notes = {"backend": "warp", "precision": "f32"}, []
    ex._note = notes.append
    same, other, broken = gpus._Slot(0, "1"), gpus._Slot(1, "2"), gpus._Slot(2, "3")
    ex.slots = [same, other, broken]
    for slot in ex.slots:
        slot.conn = type("Closed", (), {"send": lambda self, msg: None})()
    same.info = {"error": None, "manifest": dict(ex.manifest), "pid": 1, "device": "1 x GPU"}
    other.info = {**same.info, "manifest": {"backend": "warp", "precision": "f64"}}
    broken.info = {"error": "ConfigError: no GPU"}
    ex._hand_out()
    assert [s.state for s in ex.slots] == ["ready", "gone", "gone"]
    assert notes == [
        "the worker process on GPU 2 is not used: it differs in precision: 'f64', here 'f32'",
        "the worker process on GPU 3 is not used: ConfigError: no GPU",
    ]


def test_a_worker_that_cannot_start_waits_to_be_let_go(tmp_path):
    """A worker whose engine fails to start says why and then waits for the driver: had it exited at once,
    the driver would have taken it for dead, restarted it, and lost the reason."""
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    here, there = ctx.Pipe()
    bad = (None, "mujoco", 1, None, 1, 1, str(tmp_path))  # no spec: ChunkWorker cannot build its runner
    proc = ctx.Process(target=gpus._work, args=(there, bad, None, {}), daemon=True)
    proc.start()
    there.close()
    assert here.poll(120)
    kind, info = here.recv()
    assert kind == "ready" and info["error"], info
    proc.join(timeout=1.0)
    assert proc.is_alive()  # still there: the driver reads why before it lets the worker go
    here.send(None)
    proc.join(timeout=30)
    assert proc.exitcode == 0


def test_a_warp_worker_started_ahead_opens_jax_beside_its_imports_and_stops_when_told():
    """`prestart._wait` with the warp engine: JAX's backend starts on a thread while the process imports MuJoCo
    MJX and MuJoCo Warp on another (both import JAX: no import deadlock), then None lets it go."""
    import multiprocessing

    from batchveh.sweeping import prestart

    ctx = multiprocessing.get_context("spawn")
    here, there = ctx.Pipe()
    proc = ctx.Process(target=prestart._wait, args=(there, "", True), daemon=True)
    proc.start()
    there.close()
    here.send(None)
    proc.join(timeout=120)
    assert proc.exitcode == 0


# -m slow (14 s on 2 cores): the size command's `--executor gpus` end to end; the sweeps' path is above
@pytest.mark.slow
def test_the_size_command_on_gpu_processes_gives_the_in_process_verdicts(tmp_path, monkeypatch):
    """`python -m batchveh.size --executor gpus` with two 'GPU' names (this process and one worker process, MuJoCo
    C) on 6 of the 60-80 kg robot's conditions, against the same command in this process: the choices, the loop's
    table and every row of verdicts.parquet equal, and each of its sweeps (the servo's, the loop's) started the
    executor."""
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", ",".join(NAMES))
    _, started = size_here_and_on(tmp_path, monkeypatch, "gpus", ["--executor", "gpus"], (gpus.GpuProcesses, "start"))
    assert len(started) >= 2, started  # the servo sweep and the loop's run(s)
