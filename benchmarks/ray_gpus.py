"""One host, side by side: the in-process sweep against a Ray sweep with one worker per GPU (issue 13).

    python benchmarks/ray_gpus.py --backend mjx --size 262144 --out benchmarks/results/h200x2-ray-gpus.json
    python benchmarks/ray_gpus.py --backend mujoco --size 64          # the CPU, to see that it runs

Writes one random sweep over sweeps/slope.yaml's ranges (slope, friction, speed; 5 s after the
settle) and runs it with the CLI as a user would, alternating `--executor local` (mjx shards each
chunk over every local GPU; warp uses one) and `--executor ray` (a local Ray instance, one worker
per GPU, or per CPU without GPUs), `--repeat` times each, in fresh processes. JAX's persistent
compile cache is shared, so from the second repeat on the compile is mostly a cache load. Prints
a table and, with --out, writes the JSON. "after compile" divides by the sweep's wall less its
compile time (the longest worker's under Ray); "process s" is the whole command, Ray's start
included. Last, what 10 million variants of 10 s (2,100 steps of 5 ms with the settle) would take
on N GPUs (or CPU workers) at the Ray rate per worker.
"""

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
SUMMARY = re.compile(
    r"^(\d+) rows \((\d+) run now\).*\| ([\d.]+) s wall, compile ([\d.]+) s, "
    r"([\d.e+]+) variant-steps/s on (\S+) \((.*)\)$"
)


def write_spec(folder: Path, size: int) -> Path:
    raw = yaml.safe_load((ROOT / "sweeps" / "slope.yaml").read_text())
    ranges = {k: {"low": v["start"], "high": v["stop"]} for k, v in raw["sweep"]["params"].items()}
    raw["sweep"] = {"method": "random", "n": size, "seed": 0, "params": ranges}
    raw["name"] = f"ray-gpus-{size}"
    path = folder / "spec.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def run(spec: Path, executor: str, backend: str, out: Path, steps: int) -> dict:
    cmd = [sys.executable, "-m", "batchveh.sweep", str(spec), "--backend", backend, "--executor", executor]
    cmd += ["--out", str(out), "--overwrite", "--quiet"]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    process_s = time.perf_counter() - t0
    line = next((m for m in map(SUMMARY.match, done.stdout.splitlines()) if m), None)
    if done.returncode or line is None:
        raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    rows, _, wall, compile_s, rate, _, device = line.groups()
    wall, compile_s = float(wall), float(compile_s)
    return {
        "executor": executor,
        "wall_s": wall,
        "compile_s": compile_s,
        "rate": float(rate),
        "rate_after_compile": int(rows) * steps / (wall - compile_s),
        "process_s": process_s,
        "device": device,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=262144, help="variants (default 262,144: 131,072 per GPU on two)")
    ap.add_argument("--backend", default="mjx", choices=["mjx", "warp", "mujoco"])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--out", help="JSON file to write, e.g. benchmarks/results/h200x2-ray-gpus.json")
    ap.add_argument("--note", default="")
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    from batchveh.sweeping.spec import load_spec

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        spec = write_spec(Path(tmp), args.size)
        steps = load_spec(spec).stats_config().n_steps
        for i in range(args.repeat):
            for executor in ("local", "ray"):
                rows.append({"repeat": i + 1, **run(spec, executor, args.backend, Path(tmp) / executor, steps)})
                print(json.dumps(rows[-1]), flush=True)
    best = {e: max(r["rate_after_compile"] for r in rows if r["executor"] == e) for e in ("local", "ray")}
    workers = int(re.match(r"Ray, (\d+) workers", rows[1]["device"]).group(1))
    per_worker = best["ray"] / workers
    ten_million = {n: 1e7 * 2100 / (per_worker * n) for n in (1, 2, 8, 64)}  # seconds
    print(f"\n{args.size:,} variants x {steps:,} steps, backend {args.backend}")
    print(
        f"{'executor':8} {'repeat':>6} {'wall s':>8} {'compile s':>9} {'rate':>10} {'after compile':>13} "
        f"{'process s':>9}  device"
    )
    for r in rows:
        print(
            f"{r['executor']:8} {r['repeat']:>6} {r['wall_s']:>8.1f} {r['compile_s']:>9.1f} {r['rate']:>10.3g} "
            f"{r['rate_after_compile']:>13.3g} {r['process_s']:>9.1f}  {r['device']}"
        )
    ratio = best["ray"] / best["local"]
    print(f"Ray / in-process, best rates after the compile: {ratio:.3f}")
    print(
        f"10 million variants x 2,100 steps at {per_worker:.3g} variant-steps/s per Ray worker: "
        + ", ".join(f"{s / 3600:.2f} h on {n}" for n, s in ten_million.items())
    )
    res = {
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "command": "python benchmarks/ray_gpus.py " + " ".join(sys.argv[1:]),
        "machine": f"{platform.node()}, {os.cpu_count()} CPUs, {platform.system()}",
        "backend": args.backend,
        "variants": args.size,
        "note": args.note,
        "rows": rows,
        "best_rate_after_compile": best,
        "ray_over_local": ratio,
        "ray_workers": workers,
        "ten_million_x_2100_steps_s": ten_million,
    }
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
