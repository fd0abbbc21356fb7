"""The steering layouts (issue 64) against closed forms, across engines and motor models: writes
validation/results/layouts.json (validation/LAYOUTS.md). Every run, closed form and tolerance is
tests/test_layouts.py's, so the study and the tests measure the same way.

    python validation/layouts.py                 # the physics, motor models and bad input (about 1 min, 2 cores)
    python validation/layouts.py --engines       # also MuJoCo C against MJX and the warp engine (CPU, ~2 min)
    python validation/layouts.py --four-wheel BASE HEAD   # also compare two results of sweeps/slope.yaml
    python validation/layouts.py --hub-lock 0.01 1e-4     # also the dcmotor cases with ffec2a4's HUB_LOCK

Sections not asked for are kept from the JSON already there. The four-wheel check compares the seed's default
slope sweep run at the commit before the layouts (d6893de) and at the layouts' commit, column by column:

    git worktree add /tmp/base d6893de && cd /tmp/base
    PYTHONPATH=. python -m batchveh.sweep sweeps/slope.yaml --backend mujoco --out /tmp/slope_base --quiet
    (the same in a worktree of the later commit, into /tmp/slope_head)
    python validation/layouts.py --four-wheel /tmp/slope_base /tmp/slope_head
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import test_layouts as T  # noqa: E402
import test_mjx as T_mjx  # noqa: E402
import test_warp as T_warp  # noqa: E402

from batchveh.model.scenarios import make_scenario  # noqa: E402
from batchveh.model.vehicle import CORNERS, MOTORS  # noqa: E402
from batchveh.run import simulate  # noqa: E402

OUT = ROOT / "validation" / "results" / "layouts.json"


def _plain(x):
    """numpy scalars as Python's."""
    return x.item() if hasattr(x, "item") else float(x)


def _err(sim, ref) -> float:
    return float(sim / ref - 1.0)


def _entry(sim, ref) -> dict:
    return {"simulated": float(sim), "closed_form": float(ref), "error": _err(sim, ref)}


def _wheels(sim, ref) -> dict:
    return {c: _entry(s, r) for c, s, r in zip(CORNERS, sim, np.broadcast_to(ref, 4), strict=True)}


def _geometry(v) -> dict:
    a, b = v.wheel.x_cg, v.wheel.y_cg
    return {
        "mass_kg": v.total_mass,
        "wheelbase_m": 2 * a,
        "track_m": 2 * b,
        "L_over_B": a / b,
        "wheel_radius_m": v.wheel.radius,
        "hinge_m": list(T.hinge(v)),
        "normal_load_N": T.normal_load(v),
    }


def pivots() -> list[dict]:
    """Each skid pivot of tests/test_layouts.py's PIVOTS against the Coulomb and Wong forms."""
    out = []
    for name, mu, rate in T.PIVOTS:
        res = T.skid_pivot(name, mu, rate)
        v, s = res.vehicle, res.stats
        drive = T.means(s)
        coulomb, wong = T.skid_coulomb_torque(v, mu), T.wong_torque(v, mu)
        hold = T.skid_hub_moment(v, mu, np.sign(rate))
        w = res.series[res.series.time >= T.STEADY]
        steady_angle = np.rad2deg(np.abs(w[[f"alpha_{c}" for c in CORNERS]].to_numpy()).mean())
        out.append(
            {
                "vehicle": name,
                "case": "skid pivot",
                "friction": mu,
                "yaw_rate_dps": rate,
                **_geometry(v),
                "status_code": int(s["status_code"]),
                "drive_Nm": _wheels(drive, -T.SY * np.sign(rate) * coulomb),
                "mean_abs_drive_Nm": _entry(np.abs(drive).mean(), coulomb),
                "drive_sum_Nm": float(s["drive_sum_mean"]),
                "wong_Nm": {
                    "closed_form": wong,
                    "simulated_mean": float(np.abs(drive).mean()),
                    "wong_over_simulated": wong / float(np.abs(drive).mean()),
                    "sqrt_1_plus_L_over_B_sq": float(np.hypot(1, v.wheel.x_cg / v.wheel.y_cg)),
                },
                "yaw_rate_rad_s": _entry(T.steady_rate(res.series, T.STEADY), np.deg2rad(rate) * T.skid_yaw_share(v)),
                "skid_factor": 1.0 / T.skid_yaw_share(v),
                "hub_Nm": _wheels(T.means(s, "steer"), hold),
                "hub_steady_angle_deg": _entry(steady_angle, np.rad2deg(abs(hold) / v.motors.steer_kp)),
                "hub_max_angle_deg": T.hub_angles(res.series),
            }
        )
    return out


