"""Deprecated import path: use :mod:`simplexspline.aero.selection.validation`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.aero.selection.validation",
    ['CONDITION_KEEP', 'split_by_maneuver', 'fold_by_maneuver', 'covered_in_fold', 'autocorrelation', 'scores'])
