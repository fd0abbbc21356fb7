"""Reliability (issue 14): each finding reproduced as a test that failed on the code before the fix.

No silent wrong numbers, no tracebacks where one line was promised, bounded memory for huge
sweeps, corrupt parts detected, one writer per result folder. All on MuJoCo C (fast).
"""

import os
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest
import yaml

import batchveh
from batchveh.sweep import main, run_sweep
from batchveh.sweeping.results import ResultFolder
from batchveh.sweeping.spec import load_spec


def _spec(tmp_path, name="r", **over):
    raw = {
        "name": name,
        "scenario": "straight_line",
        "fixed": {"total_time": 1.0, "ramp_time": 0.5},
        "sweep": {"method": "grid", "params": {"slope_deg": [0, 5, 10, 15]}},
        "output": str(tmp_path / name),
    }
    raw.update(over)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def _one_line(capsys, argv, code):
    try:
        got = main(argv)
    except SystemExit as exc:  # argparse's own errors exit from parse_args
        got = exc.code
    err = capsys.readouterr().err.strip()
    assert got == code and len(err.splitlines()) == 1 and "Traceback" not in err, (got, err)
    return err


# --- 1. statistics that cannot be valid are refused before any work --------------------------------


@pytest.mark.parametrize(
    "fixed, window, expect",
    [
        ({"total_time": 1.0}, [4, 10], ["window", "[4, 10]", "total_time (1 s)"]),  # was: every row ok, peak inf
        ({"total_time": 0.001, "time_step": 0.005}, None, ["time_step", "exceeds total_time"]),  # was: IndexError
        ({"total_time": 1.0}, [0.99, 1.0], ["window", "holds 3 steps", "at least 5"]),
    ],
)
def test_invalid_windows_and_runs_are_refused_before_work(tmp_path, capsys, fixed, window, expect):
    path = _spec(tmp_path, fixed=fixed, **({"window": window} if window else {}))
    for argv in ([str(path), "--dry-run"], [str(path), "--quiet", "--backend", "mujoco"]):
        err = _one_line(capsys, argv, 2)
        assert str(path) in err
        for part in expect:
            assert part in err, (part, err)
    assert not (tmp_path / "r").exists()  # no work, no folder


# --- 2. divergence reported by the MuJoCo C engine --------------------------------------------------


def test_mujoco_c_reports_divergence_and_never_inf_under_ok(tmp_path, capfd):
    # 55 and 60 deg, mu 0.9, 50 km/h, 500 kg payload: the vehicle tumbles and MuJoCo finds a huge
    # qacc at about 5 s (it printed "WARNING: Nan, Inf or huge value in QACC" and the run was
    # reported flipped, since MuJoCo resets such a simulation); 10 deg climbs normally
    path = _spec(
        tmp_path,
        fixed={"total_time": 10.0, "friction": 0.9, "speed_kmh": 50.0, "payload.mass": 500.0},
        sweep={"method": "grid", "params": {"slope_deg": [10, 55, 60]}},
        vehicle={"tyre": {"model": "rigid"}},  # the slip tyre slides down these without diverging
    )
    summary = run_sweep(load_spec(path), backend="mujoco", progress=False)
    df = batchveh.load(tmp_path / "r")
    assert list(df.status) == ["ok", "diverged", "diverged"], list(df.status)
    assert summary["diverged"] == 2 and "QACC" in summary["engine_warnings"][0]
    assert "WARNING" not in capfd.readouterr().out  # MuJoCo's message became data, not output
    stat_cols = [c for c in df.columns if c.startswith(("drive", "steer"))]
    assert np.isfinite(df.loc[df.status == "ok", stat_cols].to_numpy()).all()


def test_a_variant_mujoco_resets_is_diverged_not_ok(tmp_path):
    """A servo gain of 1e12 makes MuJoCo find a huge qacc at the first step of a linear ramp (its speed
    kinks at t = 0; the settle before it holds the speeds at 0 and passes) and reset the simulation,
    which then sits still: finite, not flipped. It must not pass as ok. (With the default smooth_step,
    whose speed starts without a kink, the vehicle tumbles for 8 steps before MuJoCo resets it: diverged
    too, but flipped first.)"""
    path = _spec(
        tmp_path,
        scenario={"kind": "straight_line", "drive_law": "ramp"},
        sweep={"method": "zip", "params": {"motors.drive_kv": [500, 1e12], "slope_deg": [5, 5]}},
    )
    run_sweep(load_spec(path), backend="mujoco", progress=False)
    df = batchveh.load(tmp_path / "r")
    assert list(df.status) == ["ok", "diverged"], list(df.status)
    assert df.max_roll_deg[1] < 1.0  # it did not flip


