"""The spline layer: pure mathematics of multivariate simplex splines.

Knows nothing about aircraft; the aero layer imports it, never the reverse.
"""

from simplexspline.spline.bform import (
    basis_values,
    bnet_points,
    de_casteljau,
    multi_indices,
    num_basis,
)
from simplexspline.spline.continuity import smoothness_matrix
from simplexspline.spline.fit.normal_equations import NormalEquations
from simplexspline.spline.space import SimplexSpline, SplineSpace
from simplexspline.spline.geometry.triangulation import Facets, Triangulation

__all__ = [
    "Triangulation",
    "Facets",
    "SplineSpace",
    "SimplexSpline",
    "NormalEquations",
    "smoothness_matrix",
    "multi_indices",
    "num_basis",
    "basis_values",
    "de_casteljau",
    "bnet_points",
]
