"""The campaign calibration: per-maneuver posteriors of one constant combined with the prior
counted once, and an estimate that disagrees with the others left out and named."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings as hsettings, strategies as st

from simplexspline.aero import import_record
from simplexspline.aero.reconstruction.campaign_calibration import (
    FALSE_ALARM,
    LONE_SHARE,
    OBSERVED,
    SCALE_FROM_MEANS_MIN,
    WIND_FLOOR,
    campaign_priors,
    campaign_wind,
    combine_campaign,
    combine_estimates,
    JointEstimate,
    combine_joint,
    lone_in_gusts,
    outlier_threshold,
    prior_conflicts,
    spread_between,
    vane_scale_from_means,
)
from simplexspline.aero.reconstruction.reconstruct import (
    HELD_STRAIGHT,
    ReconstructionSettings,
    reconstruct,
)

SD0 = 2.0


def _formula(est, sd0=SD0):
    w = sum(1 / sd ** 2 for _v, sd, *_ in est) - (len(est) - 1) / sd0 ** 2
    return sum(v / sd ** 2 for v, sd, *_ in est) / w, w ** -0.5


def test_consistent_estimates_are_combined_with_the_prior_counted_once():
    est = [(0.4, 0.3, SD0, 6), (0.9, 1.3, SD0, 8), (1.5, 0.9, SD0, 7), (-0.2, 1.7, SD0, 11)]
    c = combine_estimates(est)
    value, sd = _formula(est)
    assert c.value == pytest.approx(value) and c.sigma == pytest.approx(sd)
    assert c.used == (6, 8, 7, 11) and c.excluded == {}


def test_an_estimate_far_from_the_others_is_left_out_and_named():
    """The measured case: one turn judged as still air in turbulence gave a confident
    airspeed bias of 3.10 +- 0.18 m/s against the others' -1.3 to 1.8 with sigmas 0.44-1.7;
    combined, it made the campaign's bias 2.66 m/s (truth 0.5)."""
    others = [(0.118, 0.443, SD0, 6), (0.219, 1.508, SD0, 8), (-1.294, 1.676, SD0, 11),
              (1.831, 0.953, SD0, 0)]
    est = others[:2] + [(3.102, 0.180, SD0, 7)] + others[2:]
    assert _formula(est)[0] == pytest.approx(2.66, abs=0.01)     # what it was
    c = combine_estimates(est)
    assert set(c.excluded) == {7} and c.excluded[7][2] > outlier_threshold(5)
    value, sd = _formula(others)
    assert c.value == pytest.approx(value) and c.sigma == pytest.approx(sd)
    assert abs(c.value - 0.5) < 1.5 * c.sigma


def test_two_estimates_cannot_outvote_each_other_and_no_information_gives_none():
    c = combine_estimates([(3.0, 0.1, SD0, 1), (-3.0, 0.1, SD0, 2)])
    assert c.excluded == {} and c.value == pytest.approx(0.0, abs=1e-12)
    assert combine_estimates([]) is None
    # posteriors as wide as the prior: the combination is the prior's width (the caller
    # leaves such a state out); wider ones (inconsistent) give nothing
    assert combine_estimates([(0.1, SD0, SD0, 1), (0.2, SD0, SD0, 2)]).sigma == \
        pytest.approx(SD0)
    assert combine_estimates([(0.1, 1.5 * SD0, SD0, 1), (0.2, 1.5 * SD0, SD0, 2)]) is None
    assert combine_estimates([(math.nan, 0.1, SD0, 1)]) is None


@given(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=12), st.integers(0, 2 ** 31))
@hsettings(max_examples=50, deadline=None)
def test_estimates_within_their_sigmas_are_all_kept(values, seed):
    """Estimates of one value whose scatter is within their sigmas (here: at most 1 sigma
    from it, so at most 2 apart in units of the larger sigma) are never left out."""
    rng = np.random.default_rng(seed)
    sds = rng.uniform(0.3, 1.0, len(values))
    est = [(0.5 + v * sd, sd, SD0, i) for i, (v, sd) in enumerate(zip(values, sds))]
    c = combine_estimates(est)
    assert c.excluded == {} and len(c.used) == len(est)


