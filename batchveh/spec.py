"""Sweep specs: YAML -> a validated `SweepSpec` -> a table of variants.

```yaml
name: slope
scenario: straight_line          # a registered name, or a mapping like a scenario YAML
vehicle: null                    # null (the seed's), a YAML path, or an inline mapping
fixed: {total_time: 6.0}         # parameter values for every variant
sweep:
  method: grid                   # grid | random | lhs | zip
  params:
    slope_deg: {start: 0, stop: 30, num: 31}   # or a list of values
    friction: [0.3, 0.5, 0.7, 0.9]
output: results/slope
solver: {type: newton, iterations: 8, ls_iterations: 16}   # optional; MuJoCo's defaults otherwise
```
For `random` and `lhs`, `n` and `seed` are required, and each parameter is
`{low, high}` with optional `log: true` (log-uniform).
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from batchveh.config import ConfigError, check_number, did_you_mean, load_yaml
from batchveh.scenarios import Scenario, load_scenario, scenario_from_mapping
from batchveh.variants import STATIC, parameter_specs
from batchveh.vehicle import Vehicle, load_vehicle, vehicle_from_mapping

METHODS = ("grid", "random", "lhs", "zip")
TOP_KEYS = (
    "name",
    "scenario",
    "vehicle",
    "fixed",
    "sweep",
    "output",
    "window",
    "lowpass_s",
    "chunk_size",
    "backend",
    "precision",
    "solver",
)
SOLVER_KEYS = {
    "type": ("newton", "cg"),
    "iterations": int,
    "ls_iterations": int,
    "tolerance": float,
    "impl": ("auto", "fused", "mjx"),  # MJX backend: batchveh.solver's fused Newton or MJX's own
}


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep."""

    name: str
    scenario: Scenario
    vehicle: Vehicle
    fixed: dict[str, float]
    method: str
    params: dict[str, Any]
    n: int | None
    seed: int
    output: Path
    window: tuple[float, float] | None
    lowpass_s: float
    chunk_size: int | None
    backend: str
    precision: str
    solver: dict[str, Any]  # MuJoCo solver options: type, iterations, ls_iterations, tolerance
    raw: dict[str, Any]  # the YAML as read, for the Parquet metadata


def _values(v: Any, where: str, meta: dict) -> np.ndarray:
    """A list of numbers or {start, stop, num} (inclusive linspace)."""
    if isinstance(v, list):
        if not v:
            raise ConfigError(f"{where}: empty list; give at least one value")
        return np.array([check_number(x, meta, where) for x in v])
    if isinstance(v, dict):
        if set(v) != {"start", "stop", "num"}:
            raise ConfigError(f"{where}: {v!r} is not a range; allowed: a list of values or {{start, stop, num}}")
        num = v["num"]
        if isinstance(num, bool) or not isinstance(num, int) or num < 1:
            raise ConfigError(f"{where}.num: {num!r} is not allowed; allowed: an integer >= 1")
        return np.linspace(check_number(v["start"], meta, where), check_number(v["stop"], meta, where), num)
    return np.array([check_number(v, meta, where)])


def load_spec(path: str | Path) -> SweepSpec:
    """Read and validate a sweep YAML; every error is one ConfigError line."""
    raw = load_yaml(path)
    return spec_from_mapping(raw, str(path))


