"""The soil wheel-ground model's study (issue 22): writes validation/results/soil.json and
docs/soil_curves.png (validation/SOIL.md).

- Single-wheel curves: drawbar pull, driving torque and sinkage against slip, each at the
  sinkage where the soil carries the wheel's load (vertical equilibrium), for the presets under
  the seed's wheel (355 N) and for the published wheel test in validation/soil_data/ (its wheel,
  load and soil), against its data.
- Closed forms on the simulated vehicle (MuJoCo C): static sinkage against Bekker's z0, and the
  drive torque of slow rolling in Bekker's distribution against r R_c.
- The dt study: drive means at 2.5, 5, 10 and 20 ms.

    python validation/soil.py
"""

import csv
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from batchveh.engines import make_engine  # noqa: E402
from batchveh.model import soil  # noqa: E402
from batchveh.model.scenarios import make_scenario  # noqa: E402
from batchveh.model.tyres import Tyre  # noqa: E402
from batchveh.model.vehicle import CORNERS, Vehicle, layout  # noqa: E402
from batchveh.stepping import stats  # noqa: E402
from batchveh.stepping.batch import make_batch  # noqa: E402
from batchveh.stepping.rollout import mujoco_steps  # noqa: E402

DATA = ROOT / "validation" / "soil_data"
SLIPS = np.array([-0.3, -0.1, 0.0, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9])


def on(preset: str, **fields) -> Vehicle:
    v = Vehicle(tyre=Tyre(model="soil"))
    return dataclasses.replace(v, soil=dataclasses.replace(v.soil, preset=preset, **soil.PRESETS[preset], **fields))


def wheel_params(radius, width, so) -> dict:
    """soil.params' inputs for one wheel of radius and width in the soil `so` (a mapping of the
    soil's fields)."""
    p = {"wheel.width": width, "wheel.radius": radius, "wheel.mass": 1.0, "hub.mass": 0.0, "chassis.mass": 0.0}
    p.update({"payload.mass": 0.0, "_drive_armature": 0.0, "tyre.relaxation_length": 0.05, "gravity": 9.81})
    p.update({f"soil.{k}": so[k] for k in ("n", "k_c", "k_phi", "c", "phi", "K", "c1", "c2", "c3")})
    return soil.params({k: np.array([x], float) for k, x in p.items()})


def equilibrium(sp, load, slip):
    """DP, T and sinkage at `slip` where the soil carries `load` (N)."""

    def at(z):
        out = soil.integrate(np.array([z]), np.array([slip / (1 - slip)]), np.zeros(1), np.ones(1), sp)
        return {k: float(np.ravel(x)[0]) for k, x in out.items()}

    r = float(np.ravel(sp["radius"])[0])
    z = brentq(lambda z: at(z)["W"] - load, 1e-7, 0.999 * r, xtol=1e-10)
    o = at(z)
    return {"slip": float(slip), "drawbar_pull_N": o["DP"], "torque_Nm": o["T"], "sinkage_m": z}


def curves(sp, load, slips=SLIPS):
    return [equilibrium(sp, load, s) for s in slips]


def published():
    """The published wheel test in validation/soil_data/ against the model at its wheel, load and
    soil: (description, rows with the model beside the data), or None where it is absent."""
    meta_path, csv_path = DATA / "wheel_test.json", DATA / "wheel_test.csv"
    if not (meta_path.exists() and csv_path.exists()):
        return None
    meta = json.loads(meta_path.read_text())
    so = {**soil.WONG_REECE, **meta["soil"]}
    sp = wheel_params(meta["radius_m"], meta["width_m"], so)
    with csv_path.open() as f:
        data = [{k: float(v) if v not in ("", None) else None for k, v in row.items()} for row in csv.DictReader(f)]
    variants = {
        name: wheel_params(meta["radius_m"], meta["width_m"], {**so, **v})
        for name, v in meta.get("variants", {}).items()
    }
    rows = []
    for d in data:
        m = equilibrium(sp, meta["load_N"], d["slip"])
        dp = d["drawbar_pull_N"]
        row = {"data": d, "model": m, "drawbar_pull_relative_error": (m["drawbar_pull_N"] - dp) / abs(dp)}
        row["variants"] = {name: equilibrium(v, meta["load_N"], d["slip"]) for name, v in variants.items()}
        rows.append(row)
    return meta, rows


