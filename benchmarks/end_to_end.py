"""How long does a user wait for `python -m batchveh.sweep SPEC`, timed from outside in fresh processes?

    python benchmarks/end_to_end.py benchmarks/slope_100k.yaml --label h200
    python benchmarks/end_to_end.py sweeps/slope.yaml --limit 512 --label cpu-2core
    python benchmarks/end_to_end.py benchmarks/slope_100k.yaml --tree old=/tmp/old --tree new=. --rounds 3
    python benchmarks/end_to_end.py sweeps/slope.yaml --tyres --rounds 2
    python benchmarks/end_to_end.py start benchmarks/slope_100k.yaml --fresh --rounds 1 --out FILE  # its --help

Four modes, each run a new process (Python start, imports, compile, the sweep, the Parquet parts and the
summary) from the repository root into a temporary folder. The default, three kinds of run:

- `first`: the first run this script makes, with the machine's caches as they are. On a fresh GPU
  machine it pays what only the first launch pays: Warp builds its kernels (into Warp's kernel
  cache) and the CUDA driver loads them. The file records what was in each cache before it.
- `cold`: a new process with an empty JAX compile cache (BATCHVEH_CACHE set to a new folder):
  the XLA compile is paid, Warp's kernels are already built.
- `warm` (--warm N times): a new process with that compile cache filled by the cold run.

The JSON (--out, default benchmarks/results/LABEL-end-to-end-SPEC[-BACKEND].json) holds each run's wall
time, the sweep's own summary (its wall, compile, rate and status counts), the caches it found,
the load average around it, and the machine, device and versions. The MuJoCo C backend
compiles nothing, so there the three kinds differ only by the operating system's file cache.

--tree NAME=PATH (twice or more): source trees side by side (was end_to_end_ab.py), e.g. two commits
(`git archive OLD batchveh | tar -x -C /tmp/old`). Each tree runs once untimed (its XLA program into
the shared compile cache, Warp's kernels into Warp's), then the trees alternate for --rounds rounds,
each process with the tree as its working directory (so it imports that tree's batchveh). --env
NAME:KEY=VALUE sets a variable for one tree. One tree alone times the same code --rounds times.
JSON: benchmarks/results/LABEL-end-to-end-ab.json.

--tyres: the spec as given (the vehicle's default tyre, `slip`) and a copy with the rigid contact,
alternated (slip, rigid, slip, ...) on MuJoCo C, --rounds rounds (was tyres_cpu.py); per model the
best and median wall and sweep times and their ratios. JSON: LABEL-tyres-cpu-SPEC.json.

`start` (was gpu_start.py; `python benchmarks/end_to_end.py start --help`): what a GPU sweep process's start
costs, four ways of starting it alternated; with --fresh, the first run on a fresh machine, each way on empty
caches of its own (MuJoCo Warp's kernels built ahead by worker processes, by threads, or at first launch).
JSON: --out.
"""

import argparse
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench import cpu_model, default_label, result_path, write_result  # noqa: E402

SUMMARY = re.compile(
    r"(?P<rows>\d+) rows \((?P<ran>\d+) run now\): (?P<status>.*?) \| (?P<sweep_s>[\d.]+) s wall, "
    r"compile (?P<compile_s>[\d.]+) s, (?P<rate>[\d.e+-]+) variant-steps/s on (?P<backend>\w+) \((?P<device>.*)\)$"
)


START_DOC = """\
What the first GPU operation of a sweep process costs, and whether it can overlap the imports.

    python benchmarks/end_to_end.py start benchmarks/slope_100k.yaml --rounds 2 --out start.json

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
(BATCHVEH_WARP_PREBUILD=0: each module builds at its first launch), and `threads` (BATCHVEH_WARP_PREBUILD=threads:
Warp's own parallel loading) where --ways names it. Each first run also records when each
kernel module landed in Warp's cache (s after the start), and what each worker's part took.
Results: benchmarks/results/h200-first-gpu-run.json.
"""


def version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def gpus() -> list[str]:
    """'name, driver version, memory' of each NVIDIA GPU nvidia-smi lists (none without it)."""
    if not shutil.which("nvidia-smi"):
        return []
    q = ["nvidia-smi", "--query-gpu=name,driver_version,memory.total", "--format=csv,noheader"]
    done = subprocess.run(q, capture_output=True, text=True)
    return [line.strip() for line in done.stdout.splitlines() if line.strip()] if done.returncode == 0 else []


def warp_cache_dir() -> Path | None:
    """Where Warp keeps its built kernels (its own rule: WARP_CACHE_PATH, else the user cache folder)."""
    ver = version("warp-lang")
    if ver is None:
        return None
    if "WARP_CACHE_PATH" in os.environ:
        return Path(os.environ["WARP_CACHE_PATH"]).resolve() / ver
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "warp" / ver


def entries(path: Path | None) -> int | None:
    """Files and folders directly in `path`; 0 where it does not exist, None where it has no meaning."""
    if path is None:
        return None
    return len(list(path.iterdir())) if path.is_dir() else 0


