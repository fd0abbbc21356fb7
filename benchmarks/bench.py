"""How fast and how accurate is each batchveh engine against its peers (raw mujoco.batch, MuJoCo Warp alone)?

    python benchmarks/bench.py                       # CPU: the peers and batchveh, small
    python benchmarks/bench.py --tyres rigid slip --skip-cpu --mjx-sizes --warp-sizes 131072
    python benchmarks/bench.py --skip-cpu --mjx-sizes --courses flat step terrain
    python benchmarks/bench.py soil --size 131072    # the soil model against slip and rigid (its own --help)
    python benchmarks/bench.py overhead --n 2048 --repeat 5 --peers same rigid   # run_sweep against the peer

Measured in one run on one machine.

Every row runs n variants of sweeps/slope.yaml's grid (drawn with a fixed seed) for 1,100 steps of
5 ms and gives variant-steps/s (one variant advanced one step, per second of wall time, after the
compile), simulated seconds per wall second, and its ratio to the raw peer of the same run. The rows:

  raw mujoco.batch rollout   the CPU peer at its best: Batch.rollout in blocks with the controls
                             precomputed outside its clock, recording qpos, qvel and qfrc_actuator
                             as batchveh does; batch size, block and threads from a short scan (or
                             --no-peer-scan and --peer-*), run before and after the GPU rows: the
                             ratio column divides by the mean of both runs
  older peer                 one Batch.step per step on 512 variants (for reference only)
  serial mj_step loop        one thread, one variant at a time (what a plain MuJoCo script does)
  batchveh mujoco            batchveh's MuJoCo C engine (its default threads), --cpu-variants
  batchveh mjx ...           MJX's JAX engine at each --mjx-sizes, --solvers and --precisions
  batchveh warp ...          the warp engine (MuJoCo Warp) at each --warp-sizes and --warp-solvers
  MuJoCo Warp direct         the GPU peer: MuJoCo Warp stepped by hand, one CUDA graph per 50 steps,
                             per-world gravity and friction, no batchveh code, no statistics
  [slip] / [rigid] ...       with --tyres, each row per wheel-ground model (the peer runs the rigid one)
  warp flat / step / terrain with --courses, the obstacles of the sweep spec on --course-backend

Accuracy columns: a fixed sample (--ref-variants) runs on MuJoCo C in float64 with tolerance 1e-12
and 200 iterations; per statistic, |x - ref| / max(|ref|, 1 N m) per variant, median / p99, over
variants that do not slip (noslip_*) and those that do (slip_*). 'sum' is the four-wheel drive sum,
'wheel' the four drive motors pooled, 'peak_lp' the peak after the 50 ms low-pass filter.

Mode `soil` (python benchmarks/bench.py soil --help): the soil model, the slip tyre and the rigid
contact on one random table of rover variants on the warp engine, best of --repeat each, and the
soil model's float32 means against MuJoCo C float64.

Mode `overhead` (python benchmarks/bench.py overhead --help; was cpu_overhead.py): batchveh's MuJoCo C engine
through run_sweep, Parquet written, against the raw mujoco.batch peer, alternated pairs; one JSON line, and
the file with --out.

Results: printed as a table and written to benchmarks/results/LABEL-KIND.json (bench: --tag names
the file; default the GPU's kind or cpu-Ncore); docs/performance.md reads the files it cites
(python benchmarks/render.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(ROOT))


# One way for every benchmark script to name a machine and write its output (machine, default_label, result_path,
# write_result): bench (its modes), end_to_end, warp_engine, structural, motors and ray_gpus import them from here
def gpu_names() -> list[str]:
    """The NVIDIA GPUs' names, as nvidia-smi gives them (none without it)."""
    import shutil
    import subprocess

    if not shutil.which("nvidia-smi"):
        return []
    done = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True, text=True)
    return [x.strip() for x in done.stdout.splitlines() if x.strip()] if done.returncode == 0 else []


def default_label() -> str:
    """The machine's label at the start of a result file's name: the GPU's kind ('h200', 'h200x2') or
    'cpu-Ncore' (N: the CPUs this process may use)."""
    import os

    names = gpu_names()
    if not names:
        return f"cpu-{len(os.sched_getaffinity(0))}core"
    # the model's token ('NVIDIA H100 80GB HBM3' -> h100, where the last word, 'hbm3', named the file before)
    model = re.search(r"\b[A-Z]{1,2}\d{2,4}[A-Za-z]*\b", names[0].removeprefix("NVIDIA "))
    kind = (model.group(0) if model else names[0].split()[-1]).lower()
    return kind if len(names) == 1 else f"{kind}x{len(names)}"


def cpu_model() -> str:
    """The CPU's model name, as /proc/cpuinfo gives it."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict:
    """The machine a result was measured on: architecture, usable CPUs, Python, CPU model, GPUs."""
    import os
    import subprocess

    info = {"machine": platform.machine(), "cpus": len(os.sched_getaffinity(0)), "python": platform.python_version()}
    info["cpu_model"] = cpu_model()
    try:
        info["gpus"] = subprocess.run(
            ["nvidia-smi", "--query-gpu=name,memory.total", "--format=csv,noheader"], capture_output=True, text=True
        ).stdout.split("\n")[:-1]
    except OSError:
        info["gpus"] = []
    return info


def result_path(kind: str, label: str | None = None, out: str | Path | None = None) -> Path:
    """--out if given, else benchmarks/results/LABEL-KIND.json."""
    return Path(out) if out else RESULTS / f"{label or default_label()}-{kind}.json"


def write_result(result: dict, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {path}")


SOLVERS = {  # name -> (solver, iterations, ls_iterations)
    "default": ("newton", 100, 50),
    "newton4": ("newton", 4, 8),
    "newton8": ("newton", 8, 16),
    "cg16": ("cg", 16, 8),
    "newton8ls4": ("newton", 8, 4),
    "newton6ls6": ("newton", 6, 6),
    "newton6ls4": ("newton", 6, 4),
    "newton5ls4": ("newton", 5, 4),
    "newton5ls3": ("newton", 5, 3),
    "newton4ls4": ("newton", 4, 4),
    "newton3ls4": ("newton", 3, 4),
    "newton2ls4": ("newton", 2, 4),
    "newton4ls2": ("newton", 4, 2),
}


WHEEL_COLLISION = "cylinder"  # --wheel-collision
CONTACT = None  # --contact CONE/IMPRATIO[/IMPEDANCE], e.g. pyramidal/1 (default: the vehicle's own)
TYRE = None  # the wheel-ground model of the rows being measured (--tyres): 'slip' or 'rigid'


def slope_table(n: int, seed: int = 0):
    """n variants drawn (fixed seed) from sweeps/slope.yaml's grid, on the chosen wheel collision shape."""
    import dataclasses

    from batchveh.sweeping.spec import load_spec, variant_table

    spec = load_spec(Path(__file__).resolve().parent.parent / "sweeps" / "slope.yaml")
    wheel = dataclasses.replace(spec.vehicle.wheel, collision=WHEEL_COLLISION)
    vehicle = dataclasses.replace(spec.vehicle, wheel=wheel)
    if TYRE:
        vehicle = dataclasses.replace(vehicle, tyre=dataclasses.replace(vehicle.tyre, model=TYRE))
    if CONTACT:
        cone, impratio, *impedance = CONTACT.split("/")
        cm = dataclasses.replace(vehicle.contact_model, cone=cone, impratio=float(impratio))
        if impedance:
            cm = dataclasses.replace(cm, impedance=float(impedance[0]))
        vehicle = dataclasses.replace(vehicle, contact_model=cm)
    spec = dataclasses.replace(spec, vehicle=vehicle)
    grid = variant_table(spec)
    idx = np.random.default_rng(seed).choice(len(grid), size=n, replace=n > len(grid))
    return spec, grid.iloc[idx].drop(columns="variant").reset_index(drop=True)


