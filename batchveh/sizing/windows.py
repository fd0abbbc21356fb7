"""Each motor's ratio window: the ratios of its gearhead series at which it covers the share, and what closes each end.

The screen (`batchveh.sizing.screening.screen`) judges every catalogue entry, and a catalogue with gearhead series
holds one entry per (motor, ratio) (model/gearheads.py). Grouped by the physical motor (`DCMotor.motor_name`):

- the window is the ratios whose screen coverage reaches the share, from the lowest to the highest;
- below it, too little reduction: the motor's torque per amp at the wheel falls short (its continuous current,
  its heat, its current's bound against the peak) or the gearhead's torque rating; above it, too much: the
  voltage line at speed, the no-load speed, or the gearhead's input speed. Each end is closed by the commonest
  reason of the ratio just outside it (or by the end of the series);
- the ratio to buy is the offered ratio in the window nearest its geometric centre, sqrt(low x high): the most
  margin, in ratio, to both ends (`choose_ratio`);
- motors rank by their continuous torque at the shaft, K i_max (`DCMotor.shaft_continuous_torque`): the smallest
  motor with a window is the screen's choice.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

# the screen's reasons, by the end of the window they close: too little reduction, or too much
BELOW = ("rms", "thermal", "peak", "gear_torque")
ABOVE = ("voltage", "speed", "gear_speed")
LIMIT_TEXT = {
    "rms": "continuous current",
    "thermal": "winding temperature",
    "peak": "current's bound (peak torque)",
    "gear_torque": "gearhead's torque rating",
    "voltage": "voltage line",
    "speed": "no-load speed",
    "gear_speed": "gearhead's input speed",
    "energy": "battery",
    "tracking": "tracking",
}


def with_motors(table: pd.DataFrame, catalogue: dict[str, Any]) -> pd.DataFrame:
    """A screen table with each entry's physical motor (`motor_name`), series ('' for a pairing) and the motor's
    continuous torque at its shaft (N m), sorted by that torque, then the ratio."""
    out = table.copy()
    out["motor_name"] = [catalogue[m].motor_name for m in out["motor"]]
    out["series"] = [catalogue[m].series for m in out["motor"]]
    out["shaft_continuous_torque"] = [catalogue[m].shaft_continuous_torque for m in out["motor"]]
    return out.sort_values(["shaft_continuous_torque", "motor_name", "gear_ratio"], kind="stable").reset_index(
        drop=True
    )


def limit_of(row: Any, reasons: tuple[str, ...]) -> str:
    """The commonest of `reasons` among a screen row's counted misses ('' where none of them counts)."""
    counts = {r: int(row[f"fails_{r}"]) for r in reasons if f"fails_{r}" in row and row[f"fails_{r}"] > 0}
    return max(counts, key=counts.get) if counts else ""


OPEN_END = 2.0  # an end no limit closes (the series ends first) counts at this factor of the other end


def choose_ratio(ratios: np.ndarray, covered: np.ndarray, coverage: np.ndarray, open_high: bool = False) -> int:
    """The index of the ratio to buy among `ratios` (ascending): of those `covered`, the nearest its window's
    geometric centre in log ratio (ties: the higher coverage); without any covered, the highest coverage (ties:
    nearest the centre of the ratios that reach it). `open_high`: no limit closes the window above (the demand asks
    no speed of the motor, as a straight line's steering; the series' highest ratio ends it): the upper end counts
    at OPEN_END x the lower, so the choice keeps that margin above the lower end and no more."""
    pool = covered if covered.any() else coverage >= coverage.max()
    lo, hi = ratios[pool].min(), ratios[pool].max()
    hi = min(hi, OPEN_END * lo) if open_high else hi
    distance = np.where(pool, np.abs(np.log(ratios) - 0.5 * (math.log(lo) + math.log(hi))), np.inf)
    order = np.lexsort((-coverage, np.round(distance, 9)))
    return int(order[0])


def _limit_at(rows: pd.DataFrame, i: int, first: tuple[str, ...], then: tuple[str, ...]) -> str:
    """The limit that fails row `i` (the commonest of `first`, else of `then`); '' past either end."""
    return (limit_of(rows.iloc[i], first) or limit_of(rows.iloc[i], then)) if 0 <= i < len(rows) else ""


