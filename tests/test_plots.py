"""Plot functions on a small real sweep: files, labelled axes, plotted values equal the DataFrame's."""

import numpy as np
import pytest
import yaml

import batchveh
from batchveh.analysis import plot
from batchveh.analysis.motors import Motor, check


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


def test_steering_envelope_and_operating_points(sweep):
    df, _ = sweep
    fig = plot.steering_envelope(df, "tiny", x="slope_deg", curve="friction")
    _labels_have_units(fig)
    worst = df[[f"steer_{c}_peak_lp" for c in ("lf", "rf", "lr", "rr")]].abs().max(axis=1)
    for line, mu in zip(fig.axes[0].lines, (0.3, 0.9), strict=True):  # one curve per friction
        expect = worst[df.friction == mu].groupby(df.slope_deg).max()
        np.testing.assert_allclose(line.get_xdata(), expect.index)
        np.testing.assert_allclose(line.get_ydata(), expect.to_numpy())
    motor = Motor(name="M", continuous_torque=2.0, peak_torque=5.0, max_speed=800, corner_speed=500, gear_ratio=20)
    fig = plot.operating_points(df, "tiny", motor)
    _labels_have_units(fig)
    pts = fig.axes[0].collections[0].get_offsets()
    c = check(df, motor)
    np.testing.assert_allclose(pts[:, 0], c.shaft_speed)
    np.testing.assert_allclose(pts[:, 1], c.shaft_rms)
    peaks = fig.axes[0].collections[1].get_offsets()
    np.testing.assert_allclose(peaks[:, 0], c.shaft_speed)
    np.testing.assert_allclose(peaks[:, 1], c.shaft_peak)


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
