"""Scenarios: what the motors impose, on which slope, friction and gravity.

A `Scenario` is a frozen dataclass of numbers (slope, friction, speed, ...) plus a
`kind` naming an entry of `SCENARIOS`. The entry's controls function maps the
numbers, given as a flat mapping of (possibly batched) arrays, and time t in s to
the imposed wheel speeds omega (4,) in rad/s and steering angles alpha (4,) in
rad, corner order lf, rf, lr, rr. The controls are pure JAX, so a sweep varies
any of those numbers inside one compiled program.

Time. A run first settles for `settle_time` s (default 0.5), then the laws run for
`total_time` s. During the settle every law is held at its value at law time 0 (steering
rates 0): the vehicle, created just touching the ground, sinks onto its contacts and the
motors take up the load before anything moves (validation/PEAKS.md, fix B). Law time t = 0
is the end of the settle: `total_time`, `ramp_time`, law parameters and the statistics
window all count from there. The engines step `n_steps` = settle_steps + total_time / dt
steps from engine time 0; `controls_fn` maps engine time to law time, and `stats` leaves the
settle steps out of every statistic (the recorded series of `batchveh.run` start after it).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from batchveh.config import ConfigError, did_you_mean, field, from_mapping, load_yaml
from batchveh.model import course, laws
from batchveh.model.vehicle import CORNER_SIGNS, CORNERS, LAYOUT_KEY, LAYOUTS, MOTORS, STEERED, hinge_xy

GRAVITY_PRESETS = {"earth": 9.81, "moon": 1.62, "mars": 3.71}
_SX = np.array([CORNER_SIGNS[c][0] for c in CORNERS], float)
_SY = np.array([CORNER_SIGNS[c][1] for c in CORNERS], float)


@dataclass(frozen=True)
class Scenario:
    """One run's conditions. Every float field can be swept by its name."""

    kind: str = "straight_line"
    slope_deg: float = field(0.0, unit="deg", ge=-60, le=60, doc="slope, by tilting gravity; >0 climbs along +X")
    friction: float = field(0.7, unit="1", gt=0, doc="Coulomb friction coefficient wheel-ground")
    gravity: float = field(9.81, unit="m/s^2", gt=0, doc="gravity magnitude (earth 9.81, moon 1.62, mars 3.71)")
    total_time: float = field(10.0, unit="s", gt=0, le=86400, doc="simulated time (at most a day)")
    time_step: float = field(0.005, unit="s", ge=1e-5, le=0.05)
    settle_time: float = field(
        0.5,
        unit="s",
        ge=0,
        le=86400,
        doc="settle before the laws start, laws held at their t = 0 values; left out of every statistic",
        sweep=False,
    )
    speed_kmh: float = field(1.0, unit="km/h", doc="target forward speed at the wheel rim")
    ramp_time: float = field(3.0, unit="s", ge=0, doc="time to reach the target speed or angle")  # see _drive
    steer_deg: float = field(45.0, unit="deg", ge=-90, le=90, doc="steering angle (steer_in_place, crab)")
    turn_radius: float = field(3.0, unit="m", doc="Ackermann turn radius; >0 turns left")
    yaw_rate_dps: float = field(20.0, unit="deg/s", doc="pivot yaw rate; >0 counter-clockwise")
    # the ground across the path (batchveh.model.course): none, step, bump, pothole or terrain, and its shape
    obstacle: str = "none"
    obstacle_x: float = field(0.3, unit="m", ge=0, le=100, doc="from the front wheels' contact to the obstacle")
    step_height: float = field(0.05, unit="m", gt=0, doc="step (curb) height")
    bump_height: float = field(0.05, unit="m", gt=0, doc="bump height, a circular segment")
    bump_length: float = field(0.3, unit="m", gt=0, doc="bump length along the path (chord)")
    pothole_depth: float = field(0.05, unit="m", gt=0, doc="pothole (ditch) depth")
    pothole_width: float = field(0.2, unit="m", gt=0, doc="pothole width along the path")
    terrain_amplitude: float = field(0.03, unit="m", ge=0, doc="terrain height, lowest to highest point")
    terrain_wavelength: float = field(0.5, unit="m", gt=0, doc="terrain bump wavelength (correlation length)")
    terrain_seed: float = field(0.0, unit="1", ge=0, doc="terrain random seed (a number; integers by convention)")
    drive_law: str = "smooth_step"  # steer_in_place keeps the seed's ramp (SCENARIOS)
    towing: tuple[bool, bool, bool, bool] = (False, False, False, False)
    laws: dict | None = None
    # kind mission (batchveh.model.missions): the segments as read, and the torque thresholds in N m
    segments: list | None = None
    torque_threshold: dict | None = None

    def validate(self, where: str = "scenario") -> None:
        """Raise ConfigError for an unknown kind or inconsistent fields."""
        check_kind(self.kind, f"{where}: ")
        if self.drive_law not in ("ramp", "unbounded_ramp", "smooth_step"):
            raise ConfigError(
                f"{where}.drive_law: {self.drive_law!r} is not allowed; allowed: ramp, unbounded_ramp, smooth_step"
            )
        entry = SCENARIOS[self.kind]
        if entry.check is not None:
            entry.check(self, where)
        for key in ("segments", "torque_threshold"):
            if getattr(self, key) is not None and key not in entry.reads:
                kinds = [k for k, e in SCENARIOS.items() if key in e.reads]
                raise ConfigError(
                    f"{where}: {key}: given for kind {self.kind!r}; allowed only with kind: {', '.join(kinds)}"
                )
        course.check_obstacle(self.obstacle, where)
        if self.obstacle != "none" and self.kind not in course.KINDS:
            raise ConfigError(
                f"{where}.obstacle: {self.obstacle!r} is not allowed with scenario {self.kind!r} (it does not drive "
                f"along +X at the obstacle); allowed: obstacle: none, or scenario {', '.join(course.KINDS)}"
            )
        if self.time_step > self.total_time:
            raise ConfigError(f"{where}.time_step: {self.time_step!r} exceeds total_time {self.total_time!r}")
        st = self.settle_time
        if isinstance(st, bool) or not isinstance(st, (int, float)) or not (math.isfinite(st) and 0 <= st <= 86400):
            raise ConfigError(f"{where}.settle_time: {st!r} is not allowed; allowed: >= 0 and <= 86400 s")

    @property
    def settle_steps(self) -> int:
        """Physics steps of the settle before law time 0 (settle_time rounded to whole steps)."""
        return int(round(self.settle_time / self.time_step))

    @property
    def n_steps(self) -> int:
        """Number of physics steps: the settle's, then total_time's."""
        return self.settle_steps + int(round(self.total_time / self.time_step))

    def gravity_vector(self) -> np.ndarray:
        """(3,) gravity in m/s^2 tilted by the slope: (-g sin s, 0, -g cos s)."""
        return gravity_vector(self.gravity, self.slope_deg, xp=np)  # numpy: no eager JAX op (2 s on a GPU)