def one_window(rows: pd.DataFrame, share: float) -> dict[str, Any]:
    """A motor's window from its screen rows (one per ratio, ascending): low and high ratio, the limits closing
    each end, the ratio to buy and its coverage, and whether the window has gaps (a ratio inside it short)."""
    rows = rows.sort_values("gear_ratio", kind="stable").reset_index(drop=True)
    ratios, coverage = rows["gear_ratio"].to_numpy(float), rows["coverage"].to_numpy(float)
    covered = coverage >= share
    inside = np.flatnonzero(covered)
    first, last = (inside[0], inside[-1]) if len(inside) else (0, len(rows) - 1)
    above = _limit_at(rows, last + 1, ABOVE, BELOW)  # '': the series ends the window (or there is none)
    pick = choose_ratio(ratios, covered, coverage, open_high=not above)
    out: dict[str, Any] = {
        "motor_name": rows["motor_name"].iloc[0],
        "shaft_continuous_torque": float(rows["shaft_continuous_torque"].iloc[0]),
        "ratios_offered": len(rows),
        "ratio_min": float(ratios.min()),
        "ratio_max": float(ratios.max()),
        "chosen": rows["motor"].iloc[pick],
        "chosen_ratio": float(ratios[pick]),
        "chosen_coverage": float(coverage[pick]),
        "covers": bool(len(inside)),
        "window_low": np.nan,
        "window_high": np.nan,
        "closed_below": "",
        "closed_above": "",
        "gaps": 0,
        "binding": "",
    }
    if len(inside):
        out["window_low"], out["window_high"] = float(ratios[first]), float(ratios[last])
        out["gaps"] = int((~covered[first : last + 1]).sum())
        out["closed_below"] = _limit_at(rows, first - 1, BELOW, ABOVE) or "the series' lowest ratio"
        out["closed_above"] = above or "the series' highest ratio"
    else:  # what binds at the ratio that comes nearest
        out["binding"] = limit_of(rows.iloc[pick], (*BELOW, *ABOVE))
    return out


def windows(table: pd.DataFrame, catalogue: dict[str, Any], share: float) -> pd.DataFrame:
    """One row per physical motor of a screen `table` (`screen`'s, over a catalogue with its series), smallest
    first by its continuous torque at the shaft: its ratio window (`one_window`)."""
    ranked = with_motors(table, catalogue)
    rows = [one_window(g, share) for _, g in ranked.groupby("motor_name", sort=False)]
    return pd.DataFrame(rows).reset_index(drop=True)


def loop_table(table: pd.DataFrame, wins: pd.DataFrame) -> pd.DataFrame:
    """The screen's rows the loop walks: one per physical motor, its ratio to buy (or, without a window, the ratio
    that comes nearest), in the windows' order (smallest motor first)."""
    by_name = table.set_index("motor")
    return by_name.loc[list(wins["chosen"])].reset_index()


def with_entry(table: pd.DataFrame, ratios: pd.DataFrame, name: str, catalogue: dict[str, Any]) -> pd.DataFrame:
    """`table` (`loop_table`'s) with the row of `name`'s motor replaced by `name`'s own row of the full screen
    `ratios`: a (motor, ratio) the user named (--steer) stands for its motor."""
    if name in set(table["motor"]):
        return table
    motor = catalogue[name].motor_name
    mine = [catalogue[m].motor_name == motor for m in table["motor"]]
    row = ratios[ratios["motor"] == name]
    if not any(mine):
        return pd.concat([table, row], ignore_index=True)
    at = mine.index(True)
    return pd.concat([table.iloc[:at], row, table.iloc[at + 1 :]], ignore_index=True)


def best_of(wins: pd.DataFrame) -> str | None:
    """The screen's choice: the ratio to buy of the smallest motor with a window, or None."""
    ok = wins[wins["covers"]]
    return str(ok["chosen"].iloc[0]) if len(ok) else None


def window_text(row: Any) -> str:
    """A motor's window in words: '36:1 to 50:1 (below: continuous current; above: voltage line)', or
    'none: best 86.0% at 28:1, where the continuous current binds'."""
    if row["covers"]:
        gaps = f", {int(row['gaps'])} ratio{'s' * (row['gaps'] > 1)} inside short" if row["gaps"] else ""
        below = LIMIT_TEXT.get(row["closed_below"], row["closed_below"])
        above = LIMIT_TEXT.get(row["closed_above"], row["closed_above"])
        return f"{row['window_low']:.4g}:1 to {row['window_high']:.4g}:1 (below: {below}; above: {above}{gaps})"
    binds = LIMIT_TEXT.get(row["binding"], row["binding"]) or "no single limit"
    return f"none: best {row['chosen_coverage']:.1%} at {row['chosen_ratio']:.4g}:1, where the {binds} binds"
