"""Deprecated import path: use :mod:`simplexspline.spline.uncertainty.intervals`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.spline.uncertainty.intervals",
    ['FORMAT', 'VERSION', 'ARRAYS', 'KINDS', 'COVARIANCES', 'DENSE_LIMIT', 'CHUNK_BYTES', 'POINT_CHUNK', 'BASIS_BYTES', 'Uncertainty'])
