"""The moves of the greedy structure search: from one structure to its neighbours (degree,
grid cells or breakpoints, one polynomial per cell or not, variables or multipliers, kinks
at breakpoints placed where the data are)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from simplexspline.aero.modelling.auto import SCHEDULING_CANDIDATES, candidate_terms
from simplexspline.aero.modelling.notation import (
    format_multiplier,
    multiplier_parts,
    parse_multiplier,
)
from simplexspline.aero.modelling.structure import Structure
from simplexspline.aero.variables import LATERAL_COEFFICIENTS, LATERAL_VARIABLES

__all__ = ["JOINT_KINK_QUANTILES", "JOINT_KINK_SPACING", "KINK_QUANTILES", "MIN_KINK_SPACING",
           "joint_kink_moves", "kink_moves", "kink_positions", "kinked_variable",
           "knot_moves", "neighbours", "schedule_moves", "with_breakpoint"]

#: Where a kink may be placed along a variable: these quantiles of its identification
#: data (the breakpoints follow the data's density, never a table's grid).
KINK_QUANTILES: tuple[float, ...] = tuple(np.round(np.arange(0.1, 0.91, 0.05), 2))
#: A term's kinks along one variable lie at least this many candidate positions apart
#: (of :data:`KINK_QUANTILES`: 10 % of the data between two kinks).
MIN_KINK_SPACING = 2
#: Where a joint kink (:func:`joint_kink_moves`) may lie: these quantiles of the
#: variable's data, 1 % apart. Flight conditions cluster the data, and which side of a
#: cluster a breakpoint falls on decides what it does: on an F-16 campaign the roll
#: derivatives' joint kink at the 5 %-quantile Mach 0.614 lowered the cross-validation
#: RMS by 0.1 %, at Mach 0.60 by 16 %.
JOINT_KINK_QUANTILES: tuple[float, ...] = tuple(np.round(np.arange(0.05, 0.951, 0.01), 2))
#: A term's joint kink lies at least this many :data:`JOINT_KINK_QUANTILES` positions
#: from a kink it has along the same variable (10 % of the data, as
#: :data:`MIN_KINK_SPACING` of :data:`KINK_QUANTILES`).
JOINT_KINK_SPACING = 10


def neighbours(s: Structure, settings, available: Sequence[str]):
    """Candidate moves from structure ``s`` under ``settings`` (a
    :class:`~simplexspline.aero.selection.search.SelectionSettings`): (description, structure)."""
    out = []
    if "degree" in settings.moves:
        if s.degree < settings.max_degree:
            out.append((f"degree {s.degree}->{s.degree + 1}", s.with_(degree=s.degree + 1)))
        if s.degree > 1:
            d = s.degree - 1
            out.append((f"degree {s.degree}->{d}",
                        s.with_(degree=d, continuity=min(s.continuity, d - 1))))
        # kinks (C^0) or smoothness across the grid planes
        if s.continuity > 0:
            out.append((f"continuity {s.continuity}->{s.continuity - 1}",
                        s.with_(continuity=s.continuity - 1)))
        if s.continuity + 1 < s.degree:
            out.append((f"continuity {s.continuity}->{s.continuity + 1}",
                        s.with_(continuity=s.continuity + 1)))
    if "resolution" in settings.moves:
        if s.degree > 0:   # one polynomial per grid cell, or the Kuhn diagonals as breaks
            out.append(("cellwise off" if s.cellwise else "cellwise on",
                        s.with_(cellwise=not s.cellwise)))
        for i, v in enumerate(s.variables):
            if v in s.knots_of:
                out.extend(knot_moves(s, v))
                continue
            res = list(s.resolution)
            if res[i] < settings.max_resolution:
                res[i] += 1
                out.append((f"refine {v} ({res[i] - 1}->{res[i]} cells)",
                            s.with_(resolution=tuple(res))))
            res = list(s.resolution)
            if res[i] > 1:
                res[i] -= 1
                out.append((f"coarsen {v} ({res[i] + 1}->{res[i]} cells)",
                            s.with_(resolution=tuple(res))))
    if "variables" in settings.moves and s.varying:
        # varying-coefficient structures: add or remove multipliers (terms of the
        # coefficient's symmetry class), schedule on one more variable or one fewer
        for term in candidate_terms(s.coefficient, available, settings.candidates):
            if term not in s.multipliers and term not in s.variables:
                out.append((f"add multiplier {term}",
                            s.with_(multipliers=(*s.multipliers, term))))
        if len(s.multipliers) > 1:
            for v in s.multipliers:
                if v in settings.kept_multipliers:
                    continue
                out.append((f"remove multiplier {v}", s.with_(
                    multipliers=tuple(w for w in s.multipliers if w != v))))
        out.extend(schedule_moves(s, settings, available))
    elif "variables" in settings.moves:
        if s.ndim < settings.max_variables:
            for v in settings.candidates:
                if v in available and v not in s.variables:
                    out.append((f"add {v}", s.with_(variables=(*s.variables, v),
                                                    resolution=(*s.resolution, 1))))
        else:  # at the variable limit: replace a variable by a candidate instead
            for i, v in enumerate(s.variables):
                for w in settings.candidates:
                    if w in available and w not in s.variables:
                        variables = list(s.variables)
                        variables[i] = w
                        res = list(s.resolution)
                        res[i] = 1
                        out.append((f"replace {v} by {w}", s.with_(
                            variables=tuple(variables), resolution=tuple(res))))
        if s.ndim > 1:
            for i, v in enumerate(s.variables):
                keep = [j for j in range(s.ndim) if j != i]
                out.append((f"remove {v}", s.with_(
                    variables=tuple(s.variables[j] for j in keep),
                    resolution=tuple(s.resolution[j] for j in keep))))
    return [(move + _continuous_note(cand), _continuous(cand)) for move, cand in out]


def knot_moves(s: Structure, v: str) -> list:
    """Moves of a variable whose grid is given by breakpoints: every other breakpoint
    dropped (a grid twice as coarse, from three breakpoints up) and midpoints inserted
    (twice as fine, from two up)."""
    ks = s.knots_of[v]
    out = []
    knots = dict(s.knots_of)
    if len(ks) >= 3:
        knots[v] = tuple(ks[::2])
        out.append((f"coarsen {v} breakpoints ({len(ks)}->{len(knots[v])})",
                    s.with_(knots=tuple(knots.items()))))
    if len(ks) >= 2:
        mid = (np.asarray(ks[:-1]) + np.asarray(ks[1:])) / 2.0
        knots[v] = tuple(float(k) for k in np.sort(np.r_[ks, mid]))
        out.append((f"refine {v} breakpoints ({len(ks)}->{len(knots[v])})",
                    s.with_(knots=tuple(knots.items()))))
    return out


def schedule_moves(s: Structure, settings, available: Sequence[str]) -> list:
    """Moves of a varying-coefficient structure's scheduling variables.

    * ``schedule on v``: ``v`` becomes a dimension of the triangulation (2 grid cells); a
      linear multiplier ``v`` is dropped, since the constant term now varies with ``v``.
      This is how the search finds that a control or the sideslip acts nonlinearly (a
      drag that grows with ``|de|``, a rolling moment that saturates with sideslip).
    * ``unschedule v``: ``v`` leaves the triangulation (a multiplier ``v`` is added back
      when ``v`` is a candidate term of the coefficient), when no term names ``v`` in its
      own dimensions or breakpoints and another scheduling variable remains.

    At most ``settings.max_schedule`` scheduling variables.
    """
    out = []
    terms = candidate_terms(s.coefficient, available, settings.candidates)
    if s.ndim < settings.max_schedule:
        for v in SCHEDULING_CANDIDATES:
            if v in available and v in settings.candidates and v not in s.variables:
                mult = tuple(m for m in s.multipliers if m != v)
                out.append((f"schedule on {v}", s.with_(
                    variables=(*s.variables, v), resolution=(*s.resolution, 2),
                    multipliers=mult or ("1",))))
    if s.ndim > 1:
        for i, v in enumerate(s.variables):
            if v in s.knots_of or any(_names_variable(m, v) for m in s.multipliers):
                continue
            mult = s.multipliers
            if v in terms and v not in mult:
                mult = (*mult, v)
            keep = [j for j in range(s.ndim) if j != i]
            out.append((f"unschedule {v}", s.with_(
                variables=tuple(s.variables[j] for j in keep),
                resolution=tuple(s.resolution[j] for j in keep), multipliers=mult)))
    return out


def _continuous(s: Structure) -> Structure:
    """``s`` with coefficients that stay continuous across its grid cells: a structure of
    more than one cell and continuity -1 (constant or linear pieces that may jump: the
    linear start, ``S^-1_0``, refined or scheduled, or raised in degree and then refined)
    becomes C^0, of degree 1 at least; any other is returned as it is.

    A refinement or a new scheduling variable at degree 0 gave a step in every
    coefficient at the cells' boundary, and ``schedule on beta`` dropped the linear
    sideslip term for it: on a six-test-point 737 course (`bench_whole_flight.py
    --aircraft 737 --design eigenmotion --turns --maneuvers 6 --seed 24 --turbulence
    none`, no maneuver list) the yawing moment became ``Cn(alpha, beta:2 | 1, phat, da)
    S^-1_0``, constant on either side of beta's midpoint, and its left-out rudder
    maneuver was predicted to R^2 -629. An aerodynamic coefficient does not jump with
    the flight condition."""
    if s.continuity < 0 and int(np.prod(s.resolution)) > 1:
        return s.with_(degree=max(s.degree, 1), continuity=0)
    return s


def _continuous_note(s: Structure) -> str:
    """The addition to a move's description when :func:`_continuous` changes its
    structure: ', degree 0->1 (C^0)' or ', C^0'."""
    if s.continuity >= 0 or int(np.prod(s.resolution)) <= 1:
        return ""
    return ", degree 0->1 (C^0)" if s.degree == 0 else ", C^0"


def _names_variable(multiplier: str, v: str) -> bool:
    """Whether a term names ``v`` in its own dimensions or breakpoints."""
    _expr, dims, knots = parse_multiplier(multiplier)
    return v in knots or (dims is not None and v in dims)


def kink_positions(columns, variables: Sequence[str],
                   quantiles: Sequence[float] = KINK_QUANTILES) -> dict:
    """Candidate breakpoints per variable: the ``quantiles`` of its data (rounded to 3
    significant digits, duplicates removed); the lateral variables get 0 only (a kink
    elsewhere would break the aircraft's mirror symmetry)."""
    out = {}
    for v in variables:
        if v in LATERAL_VARIABLES:
            out[v] = (0.0,)
            continue
        x = np.asarray(columns[v], dtype=float)
        q = np.quantile(x, quantiles)
        q = np.array([float(f"{k:.3g}") for k in q])
        out[v] = tuple(float(k) for k in np.unique(q))
    return out


def kink_moves(s: Structure, positions) -> list:
    """Moves that add a kink to one term of a varying-coefficient structure: for a term
    ``m`` (``1`` included) and a variable ``v`` with candidate breakpoints ``positions[v]``
    (:func:`kink_positions`), the term ``m*|v-k|``, whose coefficient depends on the
    scheduling variables other than ``v``: together with ``m``'s own coefficient, which
    is smooth across ``k``, the model's dependence on ``v`` may change slope at ``k`` (the
    hinge ``max(0, v - k)`` of adaptive regression splines, Friedman 1991), for every value
    of the other variables, with few coefficients and without a thin slab of data beyond
    ``k`` (a breakpoint of the grid would give the slab its own polynomials).

    ``v`` is a scheduling variable or a factor of a term (``beta*|beta|``: a sideslip
    derivative that changes with the sideslip's size). A term's kinks along one variable
    lie :data:`MIN_KINK_SPACING` candidate positions apart or more (a table has several
    breakpoints), kinks (terms with an absolute value, ``|de|`` included) get no kinks, and terms restricted to some variables or breakpoints
    get none. A kink in a lateral variable (at 0, see :func:`kink_positions`) keeps the
    term's parity: only terms of the coefficient's own parity get one.
    """
    if not s.varying:
        return []
    lateral = s.coefficient in LATERAL_COEFFICIENTS
    have = set(s.multipliers)
    kinked = _kinks_of(s.multipliers)
    out = []
    for parts in _plain_terms(s.multipliers):
        base = _product(parts)
        odd = sum(c in LATERAL_VARIABLES and not a for c, a, _k in parts) % 2 == 1
        for v, ks in positions.items():
            if any(c == v and a for c, a, _k in parts):
                continue                 # (beta*|beta|, de*|de-0.1|: slopes that change)
            if v in LATERAL_VARIABLES and odd != lateral:
                continue                 # |beta| on an even term of Cl: an even term
            own = tuple(w for w in s.variables if w != v) if v in s.variables else None
            ks = np.asarray(ks, dtype=float)
            taken = np.searchsorted(ks, kinked.get((base, v), []))
            for i, k in enumerate(ks):
                if len(taken) and np.min(np.abs(taken - i)) < MIN_KINK_SPACING:
                    continue             # next to a kink the term has: no second one
                term = _kink_term(base, v, k, own)
                if term not in have:
                    out.append((f"add kink {term}",
                                s.with_(multipliers=(*s.multipliers, term))))
    return out


def joint_kink_moves(s: Structure, positions) -> list:
    """Moves that give every term that may take one a kink at the same breakpoint, each
    with a constant coefficient: ``add kinks |v-k|`` adds ``m*|v-k|[]`` for every term
    ``m`` of a varying-coefficient structure that :func:`kink_moves` would kink along
    ``v`` (plain, unrestricted, not a kink itself), at every candidate ``k`` of
    ``positions[v]`` (:func:`kink_positions` with :data:`JOINT_KINK_QUANTILES`), where
    two terms or more may take it. A term keeps :data:`JOINT_KINK_SPACING` positions from
    a kink it has along ``v``. The lateral variables get none: their kinks lie at 0 for
    the mirror symmetry, one term at a time (:func:`kink_moves`); joint ones there
    explained more of the residual in-sample than any Mach breakpoint and took the
    screen's places, and the cross-validation never kept one (F-16 rolling moment).

    An aerodynamic database tabulates its derivatives over one grid of Mach (or angle of
    attack), so their slopes change at the same breakpoints; the hinge of adaptive
    regression splines (Friedman 1991) enters with one coefficient. A kink whose
    coefficient is a spline of the other scheduling variables (:func:`kink_moves`) has as
    many coefficients as the term itself, and a cross-validation by maneuver, which holds
    out whole flight conditions, sees them extrapolate: on an F-16 campaign (the
    generalization benchmark's alternative design with GPS) the sideslip, aileron and
    rudder derivatives' kinks at Mach 0.6 raised the rolling moment's cross-validation
    RMS by 4 % scheduled on the angle of attack and lowered it by 16 % with constant
    coefficients. The screen (:func:`~simplexspline.aero.selection.search.screen_moves`)
    picks the breakpoint per variable that explains most of the current model's
    residual; there the search found Mach 0.597 and alpha 0.0875 rad (the database's
    breakpoints: Mach 0.6 and 5 deg).
    """
    if not s.varying:
        return []
    have = set(s.multipliers)
    kinked = _kinks_of(s.multipliers)
    bases = [_product(parts) for parts in _plain_terms(s.multipliers)]
    out = []
    for v, ks in positions.items():
        if v in LATERAL_VARIABLES:
            continue
        ks = np.asarray(ks, dtype=float)
        eligible = [(b, np.searchsorted(ks, kinked.get((b, v), []))) for b in bases]
        for i, k in enumerate(ks):
            terms = [_kink_term(b, v, k, ()) for b, taken in eligible
                     if not (len(taken) and np.min(np.abs(taken - i)) < JOINT_KINK_SPACING)]
            terms = [t for t in terms if t not in have]
            if len(terms) >= 2:
                out.append((f"add kinks {_kink_term('1', v, k, None)}",
                            s.with_(multipliers=(*s.multipliers, *terms))))
    return out


def _plain_terms(multipliers) -> list:
    """The factors (:func:`multiplier_parts`) of the terms that may take a kink: neither
    restricted to some variables nor given breakpoints of their own, nor kinks
    themselves."""
    out = []
    for m in multipliers:
        _expr, dims, knots = parse_multiplier(m)
        parts = multiplier_parts(m)
        if dims is None and not knots and not any(a for _c, a, _k in parts):
            out.append(parts)
    return out


def _kinks_of(multipliers) -> dict:
    """The kinks the terms have: (the term's other factors, v) -> the breakpoints of its
    factors ``|v-k|`` (``'|de|'`` is a kink at 0)."""
    kinked: dict = {}
    for t in multipliers:
        parts = multiplier_parts(t)
        for i, (c, a, k) in enumerate(parts):
            if a:
                kinked.setdefault((_product(parts[:i] + parts[i + 1:]), c), []).append(k)
    return kinked


def kinked_variable(term: str) -> tuple | None:
    """The variable and breakpoint of a kink term's one ``|v-k|`` factor:
    ``'beta*|mach-0.612|[alpha]'`` -> ('mach', 0.612); None for a term without exactly one."""
    kinks = [(c, k) for c, a, k in multiplier_parts(term) if a]
    return kinks[0] if len(kinks) == 1 else None


def with_breakpoint(term: str, k: float) -> str:
    """A kink term (:func:`kinked_variable`) with its breakpoint moved to ``k``, its other
    factors and the variables its coefficient depends on kept:
    ``with_breakpoint('beta*|mach-0.612|[alpha]', 0.6)`` -> ``'beta*|mach-0.6|[alpha]'``."""
    found = kinked_variable(term)
    if found is None:
        raise ValueError(f"{term!r} has not exactly one kink factor |v-k|")
    v = found[0]
    _expr, dims, _knots = parse_multiplier(term)
    base = _product(tuple(p for p in multiplier_parts(term) if not p[1]))
    return _kink_term(base, v, k, dims)


def _kink_term(base: str, v: str, k: float, own) -> str:
    """The canonical text of the term ``base*|v-k|`` whose coefficient depends on ``own``
    (None: on every scheduling variable)."""
    factor = f"|{v}-{k:g}|" if k > 0 else f"|{v}+{-k:g}|" if k < 0 else f"|{v}|"
    return format_multiplier(factor if base == "1" else f"{base}*{factor}", own)


def _product(parts) -> str:
    """The expression text of factors ``(column, absolute, breakpoint)``; ``'1'`` when none."""
    if not parts:
        return "1"
    return format_multiplier("*".join(
        (f"|{c}-{k!r}|" if k else f"|{c}|") if a else c for c, a, k in parts))
