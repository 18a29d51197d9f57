"""The moves of the greedy structure search: from one structure to its neighbours (degree,
grid cells or breakpoints, one polynomial per cell or not, variables or multipliers)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from simplexspline.aero.modelling.auto import SCHEDULING_CANDIDATES, candidate_terms
from simplexspline.aero.modelling.notation import parse_multiplier
from simplexspline.aero.modelling.structure import Structure

__all__ = ["knot_moves", "neighbours", "schedule_moves"]


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
    return out


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


def _names_variable(multiplier: str, v: str) -> bool:
    """Whether a term names ``v`` in its own dimensions or breakpoints."""
    _expr, dims, knots = parse_multiplier(multiplier)
    return v in knots or (dims is not None and v in dims)
