"""Uncertainty of fitted splines: coefficient covariance, intervals, data coverage.

:mod:`~simplexspline.spline.uncertainty.intervals` (standard errors, confidence and
prediction intervals), :mod:`~simplexspline.spline.uncertainty.covariance` (the covariance
engine of the constrained estimator) and :mod:`~simplexspline.spline.uncertainty.coverage`
(where a spline is supported by data).
"""
