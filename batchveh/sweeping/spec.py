"""Sweep specs: YAML -> a validated `SweepSpec` -> a lazy table of variants.

```yaml
name: slope
scenario: straight_line          # a registered name, or a mapping like a scenario YAML
vehicle: null                    # null (the seed's), a YAML path, or an inline mapping
fixed: {total_time: 6.0}         # parameter values for every variant
sweep:
  method: grid                   # grid | random | lhs | sobol | zip
  params:
    slope_deg: {start: 0, stop: 30, num: 31}   # or a list of values
    friction: [0.3, 0.5, 0.7, 0.9]
output: results/slope
solver: {type: newton, iterations: 8, ls_iterations: 16}   # optional; MuJoCo's defaults otherwise
```
For `random`, `lhs` and `sobol`, `n` is required (`seed` defaults to 0), and each parameter
is `{low, high}` with optional `log: true` (log-uniform). `sobol` is Saltelli's scheme on a
scrambled Sobol' sequence (SALib), for variance-based sensitivity (`batchveh.sensitivity`):
`n` is the base size N, a power of two, and the sweep has N (2D + 2) variants for D >= 2
parameters, in blocks of 2D + 2 rows per base point (`saltelli_block`).

The typed parts (`SpecFile`, `Sampling`, `SolverOptions`) are validated by
`config.from_mapping`, so every error is one line naming the file, key, value and
what is allowed. Everything that cannot give valid statistics (a window outside
the run, fewer steps than a window needs, a swept static field) is refused here,
before any work. The variant table is lazy: `len(spec.table())` counts a
billion-variant grid at once, and `rows(start, stop)` builds one chunk.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from batchveh.config import ConfigError, check_number, did_you_mean, field, from_mapping, load_yaml
from batchveh.model import course, missions
from batchveh.model.params import base_params, parameter_specs, variant_setup
from batchveh.model.scenarios import Scenario, check_layout, load_scenario, scenario_from_mapping
from batchveh.model.soil import check_ground
from batchveh.model.vehicle import Vehicle, load_vehicle, vehicle_from_mapping
from batchveh.stepping.motor_stats import MotorStatsConfig
from batchveh.stepping.stats import StatsConfig, slip_limit

# numeric scenario fields that are neither swept nor fixed per sweep: they belong in the scenario
SCENARIO_SETTINGS = tuple(
    f.name for f in dataclasses.fields(Scenario) if f.metadata and not f.metadata.get("sweep", True)
)
MAX_VARIANTS = 10_000_000  # a sweep above this is refused unless the limit is raised (--max-variants)
RNG_BLOCK = 65536  # random and lhs rows are drawn in blocks of this many, so values do not depend on chunking
SAMPLED = ("random", "lhs", "sobol")  # methods whose parameters are ranges {low, high, log}, with a size n


@dataclass(frozen=True)
class SolverOptions:
    """MuJoCo solver options (None keeps MuJoCo's) and the MJX backend's solver code."""

    type: Literal["newton", "cg"] | None = None
    iterations: int | None = field(None, ge=1)
    ls_iterations: int | None = field(None, ge=1)
    tolerance: float | None = field(None, gt=0)


@dataclass(frozen=True)
class Sampling:
    """The `sweep:` part: how the variants are drawn; `params` is checked per method."""

    method: Literal["grid", "random", "lhs", "sobol", "zip"] = "grid"
    params: dict | None = None
    n: int | None = field(None, ge=1)
    seed: int = field(0, ge=0)


@dataclass(frozen=True)
class SpecFile:
    """The top-level keys of a sweep YAML."""

    name: str = ""
    scenario: Any = "straight_line"
    vehicle: Any = None
    fixed: dict | None = None
    sweep: Sampling | None = None
    output: str | None = None
    window: tuple[float, float] | None = field(None, unit="s", ge=0)
    lowpass_s: float = field(0.05, unit="s", gt=0)
    chunk_size: int | None = field(None, ge=1)
    backend: Literal["auto", "mujoco", "mjx", "warp"] = "auto"
    precision: Literal["f32", "f64"] = "f32"
    solver: SolverOptions = SolverOptions()
    # sizing (batchveh.size): the share of the time the motors run this run, repeated; 1 = back to back, for ever
    duty: float = field(1.0, unit="1", gt=0, le=1)

    def validate(self, where: str) -> None:
        if not self.name:
            raise ConfigError(f"{where}: name: {self.name!r} is not allowed; allowed: a non-empty string")
        if self.sweep is None or not self.sweep.params:
            raise ConfigError(f"{where}: sweep.params: missing; allowed: a mapping of parameter: values")


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep. `scenario` and `vehicle` already carry the fixed values."""

    name: str
    scenario: Scenario
    vehicle: Vehicle
    fixed: dict[str, float]
    method: str
    params: dict[str, Any]  # grid/zip: name -> values; random/lhs/sobol: name -> (low, high, log)
    n: int | None  # random/lhs: the variants; sobol: the base size N
    seed: int
    output: Path | str  # a local folder, or a URI pyarrow.fs understands
    window: tuple[float, float] | None
    lowpass_s: float
    chunk_size: int | None
    backend: str
    precision: str
    solver: SolverOptions
    raw: dict[str, Any]  # the YAML as read, for the Parquet metadata
    where: str = "spec"  # the file it came from, for messages
    duty: float = 1.0  # sizing: the share of the time this run repeats (SpecFile.duty)

    def table(self) -> VariantTable:
        """The variants, counted without being built."""
        return VariantTable(self)

    def stats_config(self) -> StatsConfig:
        """The reduction's settings: steps, window and filter."""
        return StatsConfig.for_scenario(
            self.scenario,
            self.window,
            lowpass_s=self.lowpass_s,
            slip_limit=slip_limit(self.vehicle),
            motors=MotorStatsConfig.for_vehicle(self.vehicle),
        )

    def variant(self, row: Any) -> tuple[Vehicle, Scenario]:
        """The vehicle and scenario of one variant (a row of the variant or result table)."""
        values = {k: row[k] if isinstance(row[k], str) else float(row[k]) for k in self.params}  # names stay names
        return variant_setup(self.vehicle, self.scenario, values)


class VariantTable:
    """The variant table of a spec: `variant` and one column per swept parameter, built on demand.

    Grid rows are unravelled from their index; random and LHS rows are drawn from RNGs
    seeded by (seed, block), so any chunk is built alone and equals the same rows of the
    whole table. Sobol' rows are SALib's Saltelli sample, drawn whole once per table (n x D
    floats, as the LHS strata are) and sliced."""

    def __init__(self, spec: SweepSpec):
        self.spec = spec
        self.names = list(spec.params)
        if spec.method == "grid":
            self.sizes = [len(spec.params[k]) for k in self.names]
            self.n = math.prod(self.sizes)
        elif spec.method == "zip":
            self.n = len(next(iter(spec.params.values())))
        elif spec.method == "sobol":
            self.n = int(spec.n) * saltelli_block(len(self.names))
        else:
            self.n = int(spec.n)
        self._perm: np.ndarray | None = None
        self._sobol: np.ndarray | None = None

    def __len__(self) -> int:
        return self.n

    def _uniform(self, start: int, stop: int) -> np.ndarray:
        """(stop - start, d) uniforms in [0, 1), the same whatever the chunking."""
        d = len(self.names)
        out = []
        for b in range(start // RNG_BLOCK, (stop - 1) // RNG_BLOCK + 1):
            lo = b * RNG_BLOCK
            u = np.random.default_rng([self.spec.seed, b]).random((min(RNG_BLOCK, self.n - lo), d))
            out.append(u[max(start - lo, 0) : stop - lo])
        return np.concatenate(out) if out else np.empty((0, d))

    def rows(self, start: int = 0, stop: int | None = None) -> pd.DataFrame:
        """Rows [start, stop) of the table."""
        stop = self.n if stop is None else min(stop, self.n)
        start = min(start, stop)
        spec, idx = self.spec, np.arange(start, stop, dtype=np.int64)
        if spec.method == "grid":
            pos = np.unravel_index(idx, self.sizes) if len(idx) else [idx] * len(self.names)
            data = {k: np.asarray(spec.params[k], float)[p] for k, p in zip(self.names, pos, strict=True)}
        elif spec.method == "zip":
            data = {k: np.asarray(spec.params[k], float)[start:stop] for k in self.names}
        else:
            if spec.method == "sobol":
                if self._sobol is None:
                    self._sobol = saltelli_sample(len(self.names), int(spec.n), spec.seed)
                u = self._sobol[start:stop]
            else:
                u = self._uniform(start, stop)
            if spec.method == "lhs":  # one sample in each of n strata per dimension, strata shuffled
                if self._perm is None:
                    rng = np.random.default_rng([spec.seed, 2**32 - 1])
                    self._perm = np.stack([rng.permutation(self.n) for _ in self.names])
                u = (self._perm[:, start:stop].T + u) / self.n
            data = {}
            for j, k in enumerate(self.names):
                lo, hi, log = spec.params[k]
                data[k] = np.exp(np.log(lo) + u[:, j] * (np.log(hi) - np.log(lo))) if log else lo + u[:, j] * (hi - lo)
        frame = pd.DataFrame(data, columns=self.names)
        frame.insert(0, "variant", idx)
        return frame


def saltelli_block(d: int) -> int:
    """Rows per base point of a `sobol` sweep of d parameters: A, the D rows A with column j from B,
    the D rows B with column j from A, then B (the layout SALib's estimators read)."""
    return 2 * d + 2


def saltelli_sample(d: int, n: int, seed: int) -> np.ndarray:
    """(n (2d + 2), d) points of the unit cube: SALib's Saltelli sample on a scrambled Sobol' sequence
    of base size n, seeded (the sweep scales them to each parameter's range, as for lhs)."""
    from SALib.sample import sobol  # SALib and scipy.stats take a second to import: only sobol sweeps pay it

    problem = {"num_vars": d, "names": [f"x{j}" for j in range(d)], "bounds": [[0.0, 1.0]] * d}
    return sobol.sample(problem, n, calc_second_order=True, scramble=True, seed=seed)


def sampler_version(method: str) -> str | None:
    """What draws a `sobol` sweep's rows (SALib's and scipy's versions: scipy's Sobol' sequence might
    scramble otherwise in another release), for the manifest a resume must match; None otherwise."""
    if method != "sobol":
        return None
    from importlib.metadata import version

    return f"SALib {version('SALib')}, scipy {version('scipy')}"


def variant_table(spec: SweepSpec) -> pd.DataFrame:
    """The whole variant table as a DataFrame (for small sweeps; large ones use `spec.table()`)."""
    return spec.table().rows()


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


def _bounds(v: Any, method: str, where: str, meta: dict) -> tuple[float, float, bool]:
    """(low, high, log) of a random or LHS parameter."""
    if not isinstance(v, dict) or not {"low", "high"} <= set(v) or set(v) - {"low", "high", "log"}:
        raise ConfigError(f"{where}: {v!r} is not allowed; allowed for {method}: {{low, high, log}}")
    lo, hi = check_number(v["low"], meta, where), check_number(v["high"], meta, where)
    log = v.get("log", False)
    if not isinstance(log, bool):
        raise ConfigError(f"{where}.log: {log!r} is not true or false")
    if hi < lo or (log and lo <= 0):
        raise ConfigError(f"{where}: {v!r} is not allowed; allowed: low <= high (and low > 0 with log)")
    return lo, hi, log


def _check_sobol(sw: Sampling, where: str) -> None:
    """A Saltelli sample needs two parameters or more and a base size that is a power of two (the
    Sobol' sequence is balanced only at powers of two: refused, not rounded, so n is what was asked)."""
    if len(sw.params) < 2:
        raise ConfigError(
            f"{where}: sweep.params: one parameter ({', '.join(map(str, sw.params))}) is not allowed for sobol; "
            "allowed: two or more (with one, S1 = ST = 1 says nothing: sweep it with grid or lhs)"
        )
    n = int(sw.n)
    if n & (n - 1):
        low, high = 1 << (n.bit_length() - 1), 1 << n.bit_length()
        raise ConfigError(
            f"{where}: sweep.n: {n} is not allowed for sobol; allowed: a power of two (the base size N of the "
            f"Sobol' sequence, which is balanced only there), e.g. {low} or {high}"
        )


def _scenario(sc: Any, where: str) -> Scenario:
    if isinstance(sc, dict):
        return scenario_from_mapping(sc, f"{where}: scenario")
    if isinstance(sc, str):
        try:
            return load_scenario(sc)
        except ConfigError as err:
            raise ConfigError(f"{where}: scenario: {err}") from None
    raise ConfigError(f"{where}: scenario: {sc!r} is not allowed; allowed: a scenario name or mapping")


def _vehicle(veh: Any, where: str) -> Vehicle:
    if veh is None:
        return Vehicle()
    if isinstance(veh, dict):
        return vehicle_from_mapping(veh, f"{where}: vehicle")
    if isinstance(veh, str):
        path = Path(veh) if Path(veh).is_absolute() else Path(where).parent / veh
        return load_vehicle(path if path.exists() else veh)
    raise ConfigError(f"{where}: vehicle: {veh!r} is not allowed; allowed: null, a YAML path or a mapping")


def check_run(scenario: Scenario, window: tuple[float, float] | None, where: str) -> None:
    """Refuse a run that cannot give valid statistics: no steps, or a window outside the run or too short."""
    scenario.validate(where)
    try:
        StatsConfig.for_scenario(scenario, window)
    except ConfigError as err:
        raise ConfigError(f"{where}: {err}") from None


def load_spec(path: str | Path) -> SweepSpec:
    """Read and validate a sweep YAML (sweeps/*.yaml); every error is one ConfigError line.

    Returns the SweepSpec: its scenario and vehicle with the fixed values set, the swept `params`, the
    sampling, `output` and the engine's settings; `batchveh.run_sweep(spec)` runs it, `spec.table()` counts
    its variants, `batchveh.sizing.in_loop(spec, ...)` re-runs its variants with real motors."""
    return spec_from_mapping(load_yaml(path), str(path))


def spec_from_mapping(raw: dict[str, Any], where: str) -> SweepSpec:
    """Validate a sweep mapping (as read from YAML) into a SweepSpec."""
    top = from_mapping(SpecFile, raw, where)
    scenario, vehicle = _scenario(top.scenario, where), _vehicle(top.vehicle, where)
    specs = parameter_specs(vehicle)

    def param_meta(key: str, at: str) -> dict:
        if key in SCENARIO_SETTINGS:
            raise ConfigError(
                f"{where}: {at}.{key}: {key} is a scenario setting, not a parameter (it fixes the step count); "
                f"allowed: set it in the scenario mapping, e.g. scenario: {{kind: straight_line, {key}: ...}}"
            )
        if key not in specs:
            raise ConfigError(
                f"{where}: {at}.{key}: unknown parameter {key!r}{did_you_mean(key, specs)}; allowed: {', '.join(specs)}"
            )
        return specs[key]

    def number(v: Any, meta: dict, at: str) -> float:
        """A number in bounds, or a categorical parameter's name as its index."""
        if "choices" not in meta:
            return check_number(v, meta, at)
        if not isinstance(v, str) or v not in meta["choices"]:
            raise ConfigError(
                f"{at}: {v!r} is not in the catalogue{did_you_mean(str(v), meta['choices'])}; "
                f"allowed: {', '.join(meta['choices'])}"
            )
        return float(meta["choices"].index(v))

    fixed = {k: number(v, param_meta(k, "fixed"), f"{where}: fixed.{k}") for k, v in (top.fixed or {}).items()}
    sw = top.sweep
    params: dict[str, Any] = {}
    for k, v in sw.params.items():
        meta, at = param_meta(str(k), "sweep.params"), f"{where}: sweep.params.{k}"
        if k in fixed:
            raise ConfigError(f"{at}: {k!r} is both fixed and swept; keep one")
        if meta["acts"] == "static":
            raise ConfigError(
                f"{at}: {k} fixes the compiled program (array shapes, step count) and cannot be swept; "
                "allowed: one value under fixed (run one sweep per value)"
            )
        if meta.get("motor") and sw.method in SAMPLED:
            raise ConfigError(
                f"{at}: {k} is a motor parameter, compiled once per distinct value; allowed: a list of values "
                "under sweep method grid or zip"
            )
        if "choices" in meta:
            names = v if isinstance(v, list) and v else [v]
            params[k] = np.array([number(x, meta, at) for x in names])
        else:
            params[k] = _bounds(v, sw.method, at, meta) if sw.method in SAMPLED else _values(v, at, meta)
    if sw.method in SAMPLED and sw.n is None:
        allowed = "a power of two >= 1, the base size N" if sw.method == "sobol" else "an integer >= 1"
        raise ConfigError(f"{where}: sweep.n: missing; allowed: {allowed} for {sw.method}")
    if sw.method == "sobol":
        _check_sobol(sw, where)
    if sw.method == "zip" and len({len(v) for v in params.values()}) > 1:
        raise ConfigError(
            f"{where}: sweep.params: zip needs lists of one length; got { {k: len(v) for k, v in params.items()} }"
        )
    if top.window is not None and top.window[1] <= top.window[0]:
        raise ConfigError(
            f"{where}: window: {list(top.window)!r} is not allowed; allowed: [start_s, end_s], start < end"
        )
    given = scenario  # before the fixed values: a mission's unread fields are named where they were set
    vehicle, scenario = variant_setup(vehicle, scenario, fixed)
    vehicle.validate(f"{where}: vehicle")
    check_ground(vehicle.tyre.model, scenario.obstacle, f"{where}: scenario")
    of = f" (vehicle {top.vehicle}, steering.layout {vehicle.steering.layout})" if isinstance(top.vehicle, str) else ""
    check_layout(vehicle.steering.layout, scenario, f"{where}{of}: scenario")
    course.check_sweep(base_params(vehicle, scenario), params, scenario.obstacle, sw.method in SAMPLED, where)
    if scenario.kind == "mission":
        missions.check_sweep(given, params, fixed, where)
    check_run(scenario, top.window, where)
    return SweepSpec(
        name=top.name,
        scenario=scenario,
        vehicle=vehicle,
        fixed=fixed,
        method=sw.method,
        params=params,
        n=sw.n,
        seed=sw.seed,
        # a URI (s3://...) stays a string: Path would fold its "//"
        output=top.output if "://" in (top.output or "") else Path(top.output or Path("results") / top.name),
        window=top.window,
        lowpass_s=top.lowpass_s,
        chunk_size=top.chunk_size,
        backend=top.backend,
        precision=top.precision,
        solver=top.solver,
        raw=raw,
        where=where,
        duty=top.duty,
    )


def spec_of_result(path: str | Path) -> SweepSpec:
    """The spec a result directory was made from (from its file metadata)."""
    from batchveh.sweeping.results import metadata

    return spec_from_mapping(metadata(path)["spec"], f"{path} (metadata)")
