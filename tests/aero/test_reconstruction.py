"""Flight path reconstruction (IEKF + RTS) on simulated campaigns where the truth is known."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from simplexspline.aero import Reconstruction, ReconstructionSettings, reconstruct
from simplexspline.aero.reconstruction.iekf import FilterNoise, rts_smooth, run_filter
from simplexspline.aero.reconstruction.kinematics import (
    MEASUREMENT_NAMES, NX, NZ, EarthModel, measure, normal_gravity, propagate,
)
from simplexspline.aero.reconstruction.reconstruct import initial_state, innovation_statistics
from simplexspline.errors import FlightDataError, InputError
from simplexspline.sim.sensors import DEFAULT_BIAS, DEFAULT_NOISE_STD

IMU = ("ax", "ay", "az", "p", "q", "r")


def _state(rng):
    x = np.zeros(NX)
    x[0:3] = rng.normal(size=3) * 100
    x[3:6] = [180.0, 3.0, 12.0]
    x[6:9] = [0.3, 0.1, 2.0]
    x[9:] = rng.normal(size=9) * 1e-3
    return x


def test_transition_matrix_matches_finite_differences():
    rng = np.random.default_rng(1)
    x, u = _state(rng), np.array([1.0, 0.3, -9.0, 0.2, -0.1, 0.05])
    earth = EarthModel(math.radians(52.0))
    F, tmp = np.eye(NX), np.eye(NX)
    propagate(x, u, 0.01, 9.81, earth, F)
    num = np.empty((NX, NX))
    for j in range(NX):
        e = np.zeros(NX)
        e[j] = 1e-6
        num[:, j] = (propagate(x + e, u, 0.01, 9.81, earth, tmp)
                     - propagate(x - e, u, 0.01, 9.81, earth, tmp)) / 2e-6
    # F is first order in dt: the second-order rotation and the Earth-rate and
    # transport-rate dependencies are left out on purpose (relative size ~ dt |omega|)
    # (terms of size dt^2 |omega| V ~ 4e-3 here)
    assert (np.abs(num - F) <= 5e-3 + 2e-2 * np.abs(num)).all()
    assert np.abs(num - F)[:3].max() < 1e-4     # position rows are exact


def test_measurement_jacobian_matches_finite_differences():
    rng = np.random.default_rng(2)
    x = _state(rng)
    H, tmp = np.zeros((NZ, NX)), np.zeros((NZ, NX))
    measure(x, H)
    num = np.empty((NZ, NX))
    for j in range(NX):
        e = np.zeros(NX)
        e[j] = 1e-6
        num[:, j] = (measure(x + e, tmp) - measure(x - e, tmp)) / 2e-6
    np.testing.assert_allclose(H, num, atol=1e-7)


def test_normal_gravity_values():
    assert normal_gravity(0.0, 0.0) == pytest.approx(9.7803253359)
    assert normal_gravity(math.pi / 2, 0.0) == pytest.approx(9.8321849378, abs=1e-6)
    assert normal_gravity(math.radians(52), 10000.0) < normal_gravity(math.radians(52), 0.0)


def test_kinematic_model_reproduces_ideal_flight(ideal_campaign):
    """With perfect sensors, one propagation step from the true state hits the next one."""
    d = ideal_campaign[ideal_campaign["maneuver"] == ideal_campaign["maneuver"].iloc[0]]
    a, b, V = (d[f"true_{c}"].to_numpy() for c in ("alpha", "beta", "tas"))
    X = np.zeros((len(d), NX))
    X[:, 0], X[:, 1], X[:, 2] = d["x_gps"], d["y_gps"], d["z_gps"]
    X[:, 3:6] = np.column_stack([V * np.cos(a) * np.cos(b), V * np.sin(b),
                                 V * np.sin(a) * np.cos(b)])
    X[:, 6], X[:, 7], X[:, 8] = d["phi"], d["theta"], np.unwrap(d["psi"])
    U = d[list(IMU)].to_numpy()
    U[:-1, :3] = 0.5 * (U[:-1, :3] + U[1:, :3])
    earth = EarthModel(math.radians(52.0))
    F = np.eye(NX)
    g = earth.gravity(d["h"].to_numpy())
    err = np.array([propagate(X[k], U[k], 0.01, g[k], earth, F) - X[k + 1]
                    for k in range(len(d) - 1)]) / 0.01
    assert np.sqrt(np.mean(err[:, 3:6] ** 2, axis=0)).max() < 0.01       # m/s^2
    assert np.abs(err[:, 3:6].mean(axis=0)).max() < 1e-3                # no bias-like error
    assert np.abs(err[:, 6:9]).max() < 1e-3                             # rad/s


def test_imu_biases_within_three_sigma(noisy_reconstruction):
    bt = noisy_reconstruction.bias_table()
    assert len(bt) == 6
    for ch in IMU:
        z = (bt[ch] - DEFAULT_BIAS[ch]) / bt[ch + "_sigma"]
        assert (z.abs() < 3).all(), (ch, z.to_dict())
    for ch in ("alpha", "beta", "tas"):      # air-data errors too (default sensors)
        z = (bt[ch] - DEFAULT_BIAS[ch]) / bt[ch + "_sigma"]
        assert (z.abs() < 3.5).all(), (ch, z.to_dict())


def test_air_data_rms_below_sensor_noise(noisy_campaign, noisy_reconstruction):
    d = noisy_reconstruction.data
    for ch in ("alpha", "beta", "tas"):
        rms = float(np.sqrt(np.mean((d[ch] - d["true_" + ch]) ** 2)))
        raw = float(np.sqrt(np.mean((noisy_campaign[ch] - noisy_campaign["true_" + ch]) ** 2)))
        assert rms < DEFAULT_NOISE_STD[ch] < raw, (ch, rms, raw)
    for ch in ("phi", "theta"):
        assert np.sqrt(np.mean((d[ch] - d["true_" + ch]) ** 2)) < DEFAULT_NOISE_STD[ch]


def test_bias_corrected_imu_channels(noisy_reconstruction):
    d = noisy_reconstruction.data
    for ch in IMU:
        mean_err = float(np.mean(d[ch] - d["true_" + ch]))
        assert abs(mean_err) < 0.2 * abs(DEFAULT_BIAS[ch]), ch


def test_innovations_consistent_and_white(noisy_reconstruction):
    for m, r in noisy_reconstruction.maneuvers.items():
        assert set(r["innovations"]) >= {"tas", "alpha", "beta", "vn_gps", "phi"}
        for ch, s in r["innovations"].items():
            assert 0.85 < s["std"] < 1.15, (m, ch, s)
            assert abs(s["mean"]) < 0.3, (m, ch, s)
            assert s["white"] >= 0.7, (m, ch, s)
        mean_it, max_it = r["iterations"]
        assert mean_it >= 1 and max_it >= mean_it and max_it <= ReconstructionSettings().max_iter


def test_innovation_statistics_of_white_noise():
    rng = np.random.default_rng(0)
    e = rng.normal(size=(4000, NZ)) * 2.0
    st = innovation_statistics(e, np.full_like(e, 4.0))
    assert st["alpha"]["std"] == pytest.approx(1.0, abs=0.05)
    assert st["alpha"]["white"] >= 0.85
    walk = np.cumsum(e, axis=0)
    assert innovation_statistics(walk, np.full_like(e, 4.0))["alpha"]["white"] == 0.0


def test_smoother_beats_filter(noisy_campaign):
    one = noisy_campaign[noisy_campaign["maneuver"] == 3]
    fwd = reconstruct(one, settings=ReconstructionSettings(smoother=False)).data
    smo = reconstruct(one).data
    rms = {k: float(np.sqrt(np.mean((d["alpha"] - d["true_alpha"]) ** 2)))
           for k, d in (("filter", fwd), ("smoother", smo))}
    assert rms["smoother"] < rms["filter"]


def test_rts_without_covariance_matches_with_covariance(noisy_campaign):
    d = noisy_campaign[noisy_campaign["maneuver"] == 3].iloc[:300]
    z = d[list(MEASUREMENT_NAMES)].to_numpy()
    earth = EarthModel(math.radians(52.0))
    noise = FilterNoise(np.full(6, 1e-3), np.full(NX, 1e-12), np.full(NZ, 0.01))
    out = run_filter(initial_state(z, ReconstructionSettings().prior),
                     d[list(IMU)].to_numpy(), z, 0.01, earth.gravity(d["h"].to_numpy()),
                     earth, noise)
    xs, var = rts_smooth(out, covariance=True)
    xs2, none = rts_smooth(out)
    assert none is None
    np.testing.assert_array_equal(xs, xs2)
    filt_var = np.diagonal(out["P_filt"], axis1=1, axis2=2)
    assert (var <= filt_var * (1 + 1e-9)).all()


def test_parallel_equals_serial_and_input_untouched(noisy_campaign):
    sub = noisy_campaign[noisy_campaign["maneuver"].isin([1, 3, 4])]
    before = sub.copy()
    serial = reconstruct(sub, workers=1)
    parallel = reconstruct(sub, workers=2)
    pd.testing.assert_frame_equal(serial.data, parallel.data)
    assert serial.maneuvers == parallel.maneuvers
    pd.testing.assert_frame_equal(sub, before)


def test_bad_maneuvers_are_rejected_and_others_processed(noisy_campaign):
    df = noisy_campaign.copy()
    df.attrs = dict(noisy_campaign.attrs)
    t = df["t"].to_numpy()
    short = (df["maneuver"] == 1) & (t > 1.0)
    df = df[~short].copy()
    nan_imu = (df["maneuver"] == 3) & (df["t"] > 4.0) & (df["t"] < 4.2)
    df.loc[nan_imu, "az"] = np.nan
    df.loc[df["maneuver"] == 4, "beta"] = np.nan
    nan_air = (df["maneuver"] == 5) & (df["t"] > 5.0) & (df["t"] < 5.5)
    df.loc[nan_air, "alpha"] = np.nan
    rec = reconstruct(df)
    assert set(rec.rejected) == {1, 3, 4}
    assert "too short" in rec.rejected[1]
    assert "'az'" in rec.rejected[3] and "NaN" in rec.rejected[3]
    assert "'beta'" in rec.rejected[4] and "no valid sample" in rec.rejected[4]
    assert sorted(rec.maneuvers) == [0, 2, 5]
    assert rec.maneuvers[5]["skipped"] == {"alpha": int(nan_air.sum())}
    assert sorted(rec.data["maneuver"].unique()) == [0, 2, 5]
    assert np.isfinite(rec.data["alpha"]).all()
    text = rec.summary()
    assert "rejected maneuver 1: too short" in text
    assert "NaN measurement samples skipped" in text
    assert rec.data.attrs["reconstruction"]["rejected"]["3"] == rec.rejected[3]


def test_nothing_reconstructable_raises(noisy_campaign):
    df = noisy_campaign[noisy_campaign["t"] < 0.5]
    with pytest.raises(FlightDataError, match="no maneuver could be reconstructed.*too short"):
        reconstruct(df)


def test_missing_column_names_it(noisy_campaign):
    with pytest.raises(FlightDataError, match=r"\['q'\]"):
        reconstruct(noisy_campaign.drop(columns=["q"]))


def test_without_gps_still_runs(noisy_campaign):
    gps = ["x_gps", "y_gps", "z_gps", "vn_gps", "ve_gps", "vd_gps"]
    one = noisy_campaign[noisy_campaign["maneuver"] == 3].drop(columns=gps)
    rec = reconstruct(one)
    assert rec.unused_channels == gps
    assert "not used" in rec.summary()
    assert np.isfinite(rec.data["alpha"]).all()


def test_settings_validation(noisy_campaign):
    with pytest.raises(InputError, match="unknown channel"):
        ReconstructionSettings(measurement_noise={"alfa": 0.1})
    with pytest.raises(InputError, match="positive"):
        ReconstructionSettings(input_noise={"ax": -1.0})
    with pytest.raises(InputError, match="accelerations"):
        ReconstructionSettings(accelerations="guess")
    with pytest.raises(InputError, match="workers"):
        reconstruct(noisy_campaign, workers=0)
    s = ReconstructionSettings(measurement_noise={"tas": 0.2})
    assert s.measurement_noise["tas"] == 0.2 and s.measurement_noise["alpha"] > 0


def test_result_type(noisy_reconstruction):
    assert isinstance(noisy_reconstruction, Reconstruction)
    assert noisy_reconstruction.thrust_subtracted
    assert noisy_reconstruction.accelerations == "measured"
