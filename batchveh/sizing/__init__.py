"""Sizing a motor and its gear ratio: each motor's ratio window over its gearhead series (`windows`) and the
requirement sheet a vendor is sent (`requirements`). The session itself is `batchveh.size`.

The package, read top to bottom as a session runs: the demand of a servo sweep's rows
(`batchveh.analysis.demand`, below sizing: analysis reads it too), the screen (`screening`: closed-form verdicts
per (motor, ratio) and variant; a straight line's ramp and a duty cycle's segments; `ramps`: the ramps it is
given), the windows and the sheet (`windows`, `requirements`), the loop (`plan`: what runs, in which batches;
`loop`: the candidates as MuJoCo dcmotors, batched; `thermal`: its hot start in closed form), and what is written
(`figures`, `report`). This module is its face: the names a user calls, e.g. `from batchveh import sizing`, then
`sizing.screen(...)`.

One catalogue format, `notebooks/motors.yaml`'s, serves every pass: a `motors:` list, each entry a motor
as its datasheet gives it at the motor shaft with its gearhead nested under `gearhead:`, and an optional
`battery:` section:

```yaml
motors:
  - name: maxon-EC45flat-70W-48V_NPT015-i40   # unique: the name that screen, in_loop and a sweep use
    nominal_voltage: 48.0               # V: the bus, unless bus_voltage is given
    terminal_resistance: 6.89           # Ohm; or the triple nominal_voltage, stall_torque, no_load_speed
    torque_constant: 0.131              # N m/A
    max_continuous_current: 0.936       # A
    rotor_inertia: 1.81e-5              # kg m^2
    thermal_resistance_winding_housing: 4.1    # K/W
    thermal_resistance_housing_ambient: 3.56   # K/W
    thermal_time_constant_winding: 29.6        # s
    max_winding_temperature: 125.0             # deg C
    gearhead: {ratio: 40.0, efficiency: 0.95, max_continuous_torque: 22.0, max_intermittent_torque: 42.0,
               max_input_speed: 1047.2}  # N m at its output; rad/s at its input
battery: {nominal_voltage: 48.0, capacity: 20.0, internal_resistance: 0.3, max_continuous_discharge_current: 20.0}
```

The loaders, low in `batchveh.model` and also public as `batchveh.load_catalogue` and `batchveh.load_battery`:
- `batchveh.model.motors.load_catalogue(path)` -> {name: DCMotor}, the `motors:` list by name;
- `batchveh.model.battery.load_battery(path)` -> Battery, the `battery:` section.

Two passes over the rows of a servo sweep (`batchveh.load(folder)`), the drive's demand taken on the
worst of the four drive motors:
1. `screen(df, catalogue, share=...)`: the fast screen, closed forms per variant (RMS current, steady
   winding temperature, the voltage at the peak, the no-load speed, the gearhead's ratings; `REASONS`).
   `share=1.0` gives the smallest motor that covers every variant; `span="mission"` (or a segment's
   prefix, `seg2_climb`) reads a mission's columns over that span instead of the steady window's RMS,
   the whole run's low-pass peak and the mean wheel speed.
2. `in_loop(spec, df, path, candidates, steer=...)`: the screen's survivors run as MuJoCo dcmotors on
   the same variants, from the hot steady state of back-to-back runs (`IN_LOOP_REASONS`).
"""

from batchveh.analysis.demand import GROUPS, WHEELS, demand
from batchveh.model.battery import Battery, load_battery
from batchveh.model.motors import load_catalogue
from batchveh.sizing.loop import (
    DIFFER,
    IN_LOOP_REASONS,
    IN_LOOP_TEXT,
    STEER_LIMIT_SHARE,
    STEER_LOST_DEG,
    STEER_REASONS,
    STEER_TEXT,
    Runner,
    best_in_loop,
    engine_runner,
    in_loop,
    in_loop_lines,
    not_simulated,
    segment_shortfall,
    steer_reasons,
)
from batchveh.sizing.screening import (
    REASON_TEXT,
    REASONS,
    bound_at_wheel,
    mission_segments,
    ramp_shortfall,
    screen,
    screen_one,
    segment_ramp,
    terminal_voltage,
)

__all__ = [
    "DIFFER",
    "GROUPS",
    "IN_LOOP_REASONS",
    "IN_LOOP_TEXT",
    "REASONS",
    "REASON_TEXT",
    "STEER_LIMIT_SHARE",
    "STEER_LOST_DEG",
    "STEER_REASONS",
    "STEER_TEXT",
    "WHEELS",
    "Battery",
    "Runner",
    "best_in_loop",
    "bound_at_wheel",
    "demand",
    "engine_runner",
    "in_loop",
    "in_loop_lines",
    "load_battery",
    "load_catalogue",
    "mission_segments",
    "not_simulated",
    "ramp_shortfall",
    "screen",
    "screen_one",
    "segment_ramp",
    "segment_shortfall",
    "steer_reasons",
    "terminal_voltage",
]
