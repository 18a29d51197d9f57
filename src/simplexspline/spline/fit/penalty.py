"""Regularised fitting: smoothness-energy and ridge penalties in B-form, weight by GCV.

The penalised estimator is

    minimise (y - X c)' W (y - X c) + lam * c' P c    subject to    H c = 0,

with P block diagonal (one d_hat x d_hat block per simplex):

- ``'energy'`` (thin plate): ``c' P c = sum_t int_t sum_{k,l} (d^2 s / dx_k dx_l)^2 dx``, the
  squared Frobenius norm of the Hessian integrated exactly over every simplex;
- ``'membrane'``: ``sum_t int_t |grad s|^2 dx``;
- ``'ridge'``: ``c' c``.

The energies are exact in the B-form. Derivatives are de Casteljau differences: with
``a^(k)`` the barycentric direction coordinates of the unit vector ``e_k``,

    d^m p / dx_k1 .. dx_km = d!/(d-m)! * sum_{|kappa|=d-m} (sum_{i1..im} a^(k1)_i1 .. a^(km)_im
                              c_{kappa + e_i1 + .. + e_im}) B^{d-m}_kappa,

and the Gram matrix of the Bernstein polynomials on a simplex t has the closed form

    int_t B^d_alpha B^d_beta dx = vol(t) * (d!)^2 (alpha+beta)! / (alpha! beta! (2d)!)
                                  / C(2d+n, n).

The weight ``lam`` is given, or chosen by generalized cross-validation
(:mod:`simplexspline.spline.fit.gcv`: :func:`choose_smoothing`); :func:`solve_penalized` fits
with either.
"""

from __future__ import annotations

import itertools
from functools import lru_cache
from math import comb, factorial

import numpy as np

from simplexspline.errors import InputError, InsufficientDataError
from simplexspline.spline import kernels
from simplexspline.spline.geometry.barycentric import direction_coordinates
from simplexspline.spline.bform import multi_index_lookup, multi_indices, num_basis

from simplexspline.spline.fit.gcv import (
    DEFAULT_PROBES,
    DENSE_MAX,
    Regularization,
    gcv_evaluator,
    penalty_scale,
    choose_smoothing,
    effective_dof,
    gcv_score,
)
from simplexspline.spline.geometry.barycentric import simplex_transforms, simplex_volumes
from simplexspline.spline.fit.constrained import DEFAULT_RIDGE, POLICIES, solve_constrained

__all__ = [
    "PENALTIES",
    "Regularization",
    "bernstein_gram",
    "choose_smoothing",
    "effective_dof",
    "energy_blocks",
    "energy_matrix",
    "gcv_score",
    "penalty_blocks",
    "solve_penalized",
]

#: Penalty kinds: second-derivative (thin-plate) energy, first-derivative energy, ridge.
PENALTIES = ("energy", "membrane", "ridge")

#: Simplices per batch when assembling energy blocks (bounds temporary memory).
_CHUNK = 2048


# ----------------------------------------------------------------------------- B-form energy
@lru_cache(maxsize=64)
def _gram(n: int, d: int) -> np.ndarray:
    kap = np.asarray(multi_indices(n, d))
    fact = np.array([float(factorial(k)) for k in range(2 * d + 1)])
    kf = np.prod(fact[kap], axis=1)
    joint = np.prod(fact[kap[:, None, :] + kap[None, :, :]], axis=2)
    g = (factorial(d) ** 2 / (factorial(2 * d) * comb(2 * d + n, n))) * joint / np.outer(kf, kf)
    g.setflags(write=False)
    return g


def bernstein_gram(n: int, d: int, volume: float = 1.0) -> np.ndarray:
    """Gram matrix of the degree-``d`` Bernstein polynomials on an n-simplex.

    Parameters
    ----------
    n : int
        Dimension, ``n >= 1``.
    d : int
        Degree, ``d >= 0``.
    volume : float
        Volume of the simplex (the matrix scales with it).

    Returns
    -------
    ndarray, shape (d_hat, d_hat)
        ``int_t B_alpha B_beta dx`` in Eq. 11 order.

    Examples
    --------
    >>> g = bernstein_gram(2, 1)
    >>> bool(np.isclose(g.sum(), 1.0))   # the basis sums to 1: integral of 1 = volume
    True
    >>> (12 * g).round(12).tolist()
    [[2.0, 1.0, 1.0], [1.0, 2.0, 1.0], [1.0, 1.0, 2.0]]
    """
    if n < 1 or d < 0:
        raise InputError(f"bernstein_gram needs n >= 1 and d >= 0, got n={n}, d={d}")
    return volume * _gram(int(n), int(d))


