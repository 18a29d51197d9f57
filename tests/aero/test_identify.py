"""The identification pipeline on synthetic data with known coefficient functions."""

from __future__ import annotations

import importlib
import json
import re
import warnings
from dataclasses import replace

import numpy as np
import pytest

from simplexspline.aero.identify import (
    OUTPUT_MARKER,
    Identification,
    IdentificationSettings,
    ThinDataWarning,
    _imu_position_note,
    _vane_scale_note,
    identify,
)
from simplexspline.aero.derivatives import derivatives, reference_conditions
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.aero.selection.search import SelectionSettings, fit_structure, select_structure
from simplexspline.aero.modelling.structure import Structure
from simplexspline.errors import FlightDataError, InputError, ModelFileError

from .synthetic import synthetic_table, true_cz

pytestmark = pytest.mark.filterwarnings("ignore::simplexspline.aero.identify.ThinDataWarning")

FAST = SelectionSettings(max_rounds=2, max_samples=6000, moves=("variables",),
                         samples_per_coefficient=5)


@pytest.fixture(scope="module")
def table():
    return synthetic_table()


@pytest.fixture(scope="module")
def result(table) -> Identification:
    settings = IdentificationSettings(
        coefficients=("CZ", "Cm"),
        structures={"CZ": Structure("CZ", ("alpha", "de", "mach"))},
        selection=FAST)
    return identify(table, settings=settings)


def test_fit_structure_recovers_a_polynomial_in_its_space(table):
    cols = {c: table[c].to_numpy() for c in table.columns if c != "maneuver_type"}
    s = Structure("CZ", ("alpha", "de", "mach", "qhat"), 3, 1)
    model = fit_structure(s, cols, table["true_CZ"].to_numpy())
    pred = model.predict(table)
    # true_cz is a cubic polynomial: reproduced to rounding by S^1_3 (tiny ridge only)
    assert np.abs(pred - table["true_CZ"]).max() < 1e-6


def test_selection_adds_the_missing_variable(table):
    cols = {c: table[c].to_numpy() for c in table.columns if c != "maneuver_type"}
    start = Structure("CZ", ("alpha", "de", "mach"))
    # the search's own moves (two rounds of 'variables' only); with the hinge start on, its
    # basis of hinge products wins on these settings and must use the variable too
    hinged, _ = select_structure(start, cols, table["CZ"].to_numpy(),
                                 table["maneuver"].to_numpy(), FAST)
    assert "qhat" in hinged.inputs
    best, history = select_structure(start, cols, table["CZ"].to_numpy(),
                                     table["maneuver"].to_numpy(),
                                     replace(FAST, hinge_start=False))
    assert "qhat" in best.variables
    assert history[0].move == "start" and history[0].accepted
    accepted = [t for t in history if t.accepted]
    assert [t.score for t in accepted] == sorted([t.score for t in accepted], reverse=True)
    # every tried structure is recorded with a finite score, and each added candidate
    assert all(np.isfinite(t.score) for t in history)
    assert {"add beta", "add qhat"} <= {t.move for t in history}


def test_identify_scores_against_measurement_and_truth(result, table):
    cz = result.results["CZ"]
    # scheduled on it, or a term in it (the hinge start's constant-coefficient basis)
    assert "qhat" in cz.structure.inputs
    v = cz.validation
    noise = 2e-3
    assert v["noise_rms"] == pytest.approx(noise, rel=0.1)
    # a cubic in the spline space: the error against the truth (estimation variance of
    # 840 coefficients from ~7,000 samples, ~sqrt(840/7000) of the noise) is below the noise
    assert v["rms_true"] < 0.6 * noise
    assert v["rms"] == pytest.approx(np.hypot(noise, v["rms_true"]), rel=0.1)
    # Eq. 54-55 with the square root: relative RMS = RMS / range of the measurement, on
    # the validation samples inside the identification data's envelope; the rest apart
    inside = result.validation["inside_CZ"].to_numpy()
    # in a covered envelope cell, in a kept simplex and inside the model's identified box
    model = cz.model
    x = result.validation[list(model.variables)].to_numpy()
    in_box = np.all((x >= model.scaling.lower) & (x <= model.scaling.upper), axis=1)
    np.testing.assert_array_equal(
        inside, result.validation["inside_envelope"].to_numpy() & in_box
        & (model.locate(x) >= 0))
    assert v["coverage"] == pytest.approx(inside.mean()) and inside.mean() > 0.8
    y = result.validation["CZ"].to_numpy()[inside]
    e = y - result.validation["model_CZ"].to_numpy()[inside]
    assert v["rms"] == pytest.approx(np.sqrt(np.mean(e**2)))
    if not inside.all():
        out = result.validation.loc[~inside]
        assert v["outside"]["n"] == len(out)
        assert v["outside"]["rms"] == pytest.approx(np.sqrt(np.mean(
            (out["CZ"] - out["model_CZ"]).to_numpy() ** 2)))
    assert v["rrms"] == pytest.approx(v["rms"] / (y.max() - y.min()))
    assert v["r2"] > 0.999
    # validation maneuvers are whole and disjoint from the identification ones
    ident_m = set(result.identification["maneuver"])
    valid_m = set(result.validation["maneuver"])
    assert ident_m.isdisjoint(valid_m) and ident_m | valid_m == set(table["maneuver"])


def test_table_and_summary(result):
    text = result.table()
    assert "CZ(" in text and "Cm(" in text and "RMS true" in text
    s = result.summary()
    for c in ("CZ", "Cm"):
        e = s["coefficients"][c]
        for key in ("structure", "rms", "rrms", "r2", "rms_true", "rrms_true", "selection"):
            assert key in e
        assert 0 < e["rrms"] < 0.05
    assert s["coefficients"]["CZ"]["paper_rrms"] == 0.026


