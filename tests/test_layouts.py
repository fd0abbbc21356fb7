"""Steering layouts (`steering.layout`: four_wheel | skid | front) against closed forms, across engines and motor
models, and their bad input (validation/LAYOUTS.md has every number; validation/layouts.py writes them).

Skid-steered (every hub fixed): the wheels roll at the chassis' velocity along x at their centres,
(v - yaw y) / r (scenarios.skid_speeds), and slide sideways at yaw x. With the slip tyre sliding (its brush
saturated, |F| = mu N: isotropic Coulomb), four point contacts at (+-a, +-b) (a = wheel.x_cg, b = wheel.y_cg,
h = hypot(a, b)) each loaded N = m g / 4 turn steadily where the moment of the drive forces about the centre
balances the lateral resistance's and each force lies along its slip. Solving both: every wheel's longitudinal
force is mu N a / h (so its drive torque mu N a r / h), its lateral force mu N b / h, and the chassis yaws at
b^2 / h^2 of the commanded rate (the wheels also slip along x: Yu et al.'s skid factor, 1 + (a / b)^2 here).
That holds for a pivot and for any turn tight enough to keep the brush saturated (`saturation_radius`): the
inner wheels brake and the outer ones drive at the same torque whatever the radius. On wide turns the brush is
linear (F = C_s N s): each wheel's torque falls to C_s N a^2 b r / (R h^2), 0 as R -> infinity (the straight
line). Between the two, `brush_turn` solves the tyre's steady state (three equations, scipy) for each wheel.
Wong's point-load form (Theory of Ground Vehicles, skid steering: every wheel's lateral force mu N) gives
mu N a r / b, sqrt(1 + (a / b)^2) above the Coulomb form: within 10% for a / b <= 0.458 only.

Front-steered: the front hubs steer so that each front wheel's centre moves along its heading about a centre on
the rear axle line, (-wheel.x_cg, R); the rear hubs are fixed. Every tolerance is a named constant with the
value it was set from (measured on this project's 2-core CPU machine, MuJoCo C unless named).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.optimize import brentq, fsolve

from batchveh.model.scenarios import make_scenario
from batchveh.model.tyres import mean_patch_radius
from batchveh.model.vehicle import CORNER_SIGNS, CORNERS, MOTORS, Vehicle, vehicle_from_mapping
from batchveh.run import simulate

pytestmark = pytest.mark.xdist_group("layouts")  # one test worker: the module's shared fixtures run once

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
SX = np.array([CORNER_SIGNS[c][0] for c in CORNERS], float)
SY = np.array([CORNER_SIGNS[c][1] for c in CORNERS], float)
G = 9.81

# --- tolerances ---------------------------------------------------------------------------------------------
# skid pivot, each wheel's steady drive torque against mu N a r / h: measured up to 0.74% (the 60 kg wide robot at
# mu 0.9; 0.06-0.13% on the others), a diagonal pattern (lf and rr one way, rf and lr the other) that cancels in
# the four-wheel mean: the four contacts' loads differ slightly under the wheels' ground forces (a warp the
# Coulomb form, which loads every wheel m g / 4, leaves out)
SKID_WHEEL_RTOL = 0.01
SKID_MEAN_RTOL = 5e-4  # the four wheels' mean |torque|: measured 9.5e-5 (the 1 t rover), 4e-6 at most on the others
SKID_YAW_RTOL = 2e-3  # the steady yaw rate against b^2 / h^2 of the command: measured 4.1e-4 (rover), 1.5e-6 others
# each fixed hub's holding torque against the Coulomb forces' moment about its hinge: measured 0.80% (the rover at
# mu 0.9: its hub turns 0.5 deg under 178 N m, which moves the contact), 0.09% on the others
HUB_MOMENT_RTOL = 0.015
# a fixed hub's largest angle over a skid run, deg: measured 0.52 deg (the 1 t rover's pivot at mu 0.9: its
# 178 N m over the servo's steer_kp 20,000 N m/rad), 0.05 deg at most on the others
FIXED_HUB_DEG = 0.75
HUB_COMPLIANCE_RTOL = 0.02  # the steady hub angle against holding moment / steer_kp: measured 0.52% (rover, mu 0.9)
WONG_BAND = 0.10  # the brief's bound for Wong's point-load form where the lateral slide dominates (a / b <= 0.458)
# skid turn at 1 km/h, mu 0.6, R 0.6 m (every brush saturated): each side's mean torque (front and rear wheel)
# against the Coulomb form: measured 2.3e-4 (30 kg robot), 1.7e-4 (AGV); 1.3e-3 at R 0.3 m (validation): the
# centripetal force shifts the turn's centre forward, so the front wheels carry more and the rear ones less
# (+-3% at R 0.3 m), which the side's mean cancels to first order. The same bound holds the drive forces' moment
# against the lateral resistance's (measured 1.3e-4) and the yaw rate against b^2 / h^2 of v / R (2.2e-4)
SKID_TURN_SIDE_RTOL = 2e-3
# each wheel against the slip tyre's steady state (`brush_turn`: centripetal force and spin moments in, loads
# m g / 4): measured 1.1e-3 (30 kg, R 0.6 m: the pivot's diagonal load pattern), 4.2e-4 (R 4 m, the linear range);
# 2.3e-3 at most over the study's radii, 0.3 to 100 m
SKID_TURN_WHEEL_RTOL = 4e-3
SKID_TURN_YAW_RTOL = 1e-3  # yaw rate against the steady state: measured 4.7e-5 (R 0.6 m); 1.8e-4 at most (study)
# the four-wheel drive sum of a flat skid turn (no rolling resistance) over one wheel's Coulomb torque: measured
# 4.1e-4 (30 kg, R 0.6 m: the centripetal force's share along x, m yaw v_y; 3.2e-3 at R 0.3 m)
SKID_TURN_SUM_SHARE = 2e-3
# a 10 km turn against the straight line with rolling resistance 0.02, each wheel apart by the linear brush's
# C_s N a^2 b r / (R h^2) (1.2e-3 N m): measured 1.1% of it (the wheels' loads shift with the rolling moments)
STRAIGHT_LIMIT_RTOL = 0.03
# front-steered Ackermann turn (MuJoCo C, slip tyre, 2-3 km/h, mu 0.8): the steady front angles against the closed
# forms: measured 1.3e-4 (AGV: its servo gives way under the aligning moment) and 4.0e-5 (30 kg robot)
FRONT_ANGLE_RTOL = 5e-4
FRONT_YAW_RTOL = 3e-3  # yaw rate against v / hypot(x_cg, R): measured -1.8e-3 (30 kg), -7.6e-4 (AGV)
FRONT_RADIUS_RTOL = 3e-3  # the circle fitted to the chassis' path against hypot(x_cg, R): measured 1.8e-3 (30 kg)
# the fitted circle's centre in the chassis frame against (-x_cg, R), over hypot(x_cg, R): measured 2.7e-3 (30 kg)
FRONT_CENTRE_SHARE = 5e-3
# a front-steered vehicle's rear hubs, largest |angle| over the run: measured 0.034 deg (the AGV, turning or steering
# in place: its rear hub's moment over steer_kp), 0.006 deg (30 kg robot)
REAR_HUB_DEG = 0.1
STEER_END_DEG = 0.05  # front hubs' final angle steering in place: measured 0.015 deg (AGV); tests/test_physics.py's
# MJX float32 against MuJoCo C, each motor's steady mean over ENGINE_WINDOW, |MJX - C| <= atol + rtol |C| (N m):
# measured 1.75e-3 N m of 3.53 (a front steer in place's drive) and 1.04e-3 of 1.40 (its steering), 2.9e-4 N m on
# the skid pivot's 2.19 N m hub moment: 6x to 9x tests/test_mjx.py's F32_MOTOR_MEAN_TOL, set on a straight climb,
# where no wheel slides (float32 rounds a sliding wheel's split its own way); its F32_MEAN_ATOL (1.5 N m) holds
MJX_MOTOR_MEAN_TOL = {"drive": (1e-3, 1e-3), "steer": (1e-3, 1e-3)}
KINK_STEPS = 3  # samples each side of a law's kink left out of MJX's series RMS (the spike is one or two steps)
# the warp engine's four-wheel sum on a front steer in place (its scrub, window 1.1-2 s) against MuJoCo C: measured
# 4.7e-4 (2.0e-3 N m of 4.26), above tests/test_warp.py's SUM_RTOL 2e-5, set on straight lines
STEER_IN_PLACE_SUM_RTOL = 2e-3
STEER_IN_PLACE_SLIP_ATOL = 2e-3  # its slip ratio (no travel: the scrub's): measured 3.9e-4 (SLIP_ATOL 5e-5)
# model dcmotor against the servo (HUB_LOCK at each fixed hub, rotor 1 kg m^2 since 30069fe): the fixed hubs' largest
# angle 0.0058 deg (the 60 kg robot's skid pivot; the servo's 0.009 deg) and 0.0014 deg (the 30 kg robot's front turn
# rear hubs); each drive's steady mean within 3.6e-3 of the largest (the front turn, where the drives carry 0.03 N m)
# and 1.3e-5 on the pivot. With ffec2a4's HUB_LOCK (rotor 1e-4 kg m^2) both runs diverged (LAYOUTS.md)
DC_HUB_DEG = 0.05
DC_DRIVE_SHARE = 0.02


# --- vehicles -----------------------------------------------------------------------------------------------


def _geometry(chassis, wheel, hub) -> dict:
    return {"chassis": chassis, "wheel": wheel, "hub": hub}


# the geometry of the sweeps' vehicles (none is the seed's 50 kg robot of the first measurement), and a short wide
# robot whose wheelbase is 0.36 of its track, where Wong's point-load form holds within 10%
GEOMETRY = {
    "robot_30kg": _geometry(  # sweeps/robot_30kg.yaml
        {"length": 0.5, "width": 0.36, "height": 0.2, "mass": 20.0, "z_cg": 0.2},
        {"radius": 0.08, "width": 0.04, "mass": 0.8, "x_cg": 0.22, "y_cg": 0.22},
        {"radius": 0.03, "length": 0.1, "mass": 1.7, "y_cg": 0.15},
    ),
    "robot_60kg": _geometry(  # sweeps/delivery_robot.yaml
        {"length": 0.6, "width": 0.5, "height": 0.3, "mass": 44.0, "z_cg": 0.28},
        {"radius": 0.10, "width": 0.05, "mass": 1.5, "x_cg": 0.3, "y_cg": 0.30},
        {"radius": 0.035, "length": 0.12, "mass": 2.5, "y_cg": 0.215},
    ),
    "agv_250kg": _geometry(  # sweeps/warehouse_agv.yaml
        {"length": 1.2, "width": 0.8, "height": 0.3, "mass": 130.0, "z_cg": 0.3},
        {"radius": 0.125, "width": 0.06, "mass": 5.0, "x_cg": 0.55, "y_cg": 0.45},
        {"radius": 0.05, "length": 0.15, "mass": 7.5, "y_cg": 0.35},
    ),
    "rover_1t": _geometry(  # sweeps/rover_1t.yaml
        {"length": 2.4, "width": 1.6, "height": 0.5, "mass": 800.0, "z_cg": 0.7},
        {"radius": 0.35, "width": 0.2, "mass": 25.0, "x_cg": 1.2, "y_cg": 0.9},
        {"radius": 0.1, "length": 0.3, "mass": 25.0, "y_cg": 0.7},
    ),
}
_DELIVERY = GEOMETRY["robot_60kg"]
GEOMETRY["wide_60kg"] = {  # the delivery robot's parts on a 0.26 m wheelbase and a 0.72 m track
    "chassis": {**_DELIVERY["chassis"], "length": 0.4, "width": 0.6},
    "wheel": {**_DELIVERY["wheel"], "x_cg": 0.13, "y_cg": 0.36},
    "hub": {**_DELIVERY["hub"], "y_cg": 0.28},
}


def vehicle(name: str, layout: str, **extra) -> Vehicle:
    """One of GEOMETRY's vehicles with `steering.layout` (and `extra` top-level keys, e.g. steering, motors)."""
    raw = {**GEOMETRY[name], **extra}
    raw["steering"] = {"layout": layout, **extra.get("steering", {})}
    return vehicle_from_mapping(raw, f"test vehicle {name}")


