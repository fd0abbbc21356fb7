"""The wheel-ground models: how the ground pushes on each wheel (validation/TYRES.md).

- `rigid`: MuJoCo's frictional contact (`vehicle.ContactModel`): friction is a soft constraint
  that the solver keeps to Coulomb's cone. The per-wheel split of the drive torque is then set
  by the contact's softness, not by the vehicle's loads (four wheels locked to one angular speed
  sink by different depths, roll on different radii and fight).
- `slip`: a slip tyre. MuJoCo's contact stays for geometry and the normal force, frictionless
  (condim 1), so steps, bumps and height fields collide as before. The tangential forces come
  from this module, on every engine, as an applied wrench on each wheel body (`xfrc_applied`).

The slip tyre, per wheel (Pacejka, Tire and Vehicle Dynamics, 3rd ed. 2012, sections 3.2 and
7.2; Rill's TMeasy for the bristle at standstill):

- Contact: N and the normal n are the net MuJoCo contact force on the wheel (`cfrc_ext` less the
  applied wrench), a step behind. Every normal of a rigid round wheel passes through its axle,
  so the contact point is taken on the nominal rim, p = c - r n_w (n_w: n in the wheel's plane):
  the rolling radius is the wheel's radius, not the contact's penetration.
- Slip: the rim point's velocity at p in the contact frame (e_x along the heading, e_y lateral),
  v_s; the forward speed of the centre V = v_c . e_x.
- State: a deflection u (m, x and y) with a relaxation length L (Pacejka's single contact point
  transient model), du/dt = -v_s - |V| u / L. Steady rolling gives u / L = -v_s / |V| =
  (kappa, tan alpha), the practical slip; at standstill u is a bristle spring (no creep, no 0/0).
  The update is implicit in u (unconditionally stable for any |V| dt / L).
- Force: the isotropic brush model with a parabolic pressure (Pacejka eq. 3.48-3.50 in the
  theta form): F = mu N (1 - (1 - theta)^3) along u, theta = C_s |u / L| / (3 mu), saturating
  at mu N from theta = 1 (|s| = 3 mu / C_s); past that the bristle slides (u is held on the
  limit). C_s is the slip stiffness per unit load, so at small slip F = C_s N s: each wheel's
  force is its load times one common slip. A bristle damper d du/dt acts in transients only
  (zero in any steady state). |F| <= mu N.
- Spin: a torsional bristle phi (rad), dphi/dt = -omega_n - |V| phi / L, moment c_phi phi up to
  mu N rho sqrt(1 - (|F| / mu N)^2): rho is the mean distance of a uniformly loaded rectangular
  patch (patch_length x wheel width) from its centre, so a wheel steered in place scrubs like
  Coulomb friction, and a patch already sliding has no friction left for spin.
- Rolling resistance: a moment C_rr N r against the wheel's rolling, from the same N, through a
  Dahl-type state q in [-1, 1] that reaches full resistance within ROLL_ENGAGE of rolling.

All functions take arrays of any leading shape (a variant, a chunk) and `xp` (numpy or
jax.numpy): the same code serves MuJoCo C (between batched steps) and MJX / MuJoCo Warp (inside
the scan).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from batchveh.config import field
from batchveh.model.indexing import place, take

MODELS = ("rigid", "slip", "soil")
# state per wheel: u_x, u_y (m), phi (rad), q (rolling-resistance engagement, -1..1)
NSTATE = 4
# bristle damping as a share of critical damping of the rim mass on the tyre's linear stiffness
# C_s N / L (transients only: zero in every steady state)
DAMPING_RATIO = 0.5
# the most the explicit tyre spring may have of omega dt (validation/TYRES.md, the dt study)
STABLE_OMEGA_DT = 0.8
# rolling over this distance at the rim engages the full rolling resistance, m
ROLL_ENGAGE = 1e-3
# below this normal force a wheel is off the ground, N
N_MIN = 1e-6
# the derived parameter holding each variant's drive-joint armature, kg m^2 (stepping.batch.drive_armature):
# the rim mass of this tyre's and the soil's stability floor reads it
DRIVE_ARMATURE = "_drive_armature"
# the derived parameter holding each variant's steering inertia over its contact's lever about the steering
# axis, squared (kg: stepping.batch.steer_mass): the rim mass is the lighter of it and the wheel's spin mass
STEER_MASS = "_steer_mass"


def rim_mass(p: Mapping[str, Any], col) -> Any:
    """The lightest mass the tyre force meets at the contact, (..., 1): the wheel's spin inertia with the drive
    joint's armature (the servo's, or a dcmotor's rotor J N^2) over r^2, or, where lighter, the steering hinge's
    inertia over the contact's lever about its axis squared (the tyre's force turns the hub through that lever: a
    heavy geared rotor makes the first large while the second stays the hub's). A towing wheel has no servo to
    hold it. `col` shapes a parameter as the caller's other inputs."""
    spin = col(p["wheel.mass"]) / 2 + col(p[DRIVE_ARMATURE]) / col(p["wheel.radius"]) ** 2
    if STEER_MASS not in p:
        return spin
    steer = col(p[STEER_MASS])
    return spin * (spin <= steer) + steer * (spin > steer)


