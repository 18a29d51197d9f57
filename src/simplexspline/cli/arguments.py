"""Argument types and the parser of the command line: bad values become one-line errors.

Every numeric option is checked by its type when the command line is parsed, before any work
starts, so ``--seed -1`` or ``--maneuvers 0`` stop at once with a message that names the
option, the value and what is accepted (exit code 2, no usage dump, no traceback).
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import NoReturn

__all__ = ["Parser", "count", "fraction", "non_negative", "non_negative_number", "positive", "seed",
           "share"]


class Parser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` whose errors are one line on stderr and exit 2."""

    def error(self, message: str) -> NoReturn:
        print(f"{self.prog}: error: {message} (see {self.prog} --help)", file=sys.stderr)
        sys.exit(2)


def _number(text: str, kind: type) -> int | float:
    try:
        value = kind(text)
    except (TypeError, ValueError):
        word = "an integer" if kind is int else "a number"
        raise argparse.ArgumentTypeError(f"expected {word}, got {text!r}") from None
    if kind is float and not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def count(text: str) -> int:
    """An integer >= 1 (numbers of maneuvers, samples, workers, cells, rounds)."""
    value = _number(text, int)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return value


def non_negative(text: str) -> int:
    """An integer >= 0 (polynomial degree)."""
    value = _number(text, int)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}")
    return value


def seed(text: str) -> int:
    """A random seed: an integer in [0, 2**32) (numpy's and the simulator's seed range)."""
    value = _number(text, int)
    if not 0 <= value < 2**32:
        raise argparse.ArgumentTypeError(
            f"a seed must be an integer between 0 and {2**32 - 1}, got {text!r}")
    return value


def positive(text: str) -> float:
    """A finite number > 0 (scales, durations, noise levels)."""
    value = _number(text, float)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return value


def non_negative_number(text: str) -> float:
    """A finite number >= 0 (noise and bias scales: 0 switches the effect off)."""
    value = _number(text, float)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return value


def share(text: str) -> float:
    """A number between 0 and 1, both included (the share of turning maneuvers)."""
    value = _number(text, float)
    if not 0 <= value <= 1:
        raise argparse.ArgumentTypeError(f"expected a number from 0 to 1, got {text!r}")
    return value


def fraction(text: str) -> float:
    """A number strictly between 0 and 1 (validation fraction)."""
    value = _number(text, float)
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"expected a number between 0 and 1, got {text!r}")
    return value
