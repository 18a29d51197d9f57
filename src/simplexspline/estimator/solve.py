"""The least-squares solve behind :meth:`SimplexSplineRegressor.fit`.

:func:`solve_outputs` turns the training samples (in model coordinates) into the
B-coefficients of every output on a triangulation:

* one set of Gram blocks is shared by all outputs; only the right-hand sides of further
  outputs differ (``_extra_rhs``);
* on a ``'simplex'`` triangulation (one polynomial) with fewer samples than coefficients,
  the same estimate comes from the N x N dual system (``_solve_dual``);
* on a ``'simplex'`` triangulation the ridge is relative to each coefficient's own Gram
  diagonal (Jacobi-scaled); otherwise :meth:`SplineSpace.solve` applies it.

Private to :mod:`simplexspline.estimator.regressor`, which re-exports these names.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from simplexspline.spline.bform import basis_values, num_basis
from simplexspline.spline.fit.constrained import SolveInfo, solve_constrained
from simplexspline.spline.space import SplineSpace

__all__ = ["solve_outputs"]

#: Rows per chunk when extra outputs' right-hand sides are accumulated.
_CHUNK = 1 << 16


def solve_outputs(tri, kind, U, Y, w, cfg):
    """B-coefficients (one (J, d_hat) array per output) and their SolveInfo."""
    degree, ridge = cfg["degree"], cfg["ridge"]
    dhat = num_basis(tri.ndim, degree)
    if kind == "simplex" and len(U) < dhat:
        return _solve_dual(tri, degree, U, Y, w, ridge)
    space = SplineSpace(tri, degree, cfg["continuity"])
    policy = "ridge" if ridge > 0 else "minnorm"
    kw = {"on_insufficient": policy, "ridge": ridge if ridge > 0 else None}
    ne = space.normal_equations(U, Y[:, 0], w)
    rhs, yty = _extra_rhs(space, U, Y[:, 1:], w)
    coefs, infos = [], []
    for k in range(Y.shape[1]):
        nek = ne
        if k:
            nek = ne.copy()
            nek.XtWy = rhs[:, :, k - 1]
            nek.ytWy = float(yty[k - 1])
        if kind == "simplex" and ridge > 0:
            # One polynomial on a simplex much larger than the data: its Bernstein
            # columns differ in scale by orders of magnitude, so the ridge is relative to
            # each coefficient's own Gram diagonal (Jacobi-scaled, scale invariant).
            diag = np.einsum("jkk->jk", nek.XtWX)
            floor = diag.max() * np.finfo(float).eps
            pen = ridge * np.apply_along_axis(np.diag, 1, np.maximum(diag, floor))
            c, info = solve_constrained(nek, space.system, on_insufficient="minnorm",
                                        penalty=pen)
        else:
            sol = space.solve(nek, **kw)
            c, info = sol.coefficients, sol.info
        coefs.append(c)
        infos.append(info)
    return coefs, infos


def _extra_rhs(space, U, Y, w):
    """X'Wy (J, d_hat, k) and y'Wy (k,) of further outputs (the Gram blocks are shared)."""
    J, dhat, k = space.triangulation.nsimplex, space.nbasis, Y.shape[1]
    acc = np.zeros((J * dhat, k))
    yty = np.zeros(k)
    if k == 0:
        return acc.reshape(J, dhat, 0), yty
    for s in range(0, len(U), _CHUNK):
        D = space.design_matrix(U[s:s + _CHUNK])
        yc = Y[s:s + _CHUNK]
        wy = yc if w is None else yc * w[s:s + _CHUNK, None]
        acc += D.T @ wy
        yty += (wy * yc).sum(axis=0)
    return acc.reshape(J, dhat, k), yty


def _solve_dual(tri, degree: int, U, Y, w, ridge: float):
    """One simplex with fewer samples than coefficients: the same estimate as
    :meth:`SplineSpace.solve` (ridge, or minimum norm when ``ridge`` is 0) from the
    N x N dual system instead of the d_hat x d_hat Gram matrix."""
    n = len(U)
    B = basis_values(tri.barycentric(U, np.zeros(n, dtype=np.int64)), degree)  # (N, d_hat)
    dhat = B.shape[1]
    sw = np.ones(n) if w is None else np.sqrt(w)
    Bw, Yw = B * sw[:, None], Y * sw[:, None]
    sv = np.linalg.svd(Bw, compute_uv=False)
    rank = int((sv > sv[0] * max(Bw.shape) * np.finfo(float).eps).sum())
    lam = ridge * float((Bw ** 2).sum()) / dhat  # ridge * mean(diag X'WX), as the solver
    if lam > 0:
        K = Bw @ Bw.T
        K[np.diag_indices(n)] += lam
        C = Bw.T @ sla.solve(K, Yw, assume_a="pos")
        policy = "ridge"
    else:
        C = np.linalg.lstsq(Bw, Yw, rcond=None)[0]
        policy = "minnorm"
    rss = ((Yw - Bw @ C) ** 2).sum(axis=0)
    nund = dhat - rank
    infos = [SolveInfo(counts=np.array([n]), deficient_simplices=np.array([0]),
                       undetermined_simplices=np.array([0] if nund else [], dtype=np.intp),
                       n_undetermined=nund, policy=policy, ridge=lam, rss=float(r))
             for r in rss]
    return [C[:, k][None, :] for k in range(Y.shape[1])], infos
