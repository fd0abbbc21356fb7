"""Peak convergence study (issue 10, finding 4): do the torque peaks that motor sizing uses
converge in the time step? MuJoCo C 3.17, float64. Run from the repository root:

    python validation/peaks.py            # full study, about 85 s on 2 CPU cores
    python validation/peaks.py --quick    # dt 5, 2.5, 1.25 ms only
    python validation/peaks.py --impratio 100 --out validation/results/peaks_impratio100.json

Prints the tables and writes validation/results/peaks.json. Conclusions: PEAKS.md.

It imports batchveh and changes nothing in it. It steps MuJoCo C itself (the same model,
controls and `stats` reduction as `batchveh.simulate(..., backend="mujoco")`, checked to
rtol 1e-12 at the start) so that it can try, without editing batchveh:
- readout "explicit": the torque batchveh records, qfrc_actuator, evaluated at the
  start-of-step velocity;
- readout "applied": the torque the implicitfast step actually applies,
  qfrc_actuator - kv (qvel_after - qvel_before) on each motor joint (the PD damping
  evaluated at the end-of-step velocity, as the implicit step integrates it). Checked at
  the start against the momentum balance M qacc + bias - passive - constraint;
- settle: the motion laws held at their t = 0 values for `settle` s before they start (the
  vehicle settles onto its contacts and its motors take up the load), the statistics
  window shifted by `settle`, and the settle steps left out of the whole-run statistics
  (`*_all`, power_peak).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

warnings.filterwarnings("ignore", category=UserWarning)

import jax  # noqa: E402
import mujoco  # noqa: E402

import batchveh  # noqa: E402
from batchveh.model.scenarios import control_schedule, make_scenario  # noqa: E402
from batchveh.model.vehicle import CORNERS, Vehicle, layout  # noqa: E402
from batchveh.stepping import stats  # noqa: E402
from batchveh.stepping.batch import make_batch  # noqa: E402
from batchveh.stepping.rollout import float_precision  # noqa: E402

DTS = (0.005, 0.0025, 0.00125, 0.000625)
QUICK_DTS = DTS[:3]
SETTLE = 0.5  # s: the slow servo mode (kv/kp = 0.1 s) decays to 1% in 0.46 s
TOL = 0.02  # the target: at most 2% per halving of dt
DRIVES = tuple(f"drive_{c}" for c in CORNERS)
STEERS = tuple(f"steer_{c}" for c in CORNERS)
# the statistics studied; the motor screen (analysis.demand.demand) sizes on drive rms and drive peak_lp_all
# (max over wheels)
STATS = ("mean", "rms", "p95", "peak", "max", "min", "peak_lp", "peak_all", "peak_lp_all", "power_peak")
SIZING_KEYS = ["drive.rms", "drive.peak_lp_all", "sum.peak_lp_all", "drive.peak_all", "sum.peak_all", "drive.peak"]


def straight(**kw):
    """The finding's case: straight line, 10 deg, mu 0.9, 1 km/h, ramp 1 s, 4 s."""
    return make_scenario(
        "straight_line", **{"slope_deg": 10, "friction": 0.9, "total_time": 4.0, "ramp_time": 1.0, **kw}
    )


CASES = {
    "straight_line": straight,
    "steer_in_place": lambda **kw: make_scenario("steer_in_place", **kw),  # seed scenario 2: 45 deg over 3 s
    "pivot": lambda **kw: make_scenario("pivot", **kw),  # steer 0-2 s, yaw ramp 2-4 s, 8 s
}


