"""How long does a sizing session take? `python -m batchveh.size` timed as a user runs it, beside the plain sweep of the
same conditions (its peer, in the same run), each a fresh process.

    python benchmarks/sizing.py robot --n 100000 --backend warp --label h200      # issue 52: <= 60 s warm, 90 s fresh
    python benchmarks/sizing.py seed --n 100000 --backend warp --label h200       # the seed's 100,000 x 10 s, <= 45 s
    python benchmarks/sizing.py robot --n 400 --backend mujoco --label cpu-2core  # within 4x its own servo sweep

The sessions: `robot`, sweeps/delivery_robot.yaml (a 60-80 kg robot) with friction 0.4-0.9 swept too, N LHS conditions
x 5 s, at --share 0.99; `seed`, benchmarks/slope_100k.yaml's seed vehicle (N LHS conditions x 10 s) at --share 0.9 (no
catalogue motor covers 99% of it). Each spec is written into a temporary folder with `n: N`.

Runs, in this order, each a new process in a fresh output folder: the session (`first`: the machine's caches as they
are; on a fresh GPU machine it pays Warp's kernel builds and the XLA compile), the plain sweep of the same spec with
the ideal servo (`sweep`, the peer), then the session --warm more times (`warm`). Per run: the wall, and from the
session's sizing.json its phases (servo sweep, screen, in the loop, trace, report) and the candidates run. The table
gives each session's wall against the sweep's (the ratio). JSON: benchmarks/results/LABEL-sizing-SESSION-N.json.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from datetime import date
from importlib import metadata
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
SESSIONS = {
    "robot": (ROOT / "sweeps" / "delivery_robot.yaml", "0.99"),
    "seed": (ROOT / "benchmarks" / "slope_100k.yaml", "0.9"),
}


def spec_for(session: str, n: int, folder: Path) -> Path:
    """The session's spec with n LHS conditions (the robot with friction swept), written into folder."""
    path, _ = SESSIONS[session]
    raw = yaml.safe_load(path.read_text())
    raw["name"] = f"{session}_{n}"
    if session == "robot":
        raw["fixed"].pop("friction", None)
        raw["sweep"]["params"]["friction"] = {"low": 0.4, "high": 0.9}
    raw["sweep"]["method"], raw["sweep"]["n"] = "lhs", n
    raw["output"] = str(folder / "results")
    out = folder / f"{session}_{n}.yaml"
    out.write_text(yaml.safe_dump(raw, sort_keys=False))
    return out


def timed(cmd: list[str]) -> tuple[float, str]:
    """(wall, the last line of stdout) of a fresh process from the repository root."""
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"})
    wall = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(f"{' '.join(cmd)}: exit {done.returncode}: {done.stderr[-3000:]}")
    lines = done.stdout.strip().splitlines()
    summary = [x for x in lines if " rows (" in x]  # a sweep's own summary line: its wall inside the process
    return wall, (summary or lines or [""])[-1]


def write(args: argparse.Namespace, runs: list[dict], share: str) -> Path:
    """The JSON of the runs so far (written after each run, so that a run cut short by a time limit keeps the
    ones before it): the ratio to the sweep once the sweep ran."""
    try:
        gpu = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True,
                             text=True, check=False).stdout.strip().splitlines()  # fmt: skip
    except OSError:
        gpu = []
    versions = {}
    for pkg in ("mujoco", "mujoco-warp", "warp-lang", "jax"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    sweep = next((r["wall_s"] for r in runs if r["kind"] == "sweep"), None)
    path = Path(args.json or ROOT / "benchmarks" / "results" / f"{args.label}-sizing-{args.session}-{args.n}.json")
    path.write_text(
        json.dumps(
            {
                "what": __doc__.split("\n\n")[0],
                "date": str(date.today()),
                "session": args.session,
                "conditions": args.n,
                "share": float(share),
                "backend": args.backend,
                "executor": args.executor or "default",
                "machine": {
                    "label": args.label,
                    "cpus": os.cpu_count(),
                    "gpus": gpu,
                    "python": platform.python_version(),
                },  # fmt: skip
                "versions": versions,
                "runs": runs,
                "session_over_sweep": {
                    r["kind"]: round(r["wall_s"] / sweep, 3) for r in runs if r["kind"] != "sweep" and sweep
                },
                "code": args.note,
            },
            indent=1,
        )
        + "\n"
    )
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("session", choices=sorted(SESSIONS))
    ap.add_argument("--n", type=int, default=100_000, help="conditions (LHS)")
    ap.add_argument("--backend", default="warp", choices=("warp", "mujoco"))
    ap.add_argument("--warm", type=int, default=1, help="warm sessions after the first")
    ap.add_argument("--executor", choices=("local", "gpus", "ray"), help="as the size command's")
    ap.add_argument("--label", default=platform.node() or "machine")
    ap.add_argument("--json", help="default: benchmarks/results/LABEL-sizing-SESSION-N.json")
    ap.add_argument("--note", default="", help="the code's and the machine's state, as the JSON's 'code'")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="sizing-"))
    spec = spec_for(args.session, args.n, tmp)
    share = SESSIONS[args.session][1]
    extra = ["--executor", args.executor] if args.executor else []
    runs = []
    kinds = ["first", "sweep", *["warm"] * args.warm]
    for i, kind in enumerate(kinds):
        out = tmp / f"run{i}"
        if kind == "sweep":  # the peer: the same conditions with the ideal servo, as the session's first phase
            servo = yaml.safe_load(spec.read_text())
            servo.setdefault("vehicle", {}).setdefault("motors", {})["model"] = "servo"
            servo_path = tmp / "servo.yaml"
            servo_path.write_text(yaml.safe_dump(servo, sort_keys=False))
            cmd = [sys.executable, "-m", "batchveh.sweep", str(servo_path), "--out", str(out), "--quiet",
                   "--backend", args.backend, *extra]  # fmt: skip
        else:
            cmd = [sys.executable, "-m", "batchveh.size", str(spec), "--catalogue", str(CATALOGUE), "--out", str(out),
                   "--quiet", "--share", share, "--backend", args.backend, *extra]  # fmt: skip
        wall, line = timed(cmd)
        row = {"kind": kind, "wall_s": round(wall, 2), "last_line": line}
        if kind != "sweep":
            s = json.loads((out / "sizing.json").read_text())
            row["phases_s"] = {k: round(v, 2) for k, v in s["wall_s"].items()}
            row["chosen"], row["steer"] = s["chosen"], s["steer"]
            keys = ("motor", "coverage", "not_simulated", "residual_K", "hot_runs")  # hot_runs: the variants run hot
            row["loop"] = [{k: r.get(k) for k in keys} for r in s["loop"]]
            row["candidates_run"] = len(s["loop"])
        runs.append(row)
        shutil.rmtree(out, ignore_errors=True)
        print(f"{kind:6} {wall:8.1f} s  {line[:150]}", flush=True)
        path = write(args, runs, share)
    sweep = next(r["wall_s"] for r in runs if r["kind"] == "sweep")
    print(f"\n{'run':6} {'wall s':>8} {'/ sweep':>8} {'servo':>7} {'loop':>7} {'screen':>7}")
    for r in runs:
        p = r.get("phases_s", {})
        print(f"{r['kind']:6} {r['wall_s']:8.1f} {r['wall_s'] / sweep:8.2f} {p.get('servo sweep', 0):7.1f} "
              f"{p.get('in the loop', 0):7.1f} {p.get('screen', 0):7.1f}")  # fmt: skip
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