@lru_cache(maxsize=64)
def _difference_factor(n: int, d: int, m: int) -> np.ndarray:
    """``R E_t`` for every m-tuple t of barycentric directions: shape ((n+1)^m, dh_m, dh).

    ``E_t`` maps degree-d coefficients to the degree-(d-m) coefficients
    ``c_{kappa + e_t1 + .. + e_tm}``; ``R`` is the upper Cholesky factor of the normalised
    degree-(d-m) Gram matrix (``G = R'R``), so that ``|R E_t c|^2`` integrates squares.
    """
    low = np.asarray(multi_indices(n, d - m))
    tuples = np.array(list(itertools.product(range(n + 1), repeat=m)), dtype=np.int64)
    add = np.zeros((len(tuples), n + 1), dtype=np.int64)
    for s in range(m):
        add[np.arange(len(tuples)), tuples[:, s]] += 1
    pos = multi_index_lookup(low[None, :, :] + add[:, None, :], d)  # (T, dh_m)
    R = np.linalg.cholesky(_gram(n, d - m)).T
    out = np.zeros((len(tuples), len(low), num_basis(n, d)))
    for t in range(len(tuples)):
        out[t][:, pos[t]] = R
    out.setflags(write=False)
    return out


def _energy(tinv: np.ndarray, volumes: np.ndarray, d: int, m: int) -> np.ndarray:
    """Energy blocks (J, dh, dh) from inverse edge matrices (J, n, n) and volumes (J,)."""
    nsimp, n, _ = tinv.shape
    dh = num_basis(n, d)
    out = np.zeros((nsimp, dh, dh))
    if m > d or nsimp == 0:
        return out
    F = _difference_factor(n, d, m)
    T, dhm, _ = F.shape
    F2 = F.reshape(T, dhm * dh)
    const = (factorial(d) / factorial(d - m)) ** 2
    for s in range(0, nsimp, _CHUNK):
        L = direction_coordinates(tinv[s:s + _CHUNK])  # (c, n, n+1)
        Lm = L
        for _ in range(m - 1):  # Kronecker powers: rows (k1..km), columns (i1..im)
            Lm = np.einsum("cab,cij->caibj", Lm, L).reshape(
                len(L), Lm.shape[1] * n, Lm.shape[2] * (n + 1))
        A = np.matmul(Lm, F2).reshape(len(L), -1, dh)  # (c, n^m * dh_m, dh)
        out[s:s + _CHUNK] = np.matmul(A.transpose(0, 2, 1), A)
    out *= (const * volumes)[:, None, None]
    return out


def energy_matrix(vertices, degree: int, order: int = 2) -> np.ndarray:
    """Derivative energy of a polynomial on one simplex, as a matrix in its B-coefficients.

    Parameters
    ----------
    vertices : array_like, shape (n + 1, n)
        The simplex's vertices, in its local order.
    degree : int
        Polynomial degree d.
    order : int, default 2
        Derivative order m: 2 gives ``int_t sum_{k,l} (d^2 p/dx_k dx_l)^2 dx`` (thin-plate
        energy, the squared Frobenius norm of the Hessian), 1 gives ``int_t |grad p|^2 dx``.

    Returns
    -------
    ndarray, shape (d_hat, d_hat)
        Symmetric positive semi-definite E with ``c' E c`` the energy; its null space is
        the polynomials of degree < m.

    Examples
    --------
    >>> E = energy_matrix([[0, 0], [1, 0], [0, 1]], degree=2)
    >>> c = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])   # p = y^2 on the unit triangle
    >>> float(np.round(c @ E @ c, 12))                   # int (p_yy)^2 = 4 * area
    2.0
    """
    v = np.asarray(vertices, dtype=float)
    if v.ndim != 2 or v.shape[0] != v.shape[1] + 1:
        raise InputError(f"vertices must have shape (n+1, n), got {v.shape}")
    _check_order(order, degree)
    _, tinv, sine = simplex_transforms(v[None])
    if sine[0] <= 0:
        raise InputError("the simplex is degenerate (zero volume)")
    return _energy(tinv, simplex_volumes(v[None]), int(degree), int(order))[0]


