"""Validation: splits by maneuver, RMS / relative RMS (Eq. 54-55), R^2, residual analysis.

The paper's Eq. 54-55 lost the square root in typesetting: here
``RMS = sqrt(mean(eps^2))`` and ``relative RMS = RMS / (max C - min C)`` (a fraction).
"""

from __future__ import annotations

import numpy as np

from simplexspline.errors import InputError

__all__ = ["autocorrelation", "fold_by_maneuver", "scores", "split_by_maneuver"]


def split_by_maneuver(maneuvers: np.ndarray, fraction: float = 0.25, *, seed: int = 0,
                      groups: np.ndarray | None = None) -> np.ndarray:
    """Choose whole maneuvers for validation.

    Parameters
    ----------
    maneuvers : ndarray, shape (N,)
        Maneuver id per sample.
    fraction : float
        Fraction of the maneuvers held out (at least one; at least one left).
    seed : int
    groups : ndarray, shape (N,), optional
        A label per sample (e.g. the maneuver type); maneuvers are drawn in proportion
        within every group so that each kind of maneuver appears in both sets.

    Returns
    -------
    ndarray of bool, shape (N,)
        True for validation samples.
    """
    maneuvers = np.asarray(maneuvers)
    if not 0.0 < fraction < 1.0:
        raise InputError(f"the validation fraction must be in (0, 1), got {fraction!r}")
    ids, first = np.unique(maneuvers, return_index=True)
    if len(ids) < 2:
        raise InputError(f"{len(ids)} maneuver(s) in the data: validation needs at least two "
                         "(one to identify on, one to validate on)")
    rng = np.random.default_rng(seed)
    labels = np.zeros(len(ids), dtype=int) if groups is None else np.unique(
        np.asarray(groups)[first], return_inverse=True)[1]
    chosen = []
    for g in np.unique(labels):
        members = ids[labels == g]
        k = round(fraction * len(members))
        chosen.extend(rng.permutation(members)[:k].tolist())
    chosen = set(chosen)
    if not chosen:
        chosen = {rng.choice(ids)}
    if len(chosen) == len(ids):
        chosen.discard(next(iter(chosen)))
    return np.isin(maneuvers, list(chosen))


def fold_by_maneuver(maneuvers: np.ndarray, k: int, *, seed: int = 0) -> np.ndarray:
    """Fold number (0..k-1) per sample, whole maneuvers per fold (shuffled, balanced by
    sample count)."""
    maneuvers = np.asarray(maneuvers)
    ids, inverse, counts = np.unique(maneuvers, return_inverse=True, return_counts=True)
    if k < 2 or len(ids) < k:
        raise InputError(f"{k}-fold cross-validation needs at least {k} maneuvers, the "
                         f"identification set has {len(ids)}")
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(ids))
    load = np.zeros(k)
    fold_of = np.empty(len(ids), dtype=int)
    for i in order[np.argsort(-counts[order], kind="stable")]:
        f = int(np.argmin(load))
        fold_of[i] = f
        load[f] += counts[i]
    return fold_of[inverse]


def autocorrelation(residual: np.ndarray, maneuvers: np.ndarray | None = None,
                    max_lag: int = 50) -> np.ndarray:
    """Normalised residual autocorrelation at lags 0..max_lag (within maneuvers)."""
    e = np.asarray(residual, dtype=float)
    e = e - e.mean()
    m = np.zeros(len(e), dtype=int) if maneuvers is None else np.asarray(maneuvers)
    var = float(np.dot(e, e))
    out = np.zeros(max_lag + 1)
    if var == 0.0:
        out[0] = 1.0
        return out
    same = np.ones(len(e), dtype=bool)
    for lag in range(max_lag + 1):
        if lag:
            same = m[lag:] == m[:-lag]
            out[lag] = float(np.dot(e[lag:][same], e[:-lag][same])) / var
        else:
            out[0] = 1.0
    return out


def scores(measured: np.ndarray, model: np.ndarray, *, truth: np.ndarray | None = None,
           maneuvers: np.ndarray | None = None, max_lag: int = 50) -> dict:
    """Validation scores of a model output against measurements (and the truth).

    Parameters
    ----------
    measured, model : ndarray, shape (N,)
        Measured coefficient and model prediction.
    truth : ndarray, shape (N,), optional
        True coefficient (simulated data).
    maneuvers : ndarray, shape (N,), optional
        For the residual autocorrelation (lags do not cross maneuvers).

    Returns
    -------
    dict
        ``n``, ``rms``, ``rrms`` (RMS / range of the measured coefficient, a fraction),
        ``r2``, ``bias``, ``max_abs``, ``autocorrelation`` (list, lags 0..max_lag),
        ``whiteness`` (fraction of lags 1..max_lag inside the 95 % band); with ``truth``
        also ``rms_true``, ``rrms_true`` (model vs truth), ``noise_rms`` (measured vs truth)
        and ``rms_true_over_noise``.
    """
    y = np.asarray(measured, dtype=float)
    yhat = np.asarray(model, dtype=float)
    if y.shape != yhat.shape or y.ndim != 1:
        raise InputError(f"measured and model must be 1-D of equal length, got {y.shape} and "
                         f"{yhat.shape}")
    if len(y) == 0:
        raise InputError("no validation samples: the validation set is empty")
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(yhat))):
        raise InputError("NaN or inf in the measured or modelled values")
    e = y - yhat
    rng = float(y.max() - y.min())
    rms = float(np.sqrt(np.mean(e * e)))
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    ac = autocorrelation(e, maneuvers, max_lag)
    band = 1.96 / np.sqrt(len(e))
    out = {
        "n": len(y), "rms": rms, "rrms": rms / rng if rng > 0 else float("nan"),
        "r2": 1.0 - float(np.sum(e * e)) / ss_tot if ss_tot > 0 else float("nan"),
        "bias": float(e.mean()), "max_abs": float(np.abs(e).max()), "range": rng,
        "autocorrelation": ac.tolist(),
        "whiteness": float(np.mean(np.abs(ac[1:]) < band)) if max_lag else 1.0,
    }
    if truth is not None:
        t = np.asarray(truth, dtype=float)
        if t.shape != y.shape:
            raise InputError("truth must have the shape of measured")
        et = t - yhat
        rms_t = float(np.sqrt(np.mean(et * et)))
        noise = float(np.sqrt(np.mean((y - t) ** 2)))
        out.update(rms_true=rms_t, rrms_true=rms_t / rng if rng > 0 else float("nan"),
                   noise_rms=noise,
                   rms_true_over_noise=rms_t / noise if noise > 0 else float("inf"))
    return out
