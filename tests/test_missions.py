"""Missions (duty cycles): statistics that add up, the slope in time, bad YAML, the motor check.

Tolerances (measured on 2 CPU cores; the measured value is next to each):
"""

import re
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import SLOPE_SUM_RTOL, slope_torque

from batchveh.engines.mjx import MjxEngine
from batchveh.engines.mujoco import MujocoEngine
from batchveh.model.missions import mission_controls, mission_slope
from batchveh.model.params import base_params
from batchveh.model.scenarios import make_scenario
from batchveh.model.vehicle import CORNERS, MOTORS
from batchveh.run import main as run_main
from batchveh.stepping import mission_stats, stats
from batchveh.stepping.batch import make_batch
from batchveh.stepping.mission_stats import MissionStatsConfig
from batchveh.sweep import main as sweep_main
from batchveh.sweeping.results import metadata, units

pytestmark = pytest.mark.xdist_group("missions")  # one test worker: the module's shared fixtures run once

# A mission of one straight segment against straight_line with the same law, on MuJoCo C, flat:
# the same steps and floats; measured 3.5e-16 (relative, worst statistic)
SAME_RUN_RTOL = 1e-12
SAME_RUN_ATOL = 1e-12  # N m, J, m: where a statistic is about 0 (the steering motors)
# The same on a slope, once by tilted gravity (straight_line) and once by the mission's body forces
# on a flat model: round-off apart in the inputs, and the elliptic cone's Newton solve stops at its
# tolerance: measured 7.6e-8 relative (drive_lf_rms), 4.7e-6 N m absolute (a steering motor)
SLOPE_FORCE_RTOL = 1e-6
SLOPE_FORCE_ATOL = 5e-5
# Segments partition the mission's steps: sums over segments against the mission's, the same
# floats added in another order; measured 4.8e-16
PARTITION_RTOL = 1e-12
# warp (float32) against MuJoCo C on a mission with a climb: every statistic within the bound these tests
# had (tests/test_warp.py's WHEEL_ATOL, one absolute bound for all)
WARP_ATOL = 0.15
# and within a regression bound by motor kind and quantity, |warp - C| <= atol + rtol |C|. Measured on the
# project's 2-core machine, the default run's mission (0.5 s) / the slow one (1.5 s): torques 1.1e-5 / 2.3e-5
# relative; the drives' regenerated energy of 0.003-0.15 J 2.9e-6 / 1.4e-5 J; the steering motors' energy
# 1.8e-8 / 7.3e-8 J, their peak speed of 6e-4 to 8e-3 rad/s 6.4e-8 / 1.0e-7 rad/s; time above the threshold
# 1e-7 / 3e-7 s (bounded by one step: a float32 sample may cross the threshold a step earlier); distance
# 5.6e-7 / 1.7e-6 relative
WARP_RTOL = 1e-4
WARP_MOTOR_ATOL = {
    "drive": {"N m": 1e-3, "J": 5e-5, "rad/s": 1e-5},
    "steer": {"N m": 3e-4, "J": 2e-7, "rad/s": 5e-7},
}
WARP_DISTANCE_ATOL = 1e-6  # m
# A mission's first segment against a mission of that segment alone, over the same steps (MuJoCo C):
# the laws before the second segment starts are the same floats (causality); the reductions fold
# the steps in other blocks. Measured 0.0 (bit-equal)
CAUSAL_RTOL = 1e-12
CAUSAL_ATOL = 1e-12  # N m, J, s, m
SPEED_KMH, RAMP_S, SLOPE_DEG = 1.0, 0.6, 8.0
PAYLOADS = np.array([0.0, 30.0])


def _mission(segments, **kw):
    return make_scenario("mission", segments=segments, friction=0.9, **kw)


def _run(engine_cls, scenario, window=None, **kw):
    cfg = stats.StatsConfig.for_scenario(scenario, window)
    engine = engine_cls(scenario, cfg, len(PAYLOADS), **kw)
    from batchveh.model.vehicle import Vehicle

    return engine.run(make_batch(Vehicle(), scenario, {"payload.mass": PAYLOADS}))


def _straight_kw(slope_deg):
    return dict(slope_deg=slope_deg, friction=0.9, speed_kmh=SPEED_KMH, ramp_time=RAMP_S, total_time=RAMP_S)


