"""Vectorised point location in triangulations.

Three strategies:

* :class:`GridLocator` for Kuhn/Freudenthal grid triangulations: the cell follows from a
  floor, the simplex from the permutation that sorts the local coordinates: O(n log n)
  per point, no search.
* :class:`WalkLocator` for any triangulation (compiled): a visibility walk through the
  facet neighbours from a seed simplex near the point (one per cell of a uniform seed grid,
  the simplex with the nearest barycentre); a few barycentric evaluations per point.
* :class:`BucketLocator` for any triangulation: a uniform bucket grid over the bounding box
  lists the simplices whose bounding boxes meet each bucket; a point is tested against the
  candidates of its bucket only. The numpy path, and the exact fallback of the walk where
  it stops at the boundary of a non-convex triangulation.

Every strategy but the grid's gives a point on (or within :data:`INSIDE_TOL` of) a face
shared by several simplices the lowest-index simplex containing it, so the answer does not
depend on the strategy, the batch or the order of the points.
"""

from __future__ import annotations

from itertools import permutations
from math import factorial

import numpy as np
from scipy.spatial import cKDTree

from simplexspline.spline.geometry.barycentric import barycentric
from simplexspline.spline import kernels

__all__ = ["GridLocator", "WalkLocator", "BucketLocator", "kuhn_permutations", "INSIDE_TOL"]

#: A point whose smallest barycentric coordinate is >= -INSIDE_TOL is inside a simplex.
INSIDE_TOL = 1e-10

#: Points are located in chunks of this many to bound temporary memory.
CHUNK = 65536


def kuhn_permutations(n: int) -> np.ndarray:
    """All permutations of ``range(n)`` in lexicographic order, shape (n!, n)."""
    return np.array(list(permutations(range(n))), dtype=np.int64).reshape(factorial(n), n)


def _perm_rank(perm: np.ndarray) -> np.ndarray:
    """Lexicographic rank (Lehmer code) of permutations, shape (N, n) -> (N,)."""
    npts, n = perm.shape
    rank = np.zeros(npts, dtype=np.int64)
    for i in range(n - 1):
        smaller_later = (perm[:, i + 1 :] < perm[:, i : i + 1]).sum(axis=1)
        rank += smaller_later * factorial(n - 1 - i)
    return rank


class GridLocator:
    """Point location on a Kuhn triangulation of the box ``[lower, upper]``.

    Parameters
    ----------
    lower, upper : ndarray, shape (n,)
        Box corners.
    shape : ndarray of int, shape (n,)
        Number of cells along each axis.
    table : ndarray of int, shape (ncells * n!,)
        Simplex index of (cell, permutation rank), ``-1`` where the simplex was dropped.
    """

    def __init__(self, lower, upper, shape, table):
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        self.shape = np.asarray(shape, dtype=np.int64)
        self.table = np.asarray(table, dtype=np.int64)
        self.step = (self.upper - self.lower) / self.shape
        self._nfact = factorial(len(self.shape))

    def locate(self, x: np.ndarray) -> np.ndarray:
        """Simplex index of each point, ``-1`` outside; x has shape (N, n)."""
        if kernels.HAVE_NUMBA and len(x) > 0:
            return kernels.grid_locate(x, self.lower, self.step, self.shape, self.table,
                                       self._nfact, INSIDE_TOL)
        return self.locate_numpy(x)

    def locate_numpy(self, x: np.ndarray) -> np.ndarray:
        """The numpy implementation of :meth:`locate`."""
        npts, n = x.shape
        rel = (x - self.lower) / self.step
        tol = INSIDE_TOL * self.shape
        inside = np.all((rel >= -tol) & (rel <= self.shape + tol), axis=1)
        cell = np.clip(np.floor(rel).astype(np.int64), 0, self.shape - 1)
        local = rel - cell
        perm = np.argsort(-local, axis=1, kind="stable")
        flat = np.ravel_multi_index(tuple(cell.T), tuple(self.shape))
        out = self.table[flat * self._nfact + _perm_rank(perm)]
        out[~inside] = -1
        return out


