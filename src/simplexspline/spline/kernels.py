"""Optional compiled kernels (numba) for the hot loops, with numpy fallbacks.

Installed with ``pip install 'simplexspline[fast]'``. Every kernel has a pure-numpy
equivalent elsewhere in the package, and the tests check that both give the same numbers;
``SIMPLEXSPLINE_NO_NUMBA=1`` in the environment forces the numpy paths. The README records
the measured factor that earns numba its place.

Kernels
-------
* :func:`grid_locate`: Kuhn-grid point location (cell by floor, simplex by sorting the local
  coordinates), one pass per point.
* :func:`basis_cols`: B-form basis values (d_hat, N), level by level over blocks of points.
* :func:`evaluate`: barycentric coordinates, basis and the dot product with the simplex's
  coefficients fused, without materialising the basis matrix.
"""

from __future__ import annotations

import os

import numpy as np

from simplexspline.spline.bform import _monomial_plan, _scale

__all__ = ["HAVE_NUMBA", "basis_plan", "grid_locate", "basis_cols", "sorted_design", "evaluate"]

try:  # pragma: no cover - exercised where numba is installed
    if os.environ.get("SIMPLEXSPLINE_NO_NUMBA"):
        raise ImportError
    import numba

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    numba = None
    HAVE_NUMBA = False


def basis_plan(n: int, d: int):
    """Flattened monomial plan for degree d: (parents, firsts, offsets, scale)."""
    parents, firsts, offsets = [], [], [0]
    for k in range(2, d + 1):
        p, f = _monomial_plan(n, k)
        parents.append(p)
        firsts.append(f)
        offsets.append(offsets[-1] + len(p))
    cat = (lambda a: np.concatenate(a).astype(np.int64)) if parents else (
        lambda a: np.zeros(0, dtype=np.int64))
    return cat(parents), cat(firsts), np.asarray(offsets, dtype=np.int64), np.asarray(
        _scale(n, d), dtype=float)


if HAVE_NUMBA:  # pragma: no cover - compiled

    @numba.njit(cache=True, nogil=True)
    def _grid_locate(x, lower, step, shape, table, nfact, tol, out):
        npts, n = x.shape
        rel = np.empty(n)
        idx = np.empty(n, dtype=np.int64)
        for i in range(npts):
            inside = True
            flat = 0
            for k in range(n):
                r = (x[i, k] - lower[k]) / step[k]
                if r < -tol * shape[k] or r > shape[k] * (1.0 + tol):
                    inside = False
                c = int(np.floor(r))
                if c < 0:
                    c = 0
                elif c > shape[k] - 1:
                    c = shape[k] - 1
                rel[k] = r - c
                flat = flat * shape[k] + c
            if not inside:
                out[i] = -1
                continue
            # Stable descending argsort of the local coordinates (insertion sort).
            for k in range(n):
                idx[k] = k
            for k in range(1, n):
                j = k
                while j > 0 and rel[idx[j - 1]] < rel[idx[j]]:
                    t = idx[j - 1]
                    idx[j - 1] = idx[j]
                    idx[j] = t
                    j -= 1
            rank = 0
            for k in range(n - 1):
                smaller = 0
                for m in range(k + 1, n):
                    if idx[m] < idx[k]:
                        smaller += 1
                f = 1
                for m in range(2, n - k):
                    f *= m
                rank += smaller * f
            out[i] = table[flat * nfact + rank]
        return out

    BLOCK = 256

    @numba.njit(cache=True, nogil=True)
    def _block_monomials(bt, i0, i1, parents, firsts, offsets, s1, s2):
        """Degree-d monomials of points i0..i1 (columns of bt), level by level, into
        scratch arrays s1/s2 (inner loops over points: contiguous, vectorisable).
        Returns the array holding the last level."""
        np1 = bt.shape[0]
        w = i1 - i0
        prev = s1
        for k in range(np1):
            for i in range(w):
                prev[k, i] = bt[k, i0 + i]
        cur = s2
        for level in range(offsets.shape[0] - 1):
            s = offsets[level]
            m = offsets[level + 1] - s
            for k in range(m):
                p = parents[s + k]
                f = firsts[s + k]
                for i in range(w):
                    cur[k, i] = prev[p, i] * bt[f, i0 + i]
            prev, cur = cur, prev
        return prev

    @numba.njit(cache=True, nogil=True)
    def _basis_cols(bt, parents, firsts, offsets, scale, out):
        npts = bt.shape[1]
        m = scale.shape[0]
        s1 = np.empty((max(m, bt.shape[0]), BLOCK))
        s2 = np.empty((max(m, bt.shape[0]), BLOCK))
        for i0 in range(0, npts, BLOCK):
            i1 = min(i0 + BLOCK, npts)
            mono = _block_monomials(bt, i0, i1, parents, firsts, offsets, s1, s2)
            for k in range(m):
                sc = scale[k]
                for i in range(i1 - i0):
                    out[k, i0 + i] = mono[k, i] * sc
        return out

    @numba.njit(cache=True, nogil=True)
    def _block_barycentric(x, sid, i0, i1, origin, tinv, bt):
        """Barycentric coordinates of points i0..i1 in their simplices into bt[:, :i1-i0]
        (a negative simplex id, i.e. outside, uses simplex 0: the caller masks it)."""
        n = x.shape[1]
        for i in range(i1 - i0):
            j = max(sid[i0 + i], 0)
            total = 0.0
            for k in range(n):
                acc = 0.0
                for q in range(n):
                    acc += tinv[j, k, q] * (x[i0 + i, q] - origin[j, q])
                bt[k + 1, i] = acc
                total += acc
            bt[0, i] = 1.0 - total

    @numba.njit(cache=True, nogil=True)
    def _evaluate(x, sid, origin, tinv, coef, parents, firsts, offsets, scale, out):
        npts, n = x.shape
        m = scale.shape[0]
        bt = np.empty((n + 1, BLOCK))
        s1 = np.empty((max(m, n + 1), BLOCK))
        s2 = np.empty((max(m, n + 1), BLOCK))
        for i0 in range(0, npts, BLOCK):
            i1 = min(i0 + BLOCK, npts)
            _block_barycentric(x, sid, i0, i1, origin, tinv, bt)
            mono = _block_monomials(bt, 0, i1 - i0, parents, firsts, offsets, s1, s2)
            for i in range(i1 - i0):
                j = sid[i0 + i]
                if j < 0:
                    out[i0 + i] = np.nan
                    continue
                val = 0.0
                for k in range(m):
                    val += mono[k, i] * scale[k] * coef[j, k]
                out[i0 + i] = val
        return out

    @numba.njit(cache=True, nogil=True)
    def _sorted_design(x, sid, pos, origin, tinv, parents, firsts, offsets, scale, out, perm):
        """Basis rows of every point written at its simplex-sorted position.

        pos[j] is the next free row of simplex j (advanced in place); perm receives the
        sorted position of each point. Barycentric coordinates and monomials are computed
        for blocks of points (vectorisable inner loops), then scattered row by row.
        """
        npts, n = x.shape
        m = scale.shape[0]
        bt = np.empty((n + 1, BLOCK))
        s1 = np.empty((max(m, n + 1), BLOCK))
        s2 = np.empty((max(m, n + 1), BLOCK))
        for i0 in range(0, npts, BLOCK):
            i1 = min(i0 + BLOCK, npts)
            _block_barycentric(x, sid, i0, i1, origin, tinv, bt)
            mono = _block_monomials(bt, 0, i1 - i0, parents, firsts, offsets, s1, s2)
            for i in range(i1 - i0):
                j = sid[i0 + i]
                row = pos[j]
                pos[j] = row + 1
                perm[i0 + i] = row
                for k in range(m):
                    out[row, k] = mono[k, i] * scale[k]
        return out



