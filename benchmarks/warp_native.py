"""The warp engine (MuJoCo Warp 4.0 as its physics) against MuJoCo Warp alone, and its reruns, in one process.

    python benchmarks/warp_native.py --size 131072 --label h100
    python benchmarks/warp_native.py --size 256 --steps 100 --ref 0      # the CPU, to see it run

Rows (same process, same GPU, same model: sweeps/slope.yaml's vehicle with the slip tyre, whose wheels'
contacts are frictionless; the same --size variants drawn from the slope grid, --steps steps of 5 ms):

  MuJoCo Warp alone   `mujoco_warp.step` on every world, one CUDA graph per 50 steps, per-world gravity and
                      ground friction, controls set by a Warp kernel; no tyre, no drive, no statistics
                      (bench.bench_mjwarp_direct)
  warp engine         batchveh's engine on the same variants: controls, slip tyre, statistics in the scan;
                      each timed run is a whole chunk (per-world fields written, the scan, the columns read back)
  warp engine MODE    the same with other settings (--modes): det=BITS (MuJoCo Warp's Option.deterministic,
                      7: all), graph=NAME (warp.JaxCallableGraphMode), @N (the first N variants)

Each engine row runs once untimed (compile and kernels), then --repeat times; the rate is the best. The
reruns: every column of two runs of one batch compared bit for bit, per mode (how many columns differ and
by how much). --ref N: bench.py's reference sample (N variants, seed 1, the spec's whole run) on MuJoCo C
in float64 at tolerance 1e-12 against the engine (float32), by bench.accuracy (|warp - C| / max(|C|, 1 N m),
median, p99 and max, variants that slip and those that do not apart).

JSON: benchmarks/results/LABEL-warp-native.json.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench  # noqa: E402


def _columns_differ(a: dict, b: dict) -> dict:
    """Columns of two runs that differ in any bit: {name: largest |a - b|}."""
    out = {}
    for k in a:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        if x.tobytes() != y.tobytes():
            with np.errstate(invalid="ignore"):
                out[k] = float(np.nanmax(np.abs(x.astype(float) - y.astype(float))))
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=131072)
    ap.add_argument("--steps", type=int, default=1100)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--ref", type=int, default=256)
    ap.add_argument("--modes", nargs="+", default=["default", "det=7@32768"])
    ap.add_argument("--label", default=None)
    args = ap.parse_args(argv)

    import jax

    from batchveh.engines.warp import WarpEngine
    from batchveh.stepping.batch import make_batch

    spec, cfg, cols, base, gravity, omega = bench.native_case(args.size, args.steps)
    sc = spec.scenario
    rows, reruns = [], {}
    result = {"machine": bench.machine(), "size": args.size, "steps": args.steps, "rows": rows, "reruns": reruns}

    rate, extra = bench.bench_mjwarp_direct(base.model, gravity, cols["friction"], omega, args.steps)
    rows.append({"name": "MuJoCo Warp alone", "rate": rate, **extra})
    print(rows[-1], flush=True)

    outs = {}
    for mode in args.modes:
        # a mode: "default", or "det=BITS" (MuJoCo Warp's DeterminismType bits, 7 all) and/or "graph=NAME"
        # (warp.JaxCallableGraphMode), comma-separated, with "@N" to run the first N variants only
        opts, _, size = mode.partition("@")
        size = int(size or args.size)
        kw = dict(o.split("=") for o in opts.split(",") if "=" in o)
        eng = WarpEngine(sc, cfg, size, deterministic=int(kw.get("det", 0)), graph_mode=kw.get("graph", "WARP"))
        batch = make_batch(spec.vehicle, sc, {k: v[:size] for k, v in cols.items()})
        try:
            t0 = time.perf_counter()
            first = eng.run(batch)
            first_s = time.perf_counter() - t0
            walls, last = [], None
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                last = eng.run(batch)
                walls.append(time.perf_counter() - t0)
        except Exception as err:  # noqa: BLE001 - a mode that cannot run is a result too
            rows.append({"name": f"warp engine {mode}", "error": f"{type(err).__name__}: {str(err)[:300]}"})
            print(rows[-1], flush=True)
            continue
        best = min(walls)
        differ = _columns_differ(first, last)
        reruns[mode] = {"columns": len(first), "differ": len(differ), "largest": differ}
        rows.append({
            "name": f"warp engine {mode}", "size": size, "rate": size * args.steps / best, "walls": walls,
            "first_s": first_s, "compile_s": eng.compile_s, "warm_s": eng.warm_s,
            "implementation": eng.implementation,
            "finite_share": float(np.isfinite(last["drive_sum_mean"]).mean()),
            "solver_limit_share_max": float(np.max(last.get("solver_limit_share", [np.nan]))),
        })  # fmt: skip
        rows[-1]["ratio_to_alone"] = rows[-1]["rate"] / rate
        print(rows[-1], "\n  reruns:", reruns[mode]["differ"], "of", len(first), "columns differ", flush=True)
        outs[mode] = last
        del eng

    if args.ref:  # bench.py's reference sample and its reduction: MuJoCo C in float64 at tolerance 1e-12
        spec_r, ref_table = bench.slope_table(args.ref, seed=1)
        ref, *_ = bench.run_backend("mujoco", spec_r, ref_table, args.ref, "default", x64=True)
        w, *_ = bench.run_backend("warp", spec_r, ref_table, args.ref, "default")
        acc = bench.accuracy(w, ref)
        acc["status_agree"] = float(np.mean(np.asarray(w["status_code"]) == np.asarray(ref["status_code"])))
        result["accuracy_vs_c"] = {"variants": args.ref, "steps": spec_r.scenario.n_steps, **acc}
        for k in ("noslip_wheel_mean", "noslip_wheel_peak", "noslip_sum_mean", "slip_wheel_mean", "slip_wheel_peak"):
            if k in acc:
                print(f"accuracy vs MuJoCo C f64, {k}: median {acc[k]['median']:.2e} p99 {acc[k]['p99']:.2e} "
                      f"(n={acc[k]['n']})", flush=True)  # fmt: skip

    result["jax"] = jax.__version__
    path = bench.result_path("warp-native", args.label)
    bench.write_result(result, path)


if __name__ == "__main__":
    main()
