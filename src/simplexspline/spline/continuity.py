"""Continuity conditions between simplices: the smoothness matrix H (paper Eq. 20-25).

Across an interior facet shared by ``t_a`` (out-of-facet vertex ``sigma``) and ``t_b``,
C^r continuity holds iff for every ``m = 0..r`` and every multi-index ``kappa'`` of degree
``d - m`` on the n shared vertices (GUIDE section 3, the general form of Eq. 21)

    c^{t_a}[kappa' on the shared slots, m on sigma's slot]
        = sum_{|gamma| = m} c^{t_b}[kappa' on the shared slots, 0 on t_b's out slot + gamma]
          * B^m_gamma(b(sigma)),

with ``b(sigma)`` the barycentric coordinates of ``sigma`` with respect to ``t_b``. Shared
vertices are matched by identity, so any vertex order inside the simplices works.

H is rank deficient around interior (n-2)-faces. :func:`reduce_rows` removes redundant
rows: the C^0 rows exactly (they are equalities between coefficients; a spanning forest of
their graph is independent and spans them all), the higher-order rows by sparse Gaussian
elimination in the C^0-reduced coordinates.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass
from math import comb

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

from simplexspline.spline.bform import basis_values, multi_index_lookup, multi_indices, num_basis

__all__ = ["smoothness_matrix", "SmoothnessSystem", "conditions_per_facet", "build_conditions"]

#: A higher-order condition is redundant when Gaussian elimination against the conditions
#: kept before it leaves no entry above this fraction of its largest original entry.
RANK_TOL = 1e-9


def conditions_per_facet(n: int, d: int, r: int) -> int:
    """Number R of C^r conditions across one facet (paper Eq. 22)."""
    return sum(comb(d - m + n - 1, n - 1) for m in range(r + 1))


def _shared_indices(n_shared: int, deg: int) -> np.ndarray:
    if n_shared == 1:
        return np.array([[deg]], dtype=np.int64)
    return np.asarray(multi_indices(n_shared - 1, deg))


@dataclass(frozen=True)
class Conditions:
    """The unreduced smoothness conditions in COO form, with each row's order m."""

    matrix: sp.csr_matrix  # (E*R, J*d_hat)
    order: np.ndarray  # (E*R,) the m of each row
    pairs0: np.ndarray  # (E*R0, 2) the two columns equated by each C^0 row


def build_conditions(tri, d: int, r: int) -> Conditions:
    """All C^r conditions across every interior facet of ``tri`` (unreduced)."""
    n = tri.ndim
    dhat = num_basis(n, d)
    ncols = tri.nsimplex * dhat
    facets = tri.facets
    nf = len(facets)
    if r < 0 or nf == 0:
        empty = sp.csr_matrix((0, ncols))
        return Conditions(empty, np.empty(0, dtype=np.int64), np.empty((0, 2), dtype=np.int64))
    ta, tb = facets.simplices[:, 0], facets.simplices[:, 1]
    pa, pb = facets.out_positions[:, 0], facets.out_positions[:, 1]
    simp = tri.simplices
    # Local positions of the shared (sorted) facet vertices in each simplex: (F, n).
    pos_a = np.argmax(simp[ta][:, None, :] == facets.vertices[:, :, None], axis=2)
    pos_b = np.argmax(simp[tb][:, None, :] == facets.vertices[:, :, None], axis=2)
    bsig = tri.out_vertex_coordinates()  # (F, n+1) in t_b's local order
    rows, cols, vals, orders = [], [], [], []
    pairs0 = None
    nrow = 0
    fidx = np.arange(nf)[:, None, None]
    for m in range(r + 1):
        kp = _shared_indices(n, d - m)  # (R_m, n)
        rm = len(kp)
        ridx = np.arange(rm)[None, :, None]
        ka = np.zeros((nf, rm, n + 1), dtype=np.int64)
        ka[fidx, ridx, pos_a[:, None, :]] = kp[None]
        ka[np.arange(nf)[:, None], np.arange(rm)[None, :], pa[:, None]] = m
        kb = np.zeros((nf, rm, n + 1), dtype=np.int64)
        kb[fidx, ridx, pos_b[:, None, :]] = kp[None]
        gam = np.asarray(multi_indices(n, m))  # (G_m, n+1) in t_b's local order
        kbg = kb[:, :, None, :] + gam[None, None]  # (F, R_m, G_m, n+1)
        col_a = ta[:, None] * dhat + multi_index_lookup(ka, d)  # (F, R_m)
        col_b = tb[:, None, None] * dhat + multi_index_lookup(kbg, d)  # (F, R_m, G_m)
        coef = basis_values(bsig, m)  # (F, G_m)
        row_id = nrow + np.arange(nf * rm).reshape(nf, rm)
        gm = gam.shape[0]
        rows += [row_id.ravel(), np.repeat(row_id.ravel(), gm)]
        cols += [col_a.ravel(), col_b.ravel()]
        vals += [np.ones(nf * rm), -np.broadcast_to(coef[:, None, :], (nf, rm, gm)).ravel()]
        orders.append(np.full(nf * rm, m, dtype=np.int64))
        if m == 0:
            pairs0 = np.stack([col_a.ravel(), col_b[:, :, 0].ravel()], axis=1)
        nrow += nf * rm
    mat = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
        shape=(nrow, ncols),
    )
    return Conditions(mat, np.concatenate(orders), pairs0)


