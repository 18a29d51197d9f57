"""Iterated extended Kalman filter and Rauch-Tung-Striebel smoother for one maneuver.

Numeric kernels on plain arrays; the state and measurement equations are in
:mod:`simplexspline.aero.reconstruction.kinematics`, the per-maneuver driver
(initialisation, checks, outputs) in :mod:`simplexspline.aero.reconstruction.reconstruct`.
With numba the forward pass and the smoother's means run compiled
(:mod:`simplexspline.aero.reconstruction.filter_kernels`, the same operations); the Python
code here is the reference, and the path without numba.

Measurement update (iterated, Gauss-Newton on the measurement equation; Jazwinski 1970)::

    x_0 = x_pred
    x_{i+1} = x_pred + K_i (z - h(x_i) - H_i (x_pred - x_i)),   K_i = P H_i' (H_i P H_i' + R)^-1

Stopping criterion: the iteration stops when the linearisation error at the new iterate is
below ``tol`` measurement-noise standard deviations in every measured channel,
``max_j |h(x_i) + H_i (x_{i+1} - x_i) - h(x_{i+1})|_j / sqrt(R_jj) < tol`` (the next
relinearisation would only correct that error; a converged update costs one gain and one
extra evaluation of h), or after ``max_iter`` gains. The error is measured against the
noise, not against the states' sigmas: in turbulence the linearisation error after the first
gain is 2-10 % of the noise (the gust just estimated turns the air-data Jacobians), which in
units of a weakly observed state's sigma looks large enough to iterate on, and every
relinearisation then moved the estimate along the direction the data cannot see (airspeed
bias against the along-track wind), always the same way: with the old rule (1e-3 predicted
sigmas of the state change) a straight maneuver in 2 m/s gusts walked the airspeed bias to
13-15 m/s with a sigma of 1.9 (``tests/aero/test_iekf.py``). A linearisation error of a tenth
of the noise moves the estimate by less than the noise justifies; larger errors (the first
samples of a maneuver, a heading started 0.1-0.3 rad off) still iterate. The covariance is updated once with the
last gain in Joseph form. Time update: ``kinematics.propagate`` (the discretisation
matched to JSBSim), ``P = F P F' + G Sigma_u G' + Q_model``, where the IMU noise enters
through G (the input columns of the transition matrix).

The forward pass also returns the log-likelihood of the measurements under the model,
``sum_k -(log det S_k + nu_k' S_k^-1 nu_k + m_k log 2 pi) / 2`` over the innovations
``nu_k`` of the predictions and their covariances ``S_k`` (from the Cholesky factor the
gain needs anyway): it scores candidate noise models on the same data
(:mod:`~simplexspline.aero.reconstruction.gusts`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.linalg.lapack import dposv

from simplexspline.aero.reconstruction import filter_kernels
from simplexspline.aero.reconstruction.kinematics import (
    NX, NZ, PSI_MEAS, EarthModel, measure, propagate,
)

__all__ = ["FilterNoise", "IteratedUpdate", "StateEstimate", "run_filter", "rts_smooth"]

_TWO_PI = 2.0 * math.pi
_LOG_TWO_PI = math.log(2.0 * math.pi)
_EYE = np.eye(NX)


@dataclass(frozen=True)
class StateEstimate:
    """A Gaussian state estimate.

    Attributes
    ----------
    x : (28,) ndarray
        Mean (:data:`~simplexspline.aero.reconstruction.kinematics.STATE_NAMES`).
    P : (28, 28) ndarray
        Covariance.
    """

    x: np.ndarray
    P: np.ndarray


@dataclass(frozen=True)
class FilterNoise:
    """The filter's noise model.

    Attributes
    ----------
    input_std : (6,) ndarray
        IMU white-noise standard deviations per sample (``ax, ay, az`` [m/s^2], ``p, q, r``
        [rad/s]).
    process_var : (28,) ndarray
        Additional process-noise variances per step (model errors).
    measurement_std : (12,) ndarray
        Measurement-noise standard deviations.
    """

    input_std: np.ndarray
    process_var: np.ndarray
    measurement_std: np.ndarray


@dataclass(frozen=True)
class IteratedUpdate:
    """Stopping rule of the iterated measurement update.

    Attributes
    ----------
    tol : float
        The linearisation error at the new iterate, in measurement-noise standard deviations
        (largest over the measured channels), below which the iteration stops.
    max_iter : int
        Maximum number of gain computations of one update.
    """

    tol: float = 0.1
    max_iter: int = 10


class _Measured(NamedTuple):
    """The measured part of one sample: values, their noise covariance, the heading row."""

    z: np.ndarray            #: (m,) the finite measurements
    R: np.ndarray            #: (m, m) their noise covariance
    sel: np.ndarray | None   #: (m,) their rows of the full measurement vector; None: all
    psi_j: int               #: row of the heading in ``z`` (-1: not measured)


def _wrap(res: np.ndarray, j: int) -> np.ndarray:
    """Wrap the heading component ``j`` (if >= 0) of a residual to [-pi, pi)."""
    if j >= 0:
        res[j] = (res[j] + math.pi) % _TWO_PI - math.pi
    return res


def _measured(zk: np.ndarray, finite: np.ndarray, complete: bool, R_full: np.ndarray
              ) -> _Measured:
    """The finite measurements of one sample ``zk`` (12,) (``complete``: all finite)."""
    if complete:
        return _Measured(zk, R_full, None, PSI_MEAS)
    sel = np.flatnonzero(finite)
    j = np.flatnonzero(sel == PSI_MEAS)
    return _Measured(zk[sel], R_full[np.ix_(sel, sel)], sel, int(j[0]) if j.size else -1)


def _iterated_update(x: np.ndarray, P: np.ndarray, meas: _Measured, H: np.ndarray,
                     iteration: IteratedUpdate, sample: int, arm: np.ndarray | None = None):
    """Iterated measurement update of the prediction ``(x, P)`` (see the module docstring).

    ``H`` (12, 28) is scratch space for the measurement Jacobian. Returns the updated
    state (28,) and covariance (28, 28), the number of gains computed, the innovation
    of the prediction with its predicted variances ((m,) each) and its log-likelihood.
    """
    sel, R, psi_j = meas.sel, meas.R, meas.psi_j
    noise_sd = np.sqrt(R.diagonal())
    xi = x
    it = 0
    while True:
        h = measure(xi, H, arm)
        Hs = H if sel is None else H[sel]
        hs = h if sel is None else h[sel]
        res = _wrap(meas.z - hs, psi_j)
        PHt = P @ Hs.T
        S = Hs @ PHt + R
        if it == 0:
            innovation = (res, S.diagonal().copy())
            # S symmetric positive definite; the last column gives S^-1 nu (likelihood)
            c, Kt, info = dposv(S, np.column_stack((PHt.T, res)))
            if info == 0:
                loglik = -0.5 * (2.0 * np.log(np.abs(c.diagonal())).sum()
                                 + res @ Kt[:, -1] + res.size * _LOG_TWO_PI)
                Kt = Kt[:, :-1]
        else:
            _, Kt, info = dposv(S, PHt.T)
        if info != 0:
            raise np.linalg.LinAlgError(
                f"innovation covariance not positive definite at sample {sample}")
        K = Kt.T
        x_new = x + K @ (res - Hs @ (x - xi))
        it += 1
        # stopping criterion: the change the next iteration would make, in predicted
        # sigmas. It is K (h(xi) + H (x_new - xi) - h(x_new)) to first order (the
        # next relinearisation only corrects the linearisation error at x_new),
        # estimated with the current gain: no new gain unless it is needed.
        hn = measure(x_new, None, arm)
        lin_err = hs + Hs @ (x_new - xi) - (hn if sel is None else hn[sel])
        step = np.max(np.abs(_wrap(lin_err, psi_j)) / noise_sd)
        xi = x_new
        if step < iteration.tol or it >= iteration.max_iter:
            break
    IKH = _EYE - K @ Hs
    return xi, IKH @ P @ IKH.T + K @ R @ K.T, it, innovation, loglik


def _predict(x: np.ndarray, P: np.ndarray, uk: np.ndarray, dt: float, gk: float,
             earth: EarthModel, F: np.ndarray, Qm: np.ndarray, var_u: np.ndarray,
             specific_force: bool = True, gust_decay: float = 1.0,
             second_order: bool = False):
    """Time update of ``(x, P)`` over one step; writes the transition matrix into ``F``."""
    x = propagate(x, uk, dt, gk, earth, F, specific_force, gust_decay, second_order)
    G = F[:9, 9:15]
    P = F @ P @ F.T + Qm
    P[:9, :9] += (G * var_u) @ G.T
    return x, P


def run_filter(initial: StateEstimate, u: np.ndarray, z: np.ndarray, dt: float,
               g: np.ndarray, earth: EarthModel, noise: FilterNoise,
               iteration: IteratedUpdate = IteratedUpdate(), *,
               arm: np.ndarray | None = None, specific_force: bool = True,
               gust_decay: float = 1.0, second_order: bool = False) -> dict:
    """Forward pass of the iterated extended Kalman filter.

    Parameters
    ----------
    initial : StateEstimate
        Initial state estimate (28,) and its covariance (28, 28).
    u : (n, 6) ndarray
        Measured IMU inputs (``ax, ay, az`` [m/s^2], ``p, q, r`` [rad/s]); finite.
    z : (n, 12) ndarray
        Measurements (:data:`~simplexspline.aero.reconstruction.kinematics.MEASUREMENT_NAMES`);
        NaN marks a missing sample, which is skipped.
    dt : float
        Sample interval [s].
    g : (n,) ndarray
        Gravity [m/s^2] per sample.
    earth : EarthModel
    noise : FilterNoise
        IMU, process and measurement noise.
    iteration : IteratedUpdate
        Stopping rule of the iterated measurement update.
    arm : (n, 9) ndarray, optional
        Per sample, ``omega x r`` [m/s] of the alpha and the beta vane and ``(0, r, -q)``
        (see :func:`~simplexspline.aero.reconstruction.kinematics.measure`); None: at the
        c.g.
    specific_force : bool
        False without accelerometers (body velocities as a random walk; ``u[:, :3]`` unused).
    gust_decay : float
        ``exp(-dt / tau)`` of the gusts' Gauss-Markov process (their process noise is in
        ``noise.process_var``); 1: gusts held.
    second_order : bool
        The second-order step for coarsely sampled inputs
        (:func:`~simplexspline.aero.reconstruction.kinematics.propagate`).

    Returns
    -------
    dict
        ``x_filt`` (n, 28), ``P_filt`` (n, 28, 28), ``x_pred`` (n, 28) and ``P_pred``
        (n, 28, 28) (row k is the prediction of sample k; row 0 is the prior), ``F``
        (n, 28, 28) (row k maps sample k to k + 1), ``innov`` (n, 12) innovations of the
        prediction (NaN where not measured), ``innov_var`` (n, 12) their predicted variances,
        ``iterations`` (n,) int, ``loglik`` (float) the log-likelihood of the measurements.

    Notes
    -----
    With numba (:data:`~simplexspline.aero.reconstruction.filter_kernels.HAVE_NUMBA`) the
    pass runs compiled (:func:`~simplexspline.aero.reconstruction.filter_kernels.filter_pass`,
    the same results to round-off); where it meets a non-positive-definite innovation
    covariance or a non-finite state, the Python path below reruns the pass and raises
    its error.
    """
    if filter_kernels.HAVE_NUMBA:
        out = _run_filter_compiled(initial, u, z, dt, g, earth, noise, iteration, arm,
                                   specific_force, gust_decay, second_order)
        if out is not None:
            return out
    n = u.shape[0]
    x_filt = np.empty((n, NX))
    P_filt = np.empty((n, NX, NX))
    x_pred = np.empty((n, NX))
    P_pred = np.empty((n, NX, NX))
    Fs = np.zeros((n, NX, NX))
    Fs[:, np.arange(NX), np.arange(NX)] = 1.0     # propagate writes the non-trivial entries
    innov = np.full((n, NZ), np.nan)
    innov_var = np.full((n, NZ), np.nan)
    iters = np.zeros(n, dtype=np.int64)
    R_full = np.diag(noise.measurement_std ** 2)
    var_u = noise.input_std ** 2
    Qm = np.diag(noise.process_var)
    H = np.zeros((NZ, NX))
    finite = np.isfinite(z)
    all_ok = finite.all(axis=1)
    x = np.array(initial.x, dtype=float)
    P = np.array(initial.P, dtype=float)
    loglik = 0.0
    for k in range(n):
        x_pred[k] = x
        P_pred[k] = P
        meas = _measured(z[k], finite[k], all_ok[k], R_full)
        if meas.z.size:
            x, P, iters[k], (res, res_var), ll = _iterated_update(
                x, P, meas, H, iteration, k, None if arm is None else arm[k])
            loglik += ll
            cols = slice(None) if meas.sel is None else meas.sel
            innov[k, cols] = res
            innov_var[k, cols] = res_var
        x_filt[k] = x
        P_filt[k] = P
        x, P = _predict(x, P, u[k], dt, g[k], earth, Fs[k], Qm, var_u, specific_force,
                        gust_decay, second_order)
    return {"x_filt": x_filt, "P_filt": P_filt, "x_pred": x_pred, "P_pred": P_pred, "F": Fs,
            "innov": innov, "innov_var": innov_var, "iterations": iters,
            "loglik": float(loglik)}


def _run_filter_compiled(initial: StateEstimate, u, z, dt, g, earth: EarthModel,
                         noise: FilterNoise, iteration: IteratedUpdate, arm,
                         specific_force: bool, gust_decay: float,
                         second_order: bool = False) -> dict | None:
    """:func:`run_filter` by the compiled kernel; None where it stopped on numerical
    trouble (the Python path then reproduces the reference's error)."""
    n = u.shape[0]
    out = {"x_filt": np.empty((n, NX)), "P_filt": np.empty((n, NX, NX)),
           "x_pred": np.empty((n, NX)), "P_pred": np.empty((n, NX, NX)),
           "F": np.empty((n, NX, NX)), "innov": np.full((n, NZ), np.nan),
           "innov_var": np.full((n, NZ), np.nan), "iterations": np.zeros(n, dtype=np.int64)}
    params = np.array([earth.rn, earth.rm, earth.tan_lat, *earth.wie, float(earth.rotation),
                       float(second_order)])
    arm = np.zeros((n, 9)) if arm is None else np.ascontiguousarray(arm, dtype=float)
    status, _, loglik = filter_kernels.filter_pass(
        np.array(initial.x, dtype=float), np.array(initial.P, dtype=float),
        np.ascontiguousarray(u, dtype=float), np.ascontiguousarray(z, dtype=float),
        float(dt), np.ascontiguousarray(g, dtype=float), params,
        np.asarray(noise.measurement_std, dtype=float) ** 2,
        np.asarray(noise.input_std, dtype=float) ** 2,
        np.ascontiguousarray(noise.process_var, dtype=float), float(iteration.tol),
        int(iteration.max_iter), arm, bool(specific_force), float(gust_decay),
        out["x_filt"], out["P_filt"], out["x_pred"], out["P_pred"], out["F"], out["innov"],
        out["innov_var"], out["iterations"])
    if status != filter_kernels.OK:
        return None
    out["loglik"] = float(loglik)
    return out


def rts_smooth(out: dict, *, covariance: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """Rauch-Tung-Striebel fixed-interval smoother over a forward pass.

    ``x_s[k] = x_f[k] + C_k (x_s[k+1] - x_p[k+1])`` with ``C_k = P_f[k] F_k' P_p[k+1]^-1``
    (all gains computed in one batched solve).

    Parameters
    ----------
    out : dict
        The result of :func:`run_filter`.
    covariance : bool
        Also return the diagonal of the smoothed covariance (one more pass with two matrix
        products per sample).

    Returns
    -------
    x_s : (n, 28) ndarray
    var_s : (n, 28) ndarray or None
        Smoothed variances, when ``covariance``.
    """
    xf, Pf, xp, Pp, F = out["x_filt"], out["P_filt"], out["x_pred"], out["P_pred"], out["F"]
    n = xf.shape[0]
    xs = xf.copy()
    if n < 2:
        return xs, (np.diagonal(Pf, axis1=1, axis2=2).copy() if covariance else None)
    compiled = filter_kernels.HAVE_NUMBA
    if compiled:
        # the gains applied to the vectors, one solve per sample (smooth_pass)
        filter_kernels.smooth_pass(*(np.ascontiguousarray(a, dtype=float)
                                     for a in (xf, Pf, xp, Pp, F)), xs)
        if not covariance:
            return xs, None
    # C_k' = P_p[k+1]^-1 F_k P_f[k]   (P symmetric)
    Ct = np.linalg.solve(Pp[1:], F[:-1] @ Pf[:-1])
    C = np.transpose(Ct, (0, 2, 1))
    if not compiled:
        for k in range(n - 2, -1, -1):
            xs[k] = xf[k] + C[k] @ (xs[k + 1] - xp[k + 1])
    var = None
    if covariance:
        var = np.empty((n, NX))
        Ps = Pf[-1].copy()
        var[-1] = np.diag(Ps)
        for k in range(n - 2, -1, -1):
            Ps = Pf[k] + C[k] @ (Ps - Pp[k + 1]) @ Ct[k]
            var[k] = np.diag(Ps)
    return xs, var
