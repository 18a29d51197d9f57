"""Standard errors of stability and control derivatives by the maneuver jackknife.

A derivative of an identified model is a function of all its coefficients, and the
coefficients of a varying-coefficient model, held terms, priors and kinks have no
closed-form covariance here (:mod:`simplexspline.spline.uncertainty` covers plain splines).
Flight data also break the textbook assumptions: the residuals of one maneuver are
correlated (turbulence, the reconstruction's errors), so the samples are not the
independent units; the maneuvers are.

The delete-a-group jackknife (Quenouille, Tukey; Efron & Tibshirani, *An Introduction to
the Bootstrap*, 11.5) needs neither. The identification maneuvers are dealt into ``g``
folds (:func:`~simplexspline.aero.selection.validation.fold_by_maneuver`); each model's
structure is identified again without each fold, and the derivative ``theta_f`` of each
refit is taken at the same flight condition as the delivered model's ``theta``. Then

    se(theta) = sqrt((g - 1) / g * sum_f (theta_f - mean_f theta_f)^2).

It measures what the data determine: where alpha and the elevator move together in
trimmed flight and one maneuver separates them, leaving that maneuver out moves
``Cm_alpha`` a long way, and the standard error says so instead of a confident slope.
It is conditional on the structure (the search is not repeated per fold), so it misses
the uncertainty of the model's form; and with few folds it is itself uncertain (with
five, a standard error is known to about +-35 %).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from simplexspline.aero.derivatives.stability import derivatives
from simplexspline.errors import InputError

__all__ = ["MIN_FOLDS", "PRIMARY", "jackknife_derivatives", "primary_derivatives"]

#: Fewest refits with a finite derivative for a standard error (NaN with fewer).
MIN_FOLDS = 3

#: The classical derivatives of each coefficient: its static stability, damping and
#: control power along its own axis (the ones the notes judge), where the models have them.
PRIMARY = ("CL_alpha", "CY_beta", "Cl_beta", "Cl_p", "Cl_da", "Cm_alpha", "Cm_q", "Cm_de",
           "Cn_beta", "Cn_r", "Cn_dr")


def jackknife_derivatives(models: Mapping, fold_models: Sequence[Mapping], *,
                          reference: Mapping, wrt: Sequence[str] | None = None,
                          geometry: Mapping | None = None) -> pd.DataFrame:
    """Derivatives at one flight condition with their maneuver-jackknife standard errors.

    Parameters
    ----------
    models : mapping of str to AeroModel
        The delivered models, by coefficient.
    fold_models : sequence of mapping of str to AeroModel
        Per fold, the same structures identified without that fold's maneuvers (a
        coefficient missing from a fold, or None: its refit failed, and the fold does not
        count for it).
    reference : mapping of str to float
        The flight condition [SI units, rad], every variable of the models.
    wrt : sequence of str, optional
        As in :func:`~simplexspline.aero.derivatives.stability.derivatives`.
    geometry : mapping, optional
        As there.

    Returns
    -------
    pandas.DataFrame
        One row per derivative (index: its name, ``Cm_alpha``): ``coefficient``,
        ``variable``, ``unit``, ``in_model``, ``value`` (the delivered models'),
        ``standard_error`` (NaN with fewer than :data:`MIN_FOLDS` finite refits, and 0
        for a variable the model does not take), ``folds`` (the refits that count) and
        ``fold_values`` (a tuple). ``attrs['reference']`` holds the condition.

    Raises
    ------
    InputError
        No models, or a fold with a coefficient the models lack.
    """
    if not models:
        raise InputError("jackknife_derivatives needs at least one model")
    ref = {str(k): float(v) for k, v in reference.items()}
    options = {"wrt": wrt, "reference": ref, "geometry": geometry, "outside": "nan"}
    full = derivatives(dict(models), **options)
    info = full.attrs["derivatives"]
    names = list(info)
    per_fold = []
    for fold in fold_models:
        fold = {c: m for c, m in fold.items() if m is not None}
        extra = set(fold) - set(models)
        if extra:
            raise InputError(f"a fold holds coefficient(s) {sorted(extra)} that the models "
                             "do not")
        vals = dict.fromkeys(names, np.nan)
        if fold:
            table = derivatives(fold, **options)
            vals.update({n: float(table[n].iloc[0]) for n in names if n in table.columns})
        # a derivative counts in a fold only where all the models it needs were refitted
        for n in names:
            needs = info[n].get("model_variables") if info[n]["coefficient"] in ("CL", "CD") \
                else [info[n]["coefficient"]]
            if not all(c in fold for c in needs):
                vals[n] = np.nan
        per_fold.append(vals)
    rows = []
    for n in names:
        theta = np.array([f[n] for f in per_fold], dtype=float)
        theta = theta[np.isfinite(theta)]
        g = theta.size
        if not info[n]["in_model"]:
            se = 0.0
        elif g >= MIN_FOLDS:
            se = float(np.sqrt((g - 1) / g * np.sum((theta - theta.mean()) ** 2)))
        else:
            se = float("nan")
        rows.append({"derivative": n, "coefficient": info[n]["coefficient"],
                     "variable": info[n]["variable"], "unit": info[n]["unit"],
                     "in_model": bool(info[n]["in_model"]),
                     "value": float(full[n].iloc[0]), "standard_error": se, "folds": g,
                     "fold_values": tuple(float(t) for t in theta)})
    out = pd.DataFrame(rows).set_index("derivative")
    out.attrs = {"reference": ref, "folds": len(fold_models)}
    return out


def primary_derivatives(table: pd.DataFrame) -> pd.DataFrame:
    """The rows of a :func:`jackknife_derivatives` table that are :data:`PRIMARY` and in
    their models, in that order."""
    keep = [n for n in PRIMARY if n in table.index and bool(table.loc[n, "in_model"])]
    return table.loc[keep]
