"""Deprecated import path: use :mod:`simplexspline.aero.export.lookup_tables`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.aero.export.lookup_tables",
    ['TABLE_FORMAT', 'TABLE_VERSION', 'MAX_TABLE_POINTS', 'JSBSIM_PROPERTIES', 'parse_grid', 'LookupTable', 'model_variables', 'lookup_table'])
