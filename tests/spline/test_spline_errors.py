"""Bad input raises a clear exception naming the problem (issue 2 acceptance)."""

from __future__ import annotations

import numpy as np
import pytest

from simplexspline import (
    DegenerateSimplexError,
    InputError,
    InsufficientDataError,
    SimplexSpline,
    SimplexSplineError,
    SplineSpace,
    Triangulation,
)

from .cases import data_in_simplices, seeded, smooth_function


@pytest.fixture(scope="module")
def setup():
    rng = seeded("errors")
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    x, _ = data_in_simplices(tri, 15, rng)
    y = smooth_function(x)
    return tri, x, y


def test_all_errors_are_simplexspline_errors():
    for cls in (InputError, DegenerateSimplexError, InsufficientDataError):
        assert issubclass(cls, SimplexSplineError)
    assert issubclass(InputError, ValueError)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nan_inf_in_x_y_weights(setup, bad):
    tri, x, y = setup
    xb = x.copy()
    xb[3, 1] = bad
    with pytest.raises(InputError, match="(?i)nan|inf|finite") as info:
        SimplexSpline.fit(xb, y, tri, 2, 1)
    assert "x" in str(info.value)
    yb = y.copy()
    yb[7] = bad
    with pytest.raises(InputError, match="(?i)nan|inf|finite") as info:
        SimplexSpline.fit(x, yb, tri, 2, 1)
    assert "y" in str(info.value)
    w = np.ones(len(y))
    w[2] = bad
    with pytest.raises(InputError, match="(?i)nan|inf|finite|weight"):
        SimplexSpline.fit(x, y, tri, 2, 1, weights=w)
    s = SimplexSpline.fit(x, y, tri, 2, 1)
    with pytest.raises(InputError, match="(?i)nan|inf|finite"):
        s.predict(xb)
    with pytest.raises(InputError, match="(?i)nan|inf|finite"):
        s.gradient(xb)
    with pytest.raises(InputError, match="(?i)nan|inf|finite"):
        SplineSpace(tri, 2, 1).normal_equations(xb, y)



def _fit(t, x, y, **kw):
    return SimplexSpline.fit(x, y, t, 2, 1, **kw)


DIMENSION = "(?i)dimension|column|shape|ndim"
ONE_D = "(?i)1-d|one-dimensional|shape|ndim"

SHAPE_CASES = {
    "x-3-columns-for-2-D": (lambda t, x, y, s: _fit(t, np.hstack([x, x[:, :1]]), y), DIMENSION),
    "y-too-short": (lambda t, x, y, s: _fit(t, x, y[:-1]), "(?i)length|rows|shape|match|same"),
    "y-2-D": (lambda t, x, y, s: _fit(t, x, y[:, None]), ONE_D),
    "weights-wrong-length": (lambda t, x, y, s: _fit(t, x, y, weights=np.ones(len(y) + 1)),
                             "(?i)weight"),
    "weights-negative": (lambda t, x, y, s: _fit(t, x, y, weights=-np.ones(len(y))),
                         "(?i)weight|negative"),
    "predict-3-columns": (lambda t, x, y, s: s.predict(np.zeros((4, 3))), DIMENSION),
    "predict-1-D-array": (lambda t, x, y, s: s.predict(np.zeros(4)), DIMENSION),
    "derivative-order-length": (lambda t, x, y, s: s.derivative(x, (1,)), "(?i)order"),
    "derivative-order-negative": (lambda t, x, y, s: s.derivative(x, (-1, 1)),
                                  "(?i)order|negative"),
    "simplices-out-of-range": (
        lambda t, x, y, s: s.predict(x[:2], simplices=np.array([0, t.nsimplex])),
        "(?i)simplex|indices|range|index"),
    "simplices-wrong-length": (lambda t, x, y, s: s.predict(x[:3], simplices=np.array([0, 1])),
                               "(?i)simplices|shape|length"),
    "normal-equations-y-2-D": (
        lambda t, x, y, s: SplineSpace(t, 2, 1).normal_equations(x, y[:, None]), ONE_D),
    "design-matrix-3-columns": (
        lambda t, x, y, s: SplineSpace(t, 2, 1).design_matrix(np.zeros((2, 3))), DIMENSION),
}


@pytest.mark.parametrize("case", list(SHAPE_CASES))
def test_wrong_shapes_and_dimension_mismatch(setup, case):
    tri, x, y = setup
    s = SimplexSpline.fit(x, y, tri, 2, 1)
    call, pattern = SHAPE_CASES[case]
    with pytest.raises(InputError, match=pattern):
        call(tri, x, y, s)


