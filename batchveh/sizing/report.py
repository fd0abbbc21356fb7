"""The sizing report: one page an engineer can hand on, in Markdown and in static HTML, with its figures beside it.

`write(folder, sizing)` writes `report.md`, `report.html`, `figures/*.png` and `verdicts.parquet` from a
`Sizing` (what `batchveh.size` found: the servo sweep's rows, the screen's table, each in-loop run's rows and
table, the chosen motor, the worst variant's trace). Nothing here simulates: the figures read results.

The figures:
- the torque-speed plane of the chosen motor and the next smaller one, at the wheel: the voltage line at the bus
  voltage (eta N K (V - K N w) / R, at 25 deg C and at the hottest winding of the run), the continuous current's
  torque, the no-load speed, and each variant's operating points in the loop (its RMS torque at its mean speed,
  its low-pass peak);
- where the variants a motor misses sit in the swept parameters (the first two), by reason;
- the worst variant's winding temperature in time, and its bus power and energy against the battery's limits.
"""

from __future__ import annotations

import html
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from batchveh.analysis.demand import LAYOUT_TEXT, WHEELS, groups
from batchveh.sizing.figures import coverage_by_ratio, sheet_points
from batchveh.sizing.loop import (
    DIFFER,
    IN_LOOP_REASONS,
    IN_LOOP_TEXT,
    STEER_REASONS,
    STEER_TEXT,
    best_in_loop,
    not_simulated,
)
from batchveh.sizing.screening import REASON_TEXT, REASONS, bound_at_wheel
from batchveh.sizing.windows import LIMIT_TEXT, window_text

FIGURES = "figures"


@dataclass
class Sizing:
    """What a sizing run found (batchveh.size): the inputs, each pass's tables and rows, and the verdict."""

    name: str
    spec_text: str  # the sweep spec's YAML as given
    params: list[str]  # the swept parameters
    servo: pd.DataFrame  # the servo sweep's rows (the demand)
    screen: pd.DataFrame  # the screen's table, one row per catalogue motor
    loop: pd.DataFrame  # in_loop's table, one row per candidate run in the loop
    detail: dict[str, pd.DataFrame]  # per candidate run in the loop: its variants' columns and reasons
    chosen: str | None
    steer: str | None  # the steering motor; None: a skid-steered vehicle has none
    share: float
    catalogue: dict[str, Any]  # name -> batchveh.model.motors.DCMotor
    battery: Any = None  # batchveh.model.battery.Battery or None
    trace: pd.DataFrame | None = None  # the worst variant's time series (batchveh.size.trace)
    worst: dict[str, Any] = field(default_factory=dict)  # the worst variant's parameter values
    versions: dict[str, str] = field(default_factory=dict)
    wall_s: dict[str, float] = field(default_factory=dict)
    steer_screen: pd.DataFrame | None = None  # the steering's screen table, one row per catalogue motor
    steer_loop: pd.DataFrame | None = None  # every in_loop row run, each with its steering's verdict and `drive`
    not_run: dict[str, str] = field(default_factory=dict)  # drive motor -> why it did not run in the loop
    duty: float = 1.0  # the spec's duty: the share of the time the run repeats
    worst_note: str = ""  # whether the motor covers the hottest variant, and why not
    span: str | None = None  # the span the screen read: None the steady window, 'mission' the whole cycle
    steer_given: bool = False  # the steering motor named with --steer (never walked up)
    ratios: pd.DataFrame | None = None  # the drive's screen of every (motor, ratio) of the catalogue
    windows: pd.DataFrame | None = None  # each drive motor's ratio window (sizing.windows)
    steer_ratios: pd.DataFrame | None = None  # the steering's screen of every (motor, ratio)
    steer_windows: pd.DataFrame | None = None  # each steering motor's ratio window
    requirements: dict[str, Any] | None = None  # the requirement sheets (size.requirement_sheets)
    geometry: str = ""  # the steering geometry sized: each wheel's trail and scrub radius (model.vehicle.geometry_line)
    layout: str = "four_wheel"  # the vehicle's steering.layout: which hubs' motors are the steering group


def steering_motors(s: Sizing) -> tuple[str, ...]:
    """The steering group's motors on the session's layout (`analysis.demand.groups`): four, the front two, none."""
    return groups(s.layout)["steer"]


def steering_words(s: Sizing) -> str:
    """The steering in a few words, for the command's last line: 'steering <motor>' (four-wheel), with the front
    hubs named (front), or that there is none (skid)."""
    if not steering_motors(s):
        return LAYOUT_TEXT[s.layout]
    return f"steering {s.steer}" + (" (front hubs; rear hubs fixed)" if s.layout == "front" else "")


def motor_count(s: Sizing) -> str:
    """The bus's motors in words: the four drives and the steering motors ('eight', 'six', 'four')."""
    return {8: "eight", 6: "six", 4: "four"}[4 + len(steering_motors(s))]


def focus(s: Sizing) -> str | None:
    """The motor the figures show: the chosen one, else the best of those run in the loop (its coverage)."""
    return s.chosen if s.chosen is not None else best_in_loop(s.loop)


def smaller(s: Sizing) -> str | None:
    """The catalogue motor next below the chosen one (or the focus, where none is chosen) by continuous torque
    at the wheel, among those run in the loop, else in the screen's table."""
    ranked = list(s.screen["motor"])
    top = focus(s)
    if top is None or top not in ranked:
        return None
    below = ranked[: ranked.index(top)]
    in_loop = [m for m in below if m in s.detail]
    return (in_loop or below or [None])[-1]


def _screen_cells(r: Any, torque: str) -> dict[str, Any]:
    """A screen table row's cells for a verdict table: the motor, its ratio, its continuous torque at the wheel
    (column `torque`), its screen coverage and counted reasons with the commonest first one."""
    first = f"; first: {r['limiting']}" if r.get("limiting") else ""
    return {
        "motor": r["motor"],
        "ratio": f"{r['gear_ratio']:g}:1",
        torque: round(float(r["continuous_torque_at_wheel"]), 3),
        "screen": f"{r['coverage']:.1%}",
        "screen misses": _counts(r, REASONS) + first,
    }


