"""DC motors with their gearheads, from datasheet values, as MuJoCo's `dcmotor` actuator (issue 31).

A catalogue entry (`notebooks/motors.yaml`) gives a motor as its datasheet does, at the
motor shaft, and its gearhead. `DCMotor.resolved()` turns it into the constants MuJoCo's dcmotor
takes (MuJoCo's XML reference, actuator/dcmotor, and its DC motor technical note):

- K (N m/A = V s/rad) and R (Ohm): from `torque_constant` and `terminal_resistance`, or from the
  nominal triple (voltage V, stall torque, no-load speed): K = V / no_load_speed and R = K V /
  stall_torque, as MuJoCo's compiler derives them. Where both are given, they must agree within
  TRIPLE_RTOL (datasheets round), else one line names the contradiction;
- the current limit (`max_continuous_current`) clips the torque to K i_max;
- the thermal model: R_T = winding-housing + housing-ambient resistance (K/W), the time constant
  (the winding's, s) or the capacitance C (J/K), with C = t_T / R_T; copper's temperature
  coefficient 0.0039 / K against the datasheet's 25 deg C;
- the gearhead: `gear` = its ratio N; the rotor inertia is MuJoCo's actuator armature, reflected
  through N^2 at the wheel by MuJoCo.

The gearhead's efficiency eta: MuJoCo's note suggests K -> eta K, which also lowers the back-EMF, so
the no-load speed would read V / (eta K). Here the motor keeps its K and the simulated motor's
resistance is R / eta instead: its current i' = eta (v - K w) / R is eta times the real current i, so
the wheel gets eta N K i, the back-EMF is the real K w (no-load speed V / K exactly), the current
limit is eta i_max in the simulated current, and the thermal model (heated by i'^2 R / eta = eta i^2
R) takes R_T / eta and eta C so that the winding heats by the real i^2 R(T). Electrical power is
v i = v i' / eta; the gearhead loses K i w (1 - eta) while motoring. The same eta acts when the wheel
drives the motor (regeneration), where a real gearhead loses 1/eta: a known simplification.

Why the vehicle uses MuJoCo's dcmotor with a voltage input and batchveh's drive (model/drive.py), not its
on-board controller and thermal state (measured, tests/test_dcmotor.py rig; docs/motors.md):
- `saturation`'s current clips the torque, not the current that heats MuJoCo's winding (3.17 and 4.0): a
  blocked motor at V / R = 20 A with a 4 A limit delivered 4 A's torque and heated with 20 A's i^2 R;
- the on-board controller compensates the back-EMF with the resistance at the reference temperature, and
  has no anti-windup at the current limit;
- with `implicitfast` (3.17), the controller's kd is integrated implicitly as the motor's damping even while
  the voltage is clamped, which slows a clamped motor's transients.

`dcmotor_xml` writes one actuator with `input="voltage"` (ctrl: the terminal voltage).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from batchveh.config import ConfigError, did_you_mean, load_yaml

TRIPLE_RTOL = 0.05  # datasheet rounding: the nominal triple and (R, K) must agree this well
COPPER_TEMPCOEF = 0.0039  # 1/K, copper's resistance against temperature
REFERENCE_TEMP = 25.0  # deg C: datasheets give R at 25 deg C


@dataclass(frozen=True)
class DCMotor:
    """One motor and its gearhead, datasheet values at the motor shaft (SI units)."""

    name: str
    nominal_voltage: float | None = None  # V
    terminal_resistance: float | None = None  # Ohm
    torque_constant: float | None = None  # N m/A
    stall_torque: float | None = None  # N m
    no_load_speed: float | None = None  # rad/s
    rotor_inertia: float = 0.0  # kg m^2
    max_continuous_current: float | None = None  # A
    thermal_resistance_winding_housing: float | None = None  # K/W
    thermal_resistance_housing_ambient: float | None = None  # K/W
    thermal_time_constant_winding: float | None = None  # s
    thermal_capacitance: float | None = None  # J/K
    max_winding_temperature: float | None = None  # deg C
    ambient_temperature: float = 25.0  # deg C
    gear_ratio: float = 1.0  # reduction N: wheel speed = motor speed / N
    gear_efficiency: float = 1.0
    gear_max_continuous_torque: float | None = None  # N m at the gearhead's output
    gear_max_intermittent_torque: float | None = None  # N m at the gearhead's output
    gear_max_input_speed: float | None = None  # rad/s at the gearhead's input (the motor)
    bus_voltage: float | None = None  # V, the driver's supply (default: nominal_voltage)
    motor: str = ""  # the physical motor (entries sharing it are one motor at several ratios); "" = name
    series: str = ""  # the gearhead series this entry's ratio comes from (model/gearheads.py); "" = a pairing

    @property
    def motor_name(self) -> str:
        """The physical motor's name: entries of one motor at several ratios share it."""
        return self.motor or self.name

    @property
    def shaft_continuous_torque(self) -> float:
        """The motor's continuous torque at its shaft, K i_max (N m): the size measure the sizing ranks motors by
        (nan without a current limit)."""
        c = self.resolved()
        return c["K"] * c["i_max"] if c["i_max"] > 0 else math.nan

    def resolved(self, where: str = "motor") -> dict[str, float]:
        """K, R, V (the bus), i_max, R_T, C, t_T, N and the rotor inertia; one ConfigError line for
        values that are impossible or contradict each other."""
        w = f"{where} {self.name}"
        for f in fields(self):
            value = getattr(self, f.name)
            if (
                f.name not in ("name", "motor", "series")
                and value is not None
                and not (isinstance(value, int | float) and math.isfinite(value))
            ):
                raise ConfigError(f"{w}: {f.name}: {value!r} is not a number; allowed: a finite number")
        for key in (
            "nominal_voltage",
            "terminal_resistance",
            "torque_constant",
            "stall_torque",
            "no_load_speed",
            "gear_max_continuous_torque",
            "gear_max_intermittent_torque",
            "gear_max_input_speed",
            "max_continuous_current",
            "thermal_resistance_winding_housing",
            "thermal_resistance_housing_ambient",
            "thermal_time_constant_winding",
            "thermal_capacitance",
            "gear_ratio",
            "bus_voltage",
        ):
            value = getattr(self, key)
            if value is not None and value <= 0:
                raise ConfigError(f"{w}: {key}: {value!r} is not allowed; allowed: > 0")
        if self.rotor_inertia < 0:
            raise ConfigError(f"{w}: rotor_inertia: {self.rotor_inertia!r} is not allowed; allowed: >= 0 kg m^2")
        if not 0 < self.gear_efficiency <= 1:
            raise ConfigError(f"{w}: gear_efficiency: {self.gear_efficiency!r} is not allowed; allowed: 0 < value <= 1")
        v, tau0, w0 = self.nominal_voltage, self.stall_torque, self.no_load_speed
        triple = None not in (v, tau0, w0)
        k, r = self.torque_constant, self.terminal_resistance
        if triple:
            k_t, r_t = v / w0, (v / w0) * v / tau0
            for key, given, derived, how in (
                ("torque_constant", k, k_t, "V / no_load_speed"),
                ("terminal_resistance", r, r_t, "K V / stall_torque"),
            ):
                if given is not None and abs(given - derived) > TRIPLE_RTOL * derived:
                    raise ConfigError(
                        f"{w}: {key}: {given:.6g} contradicts the datasheet triple (nominal_voltage {v:g} V, "
                        f"stall_torque {tau0:g} N m, no_load_speed {w0:g} rad/s), which gives {derived:.6g} ({how}); "
                        f"allowed: values within {TRIPLE_RTOL:.0%} of each other"
                    )
            k, r = k if k is not None else k_t, r if r is not None else r_t
        if k is None or r is None:
            raise ConfigError(
                f"{w}: needs torque_constant and terminal_resistance, or nominal_voltage, stall_torque and "
                "no_load_speed; allowed: either set"
            )
        bus = self.bus_voltage or v
        if bus is None:
            raise ConfigError(f"{w}: bus_voltage: missing, and no nominal_voltage; allowed: a voltage > 0")
        r_th = None
        if self.thermal_resistance_winding_housing is not None or self.thermal_resistance_housing_ambient is not None:
            r_th = (self.thermal_resistance_winding_housing or 0.0) + (self.thermal_resistance_housing_ambient or 0.0)
        t_th, c_th = self.thermal_time_constant_winding, self.thermal_capacitance
        if (t_th is not None or c_th is not None) and r_th is None:
            key = "thermal_time_constant_winding" if t_th is not None else "thermal_capacitance"
            raise ConfigError(
                f"{w}: {key}: given with no thermal resistance, so the winding's heating is undefined; allowed: "
                "thermal_resistance_winding_housing and thermal_resistance_housing_ambient (K/W) with it"
            )
        if r_th is not None and t_th is None and c_th is None:
            raise ConfigError(
                f"{w}: thermal resistance given with neither thermal_time_constant_winding nor thermal_capacitance; "
                "allowed: one of them (s or J/K)"
            )
        if r_th is not None:
            c_th = c_th if c_th is not None else t_th / r_th
            t_th = r_th * c_th
        return {
            "K": k,
            "R": r,
            "V": bus,
            "i_max": self.max_continuous_current or 0.0,
            "R_T": r_th or 0.0,
            "C": c_th or 0.0,
            "t_T": t_th or 0.0,
            "N": self.gear_ratio,
            "eta": self.gear_efficiency,
            "J": self.rotor_inertia,
            "T_amb": self.ambient_temperature,
            "T_max": self.max_winding_temperature if self.max_winding_temperature is not None else math.inf,
        }


