"""Validation scores (Eq. 54-55 with the square root) and maneuver splits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simplexspline.aero.selection.validation import (
    CONDITION_KEEP,
    autocorrelation,
    covered_in_fold,
    fold_by_maneuver,
    scores,
    split_by_maneuver,
    validation_split,
)
from simplexspline.errors import InputError


def test_scores_formulas():
    y = np.array([0.0, 1.0, 2.0, 3.0])
    yhat = np.array([0.5, 1.0, 2.0, 2.5])
    truth = np.array([0.0, 1.1, 2.0, 2.9])
    s = scores(y, yhat, truth=truth, max_lag=2)
    assert s["rms"] == pytest.approx(np.sqrt(0.5 / 4))
    assert s["rrms"] == pytest.approx(np.sqrt(0.5 / 4) / 3.0)
    assert s["r2"] == pytest.approx(1 - 0.5 / 5.0)
    assert s["rms_true"] == pytest.approx(np.sqrt((0.25 + 0.01 + 0 + 0.16) / 4))
    assert s["noise_rms"] == pytest.approx(np.sqrt(0.02 / 4))
    assert s["rms_true_over_noise"] == pytest.approx(s["rms_true"] / s["noise_rms"])
    assert len(s["autocorrelation"]) == 3 and s["autocorrelation"][0] == 1.0


def test_scores_errors():
    with pytest.raises(InputError, match="validation set is empty"):
        scores(np.array([]), np.array([]))
    with pytest.raises(InputError, match="NaN"):
        scores(np.array([1.0, np.nan]), np.array([1.0, 2.0]))
    with pytest.raises(InputError, match="equal length"):
        scores(np.ones(3), np.ones(2))


def test_white_residuals_are_white_and_lags_stay_inside_maneuvers():
    rng = np.random.default_rng(0)
    e = rng.standard_normal(20000)
    s = scores(e, np.zeros_like(e), maneuvers=np.repeat(np.arange(20), 1000))
    assert s["whiteness"] > 0.85
    m = np.array([0, 0, 1, 1])
    ac = autocorrelation(np.array([1.0, 1.0, -1.0, -1.0]), m, max_lag=1)
    # (1*1 + (-1)(-1)) / 4; the pair across the boundary (1*-1) is skipped, else 0.25
    assert ac[1] == pytest.approx(0.5)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 40), frac=st.floats(0.05, 0.95), seed=st.integers(0, 10))
def test_split_holds_out_whole_maneuvers(n, frac, seed):
    man = np.repeat(np.arange(n), 7)
    val = split_by_maneuver(man, frac, seed=seed)
    held = set(man[val])
    assert held and len(held) < n
    for m in range(n):   # whole maneuvers only
        assert val[man == m].all() or not val[man == m].any()


def test_split_draws_within_each_maneuver_type():
    man = np.repeat(np.arange(40), 5)
    kind = np.where(man % 4 == 0, "sos", "3211")
    for seed in range(6):
        val = split_by_maneuver(man, 0.25, groups=kind, seed=seed)
        assert set(kind[val]) == {"sos", "3211"}
        assert len(set(man[val])) == 10                          # a quarter of 40
        assert len(set(man[val & (kind == "sos")])) in (2, 3)     # 2.5 of the 10


@pytest.mark.parametrize("sizes", [[2] * 6, [3, 2, 2, 1, 1, 1, 1, 1], [6, 2, 2, 2, 2, 2, 2]])
def test_the_split_holds_its_fraction_out_of_many_small_kinds(sizes):
    """A record of a few maneuvers of many kinds (a flight-test course: stationary
    measurements, two phugoids, two short periods ...) gets a quarter of its maneuvers for
    validation, not the one that rounding each kind on its own (round(0.25 * 2) == 0) left.
    Every kind keeps a maneuver for identification, and the only maneuver of a kind is not
    drawn."""
    kind = np.repeat(np.arange(len(sizes)), sizes)
    man = np.repeat(np.arange(len(kind)), 10)
    kinds = kind[man]
    for seed in range(8):
        val = split_by_maneuver(man, 0.25, groups=kinds, seed=seed)
        held = np.unique(man[val])
        assert held.size == round(0.25 * len(kind))
        per_kind = np.bincount(kind[held], minlength=len(sizes))
        assert np.all(per_kind < np.asarray(sizes))         # one of each kind identifies
        assert np.all(per_kind[np.asarray(sizes) == 1] == 0)


def test_kinds_of_one_maneuver_each_are_not_drawn():
    """Twelve kinds of one maneuver each: the draw takes none of them (each would leave
    identification without its kind); one maneuver is held out, as the rules allow."""
    man = np.repeat(np.arange(12), 10)
    for seed in range(4):
        val = split_by_maneuver(man, 0.25, groups=man, seed=seed)
        assert np.unique(man[val]).size == 1


def test_what_a_rule_refuses_in_one_kind_is_taken_from_the_others():
    """The mass range keeps the first and last maneuvers (the fuel extremes) in
    identification; with two kinds of four, the kind holding both ends still gets its
    share elsewhere, and the total stays a quarter."""
    man = np.repeat(np.arange(8), 10)
    kind = np.repeat(np.array([0, 1, 1, 1, 1, 0, 0, 0]), 10)
    mass = np.repeat(np.linspace(900.0, 800.0, 8), 10)[:, None]
    for seed in range(8):
        val = split_by_maneuver(man, 0.25, groups=kind, seed=seed, ranges=mass)
        held = set(man[val])
        assert len(held) == 2 and not held & {0, 7}


def _condition_campaign(seed=0):
    """Maneuvers of 30 flight conditions: per condition one long sum-of-sines (most of
    its samples) or two, and short 3211s."""
    rng = np.random.default_rng(seed)
    man, cond, kind = [], [], []
    m = 0
    for c in range(30):
        plan = ["sos"] * (1 + c % 2) + ["3211"] * int(rng.integers(2, 5))
        for k in plan:
            size = 90 if k == "sos" else 10
            man += [m] * size
            cond += [c] * size
            kind += [k] * size
            m += 1
    return np.array(man), np.array(cond), np.array(kind)


@pytest.mark.parametrize("seed", range(5))
def test_split_keeps_every_flight_condition_identified(seed):
    man, cond, kind = _condition_campaign(seed)
    val = split_by_maneuver(man, 0.25, seed=seed, groups=kind, conditions=cond)
    for c in np.unique(cond):
        at = cond == c
        assert np.count_nonzero(at & ~val) >= CONDITION_KEEP * np.count_nonzero(at)
    # the lone sum-of-sines of a condition stays for identification; paired ones may go
    lone = [c for c in range(30) if c % 2 == 0]
    assert not (val & (kind == "sos") & np.isin(cond, lone)).any()
    assert (val & (kind == "sos")).any() and (val & (kind == "3211")).any()
    # without conditions the split is the plain stratified one, lone maneuvers included
    plain = [split_by_maneuver(man, 0.25, seed=s, groups=kind) for s in range(10)]
    assert any((v & (kind == "sos") & np.isin(cond, lone)).any() for v in plain)


def test_folds_spread_conditions_and_score_covered_samples():
    man, cond, _kind = _condition_campaign(1)
    folds = fold_by_maneuver(man, 3, seed=0, conditions=cond)
    for m in np.unique(man):
        assert len(np.unique(folds[man == m])) == 1          # whole maneuvers
    for c in np.unique(cond):
        n_man = len(np.unique(man[cond == c]))
        # a condition's maneuvers go to different folds while there are folds left
        assert len(np.unique(folds[cond == c])) == min(n_man, 3)
    scored = covered_in_fold(folds, cond)
    for c in np.unique(cond):
        for f in range(3):
            at = (cond == c) & (folds == f)
            if at.any():
                kept = np.count_nonzero((cond == c) & (folds != f))
                assert scored[at].all() == (kept >= CONDITION_KEEP * np.count_nonzero(
                    cond == c))
    assert 0.3 < scored.mean() < 1.0


def test_folds_deal_the_maneuvers_that_move_the_coefficient_when_one_fold_took_all():
    """Two of nine maneuvers move the coefficient (a pulse and a doublet four times its
    size). Where the plain draw puts both into one fold, so that its training folds hold
    neither, the folds are drawn again with them dealt to different folds; where the draw
    already parts them, the folds are the plain ones."""
    rng = np.random.default_rng(3)
    sizes = np.full(9, 200)            # equal: the seed's shuffle orders the draw
    man = np.repeat(np.arange(9), sizes)
    y = rng.normal(0.0, 1e-4, len(man))
    y[man == 2] += rng.normal(0.0, 1e-3, sizes[2])       # a pulse
    y[man == 6] += rng.normal(0.0, 4e-3, sizes[6])       # a doublet
    together = apart = None
    for seed in range(40):
        plain = fold_by_maneuver(man, 3, seed=seed)
        same = plain[man == 2][0] == plain[man == 6][0]
        if same and together is None:
            together = seed
        if not same and apart is None:
            apart = seed
    assert together is not None and apart is not None
    dealt = fold_by_maneuver(man, 3, seed=together, excitation=y)
    assert dealt[man == 2][0] != dealt[man == 6][0]
    for m in range(9):
        assert len(set(dealt[man == m])) == 1                 # whole maneuvers
    assert set(np.unique(dealt)) == {0, 1, 2}
    assert np.array_equal(fold_by_maneuver(man, 3, seed=apart, excitation=y),
                          fold_by_maneuver(man, 3, seed=apart))
    # a quiet coefficient (nothing moves it) leaves the plain draw
    flat = np.full(len(man), 0.02)
    assert np.array_equal(fold_by_maneuver(man, 3, seed=together, excitation=flat),
                          fold_by_maneuver(man, 3, seed=together))


def test_split_errors():
    with pytest.raises(InputError, match="at least two"):
        split_by_maneuver(np.zeros(10), 0.3)
    with pytest.raises(InputError, match=r"in \(0, 1\)"):
        split_by_maneuver(np.arange(10), 0.0)


def test_folds_are_whole_maneuvers_and_balanced():
    rng = np.random.default_rng(1)
    sizes = rng.integers(100, 1000, 30)
    man = np.repeat(np.arange(30), sizes)
    f = fold_by_maneuver(man, 3)
    for m in range(30):
        assert len(set(f[man == m])) == 1
    load = np.bincount(f)
    assert load.max() - load.min() <= sizes.max()
    with pytest.raises(InputError, match="at least 5 maneuvers"):
        fold_by_maneuver(np.arange(4), 5)


def _one_axis_maneuvers(rng, axes=(0, 0, 0, 1, 1, 2, 2), n=200):
    """Maneuvers of one kind each (a short period, a roll, ...): maneuver m moves signal
    ``axes[m]`` of three and leaves the others at their noise."""
    man = np.repeat(np.arange(len(axes)), n)
    signals = 0.01 * rng.standard_normal((man.size, 3))
    t = np.arange(n) * 0.1
    for m, axis in enumerate(axes):
        signals[man == m, axis] += np.sin(2 * np.pi * 0.5 * t + m)
    return man, signals, np.array([f"kind-{m}" for m in man])


@pytest.mark.parametrize("seed", range(6))
def test_every_signal_is_excited_in_validation_while_identification_keeps_it(seed):
    """Seven maneuvers of one kind each: the draw holds out one; the excitation rule adds,
    per signal that no held-out maneuver moves, one that does, never the last one that
    moves it."""
    man, signals, kind = _one_axis_maneuvers(np.random.default_rng(seed))
    axes = np.array([0, 0, 0, 1, 1, 2, 2])
    plain = split_by_maneuver(man, 0.25, seed=seed, groups=kind)
    assert np.unique(man[plain]).size == 1          # one kind each: nothing drawn per kind
    val = split_by_maneuver(man, 0.25, seed=seed, groups=kind, excitation=signals)
    held = np.unique(man[val])
    assert set(np.unique(man[plain])) <= set(held)
    assert set(axes[held]) == {0, 1, 2}             # every signal moves in validation ...
    ident = np.setdiff1d(np.arange(axes.size), held)
    assert set(axes[ident]) == {0, 1, 2}            # ... and in identification


def test_a_signal_only_one_maneuver_moves_stays_in_identification():
    man, signals, kind = _one_axis_maneuvers(np.random.default_rng(1), axes=(0, 0, 0, 0, 1))
    for seed in range(8):
        val = split_by_maneuver(man, 0.25, seed=seed, groups=kind, excitation=signals)
        assert 4 not in np.unique(man[val])         # the only maneuver that moves signal 1


@pytest.mark.parametrize("seed", range(6))
def test_a_signal_only_one_maneuver_moves_is_validated_by_leaving_it_out(seed):
    """Signal 1 moves in maneuver 4 alone (a course's one short period): it cannot be held
    out, so no validation maneuver moves signal 1 and none can be added; the split names
    maneuver 4 for a left-out validation of signal 1, and none for the signals that the
    validation moves. Without the excitation signals there is nothing to name."""
    man, signals, kind = _one_axis_maneuvers(np.random.default_rng(seed),
                                             axes=(0, 0, 0, 0, 1))
    split = validation_split(man, 0.25, seed=seed, groups=kind, excitation=signals)
    held = set(np.unique(man[split.validation]).tolist())
    assert 4 not in held
    assert split.left_out[1] == 4
    assert split.left_out[0] is None          # the held-out maneuvers move signal 0
    assert validation_split(man, 0.25, seed=seed, groups=kind).left_out == ()
    # a signal that only noise moves has nothing worth leaving out
    flat = signals.copy()
    flat[:, 1] = 0.01 * np.random.default_rng(seed).standard_normal(len(man))
    flat[man == 4, 1] *= 1.5
    split = validation_split(man, 0.25, seed=seed, groups=kind, excitation=flat)
    assert split.left_out[1] is None


def _refused_exciters(weak: float, n=200):
    """Ten maneuvers, each of its own kind, flown from full to empty tanks. Signal 0
    moves in all of them but 0 and 9; signal 1 moves strongly in 0 and 9 only (the
    heaviest and the lightest, which the mass rule keeps for identification) and by
    ``weak`` in 4 and 5; noise 0.01 everywhere."""
    rng = np.random.default_rng(7)
    man = np.repeat(np.arange(10), n)
    t = np.tile(np.arange(n) * 0.1, 10)
    signals = 0.01 * rng.standard_normal((man.size, 2))
    wave = np.sqrt(2.0) * np.sin(2 * np.pi * 0.5 * t)
    for m in range(1, 9):
        signals[man == m, 0] += wave[man == m]
    for m, amp in ((0, 1.0), (9, 1.0), (4, weak), (5, weak)):
        signals[man == m, 1] += amp * wave[man == m]
    mass = np.repeat(np.linspace(9000.0, 8000.0, 10), n)[:, None]
    return man, signals, mass


@pytest.mark.parametrize("seed", range(8))
def test_a_signal_the_rules_leave_unexcited_is_validated_by_leaving_its_exciter_out(seed):
    """Every maneuver that excites signal 1 is refused (the mass range keeps 0 and 9 for
    identification; 4 and 5 move it by a fifth as much, below what counts as excited):
    the strongest exciter is named for a left-out validation of signal 1, the shared
    split is untouched, and signal 0, excited in it, gets none. Until stop 40 one of the
    weaker maneuvers was held out for signal 1 alone: identification data taken for a
    validation that still did not excite it."""
    man, signals, mass = _refused_exciters(weak=0.2)
    split = validation_split(man, 0.25, seed=seed, excitation=signals, ranges=mass)
    np.testing.assert_array_equal(split.validation, split_by_maneuver(
        man, 0.25, seed=seed, excitation=signals, ranges=mass))
    held = set(np.unique(man[split.validation]).tolist())
    assert not held & {0, 9}
    assert split.left_out[0] is None and split.left_out[1] in (0, 9)
    # moving signal 1 by half as much, a weaker maneuver excites it: the draw holds one
    # out for every signal and nothing is left out
    man, signals, mass = _refused_exciters(weak=0.5)
    split = validation_split(man, 0.25, seed=seed, excitation=signals, ranges=mass)
    assert set(np.unique(man[split.validation]).tolist()) & {4, 5}
    assert split.left_out == (None, None)


@pytest.mark.parametrize("seed", range(8))
def test_validation_maneuvers_lie_inside_the_identification_range_of_the_mass(seed):
    """A flight burns fuel: the first maneuver is the heaviest, the last the lightest. A
    held-out maneuver lies within the identification maneuvers' range of every test-point
    variable (mass; gear down in one maneuver only), so no model that takes them as
    variables meets its validation outside its identified range; NaN is ignored."""
    rng = np.random.default_rng(seed)
    n_man, n = 12, 50
    man = np.repeat(np.arange(n_man), n)
    mass = 9000.0 - 2.0 * np.arange(man.size) + rng.normal(0, 0.5, man.size)
    gear = np.where(man == 5, 1.0, 0.0)
    flap = np.full(man.size, np.nan)                # a channel the record does not hold
    ranges = np.column_stack([mass, gear, flap])
    plain = [split_by_maneuver(man, 0.25, seed=s) for s in range(40)]
    assert any(np.isin([0, 5, n_man - 1], np.unique(man[v])).any() for v in plain)
    val = split_by_maneuver(man, 0.25, seed=seed, ranges=ranges)
    held = np.unique(man[val])
    assert held.size >= 1 and not np.isin([0, 5, n_man - 1], held).any()
    ident = ~val
    for col in (mass, gear):
        assert col[val].min() >= col[ident].min() and col[val].max() <= col[ident].max()
    # Every maneuver at one mass: nothing to avoid, the draw is the plain one.
    same = split_by_maneuver(man, 0.25, seed=seed, ranges=np.full((man.size, 1), 9000.0))
    np.testing.assert_array_equal(same, split_by_maneuver(man, 0.25, seed=seed))


def _course(rng):
    """A flight-test course: six airspeeds (envelope cells 0-5), at each a stationary
    measurement and pitch and roll maneuvers; the top airspeed has one roll, the others
    two. Returns maneuvers, cells, motion (pitch rate, roll rate), kinds, and the id of
    the lone roll."""
    plan = [(5, ("stationary", "pitch", "roll"))] + [
        (c, ("stationary", "pitch", "roll", "roll")) for c in range(5)]
    man, cells, motion, kinds, lone = [], [], [], [], None
    n, m = 60, 0
    t = np.arange(n) * 0.1
    for cell, kinds_here in plan:
        for kind in kinds_here:
            q = rng.normal(0, 1e-3, n) + (np.sin(2 * np.pi * 0.4 * t) if kind == "pitch" else 0)
            p = rng.normal(0, 1e-3, n) + (np.sin(2 * np.pi * 0.3 * t + m) if kind == "roll"
                                          else 0)
            if kind == "roll" and cell == 5:
                lone = m
            man.append(np.full(n, m))
            cells.append(np.full(n, cell))
            motion.append(np.column_stack([q, p]))
            kinds.append(np.full(n, kind))
            m += 1
    return (np.concatenate(man), np.concatenate(cells), np.vstack(motion),
            np.concatenate(kinds), lone)


def test_a_maneuver_is_held_out_only_where_identification_makes_the_same_motion():
    """The only roll flown at the top airspeed is never held out (a model of the roll
    terms scheduled on the airspeed would meet an extrapolation there); without the
    motions it is, for some seeds. Every held-out roll has another roll in its cell left
    for identification, and rolls are still validated."""
    man, cells, motion, kinds, lone = _course(np.random.default_rng(0))
    plain = [np.unique(man[split_by_maneuver(man, 0.25, seed=s, groups=kinds, cells=cells)])
             for s in range(30)]
    assert any(lone in held for held in plain)
    rolls_held = 0
    for seed in range(30):
        val = split_by_maneuver(man, 0.25, seed=seed, groups=kinds, cells=cells,
                                motion=motion)
        held = np.unique(man[val])
        assert lone not in held
        for h in held:
            if kinds[man == h][0] != "roll":
                continue
            rolls_held += 1
            cell = cells[man == h][0]
            others = np.unique(man[(cells == cell) & ~val & (kinds == "roll")])
            assert others.size >= 1
    assert rolls_held >= 15


def test_without_cells_a_motion_keeps_one_maneuver_that_makes_it():
    """Without envelope cells the motion rule keeps, of the maneuvers that make a motion,
    at least one for identification (one roll among pitch maneuvers is never held out)."""
    rng = np.random.default_rng(2)
    n = 80
    man = np.repeat(np.arange(6), n)
    t = np.tile(np.arange(n) * 0.1, 6)
    q = np.where(man < 5, np.sin(2 * np.pi * 0.4 * t), 0) + rng.normal(0, 1e-3, man.size)
    p = np.where(man == 5, np.sin(2 * np.pi * 0.3 * t), 0) + rng.normal(0, 1e-3, man.size)
    for seed in range(12):
        val = split_by_maneuver(man, 0.5, seed=seed, motion=np.column_stack([q, p]))
        assert 5 not in np.unique(man[val])


def test_identify_splits_by_motion_only_when_asked():
    """``IdentificationSettings(split_motion=True)`` passes the rates to the split: the
    course's lone roll at the top airspeed then stays for identification; by default the
    draw is the one without the motion rule."""
    import pandas as pd

    from simplexspline.aero.identify import IdentificationSettings, _split

    man, cells, motion, kinds, lone = _course(np.random.default_rng(0))
    rng = np.random.default_rng(1)
    data = pd.DataFrame({"maneuver": man, "maneuver_type": kinds,
                         "mach": 0.4 + 0.05 * cells + rng.normal(0, 1e-4, man.size),
                         "alpha": 0.05 + rng.normal(0, 1e-4, man.size),
                         "q": motion[:, 0], "p": motion[:, 1],
                         "Cm": -0.5 * motion[:, 0], "Cl": -0.3 * motion[:, 1]})
    held = {flag: [set(_split(data, IdentificationSettings(seed=s, split_motion=flag),
                              lambda _: None)[1]["maneuver"]) for s in range(20)]
            for flag in (False, True)}
    assert any(lone in h for h in held[False])
    assert not any(lone in h for h in held[True])
    assert IdentificationSettings(split_motion=True).to_dict()["split_motion"] is True