def _cols(table, spec):
    cols = {k: table[k].to_numpy() for k in table.columns}
    cols.update({k: np.full(len(table), v) for k, v in spec.fixed.items() if k not in ("time_step", "total_time")})
    return cols


def set_solver(m, name: str, tolerance: float | None = None):
    """The named SOLVERS setting (and a tolerance, for the reference) through batchveh's own setter."""
    from batchveh.stepping.batch import apply_solver

    solver, it, ls = SOLVERS[name]
    apply_solver(
        m,
        {
            "type": solver,
            "iterations": it,
            "ls_iterations": ls,
            **({} if tolerance is None else {"tolerance": tolerance}),
        },
    )


def mjx_model(spec, table, solver: str):
    """The batched MJX model of the table's variants with the named SOLVERS setting, and its in_axes."""
    from batchveh.stepping.batch import make_batch
    from batchveh.stepping.batch import mjx_model as put

    batch = make_batch(spec.vehicle, spec.scenario, _cols(table, spec))
    set_solver(batch.model, solver)
    return put(batch)


def settled(m, axes, steps: int = 100):
    """Every variant after `steps` MJX steps with the drive servos holding speed (a steady state)."""
    import jax
    import jax.numpy as jnp
    from mujoco import mjx

    def settle(mm):
        d = mjx.make_data(mm)
        ctrl = jnp.zeros(mm.nu).at[:4].set(1.0).at[8:12].set(1.0)
        return jax.lax.scan(lambda d, _: (mjx.step(mm, d.replace(ctrl=ctrl)), None), d, None, length=steps)[0]

    return jax.block_until_ready(jax.jit(jax.vmap(settle, in_axes=(axes,)))(m))


def best_time(fn, *args, repeat: int = 10) -> float:
    """Fastest of `repeat` timed calls of fn(*args) after one warm-up, s."""
    import jax

    jax.block_until_ready(fn(*args))
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        jax.block_until_ready(fn(*args))
        best = min(best, time.perf_counter() - t0)
    return best


def bench_serial(spec, table, n_steps):
    import mujoco

    from batchveh.stepping.batch import make_batch

    batch = make_batch(spec.vehicle, spec.scenario, _cols(table, spec))
    m = batch.model
    d = mujoco.MjData(m)
    t0 = time.perf_counter()
    for i in range(batch.n):
        for name, values in batch.fields.items():
            target = m.opt.gravity if name == "opt.gravity" else getattr(m, name)
            target[:] = values[i]
        mujoco.mj_resetData(m, d)
        for _ in range(n_steps):
            d.ctrl[:4] = d.ctrl[8:12] = 1.0
            mujoco.mj_step(m, d)
    return batch.n * n_steps / (time.perf_counter() - t0)


def raw_controls(spec, batch, n_steps: int) -> np.ndarray:
    """(n, n_steps, nu) float64: every variant's controls at every step, as batchveh's engines compute them
    (the scenario's schedule), so the peer steps the same simulations."""
    import jax
    import jax.numpy as jnp

    from batchveh.model.scenarios import control_schedule

    f = jax.jit(jax.vmap(control_schedule(spec.scenario), in_axes=(0, None)))
    params = {k: jnp.asarray(v) for k, v in batch.params.items()}
    return np.asarray(f(params, jnp.asarray(np.arange(n_steps) * batch.model.opt.timestep)), np.float64)


RECORD = ("qpos", "qvel", "qfrc_actuator")  # what batchveh's mujoco engine records for its statistics
PEER_DEFAULT = {"variants": 4096, "block": 100, "threads": 0}  # without a scan (0 threads: all CPUs)


def bench_raw_rollout(spec, table, n_steps, block: int = 100, nthread: int = 0, size: int | None = None):
    """Raw mujoco.batch at its best: Batch.rollout in blocks of `block` steps with the controls precomputed
    (outside the clock), recording qpos, qvel and qfrc_actuator as batchveh does, in batches of `size`
    variants (default: all of the table in one). Returns (variant-steps/s, MuJoCo threads); the clock
    covers the rollout calls only."""
    from mujoco.batch import Batch

    from batchveh.engines.mujoco import cpus
    from batchveh.stepping.batch import make_batch

    size, nthread = size or len(table), nthread or cpus()
    wall = 0.0
    for start in range(0, len(table), size):
        batch = make_batch(spec.vehicle, spec.scenario, _cols(table.iloc[start : start + size], spec))
        ctrl = raw_controls(spec, batch, n_steps)
        blocks = [np.ascontiguousarray(ctrl[:, s : s + block]) for s in range(0, n_steps, block)]
        del ctrl
        b = Batch(batch.model, nsim=batch.n, nthread=nthread)
        for name, values in batch.fields.items():
            b.expand(name)[:] = values
        b.reset()
        m = batch.model
        dims = {"qpos": m.nq, "qvel": m.nv, "qfrc_actuator": m.nv}
        outs = {k: {r: np.empty((batch.n, k, d)) for r, d in dims.items()} for k in {c.shape[1] for c in blocks}}
        t0 = time.perf_counter()
        for c in blocks:
            b.rollout(c.shape[1], control=c, record=RECORD, out=outs[c.shape[1]])
        wall += time.perf_counter() - t0
    return len(table) * n_steps / wall, nthread