def _fmt(*xs: float) -> str:
    return " ".join(f"{x:.10g}" for x in xs)


def reflected_inertia(motor: DCMotor) -> float:
    """The rotor's inertia at the wheel, J N^2 (kg m^2)."""
    return motor.rotor_inertia * motor.gear_ratio**2


def dcmotor_xml(name: str, joint: str, motor: DCMotor, *, rotor: bool = True, thermal: bool = False) -> str:
    """MJCF of one `dcmotor` on `joint`, its terminal voltage as ctrl (`input="voltage"`): the motor alone,
    its drive being batchveh's (model/drive.py). The gearhead's efficiency: the module's note. rotor False:
    no actuator armature; the caller puts `reflected_inertia` on the joint instead (MuJoCo Warp in MJX 3.17
    ignores an actuator's armature: with it, a climb's drive torques read 1% apart from MuJoCo C's; on the
    joint both agree within 1e-5). thermal True: MuJoCo's own winding state (its `thermal` attribute), which
    heats with the current before `saturation` clips it; the vehicle leaves it out (the drive has its own)."""
    c = motor.resolved()
    n, eta = c["N"], c["eta"]
    heat = ""
    if thermal and c["R_T"] > 0:
        heat = f' thermal="{_fmt(c["R_T"] / eta, eta * c["C"], 0, COPPER_TEMPCOEF, REFERENCE_TEMP, c["T_amb"])}"'
    saturation = f' saturation="0 {_fmt(eta * c["i_max"])} 0"' if c["i_max"] > 0 else ""
    return (
        f'<dcmotor name="{name}" joint="{joint}" gear="{_fmt(n)}" armature="{_fmt(c["J"] if rotor else 0.0)}" '
        f'resistance="{_fmt(c["R"] / eta)}" motorconst="{_fmt(c["K"])}"{saturation}{heat} input="voltage"/>'
    )


