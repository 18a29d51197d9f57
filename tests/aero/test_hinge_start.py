"""The adaptive-regression-spline start of the structure search (hinge_start)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from simplexspline.aero.modelling.notation import multiplier_parts
from simplexspline.aero.modelling.structure import Structure
from simplexspline.aero.selection import hinge_start, search
from simplexspline.aero.selection.hinge_start import (
    GCV_PENALTIES, forward_hinges, hinge_structures, prune_path,
)
from simplexspline.aero.selection.search import (
    SelectionSettings, fit_structure, select_structure,
)
from simplexspline.aero.variables import LATERAL_VARIABLES
from simplexspline.errors import InputError

from .synthetic import smooth_wave


def _maneuvers(n_man: int = 10, samples: int = 500, seed: int = 0) -> dict:
    """Smooth random trajectories of alpha, de, mach, qhat and beta, maneuver by maneuver."""
    rng = np.random.default_rng(seed)
    t = np.arange(samples) * 0.01
    cols = {k: [] for k in ("alpha", "de", "mach", "qhat", "beta", "man")}
    for m in range(n_man):
        def wave(amp, centre=0.0):
            return smooth_wave(rng, t, amp, centre, freq=(0.2, 1.2))

        for k, v in (("alpha", wave(0.15, rng.uniform(0.0, 0.25))), ("de", wave(0.15)),
                     ("mach", np.clip(wave(0.05, rng.uniform(0.4, 0.7)), 0.3, 0.8)),
                     ("qhat", wave(0.004)), ("beta", wave(0.08)),
                     ("man", np.full(samples, m))):
            cols[k].append(v)
    return {k: np.concatenate(v) for k, v in cols.items()}


@pytest.fixture
def pass_calls(monkeypatch) -> list:
    """The sample counts of every run of the passes the search makes (a spy)."""
    calls = []

    def spy(start, columns, y, variables, **kw):
        calls.append(len(y))
        return hinge_start.hinge_choices(start, columns, y, variables, **kw)

    monkeypatch.setattr(search, "hinge_choices", spy)
    return calls


def _table_truth(d: dict) -> np.ndarray:
    """A database-like drag: slopes in alpha and in the elevator that change at
    breakpoints, and an elevator kink whose size changes at an alpha breakpoint (a
    product of two kinks), plus pitch damping."""
    a, de = d["alpha"], d["de"]
    return (0.02 + 0.3 * np.abs(a - 0.1) + 0.4 * np.abs(a - 0.1) * np.abs(de + 0.02)
            + 0.1 * np.abs(de + 0.02) + 0.2 * a - 1.5 * d["qhat"])


def test_the_forward_pass_finds_a_product_of_kinks_and_the_fit_follows_it():
    d = _maneuvers()
    truth = _table_truth(d)
    y = truth + 1e-3 * np.random.default_rng(1).standard_normal(len(truth))
    cols = {k: d[k] for k in ("alpha", "de", "mach", "qhat", "beta")}
    terms = forward_hinges(cols, y, "CX", list(cols))
    assert terms[0] == ()
    products = [t for t in terms if len(t) == 2 and all(k is not None for _v, k in t)]
    # a product of an alpha kink and an elevator kink near the truth's breakpoints
    assert any({v for v, _k in t} == {"alpha", "de"}
               and min(abs(k - 0.1) for v, k in t if v == "alpha") < 0.03
               and min(abs(k + 0.02) for v, k in t if v == "de") < 0.03 for t in products)
    start = Structure("CX", ("alpha", "mach"), 3, 1, (3, 1), ("1", "qhat", "de"))
    structures = hinge_structures(start, cols, y, list(cols))
    assert structures
    for s in structures:
        assert s.variables == ("alpha",) and s.degree == 0 and s.resolution == (1,)
        assert s.multipliers[0] == "1"
    fit = fit_structure(structures[0], cols, y)
    assert np.sqrt(np.mean((fit.predict(cols) - truth) ** 2)) < 2e-3


@pytest.mark.parametrize("share", [0.23, 0.41, 0.57, 0.66, 0.79])
def test_a_kink_is_placed_on_its_breakpoint(share):
    """The forward pass scores a hinge together with its plain partner (as MARS scores a
    pair of hinges): scored alone, ``|alpha-k|`` must also stand in for the straight line
    beside the kink, and the pass placed these kinks 0.006-0.026 rad off, one to three and
    a half steps of the knot grid (0.0075 rad here)."""
    d = _maneuvers()
    a = d["alpha"]
    k0 = float(np.quantile(a, share))
    y = 0.5 * np.abs(a - k0) + 0.2 * a
    terms = forward_hinges({"alpha": a, "de": d["de"]}, y, "CX", ["alpha", "de"],
                           max_terms=3)
    knots = [k for t in terms for v, k in t if v == "alpha" and k is not None]
    assert knots
    step = float(np.median(np.diff(np.quantile(a, hinge_start.HINGE_QUANTILES))))
    assert min(abs(k - k0) for k in knots) < 0.6 * step


def test_the_pruning_path_removes_one_term_at_a_time_and_its_error_grows():
    d = _maneuvers(n_man=6, samples=300)
    y = _table_truth(d)
    cols = {k: d[k] for k in ("alpha", "de", "qhat")}
    terms = forward_hinges(cols, y, "CX", list(cols), max_terms=12)
    path = prune_path(cols, y, terms)
    sizes = [len(ts) for ts, _sse, _n in path]
    assert sizes == list(range(len(terms), 0, -1))
    sse = np.array([e for _ts, e, _n in path])
    assert np.all(np.diff(sse) >= -1e-12 * sse.max())     # fewer terms, never less error
    assert all(() in ts for ts, _e, _n in path)               # the intercept stays


@pytest.mark.parametrize("coefficient, odd", [("Cl", True), ("Cm", False)])
def test_terms_keep_the_coefficients_mirror_symmetry(coefficient, odd):
    """Odd in the lateral variables for the lateral coefficients, even for the others;
    a lateral variable's kink lies at 0 only."""
    d = _maneuvers(n_man=6, samples=300)
    cols = {k: d[k] for k in ("alpha", "de", "qhat", "beta")}
    y = -0.1 * d["beta"] + 0.3 * np.abs(d["alpha"] - 0.1) * d["beta"] \
        + 0.05 * np.abs(d["beta"]) * d["alpha"] + 0.01 * d["de"]
    terms = forward_hinges(cols, y, coefficient, list(cols), max_terms=15)
    assert len(terms) > 1
    for t in terms[1:]:
        plain_lateral = sum(1 for v, k in t if k is None and v in LATERAL_VARIABLES)
        assert (plain_lateral % 2 == 1) is odd
        assert all(k == 0.0 for v, k in t if v in LATERAL_VARIABLES and k is not None)