# --- rollout ------------------------------------------------------------------------------
def rollout(vehicle: Vehicle, sc, settle: float = 0.0) -> dict[str, np.ndarray]:
    """Step MuJoCo C through `sc`, the laws held at their t = 0 values for the first `settle` s.

    Returns per-step samples (after step i, at t = (i + 1) dt; `time` is t - settle) of
    stats.sample plus: tau_applied (n, 8), pen (deepest contact, m, < 0 in contact) and
    ncon. With settle 0 the controls are those of batchveh.stepping.rollout.mujoco_steps."""
    batch = make_batch(vehicle, sc, {})
    m = batch.model
    lay = layout(m)
    dt = m.opt.timestep
    ns = int(round(settle / dt))
    n = ns + sc.n_steps
    with float_precision("f64"):
        p = {k: np.asarray(float(v[0]), np.float64) for k, v in batch.params.items()}
        sched = jax.jit(control_schedule(sc))
        ctrls = np.asarray(sched(p, np.arange(sc.n_steps) * dt))
        hold = np.array(sched(p, np.zeros(1)))[0]
    hold[12:16] = 0.0  # steering rates: the laws have not started
    ctrls = np.concatenate([np.tile(hold, (ns, 1)), ctrls])
    kv = np.array([p["motors.drive_kv"]] * 4 + [p["motors.steer_kv"]] * 4)
    radius = float(p["wheel.radius"])
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    rows = []
    for i in range(n):
        v0 = d.qvel[lay.motor_dof].copy()
        d.ctrl[:] = ctrls[i]
        mujoco.mj_step(m, d)
        s = stats.sample(d.qpos.copy(), d.qvel.copy(), d.qfrc_actuator.copy(), ctrls[i], radius, lay)
        s["tau_applied"] = s["tau"] - kv * (d.qvel[lay.motor_dof] - v0)
        s["pen"] = np.array(d.contact.dist.min() if d.ncon else 0.0)
        s["ncon"] = np.array(float(d.ncon))
        rows.append(s)
    out = {k: np.stack([r[k] for r in rows]) for k in rows[0]}
    out["time"] = (np.arange(n) + 1) * dt - ns * dt
    out["dt"], out["settle_steps"], out["kv"] = dt, ns, kv
    return out


def statistics(ser: dict, sc, readout: str = "explicit") -> dict[str, float]:
    """batchveh's statistics of a rollout: window = second half of the motion; with a settle,
    the settle steps are folded first and then dropped from the whole-run peaks."""
    dt, ns = ser["dt"], ser["settle_steps"]
    n = len(ser["time"])
    t0 = ns * dt
    cfg = stats.StatsConfig.make(dt, n, (t0 + sc.total_time / 2, min(t0 + sc.total_time, n * dt)))
    keys = ("tau", "omega", "rim", "alpha", "ref", "pos", "quat", "vel")
    block = {k: np.asarray(ser[k], np.float64) for k in keys}
    if readout == "applied":
        block["tau"] = np.asarray(ser["tau_applied"], np.float64)
    acc = stats.init(cfg, ())
    if ns:
        acc = stats.update(acc, {k: v[:ns] for k, v in block.items()}, np.arange(ns), cfg)
        for k in ("peak_all", "lp_peak_all", "power_peak"):
            acc[k] = np.zeros_like(acc[k])
    acc = stats.update(acc, {k: v[ns:] for k, v in block.items()}, np.arange(ns, n), cfg)
    return {k: float(v) for k, v in stats.finalize(acc, cfg).items()}


def grouped(st: dict[str, float]) -> dict[str, float]:
    """Each statistic over a motor group: the worst drive, the worst steering motor, the drive sum."""
    out = {}
    for group, names in (("drive", DRIVES), ("steer", STEERS)):
        for s in STATS:
            if s == "power_peak":
                vals = [st.get(f"drive_{c}_power_peak") for c in CORNERS] if group == "drive" else []
            else:
                vals = [st[f"{m}_{s}"] for m in names]
            if not vals:
                continue
            if s in ("mean", "min"):
                v = min(vals) if s == "min" else max(vals, key=abs)
            else:
                v = max(vals)
            out[f"{group}.{s}"] = v
    for s in STATS:
        if f"drive_sum_{s}" in st:
            out[f"sum.{s}"] = st[f"drive_sum_{s}"]
    return out


