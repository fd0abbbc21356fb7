"""Sobol' sweeps and their indices (issue 23): the Saltelli sample, the estimators end to end against
closed forms (Ishigami; m g sin(s) r on steady climbs), non-ok rows, resume, --limit, Ray, bad input,
the output files and the plots. MuJoCo C, short runs.

Every expected index is a closed form computed here, never the code's own output; where the
estimate is compared with one, the tolerance is the estimate's own confidence interval (SALib's
bootstrap, 95 %), and the interval is required to be narrow enough for the check to mean something.
"""

import json
import logging
import math
import os
import re
import shutil
import time
import warnings

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml
from conftest import SLOPE_SUM_RTOL, slope_torque
from SALib.analyze import sobol as salib_sobol

import batchveh
from batchveh.analysis import plot
from batchveh.analysis.sensitivity import SensitivityWarning, write
from batchveh.sensitivity import main
from batchveh.sweep import main as sweep_main
from batchveh.sweep import run_sweep
from batchveh.sweeping.results import ResultFolder
from batchveh.sweeping.spec import load_spec, variant_table

pytestmark = pytest.mark.xdist_group("sensitivity")  # one test worker: the module's shared fixtures run once

CLIMB = {"total_time": 2.0, "ramp_time": 0.5}  # a 0.5 s ramp, the steady window 1..2 s: 500 steps in all
SLOPE = {"low": 2.0, "high": 15.0}  # deg
FRICTION = {"low": 0.6, "high": 1.0}  # tan(15 deg) = 0.27: nothing slips
PAYLOAD = {"low": 0.0, "high": 150.0}  # kg


def _spec(tmp_path, name, params, n, fixed=None, scenario="straight_line", seed=0):
    raw = {
        "name": name,
        "scenario": scenario,
        "fixed": fixed or {"total_time": 1.0, "ramp_time": 0.5},
        "sweep": {"method": "sobol", "n": n, "seed": seed, "params": params},
        "backend": "mujoco",
        "output": str(tmp_path / name),
    }
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def _run(path, out=None, **kw):
    out = out or load_spec(path).output
    run_sweep(load_spec(path), out=out, progress=False, **kw)
    return out


def _quiet_indices(result, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SensitivityWarning)
        return batchveh.sensitivity(result, *args, **kw)


def _index(table, stat, param, which):
    row = table[(table.statistic == stat) & (table.parameter == param)]
    assert len(row) == 1, (stat, param)
    return float(row[which].iloc[0]), float(row[f"{which}_conf"].iloc[0])


def _within_interval(table, stat, expect, max_conf):
    """Each index within its own confidence interval of the closed form, and that interval narrow."""
    for (param, which), value in expect.items():
        got, conf = _index(table, stat, param, which)
        assert conf <= max_conf, (param, which, got, conf)
        assert abs(got - value) <= conf, f"{which} of {param}: {got:.4f} +- {conf:.4f}, closed form {value:.4f}"


