"""The ground the vehicle drives on: a flat plane, or an obstacle across its path.

The scenario's flat fields shape it (lengths in m):

- `obstacle`: `none` (the plane), `step`, `bump`, `pothole` or `terrain`;
- `obstacle_x`: from the front wheels' contact points at the start (x = wheel.x_cg) to the
  obstacle's near edge, along +X;
- `step`: a box of `step_height` from the near edge on for COURSE_LENGTH, a curb onto a plateau,
  its top edge rounded off by EDGE_RADIUS (a capsule along it);
- `bump`: a circular segment of `bump_height` over a chord of `bump_length` (a cylinder across
  the path whose axis lies below the ground), at most a half-cylinder;
- `pothole`: a ditch of `pothole_depth` and `pothole_width`: the plane sinks to -depth and two
  boxes with their tops at z = 0, their edges at the gap rounded off, carry the vehicle on either
  side of the gap;
- `terrain`: a height field of random bumps from the near edge on for TERRAIN_LENGTH:
  `terrain_amplitude` from its lowest to its highest point, `terrain_wavelength` the mean distance
  between neighbouring crests along a line, `terrain_seed` the random field.

Every ground geom gets the ground plane's contact (`vehicle.ground_geom`: priority 1, the
scenario's friction, the contact model's solimp and solref). The shape fields are structure:
a sweep compiles the model once per distinct combination (`params.structural`), so every
variant's geoms and heights are MuJoCo's own. `flag` marks a run that did not get over its
obstacle: status `stuck`, from the variant's own final position and obstacle.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Protocol

import mujoco
import numpy as np

from batchveh.config import ConfigError, did_you_mean
from batchveh.model.vehicle import GROUND, ground_geom

if TYPE_CHECKING:
    from batchveh.model.vehicle import Vehicle

OBSTACLES = ("none", "step", "bump", "pothole", "terrain")
# the scenarios that drive along +X across an obstacle (a mission's turns are its user's choice: the
# `reached` and `cleared` flags read x and ignore yaw)
KINDS = ("straight_line", "manual", "towing", "custom", "mission")
# the scenario fields each obstacle reads (obstacle_x: all but none); they are structure
SHAPE_FIELDS = {
    "step": ("step_height",),
    "bump": ("bump_height", "bump_length"),
    "pothole": ("pothole_depth", "pothole_width"),
    "terrain": ("terrain_amplitude", "terrain_wavelength", "terrain_seed"),
}
FIELDS = ("obstacle_x", *(k for names in SHAPE_FIELDS.values() for k in names))
PREFIX = "course_"  # the name of every ground geom but the plane
COURSE_LENGTH = 20.0  # m along X: a step's plateau, each side of a pothole
COURSE_WIDTH = 4.0  # m along Y, centred on the path
# The top edges of a step and of a pothole are rounded off: MuJoCo C's cylinder-box collision puts the
# normal of a wheel pressed on a box's edge along the box face's normal (1 0 0 where the edge-to-axis
# direction is 0.67 0 -0.74: the wheel met a curb as a wall); on a capsule along the edge the normal is
# the edge-to-axis direction on every engine (validation/OBSTACLES.md)
EDGE_RADIUS = 0.01  # m, at most half the box's height
# m: a front wheel this close to touching a step's riser has reached it (a wheel the step holds back is
# `stuck`, not `short`); the contact's own sinkage is a few mm
TOUCH = 0.01
TERRAIN_LENGTH = 3.0  # m along X
TERRAIN_WIDTH = 1.6  # m along Y: both wheel tracks of the seed's vehicle (+-0.445 m) with room to drift
TERRAIN_MARGIN = 0.2  # m: a wheel's outer edge stays this far inside the height field's side
TERRAIN_CELL = 0.05  # m between height samples
TERRAIN_BASE = 0.1  # m, the height field's solid base below its zero
# the height field sits this far below the plane, so that a wheel on the plane (sunk 1.5 mm into the
# soft contact) does not touch its flat parts as well: heights count from z = -2 mm
TERRAIN_SINK = 0.002  # m
# geom-type pairs MJX's JAX implementation has no collision function for (its collision_driver table;
# tests/test_course.py checks this against it). MuJoCo C and MuJoCo Warp collide every pair made here.
JAX_CANNOT_COLLIDE = {("cylinder", "box"), ("cylinder", "hfield")}
_TYPE = {int(t): name.removeprefix("mjGEOM_").lower() for name, t in mujoco.mjtGeom.__members__.items()}


class Ground(Protocol):
    """The scenario fields the ground is built from (`scenarios.Scenario` has them): scenarios import
    this module, so it names what it reads instead of importing the Scenario."""

    obstacle: str
    obstacle_x: float  # m
    friction: float
    time_step: float  # s
    step_height: float  # m
    bump_height: float  # m
    bump_length: float  # m
    pothole_depth: float  # m
    pothole_width: float  # m
    terrain_amplitude: float  # m
    terrain_wavelength: float  # m
    terrain_seed: float


def check_obstacle(kind: Any, where: str) -> None:
    """One ConfigError line unless `kind` is a known obstacle."""
    if kind not in OBSTACLES:
        raise ConfigError(
            f"{where}.obstacle: {kind!r} is not allowed{did_you_mean(kind, OBSTACLES)}; allowed: {', '.join(OBSTACLES)}"
        )


def step_reach(p: Mapping[str, Any]) -> Any:
    """How far ahead of its contact point a wheel of radius r meets a step of height h, m: sqrt(2 r h - h^2)
    (h taken at most r)."""
    r = np.asarray(p["wheel.radius"], float)
    h = np.minimum(p["step_height"], r)
    return np.sqrt(2 * r * h - h * h)


def rules(p: Mapping[str, Any], obstacle: str) -> list[tuple[str, Any, Any, str]]:
    """(key, value, bound, rule) for each rule of the obstacle; rule '<' or '<=': the value must stay
    below the bound, '>=': at or above it. A step must be lower than the wheel radius (the wheel meets
    its edge below the wheel centre, so the edge can lift it); a bump is at most a half-cylinder
    (height <= length / 2); and no wheel may touch the obstacle at the start: a wheel reaches
    sqrt(2 r h - h^2) ahead of its contact point at height h."""
    r = np.asarray(p["wheel.radius"], float)
    if obstacle == "step":
        return [("step_height", p["step_height"], r, "<"), ("obstacle_x", p["obstacle_x"], step_reach(p), ">=")]
    if obstacle == "bump":
        h, half = np.asarray(p["bump_height"], float), np.asarray(p["bump_length"], float) / 2
        radius = (h * h + half * half) / (2 * h)  # the bump's circle; its centre is radius - h below ground
        reach = np.sqrt(np.maximum((r + radius) ** 2 - (r + radius - h) ** 2, 0.0)) - half
        return [("bump_height", h, half, "<="), ("obstacle_x", p["obstacle_x"], np.maximum(reach, 0.0), ">=")]
    if obstacle == "pothole":
        return [("pothole_width", p["pothole_width"], COURSE_LENGTH, "<=")]
    if obstacle == "terrain":  # bumps below the wheel centre, and both wheel tracks on the height field
        inside = TERRAIN_WIDTH / 2 - TERRAIN_MARGIN - np.asarray(p["wheel.width"], float) / 2
        return [("terrain_amplitude", p["terrain_amplitude"], r, "<"), ("wheel.y_cg", p["wheel.y_cg"], inside, "<=")]
    return []


_BOUND_NAME = {
    "step_height": "wheel.radius",
    "bump_height": "bump_length / 2",
    "obstacle_x": "the wheel's reach",
    "pothole_width": "the course's length",
    "terrain_amplitude": "wheel.radius",
    "wheel.y_cg": f"the terrain's half-width less {TERRAIN_MARGIN:g} m and half the wheel's width",
}


def check(p: Mapping[str, Any], obstacle: str, where: str) -> None:
    """Refuse, in one ConfigError line, parameter values (scalars or arrays) that break one of the
    obstacle's `rules`; the first offending value is named with its bound."""
    for key, value, bound, rule in rules(p, obstacle):
        value, bound = np.broadcast_arrays(np.asarray(value, float), np.asarray(bound, float))
        ok = {"<": value < bound, "<=": value <= bound * (1 + 1e-12), ">=": value >= bound * (1 - 1e-12)}[rule]
        bad = np.flatnonzero(~ok)
        if bad.size:
            i = bad[0]
            raise ConfigError(
                f"{where}: {key}: {value.flat[i]:.6g} m is not allowed with {_BOUND_NAME[key]} "
                f"{bound.flat[i]:.6g} m; allowed: {key} {rule} {_BOUND_NAME[key]}"
            )


