"""Initial heading and wind of a maneuver without a heading channel: the wind triangle.

Without a heading channel the filter starts from a heading guess. The GPS track is wrong by
the crab angle (crosswind / airspeed, 0.03-0.06 rad for 5-12 m/s of wind at 200 m/s), and
in straight flight the filter cannot correct it: a heading error ``d`` and a crosswind error
``V d`` give the same GPS positions, the same air data and (with a lateral accelerometer
bias to match) the same specific forces. Measured on a 6-maneuver real-like f16 campaign
(no heading, no beta vane, GPS positions only, wind 5-12 m/s): started from the GPS track,
the smoothed heading stayed 0.007-0.07 rad off and the wind 0.9-10 m/s off, with reported
sigmas of 0.1-0.6 m/s; started from the true heading, the wind was within 0.2-0.45 m/s.

A heading *change* separates them: the air-relative velocity turns with the aircraft, a
constant wind does not. Over the maneuver the horizontal GPS track obeys, as complex numbers
(north + i east),

    P(t) = P0 + exp(i psi0) A(t) + W t,    A(t) = int_0^t C_nb(phi, theta, psi_rel) v_air dt

with ``psi_rel`` the heading change integrated from the gyros and attitude, ``v_air`` the
air-relative body velocity from airspeed, angle of attack and sideslip (0 without a vane).
``P0`` and ``W`` enter linearly: with them projected out, ``psi0`` is the rotation that
best maps the detrended air track onto the detrended GPS track (a 2-D Procrustes problem,
closed form), and ``W`` follows. With a heading change of 0.9-2.1 rad this gave the heading
within 0.004-0.013 rad and the wind within 0.6 m/s on the same campaign; below about
0.3 rad of heading change the rotation is decided by the model errors (a vane offset, an
unknown sideslip) and the GPS track is the better guess.

Numeric kernel on plain arrays (one maneuver); the driver is
:mod:`simplexspline.aero.reconstruction.reconstruct`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

__all__ = ["MIN_HEADING_CHANGE", "WindTriangle", "wind_triangle"]

#: Heading change [rad] below which the wind triangle does not determine the heading.
MIN_HEADING_CHANGE = 0.3


class WindTriangle(NamedTuple):
    """Heading at the first sample and constant wind from the wind triangle."""

    psi0: float            #: heading at the first sample [rad]
    wind_n: float          #: wind towards north [m/s]
    wind_e: float          #: wind towards east [m/s]
    heading_change: float  #: max - min of the gyro heading over the maneuver [rad]
    residual: float        #: RMS of the horizontal track residual per axis [m]


def _cumulative(x: np.ndarray, dt: float) -> np.ndarray:
    """Trapezoidal running integral, starting at 0."""
    out = np.zeros_like(x)
    out[1:] = np.cumsum(0.5 * (x[1:] + x[:-1])) * dt
    return out


def _filled(x: np.ndarray) -> np.ndarray:
    """NaN samples linearly interpolated (held at the ends)."""
    ok = np.isfinite(x)
    if ok.all() or not ok.any():
        return x
    k = np.arange(x.size)
    return np.interp(k, k[ok], x[ok])


def wind_triangle(dt: float, tas: np.ndarray, alpha: np.ndarray, beta: np.ndarray | None,
                  phi: np.ndarray, theta: np.ndarray, q: np.ndarray, r: np.ndarray,
                  north: np.ndarray, east: np.ndarray) -> WindTriangle | None:
    """Heading at the first sample and the constant wind that best explain the GPS track.

    Parameters
    ----------
    dt : float
        Sample interval [s] (uniform sampling).
    tas : (n,) ndarray
        Airspeed [m/s].
    alpha, beta : (n,) ndarray
        Angle of attack and sideslip [rad]; ``beta`` None (no vane): zero.
    phi, theta : (n,) ndarray
        Bank and pitch attitude [rad].
    q, r : (n,) ndarray
        Body pitch and yaw rates [rad/s].
    north, east : (n,) ndarray
        Horizontal GPS track [m] (positions, or integrated GPS velocities); NaN where not
        measured.

    Returns
    -------
    WindTriangle or None
        None when fewer than 10 samples have a GPS track and air data.
    """
    V = _filled(np.asarray(tas, dtype=float))
    a = _filled(np.asarray(alpha, dtype=float))
    b = np.zeros_like(V) if beta is None else np.nan_to_num(_filled(np.asarray(beta, float)))
    phi = _filled(np.asarray(phi, dtype=float))
    theta = _filled(np.asarray(theta, dtype=float))
    psidot = (np.asarray(q, dtype=float) * np.sin(phi)
              + np.asarray(r, dtype=float) * np.cos(phi)) / np.cos(theta)
    psi = _cumulative(psidot, dt)
    ub, vb, wb = V * np.cos(a) * np.cos(b), V * np.sin(b), V * np.sin(a) * np.cos(b)
    cf, sf, ct, st = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta)
    cp, sp = np.cos(psi), np.sin(psi)
    vn = ct * cp * ub + (sf * st * cp - cf * sp) * vb + (cf * st * cp + sf * sp) * wb
    ve = ct * sp * ub + (sf * st * sp + cf * cp) * vb + (cf * st * sp - sf * cp) * wb
    A = _cumulative(vn + 1j * ve, dt)
    P = np.asarray(north, dtype=float) + 1j * np.asarray(east, dtype=float)
    ok = np.isfinite(P) & np.isfinite(A)
    if ok.sum() < 10:
        return None
    t = np.arange(V.size)[ok] * dt
    A, P = A[ok], P[ok]
    X = np.column_stack([np.ones_like(t), t - t.mean()])

    def detrend(y):
        return y - X @ np.linalg.lstsq(X, y, rcond=None)[0]

    Ad, Pd = detrend(A), detrend(P)
    cross = np.sum(np.conj(Ad) * Pd)
    rot = cross / abs(cross) if abs(cross) > 0 else 1.0 + 0j
    coef = np.linalg.lstsq(X, P - rot * A, rcond=None)[0]
    res = P - rot * A - X @ coef
    return WindTriangle(psi0=float(np.angle(rot)), wind_n=float(coef[1].real),
                        wind_e=float(coef[1].imag),
                        heading_change=float(psi.max() - psi.min()),
                        residual=float(math.sqrt(np.mean(np.abs(res) ** 2) / 2)))