def turns() -> list[dict]:
    """Skid turns at 1 km/h, mu 0.6 over a range of radii: each side against the Coulomb form, each wheel against
    the slip tyre's steady state, the wide turns against the linear brush."""
    out = []
    radii = {"robot_30kg": (0.3, 0.6, -0.6, 1.0, 2.0, 4.0, 10.0, 100.0), "agv_250kg": (0.6, 2.0, -4.0, 10.0)}
    for name, rs in radii.items():
        for radius in rs:
            res = T.skid_turn(name, T.TURN_MU, radius)
            v, s = res.vehicle, res.stats
            drive = T.means(s)
            inner = T.SY == np.sign(radius)
            ref = T.brush_turn(v, T.TURN_MU, radius, 1.0)
            coulomb = T.skid_coulomb_torque(v, T.TURN_MU)
            linear = T.skid_linear_torque(v, radius, v.tyre.slip_stiffness)
            sat = T.saturation_radius(v, T.TURN_MU, v.tyre.slip_stiffness)
            a, b, r = v.wheel.x_cg, v.wheel.y_cg, v.wheel.radius
            moment = -(T.SY * b * drive / r).sum() * np.sign(radius)
            w = res.series[res.series.time >= T.STEADY]
            _, _, path = T.circle_fit(w.x.to_numpy(), w.y.to_numpy())
            yaw = T.steady_rate(res.series, T.STEADY)
            out.append(
                {
                    "vehicle": name,
                    "case": "skid turn",
                    "turn_radius_m": radius,
                    "speed_kmh": 1.0,
                    "friction": T.TURN_MU,
                    **_geometry(v),
                    "status_code": int(s["status_code"]),
                    "saturation_radius_m": sat,
                    "saturated": bool(abs(radius) < sat),
                    "inner": {
                        "simulated": float(drive[inner].mean()),
                        "coulomb": -coulomb,
                        "brush": float(ref["torque"][inner].mean()),
                        "error_vs_coulomb": _err(-drive[inner].mean(), coulomb),
                        "error_vs_brush": _err(drive[inner].mean(), ref["torque"][inner].mean()),
                    },
                    "outer": {
                        "simulated": float(drive[~inner].mean()),
                        "coulomb": coulomb,
                        "brush": float(ref["torque"][~inner].mean()),
                        "error_vs_coulomb": _err(drive[~inner].mean(), coulomb),
                        "error_vs_brush": _err(drive[~inner].mean(), ref["torque"][~inner].mean()),
                    },
                    "linear_brush_Nm": linear,
                    "drive_Nm_vs_brush": _wheels(drive, ref["torque"]),
                    "drive_sum_Nm": float(s["drive_sum_mean"]),
                    "drive_sum_over_coulomb": float(s["drive_sum_mean"]) / coulomb,
                    "moment_Nm": _entry(moment, 4 * T.TURN_MU * T.normal_load(v) * a * b / np.hypot(a, b)),
                    "yaw_rate_rad_s": {
                        "simulated": yaw,
                        "brush": ref["yaw"],
                        "coulomb": 1 / 3.6 / radius * T.skid_yaw_share(v),
                        "error_vs_brush": _err(yaw, ref["yaw"]),
                    },
                    "path_radius_m": {
                        "simulated": path,
                        "commanded": abs(radius),
                        "closed_form": abs(radius) / T.skid_yaw_share(v),
                        "error": _err(path, abs(radius) / T.skid_yaw_share(v)),
                    },
                    "hub_max_angle_deg": T.hub_angles(res.series),
                }
            )
    return out


