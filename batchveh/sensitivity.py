"""Which parameter drives each statistic: Sobol' indices of a `sobol` sweep, through SALib.

    python -m batchveh.sensitivity results/NAME
    python -m batchveh.sensitivity results/NAME --statistics drive_sum_peak_lp,steer_lf_rms --out /tmp/climb

The command line over `batchveh.analysis.sensitivity` (the estimators, the tidy table, its files
and warnings; its docstring says how rows that are not ok are handled). `batchveh.sensitivity(
result, ...)` calls that module's `sensitivity`; import its other names from there.
"""

from __future__ import annotations

import argparse
import sys
import types
import warnings

from batchveh.analysis.sensitivity import (
    NON_OK,
    SensitivityWarning,
    sensitivity,
    summary,
    write,
    write_into_result,
)
from batchveh.cli import run_main
from batchveh.config import OneLineParser
from batchveh.sweeping.results import Locked

EXIT_OK, EXIT_INPUT, EXIT_EXISTS = 0, 2, 3

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(
        prog="python -m batchveh.sensitivity",
        description=__doc__.split("\n\n")[0],
        epilog="Exit codes: 0 done (warnings on stderr), 2 bad result folder or argument (one line), 3 a sweep is "
        "writing into the folder. Output: OUT.parquet and OUT.csv, by default sensitivity.* in the result folder.",
    )
    parser.add_argument("result", help="result folder of a sobol sweep, e.g. results/NAME")
    parser.add_argument("--statistics", help="comma-separated columns (default: every numeric statistic)")
    parser.add_argument(
        "--non-ok",
        choices=NON_OK,
        default="drop",
        help="rows not ok: drop their base points (default), keep their statistics, or refuse",
    )
    parser.add_argument("--out", help="path (or URI) of the output without suffix (default: RESULT/sensitivity)")
    parser.add_argument("--conf-level", type=float, default=0.95, help="confidence level (default 0.95)")
    parser.add_argument("--resamples", type=int, default=100, help="bootstrap resamples (default 100)")
    parser.add_argument("--top", type=int, default=3, help="parameters printed per statistic (default 3)")
    return run_main(parser, _sensitivity, argv, codes={Locked: EXIT_EXISTS}, where=lambda args: args.out or args.result)


def _sensitivity(args: argparse.Namespace) -> int:
    """The command on its parsed arguments; `run_main` turns its input errors into one line."""
    chosen = [s.strip() for s in args.statistics.split(",") if s.strip()] if args.statistics is not None else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SensitivityWarning)
        table = sensitivity(
            args.result, chosen, non_ok=args.non_ok, conf_level=args.conf_level, resamples=args.resamples
        )
    written = write(table, args.out) if args.out else write_into_result(table, args.result)
    for w in caught:
        if issubclass(w.category, SensitivityWarning):
            print(f"warning: {w.message}", file=sys.stderr)
    meta = table.attrs["sensitivity"]
    print(
        f"{meta['sweep']}: {len(table) // max(len(meta['parameters']), 1)} statistics x {len(meta['parameters'])} "
        f"parameters; {meta['notes'][-1]}"
    )
    for line in summary(table, args.top):
        print(line)
    print("written: " + ", ".join(written))
    return EXIT_OK


class _CallableModule(types.ModuleType):
    """`batchveh.sensitivity(result, ...)` calls `sensitivity`: the module and the function share the
    name (the CLI is `python -m batchveh.sensitivity`), and the import system binds the module to the
    package's attribute, so the module itself answers the call (with no frame of its own between, so
    a warning points at the caller's line)."""

    __call__ = staticmethod(sensitivity)


sys.modules[__name__].__class__ = _CallableModule

if __name__ == "__main__":
    sys.exit(main())
