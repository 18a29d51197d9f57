"""The maneuver jackknife of the derivatives: its formula, its calibration against the
textbook standard error where that one holds, and what it says where the data are
collinear."""

from __future__ import annotations

import numpy as np
import pytest

from simplexspline.aero.derivatives import derivatives
from simplexspline.aero.derivatives.jackknife import (
    MIN_FOLDS,
    jackknife_derivatives,
    primary_derivatives,
    with_standard_errors,
)
from simplexspline.aero.modelling.structure import Structure
from simplexspline.aero.selection.search import fit_structure
from simplexspline.aero.selection.validation import fold_by_maneuver
from simplexspline.errors import InputError

#: Cm linear in alpha, de and qhat: the classical model, one simplex, constant coefficients.
LINEAR = Structure("Cm", ("alpha",), 0, -1, (1,), multipliers=("1", "alpha", "de", "qhat"))
TRUE = {"Cm_alpha": -0.6, "Cm_de": -1.2, "Cm_q": -9.0}


def _flight(n_maneuvers: int = 20, samples: int = 300, *, seed: int = 0,
            collinear: bool = False, noise: float = 2e-3) -> dict:
    """Columns of maneuvers with Cm = 0.02 - 0.6 alpha - 1.2 de - 9 qhat + white noise.
    ``collinear``: alpha follows the elevator (trimmed flight, alpha = -de / 2 + a tiny
    independent part) in every maneuver but one."""
    rng = np.random.default_rng(seed)
    cols = {k: [] for k in ("maneuver", "alpha", "de", "qhat", "Cm")}
    t = np.linspace(0.0, 6.0, samples)
    for m in range(n_maneuvers):
        de = 0.05 * np.sin(2 * np.pi * rng.uniform(0.1, 0.5) * t + rng.uniform(0, 6))
        free = 0.04 * np.sin(2 * np.pi * rng.uniform(0.2, 0.8) * t + rng.uniform(0, 6))
        alpha = 0.05 - 0.5 * de + (0.001 * free / 0.04 if collinear and m else free)
        qhat = 0.003 * np.sin(2 * np.pi * rng.uniform(0.3, 1.0) * t + rng.uniform(0, 6))
        cm = 0.02 + TRUE["Cm_alpha"] * alpha + TRUE["Cm_de"] * de + TRUE["Cm_q"] * qhat
        for k, v in (("maneuver", np.full(samples, m)), ("alpha", alpha), ("de", de),
                     ("qhat", qhat), ("Cm", cm + noise * rng.standard_normal(samples))):
            cols[k].append(v)
    return {k: np.concatenate(v) for k, v in cols.items()}


def _fits(cols: dict, k: int, structure: Structure = LINEAR) -> tuple:
    """The model on all the data and the k refits without each fold of maneuvers."""
    y = cols["Cm"]
    full = fit_structure(structure, cols, y)
    folds = fold_by_maneuver(cols["maneuver"], k, seed=0)
    refits = [{"Cm": fit_structure(structure, {v: x[folds != f] for v, x in cols.items()},
                                   y[folds != f])} for f in range(k)]
    return {"Cm": full}, refits


REFERENCE = {"alpha": 0.05, "de": 0.0, "qhat": 0.0}


def test_the_standard_error_is_the_jackknife_formula_over_the_refits():
    models, refits = _fits(_flight(), 5)
    table = jackknife_derivatives(models, refits, reference=REFERENCE)
    theta = np.array([derivatives(f, reference=REFERENCE)["Cm_alpha"].iloc[0]
                      for f in refits])
    expected = np.sqrt(4 / 5 * np.sum((theta - theta.mean()) ** 2))
    assert table.loc["Cm_alpha", "standard_error"] == pytest.approx(expected, rel=1e-12)
    assert table.loc["Cm_alpha", "folds"] == 5
    assert table.loc["Cm_alpha", "fold_values"] == pytest.approx(tuple(theta))
    assert table.loc["Cm_alpha", "value"] == pytest.approx(
        derivatives(models, reference=REFERENCE)["Cm_alpha"].iloc[0])
    assert table.attrs["reference"] == REFERENCE and table.attrs["folds"] == 5


def test_with_independent_noise_it_agrees_with_the_least_squares_standard_error():
    cols = _flight(n_maneuvers=30, seed=3)
    models, refits = _fits(cols, 10)
    table = jackknife_derivatives(models, refits, reference=REFERENCE)
    # the textbook standard errors of ordinary least squares (white noise: they hold here)
    x = np.column_stack([np.ones(len(cols["Cm"])), cols["alpha"], cols["de"], cols["qhat"]])
    coef, res, *_ = np.linalg.lstsq(x, cols["Cm"], rcond=None)
    sigma2 = res[0] / (len(x) - x.shape[1])
    se = np.sqrt(np.diag(sigma2 * np.linalg.inv(x.T @ x)))
    for name, j in (("Cm_alpha", 1), ("Cm_de", 2), ("Cm_q", 3)):
        assert table.loc[name, "value"] == pytest.approx(coef[j], rel=1e-6)
        # ten folds: the jackknife's own spread is about +-25 %
        assert 0.5 < table.loc[name, "standard_error"] / se[j] < 2.0, name
        assert abs(table.loc[name, "value"] - TRUE[name]) < 4 * se[j]


