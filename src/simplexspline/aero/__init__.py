"""The identification method of de Visser, Mulder and Chu on top of the spline layer.

The flight-data schema (:mod:`simplexspline.aero.flightdata`), flight path reconstruction
(:mod:`simplexspline.aero.reconstruction`, IEKF + RTS smoother), the aerodynamic
coefficients of Eq. 43-48 (:mod:`simplexspline.aero.coefficients`), model structures and
their automatic selection (:mod:`~simplexspline.aero.structure`,
:mod:`~simplexspline.aero.selection`), validation (:mod:`~simplexspline.aero.validation`),
the whole pipeline (:func:`identify`, docs/identification.md) and its report
(:mod:`~simplexspline.aero.report`).
"""

from __future__ import annotations

from simplexspline.aero.coefficients import aerodynamic_coefficients, angular_accelerations
from simplexspline.aero.config import load_config, parse_structure
from simplexspline.aero.derivatives import (
    condition_grid,
    derivatives,
    load_models,
    plot_derivative_map,
    plot_derivatives,
    reference_conditions,
)
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
from simplexspline.aero.identify import (
    Identification,
    IdentificationSettings,
    ThinDataWarning,
    identify,
)
from simplexspline.aero.model import AeroModel
from simplexspline.aero.reconstruction import (
    Reconstruction,
    ReconstructionSettings,
    innovation_statistics,
    reconstruct,
)
from simplexspline.aero.selection import SelectionSettings, select_structure
from simplexspline.aero.structure import Scaling, Structure, preset
from simplexspline.aero.validation import scores, split_by_maneuver

__all__ = [
    "FLIGHT_DATA_COLUMNS",
    "REQUIRED_COLUMNS",
    "SCHEMA_VERSION",
    "AeroModel",
    "FlightDataReport",
    "FlightDataWarning",
    "Identification",
    "IdentificationSettings",
    "Reconstruction",
    "ReconstructionSettings",
    "Scaling",
    "SelectionSettings",
    "Structure",
    "ThinDataWarning",
    "aerodynamic_coefficients",
    "condition_grid",
    "derivatives",
    "load_models",
    "plot_derivative_map",
    "plot_derivatives",
    "reference_conditions",
    "angular_accelerations",
    "identify",
    "innovation_statistics",
    "load_config",
    "midpoint_derivative",
    "parse_structure",
    "preset",
    "read_flight_data",
    "reconstruct",
    "scores",
    "select_structure",
    "split_by_maneuver",
    "validate_flight_data",
    "write_flight_data",
]
