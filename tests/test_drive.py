"""The dcmotor drive (batchveh/model/drive.py) on the seed vehicle's climb against closed forms, on MuJoCo C
(2 cores): the steady speed on the voltage line, the first-order approach to it after a current-limited start,
and the winding (the resistance the simulated motor ran with, the one-node model, the sweep's column).

The climbs: 0.5, 1 and 2 deg on the slip tyre (no rolling resistance), 12 km/h asked over a 1 s ramp, more
than the motors' no-load speed (10.4 and 10.6 km/h), so each drive first accelerates the vehicle at its
current limit, then meets the voltage line and settles on it, below its no-load speed by the drop its share
of the weight's pull costs: (R(T) T / (eta N K)) / (K N), T = M g sin(slope) r / 4. Numbers measured here are
in validation/results/drive_checks.json."""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from batchveh.engines.mujoco import MujocoEngine
from batchveh.model.motors import COPPER_TEMPCOEF, REFERENCE_TEMP, load_catalogue
from batchveh.model.vehicle import MOTORS, layout
from batchveh.stepping.batch import make_batch
from batchveh.stepping.rollout import mujoco_steps
from batchveh.sweeping.spec import spec_from_mapping

pytestmark = pytest.mark.xdist_group("drive")  # one test worker: the module's shared fixtures run once

CATALOGUE = Path(__file__).resolve().parent.parent / "notebooks" / "motors.yaml"
EC45 = "maxon-EC45flat43-70W-24V_NPT015-i40"  # 5.05 N m at its current limit at the wheel, 14.85 rad/s no-load
FAULHABER = "faulhaber-3863H024CR_NPT015-i40"  # 5.96 N m, 15.08 rad/s
STEER = "maxon-353297-48V_NPT025-i40"
CASES = [(EC45, 0.5), (EC45, 1.0), (EC45, 2.0), (FAULHABER, 2.0)]  # (drive, slope in deg)
HEAT_CASE = (EC45, 2.0)  # 7.6 s at the current limit, then the line: the winding rises 10.2 K in 12.5 s
SPEED_KMH, TOTAL_TIME, RAMP_TIME = 12.0, 12.0, 1.0
WINDOW_S = 2.0  # the steady window: the run's last 2 s (the 2 deg climbs meet the line at 5.6 and 7.7 s)

# the bounds, and regression bounds a few times what this project's 2-core machine measured
LINE_RTOL = 0.05  # the drop below no-load against the closed form: measured |rel| <= 1.2e-3 (rear wheels, 2 deg)
LINE_REGRESSION = 5e-3  # a drive that kept R at 25 deg C on the line reads -2.0% to -3.8% here (checked)
AT_BUS_RTOL = 1e-9  # the terminal voltage over the steady window against the bus: measured 0 (the clamp's value)
# The approach's tau (log-linear fit, time to 63%) against the closed forms. Against the (M r^2 / 4) R /
# (eta N^2 K^2) it reads +8.9% to +11.7%; with the joint's own inertia (dof_M0: the wheel's spin, the rotor's J N^2,
# 0.086 and 0.076 kg m^2) added, +3.2% to +5.1%; the rest is the slip tyre's own slip compliance (the rigid
# contact, 2 deg: 0.348 s against 0.350 s) and implicitfast's step
TAU_RTOL = 0.20  # measured +8.9% to +11.7% (the form)
TAU_REGRESSION = 0.08  # measured +3.2% to +5.1% (the form with the joint's inertia)
T_FROM_R_TOL = 0.5  # K: the temperature the motor's resistance gives back against the drive's: measured 1.6e-8 K
TINY_CURRENT = 1e-3  # A (simulated i'): below it the resistance is not read from the trace
HEAT_ODE_TOL = 2e-3  # K: the winding against solve_ivp of the one-node model: measured 4.5e-4 K of a 10.2 K rise
# (the drive's explicit Euler step at 5 ms)
COLUMN_TOL = 1e-9  # K: the sweep's winding_temp_peak against the trace's maximum: measured 0 (the same float64)
AT_LIMIT_RTOL = 1e-6  # |F| >= K eta i_max (1 - this): at the current limit, as motor_stats counts it


