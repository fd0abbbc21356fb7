"""How close does the warp engine come to MuJoCo Warp alone on one GPU: its rate, where its step goes, its reruns?

    python benchmarks/warp_engine.py native --size 131072 --label h100
    python benchmarks/warp_engine.py profile --size 131072 --label h100
    python benchmarks/warp_engine.py determinism --size 8192 --steps 400 --label h100
    python benchmarks/warp_engine.py MODE --help                 # what each mode measures

Every mode runs the same case (bench.native_case: sweeps/slope.yaml's vehicle with the slip tyre, the slope
grid's variants drawn with seed 3) against MuJoCo Warp alone (bench.bench_mjwarp_direct: `mujoco_warp.step`,
one CUDA graph per 50 steps, no tyre, drive or statistics), in one process on one GPU:

  native        the engine's rate against MuJoCo Warp alone's, per --modes setting; its reruns bit for bit;
                --ref: its float32 against MuJoCo C float64 (was warp_native.py; LABEL-warp-native.json)
  profile       where a step of the engine goes: MuJoCo Warp's kernels, XLA's, copies, idle, from a JAX
                profiler trace (was warp_profile.py; LABEL-warp-profile.json)
  determinism   whether two runs of MuJoCo Warp alone give the same bits, with and without its
                Option.deterministic (was determinism.py; LABEL-determinism.json)
"""

from __future__ import annotations

import argparse
import glob
import gzip
import json
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench  # noqa: E402

NATIVE_DOC = """\
The warp engine (MuJoCo Warp 4.0 as its physics) against MuJoCo Warp alone, and its reruns, in one process.

    python benchmarks/warp_engine.py native --size 131072 --label h100
    python benchmarks/warp_engine.py native --size 256 --steps 100 --ref 0      # the CPU, to see it run

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
PROFILE_DOC = """\
Where a step of the warp engine goes, against MuJoCo Warp alone, in one process on one GPU.

    python benchmarks/warp_engine.py profile --size 131072 --label h100

Rows (the model, variants and controls of `native`; --steps steps of 5 ms; best of --repeat):

  MuJoCo Warp alone   bench.bench_mjwarp_direct: `mujoco_warp.step`, one CUDA graph per 50 steps
  physics in JAX      the engine's own Warp calls (WarpPhysics.step: controls and wrenches in, the step, the
                      scan's fields out) in a JAX scan, with constant controls: no tyre, drive or statistics
  warp engine         the whole chunk (WarpEngine.run)

and the engine's per-step cost split by kind from a JAX profiler trace of one run (device kernels grouped
as Warp's, XLA's and copies; the GPU's idle time between them), when the profiler records the device.

JSON: benchmarks/results/LABEL-warp-profile.json.
"""
DETERMINISM_DOC = """\
Do two runs give the same bits on a GPU? MuJoCo Warp alone, with and without its Option.deterministic.

    python benchmarks/warp_engine.py determinism --size 8192 --steps 400 --label h100

MuJoCo Warp stepped by hand (bench.bench_mjwarp_direct: sweeps/slope.yaml's vehicle with the slip tyre's
frictionless contacts, per-world gravity and friction, one CUDA graph per 50 steps), from a fresh model and
data each run, twice per --det setting (DeterminismType bits; 7: all). Per setting: the rate of each run,
and how many worlds end with other bits in qpos, qvel or qfrc_actuator, and the largest difference.
The warp engine's own reruns are in `native` ('reruns').

