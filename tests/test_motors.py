"""Motor sizing against hand-computed values: one API (batchveh.sizing.screen, in_loop) over one
catalogue format (notebooks/motors.yaml's, batchveh.load_catalogue) and its battery (batchveh.load_battery)."""

import re

import numpy as np
import pandas as pd
import pytest
import yaml

import batchveh
from batchveh import sizing
from batchveh.config import ConfigError
from batchveh.model.motors import DCMotor
from batchveh.sizing import REASONS, demand, screen, screen_one

WHEELS = ("drive_lf", "drive_rf", "drive_lr", "drive_rr")

# K 0.05 N m/A, R 1.2 Ohm, 24 V, 4 A continuous, N 20, eta 0.8: at the wheel 0.8 x 20 x 0.05 = 0.8 N m per A;
# no-load 480 rad/s at the motor (24 rad/s at the wheel); R_T 6 K/W, max 125 deg C; J N^2 = 1e-5 x 400 = 4e-3
DC = DCMotor(
    "dc-test",
    nominal_voltage=24.0,
    terminal_resistance=1.2,
    torque_constant=0.05,
    max_continuous_current=4.0,
    thermal_resistance_winding_housing=2.0,
    thermal_resistance_housing_ambient=4.0,
    thermal_time_constant_winding=30.0,
    max_winding_temperature=125.0,
    gear_ratio=20.0,
    gear_efficiency=0.8,
    gear_max_intermittent_torque=12.0,
    gear_max_input_speed=400.0,
    rotor_inertia=1e-5,
)


def _frame(rms, peak, speed, window=None):
    """A servo sweep's rows by hand: `peak` the whole run's low-pass peak (a ramp's too), `window` the steady
    window's (default: the RMS, a steady run's torque)."""
    cols = {"wheel_speed": speed, "slope_deg": np.arange(len(rms), dtype=float)}
    for w in WHEELS:
        cols[f"{w}_rms"], cols[f"{w}_peak_lp_all"] = rms, peak
        cols[f"{w}_peak_lp"] = rms if window is None else window
    return pd.DataFrame({k: np.asarray(v, float) for k, v in cols.items()})


def _plain(name, i_max, resistance):
    """No thermal model, 24 V, K 0.1 N m/A, N 10, eta 1: 1 N m at the wheel per A, no-load 24 rad/s at the wheel."""
    return DCMotor(
        name,
        nominal_voltage=24.0,
        terminal_resistance=resistance,
        torque_constant=0.1,
        max_continuous_current=i_max,
        gear_ratio=10.0,
        gear_efficiency=1.0,
    )


def test_demand_is_the_worst_of_the_four_drives_at_the_wheel():
    """|torque| of the worst wheel, each statistic on its own (the RMS of one wheel, the peak of another)."""
    df = pd.DataFrame(
        {
            "wheel_speed": [-3.0, 2.0],
            "drive_lf_rms": [1.0, -5.0],
            "drive_rf_rms": [-2.5, 1.0],
            "drive_lr_rms": [0.5, 0.5],
            "drive_rr_rms": [0.0, 0.0],
            "drive_lf_peak_lp_all": [4.0, 1.0],
            "drive_rf_peak_lp_all": [1.0, 1.0],
            "drive_lr_peak_lp_all": [-7.0, 1.0],
            "drive_rr_peak_lp_all": [1.0, 9.0],
        }
    )
    need = demand(df)
    assert list(need.rms) == [2.5, 5.0] and list(need.peak) == [7.0, 9.0] and list(need.speed) == [3.0, 2.0]


