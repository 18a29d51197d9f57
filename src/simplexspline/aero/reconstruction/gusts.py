"""Turbulence in the flight path reconstruction: gusts whose intensity the data choose.

Real flights always meet some turbulence. A wind that is constant over a maneuver cannot
follow it: the air data then disagree with the IMU-driven kinematics by the gusts (1-2 m/s
in JSBSim's "light" MIL-F-8785C turbulence, 0.5-1 deg of angle of attack at 150 m/s), the
filter pushes them into the constant states (the airspeed bias, the vane offsets, the
wind) and the reconstruction fails (with all sensors: alpha errors 6x the raw vane's,
airspeed errors of 15 m/s). A random-walk wind follows the gusts but also the constant
air-data errors, so it no longer separates them from the wind.

Here the wind is a constant (or random walk) *plus* gusts, one per NED axis, each a
zero-mean first-order Gauss-Markov process (the simplest model with the two properties that
matter: gusts have a finite variance and a finite correlation time)::

    g[k+1] = a g[k] + w[k],   a = exp(-dt / tau),   var(w) = sigma^2 (1 - a^2)

with ``tau = L / V`` (the air mass's correlation length ``L`` passed at the airspeed
``V``). Being zero-mean and stationary, the gusts cannot absorb a constant: the air-data
errors and the steady wind stay separated as in still air, and the gusts are what the air
data see beyond the kinematics at the time scales of turbulence.

The intensity ``sigma`` is chosen per maneuver by the data, not set for one simulator or
aircraft (:func:`choose_gusts`): the still-air model (``sigma = 0``, the gusts held at
zero) runs first, and if its air-data innovations are consistent (normalised standard
deviation at most :data:`GUST_EVIDENCE`) it is kept, at no extra cost. Otherwise candidate
intensities and correlation lengths are scored by the log-likelihood of the measurements
(the innovations' Gaussian density, which every forward pass returns) in a short
coordinate search (:func:`choose_gusts`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from typing import NamedTuple

import numpy as np

__all__ = ["GUST_EVIDENCE", "GustChoice", "gust_process", "innovation_excess", "choose_gusts"]

#: Normalised standard deviation of the still-air model's air-data innovations above which
#: gusts are looked for (a consistent filter gives about 1). Measured on 6-maneuver real-like
#: records at 10 Hz (f16, seed 11): 0.9-3.3 in still air (the channel lags, not yet undone,
#: and the 10 Hz model errors), 4.4-20 in JSBSim's light turbulence; at 2 the gusts were
#: chosen in two still-air maneuvers, absorbed the lags (which then went unestimated) and
#: moved the campaign's airspeed calibration by 2.5 m/s.
GUST_EVIDENCE = 4.0

#: Errors of a filter run that count as a failed candidate (the next one is tried).
_FAILURES = (np.linalg.LinAlgError, FloatingPointError, ValueError, ZeroDivisionError)


class GustChoice(NamedTuple):
    """The gust model chosen for one maneuver."""

    out: dict           #: the forward pass with that model (:func:`~.iekf.run_filter`)
    std: float          #: gust standard deviation per axis [m/s] (0: still air)
    length_m: float     #: correlation length [m] (nan in still air)
    scores: dict        #: (std [m/s], length [m]) -> log-likelihood, the candidates run
    evidence: float     #: the still-air model's :func:`innovation_excess` (nan: not run)


def gust_process(std: float, length_m: float, airspeed: float, dt: float
                 ) -> tuple[float, float]:
    """Decay and per-step process variance of the gusts' Gauss-Markov process.

    Parameters
    ----------
    std : float
        Stationary standard deviation of each gust component [m/s].
    length_m : float
        Correlation length of the turbulence [m].
    airspeed : float
        Airspeed [m/s] (the aircraft crosses the length in ``length_m / airspeed`` s).
    dt : float
        Sample interval [s].

    Returns
    -------
    decay : float
        ``exp(-dt / tau)``, ``tau = length_m / airspeed`` [s]; 1 when ``std`` is 0.
    var_step : float
        ``std^2 (1 - decay^2)`` [m^2/s^2]: keeps the variance at ``std^2``.

    Examples
    --------
    >>> a, q = gust_process(1.0, 300.0, 150.0, 0.1)
    >>> round(a, 4), round(q / (1 - a * a), 6)
    (0.9512, 1.0)
    """
    if std <= 0:
        return 1.0, 0.0
    tau = length_m / max(airspeed, 1.0)
    decay = math.exp(-dt / tau)
    return decay, std * std * (1.0 - decay * decay)


def innovation_excess(stats: Mapping, channels: Iterable[str]) -> float:
    """Largest normalised innovation standard deviation over ``channels`` (1: consistent).

    Parameters
    ----------
    stats : mapping
        :func:`~simplexspline.aero.reconstruction.reconstruct.innovation_statistics`.
    channels : iterable of str
        The channels to look at (those measured; absent ones are skipped).
    """
    vals = [stats[c]["std"] for c in channels if c in stats]
    return float(max(vals)) if vals else 0.0


class _NoStillAir(Exception):
    """Skips the still-air pass."""


def _checked(out: dict) -> dict:
    if not (math.isfinite(out["loglik"]) and np.isfinite(out["x_filt"]).all()):
        raise FloatingPointError("the filter's states or likelihood are not finite")
    return out


def choose_gusts(run: Callable[[float, float], dict], stds: Iterable[float],
                 lengths: Iterable[float], evidence: Callable[[dict], float] | None
                 ) -> GustChoice:
    """The gust intensity and correlation length the data support best, and its pass.

    Still air first; if its innovations show gusts, the intensities in increasing order at
    the middle candidate length (stopping at the first that scores worse than the one
    before), then the other lengths at the chosen intensity: a coordinate search by the
    log-likelihood of the measurements.

    Parameters
    ----------
    run : callable
        ``run(std, length_m)`` -> the forward pass (a dict with ``loglik`` and ``x_filt``)
        with gusts of that standard deviation [m/s] (0: held at zero) and correlation
        length [m]; it may raise when the model cannot follow the data.
    stds : iterable of float
        Gust standard deviations [m/s] to try when still air does not fit.
    lengths : iterable of float
        Correlation lengths [m] to try.
    evidence : callable or None
        ``evidence(out)`` -> the still-air pass's :func:`innovation_excess`; None: no
        still-air pass (gusts of the given intensities only).

    Returns
    -------
    GustChoice

    Raises
    ------
    numpy.linalg.LinAlgError, FloatingPointError, ValueError
        The last error when every candidate failed.
    """
    lengths = sorted(float(x) for x in lengths)
    mid = lengths[len(lengths) // 2]
    scores: dict = {}
    best: list = []                      # [out, std, length] of the best so far
    errors: list = []
    excess = math.nan
    try:
        if evidence is None:
            raise _NoStillAir
        out = run(0.0, mid)     # kept even if it diverged: the caller diagnoses that
        scores[(0.0, math.nan)] = out["loglik"]
        best = [out, 0.0, math.nan]
        excess = evidence(_checked(out))
        if excess <= GUST_EVIDENCE:
            return GustChoice(out, 0.0, math.nan, scores, excess)
    except _NoStillAir:
        pass
    except _FAILURES as exc:
        errors.append(exc)

    def better(std: float, length: float) -> bool:
        try:
            out = _checked(run(std, length))
        except _FAILURES as exc:
            errors.append(exc)
            return False
        scores[(std, length)] = out["loglik"]
        # (a diverged still-air pass scores nan: never better)
        if best and not out["loglik"] > best[0]["loglik"]:
            return False
        best[:] = [out, std, length]
        return True

    for std in sorted(float(c) for c in stds if c > 0):
        if not better(std, mid) and best and best[1] > 0:
            break
    if best and best[1] > 0:
        for length in lengths:
            if length != mid:
                better(best[1], length)
        if best[2] != mid:                   # one more round of intensities there
            grid = sorted(float(c) for c in stds if c > 0)
            i = grid.index(best[1])
            for std in grid[max(i - 1, 0):i] + grid[i + 1:i + 2]:
                better(std, best[2])
    if not best:
        raise errors[-1]
    return GustChoice(best[0], best[1], best[2], scores, excess)
