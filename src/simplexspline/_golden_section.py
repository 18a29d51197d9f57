"""Golden-section search for the minimum of a function of one variable on an interval."""

from __future__ import annotations

import math
from collections.abc import Callable

__all__ = ["golden_section"]

_RATIO = (math.sqrt(5.0) - 1.0) / 2.0


def golden_section(f: Callable[[float], float], lo: float, hi: float, *,
                   tol: float | None = None, steps: int | None = None) -> None:
    """Narrow [lo, hi] around a minimum of ``f`` by golden-section steps, until it is
    shorter than ``tol`` (positive) or after ``steps`` steps (at least one of them given),
    or when it no longer shrinks (floating-point spacing).

    ``f`` is called at the points tried and keeps what it needs (the caller's cache of
    values holds the result): the search returns nothing.
    """
    if tol is None and steps is None:
        raise ValueError("golden_section needs tol or steps")
    if tol is not None and not tol > 0:
        raise ValueError(f"golden_section's tol must be positive, got {tol!r}")
    a, b = lo, hi
    c, d = b - _RATIO * (b - a), a + _RATIO * (b - a)
    fc, fd = f(c), f(d)
    done, width = 0, math.inf
    # (and while the bracket still shrinks: below the floating-point spacing it cannot)
    while ((tol is None or b - a > tol) and (steps is None or done < steps)
           and b - a < width):
        width = b - a
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - _RATIO * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + _RATIO * (b - a)
            fd = f(d)
        done += 1
