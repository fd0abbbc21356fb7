"""Structural sweeps without a compile per variant (batchveh/stepping/fields.py) against a full compile.

The reference is `batch.compiled_fields`: MuJoCo's compiler run once per variant, every numeric
MjModel field that differs from the base model's. The fast path must give each of them within
FIELD_RTOL for every variant, and leave no other field different: a derived constant left at the
base model's value (mj_setConst's invweight0, acc0, subtree masses, ...) fails here.
"""

import numpy as np
import pytest

from batchveh.config import ConfigError
from batchveh.engines.mujoco import MujocoEngine
from batchveh.model.params import base_params, parameter_specs, structural
from batchveh.model.scenarios import make_scenario
from batchveh.model.vehicle import Vehicle, Wheel
from batchveh.stepping import stats
from batchveh.stepping.batch import SAMEFRAME, VariantBatch, compiled_fields, make_batch, model_for
from batchveh.stepping.fields import g10

FIELD_RTOL = 1e-10  # the bound, relative to the field's largest value in the variant
# measured: 0 for every field (bit-identical) on this project's 2-core machine
TORQUE_RTOL = 1e-9  # simulated statistics, fast path against compile per variant, MuJoCo C
N = 200
MIX = ("payload.mass", "wheel.radius", "chassis.z_cg", "wheel.y_cg", "payload.x")
VEHICLE = [k for k in structural(parameter_specs(Vehicle()), Vehicle()) if "." in k]


def _table(names, n=N, seed=0):
    """n random values of each parameter about its base value (payload from 0 to 40 kg, offsets +-0.1 m)."""
    rng = np.random.default_rng(seed)
    p = base_params(Vehicle(), make_scenario())
    out = {}
    for k in names:
        if k == "payload.mass":
            lo, hi = 0.0, 40.0
        elif k == "wheel.rolling_resistance":
            lo, hi = 0.0, 0.06
        elif k.startswith("steering."):  # 0 is the chassis corner; a hinge's place is positive
            corner = p["chassis.length" if k.endswith("_x") else "chassis.width"] / 2
            lo, hi = 0.8 * corner, 1.2 * corner
        elif p[k] == 0:
            lo, hi = -0.1, 0.1
        else:
            lo, hi = 0.8 * p[k], 1.2 * p[k]
        out[k] = rng.uniform(lo, hi, n)
    return out


def _compare(vehicle, scenario, table):
    """Largest relative error of the fast path's fields against a compile per variant, by field."""
    batch = make_batch(vehicle, scenario, table)
    n = batch.n
    params = {k: np.full(n, v) for k, v in base_params(vehicle, scenario).items()}
    params.update(table)
    names = structural(table, vehicle)
    ref = compiled_fields(vehicle, scenario, model_for(vehicle, scenario), params, names)
    errors = {}
    for name in sorted(set(ref) | set(batch.fields) - set(SAMEFRAME) - {"opt.gravity", "geom_friction"}):
        base = getattr(batch.model, name)
        want = ref.get(name, np.broadcast_to(base, (n, *base.shape)))
        got = batch.fields.get(name, np.broadcast_to(base, (n, *base.shape))).reshape(want.shape)
        scale = np.maximum(np.abs(want).reshape(n, -1).max(axis=1), 1e-300)
        errors[name] = float((np.abs(got - want).reshape(n, -1).max(axis=1) / scale).max())
    return ref, errors


@pytest.mark.parametrize("names", [(k,) for k in VEHICLE] + [MIX], ids=lambda k: "+".join(k))
def test_fields_equal_a_compile_per_variant(names):
    ref, errors = _compare(Vehicle(), make_scenario(), _table(names))
    worst = {k: e for k, e in errors.items() if e > FIELD_RTOL}
    assert not worst, worst
    if names == MIX:  # the mix moves the derived constants too: the comparison covered them
        assert {"body_subtreemass", "dof_invweight0", "body_invweight0", "actuator_acc0", "dof_M0"} <= set(ref)


@pytest.mark.parametrize(
    "scenario, table",
    [
        (
            dict(obstacle="step", step_height=0.05, obstacle_x=0.5),
            {"step_height": (0.02, 0.09), "wheel.x_cg": (0.45, 0.55)},
        ),
        (
            dict(obstacle="bump", bump_height=0.05, bump_length=0.4, obstacle_x=0.5),
            {"bump_length": (0.3, 0.5), "payload.mass": (0, 40)},
        ),
        (
            dict(obstacle="pothole", pothole_depth=0.05, pothole_width=0.2, obstacle_x=0.5),
            {"pothole_width": (0.1, 0.3), "obstacle_x": (0.5, 0.8)},
        ),
        (
            dict(obstacle="terrain", terrain_amplitude=0.03, terrain_wavelength=0.3, obstacle_x=0.5),
            {"terrain_seed": (0, 1e6), "wheel.radius": (0.18, 0.21)},
        ),
    ],
    ids=["step", "bump", "pothole", "terrain"],
)
def test_course_fields_equal_a_compile_per_variant(scenario, table):
    """The ground's shape: its rows from a compile per distinct shape, the vehicle's in closed form."""
    rng = np.random.default_rng(1)
    n = 24
    values = {k: rng.uniform(lo, hi, n) for k, (lo, hi) in table.items()}
    _, errors = _compare(Vehicle(), make_scenario(**scenario), values)
    assert not {k: e for k, e in errors.items() if e > FIELD_RTOL}