def check_sweep(p: Mapping[str, Any], swept: Mapping[str, Any], obstacle: str, ranges: bool, where: str) -> None:
    """Before any work: the rules for the base values `p` and for every combination of the smallest
    and largest swept values (each rule is monotonic in each value: the extremes hold the worst case;
    the range ends of random and LHS with `ranges` True). A swept shape field that the obstacle does
    not read is refused too."""
    used = (*SHAPE_FIELDS.get(obstacle, ()), *(("obstacle_x",) if obstacle != "none" else ()))
    for key in swept:
        if key in FIELDS and key not in used:
            readers = [k for k, names in SHAPE_FIELDS.items() if key in names] or list(OBSTACLES[1:])
            raise ConfigError(
                f"{where}: sweep.params.{key}: the scenario's obstacle is {obstacle!r}, which does not read {key}; "
                f"allowed: obstacle: {' or '.join(readers)} in the scenario, or leave {key} out"
            )
    check(p, obstacle, where)
    keys = [k for k in swept if k in (*FIELDS, "wheel.radius", "wheel.y_cg", "wheel.width")]
    if not keys:
        return
    ends = [np.asarray(swept[k][:2] if ranges else swept[k], float) for k in keys]
    grid = np.meshgrid(*[(e.min(), e.max()) for e in ends], indexing="ij")
    check({**p, **{k: g.ravel() for k, g in zip(keys, grid, strict=True)}}, obstacle, f"{where}: sweep.params")


