"""A catalogue motor as MuJoCo's dcmotor (batchveh/model/motors.py) against closed forms, on MuJoCo C.

The rig: one wheel (a 3 kg cylinder of radius 0.2 m) on a hinge, no gravity, no ground, driven by
the motor through its gearhead. Closed forms from MuJoCo's DC motor technical note and the one-node
thermal model, solved by scipy.
"""

import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from batchveh.config import ConfigError
from batchveh.model.motors import COPPER_TEMPCOEF, REFERENCE_TEMP, DCMotor, dcmotor_xml, pick

V, R, K, N, ETA = 24.0, 1.2, 0.05, 20.0, 0.8
MOTOR = DCMotor(
    "test-motor",
    nominal_voltage=V,
    terminal_resistance=R,
    torque_constant=K,
    thermal_resistance_winding_housing=2.0,
    thermal_resistance_housing_ambient=4.0,
    thermal_time_constant_winding=30.0,
    gear_ratio=N,
    gear_efficiency=ETA,
    rotor_inertia=1e-5,
)
# the bounds, and regression bounds a few times what this project's 2-core machine measured
SPEED_RTOL, SPEED_REGRESSION = 5e-3, 1e-9  # measured 7e-15
STALL_RTOL, STALL_REGRESSION = 5e-3, 1e-3  # measured 2.6e-4 (voltage-limited, 0.1 s after the start), 2e-16
THERMAL_RTOL, THERMAL_REGRESSION = 1e-2, 1e-4  # of the final rise: measured 1.1e-5 (9.2e-4 K of 82 K)
ENERGY_RTOL, ENERGY_REGRESSION = 5e-3, 3e-3  # measured 1.4e-3 (sums of 1 ms steps) and 3.1e-4 (work)


def _rig(motor: DCMotor, *, locked=False, damping=0.0, dt=1e-3) -> tuple[mujoco.MjModel, mujoco.MjData]:
    lock = '<equality><joint joint1="w" polycoef="0 0 0 0 0"/></equality>' if locked else ""
    m = mujoco.MjModel.from_xml_string(f"""<mujoco>
  <option timestep="{dt}" integrator="implicitfast" gravity="0 0 0"/>
  <worldbody><body><joint name="w" type="hinge" axis="0 1 0" damping="{damping}"/>
    <geom type="cylinder" size=".2 .05" zaxis="0 1 0" mass="3"/></body></worldbody>
  {lock}<actuator>{dcmotor_xml("m", "w", motor, thermal=True)}</actuator>
</mujoco>""")
    return m, mujoco.MjData(m)


def test_a_free_wheel_reaches_the_no_load_speed():
    """V / (K N) at the wheel, the gearhead's efficiency aside (it acts on torque, not on the back-EMF)."""
    m, d = _rig(MOTOR)
    d.ctrl[0] = V
    for _ in range(20_000):
        mujoco.mj_step(m, d)
    assert d.qvel[0] == pytest.approx(V / (K * N), rel=min(SPEED_RTOL, SPEED_REGRESSION))


@pytest.mark.parametrize("i_max", [None, 4.0])  # voltage-limited (V / R = 20 A), then current-limited
def test_a_blocked_wheel_gets_the_stall_or_current_limited_torque(i_max):
    motor = DCMotor(
        **{
            **vars(MOTOR),
            "max_continuous_current": i_max,
            "thermal_time_constant_winding": None,
            "thermal_resistance_winding_housing": None,
            "thermal_resistance_housing_ambient": None,
        }
    )
    m, d = _rig(motor, locked=True)
    d.ctrl[0] = V
    for _ in range(100):
        mujoco.mj_step(m, d)
    current = V / R if i_max is None else min(V / R, i_max)
    assert d.qfrc_actuator[0] == pytest.approx(ETA * N * K * current, rel=min(STALL_RTOL, STALL_REGRESSION))