def straight_limit() -> dict:
    """A 10 km skid turn against the straight line, rolling resistance 0.02 (test_wide_skid_turn_...)."""
    name, radius, c_rr = "robot_30kg", 1.0e4, 0.02
    extra = {"wheel": {**T.GEOMETRY[name]["wheel"], "rolling_resistance": c_rr}}
    turn = T.skid_turn(name, T.TURN_MU, radius, **extra)
    line = simulate(
        turn.vehicle,
        make_scenario("straight_line", friction=T.TURN_MU, **T.TURN),
        window=(T.STEADY, T.TURN["total_time"]),
    )
    v = turn.vehicle
    apart = (T.means(turn.stats) - T.means(line.stats)) * -T.SY
    return {
        "vehicle": name,
        "turn_radius_m": radius,
        "rolling_resistance": c_rr,
        "straight_drive_Nm": T.means(line.stats).tolist(),
        "straight_sum_Nm": _entry(float(line.stats["drive_sum_mean"]), 4 * c_rr * T.normal_load(v) * v.wheel.radius),
        "turn_drive_Nm": T.means(turn.stats).tolist(),
        "turn_minus_straight_Nm": _wheels(apart, T.skid_linear_torque(v, radius, v.tyre.slip_stiffness)),
    }


def demand() -> list[dict]:
    """Each skid vehicle's pivot torque per wheel against its straight-line demand on the flat (rolling resistance
    0.02) and on a 5 deg ramp (no rolling resistance), the same friction 0.6: how many times more the turn asks."""
    out = []
    for name in ("robot_30kg", "robot_60kg", "agv_250kg", "rover_1t"):
        pivot = T.skid_pivot(name, 0.6, 20.0)
        flat_v = T.vehicle(name, "skid", wheel={**T.GEOMETRY[name]["wheel"], "rolling_resistance": 0.02})
        window = (T.STEADY, T.TURN["total_time"])
        flat = simulate(flat_v, make_scenario("straight_line", friction=0.6, **T.TURN), window=window)
        ramp = simulate(
            pivot.vehicle, make_scenario("straight_line", friction=0.6, slope_deg=5.0, **T.TURN), window=window
        )
        turn = float(np.abs(T.means(pivot.stats)).mean())
        f, r = float(flat.stats["drive_sum_mean"]) / 4, float(ramp.stats["drive_sum_mean"]) / 4
        out.append(
            {
                "vehicle": name,
                "pivot_Nm": turn,
                "flat_crr_0.02_Nm": f,
                "ramp_5deg_Nm": r,
                "pivot_over_flat": turn / f,
                "pivot_over_ramp": turn / r,
            }
        )
    return out


