"""Varying-coefficient simplex splines: ``f(z, m) = sum_k m_k s_k(z)``.

Aerodynamic databases (and the physics behind them) are mostly linear in the control
surface deflections and the non-dimensional rates, with coefficients that vary over the
flight envelope: ``Cl = Cl_0(alpha, beta, M) + Cl_p(alpha, ...) phat + Cl_da(alpha, ...) da +
...``. A varying-coefficient spline fits exactly this form: K splines ``s_k`` of one space
S^r_d(T) over the *scheduling* variables ``z`` (n of them), multiplied by K known
*multipliers* ``m_k`` (``1``, ``phat``, ``da``, ...). Each ``s_k`` is a C^r simplex spline;
the model is linear in all their B-coefficients, so the fit is again an
equality-constrained least-squares problem.

A point in simplex t touches only the coefficients of simplex t of every term: its
regression row is ``kron(m, B(b))`` (K * d_hat values), so X'WX stays block diagonal with
J blocks of (K d_hat) x (K d_hat). The blocks are accumulated chunk by chunk exactly like
:class:`~simplexspline.spline.fit.normal_equations.NormalEquations` (never the dense N x (J K d_hat)
matrix), and the constrained solver, the ridge and the smoothing penalties with GCV of the
plain splines apply unchanged, on K copies of the continuity conditions.

Coefficient order: ``coefficients[t, k, :]`` are the B-coefficients (Eq. 11 order) of term
k on simplex t; flattened per simplex as ``(k, kappa)``.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse as sp

from simplexspline.errors import InputError
from simplexspline.spline import kernels
from simplexspline.spline.geometry.barycentric import direction_coordinates
from simplexspline.spline.bform import (
    basis_values_t,
    multi_index_lookup,
    multi_indices,
    num_basis,
)
from simplexspline.spline.fit.normal_equations import BlockSums
from simplexspline.spline.continuity import build_conditions
from simplexspline.spline.fit.constrained import global_points, solve_constrained
from simplexspline.spline.fit.penalty import penalty_blocks
from simplexspline.spline.formats.model_file import ModelRecord, read_model, save_spline
from simplexspline.spline.geometry.outside import locate, located_data
from simplexspline.spline.inputs import as_points, as_values, as_weights
from simplexspline.spline.space import SimplexSpline
from simplexspline.spline.fit.penalty import solve_penalized

__all__ = ["TermGrams", "VaryingCoefficientSpace", "VaryingNormalEquations",
           "VaryingCoefficientSpline", "constancy_conditions"]

#: Points per chunk when accumulating (bounds the (K d_hat) x chunk temporary).
CHUNK = 1 << 16


def _multipliers(m, npts: int, nterms: int) -> np.ndarray:
    """Validated multipliers, shape (N, K) float."""
    arr = np.asarray(m, dtype=float)
    if arr.ndim == 1 and nterms == 1:
        arr = arr[:, None]
    if arr.shape != (npts, nterms):
        raise InputError(f"multipliers must have shape ({npts}, {nterms}) (one column per "
                         f"term), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.nonzero(~np.all(np.isfinite(arr), axis=1))[0]
        raise InputError(f"{len(bad)} multiplier row(s) hold NaN or inf (first rows "
                         f"{bad[:5].tolist()}): drop or fill them")
    return arr


def constancy_conditions(space, dims) -> sp.coo_matrix:
    """Conditions that make a spline of ``space`` constant along the coordinate axes
    ``dims``: in every simplex its first derivative along each such axis vanishes (the
    de Casteljau differences of its B-coefficients in that direction are zero).

    Returns
    -------
    scipy.sparse.coo_matrix, shape (J * len(dims) * C(d - 1 + n, n), J * d_hat)
        Rows on the coefficient vector in Eq. 24 order (simplex-major). Together with the
        continuity conditions the spline then does not depend on those variables.
    """
    tri = space.triangulation
    n, d, dhat = tri.ndim, space.degree, space.nbasis
    J = tri.nsimplex
    dims = [int(e) for e in dims]
    if d == 0 or not dims:
        return sp.coo_matrix((0, J * dhat))
    low = multi_indices(n, d - 1)                                      # (L, n+1)
    local = multi_index_lookup(low[:, None, :] + np.eye(n + 1, dtype=np.int64)[None], d)
    L = len(low)
    lam = direction_coordinates(tri._tinv)                              # (J, n, n+1)
    rows, cols, vals = [], [], []
    for q, e in enumerate(dims):
        a = lam[:, e, :]                                                 # (J, n+1)
        r = (np.arange(J)[:, None, None] * len(dims) + q) * L + np.arange(L)[None, :, None]
        rows.append(np.broadcast_to(r, (J, L, n + 1)).ravel())
        cols.append((np.arange(J)[:, None, None] * dhat + local[None]).ravel())
        vals.append(np.broadcast_to(a[:, None, :], (J, L, n + 1)).ravel())
    return sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(J * len(dims) * L, J * dhat))


class _TermSystem:
    """The continuity conditions of K copies of one space, in the layout the constrained
    solver expects (``gather``, ``nglobal``, ``A_all``, ``H_full``, ``solver_cache``), for
    coefficients ordered (simplex, term, basis); plus, for terms that depend on fewer
    variables, the conditions that keep them constant along the others."""

    def __init__(self, space, nterms: int, excluded=None, facets=None):

        base = space.system
        tri = space.triangulation
        J, dhat, K = tri.nsimplex, space.nbasis, nterms
        M = base.nglobal
        g = base.gather.reshape(J, 1, dhat)
        self.gather = (np.arange(K)[None, :, None] * M + g).reshape(-1).astype(np.int64)
        self.nglobal = K * M

        def per_term(mat: sp.coo_matrix, k: int):
            """Rows on one term's coefficients (simplex-major) -> rows on all of them."""
            t, i = mat.col // dhat, mat.col % dhat
            return mat.row, t * K * dhat + k * dhat + i, mat.data

        blocks = [(base.H_full.tocoo(), k) for k in range(K)]
        for k, dims in enumerate(excluded or [()] * K):
            if len(dims):
                blocks.append((constancy_conditions(space, dims), k))
        base_orders = space.facet_continuity if space.facet_continuity is not None else \
            np.full(len(tri.facets), space.continuity)
        for k, join in enumerate(facets or [None] * K):
            mask, points = join if isinstance(join, tuple) else (join, None)
            if mask is not None and np.any(mask & (base_orders < space.degree)):
                # one polynomial across these facets: the orders the space lacks there
                cond = build_conditions(tri, space.degree, -1,
                                        np.where(mask, space.degree, -1), points)
                rows = np.nonzero(cond.order > base_orders[cond.facet])[0]
                blocks.append((cond.matrix[rows].tocoo(), k))
        rows, cols, vals, off = [], [], [], 0
        for mat, k in blocks:
            r, c, v = per_term(mat, k)
            rows.append(r + off)
            cols.append(c)
            vals.append(v)
            off += mat.shape[0]
        self.H_full = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                            np.concatenate(cols))),
                                    shape=(off, J * K * dhat))
        A = sp.block_diag([base.A_all] * K, format="csr") if base.A_all.shape[0] \
            else sp.csr_matrix((0, K * M))
        extra = self.H_full[K * base.H_full.shape[0]:].tocoo()
        if extra.shape[0]:   # the constancy conditions in the C^0-reduced coordinates
            Ae = sp.csr_matrix((extra.data, (extra.row, self.gather[extra.col])),
                               shape=(extra.shape[0], K * M))
            Ae.sum_duplicates()
            A = sp.vstack([A, Ae]).tocsr()
        self.A_all = A
        pts = global_points(tri, space.degree, base.gather, M)
        self.solver_cache: dict = {"points": np.tile(pts, (K, 1))}


