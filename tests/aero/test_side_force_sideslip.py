"""The sideslip from the side force through an identified CY model (no sideslip vane, gusts)."""

from __future__ import annotations

import importlib

import numpy as np
import pandas as pd
import pytest

from simplexspline.aero.identify import IdentificationSettings, identify
from simplexspline.aero.modelling.structure import Structure
from simplexspline.aero.selection.search import PLAIN_FIT, fit_structure
from simplexspline.aero.selection.side_force_sideslip import (
    MAX_CORRECTION,
    LinearSideForce,
    REFEREE_GAIN,
    choose_sideslip,
    cross_fitted_sideslip,
    referee,
    side_force_sideslip,
)
from simplexspline.errors import InputError

from .synthetic import synthetic_table

NOISE = 1e-3
KINEMATIC = ("estimated from the lateral kinematics and GPS (no sideslip vane), zero mean "
             "over the maneuver assumed")


def _gusts(man: np.ndarray, t: np.ndarray, rng, size=0.006) -> np.ndarray:
    """A lateral gust's sideslip per maneuver [rad]: slow (0.2-0.5 Hz), zero mean."""
    out = np.zeros(man.size)
    for m in np.unique(man):
        k = man == m
        f, ph = rng.uniform(0.2, 0.5, 2), rng.uniform(0, 2 * np.pi, 2)
        out[k] = size * np.sum(np.sin(2 * np.pi * f[:, None] * t[k] + ph[:, None]), axis=0)
    return out


def _gusty_table(seed=0) -> pd.DataFrame:
    """The synthetic flights, their coefficients following the true sideslip (``true_beta``),
    and ``beta`` the kinematic one that misses a lateral gust."""
    rng = np.random.default_rng(seed)
    df = synthetic_table(seed=seed, noise=NOISE)
    df["true_beta"] = df["beta"]
    df["beta"] = df["true_beta"] - _gusts(df["maneuver"].to_numpy(), df["t"].to_numpy(), rng)
    return df


def _cy_model(df):
    cols = {c: df[c].to_numpy() for c in ("beta", "dr", "da")}
    return fit_structure(Structure("CY", ("beta", "dr", "da"), 2, 1), cols, df["CY"].to_numpy())


def _rms(e) -> float:
    return float(np.sqrt(np.mean(np.square(e))))


def test_the_side_force_gives_the_sideslip_to_its_noise_through_a_right_model():
    """Through a CY model of the true sideslip, the side force gives the sideslip to the
    side-force noise over |CY_beta| (0.9), whatever the kinematic sideslip missed."""
    df = _gusty_table()
    model = _cy_model(df.assign(beta=df["true_beta"]))
    rows = df["maneuver"].to_numpy() % 2 == 0           # the maneuvers with gusts
    sf = side_force_sideslip(model, df, rows)
    assert _rms((sf.beta - df["true_beta"])[rows]) == pytest.approx(NOISE / 0.9, rel=0.1)
    np.testing.assert_array_equal(sf.beta[~rows], df["beta"].to_numpy()[~rows])
    assert sf.slope == pytest.approx(-0.9, abs=0.02)
    assert sf.correction_rms == pytest.approx(_rms(sf.beta[rows] - df["beta"][rows]))
    assert sf.clipped == 0
    # nothing to correct: the kinematic sideslip as it is
    none = side_force_sideslip(model, df, np.zeros(len(df), bool))
    np.testing.assert_array_equal(none.beta, df["beta"].to_numpy())


def test_through_the_model_fitted_on_the_kinematic_sideslip_the_error_halves():
    """As identify does it: CY's model is fitted on the kinematic sideslip, whose error
    (the gusts) attenuates its slope by var(beta) / (var(beta) + var(gust)) (errors in
    variables); the side force's sideslip then carries that scale error, and its error is
    below 0.6 times the kinematic one's."""
    df = _gusty_table()
    model = _cy_model(df)
    rows = np.ones(len(df), bool)
    sf = side_force_sideslip(model, df, rows)
    kept = np.var(df["true_beta"]) / np.var(df["beta"] - df["beta"].mean())
    assert kept < 1 and sf.slope == pytest.approx(-0.9 * kept, rel=0.1)
    assert _rms(sf.beta - df["true_beta"]) < 0.6 * _rms(df["beta"] - df["true_beta"])