# --- closed forms -------------------------------------------------------------------------------------------


def normal_load(v: Vehicle, g: float = G) -> float:
    """Each wheel's static load m g / 4, N (the chassis' centre of mass on the centre: chassis.x_cg, y_cg 0)."""
    return v.total_mass * g / 4


def skid_coulomb_torque(v: Vehicle, mu: float) -> float:
    """Each wheel's drive torque |mu N a / h| r of a sliding skid turn (pivot, or the brush saturated), N m."""
    a, b = v.wheel.x_cg, v.wheel.y_cg
    return mu * normal_load(v) * a / np.hypot(a, b) * v.wheel.radius


def wong_torque(v: Vehicle, mu: float) -> float:
    """Wong's point-load form: each wheel's lateral force mu N, so M_r = mu W L / 2 and each wheel drives
    mu N L / B = mu N a / b, times r (N m)."""
    return mu * normal_load(v) * v.wheel.x_cg / v.wheel.y_cg * v.wheel.radius


def skid_yaw_share(v: Vehicle) -> float:
    """The sliding skid vehicle's yaw rate over the commanded one, b^2 / h^2 (isotropic friction, equal loads)."""
    a, b = v.wheel.x_cg, v.wheel.y_cg
    return b * b / (a * a + b * b)


def hinge(v: Vehicle) -> tuple[float, float]:
    """(x, y) of the left front steering hinge: steering.axis_x / axis_y, the chassis corner where 0."""
    return v.steering.axis_x or v.chassis.length / 2, v.steering.axis_y or v.chassis.width / 2


