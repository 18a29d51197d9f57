"""Smoothed numerical differentiation of sampled signals (angular accelerations from rates).

Method: a local least-squares polynomial (Savitzky-Golay) derivative over an even window of
``2 m`` samples centred on the *midpoint* ``t_k + dt/2`` between samples k and k + 1. For
signals that are polynomials of degree <= ``degree`` inside the window it is exact. With
``m = 1`` it is the forward difference ``(x[k+1] - x[k]) / dt``, the convention of the
flight-data schema (JSBSim integrates the rates with explicit Euler, so ``pdot[k]`` is the
forward difference of ``p``).

Phase lag: the window is symmetric about the point where the derivative is wanted, so the
filter has **zero phase lag** with respect to the forward-difference convention (a constant
lead of ``dt / 2`` with respect to sample time ``t_k``, which is exactly the convention).
The price is amplitude attenuation at high frequency. For the defaults (m = 8, i.e. a
16-sample window of 0.16 s at 100 Hz, degree 4) the derivative's gain is -3 dB at 7.9 Hz
and the white-noise gain is 0.097 times that of the forward difference; m = 12 with
degree 2 would give 2.4 Hz and 0.021 (smoother but it flattens 3211 pulses: 1.5 % relative
RMS error in Cm on noise-free simulated data, against 0.13 % for the defaults). Near the ends
of the record the window is shifted inside the data (one-sided fits), which keeps the degree but
not the zero phase.

**Records sampled coarser than the simulator's step** (:data:`SIMULATOR_STEP_MAX_S`; real
records at 10-50 Hz) are instantaneous samples of a continuous motion, not an Euler
integration: there the derivative is wanted *at* the sample (:func:`sample_derivative`, an
odd window ``k - m .. k + m``), and 16 samples would span 1.6 s at 10 Hz (-3 dB at 0.8 Hz,
below a short period's frequency). The default half window is then 0.08 s, as at 100 Hz,
but at least 2 samples (:data:`HALF_WINDOW_S`). Measured on simulated 10 Hz records without
angular accelerations (four aircraft, light turbulence), the reconstructed Cl, Cm and Cn's
RMS errors against the truth fell by 30-80 % against the 16-sample midpoint derivative
(docs/reconstruction.md, "Angular accelerations").
"""

from __future__ import annotations

import numpy as np

from simplexspline.errors import InputError

__all__ = ["HALF_WINDOW_S", "SIMULATOR_STEP_MAX_S", "derivative_by_maneuver",
           "derivative_weights", "matched_by_maneuver", "matched_smoothing", "matched_weights",
           "midpoint_derivative", "sample_derivative"]

#: Largest sample interval [s] taken as the simulator's own step (JSBSim's explicit Euler at
#: 100 Hz): the forward-difference (midpoint) convention of the flight-data schema applies.
#: Coarser records are samples of a continuous motion.
SIMULATOR_STEP_MAX_S = 0.0101
#: Half width [s] of the default window of a coarser record's derivative (that of the
#: 16-sample window at 100 Hz); at least 2 samples.
HALF_WINDOW_S = 0.08


def derivative_weights(positions: np.ndarray, at: float, degree: int) -> np.ndarray:
    """Weights w such that ``sum(w * x)`` is the derivative at ``at`` of the LS polynomial.

    Parameters
    ----------
    positions : (k,) ndarray
        Sample positions in units of the sample interval.
    at : float
        Where the derivative is wanted (same units).
    degree : int
        Polynomial degree (< k).
    """
    s = np.asarray(positions, dtype=float) - at
    V = np.vander(s, degree + 1, increasing=True)       # columns 1, s, s^2, ...
    # derivative at s = 0 is the coefficient of s: second row of the pseudo-inverse
    return np.linalg.pinv(V)[1]


