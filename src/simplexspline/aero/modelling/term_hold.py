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
which the term is excited (where it moves independently of the other terms:
:func:`excited_boxes`): virtual samples at interior points of the triangulation outside
that box ask ``c_k`` for its value at the nearest point of the box (the first fit's), as
a table lookup holds its edge values. Where the term is excited the data decide; outside, the
derivative stays what it was where it was last measured. A term excited everywhere gets
no virtual samples, and neither does the constant term.
"""

from __future__ import annotations

import numpy as np

from simplexspline.aero.modelling.prior import interior_points
from simplexspline.aero.modelling.notation import multiplier_factors
from simplexspline.aero.modelling.structure import Structure

__all__ = ["BINS", "HOLD_WEIGHT", "TERM_EXCITED", "excitation", "excited_boxes",
           "hold_samples", "hole_intervals"]

#: A bin excites a term when the term's partial standard deviation there, or its sum of
#: squares (:func:`excited_boxes`), is at least this share of its largest in any bin.
TERM_EXCITED = 1.0 / 3.0

#: Bins per scheduling variable in which a term's independent movement is measured.
BINS = 10

#: A bin judges a term's movement from at least this many samples per term (and one for
#: the constant); with fewer it cannot say.
BIN_SAMPLES_PER_TERM = 3

#: Ridge on the correlation matrix of a bin's terms: a term that others determine exactly
#: keeps a partial residual of about _RIDGE of its own.
_RIDGE = 1e-9

#: Weight of one virtual sample of a held coefficient, relative to a real sample. One
#: polynomial may span both sides of a box's face, so the virtual samples compete with
#: the data inside: at 1 a roll damping excited below Mach 0.4 still moved by 0.04 /rad
#: between Mach 0.6 and 0.9 (noise 1e-3), at 10 by under 0.015, and the fit where the
#: term is excited did not change (tests/aero/test_term_hold.py).
HOLD_WEIGHT = 10.0

#: Scaled distance beyond a box's face from which a point counts as outside.
_TOL = 1e-9

#: The smallest share of a known bin that does not excite a term (0 marks excited bins).
_TINY = 1e-12

#: A box that reaches within this share of the data's range of every face of the data's
#: box is the whole box (the excited samples' extremes lie a little inside the data's).
_WHOLE = 0.02


def excited_boxes(structure: Structure, z: np.ndarray, m: np.ndarray) -> list:
    """Per term, the box of the scheduling variables where it is excited, or None (the
    constant term, a term that never moves, or one excited throughout the data's box).

    A term is excited where it moves **independently of the other terms**: along every
    scheduling variable the data are cut into :data:`BINS` equal bins, and in each the
    term's partial residual is taken (its residual after the least squares on the other
    terms that read none of its columns, and a constant, there). A bin excites the term
    where the residual's RMS (the partial standard deviation) or its sum of squares (the
    information the bin holds on the term's coefficient) reaches :data:`TERM_EXCITED` of
    its largest in any bin along that variable; bins with fewer than
    :data:`BIN_SAMPLES_PER_TERM` samples per term cannot say and join the box when they
    adjoin an excited bin. The box spans, along every variable, the samples of the excited
    bins where the residual reaches that share of the bin's partial standard deviation
    (the excitation's edge need not be a bin's).

    A term's size is not its excitation: on a Cessna flight-test course the angle of attack
    and the elevator differ from test point to test point along the trim line, together,
    and the pitching moment's alpha derivative, free at every test point but the one of
    the short period, drifted from -2.3 to +0.01 /rad across them (truth -1.4). The sum
    of squares counts a bin where the term moves in a share of many samples (an F-16
    campaign's elevator inputs, flaps up, among much quiet flight: 0.3 of the flaps-down
    bin's partial standard deviation, 0.5 of its sum); the RMS counts a thin bin where it
    moves hard (the high angles of attack).

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
    return excitation(structure, z, m)[0]


def excitation(structure: Structure, z: np.ndarray, m: np.ndarray) -> tuple:
    """:func:`excited_boxes` and, per term, how much each bin outside its box excites it.

    Returns
    -------
    boxes : list
        :func:`excited_boxes`.
    shares : list of (ndarray, ndarray, ndarray) or None, length K
        Per term with a box: the data's lower corner and width along every scheduling
        variable (scaled), and per variable and bin its excitation share, the larger of
        its partial standard deviation and its sum of squares as a share of the largest
        in any bin (NaN: a bin that cannot say), shape (n, BINS); 0 in excited bins
        (whose samples beyond the box do not move the term).
    """
    z, m = np.asarray(z, dtype=float), np.asarray(m, dtype=float)
    n_samples, n_terms = m.shape
    lo_all, hi_all = z.min(axis=0), z.max(axis=0)
    moving = [k for k, name in enumerate(structure.multipliers)
              if name != "1" and n_samples and np.ptp(m[:, k]) > 0]
    width = np.where(hi_all > lo_all, hi_all - lo_all, 1.0)
    hit = np.zeros(n_terms, dtype=bool)
    share = np.full((n_terms, z.shape[1], BINS), np.nan)
    lo = np.tile(lo_all, (n_terms, 1))
    hi = np.tile(hi_all, (n_terms, 1))
    need = BIN_SAMPLES_PER_TERM * (len(moving) + 1)
    # the other effects a term is told apart from: the terms that read none of its columns
    # (beta*|mach - 0.59| is beta's own shape, not another effect: in a bin of Mach it is
    # beta times a constant)
    factors = [set(multiplier_factors(structure.multipliers[k])) for k in moving]
    others = [[i for i in range(len(moving)) if not factors[i] & factors[j]]
              for j in range(len(moving))]
    for j in range(z.shape[1]):
        bins = _bin_index(z[:, j], lo_all[j], width[j])
        counts = np.bincount(bins, minlength=BINS)
        known = (counts >= need) & bool(moving)
        resid = np.zeros((n_terms, n_samples))           # a term's row contiguous
        order = np.argsort(bins, kind="stable")
        starts = np.concatenate([[0], np.cumsum(counts)])
        for b in np.flatnonzero(known):
            rows = order[starts[b]:starts[b + 1]]
            resid[np.ix_(moving, rows)] = _partial_residuals(m[np.ix_(rows, moving)],
                                                             others).T
        unknown = ~known[bins]
        safe = np.maximum(counts, 1)
        for k in moving:
            r = np.abs(resid[k])
            info = np.where(known, np.bincount(bins, r * r, minlength=BINS), 0.0)
            part = np.sqrt(info / safe)                   # partial std per bin
            top = part.max()
            if not top > 0:
                continue
            level = np.maximum(part / top, info / info.max())
            on = known & (level >= TERM_EXCITED)
            # 0 marks an excited bin; a known bin that is not keeps a positive share
            share[k, j] = np.where(known, np.where(on, 0.0, np.maximum(level, _TINY)),
                                   np.nan)
            # in an excited bin, the samples where the term moves (the bin's edge need
            # not be the excitation's)
            moves = on[bins] & (r >= TERM_EXCITED * part[bins])
            on = _adjoining_unknown(on, known)
            rows = moves | (on[bins] & unknown)
            hit[k] = True
            zj = z[:, j][rows]
            lo[k, j], hi[k, j] = zj.min(), zj.max()
    boxes, shares = [], []
    margin = _WHOLE * (hi_all - lo_all)
    for k in range(n_terms):
        whole = not hit[k] or (np.all(lo[k] <= lo_all + margin)
                               and np.all(hi[k] >= hi_all - margin))
        boxes.append(None if whole else (lo[k], hi[k]))
        # a term excited throughout the box may still have holes inside it
        shares.append((lo_all, width, share[k])
                      if not whole or (hit[k] and _holes(share[k]).any()) else None)
    return boxes, shares


def hole_intervals(shares: tuple | None) -> dict:
    """The holes of one term's excitation (:func:`excitation`'s ``shares`` entry): per
    scheduling variable index, the (lower, upper) ranges (scaled) of consecutive bins that
    do not excite the term between bins that do. Empty when there are none."""
    if shares is None:
        return {}
    base, width, share = shares
    out = {}
    for j, row in enumerate(_holes(share)):
        # the starts and ends (exclusive) of the runs of hole bins
        edges = np.flatnonzero(np.diff(np.r_[0, row.astype(np.int8), 0]))
        step = width[j] / BINS
        runs = [(float(base[j] + a * step), float(base[j] + e * step))
                for a, e in zip(edges[::2], edges[1::2])]
        if runs:
            out[j] = runs
    return out


def _holes(share: np.ndarray) -> np.ndarray:
    """Per scheduling variable and bin (shape (n, BINS)): a bin that does not excite the
    term (positive share) with excited bins (share 0) on both sides: a hole in its box."""
    on = share == 0.0
    left = np.maximum.accumulate(on, axis=1)
    right = np.maximum.accumulate(on[:, ::-1], axis=1)[:, ::-1]
    return (share > 0.0) & left & right


def _bin_index(x: np.ndarray, base: float, width: float) -> np.ndarray:
    """The bin (0..BINS-1) of each value ``x`` along a scheduling variable that spans
    ``base .. base + width`` in the data (values beyond fall in the end bins)."""
    return np.clip(((x - base) / width * BINS).astype(np.int64), 0, BINS - 1)


def _partial_residuals(x: np.ndarray, others: list) -> np.ndarray:
    """Per column k of ``x`` (samples, terms), its residual after the least squares on the
    columns ``others[k]`` and a constant (about 0 where they determine it)."""
    x = x - x.mean(axis=0)
    scale = np.sqrt(np.mean(x * x, axis=0))
    scale = np.where(scale > 0, scale, 1.0)
    xs = x / scale
    g = xs.T @ xs / len(xs)                               # correlation matrix
    # column k of ``xs @ w`` is column k less its least squares on ``others[k]``
    w = np.eye(len(others))
    for k, rest in enumerate(others):
        if len(rest):
            sub = g[np.ix_(rest, rest)] + _RIDGE * np.eye(len(rest))
            w[rest, k] = -np.linalg.solve(sub, g[rest, k])
    return (xs @ w) * scale


def _adjoining_unknown(on: np.ndarray, known: np.ndarray) -> np.ndarray:
    """``on`` grown over runs of bins that cannot say (``~known``) next to an excited
    bin."""
    out = on.copy()
    for idx in (range(len(on)), reversed(range(len(on)))):
        carry = False
        for b in idx:
            if known[b]:
                carry = bool(on[b])
            elif carry:
                out[b] = True
    return out


def hold_samples(structure: Structure, triangulation, boxes: list, spline,
                 shares: list | None = None) -> tuple:
    """Virtual samples that hold every boxed term's coefficient at its value on the box.

    With ``shares`` (:func:`excitation`) a virtual sample's weight falls with the
    excitation of the bins it lies in outside the box: ``1 - share / TERM_EXCITED`` for
    the least excited of them (1 where a bin cannot say), so that a bin just under the
    threshold is held about as little as one just over it is (not at all).

    Parameters
    ----------
    structure : Structure
    triangulation : Triangulation
        The model's (scaled coordinates).
    boxes : list
        :func:`excited_boxes`.
    spline : VaryingCoefficientSpline
        The first fit, whose coefficients on the boxes are held.
    shares : list, optional
        :func:`excitation`'s second result; without it every weight is 1.

    Returns
    -------
    z : ndarray, shape (M, n)
    m : ndarray, shape (M, K)
        Unit multipliers (one term at a time).
    y : ndarray, shape (M,)
        The term's coefficient at the point moved onto its box.
    w : ndarray, shape (M,)
        Relative weights in (0, 1].
    """
    pts = interior_points(triangulation, structure.degree + 1)
    K = structure.nterms
    zs, ms, ys, ws = [], [], [], []
    for k, box in enumerate(boxes):
        share = None if shares is None else shares[k]
        if box is None and share is None:
            continue
        if box is None:          # excited throughout the data's box, but for holes
            lo, hi = share[0], share[0] + share[1]
            out = np.zeros(len(pts), dtype=bool)
        else:
            lo, hi = box
            out = np.any((pts < lo - _TOL) | (pts > hi + _TOL), axis=1)
        if out.any():
            held = spline.term_values(np.clip(pts[out], lo, hi),
                                      outside="extrapolate")[:, k]
            ok = np.isfinite(held)
            w = np.ones(int(ok.sum()))
            if share is not None:
                w = _hold_weights(pts[out][ok], lo, hi, share)
            _append(zs, ms, ys, ws, pts[out][ok], k, K, held[ok], w)
        if share is not None:
            z, held, w = _across_holes(spline, k, np.clip(pts[~out], lo, hi), share)
            _append(zs, ms, ys, ws, z, k, K, held, w)
    if not zs:
        return np.zeros((0, structure.ndim)), np.zeros((0, K)), np.zeros(0), np.zeros(0)
    z, m, y, w = np.vstack(zs), np.vstack(ms), np.concatenate(ys), np.concatenate(ws)
    keep = w > 0
    return z[keep], m[keep], y[keep], w[keep]


def _append(zs: list, ms: list, ys: list, ws: list, z: np.ndarray, k: int, K: int,
            y: np.ndarray, w: np.ndarray) -> None:
    """Add virtual samples of term ``k`` (of ``K``) at ``z`` with values ``y``."""
    if not len(y):
        return
    unit = np.zeros((len(y), K))
    unit[:, k] = 1.0
    zs.append(z)
    ms.append(unit)
    ys.append(y)
    ws.append(w)


def _across_holes(spline, k: int, pts: np.ndarray, shares: tuple) -> tuple:
    """Virtual samples of term ``k`` at the points of ``pts`` (inside its box) that lie in
    a hole of its excitation (:func:`_holes`) along some scheduling variable: the first
    fit's coefficient interpolated linearly along that variable between the excited bins
    on either side, as a table interpolates between the breakpoints where it was
    measured; weighted ``1 - share / TERM_EXCITED`` by the hole's bin. Returns (z, y, w).
    """
    base, width, share = shares
    holes = _holes(share)
    z_out, y_out, w_out = [], [], []
    taken = np.zeros(len(pts), dtype=bool)
    for j in np.flatnonzero(holes.any(axis=1)):
        b = _bin_index(pts[:, j], base[j], width[j])
        here = holes[j][b] & ~taken
        if not here.any():
            continue
        taken |= here
        p, bb = pts[here], b[here]
        on = np.flatnonzero(share[j] == 0.0)
        left = on[np.searchsorted(on, bb) - 1]          # the excited bins either side
        right = on[np.searchsorted(on, bb)]
        step = width[j] / BINS
        a, c = base[j] + (left + 1) * step, base[j] + right * step
        ends = []
        for edge in (a, c):
            q = p.copy()
            q[:, j] = edge
            ends.append(spline.term_values(q, outside="extrapolate")[:, k])
        t = np.clip((p[:, j] - a) / np.where(c > a, c - a, 1.0), 0.0, 1.0)
        held = (1.0 - t) * ends[0] + t * ends[1]
        ok = np.isfinite(held)
        s = share[j][bb]
        z_out.append(p[ok])
        y_out.append(held[ok])
        w_out.append((1.0 - np.minimum(s, TERM_EXCITED) / TERM_EXCITED)[ok])
    if not z_out:
        return np.zeros((0, pts.shape[1])), np.zeros(0), np.zeros(0)
    return np.vstack(z_out), np.concatenate(y_out), np.concatenate(w_out)


def _hold_weights(pts: np.ndarray, lo: np.ndarray, hi: np.ndarray, shares: tuple) -> np.ndarray:
    """Relative weight of the virtual samples at ``pts`` (outside the box ``lo..hi``):
    ``1 - share / TERM_EXCITED`` of the least excited bin they lie in beyond the box."""
    base, width, share = shares
    w = np.zeros(len(pts))
    for j in range(pts.shape[1]):
        beyond = (pts[:, j] < lo[j] - _TOL) | (pts[:, j] > hi[j] + _TOL)
        s = np.nan_to_num(share[j][_bin_index(pts[:, j], base[j], width[j])], nan=0.0)
        w = np.where(beyond, np.maximum(w, 1.0 - np.minimum(s, TERM_EXCITED) / TERM_EXCITED), w)
    return w