def load_catalogue(path: str | Path) -> dict[str, DCMotor]:
    """The motors of a catalogue YAML (notebooks/motors.yaml's format: a list under `motors:`, each a mapping of
    DCMotor's fields, the gearhead nested under `gearhead:` with `ratio`, `efficiency` and its ratings): a dict
    {name: DCMotor}, in the file's order, then every (motor, ratio) its `series:` allow (model/gearheads.py), in
    the series' order. A bad entry is one ConfigError line naming the file, entry and key."""
    from batchveh.model.gearheads import GEAR_FIELDS, allowed, combination, load_series, number

    data = load_yaml(path)
    series = load_series(data.get("gearhead_series"), str(path))
    known = {f.name for f in fields(DCMotor)} - {"series"}
    out: dict[str, DCMotor] = {}
    combos: list[DCMotor] = []
    for i, raw in enumerate(data.get("motors") or []):
        where = f"{path}: motors[{i}]"
        if not isinstance(raw, dict):
            raise ConfigError(f"{where}: {raw!r} is not a mapping; allowed: a motor's datasheet values")
        entry: dict[str, Any] = {k: v for k, v in raw.items() if k in known}
        gear = raw.get("gearhead") or {}
        for key, to in GEAR_FIELDS.items():
            if gear.get(key) is not None:
                entry[to] = number(gear[key], f"{where}: gearhead: {key}")
        if "name" not in entry:
            raise ConfigError(f"{where}: name: missing; allowed: a unique name")
        motor = DCMotor(**entry)
        motor.resolved(where)
        if raw.get("gearhead") or not raw.get("series"):  # a motor with series and no gearhead: its ratios only
            out[motor.name] = motor
        pairs = allowed(raw.get("series"), series, f"{where} ({motor.name})")
        combos += [combination(motor, s, r) for s, r in pairs]
    for motor in combos:  # a pairing written out under the same name stays as written
        if motor.name not in out:
            motor.resolved(f"{path}: {motor.name}")
            out[motor.name] = motor
    return out