def test_the_threshold_grows_with_the_number_of_estimates():
    """About 1 % family-wise: 3.09 sigma for 5 estimates, 3.48 for 20; 3.36 sigma among
    20 (the main job's largest, an honest one) is kept, among 5 it is not."""
    assert outlier_threshold(5) == pytest.approx(3.09, abs=0.01)
    assert outlier_threshold(20) == pytest.approx(3.48, abs=0.01)
    assert outlier_threshold(20, FALSE_ALARM / 5) == pytest.approx(3.89, abs=0.01)
    with pytest.raises(ValueError, match="false_alarm"):
        outlier_threshold(5, 0.0)
    rng = np.random.default_rng(3)
    for n, left_out in ((20, False), (5, True)):
        sds = np.full(n, 1.0)
        values = rng.normal(0.0, 1e-3, n)           # the others agree closely
        values[0] = 3.36 * math.sqrt(1.0 + 1.0 / (n - 1))   # 3.36 sigma from the others
        c = combine_estimates([(v, sd, 100.0, i) for i, (v, sd) in enumerate(zip(values, sds))])
        assert (0 in c.excluded) == left_out, (n, c.excluded)


def test_a_maneuver_left_out_of_one_constant_is_left_out_of_all():
    """Maneuver 7 disagrees on the airspeed bias and maneuver 4 on the vane scale; their
    other estimates agree but are dropped too."""
    btas = [(0.1, 0.4, SD0, 1), (0.2, 0.5, SD0, 2), (-0.1, 0.45, SD0, 3), (0.0, 0.5, SD0, 4),
            (9.0, 0.1, SD0, 7)]
    balpha = [(0.0030, 0.0010, 0.02, m) for m in (1, 2, 3, 4, 7)]
    kalpha = [(0.0, 0.005, 0.05, 1), (0.001, 0.005, 0.05, 2), (-0.002, 0.005, 0.05, 3),
              (0.2, 0.005, 0.05, 4)]
    combined, excluded = combine_campaign({"btas": btas, "balpha": balpha,
                                           "kalpha": kalpha, "bbeta": []})
    assert set(excluded["btas"]) == {7} and set(excluded["kalpha"]) == {4}
    assert combined["btas"].used == (1, 2, 3) and combined["balpha"].used == (1, 2, 3)
    assert combined["kalpha"].used == (1, 2, 3) and combined["bbeta"] is None
    assert "balpha" not in excluded          # dropped with its maneuvers, not for itself
    # threshold with 4 constants: FALSE_ALARM / 4 per constant
    assert excluded["btas"][7][2] > outlier_threshold(5, FALSE_ALARM / 4)


def test_the_others_scatter_widens_the_threshold():
    """When the other estimates scatter twice as much as their sigmas say, an estimate 4
    sigma off is within their scatter (2 'real' sigmas) and kept."""
    rng = np.random.default_rng(4)
    others = rng.normal(0.0, 2.0, 12)
    others = (others - others.mean()) / others.std(ddof=1) * 2.0
    est = [(v, 1.0, 100.0, i + 1) for i, v in enumerate(others)]
    far = 4.0 * math.sqrt(1.0 + 1.0 / 12)
    assert combine_estimates([(far, 1.0, 100.0, 0)] + est).excluded == {}
    assert 0 in combine_estimates([(far, 1.0, 100.0, 0)] +
                                  [(0.01 * v, 1.0, 100.0, i) for v, _s, _p, i in est]).excluded


