"""Whole flights cut into maneuvers: time lists, excitation detection, ground removal.

A continuous flight record (taxi, take-off, climbs, maneuvers, cruise, landing) becomes the
schema's maneuvers in three steps:

1. :func:`airborne_mask`: ground and taxi samples are dropped, by a weight-on-wheels channel
   when there is one, else by airspeed below ``min_airspeed`` or altitude within
   ``min_height`` of the record's lowest (the runway's) pressure altitude;
2. the maneuvers: a time list (:func:`read_maneuver_list`, CSV ``start,end,type`` or TOML
   ``[[maneuver]]``, record time [s]), or :func:`detect_excitation` (control-surface and
   rate activity above ``threshold`` times the record's quiet level) with the turns, each
   from its roll-in to its roll-out (:func:`detect_turns`, :func:`absorb_turns`), and the
   stationary measurements between them (:func:`detect_steady`), or
   every airborne stretch as one maneuver;
3. :func:`cut`: each maneuver is intersected with the usable samples (airborne, no dropout);
   a maneuver interrupted by a dropout becomes several, pieces shorter than
   ``min_duration_s`` are dropped, and every decision is reported.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simplexspline.aero.reconstruction.kinematics import euler_rates
from simplexspline.errors import InputError

__all__ = ["Segment", "airborne_mask", "read_maneuver_list", "detect_excitation",
           "detect_turns", "detect_steady", "absorb", "absorb_turns", "airborne_segments",
           "cut",
           "EXCITATION_SIGNALS", "STEADY_AIRSPEED_BAND", "STEADY_HEIGHT_BAND", "STEADY_MIN_S",
           "STEADY_BANK_BAND", "STEADY_BAND_SIGMAS", "TURN_RATE"]

#: Signals whose activity marks a maneuver, and the axis each belongs to.
EXCITATION_SIGNALS: dict[str, str] = {"de": "elevator", "da": "aileron", "dr": "rudder",
                                      "q": "elevator", "p": "aileron", "r": "rudder"}


@dataclass(frozen=True)
class Segment:
    """A maneuver in record time.

    Attributes
    ----------
    start, end : float
        Record time [s].
    type : str
        Maneuver type ('3211-elevator', 'excitation-aileron', 'flight', ...).
    """

    start: float
    end: float
    type: str


def _runs(mask: np.ndarray):
    edges = np.diff(np.r_[0, np.asarray(mask, bool).view(np.int8), 0])
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))


def airborne_mask(n: int, *, wow=None, tas=None, h=None, min_airspeed: float = 25.0,
                  min_height: float = 15.0) -> tuple[np.ndarray, str]:
    """Samples in flight.

    Parameters
    ----------
    n : int
        Number of samples.
    wow : ndarray, shape (n,), optional
        Weight on wheels (> 0.5 on the ground); used alone when given.
    tas, h : ndarray, shape (n,), optional
        True airspeed [m/s] and pressure altitude [m].
    min_airspeed, min_height : float
        Slower than ``min_airspeed`` [m/s], or lower than ``min_height`` [m] above the
        lowest altitude of the record, is on the ground.

    Returns
    -------
    airborne : ndarray of bool, shape (n,)
    rule : str
        How the ground was recognised (for the summary).
    """
    if wow is not None and np.isfinite(wow).any():
        with np.errstate(invalid="ignore"):
            return ~(np.asarray(wow) > 0.5) & np.isfinite(wow), "weight-on-wheels channel"
    air = np.ones(n, bool)
    rules = []
    with np.errstate(invalid="ignore"):
        if tas is not None and np.isfinite(tas).any():
            air &= np.asarray(tas) >= min_airspeed
            rules.append(f"airspeed >= {min_airspeed:.3g} m/s")
        if h is not None and np.isfinite(h).any():
            air &= np.asarray(h) >= np.nanmin(h) + min_height
            rules.append(f"altitude >= {min_height:.3g} m above the record's lowest")
    return air, " and ".join(rules) if rules else "no rule (no wow, airspeed or altitude)"


def read_maneuver_list(path: str | Path) -> list[Segment]:
    """A maneuver time list: CSV with columns ``start, end[, type]`` or TOML ``[[maneuver]]``.

    Times are record time [s]. Raises :class:`~simplexspline.errors.InputError` naming the
    row of an entry with ``end <= start``, of overlapping entries or of a missing column.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"maneuver list {str(path)!r} does not exist")
    if path.suffix.lower() == ".toml":
        try:
            import tomllib
        except ModuleNotFoundError:  # Python < 3.11: the 'aero' extra installs tomli
            import tomli as tomllib
        try:
            rows = tomllib.loads(path.read_text(encoding="utf-8")).get("maneuver", [])
        except tomllib.TOMLDecodeError as exc:
            raise InputError(f"{path}: not valid TOML: {exc}") from None
    else:
        import pandas as pd  # optional dependency (the 'aero' extra)

        try:
            frame = pd.read_csv(path, skipinitialspace=True, comment="#")
        except Exception as exc:  # pandas raises several types for malformed CSV
            raise InputError(f"cannot read maneuver list {str(path)!r}: {exc}") from None
        rows = frame.to_dict("records")
    out = []
    for i, row in enumerate(rows, start=1):
        try:
            start, end = float(row["start"]), float(row["end"])
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{path}: maneuver {i} needs numeric 'start' and 'end' [s] "
                             f"(record time); got {row!r}") from None
        kind = row.get("type")
        kind = "maneuver" if kind is None or (isinstance(kind, float) and np.isnan(kind)) \
            else str(kind)
        if not (np.isfinite(start) and np.isfinite(end) and end > start):
            raise InputError(f"{path}: maneuver {i} ends at {end:g} s, not after its start "
                             f"{start:g} s")
        out.append(Segment(start, end, kind))
    if not out:
        raise InputError(f"{path}: the maneuver list is empty")
    out.sort(key=lambda s: s.start)
    for a, b in zip(out, out[1:]):
        if b.start < a.end:
            raise InputError(f"{path}: maneuvers {a} and {b} overlap")
    return out


