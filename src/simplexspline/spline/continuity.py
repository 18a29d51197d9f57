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
from functools import cached_property
from math import comb

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

from simplexspline.spline.bform import basis_values, multi_index_lookup, multi_indices, num_basis
from simplexspline.spline.inputs import check_degree

__all__ = [
    "SmoothnessSystem",
    "build_conditions",
    "cell_facets",
    "conditions_per_facet",
    "plane_facets",
    "smoothness_matrix",
]

#: A higher-order condition is redundant when Gaussian elimination against the conditions
#: kept before it leaves no entry above this fraction of its largest original entry.
RANK_TOL = 1e-9


def conditions_per_facet(n: int, d: int, r: int) -> int:
    """Number R of C^r conditions across one facet (paper Eq. 22)."""
    return sum(comb(d - m + n - 1, n - 1) for m in range(r + 1))


def cell_facets(tri) -> np.ndarray:
    """Which interior facets lie inside the cells of a grid triangulation.

    A facet of a Kuhn (Freudenthal) grid triangulation either lies on a grid plane (all
    its vertices share one coordinate) or cuts through a cell (no coordinate is shared).

    Returns
    -------
    ndarray of bool, shape (F,)
        True for the facets inside cells (``triangulation.facets`` order). Meaningful for
        grid triangulations only (:meth:`Triangulation.grid`, :meth:`Triangulation.fit`).
    """
    fv = np.asarray(tri.vertices)[tri.facets.vertices]                   # (F, n, n)
    if not len(fv):
        return np.zeros(0, dtype=bool)
    span = fv.max(axis=1) - fv.min(axis=1)                              # (F, n)
    scale = np.ptp(np.asarray(tri.vertices), axis=0)
    return ~np.any(span <= 1e-12 * np.where(scale > 0, scale, 1.0), axis=1)


def plane_facets(tri, axis: int, values, tol: float = 1e-9) -> np.ndarray:
    """Which interior facets lie in one of the hyperplanes ``x[axis] = value``.

    Returns
    -------
    ndarray of bool, shape (F,)
        True for facets all of whose vertices have coordinate ``axis`` within ``tol``
        of one of ``values``.
    """
    values = np.atleast_1d(np.asarray(values, dtype=float))
    fv = np.asarray(tri.vertices)[tri.facets.vertices][:, :, axis]       # (F, n)
    if not len(fv) or not len(values):
        return np.zeros(len(fv), dtype=bool)
    flat = np.ptp(fv, axis=1) <= tol
    return flat & np.any(np.abs(fv[:, :1] - values[None, :]) <= tol, axis=1)


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
    facet: np.ndarray = None  # (E*R,) the interior facet (tri.facets index) of each row


