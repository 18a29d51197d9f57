"""Coefficients held beyond the data that excite their term (modelling/term_hold.py)."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from simplexspline.aero.config import parse_structure
from simplexspline.aero.modelling.term_hold import TERM_EXCITED, excited_boxes
from simplexspline.aero.selection.search import SelectionSettings, fit_structure


def _course(rng, n=6000, *, edge=0.6, noise=1e-4):
    """Mach 0.3-0.9 flown throughout with the elevator moving; the roll rate moves only
    below Mach ``edge`` (the lateral inputs of a course flown at its slower test points).
    The true roll damping varies mildly with Mach."""
    mach = rng.uniform(0.3, 0.9, n)
    de = 0.05 * rng.standard_normal(n)
    phat = np.where(mach < edge, 0.02 * rng.standard_normal(n),
                    1e-5 * rng.standard_normal(n))
    y = 0.01 - 0.2 * de + _true_damping(mach) * phat + noise * rng.standard_normal(n)
    return {"mach": mach, "de": de, "phat": phat}, y


def _true_damping(mach):
    return -(0.4 + 0.1 * (mach - 0.45))


def _roll_damping(model, mach):
    """The model's dCl/dphat at the given Mach numbers (finite difference)."""
    base = {"mach": mach, "de": np.zeros_like(mach), "phat": np.zeros_like(mach)}
    up = dict(base, phat=np.full_like(mach, 0.01))
    return (model.predict(up) - model.predict(base)) / 0.01


def test_boxes_cover_where_a_term_moves():
    rng = np.random.default_rng(0)
    cols, _ = _course(rng)
    s = parse_structure("Cl(mach | 1, de, phat) S^1_3")
    z = ((cols["mach"] - 0.3) / 0.6)[:, None]
    m = np.column_stack([np.ones_like(z[:, 0]), cols["de"] / 0.05, cols["phat"] / 0.014])
    boxes = excited_boxes(s, z, m)
    assert boxes[0] is None                 # the constant term
    assert boxes[1] is None                 # de moves throughout
    lo, hi = boxes[2]
    assert lo[0] == pytest.approx(0.0, abs=0.01)
    assert hi[0] == pytest.approx(0.5, abs=0.01)    # Mach 0.6
    assert 0.0 < TERM_EXCITED < 1.0


def test_a_derivative_is_held_beyond_the_data_that_excite_it():
    """Rolls flown below Mach 0.4 only, noisy: unheld, the roll damping above is the
    continuation of a cubic and strays by up to 0.2-0.7 /rad at Mach 0.9 (the truth
    moves by 0.05 there); held, it stays at its value at Mach 0.4, on every draw. Where the
    rolls were flown, both fits agree with the truth."""
    s = parse_structure("Cl(mach | 1, de, phat) S^1_3")
    far = np.array([0.6, 0.7, 0.8, 0.9])
    near = np.array([0.31, 0.35, 0.39])
    worst_held = worst_free = 0.0
    for seed in range(5):
        cols, y = _course(np.random.default_rng(seed), edge=0.4, noise=1e-3)
        held = fit_structure(s, cols, y, SelectionSettings())
        free = fit_structure(s, cols, y, replace(SelectionSettings(), hold_terms=False))
        bounds = held.provenance["held_terms"]
        assert set(bounds) == {"phat"}
        assert bounds["phat"]["upper"][0] == pytest.approx(0.4, abs=0.01)
        assert "held_terms" not in free.provenance
        edge = _roll_damping(held, np.array([0.4]))[0]
        np.testing.assert_allclose(_roll_damping(held, far), edge, atol=0.02)
        worst_held = max(worst_held, np.abs(_roll_damping(held, far) - _true_damping(far)).max())
        worst_free = max(worst_free, np.abs(_roll_damping(free, far) - _true_damping(far)).max())
        for model in (held, free):
            np.testing.assert_allclose(_roll_damping(model, near), _true_damping(near),
                                       atol=6e-3)
    assert worst_held < 0.07
    assert worst_free > 0.2


