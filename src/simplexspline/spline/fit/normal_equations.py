"""Per-simplex normal-equation blocks, accumulated chunk by chunk.

The regression matrix X of Eq. 36 is block diagonal after sorting the points by simplex:
each point touches only the d_hat columns of its simplex. So ``X'WX`` is block diagonal
with J blocks of d_hat x d_hat, and ``X'Wy`` has J blocks of d_hat. They are accumulated
by sorting each chunk of points per simplex and one BLAS product per block; the dense
N x (J*d_hat) matrix is never formed, and memory is bounded independently of N.
"""

from __future__ import annotations

import numpy as np

from simplexspline.errors import InputError, OutsideDomainError
from simplexspline.spline import kernels
from simplexspline.spline.bform import basis_values_t, num_basis
from simplexspline.spline.inputs import as_points, as_values, as_weights

__all__ = ["BlockSums", "NormalEquations"]

#: The additive sufficient statistics of an accumulator (what merge, + and - combine).
_BLOCKS = ("XtWX", "XtWy", "ytWy", "wsum", "counts")

#: Points processed per chunk when accumulating (bounds temporary memory).
CHUNK = 1 << 18

#: Calls of ``add`` with at least this many points use the fused compiled kernel (basis
#: tiles and BLAS dsyrk in one pass); smaller ones the two-step path, whose per-block
#: overhead is negligible there.
FUSED_MIN_POINTS = 100_000

#: Simplices with at most this many points in a chunk have their blocks accumulated by a
#: compiled loop (numba) rather than one BLAS product each, when a chunk has at least
#: SMALL_MANY of them (below that the per-block products cost little).
SMALL_BLOCK = 64
SMALL_MANY = 256

#: Calls of ``add`` with at least this many points are split across threads (see
#: :func:`_thread_count`); below, thread start-up and the extra block sums cost more
#: than they save.
PARALLEL_MIN_POINTS = 100_000


def _thread_count(npoints: int, threads: int | None) -> int:
    """Threads for accumulating ``npoints`` points (>= 1)."""
    return kernels.thread_count(npoints, threads, PARALLEL_MIN_POINTS)


class BlockSums:
    """What accumulators of per-simplex normal-equation blocks share: the additive
    sufficient statistics (:data:`_BLOCKS`) and how they combine. Subclasses define the
    blocks' shapes, ``add`` and ``_check_compatible``."""

    @property
    def npoints(self) -> int:
        """Total number of accumulated points."""
        return int(self.counts.sum())

    def _space_key(self) -> tuple:
        """The arguments of ``check_space`` that describe these blocks' space."""
        return self.triangulation, self.degree

    def _check_compatible(self, other) -> None:
        if type(other) is not type(self):
            raise InputError(f"cannot combine {type(self).__name__} with "
                             f"{type(other).__name__}")
        self.check_space(*other._space_key())

    def merge(self, other):
        """Add another accumulator (same space) into this one, in place."""
        self._check_compatible(other)
        for name in _BLOCKS:
            mine = getattr(self, name)
            if isinstance(mine, np.ndarray):
                mine += getattr(other, name)
            else:
                setattr(self, name, mine + getattr(other, name))
        return self

    def __add__(self, other):
        return self.copy().merge(other)

    def __sub__(self, other):
        """The blocks of this accumulator without ``other``'s (e.g. all data minus one
        cross-validation fold)."""
        self._check_compatible(other)
        out = self.copy()
        for name in _BLOCKS:
            setattr(out, name, getattr(out, name) - getattr(other, name))
        return out

    def copy(self):
        """A deep copy (the triangulation is shared)."""
        out = type(self).__new__(type(self))
        out.__dict__.update({k: (v.copy() if isinstance(v, np.ndarray) else v)
                             for k, v in self.__dict__.items()})
        return out