def test_merging_normal_equations_of_different_spaces(setup):
    tri, x, y = setup
    a = SplineSpace(tri, 2, 1).normal_equations(x, y)
    b = SplineSpace(tri, 3, 1).normal_equations(x, y)
    with pytest.raises(InputError, match="(?i)degree|triangulation|match|compatible|different"):
        a + b
    stretched = Triangulation(tri.vertices * 2.0, tri.simplices)
    c = SplineSpace(stretched, 2, 1).normal_equations(2.0 * x, y)
    with pytest.raises(InputError, match="(?i)triangulation|match|compatible|different"):
        a + c


@pytest.mark.parametrize("degree,continuity,pattern", [
    (-1, -1, "(?i)degree"),
    (2, 2, "(?i)continuity"),
    (2, 3, "(?i)continuity"),
    (0, 0, "(?i)continuity"),
    (3, -2, "(?i)continuity"),
])
def test_bad_degree_and_continuity(setup, degree, continuity, pattern):
    tri, x, y = setup
    with pytest.raises(InputError, match=pattern):
        SplineSpace(tri, degree, continuity)
    with pytest.raises(InputError, match=pattern):
        SimplexSpline.fit(x, y, tri, degree, continuity)


def test_non_integer_degree(setup):
    tri, x, y = setup
    with pytest.raises(InputError, match="(?i)degree|integer"):
        SplineSpace(tri, 2.5, 1)


def test_degenerate_simplices_named():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1]], dtype=float)
    S = np.array([[0, 1, 2, 4], [0, 1, 2, 3]])  # the second tetrahedron is flat (z = 0)
    with pytest.raises(DegenerateSimplexError, match="(?i)degenerate|volume") as info:
        Triangulation(V, S)
    np.testing.assert_array_equal(info.value.simplices, [1])
    assert "1" in str(info.value)


def test_too_little_data_lists_simplices(setup):
    tri, x, y = setup
    where = tri.locate(x)
    keep = where != 3
    with pytest.raises(InsufficientDataError, match="3") as info:
        SimplexSpline.fit(x[keep], y[keep], tri, 2, -1)
    np.testing.assert_array_equal(info.value.simplices, [3])
    np.testing.assert_array_equal(info.value.counts, [0])
    with pytest.raises(InsufficientDataError, match="(?i)simplex|simplices"):
        SimplexSpline.fit(x[:4], y[:4], tri, 3, 1)


def test_empty_data(setup):
    tri, x, y = setup
    with pytest.raises((InputError, InsufficientDataError),
                       match="(?i)no data|empty|points|simplices"):
        SimplexSpline.fit(x[:0], y[:0], tri, 1, 0)


def test_fit_points_outside_triangulation(setup):
    from simplexspline import OutsideDomainError

    tri, x, y = setup
    xo = np.vstack([x, [[5.0, 5.0]]])
    yo = np.append(y, 1.0)
    with pytest.raises(OutsideDomainError, match="(?i)outside") as info:
        SimplexSpline.fit(xo, yo, tri, 2, 1)
    np.testing.assert_array_equal(info.value.indices, [len(x)])


@pytest.mark.parametrize("where", ["x", "y", "weights", "predict"])
def test_complex_input_is_refused_not_truncated(where):
    """numpy would drop the imaginary part with only a ComplexWarning (issue 18, item 9)."""
    from simplexspline import InputError, SplineSpace, Triangulation

    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, (200, 2))
    y = x[:, 0] + x[:, 1]
    space = SplineSpace(Triangulation.grid([0, 0], [1, 1], (1, 1)), 1, 0)
    args = {"x": x, "y": y, "weights": np.ones(len(y))}
    if where == "predict":
        with pytest.raises(InputError, match=r"x is complex: give real numbers"):
            space.fit(x, y).predict(x + 1e-3j)
        return
    args[where] = args[where] + 1j
    with pytest.raises(InputError, match=rf"{where} is complex: give real numbers"):
        space.fit(args["x"], args["y"], args["weights"])


@pytest.mark.parametrize("ndim, degree", [(2, 1000), (5, 30)])
def test_huge_degree_is_refused_before_any_allocation(ndim, degree):
    """d = 1000 (or 30 in 5-D) would ask numpy for TiB: a clear message up front."""
    from simplexspline import InputError, SimplexSpline, SplineSpace, Triangulation

    tri = Triangulation.grid(np.zeros(ndim), np.ones(ndim), (1,) * ndim)
    with pytest.raises(InputError, match=r"degree \d+ in \d dimensions has [\d,]+ "
                                         r"B-coefficients, above the limit 6,000"):
        SplineSpace(tri, degree, 0)
    with pytest.raises(InputError, match="above the limit"):
        SimplexSpline(tri, degree, 0, np.zeros((tri.nsimplex, 1)))