def skid_hub_moment(v: Vehicle, mu: float, sign: float = 1.0) -> float:
    """A fixed hub's holding torque (its steering slot's, about +z on the hub) in a sliding skid turn: minus the
    moment of the ground's force on its wheel (F_x = -sy mu N a / h, F_y = -sx mu N b / h, `sign` the yaw's)
    about its hinge; the same at every corner: mu N ((a - hx) b - (b - hy) a) / h."""
    a, b = v.wheel.x_cg, v.wheel.y_cg
    hx, hy = hinge(v)
    return sign * mu * normal_load(v) * ((a - hx) * b - (b - hy) * a) / np.hypot(a, b)


def saturation_radius(v: Vehicle, mu: float, c_s: float) -> float:
    """The largest commanded turn radius |R| at which every brush of a sliding skid turn stays saturated (the
    Coulomb form holds): the outer wheel's practical slip |v_s| / V = a h / (b (R_a + b)) reaches 3 mu / C_s, with
    the path's radius R_a = R h^2 / b^2 (centripetal force left out)."""
    a, b = v.wheel.x_cg, v.wheel.y_cg
    h = np.hypot(a, b)
    return (a * h * c_s / (3 * mu * b) - b) * b * b / (h * h)


def skid_linear_torque(v: Vehicle, radius: float, c_s: float) -> float:
    """Each wheel's drive torque in a wide skid turn, the brush linear (F = C_s N s) and V = v at every wheel:
    C_s N a^2 b r / (|R| h^2), N m; 0 as R -> infinity."""
    a, b = v.wheel.x_cg, v.wheel.y_cg
    return c_s * normal_load(v) * a * a * b * v.wheel.radius / (abs(radius) * (a * a + b * b))


def brush_turn(v: Vehicle, mu: float, radius: float, speed_kmh: float) -> dict:
    """The slip tyre's steady state in a flat skid turn commanded at v = speed_kmh and yaw v / radius: each wheel
    rolls at (v - yaw y) / r; the chassis' velocity (v_x, v_y) and yaw rate w solve the force balance along x
    and y (with the centripetal m w v) and the moment balance, the brush force of each wheel being
    -mu N (1 - (1 - theta)^3) along its practical slip s = v_s / V (theta = C_s |s| / (3 mu), at most 1) and
    its torsional bristle -C_s N polar w / V within mu N rho sqrt(1 - (F / mu N)^2) (batchveh/model/tyres.py's
    steady forms). Loads m g / 4 (no load transfer). Returns each wheel's drive torque F_x r (N m), the yaw
    rate (rad/s), v_x and v_y (m/s)."""
    m, n = v.total_mass, normal_load(v)
    a, b, r = v.wheel.x_cg, v.wheel.y_cg, v.wheel.radius
    c_s, patch = v.tyre.slip_stiffness, v.tyre.patch_length
    polar = ((patch / 2) ** 2 + (v.wheel.width / 2) ** 2) / 3.0
    rho = float(mean_patch_radius(patch / 2, v.wheel.width / 2))
    speed = speed_kmh / 3.6
    x, y = SX * a, SY * b
    rim = speed - speed / radius * y  # each rim's speed, omega r

    def forces(q):
        vx, vy, w = q
        ahead = vx - w * y
        slip = np.stack([ahead - rim, vy + w * x]) / np.abs(ahead)
        mag = np.hypot(*slip)
        theta = np.minimum(c_s * mag / (3 * mu), 1.0)
        f = -mu * n * (1 - (1 - theta) ** 3) * slip / np.maximum(mag, 1e-300)
        left = np.sqrt(np.maximum(1 - (np.hypot(*f) / (mu * n)) ** 2, 0.0))
        spin = np.clip(-c_s * n * polar * w / np.abs(ahead), -mu * n * rho * left, mu * n * rho * left)
        return f, spin

    def residual(q):
        vx, vy, w = q
        f, spin = forces(q)
        return [f[0].sum() + m * w * vy, f[1].sum() - m * w * vx, (x * f[1] - y * f[0] + spin).sum()]

    q = fsolve(residual, [speed, 0.0, speed / radius * skid_yaw_share(v)], xtol=1e-12)
    assert np.abs(residual(q)).max() < 1e-8 * m, residual(q)
    f, _ = forces(q)
    return {"torque": f[0] * r, "yaw": float(q[2]), "vx": float(q[0]), "vy": float(q[1])}


def front_angle(v: Vehicle, radius: float, sy: float) -> float:
    """The steady angle (rad) of the front hub on side sy (+1 left) in a turn about (-wheel.x_cg, radius): the
    wheel's centre, hinge + Rot(angle) d (d the wheel from its hinge at angle 0), moves along the wheel's heading
    about the centre, (c - centre) . (cos, sin) = 0; the root nearest straight ahead (scipy's brentq)."""
    a = v.wheel.x_cg
    hx, hy = hinge(v)
    axis = np.array([hx, sy * hy])
    d = np.array([a - hx, sy * (v.wheel.y_cg - hy)])
    centre = np.array([-a, radius])

    def along(t):
        c = axis + np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]) @ d
        return float((c - centre) @ np.array([np.cos(t), np.sin(t)]))

    return brentq(along, -1.45, 1.45, xtol=1e-14)


