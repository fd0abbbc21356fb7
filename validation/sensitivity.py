"""Sobol' indices against closed forms (issue 23), through batchveh's own machinery (a sobol sweep on
MuJoCo C, Parquet, batchveh.sensitivity): writes validation/results/sensitivity.json, the values quoted in
docs/sensitivity.md. tests/test_sensitivity.py asserts the same checks; this script records the numbers.

- Ishigami (a = 7, b = 0.1) of three swept parameters in [-pi, pi] as a derived statistic, N = 4096.
- Steady non-slipping climbs, slope x friction, N = 64: S1(slope), ST(friction) of the drive sum's mean.
- Slope x friction x payload mass, N = 256 and 1024: the indices of m g sin(s) r's variance decomposition.

    python validation/sensitivity.py          # about 3 min on 2 CPU cores
"""

import json
import math
import os
import platform
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import batchveh  # noqa: E402
from batchveh.analysis.sensitivity import SensitivityWarning  # noqa: E402
from batchveh.model.vehicle import Vehicle  # noqa: E402
from batchveh.sweep import run_sweep  # noqa: E402
from batchveh.sweeping.spec import spec_from_mapping  # noqa: E402

G = 9.81
CLIMB = {"total_time": 2.0, "ramp_time": 0.5}
SLOPE, FRICTION, PAYLOAD = (2.0, 15.0), (0.6, 1.0), (0.0, 150.0)


def _indices(tmp, name, params, n, statistic, fixed, scenario="straight_line", derived=None):
    """Run a sobol sweep of `params` ({name: (low, high)}) and return {(parameter, S1|ST): [index, conf]}."""
    raw = {
        "name": name,
        "scenario": scenario,
        "fixed": fixed,
        "sweep": {
            "method": "sobol",
            "n": n,
            "seed": 0,
            "params": {k: {"low": lo, "high": hi} for k, (lo, hi) in params.items()},
        },
        "backend": "mujoco",
    }
    out = Path(tmp) / name
    t0 = time.time()
    run_sweep(spec_from_mapping(raw, f"validation/sensitivity.py ({name})"), out=out, progress=False)
    df = batchveh.load(out)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SensitivityWarning)
        table = batchveh.sensitivity(out, [statistic], derived=derived)
    got = {
        f"{r.parameter} {k}": [float(getattr(r, k)), float(getattr(r, f"{k}_conf"))]
        for r in table.itertuples()
        for k in ("S1", "ST")
    }
    return {
        "variants": len(df),
        "ok": int((df.status == "ok").sum()),
        "slipping": int(df.slipping.sum()),
        "seconds": round(time.time() - t0, 1),
        "indices": got,
    }, df


def ishigami(tmp):
    a, b, pi = 7.0, 0.1, math.pi
    names = ("steer_deg", "turn_radius", "yaw_rate_dps")  # read by no straight line: the runs stay short

    def f(frame):
        x1, x2, x3 = (frame[k].to_numpy() for k in names)
        return np.sin(x1) + a * np.sin(x2) ** 2 + b * x3**4 * np.sin(x1)

    res, _ = _indices(
        tmp, "ishigami", dict.fromkeys(names, (-pi, pi)), 4096, "ishigami",
        {"total_time": 0.05}, {"kind": "straight_line", "settle_time": 0.0}, {"ishigami": f},
    )  # fmt: skip
    # Ishigami and Homma (1990); Sobol' and Levitan (1999): the partial variances
    v = a**2 / 8 + b * pi**4 / 5 + b**2 * pi**8 / 18 + 0.5
    v1, v2, v13 = 0.5 * (1 + b * pi**4 / 5) ** 2, a**2 / 8, 8 * b**2 * pi**8 / 225
    x1, x2, x3 = names
    res["closed_form"] = {
        f"{x1} S1": v1 / v, f"{x2} S1": v2 / v, f"{x3} S1": 0.0,
        f"{x1} ST": (v1 + v13) / v, f"{x2} ST": v2 / v, f"{x3} ST": v13 / v,
    }  # fmt: skip
    return res


def climb(tmp):
    res, df = _indices(tmp, "climb", {"slope_deg": SLOPE, "friction": FRICTION}, 64, "drive_sum_mean", CLIMB)
    v = Vehicle()
    expect = v.total_mass * G * np.sin(np.deg2rad(df.slope_deg)) * v.wheel.radius
    res["drive_sum_mean_vs_m_g_sin_r_max_rel"] = float(np.max(np.abs(df.drive_sum_mean / expect - 1)))
    res["closed_form"] = {"friction ST": 0.0}
    return res


def payload_decomposition(m0):
    """Sobol' indices of Y = (m0 + P) g r sin(s), P and s independent and uniform, by the moments of the two
    factors (Gauss-Legendre, exact for these smooth integrands to machine precision)."""
    x, w = np.polynomial.legendre.leggauss(40)
    s = np.deg2rad(np.mean(SLOPE) + np.ptp(SLOPE) / 2 * x)
    p = m0 + np.mean(PAYLOAD) + np.ptp(PAYLOAD) / 2 * x
    e_f, e_f2 = w @ p / 2, w @ p**2 / 2
    e_h, e_h2 = w @ np.sin(s) / 2, w @ np.sin(s) ** 2 / 2
    var_f, var_h = e_f2 - e_f**2, e_h2 - e_h**2
    v_p, v_s, v_ps = var_f * e_h**2, e_f**2 * var_h, var_f * var_h
    v = v_p + v_s + v_ps
    return {
        "slope_deg S1": v_s / v,
        "slope_deg ST": (v_s + v_ps) / v,
        "payload.mass S1": v_p / v,
        "payload.mass ST": (v_p + v_ps) / v,
    }


def payload(tmp, n):
    params = {"slope_deg": SLOPE, "friction": FRICTION, "payload.mass": PAYLOAD}
    res, _ = _indices(tmp, f"payload{n}", params, n, "drive_sum_mean", CLIMB)
    res["closed_form"] = payload_decomposition(Vehicle().total_mass)
    return res


def main():
    cpu = platform.processor() or platform.machine()
    out = {
        "machine": f"{cpu}, {len(os.sched_getaffinity(0))} CPUs, {platform.system()}",
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "engine": "mujoco (MuJoCo C, float64), the slip tyre",
        "confidence": "SALib's bootstrap, 95 % half-width",
    }
    with tempfile.TemporaryDirectory() as tmp:
        for name, run in [
            ("ishigami_N4096", ishigami),
            ("climb_N64", climb),
            ("payload_N256", lambda t: payload(t, 256)),
            ("payload_N1024", lambda t: payload(t, 1024)),
        ]:
            out[name] = run(tmp)
            print(name, json.dumps(out[name]), flush=True)
    path = Path(__file__).resolve().parent / "results" / "sensitivity.json"
    path.write_text(json.dumps(out, indent=1))
    print("wrote", path)


if __name__ == "__main__":
    main()
