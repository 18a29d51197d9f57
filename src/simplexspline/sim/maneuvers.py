"""Maneuver input signals: 3211 pulse trains, doublets, single pulses and multi-axis sums
of sines.

The paper's design follows Section IV of de Visser, Mulder and Chu (AIAA 2010-7950): short,
large-amplitude automatic 3211 pulse sets on one surface, and ~100 s semi-random
sum-of-sines disturbance signals on all three axes while a pilot holds straight and level.
The 'eigenmotion' design is the textbook flight-test course's instead: single pulses and
doublets at small amplitudes, each followed by a long free response (phugoid, short
period, aperiodic roll, Dutch roll), the maneuvers of a real training-flight record.

A design is plain data (a dict of numbers and lists). Amplitudes are angular accelerations
[rad/s^2]: :func:`excitation` turns them into surface deflections with the aircraft's
control power and the dynamic pressure at the trim point, so one design scales sensibly
from 120 to 260 m/s.
"""

from __future__ import annotations

import math

import numpy as np

from simplexspline.errors import InputError
from simplexspline.sim.aircraft import AircraftProfile

__all__ = [
    "AXES",
    "MANEUVER_FAMILIES",
    "MANEUVER_TYPES",
    "EXCITATION_DESIGNS",
    "PULSE_PATTERNS",
    "design_maneuver",
    "phugoid_period",
    "excitation",
    "pulse_shape",
    "multisine",
]

#: Control axes in the order (elevator, aileron, rudder).
AXES = ("elevator", "aileron", "rudder")
#: Families a campaign mixes; the pulse families are flown on one axis at a time.
MANEUVER_FAMILIES = ("3211", "doublet", "pulse", "sum-of-sines")
#: Pulse families and their patterns (pulse lengths in units, alternating sign).
PULSE_PATTERNS = {"3211": (3, 2, 1, 1), "doublet": (1, 1), "pulse": (1,)}
#: Every ``maneuver_type`` value the simulator writes.
MANEUVER_TYPES = tuple(f"{fam}-{ax}" for fam in PULSE_PATTERNS for ax in AXES) + (
    "sum-of-sines",
)

#: Excitation designs: the paper's (the project was developed on it) and an alternative one.
EXCITATION_DESIGNS = {
    "paper": "3211 pulse units from the profile's range, doublets at 1.5-2x that; 16 sines "
             "per axis log-spread over the profile's band, random phases",
    "alternative": "3211 pulse units from the upper half of the profile's range to 1.6x its "
                   "top, doublets at 0.7-1.2x; 10 sines per axis evenly spread over a band "
                   "shifted to 1.5x-0.7x the profile's, phases chosen for a low peak factor",
    "eigenmotion": "the flight-test course's: single pulses and doublets in the lower half "
                   "of the profile's amplitudes, each followed by a long free response (an "
                   "elevator pulse then 1-1.5 phugoid periods, an aileron pulse then 10-25 s "
                   "of aperiodic roll and spiral, a rudder doublet then 15-25 s of Dutch "
                   "roll, an elevator doublet then 6-10 s of short period); no 3211s, no "
                   "sums of sines",
}
#: Free response after each pulse family and axis in the eigenmotion design [s]; the
#: elevator pulse's (the phugoid) is given in phugoid periods instead.
EIGENMOTION_TAIL_S = {("pulse", "aileron"): (10.0, 25.0), ("pulse", "rudder"): (12.0, 20.0),
                      ("doublet", "elevator"): (6.0, 10.0),
                      ("doublet", "aileron"): (8.0, 12.0),
                      ("doublet", "rudder"): (15.0, 25.0)}
PHUGOID_PERIODS = (1.0, 1.5)  #: free response after the phugoid's elevator pulse
ALT_SOS_COMPONENTS = 10  #: sinusoids per axis in the alternative design
ALT_PHASE_TRIALS = 32  #: random phase sets tried per axis for a low peak factor

LEAD_S = 2.0  #: trimmed flight recorded before the input starts [s]
TAIL_S = 7.0  #: free response recorded after a pulse input [s]
TAPER_S = 3.0  #: cosine fade-in/fade-out of the sum-of-sines signal [s]
SOS_COMPONENTS = 16  #: sinusoids per axis in the sum-of-sines signal