@pytest.fixture(scope="module")
def straight():
    """straight_line, flat and on a tilted plane, its window the whole run after the settle (MuJoCo C)."""
    runs = {
        s: _run(MujocoEngine, make_scenario("straight_line", **_straight_kw(s)), window=(0.0, RAMP_S))
        for s in (0.0, SLOPE_DEG)
    }
    assert all(r["drive_sum_peak"].min() > 1 for r in runs.values())  # runs with torques to compare
    return runs


def _one_segment(slope_deg):
    """The same run as a mission on a flat model: one accelerate segment on its own slope."""
    return _mission([{"kind": "accelerate", "duration": RAMP_S, "slope_deg": slope_deg}], speed_kmh=SPEED_KMH)


def _assert_mission_is_the_run(mission, run, rtol, atol):
    for ch in (*MOTORS, "drive_sum"):
        for stat in ("rms", "peak", "peak_lp"):
            np.testing.assert_allclose(mission[f"mission_{ch}_{stat}"], run[f"{ch}_{stat}"], rtol, atol, err_msg=ch)
    for corner in CORNERS:  # the net energy of a drive motor, split into driving and regenerating
        net = mission[f"mission_drive_{corner}_energy_drive"] + mission[f"mission_drive_{corner}_energy_regen"]
        np.testing.assert_allclose(net, run[f"drive_{corner}_energy"], rtol, atol, err_msg=corner)
    np.testing.assert_allclose(mission["mission_distance"], run["distance"], rtol, atol)


@pytest.mark.parametrize(
    "slope_deg, rtol, atol", [(0.0, SAME_RUN_RTOL, SAME_RUN_ATOL), (SLOPE_DEG, SLOPE_FORCE_RTOL, SLOPE_FORCE_ATOL)]
)
def test_one_segment_mission_is_the_straight_line_on_mujoco_c(straight, slope_deg, rtol, atol):
    m = _run(MujocoEngine, _one_segment(slope_deg))
    _assert_mission_is_the_run(m, straight[slope_deg], rtol, atol)
    # the mission's own steady-window statistics are the straight line's too (second half of the run)
    ref = _run(MujocoEngine, make_scenario("straight_line", **_straight_kw(slope_deg)))
    for col in ("drive_sum_mean", "drive_lf_rms", "steer_rf_peak", "slip_ratio", "final_x"):
        np.testing.assert_allclose(m[col], ref[col], rtol, atol, err_msg=col)


@pytest.mark.slow  # the same mission on MuJoCo C and on warp stays in the default run
def test_one_segment_mission_on_mjx_matches(straight):
    """MJX (JAX implementation, float64): the mission's statistics, reduced in the scan's carry and
    sloped by the body forces, are the straight line's of MuJoCo C on a tilted plane (measured
    7.6e-8 relative, 4.7e-6 N m, as the mission on MuJoCo C: MJX and C missions agree to 5.1e-13).
    One compile (16 s on 2 cores)."""
    m = _run(MjxEngine, _one_segment(SLOPE_DEG), precision="f64")
    _assert_mission_is_the_run(m, straight[SLOPE_DEG], SLOPE_FORCE_RTOL, SLOPE_FORCE_ATOL)


def test_two_segments_add_up_to_the_mission():
    """Accelerate, then stop: the energies (driving and regenerating) and the time above the
    threshold of the two segments add up to the mission's; peaks are the larger of the two."""
    # on a 5 deg slope: each segment gives it (the scenario's slope_deg would reach only a climb; given
    # as slope_deg=5.0 here, the run was flat: drive_lf energy 6.49 J, 11.13 J on the slope)
    sc = _mission(
        [
            {"kind": "accelerate", "duration": 0.5, "speed_kmh": 2.0, "slope_deg": 5.0},
            {"kind": "stop", "duration": 0.5, "slope_deg": 5.0},
        ],
        torque_threshold={"drive": 3.0, "steer": 0.5},
    )
    out = _run(MujocoEngine, sc)
    seg = ("seg0_accelerate", "seg1_stop")
    for m in MOTORS:
        for stat in ("energy_drive", "energy_regen", "time_above"):
            total = out[f"{seg[0]}_{m}_{stat}"] + out[f"{seg[1]}_{m}_{stat}"]
            np.testing.assert_allclose(total, out[f"mission_{m}_{stat}"], PARTITION_RTOL, 1e-15, err_msg=m + stat)
        for stat in ("peak", "peak_lp", "speed_peak"):
            both = np.maximum(out[f"{seg[0]}_{m}_{stat}"], out[f"{seg[1]}_{m}_{stat}"])
            np.testing.assert_array_equal(both, out[f"mission_{m}_{stat}"], err_msg=m + stat)
        # mean squares weighted by the segments' equal step counts
        ms = (out[f"{seg[0]}_{m}_rms"] ** 2 + out[f"{seg[1]}_{m}_rms"] ** 2) / 2
        np.testing.assert_allclose(ms, out[f"mission_{m}_rms"] ** 2, PARTITION_RTOL, err_msg=m)
    # something to add up: the drives work while accelerating up the slope and brake while stopping
    # (the stop takes them back, minus what holding the slope costs), the threshold is crossed
    assert (out["seg0_accelerate_drive_lf_energy_drive"] > 1.0).all()
    assert (out["seg1_stop_drive_lf_energy_regen"] < -0.01).all()
    assert (out["mission_drive_lf_time_above"] > 0.1).all() and (out["mission_drive_lf_time_above"] < 1.0).all()
    assert "mission_drive_sum_time_above" not in out  # no threshold for the sum


