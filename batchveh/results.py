"""A result folder: its manifest, its lock, its part files with checksums, and `load`.

A result folder holds `manifest.json` and `part-NNNNN.parquet` files, one per chunk.
The manifest records what a resume must match (the spec, the chunk size, the
backend) and, for every part written, its row count, size and SHA-256; a part
that is missing, unlisted or does not match is not finished, and `--resume` runs
its chunk again. Each part's Arrow fields carry `unit` and `description` metadata;
its file metadata carries the spec, the batchveh, mujoco and jax versions, the
device and the timings. Parts and the manifest are written under a temporary name,
then renamed, so a kill leaves either the old file or the new one.

A running sweep holds an advisory lock on `.batchveh.lock` in the folder, so a
second writer stops at once with the holder's process id and host.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from batchveh.config import ConfigError
from batchveh.stats import CHANNELS

MANIFEST = "manifest.json"
LOCK = ".batchveh.lock"
PART = "part-{:05d}.parquet"


class ResultError(ConfigError):
    """A result folder that cannot be used as it is: one line, with what to do."""


class Locked(FileExistsError):
    """Another process is writing into the result folder."""


_STAT_DOC = {
    "mean": ("N m", "mean torque over the steady window"),
    "rms": ("N m", "RMS torque over the steady window"),
    "min": ("N m", "minimum torque over the steady window"),
    "max": ("N m", "maximum torque over the steady window"),
    "peak": ("N m", "peak |torque| over the steady window"),
    "p95": ("N m", "95th percentile of |torque| over the steady window (strided samples)"),
    "peak_all": ("N m", "peak |torque| over the whole run after the settle"),
    "peak_lp": ("N m", "peak |low-pass filtered torque| over the steady window"),
    "peak_lp_all": ("N m", "peak |low-pass filtered torque| over the whole run after the settle"),
    "energy": ("J", "mechanical energy delivered, integral of torque x speed, whole run after the settle"),
    "power_peak": ("W", "peak |torque x speed| over the whole run after the settle"),
}
_OTHER_DOC = {
    "variant": ("", "variant id"),
    "status": (
        "",
        "ok, diverged (NaN, inf or a huge state, or MuJoCo found the simulation unstable) or flipped "
        "(roll or pitch > 60 deg)",
    ),
    "distance": ("m", "path length of the chassis centre in the ground plane after the settle"),
    "mean_speed": ("m/s", "mean forward chassis speed over the steady window"),
    "wheel_speed": ("rad/s", "mean wheel angular speed (four wheels) over the steady window"),
    "slip_ratio": ("1", "1 - forward speed / mean rim speed over the steady window"),
    "slipping": ("", "|slip_ratio| > 0.1: the imposed speed is not held by the ground"),
    "window_accel": ("m/s^2", "least-squares forward acceleration of the chassis over the steady window"),
    "steady": ("", "|window_accel| < 0.05 m/s^2: the window is steady (torques exclude acceleration)"),
    "speed_track_err": ("1", "steady mean wheel-speed error relative to the imposed speed (max over wheels)"),
    "steer_track_err_deg": ("deg", "max steering-angle error over the steady window"),
    "max_roll_deg": ("deg", "max |roll| over the run after the settle"),
    "max_pitch_deg": ("deg", "max |pitch| over the run after the settle"),
    "final_x": ("m", "final chassis x"),
    "final_y": ("m", "final chassis y"),
    "final_yaw_deg": ("deg", "final chassis yaw"),
    "solver_limit_share": (
        "1",
        "share of steps whose constraint solve stopped on opt.iterations, not on the tolerance "
        "(mujoco and warp backends; MJX's JAX solver does not count its iterations)",
    ),
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


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _write_atomic(path: Path, write) -> None:
    """Call write(tmp) on a temporary name beside `path`, then rename it to `path`: a kill leaves
    the old file or the new one, never half of one."""
    tmp = path.with_name(f".{path.name}.tmp")
    write(tmp)
    os.replace(tmp, path)


def annotated_table(frame: pd.DataFrame, fields: dict[str, dict[str, str]], meta: dict[str, str]) -> pa.Table:
    """A frame as an Arrow table with `fields[name]` as each field's metadata and `meta` on the file."""
    table = pa.Table.from_pandas(frame, preserve_index=False)
    schema = pa.schema([f.with_metadata(fields.get(f.name, {})) for f in table.schema], metadata=meta)
    return table.cast(schema)


