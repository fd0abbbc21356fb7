"""What the screen needs of a vehicle and its scenario beside the servo's rows: each variant's imposed wheel
acceleration (the rotor's share of the peak), a straight line's speed ramp, and a duty cycle's accelerating and
standing segments (`batchveh.sizing.screening.screen_one`'s and `segment_ramp`'s `ramp`)."""

from __future__ import annotations

from typing import Any

ACCELERATING = ("accelerate",)  # a duty cycle's segments the screen's ramp model reads (`segment_ramp`)
CARRIES_SPEED = ("accelerate", "cruise", "climb")  # segments that end at their own speed (else from standstill)
STANDING = ("steer",)  # segments that ask the drives to hold their wheels still while the steering turns them


def _column(df: Any, name: str, default: float) -> Any:
    """A swept parameter's values per row of `df`, or its fixed value where it was not swept."""
    import numpy as np

    return df[name].to_numpy(float) if name in df else np.full(len(df), float(default))


def wheel_accel(spec: Any, df: Any) -> Any:
    """Each variant's imposed wheel acceleration over its speed ramp (rad/s^2), for the screen's rotor inertia:
    speed / (radius x ramp time), where the scenario has both; else 0."""
    import numpy as np

    sc = spec.scenario
    if not hasattr(sc, "speed_kmh") or not getattr(sc, "ramp_time", 0):
        return 0.0
    ramp = np.maximum(_column(df, "ramp_time", sc.ramp_time), 1e-9)
    return _column(df, "speed_kmh", sc.speed_kmh) / 3.6 / _column(df, "wheel.radius", spec.vehicle.wheel.radius) / ramp


def ramp_of(spec: Any, df: Any) -> dict[str, Any] | None:
    """The straight line's ramp for the screen (`screening.screen_one`'s `ramp`), each variant's own: the imposed
    wheel speed (rad/s), what each drive accelerates without its rotor (kg m^2: a quarter of the vehicle's mass,
    the payload's with it, at the wheel's radius, and the wheel as a solid disc), the ramp time, the window, the
    drive law, and the four wheels' grip at the wheel, mu M g cos(slope) r (N m); None for a scenario without a
    speed ramp (a mission, a steer in place)."""
    import numpy as np

    sc = spec.scenario
    if sc.kind == "mission":
        return mission_ramp(spec, df)
    if sc.kind != "straight_line" or not getattr(sc, "ramp_time", 0):
        return None
    v = spec.vehicle

    def col(name: str, default: float) -> Any:
        return _column(df, name, default)

    radius = col("wheel.radius", v.wheel.radius)
    mass = _mass(spec, df)
    total = float(sc.total_time)
    return {
        "speed": col("speed_kmh", sc.speed_kmh) / 3.6 / radius,
        "inertia": _drive_inertia(spec, df),
        "ramp_time": col("ramp_time", sc.ramp_time),
        "window": tuple(spec.window) if spec.window is not None else (total / 2, total),
        "law": sc.drive_law,
        "grip": col("friction", sc.friction)
        * mass
        * col("gravity", sc.gravity)
        * np.cos(np.deg2rad(col("slope_deg", sc.slope_deg)))
        * radius,
    }


def _mass(spec: Any, df: Any) -> Any:
    """Each variant's vehicle mass (kg): chassis, four wheels and hubs, payload."""
    v = spec.vehicle
    wheel = _column(df, "wheel.mass", v.wheel.mass)
    mass = _column(df, "chassis.mass", v.chassis.mass) + 4 * (wheel + _column(df, "hub.mass", v.hub.mass))
    return mass + _column(df, "payload.mass", v.payload.mass)


def _drive_inertia(spec: Any, df: Any) -> Any:
    """What each drive accelerates without its rotor (kg m^2, per variant): a quarter of the vehicle at the wheel's
    radius, and the wheel as a solid disc."""
    v = spec.vehicle
    radius = _column(df, "wheel.radius", v.wheel.radius)
    return _mass(spec, df) * radius**2 / 4 + 0.5 * _column(df, "wheel.mass", v.wheel.mass) * radius**2


def mission_ramp(spec: Any, df: Any) -> dict[str, Any]:
    """A duty cycle's ramp for the screen (`sizing.screening.segment_ramp`): each accelerating segment's transition,
    duration and the span it starts from (the previous one where it ends at its speed, else None: standstill),
    the spans where the vehicle stands while it steers (`standing`: a drive's peak there is not judged), each
    variant's drive inertia (`_drive_inertia`) and the servo's armature."""
    from batchveh.model.missions import mission_of

    m = mission_of(spec.scenario)
    spans = m.spans[1:]
    segments = {}
    for k, seg in enumerate(m.segments):
        if seg.kind not in ACCELERATING:
            continue
        before = m.segments[k - 1].kind if k else None
        segments[spans[k]] = {
            "transition": m.transition(k),
            "duration": (m.boundaries[k + 1] - m.boundaries[k]) * m.dt,
            "previous": spans[k - 1] if before in CARRIES_SPEED else None,
        }
    standing = [spans[k] for k, seg in enumerate(m.segments) if seg.kind in STANDING]
    return {
        "segments": segments,
        "standing": standing,
        "inertia": _drive_inertia(spec, df),
        "armature": spec.vehicle.motors.armature,
    }
