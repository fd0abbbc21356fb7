"""Durable results (issue 62): what a kill or a power cut leaves in a result folder, and `--resume` alone back to the
uninterrupted run's rows, bit for bit, re-running only the chunks that were in flight or torn.

The fast harness kills a sweep of 3 one-variant chunks deterministically: `write_atomic`, through which every part and
manifest is written, is replaced by one that at a chosen write leaves what a kill there leaves (nothing, the whole
temporary, or the file renamed into place) and then raises, it and every write after it, as a killed process writes
nothing more. The sweep's writes come in a fixed order on its writer thread: the manifest when the folder is opened,
then for each chunk its part and the manifest recording it. Then the file written last is torn as a power cut leaves
a file renamed before its data reached the disk: zero bytes, cut to half, or a stale temporary. The slow test kills a
real `python -m batchveh.sweep` with SIGKILL at random points.
"""

import os
import posixpath
import random
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import yaml

import batchveh
from batchveh.config import ConfigError
from batchveh.sweep import main, run_sweep
from batchveh.sweeping import results, storage
from batchveh.sweeping.chunks import ChunkRunner
from batchveh.sweeping.results import ResultFolder
from batchveh.sweeping.spec import load_spec

CHUNKS = 3
KILLS = 5  # the slow test's
PARTS = [results.PART.format(c) for c in range(CHUNKS)]


def _spec(tmp_path: Path, name: str = "d", slopes=(0, 5, 10)) -> Path:
    """A sweep of one variant per slope, short (0.05 s settling, 0.2 s at 5 ms steps) on MuJoCo C."""
    raw = {
        "name": name,
        "scenario": {"kind": "straight_line", "settle_time": 0.05, "time_step": 0.005},
        "fixed": {"total_time": 0.2, "ramp_time": 0.05},
        "sweep": {"method": "grid", "params": {"slope_deg": list(slopes)}},
        "backend": "mujoco",
        "output": str(tmp_path / name),
    }
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """(spec path, the uninterrupted run's folder, its rows, {part: checksum of its data})."""
    tmp = tmp_path_factory.mktemp("durable")
    path = _spec(tmp)
    out = tmp / "full"
    run_sweep(load_spec(path), out=out, chunk_size=1, progress=False)
    return path, out, batchveh.load(out), _data_sums(out)


def _data_sums(out: Path) -> dict[str, str]:
    return {p.name: storage.table_sha256(pq.read_table(p)) for p in sorted(out.glob("part-*.parquet"))}


class Killed(BaseException):
    """The sweep process killed: raised by every write from the kill on (not an Exception: nothing catches it)."""


class Kill:
    """Stands in for results.write_atomic: at the `at`-th write of the file `name` it leaves what a kill there
    leaves, `how`: 'nothing' (killed before the write began), 'temporary' (the temporary written whole, killed
    before the rename) or 'renamed' (the write done, killed right after); then it raises Killed, as does every write
    after. `reached`: the chunks whose part's write began before or at the kill; `last`: the file written last."""

    def __init__(self, name: str, at: int, how: str):
        self.name, self.at, self.how = name, at, how
        self.seen: dict[str, int] = {}
        self.killed = False
        self.reached: set[int] = set()
        self.last: str | None = None

    def __call__(self, fs, path, data):
        if self.killed:
            raise Killed
        name = posixpath.basename(path)
        if name.startswith("part-"):
            self.reached.add(int(name[5:10]))
        self.seen[name] = self.seen.get(name, 0) + 1
        if (name, self.seen[name]) != (self.name, self.at):
            storage.write_atomic(fs, path, data)
            self.last = path
            return
        self.killed = True
        if self.how == "temporary":
            self.last = storage.temporary_name(path)
            with open(self.last, "wb") as f:
                f.write(memoryview(data))
        elif self.how == "renamed":
            storage.write_atomic(fs, path, data)
            self.last = path
        raise Killed


