"""Input signals: 3211 and doublet shapes, sum-of-sines spectra, randomised designs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplexspline.errors import InputError
from simplexspline.sim import MANEUVER_TYPES, get_aircraft
from simplexspline.sim.maneuvers import (
    EIGENMOTION_TAIL_S,
    LEAD_S,
    PHUGOID_PERIODS,
    PULSE_PATTERNS,
    phugoid_period,
    design_maneuver,
    excitation,
    peak_factor,
    multisine,
    pulse_shape,
)


def test_3211_pulse_train():
    t = np.arange(0, 5, 0.01)
    s = pulse_shape(t, 0.5, (3, 2, 1, 1))
    expected = np.select([t < 1.5, t < 2.5, t < 3.0, t < 3.5], [1.0, -1.0, 1.0, -1.0], 0.0)
    assert np.array_equal(s, expected)


def test_single_pulse():
    t = np.arange(-1, 3, 0.01)
    s = pulse_shape(t, 1.5, PULSE_PATTERNS["pulse"])
    assert np.array_equal(s, np.select([t < 0, t < 1.5], [0.0, 1.0], 0.0))


def test_doublet():
    t = np.arange(-1, 3, 0.01)
    s = pulse_shape(t, 1.0, (1, 1))
    assert np.array_equal(s, np.select([t < 0, t < 1, t < 2], [0.0, 1.0, -1.0], 0.0))


def test_multisine_unit_rms_and_spectrum():
    duration = 100.0
    t = np.arange(0, duration, 0.01)
    freqs = [0.11, 0.37, 0.93, 1.51]
    s = multisine(t, freqs, [0.1, 2.0, 4.0, 1.0], duration)
    core = s[(t > 3) & (t < duration - 3)]
    assert np.sqrt(np.mean(core**2)) == pytest.approx(1.0, rel=0.05)
    spec = np.abs(np.fft.rfft(s))
    f = np.fft.rfftfreq(len(t), 0.01)
    peaks = f[np.argsort(spec)[-4:]]
    assert np.allclose(np.sort(peaks), freqs, atol=0.011)
    assert s[0] == 0.0 and abs(s[-1]) < 1e-3  # tapered ends


@pytest.mark.parametrize("aircraft", ["f16", "global5000", "c172p", "A4", "737", "T37"])
def test_designs_respect_the_profile(aircraft, rng):
    prof = get_aircraft(aircraft)
    for kind in MANEUVER_TYPES:
        d = design_maneuver(kind, prof, rng)
        assert d["type"] == kind
        if kind == "sum-of-sines":
            assert 90 <= d["signal_s"] <= 110
            sets = [set(np.round(np.asarray(f) * d["signal_s"]).astype(int))
                    for f in d["freqs_hz"]]
            assert all(len(s) == len(f) for s, f in zip(sets, d["freqs_hz"]))
            assert not (sets[0] & sets[1] or sets[0] & sets[2] or sets[1] & sets[2])
            lo, hi = prof.sos_band_hz
            assert all(lo - 0.05 <= x <= hi + 0.05 for f in d["freqs_hz"] for x in f)
            assert abs(d["bank"]) <= prof.sos_bank
        else:
            i = ("elevator", "aileron", "rudder").index(d["axis"])
            lo, hi = prof.pulse_accel[i]
            assert lo <= abs(d["accel"]) <= hi
            n_units = sum(PULSE_PATTERNS[kind.split("-")[0]])
            assert d["pattern"] == list(PULSE_PATTERNS[kind.split("-")[0]])
            assert d["duration_s"] == pytest.approx(LEAD_S + n_units * d["unit_s"] + 7.0)


def test_excitation_amplitude_is_capped_and_signed():
    prof = get_aircraft("f16")
    d = design_maneuver("3211-rudder", prof, np.random.default_rng(0))
    n = int(d["duration_s"] / 0.01)
    limits = tuple(s.limit for s in prof.surfaces)
    x = excitation(d, n, 0.01, (1.0, 1.0, -100.0), limits)
    assert np.all(x[:, :2] == 0)
    assert np.max(np.abs(x[:, 2])) == pytest.approx(0.8 * limits[2])
    assert np.all(x[: int(LEAD_S / 0.01), 2] == 0)
    first = x[int(LEAD_S / 0.01), 2]
    assert math.copysign(1, first) == -math.copysign(1, d["accel"])


def test_unknown_maneuver_type():
    with pytest.raises(InputError, match="unknown maneuver type 'loop'"):
        design_maneuver("loop", get_aircraft("f16"), np.random.default_rng(0))


@pytest.mark.parametrize("aircraft", ["f16", "c172p"])
def test_alternative_design_differs_from_the_paper(aircraft):
    """Longer 3211 pulses, fewer sines evenly spread in a narrower band, lower peak factor."""
    prof = get_aircraft(aircraft)
    paper = [design_maneuver("3211-elevator", prof, np.random.default_rng(i))
             for i in range(20)]
    alt = [design_maneuver("3211-elevator", prof, np.random.default_rng(i), design="alternative")
           for i in range(20)]
    lo, hi = prof.pulse_unit_s
    assert all(0.5 * (lo + hi) <= d["unit_s"] <= 1.6 * hi for d in alt)
    assert np.mean([d["unit_s"] for d in alt]) > np.mean([d["unit_s"] for d in paper])
    crest = {}
    for design in ("paper", "alternative"):
        sos = [design_maneuver("sum-of-sines", prof, np.random.default_rng(i), design=design)
               for i in range(6)]
        crest[design] = np.mean([peak_factor(f, ph, d["signal_s"]) for d in sos
                                 for f, ph in zip(d["freqs_hz"], d["phases"])])
        n = [len(f) for d in sos for f in d["freqs_hz"]]
        assert set(n) == ({16} if design == "paper" else {10})
    assert crest["alternative"] < crest["paper"]
    band_lo, band_hi = prof.sos_band_hz
    assert all(1.5 * band_lo - 0.02 <= x <= 0.7 * band_hi + 0.02 for d in sos
               for f in d["freqs_hz"] for x in f)


def test_peak_factor_of_one_sine_and_of_aligned_sines():
    assert peak_factor([0.5], [0.0], 10.0) == pytest.approx(1.0, rel=1e-3)
    # n sines in phase at t = 0 (cosines) peak at n with RMS sqrt(n / 2): factor sqrt(n)
    assert peak_factor([0.1, 0.2, 0.3, 0.4], [math.pi / 2] * 4, 10.0) == pytest.approx(2.0)


def test_unknown_excitation_design():
    with pytest.raises(InputError, match="unknown excitation design 'mine'"):
        design_maneuver("3211-rudder", get_aircraft("f16"), np.random.default_rng(0),
                        design="mine")


@pytest.mark.parametrize("aircraft", ["global5000", "c172p"])
def test_eigenmotion_design_is_the_flight_test_courses(aircraft):
    """Single pulses and doublets in the lower half of the profile's amplitudes, each with
    its eigenmotion's free response: the phugoid's 1-1.5 periods at the profile's median
    airspeed after an elevator pulse, the others' seconds from the table."""
    prof = get_aircraft(aircraft)
    period = phugoid_period(float(np.median(prof.airspeeds_mps)))
    assert period == pytest.approx(math.pi * math.sqrt(2) * np.median(prof.airspeeds_mps)
                                   / 9.80665)
    for fam in ("pulse", "doublet"):
        for axis in ("elevator", "aileron", "rudder"):
            for i in range(10):
                d = design_maneuver(f"{fam}-{axis}", prof, np.random.default_rng(i),
                                    design="eigenmotion")
                a_lo, a_hi = prof.pulse_accel[("elevator", "aileron", "rudder").index(axis)]
                assert abs(d["accel"]) <= 0.5 * (a_lo + a_hi) + 1e-12
                if (fam, axis) == ("pulse", "elevator"):
                    lo, hi = (x * period for x in PHUGOID_PERIODS)
                    assert abs(d["accel"]) <= 0.6 * a_lo
                else:
                    lo, hi = EIGENMOTION_TAIL_S[fam, axis]
                assert lo <= d["tail_s"] <= hi
                assert d["duration_s"] == pytest.approx(
                    LEAD_S + sum(PULSE_PATTERNS[fam]) * d["unit_s"] + d["tail_s"])
                if fam == "pulse":
                    assert d["unit_s"] >= 2.0 * prof.pulse_unit_s[1]


def test_eigenmotion_design_has_no_3211_or_sum_of_sines():
    prof = get_aircraft("global5000")
    for kind in ("3211-aileron", "sum-of-sines"):
        with pytest.raises(InputError, match="pulses and doublets only"):
            design_maneuver(kind, prof, np.random.default_rng(0), design="eigenmotion")
