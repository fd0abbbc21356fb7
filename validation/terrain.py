"""Terrain: which engine's height-field contact to trust, measured against exact geometry.

Run from the repository root:

    python validation/terrain.py                      # MuJoCo C, about 15 s on 2 CPU cores
    python validation/terrain.py --engines warp mjx   # MuJoCo Warp (CPU) and MJX JAX f64, about 4 min

Prints a table per part and writes validation/results/terrain.json. Method and conclusions:
TERRAIN.md. The seed's vehicle, four wheels locked to one imposed speed, no rolling resistance.

1. Terrain crossed (`obstacle: terrain`, 4 cm, seeds 0 and 1, 2 km/h, mu 0.9): long enough for the
   rear wheels to pass the far edge (`cleared`), per-wheel and four-wheel torque statistics, drive
   work, distance, and on MuJoCo C the contacts per wheel on the height field.
2. A bump (`obstacle: bump`, a cylinder geom: exact geometry) against a height field sampled from
   the same circular segment at 0.05 m (TERRAIN_CELL) and finer cells: MuJoCo C with cylinder and
   sphere wheels, MuJoCo Warp with cylinder wheels, MJX with sphere wheels.
3. A flat height field (all zeros, the plane moved 5 cm below it) on a 10 deg climb: the four-wheel
   sum against m g sin(s) r.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from batchveh.engines import make_engine  # noqa: E402
from batchveh.model import course  # noqa: E402
from batchveh.model.scenarios import make_scenario  # noqa: E402
from batchveh.model.vehicle import CORNERS, GROUND, ContactModel, Vehicle, Wheel, ground_geom, layout, mjcf  # noqa: E402
from batchveh.stepping import stats
from batchveh.stepping.batch import make_batch, servo_damping  # noqa: E402
from batchveh.stepping.rollout import mujoco_steps  # noqa: E402

G = 9.81
RESULTS = Path(__file__).resolve().parent / "results" / "terrain.json"
SPEED_KMH = 2.0
FRICTION = 0.9
TERRAIN = {"terrain_amplitude": 0.04, "terrain_wavelength": 0.5, "obstacle_x": 0.2}
TERRAIN_TIME = 10.0  # s: the rear wheels pass the far edge at about 8.1 s at 2 km/h
BUMP = {"bump_height": 0.04, "bump_length": 0.4, "obstacle_x": 0.5}
BUMP_TIME = 5.0  # s
CELLS = (0.05, 0.025, 0.0125)  # m between height samples of the sampled bump
SLOPE_DEG = 10.0
PLANE_DROP = 0.05  # m: the plane under a flat height field, out of reach of the wheels
WHEELS = tuple(f"drive_{c}" for c in CORNERS)
# the statistics window, s of law time: from after the 0.5 s ramp (and 6 low-pass time constants)
# to the end; every torque column compared is the window's, the drive work the whole run's
WINDOW_START = 0.8


def stats_config(sc) -> stats.StatsConfig:
    return stats.StatsConfig.for_scenario(sc, window=(WINDOW_START, sc.total_time))


def vehicle(collision: str, impedance: float | None = None) -> Vehicle:
    """The seed's vehicle with `collision` wheels; `impedance`: the contact impedance d (None: the
    default ContactModel's)."""
    cm = ContactModel() if impedance is None else ContactModel(impedance=impedance)
    return Vehicle(wheel=Wheel(collision=collision), contact_model=cm)


def scenario(obstacle: str, total_time: float, **kw):
    base = {"speed_kmh": SPEED_KMH, "ramp_time": 0.5, "friction": FRICTION, "total_time": total_time}
    return make_scenario("straight_line", obstacle=obstacle, **{**base, **kw})