def test_terms_excited_throughout_are_fitted_as_before():
    rng = np.random.default_rng(2)
    cols, y = _course(rng)
    cols["phat"] = 0.02 * rng.standard_normal(len(y))       # rolls at every Mach number
    s = parse_structure("Cl(mach | 1, de, phat) S^1_3")
    held = fit_structure(s, cols, y, SelectionSettings())
    free = fit_structure(s, cols, y, replace(SelectionSettings(), hold_terms=False))
    assert "held_terms" not in held.provenance
    np.testing.assert_array_equal(held.spline.coefficients, free.spline.coefficients)


def test_identify_says_which_derivatives_are_held(tmp_path, capsys):
    """identify names the held terms and the ranges where the data excite them; so does
    the derivatives command, from the model file."""
    cols, y = _course(np.random.default_rng(3), n=4000, edge=0.5, noise=1e-3)
    res = _identify_cl(cols, y, "Cl(mach | 1, de, phat) S^1_3")
    note = next(w for w in res.warnings if "held" in w)
    assert note.startswith("Cl: the data excite some terms only in part of the envelope")
    assert re.search(r"phat \(mach 0\.30\d*\.\.0\.(49|50)\d*\)", note)
    assert "held_terms" in res.results["Cl"].model.provenance
    from simplexspline.cli import main

    path = res.results["Cl"].model.save(tmp_path / "Cl.json")
    assert main(["derivatives", str(path), "-o", str(tmp_path / "d.csv"),
                 "--alpha=0.05,0.1"]) == 0
    assert re.search(r"Cl: the derivatives of its phat term were measured only at mach "
                     r"0\.30\d*\.\.0\.(49|50)\d*; beyond, they are held", capsys.readouterr().out)


def _identify_cl(cols: dict, y, structure: str):
    """identify Cl alone on ten synthetic maneuvers of 400 samples carrying ``cols`` and
    ``y`` (4000 samples), with the given structure, no search, one process."""
    from simplexspline.aero.identify import IdentificationSettings, identify

    from .synthetic import synthetic_table

    table = synthetic_table(10, 400)
    for k, v in cols.items():
        table[k] = v
    table["Cl"] = y
    return identify(table, settings=IdentificationSettings(
        coefficients=("Cl",), select=False, workers=1,
        structures={"Cl": parse_structure(structure)}))


def _gap_course(rng, n=6000):
    """Mach 0.3-0.9 with the elevator moving throughout and rolls only below Mach 0.4 and
    above 0.8 (a gap in the roll rate's excitation between)."""
    mach = rng.uniform(0.3, 0.9, n)
    de = 0.05 * rng.standard_normal(n)
    phat = np.where((mach < 0.4) | (mach > 0.8), 0.02 * rng.standard_normal(n),
                    1e-5 * rng.standard_normal(n))
    y = 0.01 - 0.2 * de + _true_damping(mach) * phat + 1e-3 * rng.standard_normal(n)
    return {"mach": mach, "de": de, "phat": phat}, y


def _trim_course(rng, n_leg=800):
    """Six test points (Mach 0.13-0.166) flown trimmed: alpha and the elevator move
    together along the trim line (de = 0.05 - 1.4 alpha), and the pitching moment carries
    an unmodelled trim moment per test point (a propeller's). At the fourth, a short
    period moves them apart. Measured alpha and de carry 2e-4 rad of noise, Cm 5e-4."""
    legs = np.linspace(0.13, 0.166, 6)
    mach, alpha, de = [], [], []
    for i, m in enumerate(legs):
        trim = 0.045 - 1.1 * (m - 0.13)
        if i == 3:
            a = trim + 0.01 * rng.standard_normal(n_leg)
            d = 0.02 * rng.standard_normal(n_leg)
        else:
            a = trim + 0.001 * rng.standard_normal(n_leg)
            d = 0.05 - 1.4 * a
        mach.append(m + 0.001 * rng.standard_normal(n_leg))
        alpha.append(a)
        de.append(d)
    cols = {"mach": np.concatenate(mach), "alpha": np.concatenate(alpha),
            "de": np.concatenate(de)}
    n = len(cols["mach"])
    y = (0.05 - 1.4 * cols["alpha"] - 1.0 * cols["de"] + 0.002 * np.sin(60 * cols["mach"])
         + 5e-4 * rng.standard_normal(n))
    cols["alpha"] = cols["alpha"] + 2e-4 * rng.standard_normal(n)
    cols["de"] = cols["de"] + 2e-4 * rng.standard_normal(n)
    return cols, y, legs


