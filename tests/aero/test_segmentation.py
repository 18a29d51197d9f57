"""Whole flights cut into maneuvers: excitation against the quiet level around it, 'auto'."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from simplexspline.aero.data.record_import import import_record
from simplexspline.aero.data.segmentation import detect_excitation

DATA = Path(__file__).resolve().parents[1] / "data" / "citation_like"


def _flight(seed: int = 0):
    """30 minutes at 10 Hz: turbulence 4x stronger in the first half (low down; it fades in
    a 200 s climb), a 3211-like pulse train every 150 s."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 1800.0, 0.1)
    sigma = np.interp(t, [0.0, 850.0, 1050.0, 1800.0], [4.0, 4.0, 1.0, 1.0]) * 1e-3
    # turbulence: smooth noise (1 s correlation)
    de = np.convolve(rng.standard_normal(t.size), np.ones(10) / np.sqrt(10), "same") * sigma
    starts = np.arange(60.0, 1750.0, 150.0)
    for s in starts:
        for k, (a, b) in enumerate([(0, 3), (3, 5), (5, 6), (6, 7)]):
            on = (t >= s + a) & (t < s + b)
            de[on] += (-1) ** k * 0.02 * (4.0 if s < 900 else 1.0) ** 0.5
    return t, {"de": de}, starts


def test_turbulent_stretches_are_not_maneuvers_and_every_pulse_train_is():
    t, data, starts = _flight()
    usable = np.ones(t.size, bool)
    segs, _ = detect_excitation(t, data, usable)
    segs = [s for s in segs if s.end - s.start >= 5.0]      # the import's min_duration_s
    assert len(segs) == len(starts)
    for s, start in zip(segs, starts):
        assert s.start <= start + 1.0 and s.end >= start + 6.0 and s.end - s.start < 20.0
    # one quiet level for the record (the method before) takes the turbulent half for
    # maneuvers: many more segments, some spanning several pulse trains
    old, _ = detect_excitation(t, data, usable, threshold=10.0, merge_s=4.0, quiet_s=0.0)
    assert len(old) != len(starts) or any(s.end - s.start > 150.0 for s in old)


def _mapping(tmp_path, segments: str) -> Path:
    text = (DATA / "mapping.toml").read_text().replace('path = "."', f'path = "{DATA}"')
    text = text[:text.index("[segments]")] + segments
    path = tmp_path / "mapping.toml"
    path.write_text(text)
    return path


def test_without_segments_a_flight_is_cut_by_excitation(tmp_path):
    result = import_record(_mapping(tmp_path, ""))
    assert [s["type"] for s in result.segments()] == ["excitation-elevator",
                                                      "excitation-aileron",
                                                      "excitation-elevator"]
    assert result.segment_notes[0] == "method 'auto': segments by excitation"


def test_auto_falls_back_to_the_airborne_stretch_of_a_one_maneuver_record(tmp_path):
    result = import_record(_mapping(tmp_path, "[segments]\nthreshold = 1e9\n"))
    assert [s["type"] for s in result.segments()] == ["flight"]
    assert any("excitation detection found 0 maneuver(s); every airborne stretch is one "
               "instead" in n for n in result.segment_notes)


@pytest.mark.parametrize("value", ["-1", "\"300 s\""])
def test_quiet_window_must_be_a_number(tmp_path, value):
    from simplexspline.errors import InputError

    with pytest.raises(InputError, match=r"segments.quiet_s.*finite number"):
        import_record(_mapping(tmp_path, f"[segments]\nmethod = \"excitation\"\n"
                                         f"quiet_s = {value}\n"))


