"""A duty cycle's accelerating segments on the screen (issue 61, part 6): a drive at its current's bound that falls
less than SHORT_SHARE behind over the segment is not failed on its peak, as the loop does not count it; one that falls
further is. The ramp model against the envelope of a bounded acceleration, computed here on a fine grid."""

import numpy as np
import pandas as pd
import pytest

from batchveh.model.motors import DCMotor
from batchveh.sizing import screen, segment_ramp
from batchveh.stepping.motor_stats import SHORT_SHARE

SEG = "seg0_accelerate"
DRIVES = ("drive_lf", "drive_rf", "drive_lr", "drive_rr")
W1, TAU, INERTIA, STEADY = 10.0, 2.0, 0.2, 1.0  # rad/s, s, kg m^2 at the wheel, N m
A_LAW = 15 / 8 * W1 / TAU  # the quintic's peak acceleration
PEAK = STEADY + INERTIA * A_LAW  # the servo's peak torque


def _motor(bound):
    """A motor with no rotor whose current's bound at the wheel, eta N K i_max, is `bound` N m."""
    return DCMotor(name="m", torque_constant=0.1, terminal_resistance=0.1, nominal_voltage=48.0,
                   max_continuous_current=bound / (0.1 * 10.0), gear_ratio=10.0)  # fmt: skip


def _cycle(n=1):
    """A duty cycle of one accelerating segment from standstill to W1 over TAU: its columns."""
    cols = {}
    for span in ("mission", SEG):
        for m in DRIVES:
            cols[f"{span}_{m}_rms"] = np.full(n, 0.5 * PEAK)
            cols[f"{span}_{m}_peak_lp"] = np.full(n, PEAK)
            cols[f"{span}_{m}_speed_peak"] = np.full(n, W1)
    return pd.DataFrame(cols)


RAMP = {"segments": {SEG: {"transition": TAU, "duration": TAU, "previous": None}}, "inertia": INERTIA, "armature": 0.0}


def _deficit_by_hand(a_max):
    """1 - the distance of a wheel whose acceleration is at most a_max over the imposed distance: the wheel's speed
    is the lower envelope a t + min_{s <= t} (v(s) - a s) of the quintic v on a grid of 200,001 points."""
    t = np.linspace(0.0, TAU, 200_001)
    x = t / TAU
    v = W1 * x**3 * (10 - 15 * x + 6 * x * x)
    w = a_max * t + np.minimum.accumulate(v - a_max * t)
    return 1.0 - np.trapezoid(w, t) / np.trapezoid(v, t)


@pytest.mark.parametrize("share_of_law", [1.0, 0.9, 0.7, 0.5])
def test_the_segments_shortfall_is_the_bounded_acceleration_by_hand(share_of_law):
    """A bound that lets the wheel accelerate at share_of_law of the law's peak: the shortfall over the segment
    within 1% (relative) of the fine-grid envelope's, or both below 1e-6 where the bound passes the peak."""
    a_max = share_of_law * A_LAW
    bound = STEADY + INERTIA * a_max
    got = float(segment_ramp(_cycle(), SEG, _motor(bound), RAMP)[0])
    expect = _deficit_by_hand(a_max)
    if share_of_law >= 1.0:
        assert got < 1e-6 and expect < 1e-6
    else:
        assert got == pytest.approx(expect, rel=0.01), (got, expect)


def test_the_screen_forgives_a_peak_the_loop_would_and_fails_one_it_would_not():
    """Two motors whose bounds sit below the segment's peak: one falls less than SHORT_SHARE behind (passes the
    screen, as the loop does not count it short), the other more (fails on peak). Without the ramp both fail."""
    df = _cycle(1)
    bounds = {}
    for name, target in (("near", 0.5 * SHORT_SHARE), ("far", 4 * SHORT_SHARE)):
        lo, hi = 0.05, 1.0  # the share of the law's peak acceleration whose deficit is `target`, by bisection
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if _deficit_by_hand(mid * A_LAW) > target else (lo, mid)
        bounds[name] = STEADY + INERTIA * hi * A_LAW
        assert bounds[name] < PEAK
    cat = {name: _motor(b) for name, b in bounds.items()}
    cat = {name: DCMotor(**{**m.__dict__, "name": name}) for name, m in cat.items()}
    _, with_ramp, _ = screen(df, cat, share=0.99, span="mission", params=[], ramp=RAMP)
    _, strict, _ = screen(df, cat, share=0.99, span="mission", params=[])
    got = with_ramp.set_index("motor")
    assert got.loc["near", "coverage"] == 1.0 and got.loc["far", "coverage"] == 0.0
    assert got.loc["far", "fails_peak"] == 1
    assert (strict["coverage"] == 0.0).all() and (strict["fails_peak"] == 1).all()


def test_a_drives_peak_while_the_vehicle_steers_in_place_is_not_judged():
    """A steer in place (the drives hold their wheels still against the patch's scrub): a drive's peak above its
    bound there fails the screen without the cycle's `standing` spans, and passes with them, as the loop reads no
    distance there. The same peak in an accelerating segment still fails where the ramp falls behind."""
    df = _cycle(1)
    steer = "seg1_steer"
    for m in DRIVES:
        df[f"{steer}_{m}_rms"], df[f"{steer}_{m}_peak_lp"], df[f"{steer}_{m}_speed_peak"] = 1.0, 5 * PEAK, 0.0
        df[f"{SEG}_{m}_peak_lp"] = 1.0  # the acceleration within every bound below
    cat = {"m": _motor(2 * PEAK)}
    standing = {**RAMP, "standing": [steer]}
    _, strict, _ = screen(df, cat, share=0.99, span="mission", params=[], ramp=RAMP)
    _, held, _ = screen(df, cat, share=0.99, span="mission", params=[], ramp=standing)
    assert strict["fails_peak"].iloc[0] == 1 and held["coverage"].iloc[0] == 1.0


@pytest.mark.parametrize("law", ["smooth_step", "ramp", "unbounded_ramp"])
def test_the_ramps_verdict_by_its_threshold_is_the_stepped_models(law):
    """`ramp_short` (a comparison against the threshold found once per ramp time) against the stepped model's
    `ramp_shortfall > SHORT_SHARE` on 4,000 draws over three ramp times, speeds 1-30 rad/s and bounds from a tenth
    of the ramp's mean acceleration to twice its peak: the same verdict on every draw."""
    from batchveh.sizing.screening import ramp_short, ramp_shortfall

    rng = np.random.default_rng(7)
    n = 4000
    ramp_time = rng.choice([1.0, 2.0, 3.5], n)
    speed = rng.uniform(1.0, 30.0, n)
    a_max = speed / ramp_time * rng.uniform(0.1, 3.75, n)
    window = (2.5, 5.0)
    stepped = ramp_shortfall(speed, ramp_time, window, a_max, law) > SHORT_SHARE
    assert 0.1 < stepped.mean() < 0.9  # both verdicts drawn
    np.testing.assert_array_equal(ramp_short(speed, ramp_time, window, a_max, law, SHORT_SHARE), stepped)