def verdict_table(s: Sizing) -> pd.DataFrame:
    """One row per catalogue motor: its continuous torque at the wheel, the screen's coverage and counted
    reasons, and where it ran in the loop, the loop's coverage, counted reasons and the variants that could not
    be simulated."""
    rows = []
    loop = s.loop.set_index("motor") if len(s.loop) else pd.DataFrame()
    for _, r in s.screen.iterrows():
        name = r["motor"]
        row = _screen_cells(r, "continuous at wheel (N m)")
        if name in loop.index:
            q = loop.loc[name]
            row["in the loop"] = f"{q['coverage']:.1%}"
            first = q.get("limiting") or ""
            row["loop misses"] = _counts(q, IN_LOOP_REASONS) + (f"; first: {first}" if first else "")
            if steering_motors(s):
                row["steering misses (not counted)"] = str(int(q.get("steer_misses", 0)))
            row["not simulated"] = q["not_simulated_why"] if q["not_simulated"] else "0"
            if name == s.chosen:
                row["verdict"] = "chosen"
            elif int(q["not_simulated"]) == len(s.servo):  # no run to judge: nothing said of the motor
                row["verdict"] = f"not judged: no run in the loop could be simulated ({q['not_simulated_why']})"
            else:
                row["verdict"] = f"fails: covers {q['coverage']:.1%} < {s.share:.0%}; {_counts(q, IN_LOOP_REASONS)}"
        else:
            row["in the loop"], row["loop misses"] = "not run", ""
            if steering_motors(s):
                row["steering misses (not counted)"] = ""
            row["not simulated"] = ""
            row["verdict"] = f"not run: {s.not_run.get(name, 'not reached')}"
        rows.append(row)
    return pd.DataFrame(rows)


def steer_table(s: Sizing) -> pd.DataFrame:
    """One row per catalogue motor as the steering: the screen of the steering's demand (its RMS and low-pass
    peak over the whole run, or a duty cycle's), and where it ran in the loop, with which drive, its
    coverage on its own criteria and its reasons; the verdict."""
    if s.steer_screen is None:
        return pd.DataFrame()
    runs = s.steer_loop if s.steer_loop is not None else pd.DataFrame()
    rows = []
    for _, r in s.steer_screen.iterrows():
        name = r["motor"]
        row = _screen_cells(r, "continuous at the hinge (N m)")
        mine = runs[runs["steer"] == name] if len(runs) else runs
        if len(mine):
            last = mine.iloc[-1]
            row["in the loop (with drive)"] = "; ".join(
                f"{q['steer_coverage']:.1%} ({q['drive']})" for _, q in mine.iterrows()
            )
            row["loop misses"] = _counts(last, STEER_REASONS, prefix="steer_fails_")
            held = last["steer_coverage"] >= s.share
            row["verdict"] = (
                "chosen"
                if name == s.steer and held
                else ("kept (given with --steer), fails: " if s.steer_given else "kept (the largest), fails: ")
                + row["loop misses"]
                if name == s.steer
                else f"fails: covers {last['steer_coverage']:.1%} < {s.share:.0%}; {row['loop misses']}"
            )
        else:
            row["in the loop (with drive)"], row["loop misses"] = "not run", ""
            ranked = list(s.steer_screen["motor"])
            if name == s.steer:
                row["verdict"] = "chosen"
            elif ranked.index(name) < ranked.index(s.steer):
                row["verdict"] = f"not run: the screen's {r['coverage']:.1%} is below {s.share:.0%}"
            else:
                row["verdict"] = f"not run: a smaller steering motor ({s.steer}) holds"
        rows.append(row)
    return pd.DataFrame(rows)


def reason_table(s: Sizing) -> pd.DataFrame:
    """Screen against loop, reason by reason, for each drive motor run in the loop: each pass's count (the screen
    over every variant, the loop over those simulated with their steering held) and why the two read it apart."""
    screen = s.screen.set_index("motor")
    rows = []
    for _, q in s.loop.iterrows():
        for r in REASONS:
            a, b = int(screen.loc[q["motor"], f"fails_{r}"]), int(q[f"fails_{r}"])
            if a or b:
                rows.append({"motor": q["motor"], "reason": r.replace("_", " "), "screen": a, "loop": b,
                             "where the passes differ": DIFFER[r] if a != b else "they agree"})  # fmt: skip
    return pd.DataFrame(rows, columns=["motor", "reason", "screen", "loop", "where the passes differ"])


def _counts(row: Any, reasons: tuple[str, ...], prefix: str = "fails_") -> str:
    parts = [f"{k.replace('_', ' ')} {int(row[f'{prefix}{k}'])}" for k in reasons if row[f"{prefix}{k}"]]
    return ", ".join(parts) or "none"


def _judged_share(s: Sizing) -> str:
    """ " (the best: 46 of 48)": how many variants the screen of the chosen or best motor counted, where fewer than
    all."""
    name = focus(s) if len(s.loop) else None
    if name is None or "judged" not in s.screen:
        return ""
    judged, total = int(s.screen.set_index("motor").loc[name, "judged"]), len(s.servo)
    return f" ({name}: {judged} of {total})" if judged < total else ""


