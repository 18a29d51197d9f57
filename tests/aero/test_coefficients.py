"""Eq. 43-48, non-dimensional rates, thrust handling and smoothed differentiation."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from simplexspline.aero import aerodynamic_coefficients, angular_accelerations, midpoint_derivative
from simplexspline.aero.data.coefficients import THRUST_COLUMNS, transfer_moments
from simplexspline.aero.data.thrust import ThrustModel
from simplexspline.aero.variables import COEFFICIENTS
from simplexspline.errors import FlightDataError, InputError


def relative_rms_table(data: pd.DataFrame) -> pd.DataFrame:
    rows = {}
    for c in COEFFICIENTS:
        err = data[c] - data["true_" + c]
        rms = float(np.sqrt(np.mean(err ** 2)))
        span = float(data["true_" + c].max() - data["true_" + c].min())
        rows[c] = {"rms": rms, "range": span, "relative_rms_%": 100 * rms / span}
    return pd.DataFrame.from_dict(rows, orient="index")


def with_truth(coef: pd.DataFrame, data: pd.DataFrame) -> pd.DataFrame:
    """The coefficients beside the truth; the truth about the coefficients' moment
    reference point where they carry it (a moving c.g.)."""
    truth = data.filter(like="true_").drop(columns=list(coef.columns), errors="ignore")
    return pd.concat([coef, truth], axis=1)


def test_ideal_sensors_reproduce_true_coefficients(ideal_campaign):
    coef, thrust = aerodynamic_coefficients(ideal_campaign, accelerations="measured")
    assert thrust
    for c in COEFFICIENTS:
        np.testing.assert_allclose(coef[c], ideal_campaign["true_" + c], rtol=0, atol=1e-6)
    V = ideal_campaign["tas"]
    np.testing.assert_allclose(coef["qhat"],
                               ideal_campaign["q"] * ideal_campaign.attrs["cbar"] / (2 * V))
    np.testing.assert_allclose(coef["phat"],
                               ideal_campaign["p"] * ideal_campaign.attrs["b"] / (2 * V))


def test_without_thrust_columns_thrust_is_included_and_flagged(ideal_campaign):
    df = ideal_campaign.drop(columns=list(THRUST_COLUMNS))
    coef, thrust = aerodynamic_coefficients(df, accelerations="measured")
    assert not thrust
    qs = 0.5 * df["rho"] * df["tas"] ** 2 * df.attrs["S"]
    expected = ideal_campaign["true_CX"] + ideal_campaign["thrust_x"] / qs
    np.testing.assert_allclose(coef["CX"], expected, atol=1e-6)


def test_differentiated_accelerations_on_ideal_data(ideal_campaign):
    acc = angular_accelerations(ideal_campaign, half_window=1)    # plain forward difference
    inner = ideal_campaign.groupby("maneuver").cumcount(ascending=False).to_numpy() > 0
    np.testing.assert_allclose(acc[inner], ideal_campaign[["pdot", "qdot", "rdot"]]
                               .to_numpy()[inner], atol=1e-9)
    coef, _ = aerodynamic_coefficients(ideal_campaign, accelerations="differentiate")
    table = relative_rms_table(with_truth(coef, ideal_campaign))
    assert (table["relative_rms_%"] < 1.0).all(), table


def test_coefficient_accuracy_from_reconstructed_data(noisy_reconstruction, capsys):
    table = relative_rms_table(noisy_reconstruction.data)
    with capsys.disabled():
        print("\ncoefficients from reconstructed data vs true_ (default sensors, measured "
              "angular accelerations):\n" + table.to_string(float_format="%.3g"))
    assert (table["relative_rms_%"] <= 1.0).all(), table


def test_coefficient_accuracy_with_differentiated_rates(noisy_campaign, noisy_reconstruction):
    data = noisy_reconstruction.data.drop(columns=["pdot", "qdot", "rdot"])
    coef, _ = aerodynamic_coefficients(data)
    table = relative_rms_table(with_truth(coef, data))
    assert (table["relative_rms_%"] <= 1.0).all(), table


def test_missing_inputs_are_named(ideal_campaign):
    with pytest.raises(FlightDataError, match="'cbar'"):
        aerodynamic_coefficients(ideal_campaign, {"S": 1.0, "b": 1.0})
    with pytest.raises(FlightDataError, match="Ixz"):
        aerodynamic_coefficients(ideal_campaign.drop(columns=["Ixz"]))
    with pytest.raises(FlightDataError, match="pdot"):
        aerodynamic_coefficients(ideal_campaign.drop(columns=["pdot"]), accelerations="measured")
    with pytest.raises(InputError, match="accelerations"):
        aerodynamic_coefficients(ideal_campaign, accelerations="maybe")


@pytest.mark.parametrize("m", [2, 5, 8, 12])
def test_midpoint_derivative_exact_for_quadratics(m):
    t = np.arange(80) * 0.01
    x = 3 - 2 * t + 5 * t ** 2
    d = midpoint_derivative(x, 0.01, half_window=m, degree=2)
    np.testing.assert_allclose(d, -2 + 10 * (t + 0.005), atol=1e-8)


def test_midpoint_derivative_forward_difference_and_noise_reduction():
    rng = np.random.default_rng(0)
    x = rng.normal(size=5000)
    np.testing.assert_allclose(midpoint_derivative(x, 0.5, half_window=1)[:-1],
                               np.diff(x) / 0.5)
    raw = np.std(np.diff(x))
    smooth = np.std(midpoint_derivative(x, 1.0, half_window=12)[20:-20])
    assert smooth < 0.1 * raw


def test_midpoint_derivative_short_and_invalid():
    np.testing.assert_allclose(midpoint_derivative(np.array([0.0, 1.0, 2.0]), 1.0), 1.0)
    with pytest.raises(InputError, match="at least 2"):
        midpoint_derivative(np.array([1.0]), 0.01)
    with pytest.raises(InputError, match="half_window"):
        midpoint_derivative(np.arange(10.0), 0.01, half_window=0)


@pytest.mark.parametrize("m, degree", [(1, 2), (2, 3), (2, 4), (3, 4), (5, 4)])
def test_sample_derivative_is_exact_at_the_samples_for_polynomials_of_its_degree(m, degree):
    from simplexspline.aero.data.differentiation import sample_derivative

    t = np.arange(40) * 0.1
    c = [0.4, -1.3, 0.8, 0.25, -0.05][:degree + 1]
    x = sum(ci * t ** i for i, ci in enumerate(c))
    exact = sum(i * ci * t ** (i - 1) for i, ci in enumerate(c) if i)
    np.testing.assert_allclose(sample_derivative(x, 0.1, m, degree), exact, atol=1e-9)
    if 2 * m > degree:      # shorter than the window: each sample at its place in the data
        np.testing.assert_allclose(sample_derivative(x[:2 * m], 0.1, m, degree),
                                   exact[:2 * m], atol=1e-9)
    with pytest.raises(InputError, match="at least 2"):
        sample_derivative(np.array([1.0]), 0.1)


def test_a_coarse_record_is_differentiated_at_its_samples_with_a_short_window():
    """At the simulator's 100 Hz step the schema's forward-difference convention holds
    (the derivative at t + dt/2, 16 samples); a 10 Hz record is differentiated at its samples
    over 5 of them. A 1 Hz oscillation (a short period) keeps 99.5 % of its amplitude there;
    the 16-sample window (1.6 s at 10 Hz) kept 35 % of it."""
    from simplexspline.aero.data.differentiation import derivative_by_maneuver

    for dt, shift in ((0.01, 0.005), (0.1, 0.0)):
        t = np.arange(0.0, 20.0, dt)
        x = np.sin(2 * np.pi * t)
        d = derivative_by_maneuver(np.zeros(t.size), t, x)
        inner = slice(int(1 / dt), -int(1 / dt))
        exact = 2 * np.pi * np.cos(2 * np.pi * (t + shift))
        gain = np.std(d[inner]) / np.std(exact[inner])
        assert 0.99 < gain < 1.01, (dt, gain)
        np.testing.assert_allclose(d[inner], exact[inner], atol=0.02 * 2 * np.pi)
    old = derivative_by_maneuver(np.zeros(t.size), t, x, half_window=8)
    assert np.std(old[inner]) / np.std(exact[inner]) < 0.4


def test_without_accelerometers_only_moment_coefficients(ideal_campaign):
    coef, _ = aerodynamic_coefficients(ideal_campaign.drop(columns=["ax", "ay", "az"]),
                                       accelerations="measured")
    assert coef[["CX", "CY", "CZ"]].isna().all().all()
    for c in ("Cl", "Cm", "Cn"):
        np.testing.assert_allclose(coef[c], ideal_campaign["true_" + c], atol=1e-6)


def test_a_thrust_model_replaces_missing_thrust_columns(ideal_campaign):
    df = ideal_campaign.drop(columns=list(THRUST_COLUMNS))
    truth = {c: ideal_campaign[c].to_numpy() for c in THRUST_COLUMNS}
    coef, thrust = aerodynamic_coefficients(df, accelerations="measured",
                                            thrust_model=lambda d: truth)
    assert thrust
    for c in COEFFICIENTS:
        np.testing.assert_allclose(coef[c], ideal_campaign["true_" + c], atol=1e-6)
    with pytest.raises(InputError, match="unknown key.*'thrust'"):
        aerodynamic_coefficients(df, thrust_model=lambda d: {"thrust": 1.0})


def test_thrust_model_of_fan_speed_density_and_mach():
    df = pd.DataFrame({"n1": [0.5, 1.0], "rho": [1.225, 0.6125], "mach": [0.0, 0.5]})
    model = ThrustModel("n1", coefficients=(0.0, 0.0, 40000.0), engines=2,
                        density_exponent=1.0, mach_factor=0.2, z_thrust_m=0.5)
    T = model(df)
    np.testing.assert_allclose(T["thrust_x"], [2 * 10000.0, 2 * 40000.0 * 0.5 * 1.1])
    np.testing.assert_allclose(T["thrust_m"], 0.5 * T["thrust_x"])
    assert ThrustModel.from_config({"input": "fuel_flow", "coefficients": [0, 5e4]}).engines == 1
    with pytest.raises(InputError, match="'n1' or 'fuel_flow'"):
        ThrustModel("rpm", (1.0,))
    with pytest.raises(InputError, match="unknown key"):
        ThrustModel.from_config({"input": "n1", "coefficients": [1], "sfc": 2})
    with pytest.raises(FlightDataError, match="needs column 'n1'"):
        model(df.drop(columns=["n1"]))


def test_transfer_moments_is_the_moment_of_the_forces_about_the_new_point():
    """Point forces F_i at p_i: the moment about P from the one about G and the total."""
    rng = np.random.default_rng(3)
    b, cbar, qs = 9.1, 3.4, 2.0e4
    points, forces = rng.normal(size=(5, 3)), rng.normal(size=(5, 3)) * 1e3
    G, P = np.array([0.3, -0.02, 0.1]), np.array([-0.5, 0.01, -0.2])
    scale = qs * np.array([b, cbar, b])
    about = {name: np.cross(points - at, forces).sum(axis=0) / scale
             for name, at in (("G", G), ("P", P))}
    moved = transfer_moments(forces.sum(axis=0)[None] / qs, about["G"][None], G - P, b, cbar)
    np.testing.assert_allclose(moved[0], about["P"], rtol=1e-12, atol=1e-15)


def test_lift_behind_the_reference_point_pitches_the_nose_down():
    """CZ < 0 (lift) at a c.g. 0.1 m aft of the point: Cm about the point drops by
    0.1 |CZ| / cbar."""
    moved = transfer_moments([[0.0, 0.0, -0.5]], [[0.0, 0.0, 0.0]], [-0.1, 0.0, 0.0],
                             10.0, 2.0)
    np.testing.assert_allclose(moved, [[0.0, -0.025, 0.0]])


def _moving_cg(df, dx=0.05, dz=0.02):
    """``df`` with the c.g. moved per maneuver (as fuel burn does)."""
    out = df.copy()
    k = out["maneuver"].to_numpy() % 3
    out["x_cg"], out["y_cg"], out["z_cg"] = -dx * k, 0.0, dz * k
    return out


def test_moments_of_a_moving_cg_are_transferred_to_one_fixed_point(ideal_campaign):
    df = _moving_cg(ideal_campaign)
    coef, _ = aerodynamic_coefficients(df, accelerations="measured")
    ref = coef.attrs["moment_reference"]
    assert ref["source"] == "the median c.g. of the data"
    np.testing.assert_allclose(ref["point_m"], np.median(df[["x_cg", "y_cg", "z_cg"]],
                                                         axis=0))
    arm = df[["x_cg", "y_cg", "z_cg"]].to_numpy() - ref["point_m"]
    true = df[[f"true_{c}" for c in COEFFICIENTS]].to_numpy()
    expected = transfer_moments(true[:, :3], true[:, 3:], arm, df.attrs["b"], df.attrs["cbar"])
    for j, c in enumerate(("Cl", "Cm", "Cn")):
        # the measured moments and the truth are about the same point
        np.testing.assert_allclose(coef[c], coef[f"true_{c}"], atol=1e-6)
        np.testing.assert_allclose(coef[f"true_{c}"], expected[:, j], rtol=1e-12)
    assert np.abs(coef["true_Cm"] - df["true_Cm"]).max() > 1e-3   # the transfer matters
    for c in ("CX", "CY", "CZ"):                                    # forces do not move
        np.testing.assert_allclose(coef[c], df[f"true_{c}"], atol=1e-6)


def test_a_given_moment_reference_point_is_used(ideal_campaign):
    df = _moving_cg(ideal_campaign)
    meta = {**df.attrs, "moment_reference_m": [0.0, 0.0, 0.0]}
    coef, _ = aerodynamic_coefficients(df, meta, accelerations="measured")
    assert coef.attrs["moment_reference"] == {"point_m": [0.0, 0.0, 0.0],
                                              "source": "metadata moment_reference_m"}
    cbar = df.attrs["cbar"]
    expected = df["true_Cm"] + (df["z_cg"] * df["true_CX"] - df["x_cg"] * df["true_CZ"]) / cbar
    np.testing.assert_allclose(coef["Cm"], expected, atol=1e-6)
    with pytest.raises(InputError, match="moment_reference_m must be three finite numbers"):
        aerodynamic_coefficients(df, {**df.attrs, "moment_reference_m": [0.0, 1.0]})


def test_cg_columns_without_forces_or_with_gaps_are_reported(ideal_campaign):
    df = _moving_cg(ideal_campaign)
    coef, _ = aerodynamic_coefficients(df.drop(columns=["ax", "ay", "az"]),
                                       accelerations="measured")
    assert coef.attrs["moment_reference"]["point_m"] is None
    assert "NOT transferred" in coef.attrs["moment_reference"]["source"]
    np.testing.assert_allclose(coef["Cm"], df["true_Cm"], atol=1e-6)
    part = df.copy()                    # one maneuver without accelerometers
    one = part["maneuver"] == part["maneuver"].iloc[0]
    part.loc[one, ["ax", "ay", "az"]] = np.nan
    coef, _ = aerodynamic_coefficients(part, accelerations="measured")
    assert coef.loc[one, ["Cl", "Cm", "Cn"]].isna().all().all()
    np.testing.assert_allclose(coef.loc[~one, "Cm"], coef.loc[~one, "true_Cm"], atol=1e-6)
    assert f"; {int(one.sum())} samples without force coefficients" in \
        coef.attrs["moment_reference"]["source"]
    gap = df.copy()
    gap.loc[gap.index[5], "x_cg"] = np.nan
    with pytest.raises(FlightDataError, match="x_cg, y_cg, z_cg hold NaN"):
        aerodynamic_coefficients(gap, accelerations="measured")


def test_campaigns_record_the_cg_that_fuel_burn_moves(noisy_campaign, ideal_campaign):
    """Sensors fixed to the airframe: the table carries the c.g. from their reference point
    (the full-fuel c.g.); it moves with the fuel, so it tracks the mass."""
    assert not {"x_cg", "y_cg", "z_cg"} & set(ideal_campaign.columns)   # sensors at the c.g.
    per = noisy_campaign.groupby("maneuver")[["x_cg", "z_cg", "mass"]].median()
    assert per["x_cg"].abs().max() < 0.2 and per["x_cg"].max() - per["x_cg"].min() > 0.01
    assert abs(np.corrcoef(per["x_cg"], per["mass"])[0, 1]) > 0.99
    ref = noisy_campaign.attrs["simulator"]["sensor_reference"]
    assert "full fuel" in ref["point"] and len(ref["jsbsim_structural_in"]) == 3


@pytest.mark.parametrize("n", [2, 3, 4, 5, 9, 40])
@pytest.mark.parametrize("m, degree", [(1, 1), (1, 2), (2, 2), (2, 4), (3, 3), (3, 4)])
def test_matched_smoothing_is_what_the_derivative_makes_of_a_piecewise_linear_rate(n, m,
                                                                                  degree):
    """For a derivative z linear between samples (any shape, a step inside one sample
    interval too) and x its exact integral, the sample derivative of x is the matched
    smoothing of z, at the ends (one-sided windows) as inside; its weights sum to 1."""
    from simplexspline.aero.data.differentiation import (matched_smoothing, matched_weights,
                                                         sample_derivative)

    rng = np.random.default_rng(n + 10 * m + 100 * degree)
    dt = 0.1
    z = rng.standard_normal(n)
    z[n // 2:] += 3.0                      # an elevator step
    x = np.r_[0.0, np.cumsum(0.5 * dt * (z[1:] + z[:-1]))]
    np.testing.assert_allclose(sample_derivative(x, dt, m, degree),
                               matched_smoothing(z, m, degree), atol=1e-9)
    w = min(2 * m + 1, n)
    for at in range(w):
        assert matched_weights(np.arange(float(w)), at, min(degree, w - 1)).sum() \
            == pytest.approx(1.0)


def test_matched_smoothing_by_maneuver_follows_the_derivative_s_windows():
    """Per maneuver, in time order: a 10 Hz maneuver smoothed as its derivative (5 samples),
    a 100 Hz one unchanged (the schema's forward difference is exact there), NaN for a
    maneuver's signal with a NaN; a constant stays constant."""
    from simplexspline.aero.data.differentiation import (matched_by_maneuver,
                                                         matched_smoothing)

    rng = np.random.default_rng(3)
    t = np.r_[np.arange(30) * 0.1, np.arange(50) * 0.01, np.arange(20) * 0.1]
    man = np.repeat([1, 2, 3], [30, 50, 20])
    z = rng.standard_normal((100, 2))
    z[80:85, 1] = np.nan
    order = rng.permutation(100)           # any row order
    out = np.empty_like(z)
    out[order] = matched_by_maneuver(man[order], t[order], z[order])
    np.testing.assert_allclose(out[:30, 0], matched_smoothing(z[:30, 0], 2, 4))
    np.testing.assert_array_equal(out[30:80], z[30:80])
    assert np.isnan(out[80:, 1]).all()
    np.testing.assert_allclose(out[80:, 0], matched_smoothing(z[80:, 0], 2, 4))
    np.testing.assert_allclose(matched_by_maneuver(man, t, np.full(100, 0.7)), 0.7)