def _spec(drive, slope, out):
    return spec_from_mapping(
        {
            "name": "drive",
            "scenario": "straight_line",
            "fixed": {"total_time": TOTAL_TIME, "ramp_time": RAMP_TIME, "slope_deg": slope, "speed_kmh": SPEED_KMH},
            "vehicle": {
                "tyre": {"model": "slip"},
                "motors": {"model": "dcmotor", "catalogue": str(CATALOGUE), "drive": drive, "steer": STEER},
            },
            "sweep": {"method": "zip", "params": {"payload.mass": [0.0]}},
            "output": str(out),
        },
        "test",
    )


def climb(drive, slope, out):
    """One climb's per-step trace on MuJoCo C, (n_steps, 8) each, settle included: the joint speeds before
    (the ones the drive and MuJoCo's force read) and after each step, the actuator force (K i'), the drive's
    record (T, the winding temperature the step ran with; v, the terminal voltage); and its constants."""
    spec = _spec(drive, slope, out)
    b = make_batch(spec.vehicle, spec.scenario, {})
    params = {k: float(v[0]) if np.ndim(v) == 1 else np.asarray(v[0]) for k, v in b.params.items()}
    m = b.model
    lay = layout(m)
    rec, speeds, force, temp, volt = {}, [], [], [], []
    for d, ctrl in mujoco_steps(m, params, scenario=spec.scenario, n_steps=spec.scenario.n_steps, record=rec):
        speeds.append(d.qvel[lay.motor_dof].copy())
        if ctrl is not None:
            force.append(d.actuator_force[lay.motor_act].copy())
            temp.append(np.array(rec["T"], float))
            volt.append(np.array(rec["v"], float))
    cat = load_catalogue(CATALOGUE)
    each = [cat[drive].resolved()] * 4 + [cat[STEER].resolved()] * 4
    c = {k: np.array([e[k] for e in each]) for k in ("K", "R", "V", "i_max", "R_T", "C", "N", "eta", "T_amb")}
    speeds = np.asarray(speeds)
    return {
        "spec": spec,
        "slope": slope,
        "dt": float(m.opt.timestep),
        "settle": spec.scenario.settle_steps,
        "mass": float(m.body_mass.sum()),
        "radius": float(params["wheel.radius"]),
        "gravity": float(spec.scenario.gravity),
        "joint_inertia": m.dof_M0[lay.motor_dof[:4]].copy(),  # the wheel's spin and the rotor's J N^2
        "before": speeds[:-1],
        "after": speeds[1:],
        "force": np.asarray(force),
        "T": np.asarray(temp),
        "v": np.asarray(volt),
        "c": c,
    }


@pytest.fixture(scope="module")
def climbs(tmp_path_factory):
    cache = {}

    def get(drive, slope):
        if (drive, slope) not in cache:
            cache[drive, slope] = climb(drive, slope, tmp_path_factory.mktemp("drive"))
        return cache[drive, slope]

    return get


def resistance(c, temp, j=slice(None)):
    """R(T) (Ohm, the real motor's) of motors j at winding temperatures temp."""
    return c["R"][j] * (1 + COPPER_TEMPCOEF * (temp - REFERENCE_TEMP))


def wheel_load(tr):
    """The torque each wheel gives the vehicle's weight on the climb, M g sin(slope) r / 4 (N m)."""
    return tr["mass"] * tr["gravity"] * math.sin(math.radians(tr["slope"])) * tr["radius"] / 4


