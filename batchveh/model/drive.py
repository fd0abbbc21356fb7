"""The motor drive of `motors.model: dcmotor`: the electronics between the scenario and each motor.

MuJoCo's `dcmotor` models the motor (its torque K i, its back-EMF, its current limit), with the terminal
voltage as its input (`input="voltage"`, no MuJoCo controller and no MuJoCo thermal state). This module is
the drive that sets that voltage each step, as a servo drive does: one pure function (`step`) over numpy or
jax.numpy, the same for every engine.

Per motor, at its joint (the wheel's spin, the hub's steering angle), per step of dt:

- the loop: tau* = kp e + kv (w_ref - w) + ki s + J dw_ref/dt, where for a drive e = s is the integral of
  its speed error (its angle error, a speed PI), and for a steering motor e = alpha_ref - alpha is the
  measured angle error and s its integral (a PID on the angle); the last term feeds the reference's own
  acceleration forward through the inertia J the loop was tuned for (the loaded wheel's, the hub's);
- the current loop, taken as ideal: the current asked is i* = tau* / (N K), clipped at the current limit;
  the terminal voltage that drives it, v = R(T) i* + K N w, is clamped at the bus voltage, and the current
  the motor then carries is (v - K N w) / R(T), clipped again (an overrunning load at the line);
- anti-windup: s holds where the current or the voltage is at its limit and its rate pushes further into
  it (conditional integration), so a motor held at a limit does not wind up and overshoot afterwards (what
  remains after a current-limited start is the loop's own response to the speed it lost: 1.8% on the
  seed's flat start with the 4.7 N m motor);
- the winding: one thermal node heated by the current the motor carries, C dT/dt = i^2 R(T) - (T - T_amb)
  / R_T, R(T) = R (1 + alpha (T - 25)); that same T sets the resistance of the next step. MuJoCo's own
  thermal state (3.17, 4.0) heats with the current before `saturation` clips it, so it is not used.

MuJoCo's motor keeps R at 25 deg C; the drive passes it the voltage that gives the carried current there:
u = K N w + R_25 i. At the current limit it asks a little more (PUSH), so that MuJoCo's saturation clips the
torque to K i_max exactly and `implicitfast` takes the torque as independent of speed, as it is at a held
current. Elsewhere MuJoCo integrates the back-EMF's damping N^2 K^2 / R_25 implicitly (exact at the voltage
line; a part of the speed loop's damping otherwise).

The gains (`gains`) come from each variant: the inertia at the joint (MuJoCo's dof_M0: the wheel's or hub's
own and the rotor's J N^2), the vehicle's mass at the wheel's radius for a drive, the back-EMF's damping and
the time step. The loop's explicit damping is at most KV_SHARE of (I_joint / dt + N^2 K^2 / R): a free wheel
(no ground) then loses at most that share of its speed error per step and never flips sign step to step.
Drives: kv = min(bandwidth x I_load, that bound), kp = kv^2 / (4 I_load) (critical damping on the loaded
wheel). Steering: a triple pole at w on the hub against the tyre's moment, kv = 3 I w, kp = 3 I w^2 + k_tyre,
ki = I w^3, with kv within the bound; k_tyre is the steering stiffness the tyre takes away where its contact
leads the steering axis (`tyre_moment_stiffness`: a contact a distance a ahead of the axis puts the lateral force
C_s N delta at a, turning the wheel further, -a C_s N per rad; docs/motors.md, "The steering loop"). Without it a
steering motor whose kp the time step caps (98.7 N m/rad on sweeps/sidewalk_robot.yaml's 1.9 N m motor) let the
rear wheels (contact 0.05 m ahead of the axis: -133 to -177 N m/rad at their static loads) steer off. kp stays
within KP_SHARE of the step's own bound, 4 I / dt^2 less the damping's share (semi-implicit Euler on I, kp, kv).
Each gain set by the user (`motors.dc_drive_kp`, ...) replaces the derived one.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from batchveh.model.motors import COPPER_TEMPCOEF, REFERENCE_TEMP

KV_SHARE = 0.5  # the speed loop's explicit damping: this share of the largest that dt allows on the free joint
KV_STEER_CAP = 1.9  # the steering's kv at most this many I / dt: kp_max = KP_SHARE (4 - 2 kv dt / I) I / dt^2 > 0
KP_SHARE = 0.5  # the steering's kp: at most this share of the largest that dt allows, (4 - 2 kv dt / I) I / dt^2
LOAD_FACTOR = 2.0  # the steering's tyre stiffness is taken at this many times a wheel's static load (N = m g / 4):
# load transfer on a climb, a stop and a bump; an overestimate only stiffens the loop (see `gains`)
PUSH = 1e-3  # at the current limit, the voltage asks this much more current, so that MuJoCo's saturation clips
# the drive's numbers per motor (..., 8) in params: `_dc.<name>` (batch.make_batch)
CONSTANTS = ("K", "R", "V", "force_max", "T_amb", "R_T", "C", "eta", "N", "kp", "kv", "ki", "ff")


def damping(c: Mapping[str, Any], xp=np) -> Any:
    """The back-EMF's damping at each joint, N^2 K^2 / R (N m s/rad), R the simulated motor's at 25 deg C."""
    return (c["N"] * c["K"]) ** 2 / c["R"]


def tyre_moment_stiffness(slip_stiffness: Any, wheel_load: Any, lead: Any) -> np.ndarray:
    """The steering stiffness (N m/rad, >= 0) the tyre's lateral force takes away from each steering hinge.

    A wheel steered by delta off its path slips laterally by delta; the tyre pushes back with C_s N delta at
    the contact. Where the contact lies a distance a along the path ahead of the steering axis, that force's
    moment about the axis, a C_s N delta, turns the wheel further: a negative stiffness a C_s N. Behind the axis
    (a caster) it holds the wheel instead. The vehicle may drive either way, so |a| counts on every wheel.
    slip_stiffness: C_s (per unit load, 1/rad); wheel_load: N (N); lead: a (m), each broadcast together."""
    return np.abs(np.asarray(lead, float)) * np.asarray(slip_stiffness, float) * np.asarray(wheel_load, float)


def gains(
    c: Mapping[str, np.ndarray],
    inertia: np.ndarray,
    load: np.ndarray,
    dt: float,
    bandwidth: tuple[Any, Any],
    given: Mapping[str, tuple[Any, Any]],
    tyre: Any = 0.0,
) -> dict[str, np.ndarray]:
    """kp, kv, ki (..., 8) at each joint (N m/rad, N m s/rad, N m/(rad s)), and ff, the inertia the loop
    feeds the reference's acceleration through (kg m^2).

    c: the motors' constants (..., 8) (K, R, N); inertia (..., 8): each motor joint's own (dof_M0: the
    wheel's spin or the hub's steering inertia with the rotor's J N^2); load (..., 4): the inertia each drive
    moves with the vehicle on its wheels (the joint's and the vehicle's mass / 4 x r^2); dt: the time step;
    bandwidth: (drive, steer) in rad/s, each (...,), 0: the largest the bound allows; given: 'kp', 'kv', 'ki'
    -> (drive, steer) gains the user set, each (...,), 0: derived; tyre (..., 4): the stiffness the tyre takes
    from each steering hinge (`tyre_moment_stiffness`, N m/rad), added to the steering's kp.

    The steering's loop on the hub, I s^2 alpha = tau + k alpha (k the tyre's negative stiffness), with tau =
    kp e + kv de/dt + ki int e: its characteristic I s^3 + kv s^2 + (kp - k) s + ki = I (s + w)^3 for kp = 3 I w^2
    + k. Taking k above the true one (a lighter wheel, a caster) leaves I s^3 + kv s^2 + (3 I w^2 + d) s + ki,
    stable for any d >= 0 (Routh: kv (3 I w^2 + d) > I ki); below it by d, stable only for d < 8/3 I w^2, which is
    why k is taken high (LOAD_FACTOR)."""
    inertia = np.asarray(inertia, float)
    kv_max = KV_SHARE * (inertia / dt + damping(c))
    i_d, i_s = np.asarray(load, float), inertia[..., 4:]
    bw_d, bw_s = (np.asarray(b, float)[..., None] for b in bandwidth)
    kv_d = np.where(bw_d > 0, np.minimum(bw_d * i_d, kv_max[..., :4]), kv_max[..., :4])
    kv_s = np.where(bw_s > 0, np.minimum(3 * bw_s * i_s, kv_max[..., 4:]), kv_max[..., 4:])
    # where the back-EMF's damping dwarfs the hub's inertia over dt (a mechanical time constant below about dt / 3),
    # kv_max alone would leave kp_max below 0 (the hub then spins away): kv stays below KV_STEER_CAP I / dt
    kv_s = np.minimum(kv_s, KV_STEER_CAP * i_s / dt)
    w_s = kv_s / (3 * i_s)
    kp_max = KP_SHARE * (4 - 2 * kv_s * dt / i_s) * i_s / dt**2
    kp_s = np.minimum(3 * i_s * w_s**2 + np.asarray(tyre, float), kp_max)
    derived = {
        "kv": np.concatenate([kv_d, kv_s], axis=-1),
        "kp": np.concatenate([kv_d**2 / (4 * i_d), kp_s], axis=-1),
        "ki": np.concatenate([np.zeros_like(kv_d), i_s * w_s**3], axis=-1),
    }
    out = {"ff": np.concatenate([i_d, i_s], axis=-1)}
    for k, value in derived.items():
        user_d, user_s = (np.asarray(g, float)[..., None] for g in given.get(k, (0.0, 0.0)))
        user = np.concatenate(np.broadcast_arrays(user_d * np.ones(4), user_s * np.ones(4)), axis=-1)
        out[k] = np.where(user > 0, user, value)
    return out


def init(c: Mapping[str, Any], start_rise: tuple[Any, Any], xp=np, dtype=None) -> dict[str, Any]:
    """The drive's state at t = 0: the loops' integrals at 0 and each winding at its ambient plus its start
    rise (`motors.drive_start_rise`, `motors.steer_start_rise`; none without a thermal model)."""
    t_amb = xp.asarray(c["T_amb"], dtype)
    rise = xp.concatenate(
        [xp.broadcast_to(xp.asarray(r, dtype)[..., None], (*xp.shape(r), 4)) for r in start_rise], axis=-1
    )
    temp = t_amb + xp.where(xp.asarray(c["C"]) > 0, rise, 0.0)
    return {"s": xp.zeros_like(temp), "T": temp, "w_ref": xp.zeros_like(temp)}


def step(state: Mapping[str, Any], servo_ctrl, q_steer, qvel, c: Mapping[str, Any], dt, xp=np):
    """One step of the drive: (u, the next state, the step's record).

    state: `init`'s (s, T) (..., 8); servo_ctrl (..., 16): the scenario's controls (the servo's: the drives'
    speeds, the steering angles, the drives' speeds again, the steering rates, at the joint); q_steer (..., 4):
    the steering angles; qvel (..., 8): the 8 motor joints' speeds, MOTORS order; c: the drive's numbers
    (..., 8), CONSTANTS. u (..., 8): MuJoCo's dcmotor voltages. The record: T, the winding temperature this
    step ran with (deg C), v, the terminal voltage (V), and `held`, whether the loop was at a limit."""
    s, temp = state["s"], state["T"]
    w_ref = xp.concatenate([servo_ctrl[..., 0:4], servo_ctrl[..., 12:16]], axis=-1)
    derr = w_ref - qvel
    e = xp.concatenate([s[..., :4], servo_ctrl[..., 4:8] - q_steer], axis=-1)
    accel = (w_ref - state["w_ref"]) / dt  # the reference's own acceleration: the inertia's feedforward
    tau = c["kp"] * e + c["kv"] * derr + c["ki"] * s + c["ff"] * accel
    nk = c["N"] * c["K"]
    i_lim = xp.where(c["force_max"] > 0, c["force_max"] / c["K"], xp.inf)
    asked = tau / nk
    at_current = xp.abs(asked) >= i_lim
    i_ask = xp.clip(asked, -i_lim, i_lim)
    r_t = c["R"] * (1 + COPPER_TEMPCOEF * (temp - REFERENCE_TEMP))
    emf = nk * qvel
    wanted = r_t * i_ask + emf
    at_voltage = xp.abs(wanted) > c["V"]
    volt = xp.clip(wanted, -c["V"], c["V"])
    line = (volt - emf) / r_t  # the current the clamped voltage drives
    current = xp.where(at_voltage, xp.clip(line, -i_lim, i_lim), i_ask)
    at_i = xp.where(at_voltage, xp.abs(line) >= i_lim, at_current)
    held = at_current | at_voltage
    rate = xp.concatenate([derr[..., :4], e[..., 4:]], axis=-1)
    # anti-windup: the integral holds while a limit holds the motor and its error pushes further into it
    s_next = s + dt * xp.where(held & (rate * tau > 0), 0.0, rate)
    # the winding: real current i / eta and resistance R eta, so i^2 R(T) / eta in the simulated motor's terms
    heat = current * current * r_t / c["eta"]
    thermal = c["C"] > 0
    cap = xp.where(thermal, c["C"], 1.0)
    r_th = xp.where(c["R_T"] > 0, c["R_T"], xp.inf)
    temp_next = xp.where(thermal, temp + dt * (heat - (temp - c["T_amb"]) / r_th) / cap, temp)
    u = emf + c["R"] * current * xp.where(at_i, 1 + PUSH, 1.0)
    return u, {"s": s_next, "T": temp_next, "w_ref": w_ref}, {"T": temp, "v": volt, "held": held}


def constants(params: Mapping[str, Any], xp=np, dtype=None) -> dict[str, Any]:
    """The drive's numbers from params (`_dc.<name>`, (..., 8) each)."""
    return {k: xp.asarray(params[f"_dc.{k}"], dtype) for k in CONSTANTS}
