"""The B-form of polynomials on a simplex: multi-indices, basis values, de Casteljau.

A polynomial of total degree ``d`` on an n-simplex is written in barycentric coordinates
``b = (b_0, ..., b_n)`` as (paper Eq. 14-16)

    p(b) = sum_{|kappa| = d} c_kappa B_kappa(b),    B_kappa(b) = d!/kappa! * b^kappa,

with the multi-indices ``kappa`` sorted as in the paper's Eq. 11 (descending lexicographic
order: ``(d,0,..,0)`` first, ``(0,..,0,d)`` last). All kernels here are vectorised over
points and take plain arrays.
"""

from __future__ import annotations

from functools import lru_cache
from itertools import combinations
from math import comb, factorial

import numpy as np

from simplexspline.errors import InputError

__all__ = [
    "multi_indices",
    "num_basis",
    "basis_values",
    "de_casteljau",
    "de_casteljau_step",
    "bnet_points",
    "multi_index_lookup",
]


def num_basis(n: int, d: int) -> int:
    """Number of B-form basis polynomials, d_hat = (d+n)! / (n! d!) (paper Eq. 12).

    Parameters
    ----------
    n : int
        Spatial dimension (number of barycentric coordinates minus one).
    d : int
        Total degree, ``d >= 0``.
    """
    return comb(d + n, n)


@lru_cache(maxsize=256)
def _multi_indices(n: int, d: int) -> np.ndarray:
    # Stars and bars: choose the positions of n bars among d + n slots; enumerate in
    # descending lexicographic order of kappa.
    out = np.empty((comb(d + n, n), n + 1), dtype=np.int64)
    for row, bars in enumerate(combinations(range(d + n), n)):
        prev = -1
        for i, bar in enumerate(bars):
            out[row, i] = bar - prev - 1
            prev = bar
        out[row, n] = d + n - prev - 1
    # combinations() yields kappa_0 ascending; Eq. 11 wants descending lexicographic.
    order = np.lexsort(-out.T[::-1])
    out = out[order]
    out.setflags(write=False)
    return out


def multi_indices(n: int, d: int) -> np.ndarray:
    """All multi-indices ``kappa`` with ``|kappa| = d`` in ``n + 1`` components.

    Parameters
    ----------
    n : int
        Spatial dimension, ``n >= 1``.
    d : int
        Total degree, ``d >= 0``.

    Returns
    -------
    ndarray of int, shape (d_hat, n + 1)
        Rows sorted as the paper's Eq. 11: ``(d,0,...,0) > (d-1,1,0,...) > ... > (0,...,0,d)``.
        The array is read-only and cached.

    Examples
    --------
    >>> multi_indices(2, 2).tolist()
    [[2, 0, 0], [1, 1, 0], [1, 0, 1], [0, 2, 0], [0, 1, 1], [0, 0, 2]]
    """
    if n < 1 or d < 0:
        raise InputError(f"multi_indices needs n >= 1 and d >= 0, got n={n}, d={d}")
    return _multi_indices(int(n), int(d))


#: Largest dense code table of :func:`multi_index_lookup` (entries); beyond it (many
#: variables), positions are computed by the combinatorial rank formula instead.
LOOKUP_TABLE_MAX = 1 << 22


@lru_cache(maxsize=256)
def _lookup(n: int, d: int) -> tuple[np.ndarray, np.ndarray]:
    # Encode a multi-index as an integer in base (d + 1) over its first n components
    # (the last is implied); a dense table maps codes back to positions.
    kap = _multi_indices(n, d)
    weights = (d + 1) ** np.arange(n, dtype=np.int64)
    codes = kap[:, :n] @ weights
    table = np.full((d + 1) ** n, -1, dtype=np.int64)
    table[codes] = np.arange(len(kap))
    table.setflags(write=False)
    weights.setflags(write=False)
    return table, weights


@lru_cache(maxsize=64)
def _binomials(top: int, k: int) -> np.ndarray:
    """C(a, b) for 0 <= a <= top, 0 <= b <= k (zero where a < b), int64."""
    out = np.array([[comb(a, b) for b in range(k + 1)] for a in range(top + 1)],
                   dtype=np.int64)
    out.setflags(write=False)
    return out


