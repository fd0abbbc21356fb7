"""Does MuJoCo's dcmotor heat its thermal state with the current before or after `saturation`?

Standalone (numpy + mujoco only); run it with any python that has mujoco installed:

    python validation/dcmotor_heat.py

Rig: one hinge, body inertia 0.01 kg m^2, integrator implicitfast, dt 5 ms. The joint is blocked
kinematically by an armature of 1e10 kg m^2 (so omega stays ~1e-10 rad/s under 0.15 N m). One
dcmotor, input="voltage", R 1.2 ohm, K 0.05 N m/A, saturation current 3 A (forcerange +-0.15 N m),
thermal = "RT C timeconst alpha T0 Ta" = "5 10 0 0.0039 25 25". A constant 24 V is applied for 4 s:
the unclipped stall current is 20 A, the clipped one 3 A, so the two hypotheses differ ~40x in
heating power.

The thermal act state (rise over ambient T) is compared with the one-node model integrated with
explicit Euler at the same dt:  C dT/dt = i^2 R(T) - T/RT,  R(T) = R (1 + alpha (T + Ta - T0)),
with (a) i = (V - K omega)/R(T) (unclipped) and (b) i = clip((V - K omega)/R(T), +-Imax) (clipped).

Writes validation/results/dcmotor_heat-<mujoco version>.json. It also prints the compiled gainprm
of a dcmotor with input="pos vel" controller="1 0 2 0 0 24" (layout check).
"""

import json
import os

import mujoco
import numpy as np

R0 = 1.2  # winding resistance at T0, ohm
KM = 0.05  # motor constant, N m/A
IMAX = 3.0  # saturation current, A
RT = 5.0  # thermal resistance, K/W
CT = 10.0  # thermal capacitance, J/K
ALPHA = 0.0039  # temperature coefficient, 1/K
T0 = 25.0  # reference temperature, C
TA = 25.0  # ambient temperature, C
VOLT = 24.0  # applied voltage, V
DT = 0.005
T_END = 4.0
ARMATURE = 1e10  # blocks the joint

RIG = """
<mujoco model="dcmotor_heat">
  <option timestep="{dt}" integrator="implicitfast"/>
  <worldbody>
    <body name="rotor">
      <joint name="hinge" type="hinge" axis="0 0 1" armature="{arm}"/>
      <inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
    </body>
  </worldbody>
  <actuator>
    {act}
  </actuator>
</mujoco>
"""

MOTOR = (
    f'<dcmotor name="m" joint="hinge" resistance="{R0}" motorconst="{KM}" saturation="0 {IMAX} 0" '
    f'thermal="{RT} {CT} 0 {ALPHA} {T0} {TA}" input="voltage"/>'
)
PIDMOTOR = (
    f'<dcmotor name="m" joint="hinge" resistance="{R0}" motorconst="{KM}" input="pos vel" controller="1 0 2 0 0 24"/>'
)


def r_of(T):
    return R0 * (1 + ALPHA * (T + TA - T0))


def one_node(clipped, nstep):
    """Explicit Euler of C dT/dt = i^2 R(T) - T/RT at omega = 0; returns T after each step."""
    T = 0.0
    out = np.empty(nstep)
    for k in range(nstep):
        R = r_of(T)
        i = VOLT / R
        if clipped:
            i = np.clip(i, -IMAX, IMAX)
        T = T + DT * (i * i * R - T / RT) / CT
        out[k] = T
    return out


def simulate():
    m = mujoco.MjModel.from_xml_string(RIG.format(dt=DT, arm=ARMATURE, act=MOTOR))
    d = mujoco.MjData(m)
    assert m.na == 1, f"expected one act state (temperature), got na={m.na}"
    layout = {
        "gainprm[:4] (R, K, alpha, T0)": m.actuator_gainprm[0, :4].tolist(),
        "dynprm[:5] (te, dimax, RT, C, Ta)": m.actuator_dynprm[0, :5].tolist(),
        "forcerange": m.actuator_forcerange[0].tolist(),
    }
    assert np.allclose(m.actuator_dynprm[0, 2:5], [RT, CT, TA]), layout
    assert np.allclose(m.actuator_gainprm[0, :4], [R0, KM, ALPHA, T0]), layout
    nstep = int(round(T_END / DT))
    rec = {
        k: np.empty(nstep)
        for k in ("t", "T", "force", "i_unclipped", "i_clipped", "omega", "actdot", "actdot_a", "actdot_b")
    }
    d.ctrl[0] = VOLT
    for k in range(nstep):
        # quantities at the start of the step (what act_dot is computed from)
        mujoco.mj_forward(m, d)
        T = d.act[0]
        w = d.actuator_velocity[0]
        R = r_of(T)
        iu = (VOLT - KM * w) / R
        ic = d.actuator_force[0] / KM
        rec["i_unclipped"][k] = iu
        rec["i_clipped"][k] = ic
        rec["force"][k] = d.actuator_force[0]
        rec["omega"][k] = w
        rec["actdot"][k] = d.act_dot[0]
        rec["actdot_a"][k] = (iu * iu * R - T / RT) / CT
        rec["actdot_b"][k] = (ic * ic * R - T / RT) / CT
        mujoco.mj_step(m, d)
        rec["t"][k] = d.time
        rec["T"][k] = d.act[0]
    return m, rec, layout


