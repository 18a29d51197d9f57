"""Varying-coefficient splines f(z, m) = sum_k m_k s_k(z): exactness, agreement with a
dense constrained least-squares reference, continuity of every term, streaming, penalties,
files and errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from simplexspline import InputError, ModelFileError, OutsideDomainError, SimplexSpline
from simplexspline import SplineSpace, Triangulation
from simplexspline.spline.varying import (
    VaryingCoefficientSpace,
    VaryingCoefficientSpline,
)

from . import reference as ref
from .cases import seeded


def _problem(n=2, shape=(2, 2), d=2, r=1, K=3, N=3000, seed="vc"):
    rng = seeded(seed, n, d, r, K)
    tri = Triangulation.grid(np.zeros(n), np.ones(n), shape)
    z = rng.random((N, n))
    m = np.column_stack([np.ones(N), rng.uniform(-1, 1, (N, K - 1))])
    return tri, SplineSpace(tri, d, r), z, m, rng


def _dense_reference(tri, d, r, z, m, y):
    """Null-space solution of the constrained problem with the explicit design
    [m_1 X, ..., m_K X] (X the plain regression matrix) and K copies of H."""
    V, S = np.asarray(tri.vertices), np.asarray(tri.simplices)
    X = ref.design_matrix(V, S, z, d)
    H = ref.smoothness_matrix(V, S, d, r)
    K = m.shape[1]
    Xk = np.hstack([m[:, [k]] * X for k in range(K)])
    Hk = scipy.linalg.block_diag(*([H] * K)) if H.size else np.zeros((0, Xk.shape[1]))
    c = ref.nullspace_solution(Xk, y, Hk)
    J, dh = len(S), X.shape[1] // len(S)
    return c.reshape(K, J, dh).transpose(1, 0, 2)   # (J, K, d_hat)


@pytest.mark.parametrize("n, shape, d, r", [(1, (3,), 3, 1), (2, (2, 2), 2, 1),
                                            (2, (2, 3), 3, 0), (3, (1, 1, 2), 2, 1)])
def test_equals_dense_constrained_least_squares(n, shape, d, r):
    tri, space, z, m, rng = _problem(n, shape, d, r, K=3, N=1500)
    y = np.sin(3 * z[:, 0]) * m[:, 1] + z.sum(axis=1) ** 2 + 0.3 * m[:, 2] * np.cos(z[:, -1]) \
        + 0.01 * rng.standard_normal(len(z))
    fit = VaryingCoefficientSpace(space, 3).fit(z, m, y)
    want = _dense_reference(tri, d, r, z, m, y)
    np.testing.assert_allclose(fit.coefficients, want, rtol=0,
                               atol=1e-8 * np.abs(want).max())


def test_reproduces_polynomial_terms_exactly_with_gradients():
    tri, space, z, m, rng = _problem(2, (2, 3), 3, 1, K=3)
    f = [lambda z: z[:, 0] ** 3 - z[:, 1] * z[:, 0], lambda z: 1 + z[:, 1] ** 2,
         lambda z: z[:, 0] * z[:, 1] ** 2]
    y = sum(fk(z) * m[:, k] for k, fk in enumerate(f))
    fit = VaryingCoefficientSpace(space, 3).fit(z, m, y)
    zt = rng.random((200, 2))
    mt = np.column_stack([np.ones(200), rng.uniform(-2, 2, (200, 2))])
    want = sum(fk(zt) * mt[:, k] for k, fk in enumerate(f))
    np.testing.assert_allclose(fit.predict(zt, mt), want, atol=1e-11)
    gz, gm = fit.gradient(zt, mt)
    np.testing.assert_allclose(gm, np.column_stack([fk(zt) for fk in f]), atol=1e-11)
    x0, x1 = zt.T
    gz_want = np.column_stack([
        3 * x0 ** 2 - x1 + mt[:, 2] * x1 ** 2,
        -x0 + 2 * x1 * mt[:, 1] + 2 * mt[:, 2] * x0 * x1])
    np.testing.assert_allclose(gz, gz_want, atol=1e-9)


def test_one_term_of_ones_is_the_plain_fit():
    tri, space, z, _m, rng = _problem(2, (3, 2), 3, 1, K=1)
    y = np.exp(z[:, 0]) * np.sin(2 * z[:, 1]) + 0.01 * rng.standard_normal(len(z))
    plain = space.fit(z, y)
    vc = VaryingCoefficientSpace(space, 1).fit(z, np.ones((len(z), 1)), y)
    np.testing.assert_allclose(vc.coefficients[:, 0, :], plain.coefficients, rtol=0,
                               atol=1e-10)


def test_every_term_is_continuous_across_facets():
    tri, space, z, m, rng = _problem(2, (3, 3), 3, 1, K=2)
    y = np.tanh(4 * z[:, 0] - 2) + m[:, 1] * np.cos(3 * z[:, 1]) + 0.05 * rng.standard_normal(
        len(z))
    fit = VaryingCoefficientSpace(space, 2).fit(z, m, y)
    H = space.H_full
    for term in fit.terms:
        assert np.abs(H @ term.coefficients.ravel()).max() < 1e-9


def test_streaming_and_fold_subtraction_equal_one_shot():
    tri, space, z, m, rng = _problem(2, (2, 2), 2, 1, K=3)
    y = z[:, 0] * m[:, 1] - m[:, 2] * z[:, 1] ** 2 + 0.02 * rng.standard_normal(len(z))
    vcs = VaryingCoefficientSpace(space, 3)
    one = vcs.normal_equations(z, m, y)
    a = vcs.normal_equations(z[:1000], m[:1000], y[:1000])
    b = vcs.normal_equations(z[1000:], m[1000:], y[1000:])
    np.testing.assert_allclose((a + b).XtWX, one.XtWX, atol=1e-10)
    np.testing.assert_allclose((one - b).XtWX, a.XtWX, atol=1e-10)
    np.testing.assert_allclose(vcs.solve(a + b).coefficients, vcs.solve(one).coefficients,
                               atol=1e-10)


def test_zero_weight_and_weights():
    tri, space, z, m, rng = _problem(2, (2, 2), 2, 1, K=2)
    y = z[:, 1] + m[:, 1] * z[:, 0]
    w = np.ones(len(z))
    w[:10] = 0.0
    ybad = y.copy()
    ybad[:10] += 100.0
    vcs = VaryingCoefficientSpace(space, 2)
    np.testing.assert_allclose(vcs.fit(z, m, ybad, w).coefficients,
                               vcs.fit(z[10:], m[10:], y[10:]).coefficients, atol=1e-10)


def test_gcv_smoothing_and_thin_data():
    """A penalty (the thin-plate energy, weight by GCV) determines simplices without data:
    there, the affine continuation of the (affine) terms."""
    rng = seeded("vc-thin")
    tri = Triangulation.grid([0, 0], [1, 1], (4, 4))
    space = SplineSpace(tri, 3, 1)   # (with r = 0 the energy would not see kinks)
    z = rng.random((4000, 2))
    z = z[~((z[:, 0] > 0.75) & (z[:, 1] > 0.75))]       # one corner cell empty
    m = np.column_stack([np.ones(len(z)), rng.uniform(-1, 1, len(z))])
    y = z[:, 0] + m[:, 1] * z[:, 1] + 0.01 * rng.standard_normal(len(z))
    vcs = VaryingCoefficientSpace(space, 2)
    with pytest.raises(Exception, match="do not determine"):
        vcs.fit(z, m, y)
    fit = vcs.fit(z, m, y, smoothing="gcv", penalty="energy")
    reg = fit.info.regularization
    assert reg.lam > 0 and np.isfinite(reg.edf)
    corner = np.array([[0.9, 0.9]])
    np.testing.assert_allclose(fit.predict(corner, [[1.0, 1.0]]), [1.8], atol=0.01)


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_files_round_trip_bit_for_bit(tmp_path, suffix):
    tri, space, z, m, rng = _problem(2, (2, 2), 3, 1, K=3)
    y = np.sin(z[:, 0]) * m[:, 2] + z[:, 1]
    fit = VaryingCoefficientSpace(space, 3).fit(z, m, y)
    fit.metadata = {"note": "test"}
    path = fit.save(tmp_path / f"vc{suffix}")
    back = VaryingCoefficientSpline.load(path)
    assert back.metadata == {"note": "test"} and back.nterms == 3
    np.testing.assert_array_equal(back.predict(z[:50], m[:50]), fit.predict(z[:50], m[:50]))
    with pytest.raises(ModelFileError, match="varying-model"):
        SimplexSpline.load(path)  # a plain reader must not misread it
    plain = space.fit(z, y).save(tmp_path / f"plain{suffix}")
    with pytest.raises(InputError, match="plain SimplexSpline"):
        VaryingCoefficientSpline.load(plain)


def test_outside_policies():
    tri, space, z, m, rng = _problem(2, (2, 2), 2, 1, K=2)
    y = z[:, 0] + m[:, 1]
    fit = VaryingCoefficientSpace(space, 2).fit(z, m, y)
    far = np.array([[1.5, 0.5]])
    assert np.isnan(fit.predict(far, [[1.0, 1.0]]))[0]
    np.testing.assert_allclose(fit.predict(far, [[1.0, 1.0]], outside="extrapolate"),
                               [2.5], atol=1e-9)
    with pytest.raises(OutsideDomainError, match="outside"):
        fit.predict(far, [[1.0, 1.0]], outside="raise")


def test_errors():
    tri, space, z, m, rng = _problem(2, (2, 2), 2, 1, K=2)
    vcs = VaryingCoefficientSpace(space, 2)
    with pytest.raises(InputError, match="nterms"):
        VaryingCoefficientSpace(space, 0)
    with pytest.raises(InputError, match=r"multipliers must have shape \(3000, 2\)"):
        vcs.fit(z, m[:, :1], z[:, 0])
    bad = m.copy()
    bad[3, 1] = np.nan
    with pytest.raises(InputError, match="NaN"):
        vcs.fit(z, bad, z[:, 0])
    with pytest.raises(OutsideDomainError, match="outside the triangulation"):
        vcs.fit(z + 2.0, m, z[:, 0])
    with pytest.raises(InputError, match="VaryingNormalEquations"):
        vcs.solve(space.normal_equations(z, z[:, 0]))
    other = VaryingCoefficientSpace(space, 3).normal_equations()
    with pytest.raises(InputError, match="3 terms"):
        vcs.solve(other)


@pytest.mark.parametrize("d, r", [(2, 0), (3, 1)])
def test_terms_restricted_to_some_variables_do_not_depend_on_the_others(d, r):
    rng = seeded("vc-dims", d, r)
    tri = Triangulation.grid([0, 0, 0], [1, 1, 1], (2, 2, 1))
    space = SplineSpace(tri, d, r)
    z = rng.random((6000, 3))
    m = np.column_stack([np.ones(len(z)), rng.uniform(-1, 1, len(z))])
    y = np.sin(2 * z[:, 0]) * z[:, 1] + np.cos(2 * z[:, 0]) * m[:, 1] \
        + 0.01 * rng.standard_normal(len(z))
    fit = VaryingCoefficientSpace(space, 2, [None, (0,)]).fit(z, m, y)
    zt = rng.random((500, 3))
    g = fit.terms[1].gradient(zt)
    assert np.abs(g[:, 1:]).max() < 1e-9            # term 1 depends on z0 only
    assert np.abs(fit.terms[0].gradient(zt)[:, 1]).max() > 0.1
    # the conditions hold on every simplex and the fit equals the dense reference with
    # the term's conditions added
    from simplexspline.spline.varying import constancy_conditions

    Cc = constancy_conditions(space, (1, 2)).toarray()
    assert Cc.shape[0] == tri.nsimplex * 2 * ref.num_basis(3, d - 1)
    assert np.abs(Cc @ fit.coefficients[:, 1, :].ravel()).max() < 1e-9
    with pytest.raises(InputError, match="one entry per term"):
        VaryingCoefficientSpace(space, 2, [None])
    with pytest.raises(InputError, match="out of range"):
        VaryingCoefficientSpace(space, 2, [None, (5,)])


def test_constant_terms_are_one_number():
    rng = seeded("vc-const")
    space = SplineSpace(Triangulation.grid([0, 0], [1, 1], (3, 3)), 2, 0)
    z = rng.random((3000, 2))
    m = np.column_stack([np.ones(len(z)), rng.uniform(-1, 1, len(z))])
    y = z[:, 0] ** 2 + 0.7 * m[:, 1]
    fit = VaryingCoefficientSpace(space, 2, [None, ()]).fit(z, m, y)
    np.testing.assert_allclose(fit.terms[1].coefficients, 0.7, atol=1e-9)
