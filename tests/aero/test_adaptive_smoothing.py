"""Adaptive smoothing of control-surface positions (LPA-ICI with a risk-chosen threshold)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simplexspline.aero.data.adaptive_smoothing import (
    noise_std, smooth_adaptive, smooth_by_maneuver)
from simplexspline.errors import InputError

SIGMA = 3.5e-4           # 0.02 deg


def _rms(a):
    return float(np.sqrt(np.mean(np.square(a))))


def _sum_of_sines(t):
    return 0.02 * np.sin(1.3 * t) + 0.01 * np.sin(4.1 * t + 0.3) + 0.005 * np.sin(9.7 * t)


def _pulses(n, dt=0.01):
    """A 3211 at 1 s per unit with ramps at 1.5 rad/s (an actuator's rate limit)."""
    t = np.arange(n) * dt
    levels = np.zeros(n)
    for start, stop, level in ((1, 4, 0.05), (4, 6, -0.05), (6, 7, 0.05), (7, 8, -0.05)):
        levels[(t >= start) & (t < stop)] = level
    out = np.zeros(n)
    for k in range(1, n):            # rate limit
        out[k] = out[k - 1] + np.clip(levels[k] - out[k - 1], -1.5 * dt, 1.5 * dt)
    return out


@pytest.mark.parametrize("kind", ["white", "sines 100 Hz", "pulses", "sines 10 Hz"])
def test_noise_level_is_found_whatever_the_signal(kind):
    rng = np.random.default_rng(0)
    if kind == "white":
        truth = np.zeros(3000)
    elif kind == "sines 100 Hz":
        truth = _sum_of_sines(np.arange(3000) * 0.01)
    elif kind == "pulses":
        truth = _pulses(1200)
    else:
        truth = _sum_of_sines(np.arange(600) * 0.1)
    est = noise_std(truth + SIGMA * rng.standard_normal(truth.size))
    assert 0.8 * SIGMA < est < 1.25 * SIGMA, est


def test_smooth_signals_lose_most_of_their_noise():
    rng = np.random.default_rng(1)
    truth = _sum_of_sines(np.arange(4000) * 0.01)
    r = smooth_adaptive(truth + SIGMA * rng.standard_normal(truth.size))
    err = _rms(r.values - truth)
    assert err < 0.45 * SIGMA, err / SIGMA
    assert r.gamma > 0 and 0 < r.risk_ratio < 0.45
    # the risk estimate is an honest estimate of the error
    assert r.risk_ratio == pytest.approx((err / SIGMA) ** 2, rel=0.5)


def test_pulse_edges_are_kept():
    rng = np.random.default_rng(2)
    truth = _pulses(1000)
    x = truth + SIGMA * rng.standard_normal(truth.size)
    r = smooth_adaptive(x)
    assert _rms(r.values - truth) < 0.6 * SIGMA
    # a global smoother of the same average window would round the edges off
    assert np.max(np.abs(r.values - truth)) < 8 * SIGMA


def test_noise_free_signals_and_quadratics_are_returned_unchanged():
    t = np.linspace(-1.0, 1.0, 500)
    quartic = 0.3 - t + 0.5 * t ** 2 - 0.2 * t ** 3 + 0.1 * t ** 4
    r = smooth_adaptive(quartic)                  # no noise found: left as measured
    assert r.noise_std < 1e-12 and np.array_equal(r.values, quartic)
    # told a noise, every window (centred quartic, one-sided quadratic) reproduces a
    # quadratic: any threshold returns it
    quadratic = 0.3 - t + 0.5 * t ** 2
    for gamma in (0.5, 3.0):
        r = smooth_adaptive(quadratic, noise=1e-3, gammas=(gamma,))
        np.testing.assert_allclose(r.values, quadratic, atol=1e-12)


def test_an_undersampled_signal_is_not_made_worse():
    """At 10 Hz the fast parts of a sum of sines look like noise to a short window; the
    risk estimate keeps the smoother from trading them for bias."""
    rng = np.random.default_rng(3)
    worse = []
    for k in range(20):
        truth = _sum_of_sines(np.arange(400) * 0.1 + k)
        x = truth + SIGMA * rng.standard_normal(truth.size)
        worse.append(_rms(smooth_adaptive(x).values - truth) / _rms(x - truth))
    assert np.median(worse) < 1.0 and max(worse) < 1.15, worse


def test_deterministic():
    rng = np.random.default_rng(4)
    x = _sum_of_sines(np.arange(800) * 0.01) + SIGMA * rng.standard_normal(800)
    assert np.array_equal(smooth_adaptive(x).values, smooth_adaptive(x).values)


@settings(max_examples=25, deadline=None)
@given(n=st.integers(16, 400), scale=st.floats(1e-6, 1.0), seed=st.integers(0, 2 ** 16))
def test_any_signal_gives_a_finite_result_no_worse_by_its_risk(n, scale, seed):
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.standard_normal(n)) * scale + scale * rng.standard_normal(n)
    r = smooth_adaptive(x)
    assert r.values.shape == x.shape and np.isfinite(r.values).all()
    assert r.risk_ratio <= 1.0
    assert (r.gamma == 0) == np.array_equal(r.values, x) or r.gamma > 0


