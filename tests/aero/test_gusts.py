"""Turbulence in the flight path reconstruction: the gust model and its choice by the data."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplexspline.aero import ReconstructionSettings, reconstruct
from simplexspline.aero.reconstruction.gusts import GUST_EVIDENCE, choose_gusts, gust_process
from simplexspline.errors import InputError
from simplexspline.sim.sensors import DEFAULT_NOISE_STD

GPS = ["x_gps", "y_gps", "z_gps", "vn_gps", "ve_gps", "vd_gps"]


def test_gauss_markov_process_keeps_its_variance():
    a, q = gust_process(1.5, 300.0, 150.0, 0.01)
    assert a == pytest.approx(math.exp(-0.01 / 2.0))
    assert q / (1 - a * a) == pytest.approx(1.5 ** 2)        # stationary variance std^2
    assert gust_process(0.0, 300.0, 150.0, 0.01) == (1.0, 0.0)
    # simulated: the sample variance and the correlation time match
    rng = np.random.default_rng(0)
    g = np.zeros(200_000)
    for k in range(1, g.size):
        g[k] = a * g[k - 1] + math.sqrt(q) * rng.standard_normal()
    assert g.std() == pytest.approx(1.5, rel=0.05)
    assert np.corrcoef(g[:-200], g[200:])[0, 1] == pytest.approx(math.exp(-1.0), abs=0.05)


def _fake_run(best_std, log):
    """A forward pass whose likelihood peaks at ``best_std`` (and length 300 m)."""

    def run(std, length):
        log.append((std, length))
        ll = -(math.log(max(std, 1e-3) / best_std)) ** 2 - 0.1 * abs(math.log(length / 300.0))
        return {"loglik": ll, "x_filt": np.zeros((2, 2)), "std": std}

    return run


def test_still_air_is_kept_when_its_innovations_are_consistent():
    log = []
    choice = choose_gusts(_fake_run(1.0, log), (0.3, 1.0, 3.0), (100.0, 300.0, 1000.0),
                          lambda out: 1.1)
    assert choice.std == 0.0 and log == [(0.0, 300.0)]          # one pass, no search


def test_the_likelihood_chooses_the_intensity_and_length():
    log = []
    choice = choose_gusts(_fake_run(1.0, log), (0.3, 1.0, 3.0), (100.0, 300.0, 1000.0),
                          lambda out: GUST_EVIDENCE + 1)
    assert (choice.std, choice.length_m) == (1.0, 300.0)
    assert choice.out["std"] == 1.0 and len(choice.scores) == len(log) == 6
    # a fixed intensity (no still-air pass): only the length is searched
    log.clear()
    choice = choose_gusts(_fake_run(1.0, log), (3.0,), (100.0, 300.0, 1000.0), None)
    assert choice.std == 3.0 and (0.0, 300.0) not in log


def test_failed_candidates_are_skipped_and_all_failing_raises():
    def run(std, length):
        if std < 2.0:
            raise FloatingPointError("diverged")
        return {"loglik": 1.0, "x_filt": np.zeros(1)}

    assert choose_gusts(run, (0.3, 1.0, 3.0), (300.0,), lambda out: 9.0).std == 3.0
    with pytest.raises(FloatingPointError, match="diverged"):
        choose_gusts(run, (0.3, 1.0), (300.0,), lambda out: 9.0)


def test_gust_settings_are_validated():
    with pytest.raises(InputError, match="gust_std"):
        ReconstructionSettings(gust_std=-1.0)
    with pytest.raises(InputError, match="gust_lengths_m"):
        ReconstructionSettings(gust_lengths_m=())
    with pytest.raises(InputError, match="gust_candidates"):
        ReconstructionSettings(gust_candidates=(1.0, float("nan")))


@pytest.fixture(scope="module")
def turbulent():
    """One 11 s elevator 3211 in an 8 m/s wind with JSBSim's light turbulence (default
    sensors, 100 Hz)."""
    from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol, SensorModel
    from simplexspline.sim.wind import Wind

    return Campaign("f16", maneuvers=1, seed=2, sensors=SensorModel(),
                    wind=Wind((8.0, 8.0), "light"),
                    grid=ConditionGrid(altitudes_m=[3000.0], airspeeds_mps=[180.0]),
                    protocol=FlightProtocol(mix={"3211": 1})).run(workers=1, progress=False)


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


@pytest.mark.parametrize("drop", [[], GPS], ids=["all sensors", "no GPS"])
def test_light_turbulence_is_reconstructed(turbulent, drop):
    """With gusts the air data are followed: the error's fluctuating part is below the raw
    sensor noise, the whole error below the raw sensor's, the innovations are consistent.
    The sensors' constant errors cannot be told from the slow part of the gusts in one
    straight maneuver: they stay (held, said so). The still-air model pushes the gusts
    into the constant states (with GPS: alpha 0.16 rad and airspeed 25 m/s off)."""
    data = turbulent.drop(columns=drop)
    assert turbulent["true_wind_d"].std() > 0.5                    # m/s: gusts
    rec = reconstruct(data, settings=ReconstructionSettings(estimate_lags=False))
    (m, r), = rec.maneuvers.items()
    assert r["gusts"]["std"] > 0 and r["gusts"]["still_air_excess"] > GUST_EVIDENCE
    d = rec.data
    for ch in ("alpha", "beta", "tas"):
        err, raw = d[ch] - d["true_" + ch], data[ch] - data["true_" + ch]
        assert err.std() < 0.9 * DEFAULT_NOISE_STD[ch], ch
        assert _rms(err) < _rms(raw), ch
        assert r["innovations"][ch]["std"] < 1.5, ch
    assert "turbulence: gusts estimated in 1 of 1 maneuvers" in rec.summary()
    if drop:
        return
    assert "turbulence" in r["held"]["tas"] and "turbulence" in r["held"]["beta"]
    still = reconstruct(data, settings=ReconstructionSettings(gust_std=0, estimate_lags=False))
    ds = still.data
    assert _rms(ds["alpha"] - ds["true_alpha"]) > 3 * _rms(data["alpha"] - data["true_alpha"])


def _gusty_angle(n: int, seed: int) -> np.ndarray:
    """A gust-driven angle of attack at 100 Hz (first-order Gauss-Markov, 1 s) [rad]."""
    rng = np.random.default_rng(seed)
    a = np.zeros(n)
    for k in range(1, n):
        a[k] = 0.99 * a[k - 1] + 0.003 * rng.standard_normal()
    return a


@pytest.mark.parametrize("lag", [0.0, 0.05, 0.08])
def test_a_vane_lag_is_found_against_the_force_it_drives(lag):
    """The lag of a 10 Hz vane against a normal force that follows the angle at once:
    within 0.005 s (a twentieth of a sample), with a standard error that covers it; the
    rotation term and a scale error of the vane do not move it."""
    from simplexspline.aero.reconstruction.sensor_corrections import (
        estimate_lag_from_response)
    n = 6000
    t = np.arange(n) / 100.0
    motion = 0.02 * np.sin(2 * np.pi * 0.3 * t)     # the aircraft's own (q follows it)
    a = motion + _gusty_angle(n, 1)                    # ... and the gusts' (q does not)
    rng = np.random.default_rng(2)
    q = np.gradient(motion, 0.01)
    force = 5.0 * a - 0.3 * a * a + 2.0 * q / 50.0 + 2e-3 * rng.standard_normal(n)
    vane = 1.04 * np.interp(t - lag, t, a + 4.0 * q / 50.0) + 0.01 \
        + 1.75e-3 * rng.standard_normal(n)
    k = slice(None, None, 10)
    est, sd = estimate_lag_from_response(vane[k], force[k], (q / 50.0)[k, None], 0.1)
    assert abs(est - lag) < 0.005
    assert 0 < sd < 0.005 and abs(est - lag) < 4 * sd


def test_a_vane_lag_estimate_needs_a_moving_channel():
    from simplexspline.aero.reconstruction.sensor_corrections import (
        estimate_lag_from_response)
    x = np.full(200, 0.05)
    assert np.isnan(estimate_lag_from_response(x, 5 * x, np.zeros((200, 1)), 0.1)[0])
    short = _gusty_angle(30, 3)
    assert np.isnan(estimate_lag_from_response(short, short, np.zeros((30, 1)), 0.1)[0])


def test_a_late_vane_is_undone_in_turbulence(turbulent):
    """In gusts the reconstruction follows a late vane, so its lag against the states is
    about zero; against the normal force it is found and undone (the 3211 above with the
    angle-of-attack vane 0.05 s late)."""
    data = turbulent.copy()
    t = data["t"].to_numpy()
    data["alpha"] = np.interp(t - 0.05, t, data["alpha"].to_numpy())
    data.attrs = turbulent.attrs
    rec = reconstruct(data)
    assert rec.lags_applied.get("alpha") == pytest.approx(0.05, abs=0.008)
    off = reconstruct(data, settings=ReconstructionSettings(estimate_lags=False))
    err = _rms(rec.data["alpha"] - rec.data["true_alpha"])
    assert err < 0.8 * _rms(off.data["alpha"] - off.data["true_alpha"])
