"""Fitting one structure, scoring it by k-fold cross-validation over maneuvers, and the
automatic model structure selection of the paper's Section IV.D.

Selection is a greedy search from a starting structure. Each round tries every move

* degree up / down (continuity kept below the degree),
* refine / coarsen the triangulation along one variable (one more / fewer grid cell),
* add a candidate variable / remove a variable (at ``max_variables``: replace a
  variable by a candidate),

scores each candidate by the RMS of k-fold cross-validation in which whole maneuvers are
held out (the normal equations of each fold are accumulated once; a fold's training
system is the sum of the others), and takes the best move when it lowers the score by more
than ``min_improvement`` (relative). Every tried structure is recorded with its score.
The held-out validation maneuvers are never used for selection.

The candidates of one search share what does not change between them
(:class:`SearchCache`): the folds' normal equations per triangulation and degree, per pair
of terms (:mod:`~simplexspline.aero.selection.fold_equations`), the prior's coarse models
per fold, and the scores already computed (the prior degree's choice scores the starting
structure that the search starts from).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from simplexspline._compute_slots import compute_slot
from simplexspline.aero.variables import CANDIDATE_VARIABLES, RATES_OF_FORCES
from simplexspline.aero.modelling.structure_space import (
    StructureSpace,
    accumulate,
    evaluate,
    input_matrix,
)
from simplexspline.aero.modelling.auto import breaks_symmetry, linear_start
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.aero.selection.kink_location import place_kink
from simplexspline.aero.selection.moves import (
    JOINT_KINK_QUANTILES,
    joint_kink_moves,
    kink_moves,
    kink_positions,
    kinked_variable,
    neighbours,
)
from simplexspline.aero.modelling.term_hold import (HOLD_WEIGHT, excitation, hold_samples,
                                                    hole_intervals)
from simplexspline.aero.modelling.prior import (
    PRIOR_DEGREES,
    PRIOR_WEIGHT,
    coarse_structure,
    virtual_samples,
)
from simplexspline.aero.modelling.notation import multiplier_factors, multiplier_parts
from simplexspline.aero.modelling.structure import Structure, multiplier_values
from simplexspline.errors import InputError, SimplexSplineError
from simplexspline.spline.varying import VaryingCoefficientSpace
from simplexspline.aero.selection.coverage import covered_in_folds
from simplexspline.aero.selection.fold_equations import FoldEquations, fold_equations
from simplexspline.aero.selection.hinge_start import hinge_choices
from simplexspline.aero.selection.validation import (covered_in_fold, fold_by_maneuver,
                                                     subsample_step)
from simplexspline.spline import kernels

__all__ = ["MOVE_KINDS", "PLAIN_FIT", "SearchCache", "SelectionSettings", "Trial",
           "choose_prior_degree", "cv_residuals", "cv_score", "cv_scored_share",
           "fit_structure", "select_structure", "within_standard_errors"]


#: The kinds of moves of the structure search (:attr:`SelectionSettings.moves`).
MOVE_KINDS: tuple[str, ...] = ("degree", "resolution", "variables", "kinks")


@dataclass(frozen=True)
class SelectionSettings:
    """Limits and options of the structure search.

    Parameters
    ----------
    candidates : tuple of str
        Variables that may be added (only those present in the data are used).
    max_rounds : int
        Greedy rounds (each takes the best of all moves). A cap, not a budget: the search
        stops sooner when no move improves. Six rounds stopped the F-16's CX on a campaign
        of 40 maneuvers while it still improved (CV RMS 7.16e-4 after round 6, 5.65e-4
        after round 8; against the truth 1.70 -> 1.10 times the noise); the size budget
        bounds the structures.
    folds : int
        k of the k-fold cross-validation by maneuver.
    min_improvement : float
        Relative decrease of the CV RMS a move must bring to be taken.
    asymmetry_improvement : float
        ... and a move that gives a lateral coefficient a term that breaks the airframe's
        mirror symmetry (:func:`~simplexspline.aero.modelling.auto.breaks_symmetry`: the
        thrust coefficient in Cl). A propeller's torque earns it easily (a Cessna 172's
        Cl cross-validated 44 % better with its fuel-flow thrust, and came 9.27 -> 4.99
        times the noise against the truth); on a jet it bought the 2 % of a per-maneuver
        bias that followed the throttle (the F-16's Cl 0.62 -> 1.13 times the noise).
    max_degree, max_resolution, max_variables : int
        Bounds of the search.
    max_schedule : int
        Most scheduling variables (triangulation dimensions) of a varying-coefficient
        structure.
    max_coefficients : int
        Largest number of B-coefficients (J * d_hat) tried.
    samples_per_coefficient : float
        A structure needs at least this many of the samples the search cross-validates on
        (at most ``max_samples``) per B-coefficient... Counting every sample of a 100 Hz
        record instead let the main job's Cn search try 8,820-coefficient structures on
        40,000 training samples per fold (2-4.6 s per trial, 65 s of search); its model
        was no better.
    seconds_per_coefficient : float
        ... or this much identification data [s] per B-coefficient, whichever allows more
        (when the caller gives the data's duration). The information in flight data grows
        with the time flown, not with the sample rate: 20 samples are 0.4 s at 50 Hz but
        2 s at 10 Hz, where the sample count alone held a 24-maneuver sortie's CX at its
        starting size, unable to take the fuel flow that its thrust follows.
    min_points : int
        Simplices holding fewer samples are dropped from the triangulation.
    moves : tuple of str
        Kinds of moves tried: 'degree' (degree, and continuity across the grid planes,
        up or down), 'resolution' (grid cells; for variables on
        breakpoints, every other breakpoint dropped or midpoints inserted; ``cellwise``
        on or off), 'variables' (add, remove or replace a variable; for
        varying-coefficient structures add or remove a multiplier, schedule on one more
        variable or one fewer), 'kinks' (varying-coefficient structures: a term ``m``
        gets a kink ``m*|v-k|`` in one of its variables at a breakpoint placed at a
        quantile of the data, :func:`~simplexspline.aero.selection.moves.kink_moves`;
        with ``joint_kinks`` also every eligible term at one breakpoint, with constant
        coefficients, :func:`~simplexspline.aero.selection.moves.joint_kink_moves`).
    ridge : float
        Relative ridge weight on the B-coefficients (times the mean diagonal of X'X): a
        tiny value that only decides directions the data and continuity leave
        undetermined in thinly covered simplices (0: minimum-norm solution instead).
    max_samples : int
        The search uses at most this many identification samples (every k-th sample, so
        all maneuvers stay); the final fit uses all of them.
    smoothing : 'auto', None, 'gcv' or float
        Smoothness-energy regularisation of every fit (weight by GCV, or a fixed relative
        weight; see docs/regularization.md): the thin-plate energy, or for C^0 structures
        the membrane energy (squared gradients; the thin-plate energy does not see kinks
        across facets). None (default): only the tiny ridge. 'auto': GCV for
        varying-coefficient structures, none for plain ones.
    prior : 'auto', 'coarse' or None
        Shrink thinly covered simplices towards a coarse model of the same variables
        (:mod:`simplexspline.aero.modelling.prior`): 'auto' (default) for varying-coefficient
        structures (many coefficients per simplex), 'coarse' for every structure, None
        never.
    prior_weight : float
        Weight of each virtual sample of the coarse model, relative to a real sample.
    screen : int or None
        Of the 'add multiplier' and of the 'schedule on' moves of a round, only this many
        are cross-validated: those whose new term explains most of the current model's
        residual (:func:`screen_moves`). 0 or None: every move is cross-validated.
    combine : int
        After the best move of a round is taken, up to this many of the round's other
        improving moves are tried on top of it, best first, each kept when it improves
        further: several independent improvements per round (0: one move per round).
    cv_average : {'sample', 'maneuver', 'maneuver-rms'}
        How the held-out errors make the cross-validation score. 'sample' (default): the
        RMS over all held-out samples. 'maneuver': the geometric mean over the held-out
        maneuvers of their mean squared errors, square-rooted, so that every maneuver
        counts alike (with the pooled RMS one held-out maneuver the training folds barely
        reach can outweigh the rest: on the main job's F-16 campaign one elevator doublet
        carried 41 % of CX's squared CV error, and ``|beta|``, better on 36 of the 47
        maneuvers, was rejected). 'maneuver-rms': the mean of the maneuvers' RMS. Measured
        on the generalization benchmark's 96 models (unseen data): 89 ('sample'), 88
        ('maneuver') on target, geometric mean of true/noise 0.534 and 0.523; on the main
        job's campaign, where the problem was found, 'maneuver' took CX from 2.30 to 1.34
        times the noise, Cm 2.16 -> 1.33, Cl 2.40 -> 1.63, at 15 s more. Not the default:
        the unseen data do not tell the two apart (docs/identification.md).
    cv_box : bool
        Score only held-out samples inside the box (every candidate variable's range) of
        their training folds (:func:`in_training_box`), as validation scores only inside
        the model's identified box. Same benchmark: 89 on target, 0.530; off by default for
        the same reason.
    hold_terms : bool
        In the final fit, hold every term's coefficient outside the box of the scheduling
        variables where the data excite the term at its value on that box
        (:mod:`~simplexspline.aero.modelling.term_hold`): a derivative stays what it was
        where it was last measured instead of following its polynomial's continuation.
        The search does not do it (its cross-validation predicts held-out maneuvers
        mostly inside the training folds' excitation, and its screening of moves and
        placing of kinks need residuals where the data are); the final fit and its
        coarse prior do. See the module for the measured effect.
    place_kinks : bool
        Move every kink the search accepts to where the fit's squared error is least
        (:func:`~simplexspline.aero.selection.kink_location.place_kink`: up to 17 fits of
        the model between the candidate positions two either side of its own), kept when
        the cross-validation score is lower. On the main job's campaign: CX 2.30 -> 2.20,
        Cm 2.11 -> 1.75 times the noise. Same benchmark: 87 on target, geometric mean
        0.534 (unchanged), the F-16's Cl better in three variants and its CX worse in two,
        and 36 % more identification time; off by default.
    linear_restart : bool
        After the search: when the linear model of the starting structure's terms
        (:func:`~simplexspline.aero.modelling.auto.linear_start`) cross-validates better
        than the structure the search found, search again from it and keep the better of
        the two. The greedy search only accepts moves that improve the score, so from a
        scheduled start it can end in a structure that no single move improves and that
        the linear model beats: on a still-air course of six test points (no maneuver
        list) CY's search ended at a CV RMS of 1.25e-3 and 4.54x the noise, its linear
        model's search at 3.7e-4 and 0.36x. Costs one cross-validation where the search's
        result wins.
    parsimony : float
        The linear restart also runs, and its result is kept when it is no larger, when
        its cross-validation error is within this many standard errors of the search's
        result (:func:`within_standard_errors`, the one-standard-error rule; 0: only a
        lower score counts). Where the cross-validation cannot tell two structures
        apart, the simpler one is kept. See docs/identification.md ("A second start")
        for the measured effect.
    joint_kinks : bool
        With the 'kinks' moves, also try every eligible term's kink at one breakpoint at
        once, each with a constant coefficient, the breakpoint per variable placed by
        the screen at the 1 %-quantile whose hinges explain most of the current
        residual (:func:`~simplexspline.aero.selection.moves.joint_kink_moves`): a
        database's derivatives tabulated on one Mach grid change slope together. On the
        generalization benchmark's 96 models (unseen data): 89 on target against 88,
        geometric mean of true/noise 0.527 against 0.538 (the F-16's rolling and yawing
        moments 1.64 -> 1.23 and 0.61 -> 0.29 in the alternative design with GPS, at
        the database's Mach 0.6 and 5 deg found from the data), but about twice the
        identification time (the main job 191 s against 101 s on one machine: a
        constant-coefficient term is a whole spline term held constant by conditions,
        so every joint kink adds a term per multiplier), and the main job's Cm 0.68 ->
        1.40 times the noise. Off by default.
    hinge_start : bool
        After the search, cross-validate the structures of an adaptive-regression-spline
        basis (:mod:`~simplexspline.aero.selection.hinge_start`: products of up to two
        factors ``v`` or ``|v-k|`` with constant coefficients, found by a forward pass over
        the data and pruned by GCV at a few costs per term) and take the best when it
        beats the search's result by ``min_improvement`` and by ``parsimony`` standard
        errors. The passes choose the terms and breakpoints from the data, so they run
        inside the folds: each fold's held-out maneuvers are predicted by the structure
        that the passes chose on the other folds (the structure taken is the passes' on
        all the data), else the cross-validation would score a choice made with the
        held-out maneuvers' own noise. The search adds one kink per
        cross-validated move and never multiplies two; on the F-16 campaign of
        ``bench_compare.py`` (split seed 101) its drag model ended at 3.54x the noise,
        where MARS reached 0.2x through such products (1.28x with this start). On by
        default since stop 55: on ``bench_generalization.py``'s 120 models 12 improve by
        more than 10 % and two worsen by 0.01x (docs/identification.md,
        "The hinge start"). Before the passes run inside the folds, the structures of the
        passes on all the data are scored as a screen (an optimistic score): where none
        beats the search's result by ``min_improvement``, nothing more is done.
    kept_multipliers : tuple of str
        Multipliers of a varying-coefficient structure that no move removes (the others
        may still be added, scheduled or given kinks). ``identify`` keeps the linear
        start's terms where the cross-validation scores none of the maneuvers that move
        the coefficient: it cannot then judge the removal of a term that only those
        maneuvers excite. On a six-test-point still-air course of a straight-wing jet
        with one elevator doublet, the search removed the elevator and the pitch rate
        from Cm, and the model's Cm_alpha was -0.01 (truth -0.70): through the
        stationary points alone, where the elevator trims the aircraft, Cm does not
        change with alpha.
    """

    candidates: tuple = CANDIDATE_VARIABLES
    max_rounds: int = 12
    folds: int = 3
    min_improvement: float = 0.01
    asymmetry_improvement: float = 0.1
    max_degree: int = 5
    max_resolution: int = 6
    max_variables: int = 5
    max_schedule: int = 3
    max_coefficients: int = 12000
    samples_per_coefficient: float = 20.0
    seconds_per_coefficient: float = 0.4
    min_points: int = 10
    max_samples: int = 60_000
    moves: tuple = ("degree", "resolution", "variables", "kinks")
    ridge: float = 1e-8
    smoothing: object = None
    prior: object = "auto"
    prior_weight: float = PRIOR_WEIGHT
    screen: int | None = 3
    combine: int = 3
    cv_average: str = "sample"
    cv_box: bool = False
    hold_terms: bool = True
    place_kinks: bool = False
    linear_restart: bool = True
    parsimony: float = 1.0
    joint_kinks: bool = False
    hinge_start: bool = True
    kept_multipliers: tuple = ()

    def __post_init__(self):
        unknown = sorted(set(self.moves) - set(MOVE_KINDS))
        if unknown:
            raise InputError(f"unknown move kind(s) {unknown} of the structure selection; "
                             f"known: {list(MOVE_KINDS)}")
        if self.joint_kinks and not self.screen:
            raise InputError("joint_kinks needs the screen (screen >= 1): without it every "
                             "one of the 91 breakpoints per variable would be "
                             "cross-validated in every round; set screen = 3 or "
                             "joint_kinks = false")
        if not (np.isfinite(self.parsimony) and self.parsimony >= 0):
            raise InputError(f"parsimony must be a finite number of standard errors >= 0 "
                             f"(0: off), got {self.parsimony!r}")
        if self.cv_average not in CV_AVERAGES:
            raise InputError(f"cv_average must be one of {list(CV_AVERAGES)}, got "
                             f"{self.cv_average!r}")
        if not isinstance(self.hinge_start, bool):
            raise InputError(f"hinge_start is on or off (true or false), got "
                             f"{self.hinge_start!r}")
        for name in ("min_improvement", "asymmetry_improvement"):
            value = getattr(self, name)
            if not 0.0 <= value < 1.0:
                raise InputError(f"{name} is a relative decrease of the CV RMS, from 0 "
                                 f"up to (not including) 1; got {value!r}")

    def to_dict(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v)
                for k, v in self.__dict__.items()}



#: The cross-validation scores (``SelectionSettings.cv_average``).
CV_AVERAGES = ("maneuver", "maneuver-rms", "sample")


#: The settings of a plain fit (:func:`fit_structure`, :func:`cv_score`): the selection's
#: defaults without the coarse-model prior.
PLAIN_FIT = SelectionSettings(prior=None)

@dataclass
class Trial:
    """One scored structure of the search."""

    structure: Structure
    score: float
    round: int
    move: str
    ncoefficients: int = 0
    nsimplex: int = 0
    seconds: float = 0.0
    accepted: bool = False
    error: str = ""

    def to_dict(self) -> dict:
        return {"structure": self.structure.to_dict(), "label": self.structure.label(),
                "cv_rms": self.score, "round": self.round, "move": self.move,
                "ncoefficients": self.ncoefficients, "nsimplex": self.nsimplex,
                "seconds": round(self.seconds, 3), "accepted": self.accepted,
                "error": self.error}


@dataclass
class SearchCache:
    """What the cross-validations of one coefficient's search share: they run on the same
    (subsampled) samples, folds and scored samples with the same settings, which the cache
    is bound to on first use (bound to others, it starts afresh).

    Attributes
    ----------
    equations : FoldEquations or None
        The folds' normal equations per triangulation and degree.
    coarse : dict
        The prior's coarse models per fold, by (coarse structure, ridge).
    scores : dict
        (structure, prior degree) -> (CV RMS, number of coefficients, simplices).
    """

    equations: FoldEquations | None = None
    coarse: dict = field(default_factory=dict)
    scores: dict = field(default_factory=dict)
    _scored: np.ndarray | None = None
    _settings: SelectionSettings | None = None

    def bind(self, y: np.ndarray, folds: np.ndarray, scored,
             settings: SelectionSettings) -> SearchCache:
        """Use the cache for these samples, folds, scored mask and settings (emptied when
        they are not the ones it holds)."""
        sc = None if scored is None else np.asarray(scored, dtype=bool)
        same = (self.equations is not None and self.equations.matches(y, folds)
                and settings == self._settings
                and (sc is None) == (self._scored is None)
                and (sc is None or np.array_equal(sc, self._scored)))
        if not same:
            self.equations = FoldEquations(y, folds)
            self.coarse.clear()
            self.scores.clear()
            self._scored = sc
            self._settings = settings
        return self


def _use_prior(structure: Structure, prior) -> bool:
    if prior is None:
        return False
    if prior == "auto":
        return structure.varying
    if prior == "coarse":
        return True
    raise InputError(f"prior must be 'auto', 'coarse' or None, got {prior!r}")


def _prior_equations(structure, space, scaling, mscale, coarse, weight: float):
    """Normal equations of the coarse model's virtual samples (see
    :mod:`simplexspline.aero.modelling.prior`), each with ``weight``."""
    z, m, yv = virtual_samples(structure, space.triangulation,
                               scaling.subset(structure.variables), mscale[0], coarse)
    return accumulate(space, z, m, yv, np.full(len(yv), weight))


def fit_structure(structure: Structure, columns: Mapping, y: np.ndarray,
                  settings: SelectionSettings = PLAIN_FIT, *,
                  weights: np.ndarray | None = None, prior_degree: int = 3,
                  provenance: dict | None = None) -> AeroModel:
    """Fit one coefficient model of the given structure on all the given samples.

    Parameters
    ----------
    structure : Structure
    columns : mapping of str to ndarray, shape (N,)
        Identification data by column name (physical units).
    y : ndarray, shape (N,)
        The coefficient.
    settings : SelectionSettings, default :data:`PLAIN_FIT`
        The fit's settings, taken whole: ``min_points`` (simplices with fewer samples are
        dropped; with a prior the whole grid is kept, the prior determines empty
        simplices), ``ridge`` (0: minimum-norm solution in undetermined directions),
        ``smoothing``, ``prior`` and ``prior_weight`` (see :class:`SelectionSettings`).
        The default is a plain fit: the selection's defaults without the prior.
    weights : ndarray, shape (N,), optional
    prior_degree : int
        Degree of the coarse model.

    Returns
    -------
    AeroModel
        ``provenance['counts']`` lists the samples per simplex.
    """
    x = input_matrix(columns, structure.inputs)
    y = np.asarray(y, dtype=float)
    min_points, ridge = settings.min_points, settings.ridge
    use_prior = _use_prior(structure, settings.prior)
    # with a prior, keep the whole grid: the prior determines simplices without data
    laid = StructureSpace.build(structure, x, 0 if use_prior else min_points)
    scaling, u, m, mscale, space = (laid.scaling, laid.scheduling, laid.multipliers,
                                    laid.multiplier_scaling, laid.space)
    keep = space.triangulation.locate(u) >= 0
    w = None if weights is None else np.asarray(weights, dtype=float)
    ne = accumulate(space, u[keep], None if m is None else m[keep], y[keep],
                     None if w is None else w[keep])
    prov = dict(provenance or {})
    counts = ne.counts.copy()          # real samples (before any virtual ones are added)
    wbar = float(np.mean(w[keep])) if w is not None and keep.any() else 1.0  # one real sample
    if use_prior:
        cs = coarse_structure(structure, prior_degree)
        coarse = fit_structure(cs, columns, y, replace(PLAIN_FIT, min_points=min_points,
                                                        ridge=ridge), weights=w)
        ne.merge(_prior_equations(structure, space, scaling, mscale, coarse,
                                  settings.prior_weight * wbar))
        prov["prior"] = {"structure": cs.label(), "degree": prior_degree,
                         "weight": settings.prior_weight}
    spline = _solve(space, ne, ridge, settings.smoothing)
    if settings.hold_terms and structure.varying:
        boxes, shares = excitation(structure, u[keep], m[keep])
        zh, mh, yh, wh = hold_samples(structure, space.triangulation, boxes, spline, shares)
        if len(yh):
            ne.merge(accumulate(space, zh, mh, yh, HOLD_WEIGHT * wbar * wh))
            spline = _solve(space, ne, ridge, settings.smoothing)
            sched = scaling.subset(structure.variables)
            prov["held_terms"] = {
                name: {"lower": sched.inverse(box[0][None])[0].tolist(),
                       "upper": sched.inverse(box[1][None])[0].tolist()}
                for name, box in zip(structure.multipliers, boxes) if box is not None}
            holes = {name: hole_intervals(share)
                     for name, share in zip(structure.multipliers, shares)}
            gaps = {name: {structure.variables[j]: [_physical(sched, j, r) for r in runs]
                           for j, runs in where.items()}
                    for name, where in holes.items() if where}
            if gaps:
                prov["held_gaps"] = gaps
            if not prov["held_terms"]:
                del prov["held_terms"]
    prov.update(samples=int(keep.sum()), dropped_samples=int((~keep).sum()),
                counts=counts.tolist(), nbasis=structure.nbasis,
                nsimplex=space.triangulation.nsimplex,
                ncoefficients=int(space.dim_coefficients))
    reg = getattr(spline.info, "regularization", None)
    if reg is not None:
        prov["smoothing"] = {"penalty": reg.penalty, "relative_weight": reg.smoothing,
                             "edf": reg.edf}
    return AeroModel(structure, scaling, spline, prov, *mscale)


def _physical(scaling, j: int, interval: tuple) -> list:
    """A scaled (lower, upper) range of scheduling variable ``j`` in its own units."""
    u = np.zeros((2, len(scaling.lower)))
    u[:, j] = interval
    return scaling.inverse(u)[:, j].tolist()


def _penalty(space) -> str:
    """The smoothing penalty of a space: the thin-plate energy, or for C^0 spaces (whose
    kinks across facets the energy does not see) the membrane energy."""
    return "membrane" if _continuity(space) == 0 \
        else "energy"


def _continuity(space) -> int:
    return space.space.continuity if isinstance(space, VaryingCoefficientSpace) \
        else space.continuity


def _solve(space, ne, ridge: float, smoothing=None):
    if isinstance(smoothing, str) and smoothing == "auto":
        smoothing = "gcv" if isinstance(space, VaryingCoefficientSpace) else None
    kw = {} if smoothing is None else {"smoothing": smoothing, "penalty": _penalty(space)}
    if ridge > 0:
        return space.solve(ne, on_insufficient="ridge", ridge=ridge, **kw)
    return space.solve(ne, on_insufficient="minnorm", **kw)


def cv_score(structure: Structure, columns: Mapping, y: np.ndarray, folds: np.ndarray,
             settings: SelectionSettings = PLAIN_FIT, *, prior_degree: int = 3,
             scored: np.ndarray | None = None,
             coarse_cache: dict | None = None,
             equations: FoldEquations | None = None,
             groups: np.ndarray | None = None) -> tuple[float, int, int]:
    """k-fold cross-validation RMS (folds = whole maneuvers) of :func:`fit_structure` with
    the same ``settings`` (default :data:`PLAIN_FIT`).

    ``scored`` (bool per sample, optional) limits the RMS to some held-out samples (e.g.
    :func:`~simplexspline.aero.selection.validation.covered_in_fold`); all are fitted on. A mask
    with no sample set scores all of them (no fold can then be judged on covered data).

    ``coarse_cache`` (a dict kept across calls on the *same* columns, y and folds, as the
    search does) keeps the prior's coarse models per fold: moves that change the grid,
    degree or continuity share one coarse model, and it is fitted once.

    ``equations`` (a :class:`~simplexspline.aero.selection.fold_equations.FoldEquations`
    of the same y and folds, optional) supplies the folds' normal equations of this
    structure and of the coarse model from blocks kept for earlier candidates on the same
    triangulation and degree (equal to a fresh accumulation up to round-off).

    ``groups`` (maneuver id per sample, optional): with ``settings.cv_average ==
    'maneuver'`` the score is the square root of the geometric mean over the held-out
    maneuvers of their mean squared residuals (scored samples only); without groups, or
    with 'sample', the RMS over all scored held-out samples.

    Returns
    -------
    rms : float
        The cross-validation RMS (pooled over samples or per maneuver, above).
    ncoefficients, nsimplex : int
    """
    r2, held, ncoef, nsimplex = cv_residuals(structure, columns, y, folds, settings,
                                             prior_degree=prior_degree, scored=scored,
                                             coarse_cache=coarse_cache,
                                             equations=equations)
    return _pooled_rms(r2, held, folds, groups, settings), ncoef, nsimplex


def _pooled_rms(r2: np.ndarray, held: np.ndarray, folds: np.ndarray,
                groups: np.ndarray | None, settings: SelectionSettings) -> float:
    """:func:`cv_score`'s figure from squared held-out residuals ``r2`` and the scored
    samples ``held`` (all shape (N,))."""
    per_maneuver = groups is not None and settings.cv_average != "sample"
    if per_maneuver and held.any():
        _ids, g_sse, g_n = _by_group(r2, held, groups)
        mse = g_sse / g_n
        if settings.cv_average == "maneuver":
            floor = np.finfo(float).tiny
            return float(np.sqrt(np.exp(np.mean(np.log(np.maximum(mse, floor))))))
        return float(np.mean(np.sqrt(mse)))     # 'maneuver-rms'
    sse = 0.0                     # fold by fold, as the folds were solved
    for f in range(int(folds.max()) + 1):
        sse += float(np.sum(r2[(folds == f) & held]))
    return float(np.sqrt(sse / np.count_nonzero(held)))


def cv_residuals(structure: Structure, columns: Mapping, y: np.ndarray, folds: np.ndarray,
                 settings: SelectionSettings = PLAIN_FIT, *, prior_degree: int = 3,
                 scored: np.ndarray | None = None, coarse_cache: dict | None = None,
                 equations: FoldEquations | None = None) -> tuple:
    """The held-out squared residuals of :func:`cv_score`'s cross-validation (same
    arguments).

    Returns
    -------
    r2 : ndarray, shape (N,)
        Squared held-out residual per sample (0 where not scored; NaN where the fold's
        model gave none).
    scored : ndarray of bool, shape (N,)
        The samples scored.
    ncoefficients, nsimplex : int
    """
    x = input_matrix(columns, structure.inputs)
    y = np.asarray(y, dtype=float)
    min_points, ridge, prior_weight = settings.min_points, settings.ridge, settings.prior_weight
    use_prior = _use_prior(structure, settings.prior)
    laid = StructureSpace.build(structure, x, 0 if use_prior else min_points)
    scaling, u, m, mscale, space = (laid.scaling, laid.scheduling, laid.multipliers,
                                    laid.multiplier_scaling, laid.space)
    tri = space.triangulation
    k = int(folds.max()) + 1
    if equations is not None and not equations.matches(y, folds):
        raise InputError("cv_score: the fold equations given were kept for other samples or "
                         "folds")
    if equations is not None:
        total, parts = equations.get(structure, laid, 0 if use_prior else min_points)
    else:
        total, parts = fold_equations(space, u, m, y, folds, k)
    if use_prior:
        cs = coarse_structure(structure, prior_degree)
        cache = {} if coarse_cache is None else coarse_cache
        if (cs, ridge) not in cache:
            cache[cs, ridge] = _coarse_fold_models(cs, input_matrix(columns, cs.inputs), y,
                                                   folds, k, min_points, ridge, equations)
        coarse_models = cache[cs, ridge]
    out = np.zeros(len(y))
    scored = np.ones(len(y), dtype=bool) if scored is None else np.asarray(scored, bool)
    if not scored.any():
        scored = np.ones(len(y), dtype=bool)
    for f in range(k):
        held = (folds == f) & scored
        if not held.any():
            continue  # nothing of this fold is scored: skip its solve
        train = total - parts[f]
        if use_prior:
            train.merge(_prior_equations(structure, space, scaling, mscale,
                                         coarse_models[f], prior_weight))
        spline = _solve(space, train, ridge, settings.smoothing)
        pred = evaluate(spline, u[held], None if m is None else m[held])
        out[held] = (y[held] - pred) ** 2
    return out, scored, int(space.dim_coefficients), int(tri.nsimplex)


def within_standard_errors(r2_simple: np.ndarray, r2_best: np.ndarray, held: np.ndarray,
                           groups: np.ndarray, k: float, cv_average: str = "sample") -> bool:
    """Whether a simpler structure's cross-validation error is within ``k`` standard
    errors of a richer one's: the one-standard-error rule (Breiman et al. 1984; Hastie,
    Tibshirani & Friedman, *The Elements of Statistical Learning*, 7.10), on the paired
    per-maneuver differences of the held-out errors (the samples of one maneuver are
    correlated; maneuvers are the independent units).

    The difference per held-out maneuver is taken in the score's own terms
    (:class:`SelectionSettings` ``cv_average``): its share of the pooled mean squared error
    ('sample'), of the log mean squared error ('maneuver') or of the RMS ('maneuver-rms').
    The simpler structure is as good when the mean difference (its excess) is at most
    ``k`` times its standard error. With fewer than three scored maneuvers there is no
    standard error and only a lower score counts (False).

    Parameters
    ----------
    r2_simple, r2_best : ndarray, shape (N,)
        Squared held-out residuals (:func:`cv_residuals`), NaN where a fold's model gave
        none.
    held : ndarray of bool, shape (N,)
        The samples scored (the same for both: the same folds and mask).
    groups : ndarray, shape (N,)
        Maneuver id per sample (the folds hold out whole maneuvers).
    k : float
        Standard errors allowed (``SelectionSettings.parsimony``).
    cv_average : str

    Returns
    -------
    bool
    """
    if not (len(r2_simple) == len(r2_best) == len(held) == len(groups)):
        raise InputError("within_standard_errors: the residuals, mask and groups differ "
                         "in length")
    if not (np.all(np.isfinite(r2_simple[held])) and np.all(np.isfinite(r2_best[held]))):
        return False
    _ids, s_sse, n = _by_group(r2_simple, held, groups)
    _ids, b_sse, _n = _by_group(r2_best, held, groups)
    if len(n) < 3:
        return False
    if cv_average == "maneuver":
        floor = np.finfo(float).tiny
        d = np.log(np.maximum(s_sse / n, floor)) - np.log(np.maximum(b_sse / n, floor))
    elif cv_average == "maneuver-rms":
        d = np.sqrt(s_sse / n) - np.sqrt(b_sse / n)
    else:                   # each maneuver's share of the pooled mean squared error
        d = (s_sse - b_sse) / n.sum() * len(n)
    excess, se = float(np.mean(d)), float(np.std(d, ddof=1) / np.sqrt(len(d)))
    return excess <= k * se


def _by_group(r2: np.ndarray, held: np.ndarray, groups: np.ndarray) -> tuple:
    """Per group (maneuver) with scored samples ``held``: (ids, sum of squared residuals,
    count)."""
    ids, inv = np.unique(np.asarray(groups)[held], return_inverse=True)
    return (ids, np.bincount(inv, weights=r2[held], minlength=len(ids)),
            np.bincount(inv, minlength=len(ids)).astype(float))


def _coarse_fold_models(cs: Structure, x: np.ndarray, y: np.ndarray, folds: np.ndarray,
                        k: int, min_points: int, ridge: float,
                        equations: FoldEquations | None = None) -> list:
    """The coarse structure ``cs`` fitted to each fold's training data (the prior of a
    cross-validated fine structure), from its inputs ``x``."""
    coarse = StructureSpace.build(cs, x, min_points)
    if equations is not None:
        c_total, c_parts = equations.get(cs, coarse, min_points)
    else:
        c_total, c_parts = fold_equations(coarse.space, coarse.scheduling,
                                          coarse.multipliers, y, folds, k)
    return [AeroModel(cs, coarse.scaling, _solve(coarse.space, c_total - c_parts[f], ridge),
                      {}, *coarse.multiplier_scaling) for f in range(k)]


def _cv_setup(columns: Mapping, y: np.ndarray, maneuvers: np.ndarray,
              settings: SelectionSettings, seed: int, conditions: np.ndarray | None,
              cells: np.ndarray | None = None):
    """Subsampled columns, coefficient, folds, scored-sample mask and maneuver ids of a
    cross-validation, or None with fewer than 2 maneuvers (fewer maneuvers than folds:
    leave one maneuver out instead).

    With ``cells`` (envelope cell per sample) each maneuver's most visited cell stands
    for its flight condition when the folds are drawn, and only held-out samples whose
    cell the training folds cover are scored; otherwise ``conditions`` play both parts.
    """
    step = subsample_step(len(y), settings.max_samples)
    cols = {k: np.asarray(v)[::step] for k, v in columns.items()}
    ys, mans = np.asarray(y, dtype=float)[::step], np.asarray(maneuvers)[::step]
    k = min(settings.folds, len(np.unique(mans)))
    if k < 2:
        return None
    if cells is not None:
        cel = np.asarray(cells)[::step]
        folds = fold_by_maneuver(mans, k, seed=seed, conditions=_modal_cell(mans, cel),
                                 excitation=ys)
        scored = covered_in_folds(cel, folds, int(cel.max()) + 1)
    else:
        cond = None if conditions is None else np.asarray(conditions)[::step]
        folds = fold_by_maneuver(mans, k, seed=seed, conditions=cond, excitation=ys)
        scored = None if cond is None else covered_in_fold(folds, cond)
    if settings.cv_box:
        box = in_training_box(cols, folds)
        scored = box if scored is None else scored & box
    return cols, ys, folds, scored, mans


def cv_scored_share(columns: Mapping, y: np.ndarray, maneuvers: np.ndarray,
                    settings: SelectionSettings | None = None, *, seed: int = 0,
                    conditions: np.ndarray | None = None,
                    cells: np.ndarray | None = None, by: str = "samples") -> dict:
    """The share of each maneuver that the cross-validation of :func:`select_structure`
    (same arguments) scores.

    A held-out sample counts only where the training folds cover its envelope cell (and
    box, with ``cv_box``). A maneuver flown alone in its cells (the one rudder pulse of a
    test point) is never scored, so it cannot tell the candidate structures apart.

    Parameters
    ----------
    by : {'samples', 'variation'}
        'samples': the share of the maneuver's samples. 'variation': the share of its
        variation, the sum of squared deviations of ``y`` from the maneuver's mean (the
        samples' share where ``y`` is constant in it). A maneuver whose trimmed lead-in
        and tail lie in cells that other maneuvers cover, but whose response leaves them,
        has a fair share of its samples scored and almost none of what it shows: the
        one elevator doublet of a still-air course had 15 % of its samples scored and
        0.2 % of its pitching-moment variation.

    Returns
    -------
    dict of maneuver id to float
        In [0, 1]; empty when the data have fewer than two maneuvers.
    """
    if by not in ("samples", "variation"):
        raise InputError(f"by must be 'samples' or 'variation', got {by!r}")
    settings = settings or SelectionSettings()
    setup = _cv_setup(columns, y, maneuvers, settings, seed, conditions, cells)
    if setup is None:
        return {}
    ys, scored, mans = setup[1], setup[3], setup[4]
    ids, where = np.unique(mans, return_inverse=True)
    if scored is None:
        return {m: 1.0 for m in ids.tolist()}
    count = np.bincount(where).astype(float)
    weight = np.ones(len(ys))
    if by == "variation":
        mean = np.bincount(where, weights=ys) / count
        weight = (ys - mean[where]) ** 2
        flat = np.bincount(where, weights=weight)[where] <= 0.0
        weight[flat] = 1.0                   # constant y in the maneuver: its samples
    share = np.bincount(where, weights=weight * scored) / np.bincount(where, weights=weight)
    return dict(zip(ids.tolist(), share.tolist()))


def in_training_box(columns: Mapping, folds: np.ndarray) -> np.ndarray:
    """Per sample, whether every column lies within the range its training folds span
    (the held-out fold's samples judged against the other folds' minimum and maximum).

    Parameters
    ----------
    columns : mapping of str to (n,) ndarray
        The candidate variables (NaN-free).
    folds : (n,) ndarray of int

    Returns
    -------
    (n,) ndarray of bool
    """
    folds = np.asarray(folds)
    inside = np.ones(len(folds), dtype=bool)
    for f in np.unique(folds):
        held = folds == f
        train = ~held
        if not train.any():
            continue
        for v in columns.values():
            v = np.asarray(v, dtype=float)
            lo, hi = v[train].min(), v[train].max()
            inside[held] &= (v[held] >= lo) & (v[held] <= hi)
    return inside


def _modal_cell(maneuvers: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Per sample, the cell its maneuver visits most."""
    ids, where = np.unique(maneuvers, return_inverse=True)
    table = np.zeros((len(ids), int(cells.max()) + 1))
    np.add.at(table, (where, cells), 1.0)
    return np.argmax(table, axis=1)[where]


