"""The soil wheel-ground model (batchveh/model/soil.py, issue 22) against closed forms, an adaptive
quadrature and the engines against each other.

References, none of them taken from the code under test:
- Bekker's static sinkage of a rigid wheel, z0 = [3 W / ((3 - n) (k_c + b k_phi) sqrt(D))]^(2 / (2n + 1)),
  and its compaction resistance R_c = (k_c + b k_phi) z0^(n+1) / (n + 1) (Wong, Theory of Ground
  Vehicles, 4th ed. 2008, eqs. 2.57 and 2.59), written out again here.
- The Wong-Reece and Janosi-Hanamoto equations (Wong and Reece 1967; Wong 2008, ch. 2), written
  out again here on scalars and integrated by scipy's adaptive quad.
- Each wheel's static load from the moment balance of the parts' masses (MuJoCo's centre of mass).
Tolerances are the issue's (issue 22), named as such; where a check's error is far inside it, a regression
bound a few times the error measured on the project's 2-core machine stands beside it (issue 35).
"""

import dataclasses
import functools
import subprocess
import sys

import numpy as np
import pytest
from scipy import integrate

from batchveh.config import ConfigError
from batchveh.engines import make_engine
from batchveh.model import soil
from batchveh.model.scenarios import make_scenario
from batchveh.model.tyres import Tyre
from batchveh.model.vehicle import CORNERS, Vehicle, layout
from batchveh.stepping import stats
from batchveh.stepping.batch import make_batch
from batchveh.stepping.rollout import mujoco_steps

G = 9.81
SOIL = Vehicle(tyre=Tyre(model="soil"))


def _on(preset):
    return dataclasses.replace(SOIL, soil=dataclasses.replace(SOIL.soil, preset=preset, **soil.PRESETS[preset]))


LUNAR = _on("lunar_soil")
# the soil with Bekker's pressure distribution (no Wong-Reece shift of the largest stress): the
# closed forms' own assumption
BEKKER = dataclasses.replace(SOIL, soil=dataclasses.replace(SOIL.soil, c1=0.0, c2=0.0, c3=0.0))
SINKAGE_RTOL = 0.10  # the issue's; measured 0.6% (dry sand) and 2.8% (lunar soil)
TORQUE_RTOL = 0.10  # the issue's; measured 2.2%
QUAD_RTOL = 0.005  # the requirement, 0.5%
QUAD_REGRESSION = 5e-5  # regression bound: measured 1.0e-5 at most (Toyoura sand) on the project's 2-core machine
ENGINE_RTOL = 0.01  # the requirement, 1% between C and MJX in float64
ENGINE_REGRESSION = 3e-10  # regression bound: measured 5.7e-11 on the project's 2-core machine
WARP_RTOL = 0.02  # the requirement, 2% at p99 for warp float32 (GPU: benchmarks; here on the CPU)
WARP_REGRESSION = 3e-3  # regression bound: measured 8.2e-4 on the project's 2-core machine
# dt from 2.5 to 20 ms moves the drive means by at most this (of the largest wheel of each row); measured
# 0.82% (lunar soil, 10 deg, 20 ms), 0.53% (dry sand, 20 ms) and 0.20% (flat lunar soil, 20 ms)
DT_RTOL = 0.02


def _params(vehicle, load_guess_mass=None):
    """The flat parameters soil.params reads, from a vehicle."""
    v = vehicle
    p = {
        "wheel.width": v.wheel.width,
        "wheel.radius": v.wheel.radius,
        "wheel.mass": v.wheel.mass,
        "hub.mass": v.hub.mass,
        "chassis.mass": v.chassis.mass,
        "payload.mass": v.payload.mass,
        "_drive_armature": v.motors.armature,  # batch.drive_armature: the servo's
        "tyre.relaxation_length": v.tyre.relaxation_length,
        "gravity": 9.81,
    }
    p.update({f"soil.{k}": getattr(v.soil, k) for k in ("n", "k_c", "k_phi", "c", "phi", "K", "c1", "c2", "c3")})
    return {k: np.array([x], float) for k, x in p.items()}