def test_the_winding_follows_the_one_node_model_under_a_constant_current():
    """A blocked motor fed i R(T) (a current-controlled driver in the loop): the winding's rise above
    ambient against scipy's solution of C dT/dt = i^2 R0 (1 + alpha (T + T_a - T_0)) - T / R_T."""
    i, dt = 3.0, 1e-3
    m, d = _rig(MOTOR, locked=True, dt=dt)
    c = MOTOR.resolved()
    rise = []
    for _ in range(int(120 / dt)):
        r_t = R * (1 + COPPER_TEMPCOEF * (d.act[0] + c["T_amb"] - REFERENCE_TEMP))
        d.ctrl[0] = i * r_t  # at rest: no back-EMF
        mujoco.mj_step(m, d)
        rise.append(d.act[0])

    def dT(_, T):
        return [(i * i * R * (1 + COPPER_TEMPCOEF * (T[0] + c["T_amb"] - REFERENCE_TEMP)) - T[0] / c["R_T"]) / c["C"]]

    times = dt * np.arange(1, len(rise) + 1)
    ref = solve_ivp(dT, (0, times[-1]), [0.0], t_eval=times[::1000], rtol=1e-10, atol=1e-12).y[0]
    got = np.asarray(rise)[::1000]
    assert ref[-1] > 40  # a real rise: 82 K after 4 thermal time constants
    assert np.max(np.abs(got - ref)) <= min(THERMAL_RTOL, THERMAL_REGRESSION) * ref[-1]


def test_electrical_energy_is_work_copper_and_gearhead_loss():
    """A wheel spun up against viscous damping under a voltage step and a reversal (regeneration):
    the energy drawn v i equals the work at the wheel, the copper's i^2 R(T) and the gearhead's
    K i w_motor (1 - eta); the work at the wheel equals its kinetic energy and the damping's loss."""
    dt, b = 1e-3, 0.05
    m, d = _rig(MOTOR, damping=b, dt=dt)
    c = MOTOR.resolved()
    drawn = work = copper = gear = damped = 0.0
    for k in range(int(8 / dt)):
        d.ctrl[0] = V if k * dt < 5 else -0.5 * V
        w_before = d.qvel[0]
        mujoco.mj_step(m, d)
        w = 0.5 * (w_before + d.qvel[0])
        current = d.actuator_force[0] / c["K"] / ETA  # the real current: i' / eta (module's note)
        r_t = R * (1 + COPPER_TEMPCOEF * (d.act[0] + c["T_amb"] - REFERENCE_TEMP))
        drawn += d.ctrl[0] * current * dt
        work += d.qfrc_actuator[0] * w * dt
        copper += current * current * r_t * dt
        gear += c["K"] * current * N * w * (1 - ETA) * dt
        damped += b * w * w * dt
    mujoco.mj_forward(m, d)
    kinetic = 0.5 * d.M[0] * d.qvel[0] ** 2  # the wheel's inertia and the rotor's, reflected through N^2
    assert drawn == pytest.approx(work + copper + gear, rel=min(ENERGY_RTOL, ENERGY_REGRESSION))
    assert work == pytest.approx(kinetic + damped, rel=min(ENERGY_RTOL, ENERGY_REGRESSION))
    assert gear > 0.05 * drawn and copper > 0.05 * drawn  # both losses are there to be counted


@pytest.mark.parametrize(
    "fields, words",
    [
        (
            {
                "nominal_voltage": 24,
                "stall_torque": 2.0,
                "no_load_speed": 480,
                "terminal_resistance": 1.2,
                "torque_constant": 0.05,
            },
            ["terminal_resistance: 1.2 contradicts the datasheet triple", "gives 0.6", "5%"],
        ),
        (
            {"terminal_resistance": -1.2, "torque_constant": 0.05, "nominal_voltage": 24},
            ["terminal_resistance: -1.2 is not allowed", "> 0"],
        ),
        (
            {
                "terminal_resistance": 1.2,
                "torque_constant": 0.05,
                "nominal_voltage": 24,
                "thermal_time_constant_winding": 30.0,
            },
            ["thermal_time_constant_winding", "no thermal resistance"],
        ),
    ],
)
def test_an_impossible_motor_is_one_line(fields, words):
    with pytest.raises(ConfigError) as err:
        DCMotor("bad", **fields).resolved("catalogue")
    text = str(err.value)
    assert "\n" not in text and "catalogue bad" in text and all(w in text for w in words), text


