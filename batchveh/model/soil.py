"""Soft soil: a rigid wheel in deformable ground, the terramechanics wheel-ground model
(`vehicle.tyre.model: soil`, validation/SOIL.md).

The wheels do not touch MuJoCo's ground (their geoms collide with nothing there); the soil
supports them. Per wheel and step, from its sinkage z (the depth of the rim's lowest point below
the soil surface, the plane z = 0) and its slip:

- Contact angles (Wong and Reece, 1967): entry theta_1 = acos(1 - z / r), exit theta_r =
  -c3 theta_1, and the angle of the largest normal stress theta_m = (c1 + c2 s) theta_1.
- Normal stress (Bekker's pressure-sinkage law): sigma = (k_c / b + k_phi) (r (cos theta -
  cos theta_1))^n ahead of theta_m, and behind it the same law at the mirrored angle.
- Shear stress (Janosi and Hanamoto): tau = (c + sigma tan phi) (1 - exp(-j / K)) along the
  shear displacement j = (j_x, j_y): j_x = r [(theta_1 - theta) - (1 - s)(sin theta_1 - sin
  theta)] (Wong and Reece), j_y = r (1 - s)(theta_1 - theta) tan beta (Ishigami et al., 2007:
  the lateral displacement at the slip angle beta).
- Integrated over the contact (Gauss-Legendre on each side of theta_m): the support W = r b
  int(sigma cos + tau_x sin), the drawbar pull DP = r b int(tau_x cos - sigma sin), the
  resisting torque T = r^2 b int(tau_x) and the side force F_y = r b int(tau_y).
- The sinkage is not solved for: the wheel's height is a degree of freedom of the simulation,
  so each wheel sinks until W carries its load (static sinkage), and deeper at higher slip as
  theta_m moves forward (slip sinkage). A damper at half of critical (on a quarter of the
  vehicle's mass and the soil's stiffness dW/dz) stands in for the soil's plastic losses.

The slip: as for the slip tyre (batchveh/model/tyres.py), a relaxed state u with relaxation length L
gives the practical slips kappa = u_x / L (steady: (r omega - V) / |V|) and tan beta = u_y / L,
with no 0/0 at standstill; s = kappa / (1 + kappa). Rolling engages (over SOIL_ENGAGE of travel,
a Dahl-type state q) the two parts of the model that need a rolling wheel: the compaction
resistance (the sigma sin term of DP) and the rolling part of j_x. A wheel at rest in its pit
therefore feels its support and what its slip state holds, not a push from the rut. The
contact patch's spin moment is the slip tyre's torsional bristle with the soil's shear
strength (c A + W tan phi) as its limit.

Left out (validation/SOIL.md): bulldozing at the wheel's front and sides, grousers, multi-pass
(the rear wheels meet fresh soil, not the front wheels' ruts), soil memory (the soil under a
wheel rises back along the loading curve when the wheel lifts), and obstacles or height fields
(refused with soil). All functions take arrays of any leading shape and `xp` (numpy or
jax.numpy), as batchveh/model/tyres.py.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from batchveh.config import ConfigError, field
from batchveh.model import tyres

# Gauss-Legendre points on each side of theta_m: 8 + 8 points are within 0.1% of an adaptive
# quadrature of the same equations (validation/SOIL.md, tests/test_soil.py)
QUADRATURE_POINTS = 8
# travel of the wheel's centre that engages the rolling parts of the model, m
SOIL_ENGAGE = 0.01
# the vertical damper as a share of critical damping
SINK_DAMPING = 0.5
# |slip ratio| above which a variant on soil is flagged as slipping: beyond it the drawbar pull
# of the presets is within a few percent of its largest (validation/SOIL.md)
SLIP_LIMIT = 0.5
# the practical slip kappa is held in [KAPPA_MIN, KAPPA_MAX]: s from -9 (braking) to 0.99
KAPPA_MIN, KAPPA_MAX = -0.9, 99.0

# Published soils. The field units are those of the literature: k_c in kN/m^(n+1), k_phi in
# kN/m^(n+2), c in kPa. validation/SOIL.md gives each source.
PRESETS: dict[str, dict[str, float]] = {
    # Wong, Theory of Ground Vehicles (4th ed. 2008), table 2.3: Land Locomotion Lab. dry sand;
    # K: Wong's typical value for dry sand (1 to 2.5 cm); Wong and Reece (1967): c1, c2
    "dry_sand": {"n": 1.1, "k_c": 0.99, "k_phi": 1528.43, "c": 1.04, "phi": 28.0, "K": 0.025},
    # Wong (2008) table 2.3 "lunar soil" (after Bekker); K from Wong's lunar soil example
    "lunar_soil": {"n": 1.0, "k_c": 1.4, "k_phi": 820.0, "c": 0.17, "phi": 35.0, "K": 0.018},
    # Ishigami, Miwa, Nagatani and Yoshida (2007), J. Field Robotics 24(3), table II: Toyoura
    # sand, a lunar regolith simulant in wheel tests
    "toyoura_sand": {"n": 1.1, "k_c": 0.0, "k_phi": 1528.43, "c": 0.0, "phi": 38.0, "K": 0.011},
}
WONG_REECE = {"c1": 0.43, "c2": 0.32, "c3": 0.0}  # Wong and Reece (1967), used by Ishigami (2007)


@dataclass(frozen=True)
class Soil:
    """The soil under the wheels of `tyre.model: soil` (batchveh/model/soil.py, validation/SOIL.md).

    `preset` names a published soil (PRESETS); any field given beside it overrides it. All
    fields are sweepable as `soil.<name>`."""

    preset: Literal["dry_sand", "lunar_soil", "toyoura_sand"] = "dry_sand"
    n: float = field(1.1, unit="1", gt=0, le=2, doc="Bekker's sinkage exponent n")
    k_c: float = field(0.99, unit="kN/m^(n+1)", ge=0, le=1e4, doc="Bekker's cohesive modulus k_c")
    k_phi: float = field(1528.43, unit="kN/m^(n+2)", gt=0, le=1e6, doc="Bekker's frictional modulus k_phi")
    c: float = field(1.04, unit="kPa", ge=0, le=1e3, doc="cohesion c")
    phi: float = field(28.0, unit="deg", ge=0, le=60, doc="internal friction angle phi")
    K: float = field(0.025, unit="m", gt=0, le=1, doc="shear deformation modulus K (Janosi-Hanamoto)")
    c1: float = field(0.43, unit="1", ge=0, le=1, doc="Wong-Reece c1: theta_m / theta_1 at zero slip")
    c2: float = field(0.32, unit="1", ge=0, le=1, doc="Wong-Reece c2: the slope of theta_m / theta_1 in slip")
    c3: float = field(0.0, unit="1", ge=0, le=1, doc="exit angle / entry angle (0: no rear contact)")

    @staticmethod
    def expand_mapping(data: Mapping[str, Any], where: str) -> dict[str, Any]:
        """The mapping with its preset's values under the fields it does not give."""
        name = data.get("preset", "dry_sand")
        if name not in PRESETS:
            raise ConfigError(f"{where}: preset: {name!r} is not allowed; allowed: {', '.join(PRESETS)}")
        return {**PRESETS[name], **data}