def _fill(x: np.ndarray) -> np.ndarray:
    ok = np.isfinite(x)
    if ok.all() or not ok.any():
        return np.where(ok, x, 0.0)
    idx = np.arange(x.size)
    return np.interp(idx, idx[ok], x[ok])


def _moving_mean(x: np.ndarray, k: int) -> np.ndarray:
    c = np.cumsum(np.r_[0.0, x])
    half = k // 2
    lo = np.clip(np.arange(x.size) - half, 0, x.size)
    hi = np.clip(np.arange(x.size) + half + 1, 0, x.size)
    return (c[hi] - c[lo]) / (hi - lo)


def _quiet_level(energy: np.ndarray, quiet: np.ndarray, window: int, floor: float) -> np.ndarray:
    """Running median of ``energy`` over the ``quiet`` samples in a centred window of
    ``window`` samples (stretches without quiet samples take the nearest level), never
    below ``floor``."""
    import pandas as pd  # optional dependency (the 'aero' extra)

    level = pd.Series(np.where(quiet, energy, np.nan)).rolling(
        window, center=True, min_periods=max(1, window // 10)).median()
    level = level.ffill().bfill().to_numpy()
    return np.maximum(np.where(np.isfinite(level), level, floor), floor)


def detect_excitation(t: np.ndarray, data, usable: np.ndarray, *, threshold: float = 30.0,
                      window_s: float = 1.0, baseline_s: float = 10.0, pad_s: float = 2.0,
                      merge_s: float = 8.0, quiet_s: float = 300.0,
                      passes: int = 2) -> tuple[list[Segment], dict]:
    """Maneuvers where control-surface or rate activity stands out of the quiet level.

    For each signal of :data:`EXCITATION_SIGNALS` present in ``data``: the deviation from a
    ``baseline_s`` moving median, squared and averaged over ``window_s`` (the activity),
    divided by the **quiet level** around it. A sample is active where any signal exceeds
    ``threshold``; active stretches closer than ``merge_s`` are merged and padded by
    ``pad_s``. The type is ``excitation-<axis>`` of the most active signal.

    The quiet level is what the pilot, the flight control system and turbulence do in
    steady flight, and it changes along a flight (more turbulence low down, other gains at
    other speeds). The first pass takes the record's quietest level (the 20th percentile of
    the activity over the usable samples; at least 1e-4 of the peak, for noise-free
    records); each of the ``passes`` further passes takes the running median of the
    activity over the samples found quiet so far (not active, not within ``pad_s`` of
    activity) in a window of ``quiet_s``, never below the first pass's level. A whole flight
    in light turbulence is cut into its maneuvers this way, where one level for the whole
    record counted the turbulent stretches as maneuvers.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Record time [s] on a uniform grid.
    data : mapping of str to ndarray
    usable : ndarray of bool, shape (n,)
        Airborne samples without dropouts.
    threshold : float
        Activity over quiet level that marks a maneuver.
    window_s, baseline_s, pad_s, merge_s : float
        Activity window, baseline median, padding, merging of close stretches [s].
    quiet_s : float
        Window of the running quiet level [s]; 0 keeps the record's quietest level.
    passes : int
        Passes that refine the quiet level (0: the record's quietest level only).

    Returns
    -------
    segments : list of Segment
    quiet : dict
        Median quiet level per signal used (its unit squared).
    """
    # lazy: scipy.ndimage costs ~0.4 s to import
    from scipy.ndimage import maximum_filter, median_filter

    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(window_s / dt)))
    kb = max(3, int(round(baseline_s / dt)) | 1)
    energies, floors = {}, {}
    for name in EXCITATION_SIGNALS:
        if name not in data:
            continue
        x = np.asarray(data[name], dtype=float)
        if not np.isfinite(x[usable]).any():
            continue
        xf = _fill(x)
        energy = _moving_mean((xf - median_filter(xf, size=kb, mode="nearest")) ** 2, k)
        # the quietest level; a floor of 1e-4 of the peak for noise-free (simulated) records
        level = max(float(np.percentile(energy[usable], 20)),
                    1e-4 * float(energy[usable].max()))
        if not level > 0:
            continue
        energies[name], floors[name] = energy, level
    if not energies:
        raise InputError("excitation detection needs at least one of de, da, dr, p, q, r with "
                         "data: map those channels, or give a maneuver list")
    names = list(energies)
    levels = {n: np.full(len(t), floors[n]) for n in names}
    window = int(round(quiet_s / dt)) | 1
    for step in range(passes + 1 if quiet_s > 0 else 1):
        stack = np.vstack([np.where(usable, energies[n] / levels[n], 0.0) for n in names])
        active = stack.max(axis=0) > threshold
        if step == passes or quiet_s <= 0:
            break
        near = max(1, int(round(pad_s / dt)))
        busy = maximum_filter(active.astype(np.int8), size=2 * near + 1, mode="nearest") > 0
        quiet = usable & ~active & ~busy
        levels = {n: _quiet_level(energies[n], quiet, window, floors[n]) for n in names}
    runs = _runs(active)
    merged = []
    for a, b in runs:
        if merged and t[a] - t[merged[-1][1] - 1] < merge_s:
            merged[-1] = (merged[-1][0], b)
        else:
            merged.append((a, b))
    segments = []
    for a, b in merged:
        axis = EXCITATION_SIGNALS[names[int(np.argmax(stack[:, a:b].mean(axis=1)))]]
        segments.append(Segment(float(t[a]) - pad_s, float(t[b - 1]) + pad_s,
                                f"excitation-{axis}"))
    return segments, {n: float(np.median(levels[n][usable])) for n in names}