def test_first_segment_is_the_mission_of_that_segment_alone():
    """Causality: a mission's first segment (accelerate, then a climb) has the statistics of a mission
    made of that segment alone, over the same steps; the climb after it changes the mission's."""
    first = {"kind": "accelerate", "duration": 0.5, "speed_kmh": 2.0}
    threshold = {"drive": 3.0, "steer": 0.5}
    both = _run(
        MujocoEngine,
        _mission([first, {"kind": "climb", "duration": 0.5, "slope_deg": 10.0}], torque_threshold=threshold),
    )
    alone = _run(MujocoEngine, _mission([first], torque_threshold=threshold))
    stats_ = ("rms", "peak", "peak_lp")
    cols = [f"seg0_accelerate_{ch}_{st}" for ch in (*MOTORS, "drive_sum") for st in stats_]
    cols += [f"seg0_accelerate_{m}_{st}" for m in MOTORS for st in ("energy_drive", "energy_regen", "time_above")]
    cols += ["seg0_accelerate_distance"]
    for col in cols:
        np.testing.assert_allclose(both[col], alone[col], CAUSAL_RTOL, CAUSAL_ATOL, err_msg=col)
    assert (alone["seg0_accelerate_drive_lf_energy_drive"] > 1.0).all()  # statistics worth comparing
    assert (alone["seg0_accelerate_drive_lf_time_above"] > 0.05).all()
    # what follows differs: the climb loads the drives to m g sin(10 deg) r by its end (48 N m with no
    # payload; measured 49.7 and 60.2 N m peak), and the mission's energy grows with it
    assert (both["seg1_climb_drive_sum_peak"] > 40.0).all()
    assert (both["mission_drive_lf_energy_drive"] > alone["mission_drive_lf_energy_drive"] + 1.0).all()


def test_span_times_in_the_metadata_are_the_durations(tmp_path):
    """mission_spans_s of a sweep's file: each segment's (start, end) in s of law time, from the
    durations by hand. The cruise by distance lasts 0.1 m / (0.7 km/h) = 0.5143 s; the ends
    0.5, 1.0143, 1.2643 s fall on the nearest 5 ms steps: 100, 203, 253."""
    from batchveh.model.missions import mission_of
    from batchveh.sweep import run_sweep
    from batchveh.sweeping.spec import spec_from_mapping

    segments = [
        {"kind": "accelerate", "duration": 0.5},
        {"kind": "cruise", "distance": 0.1, "speed_kmh": 0.7},
        {"kind": "stop", "duration": 0.25},
    ]
    raw = {
        "name": "spans",
        "scenario": {"kind": "mission", "segments": segments},
        "sweep": {"params": {"friction": [0.7]}},
        "backend": "mujoco",
    }
    spec = spec_from_mapping(raw, "test")
    assert run_sweep(spec, out=tmp_path / "s", progress=False)["ok"] == 1
    spans = metadata(tmp_path / "s")["mission_spans_s"]
    ends = [0.0, 0.5, 1.015, 1.265]
    expect = {"mission": [0.0, 1.265], "seg0_accelerate": ends[0:2], "seg1_cruise": ends[1:3], "seg2_stop": ends[2:4]}
    assert list(spans) == list(expect)
    for span, times in expect.items():
        np.testing.assert_allclose(spans[span], times, rtol=0, atol=1e-12, err_msg=span)
    m = mission_of(spec.scenario)
    np.testing.assert_allclose([m.start(k) for k in range(4)], ends, rtol=0, atol=1e-12)


