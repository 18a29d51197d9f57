"""Sensor model: noise, bias, lag, defaults, validation (no JSBSim needed)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplexspline.errors import InputError
from simplexspline.sim import DEFAULT_BIAS, DEFAULT_NOISE_STD, MEASURED_CHANNELS, SensorModel


def _true(n: int = 20000) -> tuple[dict, np.ndarray]:
    t = np.arange(n) * 0.01
    true = {ch: np.sin(0.3 * t + i) for i, ch in enumerate(MEASURED_CHANNELS)}
    return true, t


def test_ideal_sensors_return_the_truth_exactly(rng):
    true, t = _true(500)
    out = SensorModel.ideal().apply(true, t, rng)
    for ch in MEASURED_CHANNELS:
        assert np.array_equal(out[ch], true[ch])
        assert out[ch] is not true[ch]
    assert SensorModel.ideal().is_ideal and not SensorModel().is_ideal


def test_noise_and_bias_statistics(rng):
    true, t = _true()
    sensors = SensorModel(noise_std={"q": 0.01}, bias={"q": -0.02})
    out = sensors.apply(true, t, rng)
    err = out["q"] - true["q"]
    assert err.mean() == pytest.approx(-0.02, abs=4 * 0.01 / math.sqrt(len(t)))
    assert err.std() == pytest.approx(0.01, rel=0.03)
    # white: no correlation between neighbouring samples
    e = err - err.mean()
    assert abs(np.dot(e[1:], e[:-1]) / np.dot(e, e)) < 0.03


def test_given_channels_override_defaults_only():
    sensors = SensorModel(noise_std={"ax": 0.05})
    assert sensors.noise_std["ax"] == 0.05
    assert sensors.noise_std["ay"] == DEFAULT_NOISE_STD["ay"]
    assert sensors.bias == {ch: DEFAULT_BIAS.get(ch, 0.0) for ch in MEASURED_CHANNELS}
    assert set(sensors.lag_s.values()) == {0.0}


def test_lag_delays_the_signal(rng):
    t = np.arange(1000) * 0.01
    true = {ch: 2.0 * t for ch in MEASURED_CHANNELS}
    out = SensorModel.ideal().__class__(
        noise_std={ch: 0.0 for ch in MEASURED_CHANNELS},
        bias={ch: 0.0 for ch in MEASURED_CHANNELS}, lag_s={"alpha": 0.05}).apply(true, t, rng)
    assert np.allclose(out["alpha"][5:], 2.0 * (t[5:] - 0.05))
    assert np.all(out["alpha"][:5] == 0.0)  # first value held before the start
    assert np.array_equal(out["beta"], true["beta"])


def test_lagged_heading_is_unwrapped_then_wrapped(rng):
    t = np.arange(400) * 0.01
    psi = (3.0 + 0.5 * t + math.pi) % (2 * math.pi) - math.pi  # crosses +-pi
    true = {ch: np.zeros_like(t) for ch in MEASURED_CHANNELS}
    true["psi"] = psi
    zero = {ch: 0.0 for ch in MEASURED_CHANNELS}
    out = SensorModel(noise_std=zero, bias=zero, lag_s={"psi": 0.1}).apply(true, t, rng)
    expected = (3.0 + 0.5 * (t - 0.1) + math.pi) % (2 * math.pi) - math.pi
    assert np.allclose(out["psi"][10:], expected[10:])
    assert out["psi"].min() >= -math.pi and out["psi"].max() <= math.pi


def test_noise_streams_do_not_depend_on_other_channels_settings():
    true, t = _true(1000)
    a = SensorModel(noise_std={"p": 0.1}).apply(true, t, np.random.default_rng(1))
    b = SensorModel(noise_std={"p": 0.1, "q": 0.5}).apply(true, t, np.random.default_rng(1))
    assert np.array_equal(a["p"], b["p"])
    assert not np.array_equal(a["q"], b["q"])


def test_round_trip_and_scaling():
    s = SensorModel(bias={"h": 3.0}, lag_s={"tas": 0.1})
    assert SensorModel.from_dict(s.to_dict()) == s
    half = s.scaled(noise=0.5, bias=0.0)
    assert half.noise_std["ax"] == pytest.approx(0.5 * s.noise_std["ax"])
    assert set(half.bias.values()) == {0.0}
    assert half.lag_s == s.lag_s


@pytest.mark.parametrize("kwargs, match", [
    ({"noise_std": {"airspeed": 1.0}}, "unknown channel 'airspeed'"),
    ({"noise_std": {"ax": -1.0}}, "noise_std of 'ax' must be a finite non-negative"),
    ({"lag_s": {"ax": float("nan")}}, "lag_s of 'ax'"),
    ({"bias": {"ax": float("inf")}}, "bias of 'ax' must be a finite number"),
])
def test_invalid_sensor_settings(kwargs, match):
    with pytest.raises(InputError, match=match):
        SensorModel(**kwargs)


def _flight(n: int = 500) -> tuple[dict, np.ndarray]:
    """A plausible state history: 150 m/s, pitching, rolling and yawing."""
    t = np.arange(n) * 0.01
    true = {ch: np.zeros(n) for ch in MEASURED_CHANNELS}
    true.update(alpha=0.05 + 0.03 * np.sin(2 * t), beta=0.02 * np.sin(3 * t),
                tas=np.full(n, 150.0), p=0.3 * np.sin(1.5 * t), q=0.1 * np.cos(2 * t),
                r=0.05 * np.sin(t), pdot=0.45 * np.cos(1.5 * t), qdot=-0.2 * np.sin(2 * t),
                rdot=0.05 * np.cos(t), ax=np.full(n, 0.5), ay=np.zeros(n),
                az=np.full(n, -9.8))
    return true, t


def test_vanes_ahead_of_the_cg_see_rate_induced_angles(rng):
    """To first order alpha_vane = alpha - q x/V + p y/V, beta_vane = beta + r x/V - p z/V."""
    true, t = _flight()
    x, y, z = 6.0, 0.4, -0.5
    ideal = {ch: 0.0 for ch in MEASURED_CHANNELS}
    sm = SensorModel(noise_std=ideal, bias=ideal,
                     alpha_vane={"position_m": [x, y, z]}, beta_vane={"position_m": [x, y, z]})
    out = sm.apply(true, t, rng)
    V = true["tas"]
    assert np.allclose(out["alpha"], true["alpha"] - true["q"] * x / V + true["p"] * y / V,
                       atol=2e-4)
    assert np.allclose(out["beta"], true["beta"] + true["r"] * x / V - true["p"] * z / V,
                       atol=2e-4)
    assert np.abs(out["alpha"] - true["alpha"]).max() > 3e-3  # the effect is not negligible
    assert out["tas"] is not true["tas"] and np.array_equal(out["tas"], true["tas"])


def test_vane_calibration_scale_and_offset(rng):
    true, t = _flight()
    ideal = {ch: 0.0 for ch in MEASURED_CHANNELS}
    sm = SensorModel(noise_std=ideal, bias=ideal,
                     alpha_vane={"scale": 1.05, "offset_rad": 0.01})
    out = sm.apply(true, t, rng)
    assert np.allclose(out["alpha"], 1.05 * true["alpha"] + 0.01, atol=1e-12)
    assert np.array_equal(out["beta"], true["beta"])


def test_imu_lever_arm_adds_rotational_accelerations(rng):
    true, t = _flight()
    ideal = {ch: 0.0 for ch in MEASURED_CHANNELS}
    arm = np.array([2.0, -0.3, 0.5])
    out = SensorModel(noise_std=ideal, bias=ideal, imu_position_m=arm).apply(true, t, rng)
    w = np.column_stack([true["p"], true["q"], true["r"]])
    wd = np.column_stack([true["pdot"], true["qdot"], true["rdot"]])
    a = np.column_stack([true["ax"], true["ay"], true["az"]])
    expected = a + np.cross(wd, arm) + np.cross(w, np.cross(w, arm))
    assert np.allclose(np.column_stack([out["ax"], out["ay"], out["az"]]), expected,
                       atol=1e-12)


def test_sensors_fixed_to_the_airframe_see_the_cg_move(rng):
    """Positions are from the reference point: a c.g. shifted by ``cg`` puts the IMU and the
    vanes at ``position - cg`` from it, sample by sample."""
    true, t = _flight()
    ideal = {ch: 0.0 for ch in MEASURED_CHANNELS}
    imu, boom = np.array([0.6, 0.05, 0.2]), [4.0, 0.0, -0.4]
    cg = np.column_stack([0.03 + 0.01 * np.sin(t), np.zeros(t.size), np.full(t.size, 0.02)])
    fixed = SensorModel(noise_std=ideal, bias=ideal, imu_position_m=imu,
                        alpha_vane={"position_m": boom})
    out = fixed.apply(true, t, rng, cg=cg)
    w = np.column_stack([true["p"], true["q"], true["r"]])
    wd = np.column_stack([true["pdot"], true["qdot"], true["rdot"]])
    a = np.column_stack([true["ax"], true["ay"], true["az"]])
    arm = imu - cg
    expected = a + np.cross(wd, arm) + np.cross(w, np.cross(w, arm))
    assert np.allclose(np.column_stack([out["ax"], out["ay"], out["az"]]), expected,
                       atol=1e-12)
    k = 377                                     # one sample: a model placed at that arm
    at_k = SensorModel(noise_std=ideal, bias=ideal, imu_position_m=tuple(arm[k]),
                       alpha_vane={"position_m": list(np.asarray(boom) - cg[k])})
    one = {ch: v[k:k + 1] for ch, v in true.items()}
    assert np.isclose(at_k.apply(one, t[k:k + 1], rng)["alpha"][0], out["alpha"][k],
                      rtol=0, atol=1e-15)
    # default sensors at the reference point see the c.g. move; ideal ones follow it
    moved = SensorModel(noise_std=ideal, bias=ideal).apply(true, t, rng, cg=cg)
    assert np.abs(moved["az"] - true["az"]).max() > 1e-3
    assert not np.array_equal(moved["alpha"], true["alpha"])
    assert SensorModel.ideal().at_cg and not SensorModel().at_cg
    assert SensorModel.from_dict(SensorModel.ideal().to_dict()).at_cg


def test_sensor_geometry_metadata_follows_the_schema():
    from simplexspline.aero.data.flight_data import sensor_geometry

    assert SensorModel().sensor_geometry() is None
    sm = SensorModel(alpha_vane={"position_m": [5.0, 0.0, 0.2], "scale": 1.03},
                     imu_position_m=(0.5, 0.0, 0.1), lag_s={"alpha": 0.05, "qdot": 0.02})
    meta = sm.sensor_geometry()
    geo = sensor_geometry({"sensor_geometry": meta})
    assert geo.alpha_vane.position_m == (5.0, 0.0, 0.2) and geo.alpha_vane.scale == 1.03
    assert geo.imu_position_m == (0.5, 0.0, 0.1)
    assert geo.lag_s == {"alpha": 0.05}  # qdot is no schema lag channel
    assert SensorModel.from_dict(sm.to_dict()) == sm
    assert sm.scaled(noise=2.0).alpha_vane == sm.alpha_vane
    assert not sm.is_ideal


@pytest.mark.parametrize("kwargs, match", [
    ({"alpha_vane": {"scale": 0.0}}, "SensorModel: metadata sensor_geometry.alpha_vane.scale"),
    ({"beta_vane": {"position_m": [1.0, 2.0]}}, "beta_vane.position_m must be three"),
    ({"imu_position_m": (500.0, 0.0, 0.0)}, "within 100 m"),
    ({"alpha_vane": {"chord": 1.0}}, "alpha_vane must be a mapping with keys"),
])
def test_invalid_sensor_geometry(kwargs, match):
    with pytest.raises(InputError, match=match):
        SensorModel(**kwargs)


def test_real_like_sensors_carry_geometry_and_lags():
    sm = SensorModel.real_like()
    meta = sm.sensor_geometry()
    assert meta["alpha_vane"]["position_m"][0] > 0 and meta["alpha_vane"]["scale"] != 1.0
    assert meta["lag_s"]["alpha"] > 0 and any(meta["imu"]["position_m"])
    assert sm.noise_std == SensorModel().noise_std