@dataclass(frozen=True)
class Tyre:
    """How the ground pushes on the wheels: `rigid` (MuJoCo's frictional contact), `slip`
    (a slip tyre on MuJoCo's frictionless contact; batchveh/model/tyres.py, validation/TYRES.md) or
    `soil` (a rigid wheel in soft soil, `vehicle.soil`; batchveh/model/soil.py, validation/SOIL.md).

    The slip tyre's friction is the scenario's `friction`, and its rolling resistance is
    `wheel.rolling_resistance`, both acting on each wheel's own normal force."""

    model: Literal["rigid", "slip", "soil"] = "slip"
    slip_stiffness: float = field(
        18.0, unit="1", gt=0, le=1e3, doc="longitudinal and lateral slip stiffness per unit normal load, C_s"
    )
    relaxation_length: float = field(
        0.05, unit="m", gt=0, doc="relaxation length of the slip state, L (the slip tyre's and the soil's)"
    )
    patch_length: float = field(0.02, unit="m", ge=0, doc="contact patch length (its width is the wheel's)")


SWEPT = ("tyre.slip_stiffness", "tyre.relaxation_length", "tyre.patch_length")


def brush(theta, xp=np):
    """The brush model's force / (mu N) at theta = C_s |s| / (3 mu): 1 - (1 - theta)^3, 1 from 1."""
    t = xp.minimum(theta, 1.0)
    return 1.0 - (1.0 - t) ** 3


def steady_force(slip, mu, c_s, xp=np):
    """Closed form of the steady force / (mu N) at a practical slip magnitude |(kappa, tan alpha)|."""
    return brush(c_s * xp.abs(slip) / (3.0 * mu), xp)


def mean_patch_radius(half_length, half_width, xp=np):
    """Mean distance from its centre of a uniform rectangle 2a x 2w (a, w >= 0), m."""
    a = xp.maximum(half_length, 1e-9)
    w = xp.maximum(half_width, 1e-9)
    d = xp.sqrt(a * a + w * w)
    return (2 * a * w * d + a**3 * xp.log((w + d) / a) + w**3 * xp.log((a + d) / w)) / (6 * a * w)


def params(p: Mapping[str, Any], xp=np) -> dict[str, Any]:
    """The tyre's per-variant inputs from the flat parameters, each (..., 1) to broadcast over the
    four wheels."""

    def col(x):
        return xp.asarray(x)[..., None]

    half_patch, half_width = col(p["tyre.patch_length"]) / 2, col(p["wheel.width"]) / 2
    return {
        "mu": col(p["friction"]),
        "radius": col(p["wheel.radius"]),
        # the patch's polar radius of gyration squared, and its mean distance from the centre
        "polar": (half_patch**2 + half_width**2) / 3.0,
        "rho": mean_patch_radius(half_patch, half_width, xp),
        "c_s": col(p["tyre.slip_stiffness"]),
        "length": col(p["tyre.relaxation_length"]),
        "c_rr": col(p["wheel.rolling_resistance"]),
        "rim_mass": rim_mass(p, col),
    }