@pytest.fixture(scope="module")
def climb(tmp_path_factory):
    """Steady non-slipping climbs, slope x friction: N = 64 base points, 384 variants (about 8 s)."""
    tmp = tmp_path_factory.mktemp("climb")
    return _run(_spec(tmp, "climb", {"slope_deg": SLOPE, "friction": FRICTION}, 64, fixed=CLIMB))


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A small sobol spec (D = 2, N = 16: 96 variants of 300 steps) and its in-process result, in chunks of 16."""
    tmp = tmp_path_factory.mktemp("small")
    path = _spec(tmp, "small", {"slope_deg": {"low": 0.0, "high": 12.0}, "speed_kmh": {"low": 0.5, "high": 3.0}}, 16)
    return path, _run(path, out=tmp / "reference", chunk_size=16)


# --- the sample -------------------------------------------------------------------------------------------


def test_sobol_sample_counts_bounds_and_layout(tmp_path, capsys):
    params = {
        "slope_deg": SLOPE,
        "friction": {"low": 0.2, "high": 1.0, "log": True},
        "speed_kmh": {"low": 0.5, "high": 4.0},
    }
    path = _spec(tmp_path, "s", params, 32)
    assert sweep_main([str(path), "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "256 variants (Saltelli: N = 32 base points x (2D + 2) = 8 for D = 3)" in out, out  # 32 (2 x 3 + 2)
    table = variant_table(load_spec(path))
    assert len(table) == 256 and list(table.variant) == list(range(256))
    x = table[list(params)].to_numpy()
    assert (x[:, 0] >= 2).all() and (x[:, 0] <= 15).all() and (x[:, 1] >= 0.2).all() and (x[:, 1] <= 1).all()
    # log-uniform: log(friction) is spread evenly, so about half the base points lie below the geometric middle
    below = np.mean(table.friction[::8] < math.sqrt(0.2 * 1.0))
    assert 0.35 < below < 0.65, below
    # each block of 8: A, A with column j from B (3 rows), B with column j from A (3 rows), B
    blocks = x.reshape(32, 8, 3)
    a, b = blocks[:, 0], blocks[:, 7]
    for j in range(3):
        ab, ba = a.copy(), b.copy()
        ab[:, j], ba[:, j] = b[:, j], a[:, j]
        np.testing.assert_array_equal(blocks[:, 1 + j], ab)
        np.testing.assert_array_equal(blocks[:, 4 + j], ba)
    # the base points fill the cube evenly (a Sobol' sequence): each half of each range holds half of them
    u = (np.log(a[:, 1]) - np.log(0.2)) / (np.log(1.0) - np.log(0.2))
    assert np.sum(u < 0.5) == 16 and np.sum((a[:, 0] - 2) / 13 < 0.5) == 16
    # seeded, and any chunk equals the same rows of the whole table
    spec = load_spec(path)
    parts = [spec.table().rows(s, s + 37) for s in range(0, 256, 37)]
    pd.testing.assert_frame_equal(pd.concat(parts, ignore_index=True), table)
    other = variant_table(load_spec(_spec(tmp_path, "t", params, 32, seed=5)))
    assert not np.allclose(other.slope_deg, table.slope_deg)


# --- the estimators end to end ----------------------------------------------------------------------------


def test_ishigami_indices_within_their_intervals_of_the_closed_form(tmp_path):
    """The Ishigami function (a = 7, b = 0.1) of three swept parameters in [-pi, pi], as a derived statistic
    of a real sobol sweep: spec, sample, sweep, Parquet, analysis. The straight line reads none of the three
    (steer_deg, turn_radius, yaw_rate_dps), so the runs stay 10 steps long: 32,768 variants in about 10 s."""
    a, b, pi = 7.0, 0.1, math.pi
    names = ("steer_deg", "turn_radius", "yaw_rate_dps")
    params = {k: {"low": -pi, "high": pi} for k in names}
    scenario = {"kind": "straight_line", "settle_time": 0.0}
    out = _run(_spec(tmp_path, "ishigami", params, 4096, fixed={"total_time": 0.05}, scenario=scenario))

    def ishigami(frame):
        x1, x2, x3 = (frame[k].to_numpy() for k in names)
        return np.sin(x1) + a * np.sin(x2) ** 2 + b * x3**4 * np.sin(x1)

    table = _quiet_indices(out, "ishigami", derived={"ishigami": ishigami})
    # closed form (Ishigami and Homma 1990; Sobol' and Levitan 1999)
    v = a**2 / 8 + b * pi**4 / 5 + b**2 * pi**8 / 18 + 0.5
    v1, v2, v13 = 0.5 * (1 + b * pi**4 / 5) ** 2, a**2 / 8, 8 * b**2 * pi**8 / 225
    expect = {
        ("steer_deg", "S1"): v1 / v,  # 0.3139
        ("turn_radius", "S1"): v2 / v,  # 0.4424
        ("yaw_rate_dps", "S1"): 0.0,
        ("steer_deg", "ST"): (v1 + v13) / v,  # 0.5576
        ("turn_radius", "ST"): v2 / v,  # 0.4424
        ("yaw_rate_dps", "ST"): v13 / v,  # 0.2437
    }
    _within_interval(table, "ishigami", expect, max_conf=0.08)
    assert (table.base_points == 4096).all() and (table.statistic == "ishigami").all()


def test_friction_does_not_drive_a_steady_climb(climb, vehicle):
    """Slope and friction swept where nothing slips: the drive sum's mean is m g sin(s) r, friction plays no part."""
    df = batchveh.load(climb)
    assert (df.status == "ok").all() and not df.slipping.any() and df.steady.all()
    expect = [slope_torque(vehicle, s) for s in df.slope_deg]
    np.testing.assert_allclose(df.drive_sum_mean, expect, rtol=SLOPE_SUM_RTOL)
    with pytest.warns(SensitivityWarning, match="wider than the index"):  # friction's indices are ~0 +- ~0
        table = batchveh.sensitivity(climb, ["drive_sum_mean"])
    s1_slope, _ = _index(table, "drive_sum_mean", "slope_deg", "S1")
    st_friction, conf = _index(table, "drive_sum_mean", "friction", "ST")
    assert s1_slope > 0.95, s1_slope
    # resolved: friction's ST is below 0.02 with its whole interval, so slope explains the rest (with two
    # parameters S1(slope) = 1 - ST(friction)). S1's own bootstrap interval is wide at N = 64 (+-0.32
    # measured): the Saltelli 2010 S1 estimator's variance, mean(B (AB - A)), not the sample's error
    assert st_friction + conf < 0.02, (st_friction, conf)
    assert not table[table.parameter == "slope_deg"].ci_wide.any()