def pulse_shape(t: np.ndarray, unit: float, pattern: tuple) -> np.ndarray:
    """Unit-amplitude pulse train.

    Parameters
    ----------
    t : (n,) ndarray
        Time since the start of the pulse train [s].
    unit : float
        Pulse unit [s].
    pattern : tuple of int
        Pulse lengths in units with alternating sign, e.g. (3, 2, 1, 1) for a 3211 and
        (1, 1) for a doublet.

    Returns
    -------
    (n,) ndarray
        +1/-1 during the pulses (starting with +1), 0 elsewhere.
    """
    out = np.zeros_like(t, dtype=float)
    start, sign = 0.0, 1.0
    for length in pattern:
        stop = start + length * unit
        out[(t >= start) & (t < stop)] = sign
        start, sign = stop, -sign
    return out


def multisine(t: np.ndarray, freqs_hz, phases, duration: float) -> np.ndarray:
    """Sum of equal-amplitude sines scaled to unit RMS, with cosine tapers at both ends.

    Parameters
    ----------
    t : (n,) ndarray
        Time since the start of the signal [s]; zero outside [0, duration].
    freqs_hz, phases : (m,) array_like
        Component frequencies [Hz] and phases [rad].
    duration : float
        Signal length [s].
    """
    f = np.asarray(freqs_hz, dtype=float)
    ph = np.asarray(phases, dtype=float)
    s = np.sin(2 * math.pi * np.outer(t, f) + ph).sum(axis=1) / math.sqrt(len(f) / 2.0)
    ramp = np.clip(np.minimum(t, duration - t) / TAPER_S, 0.0, 1.0)
    return s * 0.5 * (1 - np.cos(math.pi * ramp))


def _sos_frequencies(rng: np.random.Generator, band: tuple, duration: float) -> list:
    """Disjoint (interleaved harmonic) frequency sets per axis, log-spread over the band."""
    lo, hi = band
    k0 = max(1, math.ceil(lo * duration))
    k1 = max(k0 + 3 * SOS_COMPONENTS, math.floor(hi * duration))
    out = []
    for axis in range(3):
        harmonics = np.arange(k0 + axis, k1 + 1, 3)
        # log-uniform targets, then the nearest unused harmonic
        targets = np.exp(rng.uniform(math.log(harmonics[0]), math.log(harmonics[-1]),
                                     SOS_COMPONENTS))
        chosen: set[int] = set()
        for target in np.sort(targets):
            order = np.argsort(np.abs(harmonics - target), kind="stable")
            for j in order:
                if int(harmonics[j]) not in chosen:
                    chosen.add(int(harmonics[j]))
                    break
        out.append(sorted(h / duration for h in chosen))
    return out


def _even_frequencies(band: tuple, duration: float) -> list:
    """Evenly spread, axis-interleaved harmonic sets (the alternative design)."""
    lo, hi = band
    k0 = max(1, math.ceil(lo * duration))
    k1 = max(k0 + 3 * ALT_SOS_COMPONENTS, math.floor(hi * duration))
    out = []
    for axis in range(3):
        harmonics = np.arange(k0 + axis, k1 + 1, 3)
        pick = np.unique(np.round(np.linspace(0, len(harmonics) - 1,
                                              ALT_SOS_COMPONENTS)).astype(int))
        out.append([float(h) / duration for h in harmonics[pick]])
    return out


def peak_factor(freqs_hz, phases, duration: float, n: int = 2000) -> float:
    """Peak / (sqrt(2) RMS) of a multisine over one signal length (1 for a single sine)."""
    t = np.linspace(0.0, duration, n, endpoint=False)
    s = np.sin(2 * math.pi * np.outer(t, freqs_hz) + np.asarray(phases)).sum(axis=1)
    return float(np.abs(s).max() / (math.sqrt(2.0) * np.sqrt(np.mean(s * s))))


def _low_peak_phases(rng: np.random.Generator, freqs: list, duration: float) -> list:
    """Of :data:`ALT_PHASE_TRIALS` random phase sets, the one with the lowest peak factor."""
    trials = [rng.uniform(0, 2 * math.pi, len(freqs)) for _ in range(ALT_PHASE_TRIALS)]
    best = min(range(ALT_PHASE_TRIALS), key=lambda j: peak_factor(freqs, trials[j], duration))
    return trials[best].tolist()


