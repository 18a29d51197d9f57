"""Spline spaces S^r_d(T) and the splines in them.

:class:`SplineSpace` (a triangulation, a degree and a continuity order: the smoothness
conditions, fitting) and :class:`SimplexSpline` (one member of a space: evaluation, exact
derivatives, statistics, persistence). Each needs the other: a space's fit is a spline, and
a spline's statistics and refits live in its space, so they share one module.
"""

from __future__ import annotations

from functools import cached_property
from math import factorial
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from simplexspline.errors import (
    InputError,
    ModelFileError,
    SimplexSplineError,
)
from simplexspline.spline import kernels
from simplexspline.spline.bform import (
    basis_values,
    basis_values_t,
    de_casteljau_step,
    num_basis,
    step_table,
)
from simplexspline.spline.continuity import (
    SmoothnessSystem,
    build_conditions,
    conditions_per_facet,
    reduce_rows,
)
from simplexspline.spline.fit.constrained import solve_constrained
from simplexspline.spline.fit.normal_equations import NormalEquations
from simplexspline.spline.fit.penalty import solve_penalized
from simplexspline.spline.formats.model_file import ModelRecord, read_model, save_spline
from simplexspline.spline.geometry.barycentric import direction_coordinates
from simplexspline.spline.geometry.outside import (
    SPLINE_POLICIES,
    check_policy,
    locate,
    located_data,
    resolve_outside,
)
from simplexspline.spline.inputs import as_points, check_basis_size, check_degree
from simplexspline.spline.uncertainty.intervals import ARRAYS as STATISTICS_ARRAYS
from simplexspline.spline.uncertainty.intervals import Uncertainty

__all__ = ["MAX_DEGREE", "SimplexSpline", "SplineSpace"]

#: Highest degree a space is fitted at. The B-form's Gram matrix grows ill-conditioned by
#: a factor of about 4 per degree: the Bernstein mass matrix of degree d (the Gram matrix
#: of evenly spread data; 1-D, and 2-D within a factor 2) has condition number 2.2e9 at
#: d = 16, 5.1e11 at d = 20 and 7.9e12 at d = 22 (2-D); Gram blocks of 5,000 random points
#: on a 2 x 2 grid are 10-100 times worse: 3e10-2e11 at d = 16, 4e13-1.3e14 at d = 20,
#: 2e15-8e15 at d = 22 (1/eps = 4.5e15: no coefficient keeps a significant digit) and
#: 3e19 at d = 30, where the minimum-norm solve took minutes and then failed. Measured
#: there with ``on_insufficient='minnorm'`` on a loaded machine: d = 20 13 s, d = 22 58 s.
MAX_DEGREE = 20