def test_an_unknown_motor_name_suggests_the_nearest():
    with pytest.raises(ConfigError) as err:
        pick({"maxon-EC45": MOTOR, "maxon-RE40": MOTOR}, "maxon-EC46", "motors.drive")
    text = str(err.value)
    assert "\n" not in text and "did you mean 'maxon-EC45'" in text and "allowed: maxon-EC45, maxon-RE40" in text


# --- the vehicle with its motors as dcmotors (vehicle.motors.model: dcmotor) ---

import dataclasses  # noqa: E402
from pathlib import Path  # noqa: E402

from batchveh.engines.mujoco import MujocoEngine  # noqa: E402
from batchveh.model.scenarios import make_scenario  # noqa: E402
from batchveh.model.vehicle import MOTORS, Motors, Vehicle  # noqa: E402
from batchveh.stepping import stats  # noqa: E402
from batchveh.stepping.batch import make_batch  # noqa: E402
from batchveh.stepping.motor_stats import MotorStatsConfig  # noqa: E402

CLIMB_SUM_RTOL = 1e-3  # the four-wheel mean torque on a steady climb, dcmotors against the servo: measured 6.4e-5


def _catalogue(tmp_path, **drive):
    """A catalogue of two motors with every limit off (24 kV, no current limit, no thermal model) whose
    rotor reflects the servo's armature 0.2 kg m^2 through the ratio, and efficiency 1."""
    base = {"nominal_voltage": 24000.0, "terminal_resistance": 0.5, "torque_constant": 0.05, "rotor_inertia": 0.2 / 400}
    motors = [
        {"name": "drive-test", **base, "gearhead": {"ratio": 20.0, "efficiency": 1.0}, **drive},
        {"name": "steer-test", **base, "rotor_inertia": 0.2 / 2500, "gearhead": {"ratio": 50.0, "efficiency": 1.0}},
    ]
    import yaml

    path = tmp_path / "catalogue.yaml"
    path.write_text(yaml.safe_dump({"motors": motors}))
    return str(path)


def _dc_vehicle(path, **gains):
    return dataclasses.replace(
        Vehicle(), motors=Motors(model="dcmotor", catalogue=path, drive="drive-test", steer="steer-test", **gains)
    )


def test_dcmotors_with_every_limit_off_climb_as_the_servo_does(tmp_path):
    """Limits off and the drive's own gains: on a steady 8 deg climb the four wheels together give what the
    servo's do (the climb's physics), though the split between them differs (the servo's stiff angle loop
    holds the four wheels to one angle; the drive's speed loop lets them share the load otherwise: 10.9
    against 10.2 N m front). Every check passes: the drive neither chatters nor exceeds its motor."""
    sc = make_scenario("straight_line", total_time=2.0, slope_deg=8.0)
    table = {"friction": np.array([0.9, 0.6])}
    cfg = stats.StatsConfig.for_scenario(sc)
    servo = MujocoEngine(sc, cfg, 2).run(make_batch(Vehicle(), sc, table))
    v = _dc_vehicle(_catalogue(tmp_path))
    dc = MujocoEngine(sc, dataclasses.replace(cfg, motors=MotorStatsConfig.for_vehicle(v)), 2).run(
        make_batch(v, sc, table)
    )
    assert (np.asarray(servo["status_code"]) == 0).all() and (np.asarray(dc["status_code"]) == 0).all()
    np.testing.assert_allclose(dc["drive_sum_mean"], servo["drive_sum_mean"], rtol=CLIMB_SUM_RTOL)
    assert (np.asarray(dc["motor_check_code"]) == 0).all()


