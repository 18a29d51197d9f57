"""Continuity orders per facet: one polynomial per grid cell (``cell_facets``), facets on
given hyperplanes (``plane_facets``), and terms of a varying-coefficient spline that are
one polynomial across chosen facets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplexspline import InputError, SplineSpace, Triangulation
from simplexspline.spline.bform import num_basis
from simplexspline.spline.continuity import build_conditions, cell_facets, plane_facets
from simplexspline.spline.varying import VaryingCoefficientSpace

from .cases import seeded


def _cellwise(tri, d, r):
    return SplineSpace(tri, d, r, np.where(cell_facets(tri), d, r))


def _monomials(x, d):
    """All monomials of degree <= d of the columns of x, shape (N, C(d + n, n))."""
    n = x.shape[1]
    cols = [np.ones(len(x))]
    for deg in range(1, d + 1):
        for combo in _compositions(n, deg):
            cols.append(np.prod(x ** np.asarray(combo), axis=1))
    return np.column_stack(cols)


def _compositions(n, deg):
    if n == 1:
        yield (deg,)
        return
    for k in range(deg + 1):
        for rest in _compositions(n - 1, deg - k):
            yield (k, *rest)


@pytest.mark.parametrize("n, shape", [(2, (3, 2)), (3, (2, 2, 1)), (3, (1, 1, 1))])
def test_cell_facets_are_the_kuhn_diagonals(n, shape):
    tri = Triangulation.grid(np.zeros(n), np.ones(n), shape)
    inside = cell_facets(tri)
    # a Kuhn cell has n! simplices around its main diagonal: in 2-D one diagonal facet
    # per cell, in 3-D six facets per cube
    per_cell = {2: 1, 3: 6}[n]
    assert inside.sum() == per_cell * math.prod(shape)
    V = np.asarray(tri.vertices)[tri.facets.vertices]
    on_plane = np.any(np.ptp(V, axis=1) == 0, axis=1)
    np.testing.assert_array_equal(inside, ~on_plane)


@pytest.mark.parametrize("n, shape, d", [(2, (3, 2), 2), (2, (2, 2), 3), (3, (2, 2, 1), 2)])
def test_cellwise_space_is_one_polynomial_per_cell(n, shape, d):
    rng = seeded("cellwise", n, d)
    tri = Triangulation.grid(np.zeros(n), np.ones(n), shape)
    space = _cellwise(tri, d, 0)
    x = rng.random((4000, n))
    spline = space.fit(x, np.sin(4 * x[:, 0]) * np.cos(3 * x[:, -1]) + x[:, 0] * x[:, 1]
                       + 0.05 * rng.standard_normal(len(x)))
    c = np.asarray(spline.coefficients).ravel()
    assert np.abs(SplineSpace(tri, d, 0).H_full @ c).max() < 1e-10     # C^0 everywhere
    assert np.abs(space.H_full @ c).max() < 1e-10
    cells = np.stack(np.meshgrid(*[np.arange(k) for k in shape], indexing="ij"),
                     axis=-1).reshape(-1, n)
    for c in cells:     # inside each cell the spline is exactly one polynomial of degree d
        pts = (c + rng.random((200, n))) / np.asarray(shape)
        A = _monomials(pts, d)
        v = spline.predict(pts)
        coef = np.linalg.lstsq(A, v, rcond=None)[0]
        assert np.abs(A @ coef - v).max() < 1e-10
    # with a single cell the space is the polynomials of degree d
    one = _cellwise(Triangulation.grid(np.zeros(n), np.ones(n), (1,) * n), d, 0)
    assert one.dimension == num_basis(n, d)


def test_cellwise_dimension_and_tables():
    """C^0 quadratics, one per cell of a 3 x 2 x 2 grid: 10 + 4 per grid plane + one per
    pair of crossing planes (truncated powers) = 31; the plain Kuhn space is far larger."""
    tri = Triangulation.grid([0, 0, 0], [1, 1, 1], (3, 2, 2))
    cw, plain = _cellwise(tri, 2, 0), SplineSpace(tri, 2, 0)
    assert cw.dimension == 10 + 4 * (2 + 1 + 1) + (2 * 1 + 2 * 1 + 1 * 1) == 31
    assert plain.dimension > 5 * cw.dimension
    # a bilinear table (hat functions on the grid) lies in the space ...
    rng = seeded("cellwise-table")
    x = rng.random((3000, 3))
    knots0, knots1 = np.linspace(0, 1, 4), np.linspace(0, 1, 3)
    table = rng.standard_normal((4, 3))
    y = sum(table[i, j] * np.interp(x[:, 0], knots0, np.eye(4)[i])
            * np.interp(x[:, 1], knots1, np.eye(3)[j]) for i in range(4) for j in range(3))
    y = y + x[:, 2] ** 2
    assert np.abs(cw.fit(x, y).predict(x) - y).max() < 1e-10
    # ... a piecewise-linear function on the Kuhn simplices (kinks along the diagonals)
    # lies in the plain S^0_1, not in the cellwise one
    kuhn = SplineSpace(tri, 1, 0).fit(x, rng.standard_normal(len(x))).predict(x)
    assert np.abs(SplineSpace(tri, 1, 0).fit(x, kuhn).predict(x) - kuhn).max() < 1e-10
    assert np.abs(_cellwise(tri, 1, 0).fit(x, kuhn).predict(x) - kuhn).max() > 1e-3


def test_uniform_facet_orders_equal_the_plain_conditions():
    tri = Triangulation.grid([0, 0], [1, 1], (2, 3))
    a = build_conditions(tri, 3, 1)
    b = build_conditions(tri, 3, 5, np.full(len(tri.facets), 1))
    assert (a.matrix != b.matrix).nnz == 0
    np.testing.assert_array_equal(a.order, b.order)
    # every row knows its facet; C^0 rows come first, facet by facet
    assert a.facet.shape == a.order.shape and a.facet.max() == len(tri.facets) - 1
    f = tri.facets
    sigma = np.asarray(tri.vertices)[np.asarray(tri.simplices)[f.simplices[:, 0],
                                                                 f.out_positions[:, 0]]]
    c = build_conditions(tri, 3, 1, None, sigma)          # the true out-of-facet vertices
    assert abs(c.matrix - a.matrix).max() < 1e-12
    none = build_conditions(tri, 3, 1, np.full(len(tri.facets), -1))
    assert none.matrix.shape[0] == 0


def test_facet_continuity_errors():
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    nf = len(tri.facets)
    with pytest.raises(InputError, match="one per interior facet"):
        SplineSpace(tri, 2, 0, np.zeros(nf + 1, dtype=int))
    with pytest.raises(InputError, match="one per interior facet"):
        SplineSpace(tri, 2, 0, np.zeros(nf))                 # floats
    with pytest.raises(InputError, match="between the continuity 0 and the degree 2"):
        SplineSpace(tri, 2, 0, np.full(nf, 3))
    with pytest.raises(InputError, match="between the continuity 1 and the degree 2"):
        SplineSpace(tri, 2, 1, np.zeros(nf, dtype=int))
    assert "mixed facet continuity" in repr(_cellwise(tri, 2, 0))


def test_plane_facets():
    tri = Triangulation.grid([0, 0], [1, 1], (4, 2))
    mid = plane_facets(tri, 0, [0.5])
    assert mid.sum() == 2                               # two grid edges on x0 = 0.5
    both = plane_facets(tri, 0, [0.25, 0.5, 0.75])
    assert both.sum() == 6 and not np.any(both & cell_facets(tri))
    assert plane_facets(tri, 1, [0.5]).sum() == 4
    assert not plane_facets(tri, 1, []).any()


@pytest.mark.parametrize("cellwise", [False, True])
def test_a_term_is_one_polynomial_across_chosen_planes(cellwise):
    """Term 1 has no break at z0 = 0.5 (a derivative tabulated on a coarser grid): its
    two halves are one polynomial, while term 0 keeps its kink there."""
    rng = seeded("vc-planes", cellwise)
    tri = Triangulation.grid([0, 0], [1, 1], (4, 2))
    space = _cellwise(tri, 2, 0) if cellwise else SplineSpace(tri, 2, 0)
    z = rng.random((8000, 2))
    m = np.column_stack([np.ones(len(z)), rng.uniform(-1, 1, len(z))])
    y = np.abs(z[:, 0] - 0.5) + (1 + z[:, 0] - z[:, 1] ** 2) * m[:, 1] \
        + 0.01 * rng.standard_normal(len(z))
    drop = plane_facets(tri, 0, [0.5])
    fit = VaryingCoefficientSpace(space, 2, term_facets=[None, drop]).fit(z, m, y)
    if cellwise:   # within a row of cells: term 1 one quadratic across z0 = 0.5, term 0 not
        band = np.column_stack([rng.uniform(0.25, 0.75, 400), rng.uniform(0, 0.5, 400)])
        A = _monomials(band, 2)
        for k, most, least in ((1, 0.0, 1e-9), (0, 1e-3, np.inf)):
            v = fit.terms[k].predict(band)
            resid = np.abs(A @ np.linalg.lstsq(A, v, rcond=None)[0] - v).max()
            assert most <= resid < least
    g = fit.terms[1].gradient(np.array([[0.5 - 1e-7, 0.3], [0.5 + 1e-7, 0.3]]))
    assert abs(g[0, 0] - g[1, 0]) < 1e-5                # no kink of term 1 at z0 = 0.5
    g = fit.terms[0].gradient(np.array([[0.5 - 1e-7, 0.3], [0.5 + 1e-7, 0.3]]))
    assert g[1, 0] - g[0, 0] > 1.5                       # term 0 keeps the |z0 - 0.5| kink
    with pytest.raises(InputError, match="term_facets must be None or"):
        VaryingCoefficientSpace(space, 2, term_facets=[None, drop[:-1]])
    with pytest.raises(InputError, match="one entry per term"):
        VaryingCoefficientSpace(space, 2, term_facets=[drop])


def test_stretched_join_is_one_polynomial_in_physical_coordinates():
    """Cells of widths 0.5 and 0.25 in physical units, both 1/2 in the unit box: with the
    out-of-facet vertices moved by the width ratio the two halves are one physical
    polynomial (x^2 is fitted exactly); joined C^2 in box coordinates they are not."""
    tri = Triangulation.grid([0.0], [1.0], (2,))
    f = tri.facets
    sigma = np.asarray(tri.vertices)[np.asarray(tri.simplices)[f.simplices[:, 0],
                                                                 f.out_positions[:, 0]]]
    u0, widths = 0.5, {True: 0.5, False: 0.25}              # below / above the plane
    below = sigma[:, 0] < u0
    pts = sigma.copy()
    pts[:, 0] = u0 + (sigma[:, 0] - u0) * np.where(below, widths[True] / widths[False],
                                                  widths[False] / widths[True])
    u = np.linspace(0, 1, 200)[:, None]
    x = np.where(u[:, 0] < u0, u[:, 0], 0.5 + (u[:, 0] - u0) * 0.5)     # physical
    space = SplineSpace(tri, 2, 0)
    vc = VaryingCoefficientSpace(space, 1, term_facets=[(np.ones(len(f), bool), pts)])
    plain = VaryingCoefficientSpace(space, 1, term_facets=[np.ones(len(f), bool)])
    one = np.ones((len(u), 1))
    assert np.abs(vc.fit(u, one, x ** 2).predict(u, one) - x ** 2).max() < 1e-12
    assert np.abs(plain.fit(u, one, x ** 2).predict(u, one) - x ** 2).max() > 1e-3
    with pytest.raises(InputError, match="stretched out-of-facet points"):
        VaryingCoefficientSpace(space, 1, term_facets=[(np.ones(len(f), bool), pts[:, :0])])
