"""B-form basics: multi-indices (Eq. 9-12), basis values (Eq. 14), de Casteljau, B-net (Eq. 17)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from simplexspline import (
    InputError,
    basis_values,
    bnet_points,
    de_casteljau,
    multi_indices,
    num_basis,
)

from . import reference as ref


def test_multi_indices_paper_example_n2_d3():
    expected = [
        (3, 0, 0), (2, 1, 0), (2, 0, 1), (1, 2, 0), (1, 1, 1),
        (1, 0, 2), (0, 3, 0), (0, 2, 1), (0, 1, 2), (0, 0, 3),
    ]
    K = multi_indices(2, 3)
    assert np.issubdtype(K.dtype, np.integer)
    assert [tuple(int(v) for v in k) for k in K] == expected


def test_multi_indices_paper_example_n2_d2():
    K = multi_indices(2, 2)
    assert K.tolist() == [[2, 0, 0], [1, 1, 0], [1, 0, 1], [0, 2, 0], [0, 1, 1], [0, 0, 2]]


@pytest.mark.parametrize("n", range(1, 7))
@pytest.mark.parametrize("d", range(0, 7))
def test_multi_indices_eq11_order_and_count(n, d):
    K = np.asarray(multi_indices(n, d))
    d_hat = math.comb(d + n, n)
    assert K.shape == (d_hat, n + 1)
    assert num_basis(n, d) == d_hat
    assert np.all(K >= 0) and np.all(K.sum(axis=1) == d)
    # Eq. 11: strictly decreasing in lexicographic order, every multi-index exactly once
    rows = [tuple(int(v) for v in k) for k in K]
    assert rows == sorted(rows, reverse=True)
    assert len(set(rows)) == d_hat
    np.testing.assert_array_equal(K, ref.multi_indices(n, d))
    assert K[0, 0] == d and K[-1, -1] == d


def test_num_basis_values():
    assert num_basis(2, 3) == 10
    assert num_basis(3, 3) == 20
    assert num_basis(6, 5) == 462
    assert num_basis(1, 0) == 1


@st.composite
def barycentric_points(draw, n=None, allow_outside=False):
    n = draw(st.integers(1, 6)) if n is None else n
    N = draw(st.integers(1, 8))
    lo = -2.0 if allow_outside else 0.0
    raw = draw(
        st.lists(
            st.lists(st.floats(lo, 3.0, allow_nan=False), min_size=n, max_size=n),
            min_size=N, max_size=N,
        )
    )
    b = np.array(raw, dtype=float).reshape(N, n)
    if not allow_outside:
        b = np.abs(b)
        b = np.hstack([b, np.ones((N, 1))])
        b /= b.sum(axis=1, keepdims=True)
    else:
        b = np.hstack([b, 1.0 - b.sum(axis=1, keepdims=True)])
    return b


@given(b=barycentric_points(), d=st.integers(0, 6))
def test_basis_partition_of_unity(b, d):
    B = basis_values(b, d)
    assert B.shape == (len(b), num_basis(b.shape[1] - 1, d))
    np.testing.assert_allclose(B.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    assert np.all(B >= 0)


@given(b=barycentric_points(allow_outside=True), d=st.integers(0, 5))
def test_basis_partition_of_unity_outside_the_simplex(b, d):
    # (b0 + ... + bn)^d = 1 also for points outside the simplex (negative coordinates)
    B = basis_values(b, d)
    scale = np.abs(B).sum(axis=1)
    np.testing.assert_allclose(B.sum(axis=1), 1.0, rtol=0, atol=1e-12 * scale.max())


@given(b=barycentric_points(allow_outside=True), d=st.integers(0, 5))
def test_basis_values_match_eq14(b, d):
    np.testing.assert_allclose(basis_values(b, d), ref.basis_values(b, d), rtol=1e-12, atol=1e-12)


def test_basis_values_vertices_are_kronecker():
    # at vertex v_i only B_{d e_i} is non-zero (and equals 1)
    n, d = 3, 4
    B = basis_values(np.eye(n + 1), d)
    K = multi_indices(n, d)
    for i in range(n + 1):
        k = int(np.flatnonzero(K[:, i] == d)[0])
        expected = np.zeros(len(K))
        expected[k] = 1.0
        np.testing.assert_allclose(B[i], expected, atol=1e-15)


@given(
    b=barycentric_points(allow_outside=True),
    d=st.integers(0, 6),
    seed=st.integers(0, 2**32 - 1),
)
def test_de_casteljau_equals_direct_evaluation(b, d, seed):
    rng = np.random.default_rng(seed)
    n = b.shape[1] - 1
    c = rng.uniform(-1, 1, (len(b), num_basis(n, d)))
    direct = (ref.basis_values(b, d) * c).sum(axis=1)
    scale = np.abs(ref.basis_values(b, d)).sum(axis=1).max()
    got = de_casteljau(c, b)
    assert got.shape == (len(b),)
    np.testing.assert_allclose(got, direct, rtol=0, atol=1e-12 * max(scale, 1.0))
    # one coefficient vector shared by all points
    got1 = de_casteljau(c[0], b)
    direct1 = ref.basis_values(b, d) @ c[0]
    np.testing.assert_allclose(got1, direct1, rtol=0, atol=1e-12 * max(scale, 1.0))


@pytest.mark.parametrize("n", range(1, 7))
@pytest.mark.parametrize("d", range(1, 6))
def test_bnet_points_eq17(n, d, rng):
    V = rng.standard_normal((n + 1, n))
    P = bnet_points(V, d)
    assert P.shape == (num_basis(n, d), n)
    np.testing.assert_allclose(P, ref.multi_indices(n, d) @ V / d, rtol=1e-13, atol=1e-13)
    # batched form (J, n+1, n) -> (J, d_hat, n)
    VV = rng.standard_normal((3, n + 1, n))
    PP = bnet_points(VV, d)
    assert PP.shape == (3, num_basis(n, d), n)
    for j in range(3):
        np.testing.assert_allclose(PP[j], ref.bnet_points(VV[j], d), rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("n", [1, 2, 3, 5])
@pytest.mark.parametrize("d", [1, 2, 4])
def test_bnet_linear_precision(n, d, rng):
    """The B-coefficients of an affine function are its values at the B-net points."""
    V = rng.standard_normal((n + 1, n))
    a, a0 = rng.standard_normal(n), rng.standard_normal()
    c = bnet_points(V, d) @ a + a0
    b = rng.dirichlet(np.ones(n + 1), size=20)
    x = b @ V
    np.testing.assert_allclose(de_casteljau(c, b), x @ a + a0, rtol=1e-12, atol=1e-12)


def test_bform_invalid_arguments():
    with pytest.raises(InputError, match="(?i)degree|d >= 0|d=-1"):
        multi_indices(2, -1)
    with pytest.raises(InputError, match="(?i)dimension|n >= 1|n=0"):
        multi_indices(0, 2)
    with pytest.raises(InputError, match="(?i)coefficient|shape|d_hat|length"):
        de_casteljau(np.ones(5), np.full((2, 3), 1 / 3))  # 5 is not C(d+2, 2) for any d


def test_de_casteljau_row_count_mismatch():
    with pytest.raises(InputError, match="(?i)shape|rows|points|match|length"):
        de_casteljau(np.ones((3, 6)), np.full((4, 3), 1 / 3))
    with pytest.raises(InputError, match="(?i)shape|barycentric|columns|n \\+ 1"):
        basis_values(np.full((4, 3, 1), 1 / 3), 2)


@pytest.mark.parametrize("n, d", [(1, 0), (1, 4), (2, 3), (3, 5), (6, 2), (5, 4)])
def test_multi_index_rank_formula_equals_the_table(n, d, monkeypatch):
    from simplexspline.spline import bform

    kap = multi_indices(n, d)
    table = bform.multi_index_lookup(kap, d)
    np.testing.assert_array_equal(table, np.arange(len(kap)))
    monkeypatch.setattr(bform, "LOOKUP_TABLE_MAX", 0)  # force the rank formula
    np.testing.assert_array_equal(bform.multi_index_lookup(kap, d), table)
    rng = np.random.default_rng(n * 10 + d)
    pick = rng.integers(0, len(kap), (4, 3))
    np.testing.assert_array_equal(bform.multi_index_lookup(kap[pick], d), pick)


def test_basis_values_in_many_variables():
    """30 variables, degree 3: the dense code table would need 4^30 entries."""
    rng = np.random.default_rng(0)
    b = rng.dirichlet(np.ones(31), size=5)
    B = basis_values(b, 3)
    assert B.shape == (5, math.comb(33, 3))
    np.testing.assert_allclose(B.sum(axis=1), 1.0, rtol=1e-12)
    k = multi_indices(30, 3)
    direct = (math.factorial(3) / np.prod([[math.factorial(int(v)) for v in row]
                                           for row in k], axis=1)) * np.prod(
        b[:, None, :] ** k[None], axis=2)
    np.testing.assert_allclose(B, direct, rtol=1e-12, atol=1e-300)