def caches(jax_cache: Path) -> dict:
    """What each compile cache holds before a run."""
    warp = warp_cache_dir()
    nv = Path.home() / ".nv" / "ComputeCache"  # the CUDA driver's own cache of compiled modules
    return {
        "jax_compile_cache": str(jax_cache),
        "jax_compile_cache_entries": entries(jax_cache),
        "warp_kernel_cache": str(warp) if warp else None,
        "warp_kernel_cache_entries": entries(warp),
        "cuda_compute_cache_entries": entries(nv) if gpus() else None,
    }


def run_once(kind: str, cmd: list[str], env: dict, jax_cache: Path) -> dict:
    found = caches(jax_cache)
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    lines = [line.strip() for line in done.stdout.splitlines() if line.strip()]
    row = {
        "kind": kind,
        "wall_s": wall,
        "returncode": done.returncode,
        "load_average_before_after": [load0, os.getloadavg()[0]],
        "caches_before": found,
    }
    match = next((SUMMARY.match(line) for line in lines if SUMMARY.match(line)), None)
    if match:
        g = match.groupdict()
        row.update(
            summary=match.group(0),
            sweep_wall_s=float(g["sweep_s"]),
            compile_s=float(g["compile_s"]),
            variant_steps_per_s=float(g["rate"]),
            backend=g["backend"],
            device=g["device"],
            rows=int(g["rows"]),
            status=g["status"],
            outside_sweep_s=wall - float(g["sweep_s"]),  # Python start, imports, spec, summary
        )
    if done.returncode:
        row["stderr_tail"] = done.stderr.strip().splitlines()[-5:]
    print(f"{kind}: {wall:.1f} s, {row.get('summary', done.stderr.strip()[-300:])}", flush=True)
    return row


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "start":
        return start_main(sys.argv[2:])
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("spec", nargs="?", default="sweeps/slope.yaml", help="sweep YAML (default: the main job)")
    ap.add_argument("--limit", type=int, help="run only the first N variants (--limit of the sweep)")
    ap.add_argument("--backend", help="--backend of the sweep (default: the spec's, usually auto)")
    ap.add_argument("--warm", type=int, default=1, help="warm runs after the cold one (default 1)")
    ap.add_argument("--label", help="machine label for the file name (default: the GPU's kind or cpu-Ncore)")
    ap.add_argument("--note", default="")
    ap.add_argument("--out", help="JSON path (default benchmarks/results/LABEL-end-to-end-SPEC[-BACKEND].json)")
    ap.add_argument("--tree", action="append", help="NAME=PATH of a source tree holding batchveh/ (A/B mode)")
    ap.add_argument("--env", action="append", default=[], help="--tree mode: NAME:KEY=VALUE for one tree")
    ap.add_argument("--tyres", action="store_true", help="slip against rigid on MuJoCo C, alternated")
    ap.add_argument("--rounds", type=int, help="--tree / --tyres: rounds (default 3 / 2)")
    args = ap.parse_args()
    if args.tree:
        args.rounds = args.rounds or 3
        return trees_main(args)
    if args.tyres:
        args.rounds = args.rounds or 2
        return tyres_main(args)

    found_gpus = gpus()
    backend = f"-{args.backend}" if args.backend else ""
    label = args.label or default_label()
    out = result_path(f"end-to-end-{Path(args.spec).stem}{backend}", label, args.out)
    sweep = [sys.executable, "-m", "batchveh.sweep", args.spec, "--quiet", "--overwrite"]
    sweep += ["--limit", str(args.limit)] if args.limit else []
    sweep += ["--backend", args.backend] if args.backend else []
    user_cache = Path(os.environ.get("BATCHVEH_CACHE", Path.home() / ".cache" / "batchveh" / "jax"))
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        fresh_cache = Path(tmp) / "jax-cache"
        fresh_env = {**os.environ, "BATCHVEH_CACHE": str(fresh_cache)}
        plan = [("first", user_cache, dict(os.environ)), ("cold", fresh_cache, fresh_env)]
        plan += [("warm", fresh_cache, fresh_env)] * args.warm
        for kind, cache, env in plan:
            runs.append(run_once(kind, [*sweep, "--out", str(Path(tmp) / "results")], env, cache))
    first = runs[0]["caches_before"]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    dirty = subprocess.run(["git", "status", "--porcelain", "batchveh"], cwd=ROOT, capture_output=True, text=True)
    res = {
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "command": " ".join(["python -m batchveh.sweep", *sweep[3:], "--out", "DIR"]),
        "spec": args.spec,
        "limit": args.limit,
        "machine": f"{cpu_model()}, {os.cpu_count()} CPUs, {platform.system()}",
        "gpus": found_gpus,
        "label": label,
        # a fresh machine: no kernel Warp built before, no XLA program cached (only meaningful on a GPU backend)
        "first_run_on_fresh_caches": not first["warp_kernel_cache_entries"] and not first["jax_compile_cache_entries"],
        "code": commit.stdout.strip() + (" with uncommitted changes in batchveh/" if dirty.stdout.strip() else ""),
        "versions": {
            "python": platform.python_version(),
            **{d: version(d) for d in ("mujoco", "mujoco-mjx", "jax", "jaxlib", "warp-lang")},
        },
        "note": args.note,
        "runs": runs,
    }
    write_result(res, out)


