"""The thrust coefficient tc = T / (qbar S): derived where the data hold the thrust, and a
power effect (elevator effectiveness growing with the slipstream) found by the search.
Without the thrust, its stand-in from the fuel flow, tc_ff, lets CX (which then holds the
thrust) follow the throttle."""

from __future__ import annotations

import numpy as np
import pandas as pd

from simplexspline.aero.data.thrust_coefficient import SPECIFIC_THRUST, thrust_coefficient
from simplexspline.aero.modelling.auto import AUTO_PRESET, restrict_to_data
from simplexspline.aero.selection.search import SelectionSettings, fit_structure, \
    select_structure


def test_thrust_coefficient_is_thrust_over_dynamic_pressure_and_area():
    df = pd.DataFrame({"thrust_x": [1000.0, 0.0, 500.0], "rho": [1.2, 1.0, 0.5],
                       "tas": [50.0, 40.0, 100.0]})
    tc = thrust_coefficient(df, {"S": 16.2})["tc"]
    qbar = 0.5 * df["rho"] * df["tas"] ** 2
    np.testing.assert_allclose(tc, df["thrust_x"] / (qbar * 16.2), rtol=1e-15)


def test_no_thrust_no_thrust_coefficient():
    df = pd.DataFrame({"thrust_x": [np.nan, np.nan], "rho": [1.2, 1.2], "tas": [50.0, 51.0]})
    assert thrust_coefficient(df, {"S": 16.2}) == {}                     # all NaN: absent
    assert thrust_coefficient(df.drop(columns="thrust_x"), {"S": 16.2}) == {}
    assert thrust_coefficient(df.assign(thrust_x=1.0), {}) == {}         # no wing area


def test_without_thrust_the_fuel_flow_stands_in():
    df = pd.DataFrame({"fuel_flow": [0.5, 0.2, np.nan], "rho": [1.2, 1.0, 0.5],
                       "tas": [150.0, 140.0, 200.0]})
    tc = thrust_coefficient(df, {"S": 30.0})
    qbar = 0.5 * df["rho"] * df["tas"] ** 2
    assert list(tc) == ["tc_ff"]
    np.testing.assert_allclose(tc["tc_ff"], df["fuel_flow"] * SPECIFIC_THRUST / (qbar * 30.0),
                               rtol=1e-15)
    both = thrust_coefficient(df.assign(thrust_x=1.0e4), {"S": 30.0})
    assert list(both) == ["tc"]                       # the thrust itself wins
    no_thrust = df.assign(thrust_x=np.nan)            # a thrust column that is all NaN
    assert list(thrust_coefficient(no_thrust, {"S": 30.0})) == ["tc_ff"]
    assert thrust_coefficient(df.assign(fuel_flow=np.nan), {"S": 30.0}) == {}
    # without fuel flow, the fan speed: T / (qbar S) ~ (N1 / sqrt(theta))^2 / (theta M^2)
    fan = df.drop(columns="fuel_flow").assign(n1=[0.8, 0.9, 0.5])
    tc = thrust_coefficient(fan, {"S": 30.0})
    assert list(tc) == ["tc_n1"]
    np.testing.assert_allclose(tc["tc_n1"], (fan["n1"] * 340.294 / fan["tas"]) ** 2,
                               rtol=1e-15)
    # both: both are offered (which one follows the thrust is the engine's)
    two = thrust_coefficient(fan.assign(fuel_flow=0.4), {"S": 30.0})
    assert list(two) == ["tc_ff", "tc_n1"]
    np.testing.assert_allclose(two["tc_n1"], tc["tc_n1"], rtol=1e-15)
    # the fuel flow without a density gives no tc_ff, the fan speed still its tc_n1
    assert list(thrust_coefficient(fan.assign(fuel_flow=0.4).drop(columns="rho"),
                                   {"S": 30.0})) == ["tc_n1"]
    # the thrust itself: no stand-in at all
    assert list(thrust_coefficient(fan.assign(fuel_flow=0.4, thrust_x=1.0e4),
                                   {"S": 30.0})) == ["tc"]


