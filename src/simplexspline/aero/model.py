"""Deprecated import path: use :mod:`simplexspline.aero.modelling.model`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.aero.modelling.model",
    ['AERO_FORMAT', 'AERO_VERSION', 'OUTSIDE', 'AeroModel'])