def near_edge(p: Mapping[str, Any]) -> Any:
    """World x of the obstacle's near edge, m: the front wheels' contact (wheel.x_cg) plus obstacle_x."""
    return p["wheel.x_cg"] + p["obstacle_x"]


def far_edge(p: Mapping[str, Any], obstacle: str) -> Any:
    """World x of the obstacle's far edge, m: past it the ground is level again (a step's riser is
    its near and far edge)."""
    extent = {
        "step": 0.0,
        "bump": p["bump_length"],
        "pothole": p["pothole_width"],
        "terrain": TERRAIN_LENGTH,
    }[obstacle]
    return near_edge(p) + extent


def ground(v: Vehicle, sc: Ground) -> tuple[str, str]:
    """(assets, worldbody MJCF) of the scenario's ground, for `vehicle.mjcf`.

    With an obstacle every ground geom sits in a mocap body at the origin: MuJoCo Warp places the
    world body's geoms once, from the model it makes its data from, so per-variant positions and
    sizes of world geoms never reached its collisions (a step sweep on warp ran every variant on the
    base model's box); a mocap body's geoms it places every step, from each world's own fields."""
    assets, geoms = _ground(v, sc)
    return assets, geoms if sc.obstacle == "none" else f'<body name="course" mocap="true">{geoms}</body>'