@dataclass(frozen=True)
class SmoothnessSystem:
    """The reduced smoothness system, in full and in C^0-reduced coordinates.

    Attributes
    ----------
    H : scipy.sparse.csr_matrix, shape (R*, J*d_hat)
        Full-row-rank smoothness matrix: a subset of the rows of ``H_full``.
    H_full : scipy.sparse.csr_matrix, shape (E*R, J*d_hat)
        All conditions of Eq. 20-22 (rank deficient in general).
    kept : ndarray of int
        Rows of ``H_full`` that make up ``H``.
    gather : ndarray of int, shape (J*d_hat,)
        Global coefficient id of every local coefficient after the C^0 conditions (local
        coefficients equated by C^0 share an id): ``c = g[gather]``.
    nglobal : int
        Number of C^0-reduced coefficients M.
    A : scipy.sparse.csr_matrix, shape (K, M)
        The kept conditions of order >= 1 in C^0-reduced coordinates (full row rank).
    """

    H: sp.csr_matrix
    H_full: sp.csr_matrix
    kept: np.ndarray
    gather: np.ndarray
    nglobal: int
    A: sp.csr_matrix

    @property
    def rank(self) -> int:
        """Rank of H_full (= number of rows of H)."""
        return self.H.shape[0]


def reduce_rows(cond: Conditions, ncols: int) -> SmoothnessSystem:
    """Remove redundant rows of the smoothness matrix (paper Eq. 25)."""
    order = cond.order
    rows0 = np.nonzero(order == 0)[0]
    # C^0: coefficient equalities. A spanning forest of the equality graph keeps an
    # independent set that implies all others; its components are the global coefficients.
    if len(rows0):
        a, b = cond.pairs0[:, 0], cond.pairs0[:, 1]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        graph = sp.csr_matrix((rows0 + 1.0, (lo, hi)), shape=(ncols, ncols))
        forest = minimum_spanning_tree(graph).tocoo()
        kept0 = np.sort(forest.data.astype(np.int64) - 1)
        nglobal, gather = connected_components(graph, directed=False)
    else:
        kept0 = np.empty(0, dtype=np.int64)
        nglobal, gather = ncols, np.arange(ncols)
    gather = gather.astype(np.int64)
    rows_hi = np.nonzero(order > 0)[0]
    if len(rows_hi):
        Hhi = cond.matrix[rows_hi]
        G = sp.csr_matrix((np.ones(ncols), (np.arange(ncols), gather)), shape=(ncols, nglobal))
        A_all = (Hhi @ G).tocsr()
        A_all.sum_duplicates()
        A_all.eliminate_zeros()
        keep_hi = _independent_rows(A_all)
        kept_hi = rows_hi[keep_hi]
        A = A_all[keep_hi]
    else:
        kept_hi = np.empty(0, dtype=np.int64)
        A = sp.csr_matrix((0, nglobal))
    kept = np.sort(np.concatenate([kept0, kept_hi]))
    return SmoothnessSystem(
        H=cond.matrix[kept],
        H_full=cond.matrix,
        kept=kept,
        gather=gather,
        nglobal=int(nglobal),
        A=A.tocsr(),
    )


def _independent_rows(A: sp.csr_matrix) -> np.ndarray:
    """Indices of a maximal set of linearly independent rows, chosen greedily in order.

    Sparse Gaussian elimination: each incoming row is reduced against the pivot rows kept
    so far (in the order the pivots were created, so the sweep terminates); if nothing
    above ``RANK_TOL`` times its largest entry remains, it is redundant, otherwise its
    largest remaining entry becomes a new pivot.
    """
    indptr, indices, data = A.indptr, A.indices, A.data
    pivot_of_col: dict[int, int] = {}  # column -> pivot number
    pivots: list[tuple[int, dict[int, float]]] = []  # (pivot column, row as dict)
    keep = []
    for i in range(A.shape[0]):
        sl = slice(indptr[i], indptr[i + 1])
        row = dict(zip(indices[sl].tolist(), data[sl].tolist()))
        if not row:
            continue
        scale = max(abs(v) for v in row.values())
        heap = [pivot_of_col[c] for c in row if c in pivot_of_col]
        heapq.heapify(heap)
        seen = set(heap)
        while heap:
            k = heapq.heappop(heap)
            pcol, prow = pivots[k]
            f = row.get(pcol)
            if f is None or f == 0.0:
                continue
            factor = f / prow[pcol]
            for c, v in prow.items():
                nv = row.get(c, 0.0) - factor * v
                row[c] = nv
                if c != pcol:
                    kk = pivot_of_col.get(c)
                    if kk is not None and kk not in seen:
                        seen.add(kk)
                        heapq.heappush(heap, kk)
            row.pop(pcol, None)
        if not row or max(abs(v) for v in row.values()) <= RANK_TOL * scale:
            continue
        pcol = max(row, key=lambda c: abs(row[c]))
        pivot_of_col[pcol] = len(pivots)
        pivots.append((pcol, row))
        keep.append(i)
    return np.asarray(keep, dtype=np.int64)


def smoothness_matrix(tri, d: int, r: int, reduce: bool = True) -> sp.csr_matrix:
    """The smoothness matrix H of C^r continuity for degree-d splines on ``tri``.

    Parameters
    ----------
    tri : Triangulation
    d : int
        Degree, ``d >= 0``.
    r : int
        Continuity order, ``-1 <= r < d`` (``-1``: no conditions).
    reduce : bool, default True
        Remove redundant rows so that H has full row rank (paper Eq. 25).

    Returns
    -------
    scipy.sparse.csr_matrix, shape (R*, J*d_hat)
        Column ``j*d_hat + k`` is B-coefficient ``k`` (Eq. 11 order) of simplex ``j``
        (Eq. 24). ``H @ c == 0`` iff the spline with coefficients ``c`` is C^r.
    """
    from simplexspline.spline.validation import check_degree

    d, r = check_degree(d, r)
    cond = build_conditions(tri, d, r)
    if not reduce:
        return cond.matrix
    return reduce_rows(cond, tri.nsimplex * num_basis(tri.ndim, d)).H