def gravity_vector(g, slope_deg, xp=jnp):
    """Gravity tilted by the slope, as in the seed: (-g sin s, 0, -g cos s) in m/s^2."""
    s = xp.deg2rad(slope_deg)
    return xp.stack([-g * xp.sin(s), 0.0 * s, -g * xp.cos(s)], axis=-1)


def numeric_fields() -> dict[str, dict[str, Any]]:
    """The sweepable float fields of Scenario, with unit and bounds (`settle_time` is not one:
    it fixes the step count, and it is no per-variant knob; set it in the scenario)."""
    return {f.name: dict(f.metadata) for f in dataclasses.fields(Scenario) if f.metadata and f.metadata["sweep"]}


# --- controls ------------------------------------------------------------------
Controls = Callable[[Scenario, Mapping[str, Any], Any], tuple[Any, Any]]


def _omega(p):
    """Wheel speed in rad/s for the target rim speed p['speed_kmh']."""
    return p["speed_kmh"] / 3.6 / p["wheel.radius"]


def _drive(sc: Scenario, target, p, t):
    """The drive law `sc.drive_law` from 0 to `target` over ramp_time. The default, smooth_step,
    reaches the target in the same ramp_time as the seed's ramp, with zero acceleration at both
    ends, so the start and the end of the ramp excite no under-resolved servo mode and the
    peaks converge in dt (validation/PEAKS.md); its peak acceleration is 15/8 of the ramp's
    (set ramp_time 1.875x longer for the ramp's peak acceleration)."""
    law = laws.LAWS[sc.drive_law]
    return law(t, 0.0 * target, target, p["ramp_time"])


