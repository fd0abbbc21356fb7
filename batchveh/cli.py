"""One error path for every command line (sweep, size, run, render, sensitivity).

Each command builds its parser (`OneLineParser`) and hands it, with the body that runs on the parsed
arguments, to `run_main`. Every input error is then one line on stderr and exit 2: a bad flag (the
parser; an unknown one names the flags allowed), a `ConfigError` (its message names the file, the key,
the value and what is allowed) and an `OSError` such as a missing file (the path and the reason). A
command's own exit codes for other exceptions come in `codes` (the size and the sweep command: 3 where
results exist); Ctrl-C is one line and exit 130. No traceback for any of them; a bug still shows its own.
"""

from __future__ import annotations

import argparse
import difflib
import sys
from collections.abc import Callable, Mapping
from typing import Any

from batchveh.config import ConfigError, OneLineParser

EXIT_OK, EXIT_INPUT, EXIT_INTERRUPTED = 0, 2, 130

__all__ = ["EXIT_INPUT", "EXIT_INTERRUPTED", "EXIT_OK", "OneLineParser", "error_line", "parse", "run_main"]


def one_line(text: Any) -> str:
    """`text` on one line: an error message from a library may span several."""
    return " ".join(part.strip() for part in str(text).splitlines() if part.strip())


def error_line(message: Any) -> None:
    """Print `message` as the command's one `error: ...` line on stderr."""
    print(f"error: {one_line(message)}", file=sys.stderr)


def _flags(parser: argparse.ArgumentParser) -> list[str]:
    """The long flags `parser` takes ('--out', ...), the help's own left out."""
    return [
        max(a.option_strings, key=len)
        for a in parser._actions  # argparse keeps no public list of its actions
        if a.option_strings and not isinstance(a, argparse._HelpAction)
    ]


def parse(parser: argparse.ArgumentParser, argv: list[str] | None) -> argparse.Namespace:
    """`parser.parse_args(argv)`, where an unknown argument's one line names the flags allowed (argparse
    names only the unknown one). A bad flag exits 2 through the parser's `error`: one line with a
    `OneLineParser`; `--help` exits 0 after printing the help, as argparse does."""
    if not isinstance(parser, OneLineParser):
        raise TypeError(f"{parser.prog}: the parser must be a batchveh.config.OneLineParser (one line per error)")
    args, extra = parser.parse_known_args(argv)
    if extra:
        flags = _flags(parser)
        first = next((a for a in extra if a.startswith("-")), None)
        names = {f.lstrip("-"): f for f in flags}  # matched without the dashes, which every flag shares
        close = difflib.get_close_matches(first.split("=")[0].lstrip("-"), names, n=1) if first else []
        hint = f" (did you mean {names[close[0]]!r}?)" if close else ""
        positional = [a.dest for a in parser._actions if not a.option_strings]
        allowed = ", ".join([*(f"<{p}>" for p in positional), *flags])
        parser.error(f"unrecognized arguments: {' '.join(extra)}{hint}; allowed: {allowed}")
    return args


def run_main(
    parser: argparse.ArgumentParser,
    body: Callable[[argparse.Namespace], int],
    argv: list[str] | None = None,
    *,
    codes: Mapping[type[BaseException] | tuple[type[BaseException], ...], int] | None = None,
    where: Callable[[argparse.Namespace], Any] | None = None,
    interrupted: str = "",
) -> int:
    """Parse `argv` with `parser` and return `body(args)`'s exit code, every input error as one line.

    - a bad flag: `parser.error`'s one line, exit 2 (SystemExit from the parser, as argparse's own)
    - `codes`: exception types to the command's own codes (checked first, e.g. {FileExistsError: 3}),
      the line is the exception's message
    - `ConfigError`: its message, exit 2
    - `OSError` (a missing or unreadable file, a full disk): 'PATH: reason', exit 2; PATH is the error's
      own file name, else `where(args)` (the output, say), else none
    - KeyboardInterrupt: 'interrupted' and `interrupted` (what is kept, how to go on), exit 130
    """
    args = parse(parser, argv)
    try:
        return body(args)
    except BaseException as err:
        own = next((code for kinds, code in (codes or {}).items() if isinstance(err, kinds)), None)
        if own is not None:
            error_line(err)
            return own
        if isinstance(err, KeyboardInterrupt):  # a new line first: a progress bar may be mid-line
            print(f"\ninterrupted{': ' + interrupted if interrupted else ''}", file=sys.stderr)
            return EXIT_INTERRUPTED
        if isinstance(err, ConfigError):
            error_line(err)
            return EXIT_INPUT
        if isinstance(err, OSError):
            place = err.filename or (where(args) if where is not None else None)
            reason = err.strerror or one_line(err) or type(err).__name__
            error_line(f"{place}: {reason}" if place else reason)
            return EXIT_INPUT
        raise  # a bug: its traceback
