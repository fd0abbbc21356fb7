"""The four-wheeled vehicle of the seed: definition, YAML loading and MuJoCo model.

Frame and conventions (the seed's, see docs/physics.md, "Conventions"):
- Z up, X forward, Y left. Lengths in m, masses in kg.
- The vehicle is a chassis box on a free joint, four hubs on vertical steering
  hinges at (+-steering.axis_x, +-steering.axis_y), by default the chassis corners
  (+-length/2, +-width/2), and four wheel cylinders on spin hinges about the hub's Y
  axis. Wheel centres sit at z = wheel radius, touching the ground plane at z = 0.
- Drive motor: positive angular speed rolls the wheel forward (+X); its torque is
  the torque on the wheel about +Y (hub frame) from its motor, positive when it
  drives the vehicle forward or up a slope.
- Steering motor: positive angle turns the wheel counter-clockwise seen from
  above (towards +Y); its torque is about +Z on the hub from the chassis.

Each motor is a stiff PD tracking servo built from two MuJoCo actuators on the
same joint, tau = kp * (theta_ref - theta) + kv * (omega_ref - omega). For a
drive, theta_ref is the integral of the imposed speed (an integrator actuator);
for steering, omega_ref is the time derivative of the imposed angle. The motor
torque read out is the sum of both actuators on the joint (qfrc_actuator).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np

from batchveh.config import ConfigError, field, from_mapping, load_yaml
from batchveh.model.motors import DCMotor, dcmotor_xml, load_catalogue, pick, reflected_inertia, with_fields
from batchveh.model.soil import Soil
from batchveh.model.tyres import Tyre

CORNERS = ("lf", "rf", "lr", "rr")
# (x sign, y sign) of each corner
CORNER_SIGNS = {"lf": (1, 1), "rf": (1, -1), "lr": (-1, 1), "rr": (-1, -1)}
MOTORS = tuple(f"drive_{c}" for c in CORNERS) + tuple(f"steer_{c}" for c in CORNERS)
CHANNELS = (*MOTORS, "drive_sum")  # the torques the statistics reduce: 8 motors and the four-wheel drive sum
GROUND = "ground"
# the steering layouts (`steering.layout`): which hubs steer. A hub that does not steer is fixed: its hinge stays
# in the model, held at 0 by its steering slot (the servo's PD, or HUB_LOCK with model dcmotor), and that slot's
# torque is the moment the hub's mounting carries, not a motor's (sizing judges no steering there)
LAYOUTS = ("four_wheel", "skid", "front")
STEERED = {"four_wheel": (True, True, True, True), "skid": (False, False, False, False),
           "front": (True, True, False, False)}  # fmt: skip
LAYOUT_KEY = "steering.layout"  # the flat parameter carrying LAYOUTS.index(layout) to the controls (base_params)
PAYLOAD_RADIUS = 0.02  # m, the payload's sphere (its inertia is 2/5 m r^2 about its centre)


@dataclass(frozen=True)
class Chassis:
    """Chassis box, centred at (x_cg, y_cg, z_cg); it does not collide."""

    length: float = field(1.0, unit="m", gt=0)
    width: float = field(0.6, unit="m", gt=0)
    height: float = field(0.15, unit="m", gt=0)
    mass: float = field(88.4, unit="kg", gt=0)
    x_cg: float = field(0.0, unit="m")
    y_cg: float = field(0.0, unit="m")
    z_cg: float = field(0.355, unit="m", gt=0)


@dataclass(frozen=True)
class Wheel:
    """Wheel cylinder, axis along Y; centre at (+-x_cg, +-y_cg, radius)."""

    radius: float = field(0.195, unit="m", gt=0)
    width: float = field(0.09, unit="m", gt=0)
    mass: float = field(3.0, unit="kg", gt=0)
    x_cg: float = field(0.5, unit="m", gt=0)
    y_cg: float = field(0.4, unit="m", gt=0)
    rolling_resistance: float = field(
        0.0, unit="1", ge=0, le=1, doc="rolling resistance coefficient C_rr (0.01-0.06: polyurethane to soft rubber)"
    )
    # contact shape: 'cylinder' (the seed's; MJX makes 3 contacts per wheel) or 'sphere'
    # (one contact per wheel, same mass and inertia; no contact width, so no scrub torque
    # from the width: faster on a GPU, for drive torques on straight paths)
    collision: Literal["cylinder", "sphere"] = "cylinder"


@dataclass(frozen=True)
class Hub:
    """Hub cylinder, axis along Y, centre at (+-wheel.x_cg, +-y_cg, wheel radius)."""

    radius: float = field(0.063, unit="m", gt=0)
    length: float = field(0.258, unit="m", gt=0)
    mass: float = field(11.1, unit="kg", gt=0)
    y_cg: float = field(0.226, unit="m", gt=0)


@dataclass(frozen=True)
class Steering:
    """Where the four steering hinges (each hub's vertical joint) stand: at (+-axis_x, +-axis_y), in the frame of
    wheel.x_cg and wheel.y_cg; 0, the default, puts a hinge at the chassis box's corner (chassis.length / 2,
    chassis.width / 2), the seed's rule. A wheel whose contact is not on its hinge's line along the vehicle has a
    trail, one outboard of it a scrub radius (`Vehicle.steering_geometry`; docs/physics.md, "Trail and scrub
    radius")."""

    axis_x: float = field(
        0.0, unit="m", ge=0, doc="each steering hinge's distance ahead of / behind the centre (0: chassis.length / 2)"
    )
    axis_y: float = field(
        0.0, unit="m", ge=0, doc="each steering hinge's distance left / right of the centre (0: chassis.width / 2)"
    )
    # which wheels steer (LAYOUTS): 'four_wheel', the seed's (four steered hubs); 'skid' (hubs fixed: turns by the
    # left and right wheel speeds, the wheels sliding sideways); 'front' (the front hubs steer at Ackermann angles,
    # the rear hubs fixed). Structure: one layout a sweep (docs/physics.md, "Layouts")
    layout: Literal["four_wheel", "skid", "front"] = "four_wheel"

    @property
    def steered(self) -> tuple[bool, ...]:
        """Whether each hub steers, CORNERS order."""
        return STEERED[self.layout]


@dataclass(frozen=True)
class Payload:
    """A point-like payload fixed to the chassis; position relative to the chassis centre.

    It is a body of its own welded to the chassis (no joint): every body's mass, centre and inertia
    is then one geom's, with no principal-axes decomposition, so a sweep derives them in closed form
    (`stepping/fields.py`); the dynamics are those of one rigid chassis with the payload on it."""

    mass: float = field(0.0, unit="kg", ge=0)
    x: float = field(0.0, unit="m")
    y: float = field(0.0, unit="m")
    z: float = field(0.0, unit="m")


@dataclass(frozen=True)
class Motors:
    """Servo gains of the 8 motors and the rotor inertia reflected at each joint.

    The defaults track within 1e-5 relative speed and 0.1 deg on a 20 deg slope
    at mu 0.9 (tests/test_physics.py) and stay stable with implicitfast at dt = 5 ms.
    The armature (e.g. a 2e-4 kg m^2 rotor behind a 32:1 gearbox) damps the
    stick-slip cycle of four wheels locked to one speed; with 0.05 the wheels
    chattered near the friction limit (docs/physics.md, "Servo choice").
    """

    drive_kp: float = field(5000.0, unit="N m/rad", ge=0)
    drive_kv: float = field(500.0, unit="N m s/rad", ge=0)
    steer_kp: float = field(20000.0, unit="N m/rad", ge=0)
    steer_kv: float = field(300.0, unit="N m s/rad", ge=0)
    armature: float = field(0.2, unit="kg m^2", ge=0, doc="rotor inertia reflected through the gearbox")
    # model dcmotor: the drive's loops (batchveh/model/drive.py, docs/motors.md). 0, the default, derives each
    # gain per variant from its inertia, motor constants and time step; a positive value replaces it
    dc_drive_kp: float = field(0.0, unit="N m/rad", ge=0, doc="dcmotor drives' speed-loop integral gain (0: derived)")
    dc_drive_kv: float = field(0.0, unit="N m s/rad", ge=0, doc="dcmotor drives' speed-loop gain (0: derived)")
    dc_drive_bandwidth: float = field(
        0.0,
        unit="rad/s",
        ge=0,
        doc="dcmotor drives' speed-loop bandwidth on the loaded wheel (0: the largest dt allows)",
    )
    dc_steer_kp: float = field(0.0, unit="N m/rad", ge=0, doc="dcmotor steering's angle gain (0: derived)")
    dc_steer_kv: float = field(0.0, unit="N m s/rad", ge=0, doc="dcmotor steering's rate gain (0: derived)")
    dc_steer_ki: float = field(0.0, unit="N m/(rad s)", ge=0, doc="dcmotor steering's integral gain (0: derived)")
    dc_steer_bandwidth: float = field(
        0.0, unit="rad/s", ge=0, doc="dcmotor steering's angle-loop bandwidth (0: the largest dt allows)"
    )
    # model dcmotor: each winding's temperature rise over its ambient at t = 0 (K), e.g. the hot steady state of
    # back-to-back runs (batchveh.sizing.loop.in_loop finds it); read as the thermal state's start value
    drive_start_rise: float = field(0.0, unit="K", ge=0, doc="dcmotor drives' winding rise at the start")
    steer_start_rise: float = field(0.0, unit="K", ge=0, doc="dcmotor steering windings' rise at the start")
    # model dcmotor: also write how each run's columns move with the start rises (motor_stats.HOT_COLUMNS), from
    # which the size command's loop takes the hot steady state's columns out of one run (sizing.thermal.hot_columns)
    hot_columns: bool = False
    # 'servo': the ideal PD servo above (the torque demand); 'dcmotor': each motor is MuJoCo's dcmotor, a
    # catalogue motor with its gearhead (batchveh/model/motors.py) driven by batchveh's drive (model/drive.py:
    # speed and angle loops, current limit, bus voltage, winding); its rotor inertia replaces `armature`
    model: Literal["servo", "dcmotor"] = "servo"
    catalogue: str = ""  # the DC motor catalogue's path (YAML, model/motors.py's load_catalogue)
    drive: str = ""  # the drive motors' catalogue name
    steer: str = ""  # the steering motors' catalogue name
    # fields set over the catalogue's values, ((field, value), ...): the sweep's motors.drive.<field>
    drive_set: tuple[tuple[str, float], ...] = ()
    steer_set: tuple[tuple[str, float], ...] = ()

    def validate(self, where: str = "motors") -> None:
        """With model dcmotor: the catalogue loads and names the drive motor, and the steering motor where one is
        named (the vehicle asks for it where a hub steers: `Vehicle.validate`); one ConfigError line."""
        if self.model == "dcmotor":
            self.dcmotors(where, steer=bool(self.steer))

    def dcmotors(self, where: str = "motors", steer: bool = True) -> tuple[DCMotor, DCMotor]:
        """The (drive, steer) catalogue motors of model dcmotor; with `steer` False (no hub steers: a skid
        layout) HUB_LOCK stands for the steering motor."""
        if not self.catalogue:
            raise ConfigError(f"{where}.catalogue: missing; allowed: the path of a motor catalogue (model: dcmotor)")
        catalogue = _catalogue(self.catalogue, where)
        drive = with_fields(pick(catalogue, self.drive, f"{where}.drive"), self.drive_set)
        if not steer:
            drive.resolved(f"{where}.drive")
            return drive, HUB_LOCK
        steer = with_fields(pick(catalogue, self.steer, f"{where}.steer"), self.steer_set)
        drive.resolved(f"{where}.drive"), steer.resolved(f"{where}.steer")
        return drive, steer

    def catalogue_names(self, where: str = "motors") -> list[str]:
        """The catalogue's motor names, in its order (model dcmotor)."""
        return list(_catalogue(self.catalogue, where)) if self.catalogue else []


@functools.lru_cache(maxsize=8)
def _catalogue_at(path: str, mtime: float) -> dict[str, DCMotor]:
    return load_catalogue(path)


def _catalogue(path: str, where: str) -> dict[str, DCMotor]:
    try:
        return _catalogue_at(path, Path(path).stat().st_mtime)
    except FileNotFoundError:
        raise ConfigError(f"{where}.catalogue: {path}: file not found; allowed: a motor catalogue's path") from None


# a fixed hub's steering slot with model dcmotor: a stiff direct drive (1 N m/A, 0.01 Ohm, 10 kA at 1 kV: 10 kN m)
# that holds the hub at 0 through the drive's angle loop, as the servo's PD does; no winding heats. Not a motor of
# the catalogue: its torque is the moment the hub's mounting carries. Its rotor inertia, 1 kg m^2 at a joint that
# does not move, keeps the loop's derived gains positive: its back-EMF damping, K^2 / R = 100 N m s/rad, over a
# light hub's inertia (below about 0.17 kg m^2 at dt 5 ms) made the angle gain negative (model/drive.gains) and
# the hubs of a 50 kg robot spun away within 0.3 s; with it they hold within 1e-5 rad
HUB_LOCK = DCMotor(name="hub_lock", torque_constant=1.0, terminal_resistance=0.01, bus_voltage=1000.0,
                   max_continuous_current=1.0e4, rotor_inertia=1.0)  # fmt: skip


@dataclass(frozen=True)
class ContactModel:
    """The rigid wheel-ground model's contact (`tyre: {model: rigid}`): how MuJoCo's soft friction
    approaches Coulomb friction (validation/DRAG.md, SCRUB.md). The slip tyre uses only its
    impedance and time constant, for the frictionless normal contact.

    MuJoCo's friction is a soft constraint: below a saturation slip speed it acts as a
    viscous damper. With its defaults (pyramidal cone, impratio 1) a seed wheel sliding at
    3 mm/s feels 0.27 mu N. The default here, an elliptic cone, impratio 100 and a soft
    impedance d = 0.25 (MuJoCo's solimp is 0.9), gives mu N from 1 mm/s up in every slip
    direction, and lets each edge of a scrubbing wheel's contact slide like Coulomb's: in the
    seed's scenario 2 the drive torque is 0.997 mu N r and the steering torque 1.088 mu N offset
    (the outer edge carries 60% of the load). With d = 0.9 the solver pushed the inner edge along
    its slip: 0.32 mu N r and 0.76 mu N offset. The price of the soft impedance: the wheels
    sink 1.5 mm, so a climb's four-wheel sum is 0.3% below m g sin(s) r, and turns creep 2%
    (tests/test_physics.py). On the warp engine it is 1.34x faster than d = 0.9 (6.74e6
    against 5.03e6 variant-steps/s, one H200). 'pyramidal' with impratio 1 is the fast preset
    (0.71 mu N against a diagonal slip)."""

    cone: Literal["elliptic", "pyramidal"] = "elliptic"
    impratio: float = field(100.0, unit="1", ge=1, le=1e4, doc="frictional-to-normal impedance ratio", sweep=False)
    impedance: float = field(
        0.25, unit="1", gt=0, le=0.999, doc="contact impedance d (MuJoCo solimp d0 = dwidth)", sweep=False
    )
    time_constant: float = field(
        0.02, unit="s", gt=0, doc="contact time constant (MuJoCo solref, damping ratio 1)", sweep=False
    )


@dataclass(frozen=True)
class Vehicle:
    """The whole vehicle; the defaults are the seed's vehicle_params.yaml."""

    chassis: Chassis = Chassis()
    wheel: Wheel = Wheel()
    hub: Hub = Hub()
    payload: Payload = Payload()
    motors: Motors = Motors()
    # where the steering hinges stand (the chassis corners unless set)
    steering: Steering = Steering()
    # 'ground': wheels touch the ground only (fast, the seed's intent); 'all': wheels also
    # touch each other and the hubs touch the ground
    contacts: Literal["ground", "all"] = "ground"
    contact_model: ContactModel = ContactModel()
    # the wheel-ground model: 'slip' (a slip tyre on frictionless contacts) or 'rigid' (MuJoCo's
    # frictional contact, contact_model above) or 'soil' (the soil below); batchveh/model/tyres.py
    tyre: Tyre = Tyre()
    # the soft soil of `tyre.model: soil` (batchveh/model/soil.py): a published preset and its fields
    soil: Soil = Soil()

    @property
    def total_mass(self) -> float:
        """Total mass in kg."""
        return self.chassis.mass + 4 * (self.wheel.mass + self.hub.mass) + self.payload.mass

    @property
    def hinge(self) -> tuple[float, float]:
        """(x, y) in m of the front-left steering hinge (`steering.axis_x`, `steering.axis_y`, or the chassis
        corner where 0); the other three mirror it."""
        x, y = hinge_xy(self.flat_geometry())
        return float(x), float(y)

    def flat_geometry(self) -> dict[str, float]:
        """The flat parameters `hinge_xy` and `steering_geometry_of` read."""
        c, w, s = self.chassis, self.wheel, self.steering
        return {"chassis.length": c.length, "chassis.width": c.width, "wheel.x_cg": w.x_cg, "wheel.y_cg": w.y_cg,
                "steering.axis_x": s.axis_x, "steering.axis_y": s.axis_y}  # fmt: skip

    @property
    def steer_offset(self) -> float:
        """Lateral distance in m from a steering axis to its wheel centre (scrub radius), outboard positive."""
        return self.wheel.y_cg - self.hinge[1]

    def steering_geometry(self) -> dict[str, dict[str, float]]:
        """Each wheel's {'trail', 'scrub_radius'} in m at zero steer, CORNERS order (`steering_geometry_of`)."""
        geo = steering_geometry_of(self.flat_geometry())
        return {c: {k: float(v) for k, v in g.items()} for c, g in geo.items()}

    def validate(self, where: str = "vehicle") -> None:
        """Raise ConfigError where the parts do not fit together."""
        if self.wheel.radius <= self.hub.radius:
            raise ConfigError(f"{where}: wheel.radius {self.wheel.radius!r} must exceed hub.radius {self.hub.radius!r}")
        if self.steering.layout == "skid":
            for key in ("axis_x", "axis_y"):
                value = getattr(self.steering, key)
                if value:
                    raise ConfigError(
                        f"{where}: steering.{key}: {value!r} places a steering hinge, and steering.layout 'skid' has "
                        "none (its hubs are fixed); allowed: no steering.axis_x / axis_y with layout skid, or layout "
                        "four_wheel or front"
                    )
            if self.motors.steer:
                raise ConfigError(
                    f"{where}: motors.steer: {self.motors.steer!r} is a steering motor, and steering.layout 'skid' "
                    "has none; allowed: no motors.steer with layout skid"
                )
        if self.motors.model == "dcmotor":
            self.dc_motors(f"{where}: motors")

    def dc_motors(self, where: str = "motors") -> tuple[DCMotor, ...]:
        """The 8 dcmotors of model dcmotor, MOTORS order: the drive motor at each wheel, the steering motor at each
        steered hub and HUB_LOCK at each fixed one (`steering.layout`)."""
        drive, steer = self.motors.dcmotors(where, steer=any(self.steering.steered))
        return (drive,) * 4 + tuple(steer if s else HUB_LOCK for s in self.steering.steered)


def hinge_xy(p: Any, xp: Any = np) -> tuple[Any, Any]:
    """(x, y) in m of the front-left steering hinge from flat parameters (floats or (n,) arrays, numpy or jax;
    `xp` the array module): `steering.axis_x` and `steering.axis_y` where positive, else the chassis corner,
    `chassis.length / 2` and `chassis.width / 2`, bit for bit as before the keys existed. Corner c's hinge is at
    (sx hx, sy hy), (sx, sy) = CORNER_SIGNS[c]."""
    ax, ay = p["steering.axis_x"], p["steering.axis_y"]
    return xp.where(ax > 0, ax, p["chassis.length"] / 2), xp.where(ay > 0, ay, p["chassis.width"] / 2)


def steering_geometry_of(p: Any, xp: Any = np) -> dict[str, dict[str, Any]]:
    """Each wheel's steering geometry at zero steer from flat parameters (`hinge_xy`), m, per corner:

    - `trail`: the contact's distance behind its hinge along the vehicle (+X forward), sx (hx - wheel.x_cg). A
      positive trail trails like a caster; a negative one leads the hinge when driving forward (the rear wheels
      of a body longer than the wheelbase);
    - `scrub_radius`: the contact's distance outboard of its hinge, wheel.y_cg - hy (the same on every corner).

    Where the contact trails its hinge by a, a steer at a standstill drags it sideways: about mu N |a| at the
    hinge on top of the patch's own scrub (docs/physics.md, "Trail and scrub radius")."""
    hx, hy = hinge_xy(p, xp)
    scrub = p["wheel.y_cg"] - hy
    # + 0.0: a wheel on its hinge's line reads a trail of 0, not -0 (sx = -1 on the rear)
    return {c: {"trail": CORNER_SIGNS[c][0] * (hx - p["wheel.x_cg"]) + 0.0, "scrub_radius": scrub} for c in CORNERS}


def geometry_line(vehicle: Vehicle) -> str:
    """The steering geometry of `vehicle` on one line, for a run's output and the size report."""
    hx, hy = vehicle.hinge
    s = vehicle.steering
    where = {(False, False): "the chassis corners", (True, True): "steering.axis_x, steering.axis_y",
             (True, False): "steering.axis_x; y at the chassis corner",
             (False, True): "steering.axis_y; x at the chassis corner"}[(s.axis_x > 0, s.axis_y > 0)]  # fmt: skip
    geo = vehicle.steering_geometry()
    trail = ", ".join(f"{c} {g['trail']:+.3f}" for c, g in geo.items())
    scrub = ", ".join(f"{c} {g['scrub_radius']:+.3f}" for c, g in geo.items())
    if s.layout == "skid":
        return "layout skid: every hub fixed (no steering motor); turns by the left and right wheel speeds"
    lead = "layout front: the front hubs steer, the rear hubs are fixed; " if s.layout == "front" else ""
    return (
        f"{lead}steering hinges at x +-{hx:.3f}, y +-{hy:.3f} m ({where}); trail (contact behind the hinge) {trail} m; "
        f"scrub radius (contact outboard) {scrub} m"
    )


def load_vehicle(path: str | Path | None) -> Vehicle:
    """Load a vehicle YAML (shaped like the seed's vehicle_params.yaml); None gives the default."""
    if path is None:
        return Vehicle()
    return vehicle_from_mapping(load_yaml(path), str(path))


def vehicle_from_mapping(data: dict[str, Any], where: str) -> Vehicle:
    """Build a Vehicle from a nested mapping; errors name `where` and the key."""
    return from_mapping(Vehicle, data, where)


def replace_path(obj: Any, dotted: str, value: Any) -> Any:
    """Return a copy of a dataclass tree with the field at `dotted` (e.g. 'wheel.radius') set."""
    head, _, rest = dotted.partition(".")
    if rest:
        return dataclasses.replace(obj, **{head: replace_path(getattr(obj, head), rest, value)})
    return dataclasses.replace(obj, **{head: value})


def numeric_paths(obj: Any, prefix: str = "") -> dict[str, Any]:
    """Map every numeric leaf of a dataclass tree to its field metadata, by dotted path."""
    out = {}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            out.update(numeric_paths(value, f"{prefix}{f.name}."))
        elif f.metadata and f.metadata.get("sweep", True):
            out[f"{prefix}{f.name}"] = dict(f.metadata)
    return out


def rolling_resistance_torque(c_rr, radius, total_mass, g_normal):
    """Rolling-resistance torque on each wheel, N m: C_rr r times the wheel's static share of the
    weight normal to the ground, m g cos(slope) / 4 (`g_normal` = g cos(slope), m/s^2).

    On the rigid contact it acts as the drive joint's friction loss: a torque of at most this size against the
    wheel's rotation, so a wheel rolling at any speed feels it in full. The four-wheel sum is
    exact on steady ground; the split ignores load transfer (docs/physics.md, "What the model leaves
    out"). Works on floats and arrays alike."""
    return c_rr * radius * total_mass * g_normal / 4


def contact_time_constant(cm: ContactModel, time_step: float) -> float:
    """The contact time constant the model gets, s: `cm.time_constant`, at least 4 time steps.

    MuJoCo itself raises it to 2 time steps; with the soft default impedance (0.25) that is not
    enough: a 1 s straight run at dt 20 ms flips the vehicle with 2 steps and runs with 4."""
    return max(cm.time_constant, 4 * time_step)


def _fmt(*xs: float) -> str:
    """Numbers for MJCF, to 10 significant digits (`stepping/fields.py` rounds its closed forms alike).

    Kept at 10 digits: with every bit (repr) the seed's hub offset -0.074 reads -0.07400000000000001,
    and that alone moved the warp engine against MuJoCo C on a rigid step climb from within 0.2% to
    0.65% in drive work (tests/test_course.py): the step's contacts amplify the last bits."""
    return " ".join(f"{x:.10g}" for x in xs)


def ground_geom(name: str, shape: str, v: Vehicle, friction: float, time_step: float) -> str:
    """One static geom of the ground, MJCF: `shape` gives its type, size and pose attributes.

    Every ground geom has priority 1, the scenario's `friction` and the contact model's solimp and
    solref, so a wheel meets the same contact on each of them (the plane, a step's box, a bump)."""
    cm = v.contact_model
    condim = 1 if v.tyre.model == "slip" else 3  # the slip tyre gives the tangential forces
    return (
        f'<geom name="{name}" {shape} priority="1" condim="{condim}" friction="{friction:.10g} 0 0" '
        f'solimp="{cm.impedance:.10g} {cm.impedance:.10g} 0.001 0.5 2" '
        f'solref="{contact_time_constant(cm, time_step):.10g} 1" contype="2" conaffinity="1" material="grid"/>'
    )


def mjcf(
    v: Vehicle,
    *,
    time_step: float = 0.005,
    friction: float = 0.7,
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81),
    ground: tuple[str, str] | None = None,
) -> str:
    """MJCF text of the vehicle on the ground.

    `ground`: (assets, worldbody geoms) of the ground, MJCF (batchveh.model.course builds them from
    `ground_geom`); None: the flat plane. The ground geoms have priority 1, so the contact
    friction is the ground's `friction` whatever the wheels carry (MuJoCo otherwise takes the
    larger). With `v.contacts == "ground"`, wheels collide with the ground and nothing else.
    """
    c, w, h, p, mo = v.chassis, v.wheel, v.hub, v.payload, v.motors
    hinge_x, hinge_y = v.hinge  # the front-left steering hinge (the chassis corner unless set)
    # rolling resistance: the drive joints' friction loss on the rigid contact; the slip tyre has its own
    c_rr = w.rolling_resistance if v.tyre.model == "rigid" else 0.0
    rolling = rolling_resistance_torque(c_rr, w.radius, v.total_mass, abs(gravity[2]))
    # contype/conaffinity bits: wheels are 1, the ground 2; a wheel meets the ground
    # (1 & 1) but not another wheel (1 & 2 = 0) unless v.contacts is "all".
    wheel_type, wheel_aff = 1, (2 if v.contacts == "ground" else 3)
    hub_type, hub_aff = (0, 0) if v.contacts == "ground" else (1, 3)
    if v.tyre.model == "soil":  # the soil carries the wheels: they never meet the ground's geoms (bits 1, 2)
        wheel_type, wheel_aff = (0, 0) if v.contacts == "ground" else (4, 5)

    def wheel_geoms(name: str) -> str:
        cyl = f'type="cylinder" size="{_fmt(w.radius, w.width / 2)}" zaxis="0 1 0" mass="{_fmt(w.mass)}"'
        if w.collision == "cylinder":
            return (
                f'<geom name="wheel_{name}" {cyl} contype="{wheel_type}" conaffinity="{wheel_aff}" '
                'friction="1 0 0" rgba=".1 .1 .1 1"/>'
            )
        return (
            f'<geom name="wheel_{name}_body" {cyl} contype="0" conaffinity="0" rgba=".1 .1 .1 1"/>'
            f'<geom name="wheel_{name}" type="sphere" size="{_fmt(w.radius)}" mass="0" contype="{wheel_type}" '
            f'conaffinity="{wheel_aff}" friction="1 0 0" rgba="0 0 0 0"/>'
        )

    # the rotor's inertia reflected at each joint: the servo's `armature`, or each dcmotor's J N^2
    steer_armature = drive_armature = (mo.armature,) * 4
    if mo.model == "dcmotor":
        inertia = [reflected_inertia(x) for x in v.dc_motors()]
        drive_armature, steer_armature = inertia[:4], inertia[4:]
    bodies = []
    for i, name in enumerate(CORNERS):
        sx, sy = CORNER_SIGNS[name]
        axis = np.array([sx * hinge_x, sy * hinge_y])  # steering axis, world x, y
        hub_local = np.array([sx * w.x_cg, sy * h.y_cg]) - axis
        wheel_local = np.array([sx * w.x_cg, sy * w.y_cg]) - axis
        bodies.append(f"""
      <body name="hub_{name}" pos="{_fmt(axis[0] - c.x_cg, axis[1] - c.y_cg, w.radius - c.z_cg)}">
        <joint name="steer_{name}" type="hinge" axis="0 0 1" armature="{_fmt(steer_armature[i])}"/>
        <geom name="hub_{name}" type="cylinder" size="{_fmt(h.radius, h.length / 2)}"
              pos="{_fmt(hub_local[0], hub_local[1], 0)}" zaxis="0 1 0" mass="{_fmt(h.mass)}"
              contype="{hub_type}" conaffinity="{hub_aff}" rgba=".55 .55 .6 1"/>
        <body name="wheel_{name}" pos="{_fmt(wheel_local[0], wheel_local[1], 0)}">
          <joint name="drive_{name}" type="hinge" axis="0 1 0" armature="{_fmt(drive_armature[i])}"
                 frictionloss="{_fmt(rolling)}"/>
          {wheel_geoms(name)}
        </body>
      </body>""")
    servo = CORNERS if mo.model == "servo" else ()  # model dcmotor: _dcmotors' actuators instead
    act = [] if servo else _dcmotors(v)
    for name in servo:
        act.append(
            f'<general name="drive_{name}_v" joint="drive_{name}" gainprm="{mo.drive_kv:.10g}" '
            f'biastype="affine" biasprm="0 0 {-mo.drive_kv:.10g}"/>'
        )
    for name in servo:
        act.append(
            f'<general name="steer_{name}_p" joint="steer_{name}" gainprm="{mo.steer_kp:.10g}" '
            f'biastype="affine" biasprm="0 {-mo.steer_kp:.10g} 0"/>'
        )
    for name in servo:
        act.append(
            f'<general name="drive_{name}_p" joint="drive_{name}" dyntype="integrator" '
            f'gainprm="{mo.drive_kp:.10g}" biastype="affine" biasprm="0 {-mo.drive_kp:.10g} 0"/>'
        )
    for name in servo:
        act.append(
            f'<general name="steer_{name}_v" joint="steer_{name}" gainprm="{mo.steer_kv:.10g}" '
            f'biastype="affine" biasprm="0 0 {-mo.steer_kv:.10g}"/>'
        )
    # the slip tyre reads each wheel's contact force from cfrc_ext, which every engine computes
    # (mj_rnePostConstraint) when a sensor needs it: one accelerometer on the chassis
    accelerometer = '<accelerometer name="chassis_acc" site="chassis_centre"/>'
    sensors = f"\n  <sensor>{accelerometer}</sensor>" if v.tyre.model == "slip" else ""
    # frictionless contacts have no cone; MJX supports condim 1 only with the pyramidal one
    cone = v.contact_model.cone if v.tyre.model == "rigid" else "pyramidal"
    ground_assets, ground_xml = ground or ("", ground_geom(GROUND, 'type="plane" size="0 0 1"', v, friction, time_step))
    return f"""<mujoco model="batchveh">
  <option timestep="{time_step:.10g}" integrator="implicitfast" gravity="{_fmt(*gravity)}"
          cone="{cone}" impratio="{v.contact_model.impratio:.10g}"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  <asset>
    <texture name="sky" type="skybox" builtin="gradient" rgb1=".5 .7 .9" rgb2=".9 .9 .95" width="64" height="64"/>
    <texture name="grid" type="2d" builtin="checker" rgb1=".62 .66 .6" rgb2=".5 .54 .48" width="64" height="64"/>
    <material name="grid" texture="grid" texrepeat="1 1" texuniform="true"/>{ground_assets}
  </asset>
  <worldbody>
    <light pos="0 0 6" dir="0 0 -1" directional="true"/>
    {ground_xml}
    <body name="chassis" pos="{_fmt(c.x_cg, c.y_cg, c.z_cg)}">
      <freejoint name="chassis"/>
      <site name="chassis_centre" size="0.01"/>
      <geom name="chassis" type="box" size="{_fmt(c.length / 2, c.width / 2, c.height / 2)}"
            mass="{_fmt(c.mass)}" contype="0" conaffinity="0" rgba=".8 .8 .8 1"/>
{"".join(bodies)}
      <body name="payload" pos="{_fmt(p.x, p.y, p.z)}">
        <geom name="payload" type="sphere" size="{_fmt(PAYLOAD_RADIUS)}" mass="{_fmt(p.mass)}"
              contype="0" conaffinity="0" rgba=".9 .3 .2 1"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    {chr(10).join("    " + a for a in act).strip()}
  </actuator>{sensors}
</mujoco>
"""