def test_an_outlier_hidden_by_another_is_found_in_the_next_round():
    """On constant B, maneuvers 5 and 7 lie on either side of the others and widen their
    scatter, so neither stands out; once 7 is left out for constant A, 5 stands out on B
    and goes too, from A as well."""
    a = [(0.0, 0.1, SD0, m) for m in (1, 2, 3, 5)] + [(5.0, 0.1, SD0, 7)]
    b = [(0.0, 0.1, SD0, m) for m in (1, 2, 3)] + [(0.6, 0.1, SD0, 5), (-0.6, 0.1, SD0, 7)]
    assert combine_estimates(b, FALSE_ALARM / 2).excluded == {}      # alone: hidden
    combined, excluded = combine_campaign({"A": a, "B": b})
    assert set(excluded["A"]) == {7} and set(excluded["B"]) == {5}
    assert combined["A"].used == (1, 2, 3) and combined["B"].used == (1, 2, 3)


def test_the_spread_between_maneuvers_is_what_the_sigmas_do_not_explain():
    """DerSimonian-Laird: estimates scattered only by their sigmas give (about) zero;
    a constant that itself changes from maneuver to maneuver by tau gives about tau."""
    rng = np.random.default_rng(3)
    sig = rng.uniform(0.5, 1.5, 400)
    honest = [(s * rng.standard_normal(), s, 100.0, i) for i, s in enumerate(sig)]
    value = sum(e[0] / e[1] ** 2 for e in honest) / sum(1 / e[1] ** 2 for e in honest)
    assert spread_between(honest, value) < 0.15
    tau = 2.0
    varying = [(tau * rng.standard_normal() + s * rng.standard_normal(), s, 100.0, i)
               for i, s in enumerate(sig)]
    value = sum(e[0] / e[1] ** 2 for e in varying) / sum(1 / e[1] ** 2 for e in varying)
    assert spread_between(varying, value) == pytest.approx(tau, rel=0.15)
    assert spread_between(varying[:1], 0.0) == 0.0


def test_each_maneuver_gets_the_others_estimate_as_its_prior():
    """A maneuver's prior never holds its own estimate: it is the combination of the
    others (prior counted once), widened by their spread; maneuvers outside the pass get
    the whole campaign's."""
    est = {"br": [(1.0e-4, 2e-5, 2e-3, 0), (1.3e-4, 2e-5, 2e-3, 1), (1.1e-4, 3e-5, 2e-3, 2),
                  (1.2e-4, 2e-5, 2e-3, 3)]}
    campaign, per, excluded = campaign_priors(est)
    assert not excluded and set(per) == {0, 1, 2, 3}
    for i, e in enumerate(est["br"]):
        others = est["br"][:i] + est["br"][i + 1:]
        value, sd = _formula(others, sd0=2e-3)
        assert per[e[3]]["br"][0] == pytest.approx(value, rel=1e-12)
        tau = spread_between(others, value)
        assert per[e[3]]["br"][1] == pytest.approx(math.hypot(sd, tau), rel=1e-12)
    value, sd = _formula(est["br"], sd0=2e-3)
    assert campaign["br"] == pytest.approx((value, math.hypot(sd, spread_between(est["br"],
                                                                                  value))))


def test_an_outlier_gets_the_others_prior_and_an_unknown_constant_none():
    """A maneuver left out gets the campaign's prior (of the others); with two estimates a
    maneuver has one other, too few for a prior; a constant the maneuvers do not know
    better than the filter's prior gives none."""
    est = {"bp": [(3.5e-4, 1e-5, 2e-3, m) for m in range(4)] + [(3.0e-3, 1e-5, 2e-3, 9)],
           "bq": [(0.0, 1.9e-3, 2e-3, m) for m in (0, 1, 2, 3, 9)]}
    campaign, per, excluded = campaign_priors(est)
    assert 9 in excluded["bp"] and 9 not in per
    assert campaign["bp"][0] == pytest.approx(3.5e-4, rel=1e-4) and "bq" not in campaign
    assert all("bq" not in p for p in per.values())
    two = {"br": [(1e-4, 1e-5, 2e-3, 0), (1.1e-4, 1e-5, 2e-3, 1)]}
    campaign, per, _ = campaign_priors(two)
    assert per == {0: {}, 1: {}} and "br" in campaign
    with pytest.raises(ValueError, match="informative"):
        campaign_priors(two, informative=0.0)


