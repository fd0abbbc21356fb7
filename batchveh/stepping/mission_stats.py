"""A mission's statistics, over the whole mission and over each segment (its spans).

Folded by `stats.update` into the same step-by-step carry as the other statistics (written
once over numpy and jax.numpy; memory does not grow with the steps), when the scenario is a
mission (`stats.StatsConfig.mission`). A span is a static range of steps: the mission covers
every step of the laws (after the settle), segment k the steps whose samples fall in
(t_k, t_k+1] of law time. Per span:

- for each motor and the four-wheel sum (`stats.CHANNELS`): `rms`, `peak` (of |torque|) and
  `peak_lp` (of the low-pass filtered |torque|, the filter of `stats`, running through every
  step from the settle on), N m;
- for each motor (`MOTORS`): `drive_peak_lp` (N m, the peak low-pass torque while the motor drives:
  the filtered torque and omega of one sign; what the voltage line must carry at speed, a braking
  torque needing less voltage, not more); `energy_drive` (J, the integral of max(tau omega, 0): the motor
  drives) and `energy_regen` (J, of min(tau omega, 0), <= 0: the motor brakes and could
  regenerate), with omega the motor joint's speed (the wheel's spin, the steering rate); their
  sum over the mission is the drive motors' `energy` of `stats`; `speed_peak` (rad/s, of |omega|);
  `time_above` (s with |torque| > the mission's `torque_threshold` for the motor's group; only
  for a group given a threshold);
- `distance` (m, path length of the chassis centre in the ground plane).

A span's statistics are NaN only where a sample inside it is not finite: a variant that diverges
keeps the statistics of the segments that ended before.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from batchveh.model import missions
from batchveh.model.vehicle import CHANNELS, MOTORS

TORQUE_STATS = {
    "rms": ("N m", "RMS torque"),
    "peak": ("N m", "peak |torque|"),
    "peak_lp": ("N m", "peak |low-pass filtered torque|"),
}
ELECTRIC_KEYS = ("i_sumsq", "t_peak", "drawn", "regen")  # the dcmotors' carry per span (model dcmotor)
ELECTRIC_STATS = {
    "current_rms": ("A", "RMS motor current (dcmotor)"),
    "winding_temp_peak": ("deg C", "peak winding temperature (dcmotor, one-node model of the delivered current)"),
    "energy_drawn": ("J", "electrical energy drawn from the bus (dcmotor)"),
    "energy_regen": ("J", "electrical energy returned to the bus (dcmotor)"),
}
MOTOR_STATS = {
    "drive_peak_lp": ("N m", "peak low-pass filtered torque while the motor drives (torque and speed of one sign)"),
    "energy_drive": ("J", "energy the motor delivers while driving, integral of max(torque x speed, 0)"),
    "energy_regen": ("J", "energy the motor takes back while braking, integral of min(torque x speed, 0), <= 0"),
    "speed_peak": ("rad/s", "peak |motor joint speed| (wheel spin or steering rate)"),
    "time_above": ("s", "time with |torque| above the mission's torque_threshold for the motor group"),
}


@dataclass(frozen=True)
class MissionStatsConfig:
    """Static settings: the spans' names and step ranges, the time step, the thresholds."""

    spans: tuple[str, ...]  # 'mission', then 'seg<k>_<name or kind>'
    first: tuple[int, ...]  # first step index of each span (0-based from the settle's first step)
    last: tuple[int, ...]  # last step index of each span
    dt: float  # s
    threshold: tuple[float, ...]  # (8,) N m in MOTORS order; inf where the group has none

    @staticmethod
    def for_scenario(scenario: Any) -> MissionStatsConfig | None:
        """The spans of a mission scenario; None for any other scenario."""
        if scenario.kind != "mission":
            return None
        m = missions.mission_of(scenario)
        b, settle = m.boundaries, scenario.settle_steps
        first = (settle, *(settle + b[k] for k in range(len(m.segments))))
        last = (settle + b[-1] - 1, *(settle + b[k + 1] - 1 for k in range(len(m.segments))))
        drive, steer = (np.inf if v is None else v for v in (m.threshold.drive, m.threshold.steer))
        return MissionStatsConfig(m.spans, first, last, scenario.time_step, (drive,) * 4 + (steer,) * 4)

    @property
    def counted(self) -> tuple[bool, ...]:
        """(8,) whether each motor's time above a threshold is counted."""
        return tuple(bool(np.isfinite(v)) for v in self.threshold)

    def times(self) -> dict[str, tuple[float, float]]:
        """Each span's law times (start, end) in s, for plots and the metadata."""
        settle = self.first[0]
        return {
            s: ((a - settle) * self.dt, (b + 1 - settle) * self.dt)
            for s, a, b in zip(self.spans, self.first, self.last, strict=True)
        }