_STEERED = np.array([STEERED[name] for name in LAYOUTS], float)  # (layouts, 4): 1 where the hub steers
_SKID = LAYOUTS.index("skid")


def steered(p):
    """(4,) 1.0 where the hub steers in the vehicle's layout (`steering.layout`, carried as LAYOUT_KEY), else 0:
    every steering target is multiplied by it, so a fixed hub's angle, rate and axis roll are 0."""
    code = jnp.asarray(p[LAYOUT_KEY])  # every engine carries it (params.base_params); a lost key fails loudly
    return jnp.asarray(_STEERED)[jnp.round(code).astype(int)]


def _skid(p):
    """True where the vehicle is skid-steered (a traced scalar)."""
    return jnp.round(jnp.asarray(p[LAYOUT_KEY])) == _SKID


def skid_speeds(p, speed_ms, yaw_rate):
    """Wheel speeds (4,) rad/s of a skid-steered vehicle whose centre moves at `speed_ms` (m/s, along its x) and
    yaws at `yaw_rate` (rad/s, >0 counter-clockwise): each wheel rolls at the chassis' velocity along x at its
    centre, speed - yaw_rate y (y = +-wheel.y_cg, half the track). Its sideways velocity, yaw_rate x, slides: the
    turning resistance (docs/physics.md, "Layouts")."""
    return (speed_ms - yaw_rate * _SY * p["wheel.y_cg"]) / p["wheel.radius"]


def _axes(p):
    """(4,) x and y of the steering axes in m: (+-steering.axis_x, +-steering.axis_y), the chassis corners where
    those are 0 (vehicle.hinge_xy)."""
    hx, hy = hinge_xy(p, jnp)
    return _SX * hx, _SY * hy


def _offset(p):
    """The wheel centre's distance outboard of its steering axis, m (the scrub radius)."""
    return p["wheel.y_cg"] - hinge_xy(p, jnp)[1]


def _wheel_from_axis(p):
    """(4,) x and y of each wheel centre from its steering axis at zero steer, m: a trail along the vehicle where
    the wheel is not on its axis's line, the offset outboard."""
    return _SX * (p["wheel.x_cg"] - hinge_xy(p, jnp)[0]), _SY * _offset(p)


def axis_roll(p, steer_rate):
    """Wheel speeds (4,) in rad/s that roll each wheel centre about its offset steering axis as the
    steering turns at `steer_rate` (4,) rad/s: the centre moves at offset * steer_rate."""
    return -_SY * _offset(p) * steer_rate / p["wheel.radius"]


def straight_line(sc, p, t):
    """Seed scenario 1: all wheels ramp to the target speed; no steering."""
    w = _drive(sc, _omega(p), p, t)
    return jnp.full(4, 1.0) * w, jnp.zeros(4)


def steer_in_place(sc, p, t):
    """Seed scenario 2: steer to -+steer_deg (lf, rf, lr, rr: -, +, +, -) over ramp_time.

    Each wheel is driven so that it rolls around its offset steering axis, as the
    seed does: a ramp to offset * steering rate / radius (0.134 rad/s for the seed).
    The steering turns at its full rate from t = 0 while the drive speeds ramp up from 0,
    so each rim lags its path and the wheels slide (scrub) for most of the ramp;
    `steer_in_place_rolling` is the consistent form.
    """
    target = jnp.deg2rad(p["steer_deg"]) * jnp.array([-1.0, 1.0, 1.0, -1.0]) * steered(p)
    alpha = laws.ramp(t, 0.0 * target, target, p["ramp_time"])
    roll = axis_roll(p, target / jnp.maximum(p["ramp_time"], 1e-12))
    return _drive(sc, roll, p, t), alpha