class VaryingNormalEquations(BlockSums):
    """Per-simplex normal-equation blocks of a varying-coefficient fit.

    Attributes
    ----------
    XtWX : ndarray, shape (J, K*d_hat, K*d_hat)
    XtWy : ndarray, shape (J, K*d_hat)
    ytWy : float
    wsum : ndarray, shape (J,)
    counts : ndarray of int, shape (J,)

    Accumulators of one space add (``a + b``, ``a.merge(b)``), so chunks, Parquet row groups
    or partitions can be accumulated separately.
    """

    def __init__(self, triangulation, degree: int, nterms: int):  # noqa: D107
        self.triangulation = triangulation
        self.degree = int(degree)
        self.nterms = int(nterms)
        J = triangulation.nsimplex
        width = self.nterms * num_basis(triangulation.ndim, self.degree)
        self.XtWX = np.zeros((J, width, width))
        self.XtWy = np.zeros((J, width))
        self.ytWy = 0.0
        self.wsum = np.zeros(J)
        self.counts = np.zeros(J, dtype=np.int64)

    def add(self, z, m, y, weights=None) -> VaryingNormalEquations:
        """Accumulate a chunk in place.

        Parameters
        ----------
        z : array_like, shape (N, n)
            Scheduling variables; all points must lie inside the triangulation.
        m : array_like, shape (N, K)
            Multipliers (a column of ones for a constant term).
        y : array_like, shape (N,)
        weights : array_like, shape (N,), optional
            Non-negative weights (inverse noise variances).

        Raises
        ------
        OutsideDomainError
            Points outside the triangulation (nothing is accumulated).
        """
        tri = self.triangulation
        pts = as_points(z, name="z", ndim=tri.ndim)
        vals = as_values(y, len(pts))
        mult = _multipliers(m, len(pts), self.nterms)
        w = as_weights(weights, len(pts))
        sid = located_data(tri, pts)
        with kernels.one_blas_thread():
            for s in range(0, len(pts), CHUNK):
                e = s + CHUNK
                self._add_located(pts[s:e], mult[s:e], vals[s:e],
                                  None if w is None else w[s:e], sid[s:e])
        return self

    def _add_located(self, pts, mult, vals, w, sid) -> None:
        tri = self.triangulation
        J = tri.nsimplex
        order = np.argsort(sid, kind="stable")
        sid_s = sid[order]
        bt = basis_values_t(tri._locator_barycentric(pts[order], sid_s).T, self.degree)
        K = self.nterms
        rows = (mult[order].T[:, None, :] * bt[None, :, :]).reshape(K * bt.shape[0], -1)
        ys = vals[order]
        ws = None if w is None else w[order]
        wy = ys if ws is None else ws * ys
        counts = np.bincount(sid, minlength=J)
        self.counts += counts
        self.wsum += counts if ws is None else np.bincount(sid_s, weights=ws, minlength=J)
        self.ytWy += float(wy @ ys)
        ends = np.cumsum(counts)
        for j in np.nonzero(counts)[0]:
            a, b = ends[j] - counts[j], ends[j]
            rj = rows[:, a:b]
            rw = rj if ws is None else rj * ws[a:b]
            self.XtWX[j] += rw @ rj.T
            self.XtWy[j] += rj @ wy[a:b]

    def check_space(self, triangulation, degree: int, nterms: int | None = None) -> None:
        """Raise InputError unless these blocks belong to this triangulation, degree and
        number of terms."""
        nterms = self.nterms if nterms is None else nterms
        if degree != self.degree or nterms != self.nterms:
            raise InputError(f"normal equations of degree {self.degree} with {self.nterms} "
                             f"terms do not match a space of degree {degree} with {nterms}")
        if not self.triangulation.same_as(triangulation):
            raise InputError("the normal equations were accumulated on a different "
                             "triangulation than this space's")

    def _space_key(self) -> tuple:
        return self.triangulation, self.degree, self.nterms