def fronts() -> list[dict]:
    out = []
    for name, steering, radius, kmh in T.FRONTS:
        v = T.vehicle(name, "front", steering=steering)
        res = T.front_turn(v, radius, kmh)
        ser = res.series
        w = ser[ser.time >= T.FRONT_STEADY]
        got = w[["alpha_lf", "alpha_rf"]].mean().to_numpy()
        expect = [T.front_angle(v, radius, sy) for sy in (1.0, -1.0)]
        a = v.wheel.x_cg
        big = np.hypot(a, radius)
        cx, cy, fitted = T.circle_fit(w.x.to_numpy(), w.y.to_numpy())
        dx, dy, yaw = cx - w.x.to_numpy(), cy - w.y.to_numpy(), w.yaw.to_numpy()
        local = np.array([np.cos(yaw) * dx + np.sin(yaw) * dy, -np.sin(yaw) * dx + np.cos(yaw) * dy]).mean(axis=1)
        out.append(
            {
                "vehicle": name,
                "case": "front Ackermann",
                "steering": steering,
                "turn_radius_m": radius,
                "speed_kmh": kmh,
                **_geometry(v),
                "status_code": int(res.stats["status_code"]),
                "trail_m": {c: g["trail"] for c, g in v.steering_geometry().items()},
                "angle_deg": {
                    c: _entry(np.rad2deg(g), np.rad2deg(e)) for c, g, e in zip(("lf", "rf"), got, expect, strict=True)
                },
                "angle_tan_form_deg": [float(np.rad2deg(T.ackermann_tan(v, radius, sy))) for sy in (1.0, -1.0)],
                "yaw_rate_rad_s": _entry(T.steady_rate(ser, T.FRONT_STEADY), np.sign(radius) * kmh / 3.6 / big),
                "path_radius_m": _entry(fitted, big),
                "centre_in_chassis_m": {
                    "simulated": local.tolist(),
                    "closed_form": [-a, radius],
                    "miss_over_radius": float(np.hypot(local[0] + a, local[1] - radius) / big),
                },
                "rear_hub_max_angle_deg": T.hub_angles(ser, ("lr", "rr")),
                "drive_Nm": T.means(res.stats).tolist(),
                "steer_Nm": T.means(res.stats, "steer").tolist(),
            }
        )
    return out


def dcmotors() -> list[dict]:
    from batchveh.engines.mujoco import MujocoEngine
    from batchveh.stepping import stats
    from batchveh.stepping.batch import make_batch
    from batchveh.stepping.motor_stats import MOTOR_STATUS, MotorStatsConfig

    out = []
    for case, (name, layout, motors, kind, kw) in T.DC_CASES.items():
        sc = make_scenario(kind, **{**T.FRONT_TURN, **kw})
        window = (T.FRONT_STEADY, sc.total_time)
        servo = simulate(T.vehicle(name, layout), sc, window=window)
        v = T.vehicle(name, layout, motors={"model": "dcmotor", "catalogue": str(T.CATALOGUE), **motors})
        dc = simulate(v, sc, window=window)
        cfg = stats.StatsConfig.for_scenario(sc, window, motors=MotorStatsConfig.for_vehicle(v))
        batch = make_batch(v, sc, {"friction": np.array([sc.friction])})
        cols = MujocoEngine(sc, cfg, 1).run(batch)
        fixed = [c for c, s in zip(CORNERS, v.steering.steered, strict=True) if not s]
        scale = float(np.abs(T.means(servo.stats)).max())
        out.append(
            {
                "case": case,
                "vehicle": name,
                "layout": layout,
                "motors": motors,
                "scenario": kind,
                **kw,
                "status_code": [int(servo.stats["status_code"]), int(dc.stats["status_code"])],
                "motor_status": MOTOR_STATUS[int(cols["motor_status_code"][0])],
                "steer_slots_kp_kv_ki": [
                    np.asarray(batch.params[f"_dc.{k}"])[0, 4:].tolist() for k in ("kp", "kv", "ki")
                ],
                "fixed_hub_max_angle_deg": {
                    "servo": T.hub_angles(servo.series, fixed),
                    "dcmotor": T.hub_angles(dc.series, fixed),
                },
                "drive_Nm": {"servo": T.means(servo.stats).tolist(), "dcmotor": T.means(dc.stats).tolist()},
                "steer_Nm": {
                    "servo": T.means(servo.stats, "steer").tolist(),
                    "dcmotor": T.means(dc.stats, "steer").tolist(),
                },
                "largest_drive_difference_over_largest_drive": float(
                    np.abs(T.means(dc.stats) - T.means(servo.stats)).max()
                )
                / scale,
            }
        )
    return out