def steer_in_place_rolling(sc, p, t):
    """Seed scenario 2, consistent form: the seed's steering, with each wheel rolling at its path speed.

    The wheel centre sits `offset` outboard of its steering axis, so while the hub turns at
    d alpha/dt the centre moves at offset * d alpha/dt along the wheel's heading. Here each wheel
    rolls at exactly that speed, omega = -sy * offset * (d alpha/dt) / r (0.134 rad/s for the seed),
    from t = 0 while the steering ramps, and stands still after it: the centre of each contact
    does not slide, and only the contact's width scrubs (a spin about the vertical through the
    contact centre: mu N width / 4 of steering torque for a uniformly loaded line, up to
    mu N width / 2 with MuJoCo's two contacts at the edges of the line).
    `steer_in_place` is the seed's form: there the drive speeds ramp up from 0, so each rim lags
    its path and the wheels slide. `drive_law` does not apply here.
    """
    target = jnp.deg2rad(p["steer_deg"]) * jnp.array([-1.0, 1.0, 1.0, -1.0]) * steered(p)
    duration = jnp.maximum(p["ramp_time"], 1e-12)
    alpha = laws.ramp(t, 0.0 * target, target, p["ramp_time"])
    roll = axis_roll(p, target / duration)
    turning = (t > 0.0) & (t <= p["ramp_time"])
    return jnp.where(turning, roll, 0.0 * roll), alpha


def crab(sc, p, t):
    """All four wheels steer to steer_deg, then drive at the target speed: the body translates sideways."""
    alpha = laws.ramp(t, 0.0, jnp.deg2rad(p["steer_deg"]), p["ramp_time"]) * steered(p)
    w = laws.ramp(t, 0.0, _omega(p), p["ramp_time"], delay=p["ramp_time"])
    return jnp.ones(4) * w, alpha


def pivot_targets(p, yaw_rate_dps):
    """(wheel speeds (4,) rad/s, steering angles (4,) rad) of a turn on the spot at yaw_rate_dps
    (deg/s, >0 counter-clockwise) about the chassis centre: each wheel rolls tangent to its circle. Skid-steered:
    the hubs stay straight, the left wheels roll back and the right ones forward at the yaw rate times half the
    track (`skid_speeds`)."""
    ax, ay = _axes(p)
    rate = jnp.deg2rad(yaw_rate_dps)
    omega, alpha = _rolling_about(p, ax, ay, rate)
    skid = _skid(p)
    return jnp.where(skid, skid_speeds(p, 0.0, rate), omega), jnp.where(skid, 0.0, alpha)


def pivot(sc, p, t):
    """Turn on the spot: steer tangent to a circle about the centre, then yaw at yaw_rate_dps."""
    omega_t, alpha_t = pivot_targets(p, p["yaw_rate_dps"])
    alpha = laws.ramp(t, 0.0 * alpha_t, alpha_t, p["ramp_time"])
    w = laws.ramp(t, 0.0 * omega_t, omega_t, p["ramp_time"], delay=p["ramp_time"])
    return w, alpha