def choose_prior_degree(structure: Structure, columns: Mapping, y: np.ndarray,
                        maneuvers: np.ndarray, settings: SelectionSettings | None = None, *,
                        seed: int = 0, conditions: np.ndarray | None = None,
                        cells: np.ndarray | None = None,
                        cache: SearchCache | None = None) -> tuple[int, dict]:
    """The degree of the prior's coarse model (:data:`~simplexspline.aero.modelling.prior.
    PRIOR_DEGREES`) with the lowest k-fold cross-validation RMS (folds = maneuvers) of the
    *fine* structure shrunk towards it: the coarse model matters where the fine one's data
    are thin, which is what held-out maneuvers probe.

    ``conditions`` (flight-condition id per sample) and ``cells`` (envelope cell per
    sample), optional: see :func:`select_structure`. ``cache`` (optional): a
    :class:`SearchCache` to share with :func:`select_structure` on the same data (its
    first score, the starting structure with the chosen prior, is then not recomputed).

    Returns
    -------
    degree : int
        3 when the structure gets no prior (or there are too few maneuvers to choose).
    scores : dict
        CV RMS per degree tried.
    """
    settings = settings or SelectionSettings()
    if not _use_prior(structure, settings.prior):
        return 3, {}
    setup = _cv_setup(columns, y, maneuvers, settings, seed, conditions, cells)
    if setup is None:
        return 3, {}
    cols, ys, folds, scored, mans = setup
    cache = (cache or SearchCache()).bind(ys, folds, scored, settings)
    scores = {}
    with kernels.one_blas_thread():
        for d in PRIOR_DEGREES:
            try:
                with compute_slot():
                    result = cv_score(structure, cols, ys, folds, settings, prior_degree=d,
                                      scored=scored, coarse_cache=cache.coarse,
                                      equations=cache.equations, groups=mans)
                cache.scores[structure, d] = result
                scores[d] = result[0]
            except SimplexSplineError:
                scores[d] = float("inf")
    best = min(scores, key=scores.get)
    return (best if np.isfinite(scores[best]) else 3), scores