# --- convergence --------------------------------------------------------------------------
# variants: readout, settle (s), drive law (None: the scenario's default, ramp)
VARIANTS = {
    "now": ("explicit", 0.0, None),
    "A": ("applied", 0.0, None),
    "A+B": ("applied", SETTLE, None),
    "A+C": ("applied", 0.0, "smooth_step"),
    "B+C": ("explicit", SETTLE, "smooth_step"),
    "A+B+C": ("applied", SETTLE, "smooth_step"),
}
FINE_DTS = (0.005, 0.0025, 0.00125, 0.000625, 0.0003125, 0.00015625, 0.000078125)


def halving_changes(vals: list[float], floor: float) -> list[float]:
    """|f(h/2) - f(h)| / max(|f(h/2)|, floor) for each halving."""
    return [abs(b - a) / max(abs(b), floor) for a, b in zip(vals[:-1], vals[1:], strict=True)]


def richardson(vals: list[float]) -> float:
    """First-order Richardson from the two finest steps (the implicit-damping error is O(dt))."""
    return 2 * vals[-1] - vals[-2] if len(vals) > 1 else vals[-1]


def variant_rows(vehicle, make, dts, variants=VARIANTS, uses_law=True):
    """Grouped statistics per variant and dt (one rollout per settle and law), and rollout wall times."""
    rows = {v: [] for v in variants}
    walls: dict[tuple, float] = {}
    for dt in dts:
        cache = {}
        for name, (readout, settle, law) in variants.items():
            law = law if uses_law else None
            key = (settle, law)
            if key not in cache:
                sc = make(time_step=dt, **({"drive_law": law} if law else {}))
                t = time.perf_counter()
                cache[key] = (sc, rollout(vehicle, sc, settle))
                walls[key] = walls.get(key, 0.0) + time.perf_counter() - t
            sc, ser = cache[key]
            rows[name].append(grouped(statistics(ser, sc, readout)))
    return rows, walls


def table(rows: list[dict], dts, title: str, keys=None, out=None) -> dict:
    """Print statistic x dt with the first and the worst halving change and Richardson's value."""
    keys = keys or [k for k in rows[0] if not k.startswith("sum.") or abs(rows[-1]["sum.rms"]) > 1e-3]
    print(f"\n{title}")
    print(f"  {'statistic':18s}" + "".join(f"{dt * 1e3:>9.4g}" for dt in dts) + "   1st %  worst %    conv.")
    summary = {}
    for k in keys:
        vals = [r[k] for r in rows]
        group = k.split(".")[0]
        scale = max(abs(r[f"{group}.peak_lp_all"]) for r in rows)
        ch = halving_changes(vals, 0.05 * scale)
        conv = richardson(vals)
        flag = "  " if ch[0] <= TOL else " *"
        print(
            f"  {k:18s}"
            + "".join(f"{v:9.3f}" for v in vals)
            + f"  {100 * ch[0]:6.1f}{flag}{100 * max(ch):6.1f}  {conv:8.3f}"
        )
        summary[k] = {"values": vals, "first_halving": ch[0], "worst_halving": max(ch), "converged": conv}
    if out is not None:
        out[title] = summary
    return summary


def sizing_line(label: str, rows: list[dict], out=None) -> None:
    """The sizing statistics (and the unfiltered peaks) of one variant: 5 ms value, 1st and worst halving."""
    parts, rec = [], {}
    for k in ("drive.rms", "drive.peak_lp_all", "sum.peak_lp_all", "drive.peak_all", "sum.peak_all"):
        vals = [r[k] for r in rows]
        if abs(vals[-1]) < 1e-3:
            continue
        ch = halving_changes(vals, 0.05 * max(abs(r[k.split(".")[0] + ".peak_lp_all"]) for r in rows))
        parts.append(f"{k} {vals[0]:6.2f}->{vals[-1]:6.2f} {100 * ch[0]:4.1f}/{100 * max(ch):4.1f}%")
        rec[k] = {"values": vals, "first_halving": ch[0], "worst_halving": max(ch)}
    print(f"  {label:28s} " + " | ".join(parts))
    if out is not None:
        out[label] = rec


