"""The identification method of de Visser, Mulder and Chu on top of the spline layer.

So far: the flight-data schema (:mod:`simplexspline.aero.flightdata`).
"""

from __future__ import annotations

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

__all__ = [
    "FLIGHT_DATA_COLUMNS",
    "REQUIRED_COLUMNS",
    "SCHEMA_VERSION",
    "FlightDataReport",
    "FlightDataWarning",
    "read_flight_data",
    "validate_flight_data",
    "write_flight_data",
]