def test_derivatives_come_with_their_jackknife_standard_errors(result):
    """identify refits each structure without each fold of identification maneuvers and
    gives the derivatives at the reference condition with their spread."""
    table = result.derivatives
    k = result.settings.derivative_folds
    assert table.attrs["folds"] == k == 5
    assert all(len(r.fold_models) == k for r in result.results.values())
    models = {c: r.model for c, r in result.results.items()}
    ref = reference_conditions(models, result.identification)
    assert table.attrs["reference"] == pytest.approx(ref)
    at_ref = derivatives(models, reference=ref)
    row = table.loc["Cm_alpha"]
    assert row["value"] == pytest.approx(at_ref["Cm_alpha"].iloc[0])
    assert row["folds"] == k and 0 < row["standard_error"] < 0.1
    # true_cm = 0.02 - 0.5 alpha - 1.2 de - 8 qhat + 2 alpha^2: the truth within 4 errors
    truth = -0.5 + 4.0 * ref["alpha"]
    assert abs(row["value"] - truth) < 4 * row["standard_error"] + 0.01
    assert "CL_alpha" not in table.index         # no CX model
    s = result.summary()["derivatives"]
    assert s["folds"] == k and s["values"]["Cm_alpha"]["standard_error"] == pytest.approx(
        row["standard_error"])
    json.dumps(s)                                 # plain JSON
    text = result.derivative_table()
    assert re.search(r"Cm_alpha\s+[-+][0-9.]+ \+- [0-9.e-]+\s+1/rad", text), text


def test_the_derivatives_command_prints_identifys_standard_errors(result, tmp_path, capsys,
                                                                no_report):
    from simplexspline.cli import main

    out = result.save(tmp_path / "out", report=False)
    assert main(["derivatives", str(out), "-o", str(tmp_path / "d.csv")]) == 0
    text = capsys.readouterr().out
    assert "identify's jackknife standard errors over 5 folds of maneuvers" in text
    row = result.derivatives.loc["Cm_alpha"]
    assert f"Cm_alpha = {row['value']:.4g} +- {row['standard_error']:.2g} 1/rad" in text
    # a summary without them (an older output) or unreadable: said, never a crash
    summary = out / "summary.json"
    summary.write_text(summary.read_text().replace('"derivatives"', '"other"'))
    assert main(["derivatives", str(out), "-o", str(tmp_path / "d.csv")]) == 0
    assert "jackknife" not in capsys.readouterr().out
    summary.write_text("{not json")
    assert main(["derivatives", str(out), "-o", str(tmp_path / "d.csv")]) == 0
    assert "no readable jackknife standard errors" in capsys.readouterr().out


def test_the_derivatives_command_gives_standard_errors_at_every_condition(result, tmp_path,
                                                                        no_report):
    """The refits travel with the output (models/jackknife); the derivatives command reads
    them and writes a standard error per derivative and condition."""
    from simplexspline.aero.derivatives.jackknife import load_fold_models
    from simplexspline.cli import main

    out = result.save(tmp_path / "out", report=False)
    folds = load_fold_models(out)
    assert len(folds) == 5 and all(set(f) == {"CZ", "Cm"} for f in folds)
    csv = tmp_path / "d.csv"
    assert main(["derivatives", str(out), "-o", str(csv), "-q"]) == 0
    import pandas as pd

    table = pd.read_csv(csv)
    se = table["se_Cm_alpha"].to_numpy()
    # NaN only at the ends of the sweep, beyond the boxes of most refits (narrower data)
    finite = np.isfinite(se)
    assert finite.mean() > 0.9 and np.all(se[finite] > 0)
    assert finite[len(se) // 4: 3 * len(se) // 4].all()
    meta = json.loads((tmp_path / "d.csv.json").read_text())
    assert meta["columns"]["se_Cm_alpha"]["kind"] == "standard_error"
    # at identify's reference condition they are the summary's
    points = tmp_path / "ref.csv"
    pd.DataFrame([result.derivatives.attrs["reference"]]).to_csv(points, index=False)
    assert main(["derivatives", str(out), "-o", str(csv), "-q", "--points", str(points)]) == 0
    assert pd.read_csv(csv)["se_Cm_alpha"].iloc[0] == pytest.approx(
        result.derivatives.loc["Cm_alpha", "standard_error"], rel=1e-6)
    long = tmp_path / "long.csv"
    assert main(["derivatives", str(out), "-o", str(long), "-q", "--long"]) == 0
    assert "standard_error" in pd.read_csv(long).columns
    # model files alone (no output directory): no refits, no standard errors
    assert main(["derivatives", str(out / "models" / "Cm.json"), "-o", str(csv), "-q"]) == 0
    assert not [c for c in pd.read_csv(csv).columns if c.startswith("se_")]


def test_no_folds_no_standard_errors(table):
    settings = IdentificationSettings(coefficients=("Cm",), selection=FAST,
                                      derivative_folds=0)
    res = identify(table, settings=settings)
    assert res.derivatives is None and res.results["Cm"].fold_models == []
    assert "derivatives" not in res.summary() and res.derivative_table() == ""


def test_a_derivative_whose_sign_the_data_do_not_determine_is_named(table):
    """Cm without any elevator effect, in a model that takes the elevator: its Cm_de is
    noise about zero, and identify says the data do not determine its sign (not a
    confident slope); Cm_alpha, which the data determine, is not named."""
    data = table.copy()
    data["Cm"] = data["Cm"] + 1.2 * data["de"]
    data.attrs = table.attrs
    settings = IdentificationSettings(
        coefficients=("Cm",), select=False,
        structures={"Cm": Structure("Cm", ("alpha", "de", "qhat"), 2, 1)})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = identify(data, settings=settings)
    row = res.derivatives.loc["Cm_de"]
    assert abs(row["value"]) < 2 * row["standard_error"]
    note = next(n for n in res.warnings if "do not determine the sign" in n)
    assert re.search(r"Cm_de [-+][0-9.e-]+ \+- [0-9.e-]+ 1/rad", note), note
    assert "Cm_alpha" not in note
    assert any("do not determine the sign" in str(w.message) for w in caught
               if issubclass(w.category, ThinDataWarning))


def test_save_writes_models_summary_and_loads(result, tmp_path, monkeypatch):
    report = importlib.import_module("simplexspline.aero.identify")  # it calls write_report

    monkeypatch.setattr(report, "write_report", lambda res, out, progress=None: None)
    out = result.save(tmp_path / "out")
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["coefficients"]) == {"CZ", "Cm"}
    model = AeroModel.load(out / "models" / "CZ.json")
    v = result.validation
    np.testing.assert_array_equal(model.predict(v), v["model_CZ"].to_numpy())
    assert model.provenance["software"].startswith("simplexspline")
    assert model.metadata()["units"]["alpha"] == "rad"
    # npz too
    out2 = result.save(tmp_path / "npz", model_format="npz")
    np.testing.assert_array_equal(AeroModel.load(out2 / "models" / "Cm.npz").predict(v),
                                  v["model_Cm"].to_numpy())