class BucketLocator:
    """Point location in an arbitrary triangulation with a uniform bucket grid.

    Parameters
    ----------
    corners : ndarray, shape (J, n + 1, n)
        Vertex coordinates of every simplex.
    origin, tinv : ndarray
        The simplices' affine maps
        (see :func:`~simplexspline.spline.geometry.barycentric.simplex_transforms`).
    """

    def __init__(self, corners: np.ndarray, origin: np.ndarray, tinv: np.ndarray):
        nsimp, _, n = corners.shape
        self.origin = origin
        self.tinv = tinv
        lo = corners.min(axis=1)
        hi = corners.max(axis=1)
        self.lower = lo.min(axis=0)
        self.upper = hi.max(axis=0)
        span = np.where(self.upper > self.lower, self.upper - self.lower, 1.0)
        # About two buckets per simplex, shaped like the bounding box.
        target = max(1.0, 2.0 * nsimp)
        # span / geometric mean of span, through logs: the product under- or overflows at
        # coordinate scales like 1e-300 or 1e+300
        per_axis = np.exp(np.log(span) - np.mean(np.log(span))) * target ** (1.0 / n)
        self.nb = np.clip(np.ceil(per_axis).astype(np.int64), 1, 1 << 20)
        self.width = span / self.nb
        blo = self._bucket_coords(lo)
        bhi = self._bucket_coords(hi)
        ext = bhi - blo + 1
        count = np.prod(ext, axis=1)
        sid = np.repeat(np.arange(nsimp), count)
        within = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
        coord = np.empty((len(sid), n), dtype=np.int64)
        rest = within
        for k in range(n - 1, -1, -1):
            e = ext[sid, k]
            coord[:, k] = blo[sid, k] + rest % e
            rest = rest // e
        bucket = np.ravel_multi_index(tuple(coord.T), tuple(self.nb))
        order = np.argsort(bucket, kind="stable")
        self.indices = sid[order]
        self.indptr = np.zeros(int(np.prod(self.nb)) + 1, dtype=np.int64)
        np.cumsum(np.bincount(bucket, minlength=int(np.prod(self.nb))), out=self.indptr[1:])

    def _bucket_coords(self, x: np.ndarray) -> np.ndarray:
        rel = np.floor((x - self.lower) / self.width).astype(np.int64)
        return np.clip(rel, 0, self.nb - 1)

    def _pairs(self, x: np.ndarray):
        """Candidate (point, simplex) pairs and the pairs' barycentric coordinates."""
        tol = INSIDE_TOL * (self.upper - self.lower + 1.0)
        inbox = np.all((x >= self.lower - tol) & (x <= self.upper + tol), axis=1)
        bucket = np.ravel_multi_index(tuple(self._bucket_coords(x).T), tuple(self.nb))
        start = self.indptr[bucket]
        count = np.where(inbox, self.indptr[bucket + 1] - start, 0)
        point = np.repeat(np.arange(len(x)), count)
        offset = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
        simplex = self.indices[np.repeat(start, count) + offset]
        b = barycentric(x[point], self.origin[simplex], self.tinv[simplex])
        return point, simplex, b.min(axis=1)

    def locate(self, x: np.ndarray) -> np.ndarray:
        """Simplex index of each point (the first containing one), ``-1`` outside."""
        out = np.full(len(x), -1, dtype=np.int64)
        for s in range(0, len(x), CHUNK):
            point, simplex, bmin = self._pairs(x[s : s + CHUNK])
            ok = bmin >= -INSIDE_TOL
            first_pt, first = np.unique(point[ok], return_index=True)
            out[s + first_pt] = simplex[ok][first]
        return out

    def containing(self, x: np.ndarray, tol: float = INSIDE_TOL):
        """All (point, simplex) pairs with the point inside the simplex (up to ``tol``)."""
        point, simplex, bmin = self._pairs(x)
        ok = bmin >= -tol
        return point[ok], simplex[ok]


