"""A result folder: its manifest, its lock, its part files with checksums, and `load`.

A result folder holds `manifest.json` and `part-NNNNN.parquet` files, one per chunk.
The manifest records what a resume must match (the spec, the chunk size, the
backend) and, for every part written, its row count, size and SHA-256; a part
that is missing, unlisted or does not match is not finished, and `--resume` runs
its chunk again. Each part's Arrow fields carry `unit` and `description` metadata;
its file metadata carries the spec, the batchveh, mujoco and jax versions, the
device and the timings. Parts and the manifest are written under a temporary name,
fsynced, then renamed and the folder fsynced (`storage.write_atomic`), so a kill or a
power cut leaves either the old file or the new one.

Each part also carries, under the file metadata key `batchveh.part`, what the manifest says
of it (`seal`): its chunk, its variants (the first one's index and their count), the
manifest's settings that a resume must match and their digest, and `data_sha256`, a
checksum of the table's content (`storage.table_sha256`: the file's own SHA-256 cannot be
written inside the file). So the manifest can be lost: on `--resume`, a manifest that is
missing, empty, torn or not JSON is rebuilt from the parts whose own record matches the
sweep's settings and whose data match their checksum; a part that is torn, unreadable or
fails its checksum is removed and its chunk runs again, and so does a part listed nowhere
valid. A manifest that is valid JSON from other settings is refused, as are intact parts
from other settings: that is another sweep's folder, not a power cut.

The folder is a local path or a URI that `pyarrow.fs` understands (`s3://bucket/sweep`,
`gs://...`, `file:///...`); both are read and written through `pyarrow.fs`. On a local
file system a running sweep holds an advisory lock on `.batchveh.lock` in the folder, so
a second writer stops at once with the holder's process id and host; an object store has
no such lock, and one folder must have one sweep at a time.
"""

from __future__ import annotations

import contextlib
import fnmatch
import hashlib
import json
import os
import posixpath
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.fs as pafs
import pyarrow.parquet as pq

from batchveh.config import ConfigError
from batchveh.stepping import mission_stats, motor_stats
from batchveh.stepping.stats import CHANNELS
from batchveh.sweeping.storage import (
    file_sha256,
    filesystem,
    parquet_bytes,
    sync_folder,
    table_sha256,
    write_atomic,
)

MANIFEST = "manifest.json"
PART_KEY = b"batchveh.part"  # a part's own record, in its file metadata (`seal`)
OWN = ("parts", "files")  # what a manifest holds besides the settings a resume must match
NO_RECORD = "carries no record of its own to check it against (written by an older batchveh)"
LOCK = ".batchveh.lock"
PART = "part-{:05d}.parquet"
PART_GLOB = "part-*.parquet"


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
        "ok, diverged (NaN, inf or a huge state, or MuJoCo found the simulation unstable), flipped "
        "(roll or pitch > 60 deg), stuck (an obstacle reached but not cleared by the end of the run) or "
        "short (an obstacle never reached: too short a run)",
    ),
    "reached": ("", "the front wheels' centres ended past the obstacle's near edge (obstacle runs only)"),
    "cleared": ("", "the rear wheels' centres ended past the obstacle's far edge (obstacle runs only)"),
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
    mission = mission_stats.column_doc(name)  # '<span>_<motor>_<stat>' of a mission
    if mission is not None:
        return mission
    motor = motor_stats.column_doc(name)  # a dcmotor's electrical statistics
    if motor is not None:
        return motor
    for ch in CHANNELS:
        if name.startswith(ch + "_"):
            unit, doc = _STAT_DOC[name[len(ch) + 1 :]]
            return unit, f"{ch}: {doc}"
    return "", ""


def _temporary(name: str) -> bool:
    """A temporary of `storage.write_atomic` for a part or the manifest (left behind by a kill)."""
    return name.endswith(".tmp") and (name.startswith(".part-") or name.startswith(f".{MANIFEST}."))


def settings(manifest: dict[str, Any]) -> dict[str, Any]:
    """What of a manifest a resume must match (all but its parts and files), as JSON reads it back."""
    return json.loads(json.dumps({k: v for k, v in manifest.items() if k not in OWN}, default=str))


def manifest_digest(manifest: dict[str, Any]) -> str:
    """The SHA-256 of a manifest's settings (`settings`, keys sorted): equal settings, equal digests."""
    return hashlib.sha256(json.dumps(settings(manifest), sort_keys=True).encode()).hexdigest()