def test_estimates_their_maneuvers_hardly_observe_are_not_combined():
    """Five turns in turbulence, each barely informed beyond the prior (sigma 1.1-1.8 of
    2.0) and each pulled the same way: counting the prior once would un-shrink them to
    5 +- 0.8 (the truth being 0); the campaign keeps no value instead. A maneuver that
    observes the constant (sigma at most half the prior's) still counts, alone."""
    weak = [(3.77, 1.63, 2.0, 0), (2.92, 1.22, 2.0, 5), (3.16, 1.13, 2.0, 15),
            (2.30, 1.81, 2.0, 16), (3.87, 1.66, 2.0, 18)]
    value, _sd = _formula(weak, sd0=2.0)
    assert value > 4.5                               # what un-shrinking would have given
    combined, excluded = combine_campaign({"btas": weak})
    assert combined["btas"] is None and not excluded
    combined, _ = combine_campaign({"btas": weak + [(0.4, 0.3, 2.0, 7)]})
    assert combined["btas"].used == (7,)
    assert combined["btas"].value == pytest.approx(0.4)
    assert OBSERVED == 0.5


def test_a_posterior_that_left_its_prior_too_far_is_a_conflict():
    """The shift of the posterior mean from the prior's has the variance prior - posterior:
    a shift of 1.2 of its sigmas is consistent, 10 is not (the cut for two constants at 1 %:
    2.81); a prior the data did not narrow cannot conflict."""
    prior = {"br": (1.8e-4, 2e-5), "bp": (3.5e-4, 2e-5)}
    var = (2e-5) ** 2 - (1e-5) ** 2                     # prior minus posterior variance
    post = {"br": (1.8e-4 + 2e-5, (1e-5) ** 2),
            "bp": (3.5e-4 + 10 * math.sqrt(var), (1e-5) ** 2)}
    assert outlier_threshold(2) == pytest.approx(2.807, abs=1e-3)
    found = prior_conflicts(post, prior)
    assert set(found) == {"bp"} and found["bp"] == pytest.approx(10.0)
    assert prior_conflicts({"br": (5.0, (2e-5) ** 2)}, {"br": (0.0, 2e-5)}) == {}
    assert prior_conflicts({}, {}) == {}


def test_a_lone_turbulent_estimate_of_an_airspeed_bias_is_named_not_used():
    """The A-4 sortie's case: of two turns only the second observes the airspeed bias
    (-2.51 +- 0.89 m/s, truth 0), and it had gusts: reported in ``excluded``'s form, with no
    distance. The vane offset that a turn in still air checks, a lone estimate from a
    maneuver in still air, and a constant outside ``states`` stay; two estimates that both
    come from maneuvers with gusts are both named."""
    est = {"btas": [(-0.70, 1.66, 2.0, 6), (-2.51, 0.885, 2.0, 14)],
           "balpha": [(0.013, 0.006, 0.02, 6), (0.009, 0.001, 0.02, 14)],
           "bbeta": [(0.004, 0.002, 0.02, 3)]}
    combined, _ = combine_campaign(est)
    assert combined["btas"].used == (14,)
    lone = lone_in_gusts(combined, {6, 14, 3}, ("btas", "bbeta"))
    assert lone == {"btas": {14: (combined["btas"].value, combined["btas"].sigma, None)},
                    "bbeta": {3: (combined["bbeta"].value, combined["bbeta"].sigma, None)}}
    assert lone_in_gusts(combined, {6}, ("btas", "bbeta")) == {}          # still air
    assert "balpha" not in lone_in_gusts(combined, {14}, ("btas", "balpha"))
    assert set(lone_in_gusts(combined, {6, 14}, ("balpha",))["balpha"]) == {6, 14}
    assert lone_in_gusts({"btas": None}, {14}, ("btas",)) == {}