#: Heading rate [rad/s] above which a sample counts as turning (:func:`detect_turns`):
#: 0.3 deg/s, a 15 deg bank at 220 m/s turns at 0.7 deg/s, a standard-rate turn at 3.
TURN_RATE = 0.3 * np.pi / 180.0


def detect_turns(t: np.ndarray, data, usable: np.ndarray, *, min_change: float,
                 smooth_s: float = 2.0, pad_s: float = 2.0) -> list[Segment]:
    """The turns of a flight: stretches whose heading changes by ``min_change`` or more.

    A record without a heading channel observes the wind only where the heading changes
    (the reconstruction's wind triangle); the excitation detector does not cut a steady
    turn (its rates hold still), so the turns are found here, from the Euler heading rate
    ``(q sin(phi) + r cos(phi)) / cos(theta)`` averaged over ``smooth_s``: each stretch of
    usable samples turning one way faster than :data:`TURN_RATE` whose heading change
    reaches ``min_change``, padded by ``pad_s``, is a segment of type ``turn``.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Record time [s] on a uniform grid.
    data : mapping of str to ndarray
        ``q``, ``r`` [rad/s], ``phi``, ``theta`` [rad]; without one of them no turn is found.
    usable : ndarray of bool, shape (n,)
    min_change : float
        Smallest heading change of a turn [rad].
    smooth_s, pad_s : float
        Averaging window of the heading rate and padding of each turn [s].

    Returns
    -------
    list of Segment
    """
    if not all(c in data for c in ("q", "r", "phi", "theta")) or len(t) < 2:
        return []
    dt = float(np.median(np.diff(t)))
    q, r, phi, theta = (_fill(np.asarray(data[c], dtype=float)) for c in ("q", "r", "phi",
                                                                          "theta"))
    rate = _moving_mean(euler_rates(0.0, q, r, phi, theta)[2],
                        max(1, int(round(smooth_s / dt))))
    out = []
    for sign in (1.0, -1.0):
        for a, b in _runs(usable & (sign * rate > TURN_RATE)):
            if abs(float(np.sum(rate[a:b])) * dt) >= min_change:
                out.append(Segment(float(t[a]) - pad_s, float(t[b - 1]) + pad_s, "turn"))
    return sorted(out, key=lambda s: s.start)


