"""Where a kink lies: a kink term's breakpoint moved to where the fit's squared error is
least, between the candidate positions around it; and the search doing so."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from simplexspline.aero.config import parse_structure
from simplexspline.aero.modelling.notation import multiplier_parts
from simplexspline.aero.selection.kink_location import place_kink, round_breakpoint
from simplexspline.aero.selection.moves import kink_positions, kinked_variable, with_breakpoint
from simplexspline.aero.selection.search import (
    PLAIN_FIT,
    SelectionSettings,
    fit_structure,
    select_structure,
)

#: Flight conditions flown at a few Mach numbers: the data's quantiles cluster at them
#: (each maneuver's Mach varies by up to +-0.012 about its condition, so the data cover
#: 0.628-0.672 continuously, between the candidates near 0.64 and 0.66).
CONDITIONS = (0.3, 0.42, 0.5, 0.55, 0.64, 0.66, 0.7, 0.8, 0.85)
#: Where the slope changes: inside the data, and no candidate position within 0.005 (the
#: quantiles nearby: 0.65, 0.66, 0.677).
KINK = 0.668


def _campaign(kink: float, seed: int = 1, n_man: int = 40, noise: float = 1e-5):
    """Maneuvers at the conditions; a sideslip derivative that starts to change at Mach
    ``kink`` (the shape of the F-16's Clb_M table)."""
    rng = np.random.default_rng(seed)
    t = np.arange(300) * 0.02
    cols = {k: [] for k in ("alpha", "mach", "beta", "truth", "man")}
    for m in range(n_man):
        def wave(amp, centre=0.0):
            f, ph = rng.uniform(0.1, 1.0, 3), rng.uniform(0, 2 * np.pi, 3)
            return centre + amp * np.sin(2 * np.pi * f[:, None] * t + ph[:, None]).sum(0) / 3

        alpha, beta = wave(0.05, 0.05), wave(0.06)
        mach = CONDITIONS[m % len(CONDITIONS)] + wave(0.012)
        truth = -0.1 * beta * (1 + alpha) - 0.9 * beta * np.maximum(mach - kink, 0.0)
        for k, v in (("alpha", alpha), ("mach", mach), ("beta", beta), ("truth", truth),
                     ("man", np.full(t.size, m))):
            cols[k].append(v)
    d = {k: np.concatenate(v) for k, v in cols.items()}
    d["y"] = d["truth"] + noise * rng.standard_normal(d["truth"].size)
    return d


def _sse(d):
    data = {k: d[k] for k in ("alpha", "mach", "beta")}

    def sse(s):
        r = d["y"] - fit_structure(s, data, d["y"], PLAIN_FIT).predict(data)
        return float(r @ r)
    return sse


def test_kink_terms_are_read_and_moved_with_their_other_factors_kept():
    assert kinked_variable("beta*|mach-0.612|[alpha]") == ("mach", 0.612)
    assert kinked_variable("|de+0.0663|[alpha/mach]") == ("de", -0.0663)
    assert kinked_variable("beta*beta") is None
    assert with_breakpoint("beta*|mach-0.612|[alpha]", 0.6) == "beta*|mach-0.6|[alpha]"
    assert with_breakpoint("|de+0.0663|[alpha/mach]", 0.01) == "|de-0.01|[alpha/mach]"
    assert with_breakpoint("dr*|alpha-0.1|", -0.02) == "dr*|alpha+0.02|"
    with pytest.raises(ValueError, match="exactly one kink"):
        with_breakpoint("beta*phat", 0.1)
    assert round_breakpoint(0.60049) == 0.6 and round_breakpoint(-0.0004256) == -0.000426


def test_a_kink_between_clustered_quantiles_is_moved_onto_the_slope_change():
    """The slope changes at Mach 0.668, near a condition's edge; the candidate positions
    are the data's quantiles (clustered at the conditions), none within 0.005 of it. From
    the nearest candidate above, the kink goes to 0.668 within the rounding, and the
    model's error against the truth drops."""
    d = _campaign(kink=KINK)
    data = {k: d[k] for k in ("alpha", "mach", "beta")}
    assert (np.abs(data["mach"] - KINK) < 0.002).sum() > 100       # data at the kink
    positions = kink_positions(data, ["mach"])["mach"]
    assert min(abs(k - KINK) for k in positions) > 0.005, positions
    start_k = min((k for k in positions if k > KINK), key=lambda k: k - KINK)
    term = f"beta*|mach-{start_k:g}|[alpha]"
    s = parse_structure(f"Cl(alpha:2, mach | 1, beta, {term}) S^1_2")
    sse = _sse(d)
    moved, e = place_kink(s, term, positions, sse)
    (k,) = [k for t in moved.multipliers for c, a, k in multiplier_parts(t) if a]
    assert abs(k - KINK) < 0.002, moved.label()
    assert e < 0.1 * sse(s)

    def rms_true(st):
        m = fit_structure(st, data, d["y"], PLAIN_FIT)
        return float(np.sqrt(np.mean((m.predict(data) - d["truth"]) ** 2)))
    assert rms_true(moved) < 0.2 * rms_true(s)


def test_a_kink_in_place_stays_and_a_second_one_keeps_its_distance():
    d = _campaign(kink=0.7, seed=2)
    data = {k: d[k] for k in ("alpha", "mach", "beta")}
    positions = kink_positions(data, ["mach"])["mach"]
    k0 = min(positions, key=lambda k: abs(k - 0.7))
    s = parse_structure(f"Cl(alpha:2, mach | 1, beta, beta*|mach-{k0:g}|[alpha]) S^1_2")
    sse = _sse(d)
    same, e = place_kink(s, f"beta*|mach-{k0:g}|[alpha]", positions, sse)
    assert abs(kinked_variable(same.multipliers[-1])[1] - 0.7) < 0.003
    # a second kink of the same term, two candidate positions below: it may not land
    # on the first (that would repeat the term)
    i = list(positions).index(k0)
    second = f"beta*|mach-{positions[i - 2]:g}|[alpha]"
    s2 = same.with_(multipliers=(*same.multipliers, second))
    moved, _e = place_kink(s2, second, positions, sse)
    ks = sorted(kinked_variable(t)[1] for t in moved.multipliers if kinked_variable(t))
    assert len(set(moved.multipliers)) == len(moved.multipliers)
    assert ks[1] - ks[0] > 0.2 * (positions[i] - positions[i - 2])
    with pytest.raises(ValueError, match="not a kink term"):
        place_kink(s, "beta", positions, sse)
    with pytest.raises(ValueError, match="not a kink term"):
        place_kink(s, "beta*|mach-0.5|[alpha]", positions, sse)


def test_the_search_moves_the_kink_it_added_and_says_so():
    """Start without the kink: with ``place_kinks`` the search adds one at a quantile and
    moves it onto the slope change (Mach 0.668, 0.005 or more from every quantile), as a
    'move kink' trial; without, the kink stays at a quantile."""
    d = _campaign(kink=KINK, seed=3, noise=2e-4)
    data = {k: d[k] for k in ("alpha", "mach", "beta")}
    start = parse_structure("Cl(alpha:2, mach | 1, beta) S^1_2")
    settings = SelectionSettings(max_rounds=2, max_samples=20_000,
                                 moves=("degree", "kinks"), place_kinks=True)

    def kinks(structure):
        return [k for t in structure.multipliers for c, a, k in multiplier_parts(t)
                if c == "mach" and a]
    best, history = select_structure(start, data, d["y"], d["man"], settings)
    assert kinks(best) and min(abs(k - KINK) for k in kinks(best)) < 0.003, best.label()
    moves = [t for t in history if t.move.startswith("move kink") and t.accepted]
    assert moves, [t.move for t in history]
    best, history = select_structure(start, data, d["y"], d["man"],
                                     replace(settings, place_kinks=False))
    assert not any(t.move.startswith("move kink") for t in history)
    assert kinks(best) and min(abs(k - KINK) for k in kinks(best)) > 0.005, best.label()
