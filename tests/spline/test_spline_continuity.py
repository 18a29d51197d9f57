"""Smoothness matrix H (Eq. 20-25) and C^r continuity across interior facets."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse

from simplexspline import SimplexSpline, SplineSpace, Triangulation, smoothness_matrix

from . import reference as ref
from .cases import data_in_simplices, make_triangulation, seeded, smooth_function

# ------------------------------------------------------------------------------- H matrix

H_CASES = [
    (n, d, r, kind)
    for kind in ("explicit", "grid", "delaunay")
    for n, d in [(1, 2), (1, 4), (2, 1), (2, 2), (2, 3), (2, 4), (3, 1), (3, 2), (3, 3), (4, 2)]
    for r in range(0, d)
    if not (n == 3 and d == 3 and kind != "explicit")
    if not (n == 4 and kind != "explicit")
]


def _dense(A):
    assert scipy.sparse.issparse(A)
    return A.toarray()


@pytest.mark.parametrize("n,d,r,kind", H_CASES)
def test_smoothness_matrix_against_dense_reference(n, d, r, kind):
    tri = make_triangulation(kind, n, seeded("H", n, d, r, kind))
    J, d_hat = tri.nsimplex, ref.num_basis(n, d)
    E = len(tri.facets.simplices)
    R = ref.conditions_per_facet(n, d, r)

    H_full = smoothness_matrix(tri, d, r, reduce=False)
    H = smoothness_matrix(tri, d, r)
    assert isinstance(H, scipy.sparse.csr_matrix) and isinstance(H_full, scipy.sparse.csr_matrix)
    assert H_full.shape == (E * R, J * d_hat)
    Hf, Hr = _dense(H_full), _dense(H)
    assert Hr.shape[1] == J * d_hat

    # reduced H: full row rank, as many rows as the rank of the unreduced H (Eq. 25)
    rank_full = ref.svd_rank(Hf)
    assert ref.svd_rank(Hr) == Hr.shape[0]
    assert Hr.shape[0] == rank_full
    # ... a subset of the unreduced rows
    for row in Hr:
        dist = np.abs(Hf - row[None, :]).max(axis=1)
        assert dist.min() <= 1e-12 * max(np.abs(row).max(), 1.0)
    # same constraints as the independent Eq. 21 reference: equal row spaces
    Href = ref.smoothness_matrix(tri.vertices, tri.simplices, d, r)
    rank_ref = ref.svd_rank(Href)
    assert rank_full == rank_ref
    assert ref.svd_rank(np.vstack([Hf, Href])) == rank_ref
    assert ref.svd_rank(np.vstack([Hr, Href])) == rank_ref

    # the space object exposes the same matrices
    space = SplineSpace(tri, d, r)
    assert space.dim_coefficients == J * d_hat
    np.testing.assert_array_equal(_dense(space.H_full), Hf)
    np.testing.assert_array_equal(_dense(space.H), Hr)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_smoothness_matrix_discontinuous_has_no_rows(n):
    tri = make_triangulation("grid", n, seeded("Hm1", n))
    H = smoothness_matrix(tri, 2, -1)
    assert H.shape == (0, tri.nsimplex * ref.num_basis(n, 2))


def test_unreduced_rank_deficient_around_interior_vertex():
    # the paper: redundant conditions appear around an interior vertex
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))  # centre vertex with 6 triangles
    Hf = smoothness_matrix(tri, 3, 1, reduce=False).toarray()
    H = smoothness_matrix(tri, 3, 1).toarray()
    assert ref.svd_rank(Hf) < Hf.shape[0]
    assert H.shape[0] == ref.svd_rank(Hf) < Hf.shape[0]


def test_dimension_of_univariate_spline_space():
    # 1-D: dim S^r_d on J intervals = J (d + 1) - (J - 1)(r + 1)
    tri = Triangulation(np.array([[0.0], [0.3], [1.0], [1.2], [2.0]]),
                        np.array([[0, 1], [1, 2], [2, 3], [3, 4]]))
    for d in range(1, 6):
        for r in range(0, d):
            H = smoothness_matrix(tri, d, r)
            assert 4 * (d + 1) - H.shape[0] == 4 * (d + 1) - 3 * (r + 1)


@pytest.mark.parametrize("n,d,r", [(2, 3, 1), (3, 2, 1), (2, 4, 2)])
def test_global_polynomial_satisfies_H(n, d, r):
    rng = seeded("Hpoly", n, d, r)
    tri = make_triangulation("explicit", n, rng)
    x, _ = data_in_simplices(tri, 2 * ref.num_basis(n, d), rng)
    p = ref.Poly.random(n, d, rng)
    # unconstrained per-simplex fits of a global polynomial are continuous: H c = 0
    c = SimplexSpline.fit(x, p(x), tri, d, -1).coefficients.ravel()
    for reduce in (True, False):
        H = smoothness_matrix(tri, d, r, reduce=reduce)
        assert np.abs(H @ c).max() <= 1e-9 * np.abs(c).max()


# ------------------------------------------------------------------------ C^r across facets


def facet_jumps(spline, tri, orders, rng, per_facet=2):
    """Max relative jump of each derivative order across all interior facets.

    Points are drawn at random on every interior facet; each side is evaluated with its own
    polynomial piece (``simplices=``). Scale: the largest |derivative| seen for that order
    (floored by 1e-3 of the largest value)."""
    fac = tri.facets
    n = tri.ndim
    F = len(fac.simplices)
    w = rng.dirichlet(np.ones(n), size=(F, per_facet))  # on the facet
    pts = np.einsum("fpk,fkn->fpn", w, tri.vertices[fac.vertices]).reshape(-1, n)
    s1 = np.repeat(fac.simplices[:, 0], per_facet)
    s2 = np.repeat(fac.simplices[:, 1], per_facet)
    value_scale = np.abs(spline.predict(pts, simplices=s1)).max()
    out = {}
    for order in orders:
        a = spline.derivative(pts, order, simplices=s1)
        b = spline.derivative(pts, order, simplices=s2)
        scale = max(np.abs(a).max(), np.abs(b).max(), 1e-3 * value_scale, 1e-300)
        out[order] = np.abs(a - b).max() / scale
    return out


CONT_CASES = [
    (n, d, r, kind)
    for kind in ("explicit", "delaunay", "grid", "fit")
    for n, d in [(1, 1), (1, 3), (1, 5), (2, 1), (2, 2), (2, 3), (2, 4), (2, 5), (3, 1), (3, 2),
                 (3, 3), (4, 2), (4, 3), (5, 2)]
    for r in range(0, d)
    if not (n == 4 and kind not in ("explicit", "grid"))
    if not (n == 5 and kind != "explicit")
]


@pytest.mark.parametrize("n,d,r,kind", CONT_CASES)
def test_derivatives_up_to_r_continuous_across_facets(n, d, r, kind):
    rng = seeded("cont", n, d, r, kind)
    tri = make_triangulation(kind, n, rng)
    x, _ = data_in_simplices(tri, ref.num_basis(n, d) + 4, rng)
    y = smooth_function(3.0 * x) + 0.01 * rng.standard_normal(len(x))
    s = SimplexSpline.fit(x, y, tri, d, r)
    jumps = facet_jumps(s, tri, ref.all_orders(n, r), rng)
    worst = max(jumps, key=jumps.get)
    assert jumps[worst] <= 1e-8, (worst, jumps[worst])
    if kind in ("grid", "fit") or n == 1:
        # order r + 1 in general jumps (grid hyperplanes carry truncated powers): the check
        # above would fail one order higher
        higher = facet_jumps(s, tri, [o for o in ref.all_orders(n, r + 1) if sum(o) == r + 1], rng)
        assert max(higher.values()) > 1e-5


def test_continuity_check_detects_discontinuous_fit():
    # r = -1: pieces fitted independently, values jump across facets
    rng = seeded("cont-fail")
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    x, _ = data_in_simplices(tri, 20, rng)
    y = smooth_function(3.0 * x) + 0.01 * rng.standard_normal(len(x))
    s = SimplexSpline.fit(x, y, tri, 2, -1)
    assert facet_jumps(s, tri, [(0, 0)], rng)[(0, 0)] > 1e-4
    s0 = SimplexSpline.fit(x, y, tri, 2, 0)
    jumps = facet_jumps(s0, tri, ref.all_orders(2, 1), rng)
    assert jumps[(0, 0)] <= 1e-8
    assert max(jumps[(1, 0)], jumps[(0, 1)]) > 1e-4