def line(tr):
    """Per drive over the steady window: the measured drop below the no-load speed V / (K N) and the closed
    form's (R(T) load / (eta N K)) / (K N) at each step's T, their means (rad/s), and the largest
    |v / V - 1| there."""
    c, d = tr["c"], slice(0, 4)
    win = slice(len(tr["T"]) - int(round(WINDOW_S / tr["dt"])), None)
    kn = c["K"][d] * c["N"][d]
    measured = c["V"][d] / kn - tr["after"][win, d]
    closed = resistance(c, tr["T"][win, d], d) * wheel_load(tr) / (c["eta"][d] * kn) / kn
    return {
        "measured": measured.mean(0),
        "closed": closed.mean(0),
        "T": tr["T"][win, d].mean(0),
        "bus_dev": float(np.max(np.abs(tr["v"][win, d] / c["V"][d] - 1))),
    }


def approach(tr, j):
    """Drive j after its current-limited start: the step the current leaves its limit (k_off), the seconds
    held there, tau from the time to 63% of the gap to the line speed (the steady window's mean) and from a
    log-linear fit of the gap between 90% and 5% of it, and the closed forms at the approach's mean winding
    temperature: the issue's (M r^2 / 4) R(T) / (eta N^2 K^2), and with the joint's own inertia added."""
    c, dt = tr["c"], tr["dt"]
    at_i = np.abs(tr["force"][:, j]) >= c["K"][j] * c["eta"][j] * c["i_max"][j] * (1 - AT_LIMIT_RTOL)
    held = np.nonzero(at_i)[0]
    k_off = int(held[-1]) + 1
    w_line = tr["after"][len(tr["T"]) - int(round(WINDOW_S / dt)) :, j].mean()
    gap = w_line - tr["after"][k_off - 1 :, j]  # from the end of the last step at the limit
    g0 = gap[0]
    k63 = int(np.nonzero(gap <= g0 / math.e)[0][0])
    t63 = dt * (k63 - 1 + (gap[k63 - 1] - g0 / math.e) / (gap[k63 - 1] - gap[k63]))
    k05 = int(np.nonzero(gap <= 0.05 * g0)[0][0])
    sel = np.arange(k05)[gap[:k05] <= 0.9 * g0]
    fit = -1.0 / np.polyfit(dt * sel, np.log(gap[sel]), 1)[0]
    temp = tr["T"][k_off : k_off + k63, j].mean()
    damping = c["eta"][j] * (c["N"][j] * c["K"][j]) ** 2 / resistance(c, temp, j)
    vehicle = tr["mass"] * tr["radius"] ** 2 / 4
    return {
        "k_off": k_off,
        "held_s": dt * int(np.sum(at_i[:k_off])),
        "first_held": int(held[0]),
        "at_i_after": bool(at_i[k_off:].any()),
        "at_v_after": float(np.min(np.abs(tr["v"][k_off:, j]) / c["V"][j])),
        "gap0": float(g0),
        "t63": float(t63),
        "fit": float(fit),
        "tau_issue": float(vehicle / damping),
        "tau_full": float((vehicle + tr["joint_inertia"][j]) / damping),
        "T": float(temp),
    }


def temperature_from_resistance(tr):
    """|T from the resistance the simulated motor ran with - the drive's T| per step and motor ((v - K N w) /
    i', i' = F / K, w the joint speed the step's force read: R' = R(T) / eta), NaN where |i'| < TINY_CURRENT;
    and which of the checked samples were at the current limit and at the voltage line."""
    c = tr["c"]
    i_sim = tr["force"] / c["K"]
    read = np.abs(i_sim) >= TINY_CURRENT
    r_sim = (tr["v"] - c["K"] * c["N"] * tr["before"]) / np.where(read, i_sim, 1.0)
    temp = REFERENCE_TEMP + (r_sim * c["eta"] / c["R"] - 1) / COPPER_TEMPCOEF
    dev = np.where(read, np.abs(temp - tr["T"]), np.nan)
    at_i = np.abs(tr["force"]) >= c["K"] * c["eta"] * c["i_max"] * (1 - AT_LIMIT_RTOL)
    at_v = np.abs(tr["v"]) >= c["V"] * (1 - AT_LIMIT_RTOL)
    return dev, read & at_i, read & at_v


