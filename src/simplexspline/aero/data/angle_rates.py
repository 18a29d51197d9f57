"""Non-dimensional rates of the flow angles: ``alphadot_hat = alpha' cbar / 2V`` and
``betadot_hat = beta' b / 2V``.

They carry the unsteady (downwash-lag and sidewash-lag) terms of the aerodynamic forces and
moments (``CZ_alphadot``, ``Cm_alphadot``, ``Cn_betadot``...), which every aircraft has and
which flight data can separate from ``qhat`` and ``rhat`` only in maneuvers where the flow
angles and the rates are not locked together (e.g. a vertical gust or a 3211 in a turn).
They are *candidates* of the structure search, never imposed.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from simplexspline.aero.data.differentiation import derivative_by_maneuver

__all__ = ["ANGLE_RATE_NAMES", "angle_rates"]

#: The columns :func:`angle_rates` adds, and where each comes from:
#: name -> (flow angle, reference length in the metadata).
ANGLE_RATE_NAMES: dict[str, tuple[str, str]] = {"alphadot_hat": ("alpha", "cbar"),
                                                "betadot_hat": ("beta", "b")}


def angle_rates(df, metadata: Mapping, *, half_window: int | None = None,
                degree: int = 4) -> dict[str, np.ndarray]:
    """The non-dimensional flow-angle rates that the data allow.

    Parameters
    ----------
    df : pandas.DataFrame
        Flight data in the schema: ``maneuver``, ``t``, ``tas`` [m/s] and ``alpha`` and/or
        ``beta`` [rad] (reconstructed data are best: the derivative amplifies noise).
    metadata : mapping
        ``cbar`` and ``b`` [m].
    half_window : int, optional
    degree : int
        Smoothing of the derivative
        (:func:`~simplexspline.aero.data.differentiation.derivative_by_maneuver`; None: the
        default for the data's rate).

    Returns
    -------
    dict of str to ndarray, shape (N,)
        ``alphadot_hat`` when ``alpha`` and ``cbar`` are present, ``betadot_hat`` when
        ``beta`` and ``b`` are (columns that are all NaN count as absent); nothing without
        ``maneuver``, ``t`` and ``tas``. Dimensionless.
    """
    if any(c not in df.columns for c in ("maneuver", "t", "tas")):
        return {}
    man = df["maneuver"].to_numpy()
    t = df["t"].to_numpy(dtype=float)
    tas = df["tas"].to_numpy(dtype=float)
    out = {}
    for name, (angle, length) in ANGLE_RATE_NAMES.items():
        if length not in metadata or angle not in df.columns \
                or not np.isfinite(df[angle].to_numpy(dtype=float)).any():
            continue
        rate = derivative_by_maneuver(man, t, df[angle].to_numpy(dtype=float),
                                      half_window=half_window, degree=degree)
        with np.errstate(divide="ignore", invalid="ignore"):
            out[name] = rate * float(metadata[length]) / (2.0 * tas)
    return out