def test_statistics_of_a_huge_state_are_diverged():
    """A state that is finite but absurd (MuJoCo's mjMAXVAL idea) is diverged, not ok."""
    from batchveh.stepping import stats

    cfg = stats.StatsConfig.make(0.01, 20)
    acc = stats.init(cfg, (2,))
    for i in range(20):
        s = {
            "tau": np.ones((2, 1, 8)),
            "omega": np.ones((2, 1, 4)),
            "rim": np.ones((2, 1)),
            "alpha": np.zeros((2, 1, 4)),
            "ref": np.ones((2, 1, 8)),
            "pos": np.zeros((2, 1, 3)),
            "quat": np.tile([1.0, 0, 0, 0], (2, 1, 1)),
            "vel": np.zeros((2, 1, 3)),
        }
        s["vel"][1, 0, 0] = 1e6 if i == 15 else 0.0  # 1000 km/s, finite
        acc = stats.update(acc, s, np.array([i]), cfg)
    out = stats.finalize(acc, cfg)
    assert [stats.STATUS[int(c)] for c in out["status_code"]] == ["ok", "diverged"]


# --- 3. a billion variants: counted, refused or dry-run without being built -------------------------


def test_huge_grid_is_counted_lazily_and_refused_in_one_line(tmp_path, capsys):
    values = {"start": 0.0, "stop": 10.0, "num": 1000}
    sweep = {"method": "grid", "params": {"slope_deg": values, "speed_kmh": values, "payload.mass": values}}
    path = _spec(tmp_path, sweep=sweep)
    tracemalloc.start()
    err = _one_line(capsys, [str(path), "--dry-run"], 2)
    assert "1,000,000,000 variants exceed the limit" in err and "--max-variants" in err
    assert main([str(path), "--dry-run", "--max-variants", str(10**9)]) == 0
    out = capsys.readouterr().out
    assert "1,000,000,000 variants" in out
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 50e6, peak  # the old code built all 1e9 rows (it died with MemoryError at 8 GB)
    # any chunk is built alone and equals the same rows of the whole table (here: the last ones)
    table = load_spec(path).table()
    rows = table.rows(10**9 - 3, 10**9)
    assert list(rows.variant) == [10**9 - 3, 10**9 - 2, 10**9 - 1]
    np.testing.assert_allclose(rows["payload.mass"], [9.97997998, 9.98998999, 10.0])
    assert (rows.slope_deg == 10.0).all() and (rows.speed_kmh == 10.0).all()


def test_random_and_lhs_rows_do_not_depend_on_chunking(tmp_path):
    for method in ("random", "lhs"):
        sweep = {"method": method, "n": 70000, "seed": 4, "params": {"friction": {"low": 0.2, "high": 1.0}}}
        table = load_spec(_spec(tmp_path, method, sweep=sweep)).table()
        whole = table.rows()
        parts = [table.rows(a, a + 9999) for a in range(0, 70000, 9999)]
        np.testing.assert_array_equal(np.concatenate([p.friction for p in parts]), whole.friction)
        if method == "lhs":  # one sample in each of n strata
            strata = np.floor((whole.friction.to_numpy() - 0.2) / 0.8 * 70000).astype(int)
            assert len(set(strata)) == 70000


# --- 4. corrupt part files ---------------------------------------------------------------------------