def one_node(tr):
    """solve_ivp of C dT/dt = i^2 R (1 + alpha (T - 25)) - (T - T_amb) / R_T for the 8 windings, the real
    current i = F / (K eta) held over each step as the drive heats with it, at each step's start."""
    c, dt = tr["c"], tr["dt"]
    current = tr["force"] / c["K"] / c["eta"]
    n = len(current)

    def rhs(t, temp):
        k = min(int(t / dt * (1 + 1e-12)), n - 1)
        return (current[k] ** 2 * resistance(c, temp) - (temp - c["T_amb"]) / c["R_T"]) / c["C"]

    times = dt * np.arange(n)
    sol = solve_ivp(rhs, (0.0, times[-1]), tr["T"][0], t_eval=times, rtol=1e-10, atol=1e-10, max_step=dt / 2)
    assert sol.success
    return sol.y.T


@pytest.mark.parametrize("drive, slope", CASES)
def test_a_climb_at_the_voltage_line_drops_below_no_load_by_its_weights_current(climbs, drive, slope):
    """Below the current limit and asked for more than the no-load speed, each drive settles at the bus
    voltage at V / (K N) less R(T) i / (K N), i the current that carries its quarter of the weight's pull."""
    tr = climbs(drive, slope)
    c = tr["c"]
    assert wheel_load(tr) < 0.5 * c["eta"][0] * c["N"][0] * c["K"][0] * c["i_max"][0]  # well below the limit
    no_load_kmh = c["V"][0] / (c["K"][0] * c["N"][0]) * tr["radius"] * 3.6
    assert SPEED_KMH > 1.1 * no_load_kmh  # asked for more than the motor can give: at the line
    got = line(tr)
    assert got["bus_dev"] <= AT_BUS_RTOL  # at the bus voltage at every step of the steady window
    assert np.all(got["T"] > REFERENCE_TEMP + 4)  # a warm winding: R(T) is not R
    np.testing.assert_allclose(got["measured"], got["closed"], rtol=min(LINE_RTOL, LINE_REGRESSION))
    assert np.all(got["measured"] > 0.005 * c["V"][0] / (c["K"][0] * c["N"][0]))  # a drop to measure: 0.96% at 0.5 deg


@pytest.mark.parametrize("drive, slope", CASES)
def test_after_a_current_limited_start_the_speed_approaches_the_line_as_a_first_order_lag(climbs, drive, slope):
    """The ramp asks for an acceleration the current cannot give: each drive starts at its current limit and
    holds it for seconds; it leaves it where its voltage meets the line, and the gap to the line speed then
    closes as exp(-t / tau), tau = I R(T) / (eta N^2 K^2), I = M r^2 / 4 (the issue's) or with the wheel's
    and rotor's own inertia at the joint."""
    tr = climbs(drive, slope)
    for j in range(4):
        a = approach(tr, j)
        assert a["first_held"] - tr["settle"] < int(round(0.1 / tr["dt"]))  # at the limit within 0.1 s of the ramp
        assert a["held_s"] > 4.0  # seconds at the limit (measured 4.5 to 7.6 s)
        assert not a["at_i_after"] and a["at_v_after"] >= 1 - AT_LIMIT_RTOL  # off the limit onto the line for good
        assert a["gap0"] > 0.03 * tr["after"][-1, j]  # a gap to close: measured 0.62 to 1.05 rad/s
        for tau, rtol in ((a["tau_issue"], TAU_RTOL), (a["tau_full"], min(TAU_RTOL, TAU_REGRESSION))):
            assert a["fit"] == pytest.approx(tau, rel=rtol)
            assert a["t63"] == pytest.approx(tau, rel=rtol)


