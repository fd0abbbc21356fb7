"""Plot functions on a small real sweep: files, labelled axes, plotted values equal the DataFrame's."""

import numpy as np
import pandas as pd
import pytest
import yaml

import batchveh
from batchveh.analysis import plot
from batchveh.model.motors import DCMotor

pytestmark = pytest.mark.xdist_group("plots")  # one test worker: the module's shared fixtures run once


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plots")
    raw = {
        "name": "tiny",
        "scenario": "straight_line",
        "fixed": {"total_time": 1.5, "ramp_time": 0.5},
        "sweep": {
            "method": "grid",
            "params": {"slope_deg": [0, 10, 20], "friction": [0.3, 0.9], "speed_kmh": [1.0, 3.0]},
        },
    }
    path = tmp / "tiny.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    out = tmp / "res"
    batchveh.run_sweep(batchveh.load_spec(path), out=out, backend="mujoco", progress=False)
    return batchveh.load(out), out


def _labels_have_units(fig):
    for ax in fig.axes:
        if ax.get_label() == "<colorbar>":
            continue
        assert "[" in ax.get_xlabel() and "]" in ax.get_xlabel(), ax.get_xlabel()
        assert "[" in ax.get_ylabel() and "]" in ax.get_ylabel(), ax.get_ylabel()


def test_envelope_plots_the_frames_values(sweep, tmp_path):
    df, _ = sweep
    fig = plot.envelope(df, "tiny")
    fig.savefig(tmp_path / "env.png")
    assert (tmp_path / "env.png").stat().st_size > 1000
    _labels_have_units(fig)
    assert "tiny" in fig._suptitle.get_text()
    use = plot.usable(df)
    ax = fig.axes[0]  # peak_lp
    for line, (_, grp) in zip(ax.lines, use.groupby("friction"), strict=True):
        expect = grp.groupby("slope_deg")["drive_sum_peak_lp"].max()
        np.testing.assert_allclose(line.get_xdata(), expect.index)
        np.testing.assert_allclose(line.get_ydata(), expect.to_numpy())


def test_heatmap_values_and_frontier(sweep):
    df, _ = sweep
    fig = plot.heatmap(df, "tiny")
    _labels_have_units(fig)
    assert "tiny" in fig.axes[0].get_title()
    mesh = fig.axes[0].collections[0]
    ok = df[~df.slipping]
    grid = ok.pivot_table(index="friction", columns="slope_deg", values="drive_sum_peak_lp", aggfunc="max")
    grid = grid.reindex(index=[0.3, 0.9], columns=[0, 10, 20])
    np.testing.assert_allclose(np.ma.filled(mesh.get_array(), np.nan).reshape(grid.shape), grid.to_numpy())
    assert np.isnan(grid.loc[0.3, 20])  # tan(20 deg) > 0.3: every variant slips, the cell is blank
    assert "(blank: slips)" in fig.axes[0].get_title()  # variants slip here, and only then is it said


def test_steering_envelope_and_operating_points(sweep):
    df, _ = sweep
    fig = plot.steering_envelope(df, "tiny", x="slope_deg", curve="friction")
    _labels_have_units(fig)
    worst = df[[f"steer_{c}_peak_lp" for c in ("lf", "rf", "lr", "rr")]].abs().max(axis=1)
    for line, mu in zip(fig.axes[0].lines, (0.3, 0.9), strict=True):  # one curve per friction
        expect = worst[df.friction == mu].groupby(df.slope_deg).max()
        np.testing.assert_allclose(line.get_xdata(), expect.index)
        np.testing.assert_allclose(line.get_ydata(), expect.to_numpy())
    # K 0.1 N m/A, R 1 Ohm, 24 V, 5 A, N 20, eta 0.9: 1.8 N m at the wheel per A; continuous 9 N m at the wheel
    motor = DCMotor("M", nominal_voltage=24.0, terminal_resistance=1.0, torque_constant=0.1,
                    max_continuous_current=5.0, gear_ratio=20.0, gear_efficiency=0.9)  # fmt: skip
    fig = plot.operating_points(df, "tiny", motor)
    _labels_have_units(fig)
    ax = fig.axes[0]
    rms = df[[f"drive_{c}_rms" for c in ("lf", "rf", "lr", "rr")]].abs().max(axis=1)
    peak = df[[f"drive_{c}_peak_lp_all" for c in ("lf", "rf", "lr", "rr")]].abs().max(axis=1)
    np.testing.assert_allclose(ax.collections[0].get_offsets()[:, 0], df.wheel_speed.abs())
    np.testing.assert_allclose(ax.collections[0].get_offsets()[:, 1], rms)
    np.testing.assert_allclose(ax.collections[1].get_offsets()[:, 1], peak)
    line = ax.lines[0]  # the voltage line: 1.8 x 24 / 1 = 43.2 N m at stall, 0 at 24 / (0.1 x 20) = 12 rad/s
    assert line.get_ydata()[0] == pytest.approx(43.2) and line.get_xdata()[-1] == pytest.approx(12.0)
    assert line.get_ydata()[-1] == pytest.approx(0.0, abs=1e-9)
    assert ax.lines[1].get_ydata()[0] == pytest.approx(9.0)


