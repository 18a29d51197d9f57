"""Choice of the penalty weight by generalized cross-validation (GCV).

For the penalised estimator of :mod:`simplexspline.spline.fit.penalty`,

    minimise (y - X c)' W (y - X c) + lam * c' P c    subject to    H c = 0,

the weight ``lam`` is chosen by minimising

    GCV(lam) = N * RSS(lam) / (N - edf(lam))^2,
    edf(lam) = tr H(lam) = tr((Z'(Q + lam P) Z)^-1 Z'QZ),

(``Q = X'WX``, Z a basis of the null space of the continuity conditions) on a logarithmic
grid of relative weights, then refined by a bounded scalar search (:func:`choose_smoothing`).
``edf`` is exact (:class:`_ExactGCV`: dense simultaneous diagonalisation of ``Z'QZ`` and
``Z'PZ``) for spaces with at most :data:`DENSE_MAX` C^0-reduced coefficients, otherwise
estimated by Hutchinson's randomised trace estimator (:class:`_HutchinsonGCV`, which solves
the penalised constrained system for all probe vectors at once; see
:func:`choose_smoothing` for its accuracy). The outcome is recorded in a
:class:`Regularization`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from simplexspline._golden_section import golden_section
from simplexspline.errors import InputError, InsufficientDataError
from simplexspline.spline import kernels
from simplexspline.spline.fit.cholesky import SparseCholesky
from simplexspline.spline.fit.constrained import global_points

__all__ = [
    "DEFAULT_PROBES",
    "DENSE_MAX",
    "SMOOTHING_GRID",
    "Regularization",
    "choose_smoothing",
    "effective_dof",
    "gcv_score",
]

#: Relative smoothing weights tried by the GCV search before refinement (``lam`` is the
#: relative weight times ``tr(X'WX) / tr(P)``).
SMOOTHING_GRID = tuple(10.0 ** k for k in range(-8, 5))

#: Up to this many C^0-reduced coefficients, edf is computed exactly (dense); beyond, by
#: Hutchinson's estimator.
DENSE_MAX = 2000

#: Default number of Hutchinson probe vectors.
DEFAULT_PROBES = 32


@dataclass
class Regularization:
    """How a penalised fit was regularised (``spline.info.regularization``).

    Attributes
    ----------
    penalty : str
        Penalty kind ('energy', 'membrane', 'ridge' or 'custom').
    smoothing : float
        Relative weight: ``lam = smoothing * scale``.
    lam : float
        Absolute weight of ``c' P c`` in the objective.
    scale : float
        ``tr(X'WX) / tr(P)`` (both over all simplices).
    edf : float
        Effective degrees of freedom ``tr H(lam)`` (NaN when not computed).
    edf_std : float
        Standard error of ``edf`` (0 when exact, NaN when not computed).
    gcv : float
        GCV score ``N RSS / (N - edf)^2`` at ``lam`` (NaN when not computed).
    rss : float
        Weighted residual sum of squares of the fit.
    npoints : int
        N, the number of data points.
    method : str
        'exact', 'hutchinson' or 'none' (edf not computed).
    chosen_by : str
        'gcv' or 'given'.
    grid, scores : ndarray
        Relative weights evaluated by the search (sorted) and their GCV scores.
    at_boundary : bool
        The minimum lies at an end of the search range (the best weight may lie beyond).
    n_dropped : int
        Coefficient directions determined neither by data, penalty nor continuity, left
        out of the edf computation (exact method).
    """

    penalty: str
    smoothing: float
    lam: float
    scale: float
    edf: float = float("nan")
    edf_std: float = float("nan")
    gcv: float = float("nan")
    rss: float = float("nan")
    npoints: int = 0
    method: str = "none"
    chosen_by: str = "given"
    grid: np.ndarray = field(default_factory=lambda: np.empty(0))
    scores: np.ndarray = field(default_factory=lambda: np.empty(0))
    at_boundary: bool = False
    n_dropped: int = 0


def gcv_score(rss: float, edf: float, npoints: int) -> float:
    """``N * RSS / (N - edf)^2``; ``inf`` when ``edf >= N``.

    >>> gcv_score(2.0, 10.0, 110)
    0.022
    """
    rest = npoints - edf
    return float(npoints * rss / rest ** 2) if rest > 0 else float("inf")


def _gathered(blocks: np.ndarray, gather: np.ndarray, M: int) -> sp.csr_matrix:
    """``G' blockdiag(blocks) G`` as a sparse M x M matrix."""
    nsimp, dh, _ = blocks.shape
    gi = gather.reshape(nsimp, dh)
    rows = np.broadcast_to(gi[:, :, None], blocks.shape).ravel()
    cols = np.broadcast_to(gi[:, None, :], blocks.shape).ravel()
    out = sp.csr_matrix((blocks.ravel(), (rows, cols)), shape=(M, M))
    out.sum_duplicates()
    return out


def _nullspace(system, cache: dict | None) -> np.ndarray:
    """Orthonormal basis (M, k) of the null space of the C^1.. conditions (dense QR)."""
    if cache is not None and "penalty_nullspace" in cache:
        return cache["penalty_nullspace"]
    M = system.nglobal
    A = system.A_all
    if A.shape[0] == 0:
        Z = np.eye(M)
    else:
        rn = np.sqrt(np.asarray(A.multiply(A).sum(axis=1)).ravel())
        A = (sp.diags(1.0 / np.where(rn > 0, rn, 1.0)) @ A).tocsr()
        # Eigenvectors of A'A: much cheaper than a pivoted QR of A' when A has many
        # (redundant) rows. On spline conditions the spectrum has a wide gap (measured:
        # null eigenvalues <= 3e-16, the others >= 3e-4 of the largest); if eigenvalues
        # fall in between, the rank-revealing QR decides.
        w, V = np.linalg.eigh((A.T @ A).toarray())
        top = max(float(w[-1]), 1e-300)
        if np.any((w > 1e-13 * top) & (w < 1e-7 * top)):
            Qf, R, _ = sla.qr(A.T.toarray(), mode="full", pivoting=True)
            diag = np.abs(np.diag(R))
            rank = int((diag > 1e-9 * diag[0]).sum()) if len(diag) else 0
            Z = np.ascontiguousarray(Qf[:, rank:])
        else:
            Z = np.ascontiguousarray(V[:, w <= 1e-10 * top])
    if cache is not None:
        cache["penalty_nullspace"] = Z
    return Z


class _ExactGCV:
    """RSS(lam) and edf(lam) for all lam from one simultaneous diagonalisation."""

    method = "exact"

    def __init__(self, ne, system, P, ridge_abs: float, cache):
        Q, q = ne.XtWX, ne.XtWy
        gather, M = system.gather, system.nglobal
        Z = _nullspace(system, cache)
        Qg = _gathered(Q, gather, M)
        Qz = Z.T @ (Qg @ Z)
        Pz = Z.T @ (_gathered(P, gather, M) @ Z)
        qz = Z.T @ np.bincount(gather, weights=q.ravel(), minlength=M)
        Qr = Qz
        if ridge_abs:
            mult = np.bincount(gather, minlength=M).astype(float)
            Qr = Qz + ridge_abs * (Z.T * mult) @ Z
        trp = float(np.trace(Pz))
        self.mu = float(np.trace(Qr)) / trp if trp > 0 else 1.0
        w, U = np.linalg.eigh(Qr + self.mu * Pz)
        keep = w > 1e-11 * max(w.max(), 1e-300)
        self.n_dropped = int((~keep).sum())
        Y = U[:, keep] / np.sqrt(w[keep])
        theta, V2 = np.linalg.eigh(Y.T @ Qr @ Y)
        V = Y @ V2
        self.theta = np.clip(theta, 0.0, 1.0)
        self.s = V.T @ qz
        self.C = V.T @ Qz @ V if ridge_abs else None
        self.cdiag = self.theta if self.C is None else np.diag(self.C).copy()
        self.ytWy = ne.ytWy

    def evaluate(self, lam: float):
        D = self.theta + lam * (1.0 - self.theta) / self.mu
        with np.errstate(divide="ignore", invalid="ignore"):
            a = np.where(D > 0, self.s / D, 0.0)
            edf = float(np.sum(np.where(D > 0, self.cdiag / D, 0.0)))
        quad = float(a @ (self.C @ a)) if self.C is not None else float(np.sum(self.theta * a * a))
        rss = max(self.ytWy - 2.0 * float(a @ self.s) + quad, 0.0)
        return rss, edf, 0.0


def _kkt_solver(K11: sp.csr_matrix, A: sp.csr_matrix, coords: np.ndarray | None):
    """Solver of ``min g'K11 g/2 - b'g s.t. A g = 0`` for many right-hand sides at once.

    A regularised condensed KKT matrix is factorised once (the package's sparse Cholesky,
    SuperLU as fallback) and iterative refinement against the exact KKT system removes the
    regularisation (the method of multipliers), as in the constrained solver.
    """
    M, m = K11.shape[0], A.shape[0]
    scale = float(K11.diagonal().mean()) or 1.0
    if m:
        rn = np.sqrt(np.asarray(A.multiply(A).sum(axis=1)).ravel())
        A = (sp.diags(scale / np.where(rn > 0, rn, 1.0)) @ A).tocsr()
    rho = 1.0 / (1e-8 * scale)
    Pc = K11 + 1e-10 * scale * sp.eye(M)
    if m:
        Pc = Pc + rho * (A.T @ A)
    Pc = Pc.tocsr()
    fac = None
    if coords is not None:
        try:
            fac = SparseCholesky(Pc, coords).solve
        except (ImportError, TypeError, np.linalg.LinAlgError):
            fac = None
    if fac is None:
        try:
            fac = spla.splu(Pc.tocsc(), permc_spec="MMD_AT_PLUS_A").solve
        except RuntimeError:
            raise InsufficientDataError(
                "the penalised system is singular: data, penalty and continuity do not "
                "determine the spline; add a ridge (ridge=1e-6) or use penalty='ridge'"
            ) from None
    At = A.T.tocsr()

    def solve(B: np.ndarray) -> np.ndarray:
        B = np.asarray(B, dtype=float).reshape(M, -1)
        if m == 0:
            G = fac(B)
            for _ in range(3):
                G = G + fac(B - K11 @ G)
            return G
        G = fac(B)
        nu = rho * (A @ G)
        for _ in range(60):
            R1 = B - K11 @ G - At @ nu
            R2 = -(A @ G)
            dG = fac(R1 + rho * (At @ R2))
            nu = nu + rho * (A @ dG - R2)
            G = G + dG
            if np.abs(dG).max() <= 1e-12 * max(np.abs(G).max(), 1e-300):
                break
        return G

    return solve


class _HutchinsonGCV:
    """RSS(lam) exact, edf(lam) by Hutchinson's estimator with fixed Rademacher probes."""

    method = "hutchinson"
    n_dropped = 0

    def __init__(self, ne, system, P, ridge_abs: float, probes: int, seed: int):
        Q, q = ne.XtWX, ne.XtWy
        nsimp, dh, _ = Q.shape
        self.ne, self.gather, self.M = ne, system.gather, system.nglobal
        self.A = system.A_all
        self.Qg = _gathered(Q, self.gather, self.M)
        if ridge_abs:
            mult = np.bincount(self.gather, minlength=self.M).astype(float)
            self.Qg = (self.Qg + sp.diags(ridge_abs * mult)).tocsr()
        self.Pg = _gathered(P, self.gather, self.M)
        w, V = np.linalg.eigh(Q)
        self.R = np.sqrt(np.clip(w, 0.0, None))[:, :, None] * V.transpose(0, 2, 1)  # Q = R'R
        rng = np.random.default_rng(seed)
        self.Zp = rng.choice([-1.0, 1.0], size=(nsimp, dh, probes))
        v = np.einsum("jab,jap->jbp", self.R, self.Zp).reshape(nsimp * dh, probes)
        G = sp.csr_matrix((np.ones(nsimp * dh), (self.gather, np.arange(nsimp * dh))),
                          shape=(self.M, nsimp * dh))
        qg = np.bincount(self.gather, weights=q.ravel(), minlength=self.M)
        self.rhs = np.column_stack([qg, G @ v])
        cache = getattr(system, "solver_cache", None)
        self.coords = cache.get("points") if cache is not None else None
        if self.coords is None:
            self.coords = global_points(ne.triangulation, ne.degree, self.gather, self.M)

    def evaluate(self, lam: float):
        ne = self.ne
        nsimp, dh = ne.XtWy.shape
        sol = _kkt_solver((self.Qg + lam * self.Pg).tocsr(), self.A, self.coords)(self.rhs)
        full = sol[self.gather]  # (J*dh, 1 + p)
        coef = full[:, 0].reshape(nsimp, dh)
        rss = max(float(ne.ytWy - 2.0 * np.einsum("jk,jk->", coef, ne.XtWy)
                        + np.einsum("jk,jkl,jl->", coef, ne.XtWX, coef)), 0.0)
        U = full[:, 1:].reshape(nsimp, dh, -1)
        est = np.einsum("jap,jab,jbp->p", self.Zp, self.R, U)
        return rss, float(est.mean()), float(est.std(ddof=1) / np.sqrt(len(est)))


def penalty_scale(ne, P: np.ndarray) -> float:
    trq = float(np.einsum("jkk->", ne.XtWX))
    trp = float(np.einsum("jkk->", P))
    if trp <= 0:
        raise InputError("the penalty is zero on this space (e.g. energy of a degree-1 "
                         "spline): choose another penalty")
    return trq / trp


def gcv_evaluator(ne, system, P, ridge_abs, method, probes, seed):
    with kernels.one_blas_thread():
        return _make_evaluator(ne, system, P, ridge_abs, method, probes, seed)


def _make_evaluator(ne, system, P, ridge_abs, method, probes, seed):
    if method not in ("auto", "exact", "hutchinson"):
        raise InputError(f"method must be 'auto', 'exact' or 'hutchinson', got {method!r}")
    if method == "exact" or (method == "auto" and system.nglobal <= DENSE_MAX):
        return _ExactGCV(ne, system, P, ridge_abs, getattr(system, "solver_cache", None))
    if int(probes) < 2:
        raise InputError(f"probes must be an integer >= 2, got {probes!r}")
    return _HutchinsonGCV(ne, system, P, ridge_abs, int(probes), seed)


def choose_smoothing(ne, system, P, *, ridge_abs: float = 0.0, method: str = "auto",
                     probes: int = DEFAULT_PROBES, grid=None, seed: int = 0,
                     penalty_name: str = "custom") -> Regularization:
    """Choose the penalty weight by generalized cross-validation.

    Parameters
    ----------
    ne : NormalEquations
        Accumulated data.
    system : SmoothnessSystem
        The spline space's continuity system (``SplineSpace.system``).
    P : ndarray, shape (J, d_hat, d_hat)
        Penalty blocks (:func:`~simplexspline.spline.fit.penalty.penalty_blocks`).
    ridge_abs : float
        An additional absolute ridge ``ridge_abs * c'c`` kept fixed (not counted as data).
    method : {'auto', 'exact', 'hutchinson'}
        How edf is computed: exact (dense; 'auto' when the space has at most
        :data:`DENSE_MAX` C^0-reduced coefficients) or Hutchinson's estimator.
    probes : int
        Hutchinson probe vectors p. The estimate of ``edf = tr(T)`` (T the symmetrised hat
        matrix, eigenvalues in [0, 1]) has standard deviation
        ``sqrt(2 (||T||_F^2 - sum_i T_ii^2) / p) <= sqrt(2 edf / p)``, i.e. relative
        error at most ``sqrt(2 / (p edf))``; its relative effect on GCV is about
        ``2 std / (N - edf)``. The same probes are used for every weight, so the GCV curve
        is smooth in lam and the error mostly shifts it.
    grid : sequence of float, optional
        Relative weights to try (default :data:`SMOOTHING_GRID`, 1e-8 .. 1e4).
    seed : int
        Seed of the probe vectors.

    Returns
    -------
    Regularization
        With ``chosen_by='gcv'``; ``rss`` is the search's value at the chosen weight.
    """
    scale = penalty_scale(ne, P)
    grid = np.sort(np.asarray(SMOOTHING_GRID if grid is None else grid, dtype=float))
    if grid.ndim != 1 or len(grid) < 2 or np.any(grid <= 0) or not np.all(np.isfinite(grid)):
        raise InputError("grid must hold at least two finite relative weights > 0")
    ev = gcv_evaluator(ne, system, P, ridge_abs, method, probes, seed)
    N = int(ne.npoints)
    seen: dict = {}

    def score(logs: float) -> float:
        key = round(float(logs), 12)
        if key not in seen:
            with kernels.one_blas_thread():
                rss, edf, std = ev.evaluate(10.0 ** key * scale)
            seen[key] = (gcv_score(rss, edf, N), rss, edf, std)
        return seen[key][0]

    logs = np.log10(grid)
    vals = np.array([score(v) for v in logs])
    if not np.any(np.isfinite(vals)):
        raise InsufficientDataError(
            f"GCV is undefined: the effective degrees of freedom reach the number of data "
            f"points ({N}) for every weight tried; add data or coarsen the triangulation")
    i = int(np.nanargmin(vals))
    lo, hi = logs[max(i - 1, 0)], logs[min(i + 1, len(logs) - 1)]
    if hi > lo:
        golden_section(score, lo, hi, tol=0.01 if ev.method == "exact" else 0.05)
    best = min(seen, key=lambda k: seen[k][0])
    g, rss, edf, std = seen[best]
    keys = np.array(sorted(seen))
    return Regularization(
        penalty=penalty_name, smoothing=10.0 ** best, lam=10.0 ** best * scale, scale=scale,
        edf=edf, edf_std=std, gcv=g, rss=rss, npoints=N, method=ev.method, chosen_by="gcv",
        grid=10.0 ** keys, scores=np.array([seen[k][0] for k in keys]),
        at_boundary=bool(best <= logs[0] + 1e-9 or best >= logs[-1] - 1e-9),
        n_dropped=ev.n_dropped)


def effective_dof(ne, system, P, lam: float, *, ridge_abs: float = 0.0,
                  method: str = "auto", probes: int = DEFAULT_PROBES,
                  seed: int = 0) -> tuple[float, float]:
    """Effective degrees of freedom ``tr H(lam)`` of the penalised constrained fit.

    Parameters
    ----------
    ne, system, P, ridge_abs, method, probes, seed
        As in :func:`choose_smoothing`.
    lam : float
        Absolute penalty weight.

    Returns
    -------
    edf : float
    std : float
        Standard error of the estimate (0 for the exact method).
    """
    ev = gcv_evaluator(ne, system, P, ridge_abs, method, probes, seed)
    with kernels.one_blas_thread():
        _, edf, std = ev.evaluate(float(lam))
    return edf, std