def test_failed_save_leaves_no_directory_and_keeps_the_old_one(result, tmp_path, monkeypatch):
    report = importlib.import_module("simplexspline.aero.identify")  # it calls write_report

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(report, "write_report", boom)
    with pytest.raises(RuntimeError, match="disk full"):
        result.save(tmp_path / "out")
    assert list(tmp_path.iterdir()) == []
    monkeypatch.setattr(report, "write_report", lambda res, out, progress=None: None)
    result.save(tmp_path / "out")
    (tmp_path / "out" / "marker").write_text("old")
    monkeypatch.setattr(report, "write_report", boom)
    with pytest.raises(RuntimeError):
        result.save(tmp_path / "out")
    assert (tmp_path / "out" / "marker").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


@pytest.fixture
def no_report(monkeypatch):
    identify_module = importlib.import_module("simplexspline.aero.identify")
    monkeypatch.setattr(identify_module, "write_report", lambda res, out, progress=None: None)


def _names(d):
    return sorted(p.name for p in d.iterdir())


def test_save_never_touches_foreign_files(result, tmp_path, no_report):
    """`identify d/input.parquet -o d` must not delete the input (issue 18, item 2)."""
    d = tmp_path / "d"
    d.mkdir()
    (d / "input.parquet").write_bytes(b"the user's data")
    with pytest.raises(InputError, match=r"holds files that are not a previous "
                                         r"identification output \(input.parquet\).*"
                                         r"--overwrite"):
        result.save(d)
    assert _names(d) == ["input.parquet"]
    result.save(d, overwrite=True)
    assert (d / "input.parquet").read_bytes() == b"the user's data"
    assert {"models", "summary.json", OUTPUT_MARKER} <= set(_names(d))
    # a previous output is recognised by its marker: saved again without --overwrite, and
    # a file the user put in it in between is kept
    (d / "notes.txt").write_text("mine")
    result.save(d, model_format="npz")
    assert (d / "notes.txt").read_text() == "mine"
    assert _names(d / "models") == ["CZ.npz", "Cm.npz", "jackknife"]
    assert _names(d / "models" / "jackknife") == [f"{c}-{f}.npz" for c in ("CZ", "Cm")
                                                  for f in range(5)]
    assert not [n for n in _names(d) if n.startswith(".identify.")]


def test_save_into_the_current_directory(result, tmp_path, monkeypatch, no_report):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    result.save(".")
    assert {"models", "summary.json", OUTPUT_MARKER} <= set(_names(work))
    result.save(".")
    assert not [n for n in _names(work) if n.startswith(".identify.")]
    assert _names(tmp_path) == ["work"]                 # nothing left beside it