def test_a_turbulent_estimate_that_the_others_cannot_check_is_lone_too():
    """The 737 course's case: a long turn in gusts gave the airspeed bias as 0.67 +- 0.15
    m/s (truth 0), another turn 0.17 +- 0.92, both with gusts: both are named. Were the
    second in still air, the first would still hold 98 % of the information, which the
    second could not see off: the rule names the turn with its own estimate. With the
    second as tight as the first it checks it; with the dominant one in still air nothing
    is named; without the estimates only the all-gusty rule counts."""
    est = {"btas": [(0.669, 0.148, 2.0, 11), (0.169, 0.923, 2.0, 1)]}
    combined, _ = combine_campaign(est)
    assert combined["btas"].used == (11, 1)
    assert lone_in_gusts(combined, {11, 1}, ("btas",), est) == {
        "btas": {11: (0.669, 0.148, None), 1: (0.169, 0.923, None)}}
    assert lone_in_gusts(combined, {11}, ("btas",), est) == {
        "btas": {11: (0.669, 0.148, None)}}
    assert lone_in_gusts(combined, {11}, ("btas",)) == {}
    assert lone_in_gusts(combined, {1}, ("btas",), est) == {}       # the long turn in still air
    assert lone_in_gusts(combined, {11, 1}, ("bbeta",), est) == {}  # not a state of the rule
    # the information shares: 1/0.148^2 - 1/4 against 1/0.923^2 - 1/4
    share = (1 / 0.148 ** 2 - 0.25) / (1 / 0.148 ** 2 + 1 / 0.923 ** 2 - 0.5)
    assert share > LONE_SHARE
    checked = {"btas": [(0.669, 0.148, 2.0, 11), (0.169, 0.30, 2.0, 1)]}
    combined, _ = combine_campaign(checked)
    assert lone_in_gusts(combined, {11}, ("btas",), checked) == {}


def test_an_airspeed_bias_the_campaign_cannot_determine_is_held_in_straight_still_air():
    """tests/data/citation_like: three straight maneuvers in still air, perfect sensors.
    With a 0.3 m/s prior on the airspeed bias the campaign's estimate (sigma 0.26-0.29)
    is not determined; a straight maneuver cannot do better (a constant on the airspeed
    and the wind along the track are one), so the bias is held at zero and said so. Each
    maneuver's own estimate put the airspeed 0.09 m/s RMS off (on a simulated course,
    1.16 m/s against the sensor's 0.10)."""
    record = Path(__file__).resolve().parents[1] / "data" / "citation_like"
    data = import_record(record / "mapping.toml").data
    truth = pd.read_csv(record / "truth.csv")
    rec = reconstruct(data, data.attrs, settings=ReconstructionSettings(
        prior={"tas_bias": 0.3}))
    out = rec.data
    err = out["tas"] - np.interp(out["t_record"], truth["t_record"], truth["tas"])
    assert float(np.sqrt(np.mean(err ** 2))) < 0.01
    assert rec.sensors()["held"]["tas"] == HELD_STRAIGHT
    assert "not estimated in a straight maneuver" in rec.summary()


def _winds(values, sd=0.2, prior=10.0):
    return [((n, sd, prior), (e, sd, prior), i) for i, (n, e) in enumerate(values)]


def test_turns_that_agree_give_the_campaign_wind_with_the_floor_as_its_sigma():
    """Three turns in one air mass: the wind is their combination, its sigma no smaller
    than WIND_FLOOR (the wind's change over a flight that the turns cannot measure)."""
    n, e, sd = campaign_wind(_winds([(3.0, -4.0), (3.2, -4.1), (2.9, -3.9)]))
    assert n == pytest.approx(3.033, abs=0.01) and e == pytest.approx(-4.0, abs=0.01)
    assert sd == WIND_FLOOR
    # one turn, sharper than the floor: still the floor
    assert campaign_wind(_winds([(3.0, -4.0)], sd=0.05))[2] == WIND_FLOOR


