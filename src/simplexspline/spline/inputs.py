"""Input validation at the public boundary: shapes, finiteness, dimensions."""

from __future__ import annotations

import math

import numpy as np

from simplexspline.errors import InputError

__all__ = ["MAX_BASIS_PER_SIMPLEX", "as_points", "as_values", "as_weights", "check_basis_size",
           "check_degree"]


def _finite(arr: np.ndarray, name: str) -> None:
    if not np.isfinite(arr).all():  # the method: np.all's wrapper costs 1-2 us a call
        bad = np.nonzero(~np.isfinite(arr.reshape(len(arr), -1)).all(axis=1))[0]
        raise InputError(
            f"{name} contains NaN or inf in {len(bad)} rows (first: {bad[:5].tolist()}); "
            "remove or repair those samples"
        )


def _as_float(x, name: str) -> np.ndarray:
    """``x`` as a float array; complex input is refused (numpy would drop the imaginary
    part with only a warning)."""
    try:
        if np.iscomplexobj(x):
            raise InputError(f"{name} is complex: give real numbers (for example {name}.real "
                             "if the imaginary parts are zero)")
        return np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(f"{name} must be a numeric array: {exc}") from None


def as_points(x, *, name: str = "x", ndim: int | None = None) -> np.ndarray:
    """Points as a finite float array of shape (N, n).

    A 1-D array is taken as N points in 1-D when ``ndim`` is 1 (or unknown), or as a single
    point when it has ``ndim > 1`` entries.
    """
    arr = _as_float(x, name)
    if arr.ndim == 1:
        if ndim is not None and ndim > 1 and arr.shape[0] == ndim:
            arr = arr[None, :]
        else:
            arr = arr[:, None]
    if arr.ndim != 2:
        raise InputError(f"{name} must have shape (N, n), got {arr.shape}")
    if ndim is not None and arr.shape[1] != ndim:
        raise InputError(
            f"{name} has {arr.shape[1]} columns but the triangulation is {ndim}-dimensional"
        )
    if arr.shape[1] < 1:
        raise InputError(f"{name} must have at least one column")
    _finite(arr, name)
    return np.ascontiguousarray(arr)


def as_values(y, npts: int, *, name: str = "y") -> np.ndarray:
    """Observations as a finite float array of shape (N,)."""
    arr = _as_float(y, name)
    if arr.ndim == 0:
        raise InputError(f"{name} must hold one value per point, shape ({npts},); got a "
                         "single number")
    if arr.ndim != 1:
        raise InputError(f"{name} must be one-dimensional with shape ({npts},), got {arr.shape}; "
                         "fit one output at a time")
    if arr.shape != (npts,):
        raise InputError(f"{name} must have shape ({npts},) to match x, got {arr.shape}")
    _finite(arr, name)
    return arr


def as_weights(w, npts: int) -> np.ndarray | None:
    """Per-sample weights (inverse variances) as a finite, non-negative array (N,); a
    single number is the same weight for every sample (as scikit-learn's sample_weight)."""
    if w is None:
        return None
    if np.ndim(w) == 0:
        w = np.full(npts, _as_float(w, "weights"))
    arr = as_values(w, npts, name="weights")
    if np.any(arr < 0):
        raise InputError(f"weights must be >= 0; {int((arr < 0).sum())} are negative")
    return arr


def check_degree(degree, continuity) -> tuple[int, int]:
    """Validate the spline degree d >= 0 and continuity -1 <= r < d."""
    for name, v in (("degree", degree), ("continuity", continuity)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise InputError(f"{name} must be an integer, got {v!r}")
    d, r = int(degree), int(continuity)
    if d < 0:
        raise InputError(f"degree must be >= 0, got d={d}")
    if r < -1:
        raise InputError(f"continuity must be >= -1 (-1: no continuity), got r={r}")
    if r >= d and not (d == 0 and r == -1):
        raise InputError(
            f"continuity must be below the degree (r < d), got r={r} >= d={d}: a C^r spline "
            f"of degree {d} with r >= d is a single global polynomial; lower r or raise d"
        )
    return d, r


#: Largest number of B-coefficients per simplex, d_hat = C(n + d, d): one Gram block is
#: d_hat^2 doubles (6000: 288 MB), and the smoothness conditions grow with it.
MAX_BASIS_PER_SIMPLEX = 6000


def check_basis_size(ndim: int, degree: int) -> int:
    """d_hat = C(n + d, d) for a space of degree ``degree`` in ``ndim`` dimensions, checked
    against :data:`MAX_BASIS_PER_SIMPLEX` before anything of that size is allocated.

    Raises
    ------
    InputError
        Naming d_hat and what to lower.
    """
    dhat = math.comb(int(ndim) + int(degree), int(degree))
    if dhat > MAX_BASIS_PER_SIMPLEX:
        raise InputError(
            f"a polynomial piece of degree {degree} in {ndim} dimensions has {dhat:,} "
            f"B-coefficients, above the limit {MAX_BASIS_PER_SIMPLEX:,} "
            "(MAX_BASIS_PER_SIMPLEX): lower the degree, or split the variables into "
            "smaller models")
    return dhat
