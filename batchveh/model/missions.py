"""Missions: a duty cycle of segments driven one after another (scenario kind `mission`).

```yaml
kind: mission
friction: 0.8
slope_deg: 10                  # deg: the slope of climb segments that give none (sweepable)
speed_kmh: 2                   # km/h: the speed of segments that give none (sweepable)
torque_threshold: {drive: 15, steer: 5}   # N m: time above these is counted (optional)
segments:
  - {kind: accelerate, duration: 2}                        # to speed_kmh over the whole duration
  - {kind: cruise, distance: 2, speed_kmh: 2}              # or duration; distance needs its own speed
  - {kind: climb, duration: 4, transition: 1.5}            # the slope turns on over `transition`
  - {kind: turn, turn: ackermann, duration: 4, turn_radius: 3}
  - {kind: stop, duration: 2}                              # to standstill over the whole duration
  - {kind: steer, duration: 2, steer_deg: 30}              # steer in place (from standstill)
  - {kind: turn, turn: pivot, duration: 4, yaw_rate_dps: 20}
```

Each segment starts from the previous one's end: its targets (the four wheel speeds, the four
steering angles and the ground slope) are reached from the previous targets by a quintic
`laws.smooth_step` over its `transition` (default: the whole duration for accelerate and stop,
min(1 s, duration) otherwise), so the imposed laws are continuous with their first two
derivatives at every boundary. A segment that starts at standstill and changes the steering
geometry steers in the first half of its transition and rolls in the second. A turn on the
spot (pivot) and a steer in place need a standstill (a stop before them); after a pivot only a
stop or another pivot may follow. Segment numbers left out take the scenario's field of the
same name (`speed_kmh`, `turn_radius`, `steer_deg`, `yaw_rate_dps`; a climb's `slope_deg`),
so sweeping those fields sweeps every segment that uses them; other segments are flat unless
they give `slope_deg`. A sweep that sweeps, fixes or sets a field the mission does not read
(`check_sweep`) is refused. The mission's `total_time` is the sum of the durations (filled in), and
the segment boundaries fall on the nearest time steps. A mission without `segments` runs
`EXAMPLE_SEGMENTS`.

The slope changes in time: the model keeps the scenario's gravity, tilted by `slope_deg` (as
`batch.make_batch` builds it), and the difference to the mission's slope at law time t acts as
a force m_i (g(t) - g0) at each body's centre of mass (`xfrc_applied`, which MuJoCo applies at
the centre of mass, as it applies gravity), on every engine. The ground plane stays where it is
and the slope always climbs along world +X. Rolling resistance (`wheel.rolling_resistance`)
keeps the cos of the scenario's `slope_deg`.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from batchveh.config import ConfigError, did_you_mean, field, from_mapping
from batchveh.model import laws
from batchveh.model.scenarios import (
    Kind,
    Scenario,
    ackermann_rolling,
    ackermann_targets,
    axis_roll,
    gravity_vector,
    law_time,
    pivot_targets,
    register,
    steered,
)

SEGMENT_KINDS = ("accelerate", "cruise", "climb", "turn", "stop", "steer")
TURNS = ("ackermann", "crab", "pivot")
COMMON_KEYS = ("kind", "duration", "transition", "slope_deg", "name")
KIND_KEYS = {
    "accelerate": ("speed_kmh",),
    "cruise": ("speed_kmh", "distance"),
    "climb": ("speed_kmh",),
    "stop": (),
    "steer": ("steer_deg", "roll"),
}
TURN_KEYS = {"ackermann": ("speed_kmh", "turn_radius"), "crab": ("speed_kmh", "steer_deg"), "pivot": ("yaw_rate_dps",)}
DEFAULT_TRANSITION = 1.0  # s, for cruise, climb, turn and steer segments (at most their duration)
STEER_IN_PLACE = (-1.0, 1.0, 1.0, -1.0)  # lf, rf, lr, rr: the seed's scenario 2 pattern
_NAME = re.compile(r"^[a-z][a-z0-9_]*$")


@dataclass(frozen=True)
class Segment:
    """One segment of a mission. Numbers left None take the scenario's field of the same name."""

    kind: str = ""
    duration: float | None = field(None, unit="s", gt=0, le=86400)
    distance: float | None = field(None, unit="m", gt=0, doc="cruise only, instead of duration")
    transition: float | None = field(None, unit="s", gt=0, doc="time to reach the segment's targets")
    speed_kmh: float | None = field(None, unit="km/h", doc="target forward speed at the wheel rim")
    slope_deg: float | None = field(None, unit="deg", ge=-60, le=60, doc="ground slope; climbs along +X")
    turn: str | None = None
    turn_radius: float | None = field(None, unit="m", doc="Ackermann turn radius; >0 turns left")
    steer_deg: float | None = field(None, unit="deg", ge=-90, le=90, doc="crab or steer-in-place angle")
    yaw_rate_dps: float | None = field(None, unit="deg/s", doc="pivot yaw rate; >0 counter-clockwise")
    roll: bool | None = None  # steer only: the wheels roll about their steering axes (default true)
    name: str | None = None

    def validate(self, where: str) -> None:
        if self.kind not in SEGMENT_KINDS:
            raise ConfigError(
                f"{where}.kind: {self.kind!r} is not a segment kind{did_you_mean(self.kind, SEGMENT_KINDS)}; "
                f"allowed: {', '.join(SEGMENT_KINDS)}"
            )
        if self.kind == "turn":
            if self.turn not in TURNS:
                raise ConfigError(
                    f"{where}.turn: {self.turn!r} is not allowed{did_you_mean(self.turn, TURNS)}; "
                    f"allowed: {', '.join(TURNS)}"
                )
            allowed = (*COMMON_KEYS, "turn", *TURN_KEYS[self.turn])
        else:
            allowed = (*COMMON_KEYS, *KIND_KEYS[self.kind])
        what = f"a {self.kind} segment" if self.kind != "turn" else f"a {self.turn} turn"
        for key in Segment.__dataclass_fields__:
            if getattr(self, key) is not None and key not in allowed and key != "kind":
                raise ConfigError(
                    f"{where}.{key}: {getattr(self, key)!r} is not used by {what}; allowed keys: {', '.join(allowed)}"
                )
        if self.kind == "cruise" and (self.duration is None) == (self.distance is None):
            raise ConfigError(f"{where}: a cruise segment needs one of duration (s) or distance (m), not both")
        if self.kind != "cruise" and self.duration is None:
            raise ConfigError(f"{where}.duration: missing; allowed: a number of seconds > 0")
        if self.distance is not None and not self.speed_kmh:
            raise ConfigError(
                f"{where}.speed_kmh: {self.speed_kmh!r} is not allowed with distance; allowed: the segment's own "
                "nonzero speed (the duration, distance / speed, fixes the compiled program)"
            )
        if self.turn_radius == 0:
            raise ConfigError(f"{where}.turn_radius: 0.0 is not allowed; allowed: nonzero m (>0 turns left)")
        if self.name is not None and not _NAME.match(str(self.name)):
            raise ConfigError(
                f"{where}.name: {self.name!r} is not allowed; allowed: lower-case letters, digits and _ "
                "(it names result columns)"
            )

    @property
    def seconds(self) -> float:
        """The duration in s (a cruise by distance: distance / speed)."""
        return self.duration if self.duration is not None else self.distance / (abs(self.speed_kmh) / 3.6)

    @property
    def geometry(self) -> str | None:
        """The steering geometry it imposes (None: a stop keeps the previous one)."""
        return {"stop": None, "steer": "steer", "turn": self.turn}.get(self.kind, "straight")


