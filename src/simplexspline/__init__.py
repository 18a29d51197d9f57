"""simplexspline: multivariate simplex splines for global nonlinear aerodynamic models.

The spline layer (:mod:`simplexspline.spline`) is pure mathematics: triangulations of
n-dimensional space, the B-form of polynomials on simplices, C^r continuity conditions and
the equality-constrained least-squares estimator. The aero layer builds the identification
method of de Visser, Mulder and Chu (AIAA 2010-7950) on top of it.
"""

from __future__ import annotations

from simplexspline._version import __version__

from simplexspline.errors import (
    DegenerateSimplexError,
    FlightDataError,
    InputError,
    InsufficientDataError,
    ModelFileError,
    OutsideDomainError,
    SimplexSplineError,
    SimulationError,
    TriangulationError,
)
from simplexspline.spline import (
    Facets,
    NormalEquations,
    SimplexSpline,
    SplineSpace,
    Triangulation,
    basis_values,
    bnet_points,
    de_casteljau,
    multi_indices,
    num_basis,
    smoothness_matrix,
)

__all__ = [
    "__version__",
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
    "SimplexSplineError",
    "InputError",
    "TriangulationError",
    "DegenerateSimplexError",
    "InsufficientDataError",
    "OutsideDomainError",
    "ModelFileError",
    "FlightDataError",
    "SimulationError",
    "SimplexSplineRegressor",
]


def __getattr__(name: str):
    # The scikit-learn estimator is imported on first use: importing scikit-learn (an
    # optional dependency) costs about a second.
    if name == "SimplexSplineRegressor":
        from simplexspline.estimator import SimplexSplineRegressor  # lazy: scikit-learn

        return SimplexSplineRegressor
    raise AttributeError(f"module 'simplexspline' has no attribute {name!r}")