def bench_raw_step(spec, table, n_steps):
    """The older peer: one Batch.step() per step on all threads, the controls written each step (a
    drive ramp, not the scenario's schedule), nothing recorded. Returns (variant-steps/s, threads)."""
    from mujoco.batch import Batch

    from batchveh.stepping.batch import make_batch

    batch = make_batch(spec.vehicle, spec.scenario, _cols(table, spec))
    b = Batch(batch.model, nsim=batch.n)
    for name, values in batch.fields.items():
        b.expand(name)[:] = values
    b.reset()
    ctrl = np.zeros((batch.n, batch.model.nu))
    t0 = time.perf_counter()
    for i in range(n_steps):
        ctrl[:, :4] = ctrl[:, 8:12] = min(1.0, i / 100)
        b.ctrl = ctrl
        b.step()
    return batch.n * n_steps / (time.perf_counter() - t0), b.nthread


def scan_peer(spec, n_steps, sizes, blocks, threads, log=print):
    """A short scan of the raw peer's settings, one factor at a time: batch size (block 100, all
    threads), then block length at the best size, then thread count at the best of both. Each point
    runs the full n_steps on `size` variants of the slope table. Returns (best settings, scan rows)."""
    rows = []

    def point(size, block, th):
        _, table = slope_table(size, seed=2)
        rate, used = bench_raw_rollout(spec, table, n_steps, block, th)
        rows.append({"variants": size, "block": block, "threads": used, "rate": rate})
        log(f"peer scan: {size} variants, block {block}, {used} threads: {rate:.3g} variant-steps/s")
        return rate

    best = max(sizes, key=lambda n: point(n, 100, 0))
    best_block = max(blocks, key=lambda k: point(best, k, 0) if k != 100 else _rate(rows, best, 100))
    from batchveh.engines.mujoco import cpus

    all_cpus = cpus()
    best_th = max(
        threads, key=lambda t: point(best, best_block, t) if t not in (0, all_cpus) else _rate(rows, best, best_block)
    )
    return {"variants": best, "block": best_block, "threads": best_th or all_cpus}, rows


def _rate(rows, size, block):
    return max(r["rate"] for r in rows if r["variants"] == size and r["block"] == block)


def run_backend(kind, spec, table, chunk, solver="default", x64=False, matmul="highest", nthread=0):
    """(columns, wall s, compile s, peak device bytes) of batchveh's backend on the table."""
    import jax

    from batchveh.engines import make_engine
    from batchveh.stepping import stats
    from batchveh.stepping.batch import make_batch

    sc = spec.scenario
    cfg = stats.StatsConfig.make(sc.time_step, sc.n_steps, spec.window)
    be = make_engine(
        kind,
        sc,
        cfg,
        chunk,
        len(table),
        precision="f64" if x64 and kind == "mjx" else "f32",
        matmul_precision=matmul,
        nthread=nthread,
    )
    out, t_run = [], 0.0
    for start in range(0, len(table), be.chunk_size):
        batch = make_batch(spec.vehicle, sc, _cols(table.iloc[start : start + be.chunk_size], spec))
        set_solver(batch.model, solver, 1e-12 if kind == "mujoco" and x64 else None)
        t0 = time.perf_counter()
        out.append(be.run(batch))
        t_run += time.perf_counter() - t0
    cols = {k: np.concatenate([o[k] for o in out]) for k in out[0]}
    peak = 0
    if kind in ("mjx", "warp"):
        stats_ = jax.devices()[0].memory_stats() or {}
        peak = stats_.get("peak_bytes_in_use", 0)
    return cols, t_run - be.compile_s, be.compile_s, peak


# --courses: the slope variants on a step (heights from a few values: each distinct height is one MuJoCo
# compile) and on one terrain (MuJoCo Warp keeps one height field per model), beside flat ground
COURSE_STEP_HEIGHTS = (0.02, 0.04, 0.06, 0.08, 0.10, 0.12, 0.14, 0.16)  # m; the wheel radius is 0.195
COURSE_WARMUP = 64  # variants run before each timed course row
COURSES = {"flat": {}, "step": {"obstacle": "step"}, "terrain": {"obstacle": "terrain", "terrain_amplitude": 0.04}}


def course_rows(rows, courses, kind, sizes, n_steps):
    """A row per course and batch size: batchveh's `kind` engine on `size` slope variants on flat ground,
    on a step (step_height drawn from COURSE_STEP_HEIGHTS) or on a terrain; the same variants on each."""
    import dataclasses

    for size in sizes:
        base, table = slope_table(size, seed=3)
        for name in courses:
            spec = dataclasses.replace(base, scenario=dataclasses.replace(base.scenario, **COURSES[name]))
            tab = table.copy()
            if name == "step":
                tab["step_height"] = np.random.default_rng(4).choice(COURSE_STEP_HEIGHTS, size)
            try:
                # warm-up on a few variants: the engine's kernels for this ground (MuJoCo Warp builds its
                # CUDA modules at their first launch, outside the compile time; 3x off the flat rate cold)
                run_backend(kind, spec, tab.iloc[:COURSE_WARMUP], COURSE_WARMUP)
                cols, wall, comp, peak = run_backend(kind, spec, tab, size)
            except Exception as err:  # out of memory, or a pair the engine cannot collide: record and go on
                rows.append({"name": f"{kind} {name} n={size}", "error": str(err)[:200]})
                print(rows[-1], flush=True)
                continue
            rows.append(
                {
                    "name": f"{kind} {name} n={size}",
                    "course": name,
                    "rate": size * n_steps / wall,
                    "compile_s": comp,
                    "peak_mem_gb": peak / 1e9,
                    "ok_share": float(np.mean(cols["status_code"] == 0)),
                }
            )
            print(rows[-1], flush=True)


def sized_rows(rows, label, sizes, n_steps, acc, backend, **extra):
    """Append a row per batch size: the rate of `run_backend(kind, spec, table, size, *options)` for
    `backend` = (kind, spec, *options) on `size` slope variants, its compile time and peak memory, the
    accuracy `acc` measured on the reference sample, and `extra`; an error row where a size fails."""
    kind, spec, *options = backend
    for size in sizes:
        _, table = slope_table(size, seed=3)
        try:
            _, wall, comp, peak = run_backend(kind, spec, table, size, *options)
        except Exception as err:  # out of memory: record and go on
            rows.append({"name": f"{label} n={size}", "error": str(err)[:200]})
            continue
        row = {
            "name": f"{label} n={size}",
            "rate": size * n_steps / wall,
            "compile_s": comp,
            "peak_mem_gb": peak / 1e9,
            "accuracy": acc,
            **extra,
        }
        rows.append(row)
        print(row, flush=True)