def part_table(frame: pd.DataFrame, param_units: dict[str, str], meta: dict[str, Any]) -> pa.Table:
    """A sweep chunk's rows, with unit and description on every column and `meta` on the file."""
    fields = {}
    for name in frame.columns:
        unit, doc = column_doc(name, param_units)
        fields[name] = {"unit": unit, "description": doc}
    return annotated_table(frame, fields, {"batchveh": json.dumps(meta, default=str)})


def write_table(table: pa.Table, path: Path) -> None:
    """Write `table` to `path` atomically (temporary name, then rename)."""
    _write_atomic(path, lambda tmp: pq.write_table(table, tmp))


class ResultFolder:
    """A sweep's output folder: manifest, lock and part files.

    `open` checks what is there against the new manifest and returns the finished
    chunks; `write_part` writes a chunk and records it. Hold `lock()` around both."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.manifest: dict[str, Any] = {}

    def part(self, chunk: int) -> Path:
        return self.path / PART.format(chunk)

    def parts(self) -> list[Path]:
        return sorted(self.path.glob("part-*.parquet")) if self.path.is_dir() else []

    def read_manifest(self) -> dict[str, Any] | None:
        f = self.path / MANIFEST
        if not f.is_file():
            return None
        try:
            return json.loads(f.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise ResultError(
                f"{f}: damaged (not JSON); give --overwrite to run the sweep again from scratch"
            ) from None

    @contextlib.contextmanager
    def lock(self) -> Iterator[None]:
        """Hold the folder's advisory lock; raise Locked naming the holder if another process has it."""
        import fcntl

        self._check_folder()
        self.path.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "another process"
                raise Locked(f"{self.path} is being written by {holder}; wait for it, or use another --out") from None
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()}".encode(), 0)
            yield
        finally:
            os.close(fd)  # closing releases the lock

    def _check_folder(self) -> None:
        for p in (self.path, *self.path.parents):
            if p.exists() and not p.is_dir():
                raise ConfigError(f"{self.path}: {p} exists and is not a folder; allowed: a folder for the results")

    def verify(self) -> tuple[set[int], dict[str, str]]:
        """(finished chunks, {part name: what is wrong}) against the manifest's records."""
        records = (self.read_manifest() or {}).get("parts", {})
        done, bad = set(), {}
        for f in self.parts():
            rec = records.get(f.name)
            if rec is None:
                bad[f.name] = "not in the manifest (written by a run that was killed before recording it)"
            elif f.stat().st_size != rec["bytes"]:
                bad[f.name] = f"{f.stat().st_size} bytes where {rec['bytes']} were written (truncated or changed)"
            elif _sha256(f) != rec["sha256"]:
                bad[f.name] = "checksum differs from the one recorded (the file changed after it was written)"
            else:
                done.add(int(f.stem.split("-")[1]))
        return done, bad

    def open(self, manifest: dict[str, Any], *, resume: bool, overwrite: bool) -> tuple[set[int], dict[str, str]]:
        """Start or resume: returns (finished chunks, bad parts removed for a rerun).

        Raises FileExistsError where results exist and neither resume nor overwrite is
        given, and ConfigError where they come from another spec or setting."""
        self._check_folder()
        old = self.read_manifest() if not overwrite else None
        existing = self.parts()
        if (existing or old is not None) and not resume and not overwrite:
            raise FileExistsError(
                f"{self.path} holds results; give --resume to continue or --overwrite to replace them"
            )
        if overwrite:
            self.remove()
        done, bad = set(), {}
        if resume and old is not None:
            ours = json.loads(json.dumps(manifest, default=str))
            differ = [k for k in ours if k != "parts" and old.get(k) != ours[k]]
            if differ:
                k = differ[0]
                raise ConfigError(
                    f"{self.path}: the results there were made with another {k} ({_short(old.get(k))}, now "
                    f"{_short(ours[k])}); resume with the same settings, or give --overwrite to replace them"
                )
            done, bad = self.verify()
            for name in bad:
                (self.path / name).unlink()
            manifest = {**manifest, "parts": {k: v for k, v in old.get("parts", {}).items() if k not in bad}}
        elif resume:  # parts but no manifest: nothing can be verified
            for f in existing:
                bad[f.name] = "no manifest to verify it against"
                f.unlink()
        self.manifest = {**manifest, "parts": manifest.get("parts", {})}
        self.path.mkdir(parents=True, exist_ok=True)
        self._save()
        return done, bad

    def _save(self) -> None:
        text = json.dumps(self.manifest, indent=1, default=str)
        _write_atomic(self.path / MANIFEST, lambda tmp: tmp.write_text(text))

    def write_part(self, chunk: int, table: pa.Table) -> None:
        """Write chunk's table atomically, then record its size and checksum in the manifest."""
        path = self.part(chunk)
        write_table(table, path)
        self.manifest["parts"][path.name] = {
            "rows": table.num_rows,
            "bytes": path.stat().st_size,
            "sha256": _sha256(path),
        }
        self._save()

    def record_files(self, paths: list[Path]) -> None:
        """Remember other files written into the folder (figures), so --overwrite removes them too."""
        names = set(self.manifest.get("files", [])) | {Path(p).name for p in paths}
        self.manifest["files"] = sorted(names)
        self._save()

    def remove(self) -> None:
        """Delete the files a sweep writes (parts, temporaries, manifest, recorded figures), nothing else."""
        old = {}
        with contextlib.suppress(ResultError):
            old = self.read_manifest() or {}
        extra = [self.path / name for name in old.get("files", []) if "/" not in name]
        for f in [*self.parts(), *self.path.glob(".part-*.tmp"), self.path / MANIFEST, *extra]:
            f.unlink(missing_ok=True)


