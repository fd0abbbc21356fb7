"""Shared helpers: closed-form references from ../shared/seed/REFERENCE.md."""

from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import yaml

from batchveh.model.tyres import Tyre
from batchveh.model.vehicle import Vehicle

# MuJoCo's frictional contact (`tyre: {model: rigid}`): the tests of that contact's own behaviour
RIGID = Vehicle(tyre=Tyre(model="rigid"))

# The four-wheel drive sum on a steady climb against m g sin(s) r: the soft contact sinks 1.5 mm,
# so the lever arm is about r - 0.75 mm (tests/test_physics.py); measured -2.8e-3 to -3.9e-3 on
# MuJoCo C, MJX and warp alike. The bound is 1%.
SLOPE_SUM_RTOL = 5e-3


def slope_torque(vehicle: Vehicle, slope_deg: float, g: float = 9.81) -> float:
    """Quasi-static four-wheel drive-torque sum on a slope: m g sin(slope) r, N m."""
    return vehicle.total_mass * g * np.sin(np.deg2rad(slope_deg)) * vehicle.wheel.radius


def sweep_spec(tmp_path, name="r", **over):
    """A small sweep's YAML in tmp_path: 8 variants (slope 0-15 deg x friction 0.3, 0.9) of 1 s on MuJoCo C, whose
    float64 rows are the same on any executor, so the in-process sweep is the exact reference of a distributed
    one; output tmp_path / name. `over` replaces top-level keys."""
    raw = {
        "name": name,
        "scenario": "straight_line",
        "fixed": {"total_time": 1.0, "ramp_time": 0.5},
        "sweep": {"method": "grid", "params": {"slope_deg": [0, 5, 10, 15], "friction": [0.3, 0.9]}},
        "backend": "mujoco",
        "output": str(tmp_path / name),
    }
    raw.update(over)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


@pytest.fixture(scope="session")
def vehicle() -> Vehicle:
    return Vehicle()


@pytest.fixture
def mjx_output_dtypes(monkeypatch) -> set[str]:
    """The dtypes of the arrays MJX runs hand back during the test (simulate brings them to the
    host with jax.device_get); the series DataFrame is float64 whatever MJX computed in."""
    import jax

    seen: set[str] = set()
    device_get = jax.device_get

    def spy(tree):
        out = device_get(tree)
        seen.update(str(np.asarray(x).dtype) for x in jax.tree_util.tree_leaves(out))
        return out

    monkeypatch.setattr(jax, "device_get", spy)
    return seen


# The results' Arrow schema (tests/test_schema.py), written by hand from the columns' documented meaning
# (results.column_doc), not read from a result
LABELS = {"status", "motor", "reasons", "steer_reasons", "motor_status", "motor_check"}
FLAGS = {"slipping", "steady", "reached", "cleared", "simulated", "steer_held", "fits", "motor_limited", "battery_over"}


def _expected(name: str) -> str:
    if name == "variant":
        return "int64"
    if name in LABELS:
        return "string"
    if name in FLAGS:
        return "bool"
    return "float64"


def _kind(t: pa.DataType) -> str:
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        return "string"
    return str(t).replace("double", "float64")


def schema_misses(path: Path) -> dict[str, tuple[str, str]]:
    """Every column of every Parquet file under `path` (or the file) whose type is not the pinned one:
    name -> (written, pinned)."""
    files = [path] if path.is_file() else sorted(path.glob("part-*.parquet"))
    assert files, path
    out = {}
    for f in files:
        for field in pq.read_schema(f):
            got, want = _kind(field.type), _expected(field.name)
            if got != want:
                out[field.name] = (got, want)
    return out


def size_here_and_on(tmp_path, monkeypatch, name: str, extra: list[str], spied: tuple[type, str]):
    """The size command on 6 of the 60-80 kg robot's conditions (MuJoCo C, float64: the same rows on any executor),
    in this process into tmp_path/here, then with `extra` (an --executor) into tmp_path/`name`, `spied` (class,
    method) wrapped to record each sweep it starts. Asserts the two agree: the choices, the loop's table and every
    row of verdicts.parquet. Returns (the second run's argv, the sweeps' names the spy saw)."""
    import json

    from batchveh.size import main as size

    root = Path(__file__).resolve().parent.parent
    base = [str(root / "sweeps" / "delivery_robot.yaml"), "--catalogue", str(root / "notebooks" / "motors.yaml"),
            "--limit", "6", "--quiet"]  # fmt: skip
    assert size([*base, "--out", str(tmp_path / "here")]) == 0
    (owner, method), started = spied, []
    real = getattr(owner, method)

    def spy(self, *args, **kwargs):
        started.append(args[0].name)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(owner, method, spy)
    argv = [*base, "--out", str(tmp_path / name), *extra]
    assert size(argv) == 0
    here, there = (json.loads((tmp_path / k / "sizing.json").read_text()) for k in ("here", name))
    assert (here["chosen"], here["steer"]) == (there["chosen"], there["steer"]) and here["chosen"] is not None
    keep = ("motor", "coverage", "judged", "not_simulated", "hot_runs", "battery_over", "start_rise_median")
    assert [{k: r[k] for k in keep} for r in here["loop"]] == [{k: r[k] for k in keep} for r in there["loop"]]
    pd.testing.assert_frame_equal(
        pd.read_parquet(tmp_path / "here" / "verdicts.parquet"), pd.read_parquet(tmp_path / name / "verdicts.parquet")
    )
    return argv, started
