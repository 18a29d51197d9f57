"""Command-line interface: thin commands over the public API.

Each sub-command lives in its own module exposing ``register(subparsers)``; the module's
parser sets ``func`` (called with the parsed arguments, returning an exit code). Errors
from the library become one-line messages and exit code 2, never tracebacks.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from simplexspline.errors import SimplexSplineError

#: Sub-command modules, in the order ``--help`` lists them.
_COMMANDS = ("identify", "simulate", "reconstruct", "export", "derivatives", "demo")


def build_parser() -> argparse.ArgumentParser:
    """Build the top-level parser with every available sub-command."""
    from simplexspline._version import __version__

    parser = argparse.ArgumentParser(
        prog="simplexspline",
        description="Multivariate simplex splines and aerodynamic model identification.",
    )
    parser.add_argument("--version", action="version", version=f"simplexspline {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _COMMANDS:
        try:
            module = importlib.import_module(f"simplexspline.cli.{name}")
        except ModuleNotFoundError as exc:  # a command whose module is not present yet
            if exc.name == f"simplexspline.cli.{name}":
                continue
            raise
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 1
    try:
        return int(args.func(args) or 0)
    except SimplexSplineError as exc:
        print(f"simplexspline {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"simplexspline {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