#: A stationary measurement holds its airspeed within this band [m/s] (:func:`detect_steady`):
#: a pilot holds a test point to a knot or two, and 2 m/s is four times the airspeed
#: sensor's noise after the smoothing below.
STEADY_AIRSPEED_BAND = 2.0
#: ... and its altitude within this band [m] (100 ft).
STEADY_HEIGHT_BAND = 30.0
#: ... for at least this long [s]: a stationary measurement lasts a minute or more.
STEADY_MIN_S = 30.0
#: ... and its bank angle within this band [rad] (5 deg): wings level, not a turn's entry or
#: roll-out, whose heading may still change less than the heading band.
STEADY_BANK_BAND = np.radians(5.0)
#: In turbulence the bands widen to this many robust standard deviations of the smoothed
#: airspeed's, altitude's and heading's fluctuation about their trend over
#: ``STEADY_MIN_S`` (the record's own gust level; :func:`detect_steady`): about the
#: expected range of a hundred independent normal draws, a 90 s measurement of gusts
#: correlated over a second or so (4 sigmas kept only half of each measurement).
STEADY_BAND_SIGMAS = 5.0


def _longest_within(x: np.ndarray, band: np.ndarray) -> tuple[int, int]:
    """The longest run ``[a, b)`` over which every column of ``x`` (n, k) stays within
    ``band`` (k,) of its own minimum (two pointers over running extrema)."""
    n, k = x.shape
    lo = [deque() for _ in range(k)]
    hi = [deque() for _ in range(k)]
    best, a = (0, 0), 0
    for b in range(n):
        for j in range(k):
            while lo[j] and x[lo[j][-1], j] >= x[b, j]:
                lo[j].pop()
            lo[j].append(b)
            while hi[j] and x[hi[j][-1], j] <= x[b, j]:
                hi[j].pop()
            hi[j].append(b)
            while x[hi[j][0], j] - x[lo[j][0], j] > band[j]:
                a += 1
                for d in (lo, hi):
                    for q in d:
                        while q and q[0] < a:
                            q.popleft()
        if b + 1 - a > best[1] - best[0]:
            best = (a, b + 1)
    return best


def _fluctuation(x: np.ndarray, where: np.ndarray, window: int) -> np.ndarray:
    """Robust standard deviation (1.4826 x the median absolute deviation) per column of
    ``x`` (n, k) about its running median over ``window`` samples, over the samples
    ``where``; zeros where none is."""
    from scipy.ndimage import median_filter  # lazy: scipy.ndimage costs ~0.4 s to import

    if not where.any():
        return np.zeros(x.shape[1])
    dev = x - median_filter(x, size=(max(3, window | 1), 1), mode="nearest")
    dev = dev[where]
    return 1.4826 * np.median(np.abs(dev - np.median(dev, axis=0)), axis=0)


