"""Known sensor geometry and calibration applied before the filter, and lag estimates after.

Numeric kernels on plain arrays (one maneuver, uniform sampling). The geometry comes from
metadata ``sensor_geometry`` (:func:`simplexspline.aero.data.flight_data.sensor_geometry`);
the c.g. from the ``x_cg, y_cg, z_cg`` columns when present.

* Lags: a channel recorded ``lag`` seconds late is moved back, ``z(t) <- z(t + lag)``
  (linear interpolation; the last ``lag`` seconds of a measurement become NaN, i.e. not
  measured; IMU inputs hold their last value).
* Vanes: ``angle = (reading - offset) / scale``; the position enters the measurement model
  as ``omega x r`` (:func:`rotation_velocity`).
* Accelerometers away from the c.g.: ``a_cg = a - omega x (omega x r) - omegadot x r``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["undo_lag", "rotation_velocity", "lever_arm_acceleration", "specific_force_at_cg",
           "estimate_lag",
           "estimate_lag_from_response"]


def undo_lag(x: np.ndarray, dt: float, lag: float, *, hold: bool = False) -> np.ndarray:
    """The channel as if recorded without its lag: ``y[k] = x(t_k + lag)``.

    A lag that is not a whole number of samples is undone by the cubic through the four
    nearest samples (exact for cubics; linear next to the ends and next to a missing
    sample). Linear interpolation half a sample away damps a motion of frequency f by
    cos(pi f dt): 5 % at 1 Hz in a 10 Hz record, and on a real-like record a vane's
    0.05 s lag undone that way made its reconstructed excursions 0.4 % small (a vane
    scale error estimated at -0.0044 +- 0.0020 where there was none).

    Parameters
    ----------
    x : (n,) ndarray
        Samples at uniform spacing ``dt`` [s].
    dt, lag : float
        Sample interval and lag [s] (lag >= 0).
    hold : bool
        Beyond the record hold the last value (inputs) instead of NaN (measurements).

    Returns
    -------
    (n,) ndarray
    """
    x = np.asarray(x, dtype=float)
    if lag == 0 or x.size < 2:
        return x.copy()
    n = x.size
    k = np.arange(n) + lag / dt
    y = np.interp(k, np.arange(n), x)
    i = np.floor(k).astype(np.int64)
    f = k - i
    inner = (i >= 1) & (i + 2 <= n - 1) & (f > 0)
    if inner.any():
        j, t = i[inner], f[inner]
        w = np.stack([-t * (t - 1) * (t - 2) / 6, (t + 1) * (t - 1) * (t - 2) / 2,
                      -(t + 1) * t * (t - 2) / 2, (t + 1) * t * (t - 1) / 6])
        cubic = sum(w[m] * x[j + m - 1] for m in range(4))
        y[inner] = np.where(np.isfinite(cubic), cubic, y[inner])
    if not hold:
        y[k > n - 1] = np.nan
    return y


def rotation_velocity(rates: np.ndarray, arm: np.ndarray) -> np.ndarray:
    """``omega x r`` [m/s] per sample: the velocity a point at arm ``r`` adds to the c.g.'s.

    Parameters
    ----------
    rates : (n, 3) ndarray
        Body rates p, q, r [rad/s].
    arm : (3,) or (n, 3) ndarray
        Position from the c.g., body axes [m].

    Returns
    -------
    (n, 3) ndarray
    """
    return np.cross(rates, np.broadcast_to(arm, rates.shape))


def lever_arm_acceleration(rates: np.ndarray, wdot: np.ndarray, arm: np.ndarray
                           ) -> np.ndarray:
    """``omegadot x r + omega x (omega x r)`` [m/s^2]: what accelerometers at arm ``r``
    read beyond the specific force at the c.g.

    Parameters
    ----------
    rates : (n, 3) ndarray
        Body rates [rad/s].
    wdot : (n, 3) ndarray
        Angular accelerations [rad/s^2].
    arm : (3,) or (n, 3) ndarray
        Accelerometer position from the c.g., body axes [m].

    Returns
    -------
    (n, 3) ndarray
    """
    r = np.broadcast_to(arm, rates.shape)
    return np.cross(wdot, r) + np.cross(rates, np.cross(rates, r))


def specific_force_at_cg(acc: np.ndarray, rates: np.ndarray, dt: float,
                         arm: np.ndarray) -> np.ndarray:
    """Specific force at the c.g. from accelerometers at arm ``r``.

    ``a_cg = a - omega x (omega x r) - omegadot x r``, with omegadot the central difference of
    the rates (one-sided at the ends).

    Parameters
    ----------
    acc : (n, 3) ndarray
        Measured specific force [m/s^2].
    rates : (n, 3) ndarray
        Body rates [rad/s].
    dt : float
        Sample interval [s].
    arm : (3,) or (n, 3) ndarray
        Accelerometer position from the c.g. [m].

    Returns
    -------
    (n, 3) ndarray
    """
    wdot = np.gradient(rates, dt, axis=0) if len(rates) > 1 else np.zeros_like(rates)
    return acc - lever_arm_acceleration(rates, wdot, arm)


def estimate_lag(residual: np.ndarray, rate_of_change: np.ndarray,
                 confounders: np.ndarray | None = None) -> tuple[float, float]:
    """Lag of a channel from its residual against the reconstruction: ``e ~ c - lag * ydot``.

    A channel recorded ``lag`` seconds late differs from the reconstructed signal ``y`` by
    ``-lag * ydot`` to first order; a least-squares fit with a constant gives the lag and
    its standard error.

    Parameters
    ----------
    residual : (n,) ndarray
        Measured minus reconstructed (NaN where not measured).
    rate_of_change : (n,) ndarray
        Time derivative of the reconstructed signal [unit/s].
    confounders : (n, m) ndarray, optional
        Effects fitted together with the lag (the residual taken without them): a vane's
        position error along x makes ``-q dx / V``, which the short period's ``alphadot``
        resembles, and a filter that estimates the position takes up most of a lag
        (a 0.08 s angle-of-attack lag at 100 Hz came out at 0.008 s against the
        reconstruction with the position estimated).

    Returns
    -------
    lag, sigma : float
        Lag [s] (positive: the channel is late) and its standard error; NaN when the
        signal does not change enough to tell.
    """
    extra = (np.zeros((np.size(residual), 0)) if confounders is None
             else np.asarray(confounders, dtype=float).reshape(np.size(residual), -1))
    ok = np.isfinite(residual) & np.isfinite(rate_of_change) & np.isfinite(extra).all(axis=1)
    e, d, c = residual[ok], rate_of_change[ok], extra[ok]
    if e.size < 10 + c.shape[1]:
        return float("nan"), float("nan")
    X = np.column_stack([-d, c])
    X = X - X.mean(axis=0)
    e = e - e.mean()
    if not float(X[:, 0] @ X[:, 0]) > 0:
        return float("nan"), float("nan")
    try:
        cov = np.linalg.inv(X.T @ X)
    except np.linalg.LinAlgError:
        return float("nan"), float("nan")
    beta = cov @ (X.T @ e)
    res = e - X @ beta
    dof = max(e.size - 1 - X.shape[1], 1)
    sigma = float(np.sqrt((res @ res) / dof * cov[0, 0]))
    return float(beta[0]), sigma


def estimate_lag_from_response(channel: np.ndarray, response: np.ndarray,
                               regressors: np.ndarray, dt: float, *,
                               max_lag_s: float = 0.25) -> tuple[float, float]:
    """Lag of a channel against a response that follows the sensed quantity at once.

    In turbulence the reconstruction follows a late vane (the gusts are free to take its
    delay), so :func:`estimate_lag` finds no lag there. The aerodynamic force does not
    wait: the normal specific force responds to the air's angle of attack without delay,
    and the accelerometers are the filter's time base. The lag is the shift ``tau`` that,
    undone (:func:`undo_lag`), lets ``response ~ 1 + c x(t + tau) + d x(t + tau)^2 +
    regressors`` explain the response best (least squares; a grid of a fifth of a sample,
    refined by the parabola through the best three). Its standard error comes from the
    curvature of the residual sum of squares, ``var = 2 s^2 / RSS''``, inflated by
    ``(1 + rho) / (1 - rho)`` for the residuals' lag-one autocorrelation ``rho`` (the
    gusts the model does not follow are coloured).

    Parameters
    ----------
    channel : (n,) ndarray
        The late channel (NaN where not measured), uniform spacing ``dt``.
    response : (n,) ndarray
        What follows the sensed quantity without delay (for the angle of attack: the
        normal specific force over the dynamic pressure, ``a_z / (rho V^2)``).
    regressors : (n, m) ndarray
        Other effects on the response (for the normal force: ``q / V``, which also takes a
        vane's rotation term ``q x / V``).
    dt : float
        Sample interval [s].
    max_lag_s : float
        Largest lag tried either way [s].

    Returns
    -------
    lag, sigma : float
        Lag [s] (positive: the channel is late) and its standard error; NaN when the
        best shift lies at the edge of the range or the channel does not move enough.
    """
    x = np.asarray(channel, dtype=float)
    y = np.asarray(response, dtype=float)
    extra = np.asarray(regressors, dtype=float).reshape(x.size, -1)
    step = dt / 5.0
    taus = np.arange(-max_lag_s, max_lag_s + 0.5 * step, step)
    edge = int(np.ceil(max_lag_s / dt)) + 2
    keep = np.zeros(x.size, dtype=bool)
    keep[edge:x.size - edge] = True
    keep &= np.isfinite(y) & np.isfinite(extra).all(axis=1)
    # either way: the ends, where a shift reaches beyond the record, are left out
    shifted = [undo_lag(x, dt, float(t)) for t in taus]
    for s_ in shifted:
        keep &= np.isfinite(s_)
    n = int(keep.sum())
    if n < 20 + extra.shape[1]:
        return float("nan"), float("nan")
    rss, best = np.empty(taus.size), None
    for i, s_ in enumerate(shifted):
        a = s_[keep]
        A = np.column_stack([np.ones(n), a, a * a, extra[keep]])
        coef, *_ = np.linalg.lstsq(A, y[keep], rcond=None)
        r = y[keep] - A @ coef
        rss[i] = float(r @ r)
        if best is None or rss[i] < float(best @ best):
            best = r
    i = int(np.argmin(rss))
    if i == 0 or i == taus.size - 1 or not np.isfinite(rss[i]):
        return float("nan"), float("nan")
    r0, r1, r2 = rss[i - 1], rss[i], rss[i + 1]
    curv = (r0 - 2 * r1 + r2) / step ** 2          # RSS''
    if not curv > 0:
        return float("nan"), float("nan")
    lag = float(taus[i] + 0.5 * step * (r0 - r2) / (r0 - 2 * r1 + r2))
    rho = float(np.clip(best[1:] @ best[:-1] / max(r1, 1e-300), 0.0, 0.95))
    s2 = r1 / max(n - 3 - extra.shape[1] - 1, 1)
    sigma = float(np.sqrt(2.0 * s2 / curv * (1 + rho) / (1 - rho)))
    return lag, sigma