def _joined(bad: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """Per row of the booleans `bad` (rows, names), the names it holds, `;`-separated ("" for none)."""
    out = np.full(len(bad), "", dtype=object)
    for j, name in enumerate(names):
        hit = bad[:, j]
        out[hit] = np.where(out[hit] == "", name, out[hit] + ";" + name)
    return out


def verdicts(s: Sizing) -> pd.DataFrame:
    """Per variant and candidate run in the loop (long form): the swept values, `motor`, `fits`, the reasons it
    fails (`;`-separated, IN_LOOP_REASONS), `motor_status`, `motor_check`, whether it could be simulated, whether
    its steering held (`steer_held`) and why not (`steer_reasons`, STEER_REASONS). `fits` needs the steering held:
    a variant the steering missed is not judged for the drive. Also each run's motor_torque_ratio, its steering
    error (deg), its steering motors' largest share of the run at the current limit, and whether it passed the
    battery's energy or continuous power (`battery_over`, judged runs only: the battery's, never a motor's miss)."""
    frames = []
    for name, d in s.detail.items():
        why = d[[f"fails_{r}" for r in IN_LOOP_REASONS]].to_numpy(bool)
        lost = not_simulated(d)
        f = d[list(s.params)].copy()
        f.insert(0, "variant", np.arange(len(d)))
        f["motor"] = name
        steer_why = d[[f"steer_fails_{r}" for r in STEER_REASONS]].to_numpy(bool)
        f["simulated"] = ~lost
        f["steer_held"] = ~lost & ~steer_why.any(axis=1)
        f["fits"] = f["steer_held"].to_numpy() & ~why.any(axis=1)
        f["reasons"] = _joined(why, IN_LOOP_REASONS)
        f["steer_reasons"] = _joined(steer_why, STEER_REASONS)
        f["motor_status"] = d["motor_status"].to_numpy()
        f["motor_check"] = d["motor_check"].to_numpy()
        f["motor_torque_ratio"] = d["motor_torque_ratio"].to_numpy(float)
        f["steer_track_err_deg"] = d["steer_track_err_deg"].to_numpy(float)
        steer = [f"{m}_at_current_share" for m in steering_motors(s)]  # the steered hubs' (none: skid, 0)
        f["steer_at_current_share"] = d[steer].max(axis=1).to_numpy() if steer else np.zeros(len(d))
        f["battery_over"] = d["battery_over"].to_numpy(bool) if "battery_over" in d else np.zeros(len(d), bool)
        frames.append(f)
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


# --- the figures ---


def torque_speed(ax, s: Sizing, name: str) -> None:
    """One motor's torque-speed plane at the wheel, with its in-the-loop operating points."""
    c = s.catalogue[name].resolved()
    n, k, eta, r, v = c["N"], c["K"], c["eta"], c["R"], c["V"]
    w0 = v / (k * n)
    w = np.linspace(0.0, w0, 100)
    d = s.detail.get(name)
    hot = float(d[[f"{m}_winding_temp_peak" for m in WHEELS]].to_numpy().max()) if d is not None else 25.0
    for temp, style in ((25.0, "-"), (hot, "--")) if d is not None else ((25.0, "-"),):
        rt = r * (1 + 0.0039 * (temp - 25.0))
        ax.plot(w, eta * n * k * (v - k * n * w) / rt, "k" + style, lw=1, label=f"voltage line, winding {temp:.0f} C")
    if c["i_max"]:
        cont = eta * n * k * c["i_max"]
        ax.fill_between(w, 0, np.minimum(cont, eta * n * k * (v - k * n * w) / r), color="tab:green", alpha=0.15,
                        label=f"continuous current: {cont:.2f} N m")  # fmt: skip
    demand = s.servo  # the screen's demand: the servo's window RMS at its mean speed (grey, behind the loop's)
    rms_servo = demand[[f"{m}_rms" for m in WHEELS]].abs().max(axis=1).to_numpy()
    shared = "servo's RMS, worst wheel (the screen's demand;\nat most the bound where the other wheels can share)"
    ax.scatter(demand["wheel_speed"], rms_servo, s=5, color="0.7", label=shared)
    speed = demand["wheel_speed"].to_numpy(float)
    from batchveh.sizing.screening import mission_segments

    segs = mission_segments(d) if d is not None else []
    if segs:  # a duty cycle: each segment's peak torque at its peak speed, one colour a segment
        import matplotlib.pyplot as plt

        colours, peaks = plt.get_cmap("tab10"), []
        for j, g in enumerate(segs):
            sp = d[[f"{g}_{m}_speed_peak" for m in WHEELS]].abs().max(axis=1).to_numpy()
            pk = d[[f"{g}_{m}_peak_lp" for m in WHEELS]].abs().max(axis=1).to_numpy()
            ax.scatter(sp, pk, s=7, color=colours(j % 10), label=f"{g}: low-pass peak at its peak speed")
            peaks.append(pk)
        peak, speed = np.concatenate(peaks), np.abs(d["wheel_speed"].to_numpy(float))
    elif d is not None:  # signed: a vehicle its motor cannot hold on a climb rolls back (negative speed)
        speed = d["wheel_speed"].to_numpy(float)
        rms = d[[f"{m}_rms" for m in WHEELS]].abs().max(axis=1).to_numpy()
        peak = d[[f"{m}_peak_lp_all" for m in WHEELS]].abs().max(axis=1).to_numpy()
        ax.scatter(speed, peak, s=6, color="tab:orange", label="low-pass peak")
        ax.scatter(speed, rms, s=6, color="tab:blue", label="RMS (steady window)")
    top = eta * n * k * v / r
    if c["i_max"]:  # the region that matters: up to a few times the continuous torque, or the highest point
        seen = float(np.max(peak)) if d is not None else float(np.max(rms_servo))
        top = min(top, max(3 * eta * n * k * c["i_max"], 1.3 * seen))
    ax.set_xlim(min(0.0, 1.05 * float(np.min(speed))), w0 * 1.05)
    if np.min(speed) < 0:
        ax.axvline(0.0, color="k", lw=0.5)
    ax.set_ylim(0, top)
    ax.set_xlabel("wheel speed (rad/s; < 0: rolled back)" if np.min(speed) < 0 else "wheel speed (rad/s)")
    ax.set_ylabel("drive torque at the wheel (N m)")
    ran = "in the loop" if d is not None else "not run in the loop: the servo's demand only"
    ax.set_title(f"{name}\n{n:g}:1, eta {eta:g}, {v:g} V; {ran}", fontsize=9)
    ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # beside: the lines stay clear


def telling(d: pd.DataFrame, params: list[str], missed: np.ndarray) -> list[str]:
    """The swept parameters, those that tell missed from covered variants best first: the difference of their
    means over the parameter's spread (the swept order where nothing is missed)."""
    if not missed.any() or missed.all():
        return list(params)

    def score(k: str) -> float:
        v = d[k].to_numpy(float)
        return abs(v[missed].mean() - v[~missed].mean()) / (v.std() or 1.0)

    return sorted(params, key=score, reverse=True)


def misses(ax, s: Sizing, name: str) -> None:
    """Where the variants `name` misses in the loop sit in the two swept parameters that tell them apart best,
    by reason."""
    d = s.detail[name]
    failed = d[[f"fails_{r}" for r in IN_LOOP_REASONS]].to_numpy(bool).any(axis=1)
    order = telling(d, [k for k in s.params if np.issubdtype(d[k].dtype, np.number)], failed)
    x, y = order[0], (order[1] if len(order) > 1 else None)
    yv = d[y].to_numpy(float) if y else np.zeros(len(d))
    lost = not_simulated(d)
    why = d[[f"fails_{r}" for r in IN_LOOP_REASONS]].to_numpy(bool)
    ok = ~lost & ~why.any(axis=1) & ~d[[f"steer_fails_{r}" for r in STEER_REASONS]].to_numpy(bool).any(axis=1)
    ax.scatter(d[x][ok], yv[ok], s=8, color="0.75", label=f"covered ({ok.sum()})")
    for j, reason in enumerate(IN_LOOP_REASONS):
        hit = why[:, j] & ~lost
        if hit.any():
            ax.scatter(d[x][hit], yv[hit], s=14, label=f"{reason.replace('_', ' ')} ({hit.sum()})")
    steer = d[[f"steer_fails_{r}" for r in STEER_REASONS]].to_numpy(bool).any(axis=1) & ~lost
    if steer.any():
        ax.scatter(d[x][steer], yv[steer], s=24, marker="+", color="m", label=f"steering missed ({steer.sum()})")
    if lost.any():
        ax.scatter(d[x][lost], yv[lost], s=20, marker="x", color="k", label=f"not simulated ({lost.sum()})")
    ax.set_xlabel(x)
    ax.set_ylabel(y or "")
    ax.set_title(f"{name}: what it misses in the loop", fontsize=9)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3)  # below: no point hidden


