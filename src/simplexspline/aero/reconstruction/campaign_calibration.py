"""One campaign calibration from the per-maneuver estimates of the same constant, with the
estimates that disagree with the others left out.

Each maneuver's filter ends with a posterior of the same air-data error (an airspeed bias,
a vane offset or scale factor) under the same zero-mean prior. Their information-weighted
combination counts the prior once::

    w = sum(1/sd_i^2) - (N - 1)/sd_0^2,   value = sum(v_i/sd_i^2) / w,   sd = w^-1/2.

The weights trust every maneuver's sigma. One maneuver whose model was wrong then decides
the campaign: measured on the real-like record of ``bench_real_like.py`` in light
turbulence, with half the airspeed channel's lag undone, the turn of maneuver 7 chose still
air and gave an airspeed bias of 3.10 +- 0.18 m/s; the other four turns gave -1.3 to 1.8 m/s
with sigmas of 0.44-1.7, and the campaign's bias came out at 2.66 +- 0.16 m/s (the truth: 0.5)
and every airspeed 2.6 m/s off. Here (:func:`combine_campaign`) an estimate more than
:func:`outlier_threshold` sigma from the combination of the others (both sigmas counted,
and scaled by the others' own scatter when it exceeds their sigmas: the filters' sigmas
tend to be optimistic alike) is left out, the worst first, as long as at least three are
compared, and so is every other estimate of that maneuver (its model was wrong); what was
left out is reported. The threshold keeps the chance that an honest campaign loses an
estimate below 1 % (Bonferroni over the constants and the estimates): on the main job's
100 Hz campaign the largest distance was 3.36 sigma among 20 estimates of 5 constants
(kept; the threshold is 3.89), the bad turn above was 5.6 sigma among 5 (threshold 3.54).

Only estimates of maneuvers that observe the constant themselves are combined: posterior
sigma at most :data:`OBSERVED` (half) of the prior's. Counting the prior once un-shrinks
every posterior, and a posterior that its prior mostly made is un-shrunk most: measured on
a whole c172p flight in light turbulence (10 Hz, no heading, GPS positions only, 44-56 m/s),
five turns estimated the airspeed bias at +2.3..+3.9 m/s with sigmas of 1.1-1.8 against the
prior's 2.0 (the truth: 0.0; what the turbulence does to a turn's estimate), and their
combination was 5.4 +- 0.8 m/s: every airspeed 5.4 m/s (11 %) low. With none of them
observing it alone, the bias is held at its prior, and the airspeed error is the sensor's
0.36 m/s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from statistics import NormalDist

import numpy as np

__all__ = ["FALSE_ALARM", "LONE_SHARE", "OBSERVED", "SCALE_FROM_MEANS_MIN", "WIND_FLOOR",
           "CombinedEstimate", "JointEstimate", "ScaleFromMeans", "campaign_priors",
           "campaign_wind", "combine_campaign", "combine_estimates", "combine_joint",
           "lone_in_gusts", "outlier_threshold", "prior_conflicts", "spread_between",
           "vane_scale_from_means"]

#: Chance that an honest campaign loses an estimate (a Bonferroni bound over its constants
#: and their estimates).
FALSE_ALARM = 0.01
#: Smallest sigma [m/s] of the campaign's wind as a straight maneuver's prior
#: (:func:`campaign_wind`): the wind of one air mass changes over a flight's hour and a few
#: hundred metres of altitude by about this much at least, and a turn or two cannot
#: measure that change.
WIND_FLOOR = 0.5
#: Largest ratio of a maneuver's posterior sigma to the prior's for its estimate to be
#: combined (:func:`combine_campaign`): the maneuver observes the constant itself.
OBSERVED = 0.5
#: Share of the combined estimates' information (beyond the prior) above which one
#: maneuver's estimate is all that a combination rests on (:func:`lone_in_gusts`): the
#: others' pooled sigma is then more than three times its own.
LONE_SHARE = 0.9


def outlier_threshold(n: int, false_alarm: float = FALSE_ALARM) -> float:
    """Sigmas from the others beyond which one of ``n`` estimates of a constant is left
    out: the two-sided normal quantile of ``false_alarm / n`` (3.09 for 5 estimates at
    1 %, 3.48 for 20)."""
    if not 0.0 < false_alarm < 1.0:
        raise ValueError(f"false_alarm must lie in (0, 1), got {false_alarm!r}")
    return NormalDist().inv_cdf(1.0 - false_alarm / (2 * max(n, 1)))


@dataclass(frozen=True)
class CombinedEstimate:
    """The campaign's value of one constant.

    Attributes
    ----------
    value, sigma : float
        The combination of the estimates kept (the unit of the constant).
    used : tuple of int
        The maneuvers whose estimates were combined.
    excluded : dict of int to tuple
        Maneuver -> (value, sigma, z): the estimates left out, with their distance from the
        combination of the others in sigmas.
    """

    value: float
    sigma: float
    used: tuple = ()
    excluded: dict = field(default_factory=dict)


def _pool(estimates: Sequence[tuple]) -> tuple[float, float]:
    """(value, sigma) of posteriors (value, sigma, prior sigma, ...) of one constant under
    one zero-mean prior (that of the first), the prior counted once; sigma inf when
    together they hold less information than the prior (inconsistent sigmas)."""
    sd0 = estimates[0][2]
    w = sum(1.0 / e[1] ** 2 for e in estimates) - (len(estimates) - 1) / sd0 ** 2
    if not w > 0:
        return 0.0, math.inf
    return sum(e[0] / e[1] ** 2 for e in estimates) / w, w ** -0.5


def _dispersion(estimates: Sequence[tuple], value: float) -> float:
    """How much more the estimates scatter about their combination ``value`` than their
    sigmas say (the Birge ratio chi^2/dof, at least 1): filters' sigmas are often
    optimistic alike, and an estimate is judged against the scatter the others show."""
    if len(estimates) < 2:
        return 1.0
    chi2 = sum((e[0] - value) ** 2 / e[1] ** 2 for e in estimates)
    return max(1.0, chi2 / (len(estimates) - 1))


def combine_estimates(estimates: Sequence[tuple],
                      false_alarm: float = FALSE_ALARM) -> CombinedEstimate | None:
    """The combination of per-maneuver posteriors of one constant, outliers left out.

    Parameters
    ----------
    estimates : sequence of (value, sigma, prior_sigma, maneuver)
        Each maneuver's final estimate, its standard deviation and the prior's (the same
        in all), in the constant's unit.
    false_alarm : float
        Chance of leaving out an estimate of honest ones (:func:`outlier_threshold`).

    Returns
    -------
    CombinedEstimate or None
        None when there are no finite estimates or together they hold less information
        than the prior; posteriors as wide as the prior give the prior's sigma (the
        caller decides whether that is information).
    """
    kept = [tuple(e) for e in estimates if math.isfinite(e[0]) and e[1] > 0]
    if not kept:
        return None
    excluded = {}
    while len(kept) >= 3:
        worst, z_worst = None, outlier_threshold(len(kept), false_alarm)
        for i, e in enumerate(kept):
            others = kept[:i] + kept[i + 1:]
            value, sd = _pool(others)
            z = (abs(e[0] - value) / math.hypot(e[1], sd) / math.sqrt(_dispersion(others, value))
                 if math.isfinite(sd) else 0.0)
            if z > z_worst:
                worst, z_worst = i, z
        if worst is None:
            break
        e = kept.pop(worst)
        excluded[e[3]] = (e[0], e[1], z_worst)
    value, sd = _pool(kept)
    if not math.isfinite(sd):
        return None
    return CombinedEstimate(float(value), float(sd), tuple(e[3] for e in kept), excluded)


def combine_campaign(estimates: dict) -> tuple[dict, dict]:
    """Every constant's combination, a maneuver left out of one left out of all.

    Parameters
    ----------
    estimates : dict of str to list
        Constant -> its estimates (value, sigma, prior_sigma, maneuver) (see
        :func:`combine_estimates`); those whose sigma exceeds :data:`OBSERVED` times the
        prior's are not combined (the maneuver hardly observes the constant).

    Returns
    -------
    combined : dict of str to CombinedEstimate or None
        Of the estimates of the maneuvers that no constant left out (None: no maneuver
        observes the constant).
    excluded : dict of str to dict
        Constant -> {maneuver: (value, sigma, z)}: the estimates left out for being far
        from the others (``z`` sigma), not those dropped with their maneuver.
    """
    false_alarm = FALSE_ALARM / max(len(estimates), 1)
    estimates = {k: [e for e in est if e[1] <= OBSERVED * e[2]] for k, est in estimates.items()}
    distrusted: set = set()
    excluded: dict = {}
    while True:
        combined = {k: combine_estimates([e for e in est if e[3] not in distrusted],
                                         false_alarm) for k, est in estimates.items()}
        new = {m for c in combined.values() if c is not None for m in c.excluded}
        for k, c in combined.items():
            if c is not None and c.excluded:
                excluded.setdefault(k, {}).update(c.excluded)
        if not new:
            return combined, excluded
        distrusted |= new


@dataclass(frozen=True)
class JointEstimate:
    """The campaign's values of constants that maneuvers observe only together.

    Attributes
    ----------
    value : numpy.ndarray, shape (k,)
        The combination of the maneuvers kept (the constants' units).
    cov : numpy.ndarray, shape (k, k)
        Its covariance.
    used : tuple of int
        The maneuvers combined (those that observe some combination of the constants).
    excluded : dict of int to float
        Maneuver -> its largest distance from the others' combination [sigma], for the
        maneuvers left out.
    """

    value: np.ndarray
    cov: np.ndarray
    used: tuple = ()
    excluded: dict = field(default_factory=dict)

    def sigma(self) -> np.ndarray:
        """Standard deviations of the constants, shape (k,)."""
        return np.sqrt(np.diag(self.cov))

    def determined(self, prior_sd) -> np.ndarray:
        """Which constants the campaign holds, shape (k,) of bool: none when the
        combination determines none of them (sigma above :data:`OBSERVED` times the
        prior's), else every one it knows better than the prior. The values are one joint
        estimate: an offset found with a scale error of 0.035 +- 0.027 is the offset *for*
        that scale error, and a maneuver that re-estimated the scale error from its own
        prior would read the vane against an offset meant for another (measured on a
        still-air Cessna course without a maneuver list: the angle of attack 1.85e-3 rad
        RMS off with the scale error re-estimated per maneuver, 1.49e-3 held)."""
        sd, sd0 = self.sigma(), np.asarray(prior_sd, dtype=float)
        if not np.any(sd <= OBSERVED * sd0):
            return np.zeros(sd.size, dtype=bool)
        return sd < sd0


def _observed_part(mean, cov, prior_sd) -> tuple:
    """The directions one maneuver observes itself and what its data say along them, in
    the prior's whitened coordinates ``z = theta / prior_sd`` (prior ``N(0, I)``: the
    directions then do not depend on the constants' units, radians against metres).

    The data's information is the posterior's less the prior's; a direction counts as
    observed where the posterior sigma is at most :data:`OBSERVED` of the prior's along it
    (the scalar rule of :func:`combine_campaign`). Returns ``(directions (k, m),
    information (m,), values (m,))``: whitened unit vectors, the data's information along
    each and the data's value along each."""
    sd0 = np.asarray(prior_sd, dtype=float)
    mean = np.asarray(mean, dtype=float) / sd0
    post_info = np.linalg.inv(np.asarray(cov, dtype=float) / np.outer(sd0, sd0))
    data = post_info - np.eye(sd0.size)
    lam, vec = np.linalg.eigh(0.5 * (data + data.T))
    keep = lam >= OBSERVED ** -2 - 1.0                # sd_post <= OBSERVED sd_prior
    u, lam = vec[:, keep], lam[keep]
    info_vector = post_info @ mean                     # the prior's mean is zero
    return u, lam, (u.T @ info_vector) / lam if lam.size else np.zeros(0)


def _pool_joint(parts: Sequence[tuple], k: int) -> tuple[np.ndarray, np.ndarray]:
    """Combination (value, covariance) of observed parts under the whitened prior
    ``N(0, I)`` of ``k`` constants."""
    info = np.eye(k)
    vector = np.zeros(k)
    for u, lam, y in parts:
        info = info + (u * lam) @ u.T
        vector = vector + u @ (lam * y)
    cov = np.linalg.inv(info)
    return cov @ vector, cov


def combine_joint(estimates: Sequence[tuple],
                  false_alarm: float = FALSE_ALARM) -> JointEstimate | None:
    """The combination of per-maneuver joint posteriors of several constants that each
    maneuver observes only in combination, outliers left out.

    A vane's offset ``b`` and scale error ``k`` enter its reading as ``b + k alpha``: a
    maneuver flown at one angle of attack (a stationary measurement) observes that sum, not
    either constant, and its marginal posteriors stay near the prior, so
    :func:`combine_campaign` cannot use it. Measured on a simulated still-air Cessna
    flight-test course (10 Hz, no heading channel, the vane 4 % off in scale and 0.7 deg in
    offset, installation not given): the turns alone determined the offset but not the scale
    error, each maneuver then estimated its own (-0.16 to +0.15) and angles of attack of
    short maneuvers came out up to 4.4e-3 rad off. The information each maneuver's data add
    along the directions it observes (:func:`_observed_part`) is summed here, the prior
    counted once, so six stationary measurements at six angles of attack give both.

    Parameters
    ----------
    estimates : sequence of (mean, cov, prior_sd, maneuver)
        Each maneuver's final posterior of the constants: mean (k,), covariance (k, k) and
        the prior's standard deviations (k,) (zero-mean, the same in every maneuver).
    false_alarm : float
        Chance of leaving out a maneuver of honest ones (:func:`outlier_threshold` over the
        directions tested).

    Returns
    -------
    JointEstimate or None
        None when no maneuver observes any combination of the constants.

    Notes
    -----
    A maneuver is compared with the combination of the others along each direction it
    observes: ``z = (y - u.x) / sqrt(1/lambda + u C u)``, scaled by the others' own scatter
    when it exceeds their sigmas (as :func:`combine_estimates`); the worst beyond the
    threshold is left out, while at least three maneuvers are compared.
    """
    parts = {}
    prior_sd = None
    for mean, cov, sd0, m in estimates:
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
            continue
        prior_sd = np.asarray(sd0, dtype=float)
        part = _observed_part(mean, cov, sd0)
        if part[1].size:
            parts[m] = part
    if not parts:
        return None
    k = prior_sd.size
    excluded = {}
    while len(parts) >= 3:
        n_dir = sum(p[1].size for p in parts.values())
        worst, z_worst = None, outlier_threshold(n_dir, false_alarm)
        for m, (u, lam, y) in parts.items():
            others = [p for q, p in parts.items() if q != m]
            x, c = _pool_joint(others, k)
            chi2 = sum(float(np.sum(lo * (yo - uo.T @ x) ** 2)) for uo, lo, yo in others)
            dof = sum(lo.size for _, lo, _ in others) - x.size
            scale = math.sqrt(max(1.0, chi2 / dof)) if dof > 0 else 1.0
            spread = 1.0 / lam + np.einsum("ij,ik,kj->j", u, c, u)
            z = float(np.max(np.abs(y - u.T @ x) / np.sqrt(spread))) / scale
            if z > z_worst:
                worst, z_worst = m, z
        if worst is None:
            break
        parts.pop(worst)
        excluded[worst] = z_worst
    z, c = _pool_joint(list(parts.values()), k)
    value, cov = prior_sd * z, c * np.outer(prior_sd, prior_sd)
    return JointEstimate(value, cov, tuple(parts), excluded)


def _information(e: tuple) -> float:
    """What a posterior (value, sigma, prior sigma, ...) knows beyond its prior: the
    information ``1/sigma^2 - 1/prior^2`` (0 for a posterior as wide as the prior)."""
    return max(0.0, 1.0 / e[1] ** 2 - 1.0 / e[2] ** 2)


def lone_in_gusts(combined: dict, gusty: set, states: Sequence[str],
                  estimates: dict | None = None) -> dict:
    """The combinations that rest on one estimate from a maneuver with gusts, of the
    constants ``states``: nothing checks such an estimate, and turbulence biases it beyond
    its sigma where it trades against the horizontal wind (an airspeed bias: a simulated
    A-4 sortie's lone turn gave -2.51 +- 0.89 m/s for a true 0).

    The same holds for a combination of estimates that all come from maneuvers with gusts:
    turbulence biases them alike, and agreeing they check nothing (simulated 737 courses
    in light turbulence, 10 Hz, no heading, true bias 0: three turns gave +0.76 +- 0.18,
    +0.76 +- 0.52 and +0.39 +- 0.73 m/s on one, and every airspeed came out 0.75 m/s
    low; a global5000 sortie's three turns -0.88..-0.28, 0.77 m/s high). Otherwise "rests
    on one" means that, with ``estimates``, one turbulent maneuver holds more than
    :data:`LONE_SHARE` of the information beyond the prior of the estimates combined: the others together then have
    a sigma more than three times its own, and the outlier test of
    :func:`combine_estimates` could not see it off by less than about ten of its sigmas
    (measured on a simulated 737 course in light turbulence, 10 Hz, no heading: a 172 s
    turn gave the airspeed bias as 0.67 +- 0.15 m/s for a true 0, another turn 0.17 +-
    0.92; their combination, 0.66 +- 0.15, put every airspeed of the flight 0.66 m/s off,
    0.81 m/s RMS against the sensor's 0.50).

    Parameters
    ----------
    combined : dict of str to CombinedEstimate or None
        From :func:`combine_campaign`.
    gusty : set
        The maneuvers in which gusts were found.
    states : sequence of str
        The constants the rule applies to.
    estimates : dict of str to sequence of (value, sigma, prior_sigma, maneuver), optional
        The estimates that :func:`combine_campaign` was given; without them only a
        combination of one estimate counts.

    Returns
    -------
    dict of str to dict
        Constant -> {maneuver: (value, sigma, None)}, in the form of ``combine_campaign``'s
        ``excluded`` (no distance: there was nothing to measure it from): the one
        maneuver's estimate, its own value and sigma when others were combined with it.
    """
    out = {}
    for k, c in combined.items():
        if k not in states or c is None or not c.used:
            continue
        if len(c.used) == 1:
            if c.used[0] in gusty:
                out[k] = {c.used[0]: (c.value, c.sigma, None)}
            continue
        kept = [e for e in (estimates or {}).get(k, ()) if e[3] in c.used]
        if all(m in gusty for m in c.used):
            own = {e[3]: (e[0], e[1], None) for e in kept}
            out[k] = {m: own.get(m, (c.value, c.sigma, None)) for m in c.used}
            continue
        info = [_information(e) for e in kept]
        if not kept or not sum(info) > 0:
            continue
        top = int(np.argmax(info))
        if kept[top][3] in gusty and info[top] > LONE_SHARE * sum(info):
            out[k] = {kept[top][3]: (kept[top][0], kept[top][1], None)}
    return out


def spread_between(estimates: Sequence[tuple], value: float) -> float:
    """The standard deviation of the constant itself from maneuver to maneuver, beyond what
    the estimates' sigmas explain (DerSimonian and Laird's moment estimate, 0 when the
    scatter is no larger than the sigmas say).

    Parameters
    ----------
    estimates : sequence of (value, sigma, ...)
        At least two finite estimates.
    value : float
        Their combination.
    """
    if len(estimates) < 2:
        return 0.0
    w = [1.0 / e[1] ** 2 for e in estimates]
    q = sum(wi * (e[0] - value) ** 2 for wi, e in zip(w, estimates))
    denom = sum(w) - sum(wi * wi for wi in w) / sum(w)
    if not denom > 0:
        return 0.0
    return math.sqrt(max(0.0, (q - (len(estimates) - 1)) / denom))


def campaign_priors(estimates: dict, informative: float = 0.5) -> tuple[dict, dict, dict]:
    """Priors for constants that the maneuvers of a campaign share but that not every
    maneuver observes (an IMU's biases: a gyro bias is seen in a turn, not in a straight
    maneuver without a heading channel).

    Each maneuver gets the combination of the *other* maneuvers' estimates (its own data
    are not counted twice), with the sigma of a new maneuver's value: the combination's
    sigma and the constant's own spread between maneuvers (:func:`spread_between`), so a
    bias that changes between flights gives a wide prior and one that stays gives a tight
    one. A constant whose prior would not be narrower than ``informative`` times the
    filter's own prior is left out: the campaign does not know it better than the maneuver.

    Parameters
    ----------
    estimates : dict of str to list
        Constant -> its estimates (value, sigma, prior_sigma, maneuver), as for
        :func:`combine_campaign` (outliers are left out the same way).
    informative : float
        Largest ratio of the campaign prior's sigma to the filter's prior sigma kept.

    Returns
    -------
    campaign : dict of str to (float, float)
        Constant -> (value, sigma) for a maneuver whose estimate was not combined.
    per_maneuver : dict of int to dict
        Maneuver -> {constant: (value, sigma)} for every maneuver combined: the others'
        combination (a constant absent when fewer than two others remain: the maneuver's
        own estimate is never part of its prior).
    excluded : dict of str to dict
        As :func:`combine_campaign`.
    """
    if not 0.0 < informative <= 1.0:
        raise ValueError(f"informative must lie in (0, 1], got {informative!r}")
    combined, excluded = combine_campaign(estimates)
    campaign: dict = {}
    per_maneuver: dict = {}
    for k, c in combined.items():
        if c is None:
            continue
        kept = [e for e in estimates[k] if e[3] in c.used]
        limit = informative * kept[0][2]
        sd = math.hypot(c.sigma, spread_between(kept, c.value))
        if sd < limit:
            campaign[k] = (c.value, sd)
        for i, e in enumerate(kept):
            mine = per_maneuver.setdefault(e[3], {})
            others = kept[:i] + kept[i + 1:]
            if len(others) < 2:
                continue
            value, sd = _pool(others)
            sd = math.hypot(sd, spread_between(others, value))
            if sd < limit:
                mine[k] = (value, sd)
    return campaign, per_maneuver, excluded


def prior_conflicts(posterior: dict, prior: dict) -> dict:
    """Constants whose estimate moved further from their (campaign) prior than the prior and
    the data allow.

    Under a consistent model the shift of a constant's posterior mean from its prior mean
    has the variance ``prior - posterior``; a shift beyond :func:`outlier_threshold` of
    the constants (1 % false alarms over them) is a conflict.

    Parameters
    ----------
    posterior : dict of str to (float, float)
        Constant -> (value, variance) at the end of the maneuver.
    prior : dict of str to (float, float)
        Constant -> (value, sigma) the maneuver started from.

    Returns
    -------
    dict of str to float
        Constant -> its shift in sigmas, for the conflicts only.
    """
    if not prior:
        return {}
    limit = outlier_threshold(len(prior))
    found = {}
    for k, (value, sd) in prior.items():
        x, var = posterior[k]
        spread = sd ** 2 - var
        if spread > 0 and math.isfinite(x) and math.isfinite(var):
            z = abs(x - value) / math.sqrt(spread)
            if z > limit:
                found[k] = float(z)
    return found


def campaign_wind(estimates: Sequence[tuple]) -> tuple[float, float, float] | None:
    """The campaign's steady wind from the maneuvers that observe it: a straight maneuver's
    prior when the record has no heading channel.

    Without a heading channel a straight maneuver cannot tell its heading from a crosswind
    (a heading error ``d`` and a crosswind ``V d`` give the same data), so the filter held
    the crosswind at zero with the heading on the GPS track. In a lateral maneuver the
    heading then changes by some degrees, the crab angle of the real wind ``W`` changes by
    ``(W / V)`` times that, and the reconstructed sideslip took the difference: on a
    still-air flight-test course (5.3 m/s of wind at 145-220 m/s) the pulses' sideslip
    drifted by up to 6.7e-3 rad, more than the sideslip they made. The turns of the same
    flight observe the wind (the wind triangle); their combination (:func:`_pool`), with
    their scatter (:func:`spread_between`: none is left out, a wind that changes between
    turns is a wind that changes) and :data:`WIND_FLOOR` added, starts every straight
    maneuver when it is informative (the caller compares it with the prior's crosswind
    sigma). Turns that disagree (separately simulated maneuvers, each with its own wind:
    6-8 m/s from three directions) give a sigma as wide as their scatter.

    Parameters
    ----------
    estimates : sequence of (north, east, maneuver)
        Per turning maneuver, its wind's north and east components, each ``(value, sigma,
        prior_sigma)`` [m/s], and the maneuver id.

    Returns
    -------
    (north, east, sigma) or None
        The wind [m/s] and one sigma for both components [m/s]; None without an estimate
        or when together they hold less information than the prior.
    """
    comps = []
    for j in range(2):
        est = [(*e[j], e[2]) for e in estimates
               if math.isfinite(e[j][0]) and e[j][1] > 0]
        if not est:
            return None
        value, sd = _pool(est)
        if not math.isfinite(sd):
            return None
        comps.append((value, math.hypot(sd, spread_between(est, value))))
    sd = max(WIND_FLOOR, comps[0][1], comps[1][1])
    return comps[0][0], comps[1][0], sd


#: Fewest maneuvers whose means determine a vane's scale error across the campaign
#: (:func:`vane_scale_from_means`): two constants and a scatter to judge them by.
SCALE_FROM_MEANS_MIN = 5


@dataclass(frozen=True)
class ScaleFromMeans:
    """A vane's scale error and offset from the maneuvers' mean angles.

    Attributes
    ----------
    scale, scale_sd : float
        The scale error ``k`` (the vane reads ``(1 + k)`` times the local flow angle) [-].
    offset, offset_sd : float
        The vane's offset at zero angle [rad].
    used : tuple of int
        The maneuvers whose means were fitted.
    excluded : dict of int to float
        Maneuver -> distance from the others' fit in sigmas: means left out.
    spread : float
        Standard deviation of the maneuvers' mean kinematic angles [rad].
    """

    scale: float
    scale_sd: float
    offset: float
    offset_sd: float
    used: tuple = ()
    excluded: dict = field(default_factory=dict)
    spread: float = 0.0


def _fit_means(a: np.ndarray, r: np.ndarray, w: np.ndarray) -> tuple:
    """Weighted straight line ``r = b + k a``: (k, b, cov, residuals, sigma^2, weighted
    residual terms ``X' W e`` per point (n, 2), ``(X' W X)^-1``)."""
    X = np.column_stack([np.ones_like(a), a])
    W = w / w.mean()
    bread = np.linalg.inv(X.T @ (W[:, None] * X))
    coef = bread @ (X.T @ (W * r))
    res = r - X @ coef
    s2 = float(np.sum(W * res ** 2) / (a.size - 2))
    return (float(coef[1]), float(coef[0]), bread * s2, res, s2,
            X * (W * res)[:, None], bread)


def _with_prior(coef: tuple, cov: np.ndarray, prior: tuple | None) -> tuple:
    """The line ``(b, k)`` of :func:`_fit_means` (its covariance ``cov``) combined with a
    zero-mean prior of sigmas ``prior = (offset_sd, scale_sd)``: (mean (2,), covariance
    (2, 2)); unchanged without a prior."""
    mean = np.array(coef, dtype=float)
    if prior is None:
        return mean, cov
    inv = np.linalg.inv(cov) + np.diag(1.0 / np.square(np.asarray(prior, dtype=float)))
    post = np.linalg.inv(inv)
    return post @ (np.linalg.solve(cov, mean)), post


def vane_scale_from_means(means, false_alarm: float = FALSE_ALARM,
                          prior: tuple | None = None) -> ScaleFromMeans | None:
    """A vane's scale error and offset across the campaign, from each maneuver's mean
    kinematic flow angle and mean vane residual.

    In turbulence a maneuver's filter cannot estimate the scale error (the part of the
    gusts' angles its gust model does not follow correlates with the angle itself), but
    the means over whole maneuvers hardly see the gusts: over a minute the mean vertical
    gust of light turbulence is a few tenths of a m/s, against test points whose angles of
    attack differ by degrees. Each maneuver gives ``a``, the mean angle at the vane that
    its kinematics give with the gusts (and the steady vertical wind) left out, and ``r``,
    the mean of the vane's reading minus that angle; across maneuvers ``r = b + k a``
    (weighted by the samples: a mean over a longer stretch holds less gust). The means
    still carry each maneuver's mean gust, and the aircraft rides a slow gust, so the
    errors of ``a`` are not independent of the angle: on a simulated course the fit found
    78 % of a 25 % scale error (docs/reconstruction.md, "The vane's scale in turbulence").

    A maneuver whose mean lies more than :func:`outlier_threshold` sigma from the line of
    the others is left out (the worst first, while :data:`SCALE_FROM_MEANS_MIN` remain).
    With ``prior`` that line is the others' combined with the prior of the offset and the
    scale error: where the others' angles hardly differ, their own line says nothing about
    a mean far from them, and one maneuver whose kinematic angle has gone astray (a
    segment of a record whose kinematics do not hold: on a simulated course, 0.52 rad
    against the vane's 0.03) would otherwise set the scale alone (there: -1.00, a vane
    that does not move).

    The maneuvers of one test point share its air mass: over the minutes of a leg the
    slow part of the turbulence does not average out (on a simulated global5000 course
    the last leg's maneuvers all had a mean vertical wind of +0.3 to +0.7 m/s, 2-5e-3 rad).
    With ``group`` given, the sigmas are therefore clustered by it (the sandwich over the
    groups, ``G / (G - 1)``; never below the independent ones), and fewer than three
    groups give no fit.

    Parameters
    ----------
    means : sequence of (a, r, n, maneuver[, group])
        Per maneuver: mean kinematic angle [rad], mean residual [rad], samples, id, and
        optionally its test point (any hashable: the maneuvers that share an air mass).
    false_alarm : float
        Chance of leaving out a mean of an honest campaign.
    prior : (float, float), optional
        Prior sigmas of the offset [rad] and of the scale error [-] (zero means), for the
        test of each mean against the others; the fit itself is the data's alone.

    Returns
    -------
    ScaleFromMeans or None
        None with fewer than :data:`SCALE_FROM_MEANS_MIN` finite means or no spread of
        the angles (the caller judges the sigma).
    """
    kept = [tuple(m) for m in means
            if all(math.isfinite(float(x)) for x in m[:2]) and m[2] > 0]
    if len(kept) < SCALE_FROM_MEANS_MIN:
        return None
    grouped = all(len(m) > 4 for m in kept)
    excluded = {}
    while True:
        a, r, w = (np.array([m[j] for m in kept], dtype=float) for j in range(3))
        if not np.ptp(a) > 0:
            return None
        k, b, cov, res, s2, terms, bread = _fit_means(a, r, w)
        if len(kept) <= SCALE_FROM_MEANS_MIN:
            break
        worst, z_worst = None, outlier_threshold(len(kept), false_alarm)
        for i in range(len(kept)):
            rest = np.arange(len(kept)) != i
            k_i, b_i, cov_i, _, s2_i, _, _ = _fit_means(a[rest], r[rest], w[rest])
            line, cov_i = _with_prior((b_i, k_i), cov_i, prior)
            x = np.array([1.0, a[i]])
            # the mean's own scatter (its weight) plus the others' line's uncertainty
            var = s2_i * w[rest].mean() / w[i] + float(x @ cov_i @ x)
            z = abs(r[i] - float(x @ line)) / math.sqrt(var) if var > 0 else 0.0
            if z > z_worst:
                worst, z_worst = i, z
        if worst is None:
            break
        excluded[kept[worst][3]] = float(z_worst)
        kept.pop(worst)
    if grouped:
        groups = [m[4] for m in kept]
        if len(set(groups)) < 3:
            return None
        meat = np.zeros((2, 2))
        for g in set(groups):
            sg = terms[np.array([x == g for x in groups])].sum(axis=0)
            meat += np.outer(sg, sg)
        G = len(set(groups))
        clustered = bread @ meat @ bread * G / (G - 1)
        var = np.maximum(np.diag(cov), np.diag(clustered))
    else:
        var = np.diag(cov)
    return ScaleFromMeans(k, float(math.sqrt(var[1])), b, float(math.sqrt(var[0])),
                          tuple(m[3] for m in kept), excluded, float(np.std(a)))