def _reference(z, s, tan_beta, v):
    """W, DP, T, F_y of one wheel by scipy's adaptive quad of the equations on scalars (SI)."""
    so, r, b = v.soil, v.wheel.radius, v.wheel.width
    k = (so.k_c / b + so.k_phi) * 1e3
    t1 = np.arccos(1 - z / r)
    tr = -so.c3 * t1
    tm = min(max((so.c1 + so.c2 * s) * t1, tr), t1)

    def sigma(t):
        if t >= tm:
            a = t
        else:
            a = t1 - (t - tr) / (tm - tr) * (t1 - tm)
        return k * max(r * (np.cos(a) - np.cos(t1)), 0.0) ** so.n

    def shear(t):
        jx = r * ((t1 - t) - (1 - s) * (np.sin(t1) - np.sin(t)))
        jy = r * (1 - s) * (t1 - t) * tan_beta
        j = np.hypot(jx, jy)
        tau = (so.c * 1e3 + sigma(t) * np.tan(np.deg2rad(so.phi))) * (1 - np.exp(-j / so.K))
        return (tau * jx / j, tau * jy / j) if j > 0 else (0.0, 0.0)

    def quad(f):
        return sum(integrate.quad(f, a, c, limit=200, epsabs=0, epsrel=1e-10)[0] for a, c in ((tr, tm), (tm, t1)))

    return {
        "W": r * b * quad(lambda t: sigma(t) * np.cos(t) + shear(t)[0] * np.sin(t)),
        "DP": r * b * quad(lambda t: shear(t)[0] * np.cos(t) - sigma(t) * np.sin(t)),
        "T": r * r * b * quad(lambda t: shear(t)[0]),
        "Fy": r * b * quad(lambda t: shear(t)[1]),
    }


@pytest.mark.parametrize("preset", list(soil.PRESETS))
def test_quadrature_matches_an_adaptive_one(preset):
    """The model's Gauss-Legendre integral against scipy's adaptive quad of the same equations:
    within 0.5% of the support, over sinkages, slips from braking to spinning and side slip."""
    v = _on(preset)
    sp = soil.params(_params(v))
    worst = 0.0
    for z in (0.005, 0.03, 0.08):
        for s in (-0.5, 0.0, 0.1, 0.4, 0.9):
            for tan_beta in (0.0, 0.3):
                got = soil.integrate(np.array([z]), np.array([s / (1 - s)]), np.array([tan_beta]), np.array([1.0]), sp)
                ref = _reference(z, s, tan_beta, v)
                for key in ("W", "DP", "T", "Fy"):
                    scale = ref["W"] * (v.wheel.radius if key == "T" else 1.0)
                    worst = max(worst, abs(float(np.ravel(got[key])[0]) - ref[key]) / scale)
    print(f"{preset}: largest difference {worst:.2e} of the support")
    assert worst < QUAD_RTOL
    assert worst < QUAD_REGRESSION, worst


def _wheel_loads(m, d):
    """Each wheel's static load on flat ground (N): the moment balance about the axles of the
    whole vehicle's weight at MuJoCo's centre of mass, split evenly left and right."""
    lay = layout(m)
    x = d.xpos[lay.wheel_bodies, 0]
    front, rear = x[:2].mean(), x[2:].mean()  # CORNERS: lf, rf, lr, rr
    weight = m.body_subtreemass[lay.chassis_body] * G
    com = d.subtree_com[lay.chassis_body, 0]
    on_front = weight * (com - rear) / (front - rear)
    return np.array([on_front / 2, on_front / 2, (weight - on_front) / 2, (weight - on_front) / 2])


def _closed(v, load):
    so, b, r = v.soil, v.wheel.width, v.wheel.radius
    k = so.k_c + b * so.k_phi  # kN / m^(n+1)
    z0 = (3 * load / 1e3 / ((3 - so.n) * k * np.sqrt(2 * r))) ** (2 / (2 * so.n + 1))
    return z0, k * 1e3 * z0 ** (so.n + 1) / (so.n + 1)


def _at_rest(v, seconds=3.0):
    sc = make_scenario("straight_line", speed_kmh=0.0, total_time=seconds, settle_time=0.0)
    batch = make_batch(v, sc, {})
    params = {k: float(x[0]) for k, x in batch.params.items()}
    for step in mujoco_steps(batch.model, params, scenario=sc, n_steps=sc.n_steps):
        d = step[0]
    return batch.model, d