def worst_trace(axes, s: Sizing) -> None:
    """The worst variant's winding temperatures, its bus power and energy against the battery, and its most loaded
    drive's torque and speed over the run against the motor's bound and no-load speed."""
    t = s.trace
    ax, bx, tx = axes
    name = focus(s)
    if name is not None and "drive_lf_torque" in t:
        c = s.catalogue[name].resolved()
        bound = bound_at_wheel(c)
        m = max(WHEELS, key=lambda w: float(t[f"{w}_torque"].abs().max()))  # the most loaded drive of the run
        tx.plot(t["time"], t[f"{m}_torque"], lw=1, color="tab:blue", label=f"{m}: torque at the wheel (N m)")
        if c["i_max"]:
            tx.axhline(bound, color="tab:blue", ls="--", lw=1, label=f"current's bound {bound:.3g} N m")
            tx.axhline(-bound, color="tab:blue", ls="--", lw=1)
        tx.set_xlabel("time (s)")
        tx.set_ylabel("drive torque at the wheel (N m)")
        sx = tx.twinx()
        sx.plot(t["time"], t[f"{m}_speed"], lw=1, color="tab:red", label=f"{m}: wheel speed (rad/s)")
        sx.axhline(c["V"] / (c["K"] * c["N"]), color="tab:red", ls="--", lw=1, label="no-load speed")
        sx.set_ylabel("wheel speed (rad/s)")
        # headroom above and below the bound and the no-load speed, where the two legends sit
        top = max(bound if c["i_max"] else 0.0, float(t[f"{m}_torque"].abs().max()), 1e-9) * 1.5
        tx.set_ylim(-top, top)
        fast = max(c["V"] / (c["K"] * c["N"]), float(t[f"{m}_speed"].abs().max()))
        sx.set_ylim(-0.5 * fast, 1.5 * fast)
        tx.set_title(f"{name}:\nthe run's most loaded drive, step by step", fontsize=9)
        tx.legend(fontsize=7, loc="upper left")
        sx.legend(fontsize=7, loc="lower right")
    for m in WHEELS:
        ax.plot(t["time"], t[f"{m}_winding_temp"], lw=1, label=m)
    c = s.catalogue[focus(s)].resolved() if focus(s) else None
    if c is not None and np.isfinite(c["T_max"]):
        ax.axhline(c["T_max"], color="r", lw=1, ls="--", label=f"maximum {c['T_max']:g} C")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("winding temperature (deg C)")
    where = ", ".join(f"{k} {v:.4g}" for k, v in s.worst.items())
    note = f"\n{s.worst_note}" if s.worst_note else ""
    ax.set_title(f"the hottest variant in the loop, from its hot start\n({where}){note}", fontsize=9)
    ax.legend(fontsize=7)
    bx.plot(t["time"], t["bus_power"], lw=1, color="tab:blue", label="bus power (W)")
    if s.battery is not None:
        bx.axhline(s.battery.max_power, color="tab:blue", ls="--", lw=1, label=f"battery's {s.battery.max_power:.0f} W")
    bx.set_xlabel("time (s)")
    bx.set_ylabel("bus power (W)")
    cx = bx.twinx()
    cx.plot(t["time"], t["bus_energy_wh"], lw=1, color="tab:red", label="bus energy (Wh)")
    cx.set_ylabel("bus energy (Wh)")
    if s.battery is not None:
        cx.set_title(f"battery {s.battery.energy_wh:.0f} Wh: the run uses {t['bus_energy_wh'].iloc[-1]:.3g} Wh",
                     fontsize=9)  # fmt: skip
    bx.legend(fontsize=7, loc="upper left")
    cx.legend(fontsize=7, loc="upper right")