def test_screen_names_each_reason_from_closed_forms():
    """One variant per reason, each just past its limit, and one that fits every limit."""
    df = _frame(
        # fits; rms: 3.3 N m = 4.125 A > 4 A; thermal: runaway-free but hot; voltage; speed; a whole-run peak
        # of 12.5 N m (a ramp's) that the 3.2 N m motor never gives; the steady window's peak 3.3 N m = 4.125 A
        # above the 4 A limit (its RMS 2 N m fits)
        rms=[2.0, 3.3, 3.1, 1.0, 0.5, 1.0, 2.0],
        peak=[4.0, 3.3, 3.1, 11.0, 0.5, 12.5, 3.3],
        speed=[10.0, 10.0, 10.0, 20.0, 19.5, 5.0, 10.0],
        window=[2.0, 3.3, 3.1, 3.0, 0.5, 1.0, 3.3],
    )
    res = screen_one(demand(df), DC)
    # at the wheel, 0.8 N m per A: variant 0 draws 2.5 A RMS, 5 A at its whole-run peak, 200 rad/s at the motor;
    # the voltage at its window's peak (2 N m = 2.5 A)
    assert res.current_rms[0] == pytest.approx(2.0 / 0.8) and res.current_peak[0] == pytest.approx(5.0)
    assert res.voltage_peak[0] == pytest.approx(2.5 * 1.2 + 0.05 * 200.0)
    # steady rise: heat = 6 K/W x i^2 x 1.2 Ohm at 25 deg C (R's reference), alpha 0.0039 feeding back
    heat = 6.0 * (3.1 / 0.8) ** 2 * 1.2
    assert res.winding_temperature[2] == pytest.approx(25 + heat / (1 - 0.0039 * heat))
    # the window's peak at most the bound, 3.2 N m = 4 A: row 1's 4.125 A reads 4 A x 1.2 + 10 V
    assert res.voltage_peak[1] == pytest.approx(4.0 * 1.2 + 0.05 * 200.0)
    expect = {
        0: set(),
        1: {"rms", "thermal", "peak"},  # 4.125 A: over 4 A, and 25 + 235 deg C; its window peaks at 4.125 A
        2: {"thermal"},  # 3.875 A, under 4 A, but 25 + 187 deg C (108 K before R(T) feeds back)
        3: {"voltage"},  # the window's 3 N m = 3.75 A: 3.75 x 1.2 + 0.05 x 400 = 24.5 V > 24 V
        4: set(),  # 19.5 rad/s at the wheel = 390 rad/s at the motor: under no-load 480 and the gear's 400
        5: set(),  # 12.5 N m whole-run peak > 12 N m intermittent, but the motor gives at most 3.2 N m
        6: {"peak"},  # the window's 3.3 N m = 4.125 A > 4 A; 2.5 A RMS; 4 A x 1.2 + 10 = 14.8 V < 24 V
    }
    got = {i: {r for r in REASONS if res[r][i]} for i in range(len(df))}
    assert got == expect, got
    # a motor that gives 16 N m (20 A): row 5's 12.5 N m peak passes the gearhead's 12 N m intermittent rating
    strong = DCMotor(**{**vars(DC), "name": "dc-20A", "max_continuous_current": 20.0})
    assert bool(screen_one(demand(df), strong).gear_torque[5])
    # past the no-load speed: 24.5 rad/s at the wheel = 490 rad/s > 480 (and past the gear's 400)
    fast = screen_one(pd.DataFrame({"rms": [0.1], "peak": [0.1], "speed": [24.5]}), DC)
    assert bool(fast.speed[0]) and bool(fast.gear_speed[0])


def test_screen_with_share_one_is_the_smallest_motor_that_covers_every_variant():
    """Three motors, given largest first, ranked by their continuous torque at the wheel eta N K i_max (5, 10,
    20 N m); at 1 N m per A the rows draw 4 and 8 A RMS, 10 and 16 A peak at 100 and 120 rad/s of motor speed."""
    df = _frame(rms=[4.0, 8.0], peak=[10.0, 16.0], speed=[10.0, 12.0])
    small = _plain("S", 5.0, 1.0)  # row 1: 8 A > 5 A (RMS and the window's peak); 5 A x 1 Ohm + 12 V = 17 V
    mid = _plain("M", 10.0, 0.5)  # row 1: 16 x 0.5 + 12 = 20 V: fits both rows
    big = _plain("L", 20.0, 0.5)  # fits too, larger
    best, table, failing = screen(df, {"L": big, "S": small, "M": mid}, share=1.0)
    assert best == "M"
    assert list(table.motor) == ["S", "M", "L"]
    np.testing.assert_allclose(table.continuous_torque_at_wheel, [5.0, 10.0, 20.0])
    np.testing.assert_allclose(table.coverage, [0.5, 1.0, 1.0])
    s = table.set_index("motor").loc["S"]
    assert (s.fails_rms, s.fails_peak, s.fails_voltage, s.fails_speed, s.fails_thermal) == (1, 1, 0, 0, 0)
    assert list(failing["S"].slope_deg) == [1.0] and failing["M"].empty and failing["L"].empty
    assert set(REASONS) <= set(failing["S"].columns)
    assert screen(df, {"S": small}, share=1.0)[0] is None  # none covers every variant
    assert screen(df, {"L": big, "S": small}, share=0.5)[0] == "S"  # half the variants: the small one


def test_screen_picks_the_smallest_that_covers_the_share_and_lists_the_failures():
    df = _frame(rms=[1.0] * 99 + [3.3], peak=[2.0] * 100, speed=[5.0] * 100)
    # twice the torque per ampere: 3.3 N m is 2.06 A, 60 deg C; continuous 6.4 N m at the wheel against 3.2
    big = DCMotor(**{**vars(DC), "name": "dc-big", "torque_constant": 0.1})
    best, table, failing = screen(df, {"dc-test": DC, "dc-big": big}, share=0.99)
    assert best == "dc-test"  # 99 of 100 fit: the one at 3.3 N m fails on RMS and heat
    row = table.set_index("motor").loc["dc-test"]
    assert row.coverage == pytest.approx(0.99) and row.fails_rms == 1 and row.fails_thermal == 1
    assert list(failing["dc-test"].slope_deg) == [99.0] and failing["dc-big"].empty
    best, _, _ = screen(df, {"dc-test": DC, "dc-big": big}, share=1.0)
    assert best == "dc-big"
    with pytest.raises(ConfigError, match="share: 0 is not allowed"):
        screen(df, {"dc-test": DC}, share=0)


