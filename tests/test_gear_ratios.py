"""The motor and the gear ratio to buy (issue 61): gearhead series in the catalogue, each motor's ratio window
against closed forms, the requirement sheet against a computation by hand, and bad series as one line."""

import math

import numpy as np
import pandas as pd
import pytest
import yaml

from batchveh.config import ConfigError
from batchveh.model.motors import load_catalogue
from batchveh.sizing import requirements, screen, windows

# a hand-made motor: K, R, the bus and the continuous current; no thermal model, no gearhead ratings
K, R, V, I_MAX, ETA = 0.05, 0.5, 24.0, 4.0, 0.9
DENSE = [round(2.0 * 1.01**k, 6) for k in range(470)]  # 2 to 214, 1% apart


def _catalogue(tmp_path, series=None, motors=None):
    data = {
        "gearhead_series": series
        if series is not None
        else [{"name": "dense", "efficiency": ETA, "ratios": [{"ratio": r} for r in DENSE]}],
        "motors": motors
        if motors is not None
        else [
            {
                "name": "hand",
                "torque_constant": K,
                "terminal_resistance": R,
                "nominal_voltage": V,
                "max_continuous_current": I_MAX,
                "series": ["dense"],
            }
        ],
    }
    path = tmp_path / "cat.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _constant_demand(torque, speed, n=10):
    """n variants, each wheel at `torque` (N m) RMS and peak, at `speed` (rad/s), duty 1."""
    cols = {"wheel_speed": np.full(n, speed)}
    for m in ("lf", "rf", "lr", "rr"):
        for stat in ("rms", "peak_lp_all", "peak_lp"):
            cols[f"drive_{m}_{stat}"] = np.full(n, torque)
    return pd.DataFrame(cols)


@pytest.mark.parametrize("torque, speed", [(6.0, 8.0), (10.0, 5.0), (3.0, 12.0)])
def test_the_window_is_the_closed_forms(tmp_path, torque, speed):
    """Constant torque T at wheel speed w, duty 1: the window opens where T / (eta N K) reaches the continuous
    current and closes where the voltage line at T crosses w, i R + K N w = V, the larger root of
    K w N^2 - V N + T R / (eta K) = 0. On a series 1% apart, each end within 2% of its closed form."""
    cat = load_catalogue(_catalogue(tmp_path))
    assert len(cat) == len(DENSE)
    df = _constant_demand(torque, speed)
    _, table, _ = screen(df, cat, share=0.99, params=[])
    wins = windows.windows(table, cat, 0.99)
    assert len(wins) == 1
    w = wins.iloc[0]
    low = torque / (ETA * K * I_MAX)
    disc = V**2 - 4 * K * speed * torque * R / (ETA * K)
    high = (V + math.sqrt(disc)) / (2 * K * speed)
    assert w["covers"], w.to_dict()
    assert w["window_low"] == pytest.approx(low, rel=0.02), (w["window_low"], low)
    assert w["window_high"] == pytest.approx(high, rel=0.02), (w["window_high"], high)
    assert w["closed_below"] in ("rms", "peak") and w["closed_above"] == "voltage"
    assert w["gaps"] == 0
    # the ratio to buy: the offered ratio nearest the window's geometric centre
    centre = math.sqrt(w["window_low"] * w["window_high"])
    assert w["chosen_ratio"] == pytest.approx(centre, rel=0.006)
    assert windows.best_of(wins) == w["chosen"]


def test_a_motor_that_cannot_cover_names_its_binding_limit_and_how_far_it_falls(tmp_path):
    """A demand past the motor at every ratio: no window, the nearest ratio and its limit; the sheet's shortfall
    factor is the closed form's: at the ratio N, the RMS torque over eta N K i_max."""
    cat = load_catalogue(_catalogue(tmp_path))
    torque, speed = 40.0, 6.0  # 40 N m at 6 rad/s: 240 W, past a 24 V motor of 4 A at any ratio
    df = _constant_demand(torque, speed)
    _, table, _ = screen(df, cat, share=0.99, params=[])
    w = windows.windows(table, cat, 0.99).iloc[0]
    assert not w["covers"] and w["chosen_coverage"] == 0.0 and w["binding"] in windows.LIMIT_TEXT
    wheel = requirements.at_wheel(df, "drive", None, 1.0, 0.99, [])
    motor = cat[w["chosen"]]
    f = requirements.shortfall(motor, wheel)
    assert f["continuous"] == pytest.approx(torque / (ETA * motor.gear_ratio * K * I_MAX), rel=1e-9)
    line = requirements.short_line(motor, wheel)
    assert line.startswith("needs ") and f"{max(f.values()):.2f}x" in line


