"""Obstacles: the simulated peak drive torque at a step against the rule of thumb, and the climb limit.

Run from the repository root (MuJoCo C, about 1 min on 2 CPU cores):

    python validation/obstacles.py

Prints both tables and writes validation/results/obstacles.json. Method and conclusions: OBSTACLES.md.

1. Peak torque. The seed's vehicle (144.8 kg, wheel radius 0.195 m, four wheels locked to one
   speed, cylinder contacts) crawls at 0.25 km/h onto a step at mu 1.2 (friction does not limit the
   climb). The rule of thumb: a wheel of load W lifts itself over a step of height h < r with a
   torque W sqrt(2 r h - h^2) (the weight's lever about the edge), W = m g / 4 here. Simulated: the
   largest front-wheel `peak_all` and `peak_lp_all` (the front wheels meet the step first), and the
   four-wheel sum's `peak_lp_all` against the rule for the whole front axle plus the rear's rolling
   share, 2 W sqrt(2 r h - h^2).
2. Climb limit. At 0.5 km/h, mu 0.3 to 1.2 and step heights in 0.01 m steps up to the wheel
   radius: the highest step the vehicle clears without slipping (status ok, not `slipping`), and the
   lowest one it does not clear (status `stuck`).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from batchveh.engines.mujoco import MujocoEngine  # noqa: E402
from batchveh.model import course  # noqa: E402
from batchveh.model.scenarios import make_scenario  # noqa: E402
from batchveh.model.vehicle import Vehicle  # noqa: E402
from batchveh.stepping import stats
from batchveh.stepping.batch import make_batch  # noqa: E402

G = 9.81
PEAK_HEIGHTS = (0.01, 0.02, 0.04, 0.06, 0.08, 0.10, 0.12, 0.14)  # m
LIMIT_FRICTIONS = (0.3, 0.5, 0.7, 0.9, 1.2)
LIMIT_HEIGHTS = tuple(np.round(np.arange(0.02, 0.195, 0.01), 3))  # m, below the wheel radius


def run(table: dict, **scenario) -> dict:
    """Statistics and `cleared` of the table's variants on a step, MuJoCo C."""
    sc = make_scenario("straight_line", obstacle="step", ramp_time=1.0, **scenario)
    batch = make_batch(Vehicle(), sc, table)
    cols = MujocoEngine(sc, stats.StatsConfig.for_scenario(sc), batch.n).run(batch)
    return course.flag(cols, batch.params, "step")


def peak_table(v: Vehicle) -> list[dict]:
    h = np.array(PEAK_HEIGHTS)
    cols = run({"step_height": h}, speed_kmh=0.25, friction=1.2, total_time=21.0)
    r, w = v.wheel.radius, v.total_mass * G / 4
    rule = w * np.sqrt(2 * r * h - h * h)
    front = ("drive_lf", "drive_rf")
    rows = []
    for i, hi in enumerate(h):
        rows.append(
            {
                "step_height": float(hi),
                "rule_nm": float(rule[i]),
                "front_peak_all": float(max(cols[f"{c}_peak_all"][i] for c in front)),
                "front_peak_lp_all": float(max(cols[f"{c}_peak_lp_all"][i] for c in front)),
                "sum_peak_lp_all": float(cols["drive_sum_peak_lp_all"][i]),
                "status": stats.STATUS[int(cols["status_code"][i])],
                "slipping": bool(cols["slipping"][i]),
            }
        )
    return rows


def limit_table() -> list[dict]:
    hh, mm = np.meshgrid(LIMIT_HEIGHTS, LIMIT_FRICTIONS)
    cols = run({"step_height": hh.ravel(), "friction": mm.ravel()}, speed_kmh=0.5, total_time=14.0)
    climbs = ((cols["status_code"] == 0) & ~cols["slipping"]).reshape(hh.shape)
    stuck = (cols["status_code"] == 3).reshape(hh.shape)
    cleared_slipping = ((cols["status_code"] == 0) & cols["slipping"]).reshape(hh.shape)
    rows = []
    for i, mu in enumerate(LIMIT_FRICTIONS):
        h = np.array(LIMIT_HEIGHTS)
        rows.append(
            {
                "friction": mu,
                "highest_climbed": float(h[climbs[i]].max()) if climbs[i].any() else None,
                "lowest_stuck": float(h[stuck[i]].min()) if stuck[i].any() else None,
                "slipping_but_cleared": [float(x) for x in h[cleared_slipping[i]]],
            }
        )
    return rows


def main() -> None:
    v = Vehicle()
    peaks = peak_table(v)
    print("| h (m) | rule W sqrt(2rh-h^2) (N m) | front peak_all | front peak_lp_all | sum peak_lp_all | status |")
    print("| ---: | ---: | ---: | ---: | ---: | --- |")
    for p in peaks:
        status = p["status"] + (", slipping" if p["slipping"] else "")
        print(
            f"| {p['step_height']:.2f} | {p['rule_nm']:.1f} | {p['front_peak_all']:.1f} | "
            f"{p['front_peak_lp_all']:.1f} | {p['sum_peak_lp_all']:.1f} | {status} |"
        )
    limits = limit_table()
    print("\n| friction | highest step climbed (m) | lowest step stuck (m) | cleared while slipping (m) |")
    print("| ---: | ---: | ---: | --- |")
    for row in limits:
        print(
            f"| {row['friction']} | {row['highest_climbed']} | {row['lowest_stuck']} | "
            f"{', '.join(map(str, row['slipping_but_cleared'])) or '-'} |"
        )
    out = Path(__file__).resolve().parent / "results" / "obstacles.json"
    out.write_text(json.dumps({"peaks": peaks, "limits": limits}, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