def _ground(v: Vehicle, sc: Ground) -> tuple[str, str]:
    geom = lambda name, shape: ground_geom(name, shape, v, sc.friction, sc.time_step)  # noqa: E731
    plane = 'type="plane" size="0 0 1"'
    if sc.obstacle == "none":
        return "", geom(GROUND, plane)
    x0 = v.wheel.x_cg + sc.obstacle_x
    half_w = COURSE_WIDTH / 2

    def box(name: str, x_lo: float, x_hi: float, z_lo: float, z_hi: float, rounded: tuple[str, ...]) -> str:
        """A box across the path, its top edges at `rounded` ('lo', 'hi' along X) rounded off by
        edge_radius: a box below the rounding, a box between the roundings and a capsule at each."""
        rho = min(EDGE_RADIUS, (z_hi - z_lo) / 2)
        # the top box starts one radius behind the capsule's axis: a corner on the capsule's top line met a
        # wheel sunk into the soft contact, and its contacts (face normal, horizontal, or the corner's) flipped
        # from step to step (validation/OBSTACLES.md). The notch left behind the capsule, rho wide and deep,
        # sags a 0.195 m wheel by 64 um
        top_lo, top_hi = x_lo + 2 * rho * ("lo" in rounded), x_hi - 2 * rho * ("hi" in rounded)
        edge_lo, edge_hi = x_lo + rho, x_hi - rho
        out = ""
        for part, (a, b, c, d) in (("", (x_lo, x_hi, z_lo, z_hi - rho)), ("_top", (top_lo, top_hi, z_hi - rho, z_hi))):
            size, pos = _fmt((b - a) / 2, half_w, (d - c) / 2), _fmt((a + b) / 2, 0, (c + d) / 2)
            out += geom(f"{PREFIX}{name}{part}", f'type="box" size="{size}" pos="{pos}"')
        for side, x in (("lo", edge_lo), ("hi", edge_hi)):
            if side in rounded:
                shape = f'type="capsule" size="{_fmt(rho, half_w)}" zaxis="0 1 0" pos="{_fmt(x, 0, z_hi - rho)}"'
                out += geom(f"{PREFIX}{name}_edge_{side}", shape)
        return out

    if sc.obstacle == "step":
        return "", geom(GROUND, plane) + box("step", x0, x0 + COURSE_LENGTH, 0.0, sc.step_height, ("lo",))
    if sc.obstacle == "bump":
        h, half_l = sc.bump_height, sc.bump_length / 2
        radius = (h * h + half_l * half_l) / (2 * h)  # the circle through both ends of the chord and the top
        shape = f'type="cylinder" size="{_fmt(radius, half_w)}" zaxis="0 1 0" pos="{_fmt(x0 + half_l, 0, h - radius)}"'
        return "", geom(GROUND, plane) + geom(PREFIX + "bump", shape)
    if sc.obstacle == "pothole":
        d, x1 = sc.pothole_depth, x0 + sc.pothole_width
        sunk = f'type="plane" size="0 0 1" pos="0 0 {-d:.10g}"'
        return "", (
            geom(GROUND, sunk)
            + box("before", x0 - COURSE_LENGTH, x0, -d, 0.0, ("hi",))
            + box("after", x1, x1 + COURSE_LENGTH, -d, 0.0, ("lo",))
        )
    nrow, ncol = terrain_shape()
    asset = (
        f'<hfield name="terrain" nrow="{nrow}" ncol="{ncol}" '
        f'size="{_fmt(TERRAIN_LENGTH / 2, TERRAIN_WIDTH / 2, 1.0, TERRAIN_BASE)}"/>'
    )
    shape = f'type="hfield" hfield="terrain" pos="{_fmt(x0 + TERRAIN_LENGTH / 2, 0, -TERRAIN_SINK)}"'
    return asset, geom(GROUND, plane) + geom(PREFIX + "terrain", shape)


def write_heights(m: mujoco.MjModel, sc: Ground) -> None:
    """Write the terrain's heights into a compiled model's hfield_data (m: the hfield's top is 1 m)."""
    if sc.obstacle == "terrain":
        m.hfield_data[:] = terrain_heights(sc.terrain_amplitude, sc.terrain_wavelength, sc.terrain_seed).ravel()


def terrain_shape() -> tuple[int, int]:
    """(rows along Y, columns along X) of the terrain's height samples."""
    return round(TERRAIN_WIDTH / TERRAIN_CELL) + 1, round(TERRAIN_LENGTH / TERRAIN_CELL) + 1


def terrain_heights(amplitude: float, wavelength: float, seed: float) -> np.ndarray:
    """Heights in m, (rows along Y, columns along X): Gaussian-filtered white noise, scaled to span
    0..`amplitude`, faded in and out over one wavelength at both ends along X.

    The filter exp(-(k sigma)^2 / 2) gives a Gaussian spectrum whose crests lie 2 pi sigma sqrt(2/3)
    apart on average along a line (Rice's formula): sigma follows from `wavelength`. The random field
    comes from the seed's float64 bits, so any number is a seed and equal numbers give equal fields."""
    nrow, ncol = terrain_shape()
    bits = int(np.float64(seed).view(np.uint64))
    noise = np.random.default_rng([bits]).standard_normal((nrow, ncol))
    sigma = wavelength / (2 * np.pi * np.sqrt(2 / 3))
    ky = 2 * np.pi * np.fft.fftfreq(nrow, TERRAIN_CELL)[:, None]
    kx = 2 * np.pi * np.fft.fftfreq(ncol, TERRAIN_CELL)[None, :]
    field = np.fft.ifft2(np.fft.fft2(noise) * np.exp(-((kx**2 + ky**2) * sigma**2) / 2)).real
    span = field.max() - field.min()
    field = (field - field.min()) / (span if span > 0 else 1.0)
    x = np.arange(ncol) * TERRAIN_CELL
    fade = np.clip(np.minimum(x, x[-1] - x) / wavelength, 0.0, 1.0)
    fade = fade * fade * (3 - 2 * fade)  # smooth at both ends
    return amplitude * field * fade[None, :]


