"""The normal equations of the cross-validation folds, shared by the candidate structures
of one search.

A structure search scores dozens of candidates on the same samples and folds, and most
candidates share their triangulation and degree with others: a move that changes the
continuity, joins the simplices of a cell (``cellwise``) or restricts a term's variables
changes only the conditions, not the normal equations; a move that adds or removes a
multiplier changes only which terms' blocks enter them. :class:`FoldEquations` keeps, per
triangulation and degree, each fold's located samples and their per-term-pair blocks
(:class:`~simplexspline.spline.varying.TermGrams`), so the normal equations of a candidate
are assembled, not accumulated again. A plain (not varying-coefficient) structure's fold
equations are kept whole. The results equal a fresh accumulation up to round-off.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from simplexspline.aero.modelling.structure import Structure
from simplexspline.aero.modelling.structure_space import StructureSpace, accumulate
from simplexspline.errors import InputError
from simplexspline.spline.varying import TermGrams, VaryingCoefficientSpace

__all__ = ["FoldEquations", "fold_equations"]


def fold_equations(space, u, m, y, folds: np.ndarray, k: int):
    """Normal equations of all located samples and of each fold's, accumulated afresh.

    Parameters
    ----------
    space : SplineSpace or VaryingCoefficientSpace
    u : ndarray, shape (N, n)
        Scaled scheduling variables.
    m : ndarray, shape (N, K), or None
        Normalised multipliers (None for a plain space).
    y : ndarray, shape (N,)
    folds : ndarray of int, shape (N,)
        Fold per sample, 0..k-1.
    k : int

    Returns
    -------
    total : NormalEquations or VaryingNormalEquations
    parts : list of k accumulators, one per fold
    """
    sid = space.triangulation.locate(u)
    parts = []
    for f in range(k):
        sel = (folds == f) & (sid >= 0)
        parts.append(accumulate(space, u[sel], None if m is None else m[sel], y[sel]))
    return _sum(parts), parts


def _sum(parts: list):
    total = parts[0].copy()
    for p in parts[1:]:
        total.merge(p)
    return total


class FoldEquations:
    """Fold normal equations of the candidates of one search (same samples, coefficient
    and folds throughout), reused across candidates that share their triangulation and
    degree.

    Parameters
    ----------
    y : ndarray, shape (N,)
        The coefficient (the samples of the search).
    folds : ndarray of int, shape (N,)
        Fold per sample.
    max_bytes : int
        Memory the kept basis values and blocks may take; beyond it the least recently
        used triangulations are dropped (default 96 MiB).

    Attributes
    ----------
    hits, misses : int
        Candidates whose fold equations were assembled from kept blocks / that needed
        their samples located and their basis values computed.
    """

    def __init__(self, y: np.ndarray, folds: np.ndarray, max_bytes: int = 96 << 20):
        self.y = np.asarray(y, dtype=float)
        self.folds = np.asarray(folds)
        if self.folds.shape != self.y.shape:
            raise InputError(f"folds must give one fold per sample ({self.y.shape}), got "
                             f"{self.folds.shape}")
        self.k = int(self.folds.max()) + 1
        self.max_bytes = int(max_bytes)
        self._entries: OrderedDict = OrderedDict()
        self.hits = 0
        self.misses = 0

    def matches(self, y: np.ndarray, folds: np.ndarray) -> bool:
        """Whether ``y`` and ``folds`` are the samples and folds of this cache."""
        y, folds = np.asarray(y), np.asarray(folds)
        return (y.shape == self.y.shape and folds.shape == self.folds.shape
                and np.array_equal(y, self.y) and np.array_equal(folds, self.folds))

    def get(self, structure: Structure, laid: StructureSpace, min_points: int):
        """The fold normal equations of ``structure`` laid on the samples as ``laid``
        (built with ``min_points``): ``(total, parts)`` as :func:`fold_equations`, new
        accumulators the caller may change."""
        space = laid.space
        tri = space.triangulation
        key = (structure.variables, tuple(sorted(structure.knots_of.items())),
               structure.resolution, structure.degree, int(min_points))
        u, m = laid.scheduling, laid.multipliers
        entry = self._entries.get(key)
        if entry is not None and not (entry["triangulation"].same_as(tri)
                                      and np.array_equal(entry["scheduling"], u)):
            entry = None        # the same description laid differently: start afresh
        varying = isinstance(space, VaryingCoefficientSpace)
        if entry is None:
            self.misses += 1
            entry = {"triangulation": tri, "scheduling": u, "plain": {}, "grams": None}
            self._entries[key] = entry
        else:
            self.hits += 1
            self._entries.move_to_end(key)
        if not varying:
            # the whole fold equations of a plain space (same triangulation and degree:
            # the continuity and the cells' joins do not enter them)
            if "parts" not in entry["plain"]:
                entry["plain"]["parts"] = fold_equations(space, u, None, self.y,
                                                         self.folds, self.k)[1]
            parts = [p.copy() for p in entry["plain"]["parts"]]
            self._trim()
            return _sum(parts), parts
        if entry["grams"] is None:
            sid = tri.locate(u)
            entry["grams"] = []
            for f in range(self.k):
                sel = np.flatnonzero((self.folds == f) & (sid >= 0))
                entry["grams"].append((sel, TermGrams(tri, structure.degree, u[sel],
                                                      self.y[sel])))
        scales, offsets = laid.multiplier_scaling
        names = [(name, float(sc), float(off)) for name, sc, off in
                 zip(structure.multipliers, scales, offsets)]
        parts = [grams.normal_equations([(key_, m[sel, i]) for i, key_ in enumerate(names)])
                 for sel, grams in entry["grams"]]
        self._trim()
        return _sum(parts), parts

    @property
    def nbytes(self) -> int:
        """Memory taken by the kept basis values and blocks."""
        return sum(_entry_bytes(e) for e in self._entries.values())

    def _trim(self) -> None:
        """Drop the least recently used entries (never the last one) beyond max_bytes."""
        while len(self._entries) > 1 and self.nbytes > self.max_bytes:
            self._entries.popitem(last=False)


def _entry_bytes(entry: dict) -> int:
    size = sum(p.XtWX.nbytes + p.XtWy.nbytes for p in entry["plain"].get("parts", ()))
    for _sel, grams in entry["grams"] or ():
        size += grams.nbytes
    return size
