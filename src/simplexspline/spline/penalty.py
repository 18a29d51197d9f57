"""Deprecated import path: use :mod:`simplexspline.spline.fit.penalty`.

This module will be removed in simplexspline 0.3.0 (see ``simplexspline._deprecation``).
"""

from simplexspline._deprecation import deprecated_module

__getattr__, __dir__ = deprecated_module(
    __name__, "simplexspline.spline.fit.penalty",
    ['PENALTIES', 'bernstein_gram', 'energy_matrix', 'energy_blocks', 'penalty_blocks', 'solve_penalized'])
