"""Stability and control derivatives from the exact gradients of identified models.

:mod:`~simplexspline.aero.derivatives.stability` (tables of derivatives at conditions) and
:mod:`~simplexspline.aero.derivatives.plots` (lines along a variable, maps over two).
"""

from simplexspline.aero.derivatives.plots import plot_derivative_map, plot_derivatives
from simplexspline.aero.derivatives.stability import (
    RATE_CONVENTIONS,
    condition_grid,
    derivative_name,
    derivative_unit,
    derivatives,
    load_models,
    long_table,
    reference_conditions,
)

__all__ = [
    "RATE_CONVENTIONS",
    "condition_grid",
    "derivative_name",
    "derivative_unit",
    "derivatives",
    "load_models",
    "long_table",
    "plot_derivative_map",
    "plot_derivatives",
    "reference_conditions",
]
