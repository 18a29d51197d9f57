"""A second start for the structure search from an adaptive-regression-spline basis.

The greedy search adds one term per cross-validated move, and a kink ``m*|v-k|`` only to a
term without one. A table of an aerodynamic database interpolated linearly in two
variables (a drag over angle of attack and elevator) changes slope along both at every
breakpoint: products of kinks, many of them. Multivariate adaptive regression splines
(MARS, Friedman 1991) find such a basis in one pass over the data: a forward pass adds, to
an existing basis function, the pair of hinges ``max(0, +-(v - k))`` in one variable that
lowers the squared error most, and a backward pass prunes the basis. On the F-16 campaign
of ``benchmarks/bench_compare.py`` MARS (py-earth) reached 0.2x the noise on the drag
coefficient where the search ended at 3.5x, and without products (additive hinges) it was
as bad as the search (docs/identification.md, "How much the result depends on the split").

This module makes that basis a structure the search can judge on its own terms: the
pair of hinges at ``k`` spans the same functions as ``|v-k|`` and ``v`` beside the parent,
so every basis function is a product of at most two factors ``v`` or ``|v-k|`` with a
constant coefficient: a varying-coefficient structure of one cell of degree 0
(``C(alpha | 1, de, |alpha-0.1|, de*|alpha-0.1|, ...) S^-1_0``), fitted, cross-validated
and saved like any other (:func:`hinge_structures`). The search's cross-validation then
decides between it and the search's own result (``SelectionSettings.hinge_start``).

The forward pass here is a plain one: candidate breakpoints at quantiles of the data
(only 0 for the lateral variables: the airframe's mirror symmetry, as the search's kinks),
products only of the coefficient's own parity (odd in the lateral variables for the side
force, roll and yaw moments, even for the others), a candidate pair scored by how much of
the current residual it explains (its correlation with the residual is exact, the residual
being orthogonal to the basis), and a least-squares refit after each addition. The
backward pass removes, one at a time, the term whose removal raises the squared error
least; the generalised cross-validation (GCV) with a cost per term picks a size on that
path, for a few costs (:func:`hinge_choices`), and the search's cross-validation by
maneuver picks among them. The passes see the data, so the search runs them again inside
each fold, on the other folds' maneuvers, to score a cost honestly.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from simplexspline.aero.modelling.notation import format_multiplier
from simplexspline.aero.modelling.structure import Structure
from simplexspline.aero.selection.validation import subsample_step
from simplexspline.aero.variables import LATERAL_COEFFICIENTS, LATERAL_VARIABLES

__all__ = ["HINGE_QUANTILES", "GCV_PENALTIES", "forward_hinges", "prune_path",
           "hinge_choices", "hinge_structures"]

#: Candidate breakpoints of a longitudinal variable: these quantiles of its data.
HINGE_QUANTILES = tuple(np.round(np.arange(0.025, 0.976, 0.025), 3))

#: Costs per added term in the GCV of the pruning path (Friedman's d): each gives one
#: candidate size; the search's cross-validation by maneuver chooses among them (GCV
#: counts 100 Hz samples as independent, so no single cost fits every record).
GCV_PENALTIES = (3.0, 10.0, 30.0)

#: A factor: (column, breakpoint or None for the plain column).
Factor = tuple


def _breakpoints(x: np.ndarray, v: str) -> np.ndarray:
    if v in LATERAL_VARIABLES:
        return np.array([0.0]) if x.min() < 0.0 < x.max() else np.empty(0)
    q = np.quantile(x, HINGE_QUANTILES)
    return np.unique(np.array([float(f"{k:.3g}") for k in q]))


def _parity(term: tuple) -> int:
    """Plain lateral factors of a term, mod 2 (``|beta|`` is even, ``beta`` odd)."""
    return sum(1 for v, k in term if k is None and v in LATERAL_VARIABLES) % 2


def _values(term: tuple, cols: Mapping) -> np.ndarray:
    out = None
    for v, k in term:
        f = cols[v] if k is None else np.abs(cols[v] - k)
        out = f if out is None else out * f
    return np.ones(len(next(iter(cols.values())))) if out is None else out


def _canonical(term: tuple) -> tuple:
    return tuple(sorted(term, key=lambda f: (f[0], -np.inf if f[1] is None else f[1])))


class _Sorted:
    """A column sorted once, for the prefix sums of :class:`_HingeSums`."""

    def __init__(self, order: np.ndarray, xs: np.ndarray):
        self.order, self.xs = order, xs

    @classmethod
    def of(cls, x: np.ndarray) -> "_Sorted":
        order = np.argsort(x, kind="stable")
        return cls(order, x[order])


class _HingeSums:
    """The candidates ``h_k = pv * |x - k|`` of one parent ``pv`` and column, for the knots
    ``ks``, centred on their mean: :meth:`products` gives ``r . h_k`` and ``h_k . h_k``,
    each shape (K,), in O(N + K) from prefix sums over the sorted column instead of O(N K)
    from the N x K candidates (Friedman's fast update of the forward pass). ``|x - k|`` is
    ``k - x`` below the knot and ``x - k`` above it, so every sum splits at the knot's
    rank into prefix sums of ``w`` and ``w x``; ``h_k^2 = pv^2 (x - k)^2`` needs only
    totals. What does not depend on ``r`` is computed once per parent and column."""

    def __init__(self, col: _Sorted, pv: np.ndarray, ks: np.ndarray):
        self.col, self.ks = col, ks
        self.a = pv[col.order]
        self.rank = np.searchsorted(col.xs, ks, side="left")     # samples below each knot
        n = len(self.a)
        self.s1 = self._split_sum(self.a)                        # sum_i h_k
        a2 = self.a * self.a
        x = col.xs
        s2 = float(a2 @ (x * x)) - 2.0 * ks * float(a2 @ x) + ks * ks * float(a2.sum())
        hh = s2 - self.s1 * self.s1 / n
        self.hh = np.where(hh > 1e-12 * np.maximum(s2, 0.0), hh, 0.0)  # a constant's round-off

    def _split_sum(self, w: np.ndarray) -> np.ndarray:
        """sum_i w_i |x_i - k| for every knot (``w`` in sorted order)."""
        x, p, ks = self.col.xs, self.rank, self.ks
        cw = np.concatenate(([0.0], np.cumsum(w)))
        cwx = np.concatenate(([0.0], np.cumsum(w * x)))
        return ks * cw[p] - cwx[p] + (cwx[-1] - cwx[p]) - ks * (cw[-1] - cw[p])

    def products(self, r: np.ndarray) -> tuple:
        """(``r . h_k``, ``h_k . h_k``) with ``h_k`` centred, each shape (K,)."""
        rh = self._split_sum(self.a * r[self.col.order]) - self.s1 / len(r) * float(r.sum())
        return rh, self.hh

    def cross(self, base: np.ndarray) -> np.ndarray:
        """``h_k . base`` for a centred column ``base`` (N,), shape (K,)."""
        return self._split_sum(self.a * base[self.col.order])


def _pair_gains(rh: np.ndarray, hh: np.ndarray, rb: float, bb: float, hb: np.ndarray,
                partner_taken: bool) -> np.ndarray:
    """What each knot's hinge explains of the residual with its plain partner ``base``
    (centred; ``rb = r . base``, ``bb = base . base``, ``hb = h_k . base``), shape (K,).

    With the partner still free, the pair is scored together, as MARS scores a pair of
    hinges: the projection of the residual on ``span(h_k, base)``. A hinge alone must also
    stand in for the straight line its partner would give, which favours knots at the
    data's ends (measured: single kinks placed 0.006-0.026 rad off in alpha, one to three
    and a half steps of the quantile grid, where the pair puts them within half a step).
    With the partner in the basis already (the residual orthogonal to it), the hinge is
    scored orthogonal to the partner."""
    if partner_taken:
        den = hh - hb * hb / bb
        return np.where(den > 1e-12 * hh, rh * rh / np.where(den > 0, den, 1.0), 0.0)
    det = hh * bb - hb * hb
    ok = det > 1e-12 * np.maximum(hh * bb, 1e-300)
    two = (rh * rh * bb - 2.0 * rh * rb * hb + rb * rb * hh) / np.where(ok, det, 1.0)
    one = np.where(hh > 0, rh * rh / np.where(hh > 0, hh, 1.0), 0.0)
    return np.where(ok, np.maximum(two, one), np.maximum(one, rb * rb / bb))


def _offers(parent: tuple, v: str, knots: np.ndarray, want: int) -> tuple:
    """What ``parent`` times a factor in ``v`` may add, of the coefficient's parity
    ``want``: the plain product (or None), the kinked products and their knots."""
    plain = _canonical((*parent, (v, None)))
    cand = plain if (_parity(plain) == want and sum(
        1 for f in plain if f[0] == v and f[1] is None) <= 1) else None
    kinked = [(float(k), _canonical((*parent, (v, float(k))))) for k in knots]
    kinked = [(k, t) for k, t in kinked if _parity(t) == want and (v, k) not in parent]
    return cand, [t for _k, t in kinked], np.array([k for k, _t in kinked])


def _best_exact(adds: list, cols: Mapping, Q: np.ndarray, resid: np.ndarray):
    """Of the additions ``adds`` (tuples of one or two terms), the one whose columns,
    orthogonalised against the basis ``Q``, explain most of ``resid``: (gain, add), the
    first of equal ones; None without additions. One orthogonalisation of every distinct
    column, then the projection on one or two columns in closed form."""
    if not adds:
        return None
    unique = list(dict.fromkeys(t for add in adds for t in add))
    index = {t: i for i, t in enumerate(unique)}
    C = np.column_stack([_values(t, cols) for t in unique])
    C = C - Q @ (Q.T @ C)
    C = C - Q @ (Q.T @ C)                             # twice: Gram-Schmidt's round-off
    G = C.T @ C
    b = C.T @ resid
    d = np.diag(G)
    gains = []
    for add in adds:
        i = index[add[0]]
        one = b[i] ** 2 / d[i] if d[i] > 0 else 0.0
        if len(add) == 1:
            gains.append(one)
            continue
        j = index[add[1]]
        two = b[j] ** 2 / d[j] if d[j] > 0 else 0.0
        det = d[i] * d[j] - G[i, j] ** 2
        if det > 1e-10 * d[i] * d[j]:
            gains.append(max((b[i] ** 2 * d[j] - 2 * b[i] * b[j] * G[i, j]
                              + b[j] ** 2 * d[i]) / det, one, two))
        else:                                          # the two span one direction
            gains.append(max(one, two))
    k = int(np.argmax(gains))
    return float(gains[k]), adds[k]


def forward_hinges(columns: Mapping, y: np.ndarray, coefficient: str,
                   variables: Sequence[str], *, max_terms: int = 40, max_degree: int = 2,
                   max_samples: int = 8000, min_gain: float = 1e-4,
                   exact: int = 40) -> list:
    """The forward pass: terms (tuples of factors ``(column, breakpoint or None)``, the
    intercept ``()`` first), in the order added.

    Parameters
    ----------
    columns : mapping of str to ndarray, shape (N,)
        Identification data (physical units).
    y : ndarray, shape (N,)
        The coefficient.
    coefficient : str
        Its name: the lateral ones (CY, Cl, Cn) get terms odd in the lateral variables,
        the others even terms.
    variables : sequence of str
        Columns the terms may use (present and varying).
    max_terms : int
        Most terms (the intercept included).
    max_degree : int
        Most factors per term.
    max_samples : int
        Every k-th sample, at most this many (all maneuvers stay).
    min_gain : float
        Stop when the best addition explains less than this share of the residual's
        sum of squares.
    exact : int
        Candidates (the best by their correlation with the residual) scored exactly,
        orthogonal to the terms already taken.
    """
    y = np.asarray(y, dtype=float)
    step = subsample_step(len(y), max_samples)
    cols = {v: np.asarray(columns[v], dtype=float)[::step] for v in variables}
    ys = y[::step]
    want = 1 if coefficient in LATERAL_COEFFICIENTS else 0
    knots = {v: _breakpoints(cols[v], v) for v in variables}
    orders = {v: _Sorted.of(cols[v]) for v in variables}
    terms: list = [()]
    taken = {()}
    values = [np.ones(len(ys))]
    Q = values[0][:, None] / np.sqrt(len(ys))       # orthonormal basis of the terms
    resid = ys - ys.mean()
    offers: dict = {}                                 # (parent, v) -> what it may add
    while len(terms) < max_terms:
        ss = float(resid @ resid)
        if not ss > 0:
            break
        # every candidate scored against the residual (cheap: a hinge with its plain
        # partner, :func:`_pair_gains`), then the best ones exactly, orthogonalised against
        # the basis
        scored = []
        for parent, pv in zip(terms, values):
            if len(parent) >= max_degree:
                continue
            for v in variables:
                if (parent, v) not in offers:
                    cand, kinked, ks = _offers(parent, v, knots[v], want)
                    sums = _HingeSums(orders[v], pv, ks) if kinked else None
                    # the plain partner parent * v (centred), which a pair is scored with
                    raw = pv * cols[v]
                    base = raw - raw.mean()
                    bb = float(base @ base)
                    if not (cand is not None and bb > 1e-12 * float(raw @ raw)):
                        bb = 0.0                     # no partner (parity) or a constant
                    hb = sums.cross(base) if sums is not None and bb > 0 else None
                    offers[parent, v] = (cand, kinked, sums, bb, hb)
                cand, kinked, sums, bb, hb = offers[parent, v]
                partner_taken = cand in taken
                if partner_taken:
                    cand = None
                free = np.array([t not in taken for t in kinked], dtype=bool)
                rb = float(resid @ (pv * cols[v])) if bb > 0 else 0.0   # resid is centred
                if cand is not None and bb > 0:
                    scored.append((rb ** 2 / bb, (cand,)))
                if free.any():
                    rh, hh = sums.products(resid)
                    gain = (_pair_gains(rh, hh, rb, bb, hb, partner_taken) if bb > 0 else
                            np.where(hh > 0, rh ** 2 / np.where(hh > 0, hh, 1.0), 0.0))
                    gain = np.where(free & (hh > 0), gain, 0.0)
                    for j in np.argsort(gain)[::-1][:min(3, int(free.sum()))]:
                        pair = (kinked[j],) + ((cand,) if cand is not None else ())
                        scored.append((float(gain[j]), pair))
        if not scored:
            break
        scored.sort(key=lambda e: -e[0])
        best = _best_exact([add for _g, add in scored[:exact]], cols, Q, resid)
        if best is None or best[0] < min_gain * ss:
            break
        for t in best[1]:
            if t in taken or len(terms) >= max_terms:
                continue
            c = _values(t, cols)
            q = c - Q @ (Q.T @ c)
            q = q - Q @ (Q.T @ q)
            nq = float(np.linalg.norm(q))
            if nq <= 1e-10 * float(np.linalg.norm(c)):
                continue                                  # no new direction
            terms.append(t)
            taken.add(t)
            values.append(c)
            Q = np.column_stack([Q, q / nq])
        resid = ys - Q @ (Q.T @ ys)
    return terms


def prune_path(columns: Mapping, y: np.ndarray, terms: Sequence[tuple], *,
               max_samples: int = 8000) -> list:
    """The backward pass: the subsets of ``terms`` from all of them down to the intercept,
    each without the term whose removal raised the squared error least, with their sum
    of squared errors: a list of (terms, sse, samples)."""
    y = np.asarray(y, dtype=float)
    step = subsample_step(len(y), max_samples)
    names = {v for t in terms for v, _k in t}
    cols = {v: np.asarray(columns[v], dtype=float)[::step] for v in names}
    ys = y[::step]
    X = np.column_stack([_values(t, cols) if t else np.ones(len(ys)) for t in terms])
    G, b, yy = X.T @ X, X.T @ ys, float(ys @ ys)
    keep = list(range(len(terms)))
    path = []
    while True:
        Gk = G[np.ix_(keep, keep)]
        inv = np.linalg.pinv(Gk)
        beta = inv @ b[keep]
        sse = max(yy - float(b[keep] @ beta), 0.0)
        path.append(([terms[i] for i in keep], sse, len(ys)))
        if len(keep) == 1:
            break
        # removing term j raises the sse by beta_j^2 / (G^-1)_jj; the intercept stays
        rise = beta ** 2 / np.maximum(np.diag(inv), 1e-300)
        rise[keep.index(0) if 0 in keep else 0] = np.inf
        del keep[int(np.argmin(rise))]
    return path


def _gcv_choice(path: list, penalty: float) -> list:
    def gcv(entry):
        ts, sse, n = entry
        m = len(ts)
        c = m + penalty * (m - 1) / 2.0
        return np.inf if c >= n else sse / n / (1.0 - c / n) ** 2
    return min(path, key=gcv)[0]


def _term_text(term: tuple) -> str:
    if not term:
        return "1"
    parts = [v if k is None else (f"|{v}-{k:g}|" if k > 0 else f"|{v}+{-k:g}|" if k < 0
                                  else f"|{v}|") for v, k in term]
    return format_multiplier("*".join(parts))


def hinge_choices(start: Structure, columns: Mapping, y: np.ndarray,
                  variables: Sequence[str], *, penalties: Sequence[float] = GCV_PENALTIES,
                  max_terms: int = 60) -> dict:
    """The structure each GCV cost chooses on the pruning path of the forward pass over
    ``columns`` and ``y``: a structure of one cell of degree 0 over ``start``'s first
    scheduling variable whose terms are the chosen products, with constant coefficients.

    Parameters
    ----------
    start : Structure
        The search's start (its coefficient and first scheduling variable).
    columns : mapping of str to ndarray, shape (N,)
        The data the passes see (physical units).
    y : ndarray, shape (N,)
    variables : sequence of str
        Columns the terms may use.
    penalties : sequence of float
        GCV costs per term.
    max_terms : int

    Returns
    -------
    dict of float to Structure
        Cost -> structure (two costs may choose the same); empty when the forward pass adds
        nothing.
    """
    terms = forward_hinges(columns, y, start.coefficient, variables, max_terms=max_terms)
    if len(terms) < 2:
        return {}
    path = prune_path(columns, y, terms)
    out = {}
    for pen in penalties:
        chosen = _gcv_choice(path, pen)
        mults = tuple(dict.fromkeys(_term_text(t) for t in chosen))
        if "1" not in mults:
            mults = ("1", *mults)
        out[pen] = Structure(start.coefficient, (start.variables[0],), degree=0,
                             continuity=-1, resolution=(1,), multipliers=mults)
    return out


def hinge_structures(start: Structure, columns: Mapping, y: np.ndarray,
                     variables: Sequence[str], *, penalties: Sequence[float] = GCV_PENALTIES,
                     max_terms: int = 60) -> list[Structure]:
    """The distinct structures of :func:`hinge_choices` (same arguments), in the order of
    ``penalties``."""
    return list(dict.fromkeys(hinge_choices(start, columns, y, variables,
                                            penalties=penalties,
                                            max_terms=max_terms).values()))