# --- causes -------------------------------------------------------------------------------
def causes(vehicle, dts, out) -> None:
    """Quantify the suspects (a)-(e) on the straight-line case, and the scrub of the turning scenarios."""
    res: dict = {}
    omega_t = 1.0 / 3.6 / vehicle.wheel.radius
    jw = vehicle.motors.armature + 0.5 * vehicle.wheel.mass * vehicle.wheel.radius**2
    print("(b) the servo's damping kv is integrated implicitly, the torque read before it: recorded - applied")
    print(
        f"    drive torque mid-ramp (t 0.4-0.6 s) against kv dt alpha (alpha = {omega_t:.4f} rad/s^2); "
        f"J_wheel {jw:.3f} kg m^2"
    )
    for dt in dts:
        ser = rollout(vehicle, straight(time_step=dt))
        mid = (ser["time"] > 0.4) & (ser["time"] < 0.6)
        bias = float((ser["tau"] - ser["tau_applied"])[mid, :4].mean())
        pred = ser["kv"][0] * dt * omega_t
        creep = float((ser["vel"][mid, 0] - ser["rim"][mid]).mean())
        print(
            f"  dt {dt * 1e3:6.4g} ms: {bias:6.3f} N m per wheel (kv dt alpha {pred:6.3f}); kv dt / J_wheel "
            f"{ser['kv'][0] * dt / jw:5.2f}; chassis ahead of the rim by {1e3 * creep:6.2f} mm/s"
        )
        res.setdefault("b", []).append({"dt": dt, "bias": bias, "predicted": pred, "creep_mm_s": 1e3 * creep})

    print("(c)(d) start-up: the vehicle starts touching the ground (no penetration) with no motor torque;")
    print("    laws held at 0 (motors hold), 10 deg, mu 0.9; applied torque")
    for dt in dts:
        sc = make_scenario(
            "custom", slope_deg=10, friction=0.9, total_time=2.0, time_step=dt, laws={"drive": 0.0, "steer": 0.0}
        )
        ser = rollout(vehicle, sc)
        t, vx, z = ser["time"], ser["vel"][:, 0], ser["pos"][:, 2]
        tsum = ser["tau_applied"][:, :4].sum(1)
        final = float(tsum[-1])
        st = grouped(statistics(ser, sc, "applied"))
        slid = -float(np.sum(np.minimum(vx, 0)) * dt)
        settled = float(t[np.nonzero(np.abs(tsum - final) > 0.01 * abs(final))[0][-1]])
        print(
            f"  dt {dt * 1e3:6.4g}: sinks {1e3 * (vehicle.chassis.z_cg - z[-1]):5.3f} mm, "
            f"slides back {1e3 * slid:4.2f} mm "
            f"(vx down to {1e3 * vx.min():6.2f} mm/s); sum peak_all {st['sum.peak_all']:6.2f} at t "
            f"{t[np.argmax(np.abs(tsum))]:5.3f} s, peak_lp_all {st['sum.peak_lp_all']:6.2f}, holding {final:6.2f} N m "
            f"(within 1% after {settled:5.3f} s); drive rms lf {st['drive.rms']:6.3f}"
        )
        res.setdefault("c", []).append(
            {
                "dt": dt,
                "slid_mm": 1e3 * slid,
                "sum_peak_all": st["sum.peak_all"],
                "sum_peak_lp_all": st["sum.peak_lp_all"],
                "holding": final,
                "settled_s": settled,
            }
        )

    print("(a) the ramp's kinks (settled first, applied torque): drive-sum torque just after each kink")
    for law in ("ramp", "smooth_step"):
        for dt in dts:
            sc = straight(time_step=dt, drive_law=law)
            ser = rollout(vehicle, sc, SETTLE)
            t, tsum = ser["time"], ser["tau_applied"][:, :4].sum(1)
            st = grouped(statistics(ser, sc, "applied"))
            k0, k1 = (t > 0) & (t < 0.3), (t > 0.9) & (t < 1.3)
            print(
                f"  {law:11s} dt {dt * 1e3:6.4g}: max after t=0 {tsum[k0].max():6.2f}, min after t=1 s "
                f"{tsum[k1].min():6.2f}; sum peak_lp_all {st['sum.peak_lp_all']:6.2f}; drive peak_all "
                f"{st['drive.peak_all']:6.3f} peak_lp_all {st['drive.peak_lp_all']:6.3f}"
            )
            res.setdefault("a", []).append(
                {
                    "law": law,
                    "dt": dt,
                    "after_t0": float(tsum[k0].max()),
                    "after_t1": float(tsum[k1].min()),
                    **{k: st[k] for k in ("sum.peak_all", "sum.peak_lp_all", "drive.peak_all", "drive.peak_lp_all")},
                }
            )

    print("(e) slip and the front/rear split in the steady window (default run, applied torque)")
    for dt in dts:
        sc = straight(time_step=dt)
        ser = rollout(vehicle, sc)
        w = ser["time"] > sc.total_time / 2
        slip = 1 - ser["vel"][w, 0] / ser["rim"][w]
        front, rear = float(ser["tau_applied"][w, 0].mean()), float(ser["tau_applied"][w, 2].mean())
        print(
            f"  dt {dt * 1e3:6.4g}: slip {slip.mean():+.2e} (std {slip.std():.1e}), contacts {ser['ncon'].min():.0f}-"
            f"{ser['ncon'].max():.0f}; front {front:6.3f} rear {rear:6.3f} N m (sum {2 * (front + rear):6.3f})"
        )
        res.setdefault("e", []).append({"dt": dt, "slip": float(slip.mean()), "front": front, "rear": rear})

    print("(e') scrub in the turning scenarios (now, applied torque): steps with no contact at all, and the")
    print("    friction bound mu N r per wheel (N = static quarter weight)")
    for name in ("steer_in_place", "pivot"):
        for dt in (0.005, 0.00125, 0.00015625):
            sc = CASES[name](time_step=dt)
            ser = rollout(vehicle, sc)
            g = grouped(statistics(ser, sc, "applied"))
            bound = sc.friction * vehicle.total_mass * sc.gravity / 4 * vehicle.wheel.radius
            print(
                f"  {name:14s} dt {dt * 1e3:6.4g}: no contact in {100 * np.mean(ser['ncon'] == 0):4.1f}% of steps; "
                f"drive peak_all {g['drive.peak_all']:6.2f}, peak_lp_all {g['drive.peak_lp_all']:6.2f} "
                f"(mu N r {bound:5.2f}); drive rms {g['drive.rms']:6.2f}"
            )
            res.setdefault("scrub", []).append(
                {
                    "case": name,
                    "dt": dt,
                    "no_contact": float(np.mean(ser["ncon"] == 0)),
                    "bound": bound,
                    **{k: g[k] for k in ("drive.peak_all", "drive.peak_lp_all", "drive.rms")},
                }
            )
    print("    steer in place with kinematically consistent laws (sine steering, each wheel rolling at exactly")
    print("    offset * steering rate / r: no forced skid, only the scrub of the 9 cm wide wheel):")
    laws = consistent_steer_laws(vehicle)
    for dt in (0.005, 0.0025, 0.00125, 0.000625, 0.00015625):
        sc = make_scenario("custom", total_time=3.0, time_step=dt, laws=laws)
        ser = rollout(vehicle, sc)
        g = grouped(statistics(ser, sc, "applied"))
        print(
            f"  consistent     dt {dt * 1e3:6.4g}: no contact in {100 * np.mean(ser['ncon'] == 0):4.1f}% of steps; "
            f"drive peak_lp_all {g['drive.peak_lp_all']:6.2f} rms {g['drive.rms']:6.2f}; "
            f"steer peak_lp_all {g['steer.peak_lp_all']:6.2f}"
        )
        res.setdefault("consistent", []).append(
            {"dt": dt, **{k: g[k] for k in ("drive.peak_lp_all", "drive.rms", "steer.peak_lp_all")}}
        )
    out["causes"] = res