def _sum_of_sines(kind: str, profile: AircraftProfile, length: float, freqs: list,
                  phases: list, scale: float, bank: float) -> dict:
    """The record of a sum-of-sines maneuver (either design) from its drawn parameters."""
    return {"type": kind, "family": "sum-of-sines", "axis": None,
            "duration_s": LEAD_S + length + 1.0, "signal_s": length,
            "freqs_hz": freqs, "phases": phases,
            "accel_rms": [scale * a for a in profile.sos_accel_rms], "bank": bank}


def _alternative_design(kind: str, profile: AircraftProfile, rng: np.random.Generator,
                        sos_duration_s: tuple, turn_fraction: float) -> dict:
    if kind == "sum-of-sines":
        length = float(rng.uniform(*sos_duration_s))
        lo, hi = profile.sos_band_hz
        freqs = _even_frequencies((1.5 * lo, max(0.7 * hi, 3.0 * lo)), length)
        phases = [_low_peak_phases(rng, f, length) for f in freqs]
        scale = float(rng.uniform(0.7, 1.1))
        turning = rng.random() < turn_fraction
        bank = float(rng.uniform(0.2, 0.8) * profile.sos_bank * (1 if rng.random() < 0.5 else -1))
        return _sum_of_sines(kind, profile, length, freqs, phases, scale,
                             bank if turning else 0.0)
    family, axis = kind.split("-", 1)
    iaxis = AXES.index(axis)
    lo, hi = profile.pulse_unit_s
    lo, hi = (0.7 * lo, 1.2 * hi) if family != "3211" else (0.5 * (lo + hi), 1.6 * hi)
    unit = float(rng.uniform(lo, hi))
    a_lo, a_hi = profile.pulse_accel[iaxis]
    # longer pulses build up larger responses: amplitudes from the lower part of the range
    amp = float(rng.uniform(0.6 * a_lo, 0.5 * (a_lo + a_hi))) * (1.0 if rng.random() < 0.5
                                                                 else -1.0)
    pattern = list(PULSE_PATTERNS[family])
    return {"type": kind, "family": family, "axis": axis,
            "duration_s": LEAD_S + sum(pattern) * unit + TAIL_S,
            "unit_s": unit, "pattern": pattern, "accel": amp}


def phugoid_period(tas_mps: float) -> float:
    """Lanchester's phugoid period ``pi sqrt(2) V / g`` [s] at true airspeed ``tas_mps``."""
    return math.pi * math.sqrt(2.0) * float(tas_mps) / 9.80665


def _eigenmotion_design(kind: str, profile: AircraftProfile, rng: np.random.Generator) -> dict:
    """A flight-test course maneuver: a pulse or doublet at the low end of the profile's
    amplitudes and a long free response (:data:`EXCITATION_DESIGNS` 'eigenmotion')."""
    family, _, axis = kind.partition("-")
    if family not in ("pulse", "doublet"):
        raise InputError(f"the eigenmotion design flies pulses and doublets only, not "
                         f"{kind!r}: give a mix of 'pulse' and 'doublet'")
    iaxis = AXES.index(axis)
    lo, hi = profile.pulse_unit_s
    a_lo, a_hi = profile.pulse_accel[iaxis]
    if family == "pulse":
        # a pulse two to four times the longest unit moves the speed (elevator: at a
        # third to two thirds of the lowest amplitude) or banks or yaws the aircraft,
        # and lets it go
        unit = float(rng.uniform(2.0 * hi, 4.0 * hi))
        amp = float(rng.uniform(0.3 * a_lo, 0.6 * a_lo) if axis == "elevator"
                    else rng.uniform(a_lo, 0.5 * (a_lo + a_hi)))
    else:
        unit = float(rng.uniform(1.5 * lo, 2.0 * hi))
        amp = float(rng.uniform(a_lo, 0.5 * (a_lo + a_hi)))
    if (family, axis) == ("pulse", "elevator"):
        period = phugoid_period(float(np.median(profile.airspeeds_mps)))
        tail = float(rng.uniform(*PHUGOID_PERIODS)) * period
    else:
        tail = float(rng.uniform(*EIGENMOTION_TAIL_S[family, axis]))
    pattern = list(PULSE_PATTERNS[family])
    return {"type": kind, "family": family, "axis": axis,
            "duration_s": LEAD_S + sum(pattern) * unit + tail, "tail_s": tail,
            "unit_s": unit, "pattern": pattern,
            "accel": amp * (1.0 if rng.random() < 0.5 else -1.0)}