def _offered_or_not(coefficient: str, variable: str, data: dict, d: dict) -> dict:
    """RMS against the truth of the default search's model with ``variable`` offered
    (True) and without it (False); asserts the search takes it when offered."""
    settings = SelectionSettings(max_rounds=4, max_samples=20_000)
    errors = {}
    for offered in (True, False):
        cols_ = data if offered else {k: v for k, v in data.items() if k != variable}
        start, _ = restrict_to_data(AUTO_PRESET[coefficient], cols_)
        best, _history = select_structure(start, cols_, d["y"], d["man"], settings)
        model = fit_structure(best, cols_, d["y"], settings)
        errors[offered] = float(np.sqrt(np.mean((model.predict(cols_) - d["truth"]) ** 2)))
        if offered:
            assert variable in best.inputs, best.label()
    return errors


def _test_points(points: int, samples: int, dt: float, seed: int, point) -> dict:
    """``points`` maneuvers of ``samples`` samples ``dt`` apart: ``point(wave, rng)`` gives
    one maneuver's columns and its ``truth`` from ``wave(amp, centre)`` (a sum of three
    sines of random frequency and phase); y is the truth plus 1e-3 white noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(samples) * dt
    cols: dict = {}
    for m in range(points):
        def wave(amp, centre=0.0):
            f, ph = rng.uniform(0.1, 1.0, 3), rng.uniform(0, 2 * np.pi, 3)
            return centre + amp * np.sin(2 * np.pi * f[:, None] * t + ph[:, None]).sum(0) / 3

        one = point(wave, rng)
        one["y"] = one["truth"] + 1e-3 * rng.standard_normal(len(t))
        one["man"] = np.full(len(t), m)
        for k, v in one.items():
            cols.setdefault(k, []).append(v)
    return {k: np.concatenate(v) for k, v in cols.items()}


def _thrust_in_cx(samples: int, dt: float, seed: int = 11) -> tuple[dict, dict]:
    """CX with the thrust in it (no thrust channel) over 20 test points of ``samples``
    samples ``dt`` apart: each point flies its own throttle, and the thrust per fuel flow
    grows with Mach (a jet). Returns the candidate columns and y, truth, maneuver."""
    def point(wave, rng):
        alpha = wave(0.03, rng.uniform(0.0, 0.1))
        de, qhat = wave(0.05, rng.uniform(-0.05, 0.0)), wave(0.004)
        mach = np.full_like(alpha, rng.uniform(0.3, 0.7)) + wave(0.01)
        rho = rng.uniform(0.6, 1.2)
        qbar_s = 0.5 * rho * (mach * 330.0) ** 2 * 30.0
        fuel_flow = rng.uniform(0.1, 0.6) + wave(0.02)                # throttle per point
        thrust = fuel_flow * 3.5e4 * (1.0 + 0.5 * mach)
        truth = -0.03 + 0.3 * alpha + 2.0 * alpha ** 2 - 0.01 * de + thrust / qbar_s
        return {"alpha": alpha, "mach": mach, "de": de, "qhat": qhat,
                "tc_ff": fuel_flow * SPECIFIC_THRUST / qbar_s, "truth": truth}

    d = _test_points(20, samples, dt, seed, point)
    return {k: d[k] for k in ("alpha", "mach", "de", "qhat", "tc_ff")}, d


def test_thrust_in_cx_follows_the_fuel_flow():
    """Offered tc_ff, the default search takes it into CX and reaches the noise; without
    it the throttle's share of CX is unexplained."""
    data, d = _thrust_in_cx(400, 0.05)
    errors = _offered_or_not("CX", "tc_ff", data, d)
    assert errors[True] < 1e-3 < errors[False] / 3, errors


def test_thrust_in_cx_follows_the_fan_speed_where_the_fuel_flow_does_not():
    """A jet whose thrust follows N1 from test point to test point while its fuel-flow
    channel hardly moves (as on the simulated T-37's courses): offered both stand-ins, the
    default search takes tc_n1 and reaches the noise; offered tc_ff alone (the rule before
    stop 60) the throttle's share of CX is left unexplained."""
    def point(wave, rng):
        alpha = wave(0.03, rng.uniform(0.0, 0.1))
        de, qhat = wave(0.05, rng.uniform(-0.05, 0.0)), wave(0.004)
        mach = np.full_like(alpha, rng.uniform(0.3, 0.7)) + wave(0.01)
        rho = rng.uniform(0.6, 1.2)
        tas = mach * 330.0
        qbar_s = 0.5 * rho * tas ** 2 * 30.0
        n1 = np.full_like(alpha, rng.uniform(0.6, 0.95)) + wave(0.005)     # throttle
        fuel_flow = 0.108 + wave(0.002)                # a channel that barely moves
        tc_n1 = (n1 * 340.294 / tas) ** 2
        truth = -0.03 + 0.3 * alpha + 2.0 * alpha ** 2 - 0.01 * de + 0.012 * tc_n1
        return {"alpha": alpha, "mach": mach, "de": de, "qhat": qhat, "tc_n1": tc_n1,
                "tc_ff": fuel_flow * SPECIFIC_THRUST / qbar_s, "truth": truth}

    d = _test_points(20, 400, 0.05, 5, point)
    data = {k: d[k] for k in ("alpha", "mach", "de", "qhat", "tc_ff", "tc_n1")}
    errors = _offered_or_not("CX", "tc_n1", data, d)
    assert errors[True] < 1e-3 < errors[False] / 3, errors


