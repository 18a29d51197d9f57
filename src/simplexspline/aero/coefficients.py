"""Deprecated import path: use :mod:`simplexspline.aero.data.coefficients`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.aero.data.coefficients",
    ['COEFFICIENT_NAMES', 'RATE_NAMES', 'THRUST_COLUMNS', 'angular_accelerations', 'aerodynamic_coefficients'])