def ackermann_targets(p, curvature, speed_kmh):
    """(wheel speeds (4,) rad/s, steering angles (4,) rad) of a turn about a centre on the rear
    wheels' axle line, (-wheel.x_cg, 1 / curvature) (curvature in 1/m, >0 left; 0 drives straight),
    the chassis centre at speed_kmh: the rear wheels steer 0, each wheel rolls at its own distance
    from the centre. Lengths are scaled by the curvature, so a straight line is the same formula.

    Front-steered: the rear hubs are fixed straight, each rear wheel rolling at the chassis' velocity at its
    centre (on the axle line, so it does not slide). Skid-steered: no hub steers; the centre moves at speed_kmh and
    the chassis yaws at v kappa (`skid_speeds`), the centre of the turn abreast of the chassis centre."""
    ax, ay = _axes(p)
    xc = -p["wheel.x_cg"]
    # the chassis centre turns at yaw rate v kappa / hypot(xc kappa, 1), at v
    rate = speed_kmh / 3.6 / jnp.hypot(xc * curvature, 1.0)
    omega, alpha = _rolling_about(p, (ax - xc) * curvature, ay * curvature - 1.0, rate, scale=curvature)
    mask = steered(p)
    # a fixed rear hub (front layout): the rear axle point moves at v / hypot(xc kappa, 1) = rate, yaw rate kappa
    fixed = skid_speeds(p, rate, rate * curvature)
    skid = skid_speeds(p, speed_kmh / 3.6, speed_kmh / 3.6 * curvature)
    omega = jnp.where(_skid(p), skid, jnp.where(mask > 0, omega, fixed))
    return omega, alpha * mask


def ackermann_rolling(p, curvature, speed_kmh, alpha, alpha_rate):
    """Wheel speeds (4,) rad/s while the Ackermann steering angles `alpha` (4,) rad change at `alpha_rate`
    (rad/s), the curvature (1/m) and speed_kmh those of the instant.

    A wheel that trails its axis by dx sweeps sideways at dx * alpha_rate as it steers. It cannot roll that
    sweep away, so the chassis yaws at the rate that lets each front wheel roll without sliding instead of
    the steady v kappa / hypot(xc kappa, 1): with the rear wheels' axle point (xc, 0) at v_r along the
    chassis, a front wheel's centre W (heading h, normal n) has no velocity along n when
        yaw = (v_r sin a - alpha_rate dx) / (W_y sin a + (W_x - xc) cos a),
    the mean of the two front wheels' taken. Each wheel then rolls at the chassis' velocity at its centre
    along its heading (its own sweep along the heading, axis_roll, is added by the caller). With
    alpha_rate 0 this is ackermann_targets' speeds; with no trail (dx 0) the yaw is the steady one. A fixed hub
    (alpha 0 there) rolls at the chassis' velocity along x at its centre; a skid-steered vehicle's wheels at
    `skid_speeds` of the instant."""
    ax, ay = _axes(p)
    xc = -p["wheel.x_cg"]
    dx, dy = _wheel_from_axis(p)
    v_r = speed_kmh / 3.6 / jnp.hypot(xc * curvature, 1.0)
    c, s = jnp.cos(alpha), jnp.sin(alpha)
    wx, wy = ax + dx * c - dy * s, ay + dx * s + dy * c
    yaw = (v_r * s - alpha_rate * dx) / (wy * s + (wx - xc) * c)
    front = _SX > 0
    yaw = jnp.sum(jnp.where(front, yaw, 0.0), axis=-1, keepdims=True) / front.sum()
    omega = ((v_r - yaw * wy) * c + yaw * (wx - xc) * s) / p["wheel.radius"]
    return jnp.where(_skid(p), skid_speeds(p, speed_kmh / 3.6, speed_kmh / 3.6 * curvature), omega)


def _rolling_about(p, ux, uy, rate, scale=1.0):
    """(wheel speeds (4,) rad/s, steering angles (4,) rad) that roll every wheel without sliding
    about one centre: (ux, uy) is each steering axis's place from that centre and `rate` the yaw
    rate (rad/s), both times `scale` (the curvature of an Ackermann turn; 1 on the spot).

    The wheel centre sits at d = (dx, dy) from its axis at zero steer (a trail dx where the wheel
    is not on its axis's line, the offset dy outboard), and turns with the hub. Heading
    h = (cos a, sin a): the centre's velocity about the centre lies along h when (u + R(a) d).h = 0,
    i.e. u.h = -dx, so a = atan2(uy, ux) +- arccos(-dx / |u|), the root nearer straight ahead.
    The wheel then rolls at rate (z x (u + R(a) d)).h / r."""
    dx, dy = (d * scale for d in _wheel_from_axis(p))
    theta = jnp.arctan2(uy, ux)
    half = jnp.arccos(jnp.clip(-dx / jnp.hypot(ux, uy), -1.0, 1.0))
    a1, a2 = (jnp.arctan2(jnp.sin(theta + k * half), jnp.cos(theta + k * half)) for k in (1.0, -1.0))
    alpha = jnp.where(jnp.abs(a1) <= jnp.abs(a2), a1, a2)
    c, s = jnp.cos(alpha), jnp.sin(alpha)
    wx, wy = ux + dx * c - dy * s, uy + dx * s + dy * c
    return rate * (wx * s - wy * c) / p["wheel.radius"], alpha


