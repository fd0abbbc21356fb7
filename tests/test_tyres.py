"""The slip tyre (batchveh/model/tyres.py, issue 20) against closed forms.

References, none of them taken from the code under test:
- Static load transfer on a slope s (../shared/seed/REFERENCE.md): each rear wheel carries
  (cos s / 2 + sin s h / L) / (2 cos s) of the load, h the centre of mass above the ground (from
  the parts' masses and heights), L the wheelbase. With rigid wheels of one radius at one speed all
  four slip alike, and with a slip stiffness proportional to load each wheel's share of the drive
  torque is its share of the load.
- Steady climb: m g (sin s + C_rr cos s) r for the four wheels.
- Brush model (Pacejka, Tire and Vehicle Dynamics, 3rd ed., section 3.2, isotropic, parabolic
  pressure): F / (mu N) = 1 - (1 - theta)^3, theta = C_s |s| / (3 mu), 1 from theta = 1.
- Coulomb: locked wheels slide at g (mu cos s - sin s); a wheel dragged along its heading feels
  mu N r on its drive and mu N offset on its steering.
Two bounds where it matters (issue 35): the issue's requirement (issue 20), named as such, and a
regression bound a few times the error measured on the project's 2-core machine, so that a change far
inside the requirement still fails. The measured values are beside each.
"""

import dataclasses

import numpy as np
import pytest

from batchveh.engines import make_engine
from batchveh.model import tyres
from batchveh.model.scenarios import make_scenario
from batchveh.model.tyres import Tyre
from batchveh.model.vehicle import CORNERS, Vehicle, Wheel, layout
from batchveh.run import simulate
from batchveh.stepping import stats
from batchveh.stepping.batch import make_batch

G = 9.81
SLIP = Vehicle()  # the default wheel-ground model is the slip tyre
SLOPES = np.array([5.0, 10.0, 20.0])
SPEEDS = np.array([1.0, 3.0])
# each wheel's share of the four-wheel drive mean vs its share of the static load: the issue's
# requirement, 2 points
SHARE_ATOL = 0.02
# regression bound by engine: measured 8.1e-5 (C and MJX f64, the 20 deg rows) and 2.8e-4 (warp f32)
# on the project's 2-core machine. An equal split is 1.3, 2.6 and 5.3 points off on the 5, 10 and
# 20 deg rows, and a wheel that lost a tenth of its load transfer 0.1 to 0.5 points
SHARE_REGRESSION = {"mujoco": 3e-4, "mjx": 3e-4, "warp": 1e-3}
SPEED_SHARE_ATOL = 0.01  # the requirement, 1 point between 1 and 3 km/h
# regression bound: measured 1.6e-6 (C, MJX f64) and 1.7e-4 (warp f32) on the project's 2-core machine
SPEED_SHARE_REGRESSION = {"mujoco": 1e-5, "mjx": 1e-5, "warp": 5e-4}
SUM_RTOL = 0.01  # the requirement
# regression bound: measured 2.3e-5 (20 deg, every engine) and 1.1e-5 (C_rr 0.02) on the project's 2-core machine
SUM_REGRESSION = 1e-4
CURVE_RTOL = 0.01  # the requirement: slip curve against its closed form
# regression bound: measured 2.0e-15 at most (the steady state is reached; float64 round-off) on the
# project's 2-core machine; the same step in float32 reads 1.3e-6 (kappa 0.03), a brush law 1e-4 too large 1e-4
CURVE_REGRESSION = 1e-12
SATURATION_ATOL = 0.02  # the requirement, 1.00 +- 0.02 at full sliding; measured 1.000 (exactly)
HOLD_MAX = 1e-3  # m in 5 s held on 10 and 20 deg at mu 0.9: the requirement
# regression bound: measured 2.0e-6 m (10 deg) and 4.0e-6 m (20 deg) on the project's 2-core machine
HOLD_REGRESSION = 1e-5  # m
SLIDE_RTOL = 0.05  # the requirement
SLIDE_REGRESSION = 1e-9  # regression bound: measured 1.6e-10 on the project's 2-core machine
COULOMB_RTOL = 0.10  # the issue's, scenario 2 with the seed's laws
DT_RTOL = 0.02  # halving dt moves a per-wheel sizing statistic by at most this (the issue's)