def _mission_frame(spans: dict) -> pd.DataFrame:
    cols = {}
    for span, (rms, peak, speed) in spans.items():
        for m in WHEELS:
            cols[f"{span}_{m}_rms"], cols[f"{span}_{m}_peak_lp"], cols[f"{span}_{m}_speed_peak"] = rms, peak, speed
    return pd.DataFrame({k: np.asarray(v, float) for k, v in cols.items()})


def test_a_mission_span_is_screened_on_its_own_rms_peak_and_peak_speed():
    """span='mission' or a segment's prefix reads <span>_<motor>_rms, _peak_lp and _speed_peak. The climb's
    second row: 3.3 N m RMS = 4.125 A > 4 A (and 25 + 235 deg C), 4 N m peak = 5 A, above the 4 A limit, at 22
    rad/s at the wheel = 440 rad/s at the motor: 5 x 1.2 + 0.05 x 440 = 28 V > 24 V, and 440 > the gearhead's 400
    rad/s input (but under the no-load 480). The whole mission's RMS, peak and speed fit (3 N m peak = 3.75 A), but
    span='mission' also checks each segment on its own: the climb's second row fails there on its instantaneous
    limits (not on the climb's own RMS: the cycle's heat is the whole cycle's)."""
    df = _mission_frame(
        {"mission": ([2.0, 2.0], [3.0, 3.0], [10.0, 10.0]), "seg3_climb": ([2.0, 3.3], [3.0, 4.0], [10.0, 22.0])}
    )
    best, table, failing = screen(df, {"dc-test": DC}, share=1.0, span="mission")
    assert best is None and table.coverage[0] == 0.5
    bad = failing["dc-test"]
    assert {r for r in REASONS if bad.loc[1, r]} == {"voltage", "gear_speed", "peak"}
    assert bad.loc[1, "where"] == "seg3_climb: voltage at 22 rad/s"
    best, table, failing = screen(df, {"dc-test": DC}, share=1.0, span="seg3_climb")
    assert best is None and table.coverage[0] == 0.5
    bad = failing["dc-test"]
    assert list(bad.index) == [1]
    assert {r for r in REASONS if bad.loc[1, r]} == {"rms", "thermal", "voltage", "gear_speed", "peak"}
    need = demand(df, span="seg3_climb")
    assert list(need.speed) == [10.0, 22.0] and list(need.rms) == [2.0, 3.3]


def _wheels_frame(span: str, wheels: list[dict], names=WHEELS) -> pd.DataFrame:
    """One row per entry of `wheels` ({motor: (peak_lp, drive_peak_lp, speed_peak)}, the others 0 N m at
    10 rad/s), for `span`, and a mission span that fits (2 N m RMS, 3 N m peak at 10 rad/s)."""
    cols = {}
    for m in names:
        got = [w.get(m, (0.0, 0.0, 10.0)) for w in wheels]
        cols[f"{span}_{m}_rms"] = [0.5] * len(wheels)
        cols[f"{span}_{m}_peak_lp"], cols[f"{span}_{m}_drive_peak_lp"], cols[f"{span}_{m}_speed_peak"] = zip(
            *got, strict=True
        )
        cols[f"mission_{m}_rms"], cols[f"mission_{m}_peak_lp"] = [2.0] * len(wheels), [3.0] * len(wheels)
        cols[f"mission_{m}_drive_peak_lp"], cols[f"mission_{m}_speed_peak"] = [3.0] * len(wheels), [10.0] * len(wheels)
    return pd.DataFrame({k: np.asarray(v, float) for k, v in cols.items()})


def test_a_duty_cycles_voltage_is_read_wheel_by_wheel_on_the_torque_that_drives():
    """dc-test at the wheel: i = T / 0.8, v = 1.2 i + 0.05 x 20 w (no gearhead speed limit here); 24 V. The
    stop's rows: 0, every wheel brakes at 3 N m from 22 rad/s (a braking torque needs less voltage): 0.98 x 22 =
    21.6 V; 1, lf drives 3 N m at 10 rad/s while rr spins free at 22: max(4.5 + 9.8, 21.6) = 21.6 V; 2, lf drives
    3 N m at 22 rad/s: 4.5 + 21.6 = 26.1 V, over; 3, lf drives 1 N m at 22.9 rad/s: 1.5 + 22.4 = 23.9 V, within
    the 2% behind its speed that the loop does not count as short (1.5 + 22.9 = 24.4 V at full speed). Read as
    before (the segment's largest |torque| at its largest speed, at full speed) all four fail (26.5, 26.5, 26.5,
    24.4 V)."""
    free = DCMotor(**{**vars(DC), "name": "dc-free", "gear_max_input_speed": None})
    wheels = [
        {m: (3.0, 0.0, 22.0) for m in WHEELS},
        {"drive_lf": (3.0, 3.0, 10.0), "drive_rr": (0.0, 0.0, 22.0)},
        {"drive_lf": (3.0, 3.0, 22.0)},
        {"drive_lf": (1.0, 1.0, 22.9)},
    ]
    df = _wheels_frame("seg1_stop", wheels)
    _, table, failing = screen(df, {"dc-free": free}, share=1.0, span="mission")
    bad = failing["dc-free"]
    assert list(bad.index) == [2] and {r for r in REASONS if bad.loc[2, r]} == {"voltage"}
    assert bad.loc[2, "where"] == "seg1_stop: voltage at 22 rad/s"
    old = df.drop(columns=[c for c in df if c.endswith("_drive_peak_lp")])
    _, _, failing = screen(old, {"dc-free": free}, share=1.0, span="mission")
    assert list(failing["dc-free"].index) == [0, 1, 2, 3]
    # --span on the one segment reads it the same way
    _, _, failing = screen(df, {"dc-free": free}, share=1.0, span="seg1_stop")
    assert list(failing["dc-free"].index) == [2]
    # a steering motor is judged on its time at the line, not on a distance it may fall behind: row 3's 24.4 V
    # at its full peak rate fails it
    steer = [{m.replace("drive", "steer"): v for m, v in w.items()} for w in wheels]
    names = tuple(m.replace("drive", "steer") for m in WHEELS)
    both = pd.concat([_wheels_frame("seg1_stop", [{}] * 4), _wheels_frame("seg1_stop", steer, names)], axis=1)
    _, _, failing = screen(both, {"dc-free": free}, share=1.0, group="steer", span="mission")
    assert list(failing["dc-free"].index) == [2, 3]