@dataclass(frozen=True)
class TorqueThreshold:
    """Torques above which the statistics count time (`time_above`), per motor group; None: not counted."""

    drive: float | None = field(None, unit="N m", gt=0)
    steer: float | None = field(None, unit="N m", gt=0)


@dataclass(frozen=True)
class Mission:
    """A validated mission on the time grid of its scenario."""

    segments: tuple[Segment, ...]
    boundaries: tuple[int, ...]  # steps of law time: segment k covers steps [b_k, b_k+1) after the settle
    dt: float  # s
    threshold: TorqueThreshold
    split: tuple[bool, ...]  # segment k steers first, then rolls (standstill start, new geometry)
    geometry: tuple[str, ...]  # the steering geometry segment k ends with

    @property
    def spans(self) -> tuple[str, ...]:
        """Column prefixes: 'mission' (every step of the laws), then 'seg<k>_<name or kind>'."""
        return ("mission", *(f"seg{k}_{s.name or s.kind}" for k, s in enumerate(self.segments)))

    def start(self, k: int) -> float:
        """Law time in s at which segment k starts."""
        return self.boundaries[k] * self.dt

    def transition(self, k: int) -> float:
        """Segment k's transition in s."""
        seg, length = self.segments[k], (self.boundaries[k + 1] - self.boundaries[k]) * self.dt
        if seg.transition is not None:
            return seg.transition
        return length if seg.kind in ("accelerate", "stop") else min(DEFAULT_TRANSITION, length)


