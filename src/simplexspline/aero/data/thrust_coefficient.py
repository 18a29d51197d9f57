"""The thrust coefficient ``tc = thrust_x / (qbar S)``: how strongly the engines blow.

A propeller's slipstream raises the dynamic pressure over the tail and the wing behind it,
so the elevator's and the rudder's effectiveness (and the wing's lift and drag there) grow
with power: at a given flight state a pitching moment per degree of elevator is larger at
full throttle than gliding. The standard non-dimensional measure of power in flight-test
identification of propeller aircraft is the thrust coefficient ``T / (qbar S)`` (e.g. Klein
and Morelli, *Aircraft System Identification*, 2006); on jets it is a harmless candidate
that the cross-validation leaves out. It is offered to the structure search as a candidate
variable (a multiplier, or a scheduling variable so that a control's effect may vary with
it), never imposed.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

__all__ = ["THRUST_COEFFICIENT", "thrust_coefficient"]

#: Name of the column :func:`thrust_coefficient` adds.
THRUST_COEFFICIENT = "tc"


def thrust_coefficient(df, metadata: Mapping) -> dict[str, np.ndarray]:
    """The thrust coefficient, when the data hold the thrust.

    Parameters
    ----------
    df : pandas.DataFrame
        Flight data in the schema with ``thrust_x`` [N] (measured, simulated or from a
        :class:`~simplexspline.aero.data.thrust.ThrustModel`), ``rho`` [kg/m^3] and
        ``tas`` [m/s].
    metadata : mapping
        ``S`` [m^2], the wing area.

    Returns
    -------
    dict of str to ndarray, shape (N,)
        ``{'tc': thrust_x / (0.5 rho tas^2 S)}`` [-]; empty when a column or ``S`` is
        missing, or the thrust is all NaN (an aircraft whose record holds no thrust).

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"thrust_x": [2000.0], "rho": [1.0], "tas": [40.0]})
    >>> thrust_coefficient(df, {"S": 16.0})["tc"].round(4)
    array([0.1562])
    """
    if "S" not in metadata or any(c not in df.columns for c in ("thrust_x", "rho", "tas")):
        return {}
    thrust = df["thrust_x"].to_numpy(dtype=float)
    if not np.isfinite(thrust).any():
        return {}
    qbar = 0.5 * df["rho"].to_numpy(dtype=float) * df["tas"].to_numpy(dtype=float) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        return {THRUST_COEFFICIENT: thrust / (qbar * float(metadata["S"]))}
