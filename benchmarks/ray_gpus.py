"""What do several GPUs of one host buy a sweep: --executor ray or gpus against one GPU in-process?

One host, side by side: the in-process sweep against a Ray sweep with one worker per GPU (issue 13), and against
--executor gpus (one process per GPU, no Ray).

    python benchmarks/ray_gpus.py --backend mjx --size 262144 --out benchmarks/results/h200x2-ray-gpus.json
    python benchmarks/ray_gpus.py --backend mujoco --size 64          # the CPU, to see that it runs
    python benchmarks/ray_gpus.py --two-gpus OUTDIR --budget 570      # issue 33, on a host of two GPUs
    python benchmarks/ray_gpus.py --gpu-processes OUTDIR --rounds-1m 2 --rounds-100k 2 --budget 570
    python benchmarks/ray_gpus.py --gpu-processes /tmp/smoke --smoke   # the same on the CPU, to see that it runs

--two-gpus (issue 33) runs the warp engine on benchmarks/slope_100k.yaml (10 s, slip tyre) through the
CLI in fresh processes, in this order, each step only while the budget (s) lasts (--only names steps):
a warm-up in-process (it builds Warp's kernels; not timed); 1,000,000 variants in-process on one GPU
(CUDA_VISIBLE_DEVICES=0) and with --executor ray on both; 100,000 with --executor ray (which runs them
in its own process, Ray not started) and in-process; the same chunks (100,000 in chunks of 50,176)
twice on GPU 0, once on GPU 1 and once on two Ray workers (BATCHVEH_RAY_ALONE=0), for the run-to-run
spread; 400,000 with --executor ray and a Ray worker killed (SIGKILL) 6 s into its first chunk. For
each sweep: the process's wall, each part's landing, the steady rate between the first and the last
part, and the executor's timeline (BATCHVEH_TIMELINE: Ray's start, the workers ready, each chunk where).
Writes OUTDIR/<gpu>x2-ray-scaling.json and OUTDIR/<gpu>x2-warp-spread.json (<gpu>: h200 or h100).

--gpu-processes (issue 33) measures `--executor gpus` (batchveh/sweeping/gpus.py: this process on GPU 0, one
worker process on GPU 1, no Ray) through the CLI in fresh processes on benchmarks/slope_100k.yaml: a warm-up
in-process (not timed), a first CUDA use of each GPU, then --rounds-1m pairs of 1,000,000 variants in-process on one GPU
(CUDA_VISIBLE_DEVICES=0) and with --executor gpus on two (CUDA_VISIBLE_DEVICES=0,1), the order swapped each
round (a shared host drifts between runs), then --rounds-100k pairs of 100,000 with --executor gpus (one
chunk: it runs in its own process) and --executor local, both GPUs visible. Prints a table: each sweep's
process wall, the time before its first part landed, the median chunk's wall (the parts' chunk_wall_s:
prepare and simulate, the compile in the first chunk of each process) and per 100,000 variants, and each
pair's ratio. Writes OUTDIR/<gpu>x2-gpu-processes.json. --smoke: the same on the CPU with the mujoco
engine and a few hundred variants, the two 'GPUs' then naming a CPU worker process of one MuJoCo thread.

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
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench import default_label, machine, write_result  # noqa: E402  (one way to name the machine and the output)

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


SLOPE = ROOT / "benchmarks" / "slope_100k.yaml"
ENV_KEYS = ("CUDA_VISIBLE_DEVICES", "BATCHVEH_RAY_ALONE", "BATCHVEH_RAY_DRIVER", "BATCHVEH_GPU_PROCESSES")


# the vehicle swept too (--structural-n): payload mass and position, wheel radius, track and CG height, the
# ranges of benchmarks/structural_warp_vs_c.yaml
STRUCTURAL = {
    "payload.mass": {"low": 0, "high": 40},
    "payload.x": {"low": -0.2, "high": 0.2},
    "wheel.radius": {"low": 0.15, "high": 0.25},
    "wheel.y_cg": {"low": 0.35, "high": 0.45},
    "chassis.z_cg": {"low": 0.3, "high": 0.4},
}


def spec_of(folder: Path, n: int, structural: bool = False) -> Path:
    raw = yaml.safe_load(SLOPE.read_text())
    raw["sweep"]["n"], raw["name"] = n, f"slope_{n}"
    if structural:
        raw["sweep"]["params"].update(STRUCTURAL)
        raw["name"] = f"structural_{n}"
    path = folder / f"{raw['name']}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def cli(spec: Path, out: Path, args=(), env=None, tmp: Path | None = None, kill_worker=False, backend="warp") -> dict:
    """One sweep through the CLI in a fresh process: its summary, the parts' landings, the timeline."""
    import pyarrow.parquet as pq

    timeline = (tmp or out.parent) / f"{out.name}.timeline.json"
    timeline.unlink(missing_ok=True)
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "BATCHVEH_TIMELINE": str(timeline), **(env or {})}
    cmd = [sys.executable, "-m", "batchveh.sweep", str(spec), "--backend", backend, "--out", str(out)]
    cmd += ["--overwrite", "--quiet", *args]
    t0 = time.time()
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    killed = None
    if kill_worker:  # SIGKILL the Ray worker once it has begun a chunk (a process this script started)
        while proc.poll() is None and killed is None:
            try:
                events = json.loads(timeline.read_text())
            except (OSError, ValueError):
                events = []
            ready = {e.get("where"): e["pid"] for e in events if e["event"] == "worker ready"}
            started = [e for e in events if e["event"] == "chunk start" and e["where"] in ready]
            if started:
                time.sleep(6.0)  # into the chunk: its compile (about 4 s), then 7-8 s of simulation
                os.kill(ready[started[0]["where"]], 9)
                killed = {"t": time.time() - t0, "pid": ready[started[0]["where"]], "chunk": started[0]["chunk"]}
            time.sleep(0.05)
    stdout, stderr = proc.communicate()
    process_s = time.time() - t0
    line = next((m for m in map(SUMMARY.match, stdout.splitlines()) if m), None)
    if proc.returncode or line is None:
        return {"error": f"{' '.join(cmd)} failed ({proc.returncode}): {stdout[-2000:]} {stderr[-3000:]}"}
    rows, ran, wall, compile_s, rate, _, device = line.groups()
    manifest = json.loads((out / "manifest.json").read_text())
    parts = []
    for name, rec in sorted(manifest["parts"].items()):
        meta = json.loads(pq.read_schema(out / name).metadata[b"batchveh"])
        parts.append(
            {
                "part": name,
                "rows": rec["rows"],
                "landed_s": (out / name).stat().st_mtime - t0,
                "chunk_wall_s": meta["chunk_wall_s"],
                "compile_s": meta["compile_s"],
            }
        )
    parts.sort(key=lambda p: p["landed_s"])
    steps = 2100  # 10 s at 5 ms after the 0.5 s settle
    after_first = sum(p["rows"] for p in parts[1:])
    span = parts[-1]["landed_s"] - parts[0]["landed_s"] if len(parts) > 1 else 0.0
    try:
        events = [{**e, "t": round(e["t"] - t0, 3)} for e in json.loads(timeline.read_text())]
    except (OSError, ValueError):
        events = []
    res = {
        "command": " ".join(cmd[1:]),
        "env": {k: v for k, v in (env or {}).items() if k in ENV_KEYS},
        "process_s": round(process_s, 2),
        "sweep_wall_s": float(wall),
        "compile_s": float(compile_s),
        "rows": int(rows),
        "ran": int(ran),
        "rate_whole_sweep": float(rate),
        "device": device,
        "first_part_s": round(parts[0]["landed_s"], 2),
        "last_part_s": round(parts[-1]["landed_s"], 2),
        "steady_rate": after_first * steps / span if span > 0 else None,
        "parts": parts,
        "notes": [ln for ln in stderr.splitlines() if ln.startswith(("note:", "error:"))],
        "timeline": events,
        "manifest_parts": len(manifest["parts"]),
        "part_files": len(list(out.glob("part-*.parquet"))),
    }
    if killed:
        res["killed"] = killed
    return res


