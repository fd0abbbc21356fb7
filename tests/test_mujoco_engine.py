"""The `mujoco` engine's parts: a chunk with the slip tyre runs as one part per CPU, in threads on small
hosts and in worker processes from PROCESS_PARTS parts on (batchveh/engines/mujoco.py)."""

import os
import signal

import numpy as np

from batchveh.engines import mujoco as mujoco_engine
from batchveh.engines.mujoco import MujocoEngine
from batchveh.stepping.batch import make_batch
from batchveh.sweeping.spec import spec_from_mapping


def test_parts_in_worker_processes_give_the_threads_bits():
    """Each variant's statistics are its own, in float64 on the same machine code: processes or threads, every
    column is bit-equal (a part's rows in another order, or another part's tyre state, would not be); a pool
    with a dead worker gives way to threads."""
    spec = spec_from_mapping(
        {
            "name": "t",
            "scenario": "straight_line",
            "fixed": {"total_time": 1.0, "ramp_time": 0.5},
            "sweep": {
                "method": "grid",
                "params": {
                    "slope_deg": [0.0, 10.0, 20.0],
                    "friction": [0.4, 0.8, 1.2],
                    "speed_kmh": {"start": 1.0, "stop": 9.0, "num": 15},
                },
            },  # fmt: skip
            "output": "unused",
        },
        "test",
    )
    rows = spec.table().rows()
    table = {k: rows[k].to_numpy() for k in spec.params}
    batch = make_batch(spec.vehicle, spec.scenario, table)
    threads = MujocoEngine(spec.scenario, spec.stats_config(), batch.n, nthread=2, processes=False)
    processes = MujocoEngine(spec.scenario, spec.stats_config(), batch.n, nthread=2, processes=True)
    assert batch.n == 135 and threads.parts(batch.n, True) == 2  # 64 variants a part at least
    a, b = threads.run(batch), processes.run(batch)
    assert a.keys() == b.keys() and len(a) > 50
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    assert np.ptp(a["drive_sum_mean"]) > 10.0  # the slopes differ: rows out of order would show

    # a worker killed (the out-of-memory killer, say): that chunk runs in threads, the broken pool is dropped
    pool = mujoco_engine._POOL["pool"]
    os.kill(next(iter(pool._processes)), signal.SIGKILL)
    c = processes.run(batch)
    for k in a:
        np.testing.assert_array_equal(a[k], c[k], err_msg=k)
    assert mujoco_engine._POOL.get("pool") is not pool
