"""Sizing agrees with itself on a light vehicle: the screen's choice, run in the loop, covers what the screen said.

The robot: sweeps/delivery_robot.yaml (60 kg plus a 0-20 kg payload, 0.10 m wheels, straight climbs of 0-10 deg at
0.5-6 km/h, 400 LHS variants, the ideal servo). The check, in two passes (batchveh.sizing, docs/motors.md):

1. the servo sweep (MuJoCo C), reused where its results are present and hold the same variants;
2. the fast screen of every catalogue motor (notebooks/motors.yaml) at share 0.99: its choice, its coverage and its
   table;
3. in the loop (`in_loop`, the drive's default gains derived per variant, model/drive.py, from the hot steady state)
   on the screen's choice and on the next smaller catalogue motor, steering on a catalogue motor that covers every
   variant's steering demand, with the catalogue's battery.

It reports: the screen's coverage against the in-loop coverage (points; they should agree within AGREE_POINTS),
`not_simulated` (variants whose run failed a physics check), every fails_* count; for the gearhead's torque,
whether a variant failing on it had a drive torque above eta N K i_max, the most the motor can deliver at the wheel
(there should be none); the largest motor_torque_ratio and motor_flip_share and the motor_status counts of each
candidate's last (hot) run. Where a candidate's in-loop run rejects variants, each is listed with its parameters,
reasons, motor_* columns and its drive gains (`_dc.kp`, `_dc.kv` of make_batch's params).

    python validation/sizing_light.py [--n 400] [--out results/delivery_robot] [--json PATH]

Writes validation/results/sizing_light.json (for the default n) and prints a table. On 2 CPU cores: about 1 min
for the servo sweep, about 2.5 min per in-loop candidate (three runs of 400 variants each).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "sweeps" / "delivery_robot.yaml"
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
OUT = ROOT / "results" / "delivery_robot"
JSON = ROOT / "validation" / "results" / "sizing_light.json"
STEER = "maxon-EC45flat-70W-48V_NPT015-i40"  # the catalogue's steering motor (its `use:`); checked below
SHARE = 0.99
AGREE_POINTS = 2.0  # the screen's choice in the loop: within this many points of the screen's coverage
WHEELS = ("drive_lf", "drive_rf", "drive_lr", "drive_rr")
MOTOR_COLS = (
    "motor_status",
    "motor_check",
    "motor_torque_ratio",
    "motor_flip_share",
    "motor_rms_ratio",
    "motor_limited",
)


def servo_sweep(n: int, out: Path) -> tuple[Any, pd.DataFrame, dict]:
    """The servo sweep's first `n` variants (its spec, its rows, how they were got): its results at `out` where
    they hold exactly those variants, else run there on MuJoCo C."""
    import batchveh

    spec = batchveh.load_spec(SPEC)
    full = batchveh.variant_table(spec)
    want = full.iloc[:n].reset_index(drop=True)
    names = list(spec.params)
    if out.exists():
        try:
            df = batchveh.load(out).reset_index(drop=True)
            if len(df) == n and np.allclose(df[names].to_numpy(float), want[names].to_numpy(float)):
                return spec, df, {"reused": True, "wall_s": None, "out": str(out)}
        except Exception as err:  # a damaged or other result: say so, and do not overwrite it
            raise SystemExit(f"{out}: holds results that cannot be reused ({err}); give another --out") from None
        raise SystemExit(f"{out}: holds other variants than the first {n} of {SPEC.name}; give another --out")
    t0 = time.perf_counter()
    batchveh.run_sweep(spec, out=out, backend="mujoco", limit=n if n < len(full) else None, progress=False)
    wall = time.perf_counter() - t0
    df = batchveh.load(out).reset_index(drop=True)
    return spec, df, {"reused": False, "wall_s": wall, "out": str(out)}


def deliverable(name: str) -> float:
    """The most a catalogue motor delivers at the wheel, eta N K i_max (N m)."""
    from batchveh.model.motors import load_catalogue

    c = load_catalogue(CATALOGUE)[name].resolved(name)
    return c["eta"] * c["N"] * c["K"] * c["i_max"]


def drive_torque(d: pd.DataFrame) -> pd.DataFrame:
    """Per variant, the largest of the four drives' |torque| at the wheel: raw peak over the run, low-pass peak,
    RMS over the steady window (N m)."""
    return pd.DataFrame(
        {
            "peak_all": d[[f"{w}_peak_all" for w in WHEELS]].abs().max(axis=1),
            "peak_lp_all": d[[f"{w}_peak_lp_all" for w in WHEELS]].abs().max(axis=1),
            "rms": d[[f"{w}_rms" for w in WHEELS]].abs().max(axis=1),
        }
    )


def drive_gains(spec: Any, d: pd.DataFrame, name: str) -> pd.DataFrame:
    """The drive gains make_batch derives for these variants (`_dc.kp`, `_dc.kv` of the front-left drive; the four
    drives carry the same) with `name` driving and STEER steering, as in_loop builds them."""
    from batchveh.stepping.batch import make_batch

    motors = dataclasses.replace(
        spec.vehicle.motors, model="dcmotor", catalogue=str(CATALOGUE), drive=name, steer=STEER
    )
    vehicle = dataclasses.replace(spec.vehicle, motors=motors)
    table = {k: d[k].to_numpy(float) for k in spec.params}
    params = make_batch(vehicle, spec.scenario, table).params
    kp, kv = np.asarray(params["_dc.kp"]), np.asarray(params["_dc.kv"])
    return pd.DataFrame({"kp": kp[:, 0], "kv": kv[:, 0], "kp_spread": np.ptp(kp[:, :4], axis=1)}, index=d.index)


def candidate_report(
    spec: Any, name: str, row: pd.Series, d: pd.DataFrame, screen_row: pd.Series, screen_failing: pd.DataFrame
) -> dict:
    """One in-loop candidate: its coverage against the screen's, its reasons, its physics checks, and each
    variant it rejects or could not simulate."""
    from batchveh.sizing import IN_LOOP_REASONS
    from batchveh.stepping.motor_stats import TORQUE_TOL

    cap = deliverable(name)
    torque = drive_torque(d)
    above = (torque[["peak_all", "peak_lp_all", "rms"]].max(axis=1) > cap * (1 + TORQUE_TOL)).to_numpy()
    gear = d["fails_gear_torque"].to_numpy(bool)
    gains = drive_gains(spec, d, name)
    reasons = [f"fails_{r}" for r in IN_LOOP_REASONS]
    rejected = d[reasons].any(axis=1).to_numpy() | (d["motor_status"] == "unstable").to_numpy()
    rows = []
    for i in np.flatnonzero(rejected):
        r = d.iloc[i]
        rows.append(
            {
                "variant": int(i),
                **{k: float(r[k]) for k in spec.params},
                "reasons": [x.removeprefix("fails_") for x in reasons if bool(r[x])],
                **{k: (r[k].item() if hasattr(r[k], "item") else r[k]) for k in MOTOR_COLS},
                "speed_shortfall_max": float(r[[f"{w}_speed_shortfall" for w in WHEELS]].max()),
                "at_current_share_max": float(r[[f"{w}_at_current_share" for w in WHEELS]].max()),
                "at_voltage_share_max": float(r[[f"{w}_at_voltage_share" for w in WHEELS]].max()),
                "winding_temp_peak_max": float(r[[f"{w}_winding_temp_peak" for w in WHEELS]].max()),
                "drive_torque_peak_all": float(torque.iloc[i]["peak_all"]),
                "drive_torque_rms": float(torque.iloc[i]["rms"]),
                "dc_kp": float(gains.iloc[i]["kp"]),
                "dc_kv": float(gains.iloc[i]["kv"]),
            }
        )
    loop_out = set(np.flatnonzero(rejected).tolist())
    screen_out = {int(i) for i in screen_failing.index}  # the servo sweep's rows, reset to 0..n-1
    screen_cov = float(screen_row["coverage"])
    loop_cov = float(row["coverage"])
    return {
        "motor": name,
        "continuous_torque_at_wheel": cap,
        "screen_coverage": screen_cov,
        "in_loop_coverage": loop_cov,
        "points": 100 * (loop_cov - screen_cov),
        "not_simulated": int(row["not_simulated"]),
        "fails": {r: int(row[f"fails_{r}"]) for r in IN_LOOP_REASONS},
        "start_rise_median_K": float(row["start_rise_median"]),
        "residual_K": float(row["residual_K"]),
        "screen_rejects": sorted(screen_out),
        "in_loop_rejects": sorted(loop_out),
        "rejected_by_both": len(screen_out & loop_out),
        "gear_torque_fails": int(gear.sum()),
        "gear_torque_fails_above_deliverable": int((gear & above).sum()),
        "variants_above_deliverable": int(above.sum()),
        "drive_torque_max_over_deliverable": float(torque["peak_all"].max() / cap),
        "motor_torque_ratio_max": float(d["motor_torque_ratio"].max()),
        "motor_flip_share_max": float(d["motor_flip_share"].max()),
        "motor_rms_ratio_max": float(d["motor_rms_ratio"].max()),
        "motor_status": {str(k): int(v) for k, v in d["motor_status"].value_counts().items()},
        "motor_check": {str(k or "none"): int(v) for k, v in d["motor_check"].value_counts().items()},
        "dc_drive_kp_range": [float(gains["kp"].min()), float(gains["kp"].max())],
        "dc_drive_kv_range": [float(gains["kv"].min()), float(gains["kv"].max())],
        "rejected": rows,
    }


def run(n: int = 400, out: Path = OUT, battery: bool = True) -> dict:
    """The whole check on the first `n` variants; returns the report (JSON-able)."""
    from batchveh import sizing
    from batchveh.model.motors import load_catalogue

    t_all = time.perf_counter()
    spec, df, servo = servo_sweep(n, Path(out))
    cat = load_catalogue(CATALOGUE)
    # the screen: each variant's own ramp acceleration (smooth_step: 15/8 of speed / ramp_time at its peak) on the
    # rotor inertia a candidate adds over the servo's armature
    r = float(spec.vehicle.wheel.radius)
    ramp = df["ramp_time"] if "ramp_time" in df else float(spec.scenario.ramp_time)
    accel = 1.875 * df["speed_kmh"] / 3.6 / r / ramp
    t0 = time.perf_counter()
    # the ramp a motor at its bound must follow, as the size command screens it
    from batchveh.sizing.ramps import ramp_of

    best, table, failing = sizing.screen(
        df, cat, share=SHARE, armature=spec.vehicle.motors.armature, accel=accel, ramp=ramp_of(spec, df)
    )
    screen_wall = time.perf_counter() - t0
    steer_best, steer_table, _ = sizing.screen(df, cat, share=1.0, group="steer")
    steer_cov = float(steer_table.set_index("motor").loc[STEER, "coverage"])
    report: dict[str, Any] = {
        "check": "sizing agrees with itself on a light vehicle (the screen's choice in the loop, default gains)",
        "spec": str(SPEC.relative_to(ROOT)),
        "catalogue": str(CATALOGUE.relative_to(ROOT)),
        "machine": "2-core CPU",
        "backend": "mujoco (MuJoCo C)",
        "date": datetime.date.today().isoformat(),
        "variants": int(len(df)),
        "vehicle_total_mass_kg_without_payload": float(spec.vehicle.total_mass - spec.vehicle.payload.mass),
        "servo_sweep": {**servo, "status": {str(k): int(v) for k, v in df["status"].value_counts().items()}},
        "share": SHARE,
        "agree_points": AGREE_POINTS,
        "screen": {
            "choice": best,
            "coverage": None if best is None else float(table.set_index("motor").loc[best, "coverage"]),
            "wall_s": screen_wall,
            "table": table.to_dict(orient="records"),
        },
        "steer": {"motor": STEER, "steer_screen_coverage": steer_cov, "steer_screen_choice": steer_best},
    }
    if best is None:
        report["agrees"] = False
        report["wall_s"] = time.perf_counter() - t_all
        return report
    order = table["motor"].tolist()
    candidates = [best] + ([order[order.index(best) - 1]] if order.index(best) > 0 else [])
    loop = []
    bat = sizing.load_battery(CATALOGUE) if battery else None
    for name in candidates:  # one at a time: each its own wall time
        t0 = time.perf_counter()
        _, tab, detail = sizing.in_loop(
            spec, df, CATALOGUE, [name], steer=STEER, share=SHARE, battery=bat, backend="mujoco", stop_at_first=False
        )
        wall = time.perf_counter() - t0
        res = candidate_report(spec, name, tab.iloc[0], detail[name], table.set_index("motor").loc[name], failing[name])
        loop.append({**res, "wall_s": wall})
    chosen = loop[0]
    report["battery"] = bat.name if bat is not None else None
    report["in_loop"] = loop
    report["agrees"] = bool(
        abs(chosen["points"]) <= AGREE_POINTS
        and chosen["not_simulated"] == 0
        and chosen["gear_torque_fails_above_deliverable"] == 0
    )
    report["wall_s"] = time.perf_counter() - t_all
    return report


def _num(x: Any) -> str:
    return f"{x:.6g}" if isinstance(x, float) else str(x)


def print_report(rep: dict) -> None:
    s = rep["screen"]
    sw = rep["servo_sweep"]
    took = "reused" if sw["reused"] else f"{sw['wall_s']:.1f} s"
    print(f"{rep['spec']}: {rep['variants']} variants, servo sweep {sw['status']}, {took}")
    print(f"screen at share {rep['share']}: {s['choice']} covers {s['coverage']}")
    cols = ["motor", "gear_ratio", "continuous_torque_at_wheel", "coverage"] + [
        c for c in s["table"][0] if c.startswith("fails_")
    ]
    print(pd.DataFrame(s["table"])[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(
        f"steering on {rep['steer']['motor']}: covers {rep['steer']['steer_screen_coverage']:.3f} of the "
        f"steering demand (the steer screen's choice at 100%: {rep['steer']['steer_screen_choice']})"
    )
    if "in_loop" not in rep:
        return
    keys = [
        "screen_coverage", "in_loop_coverage", "points", "not_simulated", "gear_torque_fails",
        "gear_torque_fails_above_deliverable", "variants_above_deliverable", "drive_torque_max_over_deliverable",
        "motor_torque_ratio_max", "motor_flip_share_max", "motor_rms_ratio_max", "start_rise_median_K",
        "wall_s",
    ]  # fmt: skip
    rows = {}
    for c in rep["in_loop"]:
        col = {k: _num(c[k]) for k in keys}
        col.update({f"fails_{k}": str(v) for k, v in c["fails"].items()})
        col["rejects: screen, loop, both"] = (
            f"{len(c['screen_rejects'])}, {len(c['in_loop_rejects'])}, {c['rejected_by_both']}"
        )
        col["motor_status"] = ", ".join(f"{k} {v}" for k, v in c["motor_status"].items())
        col["motor_check"] = ", ".join(f"{k} {v}" for k, v in c["motor_check"].items())
        col["dc_drive_kp, kv"] = f"{c['dc_drive_kp_range'][0]:.4g}-{c['dc_drive_kp_range'][1]:.4g}, " \
                                 f"{c['dc_drive_kv_range'][0]:.4g}-{c['dc_drive_kv_range'][1]:.4g}"  # fmt: skip
        rows[c["motor"]] = col
    print(pd.DataFrame(rows).to_string())
    for c in rep["in_loop"]:
        if c["rejected"]:
            print(f"{c['motor']}: {len(c['rejected'])} variants rejected in the loop (first 10):")
            print(pd.DataFrame(c["rejected"][:10]).to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(
        f"agrees: {rep['agrees']} (within {rep['agree_points']} points, none unstable, no gear-torque failure above "
        f"eta N K i_max); {rep['wall_s']:.1f} s in all"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=400, help="the first N variants of the sweep (default all 400)")
    ap.add_argument("--out", type=Path, default=None, help="the servo sweep's results (default results/delivery_robot"
                    " for all 400, else /tmp/sizing_light_<n>)")  # fmt: skip
    ap.add_argument("--json", type=Path, default=None, help="where to write the report (default: "
                    "validation/results/sizing_light.json for all 400, else none)")  # fmt: skip
    ap.add_argument("--no-battery", action="store_true", help="leave the battery's energy and power out")
    args = ap.parse_args(argv)
    out = args.out or (OUT if args.n >= 400 else Path(f"/tmp/sizing_light_{args.n}"))
    rep = run(args.n, out, battery=not args.no_battery)
    print_report(rep)
    path = args.json or (JSON if args.n >= 400 else None)
    if path is not None:
        path.write_text(json.dumps(rep, indent=1, default=str) + "\n")
        print(f"wrote {path}")
    return 0 if rep["agrees"] else 1


if __name__ == "__main__":
    sys.exit(main())