def _product_decomposition(m0, payload, slope_deg):
    """Closed-form variance decomposition of Y = (m0 + P) g r sin(s), P and s independent and uniform:
    Y = f(P) h(s), so V_P = Var f E[h]^2, V_s = E[f]^2 Var h, V_Ps = Var f Var h."""
    p0, p1 = payload
    s0, s1 = np.deg2rad(slope_deg)
    ef, vf = m0 + (p0 + p1) / 2, (p1 - p0) ** 2 / 12
    eh = (np.cos(s0) - np.cos(s1)) / (s1 - s0)
    eh2 = 0.5 - (np.sin(2 * s1) - np.sin(2 * s0)) / (4 * (s1 - s0))
    vh = eh2 - eh**2
    v_p, v_s, v_ps = vf * eh**2, ef**2 * vh, vf * vh
    v = v_p + v_s + v_ps
    # the same by Gauss-Legendre quadrature of the closed form: the moments of f and h
    x, w = np.polynomial.legendre.leggauss(40)
    s = (s0 + s1) / 2 + (s1 - s0) / 2 * x
    p = (p0 + p1) / 2 + (p1 - p0) / 2 * x
    q_eh, q_eh2 = np.sum(w * np.sin(s)) / 2, np.sum(w * np.sin(s) ** 2) / 2
    q_ef, q_ef2 = np.sum(w * (m0 + p)) / 2, np.sum(w * (m0 + p) ** 2) / 2
    q_v = q_ef2 * q_eh2 - (q_ef * q_eh) ** 2
    np.testing.assert_allclose([q_eh, q_eh2, q_ef, q_ef2 - q_ef**2, q_v], [eh, eh2, ef, vf, v], rtol=1e-12)
    return {
        ("slope_deg", "S1"): v_s / v,  # 0.806
        ("slope_deg", "ST"): (v_s + v_ps) / v,  # 0.837
        ("payload.mass", "S1"): v_p / v,  # 0.163
        ("payload.mass", "ST"): (v_p + v_ps) / v,  # 0.194
    }


