"""Compiled kernels (numba) of the iterated extended Kalman filter and the RTS smoother.

The same equations as the Python reference path (:mod:`~simplexspline.aero.reconstruction.
kinematics` for the model, :mod:`~simplexspline.aero.reconstruction.iekf` for the filter),
written as loops over plain arrays so that numba compiles the whole per-sample recursion:
prediction, measurement model and Jacobian, the iterated update with its stopping rule and
the Joseph-form covariance update, and the smoother's backward pass. The matrix products
are the reference's, in the same grouping and by BLAS as there (``P H'``, ``H (P H')``, the
Joseph form ``(I - K H) P (I - K H)' + K R K'``, ``F P F'``): the Joseph form regrouped as
``P - K (P H')'`` moved weakly observed states by 1e-6 of their sigma, the mirrored form by
1e-10. The gain's small Cholesky solve is the kernel's own, and the smoother applies each
gain to its vector instead of forming it (less work, the same to round-off). The results
agree with the reference to round-off (``tests/aero/test_filter_kernels.py`` runs both).

Installed with the ``fast`` extra; ``SIMPLEXSPLINE_NO_NUMBA=1`` in the environment (or
:data:`HAVE_NUMBA` set False) leaves the Python path in charge. The kernels never raise on
numerical trouble: they stop and return a status (:data:`NOT_POSITIVE_DEFINITE`,
:data:`NOT_FINITE`) and the caller reruns the Python path, which raises the reference's
exception with its message.

Kernels
-------
* :func:`filter_pass`: the forward pass of :func:`~simplexspline.aero.reconstruction.iekf.
  run_filter` into preallocated output arrays.
* :func:`smooth_pass`: the RTS backward pass of the state means.
* :func:`measure_series`: the predicted measurements of a sequence of states.
"""

from __future__ import annotations

import math

import numpy as np

# numba's presence (and the SIMPLEXSPLINE_NO_NUMBA switch) is decided once, by the spline
# layer's kernels
from simplexspline.spline.kernels import HAVE_NUMBA

__all__ = ["HAVE_NUMBA", "OK", "NOT_POSITIVE_DEFINITE", "NOT_FINITE", "filter_pass",
           "smooth_pass", "measure_series"]

if HAVE_NUMBA:  # pragma: no cover - exercised where numba is installed
    import numba

#: Status of :func:`filter_pass`: every sample processed.
OK = 0
#: Status: an innovation covariance was not positive definite (at the returned sample).
NOT_POSITIVE_DEFINITE = 1
#: Status: a state or covariance became non-finite (at the returned sample).
NOT_FINITE = 2

# compile-time constants (tests/aero/test_filter_kernels.py checks them against kinematics)
_NX = 28            # states (kinematics.STATE_NAMES)
_NZ = 12            # measurements (kinematics.MEASUREMENT_NAMES)
_PSI_MEAS = 11      # row of the heading in the measurement vector (kinematics.PSI_MEAS)
_TWO_PI = 2.0 * math.pi
_LOG_TWO_PI = math.log(2.0 * math.pi)


