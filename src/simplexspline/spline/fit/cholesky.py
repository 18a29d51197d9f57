"""Multifrontal sparse Cholesky factorisation with a geometric nested-dissection ordering.

The constrained least-squares solver (:mod:`simplexspline.spline.fit.constrained`) and the
Hutchinson GCV evaluator (:mod:`simplexspline.spline.fit.gcv`) factorise sparse symmetric
positive definite matrices ``P = L L'`` whose unknowns are spline coefficients with a
position in space (their B-net points). :class:`SparseCholesky` orders them by nested
dissection along coordinate planes, builds the frontal structure once per sparsity pattern
(:class:`_CholeskySymbolic`, cached across fits on one spline space) and does the dense work
per front with LAPACK/BLAS.

Notes
-----
Tuning constants: :data:`ND_LEAF` (size of a dense leaf front) and :data:`SERIAL_FRONT`
(fronts at least this large use the BLAS library's default thread count).
"""

from __future__ import annotations

import contextlib

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.linalg import blas

from simplexspline.spline import kernels

__all__ = ["ND_LEAF", "SERIAL_FRONT", "SparseCholesky"]

#: Nested dissection stops splitting at this many unknowns (a dense leaf front).
ND_LEAF = 256

#: Frontal matrices smaller than this (rows) are factorised with one BLAS thread, larger
#: ones with the BLAS library's default; the triangular solves always use one. The default
#: (no limit: one thread throughout) is the robust choice on shared machines: with another
#: process busy on one of the 2 cores, OpenBLAS's spinning threads made benchmark 3's
#: factorisation 2-3x slower than one thread. On an idle many-core machine, e.g. 1500 lets
#: the large fronts use all cores.
SERIAL_FRONT = float("inf")