def seal(table: pa.Table, chunk: int, first: int, manifest: dict[str, Any]) -> pa.Table:
    """`table` with its own record under the file metadata key `batchveh.part`: the chunk, the first variant's
    index and the count of variants, the settings of the sweep's `manifest` and their digest. `write_file` adds
    the checksum of the table's content (`storage.table_sha256`) as it writes the part, on the writing thread
    beside the engine; a resume checks the part against it when the manifest cannot vouch for the part."""
    own = {
        "chunk": chunk,
        "first_variant": first,
        "variants": table.num_rows,
        "digest": manifest_digest(manifest),
        "settings": settings(manifest),
    }
    return table.replace_schema_metadata({**(table.schema.metadata or {}), PART_KEY: json.dumps(own).encode()})


def _checksummed(table: pa.Table) -> tuple[pa.Table, dict[str, Any] | None]:
    """(`table` with the checksum of its content added to its own record, that record), or (table, None) for a
    table that has no record of its own (not made by a sweep's chunk)."""
    raw = (table.schema.metadata or {}).get(PART_KEY)
    if raw is None:
        return table, None
    own = {**json.loads(raw), "data_sha256": table_sha256(table)}
    return table.replace_schema_metadata({**table.schema.metadata, PART_KEY: json.dumps(own).encode()}), own


def _chunk_of(name: str) -> int:
    return int(name.removesuffix(".parquet").split("-")[1])


def annotated_table(frame: pd.DataFrame, fields: dict[str, dict[str, str]], meta: dict[str, str]) -> pa.Table:
    """A frame as an Arrow table with `fields[name]` as each field's metadata and `meta` on the file. Every
    floating column is written float64, whatever the engine computed in (MJX and Warp run float32): a result's
    schema does not depend on the engine (tests/test_schema.py pins each column's type)."""
    wide = {c: "float64" for c, t in frame.dtypes.items() if pd.api.types.is_float_dtype(t)}
    table = pa.Table.from_pandas(frame.astype(wide), preserve_index=False)
    schema = pa.schema([f.with_metadata(fields.get(f.name, {})) for f in table.schema], metadata=meta)
    return table.cast(schema)


def part_table(frame: pd.DataFrame, param_units: dict[str, str], meta: dict[str, Any]) -> pa.Table:
    """A sweep chunk's rows, with unit and description on every column and `meta` on the file, with the steering
    geometry of its spec's vehicle added (`steering_metadata`, under `steering_geometry`)."""
    fields = {}
    for name in frame.columns:
        unit, doc = column_doc(name, param_units)
        fields[name] = {"unit": unit, "description": doc}
    if "spec" in meta and "steering_geometry" not in meta:
        meta = {**meta, "steering_geometry": steering_metadata(meta["spec"], frame)}
    return annotated_table(frame, fields, {"batchveh": json.dumps(meta, default=str)})


def steering_metadata(raw: Any, frame: pd.DataFrame | None = None) -> dict[str, Any] | str:
    """Where a sweep's steering hinges stand and each wheel's trail and scrub radius, m (vehicle.steering_geometry_of):
    its spec's vehicle (`raw`, the spec as read) with its fixed values, and each variant's where the part's rows
    (`frame`) sweep a key that moves them: then [least, most] over the rows. A vehicle that cannot be read back
    here (a YAML path not found from the working folder) gives a line saying so."""
    from batchveh.model.vehicle import Vehicle, hinge_xy, load_vehicle, steering_geometry_of, vehicle_from_mapping

    veh = raw.get("vehicle") if isinstance(raw, dict) else None
    try:
        if isinstance(veh, dict):
            vehicle = vehicle_from_mapping(veh, "spec: vehicle")
        elif isinstance(veh, str):
            vehicle = load_vehicle(veh)
        else:
            vehicle = Vehicle()
    except (ConfigError, OSError) as err:
        return f"not recorded: the spec's vehicle cannot be read here ({err})"
    flat: dict[str, Any] = vehicle.flat_geometry()
    fixed = (raw.get("fixed") or {}) if isinstance(raw, dict) else {}
    flat.update({k: float(v) for k, v in fixed.items() if k in flat and isinstance(v, (int, float))})
    swept = [k for k in flat if frame is not None and k in frame.columns]
    flat.update({k: frame[k].to_numpy(float) for k in swept})

    def value(x: Any) -> float | list[float]:
        x = pd.Series(x, dtype=float) if pd.api.types.is_list_like(x) else x
        if not pd.api.types.is_list_like(x):
            return round(float(x), 12)  # to 1e-12 m: 0.07, not 0.06999999999999995
        low, high = round(float(x.min()), 12), round(float(x.max()), 12)
        return low if low == high else [low, high]

    hx, hy = hinge_xy(flat)
    return {
        "hinge_x_m": value(hx),
        "hinge_y_m": value(hy),
        "hinges_from": "steering.axis_x, steering.axis_y where > 0, else the chassis corners",
        "varies_with": swept,
        **{c: {f"{k}_m": value(v) for k, v in g.items()} for c, g in steering_geometry_of(flat).items()},
    }