def ackermann_tan(v: Vehicle, radius: float, sy: float) -> float:
    """With each front wheel on its hinge's line along the vehicle (no trail), tan(angle) = L / (R - y_hinge):
    L = 2 wheel.x_cg the wheelbase, y_hinge = sy hy (the heading square to the line from the centre)."""
    return np.arctan(2 * v.wheel.x_cg / (radius - sy * hinge(v)[1]))


def circle_fit(x, y) -> tuple[float, float, float]:
    """Least-squares circle through the points (Kasa): centre x, centre y, radius."""
    a = np.column_stack([x, y, np.ones_like(x)])
    d, e, f = np.linalg.lstsq(a, -(x * x + y * y), rcond=None)[0]
    cx, cy = -d / 2, -e / 2
    return cx, cy, float(np.sqrt(cx * cx + cy * cy - f))


# --- runs ---------------------------------------------------------------------------------------------------

STEADY = 2.5  # s: law time from which a turn is steady (hubs 0..1 s, drive ramp 1..2 s)
TURN = {"total_time": 4.0, "ramp_time": 1.0}


def steady_rate(series, t_from: float) -> float:
    """Least-squares slope of the unwrapped yaw from t_from on, rad/s."""
    w = series[series.time >= t_from]
    return float(np.polyfit(w.time.to_numpy(), np.unwrap(w.yaw.to_numpy()), 1)[0])


def means(stats, kind: str = "drive") -> np.ndarray:
    """The four wheels' (or hubs') steady mean torques, CORNERS order."""
    return np.array([float(stats[f"{kind}_{c}_mean"]) for c in CORNERS])


def hub_angles(series, hubs=CORNERS) -> float:
    """The largest |angle| of the named hubs over the whole run, deg."""
    return float(np.rad2deg(np.abs(series[[f"alpha_{c}" for c in hubs]].to_numpy()).max()))


def skid_pivot(name: str, mu: float, yaw_rate_dps: float, **extra):
    """A skid pivot: the drive ramp 1..2 s (the hubs' 0..1 s steer is none), steady 2.5..4 s."""
    sc = make_scenario("pivot", friction=mu, yaw_rate_dps=yaw_rate_dps, **TURN)
    return simulate(vehicle(name, "skid", **extra), sc, window=(STEADY, TURN["total_time"]))


def skid_turn(name: str, mu: float, radius: float, speed_kmh: float = 1.0, **extra):
    """A skid turn (kind ackermann): v = speed_kmh, yaw v / radius about a centre abreast of the chassis centre."""
    sc = make_scenario("ackermann", friction=mu, turn_radius=radius, speed_kmh=speed_kmh, **TURN)
    return simulate(vehicle(name, "skid", **extra), sc, window=(STEADY, TURN["total_time"]))


FRONT_TURN = {"total_time": 5.0, "ramp_time": 1.5}  # steer 0..1.5 s, drive 1.5..3 s, steady from 3.5 s
FRONT_STEADY = 3.5


def front_turn(v: Vehicle, radius: float, speed_kmh: float, mu: float = 0.8, **kw):
    sc = make_scenario("ackermann", friction=mu, turn_radius=radius, speed_kmh=speed_kmh, **FRONT_TURN)
    return simulate(v, sc, window=(FRONT_STEADY, FRONT_TURN["total_time"]), **kw)


# --- a. skid pivot ------------------------------------------------------------------------------------------

PIVOTS = [
    *((name, 0.6, 20.0) for name in ("robot_30kg", "robot_60kg", "wide_60kg", "agv_250kg", "rover_1t")),
    *((name, 0.9, -30.0) for name in ("robot_30kg", "wide_60kg", "rover_1t")),
]
# the default run's cases (each check on a vehicle in Wong's band and one out of it, both yaw directions); the others
# run with -m slow (the default run stays under 5 minutes on 2 cores)
DEFAULT_PIVOTS = {("robot_30kg", 0.6, 20.0), ("wide_60kg", 0.6, 20.0), ("robot_30kg", 0.9, -30.0)}


class _Runs(dict):
    """Runs made when first asked for, kept for the module: `fn(*key)`."""

    def __init__(self, fn):
        super().__init__()
        self.fn = fn

    def __missing__(self, key):
        self[key] = value = self.fn(*key)
        return value


def _params(cases, default, ids):
    """pytest params of `cases`, those not in `default` marked slow."""
    return [pytest.param(c, id=ids(c), marks=() if c in default else pytest.mark.slow) for c in cases]


PIVOT_PARAMS = _params(PIVOTS, DEFAULT_PIVOTS, lambda c: f"{c[0]}-mu{c[1]}-{c[2]:+g}dps")


@pytest.fixture(scope="module")
def pivots():
    """The PIVOTS cases asked for, on MuJoCo C, slip tyre (4 s each)."""
    return _Runs(skid_pivot)


@pytest.mark.parametrize("case", PIVOT_PARAMS)
def test_skid_pivot_drive_torque_is_the_coulomb_closed_form(pivots, case):
    """Each wheel's drive torque mu N a r / h, the left wheels backward and the right ones forward for a positive
    yaw (the signs flip with it), the four-wheel sum 0, the yaw rate b^2 / h^2 of the command, and each fixed hub
    holding the Coulomb forces' moment about its hinge at the angle that moment over steer_kp gives."""
    name, mu, rate = case
    res = pivots[case]
    v, s = res.vehicle, res.stats
    assert s["status_code"] == 0
    drive = means(s)
    expect = skid_coulomb_torque(v, mu)
    np.testing.assert_array_equal(np.sign(drive), -SY * np.sign(rate))  # left back, right forward for yaw > 0
    np.testing.assert_allclose(np.abs(drive), expect, rtol=SKID_WHEEL_RTOL)
    np.testing.assert_allclose(np.abs(drive).mean(), expect, rtol=SKID_MEAN_RTOL)
    assert abs(float(s["drive_sum_mean"])) < SKID_MEAN_RTOL * expect
    yaw = steady_rate(res.series, STEADY)
    np.testing.assert_allclose(yaw, np.deg2rad(rate) * skid_yaw_share(v), rtol=SKID_YAW_RTOL)
    hold = skid_hub_moment(v, mu, np.sign(rate))
    np.testing.assert_allclose(means(s, "steer"), hold, rtol=HUB_MOMENT_RTOL)
    angle = hub_angles(res.series)
    assert angle < FIXED_HUB_DEG, angle
    w = res.series[res.series.time >= STEADY]
    steady_angle = np.rad2deg(np.abs(w[[f"alpha_{c}" for c in CORNERS]].to_numpy()).mean())
    np.testing.assert_allclose(steady_angle, np.rad2deg(abs(hold) / v.motors.steer_kp), rtol=HUB_COMPLIANCE_RTOL)


