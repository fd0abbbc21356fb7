"""Property-based fuzzing (Hypothesis) of the three YAML inputs: sweep specs, scenarios, vehicles.

Every input either runs or is refused with exit 2 and one line: never a traceback, never a
statistic that is not finite under status `ok`. Inputs are drawn near the valid ones (known
keys, values around the defaults and at the extremes: 0, negatives, 1e-12, 1e30, NaN, inf,
strings, lists), so most reach the simulation. Runs are bounded: a valid input is simulated
only when it is short (the budget below); otherwise it is checked through its dry run.

The default run draws a few examples per target; the long pass is
    BATCHVEH_FUZZ_EXAMPLES=1000 python -m pytest tests/test_fuzz.py
"""

import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
import yaml

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, event, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import batchveh  # noqa: E402
from batchveh.config import ConfigError  # noqa: E402
from batchveh.model.params import base_params, parameter_specs  # noqa: E402
from batchveh.model.scenarios import SCENARIOS, numeric_fields  # noqa: E402
from batchveh.model.vehicle import numeric_paths  # noqa: E402
from batchveh.stepping.stats import STATUS  # noqa: E402

EXAMPLES = int(os.environ.get("BATCHVEH_FUZZ_EXAMPLES", "8"))
STEP_BUDGET = 2000  # variant-steps simulated per example at most
FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.data_too_large],
    derandomize=EXAMPLES <= 8,  # the default run is repeatable; the long pass explores
)

EXTREMES = [0, 0.0, -1.0, 1e-12, 1e-3, 0.05, 0.5, 1, 2.5, 10, 90, 1e3, 1e9, 1e30, float("nan"), float("inf")]
number = st.one_of(st.sampled_from(EXTREMES), st.floats(-100, 100), st.integers(-5, 5000))
junk = st.one_of(st.none(), st.booleans(), st.text(max_size=4), st.lists(number, max_size=3), st.just({}))
value = st.one_of(number, number, number, junk)  # mostly numbers


def mostly(good: st.SearchStrategy, bad: st.SearchStrategy) -> st.SearchStrategy:
    """`good` nine times in ten, `bad` otherwise (Hypothesis favours small numbers: 9 is rare enough)."""
    return st.integers(0, 9).flatmap(lambda k: bad if k == 9 else good)


def near_default(default: float) -> st.SearchStrategy:
    """Numbers around a field's default, now and then an extreme or junk."""
    return mostly(st.one_of(st.floats(0.2 * abs(default), 3.0 * abs(default) + 1e-3), st.just(default)), value)


SCENARIO_FIELDS = {k: near_default(getattr(batchveh.Scenario(), k)) for k in numeric_fields()}
SCENARIO_FIELDS["total_time"] = st.one_of(st.floats(0.0, 1.0), value)
SCENARIO_FIELDS["time_step"] = st.one_of(st.sampled_from([0.005, 0.002, 0.01]), value)
SCENARIO_FIELDS["kind"] = st.one_of(st.sampled_from(list(SCENARIOS)), st.text(max_size=6))
SCENARIO_FIELDS["gravity"] = st.one_of(st.sampled_from(["moon", "mars", "jupiter"]), SCENARIO_FIELDS["gravity"])


def _leaf(obj, path):
    for part in path.split("."):
        obj = getattr(obj, part)
    return obj


VEHICLE_PATHS = {p: near_default(_leaf(batchveh.Vehicle(), p)) for p in numeric_paths(batchveh.Vehicle())}


@st.composite
def scenario_mapping(draw):
    keys = draw(st.lists(st.sampled_from([*SCENARIO_FIELDS, "bogus"]), max_size=5, unique=True))
    if draw(st.integers(0, 4)) > 0:
        keys.append("total_time")  # mostly short runs, so most valid ones are simulated
    return {k: draw(SCENARIO_FIELDS.get(k, value)) for k in keys}


@st.composite
def vehicle_mapping(draw):
    paths = draw(st.lists(st.sampled_from([*VEHICLE_PATHS, "wheel.colour", "frame.mass"]), max_size=5, unique=True))
    out: dict = {}
    for p in paths:
        part, leaf = p.split(".")
        out.setdefault(part, {})[leaf] = draw(VEHICLE_PATHS.get(p, value))
    if draw(st.booleans()):
        out["contacts"] = draw(st.sampled_from(["ground", "all", "none"]))
    return out