def _rank(kappa: np.ndarray, d: int) -> np.ndarray:
    """Eq. 11 positions by counting the multi-indices that precede each one: with
    ``s_i = d - kappa_0 - ... - kappa_{i-1}``, those that agree up to component i and are
    larger there number C(s_i - kappa_i + n - i - 1, n - i) (hockey-stick identity)."""
    n = kappa.shape[-1] - 1
    binom = _binomials(d + n, n)
    rem = d - np.cumsum(kappa[..., :n], axis=-1) + kappa[..., :n]  # s_i
    i = np.arange(n)
    return binom[rem - kappa[..., :n] + n - i - 1, n - i].sum(axis=-1)


def multi_index_lookup(kappa: np.ndarray, d: int) -> np.ndarray:
    """Positions (in Eq. 11 order) of multi-indices ``kappa`` of degree ``d``.

    Parameters
    ----------
    kappa : array_like of int, shape (..., n + 1)
        Multi-indices with ``sum(kappa, axis=-1) == d`` and non-negative entries.
    d : int
        Their degree.

    Returns
    -------
    ndarray of int, shape (...)
    """
    kappa = np.asarray(kappa, dtype=np.int64)
    n = kappa.shape[-1] - 1
    if (d + 1) ** n > LOOKUP_TABLE_MAX:
        return _rank(kappa, d)
    table, weights = _lookup(n, d)
    return table[kappa[..., :n] @ weights]


@lru_cache(maxsize=256)
def scale_factors(n: int, d: int) -> np.ndarray:
    """The B-form scale factors d!/kappa! in Eq. 11 order."""
    kap = _multi_indices(n, d)
    fact = np.array([factorial(k) for k in range(d + 1)], dtype=float)
    scale = factorial(d) / np.prod(fact[kap], axis=1)
    scale.setflags(write=False)
    return scale