def init(cfg: MissionStatsConfig, batch: tuple[int, ...], xp=np, dtype=None, motors: bool = False) -> dict[str, Any]:
    """Empty carry for `batch` leading dims; with `motors`, the dcmotors' electrical statistics per span too."""
    n = len(cfg.spans)

    def z(*shape):
        return xp.zeros((*batch, n, *shape), dtype=dtype or xp.float64)

    keys9 = ("sumsq", "peak", "peak_lp")
    keys8 = ("energy_drive", "energy_regen", "above", "speed_peak", "drive_peak_lp")
    out = {**{k: z(len(CHANNELS)) for k in keys9}, **{k: z(len(MOTORS)) for k in keys8}, "distance": z()}
    if motors:
        out.update({k: z(len(MOTORS)) for k in ELECTRIC_KEYS} | {"bus_energy": z()})
    return out


def update(c: dict[str, Any], tau, lp, s: dict[str, Any], i, cfg: MissionStatsConfig, xp=np) -> dict[str, Any]:
    """Fold a block of B steps (indices i (B,)) into carry `c`: tau and lp (..., B, 9) N m, the torques and
    their low-pass filtered values (the motors and the four-wheel sum, as `stats.update` builds them), s the
    samples (`stats.sample`; `rate` (..., B, 8) motor joint speeds rad/s, `vel` (..., B, 3) m/s; with dcmotors
    `motors`, their electrical sample, with `temp` (..., B, 8) their windings' temperatures)."""
    first, last = xp.asarray(cfg.first), xp.asarray(cfg.last)
    inside = (i[:, None] >= first[None, :]) & (i[:, None] <= last[None, :])  # (B, S)
    wt = xp.where(inside, 1.0, 0.0).T  # (S, B): sums over a span are products with it

    def total(x):  # x (..., B, C) -> sum over each span's steps, (..., S, C); NaN only where a step inside is
        bad = ~xp.isfinite(x)  # not finite (wt @ x would give 0 x NaN = NaN to every span, those that ended too)
        hit = wt @ xp.where(bad, 1.0, 0.0)
        return xp.where(hit > 0, np.nan, wt @ xp.where(bad, 0.0, x))

    def peak(old, x):  # x (..., B, C) >= 0 -> max over each span's steps, (..., S, C)
        return xp.maximum(old, xp.where(inside[:, :, None], x[..., :, None, :], 0.0).max(-3))

    power = s["tau"] * s["rate"]
    abs_lp = xp.abs(lp)
    # the low-pass torque where it drives (0 where it brakes); NaN where the sample is (the product keeps it)
    driving = abs_lp[..., : len(MOTORS)] * xp.where(lp[..., : len(MOTORS)] * s["rate"] > 0.0, 1.0, 0.0)
    above = xp.where(xp.abs(s["tau"]) > xp.asarray(cfg.threshold), 1.0, 0.0)
    above = xp.where(xp.isfinite(s["tau"]), above, np.nan)  # unknown where the torque is
    speed = xp.sqrt(s["vel"][..., 0] ** 2 + s["vel"][..., 1] ** 2)
    out = {
        "sumsq": c["sumsq"] + total(tau * tau),
        "peak": peak(c["peak"], xp.abs(tau)),
        "peak_lp": peak(c["peak_lp"], abs_lp),
        "energy_drive": c["energy_drive"] + total(xp.maximum(power, 0.0)) * cfg.dt,
        "energy_regen": c["energy_regen"] + total(xp.minimum(power, 0.0)) * cfg.dt,
        "above": c["above"] + total(above) * cfg.dt,
        "speed_peak": peak(c["speed_peak"], xp.abs(s["rate"])),
        "drive_peak_lp": peak(c["drive_peak_lp"], driving),
        "distance": c["distance"] + total(speed[..., None])[..., 0] * cfg.dt,
    }
    if "i_sumsq" in c:  # the dcmotors: current, winding, energy per span
        e = s["motors"]
        cur, power = e["current"], e["power"]
        out["i_sumsq"] = c["i_sumsq"] + total(cur * cur)
        out["t_peak"] = peak(c["t_peak"], e["temp"])
        out["drawn"] = c["drawn"] + total(xp.maximum(power, 0.0)) * cfg.dt
        out["regen"] = c["regen"] + total(xp.maximum(-power, 0.0)) * cfg.dt
        bus = (power * e["on_bus"]).sum(-1)  # the motors' own, never a fixed hub's lock (motor_stats.sample)
        out["bus_energy"] = c["bus_energy"] + total(bus[..., None])[..., 0] * cfg.dt
    return out


