"""The scikit-learn compatible regressor :class:`SimplexSplineRegressor`.

:mod:`~simplexspline.estimator.regressor` (the estimator), its scikit-learn compatibility
layer (:mod:`~simplexspline.estimator.compat`) and its per-output solve
(:mod:`~simplexspline.estimator.solve`).
"""

from simplexspline.estimator.regressor import NotFittedError, SimplexSplineRegressor

__all__ = ["NotFittedError", "SimplexSplineRegressor"]
