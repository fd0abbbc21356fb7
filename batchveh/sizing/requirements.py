"""The requirement sheet: what a motor must deliver over the share of the conditions asked, and how far each
catalogue motor falls from it.

Each figure is a nearest-rank quantile over the servo sweep's variants: the value that `share` of them need at
most (with share 0.99 and 300 variants, the 297th smallest), taken on the worst of the group's motors
(`batchveh.analysis.demand.demand`: the four drives; the steering motors of the hubs that steer on the vehicle's
steering layout, none on a skid-steered one, which has no steering sheet), and it names the variant that sets it.
At the wheel (the hinge for the steering):

- rms_torque: the RMS torque at the spec's duty, sqrt(duty) x the span's RMS (N m);
- peak_torque: the low-pass peak torque the screen judges against the current's bound: a straight line's
  steady window (its speed held), a duty cycle's or a steering motor's whole run (N m); `accel_peak_torque`: a
  straight line's whole run, its speed ramp with it;
- top_speed: the wheel speed (a straight line's mean over its window, a duty cycle's peak; rad/s), and
  torque_at_top_speed, the peak torque over the variants within 10% of that speed (N m);
- continuous_power: the RMS torque at the duty times the speed (W; the mean mechanical power is at most this);
- peak_power: the largest |torque x speed| of one wheel over the run, where the sweep recorded it, else the peak
  torque times the speed (W).

At the motor's shaft for a ratio N with efficiency eta: torque / (eta N), speed x N, power / eta.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from batchveh.analysis.demand import demand, groups
from batchveh.sizing.screening import bound_at_wheel, terminal_voltage

UNITS = {
    "rms_torque": "N m",
    "peak_torque": "N m",
    "accel_peak_torque": "N m",
    "top_speed": "rad/s",
    "torque_at_top_speed": "N m",
    "continuous_power": "W",
    "peak_power": "W",
}
NEAR_TOP = 0.10  # the torque at top speed: over the variants within this share of the top speed


def nearest_rank(values: np.ndarray, share: float, counted: np.ndarray | None = None) -> tuple[float, int]:
    """The value `share` of the counted values are at most (nearest rank: the ceil(share n)-th smallest) and its
    row; (nan, -1) where none is counted."""
    values = np.asarray(values, float)
    rows = np.flatnonzero(np.ones(len(values), bool) if counted is None else np.asarray(counted, bool))
    rows = rows[np.isfinite(values[rows])]
    if not len(rows):
        return math.nan, -1
    order = rows[np.argsort(values[rows], kind="stable")]
    k = max(int(math.ceil(share * len(order) - 1e-9)), 1) - 1
    return float(values[order[k]]), int(order[k])


def per_variant(
    df: pd.DataFrame, group: str, span: str | None, duty: float, layout: str = "four_wheel"
) -> pd.DataFrame:
    """Each variant's figures on the worst of the group's motors on the steering `layout`, at the wheel (the
    module's list)."""
    need = demand(df, group, span, layout)
    out = pd.DataFrame(index=df.index)
    out["rms_torque"] = math.sqrt(duty) * need["rms"]
    out["peak_torque"] = need["peak_window"]
    if span is None and group == "drive":
        out["accel_peak_torque"] = need["peak"]
    out["top_speed"] = need["speed"]
    out["continuous_power"] = out["rms_torque"] * need["speed"]
    names = groups(layout)[group]
    recorded = [f"{m}_power_peak" for m in names]
    if span is None and recorded[0] in df:
        out["peak_power"] = df[recorded].abs().max(axis=1)
    else:
        out["peak_power"] = need["peak"] * need["speed"]
    return out


def _figure(value: float, row: int, df: pd.DataFrame, params: list[str], unit: str) -> dict[str, Any]:
    variant = {} if row < 0 else {p: _plain(df[p].iloc[row]) for p in params if p in df}
    return {"value": value, "unit": unit, "row": row, "variant": variant}


def _plain(x: Any) -> Any:
    return x.item() if hasattr(x, "item") else x


def at_wheel(
    df: pd.DataFrame,
    group: str,
    span: str | None,
    duty: float,
    share: float,
    params: list[str],
    layout: str = "four_wheel",
) -> dict[str, dict[str, Any]]:
    """The sheet at the wheel (the hinge): {figure: {value, unit, row, variant}} (the module's list)."""
    v = per_variant(df, group, span, duty, layout)
    out = {}
    for key in v.columns:
        value, row = nearest_rank(v[key].to_numpy(), share)
        out[key] = _figure(value, row, df, params, UNITS[key])
    top = out["top_speed"]["value"]
    if not (np.isfinite(top) and top > 0):  # no speed asked of the motor (a straight line's steering): no speed rows
        out = {k: f for k, f in out.items() if k in ("rms_torque", "peak_torque", "accel_peak_torque")}
    if group == "drive" and np.isfinite(top) and top > 0:
        near = v["top_speed"].to_numpy() >= (1 - NEAR_TOP) * top
        value, row = nearest_rank(v["peak_torque"].to_numpy(), share, near)
        out["torque_at_top_speed"] = _figure(value, row, df, params, UNITS["torque_at_top_speed"])
    order = list(UNITS)
    return {k: out[k] for k in order if k in out}


def at_shaft(wheel: dict[str, dict[str, Any]], ratio: float, efficiency: float) -> dict[str, dict[str, Any]]:
    """The sheet at the motor's shaft behind a gearhead of `ratio` and `efficiency`."""
    out = {}
    for key, fig in wheel.items():
        scale = {"N m": 1.0 / (efficiency * ratio), "rad/s": ratio, "W": 1.0 / efficiency}[fig["unit"]]
        out[key] = {**fig, "value": fig["value"] * scale}
    return out


def sheet(
    df: pd.DataFrame,
    group: str,
    span: str | None,
    duty: float,
    share: float,
    params: list[str],
    motor: Any = None,
    layout: str = "four_wheel",
) -> dict[str, Any]:
    """A group's requirement sheet on the steering `layout`: at the wheel, and at the shaft of `motor` (a catalogue
    DCMotor: its ratio and efficiency; None: the wheel's only)."""
    wheel = at_wheel(df, group, span, duty, share, params, layout)
    out: dict[str, Any] = {"share": share, "duty": duty, "span": span or "window", "at_wheel": wheel}
    if motor is not None:
        out["at_shaft"] = {
            "motor": motor.name,
            "ratio": motor.gear_ratio,
            "efficiency": motor.gear_efficiency,
            **at_shaft(wheel, motor.gear_ratio, motor.gear_efficiency),
        }
    return out


def shortfall(motor: Any, wheel: dict[str, dict[str, Any]]) -> dict[str, float]:
    """How far `motor` (at its ratio) falls from the sheet at the wheel: each limit's need over what it gives
    (above 1: short by that factor). continuous: the RMS torque over eta N K i_max; peak: the peak torque over the
    same bound; speed: the top speed x N over the no-load speed at the bus, V / K; voltage: the voltage the torque at
    top speed (at most the bound) needs at that speed over the bus; gear_torque, gear_speed: the gearhead's."""
    c = motor.resolved()
    bound = bound_at_wheel(c)
    val = {k: f["value"] for k, f in wheel.items()}
    top = val.get("top_speed", 0.0) or 0.0
    out = {"continuous": val["rms_torque"] / bound, "peak": val["peak_torque"] / bound}
    if top > 0:
        out["speed"] = top * c["N"] / (c["V"] / c["K"])
        corner = min(val.get("torque_at_top_speed", val["peak_torque"]), bound)
        out["voltage"] = float(terminal_voltage(corner, top, c)) / c["V"]
    gear = []
    if motor.gear_max_continuous_torque is not None:
        gear.append(min(val["rms_torque"], bound) / motor.gear_max_continuous_torque)
    if motor.gear_max_intermittent_torque is not None:
        gear.append(min(val["peak_torque"], bound) / motor.gear_max_intermittent_torque)
    if gear:
        out["gear_torque"] = max(gear)
    if motor.gear_max_input_speed is not None and top > 0:
        out["gear_speed"] = top * c["N"] / motor.gear_max_input_speed
    return {k: float(v) for k, v in out.items()}


SHORT_TEXT = {
    "continuous": "its continuous torque (K i_max through the gearhead)",
    "peak": "its current's bound at the peak torque",
    "speed": "its no-load speed at the bus voltage",
    "voltage": "its bus voltage at top speed",
    "gear_torque": "its gearhead's torque rating",
    "gear_speed": "its gearhead's input speed",
}


def short_line(motor: Any, wheel: dict[str, dict[str, Any]]) -> str:
    """`motor` against the sheet in words: 'needs 1.6x its continuous torque ... at 9.5 rad/s' for its worst
    factor, or 'meets every figure of the sheet'."""
    f = shortfall(motor, wheel)
    key = max(f, key=f.get)
    if f[key] <= 1.0:
        return f"meets every figure of the sheet at {motor.gear_ratio:g}:1 (worst: {SHORT_TEXT[key]}, {f[key]:.2f}x)"
    top = wheel.get("top_speed", {}).get("value", 0.0) or 0.0
    at = f" at {top:.3g} rad/s" if key in ("voltage", "speed", "gear_speed") and top > 0 else ""
    return f"needs {f[key]:.2f}x {SHORT_TEXT[key]}{at}, at {motor.gear_ratio:g}:1"


def sheets(
    df: Any, spec: Any, span: str | None, share: float, cat: dict, drive: str, steer: str | None, wins: Any
) -> dict[str, Any]:
    """The session's requirement sheets: the drive's at the wheel and at the shaft of `drive`, the
    steering's at the hinge and at the shaft of `steer` (its steered hubs' only; None on a skid-steered vehicle,
    which has no steering motor: `steer` None); with each motor's shortfall against the drive's sheet at
    the ratio where it comes nearest (`would`: {motor: line}) and the (motor, ratio) nearest to covering."""
    params = list(spec.params)
    layout = spec.vehicle.steering.layout
    steered = bool(groups(layout)["steer"])
    out = {
        "drive": sheet(df, "drive", span, spec.duty, share, params, cat[drive], layout),
        "steer": sheet(df, "steer", span, spec.duty, share, params, cat[steer], layout) if steered else None,
    }
    wheel = out["drive"]["at_wheel"]
    by_motor: dict[str, list] = {}
    for m in cat.values():
        by_motor.setdefault(m.motor_name, []).append(m)
    # each motor at the ratio where it comes nearest the sheet: the least of its worst factor
    out["would"] = {  # smallest motor first, as the windows
        name: short_line(min(by_motor[name], key=lambda m: max(shortfall(m, wheel).values())), wheel)
        for name in wins["motor_name"]
    }
    near = wins.sort_values("chosen_coverage", ascending=False, kind="stable").iloc[0]
    out["nearest"] = {"motor": near["chosen"], "ratio": near["chosen_ratio"], "coverage": near["chosen_coverage"],
                      "binding": near["binding"] or near["closed_below"]}  # fmt: skip
    return out