def ackermann(sc, p, t):
    """Turn about a centre on the rear axle line at turn_radius (>0 left): front wheels steer, all roll."""
    omega_t, alpha_t = ackermann_targets(p, 1.0 / p["turn_radius"], p["speed_kmh"])
    alpha = laws.ramp(t, 0.0 * alpha_t, alpha_t, p["ramp_time"])
    w = laws.ramp(t, 0.0 * omega_t, omega_t, p["ramp_time"], delay=p["ramp_time"])
    return w, alpha


def towing(sc, p, t):
    """Straight line with the towing wheels (scenario.towing, rear by default) free: only the others drive."""
    return straight_line(sc, p, t)


def custom_laws(sc: Scenario, where: str = "scenario") -> tuple[laws.Law, ...]:
    """The 8 laws of a custom scenario, MOTORS order; steering laws converted from deg to rad.

    `laws:` maps `drive`, `steer` (defaults for all four) or a motor name to a law.
    """
    spec = dict(sc.laws or {})
    allowed = ("drive", "steer", *MOTORS)
    for k in spec:
        if k not in allowed:
            raise ConfigError(f"{where}.laws: unknown key {k!r}; allowed keys: {', '.join(allowed)}")
    out = []
    for motor in MOTORS:
        group = motor.split("_")[0]
        raw = spec.get(motor, spec.get(group, 0.0))
        law = laws.law_from_mapping(raw, f"{where}.laws.{motor}")
        if group == "steer":
            law = law.scaled(np.pi / 180, laws.VALUE_KEYS)
        out.append(law)
    return tuple(out)


def _custom_motions(sc: Scenario) -> list[tuple[str, str]]:
    """A custom scenario's motions: a steer of each hub its laws name (`steer` names all four)."""
    keys = set(sc.laws or {})
    hubs = CORNERS if "steer" in keys else [c for c in CORNERS if f"steer_{c}" in keys]
    at = {c: f".laws.steer_{c}" if f"steer_{c}" in keys else ".laws.steer" for c in hubs}
    return [("", "straight")] + [(at[c], f"steer_{c}") for c in hubs]


def _check_custom(sc: Scenario, where: str) -> None:
    """The custom kind's check: its laws parse (`custom_laws`)."""
    custom_laws(sc, where)


def custom(sc, p, t):
    """Eight motion laws from YAML: drive speeds in rad/s, steering angles in deg."""
    ls = custom_laws(sc)
    vals = [law(t) for law in ls]
    return jnp.stack(vals[:4]), jnp.stack(vals[4:]) * steered(p)


def manual(sc, p, t):
    """Seed scenario 0, 'manual inputs': like straight_line, every field from the config."""
    return straight_line(sc, p, t)


class Kind(NamedTuple):
    """A registered scenario kind: its controls, its own defaults, and optional hooks: `check(sc,
    where)` raises ConfigError for a scenario of this kind that cannot run; `complete(fields, where)`
    fills fields derived from the others before the Scenario is built (a mission's total_time);
    `reads` names the kind-only fields (segments, torque_threshold) it accepts."""

    controls: Controls
    defaults: dict[str, Any]
    check: Callable[[Scenario, str], None] | None = None
    complete: Callable[[dict[str, Any], str], dict[str, Any]] | None = None
    reads: tuple[str, ...] = ()
    # the motions it asks of the vehicle (MOTIONS' names), or f(sc) -> [(where, motion), ...]: `check_layout`
    # refuses those a layout cannot do
    motions: tuple[str, ...] | Callable[[Scenario], list[tuple[str, str]]] = ("straight",)