def test_a_turn_is_found_by_its_heading_change_and_absorbs_its_entry_and_exit():
    """A 90 deg turn at 1.5 deg/s (rolled in and out over 5 s) and an aileron doublet that
    moves the heading back and forth: one turn, from its roll-in to its roll-out; the
    doublet is not a turn. The maneuvers detected at its entry and exit become part of it
    (one maneuver from the roll-in to the roll-out), a maneuver elsewhere stays."""
    from simplexspline.aero.data.segmentation import (Segment, absorb, absorb_turns,
                                                      detect_turns)
    from simplexspline.aero.reconstruction.wind_triangle import MIN_HEADING_CHANGE

    t = np.arange(0.0, 350.0, 0.1)
    rate = np.interp(t, [100.0, 105.0, 160.0, 165.0], [0.0, 1.5, 1.5, 0.0]) * np.pi / 180
    rate = np.where((t > 100) & (t < 165), rate, 0.0)
    rate += np.where((t > 250) & (t < 260), 2.0 * np.sin(2 * np.pi * (t - 250) / 5.0), 0.0) \
        * np.pi / 180
    phi = np.where(rate != 0, 0.3 * np.sign(rate), 0.0)
    data = {"q": rate * np.sin(phi), "r": rate * np.cos(phi), "phi": phi,
            "theta": np.full(t.size, 0.05)}
    data["r"] = data["r"] * np.cos(data["theta"])
    data["q"] = data["q"] * np.cos(data["theta"])
    turns = detect_turns(t, data, np.ones(t.size, bool), min_change=MIN_HEADING_CHANGE)
    assert len(turns) == 1 and turns[0].type == "turn"
    assert 96.0 < turns[0].start < 104.0 and 161.0 < turns[0].end < 169.0
    assert detect_turns(t, {"q": data["q"]}, np.ones(t.size, bool), min_change=0.3) == []
    entry, exit_ = Segment(95.0, 108.0, "excitation-aileron"), Segment(158.0, 170.0, "x")
    other = Segment(250.0, 262.0, "excitation-aileron")
    whole, rest = absorb(turns[0], [exit_, other, entry])
    assert whole == Segment(95.0, 170.0, "turn") and rest == [other]
    assert absorb(turns[0], [other]) == (turns[0], [other])
    # an S-turn: two turns whose padding overlaps become one, with what they overlap
    second = Segment(168.0, 200.0, "turn")
    merged, n = absorb_turns([entry, exit_, other], [turns[0], second])
    assert merged == [Segment(95.0, 200.0, "turn"), other] and n == 1


def test_the_turns_between_detected_maneuvers_become_maneuvers_unless_switched_off(tmp_path):
    """tests/data/citation_like flies straight: no turn is added, and the key must be a
    boolean."""
    from simplexspline.errors import InputError

    assert not any("turn(s) cut" in n for n in import_record(_mapping(tmp_path, ""))
                   .segment_notes)
    off = import_record(_mapping(tmp_path, "[segments]\nturns = false\n"))
    assert [s["type"] for s in off.segments()] == ["excitation-elevator",
                                                   "excitation-aileron",
                                                   "excitation-elevator"]
    with pytest.raises(InputError, match=r"turns.*must be true or false"):
        import_record(_mapping(tmp_path, "[segments]\nturns = \"yes\"\n"))


def test_stationary_measurements_are_found_between_the_maneuvers():
    """A course at 10 Hz: a stationary measurement at 60 m/s (90 s) with a maneuver inside
    it, an acceleration to 70 m/s (40 s), a second at 70 m/s (60 s) whose last 20 s climb
    60 m, a turn, a third of 20 s only. Found: the first's parts either side of the
    maneuver (40 s each), the second's level part; not the acceleration, the climb, the
    turn (banked 23 deg: the bank band stops the level stretch before it at 30 s, less
    the smoothing) or the short one."""
    from simplexspline.aero.data.segmentation import (STEADY_MIN_S, Segment, detect_steady)

    rng = np.random.default_rng(3)
    t = np.arange(0.0, 350.0, 0.1)
    tas = np.interp(t, [0, 90, 130, 400], [60.0, 60.0, 70.0, 70.0])
    h = 1000.0 + np.interp(t, [0, 190, 210, 400], [0.0, 0.0, 60.0, 60.0])
    turning = (t > 230) & (t < 330)
    rate = np.where(turning, 3.0 * np.pi / 180, 0.0)
    phi = np.where(turning, 0.4, 0.0)
    data = {"tas": tas + 0.1 * rng.standard_normal(t.size),
            "h": h + 1.0 * rng.standard_normal(t.size),
            "q": rate * np.sin(phi), "r": rate * np.cos(phi), "phi": phi,
            "theta": np.full(t.size, 0.02)}
    others = [Segment(40.0, 50.0, "excitation-elevator")]
    found = detect_steady(t, data, np.ones(t.size, bool), others)
    assert all(s.type == "steady" and s.end - s.start >= STEADY_MIN_S for s in found)
    spans = [(round(s.start), round(s.end)) for s in found]
    assert len(found) == 3, spans
    assert found[0].start == 0.0 and 39.0 <= found[0].end <= 40.0        # before the maneuver
    assert 50.0 <= found[1].start <= 51.0 and 86.0 <= found[1].end <= 100.0  # after it
    assert 118.0 <= found[2].start <= 132.0 and 188.0 <= found[2].end <= 202.0  # at 70 m/s
    assert detect_steady(t, {"tas": data["tas"]}, np.ones(t.size, bool), []) == []


