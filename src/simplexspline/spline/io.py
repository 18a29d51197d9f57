"""Deprecated import path: use :mod:`simplexspline.spline.formats.model_file`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.spline.formats.model_file",
    ['FORMAT', 'VERSION', 'VARYING_FORMAT', 'STATS_PREFIX', 'save_spline'],
    elsewhere={"load_spline": "simplexspline.spline.formats.loading",
               "atomic_write": "simplexspline._files"})