# A motor's fields a sweep may set (`motors.drive.<field>`, `motors.steer.<field>`): unit and rule
SWEEPABLE = {
    "nominal_voltage": ("V", "gt"),
    "terminal_resistance": ("Ohm", "gt"),
    "torque_constant": ("N m/A", "gt"),
    "rotor_inertia": ("kg m^2", "ge"),
    "max_continuous_current": ("A", "gt"),
    "thermal_resistance_winding_housing": ("K/W", "ge"),
    "thermal_resistance_housing_ambient": ("K/W", "ge"),
    "thermal_time_constant_winding": ("s", "gt"),
    "max_winding_temperature": ("deg C", "gt"),
    "ambient_temperature": ("deg C", "ge"),
    "gear_ratio": ("1", "gt"),
    "gear_efficiency": ("1", "gt"),
    "bus_voltage": ("V", "gt"),
}


def with_fields(motor: DCMotor, values: Any) -> DCMotor:
    """`motor` with `values` ((field, value) pairs of SWEEPABLE) set. Setting torque_constant or
    terminal_resistance drops the stall torque and no-load speed (the nominal triple they would
    contradict); a thermal time constant replaces a given capacitance."""
    changes = dict(values)
    if not changes:
        return motor
    if "torque_constant" in changes or "terminal_resistance" in changes:
        k = changes.get("torque_constant", motor.resolved()["K"])
        r = changes.get("terminal_resistance", motor.resolved()["R"])
        changes.update(torque_constant=k, terminal_resistance=r, stall_torque=None, no_load_speed=None)
    if "nominal_voltage" in changes and motor.stall_torque is not None and "torque_constant" not in changes:
        c = motor.resolved()  # keep K and R: the triple's voltage alone moves the bus default
        changes.update(torque_constant=c["K"], terminal_resistance=c["R"], stall_torque=None, no_load_speed=None)
    if "thermal_time_constant_winding" in changes:
        changes["thermal_capacitance"] = None
    return dataclasses.replace(motor, **changes)


def pick(catalogue: dict[str, DCMotor], name: str, where: str) -> DCMotor:
    """The catalogue's motor `name`, or one ConfigError line with did-you-mean."""
    if name not in catalogue:
        raise ConfigError(
            f"{where}: {name!r} is not in the catalogue{did_you_mean(name, catalogue)}; allowed: {', '.join(catalogue)}"
        )
    return catalogue[name]
