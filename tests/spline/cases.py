"""Test-case builders shared by the spline tests: triangulations of every kind and data
inside every simplex."""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest

from simplexspline import Triangulation

from . import reference as ref

KINDS = ("explicit", "delaunay", "grid", "fit")

# Problems costlier than this (J * d_hat**2: per-simplex Gram blocks) are marked slow.
FAST_COST = 20000

# Problems with more coefficients (J * d_hat) than this are left out ("where sizes allow").
MAX_COEFFICIENTS = 16000

# Typical simplex counts of the Delaunay cases (they vary a little with the seed).
DELAUNAY_J = {1: 2, 2: 4, 3: 14, 4: 12, 5: 16, 6: 20}


def seeded(*key) -> np.random.Generator:
    return np.random.default_rng(zlib.crc32(repr(key).encode()))


def grid_shape(n: int) -> tuple:
    if n == 1:
        return (3,)
    if n == 2:
        return (2, 3)
    if n == 3:
        return (2, 1, 1)
    return (1,) * n


def delaunay_points(n: int, rng: np.random.Generator) -> np.ndarray:
    """Points in general position whose Delaunay triangulation has an interior vertex and
    no slivers to speak of."""
    if n <= 3:
        corners = np.array(list(np.ndindex(*(2,) * n)), dtype=float)
        pts = corners + 0.08 * rng.uniform(-1, 1, corners.shape)
        centre = 0.5 + 0.1 * rng.uniform(-1, 1, (1, n))
        return np.vstack([pts, centre])
    simplex = ref.regular_simplex(n, scale=2.0) + 0.05 * rng.standard_normal((n + 1, n))
    inner = rng.dirichlet(np.full(n + 1, 6.0), size=2) @ simplex
    return np.vstack([simplex, inner])


def make_triangulation(kind: str, n: int, rng: np.random.Generator) -> Triangulation:
    if kind == "explicit":
        V, S = ref.star_triangulation(n, rng)
        return Triangulation(V, S)
    if kind == "delaunay":
        return Triangulation.delaunay(delaunay_points(n, rng))
    lower = rng.uniform(-1.0, 0.0, n)
    upper = lower + rng.uniform(1.0, 2.0, n)
    if kind == "grid":
        return Triangulation.grid(lower, upper, grid_shape(n))
    if kind == "fit":
        x0 = rng.uniform(lower, upper, size=(40 * 2**n, n))
        return Triangulation.fit(x0, grid_shape(n))
    raise AssertionError(kind)


def expected_nsimplex(kind: str, n: int) -> int | None:
    if kind == "explicit":
        return n + 1
    if kind in ("grid", "fit"):
        return math.prod(grid_shape(n)) * math.factorial(n)
    return None


def data_in_simplices(tri, per_simplex: int, rng, alpha: float = 1.0):
    return ref.points_in_simplices(tri.vertices, tri.simplices, per_simplex, rng, alpha)


def problem_size(n: int, d: int, kind: str) -> int:
    """Number of B-coefficients J * d_hat of a case."""
    J = expected_nsimplex(kind, n)
    if J is None:
        J = DELAUNAY_J[n]
    return J * ref.num_basis(n, d)


def case_param(n: int, d: int, r: int, kind: str, budget: int = FAST_COST):
    """A pytest.param, marked slow when the problem is large."""
    J = expected_nsimplex(kind, n)
    if J is None:
        J = DELAUNAY_J[n]
    marks = [pytest.mark.slow] if J * ref.num_basis(n, d) ** 2 > budget else []
    return pytest.param(n, d, r, kind, marks=marks, id=f"n{n}-d{d}-r{r}-{kind}")


def smooth_function(x: np.ndarray) -> np.ndarray:
    """A smooth non-polynomial test function of any dimension."""
    x = np.atleast_2d(x)
    return np.exp(0.6 * x[:, 0] - 0.4 * x[:, 1:].sum(1)) * np.cos(0.7 * x[:, 0] + 0.5 * x[:, -1])
