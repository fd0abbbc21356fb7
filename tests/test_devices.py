"""Sharding variants over several devices gives what one device gives (two forced CPU devices)."""

import json
import os
import subprocess
import sys

import pytest

_SCRIPT = """
import json, sys
import numpy as np
import jax
from batchveh.stepping import stats
from batchveh.stepping.batch import make_batch
from batchveh.engines.mjx import MjxEngine
from batchveh.model.scenarios import make_scenario
from batchveh.model.vehicle import Vehicle
sc = make_scenario("straight_line", total_time=0.5, ramp_time=0.25, friction=0.9)
cfg = stats.StatsConfig.make(sc.time_step, sc.n_steps)
batch = make_batch(Vehicle(), sc, {"slope_deg": np.linspace(0, 15, 6)})
be = MjxEngine(sc, cfg, 6)
out = be.run(batch)
print(json.dumps({"devices": len(jax.devices()), "chunk": be.chunk_size,
                  "sum": [float(x) for x in out["drive_sum_mean"]]}))
"""


def _start(n_devices):
    env = {**os.environ, "XLA_FLAGS": f"--xla_force_host_platform_device_count={n_devices}", "JAX_PLATFORMS": "cpu"}
    return subprocess.Popen(
        [sys.executable, "-c", _SCRIPT], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )


def _result(proc):
    stdout, stderr = proc.communicate(timeout=600)
    assert proc.returncode == 0, stderr[-3000:]
    return json.loads(stdout.strip().splitlines()[-1])


# float32: sharding changes the per-device batch (6 -> 3), so XLA may reorder float32 sums;
# measured relative difference up to 7.3e-7 (abs 2.7e-5 N m on 36 N m)
SHARD_RTOL = 3e-6


# -m slow (25-33 s, two processes compiling MJX): no cheaper multi-device check exists, so sharding over
# devices is checked in -m slow only; the default run covers MJX on one device (e.g. test_sweep.py's
# test_sweep_physics_both_backends_and_single_runs)
@pytest.mark.slow
def test_two_devices_match_one():
    # both processes at once: each is mostly one thread compiling, so on 2 cores they take little more
    # than one (34 s one after the other on the project's 2-core machine)
    procs = [_start(1), _start(2)]
    try:
        one, two = (_result(p) for p in procs)
    finally:
        for p in procs:
            p.kill()  # a no-op on one that has exited
    assert one["devices"] == 1 and two["devices"] == 2
    assert two["chunk"] % 2 == 0
    assert len(two["sum"]) == len(one["sum"]) == 6
    for a, b in zip(one["sum"], two["sum"], strict=True):
        assert abs(a - b) <= SHARD_RTOL * max(1.0, abs(a)), (one, two)
