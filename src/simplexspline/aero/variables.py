"""The shared vocabulary of the aero layer: coefficient and variable names, units, radians.

Every aero module takes these names from here, so that the flight-data schema, the model
structures, the selection and the report speak of the same columns in the same units
(SI inside the project, radians everywhere; conversions happen at the boundaries).
"""

from __future__ import annotations

import math

__all__ = ["CANDIDATE_VARIABLES", "COEFFICIENTS", "DEG", "RATE_NAMES", "UNITS"]

#: Radians per degree (multiply a value in degrees by ``DEG`` to get radians).
DEG = math.pi / 180.0

#: The six body-axis force and moment coefficients (Eq. 43-48).
COEFFICIENTS: tuple[str, ...] = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")

#: Non-dimensional body rates p b / 2V, q cbar / 2V, r b / 2V.
RATE_NAMES: tuple[str, ...] = ("phat", "qhat", "rhat")

#: Explanatory variables the automatic structure selection may add (when in the data).
CANDIDATE_VARIABLES: tuple[str, ...] = ("alpha", "beta", "mach", "phat", "qhat", "rhat",
                                        "de", "da", "dr")

#: Units of the variables and coefficients (SI, radians).
UNITS = {
    "alpha": "rad", "beta": "rad", "mach": "-", "tas": "m/s", "h": "m", "rho": "kg/m^3",
    "p": "rad/s", "q": "rad/s", "r": "rad/s", "phat": "- (p b / 2V)",
    "qhat": "- (q cbar / 2V)", "rhat": "- (r b / 2V)", "de": "rad", "da": "rad", "dr": "rad",
    "dte": "rad", "flap": "rad", "speedbrake": "rad", "gear": "-",
    "phi": "rad", "theta": "rad", "pdot": "rad/s^2", "qdot": "rad/s^2", "rdot": "rad/s^2",
    **{c: "-" for c in COEFFICIENTS},
}