class NormalEquations(BlockSums):
    """Sufficient statistics of a (weighted) least-squares spline fit.

    Parameters
    ----------
    triangulation : Triangulation
    degree : int

    Attributes
    ----------
    XtWX : ndarray, shape (J, d_hat, d_hat)
        Per-simplex Gram blocks ``sum_i w_i B(b_i) B(b_i)'``.
    XtWy : ndarray, shape (J, d_hat)
        Per-simplex ``sum_i w_i y_i B(b_i)``.
    ytWy : float
        ``sum_i w_i y_i^2``.
    wsum : ndarray, shape (J,)
        Sum of weights per simplex.
    counts : ndarray of int, shape (J,)
        Number of points (with any weight) per simplex.

    Notes
    -----
    Accumulators from different chunks (or machines) add: ``a + b`` or ``a.merge(b)``.
    """

    def __init__(self, triangulation, degree: int):
        self.triangulation = triangulation
        self.degree = int(degree)
        nsimp = triangulation.nsimplex
        dhat = num_basis(triangulation.ndim, self.degree)
        self.XtWX = np.zeros((nsimp, dhat, dhat))
        self.XtWy = np.zeros((nsimp, dhat))
        self.ytWy = 0.0
        self.wsum = np.zeros(nsimp)
        self.counts = np.zeros(nsimp, dtype=np.int64)

    def add(self, x, y, weights=None, *, threads: int | None = None) -> NormalEquations:
        """Accumulate a chunk of data in place.

        Parameters
        ----------
        x : array_like, shape (N, n)
            Points; all must lie inside the triangulation.
        y : array_like, shape (N,)
            Observations.
        weights : array_like, shape (N,), optional
            Non-negative weights (inverse noise variances; diagonal Sigma^-1 of Eq. 38).
        threads : int, optional
            Worker threads for large calls (each locates and accumulates a contiguous part
            of the points into private blocks, which are then summed). Default: the CPUs
            this process may use (``SIMPLEXSPLINE_THREADS`` overrides), for calls of at
            least :data:`PARALLEL_MIN_POINTS` points; 1 runs in the calling thread.

        Returns
        -------
        self

        Raises
        ------
        OutsideDomainError
            When points lie outside the triangulation (nothing is accumulated then).
        """
        tri = self.triangulation
        pts = as_points(x, name="x", ndim=tri.ndim)
        vals = as_values(y, len(pts))
        w = as_weights(weights, len(pts))
        nthreads = _thread_count(len(pts), threads)
        bounds = np.linspace(0, len(pts), nthreads + 1).astype(np.int64)
        fused = len(pts) >= FUSED_MIN_POINTS
        with kernels.one_blas_thread():
            if nthreads == 1:
                parts = [self._accumulate(pts, vals, w, fused, None)]
            else:
                from concurrent.futures import ThreadPoolExecutor

                def work(i):
                    s, e = bounds[i], bounds[i + 1]
                    return self._accumulate(pts[s:e], vals[s:e], None if w is None else w[s:e],
                                            fused, NormalEquations(tri, self.degree))

                with ThreadPoolExecutor(nthreads) as pool:
                    parts = list(pool.map(work, range(nthreads)))
        out = np.concatenate([o + b for (o, _), b in zip(parts, bounds) if len(o)]
                             ) if any(len(o) for o, _ in parts) else np.zeros(0, np.int64)
        if len(out):
            raise OutsideDomainError(
                f"{len(out)} of {len(pts)} data points lie outside the triangulation "
                f"(first rows: {out[:5].tolist()}); drop them or enlarge the triangulation",
                out,
            )
        for _, part in parts:
            if part is not None:
                self.merge(part)
        return self

    def _accumulate(self, pts, vals, w, fused: bool, into):
        """Locate and accumulate points into ``into`` (None: this accumulator); returns
        (indices of points outside the triangulation, accumulator). Nothing is accumulated
        when any point lies outside."""
        sid = self.triangulation.locate(pts)
        out = np.nonzero(sid < 0)[0]
        if len(out):
            return out, None
        target = self if into is None else into
        for s in range(0, len(pts), CHUNK):
            e = s + CHUNK
            target._add_located(pts[s:e], vals[s:e], None if w is None else w[s:e],
                                sid[s:e], fused)
        return out, into

    def _add_located(self, pts, vals, w, sid, fused: bool = False) -> None:
        """Accumulate points whose simplices are known (kernel, no validation)."""
        tri = self.triangulation
        nsimp = tri.nsimplex
        counts = np.bincount(sid, minlength=nsimp)
        self.counts += counts
        ends = np.cumsum(counts)
        wy = vals if w is None else w * vals
        if fused and kernels.fused_normal(pts, sid, counts, w, wy, tri._origin, tri._tinv, self.degree,
                                self.XtWX, self.XtWy):
            self.wsum += counts if w is None else np.bincount(sid, weights=w, minlength=nsimp)
            self.ytWy += float(wy @ vals)
            return
        if kernels.HAVE_NUMBA:
            # Basis columns written directly in simplex-sorted order: X_j' = cols[:, s:e].
            cols, perm = kernels.sorted_design_t(pts, sid, counts, tri._origin, tri._tinv,
                                                 self.degree)
            ys = np.empty_like(vals)
            ys[perm] = vals
            ws = None
            if w is not None:
                ws = np.empty_like(w)
                ws[perm] = w
        else:
            order = np.argsort(sid, kind="stable")
            b = tri._locator_barycentric(pts[order], sid[order])
            cols = basis_values_t(b.T, self.degree)  # (d_hat, N)
            ys = vals[order]
            ws = None if w is None else w[order]
        if ws is None:
            self.wsum += counts
            self.ytWy += float(ys @ ys)
            wy = ys
        else:
            self.wsum += np.bincount(sid, weights=w, minlength=nsimp)
            wy = ws * ys
            self.ytWy += float(wy @ ys)
        small = np.nonzero((counts > 0) & (counts <= SMALL_BLOCK))[0]
        if kernels.HAVE_NUMBA and len(small) >= SMALL_MANY:
            # Many small blocks (large triangulations): one compiled pass instead of a BLAS
            # call per simplex (Python overhead and small products far below BLAS speed).
            kernels.gram_blocks(cols, ws, wy, ends, counts, small, self.XtWX, self.XtWy)
            large = np.nonzero(counts > SMALL_BLOCK)[0]
        else:
            large = np.nonzero(counts)[0]
        for j in large:
            s, e = ends[j] - counts[j], ends[j]
            xj = cols[:, s:e]  # (d_hat, n_j), row stride N: a valid BLAS operand
            xw = xj if ws is None else xj * ws[s:e]
            self.XtWX[j] += xw @ xj.T
            self.XtWy[j] += xj @ wy[s:e]

    def check_space(self, triangulation, degree: int) -> None:
        """Raise InputError unless these blocks belong to ``triangulation`` and ``degree``."""
        if degree != self.degree:
            raise InputError(f"normal equations of degree {self.degree} do not match a spline "
                             f"space of degree {degree}")
        if not self.triangulation.same_as(triangulation):
            raise InputError("the normal equations were accumulated on a different "
                             "triangulation than this spline space's")


