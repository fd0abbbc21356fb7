"""The soil wheel-ground model on the warp engine: its speed against the rigid ground's models,
and its float32 accuracy against MuJoCo C float64 (issue 22).

    python benchmarks/soil.py --size 131072 --out benchmarks/results/h200-soil.json   # one GPU
    python benchmarks/soil.py --size 256 --ref 32 --steps 200                           # a CPU, to see it run

One random table of variants on the Moon, Mars and the Earth (slope 0-20 deg, speed 0.5-4 km/h,
and the lunar soil preset's k_phi, phi, K, c and n each swept over a band around it) runs on the
warp engine with each wheel-ground model: `soil`, then the `slip` tyre and the `rigid` contact on
the same table (their soil columns unused), in turns, `--repeat` times, each after a warm-up run
of the same program. Rates are variant-steps/s; ratios are against `rigid` and `slip` measured in
the same process. Accuracy: the first `--ref` variants on MuJoCo C in float64 against the warp
engine's float32, per-wheel drive means (steady window), relative to the largest wheel of the
variant, median / p99 / largest, for the variants C calls ok, steady and not slipping (the ones a
sizing reads) and for the rest (a vehicle still accelerating in low gravity at the end of its run
amplifies float32's rounding).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from batchveh.engines import make_engine  # noqa: E402
from batchveh.model import soil  # noqa: E402
from batchveh.model.scenarios import make_scenario  # noqa: E402
from batchveh.model.tyres import Tyre  # noqa: E402
from batchveh.model.vehicle import CORNERS, Vehicle  # noqa: E402
from batchveh.stepping import stats
from batchveh.stepping.batch import make_batch  # noqa: E402

MODELS = ("soil", "slip", "rigid")


def table(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    lunar = soil.PRESETS["lunar_soil"]
    return {
        "slope_deg": rng.uniform(0.0, 20.0, n),
        "speed_kmh": rng.uniform(0.5, 4.0, n),
        "gravity": rng.choice([1.62, 3.71, 9.81], n),
        "soil.k_phi": lunar["k_phi"] * rng.uniform(0.5, 2.0, n),
        "soil.phi": rng.uniform(25.0, 45.0, n),
        "soil.K": rng.uniform(0.01, 0.03, n),
        "soil.c": rng.uniform(0.0, 1.5, n),
        "soil.n": rng.uniform(0.8, 1.2, n),
    }


def vehicle(model: str) -> Vehicle:
    v = Vehicle(tyre=Tyre(model=model))
    return dataclasses.replace(v, soil=dataclasses.replace(v.soil, preset="lunar_soil", **soil.PRESETS["lunar_soil"]))


def scenario(steps: int):
    dt = 0.005
    return make_scenario("straight_line", total_time=(steps - 100) * dt, ramp_time=1.0, settle_time=100 * dt)


def run(model: str, tab: dict, steps: int, backend: str, precision: str):
    v, sc = vehicle(model), scenario(steps)
    batch = make_batch(v, sc, tab)
    cfg = stats.StatsConfig.for_scenario(sc, slip_limit=stats.slip_limit(v))
    eng = make_engine(backend, sc, cfg, batch.n, precision=precision)
    t0 = time.perf_counter()
    cols = eng.run(batch)
    return cols, time.perf_counter() - t0, batch.n * sc.n_steps


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=131072)
    ap.add_argument("--steps", type=int, default=1100, help="steps per variant, the 0.5 s settle included")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--ref", type=int, default=256, help="variants of the C float64 reference")
    ap.add_argument("--backend", default="warp", choices=["warp", "mjx"])
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    import jax

    tab = table(args.size)
    rows = {m: [] for m in MODELS}
    for m in MODELS:  # warm: each program compiled (and Warp's kernels built) before any timing
        run(m, tab, args.steps, args.backend, "f32")
    for _ in range(args.repeat):
        for m in MODELS:
            cols, wall, vsteps = run(m, tab, args.steps, args.backend, "f32")
            rows[m].append({"wall_s": wall, "rate": vsteps / wall})
            if m == "soil":
                got = cols
    summary = {m: max(r["rate"] for r in rows[m]) for m in MODELS}
    print(f"{'model':<6} {'best rate':>12} {'walls s':>20}")
    for m in MODELS:
        walls = " ".join(f"{r['wall_s']:.2f}" for r in rows[m])
        print(f"{m:<6} {summary[m]:12.3e} {walls:>20}")
    print(f"soil / rigid {summary['soil'] / summary['rigid']:.3f}, soil / slip {summary['soil'] / summary['slip']:.3f}")

    ref_tab = {k: v[: args.ref] for k, v in tab.items()}
    ref, _, _ = run("soil", ref_tab, args.steps, "mujoco", "f64")
    c = np.stack([ref[f"drive_{k}_mean"] for k in CORNERS], 1)
    w = np.stack([np.asarray(got[f"drive_{k}_mean"])[: args.ref] for k in CORNERS], 1)
    err = (np.abs(w - c) / np.abs(c).max(1, keepdims=True)).max(1)
    good = (np.asarray(ref["status_code"]) == 0) & ~np.asarray(ref["slipping"]) & np.asarray(ref["steady"])
    accuracy = {}
    for name, sel in (("ok, steady, not slipping", good), ("slipping, unsteady or not ok", ~good)):
        e = err[sel]
        accuracy[name] = {
            "variants": int(sel.sum()),
            **(
                {"median": float(np.median(e)), "p99": float(np.quantile(e, 0.99)), "max": float(e.max())}
                if e.size
                else {}
            ),
        }
        print(f"{args.backend} f32 against C f64, {name}: {accuracy[name]}")
    result = {
        "what": "the soil wheel-ground model on the warp engine against rigid and slip; float32 accuracy against C",
        "device": str(jax.devices()[0]),
        "host": platform.node(),
        "size": args.size,
        "steps": args.steps,
        "backend": args.backend,
        "rows": rows,
        "best_rate": summary,
        "soil_over_rigid": summary["soil"] / summary["rigid"],
        "soil_over_slip": summary["soil"] / summary["slip"],
        "accuracy": accuracy,
        "slipping_share": float(np.mean(np.asarray(got["slipping"]))),
    }
    if args.out:
        args.out.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
