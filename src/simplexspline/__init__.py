"""simplexspline: multivariate simplex splines for global nonlinear aerodynamic models.

The spline layer (:mod:`simplexspline.spline`) is pure mathematics: triangulations of
n-dimensional space, the B-form of polynomials on simplices, C^r continuity conditions and
the equality-constrained least-squares estimator. The aero layer builds the identification
method of de Visser, Mulder and Chu (AIAA 2010-7950) on top of it.
"""

from __future__ import annotations

from simplexspline._version import __version__

#: Where each public name lives. The package imports them on first use (PEP 562), so that
#: ``import simplexspline`` (and the ``simplexspline`` command's launcher) costs
#: milliseconds, not the two seconds of numpy, scipy and the spline kernels: a Ctrl-C in
#: that time is then caught by the launcher, never a traceback.
_HOMES = {
    **dict.fromkeys(("DegenerateSimplexError", "FlightDataError", "InputError",
                     "InsufficientDataError", "ModelFileError", "OutsideDomainError",
                     "SimplexSplineError", "SimulationError", "TriangulationError"),
                    "simplexspline.errors"),
    **dict.fromkeys(("Facets", "NormalEquations", "SimplexSpline", "SplineSpace",
                     "Triangulation", "basis_values", "bnet_points", "de_casteljau",
                     "multi_indices", "num_basis", "smoothness_matrix"),
                    "simplexspline.spline"),
    # scikit-learn (optional) costs about a second more
    "SimplexSplineRegressor": "simplexspline.estimator",
}

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
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'simplexspline' has no attribute {name!r}")
    value = getattr(__import__(home, fromlist=[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