def spread(a: Path, b: Path) -> dict:
    """Run-to-run differences of two result folders of the same variants, per numeric column: relative
    |a - b| / max(|a|, |b|) (0 where both are 0) and the same with a floor of 1e-3 of the column's p99
    magnitude (for values near zero, such as a lateral position): max and p99 over the variants."""
    import numpy as np

    sys.path.insert(0, str(ROOT))
    import batchveh

    x = batchveh.load(a).sort_values("variant").reset_index(drop=True)
    y = batchveh.load(b).sort_values("variant").reset_index(drop=True)
    assert (x["variant"].to_numpy() == y["variant"].to_numpy()).all()
    cols = {}
    for k in x.columns:
        if k == "variant" or x[k].dtype.kind not in "fiu" or x[k].dtype.kind == "b":
            continue
        u, v = x[k].to_numpy(np.float64), y[k].to_numpy(np.float64)
        ok = np.isfinite(u) & np.isfinite(v)
        u, v = u[ok], v[ok]
        d = np.abs(u - v)
        big = np.maximum(np.abs(u), np.abs(v))
        rel = np.where(big > 0, d / np.where(big > 0, big, 1), 0.0)
        floor = 1e-3 * np.percentile(big, 99) if big.size else 0.0
        relf = d / np.maximum(big, floor) if floor > 0 else rel
        cols[k] = {
            "rel_max": float(rel.max(initial=0)),
            "rel_p99": float(np.percentile(rel, 99)) if rel.size else 0.0,
            "floored_max": float(relf.max(initial=0)),
            "floored_p99": float(np.percentile(relf, 99)) if relf.size else 0.0,
            "identical_share": float((d == 0).mean()) if d.size else 1.0,
        }
    same_status = float((x["status"] == y["status"]).mean())
    worst = sorted(cols, key=lambda k: -cols[k]["floored_max"])[:8]
    return {"variants": len(x), "status_equal_share": same_status, "worst_floored_max": worst, "columns": cols}