def warp_rows(rows, spec, ref_table, ref, solver, sizes, direct_sizes, n_steps):
    """Rows of batchveh's warp engine and of MuJoCo Warp driven directly, at each size; the
    warp engine's accuracy on the reference sample."""

    from batchveh.model.scenarios import gravity_vector
    from batchveh.stepping.batch import make_batch

    cols_acc, *_ = run_backend("warp", spec, ref_table, len(ref_table), solver)
    acc = accuracy(cols_acc, ref)
    limit = cols_acc.get("solver_limit_share")
    limit_max = None if limit is None else float(np.max(limit))
    sized_rows(
        rows,
        f"batchveh warp {solver} f32",
        sizes,
        n_steps,
        acc,
        ("warp", spec, solver),
        ref_solver_limit_share_max=limit_max,
    )
    for size in direct_sizes:
        _, table = slope_table(size, seed=3)
        cols = _cols(table, spec)
        batch = make_batch(spec.vehicle, spec.scenario, {})
        set_solver(batch.model, solver)
        gravity = np.asarray(gravity_vector(np.full(size, spec.scenario.gravity), cols["slope_deg"], xp=np))
        omega = cols["speed_kmh"] / 3.6 / spec.vehicle.wheel.radius
        name = f"MuJoCo Warp direct (CUDA graph of 50 steps, no statistics) {solver} n={size}"
        try:
            rate, extra = bench_mjwarp_direct(batch.model, gravity, cols["friction"], omega, n_steps)
        except Exception as err:
            rows.append({"name": name, "error": str(err)[:200]})
            continue
        rows.append({"name": name, "rate": rate, **extra})
        print(rows[-1], flush=True)


FLOOR_NM = 1.0  # below 1 N m, errors are compared in absolute terms