def _prefix(where: str) -> str:
    return f"{where}.segments" if ":" in where else f"{where}: segments"


def parse_segments(raw: Any, where: str) -> tuple[Segment, ...]:
    """The segments of a mission's `segments:` list, each validated."""
    at = _prefix(where)
    if not isinstance(raw, list) or not raw:
        raise ConfigError(f"{at}: {raw!r} is not allowed; allowed: a non-empty list of segment mappings")
    out = []
    for k, item in enumerate(raw):
        if not isinstance(item, Mapping):
            raise ConfigError(f"{at}[{k}]: {item!r} is not a mapping; allowed: {{kind: ..., duration: ...}}")
        out.append(from_mapping(Segment, dict(item), f"{at}[{k}]"))
    return tuple(out)


def mission_duration(fields: Mapping[str, Any], where: str) -> float:
    """The sum of the segments' durations in s, from a scenario mapping (its `segments`)."""
    return float(sum(s.seconds for s in parse_segments(fields.get("segments"), where)))


def mission_of(sc: Scenario, where: str = "scenario") -> Mission:
    """The mission of a scenario of kind mission; ConfigError for one that cannot run."""
    segments = parse_segments(sc.segments, where)
    at = _prefix(where)
    dt = sc.time_step
    ends = np.cumsum([s.seconds for s in segments])
    boundaries = (0, *(int(round(e / dt)) for e in ends))
    split, moving, geometry, geometries = [], False, "straight", []
    for k, seg in enumerate(segments):
        steps = boundaries[k + 1] - boundaries[k]
        if steps < 1:
            raise ConfigError(f"{at}[{k}].duration: {seg.seconds!r} s is shorter than one time step ({dt:g} s)")
        if seg.transition is not None and seg.transition > steps * dt * (1 + 1e-9):
            raise ConfigError(
                f"{at}[{k}].transition: {seg.transition!r} exceeds the segment's duration {steps * dt:g} s; "
                "allowed: > 0 and <= the duration"
            )
        still_only = seg.kind == "steer" or seg.geometry == "pivot"
        if still_only and moving and geometry != "pivot":
            raise ConfigError(
                f"{at}[{k}]: a {seg.turn or seg.kind} segment needs a standstill, and segment {k - 1} "
                f"({segments[k - 1].kind}) ends moving; allowed: a stop segment before it"
            )
        if geometry == "pivot" and moving and seg.kind != "stop" and seg.geometry != "pivot":
            raise ConfigError(
                f"{at}[{k}]: a {seg.turn or seg.kind} segment cannot follow a pivot (the vehicle is turning on "
                "the spot); allowed: a stop or another pivot next"
            )
        new = seg.geometry or geometry
        rolls = seg.kind not in ("stop", "steer")
        split.append(rolls and not moving and not new == geometry == "straight")
        moving = rolls and seg.speed_kmh != 0
        geometry = new
        geometries.append(new)
    threshold = from_mapping(TorqueThreshold, dict(sc.torque_threshold or {}), f"{where}: torque_threshold")
    return Mission(segments, boundaries, dt, threshold, tuple(split), tuple(geometries))


def check_mission(sc: Scenario, where: str) -> None:
    """Raise ConfigError where a mission scenario's fields are wrong (scenarios refuses its fields
    given to another kind)."""
    if sc.torque_threshold is not None and not isinstance(sc.torque_threshold, Mapping):
        raise ConfigError(
            f"{where}: torque_threshold: {sc.torque_threshold!r} is not a mapping; allowed: {{drive, steer}}"
        )
    mission_of(sc, where)
    _check_total(sc.total_time, mission_duration({"segments": sc.segments}, where), f"{where}: total_time")


def _check_total(total_time: float, total: float, at: str) -> None:
    """One ConfigError line unless a total_time given at `at` is the segments' total (s)."""
    if not math.isclose(total_time, total, rel_tol=1e-9, abs_tol=1e-12):
        raise ConfigError(
            f"{at}: {total_time!r} differs from the segments' total {total:g} s; "
            "allowed: leave total_time out (a mission's is the sum of the durations), or give that sum"
        )


