"""Which parameter drives each statistic: Sobol' indices of a `sobol` sweep, through SALib
(the command line is `python -m batchveh.sensitivity`, batchveh/sensitivity.py).

For each statistic (a numeric result column, or one derived from them) and each swept
parameter: the first-order index S1, the share of the statistic's variance the parameter
explains alone; the total index ST, which adds its interactions with all the others; and the
half-widths of their confidence intervals. SALib's `sobol.analyze` estimates them (Saltelli et
al. 2010; bootstrap intervals over the base points) from the Saltelli sample the sweep ran
(`spec.saltelli_sample`): N base points, each a block of 2D + 2 rows. The sample is checked
against that layout first, from the rows' own parameter values.

The answer is a tidy table, a row per (statistic, parameter), with the statistic's unit and
spread; `write` puts it in Parquet (units on the fields, the metadata on the file) and CSV (the
metadata in leading `#` lines: `pandas.read_csv(path, comment="#")`).

Rows that are not `ok` (diverged, flipped, stuck, short) and rows that are missing (`--limit`, a
sweep not finished) are handled explicitly, because the estimators need every row of a block:

- `non_ok="drop"` (default): a base point with a row that is not ok is left out whole, so the
  indices describe the variants that ran through, and the Sobol' sequence's balance is lost;
- `non_ok="keep"`: the rows' statistics are used whatever their status;
- `non_ok="refuse"`: any row not ok is an error.

A base point with a missing row, or a non-finite value of the statistic, is always left out.
Every such choice is counted in the metadata and said in a `SensitivityWarning`; so is every
index whose confidence interval is wider than the index (2 x half-width > |index|): such an
index is not resolved from zero at this N.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from batchveh.config import ConfigError, did_you_mean
from batchveh.sweeping.results import ResultError, ResultFolder, annotated_table, load, units
from batchveh.sweeping.spec import SweepSpec, saltelli_block, spec_of_result
from batchveh.sweeping.storage import filesystem, parquet_bytes, write_atomic

NON_OK = ("drop", "keep", "refuse")
MIN_BASE_POINTS = 4  # fewer give no bootstrap interval worth the name
CONSTANT_RTOL = 1e-12  # a statistic whose spread is below this share of its size is constant
FILE = "sensitivity"  # sensitivity.parquet and sensitivity.csv in the result folder, by default
COLUMNS = {
    "statistic": ("", "the result column (or derived statistic) the indices are of"),
    "unit": ("", "the statistic's unit"),
    "parameter": ("", "the swept parameter"),
    "parameter_unit": ("", "the parameter's unit"),
    "S1": ("1", "first-order Sobol' index: the share of the statistic's variance the parameter explains alone"),
    "S1_conf": ("1", "half-width of S1's confidence interval (bootstrap over the base points)"),
    "ST": ("1", "total Sobol' index: S1 and every interaction of the parameter with the others"),
    "ST_conf": ("1", "half-width of ST's confidence interval (bootstrap over the base points)"),
    "std": ("", "standard deviation of the statistic over the rows used, in the row's unit"),
    "base_points": ("", "base points (blocks of 2D + 2 rows) the estimate used"),
    "ci_wide": ("", "an interval wider than its index (2 x half-width > |index|), S1 or ST: not resolved from zero"),
}


class SensitivityWarning(UserWarning):
    """Rows left out of the estimate, or indices not resolved by their confidence intervals."""


Derived = Mapping[str, Callable[[pd.DataFrame], Any] | tuple[Callable[[pd.DataFrame], Any], str]]


def sensitivity(
    result: str | Path,
    statistics: str | Sequence[str] | None = None,
    *,
    derived: Derived | None = None,
    non_ok: str = "drop",
    conf_level: float = 0.95,
    resamples: int = 100,
    seed: int = 1,
) -> pd.DataFrame:
    """S1, ST and their confidence intervals of every numeric statistic of a `sobol` sweep's result.

    `result`: the result folder (a path or a URI). `statistics`: the columns to analyse (default:
    every numeric column that is not a parameter, and the derived ones). `derived`: statistics
    computed from the loaded rows, {name: function(frame) -> values} or {name: (function, unit)},
    e.g. the worst of four motors. `non_ok`: drop, keep or refuse the rows that are not ok (module
    docstring). `conf_level`, `resamples`, `seed`: SALib's bootstrap (seed >= 1: SALib leaves a
    seed of 0 unseeded). Returns the tidy table (columns `COLUMNS`) with the metadata in
    `table.attrs["sensitivity"]`; ConfigError (one line) for a result or option that cannot give
    indices; a SensitivityWarning for each thing left out or not resolved."""
    from SALib.analyze import sobol

    where = str(result)
    _check_options(non_ok, conf_level, resamples, seed)
    spec = _sobol_spec(result)
    names = list(spec.params)
    frame = load(result)
    unit_of = units(result)
    extra = _derived(frame, derived or {}, where)
    chosen = _statistics(frame, statistics, names, extra, where)
    sample = _Sample(frame, spec, non_ok, where)

    problem = {"num_vars": len(names), "names": names, "bounds": [[0.0, 1.0]] * len(names)}
    rows, left_out = [], {}
    for stat in chosen:
        values, unit = extra[stat] if stat in extra else (frame[stat].to_numpy(float), unit_of.get(stat, ""))
        y = values[sample.pos[sample.use]]  # (base points, 2D + 2)
        y = y[np.isfinite(y).all(axis=1)]
        if len(y) < MIN_BASE_POINTS:
            left_out[stat] = f"{len(y)} base points with finite values, fewer than {MIN_BASE_POINTS}"
            continue
        if np.ptp(y) <= CONSTANT_RTOL * np.abs(y).max():
            left_out[stat] = "constant over the sample: no variance to share"
            continue
        with warnings.catch_warnings():  # SALib warns where a bootstrap resample is constant: the interval says it
            warnings.simplefilter("ignore")
            si = sobol.analyze(  # second order too: SALib reads the 2D + 2 layout only then (S2 is not reported)
                problem, y.ravel(), calc_second_order=True, num_resamples=resamples, conf_level=conf_level, seed=seed
            )
        for j, p in enumerate(names):
            rows.append(
                {
                    "statistic": stat,
                    "unit": unit,
                    "parameter": p,
                    "parameter_unit": unit_of.get(p, ""),
                    **{k: float(si[k][j]) for k in ("S1", "S1_conf", "ST", "ST_conf")},
                    "std": float(np.std(y)),
                    "base_points": len(y),
                }
            )
    table = pd.DataFrame(rows, columns=[c for c in COLUMNS if c != "ci_wide"])
    table["ci_wide"] = _wide(table, "S1") | _wide(table, "ST")
    found = _warnings(table, left_out, sample, where)
    table.attrs["sensitivity"] = {
        **_metadata(spec, result, sample, left_out),
        "conf_level": conf_level,
        "resamples": resamples,
        "seed": seed,
        "warnings": found,
    }
    for text in found:
        warnings.warn(text, SensitivityWarning, stacklevel=2)
    return table


class _Sample:
    """Which base points of a sobol result enter the estimate: `pos` (N, 2D + 2) the row of each variant
    (-1: missing), `use` (N,) the base points complete and, with non_ok drop, ok; `notes` say why."""

    def __init__(self, frame: pd.DataFrame, spec: SweepSpec, non_ok: str, where: str):
        n_base, d = int(spec.n), len(spec.params)
        block = saltelli_block(d)
        variants, total = frame["variant"].to_numpy(), n_base * block
        if len(variants) and (
            variants.min() < 0 or variants.max() >= total or len(np.unique(variants)) < len(variants)
        ):
            raise ResultError(
                f"{where}: variant ids outside 0..{total - 1} or repeated; the parts do not come from this sobol sweep"
            )
        pos = np.full(total, -1)
        pos[variants] = np.arange(len(variants))
        self.pos, self.rows, self.missing = pos.reshape(n_base, block), len(frame), total - len(variants)
        present = (self.pos >= 0).all(axis=1)
        _check_layout(frame[list(spec.params)].to_numpy(float)[self.pos[present]], d, where)
        status = frame["status"].to_numpy().astype(str)
        self.counts = {k: int(v) for k, v in pd.Series(status).value_counts().items()}
        self.bad = len(frame) - self.counts.get("ok", 0)
        ok = np.zeros(n_base, bool)
        ok[present] = (status[self.pos[present]] == "ok").all(axis=1)
        if non_ok == "refuse" and self.bad:
            raise ResultError(
                f"{where}: {self.bad:,} of {len(frame):,} rows are not ok ({_counts(self.counts)}); Sobol' estimators "
                f"need every row of a base point; allowed: non_ok drop (leave out the {int((present & ~ok).sum()):,} "
                "base points that hold them) or keep (use their statistics as they are)"
            )
        self.use = present & ok if non_ok == "drop" else present
        self.non_ok = non_ok
        self.notes = []  # what happened to the sample, for the metadata and the warnings
        if self.missing:
            self.notes.append(
                f"{self.missing:,} of {total:,} variants are missing (--limit, or a sweep not finished): "
                f"{int((~present).sum()):,} of {n_base:,} base points are incomplete and left out"
            )
        if self.bad:
            share = (
                f"{self.bad:,} of {len(frame):,} rows ({self.bad / len(frame):.1%}) are not ok ({_counts(self.counts)})"
            )
            held = int((present & ~self.use).sum())
            self.notes.append(
                f"{share}: the {held:,} base points that hold them ({held / n_base:.1%} of {n_base:,}) are left out, "
                "so the indices describe the variants that ran through (non_ok keep uses them, refuse stops)"
                if non_ok == "drop"
                else f"{share}: kept, their statistics used as they are (non_ok keep)"
            )
        used = int(self.use.sum())
        self.summary = f"{used:,} of {n_base:,} base points used ({used * block:,} rows)"
        if used < MIN_BASE_POINTS:
            raise ResultError(
                f"{where}: {used} base points of {n_base:,} are complete{' and ok' * (non_ok == 'drop')}; "
                f"allowed: at least {MIN_BASE_POINTS} ({'; '.join([*self.notes, self.summary])})"
            )


def _wide(table: pd.DataFrame, index: str) -> pd.Series:
    """Whether each row's interval of `index` (S1 or ST) is wider than the index: 2 x half-width > |index|."""
    return 2 * table[f"{index}_conf"] > table[index].abs()


