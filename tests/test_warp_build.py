"""Building MuJoCo Warp's kernels ahead in worker processes (batchveh/engines/warp_build.py).

What the engine computes does not depend on it (the same kernels, built elsewhere first); what it must
get right is which kernels: the key that says a vehicle's kernels are built, and that the workers'
stages reach every module MuJoCo Warp's step launches (checked on the CPU, where Warp builds the same
modules for its CPU device; slow: Warp's CPU compiles take about 20 s on 2 cores).
"""

import os
import pickle
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from batchveh.engines import warp_build
from batchveh.engines.warp import CONTACTS_PER_WORLD, constraint_rows
from batchveh.model.scenarios import make_scenario
from batchveh.model.vehicle import Vehicle
from batchveh.stepping.batch import make_batch

# modules MuJoCo Warp's step may still build at its first launch after the workers: `_next_time`, which
# only the integrator's advance launches (0.14-0.24 s on one H200: benchmarks/results/h200-first-gpu-run.json)
LEFT_TO_THE_STEP = ("_next_time_builder",)


def _batch(table, swept=None):
    sc = make_scenario("straight_line", total_time=1.0, ramp_time=0.5)
    return make_batch(Vehicle(), sc, table, swept)


def _key(b, chunk=8):
    batched = {k: chunk for k in b.fields}
    return warp_build.key(b.model, batched, constraint_rows(b.model, CONTACTS_PER_WORLD), CONTACTS_PER_WORLD)


def test_key_follows_structure_not_values():
    a = _batch({"slope_deg": np.array([0.0, 5.0]), "friction": np.array([0.5, 0.9])})
    b = _batch({"slope_deg": np.array([20.0, 25.0]), "friction": np.array([0.3, 1.1])})
    assert _key(a) == _key(b)  # other values of the same swept parameters: the same kernels
    assert _key(a) == _key(a, chunk=16)  # gravity's and friction's leading size keys nothing
    args = (a.model, constraint_rows(a.model, CONTACTS_PER_WORLD), CONTACTS_PER_WORLD)
    # the chunk's leading size of a geometry field keys the broadphase (a sweep over the vehicle)
    assert warp_build.key(a.model, {"geom_aabb": 8}, *args[1:]) != warp_build.key(a.model, {"geom_aabb": 16}, *args[1:])
    c = _batch({"slope_deg": np.array([0.0, 5.0])})
    assert _key(c) != _key(a)  # another set of batched fields
    d = _batch({"slope_deg": np.array([0.0, 5.0]), "friction": np.array([0.5, 0.9])})
    d.model.opt.iterations = 50
    assert _key(d) != _key(a)


def test_not_wanted_when_switched_off_or_marked(monkeypatch, tmp_path):
    b = _batch({"slope_deg": np.array([0.0, 5.0])})
    args = (b.model, {"opt.gravity": 2}, 96, CONTACTS_PER_WORLD)
    monkeypatch.setattr(warp_build, "marker", lambda k: str(tmp_path / f"batchveh-ahead-{k}"))
    monkeypatch.setattr(warp_build, "may_spawn", lambda: True)
    assert warp_build.wanted(*args)
    monkeypatch.setenv("BATCHVEH_WARP_PREBUILD", "0")
    assert not warp_build.wanted(*args)
    monkeypatch.delenv("BATCHVEH_WARP_PREBUILD")
    (tmp_path / f"batchveh-ahead-{warp_build.key(*args)}").write_text("built")
    assert not warp_build.wanted(*args)
    monkeypatch.setattr(warp_build, "may_spawn", lambda: False)  # an unguarded script, a daemonic worker
    assert not warp_build.wanted(b.model, {"opt.gravity": 4}, 96, CONTACTS_PER_WORLD)


def test_thread_only_where_no_worker_may_start_and_not_built(monkeypatch, tmp_path):
    b = _batch({"slope_deg": np.array([0.0, 5.0])})
    args = (b.model, {"opt.gravity": 2}, 96, CONTACTS_PER_WORLD)
    monkeypatch.setattr(warp_build, "marker", lambda k: str(tmp_path / f"batchveh-ahead-{k}"))
    monkeypatch.setattr(warp_build, "may_spawn", lambda: True)
    assert not warp_build.thread_wanted(*args)  # worker processes build them instead
    monkeypatch.setattr(warp_build, "may_spawn", lambda: False)  # a daemonic gpus worker
    assert warp_build.thread_wanted(*args)
    monkeypatch.setenv("BATCHVEH_WARP_PREBUILD", "0")
    assert not warp_build.thread_wanted(*args)
    monkeypatch.delenv("BATCHVEH_WARP_PREBUILD")
    (tmp_path / f"batchveh-ahead-{warp_build.key(*args)}").write_text("built")
    assert not warp_build.thread_wanted(*args)  # a warm machine: the first launch loads them from the cache
    assert warp_build.thread_wanted(b.model, {"geom_aabb": 8}, 96, CONTACTS_PER_WORLD)  # another vehicle sweep


