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

Without the thrust (no thrust columns, no thrust model: the thrust stays in CX, as in the
paper) a record usually still holds the engines' fuel flow, and the force the model must
then explain varies with it from one test point to the next. The fuel-flow thrust
coefficient ``tc_ff = fuel_flow * V_ff / (qbar S)`` stands in for ``tc``: the thrust a fuel
flow would give at a fixed specific thrust ``V_ff`` (:data:`SPECIFIC_THRUST`), over the
dynamic pressure. Only its shape matters: the model multiplies it by fitted coefficients
that may vary with the flight state (a jet's thrust per fuel flow grows with Mach, a
propeller's falls with airspeed), so any constant ``V_ff`` gives the same fit.

A record with the fan speed N1 gets ``tc_n1 = (n1 a0 / tas)^2`` (``a0`` the sea-level
speed of sound): a turbofan's corrected thrust ``F / delta`` grows about as the square of
its corrected fan speed ``N1 / sqrt(theta)``, and with ``qbar = 0.7 p M^2`` and
``theta M^2 = (tas / a0)^2`` that makes ``T / (qbar S)`` proportional to it. Again only
its shape matters.

A record with both gets both, and the search takes what the data support: which of the
two follows an engine's thrust better is the engine's, not a rule's. On a simulated T-37
course (``bench_whole_flight.py --aircraft T37 --design eigenmotion --turns --maneuvers 12
--seed 61 --turbulence light``) the fuel flow hardly moved between test points
(0.108-0.115 kg/s) while N1 did: a least-squares fit of the true CX (thrust included) on
alpha, alpha^2, de, qhat, Mach and beta^2 left 6.3e-3 RMS, 6.1e-3 with ``tc_ff``, 1.0e-3
with ``tc_n1`` (the coefficient's noise: 9.9e-4). Offered only ``tc_ff`` (the rule before
stop 60), identify's CX scored validation R^2 0.24 there (4.5x the noise against the
truth); offered both, 0.93 (1.0x).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

__all__ = ["FAN_SPEED_THRUST_COEFFICIENT", "FUEL_FLOW_THRUST_COEFFICIENT", "SPECIFIC_THRUST",
           "THRUST_COEFFICIENT", "thrust_coefficient"]

#: Name of the column :func:`thrust_coefficient` adds from the thrust.
THRUST_COEFFICIENT = "tc"
#: Name of the column it adds from the fuel flow when the data hold no thrust.
FUEL_FLOW_THRUST_COEFFICIENT = "tc_ff"
#: Thrust per fuel flow [N/(kg/s) = m/s] that scales ``tc_ff`` to the size of ``tc``: a
#: turbofan's order of magnitude (TSFC 0.9 lb/(lbf h)). A scale only: it changes no fit.
SPECIFIC_THRUST = 4.0e4
#: Name of the column it adds from the fan speed when the data hold no thrust and no fuel
#: flow.
FAN_SPEED_THRUST_COEFFICIENT = "tc_n1"
#: Sea-level speed of sound of the ISA [m/s].
_A0 = 340.294


def thrust_coefficient(df, metadata: Mapping) -> dict[str, np.ndarray]:
    """The thrust coefficient, or its stand-in from the fuel flow or the fan speed when the
    data hold no thrust.

    Parameters
    ----------
    df : pandas.DataFrame
        Flight data in the schema with ``rho`` [kg/m^3], ``tas`` [m/s] and ``thrust_x``
        [N] (measured, simulated or from a
        :class:`~simplexspline.aero.data.thrust.ThrustModel`) or, failing that,
        ``fuel_flow`` [kg/s], or ``n1`` [-].
    metadata : mapping
        ``S`` [m^2], the wing area.

    Returns
    -------
    dict of str to ndarray, shape (N,)
        ``{'tc': thrust_x / (0.5 rho tas^2 S)}`` [-] when the thrust is there (not all
        NaN); else ``'tc_ff': fuel_flow * SPECIFIC_THRUST / (0.5 rho tas^2 S)`` [-]
        when the fuel flow is, and ``'tc_n1': (n1 * 340.294 / tas)^2`` [-] when the
        fan speed is (which needs neither ``rho`` nor ``S``), both when both are; else
        empty (also when ``tas``, or ``S`` or ``rho`` for the first two, is missing).

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"thrust_x": [2000.0], "rho": [1.0], "tas": [40.0]})
    >>> thrust_coefficient(df, {"S": 16.0})["tc"].round(4)
    array([0.1562])
    >>> df = pd.DataFrame({"fuel_flow": [0.05], "rho": [1.0], "tas": [40.0]})
    >>> thrust_coefficient(df, {"S": 16.0})["tc_ff"].round(4)
    array([0.1562])
    >>> df = pd.DataFrame({"n1": [0.8], "rho": [1.0], "tas": [200.0]})
    >>> thrust_coefficient(df, {"S": 16.0})["tc_n1"].round(4)
    array([1.8528])
    """
    if "tas" not in df.columns:
        return {}
    tas = df["tas"].to_numpy(dtype=float)

    def per_qbar_s(column: str, scale: float):
        """``column * scale / (qbar S)``, or None (no such data, or no rho or S)."""
        if column not in df.columns or "rho" not in df.columns or "S" not in metadata:
            return None
        force = df[column].to_numpy(dtype=float) * scale
        if not np.isfinite(force).any():
            return None
        qbar = 0.5 * df["rho"].to_numpy(dtype=float) * tas ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            return force / (qbar * float(metadata["S"]))

    tc = per_qbar_s("thrust_x", 1.0)
    if tc is not None:
        return {THRUST_COEFFICIENT: tc}           # the thrust itself: no stand-in
    out = {}
    tc_ff = per_qbar_s("fuel_flow", SPECIFIC_THRUST)
    if tc_ff is not None:
        out[FUEL_FLOW_THRUST_COEFFICIENT] = tc_ff
    if "n1" in df.columns:
        n1 = df["n1"].to_numpy(dtype=float)
        if np.isfinite(n1).any():
            with np.errstate(divide="ignore", invalid="ignore"):
                out[FAN_SPEED_THRUST_COEFFICIENT] = (n1 * _A0 / tas) ** 2
    return out