def test_corrections_are_clipped_and_bad_models_refused():
    df = _gusty_table()
    model = _cy_model(df)
    wild = df.assign(CY=df["CY"] + np.where(df["maneuver"] == 0, 0.5, 0.0))   # a glitch
    sf = side_force_sideslip(model, wild, np.ones(len(df), bool))
    k = (df["maneuver"] == 0).to_numpy()
    assert sf.clipped == k.sum()
    np.testing.assert_allclose(np.abs(sf.beta[k] - df["beta"].to_numpy()[k]), MAX_CORRECTION)
    cols = {c: df[c].to_numpy() for c in ("dr", "da")}
    no_beta = fit_structure(Structure("CY", ("dr", "da"), 1, 0), cols, df["CY"].to_numpy())
    with pytest.raises(InputError, match="needs a CY model with 'beta'"):
        side_force_sideslip(no_beta, df, np.ones(len(df), bool))
    flat = df.assign(CY=0.15 * df["dr"])
    with pytest.raises(InputError, match="dCY/dbeta is 0"):
        side_force_sideslip(_cy_model(flat.assign(CY=0.0 * df["beta"])), flat,
                            np.ones(len(df), bool))


def test_cross_fitted_sideslip_is_out_of_sample_and_still_better():
    """Each fold through CY's structure refitted without it: not the in-sample correction,
    as good on the data as through the full model (the gusts are not in CY's structure)."""
    df = _gusty_table()
    model = _cy_model(df)
    rows = np.ones(len(df), bool)
    inside = side_force_sideslip(model, df, rows)
    crossed = cross_fitted_sideslip(model, df, rows, PLAIN_FIT)
    assert not np.allclose(crossed.beta, inside.beta)
    assert _rms(crossed.beta - inside.beta) < 0.2 * _rms(inside.beta - df["beta"])
    assert _rms(crossed.beta - df["true_beta"]) < 0.6 * _rms(df["beta"] - df["true_beta"])
    assert crossed.slope == pytest.approx(inside.slope, rel=0.05)
    with pytest.raises(InputError, match="at least two maneuvers"):
        cross_fitted_sideslip(model, df[df["maneuver"] == 0], rows[:800], PLAIN_FIT)


def test_the_referee_prefers_the_sideslip_that_explains_the_moments():
    df = _gusty_table()
    truth, kinematic = df["true_beta"].to_numpy(), df["beta"].to_numpy()
    better = referee(df, kinematic, truth)
    assert set(better) == {"Cl", "Cn"} and all(r < REFEREE_GAIN for r in better.values())
    noisy = kinematic + 0.02 * np.random.default_rng(0).standard_normal(len(df))
    assert all(r > 1.0 for r in referee(df, kinematic, noisy).values())
    assert referee(df[df["maneuver"] == 0], kinematic[:800], truth[:800]) == {}
    assert referee(df.drop(columns=["Cl", "Cn"]), kinematic, truth) == {}


def test_a_side_force_model_that_explains_no_gust_is_refused():
    """A side force with a disturbance of its own (not the air's sideslip: the roll and
    yaw moments do not see it) makes a sideslip that explains them worse: refused. The
    gusts' side force is taken."""
    df = _gusty_table()
    rows = np.ones(len(df), bool)
    good = choose_sideslip(_cy_model(df), df, df, rows, rows, PLAIN_FIT)
    assert good.used and all(r < REFEREE_GAIN for r in good.ratios.values())
    rng = np.random.default_rng(5)
    junk = df.assign(beta=df["true_beta"],
                     CY=df["CY"] + _gusts(df["maneuver"].to_numpy(), df["t"].to_numpy(),
                                          rng, size=0.02))
    bad = choose_sideslip(_cy_model(junk), junk, junk, rows, rows, PLAIN_FIT)
    assert not bad.used and min(bad.ratios.values()) > 1.0
    one = df[df["maneuver"] == 0]
    lone = choose_sideslip(_cy_model(df), one, one, rows[:800], rows[:800], PLAIN_FIT)
    assert not lone.used and lone.ratios == {}
    np.testing.assert_array_equal(lone.identification, one["beta"].to_numpy())


