"""Data coverage (issue 7): per-simplex counts and normalised information against exact
values, the supported rule, point queries, summaries and the coverage map."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplexspline import InputError, SplineSpace, Triangulation
from simplexspline.spline.uncertainty.coverage import Coverage, coverage

from . import reference as ref
from .cases import seeded
from .test_spline_regularization import duffy_rule, thin_edge_problem


def test_counts_and_weights_per_simplex():
    tri = Triangulation.grid([0, 0], [1, 1], (3, 3))
    rng = seeded("cov-counts")
    x = rng.uniform(0, 1, (500, 2)) ** 2  # crowded towards the origin
    w = rng.uniform(0.5, 2.0, len(x))
    cov = coverage(SplineSpace(tri, 2, 1).normal_equations(x, np.zeros(len(x)), w))
    sid = tri.locate(x)
    np.testing.assert_array_equal(cov.counts, np.bincount(sid, minlength=tri.nsimplex))
    np.testing.assert_allclose(cov.weight, np.bincount(sid, w, minlength=tri.nsimplex))
    np.testing.assert_allclose(cov.effective_points, cov.counts * cov.information)


@pytest.mark.parametrize("n,d", [(2, 1), (2, 3), (3, 2)])
def test_information_is_one_for_exactly_uniform_data(n, d):
    # Quadrature points weighted by the quadrature weights reproduce the exact expected
    # Gram block of uniform data: the normalised smallest eigenvalue is exactly 1.
    rng = seeded("cov-uniform", n, d)
    V = ref.regular_simplex(n) + 0.1 * rng.standard_normal((n + 1, n))
    tri = Triangulation(V, [list(range(n + 1))])
    b, w = duffy_rule(n, d + n)
    x = b @ V
    keep = tri.locate(x) >= 0
    cov = coverage(SplineSpace(tri, d, -1).normal_equations(x[keep], np.zeros(keep.sum()),
                                                             w[keep] * math.factorial(n)))
    assert keep.all()
    assert cov.information[0] == pytest.approx(1.0, rel=1e-9)


def test_data_on_a_line_carry_no_information():
    tri = Triangulation.grid([0, 0], [1, 1], (1, 1))
    t = seeded("cov-line").uniform(0.05, 0.95, 5000)
    x = np.column_stack([t, 0.3 * t])  # a straight line through simplex 0 or 1
    cov = coverage(SplineSpace(tri, 2, 1).normal_equations(x, np.zeros(len(x))))
    j = int(np.argmax(cov.counts))
    assert cov.counts[j] > 1000
    assert cov.information[j] < 1e-10
    assert not cov.supported[j]


def test_supported_rule_and_threshold():
    tri = Triangulation.grid([0, 0], [1, 1], (4, 4))
    rng = seeded("cov-rule")
    x = np.vstack([rng.uniform(0, 1, (3000, 2)) * [0.5, 1.0],   # dense on the left
                   rng.uniform(0, 1, (30, 2)) * [0.5, 1.0] + [0.5, 0.0]])
    ne = SplineSpace(tri, 3, 1).normal_equations(x, np.zeros(len(x)))
    for thr in (0.25, 1.0, 4.0):
        cov = coverage(ne, min_effective=thr)
        dh = cov.nbasis
        np.testing.assert_array_equal(
            cov.supported, (cov.counts >= dh) & (cov.effective_points >= thr * dh))
    cov = coverage(ne)
    left = tri.centroids()[:, 0] < 0.5
    assert cov.supported[left].all()
    assert not cov.supported[~left].any()
    assert "effective points >= 0.5 * d_hat" in cov.rule


def test_supported_at_points_and_summary():
    tri = Triangulation.grid([0, 0], [1, 1], (4, 4))
    rng = seeded("cov-at")
    x = rng.uniform(0, 1, (4000, 2)) * [0.5, 1.0]
    cov = coverage(SplineSpace(tri, 2, 1).normal_equations(x, np.zeros(len(x))))
    q = np.array([[0.1, 0.5], [0.9, 0.5], [1.5, 0.5], [0.3, 0.9]])
    np.testing.assert_array_equal(cov.supported_at(q), [True, False, False, True])
    s = cov.summary()
    assert s["simplices"] == 32 and s["supported"] == 16 and s["empty"] == 16
    assert s["volume_fraction_supported"] == pytest.approx(0.5)
    assert s["data_fraction_supported"] == pytest.approx(1.0)
    assert 0 < s["information_min"] <= s["information_median"] <= 1.2
    assert "16 of 32 simplices supported (50.0 % of the volume" in str(cov)


def test_thin_edge_is_flagged_where_the_unregularised_fit_diverges():
    x, y, xv, fv, thin = thin_edge_problem(0)
    space = SplineSpace(Triangulation.grid([0, 0], [1, 1], (6, 6)), 3, 1)
    ne = space.normal_equations(x, y)
    cov = coverage(ne)
    plain = space.solve(ne, on_insufficient="minnorm")
    err = np.abs(plain.predict(xv) - fv)
    ok = cov.supported_at(xv)
    # every validation point in a supported simplex lies in the dense region
    assert not np.any(ok & thin)
    assert np.sqrt(np.mean(err[ok] ** 2)) < 0.02 < np.sqrt(np.mean(err[~ok] ** 2))


@pytest.mark.parametrize("n", [2, 3])
def test_plot_writes_a_png(tmp_path, n):
    pytest.importorskip("matplotlib")
    tri = Triangulation.grid([0] * n, [1] * n, (2,) * n)
    x = seeded("cov-plot", n).uniform(0, 1, (800, n)) * np.r_[0.5, np.ones(n - 1)]
    cov = coverage(SplineSpace(tri, 2, 1).normal_equations(x, np.zeros(len(x))))
    path = tmp_path / "coverage.png"
    fig = cov.plot(dims=(0, n - 1), points=x, path=path, labels=("alpha", "beta"))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert fig.axes[0].get_xlabel() == "alpha"
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left
    with pytest.raises(InputError, match="dims must be two different variables"):
        cov.plot(dims=(0, 0))


def test_coverage_input_errors():
    tri = Triangulation.grid([0, 0], [1, 1], (1, 1))
    with pytest.raises(InputError, match="takes a NormalEquations"):
        coverage(np.zeros((2, 6, 6)))
    ne = SplineSpace(tri, 2, 1).normal_equations()
    with pytest.raises(InputError, match="min_effective must be"):
        coverage(ne, min_effective=-1)
    cov = coverage(ne)  # no data: nothing supported, no error
    assert isinstance(cov, Coverage) and not cov.supported.any()
    assert cov.summary()["data_fraction_supported"] == 0.0