def _check_options(non_ok: str, conf_level: float, resamples: int, seed: int) -> None:
    if non_ok not in NON_OK:
        raise ConfigError(f"non_ok: {non_ok!r} is not allowed; allowed: {', '.join(NON_OK)}")
    if not 0 < conf_level < 1:
        raise ConfigError(f"conf_level: {conf_level!r} is not allowed; allowed: between 0 and 1, e.g. 0.95")
    for key, value in (("resamples", resamples), ("seed", seed)):
        if isinstance(value, bool) or not isinstance(value, int) or value < (2 if key == "resamples" else 1):
            raise ConfigError(
                f"{key}: {value!r} is not allowed; allowed: an integer >= {2 if key == 'resamples' else 1}"
            )


def _sobol_spec(result: str | Path) -> SweepSpec:
    """The spec of `result`, which must be a `sobol` sweep."""
    try:
        spec = spec_of_result(result)
    except KeyError:
        raise ResultError(f"{result}: no sweep spec in the file metadata (not a batchveh sweep result)") from None
    if spec.method != "sobol":
        raise ResultError(
            f"{result}: sweep.method is {spec.method!r}; Sobol' indices need the Saltelli sample of a sobol sweep; "
            "allowed: sweep: {method: sobol, n: 1024, params: {name: {low, high}, ...}}"
        )
    return spec


