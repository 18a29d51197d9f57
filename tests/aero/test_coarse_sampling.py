"""The kinematic step for records sampled coarser than the aircraft moves (10-20 Hz): the
inputs' means over the step by a cubic through four samples, and a step second order in dt.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplexspline.aero.reconstruction.kinematics import (
    NX, EarthModel, propagate, step_mean,
)


def test_step_mean_is_exact_for_cubics_and_falls_back_to_the_trapezoid():
    t = np.linspace(0.0, 2.0, 21)
    c = np.array([0.3, -1.2, 0.7, 0.4])

    def antiderivative(x):
        return sum(ci * x ** (i + 1) / (i + 1) for i, ci in enumerate(c))

    values = np.column_stack([sum(ci * t ** i for i, ci in enumerate(c)), np.ones_like(t)])
    means = step_mean(values)
    exact = (antiderivative(t[1:]) - antiderivative(t[:-1])) / np.diff(t)
    np.testing.assert_allclose(means[1:-1, 0], exact[1:-1], rtol=1e-12)
    np.testing.assert_allclose(means[:, 1], 1.0)
    # the end intervals (no outer neighbour) and a missing sample's neighbours: trapezoid
    np.testing.assert_allclose(means[[0, -1], 0], 0.5 * (values[[0, -2], 0] + values[[1, -1], 0]))
    values[10, 0] = np.nan
    gap = step_mean(values)
    np.testing.assert_allclose(gap[[8, 11], 0], 0.5 * (values[[8, 11], 0] + values[[9, 12], 0]))
    assert np.isfinite(gap[:, 0]).sum() == len(gap) - 2


def _inputs(t):
    """Smooth IMU inputs of a pull-up with rolling: specific force [m/s^2], rates [rad/s]."""
    w = 2 * math.pi * 0.8
    return np.column_stack([
        0.8 * np.sin(w * t), 0.4 * np.cos(1.3 * w * t), -9.8 - 4.0 * np.sin(w * t),
        0.3 * np.sin(0.9 * w * t), 0.12 * np.cos(w * t), 0.05 * np.sin(0.7 * w * t)])


def _fly(dt: float, duration: float, second_order: bool, cubic: bool = True) -> np.ndarray:
    earth = EarthModel(math.radians(52.0))
    x = np.zeros(NX)
    x[3:6] = (150.0, 0.0, 5.0)
    x[6:9] = (0.05, 0.03, 0.4)
    F = np.eye(NX)
    n = int(round(duration / dt))
    t = np.arange(-1, n + 2) * dt               # one sample beyond each end for the cubic
    u = _inputs(t)
    means = step_mean(u)[1:n + 1] if cubic else 0.5 * (u[1:n + 1] + u[2:n + 2])
    for k in range(n):
        x = propagate(x, means[k], dt, 9.81, earth, F, second_order=second_order)
    return x


@pytest.mark.parametrize("second_order, order", [(True, 2.0), (False, 1.0)])
def test_convergence_order_of_the_step(second_order, order):
    """Errors at the end of a 4 s maneuver against a 1 ms reference: halving the step
    divides them by 4 with the second-order step, by 2 without."""
    reference = _fly(0.001, 4.0, True)
    err = [np.abs(_fly(dt, 4.0, second_order) - reference) for dt in (0.1, 0.05, 0.025)]
    for j in (slice(3, 6), slice(0, 3), slice(6, 9)):
        e = [float(np.max(v[j])) for v in err]
        rates = np.log2(np.array(e[:-1]) / np.array(e[1:]))
        assert np.all(rates > order - 0.3), (j, e, rates)
    if second_order:       # at 10 Hz: velocity within 5 cm/s, position within 5 cm (the
        # first-order step: 4 cm/s and 29 cm)
        assert np.max(err[0][3:6]) < 0.05 and np.max(err[0][0:3]) < 0.05


def test_cubic_means_beat_the_trapezoid_at_10_hz():
    reference = _fly(0.001, 4.0, True)
    cubic = np.max(np.abs(_fly(0.1, 4.0, True) - reference)[3:6])
    trapezoid = np.max(np.abs(_fly(0.1, 4.0, True, cubic=False) - reference)[3:6])
    assert cubic < 0.5 * trapezoid, (cubic, trapezoid)


def test_a_fractional_lag_is_undone_exactly_for_cubics():
    from simplexspline.aero.reconstruction.sensor_corrections import undo_lag

    t = np.arange(60) * 0.1
    def cubic(x):
        return 0.3 + x - 0.2 * x ** 2 + 0.05 * x ** 3

    y = undo_lag(cubic(t), 0.1, 0.05)
    np.testing.assert_allclose(y[1:-2], cubic(t[1:-2] + 0.05), rtol=0, atol=1e-12)
    assert np.isnan(y[-1]) and np.isfinite(y[-2])          # beyond the record: NaN
    assert undo_lag(cubic(t), 0.1, 0.05, hold=True)[-1] == cubic(t)[-1]
    # a 1 Hz motion at 10 Hz, half a sample: 0.4 % instead of linear's 5 %
    s = np.sin(2 * np.pi * t)
    err = undo_lag(s, 0.1, 0.05)[1:-2] - np.sin(2 * np.pi * (t[1:-2] + 0.05))
    assert np.max(np.abs(err)) < 0.004
    # a missing sample: its neighbourhood falls back to linear interpolation, not NaN
    s[30] = np.nan
    z = undo_lag(s, 0.1, 0.05)
    assert np.isnan(z[29]) and np.isnan(z[30]) and np.isfinite(z[[27, 28, 31, 32]]).all()


def test_a_10_hz_record_gets_its_angular_accelerations_at_the_samples(noisy_campaign):
    """The six noisy f16 maneuvers taken at every tenth sample (a 10 Hz record without
    angular accelerations): the moment coefficients' error against the truth with the
    default derivative (at the samples, 5 of them) is under 0.3x that of the 16-sample
    midpoint derivative, which spans 1.6 s at 10 Hz and flattens the short period (measured:
    0.13-0.14x)."""
    from simplexspline.aero import ReconstructionSettings, reconstruct

    coarse = noisy_campaign.groupby("maneuver", sort=False).nth(slice(None, None, 10))
    coarse = coarse.drop(columns=["pdot", "qdot", "rdot"]).reset_index(drop=True)
    coarse.attrs = {**noisy_campaign.attrs, "sample_rate_hz": 10.0}

    def errors(**settings):
        d = reconstruct(coarse, workers=1, settings=ReconstructionSettings(**settings)).data
        return np.array([np.sqrt(np.mean((d[c] - d["true_" + c]) ** 2))
                         for c in ("Cl", "Cm", "Cn")])

    new, old = errors(), errors(diff_half_window=8)
    assert np.all(new < 0.3 * old), (new, old)