def detect_steady(t: np.ndarray, data, usable: np.ndarray, others: list, *,
                  min_duration_s: float = STEADY_MIN_S,
                  airspeed_band: float = STEADY_AIRSPEED_BAND,
                  height_band: float = STEADY_HEIGHT_BAND,
                  smooth_s: float = 2.0,
                  band_sigmas: float = STEADY_BAND_SIGMAS,
                  bank_band: float = STEADY_BANK_BAND) -> list[Segment]:
    """The stationary measurements of a flight: straight, level stretches at one airspeed
    between the detected maneuvers and turns.

    The excitation detector cuts where the controls and rates move, so a flight-test
    course's stationary measurements (a minute or more of trimmed flight at each airspeed)
    were dropped. They are the data that tell a vane's offset from its scale error (each
    observes the offset plus the scale error times its one angle of attack) and that trace
    the lift curve: on a simulated still-air Cessna course cut by excitation, the angle of
    attack came out 1.5e-3 rad RMS off without them, 2.0e-4 with a maneuver list that
    logged them. Here every stretch of usable samples that ``others`` do not overlap gives
    its longest part whose airspeed and altitude (averaged over ``smooth_s``) stay within
    ``airspeed_band`` and ``height_band`` and whose heading (the integral of the Euler
    heading rate, with ``q, r, phi, theta``) stays within what :data:`TURN_RATE` turns in
    ``min_duration_s`` (9 deg) and its bank angle within ``bank_band`` (wings level: a
    turn's roll-out, still banked 10 deg while its heading changes 7 deg, is not taken),
    when it lasts ``min_duration_s`` or more, and so on in what is left either side of
    it: type ``steady``.

    **Turbulence.** Gusts move the measured airspeed by a metre per second or more within
    seconds while the pilot holds the test point's mean: on the simulated light-turbulence
    courses of ``bench_courses.py`` a stationary measurement's 2 s mean airspeed spanned
    4.8-11 m/s and the 2 s heading rate crossed 0.3 deg/s every few seconds (0.2 deg/s
    standard deviation), and none of the 48 was found while straight flight was judged by
    that rate. So the heading is judged over the stretch instead, and each band is at
    least ``band_sigmas`` robust standard deviations (1.4826 x the median absolute
    deviation) of the smoothed signal about its running median over ``min_duration_s``,
    over the samples that ``others`` leave (the record's own fluctuation at the time
    scales within a measurement; the fixed bands are four times the sensor's noise for
    the same reason). In still air that fluctuation is the sensor's noise and the fixed
    bands hold.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Record time [s] on a uniform grid.
    data : mapping of str to ndarray
        ``tas`` [m/s] and ``h`` [m]; ``q, r, phi, theta`` for the heading rate. Without
        ``tas`` or ``h`` none is found.
    usable : ndarray of bool, shape (n,)
    others : list of Segment
        The maneuvers (and turns) already cut.
    min_duration_s, airspeed_band, height_band, smooth_s : float
    band_sigmas : float
        The bands' least width in robust standard deviations of the smoothed signals'
        fluctuation (0: the fixed bands only).
    bank_band : float
        Band of the bank angle [rad] (with ``q, r, phi, theta``).

    Returns
    -------
    list of Segment
    """
    if not all(c in data for c in ("tas", "h")) or len(t) < 2:
        return []
    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(smooth_s / dt)))
    x = np.column_stack([_moving_mean(_fill(np.asarray(data[c], dtype=float)), k)
                         for c in ("tas", "h")])
    free = np.asarray(usable, bool).copy()
    for o in others:
        free &= ~((t >= o.start) & (t <= o.end))
    bands = [airspeed_band, height_band]
    if all(c in data for c in ("q", "r", "phi", "theta")):
        q, r, phi, theta = (_fill(np.asarray(data[c], dtype=float))
                            for c in ("q", "r", "phi", "theta"))
        # the heading [rad], the integral of the Euler heading rate: straight flight
        # holds it within what TURN_RATE turns in min_duration_s
        heading = np.cumsum(_moving_mean(euler_rates(0.0, q, r, phi, theta)[2], k)) * dt
        x = np.column_stack([x, heading, _moving_mean(phi, k)])
        bands += [TURN_RATE * min_duration_s, bank_band]
    band = np.maximum(bands,
                      band_sigmas * _fluctuation(x, free, int(round(min_duration_s / dt))))
    out = []
    todo = list(_runs(free))
    while todo:                 # the longest steady part, then those left and right of it
        a, b = todo.pop()
        if (b - a) * dt < min_duration_s:
            continue
        i, j = _longest_within(x[a:b], band)
        if (j - i) * dt >= min_duration_s:
            out.append(Segment(float(t[a + i]), float(t[a + j - 1]), "steady"))
            todo += [(a, a + i), (a + j, b)]
    return sorted(out, key=lambda seg: seg.start)