def figures(folder: Path, s: Sizing) -> dict[str, str]:
    """The PNGs under folder/figures: {title: relative path}."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = {}
    (folder / FIGURES).mkdir(parents=True, exist_ok=True)
    shown = [m for m in dict.fromkeys((smaller(s), focus(s))) if m is not None]
    if shown:
        fig, axes = plt.subplots(1, len(shown), figsize=(8.5 * len(shown), 4.4), squeeze=False)
        for ax, name in zip(axes[0], shown, strict=True):
            torque_speed(ax, s, name)
            if s.requirements and name == focus(s):  # the sheet's points on the motor that covers (or comes nearest)
                sheet_points(ax, s.requirements["drive"], s.servo["wheel_speed"].to_numpy(float))
                ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        out["The torque-speed plane at the wheel"] = _save(fig, folder, "torque_speed.png")
    for what, ratios, wins in (("drive", s.ratios, s.windows), ("steering", s.steer_ratios, s.steer_windows)):
        if ratios is None or wins is None or not len(wins):
            continue
        rows = -(-len(wins) // 4)
        fig = plt.figure(figsize=(15, 3.4 * rows))
        coverage_by_ratio(fig, ratios, wins, s.catalogue, s.share, what)
        out[f"Coverage against gear ratio: {what}"] = _save(fig, folder, f"ratios_{what}.png")
    looped = [m for m in shown if m in s.detail]
    if looped:
        fig, axes = plt.subplots(1, len(looped), figsize=(5.5 * len(looped), 4.2), squeeze=False)
        for ax, name in zip(axes[0], looped, strict=True):
            misses(ax, s, name)
        out["Where the misses are"] = _save(fig, folder, "misses.png")
    if s.trace is not None:
        fig, axes = plt.subplots(1, 3, figsize=(16, 4.2))
        worst_trace(axes, s)
        out["The hottest variant: winding and bus"] = _save(fig, folder, "worst.png")
    return out


def _save(fig, folder: Path, name: str) -> str:
    fig.tight_layout()
    fig.savefig(folder / FIGURES / name, dpi=110)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return f"{FIGURES}/{name}"


# --- the page ---


def _md_table(df: pd.DataFrame) -> str:
    cols = [str(c) for c in df.columns]
    lines = ["| " + " | ".join(cols) + " |", "| " + " | ".join("---" for _ in cols) + " |"]
    for _, row in df.iterrows():
        lines.append("| " + " | ".join(str(v).replace("|", "/") for v in row.to_numpy()) + " |")
    return "\n".join(lines)


def catalogue_table(s: Sizing) -> pd.DataFrame:
    """The catalogue entries the report used (the chosen, the next smaller, the steering motor): their numbers."""
    names = [m for m in dict.fromkeys([focus(s), smaller(s), s.steer]) if m]
    rows = []
    for name in names:
        c = s.catalogue[name].resolved()
        rows.append({"motor": name, "K (N m/A)": c["K"], "R (Ohm)": c["R"], "bus (V)": c["V"], "i_max (A)": c["i_max"],
                     "R_T (K/W)": c["R_T"], "tau_T (s)": c["t_T"], "T_max (C)": c["T_max"], "ratio": c["N"],
                     "eta": c["eta"], "rotor (kg m^2)": c["J"]})  # fmt: skip
    return pd.DataFrame(rows)


def energy_line(s: Sizing) -> str:
    """The bus energy of one run of the cycle on the chosen (or best) motor, median and worst over the variants,
    and how many cycles one battery charge gives at the worst; a mission reads its whole cycle's."""
    name = focus(s)
    if name is None or name not in s.detail or s.battery is None:
        return ""
    d = s.detail[name]
    cycle = "mission_" if "mission_bus_energy_wh" in d else ""
    e = d[f"{cycle}bus_energy_wh"].to_numpy(float)
    fixed = fixed_hubs_wh(s, d, cycle)
    e = e - fixed  # the motors' own: a fixed hub's slot (HUB_LOCK) is its mounting, no motor
    worst = float(np.max(e))
    cycles = s.battery.energy_wh / worst if worst > 0 else np.inf
    apart = (
        f"; the fixed hubs' slots, which the loop's bus counts, taken out: {np.median(fixed):.2g} Wh at the median"
        if len(fixed_hubs(s))
        else ""
    )
    return (
        f"{name}: {np.median(e):.3g} Wh a cycle at the median, {worst:.3g} Wh at the worst variant (the bus, the "
        f"{motor_count(s)} motors, regeneration netted{apart}): {cycles:,.0f} cycles on one charge of the "
        f"{s.battery.energy_wh:.0f} Wh battery at the worst."
    )


def fixed_hubs(s: Sizing) -> list[str]:
    """The fixed hubs' steering slots on the session's layout (held by HUB_LOCK in the loop: no motor)."""
    return [m for m in groups("four_wheel")["steer"] if m not in steering_motors(s)]


def fixed_hubs_wh(s: Sizing, d: pd.DataFrame, cycle: str = "") -> np.ndarray:
    """Per variant of a loop run `d`, the net energy (Wh) its fixed hubs' slots drew: the loop's bus
    (motor_stats' bus_energy_wh, each motor's energy_drawn less energy_regen) sums all eight slots, a fixed hub's
    HUB_LOCK with them; 0 on the four-wheel layout."""
    out = np.zeros(len(d))
    for m in fixed_hubs(s):
        out += (d[f"{cycle}{m}_energy_drawn"] - d[f"{cycle}{m}_energy_regen"]).to_numpy(float) / 3600.0
    return out


def battery_line(s: Sizing) -> str:
    """The battery against the chosen (or best) motor's runs judged in the loop: the peak bus power's median, p99
    and largest, and how many runs pass its continuous power or its energy (given apart: never a motor's miss)."""
    name = focus(s)
    if name is None or name not in s.detail or s.battery is None or "battery_over" not in s.detail[name]:
        return ""
    d = s.detail[name]
    judged = d["judged"].to_numpy(bool)
    if not judged.any():
        return ""
    b = s.battery
    power = d["bus_power_peak"].to_numpy(float)[judged]
    over_p = int((power > b.max_power).sum())
    over_e = int((d["bus_energy_wh"].to_numpy(float)[judged] > b.energy_wh).sum())
    n = int(judged.sum())
    line = (
        f"Peak bus power on {name} (the {motor_count(s)} motors): {np.median(power):.0f} W at the median, p99 "
        f"{np.percentile(power, 99):.0f} W, {power.max():.0f} W at the largest, over the {_variants(n)} judged. The "
        f"battery's continuous power ({b.max_power:.0f} W: {b.max_continuous_discharge_current:g} A from "
        f"{b.nominal_voltage:g} V less its {b.internal_resistance:g} Ohm) is passed in {over_p} of them, its "
        f"energy ({b.energy_wh:.0f} Wh) in {over_e}."
    )
    if over_p or over_e:
        line += (
            " These are the battery's limits, not a motor's: those runs are not counted against any drive. A peak "
            "as short as a ramp's may lie within the battery's burst rating, which the catalogue does not give."
        )
    return line