@pytest.mark.parametrize("case", PIVOT_PARAMS)
def test_wong_point_load_form_holds_where_the_lateral_slide_dominates(pivots, case):
    """Wong's mu N a r / b, sqrt(1 + (a / b)^2) above the Coulomb form: within 10% of the simulated torque on the
    wide robot (a / b 0.36: 6.3% above), and more than 10% off on the others (a / b 1.0 to 1.33: 41% to 67%
    above), where the wheels slide along x as much as sideways and the lateral force is mu N b / h, not mu N."""
    for (name, mu, _), res in [(case, pivots[case])]:
        v = res.vehicle
        sim = float(np.abs(means(res.stats)).mean())
        ratio = wong_torque(v, mu) / sim
        np.testing.assert_allclose(ratio, np.hypot(1, v.wheel.x_cg / v.wheel.y_cg), rtol=SKID_MEAN_RTOL)
        if name == "wide_60kg":
            assert v.wheel.x_cg / v.wheel.y_cg <= 0.45
            assert abs(ratio - 1) <= WONG_BAND, ratio
        else:
            assert abs(ratio - 1) > WONG_BAND, (name, ratio)


# --- b. skid turn -------------------------------------------------------------------------------------------

TURNS = [("robot_30kg", 0.6), ("robot_30kg", -0.6), ("robot_30kg", 4.0), ("agv_250kg", 0.6), ("agv_250kg", -4.0)]
TURN_MU = 0.6


DEFAULT_TURNS = {("robot_30kg", 0.6), ("robot_30kg", 4.0)}  # the others with -m slow


@pytest.fixture(scope="module")
def turns():
    """The TURNS cases asked for, on MuJoCo C at 1 km/h, mu 0.6."""
    return _Runs(lambda name, radius: skid_turn(name, TURN_MU, radius))


@pytest.mark.parametrize("case", _params(TURNS, DEFAULT_TURNS, lambda c: f"{c[0]}-R{c[1]:+g}"))
def test_skid_turn_follows_the_tyres_steady_state(turns, case):
    """Each wheel's torque and the yaw rate against the slip tyre's steady state (`brush_turn`): the inner side
    (left for R > 0) brakes, the outer one drives; the four-wheel sum is the centripetal force's share only."""
    name, radius = case
    res = turns[case]
    v, s = res.vehicle, res.stats
    assert s["status_code"] == 0
    ref = brush_turn(v, TURN_MU, radius, 1.0)
    drive = means(s)
    inner = SY == np.sign(radius)
    assert np.all(drive[inner] < 0) and np.all(drive[~inner] > 0), drive
    np.testing.assert_allclose(drive, ref["torque"], rtol=SKID_TURN_WHEEL_RTOL)
    np.testing.assert_allclose(steady_rate(res.series, STEADY), ref["yaw"], rtol=SKID_TURN_YAW_RTOL)
    assert abs(float(s["drive_sum_mean"])) < SKID_TURN_SUM_SHARE * skid_coulomb_torque(v, TURN_MU)
    assert hub_angles(res.series) < FIXED_HUB_DEG


@pytest.mark.parametrize(
    "case", _params([c for c in TURNS if abs(c[1]) < 1], DEFAULT_TURNS, lambda c: f"{c[0]}-R{c[1]:+g}")
)
def test_tight_skid_turn_is_the_pivots_coulomb_form(turns, case):
    """A turn tight enough to saturate every brush (R below `saturation_radius`): the inner side brakes and the
    outer one drives at mu N a r / h each, the radius' own value aside, as in a pivot; the drive forces' moment
    about the centre, -sum y F_x, balances the lateral resistance's 4 mu N a b / h, and the chassis yaws at
    b^2 / h^2 of v / R."""
    name, radius = case
    res = turns[case]
    v = res.vehicle
    assert abs(radius) < saturation_radius(v, TURN_MU, v.tyre.slip_stiffness)
    drive = means(res.stats)
    inner = SY == np.sign(radius)
    expect = skid_coulomb_torque(v, TURN_MU)
    np.testing.assert_allclose([-drive[inner].mean(), drive[~inner].mean()], expect, rtol=SKID_TURN_SIDE_RTOL)
    a, b, r = v.wheel.x_cg, v.wheel.y_cg, v.wheel.radius
    moment = -(SY * b * drive / r).sum() * np.sign(radius)
    resistance = 4 * TURN_MU * normal_load(v) * a * b / np.hypot(a, b)
    np.testing.assert_allclose(moment, resistance, rtol=SKID_TURN_SIDE_RTOL)
    yaw = steady_rate(res.series, STEADY)
    np.testing.assert_allclose(yaw, 1.0 / 3.6 / radius * skid_yaw_share(v), rtol=SKID_TURN_SIDE_RTOL)


def test_wide_skid_turn_tends_to_the_straight_line():
    """R -> infinity: a 10 km skid turn's wheels carry the straight line's torques (rolling resistance 0.02:
    C_rr N r each) to within the linear brush's C_s N a^2 b r / (R h^2), which vanishes with 1 / R."""
    name, radius, c_rr = "robot_30kg", 1.0e4, 0.02
    extra = {"wheel": {**GEOMETRY[name]["wheel"], "rolling_resistance": c_rr}}
    turn = skid_turn(name, TURN_MU, radius, **extra)
    sc = make_scenario("straight_line", friction=TURN_MU, **TURN)
    line = simulate(turn.vehicle, sc, window=(STEADY, TURN["total_time"]))
    v = turn.vehicle
    # the four-wheel sum is C_rr m g r; each wheel's share moves with the load the rolling moments shift rearward
    np.testing.assert_allclose(float(line.stats["drive_sum_mean"]), 4 * c_rr * normal_load(v) * v.wheel.radius,
                               rtol=SKID_MEAN_RTOL)  # fmt: skip
    apart = (means(turn.stats) - means(line.stats)) * np.sign(radius) * -SY  # > 0: the outer side drives more
    np.testing.assert_allclose(apart, skid_linear_torque(v, radius, v.tyre.slip_stiffness), rtol=STRAIGHT_LIMIT_RTOL)


