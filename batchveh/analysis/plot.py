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

from batchveh.config import ConfigError
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


def label(name: str, units: dict[str, str] | None = None) -> str:
    """Axis label with unit for a parameter or result column (`units`: the result file's, batchveh.units)."""
    if name in LABELS:
        return LABELS[name]
    if units and units.get(name):
        return f"{name} [{units[name]}]"
    from batchveh.model.params import parameter_specs
    from batchveh.sweeping.results import column_doc

    param_units = {k: spec.get("unit", "") for k, spec in parameter_specs().items()}
    unit = column_doc(name, param_units)[0]
    return f"{name} [{unit}]" if unit else name


def torque_label(motor: str, stat: str, units: dict[str, str] | None = None) -> str:
    """Axis label of a torque statistic `motor_stat` (e.g. drive_sum, peak_lp), with its unit."""
    unit = (units or {}).get(f"{motor}_{stat}") or "N m"
    if motor == "steer_worst":
        return f"steering {stat} torque, worst corner [{unit}]"
    return f"{motor} {stat} torque [{unit}]"


def usable(df: pd.DataFrame) -> pd.DataFrame:
    """Rows whose statistics describe a held, steady state: status ok, not slipping, steady window."""
    keep = df["status"] == "ok"
    if "slipping" in df:
        keep &= ~df["slipping"].astype(bool)
    if "steady" in df:
        keep &= df["steady"].astype(bool)
    return df[keep]


# --- sampled sweeps (random, LHS, Sobol') --------------------------------------------
# Nearly every value of a sampled parameter is distinct, so a curve per value (the grid
# envelope) or a cell per value pair (the grid heatmap) draws isolated dots. These sweeps
# are drawn binned instead: equal-count bins of a parameter, and quantiles of the torque
# over the variants in each bin.

SAMPLED_METHODS = ("random", "lhs", "sobol")  # batchveh.sweeping.spec.SAMPLED
MIN_PER_BIN, MAX_BINS = 10, 15  # envelope bins: at least 10 variants each, at most 15 bins
BAND = (5, 95)  # the shaded band: these percentiles of the variants in a bin


def swept_columns(df: pd.DataFrame, swept: list[str] | None = None) -> list[str]:
    """`swept` (those in `df`), or else the known parameters among `df`'s columns."""
    if swept is None:
        from batchveh.model.params import parameter_specs

        return [c for c in df.columns if c in parameter_specs()]
    return [c for c in swept if c in df]


def is_sampled(df: pd.DataFrame, swept: list[str] | None = None, sampled: bool | None = None) -> bool:
    """Whether a sweep's variants are sampled (random, LHS, Sobol') rather than a grid.

    `sampled` (e.g. the spec's `sweep.method in SAMPLED_METHODS`) decides when given. Else from
    the data: a grid's rows are the combinations of its parameters' levels, so the product of the
    distinct values of each swept column is the number of rows; a sampled sweep's values are
    nearly all distinct (a Sobol' sweep's repeat 2D + 2 times), so that product is far above it.
    Sampled: more than twice the rows (a grid run with --limit to under half reads as sampled).
    One swept parameter is drawn as a grid (a line through every variant is exact).
    """
    if sampled is not None:
        return bool(sampled)
    cols = swept_columns(df, swept)
    if len(cols) < 2 or df.empty:
        return False
    combinations = float(np.prod([df[c].nunique() for c in cols], dtype=float))
    return combinations > 2 * len(df)