def battery_over(s: Sizing) -> int:
    """The runs judged in the loop on the chosen (or best) motor that pass the battery's energy or power."""
    name = focus(s)
    if name is None or "battery_over" not in s.loop:
        return 0
    return int(s.loop.set_index("motor").loc[name, "battery_over"])


def steer_segments_line(s: Sizing) -> str:
    """A mission's steering demand by segment: which segment sets the steering's low-pass peak and its RMS, in how
    many variants, and the p99 of each, from the servo's run (the screen) and the chosen drive's run in the loop."""
    from batchveh.sizing.screening import mission_segments

    segs = mission_segments(s.servo)
    steer = steering_motors(s)  # the steered hubs' motors, never a fixed hub's mounting
    if not segs or not steer:
        return ""
    parts = []
    frames = [("screen", s.servo)] + ([("loop", s.detail[focus(s)])] if focus(s) in s.detail else [])
    for label, df in frames:
        for stat, suffix in (("peak", "peak_lp"), ("RMS", "rms")):
            per = np.stack([df[[f"{g}_{m}_{suffix}" for m in steer]].abs().max(axis=1).to_numpy() for g in segs], 1)
            top = pd.Series(np.array(segs)[np.argmax(per, axis=1)]).value_counts()
            p99 = float(np.percentile(per.max(axis=1), 99))
            where = f"{top.index[0]} in {int(top.iloc[0])} of {len(df)}"
            parts.append(f"{label}: its {stat} set by {where} (p99 {p99:.3g} N m)")
    return "The steering by segment: " + "; ".join(parts) + "."


def headline(s: Sizing) -> str:
    """The verdict in one sentence, and the battery's where the runs pass it."""
    over = battery_over(s)
    battery = (
        f" The battery's energy or continuous power is passed in {over} of the runs judged: the battery's limits, "
        "not counted against a motor (The battery)."
        if over
        else ""
    )
    return _headline(s) + battery


def _headline(s: Sizing) -> str:
    n = len(s.servo)
    if s.chosen is None:
        best = focus(s)
        if best is None:
            return f"No motor of the catalogue covers {s.share:.0%} of the {n} variants in the loop."
        q = s.loop.set_index("motor").loc[best]
        lost = steering_lost(q, n)
        if int(q["not_simulated"]) == n:  # nothing to judge: every run failed its physics checks or diverged
            return (
                f"No motor of the catalogue covers {s.share:.0%} of the {n} variants in the loop: no drive motor "
                f"could be judged, every run of the best, {best}, could not be simulated ({q['not_simulated_why']}): "
                "that says nothing of the motor."
            )
        if lost and lost == n - int(q["not_simulated"]):  # no drive could be judged
            return (
                f"No drive motor could be judged: the steering motor {q['steer']} lost every run simulated in the "
                f"loop ({_counts(q, STEER_REASONS, prefix='steer_fails_')}); the steering's table says what holds."
            )
        return (
            f"No motor of the catalogue covers {s.share:.0%} of the {n} variants in the loop. The best, {best}, "
            f"covers {q['coverage']:.1%}; it misses for: {_counts(q, IN_LOOP_REASONS)} (the figures show it)."
        )
    row = s.loop.set_index("motor").loc[s.chosen]
    c = s.catalogue[s.chosen].resolved()
    lost = steering_lost(row, n)
    judged = f" (the other {lost} the steering lost: not counted for the drive)" if lost else ""
    return (
        f"{s.chosen}: its gearhead {c['N']:g}:1 (efficiency {c['eta']:g}) covers {row['coverage']:.1%} of the "
        f"{_variants(n - int(row['not_simulated']) - lost)} judged in the loop{judged} (asked: {s.share:.0%}), "
        f"{float(s.screen.set_index('motor').loc[s.chosen, 'coverage']):.1%} in the screen."
    )


def _variants(k: int) -> str:
    return f"{k} variant{'s' * (k != 1)}"


def steering_lost(row: Any, n: int) -> int:
    """Of a loop row's `n` variants, those simulated that its drive is not judged on: the steering's misses."""
    return n - int(row["not_simulated"]) - int(row.get("judged", n - int(row["not_simulated"])))