def _dcmotors(v: Vehicle) -> list[str]:
    """MJCF of the 8 motors as dcmotors, in MOTORS order, each with its terminal voltage as ctrl (the drive's,
    batchveh/model/drive.py)."""
    return [dcmotor_xml(name, name, m, rotor=False) for name, m in zip(MOTORS, v.dc_motors(), strict=True)]


def build_model(v: Vehicle, **kw: Any) -> mujoco.MjModel:
    """Compile the vehicle into an MjModel; keyword arguments go to `mjcf`.

    A vehicle MuJoCo refuses (a mass or size it cannot represent) is one ConfigError line."""
    try:
        return mujoco.MjModel.from_xml_string(mjcf(v, **kw))
    except ValueError as err:
        msg = " ".join(str(err).split())
        raise ConfigError(f"vehicle: MuJoCo cannot compile it ({msg}); allowed: physically sized parts") from None


@dataclass(frozen=True)
class Layout:
    """Indices into MuJoCo arrays, shared by every model of one vehicle structure."""

    motor_dof: np.ndarray  # (8,) dof of each motor joint, in MOTORS order
    motor_qpos: np.ndarray  # (8,) qpos address of each motor joint
    drive_vel_act: np.ndarray  # (4,) actuator ids, velocity part of the drives (servo; empty for dcmotor)
    drive_pos_act: np.ndarray  # (4,) integrator (position) part of the drives
    steer_pos_act: np.ndarray
    steer_vel_act: np.ndarray
    motor_act: np.ndarray  # (8,) each motor's dcmotor actuator, MOTORS order (model dcmotor; empty for servo)
    ground_geom: int
    wheel_geoms: np.ndarray
    chassis_body: int
    hub_bodies: np.ndarray  # (4,) in CORNERS order
    wheel_bodies: np.ndarray
    # the wheel-ground model the model was built for: 'rigid' (MuJoCo's contact), 'slip' (frictionless
    # contacts: batchveh.model.tyres gives the tangential forces) or 'soil' (no wheel-ground contacts:
    # batchveh.model.soil gives every force)
    wheel_ground: str

    @property
    def dcmotor(self) -> bool:
        """Whether the motors are dcmotors (ctrl: each motor's terminal voltage, from batchveh's drive)."""
        return self.motor_act.size > 0

    @property
    def applied(self) -> bool:
        """Whether the wheels' ground forces are applied by batchveh (slip tyre, soil) each step."""
        return self.wheel_ground != "rigid"


