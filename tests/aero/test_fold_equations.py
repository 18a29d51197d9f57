"""The folds' normal equations shared by the candidates of a search: assembled from kept
blocks, they equal a fresh accumulation, and the search selects the same structures with
the same scores as with fresh accumulations for every candidate."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from simplexspline import InputError
from simplexspline.aero.modelling.structure import Structure
from simplexspline.aero.modelling.structure_space import StructureSpace, input_matrix
from simplexspline.aero.selection import fold_equations as fe
from simplexspline.aero.selection.fold_equations import FoldEquations, fold_equations
from simplexspline.aero.selection.search import (
    SearchCache,
    SelectionSettings,
    choose_prior_degree,
    cv_score,
    select_structure,
)
from simplexspline.aero.selection.validation import fold_by_maneuver


def _data(n_man=12, samples=500, seed=3, noise=2e-3):
    """Maneuvers of a CX-like truth: a curve in alpha, a kink in the elevator, sideslip."""
    rng = np.random.default_rng(seed)
    t = np.arange(samples) * 0.01
    cols = {k: [] for k in ("alpha", "mach", "de", "qhat", "beta", "y", "man")}
    for m in range(n_man):
        def wave(amp, centre=0.0):
            f, ph = rng.uniform(0.1, 1.0, 3), rng.uniform(0, 2 * np.pi, 3)
            return centre + amp * np.sin(2 * np.pi * f[:, None] * t + ph[:, None]).sum(0) / 3

        alpha = wave(0.1, rng.uniform(0.03, 0.15))
        de, qhat, beta = wave(0.12), wave(0.004), wave(0.15)
        mach = np.clip(wave(0.05, rng.uniform(0.4, 0.7)), 0.3, 0.8)
        y = 0.02 + 0.3 * alpha**2 + 0.25 * np.abs(de) + 0.4 * beta**2 - 2.0 * qhat \
            + noise * rng.standard_normal(samples)
        for k, v in (("alpha", alpha), ("mach", mach), ("de", de), ("qhat", qhat),
                     ("beta", beta), ("y", y), ("man", np.full(samples, m))):
            cols[k].append(v)
    return {k: np.concatenate(v) for k, v in cols.items()}


@pytest.fixture(scope="module")
def data():
    d = _data()
    d["folds"] = fold_by_maneuver(d["man"], 3, seed=0)
    return d


def _close(a, b, rtol=1e-10):
    return np.abs(a - b).max() <= rtol * max(np.abs(b).max(), 1e-300)


def _check(eq, s, d, min_points):
    laid = StructureSpace.build(s, input_matrix(d, s.inputs), min_points)
    total, parts = eq.get(s, laid, min_points)
    ref_total, ref_parts = fold_equations(laid.space, laid.scheduling, laid.multipliers,
                                          d["y"], d["folds"], 3)
    for a, b in zip([total, *parts], [ref_total, *ref_parts]):
        assert _close(a.XtWX, b.XtWX) and _close(a.XtWy, b.XtWy)
        assert a.ytWy == pytest.approx(b.ytWy, rel=1e-12)
        assert np.array_equal(a.counts, b.counts)
    return total


def test_kept_blocks_give_the_fresh_fold_equations(data):
    eq = FoldEquations(data["y"], data["folds"])
    base = Structure("CX", ("alpha", "mach"), 3, 1, (2, 1), ("1", "qhat", "de"))
    _check(eq, base, data, 10)
    assert (eq.hits, eq.misses) == (0, 1)
    # same triangulation and degree: a multiplier added or removed, other continuity,
    # cells joined: assembled from the kept blocks
    for s in (base.with_(multipliers=("1", "qhat", "de", "|de|")),
              base.with_(multipliers=("qhat", "de")),     # no constant: rescaled terms
              base.with_(continuity=0), base.with_(cellwise=True)):
        _check(eq, s, data, 10)
    assert (eq.hits, eq.misses) == (4, 1)
    _check(eq, base.with_(degree=4), data, 10)        # another degree: its own blocks
    _check(eq, base, data, 0)                          # the whole grid (with a prior)
    assert eq.misses == 3
    plain = Structure("CX", ("alpha", "de"), 2, 1, (2, 2))
    _check(eq, plain, data, 10)
    total = _check(eq, plain.with_(continuity=0), data, 10)
    total.XtWX[:] = 0.0                                # the caller's copy
    _check(eq, plain, data, 10)
    assert (eq.hits, eq.misses) == (6, 4)


def test_kept_blocks_are_tied_to_their_samples(data):
    eq = FoldEquations(data["y"], data["folds"])
    assert eq.matches(data["y"], data["folds"])
    assert not eq.matches(data["y"] + 1.0, data["folds"])
    s = Structure("CX", ("alpha", "mach"), 2, 1, (2, 1), ("1", "qhat"))
    with pytest.raises(InputError, match="other samples or folds"):
        cv_score(s, data, data["y"][::-1].copy(), data["folds"], equations=eq)
    with pytest.raises(InputError, match="one fold per sample"):
        FoldEquations(data["y"], data["folds"][:10])


def test_cross_validation_with_kept_blocks_equals_the_fresh_one(data):
    settings = SelectionSettings()          # with the coarse-model prior
    eq = FoldEquations(data["y"], data["folds"])
    coarse = {}
    for s in (Structure("CX", ("alpha", "mach"), 3, 1, (2, 1), ("1", "qhat", "de")),
              Structure("CX", ("alpha", "mach"), 3, 1, (2, 1), ("1", "qhat", "de", "|de|")),
              Structure("CX", ("alpha", "mach"), 3, 0, (2, 1), ("1", "qhat", "de"))):
        kept = cv_score(s, data, data["y"], data["folds"], settings, equations=eq,
                        coarse_cache=coarse)
        fresh = cv_score(s, data, data["y"], data["folds"], settings)
        assert kept[1:] == fresh[1:]
        assert kept[0] == pytest.approx(fresh[0], rel=1e-9)
    assert eq.hits >= 2


def test_the_search_selects_what_fresh_accumulations_select(data, monkeypatch):
    cols = {k: data[k] for k in ("alpha", "mach", "de", "qhat", "beta")}
    start = Structure("CX", ("alpha", "mach"), 3, 1, (2, 1), ("1", "qhat", "de"))
    settings = SelectionSettings(max_rounds=2, max_samples=4000)
    cache = SearchCache()
    degree, prior_scores = choose_prior_degree(start, cols, data["y"], data["man"],
                                               settings, cache=cache)
    best, history = select_structure(start, cols, data["y"], data["man"], settings,
                                     prior_degree=degree, cache=cache)
    assert cache.equations.hits > cache.equations.misses
    # the search's first score is the prior choice's, not computed again
    assert history[0].score == prior_scores[degree]

    def fresh(self, structure, laid, min_points):
        return fold_equations(laid.space, laid.scheduling, laid.multipliers, self.y,
                              self.folds, self.k)

    monkeypatch.setattr(fe.FoldEquations, "get", fresh)
    best2, history2 = select_structure(start, cols, data["y"], data["man"], settings,
                                       prior_degree=degree)
    assert best == best2
    assert [t.structure for t in history] == [t.structure for t in history2]
    a = np.array([t.score for t in history])
    b = np.array([t.score for t in history2])
    assert np.allclose(a, b, rtol=1e-8, atol=0)
    assert len(history) > 10


def test_memory_is_bounded(data):
    eq = FoldEquations(data["y"], data["folds"], max_bytes=1)
    base = Structure("CX", ("alpha", "mach"), 3, 1, (2, 1), ("1", "qhat", "de"))
    for res in ((2, 1), (3, 1), (2, 2)):
        _check(eq, base.with_(resolution=res), data, 10)
        assert len(eq._entries) == 1 and eq.nbytes > 0     # only the last one is kept
    _check(eq, base.with_(resolution=(2, 1)), data, 10)     # dropped: computed again
    assert (eq.hits, eq.misses) == (0, 4)


def test_a_search_cache_is_emptied_for_other_data_or_settings(data):
    cache = SearchCache()
    settings = SelectionSettings()
    cache.bind(data["y"], data["folds"], None, settings)
    cache.scores["x"] = (1.0, 1, 1)
    cache.bind(data["y"], data["folds"], None, settings)
    assert "x" in cache.scores                      # the same samples, folds, settings
    for y, folds, scored, s in (
            (data["y"] + 1.0, data["folds"], None, settings),
            (data["y"], data["folds"], np.ones(len(data["y"]), bool), settings),
            (data["y"], data["folds"], None, replace(settings, ridge=1e-6))):
        cache.bind(data["y"], data["folds"], None, settings)
        cache.scores["x"] = (1.0, 1, 1)
        cache.bind(y, folds, scored, s)
        assert not cache.scores and not cache.coarse