def _derived(frame: pd.DataFrame, derived: Derived, where: str) -> dict[str, tuple[np.ndarray, str]]:
    out = {}
    for name, entry in derived.items():
        fn, unit = entry if isinstance(entry, tuple) else (entry, "")
        if name in frame:
            raise ConfigError(f"derived: {name!r} is a column of {where} already; allowed: a new name")
        values = np.asarray(fn(frame), float)
        if values.shape != (len(frame),):
            raise ConfigError(
                f"derived: {name!r} gives shape {values.shape}; allowed: one value per row ({len(frame)})"
            )
        out[name] = (values, unit)
    return out


def _statistics(frame, statistics, names, extra, where) -> list[str]:
    """The statistics to analyse, checked: numeric result columns that are not parameters, or derived."""
    columns = [c for c in frame.columns if c != "variant" and c not in names and frame[c].dtype.kind in "fiu"]
    numeric = [*columns, *extra]
    if statistics is None:
        return numeric
    chosen = [statistics] if isinstance(statistics, str) else list(statistics)
    for s in chosen:
        if s in names:
            raise ConfigError(f"statistics: {s!r} is a swept parameter of {where}; allowed: a statistic")
        if s not in numeric:
            why = "not a numeric column" if s in frame else f"unknown{did_you_mean(s, numeric)}"
            raise ConfigError(f"statistics: {s!r} is {why} in {where}; allowed: a numeric statistic, e.g. {numeric[0]}")
    if not chosen:
        raise ConfigError(f"statistics: empty; allowed: one or more of {where}'s numeric columns")
    return chosen


def _check_layout(x: np.ndarray, d: int, where: str) -> None:
    """x (base points, 2d + 2, d): each block is A, A with column j from B (d rows), B with column j
    from A (d rows), B; raise ResultError where the rows' parameter values are not that layout."""
    a, b = x[:, 0], x[:, -1]
    for j in range(d):
        ab, ba = a.copy(), b.copy()
        ab[:, j], ba[:, j] = b[:, j], a[:, j]
        if not (np.array_equal(x[:, 1 + j], ab) and np.array_equal(x[:, 1 + d + j], ba)):
            raise ResultError(
                f"{where}: the rows' parameter values are not a Saltelli sample (blocks of 2D + 2 = "
                f"{saltelli_block(d)} rows by variant); the parts do not come from this sobol sweep"
            )


