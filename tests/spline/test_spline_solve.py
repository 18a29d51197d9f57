"""Regression matrix (Eq. 36), normal equations, the constrained estimator (Eq. 38-42)
against dense references, weights, streaming, and the on_insufficient policies."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse
from hypothesis import given
from hypothesis import strategies as st
from scipy.special import comb

from simplexspline import (
    InputError,
    InsufficientDataError,
    NormalEquations,
    OutsideDomainError,
    SimplexSpline,
    SplineSpace,
    Triangulation,
)
from simplexspline.spline.space import MAX_DEGREE

from . import reference as ref
from .cases import data_in_simplices, make_triangulation, seeded, smooth_function

SMALL_CASES = [
    (1, 3, 1, "grid"), (1, 4, 2, "delaunay"), (2, 1, 0, "grid"), (2, 2, 1, "delaunay"),
    (2, 3, 1, "grid"), (2, 3, 0, "explicit"), (2, 4, 2, "explicit"), (2, 4, 1, "fit"),
    (3, 2, 1, "explicit"), (3, 2, 0, "grid"), (3, 3, 1, "explicit"), (4, 2, 1, "explicit"),
    (2, 2, -1, "grid"),
]


def _problem(n, d, r, kind, tag, per=None):
    rng = seeded(tag, n, d, r, kind)
    tri = make_triangulation(kind, n, rng)
    d_hat = ref.num_basis(n, d)
    x, where = data_in_simplices(tri, per or (d_hat + 5), rng)
    y = smooth_function(2.0 * x) + 0.05 * rng.standard_normal(len(x))
    w = rng.uniform(0.2, 3.0, len(x))
    return rng, tri, x, where, y, w


@pytest.mark.parametrize("n,d,r,kind", SMALL_CASES)
def test_design_matrix_matches_dense_reference(n, d, r, kind):
    rng, tri, x, where, y, w = _problem(n, d, r, kind, "X")
    X = SplineSpace(tri, d, r).design_matrix(x)
    assert isinstance(X, scipy.sparse.csr_matrix)
    assert X.shape == (len(x), tri.nsimplex * ref.num_basis(n, d))
    Xref = ref.design_matrix(tri.vertices, tri.simplices, x, d, where=where)
    np.testing.assert_allclose(X.toarray(), Xref, rtol=1e-12, atol=1e-13)
    # each row touches only its simplex's d_hat columns
    assert X.nnz <= len(x) * ref.num_basis(n, d)


def test_design_matrix_outside_raises():
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    with pytest.raises(OutsideDomainError, match="(?i)outside") as info:
        SplineSpace(tri, 2, 1).design_matrix(np.array([[0.5, 0.5], [2.0, 0.5], [0.1, 0.2]]))
    np.testing.assert_array_equal(info.value.indices, [1])


@pytest.mark.parametrize("n,d,r,kind", SMALL_CASES[:8])
def test_normal_equations_match_dense(n, d, r, kind):
    rng, tri, x, where, y, w = _problem(n, d, r, kind, "NE")
    ne = SplineSpace(tri, d, r).normal_equations(x, y, w)
    assert isinstance(ne, NormalEquations)
    J, d_hat = tri.nsimplex, ref.num_basis(n, d)
    assert ne.XtWX.shape == (J, d_hat, d_hat) and ne.XtWy.shape == (J, d_hat)
    Xref = ref.design_matrix(tri.vertices, tri.simplices, x, d, where=where)
    full = Xref.T @ (w[:, None] * Xref)
    for j in range(J):
        blk = slice(j * d_hat, (j + 1) * d_hat)
        np.testing.assert_allclose(ne.XtWX[j], full[blk, blk], rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(ne.XtWy.ravel(), Xref.T @ (w * y), rtol=1e-11, atol=1e-12)
    assert ne.ytWy == pytest.approx(float(np.sum(w * y * y)), rel=1e-12)
    np.testing.assert_array_equal(ne.counts, np.bincount(where, minlength=J))
    # unweighted = weights of one
    ne1 = SplineSpace(tri, d, r).normal_equations(x, y)
    ne2 = SplineSpace(tri, d, r).normal_equations(x, y, np.ones(len(x)))
    np.testing.assert_allclose(ne1.XtWX, ne2.XtWX, rtol=1e-14, atol=0)


@pytest.mark.parametrize("n,d,r,kind", SMALL_CASES)
def test_constrained_solution_equals_nullspace_and_kkt_references(n, d, r, kind):
    rng, tri, x, where, y, w = _problem(n, d, r, kind, "solve")
    s = SplineSpace(tri, d, r).fit(x, y, weights=w)
    c = s.coefficients.ravel()
    X = ref.design_matrix(tri.vertices, tri.simplices, x, d, where=where)
    H = ref.smoothness_matrix(tri.vertices, tri.simplices, d, r)
    c_null = ref.nullspace_solution(X, y, H, w)
    assert np.linalg.norm(c - c_null) <= 1e-8 * np.linalg.norm(c_null)
    c_kkt = ref.kkt_solution(X, y, H, w)
    assert np.linalg.norm(c_kkt - c_null) <= 1e-6 * np.linalg.norm(c_null)  # pinv is cruder
    # and the same through SimplexSpline.fit and solve(normal_equations)
    s2 = SimplexSpline.fit(x, y, tri, d, r, weights=w)
    space = SplineSpace(tri, d, r)
    s3 = space.solve(space.normal_equations(x, y, w))
    np.testing.assert_allclose(s2.coefficients, s.coefficients, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(s3.coefficients, s.coefficients, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("n,d,r,kind",
                         [(2, 3, 1, "grid"), (3, 2, 1, "explicit"), (1, 3, 2, "grid")])
def test_zero_weight_sample_has_no_influence(n, d, r, kind):
    rng, tri, x, where, y, w = _problem(n, d, r, kind, "w0")
    base = SimplexSpline.fit(x, y, tri, d, r, weights=w)
    extra, _ = data_in_simplices(tri, 1, rng)
    x2 = np.vstack([x, extra])
    y2 = np.concatenate([y, 1e6 * rng.standard_normal(len(extra))])  # wild values
    w2 = np.concatenate([w, np.zeros(len(extra))])
    perm = rng.permutation(len(x2))
    s = SimplexSpline.fit(x2[perm], y2[perm], tri, d, r, weights=w2[perm])
    np.testing.assert_allclose(s.coefficients, base.coefficients, rtol=1e-10,
                               atol=1e-10 * np.abs(base.coefficients).max())


def test_uniform_weight_scaling_does_not_change_solution():
    rng, tri, x, where, y, w = _problem(2, 3, 1, "grid", "wscale")
    a = SimplexSpline.fit(x, y, tri, 3, 1, weights=w)
    b = SimplexSpline.fit(x, y, tri, 3, 1, weights=1e3 * w)
    np.testing.assert_allclose(a.coefficients, b.coefficients, rtol=1e-9, atol=1e-11)


@pytest.mark.parametrize("n,d,r,kind", [(2, 3, 1, "grid"), (3, 2, 0, "delaunay")])
def test_streaming_normal_equations_equal_one_shot(n, d, r, kind):
    rng, tri, x, where, y, w = _problem(n, d, r, kind, "stream")
    space = SplineSpace(tri, d, r)
    one = space.normal_equations(x, y, w)
    chunks = np.array_split(rng.permutation(len(x)), 5)
    acc = space.normal_equations(x[chunks[0]], y[chunks[0]], w[chunks[0]])
    for idx in chunks[1:3]:
        ret = acc.add(x[idx], y[idx], w[idx])
        assert ret is acc
    other = space.normal_equations(x[chunks[3]], y[chunks[3]], w[chunks[3]])
    other.add(x[chunks[4]], y[chunks[4]], w[chunks[4]])
    acc_before = (acc.XtWX.copy(), acc.XtWy.copy(), acc.ytWy, acc.counts.copy())
    other_before = (other.XtWX.copy(), other.counts.copy())
    merged = acc + other
    # '+' returns a new object and leaves its operands alone
    assert merged is not acc and merged is not other
    np.testing.assert_array_equal(acc.XtWX, acc_before[0])
    np.testing.assert_array_equal(acc.XtWy, acc_before[1])
    assert acc.ytWy == acc_before[2]
    np.testing.assert_array_equal(acc.counts, acc_before[3])
    np.testing.assert_array_equal(other.XtWX, other_before[0])
    np.testing.assert_array_equal(other.counts, other_before[1])
    for ne in (merged,):
        np.testing.assert_allclose(ne.XtWX, one.XtWX, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(ne.XtWy, one.XtWy, rtol=1e-12, atol=1e-13)
        assert ne.ytWy == pytest.approx(one.ytWy, rel=1e-12)
        np.testing.assert_array_equal(ne.counts, one.counts)
    s_stream = space.solve(merged)
    s_one = space.fit(x, y, weights=w)
    np.testing.assert_allclose(s_stream.coefficients, s_one.coefficients, rtol=1e-9, atol=1e-11)


# ------------------------------------------------------------------------- insufficient data


def _line(J=4):
    V = np.linspace(0.0, 1.0, J + 1)[:, None]
    return Triangulation(V, np.stack([np.arange(J), np.arange(1, J + 1)], axis=1))


def test_insufficient_data_raise_lists_simplices_and_counts():
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))  # 8 triangles
    rng = seeded("insuff")
    x, where = data_in_simplices(tri, 12, rng)
    keep = ~np.isin(where, [2, 5]) | (np.arange(len(x)) % 12 < 3)  # 3 points in 2 and 5
    keep &= where != 6  # simplex 6 empty
    x, where = x[keep], where[keep]
    y = smooth_function(x)
    d = 2  # d_hat = 6 > 3
    with pytest.raises(InsufficientDataError, match=r"(?s)2.*5.*6|simplices") as info:
        SimplexSpline.fit(x, y, tri, d, -1)
    assert set(info.value.simplices.tolist()) == {2, 5, 6}
    counts = dict(zip(info.value.simplices.tolist(), info.value.counts.tolist()))
    assert counts == {2: 3, 5: 3, 6: 0}
    msg = str(info.value)
    for j in (2, 5, 6):
        assert str(j) in msg
    # default policy is 'raise' everywhere
    with pytest.raises(InsufficientDataError, match="(?i)simplex|simplices"):
        SplineSpace(tri, d, -1).fit(x, y)
    with pytest.raises(InsufficientDataError, match="(?i)simplex|simplices"):
        SplineSpace(tri, d, -1).solve(SplineSpace(tri, d, -1).normal_equations(x, y))


def test_well_determined_problem_never_reported_insufficient():
    """Every simplex holds 14 > d_hat = 6 random points: the fit is unique, whatever the
    (tiny) dimension of S^1_2 on the three-direction mesh."""
    rng = seeded("s12")
    tri = Triangulation.grid([0, 0], [1, 1], (24, 24))
    x, _ = data_in_simplices(tri, 14, rng)
    y = smooth_function(x)
    s = SimplexSpline.fit(x, y, tri, 2, 1)
    assert np.all(np.isfinite(s.coefficients))
    H_full = SplineSpace(tri, 2, 1).H_full  # unreduced: no rank reduction needed here
    assert np.abs(H_full @ s.coefficients.ravel()).max() <= 1e-9


def test_insufficient_data_uses_continuity():
    """An empty interval is determined by continuity for C^0 linear, not for C^0 cubic."""
    tri = _line(3)
    rng = seeded("insuff-line")
    x = np.concatenate([rng.uniform(0, 1 / 3, 10), rng.uniform(2 / 3, 1, 10)])[:, None]
    y = 2.0 * x[:, 0] - 1.0
    s = SimplexSpline.fit(x, y, tri, 1, 0)  # middle piece fixed by its two end values
    xt = np.linspace(0.01, 0.99, 30)[:, None]
    np.testing.assert_allclose(s.predict(xt), 2.0 * xt[:, 0] - 1.0, rtol=1e-9, atol=1e-9)
    with pytest.raises(InsufficientDataError, match="(?i)simplex|simplices") as info:
        SimplexSpline.fit(x, y, tri, 3, 0)
    np.testing.assert_array_equal(info.value.simplices, [1])
    np.testing.assert_array_equal(info.value.counts, [0])


def test_insufficient_minnorm_keeps_data_determined_part():
    tri = _line(4)
    rng = seeded("minnorm")
    x = np.concatenate([rng.uniform(0.0, 0.25, 12), rng.uniform(0.5, 1.0, 25)])[:, None]
    y = np.sin(4 * x[:, 0])
    d, r = 3, 1
    space = SplineSpace(tri, d, r)
    s = space.fit(x, y, on_insufficient="minnorm")
    xt = np.linspace(0, 1, 41)[:, None]
    assert np.all(np.isfinite(s.predict(xt)))
    # the reference: minimum-norm constrained least squares
    where = ref.locate(tri.vertices, tri.simplices, x)
    X = ref.design_matrix(tri.vertices, tri.simplices, x, d, where=where)
    H = ref.smoothness_matrix(tri.vertices, tri.simplices, d, r)
    c_ref = ref.nullspace_solution(X, y, H)
    c = s.coefficients.ravel()
    np.testing.assert_allclose(X @ c, X @ c_ref, rtol=1e-8, atol=1e-9)  # fitted values unique
    assert np.abs(H @ c).max() <= 1e-9 * np.abs(c).max()
    # the data-determined coefficients (simplices 0, 2, 3 of which 2 and 3 are dense) equal
    # those of the reference; the free directions take the minimum norm
    np.testing.assert_allclose(s.coefficients[[0, 2, 3]], c_ref.reshape(4, -1)[[0, 2, 3]],
                               rtol=1e-7, atol=1e-8)
    assert np.linalg.norm(c) <= np.linalg.norm(c_ref) * (1 + 1e-8)
    # r = -1: empty simplex gets zero coefficients, the others the plain per-simplex fit
    s_disc = SplineSpace(tri, d, -1).fit(x, y, on_insufficient="minnorm")
    for j in (0, 2, 3):
        rows = where == j
        cj = np.linalg.lstsq(X[rows][:, j * 4:(j + 1) * 4], y[rows], rcond=None)[0]
        np.testing.assert_allclose(s_disc.coefficients[j], cj, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(s_disc.coefficients[1], 0.0, atol=1e-12)


def test_insufficient_ridge_finite():
    tri = Triangulation.grid([0, 0], [1, 1], (3, 3))
    rng = seeded("ridge")
    x = rng.uniform(0, 1, (300, 2))
    x = x[x.sum(1) < 1.0]  # upper right half empty
    y = smooth_function(x)
    for kw in ({}, {"ridge": 1e-8}):
        s = SplineSpace(tri, 3, 1).fit(x, y, on_insufficient="ridge", **kw)
        xt = rng.uniform(0, 1, (200, 2))
        assert np.all(np.isfinite(s.predict(xt)))
        assert np.all(np.isfinite(s.coefficients))
        # data well represented where there are data
        assert np.sqrt(np.mean((s.predict(x) - y) ** 2)) < 1e-2
    with pytest.raises(InputError, match="(?i)on_insufficient"):
        SplineSpace(tri, 3, 1).fit(x, y, on_insufficient="ignore")


# --------------------------------------------------------------------------- affine invariance


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 3), d=st.integers(1, 3), data=st.data())
def test_affine_invariance_of_fits(seed, n, d, data):
    """B-coefficients depend only on barycentric coordinates: fitting the affinely mapped
    data on the affinely mapped triangulation gives the same coefficients."""
    r = data.draw(st.integers(-1, d - 1), label="r")
    rng = np.random.default_rng(seed)
    tri = make_triangulation(data.draw(st.sampled_from(["explicit", "grid"]), label="kind"), n, rng)
    x, _ = data_in_simplices(tri, ref.num_basis(n, d) + 3, rng)
    y = smooth_function(x) + 0.1 * rng.standard_normal(len(x))
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    A = Q @ np.diag(rng.uniform(0.3, 3.0, n)) * data.draw(st.sampled_from([1.0, 1e-3, 1e3]))
    t = rng.uniform(-5, 5, n)
    mapped = Triangulation(tri.vertices @ A.T + t, tri.simplices)
    s1 = SimplexSpline.fit(x, y, tri, d, r)
    s2 = SimplexSpline.fit(x @ A.T + t, y, mapped, d, r)
    np.testing.assert_allclose(s2.coefficients, s1.coefficients, rtol=1e-8,
                               atol=1e-8 * np.abs(s1.coefficients).max())


def test_points_in_lower_dimensional_set_are_insufficient():
    """Enough points, but all on one line inside a triangle: a quadratic is not determined."""
    tri = Triangulation.grid([0, 0], [1, 1], (1, 1))
    rng = seeded("collinear")
    x, where = data_in_simplices(tri, 20, rng)
    j = 0
    Vj = tri.vertices[tri.simplices[j]]
    t = rng.uniform(0.1, 0.9, 20)
    a, b = Vj.mean(0) + 0.2 * (Vj[0] - Vj.mean(0)), Vj.mean(0) + 0.2 * (Vj[1] - Vj.mean(0))
    line = a + t[:, None] * (b - a)
    x = np.vstack([x[where != j], line])
    y = smooth_function(x)
    with pytest.raises(InsufficientDataError, match=str(j)) as info:
        SimplexSpline.fit(x, y, tri, 2, -1)
    np.testing.assert_array_equal(info.value.simplices, [j])
    np.testing.assert_array_equal(info.value.counts, [20])
    # linear pieces are determined by points on a line? no: still undetermined for d = 1
    with pytest.raises(InsufficientDataError, match="(?i)simplex|simplices"):
        SimplexSpline.fit(x, y, tri, 1, -1)
    # with C^0 continuity a linear spline is determined (the other triangle fixes the edge)
    s = SimplexSpline.fit(x, y, tri, 1, 0)
    assert np.all(np.isfinite(s.coefficients))


@pytest.mark.parametrize("policy", ["minnorm", "raise"])
def test_policies_agree_on_determined_problems(policy):
    rng, tri, x, where, y, w = _problem(2, 3, 1, "grid", "policies")
    base = SimplexSpline.fit(x, y, tri, 3, 1, weights=w)
    s = SplineSpace(tri, 3, 1).fit(x, y, weights=w, on_insufficient=policy)
    np.testing.assert_allclose(s.coefficients, base.coefficients, rtol=1e-9, atol=1e-11)


def test_simplex_with_only_zero_weights_is_insufficient():
    rng, tri, x, where, y, w = _problem(2, 2, -1, "grid", "allzero")
    w = w.copy()
    w[where == 3] = 0.0
    with pytest.raises(InsufficientDataError, match="(?i)simplex|simplices") as info:
        SimplexSpline.fit(x, y, tri, 2, -1, weights=w)
    np.testing.assert_array_equal(info.value.simplices, [3])


def test_solve_rejects_normal_equations_of_another_space():
    rng, tri, x, where, y, w = _problem(2, 2, 1, "grid", "otherspace")
    ne = SplineSpace(tri, 2, 1).normal_equations(x, y)
    other = Triangulation.grid([0, 0], [1, 1], (3, 3))
    with pytest.raises(InputError, match="(?i)triangulation|degree|space|match|different"):
        SplineSpace(other, 2, 1).solve(ne)
    with pytest.raises(InputError, match="(?i)triangulation|degree|space|match|different"):
        SplineSpace(tri, 3, 1).solve(ne)
    # same number of simplices, different geometry: must not be solved silently
    stretched = Triangulation(tri.vertices * 2.0, tri.simplices)
    with pytest.raises(InputError, match="(?i)triangulation|space|match|different"):
        SplineSpace(stretched, 2, 1).solve(ne)


def test_fit_triangulation_with_min_points_above_data_size():
    x = seeded("minpts").uniform(size=(20, 2))
    from simplexspline import SimplexSplineError

    with pytest.raises(SimplexSplineError, match="(?i)min_points|no simplex|empty|points"):
        Triangulation.fit(x, (2, 2), min_points=100)


@pytest.mark.parametrize("n,d,r,kind", [(3, 4, -1, "explicit"), (2, 5, -1, "grid"),
                                         (2, 3, 1, "grid"), (3, 2, 1, "grid")])
def test_weights_spanning_six_decades(n, d, r, kind):
    """d_hat + 5 random points per simplex and weights 10^U(-3, 3): the data determine the
    spline (ill-conditioned, not singular), so the fit must succeed and be RSS-optimal."""
    rng = seeded("probe", n, d, r, kind)
    tri = make_triangulation(kind, n, rng)
    x, where = data_in_simplices(tri, ref.num_basis(n, d) + 5, rng)
    y = smooth_function(2 * x) + 0.05 * rng.standard_normal(len(x))
    w = 10 ** rng.uniform(-3, 3, len(x))
    s = SimplexSpline.fit(x, y, tri, d, r, weights=w)
    X = ref.design_matrix(tri.vertices, tri.simplices, x, d, where=where)
    H = ref.smoothness_matrix(tri.vertices, tri.simplices, d, r)
    c_ref = ref.nullspace_solution(X, y, H, w)
    rss = lambda c: float(np.sum(w * (y - X @ c) ** 2))  # noqa: E731
    assert rss(s.coefficients.ravel()) <= rss(c_ref) * (1 + 1e-6)


def test_insufficient_error_always_names_simplices():
    """Whatever triggers it, an InsufficientDataError lists the offending simplices."""
    rng = seeded("names")
    tri = Triangulation.grid([0, 0, 0], [1, 1, 1], (1, 1, 1))
    for d, r, per in [(2, -1, 5), (3, 1, 4), (2, 0, 3), (4, -1, 30)]:
        x, where = data_in_simplices(tri, per, rng)
        x = x[where != 2]
        try:
            SimplexSpline.fit(x, smooth_function(x), tri, d, r)
        except InsufficientDataError as err:
            assert err.simplices.size > 0, (d, r, str(err))
            assert len(err.counts) == len(err.simplices)
            for j in err.simplices[:5]:
                assert str(j) in str(err)


def test_high_degree_fit_limited_by_conditioning_not_refused():
    """Issue 18, item 7: n = 2, d = 16 on a 2 x 2 grid with 5,000 points. The Gram blocks
    have condition numbers near 1e11, so coefficients are only known to about 1e-5
    relative; the solve must still return the (backward-stable) constrained least-squares
    fit instead of calling the determined system singular."""
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    rng = seeded("high-degree")
    x = rng.random((5000, 2))
    y = np.sin(3 * x[:, 0]) + x[:, 1] ** 2
    s = SplineSpace(tri, 16, 1).fit(x, y, on_insufficient="minnorm")
    assert np.sqrt(np.mean((s.predict(x) - y) ** 2)) < 1e-9  # smooth: fitted to round-off
    c = s.coefficients.ravel()
    assert np.abs(SplineSpace(tri, 16, 1).H_full @ c).max() <= 1e-12 * np.abs(c).max()


def _bernstein_mass_condition(d: int) -> float:
    """Condition number of the univariate Bernstein mass matrix of degree d,
    int B_i B_j = C(d,i) C(d,j) / C(2d,i+j) / (2d+1)."""
    i = np.arange(d + 1)
    G = comb(d, i)[:, None] * comb(d, i)[None, :] / comb(2 * d, i[:, None] + i[None, :])
    w = np.linalg.eigvalsh(G)
    return w[-1] / w[0]


def test_numerically_hopeless_degree_is_refused_up_front():
    """Issue 18, item 7: d = 30 with minnorm took minutes and then failed; a degree whose
    Gram matrices pass double precision is refused when the space is made, naming the
    limit and what to do."""
    # evenly spread data: condition 1e12 at most; real data are 10-100 times worse
    assert _bernstein_mass_condition(MAX_DEGREE) < 1e12 < _bernstein_mass_condition(
        MAX_DEGREE + 2)
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    for d in (MAX_DEGREE + 1, 30):
        with pytest.raises(InputError, match=f"degree {d} is numerically hopeless.*"
                                             f"use degree <= {MAX_DEGREE}"):
            SplineSpace(tri, d, 1)
    x = seeded("hopeless").random((5000, 2))
    with pytest.raises(InputError, match="numerically hopeless"):
        SimplexSpline.fit(x, x[:, 0], tri, degree=30, on_insufficient="minnorm")
    assert SplineSpace(tri, MAX_DEGREE, 1).nbasis == 231


def test_full_rank_screen_accepts_only_clearly_nonsingular_conditions():
    """The Cholesky screen of _undetermined says 'full rank' for a well-conditioned block
    of conditions, never for one with a null direction or singular values near the SVD's
    1e-9 rank threshold (those go on to the exact SVD)."""
    from simplexspline.spline.fit.constrained import _clearly_full_rank

    rng = np.random.default_rng(0)
    u, _ = np.linalg.qr(rng.standard_normal((300, 40)))
    v, _ = np.linalg.qr(rng.standard_normal((40, 40)))
    for smallest, full in ((1e-2, True), (1e-4, True), (1e-7, False), (1e-10, False),
                           (0.0, False)):
        sv = np.geomspace(1.0, max(smallest, 1e-300), 40)
        sv[-1] = smallest
        C = (u * sv) @ v.T
        assert _clearly_full_rank(C.T @ C) is full, smallest
    assert not _clearly_full_rank(np.zeros((3, 3)))


@pytest.mark.parametrize("seed", [0, 3, 5])
def test_undetermined_directions_match_a_dense_null_space(seed):
    """null(Q) intersected with null(H), found by components (most of them screened as
    full rank), spans the null space of the stacked dense [Q; H]."""
    from simplexspline.spline import kernels
    from simplexspline.spline.fit.constrained import _null_directions, _undetermined

    rng = np.random.default_rng(seed)
    tri = Triangulation.delaunay(rng.random((9, 3)))
    space = SplineSpace(tri, 4, 1)
    # sparse data: simplices with many points, with a few, and without any
    many, few = np.array_split(rng.permutation(tri.nsimplex)[:2 * tri.nsimplex // 3], 2)
    x = np.vstack([np.einsum("ik,ikn->in", rng.dirichlet(np.ones(4), k),
                             tri.corners[[j] * k]) for js, k in ((many, 60), (few, 6))
                   for j in js])
    ne = space.normal_equations(x, np.sin(x).sum(axis=1))
    N, _ = _null_directions(ne.XtWX, ne.counts)
    H = space.system.H_full
    Z = _undetermined(N, H).toarray()
    Qd = scipy.linalg.block_diag(*ne.XtWX)
    stacked = np.vstack([Qd / np.abs(Qd).max(), H.toarray()])
    with kernels.one_blas_thread():  # threaded OpenBLAS took 14 s here on a loaded machine
        sv, vt = np.linalg.svd(stacked, full_matrices=False)[1:]
    ref_null = vt[int((sv > 1e-9 * sv[0]).sum()):].T
    assert Z.shape[1] == ref_null.shape[1] > 0
    # the same subspace: each basis projects onto the other without loss
    Zo = np.linalg.qr(Z)[0]
    np.testing.assert_allclose(ref_null @ (ref_null.T @ Zo), Zo, atol=1e-7)
