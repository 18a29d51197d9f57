"""A scikit-learn compatible regressor: :class:`SimplexSplineRegressor`.

The estimator wraps the spline layer (:class:`~simplexspline.Triangulation`,
:class:`~simplexspline.SplineSpace`, :class:`~simplexspline.SimplexSpline`) behind the
``fit`` / ``predict`` / ``score`` / ``get_params`` / ``set_params`` protocol, so a simplex
spline can be used in :class:`sklearn.pipeline.Pipeline`, tuned by
:class:`sklearn.model_selection.GridSearchCV` and cross-validated like any regressor.

scikit-learn is optional: when it is installed the estimator subclasses its
``RegressorMixin`` and ``BaseEstimator`` (and uses its input validation, so it behaves
exactly like the library's own estimators); without it, equivalent ``get_params``,
``set_params``, ``score`` and input validation are provided here.

How a fit works
---------------
1. Samples with zero weight are removed (they influence nothing, not even the box below).
2. Features that do not vary over the remaining samples are set aside: the model is
   constant along them (``active_features_`` lists the others).
3. With ``scale=True`` the active features are mapped to the unit box of the training
   data, ``u = (x - data_min_) / (data_max_ - data_min_)``, so that simplices are well
   shaped whatever the units.
4. A triangulation of that box is built: a Kuhn grid with ``resolution`` cells per feature
   whose simplices holding fewer than ``min_points`` samples are dropped
   (:meth:`Triangulation.fit`, the paper's Fig. 5 idea); or one simplex enclosing the box
   (a single polynomial, for many features); or the triangulation the user gave.
5. The B-coefficients of S^r_d on it are the equality-constrained (weighted) least-squares
   estimate (:meth:`SplineSpace.solve`), with a small relative ridge so that thin data
   never make the problem singular.
"""

from __future__ import annotations

import inspect
import numbers
import warnings
from math import comb, factorial

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from simplexspline.errors import InputError, SimplexSplineError
from simplexspline.spline.bform import basis_values, num_basis
from simplexspline.spline.solve import SolveInfo, solve_constrained
from simplexspline.spline.space import SplineSpace
from simplexspline.spline.spline import SimplexSpline
from simplexspline.spline.triangulation import Triangulation
from simplexspline.spline.validation import check_degree

try:  # scikit-learn is optional
    from sklearn.base import BaseEstimator as _BaseEstimator
    from sklearn.base import RegressorMixin as _RegressorMixin
    from sklearn.exceptions import NotFittedError as _SklearnNotFittedError

    try:  # scikit-learn >= 1.6
        from sklearn.utils.validation import validate_data as _sk_validate_data
    except ImportError:  # pragma: no cover - older scikit-learn
        _sk_validate_data = None
    HAVE_SKLEARN = True
except ImportError:  # pragma: no cover - exercised by a subprocess test
    HAVE_SKLEARN = False
    _sk_validate_data = None
    _SklearnNotFittedError = AttributeError
    _BaseEstimator = None
    _RegressorMixin = None

__all__ = [
    "SimplexSplineRegressor",
    "NotFittedError",
    "OUTSIDE",
    "TRIANGULATIONS",
    "GRID_SIMPLEX_LIMIT",
    "MAX_BASIS_PER_SIMPLEX",
    "HAVE_SKLEARN",
]

#: Prediction policies outside the training domain.
OUTSIDE = ("clamp", "extrapolate", "nan")

#: Triangulations the estimator can build (or pass a :class:`Triangulation`).
TRIANGULATIONS = ("auto", "grid", "simplex")

#: Largest Kuhn grid (``m! * prod(resolution)`` simplices before empty ones are dropped)
#: the estimator builds; :meth:`Triangulation.fit` materialises the whole grid first.
#: ``triangulation='auto'`` uses a grid while ``m!`` stays within it (up to 8 features).
GRID_SIMPLEX_LIMIT = 100_000

#: Largest number of B-coefficients in one simplex (``C(m + d, d)``): a single simplex's
#: Gram block is a dense square matrix of this order.
MAX_BASIS_PER_SIMPLEX = 6000

#: Rows per chunk when extra outputs' right-hand sides are accumulated.
_CHUNK = 1 << 16

#: Relative tolerance of the box tests in model coordinates (as the locators' INSIDE_TOL).
_BOX_TOL = 1e-10


class NotFittedError(InputError, _SklearnNotFittedError):
    """A :class:`SimplexSplineRegressor` used before ``fit``.

    Derives from the package's :class:`~simplexspline.InputError` and, when scikit-learn is
    installed, from :class:`sklearn.exceptions.NotFittedError` (otherwise from
    ``AttributeError``), so either family catches it.
    """