def _share_rear(vehicle: Vehicle, slope_deg):
    """Static load share of each rear wheel on a slope (REFERENCE.md), h from the parts at rest."""
    c, w, h, p = vehicle.chassis, vehicle.wheel, vehicle.hub, vehicle.payload
    masses = np.array([c.mass, 4 * w.mass, 4 * h.mass, p.mass])
    heights = np.array([c.z_cg, w.radius, w.radius, c.z_cg + p.z])
    cg = masses @ heights / masses.sum()
    base = 2 * w.x_cg
    s = np.deg2rad(slope_deg)
    return (np.cos(s) / 2 + np.sin(s) * cg / base) / (2 * np.cos(s))


def _climbs(backend, vehicle=SLIP, precision="f64", total_time=6.0):
    """The climbs, the last 3 s averaged (a 3 s run: its last 1 s)."""
    sc = make_scenario("straight_line", friction=0.9, total_time=total_time, ramp_time=1.0)
    table = {
        "slope_deg": np.repeat(SLOPES, len(SPEEDS)),
        "speed_kmh": np.tile(SPEEDS, len(SLOPES)),
    }
    batch = make_batch(vehicle, sc, table)
    cfg = stats.StatsConfig.for_scenario(sc, (max(total_time - 3.0, 2.0), total_time))
    eng = make_engine(backend, sc, cfg, batch.n, precision=precision)
    cols = eng.run(batch)
    means = np.stack([cols[f"drive_{c}_mean"] for c in CORNERS], axis=1)
    return table, means, cols


# warp on the CPU costs about 9 ms a step whatever the batch: its default run is 3 s (averaged over 2..3 s), where
# it measured 2.9e-4 (share), 1.8e-4 (speed) and 2.2e-5 (sum), as over 3..6 s of the 6 s run (-m slow, "warp_6s")
WARP_SHORT_S = 3.0


@pytest.mark.parametrize("backend", ["mujoco", "mjx", "warp", pytest.param("warp_6s", marks=pytest.mark.slow)])
def test_split_follows_load(backend):
    """5, 10 and 20 deg at mu 0.9, 1 and 3 km/h: each wheel's share of the drive torque is its share
    of the static load within 2 points, and 1 -> 3 km/h moves it by at most 1 point; the four-wheel
    sum is m g sin(s) r within 1% (the requirements; the regression bounds, by engine, are tens of
    times tighter). MuJoCo C and MJX in float64, warp in float32 (its only one)."""
    total_time = {"warp": WARP_SHORT_S}.get(backend, 6.0)
    backend = backend.removesuffix("_6s")
    table, means, cols = _climbs(backend, precision="f32" if backend == "warp" else "f64", total_time=total_time)
    assert (cols["status_code"] == 0).all(), cols["status_code"]
    total = means.sum(1)
    share = means / total[:, None]
    rear = _share_rear(SLIP, table["slope_deg"])
    expect = np.stack([0.5 - rear, 0.5 - rear, rear, rear], axis=1)
    worst = np.abs(share - expect).max()
    by_speed = np.abs(share[0::2] - share[1::2]).max()
    print(f"{backend}: share off load by {100 * worst:.3f} points, speed moves it {100 * by_speed:.4f} points")
    assert worst < SHARE_ATOL
    assert by_speed < SPEED_SHARE_ATOL
    assert worst < SHARE_REGRESSION[backend], worst
    assert by_speed < SPEED_SHARE_REGRESSION[backend], by_speed
    ref = SLIP.total_mass * G * np.sin(np.deg2rad(table["slope_deg"])) * SLIP.wheel.radius
    np.testing.assert_allclose(total, ref, rtol=SUM_RTOL)
    np.testing.assert_allclose(total, ref, rtol=SUM_REGRESSION)


def test_sum_with_rolling_resistance():
    """C_rr 0.02 on flat ground and on 10 deg: the four-wheel drive mean is m g (sin s + C_rr cos s) r
    within 1%, each wheel's rolling part acting on its own load."""
    v = dataclasses.replace(SLIP, wheel=Wheel(rolling_resistance=0.02))
    sc = make_scenario("straight_line", friction=0.9, total_time=6.0, ramp_time=1.0)
    slopes = np.array([0.0, 10.0])
    batch = make_batch(v, sc, {"slope_deg": slopes})
    cols = make_engine("mujoco", sc, stats.StatsConfig.for_scenario(sc, (3.0, 6.0)), 2).run(batch)
    total = sum(cols[f"drive_{c}_mean"] for c in CORNERS)
    s = np.deg2rad(slopes)
    ref = v.total_mass * G * (np.sin(s) + 0.02 * np.cos(s)) * v.wheel.radius
    print("sum / closed form - 1:", total / ref - 1)
    np.testing.assert_allclose(total, ref, rtol=SUM_RTOL)
    np.testing.assert_allclose(total, ref, rtol=SUM_REGRESSION)


