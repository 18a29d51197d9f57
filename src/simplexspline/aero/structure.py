"""Deprecated import path: use :mod:`simplexspline.aero.modelling.structure`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.aero.modelling.structure",
    ['preset', 'COEFFICIENTS', 'CANDIDATE_VARIABLES', 'UNITS', 'Structure', 'multiplier_values', 'multiplier_jacobian', 'structures_from_config', 'KNOT_MARGIN', 'Scaling'])