def over_budget(res: dict, name: str, guess_s: float, left: float) -> bool:
    """Whether step `name`, about `guess_s` s, does not fit the `left` s of the budget (noted in res["skipped"])."""
    if left >= guess_s:
        return False
    res["skipped"].append(f"{name} (needs about {guess_s} s, {left:.0f} s left)")
    print(f"skip {name}", flush=True)
    return True


def two_gpus(
    outdir: Path,
    budget: float,
    backend: str = "warp",
    scale: float = 1.0,
    only=None,
    warmup_n=100_000,
    rounds_100k: int = 1,
) -> None:
    t_start = time.time()
    prefix = default_label()  # 'h200x2' on two H200s
    outdir.mkdir(parents=True, exist_ok=True)
    res = {
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "command": "python benchmarks/ray_gpus.py " + " ".join(sys.argv[1:]),
        "machine": machine(),
        "spec": "benchmarks/slope_100k.yaml (10 s, 2,100 steps with the settle; slip tyre), n set per step",
        "steps": {},
        "skipped": [],
    }
    spreads: dict = {"date": res["date"], "machine": res["machine"], "pairs": {}}
    work = Path(tempfile.mkdtemp(prefix="ray33-"))

    def save():
        write_result(res, outdir / f"{prefix}-ray-scaling.json")
        write_result(spreads, outdir / f"{prefix}-warp-spread.json")

    def step(name, guess_s, n, executor, args=(), env=None, kill=False):
        if only and name not in only and not name.startswith("warmup"):
            return None
        if over_budget(res, name, guess_s, budget - (time.time() - t_start)):
            return None
        n = max(1, int(n * scale))
        r = cli(spec_of(work, n), work / name, ["--executor", executor, *args], env, work, kill, backend)
        res["steps"][name] = {"variants": n, "executor": executor, **r}
        print(name, {k: r.get(k) for k in ("process_s", "first_part_s", "steady_rate", "device", "error")}, flush=True)
        save()
        return r

    one = {"CUDA_VISIBLE_DEVICES": "0"}
    step(f"warmup_{warmup_n}_local", 150, warmup_n, "local")
    a = step("1m_local_1gpu", 160, 1_000_000, "local", env=one)
    b = step("1m_ray_2gpu", 110, 1_000_000, "ray")
    if a and b and "error" not in a and "error" not in b:
        res["ray_over_one_gpu_process"] = b["process_s"] / a["process_s"]
        save()
    for r in range(1, rounds_100k + 1):  # alternated: a shared host drifts between runs
        tail = "" if r == 1 else f"_{r}"
        step(f"100k_ray{tail}", 40, 100_000, "ray")
        step(f"100k_local{tail}", 40, 100_000, "local")
    same = ["--chunk-size", str(max(1, int(50176 * scale)))]
    pairs = {
        "gpu0_again": ("same_gpu0_a", "same_gpu0_b"),
        "gpu1": ("same_gpu0_a", "same_gpu1"),
        "ray_workers": ("same_gpu0_a", "same_ray_workers"),
    }
    step("same_gpu0_a", 40, 100_000, "local", same, one)
    step("same_gpu0_b", 40, 100_000, "local", same, one)
    step("same_gpu1", 40, 100_000, "local", same, {"CUDA_VISIBLE_DEVICES": "1"})
    step("same_ray_workers", 50, 100_000, "ray", same, {"BATCHVEH_RAY_ALONE": "0"})
    for name, (x, y) in pairs.items():
        if x in res["steps"] and y in res["steps"] and "error" not in res["steps"][y]:
            spreads["pairs"][name] = {"a": x, "b": y, **spread(work / x, work / y)}
            save()
    step("400k_ray_worker_killed", 80, 400_000, "ray", kill=True)
    if a and b and "error" not in a and "error" not in b and time.time() - t_start < budget - 20:
        spreads["pairs"]["1m_one_gpu_vs_ray_two"] = {
            "a": "1m_local_1gpu",
            "b": "1m_ray_2gpu",
            "note": "chunks of 125,184 in both",
            **spread(work / "1m_local_1gpu", work / "1m_ray_2gpu"),
        }
    res["total_s"] = time.time() - t_start
    save()


