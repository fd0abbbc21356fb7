"""The loop's hot start in closed form: the one-node winding's back-to-back fixed point from one run
(`_hot_start`), and a run's columns had it started hotter, taken from the run from ambient (`hot_columns`, on a
straight line: `closed_form`)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from batchveh.analysis.demand import GROUP_RISES, RISE_GROUP
from batchveh.model.battery import Battery


def _hot_start(res: pd.DataFrame, names: tuple[str, ...], c: dict, start: np.ndarray, duration: float, rest: float):
    """Per variant, the start rise (K above ambient) at which a run repeated back to back, `rest` s at standstill
    between runs, ends where it started: the fixed point of the one-node winding's run-to-run map, in closed form
    from one run `res` that started at `start`, for the hottest of the motors `names` (constants `c`, resolved).

    Over a run the rise s obeys C ds/dt = i^2 R (1 + alpha (T_a + s - 25)) - s / R_T: linear in s, so the run maps
    its start onto its end as end = Phi start + Gamma, with Phi = exp((alpha R Q - D / R_T) / C), Q the integral of
    i^2 over the steps whose heat `<motor>_winding_temp_end` holds (`<motor>_current_sq_time`: every step but the
    last) and D their duration (the run's less one step); Gamma = end - Phi start from the run itself. The rest
    cools by E = exp(-rest / tau). Back to back: s = E (Phi s + Gamma), so
    s = E Gamma / (1 - E Phi) (a winding whose copper loss grows faster with heat than it sheds runs away: it has
    none, and the run repeated once, E end, stands in; its heat fails it anyway).
    Exact where the current does not depend on the temperature, the drive passing MuJoCo the voltage that gives
    the asked current; at its voltage line the hot winding carries a little less, and the next run says how much
    (its residual). No thermal model: 0."""
    from batchveh.model.motors import COPPER_TEMPCOEF

    if c["t_T"] <= 0 or c["C"] <= 0:
        return np.zeros(len(res))
    e = np.exp(-rest / c["t_T"])
    out = np.zeros(len(res))
    for m in names:
        q = res[f"{m}_current_sq_time"].to_numpy(float)
        end = res[f"{m}_winding_temp_end"].to_numpy(float) - c["T_amb"]
        phi = np.exp((COPPER_TEMPCOEF * c["R"] * q - duration / c["R_T"]) / c["C"])
        gamma = end - phi * start
        with np.errstate(divide="ignore", invalid="ignore"):  # a runaway has no fixed point: the run repeated once
            s = np.where(e * phi < 1.0, e * gamma / (1.0 - e * phi), e * end)
        out = np.maximum(out, np.nan_to_num(s, nan=0.0, posinf=0.0, neginf=0.0))
    return np.maximum(out, 0.0)


HOT_MARGIN = 0.99  # a run in closed form only where its start rise stays below this share of its voltage margin


def closed_form(spec: Any) -> bool:
    """Whether the loop takes a candidate's hot run in closed form from its cold one (`hot_columns`): on a straight
    line; a mission's spans' electric columns (each segment's peak and energies) have none here."""
    return spec.stats_config().mission is None


def hot_columns(
    res: pd.DataFrame, start: dict, consts: dict, battery: Battery | None = None, rises: dict | None = None
):
    """A run's columns had it started at the rises `start` ({'motors.drive_start_rise': (n,), 'motors.steer_start_rise':
    (n,)} K, each group's windings), in closed form from `res`, a run from ambient with `motors.hot_columns`
    (motor_stats.HOT_COLUMNS's columns), and which variants it cannot answer for. Returns (the columns, redo (n,) bool).

    Off the voltage line the drive carries the current it asks whatever the winding's resistance, so the run
    started hotter is the same run: its currents, torques and speeds are these, and the winding, linear in its
    temperature at a given current, runs at T + s g (`<motor>_temp_gain`, g at the last step). So: the end
    exactly; the peak, a convex function of s kept at 0 and motor_stats.HOT_GRID, interpolated (an upper bound;
    the true one is at least max(f(a) + g (s - a), f(b) - (b - s)) between the points a, b around s); the net
    energy exactly (the power rises by alpha R i^2 g s); the bus's peak power below P + s (its gains) and at least
    P. A variant is redone (`redo`) where a step would reach the voltage line (s at HOT_MARGIN of
    `<motor>_voltage_margin` or above: its current would depend on s), where its thermal verdict lies inside the
    peak's bounds, and where the battery's power does. `consts`: the groups' resolved catalogue constants.
    `rises`: each start rise's windings (`analysis.demand.group_rises` of the vehicle's steering layout: a fixed
    hub's slot is no winding; default GROUP_RISES, the four-wheel layout's), `start` and `consts` keyed alike."""
    from batchveh.stepping.motor_stats import HOT_GRID

    out = res.copy()
    n = len(res)
    rows = np.arange(n)
    redo = np.zeros(n, bool)
    grid = np.array((0.0, *HOT_GRID))
    last = len(grid) - 1
    net = res["bus_energy_wh"].to_numpy(float).copy()
    bus_hi = res["bus_power_peak"].to_numpy(float).copy()
    for key, names in (GROUP_RISES if rises is None else rises).items():
        side = RISE_GROUP[key]
        s = np.asarray(start[key], float)
        t_max = consts[key]["T_max"]
        bus_hi += s * res[f"bus_power_gain_{side}"].to_numpy(float)
        for m in names:
            g = res[f"{m}_temp_gain"].to_numpy(float)
            out[f"{m}_winding_temp_end"] = res[f"{m}_winding_temp_end"].to_numpy(float) + s * g
            f = np.stack(
                [res[f"{m}_winding_temp_peak{x}"].to_numpy(float) for x in ("", *(f"_{v:g}K" for v in HOT_GRID))], 1
            )
            j = np.clip(np.searchsorted(grid, s, side="right") - 1, 0, last)
            k = np.minimum(j + 1, last)
            a, b, fa, fb = grid[j], grid[k], f[rows, j], f[rows, k]
            beyond = j == last
            width = np.where(beyond, 1.0, b - a)
            hi = np.where(beyond, fa + (s - a), fa + (fb - fa) * (s - a) / width)
            lo = np.where(beyond, fa + g * (s - a), np.maximum(fa + g * (s - a), fb - (b - s)))
            out[f"{m}_winding_temp_peak"] = hi
            heated = s > 0
            redo |= heated & (lo <= t_max) & (t_max < hi)  # its thermal verdict is not in the bounds
            redo |= heated & (s >= HOT_MARGIN * res[f"{m}_voltage_margin"].to_numpy(float))  # at the voltage line
            hd, hr = (res[f"{m}_heat_gain_{x}"].to_numpy(float) for x in ("drawn", "regen"))
            drawn, regen = (res[f"{m}_energy_{x}"].to_numpy(float) for x in ("drawn", "regen"))
            # the net exact; a regenerating step that turns to drawing moves as much from one to the other
            out[f"{m}_energy_regen"] = np.maximum(regen - s * hr, 0.0)
            out[f"{m}_energy_drawn"] = drawn - regen + s * (hd + hr) + out[f"{m}_energy_regen"].to_numpy()
            net += s * (hd + hr) / 3600.0
    out["bus_energy_wh"] = net
    out["bus_power_peak"] = bus_hi
    if battery is not None:  # the battery's power verdict inside [P, P + its gains]
        p0 = res["bus_power_peak"].to_numpy(float)
        redo |= (p0 <= battery.max_power) & (battery.max_power < bus_hi)
    return out, redo


def _without_gains(res: pd.DataFrame) -> pd.DataFrame:
    """A run's columns less motor_stats' start-rise gains (MotorStatsConfig.hot)."""
    from batchveh.stepping.motor_stats import HOT_COLUMNS

    gains = tuple(f"_{k}" for k in HOT_COLUMNS)
    return res.drop(columns=[c for c in res if c.endswith(gains) or c.startswith("bus_power_gain_")])