def energy_blocks(triangulation, degree: int, order: int = 2) -> np.ndarray:
    """Per-simplex energy matrices (see :func:`energy_matrix`) of a triangulation.

    Parameters
    ----------
    triangulation : Triangulation
    degree : int
    order : int, default 2

    Returns
    -------
    ndarray, shape (J, d_hat, d_hat)
    """
    _check_order(order, degree)
    with kernels.one_blas_thread():
        return _energy(triangulation._tinv, triangulation.volumes(), int(degree), int(order))


def _check_order(order, degree) -> None:
    if int(order) not in (1, 2) or int(order) != order:
        raise InputError(f"the energy's derivative order must be 1 or 2, got {order!r}")
    if degree < order:
        raise InputError(
            f"a degree-{degree} spline has no order-{order} energy (its derivatives of order "
            f"{order} vanish): use penalty='ridge'" + (" or 'membrane'" if degree >= 1 else ""))


def penalty_blocks(triangulation, degree: int, penalty="energy", *,
                   width: int | None = None) -> np.ndarray:
    """Penalty blocks P_t (J, d_hat, d_hat) of a named kind, or validated custom blocks.

    Parameters
    ----------
    triangulation : Triangulation
    degree : int
    penalty : {'energy', 'membrane', 'ridge'} or array_like, shape (J, d_hat, d_hat)
        See the module docstring. Custom blocks must be symmetric positive semi-definite.
    width : int, optional
        Size of custom blocks when it is not d_hat (varying-coefficient splines: K d_hat).

    Returns
    -------
    ndarray, shape (J, d_hat, d_hat)
    """
    nsimp = triangulation.nsimplex
    dh = num_basis(triangulation.ndim, degree)
    if isinstance(penalty, str):
        if penalty == "energy":
            return energy_blocks(triangulation, degree, 2)
        if penalty == "membrane":
            return energy_blocks(triangulation, degree, 1)
        if penalty == "ridge":
            return np.broadcast_to(np.eye(dh), (nsimp, dh, dh)).copy()
        raise InputError(f"penalty must be one of {PENALTIES} or an array of blocks, "
                         f"got {penalty!r}")
    P = np.asarray(penalty, dtype=float)
    dh = dh if width is None else int(width)
    if P.shape != (nsimp, dh, dh):
        raise InputError(f"penalty blocks must have shape (J, d_hat, d_hat) = "
                         f"{(nsimp, dh, dh)}, got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise InputError("penalty blocks contain NaN or inf")
    if not np.allclose(P, P.transpose(0, 2, 1), rtol=1e-10, atol=1e-12 * np.abs(P).max()):
        raise InputError("penalty blocks must be symmetric")
    return P


# ----------------------------------------------------------------------------- penalised fit
def solve_penalized(ne, system, *, penalty="energy", smoothing="gcv",
                    on_insufficient: str = "raise", ridge: float | None = None,
                    method: str = "auto", probes: int = DEFAULT_PROBES):
    """Fit with a penalty: minimise ``(y-Xc)'W(y-Xc) + lam c'Pc`` s.t. ``H c = 0``.

    Parameters
    ----------
    ne : NormalEquations
    system : SmoothnessSystem
    penalty : {'energy', 'membrane', 'ridge'} or ndarray, shape (J, d_hat, d_hat)
        Penalty kind (see the module docstring) or custom blocks.
    smoothing : 'gcv' or float
        'gcv' chooses the weight (:func:`choose_smoothing`); a float >= 0 is the relative
        weight (``lam = smoothing * tr(X'WX) / tr(P)``).
    on_insufficient, ridge
        As in :func:`~simplexspline.spline.fit.constrained.solve_constrained` (the ridge is an extra
        fixed regularisation, relative to the mean diagonal of X'WX).
    method, probes
        How edf is computed (:func:`choose_smoothing`). With a float ``smoothing``, edf is
        computed only when the exact method applies (else NaN).

    Returns
    -------
    coefficients : ndarray, shape (J, d_hat)
    info : SolveInfo
        With ``info.regularization`` a :class:`Regularization`.
    """
    if on_insufficient not in POLICIES:
        raise InputError(f"on_insufficient must be one of {POLICIES}, got {on_insufficient!r}")
    if ridge is not None and (not np.isfinite(ridge) or ridge < 0):
        raise InputError(f"ridge must be a finite number >= 0, got {ridge!r}")
    tri = ne.triangulation
    cache = getattr(system, "solver_cache", None)
    name = penalty if isinstance(penalty, str) else "custom"
    if isinstance(penalty, str) and cache is not None:
        store = cache.setdefault("penalty_blocks", {})
        if penalty not in store:
            store[penalty] = penalty_blocks(tri, ne.degree, penalty)
        P = store[penalty]
    else:
        P = penalty_blocks(tri, ne.degree, penalty, width=ne.XtWX.shape[1])
    if ne.npoints == 0 or not np.any(ne.wsum > 0):
        raise InsufficientDataError(
            "no data (or only zero weights) to fit: add data points",
            np.arange(tri.nsimplex), ne.counts)
    r = ridge if ridge is not None else (DEFAULT_RIDGE if on_insufficient == "ridge" else 0.0)
    dh = P.shape[1]
    diag_mean = float(np.einsum("jkk->", ne.XtWX) / max(int((ne.counts > 0).sum()) * dh, 1))
    ridge_abs = float(r) * diag_mean
    if isinstance(smoothing, str):
        if smoothing != "gcv":
            raise InputError(f"smoothing must be 'gcv' or a number >= 0, got {smoothing!r}")
        reg = choose_smoothing(ne, system, P, ridge_abs=ridge_abs, method=method,
                               probes=probes, penalty_name=name)
    else:
        try:
            s = float(smoothing)
        except (TypeError, ValueError):
            raise InputError(
                f"smoothing must be 'gcv' or a number >= 0, got {smoothing!r}") from None
        if not np.isfinite(s) or s < 0:
            raise InputError(f"smoothing must be 'gcv' or a number >= 0, got {smoothing!r}")
        scale = penalty_scale(ne, P)
        reg = Regularization(penalty=name, smoothing=s, lam=s * scale, scale=scale,
                             npoints=int(ne.npoints))
        if method == "exact" or (method == "auto" and system.nglobal <= DENSE_MAX) or (
                method == "hutchinson"):
            ev = gcv_evaluator(ne, system, P, ridge_abs, method, probes, 0)
            with kernels.one_blas_thread():
                rss, reg.edf, reg.edf_std = ev.evaluate(reg.lam)
            reg.gcv = gcv_score(rss, reg.edf, reg.npoints)
            reg.method, reg.n_dropped = ev.method, ev.n_dropped
    coef, info = solve_constrained(ne, system, on_insufficient=on_insufficient, ridge=ridge,
                                   penalty=reg.lam * P if reg.lam > 0 else None)
    reg.rss = info.rss
    info.regularization = reg
    return coef, info


def fit_penalty(spline):
    """Absolute penalty blocks ``lam * P`` of a penalised fit (from
    ``spline.info.regularization``; the blocks from the space's solver cache when
    :func:`solve_penalized` stored them there), or None for an unpenalised fit."""
    reg = getattr(spline.info, "regularization", None) if spline.info is not None else None
    lam = float(getattr(reg, "lam", 0.0) or 0.0) if reg is not None else 0.0
    if not lam > 0:
        return None
    kind = getattr(reg, "penalty", None)
    if kind not in PENALTIES:
        raise InputError(f"the spline was fitted with a {kind!r} penalty: pass its absolute "
                         "blocks, penalty=lam * blocks, to with_statistics")
    cache = getattr(spline.space.system, "solver_cache", None)
    store = cache.get("penalty_blocks", {}) if cache is not None else {}
    blocks = store.get(kind)
    if blocks is None:
        blocks = penalty_blocks(spline.triangulation, spline.degree, kind)
    return lam * blocks
