"""The fast paths of issue 3 against plain references: the nested-dissection sparse Cholesky,
the constrained solve on problems large enough to be cut into many fronts, and the compiled
accumulation of many small normal-equation blocks (numba and numpy paths agree)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from simplexspline import InputError, NormalEquations, OutsideDomainError, SplineSpace, Triangulation
from simplexspline.spline import kernels
from simplexspline.spline.bform import bnet_points
from simplexspline.spline.fit import constrained as solve
from simplexspline.spline.fit import normal_equations as normal
from simplexspline.spline.fit.cholesky import SparseCholesky, nested_dissection

from . import reference as ref


def _grid_laplacian(shape, rng):
    """A random SPD matrix with the pattern of a 27-point stencil, and grid positions."""
    idx = np.arange(np.prod(shape)).reshape(shape)
    pts = np.stack(np.meshgrid(*[np.arange(s) for s in shape], indexing="ij"), -1).reshape(
        -1, len(shape)).astype(float)
    rows, cols = [], []
    for off in np.ndindex(*(3,) * len(shape)):
        o = np.array(off) - 1
        src = idx[tuple(slice(max(0, -k), s - max(0, k)) for k, s in zip(o, shape))]
        dst = idx[tuple(slice(max(0, k), s - max(0, -k) if k < 0 else s) for k, s in
                        zip(o, shape))]
        rows.append(src.ravel())
        cols.append(dst.ravel())
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    vals = rng.uniform(-1.0, 0.0, len(rows))
    A = sp.csr_matrix((vals, (rows, cols)), shape=(len(pts),) * 2)
    A = A + A.T
    A = A + sp.diags(np.asarray(abs(A).sum(axis=1)).ravel() + 0.1)
    return A.tocsr(), pts


@pytest.mark.parametrize("shape,leaf", [((9, 8, 7), 40), ((30, 25), 32), ((500,), 16)])
def test_sparse_cholesky_solves_spd_systems(shape, leaf):
    rng = np.random.default_rng(sum(shape))
    A, pts = _grid_laplacian(shape, rng)
    chol = SparseCholesky(A, pts, leaf=leaf)
    assert len(chol.factors) > 3  # really cut into fronts
    b = rng.standard_normal(A.shape[0])
    x = chol.solve(b)
    np.testing.assert_allclose(x, spla.spsolve(A.tocsc(), b), rtol=1e-10, atol=1e-12)


def test_nested_dissection_is_a_valid_ordering():
    rng = np.random.default_rng(5)
    A, pts = _grid_laplacian((10, 9, 8), rng)
    perm, nodes = nested_dissection(A, pts, 30)
    assert np.array_equal(np.sort(perm), np.arange(A.shape[0]))
    # Separator property: unknowns of two sibling subtrees are never coupled.
    span = {}
    for t, (s, e, kids) in enumerate(nodes):
        lo = min([span[k][0] for k in kids] + [s])
        span[t] = (lo, e)
        if len(kids) == 2:
            a, b = (perm[span[k][0]:span[k][1]] for k in kids)
            assert A[a][:, b].nnz == 0


def test_sparse_cholesky_rejects_indefinite():
    A = sp.csr_matrix(np.diag([1.0, -1.0, 2.0]))
    with pytest.raises(np.linalg.LinAlgError):
        SparseCholesky(A, np.arange(3.0)[:, None])


def _fit_problem(n, d, r, shape):
    rng = np.random.default_rng(n * 100 + d * 10 + r)
    tri = Triangulation.grid(np.zeros(n), np.ones(n), shape)
    space = SplineSpace(tri, d, r)
    assert space.system.nglobal > 256  # more unknowns than one leaf front
    x = rng.random((40 * tri.nsimplex, n))
    y = np.sin(3 * x[:, 0]) + x[:, -1] ** 2 + 0.01 * rng.standard_normal(len(x))
    w = rng.uniform(0.5, 2.0, len(x))
    return tri, space, x, y, w


@pytest.fixture
def sparse_path(monkeypatch):
    """Force the sparse factorisation (these problems are small enough for the dense one)."""
    monkeypatch.setattr(solve, "DENSE_MAX", 0)


def test_constrained_fit_on_many_fronts_matches_dense_kkt(sparse_path):
    n, d, r = 2, 4, 2
    tri, space, x, y, w = _fit_problem(n, d, r, (6, 5))
    got = space.fit(x, y, w).coefficients.ravel()
    X = space.design_matrix(x).toarray()
    H = ref.smoothness_matrix(tri.vertices, tri.simplices, d, r)
    want = ref.kkt_solution(X, y, H, w)
    np.testing.assert_allclose(got, want, rtol=1e-8, atol=1e-8 * np.abs(want).max())


@pytest.mark.parametrize("n,d,r,shape", [(3, 3, 1, (3, 3, 2)), (3, 2, 1, (5, 4, 4)),
                                         (2, 5, 1, (7, 6))])
def test_constrained_fit_on_many_fronts_matches_superlu(n, d, r, shape, monkeypatch,
                                                        sparse_path):
    _, space, x, y, w = _fit_problem(n, d, r, shape)
    got = space.fit(x, y, w).coefficients
    # a second fit on the same space reuses the cached ordering: the same numbers
    np.testing.assert_array_equal(space.fit(x, y, w).coefficients, got)

    def refuse(*args, **kwargs):
        raise np.linalg.LinAlgError

    monkeypatch.setattr(solve, "SparseCholesky", refuse)  # the SuperLU path
    want = space.fit(x, y, w).coefficients
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-10 * np.abs(want).max())
    assert np.abs(space.H_full @ got.ravel()).max() <= 1e-10 * np.abs(got).max()


def test_many_small_blocks_accumulate_like_the_blas_path(monkeypatch):
    rng = np.random.default_rng(7)
    tri = Triangulation.grid(np.zeros(3), np.ones(3), (6, 6, 6))  # 1296 simplices
    x = rng.random((20_000, 3))
    y = rng.standard_normal(len(x))
    w = rng.uniform(0.1, 3.0, len(x))
    space = SplineSpace(tri, 3, 1)
    fast = space.normal_equations(x, y, w)
    monkeypatch.setattr(normal, "SMALL_BLOCK", 0)  # every block through BLAS
    slow = space.normal_equations(x, y, w)
    np.testing.assert_allclose(fast.XtWX, slow.XtWX, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(fast.XtWy, slow.XtWy, rtol=1e-12, atol=1e-12)
    assert fast.ytWy == pytest.approx(slow.ytWy, rel=1e-14)
    np.testing.assert_array_equal(fast.counts, slow.counts)


def test_extend_add_numpy_and_compiled_agree(monkeypatch):
    rng = np.random.default_rng(3)
    idx = np.sort(rng.choice(40, 15, replace=False))
    upd = rng.standard_normal((15, 15))
    fronts = []
    for numba_on in (kernels.HAVE_NUMBA, False):
        monkeypatch.setattr(kernels, "HAVE_NUMBA", numba_on)
        front = np.asfortranarray(rng.standard_normal((40, 40)) * 0 + 1.0)
        kernels.extend_add(front, idx, upd)
        fronts.append(np.tril(front))
    np.testing.assert_allclose(fronts[0], fronts[1], rtol=1e-15)
    assert fronts[0][idx[3], idx[1]] == pytest.approx(1.0 + upd[3, 1])


@pytest.mark.parametrize("weighted", [False, True])
def test_fused_accumulation_matches_two_step_path(monkeypatch, weighted):
    if not kernels.HAVE_NUMBA:
        pytest.skip("the fused kernel needs numba")
    rng = np.random.default_rng(11)
    tri = Triangulation.grid(np.zeros(3), np.ones(3), (3, 2, 2))
    x = rng.random((30_000, 3))
    y = np.cos(4 * x[:, 0]) + x[:, 1] * x[:, 2]
    w = rng.uniform(0.1, 3.0, len(x)) if weighted else None
    space = SplineSpace(tri, 3, 1)
    monkeypatch.setattr(normal, "FUSED_MIN_POINTS", 1)
    monkeypatch.setattr(normal, "CHUNK", 7_000)  # several chunks, tiles of every size
    fused = space.normal_equations(x, y, w)
    monkeypatch.setattr(normal, "FUSED_MIN_POINTS", 10**12)
    plain = space.normal_equations(x, y, w)
    np.testing.assert_allclose(fused.XtWX, plain.XtWX, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(fused.XtWy, plain.XtWy, rtol=1e-12, atol=1e-10)
    assert fused.ytWy == pytest.approx(plain.ytWy, rel=1e-13)
    np.testing.assert_array_equal(fused.counts, plain.counts)
    np.testing.assert_allclose(fused.wsum, plain.wsum, rtol=1e-13)
    np.testing.assert_array_equal(fused.XtWX, np.swapaxes(fused.XtWX, 1, 2))  # symmetric


@pytest.mark.parametrize("leaf", [4, 16, 64])
def test_sparse_cholesky_with_decoupled_blocks(leaf):
    """Fronts with no coupling to later unknowns (empty update) must not break the tree
    (a KeyError seen in structure selection)."""


    rng = np.random.default_rng(0)
    blocks = []
    for _ in range(6):
        a = rng.normal(size=(30, 30))
        blocks.append(a @ a.T + 30 * np.eye(30))
    P = sp.block_diag(blocks).tocsr()
    f = SparseCholesky(P, rng.uniform(size=(180, 2)), leaf=leaf)
    b = rng.normal(size=180)
    assert np.abs(P @ f.solve(b) - b).max() < 1e-10


def test_sparse_cholesky_with_an_empty_separator(capfd):
    """A region that falls apart into two uncoupled halves gets an empty separator whose
    front owns nothing but passes its children's updates on (dsyrk once rejected the
    rank-0 update and OpenBLAS printed "On entry to DSYRK parameter number 7 had an
    illegal value", seen in a paper-preset Cl search)."""
    n = 1200
    off = np.full(n - 1, -1.0)
    off[299] = 0.0                                  # no coupling across this gap
    P = sp.diags([off, np.full(n, 4.0), off], [-1, 0, 1], format="csr")
    P.eliminate_zeros()
    chol = SparseCholesky(P, np.arange(n, dtype=float)[:, None])
    empty = [(s, e, len(U)) for s, e, _L, _W, U in chol.factors if s == e]
    assert empty and all(u > 0 for *_, u in empty)  # the case: owns nothing, updates later
    b = np.random.default_rng(1).normal(size=n)
    np.testing.assert_allclose(chol.solve(b), spla.spsolve(P.tocsc(), b), rtol=1e-12)
    printed = capfd.readouterr()
    assert "DSYRK" not in printed.out + printed.err     # OpenBLAS's xerbla prints to stdout


