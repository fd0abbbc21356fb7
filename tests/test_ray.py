"""Sweeps on Ray (issue 13), on a local Ray instance with 2 CPUs and MuJoCo C (float64, so the
in-process sweep of the same spec is the exact reference): equal results, a worker killed by its
process id, the driver killed with SIGKILL then --resume, a chunk that keeps failing, bad input.

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

import pandas as pd
import pytest
import ray
import yaml

import batchveh
from batchveh.sweep import main, run_sweep
from batchveh.sweeping import cluster
from batchveh.sweeping.results import ResultFolder
from batchveh.sweeping.spec import load_spec

# 64 variants of 1,100 steps (0.5 s settle, 5 s at 5 ms): a chunk of 8 takes about 0.2 s on one thread,
# so a kill right after the first part lands while most chunks are still to run
BIG = {
    "fixed": {"total_time": 5.0, "ramp_time": 0.5},
    "sweep": {"method": "grid", "params": {"slope_deg": [0, 2, 4, 6, 8, 10, 12, 14], "friction": [0.3, 0.9] * 4}},
}


def _spec(tmp_path, name="r", **over):
    raw = {
        "name": name,
        "scenario": "straight_line",
        "fixed": {"total_time": 1.0, "ramp_time": 0.5},
        "sweep": {"method": "grid", "params": {"slope_deg": [0, 5, 10, 15], "friction": [0.3, 0.9]}},
        "backend": "mujoco",
        "output": str(tmp_path / name),
    }
    raw.update(over)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


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


def test_worker_killed_mid_sweep_finishes_equal(tmp_path, local_ray):
    path = _spec(tmp_path, **BIG)
    expect = _reference(tmp_path, path, chunk_size=8)
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


def test_driver_killed_then_resume_equals_uninterrupted(tmp_path, local_ray):
    path = _spec(tmp_path, **BIG)
    expect = _reference(tmp_path, path, chunk_size=8)
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
