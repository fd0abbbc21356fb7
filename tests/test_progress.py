"""The progress bar moves within a chunk (issue 62): MuJoCo C tells the variant-steps it simulates, block by block,
and the sweep's bar shows them as variants before the chunk's part is written; the numbers are the same bits."""

from pathlib import Path

import pandas as pd
import tqdm.auto
import yaml

import batchveh
from batchveh.engines.mujoco import MujocoEngine
from batchveh.stepping.batch import make_batch
from batchveh.sweep import run_sweep
from batchveh.sweeping.spec import load_spec


def _spec(tmp_path: Path) -> Path:
    """Three variants, 1.0 s at 5 ms steps and 0.05 s settling: three blocks of MuJoCo C's 100 steps."""
    raw = {
        "name": "bar",
        "scenario": {"kind": "straight_line", "settle_time": 0.05, "time_step": 0.005},
        "fixed": {"total_time": 1.0, "ramp_time": 0.2},
        "sweep": {"method": "grid", "params": {"slope_deg": [0, 5, 10]}},
        "backend": "mujoco",
        "output": str(tmp_path / "bar"),
    }
    path = tmp_path / "bar.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def test_the_engine_tells_every_variant_step_and_its_numbers_do_not_move(tmp_path):
    spec = load_spec(_spec(tmp_path))
    cfg = spec.stats_config()
    assert cfg.n_steps > 2 * 100  # three blocks
    rows = spec.table().rows(0, 3)

    def batch():
        return make_batch(spec.vehicle, spec.scenario, {k: rows[k].to_numpy() for k in spec.params}, spec.params)

    told = []
    heard = MujocoEngine(spec.scenario, cfg, 3)
    heard.progress = told.append
    a, b = heard.run(batch()), MujocoEngine(spec.scenario, cfg, 3).run(batch())
    assert told == [3 * 100, 3 * 100, 3 * (cfg.n_steps - 200)]
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].tobytes() == b[k].tobytes(), k


def test_the_bar_moves_before_the_first_part_is_written(tmp_path, monkeypatch):
    path = _spec(tmp_path)
    out, quiet = tmp_path / "shown", tmp_path / "quiet"
    seen = []  # (variants the bar moved by, parts written by then)

    class Recorded(tqdm.auto.tqdm):
        def update(self, n=1):
            seen.append((n, len(list(out.glob("part-*.parquet")))))
            return super().update(n)

    monkeypatch.setattr(tqdm.auto, "tqdm", Recorded)
    s = run_sweep(load_spec(path), out=out, progress=True)
    assert s["rows"] == 3 and s["chunk_size"] == 3  # one chunk
    moved = [n for n, _ in seen if n]
    assert sum(moved) == 3 and len(moved) >= 2, seen  # in steps, not all at once
    assert seen[0][1] == 0, seen  # the first move came before the chunk's part was written
    run_sweep(load_spec(path), out=quiet, progress=False)
    pd.testing.assert_frame_equal(batchveh.load(out), batchveh.load(quiet), check_exact=True)