def ground_geoms(m: mujoco.MjModel) -> np.ndarray:
    """Ids of the ground's geoms: the plane and every course geom (they carry the scenario's friction)."""
    return np.array([i for i in range(m.ngeom) if m.geom(i).name == GROUND or m.geom(i).name.startswith(PREFIX)])


def check_backend(m: mujoco.MjModel, backend: str, swept: Any = ()) -> None:
    """Refuse, before any work, a course the backend cannot run: a wheel-ground pair MJX's JAX
    implementation cannot collide (backend 'mjx'), or terrain heights swept on 'warp' (MuJoCo Warp
    keeps one height field per model). One ConfigError line naming the engine and the pair."""
    if backend == "mjx":
        wheels = [i for i in range(m.ngeom) if m.geom(i).name.startswith("wheel_") and m.geom_contype[i]]
        for g in ground_geoms(m):
            for w in wheels:
                pair = (_TYPE[int(m.geom_type[w])], _TYPE[int(m.geom_type[g])])
                if pair in JAX_CANNOT_COLLIDE:
                    raise ConfigError(
                        f"backend mjx: MJX's JAX implementation cannot collide a {pair[0]} wheel with a {pair[1]} "
                        f"({m.geom(g).name.removeprefix(PREFIX)}); allowed: vehicle.wheel.collision: sphere, or the "
                        "mujoco or warp backend"
                    )
    terrain = [k for k in SHAPE_FIELDS["terrain"] if k in swept]
    if backend == "warp" and terrain:
        raise ConfigError(
            f"backend warp: MuJoCo Warp keeps one height field per model (hfield_data), so {', '.join(terrain)} "
            "cannot vary per variant; allowed: fixed terrain values (one sweep per terrain), or the mujoco or mjx "
            "backend"
        )


def flag(cols: dict[str, Any], p: Mapping[str, Any], obstacle: str) -> dict[str, Any]:
    """The columns with `reached` and `cleared` added, and the status of an ok run that did not get
    over its obstacle: `stuck` (code 3) where the front wheels reached the near edge, `short` (code 4)
    where they never did (total_time too short for the distance, or a run that stood or turned away):
    its statistics say nothing about the obstacle.

    Reached: the front wheels' centres ended past the near edge, or, at a step, within TOUCH of
    touching its riser (a wheel of radius r held by a step of height h stops sqrt(2 r h - h^2) short
    of it); cleared: the rear wheels' centres ended past the far edge; from the variant's own
    wheel.x_cg, chassis.x_cg and obstacle (the chassis starts at x = chassis.x_cg, the wheels at
    +-wheel.x_cg; yaw is ignored: the obstacle lies across +X). Give total_time long enough to cross it."""
    if obstacle == "none":
        return cols
    travel = np.asarray(cols["final_x"]) - np.asarray(p["chassis.x_cg"])
    reach = step_reach(p) + TOUCH if obstacle == "step" else 0.0
    reached = np.asarray(p["wheel.x_cg"]) + travel + reach > near_edge(p)
    cleared = -np.asarray(p["wheel.x_cg"]) + travel > far_edge(p, obstacle)
    out = dict(cols)
    out["reached"], out["cleared"] = reached, cleared
    ok = np.asarray(cols["status_code"]) == 0
    out["status_code"] = np.where(ok & ~cleared, np.where(reached, 3, 4), cols["status_code"])
    return out


def _fmt(*xs: float) -> str:
    return " ".join(f"{x:.10g}" for x in xs)
