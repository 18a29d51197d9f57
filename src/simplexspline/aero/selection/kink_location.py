"""Where a kink lies: the breakpoint of a kink term moved to where the fit's squared error is
least.

The search places a kink ``m*|v-k|`` at one of a few quantiles of ``v``'s data
(:func:`~simplexspline.aero.selection.moves.kink_positions`, 5 % apart): enough to find
that a slope changes, not where. Where it changes matters when the data cluster near the
breakpoint (flight conditions are flown at a few Mach numbers): on the main job's F-16
campaign the roll moment's sideslip derivative starts to change at the table's Mach 0.6;
the nearest quantile was 0.612, and the model's error against the truth at the true
inputs went from 2.4 to 0.9 times the noise with the kink moved to 0.6 (a second kink at
the table's 0.8 then helped as well; next to the misplaced one it did not). Adaptive
regression splines place their knots at the data value that minimises the residual sum of
squares (Friedman 1991); this is that search, along ``v`` between the candidate positions
two either side of the kink's own, on the fit of the whole model (the term's coefficient is a spline of
the other scheduling variables, so a regression of the current residual on the hinge alone
points to the wrong place: measured, it preferred Mach 0.611 and 0.682).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from simplexspline._golden_section import golden_section
from simplexspline.aero.modelling.structure import Structure
from simplexspline.aero.selection.moves import kinked_variable, with_breakpoint

__all__ = ["GRID_POINTS", "GOLDEN_STEPS", "REACH", "place_kink", "round_breakpoint"]

#: How far the search looks: this many candidate positions either side of the kink's own
#: (flight conditions cluster the data, so neighbouring quantiles can lie far apart, and
#: the one the screen took need not be the nearest to the slope change: 0.612 of 0.536,
#: 0.609, 0.612 and 0.678, for a change at 0.6).
REACH = 2
#: Evenly spaced breakpoints tried in that bracket.
GRID_POINTS = 9
#: Golden-section steps around the best of them.
GOLDEN_STEPS = 5


def round_breakpoint(k: float) -> float:
    """A breakpoint as the model's label writes it: 3 significant digits."""
    return float(f"{float(k):.3g}")


def place_kink(structure: Structure, term: str, positions: Sequence[float],
               sse: Callable[[Structure], float], *,
               limits: tuple[float, float] | None = None) -> tuple[Structure, float]:
    """The structure with the breakpoint of its kink term ``term`` moved to where ``sse``
    is least, between the breakpoint's neighbours among the candidate ``positions``.

    Parameters
    ----------
    structure : Structure
        A varying-coefficient structure holding ``term`` (``m*|v-k|``).
    term : str
        The kink term, one of ``structure.multipliers``.
    positions : sequence of float
        The candidate breakpoints along ``v`` (physical units), of which the term's
        breakpoint is normally one: the search looks between the :data:`REACH`-th
        positions below and above it.
    sse : callable
        Residual sum of squares of a structure fitted to the identification samples
        (``inf`` when the fit fails).
    limits : (float, float), optional
        How far the search may go where fewer than :data:`REACH` positions lie on one side
        (the data's range of ``v``); default: not beyond the breakpoint itself.

    Returns
    -------
    structure : Structure
        With the term's breakpoint at the best place found (``structure`` itself when no
        place is better than the term's own breakpoint).
    sse : float
        Its residual sum of squares.
    """
    found = kinked_variable(term)
    if found is None or term not in structure.multipliers:
        raise ValueError(f"{term!r} is not a kink term of {structure.label()}")
    v, k0 = found
    ks = np.unique(np.asarray(positions, dtype=float))
    lo_limit, hi_limit = limits if limits is not None else (k0, k0)
    below, above = ks[ks < k0], ks[ks > k0]
    lo = below[-REACH] if len(below) >= REACH else min(lo_limit, k0)
    hi = above[REACH - 1] if len(above) >= REACH else max(hi_limit, k0)
    # other kinks of the same factors along v: the term may not land on one of them
    kinked = {t: kinked_variable(t) for t in structure.multipliers if t != term}
    others = [found[1] for t, found in kinked.items()
              if found is not None and found[0] == v and with_breakpoint(t, k0) == term]
    tolerance = 0.05 * (hi - lo)
    index = structure.multipliers.index(term)
    values: dict[float, tuple[float, Structure]] = {}

    def at(k: float) -> float:
        k = round_breakpoint(k)
        if k in values:
            return values[k][0]
        if k != round_breakpoint(k0) and any(abs(k - o) <= tolerance for o in others):
            values[k] = (np.inf, structure)
            return np.inf
        terms = list(structure.multipliers)
        terms[index] = with_breakpoint(term, k)
        s = structure if k == round_breakpoint(k0) else structure.with_(
            multipliers=tuple(terms))
        e = float(sse(s))
        values[k] = (e if np.isfinite(e) else np.inf, s)    # a failed fit: never the best
        return values[k][0]

    base = at(k0)
    if not hi > lo:
        return structure, base
    grid = np.linspace(lo, hi, GRID_POINTS)
    scores = [at(k) for k in grid]
    j = int(np.argmin(scores))
    a, b = grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]
    golden_section(at, a, b, steps=GOLDEN_STEPS)     # in the best grid point's bracket
    k_best = min(values, key=lambda k: values[k][0])
    best, s_best = values[k_best][0], values[k_best][1]
    if not best < base:
        return structure, base
    return s_best, best