def test_turns_that_disagree_give_a_sigma_as_wide_as_their_scatter():
    """Separately simulated maneuvers, each with its own wind: none is left out as an
    outlier (a wind that changes is not a bad estimate), and the sigma covers the
    scatter, so the reconstruction does not take it as the straight maneuvers' wind."""
    winds = [(-6.5, 4.6), (-6.1, 3.5), (8.1, -0.4)]
    n, e, sd = campaign_wind(_winds(winds))
    assert sd > 0.5 * np.std([w[0] for w in winds])
    assert min(w[0] for w in winds) < n < max(w[0] for w in winds)


def test_no_turn_gives_no_campaign_wind():
    assert campaign_wind([]) is None
    assert campaign_wind([((math.nan, 0.2, 10.0), (1.0, 0.2, 10.0), 0)]) is None
    # as wide as the prior: no information
    assert campaign_wind(_winds([(1.0, 1.0), (2.0, 2.0)], sd=20.0)) is None


def _vane_posterior(alphas, offset, scale, noise, prior_sd, rng):
    """A maneuver's exact (linear-Gaussian) posterior of a vane's (offset, scale error)
    from readings ``offset + scale * alpha + noise`` at the angles ``alphas``, zero-mean
    prior ``diag(prior_sd**2)``; returns the posterior and its data (H, y)."""
    H = np.column_stack([np.ones_like(alphas), alphas])
    y = H @ np.array([offset, scale]) + noise * rng.standard_normal(alphas.size)
    info = np.diag(1 / np.asarray(prior_sd) ** 2) + H.T @ H / noise ** 2
    cov = np.linalg.inv(info)
    return cov @ (H.T @ y / noise ** 2), cov, H, y


@hsettings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000))
def test_maneuvers_at_one_angle_each_give_the_vane_offset_and_scale_together(seed):
    """Six stationary measurements, each at one angle of attack, observe only
    offset + k alpha: no marginal is determined (combine_campaign has nothing to combine),
    but the joint combination is exactly the batch least-squares posterior of all the
    readings, the prior counted once."""
    rng = np.random.default_rng(seed)
    prior_sd = (0.02, 0.05)
    est, Hs, ys = [], [], []
    for m, a in enumerate(np.linspace(0.0, 0.04, 6)):
        mean, cov, H, y = _vane_posterior(np.full(200, a), 0.012, 0.04, 4e-3, prior_sd, rng)
        est.append((mean, cov, prior_sd, m))
        Hs.append(H)
        ys.append(y)
        assert math.sqrt(cov[1, 1]) > OBSERVED * prior_sd[1]     # k: not observed alone
    marginal, _ = combine_campaign({"kalpha": [(e[0][1], math.sqrt(e[1][1, 1]), prior_sd[1],
                                                e[3]) for e in est]})
    assert marginal["kalpha"] is None
    joint = combine_joint(est)
    H, y = np.vstack(Hs), np.concatenate(ys)
    info = np.diag(1 / np.asarray(prior_sd) ** 2) + H.T @ H / 4e-3 ** 2
    batch_cov = np.linalg.inv(info)
    np.testing.assert_allclose(joint.cov, batch_cov, rtol=1e-8)
    np.testing.assert_allclose(joint.value, batch_cov @ (H.T @ y / 4e-3 ** 2), rtol=1e-7,
                               atol=1e-12)
    assert joint.used == tuple(range(6)) and not joint.excluded
    assert joint.sigma()[1] < OBSERVED * prior_sd[1]           # determined together
    assert abs(joint.value[1] - 0.04) < 5 * joint.sigma()[1]


