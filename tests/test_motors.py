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
