"""The drive's derived gains (batchveh/model/drive.py, batch.drive_gains) on four vehicles unlike each other:
the table of docs/motors.md, "The gains, from each variant". Writes validation/results/drive_gains.json.

    python validation/drive_gains.py
"""

import json
from datetime import date
from pathlib import Path

import numpy as np

from batchveh.stepping.batch import make_batch
from batchveh.sweeping.spec import spec_from_mapping

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = str(ROOT / "notebooks" / "motors.yaml")
STEER = "maxon-353297-48V_NPT025-i40"
ROBOT = {
    "chassis": {"mass": 44.0, "length": 0.6, "width": 0.45, "z_cg": 0.2},
    "wheel": {"radius": 0.1, "mass": 1.0, "width": 0.05, "x_cg": 0.3, "y_cg": 0.28},
    "hub": {"mass": 3.0, "radius": 0.03, "length": 0.1, "y_cg": 0.2},
}
ROVER = {
    "chassis": {"mass": 880.0, "length": 2.0, "width": 1.4, "z_cg": 0.6},
    "wheel": {"radius": 0.4, "mass": 20.0, "width": 0.2, "x_cg": 0.9, "y_cg": 0.8},
    "hub": {"mass": 10.0, "radius": 0.1, "length": 0.3, "y_cg": 0.55},
}
CASES = {
    "seed 145 kg, r 0.195 m, EC 45 flat 48 V on 40:1": ({}, "maxon-EC45flat-70W-48V_NPT015-i40"),
    "seed, maxon 353297 on 40:1": ({}, "maxon-353297-48V_NPT025-i40"),
    "robot 60 kg, r 0.10 m, Faulhaber 3863H048CR on 28:1": (ROBOT, "faulhaber-3863H048CR_NPT015-i28"),
    "rover 1 t, r 0.40 m, maxon 353297 on 40:1": (ROVER, "maxon-353297-48V_NPT025-i40"),
}


def gains(vehicle: dict, drive: str) -> dict:
    motors = {"model": "dcmotor", "catalogue": CATALOGUE, "drive": drive, "steer": STEER}
    raw = {"name": "g", "scenario": "straight_line", "vehicle": {**vehicle, "motors": motors},
           "sweep": {"method": "zip", "params": {"friction": [0.7]}}, "output": "unused"}  # fmt: skip
    spec = spec_from_mapping(raw, "drive_gains")
    b = make_batch(spec.vehicle, spec.scenario, {"friction": np.array([0.7])})
    kv, kp, ki, ff = (b.params[f"_dc.{k}"][0] for k in ("kv", "kp", "ki", "ff"))
    return {
        "mass_kg": float(b.model.body_mass.sum()),
        "time_step_s": float(b.model.opt.timestep),
        "drive_kv": float(kv[0]),
        "drive_kp": float(kp[0]),
        "drive_load_inertia": float(ff[0]),
        "drive_pole_rad_s": float(kv[0] / (2 * ff[0])),
        "steer_kv": float(kv[4]),
        "steer_kp": float(kp[4]),
        "steer_ki": float(ki[4]),
        "steer_inertia": float(ff[4]),
        "steer_w_rad_s": float(kv[4] / (3 * ff[4])),
    }


def main() -> None:
    out = {name: gains(*case) for name, case in CASES.items()}
    print(f"{'vehicle':55s} {'kv':>7s} {'kp':>7s} {'I_load':>7s} {'pole':>6s} {'steer w':>7s}")
    for name, g in out.items():
        print(f"{name:55s} {g['drive_kv']:7.3g} {g['drive_kp']:7.3g} {g['drive_load_inertia']:7.3g} "
              f"{g['drive_pole_rad_s']:6.3g} {g['steer_w_rad_s']:7.3g}")  # fmt: skip
    path = ROOT / "validation" / "results" / "drive_gains.json"
    path.write_text(json.dumps({"date": str(date.today()), "cases": out}, indent=1) + "\n")
    print(f"written: {path}")


if __name__ == "__main__":
    main()