# --- c. front steering --------------------------------------------------------------------------------------

# the 30 kg robot's hinges at its chassis corners (each wheel 0.03 m behind its hinge: a trail) and the AGV's on
# its wheels' line along the vehicle (steering.axis_x = wheel.x_cg: tan(angle) = L / (R - y_hinge))
FRONTS = [("robot_30kg", {}, 2.0, 2.0), ("robot_30kg", {}, -3.0, 3.0), ("agv_250kg", {"axis_x": 0.55}, 2.0, 2.0),
          ("agv_250kg", {"axis_x": 0.55}, -3.0, 3.0)]  # fmt: skip


DEFAULT_FRONTS = {("robot_30kg", 2.0), ("agv_250kg", -3.0)}  # both vehicles, both directions; the others -m slow


@pytest.fixture(scope="module")
def fronts():
    """The FRONTS cases asked for, by (vehicle, radius)."""
    by = {(n, r): (st, kmh) for n, st, r, kmh in FRONTS}
    return _Runs(lambda n, r: front_turn(vehicle(n, "front", steering=by[n, r][0]), r, by[n, r][1]))


@pytest.mark.parametrize(
    "case",
    [pytest.param(c, id=f"{c[0]}-R{c[2]:+g}", marks=() if (c[0], c[2]) in DEFAULT_FRONTS else pytest.mark.slow)
     for c in FRONTS],
)  # fmt: skip
def test_front_steered_turns_about_the_rear_axle_line(fronts, case):
    """The front hubs' steady angles against the closed forms, the yaw rate v / hypot(x_cg, R), the path's circle
    (its radius hypot(x_cg, R), its centre at (-x_cg, R) in the chassis frame: on the rear axle line), the rear
    hubs held straight."""
    name, steering, radius, kmh = case
    res = fronts[(name, radius)]
    v, ser = res.vehicle, res.series
    assert res.stats["status_code"] == 0
    w = ser[ser.time >= FRONT_STEADY]
    got = w[["alpha_lf", "alpha_rf"]].mean().to_numpy()
    expect = [front_angle(v, radius, sy) for sy in (1.0, -1.0)]
    np.testing.assert_allclose(got, expect, rtol=FRONT_ANGLE_RTOL)
    if steering.get("axis_x") == v.wheel.x_cg:  # no trail: the textbook form
        np.testing.assert_allclose(expect, [ackermann_tan(v, radius, sy) for sy in (1.0, -1.0)], rtol=1e-12)
    assert abs(got[0]) > abs(got[1]) if radius > 0 else abs(got[1]) > abs(got[0])  # the inner wheel steers more
    a = v.wheel.x_cg
    big = np.hypot(a, radius)
    np.testing.assert_allclose(steady_rate(ser, FRONT_STEADY), np.sign(radius) * kmh / 3.6 / big, rtol=FRONT_YAW_RTOL)
    cx, cy, fitted = circle_fit(w.x.to_numpy(), w.y.to_numpy())
    np.testing.assert_allclose(fitted, big, rtol=FRONT_RADIUS_RTOL)
    dx, dy, yaw = cx - w.x.to_numpy(), cy - w.y.to_numpy(), w.yaw.to_numpy()
    local = np.array([np.cos(yaw) * dx + np.sin(yaw) * dy, -np.sin(yaw) * dx + np.cos(yaw) * dy]).mean(axis=1)
    assert np.hypot(local[0] + a, local[1] - radius) < FRONT_CENTRE_SHARE * big, local
    assert hub_angles(ser, ("lr", "rr")) < REAR_HUB_DEG


def test_front_steered_steers_in_place_with_its_front_hubs_only():
    """steer_in_place on a front-steered vehicle: the front hubs reach the seed's -45 / +45 deg (lf, rf), the rear
    hubs stay straight (the layout's mask on the targets), every wheel's speed target of a rear hub 0."""
    v = vehicle("agv_250kg", "front")
    res = simulate(v, make_scenario("steer_in_place", total_time=2.0, ramp_time=1.5), window=(1.6, 2.0))
    assert res.stats["status_code"] == 0
    last = res.series.iloc[-1]
    np.testing.assert_allclose(np.rad2deg([last.alpha_lf, last.alpha_rf]), [-45.0, 45.0], atol=STEER_END_DEG)
    assert hub_angles(res.series, ("lr", "rr")) < REAR_HUB_DEG
    assert np.all(res.series[["alpha_ref_lr", "alpha_ref_rr", "omega_ref_lr", "omega_ref_rr"]].to_numpy() == 0.0)


# --- d. MuJoCo C against MJX and the warp engine, per layout ------------------------------------------------

# (vehicle, layout, steering), scenario kind, its settings: 2 s after the settle, the drive ramp 0.5..1 s
ENGINE_CASES = {
    "skid_pivot": ("robot_30kg", "skid", "pivot", {"friction": 0.6, "yaw_rate_dps": 20.0}),
    "skid_turn": ("robot_30kg", "skid", "ackermann", {"friction": 0.6, "turn_radius": 0.6, "speed_kmh": 1.0}),
    "front_ackermann": ("robot_30kg", "front", "ackermann", {"friction": 0.8, "turn_radius": 2.0, "speed_kmh": 2.0}),
    "front_steer_in_place": ("robot_30kg", "front", "steer_in_place", {"friction": 0.7, "ramp_time": 1.0}),
}
ENGINE_RUN = {"total_time": 2.0, "ramp_time": 0.5}
# the statistics' window, after every linear ramp's end (1 s at most): a kink in an imposed law gives one step's
# torque spike that float32 rounds its own way (below); the whole-run statistics still see it
ENGINE_WINDOW = (1.1, 2.0)


def engine_case(case: str):
    name, layout, kind, kw = ENGINE_CASES[case]
    return vehicle(name, layout), make_scenario(kind, **{**ENGINE_RUN, **kw})


