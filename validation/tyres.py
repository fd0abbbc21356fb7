"""The slip tyre's obstacle and mission checks (issue 20), against the rigid contact: writes
validation/results/tyres.json (validation/TYRES.md).

- Step climbs at 0.25 km/h, 3 and 5 cm, C_rr 0.01, mu 0.9: drive work over m g h + rolling + kinetic.
- Climb limit against friction at 0.5 km/h (1 cm grid), slip tyre and rigid contact.
- A mission's cruise after a 10 deg climb against the same cruise without the climb: per-wheel RMS.

    python validation/tyres.py
"""

import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from batchveh.engines.mujoco import MujocoEngine  # noqa: E402
from batchveh.model import course  # noqa: E402
from batchveh.model.scenarios import make_scenario  # noqa: E402
from batchveh.model.tyres import Tyre  # noqa: E402
from batchveh.model.vehicle import CORNERS, Vehicle, Wheel, rolling_resistance_torque  # noqa: E402
from batchveh.stepping import stats
from batchveh.stepping.batch import make_batch  # noqa: E402

G = 9.81
MODELS = {"slip": Vehicle(), "rigid": Vehicle(tyre=Tyre(model="rigid"))}


def _run(vehicle, sc, table, window=None):
    batch = make_batch(vehicle, sc, table)
    cols = MujocoEngine(sc, stats.StatsConfig.for_scenario(sc, window), batch.n).run(batch)
    return course.flag(cols, batch.params, sc.obstacle)


def step_energy(model):
    v = dataclasses.replace(MODELS[model], wheel=Wheel(rolling_resistance=0.01))
    sc = make_scenario(
        "straight_line", total_time=19.0, ramp_time=1.0, speed_kmh=0.25, friction=0.9, obstacle="step", obstacle_x=0.2
    )
    heights = np.array([0.03, 0.05])
    cols = _run(v, sc, {"step_height": heights})
    m, r = v.total_mass, v.wheel.radius
    speed = 0.25 / 3.6
    inertia = 0.5 * v.wheel.mass * r**2 + v.motors.armature
    kinetic = 0.5 * m * speed**2 + 4 * 0.5 * inertia * (speed / r) ** 2
    rolling = 4 * rolling_resistance_torque(0.01, r, m, G) * cols["distance"] / r
    work = sum(cols[f"drive_{c}_energy"] for c in CORNERS)
    return {
        "heights_m": heights.tolist(),
        "cleared": np.asarray(cols["cleared"], bool).tolist(),
        "work_over_closed_form": (work / (m * G * heights + rolling + kinetic)).tolist(),
    }


def climb_limit(model, frictions=(0.3, 0.5, 0.7, 0.9, 1.2)):
    heights = np.round(np.arange(0.02, 0.19, 0.01), 3)
    sc = make_scenario("straight_line", total_time=14.0, ramp_time=1.0, speed_kmh=0.5, obstacle="step", obstacle_x=0.2)
    mu = np.repeat(frictions, len(heights))
    h = np.tile(heights, len(frictions))
    cols = _run(MODELS[model], sc, {"friction": mu, "step_height": h})
    cleared = np.asarray(cols["cleared"], bool).reshape(len(frictions), len(heights))
    out = {}
    for k, f in enumerate(frictions):
        ok = heights[cleared[k]]
        out[str(f)] = float(ok.max()) if ok.size else 0.0
    return out


def mission_windup(model):
    climb = [
        {"kind": "accelerate", "duration": 2},
        {"kind": "cruise", "duration": 2},
        {"kind": "climb", "duration": 4, "transition": 1.5},
        {"kind": "cruise", "duration": 2},
        {"kind": "cruise", "duration": 4},
    ]
    flat = [dict(s) for s in climb]
    flat[2] = {"kind": "cruise", "duration": 4}
    v = dataclasses.replace(MODELS[model], wheel=Wheel(rolling_resistance=0.02))
    rms = {}
    for name, segs in (("climb", climb), ("flat", flat)):
        sc = make_scenario("mission", segments=segs, friction=0.9, slope_deg=10.0, speed_kmh=2.0)
        cols = _run(v, sc, {"payload.mass": np.array([0.0])})
        key = [k for k in cols if k.startswith("seg4_") and k.endswith("_rms") and "drive_" in k and "sum" not in k]
        rms[name] = {k: float(np.asarray(cols[k])[0]) for k in sorted(key)}
    ratio = {k: rms["climb"][k] / rms["flat"][k] for k in rms["flat"]}
    return {"rms_after_climb": rms["climb"], "rms_without_climb": rms["flat"], "ratio": ratio}


def main():
    out = {"date": time.strftime("%Y-%m-%d"), "engine": "MuJoCo C float64 (batchveh mujoco engine)"}
    for model in ("slip", "rigid"):
        t0 = time.time()
        out[model] = {"step_energy": step_energy(model), "mission_windup": mission_windup(model)}
        out[model]["climb_limit_m_by_friction"] = climb_limit(model)
        print(model, json.dumps(out[model], indent=1), f"{time.time() - t0:.0f} s", flush=True)
    path = Path(__file__).resolve().parent / "results" / "tyres.json"
    path.write_text(json.dumps(out, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