def _reconstructed(df, gusty=True):
    """The table as a reconstruction without sideslip vane leaves it: its record says so,
    with gusts found in every maneuver (or none)."""
    out = df.copy()
    out.attrs = {**df.attrs, "reconstruction": {"maneuvers": {
        str(m): {"observability": {"beta": KINEMATIC},
                 "gusts": {"std": 1.0 if gusty else 0.0, "length_m": 300.0}}
        for m in df["maneuver"].unique()}}}
    return out


def test_identify_fits_the_roll_and_yaw_models_on_the_side_force_sideslip():
    """Cl and Cn in beta: on the kinematic sideslip their models carry the gusts'
    -0.08 x 1e-2 and 0.1 x 1e-2; on the side force's they reach the noise. CY keeps the
    kinematic sideslip; the note, the provenance and the column say what was done."""
    df = _gusty_table(1)
    settings = IdentificationSettings(
        coefficients=("CY", "Cl", "Cn"), select=False,
        structures={"CY": Structure("CY", ("beta", "dr", "da"), 2, 1),
                    "Cl": Structure("Cl", ("beta", "da", "phat", "rhat"), 2, 1),
                    "Cn": Structure("Cn", ("beta", "dr", "rhat"), 2, 1)})
    plain = identify(_reconstructed(df, gusty=False), settings=settings)
    aided = identify(_reconstructed(df), settings=settings)
    assert "beta_side_force" not in plain.validation.columns
    for c in ("Cl", "Cn"):
        before = plain.results[c].validation["rms_true"]
        after = aided.results[c].validation["rms_true"]
        assert after < 0.6 * before, (c, before, after)
        assert after < 1.5 * aided.results[c].validation["noise_rms"]
    assert aided.results["CY"].validation == plain.results["CY"].validation
    v = aided.validation
    assert _rms(v["beta_side_force"] - v["true_beta"]) < \
        0.6 * _rms(v["beta"] - v["true_beta"])
    assert any("no sideslip vane and gusts" in n and "Cl, Cn identified on the sideslip" in n
               for n in aided.warnings)
    record = aided.results["Cl"].model.provenance["sideslip"]
    assert record["coefficients"] == ["Cl", "Cn"] and record["dCY_dbeta_per_rad"] < 0


def test_identify_keeps_the_kinematic_sideslip_when_the_referee_refuses():
    df = _gusty_table(1)
    rng = np.random.default_rng(2)
    junk = df.assign(beta=df["true_beta"],
                     CY=df["CY"] + _gusts(df["maneuver"].to_numpy(), df["t"].to_numpy(), rng,
                                          size=0.02))
    settings = IdentificationSettings(
        coefficients=("CY", "Cn"), select=False,
        structures={"CY": Structure("CY", ("beta", "dr", "da"), 2, 1),
                    "Cn": Structure("Cn", ("beta", "dr", "rhat"), 2, 1)})
    plain = identify(_reconstructed(junk, gusty=False), settings=settings)
    refused = identify(_reconstructed(junk), settings=settings)
    assert refused.results["Cn"].validation == plain.results["Cn"].validation
    assert "sideslip" not in refused.provenance
    assert any("did not explain the roll and yaw moments better out of sample" in n
               and "the others keep the kinematic sideslip" in n for n in refused.warnings)
    assert "beta_side_force" in refused.validation.columns