def _checked(x, half_window: int, degree: int) -> tuple[np.ndarray, int]:
    """The samples as floats and the half window, or InputError naming what is wrong."""
    x = np.asarray(x, dtype=float)
    m = int(half_window)
    if m < 1 or degree < 1:
        raise InputError(f"need half_window >= 1 and degree >= 1; got "
                         f"half_window={half_window}, degree={degree}")
    if x.size < 2:
        raise InputError(f"need at least 2 samples to differentiate, got {x.size}")
    return x, m


def midpoint_derivative(x, dt: float, half_window: int = 8, degree: int = 4) -> np.ndarray:
    """Smoothed derivative of a uniformly sampled signal, in the forward-difference convention.

    Parameters
    ----------
    x : (n,) array_like
        Samples (finite).
    dt : float
        Sample interval [s].
    half_window : int
        m: the fit uses 2 m samples (k - m + 1 .. k + m). 1 gives the plain forward
        difference.
    degree : int
        Polynomial degree of the local fit (reduced to 2 m - 1 when larger).

    Returns
    -------
    (n,) ndarray
        Derivative estimate at ``t_k + dt / 2`` for k = 0 .. n - 1 (the last sample uses the
        one-sided fit at ``t_{n-1} + dt/2``). Units of x per second.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(50) * 0.01
    >>> d = midpoint_derivative(t**2, 0.01, half_window=4)
    >>> bool(np.allclose(d, 2 * (t + 0.005)))
    True
    """
    x, m = _checked(x, half_window, degree)
    degree = min(int(degree), 2 * m - 1)
    n = x.size
    w = 2 * m
    if n < w:
        m = n // 2
        w = 2 * m if n >= 2 * m else n
        degree = min(degree, w - 1)
    out = np.empty(n)
    pos = np.arange(w, dtype=float)
    centre = derivative_weights(pos, m - 0.5, degree) / dt
    # interior: output k uses x[k-m+1 .. k+m]
    if n >= w:
        conv = np.convolve(x, centre[::-1], mode="valid")   # length n - w + 1
        out[m - 1:n - m] = conv
    for k in list(range(0, m - 1)) + list(range(n - m, n)):
        start = min(max(k - m + 1, 0), n - w)
        wk = derivative_weights(pos, k + 0.5 - start, degree) / dt
        out[k] = wk @ x[start:start + w]
    return out


def sample_derivative(x, dt: float, half_window: int = 2, degree: int = 4) -> np.ndarray:
    """Smoothed derivative of a uniformly sampled signal at its samples (a record sampled
    coarser than the simulator's step).

    Parameters
    ----------
    x, dt
        As for :func:`midpoint_derivative`.
    half_window : int
        m: the fit uses the 2 m + 1 samples k - m .. k + m (shifted inside the data at the
        ends).
    degree : int
        Polynomial degree of the local fit (reduced to 2 m when larger: interpolation).

    Returns
    -------
    (n,) ndarray
        Derivative estimate at ``t_k`` for k = 0 .. n - 1, in units of x per second.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(30) * 0.1
    >>> d = sample_derivative(t**3, 0.1, half_window=2, degree=3)
    >>> bool(np.allclose(d, 3 * t**2))
    True
    """
    x, m = _checked(x, half_window, degree)
    return _odd_window(x, m, degree, lambda pos, at, d: derivative_weights(pos, at, d) / dt)


def _odd_window(x: np.ndarray, m: int, degree: int, weights) -> np.ndarray:
    """``sum(weights(positions, at, degree) * window)`` at every sample of ``x``: the window
    ``k - m .. k + m`` (shifted inside the data at the ends, all of ``x`` when shorter), the
    weights evaluated at the sample's place in it (:func:`sample_derivative`,
    :func:`matched_smoothing`)."""
    n = x.size
    w = min(2 * m + 1, n)
    degree = min(int(degree), w - 1)
    pos = np.arange(w, dtype=float)
    out = np.empty(n)
    if w == 2 * m + 1:
        out[m:n - m] = np.convolve(x, weights(pos, float(m), degree)[::-1], mode="valid")
        ends = list(range(0, m)) + list(range(n - m, n))
    else:
        ends = range(n)
    for k in ends:
        start = min(max(k - m, 0), n - w)
        out[k] = weights(pos, k - start, degree) @ x[start:start + w]
    return out


