"""The ``simplexspline`` command's entry point: the command line, safe to interrupt at once.

Importing the command line takes about two seconds (numpy, scipy, pandas, the compiled
spline kernels). A Ctrl-C in that time would otherwise print a long traceback from inside
some library's import, or worse, numpy's misleading "Importing the numpy C-extensions
failed" (its C code turns the interrupt into an ImportError). This module imports nothing
but built-in modules itself. While it imports the command line, a Ctrl-C is only noted;
once the import is done the command stops with the same one-line message and exit code
(130) as an interrupt during a command. What remains is the interpreter's own start-up
(some 20 ms, before any of the package's code runs).
"""

from __future__ import annotations

import sys

# The C module behind ``signal``: built into the interpreter, so importing it cannot be
# interrupted (``signal`` itself first imports enum, functools and collections).
import _signal as signal

__all__ = ["main"]


def main(argv=None) -> int:
    """Import and run the command line; returns the process exit code.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments (default: ``sys.argv[1:]``).
    """
    noted = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: noted.append(signum))
    try:
        from simplexspline.cli import main as run  # heavy: imported with Ctrl-C deferred
    finally:
        signal.signal(signal.SIGINT, previous)
    try:
        if noted:
            raise KeyboardInterrupt
        return run(argv)   # interrupts during a command are named by the command line
    except KeyboardInterrupt:   # during the import, or while parsing the arguments
        print("simplexspline: interrupted", file=sys.stderr)
        return 130
