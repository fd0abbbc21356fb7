"""The requirement sheet by hand (issue 61): a size session's `sizing.json` sheet against the same figures computed
here from its servo sweep's Parquet files, read with pyarrow alone, and the catalogue's YAML, read with PyYAML alone.

    python validation/requirement_sheet.py OUT [--json validation/results/requirement_sheet_seed.json]

OUT: a `python -m batchveh.size` folder (its servo/ and sizing.json). By hand, on the worst of the four wheels per
variant, numpy's inverted-CDF percentile at the session's share (the value `share` of the variants need at most):
the RMS torque x sqrt(duty), the steady window's low-pass peak, the whole run's, the mean wheel speed, the peak of
one wheel's |torque x speed|, RMS x speed; the torque at top speed over the variants within 10% of the top speed;
at the shaft of the chosen (or nearest) motor: torque / (eta N), speed x N, power / eta, with N and eta read from the
catalogue's YAML (a pairing's `gearhead:` block or its series' ratio). Each within 1% (the issue's bound).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import yaml

ROOT = Path(__file__).resolve().parent.parent
TOLERANCE = 0.01
WHEELS = ("lf", "rf", "lr", "rr")


def gear_of(catalogue: Path, name: str) -> tuple[float, float]:
    """(N, eta) of a catalogue name, from the YAML by hand: a pairing's gearhead, or <motor>_<series>-i<label>."""
    raw = yaml.safe_load(catalogue.read_text())
    for m in raw["motors"]:
        if m["name"] == name:
            return float(m["gearhead"]["ratio"]), float(m["gearhead"]["efficiency"])
    for s in raw["gearhead_series"]:
        for r in s["ratios"]:
            label = str(r.get("label", f"{r['ratio']:g}:1")).split(":")[0]
            if name.endswith(f"_{s['name']}-i{label}"):
                return float(r["ratio"]), float(r.get("efficiency", s.get("efficiency")))
    raise SystemExit(f"{name}: not found in {catalogue}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out")
    ap.add_argument("--catalogue", default=str(ROOT / "notebooks" / "motors.yaml"))
    ap.add_argument("--json")
    args = ap.parse_args()
    out = Path(args.out)
    summary = json.loads((out / "sizing.json").read_text())
    table = pq.read_table(sorted((out / "servo").glob("part-*.parquet"))).to_pandas()
    share, duty = summary["share"], summary["duty"]

    def worst(stat: str) -> np.ndarray:
        return np.max(np.abs(np.stack([table[f"drive_{w}_{stat}"].to_numpy(float) for w in WHEELS])), axis=0)

    speed = np.abs(table["wheel_speed"].to_numpy(float))
    rms = np.sqrt(duty) * worst("rms")
    values = {
        "rms_torque": rms,
        "peak_torque": worst("peak_lp"),
        "accel_peak_torque": worst("peak_lp_all"),
        "top_speed": speed,
        "continuous_power": rms * speed,
        "peak_power": worst("power_peak"),
    }
    hand = {k: float(np.percentile(v, 100 * share, method="inverted_cdf")) for k, v in values.items()}
    near = speed >= 0.9 * hand["top_speed"]
    hand["torque_at_top_speed"] = float(np.percentile(values["peak_torque"][near], 100 * share, method="inverted_cdf"))
    sheet = summary["requirements"]["drive"]
    got = {k: f["value"] for k, f in sheet["at_wheel"].items()}
    n, eta = gear_of(Path(args.catalogue), sheet["at_shaft"]["motor"])
    scale = {"N m": 1 / (eta * n), "rad/s": n, "W": 1 / eta}
    rows = {}
    for key, h in hand.items():
        unit = sheet["at_wheel"][key]["unit"]
        shaft = sheet["at_shaft"][key]["value"]
        rows[key] = {
            "unit": unit,
            "size_command": got[key],
            "by_hand": h,
            "rel_diff": abs(got[key] - h) / max(abs(h), 1e-12),
            "shaft_size_command": shaft,
            "shaft_by_hand": h * scale[unit],
            "shaft_rel_diff": abs(shaft - h * scale[unit]) / max(abs(h * scale[unit]), 1e-12),
            "variant": sheet["at_wheel"][key]["variant"],
        }
    worst_diff = max(max(r["rel_diff"], r["shaft_rel_diff"]) for r in rows.values())
    for key, r in rows.items():
        print(f"{key:22} {r['size_command']:10.4g} {r['by_hand']:10.4g} {r['rel_diff']:9.2e}   shaft "
              f"{r['shaft_size_command']:10.4g} {r['shaft_by_hand']:10.4g} {r['unit']}")  # fmt: skip
    print(f"largest relative difference {worst_diff:.2e} (bound {TOLERANCE}); shaft of {sheet['at_shaft']['motor']}")
    result = {
        "what": __doc__.split("\n\n")[0],
        "session": str(out),
        "variants": len(table),
        "share": share,
        "duty": duty,
        "chosen": summary["chosen"],
        "shaft_of": sheet["at_shaft"]["motor"],
        "figures": rows,
        "largest_rel_diff": worst_diff,
        "bound": TOLERANCE,
        "nearest": summary["requirements"].get("nearest"),
        "would": summary["requirements"].get("would"),
    }
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1, default=str) + "\n")
    if worst_diff > TOLERANCE:
        raise SystemExit(f"a figure differs by {worst_diff:.2%} > {TOLERANCE:.0%}")


if __name__ == "__main__":
    main()