def dot(a, b):
    """The dot product over the last axis."""
    return (a * b).sum(-1)


def unit(v, xp, eps=1e-12):
    """v over its length (last axis)."""
    return v / xp.maximum(xp.sqrt(dot(v, v)), eps)[..., None]


def kinematics(xpos, xmat, qvel, lay, xp=np) -> dict[str, Any]:
    """Each wheel's centre c, axle a, centre velocity v and angular velocity w (world, (..., 4, 3)),
    and its spin rate relative to the hub (..., 4).

    xpos (..., nbody, 3) and xmat (..., nbody, 3, 3) of the last forward pass; qvel (..., nv) now.
    The chassis is the free joint's body: qvel[0:3] its origin's world velocity, qvel[3:6] its
    angular velocity in its own frame (MuJoCo's convention)."""
    x0 = xpos[..., lay.chassis_body, :]
    r0 = xmat[..., lay.chassis_body, :, :]
    v0 = qvel[..., 0:3]
    w0 = (r0 * qvel[..., None, 3:6]).sum(-1)  # R @ omega_local
    c = take(xpos, lay.wheel_bodies, -2)
    hub = take(xpos, lay.hub_bodies, -2)
    z_hub = take(xmat, lay.hub_bodies, -3)[..., 2]
    axle = take(xmat, lay.wheel_bodies, -3)[..., 1]
    steer = take(qvel, lay.motor_dof[4:])[..., None]
    spin = take(qvel, lay.motor_dof[:4])
    v = v0[..., None, :] + xp.cross(w0[..., None, :], c - x0[..., None, :]) + steer * xp.cross(z_hub, c - hub)
    w = w0[..., None, :] + steer * z_hub + spin[..., None] * axle
    return {"c": c, "axle": axle, "v": v, "w": w, "spin": spin}


def contact_force(cfrc_ext, xfrc_applied, lay):
    """The net contact force on each wheel, (..., 4, 3) world: cfrc_ext's force less the applied one."""
    return take(cfrc_ext, lay.wheel_bodies, -2)[..., 3:6] - take(xfrc_applied, lay.wheel_bodies, -2)[..., 0:3]


def init_state(shape: tuple[int, ...], xp=np, dtype=None):
    """The tyre state of `shape` variants at rest, (*shape, 4, NSTATE)."""
    return xp.zeros((*shape, 4, NSTATE), dtype=dtype or xp.float64)