def test_truncated_part_is_named_by_load_and_rerun_by_resume(tmp_path, capsys):
    path = _spec(tmp_path)
    argv = [str(path), "--backend", "mujoco", "--chunk-size", "1", "--quiet"]
    assert main(argv) == 0
    full = batchveh.load(tmp_path / "r")
    part = tmp_path / "r" / "part-00002.parquet"
    part.write_bytes(part.read_bytes()[:200])  # truncated: it was counted as finished before
    with pytest.raises(batchveh.ResultError, match=r"part-00002.parquet: .*truncated.*--resume"):
        batchveh.load(tmp_path / "r")
    capsys.readouterr()
    assert main([*argv, "--resume"]) == 0
    assert "part-00002.parquet" in capsys.readouterr().err  # a note names the part that runs again
    assert batchveh.load(tmp_path / "r").equals(full)


def test_a_uri_output_is_written_checked_and_resumed_through_pyarrow_fs(tmp_path, capsys):
    """Issue 13: an output URI (file:// here; s3:// goes the same way through pyarrow.fs) behaves as a path."""
    path = _spec(tmp_path)
    uri = (tmp_path / "u").as_uri()
    argv = [str(path), "--backend", "mujoco", "--chunk-size", "1", "--quiet"]
    assert main([*argv, "--out", str(tmp_path / "p")]) == 0
    assert main([*argv, "--out", uri]) == 0
    assert main([*argv, "--out", uri]) == 3  # results there: never overwritten silently
    assert batchveh.load(uri).equals(batchveh.load(tmp_path / "p"))
    part = tmp_path / "u" / "part-00001.parquet"
    part.write_bytes(part.read_bytes()[:200])
    with pytest.raises(batchveh.ResultError, match=f"{uri}/part-00001.parquet: .*truncated"):
        batchveh.load(uri)
    capsys.readouterr()
    assert main([*argv, "--out", uri, "--resume"]) == 0
    assert f"{uri}/part-00001.parquet" in capsys.readouterr().err
    assert batchveh.load(uri).equals(batchveh.load(tmp_path / "p"))


# --- 5. YAML 1.2 numbers ------------------------------------------------------------------------------