def _wheel_at(v_centre, omega, n_force=355.0, r=0.195):
    """Kinematics and contact force of one wheel on flat ground, axle +Y, heading +X."""
    kin = {
        "c": np.array([0.0, 0.0, r]),
        "axle": np.array([0.0, 1.0, 0.0]),
        "v": np.asarray(v_centre, float),
        "w": np.array([0.0, omega, 0.0]),
        "spin": np.asarray(omega, float),
    }
    return kin, np.array([0.0, 0.0, n_force])


def _steady(kin, fc, mu=0.9, c_s=18.0, steps=4000, dt=0.005):
    tp = tyres.params(
        {
            "friction": mu,
            "wheel.radius": 0.195,
            "wheel.width": 0.09,
            "tyre.slip_stiffness": c_s,
            "tyre.relaxation_length": 0.05,
            "tyre.patch_length": 0.02,
            "wheel.rolling_resistance": 0.0,
            "wheel.mass": 3.0,
            "_drive_armature": 0.2,
        }
    )
    tp = {k: np.asarray(x)[..., 0] for k, x in tp.items()}
    state = tyres.init_state(())[0]
    for _ in range(steps):
        state, wrench, info = tyres.step(state, kin, fc, tp, dt)
    return info


@pytest.mark.parametrize("kappa", [-0.5, -0.2, -0.05, -0.01, 0.01, 0.03, 0.1, 0.2, 0.5])
def test_slip_curve_longitudinal(kappa):
    """A loaded wheel at 1 m/s turning at (1 + kappa) V / r: Fx / (mu N) follows the brush model's
    closed form within 1% and is 1.00 +- 0.02 at full sliding (|kappa| >= 3 mu / C_s = 0.15)."""
    mu, c_s, speed = 0.9, 18.0, 1.0
    kin, fc = _wheel_at([speed, 0.0, 0.0], (1 + kappa) * speed / 0.195)
    info = _steady(kin, fc, mu, c_s)
    got = float(info["fx"]) / (mu * 355.0)
    theta = c_s * abs(kappa) / (3 * mu)
    expect = np.sign(kappa) * (1 - (1 - min(theta, 1.0)) ** 3)
    assert got == pytest.approx(expect, rel=CURVE_RTOL)
    assert got == pytest.approx(expect, rel=CURVE_REGRESSION)
    if theta >= 1:
        assert abs(got) == pytest.approx(1.0, abs=SATURATION_ATOL)


@pytest.mark.parametrize("alpha_deg", [0.5, 2.0, 5.0, 8.0, 15.0, 30.0])
def test_slip_curve_lateral(alpha_deg):
    """Free rolling at a slip angle alpha: Fy / (mu N) follows the closed form at |s| = tan(alpha)
    within 1%, against the lateral slip, and saturates at 1.00 +- 0.02."""
    mu, c_s, speed = 0.9, 18.0, 1.0
    a = np.deg2rad(alpha_deg)
    kin, fc = _wheel_at([speed * np.cos(a), speed * np.sin(a), 0.0], speed * np.cos(a) / 0.195)
    info = _steady(kin, fc, mu, c_s)
    got = float(info["fy"]) / (mu * 355.0)
    theta = c_s * np.tan(a) / (3 * mu)
    expect = -(1 - (1 - min(theta, 1.0)) ** 3)  # the force opposes the slip (+Y)
    assert got == pytest.approx(expect, rel=CURVE_RTOL)
    assert got == pytest.approx(expect, rel=CURVE_REGRESSION)
    assert abs(float(info["fx"])) < 1e-6 * mu * 355.0
    if theta >= 1:
        assert abs(got) == pytest.approx(1.0, abs=SATURATION_ATOL)