def _counts(counts: Mapping[str, int]) -> str:
    return ", ".join(f"{v:,} {k}" for k, v in counts.items() if k != "ok") or "none"


def _warnings(table: pd.DataFrame, left_out: dict[str, str], sample: _Sample, where: str) -> list[str]:
    found = [f"{where}: {note}" for note in sample.notes]
    if left_out:
        some = "; ".join(f"{k}: {v}" for k, v in list(left_out.items())[:3])
        more = f" (and {len(left_out) - 3} more)" if len(left_out) > 3 else ""
        found.append(f"{where}: {len(left_out)} statistics left out: {some}{more}")
    for s in ("S1", "ST"):
        wide = table[_wide(table, s)]
        if len(wide):
            ex = wide.iloc[(wide[s].abs() - 2 * wide[f"{s}_conf"]).argmin()]  # the least resolved
            found.append(
                f"{where}: the confidence interval of {s} is wider than the index for {len(wide)} of {len(table)} "
                f"(statistic, parameter) pairs, e.g. {ex.parameter} for {ex.statistic}: {ex[s]:.3g} +- "
                f"{ex[f'{s}_conf']:.2g}; those are not resolved from zero: read them as below |index| + interval, "
                "or raise n"
            )
    return found


def _metadata(spec: SweepSpec, result: str | Path, sample: _Sample, left_out: dict[str, str]) -> dict[str, Any]:
    from importlib.metadata import version

    from batchveh import __version__

    n_base, used = int(spec.n), int(sample.use.sum())
    return {
        "result": str(result),
        "sweep": spec.name,
        "parameters": {k: {"low": lo, "high": hi, "log": log} for k, (lo, hi, log) in spec.params.items()},
        "base_size": n_base,
        "variants": n_base * saltelli_block(len(spec.params)),
        "rows": sample.rows,
        "missing_rows": sample.missing,
        "status": sample.counts,
        "non_ok": sample.non_ok,
        "base_points_used": used,
        "base_points_left_out": n_base - used,
        "estimator": "SALib.analyze.sobol.analyze (Saltelli et al. 2010), bootstrap intervals over base points",
        "versions": {"batchveh": __version__, "SALib": version("SALib")},
        "notes": [*sample.notes, sample.summary],
        "left_out": left_out,
    }


def write(table: pd.DataFrame, out: str | Path) -> list[str]:
    """Write `table` as `out`.parquet (units and descriptions on the fields, the metadata on the file)
    and `out`.csv (the metadata in leading `#` lines); `out` a local path or a URI, without suffix."""
    fs, root = filesystem(out)
    fs.create_dir(root.rsplit("/", 1)[0], recursive=True)
    written = []
    for suffix, data in _files(table).items():
        write_atomic(fs, root + suffix, data)
        written.append(f"{out}{suffix}")
    return written


def _files(table: pd.DataFrame) -> dict[str, bytes]:
    """{suffix: bytes} of the Parquet and CSV files of `table`."""
    meta = table.attrs.get("sensitivity", {})
    fields = {c: {"unit": u, "description": doc} for c, (u, doc) in COLUMNS.items()}
    parquet = annotated_table(table, fields, {"batchveh_sensitivity": json.dumps(meta, default=str)})
    head = "".join(f"# {k}: {json.dumps(v, default=str)}\n" for k, v in meta.items())
    return {".parquet": parquet_bytes(parquet).to_pybytes(), ".csv": (head + table.to_csv(index=False)).encode()}


def write_into_result(table: pd.DataFrame, result: str | Path) -> list[str]:
    """Write `table` into the result folder (sensitivity.parquet, sensitivity.csv) under its lock, and
    record the files in its manifest, so that the sweep's --overwrite removes them with the parts."""
    folder = ResultFolder(result)
    with folder.lock():
        return folder.add_files({FILE + suffix: data for suffix, data in _files(table).items()})


def summary(table: pd.DataFrame, top: int = 3) -> list[str]:
    """A line per statistic: its unit and spread, then its `top` parameters by ST."""
    lines = []
    for stat, rows in table.groupby("statistic", sort=False):
        rows = rows.sort_values("ST", ascending=False)
        first = rows.iloc[0]
        unit = f" [{first.unit}]" if first.unit else ""
        parts = [
            f"{r.parameter} ST {r.ST:.3f}+-{r.ST_conf:.3f} S1 {r.S1:.3f}+-{r.S1_conf:.3f}{' (wide)' * r.ci_wide}"
            for r in rows.head(top).itertuples()
        ]
        lines.append(f"{stat}{unit}, std {first['std']:.3g}: " + "; ".join(parts))
    return lines