def _pitch_stiffness(model, mach):
    base = {"mach": mach, "alpha": np.full_like(mach, 0.03), "de": np.zeros_like(mach)}
    up = dict(base, alpha=base["alpha"] + 0.01)
    return (model.predict(up) - model.predict(base)) / 0.01


def test_a_term_that_moves_only_with_others_is_not_excited():
    """Along the trim line alpha is large at every test point but moves apart from the
    elevator only in the short period: its derivative is measured there alone. Unheld, it
    drifts to about 0 at the outer test points (a Cessna course's Cm_alpha went from -2.3
    to +0.01 /rad); held, it stays within 0.2 of the truth, on every draw."""
    s = parse_structure("Cm(mach | 1, de, alpha) S^1_3")
    for seed in range(3):
        cols, y, legs = _trim_course(np.random.default_rng(seed))
        held = fit_structure(s, cols, y, SelectionSettings())
        free = fit_structure(s, cols, y, replace(SelectionSettings(), hold_terms=False))
        box = held.provenance["held_terms"]["alpha"]
        assert legs[2] < box["lower"][0] < legs[3] < box["upper"][0] < legs[4]
        assert set(held.provenance["held_terms"]) == {"alpha", "de"}
        np.testing.assert_allclose(_pitch_stiffness(held, legs), -1.4, atol=0.2)
        assert np.abs(_pitch_stiffness(free, legs[[0, -1]]) + 1.4).min() > 1.0


def test_a_terms_own_shape_does_not_hide_its_excitation():
    """beta * |mach - 0.6| is beta times a constant within a bin of Mach: it is beta's
    shape, not another effect, and does not make beta look unexcited there."""
    rng = np.random.default_rng(4)
    mach = rng.uniform(0.3, 0.9, 6000)
    beta = 0.05 * rng.standard_normal(6000)
    s = parse_structure("Cl(mach | 1, beta, beta*|mach-0.6|) S^1_3")
    z = ((mach - 0.3) / 0.6)[:, None]
    m = np.column_stack([np.ones_like(mach), beta / 0.05, beta * np.abs(mach - 0.6) / 0.015])
    assert excited_boxes(s, z, m) == [None, None, None]


def test_many_quieter_samples_excite_a_term_too():
    """Flaps up, most of the flight is quiet and a fifth of it elevator inputs; flaps down,
    a few inputs, larger. The flaps-up bin's partial standard deviation is 0.3 of the
    flaps-down one's, but its sum of squares is larger: the elevator is excited at both
    settings (an F-16 campaign had its CZ elevator derivative held over all its flaps-up
    data)."""
    rng = np.random.default_rng(5)
    n_up, n_down = 20000, 2000
    flap = np.concatenate([np.zeros(n_up), np.full(n_down, 0.26)])
    quiet = rng.random(n_up) < 0.8
    de = np.concatenate([np.where(quiet, 0.001, 0.02) * rng.standard_normal(n_up),
                         0.03 * rng.standard_normal(n_down)])
    s = parse_structure("CZ(flap | 1, de) S^1_3")
    z = (flap / 0.26)[:, None]
    m = np.column_stack([np.ones_like(de), de / 0.02])
    up, down = (np.sqrt(np.mean(de[flap == v] ** 2)) for v in (0.0, 0.26))
    assert up < TERM_EXCITED * down                  # by the partial std alone: not excited
    assert excited_boxes(s, z, m) == [None, None]


def _two_speed_rolls(rng, amplitude, n=8000):
    """Rolls at full amplitude below Mach 0.5, and in 3 % of the samples above at
    ``amplitude`` of it; the true roll damping steepens with Mach."""
    mach = np.where(rng.random(n) < 0.97, rng.uniform(0.3, 0.5, n), rng.uniform(0.5, 0.9, n))
    phat = 0.02 * np.where(mach < 0.5, 1.0, amplitude) * rng.standard_normal(n)
    damping = -(0.4 + 0.5 * (mach - 0.45))
    y = 0.01 + damping * phat + 1e-4 * rng.standard_normal(n)
    return {"mach": mach, "de": np.zeros(n), "phat": phat}, y


