"""Stability and control derivatives from identified models with known truth."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from simplexspline.aero.derivatives.plots import plot_derivative_map, plot_derivatives
from simplexspline.aero.selection.search import PLAIN_FIT
from simplexspline.aero.derivatives.stability import (
    condition_grid,
    derivative_name,
    derivative_unit,
    derivatives,
    load_models,
    reference_conditions,
)
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.aero.selection.search import fit_structure
from simplexspline.aero.modelling.structure import Structure
from simplexspline.cli import main
from simplexspline.errors import InputError, ModelFileError, OutsideDomainError

A = (0.1, -4.5, 2.0, -0.6)          # CZ = a0 + a1 alpha + a2 alpha^2 mach + a3 de
B, CBAR = 9.0, 3.5                  # geometry [m]


def cz_true(alpha, mach, de):
    return A[0] + A[1] * alpha + A[2] * alpha**2 * mach + A[3] * de


def cm_true(alpha, q, de):          # q in rad/s (a model in dimensional rates)
    return 0.02 - 0.5 * alpha - 0.1 * q - 1.2 * de + 0.8 * alpha**2 + 0.5 * alpha * q**2


def cl_true(beta, phat, da):        # phat = p b / 2V (non-dimensional)
    return -0.08 * beta - 0.4 * phat + 0.05 * da + 0.3 * beta * phat


def cn_true(alpha, beta):           # not a polynomial: the spline only approximates it
    return np.sin(3.0 * alpha) * beta + 0.2 * np.tanh(5.0 * beta)


def _data(n=3000, seed=0):
    rng = np.random.default_rng(seed)
    return {"alpha": rng.uniform(-0.1, 0.3, n), "mach": rng.uniform(0.3, 0.8, n),
            "de": rng.uniform(-0.2, 0.2, n), "q": rng.uniform(-0.4, 0.4, n),
            "beta": rng.uniform(-0.1, 0.1, n), "phat": rng.uniform(-0.02, 0.02, n),
            "da": rng.uniform(-0.2, 0.2, n)}


@pytest.fixture(scope="module")
def models():
    d = _data()
    fit = replace(PLAIN_FIT, ridge=0.0, min_points=1)
    return {
        "CZ": fit_structure(Structure("CZ", ("alpha", "mach", "de"), 3, 1, (2, 2, 1)), d,
                            cz_true(d["alpha"], d["mach"], d["de"]), fit),
        "Cl": fit_structure(Structure("Cl", ("beta", "phat", "da"), 3, 1), d,
                            cl_true(d["beta"], d["phat"], d["da"]), fit),
        "Cm": fit_structure(Structure("Cm", ("alpha", "q", "de"), 3, 1), d,
                            cm_true(d["alpha"], d["q"], d["de"]), fit),
    }


@pytest.fixture(scope="module")
def cn_model():
    d = _data(6000, seed=1)
    return fit_structure(Structure("Cn", ("alpha", "beta"), 3, 1, (4, 4)), d,
                         cn_true(d["alpha"], d["beta"]), replace(PLAIN_FIT, ridge=0.0,
                                                                 min_points=1))


@pytest.fixture(scope="module")
def model_dir(models, tmp_path_factory):
    out = tmp_path_factory.mktemp("ident") / "out"
    (out / "models").mkdir(parents=True)
    for c, m in models.items():
        m.save(out / "models" / f"{c}.json")
    (out / "summary.json").write_text("{}")
    return out


# ---------------------------------------------------------------------------- truth
def test_derivatives_equal_the_analytic_partials(models):
    alpha = np.linspace(-0.09, 0.29, 9)
    mach = np.array([0.35, 0.55, 0.75])
    t = derivatives(models["CZ"], {"alpha": alpha, "mach": mach, "de": 0.05})
    assert len(t) == 27 and t["inside_CZ"].all()
    a, m = t["alpha"].to_numpy(), t["mach"].to_numpy()
    np.testing.assert_allclose(t["CZ_alpha"], A[1] + 2 * A[2] * a * m, atol=1e-9)
    np.testing.assert_allclose(t["CZ_mach"], A[2] * a**2, atol=1e-9)
    np.testing.assert_allclose(t["CZ_de"], A[3], atol=1e-9)
    assert set(t.columns) == {"alpha", "mach", "de", "CZ_alpha", "CZ_mach", "CZ_de",
                              "inside_CZ", "samples_CZ"}
    # data support: the identification samples of the simplex holding each condition
    model = models["CZ"]
    sid = model.spline.triangulation.locate(model.scaling.transform(
        t[["alpha", "mach", "de"]].to_numpy()))
    counts = np.asarray(model.provenance["counts"])
    assert np.array_equal(t["samples_CZ"], counts[sid]) and counts.sum() == 3000


def test_lift_curve_and_drag_slopes_from_the_body_axis_models():
    """CL_alpha and CD_alpha from CX and CZ models of a known lift and drag polar
    (CL = 0.2 + 4.5 alpha, CD = 0.02 + 0.6 alpha^2, as body-axis forces)."""
    d = _data(4000, seed=3)
    a = d["alpha"]
    cl, cd = 0.2 + 4.5 * a, 0.02 + 0.6 * a**2
    cx, cz = cl * np.sin(a) - cd * np.cos(a), -cl * np.cos(a) - cd * np.sin(a)
    fit = replace(PLAIN_FIT, ridge=0.0, min_points=1)
    both = {c: fit_structure(Structure(c, ("alpha", "mach"), 5, 1, (4, 1)), d, y, fit)
            for c, y in (("CX", cx), ("CZ", cz))}
    grid = np.linspace(-0.05, 0.25, 7)
    t = derivatives(both, {"alpha": grid, "mach": 0.5})
    np.testing.assert_allclose(t["CL_alpha"], 4.5, atol=2e-4)
    np.testing.assert_allclose(t["CD_alpha"], 1.2 * grid, atol=2e-4)
    assert t["inside_CL"].all() and t.attrs["derivatives"]["CL_alpha"]["coefficient"] == "CL"
    assert "CL_alpha" not in derivatives(both["CZ"], {"alpha": grid, "mach": 0.5})
    assert "CL_alpha" not in derivatives(both, {"alpha": grid, "mach": 0.5}, wrt=["mach"])


def test_chain_rule_through_the_scaling_matches_finite_differences(cn_model):
    """Exact gradient (unit-box gradient / span) == central differences of predict, at
    points spread over 16 x 2 simplices of a non-polynomial fit."""
    rng = np.random.default_rng(5)
    x = np.column_stack([rng.uniform(-0.09, 0.29, 200), rng.uniform(-0.09, 0.09, 200)])
    t = derivatives(cn_model, pd.DataFrame(x, columns=["alpha", "beta"]))
    h = 1e-6
    for i, name in enumerate(("Cn_alpha", "Cn_beta")):
        e = np.zeros(2)
        e[i] = h
        fd = (cn_model.predict(x + e, outside="nan") - cn_model.predict(x - e, outside="nan"))
        np.testing.assert_allclose(t[name], fd / (2 * h), rtol=1e-5, atol=1e-6)
    # the spans differ by 2x: a wrong chain rule would be off by that factor
    assert np.ptp(cn_model.scaling.span) > 0.1
    # and the fit is good enough that the derivatives approximate the analytic ones
    a, b = x[:, 0], x[:, 1]
    assert np.max(np.abs(t["Cn_beta"] - (np.sin(3 * a) + 1.0 / np.cosh(5 * b) ** 2))) < 0.05


def test_variables_outside_the_model_give_marked_zeros(models):
    t = derivatives(models, {"alpha": [0.0, 0.1, 0.5], "mach": 0.5}, wrt=["alpha", "beta"])
    info = t.attrs["derivatives"]
    assert info["CZ_beta"]["in_model"] is False and info["Cl_alpha"]["in_model"] is False
    assert info["Cl_beta"]["in_model"] is True and info["CZ_alpha"]["in_model"] is True
    inside = t["inside_CZ"].to_numpy()
    assert inside.tolist() == [True, True, False]           # alpha = 0.5 is outside
    assert np.all(t["CZ_beta"][inside] == 0.0)               # exactly 0, not NaN
    assert t["CZ_beta"].isna().tolist() == [False, False, True]  # undefined model: NaN
    assert np.all(t["Cl_alpha"] == 0.0) and t["inside_Cl"].all()
    long = derivatives(models, {"alpha": [0.0, 0.5], "mach": 0.5}, wrt=["alpha", "beta"],
                       layout="long")
    row = long[(long.derivative == "CZ_beta") & (long.point == 0)].iloc[0]
    assert row.value == 0.0 and not row.in_model and row.inside
    row = long[(long.derivative == "CZ_alpha") & (long.point == 1)].iloc[0]
    assert np.isnan(row.value) and row.in_model and not row.inside and row.samples == 0
    assert len(long) == 2 * 3 * 2


def test_outside_policies(models):
    at = pd.DataFrame({"alpha": [0.1, 0.4], "mach": [0.5, 0.5], "de": [0.0, 0.0]})
    nan = derivatives(models["CZ"], at)
    assert np.isfinite(nan["CZ_alpha"][0]) and np.isnan(nan["CZ_alpha"][1])
    ext = derivatives(models["CZ"], at, outside="extrapolate")
    # the fitted cubic is the global polynomial, so extrapolation reproduces it exactly
    np.testing.assert_allclose(ext["CZ_alpha"], A[1] + 2 * A[2] * at.alpha * 0.5, atol=1e-8)
    assert ext["inside_CZ"].tolist() == [True, False]
    with pytest.raises(OutsideDomainError, match=r"1 of 2 conditions lie outside the domain"
                       r".*first rows \[1\]"):
        derivatives(models["CZ"], at, outside="raise")
    with pytest.raises(InputError, match="outside must be one of.*clamped"):
        derivatives(models["CZ"], at, outside="clamp")


def test_rate_conversions(models):
    cm, cl = models["Cm"], models["Cl"]
    tas = np.array([120.0, 200.0, 250.0])
    at = pd.DataFrame({"alpha": 0.1, "q": 0.0, "de": 0.0, "beta": 0.02, "phat": 0.0,
                       "da": 0.0, "tas": tas})
    native = derivatives([cm, cl], at)
    assert {"Cm_q_dim", "Cl_p", "Cm_p", "Cl_q_dim"} <= set(native.columns)
    np.testing.assert_allclose(native["Cm_q_dim"], -0.1, atol=1e-9)
    np.testing.assert_allclose(native["Cl_p"], -0.4 + 0.3 * 0.02, atol=1e-9)
    geo = {"b": B, "cbar": CBAR}
    nd = derivatives([cm, cl], at, rates="nondimensional", geometry=geo)
    # qhat = q cbar / 2V  =>  dCm/dqhat = dCm/dq * 2V / cbar
    np.testing.assert_allclose(nd["Cm_q"], -0.1 * 2 * tas / CBAR, rtol=1e-9)
    np.testing.assert_allclose(nd["Cl_p"], native["Cl_p"], rtol=1e-12)
    assert nd.attrs["derivatives"]["Cm_q"]["unit"] == "-"
    dim = derivatives([cm, cl], at, rates="dimensional", geometry=geo)
    np.testing.assert_allclose(dim["Cl_p_dim"], (-0.4 + 0.3 * 0.02) * B / (2 * tas),
                               rtol=1e-9)
    np.testing.assert_allclose(dim["Cm_q_dim"], -0.1, atol=1e-9)
    assert dim.attrs["derivatives"]["Cl_p_dim"]["unit"] == "s/rad"
    # a condition given as qhat is converted to the model's q: dCm/dalpha = -0.5 + 1.6 a +
    # 0.5 q^2 with q = qhat 2V / cbar
    at2 = pd.DataFrame({"alpha": [0.1, 0.1], "qhat": [0.001, 0.002], "de": 0.0,
                        "tas": [200.0, 150.0]})
    t = derivatives(cm, at2, geometry=geo)
    q = at2.qhat * 2 * at2.tas / CBAR
    np.testing.assert_allclose(t["q"], q, rtol=1e-12)
    np.testing.assert_allclose(t["Cm_alpha"], -0.5 + 1.6 * 0.1 + 0.5 * q**2, atol=1e-9)


def test_rate_conversion_errors(models):
    at = pd.DataFrame({"alpha": [0.1], "q": [0.0], "de": [0.0]})
    with pytest.raises(InputError, match="Cm model needs the true airspeed.*tas"):
        derivatives(models["Cm"], at, rates="nondimensional", geometry={"cbar": CBAR})
    with pytest.raises(InputError, match="reference length cbar"):
        derivatives(models["Cm"], at.assign(tas=200.0), rates="nondimensional")
    with pytest.raises(InputError, match="geometry cbar must be a positive length"):
        derivatives(models["Cm"], at, geometry={"cbar": -1})


def test_names_and_units():
    assert [derivative_name(c, v) for c, v in [("Cm", "alpha"), ("Cl", "beta"),
                                                ("Cn", "dr"), ("Cm", "qhat"),
                                                ("Cl", "phat"), ("Cn", "rhat"),
                                                ("Cm", "q"), ("CZ", "mach")]] == \
        ["Cm_alpha", "Cl_beta", "Cn_dr", "Cm_q", "Cl_p", "Cn_r", "Cm_q_dim", "CZ_mach"]
    assert [derivative_unit(v) for v in ("alpha", "de", "qhat", "q", "mach", "tas")] == \
        ["1/rad", "1/rad", "-", "s/rad", "-", "s/m"]


def test_unknown_variable_and_bad_options(models):
    with pytest.raises(InputError, match=r"unknown variable\(s\) \['alfa'\] in wrt; the "
                       r"models depend on \['alpha', 'mach', 'de'\]"):
        derivatives(models["CZ"], wrt=["alfa"])
    with pytest.raises(InputError, match="rates must be one of"):
        derivatives(models["CZ"], rates="per-second")
    with pytest.raises(InputError, match="1 input row.* of the CZ model hold NaN"):
        derivatives(models["CZ"], pd.DataFrame({"alpha": [np.nan]}))


def test_reference_conditions(models):
    ref = reference_conditions(models)
    assert ref["beta"] == 0.0 and ref["q"] == 0.0 and ref["phat"] == 0.0 and ref["da"] == 0
    # alpha: the sample-weighted simplex centroids, about the uniform data's mean 0.1
    assert abs(ref["alpha"] - 0.1) < 0.02 and abs(ref["mach"] - 0.55) < 0.03
    data = pd.DataFrame(_data(500, seed=3))
    med = reference_conditions(models, data, {"tas": 180.0})
    assert med["alpha"] == pytest.approx(np.median(data.alpha)) and med["tas"] == 180.0
    one = derivatives(models, None)
    assert len(one) == 1 and one["alpha"][0] == pytest.approx(ref["alpha"])
    # a model's provenance may carry the identification medians and the geometry
    from dataclasses import replace

    cm = models["Cm"]
    cm2 = replace(cm, provenance={**cm.provenance, "medians": {"alpha": 0.07, "de": 0.01},
                                  "geometry": {"S": 20.0, "b": B, "cbar": CBAR}})
    assert reference_conditions(cm2)["alpha"] == 0.07
    t = derivatives(cm2, None, rates="nondimensional", reference={"tas": 150.0})
    assert t["alpha"][0] == 0.07 and t["de"][0] == 0.01
    assert t["Cm_q"][0] == pytest.approx((-0.1 + 0.07 * 0.0) * 2 * 150.0 / CBAR)


def test_condition_grid(models):
    g = condition_grid(models, {"alpha": [0.0, 0.1, 0.2], "mach": [0.4, 0.6], "beta": 0.01})
    assert len(g) == 6 and g.alpha.tolist() == [0.0, 0.0, 0.1, 0.1, 0.2, 0.2]
    assert g.mach.tolist() == [0.4, 0.6] * 3 and np.all(g.beta == 0.01)
    assert {"de", "q", "phat", "da"} <= set(g.columns)
    # a rate whose twin is swept is derived from it, not fixed at its reference
    assert "q" not in condition_grid(models, {"qhat": [0.0, 0.01]}).columns


def test_load_models(model_dir, models, tmp_path):
    loaded = load_models(model_dir)
    assert list(loaded) == ["CZ", "Cl", "Cm"]
    assert isinstance(loaded["Cm"], AeroModel) and loaded["Cm"].variables == ("alpha", "q",
                                                                                 "de")
    assert list(load_models([model_dir / "models" / "Cm.json"])) == ["Cm"]
    assert list(load_models(model_dir, ["Cm"])) == ["Cm"]
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "summary.json").write_text("{}")
    with pytest.raises(ModelFileError, match="no model files .* in '.*empty'"):
        load_models(empty)
    with pytest.raises(ModelFileError, match="does not exist"):
        load_models(tmp_path / "nothing")
    with pytest.raises(InputError, match="two models of Cm"):
        load_models([model_dir / "models" / "Cm.json"] * 2)
    with pytest.raises(InputError, match=r"no model of \['Cn'\]"):
        load_models(model_dir, ["Cn"])


# ---------------------------------------------------------------------------- plots
def test_plots(models):
    t = derivatives(models, {"alpha": np.linspace(-0.1, 0.35, 12), "mach": [0.4, 0.9]},
                    outside="extrapolate")
    fig = plot_derivatives(t)
    shown = [ax for ax in fig.axes if ax.get_visible()]
    inmodel = [k for k, d in t.attrs["derivatives"].items() if d["in_model"]]
    assert [ax.get_title() for ax in shown] == inmodel
    ax = shown[inmodel.index("CZ_alpha")]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == \
        ["mach = 0.4", "mach = 0.9 (outside)"]
    xs = ax.get_lines()[0].get_xdata()
    assert xs.min() == pytest.approx(np.degrees(-0.1))          # alpha in degrees
    cm = shown[inmodel.index("Cm_alpha")]                       # Cm has no Mach: one line
    assert [t.get_text() for t in cm.get_legend().get_texts()] == ["any mach"]
    styles = {line.get_linestyle() for line in ax.get_lines()}
    assert "-" in styles and ":" in styles and "--" not in styles   # dotted: extrapolated
    thin = t.copy()
    thin.attrs = t.attrs
    thin.loc[thin.alpha > 0.2, "samples_CZ"] = 2 * 20 - 1       # below 2 d_hat: dashed
    ax = plot_derivatives(thin, ["CZ_alpha"]).axes[0]
    dashed = [line for line in ax.get_lines() if line.get_linestyle() == "--"]
    assert dashed and np.nanmin(dashed[0].get_xdata()[np.isfinite(
        dashed[0].get_ydata())]) < np.degrees(0.2) < np.nanmax(dashed[0].get_xdata())
    grid = derivatives(models, {"alpha": np.linspace(-0.1, 0.3, 5),
                                "mach": np.linspace(0.3, 0.9, 4)})
    fig = plot_derivative_map(grid, ["CZ_alpha", "Cm_de"])
    assert len([ax for ax in fig.axes if ax.get_title()]) == 2
    hatched = [c for c in fig.axes[0].collections if getattr(c, "hatches", None)]
    assert not hatched
    grid.loc[grid.alpha > 0.15, "samples_CZ"] = 0    # thinly covered: hatched
    fig = plot_derivative_map(grid, ["CZ_alpha"])
    assert [c.hatches for c in fig.axes[0].collections if getattr(c, "hatches", None)] \
        == [["////"]]
    with pytest.raises(InputError, match="a map needs the table of a full alpha x mach"):
        plot_derivative_map(grid.iloc[:-1])


# ---------------------------------------------------------------------------- CLI
def test_cli_writes_table_description_and_plot(model_dir, tmp_path, capsys):
    out, png = tmp_path / "d.csv", tmp_path / "d.png"
    code = main(["derivatives", str(model_dir), "-o", str(out), "--plot", str(png),
                 "--alpha", "-5:15:21deg", "--mach", "0.4,0.6", "--at", "tas=200,de=1deg",
                 "--rates", "nondimensional", "--geometry", f"b={B},cbar={CBAR}"])
    assert code == 0
    text = capsys.readouterr().out
    assert "42 conditions" in text and "Cm_q = " in text
    t = pd.read_csv(out)
    assert len(t) == 42 and t.alpha.iloc[-1] == pytest.approx(np.radians(15))
    np.testing.assert_allclose(t.de, np.radians(1.0))
    np.testing.assert_allclose(t.Cm_q, -0.1 * 2 * 200 / CBAR, rtol=1e-8)
    a, m = t.alpha.to_numpy(), t.mach.to_numpy()
    np.testing.assert_allclose(t.CZ_alpha, A[1] + 2 * A[2] * a * m, atol=1e-8)
    assert np.all(t.Cl_alpha == 0)
    meta = json.loads((tmp_path / "d.csv.json").read_text())
    assert meta["columns"]["Cl_alpha"]["in_model"] is False
    assert meta["columns"]["Cm_q"]["unit"] == "-" and meta["rates"] == "nondimensional"
    assert meta["columns"]["alpha"] == {"kind": "condition", "unit": "rad"}
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_cli_map_and_long(model_dir, tmp_path, capsys):
    out = tmp_path / "m.csv"
    code = main(["derivatives", str(model_dir / "models" / "CZ.json"), "-o", str(out),
                 "--map", "--mach", "0.3:0.8:6", "--alpha=-0.1:0.3:5", "--long",
                 "--plot", str(tmp_path / "m.png"), "-q"])
    assert code == 0 and capsys.readouterr().out == ""
    t = pd.read_csv(out)
    assert len(t) == 30 * 3 and set(t.derivative) == {"CZ_alpha", "CZ_mach", "CZ_de"}
    assert (tmp_path / "m.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("args, message", [
    (["--wrt", "alfa"], r"unknown variable\(s\) \['alfa'\] in wrt"),
    (["--alpha=-5:20:26"], "alpha = -5 rad is not a plausible angle.*write -5deg"),
    (["--at", "mach=3deg"], r"mach \[-\] cannot take a 'deg' value"),
    (["--alpha", "0:1"], "must be START:STOP:NUM"),
    (["--rates", "nondimensional"], "needs the true airspeed"),
    (["--points", "x.csv", "--map"], "cannot be combined"),
])
def test_cli_errors_are_one_line(model_dir, tmp_path, capsys, args, message):
    code = main(["derivatives", str(model_dir), "-o", str(tmp_path / "d.csv"), *args])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith("simplexspline derivatives: error: ")
    import re

    assert re.search(message, err), err
    assert not (tmp_path / "d.csv").exists()


def test_cli_directory_without_models(tmp_path, capsys):
    (tmp_path / "models").mkdir()
    code = main(["derivatives", str(tmp_path), "-o", str(tmp_path / "d.csv")])
    err = capsys.readouterr().err
    assert code == 2 and "no model files (*.json, *.npz) in" in err and "models" in err


def test_cli_points_file(model_dir, tmp_path):
    pts = tmp_path / "p.csv"
    pd.DataFrame({"alpha": [0.0, 0.1], "mach": [0.5, 0.6], "de": [0.0, 0.1],
                  "beta": 0.0, "phat": 0.0, "da": 0.0, "q": 0.0}).to_csv(pts, index=False)
    out = tmp_path / "d.csv"
    assert main(["derivatives", str(model_dir), "-o", str(out), "--points", str(pts),
                 "--coefficients", "CZ", "-q"]) == 0
    t = pd.read_csv(out)
    np.testing.assert_allclose(t.CZ_alpha, A[1] + 2 * A[2] * np.array([0.0, 0.06]),
                               atol=1e-9)


# ---------------------------------------------------------------------------- report
def test_report_section(models):
    """The report's 'Stability and control derivatives' section: the table at the
    identification-data medians and the figures."""
    from simplexspline.aero.report.document import to_html, to_markdown
    from simplexspline.aero.report.page import _derivative_section, _Renderer

    ident = pd.DataFrame(_data(401, seed=2))
    jobs = []

    def slot(label, fn, *args):
        jobs.append((label, fn, args))

    blocks = [b for b in _derivative_section(models, ident, slot) if b is not None]
    html, md = to_html(blocks, title="t"), to_markdown(blocks)
    assert '<h2 id="derivatives">Stability and control derivatives</h2>' in html
    a, q = np.median(ident.alpha), np.median(ident.q)
    cm_alpha = -0.5 + 1.6 * a + 0.5 * q**2
    # Markdown escapes "_" (data never become emphasis)
    # no jackknife table given: the standard-error column stays empty
    assert f"| Cm | Cm\\_alpha | {cm_alpha:.4g} |  | 1/rad |  |" in md
    assert f"| Cm | Cm\\_q\\_dim | {-0.1 + a * q:.4g} |  | s/rad |  |" in md
    assert "Cm\\_mach" not in md and "Cm_mach" not in html  # not in the model: left out
    assert [j[0] for j in jobs] == ["CZ derivatives", "Cl derivatives", "Cm derivatives",
                                    "derivative maps"]
    figs = [fn(_Renderer, *args) for _, fn, args in (jobs[0], jobs[-1])]
    assert [f.name for f in figs] == ["CZ_derivatives", "derivative_maps"]
    assert all(f.png[:8] == b"\x89PNG\r\n\x1a\n" for f in figs)