def check_ground(model: str, obstacle: str, where: str) -> None:
    """One ConfigError line for soil under an obstacle or a height field: the soil is the plane's."""
    if model == "soil" and obstacle != "none":
        raise ConfigError(
            f"{where}.obstacle: {obstacle!r} is not allowed with vehicle.tyre.model soil; allowed: none "
            "(the soil model is a flat deformable plane; obstacles and terrain are rigid ground only)"
        )


SWEPT = tuple(f"soil.{k}" for k in ("n", "k_c", "k_phi", "c", "phi", "K", "c1", "c2", "c3"))


def params(p: Mapping[str, Any], xp=np) -> dict[str, Any]:
    """The soil model's per-variant inputs in SI units from the flat parameters, each (..., 1) to
    broadcast over the four wheels."""

    def col(x):
        return xp.asarray(x)[..., None]

    b = col(p["wheel.width"])
    quarter = (col(p["chassis.mass"]) + col(p["payload.mass"])) / 4 + col(p["wheel.mass"]) + col(p["hub.mass"])
    return {
        "n": col(p["soil.n"]),
        "k": (col(p["soil.k_c"]) / b + col(p["soil.k_phi"])) * 1e3,  # Pa / m^n
        "c": col(p["soil.c"]) * 1e3,  # Pa
        "tan_phi": xp.tan(xp.deg2rad(col(p["soil.phi"]))),
        "K": col(p["soil.K"]),
        "c1": col(p["soil.c1"]),
        "c2": col(p["soil.c2"]),
        "c3": col(p["soil.c3"]),
        "radius": col(p["wheel.radius"]),
        "width": b,
        "quarter_mass": quarter,
        "gravity": col(p["gravity"]),
        "length": col(p["tyre.relaxation_length"]),
        "rim_mass": tyres.rim_mass(p, col),
    }


# Gauss-Legendre nodes and weights on [-1, 1], once: the MuJoCo C path calls _nodes every step
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(QUADRATURE_POINTS)


def _nodes(a, b, xp):
    """Gauss-Legendre nodes and weights on [a, b] (arrays (...,)), as (..., Q)."""
    half = ((b - a) / 2)[..., None]  # the nodes in the arrays' precision (JAX keeps float64 constants apart)
    x, w = xp.asarray(_GAUSS_X, dtype=half.dtype), xp.asarray(_GAUSS_W, dtype=half.dtype)
    return a[..., None] + half * (x + 1.0), half * w