def test_the_size_budget_counts_the_time_flown_not_the_samples():
    """20 test points of 18 s at 10 Hz: 3600 samples allow 180 coefficients at 20 samples
    each, the size of CX's starting structure, so the search cannot add tc_ff to it (only
    after shrinking it, if ever); counted as 360 s of data at 0.4 s each (900
    coefficients) it adds tc_ff in the first round, and reaches the noise."""
    data, d = _thrust_in_cx(180, 0.1, seed=3)
    # the search's own path (the hinge start, a basis beside it, has its own tests)
    settings = SelectionSettings(max_rounds=3, max_samples=20_000, hinge_start=False)
    start, _ = restrict_to_data(AUTO_PRESET["CX"], data)
    assert start.size() >= len(d["y"]) / settings.samples_per_coefficient

    def first_round(history):
        return {t.move: t.accepted for t in history if t.round == 1}

    _, history = select_structure(start, data, d["y"], d["man"], settings)
    assert not any(m.startswith("add multiplier") for m in first_round(history))
    by_time, history = select_structure(start, data, d["y"], d["man"], settings,
                                        duration_s=len(d["y"]) * 0.1)
    assert first_round(history)["add multiplier tc_ff"]
    model = fit_structure(by_time, data, d["y"], settings)
    assert np.sqrt(np.mean((model.predict(data) - d["truth"]) ** 2)) < 1.5e-3


def test_the_size_budget_counts_the_samples_the_search_cross_validates_on():
    """The same 3600 samples at 5 samples per coefficient allow 720 coefficients, so the
    search tries structures larger than CX's 180-coefficient start; subsampled to 900 for
    the cross-validation (``max_samples``), they allow 180, and no larger structure is
    tried (the main job's Cn had tried 8,820 coefficients on 40,000 training samples)."""
    data, d = _thrust_in_cx(180, 0.1, seed=3)
    start, _ = restrict_to_data(AUTO_PRESET["CX"], data)
    largest = {}
    for max_samples in (20_000, 900):
        settings = SelectionSettings(max_rounds=2, max_samples=max_samples,
                                     samples_per_coefficient=5)
        _, history = select_structure(start, data, d["y"], d["man"], settings)
        largest[max_samples] = max(t.structure.size() for t in history)
    assert largest[20_000] > start.size() >= largest[900]


def test_search_finds_a_power_effect_on_the_elevator():
    """Cm's elevator term scales with the slipstream, (1 + 3 tc): the default search, offered
    tc, takes it into the model and reaches the noise; without tc it cannot."""
    def point(wave, rng):
        alpha = wave(0.05, rng.uniform(0.0, 0.12))
        de, qhat = wave(0.1, rng.uniform(-0.05, 0.05)), wave(0.004)
        mach = np.full_like(alpha, rng.uniform(0.15, 0.25)) + wave(0.01)
        tc = np.clip(wave(0.05, rng.uniform(0.0, 0.3)), 0.0, None)   # throttle per maneuver
        truth = 0.05 - 0.9 * alpha - 1.1 * de * (1.0 + 3.0 * tc) - 12.0 * qhat
        return {"alpha": alpha, "mach": mach, "de": de, "qhat": qhat, "tc": tc,
                "truth": truth}

    d = _test_points(18, 500, 0.02, 4, point)
    data = {k: d[k] for k in ("alpha", "mach", "de", "qhat", "tc")}
    errors = _offered_or_not("Cm", "tc", data, d)
    assert errors[True] < 1e-3 < errors[False] / 3, errors
