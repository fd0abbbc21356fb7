"""What does a sweep over the vehicle itself cost: preparing structural variants, sweeping them, warp against C?

Sweeps over the vehicle itself (issue 30).

    python benchmarks/structural.py prepare --label cpu-2core
    python benchmarks/structural.py sweep --size 3000 --time 1 --repeat 2 --label cpu-2core
    python benchmarks/structural.py sweep --size 1000000 --time 10 --repeat 1 --backend warp --label h200
    python benchmarks/structural.py resume --size 1000000 --time 10 --backend warp --kill-after 3 --label h200
    python benchmarks/structural.py spread --size 131072 --backend warp --label h200
    python benchmarks/structural.py compare RESULTS_A RESULTS_B --label h200-warp-vs-c

- `prepare`: `make_batch` per variant for payload.mass, wheel.radius and a mix of five structural
  parameters (random values; best of 3), against the old path, a MuJoCo compile per variant
  (`batch.compiled_fields`, on 200 variants).
- `sweep`: the CLI in fresh processes, as a user runs it, alternated: a random (LHS on --lhs) sweep
  over slope, friction and speed ('flat'), and the same with payload.mass and wheel.radius
  ('structural'); each run's process wall, the sweep's own wall and the dry run's estimate.
- `resume`: the structural sweep killed once `--kill-after` parts are written, then `--resume`d:
  the chunks the resume ran, and its rows against an uninterrupted run's (given with --reference,
  or run here first).
- `spread`: one chunk of the structural sweep run twice in one process: the engine's run-to-run
  spread, max and p99 of each statistic's relative difference.
- `compare`: two result folders of the same spec (e.g. warp against MuJoCo C): per-wheel mean and
  peak, p99 and max of the relative error.

Each writes benchmarks/results/LABEL-structural-PART.json (or --out) and prints a table.
"""

import argparse
import json
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parent.parent
FLAT = {
    "slope_deg": {"low": 0, "high": 20},
    "friction": {"low": 0.3, "high": 1.0},
    "speed_kmh": {"low": 0.5, "high": 9.5},
}
VEHICLE = {"payload.mass": {"low": 0, "high": 40}, "wheel.radius": {"low": 0.15, "high": 0.25}}
MIX = ("payload.mass", "wheel.radius", "chassis.z_cg", "wheel.y_cg", "payload.x")
SUMMARY = re.compile(
    r"^(\d+) rows \((\d+) run now\).*\| ([\d.]+) s wall, compile ([\d.]+) s, ([\d.e+]+) variant-steps/s"
)
ESTIMATE = re.compile(r"about (\d+ min|[\d.]+ h|\d+ s) ")
from bench import machine, result_path, write_result  # noqa: E402  (one way to name the machine and the output)

STATS = ("mean", "peak_lp_all")  # per-wheel columns compared: drive_{corner}_{stat}


def write_spec(folder: Path, name: str, size: int, total_time: float, params: dict, lhs: bool) -> Path:
    spec = {
        "name": name,
        "scenario": "straight_line",
        "fixed": {"total_time": total_time, "ramp_time": min(2.0, total_time / 2)},
        "sweep": {"method": "lhs" if lhs else "random", "n": size, "seed": 0, "params": params},
        "output": str(folder / name),
    }
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    return path


def seconds(text: str) -> float:
    value, unit = text.split()
    return float(value) * {"s": 1, "min": 60, "h": 3600}[unit]


def cli(spec: Path, *args: str, timeout: float | None = None) -> dict:
    """One CLI run in a fresh process: its wall, and the summary line's numbers."""
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "batchveh.sweep", str(spec), "--quiet", *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=timeout,
    )
    wall = time.perf_counter() - t0
    out = {"process_s": wall, "rc": done.returncode}
    for line in done.stdout.splitlines():
        if m := SUMMARY.match(line):
            out.update(rows=int(m[1]), ran=int(m[2]), sweep_s=float(m[3]), compile_s=float(m[4]), rate=float(m[5]))
        if m := ESTIMATE.search(line):
            out["estimate_s"] = seconds(m[1])
    if done.returncode:
        out["stderr"] = done.stderr[-2000:]
    return out


