"""Coverage of the identification data, the split and CV that do not reward extrapolation,
scores inside and outside the coverage, excitation and collinearity diagnostics, and the
flow-angle rates."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from simplexspline.aero.data.angle_rates import angle_rates
from simplexspline.aero.selection.coverage import (
    COVERAGE_MIN_COUNT,
    EnvelopeCells,
    covered_in_folds,
    search_cells,
    threshold,
)
from simplexspline.aero.selection.diagnostics import VIF_LIMIT, collinearity, excitation
from simplexspline.aero.selection.validation import (
    COVERED_KEEP,
    fold_by_maneuver,
    scores_by_coverage,
    split_by_maneuver,
)
from simplexspline.aero.selection.search import SelectionSettings, cv_scored_share
from simplexspline.errors import InputError


def _envelope(n_man=20, per=300, seed=0):
    """Maneuvers around 0.05 rad of alpha, and one lone maneuver far above (id 99)."""
    rng = np.random.default_rng(seed)
    alpha = np.concatenate([rng.normal(0.05, 0.03, per) for _ in range(n_man)]
                           + [rng.uniform(0.3, 0.4, per)])
    mach = np.concatenate([np.full(per, rng.uniform(0.4, 0.8)) for _ in range(n_man)]
                          + [np.full(per, 0.3)])
    man = np.repeat(np.r_[np.arange(n_man), 99], per)
    return {"alpha": alpha, "mach": mach}, man


def test_cells_are_equal_width_and_constant_variables_are_left_out():
    cols, _ = _envelope()
    cols["beta"] = np.zeros_like(cols["alpha"])
    env = EnvelopeCells.from_data(cols, bins=4)
    assert env.variables == ("alpha", "mach")
    e = env.edges[0]
    assert np.allclose(np.diff(np.r_[cols["alpha"].min(), e, cols["alpha"].max()]),
                       np.ptp(cols["alpha"]) / 4)
    cells = env.cell(cols)
    assert cells.min() >= 0 and cells.max() < env.ncells == 16
    with pytest.raises(InputError, match="missing"):
        env.cell({"alpha": cols["alpha"]})
    with pytest.raises(InputError, match="bins"):
        EnvelopeCells.from_data(cols, bins=0)


def test_covered_in_folds_counts_only_the_other_folds():
    rng = np.random.default_rng(1)
    cells = rng.integers(0, 7, 500)
    folds = rng.integers(0, 3, 500)
    cells[cells == 6] = np.where(folds[cells == 6] == 0, 6, 5)   # cell 6: fold 0 only
    got = covered_in_folds(cells, folds, 7)
    for i in range(0, 500, 7):
        rest = np.bincount(cells[folds != folds[i]], minlength=7)
        assert got[i] == (rest[cells[i]] >= threshold(rest))
    assert not got[cells == 6].any()
    assert threshold(np.array([0, 0, 1000, 3000])) == pytest.approx(0.05 * 2000)
    assert threshold(np.array([0, 10, 10])) == COVERAGE_MIN_COUNT


def _test_points(n_points=5, per=200, seed=2):
    """A flight-test course: per test point (its own Mach number) an elevator, an aileron
    and a rudder maneuver, the rudder one alone in reaching large sideslip."""
    rng = np.random.default_rng(seed)
    cols = {"alpha": [], "beta": [], "mach": []}
    man, kind = [], []
    for p in range(n_points):
        for k, beta_amp in enumerate((0.002, 0.01, 0.08)):
            cols["alpha"].append(0.06 + 0.01 * rng.standard_normal(per))
            cols["beta"].append(beta_amp * np.sin(np.linspace(0, 6, per)))
            cols["mach"].append(np.full(per, 0.3 + 0.1 * p) + 1e-3 * rng.standard_normal(per))
            man.append(np.full(per, 3 * p + k))
            kind.append(k)
    return ({v: np.concatenate(x) for v, x in cols.items()}, np.concatenate(man),
            np.array(kind))


def test_a_lateral_search_scores_a_rudder_input_flown_once_per_test_point():
    """Without the sideslip among the cells, the lateral coefficients' cross-validation
    scores each test point's one rudder maneuver against the same test point's other
    maneuvers; the longitudinal coefficients keep the sideslip and leave it unscored."""
    cols, man, kind = _test_points()
    env = EnvelopeCells.from_data(cols)
    assert env.variables == ("alpha", "beta", "mach")
    lateral = env.without(("beta",))
    assert lateral.variables == ("alpha", "mach") and lateral.edges[0] is env.edges[0]
    assert lateral.ncells == (len(env.edges[0]) + 1) * (len(env.edges[2]) + 1)
    assert np.array_equal(search_cells(env, "CX", cols), env.cell(cols))
    assert np.array_equal(search_cells(env, "Cm", cols), env.cell(cols))
    cy = search_cells(env, "CY", cols)
    assert np.array_equal(cy, lateral.cell(cols))
    assert np.array_equal(search_cells(env, "Cn", cols), cy)
    y = np.zeros(len(man))
    rudder = [3 * p + 2 for p in range(5)]

    def shares(cells):
        got = cv_scored_share(cols, y, man, SelectionSettings(folds=3), seed=0, cells=cells)
        return np.array([got[m] for m in rudder])

    assert shares(env.cell(cols)).max() < 0.5          # large sideslip: alone in its cells
    assert shares(cy).min() > 0.9                      # but the tails in alpha


def test_split_never_holds_out_a_maneuver_that_only_it_flies():
    cols, man = _envelope()
    env = EnvelopeCells.from_data(cols)
    cells = env.cell(cols)
    for seed in range(6):
        val = split_by_maneuver(man, 0.3, seed=seed, cells=cells)
        assert not val[man == 99].any()
        counts = env.counts(cells, ~val)
        covered = env.covered(cells[val], counts)
        # every held-out maneuver keeps most of its samples inside the coverage
        for m in np.unique(man[val]):
            assert covered[man[val] == m].mean() >= COVERED_KEEP
    # folds are drawn on the maneuvers' most visited cells, each fold non-empty
    folds = fold_by_maneuver(man, 3, conditions=cells)
    assert set(np.unique(folds)) == {0, 1, 2}


def test_scores_by_coverage_separate_extrapolation():
    rng = np.random.default_rng(2)
    truth = rng.normal(size=400)
    y = truth + 0.01 * rng.normal(size=400)
    model = truth.copy()
    covered = np.ones(400, dtype=bool)
    covered[350:] = False
    model[350:] += 1.0                      # a wild extrapolation
    man = np.repeat(np.arange(8), 50)
    s = scores_by_coverage(y, model, covered, truth=truth, maneuvers=man)
    assert s["n"] == 350 and s["coverage"] == pytest.approx(350 / 400)
    assert s["rms_true"] == pytest.approx(0.0)
    assert s["outside"]["n"] == 50 and s["outside"]["rms_true"] == pytest.approx(1.0)
    assert s["outside"]["maneuvers"] == {7: 1.0}
    none = scores_by_coverage(y, model, np.zeros(400, dtype=bool), truth=truth)
    assert none["n"] == 400 and none["coverage"] == 0.0 and "outside" not in none
    with pytest.raises(InputError, match="shape"):
        scores_by_coverage(y, model, covered[:10])


def test_excitation_names_the_maneuvers_and_the_input():
    rng = np.random.default_rng(3)
    man = np.repeat(np.arange(5), 100)
    y = 0.001 * rng.normal(size=500)
    y[man == 3] += 0.01 * np.sin(np.arange(100) / 5)
    types = np.repeat(["doublet-aileron"] * 3 + ["3211-elevator", "doublet-rudder"], 100)
    low = excitation("Cm", y, y - np.where(man == 3, y, 0), man, r2=0.05,
                     maneuver_types=types)
    assert not low["excited"] and low["best"][0] == 3
    assert "Cm is barely excited" in low["message"] and "elevator" in low["message"]
    assert "3211-elevator" in low["message"]
    ok = excitation("Cl", y, 0.1 * y, man, r2=0.9)
    assert ok["excited"] and ok["message"] == ""


def test_collinearity_flags_what_moves_together_with_a_consistent_error():
    rng = np.random.default_rng(4)
    n = 4000
    alpha = rng.normal(size=n)
    de = -0.5 * alpha + 0.01 * rng.normal(size=n)        # trimmed flight: locked together
    qhat = rng.normal(size=n)
    resid = 0.01 * rng.normal(size=n)
    out = {d["variable"]: d for d in collinearity({"alpha": alpha, "de": de, "qhat": qhat},
                                                  ["alpha", "de", "qhat", "beta"], resid)}
    assert set(out) == {"alpha", "de", "qhat"}
    assert not out["de"]["separable"] and out["de"]["partner"] == "alpha"
    assert out["de"]["vif"] > VIF_LIMIT and out["de"]["correlation"] < -0.99
    assert out["qhat"]["separable"] and out["qhat"]["vif"] == pytest.approx(1.0, abs=0.01)
    # independent samples: the classic standard error of a slope
    assert out["qhat"]["std_error"] == pytest.approx(0.01 / (np.sqrt(n) * qhat.std()),
                                                     rel=0.05)
    # correlated samples count less
    slow = collinearity({"qhat": qhat}, ["qhat"], resid, autocorrelation=[1.0, 0.9, 0.8])
    assert slow[0]["std_error"] > 2 * out["qhat"]["std_error"]


def test_angle_rates_are_nondimensional_derivatives_per_maneuver():
    t = np.arange(200) * 0.01
    df = pd.DataFrame({"maneuver": np.repeat([1, 2], 100), "t": np.r_[t[:100], t[:100]],
                       "tas": 100.0, "alpha": np.r_[0.3 * t[:100], -0.2 * t[:100]],
                       "beta": np.r_[np.zeros(100), 0.5 * t[:100]]})
    got = angle_rates(df, {"cbar": 2.0, "b": 10.0})
    assert np.allclose(got["alphadot_hat"], np.r_[np.full(100, 0.3), np.full(100, -0.2)]
                       * 2.0 / 200.0)
    assert np.allclose(got["betadot_hat"][100:], 0.5 * 10.0 / 200.0)
    assert set(angle_rates(df, {"cbar": 2.0})) == {"alphadot_hat"}   # no span: no beta'
