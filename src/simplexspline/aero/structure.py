"""Deprecated import path: use :mod:`simplexspline.aero.modelling.structure`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.aero.modelling.structure",
    ['Structure', 'multiplier_values', 'multiplier_jacobian', 'structures_from_config',
     'KNOT_MARGIN', 'Scaling'],
    elsewhere={"preset": "simplexspline.aero.modelling.presets",
               "COEFFICIENTS": "simplexspline.aero.variables",
               "CANDIDATE_VARIABLES": "simplexspline.aero.variables",
               "UNITS": "simplexspline.aero.variables"})