CHECK = textwrap.dedent(
    """
    import os, pickle, sys
    import numpy as np
    import mujoco, warp as wp
    from batchveh.engines import warp_build

    if __name__ == "__main__":
        model, batched, njmax, ncon = pickle.load(open(sys.argv[1], "rb"))
        report = warp_build.AheadBuild(model, batched, njmax, ncon, device="cpu").wait()
        failed = {k: v for k, v in report.items() if isinstance(v, str)}
        assert not failed, failed
        wp.init()
        cache = wp.config.kernel_cache_dir
        before = set(os.listdir(cache))
        import mujoco_warp as mjw
        m = mjw.put_model(model)
        m.opt.warn_overflow = 0
        for name, size in batched.items():
            owner, attr = (m.opt, name[4:]) if name.startswith("opt.") else (m, name)
            a = getattr(owner, attr)
            setattr(owner, attr, wp.array(np.repeat(a.numpy()[:1], size, axis=0), dtype=a.dtype))
        d = mjw.put_data(model, mujoco.MjData(model), nworld=1, naconmax=ncon, njmax=njmax)
        with wp.ScopedLogLevel(wp.LOG_ERROR):
            mjw.step(m, d)
        wp.synchronize()
        print("LEFT", sorted(set(os.listdir(cache)) - before))
    """
)


@pytest.mark.slow
def test_workers_build_every_module_the_step_launches(tmp_path):
    """On an empty kernel cache, after the workers, one real MuJoCo Warp step builds only LEFT_TO_THE_STEP."""
    b = _batch({"slope_deg": np.array([0.0, 5.0]), "friction": np.array([0.5, 0.9])})
    payload = (b.model, {k: 8 for k in b.fields}, constraint_rows(b.model, CONTACTS_PER_WORLD), CONTACTS_PER_WORLD)
    (tmp_path / "model.pkl").write_bytes(pickle.dumps(payload))
    (tmp_path / "check.py").write_text(CHECK)
    env = {**os.environ, "WARP_CACHE_PATH": str(tmp_path / "cache"), "JAX_PLATFORMS": "cpu"}
    done = subprocess.run(
        [sys.executable, str(tmp_path / "check.py"), str(tmp_path / "model.pkl")],
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    left = next(line for line in done.stdout.splitlines() if line.startswith("LEFT"))
    built = eval(left[5:])  # noqa: S307 - our own script's printed list of folder names
    unexpected = [x for x in built if not any(x.startswith(f"wp_{n}") for n in LEFT_TO_THE_STEP)]
    assert not unexpected, built
    assert len(os.listdir(tmp_path / "cache" / os.listdir(tmp_path / "cache")[0])) > 25  # the workers built them


def test_a_daemonic_worker_starts_no_workers(monkeypatch):
    """The gpus executor's per-GPU processes are daemonic: Python refuses them children, so a first chunk
    there must not try (it failed every chunk of a 1,000,000-variant sweep on two H100s before)."""
    import multiprocessing
    from types import SimpleNamespace

    monkeypatch.setattr(warp_build, "spawn_safe", lambda: True)  # as under python -m batchveh.sweep
    assert warp_build.may_spawn()
    monkeypatch.setattr(multiprocessing, "current_process", lambda: SimpleNamespace(daemon=True))
    assert not warp_build.may_spawn()


def test_workers_past_their_time_are_ended():
    """A build still running when the engine stops waiting is ended with the pool, not left for the
    interpreter's exit to wait on."""
    import multiprocessing
    import time

    pool = warp_build._workers()
    try:
        late = pool.apply_async(time.sleep, (120,))
        time.sleep(1.0)
        assert not late.ready()
    finally:
        t0 = time.perf_counter()
        warp_build.stop_workers()
    assert time.perf_counter() - t0 < 20
    assert not [p for p in multiprocessing.active_children() if "PoolWorker" in p.name]