def engines() -> list[dict]:
    """MuJoCo C against the warp engine (two variants) and MJX (float32 and float64) on each ENGINE_CASES case."""
    from batchveh.engines.mujoco import MujocoEngine
    from batchveh.engines.warp import WarpEngine
    from batchveh.stepping import stats
    from batchveh.stepping.batch import make_batch

    suffixes = ("_mean", "_rms", "_peak", "_peak_lp", "_peak_all", "_peak_lp_all")
    out = []
    for case in T.ENGINE_CASES:
        v, sc = T.engine_case(case)
        table = {"friction": np.array([sc.friction, sc.friction + 0.1])}
        cfg = stats.StatsConfig.for_scenario(sc, T.ENGINE_WINDOW)
        t0 = time.perf_counter()
        w = WarpEngine(sc, cfg, 2).run(make_batch(v, sc, table))
        t_warp = time.perf_counter() - t0
        c = MujocoEngine(sc, cfg, 2).run(make_batch(v, sc, table))
        warp = {"seconds": t_warp, "status_equal": bool(np.array_equal(w["status_code"], c["status_code"]))}
        for kind in ("drive", "steer"):
            ms = [m for m in MOTORS if m.startswith(kind)]
            diff = np.array([np.abs(np.asarray(w[m + s]) - np.asarray(c[m + s])) for m in ms for s in suffixes])
            mag = np.array([np.abs(np.asarray(c[m + s])) for m in ms for s in suffixes])
            smooth = np.array([s != "_peak_all" for m in ms for s in suffixes])
            rtol, atol = T_warp.MOTOR_TOL[kind]
            warp[kind] = {
                "max_abs_Nm": float(diff.max()),
                "largest_Nm": float(mag.max()),
                "max_abs_without_peak_all_Nm": float(diff[smooth].max()),
                "peak_all_max_abs_Nm": float(diff[~smooth].max()),
                "worst_over_motor_tol_without_peak_all": float((diff / (atol + rtol * mag))[smooth].max()),
            }
        warp["drive_sum_mean_abs_Nm"] = float(np.abs(np.asarray(w["drive_sum_mean"]) - c["drive_sum_mean"]).max())
        warp["drive_sum_mean_rel"] = float(
            (
                np.abs(np.asarray(w["drive_sum_mean"]) - c["drive_sum_mean"])
                / np.maximum(np.abs(c["drive_sum_mean"]), 1e-12)
            ).max()
        )
        warp["drive_sum_mean_C_Nm"] = np.asarray(c["drive_sum_mean"]).tolist()
        for key in ("slip_ratio", "mean_speed"):
            warp[f"{key}_max_abs"] = float(np.abs(np.asarray(w[key]) - c[key]).max())
        cs = simulate(v, sc, backend="mujoco", window=T.ENGINE_WINDOW)
        t0 = time.perf_counter()
        j = simulate(v, sc, backend="mjx", window=T.ENGINE_WINDOW)
        t_mjx = time.perf_counter() - t0
        d = simulate(v, sc, backend="mjx", precision="f64")
        a, b = cs.series[list(MOTORS)].to_numpy(), j.series[list(MOTORS)].to_numpy()
        smooth = ~T.kinks(sc, cs.series.time)
        mjx = {
            "seconds_f32": t_mjx,
            "status_equal": bool(cs.stats["status_code"] == j.stats["status_code"]),
            "series_rms_share": float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(a**2))),
            "series_rms_share_away_from_kinks": float(
                np.sqrt(np.mean((a[smooth] - b[smooth]) ** 2)) / np.sqrt(np.mean(a[smooth] ** 2))
            ),
            "series_max_abs_Nm": float(np.abs(a - b).max()),
            "series_max_abs_away_from_kinks_Nm": float(np.abs(a[smooth] - b[smooth]).max()),
            "f64_series_max_abs_Nm": float(np.abs(a - d.series[list(MOTORS)].to_numpy()).max()),
        }
        for kind in ("drive", "steer"):
            ms = [m for m in MOTORS if m.startswith(kind)]
            diff = np.array([abs(j.stats[f"{m}_mean"] - cs.stats[f"{m}_mean"]) for m in ms])
            mag = np.array([abs(cs.stats[f"{m}_mean"]) for m in ms])
            rtol, atol = T_mjx.F32_MOTOR_MEAN_TOL[kind]
            mjx[kind] = {
                "mean_max_abs_Nm": float(diff.max()),
                "mean_max_rel": float((diff / np.maximum(mag, 1e-12)).max()),
                "largest_mean_Nm": float(mag.max()),
                "worst_over_test_mjx_F32_MOTOR_MEAN_TOL": float((diff / (atol + rtol * mag)).max()),
            }
        out.append(
            {
                "case": case,
                "vehicle": T.ENGINE_CASES[case][0],
                "layout": T.ENGINE_CASES[case][1],
                "scenario": sc.kind,
                "warp_vs_c": warp,
                "mjx_vs_c": mjx,
            }
        )
        print(case, json.dumps(out[-1], default=_plain), flush=True)
    # the same Ackermann turn on the four-wheel layout (its rear hubs steer 0 there too): the whole-run peak's
    # float32 rounding at the steering ramp's kinks is not the front layout's
    name, _, kind, kw = T.ENGINE_CASES["front_ackermann"]
    v = T.vehicle(name, "four_wheel")
    sc = make_scenario(kind, **{**T.ENGINE_RUN, **kw})
    table = {"friction": np.array([sc.friction, sc.friction + 0.1])}
    cfg = stats.StatsConfig.for_scenario(sc, T.ENGINE_WINDOW)
    w, c = (E(sc, cfg, 2).run(make_batch(v, sc, table)) for E in (WarpEngine, MujocoEngine))
    out.append(
        {
            "case": "four_wheel_ackermann (reference)",
            "vehicle": name,
            "layout": "four_wheel",
            "scenario": kind,
            "warp_vs_c": {
                "status_equal": bool(np.array_equal(w["status_code"], c["status_code"])),
                **{
                    f"{k}_peak_all_max_abs_Nm": max(
                        float(np.abs(np.asarray(w[f"{k}_{x}_peak_all"]) - c[f"{k}_{x}_peak_all"]).max())
                        for x in CORNERS
                    )
                    for k in ("drive", "steer")
                },
            },
        }
    )
    return out


