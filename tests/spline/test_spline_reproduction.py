"""Polynomial reproduction (issue 2 acceptance) and derivative exactness.

Any polynomial of total degree <= d is reproduced to <= 1e-9 relative error from noise-free
scattered samples for n = 1..6, d = 0..5, every r < d and every triangulation kind (large
problems marked slow; the fast matrix covers every n, d, r and kind)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from simplexspline import SimplexSpline, SplineSpace, Triangulation

from . import reference as ref
from .cases import (
    KINDS,
    MAX_COEFFICIENTS,
    case_param,
    data_in_simplices,
    make_triangulation,
    problem_size,
    seeded,
)


def _cases():
    out = []
    for n in range(1, 7):
        for d in range(0, 6):
            for r in range(-1, d):
                for kind in KINDS:
                    if problem_size(n, d, kind) <= MAX_COEFFICIENTS:
                        out.append(case_param(n, d, r, kind))
    return out


def relative_error(got, expected):
    return np.max(np.abs(got - expected)) / max(np.max(np.abs(expected)), 1e-300)


@pytest.mark.parametrize("n,d,r,kind", _cases())
def test_polynomial_reproduction(n, d, r, kind):
    rng = seeded("repro", n, d, r, kind)
    tri = make_triangulation(kind, n, rng)
    d_hat = ref.num_basis(n, d)
    x, _ = data_in_simplices(tri, d_hat + max(3, d_hat // 2), rng)
    p = ref.Poly.random(n, d, rng, centre=tri.vertices.mean(0), exact=True)
    s = SimplexSpline.fit(x, p(x), tri, d, r)
    assert s.degree == d and s.continuity == r
    assert s.coefficients.shape == (tri.nsimplex, d_hat)
    xt, _ = data_in_simplices(tri, 4, rng)
    assert relative_error(s.predict(xt), p(xt)) <= 1e-9
    assert relative_error(s.predict(x), p(x)) <= 1e-9


@pytest.mark.parametrize("n", [1, 2, 3, 4, 6])
def test_lower_degree_polynomials_reproduced(n):
    """Degree < d polynomials (e.g. constants and affine functions) are in S^r_d too."""
    rng = seeded("lower", n)
    tri = make_triangulation("explicit", n, rng)
    d = 3 if n <= 4 else 2
    x, _ = data_in_simplices(tri, 2 * ref.num_basis(n, d), rng)
    for k in range(d):
        p = ref.Poly.random(n, k, rng, centre=tri.vertices.mean(0))
        s = SimplexSpline.fit(x, p(x), tri, d, d - 1)
        xt, _ = data_in_simplices(tri, 5, rng)
        assert relative_error(s.predict(xt), p(xt)) <= 1e-9


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 3), d=st.integers(1, 4), data=st.data())
def test_reproduction_random_polynomials_property(seed, n, d, data):
    r = data.draw(st.integers(-1, d - 1), label="r")
    kind = data.draw(st.sampled_from(["explicit", "grid", "delaunay"]), label="kind")
    rng = np.random.default_rng(seed)
    tri = make_triangulation(kind, n, rng)
    d_hat = ref.num_basis(n, d)
    x, _ = data_in_simplices(tri, d_hat + 3, rng, alpha=data.draw(st.sampled_from([0.5, 1.0, 3.0])))
    p = ref.Poly.random(n, d, rng, centre=tri.vertices.mean(0))
    s = SimplexSpline.fit(x, p(x), tri, d, r)
    xt, _ = data_in_simplices(tri, 3, rng)
    assert relative_error(s.predict(xt), p(xt)) <= 1e-9


# ------------------------------------------------------------------ derivatives of polynomials

DERIV_CASES = [
    (1, 4, 2, "grid"), (2, 3, 1, "grid"), (2, 4, 0, "delaunay"), (2, 2, -1, "explicit"),
    (3, 3, 1, "explicit"), (3, 2, 0, "grid"), (4, 2, 1, "explicit"), (2, 5, 1, "fit"),
]


@pytest.mark.parametrize("n,d,r,kind", DERIV_CASES)
def test_gradient_and_derivatives_exact_on_polynomials(n, d, r, kind):
    rng = seeded("deriv", n, d, r, kind)
    tri = make_triangulation(kind, n, rng)
    x, _ = data_in_simplices(tri, 2 * ref.num_basis(n, d), rng)
    p = ref.Poly.random(n, d, rng, centre=tri.vertices.mean(0), exact=True)
    s = SimplexSpline.fit(x, p(x), tri, d, r)
    xt, _ = data_in_simplices(tri, 4, rng)
    g = s.gradient(xt)
    assert g.shape == (len(xt), n)
    assert relative_error(g, p.gradient(xt)) <= 1e-7
    for order in ref.all_orders(n, d):
        got = s.derivative(xt, order)
        assert got.shape == (len(xt),)
        expected = p.derivative(order)(xt)
        scale = max(np.max(np.abs(expected)), 1e-3 * np.max(np.abs(p(xt))))
        assert np.max(np.abs(got - expected)) <= 1e-7 * scale, order
    np.testing.assert_allclose(s.derivative(xt, (0,) * n), s.predict(xt), rtol=1e-13, atol=1e-13)
    # order above the degree: identically zero
    above = (d + 1,) + (0,) * (n - 1)
    np.testing.assert_array_equal(s.derivative(xt, above), np.zeros(len(xt)))
    if n >= 2:
        np.testing.assert_array_equal(s.derivative(xt, (d,) + (1,) + (0,) * (n - 2)), 0.0)


def test_gradient_of_piecewise_spline_matches_finite_differences():
    rng = seeded("fd")
    tri = Triangulation.grid([0, 0], [1, 1], (3, 3))
    x, _ = data_in_simplices(tri, 30, rng)
    y = np.sin(3 * x[:, 0]) * np.cos(2 * x[:, 1])
    s = SimplexSpline.fit(x, y, tri, 3, 1)
    xt, where = data_in_simplices(tri, 3, rng, alpha=5.0)  # away from facets
    h = 1e-6
    fd = np.stack([(s.predict(xt + h * e, simplices=where) - s.predict(xt - h * e, simplices=where))
                   / (2 * h) for e in np.eye(2)], axis=1)
    np.testing.assert_allclose(s.gradient(xt), fd, rtol=1e-6, atol=1e-6)


# ---------------------------------------------------------------------------- outside policies


def _global_quadratic_on_unit_square():
    rng = seeded("outside")
    tri = Triangulation.grid([0.0, 0.0], [1.0, 1.0], (2, 2))
    x, _ = data_in_simplices(tri, 20, rng)
    p = ref.Poly.random(2, 2, rng, centre=[0.5, 0.5], exact=True)
    return tri, p, SimplexSpline.fit(x, p(x), tri, 2, 1)


def test_predict_outside_nan_by_default():
    tri, p, s = _global_quadratic_on_unit_square()
    x = np.array([[0.3, 0.4], [1.5, 0.5], [0.9, 0.1], [-0.2, -0.3]])
    out = s.predict(x)
    assert np.isnan(out[1]) and np.isnan(out[3])
    np.testing.assert_allclose(out[[0, 2]], p(x[[0, 2]]), rtol=1e-9)
    np.testing.assert_array_equal(s.predict(x, outside="nan"), out)
    g = s.gradient(x)
    assert np.all(np.isnan(g[[1, 3]])) and np.all(np.isfinite(g[[0, 2]]))
    dv = s.derivative(x, (1, 1))
    assert np.all(np.isnan(dv[[1, 3]])) and np.all(np.isfinite(dv[[0, 2]]))


def test_predict_outside_raise():
    from simplexspline import OutsideDomainError

    tri, p, s = _global_quadratic_on_unit_square()
    x = np.array([[0.3, 0.4], [1.5, 0.5], [0.9, 0.1], [-0.2, -0.3]])
    with pytest.raises(OutsideDomainError, match="(?i)outside") as info:
        s.predict(x, outside="raise")
    np.testing.assert_array_equal(np.sort(info.value.indices), [1, 3])
    assert isinstance(info.value, ValueError)
    with pytest.raises(OutsideDomainError, match="(?i)outside"):
        s.gradient(x, outside="raise")
    with pytest.raises(OutsideDomainError, match="(?i)outside"):
        s.derivative(x, (1, 0), outside="raise")
    # all inside: no error
    np.testing.assert_allclose(s.predict(x[[0, 2]], outside="raise"), p(x[[0, 2]]), rtol=1e-9)


def test_predict_outside_extrapolate_reproduces_global_polynomial():
    tri, p, s = _global_quadratic_on_unit_square()
    x = np.array([[0.3, 0.4], [1.5, 0.5], [0.9, 0.1], [-0.2, -0.3], [1.2, 1.3], [0.5, -0.1]])
    out = s.predict(x, outside="extrapolate")
    assert np.all(np.isfinite(out))
    np.testing.assert_allclose(out, p(x), rtol=1e-8, atol=1e-8 * np.abs(p(x)).max())
    np.testing.assert_allclose(s.gradient(x, outside="extrapolate"), p.gradient(x), rtol=1e-7,
                               atol=1e-7)
    np.testing.assert_allclose(s.derivative(x, (2, 0), outside="extrapolate"),
                               p.derivative((2, 0))(x), rtol=1e-7, atol=1e-7)


def test_predict_bad_outside_policy():
    from simplexspline import InputError

    tri, p, s = _global_quadratic_on_unit_square()
    with pytest.raises(InputError, match="(?i)outside"):
        s.predict(np.array([[0.5, 0.5]]), outside="clip")


def test_predict_forced_simplices_evaluate_that_piece():
    tri, p, s = _global_quadratic_on_unit_square()
    rng = seeded("forced")
    x = rng.uniform(0, 1, (10, 2))
    others = (tri.locate(x) + 3) % tri.nsimplex
    # a global polynomial: every piece is the polynomial, also outside its simplex
    np.testing.assert_allclose(s.predict(x, simplices=others), p(x), rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(s.gradient(x, simplices=others), p.gradient(x), rtol=1e-7, atol=1e-8)


def test_space_attributes():
    tri = make_triangulation("grid", 2, seeded("space"))
    sp_ = SplineSpace(tri, 3, 1)
    assert sp_.dim_coefficients == tri.nsimplex * 10
    assert sp_.H.shape[1] == sp_.dim_coefficients
    assert sp_.H_full.shape == (len(tri.facets.simplices) * ref.conditions_per_facet(2, 3, 1),
                                sp_.dim_coefficients)


def test_degree_zero_spline_derivatives_vanish():
    rng = seeded("d0")
    tri = Triangulation.grid([0, 0, 0], [1, 2, 1], (1, 1, 1))
    x, where = data_in_simplices(tri, 3, rng)
    y = where.astype(float)  # piecewise constant data
    s = SimplexSpline.fit(x, y, tri, 0, -1)
    np.testing.assert_allclose(s.predict(x), y, atol=1e-12)
    np.testing.assert_array_equal(s.gradient(x), np.zeros((len(x), 3)))
    np.testing.assert_allclose(s.derivative(x, (0, 0, 0)), y, atol=1e-12)
    np.testing.assert_array_equal(s.derivative(x, (0, 1, 0)), np.zeros(len(x)))


def test_predict_no_points():
    tri, p, s = _global_quadratic_on_unit_square()
    assert s.predict(np.zeros((0, 2))).shape == (0,)
    assert s.gradient(np.zeros((0, 2))).shape == (0, 2)


@pytest.mark.parametrize("d,r", [(3, 1), (2, 1), (5, 2)])
def test_reproduction_on_fit_triangulation_with_holes(d, r):
    """Triangulation.fit of clustered data drops simplices: a non-convex domain."""
    rng = seeded("holes", d, r)
    x0 = np.vstack([rng.normal([0.2, 0.2], 0.12, (300, 2)), rng.normal([0.8, 0.7], 0.1, (300, 2)),
                    rng.uniform(0, 1, (40, 2)) * [1.0, 0.1]])
    tri = Triangulation.fit(x0, (6, 6), min_points=2)
    assert tri.nsimplex < 72
    x, _ = data_in_simplices(tri, ref.num_basis(2, d) + 4, rng)
    p = ref.Poly.random(2, d, rng, centre=[0.5, 0.5], exact=True)
    s = SimplexSpline.fit(x, p(x), tri, d, r)
    xt, _ = data_in_simplices(tri, 3, rng)
    assert relative_error(s.predict(xt), p(xt)) <= 1e-9