def run_tree(tree: Path, spec: Path, out: Path, cache: Path, extra: list[str], env: dict[str, str]) -> dict:
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


def trees_main(args) -> None:
    """--tree: source trees alternated, fresh processes, warm caches."""
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
            row = run_tree(tree, spec, Path(tmp) / "r", cache, extra, envs[name])
            print(json.dumps({"tree": name, "kind": "warm-up", **row}), flush=True)
        for r in range(args.rounds):
            for name, tree in trees.items():
                row = {"tree": name, "round": r + 1, **run_tree(tree, spec, Path(tmp) / "r", cache, extra, envs[name])}
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
    out = result_path("end-to-end-ab", args.label, args.out)
    write_result({"info": info, "runs": runs, "summary": summary}, out)


def with_tyre(spec: Path, model: str, folder: Path) -> Path:
    """A copy of `spec` whose vehicle runs the wheel-ground model `model`."""
    text = yaml.safe_load(spec.read_text())
    vehicle = dict(text.get("vehicle") or {})
    vehicle["tyre"] = {**(vehicle.get("tyre") or {}), "model": model}
    out = folder / f"{spec.stem}-{model}.yaml"
    out.write_text(yaml.safe_dump({**text, "vehicle": vehicle}, sort_keys=False))
    return out


def tyres_main(args) -> None:
    """--tyres: slip against rigid on MuJoCo C, alternated."""
    spec = Path(args.spec)
    out = result_path(f"tyres-cpu-{spec.stem}", args.label, args.out)
    runs = {"slip": [], "rigid": []}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        specs = {m: with_tyre(ROOT / spec, m, tmp) for m in runs}
        env = {**os.environ, "BATCHVEH_CACHE": str(tmp / "jax-cache")}
        for r in range(args.rounds):
            for model in runs:
                cmd = [sys.executable, "-m", "batchveh.sweep", str(specs[model]), "--quiet", "--overwrite"]
                cmd += ["--backend", "mujoco", "--out", str(tmp / "results")]
                cmd += ["--limit", str(args.limit)] if args.limit else []
                runs[model].append(run_once(f"{model} {r + 1}", cmd, env, tmp / "jax-cache"))
    summary = {}
    for model, rows in runs.items():
        walls = [row["wall_s"] for row in rows]
        sweeps = [row["sweep_wall_s"] for row in rows if "sweep_wall_s" in row]
        summary[model] = {
            "wall_best_s": min(walls),
            "wall_median_s": statistics.median(walls),
            "sweep_best_s": min(sweeps) if sweeps else None,
            "sweep_median_s": statistics.median(sweeps) if sweeps else None,
            "status": rows[-1].get("status"),
        }
    ok = all(summary[m]["sweep_best_s"] for m in runs)
    ratios = (
        {
            "sweep_best_slip_over_rigid": summary["slip"]["sweep_best_s"] / summary["rigid"]["sweep_best_s"],
            "wall_best_slip_over_rigid": summary["slip"]["wall_best_s"] / summary["rigid"]["wall_best_s"],
            "wall_median_slip_over_rigid": summary["slip"]["wall_median_s"] / summary["rigid"]["wall_median_s"],
        }
        if ok
        else {}
    )
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    res = {
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "spec": str(spec),
        "limit": args.limit,
        "backend": "mujoco",
        "machine": f"{cpu_model()}, {os.cpu_count()} CPUs, {platform.system()}",
        "code": commit.stdout.strip(),
        "versions": {"python": platform.python_version(), "mujoco": version("mujoco")},
        "order": "slip then rigid, alternating, each a fresh process",
        "summary": summary,
        "ratios": ratios,
        "runs": runs,
    }
    print(f"{'model':6} {'best wall s':>12} {'median wall s':>14} {'best sweep s':>13}  status")
    for model, s in summary.items():
        best = f"{s['wall_best_s']:12.1f} {s['wall_median_s']:14.1f} {s['sweep_best_s'] or 0:13.1f}"
        print(f"{model:6} {best}  {s['status']}")
    for k, v in ratios.items():
        print(f"{k}: {v:.3f}")
    write_result(res, out)


OVERLAP = """
import sys, threading, runpy
import jax, numpy as np
threading.Thread(target=lambda: jax.device_put(np.zeros(1, np.float32)).block_until_ready(), daemon=True).start()
runpy.run_module("batchveh.sweep", run_name="__main__", alter_sys=True)
"""


def start_main(argv=None):
    ap = argparse.ArgumentParser(
        prog="end_to_end.py start", description=START_DOC, formatter_class=argparse.RawDescriptionHelpFormatter
    )
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
    args = ap.parse_args(argv)
    if args.fresh:
        return start_fresh(args)
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


def _start_run(spec: str, out: Path, env: dict) -> dict:
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


def start_fresh(args) -> None:
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
                    row = {"way": name, "kind": kind, "round": r + 1, **_start_run(args.spec, Path(tmp) / "r", env)}
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