def test_the_screen_counts_a_drive_over_the_variants_judged():
    """As the loop counts a drive over the runs whose steering held: the one variant that fails on RMS is not
    judged, so the coverage is 99 of 99 and no reason is counted."""
    df = _frame(rms=[1.0] * 99 + [3.3], peak=[2.0] * 100, speed=[5.0] * 100)
    judged = np.arange(100) < 99
    best, table, failing = screen(df, {"dc-test": DC}, share=1.0, judged=judged)
    row = table.iloc[0]
    assert best == "dc-test" and row.coverage == 1.0 and row.judged == 99 and row.fails_rms == 0
    assert failing["dc-test"].empty
    best, table, _ = screen(df, {"dc-test": DC}, share=1.0)
    assert best is None and table.judged[0] == 100 and table.fails_rms[0] == 1


def test_the_loop_names_a_speed_miss_by_the_segment_that_asks_it():
    """The servo's peak wheel speed passes the no-load speed (24 rad/s at the wheel) first in seg2 for row 0,
    in seg1 for row 1, nowhere for row 2."""
    from batchveh.sizing.loop import _first_segment_above

    servo = pd.DataFrame(
        {
            f"seg{k}_{name}_{m}_speed_peak": v
            for k, name, v in ((1, "cruise", [10.0, 25.0, 10.0]), (2, "turn", [24.5, 30.0, 23.0]))
            for m in WHEELS
        }  # fmt: skip
    )
    servo = servo.assign(**{f"seg{k}_{n}_{m}_rms": 1.0 for k, n in ((1, "cruise"), (2, "turn")) for m in WHEELS})
    assert list(_first_segment_above(servo, 24.0)) == ["seg2_turn", "seg1_cruise", ""]


def test_the_rotor_inertia_is_reflected_only_with_accel():
    """peak + max(J N^2 - armature, 0) |accel| with J N^2 = 4e-3 kg m^2: with accel 500 rad/s^2 and no servo
    armature, 4 N m becomes 6 N m (7.5 A); with armature 1e-3 simulated already, 5.5 N m (6.875 A); with an
    armature above J N^2, nothing; with the defaults (0, 0), nothing."""
    need = pd.DataFrame({"rms": [1.0, 1.0], "peak": [4.0, 4.0], "speed": [0.0, 0.0]})
    np.testing.assert_allclose(screen_one(need, DC).current_peak, [5.0, 5.0])
    np.testing.assert_allclose(screen_one(need, DC, accel=500.0).current_peak, [7.5, 7.5])
    np.testing.assert_allclose(screen_one(need, DC, accel=-500.0).current_peak, [7.5, 7.5])
    np.testing.assert_allclose(screen_one(need, DC, armature=1e-3, accel=500.0).current_peak, [6.875, 6.875])
    np.testing.assert_allclose(screen_one(need, DC, armature=0.01, accel=500.0).current_peak, [5.0, 5.0])
    np.testing.assert_allclose(screen_one(need, DC, accel=np.array([0.0, 500.0])).current_peak, [5.0, 7.5])
    # through screen, on a motor that gives 16 N m (20 A): 11 N m + 4e-3 x 500 = 13 N m passes the gearhead's
    # 12 N m intermittent rating
    strong = DCMotor(**{**vars(DC), "name": "dc-20A", "max_continuous_current": 20.0})
    df = _frame(rms=[1.0], peak=[11.0], speed=[0.0])
    assert screen(df, {"dc-20A": strong}, share=1.0)[0] == "dc-20A"
    best, table, _ = screen(df, {"dc-20A": strong}, share=1.0, accel=500.0)
    assert best is None and table.fails_gear_torque[0] == 1 and table.fails_voltage[0] == 0