def design_maneuver(kind: str, profile: AircraftProfile, rng: np.random.Generator,
                    sos_duration_s: tuple = (90.0, 110.0), turn_fraction: float = 0.5,
                    design: str = "paper") -> dict:
    """Randomised input design for one maneuver.

    Parameters
    ----------
    kind : str
        One of :data:`MANEUVER_TYPES`.
    profile : AircraftProfile
        Supplies the pulse-unit range, amplitude ranges and frequency band.
    rng : numpy.random.Generator
        The maneuver's design stream.
    sos_duration_s : (float, float)
        Range of sum-of-sines signal lengths [s].
    turn_fraction : float
        Probability that a sum-of-sines maneuver is flown in a level turn (bank up to
        ``profile.sos_bank``) instead of straight and level.
    design : str
        One of :data:`EXCITATION_DESIGNS`.

    Returns
    -------
    dict
        ``type``, ``duration_s`` (record length incl. lead-in and free response) and the
        signal parameters (plain numbers and lists).
    """
    if kind not in MANEUVER_TYPES:
        raise InputError(f"unknown maneuver type {kind!r}: choose one of {MANEUVER_TYPES}")
    if design not in EXCITATION_DESIGNS:
        raise InputError(f"unknown excitation design {design!r}: choose one of "
                         f"{list(EXCITATION_DESIGNS)}")
    if design == "alternative":
        return _alternative_design(kind, profile, rng, sos_duration_s, turn_fraction)
    if design == "eigenmotion":
        return _eigenmotion_design(kind, profile, rng)
    if kind == "sum-of-sines":
        length = float(rng.uniform(*sos_duration_s))
        freqs = _sos_frequencies(rng, profile.sos_band_hz, length)
        phases = [rng.uniform(0, 2 * math.pi, len(f)).tolist() for f in freqs]
        scale = float(rng.uniform(0.6, 1.0))
        turning = rng.random() < turn_fraction
        bank = float(rng.uniform(0.3, 1.0) * profile.sos_bank * (1 if rng.random() < 0.5 else -1))
        return _sum_of_sines(kind, profile, length, freqs, phases, scale,
                             bank if turning else 0.0)
    family, axis = kind.split("-", 1)
    iaxis = AXES.index(axis)
    lo, hi = profile.pulse_unit_s
    if family != "3211":
        lo, hi = 1.5 * lo, 2.0 * hi
    unit = float(rng.uniform(lo, hi))
    amp = float(rng.uniform(*profile.pulse_accel[iaxis])) * (1.0 if rng.random() < 0.5 else -1.0)
    pattern = list(PULSE_PATTERNS[family])
    return {"type": kind, "family": family, "axis": axis,
            "duration_s": LEAD_S + sum(pattern) * unit + TAIL_S,
            "unit_s": unit, "pattern": pattern, "accel": amp}


def excitation(design: dict, n: int, dt: float, gains: tuple, limits: tuple,
               pitch_scale: float = 1.0) -> np.ndarray:
    """Surface deflections added to the pilot/SAS commands, per sample.

    Parameters
    ----------
    design : dict
        From :func:`design_maneuver`.
    n : int
        Number of samples.
    dt : float
        Sample time [s].
    gains : (3,) tuple of float
        Deflection per angular acceleration for (elevator, aileron, rudder) at the trim
        point [rad / (rad/s^2)] (signed: includes the sign of the control power).
    limits : (3,) tuple of float
        Surface limits [rad]; amplitudes are capped at 80 % of them.
    pitch_scale : float
        Factor on elevator pulse amplitudes (dynamic-pressure scheduling).

    Returns
    -------
    (n, 3) ndarray
        Deflections [rad]; zero during the lead-in.
    """
    t = np.arange(n) * dt - LEAD_S
    out = np.zeros((n, 3))
    if design["family"] == "sum-of-sines":
        for i in range(3):
            sig = multisine(t, design["freqs_hz"][i], design["phases"][i], design["signal_s"])
            sig[(t < 0) | (t > design["signal_s"])] = 0.0
            amp = min(abs(gains[i] * design["accel_rms"][i]), 0.3 * limits[i])
            out[:, i] = math.copysign(amp, gains[i]) * sig
        return out
    i = AXES.index(design["axis"])
    scale = pitch_scale if i == 0 else 1.0
    amp = min(abs(gains[i] * design["accel"] * scale), 0.8 * limits[i])
    out[:, i] = math.copysign(amp, gains[i] * design["accel"]) * pulse_shape(
        t, design["unit_s"], tuple(design["pattern"]))
    return out