#: Seed cells per simplex of :class:`WalkLocator`'s seed grid (at most :data:`SEED_MAX`).
SEED_PER_SIMPLEX = 4.0
SEED_MAX = 1 << 22


class WalkLocator:
    """Point location in an arbitrary triangulation by a compiled visibility walk.

    Parameters
    ----------
    corners : ndarray, shape (J, n + 1, n)
        Vertex coordinates of every simplex.
    origin, tinv : ndarray
        The simplices' affine maps
        (see :func:`~simplexspline.spline.geometry.barycentric.simplex_transforms`).
    neighbors : ndarray of int, shape (J, n + 1)
        Neighbour across the facet opposite each local vertex, -1 on the boundary.
    convex : bool
        The triangulation covers a convex set (a Delaunay triangulation with no simplex
        dropped): a walk stopped by a boundary facet proves the point outside.
    fallback : callable
        ``fallback(points) -> simplices`` for the points a walk cannot settle (stopped at
        the boundary of a non-convex triangulation, or cycling in a non-Delaunay one).

    Notes
    -----
    The walk steps from the seed simplex of the point's cell across the facet opposite
    the most negative barycentric coordinate until none is below ``-INSIDE_TOL``; on a
    Delaunay triangulation it always ends (Edelsbrunner's acyclicity theorem), elsewhere a
    step limit hands cycling points to the fallback.
    """

    def __init__(self, corners: np.ndarray, origin: np.ndarray, tinv: np.ndarray,
                 neighbors: np.ndarray, convex: bool, fallback):
        nsimp, _, n = corners.shape
        self.origin = np.ascontiguousarray(origin)
        self.tinv = np.ascontiguousarray(tinv)
        self.neighbors = np.ascontiguousarray(neighbors, dtype=np.int64)
        self.convex = bool(convex)
        self.fallback = fallback
        self.lower = corners.min(axis=(0, 1))
        upper = corners.max(axis=(0, 1))
        span = np.where(upper > self.lower, upper - self.lower, 1.0)
        target = min(max(1.0, SEED_PER_SIMPLEX * nsimp), SEED_MAX)
        per_axis = span / np.prod(span) ** (1.0 / n) * target ** (1.0 / n)
        self.shape = np.clip(np.ceil(per_axis).astype(np.int64), 1, 1 << 16)
        while np.prod(self.shape.astype(float)) > SEED_MAX:
            self.shape = np.maximum(1, self.shape // 2)
        self.width = span / self.shape
        centres = self.lower + (np.indices(tuple(self.shape)).reshape(n, -1).T + 0.5
                                ) * self.width
        _, seeds = cKDTree(corners.mean(axis=1)).query(centres)
        seeds = np.asarray(seeds, dtype=np.int64).reshape(-1)
        # Better seeds: the simplex containing each cell's centre (found by walking from
        # the nearest barycentre), so that most walks take no step at all.
        found = kernels.walk_locate(centres, self._plan(seeds))
        self.seeds = np.where(found >= 0, found, seeds)
        #: The walk kernels' arguments (:func:`~simplexspline.spline.kernels.walk_plan`).
        self.plan = self._plan(self.seeds)

    def _plan(self, seeds: np.ndarray) -> tuple:
        return kernels.walk_plan(self.origin, self.tinv, self.neighbors, self.lower,
                                 self.width, self.shape, seeds, self.convex, INSIDE_TOL)

    def locate(self, x: np.ndarray) -> np.ndarray:
        """Simplex index of each point (the lowest-index containing one), -1 outside."""
        return self.settle(x, kernels.walk_locate(x, self.plan))

    def settle(self, x: np.ndarray, sid: np.ndarray) -> np.ndarray:
        """``sid`` from a walk kernel with the points it could not settle (-2) located by
        the fallback, in place; returns ``sid``."""
        rest = np.nonzero(sid == -2)[0]
        if len(rest):
            sid[rest] = self.fallback(x[rest])
        return sid
