"""The filter kernel on data from its own model: a maneuver in gusts with an airspeed bias.

The data come from the state and measurement equations the filter uses
(:mod:`simplexspline.aero.reconstruction.kinematics`), with gusts drawn from the filter's own
Gauss-Markov model, so any error beyond the reported sigma is the estimator's, not a model
mismatch.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplexspline.aero.reconstruction.gusts import gust_process
from simplexspline.aero.reconstruction.iekf import (
    FilterNoise, IteratedUpdate, StateEstimate, run_filter,
)
from simplexspline.aero.reconstruction.kinematics import (
    GUST, MEASUREMENT_NAMES, NX, STATE_NAMES, EarthModel, measure, propagate,
)

DT = 0.1                    # s: a 10 Hz flight-test record
G0 = 9.81
BTAS = 0.5                  # m/s: the airspeed sensor's bias
WIND = (5.0, -3.0, 0.0)     # m/s NED
LENGTH_M = 300.0            # correlation length of the gusts
NOISE = {"x_gps": 2.0, "y_gps": 2.0, "z_gps": 4.0, "vn_gps": 0.05, "ve_gps": 0.05,
         "vd_gps": 0.1, "tas": 0.1, "alpha": 1.7e-3, "beta": 1.7e-3, "phi": 8.7e-4,
         "theta": 8.7e-4, "psi": 1.7e-3}
IMU_NOISE = np.array([0.01, 0.01, 0.01, 1.7e-4, 1.7e-4, 1.7e-4])
IBTAS = STATE_NAMES.index("btas")


def _c_bn(phi: float, theta: float, psi: float) -> np.ndarray:
    """NED to body rotation (3-2-1 Euler angles)."""
    cf, sf, ct, st, cp, sp = (math.cos(phi), math.sin(phi), math.cos(theta),
                              math.sin(theta), math.cos(psi), math.sin(psi))
    return np.array([[ct * cp, ct * sp, -st],
                     [sf * st * cp - cf * sp, sf * st * sp + cf * cp, sf * ct],
                     [cf * st * cp + sf * sp, cf * st * sp - sf * cp, cf * ct]])


def _turn(seed: int, bank_deg: float, gust_std: float, airspeed: float = 145.0,
          duration_s: float = 36.0):
    """A steady level turn (0: straight) at ``bank_deg`` in gusts: true states, the IMU
    inputs with noise and the measurements with noise."""
    rng = np.random.default_rng(seed)
    earth = EarthModel(math.radians(52.0), rotation=False)
    n = int(round(duration_s / DT))
    phi, alpha = math.radians(bank_deg), math.radians(3.0)
    turn_rate = G0 * math.tan(phi) / airspeed
    rates = np.array([0.0, turn_rate * math.sin(phi), turn_rate * math.cos(phi)])
    decay, q_gust = gust_process(gust_std, LENGTH_M, airspeed, DT)
    x = np.zeros(NX)
    x[6:9] = [phi, alpha, 0.3]
    x[IBTAS] = BTAS
    x[18:21] = WIND
    x[GUST] = gust_std * rng.standard_normal(3)
    air = airspeed * np.array([math.cos(alpha), 0.0, math.sin(alpha)])
    x[3:6] = air + _c_bn(*x[6:9]) @ (x[18:21] + x[GUST])
    F = np.eye(NX)
    states, inputs = np.empty((n, NX)), np.empty((n, 6))
    for k in range(n):
        states[k] = x
        ph, th = x[6], x[7]
        gravity = G0 * np.array([-math.sin(th), math.sin(ph) * math.cos(th),
                                 math.cos(ph) * math.cos(th)])
        inputs[k, :3] = np.cross(rates, x[3:6]) - gravity     # keeps the ground path steady
        inputs[k, 3:] = rates
        x = propagate(x, inputs[k], DT, G0, earth, F, gust_decay=decay)
        x[GUST] += math.sqrt(q_gust) * rng.standard_normal(3)
    noise = np.array([NOISE[c] for c in MEASUREMENT_NAMES])
    z = np.array([measure(s, None) for s in states]) + noise * rng.standard_normal((n, 12))
    z[:, :3] -= states[0, :3]
    u = inputs + IMU_NOISE * rng.standard_normal(inputs.shape)
    u[:-1, :3] = 0.5 * (u[:-1, :3] + u[1:, :3])
    return states, u, z, earth


def _estimate(seed: int, *, bank_deg: float, gust_std: float, missing=(),
              heading_error: float = 0.0, update: IteratedUpdate = IteratedUpdate()):
    """The filter's final airspeed bias and its sigma, started with the bias and the wind
    at zero (sigmas 2 and 10 m/s) and, without a heading channel, the heading off by
    ``heading_error`` (sigma 0.3 rad)."""
    states, u, z, earth = _turn(seed, bank_deg, gust_std)
    for c in missing:
        z[:, MEASUREMENT_NAMES.index(c)] = np.nan
    x0 = states[0].copy()
    x0[:3] = 0.0
    x0[IBTAS] = 0.0
    x0[18:21] = 0.0
    x0[GUST] = 0.0
    sd = np.full(NX, 1e-8)
    sd[0:3], sd[3:6], sd[6:9] = 5.0, 10.0, 0.01
    sd[9:12], sd[12:15], sd[15:17] = 0.1, 2e-3, 0.02
    sd[IBTAS], sd[18:20], sd[20] = 2.0, 10.0, 1.0
    sd[GUST] = gust_std
    if "psi" in missing:
        x0[8] += heading_error
        sd[8] = 0.3
    decay, q_gust = gust_process(gust_std, LENGTH_M, 145.0, DT)
    q = np.zeros(NX)
    q[3:6], q[6:9], q[9:21] = (0.03 * DT) ** 2, (1e-6 * DT) ** 2, 1e-16
    q[GUST] = q_gust
    noise = FilterNoise(IMU_NOISE, q, np.array([NOISE[c] for c in MEASUREMENT_NAMES]))
    out = run_filter(StateEstimate(x0, np.diag(sd ** 2)), u, z, DT, np.full(len(u), G0),
                     earth, noise, update, gust_decay=decay)
    return out["x_filt"][-1, IBTAS], math.sqrt(out["P_filt"][-1, IBTAS, IBTAS])


SEEDS = range(6)


def test_airspeed_bias_does_not_drift_in_gusts_in_straight_flight():
    """Straight flight cannot tell the airspeed bias from the along-track wind: the filter
    must leave it near its prior. Relinearising the update at every sample until it moved
    less than 1e-3 predicted sigmas (the old stopping rule) walked it to 12.7-14.9 m/s
    (sigma 1.9) in gusts of 2 m/s: each relinearisation at the gust just estimated turned
    the air-data Jacobians, and the update moved along the unobservable direction, always
    the same way. Stopping once the linearisation error is a tenth of the measurement noise:
    within 1.2 m/s."""
    for seed in SEEDS:
        value, sd = _estimate(seed, bank_deg=0.0, gust_std=2.0)
        assert sd > 0.9 * 2.0                             # m/s: the prior's, unobservable
        assert abs(value - BTAS) < sd, (seed, value, sd)
    drift, sd = _estimate(0, bank_deg=0.0, gust_std=2.0, update=IteratedUpdate(tol=1e-3))
    assert drift - BTAS > 3 * sd                          # the old rule's drift


@pytest.mark.parametrize("missing, heading_error", [
    ((), 0.0),
    (("psi", "beta", "vn_gps", "ve_gps", "vd_gps"), 0.1),
], ids=["all sensors", "no heading, no beta vane, GPS positions only"])
def test_turn_in_gusts_recovers_the_airspeed_bias_within_its_sigma(missing, heading_error):
    """A 36 s turn at 30 deg bank (80 deg of heading change) in 1.5 m/s gusts: the airspeed
    bias comes out within its sigma's spread over the seeds. Without heading, sideslip vane
    and GPS velocities the old stopping rule gave +1.7..+5.1 m/s for a true 0.5 (sigma 1.3),
    the bias seen on the whole-flight rehearsal (over 24 seeds now: mean error 0.00 +- 0.25,
    normalised RMS 0.94; with all sensors -0.35 +- 0.21, 1.1)."""
    est = np.array([_estimate(seed, bank_deg=30.0, gust_std=1.5, missing=missing,
                              heading_error=heading_error) for seed in SEEDS])
    z = (est[:, 0] - BTAS) / est[:, 1]
    assert (np.abs(z) < 3).all(), est
    assert math.sqrt(np.mean(z ** 2)) < 1.6, est
    assert abs(np.mean(z)) < 3 / math.sqrt(len(z)), est     # no bias beyond the spread
    assert np.mean(est[:, 1]) < 0.8 * 2.0                 # the turn informs it
