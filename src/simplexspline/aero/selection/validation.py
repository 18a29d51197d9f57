"""Validation: splits by maneuver, RMS / relative RMS (Eq. 54-55), R^2, residual analysis.

The paper's Eq. 54-55 lost the square root in typesetting: here
``RMS = sqrt(mean(eps^2))`` and ``relative RMS = RMS / (max C - min C)`` (a fraction).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simplexspline.aero.selection.coverage import threshold
from simplexspline.errors import InputError

__all__ = ["CONDITION_KEEP", "COVERED_KEEP", "EXCITED", "FOLD_EXCITED", "PAPER_TABLE2",
           "ValidationSplit", "autocorrelation", "covered_in_fold", "fold_by_maneuver",
           "maneuver_spread",
           "scores", "scores_by_coverage", "split_by_maneuver", "subsample_step",
           "validation_split"]

#: Fraction of each flight condition's samples that stays for identification when
#: validation maneuvers are held out (and in the training folds of a scored
#: cross-validation fold): validation then measures the model where it was identified.
CONDITION_KEEP = 0.5

#: Fraction of a validation maneuver's samples that must stay covered by the
#: identification data (see :func:`split_by_maneuver`, ``cells``).
COVERED_KEEP = 0.9

#: A maneuver excites a signal when the signal's standard deviation within it is at least
#: this fraction of the largest over the maneuvers (:func:`split_by_maneuver`).
EXCITED = 1.0 / 3.0

#: A maneuver moves a coefficient, for the dealing of the cross-validation's folds
#: (:func:`fold_by_maneuver`), when the coefficient's standard deviation within it is at
#: least this fraction of the largest over the maneuvers: a lower bar than
#: :data:`EXCITED`, so that a pulse beside a doublet four times its size counts.
FOLD_EXCITED = 0.1

#: Validation relative RMS of the paper's Table 2 (Cessna Citation II, fractions).
PAPER_TABLE2 = {"CX": 0.0693, "CZ": 0.0260, "Cl": 0.0170, "Cm": 0.0172, "Cn": 0.0472}


def subsample_step(n: int, max_samples: int) -> int:
    """The stride that leaves at most ``max_samples`` of ``n`` samples (every k-th sample,
    so that every maneuver keeps its share): the searches' and the jackknife's
    subsampling of a long record."""
    return max(1, int(np.ceil(n / max_samples)))


@dataclass(frozen=True)
class ValidationSplit:
    """Whole maneuvers held out for validation (:func:`validation_split`).

    Attributes
    ----------
    validation : ndarray of bool, shape (N,)
        True for the samples of the maneuvers held out for every signal.
    left_out : tuple
        Per ``excitation`` signal (column), a maneuver id kept for identification but
        validated by leaving it out, or None: the validation does not excite the signal
        (its standard deviation there below :data:`EXCITED` times the largest), and no
        maneuver that does can be spared (each is the last to excite it, or alone where it
        flies). This maneuver, the one that moves the signal most (more than three times
        as much as any validation maneuver, by the definition of excited), is predicted by
        a model of the same structure identified without it: the validation then measures
        what the signal does, and the delivered model still learns from it. Empty without
        ``excitation``.
    """

    validation: np.ndarray
    left_out: tuple = ()


def split_by_maneuver(maneuvers: np.ndarray, fraction: float = 0.25, **rules) -> np.ndarray:
    """The shared validation samples of :func:`validation_split` (same parameters).

    Returns
    -------
    ndarray of bool, shape (N,)
        True for validation samples.
    """
    return validation_split(maneuvers, fraction, **rules).validation


def validation_split(maneuvers: np.ndarray, fraction: float = 0.25, *, seed: int = 0,
                     groups: np.ndarray | None = None,
                     conditions: np.ndarray | None = None,
                     keep: float = CONDITION_KEEP, cells: np.ndarray | None = None,
                     covered_keep: float = COVERED_KEEP,
                     excitation: np.ndarray | None = None,
                     ranges: np.ndarray | None = None,
                     motion: np.ndarray | None = None) -> ValidationSplit:
    """Choose whole maneuvers for validation.

    Parameters
    ----------
    maneuvers : ndarray, shape (N,)
        Maneuver id per sample.
    fraction : float
        Fraction of the maneuvers held out (``round(fraction * n)``, at least one; at
        least one left), apportioned to the ``groups`` in proportion to their sizes
        (largest remainders); where the rules below refuse a group's, other maneuvers
        are taken instead. The draw never holds out the only maneuver of a group, nor
        the last one left for identification of a group of several: every kind of
        maneuver is identified on (when both of a course's two aileron pulses were held
        out, the lateral models had none, and Cn's validation R^2 was -16).
    seed : int
    groups : ndarray, shape (N,), optional
        A label per sample (e.g. the maneuver type); maneuvers are drawn in proportion
        within every group so that each kind of maneuver appears in both sets.
    conditions : ndarray, shape (N,), optional
        Flight-condition id per sample. A maneuver is held out only while its flight
        condition keeps at least ``keep`` of its samples for identification, so that every
        validation maneuver is flown where the model was identified (validation measures
        the model, not an extrapolation to a condition nobody flew). Where that leaves a
        group short, it gets fewer validation maneuvers.
    keep : float
        Fraction of each flight condition's samples that stays for identification.
    cells : ndarray of int, shape (N,), optional
        Envelope cell per sample (:meth:`~simplexspline.aero.selection.coverage.
        EnvelopeCells.cell`). A maneuver is held out only while at least ``covered_keep``
        of its samples lie in cells that keep enough identification samples
        (:func:`~simplexspline.aero.selection.coverage.threshold` of the whole data's
        cell counts): the data-driven form of ``conditions``, for records without a
        condition column.
    covered_keep : float
    excitation : ndarray, shape (N, k), optional
        Signals that the validation should see vary (the coefficients to be modelled).
        After the draw, a signal that no validation maneuver excites (its standard
        deviation within the maneuver below :data:`EXCITED` times the largest of any
        maneuver) gets the maneuver that excites it most among those that the other rules
        allow and that leave a maneuver exciting it at least half as much for
        identification. And no maneuver is held out that is the last in identification to
        excite a signal. A record of a few maneuvers of one kind each (a short period, a
        Dutch roll, a roll) otherwise validated its roll model on a pitch maneuver: R^2
        below zero, measuring the noise.

        A signal that the validation still does not excite (every exciting maneuver
        refused by the rules) is validated by leaving one out (``left_out``): the
        maneuver that moves it most. On a flight-test course whose elevator inputs were
        each the only data at their test points, Cm was validated on stationary
        measurements and turns (R^2 -0.5 to -7: the noise against a trim bias). Until
        stop 40 such a signal got a weaker maneuver held out for it alone (one of two
        elevator pulses at one test point): below the excitation level by construction
        (the draw takes the maneuvers that reach it), it took identification data and
        left the validation barely excited; the Cessna course's Cm models were 4.3x and
        6.2x the noise against the truth with it, 0.84x and 4.0x without it.
    ranges : ndarray, shape (N, m), optional
        Variables that a maneuver holds about constant and that change between maneuvers
        (the mass as fuel burns, the configuration): a maneuver is held out only while its
        values lie within the range of the maneuvers left for identification (NaN is
        ignored). The first and the last maneuver of a flight hold the extremes of the
        mass; a model that took the mass as a variable then met its validation outside its
        identified range, and the validation scored nothing (or an extrapolation).
    motion : ndarray, shape (N, m), optional
        The motions a maneuver makes (body rates, control deflections:
        :data:`~simplexspline.aero.variables.MOTION_VARIABLES`). A maneuver is held out
        only while, for every motion it makes (standard deviation within it at least
        :data:`EXCITED` times the largest of any maneuver), at least ``covered_keep`` of
        its samples lie in envelope ``cells`` (all in one without them) where the
        maneuvers left for identification that make the same motion keep enough samples
        (:func:`~simplexspline.aero.selection.coverage.threshold`). A model whose roll
        terms are scheduled on the Mach number knows them only where rolls were flown:
        on a flight-test course with one or two pulses per axis at each of six airspeeds,
        the only aileron pulse at the top speed was held out, and the lateral models,
        right elsewhere, met it with errors 8x its own variation (validation R^2 -18 to
        -108), an extrapolation that no identification data could have told apart.

    Returns
    -------
    ValidationSplit
    """
    maneuvers = np.asarray(maneuvers)
    if not 0.0 < fraction < 1.0:
        raise InputError(f"the validation fraction must be in (0, 1), got {fraction!r}")
    ids, first, counts = np.unique(maneuvers, return_index=True, return_counts=True)
    if len(ids) < 2:
        raise InputError(f"{len(ids)} maneuver(s) in the data: validation needs at least two "
                         "(one to identify on, one to validate on)")
    rng = np.random.default_rng(seed)
    labels = np.zeros(len(ids), dtype=int) if groups is None else np.unique(
        np.asarray(groups)[first], return_inverse=True)[1]
    if conditions is None:
        cond = np.arange(len(ids))
        room = counts.astype(float)
    else:
        cond = np.unique(np.asarray(conditions)[first], return_inverse=True)[1]
        room = (1.0 - keep) * np.bincount(cond, weights=counts)
    where = np.unique(maneuvers, return_inverse=True)[1]      # maneuver index per sample
    if cells is not None:
        cells = np.asarray(cells)
        left = np.bincount(cells).astype(float)          # identification samples per cell
        min_count = threshold(left)
        own = [np.bincount(cells[where == i], minlength=len(left)) for i in range(len(ids))]
    chosen = []
    spread, level = (None, None) if excitation is None else maneuver_spread(
        maneuvers, len(ids), np.asarray(excitation, dtype=float))
    low, high = (None, None) if ranges is None else _maneuver_ranges(
        maneuvers, len(ids), np.asarray(ranges, dtype=float))
    if motion is not None:
        moves, move_level = maneuver_spread(maneuvers, len(ids),
                                            np.asarray(motion, dtype=float))
        moves = moves >= move_level                          # (n_ids, m): motions made
        place = np.zeros(len(maneuvers), dtype=np.int64) if cells is None else cells
        own_cells = np.zeros((len(ids), int(place.max()) + 1))
        np.add.at(own_cells, (where, place), 1.0)

    sizes = np.bincount(labels)

    def allowed(i, held) -> bool:
        """Whether maneuver i may join ``held`` (maneuver ids) in the validation: its
        condition and cells allow it, identification keeps a maneuver exciting every signal
        that it excites, and one of its kind when the kind has several."""
        if counts[i] > room[cond[i]]:
            return False
        rest = ~np.isin(ids, held)           # the maneuvers identification would keep
        rest[i] = False
        if sizes[labels[i]] > 1 and not np.any(rest & (labels == labels[i])):
            return False
        if low is not None:
            if not rest.any() or np.any((low[i] < np.fmin.reduce(low[rest], axis=0))
                                        | (high[i] > np.fmax.reduce(high[rest], axis=0))):
                return False
        if spread is not None:
            moved = spread[i] >= level
            if np.any(moved & ~np.any(rest[:, None] & (spread >= level), axis=0)):
                return False
        if motion is not None:
            for j in np.flatnonzero(moves[i]):
                there = own_cells[rest & moves[:, j]].sum(axis=0)
                mine = own_cells[i]
                if mine[there >= threshold(there)].sum() < covered_keep * counts[i]:
                    return False
        if cells is not None:
            after = left - own[i]
            hit = own[i] > 0
            if own[i][hit & (after >= min_count)].sum() < covered_keep * counts[i]:
                return False
        return True

    def take(i) -> bool:
        """Hold maneuver i out if :func:`allowed`."""
        nonlocal left
        if not allowed(i, chosen):
            return False
        if cells is not None:
            left = left - own[i]
        room[cond[i]] -= counts[i]
        chosen.append(ids[i])
        return True

    quota = _quotas(sizes, fraction, rng)
    for g in np.unique(labels):
        members = np.flatnonzero(labels == g)
        taken = 0
        for i in rng.permutation(members):
            if taken == quota[g] or sizes[g] == 1:
                break
            taken += take(i)
    # what the rules refused in one kind is made up in the others, so that the validation
    # holds its fraction of the maneuvers wherever the rules allow; never the only
    # maneuver of a kind (a course's one Dutch roll): identification would not know it
    target = max(1, round(fraction * len(ids)))
    for i in rng.permutation(len(ids)):
        if len(chosen) >= target:
            break
        if ids[i] not in chosen and sizes[labels[i]] > 1:
            take(i)
    if not chosen:          # kinds of one maneuver each: one, where the rules allow
        if not any(take(i) for i in rng.permutation(len(ids))):
            chosen.append(rng.choice(ids))
    if spread is not None:
        _cover_excitation(ids, spread, level, chosen, take)
    chosen = set(chosen)
    if len(chosen) == len(ids):
        chosen.discard(next(iter(chosen)))
    chosen = list(chosen)
    left = () if spread is None else _left_out(ids, spread, level, chosen)
    return ValidationSplit(np.isin(maneuvers, chosen), left)


def _quotas(sizes: np.ndarray, fraction: float, rng: np.random.Generator) -> np.ndarray:
    """Maneuvers to hold out per group (``sizes``: maneuvers per group): the
    largest-remainder apportionment of ``round(fraction * n)`` (at least one) in proportion
    to the groups' sizes, equal remainders in random order. Rounding each group on its own
    held out none of a group of two (``round(0.5) == 0``): six kinds of two maneuvers held
    out one of the twelve (the fallback's), and 40-maneuver campaigns drew 11-12
    instead of 10."""
    n = int(sizes.sum())
    total = max(1, round(fraction * n))
    share = sizes * total / n
    quota = np.floor(share).astype(int)
    order = np.lexsort((rng.random(len(sizes)), -(share - quota)))
    quota[order[:total - int(quota.sum())]] += 1
    return np.minimum(quota, sizes)


def maneuver_spread(maneuvers: np.ndarray, n_ids: int, signals: np.ndarray) -> tuple:
    """Standard deviation of every signal within every maneuver, shape (n_ids, k) (-inf
    where fewer than two finite samples), and the level that counts as excited per signal
    (:data:`EXCITED` times the largest; infinite for a signal no maneuver moves)."""
    signals = signals.reshape(len(maneuvers), -1)
    where = np.unique(maneuvers, return_inverse=True)[1]
    spread = np.full((n_ids, signals.shape[1]), np.nan)
    for j in range(signals.shape[1]):
        ok = np.isfinite(signals[:, j])
        x, w = signals[ok, j], where[ok]
        count = np.bincount(w, minlength=n_ids)
        with np.errstate(divide="ignore", invalid="ignore"):
            mean = np.bincount(w, x, minlength=n_ids) / count
            var = np.bincount(w, (x - mean[w]) ** 2, minlength=n_ids) / count
        spread[:, j] = np.where(count > 1, np.sqrt(var), np.nan)
    level = np.full(signals.shape[1], np.inf)
    for j in range(signals.shape[1]):
        finite = spread[:, j][np.isfinite(spread[:, j])]
        if finite.size and finite.max() > 0:
            level[j] = EXCITED * float(finite.max())
    return np.nan_to_num(spread, nan=-np.inf), level


def _maneuver_ranges(maneuvers: np.ndarray, n_ids: int, values: np.ndarray) -> tuple:
    """Smallest and largest finite value of every column within every maneuver, shapes
    (n_ids, m) (NaN where a maneuver has none)."""
    values = values.reshape(len(maneuvers), -1)
    where = np.unique(maneuvers, return_inverse=True)[1]
    low = np.full((n_ids, values.shape[1]), np.inf)
    high = np.full((n_ids, values.shape[1]), -np.inf)
    for j in range(values.shape[1]):
        ok = np.isfinite(values[:, j])
        np.minimum.at(low[:, j], where[ok], values[ok, j])
        np.maximum.at(high[:, j], where[ok], values[ok, j])
    none = ~np.isfinite(low)
    low[none], high[none] = np.nan, np.nan
    return low, high


def _cover_excitation(ids: np.ndarray, spread: np.ndarray, level: np.ndarray, chosen: list,
                      take) -> None:
    """Add to ``chosen`` (maneuver ids), for every signal that no chosen maneuver excites,
    the maneuver that excites it most and that ``take`` allows, keeping one at least half
    as exciting for identification (:func:`split_by_maneuver`, ``excitation``)."""
    for j in range(spread.shape[1]):
        col = spread[:, j]
        held = np.isin(ids, chosen)
        if not np.isfinite(level[j]) or np.any(held & (col >= level[j])):
            continue
        for i in np.argsort(-col):
            if held[i] or not col[i] >= level[j]:
                continue
            rest = ~held
            rest[i] = False
            if rest.sum() < 2 or col[rest].max() < 0.5 * col[i]:
                continue
            if take(i):
                break


def _left_out(ids: np.ndarray, spread: np.ndarray, level: np.ndarray,
              chosen: list) -> tuple:
    """Per signal, the identification maneuver validated by leaving it out, or None
    (:class:`ValidationSplit`, ``left_out``)."""
    held = np.isin(ids, chosen)
    out = []
    for j in range(spread.shape[1]):
        col = spread[:, j]
        pick = None
        rest = np.flatnonzero(~held)
        # not excited in validation: the maneuver that moves it most is not held out
        if np.isfinite(level[j]) and not np.any(held & (col >= level[j])) \
                and len(rest) >= 2:
            i = rest[np.argmax(col[rest])]
            pick = ids[i].item() if hasattr(ids[i], "item") else ids[i]
        out.append(pick)
    return tuple(out)


def fold_by_maneuver(maneuvers: np.ndarray, k: int, *, seed: int = 0,
                     conditions: np.ndarray | None = None,
                     excitation: np.ndarray | None = None) -> np.ndarray:
    """Fold number (0..k-1) per sample, whole maneuvers per fold (shuffled, balanced by
    sample count).

    With ``conditions`` (flight-condition id per sample) each condition's maneuvers are
    spread over the folds, largest first, so that holding out a fold leaves most flight
    conditions flown in the training folds (as :func:`split_by_maneuver` does for the
    validation set).

    With ``excitation`` (the coefficient, shape (N,)), when the folds drawn so put every
    maneuver that moves it (within-maneuver standard deviation at least
    :data:`FOLD_EXCITED` times the largest) into one fold, the folds are drawn again with
    those maneuvers dealt out first, one fold after the other, most moving first. A fold
    whose training folds hold none of them cannot tell any structure's dynamic terms
    apart: on a still-air course the one elevator pulse and the one doublet fell into
    one of three folds, every candidate pitching-moment model missed the held-out
    doublet by 0.75 of its own variation, and the search dropped the elevator and the
    pitch rate from the model. Where the exciting maneuvers already fall into more than
    one fold, the folds are those drawn without it.
    """
    maneuvers = np.asarray(maneuvers)
    ids, first, inverse, counts = np.unique(maneuvers, return_index=True,
                                            return_inverse=True, return_counts=True)
    if k < 2 or len(ids) < k:
        raise InputError(f"{k}-fold cross-validation needs at least {k} maneuvers, the "
                         f"identification set has {len(ids)}")
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(ids))
    order = order[np.argsort(-counts[order], kind="stable")]
    cond = None if conditions is None else np.unique(np.asarray(conditions)[first],
                                                     return_inverse=True)[1]
    fold_of = _deal(order, counts, k, cond)
    if excitation is not None:
        spread = maneuver_spread(maneuvers, len(ids),
                                 np.asarray(excitation, dtype=float))[0][:, 0]
        top = float(spread.max())
        moving = np.flatnonzero(spread >= FOLD_EXCITED * top) if top > 0 else []
        if len(moving) > 1 and len(np.unique(fold_of[moving])) == 1:
            first_dealt = moving[np.argsort(-spread[moving], kind="stable")]
            rest = order[~np.isin(order, first_dealt)]
            fold_of = _deal(np.concatenate([first_dealt, rest]), counts, k, cond,
                            dealt=len(first_dealt))
    return fold_of[inverse]


def _deal(order: np.ndarray, counts: np.ndarray, k: int, cond: np.ndarray | None,
          dealt: int = 0) -> np.ndarray:
    """Fold per maneuver (index into ``counts``), in ``order``: the first ``dealt`` one
    per fold in turn, the others to the fold holding least of their condition (ties to
    the least loaded fold; the least loaded without conditions)."""
    load = np.zeros(k)
    fold_of = np.empty(len(counts), dtype=int)
    used = None if cond is None else np.zeros((cond.max() + 1, k))
    for n, i in enumerate(order):
        if n < dealt:
            f = n % k
        elif used is None:
            f = int(np.argmin(load))
        else:
            f = int(np.lexsort((load, used[cond[i]]))[0])
        fold_of[i] = f
        load[f] += counts[i]
        if used is not None:
            used[cond[i], f] += counts[i]
    return fold_of


def covered_in_fold(folds: np.ndarray, conditions: np.ndarray,
                    keep: float = CONDITION_KEEP) -> np.ndarray:
    """Samples whose flight condition keeps at least ``keep`` of its samples in the other
    folds: the held-out samples a cross-validation scores, so that it measures the model
    where it was identified, as the validation split does (see
    :func:`split_by_maneuver`).

    Parameters
    ----------
    folds : ndarray of int, shape (N,)
    conditions : ndarray, shape (N,)
        Flight-condition id per sample.
    keep : float

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    folds = np.asarray(folds)
    cond = np.unique(np.asarray(conditions), return_inverse=True)[1]
    table = np.zeros((cond.max() + 1, folds.max() + 1))
    np.add.at(table, (cond, folds), 1.0)
    total = table.sum(axis=1)
    return total[cond] - table[cond, folds] >= keep * total[cond]


def autocorrelation(residual: np.ndarray, maneuvers: np.ndarray | None = None,
                    max_lag: int = 50) -> np.ndarray:
    """Normalised residual autocorrelation at lags 0..max_lag (within maneuvers)."""
    e = np.asarray(residual, dtype=float)
    e = e - e.mean()
    m = np.zeros(len(e), dtype=int) if maneuvers is None else np.asarray(maneuvers)
    var = float(np.dot(e, e))
    out = np.zeros(max_lag + 1)
    if var == 0.0:
        out[0] = 1.0
        return out
    same = np.ones(len(e), dtype=bool)
    for lag in range(max_lag + 1):
        if lag:
            same = m[lag:] == m[:-lag]
            out[lag] = float(np.dot(e[lag:][same], e[:-lag][same])) / var
        else:
            out[0] = 1.0
    return out


def scores(measured: np.ndarray, model: np.ndarray, *, truth: np.ndarray | None = None,
           maneuvers: np.ndarray | None = None, max_lag: int = 50,
           truth_model: np.ndarray | None = None) -> dict:
    """Validation scores of a model output against measurements (and the truth).

    Parameters
    ----------
    measured, model : ndarray, shape (N,)
        Measured coefficient and model prediction.
    truth : ndarray, shape (N,), optional
        True coefficient (simulated data).
    maneuvers : ndarray, shape (N,), optional
        For the residual autocorrelation (lags do not cross maneuvers).
    truth_model : ndarray, shape (N,), optional
        The model's prediction to judge against ``truth`` when it differs from the one
        against the measurements (``model``): a measurement that smooths the coefficient
        is predicted from regressors smoothed alike, the truth from the instantaneous ones
        (:func:`~simplexspline.aero.data.differentiation.matched_by_maneuver`).

    Returns
    -------
    dict
        ``n``, ``rms``, ``rrms`` (RMS / range of the measured coefficient, a fraction),
        ``r2``, ``bias``, ``max_abs``, ``autocorrelation`` (list, lags 0..max_lag),
        ``whiteness`` (fraction of lags 1..max_lag inside the 95 % band); with ``truth``
        also ``rms_true``, ``rrms_true`` (model vs truth), ``noise_rms`` (measured vs truth)
        and ``rms_true_over_noise``.
    """
    y = np.asarray(measured, dtype=float)
    yhat = np.asarray(model, dtype=float)
    if y.shape != yhat.shape or y.ndim != 1:
        raise InputError(f"measured and model must be 1-D of equal length, got {y.shape} and "
                         f"{yhat.shape}")
    if len(y) == 0:
        raise InputError("no validation samples: the validation set is empty")
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(yhat))):
        raise InputError("NaN or inf in the measured or modelled values")
    e = y - yhat
    rng = float(y.max() - y.min())
    rms = float(np.sqrt(np.mean(e * e)))
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    ac = autocorrelation(e, maneuvers, max_lag)
    band = 1.96 / np.sqrt(len(e))
    out = {
        "n": len(y), "rms": rms, "rrms": rms / rng if rng > 0 else float("nan"),
        "r2": 1.0 - float(np.sum(e * e)) / ss_tot if ss_tot > 0 else float("nan"),
        "bias": float(e.mean()), "max_abs": float(np.abs(e).max()), "range": rng,
        "autocorrelation": ac.tolist(),
        "whiteness": float(np.mean(np.abs(ac[1:]) < band)) if max_lag else 1.0,
    }
    if truth is not None:
        t = np.asarray(truth, dtype=float)
        at = yhat if truth_model is None else np.asarray(truth_model, dtype=float)
        if t.shape != y.shape or at.shape != y.shape:
            raise InputError("truth (and truth_model) must have the shape of measured")
        et = t - at
        rms_t = float(np.sqrt(np.mean(et * et)))
        noise = float(np.sqrt(np.mean((y - t) ** 2)))
        out.update(rms_true=rms_t, rrms_true=rms_t / rng if rng > 0 else float("nan"),
                   noise_rms=noise,
                   rms_true_over_noise=rms_t / noise if noise > 0 else float("inf"))
    return out