def test_a_maneuver_whose_vane_disagrees_is_left_out_of_the_joint_combination():
    """One maneuver whose model was wrong (its reading 3e-3 rad off: a vane boom's
    rate-induced angle in a steady turn) is named with its distance, and the others give
    the vane; a maneuver that observes nothing is not combined, none at all gives None."""
    rng = np.random.default_rng(3)
    prior_sd = (0.02, 0.05)
    est = [(*_vane_posterior(a + 1e-4 * rng.standard_normal(200), 0.012, 0.04, 4e-3,
                             prior_sd, rng)[:2], prior_sd, m)
           for m, a in enumerate(np.linspace(0.0, 0.04, 6))]
    bad = _vane_posterior(np.full(200, 0.02), 0.012 - 3e-3, 0.04, 4e-3, prior_sd, rng)
    est.append((*bad[:2], prior_sd, 9))
    joint = combine_joint(est)
    assert set(joint.excluded) == {9} and joint.excluded[9] > outlier_threshold(7)
    assert 9 not in joint.used
    assert abs(joint.value[0] - 0.012) < 4 * joint.sigma()[0]
    blind = (np.zeros(2), np.diag(np.square(prior_sd)), prior_sd, 11)     # the prior itself
    assert 11 not in combine_joint(est + [blind]).used
    assert combine_joint([blind]) is None
    assert combine_joint([]) is None


def test_a_vane_s_constants_are_held_together_once_one_is_determined():
    """The joint estimate's offset belongs to its scale error: once the campaign
    determines one constant of a vane it holds every one it knows better than the prior
    (an undetermined scale error included), and none while it determines none."""
    prior_sd = np.array([0.02, 0.05, 5.0])
    joint = JointEstimate(np.array([0.011, 0.035, 5.1]),
                          np.diag([7e-4, 0.027, 6.0]) ** 2, (1, 2, 3))
    np.testing.assert_array_equal(joint.determined(prior_sd), [True, True, False])
    vague = JointEstimate(np.zeros(3), np.diag([0.015, 0.04, 4.0]) ** 2)
    assert not vague.determined(prior_sd).any()


def test_the_joint_combination_does_not_depend_on_the_constants_units():
    """A vane's offset is in radians and its position in metres: which directions a
    maneuver observes, and the combination, are the same in millimetres (the prior's
    whitened coordinates). In raw units the eigenvectors of the information mixed them,
    and a Cessna course's boom came out at 10.4 m for 4 (5.1 whitened)."""
    rng = np.random.default_rng(7)
    prior_sd = np.array([0.02, 0.05, 5.0])
    est = []
    for m in range(9):      # stationary measurements, steady turns, pitch pulses
        a = rng.uniform(0.0, 0.04)
        q = (np.zeros(200), np.full(200, rng.uniform(0.02, 0.05)),
             rng.uniform(-0.05, 0.05, 200))[m % 3] + 2e-3 * rng.standard_normal(200)
        H = np.column_stack([np.ones(200), a + 1e-3 * rng.standard_normal(200), -q / 50.0])
        info = np.diag(1 / prior_sd ** 2) + H.T @ H / 4e-3 ** 2
        cov = np.linalg.inv(info)
        y = H @ np.array([0.012, 0.04, 4.0]) + 4e-3 * rng.standard_normal(200)
        est.append((cov @ H.T @ y / 4e-3 ** 2, cov, prior_sd, m))
    metres = combine_joint(est)
    to_mm = np.array([1.0, 1.0, 1000.0])
    mm = combine_joint([(v * to_mm, c * np.outer(to_mm, to_mm), sd * to_mm, m)
                        for v, c, sd, m in est])
    np.testing.assert_allclose(mm.value, metres.value * to_mm, rtol=1e-9)
    np.testing.assert_allclose(mm.cov, metres.cov * np.outer(to_mm, to_mm), rtol=1e-9)
    assert mm.used == metres.used
    assert abs(metres.value[2] - 4.0) < 4 * metres.sigma()[2]


