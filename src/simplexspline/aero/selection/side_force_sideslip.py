"""The sideslip that the side force gives, through an identified side-force model.

Without a sideslip vane the reconstruction has the sideslip from the lateral kinematics
(the accelerometers, the rates and attitudes, the GPS velocities and a wind). In turbulence
that sideslip misses the lateral gusts: the air's velocity across the aircraft changes
faster than any wind state follows, and no channel of such a record measures it. On a
simulated 10 Hz f16 record in light turbulence the kinematic sideslip was off by 6.9e-3
rad RMS, and the roll and yaw models identified on it by 2-3x their noise (validation R^2
of Cl -0.32 on seed 5 of that record, CY, Cl and Cn identified alone; 0.49 on the side
force's sideslip).

The lateral accelerometer does see the gusts: the side force follows the sideslip of the
air, ``CY = CY(beta, ...)``. With a model of CY identified on the kinematic sideslip, the
part of the measured CY that the model does not explain, divided by the model's
``dCY/dbeta``, is the sideslip the kinematics missed:

    beta_sf = beta + (CY - CY_model) / (dCY/dbeta)

(a model-aided, or "synthetic", sideslip, as flight-test departments compute it for
aircraft without a vane). Its own error is the side-force noise over ``CY_beta`` plus the
CY model's error, and its scale is that of CY's slope, which the gusts in the kinematic
sideslip attenuate (errors in variables: ``var(beta) / (var(beta) + var(gust))``); a model
linear in it absorbs the scale. It cannot serve CY itself (CY's model fitted on
``beta_sf`` would reproduce the model that made it), so CY keeps the kinematic sideslip.

Whether it is better is measured, not assumed. Where CY's model is poor (a 12-maneuver
sortie that barely excited the side force: validation R^2 0.13-0.39) its residual is model
error rather than gusts: in-sample the corrected sideslip still looked better, but on
maneuvers that CY's model had not seen it was 2.3x worse than the kinematic one, and the
roll and yaw models fitted on it lost their validation R^2 (0.35 -> 0.02, 0.65 -> 0.28). So:

* :func:`cross_fitted_sideslip`: on the identification maneuvers the correction comes from
  CY's structure refitted without the maneuver's fold, so that it is as out-of-sample there
  as on the validation maneuvers;
* :func:`referee`: the roll and yaw moments judge it, by the cross-validated error of a
  model linear in the lateral variables (sideslip, rates, aileron, rudder, with their
  products with alpha and Mach), with either sideslip. The gusts act on them through the
  air's sideslip as on the side force; a sideslip that explains them better out of sample
  is the better one;
* :func:`choose_sideslip` takes the side force's sideslip when it lowers that error (the
  geometric mean over Cl and Cn) below :data:`REFEREE_GAIN`.

**The slope** (since stop 57). CY's identified model is the one that predicts CY best on
the kinematic sideslip, which is not the one whose ``dCY/dbeta`` is the air's. Where the
kinematic sideslip misses the gusts, the roll rate and the aileron (which move with the
sideslip in a Dutch roll and in a gust's response) take over part of its effect: on a
global5000 flight-test course in light turbulence (``bench_whole_flight.py --aircraft
global5000 --design eigenmotion --turns --maneuvers 12 --seed 21``, no maneuver list)
CY's model had ``dCY/dbeta`` -0.21 /rad against the simulator's -0.94, and a least-squares
fit in the sideslip, the rudder, the yaw rate, the roll rate and the aileron on the rudder
inputs alone gave -0.15; without the roll rate and the aileron, -0.94. The side force's
sideslip through CY's model was then 2.3x the air's (error 1.8e-2 rad RMS against the
kinematic 9.1e-3), and the roll and yaw models' ``Cl_beta`` and ``Cn_beta`` 5x too small.
So :class:`LinearSideForce` is a second candidate: ``CY = c0 + CY_beta beta + CY_dr dr +
CY_r rhat``, the first-order side force of any aircraft with a fin, fitted on the
maneuvers that move the kinematic sideslip most (within-maneuver standard deviation at
least :data:`~simplexspline.aero.selection.validation.EXCITED` of the largest: there the
gusts are a small part of it). On that course its sideslip is off by 2.6e-3 rad RMS
(correlation 0.98 with the air's, scale 1.05). It is fitted once on the identification
data, not cross-fitted: four coefficients over thousands of samples barely see their own
noise, while a fold without the course's few rudder inputs fitted its slope on gusts
(-0.28 /rad). The referee chooses between the two, as between either and the kinematic
sideslip.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from simplexspline.aero.modelling.model import AeroModel
from simplexspline.aero.selection.search import SelectionSettings, fit_structure
from simplexspline.aero.selection.validation import fold_by_maneuver, maneuver_spread
from simplexspline.errors import InputError

__all__ = ["FOLDS", "LINEAR_TERMS", "LinearSideForce", "MAX_CORRECTION", "MIN_SLOPE_SHARE",
           "REFEREE_GAIN", "SideForceSideslip", "SideslipChoice", "choose_sideslip",
           "cross_fitted_sideslip", "referee", "side_force_sideslip"]

#: Largest correction of the kinematic sideslip [rad]: the sigma of the reconstruction's
#: zero-mean sideslip pseudo-measurement; a lateral gust of 2-3 m/s at 150 m/s is 0.02 rad.
MAX_CORRECTION = 0.05
#: Where the model's |dCY/dbeta| falls below this share of its median (a model that flattens
#: at the edge of its box, or a sample where its slope changes sign), the median slope is
#: used instead: a small slope would blow the noise up.
MIN_SLOPE_SHARE = 0.5
#: Folds by maneuver of the cross-fitting and of the referee (fewer with fewer maneuvers).
FOLDS = 5
#: The side force's sideslip is taken when the referee's cross-validated error of the roll
#: and yaw moments with it is below this share of the error with the kinematic sideslip.
REFEREE_GAIN = 0.95
#: The lateral variables of the referee's linear models (those in the data), besides the
#: sideslip; each also enters multiplied by alpha and by Mach when those are in the data.
REFEREE_VARIABLES = ("phat", "rhat", "da", "dr")
#: The terms of :class:`LinearSideForce` besides the constant and the sideslip (those in
#: the data): the rudder and the yaw rate.
LINEAR_TERMS = ("dr", "rhat")


@dataclass(frozen=True)
class LinearSideForce:
    """``CY = c0 + CY_beta beta + CY_dr dr + CY_r rhat`` (the :data:`LINEAR_TERMS` in the
    data), fitted by least squares on the maneuvers that move the kinematic sideslip most
    (module docstring, "The slope").

    Attributes
    ----------
    terms : tuple of str
        ``('1', 'beta', ...)``.
    coefficients : ndarray, shape (len(terms),)
    maneuvers : tuple
        The maneuvers it was fitted on.
    """

    terms: tuple
    coefficients: np.ndarray
    maneuvers: tuple = ()

    @property
    def slope(self) -> float:
        """``dCY/dbeta`` [1/rad]."""
        return float(self.coefficients[1])

    @classmethod
    def fit(cls, data) -> LinearSideForce:
        """Fit on ``data`` (``maneuver``, ``CY``, ``beta`` and the :data:`LINEAR_TERMS`
        present), on the maneuvers whose within-maneuver standard deviation of ``beta`` is
        at least :data:`~simplexspline.aero.selection.validation.EXCITED` times the
        largest (all of them where the sideslip moves in none).

        Raises
        ------
        InputError
            No ``beta`` or ``CY`` column, fewer samples than terms, or a slope that is 0
            or not finite (the side force cannot give the sideslip).
        """
        if not {"beta", "CY", "maneuver"} <= set(data.columns):
            raise InputError("the linear side-force model needs the columns maneuver, beta "
                             "and CY")
        terms = ("1", "beta", *(t for t in LINEAR_TERMS if t in data.columns))
        mans = data["maneuver"].to_numpy()
        ids = np.unique(mans)
        spread, level = maneuver_spread(mans, len(ids),
                                        data["beta"].to_numpy(dtype=float))
        moving = ids[spread[:, 0] >= level[0]] if np.isfinite(level[0]) else ids
        rows = np.isin(mans, moving)
        x = np.column_stack([np.ones(int(rows.sum()))]
                            + [data[t].to_numpy(dtype=float)[rows] for t in terms[1:]])
        y = data["CY"].to_numpy(dtype=float)[rows]
        ok = np.all(np.isfinite(x), axis=1) & np.isfinite(y)
        if ok.sum() <= len(terms):
            raise InputError(f"the linear side-force model has {int(ok.sum())} finite "
                             f"samples for {len(terms)} terms")
        coef, *_ = np.linalg.lstsq(x[ok], y[ok], rcond=None)
        if not np.isfinite(coef[1]) or coef[1] == 0.0:
            raise InputError(f"the linear side-force model's dCY/dbeta is {coef[1]:g}: it "
                             "cannot give the sideslip")
        return cls(terms, coef, tuple(moving.tolist()))

    def predict(self, data) -> np.ndarray:
        """CY at the rows of ``data``, shape (N,)."""
        x = np.column_stack([np.ones(len(data))]
                            + [data[t].to_numpy(dtype=float) for t in self.terms[1:]])
        return x @ self.coefficients


@dataclass(frozen=True)
class SideForceSideslip:
    """The corrected sideslip and what was done.

    Attributes
    ----------
    beta : ndarray, shape (N,)
        The sideslip [rad]: ``beta_sf`` in the rows asked for, the kinematic one elsewhere.
    slope : float
        Median ``dCY/dbeta`` of the model over those rows [1/rad].
    correction_rms : float
        RMS of ``beta_sf - beta`` over those rows [rad].
    clipped : int
        Rows whose correction was clipped to :data:`MAX_CORRECTION`.
    """

    beta: np.ndarray
    slope: float
    correction_rms: float
    clipped: int


def side_force_sideslip(model: AeroModel | LinearSideForce, data,
                        rows: np.ndarray) -> SideForceSideslip:
    """``beta + (CY - CY_model) / (dCY/dbeta)`` in the rows ``rows``.

    Parameters
    ----------
    model : AeroModel or LinearSideForce
        A side-force model (coefficient ``CY``) with ``beta`` among its inputs, identified
        on the kinematic sideslip.
    data : pandas.DataFrame
        Flight data with the model's inputs, ``beta`` [rad] and the measured ``CY`` [-].
    rows : ndarray of bool, shape (N,)
        The rows to correct (the maneuvers with gusts).

    Returns
    -------
    SideForceSideslip

    Raises
    ------
    InputError
        The model is not a side-force model with ``beta``, or its slope is zero.
    """
    linear = isinstance(model, LinearSideForce)
    if not linear and (model.coefficient != "CY" or "beta" not in model.variables):
        raise InputError(f"the sideslip from the side force needs a CY model with 'beta' "
                         f"among its variables, got {model.structure.label()}")
    beta = data["beta"].to_numpy(dtype=float).copy()
    rows = np.asarray(rows, dtype=bool)
    if not rows.any():
        return SideForceSideslip(beta, float("nan"), 0.0, 0)
    part = data.loc[rows]
    slope = np.full(len(part), model.slope) if linear else \
        model.gradient(part)[:, list(model.variables).index("beta")]
    typical = float(np.median(slope))
    if not np.isfinite(typical) or typical == 0.0:
        raise InputError(f"the CY model's dCY/dbeta is {typical:g} over the rows asked for: "
                         "it cannot give the sideslip")
    weak = ~(slope / typical >= MIN_SLOPE_SHARE)
    slope = np.where(weak, typical, slope)
    residual = part["CY"].to_numpy(dtype=float) - model.predict(part)
    correction = residual / slope
    clipped = int(np.sum(np.abs(correction) > MAX_CORRECTION))
    correction = np.clip(correction, -MAX_CORRECTION, MAX_CORRECTION)
    beta[rows] += correction
    return SideForceSideslip(beta, typical, float(np.sqrt(np.mean(correction ** 2))), clipped)


def _folds(data, seed: int) -> np.ndarray | None:
    """Fold per row (whole maneuvers), or None with fewer than two maneuvers."""
    mans = data["maneuver"].to_numpy()
    k = min(FOLDS, np.unique(mans).size)
    return None if k < 2 else fold_by_maneuver(mans, k, seed=seed)


def cross_fitted_sideslip(model: AeroModel, data, rows: np.ndarray,
                          settings: SelectionSettings, *, seed: int = 0,
                          folds: np.ndarray | None = None) -> SideForceSideslip:
    """:func:`side_force_sideslip` on the data the model was identified on, each fold of
    maneuvers through the model's structure refitted on the other folds (same settings and
    prior degree), so that the correction is out of sample as on new maneuvers.

    Parameters
    ----------
    model : AeroModel
        CY's model, identified on ``data``.
    data : pandas.DataFrame
        Its identification data (``maneuver``, the model's inputs, ``beta``, ``CY``).
    rows : ndarray of bool, shape (N,)
    settings : SelectionSettings
        The settings the model was fitted with.
    seed : int
        Seed of the folds.
    folds : ndarray of int, shape (N,), optional
        The folds by maneuver, when the caller has them.

    Returns
    -------
    SideForceSideslip
        Slope and clipped count over all folds; the correction's RMS over ``rows``.

    Raises
    ------
    InputError
        Fewer than two maneuvers.
    """
    folds = _folds(data, seed) if folds is None else folds
    if folds is None:
        raise InputError("cross-fitting the side force's sideslip needs at least two "
                         "maneuvers")
    rows = np.asarray(rows, dtype=bool)
    beta = data["beta"].to_numpy(dtype=float).copy()
    columns = {v: data[v].to_numpy(dtype=float) for v in model.variables}
    y = data["CY"].to_numpy(dtype=float)
    degree = int((model.provenance.get("prior") or {}).get("degree", 3))
    slopes, clipped = [], 0
    for f in np.unique(folds):
        test = folds == f
        if not (rows & test).any():
            continue
        train = ~test
        refit = fit_structure(model.structure, {v: x[train] for v, x in columns.items()},
                              y[train], settings, prior_degree=degree)
        part = data.loc[test]
        sf = side_force_sideslip(refit, part, rows[test])
        beta[test] = sf.beta
        slopes.append(np.full(int((rows & test).sum()), sf.slope))
        clipped += sf.clipped
    correction = (beta - data["beta"].to_numpy(dtype=float))[rows]
    return SideForceSideslip(beta, float(np.median(np.concatenate(slopes))),
                             float(np.sqrt(np.mean(correction ** 2))), clipped)


def _lateral_design(data, beta: np.ndarray) -> np.ndarray:
    """The referee's regressors: 1, the sideslip and the lateral variables present, each
    alone and times alpha and Mach where present."""
    terms = [beta] + [data[v].to_numpy(dtype=float) for v in REFEREE_VARIABLES
                      if v in data.columns]
    scales = [data[v].to_numpy(dtype=float) for v in ("alpha", "mach") if v in data.columns]
    return np.column_stack([np.ones(len(beta)), *terms,
                            *[t * s for t in terms for s in scales]])


def referee(data, beta_a: np.ndarray, beta_b: np.ndarray,
            coefficients: Sequence[str] = ("Cl", "Cn"), *, seed: int = 0,
            folds: np.ndarray | None = None) -> dict:
    """How much better the roll and yaw moments are explained with sideslip ``beta_b`` than
    with ``beta_a``: the ratio of the cross-validated (folds by maneuver) mean square error
    of a model linear in the lateral variables, b over a, per coefficient.

    Parameters
    ----------
    data : pandas.DataFrame
        ``maneuver``, the coefficients, and the lateral variables present
        (:data:`REFEREE_VARIABLES`, ``alpha``, ``mach``).
    beta_a, beta_b : ndarray, shape (N,)
        Two sideslips [rad].
    coefficients : sequence of str
        Those of them in ``data`` are judged.
    seed : int
    folds : ndarray of int, shape (N,), optional
        The folds by maneuver, when the caller has them.

    Returns
    -------
    dict of str to float
        Ratio per coefficient judged (below 1: ``beta_b`` explains it better); empty with
        fewer than two maneuvers or none of the coefficients.
    """
    folds = _folds(data, seed) if folds is None else folds
    out: dict = {}
    if folds is None:
        return out
    designs = (_lateral_design(data, np.asarray(beta_a, dtype=float)),
               _lateral_design(data, np.asarray(beta_b, dtype=float)))
    for c in coefficients:
        if c not in data.columns:
            continue
        y = data[c].to_numpy(dtype=float)
        sse = []
        for x in designs:
            err = 0.0
            for f in np.unique(folds):
                test = folds == f
                coef, *_ = np.linalg.lstsq(x[~test], y[~test], rcond=None)
                err += float(np.sum((y[test] - x[test] @ coef) ** 2))
            sse.append(err)
        out[c] = sse[1] / sse[0] if sse[0] > 0 else float("nan")
    return out


@dataclass(frozen=True)
class SideslipChoice:
    """Which sideslip the coefficients other than CY are identified on.

    Attributes
    ----------
    used : bool
        The side force's sideslip is taken (in the maneuvers with gusts).
    identification, validation : ndarray
        The side force's sideslip per row of either set [rad] (cross-fitted on the
        identification set; through CY's model on the validation set); the kinematic one
        outside the maneuvers with gusts.
    ratios : dict of str to float
        The referee's ratios (:func:`referee`) of the candidate chosen.
    slope : float
        Median dCY/dbeta [1/rad].
    correction_rms : float
        RMS correction over the identification rows with gusts [rad].
    clipped : int
    source : {'model', 'linear'}
        The candidate chosen: through CY's identified model, or :class:`LinearSideForce`.
    candidates : dict
        Per candidate its referee ratios, slope and correction RMS (or the reason it
        could not be made).
    """

    used: bool
    identification: np.ndarray
    validation: np.ndarray
    ratios: dict = field(default_factory=dict)
    slope: float = float("nan")
    correction_rms: float = 0.0
    clipped: int = 0
    source: str = "model"
    candidates: dict = field(default_factory=dict)


def choose_sideslip(model: AeroModel, ident, valid, rows_ident: np.ndarray,
                    rows_valid: np.ndarray, settings: SelectionSettings, *,
                    seed: int = 0) -> SideslipChoice:
    """The side force's sideslip for both sets, through CY's model or through
    :class:`LinearSideForce` (fitted on ``ident``), whichever the roll and yaw moments
    explain better, and whether they take it (:data:`REFEREE_GAIN`; module docstring).

    Parameters
    ----------
    model : AeroModel
        CY's model, identified on ``ident`` with ``settings``.
    ident, valid : pandas.DataFrame
        Identification and validation data.
    rows_ident, rows_valid : ndarray of bool
        Their rows in maneuvers with gusts.
    settings : SelectionSettings
    seed : int

    Returns
    -------
    SideslipChoice
    """
    kinematic = ident["beta"].to_numpy(dtype=float)
    folds = _folds(ident, seed)
    if folds is None:
        return SideslipChoice(False, kinematic, valid["beta"].to_numpy(dtype=float))
    made, why = {}, {}
    fitted = cross_fitted_sideslip(model, ident, rows_ident, settings, folds=folds)
    made["model"] = (fitted, side_force_sideslip(model, valid, rows_valid))
    try:
        # not cross-fitted: four coefficients over thousands of samples, and a fold
        # without the few maneuvers that move the sideslip (a course's rudder inputs)
        # fitted its slope on gusts instead (-0.28 /rad against -0.89 on the rest)
        lin = LinearSideForce.fit(ident)
        made["linear"] = (side_force_sideslip(lin, ident, rows_ident),
                          side_force_sideslip(lin, valid, rows_valid))
    except InputError as exc:
        why["linear"] = str(exc)
    scored = {}
    for name, (fit_i, _on_v) in made.items():
        ratios = referee(ident, kinematic, fit_i.beta, folds=folds)
        finite = [r for r in ratios.values() if np.isfinite(r) and r > 0]
        gain = float(np.exp(np.mean(np.log(finite)))) if finite else float("inf")
        scored[name] = (gain, ratios)
    best = min(scored, key=lambda n: scored[n][0])     # 'model' first on a tie
    gain, ratios = scored[best]
    fit_i, on_v = made[best]
    candidates = {n: {"referee_error_ratios": scored[n][1], "dCY_dbeta": made[n][0].slope,
                      "correction_rms": made[n][0].correction_rms} for n in made}
    candidates.update({n: {"not made": w} for n, w in why.items()})
    return SideslipChoice(gain < REFEREE_GAIN, fit_i.beta, on_v.beta, ratios, fit_i.slope,
                          fit_i.correction_rms, fit_i.clipped + on_v.clipped, best,
                          candidates)