def hfield_model(v: Vehicle, sc, heights: np.ndarray, cell: float, x_lo: float, width: float, z: float, plane_z: float):
    """The vehicle on a plane at `plane_z` and a height field whose heights (rows along Y, columns
    along X, m) start at x = `x_lo`, `cell` apart, centred on y = 0, its zero at z = `z`; the ground
    geoms in a mocap body as course.ground makes them, with the ground's contact and the actuator
    gains of the scenario's own model (the gains do not depend on the ground)."""
    nrow, ncol = heights.shape
    length = (ncol - 1) * cell
    top = max(float(heights.max()), 1e-3)
    asset = (
        f'<hfield name="hf" nrow="{nrow}" ncol="{ncol}" size="{length / 2} {width / 2} {top} {course.TERRAIN_BASE}"/>'
    )
    geom = lambda name, shape: ground_geom(name, shape, v, sc.friction, sc.time_step)  # noqa: E731
    plane = geom(GROUND, f'type="plane" size="0 0 1" pos="0 0 {plane_z}"')
    hf = geom(course.PREFIX + "hf", f'type="hfield" hfield="hf" pos="{x_lo + length / 2} 0 {z}"')
    xml = mjcf(
        v,
        time_step=sc.time_step,
        friction=sc.friction,
        gravity=tuple(sc.gravity_vector()),
        ground=(asset, f'<body name="course" mocap="true">{plane}{hf}</body>'),
    )
    m = mujoco.MjModel.from_xml_string(xml)
    m.hfield_data[:] = (heights / top).ravel()
    ref = make_batch(v, sc, {}).model
    m.actuator_gainprm[:] = ref.actuator_gainprm
    m.actuator_biasprm[:] = ref.actuator_biasprm
    return m


def bump_surface(x: np.ndarray, x0: float, h: float, length: float) -> np.ndarray:
    """Height of the bump's circular segment at world x (m), below zero outside the chord."""
    half = length / 2
    radius = (h * h + half * half) / (2 * h)
    dx = np.minimum(np.abs(x - (x0 + half)), radius)
    return np.sqrt(radius * radius - dx * dx) - (radius - h)


def bump_hfield(v: Vehicle, sc, cell: float):
    """The bump of `sc` as a height field of `cell` (the terrain's width, sunk TERRAIN_SINK below the
    plane as the terrain is): its surface is max(circle, -TERRAIN_SINK), so with the plane the
    ground is the bump's exactly at the samples and linear between them."""
    x0 = v.wheel.x_cg + sc.obstacle_x
    x_lo = x0 - 0.1
    ncol = int(round((sc.bump_length + 0.2) / cell)) + 1
    nrow = int(round(course.TERRAIN_WIDTH / cell)) + 1
    x = x_lo + np.arange(ncol) * cell
    heights = np.maximum(bump_surface(x, x0, sc.bump_height, sc.bump_length) + course.TERRAIN_SINK, 0.0)
    return hfield_model(
        v,
        sc,
        np.broadcast_to(heights, (nrow, ncol)).copy(),
        cell,
        x_lo,
        course.TERRAIN_WIDTH,
        -course.TERRAIN_SINK,
        0.0,
    )


def flat_hfield(v: Vehicle, sc, cell: float = course.TERRAIN_CELL):
    """A flat height field (all zeros) at z = 0 under the whole run, the plane PLANE_DROP below."""
    length, width = 8.0, course.TERRAIN_WIDTH
    shape = (int(round(width / cell)) + 1, int(round(length / cell)) + 1)
    return hfield_model(v, sc, np.zeros(shape), cell, -2.0, width, 0.0, -PLANE_DROP)


def c_run(m: mujoco.MjModel, v: Vehicle, sc) -> dict:
    """MuJoCo C, one variant: the statistics (the engines' reduction), the final x, and the contacts
    per wheel: mean count on non-plane geoms while touching them, the largest count, and the share
    of those contacts whose normal points down (z < 0)."""
    batch = make_batch(v, sc, {})
    p = {k: float(x[0]) for k, x in batch.params.items()}
    lay = layout(m)
    damping = servo_damping(p, sc.towing)
    plane = m.geom(GROUND).id
    counts, down, total = [], 0, 0
    rows, prev = [], None
    for d, ctrl in mujoco_steps(m, p, scenario=sc, n_steps=sc.n_steps):
        if ctrl is not None:
            dv = (d.qvel - prev)[lay.motor_dof]
            rows.append(
                stats.sample(
                    d.qpos.copy(), d.qvel.copy(), d.qfrc_actuator.copy(), ctrl, p["wheel.radius"], lay, damping, dv
                )
            )
            geom = d.contact.geom[: d.ncon]
            ground = (geom != plane).all(1)
            counts.append([np.count_nonzero(ground & (geom == w).any(1)) for w in lay.wheel_geoms])
            # the normal points from geom 0 to geom 1: up, seen from the ground, where the ground is geom 0
            up = np.where(np.isin(geom[:, 0], lay.wheel_geoms), -1, 1) * d.contact.frame[: d.ncon, 2]
            down += int(np.count_nonzero(ground & (up < 0)))
            total += int(np.count_nonzero(ground))
        prev = d.qvel.copy()
    series = {k: np.stack([r[k] for r in rows]) for k in rows[0]}
    cfg = stats_config(sc)
    acc = stats.update(stats.init(cfg, ()), series, np.arange(cfg.n_steps), cfg)
    cols = stats.finalize(acc, cfg)
    counts = np.array(counts)
    on = np.where(counts > 0, counts, np.nan)
    cols["contacts_mean"] = np.nanmean(on, 0) if np.isfinite(on).any() else np.zeros(4)
    cols["contacts_max"] = counts.max(0)
    cols["down_share"] = down / max(total, 1)
    cols["series"] = {
        "tau": series["tau"][:, :4],
        "x": series["pos"][:, 0],
        "z": series["pos"][:, 2],
        "contacts": counts,
    }
    return cols


