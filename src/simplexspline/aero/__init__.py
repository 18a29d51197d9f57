"""The identification method of de Visser, Mulder and Chu on top of the spline layer.

The flight-data schema (:mod:`simplexspline.aero.data.flight_data`), the import of real
flight-test records (:func:`import_record`, docs/import.md), flight path reconstruction
(:mod:`simplexspline.aero.reconstruction.reconstruct`, IEKF + RTS smoother), the aerodynamic
coefficients of Eq. 43-48 (:mod:`simplexspline.aero.data.coefficients`), model structures and
their automatic selection (:mod:`~simplexspline.aero.modelling.structure`,
:mod:`~simplexspline.aero.selection.search`), validation (:mod:`~simplexspline.aero.selection.validation`),
the whole pipeline (:func:`identify`, docs/identification.md) and its report
(:mod:`~simplexspline.aero.report.page`).
"""

from __future__ import annotations

from simplexspline.aero.data.coefficients import aerodynamic_coefficients, angular_accelerations
from simplexspline.aero.config import load_config, parse_structure
from simplexspline.aero.derivatives.stability import (
    condition_grid,
    derivatives,
    load_models,
    reference_conditions,
)
from simplexspline.aero.derivatives.plots import plot_derivative_map, plot_derivatives
from simplexspline.aero.data.differentiation import midpoint_derivative
from simplexspline.aero.data.mapping import read_mapping
from simplexspline.aero.data.record_import import ImportResult, import_record
from simplexspline.aero.data.flight_data import (
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
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.aero.reconstruction.reconstruct import (
    Reconstruction,
    ReconstructionSettings,
    innovation_statistics,
    reconstruct,
)
from simplexspline.aero.selection.search import SelectionSettings, select_structure
from simplexspline.aero.modelling.presets import preset
from simplexspline.aero.modelling.structure import Scaling, Structure
from simplexspline.aero.selection.validation import scores, split_by_maneuver, validation_split

__all__ = [
    "FLIGHT_DATA_COLUMNS",
    "REQUIRED_COLUMNS",
    "SCHEMA_VERSION",
    "AeroModel",
    "FlightDataReport",
    "FlightDataWarning",
    "Identification",
    "IdentificationSettings",
    "ImportResult",
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
    "import_record",
    "innovation_statistics",
    "load_config",
    "midpoint_derivative",
    "parse_structure",
    "preset",
    "read_flight_data",
    "read_mapping",
    "reconstruct",
    "scores",
    "select_structure",
    "split_by_maneuver",
    "validate_flight_data",
    "validation_split",
    "write_flight_data",
]