# --------------------------------------------------------------------------- fallbacks
class _FallbackBaseEstimator:
    """``get_params`` / ``set_params`` / ``repr`` as scikit-learn's BaseEstimator does them."""

    @classmethod
    def _get_param_names(cls) -> list[str]:
        sig = inspect.signature(cls.__init__)
        return sorted(p.name for p in sig.parameters.values()
                      if p.name != "self" and p.kind == p.KEYWORD_ONLY)

    def get_params(self, deep: bool = True) -> dict:
        """Parameters of this estimator, name -> value."""
        return {name: getattr(self, name) for name in self._get_param_names()}

    def set_params(self, **params):
        """Set parameters (validated at ``fit``, as scikit-learn does); returns self."""
        valid = self._get_param_names()
        for name, value in params.items():
            if name not in valid:
                raise InputError(f"Invalid parameter {name!r} for estimator "
                                 f"{type(self).__name__}. Valid parameters are: {valid!r}.")
            setattr(self, name, value)
        return self

    def __repr__(self) -> str:
        defaults = {p.name: p.default
                    for p in inspect.signature(type(self).__init__).parameters.values()}
        changed = []
        for name, value in self.get_params().items():
            default = defaults.get(name)
            same = value is default or (type(value) is type(default) and value == default)
            if not same:
                changed.append(f"{name}={value!r}")
        return f"{type(self).__name__}({', '.join(changed)})"