def test_sweep_figures_and_seed_figures_of_a_variant(sweep, tmp_path):
    df, out = sweep
    paths = plot.sweep_figures(df, "tiny", tmp_path)
    assert {p.name for p in paths} >= {"envelope.png", "heatmap.png"}
    from batchveh.sweeping.spec import spec_of_result

    row = df.iloc[7]
    vehicle, scenario = spec_of_result(out).variant(row)
    assert scenario.slope_deg == row.slope_deg and scenario.friction == row.friction
    res = batchveh.simulate(vehicle, scenario)
    # the same physics up to the model's gravity: the sweep computes it per variant in float64, the
    # single run's model in float32 (Scenario.gravity_vector), 5e-8 apart. With the linear ramp that
    # difference stayed 5e-8 in this row, but smooth_step's higher peak acceleration (3.1 m/s^2 over
    # 0.5 s to 3 km/h) makes the front/rear split sensitive (a 1e-6 change of the slope moves the
    # per-wheel series by 0.05 N m), and the drive sum's window mean inherits a little of it. Measured
    # 2.45e-6 for this row, the worst of the sweep's non-slipping rows; a variant set up wrongly (one
    # grid step of slope, friction or speed) would be off by percents
    np.testing.assert_allclose(res.stats["drive_sum_mean"], row.drive_sum_mean, rtol=1e-5)
    figs = plot.seed_figures(res.series, tmp_path / "seed", "variant 7")
    assert len(figs) == 4 and all(p.exists() for p in figs)


# --- sampled sweeps (random, LHS, Sobol'): binned envelopes and heatmaps ------------------


def _sampled_frame(n=300, seed=1, slips=False, diagonal=False):
    """A synthetic LHS-like result: three uniform parameters, torques rising with slope and speed,
    a few failed and unsteady rows; `slips`: the variants above the static limit (and a few more)
    slip; `diagonal`: friction follows slope, so the off-diagonal cells of a heatmap hold none."""
    rng = np.random.default_rng(seed)
    slope = rng.uniform(0.0, 25.0, n)
    friction = 0.3 + 0.6 * slope / 25.0 + rng.normal(0, 0.02, n) if diagonal else rng.uniform(0.3, 0.9, n)
    df = pd.DataFrame({"slope_deg": slope, "friction": friction, "speed_kmh": rng.uniform(1.0, 3.0, n)})
    df["drive_sum_peak_lp"] = 4.0 * slope + 8.0 * df.speed_kmh + rng.gamma(2.0, 3.0, n)
    df["drive_sum_rms"] = 0.8 * df.drive_sum_peak_lp + rng.normal(0, 1.0, n)
    df["status"] = np.where(rng.random(n) < 0.03, "diverged", "ok")
    df["slipping"] = (np.tan(np.deg2rad(slope)) > 0.9 * friction) if slips else False
    df["steady"] = rng.random(n) > 0.05
    return df


def _bins_by_numpy(x, k):
    """Equal-count bins computed here, apart from the plotting code: masks of the k bins of x."""
    edges = np.quantile(x, np.linspace(0.0, 1.0, k + 1))
    return [
        (x >= lo) & ((x < hi) if i < k - 1 else (x <= hi))
        for i, (lo, hi) in enumerate(zip(edges[:-1], edges[1:], strict=True))
    ]


def test_is_sampled_reads_the_data():
    grid = pd.DataFrame(
        [(s, f, v) for s in (0, 10, 20) for f in (0.3, 0.9) for v in (1, 3)],
        columns=["slope_deg", "friction", "speed_kmh"],
    )
    assert not plot.is_sampled(grid)
    assert plot.is_sampled(_sampled_frame(60))
    from batchveh.sweeping.spec import saltelli_sample

    sobol = pd.DataFrame(saltelli_sample(3, 16, 0), columns=["slope_deg", "friction", "speed_kmh"])
    assert plot.is_sampled(sobol)  # each value repeated (2D + 2 rows a base point), still far from a grid
    assert not plot.is_sampled(_sampled_frame(60)[["slope_deg"]])  # one parameter: a line through every variant
    assert plot.is_sampled(grid, sampled=True) and not plot.is_sampled(_sampled_frame(60), sampled=False)


