"""Point location off the grid: the compiled walk (WalkLocator) against scipy's qhull
search and brute force, points on shared faces, outside points, non-convex and sliver
triangulations, and the numpy bucket path."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.spatial
from hypothesis import given, settings
from hypothesis import strategies as st

from simplexspline import OutsideDomainError, SimplexSpline, SplineSpace, Triangulation
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


def _reference_values(spline, x, outside="nan"):
    """The unfused compiled path: location, the outside policy, then evaluation."""
    tri = spline.triangulation
    sid = tri.locate(x)
    if outside == "extrapolate":
        bad = sid < 0
        sid[bad] = tri.nearest(x[bad])
    return kernels.evaluate(np.ascontiguousarray(x, dtype=float), sid, tri._origin,
                            tri._tinv, spline.coefficients, spline.degree)


@needs_numba
@settings(max_examples=20, deadline=None)
@given(n=st.integers(1, 5), d=st.integers(0, 4), nv=st.integers(0, 25),
       seed=st.integers(0, 2**32 - 1))
def test_fused_walk_evaluation_is_location_then_evaluation(n, d, nv, seed):
    """predict's one-pass walk and evaluation gives the numbers of locating first and
    evaluating after, bit for bit: inside, on shared facets and vertices (the lowest-index
    simplex), and outside (NaN, or the nearest simplex's polynomial)."""
    rng = np.random.default_rng(seed)
    pts = rng.random((n + 2 + nv, n))
    tri = Triangulation.delaunay(pts)
    coef = rng.standard_normal((tri.nsimplex, kernels.basis_plan(n, d)[3].size))
    spline = SimplexSpline(tri, d, -1 if d == 0 else 0, coef)
    x = [_inside(tri, 200, rng), rng.uniform(-0.3, 1.3, (100, n)), tri.vertices]
    if n > 1:
        fac = tri.facets
        if len(fac):
            w = rng.dirichlet(np.ones(n), len(fac))
            x.append(np.einsum("fk,fkn->fn", w, tri.vertices[fac.vertices]))
    x = np.vstack(x)
    for outside in ("nan", "extrapolate"):
        fused = spline.predict(x, outside=outside)
        np.testing.assert_array_equal(fused, _reference_values(spline, x, outside))
    # one point at a time (the small-batch path) gives the same numbers
    some = x[rng.choice(len(x), 20)]
    np.testing.assert_array_equal(np.array([spline.predict(p)[0] for p in some]),
                                  spline.predict(some))
    sid, values, unlocated = kernels.walk_evaluate(x, tri._locator.plan, coef, d)
    assert unlocated == np.count_nonzero(sid < 0)
    np.testing.assert_array_equal(np.isnan(values), sid < 0)


@needs_numba
def test_fused_evaluation_settles_walks_stopped_at_a_notch():
    """On a non-convex triangulation the walk hands points stopped at the notch to the
    bucket search; predict then evaluates them in the simplex found there."""
    full = Triangulation.grid([0, 0], [2, 2], (2, 2))
    keep = np.ones(full.nsimplex, dtype=bool)
    keep[full.locate([[1.7, 1.2], [1.2, 1.7]])] = False
    tri = Triangulation(full.vertices, full.simplices[keep])
    rng = np.random.default_rng(4)
    x = rng.uniform(-0.1, 2.1, (3000, 2))
    y = np.sin(x[:, 0]) + x[:, 1] ** 2
    inside = tri.locate(x) >= 0
    spline = SplineSpace(tri, 3, 1).fit(x[inside], y[inside])
    sid, _, unlocated = kernels.walk_evaluate(x, tri._locator.plan, spline.coefficients, 3)
    assert np.any(sid == -2)  # the case under test: walks the kernel could not settle
    np.testing.assert_array_equal(spline.predict(x), _reference_values(spline, x))
    np.testing.assert_array_equal(spline.predict(x, outside="extrapolate"),
                                  _reference_values(spline, x, "extrapolate"))
    with pytest.raises(OutsideDomainError, match="outside the triangulation"):
        spline.predict(x, outside="raise")
    # against the numpy path (de Casteljau through derivative order 0)
    np.testing.assert_allclose(spline.predict(x), spline.derivative(x, (0, 0)), rtol=1e-12,
                               atol=1e-12)
