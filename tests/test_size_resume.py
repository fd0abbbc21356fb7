"""A size session killed in its loop and run again (issue 62): `python -m batchveh.size` SIGKILLed once a run in
its loop has written a part, the part written last torn as a power cut leaves it, then the same command again
(no --overwrite, no --resume: the report does not exist yet) ends with the uninterrupted session's report, and
only the chunks not written whole before run again."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

import batchveh

ROOT = Path(__file__).resolve().parent.parent
SPEC = ROOT / "sweeps" / "delivery_robot.yaml"
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
LIMIT = 12  # variants: the first of the robot's LHS
TIMEOUT_S = 600


def _command(spec: Path, out: Path) -> list[str]:
    return [
        sys.executable,
        "-m",
        "batchveh.size",
        str(spec),
        "--catalogue",
        str(CATALOGUE),
        "--limit",
        str(LIMIT),
        "--out",
        str(out),
        "--quiet",
    ]


def _parts(out: Path) -> dict[str, int]:
    """{folder/part: its file's mtime in ns} of every part of the servo sweep and the loop's runs."""
    found = [*out.glob("servo/part-*.parquet"), *out.glob("loop/*/part-*.parquet")]
    return {str(p.relative_to(out)): p.stat().st_mtime_ns for p in sorted(found)}


def _run(cmd: list[str]) -> subprocess.CompletedProcess:
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT_S, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    return done


@pytest.mark.slow
@pytest.mark.parametrize("chunk", [None, 4], ids=["as shipped", "chunks of 4"])
def test_a_size_session_killed_in_its_loop_and_run_again_ends_with_the_uninterrupted_report(tmp_path, chunk):
    """As shipped, each sweep of the session (the servo's, the loop's run) is one chunk; in chunks of 4 (the spec's
    chunk_size) the servo sweep has 3 and the loop's run several, and the kill lands among them."""
    spec = SPEC
    if chunk is not None:
        spec = tmp_path / SPEC.name
        spec.write_text(SPEC.read_text() + f"chunk_size: {chunk}\n")
    full, killed = tmp_path / "full", tmp_path / "killed"
    _run(_command(spec, full))
    expected = _parts(full)
    assert any(k.startswith("loop/") for k in expected), expected

    # killed once the loop has written a part (polled every 5 ms: the kill lands in the loop's next chunk or in
    # the writes after the part)
    proc = subprocess.Popen(
        _command(spec, killed), cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True
    )
    deadline = time.time() + TIMEOUT_S
    while not list(killed.glob("loop/*/part-*.parquet")) and proc.poll() is None and time.time() < deadline:
        time.sleep(0.005)
    os.killpg(proc.pid, signal.SIGKILL)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL, err.decode()
    assert not (killed / "sizing.json").exists() and not (killed / "report.md").exists()

    # the part written last torn: renamed into place, its data never reached the disk (zero bytes)
    before = _parts(killed)
    last = max(before, key=before.get)
    (killed / last).write_bytes(b"")
    whole = {k: v for k, v in before.items() if k != last}
    assert any(k.startswith("loop/") for k in before)

    _run(_command(spec, killed))  # the same command: no --overwrite, no --resume
    after = _parts(killed)
    assert set(after) == set(expected)  # every chunk of the uninterrupted session, in the same folders
    assert {k: after[k] for k in whole} == whole  # a part whole before the second run is not written again
    rerun = sorted(k for k in after if k not in whole)  # the torn part and the chunks not written before the kill
    assert last in rerun and len(rerun) == len(expected) - len(whole)
    print(
        f"chunk size {chunk}: killed with {len(before)} of {len(expected)} parts written ({last} torn); "
        f"the second run wrote {len(rerun)}: {rerun}; {len(whole)} kept"
    )

    got, want = (json.loads((d / "sizing.json").read_text()) for d in (killed, full))
    assert got["chosen"] == want["chosen"] and got["chosen"] is not None
    assert len(got["loop"]) == len(want["loop"])
    pairs = zip(got["loop"], want["loop"], strict=True)
    differ = [(r["motor"], k, r[k], w.get(k)) for r, w in pairs for k in r if r[k] != w.get(k)]
    assert not differ, differ
    pd.testing.assert_frame_equal(
        pd.read_parquet(killed / "verdicts.parquet"), pd.read_parquet(full / "verdicts.parquet"), check_exact=True
    )
    for folder in {str(Path(k).parent) for k in expected}:  # each sweep's rows, bit for bit
        pd.testing.assert_frame_equal(
            batchveh.load(killed / folder), batchveh.load(full / folder), check_exact=True, obj=folder
        )