def _size(s: Structure, ranges: Mapping | None = None) -> int:
    return s.size(ranges)


def select_structure(start: Structure, columns: Mapping, y: np.ndarray,
                     maneuvers: np.ndarray, settings: SelectionSettings | None = None, *,
                     seed: int = 0, progress: Callable[[str], None] | None = None,
                     prior_degree: int = 3, conditions: np.ndarray | None = None,
                     cells: np.ndarray | None = None,
                     cache: SearchCache | None = None,
                     duration_s: float | None = None) -> tuple[Structure, list]:
    """Greedy automatic model structure selection.

    From ``start``, each round cross-validates the moves and accepts the best while it
    improves the score. With ``settings.linear_restart`` the search runs again from the
    linear model of ``start``'s terms when that cross-validates better than the result,
    and the better of the two results is returned.

    Parameters
    ----------
    start : Structure
        Where the search starts (e.g. the paper's structure).
    columns : mapping of str to ndarray, shape (N,)
        Identification data by column (physical units).
    y : ndarray, shape (N,)
        The coefficient.
    maneuvers : ndarray, shape (N,)
        Maneuver id per sample (the folds hold out whole maneuvers).
    settings : SelectionSettings, optional
    seed : int
        Seed of the fold assignment.
    progress : callable, optional
        Called with a short text after each scored structure.
    prior_degree : int
        Degree of the coarse model of the prior (see :func:`choose_prior_degree`).
    conditions : ndarray, shape (N,), optional
        Flight-condition id per sample: the folds spread every condition's maneuvers and
        the CV RMS counts only held-out samples whose condition keeps most of its data in
        the training folds (:func:`~simplexspline.aero.selection.validation.covered_in_fold`), so
        that the selection optimises what the validation measures.
    cells : ndarray of int, shape (N,), optional
        Envelope cell per sample (:class:`~simplexspline.aero.selection.coverage.
        EnvelopeCells`), the data-driven form of ``conditions`` (which it replaces): a
        held-out sample counts only when the training folds cover its cell
        (:func:`~simplexspline.aero.selection.coverage.covered_in_folds`), so the search
        neither rewards nor punishes extrapolation.
    cache : SearchCache, optional
        What the cross-validations share (see :class:`SearchCache`); pass the one given
        to :func:`choose_prior_degree` on the same data to reuse its scores.
    duration_s : float, optional
        Time the identification data span [s] (the sum over maneuvers): with it the size
        budget is also ``duration_s / settings.seconds_per_coefficient``.

    Returns
    -------
    best : Structure
    history : list of Trial
        Every structure tried, in order, with its CV RMS (``inf`` when it failed, with the
        reason in ``error``); the accepted ones have ``accepted=True``.
    """
    settings = settings or SelectionSettings()
    y = np.asarray(y, dtype=float)
    n = len(y)
    setup = _cv_setup(columns, y, maneuvers, settings, seed, conditions, cells)
    if setup is None:
        raise InputError("structure selection needs at least 2 identification maneuvers "
                         "for cross-validation; give more maneuvers or use select=False "
                         "(--no-select)")
    cols, ys, folds, scored, mans = setup
    # a flow-angle rate is not offered to a force that makes it (RATES_OF_FORCES)
    available = [v for v in cols if np.ptp(np.asarray(cols[v], dtype=float)) > 0
                 and start.coefficient not in RATES_OF_FORCES.get(v, ())]
    ranges = {v: (float(np.min(cols[v])), float(np.max(cols[v]))) for v in available}
    budget = min(settings.max_coefficients, int(max(
        len(ys) / settings.samples_per_coefficient,
        (duration_s or 0.0) / settings.seconds_per_coefficient)))
    seen: dict = {}
    history: list = []
    cache = (cache or SearchCache()).bind(ys, folds, scored, settings)

    def score(s: Structure, rnd: int, move: str) -> float:
        key = s
        if key in seen:
            return seen[key]
        t0 = time.perf_counter()
        trial = Trial(s, float("inf"), rnd, move)
        try:
            done = cache.scores.get((s, prior_degree))
            if done is None:
                with compute_slot():
                    t0 = time.perf_counter()       # the trial's own time, not the wait
                    done = cv_score(s, cols, ys, folds, settings, prior_degree=prior_degree,
                                    scored=scored, coarse_cache=cache.coarse,
                                    equations=cache.equations, groups=mans)
            trial.score, trial.ncoefficients, trial.nsimplex = done
        except SimplexSplineError as exc:
            trial.error = str(exc)[:300]
        trial.seconds = time.perf_counter() - t0
        seen[key] = trial.score
        history.append(trial)
        if progress is not None:
            progress(f"{s.label()}: {trial.score:.4g}")
        return trial.score

    score.history = history
    def screen(best, moves):
        with compute_slot():
            return screen_moves(best, moves, cols, ys, settings)

    score.screen = screen if settings.screen else None
    kinks = kink_positions(cols, available) if "kinks" in settings.moves else None
    joint = (kink_positions(cols, available, JOINT_KINK_QUANTILES)
             if "kinks" in settings.moves and settings.joint_kinks else None)
    score.place = None
    if kinks and settings.place_kinks:
        plain = replace(settings, prior=None, hold_terms=False)

        def sse(s: Structure) -> float:
            try:
                r = ys - fit_structure(s, cols, ys, plain).predict(cols)
            except SimplexSplineError:
                return float("inf")
            return float(r @ r)

        def place(best: Structure, term: str):
            v, _k = kinked_variable(term)
            if v not in kinks or len(kinks[v]) < 2:
                return best          # a lateral variable's kink stays at 0 (mirror symmetry)
            with compute_slot():
                return place_kink(best, term, kinks[v], sse, limits=ranges.get(v))[0]

        score.place = place

    residuals: dict = {}                        # held-out residuals, computed once each

    def held_out(s: Structure) -> tuple:
        """Squared held-out residuals of ``s`` and the samples scored (:func:`cv_residuals`)."""
        if s not in residuals:
            with compute_slot():
                residuals[s] = cv_residuals(s, cols, ys, folds, settings,
                                            prior_degree=prior_degree, scored=scored,
                                            coarse_cache=cache.coarse,
                                            equations=cache.equations)[:2]
        return residuals[s]

    def searched() -> tuple:
        """The greedy search and, where it applies, the linear restart."""
        best, found = _search(start, settings, available, budget, score, ranges, kinks,
                              joint)
        history = score.history
        linear = linear_start(start)
        if not settings.linear_restart or linear == start:
            return best, history
        first = [t.accepted for t in history]

        def as_good(simple: Structure, simple_score: float) -> bool:
            """``simple`` cross-validates better than the search's result, or within
            ``settings.parsimony`` standard errors of it (:func:`within_standard_errors`)."""
            if simple_score < found:
                return True
            if not settings.parsimony or not np.isfinite(simple_score) or simple == best:
                return False
            (r_simple, _s), (r_best, scored_best) = held_out(simple), held_out(best)
            return within_standard_errors(r_simple, r_best, scored_best, mans,
                                          settings.parsimony, settings.cv_average)

        if not as_good(linear, score(linear, 0, "linear start")):
            return best, history
        for t in history:                                 # accepted: the path to the result
            t.accepted = False
        again, again_score = _search(linear, settings, available, budget, score, ranges,
                                     kinks, joint, label="linear start")
        if again_score < found or (again.size() <= best.size()
                                   and as_good(again, again_score)):
            return again, history
        for t, a in zip(history, first + [False] * (len(history) - len(first))):
            t.accepted = a                                # the first search's result stays
        return best, history

    fold_residuals: dict = {}                   # (structure, fold) -> that fold's residuals

    def held_out_in(s: Structure, f: int) -> tuple:
        """Squared residuals of fold ``f``'s held-out samples predicted by ``s`` fitted
        to the other folds (that fold's solve only), and the samples scored."""
        if (s, f) not in fold_residuals:
            only = (folds == f) & (np.ones(len(ys), dtype=bool) if scored is None
                                   else scored)
            try:
                with compute_slot():
                    fold_residuals[s, f] = cv_residuals(
                        s, cols, ys, folds, settings, prior_degree=prior_degree,
                        scored=only, coarse_cache=cache.coarse,
                        equations=cache.equations)[:2]
            except SimplexSplineError:
                fold_residuals[s, f] = (np.full(len(ys), np.nan), only)
        return fold_residuals[s, f]

    def hinge_started(best: Structure, history: list) -> tuple:
        """The adaptive-regression-spline start (``settings.hinge_start``),
        cross-validated with its passes inside the folds: taken when it beats the
        search's result by the move threshold and by ``parsimony`` standard errors."""
        found = score(best, 0, "result")
        variables = [v for v in available if v in settings.candidates]
        try:
            with compute_slot():
                final = hinge_choices(start, cols, ys, variables)
        except SimplexSplineError:
            return best, history
        if not final:
            return best, history
        # a screen: scored with the passes on all the data the hinge structures can only
        # look better than they are; where even so none beats the search's result, the
        # passes inside the folds are not worth running
        optimistic = min(score(h, 0, f"hinge start screen (GCV cost {pen:g}, "
                                     f"{len(h.multipliers)} terms; passes on all the data)")
                         for pen, h in final.items())
        if not optimistic < found * (1.0 - settings.min_improvement):
            return best, history
        try:
            with compute_slot():
                per_fold = [hinge_choices(start, {v: cols[v][folds != f] for v in variables},
                                          ys[folds != f], variables)
                            for f in range(int(folds.max()) + 1)]
        except SimplexSplineError:
            return best, history
        if not all(per_fold):
            return best, history
        chosen = None
        for pen, h in final.items():
            t0 = time.perf_counter()
            r2 = np.zeros(len(ys))
            held = np.zeros(len(ys), dtype=bool)
            for f, choices in enumerate(per_fold):
                part = folds == f
                rf, hf = held_out_in(choices[pen], f)
                r2[part], held[part] = rf[part], hf[part]
            c = (_pooled_rms(r2, held, folds, mans, settings)
                 if held.any() and np.all(np.isfinite(r2[held])) else float("inf"))
            history.append(Trial(h, c, 0, f"hinge start (GCV cost {pen:g}, "
                                          f"{len(h.multipliers)} terms; its passes inside "
                                          "the folds)", seconds=time.perf_counter() - t0))
            if progress is not None:
                progress(f"{h.label()}: {c:.4g}")
            if np.isfinite(c) and (chosen is None or c < chosen[0]):
                chosen = (c, h, r2, held)
        if chosen is None:
            return best, history
        c, h, r2_h, held_h = chosen
        if not c < found * (1.0 - settings.min_improvement):
            return best, history
        if settings.parsimony:
            r_best, s_best = held_out(best)
            if within_standard_errors(r_best, r2_h, s_best & held_h, mans,
                                      settings.parsimony, settings.cv_average):
                return best, history
        for t in history:
            t.accepted = False
        _accept(history, h, c)
        return h, history

    with kernels.one_blas_thread():
        best, history = searched()
        if not settings.hinge_start:
            return best, history
        return hinge_started(best, history)


