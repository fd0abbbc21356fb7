"""Bad vehicle and scenario input: one clear line, non-zero exit, no traceback."""

import subprocess
import sys

import pytest

from batchveh.run import main


def _err(capsys, argv):
    code = main(argv)
    err = capsys.readouterr().err.strip()
    return code, err


@pytest.mark.parametrize(
    "text, expect",
    [
        ("chassis:\n  mas: 80\n", ["chassis.mas", "allowed keys: length, width, height, mass"]),
        ("chassis:\n  mass: -5\n", ["chassis.mass", "-5.0", "> 0 kg"]),
        ("wheel:\n  radius: big\n", ["wheel.radius", "'big'", "not a number"]),
        ("payload: 3\n", ["payload", "not a mapping"]),
        ("wheel:\n  radius: 0.05\n", ["wheel.radius", "hub.radius"]),
    ],
)
def test_bad_vehicle_yaml(tmp_path, capsys, text, expect):
    path = tmp_path / "veh.yaml"
    path.write_text(text)
    code, err = _err(capsys, ["straight_line", "--vehicle", str(path), "--out", str(tmp_path / "o")])
    assert code == 2
    assert len(err.splitlines()) == 1, err
    assert str(path) in err
    for part in expect:
        assert part in err, (part, err)


@pytest.mark.parametrize(
    "text, expect",
    [
        ("kind: drift\n", ["'drift'", "known: manual, straight_line"]),
        ("kind: straight_line\nslope_deg: 95\n", ["slope_deg", "95.0", "<= 60"]),
        ("kind: straight_line\ngravity: jupiter\n", ["gravity", "earth, moon, mars"]),
        ("kind: straight_line\nfriction: [1]\n", ["friction", "not a number"]),
        ("kind: custom\nlaws:\n  drive: {law: ramp, stop: 1}\n", ["laws.drive_lf", "needs 'start'"]),
    ],
)
def test_bad_scenario_yaml(tmp_path, capsys, text, expect):
    path = tmp_path / "sc.yaml"
    path.write_text(text)
    code, err = _err(capsys, [str(path), "--out", str(tmp_path / "o")])
    assert code == 2 and len(err.splitlines()) == 1, err
    assert str(path) in err
    for part in expect:
        assert part in err, (part, err)


def test_missing_files_and_unknown_names(tmp_path, capsys):
    code, err = _err(capsys, ["straight_line", "--vehicle", str(tmp_path / "nope.yaml")])
    assert code == 2 and "nope.yaml: file not found" in err
    code, err = _err(capsys, ["zigzag"])
    assert code == 2 and "known: manual, straight_line, steer_in_place, towing" in err
    code, err = _err(capsys, ["straight_lne"])
    assert code == 2 and "did you mean 'straight_line'?" in err


def test_cli_bad_input_prints_no_traceback(tmp_path):
    path = tmp_path / "veh.yaml"
    path.write_text("chassis:\n  mass: -1\n")
    out = subprocess.run(
        [sys.executable, "-m", "batchveh.run", "straight_line", "--vehicle", str(path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 2
    lines = [ln for ln in out.stderr.splitlines() if ln.strip() and "warp" not in ln]
    assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr


def test_custom_scenario_yaml_runs(tmp_path, capsys):
    path = tmp_path / "sc.yaml"
    path.write_text(
        "kind: custom\ntotal_time: 1.0\nlaws:\n  drive: {law: smooth_step, start: 0, stop: 2, "
        "duration: 0.5}\n  steer_lf: {law: sine, offset: 0, amplitude: 5, frequency: 1}\n"
    )
    code = main([str(path), "--out", str(tmp_path / "o")])
    assert code == 0
    import pandas as pd

    s = pd.read_parquet(tmp_path / "o" / "series.parquet")
    assert abs(s.omega_ref_lf.iloc[-1] - 2.0) < 1e-6
    assert abs(s.alpha_ref_lf.abs().max() - 5 * 3.141592653589793 / 180) < 1e-3
    assert (tmp_path / "o" / "steer_torques_smoothed.png").exists()
