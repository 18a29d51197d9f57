"""Geometry of triangulations: simplices, barycentric coordinates, point location.

:mod:`~simplexspline.spline.geometry.barycentric` (coordinates, volumes, quality),
:mod:`~simplexspline.spline.geometry.location` (grid and bucket point location) and
:mod:`~simplexspline.spline.geometry.triangulation` (construction, validation, facets).
"""

from simplexspline.spline.geometry.triangulation import Facets, Triangulation

__all__ = ["Facets", "Triangulation"]