def test_sampled_envelope_is_the_binned_quantiles(tmp_path):
    df = _sampled_frame(300, slips=True)
    fig = plot.envelope(df, "lhs")
    fig.savefig(tmp_path / "env.png")
    _labels_have_units(fig)
    use = df[(df.status == "ok") & ~df.slipping & df.steady]
    assert len(use) >= 150  # so 15 bins (n // 10, at most 15), each of at least 10 variants
    params, stats = ["slope_deg", "friction", "speed_kmh"], ["peak_lp", "rms"]
    assert len(fig.axes) == len(params) * len(stats)  # a row per swept parameter, a column per statistic
    for r, x in enumerate(params):
        for c, stat in enumerate(stats):
            ax = fig.axes[r * len(stats) + c]
            assert ax.get_xlabel() == plot.label(x)
            xs, ys = use[x].to_numpy(), use[f"drive_sum_{stat}"].to_numpy()
            masks = _bins_by_numpy(xs, 15)
            assert all(m.sum() >= 10 for m in masks) and sum(m.sum() for m in masks) == len(use)
            expect = np.array([np.percentile(ys[m], [5, 50, 95, 99]).tolist() + [ys[m].max()] for m in masks])
            lines = {line.get_gid(): line for line in ax.lines}
            for k, gid in enumerate(("p5", "median", "p95", "p99", "max")):
                np.testing.assert_allclose(lines[gid].get_xdata(), [np.median(xs[m]) for m in masks])
                np.testing.assert_allclose(lines[gid].get_ydata(), expect[:, k], err_msg=f"{x} {stat} {gid}")
            assert any(coll.get_gid() == "band" for coll in ax.collections)
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) == 1  # one legend, a fixed set of entries: never one per distinct value
    texts = [t.get_text() for t in legends[0].get_texts()]
    assert len(texts) == 5 and not any("=" in t for t in texts), texts


def test_sampled_heatmap_is_binned_and_says_slips_only_when_some_slip():
    for slips in (False, True):
        df = _sampled_frame(400, seed=2, diagonal=True)
        df["slipping"] = slips & (df.slope_deg > 20.0)  # the steepest fifth slips
        fig = plot.heatmap(df, "lhs", bins=5)
        _labels_have_units(fig)
        ax = fig.axes[0]
        keep = ((df.status == "ok") & ~df.slipping).to_numpy()
        y_masks, x_masks = _bins_by_numpy(df.friction.to_numpy(), 5), _bins_by_numpy(df.slope_deg.to_numpy(), 5)
        val = df.drive_sum_peak_lp.to_numpy()
        expect = np.full((5, 5), np.nan)
        count = np.zeros((5, 5), int)
        for j, my in enumerate(y_masks):
            for i, mx in enumerate(x_masks):
                count[j, i] = (my & mx).sum()
                if (my & mx & keep).any():
                    expect[j, i] = np.percentile(val[my & mx & keep], 95)
        got = np.ma.filled(ax.collections[0].get_array().astype(float), np.nan).reshape(5, 5)
        np.testing.assert_allclose(got, expect)
        title = ax.get_title()
        assert "p95" in title and "drive_sum_peak_lp" in title
        assert (count == 0).any() and "blank: no variants" in title  # the diagonal leaves cells without variants
        assert ("slip" in title.lower()) == slips, title
        assert ("grey: every variant slips" in title) == bool(((count > 0) & np.isnan(expect)).any())
        assert "no variants" in title or not (count == 0).any()


def test_grid_heatmap_without_slips_says_nothing_of_slips():
    df = _sampled_frame(12)  # the columns; values replaced by a 3 x 2 x 2 grid
    df[["slope_deg", "friction", "speed_kmh"]] = [(s, f, v) for s in (0, 5, 10) for f in (0.6, 0.9) for v in (1, 3)]
    df["status"], df["slipping"] = "ok", False
    fig = plot.heatmap(df, "grid")
    assert "slip" not in fig.axes[0].get_title()
    assert not np.isnan(np.ma.filled(fig.axes[0].collections[0].get_array().astype(float), np.nan)).any()


@pytest.fixture(scope="module")
def lhs_sweep(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plots_lhs")
    raw = {
        "name": "tiny_lhs",
        "scenario": "straight_line",
        "fixed": {"total_time": 1.5, "ramp_time": 0.5},
        "sweep": {
            "method": "lhs",
            "n": 40,
            "seed": 0,
            "params": {
                "slope_deg": {"low": 0.0, "high": 25.0},
                "friction": {"low": 0.3, "high": 0.9},
                "speed_kmh": {"low": 1.0, "high": 3.0},
            },
        },
    }
    path = tmp / "tiny_lhs.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    out = tmp / "res"
    spec = batchveh.load_spec(path)
    batchveh.run_sweep(spec, out=out, backend="mujoco", progress=False)
    return batchveh.load(out), out, list(spec.params)


def test_sweep_figures_on_a_real_lhs_sweep(lhs_sweep):
    df, out, swept = lhs_sweep
    assert plot.is_sampled(df, swept)
    paths = plot.sweep_figures(df, "tiny_lhs", out, swept=swept)  # as --plots calls it, into the result
    assert {p.name for p in paths} == {"envelope.png", "heatmap.png"} and all(p.stat().st_size > 1000 for p in paths)
    fig = plot.envelope(df, "tiny_lhs", swept=swept, units=batchveh.units(out))
    _labels_have_units(fig)
    assert len(fig.axes) == 2 * len(swept)
    texts = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()]
    assert texts and not any("=" in t for t in texts), texts  # no 'friction = 0.400072'
    median = {line.get_gid(): line for line in fig.axes[0].lines}["median"]
    assert 3 <= len(median.get_xdata()) <= 15  # bins, not a point per variant
    title = plot.heatmap(df, "tiny_lhs", swept=swept).axes[0].get_title()
    assert ("slip" in title) == bool(df.slipping.any()), title
