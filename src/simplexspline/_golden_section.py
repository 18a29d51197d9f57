"""Golden-section search for the minimum of a function of one variable on an interval."""

from __future__ import annotations

import math
from collections.abc import Callable

__all__ = ["golden_section"]

_RATIO = (math.sqrt(5.0) - 1.0) / 2.0


def golden_section(f: Callable[[float], float], lo: float, hi: float, *,
                   tol: float | None = None, steps: int | None = None) -> None:
    """Narrow [lo, hi] around a minimum of ``f`` by golden-section steps, until it is
    shorter than ``tol`` or after ``steps`` steps (at least one of them given).

    ``f`` is called at the points tried and keeps what it needs (the caller's cache of
    values holds the result): the search returns nothing.
    """
    if tol is None and steps is None:
        raise ValueError("golden_section needs tol or steps")
    a, b = lo, hi
    c, d = b - _RATIO * (b - a), a + _RATIO * (b - a)
    fc, fd = f(c), f(d)
    done = 0
    while (tol is None or b - a > tol) and (steps is None or done < steps):
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - _RATIO * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + _RATIO * (b - a)
            fd = f(d)
        done += 1