@pytest.mark.parametrize("preset", ["dry_sand", "lunar_soil"])
def test_static_sinkage_is_bekkers(preset):
    """A vehicle at rest (zero slip, no motion): each wheel's sinkage is Bekker's z0 at its own
    static load within 10%, on the issue's dry sand and a lunar soil on the Moon."""
    v = _on(preset)
    m, d = _at_rest(v)
    lay = layout(m)
    sinkage = v.wheel.radius - d.xpos[lay.wheel_bodies, 2]
    z0, _ = _closed(v, _wheel_loads(m, d))
    print(f"{preset}: sinkage {sinkage} m, Bekker {z0} m, ratio {sinkage / z0}")
    np.testing.assert_allclose(sinkage, z0, rtol=SINKAGE_RTOL)
    assert np.abs(d.qvel[:3]).max() < 1e-4  # at rest


def _drive(vehicle, table, backend="mujoco", precision="f64", scenario=None, window=(3.0, 6.0)):
    sc = scenario or make_scenario("straight_line", total_time=6.0, ramp_time=1.0)
    batch = make_batch(vehicle, sc, table)
    cfg = stats.StatsConfig.for_scenario(sc, window, slip_limit=stats.slip_limit(vehicle))
    cols = make_engine(backend, sc, cfg, batch.n, precision=precision).run(batch)
    return np.stack([cols[f"drive_{c}_mean"] for c in CORNERS], axis=1), cols


def test_rolling_torque_is_the_compaction_resistance():
    """Slow steady rolling on flat dry sand (1 km/h), Bekker's distribution: the four-wheel drive
    torque is r times the sum of each wheel's compaction resistance R_c within 10%."""
    means, cols = _drive(BEKKER, {"speed_kmh": np.array([1.0])})
    assert cols["steady"].all() and not cols["slipping"].any()
    m, d = _at_rest(BEKKER, 0.5)
    _, rc = _closed(BEKKER, _wheel_loads(m, d))
    expect = BEKKER.wheel.radius * rc.sum()
    print(f"drive sum {means.sum():.2f} N m, r sum R_c {expect:.2f} N m, ratio {means.sum() / expect:.4f}")
    assert means.sum() == pytest.approx(expect, rel=TORQUE_RTOL)


ENGINE_TABLE = {
    "slope_deg": np.array([0.0, 5.0, 0.0, 8.0]),
    "speed_kmh": np.array([1.0, 2.0, 3.0, 1.0]),
    "gravity": np.array([9.81, 9.81, 1.62, 1.62]),
}


@functools.cache
def _engine_table_on_c():
    """ENGINE_TABLE on lunar soil on MuJoCo C, the reference of the MJX and warp tests: run once."""
    return _drive(LUNAR, ENGINE_TABLE)


def test_mjx_float64_agrees_with_mujoco_c():
    """Lunar soil on the Earth and the Moon, flat and climbing: MJX float64's per-wheel drive means
    within 1% of MuJoCo C's."""
    v = LUNAR
    ref, c_cols = _engine_table_on_c()
    got, _ = _drive(v, ENGINE_TABLE, backend="mjx", precision="f64")
    err = np.abs(got - ref) / np.abs(ref).max(axis=1, keepdims=True)
    print("MJX f64 against C, largest per-wheel difference of the largest wheel:", err.max())
    assert (c_cols["status_code"] == 0).all()
    assert err.max() < ENGINE_RTOL
    assert err.max() < ENGINE_REGRESSION, err.max()


# warp on the CPU costs about 9 ms a step whatever the batch: the default run drives 3 s (averaged over 2..3 s),
# where warp measured 1.4e-5 against C on the project's 2-core machine; the 6 s run is -m slow
WARP_SHORT_REGRESSION = 1e-4


@pytest.mark.parametrize("total_time", [3.0, pytest.param(6.0, marks=pytest.mark.slow)], ids=["3s", "6s"])
def test_warp_float32_agrees_with_mujoco_c(total_time):
    """The warp engine in float32 (here on the CPU) within 2% of MuJoCo C float64 per wheel."""
    v = LUNAR
    if total_time == 6.0:
        ref, _ = _engine_table_on_c()
        got, _ = _drive(v, ENGINE_TABLE, backend="warp", precision="f32")
        bound = WARP_REGRESSION
    else:
        sc = make_scenario("straight_line", total_time=total_time, ramp_time=1.0)
        ref, _ = _drive(v, ENGINE_TABLE, scenario=sc, window=(2.0, total_time))
        got, _ = _drive(v, ENGINE_TABLE, backend="warp", precision="f32", scenario=sc, window=(2.0, total_time))
        bound = WARP_SHORT_REGRESSION
    err = np.abs(got - ref) / np.abs(ref).max(axis=1, keepdims=True)
    print("warp f32 against C, largest per-wheel difference of the largest wheel:", err.max())
    assert err.max() < WARP_RTOL
    assert err.max() < bound, err.max()