def pid_layout():
    m = mujoco.MjModel.from_xml_string(RIG.format(dt=DT, arm=0, act=PIDMOTOR))
    return {
        "xml": PIDMOTOR,
        "nu": int(m.nu),
        "na": int(m.na),
        "gainprm": m.actuator_gainprm[0].tolist(),
        "biasprm": m.actuator_biasprm[0].tolist(),
        "dynprm": m.actuator_dynprm[0].tolist(),
    }


def main():
    np.set_printoptions(precision=5, suppress=True, linewidth=160)
    m, rec, layout = simulate()
    nstep = len(rec["t"])
    pa = one_node(False, nstep)
    pb = one_node(True, nstep)

    print(
        f"mujoco {mujoco.__version__}; joint blocked by armature {ARMATURE:g}; "
        f"max |omega| {np.abs(rec['omega']).max():.2e} rad/s"
    )
    print(f"compiled: {layout}")
    print(
        f"{'t s':>5} {'force Nm':>9} {'i_unclip A':>10} {'i_clip A':>9} "
        f"{'T_mj K':>10} {'T_unclip K':>10} {'T_clip K':>10}"
    )
    for tq in (0.005, 0.5, 1.0, 2.0, 3.0, 4.0):
        k = int(round(tq / DT)) - 1
        print(
            f"{rec['t'][k]:5.3f} {rec['force'][k]:9.4f} {rec['i_unclipped'][k]:10.4f} "
            f"{rec['i_clipped'][k]:9.4f} {rec['T'][k]:10.5f} {pa[k]:10.5f} {pb[k]:10.5f}"
        )

    T_end = float(rec["T"][-1])
    err_a = abs(T_end - pa[-1]) / abs(pa[-1])
    err_b = abs(T_end - pb[-1]) / abs(pb[-1])
    # per-step act_dot check, independent of accumulated trajectory
    ad_a = float(np.max(np.abs(rec["actdot"] - rec["actdot_a"]) / np.abs(rec["actdot_a"])))
    ad_b = float(np.max(np.abs(rec["actdot"] - rec["actdot_b"]) / np.abs(rec["actdot_b"])))
    match = "unclipped" if err_a < err_b else "clipped"
    print(
        f"after {T_END} s: T_mj {T_end:.6f} K, unclipped {pa[-1]:.6f} K (rel err {err_a:.2e}), "
        f"clipped {pb[-1]:.6f} K (rel err {err_b:.2e}) -> matches {match}"
    )
    print(f"per-step act_dot max rel err: vs unclipped {ad_a:.2e}, vs clipped {ad_b:.2e}")

    pid = pid_layout()
    print(f"pos-vel controller dcmotor: nu {pid['nu']} na {pid['na']}")
    print(f"  gainprm {np.array(pid['gainprm'])}")

    out = {
        "mujoco_version": mujoco.__version__,
        "rig": {
            "inertia": 0.01,
            "armature": ARMATURE,
            "integrator": "implicitfast",
            "timestep": DT,
            "actuator": MOTOR,
            "voltage": VOLT,
            "duration": T_END,
            "max_abs_omega": float(np.abs(rec["omega"]).max()),
        },
        "compiled": layout,
        "force_after_4s": float(rec["force"][-1]),
        "i_unclipped_after_4s": float(rec["i_unclipped"][-1]),
        "i_clipped_after_4s": float(rec["i_clipped"][-1]),
        "T_rise_mujoco_after_4s": T_end,
        "T_rise_pred_unclipped": float(pa[-1]),
        "T_rise_pred_clipped": float(pb[-1]),
        "rel_err_unclipped": float(err_a),
        "rel_err_clipped": float(err_b),
        "actdot_max_rel_err_unclipped": ad_a,
        "actdot_max_rel_err_clipped": ad_b,
        "matches": match,
        "pid_controller_layout": pid,
    }
    here = os.path.dirname(os.path.abspath(__file__))
    path = os.path.join(here, "results", f"dcmotor_heat-{mujoco.__version__}.json")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        json.dump(out, f, indent=2)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