@pytest.mark.parametrize("drive, slope", CASES)
def test_the_resistance_the_motor_ran_with_gives_back_the_winding_temperature(climbs, drive, slope):
    """At every step and for all 8 motors, MuJoCo's own force and speed with the drive's terminal voltage:
    (v - K N w) / i' = R(T) / eta, the temperature of which is the drive's, at the current limit (where MuJoCo's
    saturation clips the torque) and at the voltage line alike."""
    tr = climbs(drive, slope)
    dev, at_i, at_v = temperature_from_resistance(tr)
    assert np.nanmax(dev) <= T_FROM_R_TOL
    assert np.isfinite(dev[:, :4]).mean() > 0.99  # the drives carry current at (next to) every step
    assert at_i[:, :4].sum() > 1000 and at_v[:, :4].sum() > 1000  # both limits were read
    assert np.ptp(tr["T"][:, :4]) > 4.0  # over a rise of several kelvin


def test_the_winding_follows_the_one_node_model_and_the_sweep_reports_its_peak(climbs):
    """The drives' windings, heated at the current limit for 7 s, then on the line, against solve_ivp of the
    one-node model with the real current of the same trace; the steering windings too (a 0.03 K rise). The
    sweep's columns (MujocoEngine, the same climb) are the trace's: winding peak and end, the share at the
    voltage line, the current's peak."""
    tr = climbs(*HEAT_CASE)
    ref = one_node(tr)
    assert np.max(np.abs(tr["T"] - ref)) <= HEAT_ODE_TOL
    assert np.min(tr["T"][-1, :4] - tr["T"][0, :4]) > 8.0  # measured 10.2 K
    spec = tr["spec"]
    out = MujocoEngine(spec.scenario, spec.stats_config(), 1).run(make_batch(spec.vehicle, spec.scenario, {}))
    run = slice(tr["settle"], None)
    c = tr["c"]
    for j, name in enumerate(MOTORS):
        assert abs(out[f"{name}_winding_temp_peak"][0] - tr["T"][run, j].max()) <= COLUMN_TOL
        assert abs(out[f"{name}_winding_temp_end"][0] - tr["T"][-1, j]) <= COLUMN_TOL
        at_v = np.abs(tr["v"][run, j]) >= c["V"][j] * (1 - AT_LIMIT_RTOL)
        assert out[f"{name}_at_voltage_share"][0] == pytest.approx(at_v.mean(), abs=1e-12)
        peak = np.max(np.abs(tr["force"][run, j])) / c["K"][j] / c["eta"][j]
        assert out[f"{name}_current_peak"][0] == pytest.approx(peak, rel=1e-9)
    assert out["drive_lf_current_peak"][0] == pytest.approx(c["i_max"][0], rel=1e-9)  # the limit, not past it


def test_a_steering_motor_faster_than_the_step_keeps_a_positive_angle_gain():
    """A steering slot whose back-EMF damping dwarfs its inertia over dt (a mechanical time constant R J / K^2 of
    1e-6 s, at dt 5 ms: ffec2a4's HUB_LOCK on a 0.015 kg m^2 hub): kv stays below KV_STEER_CAP I / dt, so the
    angle gain's bound, KP_SHARE (4 - 2 kv dt / I) I / dt^2, stays positive (it was -9,116 N m/rad)."""
    from batchveh.model.drive import KV_STEER_CAP, gains

    dt, hub = 0.005, 0.015
    c = {"K": np.full(8, 1.0), "R": np.full(8, 0.01), "N": np.ones(8)}
    inertia = np.full(8, hub + 1e-4)  # the joint's own inertia with the rotor's J N^2
    out = gains(c, inertia, np.full(4, 0.5), dt, (0.0, 0.0), {})
    assert np.all(out["kp"][4:] > 0) and np.all(out["ki"][4:] > 0), out["kp"]
    assert np.all(out["kv"][4:] <= KV_STEER_CAP * inertia[4:] / dt * (1 + 1e-12))