# Scenario fields a mission reads only through the segments that leave their own value out
# (`fields_read`), and those it never reads: each segment reaches its targets by a quintic step
# over its own transition. Every other scenario field (friction, gravity, time_step, the obstacle's)
# acts as in any scenario. A slope_deg that no climb reads still sets the model's gravity, but the
# body forces cancel it (sweeping it over 0/10/30 deg on a mission without a climb, MuJoCo C:
# statistics equal to 1.2e-13 relative), except in the rolling resistance, whose normal load keeps
# cos(slope_deg): with C_rr 0.03 a cruise's drive RMS fell 13.6% at 30 deg on flat segments, a
# model limit and not a slope, so it counts as unread.
READ_BY = {
    "speed_kmh": "segment that rolls (accelerate, cruise, climb, an ackermann or crab turn)",
    "turn_radius": "ackermann turn",
    "steer_deg": "steer segment or crab turn",
    "yaw_rate_dps": "pivot turn",
    "slope_deg": "climb",
}
NEVER_READ = {
    "ramp_time": "each segment reaches its targets over its own transition (s)",
    "drive_law": "each segment reaches its targets by a quintic smooth step over its transition",
    "laws": "only kind custom reads laws",
}


def _wants(seg: Segment) -> dict[str, bool]:
    """Which fields of READ_BY segment `seg` uses (its own value, or the scenario's where it gives none)."""
    rolls = seg.kind in ("accelerate", "cruise", "climb") or seg.geometry in ("ackermann", "crab")
    return {
        "speed_kmh": rolls,
        "turn_radius": seg.geometry == "ackermann",
        "steer_deg": seg.kind == "steer" or seg.geometry == "crab",
        "yaw_rate_dps": seg.geometry == "pivot",
        "slope_deg": seg.kind == "climb",
    }


def fields_read(segments: tuple[Segment, ...], own: bool = False) -> dict[str, tuple[int, ...]]:
    """Each field of READ_BY with the segments (indices) that leave it out, and so read the scenario's
    (`own` True: those that use it and give their own instead)."""
    return {
        key: tuple(k for k, seg in enumerate(segments) if _wants(seg)[key] and (getattr(seg, key) is None) != own)
        for key in READ_BY
    }


def check_sweep(sc: Scenario, swept: Any, fixed: Mapping[str, float], where: str) -> None:
    """Before any work: one ConfigError line for a scenario field that mission scenario `sc` (as given,
    before `fixed`) does not read, where it was swept (`swept`: the names), fixed to other than its
    default, or set in the scenario to other than its default; and for a fixed total_time that is not
    the segments' total."""
    segments = parse_segments(sc.segments, f"{where}: scenario")
    if "total_time" in fixed:
        _check_total(fixed["total_time"], float(sum(s.seconds for s in segments)), f"{where}: fixed.total_time")
    reads, owns = fields_read(segments), fields_read(segments, own=True)
    defaults = {f.name: f.default for f in dataclasses.fields(Scenario)}
    given = [(f"sweep.params.{key}", key) for key in swept]
    given += [(f"fixed.{key}", key) for key, value in fixed.items() if key in defaults and value != defaults[key]]
    given += [(f"scenario.{key}", key) for key in (*READ_BY, *NEVER_READ) if getattr(sc, key) != defaults[key]]
    read = [f"{key} (segments {', '.join(map(str, ks))})" for key, ks in reads.items() if ks]
    for at, key in given:
        if key in NEVER_READ:
            why, allowed = NEVER_READ[key], f"leave {key} out"
        elif key in READ_BY and not reads[key]:
            why = f"no {READ_BY[key]} leaves {key} out"
            if owns[key]:
                why += f" (segments {', '.join(map(str, owns[key]))} give their own)"
            if key == "slope_deg":
                why += ", and the other segments are flat unless they give their own slope_deg"
            allowed = f"leave {key} out, or leave it out of a segment that should take the scenario's"
        else:
            continue
        raise ConfigError(
            f"{where}: {at}: the mission does not read {key}: {why}; of the fields its segments can leave to the "
            f"scenario it reads {', '.join(read) or 'none'} (and friction, gravity, time_step and the vehicle's "
            f"parameters); allowed: {allowed}"
        )


# --- the imposed laws ------------------------------------------------------------


