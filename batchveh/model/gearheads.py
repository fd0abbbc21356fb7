"""Gearhead series of a motor catalogue: every ratio a vendor offers, and the (motor, ratio) pairs they make.

A catalogue (`notebooks/motors.yaml`) may hold, beside its `motors:` list, a `gearhead_series:` list:

```yaml
gearhead_series:
  - name: maxon-GP52C                 # unique; a motor's `series:` names it
    max_input_speed: 628.3            # rad/s; a value at the series' level is every ratio's default
    ratios:                           # every ratio the vendor offers
      - {ratio: 3.5, label: "3.5:1", stages: 1, efficiency: 0.91, max_continuous_torque: 4.0,
         max_intermittent_torque: 6.0}
motors:
  - name: maxon-578298-RE50-48V_GP52C-i26
    motor: maxon-578298-RE50-48V      # the physical motor (entries sharing it are one motor at several ratios)
    series: [maxon-GP52C]             # the series that fit it; or [{name: maxon-GP52C, ratios: [26, 43]}]
    ...
```

Each motor that names a series gets one catalogue entry per ratio it allows (`combination`): the motor's datasheet
values with that ratio's reduction, efficiency and ratings, named `<motor>_<series>-i<label>`. An entry already
in the catalogue under that name (a pairing written out by hand) stays as written. A series' values are at the
gearhead's output (torques, N m) or its input (speed, rad/s; inertia, kg m^2), as the catalogue's rules say.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from batchveh.config import ConfigError, did_you_mean

# a gearhead's keys that set a DCMotor field, in a pairing's `gearhead:` block and in a series' ratio alike
GEAR_FIELDS = {
    "ratio": "gear_ratio",
    "efficiency": "gear_efficiency",
    "max_continuous_torque": "gear_max_continuous_torque",
    "max_intermittent_torque": "gear_max_intermittent_torque",
    "max_input_speed": "gear_max_input_speed",
}
RATIO_KEYS = (*GEAR_FIELDS, "inertia_at_input", "stages", "mass", "label", "product_number")  # a ratio's keys
SERIES_KEYS = {"name", "ratios", "vendor", "product", "source", "source_detail", "confidence", *RATIO_KEYS} - {
    "ratio",
    "label",
    "product_number",
}


@dataclass(frozen=True)
class GearRatio:
    """One ratio of a series: its reduction N and, where the vendor prints them, its efficiency and ratings."""

    ratio: float
    label: str
    efficiency: float | None = None
    max_continuous_torque: float | None = None  # N m at the output
    max_intermittent_torque: float | None = None  # N m at the output
    max_input_speed: float | None = None  # rad/s at the input
    stages: float | None = None


@dataclass(frozen=True)
class GearheadSeries:
    """A vendor's gearhead series: its name and every ratio it offers, ascending."""

    name: str
    ratios: tuple[GearRatio, ...]

    def offers(self, ratio: float) -> GearRatio | None:
        """The series' ratio whose reduction or label is `ratio` (within 0.5%), or None."""
        for r in self.ratios:
            if abs(r.ratio - ratio) <= 0.005 * r.ratio or r.label.split(":")[0] == f"{ratio:g}":
                return r
        return None


def number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigError(f"{where}: {value!r} is not a number; allowed: a finite number")
    return float(value)


def _ratio(raw: Any, defaults: dict[str, Any], where: str) -> GearRatio:
    if not isinstance(raw, dict):
        raise ConfigError(f"{where}: {raw!r} is not a mapping; allowed: {{ratio: N, efficiency: ..., ...}}")
    for key in raw:
        if key not in RATIO_KEYS:
            raise ConfigError(
                f"{where}: {key}: unknown key{did_you_mean(key, RATIO_KEYS)}; allowed: {', '.join(RATIO_KEYS)}"
            )
    if "ratio" not in raw:
        raise ConfigError(f"{where}: ratio: missing; allowed: the reduction N > 0")
    values = {**defaults, **raw}
    if values.get("efficiency") is None:  # never 100% in its place: the motor would be sized on a lossless gear
        raise ConfigError(f"{where}: efficiency: missing; allowed: the vendor's efficiency, 0 < value <= 1")
    got: dict[str, Any] = {}
    for key in ("ratio", "efficiency", "max_continuous_torque", "max_intermittent_torque", "max_input_speed", "stages"):
        if values.get(key) is not None:
            got[key] = number(values[key], f"{where}: {key}")
            if got[key] <= 0:
                raise ConfigError(f"{where}: {key}: {got[key]!r} is not allowed; allowed: > 0")
    for key in ("inertia_at_input", "mass"):
        if values.get(key) is not None:
            number(values[key], f"{where}: {key}")
    if got.get("efficiency") is not None and not got["efficiency"] <= 1:
        raise ConfigError(f"{where}: efficiency: {got['efficiency']!r} is not allowed; allowed: 0 < value <= 1")
    label = str(raw.get("label") or f"{got['ratio']:g}:1")
    return GearRatio(label=label, **got)


