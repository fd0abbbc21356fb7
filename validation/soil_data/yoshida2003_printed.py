"""Yoshida, Watanabe, Mizuno and Ishigami (2003): their printed wheel equations, written out again on
scalars and integrated by scipy's adaptive quad, independent of batchveh/model/soil.py (which is
called only at the end, to compare). Writes yoshida2003_printed.json beside this file.

Questions (validation/soil_data/README.md, validation/SOIL.md "Published data"):
1. Do the printed equations with the printed dry-sand parameters, under each plausible reading of
   the misprinted units of k_c and k_phi, reproduce the authors' own theory curves of Fig. 5
   (wheel_test_all_loads.csv, kind=theory; peaks 11.2 / 16.0 / 25.3 N at 24.5 / 34.3 / 53.9 N)?
2. Where does the drawbar pull go in batchveh's setting of the same test (c3 = 0)?
3. Does batchveh's soil.integrate give the same forces as these equations at the same settings?

The paper's equations (section 2, numbers as printed):
  (2)  tau = (c + sigma tan phi)(1 - exp(-j / k)), j = r [theta_f - theta - (1 - s)(sin theta_f - sin theta)]
  (3)  W  = r b [int sigma cos + int tau sin],  (4) DP = r b [int tau cos - int sigma sin]
  (5)  T  = r^2 b int tau, all from theta_r to theta_f
  (6)  sigma = sigma_max ((cos theta - cos theta_f) / (cos theta_m - cos theta_f))^n
  (7)  theta_m = c1 s theta_f,  (8) sigma_max = (k_c / b + k_phi) r^n (cos theta_m - cos theta_f)^n
  (10) W = int_{-theta_s}^{theta_s} (k_c / b + k_phi)(r (cos theta - cos theta_s))^n r b dtheta
  (11) h_s = r (1 - cos theta_s),  (12) h_k = c2 s,  (13) theta_f = acos(1 - (h_s + h_k) / r)
  (14) theta_r = c3 theta_f  (read here as -c3 theta_f: the rear angle, below the axle's vertical)
  dry sand: c 0.005, phi 27.5 deg, r 0.09 m, b 0.1 m, k 0.012 m, k_c 85e3 [N/m^(n+1)],
  k_phi 45e4 [N/m^(n+1)] (the unit as printed), n 1.38, c1 0.5, c2 0.025 m, c3 1.1.
(6) with (8) is sigma = (k_c / b + k_phi)(r (cos theta - cos theta_f))^n on the whole contact: theta_m
cancels, and with theta_r = -1.1 theta_f the stress is symmetric about the bottom. The "mirrored"
variant is the Wong-Reece form of the same group's 2005 paper (eq. 7 there, and batchveh's): behind
theta_m the front law at the angle mapped from [theta_r, theta_m] onto [theta_f, theta_m].

    python validation/soil_data/yoshida2003_printed.py     (about a minute on one core)
"""

import csv
import json
import sys
from pathlib import Path

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

HERE = Path(__file__).resolve().parent
R, B, PHI, KJ, N = 0.09, 0.1, np.deg2rad(27.5), 0.012, 1.38
C = 0.0  # 0.005 "N/m^2" (or kPa): below 5 Pa, nothing against the stresses here (kPa)
C1, C2, C3 = 0.5, 0.025, 1.1
LOADS = (24.5, 34.3, 53.9)
# readings of k = k_c / b + k_phi (Pa / m^n) at b = 0.1 m
READINGS = {
    "SI: k_c 85e3 N/m^(n+1), k_phi 45e4 N/m^(n+2)": 85e3 / B + 45e4,
    "as printed: both N/m^(n+1), so (k_c + k_phi) / b": (85e3 + 45e4) / B,
    "k_c / b with b in mm": 85e3 / (B * 1e3) + 45e4,
    "k_c + b k_phi (Wong's per-length form)": 85e3 + B * 45e4,
}


