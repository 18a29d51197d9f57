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
from pathlib import Path

import numpy as np
import pandas as pd

from simplexspline.aero.derivatives.stability import derivatives
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.errors import InputError

__all__ = ["FOLD_DIR", "MIN_FOLDS", "PRIMARY", "jackknife_derivatives", "load_fold_models",
           "primary_derivatives", "with_standard_errors"]

#: The folder, inside an identification output's ``models/``, that holds the refits
#: (``<C>-<fold>.json`` or ``.npz``), written by ``Identification.save``.
FOLD_DIR = "jackknife"

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
    full = derivatives(dict(models), wrt=wrt, reference=ref, geometry=geometry,
                       outside="nan")
    info = full.attrs["derivatives"]
    names = list(info)
    thetas = _fold_values(full, fold_models, None, {"wrt": wrt, "geometry": geometry})
    rows = []
    for n in names:
        theta = thetas[n][:, 0]
        theta = theta[np.isfinite(theta)]
        g = theta.size
        se = 0.0 if not info[n]["in_model"] else float(_jackknife_se(theta[:, None])[0])
        rows.append({"derivative": n, "coefficient": info[n]["coefficient"],
                     "variable": info[n]["variable"], "unit": info[n]["unit"],
                     "in_model": bool(info[n]["in_model"]),
                     "value": float(full[n].iloc[0]), "standard_error": se, "folds": g,
                     "fold_values": tuple(float(t) for t in theta)})
    out = pd.DataFrame(rows).set_index("derivative")
    out.attrs = {"reference": ref, "folds": len(fold_models)}
    return out


def _fold_values(table: pd.DataFrame, fold_models: Sequence[Mapping], at,
                 options: Mapping) -> dict:
    """Per derivative of ``table`` (made by ``derivatives(models, at, ...)``) its values
    in every refit at the table's conditions, shape (folds, N): NaN where a fold lacks a
    model the derivative needs (``CL_alpha``: CX and CZ) or a refit is undefined there.

    Raises
    ------
    InputError
        A fold with a coefficient the table's models lack.
    """
    info = table.attrs["derivatives"]
    known = set(table.attrs.get("models", {}))
    values = {n: np.full((len(fold_models), len(table)), np.nan) for n in info}
    for f, fold in enumerate(fold_models):
        fold = {c: m for c, m in fold.items() if m is not None}
        extra = set(fold) - known
        if extra:
            raise InputError(f"a fold holds coefficient(s) {sorted(extra)} that the models "
                             "do not")
        if not fold:
            continue
        part = derivatives(fold, at, outside="nan", reference=table.attrs["reference"],
                           **options)
        for n, d in info.items():
            needs = d.get("model_variables") if d["coefficient"] in ("CL", "CD") \
                else [d["coefficient"]]
            if n in part.columns and all(c in fold for c in needs):
                values[n][f] = part[n].to_numpy(dtype=float)
    return values


def _jackknife_se(theta: np.ndarray) -> np.ndarray:
    """Per column of ``theta`` (refits x conditions, NaN where a refit gave none) the
    jackknife standard error over its finite refits; NaN with fewer than
    :data:`MIN_FOLDS`."""
    ok = np.isfinite(theta)
    g = ok.sum(axis=0)
    mean = np.where(g > 0, np.nansum(theta, axis=0) / np.maximum(g, 1), np.nan)
    dev = np.where(ok, theta - mean, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        se = np.sqrt((g - 1) / np.maximum(g, 1) * np.sum(dev ** 2, axis=0))
    return np.where(g >= MIN_FOLDS, se, np.nan)


def with_standard_errors(table: pd.DataFrame, fold_models: Sequence[Mapping], at=None, *,
                         wrt: Sequence[str] | None = None, rates: str = "native",
                         geometry: Mapping | None = None) -> pd.DataFrame:
    """A wide :func:`~simplexspline.aero.derivatives.stability.derivatives` table with a
    ``se_<name>`` column per derivative: its jackknife standard error at each condition
    from the refits ``fold_models`` (as :func:`jackknife_derivatives`), evaluated at the
    table's own conditions (``at`` and ``table.attrs['reference']``, as the table was
    made). 0 for a variable the model does not take; NaN outside a refit's domain with
    fewer than :data:`MIN_FOLDS` refits left.

    Raises
    ------
    InputError
        A fold with a coefficient the table's models lack.
    """
    info = table.attrs["derivatives"]
    theta = _fold_values(table, fold_models, at,
                         {"wrt": wrt, "rates": rates, "geometry": geometry})
    out = table.copy()
    for n, d in info.items():
        out[f"se_{n}"] = (np.zeros(len(table)) if not d["in_model"]
                          else _jackknife_se(theta[n]))
    out.attrs = {**table.attrs, "jackknife_folds": len(fold_models)}
    return out


def load_fold_models(outdir, coefficients=None) -> list:
    """The refits an identification output keeps (``OUTDIR/models/jackknife``), as a list
    of ``{coefficient: AeroModel}`` per fold; empty when the output has none (written
    before stop 57, or with ``derivative_folds = 0``).

    Raises
    ------
    ModelFileError
        A refit's file that cannot be read.
    """
    folder = Path(outdir) / "models" / FOLD_DIR
    if not folder.is_dir():
        return []
    folds: dict = {}
    for path in sorted(folder.iterdir()):
        stem, _, index = path.stem.rpartition("-")
        if path.suffix.lower() not in (".json", ".npz") or not index.isdigit():
            continue
        if coefficients is not None and stem not in coefficients:
            continue
        folds.setdefault(int(index), {})[stem] = AeroModel.load(path)
    return [folds[k] for k in sorted(folds)]


def primary_derivatives(table: pd.DataFrame) -> pd.DataFrame:
    """The rows of a :func:`jackknife_derivatives` table that are :data:`PRIMARY` and in
    their models, in that order."""
    keep = [n for n in PRIMARY if n in table.index and bool(table.loc[n, "in_model"])]
    return table.loc[keep]