def build_conditions(tri, d: int, r: int, facet_orders=None, out_points=None) -> Conditions:
    """All C^r conditions across every interior facet of ``tri`` (unreduced).

    ``facet_orders`` (shape (F,), optional) gives each interior facet its own continuity
    order instead (-1..d; d: the two pieces are one polynomial); ``r`` is then unused.

    ``out_points`` (shape (F, n), optional) replaces the out-of-facet vertex sigma of
    ``facets.simplices[:, 0]`` in the conditions by another point ``S(sigma)``, for maps
    ``S`` that are affine and fix the facet (a stretch across it): the conditions then join
    ``p_a`` to ``p_b o S`` instead of ``p_b`` (smoothness in coordinates that are
    stretched differently on the two sides, e.g. a piecewise-linear variable scaling).
    """
    n = tri.ndim
    dhat = num_basis(n, d)
    ncols = tri.nsimplex * dhat
    facets = tri.facets
    orders_f = np.full(len(facets), r, dtype=np.int64) if facet_orders is None else \
        np.asarray(facet_orders, dtype=np.int64)
    sel = np.nonzero(orders_f >= 0)[0]
    nf = len(sel)
    if nf == 0:
        empty = sp.csr_matrix((0, ncols))
        return Conditions(empty, np.empty(0, dtype=np.int64), np.empty((0, 2), dtype=np.int64),
                          np.empty(0, dtype=np.int64))
    ta, tb = facets.simplices[sel, 0], facets.simplices[sel, 1]
    pa = facets.out_positions[sel, 0]
    fverts = facets.vertices[sel]
    orders_f = orders_f[sel]
    simp = tri.simplices
    # Local positions of the shared (sorted) facet vertices in each simplex: (F, n).
    pos_a = np.argmax(simp[ta][:, None, :] == fverts[:, :, None], axis=2)
    pos_b = np.argmax(simp[tb][:, None, :] == fverts[:, :, None], axis=2)
    if out_points is None:
        bsig_all = tri.out_vertex_coordinates()[sel]  # (F, n+1) in t_b's local order
    else:
        bsig_all = tri.barycentric(np.asarray(out_points, dtype=float)[sel], tb)
    rows, cols, vals, orders, facet_of = [], [], [], [], []
    pairs0 = np.empty((0, 2), dtype=np.int64)
    nrow = 0
    for m in range(int(orders_f.max()) + 1):
        on = orders_f >= m       # the facets with conditions of this order
        nf = int(on.sum())
        fidx = np.arange(nf)[:, None, None]
        ta_m, tb_m, pa_m, bsig = ta[on], tb[on], pa[on], bsig_all[on]
        pos_am, pos_bm = pos_a[on], pos_b[on]
        kp = _shared_indices(n, d - m)  # (R_m, n)
        rm = len(kp)
        ridx = np.arange(rm)[None, :, None]
        ka = np.zeros((nf, rm, n + 1), dtype=np.int64)
        ka[fidx, ridx, pos_am[:, None, :]] = kp[None]
        ka[np.arange(nf)[:, None], np.arange(rm)[None, :], pa_m[:, None]] = m
        kb = np.zeros((nf, rm, n + 1), dtype=np.int64)
        kb[fidx, ridx, pos_bm[:, None, :]] = kp[None]
        gam = np.asarray(multi_indices(n, m))  # (G_m, n+1) in t_b's local order
        kbg = kb[:, :, None, :] + gam[None, None]  # (F, R_m, G_m, n+1)
        col_a = ta_m[:, None] * dhat + multi_index_lookup(ka, d)  # (F, R_m)
        col_b = tb_m[:, None, None] * dhat + multi_index_lookup(kbg, d)  # (F, R_m, G_m)
        coef = basis_values(bsig, m)  # (F, G_m)
        row_id = nrow + np.arange(nf * rm).reshape(nf, rm)
        gm = gam.shape[0]
        rows += [row_id.ravel(), np.repeat(row_id.ravel(), gm)]
        cols += [col_a.ravel(), col_b.ravel()]
        vals += [np.ones(nf * rm), -np.broadcast_to(coef[:, None, :], (nf, rm, gm)).ravel()]
        orders.append(np.full(nf * rm, m, dtype=np.int64))
        facet_of.append(np.repeat(sel[on], rm))
        if m == 0:
            pairs0 = np.stack([col_a.ravel(), col_b[:, :, 0].ravel()], axis=1)
        nrow += nf * rm
    mat = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
        shape=(nrow, ncols),
    )
    return Conditions(mat, np.concatenate(orders), pairs0, np.concatenate(facet_of))