def spec_from_mapping(raw: dict[str, Any], where: str) -> SweepSpec:
    for k in raw:
        if k not in TOP_KEYS:
            raise ConfigError(
                f"{where}: {k}: unknown key {k!r}{did_you_mean(k, TOP_KEYS)}; allowed keys: {', '.join(TOP_KEYS)}"
            )
    name = raw.get("name")
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{where}: name: {name!r} is not allowed; allowed: a non-empty string")
    sc = raw.get("scenario", "straight_line")
    if isinstance(sc, dict):
        scenario = scenario_from_mapping(sc, f"{where}: scenario")
    elif isinstance(sc, str):
        try:
            scenario = load_scenario(sc)
        except ConfigError as err:
            raise ConfigError(f"{where}: scenario: {err}") from None
    else:
        raise ConfigError(f"{where}: scenario: {sc!r} is not allowed; allowed: a scenario name or mapping")
    veh = raw.get("vehicle")
    if veh is None:
        vehicle = Vehicle()
    elif isinstance(veh, dict):
        vehicle = vehicle_from_mapping(veh, f"{where}: vehicle")
    elif isinstance(veh, str):
        vpath = Path(veh) if Path(veh).is_absolute() else Path(where).parent / veh
        vehicle = load_vehicle(vpath if vpath.exists() else veh)
    else:
        raise ConfigError(f"{where}: vehicle: {veh!r} is not allowed; allowed: null, a YAML path or a mapping")
    specs = parameter_specs(vehicle)

    def param_meta(key: str, at: str) -> dict:
        if key not in specs:
            raise ConfigError(
                f"{where}: {at}.{key}: unknown parameter {key!r}{did_you_mean(key, specs)}; allowed: {', '.join(specs)}"
            )
        return specs[key]

    fixed_raw = raw.get("fixed") or {}
    if not isinstance(fixed_raw, dict):
        raise ConfigError(f"{where}: fixed: {fixed_raw!r} is not a mapping of parameter: value")
    fixed = {k: check_number(v, param_meta(k, "fixed"), f"{where}: fixed.{k}") for k, v in fixed_raw.items()}
    sw = raw.get("sweep")
    if not isinstance(sw, dict):
        raise ConfigError(f"{where}: sweep: {sw!r} is not a mapping with method and params")
    for k in sw:
        if k not in ("method", "params", "n", "seed"):
            raise ConfigError(f"{where}: sweep.{k}: unknown key {k!r}; allowed keys: method, params, n, seed")
    method = sw.get("method", "grid")
    if method not in METHODS:
        raise ConfigError(f"{where}: sweep.method: {method!r} is not allowed; allowed: {', '.join(METHODS)}")
    params_raw = sw.get("params")
    if not isinstance(params_raw, dict) or not params_raw:
        raise ConfigError(f"{where}: sweep.params: {params_raw!r} is not a non-empty mapping of parameters")
    n = sw.get("n")
    seed = sw.get("seed", 0)
    params: dict[str, Any] = {}
    for k, v in params_raw.items():
        meta = param_meta(k, "sweep.params")
        at = f"{where}: sweep.params.{k}"
        if k in fixed:
            raise ConfigError(f"{at}: {k!r} is both fixed and swept; keep one")
        if method in ("random", "lhs"):
            if not isinstance(v, dict) or not {"low", "high"} <= set(v) or set(v) - {"low", "high", "log"}:
                raise ConfigError(f"{at}: {v!r} is not allowed; allowed for {method}: {{low, high, log}}")
            lo, hi = check_number(v["low"], meta, at), check_number(v["high"], meta, at)
            log = bool(v.get("log", False))
            if hi < lo or (log and lo <= 0):
                raise ConfigError(f"{at}: {v!r} is not allowed; allowed: low <= high (and low > 0 with log)")
            params[k] = (lo, hi, log)
        else:
            params[k] = _values(v, at, meta)
    if method in ("random", "lhs"):
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise ConfigError(f"{where}: sweep.n: {n!r} is not allowed; allowed: an integer >= 1 for {method}")
        if isinstance(seed, bool) or not isinstance(seed, int):
            raise ConfigError(f"{where}: sweep.seed: {seed!r} is not allowed; allowed: an integer")
    if method == "zip" and len({len(v) for v in params.values()}) > 1:
        raise ConfigError(
            f"{where}: sweep.params: zip needs lists of one length; got { {k: len(v) for k, v in params.items()} }"
        )
    window = raw.get("window")
    if window is not None:
        if not isinstance(window, list) or len(window) != 2:
            raise ConfigError(f"{where}: window: {window!r} is not allowed; allowed: [start_s, end_s]")
        window = (
            check_number(window[0], {"ge": 0}, f"{where}: window"),
            check_number(window[1], {"gt": 0}, f"{where}: window"),
        )
        if window[1] <= window[0]:
            raise ConfigError(f"{where}: window: {list(window)!r} is not allowed; allowed: start < end")
    chunk = raw.get("chunk_size")
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1):
        raise ConfigError(f"{where}: chunk_size: {chunk!r} is not allowed; allowed: an integer >= 1")
    backend = raw.get("backend", "auto")
    if backend not in ("auto", "mjx", "mujoco"):
        raise ConfigError(f"{where}: backend: {backend!r} is not allowed; allowed: auto, mjx, mujoco")
    precision = raw.get("precision", "f32")
    if precision not in ("f32", "f64"):
        raise ConfigError(f"{where}: precision: {precision!r} is not allowed; allowed: f32, f64")
    solver = raw.get("solver") or {}
    if not isinstance(solver, dict):
        raise ConfigError(f"{where}: solver: {solver!r} is not a mapping; allowed keys: {', '.join(SOLVER_KEYS)}")
    for k, v in solver.items():
        if k not in SOLVER_KEYS:
            raise ConfigError(f"{where}: solver.{k}: unknown key {k!r}; allowed keys: {', '.join(SOLVER_KEYS)}")
        kind = SOLVER_KEYS[k]
        if isinstance(kind, tuple):
            if v not in kind:
                raise ConfigError(f"{where}: solver.{k}: {v!r} is not allowed; allowed: {', '.join(kind)}")
        elif kind is int and (isinstance(v, bool) or not isinstance(v, int) or v < 1):
            raise ConfigError(f"{where}: solver.{k}: {v!r} is not allowed; allowed: an integer >= 1")
        elif kind is float:
            check_number(v, {"gt": 0}, f"{where}: solver.{k}")
    lowpass = check_number(raw.get("lowpass_s", 0.05), {"gt": 0, "unit": "s"}, f"{where}: lowpass_s")
    output = Path(raw.get("output") or Path("results") / name)
    scenario = dataclasses.replace(scenario, **{k: v for k, v in fixed.items() if k in STATIC})
    return SweepSpec(
        name=name,
        scenario=scenario,
        vehicle=vehicle,
        fixed=fixed,
        method=method,
        params=params,
        n=n,
        seed=seed,
        output=output,
        window=window,
        lowpass_s=lowpass,
        chunk_size=chunk,
        backend=backend,
        precision=precision,
        solver=solver,
        raw=raw,
    )


