"""TermGrams: the normal equations of any set of terms, assembled from blocks kept per pair
of terms, equal a fresh accumulation up to round-off."""

from __future__ import annotations

import numpy as np
import pytest

from simplexspline import InputError, OutsideDomainError, SplineSpace, Triangulation
from simplexspline.spline.varying import TermGrams, VaryingCoefficientSpace, \
    VaryingNormalEquations


def _sample(n=4000, seed=0):
    rng = np.random.default_rng(seed)
    z = rng.random((n, 2))
    cols = {"1": np.ones(n), "u": rng.normal(size=n), "v": rng.uniform(-1, 1, n),
            "uv": rng.normal(size=n) ** 2}
    y = np.sin(3 * z[:, 0]) + cols["u"] * z[:, 1] + 0.01 * rng.normal(size=n)
    return z, cols, y, rng.uniform(0.5, 2.0, n)


def _fresh(tri, degree, z, cols, names, y, w):
    m = np.column_stack([cols[k] for k in names])
    return VaryingNormalEquations(tri, degree, len(names)).add(z, m, y, w)


@pytest.mark.parametrize("weighted", [False, True])
def test_any_set_of_terms_equals_a_fresh_accumulation(weighted):
    z, cols, y, w = _sample()
    w = w if weighted else None
    tri = Triangulation.grid([0, 0], [1, 1], (3, 2))
    grams = TermGrams(tri, 3, z, y, w)
    # terms in several sets and orders, new ones arriving after others were assembled
    for names in (["1", "u"], ["u", "1", "v"], ["v"], ["1", "uv", "u", "v"], ["uv", "1"]):
        ne = grams.normal_equations([(k, cols[k]) for k in names])
        ref = _fresh(tri, 3, z, cols, names, y, w)
        scale = np.abs(ref.XtWX).max()
        assert np.abs(ne.XtWX - ref.XtWX).max() <= 1e-12 * scale
        assert np.allclose(ne.XtWy, ref.XtWy, rtol=1e-12, atol=1e-12 * np.abs(ref.XtWy).max())
        assert ne.ytWy == pytest.approx(ref.ytWy, rel=1e-13)
        assert np.array_equal(ne.counts, ref.counts)
        assert np.allclose(ne.wsum, ref.wsum, rtol=1e-13)
        assert ne.nterms == len(names)


def test_assembled_equations_solve_to_the_fresh_fit_and_are_independent_copies():
    z, cols, y, _ = _sample()
    space = VaryingCoefficientSpace(SplineSpace(Triangulation.grid([0, 0], [1, 1], (2, 2)),
                                                3, 1), 2)
    grams = TermGrams(space.triangulation, 3, z, y)
    ne = grams.normal_equations([("1", cols["1"]), ("u", cols["u"])])
    ref = space.normal_equations(z, np.column_stack([cols["1"], cols["u"]]), y)
    a = space.solve(ne).coefficients
    b = space.solve(ref).coefficients
    assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max()
    ne.XtWX[:] = 0.0          # the caller's copy: the kept blocks do not change
    again = grams.normal_equations([("1", cols["1"]), ("u", cols["u"])])
    assert np.abs(again.XtWX - ref.XtWX).max() <= 1e-12 * np.abs(ref.XtWX).max()


def test_bad_input():
    z, cols, y, _ = _sample(200)
    tri = Triangulation.grid([0, 0], [1, 1], (2, 2))
    with pytest.raises(OutsideDomainError, match="outside the triangulation"):
        TermGrams(tri, 2, z + 1.5, y)
    grams = TermGrams(tri, 2, z, y)
    with pytest.raises(InputError, match="repeated term keys"):
        grams.normal_equations([("u", cols["u"]), ("u", cols["u"])])
    with pytest.raises(InputError, match="200 finite values"):
        grams.normal_equations([("w", np.ones(10))])
    bad = cols["u"].copy()
    bad[3] = np.nan
    with pytest.raises(InputError, match="finite values"):
        grams.normal_equations([("nan", bad)])
