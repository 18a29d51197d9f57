"""Aircraft kinematic equations for flight path reconstruction: state model and Jacobians.

The model is driven by the IMU (specific forces and inertial body rates, minus estimated
biases) and is exact for a rigid aircraft over a rotating WGS84 Earth in a local north-east-
down (NED) frame (no aerodynamic model is involved):

    d(V_b)/dt  = f - b_f + C_bn g_n - (omega_ib + omega_ie,b) x V_b
    d(Phi)/dt  = E(phi, theta) (omega_ib - C_bn (omega_ie,n + omega_en,n))
    d(x_n)/dt  = C_nb V_b

with V_b = (u, v, w) the Earth-relative velocity in body axes, omega_ib = gyro - b_omega the
inertial body rate, omega_ie the Earth rate, omega_en the transport rate, g_n the normal
gravity (gravitation plus centrifugal) at the latitude and altitude, and E the Euler-angle
kinematic matrix (3-2-1). The transport rate cancels from the velocity equation. Earth rate
and transport rate are about 1e-4 rad/s, the size of a gyro bias, and Coriolis acceleration
about 0.03 m/s^2, the size of an accelerometer bias: leaving them out would bias the
estimates. In the Jacobians they are treated as known inputs (their state derivatives are
below 1e-6 of the retained terms).

States (28): ``x, y, z`` [m] NED position from the maneuver's first GPS sample; ``u, v, w``
[m/s] (Earth-relative); ``phi, theta, psi`` [rad] (psi is kept unwrapped); accelerometer
biases ``bax, bay, baz`` [m/s^2]; gyro biases ``bp, bq, br`` [rad/s]; air-data errors
``balpha``, ``bbeta`` [rad] (vane offsets) and ``btas`` [m/s] (airspeed bias); the steady
wind ``wind_n, wind_e, wind_d`` [m/s] (NED velocity of the air mass, constant or a random
walk); vane scale-factor errors ``kalpha, kbeta`` [-]; the gusts ``gust_n, gust_e,
gust_d`` [m/s] (turbulence on top of the steady wind: a zero-mean first-order Gauss-Markov
process, ``g[k+1] = a g[k] + w``, whose decay ``a`` the caller gives; see
:mod:`~simplexspline.aero.reconstruction.gusts`); the vanes' position errors along the
body x axis ``xalpha, xbeta`` [m] (a vane ahead of where the sensor geometry puts it reads
the pitch rate's and yaw rate's induced angles ``-q dx / V`` and ``r dx / V`` on top). The
air moves at wind + gust. Which states are estimated depends on the channels present (the
driver holds the unobservable ones at their prior).

Measurements (12): GPS position ``x_gps, y_gps, z_gps``, GPS velocity ``vn_gps, ve_gps,
vd_gps``, air data ``tas, alpha, beta`` (of the air-relative velocity, at the vanes'
positions) and attitude ``phi, theta, psi``.

Discretisation (measured against JSBSim on noise-free campaigns): the specific force enters
as the mean of samples k and k + 1 (the caller averages it), the body axes turn by the exact
rotation ``omega dt`` of sample k (second order in the velocity equation; the attitude via
the direction cosine matrix and back to Euler angles). The transition matrix is the
first-order ``I + dt A``.

These are private numeric kernels on plain floats and arrays; the per-maneuver driver is
:mod:`simplexspline.aero.reconstruction.reconstruct`.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "STATE_NAMES", "INPUT_NAMES", "MEASUREMENT_NAMES", "BIAS_STATES", "WIND_STATES",
    "SCALE_STATES", "POSITION_STATES", "GUST_STATES", "GUST", "EarthModel",
    "euler_rates", "normal_gravity", "propagate", "measure", "step_mean",
]

#: State vector, in order.
STATE_NAMES: tuple[str, ...] = (
    "x", "y", "z", "u", "v", "w", "phi", "theta", "psi",
    "bax", "bay", "baz", "bp", "bq", "br", "balpha", "bbeta", "btas",
    "wind_n", "wind_e", "wind_d", "kalpha", "kbeta", "gust_n", "gust_e", "gust_d",
    "xalpha", "xbeta",
)
#: IMU inputs, in order (schema columns).
INPUT_NAMES: tuple[str, ...] = ("ax", "ay", "az", "p", "q", "r")
#: Measurements, in order (schema columns).
MEASUREMENT_NAMES: tuple[str, ...] = (
    "x_gps", "y_gps", "z_gps", "vn_gps", "ve_gps", "vd_gps",
    "tas", "alpha", "beta", "phi", "theta", "psi",
)
#: Bias states and the schema channel each one corrupts.
BIAS_STATES: dict[str, str] = {
    "bax": "ax", "bay": "ay", "baz": "az", "bp": "p", "bq": "q", "br": "r",
    "balpha": "alpha", "bbeta": "beta", "btas": "tas",
}
#: Wind states (NED, the velocity of the air mass over the Earth) [m/s].
WIND_STATES: tuple[str, ...] = ("wind_n", "wind_e", "wind_d")
#: Vane scale-factor errors (the vane reads (1 + k) times the local flow angle) [-].
SCALE_STATES: dict[str, str] = {"kalpha": "alpha", "kbeta": "beta"}
#: Vane position errors along the body x axis [m] (the vane sits that far ahead of the
#: position the sensor geometry gives).
POSITION_STATES: dict[str, str] = {"xalpha": "alpha", "xbeta": "beta"}
#: Gust states (NED, turbulence on top of the steady wind) [m/s].
GUST_STATES: tuple[str, ...] = ("gust_n", "gust_e", "gust_d")
#: Slice of the gust states in the state vector.
GUST = slice(23, 26)
NX = len(STATE_NAMES)
NZ = len(MEASUREMENT_NAMES)
#: index of psi in the measurement vector (its innovation is wrapped to [-pi, pi)).
PSI_MEAS = MEASUREMENT_NAMES.index("psi")

_OMEGA_E = 7.292115e-5          # WGS84 Earth rate [rad/s]
_A = 6378137.0                  # WGS84 semi-major axis [m]
_E2 = 6.69437999014e-3          # WGS84 first eccentricity squared
_F = 1.0 / 298.257223563
_M = 0.00344978650684           # omega^2 a^2 b / GM


def euler_rates(p, q, r, phi, theta) -> tuple:
    """The Euler angles' rates from the body rates and attitude.

    Parameters
    ----------
    p, q, r : float or ndarray
        Body rates [rad/s].
    phi, theta : float or ndarray
        Bank and pitch angles [rad].

    Returns
    -------
    (phi', theta', psi') : tuple of float or ndarray
        [rad/s]: ``p + tan(theta) (q sin(phi) + r cos(phi))``, ``q cos(phi) - r sin(phi)``,
        ``(q sin(phi) + r cos(phi)) / cos(theta)``.
    """
    turn = q * np.sin(phi) + r * np.cos(phi)
    return p + np.tan(theta) * turn, q * np.cos(phi) - r * np.sin(phi), turn / np.cos(theta)


def normal_gravity(lat: float, h) -> np.ndarray | float:
    """WGS84 normal gravity (gravitation plus centrifugal) [m/s^2].

    Somigliana's formula at the ellipsoid with the second-order free-air correction.

    Parameters
    ----------
    lat : float
        Geodetic latitude [rad].
    h : float or ndarray
        Height above the ellipsoid [m].
    """
    s2 = math.sin(lat) ** 2
    g0 = 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - _E2 * s2)
    h = np.asarray(h, dtype=float)
    return g0 * (1 - 2 / _A * (1 + _F + _M - 2 * _F * s2) * h + 3 * h * h / _A**2)


class EarthModel:
    """Earth rate, radii of curvature and gravity at one latitude.

    Parameters
    ----------
    lat : float
        Geodetic latitude [rad] (the simulator flies at 52 deg N).
    rotation : bool
        Include Earth rotation (Coriolis and Earth rate) and the transport rate. Switch off
        only for data from a flat, non-rotating Earth simulation.
    """

    def __init__(self, lat: float, rotation: bool = True):
        self.lat = float(lat)
        s = math.sin(lat)
        self.rn = _A / math.sqrt(1 - _E2 * s * s)
        self.rm = _A * (1 - _E2) / (1 - _E2 * s * s) ** 1.5
        self.tan_lat = math.tan(lat)
        w = _OMEGA_E if rotation else 0.0
        self.rotation = bool(rotation)
        self.wie = (w * math.cos(lat), 0.0, -w * s)

    def gravity(self, h) -> np.ndarray | float:
        """Normal gravity [m/s^2] at height ``h`` [m]."""
        return normal_gravity(self.lat, h)


def _dcm(phi: float, theta: float, psi: float):
    """C_nb (body to NED) as nested tuples, rows."""
    cf, sf = math.cos(phi), math.sin(phi)
    ct, st = math.cos(theta), math.sin(theta)
    cp, sp = math.cos(psi), math.sin(psi)
    return ((ct * cp, sf * st * cp - cf * sp, cf * st * cp + sf * sp),
            (ct * sp, sf * st * sp + cf * cp, cf * st * sp - sf * cp),
            (-st, sf * ct, cf * ct))


def _rotate_euler(C, ax: float, ay: float, az: float, psi_prev: float):
    """Euler angles of C_nb R(a), R the rotation by the angle vector a (Rodrigues)."""
    th2 = ax * ax + ay * ay + az * az
    if th2 < 1e-24:
        s1, s2 = 1.0, 0.5
    else:
        th = math.sqrt(th2)
        s1, s2 = math.sin(th) / th, (1.0 - math.cos(th)) / th2
    # R = I + s1 [a x] + s2 [a x]^2
    R = ((1.0 - s2 * (ay * ay + az * az), -s1 * az + s2 * ax * ay, s1 * ay + s2 * ax * az),
         (s1 * az + s2 * ax * ay, 1.0 - s2 * (ax * ax + az * az), -s1 * ax + s2 * ay * az),
         (-s1 * ay + s2 * ax * az, s1 * ax + s2 * ay * az, 1.0 - s2 * (ax * ax + ay * ay)))
    c20 = C[2][0] * R[0][0] + C[2][1] * R[1][0] + C[2][2] * R[2][0]
    c21 = C[2][0] * R[0][1] + C[2][1] * R[1][1] + C[2][2] * R[2][1]
    c22 = C[2][0] * R[0][2] + C[2][1] * R[1][2] + C[2][2] * R[2][2]
    c10 = C[1][0] * R[0][0] + C[1][1] * R[1][0] + C[1][2] * R[2][0]
    c00 = C[0][0] * R[0][0] + C[0][1] * R[1][0] + C[0][2] * R[2][0]
    theta = -math.asin(max(-1.0, min(1.0, c20)))
    phi = math.atan2(c21, c22)
    psi = math.atan2(c10, c00)
    psi += round((psi_prev - psi) / (2 * math.pi)) * 2 * math.pi   # keep psi unwrapped
    return phi, theta, psi


_F_ENTRIES = (
    (0, 3), (0, 4), (0, 5), (1, 3), (1, 4), (1, 5), (2, 3), (2, 4), (2, 5),
    (0, 6), (1, 6), (2, 6), (0, 7), (1, 7), (2, 7), (0, 8), (1, 8),
    (3, 4), (3, 5), (4, 3), (4, 5), (5, 3), (5, 4),
    (3, 7), (4, 6), (4, 7), (5, 6), (5, 7),
    (3, 9), (4, 10), (5, 11),
    (3, 13), (3, 14), (4, 12), (4, 14), (5, 12), (5, 13),
    (6, 6), (6, 7), (7, 6), (8, 6), (8, 7),
    (6, 12), (6, 13), (6, 14), (7, 13), (7, 14), (8, 13), (8, 14),
)
_F_INDEX = np.array([i * NX + j for i, j in _F_ENTRIES])


def step_mean(values: np.ndarray) -> np.ndarray:
    """The mean of sampled inputs over each sample interval, through the cubic of the four
    nearest samples: ``(-x[k-1] + 13 x[k] + 13 x[k+1] - x[k+2]) / 24`` (exact for cubics;
    the trapezoid ``(x[k] + x[k+1]) / 2`` where a neighbour is missing or not finite).

    Parameters
    ----------
    values : (n, m) ndarray
        Uniformly sampled inputs, one column per channel (any unit).

    Returns
    -------
    (n - 1, m) ndarray
        Row k: the mean over [t_k, t_k+1].
    """
    x = np.asarray(values, dtype=float)
    out = 0.5 * (x[:-1] + x[1:])
    if x.shape[0] >= 4:
        cubic = (13.0 * (x[1:-2] + x[2:-1]) - x[:-3] - x[3:]) / 24.0
        inner = out[1:-1]
        np.copyto(inner, cubic, where=np.isfinite(cubic))
    return out


def propagate(x: np.ndarray, u: np.ndarray, dt: float, g: float, earth: EarthModel,
              F: np.ndarray, specific_force: bool = True, gust_decay: float = 1.0,
              second_order: bool = False) -> np.ndarray:
    """One step of the state equations and its (first-order) transition matrix.

    Parameters
    ----------
    x : (28,) ndarray
        State at step k.
    u : (6,) ndarray
        Measured IMU inputs over the step: specific force ``ax, ay, az`` [m/s^2], rates
        ``p, q, r`` [rad/s] (at 100 Hz the simulator's convention: the specific force's
        trapezoid, the rates at sample k; sampled coarser, their means over the step,
        :func:`step_mean`).
    dt : float
        Step [s].
    g : float
        Gravity at this altitude [m/s^2].
    earth : EarthModel
    F : (28, 28) ndarray
        Output: the transition matrix I + dt * df/dx. Only the model's non-trivial
        entries are written: pass the identity (or a matrix returned by an earlier call
        with the same ``specific_force``) so that every other entry is already that of the
        identity.
    specific_force : bool
        False when there are no accelerometers: the body velocities are then a random walk
        (held, to be driven by process noise) and ``u[:3]`` is ignored.
    gust_decay : float
        ``exp(-dt / tau)`` of the gusts' Gauss-Markov process (1: held).
    second_order : bool
        For inputs sampled coarser than the aircraft moves (with :func:`step_mean`): the
        second half of the step's gravity is taken at the step's end attitude and the
        position moves by the mean of the start and end velocities. False (the
        simulator's 100 Hz data): both at the step's start, which matches JSBSim's own
        steps (with the second-order step the still-air vertical wind of a c172p campaign
        flipped sign, +0.007 -> -0.007 m/s, rather than vanishing).

    Returns
    -------
    (28,) ndarray
        State at step k + 1.
    """
    (_, _, _, uu, vv, ww, phi, theta, psi, bax, bay, baz, bp, bq, br) = x[:15].tolist()
    fx, fy, fz = u[0] - bax, u[1] - bay, u[2] - baz
    p, q, r = u[3] - bp, u[4] - bq, u[5] - br
    C = _dcm(phi, theta, psi)
    cf, sf = math.cos(phi), math.sin(phi)
    ct, st = math.cos(theta), math.sin(theta)
    tt = st / ct
    # Earth rate and transport rate in NED, then in body axes (C_bn = C_nb')
    vn = C[0][0] * uu + C[0][1] * vv + C[0][2] * ww
    ve = C[1][0] * uu + C[1][1] * vv + C[1][2] * ww
    vd = C[2][0] * uu + C[2][1] * vv + C[2][2] * ww
    wie = earth.wie
    if earth.rotation:
        wen = (ve / earth.rn, -vn / earth.rm, -ve * earth.tan_lat / earth.rn)
    else:
        wen = (0.0, 0.0, 0.0)
    win = (wie[0] + wen[0], wie[1] + wen[1], wie[2] + wen[2])
    wie_b = [C[0][i] * wie[0] + C[1][i] * wie[1] + C[2][i] * wie[2] for i in range(3)]
    win_b = [C[0][i] * win[0] + C[1][i] * win[1] + C[2][i] * win[2] for i in range(3)]
    # gravity in body axes: C_bn (0, 0, g)
    gx, gy, gz = -g * st, g * sf * ct, g * cf * ct
    # velocity equation: total rotation omega_ib + omega_ie (for the Jacobian)
    P, Q, R = p + wie_b[0], q + wie_b[1], r + wie_b[2]
    # attitude equation: rates relative to NED
    pn, qn, rn = p - win_b[0], q - win_b[1], r - win_b[2]
    out = x.copy()
    # attitude: rotate C_nb by the exact rotation of angle |omega_nb| dt (what a normalised
    # quaternion step does), then back to Euler angles; Euler-angle integration would leave
    # second-order errors of dt |omega|^2 / 2 that look like gyro biases in rolling maneuvers
    phi1, theta1, psi1 = _rotate_euler(C, pn * dt, qn * dt, rn * dt, psi)
    out[6], out[7], out[8] = phi1, theta1, psi1
    # the body axes turn by theta = omega_ib dt during the step: half the step's velocity
    # change in the axes of its start, the rotation, the other half in the axes of its end
    # (JSBSim's discrete rotation gives dt |omega|^2 V / 2 ~ 0.005 m/s^2)
    hx = 0.5 * dt * (fx + gx - (wie_b[1] * ww - wie_b[2] * vv))
    hy = 0.5 * dt * (fy + gy - (wie_b[2] * uu - wie_b[0] * ww))
    hz = 0.5 * dt * (fz + gz - (wie_b[0] * vv - wie_b[1] * uu))
    u1, v1, w1 = uu + hx, vv + hy, ww + hz
    tx, ty, tz = p * dt, q * dt, r * dt
    cx, cy, cz = ty * w1 - tz * v1, tz * u1 - tx * w1, tx * v1 - ty * u1
    ccx, ccy, ccz = ty * cz - tz * cy, tz * cx - tx * cz, tx * cy - ty * cx
    out[3] = u1 - cx + 0.5 * ccx + hx
    out[4] = v1 - cy + 0.5 * ccy + hy
    out[5] = w1 - cz + 0.5 * ccz + hz
    pn_, pe_, pd_ = vn, ve, vd
    if second_order:
        # gravity of the second half seen from the end attitude (with the start's in both
        # halves the error is dt g dtheta / 2 per step: at 10 Hz the reconstructed angle
        # of attack of a campaign with perfect sensors was 1.5-2.2e-4 rad off)
        C1 = _dcm(phi1, theta1, psi1)
        # gravity in end-body axes: the third row of the end C_nb times g
        out[3] += 0.5 * dt * (g * C1[2][0] - gx)
        out[4] += 0.5 * dt * (g * C1[2][1] - gy)
        out[5] += 0.5 * dt * (g * C1[2][2] - gz)
        u2, v2, w2 = out[3], out[4], out[5]
        pn_ = 0.5 * (vn + C1[0][0] * u2 + C1[0][1] * v2 + C1[0][2] * w2)
        pe_ = 0.5 * (ve + C1[1][0] * u2 + C1[1][1] * v2 + C1[1][2] * w2)
        pd_ = 0.5 * (vd + C1[2][0] * u2 + C1[2][1] * v2 + C1[2][2] * w2)
    # GPS x/y are latitude/longitude changes scaled at the first sample (flat earth)
    out[0] += dt * pn_ * (1.0 + x[2] / earth.rm)
    out[1] += dt * pe_ * (1.0 + x[2] / earth.rn + earth.tan_lat * x[0] / earth.rm)
    out[2] += dt * pd_

    # Jacobian A = df/dx; F = I + dt A
    s_ = qn * sf + rn * cf
    c_ = qn * cf - rn * sf
    a = sf * vv + cf * ww                 # body y-z velocity rotated by phi
    b = cf * vv - sf * ww
    c = ct * uu + st * a                  # horizontal velocity along the heading
    cp, sp = math.cos(psi), math.sin(psi)
    gd = g * dt
    # values in the order of _F_INDEX (one scatter instead of ~60 item assignments)
    vals = (
        # position rows: d(C V)/dV = C, then d/dphi, d/dtheta, d/dpsi
        dt * C[0][0], dt * C[0][1], dt * C[0][2],
        dt * C[1][0], dt * C[1][1], dt * C[1][2],
        dt * C[2][0], dt * C[2][1], dt * C[2][2],
        dt * (st * cp * b + sp * a), dt * (st * sp * b - cp * a), dt * (ct * b),
        dt * (cp * (-st * uu + ct * a)), dt * (sp * (-st * uu + ct * a)),
        dt * (-ct * uu - st * a),
        dt * (-sp * c - cp * b), dt * (cp * c - sp * b),
        # velocity rows: rotation, gravity, accelerometer and gyro biases
        dt * R, -dt * Q, -dt * R, dt * P, dt * Q, -dt * P,
        -gd * ct, gd * cf * ct, -gd * sf * st, -gd * sf * ct, -gd * cf * st,
        -dt, -dt, -dt,
        dt * ww, -dt * vv, -dt * ww, dt * uu, dt * vv, -dt * uu,
        # attitude rows
        1.0 + dt * c_ * tt, dt * s_ / (ct * ct), -dt * s_, dt * c_ / ct, dt * s_ * tt / ct,
        -dt, -dt * sf * tt, -dt * cf * tt, -dt * cf, dt * sf, -dt * sf / ct, -dt * cf / ct,
    )
    F.flat[_F_INDEX] = vals
    out[GUST] *= gust_decay
    F[23, 23] = F[24, 24] = F[25, 25] = gust_decay
    if not specific_force:
        out[3:6] = x[3:6]
        F[3:6, :] = 0.0
        F[3, 3] = F[4, 4] = F[5, 5] = 1.0
    return out


def _dcm_derivatives(cf, sf, ct, st, cp, sp):
    """d C_nb / d phi, d theta, d psi (each a 3 x 3 ndarray)."""
    return (np.array(((0.0, cf * st * cp + sf * sp, -sf * st * cp + cf * sp),
                      (0.0, cf * st * sp - sf * cp, -sf * st * sp - cf * cp),
                      (0.0, cf * ct, -sf * ct))),
            np.array(((-st * cp, sf * ct * cp, cf * ct * cp),
                      (-st * sp, sf * ct * sp, cf * ct * sp),
                      (-ct, -sf * st, -cf * st))),
            np.array(((-ct * sp, -sf * st * sp - cf * cp, -cf * st * sp + sf * cp),
                      (ct * cp, sf * st * cp - cf * sp, cf * st * cp + sf * sp),
                      (0.0, 0.0, 0.0))))


def measure(x: np.ndarray, H: np.ndarray | None, arm: np.ndarray | None = None
            ) -> np.ndarray:
    """Predicted measurements and their Jacobian.

    The air data see the air-relative velocity ``V_a = V_b - C_bn W`` (W the steady wind
    plus the gusts);
    the vanes see it at their position, ``V_a + omega x r``, and read ``(1 + k)`` times the
    flow angle there plus their offset. The airspeed is that of the c.g.

    Parameters
    ----------
    x : (28,) ndarray
        State.
    H : (12, 28) ndarray or None
        Output: d h / d x (overwritten in place); None to skip the Jacobian.
    arm : (9,) ndarray, optional
        ``omega x r`` [m/s] of the alpha vane (first three) and of the beta vane (next
        three) at the positions the sensor geometry gives, and ``omega x e_x = (0, r, -q)``
        [rad/s] (last three: what a vane's position error along x adds per metre) at this
        sample, body axes; None: vanes at the c.g. and no rates.

    Returns
    -------
    (12,) ndarray
        ``x_gps, y_gps, z_gps`` [m], ``vn, ve, vd`` [m/s], ``tas`` [m/s], ``alpha``,
        ``beta``, ``phi``, ``theta``, ``psi`` [rad] (psi unwrapped, as the state).
    """
    (px, py, pz, uu, vv, ww, phi, theta, psi, _, _, _, _, _, _, ba, bb, bv,
     wn, we, wd, ka, kb, gn, ge, gd, xa, xb) = x.tolist()
    wn, we, wd = wn + gn, we + ge, wd + gd      # the air moves at wind + gust
    C = _dcm(phi, theta, psi)
    cf, sf = math.cos(phi), math.sin(phi)
    ct, st = math.cos(theta), math.sin(theta)
    cp, sp = math.cos(psi), math.sin(psi)
    vn = C[0][0] * uu + C[0][1] * vv + C[0][2] * ww
    ve = C[1][0] * uu + C[1][1] * vv + C[1][2] * ww
    vd = C[2][0] * uu + C[2][1] * vv + C[2][2] * ww
    # air-relative velocity at the c.g. and at the vanes
    ua = uu - (C[0][0] * wn + C[1][0] * we + C[2][0] * wd)
    va = vv - (C[0][1] * wn + C[1][1] * we + C[2][1] * wd)
    wa = ww - (C[0][2] * wn + C[1][2] * we + C[2][2] * wd)
    if arm is None:
        a0 = a2 = b0 = b1 = b2 = d0 = d1 = d2 = 0.0
    else:
        a0, _, a2, b0, b1, b2, d0, d1, d2 = arm.tolist()  # v at the alpha vane: no matter
        a0, a2 = a0 + xa * d0, a2 + xa * d2
        b0, b1, b2 = b0 + xb * d0, b1 + xb * d1, b2 + xb * d2
    V = math.sqrt(ua * ua + va * va + wa * wa)
    ul, wl = ua + a0, wa + a2
    uw2a = ul * ul + wl * wl
    alpha_l = math.atan2(wl, ul)
    ub, vb, wb = ua + b0, va + b1, wa + b2
    Vb2 = ub * ub + vb * vb + wb * wb
    Vb = math.sqrt(Vb2)
    beta_l = math.asin(vb / Vb)
    h = np.array((px, py, pz, vn, ve, vd, V + bv, (1.0 + ka) * alpha_l + ba,
                  (1.0 + kb) * beta_l + bb, phi, theta, psi))
    if H is None:
        return h
    H[...] = 0.0
    H[0, 0] = H[1, 1] = H[2, 2] = 1.0
    for i in range(3):
        H[3 + i, 3] = C[i][0]
        H[3 + i, 4] = C[i][1]
        H[3 + i, 5] = C[i][2]
    a = sf * vv + cf * ww
    b = cf * vv - sf * ww
    c = ct * uu + st * a
    H[3, 6] = st * cp * b + sp * a
    H[4, 6] = st * sp * b - cp * a
    H[5, 6] = ct * b
    H[3, 7] = cp * (-st * uu + ct * a)
    H[4, 7] = sp * (-st * uu + ct * a)
    H[5, 7] = -ct * uu - st * a
    H[3, 8] = -sp * c - cp * b
    H[4, 8] = cp * c - sp * b
    # air data: gradients with respect to the air-relative body velocity, then the chain
    # rule through V_a = V_b - C' W (body velocity, attitude and wind)
    uwb = math.sqrt(ub * ub + wb * wb)
    grads = np.array(((ua / V, va / V, wa / V),
                      ((1.0 + ka) * -wl / uw2a, 0.0, (1.0 + ka) * ul / uw2a),
                      ((1.0 + kb) * -ub * vb / (Vb2 * uwb), (1.0 + kb) * uwb / Vb2,
                       (1.0 + kb) * -wb * vb / (Vb2 * uwb))))
    Cm = np.array(C)
    W = np.array((wn, we, wd))
    H[6:9, 3:6] = grads
    for j, dC in enumerate(_dcm_derivatives(cf, sf, ct, st, cp, sp)):
        H[6:9, 6 + j] = -grads @ (dC.T @ W)
    H[6:9, 18:21] = -grads @ Cm.T
    H[6:9, 23:26] = H[6:9, 18:21]
    H[6, 17] = 1.0
    H[7, 15] = 1.0
    H[8, 16] = 1.0
    H[7, 21] = alpha_l
    H[8, 22] = beta_l
    H[7, 26] = grads[1] @ (d0, d1, d2)
    H[8, 27] = grads[2] @ (d0, d1, d2)
    H[9, 6] = H[10, 7] = H[11, 8] = 1.0
    return h
