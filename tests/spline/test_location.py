"""Point location off the grid: the compiled walk (WalkLocator) against scipy's qhull
search and brute force, points on shared faces, outside points, non-convex and sliver
triangulations, and the numpy bucket path."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.spatial
from hypothesis import given, settings
from hypothesis import strategies as st

from simplexspline import OutsideDomainError, SplineSpace, Triangulation
from simplexspline.spline import kernels
from simplexspline.spline.geometry.location import INSIDE_TOL, BucketLocator, WalkLocator

from . import reference as ref

needs_numba = pytest.mark.skipif(not kernels.HAVE_NUMBA, reason="the walk is compiled")


def _inside(tri, npts, rng):
    vol = tri.volumes()
    j = rng.choice(tri.nsimplex, npts, p=vol / vol.sum())
    b = rng.dirichlet(np.ones(tri.ndim + 1), npts)
    return np.einsum("ik,ikn->in", b, tri.corners[j])


@needs_numba
@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 6), nv=st.integers(0, 40), seed=st.integers(0, 2**32 - 1))
def test_walk_agrees_with_qhull_find_simplex(n, nv, seed):
    rng = np.random.default_rng(seed)
    pts = rng.random((n + 2 + nv, n))
    dt = scipy.spatial.Delaunay(pts) if n > 1 else None
    tri = Triangulation.delaunay(pts)
    assert isinstance(tri._locator, WalkLocator)
    lo, hi = pts.min(0), pts.max(0)
    x = np.vstack([_inside(tri, 300, rng), rng.uniform(lo - 0.2, hi + 0.2, (300, n))])
    loc = tri.locate(x)
    if dt is not None and tri.nsimplex == dt.nsimplex:
        # qhull's simplices are ours (same order) when none was dropped as flat
        theirs = dt.find_simplex(x)
        b = tri.barycentric(x, np.maximum(loc, 0))
        clear = (b.min(axis=1) > 1e-8) | (loc < 0)  # not near a face: one answer
        np.testing.assert_array_equal(loc[clear], theirs[clear])
    # always: the lowest-index simplex containing the point, as brute force
    np.testing.assert_array_equal(loc, ref.locate(tri.vertices, tri.simplices, x,
                                                  tol=INSIDE_TOL))


@needs_numba
@pytest.mark.parametrize("n", [2, 3, 4])
def test_points_on_shared_faces_get_one_consistent_simplex(n):
    """Facet midpoints, edge points and vertices: the same simplex (the lowest-index one
    containing them) whatever the batch, the order or the neighbouring points."""
    rng = np.random.default_rng(n)
    tri = Triangulation.delaunay(rng.random((12 * n, n)))
    fac = tri.facets
    w = rng.dirichlet(np.ones(n), len(fac))
    on_facets = np.einsum("fk,fkn->fn", w, tri.vertices[fac.vertices])
    edges = 0.5 * (tri.vertices[tri.simplices[:, 0]] + tri.vertices[tri.simplices[:, 1]])
    x = np.vstack([on_facets, edges, tri.vertices])
    expected = ref.locate(tri.vertices, tri.simplices, x, tol=INSIDE_TOL)
    assert np.all(expected >= 0)
    np.testing.assert_array_equal(tri.locate(x), expected)
    perm = rng.permutation(len(x))
    np.testing.assert_array_equal(tri.locate(x[perm]), expected[perm])
    one_by_one = np.array([tri.locate(p[None])[0] for p in x[:50]])
    np.testing.assert_array_equal(one_by_one, expected[:50])
    # the numpy bucket path applies the same rule
    np.testing.assert_array_equal(tri._buckets.locate(x), expected)


@needs_numba
def test_outside_points_follow_the_policy_never_a_kernel_error():
    rng = np.random.default_rng(3)
    pts = rng.random((30, 3))
    tri = Triangulation.delaunay(pts)
    spline = SplineSpace(tri, 2, 1).fit(_inside(tri, 3000, rng), rng.random(3000))
    far = np.array([[5.0, 5.0, 5.0], [-1e300, 0.0, 0.0], [0.5, 0.5, 1e300]])
    beside = rng.uniform(-0.3, 1.3, (200, 3))
    x = np.vstack([far, beside])
    loc = tri.locate(x)
    np.testing.assert_array_equal(loc, ref.locate(tri.vertices, tri.simplices, x,
                                                  tol=INSIDE_TOL))
    assert np.all(loc[:3] == -1)
    out = loc < 0
    assert np.all(np.isnan(spline.predict(x)[out]))
    # extrapolation is finite where the polynomial does not overflow
    assert np.all(np.isfinite(spline.predict(np.delete(x, [1, 2], axis=0),
                                             outside="extrapolate")))
    with pytest.raises(OutsideDomainError, match="outside the triangulation"):
        spline.predict(x, outside="raise")


@needs_numba
def test_non_convex_triangulation_walks_around_the_notch():
    """An L-shaped domain (a Kuhn grid with one cell removed, given explicitly): walks that
    hit the notch's boundary are settled exactly by the bucket search."""
    full = Triangulation.grid([0, 0], [2, 2], (2, 2))
    keep = np.ones(full.nsimplex, dtype=bool)
    keep[full.locate([[1.7, 1.2], [1.2, 1.7]])] = False  # the upper right cell
    tri = Triangulation(full.vertices, full.simplices[keep])
    assert tri.kind == "explicit" and not tri._convex
    assert isinstance(tri._locator, WalkLocator)
    rng = np.random.default_rng(0)
    x = rng.uniform(-0.1, 2.1, (2000, 2))
    np.testing.assert_array_equal(tri.locate(x),
                                  ref.locate(tri.vertices, tri.simplices, x, tol=INSIDE_TOL))
    assert np.any(tri.locate(x) < 0) and np.any(tri.locate(x) >= 0)


def test_delaunay_convexity_flag():
    rng = np.random.default_rng(1)
    tri = Triangulation.delaunay(rng.random((20, 3)))
    assert tri._convex
    # rebuilt from arrays, the flag is recomputed from the volumes
    again = Triangulation.from_arrays(tri.to_arrays())
    assert again._convex
    # a Delaunay triangulation that lost a simplex is not convex
    holed = Triangulation.from_arrays({**tri.to_arrays(), "simplices": tri.simplices[1:]},
                                      check=False)
    assert not holed._convex


@needs_numba
def test_slivers_are_located_and_listed():
    # a flat-ish fourth vertex over a triangle: Delaunay makes slivers
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1e-4], [0.5, 0.5, 1.0],
                  [0.5, 0.5, -1.0]], dtype=float)
    tri = Triangulation.delaunay(V)
    assert len(tri.slivers()) >= 1
    rng = np.random.default_rng(2)
    x = np.vstack([_inside(tri, 500, rng), tri.corners[tri.slivers()].mean(axis=1)])
    np.testing.assert_array_equal(tri.locate(x),
                                  ref.locate(tri.vertices, tri.simplices, x, tol=INSIDE_TOL))


@needs_numba
def test_walk_and_bucket_paths_agree_on_random_points():
    rng = np.random.default_rng(5)
    tri = Triangulation.delaunay(rng.random((200, 3)))
    x = rng.uniform(-0.1, 1.1, (5000, 3))
    bucket = BucketLocator(np.asarray(tri.corners), tri._origin, tri._tinv)
    np.testing.assert_array_equal(tri.locate(x), bucket.locate(x))