def _tear(path: Path, how: str) -> None:
    """What a power cut leaves of a file renamed (or written) before its data reached the disk."""
    data = path.read_bytes()
    if how == "zero":
        path.write_bytes(b"")
    elif how == "half":
        path.write_bytes(data[: len(data) // 2])
    elif how == "changed":  # a whole Parquet file, its own record kept, one value changed: fails its checksum
        table = pq.read_table(path)
        i = table.schema.get_field_index("final_x")
        x = table.column(i).to_pylist()
        x[0] = x[0] + 1e-9
        pq.write_table(table.set_column(i, table.schema.field(i), pa.array(x, pa.float64())), path)
    elif how == "gone":
        path.unlink()
    else:
        raise ValueError(how)


@pytest.fixture
def chunks_run(monkeypatch):
    """The chunks simulated, in order, by every sweep of the test."""
    ran: list[int] = []
    finish = ChunkRunner.finish

    def spy(self, prepared):
        ran.append(prepared[0])
        return finish(self, prepared)

    monkeypatch.setattr(ChunkRunner, "finish", spy)
    return ran


# (case, the write killed: (file, its n-th write, how), tears: [(file or 'last', how)], chunks in flight or torn
# that must run again). The manifest is written once when the folder opens, then once per chunk: its 3rd write
# records part 1. A kill right after that write leaves what a kill between chunks 1 and 2 leaves.
P0, P1, P2, M = "part-00000.parquet", "part-00001.parquet", "part-00002.parquet", "manifest.json"
CASES = [
    ("part1 temporary whole, killed before its rename", (P1, 1, "temporary"), [], {1}),
    ("part1 temporary cut to half", (P1, 1, "temporary"), [("last", "half")], {1}),
    ("part1 temporary zeroed", (P1, 1, "temporary"), [("last", "zero")], {1}),
    ("part1 renamed, killed before the manifest's write", (M, 3, "nothing"), [], set()),
    ("part1 renamed, then zeroed", (M, 3, "nothing"), [(P1, "zero")], {1}),
    ("part1 renamed, then cut to half", (M, 3, "nothing"), [(P1, "half")], {1}),
    ("manifest temporary cut to half, killed before its rename", (M, 3, "temporary"), [("last", "half")], set()),
    ("manifest renamed, then cut to half", (M, 3, "renamed"), [(M, "half")], set()),
    ("between chunks 1 and 2", (P2, 1, "nothing"), [], {2}),
    ("between chunks, manifest zeroed", (P2, 1, "nothing"), [(M, "zero")], {2}),
    ("between chunks, manifest lost", (P2, 1, "nothing"), [(M, "gone")], {2}),
    ("between chunks, manifest zeroed and part1 cut to half", (P2, 1, "nothing"), [(M, "zero"), (P1, "half")], {1, 2}),
    ("the first manifest zeroed, part0 in flight", (P0, 1, "nothing"), [(M, "zero")], {0}),
    ("between chunks, part0 changed (fails its checksum)", (P2, 1, "nothing"), [(P0, "changed")], {0, 2}),
    ("between chunks, manifest zeroed and part0 changed", (P2, 1, "nothing"), [(M, "zero"), (P0, "changed")], {0, 2}),
]


@pytest.mark.parametrize("case, kill, tears, rerun", CASES, ids=[re.sub(r"\W+", "-", c[0]).strip("-") for c in CASES])
def test_killed_then_torn_resumes_to_the_uninterrupted_rows(
    reference, tmp_path, monkeypatch, chunks_run, case, kill, tears, rerun
):
    path, _, full, sums = reference
    spec, out = load_spec(path), tmp_path / "out"
    cut = Kill(*kill)
    with monkeypatch.context() as m, pytest.raises(Killed):  # the next process writes as ever
        m.setattr(results, "write_atomic", cut)
        run_sweep(spec, out=out, chunk_size=1, progress=False)
    assert cut.killed
    for name, how in tears:
        _tear(Path(cut.last) if name == "last" else out / name, how)
    # the chunks the killed run never began to write run now, and of the others only those in flight or torn
    assert rerun <= cut.reached
    expect = sorted(rerun | (set(range(CHUNKS)) - cut.reached))
    del chunks_run[:]
    notes: list[str] = []
    summary = run_sweep(spec, out=out, chunk_size=1, progress=False, resume=True, report=notes.append)
    assert sorted(chunks_run) == expect, (case, notes)
    assert summary["ran"] == len(expect) and summary["rows"] == CHUNKS
    pd.testing.assert_frame_equal(batchveh.load(out), full, check_exact=True)
    assert _data_sums(out) == sums  # every part's values, bit for bit
    assert sorted(ResultFolder(out).read_manifest()["parts"]) == PARTS
    assert not [p.name for p in out.iterdir() if p.name.endswith(".tmp")]  # stale temporaries removed
    damaged = any(name == "manifest.json" and how != "gone" for name, how in tears)
    assert any("manifest.json: damaged" in n and "rebuilt" in n for n in notes) == damaged, notes


def test_the_command_line_resumes_over_a_torn_manifest(reference, tmp_path, capsys):
    """`python -m batchveh.sweep ... --resume` over a manifest cut to half: exit 0, one note, no --overwrite asked."""
    path, full_out, full, _ = reference
    out = tmp_path / "cli"
    argv = [str(path), "--chunk-size", "1", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    (out / P2).unlink()
    _tear(out / "manifest.json", "half")
    with pytest.raises(batchveh.ResultError, match=r"manifest.json: damaged .*--resume to rebuild"):
        batchveh.load(out)
    capsys.readouterr()
    assert main(argv) == 3  # results there: --resume or --overwrite, as ever
    capsys.readouterr()
    assert main([*argv, "--resume"]) == 0
    err = capsys.readouterr().err
    assert "manifest.json: damaged (not JSON: torn); rebuilt from the 2 whole parts" in err and "--overwrite" not in err
    pd.testing.assert_frame_equal(batchveh.load(out), full, check_exact=True)


def test_a_valid_manifest_of_other_settings_still_refuses(reference, tmp_path):
    path, full_out, _, _ = reference
    out = tmp_path / "other"
    run_sweep(load_spec(path), out=out, chunk_size=1, progress=False, limit=2)
    before = sorted(p.name for p in out.iterdir())
    with pytest.raises(ConfigError, match=r"another n_variants \(2, now 3\)"):
        run_sweep(load_spec(path), out=out, chunk_size=1, progress=False, resume=True)
    # and with that manifest torn, the whole parts of the other settings refuse the same way: nothing removed
    _tear(out / "manifest.json", "zero")
    with pytest.raises(ConfigError, match=r"another n_variants \(2, now 3\) \(as part-00000.parquet records\)"):
        run_sweep(load_spec(path), out=out, chunk_size=1, progress=False, resume=True)
    assert sorted(p.name for p in out.iterdir()) == before


def test_each_part_carries_what_the_manifest_says_of_it(reference):
    _, out, _, sums = reference
    folder = ResultFolder(out)
    manifest = folder.read_manifest()
    for c, name in enumerate(PARTS):
        own, why = folder.own_record(name)
        assert why == "" and own["chunk"] == c and own["first_variant"] == c and own["variants"] == 1
        assert own["digest"] == results.manifest_digest(manifest) and own["settings"] == results.settings(manifest)
        rec = manifest["parts"][name]
        assert own["data_sha256"] == rec["data_sha256"] == sums[name] and rec["first_variant"] == c
        assert rec["rows"] == 1 and rec["bytes"] == (out / name).stat().st_size  # the keys older readers know
        assert rec["sha256"] == storage.file_sha256(folder.fs, str(out / name))


def test_write_atomic_syncs_the_file_before_its_rename_and_the_folder_after(tmp_path, monkeypatch):
    """The order a power cut needs: the data on the disk, then the name, then the name on the disk."""
    events = []
    fsync, replace = os.fsync, os.replace

    def spy_fsync(fd):
        events.append(("fsync", "folder" if os.path.isdir(f"/proc/self/fd/{fd}") else "file"))
        fsync(fd)

    def spy_replace(a, b):
        events.append(("rename", os.path.basename(b)))
        replace(a, b)

    monkeypatch.setattr(os, "fsync", spy_fsync)
    monkeypatch.setattr(os, "replace", spy_replace)
    fs, root = storage.filesystem(tmp_path)
    storage.write_atomic(fs, f"{root}/f.bin", b"data")
    assert events == [("fsync", "file"), ("rename", "f.bin"), ("fsync", "folder")]
    assert (tmp_path / "f.bin").read_bytes() == b"data" and os.listdir(tmp_path) == ["f.bin"]
    events.clear()
    with ResultFolder(tmp_path / "locked").lock():  # the holder's name, written in place, synced
        pass
    assert ("fsync", "file") in events and ("fsync", "folder") in events and ("rename", ".batchveh.lock") not in events


def test_table_checksum_survives_parquet_and_sees_every_bit(tmp_path):
    table = pa.table(
        {
            "x": pa.array([0.0, -0.0, float("nan"), 1.5], pa.float64()),
            "s": ["ok", "diverged", None, ""],
            "b": [True, False, True, None],
            "i": pa.array([1, None, 3, 4], pa.int64()),
        }
    )
    pq.write_table(table, tmp_path / "t.parquet")
    assert storage.table_sha256(pq.read_table(tmp_path / "t.parquet")) == storage.table_sha256(table)
    flipped = table.set_column(0, "x", pa.array([-0.0, -0.0, float("nan"), 1.5], pa.float64()))
    moved = table.set_column(1, "s", pa.array(["ok", "diverged", "", None]))
    assert len({storage.table_sha256(t) for t in (table, flipped, moved)}) == 3


# --- the real thing: SIGKILL at random points -------------------------------------------------------------------


@pytest.mark.slow
def test_sigkilled_at_random_points_resumes_to_the_uninterrupted_rows(tmp_path):
    """A `python -m batchveh.sweep` of 16 one-variant chunks killed with SIGKILL 5 times at random points (a random
    count of parts written, then a random delay inside the next chunk's simulation and writes), one of the two files
    written last (a part, the manifest or a temporary) torn at random after each kill as a power cut leaves it, each
    time resumed with --resume alone (killed again, the last time run to the end): the uninterrupted run's rows, bit
    for bit, and a part found whole before a resume is never written again."""
    rng = random.Random(62)
    n = 16
    path = _spec(tmp_path, "k", slopes=range(0, 2 * n, 2))
    full = tmp_path / "full"
    run_sweep(load_spec(path), out=full, chunk_size=1, progress=False)
    out = tmp_path / "killed"
    cmd = [sys.executable, "-m", "batchveh.sweep", str(path), "--chunk-size", "1", "--out", str(out), "--quiet"]
    log = []
    for round_ in range(KILLS + 1):
        whole = _whole_parts(out)
        present = {p.name for p in out.glob("part-*.parquet")} if out.exists() else set()
        proc = subprocess.Popen(
            cmd + ["--resume"] * (round_ > 0),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            start_new_session=True,
        )
        if round_ < KILLS:
            target = len(present) + rng.randint(1, 3)
            deadline = time.time() + 120
            while len(list(out.glob("part-*.parquet"))) < target and time.time() < deadline and proc.poll() is None:
                time.sleep(0.01)
            time.sleep(rng.uniform(0.0, 0.15))  # somewhere in the next chunk: simulating, writing its part or manifest
            os.killpg(proc.pid, signal.SIGKILL)
        _, err = proc.communicate(timeout=300)
        assert proc.returncode in ((-signal.SIGKILL, 0) if round_ < KILLS else (0,)), err.decode()
        after = _whole_parts(out)
        assert {k: v for k, v in after.items() if k in whole} == whole  # a part whole before is not written again
        entry = {
            "round": round_,
            "exit": proc.returncode,
            "torn before": sorted(present - set(whole)),
            "written": sorted(k for k in after if k not in whole),
            "notes": [line[-90:] for line in err.decode().splitlines() if line.startswith("note:")],
        }
        files = [p for p in out.iterdir() if p.name.startswith(("part-", "manifest", ".part-", ".manifest"))]
        if round_ < KILLS and files:
            last = rng.choice(sorted(files, key=lambda p: p.stat().st_mtime_ns)[-2:])  # one of the 2 written last
            entry["torn now"] = (last.name, rng.choice(["zero", "half", "keep"]))
            if entry["torn now"][1] != "keep":
                _tear(last, entry["torn now"][1])
        log.append(entry)
    print(*log, sep="\n")  # shown with -s: where each kill landed and what each resume ran
    pd.testing.assert_frame_equal(batchveh.load(out), batchveh.load(full), check_exact=True)
    assert _data_sums(out) == _data_sums(full), log
    assert not [p.name for p in out.iterdir() if p.name.endswith(".tmp")]


def _whole_parts(out: Path) -> dict[str, str]:
    """{part: its file's SHA-256} of the parts that are whole by their own record."""
    if not out.exists():
        return {}
    folder = ResultFolder(out)
    return {
        name: storage.file_sha256(folder.fs, str(out / name)) for name in folder.parts() if folder.own_record(name)[0]
    }
