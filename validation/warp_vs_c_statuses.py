"""Warp against MuJoCo C, variant by variant: how often the two engines give a variant the same `status` and the same
`motor_status` (issue 51: at least 99.9%), the counts of each on both, the variants that differ, and the largest
steering error and torque ratio on each. Writes validation/results/sidewalk_warp_vs_c.json.

    python validation/warp_vs_c_statuses.py WARP_RESULTS C_RESULTS [--machine "one H200"] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import subprocess
from datetime import date
from pathlib import Path

import numpy as np

import batchveh

ROOT = Path(__file__).resolve().parent.parent
JSON = ROOT / "validation" / "results" / "sidewalk_warp_vs_c.json"
EQUAL_MIN = 0.999  # the bound: the share of variants whose statuses agree


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("warp")
    ap.add_argument("c")
    ap.add_argument("--machine", default="")
    ap.add_argument("--json", default=str(JSON))
    args = ap.parse_args()
    w = batchveh.load(args.warp).sort_values("variant").reset_index(drop=True)
    c = batchveh.load(args.c).sort_values("variant").reset_index(drop=True)
    assert (w["variant"].to_numpy() == c["variant"].to_numpy()).all(), "the two results hold different variants"
    out = {"what": __doc__.split("\n\n")[0], "date": str(date.today()), "variants": len(c), "bound": EQUAL_MIN,
           "commit": subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True)
           .stdout.strip(), "machine": args.machine}  # fmt: skip
    for col in ("status", "motor_status"):
        same = w[col].astype(str).to_numpy() == c[col].astype(str).to_numpy()
        out[f"{col}_equal"] = float(same.mean())
        out[f"{col}_counts"] = {"warp": w[col].astype(str).value_counts().to_dict(),
                                "c": c[col].astype(str).value_counts().to_dict()}  # fmt: skip
        params = [k for k in ("payload.mass", "slope_deg", "speed_kmh", "friction") if k in c]
        diff = c.loc[~same, params].assign(warp=w.loc[~same, col].astype(str), c=c.loc[~same, col].astype(str))
        out[f"{col}_differ"] = diff.round(4).to_dict(orient="records")
    for name, df in (("warp", w), ("c", c)):
        out[f"{name}_steer_err_deg_max"] = float(np.max(df["steer_track_err_deg"]))
        out[f"{name}_torque_ratio_max"] = float(np.max(df["motor_torque_ratio"]))
    out["met"] = out["status_equal"] >= EQUAL_MIN and out["motor_status_equal"] >= EQUAL_MIN
    Path(args.json).write_text(json.dumps(out, indent=1) + "\n")
    print(f"status equal {out['status_equal']:.4%}, motor_status equal {out['motor_status_equal']:.4%} "
          f"(bound {EQUAL_MIN:.1%}); written {args.json}")  # fmt: skip


if __name__ == "__main__":
    main()