def test_the_search_takes_the_hinge_start_where_it_cross_validates_better():
    """A product of kinks that no single move of the search adds: with ``hinge_start``
    the search returns the hinge structure (its trial accepted, the search's path not)
    and it is closer to the truth; without it the search's own result stays."""
    d = _maneuvers(n_man=10, samples=500, seed=4)
    truth = _table_truth(d)
    y = truth + 1e-3 * np.random.default_rng(5).standard_normal(len(truth))
    cols = {k: d[k] for k in ("alpha", "de", "mach", "qhat", "beta")}
    start = Structure("CX", ("alpha", "mach"), 3, 1, (3, 1), ("1", "qhat", "de"))
    plain = SelectionSettings(max_rounds=2, max_samples=20_000, hinge_start=False)
    best, history = select_structure(start, cols, y, d["man"], plain)
    assert not any("hinge" in t.move for t in history)
    best_h, history_h = select_structure(start, cols, y, d["man"],
                                         replace(plain, hinge_start=True))
    accepted = [t for t in history_h if t.accepted]
    assert len(accepted) == 1 and accepted[0].move.startswith("hinge start")
    assert best_h == accepted[0].structure and best_h.degree == 0
    assert all(len(multiplier_parts(m)) <= 2 for m in best_h.multipliers)

    def rms(s):
        fit = fit_structure(s, cols, y)
        return float(np.sqrt(np.mean((fit.predict(cols) - truth) ** 2)))

    assert rms(best_h) < 0.7 * rms(best)


def test_hinge_start_must_be_a_bool():
    with pytest.raises(InputError, match="hinge_start is on or off"):
        SelectionSettings(hinge_start="yes")


def test_the_hinge_start_must_beat_the_search_by_parsimony_standard_errors():
    """The search's result stays unless the hinge structure's paired per-maneuver gain
    exceeds ``parsimony`` standard errors: with a bound no gain reaches, the same data as
    above keep the search's result; with ``parsimony=0`` only the threshold counts."""
    d = _maneuvers(n_man=10, samples=500, seed=4)
    y = _table_truth(d) + 1e-3 * np.random.default_rng(5).standard_normal(len(d["alpha"]))
    cols = {k: d[k] for k in ("alpha", "de", "mach", "qhat", "beta")}
    start = Structure("CX", ("alpha", "mach"), 3, 1, (3, 1), ("1", "qhat", "de"))
    base = SelectionSettings(max_rounds=2, max_samples=20_000, hinge_start=True)
    strict, history = select_structure(start, cols, y, d["man"],
                                       replace(base, parsimony=1e6))
    hinge_trials = [t for t in history if t.move.startswith("hinge start")]
    assert hinge_trials and not any(t.accepted for t in hinge_trials)
    assert not strict.multipliers == hinge_trials[0].structure.multipliers
    loose, history0 = select_structure(start, cols, y, d["man"], replace(base, parsimony=0.0))
    assert [t.move for t in history0 if t.accepted][0].startswith("hinge start")
    assert loose.degree == 0