def layout(m: mujoco.MjModel) -> Layout:
    """Look up the indices batchveh reads and writes, by name."""
    jid = [m.joint(n).id for n in MOTORS]

    names = {m.actuator(i).name for i in range(m.nactuator)}
    dc = "drive_lf" in names

    def acts(kind: str, part: str) -> np.ndarray:
        return np.array([], int) if dc else np.array([m.actuator(f"{kind}_{c}_{part}").id for c in CORNERS])

    return Layout(
        motor_dof=np.array([m.jnt_dofadr[j] for j in jid]),
        motor_qpos=np.array([m.jnt_qposadr[j] for j in jid]),
        drive_vel_act=acts("drive", "v"),
        drive_pos_act=acts("drive", "p"),
        steer_pos_act=acts("steer", "p"),
        steer_vel_act=acts("steer", "v"),
        motor_act=np.array([m.actuator(n).id for n in MOTORS]) if dc else np.array([], int),
        ground_geom=m.geom(GROUND).id,
        wheel_geoms=np.array([m.geom(f"wheel_{c}").id for c in CORNERS]),
        chassis_body=m.body("chassis").id,
        hub_bodies=np.array([m.body(f"hub_{c}").id for c in CORNERS]),
        wheel_bodies=np.array([m.body(f"wheel_{c}").id for c in CORNERS]),
        wheel_ground=_wheel_ground(m),
    )


def _wheel_ground(m: mujoco.MjModel) -> str:
    """The wheel-ground model of a built model: 'soil' where the wheels cannot meet the ground's
    geoms, 'slip' where the ground is frictionless, else 'rigid'."""
    ground, wheel = m.geom(GROUND).id, m.geom(f"wheel_{CORNERS[0]}").id
    meets = (m.geom_contype[wheel] & m.geom_conaffinity[ground]) or (m.geom_contype[ground] & m.geom_conaffinity[wheel])
    if not meets:
        return "soil"
    return "slip" if m.geom_condim[ground] == 1 else "rigid"