def sections(s: Sizing, figs: dict[str, str]) -> list[tuple[str, str, Any]]:
    """The page as (heading, kind, content): kind 'text', 'table' (a DataFrame), 'figure' (a path), 'code'."""
    apart = {"energy": "the battery's energy or power: given apart (The battery), never counted against a motor"}
    reasons = "; ".join(f"{k.replace('_', ' ')}: {apart.get(k, v)}" for k, v in IN_LOOP_TEXT.items())
    screen = "; ".join(f"{k.replace('_', ' ')}: {v}" for k, v in REASON_TEXT.items())
    by_segment = steer_segments_line(s)
    steered = bool(steering_motors(s))
    out: list[tuple[str, str, Any]] = [
        ("", "text", headline(s)),
        (
            "",
            "text",
            f"{len(s.servo)} variants of `{s.name}` over {', '.join(s.params)}. {_steering_text(s)} The screen "
            "checks every motor against the ideal servo's demand; the loop runs the candidates, smallest first, as "
            "DC motors driven by batchveh's drive, from the hot steady state of back-to-back runs.",
        ),
        *([("", "text", f"The vehicle sized: {s.geometry}.")] if s.geometry else []),
        *ratio_sections(s),
        ("Verdict: the drive motors", "table", verdict_table(s)),
        ("", "text", f"Screen misses: {screen}. Loop misses: {reasons}. " + (
            "Not simulated: a run that diverged or failed its own physics checks with its steering held; it says "
            "nothing of the motor and is never counted against it (a run whose steering was lost first is the "
            "steering's miss). Steering misses: the steering motor's, never the drive's: not counted for the drive."
            if steered else "Not simulated: a run that diverged or failed its own physics checks; it says nothing of "
            "the motor and is never counted against it.")),
        *([("Verdict: the steering motor", "table", steer_table(s)),
           ("", "text", "The steering's criteria in the loop: " + "; ".join(
            f"{k}: {v}" for k, v in STEER_TEXT.items()) + f". It must hold on {s.share:.0%} of the variants "
            "simulated, or the next larger steering motor runs with the same drive." + _steered_hubs(s))]
          if steered else [("The steering", "text", _no_steering(s))]),
        *([("", "text", by_segment)] if by_segment else []),
        ("Screen against loop, reason by reason", "table", reason_table(s)),
        ("", "text", "The screen read " + (
            "the steady window" if s.span is None else "the whole duty cycle (its RMS and heat), each segment also "
            "checked on its own demand against the motor's instantaneous limits (the first segment and reason a "
            "variant fails for is named)" if s.span == "mission" else f"the span {s.span}") + "."),
        ("", "text", f"Both passes use one list of criteria at the spec's duty ({s.duty:g} of the time: "
                     f"{'the run repeated back to back' if s.duty >= 1 else 'the run repeated with rests between'}"
                     "). The loop counts a drive over the variants simulated" + (" whose steering held" if steered
                     else "") + "; the screen of a "
                     "motor run in the loop counts over the same variants, so the two read one set"
                     f"{_judged_share(s)}; a motor not run, over every variant."),
    ]  # fmt: skip
    for title, path in figs.items():
        out.append((title, "figure", path))
    energy, battery = energy_line(s), battery_line(s)
    if energy or battery:
        out.append(("The battery", "text", " ".join(x for x in (energy, battery) if x)))
    out.append(("Catalogue entries", "table", catalogue_table(s)))
    out.append(("Inputs", "code", s.spec_text))
    meta = {**s.versions, **{f"wall {k} (s)": f"{v:.1f}" for k, v in s.wall_s.items()}}
    out.append(("", "text", "; ".join(f"{k}: {v}" for k, v in meta.items())))
    return out


def _steering_text(s: Sizing) -> str:
    """The steering the session sized, in a sentence: its motor (four-wheel, as before layouts), or the layout's
    words (LAYOUT_TEXT) and what its fixed hubs' columns are."""
    if s.layout == "four_wheel":
        return f"Steering on {s.steer}."
    if not steering_motors(s):
        return f"Steering layout: {LAYOUT_TEXT[s.layout]}."
    return f"Steering layout: {LAYOUT_TEXT[s.layout]}; steering on {s.steer}." + _steered_hubs(s)


def _no_steering(s: Sizing) -> str:
    """A skid-steered vehicle's steering section: there is none to size, and why."""
    return (
        f"{LAYOUT_TEXT[s.layout][0].upper()}{LAYOUT_TEXT[s.layout][1:]}: the vehicle turns by its left and right "
        "wheel speeds, its wheels sliding sideways. No steering screen, window, requirement sheet or confirmation in "
        "the loop; each hub's steer_<corner> columns are the moment its mounting carries (held straight), no "
        "motor's."
    )


def _steered_hubs(s: Sizing) -> str:
    """Where some hubs are fixed (front): which columns the steering reads, and which it never does."""
    fixed = fixed_hubs(s)
    if not fixed or not steering_motors(s):
        return ""
    return (
        f" Every steering figure reads {', '.join(steering_motors(s))} only; {', '.join(fixed)} are the moments the "
        "fixed hubs' mountings carry, not a motor's."
    )


def window_table(wins: pd.DataFrame | None) -> pd.DataFrame:
    """One row per motor: its continuous torque at the shaft, the ratios offered, its window and the limits that
    close it, the ratio to buy and its screen coverage."""
    if wins is None:
        return pd.DataFrame()
    return pd.DataFrame(
        {
            "motor": wins["motor_name"],
            "K i_max at the shaft (N m)": wins["shaft_continuous_torque"].round(4),
            "ratios offered": [
                f"{r['ratios_offered']} ({r['ratio_min']:g}-{r['ratio_max']:g}:1)" for _, r in wins.iterrows()
            ],
            "window": [window_text(r) for _, r in wins.iterrows()],
            "ratio to buy": [f"{r:.4g}:1" for r in wins["chosen_ratio"]],
            "screen": [f"{c:.1%}" for c in wins["chosen_coverage"]],
        }
    )


def sheet_table(sheet: dict[str, Any], params: list[str], at: str = "at the wheel") -> pd.DataFrame:
    """A requirement sheet as a table: each figure at the wheel (hinge) and at the motor's shaft, and the
    variant that sets it."""
    shaft = sheet.get("at_shaft", {})
    rows = []
    for key, fig in sheet["at_wheel"].items():
        variant = ", ".join(f"{k} {_short(v)}" for k, v in fig["variant"].items()) or "-"
        at_shaft = shaft.get(key, {}).get("value", float("nan"))  # not `at`: the column's name
        rows.append({"figure": SHEET_TEXT.get(key, key), "unit": fig["unit"], at: _short(fig["value"]),
                     "at the shaft": _short(at_shaft), "set by the variant": variant})  # fmt: skip
    return pd.DataFrame(rows)


SHEET_TEXT = {
    "rms_torque": "RMS torque at the duty",
    "peak_torque": "peak torque (low-pass: a straight line's steady window, a duty cycle's whole run)",
    "accel_peak_torque": "peak torque with the speed ramp",
    "top_speed": "top speed",
    "torque_at_top_speed": "torque at top speed (within 10%)",
    "continuous_power": "continuous power (RMS torque x speed)",
    "peak_power": "peak mechanical power",
}


