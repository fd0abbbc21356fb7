"""Where an MJX step spends its time on this vehicle: cumulative pipeline stages, vmapped.

    python benchmarks/stages.py --n 65536 --solver newton8

Each row times jit(vmap(prefix of mjx.step)) over n variants from a settled state (10
runs after a warm-up, best kept); the difference to the previous row is that stage's
cost. This is the profile evidence for docs/performance.md (no trace viewer is needed).
"""

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=65536)
    ap.add_argument("--solver", default="newton8")
    ap.add_argument("--out", default=None, help="JSON file for the rows")
    ap.add_argument("--wheel-collision", default="cylinder", choices=["cylinder", "sphere"])
    args = ap.parse_args()
    import bench

    bench.WHEEL_COLLISION = args.wheel_collision
    import jax
    from bench import best_time, mjx_model, settled, slope_table
    from mujoco import mjx

    spec, table = slope_table(args.n, seed=3)
    m, axes = mjx_model(spec, table, args.solver)

    with jax.default_matmul_precision("highest"):
        data = settled(m, axes)

        def smooth(mm, d):
            for f in (mjx.kinematics, mjx.com_pos, mjx.crb, mjx.factor_m):
                d = f(mm, d)
            return d

        stages = [
            ("kinematics, com, crb, factor_m", smooth),
            ("+ collision", lambda mm, d: mjx.collision(mm, smooth(mm, d))),
            ("+ make_constraint", lambda mm, d: mjx.make_constraint(mm, mjx.collision(mm, smooth(mm, d)))),
            (
                "+ transmission, velocity, actuation, acceleration (forward without solve)",
                lambda mm, d: mjx.fwd_acceleration(
                    mm,
                    mjx.fwd_actuation(
                        mm,
                        mjx.fwd_velocity(
                            mm, mjx.transmission(mm, mjx.make_constraint(mm, mjx.collision(mm, smooth(mm, d))))
                        ),
                    ),
                ),
            ),
            ("+ solve (mjx.forward)", mjx.forward),
            ("+ implicitfast integration (mjx.step)", mjx.step),
        ]
        rows, prev = [], 0.0
        for name, fn in stages:
            best = best_time(jax.jit(jax.vmap(fn, in_axes=(axes, 0))), m, data)
            rows.append({"stage": name, "ms": best * 1e3, "delta_ms": best * 1e3 - prev})
            prev = best * 1e3
    total = rows[-1]["ms"]
    print(
        f"{args.n} variants, {args.solver}, {jax.devices()[0].device_kind}: one step {total:.2f} ms "
        f"= {args.n / total * 1e3:.3g} variant-steps/s"
    )
    for r in rows:
        print(f"{r['stage']:78s} {r['ms']:8.2f} ms  (+{r['delta_ms']:7.2f}, {100 * r['delta_ms'] / total:5.1f}%)")
    if args.out:
        Path(args.out).write_text(
            json.dumps(
                {
                    "n": args.n,
                    "solver": args.solver,
                    "device": jax.devices()[0].device_kind,
                    "wheel_collision": args.wheel_collision,
                    "rows": rows,
                },
                indent=1,
            )
        )


if __name__ == "__main__":
    main()
