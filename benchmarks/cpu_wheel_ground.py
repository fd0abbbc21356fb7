"""The wheel-ground models' cost on the MuJoCo C engine, per step: MuJoCo's own step against the slip
tyre's and the soil's array code between the steps, run as numpy and as the XLA-compiled float64
function the engine uses (`rollout.MujocoTyre`), side by side in one run.

    python benchmarks/cpu_wheel_ground.py --out benchmarks/results/cpu-2core-wheel-ground-step.json

Per model and batch size: a Batch of the seed vehicle on a 5 deg climb at 2 km/h, stepped 20 times,
then timed over --steps steps each: `Batch.step` (all CPU threads), `wheels.step` + the xfrc_applied
scatter in numpy, and the same through `MujocoTyre.wrench` (compiled once before its clock). Both
tyre paths start from the same state and get the same inputs; the largest difference of their
wrenches is recorded. Prints a table and one JSON line.
"""

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from cpu_overhead import cpu_model  # noqa: E402
from mujoco.batch import Batch  # noqa: E402

from batchveh.model import wheels  # noqa: E402
from batchveh.model.scenarios import make_scenario  # noqa: E402
from batchveh.model.tyres import Tyre  # noqa: E402
from batchveh.model.vehicle import Vehicle  # noqa: E402
from batchveh.stepping.batch import make_batch  # noqa: E402
from batchveh.stepping.rollout import MujocoTyre, layout  # noqa: E402


def _per_call(fn, steps):
    t0 = time.perf_counter()
    for _ in range(steps):
        out = fn()
    return (time.perf_counter() - t0) / steps, out


def row(model: str, n: int, steps: int) -> dict:
    sc = make_scenario("straight_line", total_time=1.0, ramp_time=0.5, speed_kmh=2.0, slope_deg=5.0, friction=0.8)
    batch = make_batch(Vehicle(tyre=Tyre(model=model)), sc, {"slope_deg": np.linspace(0.0, 10.0, n)})
    m, lay = batch.model, layout(batch.model)
    b = Batch(m, nsim=n, nthread=0)
    for _ in range(20):
        b.step()
    x = tuple(b.bind(k) for k in ("xpos", "xmat", "qvel", "cfrc_ext", "xfrc_applied"))
    args = (x[0], x[1].reshape(n, m.nbody, 3, 3), *x[2:])
    xla = MujocoTyre(m, lay, batch.params)
    t0 = time.perf_counter()
    xla.wrench(*args)  # compiles
    compile_s = time.perf_counter() - t0
    state0 = np.asarray(xla.state)
    tp = wheels.params({k: np.asarray(v, np.float64) for k, v in batch.params.items()}, lay.wheel_ground, np)
    dt = float(m.opt.timestep)

    def numpy_wrench():
        return wheels.step_xfrc(state0, *args, tp, lay, dt, m.nbody, np)[1]

    def xla_wrench():
        xla.state = state0
        return xla.wrench(*args)

    step_s, _ = _per_call(b.step, steps)
    numpy_s, w_np = _per_call(numpy_wrench, steps)
    xla_s, w_xla = _per_call(xla_wrench, steps)
    return {
        "model": model,
        "variants": n,
        "batch_step_ms": step_s * 1e3,
        "numpy_ms": numpy_s * 1e3,
        "xla_ms": xla_s * 1e3,
        "numpy_over_xla": numpy_s / xla_s,
        "compile_s": compile_s,
        "max_abs_wrench_difference": float(np.abs(w_np - w_xla).max()),
        "max_abs_wrench": float(np.abs(w_np).max()),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 2048, 4096])
    ap.add_argument("--steps", type=int, default=50, help="timed steps per row")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()
    rows = [row(model, n, a.steps) for model in ("slip", "soil") for n in a.sizes]
    print("| model | variants | Batch.step ms | numpy ms | XLA ms | numpy / XLA | max |diff| of the wrenches |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        print(
            f"| {r['model']} | {r['variants']} | {r['batch_step_ms']:.2f} | {r['numpy_ms']:.2f} | {r['xla_ms']:.2f} "
            f"| {r['numpy_over_xla']:.2f} | {r['max_abs_wrench_difference']:.1e} (of {r['max_abs_wrench']:.0f}) |"
        )
    out = {
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "machine": f"{cpu_model()}, {len(os.sched_getaffinity(0))} CPUs, {platform.system()}",
        "load_average": os.getloadavg(),
        "command": " ".join(["python", *sys.argv]),
        "rows": rows,
    }
    print(json.dumps(out))
    if a.out:
        a.out.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
