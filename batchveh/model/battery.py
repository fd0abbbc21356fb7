"""The battery of a motor catalogue: its `battery:` section (notebooks/motors.yaml), read here, low, beside the
motors' `load_catalogue` (model/motors.py); the loop (`batchveh.sizing.loop`) checks each run's bus energy and peak
power against it. Public as `batchveh.load_battery`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from batchveh.config import ConfigError, did_you_mean, field, from_mapping, load_yaml


@dataclass(frozen=True)
class Battery:
    """The battery of a catalogue's `battery:` section (notebooks/motors.yaml; SI, at its terminals)."""

    name: str = "battery"
    nominal_voltage: float = field(48.0, unit="V", gt=0)
    capacity: float = field(10.0, unit="A h", gt=0)
    internal_resistance: float = field(0.1, unit="Ohm", ge=0)
    max_continuous_discharge_current: float = field(20.0, unit="A", gt=0)

    @property
    def energy_wh(self) -> float:
        return self.nominal_voltage * self.capacity

    @property
    def max_power(self) -> float:
        """Power at the terminals at the continuous discharge current: (V - I R) I (W)."""
        i = self.max_continuous_discharge_current
        return (self.nominal_voltage - i * self.internal_resistance) * i


def load_battery(path: str | Path) -> Battery:
    """The `battery:` section of a catalogue YAML (notebooks/motors.yaml) as a Battery (its nominal_voltage,
    capacity, internal_resistance and max_continuous_discharge_current, each required; energy_wh and max_power
    derived); other keys of the section are ignored, and a missing section or field is one ConfigError line."""
    data = load_yaml(path)
    raw = data.get("battery") if isinstance(data, dict) else None
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: battery: missing; allowed: a mapping of Battery's fields")
    keep = {k: v for k, v in raw.items() if k in Battery.__dataclass_fields__}
    for need in ("nominal_voltage", "capacity", "internal_resistance", "max_continuous_discharge_current"):
        if need not in keep:  # never a default in its place: a misspelt key would size against another battery
            other = [k for k in raw if k not in Battery.__dataclass_fields__]
            raise ConfigError(f"{path}: battery: {need}: missing{did_you_mean(need, other)}; allowed: a number")
    return from_mapping(Battery, keep, f"{path}: battery")