def test_combined_slip_saturates_on_the_circle():
    """kappa 0.1 with alpha 5 deg: the force is along the slip vector with magnitude from |s|."""
    mu, c_s, speed = 0.9, 18.0, 1.0
    a, kappa = np.deg2rad(5.0), 0.1
    v = np.array([speed * np.cos(a), speed * np.sin(a), 0.0])
    kin, fc = _wheel_at(v, (1 + kappa) * speed * np.cos(a) / 0.195)
    info = _steady(kin, fc, mu, c_s)
    s = np.array([kappa, -np.tan(a)])
    theta = c_s * np.hypot(*s) / (3 * mu)
    mag = mu * 355.0 * (1 - (1 - min(theta, 1.0)) ** 3)
    got = np.array([float(info["fx"]), float(info["fy"])])
    np.testing.assert_allclose(got, mag * s / np.hypot(*s), rtol=CURVE_RTOL)
    np.testing.assert_allclose(got, mag * s / np.hypot(*s), rtol=CURVE_REGRESSION)


def test_standstill_holds_and_slides_like_coulomb():
    """Wheels held at zero speed: on 10 and 20 deg at mu 0.9 the chassis moves less than 1 mm in
    5 s (the requirement; 10 um as the regression bound); on 25 deg at mu 0.3 it slides down at
    g (mu cos s - sin s) within 5% (1e-9 as the regression bound)."""
    for slope in (10.0, 20.0):
        sc = make_scenario("straight_line", slope_deg=slope, friction=0.9, speed_kmh=0.0, total_time=5.0)
        x = simulate(SLIP, sc).series[["x", "y"]].to_numpy()
        moved = np.abs(x - x[0]).max()
        print(f"held on {slope} deg: moved {moved:.3g} m in 5 s")
        assert moved < HOLD_MAX
        assert moved < HOLD_REGRESSION, moved
    s = np.deg2rad(25.0)
    sc = make_scenario("straight_line", slope_deg=25.0, friction=0.3, speed_kmh=0.0, total_time=2.0)
    f = simulate(SLIP, sc).series
    sel = (f["time"] > 0.5) & (f["time"] <= 2.0)
    accel = np.polyfit(f["time"][sel], f["vx"][sel], 1)[0]
    expect = G * (0.3 * np.cos(s) - np.sin(s))
    print(f"slide: {accel:.5g} m/s^2 against {expect:.5g}")
    assert accel == pytest.approx(expect, rel=SLIDE_RTOL)
    assert accel == pytest.approx(expect, rel=SLIDE_REGRESSION)


def test_scrub_slides_like_coulomb():
    """The seed's scenario 2 with the seed's laws: from 0.2 s to 1.0 s each contact slides along
    the wheel's heading (REFERENCE.md, tests/test_scrub.py), so the drive torque is mu N r and the
    steering torque mu N offset per wheel within 10%, N = m g / 4 by the two mirror symmetries."""
    sc = make_scenario("steer_in_place")
    f = simulate(SLIP, sc, window=(0.2, 1.0)).series
    sel = (f["time"] > 0.2 + 1e-9) & (f["time"] <= 1.0 + 1e-9)
    n = SLIP.total_mass * G / 4
    mu = sc.friction
    drive = np.abs([f[f"drive_{c}"][sel].mean() for c in CORNERS]) / (mu * n * SLIP.wheel.radius)
    steer = np.abs([f[f"steer_{c}"][sel].mean() for c in CORNERS]) / (mu * n * SLIP.steer_offset)
    print("drive / mu N r:", drive, "steer / mu N offset:", steer)
    np.testing.assert_allclose(drive, 1.0, rtol=COULOMB_RTOL)
    np.testing.assert_allclose(steer, 1.0, rtol=COULOMB_RTOL)


SIZING = ("mean", "peak", "rms", "peak_lp")


