"""The optional compiled kernels give the same numbers as the numpy implementations."""

from __future__ import annotations

import numpy as np
import pytest

from simplexspline import SimplexSpline, SplineSpace, Triangulation
from simplexspline.spline import kernels
from simplexspline.spline.bform import basis_values_t

pytestmark = pytest.mark.skipif(not kernels.HAVE_NUMBA, reason="numba not installed")


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_grid_locate_matches_numpy(n):
    rng = np.random.default_rng(n)
    shape = (3, 2, 2, 1, 1)[:n]
    tri = Triangulation.fit(rng.random((400, n)) ** 2, shape, min_points=2)
    loc = tri._locator
    lattice = np.stack(np.meshgrid(*[np.linspace(-0.25, 1.25, 7)] * n), -1).reshape(-1, n)
    x = np.vstack([rng.uniform(-0.1, 1.1, (3000, n)), lattice, loc.lower, loc.upper])
    np.testing.assert_array_equal(loc.locate(x), loc.locate_numpy(x))


@pytest.mark.parametrize("n,d", [(1, 1), (2, 3), (3, 4), (5, 3), (6, 2)])
def test_basis_cols_matches_numpy(n, d):
    b = np.random.default_rng(d).dirichlet(np.ones(n + 1), 700).T
    np.testing.assert_allclose(kernels.basis_cols(b, d), basis_values_t(b, d), rtol=1e-14,
                               atol=1e-15)


def test_fit_and_predict_identical_to_numpy_path(monkeypatch):
    rng = np.random.default_rng(7)
    tri = Triangulation.grid(np.zeros(3), np.ones(3), (2, 2, 2))
    x = rng.random((5000, 3))
    y = np.sin(3 * x[:, 0]) + x[:, 1] * x[:, 2]
    space = SplineSpace(tri, 3, 1)
    fast = space.fit(x, y)
    xe = rng.uniform(-0.1, 1.1, (2000, 3))
    pf = fast.predict(xe)
    monkeypatch.setattr(kernels, "HAVE_NUMBA", False)
    slow = space.fit(x, y)
    ps = slow.predict(xe)
    np.testing.assert_allclose(fast.coefficients, slow.coefficients, rtol=1e-11, atol=1e-12)
    np.testing.assert_array_equal(np.isnan(pf), np.isnan(ps))
    np.testing.assert_allclose(pf[~np.isnan(pf)], ps[~np.isnan(ps)], rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("n,d,kind", [(1, 1, "grid"), (2, 1, "delaunay"), (2, 3, "grid"),
                                      (3, 2, "delaunay"), (3, 4, "delaunay"),
                                      (5, 3, "delaunay")])
def test_compiled_gradient_matches_numpy_path(n, d, kind, monkeypatch):
    """The compiled gradient against the per-simplex numpy products, inside, on shared
    facets and vertices, and outside under each policy."""
    rng = np.random.default_rng(10 * n + d)
    tri = (Triangulation.grid(np.zeros(n), np.ones(n), (2,) * n) if kind == "grid"
           else Triangulation.delaunay(rng.random((n + 8, n))))
    coef = rng.standard_normal((tri.nsimplex, kernels.basis_plan(n, d)[3].size))
    spline = SimplexSpline(tri, d, 0, coef)
    x = np.vstack([rng.uniform(-0.2, 1.2, (400, n)), tri.vertices,
                   np.asarray(tri.corners).mean(axis=1)])
    fast = {o: spline.gradient(x, outside=o) for o in ("nan", "extrapolate")}
    one = np.vstack([spline.gradient(p) for p in x[:30]])
    monkeypatch.setattr(kernels, "HAVE_NUMBA", False)
    for o, got in fast.items():
        want = spline.gradient(x, outside=o)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
        ok = ~np.isnan(want)
        np.testing.assert_allclose(got[ok], want[ok], rtol=1e-10,
                                   atol=1e-11 * np.abs(want[ok]).max())
    np.testing.assert_allclose(one, fast["nan"][:30], rtol=1e-13, atol=1e-13)


def test_one_compiled_type_whatever_the_arrays_layout():
    """The wrappers hand the kernels read-only contiguous geometry and coefficients, so a
    strided, writeable or read-only input compiles no second version (each costs 1-1.5 s
    on an empty cache and a cache load in every worker process) and gives the same
    numbers."""
    rng = np.random.default_rng(3)
    tri = Triangulation.grid(np.zeros(2), np.ones(2), (2, 2))
    x = rng.random((500, 2))
    sid = tri.locate(x)
    coef = rng.normal(size=(tri.nsimplex, 10))
    wide = np.zeros((tri.nsimplex, 20))
    wide[:, ::2] = coef                                   # a strided view, writeable
    frozen = coef.copy()
    frozen.flags.writeable = False
    tinv_view = np.concatenate([tri._tinv, tri._tinv])[: tri.nsimplex]   # writeable copy
    values = [kernels.evaluate(x, sid, tri._origin, tinv, c, 3)
              for c in (coef, wide[:, ::2], frozen) for tinv in (tri._tinv, tinv_view)]
    grads = [kernels.gradient(x, sid, tri._origin, tri._tinv, c, 3)
             for c in (coef, wide[:, ::2], frozen)]
    for v in values[1:]:
        np.testing.assert_array_equal(v, values[0])
    for g in grads[1:]:
        np.testing.assert_array_equal(g, grads[0])
    assert len(kernels._evaluate.signatures) == 1
    assert len(kernels._gradient.signatures) == 1