#: Kinds of moves that :func:`screen_moves` ranks before any is cross-validated.
_SCREENED = ("add multiplier ", "schedule on ", "remove multiplier ", "add kink ",
             "add kinks ")


def screen_moves(best: Structure, moves: list, columns: Mapping, y: np.ndarray,
                 settings: SelectionSettings) -> list:
    """The moves worth a cross-validation: all but the 'add multiplier', 'schedule on',
    'remove multiplier', 'add kink' and 'add kinks' moves, of which only the
    ``settings.screen`` most promising each.

    An addition is promising when what it adds explains much of the current model's
    residual: the R^2 of a least-squares fit of the residual (in-sample, of ``best``
    fitted to the search's samples) by the new term (or kink) times 1, z and z^2 (z: the
    first scheduling variable, scaled), by a joint kink's terms (constant coefficients),
    or for a new scheduling variable v by v^2, |v|, v^3 and v z. Of the kinks, the best
    breakpoint of each term and variable (of each variable for joint kinks) comes
    first. A removal is promising when the term contributes little (RMS of its part of the
    current model). A cheap linear regression per move instead of a k-fold spline fit.
    """
    ranked = {kind: [] for kind in _SCREENED}
    kept = []
    for move, cand in moves:
        kind = next((k for k in _SCREENED if move.startswith(k)), None)
        (kept.append((move, cand)) if kind is None else ranked[kind].append((move, cand)))
    if not any(len(r) > settings.screen for r in ranked.values()):
        return moves
    try:
        # residuals where the data are: the hold of unexcited terms does not matter here
        model = fit_structure(best, columns, y, replace(settings, prior=None,
                                                        hold_terms=False))
    except SimplexSplineError:
        return moves
    resid = y - model.predict(columns)
    share = {}
    if best.varying:
        z, m = model.split(model.inputs(columns), clip=True)
        parts = model.spline.term_values(z, outside="extrapolate") * m
        share = {name: float(np.sqrt(np.mean(parts[:, k] ** 2)))
                 for k, name in enumerate(best.multipliers)}
    z0 = np.asarray(columns[best.variables[0]], dtype=float)
    z0 = (z0 - z0.mean()) / (z0.std() or 1.0)
    for kind, items in ranked.items():
        if len(items) <= settings.screen:
            kept.extend(items)
            continue
        gains = []
        for move, cand in items:
            name = move[len(kind):].split(", ")[0]   # without a note ('degree 0->1')
            if kind == "remove multiplier ":
                gains.append(-share.get(name, 0.0))
                continue
            if kind in ("add multiplier ", "add kink ", "add kinks "):
                added = tuple(t for t in cand.multipliers if t not in best.multipliers)
                terms = Structure(best.coefficient, best.variables, multipliers=added)
                t = multiplier_values(terms, input_matrix(columns, terms.inputs)).T
                # a joint kink's terms have constant coefficients; one new term's may vary
                feats = list(t) if kind == "add kinks " else [t[0], t[0] * z0,
                                                              t[0] * z0 * z0]
            else:
                v = np.asarray(columns[name], dtype=float)
                v = (v - v.mean()) / (v.std() or 1.0)
                feats = [v * v, np.abs(v), v ** 3, v * z0]
            gains.append(_explained(np.vstack(feats), resid))
        order = np.argsort(gains)[::-1]
        if kind in ("add kink ", "add kinks "):
            # one breakpoint per term and variable: neighbouring quantiles of one kink
            # (Mach 0.609 and 0.612) would take the cross-validations' places
            order = _one_per_group(order, [_kink_group(m) for m, _c in items])
        kept.extend(items[i] for i in order[:settings.screen])
    return kept