def kinks(sc, time) -> np.ndarray:
    """True at the samples within KINK_STEPS steps of a kink in the case's imposed laws (0, ramp_time and twice it:
    the linear ramps' starts and ends), where one step's torque spike is float32's to round."""
    at = np.array([0.0, sc.ramp_time, 2 * sc.ramp_time])
    return (np.abs(np.asarray(time)[:, None] - at[None, :]) < (KINK_STEPS + 0.5) * sc.time_step).any(axis=1)


@pytest.mark.slow
@pytest.mark.parametrize("case", list(ENGINE_CASES))
def test_warp_matches_mujoco_c_per_layout(case):
    """The warp engine (MuJoCo Warp on the CPU, float32) against MuJoCo C on each layout's motions, two variants
    (the case's friction and 0.1 more): statuses equal, every motor's statistics within tests/test_warp.py's bounds
    (WHEEL_ATOL, MOTOR_TOL; on a steered layout the unfiltered whole-run peak aside: ENGINE_WINDOW), the sum, slip
    and speed within its SUM_*, SLIP_ATOL, SPEED_ATOL (a front steer in place's sum and slip within
    STEER_IN_PLACE_SUM_RTOL and STEER_IN_PLACE_SLIP_ATOL)."""
    from test_warp import MOTOR_TOL, SLIP_ATOL, SPEED_ATOL, STAT_SUFFIXES, SUM_ATOL, SUM_RTOL, WHEEL_ATOL

    from batchveh.engines.mujoco import MujocoEngine
    from batchveh.engines.warp import WarpEngine
    from batchveh.stepping import stats
    from batchveh.stepping.batch import make_batch

    v, sc = engine_case(case)
    table = {"friction": np.array([sc.friction, sc.friction + 0.1])}
    cfg = stats.StatsConfig.for_scenario(sc, ENGINE_WINDOW)
    w, c = (E(sc, cfg, 2).run(make_batch(v, sc, table)) for E in (WarpEngine, MujocoEngine))
    np.testing.assert_array_equal(w["status_code"], c["status_code"])
    assert np.all(c["status_code"] == 0)
    sum_rtol = STEER_IN_PLACE_SUM_RTOL if sc.kind == "steer_in_place" else SUM_RTOL
    np.testing.assert_allclose(w["drive_sum_mean"], c["drive_sum_mean"], rtol=sum_rtol, atol=SUM_ATOL)
    steered = any(v.steering.steered)
    for m in MOTORS:
        rtol, atol = MOTOR_TOL[m.split("_")[0]]
        for suffix in STAT_SUFFIXES:
            got, ref = np.asarray(w[m + suffix]), np.asarray(c[m + suffix])
            if suffix == "_peak_all" and steered:  # the steering ramp's kink: its one-step spike (ENGINE_WINDOW)
                continue
            np.testing.assert_allclose(got, ref, atol=WHEEL_ATOL, err_msg=m + suffix)
            np.testing.assert_allclose(got, ref, rtol=rtol, atol=atol, err_msg=m + suffix)
    slip_atol = STEER_IN_PLACE_SLIP_ATOL if sc.kind == "steer_in_place" else SLIP_ATOL
    np.testing.assert_allclose(w["slip_ratio"], c["slip_ratio"], atol=slip_atol)
    np.testing.assert_allclose(w["mean_speed"], c["mean_speed"], atol=SPEED_ATOL)


@pytest.mark.slow
@pytest.mark.parametrize("case", list(ENGINE_CASES))
def test_mjx_matches_mujoco_c_per_layout(case):
    """MJX float32 against MuJoCo C on each layout's motions: statuses equal, each motor's steady mean within
    tests/test_mjx.py's F32_MEAN_ATOL and this module's MJX_MOTOR_MEAN_TOL, the series' RMS difference within its
    F32_SERIES_RTOL of the RMS torque away from the laws' kinks; MJX float64 within its F64_SERIES_ATOL at every
    step, kinks included."""
    from test_mjx import F32_MEAN_ATOL, F32_SERIES_RTOL, F64_SERIES_ATOL

    v, sc = engine_case(case)
    c = simulate(v, sc, backend="mujoco", window=ENGINE_WINDOW)
    j = simulate(v, sc, backend="mjx", window=ENGINE_WINDOW)
    assert c.stats["status_code"] == j.stats["status_code"] == 0
    a, b = c.series[list(MOTORS)].to_numpy(), j.series[list(MOTORS)].to_numpy()
    smooth = ~kinks(sc, c.series.time)
    share = np.sqrt(np.mean((a[smooth] - b[smooth]) ** 2)) / np.sqrt(np.mean(a[smooth] ** 2))
    assert share <= F32_SERIES_RTOL, share
    for m in MOTORS:
        np.testing.assert_allclose(j.stats[f"{m}_mean"], c.stats[f"{m}_mean"], atol=F32_MEAN_ATOL, err_msg=m)
        rtol, atol = MJX_MOTOR_MEAN_TOL[m.split("_")[0]]
        np.testing.assert_allclose(j.stats[f"{m}_mean"], c.stats[f"{m}_mean"], rtol=rtol, atol=atol, err_msg=m)
    d = simulate(v, sc, backend="mjx", precision="f64").series[list(MOTORS)].to_numpy()
    assert np.abs(a - d).max() <= F64_SERIES_ATOL, np.abs(a - d).max()


# --- e. both motor models per layout ------------------------------------------------------------------------

BIG = "maxon-353297-48V_NPT025-i40"  # 31.8 N m continuous at the wheel (tests/test_motors_in_loop.py)
DC_CASES = {
    # a skid vehicle names no steering motor: HUB_LOCK holds its hubs
    "skid_pivot": ("robot_60kg", "skid", {"drive": BIG}, "pivot", {"friction": 0.6, "yaw_rate_dps": 20.0}),
    "front_ackermann": ("robot_30kg", "front", {"drive": BIG, "steer": BIG}, "ackermann",
                        {"friction": 0.8, "turn_radius": 2.0, "speed_kmh": 2.0}),
}  # fmt: skip


