"""The thrust coefficient tc = T / (qbar S): derived where the data hold the thrust, and a
power effect (elevator effectiveness growing with the slipstream) found by the search."""

from __future__ import annotations

import numpy as np
import pandas as pd

from simplexspline.aero.data.thrust_coefficient import thrust_coefficient
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


def test_search_finds_a_power_effect_on_the_elevator():
    """Cm's elevator term scales with the slipstream, (1 + 3 tc): the default search, offered
    tc, takes it into the model and reaches the noise; without tc it cannot."""
    rng = np.random.default_rng(4)
    t = np.arange(500) * 0.02
    cols = {k: [] for k in ("alpha", "mach", "de", "qhat", "tc", "y", "truth", "man")}
    for m in range(18):
        def wave(amp, centre=0.0):
            f, ph = rng.uniform(0.1, 1.0, 3), rng.uniform(0, 2 * np.pi, 3)
            return centre + amp * np.sin(2 * np.pi * f[:, None] * t + ph[:, None]).sum(0) / 3

        alpha = wave(0.05, rng.uniform(0.0, 0.12))
        de, qhat = wave(0.1, rng.uniform(-0.05, 0.05)), wave(0.004)
        mach = np.full_like(t, rng.uniform(0.15, 0.25)) + wave(0.01)
        tc = np.clip(wave(0.05, rng.uniform(0.0, 0.3)), 0.0, None)   # throttle per maneuver
        truth = 0.05 - 0.9 * alpha - 1.1 * de * (1.0 + 3.0 * tc) - 12.0 * qhat
        for k, v in (("alpha", alpha), ("mach", mach), ("de", de), ("qhat", qhat),
                     ("tc", tc), ("truth", truth),
                     ("y", truth + 1e-3 * rng.standard_normal(len(t))),
                     ("man", np.full(len(t), m))):
            cols[k].append(v)
    d = {k: np.concatenate(v) for k, v in cols.items()}
    data = {k: d[k] for k in ("alpha", "mach", "de", "qhat", "tc")}
    settings = SelectionSettings(max_rounds=4, max_samples=20_000)
    errors = {}
    for offered in (True, False):
        cols_ = data if offered else {k: v for k, v in data.items() if k != "tc"}
        start, _ = restrict_to_data(AUTO_PRESET["Cm"], cols_)
        best, _history = select_structure(start, cols_, d["y"], d["man"], settings)
        model = fit_structure(best, cols_, d["y"], settings)
        errors[offered] = float(np.sqrt(np.mean((model.predict(cols_) - d["truth"]) ** 2)))
        if offered:
            assert "tc" in best.inputs, best.label()
    assert errors[True] < 1e-3 < errors[False] / 3, errors