def _kink_group(move: str) -> tuple:
    """The group of an 'add kink' or 'add kinks' move: its factors without their
    breakpoints, and the kinked variable. ``beta*|mach-0.6|[alpha]`` and
    ``beta*|mach-0.7|[alpha]`` share one; so do the joint ``|mach-0.6|`` and
    ``|mach-0.7|``."""
    term = move.split(" ", 2)[2]
    parts = multiplier_parts(term)
    kink = [c for c, a, _k in parts if a]
    rest = [(c, a) for c, a, _k in parts]
    return str(rest), kink[-1] if kink else ""


def _one_per_group(order, groups) -> list:
    """``order`` with every index after the first of its group moved behind the others."""
    seen, first, later = set(), [], []
    for i in order:
        (later if groups[i] in seen else first).append(i)
        seen.add(groups[i])
    return first + later


def _explained(features: np.ndarray, resid: np.ndarray) -> float:
    """R^2 of the least-squares fit of the centred ``resid`` (N,) by the centred rows of
    ``features`` (k, N), from their small Gram matrix: ``b' G^+ b / r'r`` with ``G = F F'``,
    ``b = F r`` (the screen ranks hundreds of kink candidates per round: a QR of the tall
    matrix for each took 5 s of a main job)."""
    r = resid - resid.mean()
    ss = float(r @ r)
    if not ss > 0:
        return 0.0
    f = features - features.mean(axis=1, keepdims=True)
    b = f @ r
    coef = np.linalg.lstsq(f @ f.T, b, rcond=1e-12)[0]
    return float(min(max(float(b @ coef) / ss, 0.0), 1.0))


