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
  it and the import splits the record there.

:func:`resample` puts a cleaned channel on the common grid by linear interpolation (angles
that wrap are interpolated the short way round). The grid's rate is the fastest channel's
unless given: a faster channel on a slower grid is interpolated, not averaged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simplexspline.errors import FlightDataError

__all__ = ["TimeIssue", "CleanChannel", "clean_time_stamps", "common_grid", "resample"]


@dataclass(frozen=True)
class TimeIssue:
    """A glitch in a channel's time stamps and what was done about it.

    Attributes
    ----------
    channel : str
    kind : {'duplicate', 'conflicting-duplicate', 'jump', 'backwards', 'dropout'}
    t : float
        Record time of the (first) glitch [s].
    samples : int
        Samples affected (dropped; for a dropout, the missing samples).
    action : str
        'dropped' or 'split'.
    duration : float
        Length of a dropout [s] (0 otherwise).
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