def test_a_late_nan_keeps_the_segments_that_ended_before():
    """A variant whose samples turn NaN in its second segment (a divergence): the first segment keeps
    its statistics, by hand from its own steps; the second and the whole mission are NaN."""
    cfg = MissionStatsConfig(
        spans=("mission", "seg0_a", "seg1_b"), first=(0, 0, 4), last=(7, 3, 7), dt=0.1, threshold=(1.0,) * 8
    )
    rng = np.random.default_rng(0)
    tau = rng.normal(0.0, 2.0, (2, 8, 9))  # 2 variants x 8 steps x (8 motors + drive sum), N m
    lp = rng.normal(0.0, 1.0, (2, 8, 9))  # the low-pass filtered torques, signed
    rate = rng.normal(0.0, 3.0, (2, 8, 8))  # rad/s
    vel = rng.normal(0.0, 0.5, (2, 8, 3))  # m/s
    tau[1, 5:] = lp[1, 5:] = rate[1, 5:] = vel[1, 5:] = np.nan  # variant 1 diverges at step 5
    c = mission_stats.init(cfg, (2,))
    for block in (slice(0, 3), slice(3, 8)):  # two blocks: the carry too
        s = {"tau": tau[:, block, :8], "rate": rate[:, block], "vel": vel[:, block]}
        c = mission_stats.update(c, tau[:, block], lp[:, block], s, np.arange(8)[block], cfg)
    out = mission_stats.finalize(c, cfg)
    t0, p0 = tau[:, :4], tau[:, :4, :8] * rate[:, :4]  # the first segment's steps 0-3
    hand = {
        "drive_lf_rms": np.sqrt((t0[..., 0] ** 2).mean(-1)),
        "steer_rr_peak": np.abs(t0[..., 7]).max(-1),
        "drive_sum_peak_lp": np.abs(lp[:, :4, 8]).max(-1),
        # the low-pass torque's peak where it and the speed have one sign (the motor drives); 0 where it never does
        "drive_rr_drive_peak_lp": np.where(lp[:, :4, 3] * rate[:, :4, 3] > 0, np.abs(lp[:, :4, 3]), 0.0).max(-1),
        "steer_lf_drive_peak_lp": np.where(lp[:, :4, 4] * rate[:, :4, 4] > 0, np.abs(lp[:, :4, 4]), 0.0).max(-1),
        "drive_rf_energy_drive": np.maximum(p0[..., 1], 0).sum(-1) * 0.1,
        "steer_lf_energy_regen": np.minimum(p0[..., 4], 0).sum(-1) * 0.1,
        "steer_lr_speed_peak": np.abs(rate[:, :4, 6]).max(-1),
        "drive_lr_time_above": (np.abs(t0[..., 2]) > 1.0).sum(-1) * 0.1,
        "distance": np.hypot(vel[:, :4, 0], vel[:, :4, 1]).sum(-1) * 0.1,
    }
    for name, value in hand.items():
        np.testing.assert_allclose(out[f"seg0_a_{name}"], value, rtol=1e-14, err_msg=name)
        assert np.isfinite(out[f"seg1_b_{name}"][0]) and np.isnan(out[f"seg1_b_{name}"][1]), name
        assert np.isfinite(out[f"mission_{name}"][0]) and np.isnan(out[f"mission_{name}"][1]), name