if HAVE_NUMBA:  # pragma: no cover - exercised where numba is installed
    _jit = numba.njit(cache=True, nogil=True, error_model="numpy")

    @_jit
    def _dcm(phi, theta, psi, C):
        """C_nb (body to NED) into ``C`` (3, 3) (kinematics._dcm)."""
        cf, sf = math.cos(phi), math.sin(phi)
        ct, st = math.cos(theta), math.sin(theta)
        cp, sp = math.cos(psi), math.sin(psi)
        C[0, 0] = ct * cp
        C[0, 1] = sf * st * cp - cf * sp
        C[0, 2] = cf * st * cp + sf * sp
        C[1, 0] = ct * sp
        C[1, 1] = sf * st * sp + cf * cp
        C[1, 2] = cf * st * sp - sf * cp
        C[2, 0] = -st
        C[2, 1] = sf * ct
        C[2, 2] = cf * ct

    @_jit
    def _rotate_euler(C, ax, ay, az, psi_prev):
        """Euler angles of C_nb R(a) (kinematics._rotate_euler)."""
        th2 = ax * ax + ay * ay + az * az
        if th2 < 1e-24:
            s1, s2 = 1.0, 0.5
        else:
            th = math.sqrt(th2)
            s1, s2 = math.sin(th) / th, (1.0 - math.cos(th)) / th2
        r00 = 1.0 - s2 * (ay * ay + az * az)
        r01 = -s1 * az + s2 * ax * ay
        r02 = s1 * ay + s2 * ax * az
        r10 = s1 * az + s2 * ax * ay
        r11 = 1.0 - s2 * (ax * ax + az * az)
        r12 = -s1 * ax + s2 * ay * az
        r20 = -s1 * ay + s2 * ax * az
        r21 = s1 * ax + s2 * ay * az
        r22 = 1.0 - s2 * (ax * ax + ay * ay)
        c20 = C[2, 0] * r00 + C[2, 1] * r10 + C[2, 2] * r20
        c21 = C[2, 0] * r01 + C[2, 1] * r11 + C[2, 2] * r21
        c22 = C[2, 0] * r02 + C[2, 1] * r12 + C[2, 2] * r22
        c10 = C[1, 0] * r00 + C[1, 1] * r10 + C[1, 2] * r20
        c00 = C[0, 0] * r00 + C[0, 1] * r10 + C[0, 2] * r20
        theta = -math.asin(max(-1.0, min(1.0, c20)))
        phi = math.atan2(c21, c22)
        psi = math.atan2(c10, c00)
        psi += round((psi_prev - psi) / (2 * math.pi)) * 2 * math.pi
        return phi, theta, psi

    @_jit
    def _propagate(x, u, dt, g, earth, F, specific_force, gust_decay, out, C, C1):
        """One step of the state equations into ``out`` and the transition matrix into
        ``F`` (every entry written) (kinematics.propagate). ``earth``: rn, rm, tan_lat,
        the Earth rate in NED (3), rotation (0/1), second-order step (0/1). ``C``, ``C1``:
        scratch (3, 3) for the start and end attitudes' C_nb."""
        uu, vv, ww = x[3], x[4], x[5]
        phi, theta, psi = x[6], x[7], x[8]
        fx, fy, fz = u[0] - x[9], u[1] - x[10], u[2] - x[11]
        p, q, r = u[3] - x[12], u[4] - x[13], u[5] - x[14]
        rn_, rm_, tan_lat = earth[0], earth[1], earth[2]
        wie0, wie1, wie2 = earth[3], earth[4], earth[5]
        _dcm(phi, theta, psi, C)
        cf, sf = math.cos(phi), math.sin(phi)
        ct, st = math.cos(theta), math.sin(theta)
        tt = st / ct
        vn = C[0, 0] * uu + C[0, 1] * vv + C[0, 2] * ww
        ve = C[1, 0] * uu + C[1, 1] * vv + C[1, 2] * ww
        vd = C[2, 0] * uu + C[2, 1] * vv + C[2, 2] * ww
        if earth[6] != 0.0:
            wen0, wen1, wen2 = ve / rn_, -vn / rm_, -ve * tan_lat / rn_
        else:
            wen0, wen1, wen2 = 0.0, 0.0, 0.0
        win0, win1, win2 = wie0 + wen0, wie1 + wen1, wie2 + wen2
        wb0 = C[0, 0] * wie0 + C[1, 0] * wie1 + C[2, 0] * wie2
        wb1 = C[0, 1] * wie0 + C[1, 1] * wie1 + C[2, 1] * wie2
        wb2 = C[0, 2] * wie0 + C[1, 2] * wie1 + C[2, 2] * wie2
        nb0 = C[0, 0] * win0 + C[1, 0] * win1 + C[2, 0] * win2
        nb1 = C[0, 1] * win0 + C[1, 1] * win1 + C[2, 1] * win2
        nb2 = C[0, 2] * win0 + C[1, 2] * win1 + C[2, 2] * win2
        gx, gy, gz = -g * st, g * sf * ct, g * cf * ct
        P_, Q_, R_ = p + wb0, q + wb1, r + wb2
        pn, qn, rn = p - nb0, q - nb1, r - nb2
        for i in range(_NX):
            out[i] = x[i]
        hx = 0.5 * dt * (fx + gx - (wb1 * ww - wb2 * vv))
        hy = 0.5 * dt * (fy + gy - (wb2 * uu - wb0 * ww))
        hz = 0.5 * dt * (fz + gz - (wb0 * vv - wb1 * uu))
        u1, v1, w1 = uu + hx, vv + hy, ww + hz
        tx, ty, tz = p * dt, q * dt, r * dt
        cx, cy, cz = ty * w1 - tz * v1, tz * u1 - tx * w1, tx * v1 - ty * u1
        ccx, ccy, ccz = ty * cz - tz * cy, tz * cx - tx * cz, tx * cy - ty * cx
        out[3] = u1 - cx + 0.5 * ccx + hx
        out[4] = v1 - cy + 0.5 * ccy + hy
        out[5] = w1 - cz + 0.5 * ccz + hz
        phi1, theta1, psi1 = _rotate_euler(C, pn * dt, qn * dt, rn * dt, psi)
        out[6], out[7], out[8] = phi1, theta1, psi1
        pn_, pe_, pd_ = vn, ve, vd
        if earth[7] != 0.0:
            _dcm(phi1, theta1, psi1, C1)
            # gravity in end-body axes: the third row of the end C_nb times g
            out[3] += 0.5 * dt * (g * C1[2, 0] - gx)
            out[4] += 0.5 * dt * (g * C1[2, 1] - gy)
            out[5] += 0.5 * dt * (g * C1[2, 2] - gz)
            u2, v2, w2 = out[3], out[4], out[5]
            pn_ = 0.5 * (vn + C1[0, 0] * u2 + C1[0, 1] * v2 + C1[0, 2] * w2)
            pe_ = 0.5 * (ve + C1[1, 0] * u2 + C1[1, 1] * v2 + C1[1, 2] * w2)
            pd_ = 0.5 * (vd + C1[2, 0] * u2 + C1[2, 1] * v2 + C1[2, 2] * w2)
        out[0] += dt * pn_ * (1.0 + x[2] / rm_)
        out[1] += dt * pe_ * (1.0 + x[2] / rn_ + tan_lat * x[0] / rm_)
        out[2] += dt * pd_

        s_ = qn * sf + rn * cf
        c_ = qn * cf - rn * sf
        a = sf * vv + cf * ww
        b = cf * vv - sf * ww
        c = ct * uu + st * a
        cp, sp = math.cos(psi), math.sin(psi)
        gd = g * dt
        for i in range(_NX):
            for j in range(_NX):
                F[i, j] = 0.0
            F[i, i] = 1.0
        # position rows
        for i in range(3):
            for j in range(3):
                F[i, 3 + j] = dt * C[i, j]
        F[0, 6] = dt * (st * cp * b + sp * a)
        F[1, 6] = dt * (st * sp * b - cp * a)
        F[2, 6] = dt * (ct * b)
        F[0, 7] = dt * (cp * (-st * uu + ct * a))
        F[1, 7] = dt * (sp * (-st * uu + ct * a))
        F[2, 7] = dt * (-ct * uu - st * a)
        F[0, 8] = dt * (-sp * c - cp * b)
        F[1, 8] = dt * (cp * c - sp * b)
        # velocity rows
        F[3, 4] = dt * R_
        F[3, 5] = -dt * Q_
        F[4, 3] = -dt * R_
        F[4, 5] = dt * P_
        F[5, 3] = dt * Q_
        F[5, 4] = -dt * P_
        F[3, 7] = -gd * ct
        F[4, 6] = gd * cf * ct
        F[4, 7] = -gd * sf * st
        F[5, 6] = -gd * sf * ct
        F[5, 7] = -gd * cf * st
        F[3, 9] = -dt
        F[4, 10] = -dt
        F[5, 11] = -dt
        F[3, 13] = dt * ww
        F[3, 14] = -dt * vv
        F[4, 12] = -dt * ww
        F[4, 14] = dt * uu
        F[5, 12] = dt * vv
        F[5, 13] = -dt * uu
        # attitude rows
        F[6, 6] = 1.0 + dt * c_ * tt
        F[6, 7] = dt * s_ / (ct * ct)
        F[7, 6] = -dt * s_
        F[8, 6] = dt * c_ / ct
        F[8, 7] = dt * s_ * tt / ct
        F[6, 12] = -dt
        F[6, 13] = -dt * sf * tt
        F[6, 14] = -dt * cf * tt
        F[7, 13] = -dt * cf
        F[7, 14] = dt * sf
        F[8, 13] = -dt * sf / ct
        F[8, 14] = -dt * cf / ct
        for i in range(23, 26):
            out[i] *= gust_decay
            F[i, i] = gust_decay
        if not specific_force:
            for i in range(3, 6):
                out[i] = x[i]
                for j in range(_NX):
                    F[i, j] = 0.0
                F[i, i] = 1.0

    @_jit
    def _measure(x, arm, h, H, jacobian, C, dC):
        """Predicted measurements into ``h`` (12,) and, if ``jacobian``, their Jacobian into
        ``H`` (12, 28) (kinematics.measure). ``arm`` (9,): omega x r at the vanes' given
        positions, then (0, r, -q)."""
        px, py, pz = x[0], x[1], x[2]
        uu, vv, ww = x[3], x[4], x[5]
        phi, theta, psi = x[6], x[7], x[8]
        ba, bb, bv = x[15], x[16], x[17]
        ka, kb = x[21], x[22]
        wn, we, wd = x[18] + x[23], x[19] + x[24], x[20] + x[25]
        _dcm(phi, theta, psi, C)
        cf, sf = math.cos(phi), math.sin(phi)
        ct, st = math.cos(theta), math.sin(theta)
        cp, sp = math.cos(psi), math.sin(psi)
        vn = C[0, 0] * uu + C[0, 1] * vv + C[0, 2] * ww
        ve = C[1, 0] * uu + C[1, 1] * vv + C[1, 2] * ww
        vd = C[2, 0] * uu + C[2, 1] * vv + C[2, 2] * ww
        ua = uu - (C[0, 0] * wn + C[1, 0] * we + C[2, 0] * wd)
        va = vv - (C[0, 1] * wn + C[1, 1] * we + C[2, 1] * wd)
        wa = ww - (C[0, 2] * wn + C[1, 2] * we + C[2, 2] * wd)
        xa, xb = x[26], x[27]
        d0, d1, d2 = arm[6], arm[7], arm[8]
        a0, a2 = arm[0] + xa * d0, arm[2] + xa * d2
        b0, b1, b2 = arm[3] + xb * d0, arm[4] + xb * d1, arm[5] + xb * d2
        V = math.sqrt(ua * ua + va * va + wa * wa)
        ul, wl = ua + a0, wa + a2
        uw2a = ul * ul + wl * wl
        alpha_l = math.atan2(wl, ul)
        ub, vb, wb = ua + b0, va + b1, wa + b2
        Vb2 = ub * ub + vb * vb + wb * wb
        Vb = math.sqrt(Vb2)
        beta_l = math.asin(vb / Vb)
        h[0], h[1], h[2] = px, py, pz
        h[3], h[4], h[5] = vn, ve, vd
        h[6] = V + bv
        h[7] = (1.0 + ka) * alpha_l + ba
        h[8] = (1.0 + kb) * beta_l + bb
        h[9], h[10], h[11] = phi, theta, psi
        if not jacobian:
            return
        for i in range(_NZ):
            for j in range(_NX):
                H[i, j] = 0.0
        H[0, 0] = H[1, 1] = H[2, 2] = 1.0
        for i in range(3):
            H[3 + i, 3] = C[i, 0]
            H[3 + i, 4] = C[i, 1]
            H[3 + i, 5] = C[i, 2]
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
        uwb = math.sqrt(ub * ub + wb * wb)
        # gradients of tas, alpha, beta with respect to the air-relative body velocity
        g00, g01, g02 = ua / V, va / V, wa / V
        g10, g11, g12 = (1.0 + ka) * -wl / uw2a, 0.0, (1.0 + ka) * ul / uw2a
        g20 = (1.0 + kb) * -ub * vb / (Vb2 * uwb)
        g21 = (1.0 + kb) * uwb / Vb2
        g22 = (1.0 + kb) * -wb * vb / (Vb2 * uwb)
        H[6, 3], H[6, 4], H[6, 5] = g00, g01, g02
        H[7, 3], H[7, 4], H[7, 5] = g10, g11, g12
        H[8, 3], H[8, 4], H[8, 5] = g20, g21, g22
        # d C_nb / d phi, d theta, d psi (kinematics._dcm_derivatives)
        dC[0, 0, 0] = 0.0
        dC[0, 0, 1], dC[0, 0, 2] = cf * st * cp + sf * sp, -sf * st * cp + cf * sp
        dC[0, 1, 0] = 0.0
        dC[0, 1, 1], dC[0, 1, 2] = cf * st * sp - sf * cp, -sf * st * sp - cf * cp
        dC[0, 2, 0], dC[0, 2, 1], dC[0, 2, 2] = 0.0, cf * ct, -sf * ct
        dC[1, 0, 0], dC[1, 0, 1], dC[1, 0, 2] = -st * cp, sf * ct * cp, cf * ct * cp
        dC[1, 1, 0], dC[1, 1, 1], dC[1, 1, 2] = -st * sp, sf * ct * sp, cf * ct * sp
        dC[1, 2, 0], dC[1, 2, 1], dC[1, 2, 2] = -ct, -sf * st, -cf * st
        dC[2, 0, 0] = -ct * sp
        dC[2, 0, 1], dC[2, 0, 2] = -sf * st * sp - cf * cp, -cf * st * sp + sf * cp
        dC[2, 1, 0] = ct * cp
        dC[2, 1, 1], dC[2, 1, 2] = sf * st * cp - cf * sp, cf * st * cp + sf * sp
        dC[2, 2, 0], dC[2, 2, 1], dC[2, 2, 2] = 0.0, 0.0, 0.0
        for j in range(3):
            # v = dC_j' W (body components of the wind's rate of change with the angle)
            v0 = dC[j, 0, 0] * wn + dC[j, 1, 0] * we + dC[j, 2, 0] * wd
            v1 = dC[j, 0, 1] * wn + dC[j, 1, 1] * we + dC[j, 2, 1] * wd
            v2 = dC[j, 0, 2] * wn + dC[j, 1, 2] * we + dC[j, 2, 2] * wd
            H[6, 6 + j] = -g00 * v0 + -g01 * v1 + -g02 * v2
            H[7, 6 + j] = -g10 * v0 + -g11 * v1 + -g12 * v2
            H[8, 6 + j] = -g20 * v0 + -g21 * v1 + -g22 * v2
        for j in range(3):
            # -grads @ C_nb' : column j is -grads @ (row j of C_nb)
            H[6, 18 + j] = -g00 * C[j, 0] + -g01 * C[j, 1] + -g02 * C[j, 2]
            H[7, 18 + j] = -g10 * C[j, 0] + -g11 * C[j, 1] + -g12 * C[j, 2]
            H[8, 18 + j] = -g20 * C[j, 0] + -g21 * C[j, 1] + -g22 * C[j, 2]
            for i in range(6, 9):
                H[i, 23 + j] = H[i, 18 + j]
        H[6, 17] = 1.0
        H[7, 15] = 1.0
        H[8, 16] = 1.0
        H[7, 21] = alpha_l
        H[8, 22] = beta_l
        H[7, 26] = g10 * d0 + g11 * d1 + g12 * d2
        H[8, 27] = g20 * d0 + g21 * d1 + g22 * d2
        H[9, 6] = H[10, 7] = H[11, 8] = 1.0

    @_jit
    def _wrap(v):
        return (v + math.pi) % _TWO_PI - math.pi

    @_jit
    def _cholesky_solve(L, m, B, nrhs):
        """Solve ``L L' X = B`` in place (``B`` (m, nrhs), ``L`` lower Cholesky factor)."""
        for i in range(m):
            for k in range(i):
                f = L[i, k]
                for c in range(nrhs):
                    B[i, c] -= f * B[k, c]
            d = L[i, i]
            for c in range(nrhs):
                B[i, c] /= d
        for i in range(m - 1, -1, -1):
            for k in range(i + 1, m):
                f = L[k, i]
                for c in range(nrhs):
                    B[i, c] -= f * B[k, c]
            d = L[i, i]
            for c in range(nrhs):
                B[i, c] /= d

    @_jit
    def _cholesky(S, m, L):
        """Lower Cholesky factor of ``S[:m, :m]`` into ``L``; False if not positive definite."""
        for j in range(m):
            s = S[j, j]
            for k in range(j):
                s -= L[j, k] * L[j, k]
            if not s > 0.0:
                return False
            d = math.sqrt(s)
            L[j, j] = d
            for i in range(j + 1, m):
                t = S[i, j]
                for k in range(j):
                    t -= L[i, k] * L[j, k]
                L[i, j] = t / d
        return True

    @_jit
    def _finite(x, P):
        """States and variances finite (a non-finite covariance shows on its diagonal:
        the updates and predictions mix every entry into it)."""
        for i in range(_NX):
            if not (math.isfinite(x[i]) and math.isfinite(P[i, i])):
                return False
        return True

    @_jit
    def filter_pass(x0, P0, u, z, dt, g, earth, r_var, var_u, q, tol, max_iter, arm,
                    specific_force, gust_decay, x_filt, P_filt, x_pred, P_pred, Fs,
                    innov, innov_var, iters):
        """Forward pass of the iterated extended Kalman filter (iekf.run_filter).

        Parameters
        ----------
        x0 : (28,) ndarray
            Initial state.
        P0 : (28, 28) ndarray
            Its covariance.
        u : (n, 6) ndarray
            IMU inputs.
        z : (n, 12) ndarray
            Measurements, NaN where missing.
        dt : float
        g : (n,) ndarray
            Gravity per sample.
        earth : (8,) ndarray
            ``rn, rm, tan_lat``, the Earth rate in NED (3), 1.0 with rotation else 0.0, and
            1.0 for the second-order step of coarsely sampled inputs else 0.0.
        r_var : (12,) ndarray
            Measurement-noise variances.
        var_u : (6,) ndarray
            IMU noise variances.
        q : (28,) ndarray
            Process-noise variances.
        tol : float
            Stopping tolerance of the iterated update (measurement-noise sigmas).
        max_iter : int
        arm : (n, 9) ndarray
            ``omega x r`` of the vanes and ``(0, r, -q)`` (zeros: at the c.g.).
        specific_force : bool
        gust_decay : float
        x_filt, P_filt, x_pred, P_pred, Fs, innov, innov_var, iters
            Outputs, shaped as :func:`~simplexspline.aero.reconstruction.iekf.run_filter`'s
            (``innov``, ``innov_var`` filled with NaN by the caller).

        Returns
        -------
        status : int
            :data:`OK`, :data:`NOT_POSITIVE_DEFINITE` or :data:`NOT_FINITE`.
        sample : int
            The sample where it stopped (-1 when OK).
        loglik : float
            Log-likelihood of the measurements.
        """
        n = u.shape[0]
        x = x0.copy()
        P = P0.copy()
        xi = np.empty(_NX)
        x_new = np.empty(_NX)
        d = np.empty(_NX)
        A = np.empty((_NX, _NX))
        Pn = np.empty((_NX, _NX))
        IKH = np.eye(_NX)
        C = np.empty((3, 3))
        C1 = np.empty((3, 3))
        dC = np.empty((3, 3, 3))
        h = np.empty(_NZ)
        hn = np.empty(_NZ)
        H = np.zeros((_NZ, _NX))
        sel = np.empty(_NZ, dtype=np.int64)
        hs = np.empty(_NZ)
        res = np.empty(_NZ)
        e = np.empty(_NZ)
        noise_sd = np.empty(_NZ)
        L = np.zeros((_NZ, _NZ))
        RHS = np.empty((_NZ, _NX + 1))
        # buffers of the selected rows' products, reshaped to (NX, m), (m, m), (m, NX)
        hs_buf = np.empty(_NZ * _NX)
        pht_buf = np.empty(_NX * _NZ)
        s_buf = np.empty(_NZ * _NZ)
        kt_buf = np.empty(_NZ * _NX)
        kr_buf = np.empty(_NZ * _NX)
        KRK = np.empty((_NX, _NX))
        loglik = 0.0
        for k in range(n):
            x_pred[k] = x
            P_pred[k] = P
            m = 0
            psi_j = -1
            for j in range(_NZ):
                if math.isfinite(z[k, j]):
                    if j == _PSI_MEAS:
                        psi_j = m
                    sel[m] = j
                    noise_sd[m] = math.sqrt(r_var[j])
                    m += 1
            if m > 0:
                Hs = hs_buf[:m * _NX].reshape((m, _NX))
                PHt = pht_buf[:_NX * m].reshape((_NX, m))
                S = s_buf[:m * m].reshape((m, m))
                Kt = kt_buf[:m * _NX].reshape((m, _NX))
                KR = kr_buf[:m * _NX].reshape((m, _NX))
                for a in range(_NX):
                    xi[a] = x[a]
                it = 0
                while True:
                    _measure(xi, arm[k], h, H, True, C, dC)
                    for r in range(m):
                        hs[r] = h[sel[r]]
                        res[r] = z[k, sel[r]] - hs[r]
                        for a in range(_NX):
                            Hs[r, a] = H[sel[r], a]
                    if psi_j >= 0:
                        res[psi_j] = _wrap(res[psi_j])
                    np.dot(P, Hs.T, PHt)
                    np.dot(Hs, PHt, S)
                    for r in range(m):
                        S[r, r] += r_var[sel[r]]
                    if not _cholesky(S, m, L):
                        return NOT_POSITIVE_DEFINITE, k, loglik
                    # the gain's rows K' = S^-1 (P Hs')' (and S^-1 nu for the likelihood)
                    for r in range(m):
                        for a in range(_NX):
                            RHS[r, a] = PHt[a, r]
                        RHS[r, _NX] = res[r]
                    _cholesky_solve(L, m, RHS, _NX + 1 if it == 0 else _NX)
                    if it == 0:
                        ld = 0.0
                        q_ = 0.0
                        for r in range(m):
                            innov[k, sel[r]] = res[r]
                            innov_var[k, sel[r]] = S[r, r]
                            ld += math.log(abs(L[r, r]))
                            q_ += res[r] * RHS[r, _NX]
                        loglik += -0.5 * (2.0 * ld + q_ + m * _LOG_TWO_PI)
                    for r in range(m):
                        for a in range(_NX):
                            Kt[r, a] = RHS[r, a]
                    # x_new = x + K (res - Hs (x - xi))
                    for a in range(_NX):
                        d[a] = x[a] - xi[a]
                    for r in range(m):
                        s = 0.0
                        for a in range(_NX):
                            s += Hs[r, a] * d[a]
                        e[r] = res[r] - s
                    for a in range(_NX):
                        s = 0.0
                        for r in range(m):
                            s += Kt[r, a] * e[r]
                        x_new[a] = x[a] + s
                    it += 1
                    # linearisation error at the new iterate, in measurement-noise sigmas
                    _measure(x_new, arm[k], hn, H, False, C, dC)
                    for a in range(_NX):
                        d[a] = x_new[a] - xi[a]
                    step = 0.0
                    for r in range(m):
                        s = 0.0
                        for a in range(_NX):
                            s += Hs[r, a] * d[a]
                        le = hs[r] + s - hn[sel[r]]
                        if r == psi_j:
                            le = _wrap(le)
                        v = abs(le) / noise_sd[r]
                        if not math.isfinite(v):   # the reference raises or iterates on
                            return NOT_FINITE, k, loglik
                        if v > step:
                            step = v
                    for a in range(_NX):
                        xi[a] = x_new[a]
                    if step < tol or it >= max_iter:
                        break
                iters[k] = it
                for a in range(_NX):
                    x[a] = xi[a]
                if not _finite(x, P):
                    return NOT_FINITE, k, loglik
                # Joseph form: (I - K Hs) P (I - K Hs)' + K R K'
                np.dot(Kt.T, Hs, IKH)
                for a in range(_NX):
                    for b in range(_NX):
                        IKH[a, b] = -IKH[a, b]
                    IKH[a, a] += 1.0
                np.dot(IKH, P, A)
                np.dot(A, IKH.T, P)
                for r in range(m):
                    for a in range(_NX):
                        KR[r, a] = Kt[r, a] * r_var[sel[r]]
                np.dot(KR.T, Kt, KRK)
                for a in range(_NX):
                    for b in range(_NX):
                        P[a, b] += KRK[a, b]
            x_filt[k] = x
            P_filt[k] = P
            # time update: x by the state equations, P = F P F' + Q + G Sigma_u G'
            F = Fs[k]
            _propagate(x, u[k], dt, g[k], earth, F, specific_force, gust_decay, x_new, C,
                       C1)
            np.dot(F, P, A)
            np.dot(A, F.T, P)
            for a in range(_NX):
                P[a, a] += q[a]
            for a in range(9):
                for b in range(9):
                    s = 0.0
                    for c in range(6):
                        s += F[a, 9 + c] * var_u[c] * F[b, 9 + c]
                    P[a, b] += s
            for a in range(_NX):
                x[a] = x_new[a]
            if not _finite(x, P):
                return NOT_FINITE, k, loglik
        return OK, -1, loglik

    @_jit
    def smooth_pass(xf, Pf, xp, Pp, F, xs):
        """RTS smoother of the means into ``xs`` (n, 28) (iekf.rts_smooth).

        ``x_s[k] = x_f[k] + C_k (x_s[k+1] - x_p[k+1])`` with ``C_k = (P_p[k+1]^-1 F_k
        P_f[k])'``, the gain applied to the vector: ``P_f[k]' F_k' P_p[k+1]'^-1 (x_s[k+1] -
        x_p[k+1])``, one LAPACK solve (LU) with one right-hand side per sample (the
        reference's NX right-hand sides and products cost twice as much). Raises
        ``LinAlgError`` on a singular ``P_p``, as the reference's batched solve does.
        """
        n = xf.shape[0]
        d = np.empty(_NX)
        w = np.empty(_NX)
        xs[n - 1] = xf[n - 1]
        for k in range(n - 2, -1, -1):
            for a in range(_NX):
                d[a] = xs[k + 1, a] - xp[k + 1, a]
            y = np.linalg.solve(Pp[k + 1].T, d)
            for a in range(_NX):                   # w = F_k' y
                w[a] = 0.0
            for b in range(_NX):
                yb = y[b]
                for a in range(_NX):
                    f = F[k, b, a]
                    if f != 0.0:
                        w[a] += f * yb
            for a in range(_NX):                   # xs[k] = xf[k] + P_f[k]' w
                s = 0.0
                for b in range(_NX):
                    s += Pf[k, b, a] * w[b]
                xs[k, a] = xf[k, a] + s

    @_jit
    def measure_series(xs, arm, out):
        """Predicted measurements of every state ``xs`` (n, 28) into ``out`` (n, 12)."""
        C = np.empty((3, 3))
        dC = np.empty((3, 3, 3))
        H = np.empty((1, 1))
        for k in range(xs.shape[0]):
            _measure(xs[k], arm[k], out[k], H, False, C, dC)

else:  # pragma: no cover
    filter_pass = smooth_pass = measure_series = None
