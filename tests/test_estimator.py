"""SimplexSplineRegressor: the scikit-learn protocol (check_estimator, Pipeline,
GridSearchCV), agreement with the spline layer, weights, multi-output, the outside
policies, the spline in input coordinates, and errors."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from simplexspline import InputError, SplineSpace, Triangulation
from simplexspline.estimator.regressor import NotFittedError, SimplexSplineRegressor

sklearn = pytest.importorskip("sklearn")
from sklearn.model_selection import GridSearchCV, cross_val_score  # noqa: E402
from sklearn.pipeline import make_pipeline  # noqa: E402
from sklearn.preprocessing import StandardScaler  # noqa: E402
from sklearn.utils.estimator_checks import parametrize_with_checks  # noqa: E402


def cubic(X):
    """A cubic polynomial in 3 variables (reproduced exactly by degree >= 3)."""
    x, y, z = X.T
    return 1.0 + x ** 3 - 2 * x * y * z + 0.5 * y ** 2 - z


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(7)
    X = np.column_stack([rng.uniform(-2, 3, 3000), rng.uniform(10, 20, 3000),
                         rng.uniform(-0.1, 0.1, 3000)])
    return X, cubic(X)


# --------------------------------------------------------------------------- protocol
@parametrize_with_checks([SimplexSplineRegressor(),
                          SimplexSplineRegressor(degree=2, resolution=2, ridge=0.0),
                          SimplexSplineRegressor(triangulation="simplex", degree=1)])
def test_sklearn_check_estimator(estimator, check):
    check(estimator)


def test_pipeline_grid_search_and_cross_validation(data):
    X, y = data
    y = y + 0.01 * np.random.default_rng(0).standard_normal(len(y))
    pipe = make_pipeline(StandardScaler(), SimplexSplineRegressor(continuity=0))
    search = GridSearchCV(pipe, {"simplexsplineregressor__degree": [1, 3],
                                 "simplexsplineregressor__resolution": [1, 2]}, cv=3)
    search.fit(X, y)
    assert search.best_params_["simplexsplineregressor__degree"] == 3
    assert search.best_score_ > 0.999
    scores = cross_val_score(SimplexSplineRegressor(degree=3), X, y, cv=3)
    assert np.all(scores > 0.999)


def test_get_set_params_and_clone():
    est = SimplexSplineRegressor(degree=2, resolution=(2, 3))
    assert est.get_params()["resolution"] == (2, 3)
    assert est.set_params(degree=4) is est and est.degree == 4
    clone = sklearn.base.clone(est)
    assert clone.get_params() == est.get_params() and clone is not est


# --------------------------------------------------------------------------- mathematics
@pytest.mark.parametrize("resolution, continuity", [(1, 1), (2, 1), ((3, 1, 2), 0),
                                                    (2, -1)])
def test_reproduces_a_cubic_in_input_units(data, resolution, continuity):
    X, y = data
    est = SimplexSplineRegressor(degree=3, continuity=continuity, resolution=resolution,
                                 ridge=0.0).fit(X, y)
    rng = np.random.default_rng(1)
    Xt = np.column_stack([rng.uniform(-2, 3, 500), rng.uniform(10, 20, 500),
                          rng.uniform(-0.1, 0.1, 500)])
    np.testing.assert_allclose(est.predict(Xt), cubic(Xt), rtol=0, atol=1e-8)
    assert est.score(Xt, cubic(Xt)) == pytest.approx(1.0, abs=1e-12)


def test_equals_the_spline_layer_fit_in_model_coordinates(data):
    X, y = data
    y = y + 0.1 * np.sin(5 * X[:, 0])
    est = SimplexSplineRegressor(degree=2, resolution=2, ridge=0.0).fit(X, y)
    U = est.model_coordinates(X)
    assert U.min() >= 0.0 and U.max() <= 1.0
    tri = Triangulation.fit(U, (2, 2, 2))
    ref = SplineSpace(tri, 2, 1).fit(U, y)
    np.testing.assert_allclose(est.spline_.coefficients, ref.coefficients, rtol=0,
                               atol=1e-9 * np.abs(ref.coefficients).max())


def test_to_spline_works_in_input_units(data, tmp_path):
    X, y = data
    est = SimplexSplineRegressor(degree=3, resolution=2, ridge=0.0).fit(X, y)
    spline = est.to_spline()
    Xt = X[:200]
    np.testing.assert_allclose(spline.predict(Xt), est.predict(Xt), rtol=0, atol=1e-10)
    # exact gradient of the cubic, in the units of X
    x, yy, z = Xt.T
    grad = np.column_stack([3 * x ** 2 - 2 * yy * z, -2 * x * z + yy, -2 * x * yy - 1])
    np.testing.assert_allclose(spline.gradient(Xt), grad, rtol=1e-7, atol=1e-7)
    path = spline.save(tmp_path / "m.json")
    from simplexspline import SimplexSpline

    np.testing.assert_array_equal(SimplexSpline.load(path).predict(Xt), spline.predict(Xt))


def test_multi_output_equals_separate_fits(data):
    X, y = data
    Y = np.column_stack([y, np.sin(X[:, 0]), X[:, 1] * X[:, 2]])
    w = np.random.default_rng(3).uniform(0.5, 2.0, len(X))
    multi = SimplexSplineRegressor(degree=2, resolution=2).fit(X, Y, sample_weight=w)
    pred = multi.predict(X[:100])
    assert pred.shape == (100, 3)
    for k in range(3):
        single = SimplexSplineRegressor(degree=2, resolution=2).fit(X, Y[:, k],
                                                                     sample_weight=w)
        np.testing.assert_allclose(pred[:, k], single.predict(X[:100]), rtol=0, atol=1e-10)
    col = SimplexSplineRegressor(degree=2).fit(X, Y[:, :1])
    assert col.predict(X[:5]).shape == (5, 1)


def test_integer_weights_repeat_and_zero_weights_remove(data):
    X, y = data
    X, y = X[:400], y + np.cos(3 * X[:, 0])
    y = y[:400]
    w = np.random.default_rng(5).integers(0, 4, len(X))
    a = SimplexSplineRegressor(degree=2, resolution=2).fit(X, y, sample_weight=w)
    b = SimplexSplineRegressor(degree=2, resolution=2).fit(np.repeat(X, w, axis=0),
                                                           np.repeat(y, w))
    np.testing.assert_allclose(a.predict(X), b.predict(X), rtol=0, atol=1e-8)
    # zero weights do not even widen the box that is triangulated
    Xo = np.vstack([X, [[100.0, 100.0, 100.0]]])
    c = SimplexSplineRegressor(degree=2, resolution=2).fit(
        Xo, np.append(y, 1e6), sample_weight=np.append(w, 0))
    np.testing.assert_array_equal(c.data_max_, a.data_max_)


def test_constant_features_are_set_aside(data):
    X, y = data
    Xc = np.column_stack([X[:, 0], np.full(len(X), 4.0), X[:, 1:]])
    est = SimplexSplineRegressor(degree=3, outside="nan").fit(Xc, y)
    assert est.active_features_.tolist() == [0, 2, 3]
    assert est.triangulation_.ndim == 3
    np.testing.assert_allclose(est.predict(Xc[:50]), y[:50], atol=1e-6)
    other = Xc[:3].copy()
    other[:, 1] = 5.0
    assert np.all(np.isnan(est.predict(other)))


def test_outside_policies():
    rng = np.random.default_rng(2)
    X = rng.uniform(0, 1, (2000, 2))
    y = X[:, 0] ** 2 + X[:, 1]
    far = np.array([[2.0, 0.5], [-1.0, 0.5]])
    clamp = SimplexSplineRegressor(degree=2, resolution=2).fit(X, y)
    np.testing.assert_allclose(clamp.predict(far), [1.0 + 0.5, 0.0 + 0.5], atol=1e-3)
    extra = SimplexSplineRegressor(degree=2, resolution=2, outside="extrapolate",
                                   ridge=0.0).fit(X, y)
    np.testing.assert_allclose(extra.predict(far), far[:, 0] ** 2 + far[:, 1], atol=1e-6)
    nan = SimplexSplineRegressor(degree=2, resolution=2, outside="nan").fit(X, y)
    assert np.all(np.isnan(nan.predict(far)))
    assert np.all(np.isfinite(nan.predict(X[:10])))


def test_single_polynomial_for_many_features_and_fewer_samples_than_coefficients():
    rng = np.random.default_rng(4)
    X = rng.uniform(-1, 1, (60, 12))
    y = X @ np.arange(12.0) + 1.0
    est = SimplexSplineRegressor(degree=1).fit(X, y)      # 'auto': 12! simplices > limit
    assert est.triangulation_kind_ == "simplex" and est.n_simplices_ == 1
    # the default safeguard ridge (1e-8) biases an ill-conditioned basis a little ...
    np.testing.assert_allclose(est.predict(X), y, rtol=1e-4)
    # ... none is exact
    exact = SimplexSplineRegressor(degree=1, ridge=0.0).fit(X, y)
    np.testing.assert_allclose(exact.predict(X), y, rtol=0, atol=1e-9)
    # degree 2 in 12 variables: 91 coefficients from 60 samples -> minimum norm (ridge 0)
    # as the pseudo-inverse gives it, through the N x N dual system
    mn = SimplexSplineRegressor(degree=2, ridge=0.0).fit(X, y)
    np.testing.assert_allclose(mn.predict(X), y, atol=1e-8)
    assert mn.spline_.info.n_undetermined == 91 - 60


def test_ridge_biases_little_and_determines_thin_data():
    rng = np.random.default_rng(8)
    X = rng.uniform(0, 1, (25, 3))             # 6 simplices x 20 coefficients, 25 samples
    y = X[:, 0] - X[:, 1] * X[:, 2]
    est = SimplexSplineRegressor(degree=3).fit(X, y)
    assert np.all(np.isfinite(est.spline_.coefficients))
    np.testing.assert_allclose(est.predict(X), y, atol=1e-4)


# --------------------------------------------------------------------------- errors
@pytest.mark.parametrize("params, match", [
    ({"degree": -1}, "degree"),
    ({"degree": 2, "continuity": 2}, "continuity"),
    ({"resolution": 0}, "resolution"),
    ({"resolution": (1, 2)}, "one positive integer per feature"),
    ({"triangulation": "delaunay"}, "triangulation must be one of"),
    ({"min_points": 0}, "min_points"),
    ({"ridge": -1.0}, "ridge"),
    ({"outside": "wrap"}, "outside must be one of"),
    ({"scale": "yes"}, "scale must be True or False"),
    ({"max_coefficients": 10}, "above the limit 10"),
    ({"max_coefficients": 100, "resolution": 2}, "above max_coefficients=100"),
    ({"resolution": 40}, "above the limit"),
])
def test_parameter_errors(data, params, match):
    X, y = data
    with pytest.raises(InputError, match=match):
        SimplexSplineRegressor(**params).fit(X, y)


def test_data_errors(data):
    X, y = data
    est = SimplexSplineRegressor()
    with pytest.raises(InputError, match="NaN"):
        est.fit(np.where(np.arange(len(X))[:, None] == 3, np.nan, X), y)
    with pytest.raises(InputError, match="requires y to be passed"):
        est.fit(X, None)
    with pytest.raises(InputError, match="all sample weights are zero"):
        est.fit(X, y, sample_weight=np.zeros(len(X)))
    with pytest.raises(InputError, match="sample_weight must be >= 0"):
        est.fit(X, y, sample_weight=-np.ones(len(X)))
    with pytest.raises(InputError, match="constant"):
        est.fit(np.ones((10, 2)), np.arange(10.0))
    with pytest.raises(NotFittedError, match="not fitted yet"):
        SimplexSplineRegressor().predict(X)
    with pytest.raises(sklearn.exceptions.NotFittedError):
        SimplexSplineRegressor().predict(X)
    est.fit(X, y)
    with pytest.raises(InputError, match="3 features"):
        est.predict(X[:, :2])


def test_without_scikit_learn_the_same_protocol_holds(tmp_path):
    """The fallbacks (get_params, set_params, score, input checks) when sklearn is absent."""
    code = textwrap.dedent("""
        import sys
        sys.modules["sklearn"] = None          # import sklearn -> ImportError
        import numpy as np
        from simplexspline.estimator.regressor import HAVE_SKLEARN, SimplexSplineRegressor
        from simplexspline import InputError
        assert not HAVE_SKLEARN
        rng = np.random.default_rng(0)
        X = rng.uniform(-1, 1, (500, 2)); y = X[:, 0] ** 2 - X[:, 1]
        est = SimplexSplineRegressor(degree=2, resolution=2)
        assert est.get_params()["degree"] == 2
        assert est.set_params(degree=3) is est
        assert repr(est) == "SimplexSplineRegressor(resolution=2)"
        assert abs(est.fit(X, y).score(X, y) - 1.0) < 1e-10
        try:
            est.set_params(bogus=1)
        except InputError as exc:
            assert "Invalid parameter 'bogus'" in str(exc)
        else:
            raise AssertionError("no error")
        try:
            est.predict(np.ones((3, 5)))
        except InputError as exc:
            assert "expecting 2 features" in str(exc)
        else:
            raise AssertionError("no error")
        print("ok")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