SCENARIOS: dict[str, Kind] = {
    "manual": Kind(manual, {}),
    "straight_line": Kind(straight_line, {}),
    "steer_in_place": Kind(steer_in_place, {"total_time": 3.0, "drive_law": "ramp"}, motions=("steer",)),  # seed's
    "towing": Kind(towing, {"towing": (False, False, True, True)}),
    "ackermann": Kind(ackermann, {"total_time": 8.0}, motions=("ackermann",)),
    "crab": Kind(crab, {"total_time": 8.0, "steer_deg": 30.0}, motions=("crab",)),
    "pivot": Kind(pivot, {"total_time": 8.0, "ramp_time": 2.0}, motions=("pivot",)),
    "steer_in_place_rolling": Kind(steer_in_place_rolling, {"total_time": 3.0}, motions=("steer",)),
    "custom": Kind(custom, {}, check=_check_custom, motions=_custom_motions),
}  # batchveh.model.missions registers "mission" (`register`); batchveh's __init__ imports it


# what each layout can do (Kind.motions): a fixed hub cannot steer, so a skid-steered vehicle turns by its wheel
# speeds only (ackermann: a turn of a radius; pivot: on the spot), and a front-steered one steers its front hubs
ALLOWED = {
    "four_wheel": None,  # everything
    "skid": ("straight", "ackermann", "pivot"),
    "front": ("straight", "ackermann", "steer", "steer_lf", "steer_rf"),
}
MOTION_NAMES = {"steer": "a steer in place", "crab": "a crab (all four wheels steered alike)",
                "pivot": "a pivot (a turn on the spot about the centre)",
                **{f"steer_{c}": f"a steer of hub {c}" for c in CORNERS}}  # fmt: skip
WHY = {
    "skid": "its hubs are fixed: it turns by its left and right wheel speeds",
    "front": "its rear hubs are fixed: it steers its front wheels only",
}


def check_layout(layout: str, sc: Scenario, where: str = "scenario") -> None:
    """Raise one ConfigError line where scenario `sc` asks a motion the vehicle's `steering.layout` cannot do
    (a crab or a steer in place on a skid-steered vehicle, a pivot on a front-steered one), before any work."""
    allowed = ALLOWED[layout]
    if allowed is None:
        return
    motions = SCENARIOS[sc.kind].motions
    pairs = motions(sc) if callable(motions) else [("", m) for m in motions]
    for at, motion in pairs:
        if motion not in allowed:
            kinds = [k for k, kd in SCENARIOS.items() if not callable(kd.motions) and set(kd.motions) <= set(allowed)]
            asked = MOTION_NAMES.get(motion, motion)
            raise ConfigError(
                f"{where}{at}: kind {sc.kind!r} asks {asked} of a vehicle with steering.layout {layout!r}, and "
                f"{WHY[layout]}; allowed on {layout}: {', '.join(kinds)}, custom and mission with "
                f"{', '.join(a for a in allowed if '_' not in a)} only"
            )


def register(name: str, kind: Kind) -> None:
    """Add a scenario kind to SCENARIOS (a module that builds on this one, as missions does)."""
    SCENARIOS[name] = kind


def law_time(sc: Scenario, t):
    """Law time of engine time `t` (s from the first step): t - settle, held at 0 during the settle.

    At step settle_steps, the first after the settle, it is exactly 0 with a time derivative
    of 1, as engine time is at the first step of a run without a settle: the engines compute
    step times i * dt by different routes (an XLA scan may fuse i * dt - settle into one
    rounding), and a law's rate at a kink (jnp.clip's gradient at its bound is 1/2) must not
    depend on the last bit. Before it the held value carries no time derivative, so the
    steering rates are 0 while the laws are held."""
    if not sc.settle_steps:
        return t
    t0 = jnp.asarray(sc.settle_steps, t.dtype) * jnp.asarray(sc.time_step, t.dtype)
    tl = t - t0
    near = jnp.abs(tl) <= 8 * jnp.finfo(t.dtype).eps * t0  # the rounding of i * dt at i = settle_steps
    tl = jnp.where(near, tl - jax.lax.stop_gradient(tl), tl)  # exactly 0, derivative 1
    return jnp.where(tl < 0, jnp.zeros_like(tl), tl)


