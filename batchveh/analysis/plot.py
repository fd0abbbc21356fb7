"""Figures: the seed's four torque figures, sweep envelopes and Sobol' indices, every axis with its unit.

Matplotlib picks its backend: inline in Jupyter, Agg on a machine without a display.

Smoothing is the seed's: every 10th sample, then a Gaussian filter with sigma = 5
(decimated) samples (scipy.ndimage.gaussian_filter1d).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from scipy.ndimage import gaussian_filter1d

from batchveh.model.vehicle import CORNERS

CORNER_TITLES = {"lf": "Left-Front", "rf": "Right-Front", "lr": "Left-Rear", "rr": "Right-Rear"}
SEED_DECIMATE, SEED_SIGMA = 10, 5.0


def smooth(time_s: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The seed's smoothing: every 10th sample, Gaussian filter sigma 5 samples."""
    t, v = np.asarray(time_s)[::SEED_DECIMATE], np.asarray(values)[::SEED_DECIMATE]
    return t, gaussian_filter1d(v, SEED_SIGMA) if len(v) > 1 else v


def torque_figure(series: pd.DataFrame, kind: str, smoothed: bool, title: str) -> plt.Figure:
    """2x2 figure of the drive or steering torques per corner (N m over s)."""
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True, constrained_layout=True)
    for ax, corner in zip(axes.ravel(), CORNERS, strict=True):
        t, y = series["time"].to_numpy(), series[f"{kind}_{corner}"].to_numpy()
        if smoothed:
            t, y = smooth(t, y)
        ax.plot(t, y, lw=1.0)
        ax.set_title(CORNER_TITLES[corner])
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"{'driving' if kind == 'drive' else 'steering'} torque [N m]")
        ax.grid(alpha=0.3)
    fig.suptitle(
        f"{title}: {'driving' if kind == 'drive' else 'steering'} motor torques{' (smoothed)' if smoothed else ''}"
    )
    return fig


