"""Parquet output: one part file per chunk, written atomically, and `load`.

A result directory holds `manifest.json` (the spec, the chunk size, the variant
count: what a resume must match) and `part-NNNNN.parquet` files. Each part's
Arrow fields carry `unit` and `description` metadata; its file metadata carries
the spec, the batchveh, mujoco and jax versions, the device and the timings.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from batchveh.stats import CHANNELS

MANIFEST = "manifest.json"

_STAT_DOC = {
    "mean": ("N m", "mean torque over the steady window"),
    "rms": ("N m", "RMS torque over the steady window"),
    "min": ("N m", "minimum torque over the steady window"),
    "max": ("N m", "maximum torque over the steady window"),
    "peak": ("N m", "peak |torque| over the steady window"),
    "p95": ("N m", "95th percentile of |torque| over the steady window (strided samples)"),
    "peak_all": ("N m", "peak |torque| over the whole run"),
    "peak_lp": ("N m", "peak |low-pass filtered torque| over the steady window"),
    "peak_lp_all": ("N m", "peak |low-pass filtered torque| over the whole run"),
    "energy": ("J", "mechanical energy delivered, integral of torque x speed, whole run"),
    "power_peak": ("W", "peak |torque x speed| over the whole run"),
}
_OTHER_DOC = {
    "variant": ("", "variant id"),
    "status": ("", "ok, diverged (NaN or inf) or flipped (roll or pitch > 60 deg)"),
    "distance": ("m", "path length of the chassis centre in the ground plane"),
    "mean_speed": ("m/s", "mean forward chassis speed over the steady window"),
    "wheel_speed": ("rad/s", "mean wheel angular speed (four wheels) over the steady window"),
    "slip_ratio": ("1", "1 - forward speed / mean rim speed over the steady window"),
    "slipping": ("", "|slip_ratio| > 0.1: the imposed speed is not held by the ground"),
    "window_accel": ("m/s^2", "least-squares forward acceleration of the chassis over the steady window"),
    "steady": ("", "|window_accel| < 0.05 m/s^2: the window is steady (torques exclude acceleration)"),
    "speed_track_err": ("1", "steady mean wheel-speed error relative to the imposed speed (max over wheels)"),
    "steer_track_err_deg": ("deg", "max steering-angle error over the steady window"),
    "max_roll_deg": ("deg", "max |roll| over the run"),
    "max_pitch_deg": ("deg", "max |pitch| over the run"),
    "final_x": ("m", "final chassis x"),
    "final_y": ("m", "final chassis y"),
    "final_yaw_deg": ("deg", "final chassis yaw"),
}


def column_doc(name: str, param_units: dict[str, str]) -> tuple[str, str]:
    """(unit, description) of a result column."""
    if name in _OTHER_DOC:
        return _OTHER_DOC[name]
    if name in param_units:
        return param_units[name], "swept parameter"
    for ch in CHANNELS:
        if name.startswith(ch + "_"):
            unit, doc = _STAT_DOC[name[len(ch) + 1 :]]
            return unit, f"{ch}: {doc}"
    return "", ""


def write_part(frame: pd.DataFrame, path: Path, param_units: dict[str, str], meta: dict[str, Any]) -> None:
    """Write one chunk's rows to `path` atomically (temporary name, then rename)."""
    table = pa.Table.from_pandas(frame, preserve_index=False)
    fields = []
    for f in table.schema:
        unit, doc = column_doc(f.name, param_units)
        fields.append(f.with_metadata({"unit": unit, "description": doc}))
    schema = pa.schema(fields, metadata={"batchveh": json.dumps(meta, default=str)})
    tmp = path.with_name(f".{path.name}.tmp")
    pq.write_table(table.cast(schema), tmp)
    os.replace(tmp, path)


FIGURES = ("envelope.png", "heatmap.png", "steering.png")


def remove_results(out: Path) -> None:
    """Delete the files a sweep writes in `out` (parts, temporaries, manifest, figures), nothing else."""
    for f in [*parts(out), *out.glob(".part-*.tmp"), out / MANIFEST, *(out / name for name in FIGURES)]:
        f.unlink(missing_ok=True)


def parts(out: Path) -> list[Path]:
    return sorted(out.glob("part-*.parquet"))


def load(path: str | Path) -> pd.DataFrame:
    """All rows of a sweep result directory (or one Parquet file) as a DataFrame, by variant."""
    path = Path(path)
    files = parts(path) if path.is_dir() else [path]
    if not files:
        raise FileNotFoundError(f"{path}: no part-*.parquet files")
    frame = pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)
    return frame.sort_values("variant").reset_index(drop=True) if "variant" in frame else frame


def _first_file(path: str | Path) -> Path:
    """A result's first part file (its schema and metadata stand for all), or the file itself."""
    path = Path(path)
    return parts(path)[0] if path.is_dir() else path


def metadata(path: str | Path) -> dict[str, Any]:
    """The batchveh file metadata of a result (spec, versions, device, timings)."""
    f = _first_file(path)
    return json.loads(pq.read_schema(f).metadata[b"batchveh"])


def units(path: str | Path) -> dict[str, str]:
    """Column name -> unit, from the Arrow field metadata."""
    f = _first_file(path)
    return {fl.name: fl.metadata[b"unit"].decode() for fl in pq.read_schema(f)}