class _FallbackRegressorMixin:
    """``score`` (the coefficient of determination R^2) without scikit-learn."""

    def score(self, X, y, sample_weight=None) -> float:
        """R^2 of ``predict(X)`` against ``y`` (averaged uniformly over outputs).

        Parameters
        ----------
        X : array_like, shape (N, n)
        y : array_like, shape (N,) or (N, k)
        sample_weight : array_like, shape (N,), optional
        """
        pred = np.asarray(self.predict(X), dtype=float)
        y = np.asarray(y, dtype=float)
        if y.shape != pred.shape:
            y = y.reshape(pred.shape)
        w = np.ones(len(y)) if sample_weight is None else _check_weights(sample_weight,
                                                                         len(y))
        y2, p2 = y.reshape(len(y), -1), pred.reshape(len(y), -1)
        mean = (w[:, None] * y2).sum(axis=0) / w.sum()
        ss_res = (w[:, None] * (y2 - p2) ** 2).sum(axis=0)
        ss_tot = (w[:, None] * (y2 - mean) ** 2).sum(axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            r2 = np.where(ss_tot > 0, 1.0 - ss_res / ss_tot,
                          np.where(ss_res > 0, 0.0, 1.0))
        return float(np.mean(r2))


if HAVE_SKLEARN:
    _Bases = (_RegressorMixin, _BaseEstimator)
else:  # pragma: no cover - exercised by a subprocess test
    _Bases = (_FallbackRegressorMixin, _FallbackBaseEstimator)


# --------------------------------------------------------------------------- estimator
class SimplexSplineRegressor(*_Bases):
    """Regression with a multivariate simplex spline, scikit-learn compatible.

    Fits a spline of S^r_d(T) (degree ``d``, C^r continuity, on a triangulation T of the
    training data's box) by equality-constrained weighted least squares; see the module
    docstring for the steps and ``docs/estimator.md`` for a guide.

    Parameters
    ----------
    degree : int, default 3
        Polynomial degree ``d >= 0`` of every piece.
    continuity : int, default 1
        Continuity order ``r`` between pieces, ``-1 <= r < d`` (-1: pieces independent).
    resolution : int or tuple of int, default 1
        Grid cells per input feature (a tuple gives one count per feature of ``X``; entries
        of constant features are ignored). Each cell holds ``m!`` simplices for ``m``
        features. Used by the ``'grid'`` triangulation.
    triangulation : {'auto', 'grid', 'simplex'} or Triangulation, default 'auto'
        ``'grid'``: the Kuhn grid of the training box (:meth:`Triangulation.fit`);
        ``'simplex'``: one simplex enclosing the box, i.e. a single polynomial of degree
        ``d`` (``resolution``, ``continuity`` and ``min_points`` do not apply);
        ``'auto'``: ``'grid'`` when the grid of one cell per feature has at most
        :data:`GRID_SIMPLEX_LIMIT` simplices (up to 8 features), else ``'simplex'``.
        A :class:`Triangulation` is used as given, in the coordinates of ``X`` (``scale``
        does not apply; every training sample must lie inside it). Delaunay triangulations
        of the data are not offered: they are full of slivers and put few samples in each
        simplex; pass ``Triangulation.delaunay(vertices)`` of chosen vertices instead.
    min_points : int, default 1
        Grid simplices holding fewer training samples (with positive weight) are dropped;
        samples in dropped simplices are not fitted. With 1, exactly the empty simplices
        are dropped.
    ridge : float, default 1e-8
        Relative ridge weight: ``ridge * mean(diag X'WX) * ||c||^2`` is added to the least
        squares objective. The small default is a numerical safeguard, not a smoother: it
        makes the problem non-singular when data are thin (coefficients that neither data
        nor continuity determine get minimum-norm values instead of an
        :class:`~simplexspline.InsufficientDataError`) and biases well-determined fits by
        about ``ridge`` times the condition number of the Gram blocks (relative): 1e-8 to
        1e-5 in practice (on ``'simplex'`` triangulations the ridge is relative to each
        coefficient's own Gram diagonal). Larger values (1e-4 .. 1e-1) regularise; tune them by
        cross-validation. 0: no ridge, undetermined directions get the exact minimum-norm
        solution.
    outside : {'clamp', 'extrapolate', 'nan'}, default 'clamp'
        Prediction outside the training domain (the box of the training data, minus
        dropped simplices; for a given triangulation, the triangulation): ``'clamp'``
        moves the input to the box first (constant continuation; a point that then lies
        in a dropped simplex is evaluated with the nearest simplex's polynomial);
        ``'extrapolate'`` evaluates the nearest simplex's polynomial at the point itself;
        ``'nan'`` returns NaN (also for a constant feature that differs from its training
        value).
    scale : bool, default True
        Map the features to the unit box of the training data before building the
        triangulation. The B-form is affine invariant, so this changes only which simplex
        counts as nearest for extrapolation and the shape of the ``'simplex'``
        triangulation; a Kuhn grid is the same up to the affine map.
    max_coefficients : int, default 100_000
        Largest number of B-coefficients (simplices x coefficients per simplex) to fit; a
        larger model raises :class:`~simplexspline.InputError` naming the limit.

    Attributes
    ----------
    spline_ : SimplexSpline
        The fitted spline (single-output fits), in model coordinates: it takes
        ``model_coordinates(X)``. Use :meth:`to_spline` for one in the coordinates of ``X``.
    splines_ : list of SimplexSpline
        One spline per output, all on ``triangulation_``.
    triangulation_ : Triangulation
        The triangulation, in model coordinates.
    triangulation_kind_ : {'grid', 'simplex', 'explicit'}
    n_features_in_ : int
        Number of features of ``X`` seen in ``fit``.
    feature_names_in_ : ndarray of str, shape (n_features_in_,)
        Feature names, when ``X`` was a DataFrame with string column names.
    n_outputs_ : int
        Number of outputs (columns of a 2-D ``y``; 1 for 1-D ``y``).
    active_features_ : ndarray of int
        Features the spline depends on: all but those constant over the training samples
        (all features for a given triangulation).
    data_min_, data_max_ : ndarray, shape (n_features_in_,)
        Range of each feature over the training samples with positive weight.
    scaled_ : bool
        Whether inputs are mapped to the unit box (``scale`` and a built triangulation).
    n_simplices_ : int
        Number of simplices J.
    n_coefficients_ : int
        Number of B-coefficients per output, ``J * C(m + d, d)``.
    n_samples_fit_ : int
        Samples that entered the fit (positive weight, inside a kept simplex).

    Notes
    -----
    Multi-output: a 2-D ``y`` of shape (N, k) gives k splines on one triangulation, fitted
    from one set of Gram blocks (only the right-hand sides differ); ``predict`` then
    returns shape (N, k). A ``y`` of shape (N, 1) gives predictions of shape (N, 1).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(-1, 1, size=(500, 2))
    >>> y = X[:, 0] ** 3 - 2 * X[:, 0] * X[:, 1] + 0.5
    >>> model = SimplexSplineRegressor(degree=3, resolution=2).fit(X, y)
    >>> model.n_simplices_, model.n_coefficients_
    (8, 80)
    >>> bool(abs(model.predict([[0.2, -0.4]])[0] - (0.008 + 0.16 + 0.5)) < 1e-6)
    True
    """

    def __init__(self, *, degree: int = 3, continuity: int = 1, resolution=1,
                 triangulation="auto", min_points: int = 1, ridge: float = 1e-8,
                 outside: str = "clamp", scale: bool = True,
                 max_coefficients: int = 100_000):
        self.degree = degree
        self.continuity = continuity
        self.resolution = resolution
        self.triangulation = triangulation
        self.min_points = min_points
        self.ridge = ridge
        self.outside = outside
        self.scale = scale
        self.max_coefficients = max_coefficients

    # ------------------------------------------------------------------ sklearn protocol
    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        tags.input_tags.allow_nan = False
        tags.input_tags.sparse = False
        return tags

    def _more_tags(self):  # scikit-learn < 1.6
        return {"multioutput": True, "allow_nan": False}

    def __sklearn_is_fitted__(self) -> bool:
        return hasattr(self, "splines_")

    def _check_fitted(self) -> None:
        if not self.__sklearn_is_fitted__():
            raise NotFittedError(
                f"This {type(self).__name__} instance is not fitted yet. Call 'fit' with "
                "appropriate arguments before using this estimator.")

    @property
    def spline_(self) -> SimplexSpline:
        """The fitted spline of a single-output fit (model coordinates)."""
        self._check_fitted()
        if self.n_outputs_ != 1:
            raise AttributeError(
                f"spline_ is defined for single-output fits; this regressor has "
                f"{self.n_outputs_} outputs: use splines_[k]")
        return self.splines_[0]

    # ------------------------------------------------------------------ fit
    def fit(self, X, y, sample_weight=None) -> SimplexSplineRegressor:
        """Fit the spline to training data.

        Parameters
        ----------
        X : array_like, shape (N, n)
            Training inputs (a DataFrame's string column names become
            ``feature_names_in_``).
        y : array_like, shape (N,) or (N, k)
            Targets; a 2-D ``y`` fits one spline per column on a shared triangulation.
        sample_weight : array_like, shape (N,), optional
            Non-negative weights (inverse noise variances). A zero weight removes the
            sample entirely (also from the box that is triangulated); integer weights are
            equivalent to repeating samples.

        Returns
        -------
        self

        Raises
        ------
        InputError
            Invalid parameters or data (NaN/inf, wrong shapes, fewer than 2 samples with
            positive weight, all features constant, a model above ``max_coefficients``).
        """
        for name in [a for a in vars(self) if a.endswith("_") and not a.startswith("__")]:
            delattr(self, name)  # no stale fitted state if this fit fails
        X, Y = self._validate_X_y(X, y)
        w = _check_weights(sample_weight, len(X))
        cfg = self._check_params(X.shape[1])
        y_2d = Y.ndim == 2
        Y = Y.reshape(len(Y), -1)
        if w is not None:
            pos = w > 0
            if not np.any(pos):
                raise InputError("all sample weights are zero: nothing to fit")
            if not np.all(pos):
                X, Y, w = X[pos], Y[pos], w[pos]
        if len(X) < 2:
            raise InputError(
                f"{type(self).__name__} needs at least 2 samples with positive weight to "
                f"fit, got {len(X)} sample (n_samples={len(X)})")
        lo, hi = X.min(axis=0), X.max(axis=0)
        explicit = isinstance(self.triangulation, Triangulation)
        if explicit:
            active = np.arange(X.shape[1])
            scaled = False
        else:
            active = np.nonzero(hi > lo)[0]
            if len(active) == 0:
                raise InputError(
                    f"all {X.shape[1]} features are constant over the {len(X)} training "
                    "samples: a spline needs at least one varying feature")
            scaled = bool(self.scale)
        self.data_min_, self.data_max_ = lo, hi
        self.active_features_ = active
        self.scaled_ = scaled
        U = self._coords(X)
        tri, kind = self._build_triangulation(U, cfg)
        dhat = num_basis(tri.ndim, cfg["degree"])
        ncoef = tri.nsimplex * dhat
        if ncoef > cfg["max_coefficients"]:
            raise InputError(
                f"the model would have {ncoef} B-coefficients per output ({tri.nsimplex} "
                f"simplices x {dhat}), above max_coefficients={cfg['max_coefficients']}: "
                "lower the degree or resolution, use fewer features, or raise "
                "max_coefficients")
        if kind == "grid":
            sid = tri.locate(U)
            kept = sid >= 0  # samples in simplices dropped by min_points are not fitted
            if not np.all(kept):
                U, Y = U[kept], Y[kept]
                w = None if w is None else w[kept]
        coefs, infos = self._solve(tri, kind, U, Y, w, cfg)
        meta = {"estimator": type(self).__name__, "coordinates": "model",
                "features": self._feature_labels(active)}
        self.splines_ = [
            SimplexSpline(tri, cfg["degree"], cfg["continuity"], c, info=info,
                          metadata={**meta, "output": k})
            for k, (c, info) in enumerate(zip(coefs, infos))]
        self.triangulation_ = tri
        self.triangulation_kind_ = kind
        self.n_outputs_ = Y.shape[1]
        self.n_simplices_ = tri.nsimplex
        self.n_coefficients_ = ncoef
        self.n_samples_fit_ = len(U)
        self._y_2d = y_2d
        return self

    def _check_params(self, n_features: int) -> dict:
        """Validate the hyper-parameters (scikit-learn defers this to ``fit``)."""
        # r < d is checked once the triangulation kind is known (_build_triangulation):
        # continuity does not apply to a single polynomial ('simplex')
        degree, _ = check_degree(self.degree, -1)
        continuity = self.continuity
        if not _is_int(continuity) or continuity < -1:
            raise InputError(f"continuity must be an integer >= -1 (-1: no continuity), got "
                             f"{continuity!r}")
        res = self.resolution
        if _is_int(res):
            res = (int(res),) * n_features
        try:
            res = tuple(res)
        except TypeError:
            raise InputError(f"resolution must be a positive integer or a tuple of "
                             f"{n_features} of them, got {self.resolution!r}") from None
        if len(res) != n_features or not all(_is_int(k) and k >= 1 for k in res):
            raise InputError(f"resolution must be a positive integer or a tuple of one "
                             f"positive integer per feature ({n_features}), got "
                             f"{self.resolution!r}")
        tri = self.triangulation
        if isinstance(tri, Triangulation):
            if tri.ndim != n_features:
                raise InputError(f"the given triangulation is {tri.ndim}-dimensional but X "
                                 f"has {n_features} features")
        elif not isinstance(tri, str) or tri not in TRIANGULATIONS:
            raise InputError(f"triangulation must be one of {TRIANGULATIONS} or a "
                             f"Triangulation, got {tri!r}")
        if not _is_int(self.min_points) or self.min_points < 1:
            raise InputError(f"min_points must be an integer >= 1, got {self.min_points!r}")
        ridge = self.ridge
        if (isinstance(ridge, bool) or not isinstance(ridge, numbers.Real)
                or not np.isfinite(ridge) or ridge < 0):
            raise InputError(f"ridge must be a finite number >= 0, got {ridge!r}")
        if not isinstance(self.outside, str) or self.outside not in OUTSIDE:
            raise InputError(f"outside must be one of {OUTSIDE}, got {self.outside!r}")
        if not isinstance(self.scale, (bool, np.bool_)):
            raise InputError(f"scale must be True or False, got {self.scale!r}")
        if not _is_int(self.max_coefficients) or self.max_coefficients < 1:
            raise InputError(f"max_coefficients must be an integer >= 1, got "
                             f"{self.max_coefficients!r}")
        return {"degree": degree, "continuity": int(continuity),
                "resolution": np.asarray(res, dtype=np.int64), "ridge": float(ridge),
                "min_points": int(self.min_points),
                "max_coefficients": int(self.max_coefficients)}

    def _build_triangulation(self, U: np.ndarray, cfg: dict):
        """The triangulation in model coordinates and its kind."""
        if isinstance(self.triangulation, Triangulation):
            check_degree(cfg["degree"], cfg["continuity"])
            return self.triangulation, "explicit"
        m = U.shape[1]
        res = cfg["resolution"][self.active_features_]
        kind = self.triangulation
        if kind == "auto":
            kind = "grid" if factorial(m) <= GRID_SIMPLEX_LIMIT else "simplex"
        if kind == "grid":
            size = factorial(m) * int(np.prod(res.astype(float)))
            if size > GRID_SIMPLEX_LIMIT:
                raise InputError(
                    f"a Kuhn grid of resolution {res.tolist()} over {m} features has "
                    f"{size} simplices, above the limit {GRID_SIMPLEX_LIMIT} "
                    "(GRID_SIMPLEX_LIMIT): lower the resolution, use fewer features, or "
                    "use triangulation='simplex' (one polynomial)")
            check_degree(cfg["degree"], cfg["continuity"])
            self._check_basis(m, cfg["degree"])
            return Triangulation.fit(U, res, min_points=cfg["min_points"]), "grid"
        cfg["continuity"] = -1  # one polynomial
        self._check_basis(m, cfg["degree"])
        lo, hi = self._box()
        verts = np.tile(lo, (m + 1, 1))
        # The corner simplex {u >= lo, sum((u - lo) / span) <= m} contains the box.
        verts[1 + np.arange(m), np.arange(m)] += m * (hi - lo)
        data = {"kind": "explicit", "vertices": verts, "simplices": np.arange(m + 1)[None]}
        return Triangulation.from_arrays(data, check=False), "simplex"

    def _check_basis(self, m: int, degree: int) -> None:
        dhat = comb(m + degree, degree)
        if dhat > min(MAX_BASIS_PER_SIMPLEX, int(self.max_coefficients)):
            raise InputError(
                f"a polynomial piece of degree {degree} in {m} features has {dhat} "
                f"B-coefficients, above the limit "
                f"{min(MAX_BASIS_PER_SIMPLEX, int(self.max_coefficients))} "
                "(MAX_BASIS_PER_SIMPLEX or max_coefficients): lower the degree or use fewer "
                "features")

    def _solve(self, tri, kind, U, Y, w, cfg):
        """B-coefficients (one (J, d_hat) array per output) and their SolveInfo."""
        degree, ridge = cfg["degree"], cfg["ridge"]
        dhat = num_basis(tri.ndim, degree)
        if kind == "simplex" and len(U) < dhat:
            return _solve_dual(tri, degree, U, Y, w, ridge)
        space = SplineSpace(tri, degree, cfg["continuity"])
        policy = "ridge" if ridge > 0 else "minnorm"
        kw = {"on_insufficient": policy, "ridge": ridge if ridge > 0 else None}
        ne = space.normal_equations(U, Y[:, 0], w)
        rhs, yty = _extra_rhs(space, U, Y[:, 1:], w)
        coefs, infos = [], []
        for k in range(Y.shape[1]):
            nek = ne
            if k:
                nek = ne.copy()
                nek.XtWy = rhs[:, :, k - 1]
                nek.ytWy = float(yty[k - 1])
            if kind == "simplex" and ridge > 0:
                # One polynomial on a simplex much larger than the data: its Bernstein
                # columns differ in scale by orders of magnitude, so the ridge is relative to
                # each coefficient's own Gram diagonal (Jacobi-scaled, scale invariant).
                diag = np.einsum("jkk->jk", nek.XtWX)
                floor = diag.max() * np.finfo(float).eps
                pen = ridge * np.apply_along_axis(np.diag, 1, np.maximum(diag, floor))
                c, info = solve_constrained(nek, space.system, on_insufficient="minnorm",
                                            penalty=pen)
            else:
                sol = space.solve(nek, **kw)
                c, info = sol.coefficients, sol.info
            coefs.append(c)
            infos.append(info)
        return coefs, infos

    # ------------------------------------------------------------------ predict
    def predict(self, X) -> np.ndarray:
        """Predict targets.

        Parameters
        ----------
        X : array_like, shape (N, n)

        Returns
        -------
        ndarray, shape (N,) or (N, k)
            Shape (N, k) when ``y`` was 2-D in ``fit``. Points outside the training
            domain follow the ``outside`` policy (NaN with ``'nan'``).
        """
        self._check_fitted()
        X = self._validate_X(X)
        U = self._coords(X)
        U, sid, valid = self._locate(U, X)
        out = np.full((len(U), self.n_outputs_), np.nan)
        rows = np.nonzero(valid)[0]
        if len(rows):
            for k, spline in enumerate(self.splines_):
                out[rows, k] = spline.predict(U[rows], simplices=sid[rows])
        return out if self._y_2d else out[:, 0]

    def model_coordinates(self, X) -> np.ndarray:
        """Map inputs to the coordinates of ``triangulation_`` and ``splines_``.

        The active features, scaled to the training box when ``scaled_``.

        Parameters
        ----------
        X : array_like, shape (N, n)

        Returns
        -------
        ndarray, shape (N, m)
        """
        self._check_fitted()
        return self._coords(self._validate_X(X))

    def to_spline(self, output: int = 0) -> SimplexSpline:
        """The fitted spline of one output in the coordinates of ``X``.

        The same polynomial pieces on the triangulation mapped back from the unit box
        (B-coefficients are invariant under affine maps), so its :meth:`~SimplexSpline.
        gradient` and :meth:`~SimplexSpline.derivative` are in the units of ``X``, and
        :meth:`~SimplexSpline.save` writes a model usable without this estimator. It takes
        the active features only, ``X[:, active_features_]``; its own ``outside`` policy
        applies (NaN outside by default, no clamping).

        Parameters
        ----------
        output : int, default 0
            Which output of a multi-output fit.

        Returns
        -------
        SimplexSpline
        """
        self._check_fitted()
        if not _is_int(output) or not 0 <= output < self.n_outputs_:
            raise InputError(f"output must be an integer in 0..{self.n_outputs_ - 1}, got "
                             f"{output!r}")
        spline = self.splines_[output]
        tri = self.triangulation_
        if self.scaled_:
            a = self.active_features_
            lo, span = self.data_min_[a], self.data_max_[a] - self.data_min_[a]
            data = dict(tri.to_arrays())
            data["vertices"] = lo + np.asarray(data["vertices"]) * span
            if "grid_lower" in data:
                data["grid_lower"] = lo + data["grid_lower"] * span
                data["grid_upper"] = lo + data["grid_upper"] * span
            tri = Triangulation.from_arrays(data, check=False)
        meta = {**spline.metadata, "coordinates": "input",
                "variables": list(spline.metadata.get("features", []))}
        return SimplexSpline(tri, spline.degree, spline.continuity, spline.coefficients,
                             info=spline.info, metadata=meta)

    # ------------------------------------------------------------------ internals
    def _box(self):
        """The training box of the active features in model coordinates."""
        a = self.active_features_
        if self.scaled_:
            return np.zeros(len(a)), np.ones(len(a))
        return self.data_min_[a].astype(float), self.data_max_[a].astype(float)

    def _coords(self, X: np.ndarray) -> np.ndarray:
        a = self.active_features_
        U = X[:, a].astype(float)
        if self.scaled_:
            lo = self.data_min_[a]
            U = (U - lo) / (self.data_max_[a] - lo)
        return np.ascontiguousarray(U)

    def _locate(self, U: np.ndarray, X: np.ndarray):
        """The points to evaluate (clamped to the box with ``outside='clamp'``), the simplex
        to evaluate each with, and which points get a value."""
        kind = self.triangulation_kind_
        tri = self.triangulation_
        policy = self.outside
        n = len(U)
        valid = np.ones(n, dtype=bool)
        if kind == "explicit":
            lo, hi = tri.vertices.min(axis=0), tri.vertices.max(axis=0)
        else:
            lo, hi = self._box()
        if policy == "clamp":
            U = np.clip(U, lo, hi)
        if kind == "simplex":
            sid = np.zeros(n, dtype=np.int64)
        else:
            sid = tri.locate(U)
        if policy == "nan":
            valid = sid >= 0
            if kind != "explicit":
                tol = _BOX_TOL * (hi - lo)
                valid &= np.all((U >= lo - tol) & (U <= hi + tol), axis=1)
                const = np.setdiff1d(np.arange(X.shape[1]), self.active_features_)
                if len(const):
                    v = self.data_min_[const]
                    valid &= np.all(np.abs(X[:, const] - v)
                                    <= 1e-9 * np.maximum(1.0, np.abs(v)), axis=1)
        else:
            miss = np.nonzero(sid < 0)[0]
            if len(miss):
                sid[miss] = tri.nearest(U[miss])
        return U, sid, valid

    def _feature_labels(self, idx) -> list[str]:
        names = getattr(self, "feature_names_in_", None)
        return [str(names[i]) if names is not None else f"x{i}" for i in idx]

    def _validate_X_y(self, X, y):
        if y is None:
            raise InputError(f"{type(self).__name__} requires y to be passed, but the target "
                             "y is None")
        if HAVE_SKLEARN:
            out = _sk_call(self, X, y, reset=True, multi_output=True, y_numeric=True)
            X, Y = out
        else:
            X = _fallback_validate_X(self, X, reset=True)
            Y = _fallback_validate_y(y, len(X))
        X = np.asarray(X, dtype=float)
        Y = np.asarray(Y, dtype=float)
        if Y.ndim == 2 and Y.shape[1] == 0:
            raise InputError("y has no columns (shape (N, 0)): nothing to fit")
        return X, Y

    def _validate_X(self, X):
        if HAVE_SKLEARN:
            X = _sk_call(self, X, None, reset=False)
        else:
            X = _fallback_validate_X(self, X, reset=False)
        return np.asarray(X, dtype=float)


# --------------------------------------------------------------------------- helpers
def _is_int(v) -> bool:
    return isinstance(v, (numbers.Integral, np.integer)) and not isinstance(v, (bool, np.bool_))


def _sk_call(est, X, y, *, reset: bool, **kw):
    """scikit-learn's input validation (any supported version); its ValueErrors become
    InputError (a ValueError too) with the same message."""
    kw.setdefault("dtype", np.float64)
    try:
        if _sk_validate_data is not None:
            if y is None:
                return _sk_validate_data(est, X, reset=reset, **kw)
            return _sk_validate_data(est, X, y, reset=reset, **kw)
        if y is None:  # pragma: no cover - scikit-learn < 1.6
            return est._validate_data(X, reset=reset, **kw)
        return est._validate_data(X, y, reset=reset, **kw)  # pragma: no cover
    except SimplexSplineError:
        raise
    except ValueError as exc:
        raise InputError(str(exc)) from None


def _feature_names(X):
    cols = getattr(X, "columns", None)
    if cols is None:
        return None
    names = np.asarray(list(cols), dtype=object)
    if len(names) and all(isinstance(c, str) for c in names):
        return names
    return None


def _fallback_validate_X(est, X, *, reset: bool) -> np.ndarray:
    """Input validation equivalent to scikit-learn's, for use without it."""
    name = type(est).__name__
    if sp.issparse(X):
        raise TypeError(f"{name} does not accept sparse input: pass a dense array "
                        "(X.toarray())")
    names = _feature_names(X)
    arr = np.asarray(X)
    if arr.dtype.kind == "c":
        raise InputError("Complex data not supported")
    try:
        arr = arr.astype(float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"X must be numeric: {exc}") from None
    if arr.ndim != 2:
        raise InputError(f"Expected a 2D array, got {arr.ndim}D array instead: reshape your "
                         "data, X.reshape(-1, 1) for a single feature or X.reshape(1, -1) "
                         "for a single sample")
    if arr.shape[0] < 1 or arr.shape[1] < 1:
        raise InputError(f"Found array with shape {arr.shape} while at least 1 sample and "
                         "1 feature are required")
    if not np.all(np.isfinite(arr)):
        raise InputError("Input X contains NaN or infinity: remove or impute those samples")
    if reset:
        est.n_features_in_ = arr.shape[1]
        if names is not None:
            est.feature_names_in_ = names
        return arr
    fitted = getattr(est, "feature_names_in_", None)
    if fitted is not None and names is None:
        warnings.warn(f"X does not have valid feature names, but {name} was fitted with "
                      "feature names", UserWarning, stacklevel=3)
    elif fitted is None and names is not None:
        warnings.warn(f"X has feature names, but {name} was fitted without feature names",
                      UserWarning, stacklevel=3)
    elif fitted is not None and (len(fitted) != len(names) or np.any(fitted != names)):
        raise InputError("The feature names should match those that were passed during "
                         f"fit: expected {list(fitted)}, got {list(names)}")
    if arr.shape[1] != est.n_features_in_:
        raise InputError(f"X has {arr.shape[1]} features, but {name} is expecting "
                         f"{est.n_features_in_} features as input.")
    return arr


def _fallback_validate_y(y, npts: int) -> np.ndarray:
    if y is None:
        raise InputError("this estimator requires y to be passed, but the target y is None")
    try:
        arr = np.asarray(y, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"y must be numeric: {exc}") from None
    if arr.ndim not in (1, 2) or len(arr) != npts:
        raise InputError(f"y must have shape ({npts},) or ({npts}, k) to match X, got "
                         f"{arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("Input y contains NaN or infinity: remove those samples")
    return arr


def _check_weights(sample_weight, npts: int):
    """Validated copy of the sample weights, shape (N,), or None."""
    if sample_weight is None:
        return None
    try:
        w = np.array(sample_weight, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"sample_weight must be numeric: {exc}") from None
    if w.ndim == 0:
        w = np.full(npts, float(w))
    if w.shape != (npts,):
        raise InputError(f"sample_weight.shape == {w.shape}, expected ({npts},): one "
                         "weight per sample")
    if not np.all(np.isfinite(w)):
        raise InputError("sample_weight contains NaN or inf")
    if np.any(w < 0):
        raise InputError(f"sample_weight must be >= 0; {int((w < 0).sum())} are negative")
    return w


def _extra_rhs(space, U, Y, w):
    """X'Wy (J, d_hat, k) and y'Wy (k,) of further outputs (the Gram blocks are shared)."""
    J, dhat, k = space.triangulation.nsimplex, space.nbasis, Y.shape[1]
    acc = np.zeros((J * dhat, k))
    yty = np.zeros(k)
    if k == 0:
        return acc.reshape(J, dhat, 0), yty
    for s in range(0, len(U), _CHUNK):
        D = space.design_matrix(U[s:s + _CHUNK])
        yc = Y[s:s + _CHUNK]
        wy = yc if w is None else yc * w[s:s + _CHUNK, None]
        acc += D.T @ wy
        yty += (wy * yc).sum(axis=0)
    return acc.reshape(J, dhat, k), yty


def _solve_dual(tri, degree: int, U, Y, w, ridge: float):
    """One simplex with fewer samples than coefficients: the same estimate as
    :meth:`SplineSpace.solve` (ridge, or minimum norm when ``ridge`` is 0) from the
    N x N dual system instead of the d_hat x d_hat Gram matrix."""
    n = len(U)
    B = basis_values(tri.barycentric(U, np.zeros(n, dtype=np.int64)), degree)  # (N, d_hat)
    dhat = B.shape[1]
    sw = np.ones(n) if w is None else np.sqrt(w)
    Bw, Yw = B * sw[:, None], Y * sw[:, None]
    sv = np.linalg.svd(Bw, compute_uv=False)
    rank = int((sv > sv[0] * max(Bw.shape) * np.finfo(float).eps).sum())
    lam = ridge * float((Bw ** 2).sum()) / dhat  # ridge * mean(diag X'WX), as the solver
    if lam > 0:
        K = Bw @ Bw.T
        K[np.diag_indices(n)] += lam
        C = Bw.T @ sla.solve(K, Yw, assume_a="pos")
        policy = "ridge"
    else:
        C = np.linalg.lstsq(Bw, Yw, rcond=None)[0]
        policy = "minnorm"
    rss = ((Yw - Bw @ C) ** 2).sum(axis=0)
    nund = dhat - rank
    infos = [SolveInfo(counts=np.array([n]), deficient_simplices=np.array([0]),
                       undetermined_simplices=np.array([0] if nund else [], dtype=np.intp),
                       n_undetermined=nund, policy=policy, ridge=lam, rss=float(r))
             for r in rss]
    return [C[:, k][None, :] for k in range(Y.shape[1])], infos