class ResultFolder:
    """A sweep's output folder: manifest, lock and part files, on a local disk or an object store.

    `open` checks what is there against the new manifest and returns the finished chunks;
    `write_part` writes a chunk and records it. Hold `lock()` around both. A worker of a
    cluster writes its part with `write_file` and hands the record to the driver, which owns
    the manifest (`record`)."""

    def __init__(self, location: str | Path):
        self.fs, self.root = filesystem(location)
        # where messages and `load` point: the path as given, or the URI
        self.path: Path | str = Path(location) if "://" not in str(location) else str(location).rstrip("/")
        self.manifest: dict[str, Any] = {}
        self.notes: list[str] = []  # what `open` found that the user should hear of (a manifest rebuilt)

    @property
    def shared(self) -> str:
        """The folder as other processes and nodes name it: the absolute path or the URI."""
        return self.path if isinstance(self.path, str) else self.root

    def where(self, name: str) -> str:
        """A file of the folder, named for a message."""
        return str(self.path / name) if isinstance(self.path, Path) else f"{self.path}/{name}"

    def _file(self, name: str) -> str:
        return posixpath.join(self.root, name)

    def _listing(self) -> list[pafs.FileInfo]:
        if self.fs.get_file_info(self.root).type != pafs.FileType.Directory:
            return []
        return self.fs.get_file_info(pafs.FileSelector(self.root, allow_not_found=True))

    def parts(self) -> list[str]:
        """The part files' names, in chunk order."""
        infos = self._listing()
        return sorted(
            f.base_name for f in infos if f.type == pafs.FileType.File and fnmatch.fnmatchcase(f.base_name, PART_GLOB)
        )

    def read_manifest(self) -> dict[str, Any] | None:
        """The manifest, or None where there is none; ResultError where it is damaged (a power cut's)."""
        manifest, damage = self._manifest()
        if damage is not None:
            raise ResultError(
                f"{self.where(MANIFEST)}: {damage}; run the sweep again with --resume to rebuild it from the parts"
            )
        return manifest

    def _manifest(self) -> tuple[dict[str, Any] | None, str | None]:
        """(the manifest or None, what is wrong with it or None). Damaged: empty, torn (not JSON, or JSON that
        is not an object), as a power cut leaves a file renamed before its data reached the disk."""
        f = self._file(MANIFEST)
        if self.fs.get_file_info(f).type != pafs.FileType.File:
            return None, None
        with self.fs.open_input_stream(f) as stream:
            data = stream.read()
        if not data.strip(b"\0 \n"):
            return None, f"damaged ({'empty' if not data else 'zeroed'})"
        try:
            manifest = json.loads(data)
        except (json.JSONDecodeError, UnicodeDecodeError):
            return None, "damaged (not JSON: torn)"
        if not isinstance(manifest, dict):
            return None, "damaged (JSON, but not an object)"
        return manifest, None

    def own_record(self, name: str) -> tuple[dict[str, Any] | None, str]:
        """(part `name`'s own record (`seal`), '') where the part is whole: readable, its record there and
        for its own chunk, and its data matching their checksum; else (None, what is wrong)."""
        path = self._file(name)
        try:
            schema = pq.read_schema(path, filesystem=self.fs)
        except Exception as err:  # noqa: BLE001 - a torn file raises whatever its bytes lead the reader to
            return None, f"torn or not Parquet ({str(err).splitlines()[0] if str(err) else type(err).__name__})"
        raw = (schema.metadata or {}).get(PART_KEY)
        if raw is None:
            return None, NO_RECORD
        try:
            own = json.loads(raw)
            table = pq.read_table(path, filesystem=self.fs)
        except Exception as err:  # noqa: BLE001
            return None, f"unreadable ({str(err).splitlines()[0] if str(err) else type(err).__name__})"
        if own.get("chunk") != _chunk_of(name) or own.get("variants") != table.num_rows:
            return None, f"its own record (chunk {own.get('chunk')}, {own.get('variants')} variants) does not fit"
        if table_sha256(table) != own.get("data_sha256"):
            return None, "its data differ from the checksum it carries (damaged after it was written)"
        return own, ""

    @contextlib.contextmanager
    def lock(self) -> Iterator[None]:
        """Hold the folder's advisory lock; raise Locked naming the holder if another process has it.
        On an object store there is no lock to take: the folder is created, nothing is locked.

        The lock is a kernel lock (flock) on the file `.batchveh.lock`, which is created once and never
        replaced: a file renamed over it would be a new file, which a second writer could lock while the
        first holds the old one. So the holder's name is written into it in place, then fsynced, and the
        folder fsynced where the file was created. A power cut releases the lock with its holder; what it
        leaves in the file (the name, or nothing) is only the message a blocked writer shows."""
        import fcntl

        self._check_folder()
        self.fs.create_dir(self.root, recursive=True)
        if not isinstance(self.fs, pafs.LocalFileSystem):
            yield
            return
        path = self._file(LOCK)
        created = not os.path.exists(path)
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 200, 0).decode(errors="replace").strip("\0 \n") or "another process"
                raise Locked(f"{self.path} is being written by {holder}; wait for it, or use another --out") from None
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()}".encode(), 0)
            os.fsync(fd)
            if created:
                sync_folder(self.root)
            yield
        finally:
            os.close(fd)  # closing releases the lock

    def _check_folder(self) -> None:
        p = self.root
        while p not in ("", "/", "."):
            if self.fs.get_file_info(p).type == pafs.FileType.File:
                raise ConfigError(f"{self.path}: {p} exists and is not a folder; allowed: a folder for the results")
            p = posixpath.dirname(p)

    def _matches(self, name: str, rec: dict[str, Any]) -> str:
        """'' where part `name` is the file the manifest's record `rec` describes, else what differs."""
        size = self.fs.get_file_info(self._file(name)).size
        if size != rec.get("bytes"):
            return f"{size} bytes where {rec.get('bytes')} were written (truncated or changed)"
        if file_sha256(self.fs, self._file(name)) != rec.get("sha256"):
            return "checksum differs from the one recorded (the file changed after it was written)"
        return ""

    def verify(self) -> tuple[set[int], dict[str, str]]:
        """(finished chunks, {part name: what is wrong}) against the manifest's records. Without a manifest,
        the parts that carry their own record are checked against it (`own_record`)."""
        manifest = self.read_manifest()
        records = (manifest or {}).get("parts", {})
        done, bad = set(), {}
        for name in self.parts():
            rec = records.get(name)
            if manifest is None:
                why = self.own_record(name)[1]
            elif rec is None:
                why = "not in the manifest (written by a run that was killed before recording it)"
            else:
                why = self._matches(name, rec)
            if why:
                bad[name] = why
            else:
                done.add(_chunk_of(name))
        return done, bad

    def refuse_existing(self, *, resume: bool, overwrite: bool) -> None:
        """FileExistsError where results are there and neither resume nor overwrite is given."""
        there = self.parts() or self.fs.get_file_info(self._file(MANIFEST)).type == pafs.FileType.File
        if not resume and not overwrite and there:
            raise FileExistsError(
                f"{self.path} holds results; give --resume to continue or --overwrite to replace them"
            )

    def resume_chunk_size(self) -> int | None:
        """The chunk size the results there were made with: the manifest's, or where it is missing or damaged
        the one the first whole part records; None where neither says."""
        manifest, _ = self._manifest()
        if manifest is not None:
            return manifest.get("chunk_size")
        for name in self.parts():
            own = self.own_record(name)[0]
            if own is not None:
                return own["settings"].get("chunk_size")
        return None

    def open(self, manifest: dict[str, Any], *, resume: bool, overwrite: bool) -> tuple[set[int], dict[str, str]]:
        """Start or resume: returns (finished chunks, bad parts removed for a rerun), and leaves in `notes`
        what the user should hear of (a manifest rebuilt).

        On resume, a part counts as finished where the manifest's record of it matches the file, or else where
        the part's own record (`seal`) has this sweep's settings and its data match their checksum (a part
        renamed into place before the manifest recorded it, or a manifest lost). A manifest that is missing,
        empty or torn is rebuilt from those parts; the other parts are removed, with the stale temporaries of
        killed writers. Raises FileExistsError where results exist and neither resume nor overwrite is given,
        and ConfigError where they come from another spec or setting (a valid manifest, or whole parts, of
        other settings)."""
        self._check_folder()
        self.refuse_existing(resume=resume, overwrite=overwrite)
        self.notes = []
        if overwrite:
            self.remove()
        ours = settings(manifest)
        digest = manifest_digest(manifest)
        done, bad, kept = set(), {}, {}
        if resume:
            old, damage = self._manifest()
            if old is not None:
                self._refuse_other(old, ours)
                if "files" in old:  # figures and analyses written beside the parts: --overwrite still removes them
                    manifest = {**manifest, "files": old["files"]}
            records = (old or {}).get("parts", {})
            for name in self.parts():
                rec = records.get(name)
                why = self._matches(name, rec) if rec is not None else "not in the manifest"
                if not why:
                    kept[name] = rec
                    continue
                own, why_own = self.own_record(name)
                if own is None:
                    bad[name] = why if rec is not None else why_own
                elif own["digest"] != digest:
                    if old is None:  # whole parts of other settings, their manifest lost: another sweep's folder
                        self._refuse_other(own["settings"], ours, name)
                    bad[name] = "made with other settings than the manifest's"
                else:
                    kept[name] = self._record_of(name, own)
            if damage is not None or (old is None and kept):
                k = len(kept)
                self.notes.append(
                    f"{self.where(MANIFEST)}: {damage or 'missing'}; rebuilt from the {k} whole part{'s' * (k != 1)} "
                    "of these settings"
                )
            for name in bad:
                self.fs.delete_file(self._file(name))
            done = {_chunk_of(name) for name in kept}
        self.remove_temporaries()
        self.manifest = {**manifest, "parts": kept}
        self.fs.create_dir(self.root, recursive=True)
        self._save()
        return done, bad

    def _refuse_other(self, theirs: dict[str, Any], ours: dict[str, Any], part: str | None = None) -> None:
        """ConfigError naming the first setting in which `theirs` (the manifest's, or a part's own) differs."""
        differ = [k for k in ours if theirs.get(k) != ours[k]]
        if differ:
            k = differ[0]
            said = f" (as {part} records)" if part else ""
            raise ConfigError(
                f"{self.path}: the results there were made with another {k} ({_short(theirs.get(k))}, now "
                f"{_short(ours[k])}){said}; resume with the same settings, or give --overwrite to replace them"
            )

    def _record_of(self, name: str, own: dict[str, Any]) -> dict[str, Any]:
        """The manifest's record of a whole part, rebuilt from the file and its own record."""
        return {
            "rows": own["variants"],
            "bytes": self.fs.get_file_info(self._file(name)).size,
            "sha256": file_sha256(self.fs, self._file(name)),
            "first_variant": own["first_variant"],
            "data_sha256": own["data_sha256"],
        }

    def remove_temporaries(self) -> None:
        """Delete the temporaries of writers that were killed (call it while no writer runs)."""
        for f in self._listing():
            if _temporary(f.base_name):
                self.fs.delete_file(f.path)

    def _save(self) -> None:
        text = json.dumps(self.manifest, indent=1, default=str)
        write_atomic(self.fs, self._file(MANIFEST), text.encode())

    def write_file(self, chunk: int, table: pa.Table) -> tuple[str, dict[str, Any]]:
        """Write chunk's part atomically and durably, the checksum of its content added to its own record
        (`seal`); return (its name, its record: rows, bytes, SHA-256, and from its own record its first
        variant and the checksum of its data). The file's checksum is of the bytes written, so it needs no
        second read of the file."""
        name = PART.format(chunk)
        table, own = _checksummed(table)
        data = parquet_bytes(table)
        write_atomic(self.fs, self._file(name), data)
        rec = {"rows": table.num_rows, "bytes": data.size, "sha256": hashlib.sha256(data).hexdigest()}
        if own is not None:
            rec.update(first_variant=own["first_variant"], data_sha256=own["data_sha256"])
        return name, rec

    def record(self, name: str, rec: dict[str, Any]) -> None:
        """Enter a written part in the manifest, and save it."""
        self.manifest["parts"][name] = rec
        self._save()

    def write_part(self, chunk: int, table: pa.Table) -> None:
        """Write chunk's table atomically, then record its size and checksum in the manifest."""
        self.record(*self.write_file(chunk, table))

    def record_files(self, paths: list[Path]) -> None:
        """Remember other files written into the folder (figures), so --overwrite removes them too."""
        names = set(self.manifest.get("files", [])) | {Path(p).name for p in paths}
        self.manifest["files"] = sorted(names)
        self._save()

    def add_files(self, files: dict[str, bytes]) -> list[str]:
        """Write files derived from the parts (an analysis) into the folder, atomically, and record them in
        its manifest where it has one, so that --overwrite removes them too; returns where they are.
        Hold `lock()` around it."""
        self.manifest = self.read_manifest() or {}
        for name, data in files.items():
            write_atomic(self.fs, self._file(name), data)
        if self.manifest:
            self.record_files([Path(name) for name in files])
        return [self.where(name) for name in files]

    def remove(self) -> None:
        """Delete the files a sweep writes (parts, temporaries, manifest, recorded figures), nothing else."""
        old = {}
        with contextlib.suppress(ResultError):
            old = self.read_manifest() or {}
        ours = {*self.parts(), MANIFEST, *(name for name in old.get("files", []) if "/" not in name)}
        for f in self._listing():
            if f.type == pafs.FileType.File and (f.base_name in ours or _temporary(f.base_name)):
                self.fs.delete_file(f.path)