def test_time_step_does_not_move_the_torques():
    """Flat dry sand, flat lunar soil and a 10 deg climb on lunar soil, at 1 km/h under the Earth's gravity
    (one batch: the soils as swept soil.* values): 2.5, 5, 10 and 20 ms steps give the same drive means
    within 2% of each row's largest wheel. On the dry sand this vehicle cannot drive (slip 0.99,
    validation/SOIL.md), and the 10 deg climb slips too. validation/SOIL.md's dt study is the lunar soil
    under the Moon's gravity."""
    dry, lunar = soil.PRESETS["dry_sand"], soil.PRESETS["lunar_soil"]
    table = {"slope_deg": np.array([0.0, 0.0, 10.0])}
    table.update({f"soil.{k}": np.array([dry[k], lunar[k], lunar[k]]) for k in dry})
    runs = []
    for dt in (0.0025, 0.005, 0.01, 0.02):
        sc = make_scenario("straight_line", total_time=6.0, ramp_time=1.0, time_step=dt)
        means, cols = _drive(SOIL, table, scenario=sc)
        runs.append(means)
    # the rows are the soils they claim: the dry sand (the base vehicle's preset) digs in, the lunar soil
    # rolls on the flat and slips on the climb
    assert SOIL.soil.preset == "dry_sand" and list(cols["slipping"]) == [True, False, True], cols["slipping"]
    ref = runs[0]
    err = max((np.abs(r - ref).max(axis=1) / np.abs(ref).max(axis=1)).max() for r in runs[1:])
    print("largest change over dt 2.5 to 20 ms:", err)
    assert err < DT_RTOL


def test_a_slope_the_soil_cannot_hold_is_flagged():
    """Lunar soil on the Moon at 1 km/h: the 5 deg climb is not flagged; at 25 deg, past what the
    soil's shear strength carries, the wheels dig in and the climb is flagged slipping."""
    _, cols = _drive(LUNAR, {"slope_deg": np.array([5.0, 25.0]), "gravity": np.array([1.62, 1.62])})
    print("slip ratio:", cols["slip_ratio"], "slipping:", cols["slipping"])
    assert not cols["slipping"][0]
    assert cols["slipping"][1]


@pytest.mark.parametrize(
    "soil_yaml, expect",
    [
        ("{k_phi: -5}", ["soil.k_phi", "-5", "> 0"]),
        ("{n: 2.5}", ["soil.n", "2.5", "<= 2"]),
        ("{n: 0}", ["soil.n", "0", "> 0"]),
        ("{phi: 65}", ["soil.phi", "65", "<= 60"]),
        ("{preset: mars}", ["preset", "mars", "dry_sand"]),
    ],
)
def test_bad_soil_is_one_line_exit_2(tmp_path, soil_yaml, expect):
    """A negative k_phi, n outside (0, 2], a friction angle over 60 deg or an unknown preset:
    one line naming the file, key, value and what is allowed, exit 2, no traceback."""
    spec = tmp_path / "soil.yaml"
    spec.write_text(
        "name: soil\nscenario: {kind: straight_line, total_time: 1.0}\n"
        f"vehicle: {{tyre: {{model: soil}}, soil: {soil_yaml}}}\n"
        "sweep: {method: grid, params: {slope_deg: [0, 5]}}\n"
    )
    out = subprocess.run(
        [sys.executable, "-m", "batchveh.sweep", str(spec), "--dry-run"], capture_output=True, text=True
    )
    lines = out.stderr.strip().splitlines()
    print(out.stderr)
    assert out.returncode == 2 and len(lines) == 1 and "Traceback" not in out.stderr
    assert str(spec) in lines[0] and all(e in lines[0] for e in expect)


def test_soil_under_an_obstacle_is_refused():
    """Soil is a flat deformable plane: with a step (or terrain) the batch is refused in one line."""
    sc = make_scenario("straight_line", obstacle="step", step_height=0.05, obstacle_x=0.5)
    with pytest.raises(ConfigError, match="obstacle: 'step' is not allowed with vehicle.tyre.model soil"):
        make_batch(SOIL, sc, {})