def controls_fn(sc: Scenario) -> Callable[[Mapping[str, Any], Any], Any]:
    """f(p, t) -> ctrl (16,) for the vehicle's actuators: omega, alpha, omega, dalpha/dt.

    `p` maps scenario fields and vehicle paths (e.g. 'wheel.radius') to arrays. `t` is engine
    time, in s from the first step: the laws see `law_time` (held at 0 through the settle).
    The steering rate is the exact time derivative of the angle law (jax.jvp).
    """
    fn = SCENARIOS[sc.kind].controls

    def ctrl(p, t):
        t = jnp.asarray(t, dtype=jnp.result_type(float))
        (omega, alpha), (_, dalpha) = jax.jvp(lambda tt: fn(sc, p, law_time(sc, tt)), (t,), (jnp.ones_like(t),))
        return jnp.concatenate([omega, alpha, omega, dalpha])

    return ctrl


def control_schedule(sc: Scenario) -> Callable[[Mapping[str, Any], Any], Any]:
    """f(p, times) -> ctrl (len(times), 16) for one variant: `controls_fn` over engine times.

    vmap it once more over `p` for many variants; jit it where it is called repeatedly.
    """
    return jax.vmap(controls_fn(sc), in_axes=(None, 0))


def check_kind(kind: Any, prefix: str = "", what: str = "not known") -> None:
    """Raise the one 'unknown scenario' ConfigError (with the closest name) unless `kind` is registered."""
    if kind not in SCENARIOS:
        raise ConfigError(
            f"{prefix}scenario {kind!r} is {what}{did_you_mean(kind, SCENARIOS)}; known: {', '.join(SCENARIOS)}"
        )


def make_scenario(kind: str = "straight_line", **overrides: Any) -> Scenario:
    """A registered scenario with its own defaults, then `overrides`."""
    check_kind(kind)
    sc = Scenario(kind=kind, **_complete({**SCENARIOS[kind].defaults, **overrides}, kind, "scenario"))
    sc.validate()
    return sc


def scenario_from_mapping(data: Mapping[str, Any], where: str) -> Scenario:
    """Build a Scenario from a mapping whose `kind` (or `name`) picks the registry entry."""
    data = dict(data)
    kind = data.pop("kind", data.pop("name", "straight_line"))
    check_kind(kind, f"{where}: ")
    if isinstance(data.get("gravity"), str):
        g = data["gravity"].lower()
        if g not in GRAVITY_PRESETS:
            raise ConfigError(
                f"{where}: gravity: {data['gravity']!r} is not allowed; allowed: a number "
                f"in m/s^2 or one of {', '.join(GRAVITY_PRESETS)}"
            )
        data["gravity"] = GRAVITY_PRESETS[g]
    return from_mapping(Scenario, {"kind": kind, **SCENARIOS[kind].defaults, **_complete(data, kind, where)}, where)


def _complete(fields: dict[str, Any], kind: str, where: str) -> dict[str, Any]:
    """`fields` with what the kind derives from them (its `complete` hook), before the Scenario is built."""
    complete = SCENARIOS[kind].complete
    return fields if complete is None else complete(fields, where)


def load_scenario(name_or_path: str | Path) -> Scenario:
    """A registered scenario by name, or a scenario YAML file."""
    s = str(name_or_path)
    if s not in SCENARIOS and (s.endswith((".yaml", ".yml")) or Path(s).exists()):
        return scenario_from_mapping(load_yaml(s), s)
    check_kind(s, what="neither a known scenario nor a YAML file")
    return make_scenario(s)