def _short(value: Any) -> str:
    text = json.dumps(value, default=str)
    return text if len(text) <= 60 else text[:57] + "..."


def parts(out: str | Path) -> list[Path] | list[str]:
    """The part files of a result folder, in chunk order (paths, or URIs on an object store)."""
    folder = ResultFolder(out)
    return [folder.path / n if isinstance(folder.path, Path) else folder.where(n) for n in folder.parts()]


def _files(folder: ResultFolder) -> list[tuple[str, str]]:
    """[(path on the folder's file system, name for messages)] of its parts, or of the one file it names."""
    kind = folder.fs.get_file_info(folder.root).type
    if kind == pafs.FileType.File:
        return [(folder.root, str(folder.path))]
    if kind != pafs.FileType.Directory:
        raise ResultError(f"{folder.path}: not found")
    names = folder.parts()
    if not names:
        raise ResultError(f"{folder.path}: no part-*.parquet files (not a sweep result, or nothing finished yet)")
    return [(folder._file(n), folder.where(n)) for n in names]


def load(path: str | Path, columns: list[str] | None = None, verify: bool = True) -> pd.DataFrame:
    """All rows of a sweep result folder (or one Parquet file) as a DataFrame, by variant.

    `path`: a local path or a URI pyarrow.fs understands (s3://...). Every part is checked
    against the manifest first (`verify`), or where the manifest is missing against its own record;
    a bad one, or a damaged manifest, raises ResultError naming it and what to do. `columns`: read
    only these (and `variant`)."""
    folder = ResultFolder(path)
    files = _files(folder)
    manifest = folder.read_manifest() if verify and files[0][0] != folder.root else {}
    if manifest is None or "parts" in manifest:  # results from before the checksums have nothing to check against
        _, bad = folder.verify()  # without a manifest, against each part's own record where it carries one
        bad = {name: why for name, why in bad.items() if why != NO_RECORD}
        if bad:
            name, why = next(iter(bad.items()))
            more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
            raise ResultError(f"{folder.where(name)}: {why}{more}; run the sweep again with --resume to recompute it")
    frames = []
    for f, shown in files:
        try:
            frames.append(
                pd.read_parquet(f, columns=None if columns is None else ["variant", *columns], filesystem=folder.fs)
            )
        except (pa.ArrowException, OSError) as err:
            raise ResultError(
                f"{shown}: not a readable Parquet file ({str(err).splitlines()[0]}); "
                "run the sweep again with --resume to recompute it"
            ) from None
    frame = pd.concat(frames, ignore_index=True)
    return frame.sort_values("variant").reset_index(drop=True) if "variant" in frame else frame


def _first_schema(path: str | Path) -> pa.Schema:
    """The schema of a result's first part (its fields and metadata stand for all), or of the file."""
    folder = ResultFolder(path)
    return pq.read_schema(_files(folder)[0][0], filesystem=folder.fs)


def metadata(path: str | Path) -> dict[str, Any]:
    """The batchveh file metadata of a result (spec, versions, device, timings)."""
    return json.loads(_first_schema(path).metadata[b"batchveh"])


def units(path: str | Path) -> dict[str, str]:
    """Column name -> unit, from the Arrow field metadata."""
    return {fl.name: fl.metadata[b"unit"].decode() for fl in _first_schema(path)}
