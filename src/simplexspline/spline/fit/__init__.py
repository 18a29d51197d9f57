"""Fitting B-coefficients: normal-equation blocks, the constrained solve, penalties.

:mod:`~simplexspline.spline.fit.normal_equations` accumulates per-simplex blocks chunk by
chunk; :mod:`~simplexspline.spline.fit.constrained` solves the equality-constrained least
squares problem of Eq. 38-42 with the sparse Cholesky of
:mod:`~simplexspline.spline.fit.cholesky`; :mod:`~simplexspline.spline.fit.penalty` and
:mod:`~simplexspline.spline.fit.gcv` add smoothness penalties and their weight by GCV.
"""

from simplexspline.spline.fit.constrained import SolveInfo, solve_constrained
from simplexspline.spline.fit.normal_equations import BlockSums, NormalEquations

__all__ = ["BlockSums", "NormalEquations", "SolveInfo", "solve_constrained"]