def test_a_mean_far_from_the_others_angles_cannot_set_the_vane_scale_under_the_prior():
    """Twenty maneuvers within 0.01 rad of angle of attack (one airspeed band), each mean
    off by its mean gust (8e-3 rad, which the kinematic angle carries and the residual
    carries with the opposite sign), and one whose kinematic angle went astray (0.52 rad,
    residual -0.49: the vane did not follow it). The others' own line says nothing that
    far from them, so without the prior the bad mean stays and sets the scale near -1 (a
    vane that does not move) with a sigma of 0.01; with the prior of the offset and
    scale (0.02 rad, 0.05) it is left out and named, and the others' line is as
    uncertain as it is (sigma above 0.05: not a calibration). Honest means 0-0.1 rad
    with a 20 % scale error keep all their maneuvers under the prior, and find the same
    line as without it."""
    rng = np.random.default_rng(5)
    a = 0.02 + 0.01 * rng.random(20)
    gust = 8e-3 * rng.standard_normal(20)
    means = [(x + g, 0.01 + 0.04 * x - g, 400, m)
             for m, (x, g) in enumerate(zip(a, gust))] + [(0.52, -0.49, 135, 20)]
    blind = vane_scale_from_means(means)
    assert 20 in blind.used and blind.scale < -0.9 and blind.scale_sd < 0.02
    fit = vane_scale_from_means(means, prior=(0.02, 0.05))
    assert 20 in fit.excluded and fit.excluded[20] > 10 and 20 not in fit.used
    assert len(fit.used) == 20 and fit.scale_sd > 0.05
    wide = np.linspace(0.0, 0.1, 12)
    honest = [(x, 0.03 + 0.2 * x + 1e-3 * rng.standard_normal(), 600, m)
              for m, x in enumerate(wide)]
    with_prior = vane_scale_from_means(honest, prior=(0.02, 0.05))
    assert with_prior.excluded == {} and with_prior.scale == pytest.approx(
        vane_scale_from_means(honest).scale)


def test_a_vane_scale_from_the_maneuvers_means_recovers_the_line_and_leaves_out_a_bad_one():
    """Means of 12 maneuvers at angles 0-0.1 rad, the vane reading 1.2x plus 0.03 rad, each
    mean off by a gust of 1e-3 rad: the line is found within its sigma, which the scatter
    gives (about 1e-3 / (0.032 sqrt(12))); a maneuver 0.02 rad off is left out and named;
    fewer than SCALE_FROM_MEANS_MIN means, or one angle for all, give None."""
    rng = np.random.default_rng(3)
    a = np.linspace(0.0, 0.1, 12)
    gust = 1e-3 * rng.standard_normal(a.size)
    means = [(x, 0.03 + 0.2 * x + e, 600, m) for m, (x, e) in enumerate(zip(a, gust))]
    fit = vane_scale_from_means(means)
    assert fit.used == tuple(range(12)) and fit.excluded == {}
    assert abs(fit.scale - 0.2) < 3 * fit.scale_sd and abs(fit.offset - 0.03) < 3 * fit.offset_sd
    assert 0.005 < fit.scale_sd < 0.03
    assert fit.spread == pytest.approx(np.std(a))
    bad = means[:5] + [(means[5][0], means[5][1] + 0.02, 600, 5)] + means[6:]
    fit_bad = vane_scale_from_means(bad)
    assert 5 in fit_bad.excluded and fit_bad.excluded[5] > 5
    assert fit_bad.scale == pytest.approx(fit.scale, abs=2 * fit.scale_sd)
    # three maneuvers per test point sharing its slow gust (3e-3 rad): clustered by test
    # point the sigma is wider than the independent one; two test points give no fit
    shared = 3e-3 * rng.standard_normal(4)
    legs = [(x, 0.03 + 0.2 * x + shared[m // 3] + 2e-4 * e, 600, m, m // 3)
            for m, (x, e) in enumerate(zip(a, rng.standard_normal(a.size)))]
    independent = vane_scale_from_means([leg[:4] for leg in legs])
    assert vane_scale_from_means(legs).scale == pytest.approx(independent.scale)
    assert vane_scale_from_means(legs).scale_sd > 1.5 * independent.scale_sd
    assert vane_scale_from_means([(*leg[:4], leg[4] % 2) for leg in legs]) is None
    assert vane_scale_from_means(means[:SCALE_FROM_MEANS_MIN - 1]) is None
    assert vane_scale_from_means([(0.05, 0.04, 600, m) for m in range(8)]) is None
    assert vane_scale_from_means([(float("nan"), 0.0, 600, m) for m in range(8)]) is None
