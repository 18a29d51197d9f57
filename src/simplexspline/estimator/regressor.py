"""A scikit-learn compatible regressor: :class:`SimplexSplineRegressor`.

The estimator wraps the spline layer (:class:`~simplexspline.Triangulation`,
:class:`~simplexspline.SplineSpace`, :class:`~simplexspline.SimplexSpline`) behind the
``fit`` / ``predict`` / ``score`` / ``get_params`` / ``set_params`` protocol, so a simplex
spline can be used in :class:`sklearn.pipeline.Pipeline`, tuned by
:class:`sklearn.model_selection.GridSearchCV` and cross-validated like any regressor.

scikit-learn is optional: when it is installed the estimator subclasses its
``RegressorMixin`` and ``BaseEstimator`` (and uses its input validation, so it behaves
exactly like the library's own estimators); without it, equivalent ``get_params``,
``set_params``, ``score`` and input validation are provided by
:mod:`simplexspline.estimator.compat`.

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

import numbers
from math import comb, factorial

import numpy as np

from simplexspline.estimator.compat import (
    HAVE_SKLEARN,
    ESTIMATOR_BASES,
    check_weights,
    fallback_validate_X,
    fallback_validate_y,
    is_int,
    sk_call,
    SklearnNotFittedError,
)
from simplexspline.estimator.solve import solve_outputs
from simplexspline.errors import InputError
from simplexspline.spline.bform import num_basis
from simplexspline.spline.space import SimplexSpline
from simplexspline.spline.geometry.outside import AERO_POLICIES, check_policy
from simplexspline.spline.geometry.triangulation import Triangulation
from simplexspline.spline.inputs import MAX_BASIS_PER_SIMPLEX, check_degree

__all__ = [
    "SimplexSplineRegressor",
    "NotFittedError",
    "TRIANGULATIONS",
    "GRID_SIMPLEX_LIMIT",
    "HAVE_SKLEARN",
]


#: Triangulations the estimator can build (or pass a :class:`Triangulation`).
TRIANGULATIONS = ("auto", "grid", "simplex")

#: Largest Kuhn grid (``m! * prod(resolution)`` simplices before empty ones are dropped)
#: the estimator builds; :meth:`Triangulation.fit` materialises the whole grid first.
#: ``triangulation='auto'`` uses a grid while ``m!`` stays within it (up to 8 features).
GRID_SIMPLEX_LIMIT = 100_000

#: Relative tolerance of the box tests in model coordinates (as the locators' INSIDE_TOL).
_BOX_TOL = 1e-10


class NotFittedError(InputError, SklearnNotFittedError):
    """A :class:`SimplexSplineRegressor` used before ``fit``.

    Derives from the package's :class:`~simplexspline.InputError` and, when scikit-learn is
    installed, from :class:`sklearn.exceptions.NotFittedError` (otherwise from
    ``AttributeError``), so either family catches it.
    """


# --------------------------------------------------------------------------- estimator
class SimplexSplineRegressor(*ESTIMATOR_BASES):
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
        w = check_weights(sample_weight, len(X))
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
        if not is_int(continuity) or continuity < -1:
            raise InputError(f"continuity must be an integer >= -1 (-1: no continuity), got "
                             f"{continuity!r}")
        res = self.resolution
        if is_int(res):
            res = (int(res),) * n_features
        try:
            res = tuple(res)
        except TypeError:
            raise InputError(f"resolution must be a positive integer or a tuple of "
                             f"{n_features} of them, got {self.resolution!r}") from None
        if len(res) != n_features or not all(is_int(k) and k >= 1 for k in res):
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
        if not is_int(self.min_points) or self.min_points < 1:
            raise InputError(f"min_points must be an integer >= 1, got {self.min_points!r}")
        ridge = self.ridge
        if (isinstance(ridge, bool) or not isinstance(ridge, numbers.Real)
                or not np.isfinite(ridge) or ridge < 0):
            raise InputError(f"ridge must be a finite number >= 0, got {ridge!r}")
        if not isinstance(self.outside, str):
            raise InputError(f"outside must be one of {AERO_POLICIES}, got {self.outside!r}")
        check_policy(self.outside, AERO_POLICIES)
        if not isinstance(self.scale, (bool, np.bool_)):
            raise InputError(f"scale must be True or False, got {self.scale!r}")
        if not is_int(self.max_coefficients) or self.max_coefficients < 1:
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
        return solve_outputs(tri, kind, U, Y, w, cfg)

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
        if not is_int(output) or not 0 <= output < self.n_outputs_:
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
            out = sk_call(self, X, y, reset=True, multi_output=True, y_numeric=True)
            X, Y = out
        else:
            X = fallback_validate_X(self, X, reset=True)
            Y = fallback_validate_y(y, len(X))
        X = np.asarray(X, dtype=float)
        Y = np.asarray(Y, dtype=float)
        if Y.ndim == 2 and Y.shape[1] == 0:
            raise InputError("y has no columns (shape (N, 0)): nothing to fit")
        return X, Y

    def _validate_X(self, X):
        if HAVE_SKLEARN:
            X = sk_call(self, X, None, reset=False)
        else:
            X = fallback_validate_X(self, X, reset=False)
        return np.asarray(X, dtype=float)
