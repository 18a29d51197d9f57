"""Covariance computation for the constrained least-squares estimator.

In the C^0-reduced coordinates ``g`` (``c = G g``) the fit is linear in the data,
``g = K qg`` with ``K = Z (Z' Qg Z)^-1 Z'`` (Z a basis of the null space of the continuity
conditions ``A g = 0``): the top-left block of the inverse KKT matrix ``[Qg A'; A 0]``. The
covariance of the estimate is ``sigma^2 K`` or, for the sandwich of a regularised fit,
``sigma^2 K Q0 K`` (see :mod:`simplexspline.spline.uncertainty.intervals` for the model). This module
computes it; :class:`~simplexspline.spline.uncertainty.intervals.Uncertainty` turns it into standard
errors and intervals.

Every prediction at a point of simplex j needs only the d_hat x d_hat block of the covariance
of that simplex's B-coefficients, ``C_j = G_j Cov(g) G_j'``. :class:`CovarianceEngine` computes the
blocks either from an orthonormal basis of the constrained coefficient space (when it fits a
memory budget: ``K = Rk Rk'``, all blocks at once) or from the columns ``K e_m`` (one per
global coefficient m that the simplices asked for), by the fit's factorisation of the
regularised KKT matrix (:mod:`simplexspline.spline.fit.constrained`) and iterative refinement against
the exact one (:func:`_refine`), many right-hand sides at once and chunk by chunk: memory is
bounded by the chunk and the J blocks, never M x M. Afterwards a standard error costs
``d_hat^2`` flops per point.

The memory budgets (``chunk_bytes``, ``basis_bytes``) are passed in by the caller
(:data:`~simplexspline.spline.uncertainty.intervals.CHUNK_BYTES`,
:data:`~simplexspline.spline.uncertainty.intervals.BASIS_BYTES`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from simplexspline.errors import InsufficientDataError
from simplexspline.spline.fit import constrained as S

__all__ = ["BASIS_BATCH", "REFINE_ACCEPT", "REFINE_MAXITER", "REFINE_TOL"]

#: Random vectors per batch when sampling the constrained space.
BASIS_BATCH = 64

#: Iterative refinement of many right-hand sides: stop when the largest relative step is
#: below REFINE_TOL; accept a column when below REFINE_ACCEPT (else GMRES, then an error).
REFINE_TOL = 1e-12
REFINE_ACCEPT = 1e-9
REFINE_MAXITER = 40


class CovarianceEngine:
    """The factorised constrained system of a fit: applies K to many right-hand sides, or
    factors K through an orthonormal basis of the constrained coefficient space."""

    def __init__(self, space, Q, counts, policy, lam, penalty, sandwich):
        system = space.system
        nsimp, dhat, _ = Q.shape
        Qp = Q if penalty is None else Q + penalty
        Nd, _ = S._null_directions(Qp, counts)
        Zu = S._undetermined(Nd, system.H_full)
        under = np.unique(Zu.indices // dhat)
        if Zu.shape[1] and policy == "raise" and not lam:
            raise InsufficientDataError(
                f"the data do not determine the spline on {len(under)} simplices "
                f"{S._listing(under, counts)}: fit (and build statistics) with "
                "on_insufficient='minnorm' or 'ridge'", under, counts[under])
        self.undetermined_mask = np.zeros(nsimp, dtype=bool)
        self.undetermined_mask[under] = True
        self.gather, M = system.gather, system.nglobal
        self.M = M
        self.Gt = sp.csr_matrix((np.ones(len(self.gather)),
                                 (self.gather, np.arange(len(self.gather)))),
                                shape=(M, len(self.gather)))
        diag_mean = float(np.einsum("jkk->", Q) / max(int((counts > 0).sum()) * dhat, 1))
        if diag_mean <= 0:
            raise InsufficientDataError("no data (or only zero weights) in the statistics",
                                        np.arange(nsimp), counts)
        gi = self.gather.reshape(nsimp, dhat)
        rows = np.broadcast_to(gi[:, :, None], Q.shape).ravel()
        cols = np.broadcast_to(gi[:, None, :], Q.shape).ravel()
        Q0 = sp.csr_matrix((Q.ravel(), (rows, cols)), shape=(M, M))
        regularized = lam > 0 or penalty is not None
        self.Q0 = Q0 if regularized and sandwich else None  # for the sandwich K Q0 K
        self.Qdata = Q0  # for the trace of the hat matrix
        Qg = Q0 if penalty is None else sp.csr_matrix((Qp.ravel(), (rows, cols)),
                                                      shape=(M, M))
        if lam > 0:
            mult = np.bincount(self.gather, minlength=M).astype(float)
            Qg = Qg + sp.diags(lam * mult)
        self.Qg = Qg.tocsr()
        A = system.A_all
        if Zu.shape[1] and policy == "minnorm" and not lam:
            ZG = (Zu.T.tocsr() @ self.Gt.T).tocsr()
            A = sp.vstack([A, ZG]).tocsr()
        m = A.shape[0]
        if m:
            rn = np.sqrt(np.asarray(A.multiply(A).sum(axis=1)).ravel())
            A = (sp.diags(1.0 / np.where(rn > 0, rn, 1.0)) @ A).tocsr()  # unit rows
            self.K = sp.bmat([[Qg, diag_mean * A.T], [diag_mean * A, None]], format="csr")
        else:
            self.K = self.Qg
        self.A, self.m = A, m
        cache = getattr(system, "solver_cache", None)
        coords = cache.get("points") if cache is not None else None
        if coords is None:
            coords = S.global_points(space.triangulation, space.degree, self.gather, M)
            if cache is not None:
                cache["points"] = coords
        self._coords, self._cache = coords, cache
        chol = cache.setdefault("cholesky", {}) if cache is not None else None
        Qc = Qg.tocsc()
        Ad = (diag_mean * A).tocsr()
        # the fit's passes: on nearly dependent conditions (Delaunay slivers) the tight
        # penalty converges where KKT_DELTA stalls
        self._pres = [lambda s=sigma, d=delta: S._preconditioner(Qc, Ad, s, d, coords, chol)
                      for sigma, delta, _ in S.kkt_passes(M, m, diag_mean)]
        self._pre = None
        self._which = 0
        self._factors = None

    # -- many right-hand sides
    def solve_many(self, V: np.ndarray) -> np.ndarray:
        """``K V`` for V of shape (M, k)."""
        V = np.asarray(V, dtype=float)
        while self._which < len(self._pres):
            if self._pre is None:
                self._pre = self._pres[self._which]()
            if self._pre is not None:
                out = _refine(self._pre, self.K, V, self.M)
                if out is not None:
                    return out
            self._which += 1
            self._pre = None
        raise InsufficientDataError(
            "the constrained least-squares system is singular: the data do not determine "
            "the spline; fit with on_insufficient='minnorm' or 'ridge'")

    def column_chunks(self, cols: np.ndarray, *, chunk_bytes: int):
        """Yield ``(a, b, K[:, cols[a:b]], S)`` chunk by chunk; S the sandwich
        ``K Q0 K[:, cols[a:b]]`` with a ridge, else None. ``chunk_bytes``: memory for the
        right-hand sides solved at once (about six arrays of the chunk)."""
        per = max(8, int(chunk_bytes // (8 * 6 * (self.M + self.m))))
        for a in range(0, len(cols), per):
            b = min(a + per, len(cols))
            E = np.zeros((self.M, b - a))
            E[cols[a:b], np.arange(b - a)] = 1.0
            Kc = self.solve_many(E)
            Sc = None if self.Q0 is None else self.solve_many(self.Q0 @ Kc)
            yield a, b, Kc, Sc

    def variance_columns(self, cols: np.ndarray, *, chunk_bytes: int,
                         basis_bytes: int) -> np.ndarray:
        """Dense columns ``cols`` of Cov(g) / sigma^2: K, or K Q0 K with a ridge."""
        fac = self.factors(basis_bytes=basis_bytes)
        if fac is not None:
            R = fac[0]
            return R @ R[cols].T
        out = np.empty((self.M, len(cols)))
        for a, b, Kc, Sc in self.column_chunks(cols, chunk_bytes=chunk_bytes):
            out[:, a:b] = Kc if Sc is None else Sc
        return out

    # -- per-simplex covariance blocks
    def fill_blocks(self, todo: np.ndarray, gram: np.ndarray, blocks: np.ndarray,
                    leverage: np.ndarray, *, chunk_bytes: int, basis_bytes: int):
        """Compute the unscaled covariance blocks (sigma^2 = 1) of the simplices ``todo``
        into ``blocks`` (J, d_hat, d_hat) and their hat-matrix contributions
        ``trace(gram_j B_j)`` into ``leverage`` (J,).

        Returns the dimension p of the constrained space when the basis path filled every
        simplex at once, None when the column path filled just ``todo``.
        """
        dhat = gram.shape[1]
        gi = self.gather.reshape(-1, dhat)
        fac = self.factors(basis_bytes=basis_bytes)
        if fac is not None:
            # Basis path: Cov(g) / sigma^2 = R R' and K = Rk Rk' with p columns.
            R, Rk, rank = fac
            J = len(gi)
            step = max(1, int(chunk_bytes // (16 * dhat * max(R.shape[1], 1))))
            for s in range(0, J, step):
                js = np.arange(s, min(s + step, J))
                Rj = R[gi[js]]  # (c, d_hat, p)
                blocks[js] = Rj @ Rj.transpose(0, 2, 1)
                Rkj = Rj if Rk is R else Rk[gi[js]]
                leverage[js] = np.einsum("jkl,jlp,jkp->j", gram[js], Rkj, Rkj)
            return rank
        # Column path: the columns K e_m of the global coefficients these simplices use.
        need = np.unique(gi[todo])
        pos = np.full(self.M, -1)
        pos[need] = np.arange(len(need))
        sub = gi[todo]  # (T, d_hat)
        rows_of = pos[sub]  # column position of each local coefficient
        order = np.argsort(rows_of.ravel(), kind="stable")
        flat_pos = rows_of.ravel()[order]
        for a, b, K, S in self.column_chunks(need, chunk_bytes=chunk_bytes):
            lo, hi = np.searchsorted(flat_pos, [a, b])
            sel = order[lo:hi]
            t, ll = np.divmod(sel, dhat)
            cols = pos[sub[t, ll]] - a
            j = todo[t]
            Kv = K[sub[t], cols[:, None]]  # (P, d_hat): K[g(j, k), g(j, l)] over k
            blocks[j, :, ll] = (Kv if S is None else S[sub[t], cols[:, None]])
            # trace(Q_j B_j) = sum_{k,l} Q_j[l, k] B_j[k, l], column l at a time
            np.add.at(leverage, j, np.einsum("pk,pk->p", gram[j, ll, :], Kv))
        return None

    # -- basis of the constrained space
    def factors(self, *, basis_bytes: int):
        """``(R, Rk, p)`` with ``Cov(g) / sigma^2 = R R'``, ``K = Rk Rk'`` (M x p) and p
        the dimension of the constrained space; None when the basis would exceed
        ``basis_bytes`` (then the column path is used). Decided, and cached, on the first
        call."""
        if self._factors is None:
            B = self._null_basis(basis_bytes)
            if B is None:
                self._factors = False
            else:
                S = B.T @ (self.Qg @ B)
                try:
                    L = sla.cholesky(0.5 * (S + S.T), lower=True)
                except sla.LinAlgError:
                    raise InsufficientDataError(
                        "the constrained least-squares system is singular: the data do not "
                        "determine the spline; fit with on_insufficient='minnorm' or "
                        "'ridge'") from None
                Rk = sla.solve_triangular(L, B.T, lower=True).T  # B L^-T: K = Rk Rk'
                R = Rk
                if self.Q0 is not None:  # sandwich K Q0 K = Rk (Rk'Q0 Rk) Rk'
                    T = Rk.T @ (self.Q0 @ Rk)
                    lam, V = np.linalg.eigh(0.5 * (T + T.T))
                    R = Rk @ (V * np.sqrt(np.maximum(lam, 0.0)))
                self._factors = (R, Rk, B.shape[1])
        return self._factors or None

    def _null_basis(self, basis_bytes: int):
        """Orthonormal basis (M, p) of null(A): the range of the orthogonal projector onto
        it, sampled with random vectors (batches until one adds no direction); None when it
        would exceed ``basis_bytes``."""
        M, m = self.M, self.m
        budget = basis_bytes // 8
        if m == 0:
            return np.eye(M) if M * M <= budget else None
        if M * 2 * BASIS_BATCH > budget:
            return None
        I = sp.identity(M, format="csc")
        A = self.A
        pre = None
        if self._cache is not None:
            pre = S._preconditioner(I, A, S.KKT_SIGMA, S.KKT_DELTA, self._coords,
                                    self._cache.setdefault("statistics_cholesky", {}))
        if pre is None:
            pre = S._preconditioner(I, A, S.KKT_SIGMA, S.KKT_DELTA)
        if pre is None:  # pragma: no cover - I + A'A/delta is positive definite
            return None
        KI = sp.bmat([[I, A.T], [A, None]], format="csr")
        rng = np.random.default_rng(20101)
        basis = np.empty((M, 0))
        size = BASIS_BATCH
        tol = 1e-8 * np.sqrt(M)
        while True:
            if (basis.shape[1] + 2 * size) * M > budget:
                return None
            Y = _refine(pre, KI, rng.standard_normal((M, size)), M)
            if Y is None:  # pragma: no cover
                return None
            for _ in range(2):
                Y -= basis @ (basis.T @ Y)
            Qy, Ry = np.linalg.qr(Y)
            U, sv, _ = np.linalg.svd(Ry)
            new = sv > tol
            basis = np.hstack([basis, Qy @ U[:, new]])
            if not new.any():
                return basis
            if new.sum() < size:
                size = 8  # nearly exhausted: confirm with a few more samples


def _refine(pre, K, V: np.ndarray, M: int):
    """Solve ``K [U; nu] = [V; 0]`` for many right-hand sides V (M, k) with the approximate
    inverse ``pre``: iterative refinement (then GMRES per column if that stalls). Returns U,
    or None when it does not converge."""
    k = V.shape[1]
    n = K.shape[0]
    rhs = np.zeros((n, k))
    rhs[:M] = V
    with np.errstate(all="ignore"):
        Z = pre(rhs).reshape(n, k)
        last = np.inf
        for _ in range(REFINE_MAXITER):
            dZ = pre(rhs - K @ Z).reshape(n, k)
            Z += dZ
            step = np.abs(dZ[:M]).max(axis=0) / np.maximum(np.abs(Z[:M]).max(axis=0), 1e-300)
            worst = float(step.max()) if k else 0.0
            if not np.isfinite(worst) or worst <= REFINE_TOL or worst >= 0.5 * last:
                break
            last = worst
        slow = np.nonzero(~(step <= REFINE_ACCEPT))[0] if k else []
        if len(slow):
            op = spla.LinearOperator(K.shape, matvec=pre, dtype=float)
            for c in slow:
                z2, _ = spla.gmres(K, rhs[:, c], x0=Z[:, c], M=op, rtol=1e-14, atol=0.0,
                                   restart=60, maxiter=20)
                if np.all(np.isfinite(z2)):
                    r = pre(rhs[:, c] - K @ z2)
                    step[c] = np.abs(r[:M]).max() / max(np.abs(z2[:M]).max(), 1e-300)
                    Z[:, c] = z2
    if not np.all(np.isfinite(Z[:M])) or not np.all(step <= REFINE_ACCEPT):
        return None
    return np.ascontiguousarray(Z[:M])
