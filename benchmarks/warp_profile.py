"""Where a step of the warp engine goes, against MuJoCo Warp alone, in one process on one GPU.

    python benchmarks/warp_profile.py --size 131072 --label h100

Rows (the model, variants and controls of warp_native.py; --steps steps of 5 ms; best of --repeat):

  MuJoCo Warp alone   bench.bench_mjwarp_direct: `mujoco_warp.step`, one CUDA graph per 50 steps
  physics in JAX      the engine's own Warp calls (WarpPhysics.step: controls and wrenches in, the step, the
                      scan's fields out) in a JAX scan, with constant controls: no tyre, drive or statistics
  warp engine         the whole chunk (WarpEngine.run)

and the engine's per-step cost split by kind from a JAX profiler trace of one run (device kernels grouped
as Warp's, XLA's and copies; the GPU's idle time between them), when the profiler records the device.

JSON: benchmarks/results/LABEL-warp-profile.json.
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

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench  # noqa: E402


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

def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
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

if __name__ == "__main__":
    main()