def test_output_dir_checked_before_any_work(tmp_path, capsys):
    d = tmp_path / "d"
    d.mkdir()
    (d / "keep.csv").write_text("x")
    from simplexspline.cli import main

    assert main(["identify", "-o", str(d), "--maneuvers", "2", "--rounds", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds files that are not a previous identification" in err[0]
    assert "simulating" not in capsys.readouterr().out
    assert _names(d) == ["keep.csv"]


def test_model_predict_on_named_columns_and_arrays(result, table):
    model = result.results["CZ"].model
    x = np.column_stack([table[v] for v in model.variables])
    np.testing.assert_array_equal(model.predict(x), model.predict(table))
    g = model.gradient(table.iloc[:50])
    assert g.shape == (50, len(model.variables))
    i = model.variables.index("qhat")
    assert np.median(g[:, i]) == pytest.approx(-30.0, rel=0.05)   # dCZ/dqhat of true_cz
    with pytest.raises(InputError, match="needs column"):
        model.predict(table.drop(columns=["alpha"]))
    with pytest.raises(InputError, match="NaN"):
        model.predict(np.full((2, len(model.variables)), np.nan))


def test_model_clamps_outside_the_identified_box(result):
    model = result.results["CZ"].model
    lo, hi = np.array(model.scaling.lower), np.array(model.scaling.upper)
    far = (hi + 10 * (hi - lo))[None, :]
    edge = hi[None, :]
    assert model.predict(far) == pytest.approx(model.predict(edge))
    assert np.isnan(model.predict(far, outside="nan")[0])


def test_loading_a_plain_spline_file_is_refused(result, tmp_path):
    path = result.results["CZ"].model.spline.save(tmp_path / "plain.json")
    with pytest.raises(ModelFileError, match="without an aerodynamic model description"):
        AeroModel.load(path)


def test_unknown_variable_is_named(table):
    settings = IdentificationSettings(
        coefficients=("CZ",), structures={"CZ": Structure("CZ", ("alpha", "elevator"))},
        select=False)
    with pytest.raises(InputError, match=r"unknown variable\(s\) \['elevator'\]"):
        identify(table, settings=settings)


def test_nan_in_a_maneuver_is_reported(table):
    bad = table.copy()
    bad.loc[bad.index[bad["maneuver"] == 4][10], "alpha"] = np.nan
    with pytest.raises(FlightDataError, match=r"NaN or inf in column\(s\) \['alpha'\].*"
                                              r"maneuver\(s\) \[4\]"):
        identify(bad, settings=IdentificationSettings(coefficients=("CZ",), select=False))


def test_one_maneuver_cannot_be_validated(table):
    one = table[table["maneuver"] == 0]
    with pytest.raises(InputError, match="at least two"):
        identify(one, settings=IdentificationSettings(coefficients=("CZ",), select=False))


def test_missing_coefficient_columns_without_reconstruction(table):
    with pytest.raises(FlightDataError, match="reconstruct='never'"):
        identify(table.drop(columns=["Cm"]),
                 settings=IdentificationSettings(reconstruct="never", select=False))


def test_thin_simplices_warn(table):
    s = Structure("CZ", ("alpha", "de", "mach"), 3, 1, (3, 3, 3))
    settings = IdentificationSettings(coefficients=("CZ",), structures={"CZ": s},
                                      select=False, thin_factor=50.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = identify(table, settings=settings)
    assert any(issubclass(w.category, ThinDataWarning) for w in caught)
    assert len(res.results["CZ"].thin) > 0 and res.warnings


@pytest.mark.parametrize("change, match", [
    ({"thin_factor": float("-inf")}, "thin_factor must be a finite number >= 0"),
    ({"thin_factor": float("nan")}, "thin_factor must be a finite number >= 0"),
    ({"seed": -1}, "seed must be an integer between 0 and"),
    ({"seed": 1.5}, "seed must be an integer between 0 and"),
    ({"workers": 0}, "workers must be an integer >= 1 or None"),
    ({"derivative_folds": 1}, "derivative_folds must be 0 .no standard errors. or an integer"),
    ({"derivative_folds": -2}, "derivative_folds must be 0"),
    ({"derivative_folds": 2.5}, "derivative_folds must be 0"),
    ({"matched_regressors": "yes"}, "matched_regressors must be true or false"),
])
def test_settings_are_validated_before_any_work(change, match):
    """Bad settings fail when the settings are made, not after the whole run."""
    with pytest.raises(InputError, match=match):
        IdentificationSettings(**change)


def test_parallel_coefficients_equal_the_serial_run(table):
    """The coefficients' searches run in worker processes: the same models as in one."""
    settings = IdentificationSettings(coefficients=("CY", "Cm"), selection=FAST, workers=1)
    serial = identify(table, settings=settings)
    parallel = identify(table, settings=replace(settings, workers=2))
    for c in ("CY", "Cm"):
        assert parallel.results[c].structure == serial.results[c].structure
        assert np.array_equal(parallel.results[c].model.spline.coefficients,
                              serial.results[c].model.spline.coefficients)
        assert np.array_equal(parallel.validation[f"model_{c}"], serial.validation[f"model_{c}"])
    assert parallel.warnings == serial.warnings


def test_coefficients_the_data_cannot_give_are_left_out_and_said(table):
    """No accelerometers: the reconstruction leaves the force coefficients NaN; the
    moments are still identified, and the summary says what was left out."""
    no_forces = table.copy()
    for c in ("CX", "CY", "CZ"):
        no_forces[c] = np.nan
    res = identify(no_forces, settings=IdentificationSettings(select=False, workers=1))
    assert set(res.results) == {"Cl", "Cm", "Cn"}
    assert sum("CX is not in the data" in w for w in res.warnings) == 1
    # asked for by name, a missing coefficient is an error, not a silent omission
    with pytest.raises(FlightDataError, match=r"NaN or inf in column\(s\) \['CX'\]"):
        identify(no_forces, settings=IdentificationSettings(
            coefficients=("CX", "Cm"), structures={"CX": Structure("CX", ("alpha",))},
            select=False))


def test_thrust_left_in_cx_is_said_with_what_the_search_was_offered(table):
    """Coefficients reconstructed without thrust (metadata ``reconstruction.thrust`` =
    'included'): the summary says CX holds it and Cm its moment (when either is modelled),
    and whether the fuel flow's tc_ff was offered; thrust subtracted, nothing is said."""
    settings = IdentificationSettings(coefficients=("CX",), select=False, workers=1)
    meta = {**table.attrs, "S": 30.0, "reconstruction": {"thrust": "included"}}
    res = identify(table, meta, settings=settings)
    assert sum("hold no fuel flow or fan speed: they cannot follow the throttle" in w
               and w.startswith("CX holds the thrust and Cm its pitching moment")
               for w in res.warnings) == 1
    pitch = identify(table, meta, settings=replace(settings, coefficients=("Cm",)))
    assert sum("Cm its pitching moment" in w for w in pitch.warnings) == 1
    lateral = identify(table, meta, settings=replace(settings, coefficients=("Cl",)))
    assert not any("holds the thrust" in w for w in lateral.warnings)
    fan = table.assign(n1=0.7 + 0.01 * (table["maneuver"] % 5))
    res = identify(fan, meta, settings=settings)
    assert sum("offered the fan-speed thrust coefficient tc_n1" in w
               for w in res.warnings) == 1
    flow = table.assign(fuel_flow=0.3 + 0.01 * table["maneuver"] % 7)
    res = identify(flow, meta, settings=settings)            # no density: no tc_ff
    assert sum("tc_ff also needs rho" in w for w in res.warnings) == 1
    flow["rho"] = 0.9
    res = identify(flow, meta, settings=settings)
    assert sum("offered the fuel-flow thrust coefficient tc_ff" in w
               for w in res.warnings) == 1
    assert "tc_ff" in res.identification.columns
    res = identify(flow.assign(n1=fan["n1"]), meta, settings=settings)
    assert sum("tc_ff = fuel_flow * 4e4 m/s / (qbar S) and the fan-speed thrust coefficient "
               "tc_n1" in w for w in res.warnings) == 1
    assert {"tc_ff", "tc_n1"} <= set(res.identification.columns)
    meta["reconstruction"]["thrust"] = "columns"
    res = identify(flow, meta, settings=settings)
    assert not any("holds the thrust" in w for w in res.warnings)


def test_a_validation_outside_the_identification_data_is_said(table):
    """Two maneuvers at angles of attack that do not overlap: whichever is held out lies
    outside the other's coverage; the scores are still given, with a warning that they
    measure extrapolation and which maneuver leaves the coverage."""
    first, second = sorted(table["maneuver"].unique())[:2]
    two = table[table["maneuver"].isin([first, second])].copy()
    shift = two["alpha"].max() - two["alpha"].min() + 0.2
    two.loc[two["maneuver"] == second, "alpha"] += shift
    settings = IdentificationSettings(coefficients=("CZ",), select=False,
                                      validation_fraction=0.5,
                                      structures={"CZ": Structure("CZ", ("alpha",))})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = identify(two, settings=settings)
    messages = [str(w.message) for w in caught if issubclass(w.category, ThinDataWarning)]
    assert any(re.search(r"CZ: only 0\.0 % of the validation samples lie inside the "
                         r"identification data's coverage \(maneuvers \[\d+\] leave it\), "
                         r"scored on all of them", m) for m in messages), messages
    assert res.results["CZ"].validation["coverage"] == 0.0
    assert any("measure extrapolation" in w for w in res.warnings)


def test_validation_maneuvers_stay_inside_the_mass_range_of_identification(table,
                                                                         monkeypatch):
    """Fuel burns over the flight: the first maneuver is the heaviest, the last the
    lightest. A model with the mass as a variable is validated inside its identified mass
    range, on a seed whose split without that rule held out the first or the last
    maneuver."""
    data = table.copy()
    rng = np.random.default_rng(3)
    data["alpha"] = rng.uniform(0.0, 0.2, len(data))   # one envelope for all maneuvers
    data["mach"] = 0.5
    data["true_CZ"] = true_cz(*(data[v].to_numpy() for v in ("alpha", "de", "mach", "qhat")))
    data["CZ"] = data["true_CZ"] + 2e-3 * rng.standard_normal(len(data))
    data["mass"] = 9000.0 - 0.05 * np.arange(len(data))
    ends = {data["maneuver"].min(), data["maneuver"].max()}
    settings = IdentificationSettings(coefficients=("CZ",), select=False,
                                      structures={"CZ": Structure("CZ", ("alpha", "mass"))})

    def held(seed):
        res = identify(data, settings=replace(settings, seed=seed))
        return res, set(res.validation["maneuver"].unique())

    with monkeypatch.context() as m:
        m.setattr(importlib.import_module("simplexspline.aero.identify"),
                  "TEST_POINT_VARIABLES", ())
        seed = next(s for s in range(20) if ends & held(s)[1])
    res, validated = held(seed)
    assert validated and not ends & validated
    mass, ident = res.validation["mass"], res.identification["mass"]
    assert mass.min() >= ident.min() and mass.max() <= ident.max()


def test_a_flow_angle_rate_is_not_offered_to_the_force_that_makes_it(table):
    """alpha' holds Z/m by the equations of motion: a column alphadot_hat that is (a noisy
    copy of) CZ itself would explain CZ without alpha. The search never tries it for CZ
    (nor betadot_hat for CY), and still does for Cm."""
    from simplexspline.aero.variables import RATES_OF_FORCES

    rng = np.random.default_rng(0)
    cols = {c: table[c].to_numpy() for c in ("alpha", "de", "mach", "qhat", "beta")}
    cols["alphadot_hat"] = table["CZ"].to_numpy() + rng.normal(0, 1e-4, len(table))
    cols["betadot_hat"] = table["CY"].to_numpy() + rng.normal(0, 1e-4, len(table))
    settings = replace(FAST, max_rounds=1)
    for coefficient, start, rate in (("CZ", ("alpha", "de"), "alphadot_hat"),
                                     ("CY", ("beta",), "betadot_hat"),
                                     ("Cm", ("alpha", "de"), "alphadot_hat")):
        assert (coefficient in RATES_OF_FORCES[rate]) == (coefficient != "Cm")
        _best, history = select_structure(Structure(coefficient, start), cols,
                                          table[coefficient].to_numpy(),
                                          table["maneuver"].to_numpy(), settings)
        tried = any(rate in t.structure.label() for t in history)
        assert tried == (coefficient == "Cm"), coefficient


def test_a_model_without_its_flow_angle_says_the_slope_along_it_is_not_identified(
        table, tmp_path, capsys):
    """Along a stationary series alpha, Mach and the elevator move together: a CZ model
    on Mach alone fits, and its derivative along alpha is 0. identify names alpha as not
    identified (not zero) when the data cannot tell it from the model's variables, and
    says nothing when they can."""
    rng = np.random.default_rng(3)
    tied = table.copy()
    tied["mach"] = 0.5 - 0.8 * tied["alpha"] + rng.normal(0, 1e-3, len(tied))
    fixed = {"CZ": Structure("CZ", ("mach",), degree=2, continuity=1)}
    settings = IdentificationSettings(coefficients=("CZ",), structures=fixed, select=False)
    with pytest.warns(UserWarning, match="does not take alpha"):
        res = identify(tied, settings=settings)
    entry = res.results["CZ"].diagnostics["flow_angle_left_out"]
    assert entry["variable"] == "alpha" and entry["partner"] == "mach"
    assert entry["vif"] > 10 and not entry["separable"]
    # the model file keeps it, and the derivatives command says its CZ_alpha is not a
    # measurement
    from simplexspline.cli import main

    path = res.results["CZ"].model.save(tmp_path / "CZ.json")
    assert main(["derivatives", str(path), "-o", str(tmp_path / "d.csv"),
                 "--alpha=0.05,0.1"]) == 0
    assert "CZ_alpha is not identified" in capsys.readouterr().out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        free = identify(table, settings=settings)
    assert "flow_angle_left_out" not in free.results["CZ"].diagnostics
    assert not any("does not take alpha" in w for w in free.warnings)


def test_a_coefficient_no_validation_maneuver_can_excite_is_validated_by_leaving_one_out(
        table, tmp_path):
    """Cm (pitch damping) moves only in maneuvers 0 and 1, flown at angles of attack nobody
    else flies (the coverage rule keeps both for identification); the validation
    maneuvers barely move it (R^2 about 0, the noise). Maneuver 0, which moves it most, is
    validated by leaving it out: a model of the same structure identified without it
    predicts it, the validation scores hold that (R^2 well above 0), the shared part is
    kept apart, and the model delivered is identified on maneuver 0 too. CZ, excited in
    the validation, gets none."""
    data = table.copy()
    man = data["maneuver"].to_numpy()
    data.loc[man < 2, "alpha"] += 0.6
    data["qhat"] *= np.select([man == 0, man == 1], [1.0, 0.6], 0.005)
    rng = np.random.default_rng(3)
    data["true_Cm"] = 0.01 - 8.0 * data["qhat"]
    data["Cm"] = data["true_Cm"] + 1e-3 * rng.standard_normal(len(data))
    settings = IdentificationSettings(
        coefficients=("CZ", "Cm"), select=False, workers=1,
        structures={"CZ": Structure("CZ", ("alpha", "de", "mach")),
                    "Cm": Structure("Cm", ("alpha",), 1, 0, (1,), ("1", "de", "qhat"))})
    res = identify(data, settings=settings)
    assert not set(np.unique(res.validation["maneuver"])) & {0, 1}
    assert res.left_out_validation == {"Cm": 0}
    v = res.results["Cm"].validation
    assert v["left_out"]["maneuver"] == 0 and v["left_out"]["n"] == int((man == 0).sum())
    assert v["shared"]["r2"] < 0.2 < 0.9 < v["left_out"]["r2"]
    assert v["r2"] > 0.9 and v["n"] == v["shared"]["n"] + v["left_out"]["n"]
    # the delivered model knows maneuver 0; the figure against the truth of the shared
    # part is the delivered model's
    assert res.results["Cm"].counts.sum() == len(res.identification)
    assert res.results["CZ"].counts.sum() == len(res.identification)
    assert v["shared"]["rms_true_over_noise"] < 1.0
    assert "left_out" not in res.results["CZ"].validation
    summary = res.summary()
    assert summary["left_out_validation_maneuvers"] == {"Cm": 0}
    assert summary["coefficients"]["Cm"]["left_out"]["maneuver"] == 0
    note = [w for w in res.warnings if "validated by leaving it out" in w]
    assert len(note) == 1 and note[0].startswith("Cm: the validation maneuvers barely "
                                                 "excite it")
    assert not any(w.startswith("Cm is barely excited") for w in res.warnings)
    # the report says which scores hold the left-out maneuver
    pytest.importorskip("matplotlib")
    from simplexspline.aero.report.page import write_report

    page = write_report(res, tmp_path / "report", workers=1)
    text = (page.parent / "report.md").read_text()
    assert "include maneuver 0, validated by leaving it out" in text


def test_a_search_that_cannot_score_where_the_coefficient_moves_starts_linear(table):
    """Cm moves (pitch damping) only in maneuver 0, flown at angles of attack no other
    maneuver flies: the search's cross-validation cannot score it, so the search starts
    from the linear model of Cm's terms instead of the scheduled start, tries no hinge
    basis (its knots would be placed on maneuver 0, which nothing judges), and says so."""
    from simplexspline.aero.modelling.auto import linear_start

    data = table.copy()
    man = data["maneuver"].to_numpy()
    data.loc[man == 0, "alpha"] += 0.6
    data["qhat"] *= np.where(man == 0, 5.0, 0.05)
    rng = np.random.default_rng(2)
    data["true_Cm"] = 0.01 + 0.02 * data["de"] - 8.0 * data["qhat"]
    data["Cm"] = data["true_Cm"] + 1e-3 * rng.standard_normal(len(data))
    start = Structure("Cm", ("alpha", "mach"), 3, 1, (3, 1), ("1", "qhat", "de"))
    res = identify(data, settings=IdentificationSettings(
        coefficients=("Cm",), structures={"Cm": start}, selection=FAST, workers=1))
    assert 0 in set(res.identification["maneuver"])
    first = res.results["Cm"].history[0].structure
    assert (first.degree, first.resolution) == (0, (1,))
    note = [w for w in res.warnings if "scored none of the maneuvers" in w]
    assert len(note) == 1 and note[0].startswith("Cm: ") and "(0 (" in note[0]
    assert "started from the linear model of its terms, kept them" in note[0]
    assert "without the hinge start" in note[0]
    # the cross-validation cannot judge removing the terms that only maneuver 0 moves,
    # nor their change across the envelope, nor what a new term takes from them: every
    # structure tried keeps the linear start's terms with constant coefficients, and no
    # term of the pitch rate (which only maneuver 0 moves) is offered
    assert first == linear_start(start, constant=True)
    kept = set(first.multipliers)
    assert {"qhat[]", "de[]"} <= kept
    for trial in res.results["Cm"].history:
        assert kept <= set(trial.structure.multipliers), trial.move
        assert not trial.move.startswith("remove multiplier"), trial.move
        assert not (trial.move.startswith(("add multiplier", "schedule on"))
                    and "qhat" in trial.move), trial.move
    final = res.results["Cm"].model.structure
    assert kept <= set(final.multipliers)
    assert FAST.hinge_start
    assert not [t.move for t in res.results["Cm"].history if "hinge start" in t.move]
    # the same data with Cm moving everywhere: the scheduled start is kept, and the
    # hinge start is tried
    data["qhat"] = table["qhat"]
    data["true_Cm"] = 0.01 + 0.02 * data["de"] - 8.0 * data["qhat"]
    data["Cm"] = data["true_Cm"] + 1e-3 * rng.standard_normal(len(data))
    res = identify(data, settings=IdentificationSettings(
        coefficients=("Cm",), structures={"Cm": start}, selection=FAST, workers=1))
    assert res.results["Cm"].history[0].structure == start
    assert [t.move for t in res.results["Cm"].history if "hinge start" in t.move]
    assert not any("scored none" in w for w in res.warnings)


def test_a_vane_scale_neither_given_nor_estimated_is_said():
    """Turbulence in every maneuver holds the angle-of-attack vane's scale at 1: the note
    names it and what it costs (the slopes along alpha); not when the mapping gives the
    scale, the campaign estimated it, one maneuver estimated it, or no longitudinal
    coefficient is modelled."""
    import pandas as pd

    data = pd.DataFrame({"alpha": np.linspace(0.0, 0.1, 5)})
    turb = ("not estimated in turbulence (gusts in this maneuver): confounded with the "
            "gusts; held at the given calibration")
    record = {"maneuvers": {"1": {"held": {"kalpha": turb}}, "2": {"held": {"kalpha": turb}}},
              "air_data_calibration": {"balpha": [0.01, 0.001]}}
    note = _vane_scale_note(data, IdentificationSettings(), {}, {"record": record})
    assert re.match(r"the angle-of-attack vane's scale factor is neither given .*\(held at 1 "
                    r"in every maneuver: not estimated in turbulence\): alpha, and every "
                    r"derivative along it \(CL_alpha, Cm_alpha\)", note), note
    # already reconstructed data: the record in the metadata
    assert _vane_scale_note(data, IdentificationSettings(), {"reconstruction": record}) == note
    given = {"sensor_geometry": {"alpha_vane": {"scale": 1.04}}}
    assert _vane_scale_note(data, IdentificationSettings(), given, {"record": record}) == ""
    campaign = {**record, "air_data_calibration": {"kalpha": [0.04, 0.005]}}
    assert _vane_scale_note(data, IdentificationSettings(), {}, {"record": campaign}) == ""
    one = {**record, "maneuvers": {**record["maneuvers"], "3": {"held": {}}}}
    assert _vane_scale_note(data, IdentificationSettings(), {}, {"record": one}) == ""
    lateral = IdentificationSettings(coefficients=("CY", "Cl", "Cn"))
    assert _vane_scale_note(data, lateral, {}, {"record": record}) == ""
    assert _vane_scale_note(data.rename(columns={"alpha": "a"}), IdentificationSettings(), {},
                            {"record": record}) == ""
    assert _vane_scale_note(data, IdentificationSettings(), {}) == ""     # no record


def test_an_imported_record_without_the_imu_position_is_told_what_it_costs():
    """The side force's lever-arm part per metre along x is m (r' + p q) / (qbar S), the
    normal force's m (p r - q') / (qbar S): the note gives their RMS (here exactly 2e-3
    and 4e-3 per metre: constant columns), only for an imported record whose metadata does
    not place the IMU, and only for the force coefficients modelled."""
    import pandas as pd

    n = 50
    data = pd.DataFrame({"mass": 1000.0, "rho": 1.0, "tas": 100.0, "p": 0.0, "q": 0.0,
                         "r": 0.0, "pdot": 0.0, "rdot": np.full(n, 0.1),
                         "CY": np.linspace(-0.05, 0.05, n)})
    meta = {"S": 10.0, "import": {}}        # qbar S = 5e4 N: 1000 kg * 0.1 / 5e4 = 2e-3
    note = _imu_position_note(data, IdentificationSettings(), meta)
    assert re.match(r"the accelerometers' position is not given .* along x moves CY by "
                    r"2\.0e-03 RMS in these data \(0\.07 of CY's own spread\), along z by "
                    r"0\.0e\+00", note), note
    assert "give [metadata.sensor_geometry.imu] position_m" in note
    given = {**meta, "sensor_geometry": {"imu": {"position_m": [0.6, 0.0, 0.2]}}}
    assert _imu_position_note(data, IdentificationSettings(), given) == ""
    assert _imu_position_note(data, IdentificationSettings(), {"S": 10.0}) == ""   # simulated
    assert _imu_position_note(data, IdentificationSettings(coefficients=("CX", "Cm")),
                              meta) == ""
    assert _imu_position_note(data.drop(columns="rdot"), IdentificationSettings(), meta) == ""
    # the normal force: m (p r - q') / (qbar S) per metre along x, -m (p^2 + q^2) along z
    pitch = data.assign(qdot=np.full(n, 0.2), q=np.full(n, 0.1), CZ=np.linspace(-0.5, 0.0, n))
    both = _imu_position_note(pitch, IdentificationSettings(), meta)
    assert re.search(r"along x moves CY by 2\.0e-03 RMS .*; along x CZ by 4\.0e-03 RMS in "
                     r"these data \(0\.03 of CZ's own spread\), along z by 2\.0e-04; ", both), both
    assert "normal-force model takes it into its alpha, pitch-rate and elevator" in both
    only = _imu_position_note(pitch, IdentificationSettings(coefficients=("CZ", "Cm")), meta)
    assert "moves CZ by 4.0e-03" in only and "CY" not in only, only
    assert _imu_position_note(pitch.drop(columns="qdot"),
                              IdentificationSettings(coefficients=("CZ",)), meta) == ""


def test_a_doublet_scored_only_in_its_trimmed_lead_in_counts_as_unscored():
    """A doublet whose trimmed lead-in shares a cell with the other maneuvers and whose
    response leaves it: half its samples are scored, almost none of its variation. By
    variation it is untested, and the search starts linear (the Cessna course's one
    elevator doublet: 15 % of samples, 0.2 % of the pitching moment's variation)."""
    from simplexspline.aero.identify import _untested
    from simplexspline.aero.selection.search import cv_scored_share

    rng = np.random.default_rng(1)
    man = np.repeat([0, 1, 2, 3], 60)
    cells = np.zeros(240, dtype=int)
    y = rng.normal(0.0, 1e-4, 240)
    doublet = man == 3
    response = np.flatnonzero(doublet)[30:]           # the second half moves
    cells[response] = 5                               # ... and leaves the shared cell
    y[response] += 5e-3 * np.sin(np.linspace(0.0, 2 * np.pi, 30))
    cols = {"alpha": rng.normal(size=240)}
    settings = SelectionSettings(folds=4)
    by_samples = cv_scored_share(cols, y, man, settings, seed=0, cells=cells)
    by_variation = cv_scored_share(cols, y, man, settings, seed=0, cells=cells,
                                   by="variation")
    assert by_samples[3] == pytest.approx(0.5)
    assert by_variation[3] < 0.01
    assert by_variation[0] == by_samples[0] == 1.0    # the others: all of them either way
    assert _untested(y, man, by_samples) == []
    assert _untested(y, man, by_variation) == [3]
    # a constant coefficient: its samples' share
    flat = cv_scored_share(cols, np.ones(240), man, settings, seed=0, cells=cells,
                           by="variation")
    assert flat[3] == pytest.approx(0.5)
    with pytest.raises(InputError, match="by must be 'samples' or 'variation'"):
        cv_scored_share(cols, y, man, settings, cells=cells, by="energy")


def test_the_unscored_search_is_offered_only_variables_that_scored_maneuvers_move():
    """_scored_candidates: a variable that only an unscored maneuver moves is not offered
    (its terms would be judged where it does not move); the others, and variables absent
    from the data, stay."""
    from simplexspline.aero.identify import _scored_candidates

    man = np.repeat([0, 1, 2, 3], 40)
    cells = np.repeat([3, 3, 3, 11], 40)          # maneuver 3 alone in its cells
    rng = np.random.default_rng(1)
    cols = {"alpha": rng.normal(size=160),
            "alphadot_hat": np.concatenate([1e-4 * rng.normal(size=120),
                                            1e-2 * rng.normal(size=40)])}
    settings = SelectionSettings(folds=3, candidates=("alpha", "alphadot_hat", "beta"))
    assert _scored_candidates(cols, man, settings, 0, cells) == ("alpha", "beta")


def test_a_coefficient_whose_exciting_maneuvers_the_search_never_scored_is_named():
    """Three maneuvers, each alone in its envelope cells: the search's cross-validation
    scores none of them (cv_scored_share 0); the two that move the coefficient most are
    untested, and the note names them with their types and the structure chosen. Where
    one of them is scored, nothing is untested."""
    from simplexspline.aero.identify import _unscored_note, _untested
    from simplexspline.aero.selection.search import cv_scored_share

    man = np.repeat([0, 1, 2], 40)
    cells = np.repeat([3, 7, 11], 40)                 # disjoint cells: nothing covered
    rng = np.random.default_rng(0)
    y = rng.normal(0.0, [1e-4] * 40 + [5e-3] * 40 + [4e-3] * 40)
    cols = {"alpha": rng.normal(size=120)}
    shares = cv_scored_share(cols, y, man, SelectionSettings(folds=3), seed=0, cells=cells)
    assert shares == {0: 0.0, 1: 0.0, 2: 0.0}
    assert _untested(y, man, shares) == [1, 2]
    assert _untested(y, man, {**shares, 2: 0.5}) == []
    assert _untested(y, man, {}) == []
    types = np.repeat(["steady", "pulse-rudder", "doublet-rudder"], 40)
    best = Structure("CY", ("alpha",), degree=1, continuity=0, resolution=(1,))
    note = _unscored_note("CY", best, [1, 2], types, man)
    assert note.startswith("CY: the structure search's cross-validation scored none of the "
                           "maneuvers that excite it most (1 (pulse-rudder), 2 "
                           "(doublet-rudder))"), note
    assert ("started from the linear model of its terms, kept them with constant "
            "coefficients (nothing could test their removal or their change across the "
            "envelope), offered only the variables that scored maneuvers move, and chose "
            "CY(alpha) S^0_1") in note
    assert "without the hinge start" in note
    # a shared cell: the maneuvers cover each other and are scored
    both = cv_scored_share(cols, y, man, SelectionSettings(folds=3), seed=0,
                           cells=np.zeros(120, dtype=int))
    assert all(v == 1.0 for v in both.values())
    assert _untested(y, man, both) == []


def test_a_failing_jackknife_is_said_and_the_models_stand(table, monkeypatch):
    identify_module = importlib.import_module("simplexspline.aero.identify")

    def broken(*args, **kwargs):
        raise InputError("a broken refit")

    monkeypatch.setattr(identify_module, "jackknife_derivatives", broken)
    res = identify(table, settings=IdentificationSettings(coefficients=("Cm",),
                                                          selection=FAST))
    assert res.derivatives is None and "Cm" in res.results
    assert any("standard errors could not be computed (a broken refit)" in w
               for w in res.warnings)


def _pulsed_10_hz_table(seed: int = 0):
    """12 maneuvers at 10 Hz with elevator pulses of 0.3-1 s and a linear pitching moment,
    whose measurement is the sample derivative of its exact integral (what the
    reconstruction makes of 10 Hz pitch rates: ``K * Cm``, not ``Cm``)."""
    from simplexspline.aero.data.differentiation import sample_derivative
    from .synthetic import true_cm

    df = synthetic_table(n_maneuvers=12, samples=300, seed=seed, noise=0.0)
    df["t"] = df["t"] * 10.0
    rng = np.random.default_rng(seed)
    for _m, idx in df.groupby("maneuver").groups.items():
        n = len(idx)
        de = np.zeros(n)
        k = 10
        while k < n - 10:
            width = int(rng.integers(3, 10))
            de[k:k + width] = rng.choice([-1.0, 1.0]) * rng.uniform(0.02, 0.06)
            k += width + int(rng.integers(3, 10))
        alpha, qhat = df.loc[idx, "alpha"].to_numpy(), df.loc[idx, "qhat"].to_numpy()
        cm = true_cm(alpha, de, qhat) - 2.0 * alpha ** 2          # linear in its terms
        integral = np.r_[0.0, np.cumsum(0.05 * (cm[1:] + cm[:-1]))]
        df.loc[idx, "de"] = de
        df.loc[idx, "true_Cm"] = cm
        df.loc[idx, "Cm"] = sample_derivative(integral, 0.1, 2, 4) \
            + 1e-4 * rng.standard_normal(n)
    return df


def test_moment_regressors_are_smoothed_as_the_differentiated_accelerations():
    """With ``matched_regressors`` and differentiated angular accelerations (the
    reconstruction's record says so) the moment coefficients' regressors are smoothed as the
    derivative smoothed the moment: on elevator pulses at 10 Hz, Cm_de is recovered to
    0.1 % (-1.2) and the model matches the instantaneous truth to 1e-5; taken as measured,
    or without the setting, the instantaneous regressors give a Cm_de 5 % low and errors
    against the truth 100 times larger."""
    df = _pulsed_10_hz_table()
    s = Structure("Cm", variables=("alpha",), degree=1, continuity=0, resolution=(1,),
                  multipliers=("1", "de", "qhat"))
    settings = IdentificationSettings(coefficients=("Cm",), structures={"Cm": s},
                                      select=False, reconstruct="never",
                                      matched_regressors=True)
    at = {"alpha": [0.1, 0.1], "de": [0.0, 0.01], "qhat": [0.0, 0.0]}
    slope, truth = {}, {}
    for acc, matched in (("differentiated", True), ("measured", True),
                         ("differentiated", False)):
        meta = {**df.attrs, "reconstruction": {"accelerations": acc, "settings": {
            "diff_half_window": None, "diff_degree": 4}}}
        res = identify(df, meta, settings=replace(settings, matched_regressors=matched))
        p = res.results["Cm"].model.predict(at)
        slope[acc, matched] = (p[1] - p[0]) / 0.01
        truth[acc, matched] = res.results["Cm"].validation["rms_true"]
    assert slope["differentiated", True] == pytest.approx(-1.2, rel=1e-3)
    assert truth["differentiated", True] < 1e-5
    for off in (("measured", True), ("differentiated", False)):
        assert slope[off] > -1.2 * 0.97 and truth[off] > 100 * truth["differentiated", True]
