"""Where a step of the warp engine's scan spends its GPU time: MuJoCo Warp's kernels, XLA's
(the tyre, the controls, the statistics, the data's copies) and the copies between them.

    python benchmarks/warp_profile.py benchmarks/slope_100k.yaml --n 100000 --steps 200 --out profile.json
    python benchmarks/warp_profile.py benchmarks/slope_100k.yaml --n 64 --steps 20          # a CPU

The engine's program for the spec's first --n variants and --steps steps is compiled and run
once, then run again under JAX's profiler (a perfetto trace). Device events are summed by name
and by kind: `warp` (Warp's kernels, named `..._cuda_kernel_forward`), `xla` (XLA's fusions and
library calls), `copy` (memcpy and memset), `other`. Per step: each kind's device time, and the
run's wall time over its steps (what the GPU's busy time leaves is launch gaps and waits).
"""

from __future__ import annotations

import argparse
import collections
import glob
import gzip
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from warp_iterations import batch_of, spec_of  # noqa: E402

from batchveh.engines.warp import WarpEngine  # noqa: E402


def kind_of(name: str) -> str:
    low = name.lower()
    if "cuda_kernel" in low:
        return "warp"
    if "memcpy" in low or "memset" in low:
        return "copy"
    if "fusion" in low or low.startswith(("loop_", "input_", "wrapped_", "gemm", "reduce", "void ", "sm")):
        return "xla"
    return "other"


def device_events(trace_dir: str) -> list[dict]:
    """Complete events ('X') of the trace's device processes (a GPU's streams), name and duration."""
    files = glob.glob(f"{trace_dir}/**/perfetto_trace.json.gz", recursive=True)
    if not files:
        return []
    with gzip.open(files[0]) as f:
        trace = json.load(f)
    events = trace["traceEvents"] if isinstance(trace, dict) else trace
    names = {e["pid"]: e["args"]["name"] for e in events if e.get("ph") == "M" and e.get("name") == "process_name"}
    gpu = {pid for pid, nm in names.items() if "/device:GPU" in nm or "gpu" in nm.lower()}
    print("trace processes:", sorted(names.values()), flush=True)
    return [e for e in events if e.get("ph") == "X" and e.get("pid") in gpu and "dur" in e]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("spec")
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--top", type=int, default=40)
    ap.add_argument("--graph-mode", help="MuJoCo Warp's CUDA graph mode (warp.JaxCallableGraphMode name)")
    ap.add_argument("--out")
    args = ap.parse_args()
    import jax

    spec = spec_of(args.spec, args.steps)
    cfg = spec.stats_config()
    batch = batch_of(spec, 0, args.n)
    engine = WarpEngine(spec.scenario, cfg, args.n)
    engine.graph_mode = args.graph_mode
    t = time.perf_counter()
    engine.run(batch)
    first = time.perf_counter() - t
    t = time.perf_counter()
    engine.run(batch)
    plain = time.perf_counter() - t
    with tempfile.TemporaryDirectory() as tmp:
        jax.profiler.start_trace(tmp, create_perfetto_trace=True)
        t = time.perf_counter()
        engine.run(batch)
        traced = time.perf_counter() - t
        jax.profiler.stop_trace()
        events = device_events(tmp)
    steps = cfg.n_steps
    by_name: dict[str, list[float]] = collections.defaultdict(lambda: [0.0, 0])
    for e in events:
        by_name[e["name"]][0] += float(e["dur"])
        by_name[e["name"]][1] += 1
    by_kind: dict[str, float] = collections.defaultdict(float)
    launches: dict[str, int] = collections.defaultdict(int)
    for name, (us, calls) in by_name.items():
        by_kind[kind_of(name)] += us
        launches[kind_of(name)] += calls
    busy = sum(by_kind.values())
    table = sorted(by_name.items(), key=lambda kv: -kv[1][0])
    result = {
        "info": {
            "spec": args.spec,
            "variants": args.n,
            "steps": steps,
            "device": str(jax.devices()[0].device_kind),
            "date": time.strftime("%Y-%m-%d %H:%M"),
            "graph_mode": args.graph_mode or "MJX's default",
        },
        "first_run_s": first,
        "run_s": plain,
        "traced_run_s": traced,
        "wall_per_step_us": plain / steps * 1e6,
        "device_busy_per_step_us": busy / steps,
        "per_step_us": {k: v / steps for k, v in sorted(by_kind.items())},
        "launches_per_step": {k: v / steps for k, v in sorted(launches.items())},
        "kernels": [
            {"kernel": name[:200], "kind": kind_of(name), "us_per_step": us / steps, "calls_per_step": calls / steps}
            for name, (us, calls) in table
        ],
    }
    print(json.dumps({k: v for k, v in result.items() if k != "kernels"}, indent=1))
    for row in [r for r in result["kernels"] if r["kind"] != "warp"] + result["kernels"][: args.top]:
        print(f"{row['us_per_step']:9.1f} us {row['calls_per_step']:6.2f}x {row['kind']:5s} {row['kernel'][:100]}")
    if args.out:
        Path(args.out).write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
