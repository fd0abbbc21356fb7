"""End to end, two versions of the code side by side: `python -m batchveh.sweep SPEC` from each
source tree in turn, fresh processes, warm caches, on the same machine in the same run.

    git archive OLD batchveh | tar -x -C /tmp/old
    python benchmarks/end_to_end_ab.py benchmarks/slope_100k.yaml --tree old=/tmp/old --tree new=. --rounds 3

Each tree runs once untimed first (its XLA program into the shared compile cache, Warp's kernels
into Warp's), then the trees alternate for --rounds rounds. A run's wall is the process's, from
the parent; the sweep's own summary line (its wall, compile, rate) is kept too. The processes run
with the tree as their working directory, so each imports its own `batchveh`.
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
from end_to_end import SUMMARY, gpus  # noqa: E402


def run(tree: Path, spec: Path, out: Path, cache: Path, extra: list[str], env: dict[str, str]) -> dict:
    t = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "batchveh.sweep", str(spec), "--quiet", "--overwrite", "--out", str(out), *extra],
        cwd=tree,
        env={**os.environ, "BATCHVEH_CACHE": str(cache), **env},
        capture_output=True,
        text=True,
    )
    row = {"wall_s": time.perf_counter() - t, "returncode": done.returncode}
    m = next((SUMMARY.match(x.strip()) for x in done.stdout.splitlines() if SUMMARY.match(x.strip())), None)
    if m:
        row.update(sweep_wall_s=float(m["sweep_s"]), compile_s=float(m["compile_s"]), rate=float(m["rate"]))
        row["status"] = m["status"]
    else:
        row["stderr_tail"] = done.stderr.splitlines()[-5:]
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("spec")
    ap.add_argument("--tree", action="append", required=True, help="NAME=PATH of a source tree holding batchveh/")
    ap.add_argument("--env", action="append", default=[], help="NAME:KEY=VALUE, an environment variable for one tree")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--limit", type=int, help="run only the first N variants (--limit of the sweep)")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    extra = ["--limit", str(args.limit)] if args.limit else []
    trees = {k: Path(v).resolve() for k, v in (t.split("=", 1) for t in args.tree)}  # a path may repeat
    spec = Path(args.spec).resolve()
    envs: dict[str, dict[str, str]] = {name: {} for name in trees}
    for e in args.env:
        name, kv = e.split(":", 1)
        envs[name].update([kv.split("=", 1)])
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        cache = Path(tmp) / "jax-cache"
        for name, tree in trees.items():
            row = run(tree, spec, Path(tmp) / "r", cache, extra, envs[name])
            print(json.dumps({"tree": name, "kind": "warm-up", **row}), flush=True)
        for r in range(args.rounds):
            for name, tree in trees.items():
                row = {"tree": name, "round": r + 1, **run(tree, spec, Path(tmp) / "r", cache, extra, envs[name])}
                runs.append(row)
                print(json.dumps(row), flush=True)
    summary = {}
    for name in trees:
        mine = [x for x in runs if x["tree"] == name]
        summary[name] = {
            "wall_s": [round(x["wall_s"], 2) for x in mine],
            "wall_median_s": statistics.median(x["wall_s"] for x in mine),
            "sweep_median_s": statistics.median(x.get("sweep_wall_s", float("nan")) for x in mine),
            "compile_median_s": statistics.median(x.get("compile_s", float("nan")) for x in mine),
        }
        s = summary[name]
        print(f"{name:8} process {s['wall_s']} s (median {s['wall_median_s']:.2f}); sweep {s['sweep_median_s']:.1f} s")
    info = {
        "spec": args.spec,
        "limit": args.limit,
        "trees": {k: str(v) for k, v in trees.items()},
        "env": envs,
        "gpus": gpus(),
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "cpus": os.cpu_count(),
    }
    Path(args.out).write_text(json.dumps({"info": info, "runs": runs, "summary": summary}, indent=1) + "\n")


if __name__ == "__main__":
    main()