def bad_input() -> list[dict]:
    """Each BAD case through both commands as processes: exit code and the line."""
    import tempfile

    import yaml

    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for case, (steering, kind, _) in T.BAD.items():
            raw = {**T.GEOMETRY["robot_30kg"], "steering": steering}
            veh = Path(tmp) / f"{case}_vehicle.yaml"
            veh.write_text(yaml.safe_dump(raw, sort_keys=False))
            spec = Path(tmp) / f"{case}_spec.yaml"
            spec.write_text(
                yaml.safe_dump(
                    {
                        "name": case,
                        "scenario": kind,
                        "vehicle": raw,
                        "fixed": {"total_time": 1.0, "ramp_time": 0.5},
                        "sweep": {"method": "grid", "params": {"friction": [0.5, 0.9]}},
                        "output": str(Path(tmp) / "o"),
                    },
                    sort_keys=False,
                )
            )
            for command, argv in (
                ("run", [kind, "--vehicle", str(veh), "--out", str(Path(tmp) / "o")]),
                ("sweep", [str(spec), "--quiet"]),
            ):
                p = subprocess.run(
                    [sys.executable, "-m", f"batchveh.{command}", *argv], capture_output=True, text=True, cwd=ROOT
                )
                line = p.stderr.strip().replace(tmp, "TMP")
                out.append(
                    {
                        "case": case,
                        "command": command,
                        "exit": p.returncode,
                        "lines": len(p.stderr.strip().splitlines()),
                        "stdout": p.stdout,
                        "stderr": line,
                    }
                )
    return out


