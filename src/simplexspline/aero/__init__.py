"""The identification method of de Visser, Mulder and Chu on top of the spline layer.

So far: the flight-data schema (:mod:`simplexspline.aero.flightdata`), flight path
reconstruction (:mod:`simplexspline.aero.reconstruction`, IEKF + RTS smoother) and the
aerodynamic coefficients of Eq. 43-48 (:mod:`simplexspline.aero.coefficients`).
"""

from __future__ import annotations

from simplexspline.aero.coefficients import aerodynamic_coefficients, angular_accelerations
from simplexspline.aero.differentiation import midpoint_derivative
from simplexspline.aero.flightdata import (
    FLIGHT_DATA_COLUMNS,
    REQUIRED_COLUMNS,
    SCHEMA_VERSION,
    FlightDataReport,
    FlightDataWarning,
    read_flight_data,
    validate_flight_data,
    write_flight_data,
)
from simplexspline.aero.reconstruction import (
    Reconstruction,
    ReconstructionSettings,
    innovation_statistics,
    reconstruct,
)

__all__ = [
    "FLIGHT_DATA_COLUMNS",
    "REQUIRED_COLUMNS",
    "SCHEMA_VERSION",
    "FlightDataReport",
    "FlightDataWarning",
    "read_flight_data",
    "validate_flight_data",
    "write_flight_data",
    "Reconstruction",
    "ReconstructionSettings",
    "aerodynamic_coefficients",
    "angular_accelerations",
    "innovation_statistics",
    "midpoint_derivative",
    "reconstruct",
]