class TermGrams:
    """Normal-equation blocks of varying-coefficient fits on one fixed sample, kept per
    pair of terms: the normal equations of any set of terms are assembled from them.

    The regression row of a point is ``kron(m, B(b))``, so block (k, l) of a simplex's
    Gram matrix, ``sum_i w_i m_ik m_il B(b_i) B(b_i)'``, depends only on the terms k and
    l. Fits that share the triangulation, the degree and the sample (the candidate
    structures of a search that add, remove or keep multipliers) share these blocks: the
    points are located and their basis values computed once, a new term costs one product
    per simplex with the terms already known, and a set of known terms costs nothing but
    copying. The result equals :meth:`VaryingNormalEquations.add` on the same data up to
    round-off.

    Parameters
    ----------
    triangulation : Triangulation
    degree : int
    z : array_like, shape (N, n)
        Scheduling variables; all points must lie inside the triangulation.
    y : array_like, shape (N,)
    weights : array_like, shape (N,), optional

    Raises
    ------
    OutsideDomainError
        Points outside the triangulation.

    Examples
    --------
    >>> import numpy as np
    >>> from simplexspline import Triangulation
    >>> rng = np.random.default_rng(0)
    >>> z, u = rng.random((500, 1)), rng.normal(size=500)
    >>> grams = TermGrams(Triangulation.grid([0], [1], (2,)), 2, z, np.sin(z[:, 0]) + u)
    >>> ne = grams.normal_equations([("1", np.ones(500)), ("u", u)])
    >>> ref = VaryingNormalEquations(grams.triangulation, 2, 2).add(
    ...     z, np.column_stack([np.ones(500), u]), np.sin(z[:, 0]) + u)
    >>> bool(np.allclose(ne.XtWX, ref.XtWX, rtol=1e-12, atol=0))
    True
    """

    def __init__(self, triangulation, degree: int, z, y, weights=None):
        self.triangulation = triangulation
        self.degree = int(degree)
        pts = as_points(z, name="z", ndim=triangulation.ndim)
        vals = as_values(y, len(pts))
        w = as_weights(weights, len(pts))
        sid = located_data(triangulation, pts)
        #: Sample order sorted by simplex (stable), shape (N,).
        self.order = np.argsort(sid, kind="stable")
        sid_s = sid[self.order]
        J = triangulation.nsimplex
        self._basis = basis_values_t(
            triangulation._locator_barycentric(pts[self.order], sid_s).T, self.degree)
        self._w = None if w is None else w[self.order]
        ys = vals[self.order]
        self._wy = ys if self._w is None else self._w * ys
        self.counts = np.bincount(sid, minlength=J)
        self.wsum = self.counts.astype(float) if self._w is None else \
            np.bincount(sid_s, weights=self._w, minlength=J)
        self.ytWy = float(self._wy @ ys)
        ends = np.cumsum(self.counts)
        self._spans = [(int(j), int(ends[j] - self.counts[j]), int(ends[j]))
                       for j in np.nonzero(self.counts)[0]]
        self._pairs: dict = {}      # (key_k, key_l) -> (J, d_hat, d_hat)
        self._rhs: dict = {}        # key -> (J, d_hat)
        self._columns: dict = {}    # key -> the term's column in sorted order

    def __len__(self) -> int:
        return len(self.order)

    @property
    def nbytes(self) -> int:
        """Memory taken by the located basis values, the columns and the kept blocks."""
        seen, size = set(), self._basis.nbytes + self.order.nbytes
        for arr in (*self._pairs.values(), *self._rhs.values(), *self._columns.values()):
            base = arr.base if arr.base is not None else arr
            if id(base) not in seen:
                seen.add(id(base))
                size += base.nbytes
        return size

    def _add_terms(self, new: list) -> None:
        """Blocks of new terms ``[(key, column), ...]`` with themselves and with every
        known term: one product per simplex."""
        cols = []
        for key, column in new:
            col = np.asarray(column, dtype=float)
            if col.shape != (len(self),) or not np.all(np.isfinite(col)):
                raise InputError(f"term {key!r}: its column must hold {len(self)} finite "
                                 f"values, got shape {col.shape}")
            cols.append(col[self.order])
        known = list(self._columns)
        for (key, _), col in zip(new, cols):
            self._columns[key] = col
        keys = known + [k for k, _ in new]
        allc = np.stack([self._columns[k] for k in keys])            # (K_all, N)
        newc = np.stack(cols)                                         # (K_new, N)
        B, dh = self._basis, self._basis.shape[0]
        J, kn, ka = self.triangulation.nsimplex, len(cols), len(keys)
        G = np.zeros((J, kn * dh, ka * dh))
        rhs = np.zeros((J, kn * dh))
        wnew = newc if self._w is None else newc * self._w
        with kernels.one_blas_thread():
            for j, a, b in self._spans:
                Bj = B[:, a:b]
                left = (wnew[:, None, a:b] * Bj[None]).reshape(kn * dh, b - a)
                right = (allc[:, None, a:b] * Bj[None]).reshape(ka * dh, b - a)
                G[j] = left @ right.T
                rhs[j] = (newc[:, None, a:b] * Bj[None]).reshape(kn * dh, b - a) \
                    @ self._wy[a:b]
        for p, kp in enumerate(keys[len(known):]):
            rows = slice(p * dh, (p + 1) * dh)
            self._rhs[kp] = rhs[:, rows]
            for q, kq in enumerate(keys):
                blk = G[:, rows, q * dh:(q + 1) * dh]
                self._pairs[kp, kq] = blk
                if (kq, kp) not in self._pairs:
                    self._pairs[kq, kp] = blk.transpose(0, 2, 1)

    def normal_equations(self, terms) -> VaryingNormalEquations:
        """The normal equations of a set of terms.

        Parameters
        ----------
        terms : sequence of (hashable, array_like of shape (N,))
            Per term, a key and its multiplier column in the order of the sample. The key
            names the column: a key seen before reuses that term's blocks (its column is
            not read again).

        Returns
        -------
        VaryingNormalEquations
            A new accumulator (it shares no memory with these blocks).
        """
        keys = [k for k, _ in terms]
        if len(set(keys)) != len(keys):
            raise InputError(f"repeated term keys {keys}")
        new = [(k, col) for k, col in terms if k not in self._columns]
        if new:
            self._add_terms(new)
        K, dh = len(keys), self._basis.shape[0]
        ne = VaryingNormalEquations(self.triangulation, self.degree, K)
        for p, kp in enumerate(keys):
            ne.XtWy[:, p * dh:(p + 1) * dh] = self._rhs[kp]
            for q, kq in enumerate(keys):
                ne.XtWX[:, p * dh:(p + 1) * dh, q * dh:(q + 1) * dh] = self._pairs[kp, kq]
        ne.ytWy = self.ytWy
        ne.wsum = self.wsum.copy()
        ne.counts = self.counts.copy()
        return ne