@pytest.mark.parametrize(
    "kind,kw",
    [
        ("straight_line", dict(slope_deg=15.0, speed_kmh=3.0, ramp_time=0.5, total_time=4.0, friction=0.9)),
        ("ackermann", dict(speed_kmh=2.0, turn_radius=2.0, total_time=5.0, friction=0.7)),
        ("steer_in_place", dict(total_time=3.0)),
    ],
)
def test_halving_dt_moves_sizing_statistics_little(kind, kw):
    """dt 5 ms against 2.5 ms on MuJoCo C: every per-wheel sizing statistic (mean, peak, RMS,
    low-passed peak of each drive and steering motor) moves by at most 2% of itself, or of 2% of
    the largest drive peak for a statistic near zero (a straight climb's steering torques)."""
    out = []
    for dt in (0.005, 0.0025):
        sc = make_scenario(kind, time_step=dt, **kw)
        out.append(simulate(SLIP, sc).stats)
    keys = [f"{k}_{c}_{s}" for k in ("drive", "steer") for c in CORNERS for s in SIZING]
    a = np.array([out[0][k] for k in keys], float)
    b = np.array([out[1][k] for k in keys], float)
    floor = np.abs(a[: len(keys) // 2]).max()  # the largest drive statistic
    rel = np.abs(a - b) / np.maximum(np.abs(b), floor)
    worst = keys[int(np.argmax(rel))]
    print(f"{kind}: worst {worst} {rel.max():.3g}")
    assert rel.max() <= DT_RTOL, (worst, rel.max())


def test_rigid_model_is_kept():
    """`tyre: {model: rigid}` compiles MuJoCo's frictional contact (condim 3, the contact model's cone)
    and no tyre; `slip` frictionless contacts (condim 1)."""
    from batchveh.model.vehicle import build_model

    rigid = build_model(dataclasses.replace(SLIP, tyre=Tyre(model="rigid")))
    slip = build_model(SLIP)
    assert (layout(rigid).wheel_ground, layout(slip).wheel_ground) == ("rigid", "slip")
    assert rigid.geom_condim[layout(rigid).ground_geom] == 3
    assert slip.geom_condim[layout(slip).ground_geom] == 1


@pytest.mark.parametrize("half_length,half_width", [(0.01, 0.045), (0.045, 0.045), (0.1, 0.02), (1e-6, 0.045)])
def test_mean_patch_radius_is_the_rectangles_mean_distance(half_length, half_width):
    """The spin moment's lever: the mean distance of a uniform 2a x 2w rectangle from its centre, against
    scipy's quadrature of sqrt(x^2 + y^2) over it (w / 2 for a line, a -> 0)."""
    from scipy.integrate import dblquad

    a, w = half_length, half_width
    integral, _ = dblquad(lambda y, x: np.hypot(x, y), 0, a, 0, w, epsabs=1e-14, epsrel=1e-10)
    assert tyres.mean_patch_radius(a, w) == pytest.approx(integral / (a * w), rel=1e-6)


@pytest.mark.parametrize("model", ["slip", "soil"])
def test_mujoco_c_wheel_ground_step_is_the_numpy_array_code_in_float64(model):
    """MuJoCo C's engine runs `wheels.step` compiled by XLA (rollout.MujocoTyre); the same step in numpy on
    the same MuJoCo data and state must give the same wrenches and state, in float64 (a float32 slip would
    show as 1e-7 of the force; measured 6e-30 N, benchmarks/results/archive.json: cpu-2core-wheel-ground-step.json)."""
    from mujoco.batch import Batch

    from batchveh.model import wheels
    from batchveh.stepping.rollout import MujocoTyre

    n = 8
    sc = make_scenario("straight_line", total_time=1.0, ramp_time=0.5, speed_kmh=2.0, slope_deg=5.0, friction=0.8)
    batch = make_batch(Vehicle(tyre=Tyre(model=model)), sc, {"slope_deg": np.linspace(0.0, 15.0, n)})
    m, lay = batch.model, layout(batch.model)
    b = Batch(m, nsim=n, nthread=1)
    b.bind("ctrl")[:] = 1.0  # the drives turn: slip, spin and the rolling parts all act
    xla = MujocoTyre(m, lay, batch.params)
    tp = wheels.params({k: np.asarray(v, np.float64) for k, v in batch.params.items()}, lay.wheel_ground, np)
    nbody, dt = m.nbody, float(m.opt.timestep)
    x = [b.bind(k) for k in ("xpos", "xmat", "qvel", "cfrc_ext", "xfrc_applied")]
    for _ in range(40):
        args = (x[0], x[1].reshape(n, nbody, 3, 3), *x[2:])
        state = np.asarray(xla.state)
        want_state, want = wheels.step_xfrc(state, *args, tp, lay, dt, nbody, np)
        got = xla.wrench(*args)
        assert got.dtype == np.float64 and np.asarray(xla.state).dtype == np.float64
        scale = max(np.abs(want).max(), 1.0)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-10 * scale)
        np.testing.assert_allclose(
            np.asarray(xla.state), want_state, rtol=0, atol=1e-10 * max(np.abs(want_state).max(), 1e-3)
        )
        x[4][:] = got
        b.step()
    assert np.abs(got[:, lay.wheel_bodies, :3]).max() > 1.0  # forces acted: the check compared something