@pytest.mark.parametrize("threads", [2, 3])
@pytest.mark.parametrize("weighted", [False, True])
def test_threaded_accumulation_matches_one_thread(threads, weighted):
    rng = np.random.default_rng(5)
    tri = Triangulation.grid(np.zeros(3), np.ones(3), (3, 2, 2))
    x = rng.random((9_001, 3))
    y = np.sin(3 * x[:, 0]) + x[:, 2]
    w = rng.uniform(0.1, 2.0, len(x)) if weighted else None
    one = NormalEquations(tri, 3).add(x, y, w, threads=1)
    many = NormalEquations(tri, 3).add(x, y, w, threads=threads)
    np.testing.assert_allclose(many.XtWX, one.XtWX, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(many.XtWy, one.XtWy, rtol=1e-12, atol=1e-10)
    assert many.ytWy == pytest.approx(one.ytWy, rel=1e-13)
    np.testing.assert_array_equal(many.counts, one.counts)


def test_threaded_accumulation_reports_outside_points_and_adds_nothing():
    tri = Triangulation.grid(np.zeros(2), np.ones(2), (2, 2))
    rng = np.random.default_rng(2)
    x = rng.random((6_000, 2))
    x[[10, 4_500]] += 2.0  # one outside point in each thread's part
    ne = NormalEquations(tri, 2)
    with pytest.raises(OutsideDomainError, match=r"2 of 6000 data points lie outside.*"
                                                 r"\[10, 4500\]"):
        ne.add(x, np.ones(len(x)), threads=2)
    assert ne.npoints == 0 and not ne.XtWX.any()
    with pytest.raises(InputError, match="threads must be >= 1"):
        ne.add(x[:5], np.ones(5), threads=0)


def test_dense_and_sparse_constrained_solves_agree(monkeypatch):
    _, space, x, y, w = _fit_problem(3, 3, 1, (2, 2, 2))
    assert space.system.nglobal <= solve.DENSE_MAX
    dense = space.fit(x, y, w).coefficients
    monkeypatch.setattr(solve, "DENSE_MAX", 0)
    sparse = space.fit(x, y, w).coefficients
    np.testing.assert_allclose(dense, sparse, rtol=1e-9, atol=1e-10 * np.abs(sparse).max())
    assert np.abs(space.H_full @ dense.ravel()).max() <= 1e-10 * np.abs(dense).max()


def test_threaded_location_and_evaluation_match_serial(monkeypatch):
    if not kernels.HAVE_NUMBA:
        pytest.skip("the threaded passes wrap the compiled kernels")
    rng = np.random.default_rng(9)
    tri = Triangulation.grid(np.zeros(3), np.ones(3), (3, 2, 2))
    x = rng.uniform(-0.05, 1.05, (5_001, 3))  # some outside: NaN in every thread's part
    spline = SplineSpace(tri, 3, 1).fit(x[tri.locate(x) >= 0], np.ones((tri.locate(x) >= 0).sum()))
    monkeypatch.setenv("SIMPLEXSPLINE_THREADS", "1")
    sid1, val1 = tri.locate(x), spline.predict(x)
    monkeypatch.setattr(kernels, "PARALLEL_MIN_POINTS", 100)
    monkeypatch.setenv("SIMPLEXSPLINE_THREADS", "3")
    assert kernels.thread_count(len(x)) == 3
    np.testing.assert_array_equal(tri.locate(x), sid1)
    np.testing.assert_array_equal(spline.predict(x), val1)
    assert np.isnan(val1).any() and (sid1 < 0).any()
    monkeypatch.setenv("SIMPLEXSPLINE_THREADS", "two")
    with pytest.raises(InputError, match="SIMPLEXSPLINE_THREADS must be an integer"):
        tri.locate(x)


def _delaunay_problem(nverts, d, seed):
    """A 3-D Delaunay triangulation of random vertices (slivers and nearly coplanar facets:
    nearly dependent C^1 conditions) with smooth data in every simplex."""
    rng = np.random.default_rng(seed)
    tri = Triangulation.delaunay(rng.random((nverts, 3)))
    x = ref.points_in_simplices(tri.vertices, tri.simplices, 40, rng)[0]
    y = np.sin(3 * x[:, 0]) * np.cos(2 * x[:, 1]) + x[:, 2] ** 3
    return tri, SplineSpace(tri, d, 1), x, y


def test_sparse_solve_on_delaunay_is_direct_and_matches_dense_kkt(monkeypatch, sparse_path):
    """Issue 17: the sparse path on a Delaunay triangulation converges by refinement on one
    factorisation (no GMRES) and gives the dense KKT reference solution."""
    tri, space, x, y = _delaunay_problem(9, 3, 17)

    def no_krylov(*args, **kwargs):
        raise AssertionError("fell back to GMRES")

    monkeypatch.setattr(solve.spla, "gmres", no_krylov)
    got = space.fit(x, y).coefficients.ravel()
    X = space.design_matrix(x).toarray()
    H = ref.smoothness_matrix(tri.vertices, tri.simplices, 3, 1)
    want = ref.kkt_solution(X, y, H)
    np.testing.assert_allclose(got, want, rtol=1e-8, atol=1e-8 * np.abs(want).max())


def test_tight_and_loose_penalty_passes_agree(monkeypatch, sparse_path):
    """The two penalties on the conditions reach the same constrained minimiser (the
    refinement removes the regularisation), on a Delaunay triangulation."""
    _, space, x, y = _delaunay_problem(25, 3, 5)
    tight = space.fit(x, y, on_insufficient="minnorm").coefficients
    monkeypatch.setattr(solve, "KKT_DELTA_TIGHT", solve.KKT_DELTA)
    loose = space.fit(x, y, on_insufficient="minnorm").coefficients
    np.testing.assert_allclose(tight, loose, rtol=1e-7, atol=1e-8 * np.abs(tight).max())
    assert np.abs(space.H_full @ tight.ravel()).max() <= 1e-10 * np.abs(tight).max()


def test_ordering_positions_follow_facets_on_delaunay():
    """The nested-dissection positions (smallest centroid of the simplices holding each
    coefficient) cut between simplices: a cut at any position c leaves every simplex
    wholly on one side or with only its shared-facet coefficients on the left, and the
    ordering they give fills less than cutting through the B-net points."""
    tri, space, x, y = _delaunay_problem(80, 3, 7)
    system = space.system
    keys = solve.global_points(tri, 3, system.gather, system.nglobal)
    cent = tri.vertices[tri.simplices].mean(axis=1)
    gi = system.gather.reshape(tri.nsimplex, -1)
    # every simplex's coefficients lie at or left of its own centroid
    assert np.all(keys[gi] <= cent[:, None, :] + 1e-15)
    ne = space.normal_equations(x, y)
    A = system.A_all
    P = (solve._assemble_gram(ne.XtWX, system.gather, system.nglobal, None) + A.T @ A
         + sp.eye(system.nglobal)).tocsr()

    def fill(coords):
        chol = SparseCholesky(P, coords)
        return sum((e - s) * (e - s + 1) // 2 + (e - s) * len(U)
                   for s, e, _, _, U in chol.factors)

    pts = np.zeros((system.nglobal, 3))
    pts[system.gather] = bnet_points(tri.vertices[tri.simplices], 3).reshape(-1, 3)
    assert fill(keys) < 0.9 * fill(pts)


def test_a_broken_pivot_is_retried_shifted_not_handed_to_superlu(monkeypatch, sparse_path):
    """Round-off can break a pivot of the condensed KKT matrix (rho A'A outweighs sigma by
    1e16): the sparse Cholesky is retried with a 1e-12 relative shift, a preconditioner
    of the unshifted system, and the fit is the same."""
    _, space, x, y, w = _fit_problem(3, 3, 1, (3, 3, 2))
    want = space.fit(x, y, w).coefficients
    real = solve.SparseCholesky
    calls = {"refused": 0, "shifted": 0, "superlu": 0}

    def first_attempt_fails(P, *args, **kwargs):
        if calls["refused"] == calls["shifted"]:        # every unshifted attempt
            calls["refused"] += 1
            raise np.linalg.LinAlgError("matrix not positive definite")
        calls["shifted"] += 1
        return real(P, *args, **kwargs)

    def no_superlu(*args, **kwargs):
        calls["superlu"] += 1
        return None

    monkeypatch.setattr(solve, "SparseCholesky", first_attempt_fails)
    monkeypatch.setattr(solve, "_splu", no_superlu)
    got = space.fit(x, y, w).coefficients
    assert calls["shifted"] >= 1 and calls["superlu"] == 0
    np.testing.assert_allclose(got, want, rtol=1e-8, atol=1e-9 * np.abs(want).max())
    assert np.abs(space.H_full @ got.ravel()).max() <= 1e-10 * np.abs(got).max()
