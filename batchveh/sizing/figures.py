"""The ratio figures of a sizing report: each motor's screen coverage against its gear ratio, its window marked,
and the requirement sheet's points on a torque-speed plane."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from batchveh.sizing.windows import LIMIT_TEXT, with_motors


def coverage_by_ratio(fig: Any, ratios: pd.DataFrame, wins: pd.DataFrame, catalogue: dict, share: float, what: str):
    """Small multiples on `fig`, one a motor (smallest first): the screen's coverage at each ratio its series
    offer (log ratio), the share asked as a line, the window shaded with the limits that close it, the ratio to
    buy starred."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    ranked = with_motors(ratios, catalogue)
    k = len(wins)
    cols = min(4, k)
    rows = -(-k // cols)
    axes = fig.subplots(rows, cols, squeeze=False, sharey=True)
    for ax in axes.ravel()[k:]:
        ax.set_visible(False)
    for ax, (_, w) in zip(axes.ravel(), wins.iterrows(), strict=False):
        g = ranked[ranked["motor_name"] == w["motor_name"]].sort_values("gear_ratio")
        for series, h in g.groupby("series", sort=False):
            ax.plot(h["gear_ratio"], 100 * h["coverage"], "o-", ms=3, lw=1, label=series or "pairing")
        ax.axhline(100 * share, color="k", lw=0.6, ls=":")
        if w["covers"]:
            ax.axvspan(w["window_low"], w["window_high"], color="tab:green", alpha=0.15)
            below = LIMIT_TEXT.get(w["closed_below"], w["closed_below"])
            above = LIMIT_TEXT.get(w["closed_above"], w["closed_above"])
            note = f"window {w['window_low']:g}-{w['window_high']:g}:1\nbelow: {below}\nabove: {above}"
        else:
            note = f"no window; best {w['chosen_coverage']:.1%}\n{LIMIT_TEXT.get(w['binding'], w['binding'])} binds"
        ax.plot([w["chosen_ratio"]], [100 * w["chosen_coverage"]], "*", ms=12, color="tab:red")
        ax.text(0.02, 0.03, note, transform=ax.transAxes, fontsize=6.5, va="bottom")
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_ylim(-2, 102)
        ax.set_title(f"{w['motor_name']}\nK i_max {w['shaft_continuous_torque']:.3g} N m", fontsize=8)
        ax.set_xlabel("gear ratio N", fontsize=8)
        ax.legend(fontsize=6, loc="center right")
    for ax in axes[:, 0]:
        ax.set_ylabel(f"{what}: screen coverage (%)", fontsize=8)


SHEET_MARKS = {
    "rms_torque": ("s", "sheet: RMS torque at the duty"),
    "peak_torque": ("^", "sheet: peak torque"),
    "torque_at_top_speed": ("D", "sheet: torque at top speed"),
}


def sheet_points(ax: Any, sheet: dict[str, Any], speed: np.ndarray) -> None:
    """The drive's requirement sheet on a torque-speed plane at the wheel: each torque figure at the speed of the
    variant that sets it (the torque at top speed at the top speed), and the top speed as a vertical line."""
    wheel = sheet["at_wheel"]
    top = wheel.get("top_speed", {}).get("value")
    for key, (marker, label) in SHEET_MARKS.items():
        fig = wheel.get(key)
        if fig is None or not np.isfinite(fig["value"]) or fig["row"] < 0:
            continue
        at = top if key == "torque_at_top_speed" else abs(float(speed[fig["row"]]))
        ax.plot([at], [fig["value"]], marker, ms=9, mfc="none", mec="tab:red", mew=1.5, label=label)
    if top is not None and np.isfinite(top):
        ax.axvline(top, color="tab:red", lw=0.8, ls="--", label="sheet: top speed")