PAYLOAD_PARAMS = {"slope_deg": SLOPE, "friction": FRICTION, "payload.mass": PAYLOAD}
# The indices of the simulated drive sum against SALib's on the closed form m g sin(s) r at the same sample
# points: the sampling error is the same in both, so only the model's departure from the closed form is left
# (the contact's lever loss, -2.8e-3 to -3.9e-3 of the sum, varies with slope). Measured 1.0e-5 at most (slope's
# S1) at N = 256 on the project's 2-core machine; payload's S1 and ST differ by 0.045 at those points, slope's by
# 0.016, so a swap of the two fails
SAME_POINTS_ATOL = 5e-5
# The dry run's time estimate against the wall time of the sweep it estimates, on MuJoCo C (the CPU): the
# issue's factor of 2 either way. Measured 9 s estimated against 7-11 s of wall (ratios 0.8-1.2) on the project's
# 2-core machine with little else running; with other sessions' tests on its two cores the same sweep took 14-23 s
# of wall (and 16-17 CPU s). The wall it would take alone lies between the measured wall and the wall less
# the other processes' CPU seconds over the cores (all of them taken from it): the estimate must be within 2x of
# a value in that range, the check itself where nothing else ran
DRY_RUN_FACTOR = 2.0


def _busy_cpu_s():
    """CPU seconds the whole machine has been busy (/proc/stat), or None where there is no /proc/stat."""
    try:
        with open("/proc/stat") as f:
            ticks = [int(x) for x in f.readline().split()[1:9]]
    except (OSError, ValueError):
        return None
    return (sum(ticks) - ticks[3] - ticks[4]) / os.sysconf("SC_CLK_TCK")  # less idle and iowait


def _payload(tmp, n):
    """The slope x friction x payload sweep at N base points: (result, spec path, wall time in s, the wall
    less the time other processes held the machine's cores during it: their CPU seconds over the cores)."""
    path = _spec(tmp, "payload", PAYLOAD_PARAMS, n, fixed=CLIMB)
    busy0, own0, t0 = _busy_cpu_s(), time.process_time(), time.perf_counter()
    out = _run(path)
    wall, own, busy1 = time.perf_counter() - t0, time.process_time() - own0, _busy_cpu_s()
    others = 0.0 if busy0 is None or busy1 is None else max(0.0, busy1 - busy0 - own)
    return out, path, wall, wall - others / (os.cpu_count() or 1)


@pytest.fixture(scope="module")
def payload256(tmp_path_factory):
    """N = 256: 2,048 climbs of 500 steps, about 11 s on 2 cores."""
    return _payload(tmp_path_factory.mktemp("payload"), 256)


@pytest.mark.parametrize(
    "n, max_conf",
    [pytest.param(256, 0.2, marks=pytest.mark.slow), pytest.param(1024, 0.1, marks=pytest.mark.slow)],
    ids=["N256", "N1024"],
)
def test_slope_and_payload_match_the_closed_form_decomposition(request, tmp_path, vehicle, n, max_conf):
    """With payload mass swept as well (N = 256: 2,048 climbs, about 11 s; slow: N = 1024, 8,192 climbs, with
    intervals half as wide), the indices of slope and mass are those of m g sin(s) r's variance decomposition,
    within their confidence intervals; and, at the same sample points, SALib's indices of the closed form's
    values, within SAME_POINTS_ATOL (tight enough to tell S1 from ST)."""
    out, path, *_ = request.getfixturevalue("payload256") if n == 256 else _payload(tmp_path, n)
    df = batchveh.load(out)
    assert (df.status == "ok").all() and not df.slipping.any() and df.steady.all()
    table = _quiet_indices(out, "drive_sum_mean")
    expect = _product_decomposition(vehicle.total_mass, (0.0, 150.0), (2.0, 15.0))
    _within_interval(table, "drive_sum_mean", expect, max_conf=max_conf)
    assert _index(table, "drive_sum_mean", "friction", "ST")[0] < 0.02
    # the closed form at the sweep's own sample points (the spec's table, not the results), through SALib
    points = variant_table(load_spec(path))
    assert list(points.variant) == list(df.variant)
    s = np.deg2rad(points.slope_deg.to_numpy())
    y = (vehicle.total_mass + points["payload.mass"].to_numpy()) * 9.81 * np.sin(s) * vehicle.wheel.radius
    names = list(PAYLOAD_PARAMS)
    problem = {"num_vars": len(names), "names": names, "bounds": [[0, 1]] * len(names)}
    closed = salib_sobol.analyze(problem, y, calc_second_order=True, num_resamples=100, seed=1)
    assert closed["ST"][1] == 0.0 and abs(closed["S1"][1]) < 1e-6  # the closed form has no friction in it
    for j, param in enumerate(names):
        for which in ("S1", "ST"):
            got = _index(table, "drive_sum_mean", param, which)[0]
            assert abs(got - closed[which][j]) <= SAME_POINTS_ATOL, (param, which, got, closed[which][j])