def test_the_loaders_are_public_in_one_place():
    from batchveh.model.motors import load_catalogue

    assert batchveh.load_catalogue is load_catalogue
    assert batchveh.load_battery is sizing.load_battery
    assert {"load_spec", "load_catalogue", "load_battery"} <= set(batchveh.__all__)
    for name in ("load_spec", "load_catalogue", "load_battery"):
        assert "->" in batchveh.__doc__.split(f"`{name}(")[1].split("\n")[0], name  # each with what it returns
    # one sizing API: the older torque-envelope path is gone
    for old in ("Motor", "load_motors", "from_dcmotor", "check", "check_mission", "smallest"):
        assert not hasattr(sizing, old), old


def test_the_documented_catalogue_format_reads_as_written(tmp_path):
    """batchveh.sizing's docstring's catalogue entry and battery, through the public loaders: K 0.131 N m/A,
    R 6.89 Ohm, 48 V, 0.936 A, R_T 4.1 + 3.56 = 7.66 K/W, N 40, eta 0.95, the gearhead's ratings; the battery
    48 V x 20 Ah = 960 Wh, and at 20 A (48 - 20 x 0.3) x 20 = 840 W."""
    text = re.search(r"```yaml\n(.*?)```", sizing.__doc__, re.S).group(1)
    path = tmp_path / "catalogue.yaml"
    path.write_text(text)
    assert yaml.safe_load(text)["motors"][0]["gearhead"]["ratio"] == 40.0
    catalogue = batchveh.load_catalogue(path)
    assert list(catalogue) == ["maxon-EC45flat-70W-48V_NPT015-i40"]
    m = catalogue["maxon-EC45flat-70W-48V_NPT015-i40"]
    c = m.resolved()
    assert (c["K"], c["R"], c["V"], c["i_max"], c["N"], c["eta"]) == (0.131, 6.89, 48.0, 0.936, 40.0, 0.95)
    assert c["R_T"] == pytest.approx(7.66) and c["t_T"] == pytest.approx(29.6) and c["T_max"] == 125.0
    gear = (m.gear_max_continuous_torque, m.gear_max_intermittent_torque, m.gear_max_input_speed)
    assert gear == (22.0, 42.0, 1047.2)
    battery = batchveh.load_battery(path)
    assert battery.energy_wh == pytest.approx(960.0) and battery.max_power == pytest.approx(840.0)


