"""The results' Arrow schema, pinned column by column (issue 52): a variant id is int64, a label a string,
a flag a bool, and every measured or swept quantity float64, on every engine the tests can run (MuJoCo C,
and MJX in float32) and for a servo sweep, a dcmotor mission and the size command's verdicts. A statistic
written as float32 (MJX's own precision, or a cast on the way) loses digits that sizing's tails read."""

from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import yaml
from conftest import schema_misses

from batchveh.sweep import run_sweep
from batchveh.sweeping.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]
CATALOGUE = ROOT / "notebooks" / "motors.yaml"
DRIVE = "maxon-353297-48V_NPT025-i28"


def _write(tmp_path, name, raw):
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump({"name": name, **raw, "output": str(tmp_path / name)}, sort_keys=False))
    return load_spec(path)


def test_the_pin_fails_a_float32_column(tmp_path):
    """The check itself: a table with one float32 statistic and one int flag is caught, column by column."""
    table = pa.table(
        {
            "variant": pa.array([0], pa.int64()),
            "drive_lf_rms": pa.array([1.0], pa.float32()),
            "slipping": pa.array([0], pa.int8()),
            "status": ["ok"],
        }
    )
    pq.write_table(table, tmp_path / "part-00000.parquet")
    assert schema_misses(tmp_path) == {"drive_lf_rms": ("float", "float64"), "slipping": ("int8", "bool")}


@pytest.mark.parametrize("backend, precision", [("mujoco", None), ("mjx", "f32")])
def test_a_sweep_writes_the_pinned_types(tmp_path, backend, precision):
    raw = {
        "scenario": "straight_line",
        "fixed": {"total_time": 1.0, "ramp_time": 0.5},
        "sweep": {"method": "grid", "params": {"slope_deg": [0, 10], "friction": [0.9]}},
        "backend": backend,
        **({"precision": precision} if precision else {}),
    }
    spec = _write(tmp_path, backend, raw)
    run_sweep(spec, out=tmp_path / backend, backend=backend, progress=False)
    assert schema_misses(tmp_path / backend) == {}


def test_the_start_rise_gains_are_written_as_pinned(tmp_path):
    """A dcmotor straight line with `motors.hot_columns` (the size command's loop runs): its gains and its peaks at
    the hotter starts are written, float64 like every statistic."""
    raw = {
        "scenario": "straight_line",
        "fixed": {"total_time": 1.0, "ramp_time": 0.5},
        "vehicle": {
            "motors": {
                "model": "dcmotor",
                "catalogue": str(CATALOGUE),
                "drive": DRIVE,
                "steer": DRIVE,
                "hot_columns": True,
            },
        },  # fmt: skip
        "sweep": {"method": "zip", "params": {"payload.mass": [0.0, 20.0]}},
        "backend": "mujoco",
    }
    spec = _write(tmp_path, "hot", raw)
    run_sweep(spec, out=tmp_path / "hot", backend="mujoco", progress=False)
    assert schema_misses(tmp_path / "hot") == {}
    names = set(pq.read_schema(sorted((tmp_path / "hot").glob("part-*.parquet"))[0]).names)
    wanted = {"drive_lf_temp_gain", "steer_rr_voltage_margin", "drive_rf_winding_temp_peak_110K"}
    wanted.add("bus_power_gain_steer")
    assert wanted <= names, sorted(wanted - names)


def test_a_dcmotor_mission_writes_the_pinned_types(tmp_path):
    """The motors' electrical columns and every segment's, on MuJoCo C."""
    raw = {
        "scenario": {
            "kind": "mission",
            "speed_kmh": 2.0,
            "segments": [
                {"kind": "accelerate", "duration": 1.0},
                {"kind": "turn", "turn": "ackermann", "duration": 1.0, "turn_radius": 3.0},
                {"kind": "stop", "duration": 1.0},
            ],
        },
        "vehicle": {"motors": {"model": "dcmotor", "catalogue": str(CATALOGUE), "drive": DRIVE, "steer": DRIVE}},
        "sweep": {"method": "zip", "params": {"payload.mass": [0.0, 20.0]}},
        "backend": "mujoco",
    }
    spec = _write(tmp_path, "mission", raw)
    run_sweep(spec, out=tmp_path / "mission", backend="mujoco", progress=False)
    misses = schema_misses(tmp_path / "mission")
    assert misses == {}
    names = pq.read_schema(sorted((tmp_path / "mission").glob("part-*.parquet"))[0]).names
    assert any(n.startswith("seg1_turn_") for n in names) and any("winding" in n for n in names), names[:20]
