"""Wall time of the README's main job, `python -m batchveh.sweep sweeps/slope.yaml`, as a user runs it.

    python benchmarks/mainjob.py --out benchmarks/results/cpu-2core-mainjob.json --note "..."

Runs the command in a fresh process (Python start, imports, the sweep, the Parquet parts and the
summary), from the repository root, into a temporary folder with --overwrite, and records the
wall time, the sweep's own summary line, the machine and its load average before and after
(other work on a shared machine slows it).
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spec", default="sweeps/slope.yaml")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from cpu_overhead import cpu_model

    runs = []
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            out = str(Path(tmp) / "mainjob")
            cmd = [sys.executable, "-m", "batchveh.sweep", args.spec, "--out", out, "--overwrite"]
            load0 = os.getloadavg()[0]
            t0 = time.perf_counter()
            done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=True)
            wall = time.perf_counter() - t0
            tail = [line for line in done.stdout.splitlines() if line.strip()][-3:]
            runs.append({"wall_s": wall, "load_average_before_after": [load0, os.getloadavg()[0]], "summary": tail})
            print(f"{wall:.1f} s: {tail}", flush=True)
    import mujoco

    res = {
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "command": f"python -m batchveh.sweep {args.spec} --out DIR --overwrite",
        "machine": f"{cpu_model()}, {os.cpu_count()} CPUs, {platform.system()}",
        "mujoco": mujoco.__version__,
        "python": platform.python_version(),
        "note": args.note,
        "runs": runs,
    }
    print(json.dumps(res))
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