def drive(vehicle, table, sc, backend="mujoco"):
    batch = make_batch(vehicle, sc, table)
    cfg = stats.StatsConfig.for_scenario(sc, (3.0, sc.total_time), slip_limit=stats.slip_limit(vehicle))
    cols = make_engine(backend, sc, cfg, batch.n, precision="f64").run(batch)
    return np.stack([cols[f"drive_{c}_mean"] for c in CORNERS], 1), cols


def closed_forms():
    out = {}
    for preset in ("dry_sand", "lunar_soil", "toyoura_sand"):
        v = on(preset)
        sc = make_scenario("straight_line", speed_kmh=0.0, total_time=3.0, settle_time=0.0)
        batch = make_batch(v, sc, {})
        params = {k: float(x[0]) for k, x in batch.params.items()}
        for step in mujoco_steps(batch.model, params, scenario=sc, n_steps=sc.n_steps):
            d = step[0]
        lay = layout(batch.model)
        sink = v.wheel.radius - d.xpos[lay.wheel_bodies, 2]
        load = float(batch.model.body_subtreemass[lay.chassis_body]) * 9.81 / 4  # the seed is balanced
        sp = wheel_params(v.wheel.radius, v.wheel.width, {**dataclasses.asdict(v.soil)})
        z0 = float(np.ravel(soil.bekker_sinkage(load, sp))[0])
        rc = float(np.ravel(soil.compaction_resistance(z0, sp))[0])
        bekker = dataclasses.replace(v, soil=dataclasses.replace(v.soil, c1=0.0, c2=0.0, c3=0.0))
        sc = make_scenario("straight_line", speed_kmh=1.0, total_time=6.0, ramp_time=1.0)
        means, cols = drive(bekker, {"speed_kmh": np.array([1.0])}, sc)
        wr, _ = drive(v, {"speed_kmh": np.array([1.0])}, sc)
        out[preset] = {
            "load_per_wheel_N": load,
            "static_sinkage_m": sink.tolist(),
            "bekker_z0_m": z0,
            "sinkage_over_z0": (sink / z0).tolist(),
            "bekker_rolling_drive_sum_Nm": float(means.sum()),
            "r_times_4_Rc_Nm": 4 * v.wheel.radius * rc,
            "ratio": float(means.sum() / (4 * v.wheel.radius * rc)),
            "bekker_rolling_slip": float(cols["slip_ratio"][0]),
            "wong_reece_rolling_drive_sum_Nm": float(wr.sum()),
        }
        print(preset, out[preset])
    return out


def dt_study():
    v = on("lunar_soil")
    table = {"slope_deg": np.array([0.0, 10.0]), "gravity": np.array([1.62, 1.62])}
    rows = {}
    for dt in (0.0025, 0.005, 0.01, 0.02):
        sc = make_scenario("straight_line", total_time=6.0, ramp_time=1.0, time_step=dt)
        means, _ = drive(v, table, sc)
        rows[str(dt)] = means.tolist()
    ref = np.array(rows["0.0025"])
    worst = max(float(np.abs(np.array(m) - ref).max() / np.abs(ref).max()) for m in rows.values())
    print("dt study, largest change against 2.5 ms:", worst)
    return {"drive_means_Nm": rows, "largest_change": worst}