def sigma(t, tf, tr, tm, k, mirrored):
    if mirrored and t < tm:
        t = tf - (t - tr) / (tm - tr) * (tf - tm)
    d = np.cos(t) - np.cos(tf)
    return k * (R * d) ** N if d > 0 else 0.0


def forces(h, s, k, c3, mirrored, c1=C1):
    """W, DP, T (N, N, N m) at total sinkage h and slip s, by eqs. (2)-(8), (13), (14)."""
    tf = np.arccos(1 - h / R)
    tr, tm = -c3 * tf, c1 * s * tf

    def tau(t):
        j = R * (tf - t - (1 - s) * (np.sin(tf) - np.sin(t)))
        return (C + sigma(t, tf, tr, tm, k, mirrored) * np.tan(PHI)) * (1 - np.exp(-j / KJ))

    breaks = sorted({x for x in (tr, tm, -tf, 0.0, tf) if tr <= x <= tf})

    def integral(f):
        return sum(
            quad(f, a, b, limit=200, epsabs=0, epsrel=1e-10)[0]
            for a, b in zip(breaks, breaks[1:], strict=False)
            if b > a
        )

    w = (
        R
        * B
        * (integral(lambda t: sigma(t, tf, tr, tm, k, mirrored) * np.cos(t)) + integral(lambda t: tau(t) * np.sin(t)))
    )
    dp = (
        R
        * B
        * (integral(lambda t: tau(t) * np.cos(t)) - integral(lambda t: sigma(t, tf, tr, tm, k, mirrored) * np.sin(t)))
    )
    return w, dp, R * R * B * integral(tau)


def static_sinkage(load, k):
    """h_s from eq. (10) as printed (no cos theta under the integral) and (11)."""

    def w(ts):
        return quad(lambda t: k * (R * (np.cos(t) - np.cos(ts))) ** N * R * B, -ts, ts, epsrel=1e-12)[0]

    return R * (1 - np.cos(brentq(lambda ts: w(ts) - load, 1e-6, np.pi / 2, xtol=1e-14)))


def equilibrium_sinkage(load, s, k, c3, mirrored, c1=C1):
    """The sinkage where eq. (3) carries the load (batchveh's way), instead of (10)-(12)."""
    return brentq(lambda h: forces(h, s, k, c3, mirrored, c1)[0] - load, 1e-6, 0.999 * R, xtol=1e-12)


def read_csv(name):
    with (HERE / name).open() as f:
        return list(csv.DictReader(f))