def test_the_servo_gains_on_a_dcmotor_chatter_and_the_run_says_so(tmp_path):
    """The servo's drive gains (kp 5000, kv 500) set by hand on a dcmotor with a 20 A limit: explicit in the
    drive, 500 N m s/rad on a wheel of 0.26 kg m^2 at 5 ms is five times what the step allows, and the torque
    flips between the current limits step after step (47% of the steps here). The run is `unstable`, its
    check `chatter`, whatever its speeds say."""
    from batchveh.stepping.motor_stats import MOTOR_CHECK, MOTOR_STATUS

    sc = make_scenario("straight_line", total_time=2.0, slope_deg=8.0)
    v = _dc_vehicle(_catalogue(tmp_path, max_continuous_current=20.0), dc_drive_kp=5000.0, dc_drive_kv=500.0)
    cfg = dataclasses.replace(stats.StatsConfig.for_scenario(sc), motors=MotorStatsConfig.for_vehicle(v))
    out = MujocoEngine(sc, cfg, 1).run(make_batch(v, sc, {"friction": np.array([0.9])}))
    assert MOTOR_STATUS[int(out["motor_status_code"][0])] == "unstable"
    assert MOTOR_CHECK[int(out["motor_check_code"][0])] == "chatter"
    assert out["motor_flip_share"][0] > 0.2
    default = _dc_vehicle(_catalogue(tmp_path, max_continuous_current=20.0))
    out = MujocoEngine(sc, cfg, 1).run(make_batch(default, sc, {"friction": np.array([0.9])}))
    assert MOTOR_STATUS[int(out["motor_status_code"][0])] != "unstable" and out["motor_flip_share"][0] == 0


WARP_SUM_RTOL = 1e-5  # warp (float32) against MuJoCo C: measured 2e-7 on the four-wheel mean (2 cores, warp on CPU)
WARP_WHEEL_RTOL = 1e-4  # a wheel's mean and peak: measured 1.3e-5


@pytest.mark.slow  # about 40 s on 2 cores: Warp builds its kernels for the CPU
def test_warp_runs_dcmotors_as_mujoco_c_does(tmp_path):
    """The rotor's inertia sits on the joint (MuJoCo Warp ignores an actuator's armature: there, a
    wheel's mean read 1% off C's)."""
    pytest.importorskip("warp")
    from batchveh.engines.warp import WarpEngine

    v = _dc_vehicle(_catalogue(tmp_path))
    sc = make_scenario("straight_line", total_time=1.0, slope_deg=8.0)
    table = {"friction": np.array([0.9, 0.6])}
    cfg = dataclasses.replace(stats.StatsConfig.for_scenario(sc), motors=MotorStatsConfig.for_vehicle(v))
    w = WarpEngine(sc, cfg, 2).run(make_batch(v, sc, table))
    c = MujocoEngine(sc, cfg, 2).run(make_batch(v, sc, table))
    np.testing.assert_allclose(w["drive_sum_mean"], c["drive_sum_mean"], rtol=WARP_SUM_RTOL)
    for k in ("drive_lf_mean", "drive_rr_mean", "drive_lf_peak_lp_all", "drive_lf_current_rms", "bus_energy_wh"):
        np.testing.assert_allclose(w[k], c[k], rtol=WARP_WHEEL_RTOL, err_msg=k)


# a drive's mean torque, warp against C over 10 s, N m at the wheel. The old drive held each wheel to its own
# angle setpoint, and float32's drift of a growing wheel angle read 0.027 N m of split until the angles were
# wrapped (1e-4 then); batchveh's drive (model/drive.py) integrates the speed error itself and reads no angle
SPLIT_ATOL = 2e-3


@pytest.mark.slow
def test_warp_keeps_the_front_rear_split_over_a_long_run(tmp_path):
    """On a nearly flat 10 s run the four drives carry 0.18-0.22 N m each, each held by its speed loop's
    integral: warp's float32 integrals must not drift from C's (a 1e-4 rad drift is 0.02 N m of split). The
    small motor of benchmarks/motors_warp_vs_c.yaml on the slip tyre, its variant 1."""
    pytest.importorskip("warp")
    from batchveh.engines.warp import WarpEngine
    from batchveh.sweeping.spec import load_spec

    spec = load_spec(Path(__file__).resolve().parent.parent / "benchmarks" / "motors_warp_vs_c.yaml")
    table = {"slope_deg": [0.161792], "friction": [0.753348], "speed_kmh": [3.450839], "payload.mass": [1.811008]}
    table = {k: np.asarray(v) for k, v in table.items()}
    cfg = spec.stats_config()
    w = WarpEngine(spec.scenario, cfg, 1).run(make_batch(spec.vehicle, spec.scenario, table))
    c = MujocoEngine(spec.scenario, cfg, 1).run(make_batch(spec.vehicle, spec.scenario, table))
    assert 0.15 < c["drive_lf_mean"][0] < c["drive_lr_mean"][0] < 0.25  # the rear carries more
    for k in ("drive_lf_mean", "drive_rf_mean", "drive_lr_mean", "drive_rr_mean"):
        assert abs(w[k][0] - c[k][0]) < SPLIT_ATOL, (k, w[k][0], c[k][0])


