"""The shared vocabulary of the aero layer: coefficient and variable names, units, radians.

Every aero module takes these names from here, so that the flight-data schema, the model
structures, the selection and the report speak of the same columns in the same units
(SI inside the project, radians everywhere; conversions happen at the boundaries).
"""

from __future__ import annotations

import math

__all__ = ["CANDIDATE_VARIABLES", "COEFFICIENTS", "DEG", "ENVELOPE_VARIABLES", "FLOW_ANGLES",
           "LATERAL_COEFFICIENTS", "LATERAL_VARIABLES", "LONGITUDINAL_COEFFICIENTS",
           "MOTION_VARIABLES", "RATE_NAMES", "RATES_OF_FORCES", "TEST_POINT_VARIABLES",
           "THRUST_VARIABLES", "UNITS"]

#: Radians per degree (multiply a value in degrees by ``DEG`` to get radians).
DEG = math.pi / 180.0

#: The six body-axis force and moment coefficients (Eq. 43-48).
COEFFICIENTS: tuple[str, ...] = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")

#: Non-dimensional body rates p b / 2V, q cbar / 2V, r b / 2V.
RATE_NAMES: tuple[str, ...] = ("phat", "qhat", "rhat")

#: Explanatory variables the automatic structure selection may add (when in the data):
#: the flight state, the controls, the non-dimensional rates and flow-angle rates, the
#: configuration (flaps, gear, speedbrake, trim tab), the mass (the centre of gravity
#: moves with fuel burn) and the thrust coefficient ``tc = T / (qbar S)`` (power effects:
#: a propeller's slipstream over the tail), where the data hold the thrust, or its stand-in
#: from the fuel flow ``tc_ff`` (or the fan speed, ``tc_n1``) where they do not (the thrust
#: then stays in CX).
CANDIDATE_VARIABLES: tuple[str, ...] = ("alpha", "beta", "mach", "phat", "qhat", "rhat",
                                        "de", "da", "dr", "alphadot_hat", "betadot_hat",
                                        "flap", "gear", "speedbrake", "dte", "mass", "tc",
                                        "tc_ff", "tc_n1")

#: The thrust coefficient and its stand-ins (:data:`CANDIDATE_VARIABLES`). The power plant
#: need not share the airframe's mirror symmetry: a propeller's torque rolls the aircraft
#: and its swirl and p-factor yaw it, in proportion to the power. The structure search
#: offers them to the lateral coefficients too
#: (:func:`~simplexspline.aero.modelling.auto.candidate_terms`).
THRUST_VARIABLES: tuple[str, ...] = ("tc", "tc_ff", "tc_n1")

#: The flow-angle rates and the force coefficients that make them. By the equations of
#: motion ``alpha' = (u w' - w u') / (u^2 + w^2)`` holds ``X/m`` and ``Z/m`` (``w' = Z/m +
#: g cos(theta) cos(phi) + q u - p v``), and ``beta'`` holds ``Y/m``: offered to those
#: coefficients, a flow-angle rate is a noisy copy of the coefficient itself. On a
#: still-air Cessna course the search took CZ(mach | 1, qhat, de, alphadot_hat) S^1_3,
#: without alpha (with alpha' = q + Z/(m V) + ..., alpha, qhat and de carry nothing
#: alphadot_hat does not): validation R^2 0.998, and a lift-curve slope of 0. The structure
#: search does not offer them to these coefficients (a structure given with them keeps
#: them); the moments keep them (the downwash lag of Cm).
RATES_OF_FORCES: dict[str, tuple[str, ...]] = {"alphadot_hat": ("CX", "CZ"),
                                               "betadot_hat": ("CY",)}

#: The longitudinal coefficients and the lateral-directional ones. An aircraft is (close
#: to) mirror-symmetric about its x-z plane, so its longitudinal coefficients are even
#: functions of the lateral-directional variables and its lateral ones odd functions:
#: general physics, not knowledge of one aircraft.
LONGITUDINAL_COEFFICIENTS: tuple[str, ...] = ("CX", "CZ", "Cm")
LATERAL_COEFFICIENTS: tuple[str, ...] = ("CY", "Cl", "Cn")

#: The flow angle each coefficient is first a function of: the angle of attack for the
#: longitudinal ones, the sideslip for the lateral ones. A model without it whose
#: variables the data cannot tell from it has an unidentified derivative along it, not a
#: zero one, and says so (:func:`~simplexspline.aero.identify.identify`, collinearity).
FLOW_ANGLES: dict[str, str] = {"CX": "alpha", "CZ": "alpha", "Cm": "alpha",
                               "CY": "beta", "Cl": "beta", "Cn": "beta"}

#: The lateral-directional variables (sign changes under the mirror symmetry).
LATERAL_VARIABLES: tuple[str, ...] = ("beta", "phat", "rhat", "da", "dr", "betadot_hat")

#: Variables that describe where in the flight envelope a sample lies: the coverage of the
#: identification data is judged in them (:mod:`simplexspline.aero.selection.coverage`).
ENVELOPE_VARIABLES: tuple[str, ...] = ("alpha", "beta", "mach")

#: The motions a maneuver makes: body rates and control deflections. A validation
#: maneuver is held out only where the identification data make the same motions
#: (:func:`~simplexspline.aero.selection.validation.split_by_maneuver`, ``motion``).
MOTION_VARIABLES: tuple[str, ...] = ("p", "q", "r", "de", "da", "dr")

#: Candidate variables that hold (about) still within a maneuver and change between them:
#: the mass as fuel burns and the configuration set per test point. A validation maneuver
#: is held out only inside their identification range
#: (:func:`~simplexspline.aero.selection.validation.split_by_maneuver`, ``ranges``).
TEST_POINT_VARIABLES: tuple[str, ...] = ("mass", "flap", "gear", "speedbrake", "dte")

#: Units of the variables and coefficients (SI, radians).
UNITS = {
    "alpha": "rad", "beta": "rad", "mach": "-", "tas": "m/s", "h": "m", "rho": "kg/m^3",
    "p": "rad/s", "q": "rad/s", "r": "rad/s", "phat": "- (p b / 2V)",
    "qhat": "- (q cbar / 2V)", "rhat": "- (r b / 2V)", "de": "rad", "da": "rad", "dr": "rad",
    "dte": "rad", "flap": "rad", "speedbrake": "rad", "gear": "-",
    "phi": "rad", "theta": "rad", "alphadot_hat": "- (alpha' cbar / 2V)",
    "betadot_hat": "- (beta' b / 2V)", "mass": "kg", "tc": "- (T / (qbar S))",
    "tc_ff": "- (fuel_flow * 4e4 m/s / (qbar S))", "tc_n1": "- ((n1 a0 / V)^2)",
    "pdot": "rad/s^2", "qdot": "rad/s^2", "rdot": "rad/s^2",
    **{c: "-" for c in COEFFICIENTS},
}
