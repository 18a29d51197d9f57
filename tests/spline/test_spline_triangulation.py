"""Triangulation services: validation, constructors, facets/neighbours, locate, barycentric
coordinates, volumes, quality and slivers."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import scipy.spatial
from hypothesis import given
from hypothesis import strategies as st

from simplexspline import (
    DegenerateSimplexError,
    InputError,
    SimplexSplineError,
    Triangulation,
    TriangulationError,
)

from . import reference as ref
from .cases import KINDS, expected_nsimplex, make_triangulation, seeded

SMALL = [
    (kind, n) for kind in KINDS for n in range(1, 7) if not (kind in ("grid", "fit") and n == 6)
]


def _ids(params):
    return [f"{k}-n{n}" for k, n in params]


@pytest.mark.parametrize("kind,n", SMALL, ids=_ids(SMALL))
def test_basic_attributes(kind, n):
    tri = make_triangulation(kind, n, seeded("attr", kind, n))
    J = tri.nsimplex
    assert tri.ndim == n
    assert tri.vertices.shape[1] == n
    assert tri.simplices.shape == (J, n + 1)
    assert np.issubdtype(tri.simplices.dtype, np.integer)
    if expected_nsimplex(kind, n) is not None and kind != "fit":
        assert J == expected_nsimplex(kind, n)
    vol = tri.volumes()
    assert vol.shape == (J,) and np.all(vol > 0)
    np.testing.assert_allclose(
        vol, [ref.simplex_volume(tri.vertices[s]) for s in tri.simplices], rtol=1e-10
    )


@pytest.mark.parametrize("kind,n", SMALL, ids=_ids(SMALL))
def test_facets_and_neighbours_consistent(kind, n):
    tri = make_triangulation(kind, n, seeded("facets", kind, n))
    S = tri.simplices
    J = tri.nsimplex
    nb = np.asarray(tri.neighbors)
    assert nb.shape == (J, n + 1)
    fac = tri.facets
    F = len(fac.simplices)
    assert fac.simplices.shape == (F, 2)
    assert fac.out_positions.shape == (F, 2)
    assert fac.vertices.shape == (F, n)
    # every interior facet: vertices sorted, equal to each simplex minus its out vertex
    for (s1, s2), (o1, o2), verts in zip(fac.simplices, fac.out_positions, fac.vertices):
        assert s1 != s2
        assert np.all(np.diff(verts) > 0)
        np.testing.assert_array_equal(np.sort(np.delete(S[s1], o1)), verts)
        np.testing.assert_array_equal(np.sort(np.delete(S[s2], o2)), verts)
        assert nb[s1, o1] == s2 and nb[s2, o2] == s1
    # the interior facets are exactly those of the reference, and neighbours agree
    rf = ref.interior_facets(S)
    assert F == len(rf.simplices)
    assert {tuple(v) for v in fac.vertices.tolist()} == {tuple(v) for v in rf.vertices.tolist()}
    assert np.sum(nb >= 0) == 2 * F
    for j, i in rf.boundary:
        assert nb[j, i] == -1
    for j in range(J):
        for i in range(n + 1):
            k = nb[j, i]
            if k >= 0:
                assert j in nb[k]
                shared = set(np.delete(S[j], i).tolist())
                assert shared <= set(S[k].tolist())


def test_neighbours_match_scipy_delaunay():
    pts = seeded("scipy-nb").uniform(size=(30, 2))
    tri = Triangulation.delaunay(pts)
    # compare as sets of neighbouring pairs keyed by simplex vertex sets
    key = lambda s: frozenset(s.tolist())  # noqa: E731
    sp = scipy.spatial.Delaunay(pts)
    pairs = lambda S, nb: {  # noqa: E731
        frozenset((key(S[j]), key(S[k]))) for j in range(len(S)) for k in nb[j] if k >= 0
    }
    assert {key(s) for s in tri.simplices} == {key(s) for s in sp.simplices}
    assert pairs(tri.simplices, tri.neighbors) == pairs(sp.simplices, sp.neighbors)


@pytest.mark.parametrize("n", range(1, 6))
def test_grid_is_kuhn(n):
    lower = -np.arange(1, n + 1) * 0.5
    upper = np.arange(1, n + 1) * 1.0
    shape = (2,) * n if n <= 3 else (1,) * n
    tri = Triangulation.grid(lower, upper, shape)
    J = math.prod(shape) * math.factorial(n)
    assert tri.nsimplex == J
    cell = (upper - lower) / np.array(shape)
    np.testing.assert_allclose(tri.volumes(), np.prod(cell) / math.factorial(n), rtol=1e-12)
    np.testing.assert_allclose(tri.volumes().sum(), np.prod(upper - lower), rtol=1e-12)
    # every simplex is z, z+e_pi1, ..., z+1 in cell units (in some vertex order)
    for s in tri.simplices:
        u = (tri.vertices[s] - lower) / cell
        np.testing.assert_allclose(u, np.round(u), atol=1e-9)
        u = np.round(u).astype(int)
        u = u[np.argsort(u.sum(1))]
        steps = np.diff(u, axis=0)
        assert np.all(steps.sum(1) == 1) and np.all(steps >= 0)
        np.testing.assert_array_equal(u[-1] - u[0], np.ones(n, dtype=int))
    # the same simplices as the reference Kuhn grid
    V, S = ref.kuhn_grid(lower, upper, shape)
    mine = {frozenset(map(tuple, np.round(tri.vertices[s], 9))) for s in tri.simplices}
    theirs = {frozenset(map(tuple, np.round(V[s], 9))) for s in S}
    assert mine == theirs


@pytest.mark.parametrize("kind,n", SMALL, ids=_ids(SMALL))
def test_locate_and_barycentric(kind, n):
    rng = seeded("locate", kind, n)
    tri = make_triangulation(kind, n, rng)
    x, where = ref.points_in_simplices(tri.vertices, tri.simplices, 3, rng)
    loc = tri.locate(x)
    assert loc.shape == (len(x),) and np.issubdtype(loc.dtype, np.integer)
    np.testing.assert_array_equal(loc, where)
    b = tri.barycentric(x, loc)
    assert b.shape == (len(x), n + 1)
    np.testing.assert_allclose(b.sum(1), 1.0, atol=1e-12)
    assert b.min() >= -1e-10
    np.testing.assert_allclose(
        np.einsum("pk,pkn->pn", b, tri.vertices[tri.simplices[loc]]), x, atol=1e-11
    )
    # points well outside the bounding box -> -1
    lo, hi = tri.vertices.min(0), tri.vertices.max(0)
    far = np.vstack([hi + 0.5 + rng.uniform(size=(4, n)), lo - 0.5 - rng.uniform(size=(4, n))])
    np.testing.assert_array_equal(tri.locate(far), -1)


@pytest.mark.parametrize("n", [2, 3])
def test_locate_outside_hull_but_inside_box(n):
    # a star triangulation of a simplex: the box corners opposite are outside the hull
    rng = seeded("hull", n)
    V, S = ref.star_triangulation(n, rng)
    tri = Triangulation(V, S)
    probes = rng.uniform(V.min(0), V.max(0), size=(400, n))
    np.testing.assert_array_equal(tri.locate(probes) >= 0, ref.locate(V, S, probes) >= 0)
    assert np.any(tri.locate(probes) < 0)


def test_barycentric_outside_point_still_reproduces_x():
    tri = Triangulation.grid([0, 0], [1, 1], (1, 1))
    x = np.array([[2.0, -1.0], [0.3, 0.1]])
    b = tri.barycentric(x, np.array([0, 1]))
    np.testing.assert_allclose(b.sum(1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("pk,pkn->pn", b, tri.vertices[tri.simplices[[0, 1]]]), x,
                               atol=1e-12)


@pytest.mark.parametrize("n", range(1, 7))
def test_quality_regular_simplex_is_one(n):
    V = ref.regular_simplex(n, scale=3.7) + 1.25
    tri = Triangulation(V, np.arange(n + 1)[None, :])
    np.testing.assert_allclose(tri.quality(), 1.0, rtol=1e-10)
    assert tri.slivers().size == 0


@pytest.mark.parametrize("kind,n", SMALL, ids=_ids(SMALL))
def test_quality_in_unit_interval_and_matches_reference(kind, n):
    tri = make_triangulation(kind, n, seeded("quality", kind, n))
    q = tri.quality()
    assert q.shape == (tri.nsimplex,)
    assert np.all(q > 0) and np.all(q <= 1 + 1e-12)
    np.testing.assert_allclose(q, [ref.quality(tri.vertices[s]) for s in tri.simplices], rtol=1e-8)


def test_slivers_reported():
    # a regular triangle and a very flat (but valid) one sharing an edge
    V = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, math.sqrt(3) / 2], [0.5, -1e-3]])
    tri = Triangulation(V, np.array([[0, 1, 2], [0, 1, 3]]))
    q = tri.quality()
    assert q[0] == pytest.approx(1.0, rel=1e-12) and q[1] < 1e-2
    np.testing.assert_array_equal(tri.slivers(), [1])
    np.testing.assert_array_equal(tri.slivers(threshold=1e-6), np.zeros(0, dtype=int))
    np.testing.assert_array_equal(np.sort(tri.slivers(threshold=1.5)), [0, 1])
    assert np.issubdtype(np.asarray(tri.slivers()).dtype, np.integer)


def test_delaunay_slivers_flagged():
    # near-cospherical points in 3-D produce flat tetrahedra in Delaunay
    rng = seeded("sliver3d")
    corners = np.array(list(itertools.product([0.0, 1.0], repeat=3)))
    tri = Triangulation.delaunay(corners + 1e-4 * rng.standard_normal(corners.shape))
    q = tri.quality()
    np.testing.assert_array_equal(np.sort(tri.slivers(threshold=0.2)), np.flatnonzero(q < 0.2))


# ---------------------------------------------------------------------------- validation


def test_invalid_inputs():
    V = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    with pytest.raises(InputError, match="(?i)nan|finite"):
        Triangulation(np.array([[0.0, np.nan], [1.0, 0.0], [0.0, 1.0]]), [[0, 1, 2]])
    with pytest.raises(InputError, match="(?i)nan|finite|inf"):
        Triangulation(np.array([[0.0, np.inf], [1.0, 0.0], [0.0, 1.0]]), [[0, 1, 2]])
    with pytest.raises(InputError, match="(?i)range|index|indices"):
        Triangulation(V, [[0, 1, 3]])
    with pytest.raises(InputError, match="(?i)range|index|indices|negative"):
        Triangulation(V, [[0, 1, -1]])
    with pytest.raises(InputError, match="(?i)shape|n \\+ 1|columns|vertices per"):
        Triangulation(V, [[0, 1]])
    with pytest.raises(InputError, match="(?i)shape|2-d|dimension"):
        Triangulation(V.ravel(), [[0, 1, 2]])
    # a repeated vertex is bad input and a zero-volume simplex: either error is fine
    with pytest.raises((InputError, DegenerateSimplexError), match="(?i)repeat|duplicate|distinct"):
        Triangulation(V, [[0, 1, 1]])


def test_degenerate_simplex_raises_with_indices():
    V = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [2.0, 0.0], [1.0, -1.0]])
    S = np.array([[0, 1, 2], [0, 1, 3], [1, 3, 4]])  # simplex 1 is flat (on the x axis)
    with pytest.raises(DegenerateSimplexError, match="(?i)degenerate|zero volume") as info:
        Triangulation(V, S)
    np.testing.assert_array_equal(info.value.simplices, [1])
    assert isinstance(info.value, TriangulationError)


def test_overlapping_simplices_raise():
    V = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.2, 0.2]])
    with pytest.raises(TriangulationError, match="(?i)overlap"):
        Triangulation(V, [[0, 1, 2], [3, 1, 2]])  # both on the same side of the shared edge
    V2 = np.array([[0, 0], [1, 0], [0, 1], [0.1, 0.1], [1.1, 0.1], [0.1, 1.1]], dtype=float)
    with pytest.raises(TriangulationError, match="(?i)overlap"):
        Triangulation(V2, [[0, 1, 2], [3, 4, 5]])  # no shared vertex at all


def test_hanging_vertex_is_nonconforming():
    V = np.array([[0, 0], [2, 0], [0, 2], [1, 1], [2, 2]], dtype=float)
    with pytest.raises(TriangulationError, match="(?i)conform|hanging"):
        Triangulation(V, [[0, 1, 2], [1, 3, 4], [3, 2, 4]])


def test_grid_shape_dimension_mismatch():
    with pytest.raises(InputError, match="(?i)shape|lower|upper|dimension"):
        Triangulation.grid([0.0, 0.0], [1.0, 1.0], (2, 2, 2))
    with pytest.raises(InputError, match="(?i)shape|lower|upper|dimension"):
        Triangulation.grid([0.0, 0.0], [1.0, 1.0, 1.0], (2, 2))


def test_constructor_arguments_checked():
    with pytest.raises(InputError, match="(?i)lower|upper|empty|greater"):
        Triangulation.grid([0.0, 1.0], [1.0, 1.0], (2, 2))
    with pytest.raises(InputError, match="(?i)shape|positive|cells"):
        Triangulation.grid([0.0, 0.0], [1.0, 1.0], (2, 0))
    with pytest.raises(InputError, match="(?i)nan|finite"):
        Triangulation.delaunay(np.array([[0.0, 0.0], [1.0, np.nan], [0.0, 1.0], [1.0, 1.0]]))
    with pytest.raises(InputError, match="(?i)nan|finite"):
        Triangulation.fit(np.array([[0.0, 0.0], [1.0, np.nan], [0.3, 1.0]]), (2, 2))


# ---------------------------------------------------------------------------- fit constructor


@pytest.mark.parametrize("n,shape,min_points", [(2, (4, 4), 1), (2, (4, 4), 5), (3, (3, 3, 3), 2)])
def test_fit_drops_sparse_simplices(n, shape, min_points):
    rng = seeded("fitdrop", n, min_points)
    # data fill only part of their bounding box: a ball around a corner plus the far corner
    x = rng.uniform(size=(600, n))
    x = x[np.linalg.norm(x, axis=1) < 0.9]
    x = np.vstack([x, np.ones((1, n))])
    tri = Triangulation.fit(x, shape, min_points=min_points)
    counts = np.bincount(tri.locate(x)[tri.locate(x) >= 0], minlength=tri.nsimplex)
    assert np.all(counts >= min_points)
    # compare with the full grid on the bounding box: kept == {count >= min_points}
    full = Triangulation.grid(x.min(0), x.max(0), shape)
    assert tri.nsimplex < full.nsimplex
    loc = full.locate(x)
    assert np.all(loc >= 0)
    full_counts = np.bincount(loc, minlength=full.nsimplex)
    key = lambda T, j: frozenset(map(tuple, np.round(T.vertices[T.simplices[j]], 9)))  # noqa: E731
    kept = {key(tri, j) for j in range(tri.nsimplex)}
    expected = {key(full, j) for j in np.flatnonzero(full_counts >= min_points)}
    assert kept == expected
    # all data inside the fitted triangulation when min_points == 1
    if min_points == 1:
        assert np.all(tri.locate(x) >= 0)


# ------------------------------------------------------------------ points on shared faces


@given(
    n=st.integers(1, 4),
    seed=st.integers(0, 2**32 - 1),
    data=st.data(),
)
def test_locate_points_on_facets_edges_and_vertices_of_grid(n, seed, data):
    """Lattice points (multiples of a quarter cell) lie on facets, edges, vertices and the
    outer boundary: each must be located in a simplex that contains it, never -1."""
    rng = np.random.default_rng(seed)
    shape = tuple(data.draw(st.lists(st.integers(1, 3), min_size=n, max_size=n), label="shape"))
    lower = rng.uniform(-2, 2, n)
    upper = lower + rng.uniform(0.5, 3, n)
    tri = Triangulation.grid(lower, upper, shape)
    ticks = [np.linspace(lower[i], upper[i], 4 * shape[i] + 1) for i in range(n)]
    idx = rng.integers(0, [len(t) for t in ticks], size=(60, n))
    x = np.stack([ticks[i][idx[:, i]] for i in range(n)], axis=1)
    loc = tri.locate(x)
    assert np.all(loc >= 0)
    b = tri.barycentric(x, loc)
    assert b.min() >= -1e-10
    np.testing.assert_allclose(np.einsum("pk,pkn->pn", b, tri.vertices[tri.simplices[loc]]), x,
                               atol=1e-10)


@pytest.mark.parametrize("kind,n", [("delaunay", 2), ("delaunay", 3), ("explicit", 3), ("fit", 2)])
def test_locate_vertices_and_facet_points(kind, n):
    rng = seeded("onfacet", kind, n)
    tri = make_triangulation(kind, n, rng)
    fac = tri.facets
    mid = tri.vertices[fac.vertices].mean(axis=1)
    x = np.vstack([tri.vertices[np.unique(tri.simplices)], mid])
    loc = tri.locate(x)
    assert np.all(loc >= 0)
    assert tri.barycentric(x, loc).min() >= -1e-10


def test_delaunay_of_degenerate_point_sets_raises():
    collinear = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])
    pattern = "(?i)degenerate|collinear|coplanar|flat|volume|dimension"
    with pytest.raises(SimplexSplineError, match=pattern):
        Triangulation.delaunay(collinear)
    with pytest.raises(SimplexSplineError, match="(?i)points|few|at least"):
        Triangulation.delaunay(np.array([[0.0, 0.0], [1.0, 0.0]]))


def test_fit_flat_bounding_box_raises():
    x = np.column_stack([np.linspace(0, 1, 20), np.full(20, 0.5)])  # no extent along axis 1
    pattern = "(?i)box|extent|range|constant|lower|upper|flat|degenerate|spread"
    with pytest.raises(SimplexSplineError, match=pattern):
        Triangulation.fit(x, (2, 2))
