"""Statistics of the constrained estimator: covariance of the B-coefficients, standard
errors and intervals, checked against a dense reference (explicit regression matrix and
null-space basis of the full smoothness matrix, from tests/spline/reference.py), by
invariances, and by Monte Carlo coverage."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.linalg as sla
from scipy import stats

import simplexspline.spline.uncertainty.intervals as st
from simplexspline import (
    InputError,
    InsufficientDataError,
    ModelFileError,
    OutsideDomainError,
    SimplexSpline,
    SplineSpace,
    Triangulation,
)
from simplexspline.spline import kernels
from simplexspline.spline.formats.model_file import save_spline

from . import reference as ref
from .cases import data_in_simplices, make_triangulation, seeded, smooth_function


# ----------------------------------------------------------------------------- reference
def dense_reference(*args, **kw):
    """sigma^2, p, the estimate and K (Cov / sigma^2) in full coordinates, from the
    explicit X, the unreduced H and a null-space basis; ``reg`` an optional dense
    regularisation matrix (J*d_hat square) with the frequentist and Bayesian K."""
    with kernels.one_blas_thread():  # threaded BLAS is slow on a busy machine
        return _dense_reference(*args, **kw)


def _dense_reference(tri, d, r, x, y, w=None, reg=None, minnorm=False):
    V, S = tri.vertices, tri.simplices
    X = ref.design_matrix(V, S, x, d)
    w = np.ones(len(x)) if w is None else w
    H = ref.smoothness_matrix(V, S, d, r) if r >= 0 else np.zeros((0, X.shape[1]))
    Q = (X.T * w) @ X
    C = H
    if minnorm:  # undetermined directions: null(Q) and null(H); constrained to zero
        U = sla.null_space(np.vstack([Q, H]))
        C = np.vstack([H, U.T])
    Z = sla.null_space(C) if len(C) else np.eye(X.shape[1])
    Qr = Q if reg is None else Q + reg
    K = Z @ np.linalg.solve(Z.T @ Qr @ Z, Z.T)
    c = K @ (X.T @ (w * y))
    res = y - X @ c
    p = np.trace(K @ Q)
    sigma2 = (w * res * res).sum() / (len(x) - p)
    return {"X": X, "Q": Q, "c": c, "K": K, "Ks": K @ Q @ K, "p": p, "sigma2": sigma2,
            "dim": Z.shape[1]}


def fit_with_stats(tri, d, r, x, y, w=None, **kw):
    space = SplineSpace(tri, d, r)
    ne = space.normal_equations(x, y, w)
    solve_kw = {k: kw.pop(k) for k in ("on_insufficient", "ridge", "smoothing", "penalty")
                if k in kw}
    return space.solve(ne, **solve_kw).with_statistics(ne, **kw), ne


@pytest.fixture(params=["basis", "columns"])
def path(request, monkeypatch):
    """Both ways to the covariance blocks: the basis of the constrained space, and columns
    of K chunk by chunk (forced by a zero memory budget for the basis)."""
    if request.param == "columns":
        monkeypatch.setattr(st, "BASIS_BYTES", 0)
        monkeypatch.setattr(st, "CHUNK_BYTES", 1 << 16)  # several chunks
    return request.param


CASES = [  # (kind, n, d, r): redundant conditions (interior vertex), 3-D, C^0 only, r = 2
    ("explicit", 2, 3, 1),
    ("delaunay", 2, 4, 2),
    ("delaunay", 3, 2, 1),
    ("grid", 2, 2, 0),
    ("fit", 2, 3, 1),
]


@pytest.mark.parametrize("kind,n,d,r", CASES)
def test_covariance_matches_dense_reference(kind, n, d, r, path):
    rng = seeded("stats-dense", kind, n, d, r)
    tri = make_triangulation(kind, n, rng)
    x, _ = data_in_simplices(tri, 3 * ref.num_basis(n, d), rng)
    w = rng.uniform(0.3, 3.0, len(x))
    y = smooth_function(x) + 0.05 * rng.standard_normal(len(x))
    spline, _ = fit_with_stats(tri, d, r, x, y, w)
    R = dense_reference(tri, d, r, x, y, w)
    unc = spline.uncertainty
    assert unc.effective_parameters == R["dim"]
    assert unc.effective_parameters == pytest.approx(R["p"], abs=1e-8)
    assert unc.dof == len(x) - R["dim"]
    assert unc.sigma2 == pytest.approx(R["sigma2"], rel=1e-9)
    cov = spline.covariance()
    ref_cov = R["sigma2"] * R["K"]
    assert np.abs(cov - ref_cov).max() <= 1e-8 * np.abs(ref_cov).max()
    blocks = unc.covariance_blocks()
    dh = ref.num_basis(n, d)
    for j in range(tri.nsimplex):
        np.testing.assert_allclose(blocks[j], cov[j * dh:(j + 1) * dh, j * dh:(j + 1) * dh],
                                   rtol=1e-9, atol=1e-12 * np.abs(cov).max())
    xt, _ = data_in_simplices(tri, 4, rng)
    Xt = ref.design_matrix(tri.vertices, tri.simplices, xt, d)
    se_ref = np.sqrt(np.einsum("ij,jk,ik->i", Xt, ref_cov, Xt))
    np.testing.assert_allclose(spline.standard_error(xt), se_ref, rtol=1e-8)
    assert unc.leverage.sum() == pytest.approx(R["dim"], rel=1e-9)


def test_without_continuity_blocks_are_inverse_gram_blocks(path):
    rng = seeded("stats-r-1")
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    x, _ = data_in_simplices(tri, 15, rng)
    y = smooth_function(x) + 0.1 * rng.standard_normal(len(x))
    spline, ne = fit_with_stats(tri, 2, -1, x, y)
    unc = spline.uncertainty
    dh = ne.XtWX.shape[1]
    assert unc.effective_parameters == tri.nsimplex * dh  # every coefficient free
    np.testing.assert_allclose(unc.covariance_blocks(),
                               unc.sigma2 * np.linalg.inv(ne.XtWX), rtol=1e-9)
    cov = spline.covariance()  # block diagonal: pieces independent
    mask = np.kron(np.eye(tri.nsimplex), np.ones((dh, dh))) == 0
    assert np.all(cov[mask] == 0.0) or np.abs(cov[mask]).max() < 1e-14 * np.abs(cov).max()


@pytest.mark.parametrize("covariance", ["frequentist", "bayesian"])
def test_penalised_fit_matches_dense_reference(covariance, path):
    from simplexspline.spline.fit.penalty import penalty_blocks

    rng = seeded("stats-penalty")
    tri = make_triangulation("explicit", 2, rng)
    d, r = 3, 1
    x, _ = data_in_simplices(tri, 25, rng)
    y = smooth_function(x) + 0.1 * rng.standard_normal(len(x))
    spline, _ = fit_with_stats(tri, d, r, x, y, smoothing=1e-2, covariance=covariance)
    reg = spline.info.regularization
    P = reg.lam * penalty_blocks(tri, d, "energy")
    R = dense_reference(tri, d, r, x, y, reg=sla.block_diag(*P))
    unc = spline.uncertainty
    assert unc.covariance_type == covariance
    assert unc.effective_parameters == pytest.approx(R["p"], rel=1e-9)
    assert unc.effective_parameters == pytest.approx(reg.edf, rel=1e-9)
    assert unc.effective_parameters < R["dim"]  # the penalty removes degrees of freedom
    assert unc.sigma2 == pytest.approx(R["sigma2"], rel=1e-9)
    K = R["Ks"] if covariance == "frequentist" else R["K"]
    ref_cov = R["sigma2"] * K
    assert np.abs(spline.covariance() - ref_cov).max() <= 1e-8 * np.abs(ref_cov).max()


def test_ridge_fit_uses_sandwich_and_hat_trace(path):
    rng = seeded("stats-ridge")
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    d, r = 3, 1
    x, _ = data_in_simplices(tri, 12, rng)
    y = smooth_function(x) + 0.1 * rng.standard_normal(len(x))
    spline, _ = fit_with_stats(tri, d, r, x, y, ridge=1e-2)
    lam = spline.info.ridge
    R = dense_reference(tri, d, r, x, y, reg=lam * np.eye(tri.nsimplex * 10))
    unc = spline.uncertainty
    assert unc.covariance_type == "frequentist"
    assert unc.effective_parameters == pytest.approx(R["p"], rel=1e-9)
    assert unc.effective_parameters < R["dim"]
    ref_cov = R["sigma2"] * R["Ks"]
    assert np.abs(spline.covariance() - ref_cov).max() <= 1e-8 * np.abs(ref_cov).max()


def test_minnorm_undetermined_simplices_are_nan(path):
    # no data in simplex 0: its interior coefficient (1, 1, 1) is set by neither data nor
    # C^0 continuity: undetermined
    rng = seeded("stats-minnorm")
    tri = Triangulation.grid([0, 0], [1, 1], (3, 3))
    d, r = 3, 0
    x = rng.uniform(0, 1, (600, 2))
    j = tri.locate(x)
    x = x[j != 0]
    y = smooth_function(x) + 0.05 * rng.standard_normal(len(x))
    spline, _ = fit_with_stats(tri, d, r, x, y, on_insufficient="minnorm")
    under = spline.info.undetermined_simplices
    assert list(under) == [0]
    R = dense_reference(tri, d, r, x, y, minnorm=True)
    unc = spline.uncertainty
    assert unc.effective_parameters == R["dim"]
    xt, where = data_in_simplices(tri, 3, rng)
    se = spline.standard_error(xt)
    bad = np.isin(where, under)
    assert np.all(np.isnan(se[bad])) and np.all(np.isfinite(se[~bad]))
    Xt = ref.design_matrix(tri.vertices, tri.simplices, xt[~bad], d)
    se_ref = np.sqrt(R["sigma2"] * np.einsum("ij,jk,ik->i", Xt, R["K"], Xt))
    np.testing.assert_allclose(se[~bad], se_ref, rtol=1e-7)
    assert np.all(np.isnan(unc.covariance_blocks()[under]))


# ----------------------------------------------------------------------------- identities
@pytest.fixture(scope="module")
def fitted():
    rng = seeded("stats-fitted")
    tri = Triangulation.grid([-1, 0], [1, 2], (3, 2))
    x = rng.uniform([-1, 0], [1, 2], (500, 2))
    w = rng.uniform(0.5, 2.0, len(x))
    y = smooth_function(x) + 0.05 * rng.standard_normal(len(x))
    space = SplineSpace(tri, 3, 1)
    ne = space.normal_equations(x, y, w)
    spline = space.solve(ne).with_statistics(ne)
    xt = rng.uniform([-1, 0], [1, 2], (60, 2))
    return {"tri": tri, "x": x, "y": y, "w": w, "space": space, "ne": ne,
            "spline": spline, "xt": xt, "se": spline.standard_error(xt)}


def test_invariant_to_adding_a_polynomial_and_scales_with_the_data(fitted):
    f = fitted
    x, y, w = f["x"], f["y"], f["w"]
    poly = 1.5 - 2 * x[:, 0] + x[:, 0] * x[:, 1] ** 2  # degree 3: in the space
    s1, _ = fit_with_stats(f["tri"], 3, 1, x, y + poly, w)
    np.testing.assert_allclose(s1.standard_error(f["xt"]), f["se"], rtol=1e-7)
    s2, _ = fit_with_stats(f["tri"], 3, 1, x, -4.0 * y, w)
    np.testing.assert_allclose(s2.standard_error(f["xt"]), 4.0 * f["se"], rtol=1e-9)


def test_relative_and_absolute_weights(fitted):
    f = fitted
    x, y, w = f["x"], f["y"], f["w"]
    s1, _ = fit_with_stats(f["tri"], 3, 1, x, y, 7.0 * w)  # relative: unchanged
    np.testing.assert_allclose(s1.standard_error(f["xt"]), f["se"], rtol=1e-9)
    a1, _ = fit_with_stats(f["tri"], 3, 1, x, y, w, absolute_weights=True)
    a7, _ = fit_with_stats(f["tri"], 3, 1, x, y, 7.0 * w, absolute_weights=True)
    assert a1.uncertainty.sigma2 == 1.0
    np.testing.assert_allclose(a7.standard_error(f["xt"]),
                               a1.standard_error(f["xt"]) / np.sqrt(7.0), rtol=1e-9)
    # absolute = relative rescaled by the estimated sigma^2
    np.testing.assert_allclose(
        a1.standard_error(f["xt"]) * np.sqrt(a1.uncertainty.sigma2_estimate), f["se"],
        rtol=1e-9)
    lo, hi = a1.confidence_interval(f["xt"], 0.9)
    z = stats.norm.ppf(0.95)
    np.testing.assert_allclose((hi - lo) / 2, z * a1.standard_error(f["xt"]), rtol=1e-12)


def test_invariant_under_affine_maps_and_data_order(fitted):
    f = fitted
    A = np.array([[2.0, 0.5], [-0.3, 1.5]])
    b = np.array([10.0, -3.0])
    tri = Triangulation(f["tri"].vertices @ A.T + b, f["tri"].simplices)
    perm = seeded("perm").permutation(len(f["x"]))
    x = f["x"][perm] @ A.T + b
    s, _ = fit_with_stats(tri, 3, 1, x, f["y"][perm], f["w"][perm])
    np.testing.assert_allclose(s.standard_error(f["xt"] @ A.T + b), f["se"], rtol=1e-7)


def test_chunked_accumulation_gives_the_same_statistics(fitted):
    f = fitted
    space = f["space"]
    ne = space.normal_equations()
    for s in range(0, len(f["x"]), 137):
        ne.add(f["x"][s:s + 137], f["y"][s:s + 137], f["w"][s:s + 137])
    spline = space.solve(ne).with_statistics(ne)
    np.testing.assert_allclose(spline.standard_error(f["xt"]), f["se"], rtol=1e-9)


def test_interval_formulas(fitted):
    f = fitted
    s, xt, se = f["spline"], f["xt"], f["se"]
    unc = s.uncertainty
    t = stats.t.ppf(0.975, len(f["x"]) - unc.effective_parameters)
    lo, hi = s.confidence_interval(xt)
    np.testing.assert_allclose((lo + hi) / 2, s.predict(xt), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose((hi - lo) / 2, t * se, rtol=1e-12)
    lo, hi = s.confidence_interval(xt, 0.95, kind="prediction", weights=2.0)
    np.testing.assert_allclose((hi - lo) / 2, t * np.sqrt(se**2 + unc.sigma2 / 2.0),
                               rtol=1e-12)
    # the variance at the data points sums (weighted) to p: trace of the hat matrix
    v = unc.unscaled_variance(f["x"])
    assert (f["w"] * v).sum() == pytest.approx(unc.effective_parameters, rel=1e-9)


def test_coefficients_for_refits_like_the_solver(fitted):
    f = fitted
    rng = seeded("refit")
    y2 = np.cos(f["x"][:, 1]) + 0.1 * rng.standard_normal(len(f["x"]))
    ne2 = f["space"].normal_equations(f["x"], y2, f["w"])
    direct = f["space"].solve(ne2).coefficients
    unc = f["spline"].uncertainty
    np.testing.assert_allclose(unc.coefficients_for(ne2.XtWy), direct, rtol=1e-9,
                               atol=1e-12)
    both = unc.coefficients_for(np.stack([ne2.XtWy, f["ne"].XtWy]))
    np.testing.assert_allclose(both[1], f["spline"].coefficients, rtol=1e-9, atol=1e-12)


def test_outside_points(fitted):
    s = fitted["spline"]
    x = np.array([[0.0, 1.0], [5.0, 5.0]])
    se = s.standard_error(x)
    assert np.isfinite(se[0]) and np.isnan(se[1])
    lo, hi = s.confidence_interval(x)
    assert np.isnan(lo[1]) and np.isnan(hi[1])
    with pytest.raises(OutsideDomainError, match="outside"):
        s.standard_error(x, outside="raise")
    # extrapolation: the nearest simplex's polynomial, with its variance
    tri = fitted["tri"]
    j = tri.nearest(x[1:])
    Xt = ref.design_matrix(tri.vertices, tri.simplices, x[1:], 3, where=j)
    cov = s.covariance()
    assert s.standard_error(x, outside="extrapolate")[1] == pytest.approx(
        np.sqrt(Xt[0] @ cov @ Xt[0]), rel=1e-8)


# ----------------------------------------------------------------------------- Monte Carlo
def monte_carlo(weights_kind: str, nrep: int = 800, ndim: int = 2, npoints: int = 240,
                truth_in_space: bool = True, seed=0):
    """Coverage of nominal 95 % intervals at fixed test points over ``nrep`` noise
    realisations on fixed design points (refit by the factorised estimator), and the mean
    estimated sigma^2 over the true one. 2-D: S^1_3 on an 18-triangle grid; 3-D: S^1_3 on a
    4x4x4 Kuhn grid (384 simplices)."""
    rng = seeded("stats-mc", weights_kind, ndim, seed)
    tri = Triangulation.grid([0] * ndim, [1] * ndim, (3, 3) if ndim == 2 else (4, 4, 4))
    space = SplineSpace(tri, 3, 1)
    if truth_in_space:  # a smooth function in the space: no approximation bias
        dense = rng.uniform(0, 1, (max(4000, 20 * space.dim_coefficients), ndim))
        truth = space.fit(dense, smooth_function(3 * dense)).predict
    else:
        truth = lambda z: smooth_function(3 * z)  # noqa: E731
    x = rng.uniform(0, 1, (npoints, ndim))
    xt = np.vstack([rng.uniform(0, 1, (40, ndim)), np.full((1, ndim), 0.01),
                    np.full((1, ndim), 0.5)])
    f, ft = truth(x), truth(xt)
    if weights_kind == "absolute":  # heteroscedastic, weights = 1 / variance
        sd = 0.02 + 0.2 * x[:, 0]
        sdt = 0.02 + 0.2 * xt[:, 0]
        w = 1.0 / sd**2
    else:
        sd, sdt, w = np.full(len(x), 0.1), np.full(len(xt), 0.1), None
    absolute = weights_kind == "absolute"
    Y = f[:, None] + sd[:, None] * rng.standard_normal((len(x), nrep))
    ne = space.normal_equations(x, Y[:, 0], w)
    spline = space.solve(ne).with_statistics(ne, absolute_weights=absolute)
    unc = spline.uncertainty
    X = space.design_matrix(x)
    ww = np.ones(len(x)) if w is None else w
    q = (X.T @ (ww[:, None] * Y)).T.reshape(nrep, tri.nsimplex, -1)
    C = unc.coefficients_for(q).reshape(nrep, -1)  # (R, J*d_hat)
    res = Y - (X @ C.T)
    dof = len(x) - unc.effective_parameters
    s2 = (ww[:, None] * res**2).sum(axis=0) / dof  # (R,) estimated sigma^2
    scale = np.ones(nrep) if absolute else s2
    k = unc.quantile(0.95)
    var1 = unc.unscaled_variance(xt)
    pred = space.design_matrix(xt) @ C.T  # (T, R)
    half = k * np.sqrt(var1[:, None] * scale[None, :])
    conf = np.abs(pred - ft[:, None]) <= half
    ynew = ft[:, None] + sdt[:, None] * rng.standard_normal(pred.shape)
    wt = 1.0 if w is None else 1.0 / sdt[:, None] ** 2
    half_p = k * np.sqrt((var1[:, None] + 1.0 / wt) * scale[None, :])
    pred_cov = np.abs(ynew - pred) <= half_p
    true_s2 = 1.0 if absolute else 0.01
    return {"confidence": round(float(conf.mean()), 4),
            "prediction": round(float(pred_cov.mean()), 4),
            "worst_point": round(float(conf.mean(axis=1).min()), 4),
            "sigma2_ratio": round(float(s2.mean() / true_s2), 4),
            "p": unc.effective_parameters, "n": len(x), "reps": nrep}


@pytest.mark.parametrize("weights_kind", ["estimated", "absolute"])
def test_monte_carlo_coverage(weights_kind):
    out = monte_carlo(weights_kind)
    print(f"\nMonte Carlo 2-D ({weights_kind} sigma^2): {out}")
    assert 0.93 <= out["confidence"] <= 0.97
    assert 0.93 <= out["prediction"] <= 0.97
    assert out["worst_point"] >= 0.88
    assert out["sigma2_ratio"] == pytest.approx(1.0, abs=0.02)


@pytest.mark.slow
@pytest.mark.parametrize("weights_kind", ["estimated", "absolute"])
def test_monte_carlo_coverage_3d(weights_kind):
    out = monte_carlo(weights_kind, nrep=500, ndim=3, npoints=3000)
    print(f"\nMonte Carlo 3-D ({weights_kind} sigma^2): {out}")
    assert 0.93 <= out["confidence"] <= 0.97
    assert 0.93 <= out["prediction"] <= 0.97
    assert out["sigma2_ratio"] == pytest.approx(1.0, abs=0.02)


def test_estimated_standard_errors_match_monte_carlo_spread():
    # the empirical standard deviation of the refitted predictions equals the formula
    rng = seeded("stats-spread")
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    space = SplineSpace(tri, 2, 1)
    x = rng.uniform(0, 1, (150, 2))
    xt = rng.uniform(0, 1, (10, 2))
    Y = 0.3 * rng.standard_normal((len(x), 4000))
    ne = space.normal_equations(x, Y[:, 0])
    unc = space.solve(ne).with_statistics(ne, absolute_weights=True).uncertainty
    X = space.design_matrix(x)
    C = unc.coefficients_for((X.T @ Y).T.reshape(Y.shape[1], tri.nsimplex, -1))
    pred = space.design_matrix(xt) @ C.reshape(Y.shape[1], -1).T
    np.testing.assert_allclose(pred.std(axis=1), 0.3 * np.sqrt(unc.unscaled_variance(xt)),
                               rtol=0.06)


# ----------------------------------------------------------------------------- files
@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_save_load_keeps_the_statistics(fitted, tmp_path, suffix):
    s = fitted["spline"]
    path = tmp_path / f"model{suffix}"
    s.save(path)
    back = SimplexSpline.load(path)
    assert back.uncertainty is not None
    np.testing.assert_allclose(back.standard_error(fitted["xt"]), fitted["se"], rtol=1e-12)
    a, b = back.confidence_interval(fitted["xt"]), s.confidence_interval(fitted["xt"])
    np.testing.assert_allclose(a, b, rtol=1e-12)
    assert back.uncertainty.effective_parameters == s.uncertainty.effective_parameters
    np.testing.assert_array_equal(back.coefficients, s.coefficients)
    # and again (p now stored)
    back.save(tmp_path / f"again{suffix}")
    again = SimplexSpline.load(tmp_path / f"again{suffix}")
    np.testing.assert_allclose(again.standard_error(fitted["xt"]), fitted["se"], rtol=1e-12)


def test_save_load_penalised_statistics(tmp_path):
    rng = seeded("stats-io-penalty")
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    x = rng.uniform(0, 1, (200, 2))
    y = smooth_function(x) + 0.1 * rng.standard_normal(len(x))
    s, _ = fit_with_stats(tri, 3, 1, x, y, smoothing=1e-2)
    s.save(tmp_path / "m.npz")
    back = SimplexSpline.load(tmp_path / "m.npz")
    assert back.uncertainty.covariance_type == "bayesian"
    np.testing.assert_allclose(back.standard_error(x[:20]), s.standard_error(x[:20]),
                               rtol=1e-12)


def test_files_without_statistics(fitted, tmp_path):
    s = fitted["spline"]
    save_spline(s, tmp_path / "plain.json", statistics=False)
    doc = json.loads((tmp_path / "plain.json").read_text())
    assert "statistics" not in doc and doc["version"] == 1
    back = SimplexSpline.load(tmp_path / "plain.json")
    assert back.uncertainty is None
    with pytest.raises(InputError, match="no statistics.*with_statistics"):
        back.standard_error(fitted["xt"])
    np.testing.assert_array_equal(back.predict(fitted["xt"]), s.predict(fitted["xt"]))


@pytest.mark.parametrize("change,match", [
    (lambda st_: st_.update(version=99), "version 99"),
    (lambda st_: st_.update(gram=[[1.0]]), "gram"),
    (lambda st_: st_.pop("nobs"), "nobs"),
    (lambda st_: st_.update(policy="maybe"), "policy"),
])
def test_corrupt_statistics_section(fitted, tmp_path, change, match):
    path = tmp_path / "m.json"
    fitted["spline"].save(path)
    doc = json.loads(path.read_text())
    change(doc["statistics"])
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match=f"statistics.*{match}|{match}"):
        SimplexSpline.load(path)


# ----------------------------------------------------------------------------- errors
def test_errors(fitted):
    f = fitted
    s = f["spline"]
    with pytest.raises(InputError, match="level"):
        s.confidence_interval(f["xt"], level=95)
    with pytest.raises(InputError, match="kind"):
        s.confidence_interval(f["xt"], kind="tolerance")
    with pytest.raises(InputError, match="weights of new observations"):
        s.confidence_interval(f["xt"], kind="prediction", weights=0.0)
    plain = SimplexSpline(s.triangulation, 3, 1, s.coefficients)
    with pytest.raises(InputError, match="no statistics"):
        plain.covariance()
    # normal equations of other data than the fit's
    other = f["space"].normal_equations(f["x"], np.cos(f["x"][:, 0]), f["w"])
    with pytest.raises(InputError, match="do not belong to this fit"):
        s.with_statistics(other)
    # of another space
    other_space = SplineSpace(Triangulation.grid([-1, 0], [1, 2], (2, 2)), 3, 1)
    with pytest.raises(InputError, match="triangulation"):
        s.with_statistics(other_space.normal_equations(f["x"], f["y"]))
    with pytest.raises(InsufficientDataError, match="no data"):
        s.with_statistics(f["space"].normal_equations())
    with pytest.raises(InputError, match="NormalEquations"):
        s.with_statistics(None)
    with pytest.raises(InputError, match="nobs"):
        s.with_statistics(f["ne"], nobs=10**9)


def test_too_few_observations_for_the_noise_variance():
    rng = seeded("stats-few")
    tri = Triangulation.grid([0, 0], [1, 1], (1, 1))
    x = rng.uniform(0, 1, (10, 2))  # d=2, r=-1: 2 * 6 = 12 parameters > N
    x = np.vstack([x, [[0.9, 0.1], [0.1, 0.9]]])
    y = x[:, 0] + 0.1 * rng.standard_normal(len(x))
    spline, _ = fit_with_stats(tri, 2, -1, x, y)
    assert spline.uncertainty.dof <= 0
    with pytest.raises(InsufficientDataError, match="noise variance.*absolute_weights"):
        spline.standard_error(x)
    known, _ = fit_with_stats(tri, 2, -1, x, y, absolute_weights=True)
    assert np.all(np.isfinite(known.standard_error(x)))


def test_dense_covariance_is_refused_for_large_problems(fitted, monkeypatch):
    monkeypatch.setattr(st, "DENSE_LIMIT", 10)
    with pytest.raises(InputError, match="covariance_blocks"):
        fitted["spline"].covariance()


# ----------------------------------------------------------------------------- aero layer
def test_aero_model_bounds_go_through_the_scaling(fitted):
    from simplexspline.aero.modelling.model import AeroModel
    from simplexspline.aero.modelling.structure import Scaling, Structure

    s = fitted["spline"]
    # unit-box spline: rebuild the fitted case on [0, 1]^2 via the affine map of the scaling
    lower, upper = np.array([-1.0, 0.0]), np.array([1.0, 2.0])
    tri = Triangulation((s.triangulation.vertices - lower) / (upper - lower),
                        s.triangulation.simplices)
    u = (fitted["x"] - lower) / (upper - lower)
    unit, _ = fit_with_stats(tri, 3, 1, u, fitted["y"], fitted["w"])
    structure = Structure("CZ", ("alpha", "de"), degree=3, continuity=1, resolution=(3, 2))
    model = AeroModel(structure, Scaling(("alpha", "de"), tuple(lower), tuple(upper)), unit)
    data = {"alpha": fitted["xt"][:, 0], "de": fitted["xt"][:, 1]}
    np.testing.assert_allclose(model.standard_error(data), fitted["se"], rtol=1e-7)
    lo, hi = model.confidence_interval(data, 0.9)
    np.testing.assert_allclose((lo + hi) / 2, model.predict(data), rtol=1e-12, atol=1e-14)


def test_covariance_columns_take_the_fits_penalty_passes(monkeypatch):
    """The column path factorises the regularised KKT matrices the fit uses, tight penalty
    first on sparse systems (KKT_DELTA alone stalls on the nearly dependent conditions of
    Delaunay slivers), and gives the basis path's covariance blocks."""
    from simplexspline.spline.fit import constrained

    rng = np.random.default_rng(17)
    tri = Triangulation.delaunay(rng.random((9, 3)))
    x, _ = data_in_simplices(tri, 40, rng)
    y = smooth_function(x) + 0.05 * rng.standard_normal(len(x))
    basis, _ = fit_with_stats(tri, 3, 1, x, y)
    want = basis.uncertainty.covariance_blocks()
    monkeypatch.setattr(constrained, "DENSE_MAX", 0)  # the sparse path's order of passes
    monkeypatch.setattr(st, "BASIS_BYTES", 0)
    seen = []
    real = constrained._preconditioner

    def spy(Qg, A, sigma, delta, *args, **kwargs):
        seen.append((sigma, delta))
        return real(Qg, A, sigma, delta, *args, **kwargs)

    monkeypatch.setattr(constrained, "_preconditioner", spy)
    space = SplineSpace(tri, 3, 1)
    ne = space.normal_equations(x, y)
    fitted = space.solve(ne)
    seen.clear()  # the fit's own passes; now the statistics'
    got = fitted.with_statistics(ne).uncertainty.covariance_blocks()
    system = space.system
    dhat = ne.XtWX.shape[1]
    scale = float(np.einsum("jkk->", ne.XtWX)) / (int((ne.counts > 0).sum()) * dhat)
    first = constrained.kkt_passes(system.nglobal, system.A_all.shape[0], scale)[0]
    assert seen and seen[0] == pytest.approx(first[:2], rel=1e-12)
    assert seen[0][1] == pytest.approx(constrained.KKT_DELTA_TIGHT * scale, rel=1e-12)
    np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-10 * np.abs(want).max())


