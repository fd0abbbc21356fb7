"""One error path for every command line (batchveh.cli): a bad flag, a missing file and a bad spec key are each
one line on stderr naming what is wrong, exit 2, no traceback; Ctrl-C is one line and exit 130.

Each command's `main(argv)` runs in this process on tiny inputs: every case stops before any simulation but the
sensitivity command's, which reads a 12-variant sobol sweep of 25 steps."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest
import yaml
from conftest import sweep_spec

from batchveh import render, run, sensitivity, size, sweep
from batchveh.cli import run_main
from batchveh.config import ConfigError, OneLineParser

CATALOGUE = Path(__file__).resolve().parent.parent / "notebooks" / "motors.yaml"
COMMANDS = {"sweep": sweep, "size": size, "run": run, "render": render, "sensitivity": sensitivity}


def _one_line(capsys, main, argv, code=2) -> str:
    """`main(argv)`'s exit code (argparse's own errors exit from the parser) and its stderr: one line, no traceback."""
    try:
        got = main(argv)
    except SystemExit as exc:
        got = exc.code
    err = capsys.readouterr().err.strip()
    assert got == code and len(err.splitlines()) == 1 and "Traceback" not in err, (got, err)
    return err


@pytest.fixture(scope="module")
def sobol_result(tmp_path_factory):
    """A sobol sweep's result folder: D = 2, N = 2 (12 variants) of 0.5 s at 20 ms, on MuJoCo C."""
    tmp = tmp_path_factory.mktemp("sobol")
    fixed = {"total_time": 0.5, "ramp_time": 0.2, "time_step": 0.02}
    path = sweep_spec(
        tmp,
        "s",
        fixed=fixed,
        sweep={
            "method": "sobol",
            "n": 2,
            "params": {"slope_deg": {"low": 0, "high": 5}, "friction": {"low": 0.6, "high": 1}},
        },
    )
    assert sweep.main([str(path), "--quiet"]) == 0
    return tmp / "s"


def _argv(command, tmp_path, request) -> dict[str, list[str]]:
    """Each case's command line: 'flag' an unknown flag, 'missing' a file that is not there, 'key' a misspelt key
    (slop_deg) in the input the command reads (a sweep spec, a scenario, or for the sensitivity a statistic)."""
    missing = str(tmp_path / "nowhere.yaml")
    if command in ("sweep", "size"):
        bad = sweep_spec(tmp_path, "bad", sweep={"method": "grid", "params": {"slop_deg": [0, 5]}})
        cat = ["--catalogue", str(CATALOGUE)] if command == "size" else []
        good = sweep_spec(tmp_path, "good")
        return {"flag": [str(good), *cat, "--bogus"], "missing": [missing, *cat], "key": [str(bad), *cat, "--quiet"]}
    if command in ("run", "render"):
        bad = tmp_path / "bad.yaml"
        bad.write_text(yaml.safe_dump({"kind": "straight_line", "slop_deg": 5}))
        out = ["--out", str(tmp_path / ("o.gif" if command == "render" else "o"))]
        return {"flag": ["straight_line", "--bogus", *out], "missing": [missing, *out], "key": [str(bad), *out]}
    result = str(request.getfixturevalue("sobol_result"))
    out = ["--out", str(tmp_path / "x")]
    return {
        "flag": [result, "--bogus", *out],
        "missing": [str(tmp_path / "nowhere"), *out],
        "key": [result, "--statistics", "drive_sum_maen", *out],
    }


@pytest.mark.parametrize("command", list(COMMANDS))
def test_bad_flag_missing_file_and_bad_key_are_one_line(command, tmp_path, capsys, request):
    module = COMMANDS[command]
    cases = _argv(command, tmp_path, request)
    err = _one_line(capsys, module.main, cases["flag"])
    assert err.startswith("error: ") and "--bogus" in err and "did you mean" not in err, err  # nothing near it
    if "run_main" in vars(module):  # the wrapper's parse names the flags allowed
        assert "allowed: " in err and "--out" in err, err
    err = _one_line(capsys, module.main, cases["missing"])
    assert err.startswith("error: ") and "nowhere" in err and "not found" in err, err
    err = _one_line(capsys, module.main, cases["key"])
    assert err.startswith("error: ") and "allowed" in err, err
    if command == "sensitivity":
        assert "'drive_sum_maen'" in err and "did you mean 'drive_sum_mean'?" in err, err
    else:
        assert "slop_deg" in err and "slope_deg" in err, err  # the misspelt key and the one meant
    assert not list(tmp_path.glob("o*")) and not list(tmp_path.glob("x*"))  # nothing written


# --- the wrapper itself ----------------------------------------------------------------------------------


def _parser() -> OneLineParser:
    parser = OneLineParser(prog="cmd")
    parser.add_argument("src")
    parser.add_argument("--out")
    parser.add_argument("--overwrite", action="store_true")
    return parser


class _Exists(FileExistsError):
    pass


@pytest.mark.parametrize(
    "raised, code, line",
    [
        (
            ConfigError("a.yaml: slop_deg: unknown; allowed: slope_deg"),
            2,
            "error: a.yaml: slop_deg: unknown; allowed: slope_deg",
        ),
        (FileNotFoundError(2, "No such file or directory", "in.csv"), 2, "error: in.csv: No such file or directory"),
        (OSError(28, "No space left on device"), 2, "error: o/: No space left on device"),  # no file name: --out's
        (_Exists("o/ exists; give --overwrite"), 3, "error: o/ exists; give --overwrite"),  # the command's own code
        (OSError("line one\nline two"), 2, "error: o/: line one line two"),  # a library's message, on one line
        (KeyboardInterrupt(), 130, "interrupted: finished parts are kept"),
    ],
)
def test_run_main_turns_each_input_error_into_one_line(capsys, raised, code, line):
    def body(args: argparse.Namespace) -> int:
        assert args.src == "a" and args.out == "o/"
        raise raised

    got = run_main(
        _parser(), body, ["a", "--out", "o/"], codes={_Exists: 3}, where=lambda a: a.out,
        interrupted="finished parts are kept",
    )  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert got == code and err == line, (got, err)


def test_run_main_returns_the_body_code_and_lets_a_bug_through(capsys):
    assert run_main(_parser(), lambda args: 4, ["a"]) == 4
    with pytest.raises(ZeroDivisionError):
        run_main(_parser(), lambda args: 1 // 0, ["a"])


def test_an_unknown_flag_names_the_flags_allowed(capsys):
    err = _one_line(capsys, lambda argv: run_main(_parser(), lambda args: 0, argv), ["a", "--ovewrite"])
    assert err == (
        "error: unrecognized arguments: --ovewrite (did you mean '--overwrite'?); allowed: <src>, --out, --overwrite "
        "(see --help)"
    ), err
    with pytest.raises(TypeError, match="OneLineParser"):
        run_main(argparse.ArgumentParser(), lambda args: 0, [])
