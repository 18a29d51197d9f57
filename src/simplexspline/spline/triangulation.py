"""Deprecated import path: use :mod:`simplexspline.spline.geometry.triangulation`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.spline.geometry.triangulation",
    ['SLIVER_THRESHOLD', 'Facets', 'Triangulation'])
