"""Invariances and input conventions: vertex order inside simplices, global vertex numbering,
simplex order, array-likes, memory layouts and dtypes, large coordinate offsets."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from simplexspline import SimplexSpline, Triangulation

from . import reference as ref
from .cases import data_in_simplices, make_triangulation, seeded, smooth_function


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 3), d=st.integers(1, 4), data=st.data())
def test_numbering_does_not_change_the_fit(seed, n, d, data):
    """Permuting the local vertex order in each simplex, the global vertex numbering and the
    order of the simplices changes nothing but the bookkeeping (paper Eq. 21)."""
    r = data.draw(st.integers(0, d - 1), label="r")
    kind = data.draw(st.sampled_from(["explicit", "grid", "delaunay"]), label="kind")
    rng = np.random.default_rng(seed)
    tri = make_triangulation(kind, n, rng)
    x, _ = data_in_simplices(tri, ref.num_basis(n, d) + 3, rng)
    y = smooth_function(2 * x) + 0.05 * rng.standard_normal(len(x))
    s = SimplexSpline.fit(x, y, tri, d, r)

    V, S = tri.vertices, tri.simplices
    vperm = rng.permutation(len(V))  # new id of old vertex i is inv[i]
    inv = np.empty_like(vperm)
    inv[vperm] = np.arange(len(V))
    S2 = inv[S]
    S2 = np.array([row[rng.permutation(n + 1)] for row in S2])
    S2 = S2[rng.permutation(len(S2))]
    tri2 = Triangulation(V[vperm], S2)
    s2 = SimplexSpline.fit(x, y, tri2, d, r)
    xt, _ = data_in_simplices(tri, 3, rng)
    scale = np.abs(s.predict(xt)).max()
    np.testing.assert_allclose(s2.predict(xt), s.predict(xt), rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(s2.gradient(xt), s.gradient(xt), rtol=0,
                               atol=1e-8 * np.abs(s.gradient(xt)).max())


@pytest.fixture(scope="module")
def fitted():
    rng = seeded("conventions")
    tri = Triangulation.grid([0, 0, 0], [1, 2, 3], (2, 2, 2))
    x, _ = data_in_simplices(tri, 15, rng)
    s = SimplexSpline.fit(x, smooth_function(x), tri, 2, 1)
    xt, _ = data_in_simplices(tri, 2, rng)
    return s, xt


def test_array_likes_layouts_and_dtypes(fitted):
    s, xt = fitted
    expected = s.predict(xt)
    np.testing.assert_array_equal(s.predict(xt.tolist()), expected)
    np.testing.assert_array_equal(s.predict(np.asfortranarray(xt)), expected)
    big = np.zeros((len(xt), 7))
    big[:, ::2][:, :3] = xt  # a non-contiguous view
    view = big[:, ::2][:, :3]
    assert not view.flags.c_contiguous
    np.testing.assert_array_equal(s.predict(view), expected)
    x32 = xt.astype(np.float32)
    np.testing.assert_allclose(s.predict(x32), s.predict(x32.astype(np.float64)), rtol=1e-12)
    np.testing.assert_array_equal(s.gradient(np.asfortranarray(xt)), s.gradient(xt))
    # integer points (vertices of the grid)
    xi = np.array([[0, 0, 0], [1, 2, 3], [1, 1, 1]])
    np.testing.assert_allclose(s.predict(xi), s.predict(xi.astype(float)), rtol=1e-14)
    # single point, order as a list
    np.testing.assert_allclose(s.predict(xt[:1]), expected[:1])
    np.testing.assert_allclose(s.derivative(xt, [1, 0, 1]), s.derivative(xt, (1, 0, 1)))


def test_gradient_columns_are_first_derivatives(fitted):
    s, xt = fitted
    g = s.gradient(xt)
    for i in range(3):
        order = tuple(int(k == i) for k in range(3))
        np.testing.assert_allclose(g[:, i], s.derivative(xt, order), rtol=1e-12, atol=1e-12)


def test_extrapolate_inside_equals_predict(fitted):
    s, xt = fitted
    np.testing.assert_array_equal(s.predict(xt, outside="extrapolate"), s.predict(xt))
    far = np.array([[1.5, 1.0, 1.0], [-0.5, -0.5, 4.0]])
    assert np.all(np.isfinite(s.predict(far, outside="extrapolate")))


def test_fit_accepts_array_likes():
    rng = seeded("arraylike")
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    x, _ = data_in_simplices(tri, 10, rng)
    y = smooth_function(x)
    a = SimplexSpline.fit(x, y, tri, 2, 1)
    b = SimplexSpline.fit(x.tolist(), y.tolist(), tri, 2, 1, weights=[1.0] * len(y))
    np.testing.assert_allclose(b.coefficients, a.coefficients, rtol=1e-12, atol=1e-14)
    t2 = Triangulation(tri.vertices.tolist(), tri.simplices.tolist())
    np.testing.assert_array_equal(t2.simplices, tri.simplices)


@pytest.mark.parametrize("offset", [1e3, 1e5])
def test_polynomial_reproduction_far_from_origin(offset):
    """Coordinates with a large common offset: barycentric coordinates must be computed
    relative to a vertex, not from raw coordinates."""
    rng = seeded("offset", offset)
    lower = np.array([offset, -offset])
    tri = Triangulation.grid(lower, lower + 1.0, (2, 2))
    x, _ = data_in_simplices(tri, 20, rng)
    p = ref.Poly.random(2, 3, rng, centre=lower + 0.5)
    s = SimplexSpline.fit(x, p(x), tri, 3, 1)
    xt, _ = data_in_simplices(tri, 4, rng)
    err = np.abs(s.predict(xt) - p(xt)).max() / np.abs(p(xt)).max()
    # limited only by the representation of x itself (eps * offset / cell size)
    assert err <= 1e-9 * max(1.0, offset * 1e-3)
