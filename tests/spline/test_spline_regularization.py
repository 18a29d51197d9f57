"""Regularised fitting (issue 7): B-form smoothness energies against quadrature, the
penalised constrained estimator and its effective degrees of freedom against dense
references, GCV, the limits lam -> 0 and lam -> inf, and the thin-edge demonstration."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import scipy.linalg

from simplexspline import InputError, InsufficientDataError, SplineSpace, Triangulation
from simplexspline.spline.fit.penalty import (
    bernstein_gram,
    choose_smoothing,
    effective_dof,
    energy_blocks,
    energy_matrix,
    gcv_score,
    penalty_blocks,
    solve_penalized,
)

from . import reference as ref
from .cases import seeded, smooth_function

# ----------------------------------------------------------------------------- references


def duffy_rule(n: int, m: int):
    """Quadrature on the unit n-simplex (collapsed coordinates, m Gauss-Legendre points per
    axis): exact for polynomials of degree <= 2m - n. Returns barycentric points (K, n+1)
    and weights (K,) summing to 1/n!."""
    xg, wg = np.polynomial.legendre.leggauss(m)
    xg, wg = (xg + 1) / 2, wg / 2
    U = np.array(np.meshgrid(*[xg] * n, indexing="ij")).reshape(n, -1).T
    W = np.prod(np.array(np.meshgrid(*[wg] * n, indexing="ij")).reshape(n, -1).T, axis=1)
    b = np.zeros((len(U), n))
    rest = np.ones(len(U))
    jac = np.ones(len(U))
    for i in range(n):
        b[:, i] = U[:, i] * rest
        jac *= rest
        rest = rest * (1 - U[:, i])
    return np.column_stack([1 - b.sum(1), b]), W * jac


class MonomialPoly:
    """A random polynomial of total degree d in Cartesian monomials, with exact partials."""

    def __init__(self, n: int, d: int, rng):
        self.exps = np.array([e for e in itertools.product(range(d + 1), repeat=n)
                              if sum(e) <= d])
        self.a = rng.normal(size=len(self.exps))

    def __call__(self, x, order=None):
        x = np.atleast_2d(x)
        order = np.zeros(x.shape[1], dtype=int) if order is None else np.asarray(order)
        out = np.zeros(len(x))
        for a, e in zip(self.a, self.exps):
            if np.any(e < order):
                continue
            c = np.prod([math.factorial(ei) / math.factorial(ei - oi) for ei, oi in zip(e, order)])
            out += a * c * np.prod(x ** (e - order), axis=1)
        return out


def quadrature_energy(V, poly: MonomialPoly, d: int, m: int) -> float:
    """int over the simplex V of the sum over all m-tuples of squared m-th partials."""
    n = V.shape[1]
    b, w = duffy_rule(n, d + 2)
    x = b @ V
    vol = abs(np.linalg.det(V[1:] - V[0]))  # = n! * volume; the weights sum to 1/n!
    total = 0.0
    for tup in itertools.product(range(n), repeat=m):
        order = np.bincount(np.array(tup), minlength=n)
        total += np.sum(w * vol * poly(x, order) ** 2)
    return total


def bform_coefficients(V, poly, d, rng):
    """B-coefficients of a polynomial on simplex V by interpolating at random points."""
    b = rng.dirichlet(np.ones(V.shape[0]), size=4 * ref.num_basis(V.shape[1], d) + 10)
    c, *_ = np.linalg.lstsq(ref.basis_values(b, d), poly(b @ V), rcond=None)
    return c


def dense_penalized(tri, d, r, x, where, y, w, P, lam):
    """Dense reference: min (y-Xc)'W(y-Xc) + lam c'Pc s.t. Hc = 0 by an SVD null space.
    Returns coefficients (J*d_hat,), edf = tr(hat matrix), weighted RSS."""
    X = ref.design_matrix(tri.vertices, tri.simplices, x, d, where=where)
    H = ref.smoothness_matrix(tri.vertices, tri.simplices, d, r)
    Z = scipy.linalg.null_space(H) if H.shape[0] else np.eye(X.shape[1])
    Pf = scipy.linalg.block_diag(*P)
    Xz = X @ Z
    A = Xz.T @ (w[:, None] * Xz) + lam * Z.T @ Pf @ Z
    coef = Z @ np.linalg.solve(A, Xz.T @ (w * y))
    hat = Xz @ np.linalg.solve(A, (Xz * w[:, None]).T)
    res = y - X @ coef
    return coef, float(np.trace(hat)), float(np.sum(w * res ** 2))


def _data(tri, d, per, tag, noise=0.05):
    rng = seeded("reg", tag)
    x, where = ref.points_in_simplices(tri.vertices, tri.simplices, per, rng)
    y = smooth_function(2.0 * x) + noise * rng.standard_normal(len(x))
    w = rng.uniform(0.5, 2.0, len(x))
    return x, where, y, w


# ----------------------------------------------------------------------------- B-form energy


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("d", [0, 1, 2, 4])
def test_bernstein_gram_matches_quadrature(n, d):
    rng = seeded("gram", n, d)
    V = rng.normal(size=(n + 1, n))
    b, w = duffy_rule(n, d + 2)
    vol = ref.simplex_volume(V)
    B = ref.basis_values(b, d)
    G = (B * (w * math.factorial(n) * vol)[:, None]).T @ B
    np.testing.assert_allclose(bernstein_gram(n, d, vol), G, rtol=1e-11, atol=1e-15 * vol)


@pytest.mark.parametrize("n,d", [(1, 2), (1, 4), (2, 2), (2, 3), (2, 5), (3, 2), (3, 4)])
@pytest.mark.parametrize("order", [1, 2])
def test_energy_matrix_matches_quadrature_of_a_polynomial(n, d, order):
    rng = seeded("energy", n, d, order)
    V = rng.normal(size=(n + 1, n))
    poly = MonomialPoly(n, d, rng)
    c = bform_coefficients(V, poly, d, rng)
    expected = quadrature_energy(V, poly, d, order)
    assert c @ energy_matrix(V, d, order) @ c == pytest.approx(expected, rel=1e-8)


@pytest.mark.parametrize("n,d", [(2, 2), (2, 3), (3, 3), (4, 2)])
def test_energy_null_space_is_the_low_degree_polynomials(n, d):
    rng = seeded("null", n, d)
    V = rng.normal(size=(n + 1, n))
    for order, dim in ((2, n + 1), (1, 1)):
        E = energy_matrix(V, d, order)
        np.testing.assert_allclose(E, E.T, atol=1e-12 * np.abs(E).max())
        ev = np.linalg.eigvalsh(E)
        assert ev[0] > -1e-10 * ev[-1]
        assert int((ev < 1e-10 * ev[-1]).sum()) == dim
    # an affine function has zero thin-plate energy
    aff = MonomialPoly(n, 1, rng)
    c = bform_coefficients(V, aff, d, rng)
    assert abs(c @ energy_matrix(V, d, 2) @ c) < 1e-10 * (c @ c)


def test_energy_blocks_sum_to_the_domain_integral():
    # p = x^2 y on [0,1]^2: int p_xx^2 + 2 p_xy^2 + p_yy^2 = int 4y^2 + 8x^2 = 4.
    tri = Triangulation.grid([0, 0], [1, 1], (3, 2))
    x = seeded("dom").uniform(0, 1, (600, 2))
    spline = SplineSpace(tri, 3, 1).fit(x, x[:, 0] ** 2 * x[:, 1])
    c = spline.coefficients
    P = energy_blocks(tri, 3)
    assert np.einsum("jk,jkl,jl->", c, P, c) == pytest.approx(4.0, rel=1e-9)
    M = energy_blocks(tri, 3, order=1)  # int (2xy)^2 + (x^2)^2 = 4/9 + 1/5
    assert np.einsum("jk,jkl,jl->", c, M, c) == pytest.approx(4 / 9 + 1 / 5, rel=1e-9)
    for j in range(tri.nsimplex):
        V = tri.vertices[tri.simplices[j]]
        np.testing.assert_allclose(P[j], energy_matrix(V, 3), rtol=1e-12,
                                   atol=1e-12 * np.abs(P[j]).max())


def test_penalty_blocks_kinds_and_errors():
    tri = Triangulation.grid([0, 0], [1, 1], (1, 1))
    np.testing.assert_array_equal(penalty_blocks(tri, 2, "ridge"), np.stack([np.eye(6)] * 2))
    with pytest.raises(InputError, match="penalty must be one of"):
        penalty_blocks(tri, 2, "bogus")
    with pytest.raises(InputError, match=r"shape \(J, d_hat, d_hat\)"):
        penalty_blocks(tri, 2, np.zeros((2, 3, 3)))
    with pytest.raises(InputError, match="symmetric"):
        penalty_blocks(tri, 2, np.triu(np.ones((2, 6, 6))))
    with pytest.raises(InputError, match="degree-1 spline has no order-2 energy"):
        penalty_blocks(tri, 1, "energy")
    with pytest.raises(InputError, match="order must be 1 or 2"):
        energy_matrix([[0, 0], [1, 0], [0, 1]], 3, order=3)


# ----------------------------------------------------------------------------- estimator

PEN_CASES = [(2, 3, 1, "energy"), (2, 2, 0, "membrane"), (2, 3, -1, "energy"),
             (3, 2, 1, "ridge"), (1, 4, 2, "energy")]


@pytest.mark.parametrize("n,d,r,kind", PEN_CASES)
def test_penalized_fit_and_edf_match_dense_reference(n, d, r, kind):
    shape = {1: (4,), 2: (2, 2), 3: (1, 1, 1)}[n]
    tri = Triangulation.grid([0] * n, [1] * n, shape)
    x, where, y, w = _data(tri, d, ref.num_basis(n, d) + 3, (n, d, r))
    space = SplineSpace(tri, d, r)
    ne = space.normal_equations(x, y, w)
    coef, info = solve_penalized(ne, space.system, penalty=kind, smoothing=0.01)
    reg = info.regularization
    P = penalty_blocks(tri, d, kind)
    c_ref, edf_ref, rss_ref = dense_penalized(tri, d, r, x, where, y, w, P, reg.lam)
    np.testing.assert_allclose(coef.ravel(), c_ref, rtol=1e-7, atol=1e-8 * np.abs(c_ref).max())
    assert reg.method == "exact"
    assert reg.edf == pytest.approx(edf_ref, rel=1e-8)
    assert reg.rss == pytest.approx(rss_ref, rel=1e-7)
    assert reg.lam == pytest.approx(0.01 * np.einsum("jkk->", ne.XtWX) / np.einsum("jkk->", P))
    # the chosen-by-GCV weight: the search's rss and edf match the reference too
    reg2 = choose_smoothing(ne, space.system, P)
    _, edf2, rss2 = dense_penalized(tri, d, r, x, where, y, w, P, reg2.lam)
    assert reg2.edf == pytest.approx(edf2, rel=1e-7)
    assert reg2.rss == pytest.approx(rss2, rel=1e-6, abs=1e-12 * ne.ytWy)
    assert reg2.gcv == pytest.approx(gcv_score(rss2, edf2, len(x)), rel=1e-6)


def test_gcv_picks_the_minimum_of_the_reference_curve():
    tri = Triangulation.grid([0, 0], [1, 1], (3, 3))
    x, where, y, w = _data(tri, 3, 14, "gcvmin", noise=0.2)
    space = SplineSpace(tri, 3, 1)
    spline = space.fit(x, y, w, smoothing="gcv")
    reg = spline.info.regularization
    assert reg.chosen_by == "gcv" and not reg.at_boundary
    P = penalty_blocks(tri, 3, "energy")
    score = {f: gcv_score(*dense_penalized(tri, 3, 1, x, where, y, w, P, reg.lam * f)[:0:-1],
                          len(x)) for f in (0.5, 1.0, 2.0)}
    assert score[1.0] <= min(score[0.5], score[2.0])
    assert reg.gcv == pytest.approx(score[1.0], rel=1e-6)
    assert np.all(reg.gcv <= reg.scores + 1e-15)
    assert 0 < reg.edf < space.dimension


def test_hutchinson_edf_within_its_documented_accuracy():
    tri = Triangulation.grid([0, 0], [1, 1], (3, 3))
    x, _, y, w = _data(tri, 3, 16, "hutch")
    space = SplineSpace(tri, 3, 1)
    ne = space.normal_equations(x, y, w)
    P = penalty_blocks(tri, 3, "energy")
    lam = 0.1 * np.einsum("jkk->", ne.XtWX) / np.einsum("jkk->", P)
    exact, zero = effective_dof(ne, space.system, P, lam, method="exact")
    probes = 64
    est, std = effective_dof(ne, space.system, P, lam, method="hutchinson", probes=probes)
    assert zero == 0.0
    bound = np.sqrt(2 * exact / probes)  # documented bound on the standard deviation
    assert 0 < std <= 1.5 * bound
    assert abs(est - exact) <= 4 * bound
    # the search by Hutchinson lands near the exact one's weight
    r_ex = choose_smoothing(ne, space.system, P, method="exact")
    r_hu = choose_smoothing(ne, space.system, P, method="hutchinson", probes=probes)
    assert r_hu.method == "hutchinson"
    assert abs(np.log10(r_hu.smoothing / r_ex.smoothing)) < 0.5


# ----------------------------------------------------------------------------- limits


def test_small_weight_gives_the_unpenalised_fit():
    tri = Triangulation.grid([0, 0], [1, 1], (2, 3))
    x, _, y, w = _data(tri, 3, 20, "lam0")
    space = SplineSpace(tri, 3, 1)
    plain = space.fit(x, y, w)
    for kind in ("energy", "ridge"):
        pen = space.fit(x, y, w, smoothing=1e-12, penalty=kind)
        np.testing.assert_allclose(pen.coefficients, plain.coefficients, rtol=1e-6,
                                   atol=1e-7 * np.abs(plain.coefficients).max())
        assert pen.info.regularization.edf == pytest.approx(space.dimension, rel=1e-6)
    zero = space.fit(x, y, w, smoothing=0.0)
    np.testing.assert_allclose(zero.coefficients, plain.coefficients, rtol=1e-10, atol=1e-12)
    assert zero.info.regularization.lam == 0.0


@pytest.mark.parametrize("n,d", [(2, 3), (3, 2)])
def test_large_energy_weight_tends_to_the_affine_least_squares_fit(n, d):
    tri = Triangulation.grid([0] * n, [1] * n, (2,) * n)
    x, _, y, w = _data(tri, d, 10, ("inf", n, d))
    space = SplineSpace(tri, d, 1)
    A = np.column_stack([np.ones(len(x)), x])
    beta, *_ = np.linalg.lstsq(A * np.sqrt(w)[:, None], y * np.sqrt(w), rcond=None)
    xv = seeded("v", n).uniform(0, 1, (200, n))
    affine = np.column_stack([np.ones(200), xv]) @ beta
    err, edf = [], []
    for s in (1e3, 1e4, 1e5):
        spline = space.fit(x, y, w, smoothing=s)
        err.append(np.abs(spline.predict(xv) - affine).max())
        edf.append(spline.info.regularization.edf)
    # the distance to the limit falls like 1/lam
    assert err[2] < 1e-3 * np.abs(y).max()
    assert 5 < err[0] / err[1] < 20 and 5 < err[1] / err[2] < 20
    assert edf[2] == pytest.approx(n + 1, abs=1e-2)
    assert 5 < (edf[1] - n - 1) / (edf[2] - n - 1) < 20
    # membrane: the limit is the weighted mean
    flat = space.fit(x, y, w, smoothing=1e5, penalty="membrane")
    np.testing.assert_allclose(flat.predict(xv), np.average(y, weights=w),
                               atol=1e-3 * np.abs(y).max())


def test_energy_penalty_determines_an_empty_simplex():
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    rng = seeded("empty")
    x = rng.uniform(0, 1, (3000, 2))
    x = x[tri.locate(x) != 3]
    y = smooth_function(x)
    space = SplineSpace(tri, 3, 1)
    with pytest.raises(InsufficientDataError, match="do not determine"):
        space.fit(x, y)
    spline = space.fit(x, y, smoothing="gcv")  # no error: the penalty fixes the rest
    assert spline.info.n_undetermined == 0
    assert np.all(np.isfinite(spline.coefficients))


def test_weight_scale_invariance_and_streaming():
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    x, _, y, w = _data(tri, 3, 25, "scale")
    space = SplineSpace(tri, 3, 1)
    a = space.fit(x, y, w, smoothing="gcv")
    b = space.fit(x, y, 10.0 * w, smoothing="gcv")
    assert b.info.regularization.smoothing == pytest.approx(a.info.regularization.smoothing,
                                                            rel=1e-6)
    np.testing.assert_allclose(b.coefficients, a.coefficients, rtol=1e-6, atol=1e-9)
    ne = space.normal_equations(x[:100], y[:100], w[:100])
    ne.add(x[100:], y[100:], w[100:])
    c = space.solve(ne, smoothing="gcv")
    np.testing.assert_allclose(c.coefficients, a.coefficients, rtol=1e-8, atol=1e-10)


def test_regularisation_input_errors():
    tri = Triangulation.grid([0, 0], [1, 1], (1, 1))
    x = seeded("err").uniform(0, 1, (200, 2))
    space = SplineSpace(tri, 2, 1)
    with pytest.raises(InputError, match="smoothing must be 'gcv' or a number"):
        space.fit(x, x[:, 0], smoothing="auto")
    with pytest.raises(InputError, match="smoothing must be 'gcv' or a number"):
        space.fit(x, x[:, 0], smoothing=-1.0)
    with pytest.raises(InputError, match="penalty must be one of"):
        space.fit(x, x[:, 0], smoothing=1.0, penalty="tv")
    with pytest.raises(InputError, match="no order-2 energy"):
        SplineSpace(tri, 1, 0).fit(x, x[:, 0], smoothing="gcv")
    ne = space.normal_equations(x, x[:, 0])
    with pytest.raises(InputError, match="method must be"):
        solve_penalized(ne, space.system, method="svd")
    with pytest.raises(InputError, match="grid must hold"):
        choose_smoothing(ne, space.system, penalty_blocks(tri, 2), grid=[1.0])


# ----------------------------------------------------------------------------- thin edge


def thin_edge_problem(seed: int = 0, nthin: int = 20, edge: float = 0.75):
    """2-D: dense noisy data where x0 < edge, a few where x0 > edge; S^1_3 on 6x6 cells."""
    rng = np.random.default_rng(seed)

    def f(p):
        return np.sin(3 * p[:, 0] + 1) * np.cos(2.5 * p[:, 1]) + 0.5 * p[:, 0] ** 2

    xd = rng.uniform(0, 1, (3000, 2)) * [edge, 1.0]
    xt = rng.uniform(0, 1, (nthin, 2)) * [1 - edge, 1.0] + [edge, 0.0]
    x = np.vstack([xd, xt])
    y = f(x) + 0.05 * rng.standard_normal(len(x))
    xv = rng.uniform(0, 1, (20000, 2))
    return x, y, xv, f(xv), xv[:, 0] > edge


@pytest.mark.parametrize("seed", [0, 3])
def test_gcv_regularisation_stops_the_divergence_at_a_thin_edge(seed):
    x, y, xv, fv, thin = thin_edge_problem(seed)
    space = SplineSpace(Triangulation.grid([0, 0], [1, 1], (6, 6)), 3, 1)
    plain = space.fit(x, y, on_insufficient="minnorm")
    reg = space.fit(x, y, smoothing="gcv", on_insufficient="minnorm")

    def rms(s, m):
        return float(np.sqrt(np.mean((s.predict(xv[m]) - fv[m]) ** 2)))

    # measured (seeds 0, 3): thin 2.8 / 5.5 -> 0.039 / 0.025; dense 0.010 / 0.009 ->
    # 0.006 / 0.005
    assert rms(plain, thin) > 1.0
    assert rms(reg, thin) < 0.1
    assert rms(reg, thin) < 0.05 * rms(plain, thin)
    assert rms(reg, ~thin) < 1.2 * rms(plain, ~thin)
    assert reg.info.regularization.chosen_by == "gcv"


def test_ridge_fit_defers_the_undetermined_analysis(monkeypatch):
    """With a ridge every direction is determined, so the (costly) analysis of the
    directions that data and continuity leave free runs only when ``info`` is read; it
    then gives what the eager analysis of a minimum-norm fit gives."""
    from simplexspline.spline.fit import constrained

    tri = Triangulation.grid([0, 0], [1, 1], (3, 3))
    rng = seeded("deferred")
    x = rng.uniform(0, 1, (4000, 2))
    x = x[~np.isin(tri.locate(x), [4, 5])]               # two simplices without data
    y = smooth_function(x)
    space = SplineSpace(tri, 3, 0)
    eager = space.fit(x, y, on_insufficient="minnorm").info
    assert eager.n_undetermined > 0 and set(eager.undetermined_simplices) == {4, 5}
    calls = []
    real = constrained._undetermined
    monkeypatch.setattr(constrained, "_undetermined",
                        lambda *a: calls.append(1) or real(*a))
    ridged = space.fit(x, y, on_insufficient="ridge")
    assert calls == []                                   # not run by the fit
    assert ridged.info.n_undetermined == eager.n_undetermined
    np.testing.assert_array_equal(ridged.info.undetermined_simplices,
                                  eager.undetermined_simplices)
    assert len(calls) == 1                               # once, when first read
    assert ridged.info.policy == "ridge" and ridged.info.ridge > 0
    assert "n_undetermined=" in repr(ridged.info)


def test_deferred_info_travels_between_processes_as_a_plain_one():
    """Fitted models come back from worker processes pickled: a deferred info arrives as
    a plain SolveInfo with the analysis done (and its other attributes kept)."""
    import pickle

    from simplexspline.spline.fit.constrained import SolveInfo

    tri = Triangulation.grid([0, 0], [1, 1], (3, 3))
    rng = seeded("deferred-pickle")
    x = rng.uniform(0, 1, (4000, 2))
    x = x[tri.locate(x) != 4]
    spline = SplineSpace(tri, 3, 0).fit(x, smooth_function(x), on_insufficient="ridge")
    spline.info.regularization = "kept"
    back = pickle.loads(pickle.dumps(spline.info))
    assert type(back) is SolveInfo and back.regularization == "kept"
    assert back.n_undetermined == spline.info.n_undetermined > 0
    np.testing.assert_array_equal(back.undetermined_simplices, [4])