def _targets(seg: Segment, p: Mapping[str, Any], alpha_prev):
    """(wheel speeds (4,) rad/s, steering angles (4,) rad) that segment `seg` reaches."""

    def own(key):
        value = getattr(seg, key)
        return p[key] if value is None else value

    rim = own("speed_kmh") / 3.6 / p["wheel.radius"]  # rad/s, as scenarios._omega computes it
    if seg.kind == "stop":
        return jnp.zeros(4), alpha_prev
    if seg.kind == "steer":
        return jnp.zeros(4), jnp.deg2rad(own("steer_deg")) * jnp.array(STEER_IN_PLACE) * steered(p)
    if seg.geometry == "ackermann":
        return ackermann_targets(p, 1.0 / own("turn_radius"), own("speed_kmh"))
    if seg.geometry == "pivot":
        return pivot_targets(p, own("yaw_rate_dps"))
    if seg.geometry == "crab":
        return jnp.full(4, 1.0) * rim, jnp.deg2rad(own("steer_deg")) * steered(p)
    return jnp.full(4, 1.0) * rim, jnp.zeros(4)


def _slope(seg: Segment, p: Mapping[str, Any]):
    """The ground slope in deg during segment `seg`: its own, the scenario's for a climb, else 0."""
    if seg.slope_deg is not None:
        return seg.slope_deg
    return p["slope_deg"] if seg.kind == "climb" else 0.0


def _curve(seg: Segment, p: Mapping[str, Any], prev: tuple[Any, Any]) -> tuple[Any, Any]:
    """(curvature 1/m, speed km/h) that segment `seg` ends with, in the straight-and-Ackermann family
    (a straight line has curvature 0); `prev` for a stop, which keeps the curvature."""
    if seg.kind == "stop":
        return prev[0], 0.0
    if seg.kind == "steer" or seg.geometry in ("crab", "pivot"):
        return prev  # not in the family; never blended along it
    speed = p["speed_kmh"] if seg.speed_kmh is None else seg.speed_kmh
    radius = p["turn_radius"] if seg.turn_radius is None else seg.turn_radius
    return (1.0 / radius if seg.geometry == "ackermann" else 0.0), speed


def mission_controls(sc: Scenario, p: Mapping[str, Any], t):
    """(wheel speeds (4,) rad/s, steering angles (4,) rad) at law time t (s): the sum over segments
    of each one's change from the previous targets, each reached by a smooth step.

    Between a straight line and an Ackermann turn while moving, the curvature and the speed are
    blended instead, and the wheels follow the Ackermann geometry of each instant. Wherever the
    steering turns, each wheel also rolls at the speed its centre moves about the offset steering
    axis, -sy offset dalpha/dt / r (`scenarios.axis_roll`; at a standstill only the contact's
    width then scrubs, as in `steer_in_place_rolling`); a steer segment with `roll: false` holds
    its wheels instead (they are dragged round, as in the seed's scenario 2).

    Measured on the turn of sweeps/mission.yaml (50 kg, mu 0.9, 2 km/h into a 2 m radius over
    1 s; MuJoCo C): peak drive torque 104 N m with
    the angles and speeds blended and no axis roll, 97 N m with the curvature blended, 19 N m with
    both (the front/rear preload left from the climb, 17.6 N m); the steady turn needs 3.2 N m."""
    m = mission_of(sc)
    omega, alpha = jnp.zeros(4), jnp.zeros(4)
    omega_prev, alpha_prev = jnp.zeros(4), jnp.zeros(4)
    curve_prev, geometry_prev = (0.0, 0.0), "straight"
    for k, seg in enumerate(m.segments):
        omega_k, alpha_k = _targets(seg, p, alpha_prev)
        curve_k = _curve(seg, p, curve_prev)
        t0, tr = m.start(k), m.transition(k)
        family = {geometry_prev, m.geometry[k]}
        if not m.split[k] and seg.kind != "stop" and "ackermann" in family and family <= {"straight", "ackermann"}:

            def change(tt, curves=(curve_prev, curve_k), tr=tr, t0=t0, prev=(omega_prev, alpha_prev)):
                def blend(t_):
                    frac = laws.smooth_step(t_, 0.0, 1.0, tr, t0)
                    return tuple(a + (b - a) * frac for a, b in zip(*curves, strict=True))

                kappa, speed = blend(tt)
                alpha_t, alpha_rate = jax.jvp(lambda t_: ackermann_targets(p, *blend(t_))[1], (tt,), (1.0 + 0.0 * tt,))
                return ackermann_rolling(p, kappa, speed, alpha_t, alpha_rate) - prev[0], alpha_t - prev[1]
        else:
            half = tr / 2 if m.split[k] else tr

            def change(tt, half=half, t0=t0, tr=tr, d=(omega_k - omega_prev, alpha_k - alpha_prev)):
                return (
                    laws.smooth_step(tt, 0.0 * d[0], d[0], half, t0 + tr - half),
                    laws.smooth_step(tt, 0.0 * d[1], d[1], half, t0),
                )

        (omega_t, alpha_t), (_, rate) = jax.jvp(change, (t,), (1.0 + 0.0 * t,))
        omega, alpha = omega + omega_t, alpha + alpha_t
        if not (seg.kind == "steer" and seg.roll is False):
            omega = omega + axis_roll(p, rate)
        omega_prev, alpha_prev, curve_prev, geometry_prev = omega_k, alpha_k, curve_k, m.geometry[k]
    return omega, alpha


