"""Scrub study: which contact softness lets MuJoCo's friction slide like Coulomb's in the seed's
scenario 2 (issue 10), and what it costs on a straight climb.

Run from the repository root (about 1 min per setting on 2 CPU cores, MuJoCo C):

    python validation/scrub.py

For each contact setting (elliptic cone, time constant 0.02 s, impratio and impedance d as listed):
- seed form (`steer_in_place`, 0.2-1.0 s): window-mean drive torque / (mu N r), steering torque
  / (mu N offset) (Coulomb sliding gives 1 and 1), and the inner and outer edge loads;
- consistent form (`steer_in_place_rolling`, 0.2-2.8 s): drive and steering torque, N m (Coulomb
  with two equally loaded edge contacts: 0 and mu N w / 2 = 11.2 N m);
- a straight 15 deg climb: the four-wheel sum against m g sin(s) r, and the wheel's sinkage.
Writes validation/results/scrub.json; SCRUB.md gives the table and the choice.
The per-step recorder is tests/test_scrub.py's, so the study and the test measure the same way.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from test_scrub import ROLLING_WINDOW, SEED_WINDOW, _record, _window  # noqa: E402

from batchveh.model.scenarios import make_scenario  # noqa: E402
from batchveh.model.vehicle import MOTORS, ContactModel, Vehicle  # noqa: E402
from batchveh.run import simulate  # noqa: E402
from batchveh.stepping.batch import make_batch  # noqa: E402
from batchveh.stepping.rollout import mujoco_steps  # noqa: E402

# (impratio, impedance d): MuJoCo's solimp default (0.9), the old batchveh default, and softer
SETTINGS = [(10, 0.9), (100, 0.9), (30, 0.3), (100, 0.4), (100, 0.3), (100, 0.25), (100, 0.2), (100, 0.15)]
CLIMB_DEG = 15.0


def seed_and_rolling(v: Vehicle) -> dict:
    out = {}
    for kind, window in (("steer_in_place", SEED_WINDOW), ("steer_in_place_rolling", ROLLING_WINDOW)):
        sc = make_scenario(kind)
        w = _window(_record(v, sc), window)
        n = w["N"].sum(-1).mean(0)[0]
        tau = np.abs(w["tau"].mean(0))
        mu = sc.friction
        out[kind] = {
            "drive_Nm": tau[0],
            "steer_Nm": tau[4],
            "drive_over_muNr": tau[0] / (mu * n * v.wheel.radius),
            "steer_over_muNoffset": tau[4] / (mu * n * v.steer_offset),
            "N_inner_outer": w["N"].mean(0)[0].tolist(),
        }
    return out


def climb(v: Vehicle) -> dict:
    sc = make_scenario("straight_line", slope_deg=CLIMB_DEG)
    s = simulate(v, sc).series
    last = s.time > s.time.max() - 1.0
    total = s.loc[last, [m for m in MOTORS if m.startswith("drive")]].to_numpy().mean(0).sum()
    closed = v.total_mass * 9.81 * np.sin(np.deg2rad(CLIMB_DEG)) * v.wheel.radius
    b = make_batch(v, sc, {})
    p = {k: float(x[0]) for k, x in b.params.items()}
    depth = []
    for step, (d, _) in enumerate(mujoco_steps(b.model, p, scenario=sc, n_steps=sc.n_steps)):
        if step > sc.n_steps - 200 and d.ncon:
            depth.append(-np.mean([d.contact[i].dist for i in range(d.ncon)]))
    return {"sum_rel_err": total / closed - 1, "sinkage_mm": float(np.mean(depth)) * 1e3}


def main() -> int:
    rows = []
    print(
        f"{'impratio':>8} {'d':>5} | seed: {'drive':>6} {'steer':>6} {'N in/out':>13} | "
        f"rolling: {'drive':>5} {'steer':>5} N m | climb: {'sum err':>8} {'sink mm':>7}"
    )
    for impratio, d in SETTINGS:
        t0 = time.perf_counter()
        v = Vehicle(contact_model=ContactModel(impratio=float(impratio), impedance=d))
        row = {"impratio": impratio, "impedance": d, **seed_and_rolling(v), "climb": climb(v)}
        rows.append(row)
        s, r, c = row["steer_in_place"], row["steer_in_place_rolling"], row["climb"]
        print(
            f"{impratio:>8} {d:>5} | seed: {s['drive_over_muNr']:6.3f} {s['steer_over_muNoffset']:6.3f} "
            f"{s['N_inner_outer'][0]:6.1f}/{s['N_inner_outer'][1]:6.1f} | rolling: {r['drive_Nm']:5.2f} "
            f"{r['steer_Nm']:5.2f}     | climb: {c['sum_rel_err']:+8.2e} {c['sinkage_mm']:7.2f}"
            f"   ({time.perf_counter() - t0:.0f} s)",
            flush=True,
        )
    out = Path(__file__).parent / "results" / "scrub.json"
    out.write_text(json.dumps({"mujoco": mujoco.__version__, "rows": rows}, indent=1, default=float) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