def step(state, kin: Mapping[str, Any], f_contact, tp: Mapping[str, Any], dt, xp=np):
    """Advance the tyre state one step and give the wrench on each wheel body.

    state (..., 4, NSTATE); kin from `kinematics`; f_contact (..., 4, 3) from `contact_force`;
    tp from `params`. Returns (new state, wrench (..., 4, 6): world force and torque at the wheel
    centre, as MuJoCo's xfrc_applied takes them, and a dict of diagnostics: normal force N,
    longitudinal and lateral force, spin moment)."""
    n_force = xp.sqrt(dot(f_contact, f_contact))
    touching = n_force > N_MIN
    n_hat = unit(f_contact, xp)
    axle = kin["axle"]
    e_x = unit(xp.cross(axle, n_hat), xp)
    e_y = xp.cross(n_hat, e_x)
    n_wheel = unit(n_hat - dot(n_hat, axle)[..., None] * axle, xp)
    lever = -tp["radius"][..., None] * n_wheel  # centre -> contact point on the rim
    v_rim = kin["v"] + xp.cross(kin["w"], lever)
    slip_v = xp.stack([dot(v_rim, e_x), dot(v_rim, e_y)], axis=-1)
    speed = xp.abs(dot(kin["v"], e_x))
    spin_n = dot(kin["w"], n_hat)

    mu, c_s = tp["mu"], tp["c_s"]
    mu_n = mu * n_force
    # the tyre force is explicit in the bodies' velocities: its stiffness C_s N / L on the rim mass
    # m must keep sqrt(k / m) dt <= STABLE_OMEGA_DT, so L is at least C_s N dt^2 / (m STABLE^2).
    # Steady forces do not depend on L (only transients do); validation/TYRES.md, the dt study
    length = xp.maximum(tp["length"], c_s * n_force * dt**2 / (tp["rim_mass"] * STABLE_OMEGA_DT**2))
    relax = 1.0 + dt * speed / length
    u_old, phi_old, q_old = state[..., 0:2], state[..., 2], state[..., 3]
    u = (u_old - dt * slip_v) / relax[..., None]
    # the brush law along u; past theta = 1 the bristle slides on its limit
    u_sat = 3.0 * mu * length / c_s
    u_mag = xp.sqrt(dot(u, u))
    over = xp.maximum(u_mag / u_sat, 1.0)
    u = u / over[..., None]
    u_mag = u_mag / over
    theta = u_mag / u_sat
    k_lin = c_s * n_force / length  # linear stiffness, N/m
    damping = DAMPING_RATIO * 2.0 * xp.sqrt(k_lin * tp["rim_mass"])
    f = (mu_n * brush(theta, xp) / xp.maximum(u_mag, 1e-12))[..., None] * u
    f = f + damping[..., None] * (u - u_old) / dt
    f_mag = xp.sqrt(dot(f, f))
    f = f * (xp.minimum(1.0, mu_n / xp.maximum(f_mag, 1e-12)))[..., None]
    f_mag = xp.minimum(f_mag, mu_n)

    # spin: a torsional bristle with what friction the translation leaves
    polar, rho = tp["polar"], tp["rho"]
    left = xp.sqrt(xp.maximum(1.0 - (f_mag / xp.maximum(mu_n, 1e-12)) ** 2, 0.0))
    m_max = mu_n * rho * left
    phi, m_spin = spin_bristle(phi_old, spin_n, relax, k_lin * polar, damping * polar, m_max, dt, xp)

    # rolling resistance: C_rr N r against the rolling, engaged over ROLL_ENGAGE of travel
    r = tp["radius"]
    q = xp.clip(q_old + dt * kin["spin"] * r / ROLL_ENGAGE, -1.0, 1.0)
    m_roll = -tp["c_rr"] * n_force * r * q

    force = f[..., 0:1] * e_x + f[..., 1:2] * e_y
    torque = xp.cross(lever, force) + m_spin[..., None] * n_hat + m_roll[..., None] * axle
    wrench = xp.concatenate([force, torque], axis=-1)
    on = touching[..., None]
    wrench = xp.where(on, wrench, 0.0)
    new = xp.concatenate([u, phi[..., None], q[..., None]], axis=-1)
    new = xp.where(on, new, 0.0)
    info = {"normal": n_force, "fx": f[..., 0], "fy": f[..., 1], "spin_moment": m_spin}
    return new, wrench, info


def spin_bristle(phi_old, spin_n, relax, k_phi, d_phi, m_max, dt, xp=np):
    """The contact patch's torsional bristle: its next angle phi (rad) from the spin rate about
    the normal (relaxed as the slip state, implicit), held where its spring reaches m_max (it
    slides), and the moment on the wheel: k_phi phi + d_phi dphi/dt, within +-m_max."""
    phi = (phi_old - dt * spin_n) / relax
    limit = m_max / xp.maximum(k_phi, 1e-12)
    phi = xp.clip(phi, -limit, limit)
    m_spin = xp.clip(k_phi * phi + d_phi * (phi - phi_old) / dt, -m_max, m_max)
    return phi, m_spin


def wheel_wrench_xfrc(wrench, nbody: int, lay, xp=np):
    """xfrc_applied (..., nbody, 6) holding each wheel's wrench on its body, zero elsewhere."""
    return place(xp.asarray(wrench), lay.wheel_bodies, nbody, -2)