def prepare(args) -> dict:
    from batchveh.model.params import base_params
    from batchveh.model.scenarios import make_scenario
    from batchveh.model.vehicle import Vehicle
    from batchveh.stepping.batch import compiled_fields, make_batch, model_for

    v, sc = Vehicle(), make_scenario()
    base = base_params(v, sc)
    rng = np.random.default_rng(0)

    def table(names, n):
        return {
            k: rng.uniform(0, 40, n) if k == "payload.mass" else base[k] + rng.uniform(-0.02, 0.02, n) for k in names
        }

    rows = []
    for case in (("payload.mass",), ("wheel.radius",), MIX):
        make_batch(v, sc, table(case, 16))  # the probe compiles, once per sweep
        times = []
        for _ in range(3):
            t = table(case, args.size)
            t0 = time.perf_counter()
            make_batch(v, sc, t, list(case))
            times.append(time.perf_counter() - t0)
        t = table(case, 200)
        params = {k: np.full(200, x) for k, x in base.items()} | t
        t0 = time.perf_counter()
        compiled_fields(v, sc, model_for(v, sc), params, list(case))
        before = (time.perf_counter() - t0) / 200
        rows.append(
            {
                "params": list(case),
                "n": args.size,
                "us_per_variant": min(times) / args.size * 1e6,
                "runs_s": times,
                "compile_per_variant_us": before * 1e6,
            }
        )
        print(
            f"{'+'.join(case):58s} {rows[-1]['us_per_variant']:8.1f} us/variant, compile {before * 1e6:8.0f} us/variant"
        )
    return {"rows": rows}


def sweep(args) -> dict:
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        specs = {
            "flat": write_spec(folder, "flat", args.size, args.time, FLAT, args.lhs),
            "structural": write_spec(folder, "structural", args.size, args.time, {**FLAT, **VEHICLE}, args.lhs),
        }
        backend = ("--backend", args.backend) if args.backend else ()
        if args.warm:  # Warp builds its kernels on a fresh machine's first launch, JAX fills its cache
            for spec in specs.values():
                cli(spec, "--limit", "1024", "--overwrite", *backend)
        for r in range(args.repeat):
            for kind, spec in specs.items():
                dry = subprocess.run(
                    [sys.executable, "-m", "batchveh.sweep", str(spec), "--dry-run", *backend],
                    capture_output=True,
                    text=True,
                    cwd=ROOT,
                ).stdout
                run = cli(spec, "--overwrite", *backend)
                m = ESTIMATE.search(dry)
                run.update(kind=kind, round=r, estimate_s=seconds(m[1]) if m else None, dry_run=dry.strip())
                runs.append(run)
                print(
                    f"{kind:11s} round {r}: process {run['process_s']:7.1f} s, sweep {run.get('sweep_s', 0):7.1f} s, "
                    f"estimate {run['estimate_s']} s, rc {run['rc']}"
                )
    med = {k: float(np.median([x["process_s"] for x in runs if x["kind"] == k])) for k in ("flat", "structural")}
    ratio = med["structural"] / med["flat"]
    wall = {(x["kind"], x["round"]): x["process_s"] for x in runs}
    pairs = [wall["structural", r] / wall["flat", r] for r in range(args.repeat)]
    print(f"structural / flat, median process wall: {ratio:.3f}; per round {pairs}, median {np.median(pairs):.3f}")
    return {
        "size": args.size,
        "total_time": args.time,
        "lhs": args.lhs,
        "runs": runs,
        "median_process_s": med,
        "ratio": ratio,
    }


def _rows(folder: str):
    """A result folder's rows (or one Parquet file's), in a fixed order."""
    import pandas as pd

    import batchveh

    rows = pd.read_parquet(folder) if folder.endswith(".parquet") else batchveh.load(folder)
    return rows.sort_values(["slope_deg", "friction", "speed_kmh"]).reset_index(drop=True)


def relative(a, b) -> dict:
    """p99 and max of |a - b| / max(|b|, floor), per numeric column both share (floor: 1% of the column's
    largest magnitude, so that near-zero values do not dominate)."""
    out = {}
    for k in a.columns:
        if k in b.columns and a[k].dtype.kind == "f" and not k.startswith(("slope", "friction", "speed")):
            x, y = a[k].to_numpy(float), b[k].to_numpy(float)
            floor = 0.01 * np.nanmax(np.abs(y)) if np.isfinite(y).any() else 1.0
            e = np.abs(x - y) / np.maximum(np.abs(y), floor or 1.0)
            out[k] = {"p99": float(np.nanpercentile(e, 99)), "max": float(np.nanmax(e))}
    return out