def consistent_steer_laws(vehicle, steer_deg=45.0, total=3.0) -> dict:
    """Custom laws: steer_in_place's corners and signs, steering alpha = A (1 - cos(pi t / T)) / 2, each
    wheel rolling at -sy * offset * alpha'(t) / r, so its centre rolls around its steering axis."""
    offset, r = vehicle.steer_offset, vehicle.wheel.radius
    a = math.radians(steer_deg)
    laws = {}
    for c, s in zip(CORNERS, (-1, 1, 1, -1), strict=True):
        sy = {"lf": 1, "rf": -1, "lr": 1, "rr": -1}[c]
        f = 1 / (2 * total)
        laws[f"steer_{c}"] = {
            "law": "sine",
            "offset": s * steer_deg / 2,
            "amplitude": s * steer_deg / 2,
            "frequency": f,
            "phase": -math.pi / 2,
        }
        laws[f"drive_{c}"] = {
            "law": "sine",
            "offset": 0.0,
            "amplitude": -sy * s * offset / r * a / 2 * math.pi / total,
            "frequency": f,
            "phase": 0.0,
        }
    return laws


# --- main ---------------------------------------------------------------------------------
def check_reproduces(vehicle) -> None:
    """This script's rollout and statistics equal batchveh.simulate's; the applied torque balances momentum."""
    sc = straight(time_step=0.005, total_time=1.0)
    ref = batchveh.simulate(vehicle, sc, backend="mujoco").stats
    mine = statistics(rollout(vehicle, sc), sc)
    bad = [k for k in mine if k in ref and not np.isclose(mine[k], float(ref[k]), rtol=1e-12, atol=1e-12)]
    assert not bad, f"rollout differs from batchveh.simulate in {bad[:5]}"
    batch = make_batch(vehicle, sc, {})
    m = batch.model
    lay = layout(m)
    d = mujoco.MjData(m)
    kv = np.array([vehicle.motors.drive_kv] * 4 + [vehicle.motors.steer_kv] * 4)
    with float_precision("f64"):
        p = {k: np.asarray(float(v[0])) for k, v in batch.params.items()}
        ctrl = np.asarray(control_schedule(sc)(p, np.array([0.5])))[0]
    worst = 0.0
    for _ in range(100):  # M qacc + bias - passive - constraint = applied torque, on the motor joints
        v0 = d.qvel.copy()
        d.ctrl[:] = ctrl
        mujoco.mj_step(m, d)
        mq = np.zeros(m.nv)
        mujoco.mj_mulM(m, d, mq, (d.qvel - v0) / m.opt.timestep)
        rhs = (mq + d.qfrc_bias - d.qfrc_passive - d.qfrc_constraint)[lay.motor_dof]
        applied = d.qfrc_actuator[lay.motor_dof] - kv * (d.qvel - v0)[lay.motor_dof]
        worst = max(worst, float(np.abs(rhs - applied).max()))
    assert worst < 1e-8, worst
    print(
        "check: the rollout reproduces batchveh.simulate (rtol 1e-12); "
        f"the applied torque balances momentum to {worst:.0e} N m"
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="dt 5, 2.5, 1.25 ms only; no fine-step runs")
    ap.add_argument("--impratio", type=float, help="contact impratio (default: batchveh's ContactModel default)")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "peaks.json"))
    args = ap.parse_args(argv)
    dts = QUICK_DTS if args.quick else DTS
    fine = QUICK_DTS if args.quick else FINE_DTS
    vehicle = Vehicle()
    if args.impratio:
        vehicle = dataclasses.replace(
            vehicle, contact_model=dataclasses.replace(vehicle.contact_model, impratio=args.impratio)
        )
    cm = vehicle.contact_model
    out: dict = {"dts": list(dts), "settle": SETTLE, "variants": {k: list(v) for k, v in VARIANTS.items()}}
    out["contact_model"] = {"cone": cm.cone, "impratio": cm.impratio}
    print(f"contact model: cone {cm.cone}, impratio {cm.impratio:g}; motors {vehicle.motors}")
    t_start = time.perf_counter()
    check_reproduces(vehicle)
    print("Variants: now = batchveh today (recorded torque qfrc_actuator, laws from t = 0, ramp);")
    print(f"A = applied torque; B = settle {SETTLE} s before the laws, left out of *_all; C = drive law smooth_step.")
    print("Tables: value at each dt (ms); '1st %': change 5 -> 2.5 ms ('*' above 2%); 'worst %': over all")
    print("halvings; 'conv.': Richardson 2 f(h_min) - f(2 h_min). drive.* / steer.*: the worst of the four motors")
    print("(max; min for min; largest |.| for mean); sum.*: the drive sum. Changes of values near 0 are taken")
    print("relative to 5% of the group's peak_lp_all.")

    print("\n=== 1. Convergence now and with the fixes ===")
    rows = {}
    for name, make in CASES.items():
        rows[name], walls = variant_rows(vehicle, make, dts, uses_law=name != "pivot")
        table(rows[name]["now"], dts, f"{name}: now", out=out)
        table(rows[name]["A+B+C"], dts, f"{name}: A+B+C", out=out)
        sc = make()
        base, settled = walls[(0.0, None)], walls[(SETTLE, None)]
        print(
            f"  settle cost: {SETTLE} s on a {sc.total_time:g} s run = +{100 * SETTLE / sc.total_time:.0f}% steps "
            f"(rollout wall over the dts {base:.2f} s -> {settled:.2f} s)"
        )
        out.setdefault("cost", {})[name] = {"steps": SETTLE / sc.total_time, "wall": [base, settled]}
    print("\nSizing statistics by variant: value at 5 ms -> at the finest dt, 1st / worst halving change")
    sizing: dict = {}
    for name in CASES:
        for v in VARIANTS:
            if name == "pivot" and "C" in v:
                continue  # pivot's laws are built-in ramps: drive_law does not reach them
            sizing_line(f"{name} {v}", rows[name][v], sizing)
    out["sizing"] = sizing

    print("\n=== 2. Causes (straight line, 10 deg, mu 0.9, unless named) ===")
    causes(vehicle, dts, out)

    if not args.quick:
        print("\n=== 3. Fine steps: converged values (A+B+C; pivot: A+B, its laws ignore drive_law) ===")
        var = {k: VARIANTS[k] for k in ("now", "A+B", "A+B+C")}
        r, _ = variant_rows(vehicle, CASES["straight_line"], fine, variants=var)
        for v in var:
            table(r[v], fine, f"straight_line: {v}, fine steps", keys=SIZING_KEYS, out=out)
        for name in ("steer_in_place", "pivot"):
            var = {"A+B+C": VARIANTS["A+B+C"]}
            r, _ = variant_rows(vehicle, CASES[name], fine, variants=var, uses_law=name != "pivot")
            keys = [
                "drive.rms",
                "drive.peak_lp_all",
                "drive.peak_all",
                "steer.rms",
                "steer.peak_lp_all",
                "steer.peak_all",
            ]
            table(r["A+B+C"], fine, f"{name}: A+B+C, fine steps", keys=keys, out=out)

    print(f"\ntotal {time.perf_counter() - t_start:.0f} s")
    path = Path(args.out)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=1, default=float) + "\n")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
