"""One time base for a record's channels; glitches in time stamps repaired or reported.

Real records have channels at different rates and time stamps that repeat, jump or go
backwards, and dropouts. :func:`clean_time_stamps` repairs what is safe and reports all of
it (:class:`TimeIssue`), never silently:

* a repeated time stamp: the later sample is dropped (reported; "conflicting" if the values
  differ);
* a single time stamp that jumps ahead and comes back (a corrupted stamp): that sample is
  dropped;
* samples stamped before an earlier sample (time going backwards): dropped when they are few
  (``max_backwards`` samples); a longer run is a clock reset and an error (split the record);
* a step longer than ``gap_factor`` nominal steps is a dropout: :func:`resample` leaves NaN in
  it and the import splits the record there;
* a channel recorded faster than its sensor updates (a 1-5 Hz GPS receiver on a 10 Hz
  recorder holds each fix for several samples, :func:`held_updates`): the repeats are
  dropped and the updates interpolated; as stairs, a 1 Hz position would be up to one
  second of flight (100 m) off.

:func:`resample` puts a cleaned channel on the common grid by linear interpolation (angles
that wrap are interpolated the short way round). The grid's rate is the fastest channel's
unless given: a faster channel on a slower grid is interpolated, not averaged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simplexspline.errors import FlightDataError

__all__ = ["TimeIssue", "CleanChannel", "clean_time_stamps", "common_grid", "held_updates",
           "resample", "HELD_SHARE"]

#: A channel whose samples repeat the one before at least this share of the time holds
#: the readings of a slower sensor (:func:`held_updates`); a sensor that updates at the
#: recorder's rate repeats only where it stands still.
HELD_SHARE = 0.5


@dataclass(frozen=True)
class TimeIssue:
    """A glitch in a channel's time stamps and what was done about it.

    Attributes
    ----------
    channel : str
    kind : {'duplicate', 'conflicting-duplicate', 'jump', 'backwards', 'dropout', 'held'}
    t : float
        Record time of the (first) glitch [s].
    samples : int
        Samples affected (dropped; for a dropout, the missing samples).
    action : str
        'dropped' or 'split'.
    duration : float
        Length of a dropout, or a held channel's update interval [s] (0 otherwise).
    """

    channel: str
    kind: str
    t: float
    samples: int
    action: str
    duration: float = 0.0

    def text(self) -> str:
        """One line for the console."""
        if self.kind == "dropout":
            return (f"channel {self.channel!r}: dropout of {self.duration:.3g} s "
                    f"({self.samples} samples missing) at t = {self.t:.6g} s; record split "
                    "there")
        if self.kind == "held":
            return (f"channel {self.channel!r}: holds each reading for several samples (a "
                    f"sensor updating every {self.duration:.3g} s, recorded faster): "
                    f"{self.samples} repeated samples dropped from t = {self.t:.6g} s, the "
                    "updates interpolated")
        what = {"duplicate": "repeated time stamp(s)",
                "conflicting-duplicate": "repeated time stamp(s) with different values",
                "jump": "time stamp(s) jumping ahead and back",
                "backwards": "time stamp(s) going backwards"}[self.kind]
        return (f"channel {self.channel!r}: {self.samples} {what} from t = {self.t:.6g} s; "
                "sample(s) dropped")


@dataclass(frozen=True)
class CleanChannel:
    """A channel with strictly increasing time stamps.

    Attributes
    ----------
    t, values : ndarray, shape (n,)
    dt : float
        Nominal sample interval [s] (median step).
    gaps : list of (float, float)
        Dropouts: (last stamp before, first stamp after) [s].
    issues : list of TimeIssue
    """

    t: np.ndarray
    values: np.ndarray
    dt: float
    gaps: list
    issues: list


def _runs(mask: np.ndarray):
    """(start, length) of the runs of True in a boolean array."""
    edges = np.diff(np.r_[0, mask.view(np.int8), 0])
    starts = np.flatnonzero(edges == 1)
    return zip(starts, np.flatnonzero(edges == -1) - starts)


def clean_time_stamps(channel: str, t, values, *, gap_factor: float = 2.5,
                      max_backwards: int = 10) -> CleanChannel:
    """Repair and report a channel's time-stamp glitches (see the module docstring).

    Parameters
    ----------
    channel : str
        Name used in the reports.
    t, values : array_like, shape (n,)
        Time stamps [s] as recorded and the values.
    gap_factor : float
        Steps longer than ``gap_factor`` times the nominal step are dropouts.
    max_backwards : int
        Most consecutive samples stamped before an earlier one that are dropped; a longer
        run raises.

    Returns
    -------
    CleanChannel

    Raises
    ------
    FlightDataError
        On a clock reset (a long run of samples going backwards in time).
    """
    t = np.asarray(t, dtype=float)
    v = np.asarray(values, dtype=float)
    issues = []
    if t.size < 2:
        return CleanChannel(t, v, float("nan"), [], issues)
    # a single stamp ahead of both neighbours' order: t[i] > t[i+1] but t[i-1] < t[i+1]
    jump = np.zeros(t.size, bool)
    jump[:-1] = t[:-1] > t[1:]
    jump[1:-1] &= t[:-2] < t[2:]
    for a, n in _runs(jump):
        issues.append(TimeIssue(channel, "jump", float(t[a]), int(n), "dropped"))
    t, v = t[~jump], v[~jump]
    prior = np.maximum.accumulate(np.r_[-np.inf, t[:-1]])
    dup = t == prior
    back = t < prior
    for a, n in _runs(back):
        if n > max_backwards:
            raise FlightDataError(
                f"channel {channel!r}: time goes back from {prior[a]:.6g} s to {t[a]:.6g} s and "
                f"stays behind for {n} samples (a clock reset?): split the record at that "
                "point or repair its time stamps")
        issues.append(TimeIssue(channel, "backwards", float(t[a]), int(n), "dropped"))
    if dup.any():
        # compare with the kept sample of the same stamp
        keep_idx = np.flatnonzero(~dup & ~back)
        pos = np.searchsorted(t[keep_idx], t[dup])
        pos = np.clip(pos, 0, keep_idx.size - 1)
        differ = v[keep_idx[pos]] != v[dup]
        n_conf = int(differ.sum())
        first = float(t[dup][0])
        if n_conf:
            issues.append(TimeIssue(channel, "conflicting-duplicate",
                                    float(t[dup][differ][0]), n_conf, "dropped"))
        if int(dup.sum()) - n_conf:
            issues.append(TimeIssue(channel, "duplicate", first, int(dup.sum()) - n_conf,
                                    "dropped"))
    keep = ~dup & ~back
    t, v = t[keep], v[keep]
    if t.size < 2:
        return CleanChannel(t, v, float("nan"), [], issues)
    steps = np.diff(t)
    dt = float(np.median(steps))
    gaps = []
    for k in np.flatnonzero(steps > gap_factor * dt):
        duration = float(steps[k])
        gaps.append((float(t[k]), float(t[k + 1])))
        issues.append(TimeIssue(channel, "dropout", float(t[k]),
                                int(round(duration / dt)) - 1, "split", duration))
    return CleanChannel(t, v, dt, gaps, issues)


def held_updates(channel: str, t, values) -> tuple[np.ndarray, np.ndarray, TimeIssue | None]:
    """The updates of a channel that holds each reading of a slower sensor.

    A sample equal to the one before it is a repeat; when at least :data:`HELD_SHARE` of
    the samples are repeats, the channel is a sensor read out faster than it updates, and
    only the first sample of each run of equal values (the update) is kept; a run longer
    than two update intervals is a value that stood still, and keeps one sample per update
    interval. Missing samples (NaN) are kept where they are.

    Parameters
    ----------
    channel : str
        Name used in the report.
    t, values : array_like, shape (n,)
        Time stamps [s] and values.

    Returns
    -------
    t, values : ndarray, shape (m,)
        The updates (everything, m = n, when the channel does not hold its readings).
    issue : TimeIssue or None
        Kind 'held', with the update interval (median) as ``duration``.

    Examples
    --------
    >>> t = np.arange(40) * 0.1
    >>> tk, vk, issue = held_updates("lat", t, np.repeat([0.0, 1.0, 2.0, 3.0], 10))
    >>> tk.tolist(), issue.duration, issue.samples
    ([0.0, 1.0, 2.0, 3.0], 1.0, 36)
    """
    t = np.asarray(t, dtype=float)
    v = np.asarray(values, dtype=float)
    if v.size < 3:
        return t, v, None
    repeat = np.r_[False, v[1:] == v[:-1]]           # NaN never equals: kept
    keep = ~repeat
    updates = keep & np.isfinite(v)
    if repeat.mean() < HELD_SHARE or updates.sum() < 2:
        return t, v, None      # (one value throughout is a dead channel, not a slow one)
    interval = float(np.median(np.diff(t[updates])))
    # a value that stays much longer than an update interval stood still (a longitude
    # while flying north, a position on the ground): its run keeps a sample per update
    # interval, in step with the updates, or it would read as a dropout
    idx = np.flatnonzero(keep)
    ends = np.r_[idx[1:], v.size]                   # each run: idx[k] .. ends[k] - 1
    step = max(1, int(round(interval / float(np.median(np.diff(t))))))
    for a, b in zip(idx, ends):
        if t[b - 1] - t[a] > 2.0 * interval:
            keep[a:b:step] = True
    first = int(np.flatnonzero(~keep)[0])
    return t[keep], v[keep], TimeIssue(channel, "held", float(t[first]), int((~keep).sum()),
                                       "dropped", interval)


def common_grid(channels, rate_hz: float | None = None) -> np.ndarray:
    """The common time base: from the earliest to the latest stamp at ``rate_hz``.

    Parameters
    ----------
    channels : iterable of CleanChannel
    rate_hz : float, optional
        Output rate; the fastest channel's if None.

    Returns
    -------
    ndarray, shape (m,)
        Times [s].
    """
    chans = [c for c in channels if c.t.size >= 2]
    if not chans:
        raise FlightDataError("no channel has two or more samples: nothing to import")
    if rate_hz is None:
        rate_hz = max(1.0 / c.dt for c in chans)
        rate_hz = float(np.round(rate_hz, 6))
    t0 = min(float(c.t[0]) for c in chans)
    t1 = max(float(c.t[-1]) for c in chans)
    n = int(np.floor((t1 - t0) * rate_hz + 1e-6)) + 1
    return t0 + np.arange(n) / rate_hz


def resample(channel: CleanChannel, grid: np.ndarray, *, wrap: bool = False) -> np.ndarray:
    """Linear interpolation onto ``grid``; NaN outside the channel's span and in dropouts.

    Parameters
    ----------
    channel : CleanChannel
    grid : ndarray, shape (m,)
    wrap : bool
        The values are angles [rad] that wrap: interpolated the short way round, each
        result on the branch of the recorded sample before it (so the recorded values, and
        any unit error in them, are kept).

    Returns
    -------
    ndarray, shape (m,)
    """
    out = np.full(grid.shape, np.nan)
    if channel.t.size == 0:
        return out
    v = np.unwrap(channel.values) if wrap else channel.values
    tol = 1e-6 * (channel.dt if np.isfinite(channel.dt) else 1.0)
    inside = (grid >= channel.t[0] - tol) & (grid <= channel.t[-1] + tol)
    if channel.t.size == 1:
        out[inside] = v[0]
    else:
        out[inside] = np.interp(grid[inside], channel.t, v)
    if wrap:  # back onto the recorded branch of the sample before (multiples of 2 pi)
        left = np.clip(np.searchsorted(channel.t, grid, side="right") - 1, 0, v.size - 1)
        out += (channel.values - v)[left]
    for a, b in channel.gaps:
        out[(grid > a + tol) & (grid < b - tol)] = np.nan
    return out