def test_yaml_exponent_numbers_are_numbers(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(
        "name: e\nvehicle: {chassis: {mass: 1.0e2}}\nfixed: {total_time: 1e0}\n"
        "sweep: {params: {payload.mass: [1e1, 2E1]}}\n"
    )
    spec = load_spec(path)  # was: "'1.0e2' is not a number"
    assert spec.vehicle.chassis.mass == 100.0 and spec.scenario.total_time == 1.0
    np.testing.assert_array_equal(spec.params["payload.mass"], [10.0, 20.0])


# --- 6 and 7. one line for every failure path, and messages that name what differs ------------------


def test_output_problems_are_one_line(tmp_path, capsys):
    path = _spec(tmp_path)
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    err = _one_line(capsys, [str(path), "--out", str(a_file), "--quiet"], 2)  # was: [Errno 17] File exists
    assert str(a_file) in err and "not a folder" in err
    err = _one_line(capsys, [str(path), "--out", str(a_file / "sub"), "--quiet"], 2)  # was: a traceback
    assert "a_file" in err
    _one_line(capsys, [str(path), "--chunk-size", "0"], 2)  # was: silently automatic
    _one_line(capsys, [str(path), "--limit", "-3"], 2)


def test_resume_names_the_setting_that_differs(tmp_path, capsys):
    path = _spec(tmp_path)
    argv = [str(path), "--backend", "mujoco", "--quiet"]
    assert main([*argv, "--limit", "2"]) == 0
    err = _one_line(capsys, [*argv, "--limit", "3", "--resume"], 2)
    assert "n_variants (2, now 3)" in err
    err = _one_line(capsys, [*argv, "--limit", "2", "--chunk-size", "1", "--resume"], 2)
    assert "chunk_size (2, now 1)" in err  # a sweep smaller than a chunk is one chunk of its own size


def test_empty_file_and_unit_messages(tmp_path, capsys):
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    err = _one_line(capsys, [str(empty)], 2)
    assert "the file is empty" in err  # was: "name: None is not allowed"
    path = _spec(tmp_path, fixed={"friction": 0})
    err = _one_line(capsys, [str(path)], 2)
    assert "allowed: > 0" in err and "> 0 1" not in err  # the unit "1" read as a number


def test_render_bad_flags_and_missing_opengl_are_one_line(tmp_path):
    def render(*args, env=None):
        out = subprocess.run(
            [sys.executable, "-m", "batchveh.render", "straight_line", *args],
            capture_output=True,
            text=True,
            timeout=300,
            env={**os.environ, **(env or {})},
        )
        lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
        assert out.returncode == 2 and len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
        return lines[0]

    gif = str(tmp_path / "x.gif")
    assert "--fps" in render("--fps", "0", "--out", gif)
    assert "--size" in render("--size", "0", "0", "--out", gif)
    assert "slope_deg" in render("--slope-deg", "95", "--total-time", "0.1", "--out", gif)
    # MUJOCO_GL naming a library that is not there: `import mujoco` itself died in PyOpenGL
    if __import__("ctypes.util").util.find_library("OSMesa") is None:
        err = render("--still", "--out", str(tmp_path / "x.png"), env={"MUJOCO_GL": "osmesa"})
        assert "no OpenGL" in err and "libOSMesa is not installed" in err


# --- 8. one writer per folder -------------------------------------------------------------------------


def test_second_writer_is_refused_with_the_holder(tmp_path, capsys):
    path = _spec(tmp_path)
    with ResultFolder(tmp_path / "r").lock():  # as a running sweep holds it
        err = _one_line(capsys, [str(path), "--backend", "mujoco", "--quiet", "--resume"], 3)
    assert f"pid {os.getpid()}" in err and "being written" in err
    assert main([str(path), "--backend", "mujoco", "--quiet"]) == 0  # released with its holder


# --- 9. estimates for the backend and device that will run --------------------------------------------


def test_dry_run_estimates_for_the_device_it_will_run_on(tmp_path, capsys):
    """The estimate names the device and its unit; how close it is to a real sweep's wall time is held within
    2x on MuJoCo C by tests/test_sensitivity.py::test_dry_run_estimate_is_within_2x_of_the_wall (the sweep
    it times runs there anyway)."""
    sweep = {"method": "grid", "params": {"slope_deg": {"start": 0, "stop": 30, "num": 1000}}}
    path = _spec(tmp_path, fixed={"total_time": 10.0}, sweep=sweep)
    assert main([str(path), "--dry-run", "--backend", "mjx"]) == 0
    out = capsys.readouterr().out
    from batchveh.engines import has_gpu

    if not has_gpu():
        # 1000 x 2000 steps at the CPU rate of MJX (5e3 per core): minutes, not "about 0 s"
        assert "CPU cores" in out and " min" in out, out


def test_a_chunk_simulated_is_written_and_recorded_even_when_the_next_one_fails(tmp_path, monkeypatch):
    """The pipeline writes a chunk on its own thread while the engine runs the next (`chunks.Pipeline`): an
    error in the next chunk, or a failed write, stops the sweep, but never loses a chunk already simulated."""
    import time

    from conftest import sweep_spec

    from batchveh.sweeping.chunks import ChunkRunner

    runner = ChunkRunner(load_spec(sweep_spec(tmp_path)), "mujoco", 8, 2)
    (tmp_path / "out").mkdir()
    folder = ResultFolder(tmp_path / "out")
    write, finish = folder.write_file, runner.finish

    def slow_write(c, table):  # chunk 1 is still being written when chunk 2 raises
        time.sleep(0.5 if c == 1 else 0.0)
        if c == 3:
            raise OSError("disk full")
        return write(c, table)

    def failing(prepared):
        if prepared[0] == 2:
            raise RuntimeError("chunk 2 broke")
        return finish(prepared)

    monkeypatch.setattr(folder, "write_file", slow_write)
    monkeypatch.setattr(runner, "finish", failing)
    written = []
    with pytest.raises(RuntimeError, match="chunk 2 broke"):
        runner.run_here([0, 1, 2, 3], folder, lambda c, name, rec: written.append((c, name, rec["rows"])))
    assert written == [(0, "part-00000.parquet", 2), (1, "part-00001.parquet", 2)]
    written.clear()
    with pytest.raises(OSError, match="disk full"):  # the last chunk's write fails: raised at the end
        runner.run_here([3], folder, lambda c, name, rec: written.append(c))
    assert written == []
    with pytest.raises(OSError, match="disk full"):  # or at the next chunk's start
        runner.run_here([3, 0, 1], folder, lambda c, name, rec: written.append(c))
    assert 3 not in written