def _seconds(text):
    """The dry run's "about 9 s" / "about 3 min" / "about 1.5 h", in s."""
    value, unit = re.search(r"; about ([0-9.]+) (s|min|h) \(", text).groups()
    return float(value) * {"s": 1, "min": 60, "h": 3600}[unit]


@pytest.mark.slow  # a check on wall time: beside another test worker the sweep's wall is not its own
def test_dry_run_estimate_is_within_2x_of_the_wall(payload256, capsys):
    """The dry run of the N = 256 payload sweep (MuJoCo C, on the CPU) estimates its time within a factor
    of 2 of the wall time that sweep took (the issue's; the GPU's estimate is not checked here). The estimate
    is for the sweep alone: where other processes used the cores meanwhile, its lower limit is half the wall
    less their CPU seconds over the cores."""
    _, path, wall, alone = payload256
    assert sweep_main([str(path), "--dry-run"]) == 0
    text = capsys.readouterr().out
    assert "2,048 variants" in text and "mujoco on" in text, text
    estimate = _seconds(text)
    print(f"dry run: {estimate:.0f} s estimated, {wall:.1f} s of wall, {alone:.1f} s less other processes' share")
    assert alone / DRY_RUN_FACTOR <= estimate <= wall * DRY_RUN_FACTOR, (estimate, wall, alone, text)


# --- rows not ok ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def diverging(tmp_path_factory):
    """Steering gains up to 1e5 at a 20 ms step: the stiffer ones diverge (status diverged, statistics NaN).
    With the slip tyre every variant above 3.7e4 diverged and none below 3.4e4 (192 variants)."""
    tmp = tmp_path_factory.mktemp("diverging")
    params = {"motors.steer_kp": {"low": 1e3, "high": 1e5, "log": True}, "slope_deg": {"low": 0.0, "high": 10.0}}
    fixed = {"total_time": 1.0, "ramp_time": 0.5, "time_step": 0.02}
    return _run(_spec(tmp, "diverging", params, 32, fixed=fixed))