def grid_locate(x, lower, step, shape, table, nfact, tol) -> np.ndarray:
    """Compiled Kuhn-grid location (see :class:`~simplexspline.spline.locate.GridLocator`)."""
    out = np.empty(len(x), dtype=np.int64)
    return _grid_locate(x, lower, step, shape, table, nfact, tol, out)


def basis_cols(bt: np.ndarray, d: int) -> np.ndarray:
    """Basis values (d_hat, N) of barycentric coordinates bt (n+1, N), compiled."""
    parents, firsts, offsets, scale = basis_plan(bt.shape[0] - 1, d)
    out = np.empty((len(scale), bt.shape[1]))
    if d == 0:
        out[:] = 1.0
        return out
    return _basis_cols(np.ascontiguousarray(bt), parents, firsts, offsets, scale, out)


def sorted_design(x, sid, counts, origin, tinv, d: int):
    """Basis rows (N, d_hat) of points located in simplices ``sid`` (all >= 0), in
    simplex-sorted order (rows of simplex j contiguous, in input order), and the sorted
    position of every input point."""
    parents, firsts, offsets, scale = basis_plan(x.shape[1], d)
    out = np.empty((len(x), len(scale)))
    perm = np.empty(len(x), dtype=np.int64)
    pos = (np.cumsum(counts) - counts).astype(np.int64)
    if d == 0:
        perm[:] = np.argsort(sid, kind="stable").argsort()
        out[:] = 1.0
        return out, perm
    _sorted_design(np.ascontiguousarray(x), sid, pos, origin, tinv, parents, firsts, offsets,
                   scale, out, perm)
    return out, perm


def evaluate(x, sid, origin, tinv, coef, d: int) -> np.ndarray:
    """Spline values at points x (N, n) in simplices sid (N,; -1 gives NaN), compiled."""
    parents, firsts, offsets, scale = basis_plan(x.shape[1], d)
    out = np.empty(len(x))
    if d == 0:
        out[:] = np.where(sid >= 0, coef[np.maximum(sid, 0), 0], np.nan)
        return out
    return _evaluate(np.ascontiguousarray(x), sid, origin, tinv, coef, parents, firsts,
                     offsets, scale, out)
