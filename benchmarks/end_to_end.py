"""End to end: `python -m batchveh.sweep SPEC` timed as a user runs it, in fresh processes.

    python benchmarks/end_to_end.py benchmarks/slope_100k.yaml --label h200
    python benchmarks/end_to_end.py sweeps/slope.yaml --limit 512 --label cpu-2core

Three kinds of run, each a new process (Python start, imports, compile, the sweep, the Parquet
parts and the summary), from the repository root, into a temporary folder:

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
"""

import argparse
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from cpu_overhead import cpu_model  # noqa: E402

SUMMARY = re.compile(
    r"(?P<rows>\d+) rows \((?P<ran>\d+) run now\): (?P<status>.*?) \| (?P<sweep_s>[\d.]+) s wall, "
    r"compile (?P<compile_s>[\d.]+) s, (?P<rate>[\d.e+-]+) variant-steps/s on (?P<backend>\w+) \((?P<device>.*)\)$"
)


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
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("spec", nargs="?", default="sweeps/slope.yaml", help="sweep YAML (default: the main job)")
    ap.add_argument("--limit", type=int, help="run only the first N variants (--limit of the sweep)")
    ap.add_argument("--backend", help="--backend of the sweep (default: the spec's, usually auto)")
    ap.add_argument("--warm", type=int, default=1, help="warm runs after the cold one (default 1)")
    ap.add_argument("--label", help="machine label for the file name (default: gpu or cpu-Ncore)")
    ap.add_argument("--note", default="")
    ap.add_argument("--out", help="JSON path (default benchmarks/results/LABEL-end-to-end-SPEC[-BACKEND].json)")
    args = ap.parse_args()

    found_gpus = gpus()
    backend = f"-{args.backend}" if args.backend else ""
    label = args.label or ("gpu" if found_gpus else f"cpu-{os.cpu_count()}core")
    out = (
        Path(args.out)
        if args.out
        else ROOT / "benchmarks" / "results" / f"{label}-end-to-end-{Path(args.spec).stem}{backend}.json"
    )
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
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