def stresses(theta, theta1, theta_r, theta_m, sp: Mapping[str, Any], xp=np):
    """Bekker-Wong-Reece normal stress sigma (Pa) at contact angles theta (..., Q)."""
    r, n = sp["radius"][..., None], sp["n"][..., None]
    t1, tr, tm = theta1[..., None], theta_r[..., None], theta_m[..., None]
    rear = theta < tm
    mirrored = t1 - (theta - tr) / xp.maximum(tm - tr, 1e-9) * (t1 - tm)
    angle = xp.where(rear, mirrored, theta)
    depth = xp.maximum(r * (xp.cos(angle) - xp.cos(t1)), 0.0)
    return sp["k"][..., None] * depth**n


def integrate(z, kappa, tan_beta, engaged, sp: Mapping[str, Any], xp=np) -> dict[str, Any]:
    """The soil's forces on a rigid wheel at sinkage z (m), practical slip kappa (forward, in the
    direction of rolling), lateral practical slip tan_beta, with the rolling parts engaged by
    `engaged` in [0, 1]: support W, drawbar pull DP, resisting torque T, side force F_y, the
    compaction resistance and the contact's entry angle, chord and shear strength (..., each)."""
    r, b = sp["radius"], sp["width"]
    z = xp.clip(z, 0.0, r)
    theta1 = xp.arccos(1.0 - z / r)
    s = kappa / (1.0 + kappa)
    theta_r = -sp["c3"] * theta1
    theta_m = xp.clip(engaged * (sp["c1"] + sp["c2"] * xp.clip(s, -1.0, 1.0)) * theta1, theta_r, theta1)
    front, wf = _nodes(theta_m, theta1, xp)
    back, wb = _nodes(theta_r, theta_m, xp)
    theta = xp.concatenate([back, front], axis=-1)
    w = xp.concatenate([wb, wf], axis=-1)
    sigma = stresses(theta, theta1, theta_r, theta_m, sp, xp)
    t1, rr = theta1[..., None], r[..., None]
    sin_gap = xp.sin(t1) - xp.sin(theta)
    jx = engaged[..., None] * rr * ((t1 - theta) - sin_gap) + rr * sin_gap * s[..., None]
    jy = rr * (t1 - theta) * (1.0 - s)[..., None] * tan_beta[..., None]
    j = xp.sqrt(jx * jx + jy * jy)
    strength = sp["c"][..., None] + sigma * sp["tan_phi"][..., None]
    tau = strength * (1.0 - xp.exp(-j / sp["K"][..., None]))
    jn = xp.maximum(j, 1e-12)
    tau_x, tau_y = tau * jx / jn, tau * jy / jn
    rb = r * b

    def quad(f):
        return (f * w).sum(-1)

    compaction = rb * quad(sigma * xp.sin(theta))
    return {
        "W": rb * quad(sigma * xp.cos(theta) + tau_x * xp.sin(theta)),
        "DP": rb * quad(tau_x * xp.cos(theta)) - engaged * compaction,
        "T": r * rb * quad(tau_x),
        "Fy": rb * quad(tau_y),
        "compaction": compaction,
        "theta1": theta1,
        "chord": r * (xp.sin(theta1) - xp.sin(theta_r)),
        "strength": rb * quad(strength),
    }


def bekker_sinkage(load, sp: Mapping[str, Any], xp=np):
    """Bekker's static sinkage of a rigid wheel (m): z0 = [3 W / ((3 - n) k b sqrt(D))]^(2 / (2n + 1)),
    k = k_c / b + k_phi (Wong, Theory of Ground Vehicles, eq. 2.57)."""
    n, b, d = sp["n"], sp["width"], 2 * sp["radius"]
    return (3.0 * load / ((3.0 - n) * sp["k"] * b * xp.sqrt(d))) ** (2.0 / (2.0 * n + 1.0))


def compaction_resistance(z0, sp: Mapping[str, Any]):
    """Bekker's compaction resistance of a rigid wheel at sinkage z0 (N): k b z0^(n+1) / (n + 1)."""
    n = sp["n"]
    return sp["k"] * sp["width"] * z0 ** (n + 1.0) / (n + 1.0)