class SmoothnessSystem:
    """The smoothness conditions of a spline space, in full and C^0-reduced coordinates.

    The C^0 conditions equate pairs of coefficients; eliminating them exactly leaves M
    global coefficients ``g`` with ``c = g[gather]``. Fitting needs only that and the
    higher-order conditions in those coordinates (``A_all``, possibly redundant); the
    full-row-rank ``H`` of Eq. 25 is computed on first access.

    Attributes
    ----------
    H_full : scipy.sparse.csr_matrix, shape (E*R, J*d_hat)
        All conditions of Eq. 20-22 (rank deficient in general).
    gather : ndarray of int, shape (J*d_hat,)
        Global coefficient id of every local coefficient.
    nglobal : int
        Number M of C^0-reduced coefficients.
    A_all : scipy.sparse.csr_matrix, shape (E*(R-R_0), M)
        The conditions of order >= 1 in C^0-reduced coordinates (may be redundant).
    """

    def __init__(self, cond: Conditions, ncols: int):
        #: Data-independent work of the solver (B-net points, sparse Cholesky ordering),
        #: kept between fits on this space.
        self.solver_cache: dict = {}
        self.H_full = cond.matrix
        order = cond.order
        rows0 = np.nonzero(order == 0)[0]
        if len(rows0):
            a, b = cond.pairs0[:, 0], cond.pairs0[:, 1]
            lo, hi = np.minimum(a, b), np.maximum(a, b)
            graph = sp.csr_matrix((rows0 + 1.0, (lo, hi)), shape=(ncols, ncols))
            # A spanning forest of the equality graph is an independent set implying all
            # C^0 rows; its connected components are the global coefficients.
            forest = minimum_spanning_tree(graph).tocoo()
            self._kept0 = np.sort(forest.data.astype(np.int64) - 1)
            nglobal, gather = connected_components(graph, directed=False)
        else:
            self._kept0 = np.empty(0, dtype=np.int64)
            nglobal, gather = ncols, np.arange(ncols)
        self.gather = gather.astype(np.int64)
        self.nglobal = int(nglobal)
        self._rows_hi = np.nonzero(order > 0)[0]
        if len(self._rows_hi):
            G = sp.csr_matrix((np.ones(ncols), (np.arange(ncols), self.gather)),
                              shape=(ncols, self.nglobal))
            A_all = (cond.matrix[self._rows_hi] @ G).tocsr()
            A_all.sum_duplicates()
            A_all.eliminate_zeros()
        else:
            A_all = sp.csr_matrix((0, self.nglobal))
        self.A_all = A_all

    @cached_property
    def kept(self) -> np.ndarray:
        """Rows of ``H_full`` forming an independent set that spans all of them."""
        keep_hi = self._rows_hi[independent_rows(self.A_all)]
        return np.sort(np.concatenate([self._kept0, keep_hi]))

    @property
    def H(self) -> sp.csr_matrix:
        """Full-row-rank smoothness matrix (Eq. 25): the rows ``kept`` of ``H_full``."""
        return self.H_full[self.kept]

    @property
    def rank(self) -> int:
        """Rank of H_full (= number of rows of H)."""
        return len(self.kept)


def reduce_rows(cond: Conditions, ncols: int) -> SmoothnessSystem:
    """The smoothness system with redundant rows identified (paper Eq. 25)."""
    return SmoothnessSystem(cond, ncols)


#: Up to this many columns, redundant higher-order rows are found by a dense QR with
#: column pivoting of A'; beyond, by sparse Gaussian elimination.
DENSE_QR_LIMIT = 4000


def independent_rows(A: sp.csr_matrix) -> np.ndarray:
    """Indices of a maximal set of linearly independent rows of a sparse matrix."""
    if A.shape[0] == 0:
        return np.empty(0, dtype=np.int64)
    used = np.unique(A.indices)
    if len(used) <= DENSE_QR_LIMIT and A.shape[0] <= 4 * DENSE_QR_LIMIT:
        from scipy.linalg import qr

        dense = A[:, used].toarray().T  # columns are the rows of A
        _, R, piv = qr(dense, mode="economic", pivoting=True)
        diag = np.abs(np.diag(R))
        rank = int((diag > RANK_TOL * diag[0]).sum()) if len(diag) else 0
        return np.sort(piv[:rank]).astype(np.int64)
    return _independent_rows_sparse(A)


def _independent_rows_sparse(A: sp.csr_matrix) -> np.ndarray:
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
    d, r = check_degree(d, r)
    cond = build_conditions(tri, d, r)
    if not reduce:
        return cond.matrix
    return SmoothnessSystem(cond, tri.nsimplex * num_basis(tri.ndim, d)).H