CLIMB_RTOL, CLIMB_REGRESSION = 1e-2, 1e-3  # the bound; measured 1.4e-4 (MuJoCo C, 2 cores)


def test_a_climb_too_steep_for_the_speed_sits_on_the_voltage_line(tmp_path):
    """24 V, K 0.05, R 0.5, eta 0.9, N 20 (no-load 24 rad/s at the wheel) on a 15 deg climb asked for
    12 km/h (17 rad/s): each wheel settles where the voltage line meets its own load, w = (V - R i) /
    (K N) with i = T / (eta N K) from the wheel's mean torque (its load share); the four wheels' mean
    against the sweep's wheel_speed. The motors sit at the voltage line through the window.

    30 s, as with MuJoCo's own controller, whose kd slowed the approach to the line about 2.5x; batchveh's
    drive leaves the back-EMF's N^2 K^2 / R' as the only damping there (the approach: tests/test_drive.py)."""
    path = _catalogue(
        tmp_path, nominal_voltage=24.0, terminal_resistance=0.5, gearhead={"ratio": 20.0, "efficiency": 0.9}
    )
    v = _dc_vehicle(path)
    sc = make_scenario("straight_line", total_time=30.0, ramp_time=1.0, slope_deg=15.0, speed_kmh=12.0, friction=1.0)
    cfg = dataclasses.replace(stats.StatsConfig.for_scenario(sc), motors=MotorStatsConfig.for_vehicle(v))
    out = MujocoEngine(sc, cfg, 1).run(make_batch(v, sc, {"slope_deg": np.array([15.0])}))
    assert int(out["status_code"][0]) == 0
    predicted = []
    for c in ("lf", "rf", "lr", "rr"):
        current = out[f"drive_{c}_mean"][0] / (0.9 * 20 * 0.05)
        predicted.append((24.0 - 0.5 * current) / (0.05 * 20))
    assert out["wheel_speed"][0] == pytest.approx(np.mean(predicted), rel=min(CLIMB_RTOL, CLIMB_REGRESSION))
    assert out["wheel_speed"][0] < 0.9 * (12 / 3.6) / Vehicle().wheel.radius  # it could not keep up
    assert all(out[f"drive_{c}_at_voltage_share"][0] > 0.5 for c in ("lf", "rf", "lr", "rr"))
    assert bool(out["motor_limited"][0])
    drawn = sum(out[f"{m}_energy_drawn"][0] - out[f"{m}_energy_regen"][0] for m in MOTORS)
    assert out["bus_energy_wh"][0] * 3600 == pytest.approx(drawn, rel=1e-12)


def test_the_catalogue_holds_six_cited_motors_whose_datasheet_values_agree():
    """notebooks/motors.yaml: every entry loads (K, R and the nominal triple within 5%), at least
    six, each citing its source (a motor at a ratio of a gearhead series: its motor's entry and its series both),
    with a thermal model and a gearhead."""
    from pathlib import Path

    from batchveh.config import load_yaml
    from batchveh.model.motors import load_catalogue

    path = Path(__file__).resolve().parent.parent / "notebooks" / "motors.yaml"
    motors = load_catalogue(path)
    data = load_yaml(path)
    raw = {m["name"]: m for m in data["motors"]}
    by_motor = {m.get("motor", m["name"]): m for m in data["motors"]}
    series = {s["name"]: s for s in data.get("gearhead_series", [])}
    assert len(motors) >= 6
    for name, motor in motors.items():
        c = motor.resolved(name)
        entry = raw.get(name) or by_motor[motor.motor_name]
        assert str(entry.get("source", "")).startswith("http"), name
        if motor.series:
            assert str(series[motor.series].get("source", "")).startswith("http"), name
        assert c["R_T"] > 0 and c["C"] > 0 and c["N"] > 1 and 0 < c["eta"] < 1, name
