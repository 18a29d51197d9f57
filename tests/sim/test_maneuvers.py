"""Input signals: 3211 and doublet shapes, sum-of-sines spectra, randomised designs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplexspline.errors import InputError
from simplexspline.sim import MANEUVER_TYPES, get_aircraft
from simplexspline.sim.maneuvers import (
    LEAD_S,
    design_maneuver,
    excitation,
    multisine,
    pulse_shape,
)


def test_3211_pulse_train():
    t = np.arange(0, 5, 0.01)
    s = pulse_shape(t, 0.5, (3, 2, 1, 1))
    expected = np.select([t < 1.5, t < 2.5, t < 3.0, t < 3.5], [1.0, -1.0, 1.0, -1.0], 0.0)
    assert np.array_equal(s, expected)


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


@pytest.mark.parametrize("aircraft", ["f16", "global5000"])
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
            n_units = 7 if kind.startswith("3211") else 2
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
