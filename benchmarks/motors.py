"""What do motors in the loop cost a sweep, and does warp agree with C on them?

The cost of motors in the loop (issue 31): the same sweep with the ideal servo and with dcmotors.

    python benchmarks/motors.py --size 2048 --time 2 --repeat 3 --label cpu-2core
    python benchmarks/motors.py --size 131072 --time 5 --repeat 1 --backend warp --label h200

A random sweep over slope, friction and speed, run by the CLI in fresh processes as a user runs it,
alternated: `servo` (the default vehicle) and `dcmotor` (the same vehicle with
notebooks/motors.yaml's maxon 353297 on a 40:1 planetary unit at every wheel and steering
joint). Each run's process wall and the sweep's own rate; the ratio of the medians of the rates.
Writes benchmarks/results/LABEL-motors.json (or --out) and prints a table.

    python benchmarks/motors.py compare WARP_RESULTS C_RESULTS --label h200-warp-vs-cpu-2core-c

Warp (float32) against MuJoCo C (float64), two result folders of benchmarks/motors_warp_vs_c.yaml (motors near
their limits): per drive, over the variants, the relative difference |warp - C| / max(|C|, 1% of C's p99 of the
column) of current RMS, winding temperature rise (peak less ambient), energy drawn, speed shortfall and the
shares at the voltage line and the current limit; for the vehicle, bus energy and peak power; p50, p99, max
and the share over 2%, and how often motor_status agrees; per drive also |warp - C| over the column's largest C
value (the limit's scale: a low-load wheel's small current is not compared with itself alone).
Writes benchmarks/results/LABEL-dcmotor-compare.json.
"""

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench import machine, result_path, write_result  # noqa: E402
from structural import FLAT, cli  # noqa: E402

MOTOR = "maxon-353297-48V_NPT025-i40"
DCMOTOR = {
    "motors": {
        "model": "dcmotor",
        "catalogue": str(ROOT / "notebooks" / "motors.yaml"),
        "drive": MOTOR,
        "steer": MOTOR,
    }
}


DRIVES = ("drive_lf", "drive_rf", "drive_lr", "drive_rr")
PER_DRIVE = ("current_rms", "winding_temp_rise", "energy_drawn", "speed_shortfall", "at_voltage_share",
             "at_current_share")  # fmt: skip


def compare(a: str, b: str, label: str, out: str | None) -> dict:
    """Warp (a) against MuJoCo C (b): the module's docstring."""
    import batchveh

    w, c = (batchveh.load(x).set_index("variant").sort_index() for x in (a, b))
    if not w.index.equals(c.index):
        raise SystemExit("compare: the two folders hold different variants")

    def column(df, m, stat):
        if stat == "winding_temp_rise":
            return df[f"{m}_winding_temp_peak"].to_numpy() - 25.0  # the spec's motors' ambient (deg C)
        return df[f"{m}_{stat}"].to_numpy()

    def summary(rel):
        return {"p50": float(np.median(rel)), "p99": float(np.percentile(rel, 99)), "max": float(rel.max()),
                "share_over_2pct": float(np.mean(rel > 0.02))}  # fmt: skip

    def rel(x, ref):
        return np.abs(x - ref) / np.maximum(np.abs(ref), 0.01 * np.percentile(np.abs(ref), 99))

    result = {"machine": machine(), "when": time.strftime("%Y-%m-%d %H:%M:%S"), "warp": a, "c": b,
              "variants": len(c), "per_drive": {}, "vehicle": {}}  # fmt: skip
    result["per_drive_of_largest"] = {}  # |warp - C| over the largest C value of the column (the limit's scale)
    for stat in PER_DRIVE:
        r = np.concatenate([rel(column(w, m, stat), column(c, m, stat)) for m in DRIVES])
        result["per_drive"][stat] = summary(r)
        a = np.concatenate([np.abs(column(w, m, stat) - column(c, m, stat)) for m in DRIVES])
        result["per_drive_of_largest"][stat] = summary(
            a / max(np.abs(np.concatenate([column(c, m, stat) for m in DRIVES])).max(), 1e-300)
        )
    for col in ("bus_energy_wh", "bus_power_peak"):
        result["vehicle"][col] = summary(rel(w[col].to_numpy(), c[col].to_numpy()))
    result["motor_status_agree"] = float((w["motor_status"] == c["motor_status"]).mean())
    result["motor_status_c"] = c["motor_status"].value_counts().to_dict()
    for k, v in {**result["per_drive"], **result["vehicle"]}.items():
        print(f"{k:20s} p50 {v['p50']:.2e}  p99 {v['p99']:.2e}  max {v['max']:.2e}  over 2% {v['share_over_2pct']:.4f}")
    for k, v in result["per_drive_of_largest"].items():
        print(f"{k:20s} of the largest C value: p99 {v['p99']:.2e}  max {v['max']:.2e}")
    print(f"motor_status agrees on {result['motor_status_agree']:.2%} of {len(c):,} variants")
    write_result(json.loads(json.dumps(result, default=str)), result_path("dcmotor-compare", label, out))
    return result


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "compare":
        q = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
        q.add_argument("part")
        q.add_argument("warp")
        q.add_argument("c")
        q.add_argument("--label", help="the result file's label (default: the machine's, bench.default_label)")
        q.add_argument("--out")
        x = q.parse_args()
        compare(x.warp, x.c, x.label, x.out)
        return
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--size", type=int, default=2048)
    p.add_argument("--time", type=float, default=2.0, help="simulated seconds per variant")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--backend", help="mujoco or warp (default: the CLI's auto)")
    p.add_argument("--label", help="the result file's label (default: the machine's, bench.default_label)")
    p.add_argument("--out")
    args = p.parse_args()
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        specs = {}
        for kind, vehicle in (("servo", None), ("dcmotor", DCMOTOR)):
            spec = {
                "name": kind,
                "scenario": "straight_line",
                "fixed": {"total_time": args.time, "ramp_time": min(1.0, args.time / 2)},
                "sweep": {"method": "random", "n": args.size, "seed": 0, "params": FLAT},
                "output": str(Path(tmp) / kind),
            }
            if vehicle:
                spec["vehicle"] = vehicle
            specs[kind] = Path(tmp) / f"{kind}.yaml"
            specs[kind].write_text(yaml.safe_dump(spec, sort_keys=False))
        backend = ("--backend", args.backend) if args.backend else ()
        for spec in specs.values():  # warm: Warp's kernels, JAX's cache
            cli(spec, "--limit", "256", "--overwrite", *backend)
        for r in range(args.repeat):
            for kind, spec in specs.items():
                run = cli(spec, "--overwrite", *backend)
                run.update(kind=kind, round=r)
                runs.append(run)
                rate = run.get("rate", 0)
                print(f"{kind:8s} round {r}: process {run['process_s']:7.1f} s, rate {rate:.3g}, rc {run['rc']}")
    rate = {k: float(np.median([x.get("rate", 0) for x in runs if x["kind"] == k])) for k in ("servo", "dcmotor")}
    ratio = rate["dcmotor"] / rate["servo"]
    print(f"dcmotor / servo, median rate: {ratio:.3f}")
    result = {"machine": machine(), "when": time.strftime("%Y-%m-%d %H:%M:%S"), "size": args.size,
              "total_time": args.time, "motor": MOTOR, "runs": runs, "median_rate": rate, "ratio": ratio}  # fmt: skip
    write_result(json.loads(json.dumps(result, default=str)), result_path("motors", args.label, args.out))


if __name__ == "__main__":
    main()