def test_a_side_force_that_cannot_give_the_sideslip_is_said_not_raised(monkeypatch):
    def flat(*_args, **_kw):
        raise InputError("the CY model's dCY/dbeta is 0 over the rows asked for")

    monkeypatch.setattr(importlib.import_module("simplexspline.aero.identify"),
                        "choose_sideslip", flat)
    df = _gusty_table(1)
    settings = IdentificationSettings(
        coefficients=("CY", "Cn"), select=False,
        structures={"CY": Structure("CY", ("beta", "dr"), 1, 0),
                    "Cn": Structure("Cn", ("beta", "dr"), 1, 0)})
    res = identify(_reconstructed(df), settings=settings)
    assert set(res.results) == {"CY", "Cn"} and "sideslip" not in res.provenance
    assert any("the side force cannot give the sideslip (the CY model's dCY/dbeta is 0"
               in n for n in res.warnings)


def _proxy_table(seed=0) -> pd.DataFrame:
    """Maneuvers whose side force follows the air's sideslip, the rudder and the yaw rate;
    the kinematic sideslip misses a lateral gust, and the roll rate follows that gust (as
    the aircraft's response to it does): a side-force model that takes the roll rate uses
    it for the sideslip the kinematics missed, and its dCY/dbeta falls. Two maneuvers in
    eight are rudder inputs with a large sideslip."""
    rng = np.random.default_rng(seed)
    t = np.arange(600) * 0.05
    parts = []
    for m in range(8):
        rudder = m in (2, 5)
        amp = 0.05 if rudder else 0.004
        f, ph = rng.uniform(0.2, 0.6, 3), rng.uniform(0, 2 * np.pi, 3)
        beta_air = amp * np.sin(2 * np.pi * f[0] * t + ph[0])
        gust = 0.006 * np.sin(2 * np.pi * f[1] * t + ph[1])
        dr = (0.08 if rudder else 0.005) * np.sin(2 * np.pi * f[2] * t + ph[2])
        rhat = 0.3 * np.gradient(beta_air, t) * 0.05 + 0.001 * rng.standard_normal(t.size)
        true_beta = beta_air + gust
        phat = 0.5 * gust + 1.5e-3 * rng.standard_normal(t.size)
        cy = -0.9 * true_beta + 0.15 * dr - 0.3 * rhat
        parts.append(pd.DataFrame({
            "maneuver": m, "t": t, "beta": beta_air, "true_beta": true_beta, "dr": dr,
            "rhat": rhat, "phat": phat, "da": 0.01 * np.sin(0.7 * t + m),
            "CY": cy + 5e-4 * rng.standard_normal(t.size),
            "Cl": -0.08 * true_beta - 0.4 * phat + 5e-4 * rng.standard_normal(t.size),
            "Cn": 0.1 * true_beta - 0.06 * dr - 0.2 * rhat
            + 5e-4 * rng.standard_normal(t.size)}))
    return pd.concat(parts, ignore_index=True)


def test_the_linear_side_force_keeps_the_air_s_slope_where_a_proxy_takes_it():
    df = _proxy_table()
    lin = LinearSideForce.fit(df)
    assert lin.terms == ("1", "beta", "dr", "rhat") and set(lin.maneuvers) == {2, 5}
    assert lin.slope == pytest.approx(-0.9, abs=0.05)
    # CY's best model on the kinematic sideslip takes the roll rate for the missed gust
    cols = {c: df[c].to_numpy() for c in ("beta", "dr", "rhat", "phat")}
    model = fit_structure(Structure("CY", ("beta",), 0, -1, (1,),
                                    multipliers=("1", "beta", "dr", "rhat", "phat")),
                          cols, df["CY"].to_numpy())
    through_model = side_force_sideslip(model, df, np.ones(len(df), bool))
    through_linear = side_force_sideslip(lin, df, np.ones(len(df), bool))
    truth = df["true_beta"].to_numpy()
    assert _rms(through_linear.beta - truth) < 0.3 * _rms(through_model.beta - truth)
    assert _rms(through_linear.beta - truth) < 0.3 * _rms(df["beta"] - truth)
    # the roll and yaw moments say so: the referee takes the linear model's sideslip
    rows = np.ones(len(df), bool)
    choice = choose_sideslip(model, df, df, rows, rows, PLAIN_FIT)
    assert choice.used and choice.source == "linear"
    assert choice.slope == pytest.approx(lin.slope)
    assert set(choice.candidates) == {"model", "linear"}
    assert choice.candidates["linear"]["referee_error_ratios"]["Cn"] < \
        choice.candidates["model"]["referee_error_ratios"]["Cn"]


