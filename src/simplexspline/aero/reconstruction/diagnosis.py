"""Likely causes of a filter that diverges or does not fit: units, signs, wind, vanes, lags.

Two kinds of evidence, both cheap and independent of the filter's convergence:

* **Kinematic consistency of the raw channels** (no filter involved): the attitude rates
  predicted by the gyros against the differentiated attitude channels,
  ``phidot = p + tan(theta) (q sin(phi) + r cos(phi))``, ``thetadot = q cos(phi) - r sin(phi)``,
  ``psidot = (q sin(phi) + r cos(phi)) / cos(theta)``. A regression slope near -1 names a sign
  error, near 57.3 or 1/57.3 a degree/radian mix-up. The mean specific force along z against
  gravity (about -g cos(theta) cos(phi) in unaccelerated flight: positive means a sign error,
  about -1 means g units). The airspeed against the GPS ground speed (a ratio near 0.514
  means knots, near 0.305 feet per second).
* **Innovations of the filter** (normalised mean and spread per channel): a large mean in
  ``tas`` with GPS points at wind or an airspeed calibration; in ``alpha`` or ``beta``
  regressed on the angle itself, the rate and the angle's rate of change: a vane scale
  factor, the vane's position ahead of the c.g., or a time lag.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from simplexspline.aero.reconstruction.kinematics import euler_rates

__all__ = ["kinematic_checks", "innovation_causes", "likely_causes", "inconsistent_imu",
           "INCONSISTENT_PRIOR_SIGMAS"]

_UNIT_RATIOS = ((180 / math.pi, "degrees where radians are expected"),
                (math.pi / 180, "radians where degrees were converted twice"))


def _slope(y: np.ndarray, x: np.ndarray) -> float:
    ok = np.isfinite(y) & np.isfinite(x)
    x, y = x[ok] - x[ok].mean(), y[ok] - y[ok].mean()
    sxx = float(x @ x)
    return float(x @ y) / sxx if sxx > 0 else math.nan


def _name_slope(channel: str, slope: float) -> str | None:
    if not math.isfinite(slope):
        return None
    if -1.3 < slope < -0.7:
        return f"sign of {channel!r} (or of the rates): its rate of change is {slope:.2f} x " \
               "the gyros' prediction"
    for ratio, what in _UNIT_RATIOS:
        if 0.7 * ratio < abs(slope) < 1.3 * ratio:
            return f"units of {channel!r}: {what} (its rate of change is {slope:.3g} x the " \
                   "gyros' prediction)"
    return None


def kinematic_checks(task: Mapping, dt: float) -> list[str]:
    """Sign and unit problems visible in the raw channels of one maneuver.

    Parameters
    ----------
    task : mapping
        Column name -> (n,) array (SI as the schema claims).
    dt : float
        Sample interval [s].

    Returns
    -------
    list of str
        One sentence per problem found (empty when the channels are consistent or the
        maneuver does not move enough to tell).
    """
    out = []
    get = {c: np.asarray(task[c], dtype=float) for c in ("p", "q", "r", "phi", "theta")
           if c in task}
    if len(get) == 5 and len(get["p"]) > 20:
        p, q, r, phi, th = (get[c] for c in ("p", "q", "r", "phi", "theta"))
        pred = dict(zip(("phi", "theta", "psi"), euler_rates(p, q, r, phi, th)))
        for ch, rate in pred.items():
            if ch not in task or np.nanstd(rate) < 0.01:     # below 0.6 deg/s: cannot tell
                continue
            x = np.unwrap(np.asarray(task[ch], dtype=float)) if ch == "psi" else \
                np.asarray(task[ch], dtype=float)
            if not np.isfinite(x).all():
                continue
            why = _name_slope(ch, _slope(np.gradient(x, dt), rate))
            if why:
                out.append(why)
    if "az" in task and "theta" in task and "phi" in task:
        az = float(np.nanmean(task["az"]))
        expect = float(np.nanmean(-9.81 * np.cos(task["theta"]) * np.cos(task["phi"])))
        if az > 2.0:
            out.append(f"sign of 'az': mean {az:.3g} m/s^2, expected about {expect:.3g} "
                       "(z is down: level flight reads about -9.81)")
        elif -1.5 < az < -0.5 and expect < -5:
            out.append(f"units of 'az': mean {az:.3g}, expected about {expect:.3g} m/s^2 "
                       "(in g? multiply by 9.80665)")
    if all(c in task for c in ("vn_gps", "ve_gps", "vd_gps", "tas")):
        gs = np.sqrt(sum(np.asarray(task[c], dtype=float) ** 2
                         for c in ("vn_gps", "ve_gps", "vd_gps")))
        ratio = float(np.nanmean(task["tas"]) / np.nanmean(gs))
        for value, what in ((0.5144, "knots"), (0.3048, "feet per second"),
                            (1 / 0.5144, "GPS speed in knots"),
                            (1 / 0.3048, "GPS speed in ft/s")):
            if math.isfinite(ratio) and abs(ratio / value - 1) < 0.12:
                out.append(f"units of 'tas': {ratio:.3g} x the GPS ground speed ({what}?)")
    return out


def innovation_causes(stats: Mapping, innov: np.ndarray, task: Mapping, present: Mapping,
                      dt: float, names: tuple) -> list[str]:
    """Causes the innovations point to, for channels that do not fit.

    Parameters
    ----------
    stats : mapping
        Per-channel innovation statistics (``mean``, ``std`` normalised).
    innov : (n, m) ndarray
        Innovations (NaN where not measured), columns ``names``.
    task : mapping
        Column name -> (n,) array.
    present : mapping
        :func:`~simplexspline.aero.reconstruction.observability.channels_present`.
    dt : float
    names : tuple of str
        Measurement channel names.

    Returns
    -------
    list of str
    """
    out = []
    bad = {c: s for c, s in stats.items() if abs(s["mean"]) > 3 or s["std"] > 3}
    gps = present.get("gps_velocity") or present.get("gps_position")
    if "tas" in bad:
        out.append("wind or airspeed calibration: 'tas' innovations are off by "
                   f"{bad['tas']['mean']:+.3g} sigma on average"
                   + (" (with GPS a constant wind is estimated; gusts need "
                      "wind_random_walk)" if gps else " (no GPS: wind cannot be estimated)"))
    rate_of = {"alpha": "q", "beta": "r"}
    for ch in ("alpha", "beta"):
        if ch not in bad or ch not in task:
            continue
        e = innov[:, names.index(ch)]
        z = np.asarray(task[ch], dtype=float)
        w = np.asarray(task[rate_of[ch]], dtype=float)
        cand = {"vane scale factor (sensor_geometry.*_vane.scale)": z - np.nanmean(z),
                "vane position ahead of the c.g. (sensor_geometry.*_vane.position_m)": w,
                "time lag (sensor_geometry.lag_s)": np.gradient(z, dt)}
        scores = {}
        for label, x in cand.items():
            ok = np.isfinite(e) & np.isfinite(x)
            if ok.sum() > 10 and np.std(x[ok]) > 0 and np.std(e[ok]) > 0:
                scores[label] = abs(float(np.corrcoef(e[ok], x[ok])[0, 1]))
        best = max(scores, key=scores.get) if scores else None
        if best and scores[best] > 0.3:
            out.append(f"{ch!r}: {best} (innovations correlate {scores[best]:.2f} with it)")
        else:
            out.append(f"{ch!r}: vane offset or calibration (innovations off by "
                       f"{bad[ch]['mean']:+.3g} sigma)")
    for ch in ("phi", "theta", "psi", "vn_gps", "ve_gps", "vd_gps"):
        if ch in bad:
            out.append(f"{ch!r} does not fit the integrated gyros and accelerometers "
                       f"(innovations {bad[ch]['mean']:+.3g} sigma mean, {bad[ch]['std']:.3g} "
                       "std): units, signs, frame or a time lag")
    return out


def likely_causes(task: Mapping, dt: float, stats: Mapping | None = None,
                  innov: np.ndarray | None = None, present: Mapping | None = None,
                  names: tuple = ()) -> str:
    """One sentence naming the likely causes (for a divergence message), or ''."""
    causes = kinematic_checks(task, dt)
    if stats is not None and innov is not None:
        causes += innovation_causes(stats, innov, task, present or {}, dt, names)
    return "; ".join(dict.fromkeys(causes))


#: How many of the filter's prior sigmas a maneuver's IMU bias may lie from the campaign's
#: median before the maneuver is rejected (:func:`inconsistent_imu`).
INCONSISTENT_PRIOR_SIGMAS = 10.0

#: Fewest reconstructed maneuvers whose median IMU biases judge one maneuver's.
_MIN_MANEUVERS = 3

_IMU_UNITS = {"ax": "m/s^2", "ay": "m/s^2", "az": "m/s^2",
              "p": "rad/s", "q": "rad/s", "r": "rad/s"}


def inconsistent_imu(biases: Mapping, prior: Mapping) -> dict:
    """Maneuvers whose accelerometer or gyro biases lie far from the other maneuvers'.

    The IMU is one instrument for the whole flight: its biases drift by a fraction of
    the filter's prior sigma between maneuvers. A maneuver whose filter needs a bias
    :data:`INCONSISTENT_PRIOR_SIGMAS` prior sigmas away from the campaign's median has
    kinematics that do not hold: its accelerations and rates do not integrate to its air
    data and GPS (a glitch, a jump of the time base, a stretch of the record spliced from
    two parts, a channel frozen or wrongly scaled in that stretch only). On a simulated
    record whose landing was a blend of the last maneuver into the ground roll (13 s in
    which the airspeed fell from 110 to 30 m/s at 0.3 m/s^2 of specific force along x),
    the segmentation took the blend for a turn and its filter found an x-accelerometer
    bias of 6.1 m/s^2, 61 prior sigmas from the others' 0.02. A bias that every maneuver
    shares, however large, is the instrument's and passes.

    Parameters
    ----------
    biases : mapping of int to mapping
        Maneuver -> channel ('ax', 'ay', 'az' [m/s^2], 'p', 'q', 'r' [rad/s]) -> (value,
        sigma) or value: each maneuver's estimated biases (other keys are ignored).
    prior : mapping
        The filter's prior sigmas ``accel_bias`` [m/s^2] and ``gyro_bias`` [rad/s]
        (:attr:`ReconstructionSettings.prior`).

    Returns
    -------
    dict of int to str
        Maneuver -> the reason it is rejected, naming the channels; empty with fewer
        than three maneuvers.
    """
    if len(biases) < _MIN_MANEUVERS:
        return {}
    limit = {ch: INCONSISTENT_PRIOR_SIGMAS * float(prior["accel_bias" if ch[0] == "a"
                                                         else "gyro_bias"])
             for ch in _IMU_UNITS}
    values = {ch: {m: float(b[ch][0] if isinstance(b[ch], (tuple, list)) else b[ch])
                   for m, b in biases.items() if ch in b} for ch in _IMU_UNITS}
    out: dict = {}
    for ch, per in values.items():
        finite = [v for v in per.values() if math.isfinite(v)]
        if len(finite) < _MIN_MANEUVERS:
            continue
        median = float(np.median(finite))
        for m, v in per.items():
            if math.isfinite(v) and abs(v - median) > limit[ch]:
                out.setdefault(m, []).append(
                    f"{ch} {v:+.3g} {_IMU_UNITS[ch]} against the campaign's median "
                    f"{median:+.3g} ({abs(v - median) / limit[ch] * INCONSISTENT_PRIOR_SIGMAS:.0f}"
                    " prior sigmas)")
    return {m: ("its IMU biases lie far from every other maneuver's (" + "; ".join(parts)
                + "): its accelerations and rates do not integrate to its air data and "
                "GPS. A glitch, a jump of the time base, a stretch spliced from two parts "
                "of the record, or a channel wrong in that stretch only: check the record "
                "there")
            for m, parts in out.items()}
