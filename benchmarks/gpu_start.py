"""What the first GPU operation of a sweep process costs, and whether it can overlap the imports.

    python benchmarks/gpu_start.py benchmarks/slope_100k.yaml --rounds 2 --out start.json

A sweep process's first GPU operation (after JAX's backend starts) took 2.1-2.9 s on one H200
wherever it fell (benchmarks/process_profile.py), while importing mujoco.mjx took 2.5 s of CPU.
Four ways of starting `python -m batchveh.sweep SPEC`, alternating, each a fresh process:

- `plain`: as a user runs it;
- `overlap`: a thread puts one float on the GPU (and waits for it) while the main thread goes on;
- `no-prealloc`: XLA_PYTHON_CLIENT_PREALLOCATE=false (JAX does not reserve 75% of the GPU's memory);
- `overlap+no-prealloc`: both.

With --fresh, the first run on a fresh machine instead (issue 32): each way gets empty caches of its own
(Warp's kernels, the CUDA driver's, JAX's programs: WARP_CACHE_PATH, CUDA_CACHE_PATH, BATCHVEH_CACHE), then a
second, warm run on them (--warm-runs of them). Ways: `ahead` (worker processes build the vehicle's MuJoCo Warp
kernels while the engine's first chunk compiles, the default: batchveh/engines/warp_build.py) and `serial`
(BATCHVEH_WARP_PREBUILD=0: each module builds at its first launch). Each first run also records when each
kernel module landed in Warp's cache (s after the start), and what each worker's part took.
Results: benchmarks/results/h200-first-gpu-run.json.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench import write_result  # noqa: E402
from end_to_end import SUMMARY  # noqa: E402

OVERLAP = """
import sys, threading, runpy
import jax, numpy as np
threading.Thread(target=lambda: jax.device_put(np.zeros(1, np.float32)).block_until_ready(), daemon=True).start()
runpy.run_module("batchveh.sweep", run_name="__main__", alter_sys=True)
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("spec")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--out", required=True)
    ap.add_argument("--fresh", action="store_true", help="first runs on empty caches, the ahead build against serial")
    ap.add_argument("--ways", default="serial,ahead", help="with --fresh: the ways to run, comma-separated")
    ap.add_argument("--warm-runs", type=int, default=1, help="with --fresh: warm runs after each first run")
    ap.add_argument(
        "--extra-way",
        action="append",
        default=[],
        metavar="NAME:KEY=VALUE,...",
        help="with --fresh: another way, the default one with these environment variables (e.g. "
        "nocache:JAX_ENABLE_COMPILATION_CACHE=false)",
    )
    args = ap.parse_args()
    if args.fresh:
        return fresh(args)
    ways = {
        "plain": ([sys.executable, "-m", "batchveh.sweep"], {}),
        "overlap": ([sys.executable, "-c", OVERLAP], {}),
        "no-prealloc": ([sys.executable, "-m", "batchveh.sweep"], {"XLA_PYTHON_CLIENT_PREALLOCATE": "false"}),
        "overlap+no-prealloc": ([sys.executable, "-c", OVERLAP], {"XLA_PYTHON_CLIENT_PREALLOCATE": "false"}),
    }
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for name, (cmd, extra) in ways.items():
                t = time.perf_counter()
                done = subprocess.run(
                    [*cmd, args.spec, "--quiet", "--overwrite", "--out", str(Path(tmp) / "r")],
                    cwd=ROOT,
                    env={**os.environ, **extra},
                    capture_output=True,
                    text=True,
                )
                wall = time.perf_counter() - t
                m = next((SUMMARY.match(x.strip()) for x in done.stdout.splitlines() if SUMMARY.match(x.strip())), None)
                row = {"way": name, "round": r + 1, "wall_s": wall, "returncode": done.returncode}
                if m:
                    row.update(sweep_wall_s=float(m["sweep_s"]), compile_s=float(m["compile_s"]), status=m["status"])
                else:
                    row["stderr_tail"] = done.stderr.splitlines()[-5:]
                runs.append(row)
                print(json.dumps(row), flush=True)
    summary = {
        name: {
            "wall_best_s": min(x["wall_s"] for x in runs if x["way"] == name),
            "wall_median_s": statistics.median(x["wall_s"] for x in runs if x["way"] == name),
        }
        for name in ways
    }
    for name, s in summary.items():
        print(f"{name:22} best {s['wall_best_s']:6.1f} s  median {s['wall_median_s']:6.1f} s")
    write_result({"spec": args.spec, "runs": runs, "summary": summary}, Path(args.out))


