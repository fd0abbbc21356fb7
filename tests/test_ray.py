"""Sweeps on Ray (issues 13 and 33), on a local Ray instance with 2 CPUs and MuJoCo C (float64, so the
in-process sweep of the same spec is the exact reference): equal results, a worker killed by its
process id, the driver killed with SIGKILL then --resume, a chunk that keeps failing, bad input; and
one host shared by this process and Ray workers (what a local GPU sweep does): equal results, each
chunk recorded once after a worker is killed, a one-chunk sweep without Ray, the chunk sizes.

One Ray instance serves the module; each sweep starts its own workers (about 5 s on 2 cores).
"""

import functools
import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections import Counter

import pandas as pd
import pytest
import ray
from conftest import size_here_and_on
from conftest import sweep_spec as _spec

import batchveh
from batchveh.sweep import main, run_sweep
from batchveh.sweeping import cluster
from batchveh.sweeping.results import ResultFolder
from batchveh.sweeping.spec import load_spec

pytestmark = pytest.mark.xdist_group("ray")  # one test worker: one local Ray instance for the module

# 64 variants of 1,100 steps (0.5 s settle, 5 s at 5 ms): a chunk of 8 takes about 0.2 s on one thread,
# so a kill right after the first part lands while most chunks are still to run
BIG = {
    "fixed": {"total_time": 5.0, "ramp_time": 0.5},
    "sweep": {"method": "grid", "params": {"slope_deg": [0, 2, 4, 6, 8, 10, 12, 14], "friction": [0.3, 0.9] * 4}},
}


def test_one_chunk_on_a_shared_host_runs_here_without_ray(tmp_path):
    """connect() with no address only arranges a local instance; a sweep of one chunk never starts it.
    (First in the module: the module's Ray instance is not up yet.)"""
    assert not ray.is_initialized()
    path = _spec(tmp_path)
    expect = _reference(tmp_path, path, chunk_size=8)
    assert cluster.connect() is True and not ray.is_initialized()
    try:
        ex = cluster.RayExecutor(driver_works=True)
        s = run_sweep(load_spec(path), out=tmp_path / "solo", chunk_size=8, progress=False, executor=ex)
        assert not ray.is_initialized() and not ex.actors
    finally:
        cluster.disconnect()
    assert s["device"].endswith("in this process alone (one chunk); Ray not started"), s["device"]
    pd.testing.assert_frame_equal(batchveh.load(tmp_path / "solo"), expect)