def figure(result, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(17, 3.8))
    for preset, rows in result["curves"].items():
        s = [r["slip"] for r in rows]
        for ax, key in zip(axes, ("drawbar_pull_N", "torque_Nm", "sinkage_m"), strict=False):
            ax.plot(s, [r[key] for r in rows], label=preset)
    pub = result.get("published")
    if pub:
        # the published wheel test on a panel of its own (its forces are a few newtons): the data,
        # the authors' own theory curve at the same load, the model at the test's wheel and soil
        s = [r["data"]["slip"] for r in pub["rows"]]
        c3 = pub["meta"]["soil"]["c3"]
        ax = axes[3]
        ax.plot(s, [r["data"]["drawbar_pull_N"] for r in pub["rows"]], "ko", label="Yoshida et al. 2003, 24.5 N")
        with (DATA / "wheel_test_all_loads.csv").open() as f:
            theory = [
                r for r in csv.DictReader(f) if r["kind"] == "theory" and float(r["load_N"]) == pub["meta"]["load_N"]
            ]
        ax.plot(
            [float(r["slip"]) for r in theory],
            [float(r["drawbar_pull_N"]) for r in theory],
            "g-",
            label="the authors' theory",
        )
        ax.plot(s, [r["model"]["drawbar_pull_N"] for r in pub["rows"]], "k--", label=f"model, c3 {c3:g}")
        for name in pub["rows"][0]["variants"]:
            ax.plot(
                s,
                [r["variants"][name]["drawbar_pull_N"] for r in pub["rows"]],
                "k:",
                label=f"model, {name.split(' (')[0]}",
            )
        ax.fill_between(
            s,
            [0.8 * r["data"]["drawbar_pull_N"] for r in pub["rows"]],
            [1.2 * r["data"]["drawbar_pull_N"] for r in pub["rows"]],
            color="0.85",
            label="data +-20%",
        )
        ax.legend(fontsize=7)
        for ax, key in zip(axes[1:3], ("torque_Nm", "sinkage_m"), strict=True):
            ax.plot(
                s, [r["model"][key] for r in pub["rows"]], "k--", label=f"published test's wheel (model, c3 {c3:g})"
            )
        axes[2].legend(fontsize=7)
    titles = ("drawbar pull, N", "driving torque, N m", "sinkage, m", "published single-wheel test: drawbar pull, N")
    for ax, title in zip(axes, titles, strict=True):
        ax.set_xlabel("slip ratio")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    result = {"curves": {}}
    v = Vehicle()
    for preset in soil.PRESETS:
        sp = wheel_params(v.wheel.radius, v.wheel.width, {**soil.PRESETS[preset], **soil.WONG_REECE})
        result["curves"][preset] = curves(sp, 355.0)
    pub = published()
    if pub is not None:
        meta, rows = pub
        errs = [
            abs(r["model"][k] - r["data"][k]) / max(abs(r["data"][k]), 1e-9)
            for r in rows
            for k in ("drawbar_pull_N", "torque_Nm")
            if r["data"].get(k) is not None
        ]
        within = sum(abs(r["drawbar_pull_relative_error"]) <= 0.2 for r in rows)
        result["published"] = {
            "meta": meta,
            "rows": rows,
            "largest_relative_error": max(errs),
            "points_within_20_percent": within,
        }
        print("published test, largest relative error:", max(errs), f"within 20%: {within} of {len(rows)}")
        for r in rows:
            print(
                f"  slip {r['data']['slip']:.3f}: data {r['data']['drawbar_pull_N']:.2f} N, "
                f"model {r['model']['drawbar_pull_N']:.2f} N "
                f"({100 * r['drawbar_pull_relative_error']:+.0f}%), torque {r['model']['torque_Nm']:.3f} N m, "
                + ", ".join(f"{n.split(' (')[0]}: {v['drawbar_pull_N']:.2f} N" for n, v in r["variants"].items())
            )
    result["closed_forms"] = closed_forms()
    result["dt_study"] = dt_study()
    (ROOT / "validation" / "results" / "soil.json").write_text(json.dumps(result, indent=1) + "\n")
    figure(result, ROOT / "docs" / "soil_curves.png")


if __name__ == "__main__":
    main()
