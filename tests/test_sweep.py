"""The sweep engine on small sweeps (CPU): variants, backends, physics, Parquet, resume, bad specs."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml
from conftest import slope_torque

import batchveh
from batchveh.sweep import main, run_sweep
from batchveh.sweeping.spec import load_spec, variant_table

# Backends agree (MJX float32 vs MuJoCo C float64) on non-slipping variants:
# - the four-wheel sum, which physics fixes, within SUM_ATOL N m;
# - each wheel's mean within SPLIT_ATOL N m: four wheels locked to one speed are
#   over-constrained, and the split is set by contact compliance and solver details
#   (measured: 2.1 N m apart at 0 deg, mu 0.3, 1.5 s; docs/physics.md "Four locked wheels").
SUM_ATOL = 0.02  # N m, near zero torque
SUM_RTOL = 2e-3  # measured 9.5e-4 at 10 deg, mu 0.3
SPLIT_ATOL = 2.5


def _spec(tmp_path, name="s", **over):
    raw = {
        "name": name,
        "scenario": "straight_line",
        "fixed": {"total_time": 1.5, "ramp_time": 0.5},
        "sweep": {"method": "grid", "params": {"slope_deg": [0, 10, 20], "friction": [0.3, 0.9]}},
        "output": str(tmp_path / name),
    }
    raw.update(over)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def test_grid_random_lhs_counts_and_values(tmp_path):
    grid = variant_table(load_spec(_spec(tmp_path)))
    assert len(grid) == 6 and list(grid.columns) == ["variant", "slope_deg", "friction"]
    assert sorted(set(grid.slope_deg)) == [0, 10, 20] and sorted(set(grid.friction)) == [0.3, 0.9]
    rng = {
        "method": "random",
        "n": 50,
        "seed": 3,
        "params": {"friction": {"low": 0.1, "high": 1.0, "log": True}, "slope_deg": {"low": 0, "high": 20}},
    }
    r = variant_table(load_spec(_spec(tmp_path, "r", sweep=rng)))
    assert len(r) == 50 and r.friction.between(0.1, 1.0).all() and r.slope_deg.between(0, 20).all()
    assert r.equals(variant_table(load_spec(_spec(tmp_path, "r2", sweep=rng))))  # seeded
    lhs = variant_table(load_spec(_spec(tmp_path, "l", sweep={**rng, "method": "lhs", "n": 40})))
    # one sample per stratum in every dimension
    strata = np.floor((lhs.slope_deg.to_numpy() - 0) / 20 * 40).astype(int)
    assert sorted(strata) == list(range(40))
    ranged = {"method": "zip", "params": {"slope_deg": {"start": 0, "stop": 4, "num": 5}, "friction": [1, 1, 1, 1, 1]}}
    z = variant_table(load_spec(_spec(tmp_path, "z", sweep=ranged)))
    np.testing.assert_allclose(z.slope_deg, [0, 1, 2, 3, 4])


def test_sweep_physics_both_backends_and_single_runs(tmp_path, vehicle):
    spec = load_spec(_spec(tmp_path))
    c = run_sweep(spec, out=tmp_path / "c", backend="mujoco", progress=False)
    j = run_sweep(spec, out=tmp_path / "j", backend="mjx", chunk_size=4, progress=False)  # 2 chunks, 1 compile
    assert c["rows"] == j["rows"] == 6
    dc, dj = batchveh.load(tmp_path / "c"), batchveh.load(tmp_path / "j")
    assert (dc.status == "ok").all() and (dj.status == "ok").all()
    # physics: tan(20 deg) > 0.3 slips; the others follow m g sin(s) r
    slip = (dc.slope_deg == 20) & (dc.friction == 0.3)
    assert dc.slipping[slip].all() and not dc.slipping[~slip].any()
    hold = dc[~slip & (dc.slope_deg > 0)]
    np.testing.assert_allclose(hold.drive_sum_mean, [slope_torque(vehicle, s) for s in hold.slope_deg], rtol=0.01)
    # the two backends agree where the ground holds
    np.testing.assert_allclose(dj.drive_sum_mean[~slip], dc.drive_sum_mean[~slip], rtol=SUM_RTOL, atol=SUM_ATOL)
    for col in [c for c in dc.columns if c.endswith("_mean") and c.startswith(("drive", "steer"))]:
        np.testing.assert_allclose(dj[col][~slip], dc[col][~slip], atol=SPLIT_ATOL, err_msg=col)
    # a batched variant equals the same variant run alone
    k = 3
    alone = batchveh.simulate(
        vehicle,
        batchveh.make_scenario(
            "straight_line",
            total_time=1.5,
            ramp_time=0.5,
            slope_deg=float(dc.slope_deg[k]),
            friction=float(dc.friction[k]),
        ),
    ).stats
    for col in ("drive_lf_mean", "drive_sum_peak", "steer_rr_p95", "drive_lf_peak_lp", "distance"):
        # controls are evaluated by JAX in float32 here, in differently shaped vmaps: 5e-8 apart
        np.testing.assert_allclose(dc[col][k], alone[col], rtol=1e-6, atol=1e-6, err_msg=col)
    # 6 variants in chunks of 4: the short last chunk is padded, so one program serves both
    assert j["compiles"] == 1 and j["compile_s"] > 0 and c["variant_steps_per_s"] > 0


def test_mjx_mass_and_geometry_variants_match_mujoco_c(tmp_path, vehicle):
    """Payload mass and wheel radius change derived constants (MJX has no set_const): both engines agree."""
    sweep = {
        "method": "zip",
        "params": {
            "payload.mass": [0.0, 40.0, 20.0],
            "wheel.radius": [0.195, 0.195, 0.25],
            "slope_deg": [10.0, 10.0, 10.0],
        },
    }
    spec = load_spec(_spec(tmp_path, "m", sweep=sweep, fixed={"total_time": 1.5, "ramp_time": 0.5, "friction": 0.9}))
    run_sweep(spec, out=tmp_path / "mc", backend="mujoco", progress=False)
    run_sweep(spec, out=tmp_path / "mj", backend="mjx", progress=False)
    dc, dj = batchveh.load(tmp_path / "mc"), batchveh.load(tmp_path / "mj")
    mass = vehicle.total_mass + dc["payload.mass"]
    expect = mass * 9.81 * np.sin(np.deg2rad(10)) * dc["wheel.radius"]
    np.testing.assert_allclose(dc.drive_sum_mean, expect, rtol=0.01)
    np.testing.assert_allclose(dj.drive_sum_mean, dc.drive_sum_mean, rtol=SUM_RTOL, atol=SUM_ATOL)
    # a larger wheel turns slower for the same speed
    assert dj.wheel_speed[2] < dj.wheel_speed[0]


def test_parquet_schema_and_metadata(tmp_path):
    spec = load_spec(_spec(tmp_path, sweep={"method": "grid", "params": {"payload.mass": [0, 30]}}))
    run_sweep(spec, out=tmp_path / "o", backend="mujoco", progress=False)
    files = sorted((tmp_path / "o").glob("part-*.parquet"))
    assert len(files) == 1
    schema = pq.read_schema(files[0])
    units = {f.name: f.metadata[b"unit"].decode() for f in schema}
    assert units["drive_lf_rms"] == "N m" and units["payload.mass"] == "kg" and units["drive_lf_energy"] == "J"
    assert all(f.metadata[b"description"] for f in schema if f.name != "variant")
    meta = batchveh.metadata(tmp_path / "o")
    assert meta["spec"]["name"] == "s" and {"batchveh", "mujoco", "jax"} <= set(meta["versions"])
    assert meta["window_s"] == [0.75, 1.5] and meta["lowpass_s"] == 0.05 and "chunk_wall_s" in meta
    df = batchveh.load(tmp_path / "o")
    for m in batchveh.MOTORS:
        for stat in ("mean", "rms", "min", "max", "peak", "p95", "peak_all", "peak_lp"):
            assert f"{m}_{stat}" in df
    assert {"drive_sum_mean", "status", "variant", "slip_ratio", "max_roll_deg", "final_x"} <= set(df.columns)
    # a heavier payload needs more torque on a flat road only through the ramp; on 0 deg the sum is ~0
    assert df.drive_lf_energy[1] > df.drive_lf_energy[0]


def test_existing_results_are_never_overwritten_silently(tmp_path, capsys):
    path = _spec(tmp_path, sweep={"method": "grid", "params": {"slope_deg": [5]}})
    assert main([str(path), "--backend", "mujoco", "--quiet"]) == 0
    assert main([str(path), "--backend", "mujoco", "--quiet"]) == 3
    assert "--overwrite" in capsys.readouterr().err
    (tmp_path / "s" / "notes.txt").write_text("the user's own file")
    assert main([str(path), "--backend", "mujoco", "--quiet", "--overwrite"]) == 0
    assert (tmp_path / "s" / "notes.txt").read_text() == "the user's own file"  # only results are replaced


def test_resume_after_kill_equals_uninterrupted(tmp_path):
    path = _spec(tmp_path, "k", sweep={"method": "grid", "params": {"slope_deg": list(range(0, 24, 2))}})
    full = tmp_path / "full"
    run_sweep(load_spec(path), out=full, backend="mujoco", chunk_size=2, progress=False)
    out = tmp_path / "killed"
    cmd = [
        sys.executable,
        "-m",
        "batchveh.sweep",
        str(path),
        "--backend",
        "mujoco",
        "--chunk-size",
        "2",
        "--out",
        str(out),
        "--quiet",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 300
    while len(list(out.glob("part-*.parquet"))) < 2 and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    kept = len(list(out.glob("part-*.parquet")))
    assert 1 <= kept < 6, kept  # killed halfway: some chunks written, not all
    assert main([str(path), "--backend", "mujoco", "--chunk-size", "2", "--out", str(out), "--quiet"]) == 3
    assert main([str(path), "--backend", "mujoco", "--chunk-size", "2", "--out", str(out), "--quiet", "--resume"]) == 0
    a, b = batchveh.load(full), batchveh.load(out)
    pd.testing.assert_frame_equal(a, b)
    assert not list(out.glob(".*.tmp"))


@pytest.mark.parametrize(
    "edit, expect",
    [
        (
            {"sweep": {"method": "grid", "params": {"slope_dge": [1]}}},
            ["sweep.params.slope_dge", "unknown parameter", "did you mean 'slope_deg'?"],
        ),
        ({"sweep": {"method": "halton", "params": {"slope_deg": [1]}}}, ["sweep.method", "'halton'", "grid, random"]),
        ({"fixed": {"friction": -1}}, ["fixed.friction", "-1", "> 0"]),
        ({"sweep": {"method": "grid", "params": {"friction": "high"}}}, ["sweep.params.friction", "'high'"]),
        ({"outptu": "x"}, ["outptu", "did you mean 'output'?", "allowed keys"]),
        ({"sweep": {"method": "random", "params": {"friction": {"low": 0.1, "high": 1}}}}, ["sweep.n"]),
        ({"scenario": "drift"}, ["scenario", "'drift'", "known:"]),
        (
            {"sweep": {"method": "grid", "params": {"time_step": [0.005, 0.0025]}}},
            ["sweep.params.time_step", "cannot be swept", "under fixed"],
        ),
        ({"solver": {"iterations": 0}}, ["solver.iterations", "0", "integer >= 1"]),
        ({"solver": {"type": "pgs"}}, ["solver.type", "'pgs'", "newton, cg"]),
        ({"solver": {"impl": "fused"}}, ["solver", "impl", "allowed keys"]),
        ({"backend": "warp", "precision": "f64"}, ["precision: 'f64'", "warp backend", "allowed: f32"]),
    ],
)
def test_bad_spec_one_line(tmp_path, capsys, edit, expect):
    path = _spec(tmp_path, **edit)
    code = main([str(path), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert str(path) in err
    for part in expect:
        assert part in err, (part, err)


def test_diverging_variant_is_flagged_and_sweep_goes_on(tmp_path):
    # a servo gain far past stability with dt 20 ms diverges; the other variant does not
    path = _spec(
        tmp_path,
        "d",
        fixed={"total_time": 1.0, "ramp_time": 0.5, "time_step": 0.02},
        sweep={"method": "zip", "params": {"motors.steer_kp": [20000, 1e9], "slope_deg": [5, 5]}},
    )
    run_sweep(load_spec(path), out=tmp_path / "d", backend="mujoco", progress=False)
    df = batchveh.load(tmp_path / "d")
    assert df.status[0] == "ok" and df.status[1] in ("diverged", "flipped"), list(df.status)
    assert df.drive_sum_mean.notna()[0]


def test_dry_run_and_help(tmp_path, capsys):
    assert main([str(_spec(tmp_path)), "--dry-run"]) == 0
    assert "6 variants" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "--resume" in capsys.readouterr().out


def test_shipped_sweeps_are_valid():
    import pathlib

    root = pathlib.Path(__file__).parent.parent / "sweeps"
    names = sorted(p.name for p in root.glob("*.yaml"))
    assert {"slope.yaml", "friction.yaml", "speed.yaml", "steering.yaml", "planets.yaml"} <= set(names)
    for p in root.glob("*.yaml"):
        raw = yaml.safe_load(p.read_text())["sweep"]
        method = raw.get("method", "grid")
        if method not in ("grid", "zip"):  # random, lhs, sobol: the spec's own count
            assert len(load_spec(p).table()) == raw["n"], p.name
            continue
        sizes = [len(v) if isinstance(v, list) else v["num"] for v in raw["params"].values()]
        expected = {"grid": int(np.prod(sizes)), "zip": sizes[0]}[method]
        assert len(load_spec(p).table()) == expected, p.name
    assert len(load_spec(root / "slope.yaml").table()) == 31 * 19 * 18  # the README's main job: 10,602


def test_non_finite_samples_mark_a_variant_diverged():
    from batchveh.stepping import stats

    cfg = stats.StatsConfig.make(0.01, 20)
    acc = stats.init(cfg, (2,))
    good = {
        "tau": np.ones((2, 1, 8)),
        "omega": np.ones((2, 1, 4)),
        "alpha": np.zeros((2, 1, 4)),
        "ref": np.ones((2, 1, 8)),
        "pos": np.zeros((2, 1, 3)),
        "quat": np.tile([1.0, 0, 0, 0], (2, 1, 1)),
        "vel": np.zeros((2, 1, 3)),
    }
    good["rim"] = np.ones((2, 1))
    for i in range(20):
        s = {k: v.copy() for k, v in good.items()}
        if i == 12:
            s["tau"][1, 0, 3] = np.nan
        acc = stats.update(acc, s, np.array([i]), cfg)
    out = stats.finalize(acc, cfg)
    assert [stats.STATUS[int(c)] for c in out["status_code"]] == ["ok", "diverged"]
    assert out["drive_lf_mean"][0] == 1.0


def test_block_update_equals_step_by_step():
    """Folding 37 steps at once gives what folding them one by one gives (the two backends' paths)."""
    from batchveh.stepping import stats

    rng = np.random.default_rng(0)
    n, steps = 3, 37
    cfg = stats.StatsConfig.make(0.01, steps, p95_samples=8)
    series = {
        "tau": rng.normal(size=(n, steps, 8)),
        "omega": rng.normal(size=(n, steps, 4)),
        "alpha": rng.normal(size=(n, steps, 4)),
        "ref": rng.normal(size=(n, steps, 8)),
        "pos": rng.normal(size=(n, steps, 3)),
        "vel": rng.normal(size=(n, steps, 3)),
        "quat": np.tile([1.0, 0, 0, 0], (n, steps, 1)),
        "rim": rng.normal(size=(n, steps)),
    }
    block = stats.finalize(stats.update(stats.init(cfg, (n,)), series, np.arange(steps), cfg), cfg)
    acc = stats.init(cfg, (n,))
    for i in range(steps):
        acc = stats.update(acc, {k: v[:, i : i + 1] for k, v in series.items()}, np.array([i]), cfg)
    one = stats.finalize(acc, cfg)
    for k in block:
        np.testing.assert_allclose(block[k], one[k], rtol=1e-12, atol=1e-12, err_msg=k)
    # the MJX/warp scan's way: JAX, one step per scan iteration, vmapped over the variants (its own
    # path for the p95 buffer: one row written in place); float64 inside the scoped context
    import jax
    import jax.numpy as jnp

    from batchveh.stepping.rollout import float_precision

    def fold(x):
        def body(c, i):
            s = {k: jax.lax.dynamic_index_in_dim(v, i, 0) for k, v in x.items()}  # time axis kept, length 1
            return stats.update(c, s, i[None], cfg, xp=jnp), None

        acc = jax.lax.scan(body, stats.init(cfg, (), xp=jnp, dtype=jnp.float64), jnp.arange(steps))[0]
        return stats.finalize(acc, cfg, xp=jnp)

    with float_precision("f64"):
        scanned = jax.jit(jax.vmap(fold))({k: jnp.asarray(v) for k, v in series.items()})
    for k in block:
        np.testing.assert_allclose(np.asarray(scanned[k]), block[k], rtol=1e-12, atol=1e-12, err_msg=f"jax {k}")
    # and the reductions are what they claim: mean over the window (second half), p95 of strided samples
    w = slice(cfg.first, cfg.last + 1)
    np.testing.assert_allclose(block["drive_lf_mean"], series["tau"][:, w, 0].mean(1))
    np.testing.assert_allclose(block["steer_rr_max"], series["tau"][:, w, 7].max(1))
    strided = np.abs(series["tau"][:, w, 0][:, :: cfg.stride])
    np.testing.assert_allclose(block["drive_lf_p95"], np.percentile(strided, 95, axis=1))


def test_wheel_radius_sweep_flags_slip_as_single_runs_do(tmp_path):
    """Issue 9.1: the rim speed used the base vehicle's radius, so 0.15 m and 0.25 m wheels were
    flagged slipping (slip ratio 0.234 and -0.278) though each held 0.553 m/s. At mu 0.9 on
    10 deg nothing slips (tan 10 deg = 0.18)."""
    sweep = {"method": "grid", "params": {"wheel.radius": [0.15, 0.195, 0.25]}}
    fixed = {"total_time": 4.0, "ramp_time": 1.0, "slope_deg": 10.0, "friction": 0.9, "speed_kmh": 2.0}
    spec = load_spec(_spec(tmp_path, "rad", sweep=sweep, fixed=fixed))
    run_sweep(spec, out=tmp_path / "rad", backend="mujoco", progress=False)
    df = batchveh.load(tmp_path / "rad")
    assert not df.slipping.any(), df.slip_ratio.tolist()
    # 2 km/h at the rim = 0.556 m/s; the tyre creeps by kappa = tan(10 deg) / C_s (its slip law)
    kappa = np.tan(np.deg2rad(10.0)) / batchveh.Vehicle().tyre.slip_stiffness
    np.testing.assert_allclose(df.mean_speed, 2.0 / 3.6 / (1 + kappa), rtol=0.01)
    np.testing.assert_allclose(df.wheel_speed, 2.0 / 3.6 / df["wheel.radius"], rtol=1e-4)
    for _, row in df.iterrows():
        alone = batchveh.simulate(*spec.variant(row)).stats
        assert bool(alone["slipping"]) == bool(row.slipping)
        np.testing.assert_allclose(row.slip_ratio, alone["slip_ratio"], atol=1e-6)


# -m slow (14 s, two MJX compiles): float64 MJX stays in the default run with test_mjx.py's
# test_mjx_float64_matches_mujoco_c_step_by_step, one compile per sweep with
# test_sweep_physics_both_backends_and_single_runs; float32 after float64 and the base-valued chunk are slow only
@pytest.mark.slow
def test_precision_is_scoped_and_compiles_follow_from_the_spec(tmp_path):
    """Issue 9.3 and 9.4: a float32 sweep after a float64 one runs in float32 (x64 was switched on
    for the process), and a chunk whose swept values all equal the base value compiles no second
    program (which fields vary was decided from each chunk's values)."""
    import jax
    import jax.numpy as jnp

    sweep = {"method": "grid", "params": {"payload.mass": [0.0, 0.0, 30.0, 40.0]}}  # chunk 0: base value only
    fixed = {"total_time": 1.5, "ramp_time": 0.5, "slope_deg": 10.0, "friction": 0.9}
    for precision in ("f64", "f32"):
        spec = load_spec(_spec(tmp_path, precision, sweep=sweep, fixed=fixed, precision=precision))
        s = run_sweep(spec, out=tmp_path / precision, backend="mjx", chunk_size=2, progress=False)
        assert s["compiles"] == 1, (precision, s["compiles"])
        df = batchveh.load(tmp_path / precision)
        # written float64 either way (tests/test_schema.py); a float32 run's values are float32 numbers
        col = df.drive_sum_mean.to_numpy()
        assert col.dtype == np.float64
        as_f32 = bool((col.astype(np.float32).astype(np.float64) == col).all())
        assert as_f32 == (precision == "f32"), (precision, col)
        assert not jax.config.jax_enable_x64 and jnp.asarray(1.0).dtype == jnp.float32
    a, b = batchveh.load(tmp_path / "f64"), batchveh.load(tmp_path / "f32")
    expect = (batchveh.Vehicle().total_mass + a["payload.mass"]) * 9.81 * np.sin(np.deg2rad(10)) * 0.195
    np.testing.assert_allclose(a.drive_sum_mean, expect, rtol=0.01)
    np.testing.assert_allclose(b.drive_sum_mean, a.drive_sum_mean, rtol=SUM_RTOL, atol=SUM_ATOL)


def test_warp_starts_quietly_without_the_cuda_driver():
    """A warp sweep on a CPU-only machine: Warp's native 'Could not find or load the NVIDIA CUDA driver'
    line stays out of stderr; Warp is initialised, and other stderr output still gets through."""
    import ctypes

    pytest.importorskip("warp")
    for lib in ("libcuda.so", "libcuda.so.1"):
        try:
            ctypes.CDLL(lib)
            pytest.skip("this machine has a CUDA driver: Warp has nothing to warn about")
        except OSError:
            pass
    code = (
        "import sys, warp; from batchveh.sweep import init_warp_without_cuda; init_warp_without_cuda(); "
        "assert warp._src.context.runtime is not None; print('after', file=sys.stderr)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "CUDA driver" not in done.stderr and done.stderr.strip() == "after", done.stderr


def test_a_mujoco_sweep_never_loads_mjx(tmp_path):
    """MJX (and the copy of MuJoCo Warp it carries) is imported only where MJX runs: a sweep on MuJoCo C, and
    so each run of the size command's loop, starts without it (3-7 s of a process's start on a GPU machine)."""
    code = (
        "import sys; from batchveh.sweep import run_sweep; from batchveh.sweeping.spec import load_spec; "
        f"run_sweep(load_spec('sweeps/slope.yaml'), out={str(tmp_path / 'r')!r}, backend='mujoco', limit=2, "
        "progress=False); import batchveh.engines.warp, batchveh.size; "
        "print(sorted(m for m in sys.modules if m.startswith('mujoco.mjx')))"
    )
    root = Path(__file__).resolve().parent.parent
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=root)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "[]", done.stdout[-2000:]