def chunk_summary(r: dict) -> dict:
    """A sweep's chunks: how many, the median chunk's wall and the median per 100,000 variants (the parts'
    chunk_wall_s), and where they ran (the executor's timeline; none in-process)."""
    import statistics

    parts = r.get("parts") or []
    where: dict = {}
    for e in r.get("timeline", []):
        if e["event"] == "chunk end":
            where[e["where"]] = where.get(e["where"], 0) + 1
    if not parts:
        return {"chunks": 0, "chunk_s": None, "s_per_100k": None, "where": where}
    return {
        "chunks": len(parts),
        "chunk_s": round(statistics.median(p["chunk_wall_s"] for p in parts), 3),
        "s_per_100k": round(statistics.median(p["chunk_wall_s"] / p["rows"] * 1e5 for p in parts), 3),
        "where": where,
    }


def gpu_processes(
    outdir: Path,
    budget: float,
    backend: str = "warp",
    rounds_1m: int = 2,
    rounds_100k: int = 1,
    warmup_n: int = 100_000,
    smoke: bool = False,
    gpus_chunk: int | None = None,
    warm_chunks: tuple[int, ...] = (),
    gpus_env: dict[str, str] | None = None,
    structural_n: int = 0,
) -> dict:
    """Issue 33: --executor gpus against one GPU in-process, alternated (see the docstring). `gpus_chunk`: the
    1,000,000-variant gpus sweeps' --chunk-size (default: the executor's, shared_chunk). `warm_chunks`: after
    the warm-up, one in-process sweep of one chunk of each of these sizes (not timed in the pairs), so that
    JAX's persistent compile cache holds each executable the pairs use: both peers start warm. `gpus_env`: each
    round also runs the gpus sweep with these environment variables added (its ratio to the same round's
    in-process sweep is the pair '1m_env'). `structural_n`: last, that many variants with the vehicle swept too
    (STRUCTURAL) with --executor gpus on two GPUs, then in-process on one."""
    import statistics

    t_start = time.time()
    scale = 1.0
    args = {"local": [], "gpus": ["--chunk-size", str(gpus_chunk)] if gpus_chunk else []}
    if smoke:  # the CPU: 200 and 20 variants, 8 chunks of the larger sweep so that the worker process gets some
        backend, scale, warmup_n = "mujoco", 2e-4, 0
        args = {"local": ["--chunk-size", "25"], "gpus": ["--chunk-size", "25"]}
    prefix = "smoke" if smoke else default_label()
    outdir.mkdir(parents=True, exist_ok=True)
    path = outdir / f"{prefix}-gpu-processes.json"
    res = {
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "command": "python benchmarks/ray_gpus.py " + " ".join(sys.argv[1:]),
        "machine": machine(),
        "spec": "benchmarks/slope_100k.yaml (10 s, 2,100 steps with the settle; slip tyre), n set per step",
        "backend": backend,
        "steps": {},
        "pairs": [],
        "skipped": [],
    }
    work = Path(tempfile.mkdtemp(prefix="gpus33-"))
    one = {"CUDA_VISIBLE_DEVICES": "0"}
    two = {"CUDA_VISIBLE_DEVICES": "0,1"}

    def step(name, guess_s, n, executor, env, args=(), structural=False):
        if over_budget(res, name, guess_s, budget - (time.time() - t_start)):
            return None
        n = max(1, int(n * scale))
        spec = spec_of(work, n, structural)
        r = cli(spec, work / name, ["--executor", executor, *args], env, work, backend=backend)
        r = {"variants": n, "executor": executor, **r, **chunk_summary(r)}
        res["steps"][name] = r
        print(name, {k: r.get(k) for k in ("process_s", "first_part_s", "chunk_s", "where", "error")}, flush=True)
        write_result(res, path)
        shutil.rmtree(work / name, ignore_errors=True)  # 1,000,000 rows a sweep: the disk is not unlimited
        return r

    def pair(kind, r, a, b):
        if not (a and b) or "error" in a or "error" in b:
            return
        res["pairs"].append(
            {
                "what": kind,
                "round": r,
                "gpus": b["_name"],
                "local": a["_name"],
                "process_ratio": round(b["process_s"] / a["process_s"], 4),
                "sweep_ratio": round(b["sweep_wall_s"] / a["sweep_wall_s"], 4),
            }
        )
        write_result(res, path)

    if warmup_n:
        step(f"warmup_{warmup_n}_local", 150, warmup_n, "local", one)
    if not smoke:  # the first CUDA use of a GPU on a fresh machine is slow: not inside a pair (both peers warm)
        res["gpu_touch_s"] = {}
        for gpu in ("0", "1"):
            t0 = time.time()
            touch = "import jax, jax.numpy as jnp; jnp.zeros(1).block_until_ready()"
            subprocess.run([sys.executable, "-c", touch], env={**os.environ, "CUDA_VISIBLE_DEVICES": gpu}, check=False)
            res["gpu_touch_s"][gpu] = round(time.time() - t0, 2)
    for k in warm_chunks:
        step(f"warm_chunk_{k}_local", 60, k, "local", one, ["--chunk-size", str(k)])
    for r in range(1, rounds_1m + 1):
        runs = [("local", f"1m_local_1gpu_{r}", one), ("gpus", f"1m_gpus_2gpu_{r}", two)]
        if gpus_env:
            runs.append(("gpus_env", f"1m_gpusenv_2gpu_{r}", {**two, **gpus_env}))
        got = {}
        for executor, name, env in runs if r % 2 else runs[::-1]:
            how = executor.removesuffix("_env")
            x = step(name, 160 if how == "local" else 90, 1_000_000, how, env, args[how])
            got[executor] = x and {**x, "_name": name}
        pair("1m", r, got["local"], got["gpus"])
        if gpus_env:
            pair("1m_env", r, got["local"], got["gpus_env"])
    if gpus_env:
        res["gpus_env"] = gpus_env
    for r in range(1, rounds_100k + 1):
        runs = [("gpus", f"100k_gpus_{r}"), ("local", f"100k_local_{r}")]
        got = {}
        for executor, name in runs if r % 2 else runs[::-1]:
            x = step(name, 40, 100_000, executor, two)
            got[executor] = x and {**x, "_name": name}
        pair("100k", r, got["local"], got["gpus"])
    if structural_n:  # Warp builds the kernels of a model with the vehicle swept once per machine: not in the pair
        step("structural_warm_20000_local", 90, 20_000, "local", one, structural=True)
        got = {}
        for executor, env in (("gpus", two), ("local", one)):
            name = f"structural_{structural_n}_{executor}"
            x = step(name, 20 + structural_n * 1.5e-4, structural_n, executor, env, structural=True)
            got[executor] = x and {**x, "_name": name}
        pair("structural", 1, got["local"], got["gpus"])
    for kind in ("1m", "100k", "1m_env", "structural"):
        ratios = [p["process_ratio"] for p in res["pairs"] if p["what"] == kind]
        if ratios:
            res[f"median_process_ratio_{kind}"] = statistics.median(ratios)
    res["total_s"] = round(time.time() - t_start, 1)
    write_result(res, path)
    print(
        f"\n{'step':22} {'process s':>9} {'sweep s':>8} {'first part s':>12} {'chunks':>6} {'chunk s':>8} "
        f"{'s/100k':>7}  where / device"
    )
    for name, x in res["steps"].items():
        if "error" in x:
            print(f"{name:22} error: {x['error'][:200]}")
            continue
        print(
            f"{name:22} {x['process_s']:>9.1f} {x['sweep_wall_s']:>8.1f} {x['first_part_s']:>12.1f} "
            f"{x['chunks']:>6} {x['chunk_s']:>8.2f} {x['s_per_100k']:>7.2f}  {x['where'] or x['device']}"
        )
    for p in res["pairs"]:
        print(
            f"{p['what']} round {p['round']}: {p['gpus']} / {p['local']}: process {p['process_ratio']:.3f}, "
            f"sweep {p['sweep_ratio']:.3f}"
        )
    for kind in ("1m", "100k", "1m_env", "structural"):
        if f"median_process_ratio_{kind}" in res:
            print(f"{kind}: median process ratio gpus / local {res[f'median_process_ratio_{kind}']:.3f}")
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=262144, help="variants (default 262,144: 131,072 per GPU on two)")
    ap.add_argument("--backend", default="mjx", choices=["mjx", "warp", "mujoco"])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--out", help="JSON file to write, e.g. benchmarks/results/h200x2-ray-gpus.json")
    ap.add_argument("--note", default="")
    ap.add_argument("--two-gpus", metavar="OUTDIR", help="issue 33's measurements (see the docstring)")
    ap.add_argument("--budget", type=float, default=570.0, help="with --two-gpus or --gpu-processes: seconds in all")
    ap.add_argument("--scale", type=float, default=1.0, help="with --two-gpus: times every size (a smoke test)")
    ap.add_argument("--only", help="with --two-gpus: the steps to run, by name, comma-separated (and the warm-up)")
    ap.add_argument(
        "--warmup-n",
        type=int,
        default=100_000,
        help="with --two-gpus or --gpu-processes: variants of the warm-up (0: none)",
    )
    ap.add_argument(
        "--rounds-100k",
        type=int,
        default=1,
        help="with --two-gpus: alternated pairs of 100k_ray / 100k_local (then _2, ...); with --gpu-processes: "
        "of 100k_gpus / 100k_local",
    )
    ap.add_argument(
        "--gpu-processes",
        metavar="OUTDIR",
        help="issue 33: --executor gpus on two GPUs against one GPU in-process, alternated (see the docstring)",
    )
    ap.add_argument(
        "--rounds-1m",
        type=int,
        default=2,
        help="with --gpu-processes: alternated pairs of 1,000,000 variants, one GPU in-process / --executor gpus",
    )
    ap.add_argument(
        "--smoke",
        action="store_true",
        help="with --gpu-processes: the CPU, the mujoco engine, a few hundred variants (to see that it runs)",
    )
    ap.add_argument(
        "--gpus-chunk-size",
        type=int,
        help="with --gpu-processes: --chunk-size of the 1,000,000-variant --executor gpus sweeps (default: "
        "the executor's own, 66,816 on two GPUs)",
    )
    ap.add_argument(
        "--warm-chunks",
        default="",
        help="with --gpu-processes: chunk sizes, comma-separated, each swept once in-process after the warm-up "
        "so that the compile cache holds them (the pairs' shapes: 125184,100096 on two GPUs)",
    )
    ap.add_argument(
        "--gpus-env",
        default="",
        help="with --gpu-processes: KEY=VALUE,... for an extra gpus sweep in each round (say "
        "JAX_CUDA_VISIBLE_DEVICES=0: each process's JAX on its own GPU only)",
    )
    ap.add_argument(
        "--structural-n",
        type=int,
        default=0,
        help="with --gpu-processes: last, this many variants with the vehicle swept too, gpus then in-process",
    )
    args = ap.parse_args()
    if args.gpu_processes:
        backend = args.backend if args.backend != "mjx" else "warp"
        gpu_processes(
            Path(args.gpu_processes),
            args.budget,
            backend,
            args.rounds_1m,
            args.rounds_100k,
            args.warmup_n,
            args.smoke,
            args.gpus_chunk_size,
            tuple(int(k) for k in args.warm_chunks.split(",") if k.strip()),
            dict(kv.split("=", 1) for kv in args.gpus_env.split(",") if kv.strip()),
            args.structural_n,
        )
        return None
    if args.two_gpus:
        backend = args.backend if args.backend != "mjx" else "warp"
        only = args.only.split(",") if args.only else None
        return two_gpus(Path(args.two_gpus), args.budget, backend, args.scale, only, args.warmup_n, args.rounds_100k)
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
        "machine": machine(),
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
        write_result(res, Path(args.out))


if __name__ == "__main__":
    main()
