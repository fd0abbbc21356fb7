"""Motor sizing: does a motor (through its gearbox) cover each variant's drive torques?

A motor spec, in YAML:

```yaml
motors:
  - name: M100
    continuous_torque: 1.2   # N m at the motor shaft, thermally sustainable
    peak_torque: 3.5         # N m at the motor shaft, short-term
    max_speed: 600           # rad/s at the motor shaft (no-load)
    corner_speed: 400        # rad/s: above it the torque limit falls as constant power
    gear_ratio: 20           # motor turns per wheel turn
    efficiency: 0.9          # gearbox efficiency, 0-1
```

Checks per variant, on the worst of the four drive motors: the steady-window RMS torque
against the continuous torque; the whole-run low-pass peak (`peak_lp_all`) against the
torque limit at that speed; the wheel speed against the maximum speed.

`check_mission` does the same against a mission's duty cycle (`batchveh.model.missions`): the RMS
over the mission (or one segment) against the continuous torque, the mission's low-pass peak
against the peak torque, reported at the wheel and at the motor shaft.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from batchveh.config import ConfigError, field, from_mapping, load_yaml

WHEELS = ("drive_lf", "drive_rf", "drive_lr", "drive_rr")
GROUPS = {"drive": WHEELS, "steer": ("steer_lf", "steer_rf", "steer_lr", "steer_rr")}


@dataclass(frozen=True)
class Motor:
    """A drive motor with its gearbox; torques and speeds at the motor shaft."""

    name: str = "motor"
    continuous_torque: float = field(1.0, unit="N m", gt=0)
    peak_torque: float = field(3.0, unit="N m", gt=0)
    max_speed: float = field(600.0, unit="rad/s", gt=0)
    corner_speed: float = field(400.0, unit="rad/s", gt=0)
    gear_ratio: float = field(20.0, unit="1", gt=0)
    efficiency: float = field(0.9, unit="1", gt=0, le=1)
    # a DC motor's voltage line (from_dcmotor): past the corner the limit falls as stall (1 - w / no_load_speed)
    # rather than as constant power; 0 (the default): constant power
    stall_torque: float = field(0.0, unit="N m", ge=0)
    no_load_speed: float = field(0.0, unit="rad/s", ge=0)

    def validate(self, where: str = "motor") -> None:
        if self.peak_torque < self.continuous_torque:
            raise ConfigError(
                f"{where}.peak_torque: {self.peak_torque!r} is below continuous_torque "
                f"{self.continuous_torque!r}; allowed: >= continuous_torque"
            )
        if self.corner_speed > self.max_speed:
            raise ConfigError(f"{where}.corner_speed: {self.corner_speed!r} exceeds max_speed {self.max_speed!r}")

    def torque_limit(self, speed: np.ndarray | float) -> np.ndarray:
        """Peak torque available at motor speed `speed` (rad/s): flat to the corner, then constant power."""
        w = np.abs(np.asarray(speed, float))
        if self.stall_torque > 0:  # a DC motor: flat to the corner, then its voltage line
            line = self.stall_torque * (1.0 - w / self.no_load_speed)
            return np.where(w <= self.max_speed, np.clip(line, 0.0, self.peak_torque), 0.0)
        limit = np.where(
            w <= self.corner_speed, self.peak_torque, self.peak_torque * self.corner_speed / np.maximum(w, 1e-12)
        )
        return np.where(w <= self.max_speed, limit, 0.0)


def load_motors(path: str | Path) -> list[Motor]:
    """Motors from a YAML file with a `motors:` list (or one motor mapping): Motor's fields, or a datasheet
    catalogue (notebooks/motors.yaml, batchveh.model.motors.load_catalogue), each entry seen through
    `from_dcmotor`."""
    data = load_yaml(path)
    items = data.get("motors", [data]) if isinstance(data, dict) else data
    if not isinstance(items, list) or not items:
        raise ConfigError(f"{path}: motors: expected a non-empty list of motor mappings")
    if all(isinstance(x, dict) and ("gearhead" in x or "torque_constant" in x or "stall_torque" in x) for x in items):
        from batchveh.model.motors import load_catalogue

        return [from_dcmotor(m) for m in load_catalogue(path).values()]
    return [from_mapping(Motor, item, f"{path}: motors[{i}]") for i, item in enumerate(items)]


def from_dcmotor(motor: Any) -> Motor:
    """A datasheet motor with its gearhead (batchveh.model.motors.DCMotor) as a torque-speed envelope at the
    shaft: continuous torque K i_max; peak torque the stall torque K V / R at the bus voltage, or the
    gearhead's intermittent rating reflected to the shaft where lower; no-load speed V / K (or the
    gearhead's input speed where lower); the voltage line from stall to no-load beyond the peak
    (`Motor.stall_torque`), not constant power."""
    c = motor.resolved()
    stall = c["K"] * c["V"] / c["R"]
    peak = stall
    if motor.gear_max_intermittent_torque is not None:
        peak = min(peak, motor.gear_max_intermittent_torque / (c["N"] * c["eta"]))
    continuous = min(c["K"] * c["i_max"], peak) if c["i_max"] else peak
    w0 = c["V"] / c["K"]
    top = min(w0, motor.gear_max_input_speed) if motor.gear_max_input_speed is not None else w0
    corner = min(max(w0 * (1.0 - peak / stall), 1e-9), top)
    return Motor(
        name=motor.name,
        continuous_torque=continuous,
        peak_torque=peak,
        max_speed=top,
        corner_speed=corner,
        gear_ratio=c["N"],
        efficiency=c["eta"],
        stall_torque=stall,
        no_load_speed=w0,
    )


def check(df: pd.DataFrame, motor: Motor) -> pd.DataFrame:
    """Per-variant shaft torques and speed and whether `motor` suffices (columns fits_*)."""
    scale = motor.gear_ratio * motor.efficiency
    out = pd.DataFrame(index=df.index)
    out["shaft_rms"] = df[[f"{w}_rms" for w in WHEELS]].abs().max(axis=1) / scale
    out["shaft_peak"] = df[[f"{w}_peak_lp_all" for w in WHEELS]].abs().max(axis=1) / scale
    out["shaft_speed"] = df["wheel_speed"].abs() * motor.gear_ratio
    out["fits_continuous"] = out.shaft_rms <= motor.continuous_torque
    out["fits_peak"] = out.shaft_peak <= motor.torque_limit(out.shaft_speed)
    out["fits_speed"] = out.shaft_speed <= motor.max_speed
    out["fits"] = out.fits_continuous & out.fits_peak & out.fits_speed
    return out


def check_mission(df: pd.DataFrame, motor: Motor, span: str = "mission", group: str = "drive") -> pd.DataFrame:
    """Per-variant mission torques against `motor`, at the wheel and at the motor shaft (fits_*).

    On the worst of the group's four motors ('drive' or 'steer') over `span` ('mission', the whole
    duty cycle, or a segment's prefix such as 'seg2_climb'):
    - continuous: the RMS torque (`<span>_<motor>_rms`) against continuous_torque;
    - peak: the low-pass peak (`<span>_<motor>_peak_lp`) against the torque limit at the span's peak
      speed (`<span>_<motor>_speed_peak`): conservative, as if the peak torque came at the top speed;
    - speed: that peak speed against max_speed.
    At the wheel (N m, rad/s): the torques as simulated, against the motor's ratings through the
    gearbox (torque x gear_ratio x efficiency, speed / gear_ratio). At the shaft: the torques
    / (gear_ratio x efficiency) and the speed x gear_ratio, against the ratings themselves."""
    if group not in GROUPS:
        raise ConfigError(f"group: {group!r} is not allowed; allowed: {', '.join(GROUPS)}")
    names = GROUPS[group]
    missing = [
        f"{span}_{m}_{s}" for m in names for s in ("rms", "peak_lp", "speed_peak") if f"{span}_{m}_{s}" not in df
    ]
    if missing:
        spans = sorted({c.removesuffix("_drive_lf_rms") for c in df.columns if c.endswith("_drive_lf_rms")})
        raise ConfigError(
            f"span: {span!r} has no column {missing[0]} (not a mission result, or another span); "
            f"allowed: {', '.join(s for s in spans if s.startswith(('mission', 'seg'))) or 'a mission result'}"
        )
    through = motor.gear_ratio * motor.efficiency  # wheel torque per shaft torque
    out = pd.DataFrame(index=df.index)
    out["wheel_rms"] = df[[f"{span}_{m}_rms" for m in names]].abs().max(axis=1)
    out["wheel_peak"] = df[[f"{span}_{m}_peak_lp" for m in names]].abs().max(axis=1)
    out["wheel_speed_peak"] = df[[f"{span}_{m}_speed_peak" for m in names]].abs().max(axis=1)
    out["shaft_rms"] = out.wheel_rms / through
    out["shaft_peak"] = out.wheel_peak / through
    out["shaft_speed_peak"] = out.wheel_speed_peak * motor.gear_ratio
    shaft_limit = motor.torque_limit(out.shaft_speed_peak)
    out["wheel_continuous_rating"] = motor.continuous_torque * through
    out["wheel_peak_limit"] = shaft_limit * through
    out["wheel_max_speed"] = motor.max_speed / motor.gear_ratio
    out["fits_continuous"] = out.shaft_rms <= motor.continuous_torque
    out["fits_peak"] = out.shaft_peak <= shaft_limit
    out["fits_speed"] = out.shaft_speed_peak <= motor.max_speed
    out["fits"] = out.fits_continuous & out.fits_peak & out.fits_speed
    return out


def smallest(df: pd.DataFrame, catalogue: list[Motor], span: str | None = None) -> tuple[Motor | None, pd.DataFrame]:
    """The motor with the lowest continuous torque that fits every row, and a per-motor summary.

    `span`: None checks the usual columns (`check`: the steady window's RMS, the whole run's
    peaks); a mission span ('mission', or a segment's prefix such as 'seg2_climb') checks the
    mission's columns over it (`check_mission`)."""
    rows: list[dict[str, Any]] = []
    checks = {m.name: check(df, m) if span is None else check_mission(df, m, span) for m in catalogue}
    for m in catalogue:
        c = checks[m.name]
        rows.append(
            {
                "motor": m.name,
                "continuous_torque": m.continuous_torque,
                "peak_torque": m.peak_torque,
                "gear_ratio": m.gear_ratio,
                "fits_all": bool(c.fits.all()),
                "fit_fraction": float(c.fits.mean()),
                "continuous_fails": int((~c.fits_continuous).sum()),
                "peak_fails": int((~c.fits_peak).sum()),
                "speed_fails": int((~c.fits_speed).sum()),
            }
        )
    summary = pd.DataFrame(rows).sort_values("continuous_torque").reset_index(drop=True)
    fitting = [m for m in sorted(catalogue, key=lambda m: m.continuous_torque) if checks[m.name].fits.all()]
    return (fitting[0] if fitting else None), summary


# --- DC motors from datasheets (batchveh.model.motors): the fast screen, with the reason of each failure ---

REASONS = ("rms", "thermal", "voltage", "speed", "gear_torque", "gear_speed")
REASON_TEXT = {
    "rms": "RMS current above the continuous current",
    "thermal": "steady winding temperature above its maximum (one-node model with R(T))",
    "voltage": "the peak torque at speed needs more than the bus voltage (the voltage line)",
    "speed": "the wheel speed needs more than the no-load speed at the bus voltage",
    "gear_torque": "wheel torque above the gearhead's continuous or intermittent rating",
    "gear_speed": "motor speed above the gearhead's input speed",
}


def demand(df: pd.DataFrame, group: str = "drive", span: str | None = None) -> pd.DataFrame:
    """Each variant's demand on the worst of the group's four motors, at the wheel: RMS and peak torque
    (N m), and speed (rad/s): the steady window's RMS, the whole run's low-pass peak and the mean
    wheel speed; or a mission span's RMS, peak and peak speed."""
    names = GROUPS[group]
    out = pd.DataFrame(index=df.index)
    if span is None:
        out["rms"] = df[[f"{m}_rms" for m in names]].abs().max(axis=1)
        out["peak"] = df[[f"{m}_peak_lp_all" for m in names]].abs().max(axis=1)
        out["speed"] = df["wheel_speed"].abs() if group == "drive" else 0.0
    else:
        out["rms"] = df[[f"{span}_{m}_rms" for m in names]].abs().max(axis=1)
        out["peak"] = df[[f"{span}_{m}_peak_lp" for m in names]].abs().max(axis=1)
        out["speed"] = df[[f"{span}_{m}_speed_peak" for m in names]].abs().max(axis=1)
    return out


def screen_one(need: pd.DataFrame, motor: Any, *, armature: float = 0.0, accel: Any = 0.0) -> pd.DataFrame:
    """Per variant, whether `motor` (a batchveh.model.motors.DCMotor with its gearhead) covers the demand
    `need` (`demand`'s columns), and why not (one boolean column per REASONS entry, True = fails).

    The demand was simulated with an ideal servo whose reflected inertia was `armature` (kg m^2 at
    the wheel: the vehicle's motors.armature); the candidate's rotor reflects J N^2, so its peak
    torque is the demand's plus (J N^2 - armature) x `accel` (rad/s^2 at the wheel, each variant's
    own, e.g. its speed over its ramp time). At the motor: i = T / (eta N K); the voltage at the peak
    v = i_peak R + K N w (the peak taken at the variant's speed: conservative); the winding's steady
    rise dT = R_T i_rms^2 R0 (1 + alpha (T_a + dT - 25)), solved in closed form (runaway where
    R_T i^2 R0 alpha >= 1)."""
    from batchveh.model.motors import COPPER_TEMPCOEF, REFERENCE_TEMP

    c = motor.resolved()
    n, eta, k, r = c["N"], c["eta"], c["K"], c["R"]
    peak = need["peak"] + np.maximum(c["J"] * n * n - armature, 0.0) * np.abs(accel)
    i_rms, i_peak = need["rms"] / (eta * n * k), peak / (eta * n * k)
    w_motor = need["speed"] * n
    out = pd.DataFrame(index=need.index)
    out["current_rms"], out["current_peak"], out["motor_speed"] = i_rms, i_peak, w_motor
    out["voltage_peak"] = i_peak * r + k * w_motor
    heat = c["R_T"] * i_rms**2 * r
    denominator = 1 - heat * COPPER_TEMPCOEF
    rise = np.where(denominator > 0, heat * (1 + COPPER_TEMPCOEF * (c["T_amb"] - REFERENCE_TEMP)) / denominator, np.inf)
    out["winding_temperature"] = c["T_amb"] + rise if c["R_T"] > 0 else np.nan
    out["rms"] = i_rms > c["i_max"] if c["i_max"] > 0 else False
    out["thermal"] = out["winding_temperature"] > c["T_max"] if c["R_T"] > 0 else False
    out["voltage"] = out["voltage_peak"] > c["V"]
    out["speed"] = w_motor > c["V"] / k
    gear_torque = np.zeros(len(need), bool)
    if motor.gear_max_continuous_torque is not None:
        gear_torque |= need["rms"].to_numpy() > motor.gear_max_continuous_torque
    if motor.gear_max_intermittent_torque is not None:
        gear_torque |= peak.to_numpy() > motor.gear_max_intermittent_torque
    out["gear_torque"] = gear_torque
    out["gear_speed"] = w_motor > motor.gear_max_input_speed if motor.gear_max_input_speed is not None else False
    out["fits"] = ~out[list(REASONS)].any(axis=1)
    return out


def screen(
    df: pd.DataFrame,
    catalogue: dict[str, Any],
    *,
    share: float = 0.99,
    group: str = "drive",
    span: str | None = None,
    armature: float = 0.0,
    accel: Any = 0.0,
    params: list[str] | None = None,
) -> tuple[str | None, pd.DataFrame, dict[str, pd.DataFrame]]:
    """The fast screen of a sweep's ideal-servo demand against DC motors with their gearheads.

    Returns (the smallest candidate that covers at least `share` of the variants, by its continuous
    torque at the wheel eta N K i_cont, or None; one row per candidate with its coverage and the count
    of variants failing for each reason; per candidate, the failing variants: `params` columns of
    `df` (default: every column not a statistic) and the reasons they fail)."""
    if not 0 < share <= 1:
        raise ConfigError(f"share: {share!r} is not allowed; allowed: 0 < share <= 1")
    need = demand(df, group, span)
    if params is None:
        from batchveh.model.params import parameter_specs

        params = [col for col in df.columns if col in parameter_specs()]
    keep = list(params)
    rows, failing = [], {}
    for name, motor in catalogue.items():
        c = motor.resolved(name)
        res = screen_one(need, motor, armature=armature, accel=accel)
        row = {
            "motor": name,
            "gear_ratio": c["N"],
            "continuous_torque_at_wheel": c["eta"] * c["N"] * c["K"] * c["i_max"] if c["i_max"] else np.nan,
            "coverage": float(res["fits"].mean()),
            **{f"fails_{why}": int(res[why].sum()) for why in REASONS},
        }
        rows.append(row)
        bad = ~res["fits"]
        failing[name] = pd.concat([df.loc[bad, keep], res.loc[bad, list(REASONS)]], axis=1)
    table = pd.DataFrame(rows).sort_values("continuous_torque_at_wheel").reset_index(drop=True)
    ok = table[table["coverage"] >= share]
    return (ok["motor"].iloc[0] if len(ok) else None), table, failing


# --- the second pass: the screen's survivors in the loop, from the hot steady state ---

IN_LOOP_REASONS = ("voltage", "peak", "speed", "thermal", "energy", "gear_torque", "gear_speed")
IN_LOOP_TEXT = {
    "voltage": "fell short of the imposed speed with a drive at its voltage line (the bus voltage)",
    "peak": "fell short of the imposed speed with a drive at its current limit (not torque enough)",
    "speed": "fell short of the imposed speed (neither limit held for more than 1% of the run)",
    "thermal": "a winding above its maximum temperature, from the hot steady state of back-to-back runs",
    "energy": "the run's bus energy above the battery's, or its peak power above the battery's",
    "gear_torque": "wheel torque above the gearhead's continuous (RMS) or intermittent (peak) rating",
    "gear_speed": "motor speed above the gearhead's input speed",
}


@dataclass(frozen=True)
class Battery:
    """The battery of a catalogue's `battery:` section (notebooks/motors.yaml; SI, at its terminals)."""

    name: str = "battery"
    nominal_voltage: float = field(48.0, unit="V", gt=0)
    capacity: float = field(10.0, unit="A h", gt=0)
    internal_resistance: float = field(0.1, unit="Ohm", ge=0)
    max_continuous_discharge_current: float = field(20.0, unit="A", gt=0)

    @property
    def energy_wh(self) -> float:
        return self.nominal_voltage * self.capacity

    @property
    def max_power(self) -> float:
        """Power at the terminals at the continuous discharge current: (V - I R) I (W)."""
        i = self.max_continuous_discharge_current
        return (self.nominal_voltage - i * self.internal_resistance) * i


def load_battery(path: str | Path) -> Battery:
    """The `battery:` section of a catalogue YAML (notebooks/motors.yaml)."""
    data = load_yaml(path)
    raw = data.get("battery") if isinstance(data, dict) else None
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: battery: missing; allowed: a mapping of Battery's fields")
    keep = {k: v for k, v in raw.items() if k in Battery.__dataclass_fields__}
    return from_mapping(Battery, keep, f"{path}: battery")


def _hot_start(gap: np.ndarray, duration: float, tau: float) -> np.ndarray:
    """The change of start rise that closes `gap` = end(s) - s (back-to-back runs end where they start), one
    Newton step on the linear one-node model: a start rise s decays as s exp(-t / tau), so end(s) ~ end(0) +
    s exp(-duration / tau), and from s = 0 the step lands on end(0) / (1 - exp(-duration / tau))."""
    if tau <= 0:
        return np.zeros_like(gap)
    return gap / (1.0 - np.exp(-duration / tau))


def in_loop(
    spec: Any,
    df: pd.DataFrame,
    catalogue: str | Path,
    candidates: list[str],
    *,
    steer: str,
    share: float = 0.99,
    hot: bool = True,
    iterations: int = 2,
    battery: Battery | None = None,
    backend: str | None = None,
    stop_at_first: bool = True,
) -> tuple[str | None, pd.DataFrame, dict[str, pd.DataFrame]]:
    """Run `candidates` (catalogue names, smallest first) as the drive motors, in the loop, on the variants of
    `df` (rows of the servo sweep `spec`), steering on `steer`; return (the first candidate that covers
    `share` of the variants, or None; one row per candidate run; per candidate, its variants' in-the-loop
    columns and reasons, IN_LOOP_REASONS, True = fails). A variant whose run failed a physics check
    (`motor_status` unstable) or diverged could not be simulated: it is counted in the row's `not_simulated`,
    never as a reason, and the coverage is over the variants simulated.

    With `hot`, a candidate runs first from ambient, then `iterations` times from the start rise that would
    make its run end where it started (`_hot_start` from the previous run's end, each drive and steering
    winding at its group's hottest): the thermal state of back-to-back runs. The row gives the median start
    rise and the largest |end - start| left (K). `stop_at_first`: stop at the first candidate that covers."""
    import dataclasses

    from batchveh.engines import make_engine, resolve_backend
    from batchveh.model.motors import load_catalogue, pick
    from batchveh.stepping.batch import make_batch
    from batchveh.stepping.motor_stats import LIMITED_SHARE, named

    if not 0 < share <= 1:
        raise ConfigError(f"share: {share!r} is not allowed; allowed: 0 < share <= 1")
    cat = load_catalogue(catalogue)
    pick(cat, steer, "steer")
    table = {k: df[k].to_numpy(float) for k in spec.params}
    name_of = resolve_backend(backend or "mujoco")
    rows, detail, best = [], {}, None
    for name in candidates:
        motor = pick(cat, name, "candidates")
        c, cs = motor.resolved(name), cat[steer].resolved(steer)
        motors = dataclasses.replace(
            spec.vehicle.motors, model="dcmotor", catalogue=str(catalogue), drive=name, steer=steer
        )
        run_spec = dataclasses.replace(spec, vehicle=dataclasses.replace(spec.vehicle, motors=motors))
        cfg = run_spec.stats_config()
        duration = cfg.n_steps * float(spec.scenario.time_step)
        engine = make_engine(name_of, spec.scenario, cfg, None, len(df))
        start = {"motors.drive_start_rise": np.zeros(len(df)), "motors.steer_start_rise": np.zeros(len(df))}
        taus = {"motors.drive_start_rise": c["t_T"], "motors.steer_start_rise": cs["t_T"]}
        ambient = {"motors.drive_start_rise": c["T_amb"], "motors.steer_start_rise": cs["T_amb"]}
        groups = {"motors.drive_start_rise": WHEELS, "motors.steer_start_rise": GROUPS["steer"]}
        runs = 1 + (iterations if hot else 0)
        for k in range(runs):
            cols = engine.run(make_batch(run_spec.vehicle, spec.scenario, {**table, **start}))
            res = pd.DataFrame({key: np.asarray(v) for key, v in named(cols).items()})
            end = {
                key: res[[f"{m}_winding_temp_end" for m in groups[key]]].max(axis=1).to_numpy() - ambient[key]
                for key in start
            }
            residual = max(float(np.max(np.abs(end[key] - start[key]))) for key in start)
            if k < runs - 1:  # the next start: one Newton step towards end(s) = s
                start = {
                    key: np.maximum(start[key] + _hot_start(end[key] - start[key], duration, taus[key]), 0.0)
                    for key in start
                }
        # a variant whose run failed a physics check (or diverged) says nothing of the motor: apart, never a reason
        diverged = res["status_code"].to_numpy() == 1
        lost = (res["motor_status"] == "unstable").to_numpy() | diverged
        why_lost = pd.Series(np.where(diverged, "diverged", res["motor_check"].to_numpy()))[lost].value_counts()
        why = _in_loop_reasons(res, motor, c, battery, LIMITED_SHARE)
        why.loc[lost, :] = False
        fits = ~why.any(axis=1)
        simulated = max(int((~lost).sum()), 1)
        rows.append(
            {
                "motor": name,
                "gear_ratio": c["N"],
                "continuous_torque_at_wheel": c["eta"] * c["N"] * c["K"] * c["i_max"] if c["i_max"] else np.nan,
                "coverage": float(fits[~lost].sum() / simulated),
                "not_simulated": int(lost.sum()),
                "not_simulated_why": ", ".join(f"{v} {k}" for k, v in why_lost.items()),
                **{f"fails_{r}": int(why[r].sum()) for r in IN_LOOP_REASONS},
                "start_rise_median": float(np.median(start["motors.drive_start_rise"])),
                "residual_K": residual,
                "runs": runs,
            }
        )
        detail[name] = pd.concat([df.reset_index(drop=True)[list(spec.params)], res, why.add_prefix("fails_")], axis=1)
        if fits[~lost].sum() / simulated >= share and best is None:
            best = name
            if stop_at_first:
                break
    return best, pd.DataFrame(rows), detail


def in_loop_lines(table: pd.DataFrame) -> list[str]:
    """One line per candidate of an `in_loop` table: its coverage over the variants simulated, the counted
    reasons its misses fail for, and, apart, the variants that could not be simulated (never a reason)."""
    lines = []
    for _, row in table.iterrows():
        fails = ", ".join(f"{r} {int(row[f'fails_{r}'])}" for r in IN_LOOP_REASONS if row[f"fails_{r}"])
        line = f"{row['motor']}: covers {row['coverage']:.1%}" + (f"; fails: {fails}" if fails else "")
        if row.get("not_simulated", 0):
            k = int(row["not_simulated"])
            line += f"; {k} variant{'s' * (k > 1)} could not be simulated: {row['not_simulated_why']}"
        lines.append(line)
    return lines


def _in_loop_reasons(res: pd.DataFrame, motor: Any, c: dict, battery: Battery | None, limited: float) -> pd.DataFrame:
    """Per variant of an in-the-loop result, each IN_LOOP_REASONS (True = fails)."""
    short = res["motor_status"].isin(["short", "stalled"]).to_numpy()
    v_share = res[[f"{m}_at_voltage_share" for m in WHEELS]].max(axis=1).to_numpy()
    i_share = res[[f"{m}_at_current_share" for m in WHEELS]].max(axis=1).to_numpy()
    at_v, at_i = v_share > limited, i_share > limited
    out = pd.DataFrame(index=res.index)
    out["voltage"] = short & at_v & (v_share > i_share)  # the limit it spent longer at
    out["peak"] = short & at_i & (i_share >= v_share)
    out["speed"] = short & ~at_v & ~at_i
    out["thermal"] = res[[f"{m}_winding_temp_peak" for m in WHEELS]].max(axis=1).to_numpy() > c["T_max"]
    energy = np.zeros(len(res), bool)
    if battery is not None:
        energy |= res["bus_energy_wh"].to_numpy() > battery.energy_wh
        energy |= res["bus_power_peak"].to_numpy() > battery.max_power
    out["energy"] = energy
    gear = np.zeros(len(res), bool)
    if motor.gear_max_continuous_torque is not None:
        gear |= res[[f"{m}_rms" for m in WHEELS]].abs().max(axis=1).to_numpy() > motor.gear_max_continuous_torque
    if motor.gear_max_intermittent_torque is not None:
        peak = res[[f"{m}_peak_lp_all" for m in WHEELS]].abs().max(axis=1).to_numpy()
        gear |= peak > motor.gear_max_intermittent_torque
    out["gear_torque"] = gear
    speed = res["wheel_speed"].abs().to_numpy() * c["N"]
    out["gear_speed"] = speed > motor.gear_max_input_speed if motor.gear_max_input_speed is not None else False
    return out