def test_climb_segment_holds_the_closed_form(vehicle):
    """A climb inside a mission (the model flat, the slope by body forces from t = 1 s, on over
    0.5 s): the four-wheel sum on the steady climb is m g sin(s) r, as on a tilted plane."""
    sc = _mission(
        [
            {"kind": "accelerate", "duration": 1.0},
            {"kind": "climb", "duration": 2.0, "slope_deg": 10.0, "transition": 0.5},
        ]
    )
    cfg = stats.StatsConfig.for_scenario(sc, (2.0, 3.0))
    out = MujocoEngine(sc, cfg, 1).run(make_batch(vehicle, sc, {}))
    np.testing.assert_allclose(out["drive_sum_mean"], slope_torque(vehicle, 10), rtol=SLOPE_SUM_RTOL)  # -3.6e-3
    # before it the ground is flat: accelerating takes about r m a_max = 11 N m, not the slope's 48
    assert out["seg0_accelerate_drive_sum_peak"][0] < 0.5 * slope_torque(vehicle, 10)
    # the slope's law: the first segment's (0) until 1 s, a quintic step to 10 deg by 1.5 s
    p = base_params(vehicle, sc)
    slope = [float(mission_slope(sc, p, t)) for t in (0.5, 1.0, 1.25, 1.5, 2.5)]
    np.testing.assert_allclose(slope, [0.0, 0.0, 5.0, 10.0, 10.0], atol=1e-12)


def test_controls_are_continuous_through_every_kind(vehicle):
    """Every segment kind in one mission: wheel speeds and steering angles have no jump at any
    boundary. Sampled at dt and dt / 2, a continuous law's largest change per sample halves; a jump
    would keep its size."""
    sc = make_scenario("mission", segments=_every_kind())
    p = base_params(vehicle, sc)
    law = jax.jit(jax.vmap(lambda tt: jnp.concatenate(mission_controls(sc, p, tt))))
    steps = []
    for dt in (1e-3, 5e-4):
        u = np.asarray(law(jnp.arange(0.0, sc.total_time + 0.5, dt)), np.float64)
        steps.append(np.abs(np.diff(u, axis=0)).max(axis=0))  # (8,): the largest change per sample
    assert (steps[0] > 1e-4).all()  # every wheel speed and steering angle moves somewhere
    ratio = steps[1] / steps[0]
    assert ((ratio > 0.4) & (ratio < 0.6)).all(), ratio  # measured 0.50
    wheel = SPEED_KMH / 3.6 / vehicle.wheel.radius
    np.testing.assert_allclose(u[int(round(1.0 / 5e-4))][:4], wheel, rtol=1e-6)  # at speed after 1 s
    assert np.abs(u[int(round(4.5 / 5e-4))][4:]).min() > 0.3  # the crab steers all four (20 deg)
    np.testing.assert_allclose(u[-1][:4], 0.0, atol=1e-6)  # it ends at a standstill


def _every_kind():
    return [
        {"kind": "accelerate", "duration": 1.0},
        {"kind": "cruise", "distance": 0.1, "speed_kmh": 1.0},
        {"kind": "climb", "duration": 1.0, "slope_deg": 5},
        {"kind": "turn", "turn": "ackermann", "duration": 1.0, "turn_radius": 2.0},
        {"kind": "turn", "turn": "crab", "duration": 1.0, "steer_deg": 20, "transition": 0.5},
        {"kind": "stop", "duration": 1.0},
        {"kind": "steer", "duration": 1.0, "steer_deg": 30},
        {"kind": "turn", "turn": "pivot", "duration": 1.0, "yaw_rate_dps": 20},
        {"kind": "stop", "duration": 0.5},
    ]


# --- bad input -------------------------------------------------------------------------------

_GOOD = "  - {kind: accelerate, duration: 1}\n"


