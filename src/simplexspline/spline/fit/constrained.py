"""The equality-constrained generalized least-squares estimator (paper Eq. 38-42).

    minimise (y - X c)' W (y - X c)   subject to   H c = 0.

Instead of the paper's pseudo-inverse of the dense KKT matrix (Eq. 42), the solver

1. eliminates the C^0 conditions exactly by gathering coefficients that they equate
   (``c = G g``, G a 0/1 matrix; see :mod:`simplexspline.spline.continuity`);
2. solves the remaining conditions ``A g = 0`` (order >= 1; possibly redundant, so no rank
   reduction is needed) by the method of multipliers (augmented Lagrangian): one sparse
   Cholesky factorisation of ``P = G'QG + rho A'A`` (multifrontal, nested-dissection order
   from the B-net points: :class:`~simplexspline.spline.fit.cholesky.SparseCholesky`; SuperLU
   as the fallback) and a few cheap iterations

       g_{k+1} = P^{-1} (G'q - A' nu_k),    nu_{k+1} = nu_k + rho A g_{k+1},

   which converge to the exact constrained solution (the KKT system of Eq. 40) whether or
   not A has full row rank.

The solution is unique iff no non-zero coefficient vector is both invisible to the data
(``Q c = 0``) and continuous (``H c = 0``). Such directions are found exactly from the
per-simplex null spaces of the Gram blocks and handled by the ``on_insufficient`` policy.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from simplexspline.errors import InputError, InsufficientDataError
from simplexspline.spline import kernels

from simplexspline.spline.fit.cholesky import SparseCholesky

__all__ = ["POLICIES", "SolveInfo", "kkt_passes", "solve_constrained"]

#: What to do when data and continuity leave coefficients undetermined.
POLICIES = ("raise", "minnorm", "ridge")

#: An eigenvalue of a simplex's Gram block below NULL_TOL * d_hat * machine epsilon times
#: the block's largest (or, for empty blocks, the mean diagonal) counts as a direction
#: without data: round-off level, so that badly conditioned but determined blocks (e.g.
#: weights spanning many decades) are not mistaken for undetermined ones.
NULL_TOL = 100.0

#: Default relative ridge weight for ``on_insufficient='ridge'``.
DEFAULT_RIDGE = 1e-6


@dataclass
class SolveInfo:
    """Diagnostics of a constrained solve.

    Attributes
    ----------
    counts : ndarray of int, shape (J,)
        Data points per simplex.
    deficient_simplices : ndarray of int
        Simplices whose own data do not determine their d_hat coefficients (fewer points
        than coefficients, or points in a lower-dimensional set); continuity may still
        determine them.
    undetermined_simplices : ndarray of int
        Simplices with coefficients determined neither by data nor by continuity.
    n_undetermined : int
        Dimension of the undetermined subspace.
    policy : str
        The ``on_insufficient`` policy applied.
    ridge : float
        The absolute ridge weight used (0 when none).
    rss : float
        Weighted residual sum of squares ``(y - Xc)' W (y - Xc)``.
    """

    counts: np.ndarray
    deficient_simplices: np.ndarray
    undetermined_simplices: np.ndarray
    n_undetermined: int
    policy: str
    ridge: float
    rss: float = field(default=float("nan"))


class _DeferredSolveInfo(SolveInfo):
    """A :class:`SolveInfo` whose undetermined directions are analysed on first access.

    A fit with a ridge needs no such analysis to solve (the ridge determines every
    direction), and its cost (dense SVDs of the null directions' conditions) dominated
    the structure search: 90 % of a 5-D S^1_3 cross-validation, 25 s of a 6-D Delaunay
    fit. The fields read the same as an eager ``SolveInfo``'s.
    """

    def __init__(self, analyse, **fields):
        self._deferred = {"analyse": analyse}
        super().__init__(undetermined_simplices=None, n_undetermined=None, **fields)

    def _field(name):  # noqa: N805 - builds the two deferred properties below
        def get(self):
            d = self._deferred
            if "analyse" in d:
                under, n = d.pop("analyse")()
                d.setdefault("undetermined_simplices", under)
                d.setdefault("n_undetermined", n)
            return d[name]

        def put(self, value):
            if value is not None:
                self._deferred[name] = value

        return property(get, put)

    undetermined_simplices = _field("undetermined_simplices")
    n_undetermined = _field("n_undetermined")
    del _field

    def __reduce__(self):
        # sent to another process (a fitted model from a worker) as a plain SolveInfo:
        # the analysis runs here, once, for the models that travel
        values = {f.name: getattr(self, f.name) for f in fields(SolveInfo)}
        extra = {k: v for k, v in vars(self).items() if k != "_deferred" and k not in values}
        return _plain_info, (values, extra)


def _plain_info(fields: dict, extra: dict) -> SolveInfo:
    """A :class:`SolveInfo` with ``fields`` and further attributes ``extra`` (unpickling
    a deferred one)."""
    info = SolveInfo(**fields)
    vars(info).update(extra)
    return info


def _full_rank_blocks(Q: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Cheap screen: blocks certainly of full rank (boolean, shape (J,)).

    A batched Cholesky factorisation with no small pivot: the smallest eigenvalue of a
    symmetric positive definite matrix is at most its smallest Cholesky pivot, and a block
    whose pivots are all well away from zero is treated as full rank. Blocks with fewer
    points than coefficients, failed factorisations and small pivots go to the exact
    eigen-analysis.
    """
    dhat = Q.shape[1]
    ok = counts >= dhat
    idx = np.nonzero(ok)[0]
    if len(idx) == 0:
        return ok
    diag_max = np.einsum("jkk->jk", Q[idx]).max(axis=1)
    try:
        L = np.linalg.cholesky(Q[idx])
    except np.linalg.LinAlgError:
        good = np.zeros(len(idx), dtype=bool)
        for i, j in enumerate(idx):
            try:
                Lj = np.linalg.cholesky(Q[j])
            except np.linalg.LinAlgError:
                continue
            good[i] = np.diag(Lj).min() ** 2 > 1e-6 * diag_max[i]
    else:
        piv = np.einsum("jkk->jk", L).min(axis=1) ** 2
        good = piv > 1e-6 * diag_max
    ok[idx] = good
    return ok


def _null_directions(Q: np.ndarray, counts: np.ndarray):
    """Columns (full coordinates, sparse) spanning null(Q), from the per-block null spaces.

    Returns the basis N (J*d_hat, k) and the simplices whose blocks are rank deficient.
    """
    nsimp, dhat, _ = Q.shape
    suspect = np.nonzero(~_full_rank_blocks(Q, counts))[0]
    if len(suspect) == 0:
        return sp.csc_matrix((nsimp * dhat, 0)), suspect
    lam, vec = np.linalg.eigh(Q[suspect])
    top = lam[:, -1]
    ref = np.where(top > 0, top, max(float(np.einsum("jkk->", Q)) / max(nsimp * dhat, 1),
                                     1e-300))
    null = lam <= NULL_TOL * dhat * np.finfo(float).eps * ref[:, None]
    bs, ks = np.nonzero(null)
    js = suspect[bs]
    rows = (js[:, None] * dhat + np.arange(dhat)[None, :]).ravel()
    cols = np.repeat(np.arange(len(js)), dhat)
    vals = vec[bs, :, ks].ravel()
    N = sp.csc_matrix((vals, (rows, cols)), shape=(nsimp * dhat, len(js)))
    return N, np.unique(js)


#: Screen of :func:`_undetermined`: a component whose Gram matrix C'C of conditions stays
#: positive definite after FULL_RANK_SHIFT * ||C'C||_inf is subtracted from its diagonal
#: has all singular values above sqrt(FULL_RANK_SHIFT) = 1e-5 of the largest (round-off
#: in C'C and in its Cholesky factor is ~1e-13 of ||C'C|| at these sizes), far above the
#: SVD's rank threshold of 1e-9: it has no undetermined direction, and its QR and SVD
#: are skipped.
FULL_RANK_SHIFT = 1e-10


def _clearly_full_rank(gram: np.ndarray) -> bool:
    """Whether ``gram`` (k x k, C'C of a block of conditions C) is certainly
    non-singular at the SVD's threshold (see :data:`FULL_RANK_SHIFT`): one Cholesky
    factorisation of the shifted matrix."""
    norm = float(np.abs(gram).sum(axis=1).max())  # >= the largest eigenvalue
    if not norm > 0:
        return False
    shifted = gram - FULL_RANK_SHIFT * norm * np.eye(len(gram))
    try:
        sla.cholesky(shifted, lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return False
    return True


def _undetermined(N: sp.csc_matrix, H: sp.csr_matrix) -> sp.csc_matrix:
    """Basis (full coordinates, sparse) of null(Q) intersected with null(H).

    The null directions couple only through the conditions they share, so the problem
    splits into connected components, each solved by a small dense SVD, unless one
    Cholesky factorisation of its conditions' Gram matrix already shows it of full rank
    (:func:`_clearly_full_rank`: the usual case; the 6-D Delaunay fit of the scaling sweep
    spent 16 s in the QRs and SVDs of 48 such components).
    """
    k = N.shape[1]
    if k == 0:
        return sp.csc_matrix((N.shape[0], 0))
    HN = (H @ N).tocsc()
    HN.data[np.abs(HN.data) < 1e-15] = 0.0
    HN.eliminate_zeros()
    pattern = (abs(HN).T @ abs(HN)).tocsr()
    ncomp, label = connected_components(pattern, directed=False)
    gram = (HN.T @ HN).tocsr()
    blocks = []
    for comp in range(ncomp):
        cols = np.nonzero(label == comp)[0]
        sub = HN[:, cols]
        rows = np.unique(sub.indices)
        if len(rows) == 0:
            blocks.append((cols, np.eye(len(cols))))
            continue
        if _clearly_full_rank(gram[cols][:, cols].toarray()):
            continue  # the conditions determine every direction: nothing to add
        dense = sub[rows].toarray()
        if dense.shape[0] > dense.shape[1]:
            # only V is needed: reduce the (tall) block to its triangular factor first;
            # a full SVD of a 4,350 x 498 block spent 10 s forming U
            dense = sla.qr(dense, mode="r", check_finite=False)[0][:dense.shape[1]]
        _, sv, vt = np.linalg.svd(dense, full_matrices=True)
        rank = int((sv > 1e-9 * sv[0]).sum())
        if rank < len(cols):
            blocks.append((cols, vt[rank:].T))
    if not blocks:
        return sp.csc_matrix((N.shape[0], 0))
    rows, cols, vals, off = [], [], [], 0
    for c, theta in blocks:
        r, q = np.nonzero(np.abs(theta) > 0)
        rows.append(c[r])
        cols.append(off + q)
        vals.append(theta[r, q])
        off += theta.shape[1]
    T = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(k, off))
    Z = (N @ T).tocsc()
    Z.data[np.abs(Z.data) < 1e-14] = 0.0
    Z.eliminate_zeros()
    return Z


def solve_constrained(ne, system, *, on_insufficient: str = "raise", ridge=None,
                      penalty=None):
    """Solve the constrained least-squares problem from accumulated normal equations.

    Parameters
    ----------
    ne : NormalEquations
        Accumulated per-simplex blocks.
    system : SmoothnessSystem
        Reduced continuity conditions of the spline space.
    on_insufficient : {'raise', 'minnorm', 'ridge'}
        When data and continuity leave coefficients undetermined: raise
        :class:`InsufficientDataError` (default); take the minimum-norm solution (exact:
        the undetermined directions are constrained to zero); or add a ridge penalty
        ``ridge * mean(diag X'WX) * ||c||^2`` to the whole problem.
    ridge : float, optional
        Relative ridge weight; with ``on_insufficient='ridge'`` defaults to 1e-6. Given
        with another policy, the ridge is applied regardless (regularised fit).
    penalty : ndarray, shape (J, d_hat, d_hat), optional
        Absolute per-simplex penalty blocks ``lam * P_t`` (symmetric positive
        semi-definite): ``c' blockdiag(penalty) c`` is added to the objective (see
        :mod:`simplexspline.spline.fit.penalty`). Directions it determines are not undetermined.

    Returns
    -------
    coefficients : ndarray, shape (J, d_hat)
    info : SolveInfo
    """
    if on_insufficient not in POLICIES:
        raise InputError(f"on_insufficient must be one of {POLICIES}, got {on_insufficient!r}")
    if ridge is not None and (not np.isfinite(ridge) or ridge < 0):
        raise InputError(f"ridge must be a finite number >= 0, got {ridge!r}")
    Q, q = ne.XtWX, ne.XtWy
    nsimp, dhat, _ = Q.shape
    if ne.npoints == 0 or not np.any(ne.wsum > 0):
        raise InsufficientDataError(
            "no data (or only zero weights) to fit: add data points", np.arange(nsimp),
            ne.counts)
    if penalty is not None:
        penalty = np.asarray(penalty, dtype=float)
        if penalty.shape != Q.shape or not np.all(np.isfinite(penalty)):
            raise InputError(f"penalty must be finite blocks of shape {Q.shape}, got "
                             f"{penalty.shape}")
    Qp = Q if penalty is None else Q + penalty
    # many small and medium dense problems (eigh, QR, SVD): BLAS threads only cost here;
    # on a loaded machine OpenBLAS's spinning threads made them 8-20x slower (a 272-simplex
    # Delaunay S^1_3 solve: 7.7 s threaded, 0.9 s on one thread)
    if ridge is None and on_insufficient == "ridge":
        ridge = DEFAULT_RIDGE
    with kernels.one_blas_thread():
        N, deficient = _null_directions(Q, ne.counts)
        if penalty is not None:
            N, _ = _null_directions(Qp, ne.counts)
    H = system.H_full

    def analyse():
        """The undetermined directions (a basis, sparse) and their simplices."""
        with kernels.one_blas_thread():
            Z = _undetermined(N, H)
        return Z, np.unique(Z.indices // dhat)

    if ridge:            # the ridge determines every direction: analysed only if asked
        Zu, under = None, None
    else:
        Zu, under = analyse()
    if not ridge and Zu.shape[1] and on_insufficient == "raise":
        raise InsufficientDataError(
            f"the data do not determine the spline on {len(under)} simplices "
            f"{_listing(under, ne.counts)}: {Zu.shape[1]} coefficient directions have no "
            "data and no continuity link to data. Add data there, coarsen the "
            "triangulation, lower the degree, or fit with on_insufficient='minnorm' "
            "(minimum-norm coefficients) or 'ridge' (small regularisation)",
            under,
            ne.counts[under],
        )
    diag_mean = float(np.einsum("jkk->", Q) / max(int((ne.counts > 0).sum()) * dhat, 1))
    lam = float(ridge or 0.0) * diag_mean
    gather, M = system.gather, system.nglobal
    if M == nsimp * dhat and system.A_all.shape[0] == 0 and (Zu is None or lam
                                                             or Zu.shape[1] == 0):
        # No continuity (r = -1): independent dense blocks, solved directly.
        coef = _solve_blocks(Qp + lam * np.eye(dhat), q)
        return coef, _info(ne, coef, deficient, under, Zu, on_insufficient, lam, analyse)
    # G'QG and G'q, assembled sparse from the blocks.
    Qg = _assemble_gram(Qp, gather, M, getattr(system, "solver_cache", None))
    qg = np.bincount(gather, weights=q.ravel(), minlength=M)
    if lam > 0:
        mult = np.bincount(gather, minlength=M).astype(float)
        Qg = Qg + sp.diags(lam * mult)
    A = system.A_all
    if Zu is not None and not lam and Zu.shape[1] and on_insufficient == "minnorm":
        # Minimum norm: the undetermined directions (which lie in range(G)) are set to zero.
        G = sp.csr_matrix((np.ones(len(gather)), (np.arange(len(gather)), gather)),
                          shape=(len(gather), M))
        ZG = (Zu.T.tocsr() @ G).tocsr()
        A = sp.vstack([A, ZG]).tocsr()
    cache = getattr(system, "solver_cache", None)
    coords = cache.get("points") if cache is not None else None
    if coords is None:
        coords = global_points(ne.triangulation, ne.degree, gather, M)
        if cache is not None:
            cache["points"] = coords
    g = _al_solve(Qg.tocsc(), qg, A, diag_mean, coords,
                  cache.setdefault("cholesky", {}) if cache is not None else None, ridge=lam,
                  null_cache=cache.setdefault("null_space", {}) if cache is not None else None)
    coef = g[gather].reshape(nsimp, dhat)
    return coef, _info(ne, coef, deficient, under, Zu, on_insufficient, lam, analyse)


def _assemble_gram(Q: np.ndarray, gather: np.ndarray, M: int,
                   cache: dict | None) -> sp.csr_matrix:
    """``G'QG`` (M x M, CSR) from the per-simplex blocks. The sparsity pattern and the slot
    of every block entry in it depend on the space only and are cached there, so each fit
    costs one weighted bincount."""
    nsimp, dhat, _ = Q.shape
    key = ("gram_pattern", nsimp, dhat, M)
    plan = cache.get(key) if cache is not None else None
    if plan is None:
        gi = gather.reshape(nsimp, dhat)
        rows = np.broadcast_to(gi[:, :, None], Q.shape).ravel()
        cols = np.broadcast_to(gi[:, None, :], Q.shape).ravel()
        lin = rows * M + cols
        uniq, slot = np.unique(lin, return_inverse=True)
        indptr = np.zeros(M + 1, dtype=np.int64)
        np.cumsum(np.bincount(uniq // M, minlength=M), out=indptr[1:])
        plan = (slot.ravel(), (uniq % M).astype(np.int64), indptr, len(uniq))
        if cache is not None:
            cache[key] = plan
    slot, indices, indptr, nnz = plan
    data = np.bincount(slot, weights=Q.ravel(), minlength=nnz)
    return sp.csr_matrix((data, indices.copy(), indptr.copy()), shape=(M, M))


def _solve_blocks(Q: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Solve J independent d_hat x d_hat systems (with two refinement steps)."""
    try:
        coef = np.linalg.solve(Q, q[..., None])[..., 0]
    except np.linalg.LinAlgError:
        raise InsufficientDataError(
            "a simplex's normal equations are singular: use on_insufficient='minnorm' or "
            "'ridge'") from None
    for _ in range(2):
        res = q - np.einsum("jkl,jl->jk", Q, coef)
        coef = coef + np.linalg.solve(Q, res[..., None])[..., 0]
    return coef


def _info(ne, coef, deficient, under, Zu, policy, lam, analyse) -> SolveInfo:
    """The fit's :class:`SolveInfo`; with ``Zu`` None (a ridge fit) its undetermined
    directions are analysed by ``analyse()`` when first read."""
    Q, q = ne.XtWX, ne.XtWy
    rss = float(ne.ytWy - 2.0 * np.einsum("jk,jk->", coef, q)
                + np.einsum("jk,jkl,jl->", coef, Q, coef))
    fields = {"counts": ne.counts.copy(), "deficient_simplices": deficient,
              "policy": policy, "ridge": lam, "rss": max(rss, 0.0)}
    if Zu is None:
        def deferred():
            Z, simplices = analyse()
            return simplices, int(Z.shape[1])
        return _DeferredSolveInfo(deferred, **fields)
    return SolveInfo(undetermined_simplices=under, n_undetermined=int(Zu.shape[1]), **fields)


#: Regularisation of the factorised KKT matrix, relative to the mean diagonal of G'QG:
#: SIGMA on the coefficient block, DELTA on the multiplier block. The factorised matrix is
#: then quasi-definite (factorisable without pivoting in any symmetric order); iterative
#: refinement against the exact KKT system removes the regularisation's effect.
KKT_SIGMA = 1e-10
KKT_DELTA = 1e-8
#: The stronger penalty on the conditions (see :func:`_al_solve`'s passes). The method of
#: multipliers contracts the multiplier error by about delta / (delta + s) per refinement
#: step, s the eigenvalues of A (G'QG)^{-1} A': nearly dependent conditions (slivers and
#: nearly coplanar facets of Delaunay triangulations) make s tiny. On 3-D S^1_4 over a
#: Delaunay triangulation of 200 random vertices (1,161 simplices) KKT_DELTA contracted
#: by 0.93 per step and the solve fell into 189 GMRES iterations (12 s); 1e-13 contracts
#: by about 1e-2 there. Smaller values lose accuracy to round-off in the factorised
#: matrix (1e-16: contraction 0.1 again), and badly conditioned data (high degrees) need
#: KKT_DELTA.
KKT_DELTA_TIGHT = 1e-13
REFINE_MAXITER = 40
#: Relative residual GMRES aims at after a stalled refinement (fits without a ridge).
GMRES_RTOL = 1e-14
#: Accepted relative forward-error estimate of a constrained solve (without a ridge).
REFINE_TOL = 1e-8
#: Accepted normwise backward error of a constrained solve whose forward-error estimate
#: stays above REFINE_TOL on every pass because the data are ill-conditioned.
BACKWARD_TOL = 1e-13


def global_points(tri, degree: int, gather: np.ndarray, M: int) -> np.ndarray:
    """Positions of the C^0-reduced coefficients for the nested-dissection ordering of the
    sparse Cholesky factorisation, shape (M, n).

    Along each axis, a coefficient's position is the smallest centroid coordinate among
    the simplices that hold it, so a cut at c along an axis splits the simplices by their
    centroids and the separator follows the facets between the two sides (the shared
    facets' coefficients and the layer beside them, which the C^1 conditions couple)
    wherever the triangulation puts them. Cutting through the coefficients' own B-net
    points instead cuts through simplices off the grid, and every coefficient of a cut
    simplex joins the separator: on 3-D S^1_4 over a Delaunay triangulation of 850 random
    vertices (5,347 simplices) the factorisation took 3.2e11 flops that way and 1.9e11
    this way (largest front 6,915 and 5,067); on Kuhn grids, whose planes follow facets
    either way, the two agree (1.6e11 flops on 5,400 simplices).
    """
    J = len(tri.simplices)
    centroids = tri.vertices[tri.simplices].mean(axis=1)
    out = np.full((M, tri.ndim), np.inf)
    dhat = len(gather) // max(J, 1)
    np.minimum.at(out, gather, np.repeat(centroids, dhat, axis=0))
    return out


def _al_solve(Qg: sp.csc_matrix, qg: np.ndarray, A: sp.csr_matrix, scale: float,
              coords: np.ndarray | None = None, cache: dict | None = None,
              ridge: float = 0.0, null_cache: dict | None = None) -> np.ndarray:
    """Minimise g'Qg g/2 - qg'g subject to A g = 0 (A may be rank deficient).

    Preconditioner: the regularised KKT matrix [Qg + sigma I, A'; A, -delta I], applied
    through its condensed form P = Qg + sigma I + A'A/delta (an M x M sparse symmetric
    positive definite matrix, factorised once), or, when there are few conditions, as a
    whole. Iterative refinement (then GMRES if that stalls) against the exact KKT system
    [Qg A'; A 0] removes the regularisation: this is the method of multipliers with
    penalty 1/delta and converges to the exact constrained minimiser whenever it is unique,
    whether or not A has full row rank.

    ``ridge`` (absolute, already in ``Qg``): directions that only the ridge determines are
    known to relative accuracy ``eps * scale / ridge`` at best, so the accepted forward
    error of the refinement is relaxed accordingly (a 1e-8 relative ridge: about 1e-6).

    Dense systems (at most :data:`DENSE_MAX` unknowns) whose first regularised pass does
    not refine to the tolerance are solved in the null space of the conditions instead
    (:func:`_null_space_solve`, the basis kept in ``null_cache`` for the next fit of the
    same space); the later passes and GMRES only when that basis is not clear-cut.
    """
    tol = REFINE_TOL if ridge <= 0 else max(REFINE_TOL, 1e2 * np.finfo(float).eps * scale / ridge)
    # GMRES's residual target: round-off without a ridge; with one, what the relaxed
    # forward tolerance needs (a residual far below it buys nothing: 1e-14 ran GMRES to its
    # 1,200-step limit in 66 of a paper-preset Cl search's 412 ridge fits, 88 % of its time)
    gmres_rtol = GMRES_RTOL if ridge <= 0 else max(GMRES_RTOL, 1e-2 * tol)
    singular = InsufficientDataError(
        "the constrained least-squares system is singular: the data do not determine the "
        "spline; use on_insufficient='minnorm' or 'ridge'")
    M = Qg.shape[0]
    m = A.shape[0]
    if m:
        rn = np.sqrt(np.asarray(A.multiply(A).sum(axis=1)).ravel())
        A = (sp.diags(scale / np.where(rn > 0, rn, 1.0)) @ A).tocsr()
    At = A.T.tocsr()

    def kkt(z):  # the exact KKT matrix [Qg A'; A 0] times z
        z1, z2 = z[:M], z[M:]
        return np.concatenate([Qg @ z1 + At @ z2, A @ z1])

    K = spla.LinearOperator((M + m, M + m), matvec=kkt, dtype=float)
    rhs = np.concatenate([qg, np.zeros(m)])
    dense_null = m and M <= DENSE_MAX and null_cache is not None
    if dense_null and _null_key(A) in null_cache:    # this space stalled before: direct
        g = _null_space_solve(Qg, qg, A, null_cache)
        if g is not None:
            return g
    stable = None
    for npass, (sigma, delta, krylov) in enumerate(kkt_passes(M, m, scale)):
        if npass == 1 and dense_null:
            # the first pass stalled: the penalty's conditioning (1/delta times the
            # conditions on top of a ridge-determined Gram matrix reaches 1e16) is the
            # limit, not the data; in the null space of the conditions the reduced Gram
            # matrix is as well conditioned as the data and the ridge make it
            g = _null_space_solve(Qg, qg, A, null_cache)
            if g is not None:
                return g
        if sigma == 0 and ridge > 0 and stable is not None:
            # a ridge fit that a regularised pass solved to round-off (backward error):
            # the ridge, not the solver, limits its accuracy; the unregularised pass
            # (SuperLU with pivoting, then up to 1,200 GMRES steps) took 223 s of a
            # 312-s Cl search in 55 of its 412 ridge fits, for no better answer
            break
        pre = None
        if sigma > 0 and M <= DENSE_MAX:
            pre = _dense_preconditioner(Qg, A, At, sigma, delta)
        if pre is None:
            pre = _preconditioner(Qg, A, sigma, delta, coords, cache)
        if pre is None:
            continue
        z, last = _refine(pre, K, rhs, M, tol, krylov=krylov, last_iterate=True,
                          gmres_rtol=gmres_rtol)
        if z is not None:
            return z[:M]
        # the pass's own last finite iterate (refining again would repeat the same
        # steps and the same GMRES restarts: 40 % of an identification's time once)
        if stable is None and last is not None \
                and _backward_error(K, last, rhs, Qg, A) <= BACKWARD_TOL:
            stable = last
    if stable is not None:
        # no pass met the forward-error tolerance, but one solved the system to round-off:
        # the conditioning of the data (high degrees: Gram blocks with condition numbers
        # of 1e10 and more) limits the coefficients, not the solver
        return stable[:M]
    raise singular


#: The null space of the conditions is clear-cut when the eigenvalues of A'A (rows of A
#: scaled alike) fall into round-off ones, at most NULL_ROUNDOFF of the largest, and the
#: others, at least NULL_SEPARATE of it (Kuhn-grid spaces: 1e-16 and 1e-2 or more; the
#: nearly dependent conditions of Delaunay slivers can fill the gap, and then the
#: iterative passes decide).
NULL_ROUNDOFF = 1e-12
NULL_SEPARATE = 1e-7
#: Null-space bases kept per space (each at most DENSE_MAX^2 doubles).
NULL_CACHE_SIZE = 4


def _null_key(A: sp.csr_matrix) -> tuple:
    return (A.shape, A.nnz, hash(A.indptr.tobytes()), hash(A.indices.tobytes()),
            hash(A.data.tobytes()))


def _null_space_solve(Qg, qg, A: sp.csr_matrix, cache: dict) -> np.ndarray | None:
    """The minimiser of ``g'Qg g/2 - qg'g`` subject to ``A g = 0`` as ``g = N y``, ``N`` an
    orthonormal basis of the null space of ``A`` (eigenvectors of the dense ``A'A``, kept
    in ``cache``), ``y`` from a Cholesky factorisation of ``N' Qg N`` with one refinement
    step; None when the null space is not clear-cut (see :data:`NULL_SEPARATE`) or
    ``N' Qg N`` is not positive definite (undetermined directions without a ridge)."""
    key = _null_key(A)
    N = cache.get(key)
    if N is None:
        with kernels.one_blas_thread():
            w, V = np.linalg.eigh((A.T @ A).toarray())
        top = float(w[-1]) if len(w) else 0.0
        if not top > 0:
            return None
        small = w <= NULL_ROUNDOFF * top
        if not np.all(w[~small] >= NULL_SEPARATE * top):
            cache[key] = False                  # not clear-cut: the iterative passes
            return None
        N = np.ascontiguousarray(V[:, small])
        if len(cache) >= NULL_CACHE_SIZE:
            cache.pop(next(iter(cache)))
        cache[key] = N
    if N is False or N.shape[1] == 0:
        return None
    with kernels.one_blas_thread():
        R = N.T @ (Qg @ N)
        b = N.T @ qg
        try:
            fac = sla.cho_factor(R, lower=True, check_finite=False)
        except sla.LinAlgError:
            return None
        y = sla.cho_solve(fac, b, check_finite=False)
        y += sla.cho_solve(fac, b - R @ y, check_finite=False)
    g = N @ y
    return g if np.all(np.isfinite(g)) else None


def kkt_passes(M: int, m: int, scale: float) -> list[tuple[float, float, bool]]:
    """The regularised KKT matrices ``[Qg + sigma I, A'; A, -delta I]`` to factorise, in
    order, for a system of M coefficients and m conditions: ``(sigma, delta, krylov)``,
    ``krylov`` whether the refinement may end in GMRES. One list for the fit and for its
    covariance (:mod:`simplexspline.spline.uncertainty.covariance`).

    With conditions, one pass with the penalty KKT_DELTA and one with KKT_DELTA_TIGHT; a
    pass that fails to converge hands over to the next. Dense (small) systems try
    KKT_DELTA first; sparse ones, where a second factorisation is what costs, the tight
    penalty (a few more refinement steps on well-conditioned conditions, 6 instead of 2 on
    a 3-D S^1_4 Kuhn grid, instead of a stall on nearly dependent ones). Last: the
    unregularised KKT matrix with pivoting (sigma = 0: SuperLU).

    Parameters
    ----------
    M, m : int
        Coefficients (C^0-reduced) and condition rows.
    scale : float
        The mean diagonal of G'QG; the conditions' rows scaled to norm ``scale``.
    """
    sigma = KKT_SIGMA * scale
    if not m:
        passes = [(sigma, KKT_DELTA * scale, True)]
    elif M <= DENSE_MAX:
        passes = [(sigma, KKT_DELTA * scale, False), (sigma, KKT_DELTA_TIGHT * scale, True)]
    else:
        passes = [(sigma, KKT_DELTA_TIGHT * scale, False), (sigma, KKT_DELTA * scale, True)]
    passes.append((0.0, KKT_DELTA * scale, True))
    return passes


def _backward_error(K, z, rhs, Qg, A) -> float:
    """Normwise backward error ``|K z - rhs| / (|K| |z| + |rhs|)`` (infinity norms, |K|
    from the blocks Qg and A) of a KKT solution."""
    knorm = float(abs(Qg).sum(axis=1).max())
    if A.shape[0]:
        knorm = max(knorm + float(abs(A).sum(axis=0).max()), float(abs(A).sum(axis=1).max()))
    r = float(np.abs(rhs - K @ z).max())
    return r / max(knorm * float(np.abs(z).max()) + float(np.abs(rhs).max()), 1e-300)


#: Systems with at most this many C^0-reduced coefficients are factorised as one dense
#: matrix (LAPACK Cholesky): below about this size the sparse factorisation's bookkeeping
#: costs more than the dense flops (the paper's 37-simplex S^1_3 model has M = 657).
DENSE_MAX = 1500


def _dense_preconditioner(Qg, A, At, sigma: float, delta: float):
    """Like :func:`_preconditioner` with sigma > 0, with the condensed matrix dense."""
    M, m = Qg.shape[0], A.shape[0]
    rho = 1.0 / delta
    P = Qg.toarray()
    if m:
        P += rho * (At @ A).toarray()
    P[np.diag_indices(M)] += sigma
    with kernels.one_blas_thread():
        try:
            fac = sla.cho_factor(P, lower=True, overwrite_a=True, check_finite=False)
        except sla.LinAlgError:
            return None

    def solve(r):
        r1, r2 = r[:M], r[M:]
        with kernels.one_blas_thread():
            dg = sla.cho_solve(fac, r1 + rho * (At @ r2) if m else r1, check_finite=False)
        return np.concatenate([dg, rho * (A @ dg - r2)]) if m else dg

    return solve


#: Relative diagonal shift of a sparse Cholesky factorisation retried after round-off broke
#: a pivot (the factor is only a preconditioner of the unshifted system).
SHIFT_RETRY = 1e-12


def _preconditioner(Qg, A, sigma: float, delta: float, coords=None, cache=None):
    """Solver for the regularised KKT matrix, or None when it cannot be factorised."""
    M, m = Qg.shape[0], A.shape[0]
    if sigma > 0:
        # Condensed (multipliers eliminated, nu = (A g - r2) / delta): P is symmetric
        # positive definite; sparse Cholesky, SuperLU if that fails.
        rho = 1.0 / delta
        At = A.T.tocsr()
        P = (Qg + sigma * sp.eye(M) + rho * (At @ A)).tocsr() if m else (
            Qg + sigma * sp.eye(M)).tocsr()
        fac = None
        if coords is not None:
            try:
                fac = SparseCholesky(P, coords, cache=cache).solve
            except np.linalg.LinAlgError:
                # round-off broke a pivot: with the tight delta, rho A'A outweighs sigma by
                # 1e16 and more. A shift of 1e-12 of the largest diagonal entry keeps the
                # factor a preconditioner (the refinement below solves the unshifted
                # system), on the same sparsity pattern and ordering; SuperLU took 0.13 s
                # per 3,000 unknowns for it, a quarter of an F-16 CX search.
                shift = SHIFT_RETRY * float(np.abs(P.diagonal()).max())
                try:
                    fac = SparseCholesky(P + shift * sp.eye(M, format="csr"), coords,
                                         cache=cache).solve
                except np.linalg.LinAlgError:
                    fac = None
        if fac is None:
            fac = _splu(P.tocsc(), 0.0)
            if fac is None:
                return None
        if m == 0:
            return fac

        def solve(r):
            r1, r2 = r[:M], r[M:]
            dg = fac(r1 + rho * (At @ r2))
            return np.concatenate([dg, rho * (A @ dg - r2)])

        return solve
    if m == 0:
        return _splu((Qg + sigma * sp.eye(M)).tocsc(), 0.0)
    # Fallback (G'QG singular along directions only the constraints fix): the whole
    # regularised KKT matrix with threshold partial pivoting.
    Kd = sp.bmat([[Qg, A.T], [A, -delta * sp.eye(m)]], format="csc")
    return _splu(Kd, 0.1)


def _splu(K: sp.csc_matrix, thresh: float):
    opts = {"permc_spec": "MMD_AT_PLUS_A", "options": {"SymmetricMode": True}}
    try:
        return spla.splu(K, diag_pivot_thresh=thresh, **opts).solve
    except RuntimeError:
        return None


def _refine(solve, K, rhs, M, tol: float = 1e-8, krylov: bool = True,
            last_iterate: bool = False, gmres_rtol: float | None = None):
    """Solve K z = rhs with an approximate inverse ``solve``: iterative refinement, then
    (if that converges slowly and ``krylov``) preconditioned GMRES to the relative residual
    ``gmres_rtol`` (default :data:`GMRES_RTOL`).

    Returns None when the relative size of the last correction (the forward-error
    estimate) of the coefficient part stays above ``tol``; with ``last_iterate`` a pair:
    that result and the last iterate (None when not finite), whatever its error."""
    with np.errstate(all="ignore"):
        z = solve(rhs)
        last = np.inf
        step = np.inf
        for _ in range(REFINE_MAXITER):
            dz = solve(rhs - K @ z)
            z += dz
            step = np.abs(dz[:M]).max() / max(np.abs(z[:M]).max(), 1e-300)
            if step <= 1e-14 or step >= 0.8 * last or not np.isfinite(step):
                break
            last = step
        if krylov and np.isfinite(step) and step > 1e-12:
            pre = spla.LinearOperator(K.shape, matvec=solve, dtype=float)
            z2, _ = spla.gmres(K, rhs, x0=z, M=pre, rtol=gmres_rtol or GMRES_RTOL, atol=0.0,
                               restart=60, maxiter=20)
            if np.all(np.isfinite(z2)):
                step = np.abs(solve(rhs - K @ z2)[:M]).max() / max(np.abs(z2[:M]).max(),
                                                                   1e-300)
                z = z2
    finite = bool(np.all(np.isfinite(z)))
    out = z if finite and step <= tol else None
    if last_iterate:
        return out, (z if finite else None)
    return out


def _listing(ids: np.ndarray, counts: np.ndarray, most: int = 12) -> str:
    parts = [f"{int(j)} ({int(counts[j])} points)" for j in ids[:most]]
    more = f", ... {len(ids) - most} more" if len(ids) > most else ""
    return "[" + ", ".join(parts) + more + "]"