def resume(args) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        spec = write_spec(folder, "structural", args.size, args.time, {**FLAT, **VEHICLE}, args.lhs)
        backend = ("--backend", args.backend) if args.backend else ()
        reference = args.reference
        if reference is None:
            reference = str(folder / "reference")
            print("uninterrupted:", cli(spec, "--out", reference, *backend))
        out = folder / "killed"
        proc = subprocess.Popen(
            [sys.executable, "-m", "batchveh.sweep", str(spec), "--quiet", "--out", str(out), *backend],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        while len(list(out.glob("part-*.parquet"))) < args.kill_after and proc.poll() is None:
            time.sleep(0.2)
        parts_at_kill = len(list(out.glob("part-*.parquet")))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        parts_after_kill = len(list(out.glob("part-*.parquet")))
        again = cli(spec, "--out", str(out), "--resume", *backend)
        diff = relative(_rows(str(out)), _rows(reference))
    worst = max(diff.items(), key=lambda kv: kv[1]["max"])
    print(
        f"killed with {parts_at_kill} parts written ({parts_after_kill} after the kill); resume ran {again.get('ran')} "
        f"of {args.size} variants; worst column {worst[0]}: max {worst[1]['max']:.3g}"
    )
    return {
        "size": args.size,
        "total_time": args.time,
        "parts_at_kill": parts_at_kill,
        "parts_after_kill": parts_after_kill,
        "resume": again,
        "against_uninterrupted": diff,
    }


def spread(args) -> dict:
    from batchveh.engines import make_engine, resolve_backend
    from batchveh.stepping.batch import make_batch
    from batchveh.sweeping.spec import load_spec

    with tempfile.TemporaryDirectory() as tmp:
        spec = load_spec(write_spec(Path(tmp), "structural", args.size, args.time, {**FLAT, **VEHICLE}, args.lhs))
    cfg = spec.stats_config()
    engine = make_engine(resolve_backend(args.backend or "auto"), spec.scenario, cfg, args.size, n_variants=args.size)
    rows = spec.table().rows(0, args.size)
    import pandas as pd

    outs = []
    for _ in range(2):
        batch = make_batch(spec.vehicle, spec.scenario, {k: rows[k].to_numpy() for k in spec.params}, spec.params)
        outs.append(pd.DataFrame({k: np.asarray(v) for k, v in engine.run(batch).items()}))
    diff = relative(outs[1], outs[0])
    worst = max(diff.items(), key=lambda kv: kv[1]["max"])
    print(
        f"{args.size} variants twice on {engine.name}: worst column {worst[0]} max {worst[1]['max']:.3g}, "
        f"p99 {worst[1]['p99']:.3g}"
    )
    return {"size": args.size, "total_time": args.time, "engine": engine.implementation, "run_to_run": diff}


def compare(args) -> dict:
    a, b = _rows(args.a), _rows(args.b)
    cols = [f"drive_{c}_{s}" for c in ("lf", "rf", "lr", "rr") for s in STATS]
    ok = (a["status"] == "ok") & (b["status"] == "ok")
    diff = relative(a.loc[ok, cols], b.loc[ok, cols])
    for k, v in diff.items():
        print(f"{k:22s} p99 {v['p99']:.3g}  max {v['max']:.3g}")
    return {
        "a": args.a,
        "b": args.b,
        "rows": int(ok.sum()),
        "per_wheel": diff,
        "worst_p99": max(v["p99"] for v in diff.values()),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("part", choices=("prepare", "sweep", "resume", "spread", "compare"))
    p.add_argument("a", nargs="?", help="compare: a result folder")
    p.add_argument("b", nargs="?", help="compare: the reference result folder")
    p.add_argument("--size", type=int, default=4000, help="variants")
    p.add_argument("--time", type=float, default=1.0, help="simulated seconds per variant")
    p.add_argument("--repeat", type=int, default=2, help="sweep: rounds of flat, then structural")
    p.add_argument("--backend", help="mujoco, mjx or warp (default: the CLI's auto)")
    p.add_argument("--lhs", action="store_true", help="Latin hypercube instead of random values")
    p.add_argument("--warm", action="store_true", help="sweep: one small run of each spec first (caches)")
    p.add_argument("--kill-after", type=int, default=2, help="resume: parts written before the kill")
    p.add_argument("--reference", help="resume: an uninterrupted run's result folder")
    p.add_argument("--label", help="machine label for the file name (default: the machine's, bench.default_label)")
    p.add_argument("--out", help="JSON path (default benchmarks/results/LABEL-structural-PART.json)")
    args = p.parse_args()
    result = {
        "part": args.part,
        "machine": machine(),
        "when": time.strftime("%Y-%m-%d %H:%M:%S"),
        **globals()[args.part](args),
    }
    path = result_path(f"structural-{args.part}", args.label, args.out)
    write_result(json.loads(json.dumps(result, default=str)), path)


if __name__ == "__main__":
    main()