@pytest.mark.parametrize(
    "text, expect",
    [
        (f"segments:\n{_GOOD}  - {{kind: cruze, duration: 1}}\n", ["segments[1].kind", "'cruze'", "'cruise'"]),
        (
            f"segments:\n{_GOOD}  - {{kind: cruise, duration: -2}}\n",
            ["segments[1].duration", "-2.0", "> 0 and <= 86400 s"],
        ),
        ("segments:\n  - {kind: cruise, duration: 1, turn_radius: 3}\n", ["segments[0].turn_radius", "allowed keys"]),
        ("segments:\n  - {kind: turn, turn: skid, duration: 1}\n", ["segments[0].turn", "ackermann, crab, pivot"]),
        (f"segments:\n{_GOOD}  - {{kind: turn, turn: pivot, duration: 2}}\n", ["segments[1]", "standstill", "stop"]),
        ("segments:\n  - {kind: stop, duration: 1, transition: 2}\n", ["segments[0].transition", "duration 1 s"]),
        ("segments:\n  - {kind: cruise, distance: 3}\n", ["segments[0].speed_kmh", "with distance"]),
        (f"total_time: 5\nsegments:\n{_GOOD}", ["total_time", "5.0", "segments' total 1 s"]),
        (f"torque_threshold: {{drive: -1}}\nsegments:\n{_GOOD}", ["torque_threshold.drive", "> 0 N m"]),
        ("segments: 3\n", ["segments", "non-empty list"]),
        (  # a turn's keys are its own geometry's: an ackermann turn has no yaw rate
            "segments:\n  - {kind: turn, turn: ackermann, duration: 1, yaw_rate_dps: 20}\n",
            [
                "segments[0].yaw_rate_dps",
                "allowed keys: kind, duration, transition, slope_deg, name, turn, speed_kmh, turn_radius",
            ],
        ),
    ],
)
def test_bad_mission_yaml(tmp_path, capsys, text, expect):
    path = tmp_path / "mission.yaml"
    path.write_text("kind: mission\n" + text)
    code = run_main([str(path), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert str(path) in err
    for part in expect:
        assert part in err, (part, err)


def test_segments_belong_to_missions(tmp_path, capsys):
    path = tmp_path / "sc.yaml"
    path.write_text(f"kind: straight_line\nsegments:\n{_GOOD}")
    assert run_main([str(path)]) == 2
    assert "allowed only with kind: mission" in capsys.readouterr().err


def test_bad_mission_in_a_sweep_spec_exits_2_without_traceback(tmp_path):
    spec = tmp_path / "spec.yaml"
    spec.write_text(
        "name: m\nscenario:\n  kind: mission\n  segments:\n    - {kind: acelerate, duration: 1}\n"
        "sweep: {params: {friction: [0.5]}}\n"
    )
    out = subprocess.run(
        [sys.executable, "-m", "batchveh.sweep", str(spec), "--dry-run"], capture_output=True, text=True, timeout=300
    )
    lines = [ln for ln in out.stderr.splitlines() if ln.strip() and "warp" not in ln]
    assert out.returncode == 2 and len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
    assert "segments[0].kind" in lines[0] and "'accelerate'" in lines[0] and str(spec) in lines[0]


# --- scenario fields a mission does not read ---------------------------------------------------

_OWN_SPEEDS = (
    "    - {kind: accelerate, duration: 0.5, speed_kmh: 2}\n"  # each segment gives its own speed
    "    - {kind: cruise, duration: 0.5, speed_kmh: 2}\n"
)


def _spec_text(segments, rest, scenario=""):
    return f"name: m\nscenario:\n  kind: mission\n{scenario}  segments:\n{segments}{rest}backend: mujoco\n"


def test_unread_swept_fields_exit_2_in_one_line(tmp_path):
    """The review's sweep: two segments with their own speed, swept over ramp_time x speed_kmh x
    turn_radius, ran 8 identical rows; now the CLI refuses it in one line, no traceback."""
    spec = tmp_path / "spec.yaml"
    sweep = "sweep: {params: {ramp_time: [1, 2], speed_kmh: [1, 2], turn_radius: [2, 3]}}\n"
    spec.write_text(_spec_text(_OWN_SPEEDS, sweep))
    out = subprocess.run(
        [sys.executable, "-m", "batchveh.sweep", str(spec), "--dry-run"], capture_output=True, text=True, timeout=300
    )
    lines = [ln for ln in out.stderr.splitlines() if ln.strip() and "warp" not in ln]
    assert out.returncode == 2 and len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
    assert str(spec) in lines[0] and "sweep.params.ramp_time" in lines[0] and "transition" in lines[0], lines[0]


_CRAB = "    - {kind: turn, turn: crab, duration: 1, steer_deg: 20}\n"
_CLIMB_OWN = "    - {kind: climb, duration: 1, slope_deg: 5}\n"


@pytest.mark.parametrize(
    "segments, rest, scenario, expect",
    [
        (_OWN_SPEEDS, "sweep: {params: {speed_kmh: [1, 2]}}\n", "", ["sweep.params.speed_kmh", "segments 0, 1 give"]),
        (_OWN_SPEEDS, "sweep: {params: {turn_radius: [2, 3]}}\n", "", ["sweep.params.turn_radius", "ackermann"]),
        (
            "    - {kind: turn, turn: ackermann, duration: 1, turn_radius: 2}\n",
            "sweep: {params: {turn_radius: [2, 3]}}\n",
            "",
            ["sweep.params.turn_radius", "segments 0 give their own", "speed_kmh (segments 0)"],
        ),
        (_CLIMB_OWN, "sweep: {params: {slope_deg: [0, 5]}}\n", "", ["sweep.params.slope_deg", "no climb leaves"]),
        (_OWN_SPEEDS, "sweep: {params: {slope_deg: [0, 5]}}\n", "", ["sweep.params.slope_deg", "flat"]),
        (_CRAB, "sweep: {params: {steer_deg: [10, 20]}}\n", "", ["sweep.params.steer_deg", "crab turn"]),
        (_OWN_SPEEDS, "sweep: {params: {yaw_rate_dps: [10, 20]}}\n", "", ["sweep.params.yaw_rate_dps", "pivot"]),
        (_OWN_SPEEDS, "fixed: {ramp_time: 2}\nsweep: {params: {friction: [0.5]}}\n", "", ["fixed.ramp_time"]),
        (_OWN_SPEEDS, "fixed: {speed_kmh: 2}\nsweep: {params: {friction: [0.5]}}\n", "", ["fixed.speed_kmh"]),
        (_OWN_SPEEDS, "sweep: {params: {friction: [0.5]}}\n", "  drive_law: ramp\n", ["scenario.drive_law"]),
        (_OWN_SPEEDS, "sweep: {params: {friction: [0.5]}}\n", "  speed_kmh: 2\n", ["scenario.speed_kmh"]),
        (  # a total_time that is not the segments' total is named where it was given
            _OWN_SPEEDS,
            "fixed: {total_time: 0.6}\nsweep: {params: {friction: [0.5]}}\n",
            "",
            ["fixed.total_time: 0.6 differs from the segments' total 1 s"],
        ),
    ],
)
def test_unread_field_is_refused(tmp_path, capsys, segments, rest, scenario, expect):
    spec = tmp_path / "spec.yaml"
    spec.write_text(_spec_text(segments, rest, scenario))
    code = sweep_main([str(spec), "--dry-run"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert str(spec) in err and "allowed:" in err, err
    for part in expect:
        assert part in err, (part, err)


@pytest.mark.parametrize(
    "segments, rest",
    [
        (  # the cruise leaves its speed out: speed_kmh is read (by segment 1)
            "    - {kind: accelerate, duration: 0.5, speed_kmh: 2}\n    - {kind: cruise, duration: 0.5}\n",
            "sweep: {params: {speed_kmh: [1, 2]}}\n",
        ),
        ("    - {kind: climb, duration: 1}\n", "sweep: {params: {slope_deg: [0, 5]}}\n"),
        ("    - {kind: turn, turn: ackermann, duration: 1}\n", "sweep: {params: {turn_radius: [2, 3]}}\n"),
        ("    - {kind: turn, turn: crab, duration: 1}\n", "sweep: {params: {steer_deg: [10, 20]}}\n"),
        ("    - {kind: steer, duration: 1}\n", "sweep: {params: {steer_deg: [10, 20]}}\n"),
        ("    - {kind: turn, turn: pivot, duration: 1}\n", "sweep: {params: {yaw_rate_dps: [10, 20]}}\n"),
        (_OWN_SPEEDS, "fixed: {total_time: 1.0}\nsweep: {params: {friction: [0.5, 0.7], gravity: [9.81]}}\n"),
    ],
)
def test_read_field_is_accepted(tmp_path, capsys, segments, rest):
    spec = tmp_path / "spec.yaml"
    spec.write_text(_spec_text(segments, rest))
    assert sweep_main([str(spec), "--dry-run"]) == 0, capsys.readouterr().err


# --- the example sweep, its columns and the motor check ------------------------------------------


def test_example_mission_sweep_writes_units_and_spans(tmp_path):
    from batchveh.sweep import run_sweep
    from batchveh.sweeping.spec import load_spec

    summary = run_sweep(load_spec("sweeps/mission.yaml"), out=tmp_path / "m", limit=1, progress=False)
    assert summary["ok"] == 1
    u = units(tmp_path / "m")
    assert u["mission_drive_lf_rms"] == "N m" and u["seg2_climb_drive_sum_peak_lp"] == "N m"
    assert u["seg2_climb_drive_lf_energy_drive"] == "J" and u["mission_steer_rr_time_above"] == "s"
    assert u["seg7_turn_steer_lf_speed_peak"] == "rad/s" and u["seg1_cruise_distance"] == "m"
    spans = metadata(tmp_path / "m")["mission_spans_s"]
    assert spans["mission"] == pytest.approx([0.0, 25.1]) and spans["seg1_cruise"] == pytest.approx([2.0, 5.6])


_COLUMN = re.compile(r"^(?:mission|seg\d+_\w+?)_(?P<kind>drive|steer)_(?:lf|rf|lr|rr|sum)_(?P<stat>\w+)$")
_UNIT = {
    "rms": "N m",
    "peak": "N m",
    "peak_lp": "N m",
    "drive_peak_lp": "N m",
    "energy_drive": "J",
    "energy_regen": "J",
    "speed_peak": "rad/s",
}


def _assert_warp_matches_c(w, c, dt):
    """Every mission and segment column of warp against MuJoCo C: the old absolute bound, and the
    regression bound of its motor kind and quantity."""
    cols = [col for col in c if col.startswith(("mission_", "seg"))]
    assert len(cols) > 100
    for col in cols:
        np.testing.assert_allclose(w[col], c[col], atol=WARP_ATOL, err_msg=col)
        m = _COLUMN.match(col)
        if col.endswith("_distance"):
            rtol, atol = WARP_RTOL, WARP_DISTANCE_ATOL
        elif m["stat"] == "time_above":
            rtol, atol = 0.0, dt * (1 + 1e-6)
        else:
            rtol, atol = WARP_RTOL, WARP_MOTOR_ATOL[m["kind"]][_UNIT[m["stat"]]]
        np.testing.assert_allclose(w[col], c[col], rtol=rtol, atol=atol, err_msg=col)


def test_two_segment_mission_on_warp_matches_mujoco_c(vehicle):
    """The warp engine (float32) steps a mission, its slope by body forces on a flat model, as MuJoCo C
    does: accelerate for 0.25 s, then climb to 10 deg over 0.2 s and hold it for 0.05 s (200 steps with the
    settle; about 7 s on 2 CPU cores with Warp's kernels cached)."""
    from batchveh.engines.warp import WarpEngine

    sc = _mission(
        [
            {"kind": "accelerate", "duration": 0.25},
            {"kind": "climb", "duration": 0.25, "slope_deg": 10.0, "transition": 0.2},
        ],
        torque_threshold={"drive": 10.0},
    )
    c, w = _run(MujocoEngine, sc), _run(WarpEngine, sc)
    # the slope is on by the end: the climb's four-wheel peak passes (m + payload) g sin(10 deg) r on both
    # engines (48.1 and 58.1 N m; measured 51.7 and 62.7 on MuJoCo C), where the same climb segment on a flat
    # run peaks at 8.5 and 10.6 N m
    slope = slope_torque(vehicle, 10.0) * (vehicle.total_mass + PAYLOADS) / vehicle.total_mass
    assert (c["seg1_climb_drive_sum_peak"] > slope).all() and (w["seg1_climb_drive_sum_peak"] > slope).all()
    _assert_warp_matches_c(w, c, sc.time_step)


@pytest.mark.slow
def test_mission_on_warp_matches_mujoco_c():
    """The warp engine (float32) steps the same mission, its slope by the same body forces (about
    25 s on 2 CPU cores with Warp's kernels cached)."""
    from batchveh.engines.warp import WarpEngine

    sc = _mission(
        [{"kind": "accelerate", "duration": 0.5}, {"kind": "climb", "duration": 1.0, "slope_deg": 10.0}],
        torque_threshold={"drive": 10.0},
    )
    c, w = _run(MujocoEngine, sc), _run(WarpEngine, sc)
    assert (c["seg1_climb_drive_sum_peak"] > 40).all()  # the slope is on by the end (48 N m)
    _assert_warp_matches_c(w, c, sc.time_step)


def test_a_mission_without_segments_runs_the_example():
    """`python -m batchveh.run mission` has a duty cycle to run: the example, 18 s, with its climb."""
    from batchveh.model.missions import EXAMPLE_SEGMENTS, mission_of

    sc = make_scenario("mission")
    assert sc.total_time == pytest.approx(18.0)
    assert [s["kind"] for s in sc.segments] == [s["kind"] for s in EXAMPLE_SEGMENTS]
    assert mission_of(sc).spans[3] == "seg2_climb"
    assert make_scenario("mission").segments is not sc.segments  # each scenario its own list
