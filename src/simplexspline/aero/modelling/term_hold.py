"""Coefficients held beyond the data that excite their term.

A varying-coefficient model ``C = sum_k c_k(z) m_k`` (scheduling variables ``z``: alpha,
Mach, ...; terms ``m_k``: the rates, the control deflections, the sideslip, ...) learns
``c_k`` only where ``m_k`` moves. A flight-test course flies its lateral inputs at a few
test points and its stationary measurements at all of them: at the others a roll
derivative's polynomial is not determined by the data (``m_k`` is about 0 there) but
follows its own continuation, and a cubic's continuation is arbitrary. On a simulated
global5000 course with one aileron and one rudder input per test point at Mach 0.54-0.68,
a turn at Mach 0.45 met a rolling-moment model whose derivatives there were 7x off:
validation R^2 -642 (`bench_whole_flight.py --design eigenmotion --maneuvers 6`).

Here every term's coefficient is **held** outside the box of the scheduling variables in
which the term is excited (its normalised value at least :data:`TERM_EXCITED` of its
99th percentile): virtual samples at interior points of the triangulation outside that box
ask ``c_k`` for its value at the nearest point of the box (the first fit's), as a table
lookup holds its edge values. Where the term is excited the data decide; outside, the
derivative stays what it was where it was last measured. A term excited everywhere gets
no virtual samples, and neither does the constant term.
"""

from __future__ import annotations

import numpy as np

from simplexspline.aero.modelling.prior import interior_points
from simplexspline.aero.modelling.structure import Structure

__all__ = ["HOLD_WEIGHT", "TERM_EXCITED", "excited_boxes", "hold_samples"]

#: A sample excites a term when the term's normalised value is at least this share of its
#: 99th percentile (of absolute values) in the identification data.
TERM_EXCITED = 1.0 / 3.0

#: Weight of one virtual sample of a held coefficient, relative to a real sample. One
#: polynomial may span both sides of a box's face, so the virtual samples compete with
#: the data inside: at 1 a roll damping excited below Mach 0.4 still moved by 0.04 /rad
#: between Mach 0.6 and 0.9 (noise 1e-3), at 10 by under 0.015, and the fit where the
#: term is excited did not change (tests/aero/test_term_hold.py).
HOLD_WEIGHT = 10.0

#: Scaled distance beyond a box's face from which a point counts as outside.
_TOL = 1e-9

#: A box that reaches within this share of the data's range of every face of the data's
#: box is the whole box (the excited samples' extremes lie a little inside the data's).
_WHOLE = 0.02


def excited_boxes(structure: Structure, z: np.ndarray, m: np.ndarray) -> list:
    """Per term, the box of the scheduling variables where it is excited, or None (the
    constant term, a term that never moves, or one excited throughout the data's box).

    Parameters
    ----------
    structure : Structure
        A varying-coefficient structure.
    z : ndarray, shape (N, n)
        Scheduling variables scaled to the unit box.
    m : ndarray, shape (N, K)
        Normalised multipliers.

    Returns
    -------
    list of (ndarray, ndarray) or None, length K
        (lower, upper) corners, scaled, per term.
    """
    lo_all, hi_all = z.min(axis=0), z.max(axis=0)
    out = []
    for k, name in enumerate(structure.multipliers):
        a = np.abs(m[:, k])
        top = float(np.quantile(a, 0.99)) if len(a) else 0.0
        if name == "1" or not top > 0:
            out.append(None)
            continue
        hit = a >= TERM_EXCITED * top
        lo, hi = z[hit].min(axis=0), z[hit].max(axis=0)
        margin = _WHOLE * (hi_all - lo_all)
        whole = np.all(lo <= lo_all + margin) and np.all(hi >= hi_all - margin)
        out.append(None if whole else (lo, hi))
    return out


def hold_samples(structure: Structure, triangulation, boxes: list, spline) -> tuple:
    """Virtual samples that hold every boxed term's coefficient at its value on the box.

    Parameters
    ----------
    structure : Structure
    triangulation : Triangulation
        The model's (scaled coordinates).
    boxes : list
        :func:`excited_boxes`.
    spline : VaryingCoefficientSpline
        The first fit, whose coefficients on the boxes are held.

    Returns
    -------
    z : ndarray, shape (M, n)
    m : ndarray, shape (M, K)
        Unit multipliers (one term at a time).
    y : ndarray, shape (M,)
        The term's coefficient at the point moved onto its box.
    """
    pts = interior_points(triangulation, structure.degree + 1)
    K = structure.nterms
    zs, ms, ys = [], [], []
    for k, box in enumerate(boxes):
        if box is None:
            continue
        lo, hi = box
        out = np.any((pts < lo - _TOL) | (pts > hi + _TOL), axis=1)
        if not out.any():
            continue
        held = spline.term_values(np.clip(pts[out], lo, hi), outside="extrapolate")[:, k]
        ok = np.isfinite(held)
        zs.append(pts[out][ok])
        unit = np.zeros((int(ok.sum()), K))
        unit[:, k] = 1.0
        ms.append(unit)
        ys.append(held[ok])
    if not zs:
        return np.zeros((0, structure.ndim)), np.zeros((0, K)), np.zeros(0)
    return np.vstack(zs), np.vstack(ms), np.concatenate(ys)