def test_rows_not_ok_are_dropped_kept_or_refused_and_reported(diverging, capsys):
    df = batchveh.load(diverging)
    bad = df.status != "ok"
    assert 0 < bad.sum() < len(df) / 2, df.status.value_counts()  # the case this test is about
    by_block = (~bad).groupby(df.variant // 6).all()  # a base point is ok where its 6 rows are
    with pytest.warns(SensitivityWarning) as record:
        dropped = batchveh.sensitivity(diverging, "drive_sum_mean")
    said = " ".join(str(w.message) for w in record)
    assert f"{bad.sum()} of {len(df)} rows" in said and f"the {(~by_block).sum()} base points" in said, said
    meta = dropped.attrs["sensitivity"]
    assert meta["base_points_used"] == by_block.sum() and meta["status"]["ok"] == (~bad).sum()
    assert meta["non_ok"] == "drop" and (dropped.base_points == by_block.sum()).all()
    # the indices are SALib's on exactly the ok base points
    y = df.drive_sum_mean.to_numpy().reshape(32, 6)[by_block.to_numpy()].ravel()
    problem = {"num_vars": 2, "names": ["motors.steer_kp", "slope_deg"], "bounds": [[0, 1]] * 2}
    direct = salib_sobol.analyze(problem, y, num_resamples=100, seed=1)
    np.testing.assert_allclose(dropped.S1, direct["S1"], rtol=1e-12)
    np.testing.assert_allclose(dropped.ST_conf, direct["ST_conf"], rtol=1e-12)
    # keep: every row's status is accepted, yet a diverged row's NaN still leaves its base point out
    kept = _quiet_indices(diverging, "drive_sum_mean", non_ok="keep")
    finite = np.isfinite(df.drive_sum_mean).groupby(df.variant // 6).all()
    assert kept.attrs["sensitivity"]["base_points_used"] == 32 and (kept.base_points == finite.sum()).all()
    # refuse: one line naming the folder, the count and what is allowed
    with pytest.raises(batchveh.ConfigError, match=rf"{bad.sum()} of {len(df)} rows are not ok.*allowed: non_ok"):
        batchveh.sensitivity(diverging, non_ok="refuse")
    assert main([str(diverging), "--non-ok", "refuse", "--out", str(diverging) + "-x"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err and str(diverging) in err


# --- resume, --limit, Ray ---------------------------------------------------------------------------------


def test_resumed_sobol_sweep_gives_identical_indices(small, tmp_path, capsys):
    path, reference = small
    out = tmp_path / "resumed"
    argv = [str(path), "--chunk-size", "16", "--out", str(out), "--quiet"]
    assert sweep_main(argv) == 0
    for name in ("part-00001.parquet", "part-00004.parquet"):  # two chunks lost, as by a kill before they were written
        (out / name).unlink()
    capsys.readouterr()
    assert sweep_main([*argv, "--resume"]) == 0
    assert "(32 run now)" in capsys.readouterr().out
    pd.testing.assert_frame_equal(batchveh.load(out), batchveh.load(reference))
    _assert_same_indices(_quiet_indices(out), _quiet_indices(reference))


def _assert_same_indices(got, expect):
    """Equal to the last bit, and the same metadata but for the folder's name."""
    pd.testing.assert_frame_equal(got, expect, check_exact=True)
    drop = lambda t: {k: v for k, v in t.attrs["sensitivity"].items() if k not in ("result", "warnings")}  # noqa: E731
    assert drop(got) == drop(expect)


def test_limit_runs_the_first_variants_and_the_analysis_takes_the_complete_blocks(small, tmp_path):
    path, reference = small
    out = tmp_path / "limited"
    assert sweep_main([str(path), "--limit", "33", "--out", str(out), "--quiet"]) == 0  # 5 blocks of 6, and 3 rows
    full, part = batchveh.load(reference), batchveh.load(out)
    pd.testing.assert_frame_equal(part, full.iloc[:33])
    with pytest.warns(SensitivityWarning, match="63 of 96 variants are missing.*11 of 16 base points are incomplete"):
        table = batchveh.sensitivity(out, ["drive_sum_mean"])
    assert (table.base_points == 5).all() and table.attrs["sensitivity"]["missing_rows"] == 63
    problem = {"num_vars": 2, "names": ["slope_deg", "speed_kmh"], "bounds": [[0, 1]] * 2}
    direct = salib_sobol.analyze(problem, full.drive_sum_mean.to_numpy()[:30], num_resamples=100, seed=1)
    np.testing.assert_allclose(table.S1, direct["S1"], rtol=1e-12)
    np.testing.assert_allclose(table.ST, direct["ST"], rtol=1e-12)


@pytest.fixture
def local_ray():
    ray = pytest.importorskip("ray")
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level=logging.ERROR)
    yield
    ray.shutdown()


@pytest.mark.slow  # 19 s beside another test worker; Ray itself is in the default run (test_ray.py)
def test_ray_sobol_sweep_equals_the_in_process_one(small, tmp_path, local_ray):
    from batchveh.sweeping import cluster

    path, reference = small
    out = tmp_path / "ray"
    s = run_sweep(load_spec(path), out=out, chunk_size=16, progress=False, executor=cluster.RayExecutor())
    assert s["rows"] == 96 and not s["failed"] and s["device"].startswith("Ray, 2 workers"), s
    pd.testing.assert_frame_equal(batchveh.load(out), batchveh.load(reference))
    _assert_same_indices(_quiet_indices(out), _quiet_indices(reference))


# --- bad input --------------------------------------------------------------------------------------------


def _one_line(capsys, run, argv):
    try:
        code = run(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and err.startswith("error: ") and "Traceback" not in err
    return err


@pytest.mark.parametrize(
    "params, n, expect",
    [
        (
            {"slope_deg": [0, 5, 10], "friction": FRICTION},
            16,
            ["sweep.params.slope_deg", "[0, 5, 10] is not allowed", "allowed for sobol: {low, high, log}"],
        ),
        (
            {"slope_deg": SLOPE, "friction": FRICTION},
            1000,
            ["sweep.n", "1000 is not allowed for sobol", "allowed: a power of two", "512 or 1024"],
        ),
        ({"slope_deg": SLOPE}, 16, ["sweep.params", "one parameter (slope_deg)", "allowed: two or more"]),
        ({"slope_deg": SLOPE, "friction": FRICTION}, None, ["sweep.n", "missing", "a power of two"]),
    ],
    ids=["grid-style list", "n not a power of two", "one parameter", "no n"],
)
def test_bad_sobol_spec_is_one_line(tmp_path, capsys, params, n, expect):
    path = _spec(tmp_path, "bad", params, n)
    for argv in ([str(path), "--quiet"], [str(path), "--dry-run"]):
        err = _one_line(capsys, sweep_main, argv)
        assert str(path) in err, err
        for part in expect:
            assert part in err, (part, err)
    assert not (tmp_path / "bad").exists()


def test_bad_analysis_input_is_one_line(small, tmp_path, capsys):
    _, reference = small
    grid = tmp_path / "grid.yaml"
    grid.write_text(
        yaml.safe_dump(
            {"name": "g", "fixed": {"total_time": 0.5}, "sweep": {"params": {"slope_deg": [0, 5]}}, "backend": "mujoco"}
        )
    )
    _run(grid, out=tmp_path / "g")
    out = ["--out", str(tmp_path / "x")]
    err = _one_line(capsys, main, [str(tmp_path / "g"), *out])
    assert "sweep.method is 'grid'" in err and "allowed: sweep: {method: sobol" in err
    err = _one_line(capsys, main, [str(reference), "--statistics", "drive_sum_maen", *out])
    assert "statistics: 'drive_sum_maen' is unknown" in err and "did you mean 'drive_sum_mean'?" in err
    assert "swept parameter" in _one_line(capsys, main, [str(reference), "--statistics", "slope_deg", *out])
    assert "not found" in _one_line(capsys, main, [str(tmp_path / "nowhere"), *out])
    assert "'bogus'" in _one_line(capsys, main, [str(reference), "--non-ok", "bogus"])
    assert "resamples: 1 is not allowed" in _one_line(capsys, main, [str(reference), "--resamples", "1", *out])
    assert not list(tmp_path.glob("x.*"))


# --- output files and plots -------------------------------------------------------------------------------


def test_cli_writes_the_table_with_units_and_metadata_into_the_result(climb, tmp_path, capsys):
    result = tmp_path / "climb"
    shutil.copytree(climb, result)
    assert main([str(result), "--statistics", "drive_sum_mean,drive_lf_peak_lp"]) == 0
    captured = capsys.readouterr()
    assert "drive_sum_mean [N m], std " in captured.out and ": slope_deg ST " in captured.out, captured.out
    assert "warning: " in captured.err and "wider than the index" in captured.err
    table = pd.read_parquet(result / "sensitivity.parquet")
    assert list(table.statistic.unique()) == ["drive_sum_mean", "drive_lf_peak_lp"] and len(table) == 4
    units = dict(zip(table.parameter, table.parameter_unit, strict=True))
    assert set(table.unit) == {"N m"} and units == {"slope_deg": "deg", "friction": "1"}
    schema = pq.read_schema(result / "sensitivity.parquet")
    assert (
        schema.field("S1").metadata[b"unit"] == b"1" and b"first-order" in schema.field("S1").metadata[b"description"]
    )
    meta = json.loads(schema.metadata[b"batchveh_sensitivity"])
    assert meta["base_size"] == 64 and meta["variants"] == 384 and meta["status"] == {"ok": 384}
    assert meta["parameters"]["friction"] == {"low": 0.6, "high": 1.0, "log": False}
    csv = pd.read_csv(result / "sensitivity.csv", comment="#")
    pd.testing.assert_frame_equal(csv, table)
    assert "# base_size: 64" in (result / "sensitivity.csv").read_text()
    # recorded in the manifest: a resume keeps the record, and the sweep's --overwrite removes the files
    assert ResultFolder(result).read_manifest()["files"] == ["sensitivity.csv", "sensitivity.parquet"]
    spec = str(tmp_path / "climb.yaml")
    shutil.copy(climb.parent / "climb.yaml", spec)
    assert sweep_main([spec, "--out", str(result), "--resume", "--quiet"]) == 0
    assert ResultFolder(result).read_manifest()["files"] == ["sensitivity.csv", "sensitivity.parquet"]
    assert sweep_main([spec, "--out", str(result), "--overwrite", "--quiet", "--limit", "6"]) == 0
    assert not (result / "sensitivity.parquet").exists() and not (result / "sensitivity.csv").exists()
    # write() elsewhere, and batchveh.sensitivity is the module, callable
    paths = write(_quiet_indices(climb, "drive_sum_mean"), tmp_path / "elsewhere" / "s")
    assert paths == [f"{tmp_path / 'elsewhere' / 's'}.parquet", f"{tmp_path / 'elsewhere' / 's'}.csv"]
    import batchveh.sensitivity as module

    assert batchveh.sensitivity is module and callable(module)


def test_plots_show_the_tables_values(climb):
    table = _quiet_indices(climb, ["drive_sum_mean", "drive_lf_rms", "steer_lf_rms"])
    fig = plot.sensitivity_bars(table, "drive_sum_mean")
    ax = fig.axes[0]
    rows = table[table.statistic == "drive_sum_mean"]
    heights = [p.get_height() for p in ax.patches]
    np.testing.assert_allclose(heights, [*rows.S1, *rows.ST])
    assert [t.get_text() for t in ax.get_xticklabels()] == ["slope [deg]", "friction coefficient [-]"]
    assert "[-]" in ax.get_ylabel() and "drive_sum_mean [N m]" in ax.get_title()
    with pytest.raises(ValueError, match="not in the table"):
        plot.sensitivity_bars(table, "drive_sum_peak")
    fig = plot.sensitivity_heatmap(table)
    mesh = fig.axes[0].collections[0]
    expect = table.pivot(index="statistic", columns="parameter", values="ST")
    expect = expect.reindex(index=["drive_sum_mean", "drive_lf_rms", "steer_lf_rms"], columns=["slope_deg", "friction"])
    np.testing.assert_allclose(np.asarray(mesh.get_array()).reshape(3, 2), expect.to_numpy())
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert len(texts) == 6 and texts[0] == f"{expect.iloc[0, 0]:.2f}" and texts[1].startswith("(")
    assert [t.get_text() for t in fig.axes[0].get_yticklabels()] == list(expect.index)