JSON: benchmarks/results/LABEL-determinism.json.
"""


def _columns_differ(a: dict, b: dict) -> dict:
    """Columns of two runs that differ in any bit: {name: largest |a - b|}."""
    out = {}
    for k in a:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        if x.tobytes() != y.tobytes():
            with np.errstate(invalid="ignore"):
                out[k] = float(np.nanmax(np.abs(x.astype(float) - y.astype(float))))
    return out


def native_main(argv=None) -> None:
    ap = argparse.ArgumentParser(
        prog="warp_engine.py native", description=NATIVE_DOC, formatter_class=argparse.RawDescriptionHelpFormatter
    )
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


def _kind(name: str) -> str:
    n = name.lower()
    if "memcpy" in n or "memset" in n:
        return "copy"
    if "cuda_kernel" in n or "wp_" in n or "_kernel_forward" in n:
        return "warp"
    return "xla"


def device_split(trace_dir: str, steps: int) -> dict:
    """Device time per step by kind, from the Perfetto trace JAX's profiler wrote under trace_dir."""
    files = glob.glob(f"{trace_dir}/**/*.trace.json.gz", recursive=True) + glob.glob(
        f"{trace_dir}/**/perfetto_trace.json.gz", recursive=True
    )
    if not files:
        return {"error": "no trace file"}
    with gzip.open(files[0]) as f:
        tr = json.load(f)
    events = tr["traceEvents"] if isinstance(tr, dict) else tr
    meta = [e for e in events if e.get("ph") == "M" and e.get("name") == "process_name"]
    pname = {e["pid"]: e["args"].get("name", "") for e in meta}
    dev = [e for e in events if e.get("ph") == "X" and "gpu" in pname.get(e.get("pid"), "").lower()]
    if not dev:
        return {"error": "no device events", "processes": sorted(set(pname.values()))[:20]}
    by_kind, by_name, args, copies = defaultdict(float), defaultdict(float), {}, defaultdict(float)
    for e in dev:
        by_kind[_kind(e["name"])] += e["dur"]
        by_name[e["name"]] += e["dur"]
        args.setdefault(e["name"], {k: str(v)[:200] for k, v in e.get("args", {}).items()})  # one event's, e.g. hlo_op
        if _kind(e["name"]) == "copy":  # where each copy comes from: XLA's program and instruction, or none (Warp)
            a = e.get("args", {})
            copies[f"{e['name']} {a.get('hlo_module', '-')} {a.get('hlo_op', '-')}"] += e["dur"]
    start = min(e["ts"] for e in dev)
    end = max(e["ts"] + e["dur"] for e in dev)
    busy = sum(by_kind.values())
    top = sorted(by_name.items(), key=lambda kv: -kv[1])[:25]
    us = 1.0 / steps
    return {
        "span_us_per_step": (end - start) * us,
        "busy_us_per_step": busy * us,
        "by_kind_us_per_step": {k: v * us for k, v in by_kind.items()},
        "kernels": len(dev),
        "kernels_per_step": len(dev) / steps,
        "top_us_per_step": [[k[:120], v * us] for k, v in top],
        "top_args": {k[:120]: args[k] for k, _ in top[:8]},
        "copies_us_per_step": dict(sorted(((k, v * us) for k, v in copies.items()), key=lambda kv: -kv[1])[:15]),
    }