def summary(cols: dict) -> dict:
    """The numbers compared, in the window: per-wheel and four-wheel low-pass peaks and RMS (N m), drive work (J),
    distance (m)."""
    g = lambda k: float(np.asarray(cols[k]).ravel()[0])  # noqa: E731
    out = {f"{w}_peak_lp": g(f"{w}_peak_lp") for w in WHEELS}
    out.update({f"{w}_rms": g(f"{w}_rms") for w in WHEELS})
    out["sum_peak_lp"] = g("drive_sum_peak_lp")
    out["sum_rms"] = g("drive_sum_rms")
    out["work"] = sum(g(f"{w}_energy") for w in WHEELS)
    out["final_x"] = g("final_x")
    for k in ("contacts_mean", "contacts_max"):
        if k in cols:
            out[k] = [float(x) for x in np.ravel(cols[k])]
    if "down_share" in cols:
        out["down_share"] = float(cols["down_share"])
    return out


def engine_run(engine: str, m: mujoco.MjModel, v: Vehicle, sc) -> dict:
    """The statistics of one variant on `engine` ('warp': float32; 'mjx': float64) with the model
    `m` in place of the scenario's own (same structure: only the ground differs)."""
    batch = make_batch(v, sc, {})
    batch.model = m
    kw = {"precision": "f64"} if engine == "mjx" else {}
    return make_engine(engine, sc, stats_config(sc), 1, **kw).run(batch)


def terrain_scenario(seed: float):
    return scenario("terrain", TERRAIN_TIME, terrain_seed=seed, **TERRAIN)


def cleared(final_x: float, v: Vehicle, sc) -> bool:
    """Whether the rear wheels' centres ended past the obstacle's far edge (course.flag's rule)."""
    if sc.obstacle == "none":
        return True
    p = {"wheel.x_cg": v.wheel.x_cg, "chassis.x_cg": v.chassis.x_cg, **{k: getattr(sc, k) for k in course.FIELDS}}
    return bool(
        course.flag({"final_x": np.array([final_x]), "status_code": np.array([0])}, p, sc.obstacle)["cleared"][0]
    )


def grounds(part: str, collision: str):
    """(label, vehicle, scenario, model) of each ground a part compares, for `collision` wheels."""
    from batchveh.stepping.batch import model_for

    v = vehicle(collision)
    if part == "terrain":
        return [(f"terrain seed {s:g}", v, terrain_scenario(s), model_for(v, terrain_scenario(s))) for s in (0.0, 1.0)]
    if part == "bump":
        sc = scenario("bump", BUMP_TIME, **BUMP)
        out = [("bump geom", v, sc, model_for(v, sc))]
        return out + [(f"bump hfield {c:g} m", v, sc, bump_hfield(v, sc, c)) for c in CELLS]
    sc = scenario("none", 4.0, slope_deg=SLOPE_DEG)
    return [("plane", v, sc, model_for(v, sc)), ("flat hfield 0.05 m", v, sc, flat_hfield(v, sc))]


# the wheels each engine runs: MJX's JAX implementation cannot collide a cylinder with a height field
ENGINE_WHEELS = {"mujoco": ("cylinder", "sphere"), "warp": ("cylinder",), "mjx": ("sphere",)}
# the grounds each engine runs (MuJoCo C: all; the others: the 0.05 m cell, the terrain's)
ENGINE_SKIP = {
    "mujoco": (),
    "warp": ("bump hfield 0.025 m", "bump hfield 0.0125 m"),
    "mjx": ("bump hfield 0.025 m", "bump hfield 0.0125 m"),
}