def test_a_fixed_hubs_steering_loop_has_positive_gains():
    """Every dcmotor steering slot's derived kp, kv and ki are positive, HUB_LOCK's at a fixed hub too: with ffec2a4's
    HUB_LOCK (rotor 1e-4 kg m^2) its back-EMF damping, N^2 K^2 / R = 100 N m s/rad, let drive.gains' explicit bound
    on kv exceed 2 I / dt on these light hubs (I 0.0147 kg m^2 on the 60 kg robot), and the steering's kp bound,
    (4 - 2 kv dt / I) I / dt^2 / 2, came out at -9,116 N m/rad: every run diverged (measured now: 7,537 and 7,600)."""
    from batchveh.stepping.batch import make_batch

    for name, layout, motors, kind, kw in DC_CASES.values():
        v = vehicle(name, layout, motors={"model": "dcmotor", "catalogue": str(CATALOGUE), **motors})
        params = make_batch(v, make_scenario(kind, **kw), {}).params
        for k in ("kp", "kv", "ki"):
            assert np.all(np.asarray(params[f"_dc.{k}"])[:, 4:] > 0), (name, layout, k, params[f"_dc.{k}"])


@pytest.mark.slow  # 5 s; the default run keeps tests/test_hub_lock.py (dcmotor against servo on a skid pivot)
@pytest.mark.parametrize("case", list(DC_CASES))
def test_dcmotor_and_servo_agree_per_layout(case):
    """model dcmotor (catalogue motors with their drive loops) against the servo on each layout: status ok, motor
    status ok, the fixed hubs held (HUB_LOCK's angle loop, or the servo's PD) within DC_HUB_DEG, and the steady
    drive torques near the servo's."""
    from batchveh.engines.mujoco import MujocoEngine
    from batchveh.stepping import stats
    from batchveh.stepping.batch import make_batch
    from batchveh.stepping.motor_stats import MOTOR_STATUS, MotorStatsConfig

    name, layout, motors, kind, kw = DC_CASES[case]
    sc = make_scenario(kind, **{**FRONT_TURN, **kw})
    window = (FRONT_STEADY, sc.total_time)
    servo = simulate(vehicle(name, layout), sc, window=window)
    v = vehicle(name, layout, motors={"model": "dcmotor", "catalogue": str(CATALOGUE), **motors})
    dc = simulate(v, sc, window=window)
    cfg = stats.StatsConfig.for_scenario(sc, window, motors=MotorStatsConfig.for_vehicle(v))
    cols = MujocoEngine(sc, cfg, 1).run(make_batch(v, sc, {"friction": np.array([sc.friction])}))
    assert servo.stats["status_code"] == dc.stats["status_code"] == 0
    assert MOTOR_STATUS[int(cols["motor_status_code"][0])] == "ok", cols["motor_status_code"]
    fixed = [c for c, s in zip(CORNERS, v.steering.steered, strict=True) if not s]
    assert hub_angles(dc.series, fixed) < DC_HUB_DEG, hub_angles(dc.series, fixed)
    scale = np.abs(means(servo.stats)).max()
    np.testing.assert_allclose(means(dc.stats), means(servo.stats), rtol=0, atol=DC_DRIVE_SHARE * scale)


# --- g. bad input -------------------------------------------------------------------------------------------


def _one_line(capsys, main, argv) -> str:
    """`main(argv)` exits 2 with one line on stderr, no traceback, nothing on stdout (tests/test_cli_errors.py)."""
    try:
        got = main(argv)
    except SystemExit as exc:
        got = exc.code
    out = capsys.readouterr()
    err = out.err.strip()
    assert got == 2 and len(err.splitlines()) == 1 and "Traceback" not in err and not out.out.strip(), (got, out)
    return err


BAD = {
    # case: (vehicle's steering, scenario kind, what the line must name besides the file)
    "unknown_layout": ({"layout": "tank"}, "pivot", ("steering.layout", "'tank'", "four_wheel, skid, front")),
    "axis_on_skid": ({"layout": "skid", "axis_x": 0.25}, "pivot", ("steering.axis_x", "0.25", "'skid'")),
    "crab_on_skid": ({"layout": "skid"}, "crab", ("steering.layout", "'skid'", "'crab'")),
    "pivot_on_front": ({"layout": "front"}, "pivot", ("steering.layout", "'front'", "'pivot'")),
}


@pytest.mark.parametrize("command", ["run", "sweep"])
@pytest.mark.parametrize("case", list(BAD))
def test_bad_layout_input_is_one_line_naming_file_key_and_value(command, case, tmp_path, capsys):
    """`python -m batchveh.run SCENARIO --vehicle V.yaml` and `python -m batchveh.sweep SPEC.yaml` (the vehicle in
    the spec): exit 2, one line naming the file that holds the vehicle, the key and its value, before any work."""
    from batchveh import run, sweep

    steering, kind, names = BAD[case]
    raw = {**GEOMETRY["robot_30kg"], "steering": steering}
    if command == "run":
        path = tmp_path / "vehicle.yaml"
        path.write_text(yaml.safe_dump(raw, sort_keys=False))
        argv = [kind, "--vehicle", str(path), "--out", str(tmp_path / "o")]
        err = _one_line(capsys, run.main, argv)
    else:
        path = tmp_path / "spec.yaml"
        spec = {
            "name": "bad",
            "scenario": kind,
            "vehicle": raw,
            "fixed": {"total_time": 1.0, "ramp_time": 0.5},
            "sweep": {"method": "grid", "params": {"friction": [0.5, 0.9]}},
            "output": str(tmp_path / "o"),
        }
        path.write_text(yaml.safe_dump(spec, sort_keys=False))
        err = _one_line(capsys, sweep.main, [str(path), "--quiet"])
    assert err.startswith("error: ") and str(path) in err, err
    for name in names:
        assert name in err, (name, err)
    assert not (tmp_path / "o").exists()  # nothing written


@pytest.mark.slow  # a process; the default run keeps the in-process lines above and tests/test_cli_errors.py
def test_a_bad_layout_is_refused_by_the_command_as_a_process(tmp_path):
    """The same through `python -m batchveh.run` as a process: exit 2, one line on stderr, nothing on stdout."""
    path = tmp_path / "vehicle.yaml"
    path.write_text(yaml.safe_dump({**GEOMETRY["agv_250kg"], "steering": {"layout": "skid"}}, sort_keys=False))
    proc = subprocess.run(
        [sys.executable, "-m", "batchveh.run", "crab", "--vehicle", str(path), "--out", str(tmp_path / "o")],
        capture_output=True, text=True, cwd=ROOT, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 2 and proc.stdout == "" and len(proc.stderr.strip().splitlines()) == 1, proc
    assert str(path) in proc.stderr and "steering.layout 'skid'" in proc.stderr and "'crab'" in proc.stderr
