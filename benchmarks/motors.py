"""The cost of motors in the loop (issue 31): the same sweep with the ideal servo and with dcmotors.

    python benchmarks/motors.py --size 2048 --time 2 --repeat 3 --label cpu-2core
    python benchmarks/motors.py --size 131072 --time 5 --repeat 1 --backend warp --label h200

A random sweep over slope, friction and speed, run by the CLI in fresh processes as a user runs it,
alternated: `servo` (the default vehicle) and `dcmotor` (the same vehicle with
notebooks/motor_catalogue.yaml's maxon 353297 on a 40:1 planetary unit at every wheel and steering
joint). Each run's process wall and the sweep's own rate; the ratio of the medians of the rates.
Writes benchmarks/results/LABEL-motors.json (or --out) and prints a table.
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
from structural import FLAT, cli, machine  # noqa: E402

MOTOR = "maxon-353297-48V_NPT025-i40"
DCMOTOR = {
    "motors": {
        "model": "dcmotor",
        "catalogue": str(ROOT / "notebooks" / "motor_catalogue.yaml"),
        "drive": MOTOR,
        "steer": MOTOR,
    }
}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--size", type=int, default=2048)
    p.add_argument("--time", type=float, default=2.0, help="simulated seconds per variant")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--backend", help="mujoco or warp (default: the CLI's auto)")
    p.add_argument("--label", default="local")
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
    out = Path(args.out or ROOT / "benchmarks" / "results" / f"{args.label}-motors.json")
    out.write_text(json.dumps(result, indent=1, default=str))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