def test_the_hold_fades_with_the_excitation():
    """A bin just under the excitation threshold is held about as little as one just over
    it is: the roll damping at Mach 0.8 with the rolls there at 0.30 and at 0.36 of the
    full amplitude (a third between them) differs by under 0.05, and both lie within 0.05
    of the truth (-0.575; -0.425 at Mach 0.5). With an all-or-nothing box they were -0.494
    and -0.579."""
    s = parse_structure("Cl(mach | 1, phat) S^1_3")
    at = np.array([0.8])
    fitted = []
    for amplitude in (0.30, 0.36):
        cols, y = _two_speed_rolls(np.random.default_rng(6), amplitude)
        model = fit_structure(s, cols, y, SelectionSettings())
        fitted.append(_roll_damping(model, at)[0])
    assert abs(fitted[0] - fitted[1]) < 0.05
    np.testing.assert_allclose(fitted, -0.575, atol=0.05)


def test_a_derivative_is_interpolated_across_a_gap_in_its_excitation():
    """Rolls flown below Mach 0.4 and above 0.8 only, on six cells: the roll damping
    between is free in the middle cells (the roll rate does not move there), and unheld
    it strays by 0.05-0.2 /rad from the truth; interpolated across the gap, by under
    0.02, on every draw. The model names the gap (provenance 'held_gaps'); the term is
    excited across the whole Mach range, so nothing is held beyond it."""
    s = parse_structure("Cl(mach:6 | 1, de, phat) S^1_3")
    mid = np.linspace(0.5, 0.7, 9)
    worst_held = worst_free = 0.0
    for seed in range(5):
        cols, y = _gap_course(np.random.default_rng(seed))
        held = fit_structure(s, cols, y, SelectionSettings())
        free = fit_structure(s, cols, y, replace(SelectionSettings(), hold_terms=False))
        assert "held_terms" not in held.provenance
        (lo, hi), = held.provenance["held_gaps"]["phat"]["mach"]
        assert lo == pytest.approx(0.42, abs=0.01) and hi == pytest.approx(0.78, abs=0.01)
        worst_held = max(worst_held, np.abs(_roll_damping(held, mid) - _true_damping(mid)).max())
        worst_free = max(worst_free, np.abs(_roll_damping(free, mid) - _true_damping(mid)).max())
    assert worst_held < 0.02
    assert worst_free > 0.1


def test_hole_intervals_are_the_unexcited_bins_between_excited_ones():
    from simplexspline.aero.modelling.term_hold import BINS, hole_intervals
    share = np.full((2, BINS), np.nan)
    # bins 2-5 between excited ones, but bin 4 cannot say (too few samples); 7-9 are
    # beyond the last excited bin (held beyond the box, not a hole)
    share[0] = [0, 0, 0.1, 0.2, np.nan, 0.1, 0, 0.05, 0.3, 0.2]
    share[1] = [0.2, 0.1, 0, 0, 0, 0, 0, 0, 0.1, 0.2]             # excited in one run
    gaps = hole_intervals((np.zeros(2), np.ones(2), share))
    assert list(gaps) == [0]
    np.testing.assert_allclose(gaps[0], [(0.2, 0.4), (0.5, 0.6)])
    assert hole_intervals(None) == {}


def test_identify_and_derivatives_name_the_gaps(tmp_path, capsys):
    """A gap in a term's excitation is named by identify (a note and warning) and by the
    derivatives command, from the model file."""
    from simplexspline.cli import main

    cols, y = _gap_course(np.random.default_rng(1), n=4000)
    res = _identify_cl(cols, y, "Cl(mach:6 | 1, de, phat) S^1_3")
    note = next(w for w in res.warnings if "interpolated" in w)
    assert note.startswith("Cl: some terms are not excited between the conditions")
    assert re.search(r"phat \(mach 0\.4\d*\.\.0\.7\d*\)", note)
    path = res.results["Cl"].model.save(tmp_path / "Cl.json")
    assert main(["derivatives", str(path), "-o", str(tmp_path / "d.csv"),
                 "--alpha=0.05,0.1"]) == 0
    assert re.search(r"Cl: the derivatives of its phat term were not measured at mach "
                     r"0\.4\d*\.\.0\.7\d*, between conditions where they were",
                     capsys.readouterr().out)
