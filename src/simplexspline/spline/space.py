"""The spline space S^r_d(T): a triangulation, a degree and a continuity order."""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse as sp

from simplexspline.errors import InputError, OutsideDomainError
from simplexspline.spline.bform import basis_values, num_basis
from simplexspline.spline.continuity import (
    SmoothnessSystem,
    build_conditions,
    conditions_per_facet,
    reduce_rows,
)
from simplexspline.spline.fit.normal_equations import NormalEquations
from simplexspline.spline.fit.constrained import solve_constrained
from simplexspline.spline.inputs import as_points, check_degree

__all__ = ["SplineSpace"]


class SplineSpace:
    """The space S^r_d(T) of C^r splines of degree d on a triangulation T (paper Eq. 7).

    Holds what does not depend on the data (the smoothness matrix and its reduction), so
    fitting many outputs on one space pays for it once.

    Parameters
    ----------
    triangulation : Triangulation
    degree : int
        Polynomial degree d >= 0.
    continuity : int
        Continuity order r, ``-1 <= r < d`` (-1: pieces independent).
    facet_continuity : array_like of int, shape (F,), optional
        A continuity order per interior facet (``triangulation.facets`` order), each
        between ``continuity`` and ``d``; ``d`` across a facet makes its two pieces one
        polynomial. :func:`~simplexspline.spline.continuity.cell_facets` finds the facets
        inside the cells of a grid triangulation: with ``d`` there, the spline is one
        polynomial per grid cell, joined C^r across the grid planes.

    Examples
    --------
    >>> import numpy as np
    >>> from simplexspline import Triangulation, SplineSpace
    >>> rng = np.random.default_rng(0)
    >>> x = rng.random((2000, 2))
    >>> space = SplineSpace(Triangulation.grid([0, 0], [1, 1], (3, 3)), degree=3, continuity=1)
    >>> spline = space.fit(x, np.sin(3 * x[:, 0]) * x[:, 1])
    >>> bool(abs(spline.predict([[0.5, 0.5]])[0] - np.sin(1.5) * 0.5) < 1e-3)
    True
    """

    def __init__(self, triangulation, degree: int, continuity: int, facet_continuity=None):
        self.triangulation = triangulation
        self.degree, self.continuity = check_degree(degree, continuity)
        self.facet_continuity = None
        if facet_continuity is not None:
            fc = np.asarray(facet_continuity)
            nf = len(triangulation.facets)
            if fc.shape != (nf,) or not np.issubdtype(fc.dtype, np.integer):
                raise InputError(f"facet_continuity must be {nf} integers (one per interior "
                                 f"facet), got shape {fc.shape} of {fc.dtype}")
            if nf and (fc.min() < self.continuity or fc.max() > self.degree):
                raise InputError(f"facet_continuity must lie between the continuity "
                                 f"{self.continuity} and the degree {self.degree}, got "
                                 f"{int(fc.min())}..{int(fc.max())}")
            self.facet_continuity = fc.astype(np.int64)

    def __repr__(self) -> str:
        mixed = "" if self.facet_continuity is None else ", mixed facet continuity"
        return (f"SplineSpace(S^{self.continuity}_{self.degree}, ndim={self.ndim}, "
                f"nsimplex={self.triangulation.nsimplex}{mixed})")

    @property
    def ndim(self) -> int:
        """Spatial dimension n."""
        return self.triangulation.ndim

    @property
    def nbasis(self) -> int:
        """B-coefficients per simplex, d_hat (Eq. 12)."""
        return num_basis(self.ndim, self.degree)

    @property
    def dim_coefficients(self) -> int:
        """Length J * d_hat of the global coefficient vector (Eq. 24)."""
        return self.triangulation.nsimplex * self.nbasis

    @property
    def conditions_per_facet(self) -> int:
        """R of Eq. 22."""
        return conditions_per_facet(self.ndim, self.degree, self.continuity)

    @cached_property
    def system(self) -> SmoothnessSystem:
        """The reduced smoothness system (built on first use, then cached)."""
        cond = build_conditions(self.triangulation, self.degree, self.continuity,
                                self.facet_continuity)
        return reduce_rows(cond, self.dim_coefficients)

    @property
    def H(self) -> sp.csr_matrix:
        """Smoothness matrix with full row rank (Eq. 23, 25), shape (R*, J*d_hat)."""
        return self.system.H

    @property
    def H_full(self) -> sp.csr_matrix:
        """All continuity conditions (Eq. 20-22), shape (E*R, J*d_hat)."""
        return self.system.H_full

    @property
    def dimension(self) -> int:
        """Dimension of the spline space: J*d_hat - rank(H)."""
        return self.dim_coefficients - self.system.rank

    def design_matrix(self, x) -> sp.csr_matrix:
        """The regression matrix X of Eq. 36 as a sparse matrix, shape (N, J*d_hat).

        Each row holds the d_hat basis values of its point's simplex. Meant for
        inspection and small problems; fitting never forms it.
        """
        tri = self.triangulation
        pts = as_points(x, name="x", ndim=tri.ndim)
        sid = tri.locate(pts)
        out = np.nonzero(sid < 0)[0]
        if len(out):
            raise OutsideDomainError(
                f"{len(out)} points lie outside the triangulation (first rows: "
                f"{out[:5].tolist()})", out)
        B = basis_values(tri._locator_barycentric(pts, sid), self.degree)
        dhat = self.nbasis
        cols = sid[:, None] * dhat + np.arange(dhat)[None, :]
        rows = np.repeat(np.arange(len(pts)), dhat)
        return sp.csr_matrix((B.ravel(), (rows, cols.ravel())),
                             shape=(len(pts), self.dim_coefficients))

    def normal_equations(self, x=None, y=None, weights=None) -> NormalEquations:
        """A normal-equation accumulator, optionally filled with a first chunk of data."""
        ne = NormalEquations(self.triangulation, self.degree)
        if x is not None:
            ne.add(x, y, weights)
        return ne

    def solve(self, normal_equations: NormalEquations, *, on_insufficient: str = "raise",
              ridge: float | None = None, smoothing=None, penalty="energy"):
        """Solve for the B-coefficients from accumulated normal equations.

        See :meth:`fit` for the parameters.

        Returns
        -------
        SimplexSpline
        """
        from simplexspline.spline.function import SimplexSpline

        if not isinstance(normal_equations, NormalEquations):
            raise InputError("solve() takes a NormalEquations accumulator "
                             "(from SplineSpace.normal_equations)")
        normal_equations.check_space(self.triangulation, self.degree)
        if smoothing is None:
            coef, info = solve_constrained(normal_equations, self.system,
                                           on_insufficient=on_insufficient, ridge=ridge)
        else:
            from simplexspline.spline.fit.penalty import solve_penalized

            coef, info = solve_penalized(normal_equations, self.system, penalty=penalty,
                                         smoothing=smoothing,
                                         on_insufficient=on_insufficient, ridge=ridge)
        return SimplexSpline(self.triangulation, self.degree, self.continuity, coef,
                             space=self, info=info)

    def fit(self, x, y, weights=None, *, on_insufficient: str = "raise",
            ridge: float | None = None, smoothing=None, penalty="energy"):
        """Fit the spline to scattered data by equality-constrained least squares.

        Parameters
        ----------
        x : array_like, shape (N, n)
            Data locations; all inside the triangulation.
        y : array_like, shape (N,)
            Observations.
        weights : array_like, shape (N,), optional
            Non-negative sample weights (inverse noise variances; Eq. 38 with a diagonal
            covariance). A zero weight removes the sample's influence.
        on_insufficient : {'raise', 'minnorm', 'ridge'}, default 'raise'
            What to do where data and continuity do not determine the coefficients: raise
            :class:`~simplexspline.InsufficientDataError` naming the simplices and their
            point counts; take the minimum-norm coefficients (exact); or regularise with a
            small ridge.
        ridge : float, optional
            Relative ridge weight (default 1e-6 with ``'ridge'``).
        smoothing : 'gcv' or float, optional
            Regularise: minimise ``(y-Xc)'W(y-Xc) + lam c'Pc`` under the continuity
            conditions. ``'gcv'`` chooses ``lam`` by generalized cross-validation; a float
            is the relative weight (``lam = smoothing * tr(X'WX) / tr(P)``). ``None`` (the
            default): no penalty. The chosen weight and the effective degrees of freedom
            are in ``spline.info.regularization``. See :mod:`simplexspline.spline.fit.penalty`.
        penalty : {'energy', 'membrane', 'ridge'} or ndarray, default 'energy'
            The penalty P used with ``smoothing``: integrated squared second derivatives
            (thin plate, in the triangulation's coordinates), squared first derivatives,
            or ``c'c``; or custom blocks of shape (J, d_hat, d_hat).

        Returns
        -------
        SimplexSpline
        """
        return self.solve(self.normal_equations(x, y, weights),
                          on_insufficient=on_insufficient, ridge=ridge,
                          smoothing=smoothing, penalty=penalty)