def load_series(raw: Any, path: str) -> dict[str, GearheadSeries]:
    """A catalogue's `gearhead_series:` list as {name: GearheadSeries}; one ConfigError line naming the file, the
    series and the key for a missing name, a series with no ratios, an unknown key or a rating not a number."""
    out: dict[str, GearheadSeries] = {}
    if raw is None:
        return out
    if not isinstance(raw, list):
        raise ConfigError(f"{path}: gearhead_series: {type(raw).__name__} is not allowed; allowed: a list of series")
    for i, entry in enumerate(raw):
        where = f"{path}: gearhead_series[{i}]"
        if not isinstance(entry, dict) or not entry.get("name"):
            raise ConfigError(f"{where}: name: missing; allowed: a unique name")
        name = str(entry["name"])
        where = f"{path}: gearhead_series[{i}] ({name})"
        for key in entry:
            if key not in SERIES_KEYS:
                keys = ", ".join(sorted(SERIES_KEYS))
                raise ConfigError(f"{where}: {key}: unknown key{did_you_mean(key, SERIES_KEYS)}; allowed: {keys}")
        ratios = entry.get("ratios")
        if not isinstance(ratios, list) or not ratios:
            raise ConfigError(f"{where}: ratios: {ratios!r} is not allowed; allowed: a list of at least one ratio")
        defaults = {k: v for k, v in entry.items() if k in RATIO_KEYS}
        parsed = tuple(_ratio(r, defaults, f"{where}: ratios[{j}]") for j, r in enumerate(ratios))
        if name in out:
            raise ConfigError(f"{where}: name: {name!r} is given twice; allowed: a unique name")
        out[name] = GearheadSeries(name, tuple(sorted(parsed, key=lambda r: r.ratio)))
    return out


def allowed(raw: Any, series: dict[str, GearheadSeries], where: str) -> list[tuple[GearheadSeries, GearRatio]]:
    """A motor entry's `series:` (a list of series names, or of {name, ratios} mappings restricting the ratios the
    vendor's combination table allows with it) as its (series, ratio) pairs; one ConfigError line for an unknown
    series (did-you-mean) or a ratio the series does not offer."""
    if raw is None:
        return []
    if not isinstance(raw, list):
        raw = [raw]
    out = []
    for j, item in enumerate(raw):
        name, only = (item.get("name"), item.get("ratios")) if isinstance(item, dict) else (item, None)
        if name not in series:
            raise ConfigError(
                f"{where}: series[{j}]: {name!r} is not a series of the catalogue{did_you_mean(name, series)}; "
                f"allowed: {', '.join(series) or 'none (no gearhead_series: section)'}"
            )
        s = series[name]
        if only is None:
            out += [(s, r) for r in s.ratios]
            continue
        for ratio in only if isinstance(only, list) else [only]:
            value = number(ratio, f"{where}: series[{j}] ({name}): ratios")
            got = s.offers(value)
            if got is None:
                offered = ", ".join(r.label for r in s.ratios)
                raise ConfigError(
                    f"{where}: series[{j}] ({name}): ratios: {ratio!r} is not a ratio {name} offers; allowed: {offered}"
                )
            out.append((s, got))
    return out


def combination(motor: Any, s: GearheadSeries, r: GearRatio) -> Any:
    """The DCMotor `motor` on ratio `r` of series `s`: its gearhead fields replaced by the ratio's (a rating the
    series does not print is None: not checked), named `<motor>_<series>-i<label>`."""
    label = r.label.split(":")[0]
    gear = {field: getattr(r, key) for key, field in GEAR_FIELDS.items()}
    return dataclasses.replace(
        motor, name=f"{motor.motor_name}_{s.name}-i{label}", motor=motor.motor_name, series=s.name, **gear
    )