def step(state, kin: Mapping[str, Any], sp: Mapping[str, Any], dt, xp=np):
    """Advance the soil state one step and give the wrench on each wheel body.

    state (..., 4, tyres.NSTATE), from `wheels.init_state`; kin from `tyres.kinematics`; sp from
    `params`. Returns (new state, wrench (..., 4, 6), world force and torque at the wheel centre,
    and a dict of diagnostics: sinkage, W, DP, T, F_y, slip ratio s)."""
    c, axle = kin["c"], kin["axle"]
    up = xp.zeros_like(c) + xp.asarray([0.0, 0.0, 1.0], dtype=c.dtype)
    e_x = tyres.unit(xp.cross(axle, up), xp)
    e_y = xp.cross(up, e_x)
    r = sp["radius"]
    # the rim's lowest point below the surface: the wheel's plane may lean (camber)
    axle_z = axle[..., 2]
    z = r * xp.sqrt(xp.maximum(1.0 - axle_z * axle_z, 0.0)) - c[..., 2]
    touching = z > 0.0
    speed = tyres.dot(kin["v"], e_x)
    omega = tyres.dot(kin["w"], axle)
    slip_v = xp.stack([speed - r * omega, tyres.dot(kin["v"], e_y)], axis=-1)

    u_old, phi_old, q_old = state[..., 0:2], state[..., 2], state[..., 3]
    q = xp.clip(q_old + dt * speed / SOIL_ENGAGE, -1.0, 1.0)
    direction = xp.where(q >= 0.0, 1.0, -1.0)
    engaged = xp.abs(q)

    # the slip state; its stiffness bound as the slip tyre's (validation/SOIL.md, the dt study)
    z_now = xp.clip(z, 0.0, r)
    theta1 = xp.arccos(1.0 - z_now / r)
    load_guess = xp.maximum(sp["quarter_mass"] * sp["gravity"], 1e-3)
    area = r * sp["width"] * theta1
    stiff = (sp["c"] * area + load_guess * sp["tan_phi"]) * r * xp.sin(theta1) / sp["K"]
    length = xp.maximum(sp["length"], stiff * dt**2 / (sp["rim_mass"] * tyres.STABLE_OMEGA_DT**2))
    relax = 1.0 + dt * xp.abs(speed) / length
    u = (u_old - dt * slip_v) / relax[..., None]
    u_x = xp.clip(direction * u[..., 0], KAPPA_MIN * length, KAPPA_MAX * length) * direction
    u = xp.stack([u_x, xp.clip(u[..., 1], -length, length)], axis=-1)
    kappa = direction * u[..., 0] / length
    tan_beta = u[..., 1] / length

    out = integrate(z, kappa, tan_beta, engaged, sp, xp)
    # the vertical damper: half of critical on a quarter of the vehicle and dW/dz ~ (n + 1/2) W / z
    k_z = (sp["n"] + 0.5) * xp.maximum(out["W"], 0.0) / xp.maximum(z_now, 1e-6)
    damper = SINK_DAMPING * 2.0 * xp.sqrt(k_z * sp["quarter_mass"])
    support = xp.maximum(out["W"] - damper * kin["v"][..., 2], 0.0)
    # no damper on the slip state: it would push while u drifts at high slip (u is not held on a
    # limit as the slip tyre's is); the servos damp the wheels' spin
    fx = direction * out["DP"]
    fy = out["Fy"]
    k_lin = stiff / length
    bristle = tyres.DAMPING_RATIO * 2.0 * xp.sqrt(k_lin * sp["rim_mass"])
    f_max = out["strength"] + 1e-9
    # the patch's spin: the slip tyre's torsional bristle, limited by what shear strength is left
    half_chord = out["chord"] / 2
    polar = (half_chord**2 + (sp["width"] / 2) ** 2) / 3.0
    rho = tyres.mean_patch_radius(half_chord, sp["width"] / 2, xp)
    left = xp.sqrt(xp.maximum(1.0 - (xp.sqrt(fx * fx + fy * fy) / f_max) ** 2, 0.0))
    phi, m_spin = tyres.spin_bristle(
        phi_old, tyres.dot(kin["w"], up), relax, k_lin * polar, bristle * polar, f_max * rho * left, dt, xp
    )

    force = support[..., None] * up + fx[..., None] * e_x + fy[..., None] * e_y
    lever = -r[..., None] * up  # the lateral force acts at the bottom of the rim
    m_axle = -direction * out["T"]
    torque = xp.cross(lever, fy[..., None] * e_y) + m_axle[..., None] * axle + m_spin[..., None] * up
    wrench = xp.where(touching[..., None], xp.concatenate([force, torque], axis=-1), 0.0)
    new = xp.concatenate([u, phi[..., None], q[..., None]], axis=-1)
    # a wheel in the air keeps its engagement (it rolls on when it lands) and loses its slip
    new = xp.where(touching[..., None], new, xp.concatenate([0.0 * new[..., :3], q[..., None]], axis=-1))
    info = {"sinkage": z, "W": support, "DP": fx, "T": out["T"], "Fy": fy, "s": kappa / (1 + kappa)}
    return new, wrench, info