def _small_fit(ridge):
    """A 3-D S^1_3 Delaunay space, its normal equations and the fit's coefficients."""
    rng = np.random.default_rng(5)
    tri = Triangulation.delaunay(rng.random((9, 3)))
    x, _ = data_in_simplices(tri, 40, rng)
    y = smooth_function(x) + 0.05 * rng.standard_normal(len(x))
    space = SplineSpace(tri, 3, 1)
    ne = space.normal_equations(x, y)
    return space, ne, space.solve(ne, ridge=ridge).coefficients


@pytest.mark.parametrize("ridge", [1e-8, None])
def test_a_ridge_fit_solved_to_round_off_skips_the_unregularised_pass(monkeypatch, ridge):
    """When no regularised pass meets the forward-error tolerance but one solved the
    system to round-off, a ridge fit returns that solution: the unregularised KKT pass
    (SuperLU with pivoting, then GMRES) is kept for fits without a ridge."""
    from simplexspline.spline.fit import constrained

    space, ne, want = _small_fit(ridge)
    sigmas = []
    real_pre, real_refine = constrained._preconditioner, constrained._refine

    def spy(Qg, A, sigma, delta, *args, **kwargs):
        sigmas.append(sigma)
        return real_pre(Qg, A, sigma, delta, *args, **kwargs)

    def stalls(solve, K, rhs, M, tol=1e-8, krylov=True, last_iterate=False, **kwargs):
        out, last = real_refine(solve, K, rhs, M, tol, krylov, last_iterate=True, **kwargs)
        return (None, last) if last_iterate else None    # "no convergence", a good iterate

    monkeypatch.setattr(constrained, "DENSE_MAX", 0)
    monkeypatch.setattr(constrained, "_preconditioner", spy)
    monkeypatch.setattr(constrained, "_refine", stalls)
    got = space.solve(ne, ridge=ridge).coefficients
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-9 * np.abs(want).max())
    if ridge:
        assert sigmas and all(s > 0 for s in sigmas)        # the regularised passes only
    else:
        assert sigmas[-1] == 0.0                            # no ridge: the last pass too


