"""What the data can and cannot tell: excitation of a coefficient and collinearity of the
explanatory variables.

* **Excitation.** A coefficient whose validation data barely vary beyond the noise gives a
  relative RMS bound by the noise and an R^2 near 0, whatever the model: the data do not
  test it. :func:`excitation` says so, names the maneuvers that excited the coefficient
  most, and which kind of input would excite it (elevator for the longitudinal
  coefficients, aileron for the rolling moment, rudder for the side force and yawing
  moment: the standard assignment of inputs to axes, true of any conventional aircraft).
* **Collinearity.** In trimmed flight the angle of attack and the elevator move together;
  in a steady sideslip the rudder and the sideslip do. The data then cannot separate
  their effects, and a model returns a confident but arbitrary split. :func:`collinearity`
  computes each variable's variance inflation factor and its most correlated partner, and
  the standard error of its local linear derivative, with the samples' correlation in
  time counted (an effective number of samples).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

__all__ = ["EXCITING_INPUTS", "LOW_R2", "VIF_LIMIT", "collinearity", "excitation"]

#: Validation R^2 below which a coefficient counts as barely excited.
LOW_R2 = 0.3
#: Variance inflation factor above which a variable's effect is called inseparable.
VIF_LIMIT = 10.0

#: The control that excites each coefficient (conventional aircraft, standard axes).
EXCITING_INPUTS = {"CX": "elevator", "CZ": "elevator", "Cm": "elevator",
                   "CY": "rudder", "Cl": "aileron", "Cn": "rudder"}


def excitation(coefficient: str, measured: np.ndarray, residual: np.ndarray,
               maneuvers: np.ndarray, r2: float, maneuver_types: np.ndarray | None = None,
               ) -> dict:
    """How well the validation data excite a coefficient.

    Parameters
    ----------
    coefficient : str
    measured : ndarray, shape (N,)
        The coefficient on the validation samples.
    residual : ndarray, shape (N,)
        Measured minus model.
    maneuvers : ndarray, shape (N,)
    r2 : float
        Validation R^2.
    maneuver_types : ndarray, shape (N,), optional
        The ``maneuver_type`` column.

    Returns
    -------
    dict
        ``ratio``: standard deviation of the coefficient over that of the residual (1:
        nothing but noise); ``excited`` (bool: R^2 >= :data:`LOW_R2`); ``best``: the (up
        to) three maneuvers with the largest variation of the coefficient; ``message``:
        a warning text when not excited, else empty.
    """
    y = np.asarray(measured, dtype=float)
    e = np.asarray(residual, dtype=float)
    man = np.asarray(maneuvers)
    ratio = float(np.std(y) / np.std(e)) if np.std(e) > 0 else float("inf")
    ids = np.unique(man)
    spread = np.array([np.std(y[man == m]) for m in ids])
    best = [(int(m) if np.issubdtype(type(m), np.integer) else str(m))
            for m in ids[np.argsort(-spread)[:3]]]
    excited = bool(np.isfinite(r2) and r2 >= LOW_R2)
    out = {"ratio": ratio, "excited": excited, "best": best, "message": ""}
    if not excited:
        kinds = ""
        if maneuver_types is not None:
            mt = np.asarray(maneuver_types)
            kinds = ", ".join(sorted({str(mt[man == m][0]) for m in best}))
            kinds = f" ({kinds})"
        axis = EXCITING_INPUTS.get(coefficient, "control")
        out["message"] = (
            f"{coefficient} is barely excited in the validation data (R^2 = {r2:.2f}; its "
            f"variation is {ratio:.1f}x the residual): its relative RMS measures the noise, "
            f"not the model. Maneuvers {best}{kinds} excite it most; fly more "
            f"{axis} inputs (3211 or doublets) to test it")
    return out


def _effective_samples(n: int, autocorrelation: Sequence[float] | None) -> float:
    """N / (1 + 2 sum of positive-lag autocorrelations), at least 1 (correlated samples
    carry less information than independent ones)."""
    if not autocorrelation:
        return float(n)
    rho = np.asarray(autocorrelation[1:], dtype=float)
    first_negative = np.flatnonzero(rho <= 0)
    rho = rho[:first_negative[0]] if first_negative.size else rho
    return max(1.0, n / (1.0 + 2.0 * float(rho.sum())))


def collinearity(columns: Mapping, variables: Sequence[str], residual: np.ndarray,
                 autocorrelation: Sequence[float] | None = None,
                 limit: float = VIF_LIMIT) -> list[dict]:
    """Variance inflation factors of the explanatory variables and the standard errors of
    their linear derivatives.

    Parameters
    ----------
    columns : mapping of str to ndarray, shape (N,)
        Identification data.
    variables : sequence of str
        The model's input columns (physical units).
    residual : ndarray, shape (N,)
        Model residuals on those samples (for the noise level).
    autocorrelation : sequence of float, optional
        Residual autocorrelation at lags 0, 1, ... (for the effective sample count).
    limit : float
        VIF above which a variable is reported as inseparable.

    Returns
    -------
    list of dict
        Per variable that varies: ``variable``, ``vif``, ``partner`` (most correlated
        other variable), ``correlation``, ``std_error`` (standard error of the derivative
        dC/dv of a linear model in all the variables, per unit of v), ``separable``
        (``vif <= limit``).
    """
    names = [v for v in variables if v in columns and np.ptp(np.asarray(columns[v],
                                                                         float)) > 0]
    if not names:
        return []
    x = np.column_stack([np.asarray(columns[v], dtype=float) for v in names])
    x = x - x.mean(axis=0)
    sd = x.std(axis=0)
    z = x / sd
    corr = np.corrcoef(z, rowvar=False) if len(names) > 1 else np.ones((1, 1))
    corr = np.atleast_2d(corr)
    inv = np.linalg.pinv(corr)
    e = np.asarray(residual, dtype=float)
    sigma = float(np.std(e))
    n_eff = _effective_samples(len(e), autocorrelation)
    out = []
    for i, v in enumerate(names):
        vif = float(max(inv[i, i], 1.0))
        others = np.abs(np.delete(corr[i], i))
        j = int(np.argmax(others)) if others.size else -1
        partner = None if j < 0 else [w for k, w in enumerate(names) if k != i][j]
        se = sigma * np.sqrt(vif) / (np.sqrt(n_eff) * sd[i])
        out.append({"variable": v, "vif": vif, "partner": partner,
                    "correlation": None if j < 0 else float(np.delete(corr[i], i)[j]),
                    "std_error": float(se), "separable": vif <= limit})
    return out