def _short(x: Any) -> str:
    return f"{x:.4g}" if isinstance(x, float) else str(x)


def ratio_sections(s: Sizing) -> list[tuple[str, str, Any]]:
    """The windows, the requirement sheets and, where no motor covers, what would."""
    if s.windows is None or s.requirements is None:
        return []
    req = s.requirements
    drive, steer = req["drive"], req.get("steer")  # no steering sheet: a skid layout
    shaft = drive.get("at_shaft", {})
    out: list[tuple[str, str, Any]] = [
        ("Ratio windows: the drive motors", "table", window_table(s.windows)),
        ("", "text", "Every ratio of each motor's gearhead series is screened (no new simulation). The window: the "
                     f"ratios whose screen coverage reaches {s.share:.0%}; below it the motor's torque per amp falls "
                     "short (current, heat, its bound, the gearhead's torque), above it its speed does (the voltage "
                     "line, the no-load speed, the gearhead's input speed). Motors rank by their continuous torque at "
                     "the shaft, K i_max; the ratio to buy is the offered ratio nearest the window's geometric "
                     "centre (an end the series closes, not a limit, counts at 2x the other end)."),
        *([("Ratio windows: the steering motors", "table", window_table(s.steer_windows))] if steer else []),
        (f"Requirement sheet: the drive ({drive['span']}, {s.share:.0%} of the variants)", "table",
         sheet_table(drive, s.params)),
        ("", "text", f"At the shaft of {shaft.get('motor', '-')} ({shaft.get('ratio', float('nan')):g}:1, efficiency "
                     f"{shaft.get('efficiency', float('nan')):g}): torque / (eta N), speed x N, power / eta. Each "
                     f"figure is the value {s.share:.0%} of the variants need at most (nearest rank), on the worst "
                     "of the four wheels, and names the variant that sets it."),
        *([("Requirement sheet: the steering (at the hinge)", "table", sheet_table(steer, s.params, "at the hinge"))]
          if steer else []),
    ]  # fmt: skip
    would = "; ".join(f"{m}: {line}" for m, line in req.get("would", {}).items())
    near = req.get("nearest")
    lead = (
        f"No motor covers; the nearest (motor, ratio): {near['motor']}, {near['coverage']:.1%} on the screen, "
        f"the {LIMIT_TEXT.get(near['binding'], near['binding'])} binding. "
        if s.chosen is None and near
        else ""
    )
    out.append(("Each motor against the drive's sheet", "text", lead + would + "."))
    return out


def markdown(s: Sizing, figs: dict[str, str]) -> str:
    lines = [f"# Motor sizing: {s.name}", ""]
    for head, kind, content in sections(s, figs):
        if head:
            lines += [f"## {head}", ""]
        if kind == "text":
            lines += [content, ""]
        elif kind == "table":
            lines += [_md_table(content), ""]
        elif kind == "figure":
            lines += [f"![{head}]({content})", ""]
        else:
            lines += ["```yaml", content.rstrip(), "```", ""]
    return "\n".join(lines)


def page(s: Sizing, figs: dict[str, str]) -> str:
    """A static HTML page, the figures beside it (figures/)."""
    body = [f"<h1>Motor sizing: {html.escape(s.name)}</h1>"]
    for head, kind, content in sections(s, figs):
        if head:
            body.append(f"<h2>{html.escape(head)}</h2>")
        if kind == "text":
            body.append(f"<p>{html.escape(content)}</p>")
        elif kind == "table":
            body.append(content.to_html(index=False, border=0, classes="t"))
        elif kind == "figure":
            body.append(f'<p><img src="{html.escape(content)}" alt="{html.escape(head)}" style="max-width:100%"></p>')
        else:
            body.append(f"<pre>{html.escape(content)}</pre>")
    style = ("body{font-family:sans-serif;max-width:70em;margin:2em auto;padding:0 1em}"
             "table.t{border-collapse:collapse;font-size:85%}table.t td,table.t th{border:1px solid #ccc;"
             "padding:2px 6px;text-align:left}pre{background:#f6f6f6;padding:1em;overflow:auto}")  # fmt: skip
    return (
        f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>Motor sizing: '
        f"{html.escape(s.name)}</title><style>{style}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n"
    )


def write(folder: str | Path, s: Sizing) -> dict[str, Path]:
    """report.md, report.html, figures/*.png, verdicts.parquet and sizing.json under `folder`; their paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    figs = figures(folder, s)
    paths = {"markdown": folder / "report.md", "html": folder / "report.html", "verdicts": folder / "verdicts.parquet",
             "summary": folder / "sizing.json"}  # fmt: skip
    paths["markdown"].write_text(markdown(s, figs))
    paths["html"].write_text(page(s, figs))
    verdicts(s).to_parquet(paths["verdicts"], index=False)
    summary = {"chosen": s.chosen, "steer": s.steer, "geometry": s.geometry, "share": s.share, "variants": len(s.servo),
               "screen": s.screen.to_dict(orient="records"), "loop": s.loop.to_dict(orient="records"),
               "steer_screen": None if s.steer_screen is None else s.steer_screen.to_dict(orient="records"),
               "steer_loop": None if s.steer_loop is None else s.steer_loop.to_dict(orient="records"),
               "not_run": s.not_run, "duty": s.duty, "requirements": s.requirements,
               "windows": None if s.windows is None else s.windows.to_dict(orient="records"),
               "steer_windows": None if s.steer_windows is None else s.steer_windows.to_dict(orient="records"),
               "worst": s.worst, "versions": s.versions, "wall_s": s.wall_s,
               "figures": figs}  # fmt: skip
    if s.layout != "four_wheel":  # the layout and its steering in words (a four-wheel summary stays as it was)
        summary = {"layout": s.layout, "steering": LAYOUT_TEXT[s.layout],
                   "steering_motors": list(steering_motors(s)), **summary}  # fmt: skip
    paths["summary"].write_text(json.dumps(summary, indent=1, default=str) + "\n")
    return paths
