"""Varying-coefficient aerodynamic models with breakpoint-aligned grids: structures,
labels, the piecewise-linear scaling, exact recovery of table-like truths with kinks,
gradients, files, exports, selection moves and errors."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from simplexspline import InputError
from simplexspline.aero.selection.search import PLAIN_FIT
from simplexspline.aero.config import parse_structure
from simplexspline.aero.export.c_code import generate_aero_c
from simplexspline.aero.export.lookup_tables import lookup_table
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.aero.selection.moves import neighbours
from simplexspline.aero.selection.search import SelectionSettings, cv_score, fit_structure
from simplexspline.aero.modelling.notation import format_knots, parse_knots
from simplexspline.aero.modelling.structure import Scaling, Structure

D2R = np.pi / 180.0
#: table breakpoints of the synthetic "database" (like JSBSim's F-16: alpha every 5 deg)
ALPHA_KNOTS = np.arange(-10, 35, 5) * D2R

#: A fit with the coarse-model prior (the selection's default).
WITH_PRIOR = replace(PLAIN_FIT, prior="auto")


def table(x, knots, values):
    """Piecewise-linear interpolation (a 1-D table with kinks at its breakpoints)."""
    return np.interp(x, knots, values)


def truth(df):
    """Cl-like: a kinked function of alpha (and a Mach kink at 0.6) plus alpha-dependent
    damping and control derivatives, as aerodynamic databases are built."""
    a, b, mach = df["alpha"], df["beta"], df["mach"]
    clb = table(a, ALPHA_KNOTS, [-0.02, 0.01, 0.03, 0.05, 0.02, 0.06, 0.04, 0.07, 0.05])
    clb_m = table(mach, [0.2, 0.6, 0.8, 1.0], [0.0, 0.0, 0.19, 0.18])
    clp = table(a, ALPHA_KNOTS, [-0.36, -0.36, -0.44, -0.42, -0.38, -0.37, -0.33, -0.29, -0.23])
    clda = table(a, ALPHA_KNOTS, [0.04, 0.05, 0.05, 0.056, 0.05, 0.056, 0.082, 0.059, 0.042])
    return -clb * b + clb_m * b + clp * df["phat"] + clda * df["da"]


def campaign(n=40, samples=1000, seed=0, noise=2e-4):
    rng = np.random.default_rng(seed)
    t = np.arange(samples) * 0.01
    parts = []
    for m in range(n):
        def wave(amp, centre=0.0):
            f = rng.uniform(0.1, 1.0, 3)
            ph = rng.uniform(0, 2 * np.pi, 3)
            return centre + amp * np.sin(2 * np.pi * f[:, None] * t + ph[:, None]).sum(0) / 3

        frame = pd.DataFrame({
            "maneuver": m, "t": t, "maneuver_type": "sum-of-sines",
            "alpha": np.clip(wave(0.2, rng.uniform(0.05, 0.2)), -0.1, 0.3),
            "beta": wave(0.12), "mach": np.clip(wave(0.15, rng.uniform(0.4, 0.8)), 0.3, 0.9),
            "phat": wave(0.05), "da": wave(0.2), "dr": wave(0.2)})
        frame["true_Cl"] = truth(frame)
        frame["Cl"] = frame["true_Cl"] + noise * rng.standard_normal(samples)
        parts.append(frame)
    return pd.concat(parts, ignore_index=True)


LABEL = "Cl(alpha@-10:30:5deg, beta, mach@0.6/0.8 | 1, phat, da) S^0_2"


@pytest.fixture(scope="module")
def data():
    return campaign()


@pytest.fixture(scope="module")
def model(data):
    s = parse_structure(LABEL)
    cols = {c: data[c].to_numpy() for c in data.columns if c != "maneuver_type"}
    return fit_structure(s, cols, data["Cl"].to_numpy(), replace(PLAIN_FIT, smoothing="gcv"))


# --------------------------------------------------------------------------- structures
def test_label_round_trip_and_sizes():
    s = parse_structure(LABEL)
    assert s.varying and s.multipliers == ("1", "phat", "da")
    assert s.inputs == ("alpha", "beta", "mach", "phat", "da")
    np.testing.assert_allclose(s.knots_of["alpha"], np.arange(-10, 35, 5) * D2R)
    assert s.knots_of["mach"] == (0.6, 0.8)
    assert s.label() == LABEL
    assert parse_structure(s.label()) == s
    assert Structure.from_dict(s.to_dict()) == s
    assert s.nterms == 3 and s.ncoef_per_simplex == 3 * 10
    assert s.cells == (10, 1, 3)


def test_knot_text():
    assert format_knots("mach", (0.6, 0.8)) == "0.6/0.8"
    assert format_knots("alpha", np.arange(-10, 15, 5) * D2R) == "-10:10:5deg"
    assert format_knots("alpha", (0.1, 0.3)) == "0.1/0.3"
    assert parse_knots("alpha", "-5/0/2.5deg") == pytest.approx((-5 * D2R, 0.0, 2.5 * D2R))
    with pytest.raises(InputError, match="breakpoints"):
        parse_knots("mach", "0.6:x:0.1")


@pytest.mark.parametrize("kwargs, match", [
    ({"multipliers": ("1", "1")}, "repeated or empty multiplier"),
    ({"knots": (("qhat", (0.1,)),)}, "not one of the variables"),
    ({"knots": (("alpha", (0.2, 0.1)),)}, "strictly increasing"),
    ({"knots": (("alpha", ("a",)),)}, "must be numbers"),
])
def test_bad_structures(kwargs, match):
    with pytest.raises(InputError, match=match):
        Structure("Cl", ("alpha", "beta"), 2, 0, **kwargs)


def test_parse_errors():
    with pytest.raises(InputError, match="no multipliers"):
        parse_structure("Cl(alpha | ) S^0_2")


# --------------------------------------------------------------------------- scaling
def test_piecewise_linear_scaling():
    rng = np.random.default_rng(1)
    x = np.column_stack([rng.uniform(-0.12, 0.41, 500), rng.uniform(0.3, 0.9, 500)])
    sc = Scaling.from_data(x, ("alpha", "mach"), {"alpha": ALPHA_KNOTS, "mach": (0.6, 0.8)})
    # interior breakpoints inside the data (and not within a quarter spacing of its ends)
    assert sc.cells == (7, 3)          # alpha knots -5..20 deg inside -6.9..23.5 deg
    k = np.asarray(sc.knots[0])
    np.testing.assert_allclose(sc.transform(np.column_stack([k, np.full_like(k, 0.6)]))[:, 0],
                               np.linspace(0, 1, len(k)), atol=1e-15)
    u = sc.transform(x)
    assert u.min() >= 0 and u.max() <= 1
    np.testing.assert_allclose(sc.inverse(u), x, atol=1e-15)
    far = np.array([[-0.5, 0.1], [0.7, 1.4]])             # linear continuation outside
    np.testing.assert_allclose(sc.inverse(sc.transform(far)), far, atol=1e-14)
    h = 1e-7
    fd = (sc.transform(x[:20] + h) - sc.transform(x[:20] - h)) / (2 * h)
    np.testing.assert_allclose(sc.jacobian(x[:20]), fd, rtol=1e-6)
    assert Scaling.from_dict(sc.to_dict()) == sc
    assert not sc.affine and Scaling.from_data(x, ("alpha", "mach")).affine


# --------------------------------------------------------------------------- fitting
def test_recovers_a_kinked_table_truth_below_the_noise_level(data, model):
    """Breakpoint-aligned S^0_2 terms contain the truth exactly: on new maneuvers the error
    against it is well below the measurement noise (2e-4); the membrane penalty (weight by
    GCV) keeps the thinly covered simplices in check."""
    test = campaign(n=8, seed=9)
    err = model.predict(test) - test["true_Cl"].to_numpy()
    assert np.sqrt(np.mean(err ** 2)) < 1e-4
    reg = model.spline.info.regularization
    assert reg.penalty == "membrane" and reg.lam > 0
    assert model.provenance["smoothing"]["relative_weight"] == reg.smoothing
    sid = model.locate(test)
    counts = np.asarray(model.provenance["counts"])
    well = np.where(sid >= 0, counts[np.maximum(sid, 0)], 0) >= 150
    assert well.mean() > 0.8 and np.sqrt(np.mean(err[well] ** 2)) < 4e-5
    # without the penalty the thin simplices spoil it
    cols = {c: data[c].to_numpy() for c in model.variables}
    raw = fit_structure(model.structure, cols, data["Cl"].to_numpy())
    err_raw = raw.predict(test) - test["true_Cl"].to_numpy()
    assert np.sqrt(np.mean(err_raw ** 2)) > 5 * np.sqrt(np.mean(err ** 2))
    # a plain spline over the same variables cannot follow the kinks and the products
    plain = fit_structure(Structure("Cl", ("alpha", "beta", "mach", "phat", "da"), 3, 1),
                          {c: data[c].to_numpy() for c in model.variables},
                          data["Cl"].to_numpy())
    err_plain = plain.predict(test) - test["true_Cl"].to_numpy()
    assert np.sqrt(np.mean(err_plain ** 2)) > 10 * np.sqrt(np.mean(err ** 2))


def test_gradient_is_exact_in_physical_units(model, data):
    x = data[list(model.variables)].to_numpy()[::997]
    g = model.gradient(x)
    h = 1e-7
    for i in range(x.shape[1]):
        e = np.zeros(x.shape[1])
        e[i] = h
        fd = (model.predict(x + e, outside="extrapolate")
              - model.predict(x - e, outside="extrapolate")) / (2 * h)
        np.testing.assert_allclose(g[:, i], fd, rtol=1e-5, atol=1e-7)
    # the multiplier derivatives are the terms: Cl_da = clda(alpha) at these points
    ida = model.variables.index("da")
    clda = table(x[:, 0], ALPHA_KNOTS, [0.04, 0.05, 0.05, 0.056, 0.05, 0.056, 0.082, 0.059,
                                        0.042])
    np.testing.assert_allclose(g[:, ida], clda, atol=2e-3)


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_model_files_round_trip(model, data, tmp_path, suffix):
    path = model.save(tmp_path / f"cl{suffix}")
    back = AeroModel.load(path)
    assert back.structure == model.structure and back.scaling == model.scaling
    assert back.multiplier_scale == model.multiplier_scale
    assert back.multiplier_offset == model.multiplier_offset and any(model.multiplier_offset)
    np.testing.assert_array_equal(back.predict(data.iloc[:300]), model.predict(data.iloc[:300]))


def test_exports(model):
    with pytest.raises(InputError, match="lookup table"):
        generate_aero_c(model)
    lut = lookup_table(model, {"alpha": np.linspace(-0.1, 0.4, 11), "beta": [0.05],
                               "mach": [0.5, 0.7], "phat": [0.0, 0.01], "da": [0.1]})
    assert lut.values.shape == (11, 1, 2, 2, 1)
    grid = np.stack(np.meshgrid(np.linspace(-0.1, 0.4, 11), [0.05], [0.5, 0.7], [0.0, 0.01],
                                [0.1], indexing="ij"), axis=-1).reshape(-1, 5)
    np.testing.assert_allclose(lut.values.ravel(), model.predict(grid), atol=1e-15)


def test_statistics_are_refused_for_varying_models(model, data):
    with pytest.raises(InputError, match="varying-coefficient"):
        model.standard_error(data.iloc[:3])


# --------------------------------------------------------------------------- selection
def test_selection_moves_change_multipliers_and_breakpoint_grids():
    s = parse_structure(LABEL)
    moves = dict(neighbours(s, SelectionSettings(), ["alpha", "beta", "mach", "phat", "da",
                                                      "dr"]))
    assert "add multiplier dr" in moves and "remove multiplier phat" in moves
    assert "refine beta (1->2 cells)" in moves
    assert not any(m.startswith(("refine alpha (", "add dr")) for m in moves)
    # breakpoint grids: every other breakpoint dropped, or midpoints inserted
    coarse = moves["coarsen alpha breakpoints (9->5)"]
    assert np.allclose(coarse.knots_of["alpha"], ALPHA_KNOTS[::2])
    assert coarse.knots_of["mach"] == s.knots_of["mach"]
    fine = moves["refine alpha breakpoints (9->17)"]
    assert np.allclose(fine.knots_of["alpha"], np.arange(-10, 32.5, 2.5) * D2R)
    assert "refine mach breakpoints (2->3)" in moves
    assert not any(m.startswith("coarsen mach") for m in moves)   # two breakpoints only
    assert parse_structure(coarse.label()) == coarse


def test_cross_validation_prefers_the_breakpoints_the_truth_has(data):
    cols = {c: data[c].to_numpy() for c in data.columns if c != "maneuver_type"}
    folds = data["maneuver"].to_numpy() % 3
    y = data["Cl"].to_numpy()
    # one polynomial per grid cell: the truth's tables are linear between breakpoints
    s = parse_structure(LABEL + " cellwise")
    moves = dict(neighbours(s, SelectionSettings(), list(cols)))
    good, coarse, fine = (cv_score(x, cols, y, folds, WITH_PRIOR)[0] for x in (
        s, moves["coarsen alpha breakpoints (9->5)"], moves["refine alpha breakpoints (9->17)"]))
    # the truth kinks every 5 deg: a 10 deg grid misses kinks, a 2.5 deg one adds variance
    assert good < 0.97 * coarse and good < 0.97 * fine
    # and the Kuhn diagonals inside the cells are no kinks of the truth: without them the
    # cross-validation error is close to the noise (2e-4), with them twice as large
    assert good < 1.25 * 2e-4 < cv_score(parse_structure(LABEL), cols, y, folds, WITH_PRIOR)[0]


def test_cross_validation_prefers_the_true_multipliers(data):
    cols = {c: data[c].to_numpy() for c in data.columns if c != "maneuver_type"}
    folds = data["maneuver"].to_numpy() % 3
    y = data["Cl"].to_numpy()
    good = cv_score(parse_structure(LABEL), cols, y, folds)[0]
    missing = cv_score(parse_structure(LABEL.replace(", da)", ")")), cols, y, folds)[0]
    extra = cv_score(parse_structure(LABEL.replace("da)", "da, dr)")), cols, y, folds)[0]
    assert good < 0.1 * missing
    assert good <= extra * 1.05


def test_multiplier_without_variation_is_an_error(data):
    cols = {c: data[c].to_numpy() for c in data.columns if c != "maneuver_type"}
    cols["gear"] = np.zeros(len(data))
    with pytest.raises(InputError, match="gear"):
        fit_structure(parse_structure("Cl(alpha | 1, gear) S^0_2"), cols,
                      data["Cl"].to_numpy())


# --------------------------------------------------------------------------- products
def test_product_multipliers_and_their_gradient():
    rng = np.random.default_rng(4)
    n = 20000
    df = pd.DataFrame({"alpha": rng.uniform(-0.1, 0.3, n), "beta": rng.uniform(-0.1, 0.1, n),
                       "qhat": rng.uniform(-0.01, 0.01, n), "flap": rng.choice([0.0, 0.26], n)})
    truth = (np.sin(3 * df.alpha) - 2.0 * df.alpha * df.beta ** 2 + 30 * df.qhat * df.flap
             * (1 + df.alpha))
    s = parse_structure("CX(alpha:2 | 1, beta*beta, qhat*flap) S^1_3")
    assert s.inputs == ("alpha", "beta", "qhat", "flap")
    model = fit_structure(s, {c: df[c].to_numpy() for c in df.columns}, truth.to_numpy(),
                          PLAIN_FIT)
    np.testing.assert_allclose(model.predict(df), truth, atol=2e-4)
    x = df[list(model.variables)].to_numpy()[:50]
    g = model.gradient(x)
    a, b, q, f = x.T
    want = np.column_stack([3 * np.cos(3 * a) - 2 * b ** 2 + 30 * q * f,
                            -4 * a * b, 30 * f * (1 + a), 30 * q * (1 + a)])
    np.testing.assert_allclose(g[:, 1:], want[:, 1:], atol=2e-3)   # the product rule
    np.testing.assert_allclose(g[:, 0], want[:, 0], atol=1e-2)     # cubic pieces vs sin
    h = 1e-6
    for i in range(4):
        e = np.zeros(4)
        e[i] = h
        fd = (model.predict(x + e, outside="extrapolate")
              - model.predict(x - e, outside="extrapolate")) / (2 * h)
        np.testing.assert_allclose(g[:, i], fd, rtol=1e-6, atol=1e-6)


# --------------------------------------------------------------------------- prior
def test_coarse_prior_stops_divergence_where_data_are_thin():
    """Remove almost all samples above alpha = 0.2: without the prior the fine model's
    simplices there diverge; shrunk towards the coarse model they follow it."""
    data = campaign()
    keep = (data["alpha"] < 0.2) | (np.arange(len(data)) % 200 == 0)
    thin = data[keep]
    cols = {c: thin[c].to_numpy() for c in thin.columns if c != "maneuver_type"}
    s = parse_structure(LABEL)
    test = campaign(n=8, seed=9)
    region = test["alpha"].to_numpy() > 0.2
    errs = {}
    for prior in (None, "auto"):
        m = fit_structure(s, cols, thin["Cl"].to_numpy(), replace(PLAIN_FIT, prior=prior))
        e = m.predict(test) - test["true_Cl"].to_numpy()
        errs[prior] = (np.sqrt(np.mean(e[region] ** 2)), np.sqrt(np.mean(e[~region] ** 2)))
    assert m.provenance["prior"]["structure"] == \
        "Cl(alpha, beta, mach | 1, phat, da) S^1_3"
    # the per-simplex counts are of real samples only (the virtual ones are not data)
    assert sum(m.provenance["counts"]) == m.provenance["samples"] == int(keep.sum())
    assert errs["auto"][0] < 0.2 * errs[None][0]          # thin region: far better
    assert errs["auto"][1] < 1.5 * errs[None][1] + 2e-5   # dense region: unharmed


def test_prior_in_cross_validation_and_errors(data):
    cols = {c: data[c].to_numpy() for c in data.columns if c != "maneuver_type"}
    folds = data["maneuver"].to_numpy() % 3
    y = data["Cl"].to_numpy()
    with_prior = cv_score(parse_structure(LABEL), cols, y, folds, WITH_PRIOR)[0]
    without = cv_score(parse_structure(LABEL), cols, y, folds, PLAIN_FIT)[0]
    # held-out maneuvers reach where the other folds' data are thin: the prior helps
    assert np.isfinite(with_prior) and with_prior < 0.7 * without
    with pytest.raises(InputError, match="prior must be"):
        fit_structure(parse_structure(LABEL), cols, y, replace(PLAIN_FIT, prior="fine"))


def test_identify_leaves_out_a_multiplier_that_never_moved():
    import warnings

    from simplexspline.aero.identify import IdentificationSettings, ThinDataWarning, identify

    data = campaign(n=8, samples=400)
    data["dr"] = 0.0                                   # the rudder never moved
    for col in ("CX", "CY", "CZ", "Cm", "Cn", "qhat", "rhat"):    # (not modelled here)
        data[col] = 0.0
    data["true_Cl"] = truth(data)
    s = parse_structure("Cl(alpha@-10:30:5deg, beta | 1, phat, da, dr) S^0_2")
    settings = IdentificationSettings(coefficients=("Cl",), structures={"Cl": s},
                                      select=False, reconstruct="never")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = identify(data, {"aircraft": "synthetic", "S": 1.0, "b": 1.0, "cbar": 1.0},
                       settings=settings)
    assert res.results["Cl"].structure.multipliers == ("1", "phat", "da")
    assert any(issubclass(w.category, ThinDataWarning) and "['dr']" in str(w.message)
               for w in caught)


def test_prior_degree_is_chosen_by_cross_validation(data):
    from simplexspline.aero.modelling.prior import PRIOR_DEGREES
    from simplexspline.aero.selection.search import choose_prior_degree

    cols = {c: data[c].to_numpy() for c in data.columns if c != "maneuver_type"}
    y = data["Cl"].to_numpy()
    mans = data["maneuver"].to_numpy()
    degree, scores = choose_prior_degree(parse_structure(LABEL), cols, y, mans)
    assert set(scores) == set(PRIOR_DEGREES) and degree == min(scores, key=scores.get)
    plain = parse_structure("Cl(alpha, beta) S^1_3")
    assert choose_prior_degree(plain, cols, y, mans) == (3, {})   # no prior for plain ones


def test_multiplier_terms_restricted_to_variables():
    s = parse_structure("Cl(alpha:3, beta:2 | 1, phat[alpha], da[], dr[alpha/beta]) S^1_3")
    assert s.term_dims == [None, (0,), (), (0, 1)]
    assert s.inputs == ("alpha", "beta", "phat", "da", "dr")
    assert parse_structure(s.label()) == s
    with pytest.raises(InputError, match="may only depend on variables"):
        parse_structure("Cl(alpha | 1, phat[mach]) S^1_3")
    data = campaign(n=12)
    cols = {c: data[c].to_numpy() for c in data.columns if c != "maneuver_type"}
    model = fit_structure(parse_structure("Cl(alpha:4, beta | 1, phat[alpha], da) S^1_3"),
                          cols, data["Cl"].to_numpy(), PLAIN_FIT)
    x = data[list(model.variables)].to_numpy()[::500]
    z, m = model.split(x)
    g = model.spline.terms[1].gradient(z)
    assert np.abs(g[:, 1]).max() < 1e-9          # the phat term depends on alpha only


def test_cross_validation_scores_only_the_chosen_held_out_samples(data):
    cols = {c: data[c].to_numpy() for c in data.columns if c != "maneuver_type"}
    folds = data["maneuver"].to_numpy() % 3
    y = data["Cl"].to_numpy()
    s = parse_structure(LABEL)
    everything = cv_score(s, cols, y, folds)[0]
    assert cv_score(s, cols, y, folds, scored=np.ones(len(y), bool))[0] == everything
    # the RMS over a subset is the subset's share of the squared error, refitted alike
    first = data["maneuver"].to_numpy() < 20
    a = cv_score(s, cols, y, folds, scored=first)[0]
    b = cv_score(s, cols, y, folds, scored=~first)[0]
    n1 = np.count_nonzero(first)
    assert np.isclose(everything ** 2 * len(y), a ** 2 * n1 + b ** 2 * (len(y) - n1))


def test_hold_keeps_the_coefficients_at_the_edge_and_the_terms_linear(model, data):
    """``outside='hold'``: beyond the box the scheduling variables are clamped (every
    coefficient keeps its edge value, and its derivative along them is 0) and the terms
    stay linear in their multipliers, where clamping every input saturates them; inside the
    box it is the default prediction; a model without multipliers clamps."""
    x = data[list(model.variables)].to_numpy()[::1999][:8].copy()
    lo, hi = np.asarray(model.scaling.lower), np.asarray(model.scaling.upper)
    ia, ida = model.variables.index("alpha"), model.variables.index("da")
    assert hi[ida] > 0
    far = x.copy()
    far[:, ia] = hi[ia] + 0.1
    far[:, ida] = 2.0 * hi[ida]
    edge = far.copy()
    edge[:, ia] = hi[ia]
    held = model.predict(far, outside="hold")
    np.testing.assert_allclose(held, model.predict(edge, outside="extrapolate"), atol=1e-12)
    half, zero = far.copy(), far.copy()
    half[:, ida], zero[:, ida] = hi[ida], 0.0
    p = [model.predict(v, outside="hold") for v in (zero, half, far)]
    np.testing.assert_allclose(p[2] - p[1], p[1] - p[0], atol=1e-12)
    assert np.abs(p[2] - p[1]).max() > 1e-4
    assert np.abs(model.predict(far, outside="clamp") - held).max() > 1e-4
    g = model.gradient(far, outside="hold")
    np.testing.assert_array_equal(g[:, ia], 0.0)
    np.testing.assert_allclose(g[:, ida], (p[2] - p[1]) / hi[ida], rtol=1e-8)
    inside = x[model.in_box(x)]
    assert len(inside)
    np.testing.assert_array_equal(model.predict(inside, outside="hold"),
                                  model.predict(inside))
    np.testing.assert_array_equal(model.gradient(inside, outside="hold"),
                                  model.gradient(inside))
    with pytest.raises(InputError, match="outside must be one of .*'hold'"):
        model.predict(x, outside="linear")
    plain = fit_structure(Structure("Cl", ("alpha", "da"), 2, 1),
                          {c: data[c].to_numpy() for c in ("alpha", "da")},
                          data["Cl"].to_numpy())
    two = far[:, [ia, ida]]
    np.testing.assert_array_equal(plain.predict(two, outside="hold"),
                                  plain.predict(two, outside="clamp"))


def test_inside_marks_rows_that_predict_would_clamp(model, data):
    """``AeroModel.in_box``: every input (scheduling variable and multiplier column) within
    the identified range; exactly the rows whose prediction clamping leaves unchanged."""
    x = data[list(model.variables)].to_numpy()
    assert model.in_box(x).all()
    lo, hi = np.asarray(model.scaling.lower), np.asarray(model.scaling.upper)
    beyond = x[:len(model.variables) * 2].copy()
    for j in range(len(model.variables)):        # one input past each end in turn
        beyond[2 * j, j] = lo[j] - 1e-3 * (hi[j] - lo[j])
        beyond[2 * j + 1, j] = hi[j] + 1e-3 * (hi[j] - lo[j])
    assert not model.in_box(beyond).any()
    edge = x[:1].copy()
    edge[0] = lo
    assert model.in_box(edge).all()                 # the box's boundary is inside
    np.testing.assert_array_equal(
        model.predict(beyond, outside="clamp") == model.predict(beyond, outside="extrapolate"),
        model.in_box(beyond))
    assert model.inside(x[model.in_box(x)]).shape == (len(x),)
    with pytest.raises(InputError, match="model needs column"):
        model.in_box(data.drop(columns=[model.variables[0]]))