def _run(spec: str, out: Path, env: dict) -> dict:
    start, t = time.time(), time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "batchveh.sweep", spec, "--quiet", "--overwrite", "--out", str(out)],
        cwd=ROOT,
        env={**os.environ, **env},
        capture_output=True,
        text=True,
    )
    row = {"wall_s": time.perf_counter() - t, "returncode": done.returncode, "start": start}
    m = next((SUMMARY.match(x.strip()) for x in done.stdout.splitlines() if SUMMARY.match(x.strip())), None)
    if m:
        row.update(sweep_wall_s=float(m["sweep_s"]), compile_s=float(m["compile_s"]), status=m["status"])
    else:
        row["stderr_tail"] = done.stderr.splitlines()[-5:]
    return row


def _landed(cache: Path, start: float) -> list[list]:
    """(module folder, s after the start when its last file landed), in order."""
    out = []
    for d in cache.rglob("*") if cache.exists() else []:  # Warp keeps its modules under a version folder
        files = [f for f in d.iterdir() if f.is_file()] if d.is_dir() else []
        if files:
            out.append([d.name, round(max(f.stat().st_mtime for f in files) - start, 2)])
    return sorted(out, key=lambda x: x[1])


def fresh(args) -> None:
    ways = {"serial": {"BATCHVEH_WARP_PREBUILD": "0"}, "ahead": {}, "threads": {"BATCHVEH_WARP_PREBUILD": "threads"}}
    ways = {k: v for k, v in ways.items() if k in args.ways.split(",")}
    for extra in args.extra_way:  # NAME:KEY=VALUE[,KEY=VALUE...]
        name, _, pairs = extra.partition(":")
        ways[name] = dict(p.split("=", 1) for p in pairs.split(",") if p)
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for name, extra in ways.items():
                caches = Path(tmp) / f"{name}-{r}"
                env = {
                    **extra,
                    "WARP_CACHE_PATH": str(caches / "warp"),
                    "CUDA_CACHE_PATH": str(caches / "cuda"),
                    "BATCHVEH_CACHE": str(caches / "batchveh"),
                    "BATCHVEH_WARP_AHEAD_LOG": str(Path(tmp) / f"ahead-{name}-{r}.jsonl"),
                }
                for kind in ("first", *["warm"] * args.warm_runs):
                    row = {"way": name, "kind": kind, "round": r + 1, **_run(args.spec, Path(tmp) / "r", env)}
                    if kind == "first":
                        row["modules_landed_s"] = _landed(caches / "warp", row["start"])
                    log = Path(env["BATCHVEH_WARP_AHEAD_LOG"])
                    if log.exists():  # what each worker's part took (warp_build.AheadBuild.wait), this run's
                        row["ahead"] = [json.loads(x) for x in log.read_text().splitlines()]
                        log.unlink()
                    runs.append(row)
                    print(json.dumps({k: v for k, v in row.items() if k != "modules_landed_s"}), flush=True)
    summary = {
        f"{name} {kind}": sorted(x["wall_s"] for x in runs if x["way"] == name and x["kind"] == kind)
        for name in ways
        for kind in ("first", "warm")
    }
    for name, walls in summary.items():
        print(f"{name:16} wall " + " / ".join(f"{w:.1f} s" for w in walls))
    doc = {"spec": args.spec, "fresh": True, "runs": runs, "summary_wall_s": summary}
    write_result(doc, Path(args.out))


if __name__ == "__main__":
    main()
