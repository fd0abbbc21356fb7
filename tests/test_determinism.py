"""Each variant's result is its own (issue 62): bit for bit the same whichever variants share its chunk or its part
of a chunk, and whichever chunk is prepared beside it.

The size command's resume (tests/test_size_resume.py, slow) compares a session that ran some chunks again with an
uninterrupted one. Its chunks of 4 differed now and then in the last digits: a sweep prepared its first chunk on
the sweep's thread while the next was prepared ahead on the pipeline's, and both used the one `mujoco.batch.Batch`
that `stepping.fields.set_const` keeps per vehicle, so a chunk's mj_setConst outputs (dof_M0, body_invweight0, ...)
could be the other chunk's, and its physics with them. Here the two calls are made to meet at a barrier inside
`Batch.set_const`, after each has written its inputs, wherever they run at once: where they do, rows differ.
"""

import threading
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from mujoco.batch import Batch

import batchveh
import batchveh.engines.mujoco as mujoco_engine
from batchveh.engines import make_engine
from batchveh.stepping.batch import apply_solver, make_batch
from batchveh.sweep import run_sweep
from batchveh.sweeping.spec import load_spec

MEET_S = 1.5  # how long a set_const call waits for a second one (a prepared chunk alone waits this once)


def _spec(tmp_path: Path) -> Path:
    """4 variants whose payload (a structural parameter: mj_setConst per variant) and slope differ, 0.2 s each."""
    raw = {
        "name": "det",
        "scenario": {"kind": "straight_line", "settle_time": 0.05, "time_step": 0.005},
        "fixed": {"total_time": 0.2, "ramp_time": 0.05},
        "sweep": {"method": "zip", "params": {"payload.mass": [0.0, 30.0, 5.0, 60.0], "slope_deg": [0, 8, 3, 12]}},
        "backend": "mujoco",
        "output": str(tmp_path / "det"),
    }
    path = tmp_path / "det.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def _calls_meet(monkeypatch) -> list[bool]:
    """Batch.set_const's first call from now on waits (up to MEET_S) for a second: two chunks prepared at once
    then both have written their inputs before either computes. Returns a list that holds True once two met."""
    barrier = threading.Barrier(2, timeout=MEET_S)
    met: list[bool] = []
    original = Batch.set_const

    def meeting(self, *args, **kwargs):
        try:
            barrier.wait()
            met.append(True)
        except threading.BrokenBarrierError:  # alone: chunks prepared one at a time
            pass
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Batch, "set_const", meeting)
    return met


def test_a_chunks_rows_do_not_depend_on_the_chunk_prepared_beside_it(tmp_path, monkeypatch):
    spec = load_spec(_spec(tmp_path))
    run_sweep(spec, out=tmp_path / "one", chunk_size=4, progress=False)  # one chunk: nothing prepared beside it
    # the Batch that set_const keeps for a vehicle's chunks of 2 is there already, as after a sweep's first chunk
    # or a session's earlier sweep of the same vehicle
    make_batch(spec.vehicle, spec.scenario, {k: np.asarray(v, float)[:2] for k, v in spec.params.items()}, spec.params)
    met = _calls_meet(monkeypatch)
    run_sweep(spec, out=tmp_path / "two", chunk_size=2, progress=False)  # the second prepared ahead of its turn
    one, two = batchveh.load(tmp_path / "one"), batchveh.load(tmp_path / "two")
    differ = [k for k in one if not one[k].equals(two[k])]
    assert not differ, f"rows differ between chunks of 4 and of 2 in {len(differ)} columns, e.g. {differ[:3]}"
    pd.testing.assert_frame_equal(one, two, check_exact=True)
    assert not met, "two chunks were prepared at once"


def test_a_variants_columns_do_not_depend_on_its_chunk_or_its_part(tmp_path, monkeypatch):
    """The MuJoCo C engine on the slip tyre (a wheel-ground step between MuJoCo's steps: a chunk runs as parts):
    each variant alone, the 4 in one part, and in 2 parts on 2 threads give the same bits."""
    spec = load_spec(_spec(tmp_path))
    table = {k: np.asarray(v, float) for k, v in spec.params.items()}
    engine = make_engine("mujoco", spec.scenario, spec.stats_config(), None, 4, nthread=2)
    engine.processes = False  # parts on threads (a worker process costs seconds to start)

    def run(rows: slice, parts: int) -> dict[str, np.ndarray]:
        batch = make_batch(spec.vehicle, spec.scenario, {k: v[rows] for k, v in table.items()}, list(table))
        apply_solver(batch.model, spec.solver)
        monkeypatch.setattr(mujoco_engine, "MIN_PART", batch.n // parts)
        assert engine.parts(batch.n, True) == parts
        return {k: np.asarray(v) for k, v in engine.run(batch).items()}

    alone = [run(slice(i, i + 1), 1) for i in range(4)]
    want = {k: np.concatenate([a[k] for a in alone]) for k in alone[0]}
    for name, got in {"one part": run(slice(0, 4), 1), "two parts": run(slice(0, 4), 2)}.items():
        differ = [k for k in want if not np.array_equal(want[k], got[k], equal_nan=True)]
        assert not differ, f"{name}: {len(differ)} columns differ from each variant run alone, e.g. {differ[:3]}"