def mission_slope(sc: Scenario, p: Mapping[str, Any], t):
    """The ground slope in deg at law time t (s): the first segment's from the start, then each
    segment's, reached over its transition."""
    m = mission_of(sc)
    slope = 0.0 * t + _slope(m.segments[0], p)
    for k in range(1, len(m.segments)):
        step = _slope(m.segments[k], p) - _slope(m.segments[k - 1], p)
        slope = slope + laws.smooth_step(t, 0.0 * step, step, m.transition(k), m.start(k))
    return slope


def body_forces_fn(sc: Scenario) -> Callable[[Mapping[str, Any], Any, Any], Any] | None:
    """f(p, body_mass (nbody,) kg, engine time s) -> xfrc_applied (nbody, 6): the force m_i (g(t) - g0)
    at each body's centre of mass that turns the model's gravity g0 (the scenario's slope_deg) into the
    mission's slope at that time; None for a scenario that is no mission."""
    if sc.kind != "mission":
        return None

    def forces(p, body_mass, t):
        t = jnp.asarray(t, dtype=jnp.result_type(float))
        g = p["gravity"]
        dg = gravity_vector(g, mission_slope(sc, p, law_time(sc, t))) - gravity_vector(g, p["slope_deg"])
        f = jnp.asarray(body_mass)[:, None] * dg[None, :]
        return jnp.concatenate([f, jnp.zeros_like(f)], axis=-1)

    return forces


# The duty cycle of a mission whose segments are left out (`python -m batchveh.run mission`): 18 s at
# the scenario's speed_kmh and turn_radius, with a 10 deg climb; sweeps/mission.yaml is a fuller one
EXAMPLE_SEGMENTS = (
    {"kind": "accelerate", "duration": 2.0},
    {"kind": "cruise", "duration": 2.0},
    {"kind": "climb", "duration": 4.0, "slope_deg": 10.0, "transition": 1.5},
    {"kind": "cruise", "duration": 2.0},
    {"kind": "turn", "turn": "ackermann", "duration": 4.0},
    {"kind": "stop", "duration": 2.0},
    {"kind": "steer", "duration": 2.0, "steer_deg": 30.0},
)


def complete_mission(fields: dict[str, Any], where: str) -> dict[str, Any]:
    """A mission's fields with EXAMPLE_SEGMENTS where no segments are given, and total_time, the sum
    of the segments' durations, where not given."""
    if "segments" not in fields:
        fields = {**fields, "segments": [dict(s) for s in EXAMPLE_SEGMENTS]}
    return fields if "total_time" in fields else {**fields, "total_time": mission_duration(fields, where)}


def mission_motions(sc: Scenario) -> list[tuple[str, str]]:
    """Each segment's motion (scenarios.check_layout): a steer in place, a turn's geometry, else a straight line."""
    return [
        (f".segments[{k}] ({seg.kind}{': ' + seg.turn if seg.kind == 'turn' else ''})",
         "steer" if seg.kind == "steer" else (seg.turn if seg.kind == "turn" else "straight"))
        for k, seg in enumerate(mission_of(sc).segments)
    ]  # fmt: skip


register(
    "mission",
    Kind(
        mission_controls,
        {},
        check=check_mission,
        complete=complete_mission,
        reads=("segments", "torque_threshold"),
        motions=mission_motions,
    ),
)