def _short(value: Any) -> str:
    text = json.dumps(value, default=str)
    return text if len(text) <= 60 else text[:57] + "..."


def parts(out: str | Path) -> list[Path]:
    """The part files of a result folder, in chunk order."""
    return ResultFolder(out).parts()


def load(path: str | Path, columns: list[str] | None = None, verify: bool = True) -> pd.DataFrame:
    """All rows of a sweep result folder (or one Parquet file) as a DataFrame, by variant.

    Every part is checked against the manifest first (`verify`); a bad one raises ResultError
    naming it and what to do. `columns`: read only these (and `variant`)."""
    path = Path(path)
    if path.is_dir():
        folder = ResultFolder(path)
        files = folder.parts()
        if not files:
            raise ResultError(f"{path}: no part-*.parquet files (not a sweep result, or nothing finished yet)")
        if verify and "parts" in (folder.read_manifest() or {}):  # older results recorded no checksums
            _, bad = folder.verify()
            if bad:
                name, why = next(iter(bad.items()))
                more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
                raise ResultError(f"{path / name}: {why}{more}; run the sweep again with --resume to recompute it")
    elif path.is_file():
        files = [path]
    else:
        raise ResultError(f"{path}: not found")
    frames = []
    for f in files:
        try:
            frames.append(pd.read_parquet(f, columns=None if columns is None else ["variant", *columns]))
        except (pa.ArrowException, OSError) as err:
            raise ResultError(
                f"{f}: not a readable Parquet file ({str(err).splitlines()[0]}); "
                "run the sweep again with --resume to recompute it"
            ) from None
    frame = pd.concat(frames, ignore_index=True)
    return frame.sort_values("variant").reset_index(drop=True) if "variant" in frame else frame


def _first_file(path: str | Path) -> Path:
    """A result's first part file (its schema and metadata stand for all), or the file itself."""
    path = Path(path)
    if not path.is_dir():
        return path
    files = parts(path)
    if not files:
        raise ResultError(f"{path}: no part-*.parquet files (not a sweep result, or nothing finished yet)")
    return files[0]


def metadata(path: str | Path) -> dict[str, Any]:
    """The batchveh file metadata of a result (spec, versions, device, timings)."""
    return json.loads(pq.read_schema(_first_file(path)).metadata[b"batchveh"])


def units(path: str | Path) -> dict[str, str]:
    """Column name -> unit, from the Arrow field metadata."""
    return {fl.name: fl.metadata[b"unit"].decode() for fl in pq.read_schema(_first_file(path))}
