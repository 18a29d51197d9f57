"""Deprecated import path: use :mod:`simplexspline.aero.data.flight_data`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.aero.data.flight_data",
    ['SCHEMA_VERSION', 'FlightDataWarning', 'ColumnSpec', 'FLIGHT_DATA_COLUMNS', 'REQUIRED_COLUMNS', 'REQUIRED_METADATA', 'NanGap', 'FlightDataReport', 'validate_flight_data', 'sidecar_path', 'write_flight_data', 'read_flight_data'])