def test_collinear_data_give_a_large_standard_error_not_a_confident_slope():
    free = jackknife_derivatives(*_fits(_flight(seed=1), 5), reference=REFERENCE)
    tangled = jackknife_derivatives(*_fits(_flight(seed=1, collinear=True), 5),
                                    reference=REFERENCE)
    # one maneuver in twenty moves alpha apart from the elevator: the fold without it
    # hardly separates them, and the standard errors grow by more than five times
    for name in ("Cm_alpha", "Cm_de"):
        assert tangled.loc[name, "standard_error"] > 5 * free.loc[name, "standard_error"]
    # and the spread is one refit's, the one without that maneuver
    theta = np.array(tangled.loc["Cm_alpha", "fold_values"])
    dev = np.sort(np.abs(theta - np.median(theta)))
    assert dev[-1] > 5 * dev[-2]


def test_failed_refits_do_not_count_and_too_few_give_nan():
    models, refits = _fits(_flight(), 5)
    refits[1] = {"Cm": None}
    table = jackknife_derivatives(models, refits, reference=REFERENCE)
    assert table.loc["Cm_alpha", "folds"] == 4 and np.isfinite(
        table.loc["Cm_alpha", "standard_error"])
    few = jackknife_derivatives(models, refits[:MIN_FOLDS - 1] + [{}],
                                reference=REFERENCE)
    assert np.isnan(few.loc["Cm_alpha", "standard_error"])


def test_a_variable_the_model_does_not_take_has_no_error():
    cols = _flight()
    cols["beta"] = np.zeros_like(cols["alpha"])
    models, refits = _fits(cols, 5)
    table = jackknife_derivatives(models, refits, reference={**REFERENCE, "beta": 0.0},
                                  wrt=["alpha", "beta"])
    assert not table.loc["Cm_beta", "in_model"]
    assert table.loc["Cm_beta", "value"] == 0.0 and table.loc["Cm_beta", "standard_error"] == 0.0


def test_primary_derivatives_keep_the_classical_ones_in_order():
    table = jackknife_derivatives(*_fits(_flight(), 5), reference=REFERENCE)
    assert list(primary_derivatives(table).index) == ["Cm_alpha", "Cm_q", "Cm_de"]


def test_bad_input_is_named():
    models, refits = _fits(_flight(n_maneuvers=6), 3)
    with pytest.raises(InputError, match="at least one model"):
        jackknife_derivatives({}, refits, reference=REFERENCE)
    with pytest.raises(InputError, match=r"coefficient\(s\) \['Cl'\] that the models do not"):
        jackknife_derivatives(models, [{"Cl": models["Cm"]}], reference=REFERENCE)


def test_standard_errors_at_every_condition_agree_with_the_reference_ones():
    models, refits = _fits(_flight(), 5)
    at_ref = jackknife_derivatives(models, refits, reference=REFERENCE)
    one = with_standard_errors(derivatives(models, reference=REFERENCE), refits)
    for name in ("Cm_alpha", "Cm_de", "Cm_q"):
        assert one[f"se_{name}"].iloc[0] == pytest.approx(at_ref.loc[name, "standard_error"])
    grid = {"alpha": np.linspace(0.0, 0.1, 7)}
    table = with_standard_errors(derivatives(models, grid, reference=REFERENCE), refits,
                                 grid)
    assert len(table) == 7 and np.all(np.isfinite(table["se_Cm_alpha"]))
    # a linear model: the same derivative and error everywhere
    assert np.ptp(table["se_Cm_alpha"]) < 1e-12
    assert table.attrs["jackknife_folds"] == 5
    with pytest.raises(InputError, match="that the models do not"):
        with_standard_errors(table, [{"Cl": models["Cm"]}])


def test_the_plot_shades_two_standard_errors_where_the_table_has_them():
    from matplotlib.collections import PolyCollection

    from simplexspline.aero.derivatives import plot_derivatives

    models, refits = _fits(_flight(), 5)
    grid = {"alpha": np.linspace(0.0, 0.1, 7)}
    plain = derivatives(models, grid, reference=REFERENCE)
    shaded = with_standard_errors(plain, refits, grid)

    def bands(table):
        fig = plot_derivatives(table, x="alpha", by=None)
        return sum(isinstance(c, PolyCollection) for ax in fig.axes for c in ax.collections)

    assert bands(plain) == 0 and bands(shaded) == 3      # Cm_alpha, Cm_de, Cm_q