def scores_by_coverage(measured: np.ndarray, model: np.ndarray, covered: np.ndarray, *,
                       truth: np.ndarray | None = None,
                       maneuvers: np.ndarray | None = None,
                       truth_model: np.ndarray | None = None) -> dict:
    """:func:`scores` on the samples inside the identification data's envelope, and the
    same on the rest under ``'outside'``: an extrapolation is judged apart from the fit.

    Parameters
    ----------
    measured, model : ndarray, shape (N,)
    covered : ndarray of bool, shape (N,)
        Samples inside the coverage (:mod:`simplexspline.aero.selection.coverage`).
    truth, maneuvers, truth_model : ndarray, shape (N,), optional
        As in :func:`scores`.

    Returns
    -------
    dict
        The scores of the covered samples (of all samples when none is covered), with
        ``coverage`` (fraction of covered samples) and, when some are not covered,
        ``outside``: their scores (no autocorrelation) and ``maneuvers`` (maneuver ->
        fraction of its samples outside).
    """
    covered = np.asarray(covered, dtype=bool)
    y, yhat = np.asarray(measured, dtype=float), np.asarray(model, dtype=float)
    if covered.shape != y.shape:
        raise InputError(f"covered must have the shape of measured {y.shape}, got "
                         f"{covered.shape}")
    man = np.zeros(len(y), dtype=int) if maneuvers is None else np.asarray(maneuvers)
    inside = covered if covered.any() else np.ones(len(y), dtype=bool)

    def part(mask, max_lag=50):
        return scores(y[mask], yhat[mask], truth=None if truth is None
                      else np.asarray(truth, dtype=float)[mask], maneuvers=man[mask],
                      max_lag=max_lag, truth_model=None if truth_model is None
                      else np.asarray(truth_model, dtype=float)[mask])

    out = part(inside)
    out["coverage"] = float(covered.mean())
    rest = ~inside
    if rest.any():
        o = part(rest, max_lag=0)
        o.pop("autocorrelation")
        ids, n = np.unique(man[rest], return_counts=True)
        total = dict(zip(*np.unique(man, return_counts=True)))
        o["maneuvers"] = {(int(m) if np.issubdtype(type(m), np.integer) else str(m)):
                          round(int(k) / int(total[m]), 3) for m, k in zip(ids, n)}
        out["outside"] = o
    return out