@st.composite
def spec_mapping(draw):
    names = list(parameter_specs())
    base = base_params(batchveh.Vehicle(), batchveh.Scenario())
    method = draw(mostly(st.sampled_from(["grid", "zip", "random", "lhs", "sobol"]), st.just("halton")))
    swept = draw(st.lists(mostly(st.sampled_from(names), st.just("slope")), min_size=1, max_size=3, unique=True))
    params = {}
    for k in swept:
        near = near_default(base.get(k, 1.0))
        if method in ("random", "lhs", "sobol"):
            params[k] = draw(mostly(st.fixed_dictionaries({"low": near, "high": near}), value))
        else:
            params[k] = draw(mostly(st.lists(near, min_size=1, max_size=3), value))
    sweep = {"method": method, "params": params}
    if method in ("random", "lhs", "sobol") or draw(st.booleans()):
        sweep["n"] = draw(st.integers(1, 3)) if draw(st.integers(0, 9)) < 9 else draw(value)
    raw = {"name": "fz" if draw(st.integers(0, 9)) < 9 else draw(junk), "sweep": sweep}
    if draw(st.booleans()):
        raw["scenario"] = draw(st.one_of(st.sampled_from(list(SCENARIOS)), scenario_mapping()))
    if draw(st.booleans()):
        raw["vehicle"] = draw(vehicle_mapping())
    fixed_names = draw(st.lists(st.sampled_from(names), max_size=3, unique=True))
    raw["fixed"] = {k: draw(near_default(base.get(k, 1.0))) for k in fixed_names}
    raw["fixed"].setdefault("total_time", draw(st.sampled_from([0.1, 0.3, 0.01])))
    for key, good, bad in (
        ("window", st.lists(st.floats(0, 0.4), min_size=2, max_size=2).map(sorted), value),
        ("lowpass_s", st.sampled_from([0.05, 0.01, 1.0]), value),
        ("chunk_size", st.integers(1, 3), value),
        ("precision", st.sampled_from(["f32", "f64"]), st.sampled_from(["f16", 64])),
        ("solver", st.fixed_dictionaries({"iterations": st.integers(1, 50)}), st.fixed_dictionaries({"x": value})),
        ("extra_key", st.nothing(), value),
    ):
        pick = draw(st.integers(0, 9))  # Hypothesis favours small numbers: 0 is "leave the key out"
        if pick == 9 or (pick == 8 and key != "extra_key"):
            raw[key] = draw(bad if pick == 9 else good)
    return raw


def _write(tmp: Path, name: str, data) -> Path:
    path = tmp / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _assert_one_line(code, err, what):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: "), (what, code, err)


def _assert_ok_rows_finite(frame, what):
    cols = [c for c in frame.columns if c.startswith(("drive", "steer"))]
    ok = frame[frame.status == "ok"]
    assert np.isfinite(ok[cols].to_numpy(dtype=float)).all(), what


@FUZZ
@given(raw=spec_mapping())
def test_fuzz_sweep_specs(raw, capsys):
    from batchveh.sweep import main
    from batchveh.sweeping.spec import load_spec

    with tempfile.TemporaryDirectory() as d:
        path = _write(Path(d), "spec.yaml", raw)
        capsys.readouterr()
        code = main([str(path), "--dry-run"])
        err = capsys.readouterr().err
        if code != 0:
            _assert_one_line(code, err, raw)
            event("spec refused")
            return
        spec = load_spec(path)
        if min(len(spec.table()), 2) * spec.scenario.n_steps > STEP_BUDGET:
            event("spec valid, too long to run")
            return
        out = Path(d) / "out"
        code = main([str(path), "--limit", "2", "--backend", "mujoco", "--quiet", "--out", str(out)])
        err = capsys.readouterr().err
        if code != 0:
            _assert_one_line(code, err, raw)  # e.g. a swept vehicle MuJoCo cannot compile
            event("spec refused at run")
            return
        frame = batchveh.load(out)
        event(f"spec ran: {'all ok' if (frame.status == 'ok').all() else 'some not ok'}")
        _assert_ok_rows_finite(frame, raw)


@FUZZ
@given(data=scenario_mapping())
def test_fuzz_scenario_yaml(data, capsys):
    from batchveh.run import main, simulate

    with tempfile.TemporaryDirectory() as d:
        path = _write(Path(d), "scenario.yaml", data)
        try:
            scenario = batchveh.load_scenario(path)
            if scenario.n_steps > STEP_BUDGET:
                event("scenario valid, too long to run")
                return
            res = simulate(batchveh.Vehicle(), scenario)
        except ConfigError:
            capsys.readouterr()
            _assert_one_line(main([str(path), "--out", str(Path(d) / "o")]), capsys.readouterr().err, data)
            event("scenario refused")
            return
        event(f"scenario ran: {STATUS[int(res.stats['status_code'])]}")
        if int(res.stats["status_code"]) == 0:
            assert all(np.isfinite(float(res.stats[f"{m}_peak"])) for m in batchveh.MOTORS), data


@FUZZ
@given(data=vehicle_mapping())
def test_fuzz_vehicle_yaml(data, capsys):
    from batchveh.run import main, simulate

    with tempfile.TemporaryDirectory() as d:
        path = _write(Path(d), "vehicle.yaml", data)
        scenario = batchveh.make_scenario("straight_line", total_time=0.3, ramp_time=0.1, slope_deg=5.0)
        try:
            res = simulate(batchveh.load_vehicle(path), scenario)
        except ConfigError:
            capsys.readouterr()
            argv = ["straight_line", "--vehicle", str(path), "--total-time", "0.3", "--out", str(Path(d) / "o")]
            _assert_one_line(main(argv), capsys.readouterr().err, data)
            event("vehicle refused")
            return
        event(f"vehicle ran: {STATUS[int(res.stats['status_code'])]}")
        if int(res.stats["status_code"]) == 0:
            assert all(np.isfinite(float(res.stats[f"{m}_peak"])) for m in batchveh.MOTORS), data
