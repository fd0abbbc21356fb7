"""batchveh's MuJoCo C engine through run_sweep against raw mujoco.batch at its best, alternated.

    python benchmarks/cpu_overhead.py --n 2048 --repeat 5 --out benchmarks/results/cpu-2core-overhead.json
    taskset -c 0,1 python benchmarks/cpu_overhead.py ...     # two cores of a larger host

Both run the first n variants of sweeps/slope.yaml (1000 steps, MuJoCo's default solver).
The peer is `bench.bench_raw_rollout`: Batch.rollout in blocks with the controls precomputed
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

import argparse
import dataclasses
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


from bench import cpu_model  # noqa: E402  (one way to name the machine)


def sweep_rate(spec, n, out, chunk=None, threads=0):
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


def profile_sweep(spec, n, out, chunk=None):
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
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
    args = ap.parse_args()
    # this script guards its main, so the engine may run its parts in worker processes (engines/mujoco.py)
    os.environ.setdefault("BATCHVEH_CPU_PROCESSES", "1")
    import mujoco
    from bench import bench_raw_rollout

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
            sweep_rate(spec, min(args.n, 64 * (t or default_threads())), out, c or None, t)  # every part, its pool
        pairs = []
        for r in range(args.repeat):
            pair = {}
            for peer in args.peers:
                pair[raw_key(peer)], _ = bench_raw_rollout(
                    peer_specs[peer], table, steps, args.peer_block, peer_threads, args.peer_variants
                )
            for c, t in settings:
                rate = sweep_rate(spec, args.n, out, c or None, t)
                pair[f"batchveh_{label(c, t)}"] = rate
                for peer in args.peers:
                    pair[f"ratio{'' if peer == 'same' else '_vs_' + peer}_{label(c, t)}"] = rate / pair[raw_key(peer)]
            pairs.append(pair)
            print(f"pair {r + 1}: " + ", ".join(f"{k} {v:.4g}" for k, v in pair.items()), flush=True)
        prof = profile_sweep(spec, args.n, out, settings[0][0] or None) if args.profile else None
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
