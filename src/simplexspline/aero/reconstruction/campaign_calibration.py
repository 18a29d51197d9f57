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
and every airspeed 2.6 m/s off. Here an estimate more than :func:`outlier_threshold` sigma
from the combination of the others (both sigmas counted, and scaled by the others' own scatter when
it exceeds their sigmas: the filters' sigmas tend to be optimistic alike) is left out, the
worst first, while at least three remain; what was left out is reported. The threshold
keeps the chance of leaving out an honest estimate of a campaign below 1 %: on the main
job's 100 Hz campaign the largest distance was 3.36 sigma among 20 (kept; the threshold
for 20 is 3.48), the bad turn above was 5.6 sigma among 5 (threshold 3.09).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from statistics import NormalDist

__all__ = ["FALSE_ALARM", "CombinedEstimate", "combine_estimates", "outlier_threshold"]

#: Chance that one of N honest estimates is left out (a Bonferroni bound): the threshold
#: grows with N, 3.1 sigma for 5 estimates, 3.5 for 20.
FALSE_ALARM = 0.01


def outlier_threshold(n: int) -> float:
    """Sigmas from the others beyond which one of ``n`` estimates is left out: the
    two-sided normal quantile of :data:`FALSE_ALARM` / n."""
    return NormalDist().inv_cdf(1.0 - FALSE_ALARM / (2 * max(n, 1)))


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
    one zero-mean prior, the prior counted once; sigma inf when they hold no information
    beyond the prior."""
    sd0 = estimates[0][2]
    w = sum(1.0 / e[1] ** 2 for e in estimates) - (len(estimates) - 1) / sd0 ** 2
    if not w > 0:
        return 0.0, math.inf
    return sum(e[0] / e[1] ** 2 for e in estimates) / w, w ** -0.5


def _dispersion(estimates: Sequence[tuple]) -> float:
    """How much more the estimates scatter than their sigmas say (the Birge ratio
    chi^2/dof about their combination, at least 1): filters' sigmas are often optimistic
    alike, and an estimate is judged against the scatter the others show."""
    if len(estimates) < 2:
        return 1.0
    value, _sd = _pool(estimates)
    chi2 = sum((e[0] - value) ** 2 / e[1] ** 2 for e in estimates)
    return max(1.0, chi2 / (len(estimates) - 1))


def combine_estimates(estimates: Sequence[tuple]) -> CombinedEstimate | None:
    """The combination of per-maneuver posteriors of one constant, outliers left out.

    Parameters
    ----------
    estimates : sequence of (value, sigma, prior_sigma, maneuver)
        Each maneuver's final estimate, its standard deviation and the prior's (the same
        in all), in the constant's unit.

    Returns
    -------
    CombinedEstimate or None
        None when there are no estimates or they hold no information beyond the prior.
    """
    kept = [tuple(e) for e in estimates if math.isfinite(e[0]) and e[1] > 0]
    if not kept:
        return None
    excluded = {}
    while len(kept) >= 3:
        worst, z_worst = None, outlier_threshold(len(kept))
        for i, e in enumerate(kept):
            others = kept[:i] + kept[i + 1:]
            value, sd = _pool(others)
            z = (abs(e[0] - value) / math.hypot(e[1], sd) / math.sqrt(_dispersion(others))
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