def accuracy(cols, ref):
    """Median / p99 / max relative error against the reference, non-slipping and slipping apart.

    Errors are |x - ref| / max(|ref|, 1 N m). 'sum' is the four-wheel drive sum, which
    physics fixes; 'wheel' pools the four drive motors, whose split among wheels locked
    to one speed is ill-conditioned (docs/physics.md, "Four locked wheels").
    """
    out = {}
    slip = np.asarray(ref["slipping"], bool)
    for label, sel in (("noslip", ~slip), ("slip", slip)):
        if not sel.any():
            continue
        for stat in ("mean", "peak", "peak_lp"):
            for group, motors in (("sum", ("drive_sum",)), ("wheel", ("drive_lf", "drive_rf", "drive_lr", "drive_rr"))):
                e = np.concatenate(
                    [
                        np.abs(np.asarray(cols[f"{m}_{stat}"])[sel] - np.asarray(ref[f"{m}_{stat}"])[sel])
                        / np.maximum(np.abs(np.asarray(ref[f"{m}_{stat}"])[sel]), FLOOR_NM)
                        for m in motors
                    ]
                )
                out[f"{label}_{group}_{stat}"] = {
                    "median": float(np.median(e)),
                    "p99": float(np.percentile(e, 99)),
                    "max": float(e.max()),
                    "n": int(sel.sum()),
                }
    return out


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "soil":
        return soil_main(sys.argv[2:])
    if len(sys.argv) > 1 and sys.argv[1] == "overhead":
        return overhead_main(sys.argv[2:])
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tag", default=None, help="result file name, without .json (default: the machine's label)")
    ap.add_argument("--cpu-variants", type=int, default=1024, help="variants for batchveh mujoco and the serial loop")
    ap.add_argument("--no-peer-scan", dest="peer_scan", action="store_false", help="skip the peer's scan")
    ap.add_argument("--scan-sizes", type=int, nargs="+", default=[1024, 2048, 4096, 8192], help="peer batch sizes")
    ap.add_argument("--scan-blocks", type=int, nargs="+", default=[50, 100, 250], help="peer rollout block lengths")
    ap.add_argument("--peer-variants", type=int, default=PEER_DEFAULT["variants"], help="peer batch, without scan")
    ap.add_argument("--peer-block", type=int, default=PEER_DEFAULT["block"], help="peer block, without scan")
    ap.add_argument("--peer-threads", type=int, default=PEER_DEFAULT["threads"], help="0: every usable CPU; no scan")
    ap.add_argument("--serial-variants", type=int, default=8)
    ap.add_argument("--ref-variants", type=int, default=256, help="sample for the accuracy reference")
    ap.add_argument("--mjx-sizes", type=int, nargs="*", default=[256])
    ap.add_argument("--warp-sizes", type=int, nargs="*", default=[], help="batchveh warp engine batch sizes")
    ap.add_argument("--direct-sizes", type=int, nargs="*", default=[], help="MuJoCo Warp driven directly: sizes")
    ap.add_argument("--warp-solvers", nargs="*", default=["default"], choices=list(SOLVERS))
    ap.add_argument("--solvers", nargs="*", default=["default"], choices=list(SOLVERS))
    ap.add_argument("--precisions", nargs="*", default=["f32"], choices=["f32", "f64"], help="mjx float precisions")
    ap.add_argument("--skip-cpu", action="store_true")
    ap.add_argument(
        "--matmul",
        nargs="*",
        default=["highest"],
        choices=["default", "high", "highest"],
        help="JAX matmul precisions to compare for mjx (GPU float32 'default' may use TF32)",
    )
    ap.add_argument(
        "--tyres",
        nargs="+",
        default=["slip"],
        choices=["slip", "rigid"],
        help="wheel-ground models of the GPU rows, each with its own C f64 reference; the CPU peer runs rigid",
    )
    ap.add_argument("--wheel-collision", default="cylinder", choices=["cylinder", "sphere"])
    ap.add_argument("--courses", nargs="*", default=[], choices=list(COURSES), help="ground: flat, step, terrain")
    ap.add_argument("--course-backend", default="warp", choices=["mujoco", "mjx", "warp"], help="engine of --courses")
    ap.add_argument("--course-sizes", type=int, nargs="*", default=[131072], help="variants per --courses row")
    ap.add_argument(
        "--contact",
        default=None,
        help="CONE/IMPRATIO[/IMPEDANCE], e.g. pyramidal/1 or elliptic/10/0.9 (default: the vehicle's)",
    )
    args = ap.parse_args()
    global WHEEL_COLLISION, CONTACT, TYRE
    WHEEL_COLLISION = args.wheel_collision
    CONTACT = args.contact
    TYRE = args.tyres[0]
    import jax
    import mujoco

    from batchveh.engines.mujoco import cpus

    spec, _ = slope_table(1)
    n_steps = spec.scenario.n_steps
    sim_s = spec.scenario.total_time
    dev = jax.devices()[0]
    tag = args.tag or default_label()
    rows = []
    info = {
        "date": time.strftime("%Y-%m-%d"),
        "device": f"{len(jax.devices())} x {dev.device_kind}",
        "cpu_threads": cpus(),
        "mujoco": mujoco.__version__,
        "jax": jax.__version__,
        "python": platform.python_version(),
        "command": " ".join(sys.argv),
        "steps": n_steps,
        "time_step": spec.scenario.time_step,
        "wheel_collision": args.wheel_collision,
        # the contact the rows ran, read from the vehicle they were built on (not from a default)
        "contact": "{0.cone}/{0.impratio:g}/{0.impedance:g} ({1})".format(
            spec.vehicle.contact_model, f"--contact {args.contact}" if args.contact else "the vehicle's default"
        ),
        "tyres": args.tyres,
        "peer_tyre": args.tyres[0],
    }

    def reference():
        """The converged reference on a fixed sample, MuJoCo C float64, for the current TYRE."""
        spec, ref_table = slope_table(args.ref_variants, seed=1)
        t0 = time.perf_counter()
        ref, *_ = run_backend("mujoco", spec, ref_table, args.ref_variants, "default", x64=True)
        print(f"reference ({TYRE}): {args.ref_variants} variants in {time.perf_counter() - t0:.1f} s", flush=True)
        return spec, ref_table, ref

    spec, ref_table, ref = reference()

    raw_rate = info["peer"] = None
    if not args.skip_cpu:
        ncpu = cpus()
        if args.peer_scan:
            threads = [ncpu, ncpu - 1] if ncpu >= 8 else [ncpu]
            peer, scan = scan_peer(spec, n_steps, args.scan_sizes, args.scan_blocks, threads)
        else:
            peer, scan = {"variants": args.peer_variants, "block": args.peer_block, "threads": args.peer_threads}, []
        info["peer"] = {
            **peer,
            "api": "Batch.rollout in blocks, controls precomputed, recording qpos, qvel, qfrc_actuator",
            "scan": scan,
        }
        _, peer_table = slope_table(peer["variants"], seed=2)
        raw_rate, nthread = bench_raw_rollout(spec, peer_table, n_steps, peer["block"], peer["threads"])
        peer_name = f"raw mujoco.batch rollout ({peer['variants']} variants, block {peer['block']}, {nthread} threads)"
        rows.append({"name": peer_name, "rate": raw_rate, "peer_runs": [raw_rate]})
        _, old_table = slope_table(512, seed=2)
        old, old_threads = bench_raw_step(spec, old_table, n_steps)
        rows.append({"name": f"older peer: Batch.step per step, 512 variants ({old_threads} threads)", "rate": old})
        _, cpu_table = slope_table(args.cpu_variants, seed=2)
        ser = bench_serial(spec, cpu_table.iloc[: args.serial_variants], n_steps)
        rows.append({"name": "serial mj_step loop (1 thread)", "rate": ser})
        cols, wall, _, _ = run_backend("mujoco", spec, cpu_table, None)
        from batchveh.engines.mujoco import default_threads

        label = f"batchveh mujoco ({default_threads()} threads, {args.cpu_variants} variants)"
        rows.append({"name": label, "rate": len(cpu_table) * n_steps / wall})
        cols_ref, *_ = run_backend("mujoco", spec, ref_table, args.ref_variants)
        rows[-1]["accuracy"] = accuracy(cols_ref, ref)
        print(rows[-4:], flush=True)

    configs = [(p == "f64", s, mm) for p in args.precisions for s in args.solvers for mm in args.matmul]
    for k, tyre in enumerate(args.tyres):
        TYRE = tyre
        if k:  # the first tyre's reference is above
            spec, ref_table, ref = reference()
        start = len(rows)
        for x64, solver, mm in configs:
            cols_acc, *_ = run_backend("mjx", spec, ref_table, args.ref_variants, solver, x64, mm)
            acc = accuracy(cols_acc, ref)
            label = f"batchveh mjx {solver} {'f64' if x64 else 'f32'}{'' if mm == 'highest' else ' mm=' + mm}"
            sized_rows(rows, label, args.mjx_sizes, n_steps, acc, ("mjx", spec, solver, x64, mm))
        for solver in args.warp_solvers if args.warp_sizes or args.direct_sizes else []:
            warp_rows(rows, spec, ref_table, ref, solver, args.warp_sizes, args.direct_sizes, n_steps)
        for r in rows[start:]:
            r["name"] = f"[{tyre}] {r['name']}"
            r["tyre"] = tyre
    if args.courses:
        course_rows(rows, args.courses, args.course_backend, args.course_sizes, n_steps)
    # the peer again after the GPU rows: the mean of both
    if raw_rate and (len(configs) and args.mjx_sizes or args.warp_sizes):
        again, _ = bench_raw_rollout(spec, peer_table, n_steps, peer["block"], peer["threads"])
        rows[0]["peer_runs"].append(again)
        raw_rate = rows[0]["rate"] = sum(rows[0]["peer_runs"]) / 2
        print(f"peer again: {again:.3g}; mean {raw_rate:.3g}", flush=True)
    for r in rows:
        if "rate" in r:
            r["sim_s_per_s"] = r["rate"] / n_steps * sim_s
            r["vs_raw_batch"] = r["rate"] / raw_rate if raw_rate else None
    print(
        f"\n{'row':50s} {'var-steps/s':>11s} {'x raw':>6s} {'comp s':>6s} {'mem GB':>6s} | non-slipping, "
        "median/p99 rel. error: sum mean, wheel mean, wheel peak, wheel peak_lp"
    )
    for r in rows:
        if "rate" not in r:
            print(f"{r['name']:50s} failed: {r['error']}")
            continue
        a = r.get("accuracy", {})
        ratio = f"{r['vs_raw_batch']:.2f}" if r.get("vs_raw_batch") else "-"
        errs = " ".join(
            f"{a[k]['median']:.1e}/{a[k]['p99']:.1e}" if k in a else "-"
            for k in ("noslip_sum_mean", "noslip_wheel_mean", "noslip_wheel_peak", "noslip_wheel_peak_lp")
        )
        print(
            f"{r['name']:50s} {r['rate']:11.3g} {ratio:>6s} {r.get('compile_s', 0):6.1f} "
            f"{r.get('peak_mem_gb', 0):6.2f} | {errs}"
        )
    write_result({"info": info, "rows": rows}, Path(tag) if tag.endswith(".json") else RESULTS / f"{tag}.json")


# MuJoCo Warp driven directly: the GPU peer (was benchmarks/mjwarp_direct.py)
def native_case(size: int, steps: int):
    """warp_engine.py's case (every mode): the slope grid's `size` variants (seed 3) with the slip tyre, and
    what MuJoCo Warp alone needs of them. Returns (spec, StatsConfig of `steps` steps, columns, base batch,
    gravity (size, 3), omega (size,) rad/s)."""
    global TYRE
    from batchveh.model.scenarios import gravity_vector
    from batchveh.stepping import stats
    from batchveh.stepping.batch import make_batch

    TYRE = "slip"
    spec, table = slope_table(size, seed=3)
    sc = spec.scenario
    cfg = stats.StatsConfig.make(sc.time_step, steps, spec.window)
    cols = _cols(table, spec)
    base = make_batch(spec.vehicle, sc, {})
    gravity = np.asarray(gravity_vector(np.full(size, sc.gravity), cols["slope_deg"], xp=np))
    omega = cols["speed_kmh"] / 3.6 / spec.vehicle.wheel.radius
    return spec, cfg, cols, base, gravity, omega


def bench_mjwarp_direct(
    model, gravity, friction, omega, n_steps: int, graph_steps: int = 50, contacts: int = 24, deterministic: int = 0,
    final: dict | None = None,
):  # fmt: skip
    """variant-steps/s of MuJoCo Warp stepping len(omega) worlds for n_steps.

    model: the MjModel; gravity (n, 3), friction (n,) of the ground geom, omega (n,) rad/s. deterministic:
    MuJoCo Warp's DeterminismType bits. final: if given, filled with the last qpos, qvel and qfrc_actuator."""
    import mujoco_warp as mjw
    import warp as wp

    from batchveh.engines.warp import constraint_rows
    from batchveh.model.vehicle import layout

    n = len(omega)
    lay = layout(model)
    cuda = wp.get_cuda_device_count() > 0
    device = "cuda:0" if cuda else "cpu"
    with wp.ScopedDevice(device):
        mw = mjw.put_model(model)
        mw.opt.warn_overflow = 0
        mw.opt.deterministic = deterministic
        mw.opt.gravity = wp.array(np.asarray(gravity, np.float32), dtype=wp.vec3)
        fr = np.broadcast_to(model.geom_friction, (n, *model.geom_friction.shape)).astype(np.float32)
        fr[:, lay.ground_geom, 0] = friction
        mw.geom_friction = wp.array(fr, dtype=wp.vec3)
        d = mjw.make_data(model, nworld=n, naconmax=n * contacts, njmax=constraint_rows(model, contacts))
        w = wp.array(np.asarray(omega, np.float32))
        vel_ids = wp.array(np.asarray(lay.drive_vel_act, np.int32))
        pos_ids = wp.array(np.asarray(lay.drive_pos_act, np.int32))

        @wp.kernel
        def set_ctrl(
            t: wp.array(dtype=float),
            om: wp.array(dtype=float),
            vel: wp.array(dtype=int),
            pos: wp.array(dtype=int),
            ctrl: wp.array2d(dtype=float),
        ):
            world, k = wp.tid()
            ctrl[world, vel[k]] = om[world]
            ctrl[world, pos[k]] = om[world] * t[world]

        def steps(count):
            for _ in range(count):
                wp.launch(set_ctrl, dim=(n, 4), inputs=[d.time, w, vel_ids, pos_ids, d.ctrl])
                mjw.step(mw, d)

        steps(1)  # compile and load the kernels
        wp.synchronize()
        if cuda:
            with wp.ScopedCapture() as capture:
                steps(graph_steps)
            graph = capture.graph
            run = lambda: wp.capture_launch(graph)  # noqa: E731
        else:
            run = lambda: steps(graph_steps)  # noqa: E731
        run()
        wp.synchronize()
        calls = max(1, n_steps // graph_steps)
        t0 = time.perf_counter()
        for _ in range(calls):
            run()
        wp.synchronize()
        wall = time.perf_counter() - t0
        qvel = d.qvel.numpy()
        if final is not None:
            final.update(qpos=d.qpos.numpy(), qvel=qvel, qfrc_actuator=d.qfrc_actuator.numpy())
    finite = float(np.isfinite(qvel).all(axis=1).mean())
    return n * calls * graph_steps / wall, {"graph_steps": graph_steps, "device": device, "finite_share": finite}


# mode `soil` (was benchmarks/soil.py)
SOIL_DOC = """The soil wheel-ground model on the warp engine: its speed against the rigid ground's models,
and its float32 accuracy against MuJoCo C float64 (issue 22).

    python benchmarks/bench.py soil --size 131072 --out benchmarks/results/h200-soil.json   # one GPU
    python benchmarks/bench.py soil --size 256 --ref 32 --steps 200                           # a CPU, to see it run

One random table of variants on the Moon, Mars and the Earth (slope 0-20 deg, speed 0.5-4 km/h,
and the lunar soil preset's k_phi, phi, K, c and n each swept over a band around it) runs on the
warp engine with each wheel-ground model: `soil`, then the `slip` tyre and the `rigid` contact on
the same table (their soil columns unused), in turns, `--repeat` times, each after a warm-up run
of the same program. Rates are variant-steps/s; ratios are against `rigid` and `slip` measured in
the same process. Accuracy: the first `--ref` variants on MuJoCo C in float64 against the warp
engine's float32, per-wheel drive means (steady window), relative to the largest wheel of the
variant, median / p99 / largest, for the variants C calls ok, steady and not slipping (the ones a
sizing reads) and for the rest (a vehicle still accelerating in low gravity at the end of its run
amplifies float32's rounding).
"""
SOIL_MODELS = ("soil", "slip", "rigid")


def soil_table(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    from batchveh.model import soil

    rng = np.random.default_rng(seed)
    lunar = soil.PRESETS["lunar_soil"]
    return {
        "slope_deg": rng.uniform(0.0, 20.0, n),
        "speed_kmh": rng.uniform(0.5, 4.0, n),
        "gravity": rng.choice([1.62, 3.71, 9.81], n),
        "soil.k_phi": lunar["k_phi"] * rng.uniform(0.5, 2.0, n),
        "soil.phi": rng.uniform(25.0, 45.0, n),
        "soil.K": rng.uniform(0.01, 0.03, n),
        "soil.c": rng.uniform(0.0, 1.5, n),
        "soil.n": rng.uniform(0.8, 1.2, n),
    }


def soil_vehicle(model: str):
    import dataclasses

    from batchveh.model import soil
    from batchveh.model.tyres import Tyre
    from batchveh.model.vehicle import Vehicle

    v = Vehicle(tyre=Tyre(model=model))
    return dataclasses.replace(v, soil=dataclasses.replace(v.soil, preset="lunar_soil", **soil.PRESETS["lunar_soil"]))


def soil_scenario(steps: int):
    from batchveh.model.scenarios import make_scenario

    dt = 0.005
    return make_scenario("straight_line", total_time=(steps - 100) * dt, ramp_time=1.0, settle_time=100 * dt)


def soil_run(model: str, tab: dict, steps: int, backend: str, precision: str):
    from batchveh.engines import make_engine
    from batchveh.stepping import stats
    from batchveh.stepping.batch import make_batch

    v, sc = soil_vehicle(model), soil_scenario(steps)
    batch = make_batch(v, sc, tab)
    cfg = stats.StatsConfig.for_scenario(sc, slip_limit=stats.slip_limit(v))
    eng = make_engine(backend, sc, cfg, batch.n, precision=precision)
    t0 = time.perf_counter()
    cols = eng.run(batch)
    return cols, time.perf_counter() - t0, batch.n * sc.n_steps


def soil_main(argv=None) -> None:
    ap = argparse.ArgumentParser(
        prog="bench.py soil", description=SOIL_DOC, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--size", type=int, default=131072)
    ap.add_argument("--steps", type=int, default=1100, help="steps per variant, the 0.5 s settle included")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--ref", type=int, default=256, help="variants of the C float64 reference")
    ap.add_argument("--backend", default="warp", choices=["warp", "mjx"])
    ap.add_argument("--label", help="machine label for the file name (default: the GPU's kind or cpu-Ncore)")
    ap.add_argument("--out", help="JSON path (default benchmarks/results/LABEL-soil.json)")
    args = ap.parse_args(argv)
    import jax

    from batchveh.model.vehicle import CORNERS

    tab = soil_table(args.size)
    rows = {m: [] for m in SOIL_MODELS}
    for m in SOIL_MODELS:  # warm: each program compiled (and Warp's kernels built) before any timing
        soil_run(m, tab, args.steps, args.backend, "f32")
    for _ in range(args.repeat):
        for m in SOIL_MODELS:
            cols, wall, vsteps = soil_run(m, tab, args.steps, args.backend, "f32")
            rows[m].append({"wall_s": wall, "rate": vsteps / wall})
            if m == "soil":
                got = cols
    summary = {m: max(r["rate"] for r in rows[m]) for m in SOIL_MODELS}
    print(f"{'model':<6} {'best rate':>12} {'walls s':>20}")
    for m in SOIL_MODELS:
        walls = " ".join(f"{r['wall_s']:.2f}" for r in rows[m])
        print(f"{m:<6} {summary[m]:12.3e} {walls:>20}")
    print(f"soil / rigid {summary['soil'] / summary['rigid']:.3f}, soil / slip {summary['soil'] / summary['slip']:.3f}")

    ref_tab = {k: v[: args.ref] for k, v in tab.items()}
    ref, _, _ = soil_run("soil", ref_tab, args.steps, "mujoco", "f64")
    c = np.stack([ref[f"drive_{k}_mean"] for k in CORNERS], 1)
    w = np.stack([np.asarray(got[f"drive_{k}_mean"])[: args.ref] for k in CORNERS], 1)
    err = (np.abs(w - c) / np.abs(c).max(1, keepdims=True)).max(1)
    good = (np.asarray(ref["status_code"]) == 0) & ~np.asarray(ref["slipping"]) & np.asarray(ref["steady"])
    accuracy = {}
    for name, sel in (("ok, steady, not slipping", good), ("slipping, unsteady or not ok", ~good)):
        e = err[sel]
        accuracy[name] = {
            "variants": int(sel.sum()),
            **(
                {"median": float(np.median(e)), "p99": float(np.quantile(e, 0.99)), "max": float(e.max())}
                if e.size
                else {}
            ),
        }
        print(f"{args.backend} f32 against C f64, {name}: {accuracy[name]}")
    result = {
        "what": "the soil wheel-ground model on the warp engine against rigid and slip; float32 accuracy against C",
        "device": str(jax.devices()[0]),
        "host": platform.node(),
        "size": args.size,
        "steps": args.steps,
        "backend": args.backend,
        "rows": rows,
        "best_rate": summary,
        "soil_over_rigid": summary["soil"] / summary["rigid"],
        "soil_over_slip": summary["soil"] / summary["slip"],
        "accuracy": accuracy,
        "slipping_share": float(np.mean(np.asarray(got["slipping"]))),
    }
    write_result(result, result_path("soil", args.label, args.out))


OVERHEAD_DOC = """\
batchveh's MuJoCo C engine through run_sweep against raw mujoco.batch at its best, alternated.

    python benchmarks/bench.py overhead --n 2048 --repeat 5 --out benchmarks/results/cpu-2core-overhead.json
    taskset -c 0,1 python benchmarks/bench.py overhead ...     # two cores of a larger host

Both run the first n variants of sweeps/slope.yaml (1000 steps, MuJoCo's default solver).
The peer is `bench_raw_rollout`: Batch.rollout in blocks with the controls precomputed
outside its clock, recording qpos, qvel and qfrc_actuator, in batches of --peer-variants
(pick them with bench.py's scan). --peers names the vehicles it rolls out, each alternated in
the same run: `same` is batchveh's own compiled model (with the slip tyre: frictionless
condim-1 wheel contacts and no tyre forces, the cheapest MuJoCo step of this vehicle), `rigid`
the same vehicle on MuJoCo's own frictional contact (`tyre: {model: rigid}`), what a user would
run in raw MuJoCo instead of batchveh's tyre. batchveh is `run_sweep` with Parquet written, timed by
its own wall clock (make_batch, the engine, the Parquet parts), at its default chunk and
thread count unless --chunks / --threads name others (each one a column). Shared machines
move both by 10-30% between runs, so they alternate (raw, then each batchveh setting), the
ratio is reported per pair, and the median is over every pair (a warm-up run of each
comes first, unmeasured). --profile adds one instrumented batchveh run: where its time goes.
Prints one JSON line (also written with --out).
"""


def overhead_sweep_rate(spec, n, out, chunk=None, threads=0):
    """variant-steps/s of run_sweep on the first n variants (its own wall clock), Parquet written."""
    import batchveh.engines.mujoco as em
    from batchveh.sweep import run_sweep

    default = em.default_threads
    if threads:
        em.default_threads = lambda: threads
    try:
        s = run_sweep(spec, out=out, backend="mujoco", limit=n, chunk_size=chunk, overwrite=True, progress=False)
    finally:
        em.default_threads = default
    return s["variant_steps_per_s"]


def overhead_profile(spec, n, out, chunk=None):
    """One run_sweep with timers: the main thread's stepping (Batch.rollout) and waits, the worker
    threads' CPU in the fold and the control schedule, and the sweep's own setup and writes."""
    from mujoco.batch import Batch

    import batchveh.engines.mujoco as em
    import batchveh.sweep as sw
    import batchveh.sweeping.chunks as ch
    from batchveh.stepping import stats
    from batchveh.sweeping.results import ResultFolder

    acc: dict[str, float] = {}

    def timed(key, fn, clock=time.perf_counter):
        def wrapper(*a, **k):
            t0 = clock()
            try:
                return fn(*a, **k)
            finally:
                acc[key] = acc.get(key, 0.0) + clock() - t0

        return wrapper

    from batchveh.stepping.rollout import MujocoTyre

    saved = [
        (Batch, "rollout", Batch.rollout),
        (Batch, "step", Batch.step),
        (MujocoTyre, "wrench", MujocoTyre.wrench),
        (stats, "update", stats.update),
        (stats, "sample", stats.sample),
        (stats, "finalize", stats.finalize),
        (em.MujocoEngine, "run", em.MujocoEngine.run),
        (em.MujocoEngine, "__init__", em.MujocoEngine.__init__),
        (ch, "make_batch", ch.make_batch),
        (ResultFolder, "write_file", ResultFolder.write_file),
    ]
    init = em.MujocoEngine.__init__

    def engine_init(self, *a, **k):
        init(self, *a, **k)
        self._ctrl = timed("controls (worker CPU)", self._ctrl, time.thread_time)

    Batch.rollout = timed("Batch.rollout (main thread, wall)", Batch.rollout)
    Batch.step = timed("Batch.step (main thread, wall; the slip tyre and soil step one at a time)", Batch.step)
    MujocoTyre.wrench = timed("wheel-ground step (main thread, wall)", MujocoTyre.wrench)
    stats.update = timed("stats.update (worker CPU)", stats.update, time.thread_time)
    stats.sample = timed("stats.sample (worker CPU)", stats.sample, time.thread_time)
    stats.finalize = timed("stats.finalize (main thread)", stats.finalize)
    em.MujocoEngine.run = timed("engine.run (wall)", em.MujocoEngine.run)
    em.MujocoEngine.__init__ = engine_init
    ch.make_batch = timed("make_batch (wall)", ch.make_batch)
    ResultFolder.write_file = timed("Parquet part writes (wall)", ResultFolder.write_file)
    try:
        cpu0 = time.process_time()
        s = sw.run_sweep(spec, out=out, backend="mujoco", limit=n, chunk_size=chunk, overwrite=True, progress=False)
        cpu = time.process_time() - cpu0
    finally:
        for owner, name, fn in saved:
            setattr(owner, name, fn)
    vsteps = n * spec.scenario.n_steps
    acc["sweep wall_s"] = s["wall_s"]
    acc["process CPU s"] = cpu
    stepping = sum(v for k, v in acc.items() if k.startswith(("Batch.", "wheel-ground")))
    acc["engine.run outside stepping (wall: setup, recording, waits, tail fold)"] = acc["engine.run (wall)"] - stepping
    return {k: {"s": v, "ns_per_variant_step": v / vsteps * 1e9} for k, v in acc.items()}


def overhead_main(argv=None):
    ap = argparse.ArgumentParser(
        prog="bench.py overhead", description=OVERHEAD_DOC, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--n", type=int, default=2048, help="variants (the first n of sweeps/slope.yaml)")
    ap.add_argument("--repeat", type=int, default=5, help="pairs")
    ap.add_argument(
        "--peers", nargs="+", choices=("same", "rigid"), default=["same"], help="vehicles the raw peer rolls out"
    )
    ap.add_argument("--peer-variants", type=int, default=None, help="peer batch size (default: all n in one)")
    ap.add_argument("--peer-block", type=int, default=100)
    ap.add_argument("--peer-threads", type=int, default=0, help="0: every CPU this process may use")
    ap.add_argument("--threads", type=int, nargs="+", default=[0], help="batchveh MuJoCo threads (0: its default)")
    ap.add_argument("--chunks", type=int, nargs="+", default=[0], help="batchveh chunk sizes (0: its default)")
    ap.add_argument("--profile", action="store_true", help="one instrumented batchveh run at the first setting")
    ap.add_argument("--note", default="", help="free text kept in the JSON (e.g. other load on the machine)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    # bench.py guards its main, so the engine may run its parts in worker processes (engines/mujoco.py)
    os.environ.setdefault("BATCHVEH_CPU_PROCESSES", "1")
    import mujoco

    from batchveh.engines.common import CPU_CHUNK
    from batchveh.engines.mujoco import cpus, default_threads
    from batchveh.sweeping.spec import load_spec

    spec = load_spec(Path(__file__).resolve().parent.parent / "sweeps" / "slope.yaml")
    table = spec.table().rows(0, args.n).drop(columns="variant")
    steps = spec.scenario.n_steps
    peer_threads = args.peer_threads or cpus()
    settings = [(c, t) for c in args.chunks for t in args.threads]

    def label(c, t):
        return f"chunk{c or CPU_CHUNK['mujoco']}_threads{t or default_threads()}"

    def raw_key(peer):
        return "raw" if peer == "same" else f"raw_{peer}"

    rigid = dataclasses.replace(spec.vehicle, tyre=dataclasses.replace(spec.vehicle.tyre, model="rigid"))
    peer_specs = {"same": spec, "rigid": dataclasses.replace(spec, vehicle=rigid)}
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "sweep"
        for c, t in settings:  # warm-up: JAX's compile of the control schedule, imports, caches
            overhead_sweep_rate(
                spec, min(args.n, 64 * (t or default_threads())), out, c or None, t
            )  # every part, its pool
        pairs = []
        for r in range(args.repeat):
            pair = {}
            for peer in args.peers:
                pair[raw_key(peer)], _ = bench_raw_rollout(
                    peer_specs[peer], table, steps, args.peer_block, peer_threads, args.peer_variants
                )
            for c, t in settings:
                rate = overhead_sweep_rate(spec, args.n, out, c or None, t)
                pair[f"batchveh_{label(c, t)}"] = rate
                for peer in args.peers:
                    pair[f"ratio{'' if peer == 'same' else '_vs_' + peer}_{label(c, t)}"] = rate / pair[raw_key(peer)]
            pairs.append(pair)
            print(f"pair {r + 1}: " + ", ".join(f"{k} {v:.4g}" for k, v in pair.items()), flush=True)
        prof = overhead_profile(spec, args.n, out, settings[0][0] or None) if args.profile else None
    ratios = [k for k in pairs[0] if k.startswith("ratio")]
    res = {
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "machine": f"{cpu_model()}, {cpus()} CPUs usable of {os.cpu_count()}",
        "cpu_threads": cpus(),
        "mujoco": mujoco.__version__,
        "python": platform.python_version(),
        "command": " ".join(sys.argv),
        "note": args.note,
        "load_average_before_after": [round(load0[0], 2), round(os.getloadavg()[0], 2)],
        "variants": args.n,
        "steps": steps,
        "solver": "MuJoCo's default (Newton, up to 100 iterations)",
        "peer": {
            "api": "Batch.rollout in blocks, controls precomputed, recording qpos, qvel, qfrc_actuator",
            "variants_per_batch": args.peer_variants or args.n,
            "block": args.peer_block,
            "threads": peer_threads,
            "vehicles": {"same": "batchveh's compiled model", "rigid": "tyre: {model: rigid}"},
        },
        "batchveh": "run_sweep (mujoco engine, Parquet written), its own wall clock",
        "pairs": pairs,
        "median_ratio": {k: statistics.median(p[k] for p in pairs) for k in ratios},
        **{f"median_{raw_key(p)}": statistics.median(q[raw_key(p)] for q in pairs) for p in args.peers},
        "profile": prof,
    }
    print(json.dumps(res))
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
