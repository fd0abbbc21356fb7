"""Motor sizing: does a motor (through its gearbox) cover each variant's drive torques?

A motor spec, in YAML:

```yaml
motors:
  - name: M100
    continuous_torque: 1.2   # N m at the motor shaft, thermally sustainable
    peak_torque: 3.5         # N m at the motor shaft, short-term
    max_speed: 600           # rad/s at the motor shaft (no-load)
    corner_speed: 400        # rad/s: above it the torque limit falls as constant power
    gear_ratio: 20           # motor turns per wheel turn
    efficiency: 0.9          # gearbox efficiency, 0-1
```

Checks per variant, on the worst of the four drive motors: the steady-window RMS torque
against the continuous torque; the whole-run low-pass peak (`peak_lp_all`) against the
torque limit at that speed; the wheel speed against the maximum speed.

`check_mission` does the same against a mission's duty cycle (`batchveh.model.missions`): the RMS
over the mission (or one segment) against the continuous torque, the mission's low-pass peak
against the peak torque, reported at the wheel and at the motor shaft.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from batchveh.config import ConfigError, field, from_mapping, load_yaml

WHEELS = ("drive_lf", "drive_rf", "drive_lr", "drive_rr")
GROUPS = {"drive": WHEELS, "steer": ("steer_lf", "steer_rf", "steer_lr", "steer_rr")}


@dataclass(frozen=True)
class Motor:
    """A drive motor with its gearbox; torques and speeds at the motor shaft."""

    name: str = "motor"
    continuous_torque: float = field(1.0, unit="N m", gt=0)
    peak_torque: float = field(3.0, unit="N m", gt=0)
    max_speed: float = field(600.0, unit="rad/s", gt=0)
    corner_speed: float = field(400.0, unit="rad/s", gt=0)
    gear_ratio: float = field(20.0, unit="1", gt=0)
    efficiency: float = field(0.9, unit="1", gt=0, le=1)

    def validate(self, where: str = "motor") -> None:
        if self.peak_torque < self.continuous_torque:
            raise ConfigError(
                f"{where}.peak_torque: {self.peak_torque!r} is below continuous_torque "
                f"{self.continuous_torque!r}; allowed: >= continuous_torque"
            )
        if self.corner_speed > self.max_speed:
            raise ConfigError(f"{where}.corner_speed: {self.corner_speed!r} exceeds max_speed {self.max_speed!r}")

    def torque_limit(self, speed: np.ndarray | float) -> np.ndarray:
        """Peak torque available at motor speed `speed` (rad/s): flat to the corner, then constant power."""
        w = np.abs(np.asarray(speed, float))
        limit = np.where(
            w <= self.corner_speed, self.peak_torque, self.peak_torque * self.corner_speed / np.maximum(w, 1e-12)
        )
        return np.where(w <= self.max_speed, limit, 0.0)


def load_motors(path: str | Path) -> list[Motor]:
    """Motors from a YAML file with a `motors:` list (or one motor mapping)."""
    data = load_yaml(path)
    items = data.get("motors", [data]) if isinstance(data, dict) else data
    if not isinstance(items, list) or not items:
        raise ConfigError(f"{path}: motors: expected a non-empty list of motor mappings")
    return [from_mapping(Motor, item, f"{path}: motors[{i}]") for i, item in enumerate(items)]


def check(df: pd.DataFrame, motor: Motor) -> pd.DataFrame:
    """Per-variant shaft torques and speed and whether `motor` suffices (columns fits_*)."""
    scale = motor.gear_ratio * motor.efficiency
    out = pd.DataFrame(index=df.index)
    out["shaft_rms"] = df[[f"{w}_rms" for w in WHEELS]].abs().max(axis=1) / scale
    out["shaft_peak"] = df[[f"{w}_peak_lp_all" for w in WHEELS]].abs().max(axis=1) / scale
    out["shaft_speed"] = df["wheel_speed"].abs() * motor.gear_ratio
    out["fits_continuous"] = out.shaft_rms <= motor.continuous_torque
    out["fits_peak"] = out.shaft_peak <= motor.torque_limit(out.shaft_speed)
    out["fits_speed"] = out.shaft_speed <= motor.max_speed
    out["fits"] = out.fits_continuous & out.fits_peak & out.fits_speed
    return out


def check_mission(df: pd.DataFrame, motor: Motor, span: str = "mission", group: str = "drive") -> pd.DataFrame:
    """Per-variant mission torques against `motor`, at the wheel and at the motor shaft (fits_*).

    On the worst of the group's four motors ('drive' or 'steer') over `span` ('mission', the whole
    duty cycle, or a segment's prefix such as 'seg2_climb'):
    - continuous: the RMS torque (`<span>_<motor>_rms`) against continuous_torque;
    - peak: the low-pass peak (`<span>_<motor>_peak_lp`) against the torque limit at the span's peak
      speed (`<span>_<motor>_speed_peak`): conservative, as if the peak torque came at the top speed;
    - speed: that peak speed against max_speed.
    At the wheel (N m, rad/s): the torques as simulated, against the motor's ratings through the
    gearbox (torque x gear_ratio x efficiency, speed / gear_ratio). At the shaft: the torques
    / (gear_ratio x efficiency) and the speed x gear_ratio, against the ratings themselves."""
    if group not in GROUPS:
        raise ConfigError(f"group: {group!r} is not allowed; allowed: {', '.join(GROUPS)}")
    names = GROUPS[group]
    missing = [
        f"{span}_{m}_{s}" for m in names for s in ("rms", "peak_lp", "speed_peak") if f"{span}_{m}_{s}" not in df
    ]
    if missing:
        spans = sorted({c.removesuffix("_drive_lf_rms") for c in df.columns if c.endswith("_drive_lf_rms")})
        raise ConfigError(
            f"span: {span!r} has no column {missing[0]} (not a mission result, or another span); "
            f"allowed: {', '.join(s for s in spans if s.startswith(('mission', 'seg'))) or 'a mission result'}"
        )
    through = motor.gear_ratio * motor.efficiency  # wheel torque per shaft torque
    out = pd.DataFrame(index=df.index)
    out["wheel_rms"] = df[[f"{span}_{m}_rms" for m in names]].abs().max(axis=1)
    out["wheel_peak"] = df[[f"{span}_{m}_peak_lp" for m in names]].abs().max(axis=1)
    out["wheel_speed_peak"] = df[[f"{span}_{m}_speed_peak" for m in names]].abs().max(axis=1)
    out["shaft_rms"] = out.wheel_rms / through
    out["shaft_peak"] = out.wheel_peak / through
    out["shaft_speed_peak"] = out.wheel_speed_peak * motor.gear_ratio
    shaft_limit = motor.torque_limit(out.shaft_speed_peak)
    out["wheel_continuous_rating"] = motor.continuous_torque * through
    out["wheel_peak_limit"] = shaft_limit * through
    out["wheel_max_speed"] = motor.max_speed / motor.gear_ratio
    out["fits_continuous"] = out.shaft_rms <= motor.continuous_torque
    out["fits_peak"] = out.shaft_peak <= shaft_limit
    out["fits_speed"] = out.shaft_speed_peak <= motor.max_speed
    out["fits"] = out.fits_continuous & out.fits_peak & out.fits_speed
    return out


def smallest(df: pd.DataFrame, catalogue: list[Motor], span: str | None = None) -> tuple[Motor | None, pd.DataFrame]:
    """The motor with the lowest continuous torque that fits every row, and a per-motor summary.

    `span`: None checks the usual columns (`check`: the steady window's RMS, the whole run's
    peaks); a mission span ('mission', or a segment's prefix such as 'seg2_climb') checks the
    mission's columns over it (`check_mission`)."""
    rows: list[dict[str, Any]] = []
    checks = {m.name: check(df, m) if span is None else check_mission(df, m, span) for m in catalogue}
    for m in catalogue:
        c = checks[m.name]
        rows.append(
            {
                "motor": m.name,
                "continuous_torque": m.continuous_torque,
                "peak_torque": m.peak_torque,
                "gear_ratio": m.gear_ratio,
                "fits_all": bool(c.fits.all()),
                "fit_fraction": float(c.fits.mean()),
                "continuous_fails": int((~c.fits_continuous).sum()),
                "peak_fails": int((~c.fits_peak).sum()),
                "speed_fails": int((~c.fits_speed).sum()),
            }
        )
    summary = pd.DataFrame(rows).sort_values("continuous_torque").reset_index(drop=True)
    fitting = [m for m in sorted(catalogue, key=lambda m: m.continuous_torque) if checks[m.name].fits.all()]
    return (fitting[0] if fitting else None), summary