def finalize(c: dict[str, Any], cfg: MissionStatsConfig, xp=np) -> dict[str, Any]:
    """Named columns, (...) each: '<span>_<channel>_<stat>' and '<span>_distance'."""
    steps = np.asarray(cfg.last) - np.asarray(cfg.first) + 1
    rms = xp.sqrt(c["sumsq"] / xp.asarray(steps, dtype=c["sumsq"].dtype)[:, None])
    cols: dict[str, Any] = {}
    for k, span in enumerate(cfg.spans):
        for j, ch in enumerate(CHANNELS):
            cols[f"{span}_{ch}_rms"] = rms[..., k, j]
            cols[f"{span}_{ch}_peak"] = c["peak"][..., k, j]
            cols[f"{span}_{ch}_peak_lp"] = c["peak_lp"][..., k, j]
        for j, motor in enumerate(MOTORS):
            cols[f"{span}_{motor}_energy_drive"] = c["energy_drive"][..., k, j]
            cols[f"{span}_{motor}_energy_regen"] = c["energy_regen"][..., k, j]
            cols[f"{span}_{motor}_speed_peak"] = c["speed_peak"][..., k, j]
            cols[f"{span}_{motor}_drive_peak_lp"] = c["drive_peak_lp"][..., k, j]
            if cfg.counted[j]:
                cols[f"{span}_{motor}_time_above"] = c["above"][..., k, j]
        cols[f"{span}_distance"] = c["distance"][..., k]
        if "i_sumsq" in c:
            i_rms = xp.sqrt(c["i_sumsq"][..., k, :] / float(steps[k]))
            for j, motor in enumerate(MOTORS):
                cols[f"{span}_{motor}_current_rms"] = i_rms[..., j]
                cols[f"{span}_{motor}_winding_temp_peak"] = c["t_peak"][..., k, j]
                cols[f"{span}_{motor}_energy_drawn"] = c["drawn"][..., k, j]
                cols[f"{span}_{motor}_energy_regen"] = c["regen"][..., k, j]
            cols[f"{span}_bus_energy_wh"] = c["bus_energy"][..., k] / 3600.0
    return cols


_COLUMN = re.compile(
    rf"^(mission|seg\d+_[a-z0-9_]+?)_(?:({'|'.join(CHANNELS)})_"
    rf"({'|'.join((*TORQUE_STATS, *MOTOR_STATS, *ELECTRIC_STATS))})|distance|bus_energy_wh)$"
)


def column_doc(name: str) -> tuple[str, str] | None:
    """(unit, description) of a mission column, or None for another column."""
    match = _COLUMN.match(name)
    if match is None:
        return None
    span, channel, stat = match.groups()
    where = "the whole mission" if span == "mission" else f"segment {span}"
    if channel is None:
        if name.endswith("_bus_energy_wh"):
            return "Wh", f"net electrical energy of the 8 dcmotors over {where}"
        return "m", f"path length of the chassis centre in the ground plane over {where}"
    unit, doc = {**TORQUE_STATS, **MOTOR_STATS, **ELECTRIC_STATS}[stat]
    return unit, f"{channel}: {doc} over {where}"