def profile_main(argv=None) -> None:
    ap = argparse.ArgumentParser(
        prog="warp_engine.py profile", description=PROFILE_DOC, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--size", type=int, default=131072)
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--label", default=None)
    args = ap.parse_args(argv)

    import jax
    import jax.numpy as jnp

    from batchveh.engines.warp import WarpEngine
    from batchveh.stepping.batch import make_batch

    spec, cfg, cols, base, gravity, omega = bench.native_case(args.size, args.steps)
    sc = spec.scenario
    rows = []
    result = {"machine": bench.machine(), "size": args.size, "steps": args.steps, "rows": rows}

    alone = max(bench.bench_mjwarp_direct(base.model, gravity, cols["friction"], omega, args.steps)[0]
                for _ in range(args.repeat))  # fmt: skip
    rows.append({"name": "MuJoCo Warp alone", "rate": alone, "ms_per_step": 1e3 * args.size / alone})
    print(rows[-1], flush=True)

    eng = WarpEngine(sc, cfg, args.size)
    batch = make_batch(spec.vehicle, sc, cols)
    eng.run(batch)
    walls = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        eng.run(batch)
        walls.append(time.perf_counter() - t0)
    rate = args.size * args.steps / min(walls)
    rows.append({"name": "warp engine", "rate": rate, "ms_per_step": 1e3 * min(walls) / args.steps,
                 "walls": walls, "ratio_to_alone": rate / alone})  # fmt: skip
    print(rows[-1], flush=True)

    # the engine's Warp calls alone in a JAX scan: constant controls, no tyre, drive or statistics
    (phys,) = eng._phys.values()
    mjm = batch.model
    ctrl0 = jnp.zeros((args.size, mjm.nu), jnp.float32) + jnp.asarray(omega, jnp.float32)[:, None] * 0.0

    def one(c):
        d = phys.start(mjm.nu, mjm.nbody, c[0])
        d = d.replace(ctrl=c)

        def body(d, _):
            return phys.step(d), None

        d, _ = jax.lax.scan(body, d, None, length=args.steps)
        return d.qvel.sum()

    fn = jax.jit(jax.vmap(one))
    fn(ctrl0).block_until_ready()
    pw = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        fn(ctrl0).block_until_ready()
        pw.append(time.perf_counter() - t0)
    prate = args.size * args.steps / min(pw)
    rows.append({"name": "physics in JAX", "rate": prate, "ms_per_step": 1e3 * min(pw) / args.steps,
                 "walls": pw, "ratio_to_alone": prate / alone})  # fmt: skip
    print(rows[-1], flush=True)

    runs = (("warp engine", lambda: eng.run(batch)), ("physics in JAX", lambda: fn(ctrl0).block_until_ready()))
    for name, run in runs:
        with tempfile.TemporaryDirectory() as tmp:
            try:
                with jax.profiler.trace(tmp, create_perfetto_trace=True):
                    run()
                split = device_split(tmp, args.steps)
            except Exception as err:  # noqa: BLE001 - a profiler that cannot run is a result too
                split = {"error": f"{type(err).__name__}: {str(err)[:300]}"}
        result[f"profile {name}"] = split
        print(name, json.dumps(split, indent=1)[:4000], flush=True)

    # the copies in the engine's compiled program (XLA's buffer assignment): shape and source of each
    (compiled,) = eng._fn.values()
    copies = [ln.strip() for ln in compiled.as_text().splitlines() if " copy(" in ln or "copy-start" in ln]
    result["hlo_copies"] = [ln[:160] for ln in copies]
    print(len(copies), "copies in the program; largest:", flush=True)
    for ln in sorted(copies, key=lambda x: -len(x.split("=")[1].split("{")[0]))[:12]:
        print("  ", ln[:200])

    result["jax"] = jax.__version__
    result["implementation"] = eng.implementation
    bench.write_result(result, bench.result_path("warp-profile", args.label))


def determinism_main(argv=None) -> None:
    ap = argparse.ArgumentParser(
        prog="warp_engine.py determinism",
        description=DETERMINISM_DOC,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--size", type=int, default=8192)
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--det", type=int, nargs="+", default=[0, 7])
    ap.add_argument("--label", default=None)
    args = ap.parse_args(argv)

    # the case of `native` and `profile` (slip tyre, seed 3); the model is the base batch's
    _, _, cols, base, gravity, omega = bench.native_case(args.size, args.steps)
    model = base.model
    rows = []
    for det in args.det:
        finals, rates = [], []
        for _ in range(2):
            final: dict = {}
            rate, _ = bench.bench_mjwarp_direct(
                model, gravity, cols["friction"], omega, args.steps, deterministic=det, final=final
            )
            finals.append(final)
            rates.append(rate)
        row = {"deterministic": det, "rates": rates}
        for k in ("qpos", "qvel", "qfrc_actuator"):
            a, b = finals[0][k], finals[1][k]
            row[f"{k}_worlds_differ"] = int(np.any(a != b, axis=1).sum())
            row[f"{k}_largest"] = float(np.max(np.abs(a - b)))
        rows.append(row)
        print(row, flush=True)
    bench.write_result({"machine": bench.machine(), "size": args.size, "steps": args.steps, "rows": rows},
                       bench.result_path("determinism", args.label))  # fmt: skip


MODES = {"native": native_main, "profile": profile_main, "determinism": determinism_main}


def main(argv=None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] not in MODES:
        ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
        ap.add_argument("mode", choices=list(MODES), help="what to measure (each mode has its own --help)")
        ap.parse_args(argv[:1])  # --help, or the error naming the modes
        return
    MODES[argv[0]](argv[1:])


if __name__ == "__main__":
    main()