def four_wheel(base: Path, head: Path) -> dict:
    """The slope sweep's results at two commits, column by column, bit for bit."""
    import batchveh

    a, b = (batchveh.load(str(p)).sort_values("variant").reset_index(drop=True) for p in (base, head))
    differ = []
    for col in a.columns:
        x, y = a[col].to_numpy(), b[col].to_numpy()
        same = np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f" else bool((x == y).all())
        if not same:
            differ.append(col)

    def digest(df):
        import pandas as pd

        return hashlib.sha256(pd.util.hash_pandas_object(df, index=False).to_numpy().tobytes()).hexdigest()

    def commit(p):
        m = json.loads((Path(p) / "manifest.json").read_text())
        return {k: m.get(k) for k in ("commit", "git_commit", "version", "backend", "implementation") if k in m}

    return {
        "spec": "sweeps/slope.yaml",
        "backend": "mujoco",
        "rows": [len(a), len(b)],
        "columns": [len(a.columns), len(b.columns)],
        "same_columns": list(a.columns) == list(b.columns),
        "differing_columns": differ,
        "sha256_of_rows": [digest(a), digest(b)],
        "manifests": [commit(base), commit(head)],
        "drive_sum_mean_total_Nm": [float(a.drive_sum_mean.sum()), float(b.drive_sum_mean.sum())],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engines", action="store_true", help="also MuJoCo C against MJX and the warp engine")
    ap.add_argument("--only-engines", action="store_true", help="only MuJoCo C against MJX and the warp engine")
    ap.add_argument("--four-wheel", nargs=2, type=Path, metavar=("BASE", "HEAD"), help="two slope sweep results")
    ap.add_argument(
        "--hub-lock",
        nargs=2,
        type=float,
        metavar=("OHM", "KG_M2"),
        help="also the dcmotor cases with HUB_LOCK's terminal resistance and rotor inertia replaced",
    )
    ap.add_argument("--base-commit", default="d6893de")
    ap.add_argument("--head-commit", default="")
    args = ap.parse_args()
    result = json.loads(OUT.read_text()) if OUT.exists() else {}
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT).stdout
    import mujoco

    result["machine"] = (
        f"this project's {len(os.sched_getaffinity(0))}-core CPU machine ({platform.machine()}), "
        f"MuJoCo {mujoco.__version__}, at commit {commit.strip()}"
    )
    ends = ("RTOL", "ATOL", "DEG", "SHARE", "BAND", "TOL")
    result["tolerances"] = {k: getattr(T, k) for k in dir(T) if k.isupper() and k.endswith(ends)}
    t0 = time.perf_counter()
    if not args.only_engines:
        result["pivot"] = pivots()
        result["turn"] = turns()
        result["straight_limit"] = straight_limit()
        result["demand"] = demand()
        result["front"] = fronts()
        result["dcmotor"] = dcmotors()
        if args.hub_lock:
            import dataclasses

            import batchveh.model.vehicle as vm

            kept = vm.HUB_LOCK
            vm.HUB_LOCK = dataclasses.replace(
                kept, terminal_resistance=args.hub_lock[0], rotor_inertia=args.hub_lock[1]
            )
            try:
                result.pop("dcmotor_suggested_hub_lock", None)
                result["dcmotor_hub_lock_replaced"] = {
                    "terminal_resistance": args.hub_lock[0],
                    "rotor_inertia": args.hub_lock[1],
                    "cases": dcmotors(),
                }
            finally:
                vm.HUB_LOCK = kept
        result["bad_input"] = bad_input()
    if args.engines or args.only_engines:
        result["engines"] = engines()
    if args.four_wheel:
        result["four_wheel_unchanged"] = {
            "base_commit": args.base_commit,
            "head_commit": args.head_commit,
            **four_wheel(*args.four_wheel),
        }
    result["seconds"] = time.perf_counter() - t0
    OUT.write_text(json.dumps(result, indent=1, default=_plain) + "\n")
    print(f"wrote {OUT} in {result['seconds']:.0f} s")


if __name__ == "__main__":
    main()