def _moves(s: Structure, settings, available, kinks, joint=None) -> list:
    """Every move from ``s``: its neighbours and, with ``kinks`` (candidate breakpoints per
    variable), the kinks of its terms in its scheduling variables and factors; with
    ``joint`` (the joint kinks' candidate breakpoints), the joint kinks there too."""
    out = neighbours(s, settings, available)
    if kinks or joint:
        near = set(s.variables) | {f for m in s.multipliers for f in
                                   multiplier_factors(m)}
    if kinks:
        out += kink_moves(s, {v: kinks[v] for v in kinks if v in near})
    if joint:
        out += joint_kink_moves(s, {v: joint[v] for v in joint if v in near})
    return out


def _search(start, settings, available, budget, score, ranges=None, kinks=None,
            joint=None, label: str = "start"):
    """The greedy search from ``start`` (its trials appended to ``score.history``): the
    best structure and its CV score."""
    best = start
    best_score = score(start, 0, label)
    history = score.history
    if not np.isfinite(best_score):
        raise InputError(f"the starting structure {start.label()} cannot be fitted: "
                         f"{next(t.error for t in reversed(history) if t.structure == start)}")
    _accept(history, start, best_score)
    for rnd in range(1, settings.max_rounds + 1):
        # moves may grow a structure up to the budget; moves that shrink it (fewer
        # multipliers, coarser, lower degree) are always allowed, so a start above the
        # budget (a preset on a short campaign) can still be simplified
        limit = max(budget, _size(best, ranges))
        moves = [(m, s) for m, s in _moves(best, settings, available, kinks, joint)
                 if _size(s, ranges) <= limit]
        if score.screen is not None:
            moves = score.screen(best, moves)
        if not moves:
            break
        results = sorted(((score(s, rnd, m), m, s) for m, s in moves),
                         key=lambda t: t[0])
        taken = [(c, m, s) for c, m, s in results
                 if c < best_score * (1.0 - _needed(best, s, settings))]
        if not taken:
            break
        sc, _move, cand = taken[0]
        # the other moves that improved on the round's start, best first, are tried on
        # top of the accepted one (a move is the same change, found by its description):
        # several independent improvements per round for a few more fits
        others = [m for _c, m, _s in taken[1:]]
        best, best_score = _accept(history, cand, sc)
        best, best_score = _place(best, best_score, _move, rnd, score)
        for move in others[:settings.combine]:
            again = dict(_moves(best, settings, available, kinks, joint)).get(move)
            if again is None or _size(again, ranges) > max(budget, _size(best, ranges)):
                continue
            c = score(again, rnd, f"{move} (combined)")
            if c < best_score * (1.0 - _needed(best, again, settings)):
                best, best_score = _accept(history, again, c)
                best, best_score = _place(best, best_score, move, rnd, score)
    return best, best_score