@pytest.mark.parametrize("ridge", [1e-8, None])
def test_gmres_aims_at_the_residual_the_fit_needs(monkeypatch, ridge):
    """After a stalled refinement GMRES runs to round-off only without a ridge; a ridge
    fit's relaxed forward tolerance needs no residual below 1e-2 of it."""
    from simplexspline.spline.fit import constrained

    space, ne, want = _small_fit(ridge)
    asked, used = [], []
    real_refine, real_gmres = constrained._refine, constrained.spla.gmres

    def refine(*args, gmres_rtol=None, **kwargs):
        asked.append(gmres_rtol)
        return real_refine(*args, gmres_rtol=gmres_rtol, **kwargs)

    def gmres(*args, rtol, **kwargs):
        used.append(rtol)
        return real_gmres(*args, rtol=rtol, **kwargs)

    monkeypatch.setattr(constrained, "REFINE_MAXITER", 1)    # refinements "stall"
    monkeypatch.setattr(constrained, "_refine", refine)
    monkeypatch.setattr(constrained.spla, "gmres", gmres)
    monkeypatch.setattr(constrained, "_null_space_solve", lambda *a, **k: None)
    got = space.solve(ne, ridge=ridge).coefficients
    assert asked and set(used) <= set(asked)
    if ridge:
        assert min(asked) >= 1e-8 and max(asked) < 1e-5
    else:
        assert set(asked) == {constrained.GMRES_RTOL} and used
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-8 * np.abs(want).max())


