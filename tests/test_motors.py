"""Motor sizing against hand-computed values."""

import numpy as np
import pandas as pd
import pytest

from batchveh.analysis.motors import Motor, check, load_motors, smallest
from batchveh.config import ConfigError


def _frame(rms, peak, wheel_speed):
    cols = {"wheel_speed": wheel_speed}
    for w in ("drive_lf", "drive_rf", "drive_lr", "drive_rr"):
        cols[f"{w}_rms"] = rms
        cols[f"{w}_peak_lp_all"] = peak
    return pd.DataFrame(cols)


def test_torque_limit_is_flat_then_constant_power():
    m = Motor(peak_torque=4.0, corner_speed=100.0, max_speed=300.0)
    np.testing.assert_allclose(m.torque_limit([0, 100, 200, 300, 301]), [4, 4, 2, 4 / 3, 0])


def test_check_by_hand():
    m = Motor(continuous_torque=1.0, peak_torque=3.0, corner_speed=200, max_speed=400, gear_ratio=10, efficiency=0.5)
    # wheel rms 4 N m -> shaft 4 / (10 * 0.5) = 0.8 <= 1; peak 10 -> 2.0 <= 3 at 100 rad/s (wheel 10 rad/s)
    c = check(_frame([4.0, 6.0, 4.0, 4.0], [10.0, 10.0, 20.0, 10.0], [10.0, 10.0, 10.0, 50.0]), m)
    assert list(c.fits_continuous) == [True, False, True, True]
    assert list(c.fits_peak) == [True, True, False, False]  # 4.0 > 3; at 500 rad/s the limit is 0
    assert list(c.fits_speed) == [True, True, True, False]
    assert list(c.fits) == [True, False, False, False]
    np.testing.assert_allclose(c.shaft_rms, [0.8, 1.2, 0.8, 0.8])


def test_smallest_motor_covering_the_envelope():
    # shaft values with gear 10, efficiency 1: rms 0.4 and 0.8 N m, peaks 1.0 and 1.6 N m,
    # speeds 100 and 120 rad/s (below every corner speed)
    df = _frame([4.0, 8.0], [10.0, 16.0], [10.0, 12.0])
    small = Motor(name="S", continuous_torque=0.5, peak_torque=1.5, gear_ratio=10, efficiency=1.0)  # rms 0.8 > 0.5
    mid = Motor(name="M", continuous_torque=1.0, peak_torque=2.0, gear_ratio=10, efficiency=1.0)  # fits both rows
    big = Motor(name="L", continuous_torque=2.0, peak_torque=6.0, gear_ratio=10, efficiency=1.0)  # fits, larger
    best, summary = smallest(df, [big, small, mid])
    assert best.name == "M"
    assert list(summary.motor) == ["S", "M", "L"]
    assert list(summary.fits_all) == [False, True, True]
    assert summary.loc[0, "continuous_fails"] == 1 and summary.loc[0, "peak_fails"] == 1  # 1.6 > 1.5
    assert smallest(df, [small])[0] is None


def test_motor_yaml(tmp_path):
    p = tmp_path / "m.yaml"
    p.write_text("motors:\n  - {name: A, continuous_torque: 1, peak_torque: 3, gear_ratio: 20}\n")
    assert load_motors(p)[0].gear_ratio == 20
    p.write_text("motors:\n  - {name: A, continuous_torque: 2, peak_torque: 1}\n")
    with pytest.raises(ConfigError, match="peak_torque.*below continuous_torque"):
        load_motors(p)
    p.write_text("motors:\n  - {name: A, torque: 2}\n")
    with pytest.raises(ConfigError, match="unknown key 'torque'"):
        load_motors(p)


# --- the fast screen of DC motors (batchveh.analysis.motors.screen) against hand-computed limits ---

from batchveh.analysis.motors import REASONS, screen, screen_one  # noqa: E402
from batchveh.model.motors import DCMotor  # noqa: E402

# K 0.05 N m/A, R 1.2 Ohm, 24 V, 4 A continuous, N 20, eta 0.8: at the wheel 0.8 x 20 x 0.05 = 0.8 N m per A;
# no-load 480 rad/s at the motor (24 rad/s at the wheel); R_T 6 K/W, max 125 deg C
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


def _frame(rms, peak, speed):
    cols = {"wheel_speed": speed, "slope_deg": np.arange(len(rms), dtype=float)}
    for w in ("drive_lf", "drive_rf", "drive_lr", "drive_rr"):
        cols[f"{w}_rms"], cols[f"{w}_peak_lp_all"] = rms, peak
    return pd.DataFrame({k: np.asarray(v, float) for k, v in cols.items()})


def test_screen_names_each_reason_from_closed_forms():
    """One variant per reason, each just past its limit, and one that fits every limit."""
    df = _frame(
        # fits; rms: 3.3 N m = 4.125 A > 4 A; thermal: runaway-free but hot; voltage; speed; gear torque
        rms=[2.0, 3.3, 3.1, 1.0, 0.5, 1.0],
        peak=[4.0, 3.3, 3.1, 11.0, 0.5, 12.5],
        speed=[10.0, 10.0, 10.0, 10.0, 19.5, 5.0],
    )
    res = screen_one(
        pd.DataFrame({"rms": df.drive_lf_rms, "peak": df.drive_lf_peak_lp_all, "speed": df.wheel_speed}), DC
    )
    # at the wheel, 0.8 N m per A: variant 0 draws 2.5 A RMS, 5 A peak at 200 rad/s of motor speed
    assert res.current_rms[0] == pytest.approx(2.0 / 0.8) and res.current_peak[0] == pytest.approx(5.0)
    assert res.voltage_peak[0] == pytest.approx(5.0 * 1.2 + 0.05 * 200.0)
    # steady rise: heat = 6 K/W x i^2 x 1.2 Ohm at 25 deg C (R's reference), alpha 0.0039 feeding back
    heat = 6.0 * (3.1 / 0.8) ** 2 * 1.2
    assert res.winding_temperature[2] == pytest.approx(25 + heat / (1 - 0.0039 * heat))
    expect = {
        0: set(),
        1: {"rms", "thermal"},  # 4.125 A: over 4 A, and 25 + 235 deg C
        2: {"thermal"},  # 3.875 A, under 4 A, but 25 + 187 deg C (108 K before R(T) feeds back)
        3: {"voltage"},  # 13.75 A x 1.2 + 0.05 x 200 = 26.5 V > 24 V
        4: set(),  # 19.5 rad/s at the wheel = 390 rad/s at the motor: under no-load 480 and the gear's 400
        5: {"gear_torque"},  # 12.5 N m peak > 12 N m intermittent
    }
    got = {i: {r for r in REASONS if res[r][i]} for i in range(len(df))}
    assert got == expect, got


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