def main():
    rows = read_csv("wheel_test_all_loads.csv")
    theory = {
        w: [
            (float(r["slip"]), float(r["drawbar_pull_N"]))
            for r in rows
            if r["kind"] == "theory" and float(r["load_N"]) == w
        ]
        for w in LOADS
    }
    data = [(float(r["slip"]), float(r["drawbar_pull_N"])) for r in read_csv("wheel_test.csv")]
    slips = [s for s, _ in theory[24.5]]
    out = {
        "theory_peaks_N": {str(w): max(d for _, d in theory[w]) for w in LOADS},
        "printed_procedure": [],
        "equilibrium": [],
    }

    # 1. the printed procedure: h = h_s (eq. 10) + c2 s, the forces at that sinkage
    for name, k in READINGS.items():
        for mirrored in (False, True):
            entry = {
                "reading": name,
                "k_Pa_per_m^n": k,
                "sigma": "mirrored (Wong-Reece)" if mirrored else "as printed (eq. 6, 8)",
                "c3": C3,
                "curves": {},
            }
            for w in LOADS:
                hs = static_sinkage(w, k)
                dp = [forces(hs + C2 * s, s, k, C3, mirrored)[1] for s in slips]
                ww = [forces(hs + C2 * s, s, k, C3, mirrored)[0] for s in (0.0, 0.5)]
                entry["curves"][str(w)] = {"h_s_mm": hs * 1e3, "DP_N": dp, "W_eq3_at_s0_and_0.5_N": ww}
            entry["largest_deviation_from_theory_N"] = max(
                abs(a - t) for w in LOADS for a, (_, t) in zip(entry["curves"][str(w)]["DP_N"], theory[w], strict=False)
            )
            out["printed_procedure"].append(entry)
            print(
                "printed",
                name,
                entry["sigma"],
                "peaks",
                [round(max(entry["curves"][str(w)]["DP_N"]), 1) for w in LOADS],
            )

    # 2. the sinkage from vertical equilibrium (no h_k), mirrored stress, rear angle c3 = 1.1, 1.0, 0
    for name in list(READINGS)[:2]:
        k = READINGS[name]
        for c3 in (C3, 1.0, 0.0):
            entry = {"reading": name, "k_Pa_per_m^n": k, "c3": c3, "curves": {}}
            for w in LOADS:
                entry["curves"][str(w)] = [
                    forces(equilibrium_sinkage(w, s, k, c3, True), s, k, c3, True)[1] for s in slips
                ]
            entry["largest_deviation_from_theory_N"] = max(
                abs(a - t) for w in LOADS for a, (_, t) in zip(entry["curves"][str(w)], theory[w], strict=False)
            )
            pts = []
            for s, d in data:
                h = equilibrium_sinkage(24.5, s, k, c3, True)
                wv, dp, tq = forces(h, s, k, c3, True)
                pts.append(
                    {"slip": s, "data_N": d, "DP_N": dp, "T_Nm": tq, "sinkage_m": h, "relative_error": (dp - d) / d}
                )
            entry["against_data_24.5N"] = pts
            out["equilibrium"].append(entry)
            print(
                "equilibrium",
                name,
                "c3",
                c3,
                "peaks",
                [round(max(entry["curves"][str(w)]), 2) for w in LOADS],
                "vs data",
                [round(p["relative_error"], 2) for p in pts],
            )

    # 3. batchveh's soil.integrate at the same sinkage, slip and soil (c1 0, c2 0.5 is theta_m = 0.5 s theta_f)
    sys.path.insert(0, str(HERE.parent.parent))
    from batchveh.model import soil

    comp = []
    for c3 in (0.0, 0.5, 1.0):
        so = {"n": N, "k_c": 85.0, "k_phi": 450.0, "c": 0.0, "phi": 27.5, "K": KJ, "c1": 0.0, "c2": C1, "c3": c3}
        p = {
            "wheel.width": B,
            "wheel.radius": R,
            "wheel.mass": 1.0,
            "hub.mass": 0.0,
            "chassis.mass": 0.0,
            "payload.mass": 0.0,
            "_drive_armature": 0.0,
            "tyre.relaxation_length": 0.05,
            "gravity": 9.81,
            **{f"soil.{a}": v for a, v in so.items()},
        }
        sp = soil.params({a: np.array([v], float) for a, v in p.items()})
        for h in (0.005, 0.015, 0.03):
            for s in (0.0, 0.2, 0.5, 0.8):
                o = soil.integrate(np.array([h]), np.array([s / (1 - s)]), np.zeros(1), np.ones(1), sp)
                ref = forces(h, s, READINGS[list(READINGS)[0]], c3, True)
                got = [float(np.ravel(o[x])[0]) for x in ("W", "DP", "T")]
                comp.append(
                    {
                        "c3": c3,
                        "h": h,
                        "s": s,
                        "batchveh": got,
                        "quad": list(ref),
                        "largest_relative": max(
                            abs(g - q) / max(abs(q), 1e-9 + 0.01 * abs(ref[0])) for g, q in zip(got, ref, strict=False)
                        ),
                    }
                )
    out["batchveh_vs_quad"] = {"rows": comp, "largest_relative": max(c["largest_relative"] for c in comp)}
    print("batchveh integrate against quad: largest relative difference", out["batchveh_vs_quad"]["largest_relative"])
    (HERE / "yoshida2003_printed.json").write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
