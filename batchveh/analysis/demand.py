"""From a servo sweep's rows to what a motor must deliver: each variant's demand at the wheel on the worst of a
group's motors (`demand`), and the groups' motor names (WHEELS, GROUPS; GROUP_RISES: the parameter of each
group's start rise; `groups` and `group_rises`: the same on a steering layout, whose fixed hubs are no motor).
Below sizing (`batchveh.sizing`): `analysis.plot` reads the demand too."""

from __future__ import annotations

import pandas as pd

from batchveh.config import ConfigError
from batchveh.model.vehicle import CORNERS, LAYOUTS, STEERED

WHEELS = ("drive_lf", "drive_rf", "drive_lr", "drive_rr")
GROUPS = {"drive": WHEELS, "steer": ("steer_lf", "steer_rf", "steer_lr", "steer_rr")}  # the four-wheel layout's
RISE_GROUP = {"motors.drive_start_rise": "drive", "motors.steer_start_rise": "steer"}  # each start rise's group
GROUP_RISES = {key: GROUPS[group] for key, group in RISE_GROUP.items()}  # each start rise's motors (four-wheel)
LAYOUT_TEXT = {  # the steering group of each layout, in words (the sizing's report and its sizing.json)
    "four_wheel": "four-wheel steering: four steering motors (every hub steers)",
    "skid": "skid steering: no steering motors (every hub fixed)",
    "front": "front steering: two steering motors (front hubs); rear hubs fixed",
}


def groups(layout: str = "four_wheel") -> dict[str, tuple[str, ...]]:
    """Each group's motors on a steering layout (`steering.layout`, vehicle.STEERED): the four drives on every
    layout; the steering motor of each hub that steers (four_wheel: the four, GROUPS; front: steer_lf, steer_rf;
    skid: none). A fixed hub's `steer_<corner>` columns are the moment its mounting carries, never a motor's: no
    steering demand, statistic or verdict reads them."""
    if layout not in LAYOUTS:
        raise ConfigError(f"steering.layout: {layout!r} is not allowed; allowed: {', '.join(LAYOUTS)}")
    steer = tuple(f"steer_{c}" for c, s in zip(CORNERS, STEERED[layout], strict=True) if s)
    return {"drive": WHEELS, "steer": steer}


def group_rises(layout: str = "four_wheel") -> dict[str, tuple[str, ...]]:
    """GROUP_RISES on a layout: each start rise's motors (`groups`), the steering's only where a hub steers."""
    names = groups(layout)
    return {key: names[group] for key, group in RISE_GROUP.items() if names[group]}


def demand(df: pd.DataFrame, group: str = "drive", span: str | None = None, layout: str = "four_wheel") -> pd.DataFrame:
    """Each variant's demand on the worst of the group's motors on the steering `layout` (`groups`: the four
    drives; the steering motors of the hubs that steer), at the wheel: RMS and peak torque
    (N m), and speed (rad/s): the steady window's RMS, the whole run's low-pass peak and the mean
    wheel speed; or a mission span's RMS, peak and peak speed. A group or span with no such columns, or the
    steering of a layout with no steering motor (skid), is one ConfigError line."""
    if group not in GROUPS:
        raise ConfigError(f"group: {group!r} is not allowed; allowed: {', '.join(GROUPS)}")
    names = groups(layout)[group]
    if not names:
        raise ConfigError(
            f"group: {group!r} has no motor on steering.layout {layout!r} ({LAYOUT_TEXT[layout]}); allowed: drive"
        )
    need = [f"{m}_rms" for m in names] if span is None else [f"{span}_{m}_rms" for m in names]
    if need[0] not in df:
        spans = sorted({c.removesuffix("_drive_lf_rms") for c in df.columns if c.endswith("_drive_lf_rms")})
        allowed = ", ".join(x for x in spans if x.startswith(("mission", "seg"))) or "none (not a mission result)"
        raise ConfigError(f"span: {span!r} has no column {need[0]}; allowed: None or a mission span: {allowed}")
    out = pd.DataFrame(index=df.index)
    if span is None:
        out["rms"] = df[[f"{m}_rms" for m in names]].abs().max(axis=1)
        out["peak"] = df[[f"{m}_peak_lp_all" for m in names]].abs().max(axis=1)
        # the current's bound against a drive's steady-window peak (a ramp's peak it rides through, falling behind
        # for a moment), but against the steering's whole-run peak: a steering motor at its bound loses its angle
        # (the 250 kg AGV's 4.24 N m steering against the drive's force at the scrub radius, 8.6 N m on its ramp,
        # turned its wheels 80-315 deg). A frame without the window's columns (made by hand): the whole run's.
        window = [f"{m}_peak_lp" for m in names]
        steady = group == "drive" and window[0] in df
        out["peak_window"] = df[window].abs().max(axis=1) if steady else out["peak"]
        if steady:  # what the four drives can share (screen_one)
            out["rms_mean"] = df[[f"{m}_rms" for m in names]].abs().mean(axis=1)
            out["peak_window_mean"] = df[window].abs().mean(axis=1)
            for j, m in enumerate(names):  # each wheel's own, for the share the others can take (screen_one)
                out[f"rms_{j}"], out[f"peak_window_{j}"] = df[f"{m}_rms"].abs(), df[f"{m}_peak_lp"].abs()
        out["speed"] = df["wheel_speed"].abs() if group == "drive" else 0.0
    else:
        out["rms"] = df[[f"{span}_{m}_rms" for m in names]].abs().max(axis=1)
        out["peak"] = df[[f"{span}_{m}_peak_lp" for m in names]].abs().max(axis=1)
        out["peak_window"] = out["peak"]
        out["speed"] = df[[f"{span}_{m}_speed_peak" for m in names]].abs().max(axis=1)
    return out