def absorb(segment: Segment, others: list) -> tuple[Segment, list]:
    """``segment`` grown over every one of ``others`` it overlaps (a turn over its roll-in
    and roll-out), and the others it did not overlap, in time order."""
    a, b, rest = segment.start, segment.end, []
    for o in sorted(others, key=lambda o: o.start):
        if o.start < b and o.end > a:
            a, b = min(a, o.start), max(b, o.end)
        else:
            rest.append(o)
    return Segment(a, b, segment.type), rest


def absorb_turns(segments: list, turns: list) -> tuple[list, int]:
    """The maneuvers with each turn (:func:`detect_turns`) grown over the ones it overlaps
    (:func:`absorb`; turns that overlap become one), in time order, and the number of turns.
    A turn that is mostly detected maneuvers (more than half of it: a sum-of-sines or a roll
    that turns the heading) takes the longest one's type; it is not counted as a turn.

    A turn is one maneuver from its roll-in to its roll-out. Without a heading channel its
    heading change is what observes the wind and an airspeed bias (the reconstruction's
    wind triangle), and the whole of it observes them best: until stop 62 each turn kept only
    its part between the maneuvers detected at its entry and exit, and on a still-air
    six-test-point Cessna course (no maneuver list) the reconstructed airspeed came out
    0.31 m/s RMS off against the raw sensor's 0.10 (the campaign's airspeed bias -0.30 +-
    0.29 m/s from the cut turns, 0.02 +- 0.04 from the flown ones); with the whole turns 0.065.
    """
    out = list(segments)
    grown = []
    for u in turns:
        before = out + grown
        whole, rest = absorb(u, before)
        taken = [s for s in before if s not in rest and s.type != "turn"]
        longest = max(taken, key=lambda s: s.end - s.start, default=None)
        if longest is not None and sum(s.end - s.start for s in taken) \
                > 0.5 * (whole.end - whole.start):
            whole = Segment(whole.start, whole.end, longest.type)   # a maneuver that turns
        grown = [s for s in rest if s not in segments] + [whole]
        out = [s for s in rest if s in segments]
    n_turns = sum(s.type == "turn" for s in grown)
    return sorted(out + grown, key=lambda s: s.start), n_turns


def airborne_segments(t: np.ndarray, usable: np.ndarray, kind: str = "flight") -> list[Segment]:
    """Every stretch of usable samples as one segment."""
    return [Segment(float(t[a]), float(t[b - 1]), kind) for a, b in _runs(usable)]


def cut(t: np.ndarray, usable: np.ndarray, segments: list[Segment], *,
        min_duration_s: float = 5.0) -> tuple[list[tuple[np.ndarray, str]], list[str]]:
    """Rows of each maneuver: the segment intersected with the usable samples.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Record time [s].
    usable : ndarray of bool, shape (n,)
    segments : list of Segment
    min_duration_s : float
        Shorter pieces are dropped.

    Returns
    -------
    pieces : list of (ndarray of int, str)
        Row indices and type of each maneuver, in time order.
    notes : list of str
        What was split or dropped, and why.
    """
    pieces, notes = [], []
    for s in segments:
        inside = (t >= s.start) & (t <= s.end)
        if not inside.any():
            notes.append(f"maneuver {s.type} {s.start:.6g}..{s.end:.6g} s lies outside the "
                         "record: dropped")
            continue
        runs = _runs(inside & usable)
        lost = int(inside.sum() - sum(b - a for a, b in runs))
        if len(runs) > 1:
            notes.append(f"maneuver {s.type} {s.start:.6g}..{s.end:.6g} s split into "
                         f"{len(runs)} at dropouts or ground samples")
        elif lost:
            notes.append(f"maneuver {s.type} {s.start:.6g}..{s.end:.6g} s: {lost} sample(s) "
                         "on the ground or in dropouts left out")
        for a, b in runs:
            if t[b - 1] - t[a] < min_duration_s:
                notes.append(f"piece {t[a]:.6g}..{t[b - 1]:.6g} s of maneuver {s.type} is "
                             f"shorter than {min_duration_s:g} s: dropped")
                continue
            pieces.append((np.arange(a, b), s.type))
    return pieces, notes