def test_a_linear_side_force_that_cannot_give_the_sideslip_is_named():
    df = _proxy_table()
    with pytest.raises(InputError, match="needs the columns maneuver, beta and CY"):
        LinearSideForce.fit(df.drop(columns=["CY"]))
    with pytest.raises(InputError, match="dCY/dbeta is 0: it cannot give the sideslip"):
        LinearSideForce.fit(df.assign(CY=0.0))
    with pytest.raises(InputError, match="finite samples for 4 terms"):
        LinearSideForce.fit(df.iloc[:3])



def test_choose_sideslip_goes_on_without_the_linear_candidate(monkeypatch):
    """Where the linear side force cannot be made, CY's model's sideslip is judged alone,
    and the choice says why the other is missing."""
    def refuse(_data):
        raise InputError("the linear side-force model's dCY/dbeta is 0")

    monkeypatch.setattr(LinearSideForce, "fit", staticmethod(refuse))
    df = _gusty_table()
    rows = np.ones(len(df), bool)
    choice = choose_sideslip(_cy_model(df), df, df, rows, rows, PLAIN_FIT)
    assert choice.used and choice.source == "model"
    assert "dCY/dbeta is 0" in choice.candidates["linear"]["not made"]


def test_identify_says_cy_s_slope_is_attenuated_where_the_linear_side_force_is_taken():
    df = _proxy_table(1)
    df["maneuver_type"] = np.where(df["maneuver"].isin([2, 5]), "doublet-rudder", "turn")
    rng = np.random.default_rng(7)
    for c in ("CX", "CZ", "Cm", "qhat"):          # a complete reconstructed table
        df[c] = 1e-3 * rng.standard_normal(len(df))
    df["alpha"], df["mach"] = 0.05, 0.5
    df.attrs = {"aircraft": "synthetic", "S": 20.0, "b": 10.0, "cbar": 2.0}
    settings = IdentificationSettings(
        coefficients=("CY", "Cn"), select=False, reconstruct="never",
        structures={"CY": Structure("CY", ("beta",), 0, -1, (1,),
                                    multipliers=("1", "beta", "dr", "rhat", "phat")),
                    "Cn": Structure("Cn", ("beta",), 0, -1, (1,),
                                    multipliers=("1", "beta", "dr", "rhat"))})
    res = identify(_reconstructed(df), settings=settings)
    record = res.provenance["sideslip"]
    assert record["through"] == "linear" and set(record["candidates"]) == {"model", "linear"}
    assert "fitted once on the identification data" in record["source"]
    note = next(n for n in res.warnings if "no sideslip vane and gusts" in n)
    assert "a side force linear in the sideslip, rudder and yaw rate" in note
    # CY's own slope is the air's here (-0.90 both): no word on attenuation
    assert "CY's own model has dCY/dbeta" not in note


def test_the_note_says_when_cy_s_own_slope_is_attenuated():
    from simplexspline.aero.identify import _attenuation_note
    from simplexspline.aero.selection.side_force_sideslip import SideslipChoice

    def choice(source, model_slope, slope=-0.89):
        return SideslipChoice(True, np.zeros(3), np.zeros(3), {}, slope, 0.0, 0, source,
                              {"model": {"dCY_dbeta": model_slope}})

    note = _attenuation_note(choice("linear", -0.21))
    assert "CY's own model has dCY/dbeta -0.21 /rad" in note and "errors in variables" in note
    assert _attenuation_note(choice("linear", -0.85)) == ""     # within 20 %: nothing said
    assert _attenuation_note(choice("model", -0.21, -0.21)) == ""