def test_the_passes_run_inside_the_folds(pass_calls):
    """The hinge structures are scored honestly: the passes run once on all the search's
    samples (the structure taken) and once per fold on the other folds' maneuvers only,
    and every hinge trial records its cost and its score."""
    d = _maneuvers(n_man=9, samples=300, seed=2)
    y = _table_truth(d) + 1e-3 * np.random.default_rng(3).standard_normal(len(d["alpha"]))
    cols = {k: d[k] for k in ("alpha", "de", "mach", "qhat")}
    start = Structure("CX", ("alpha", "mach"), 3, 1, (3, 1), ("1", "qhat", "de"))
    settings = SelectionSettings(max_rounds=1, folds=3, hinge_start=True)
    _best, history = select_structure(start, cols, y, d["man"], settings)
    n = len(y)
    assert pass_calls[0] == n and len(pass_calls) == 1 + 3
    assert all(0 < c < n for c in pass_calls[1:]) and sum(pass_calls[1:]) == 2 * n
    screen = [t for t in history if t.move.startswith("hinge start screen")]
    honest = [t for t in history if "passes inside the folds" in t.move]
    assert 0 < len(screen) <= len(GCV_PENALTIES)
    assert len(honest) == len(GCV_PENALTIES)
    assert all(np.isfinite(t.score) for t in honest)
    # scored with the passes on all the data, a structure looks better than it is
    by_structure = {t.structure: t.score for t in screen}
    assert all(t.score >= by_structure[t.structure] * 0.98 for t in honest
               if t.structure in by_structure)


def test_the_passes_inside_the_folds_are_skipped_where_the_screen_fails(pass_calls):
    """A hinge basis that does not beat the search even when scored with the passes on all
    the data (optimistically) is not scored again: the passes run once."""
    d = _maneuvers(n_man=9, samples=300, seed=8)
    y = (0.02 + 0.3 * d["alpha"] + 0.1 * d["de"] - 1.5 * d["qhat"]
         + 1e-3 * np.random.default_rng(9).standard_normal(len(d["alpha"])))
    cols = {k: d[k] for k in ("alpha", "de", "mach", "qhat")}
    start = Structure("CX", ("alpha",), 1, 0, (1,), ("1", "qhat", "de"))
    _best, history = select_structure(start, cols, y, d["man"],
                                      SelectionSettings(max_rounds=1, hinge_start=True))
    assert pass_calls == [len(y)]
    assert any(t.move.startswith("hinge start screen") for t in history)
    assert not any("passes inside the folds" in t.move for t in history)


def test_a_hinge_basis_fitted_to_noise_is_not_taken():
    """Where the start already holds the truth, the forward pass can only fit noise; the
    noise of flight data is coloured (slow within a maneuver), which a basis chosen on
    all the data fits far better in sample than held out. Scored with its passes inside
    the folds it does not beat the search's result."""
    d = _maneuvers(n_man=12, samples=400, seed=6)
    truth = 0.02 + 0.3 * d["alpha"] + 0.1 * d["de"] - 1.5 * d["qhat"]
    rng = np.random.default_rng(7)
    t = np.arange(400) * 0.01
    slow = np.concatenate([sum(rng.normal(0, 3e-3) * np.sin(2 * np.pi * rng.uniform(0.1, 0.6)
                                                            * t + rng.uniform(0, 6.3))
                               for _ in range(3)) for _m in range(12)])
    y = truth + slow + 1e-3 * rng.standard_normal(len(truth))
    cols = {k: d[k] for k in ("alpha", "de", "mach", "qhat", "beta")}
    start = Structure("CX", ("alpha",), 1, 0, (1,), ("1", "qhat", "de"))
    settings = SelectionSettings(max_rounds=2, hinge_start=True)
    best, history = select_structure(start, cols, y, d["man"], settings)
    assert any(t.move.startswith("hinge start") for t in history)
    assert not any(t.accepted and t.move.startswith("hinge start") for t in history)
