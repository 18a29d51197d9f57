"""The equality-constrained generalized least-squares estimator (paper Eq. 38-42).

    minimise (y - X c)' W (y - X c)   subject to   H c = 0.

Instead of the paper's pseudo-inverse of the dense KKT matrix (Eq. 42), the solver

1. eliminates the C^0 conditions exactly by gathering coefficients that they equate
   (``c = G g``, G a 0/1 matrix; see :mod:`simplexspline.spline.continuity`);
2. solves the sparse KKT system of the remaining, full-row-rank conditions ``A g = 0``

       [ G'QG  A' ] [ g  ]   [ G'q ]
       [ A     0  ] [ nu ] = [ 0   ]

   with a sparse LU factorisation (SuperLU) and one step of iterative refinement.

The solution is unique iff no non-zero coefficient vector is both invisible to the data
(``Q c = 0``) and continuous (``H c = 0``). Such directions are found exactly from the
per-simplex null spaces of the Gram blocks and handled by the ``on_insufficient`` policy.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from simplexspline.errors import InputError, InsufficientDataError

__all__ = ["solve_constrained", "SolveInfo", "POLICIES"]

#: What to do when data and continuity leave coefficients undetermined.
POLICIES = ("raise", "minnorm", "ridge")

#: An eigenvalue of a simplex's Gram block below this fraction of the block's largest
#: (or of the largest block's, for empty blocks) counts as a direction without data.
NULL_TOL = 1e-10

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


def _null_directions(Q: np.ndarray):
    """Per-block eigen-decomposition: the columns (full coordinates) spanning null(Q)."""
    nsimp, dhat, _ = Q.shape
    lam, vec = np.linalg.eigh(Q)
    top = lam[:, -1]
    ref = np.where(top > 0, top, max(float(top.max()), 1.0))
    null = lam <= NULL_TOL * ref[:, None]
    js, ks = np.nonzero(null)
    rows = (js[:, None] * dhat + np.arange(dhat)[None, :]).ravel()
    cols = np.repeat(np.arange(len(js)), dhat)
    vals = vec[js, :, ks].ravel()
    N = sp.csc_matrix((vals, (rows, cols)), shape=(nsimp * dhat, len(js)))
    return N, np.unique(js)


def _undetermined(N: sp.csc_matrix, H: sp.csr_matrix) -> np.ndarray:
    """Orthonormal basis (full coordinates, dense) of null(Q) intersected with null(H)."""
    k = N.shape[1]
    if k == 0:
        return np.zeros((N.shape[0], 0))
    HN = (H @ N).tocsr()
    HN.eliminate_zeros()
    nz = np.diff(HN.indptr) > 0
    dense = HN[nz].toarray()
    if dense.shape[0] == 0:
        theta = np.eye(k)
    else:
        _, s, vt = np.linalg.svd(dense, full_matrices=True)
        tol = 1e-9 * (s[0] if len(s) else 1.0)
        rank = int((s > tol).sum())
        theta = vt[rank:].T
    return np.asarray(N @ theta)


def solve_constrained(ne, system, *, on_insufficient: str = "raise", ridge=None):
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
    N, deficient = _null_directions(Q)
    Zu = _undetermined(N, system.H_full) if N.shape[1] else np.zeros((nsimp * dhat, 0))
    under = np.unique(np.nonzero(np.abs(Zu) > 1e-12)[0] // dhat) if Zu.shape[1] else \
        np.empty(0, dtype=np.int64)
    if ridge is None and on_insufficient == "ridge":
        ridge = DEFAULT_RIDGE
    if Zu.shape[1] and on_insufficient == "raise" and not ridge:
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
    # G'QG and G'q, assembled sparse from the blocks.
    loc = np.arange(nsimp * dhat).reshape(nsimp, dhat)
    gi = gather[loc]
    rows = np.broadcast_to(gi[:, :, None], Q.shape).ravel()
    cols = np.broadcast_to(gi[:, None, :], Q.shape).ravel()
    Qg = sp.csr_matrix((Q.ravel(), (rows, cols)), shape=(M, M))
    qg = np.bincount(gi.ravel(), weights=q.ravel(), minlength=M)
    if lam > 0:
        mult = np.bincount(gather, minlength=M).astype(float)
        Qg = Qg + sp.diags(lam * mult)
    A = system.A
    if Zu.shape[1] and on_insufficient == "minnorm" and not lam:
        # Minimum norm: the undetermined directions (which lie in range(G)) are set to zero.
        ZG = sp.csr_matrix(Zu.T) @ sp.csr_matrix(
            (np.ones(len(gather)), (np.arange(len(gather)), gather)), shape=(len(gather), M))
        ZG = sp.csr_matrix(ZG)
        ZG.data[np.abs(ZG.data) < 1e-14] = 0.0
        ZG.eliminate_zeros()
        A = sp.vstack([A, ZG]).tocsr()
    g = _kkt_solve(Qg.tocsc(), qg, A, diag_mean)
    coef = g[gather].reshape(nsimp, dhat)
    rss = float(ne.ytWy - 2.0 * np.einsum("jk,jk->", coef, q)
                + np.einsum("jk,jkl,jl->", coef, Q, coef))
    info = SolveInfo(
        counts=ne.counts.copy(),
        deficient_simplices=deficient,
        undetermined_simplices=under,
        n_undetermined=int(Zu.shape[1]),
        policy=on_insufficient,
        ridge=lam,
        rss=max(rss, 0.0),
    )
    return coef, info


def _kkt_solve(Qg: sp.csc_matrix, qg: np.ndarray, A: sp.csr_matrix, scale: float) -> np.ndarray:
    """Solve [Qg A'; A 0] [g; nu] = [qg; 0] by sparse LU with iterative refinement."""
    M = Qg.shape[0]
    K_rows = A.shape[0]
    if K_rows:
        # Rows of A scaled to the size of Qg's diagonal keeps the KKT matrix balanced.
        rn = np.sqrt(np.asarray(A.multiply(A).sum(axis=1)).ravel())
        As = sp.diags(scale / np.where(rn > 0, rn, 1.0)) @ A
        K = sp.bmat([[Qg, As.T], [As, None]], format="csc")
    else:
        K = Qg
    rhs = np.concatenate([qg, np.zeros(K_rows)])
    try:
        lu = spla.splu(K, permc_spec="COLAMD", diag_pivot_thresh=1.0)
    except RuntimeError as exc:
        raise InsufficientDataError(
            f"the constrained least-squares system is singular ({exc}): the data do not "
            "determine the spline; use on_insufficient='minnorm' or 'ridge'") from None
    sol = lu.solve(rhs)
    for _ in range(2):
        res = rhs - K @ sol
        sol = sol + lu.solve(res)
    if not np.all(np.isfinite(sol)):
        raise InsufficientDataError(
            "the constrained least-squares system is numerically singular: use "
            "on_insufficient='minnorm' or 'ridge'")
    return sol[:M]


def _listing(ids: np.ndarray, counts: np.ndarray, most: int = 12) -> str:
    parts = [f"{int(j)} ({int(counts[j])} points)" for j in ids[:most]]
    more = f", ... {len(ids) - most} more" if len(ids) > most else ""
    return "[" + ", ".join(parts) + more + "]"