def derivative_by_maneuver(maneuver, t, values, *, half_window: int | None = None,
                           degree: int = 4) -> np.ndarray:
    """Smoothed time derivatives of signals, maneuver by maneuver (never across maneuvers).

    Parameters
    ----------
    maneuver : (n,) array_like
        Maneuver id per sample.
    t : (n,) array_like
        Time [s]; uniform sampling within a maneuver (its median step is used).
    values : (n,) or (n, k) array_like
        Signals to differentiate.
    half_window : int, optional
        See :func:`midpoint_derivative` and :func:`sample_derivative`. None (default): 8
        at the simulator's step, else :data:`HALF_WINDOW_S` at the maneuver's rate (at
        least 2 samples).
    degree : int
        Polynomial degree of the local fits.

    Returns
    -------
    ndarray, shape of ``values``
        Derivatives per second, in the input's row order; NaN for a signal of a maneuver
        that holds a NaN or only one sample. A maneuver sampled at the simulator's step
        (at most :data:`SIMULATOR_STEP_MAX_S`) gets the forward-difference convention
        (:func:`midpoint_derivative`, at ``t_k + dt/2``), a coarser one the derivative at
        its samples (:func:`sample_derivative`).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.r_[np.arange(20), np.arange(20)] * 0.01
    >>> d = derivative_by_maneuver(np.repeat([1, 2], 20), t, 3.0 * t, half_window=2)
    >>> bool(np.allclose(d, 3.0))
    True
    """
    def derivative(col, dt, m, coarse):
        return (sample_derivative if coarse else midpoint_derivative)(col, dt, m, degree)
    return _by_maneuver(maneuver, t, values, half_window, derivative)


def _half_window(dt: float, half_window: int | None) -> tuple[int, bool]:
    """The half window of a maneuver sampled every ``dt`` seconds, and whether it is
    coarser than the simulator's step (:func:`derivative_by_maneuver`)."""
    if dt <= SIMULATOR_STEP_MAX_S:
        return (8 if half_window is None else half_window), False
    return (max(2, round(HALF_WINDOW_S / dt)) if half_window is None else half_window), True


def _by_maneuver(maneuver, t, values, half_window: int | None, apply) -> np.ndarray:
    """``apply(col, dt, m, coarse)`` on each finite signal of each maneuver in time order
    (NaN for a maneuver's signal that holds a NaN or only one sample), in the input's row
    order; ``m`` and ``coarse`` from :func:`_half_window`."""
    man = np.asarray(maneuver)
    t = np.asarray(t, dtype=float)
    x = np.asarray(values, dtype=float)
    flat = x.ndim == 1
    x2 = x[:, None] if flat else x
    if len(man) != len(t) or len(t) != len(x2):
        raise InputError(f"maneuver, t and values must have equal lengths, got {len(man)}, "
                         f"{len(t)} and {len(x2)}")
    out = np.full(x2.shape, np.nan)
    order = np.argsort(man, kind="stable")
    bounds = np.flatnonzero(man[order][1:] != man[order][:-1]) + 1
    for idx in np.split(order, bounds):
        if idx.size < 2:
            continue
        idx = idx[np.argsort(t[idx], kind="stable")]
        dt = float(np.median(np.diff(t[idx])))
        m, coarse = _half_window(dt, half_window)
        for j in range(x2.shape[1]):
            col = x2[idx, j]
            if np.isfinite(col).all():
                out[idx, j] = apply(col, dt, m, coarse)
    return out[:, 0] if flat else out