def test_sphere_wheels_fields_equal_a_compile_per_variant():
    _, errors = _compare(Vehicle(wheel=Wheel(collision="sphere")), make_scenario(), _table(MIX, n=50))
    assert not {k: e for k, e in errors.items() if e > FIELD_RTOL}


def test_a_stale_constant_is_caught(monkeypatch):
    """The comparison itself fails where mj_setConst's part is skipped (every derived field stale)."""
    from batchveh.stepping import fields

    def stale(m, inputs, outputs, n, **_):
        return {k: np.broadcast_to(getattr(m, k), (n, *getattr(m, k).shape)).copy() for k in outputs}

    monkeypatch.setattr(fields, "set_const", stale)
    _, errors = _compare(Vehicle(), make_scenario(), _table(("payload.mass",), n=20))
    assert errors["dof_invweight0"] > 1e3 * FIELD_RTOL and errors["body_subtreemass"] > 1e3 * FIELD_RTOL


def test_torques_equal_a_compile_per_variant_on_mujoco_c():
    sc = make_scenario("straight_line", total_time=1.0, ramp_time=0.3, slope_deg=8.0)
    table = _table(MIX)
    fast = make_batch(Vehicle(), sc, table)
    params = {k: np.full(N, v) for k, v in base_params(Vehicle(), sc).items()}
    params.update(table)
    ref = compiled_fields(Vehicle(), sc, model_for(Vehicle(), sc), params, list(MIX))
    slow = VariantBatch(fast.model, {**ref, **{k: v for k, v in fast.fields.items() if k not in ref}}, fast.params, N)
    cfg = stats.StatsConfig.for_scenario(sc)
    a = MujocoEngine(sc, cfg, N).run(fast)
    b = MujocoEngine(sc, cfg, N).run(slow)
    assert (np.asarray(a["status_code"]) == 0).all()
    for k in a:
        if np.asarray(a[k]).dtype.kind == "f":
            scale = np.max(np.abs(b[k])) or 1.0
            assert np.max(np.abs(np.asarray(a[k]) - b[k])) <= TORQUE_RTOL * scale, k


def test_g10_is_the_mjcf_number():
    rng = np.random.default_rng(2)
    x = rng.uniform(-1, 1, 20000) * 10.0 ** rng.integers(-8, 8, 20000)
    x = np.concatenate([x, [0.0, 1.0, 10.0, 1e-3, 0.195, -0.07400000000000001, 123.456789012345]])
    assert np.array_equal(g10(x), np.array([float(f"{v:.10g}") for v in x]))


@pytest.mark.parametrize(
    "values, words",
    [
        (
            {"wheel.radius": [0.2, 0.05, 0.3]},
            ["variant 1", "wheel.radius = 0.05", "wheel.radius > hub.radius (0.063 m)"],
        ),
        (
            {"payload.mass": [1.0, -2.0], "wheel.mass": [3.0, 3.0]},
            ["variant 1", "payload.mass = -2", ">= 0 kg", "wheel.mass=3"],
        ),
        ({"chassis.length": [1.0, 0.0]}, ["variant 1", "chassis.length = 0", "> 0 m"]),
    ],
)
def test_an_impossible_vehicle_is_one_line(values, words):
    with pytest.raises(ConfigError) as err:
        make_batch(Vehicle(), make_scenario(), {k: np.asarray(v) for k, v in values.items()})
    text = str(err.value)
    assert "\n" not in text and all(w in text for w in words), text


def test_an_impossible_variant_stops_the_sweep_in_one_line_before_any_simulation(tmp_path, capsys):
    from batchveh.sweep import main

    spec = tmp_path / "bad.yaml"
    spec.write_text(
        "name: bad\nscenario: straight_line\nfixed: {total_time: 1.0}\n"
        "sweep: {method: random, n: 50, seed: 0, params: {wheel.radius: {low: 0.05, high: 0.3}}}\n"
        f"output: {tmp_path / 'out'}\n"
    )
    assert main([str(spec), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(spec) in err and "wheel.radius" in err and "hub.radius" in err, err
    assert not list((tmp_path / "out").glob("part-*.parquet"))
