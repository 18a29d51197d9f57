"""Command-line interface: thin commands over the public API.

Each sub-command lives in its own module exposing ``register(subparsers)``, which adds and
returns the command's parser, and ``run(args)``, which executes the command with the parsed
arguments and returns an exit code. Errors from the library become one-line messages and
exit code 2, never tracebacks.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from simplexspline._version import __version__
from simplexspline.cli import demo, derivatives, export, identify, reconstruct, simulate
from simplexspline.errors import SimplexSplineError

#: Sub-command modules, in the order ``--help`` lists them.
COMMANDS = (identify, simulate, reconstruct, export, derivatives, demo)


def build_parser() -> argparse.ArgumentParser:
    """Build the top-level parser with every sub-command."""
    parser = argparse.ArgumentParser(
        prog="simplexspline",
        description="Multivariate simplex splines and aerodynamic model identification.",
    )
    parser.add_argument("--version", action="version", version=f"simplexspline {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for command in COMMANDS:
        command.register(sub).set_defaults(func=command.run)
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