def variants(spec: SweepSpec) -> pd.DataFrame:
    """The variant table: a `variant` id and one column per swept parameter, in a fixed order."""
    names = list(spec.params)
    if spec.method == "grid":
        rows = list(itertools.product(*[spec.params[k] for k in names]))
        data = np.array(rows, float).reshape(len(rows), len(names))
    elif spec.method == "zip":
        data = np.stack([spec.params[k] for k in names], axis=1).astype(float)
    else:
        rng = np.random.default_rng(spec.seed)
        n, d = spec.n, len(names)
        if spec.method == "random":
            u = rng.random((n, d))
        else:  # Latin hypercube: one sample in each of n strata per dimension, strata shuffled
            u = (np.stack([rng.permutation(n) for _ in range(d)], axis=1) + rng.random((n, d))) / n
        data = np.empty((n, d))
        for j, k in enumerate(names):
            lo, hi, log = spec.params[k]
            data[:, j] = np.exp(np.log(lo) + u[:, j] * (np.log(hi) - np.log(lo))) if log else lo + u[:, j] * (hi - lo)
    frame = pd.DataFrame(data, columns=names)
    frame.insert(0, "variant", np.arange(len(frame), dtype=np.int64))
    return frame


def variant_setup(spec: SweepSpec, row: Any) -> tuple[Vehicle, Scenario]:
    """The vehicle and scenario of one variant (a row of the variant or result table)."""
    from batchveh.scenarios import numeric_fields
    from batchveh.vehicle import numeric_paths, replace_path

    values = {**spec.fixed, **{k: float(row[k]) for k in spec.params}}
    scenario_keys = numeric_fields()
    sc = dataclasses.replace(spec.scenario, **{k: v for k, v in values.items() if k in scenario_keys})
    vehicle = spec.vehicle
    for k, v in values.items():
        if k in numeric_paths(vehicle):
            vehicle = replace_path(vehicle, k, float(v))
    return vehicle, sc


def spec_of_result(path: str | Path) -> SweepSpec:
    """The spec a result directory was made from (from its file metadata)."""
    from batchveh.io import metadata

    return spec_from_mapping(metadata(path)["spec"], f"{path} (metadata)")