class SparseCholesky:
    """Multifrontal sparse Cholesky factorisation ``P = L L'`` of a symmetric positive
    definite matrix whose unknowns have positions in space (here the B-net points).

    Ordering: geometric nested dissection. A region of unknowns is cut by a plane normal to
    a coordinate axis, at the position (among the middle half of the unknowns, along every
    axis) with the smallest vertex separator: the unknowns on one side coupled to the other.
    The separator is eliminated after both halves. On simplex splines the best planes follow
    the facets (two layers of B-net points: the facet and, coupled through the C^1
    conditions, the first layer beside it).

    Factorisation: every tree node owns its separator (or a leaf region) and assembles a
    dense frontal matrix from P and its children's update matrices; LAPACK/BLAS do the
    dense Cholesky, triangular solve and rank-k update. Raises ``numpy.linalg.LinAlgError``
    when P is not numerically positive definite.
    """

    def __init__(self, P, coords: np.ndarray, leaf: int = ND_LEAF, cache: dict | None = None):
        P = sp.csr_matrix(P)
        P.sum_duplicates()
        P.sort_indices()
        key = (P.shape[0], P.nnz, hash(P.indptr.tobytes()), hash(P.indices.tobytes()))
        sym = cache.get(key) if cache is not None else None
        if sym is None:
            sym = _CholeskySymbolic(P, np.asarray(coords, dtype=float), leaf)
            if cache is not None:
                cache.clear()  # one pattern at a time (bounded memory)
                cache[key] = sym
        self.perm = sym.perm
        data = P.data
        nodes = sym.nodes
        self.factors = [None] * len(nodes)
        pending: dict = {}
        for t, node in enumerate(nodes):
            s, e, U = node[:3]
            with (kernels.one_blas_thread() if e - s + len(U) < SERIAL_FRONT
                  else contextlib.nullcontext()):
                self._factor_node(t, *node, data, pending)

    def _factor_node(self, t, s, e, U, frow, fcol, src, kids, data, pending):
        """Assemble, factorise and (into ``pending``) update one front."""
        nown = e - s
        front = np.zeros((nown + len(U),) * 2, order="F")
        front[frow, fcol] = data[src]  # lower triangle of P's part
        for c, li in kids:
            kernels.extend_add(front, li, pending.pop(c))
        if nown == 0:
            # an empty separator (the region fell apart into uncoupled halves): the
            # children's updates pass through (BLAS's dsyrk rejects a rank-0 update, and
            # OpenBLAS prints "On entry to DSYRK parameter number 7 had an illegal value")
            if len(U):
                pending[t] = front
            self.factors[t] = (s, e, np.zeros((0, 0)), np.zeros((0, len(U))), U)
            return
        try:
            L11 = sla.cholesky(front[:nown, :nown], lower=True, check_finite=False,
                               overwrite_a=True)
        except sla.LinAlgError:
            raise np.linalg.LinAlgError("matrix not positive definite") from None
        W = sla.solve_triangular(L11, front[nown:, :nown].T, lower=True,
                                 check_finite=False)  # L21'
        if len(U):
            pending[t] = blas.dsyrk(-1.0, W, beta=1.0, c=front[nown:, nown:], trans=1,
                                    lower=1, overwrite_c=1)
        self.factors[t] = (s, e, L11, W, U)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``P^{-1} b``."""
        with kernels.one_blas_thread():
            return self._solve(b)

    def _solve(self, b: np.ndarray) -> np.ndarray:
        x = np.asarray(b, dtype=float)[self.perm]
        for s, e, L11, W, U in self.factors:
            xs = sla.solve_triangular(L11, x[s:e], lower=True, check_finite=False)
            x[s:e] = xs
            if len(U):
                x[U] -= W.T @ xs
        for s, e, L11, W, U in reversed(self.factors):
            r = x[s:e] - W @ x[U] if len(U) else x[s:e]
            x[s:e] = sla.solve_triangular(L11, r, lower=True, trans="T", check_finite=False)
        out = np.empty_like(x)
        out[self.perm] = x
        return out


class _CholeskySymbolic:
    """Ordering and frontal structure of :class:`SparseCholesky` (depends on the pattern
    only, so it is reused across fits on one spline space)."""

    def __init__(self, P: sp.csr_matrix, coords: np.ndarray, leaf: int):
        self.perm, tree = nested_dissection(P, coords, leaf)
        # Permuted pattern whose values are positions in P.data.
        pos = sp.csr_matrix((np.arange(1, P.nnz + 1, dtype=float), P.indices, P.indptr),
                            shape=P.shape)
        pos = pos[self.perm][:, self.perm].tocsr()
        self.nodes = []
        updates = {}
        for t, (s, e, kids) in enumerate(tree):
            lo, hi = pos.indptr[s], pos.indptr[e]
            cols = pos.indices[lo:hi]
            rows = np.repeat(np.arange(e - s), np.diff(pos.indptr[s:e + 1]))
            src = pos.data[lo:hi].astype(np.int64) - 1
            keep = cols >= s  # columns of earlier (descendant) unknowns arrive as updates
            cols, rows, src = cols[keep], rows[keep], src[keep]
            # children decoupled from everything later (empty update) contribute nothing
            kids = [c for c in kids if c in updates]
            child_u = [updates.pop(c) for c in kids]
            U = np.unique(np.concatenate([cols[cols >= e]] + [u[u >= e] for u in child_u]))
            F = np.concatenate([np.arange(s, e), U])
            if len(U):
                updates[t] = U
            self.nodes.append((s, e, U, np.searchsorted(F, cols), rows, src,
                               [(c, np.searchsorted(F, u)) for c, u in zip(kids, child_u)]))


def nested_dissection(P: sp.csr_matrix, coords: np.ndarray, leaf: int):
    """Elimination order and tree: ``perm`` and nodes ``(start, end, children)`` in
    postorder (node t owns the unknowns ``perm[start:end]``)."""
    owns: list[np.ndarray] = []
    nodes: list[tuple] = []

    def cut(region):
        m = len(region)
        sub = P[region][:, region].tocsr()
        filled = np.diff(sub.indptr) > 0
        starts = sub.indptr[:-1][filled]
        best = None
        for axis in range(coords.shape[1]):
            x = coords[region, axis]
            near = x[sub.indices]
            hi, lo = x.copy(), x.copy()  # extent of each unknown's couplings
            hi[filled] = np.maximum(hi[filled], np.maximum.reduceat(near, starts))
            lo[filled] = np.minimum(lo[filled], np.minimum.reduceat(near, starts))
            xs = np.sort(x)
            cand = np.unique(xs[m // 4:(3 * m) // 4 + 1])
            cand = cand[cand < xs[-1]]
            if len(cand) == 0:
                continue
            nleft = np.searchsorted(xs, cand, "right")
            sep_left = nleft - np.searchsorted(np.sort(hi), cand, "right")
            sep_right = np.searchsorted(np.sort(lo), cand, "right") - nleft
            size = np.minimum(sep_left, sep_right)
            cost = size * (1.0 + np.abs(nleft / m - 0.5))
            i = int(np.argmin(cost))
            if best is None or cost[i] < best[0]:
                best = (cost[i], size[i], cand[i], sep_left[i] <= sep_right[i], x, hi, lo)
        if best is None or best[1] >= m // 2:
            return None
        _, _, c, on_left, x, hi, lo = best
        left = x <= c
        sep = left & (hi > c) if on_left else ~left & (lo <= c)
        return sep, left & ~sep, ~left & ~sep

    def build(region, depth=0):
        parts = cut(region) if len(region) > leaf and depth < 64 else None
        if parts is None:
            kids, own = [], region
        else:
            sep, a, b = parts
            kids = [build(region[p], depth + 1) for p in (a, b) if p.any()]
            own = region[sep]
        owns.append(own)
        nodes.append(kids)
        return len(nodes) - 1

    build(np.arange(P.shape[0]))
    perm = np.concatenate(owns)
    ends = np.cumsum([len(o) for o in owns])
    return perm, [(int(e - len(o)), int(e), k) for o, e, k in zip(owns, ends, nodes)]