class VaryingCoefficientSpace:
    """K copies of a spline space S^r_d(T), combined as ``f(z, m) = sum_k m_k s_k(z)``.

    Parameters
    ----------
    space : SplineSpace
        The space of every term (its triangulation is over the scheduling variables).
    nterms : int
        Number K of terms (multipliers), >= 1.
    term_dims : sequence of (sequence of int or None), optional
        Per term, the axes of the space it depends on (None: all). A term is held
        constant along the other axes by extra linear conditions
        (:func:`constancy_conditions`): e.g. a roll-damping term that depends on alpha
        only, in a model scheduled on alpha, beta and Mach, has far fewer free
        coefficients where the data are thin.
    term_facets : sequence of (None, bool array (F,), or (bool array (F,), array (F, n))),
        optional
        Per term, interior facets across which it is one polynomial (e.g. the grid planes
        of breakpoints a term's table does not have; see
        :func:`~simplexspline.spline.continuity.plane_facets`). With a second array of
        points, the term's pieces are joined through the stretch that maps each facet's
        out-of-facet vertex to that point (``out_points`` of
        :func:`~simplexspline.spline.continuity.build_conditions`): one polynomial in
        coordinates scaled differently on the two sides.

    Examples
    --------
    >>> import numpy as np
    >>> from simplexspline import SplineSpace, Triangulation
    >>> rng = np.random.default_rng(0)
    >>> z = rng.random((3000, 1))                      # scheduling variable
    >>> u = rng.uniform(-1, 1, 3000)                   # a control input
    >>> y = np.sin(3 * z[:, 0]) + (1 + z[:, 0] ** 2) * u
    >>> space = SplineSpace(Triangulation.grid([0], [1], (4,)), degree=3, continuity=1)
    >>> vc = VaryingCoefficientSpace(space, 2).fit(z, np.column_stack([np.ones(3000), u]), y)
    >>> bool(abs(vc.predict([[0.5]], [[1.0, 0.5]])[0] - (np.sin(1.5) + 0.5 * 1.25)) < 1e-3)
    True
    """

    def __init__(self, space, nterms: int, term_dims=None, term_facets=None):
        if isinstance(nterms, bool) or not isinstance(nterms, (int, np.integer)) or nterms < 1:
            raise InputError(f"nterms must be an integer >= 1, got {nterms!r}")
        self.space = space
        self.nterms = int(nterms)
        n = space.ndim
        if term_dims is None:
            term_dims = [None] * self.nterms
        if len(term_dims) != self.nterms:
            raise InputError(f"term_dims must give one entry per term ({self.nterms}), got "
                             f"{len(term_dims)}")
        dims = []
        for k, td in enumerate(term_dims):
            td = tuple(range(n)) if td is None else tuple(sorted({int(e) for e in td}))
            if any(not 0 <= e < n for e in td):
                raise InputError(f"term {k}: variables {list(td)} out of range for a "
                                 f"{n}-dimensional space")
            dims.append(td)
        #: Per term, the variables (axes) it depends on; constant along the others.
        self.term_dims = tuple(dims)
        nf = len(space.triangulation.facets)
        if term_facets is None:
            term_facets = [None] * self.nterms
        if len(term_facets) != self.nterms:
            raise InputError(f"term_facets must give one entry per term ({self.nterms}), "
                             f"got {len(term_facets)}")
        joins = []
        for k, tf in enumerate(term_facets):
            mask, points = tf if isinstance(tf, tuple) else (tf, None)
            if mask is not None:
                mask = np.asarray(mask)
                if mask.shape != (nf,) or mask.dtype != bool:
                    raise InputError(f"term {k}: term_facets must be None or {nf} booleans "
                                     f"(one per interior facet), got {mask.dtype} "
                                     f"{mask.shape}")
            if points is not None:
                points = np.asarray(points, dtype=float)
                if mask is None or points.shape != (nf, n) or not np.all(np.isfinite(points)):
                    raise InputError(f"term {k}: the stretched out-of-facet points must be "
                                     f"finite, shape ({nf}, {n}), with a facet mask")
            joins.append(mask if points is None else (mask, points))
        #: Per term, None or the interior facets across which it is one polynomial (a
        #: mask, or (mask, stretched out-of-facet points), see ``term_facets``).
        self.term_facets = tuple(joins)

    def __repr__(self) -> str:
        s = self.space
        return (f"VaryingCoefficientSpace({self.nterms} x S^{s.continuity}_{s.degree}, "
                f"ndim={s.ndim}, nsimplex={s.triangulation.nsimplex})")

    @property
    def triangulation(self):
        return self.space.triangulation

    @property
    def dim_coefficients(self) -> int:
        """Number of B-coefficients, J * K * d_hat."""
        return self.nterms * self.space.dim_coefficients

    @cached_property
    def system(self) -> _TermSystem:
        n = self.space.ndim
        excluded = [tuple(e for e in range(n) if e not in td) for td in self.term_dims]
        return _TermSystem(self.space, self.nterms, excluded, self.term_facets)

    def normal_equations(self, z=None, m=None, y=None, weights=None) -> VaryingNormalEquations:
        """An accumulator, optionally filled with a first chunk."""
        ne = VaryingNormalEquations(self.triangulation, self.space.degree, self.nterms)
        if z is not None:
            ne.add(z, m, y, weights)
        return ne

    def penalty_blocks(self, penalty="energy") -> np.ndarray:
        """Per-simplex penalty blocks of every term, shape (J, K*d_hat, K*d_hat): the plain
        space's blocks (:func:`~simplexspline.spline.fit.penalty.penalty_blocks`) on the
        diagonal."""
        P = penalty_blocks(self.triangulation, self.space.degree, penalty)
        J, dh, _ = P.shape
        out = np.zeros((J, self.nterms * dh, self.nterms * dh))
        for k in range(self.nterms):
            out[:, k * dh:(k + 1) * dh, k * dh:(k + 1) * dh] = P
        return out

    def solve(self, normal_equations: VaryingNormalEquations, *,
              on_insufficient: str = "raise", ridge: float | None = None, smoothing=None,
              penalty="energy") -> VaryingCoefficientSpline:
        """Solve for the B-coefficients of all terms.

        Parameters as :meth:`SplineSpace.fit`: ``on_insufficient`` ('raise', 'minnorm',
        'ridge'), ``ridge`` (relative), ``smoothing`` ('gcv' or a relative weight, one
        weight for all terms: put the multipliers on comparable scales) and ``penalty``
        (a kind, applied to every term, or blocks of shape (J, K*d_hat, K*d_hat)).
        """
        if not isinstance(normal_equations, VaryingNormalEquations):
            raise InputError("solve() takes a VaryingNormalEquations accumulator (from "
                             "VaryingCoefficientSpace.normal_equations)")
        sp_ = self.space
        normal_equations.check_space(sp_.triangulation, sp_.degree, self.nterms)
        if smoothing is None:
            coef, info = solve_constrained(normal_equations, self.system,
                                           on_insufficient=on_insufficient, ridge=ridge)
        else:
            P = self.penalty_blocks(penalty) if isinstance(penalty, str) else penalty
            coef, info = solve_penalized(normal_equations, self.system, penalty=P,
                                         smoothing=smoothing,
                                         on_insufficient=on_insufficient, ridge=ridge)
            if isinstance(penalty, str):
                info.regularization.penalty = penalty
        J, dh = sp_.triangulation.nsimplex, sp_.nbasis
        return VaryingCoefficientSpline(sp_.triangulation, sp_.degree, sp_.continuity,
                                        coef.reshape(J, self.nterms, dh), info=info)

    def fit(self, z, m, y, weights=None, **kwargs) -> VaryingCoefficientSpline:
        """Accumulate and solve in one call (keyword arguments as :meth:`solve`)."""
        return self.solve(self.normal_equations(z, m, y, weights), **kwargs)


