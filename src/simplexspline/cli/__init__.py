"""Command-line interface: thin commands over the public API.

Each sub-command lives in its own module exposing ``register(subparsers)``, which adds and
returns the command's parser, and ``run(args)``, which executes the command with the parsed
arguments and returns an exit code. Errors from the library become one-line messages and
exit code 2, never tracebacks: bad arguments (:mod:`~simplexspline.cli.arguments`), the
library's :class:`~simplexspline.errors.SimplexSplineError` and operating-system errors
(disk full, read-only or missing paths, permissions, out of memory).
"""

from __future__ import annotations

import argparse
import errno
import sys
from collections.abc import Sequence

from simplexspline._version import __version__
from simplexspline.cli import (arguments, demo, derivatives, export, identify, import_record,
                               reconstruct, simulate)
from simplexspline.errors import SimplexSplineError

#: Sub-command modules, in the order ``--help`` lists them.
COMMANDS = (identify, simulate, import_record, reconstruct, export, derivatives, demo)


def build_parser() -> argparse.ArgumentParser:
    """Build the top-level parser with every sub-command."""
    parser = arguments.Parser(
        prog="simplexspline",
        description="Multivariate simplex splines and aerodynamic model identification.",
    )
    parser.add_argument("--version", action="version", version=f"simplexspline {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for command in COMMANDS:
        command.register(sub).set_defaults(func=command.run)
    return parser


#: What to do about the operating-system errors a command meets most often.
_OS_ADVICE = {
    errno.ENOSPC: "free disk space or write somewhere else",
    errno.EDQUOT: "free disk space or write somewhere else",
    errno.EROFS: "the file system is read-only: write somewhere else",
    errno.EACCES: "check the permissions, or write somewhere else",
    errno.EPERM: "check the permissions, or write somewhere else",
    errno.ENOENT: "check the path",
    errno.ENOTDIR: "a part of the path is a file, not a directory: check the path",
    errno.EISDIR: "the path is a directory: give a file name",
}


def os_error_message(exc: OSError) -> str:
    """One line for an operating-system error: what failed, on which path, and what to do.

    >>> os_error_message(OSError(2, "No such file or directory", "flight.parquet"))
    "cannot read 'flight.parquet': No such file or directory (errno 2); check the path"
    """
    where = f" {exc.filename!r}" if exc.filename else ""
    verb = "read" if exc.errno in (errno.ENOENT, errno.ENOTDIR) else "write"
    what = exc.strerror or str(exc) or type(exc).__name__
    advice = _OS_ADVICE.get(exc.errno, "check the path, the permissions and the free space")
    code = f" (errno {exc.errno})" if exc.errno else ""
    return f"cannot {verb}{where}: {what}{code}; {advice}"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the process exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a bad argument (one line printed)
        return exc.code if isinstance(exc.code, int) else 0 if exc.code is None else 2
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 1
    try:
        return int(args.func(args) or 0)
    except SimplexSplineError as exc:
        print(f"simplexspline {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"simplexspline {args.command}: error: {os_error_message(exc)}", file=sys.stderr)
        return 2
    except MemoryError:
        print(f"simplexspline {args.command}: error: out of memory; use fewer samples or "
              "maneuvers, a smaller model, or a machine with more memory", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"simplexspline {args.command}: interrupted", file=sys.stderr)
        return 130