def _needed(best: Structure, cand: Structure, settings) -> float:
    """The relative improvement of the CV score that the move ``best`` -> ``cand`` must
    bring: ``settings.asymmetry_improvement`` when it adds a term that breaks the
    airframe's symmetry, ``settings.min_improvement`` otherwise."""
    added = set(cand.multipliers) - set(best.multipliers)
    if any(breaks_symmetry(cand.coefficient, m) for m in added):
        return max(settings.min_improvement, settings.asymmetry_improvement)
    return settings.min_improvement


def _place(best: Structure, best_score: float, move: str, rnd: int, score) -> tuple:
    """After an accepted 'add kink' move: the kink moved to where the fit's squared error
    is least (:func:`~simplexspline.aero.selection.kink_location.place_kink`), kept when
    the cross-validation agrees."""
    if not move.startswith("add kink ") or getattr(score, "place", None) is None:
        return best, best_score
    term = move[len("add kink "):]
    if term not in best.multipliers:
        return best, best_score
    moved = score.place(best, term)
    if moved == best:
        return best, best_score
    new = next(t for t in moved.multipliers if t not in best.multipliers)
    c = score(moved, rnd, f"move kink {term} -> {new}")
    if c < best_score:
        return _accept(score.history, moved, c)
    return best, best_score


def _accept(history: list, structure: Structure, value: float) -> tuple:
    """Mark the last trial of ``structure`` accepted; the new (best, score)."""
    for t in reversed(history):
        if t.structure == structure:
            t.accepted = True
            break
    return structure, value