class VaryingCoefficientSpline:
    """A fitted ``f(z, m) = sum_k m_k s_k(z)``: K simplex splines on one triangulation.

    Parameters
    ----------
    triangulation : Triangulation
    degree, continuity : int
    coefficients : array_like, shape (J, K, d_hat)
    metadata : dict, optional
    """

    def __init__(self, triangulation, degree: int, continuity: int, coefficients, *,
                 info=None, metadata: dict | None = None):
        coef = np.asarray(coefficients, dtype=float)
        if coef.ndim != 3:
            raise InputError(f"coefficients must have shape (J, K, d_hat), got {coef.shape}")
        self.terms = [SimplexSpline(triangulation, degree, continuity, coef[:, k, :])
                      for k in range(coef.shape[1])]
        self.triangulation = triangulation
        self.degree, self.continuity = self.terms[0].degree, self.terms[0].continuity
        self.coefficients = coef
        self.info = info
        self.metadata = dict(metadata or {})

    @property
    def nterms(self) -> int:
        return self.coefficients.shape[1]

    @property
    def ndim(self) -> int:
        return self.triangulation.ndim

    def __repr__(self) -> str:
        return (f"VaryingCoefficientSpline({self.nterms} x S^{self.continuity}_{self.degree}, "
                f"ndim={self.ndim}, nsimplex={self.triangulation.nsimplex})")

    def _locate(self, z, outside: str):
        pts = as_points(z, name="z", ndim=self.triangulation.ndim)
        sid, _ = locate(self.triangulation, pts, outside)
        return pts, sid

    def term_values(self, z, *, outside: str = "nan") -> np.ndarray:
        """The K term splines at the points, shape (N, K): ``s_k(z)``, which is also the
        derivative of ``f`` with respect to ``m_k``."""
        pts, sid = self._locate(z, outside)
        out = np.full((len(pts), self.nterms), np.nan)
        ok = sid >= 0
        for k, s in enumerate(self.terms):
            out[ok, k] = s.predict(pts[ok], simplices=sid[ok])
        return out

    def predict(self, z, m, *, outside: str = "nan") -> np.ndarray:
        """``f(z, m)``, shape (N,).

        Parameters
        ----------
        z : array_like, shape (N, n)
        m : array_like, shape (N, K)
        outside : {'nan', 'raise', 'extrapolate'}
            For scheduling points outside the triangulation (as :meth:`SimplexSpline.predict`).
        """
        vals = self.term_values(z, outside=outside)
        return np.einsum("nk,nk->n", vals, _multipliers(m, len(vals), self.nterms))

    def gradient(self, z, m, *, outside: str = "nan"):
        """Exact partial derivatives: ``(df/dz, df/dm)`` of shapes (N, n) and (N, K)."""
        pts, sid = self._locate(z, outside)
        mult = _multipliers(m, len(pts), self.nterms)
        gz = np.full((len(pts), self.ndim), np.nan)
        gm = np.full((len(pts), self.nterms), np.nan)
        ok = sid >= 0
        if np.any(ok):
            gz[ok] = 0.0
            for k, s in enumerate(self.terms):
                gz[ok] += mult[ok, k, None] * s.gradient(pts[ok], simplices=sid[ok])
                gm[ok, k] = s.predict(pts[ok], simplices=sid[ok])
        return gz, gm

    def save(self, path):
        """Write the model (``.json`` or ``.npz``, atomically; see docs/model-format.md)."""
        return save_spline(self, path)

    @staticmethod
    def load(path) -> VaryingCoefficientSpline:
        """Load a model file written by :meth:`save`."""
        record = read_model(path)
        if not record.varying:
            raise InputError(f"{path} holds a plain SimplexSpline, not a varying-coefficient "
                             "model: load it with SimplexSpline.load")
        return VaryingCoefficientSpline.from_record(record)

    @classmethod
    def from_record(cls, record: ModelRecord) -> VaryingCoefficientSpline:
        """The varying-coefficient spline a model file holds (read by
        :func:`~simplexspline.spline.formats.model_file.read_model`)."""
        head = record.header

        def make(tri):
            coef = np.asarray(record.coefficients, dtype=float)
            shape = (tri.nsimplex, int(head["nterms"]), int(head["nbasis"]))
            if coef.shape != shape:
                raise record.error(f"coefficients of shape {coef.shape}, expected {shape}")
            return cls(tri, head["degree"], head["continuity"], coef,
                       metadata=head.get("metadata") or {})

        return record.build(make)
