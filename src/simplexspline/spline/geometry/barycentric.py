"""Barycentric coordinates and simplex geometry (vectorised kernels on plain arrays).

For a simplex with vertices ``v_0..v_n`` the affine map ``x = v_0 + T @ (b_1..b_n)`` with
``T = [v_1 - v_0, ..., v_n - v_0]`` gives the barycentric coordinates (paper Eq. 3-4)
``b_1..b_n = T^{-1} (x - v_0)`` and ``b_0 = 1 - sum(b_1..b_n)``.
"""

from __future__ import annotations

from math import factorial

import numpy as np

__all__ = [
    "simplex_transforms",
    "barycentric",
    "direction_coordinates",
    "simplex_volumes",
    "simplex_quality",
]

#: A simplex whose volume is below this fraction of the product of its edge lengths from
#: v_0 is degenerate (the normalised "sine" of its corner at v_0).
DEGENERACY_TOL = 1e-12


def simplex_transforms(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Affine maps of simplices.

    Parameters
    ----------
    corners : ndarray, shape (J, n + 1, n)
        Vertex coordinates of J simplices.

    Returns
    -------
    origin : ndarray, shape (J, n)
        The first vertex of each simplex.
    tinv : ndarray, shape (J, n, n)
        Inverse edge matrices; rows of zeros (and ``inf`` never) for degenerate simplices.
    sine : ndarray, shape (J,)
        ``|det T| / prod |T[:, k]|``: 1 for an orthogonal corner, 0 for a flat simplex.
        Computed as the determinant of the unit edge vectors, so it does not under- or
        overflow at coordinate scales where ``det T`` would (1e-300 or 1e+300).
    """
    origin = corners[:, 0, :]
    edges = np.swapaxes(corners[:, 1:, :] - origin[:, None, :], 1, 2)  # (J, n, n) columns
    if len(edges):
        lengths = np.max(np.abs(edges), axis=1, keepdims=True)       # no overflow in norms
        with np.errstate(divide="ignore", invalid="ignore"):
            unit = np.where(lengths > 0, edges / np.where(lengths > 0, lengths, 1.0), 0.0)
            unit = unit / np.where(lengths > 0, np.linalg.norm(unit, axis=1, keepdims=True),
                                   1.0)
        sine = np.abs(np.linalg.det(unit))
        sine[np.any(lengths[:, 0, :] == 0, axis=1) | ~np.isfinite(sine)] = 0.0
    else:
        sine = np.empty(0)
    tinv = np.zeros_like(edges)
    ok = sine > DEGENERACY_TOL
    if np.any(ok):
        tinv[ok] = np.linalg.inv(edges[ok])
    return origin, tinv, sine


def barycentric(x: np.ndarray, origin: np.ndarray, tinv: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of points with respect to given simplices.

    Parameters
    ----------
    x : ndarray, shape (N, n)
        Points.
    origin : ndarray, shape (N, n)
        First vertex of each point's simplex.
    tinv : ndarray, shape (N, n, n)
        Inverse edge matrix of each point's simplex.

    Returns
    -------
    ndarray, shape (N, n + 1)
    """
    npts, n = x.shape
    b = np.empty((npts, n + 1))
    np.einsum("ikl,il->ik", tinv, x - origin, out=b[:, 1:])
    b[:, 0] = 1.0 - b[:, 1:].sum(axis=1)
    return b


def direction_coordinates(tinv: np.ndarray) -> np.ndarray:
    """Barycentric direction coordinates of the Cartesian unit vectors.

    Parameters
    ----------
    tinv : ndarray, shape (..., n, n)

    Returns
    -------
    ndarray, shape (..., n, n + 1)
        Row ``k`` holds ``b(x + e_k) - b(x)``: the coordinates used by de Casteljau steps to
        differentiate along ``e_k``. Each row sums to zero.
    """
    rows = np.swapaxes(tinv, -1, -2)  # (..., k, i): d b_i / d x_k for i = 1..n
    out = np.empty(tinv.shape[:-2] + (tinv.shape[-1], tinv.shape[-1] + 1))
    out[..., 1:] = rows
    out[..., 0] = -rows.sum(axis=-1)
    return out


def simplex_volumes(corners: np.ndarray) -> np.ndarray:
    """n-dimensional volumes of simplices, shape (J,), from corners (J, n + 1, n)."""
    n = corners.shape[-1]
    edges = corners[:, 1:, :] - corners[:, :1, :]
    return np.abs(np.linalg.det(edges)) / factorial(n)


def simplex_quality(corners: np.ndarray) -> np.ndarray:
    """Normalised radius ratio ``n * r_in / r_circ`` of simplices.

    1 for the regular simplex, tending to 0 for slivers and needles; 0 for degenerate ones.

    Parameters
    ----------
    corners : ndarray, shape (J, n + 1, n)

    Returns
    -------
    ndarray, shape (J,)
    """
    nsimp, np1, n = corners.shape
    if nsimp == 0:
        return np.empty(0)
    edges = corners[:, 1:, :] - corners[:, :1, :]  # (J, n, n), rows are edges
    det = np.abs(np.linalg.det(edges))
    volume = det / factorial(n)
    # Circumcentre c (relative to v_0): 2 e_k . c = |e_k|^2.
    rhs = 0.5 * np.einsum("jkn,jkn->jk", edges, edges)
    ok = det > DEGENERACY_TOL * np.prod(np.linalg.norm(edges, axis=2), axis=1)
    quality = np.zeros(nsimp)
    if not np.any(ok):
        return quality
    centre = np.linalg.solve(edges[ok], rhs[ok][..., None])[..., 0]
    r_circ = np.linalg.norm(centre, axis=1)
    # Inradius r = n V / (sum of facet (n-1)-volumes).
    area = np.zeros((int(ok.sum()),))
    sub = corners[ok]
    for i in range(np1):
        facet = np.delete(sub, i, axis=1)  # (J, n, n)
        fe = facet[:, 1:, :] - facet[:, :1, :]  # (J, n-1, n)
        gram = np.einsum("jan,jbn->jab", fe, fe)
        area += np.sqrt(np.maximum(np.linalg.det(gram), 0.0)) / factorial(n - 1)
    r_in = n * volume[ok] / area
    quality[ok] = n * r_in / r_circ
    return quality