@lru_cache(maxsize=256)
def monomial_plan(n: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Monomial b^kappa (|kappa| = k) = b^(kappa - e_f) * b_f with f its first non-zero slot.

    Returns (parent positions in the degree k-1 list, f) for every degree-k multi-index.
    """
    cur = _multi_indices(n, k)
    first = np.argmax(cur > 0, axis=1)
    parent = multi_index_lookup(cur - np.eye(n + 1, dtype=np.int64)[first], k - 1)
    parent.setflags(write=False)
    first.setflags(write=False)
    return parent, first


@lru_cache(maxsize=256)
def step_table(n: int, d: int) -> np.ndarray:
    """Index table for one de Casteljau step from degree d to d - 1.

    Row k (a multi-index of degree d - 1) holds the positions of kappa_k + e_i, i = 0..n,
    in the degree-d ordering.
    """
    low = _multi_indices(n, d - 1)
    up = low[:, None, :] + np.eye(n + 1, dtype=np.int64)[None, :, :]
    table = multi_index_lookup(up, d)
    table.setflags(write=False)
    return table


def basis_values(b: np.ndarray, d: int) -> np.ndarray:
    """Values of all degree-``d`` B-form basis polynomials (paper Eq. 14).

    Parameters
    ----------
    b : array_like, shape (N, n + 1)
        Barycentric coordinates (any real values; outside the simplex some are negative).
    d : int
        Degree, ``d >= 0``.

    Returns
    -------
    ndarray, shape (N, d_hat)
        ``B[i, k] = d!/kappa_k! * prod_j b[i, j] ** kappa_k[j]``, columns in Eq. 11 order.
        Rows sum to ``(sum_j b[i, j]) ** d`` (1 for barycentric coordinates).
    """
    b = np.asarray(b, dtype=float)
    if b.ndim != 2:
        raise InputError(f"b must have shape (N, n+1), got {b.shape}")
    return basis_values_t(b.T, d).T


def basis_values_t(bt: np.ndarray, d: int) -> np.ndarray:
    """Transposed basis values: ``bt`` of shape (n + 1, N) gives (d_hat, N).

    The transposed layout keeps each basis function contiguous over points, which is what
    the per-simplex Gram products want. Built degree by degree: the degree-k monomials are
    the degree-(k-1) ones times one barycentric coordinate, so each basis value costs one
    multiplication plus the final scaling.
    """
    n = bt.shape[0] - 1
    npts = bt.shape[1]
    if d == 0:
        return np.ones((1, npts))
    mono = bt.copy()  # degree 1: b_i
    for k in range(2, d + 1):
        parent, first = monomial_plan(n, k)
        nxt = np.empty((len(parent), npts))
        np.multiply(mono[parent], bt[first], out=nxt)
        mono = nxt
    mono *= scale_factors(n, d)[:, None]
    return mono


def de_casteljau_step(c: np.ndarray, lam: np.ndarray, d: int) -> np.ndarray:
    """One de Casteljau step: degree-``d`` coefficients to degree ``d - 1``.

    ``c1[kappa] = sum_i lam_i * c[kappa + e_i]`` for ``|kappa| = d - 1``. With ``lam`` the
    barycentric coordinates of a point this is the classical subdivision step; with ``lam``
    the barycentric *direction* coordinates of a vector ``u`` (summing to zero), ``d`` times
    the result is the B-form of the directional derivative along ``u``.

    Parameters
    ----------
    c : ndarray, shape (..., d_hat(d))
    lam : ndarray, shape (..., n + 1), broadcastable against ``c``'s leading axes
    d : int, ``d >= 1``

    Returns
    -------
    ndarray, shape (..., d_hat(d - 1))
    """
    n = lam.shape[-1] - 1
    table = step_table(n, d)
    return np.einsum("...ki,...i->...k", c[..., table], lam)


def de_casteljau(c: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Evaluate B-form polynomials by the de Casteljau algorithm.

    Parameters
    ----------
    c : array_like, shape (N, d_hat) or (d_hat,)
        B-coefficients in Eq. 11 order (one row per point, or one polynomial for all).
    b : array_like, shape (N, n + 1)
        Barycentric coordinates.

    Returns
    -------
    ndarray, shape (N,)
    """
    c = np.asarray(c, dtype=float)
    b = np.asarray(b, dtype=float)
    if b.ndim != 2 or c.ndim not in (1, 2) or (c.ndim == 2 and c.shape[0] != b.shape[0]):
        raise InputError(f"de_casteljau needs c of shape (N, d_hat) or (d_hat,) and b of shape "
                         f"(N, n+1) with matching rows, got {c.shape} and {b.shape}")
    n = b.shape[-1] - 1
    dhat = c.shape[-1]
    d = _degree_of(n, dhat)
    c = np.broadcast_to(c, b.shape[:-1] + (dhat,))
    for k in range(d, 0, -1):
        c = de_casteljau_step(c, b, k)
    return c[..., 0]


def _degree_of(n: int, dhat: int) -> int:
    d = 0
    while comb(d + n, n) < dhat:
        d += 1
    if comb(d + n, n) != dhat:
        raise InputError(f"{dhat} coefficients is not a B-form size d_hat = C(d+n, n) for n={n}")
    return d


def bnet_points(simplex_vertices: np.ndarray, d: int) -> np.ndarray:
    """Spatial positions of the B-coefficients, the B-net (paper Eq. 17).

    Parameters
    ----------
    simplex_vertices : array_like, shape (n + 1, n) or (J, n + 1, n)
        Vertices of one simplex or of J simplices (in their local vertex order).
    d : int
        Degree.

    Returns
    -------
    ndarray, shape (d_hat, n) or (J, d_hat, n)
        ``sum_i kappa_i v_i / d`` for every multi-index (for ``d = 0``: the centroid).
    """
    v = np.asarray(simplex_vertices, dtype=float)
    n = v.shape[-1]
    kap = multi_indices(n, d).astype(float)
    weights = kap / d if d > 0 else np.full((1, n + 1), 1.0 / (n + 1))
    return np.einsum("ki,...in->...kn", weights, v)
