"""scikit-learn compatibility and input validation of the estimator.

:class:`~simplexspline.estimator.regressor.SimplexSplineRegressor` works with or without
scikit-learn. This module holds everything that depends on which case applies:

* the optional import of scikit-learn (:data:`HAVE_SKLEARN`) and the base classes of the
  estimator, ``ESTIMATOR_BASES``: scikit-learn's ``RegressorMixin`` and ``BaseEstimator`` when it is
  installed, else the fallbacks :class:`_FallbackRegressorMixin` (``score``) and
  :class:`_FallbackBaseEstimator` (``get_params``, ``set_params``, ``repr``), which behave
  as scikit-learn's;
* input validation: scikit-learn's own (``sk_call``, its ValueErrors turned into
  :class:`~simplexspline.InputError`) or an equivalent without it
  (``fallback_validate_X``, ``fallback_validate_y``), and the checks used in either case
  (``check_weights``, ``is_int``).

Private to :mod:`simplexspline.estimator.regressor`, which re-exports these names.
"""

from __future__ import annotations

import inspect
import numbers
import warnings

import numpy as np
import scipy.sparse as sp

from simplexspline.errors import InputError, SimplexSplineError

try:  # scikit-learn is optional
    from sklearn.base import BaseEstimator as _BaseEstimator
    from sklearn.base import RegressorMixin as _RegressorMixin
    from sklearn.exceptions import NotFittedError as SklearnNotFittedError

    try:  # scikit-learn >= 1.6
        from sklearn.utils.validation import validate_data as _sk_validate_data
    except ImportError:  # pragma: no cover - older scikit-learn
        _sk_validate_data = None
    HAVE_SKLEARN = True
except ImportError:  # pragma: no cover - exercised by a subprocess test
    HAVE_SKLEARN = False
    _sk_validate_data = None
    SklearnNotFittedError = AttributeError
    _BaseEstimator = None
    _RegressorMixin = None

__all__ = ["HAVE_SKLEARN"]


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
        w = np.ones(len(y)) if sample_weight is None else check_weights(sample_weight,
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
    ESTIMATOR_BASES = (_RegressorMixin, _BaseEstimator)
else:  # pragma: no cover - exercised by a subprocess test
    ESTIMATOR_BASES = (_FallbackRegressorMixin, _FallbackBaseEstimator)


# --------------------------------------------------------------------------- validation
def is_int(v) -> bool:
    return isinstance(v, (numbers.Integral, np.integer)) and not isinstance(v, (bool, np.bool_))


def sk_call(est, X, y, *, reset: bool, **kw):
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


def fallback_validate_X(est, X, *, reset: bool) -> np.ndarray:
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


def fallback_validate_y(y, npts: int) -> np.ndarray:
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


def check_weights(sample_weight, npts: int):
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