def test_the_sheet_is_the_nearest_rank_quantile_and_names_its_variant():
    """100 variants with RMS torques 1..100 N m: at share 0.99 the sheet's RMS is the 99th smallest, 99 N m, at
    the duty sqrt(duty) of it; its variant is that row; at the shaft of ratio 20, eta 0.8: T / 16."""
    n = 100
    df = _constant_demand(1.0, 5.0, n)
    df["drive_rr_rms"] = np.arange(1.0, n + 1)[::-1]  # row 0 has 100 N m, row 1 99 N m
    df["slope_deg"] = np.arange(n, dtype=float)
    sheet = requirements.at_wheel(df, "drive", None, 0.25, 0.99, ["slope_deg"])
    rms = sheet["rms_torque"]
    assert rms["value"] == pytest.approx(0.5 * 99.0) and rms["row"] == 1 and rms["variant"] == {"slope_deg": 1.0}
    shaft = requirements.at_shaft(sheet, 20.0, 0.8)
    assert shaft["rms_torque"]["value"] == pytest.approx(0.5 * 99.0 / 16.0)
    assert shaft["top_speed"]["value"] == pytest.approx(100.0)
    # 101 values 1..101: 0.99 x 101 = 99.99, so the nearest rank is the 100th smallest (100), not the 99th
    assert requirements.nearest_rank(np.arange(1.0, 102.0)[::-1], 0.99) == (100.0, 1)


def _motor(**extra):
    return {"name": "m", "torque_constant": K, "terminal_resistance": R, "nominal_voltage": V, **extra}


BAD = [
    (None, [_motor(series=["densse"])],
     "motors[0] (m): series[0]: 'densse' is not a series of the catalogue (did you mean 'dense'?)"),
    (None, [_motor(series=[{"name": "dense", "ratios": [1000]}])],
     "series[0] (dense): ratios: 1000 is not a ratio dense offers"),
    ([{"name": "empty", "efficiency": 0.9, "ratios": []}], [_motor()],
     "gearhead_series[0] (empty): ratios: [] is not allowed"),
    ([{"name": "s", "efficiency": 0.9, "ratios": [{"ratio": 5, "max_continuous_torque": "12 Nm"}]}], [_motor()],
     "gearhead_series[0] (s): ratios[0]: max_continuous_torque: '12 Nm' is not a number"),
    ([{"name": "s", "ratios": [{"ratio": 5}]}], [_motor()],
     "gearhead_series[0] (s): ratios[0]: efficiency: missing"),
    (None, [_motor(gearhead={"ratio": 5, "efficiency": "high"})],
     "motors[0]: gearhead: efficiency: 'high' is not a number"),
]  # fmt: skip


@pytest.mark.parametrize("series, motors, words", BAD)
def test_a_bad_series_is_one_line_naming_file_entry_and_key(tmp_path, series, motors, words):
    path = _catalogue(tmp_path, series=series, motors=motors)
    with pytest.raises(ConfigError) as err:
        load_catalogue(path)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(str(path)) and words in msg, msg


def test_paired_entries_load_unchanged_and_a_series_adds_its_ratios(tmp_path):
    """A pairing written out by hand keeps its values under its name; its motor's series adds one entry per ratio,
    named <motor>_<series>-i<label>, sharing the motor's name."""
    pair = _motor(name="m_g-i10", motor="m", gearhead={"ratio": 10.0, "efficiency": 0.7}, series=["g"])
    series = [{"name": "g", "efficiency": 0.9, "ratios": [{"ratio": 5}, {"ratio": 10, "label": "10:1"}, {"ratio": 20}]}]
    cat = load_catalogue(_catalogue(tmp_path, series=series, motors=[pair]))
    assert list(cat) == ["m_g-i10", "m_g-i5", "m_g-i20"]
    assert cat["m_g-i10"].gear_efficiency == 0.7  # the pairing as written, not the series' 10:1
    assert cat["m_g-i20"].gear_ratio == 20.0 and cat["m_g-i20"].gear_efficiency == 0.9
    assert {m.motor_name for m in cat.values()} == {"m"}


@pytest.mark.parametrize("series, motors, words", BAD)
def test_the_size_command_gives_a_bad_series_one_line_and_exit_2(tmp_path, capsys, series, motors, words):
    """The same bad catalogues through `python -m batchveh.size --dry-run`: one line on stderr, exit 2."""
    from pathlib import Path

    from batchveh.size import EXIT_INPUT, main

    spec = Path(__file__).resolve().parent.parent / "sweeps" / "delivery_robot.yaml"
    path = _catalogue(tmp_path, series=series, motors=motors)
    rc = main([str(spec), "--catalogue", str(path), "--dry-run"])
    err = capsys.readouterr().err.strip()
    assert rc == EXIT_INPUT and err.count("\n") == 0 and words in err and "Traceback" not in err, err
