"""What the first GPU operation of a sweep process costs, and whether it can overlap the imports.

    python benchmarks/gpu_start.py benchmarks/slope_100k.yaml --rounds 2 --out start.json

A sweep process's first GPU operation (after JAX's backend starts) took 2.1-2.9 s on one H200
wherever it fell (benchmarks/process_profile.py), while importing mujoco.mjx took 2.5 s of CPU.
Four ways of starting `python -m batchveh.sweep SPEC`, alternating, each a fresh process:

- `plain`: as a user runs it;
- `overlap`: a thread puts one float on the GPU (and waits for it) while the main thread goes on;
- `no-prealloc`: XLA_PYTHON_CLIENT_PREALLOCATE=false (JAX does not reserve 75% of the GPU's memory);
- `overlap+no-prealloc`: both.
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
    args = ap.parse_args()
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
    Path(args.out).write_text(json.dumps({"spec": args.spec, "runs": runs, "summary": summary}, indent=1) + "\n")


if __name__ == "__main__":
    main()