def auto_bins(n: int) -> int:
    """Bins of an envelope over `n` variants: n // 10 (at least 10 each), 1 to 15."""
    return int(np.clip(n // MIN_PER_BIN, 1, MAX_BINS))


def equal_count_edges(x, bins: int | None = None) -> np.ndarray:
    """Edges of `bins` (default auto_bins) equal-count bins of `x`: its quantiles at k / bins, duplicates
    (ties) merged. Bin i holds edges[i] <= x < edges[i + 1], the last one also x == edges[-1]."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return np.array([0.0, 1.0])
    edges = np.unique(np.quantile(x, np.linspace(0.0, 1.0, (bins or auto_bins(len(x))) + 1)))
    return edges if len(edges) > 1 else np.array([edges[0], edges[0]])


def bin_index(x, edges: np.ndarray) -> np.ndarray:
    """The bin of each x (equal_count_edges' convention), clipped into the first and last bin."""
    return np.clip(np.searchsorted(edges, np.asarray(x, dtype=float), side="right") - 1, 0, len(edges) - 2)


def binned_quantiles(x, y, edges: np.ndarray) -> pd.DataFrame:
    """Per non-empty bin of `x`: its edges (lo, hi), the median x of its variants (x), their number (n)
    and y's percentiles p5, p50, p95, p99 (numpy's linear interpolation) and max."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    idx = bin_index(x, edges)
    rows = []
    for i in np.unique(idx):
        xs, ys = x[idx == i], y[idx == i]
        p5, p50, p95, p99 = np.percentile(ys, [BAND[0], 50, BAND[1], 99])
        rows.append(
            {"lo": edges[i], "hi": edges[i + 1], "x": np.median(xs), "n": len(ys), "p5": p5, "p50": p50}
            | {"p95": p95, "p99": p99, "max": ys.max()}
        )
    return pd.DataFrame(rows, columns=["lo", "hi", "x", "n", "p5", "p50", "p95", "p99", "max"])


def _binned_envelope(
    data: pd.DataFrame,
    name: str,
    motor: str,
    xs: list[str],
    stats: tuple[str, ...],
    bins: int | None,
    units: dict[str, str] | None,
    kept: str,
) -> plt.Figure:
    """A row of axes per parameter in `xs`, a column per statistic: the binned quantile band."""
    fig, axes = plt.subplots(
        len(xs),
        len(stats),
        figsize=(5.5 * len(stats) + 1.6, 3.3 * len(xs) + 0.7),
        constrained_layout=True,
        squeeze=False,
        sharey="col",
    )
    for r, x in enumerate(xs):
        for c, stat in enumerate(stats):
            ax, col = axes[r][c], f"{motor}_{stat}"
            sub = data[[x, col]].dropna()
            ax.set_xlabel(label(x, units))
            ax.set_ylabel(torque_label(motor, stat, units))
            ax.grid(alpha=0.3)
            if sub.empty:
                ax.text(0.5, 0.5, "no variants to draw", transform=ax.transAxes, ha="center", va="center")
                continue
            edges = equal_count_edges(sub[x], bins)
            q = binned_quantiles(sub[x], sub[col], edges)
            ax.scatter(sub[x], sub[col], s=5, color="0.55", alpha=0.5, lw=0, label="a variant", rasterized=True)
            ax.fill_between(
                q["x"], q["p5"], q["p95"], color="C0", alpha=0.25, lw=0, label="p5-p95 in a bin", gid="band"
            )
            ax.plot(q["x"], q["p5"], color="C0", lw=0.6, label="_p5", gid="p5")
            ax.plot(q["x"], q["p95"], color="C0", lw=0.6, label="_p95", gid="p95")
            ax.plot(q["x"], q["p50"], color="C0", lw=1.8, marker=".", label="median in a bin", gid="median")
            ax.plot(q["x"], q["p99"], color="C3", lw=1.0, ls="--", label="p99 in a bin", gid="p99")
            ax.plot(q["x"], q["max"], color="C3", ls="none", marker="^", ms=4, label="max in a bin", gid="max")
            ax.set_xticks(edges, minor=True)  # the bin edges, as minor ticks
            ax.tick_params(axis="x", which="minor", length=5, color="C0")
            ax.set_title(f"{stat}: {len(q)} equal-count bins, {q['n'].min()}-{q['n'].max()} variants each", fontsize=10)
    axes[0][-1].legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    what = {"drive_sum": "drive_sum torque", "steer_worst": "steering torque (worst corner)"}.get(motor, motor)
    fig.suptitle(f"sweep '{name}': {what} against each swept parameter\n({len(data)} variants: {kept})")
    return fig


def envelope(
    df: pd.DataFrame,
    name: str,
    *,
    motor: str = "drive_sum",
    x: str | None = None,
    curve: str | None = "friction",
    band: str | None = "speed_kmh",
    stats: tuple[str, ...] = ("peak_lp", "rms"),
    rows: str = "usable",
    max_curves: int = 6,
    swept: list[str] | None = None,
    sampled: bool | None = None,
    bins: int | None = None,
    units: dict[str, str] | None = None,
) -> plt.Figure:
    """Torque envelopes: `motor`'s statistics against `x`.

    Grid sweeps (x default slope_deg): one curve per `curve` value; the line is the maximum over
    `band` (e.g. speed), the shaded band spans min to max over it; at most `max_curves` evenly
    spaced values of `curve`.

    Sampled sweeps (random, LHS, Sobol': is_sampled(df, swept, sampled)): a row of axes per swept
    parameter (or only `x`), each with the statistic's p5-p95 band, median, p99 and max over the
    variants in each of `bins` equal-count bins of the parameter (default auto_bins: n // 10, at
    most 15), each variant a grey dot; `curve`, `band` and `max_curves` are not used.

    By default only usable rows (ok, not slipping, steady) are drawn. `units`: the result
    file's (batchveh.units), for the axis labels.
    """
    data = usable(df) if rows == "usable" else df
    if is_sampled(df, swept, sampled):
        xs = [x] if x is not None else swept_columns(df, swept)
        kept = "ok, not slipping, steady" if rows == "usable" else "all"
        return _binned_envelope(data, name, motor, xs, stats, bins, units, f"{kept}, of {len(df)}")
    x = x or "slope_deg"
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
        ax.set_xlabel(label(x, units))
        ax.set_ylabel(torque_label(motor, stat, units))
        ax.grid(alpha=0.3)
        ax.set_title(f"{stat}: max over {band} (band: min-max)" if band else f"{stat}: max over the other parameters")
    axes[0][-1].legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle(f"sweep '{name}': {motor} torque envelope")
    return fig


HEATMAP_AGG = {"mean": "mean", "median": "median", "p95": 0.95, "max": "max"}


def _binned_heatmap(
    df: pd.DataFrame,
    name: str,
    col: str,
    x: str,
    y: str,
    agg: str,
    bins: int | None,
    units: dict[str, str] | None,
) -> plt.Figure:
    """`agg` of `col` over the ok, non-slipping variants in each cell of equal-count bins of x and y."""
    if agg not in HEATMAP_AGG:
        raise ValueError(f"agg {agg!r} is not allowed; allowed: {', '.join(HEATMAP_AGG)}")
    k = bins or int(np.clip(np.sqrt(len(df) / 5), 2, 12))  # about 5 variants a cell or more
    xe, ye = equal_count_edges(df[x], k), equal_count_edges(df[y], k)  # all variants: the cells cover the sweep
    ix, iy = bin_index(df[x], xe), bin_index(df[y], ye)
    slipping = df["slipping"].astype(bool).to_numpy() if "slipping" in df else np.zeros(len(df), bool)
    failed = (df["status"] != "ok").to_numpy()
    keep = ~slipping & ~failed
    shape = (len(ye) - 1, len(xe) - 1)
    grid = np.full(shape, np.nan)
    vals = pd.Series(df[col].to_numpy()[keep]).groupby([iy[keep], ix[keep]])
    how = HEATMAP_AGG[agg]
    for (j, i), v in (vals.quantile(how) if isinstance(how, float) else vals.agg(how)).items():
        grid[j, i] = v
    count = np.zeros(shape, int)
    np.add.at(count, (iy, ix), 1)
    dropped = (count > 0) & np.isnan(grid)  # variants here, but none kept
    fig, ax = plt.subplots(figsize=(8.5, 5.8), constrained_layout=True)
    mesh = ax.pcolormesh(xe, ye, np.ma.masked_invalid(grid), shading="flat", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=f"{agg} of {col} per cell [{(units or {}).get(col) or 'N m'}]")
    if dropped.any():
        ax.pcolormesh(xe, ye, np.ma.masked_where(~dropped, np.ones(shape)), cmap="Greys", vmin=0, vmax=4)
    if slipping.any():
        ax.scatter(df[x][slipping], df[y][slipping], marker="x", s=14, lw=0.8, color="r", label="a slipping variant")
    if x == "slope_deg" and y == "friction":
        s = np.linspace(xe[0], xe[-1], 200)
        ax.plot(s, np.tan(np.deg2rad(s)), "k--", lw=1.5, label="static limit tan(slope) = mu")
    ax.set_xlim(xe[0], xe[-1])
    ax.set_ylim(ye[0], ye[-1])
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", fontsize="small")
    ax.set_xlabel(label(x, units))
    ax.set_ylabel(label(y, units))
    notes = []
    if slipping.any():
        notes.append(f"{slipping.sum()} of {len(df)} variants slip, left out")
    if failed.any():
        notes.append(f"{failed.sum()} failed, left out")
    if dropped.any():
        why = " or ".join(w for w, flag in (("slips", slipping.any()), ("failed", failed.any())) if flag)
        notes.append(f"grey: every variant {why}")
    if (count == 0).any():
        notes.append("blank: no variants")
    ax.set_title(
        f"sweep '{name}': {agg} of {col} in each cell ({k} x {k} equal-count bins)"
        + (f"\n({'; '.join(notes)})" if notes else ""),
        fontsize=10,
    )
    return fig


def heatmap(
    df: pd.DataFrame,
    name: str,
    *,
    motor: str = "drive_sum",
    stat: str = "peak_lp",
    x: str = "slope_deg",
    y: str = "friction",
    swept: list[str] | None = None,
    sampled: bool | None = None,
    agg: str = "p95",
    bins: int | None = None,
    units: dict[str, str] | None = None,
) -> plt.Figure:
    """`x` by `y` map of `motor_stat` over the other parameters, non-slipping rows only.

    Grid sweeps: each cell is the largest value over the other parameters; cells where every
    variant slips are blank. The dashed line is the static no-slip frontier tan(slope) = mu;
    the step line is the observed frontier (lowest friction at which no variant of that slope slips).

    Sampled sweeps (is_sampled(df, swept, sampled)): `bins` (default sqrt(n / 5), 2 to 12)
    equal-count bins of x and of y; a cell's colour is `agg` (p95, max, mean or median) over its ok,
    non-slipping variants; cells whose variants all slip (or fail) are grey, cells without variants
    blank, slipping variants red crosses. The title says which kinds there are.
    """
    col = f"{motor}_{stat}"
    if is_sampled(df, swept, sampled):
        return _binned_heatmap(df, name, col, x, y, agg, bins, units)
    ok = df[(df["status"] == "ok") & ~df["slipping"].astype(bool)]
    grid = ok.pivot_table(index=y, columns=x, values=col, aggfunc="max")
    xs, ys = sorted(df[x].unique()), sorted(df[y].unique())
    grid = grid.reindex(index=ys, columns=xs)
    fig, ax = plt.subplots(figsize=(8, 5.5), constrained_layout=True)
    mesh = ax.pcolormesh(xs, ys, grid.to_numpy(), shading="nearest", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=torque_label(motor, stat, units))
    if x == "slope_deg" and y == "friction":
        s = np.linspace(min(xs), max(xs), 200)
        ax.plot(s, np.tan(np.deg2rad(s)), "k--", lw=1.5, label="static limit tan(slope) = mu")
        slips = df.groupby([x, y])["slipping"].any().unstack()
        frontier = [next((f for f in ys if not slips.loc[sx, f:].any()), np.nan) for sx in xs]
        ax.step(xs, frontier, "r-", where="mid", lw=1.5, label="observed: no variant slips above")
        ax.set_ylim(min(ys), max(ys))
        ax.legend(loc="upper left", fontsize="small")
    ax.set_xlabel(label(x, units))
    ax.set_ylabel(label(y, units))
    why = (("slips", df["slipping"].astype(bool).any()), ("failed", (df["status"] != "ok").any()))
    blank = [w for w, flag in why if flag]
    ax.set_title(
        f"sweep '{name}': max {motor} {stat} over the other parameters"
        + (f" (blank: {' or '.join(blank)})" if blank else "")
    )
    return fig


def steering_envelope(
    df: pd.DataFrame,
    name: str,
    *,
    x: str | None = "friction",
    curve: str = "yaw_rate_dps",
    stat: str = "peak_lp",
    swept: list[str] | None = None,
    sampled: bool | None = None,
    bins: int | None = None,
    units: dict[str, str] | None = None,
) -> plt.Figure:
    """The largest steering-motor statistic (over the four corners) against `x`, a curve per `curve`;
    for a sampled sweep (is_sampled) binned as `envelope` is, against `x` or (x None) each swept parameter."""
    data = df[df["status"] == "ok"].copy()
    data["steer_worst"] = data[[f"steer_{c}_{stat}" for c in CORNERS]].abs().max(axis=1)
    if is_sampled(df, swept, sampled):
        data[f"steer_worst_{stat}"] = data["steer_worst"]
        xs = [x] if x is not None else swept_columns(df, swept)
        return _binned_envelope(data, name, "steer_worst", xs, (stat,), bins, units, f"ok, of {len(df)}")
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    groups = data.groupby(curve) if curve in data else [("all", data)]
    for value, grp in groups:
        g = grp.groupby(x)["steer_worst"].max()
        ax.plot(g.index, g.to_numpy(), marker="o", label=f"{curve} = {value}")
    ax.set_xlabel(label(x, units))
    ax.set_ylabel(f"steering {stat} torque, worst corner [N m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title(f"sweep '{name}': steering torque envelope")
    return fig


def operating_points(df: pd.DataFrame, name: str, motor) -> plt.Figure:
    """Each variant's worst drive at the wheel (`batchveh.analysis.demand.demand`: the steady RMS and the whole
    run's low-pass peak against the wheel speed) over `motor`'s limits as the screen checks them: its voltage
    line eta N K (V - K N w) / R, its continuous torque eta N K i_max and its gearhead's intermittent rating
    (`motor`: a catalogue entry, batchveh.load_catalogue(path)[name])."""
    from batchveh.analysis.demand import demand

    need = demand(df)
    c = motor.resolved()
    per_amp = c["eta"] * c["N"] * c["K"]  # N m at the wheel per A
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    ax.scatter(need.speed, need.rms, s=8, label="RMS (steady window)")
    ax.scatter(need.speed, need.peak, s=8, marker="x", label="peak after low-pass (whole run)")
    w = np.linspace(0, c["V"] / (c["K"] * c["N"]), 300)
    ax.plot(w, per_amp * (c["V"] - c["K"] * c["N"] * w) / c["R"], "k-", label=f"{motor.name}: voltage line")
    if c["i_max"]:
        ax.axhline(per_amp * c["i_max"], color="k", ls="--", label=f"{motor.name}: continuous torque")
    if motor.gear_max_intermittent_torque is not None:
        ax.axhline(motor.gear_max_intermittent_torque, color="r", ls=":", label="gearhead: intermittent rating")
    ax.set_ylim(0, 1.3 * max(float(need.peak.max()), per_amp * c["i_max"]))
    ax.set_xlabel("wheel speed [rad/s]")
    ax.set_ylabel("wheel torque [N m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title(f"sweep '{name}': operating points vs {motor.name} (gear {c['N']:g}:1)")
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


def sweep_figures(
    df: pd.DataFrame,
    name: str,
    out_dir: str | Path,
    swept: list[str] | None = None,
    *,
    sampled: bool | None = None,
    units: dict[str, str] | None = None,
) -> list[Path]:
    """The figures that fit a sweep's parameters, as PNG in `out_dir` (the sweep CLI's --plots).

    `swept`: the swept parameter names in spec order (default: the known parameters in `df`).
    `sampled`: whether the sweep is random, LHS or Sobol' (default: is_sampled's reading of the
    data). `units`: the result file's (default: read from `out_dir` when it holds the result).

    Grid sweeps: an envelope against slope (or else the first swept parameter), one curve per
    the next swept parameter; the slope x friction heatmap when both are swept; the steering
    envelope when a steering parameter is swept.
    Sampled sweeps: binned envelopes against each swept parameter; a binned heatmap of slope x
    friction (or else the first two swept parameters); a binned steering envelope when a
    steering parameter is swept.
    """
    out_dir = Path(out_dir)
    swept = swept_columns(df, swept)
    if not swept:
        return []
    if units is None:
        from batchveh.sweeping.results import units as file_units

        try:
            units = file_units(out_dir)
        except (ConfigError, OSError, KeyError, TypeError):  # not a result folder: label() knows the units
            units = None
    steering = [p for p in ("yaw_rate_dps", "steer_deg", "turn_radius") if p in swept]
    if is_sampled(df, swept, sampled):
        figs = {"envelope.png": envelope(df, name, x=None, swept=swept, sampled=True, units=units)}
        if len(swept) > 1:
            x, y = ("slope_deg", "friction") if {"slope_deg", "friction"} <= set(swept) else swept[:2]
            figs["heatmap.png"] = heatmap(df, name, x=x, y=y, swept=swept, sampled=True, units=units)
        if steering:
            figs["steering.png"] = steering_envelope(df, name, x=None, swept=swept, sampled=True, units=units)
        return _save(figs, out_dir)
    x = "slope_deg" if "slope_deg" in swept else swept[0]
    others = [p for p in swept if p != x]
    curve = others[0] if others else None
    band = others[1] if len(others) > 1 else None
    figs = {"envelope.png": envelope(df, name, x=x, curve=curve, band=band, sampled=False, units=units)}
    if {"slope_deg", "friction"} <= set(swept):
        figs["heatmap.png"] = heatmap(df, name, sampled=False, units=units)
    if steering:
        over = [p for p in swept if p != steering[0]]
        figs["steering.png"] = steering_envelope(
            df, name, x=over[0] if over else steering[0], curve=steering[0], sampled=False, units=units
        )
    return _save(figs, out_dir)


def _save(figs: dict[str, plt.Figure], out_dir: Path) -> list[Path]:
    """Write each figure as `out_dir`/its name (PNG, 100 dpi), close it; return the paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for fname, fig in figs.items():
        fig.savefig(out_dir / fname, dpi=100)
        plt.close(fig)
        paths.append(out_dir / fname)
    return paths