class SplineSpace:
    """The space S^r_d(T) of C^r splines of degree d on a triangulation T (paper Eq. 7).

    Holds what does not depend on the data (the smoothness matrix and its reduction), so
    fitting many outputs on one space pays for it once.

    Parameters
    ----------
    triangulation : Triangulation
    degree : int
        Polynomial degree, 0 <= d <= :data:`MAX_DEGREE` (20; above it the B-form is
        numerically hopeless in double precision).
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
        check_basis_size(triangulation.ndim, self.degree)
        if self.degree > MAX_DEGREE:
            raise InputError(
                f"degree {self.degree} is numerically hopeless: the Gram matrices of "
                f"B-form polynomials above degree {MAX_DEGREE} (MAX_DEGREE) have condition "
                "numbers beyond double precision, so no coefficient could be determined; "
                f"use degree <= {MAX_DEGREE} (and refine the triangulation for more "
                "detail)")
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
        sid = located_data(tri, pts)
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
        if not isinstance(normal_equations, NormalEquations):
            raise InputError("solve() takes a NormalEquations accumulator "
                             "(from SplineSpace.normal_equations)")
        normal_equations.check_space(self.triangulation, self.degree)
        if smoothing is None:
            coef, info = solve_constrained(normal_equations, self.system,
                                           on_insufficient=on_insufficient, ridge=ridge)
        else:
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


#: Points evaluated per chunk (bounds temporary memory).
CHUNK = 1 << 16


class SimplexSpline:
    """A spline function in B-form on a triangulation: one polynomial piece per simplex.

    Usually made by :meth:`fit` or :meth:`SplineSpace.fit`; can also be built from
    coefficients.

    Parameters
    ----------
    triangulation : Triangulation
    degree, continuity : int
    coefficients : array_like, shape (J, d_hat)
        B-coefficients per simplex in Eq. 11 order.
    metadata : dict, optional
        Free-form JSON-serialisable information saved with the model (variable names,
        units, provenance).

    Attributes
    ----------
    coefficients : ndarray, shape (J, d_hat)
    info : SolveInfo or None
        Fit diagnostics (per-simplex counts, undetermined simplices, residual sum of
        squares) when the spline was fitted.
    """

    def __init__(self, triangulation, degree: int, continuity: int, coefficients, *,
                 space=None, info=None, metadata: dict | None = None):
        self.triangulation = triangulation
        self.degree, self.continuity = check_degree(degree, continuity)
        check_basis_size(triangulation.ndim, self.degree)
        coef = np.asarray(coefficients, dtype=float)
        shape = (triangulation.nsimplex, num_basis(triangulation.ndim, self.degree))
        if coef.shape != shape:
            raise InputError(f"coefficients must have shape {shape}, got {coef.shape}")
        if not np.all(np.isfinite(coef)):
            raise InputError("coefficients contain NaN or inf")
        self.coefficients = coef
        self._space = space
        self.info = info
        self.metadata = dict(metadata or {})

    # ------------------------------------------------------------------ construction
    @classmethod
    def fit(cls, x, y, triangulation, degree: int = 3, continuity: int = 1, weights=None, *,
            on_insufficient: str = "raise", ridge: float | None = None) -> SimplexSpline:
        """Fit a spline of S^r_d(T) to scattered data (see :meth:`SplineSpace.fit`)."""
        return SplineSpace(triangulation, degree, continuity).fit(
            x, y, weights, on_insufficient=on_insufficient, ridge=ridge)

    @property
    def space(self):
        """The spline space this spline belongs to."""
        if self._space is None:
            self._space = SplineSpace(self.triangulation, self.degree, self.continuity)
        return self._space

    @property
    def ndim(self) -> int:
        """Number of input variables n."""
        return self.triangulation.ndim

    def __repr__(self) -> str:
        return (f"SimplexSpline(S^{self.continuity}_{self.degree}, ndim={self.ndim}, "
                f"nsimplex={self.triangulation.nsimplex})")

    # ------------------------------------------------------------------ evaluation
    def _prepare(self, x, outside: str, simplices):
        tri = self.triangulation
        pts = as_points(x, name="x", ndim=tri.ndim)
        if simplices is not None:
            return pts, tri._check_ids(simplices, len(pts)), np.ones(len(pts), dtype=bool)
        sid, valid = locate(tri, pts, outside)
        return pts, sid, valid

    def predict(self, x, *, outside: str = "nan", simplices=None) -> np.ndarray:
        """Evaluate the spline.

        Parameters
        ----------
        x : array_like, shape (N, n)
            Evaluation points (a single point may be given as shape (n,)).
        outside : {'nan', 'raise', 'extrapolate'}, default 'nan'
            Points outside the triangulation give NaN, raise
            :class:`~simplexspline.OutsideDomainError`, or are evaluated with the polynomial
            of the nearest simplex (see :meth:`Triangulation.nearest`).
        simplices : array_like of int, shape (N,), optional
            Evaluate each point with the polynomial piece of the given simplex instead of
            the one containing it (``outside`` is then ignored).

        Returns
        -------
        ndarray, shape (N,)
        """
        if not kernels.HAVE_NUMBA:
            return self.derivative(x, (0,) * self.ndim, outside=outside, simplices=simplices)
        tri = self.triangulation
        pts = as_points(x, name="x", ndim=tri.ndim)
        if simplices is not None:
            return kernels.evaluate(pts, tri._check_ids(simplices, len(pts)), tri._origin,
                                    tri._tinv, self.coefficients, self.degree)
        check_policy(outside, SPLINE_POLICIES)
        # one compiled pass locates and evaluates; only points outside come back here
        sid, values, outside_any = tri._locate_evaluate(pts, self.coefficients, self.degree)
        if outside_any:
            out = np.nonzero(sid < 0)[0]
            sid, _ = resolve_outside(tri, pts, sid, outside)
            redo = out[sid[out] >= 0]  # extrapolated
            values[redo] = kernels.evaluate(pts[redo], sid[redo], tri._origin, tri._tinv,
                                            self.coefficients, self.degree)
        return values

    __call__ = predict

    def derivative(self, x, order, *, outside: str = "nan", simplices=None) -> np.ndarray:
        """Partial derivative of any order, exact from the B-form.

        Parameters
        ----------
        x : array_like, shape (N, n)
        order : sequence of int, length n
            Differentiation order per variable, e.g. ``(1, 0, 2)`` for
            d^3 s / dx_0 dx_2^2. A total order above the degree gives zeros.
        outside, simplices
            As in :meth:`predict`.

        Returns
        -------
        ndarray, shape (N,)
        """
        order = self._check_order(order)
        pts, sid, valid = self._prepare(x, outside, simplices)
        out = np.full(len(pts), np.nan)
        m = int(sum(order))
        if m > self.degree:
            out[valid] = 0.0
            return out
        dirs = [k for k, o in enumerate(order) for _ in range(o)]
        scale = factorial(self.degree) / factorial(self.degree - m)
        idx = np.nonzero(valid)[0]
        tri = self.triangulation
        for s in range(0, len(idx), CHUNK):
            rows = idx[s:s + CHUNK]
            j = sid[rows]
            c = self.coefficients[j]
            if dirs:
                lam = direction_coordinates(tri._tinv[j])
                deg = self.degree
                for k in dirs:
                    c = de_casteljau_step(c, lam[:, k, :], deg)
                    deg -= 1
            b = tri._locator_barycentric(pts[rows], j)
            bt = basis_values_t(b.T, self.degree - m)
            out[rows] = scale * np.einsum("kn,nk->n", bt, c)
        return out

    def gradient(self, x, *, outside: str = "nan", simplices=None) -> np.ndarray:
        """Gradient of the spline, exact from the B-form.

        Parameters
        ----------
        x : array_like, shape (N, n)
        outside, simplices
            As in :meth:`predict`.

        Returns
        -------
        ndarray, shape (N, n)
            NaN rows for points outside (with ``outside='nan'``).
        """
        pts, sid, valid = self._prepare(x, outside, simplices)
        n, d = self.ndim, self.degree
        tri = self.triangulation
        if kernels.HAVE_NUMBA and d > 0:
            return kernels.gradient(pts, np.where(valid, sid, -1), tri._origin, tri._tinv,
                                    self.coefficients, d)
        out = np.full((len(pts), n), np.nan)
        idx = np.nonzero(valid)[0]
        if d == 0:
            out[idx] = 0.0
            return out
        # ds/db_i = d * sum_k c[kappa_k + e_i] B^{d-1}_k(b); then the chain rule with the
        # (per-simplex constant) gradients of the barycentric coordinates. Points are
        # grouped by simplex so both steps are small matrix products.
        cup = self.coefficients[:, step_table(n, d)]  # (J, d_hat(d-1), n+1)
        for s in range(0, len(idx), CHUNK):
            rows = idx[s:s + CHUNK]
            order = np.argsort(sid[rows], kind="stable")
            rows = rows[order]
            j = sid[rows]
            bt = basis_values_t(tri._locator_barycentric(pts[rows], j).T, d - 1)
            counts = np.bincount(j, minlength=tri.nsimplex)
            ends = np.cumsum(counts)
            grad = np.empty((len(rows), n))
            for jj in np.nonzero(counts)[0]:
                a, e = ends[jj] - counts[jj], ends[jj]
                lam = direction_coordinates(tri._tinv[jj])  # (n, n+1): d b_i / d x_k
                grad[a:e] = (bt[:, a:e].T @ cup[jj]) @ lam.T
            out[rows] = d * grad
        return out

    def _check_order(self, order) -> tuple[int, ...]:
        order = tuple(np.atleast_1d(np.asarray(order)).tolist())
        if len(order) != self.ndim or any(
                not isinstance(o, int) or isinstance(o, bool) or o < 0 for o in order):
            raise InputError(
                f"order must be {self.ndim} non-negative integers (one per variable), "
                f"got {order}")
        return order

    # ------------------------------------------------------------------ persistence
    def save(self, path) -> Path:
        """Save to an open, versioned model file (``.json`` or ``.npz``; no pickled objects).

        The write is atomic (temporary file, then rename). Loading reproduces predictions
        bit for bit. See :mod:`simplexspline.spline.formats.model_file` for the format.
        """
        return save_spline(self, path)

    @classmethod
    def load(cls, path) -> SimplexSpline:
        """Load a model file written by :meth:`save`."""
        record = read_model(path)
        if record.varying:
            raise ModelFileError(f"{path} holds a varying-coefficient model "
                                 "(simplexspline.varying-model): load it with "
                                 "VaryingCoefficientSpline.load or AeroModel.load")
        return cls.from_record(record)

    @classmethod
    def from_record(cls, record: ModelRecord) -> SimplexSpline:
        """The spline a model file holds (read by
        :func:`~simplexspline.spline.formats.model_file.read_model`)."""
        head = record.header
        spline = record.build(lambda tri: cls(tri, head["degree"], head["continuity"],
                                              record.coefficients,
                                              metadata=head.get("metadata") or {}))
        if record.has_statistics:
            spline._uncertainty = _statistics_from(record, spline)
        return spline

    # ------------------------------------------------------------------ statistics
    #: Covariance information (an
    #: :class:`~simplexspline.spline.uncertainty.intervals.Uncertainty`) when attached by
    #: :meth:`with_statistics` or loaded from a model file that has it.
    _uncertainty = None

    def with_statistics(self, normal_equations, *, absolute_weights: bool = False,
                        nobs: int | None = None, covariance: str | None = None,
                        on_insufficient: str | None = None, ridge: float | None = None,
                        penalty=None) -> SimplexSpline:
        """This spline with the statistics of its fit: standard errors, confidence and
        prediction intervals, covariance of the B-coefficients.

        Parameters
        ----------
        normal_equations : NormalEquations
            The accumulator the spline was solved from::

                ne = space.normal_equations(x, y, weights)
                spline = space.solve(ne).with_statistics(ne)

        absolute_weights : bool, default False
            The weights are the inverse noise variances (known noise): sigma^2 = 1 and
            normal quantiles. By default sigma^2 = RSS / (N - p) is estimated (weights
            relative) and intervals use Student t with N - p degrees of freedom.
        nobs : int, optional
            Number of observations N, when some accumulated points had zero weight.
        covariance : {'frequentist', 'bayesian'}, optional
            For ridge or penalised (``smoothing``) fits: the variance of the biased
            estimate (sandwich) or the Bayesian posterior covariance, which also covers
            the smoothing bias on average. Default: 'bayesian' with a smoothing penalty,
            else 'frequentist'.
        on_insufficient, ridge, penalty : optional
            The fit's settings when ``self.info`` does not have them (default: from
            ``self.info``); ``penalty`` as absolute blocks ``lam * P``, shape
            (J, d_hat, d_hat), for custom penalties.

        Returns
        -------
        SimplexSpline
            A new spline with the same coefficients and the statistics attached (saved with
            it by :meth:`save`).

        Raises
        ------
        InputError
            Normal equations of another space or of other data than this fit's.
        InsufficientDataError
            No data in the normal equations.
        """
        unc = Uncertainty.from_fit(self, normal_equations, absolute_weights=absolute_weights,
                                   nobs=nobs, covariance=covariance,
                                   on_insufficient=on_insufficient, ridge=ridge,
                                   penalty=penalty)
        out = SimplexSpline(self.triangulation, self.degree, self.continuity,
                            self.coefficients, space=self.space, info=self.info,
                            metadata=self.metadata)
        out._uncertainty = unc
        return out

    @property
    def uncertainty(self):
        """The :class:`~simplexspline.spline.uncertainty.intervals.Uncertainty` of the fit, or None
        when the spline has no statistics (see :meth:`with_statistics`)."""
        return self._uncertainty

    def _statistics(self):
        if self._uncertainty is None:
            raise InputError(
                "this spline has no statistics: build them from the normal equations it was "
                "fitted to, spline = space.solve(ne).with_statistics(ne) (a model file keeps "
                "them when saved from such a spline)")
        return self._uncertainty

    def standard_error(self, x, *, outside: str = "nan") -> np.ndarray:
        """Standard error of the fitted value at each point, shape (N,).

        ``sqrt(sigma^2 * v' K v)`` with ``v`` the (C^0-gathered) basis values at the point
        and ``K`` the estimator's unscaled covariance (see
        :mod:`simplexspline.spline.uncertainty.intervals`). Same units as the fitted values.

        Parameters
        ----------
        x : array_like, shape (N, n)
        outside : {'nan', 'raise', 'extrapolate'}, default 'nan'
            As in :meth:`predict`. NaN also in simplices the data do not determine.
        """
        return self._statistics().standard_error(x, outside=outside)

    def confidence_interval(self, x, level: float = 0.95, *, kind: str = "confidence",
                            weights=None, outside: str = "nan"):
        """Pointwise interval around the fitted value.

        Parameters
        ----------
        x : array_like, shape (N, n)
        level : float, default 0.95
            Coverage probability of each (pointwise, not simultaneous) interval.
        kind : {'confidence', 'prediction'}, default 'confidence'
            For the true function value (``s(x) -/+ q * se``), or for a new observation at
            x (``s(x) -/+ q * sqrt(se^2 + sigma^2 / w)``).
        weights : float or array_like, shape (N,), optional
            Weights of the new observations (``'prediction'``; default 1, on the scale of
            the fit's weights).
        outside : {'nan', 'raise', 'extrapolate'}, default 'nan'

        Returns
        -------
        lower, upper : ndarray, shape (N,)
            ``q`` is the Student t quantile with N - p degrees of freedom (normal with
            ``absolute_weights``).
        """
        unc = self._statistics()
        center = self.predict(x, outside=outside)
        return unc.interval(center, x, level, kind=kind, weights=weights, outside=outside)

    def covariance(self) -> np.ndarray:
        """Covariance of the B-coefficients, shape (J*d_hat, J*d_hat), Eq. 24 order.

        Dense: only for small problems (J*d_hat <= 6000); otherwise use
        ``uncertainty.covariance_blocks()`` (per simplex) or :meth:`standard_error`.
        """
        return self._statistics().covariance()


def _statistics_from(record: ModelRecord, spline: SimplexSpline) -> Uncertainty:
    """The optional statistics section of a model file as an Uncertainty."""
    section = record.statistics
    if not isinstance(section, dict):
        raise record.error("the statistics section must be an object")
    arrays = record.statistics_arrays or {k: np.asarray(section[k]) for k in STATISTICS_ARRAYS
                                          if k in section}
    try:
        return Uncertainty.from_state(spline.space, section, arrays)
    except (SimplexSplineError, KeyError, TypeError, ValueError) as exc:
        raise record.error(f"invalid statistics section: {exc}") from None