@pytest.mark.parametrize("ridge", [1e-8, None])
def test_a_stalled_dense_solve_goes_to_the_null_space_of_the_conditions(monkeypatch, ridge):
    """When the first regularised pass of a dense system stalls, the fit is solved in the
    null space of the conditions (no GMRES); the basis is kept for the next fit of the
    same space, which then goes there directly. Same coefficients as the KKT passes."""
    from simplexspline.spline.fit import constrained

    rng = np.random.default_rng(7)
    tri = Triangulation.grid(np.zeros(2), np.ones(2), (3, 3))
    x = rng.random((3000, 2))
    y = smooth_function(x) + 0.05 * rng.standard_normal(len(x))
    space = SplineSpace(tri, 4, 1)
    ne = space.normal_equations(x, y)
    want = space.solve(ne, ridge=ridge).coefficients
    gmres, eighs = [], []
    real_eigh, real_refine = np.linalg.eigh, constrained._refine

    def stalled_first_pass(*args, krylov=True, **kwargs):
        return (None, None) if not krylov else real_refine(*args, krylov=krylov, **kwargs)

    monkeypatch.setattr(constrained, "_refine", stalled_first_pass)
    monkeypatch.setattr(constrained.spla, "gmres", lambda *a, **k: gmres.append(1))
    monkeypatch.setattr(constrained.np.linalg, "eigh",
                        lambda *a, **k: eighs.append(1) or real_eigh(*a, **k))
    again = SplineSpace(tri, 4, 1)
    for _ in range(2):
        got = again.solve(ne, ridge=ridge)
        np.testing.assert_allclose(got.coefficients, want, rtol=1e-7,
                                   atol=1e-9 * np.abs(want).max())
    assert not gmres and len(eighs) == 1
    H = again.H_full
    assert np.abs(H @ got.coefficients.ravel()).max() < 1e-10 * np.abs(want).max()