def test_shared_chunk_sizes():
    # one host's GPUs: equal chunks of at least 65,536 variants, up to 5 per GPU, none over the largest
    assert cluster.shared_chunk(100_000, 2) == 100_096  # one chunk: this process alone
    assert cluster.shared_chunk(1_000_000, 2) == 100_096  # 10 chunks: 5 per GPU
    assert -(-1_000_000 // 100_096) == 10
    assert cluster.shared_chunk(10_000_000, 8) == 130_048  # 77 chunks, under the largest
    assert cluster.shared_chunk(200_000, 2) == 66_816  # 3 chunks


def test_alone_below_what_ray_start_saves():
    # a local GPU sweep runs without Ray where a second GPU would not save more than Ray's start costs
    assert cluster.alone_reason(1_000_000, 2100, "warp", gpus=1) == "one GPU"
    assert cluster.alone_reason(1_000_000, 2100, "warp", gpus=2, chunk=1_000_000) == "one chunk"
    assert "of simulation on one GPU" in cluster.alone_reason(100_000, 2100, "warp", gpus=2)  # about 11 s
    assert cluster.alone_reason(1_000_000, 2100, "warp", gpus=2) is None  # about 110 s: Ray's workers
    assert cluster.alone_reason(100_000, 2100, "mjx", gpus=2) is None  # MJX is 6x slower: worth it


def test_this_process_beside_workers_is_refused_on_warp(tmp_path, monkeypatch):
    monkeypatch.setenv("BATCHVEH_RAY_DRIVER", "1")
    ex = cluster.RayExecutor()
    with pytest.raises(batchveh.config.ConfigError, match="unknown stream"):
        ex.start(load_spec(_spec(tmp_path)), "warp", 8, 8, ResultFolder(tmp_path / "w"))


def test_worth_it():
    ex = cluster.RayExecutor()
    ex._chunk_s, ex._compile_s, ex._own = None, None, None
    assert ex.worth_it(warm=False, queued=1)  # nothing timed yet
    ex._chunk_s, ex._compile_s = 10.0, 4.0
    ex._own = (0, time.perf_counter())  # this process has just begun a chunk of 10 s
    assert ex.worth_it(warm=False, queued=1)  # 14 s on the worker against 20 s here
    ex._own = (0, time.perf_counter() - 7.0)  # 3 s left here: 13 s against 14 s on a cold worker
    assert not ex.worth_it(warm=False, queued=1)
    assert ex.worth_it(warm=True, queued=1)  # 10 s on a warm one


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray instance with 2 CPUs: 2 workers of one CPU slot each."""
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level=logging.ERROR)
    yield
    ray.shutdown()


def _reference(tmp_path, path, chunk_size):
    out = tmp_path / "reference"
    run_sweep(load_spec(path), out=out, chunk_size=chunk_size, progress=False)
    return batchveh.load(out)


@pytest.fixture(scope="module")
def big_reference(tmp_path_factory):
    """BIG swept in this process in chunks of 8, the exact reference of the four tests that sweep it on Ray:
    run once for the module (7 s on 2 cores)."""
    tmp = tmp_path_factory.mktemp("big")
    return _reference(tmp, _spec(tmp, **BIG), chunk_size=8)


def _parts(out):
    return sorted(p.name for p in out.glob("part-*.parquet"))


def test_ray_sweep_equals_the_in_process_one(tmp_path, local_ray):
    path = _spec(tmp_path)
    expect = _reference(tmp_path, path, chunk_size=2)
    ex = cluster.RayExecutor()
    uri = (tmp_path / "ray").as_uri()  # file://...: written and read through pyarrow.fs, as s3:// would be
    s = run_sweep(load_spec(path), out=uri, chunk_size=2, progress=False, executor=ex)
    assert s["rows"] == s["ran"] == 8 and not s["failed"], s
    # it ran on two Ray worker processes, not here
    assert s["device"].startswith("Ray, 2 workers on 1 node, each 1 CPU thread"), s["device"]
    pids = {w["pid"] for w in ex.workers_info}
    assert len(pids) == 2 and os.getpid() not in pids
    got = batchveh.load(uri)  # verifies every part against the manifest's checksums
    pd.testing.assert_frame_equal(got, expect)
    assert batchveh.load(tmp_path / "ray").equals(got)  # the same folder by its path
    assert _parts(tmp_path / "ray") == [f"part-0000{c}.parquet" for c in range(4)]
    assert not list((tmp_path / "ray").glob(".*.tmp"))
    assert batchveh.units(uri)["drive_lf_rms"] == "N m" and batchveh.metadata(uri)["device"].startswith("1 CPU")


# -m slow (15 s): a killed worker's chunk runs again, each chunk once, equal results: in the default run
# by test_shared_host_worker_killed (the shared-host dispatch; this one's, Ray workers only, is slow only)
@pytest.mark.slow
def test_worker_killed_mid_sweep_finishes_equal(tmp_path, local_ray, big_reference):
    path = _spec(tmp_path, **BIG)
    expect = big_reference
    out, ex, notes, killed = tmp_path / "killed", cluster.RayExecutor(), [], []

    def kill_one_worker():  # once the first part is written: the workers are busy with the next chunks
        deadline = time.time() + 120
        while not (ex.workers_info and _parts(out)) and time.time() < deadline:
            time.sleep(0.01)
        pid = ex.workers_info[0]["pid"]
        os.kill(pid, signal.SIGKILL)
        killed.append((pid, len(_parts(out))))

    killer = threading.Thread(target=kill_one_worker)
    killer.start()
    s = run_sweep(load_spec(path), out=out, chunk_size=8, progress=False, report=notes.append, executor=ex)
    killer.join()
    [(pid, parts_at_kill)] = killed
    assert parts_at_kill < 8, "killed after the sweep had finished"
    assert any("its Ray worker died; it runs again" in n for n in notes), notes
    assert s["rows"] == 64 and not s["failed"]
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)  # that worker is gone; Ray restarted it
    pd.testing.assert_frame_equal(batchveh.load(out), expect)
    # every chunk recorded once, nothing half-written left behind
    assert sorted(ResultFolder(out).read_manifest()["parts"]) == _parts(out) and len(_parts(out)) == 8
    assert not list(out.glob(".*.tmp"))


# -m slow (20 s): a driver killed then --resume: in the default run by test_sweep.py's
# test_resume_after_kill_equals_uninterrupted; --resume over parts Ray workers wrote by
# test_chunk_that_keeps_failing_is_named_and_the_rest_written
@pytest.mark.slow
def test_driver_killed_then_resume_equals_uninterrupted(tmp_path, local_ray, big_reference):
    path = _spec(tmp_path, **BIG)
    expect = big_reference
    out = tmp_path / "driver"
    argv = [str(path), "--chunk-size", "8", "--out", str(out), "--quiet", "--executor", "ray"]
    # a driver of its own on this module's cluster, joined by its address as on a real one; its workers die with it
    address = ray.get_runtime_context().gcs_address
    proc = subprocess.Popen(
        [sys.executable, "-m", "batchveh.sweep", *argv, "--address", address],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.time() + 180
    while not _parts(out) and time.time() < deadline and proc.poll() is None:
        time.sleep(0.01)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    kept = len(_parts(out))
    assert 1 <= kept < 8, kept  # killed halfway: some chunks written, not all
    assert main([*argv, "--resume"]) == 0  # a new driver, here
    pd.testing.assert_frame_equal(batchveh.load(out), expect)
    assert not list(out.glob(".*.tmp"))


@pytest.mark.slow
def test_chunk_that_keeps_failing_is_named_and_the_rest_written(tmp_path, local_ray, capsys, monkeypatch):
    path = _spec(tmp_path)
    expect = _reference(tmp_path, path, chunk_size=2)
    env = {"env_vars": {"BATCHVEH_FAIL_CHUNKS": "1"}}  # chunk 1 raises on every worker
    monkeypatch.setattr(cluster, "RayExecutor", functools.partial(cluster.RayExecutor, runtime_env=env))
    argv = [str(path), "--chunk-size", "2", "--quiet", "--executor", "ray"]
    assert main(argv) == 4
    err = capsys.readouterr().err
    assert "error: chunk 1 (part-00001.parquet) not written: failed 3 times" in err, err
    assert "injected fault" in err and err.count("it runs again") == 2, err
    out = tmp_path / "r"
    assert _parts(out) == ["part-00000.parquet", "part-00002.parquet", "part-00003.parquet"]
    partial = batchveh.load(out)
    pd.testing.assert_frame_equal(partial, expect[~expect.variant.isin([2, 3])].reset_index(drop=True))
    # --resume runs chunk 1 alone, here in this process: the parts the Ray workers wrote are kept
    assert main([str(path), "--chunk-size", "2", "--quiet", "--resume"]) == 0
    assert "(2 run now)" in capsys.readouterr().out
    pd.testing.assert_frame_equal(batchveh.load(out), expect)


def _one_line(capsys, argv):
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors exit from parse_args
        code = exc.code
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, (code, err)
    return err


def test_bad_executor_or_address_is_one_line(tmp_path, capsys, monkeypatch, local_ray):
    path = str(_spec(tmp_path))
    assert "'dask'" in _one_line(capsys, [path, "--executor", "dask"])
    assert "needs --executor ray" in _one_line(capsys, [path, "--address", "127.0.0.1:6379"])
    assert "'nonsense' is not allowed" in _one_line(capsys, [path, "--executor", "ray", "--address", "nonsense"])
    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    err = _one_line(capsys, [path, "--executor", "ray", "--address", f"127.0.0.1:{port}"])
    assert "no Ray cluster answers there" in err and "ray start --head" in err
    monkeypatch.setitem(sys.modules, "ray", None)  # as without ray installed
    err = _one_line(capsys, [path, "--executor", "ray"])
    assert "Ray is not installed" in err and "pip install -e '.[ray]'" in err
    assert not (tmp_path / "r").exists()  # nothing was started or written


def _shared_run(tmp_path, monkeypatch, big_reference, name, kill=False):
    """BIG on this process and one Ray worker (a shared host, as on GPUs, here on the CPU). This process
    runs its first chunk, then waits until the worker has built its engine (and, with `kill`, until the
    worker has been killed), so that the worker surely runs chunks."""
    from batchveh.sweeping.chunks import ChunkRunner

    path = _spec(tmp_path, **BIG)
    expect = big_reference
    out, ex, notes, killed = tmp_path / name, cluster.RayExecutor(workers=1, driver_works=True), [], []
    run, calls = ChunkRunner.run, []

    def slow_here(self, c):  # in this process only: the Ray worker imports its own ChunkRunner
        calls.append(c)
        if len(calls) == 2 and ex.starting:
            ray.wait(list(ex.starting), num_returns=len(ex.starting), timeout=120)
        deadline = time.time() + 120
        while kill and len(calls) > 2 and not killed and time.time() < deadline:
            time.sleep(0.01)
        return run(self, c)

    def kill_worker():  # once this process knows the worker's process id: it holds chunks then
        deadline = time.time() + 120
        while not ex.workers_info and time.time() < deadline:
            time.sleep(0.005)
        pid = ex.workers_info[0]["pid"]
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)

    monkeypatch.setattr(ChunkRunner, "run", slow_here)
    killer = threading.Thread(target=kill_worker)
    if kill:
        killer.start()
    s = run_sweep(load_spec(path), out=out, chunk_size=8, progress=False, report=notes.append, executor=ex)
    if kill:
        killer.join()
    assert s["rows"] == 64 and not s["failed"], s
    assert s["device"].startswith("this process and 1 Ray worker, each 1 CPU thread"), s["device"]
    pd.testing.assert_frame_equal(batchveh.load(out), expect)  # bit-identical to the in-process sweep
    # every chunk recorded once, nothing half-written left behind
    assert sorted(ResultFolder(out).read_manifest()["parts"]) == _parts(out) and len(_parts(out)) == 8
    assert not list(out.glob(".*.tmp"))
    ends = [e for e in ex.timeline if e["event"] == "chunk end"]
    return ends, notes, killed


def test_shared_host_equals_in_process(tmp_path, local_ray, monkeypatch, big_reference):
    ends, notes, _ = _shared_run(tmp_path, monkeypatch, big_reference, "shared")
    where = Counter(e["where"] for e in ends)
    assert where["driver"] >= 1 and where["worker 0"] >= 1, where  # both ran chunks
    assert sorted(e["chunk"] for e in ends) == list(range(8)) and not notes, notes


@pytest.mark.slow
def test_shared_host_worker_killed(tmp_path, local_ray, monkeypatch, big_reference):
    ends, notes, killed = _shared_run(tmp_path, monkeypatch, big_reference, "shared-killed", kill=True)
    [pid] = killed
    assert any("its Ray worker died; it runs again" in n for n in notes), notes
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    # the chunks the killed worker held ran again, here or on the restarted worker: each ended once
    assert sorted(e["chunk"] for e in ends) == list(range(8)), ends


# -m slow (33-94 s on 2 cores): the size command's Ray path end to end; its sweeps' Ray path is in the default run above
@pytest.mark.slow
def test_the_size_command_on_ray_gives_the_in_process_verdicts(tmp_path, local_ray, monkeypatch):
    """`python -m batchveh.size --executor ray` on 6 of the 60-80 kg robot's conditions (MuJoCo C, float64: the
    same rows on any executor) against the same command in this process: every row of verdicts.parquet, the
    choices and the loop's table equal; a second run resumes every sweep (no chunk run again)."""
    from batchveh.size import main as size

    argv, started = size_here_and_on(tmp_path, monkeypatch, "ray", ["--executor", "ray"],
                                     (cluster.RayExecutor, "_start_workers"))  # fmt: skip
    assert len(started) >= 2, started  # the servo sweep and the loop's run(s), each on Ray's workers
    parts = {p: p.stat().st_mtime_ns for p in (tmp_path / "ray").rglob("part-*.parquet")}
    assert parts  # the servo sweep's and the loop's chunks, written by Ray's workers
    assert size([*argv, "--overwrite"]) == 0
    assert {p: p.stat().st_mtime_ns for p in (tmp_path / "ray").rglob("part-*.parquet")} == parts