def test_the_loaders_refuse_in_one_line(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("motors:\n  - {torque_constant: 0.1, terminal_resistance: 1.0, nominal_voltage: 24}\n")
    with pytest.raises(ConfigError, match=r"motors\[0\]: name: missing"):
        batchveh.load_catalogue(p)
    # K 0.2 contradicts the triple's V / no_load_speed = 24 / 240 = 0.1
    p.write_text(
        "motors:\n  - {name: A, nominal_voltage: 24, stall_torque: 2.4, no_load_speed: 240, torque_constant: 0.2}\n"
    )
    with pytest.raises(ConfigError, match="torque_constant: 0.2 contradicts the datasheet triple"):
        batchveh.load_catalogue(p)
    with pytest.raises(ConfigError, match="battery: missing"):
        batchveh.load_battery(p)
    # a misspelt field is named, never replaced by Battery's default (10 A h)
    p.write_text("battery: {nominal_voltage: 48, capacty: 20, internal_resistance: 0.3, "
                 "max_continuous_discharge_current: 20}\n")  # fmt: skip
    with pytest.raises(ConfigError, match=r"battery: capacity: missing \(did you mean 'capacty'\?\)"):
        batchveh.load_battery(p)


def test_in_loop_reads_a_spec_path_and_refuses_a_bad_name_in_one_line(tmp_path):
    """in_loop's `spec` may be the sweep YAML's path (read with batchveh.load_spec, not an AttributeError);
    a candidate or steering name not in the catalogue is one ConfigError line, before anything runs."""
    from pathlib import Path

    catalogue = Path(__file__).resolve().parent.parent / "notebooks" / "motors.yaml"
    steer = "maxon-353297-48V_NPT025-i40"
    spec = tmp_path / "s.yaml"
    spec.write_text(
        yaml.safe_dump(
            {
                "name": "s",
                "scenario": "straight_line",
                "fixed": {"total_time": 1.0, "ramp_time": 0.5},
                "sweep": {"method": "grid", "params": {"slope_deg": [0.0, 5.0]}},
                "output": str(tmp_path / "out"),
            }
        )
    )
    df = pd.DataFrame({"slope_deg": [0.0, 5.0]})
    for given in (spec, str(spec)):
        with pytest.raises(ConfigError, match=r"candidates: 'maxon-353297-48V_NPT025-i4' .*did you mean"):
            sizing.in_loop(given, df, catalogue, ["maxon-353297-48V_NPT025-i4"], steer=steer)
    with pytest.raises(ConfigError, match=r"steer: 'nope' is not in the catalogue"):
        sizing.in_loop(spec, df, catalogue, [steer], steer="nope")


def test_a_span_that_is_not_there_is_one_line():
    """A servo sweep's rows screened on a mission span they do not have: one ConfigError line naming it."""
    from batchveh.sizing import demand

    df = pd.DataFrame({f"drive_{c}_rms": [1.0] for c in ("lf", "rf", "lr", "rr")})
    with pytest.raises(ConfigError, match=r"span: 'mission' has no column mission_drive_lf_rms") as err:
        demand(df, span="mission")
    assert "\n" not in str(err.value)


def test_the_four_drives_share_what_one_clipped_wheel_cannot_give():
    """0.8 N m per A, 3.2 N m bound. Row 0: the worst wheel 3.6 N m RMS and window peak, the others 2.0: mean 2.4
    fits, so the worst is taken at 3.2 N m (4 A, not over 4 A): no rms, no peak (the loop held such climbs with
    that wheel at its bound). Row 1: worst 3.6, others 3.4: mean 3.45 > 3.2: judged alone, 4.5 A > 4 A."""
    worst, rest = [3.6, 3.6], [2.0, 3.4]
    cols = {"wheel_speed": [5.0, 5.0]}
    for i, w in enumerate(WHEELS):
        v = worst if i == 2 else rest
        cols[f"{w}_rms"], cols[f"{w}_peak_lp"], cols[f"{w}_peak_lp_all"] = v, v, v
    df = pd.DataFrame({k: np.asarray(v, float) for k, v in cols.items()})
    res = screen_one(demand(df), DC)
    assert res.current_rms[0] == pytest.approx(4.0) and res.current_rms[1] == pytest.approx(4.5)
    assert {r for r in REASONS if res[r][0]} == {"thermal"}  # 4 A: 25 + 6 x 16 x 1.2 / (1 - 0.0039 x 115.2)
    assert {"rms", "peak"} <= {r for r in REASONS if res[r][1]}
    # the steering's four motors hold each its own wheel: no sharing
    steer = df.rename(columns=lambda c: c.replace("drive_", "steer_"))
    assert demand(steer, "steer").peak_window[0] == pytest.approx(3.6) and "rms_mean" not in demand(steer, "steer")


def test_rms_alone_and_the_duty():
    """A motor with no thermal model (the screen's rms the only current check): 3.3 N m RMS = 4.125 A > 4 A, its
    window's low-pass peak 3.1 N m (3.875 A: a fast ripple's peak filtered below its RMS) fails on RMS alone. At
    duty 0.5 (the run half the time): sqrt(0.5) x 4.125 = 2.92 A, and the heat halves (the DC motor: 25 + 235 deg C
    back to back, 25 + 6 x 0.5 x 17.0 x 1.2 / (1 - 0.0039 x 61.3) = 105.5 deg C at half duty)."""
    cold = DCMotor(**{**{k: v for k, v in vars(DC).items() if not k.startswith("thermal")}, "name": "dc-cold"})
    cold = DCMotor(**{**vars(cold), "max_winding_temperature": None})
    df = _frame(rms=[3.3], peak=[3.3], speed=[5.0], window=[3.1])
    best, table, _ = screen(df, {"dc-cold": cold}, share=1.0)
    row = table.iloc[0]
    assert best is None and row.fails_rms == 1 and sum(row[f"fails_{r}"] for r in REASONS) == 1
    half = screen_one(demand(df), DC, duty=0.5)
    assert half.current_rms[0] == pytest.approx(np.sqrt(0.5) * 3.3 / 0.8)
    heat = 6.0 * 0.5 * (3.3 / 0.8) ** 2 * 1.2
    assert half.winding_temperature[0] == pytest.approx(25 + heat / (1 - 0.0039 * heat))
    assert not half.rms[0] and not half.thermal[0]
    assert screen_one(demand(df), DC).thermal[0]  # back to back: 25 + 235 deg C


def test_a_ramp_the_motor_cannot_follow_is_short_in_the_window():
    """A linear ramp to 10 rad/s over 2 s (5 rad/s^2) with the wheel's acceleration capped at 2.5 rad/s^2: the wheel
    reaches 10 rad/s at 4 s. Over the window [2.5, 5] s its speed rises from 6.25 to 10 by 4 s, then holds: mean
    ((6.25 + 10) / 2 x 1.5 + 10 x 1) / 2.5 = 8.875 rad/s, 11.25% short. At 5 rad/s^2 or more it is on time."""
    got = sizing.ramp_shortfall(10.0, 2.0, (2.5, 5.0), 2.5, law="ramp")
    assert got == pytest.approx(0.1125, abs=2e-3)  # the 400-step grid: 1/80 s a step
    assert sizing.ramp_shortfall(10.0, 2.0, (2.5, 5.0), 5.0, law="ramp") == pytest.approx(0.0, abs=1e-12)
    # smooth_step's peak acceleration is 15/8 of the mean: 9.375 rad/s^2 here; at 9 the wheel lags a little
    # during the ramp, catches up before 2.5 s, and the window is on speed
    assert sizing.ramp_shortfall(10.0, 2.0, (2.5, 5.0), 9.0) == pytest.approx(0.0, abs=1e-12)
    assert sizing.ramp_shortfall(10.0, 2.0, (2.5, 5.0), 2.0) > 0.1


def test_the_wheels_share_only_within_their_grip():
    """Bound 3.2 N m a wheel. Torques 3.6 (the worst) and 2.0 x 3: 9.6 N m together, within 4 x 3.2. With grip
    for 10.7 N m over the four (u = 9.6 / 10.7 = 0.897), each wheel takes at most its torque / u: the others
    2.23 N m each, 3.2 + 3 x 2.23 = 9.89 >= 9.6: they share. With grip for 9.8 (u = 0.98): 3.2 + 3 x 2.04 =
    9.32 < 9.6: they cannot, and the worst wheel is judged alone (4.5 A > 4 A: rms, peak)."""
    cols = {"wheel_speed": [5.0, 5.0]}
    for i, w in enumerate(WHEELS):
        v = [3.6, 3.6] if i == 2 else [2.0, 2.0]
        cols[f"{w}_rms"], cols[f"{w}_peak_lp"], cols[f"{w}_peak_lp_all"] = v, v, v
    need = demand(pd.DataFrame({k: np.asarray(v, float) for k, v in cols.items()}))
    ramp = {"speed": 0.0, "inertia": 1.0, "ramp_time": 1.0, "window": (2.0, 4.0), "law": "ramp", "grip": [10.7, 9.8]}
    res = screen_one(need, DC, ramp=ramp)
    assert not res.peak[0] and res.current_rms[0] == pytest.approx(4.0)
    assert res.peak[1] and res.rms[1] and res.current_rms[1] == pytest.approx(4.5)


@pytest.mark.parametrize("duty", [1.0, 0.5, 0.2])
def test_the_hot_start_at_a_duty_is_the_cycles_steady_state(duty):
    """A one-node winding stepped as the drive steps it (1 ms, its resistance rising 0.39%/K with its
    temperature), 3 A for the first 4 s of a 10 s run and 1 A after, then resting (1 / duty - 1) runs at ambient,
    cycle after cycle: 300 cycles from cold settle on s*. `_hot_start` on the first run alone (from cold: its end
    and its integral of i^2) lands on s*; so does it from a run that started elsewhere (s = 30 K). Without the
    resistance's rise with temperature (alpha 0 in the closed form) it would land low."""
    from batchveh.model.motors import COPPER_TEMPCOEF
    from batchveh.sizing.thermal import _hot_start

    r, r_th, cap, t_amb, run, dt = 1.2, 6.0, 5.0, 25.0, 10.0, 1e-3
    c = {"R": r, "R_T": r_th, "C": cap, "t_T": r_th * cap, "T_amb": t_amb}
    current = np.where(np.arange(int(run / dt)) * dt < 4.0, 3.0, 1.0)
    rest = run * (1 / duty - 1)

    def one_run(s):
        for i in current:
            s = s + dt * (i * i * r * (1 + COPPER_TEMPCOEF * (t_amb + s - 25.0)) - s / r_th) / cap
        return s

    s = 0.0
    for _ in range(300):
        s = one_run(s) * np.exp(-rest / (r_th * cap))
    q = float((current * current).sum() * dt)
    for begin in (0.0, 30.0):
        res = pd.DataFrame({"drive_lf_current_sq_time": [q], "drive_lf_winding_temp_end": [t_amb + one_run(begin)]})
        got = _hot_start(res, ("drive_lf",), c, np.array([begin]), run, rest)[0]
        assert got == pytest.approx(s, rel=1e-4), (begin, got, s)
    cold = pd.DataFrame({"drive_lf_current_sq_time": [q], "drive_lf_winding_temp_end": [t_amb + one_run(0.0)]})
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("batchveh.model.motors.COPPER_TEMPCOEF", 0.0)
        # measured 3.2 K low of 31.7 at duty 1, 0.53 of 12.4 at 0.5, 0.025 of 2.65 at 0.2: 50x the bound above
        assert s - _hot_start(cold, ("drive_lf",), c, np.array([0.0]), run, rest)[0] > 5e-3 * s


def test_a_runaway_winding_starts_where_one_run_repeated_would():
    """A winding whose copper loss grows faster with heat than it sheds (alpha R Q / C = 0.0039 x 1.2 x 1e4 / 5 =
    9.4 > D / (R_T C) = 0.33) has no back-to-back fixed point: the next run starts where this one ended, cooled
    over the rest (here none: 175 K), not at an infinite rise; a run that diverged (NaN) starts cold."""
    from batchveh.sizing.thermal import _hot_start

    c = {"R": 1.2, "R_T": 6.0, "C": 5.0, "t_T": 30.0, "T_amb": 25.0}
    res = pd.DataFrame({"drive_lf_current_sq_time": [1e4, np.nan], "drive_lf_winding_temp_end": [200.0, np.nan]})
    np.testing.assert_array_equal(_hot_start(res, ("drive_lf",), c, np.zeros(2), 10.0, 0.0), [175.0, 0.0])


def test_a_duty_cycle_is_screened_on_the_whole_cycle_and_each_segment():
    """A mission's rows: its steady window (the usual columns) fits the DC motor (0.8 N m/A, 4 A, no-load 24 rad/s
    at the wheel, the gearhead's input 400 rad/s = 20 at the wheel) on every row; the cycle does not. Row 0: a
    segment's peak speed 24.5 rad/s past the no-load speed (and the gearhead's input), where its 2 N m need
    2.5 A x 1.2 + 0.05 x 490 = 27.5 V > 24 V: the segment is named. Row 1: the cycle's RMS 3.3 N m = 4.125 A > 4 A
    (and 25 + 235 deg C). Row 2: the cycle's RMS 3.1 N m = 3.875 A, under 4 A but 25 + 187 deg C: heat alone."""
    window = {"rms": [2.0, 2.0, 2.0], "peak": [2.0, 2.0, 2.0], "speed": [10.0, 10.0, 10.0]}
    spans = {
        "mission": ([2.0, 3.3, 3.1], [2.0, 3.1, 3.1], [24.5, 10.0, 10.0]),
        "seg0_cruise": ([2.0, 2.0, 2.0], [2.0, 2.0, 2.0], [10.0, 10.0, 10.0]),
        "seg1_climb": ([2.0, 3.3, 3.1], [2.0, 3.1, 3.1], [24.5, 10.0, 10.0]),
    }
    df = pd.concat([_frame(window["rms"], window["peak"], window["speed"]), _mission_frame(spans)], axis=1)
    best, table, _ = screen(df, {"dc-test": DC}, share=1.0)
    assert best == "dc-test" and table.coverage[0] == 1.0  # the window alone: every row fits
    best, table, failing = screen(df, {"dc-test": DC}, share=1.0, span="mission")
    bad = failing["dc-test"]
    assert best is None and list(bad.index) == [0, 1, 2]
    assert {r for r in REASONS if bad.loc[0, r]} == {"voltage", "speed", "gear_speed"}
    assert bad.loc[0, "where"] == "seg1_climb: voltage at 24.5 rad/s"
    assert {r for r in REASONS if bad.loc[1, r]} == {"rms", "thermal"} and bad.loc[1, "where"] == "mission: rms"
    assert {r for r in REASONS if bad.loc[2, r]} == {"thermal"} and bad.loc[2, "where"] == "mission: thermal"
    assert table.limiting[0].endswith("(1 of 3)")


def test_a_segment_the_loop_falls_behind_in_is_named():
    """The loop's distance over each segment against the servo's: more than 2% short is short (the climb's 1.95 m
    for 2.0: 2.5%; 1.97 m, 1.5%, is not); a stop the servo barely moves in is not read; the first short segment is
    named; not a mission: nothing."""
    servo = pd.DataFrame({"seg0_accelerate_distance": [0.5, 0.5], "seg1_climb_distance": [2.0, 2.0],
                          "seg2_stop_distance": [0.01, 0.01], "seg0_accelerate_drive_lf_rms": [1.0, 1.0],
                          "seg1_climb_drive_lf_rms": [1.0, 1.0], "seg2_stop_drive_lf_rms": [0.0, 0.0]})  # fmt: skip
    loop = servo.copy()
    loop["seg1_climb_distance"] = [1.95, 1.97]
    loop["seg2_stop_distance"] = [0.0, 0.0]
    assert list(sizing.segment_shortfall(servo, loop)) == ["seg1_climb", ""]
    assert list(sizing.segment_shortfall(pd.DataFrame({"x": [1.0]}), pd.DataFrame({"x": [1.0]}))) == [""]


def test_the_current_integral_covers_the_steps_the_end_temperature_holds():
    """`current_sq_time` (the hot start's Q) is the integral of i^2 over every step but the last, in two blocks:
    `winding_temp_end` is the temperature the last step ran with, before that step's heat."""
    from batchveh.stepping import motor_stats

    rng = np.random.default_rng(1)
    dt, cur = 0.01, rng.normal(0.0, 2.0, (1, 7, 8))  # 1 variant x 7 steps x 8 motors, A
    c = motor_stats.init((1,))
    for block in (slice(0, 4), slice(4, 7)):
        n = block.stop - block.start
        e = {"current": cur[:, block], "power": np.zeros((1, n, 8)), "temp": np.full((1, n, 8), 25.0),
             "at_v": np.zeros((1, n, 8), bool), "at_i": np.zeros((1, n, 8), bool), "joint": np.zeros((1, n, 8)),
             "bound": np.full((1, n, 8), np.inf), "on_bus": np.ones((1, 1, 8))}  # fmt: skip
        c = motor_stats.update(c, e, np.zeros((1, n, 8)), np.ones(n), np.ones(n), dt)
    out = motor_stats.finalize(c, np.array([7.0]), np.zeros((1, 4)), np.ones((1, 4)))
    np.testing.assert_allclose(out["drive_rf_current_sq_time"], (cur[:, :6, 1] ** 2).sum(-1) * dt, rtol=1e-12)