def seed_figures(series: pd.DataFrame, out_dir: str | Path, title: str) -> list[Path]:
    """Write the seed's four figures (driving/steering, raw/smoothed) as PNG; return their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for kind in ("drive", "steer"):
        for smoothed in (False, True):
            fig = torque_figure(series, kind, smoothed, title)
            path = out_dir / f"{kind}_torques{'_smoothed' if smoothed else ''}.png"
            fig.savefig(path, dpi=100)
            plt.close(fig)
            paths.append(path)
    return paths


# --- sweep figures -------------------------------------------------------------------
# Each takes a sweep DataFrame (batchveh.load) and the sweep's name, labels every axis
# with its unit, and plots exactly the DataFrame's values (tests read them back).

LABELS = {
    "slope_deg": "slope [deg]",
    "friction": "friction coefficient [-]",
    "speed_kmh": "speed [km/h]",
    "gravity": "gravity [m/s^2]",
    "yaw_rate_dps": "yaw rate [deg/s]",
    "payload.mass": "payload [kg]",
    "steer_deg": "steering angle [deg]",
    "turn_radius": "turn radius [m]",
}


def label(name: str) -> str:
    """Axis label with unit for a parameter or result column."""
    if name in LABELS:
        return LABELS[name]
    from batchveh.model.params import parameter_specs
    from batchveh.sweeping.results import column_doc

    units = {k: spec.get("unit", "") for k, spec in parameter_specs().items()}
    unit = column_doc(name, units)[0]
    return f"{name} [{unit}]" if unit else name


def usable(df: pd.DataFrame) -> pd.DataFrame:
    """Rows whose statistics describe a held, steady state: status ok, not slipping, steady window."""
    keep = df["status"] == "ok"
    if "slipping" in df:
        keep &= ~df["slipping"].astype(bool)
    if "steady" in df:
        keep &= df["steady"].astype(bool)
    return df[keep]


def envelope(
    df: pd.DataFrame,
    name: str,
    *,
    motor: str = "drive_sum",
    x: str = "slope_deg",
    curve: str | None = "friction",
    band: str | None = "speed_kmh",
    stats: tuple[str, ...] = ("peak_lp", "rms"),
    rows: str = "usable",
    max_curves: int = 6,
) -> plt.Figure:
    """Torque envelopes: `motor`'s statistics against `x`, one curve per `curve` value.

    The line is the maximum over `band` (e.g. speed), the shaded band spans min to max
    over it. By default only usable rows (ok, not slipping, steady) are drawn, and at most
    `max_curves` evenly spaced values of `curve`.
    """
    data = usable(df) if rows == "usable" else df
    if curve is not None:
        values = np.sort(data[curve].unique())
        if len(values) > max_curves:
            values = values[np.round(np.linspace(0, len(values) - 1, max_curves)).astype(int)]
            data = data[data[curve].isin(values)]
    fig, axes = plt.subplots(1, len(stats), figsize=(6 * len(stats), 4.5), constrained_layout=True, squeeze=False)
    for ax, stat in zip(axes[0], stats, strict=True):
        col = f"{motor}_{stat}"
        for value, grp in data.groupby(curve) if curve else [(None, data)]:
            g = grp.groupby(x)[col]
            lo, hi = g.min(), g.max()
            ax.plot(hi.index, hi.to_numpy(), marker=".", label=f"{curve} = {value:g}" if curve else "all")
            if band is not None:
                ax.fill_between(lo.index, lo.to_numpy(), hi.to_numpy(), alpha=0.2)
        ax.set_xlabel(label(x))
        ax.set_ylabel(f"{motor} {stat} torque [N m]")
        ax.grid(alpha=0.3)
        ax.set_title(f"{stat}: max over {band} (band: min-max)" if band else f"{stat}: max over the other parameters")
    axes[0][-1].legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle(f"sweep '{name}': {motor} torque envelope")
    return fig


def heatmap(
    df: pd.DataFrame,
    name: str,
    *,
    motor: str = "drive_sum",
    stat: str = "peak_lp",
    x: str = "slope_deg",
    y: str = "friction",
) -> plt.Figure:
    """`x` by `y` map of the largest `motor_stat` over the other parameters, non-slipping rows only.

    Cells where every variant slips are blank. The dashed line is the static no-slip
    frontier tan(slope) = mu; the step line is the observed frontier (lowest friction
    at which no variant of that slope slips).
    """
    col = f"{motor}_{stat}"
    ok = df[(df["status"] == "ok") & ~df["slipping"].astype(bool)]
    grid = ok.pivot_table(index=y, columns=x, values=col, aggfunc="max")
    xs, ys = sorted(df[x].unique()), sorted(df[y].unique())
    grid = grid.reindex(index=ys, columns=xs)
    fig, ax = plt.subplots(figsize=(8, 5.5), constrained_layout=True)
    mesh = ax.pcolormesh(xs, ys, grid.to_numpy(), shading="nearest", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=f"{motor} {stat} torque [N m]")
    if x == "slope_deg" and y == "friction":
        s = np.linspace(min(xs), max(xs), 200)
        ax.plot(s, np.tan(np.deg2rad(s)), "k--", lw=1.5, label="static limit tan(slope) = mu")
        slips = df.groupby([x, y])["slipping"].any().unstack()
        frontier = [next((f for f in ys if not slips.loc[sx, f:].any()), np.nan) for sx in xs]
        ax.step(xs, frontier, "r-", where="mid", lw=1.5, label="observed: no variant slips above")
        ax.set_ylim(min(ys), max(ys))
        ax.legend(loc="upper left", fontsize="small")
    ax.set_xlabel(label(x))
    ax.set_ylabel(label(y))
    ax.set_title(f"sweep '{name}': max {motor} {stat} over the other parameters (blank: slips)")
    return fig


def steering_envelope(
    df: pd.DataFrame, name: str, *, x: str = "friction", curve: str = "yaw_rate_dps", stat: str = "peak_lp"
) -> plt.Figure:
    """The largest steering-motor statistic (over the four corners) against `x`, a curve per `curve`."""
    data = df[df["status"] == "ok"].copy()
    data["steer_worst"] = data[[f"steer_{c}_{stat}" for c in CORNERS]].abs().max(axis=1)
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    groups = data.groupby(curve) if curve in data else [("all", data)]
    for value, grp in groups:
        g = grp.groupby(x)["steer_worst"].max()
        ax.plot(g.index, g.to_numpy(), marker="o", label=f"{curve} = {value}")
    ax.set_xlabel(label(x))
    ax.set_ylabel(f"steering {stat} torque, worst corner [N m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title(f"sweep '{name}': steering torque envelope")
    return fig


def operating_points(df: pd.DataFrame, name: str, motor) -> plt.Figure:
    """Each variant's worst drive motor at the motor shaft (RMS and low-pass peak against
    speed) over `motor`'s continuous torque and torque-speed limit (a batchveh.analysis.motors.Motor)."""
    from batchveh.analysis.motors import check

    c = check(df, motor)
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    ax.scatter(c.shaft_speed, c.shaft_rms, s=8, label="RMS (steady window)")
    ax.scatter(c.shaft_speed, c.shaft_peak, s=8, marker="x", label="peak after low-pass (whole run)")
    w = np.linspace(0, motor.max_speed * 1.05, 300)
    ax.plot(w, motor.torque_limit(w), "k-", label=f"{motor.name}: peak torque limit")
    ax.axhline(motor.continuous_torque, color="k", ls="--", label=f"{motor.name}: continuous torque")
    ax.set_xlabel("motor speed [rad/s]")
    ax.set_ylabel("motor shaft torque [N m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title(f"sweep '{name}': operating points vs {motor.name} (gear {motor.gear_ratio:g}:1)")
    return fig


def mission_trace(series: pd.DataFrame, mission, group: str = "drive", title: str = "") -> plt.Figure:
    """A mission's motor torques against time (one run's series, batchveh.run.simulate), each
    segment shaded and named (`mission`: batchveh.model.missions.Mission, e.g. missions.mission_of)."""
    fig, ax = plt.subplots(figsize=(10, 4.5), constrained_layout=True)
    t = series["time"].to_numpy()
    ends = [mission.start(k) for k in range(1, len(mission.segments))] + [t[-1]]
    for k, seg in enumerate(mission.segments):
        t0, t1 = mission.start(k), ends[k]
        ax.axvspan(t0, t1, color=f"C{k % 10}", alpha=0.08, lw=0)
        ax.text(
            (t0 + t1) / 2,
            1.01,
            seg.name or seg.kind,
            transform=ax.get_xaxis_transform(),
            ha="center",
            va="bottom",
            fontsize="small",
        )
    for c in CORNERS:
        ax.plot(t, series[f"{group}_{c}"], lw=0.8, label=f"{group} {CORNER_TITLES[c]}")
    ax.set_xlabel("time [s]")
    where = "at the wheel" if group == "drive" else "about the steering axis"
    ax.set_ylabel(f"{group} motor torque {where} [N m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small", ncol=4, loc="lower left")
    ax.set_title(title or f"mission: {group} torques by segment", pad=18)
    return fig


def climb_limit(
    df: pd.DataFrame, name: str, *, x: str = "step_height", curve: str = "speed_kmh", rule: tuple | None = None
) -> tuple[plt.Figure, dict]:
    """The worst drive motor's whole-run low-pass peak against the obstacle's height, a curve per
    `curve`; variants that did not get over (status `stuck`) are crosses at their height, and
    each curve's climb limit (between its highest climbed and lowest stuck height) is drawn.
    `rule`: (W, r), a wheel's load in N and radius in m, draws the rule of thumb W sqrt(2 r h - h^2).
    Returns the figure and {curve value: (highest climbed, lowest stuck) in the units of x}."""
    data = df[df["status"].isin(["ok", "stuck"])].copy()
    data["drive_worst"] = data[[f"drive_{c}_peak_lp_all" for c in CORNERS]].abs().max(axis=1)
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    limits = {}
    for k, (value, grp) in enumerate(data.groupby(curve)):
        climbed, stuck = grp[grp.status == "ok"], grp[grp.status == "stuck"]
        g = climbed.groupby(x)["drive_worst"].max()
        ax.plot(g.index, g.to_numpy(), marker="o", color=f"C{k}", label=f"{label(curve)} = {value:g}")
        ax.plot(stuck[x], stuck["drive_worst"], "x", color=f"C{k}", ms=8)
        top, low = (climbed[x].max() if len(climbed) else np.nan), (stuck[x].min() if len(stuck) else np.nan)
        limits[value] = (top, low)
        if np.isfinite(top) and np.isfinite(low):
            ax.axvline((top + low) / 2, color=f"C{k}", ls=":", lw=1)
    if rule is not None:
        w, r = rule
        h = np.linspace(0, min(r, data[x].max() * 1.05), 200)
        ax.plot(h, w * np.sqrt(np.maximum(2 * r * h - h * h, 0)), "k--", lw=1, label="rule of thumb W sqrt(2rh - h²)")
    ax.set_xlabel(label(x))
    ax.set_ylabel("drive peak torque, worst wheel, 50 ms low-pass [N m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title(f"sweep '{name}': peak drive torque; x = stuck, dotted = climb limit")
    return fig, limits


# --- sensitivity figures ---------------------------------------------------------------
# Each takes the tidy table of batchveh.sensitivity (a row per statistic and parameter).


def sensitivity_bars(table: pd.DataFrame, statistic: str) -> plt.Figure:
    """S1 and ST of each swept parameter for one statistic, with their confidence intervals."""
    rows = table[table["statistic"] == statistic]
    if rows.empty:
        raise ValueError(f"statistic {statistic!r} is not in the table; it has {', '.join(table.statistic.unique())}")
    x, w = np.arange(len(rows)), 0.38
    fig, ax = plt.subplots(figsize=(max(5.0, 1.2 * len(rows) + 2), 4.2), constrained_layout=True)
    ax.bar(x - w / 2, rows["S1"], w, yerr=rows["S1_conf"], capsize=3, label="S1: alone")
    ax.bar(x + w / 2, rows["ST"], w, yerr=rows["ST_conf"], capsize=3, label="ST: with its interactions")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(x, [label(p) for p in rows["parameter"]], rotation=20, ha="right")
    ax.set_xlabel("swept parameter [unit]")
    ax.set_ylabel("Sobol' index [-]")
    low = min(0.0, float((rows["S1"] - rows["S1_conf"]).min()), float((rows["ST"] - rows["ST_conf"]).min()))
    ax.set_ylim(low - 0.02, max(1.05, float((rows["ST"] + rows["ST_conf"]).max()) + 0.02))
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize="small")
    first = rows.iloc[0]
    unit = f" [{first['unit']}]" if first["unit"] else ""
    ax.set_title(
        f"{statistic}{unit}: shares of its variance (std {first['std']:.3g}, {first['base_points']} base points)",
        fontsize="medium",
    )
    return fig


def sensitivity_heatmap(table: pd.DataFrame, statistics: list[str] | None = None, index: str = "ST") -> plt.Figure:
    """`index` (ST or S1) of each statistic (rows) and parameter (columns), the value in each cell; a cell
    whose confidence interval is wider than its index is written in brackets (not resolved from zero)."""
    data = table if statistics is None else table[table["statistic"].isin(statistics)]
    stats = list(dict.fromkeys(data["statistic"])) if statistics is None else list(statistics)
    params = list(dict.fromkeys(data["parameter"]))
    grid = data.pivot(index="statistic", columns="parameter", values=index).reindex(index=stats, columns=params)
    conf = data.pivot(index="statistic", columns="parameter", values=f"{index}_conf").reindex(
        index=stats, columns=params
    )
    fig, ax = plt.subplots(figsize=(2.0 + 1.25 * len(params), 1.2 + 0.42 * len(stats)), constrained_layout=True)
    mesh = ax.pcolormesh(grid.to_numpy(), cmap="viridis", vmin=0.0, vmax=1.0)
    fig.colorbar(mesh, ax=ax, label=f"{index} [-]")
    for i, stat in enumerate(stats):
        for j, p in enumerate(params):
            v, c = grid.loc[stat, p], conf.loc[stat, p]
            text = f"{v:.2f}" if 2 * c <= abs(v) else f"({v:.2f})"
            ax.text(j + 0.5, i + 0.5, text, ha="center", va="center", color="w" if v < 0.6 else "k", fontsize="small")
    ax.set_xticks(np.arange(len(params)) + 0.5, [label(p) for p in params], rotation=20, ha="right")
    ax.set_yticks(np.arange(len(stats)) + 0.5, stats)
    ax.invert_yaxis()
    ax.set_xlabel("swept parameter [unit]")
    ax.set_ylabel("statistic [its unit]")
    name = "total" if index == "ST" else "first-order"
    ax.set_title(f"{name} Sobol' index {index}; (brackets): interval wider than the index", fontsize="medium")
    return fig


def sweep_figures(df: pd.DataFrame, name: str, out_dir: str | Path, swept: list[str] | None = None) -> list[Path]:
    """The figures that fit a sweep's parameters, as PNG in `out_dir` (the sweep CLI's --plots).

    `swept`: the swept parameter names in spec order (default: the known parameters in `df`).
    An envelope against slope (or else the first swept parameter), one curve per the next
    swept parameter; the slope x friction heatmap when both are swept; the steering
    envelope when a steering parameter is swept.
    """
    from batchveh.model.params import parameter_specs

    out_dir = Path(out_dir)
    if swept is None:
        swept = [c for c in df.columns if c in parameter_specs()]
    if not swept:
        return []
    x = "slope_deg" if "slope_deg" in swept else swept[0]
    others = [p for p in swept if p != x]
    curve = others[0] if others else None
    band = others[1] if len(others) > 1 else None
    figs = {"envelope.png": envelope(df, name, x=x, curve=curve, band=band)}
    if {"slope_deg", "friction"} <= set(swept):
        figs["heatmap.png"] = heatmap(df, name)
    steering = [p for p in ("yaw_rate_dps", "steer_deg", "turn_radius") if p in swept]
    if steering:
        over = [p for p in swept if p != steering[0]]
        figs["steering.png"] = steering_envelope(df, name, x=over[0] if over else steering[0], curve=steering[0])
    paths = []
    for fname, fig in figs.items():
        fig.savefig(out_dir / fname, dpi=100)
        plt.close(fig)
        paths.append(out_dir / fname)
    return paths