def matched_weights(positions, at: float, degree: int) -> np.ndarray:
    """Weights v such that ``sum(v * z)`` is what the derivative weights
    (:func:`derivative_weights` ``(positions, at, degree)``) make of a signal whose
    derivative is ``z``: the smoothing that the derivative filter applies to the derivative.

    A derivative filter ``sum(w_j x(p_j))`` of a continuous signal is an integral of its
    derivative, ``integral K(s) x'(s) ds`` with the kernel ``K(s) = sum of w_j over the
    p_j beyond s`` (counted negative before ``at``), whose integral is 1. The derivative it
    returns is ``K * x'``, not ``x'(at)``: a pitch acceleration differentiated from 10 Hz
    rates is smeared over +-2 samples, by as much as the elevator step that caused it.
    Regressors that enter the same equation linearly must be smeared alike for the equation
    to hold (``K * (a z) = a (K * z)``); with ``z`` linear between samples,
    ``v_i = integral K(s) hat_i(s) ds`` makes that exact: for ``x' = z``,
    ``sum(w * x) == sum(v * z)`` (Morelli and Klein, *Aircraft System Identification*,
    treat the frequency-domain counterpart: the same filter on both sides of the equation).

    Parameters
    ----------
    positions : (k,) ndarray
        Sample positions in units of the sample interval (consecutive integers).
    at, degree
        As in :func:`derivative_weights`.

    Returns
    -------
    (k,) ndarray
        Weights summing to 1.

    Examples
    --------
    >>> import numpy as np
    >>> np.round(matched_weights(np.arange(5.0), 2.0, 4) * 24, 10)
    array([-1.,  6., 14.,  6., -1.])
    """
    pos = np.asarray(positions, dtype=float)
    w = derivative_weights(pos, at, degree)
    cuts = np.unique(np.r_[pos, at])
    cuts = cuts[(cuts >= pos.min()) & (cuts <= pos.max())]
    v = np.zeros(pos.size)
    for a, b in zip(cuts[:-1], cuts[1:]):
        mid = 0.5 * (a + b)
        k = w[pos > mid].sum() if mid > at else -w[pos < mid].sum()
        hat_a = np.maximum(0.0, 1.0 - np.abs(a - pos))
        hat_b = np.maximum(0.0, 1.0 - np.abs(b - pos))
        v += k * 0.5 * (b - a) * (hat_a + hat_b)
    return v


def matched_smoothing(x, half_window: int = 2, degree: int = 4) -> np.ndarray:
    """A regressor smoothed as :func:`sample_derivative` smooths a derivative (its windows,
    one-sided at the ends, with :func:`matched_weights`).

    Parameters
    ----------
    x : (n,) array_like
        Samples (finite) of a signal that enters an equation with the derivative.
    half_window, degree
        Those of the derivative (:func:`sample_derivative`).

    Returns
    -------
    (n,) ndarray
        For ``x`` linear between samples and ``q' = x``, ``sample_derivative(q) ==
        matched_smoothing(x)`` (to rounding).
    """
    x, m = _checked(x, half_window, degree)
    return _odd_window(x, m, degree, matched_weights)


def matched_by_maneuver(maneuver, t, values, *, half_window: int | None = None,
                        degree: int = 4) -> np.ndarray:
    """Regressors smoothed as :func:`derivative_by_maneuver` smooths the derivatives, maneuver
    by maneuver: :func:`matched_smoothing` where a maneuver is sampled coarser than the
    simulator's step, the values unchanged at the step.

    At the simulator's step the schema's derivative is the forward difference of an explicit
    Euler integration, exact at the sample (not the smoothing of a continuous motion), and
    the 16-sample window's gain is -3 dB only at 7.9 Hz; there is nothing to match.

    Parameters
    ----------
    maneuver, t, values, half_window, degree
        As in :func:`derivative_by_maneuver` (the same settings as the derivatives').

    Returns
    -------
    ndarray, shape of ``values``
        In the input's row order; NaN for a maneuver's signal that holds a NaN or only one
        sample.
    """
    def smooth(col, _dt, m, coarse):
        return matched_smoothing(col, m, degree) if coarse else col
    return _by_maneuver(maneuver, t, values, half_window, smooth)