def sink_rows() -> list[dict]:
    """MuJoCo C, the vehicle at rest for 2 s on the plane and on flat height fields (the plane 5 cm
    below): each wheel's sink into the ground (mm) and its contacts."""
    from batchveh.stepping.batch import model_for

    out = []
    for collision in ("cylinder", "sphere"):
        v = vehicle(collision)
        sc = scenario("none", 2.0, speed_kmh=0.0)
        p = {k: float(x[0]) for k, x in make_batch(v, sc, {}).params.items()}
        for label, m in (
            ("plane", model_for(v, sc)),
            *((f"flat hfield {c:g} m", flat_hfield(v, sc, c)) for c in (0.05, 0.0125)),
        ):
            d = None
            for d, _ in mujoco_steps(m, p, scenario=sc, n_steps=sc.n_steps):  # noqa: B007 (the last data)
                pass
            wheels = layout(m).wheel_geoms
            z = [d.xpos[m.geom_bodyid[w]][2] for w in wheels]
            n = [int(np.count_nonzero((d.contact.geom[: d.ncon] == w).any(1))) for w in wheels]
            row = {"part": "sink", "ground": label, "engine": "mujoco", "wheels": collision}
            row["sink_mm"] = float(np.mean([(v.wheel.radius - zi) * 1e3 for zi in z]))
            row["contacts"] = float(np.mean(n))
            row["sink_x_contacts_mm"] = row["sink_mm"] * row["contacts"]
            out.append(row)
            print(
                f"sink     {label:22} mujoco {collision:8} sink {row['sink_mm']:.3f} mm with "
                f"{row['contacts']:g} contacts per wheel: sink x contacts {row['sink_x_contacts_mm']:.2f} mm"
            )
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", nargs="+", default=["mujoco"], choices=["mujoco", "warp", "mjx"])
    ap.add_argument(
        "--parts", nargs="+", default=["sink", "terrain", "bump", "flat"], choices=["sink", "terrain", "bump", "flat"]
    )
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    rows = json.loads(args.out.read_text())["rows"] if args.out.exists() else []
    for part in args.parts:
        if part == "sink":
            new = sink_rows()
            rows = [r for r in rows if r["part"] != "sink"] + new
            continue
        for engine in args.engines:
            for collision in ENGINE_WHEELS[engine]:
                for label, v, sc, m in grounds(part, collision):
                    if label in ENGINE_SKIP[engine]:
                        continue
                    start = time.perf_counter()
                    cols = c_run(m, v, sc) if engine == "mujoco" else engine_run(engine, m, v, sc)
                    row = {"part": part, "ground": label, "engine": engine, "wheels": collision}
                    row.update(summary(cols))
                    row["cleared"] = cleared(row["final_x"], v, sc)
                    row["wall_s"] = round(time.perf_counter() - start, 1)
                    key = (part, label, engine, collision)
                    rows = [r for r in rows if (r["part"], r["ground"], r["engine"], r["wheels"]) != key]
                    rows.append(row)
                    print(line(row), flush=True)
                    args.out.parent.mkdir(exist_ok=True)
                    args.out.write_text(json.dumps({"settings": settings(), "rows": rows}, indent=1) + "\n")


def settings() -> dict:
    return {
        "speed_kmh": SPEED_KMH,
        "friction": FRICTION,
        "terrain": TERRAIN,
        "terrain_time_s": TERRAIN_TIME,
        "bump": BUMP,
        "bump_time_s": BUMP_TIME,
        "slope_deg": SLOPE_DEG,
        "window_s": [WINDOW_START, "total_time"],
        "terrain_cell_m": course.TERRAIN_CELL,
        "mujoco": mujoco.__version__,
    }


def line(r: dict) -> str:
    peaks = " ".join(f"{r[f'{w}_peak_lp']:6.1f}" for w in WHEELS)
    rms = " ".join(f"{r[f'{w}_rms']:5.1f}" for w in WHEELS)
    cnt = " ".join(f"{c:4.1f}" for c in r.get("contacts_mean", [])) or "-"
    return (
        f"{r['part']:8} {r['ground']:22} {r['engine']:6} {r['wheels']:8} peak_lp {peaks} | sum {r['sum_peak_lp']:6.1f} "
        f"| rms {rms} | sum {r['sum_rms']:5.1f} | work {r['work']:6.1f} J | x {r['final_x']:5.2f} "
        f"{'cleared' if r['cleared'] else 'NOT cleared'} | contacts {cnt} | {r['wall_s']} s"
    )


if __name__ == "__main__":
    main()