def test_stationary_measurements_can_be_switched_off_and_the_key_is_a_boolean(tmp_path):
    from simplexspline.errors import InputError

    on = import_record(_mapping(tmp_path, ""))
    off = import_record(_mapping(tmp_path, "[segments]\nsteady = false\n"))
    assert not any(s["type"] == "steady" for s in off.segments())
    assert len(on.segments()) >= len(off.segments())
    with pytest.raises(InputError, match=r"steady.*must be true or false"):
        import_record(_mapping(tmp_path, "[segments]\nsteady = 1\n"))


def _gusts(rng, n: int, dt: float, tau: float, sd: float) -> np.ndarray:
    """First-order Gauss-Markov noise: correlation time ``tau`` [s], standard deviation
    ``sd``."""
    a = np.exp(-dt / tau)
    w = rng.standard_normal(n) * sd * np.sqrt(1.0 - a * a)
    out = np.empty(n)
    out[0] = sd * rng.standard_normal()
    for i in range(1, n):
        out[i] = a * out[i - 1] + w[i]
    return out


def test_stationary_measurements_in_turbulence_are_found_and_turns_are_not():
    """Light turbulence at 10 Hz: the airspeed fluctuates by 1 m/s (3 s correlation),
    the altitude by 5 m, the heading rate by 0.2 deg/s, so the 2 s means leave the fixed
    2 m/s band and the heading rate crosses the turn threshold every few seconds. A
    90 s stationary measurement at 60 m/s is found (most of it); the acceleration to
    70 m/s (0.25 m/s^2 over 40 s) and a slow 1 deg/s turn of 60 s in the same
    turbulence are not. Without the gust-scaled bands none was found."""
    from simplexspline.aero.data.segmentation import detect_steady

    rng = np.random.default_rng(11)
    dt = 0.1
    t = np.arange(0.0, 260.0, dt)
    tas = np.interp(t, [0, 90, 130, 400], [60.0, 60.0, 70.0, 70.0])
    turn = (t >= 150) & (t < 210)
    rate = np.where(turn, np.radians(1.0), 0.0) + _gusts(rng, t.size, dt, 2.0,
                                                           np.radians(0.2))
    phi = np.where(turn, 0.05, 0.0) + _gusts(rng, t.size, dt, 2.0, 0.01)
    theta = 0.03 + _gusts(rng, t.size, dt, 2.0, 0.005)
    data = {"tas": tas + _gusts(rng, t.size, dt, 3.0, 1.0),
            "h": 1000.0 + _gusts(rng, t.size, dt, 10.0, 5.0),
            "phi": phi, "theta": theta,
            # the Euler heading rate (q sin(phi) + r cos(phi)) / cos(theta) is ``rate``
            "q": rate * np.sin(phi) * np.cos(theta), "r": rate * np.cos(phi) * np.cos(theta)}
    found = detect_steady(t, data, np.ones(t.size, bool), [])
    spans = [(round(s.start), round(s.end)) for s in found]
    covered = np.zeros(t.size, bool)
    for s in found:
        covered |= (t >= s.start) & (t <= s.end)
    assert covered[t < 90].mean() > 0.8, spans            # the stationary measurement
    assert not covered[(t > 102) & (t < 118)].any(), spans  # not the acceleration
    assert not covered[(t > 165) & (t < 195)].any(), spans  # not the turn
    # the fixed bands alone (band_sigmas = 0) find nothing here
    assert detect_steady(t, data, np.ones(t.size, bool), [], band_sigmas=0.0) == []