def _ici_by_definition(fits, sds, halves, x, room, gamma):
    """Per sample, the largest window whose interval meets every smaller window's and
    that fits in the sample's room (the definition, one sample at a time)."""
    est, sd = x.copy(), np.full(x.size, np.inf)
    for i in range(x.size):
        lo, hi = -np.inf, np.inf
        for y, s, h in zip(fits[:, i], sds, halves):
            lo, hi = max(lo, y - gamma * s), min(hi, y + gamma * s)
            if lo > hi or room[i] < h:
                break
            est[i], sd[i] = y, s
    return est, sd


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 40), k=st.integers(0, 6), gamma=st.sampled_from((0.5, 1.0, 3.0)),
       seed=st.integers(0, 2 ** 16))
def test_ici_takes_the_largest_consistent_window(n, k, gamma, seed):
    """The window choice, compiled and in numpy, equals the definition sample by sample
    (also with no windows at all, and samples without room for the first one)."""
    from simplexspline.aero.data.adaptive_smoothing import _ici, _ici_numpy

    rng = np.random.default_rng(seed)
    fits = np.cumsum(rng.standard_normal((k, n)), axis=0) * 0.3 + rng.standard_normal(n)
    sds = np.sort(rng.uniform(0.1, 1.0, k))[::-1]
    halves = np.cumsum(rng.integers(1, 3, k))
    x = rng.standard_normal(n)
    room = rng.integers(0, 12, n)
    ref_est, ref_sd = _ici_by_definition(fits, sds, halves, x, room, gamma)
    for ici in (_ici, _ici_numpy):           # compiled (where numba is) and numpy paths
        est, sd = ici(fits, sds, halves, x, room, gamma)
        assert np.array_equal(est, ref_est) and np.array_equal(sd, ref_sd)


def test_by_maneuver_keeps_gaps_and_does_not_smear_across_maneuvers():
    rng = np.random.default_rng(5)
    t = np.arange(600) * 0.01
    a, b = _sum_of_sines(t), _sum_of_sines(t) + 0.2          # a jump between maneuvers
    values = np.r_[a, b] + SIGMA * rng.standard_normal(1200)
    values[100:110] = np.nan
    maneuver = np.r_[np.zeros(600, int), np.ones(600, int)]
    out, results = smooth_by_maneuver(maneuver, values)
    assert np.isnan(out[100:110]).all() and np.isfinite(np.delete(out, range(100, 110))).all()
    assert len(results) == 3                          # two runs in maneuver 0, one in 1
    truth = np.r_[a, b]
    keep = np.isfinite(out)
    assert _rms(out[keep] - truth[keep]) < 0.75 * SIGMA      # short runs: less to gain
    assert abs(out[600] - truth[600]) < 5 * SIGMA      # the jump is not smeared


@pytest.mark.parametrize("call, match", [
    (lambda: smooth_adaptive(np.array([0.0, np.nan] * 20)), "NaN or infinite"),
    (lambda: smooth_adaptive(np.zeros((20, 2))), "one-dimensional"),
    (lambda: smooth_adaptive(np.zeros(40), degree=3), "even integer"),
    (lambda: smooth_adaptive(np.zeros(40), gammas=(1.0, -1.0)), "positive numbers"),
    (lambda: smooth_adaptive(np.zeros(40), probes=0), "positive integer"),
    (lambda: smooth_adaptive(np.zeros(40), noise=-1.0), "noise must be"),
    (lambda: smooth_by_maneuver(np.zeros(5), np.zeros(6)), "one length"),
])
def test_bad_input_is_named(call, match):
    with pytest.raises(InputError, match=match):
        call()


def test_reconstruction_smooths_the_controls_and_says_so(noisy_campaign, noisy_reconstruction):
    from simplexspline.aero import ReconstructionSettings, reconstruct

    rec = noisy_reconstruction
    data = rec.data
    for ch in ("de", "da", "dr"):
        raw = noisy_campaign.loc[data.index, ch] - data[f"true_{ch}"]
        assert _rms(data[ch] - data[f"true_{ch}"]) < 0.6 * _rms(raw), ch
        st = rec.control_smoothing[ch]
        assert st["smoothed"] >= 1 and 0 < st["risk_ratio"] < 1
    assert "control de: smoothed in" in rec.summary()
    assert data.attrs["reconstruction"]["control_smoothing"]["de"]["runs"] >= 1
    off = reconstruct(noisy_campaign.iloc[:3000], workers=1,
                      settings=ReconstructionSettings(smooth_controls=False))
    assert off.control_smoothing == {}
    np.testing.assert_array_equal(off.data["de"], noisy_campaign.loc[off.data.index, "de"])
