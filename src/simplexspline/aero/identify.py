"""Global aerodynamic model identification, end to end (the paper's Section IV).

flight data -> reconstruction (when the table holds raw sensor channels) -> coefficients
-> identification / validation split by maneuver -> model structure per coefficient
(preset or automatic selection) -> fit on all identification data -> validation scores
(RMS, relative RMS, R^2, residual autocorrelation, error against the truth when known)
-> report.
"""

from __future__ import annotations

import hashlib
import math
import json
import os
import contextlib
import shutil
import time
import warnings
from collections.abc import Callable, Mapping
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from simplexspline.aero.data.angle_rates import ANGLE_RATE_NAMES, angle_rates
from simplexspline.aero.data.differentiation import matched_by_maneuver
from simplexspline.aero.derivatives.jackknife import (
    FOLD_DIR,
    MIN_FOLDS,
    jackknife_derivatives,
    primary_derivatives,
)
from simplexspline.aero.derivatives.stability import reference_conditions
from simplexspline.aero.data.flight_data import without_metadata
from simplexspline.aero.data.thrust_coefficient import (
    FAN_SPEED_THRUST_COEFFICIENT,
    FUEL_FLOW_THRUST_COEFFICIENT,
    THRUST_COEFFICIENT,
    thrust_coefficient,
)
from simplexspline.aero.modelling.auto import linear_start, restrict_to_data
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.aero.selection.search import (
    SelectionSettings,
    Trial,
    SearchCache,
    choose_prior_degree,
    cv_scored_share,
    fit_structure,
    select_structure,
)
from simplexspline.aero.modelling.presets import preset
from simplexspline.aero.modelling.structure import multiplier_values, Structure
from simplexspline.aero.selection.coverage import EnvelopeCells, search_cells
from simplexspline.aero.selection.side_force_sideslip import REFEREE_GAIN, choose_sideslip
from simplexspline.aero.selection.diagnostics import collinearity, excitation
from simplexspline.aero.variables import (
    COEFFICIENTS,
    ENVELOPE_VARIABLES,
    FLOW_ANGLES,
    MOTION_VARIABLES,
    TEST_POINT_VARIABLES,
)
from simplexspline.aero.selection.validation import (
    PAPER_TABLE2,
    fold_by_maneuver,
    maneuver_spread,
    scores,
    scores_by_coverage,
    subsample_step,
    validation_split,
)
from simplexspline._files import jsonable, locked, remove_stale, temp_dir
from simplexspline._compute_slots import busy_seconds, compute_slot, init_worker
from simplexspline._workers import process_context
from simplexspline._version import __version__
from simplexspline.errors import FlightDataError, InputError, SimplexSplineError
from simplexspline.aero.report.page import write_report
from simplexspline.aero.reconstruction.reconstruct import reconstruct
from simplexspline.aero.reconstruction.sensor_corrections import lever_arm_acceleration
from simplexspline.spline import kernels

__all__ = [
    "OUTPUT_ENTRIES",
    "OUTPUT_MARKER",
    "CoefficientResult",
    "Identification",
    "IdentificationSettings",
    "ThinDataWarning",
    "check_output_dir",
    "identify",
]

#: Folds of identification maneuvers of the derivatives' jackknife standard errors
#: (:attr:`IdentificationSettings.derivative_folds`).
DERIVATIVE_FOLDS = 5

#: Columns that identify data as already reconstructed (coefficients present).
_RECONSTRUCTED = ("CX", "CY", "CZ", "Cl", "Cm", "Cn", "phat", "qhat", "rhat")
#: Air data the reconstruction writes besides: a structure may name them before they exist
#: (the sideslip of a record without a vane); the check after the reconstruction has the
#: last word.
_RECONSTRUCTED_AIR_DATA = ("alpha", "beta", "tas")
#: The coefficients whose measurements hold the differentiated angular accelerations.
MOMENT_COEFFICIENTS = ("Cl", "Cm", "Cn")


class ThinDataWarning(UserWarning):
    """A model has simplices holding too few identification samples."""


@dataclass(frozen=True)
class IdentificationSettings:
    """Settings of :func:`identify`.

    Parameters
    ----------
    coefficients : tuple of str
        Coefficients to model (default all six, CX..Cn).
    preset : {'auto', 'paper', 'varying', 'f16'}
        Where the starting structures come from (see
        :func:`~simplexspline.aero.modelling.presets.preset`): 'auto' (default) starts
        from knowledge-free structures; the others carry prior knowledge.
    structures : dict of str to Structure, optional
        Starting (or fixed) structures overriding the preset's.
    select : bool
        Run the automatic structure selection from the starting structures.
    selection : SelectionSettings
    validation_fraction : float
        Fraction of the maneuvers held out for validation (drawn within every maneuver
        type).
    seed : int
        Seed of the split and the folds.
    split_motion : bool
        Hold a maneuver out for validation only where identification keeps maneuvers
        making the same motions (rates, controls) in its envelope cells
        (:func:`~simplexspline.aero.selection.validation.split_by_maneuver`, ``motion``).
        Off by default: on a still-air flight-test course it kept the only aileron pulse
        at the top airspeed for identification (lateral validation R^2 -37/-18/-108 ->
        -6.7/-0.66/-5.4), but the generalization benchmark's draws moved with it (83 of 96
        models on target against 88; the c172p's Cm search lost its thrust scheduling on
        the new identification set, 0.80 -> 4.26 x the noise) and the Cessna course's
        roll model did worse on its new draw (docs/identification.md, step 2).
    reconstruct : {'auto', 'always', 'never'}
        Flight path reconstruction: 'auto' runs it unless the table already has the
        coefficient columns ``CX..Cn`` and ``phat, qhat, rhat``.
    workers : int or None
        Processes for the reconstruction and for the coefficients' searches and fits
        (None: all CPUs; 1: everything in this process).
    thin_factor : float
        A simplex is reported as thinly covered when it holds fewer than
        ``thin_factor * d_hat`` identification samples.
    derivative_folds : int
        Folds of identification maneuvers for the jackknife standard errors of the
        derivatives at the reference condition
        (:mod:`~simplexspline.aero.derivatives.jackknife`): each model's structure is
        identified again without each fold (fewer folds with fewer maneuvers; 0: no
        standard errors).
    matched_regressors : bool
        Where the angular accelerations were differentiated from rates sampled coarser
        than the simulator's step (a 10 Hz record), search and fit the moment coefficients
        on regressors smoothed as the derivative smoothed the moments
        (:func:`_matched_differentiation`); the models are judged against a truth at the
        instantaneous regressors. Off by default: exact where the moment is linear in its
        terms (on 10 Hz elevator pulses Cm_de -1.2000 against -1.134 without), and on a
        simulated 10 Hz T37 course a linear Cm's pitch damping and elevator power came out
        closer to the truth (Cm_q -30.2 -> -40.2, Cm_de -0.58 -> -0.73; from the true
        coefficients -43.0, -0.82), but on the 14 flight-test courses of
        ``bench_courses.py`` the searched models were not closer to the truth (geometric
        mean of RMS vs truth / noise 1.619 -> 1.635; Cl and Cn closer in 7 of the 8 that
        moved by more than 10 %, Cm farther in all 6; docs/reconstruction.md, "Angular
        accelerations").
    """

    coefficients: tuple = COEFFICIENTS
    preset: str = "auto"
    structures: Mapping | None = None
    select: bool = True
    selection: SelectionSettings = field(default_factory=SelectionSettings)
    validation_fraction: float = 0.25
    seed: int = 0
    split_motion: bool = False
    reconstruct: str = "auto"
    workers: int | None = None
    thin_factor: float = 2.0
    derivative_folds: int = DERIVATIVE_FOLDS
    matched_regressors: bool = False

    def __post_init__(self):
        unknown = [c for c in self.coefficients if c not in COEFFICIENTS]
        if unknown or not self.coefficients:
            raise InputError(f"unknown coefficient(s) {unknown or '(none given)'}; known: "
                             f"{list(COEFFICIENTS)}")
        if self.reconstruct not in ("auto", "always", "never"):
            raise InputError("reconstruct must be 'auto', 'always' or 'never', got "
                             f"{self.reconstruct!r}")
        preset(self.preset)  # validates the name
        if not 0.0 < self.validation_fraction < 1.0:
            raise InputError("validation_fraction must be in (0, 1), got "
                             f"{self.validation_fraction!r}")
        if not (isinstance(self.thin_factor, (int, float)) and math.isfinite(self.thin_factor)
                and self.thin_factor >= 0):
            raise InputError(f"thin_factor must be a finite number >= 0, got "
                             f"{self.thin_factor!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) \
                or not 0 <= self.seed < 2**32:
            raise InputError(f"seed must be an integer between 0 and {2**32 - 1}, got "
                             f"{self.seed!r}")
        if isinstance(self.derivative_folds, bool) \
                or not isinstance(self.derivative_folds, (int, np.integer)) \
                or self.derivative_folds < 0 or self.derivative_folds == 1:
            raise InputError("derivative_folds must be 0 (no standard errors) or an integer "
                             f">= 2, got {self.derivative_folds!r}")
        if self.workers is not None and (isinstance(self.workers, bool)
                                         or not isinstance(self.workers, (int, np.integer))
                                         or self.workers < 1):
            raise InputError(f"workers must be an integer >= 1 or None, got {self.workers!r}")
        if not isinstance(self.matched_regressors, (bool, np.bool_)):
            raise InputError("matched_regressors must be true or false, got "
                             f"{self.matched_regressors!r}")

    def starting_structures(self) -> dict:
        base = preset(self.preset)
        if self.structures:
            base.update(self.structures)
        return {c: base[c] for c in self.coefficients}

    def to_dict(self) -> dict:
        return {
            "coefficients": list(self.coefficients), "preset": self.preset,
            "structures": {c: s.to_dict() for c, s in self.starting_structures().items()},
            "select": self.select, "selection": self.selection.to_dict(),
            "validation_fraction": self.validation_fraction, "seed": self.seed,
            "split_motion": self.split_motion,
            "reconstruct": self.reconstruct, "thin_factor": self.thin_factor,
            "derivative_folds": self.derivative_folds,
            "matched_regressors": self.matched_regressors,
        }


@dataclass
class CoefficientResult:
    """The identified model of one coefficient and its scores.

    Attributes
    ----------
    model : AeroModel
    validation : dict
        :func:`~simplexspline.aero.selection.validation.scores` on the validation maneuvers.
    identification : dict
        The same on the identification data (fit quality).
    history : list of Trial
        Structures tried by the selection (only the start when selection is off).
    counts : ndarray of int, shape (J,)
        Identification samples per simplex.
    thin : ndarray of int
        Simplices holding fewer than ``thin_factor * d_hat`` samples.
    seconds : float
        Wall time of selection + fit.
    diagnostics : dict
        ``excitation`` (:func:`~simplexspline.aero.selection.diagnostics.excitation` of
        the validation data) and ``collinearity`` (per input variable: VIF, most
        correlated partner, standard error of its linear derivative).
    fold_models : list of AeroModel or None
        The structure identified again without each fold of identification maneuvers
        (None where that fit failed), for the derivatives' jackknife
        (:attr:`IdentificationSettings.derivative_folds`; empty without it).
    """

    model: AeroModel
    validation: dict
    identification: dict
    history: list
    counts: np.ndarray
    thin: np.ndarray
    seconds: float = 0.0
    diagnostics: dict = field(default_factory=dict)
    fold_models: list = field(default_factory=list)

    @property
    def structure(self) -> Structure:
        return self.model.structure


@dataclass
class Identification:
    """The result of :func:`identify`.

    Attributes
    ----------
    results : dict of str to CoefficientResult
    identification, validation : pandas.DataFrame
        The coefficient data (reconstructed when needed) split by maneuver, with the model
        outputs ``model_<C>``, ``inside_<C>`` (bool: inside the envelope and inside the
        model's identified box, where its scores count) and ``inside_envelope`` (bool:
        the sample lies in an envelope cell the identification data cover) added to
        ``validation``.
    settings : IdentificationSettings
    metadata : dict
        Flight-data metadata.
    provenance : dict
        Input hash, package version, times, reconstruction summary.
    warnings : list of str
    left_out_validation : dict of str to maneuver id
        Coefficients that the validation maneuvers barely excite, and the identification
        maneuver that excites each most
        (``ValidationSplit.left_out``): a model of the same structure identified without
        it predicts it, and the validation scores hold that prediction
        (``validation['left_out']``); the delivered model is identified on it.
    derivatives : pandas.DataFrame or None
        The models' derivatives at the reference condition (the identification data's
        medians) with their maneuver-jackknife standard errors
        (:func:`~simplexspline.aero.derivatives.jackknife.jackknife_derivatives`); None
        with ``derivative_folds = 0`` or too few maneuvers.
    """

    results: dict
    identification: object
    validation: object
    settings: IdentificationSettings
    metadata: dict
    provenance: dict
    warnings: list = field(default_factory=list)
    left_out_validation: dict = field(default_factory=dict)
    derivatives: object = None

    @property
    def has_truth(self) -> bool:
        return all(f"true_{c}" in self.validation.columns for c in self.results)

    def table(self) -> str:
        """The Table-2 style validation table (plain text): scores on the validation
        samples inside the identification data's envelope (``inside``: their share)."""
        head = (f"{'model':<44} {'simplices':>9} {'RMS':>10} {'rel. RMS':>9} {'R2':>7} "
                f"{'paper':>7} {'inside':>7}")
        if self.has_truth:
            head += f" {'RMS true':>10} {'rel. true':>9} {'noise RMS':>10}"
        lines = [head, "-" * len(head)]
        for c, res in self.results.items():
            v = res.validation
            paper = PAPER_TABLE2.get(c)
            line = (f"{res.structure.label():<44} {res.model.spline.triangulation.nsimplex:>9d}"
                    f" {v['rms']:>10.3e} {100 * v['rrms']:>8.2f}% {v['r2']:>7.4f} "
                    f"{'' if paper is None else f'{100 * paper:.2f}%':>7}"
                    f" {100 * v.get('coverage', 1.0):>6.1f}%")
            if self.has_truth:
                line += (f" {v['rms_true']:>10.3e} {100 * v['rrms_true']:>8.3f}%"
                         f" {v['noise_rms']:>10.3e}")
            lines.append(line)
        return "\n".join(lines)

    def derivative_table(self) -> str:
        """The primary derivatives at the reference condition with their jackknife standard
        errors (plain text; '' without them)."""
        if self.derivatives is None:
            return ""
        rows = primary_derivatives(self.derivatives)
        if rows.empty:
            return ""
        lines = [f"derivatives at the reference condition (identification-data medians), "
                 f"+- jackknife standard error over {self.derivatives.attrs['folds']} folds "
                 f"of maneuvers:"]
        lines += [f"  {n:<10} {r.value:>+10.4g} +- {r.standard_error:<9.2g} {r.unit}"
                  for n, r in rows.iterrows()]
        return "\n".join(lines)

    def summary(self) -> dict:
        """The content of ``summary.json``."""
        out = {"format": "simplexspline.identification", "version": 1,
               "aircraft": self.metadata.get("aircraft"),
               "provenance": self.provenance,
               "settings": self.settings.to_dict(),
               "identification_maneuvers": sorted(
                   int(m) for m in np.unique(self.identification["maneuver"])),
               "validation_maneuvers": sorted(
                   int(m) for m in np.unique(self.validation["maneuver"])),
               "left_out_validation_maneuvers": {c: int(m) for c, m in
                                                 self.left_out_validation.items()},
               "warnings": list(self.warnings),
               "coefficients": {}}
        for c, res in self.results.items():
            v = res.validation
            entry = {"structure": res.structure.to_dict(), "label": res.structure.label(),
                     "nsimplex": int(res.model.spline.triangulation.nsimplex),
                     "ncoefficients": int(res.model.spline.coefficients.size),
                     "rms": v["rms"], "rrms": v["rrms"], "r2": v["r2"], "n": v["n"],
                     "whiteness": v["whiteness"],
                     "identification": {k: res.identification[k]
                                        for k in ("rms", "rrms", "r2", "n")},
                     "thin_simplices": len(res.thin),
                     "paper_rrms": PAPER_TABLE2.get(c),
                     "seconds": round(res.seconds, 3),
                     "selection": [t.to_dict() for t in res.history]}
            for k in ("rms_true", "rrms_true", "noise_rms", "rms_true_over_noise",
                      "coverage", "outside", "left_out", "shared"):
                if k in v:
                    entry[k] = v[k]
            if res.diagnostics:
                entry["diagnostics"] = res.diagnostics
            out["coefficients"][c] = entry
        if self.derivatives is not None:
            table = self.derivatives
            out["derivatives"] = {
                "reference": table.attrs["reference"], "folds": table.attrs["folds"],
                "method": "delete-a-group jackknife over folds of identification maneuvers",
                "values": {n: {"coefficient": r.coefficient, "variable": r.variable,
                               "unit": r.unit, "in_model": bool(r.in_model),
                               "value": r.value, "standard_error": r.standard_error,
                               "folds": int(r.folds), "fold_values": list(r.fold_values)}
                           for n, r in table.iterrows()}}
        return out

    def save(self, outdir, *, report: bool = True, model_format: str = "json",
             progress: Callable[[str], None] | None = None, overwrite: bool = False) -> Path:
        """Write ``summary.json``, ``models/<C>.json`` and (optionally) ``report.html`` +
        ``report.md`` with figures to ``outdir``.

        Only the project's own entries (:data:`OUTPUT_ENTRIES`) are written or replaced;
        other files in ``outdir`` are never touched. Everything is first written to a
        temporary directory inside ``outdir`` and moved into place at the end, so a failure
        leaves the previous results as they were (and no new directory).

        Parameters
        ----------
        overwrite : bool, default False
            Write into a non-empty directory that is not a previous output (one without
            the :data:`OUTPUT_MARKER` file). Its other files are kept.

        Raises
        ------
        InputError
            ``outdir`` is a file, its parent does not exist, or it holds other files and
            ``overwrite`` is False (see :func:`check_output_dir`).
        """
        outdir = Path(outdir)
        if model_format not in ("json", "npz"):
            raise InputError(f"model_format must be 'json' or 'npz', got {model_format!r}")
        check_output_dir(outdir, overwrite=overwrite)
        try:
            outdir.mkdir()
            created = True
        except FileExistsError:
            created = False
        remove_stale(outdir, ".identify.*")       # left by a killed run
        try:
            with temp_dir(outdir, ".identify.", ".tmp") as tmp:
                (tmp / "models").mkdir()
                for c, res in self.results.items():
                    res.model.save(tmp / "models" / f"{c}.{model_format}")
                    # the jackknife's refits: the derivatives command's standard errors
                    for f, fold in enumerate(res.fold_models):
                        if fold is not None:
                            (tmp / "models" / FOLD_DIR).mkdir(exist_ok=True)
                            fold.save(tmp / "models" / FOLD_DIR / f"{c}-{f}.{model_format}")
                (tmp / "summary.json").write_text(
                    json.dumps(jsonable(self.summary()), indent=1, allow_nan=True) + "\n",
                    encoding="utf-8")
                if report:
                    write_report(self, tmp, progress=progress)
                (tmp / OUTPUT_MARKER).write_text(json.dumps(
                    {"format": "simplexspline.identification", "version": 1}) + "\n")
                _move_entries(tmp, outdir)
        except BaseException:
            if created:
                with contextlib.suppress(OSError):
                    outdir.rmdir()                # only when nothing else was put there
            raise
        return outdir


#: The file that marks a directory as an identification output (a previous run's).
OUTPUT_MARKER = ".simplexspline-identification"

#: The entries an identification output consists of; nothing else in it is touched.
OUTPUT_ENTRIES = (OUTPUT_MARKER, "models", "figures", "summary.json", "report.html",
                  "report.md")


def check_output_dir(outdir, *, overwrite: bool = False) -> Path:
    """Check, before any work, that identification results may be written to ``outdir``.

    A new directory, an empty one or a previous output (with :data:`OUTPUT_MARKER`) is
    fine; a directory holding other files only with ``overwrite`` (their files are kept).

    Raises
    ------
    InputError
        Naming the problem and what to do.
    """
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise InputError(f"output {str(outdir)!r} exists and is not a directory")
    if not outdir.resolve().parent.is_dir():
        raise InputError(f"the parent directory of output {str(outdir)!r} does not exist")
    if outdir.is_dir() and not overwrite and not (outdir / OUTPUT_MARKER).is_file():
        others = sorted(p.name for p in outdir.iterdir() if not p.name.startswith(".identify."))
        if others:
            shown = ", ".join(others[:3]) + (", ..." if len(others) > 3 else "")
            raise InputError(
                f"output directory {str(outdir)!r} holds files that are not a previous "
                f"identification output ({shown}): choose a new or empty directory, or "
                "pass --overwrite (overwrite=True) to write the results beside them")
    return outdir


def _move_entries(new: Path, outdir: Path) -> None:
    """Replace the output entries of ``outdir`` by those of ``new`` (both in one file
    system); previous entries the new output does not have are removed (they are ours)."""
    with locked(outdir), temp_dir(outdir, ".identify.", ".old") as trash:
        _swap_entries(new, outdir, trash)      # concurrent saves take turns: one whole wins


def _swap_entries(new: Path, outdir: Path, trash: Path) -> None:
    """Move our entries of ``outdir`` to ``trash`` and those of ``new`` in; on failure put
    the previous ones back."""
    moved: list = []
    try:
        for name in reversed(OUTPUT_ENTRIES):          # the marker last
            if (outdir / name).exists() or (outdir / name).is_symlink():
                os.replace(outdir / name, trash / name)
            moved.append(name)
            if (new / name).exists():
                os.replace(new / name, outdir / name)
    except BaseException:
        for name in moved:                              # put the previous output back
            target = outdir / name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            elif target.exists() or target.is_symlink():
                target.unlink()
            if (trash / name).exists() or (trash / name).is_symlink():
                os.replace(trash / name, target)
        raise


def file_hash(path) -> str:
    """SHA-256 of a file (provenance)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return "sha256:" + h.hexdigest()


def _coefficient_data(df, meta: dict, settings: IdentificationSettings, progress: bool,
                      log: Callable[[str], None]):
    """Reconstruct when needed; return (table with coefficients, reconstruction note)."""
    have = all(c in df.columns for c in _RECONSTRUCTED)
    if settings.reconstruct == "never" or (settings.reconstruct == "auto" and have):
        if not have:
            missing = [c for c in _RECONSTRUCTED if c not in df.columns]
            raise FlightDataError(f"reconstruct='never' but the coefficient column(s) "
                                  f"{missing} are missing: run the reconstruction")
        return df, {"reconstructed": False}
    log("flight path reconstruction (IEKF + RTS smoother)")
    rec = reconstruct(df, meta, workers=settings.workers, progress=progress)
    note = {"reconstructed": True, "rejected": {int(k): v for k, v in rec.rejected.items()},
            "thrust_subtracted": rec.thrust_subtracted, "accelerations": rec.accelerations,
            "moment_reference": rec.moment_reference, "summary": rec.summary(),
            "record": rec.data.attrs.get("reconstruction"),
            "differentiation": {"half_window": rec.settings.diff_half_window,
                                "degree": rec.settings.diff_degree}}
    return rec.data, note


def _check_columns(df, structures: Mapping, coefficients, extra=()) -> None:
    cols = set(df.columns) | set(extra)
    for c in coefficients:
        if c not in cols:
            raise FlightDataError(f"coefficient column {c!r} is missing from the data")
    for c, s in structures.items():
        missing = [v for v in s.inputs if v not in cols]
        if missing:
            raise InputError(f"unknown variable(s) {missing} in the structure of {c}; the "
                             f"data have {sorted(cols)}")


def identify(df, metadata: Mapping | None = None, *,
             settings: IdentificationSettings | None = None, progress: bool = False,
             log: Callable[[str], None] | None = None, source: str | None = None,
             ) -> Identification:
    """Identify the aerodynamic model of an aircraft from flight data.

    Parameters
    ----------
    df : pandas.DataFrame
        Flight data in the flight-data schema: raw measurements (reconstructed first) or
        already reconstructed data with ``CX..Cn, phat, qhat, rhat``.
    metadata : mapping, optional
        Schema metadata (``df.attrs`` if None).
    settings : IdentificationSettings, optional
    progress : bool
        Progress bars for the long steps.
    log : callable, optional
        Receives one line per step (e.g. ``print``).
    source : str, optional
        Description of the input (file name and hash) for the provenance.

    Returns
    -------
    Identification

    Raises
    ------
    FlightDataError
        Missing columns, NaN/inf in a used column (naming the maneuvers), no maneuvers.
    InputError
        Unknown variables in a structure, an empty identification or validation set.
    """
    settings = settings or IdentificationSettings()
    log = log or (lambda _msg: None)
    t_start = time.perf_counter()
    meta = dict(df.attrs if metadata is None else metadata)
    structures = settings.starting_structures()
    data, rec_note, used, settings, dropped, gusty = _identification_data(
        df, meta, settings, structures, progress, log)
    ident, valid, coverage, left = _split(data, settings, log)
    columns = {c: ident[c].to_numpy(dtype=float) for c in data.columns
               if c in used or c in settings.selection.candidates}
    columns = {c: v for c, v in columns.items() if np.all(np.isfinite(v))}
    matched = _matched_differentiation(rec_note, meta) if settings.matched_regressors \
        else None
    results, notes, sideslip = _fit_all(structures, ident, valid, columns,
                                        _Splits(coverage, left, matched), settings, source,
                                        progress, log, gusty)
    notes = dropped + notes
    prov = {"software": f"simplexspline {__version__}",
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "seconds": round(time.perf_counter() - t_start, 2),
            "reconstruction": rec_note}
    if sideslip:
        prov["sideslip"] = sideslip
    if source:
        prov["source"] = source
    left = {c: m for c, m in left.items() if "left_out" in results[c].validation}
    table, failed = _derivative_errors(results, ident)
    unsure = failed or ("" if table is None else _sign_note(table))
    if unsure:
        warnings.warn(unsure, ThinDataWarning, stacklevel=2)
        notes.append(unsure)
    out = Identification(results, ident, valid, settings, meta, prov, notes, left, table)
    _record_provenance(results, out, meta, settings, prov)
    return out


def _identification_data(df, meta: dict, settings: IdentificationSettings,
                         structures: Mapping, progress: bool, log):
    """Step 1: the checked data with coefficients (reconstructed first when raw), a note on
    the reconstruction, the columns the structures and the selection use, the settings
    without the coefficients the data cannot give, and what was left out (notes)."""
    if "maneuver" not in df.columns:
        raise FlightDataError("column 'maneuver' is missing: the validation split is made "
                              "by maneuver")
    if len(df) == 0:
        raise FlightDataError("the flight data table is empty")
    # Fail before the (long) reconstruction when a structure the user gave names an
    # unknown column; a preset's structures are restricted to the data instead.
    given = dict(settings.structures or {})
    _check_columns(df, given, (), extra=(*_RECONSTRUCTED, *_RECONSTRUCTED_AIR_DATA,
                                         *ANGLE_RATE_NAMES,
                                         THRUST_COEFFICIENT, FUEL_FLOW_THRUST_COEFFICIENT,
                                         FAN_SPEED_THRUST_COEFFICIENT))
    data, rec_note = _coefficient_data(df, meta, settings, progress, log)
    gusty = _gusts_without_vane(data.attrs.get("reconstruction")
                                or meta.get("reconstruction") or {})
    data = without_metadata(data)
    derived = {**angle_rates(data, meta), **thrust_coefficient(data, meta)}
    for name, values in derived.items():
        if name not in data.columns:        # derived candidates: alpha', beta' made
            data[name] = values             # non-dimensional like the body rates, and
                                            # the thrust coefficient T / (qbar S) (or
                                            # its stand-in from the fuel flow or N1)
    # coefficients the data cannot give (no accelerometers: no force coefficients) are
    # left out and said so, unless the user asked for them by name
    absent = [c for c in settings.coefficients if c not in data.columns
              or not np.isfinite(data[c].to_numpy(dtype=float)).any()]
    dropped = []
    if absent and len(absent) < len(settings.coefficients) and not given:
        dropped = [f"{c} is not in the data (the reconstruction could not compute it, "
                   "e.g. a force coefficient without accelerometers): not modelled"
                   for c in absent]
        for msg in dropped:
            log(f"warning: {msg}")
        settings = replace(settings, coefficients=tuple(c for c in settings.coefficients
                                                        if c not in absent))
        structures = {c: v for c, v in structures.items() if c not in absent}
    _check_columns(data, given, settings.coefficients)
    thrust = _thrust_note(data, settings, rec_note, meta)
    if thrust:
        log(f"note: {thrust}")
        dropped.append(thrust)
    imu = _imu_position_note(data, settings, meta)
    if imu:
        log(f"note: {imu}")
        dropped.append(imu)
    scale = _vane_scale_note(data, settings, meta, rec_note)
    if scale:
        log(f"note: {scale}")
        dropped.append(scale)
    # the reconstruction's own record travels in the data's metadata, not the provenance
    rec_note = {k: v for k, v in rec_note.items() if k != "record"}
    # the structures' columns that the data have must be clean (a preset's missing ones
    # are left out later); candidates of the search with gaps are only not offered
    def present(v):     # a column that is entirely NaN is a sensor the aircraft lacks
        return v in data.columns and bool(np.isfinite(data[v].to_numpy(dtype=float)).any())

    required = set(settings.coefficients) | {v for s in given.values() for v in s.inputs} \
        | {v for s in structures.values() for v in s.inputs if present(v)}
    wanted = set(settings.selection.candidates) if settings.select else set()
    wanted = {v for v in wanted - required if present(v)}
    unusable = sorted(v for v in wanted
                      if not np.all(np.isfinite(data[v].to_numpy(dtype=float))))
    if unusable:
        log(f"column(s) {unusable} hold NaN or inf: not used as model variables")
    used = sorted(required | (wanted - set(unusable)))
    bad_rows = ~np.all(np.isfinite(data[sorted(required)].to_numpy(dtype=float)), axis=1)
    if bad_rows.any():
        mans = np.unique(data["maneuver"].to_numpy()[bad_rows])
        cols = [c for c in sorted(required)
                if not np.all(np.isfinite(data[c].to_numpy(dtype=float)))]
        raise FlightDataError(f"NaN or inf in column(s) {cols} in {int(bad_rows.sum())} rows "
                              f"of maneuver(s) {mans[:10].tolist()}: drop those maneuvers or "
                              "fill the gaps before identification")
    return data, rec_note, used, settings, dropped, gusty


def _gusts_without_vane(record: Mapping) -> list:
    """The maneuvers (as str) in which a reconstruction (its metadata record) had no
    sideslip vane, had GPS, and found gusts: their kinematic sideslip misses the lateral
    gusts (:mod:`simplexspline.aero.selection.side_force_sideslip`)."""
    out = []
    for m, r in (record.get("maneuvers") or {}).items():
        beta = str((r.get("observability") or {}).get("beta", ""))
        if beta.startswith("estimated from the lateral kinematics") \
                and float((r.get("gusts") or {}).get("std") or 0.0) > 0.0:
            out.append(str(m))
    return out


def _fit_all(structures: Mapping, ident, valid, columns: Mapping, splits: _Splits,
             settings: IdentificationSettings, source, progress: bool, log, gusty: list):
    """Step 3 for every coefficient: :func:`_fit_coefficients`, in two stages when the
    reconstruction found gusts without a sideslip vane (``gusty``: maneuvers): CY first on
    the kinematic sideslip, then the others on the sideslip that the side force gives
    through CY's model in those maneuvers, if the roll and yaw moments say it is the better
    one (:mod:`simplexspline.aero.selection.side_force_sideslip`; ``beta_side_force`` in
    both frames, the kinematic one stays in ``beta``). Returns (results, notes, record of
    the sideslip or None)."""
    coefs = tuple(settings.coefficients)
    others = tuple(c for c in coefs if c != "CY")
    lateral = [c for c in ("Cl", "Cn") if c in others]
    if not gusty or "CY" not in coefs or not lateral or "beta" not in ident.columns:
        return (*_fit_coefficients(structures, ident, valid, columns, splits, settings,
                                   source, progress, log), None)
    first, notes = _fit_coefficients(structures, ident, valid, columns, splits,
                                      replace(settings, coefficients=("CY",)), source,
                                      progress, log)
    model = first["CY"].model
    rows = {name: frame["maneuver"].astype(str).isin(gusty).to_numpy()
            for name, frame in (("identification", ident), ("validation", valid))}
    n_man = sum(int(frame["maneuver"][rows[name]].nunique())
                for name, frame in (("identification", ident), ("validation", valid)))
    head = f"no sideslip vane and gusts in {n_man} maneuver(s): "
    choice, why = None, "CY's model does not take beta"
    if "beta" in model.variables:
        try:
            choice = choose_sideslip(model, ident, valid, rows["identification"],
                                     rows["validation"], settings.selection,
                                     seed=settings.seed)
        except SimplexSplineError as exc:     # e.g. a CY model flat in beta
            why = f"the side force cannot give the sideslip ({exc})"
        else:
            ident["beta_side_force"] = choice.identification
            valid["beta_side_force"] = choice.validation
    judged = "" if choice is None else ", ".join(
        f"{c} {r:.2f}" for c, r in choice.ratios.items())
    if choice is None or not choice.used:
        if choice is not None:
            why = ("the sideslip from the side force through CY's model did not explain the "
                   f"roll and yaw moments better out of sample (cross-validated error ratios "
                   f"{judged or 'none: too few maneuvers'}; needed below {REFEREE_GAIN})")
        note = (head + f"{why}: the others keep the kinematic sideslip, which misses the "
                "lateral gusts")
        log(f"note: {note}")
        rest, more = _fit_coefficients(structures, ident, valid, columns, splits,
                                       replace(settings, coefficients=others), source,
                                       progress, log)
        return {c: {**first, **rest}[c] for c in coefs}, notes + [note] + more, None
    frames = {"identification": ident.assign(beta=choice.identification),
              "validation": valid.assign(beta=choice.validation)}
    cols = {**columns, "beta": choice.identification}
    rest, more = _fit_coefficients(structures, frames["identification"],
                                   frames["validation"], cols, splits,
                                   replace(settings, coefficients=others), source, progress,
                                   log)
    for c in others:
        for k in (f"model_{c}", f"inside_{c}"):
            valid[k] = frames["validation"][k]
    through = ("CY's model" if choice.source == "model" else
               "a side force linear in the sideslip, rudder and yaw rate, fitted on the "
               "maneuvers that move the sideslip most")
    fitting = ("cross-fitted by maneuver on the identification data" if choice.source ==
               "model" else "fitted once on the identification data")
    record = {"source": f"side force through {through} (beta + (CY - CY_model) / "
                        f"(dCY/dbeta); {fitting}) in the maneuvers with gusts; CY on the "
                        "kinematic sideslip",
              "through": choice.source,
              "candidates": jsonable(choice.candidates),
              "maneuvers": sorted(gusty, key=lambda m: (len(m), m)),
              "dCY_dbeta_per_rad": round(choice.slope, 4),
              "correction_rms_rad": round(choice.correction_rms, 6),
              "clipped": choice.clipped,
              "referee_error_ratios": {c: round(r, 4) for c, r in choice.ratios.items()},
              "coefficients": list(others)}
    note = (head + f"{', '.join(others)} identified on the sideslip that the side force "
            f"gives there through {through} (dCY/dbeta {choice.slope:.3g} /rad; correction "
            f"{choice.correction_rms:.2g} rad RMS; column beta_side_force; it explains the "
            f"roll and yaw moments better out of sample: error ratios {judged}); CY on the "
            "kinematic sideslip" + _attenuation_note(choice))
    log(f"note: {note}")
    return {c: {**first, **rest}[c] for c in coefs}, notes + [note] + more, record


def _attenuation_note(choice) -> str:
    """Where the linear side force was chosen and CY's own model has a markedly smaller
    dCY/dbeta: what that says of CY's derivatives, or ''."""
    model = (choice.candidates.get("model") or {}).get("dCY_dbeta")
    if choice.source != "linear" or model is None or not np.isfinite(model) \
            or abs(model) >= 0.8 * abs(choice.slope):
        return ""
    return (f"; CY's own model has dCY/dbeta {model:.3g} /rad there: fitted on the kinematic "
            "sideslip, which misses the gusts, its derivatives along the sideslip are too "
            "small (errors in variables) and its roll-rate and aileron terms take over part "
            "of the sideslip's effect")


def _thrust_note(data, settings: IdentificationSettings, rec_note: Mapping,
                 meta: Mapping) -> str:
    """What CX and Cm hold when the reconstruction left the thrust in the coefficients
    (this run's, or the one that made the data): the note, or '' (thrust subtracted,
    neither modelled, or coefficients from elsewhere)."""
    if rec_note.get("reconstructed"):
        included = not rec_note.get("thrust_subtracted")
    else:
        included = (meta.get("reconstruction") or {}).get("thrust") == "included"
    if not included or not {"CX", "Cm"} & set(settings.coefficients):
        return ""
    # the thrust line of a real installation passes off the c.g.: on the simulated f16 its
    # moment was 0.8-1.8e-3 of Cm, from test point to test point, about its noise
    holds = ("CX holds the thrust and Cm its pitching moment (a thrust line off the c.g.) "
             "(no thrust columns, no thrust model")
    if FUEL_FLOW_THRUST_COEFFICIENT in data.columns:
        both = FAN_SPEED_THRUST_COEFFICIENT in data.columns
        return (f"{holds}); the search is offered the fuel-flow thrust coefficient tc_ff = "
                "fuel_flow * 4e4 m/s / (qbar S)"
                + (" and the fan-speed thrust coefficient tc_n1 = (n1 a0 / V)^2" if both
                   else "")
                + " so that they may follow the throttle"
                + (", and takes what the data support" if both else ""))
    if FAN_SPEED_THRUST_COEFFICIENT in data.columns:
        return (f"{holds}, no fuel flow); the search is offered the fan-speed thrust "
                "coefficient tc_n1 = (n1 a0 / V)^2 (a turbofan's) so that they may follow "
                "the throttle")
    why = ("the fuel flow is there, but tc_ff also needs rho, tas and the wing area S"
           if "fuel_flow" in data.columns else "the data hold no fuel flow or fan speed")
    return (f"{holds}) and {why}: they cannot follow the throttle between test points; map "
            "the engines' fuel flow (fuel_flow) or fan speed (n1), or give a thrust model")


def _vane_scale_note(data, settings: IdentificationSettings, meta: Mapping,
                     rec_note: Mapping | None = None) -> str:
    """An angle-of-attack vane whose scale factor is neither given nor estimated: the
    reconstruction held it at 1 in every maneuver (turbulence in all of them, no GPS, or
    not requested) and the maneuvers' means could not determine it either (docs/
    reconstruction.md, "The vane's scale in turbulence"), so the angle of attack carries
    the vane's own scale error, and with it every derivative along alpha. The note, or ''
    (the scale given or estimated, no vane, no reconstruction record, or no longitudinal
    coefficient modelled).

    A vane reads the local flow, which the fuselage's upwash turns by several per cent;
    measured on a simulated global5000 course in light turbulence whose vane read 1.25x
    the flow angle (`bench_whole_flight.py --design eigenmotion --maneuvers 12 --turns`,
    scale 1.25 put into `SensorModel.real_like()`): CL_alpha came out at 3.37 for a true
    4.35, the vane's scale to 3 %."""
    rec = (rec_note or {}).get("record") or meta.get("reconstruction") or {}
    maneuvers = rec.get("maneuvers") or {}
    if not maneuvers or "alpha" not in data.columns \
            or not {"CX", "CZ", "Cm"} & set(settings.coefficients):
        return ""
    vane = (meta.get("sensor_geometry") or {}).get("alpha_vane") or {}
    if vane.get("scale") is not None or "kalpha" in (rec.get("air_data_calibration") or {}):
        return ""
    held = [str((m.get("held") or {}).get("kalpha", "")) for m in maneuvers.values()]
    if not all(held):
        return ""                        # some maneuver estimated it
    why = sorted(set(h.split(":")[0].split(" (")[0] for h in held))
    return ("the angle-of-attack vane's scale factor is neither given (metadata "
            "sensor_geometry.alpha_vane.scale) nor estimated (held at 1 in every maneuver: "
            + "; ".join(why) + "): alpha, and every derivative along it (CL_alpha, "
            "Cm_alpha), carry the vane's own scale error (a vane's upwash is often several "
            "per cent); give the scale from the vane's calibration, or fly with GPS a "
            "stretch of calm air or steady stretches of a minute or more at several "
            "airspeeds, from which the reconstruction estimates it")


def _imu_position_note(data, settings: IdentificationSettings, meta: Mapping) -> str:
    """An imported record whose accelerometers' position is not given: how much each metre
    of it along x and z moves CY and CZ (the note), or '' (given, simulated data, neither
    modelled, or a column missing).

    The specific force at an IMU ``r`` from the c.g. holds ``omega' x r + omega x (omega x
    r)``: at ``y = 0`` its lateral part is ``(r' + p q) x - (p' - q r) z``, its normal part
    ``(p r - q') x - (p^2 + q^2) z``. The angular accelerations are themselves linear in
    the flow angles, the rates and the controls, so the force models take that part into
    their derivatives, and no aerodynamic data can take it out. On a still-air flight-test
    course (`bench_whole_flight.py --design eigenmotion --maneuvers 6 --turns --turbulence
    none`: real-like sensors, the IMU 0.6 m ahead of and 0.2 m below the c.g.) each metre
    along x is 1.4e-4 of CY RMS and along z 5.0e-4, against a noise of about 3e-4; on the
    Cessna 172's (seed 5, maneuver list) the normal part took CL_alpha to 4.55 /rad, 4.81
    with the installation given (truth 5.27): the pitch acceleration in an elevator
    doublet is about ``M_alpha alpha``, so ``-x q'`` is a lift slope of its own."""
    if "import" not in meta:
        return ""
    geo = meta.get("sensor_geometry") or {}
    if (geo.get("imu") or {}).get("position_m") is not None:
        return ""
    base = ("mass", "rho", "tas", "p", "q", "r")
    if not all(c in data.columns for c in base) or "S" not in meta:
        return ""
    col = {c: data[c].to_numpy(dtype=float) for c in data.columns
           if c in (*base, "pdot", "qdot", "rdot", "CY", "CZ")}
    scale = col["mass"] / (0.5 * col["rho"] * col["tas"] ** 2 * float(meta["S"]))
    rates = np.column_stack([col[c] for c in ("p", "q", "r")])
    zero = np.zeros(len(scale))

    def per_metre(axis: int, used: tuple) -> tuple:
        """The coefficient along body ``axis`` per metre of the IMU along x and along z;
        only the angular accelerations ``used`` enter (the others, unused there, zero)."""
        wdot = np.column_stack([col[c] if c in used else zero
                                for c in ("pdot", "qdot", "rdot")])
        return tuple(scale * lever_arm_acceleration(rates, wdot, e)[:, axis]
                     for e in ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)))

    arms = {}
    if "CY" in settings.coefficients and all(c in col for c in ("pdot", "rdot", "CY")):
        arms["CY"] = per_metre(1, ("pdot", "rdot"))
    if "CZ" in settings.coefficients and all(c in col for c in ("qdot", "CZ")):
        arms["CZ"] = per_metre(2, ("qdot",))
    parts = []
    for c, (per_x, per_z) in arms.items():
        ok = np.isfinite(per_x) & np.isfinite(per_z) & np.isfinite(col[c])
        if ok.sum() < 2:
            continue
        rx = float(np.sqrt(np.mean(per_x[ok] ** 2)))
        rz = float(np.sqrt(np.mean(per_z[ok] ** 2)))
        spread = float(np.std(col[c][ok]))
        share = f" ({rx / spread:.2f} of {c}'s own spread)" if spread > 0 else ""
        parts.append((c, f"{c} by {rx:.1e} RMS in these data{share}, along z by {rz:.1e}"))
    if not parts:
        return ""
    takes = {"CY": "the side-force model takes it into its sideslip, rate and control "
                   "derivatives",
             "CZ": "the normal-force model takes it into its alpha, pitch-rate and elevator "
                   "derivatives (CL_alpha among them)"}
    return ("the accelerometers' position is not given (metadata sensor_geometry.imu): "
            "each metre of the IMU's distance from the c.g. along x moves "
            + "; along x ".join(text for _, text in parts) + "; "
            + ", ".join(takes[c] for c, _ in parts)
            + ", and the data cannot take it out (the angular accelerations are linear in "
            "the same variables): give [metadata.sensor_geometry.imu] position_m from the "
            "installation drawings")


@dataclass(frozen=True)
class _Coverage:
    """Which validation samples lie where the identification data are, and the envelope
    cells that say so (see :mod:`simplexspline.aero.selection.coverage`)."""

    valid_covered: np.ndarray
    envelope: EnvelopeCells


@dataclass(frozen=True)
class _Splits:
    """The shared split's coverage, the maneuvers validated by leaving them out
    (:attr:`Identification.left_out_validation`, candidates per coefficient) and the
    matched smoothing of the moment coefficients' regressors."""

    coverage: _Coverage
    left_out: dict = field(default_factory=dict)
    #: the differentiation of the angular accelerations that the moment coefficients'
    #: regressors are smoothed to match (:func:`_matched_differentiation`), or None
    matched: Mapping | None = None


def _split(data, settings: IdentificationSettings, log):
    """Step 2: identification and validation samples, split by whole maneuvers so that
    validation maneuvers stay inside the envelope the identification data cover."""
    groups = data["maneuver_type"].to_numpy() if "maneuver_type" in data.columns else None
    env = {v: data[v].to_numpy(dtype=float) for v in ENVELOPE_VARIABLES if v in data.columns}
    envelope = EnvelopeCells.from_data(env)
    cells = envelope.cell(env)
    excited = [c for c in settings.coefficients if c in data.columns]
    held = [v for v in TEST_POINT_VARIABLES if v in data.columns]
    motion = [v for v in MOTION_VARIABLES if v in data.columns] if settings.split_motion \
        else []
    split = validation_split(data["maneuver"].to_numpy(), settings.validation_fraction,
                             seed=settings.seed, groups=groups, cells=cells,
                             excitation=data[excited].to_numpy(dtype=float),
                             ranges=data[held].to_numpy(dtype=float) if held else None,
                             motion=data[motion].to_numpy(dtype=float) if motion else None)
    is_val = split.validation
    left = {c: m for c, m in zip(excited, split.left_out) if m is not None}
    ident, valid = data.loc[~is_val].copy(), data.loc[is_val].copy()
    # The metadata live in ``meta``; pandas deep-copies ``attrs`` on every column access
    # (0.26 s each with a campaign's reconstruction record), so the splits carry none.
    ident.attrs, valid.attrs = {}, {}
    if len(valid) == 0 or len(ident) == 0:
        raise InputError("the identification or validation set is empty; give more maneuvers"
                         " or change validation_fraction")
    coverage = _Coverage(envelope.covered(cells[is_val], envelope.counts(cells[~is_val])),
                         envelope)
    valid["inside_envelope"] = coverage.valid_covered
    log(f"{data['maneuver'].nunique()} maneuvers: {ident['maneuver'].nunique()} for "
        f"identification ({len(ident):,} samples), {valid['maneuver'].nunique()} for "
        f"validation ({len(valid):,} samples, {100 * coverage.valid_covered.mean():.1f} % "
        f"inside the identification data's envelope)")
    return ident, valid, coverage, left


def _matched_differentiation(rec_note: Mapping, meta: Mapping) -> dict | None:
    """The settings of the differentiation that gave the angular accelerations in the
    moment coefficients (``half_window``, ``degree``), or None when they were measured or
    are not known (coefficients computed elsewhere).

    A derivative of sampled rates is the smoothing ``K * qdot`` of the true one
    (:func:`~simplexspline.aero.data.differentiation.matched_weights`): at 10 Hz over +-2
    samples, which an elevator or aileron step fills. The moment coefficients' regressors
    are then smoothed alike for the search and the fit
    (:func:`~simplexspline.aero.data.differentiation.matched_by_maneuver`, a no-op at the
    simulator's step), so that the equation ``K * Cm = Cm(K * x)`` holds for the terms
    linear in their multipliers; the model is the instantaneous ``Cm(x)``, judged against
    a truth at the instantaneous regressors. Measured on a simulated 10 Hz T37
    flight-test course (six test points, still air, seed 62, the maneuver list), a linear
    least-squares Cm on the reconstructed data gave Cm_q -30.2 and Cm_de -0.58 /rad with
    instantaneous regressors, -40.2 and -0.73 with matched ones, against -43.0 and -0.82
    from the true coefficients on the true states.
    """
    if rec_note.get("reconstructed"):
        if rec_note.get("accelerations") != "differentiated":
            return None
        return dict(rec_note.get("differentiation") or {"half_window": None, "degree": 4})
    record = meta.get("reconstruction") or {}
    if record.get("accelerations") != "differentiated":
        return None
    given = record.get("settings") or {}
    return {"half_window": given.get("diff_half_window"),
            "degree": given.get("diff_degree", 4)}


def _matched_frames(ident, valid, columns: Mapping, matched: Mapping) -> tuple:
    """(identification frame, validation frame, columns) with the regressors smoothed as
    the differentiation smoothed the angular accelerations
    (:func:`~simplexspline.aero.data.differentiation.matched_by_maneuver`, per maneuver).
    The flow-angle rates are left alone: they are derivatives from the same filter, so
    already ``K * alpha'``."""
    names = [v for v in columns if v not in COEFFICIENTS and v not in ANGLE_RATE_NAMES
             and not v.startswith("true_")]
    frames = []
    for frame in (ident, valid):
        out = frame.copy()
        if names and len(frame):
            out[names] = matched_by_maneuver(frame["maneuver"].to_numpy(),
                                             frame["t"].to_numpy(dtype=float),
                                             frame[names].to_numpy(dtype=float),
                                             half_window=matched.get("half_window"),
                                             degree=int(matched.get("degree") or 4))
        frames.append(out)
    cols = {k: (frames[0][k].to_numpy(dtype=float) if k in names else v)
            for k, v in columns.items()}
    return frames[0], frames[1], cols


def _fit_coefficients(structures: Mapping, ident, valid, columns: Mapping,
                      splits: _Splits, settings: IdentificationSettings, source,
                      progress: bool, log):
    """Step 3: select, fit and validate each coefficient's model (one BLAS thread: many
    small factorisations), the coefficients in parallel processes when ``workers``
    allow (each search is independent; results are identical to a serial run)."""
    results, notes = {}, []
    coefs = tuple(settings.coefficients)
    has_truth = all(f"true_{c}" in valid.columns for c in coefs)
    workers = min(len(coefs), settings.workers or os.cpu_count() or 1)
    bar = _bar(len(coefs), progress)
    outcomes = {}
    # (identification, validation, columns, instantaneous frames or None) per kind of
    # coefficient: True for a moment coefficient on matched regressors
    frames = {False: (ident, valid, columns, None)}
    if splits.matched is not None and any(c in MOMENT_COEFFICIENTS for c in coefs):
        frames[True] = (*_matched_frames(ident, valid, columns, splits.matched),
                        (ident, valid))

    def matched(c) -> bool:
        return c in MOMENT_COEFFICIENTS and True in frames

    def done(c, outcome):
        outcomes[c] = outcome
        v = outcome[0].validation
        log(f"{outcome[0].structure.label():<44} validation rel. RMS {100 * v['rrms']:.2f} %"
            + (f", RMS vs truth {v['rms_true']:.3e} (noise {v['noise_rms']:.3e})"
               if has_truth else "") + f"  [{outcome[0].seconds:.1f} s]")
        bar.update(1)

    if workers > 1:
        # only what the fits read travels to the workers
        keep = set(columns) | set(coefs) | {f"true_{c}" for c in coefs} \
            | {"maneuver", "maneuver_type", "t"}

        def slim(frame):
            return frame[[k for k in frame.columns if k in keep]]
        ctx = process_context()
        # one process per coefficient (up to 3 per worker), ``workers`` of them computing
        # at once, trial by trial (simplexspline._compute_slots): which search is long is
        # not known in advance, and one that started last ran alone at the end (the main
        # job: 69 s for 101 s of work on 2 cores). The largest starting structures first
        # when there are fewer processes than coefficients. Results do not depend on it.
        order = sorted(coefs, key=lambda c: -structures[c].size())
        procs = min(len(coefs), SLOT_PROCESSES * workers)
        gate = ctx.Semaphore(workers) if procs > workers else None
        with ProcessPoolExecutor(max_workers=procs, mp_context=ctx,
                                 initializer=init_worker, initargs=(gate,)) as pool:
            slimmed = {k: (slim(i), slim(v), cols, None if inst is None else
                           tuple(slim(f) for f in inst))
                       for k, (i, v, cols, inst) in frames.items()}
            futures = {pool.submit(_identify_in_worker, c, structures[c],
                                   *slimmed[matched(c)][:3], splits.coverage, settings,
                                   has_truth, source, splits.left_out.get(c),
                                   slimmed[matched(c)][3]): c
                       for c in order}
            for fut in as_completed(futures):
                done(futures[fut], fut.result())
    else:
        with kernels.one_blas_thread():
            for c in coefs:
                i_c, v_c, cols_c, instant = frames[matched(c)]
                done(c, _identify_one(c, structures[c], i_c, v_c, cols_c,
                                      splits.coverage, settings, has_truth, source,
                                      splits.left_out.get(c), instant))
    for c in coefs:          # in coefficient order, however the workers finished
        res, pred_v, new_notes, to_warn = outcomes[c]
        results[c] = res
        valid[f"model_{c}"] = pred_v
        valid[f"inside_{c}"] = _covered(res.model, valid,
                                        valid["inside_envelope"].to_numpy())
        notes.extend(new_notes)
        for msg in to_warn:
            warnings.warn(msg, ThinDataWarning, stacklevel=3)
    bar.close()
    return {c: results[c] for c in coefs}, notes


#: Below this share of validation samples inside the identification data's coverage, the
#: validation scores mostly measure extrapolation, and identify says so.
MIN_VALIDATION_COVERAGE = 0.5


def _extrapolation_note(c: str, v_scores: Mapping, maneuvers: np.ndarray,
                        covered: np.ndarray) -> str:
    """The warning for a validation that lies (mostly) outside the identification data."""
    share = v_scores["coverage"]
    outside = [_plain_id(m) for m in np.unique(maneuvers[~covered])]
    scored = ("scored on all of them (nothing else to score)" if share == 0 else
              "scored on the covered part; the rest under 'outside' in summary.json")
    return (f"{c}: only {100 * share:.1f} % of the validation samples lie inside the "
            f"identification data's coverage (maneuvers {outside[:10]}"
            f"{' ...' if len(outside) > 10 else ''} leave it), {scored}: the validation "
            "figures measure extrapolation, not the model; fly more maneuvers at these "
            "conditions or hold out fewer (validation_fraction)")


def _record_provenance(results: Mapping, out: Identification, meta: dict,
                       settings: IdentificationSettings, prov: dict) -> None:
    """Step 4: what each model file keeps of the run (settings, medians, geometry,
    validation scores)."""
    for c, res in results.items():
        ident = out.identification
        res.model.provenance.update({"software": prov["software"],
                                     "settings": settings.to_dict(),
                                     "medians": {v: float(np.median(ident[v].to_numpy(
                                         dtype=float))) for v in res.model.variables},
                                     "geometry": {k: float(meta[k]) for k in
                                                  ("S", "b", "cbar") if k in meta},
                                     "validation": {k: res.validation.get(k) for k in
                                                    ("rms", "rrms", "r2", "rms_true",
                                                     "rrms_true")}})
        side = prov.get("sideslip")
        if side and res.model.coefficient in side["coefficients"] \
                and "beta" in res.model.variables:
            res.model.provenance["sideslip"] = side


def _identify_in_worker(*args) -> tuple:
    """:func:`_identify_one` in a worker process, with one BLAS thread (the workers
    share the cores)."""
    with kernels.one_blas_thread():
        return _identify_one(*args)


#: Worker processes per compute slot of the coefficients' searches (_fit_coefficients).
SLOT_PROCESSES = 3


def _identify_one(c: str, start: Structure, ident, valid, columns: Mapping,
                  coverage: _Coverage, settings: IdentificationSettings, has_truth: bool,
                  source, left_out=None, instant=None) -> tuple:
    """Select (optionally), fit and validate the model of coefficient ``c`` (in this
    process or a worker); ``left_out``: the identification maneuver validated by leaving
    it out (:attr:`Identification.left_out_validation`), or None; ``instant``: when
    ``ident`` and ``valid`` hold matched-smoothed regressors (:func:`_matched_frames`),
    the (identification, validation) frames with the instantaneous ones, at which the
    model is judged against a truth.

    Returns
    -------
    result : CoefficientResult
    prediction : ndarray, shape (len(valid),)
        The model on the validation samples.
    notes : list of str
        What the user should know (also in the summary).
    warn : list of str
        The notes that are :class:`ThinDataWarning` s.
    """
    t0, busy0 = time.perf_counter(), busy_seconds()
    notes: list = []
    warn: list = []
    y = ident[c].to_numpy(dtype=float)
    mans = ident["maneuver"].to_numpy()
    start, dropped = restrict_to_data(start, columns)
    if dropped:
        msg = (f"{c}: {sorted(dropped)} left out of the starting structure, the data cannot "
               "support them (" + "; ".join(f"{k}: {v}" for k, v in dropped.items()) + ")")
        notes.append(msg)
        warn.append(msg)
    start = _drop_zero_multipliers(start, columns, notes, warn)
    # the search's coverage: without the sideslip for a lateral coefficient
    cells = search_cells(coverage.envelope, c, {v: ident[v].to_numpy(dtype=float)
                                                 for v in coverage.envelope.variables})
    cache = SearchCache()     # shared: the search starts where the prior's choice ended
    untested: list = []
    if settings.select:
        # the maneuvers that move c, when the search's cross-validation can score none
        untested = _untested(y, mans, cv_scored_share(columns, y, mans, settings.selection,
                                                      seed=settings.seed, cells=cells,
                                                      by="variation"))
    selection = settings.selection
    if untested:
        # the linear model of the start's terms, and no hinge basis: the forward pass
        # would place its knots and products on the unscored maneuvers, where the
        # cross-validation cannot judge them (the 737 six-point course's Cn); nor can it
        # judge the removal of a term that only those maneuvers excite, nor how its
        # derivative changes across the envelope, nor what a new term takes from it: the
        # linear terms stay, with constant coefficients, and the search is offered only
        # the variables that scored maneuvers move (the T37 six-point still-air course's
        # Cm lost its elevator and pitch rate, Cm_alpha -0.01 against the truth's -0.70;
        # kept, the elevator's coefficient varied with alpha and took the trim curve;
        # constant, alpha-dot terms added on the scored maneuvers took the doublet's
        # moment: Cm_de -0.11 against the simulator's -0.96)
        start = linear_start(start, constant=True)
        selection = replace(selection, hinge_start=False,
                            kept_multipliers=tuple(start.multipliers),
                            candidates=_scored_candidates(columns, mans, selection,
                                                          settings.seed, cells))
    prior_degree, prior_scores = choose_prior_degree(start, columns, y, mans,
                                                     selection, seed=settings.seed,
                                                     cells=cells, cache=cache)
    if settings.select:
        best, history = select_structure(start, columns, y, mans, selection,
                                         seed=settings.seed, prior_degree=prior_degree,
                                         cells=cells, cache=cache,
                                         duration_s=_duration(ident))
        if untested:
            notes.append(_unscored_note(c, best, untested, ident["maneuver_type"].to_numpy()
                                        if "maneuver_type" in ident.columns else None, mans))
    else:
        best, history = start, [Trial(start, float("nan"), 0, "fixed", accepted=True)]
    with compute_slot():
        return _fit_and_validate(c, best, history, prior_degree, prior_scores, ident, valid,
                                 columns, coverage, settings, has_truth, source, notes, warn,
                                 t0, busy0, left_out, instant)


#: A maneuver counts as scored by the structure search's cross-validation when at least
#: this share of its variation is (:func:`_untested`).
SCORED_SHARE = 0.1


def _untested(y: np.ndarray, maneuvers: np.ndarray, shares: Mapping) -> list:
    """The maneuvers that excite the coefficient ``y`` (within-maneuver standard deviation
    at least ``EXCITED`` times the largest), most moving first, when the structure
    search's cross-validation scores none of them (``shares``:
    :func:`~simplexspline.aero.selection.search.cv_scored_share` by variation; scored
    means at least ``SCORED_SHARE`` of a maneuver's variation, not of its samples: a
    doublet's trimmed lead-in can be scored where its response is not); otherwise [].

    The search cannot then tell the candidate structures apart where the coefficient
    moves. On a still-air course with one input per axis and test point, each rudder
    maneuver flown at a Mach number that no other identification maneuver flew, the
    search kept the scheduled start for Cn: 3.82x the noise at a held-out turn, where
    the linear model was at 0.45x.
    """
    if not shares:
        return []
    ids = np.unique(maneuvers)
    spread, level = maneuver_spread(maneuvers, len(ids), y)
    spread, level = spread[:, 0], float(level[0])
    if not np.isfinite(level):
        return []
    moving = [i for i in np.argsort(-spread) if spread[i] >= level]
    if any(shares.get(ids[i].item(), 1.0) >= SCORED_SHARE for i in moving):
        return []
    return [ids[i].item() for i in moving]


def _scored_candidates(columns: Mapping, maneuvers: np.ndarray, selection, seed: int,
                       cells) -> tuple:
    """The search's candidate variables whose own exciting maneuvers the cross-validation
    scores (:func:`_untested` of the variable's column is empty): where the coefficient's
    exciting maneuvers are unscored, a term added on the scored maneuvers may take over
    what only the unscored ones show, and nothing would see it. On the T37 six-point
    still-air course, alpha-dot terms added to Cm took its one elevator doublet's moment
    (Cm_de -0.11 against the doublet's -0.56 by least squares). Variables absent from
    ``columns`` are left as they are (the search skips them)."""
    out = []
    for v in selection.candidates:
        x = columns.get(v)
        if x is None:
            out.append(v)
            continue
        x = np.asarray(x, dtype=float)
        shares = cv_scored_share(columns, x, maneuvers, selection, seed=seed, cells=cells,
                                 by="variation")
        if not _untested(x, maneuvers, shares):
            out.append(v)
    return tuple(out)


def _unscored_note(c: str, best: Structure, untested: list, types: np.ndarray | None,
                   maneuvers: np.ndarray) -> str:
    """The note on a coefficient whose exciting maneuvers (``untested``: :func:`_untested`)
    the search's cross-validation never scored: its search started from the linear model
    of its terms (:func:`~simplexspline.aero.modelling.auto.linear_start`) without the
    hinge start (``SelectionSettings.hinge_start``) and with those terms kept
    (``SelectionSettings.kept_multipliers``), and ``best`` is what the scored maneuvers
    supported beyond it."""
    first = {} if types is None else {m: types[k] for m, k in
                                      zip(*np.unique(maneuvers, return_index=True))}
    named = ", ".join(f"{m}" + (f" ({first[m]})" if m in first else "")
                      for m in untested[:4])
    return (f"{c}: the structure search's cross-validation scored none of the maneuvers "
            f"that excite it most ({named}): each lies alone in its envelope cells, so no "
            "structure could be tested where it matters; the search started from the "
            "linear model of its terms, kept them with constant coefficients (nothing "
            "could test their removal or their change across the envelope), offered only "
            "the variables that scored maneuvers move, and chose "
            f"{best.label()} on the other maneuvers, "
            "without the hinge start (its forward pass would place knots on those "
            "maneuvers that nothing judges); fly those inputs twice per test point to "
            "test a scheduled structure")


def _duration(data) -> float | None:
    """Time the maneuvers of ``data`` span [s]: samples times the median sample interval
    of each maneuver; None without a time column."""
    if "t" not in data.columns or len(data) < 2:
        return None
    total = 0.0
    for _, t in data.groupby("maneuver", sort=False)["t"]:
        dt = np.diff(t.to_numpy(dtype=float))
        dt = dt[np.isfinite(dt) & (dt > 0)]
        if dt.size:
            total += len(t) * float(np.median(dt))
    return total or None


def _fit_and_validate(c: str, best: Structure, history: list, prior_degree: int,
                      prior_scores: dict, ident, valid, columns: Mapping,
                      coverage: _Coverage, settings: IdentificationSettings,
                      has_truth: bool, source, notes: list, warn: list, t0: float,
                      busy0: float | None, left_out_maneuver=None, instant=None) -> tuple:
    """The rest of :func:`_identify_one` after the search: the final fit on all
    identification data, validation and the notes. With ``left_out_maneuver`` the
    validation also scores that identification maneuver, predicted by a model of the
    same structure identified without it (:func:`_left_out_prediction`). ``instant``: as
    in :func:`_identify_one`."""
    y = ident[c].to_numpy(dtype=float)
    mans = ident["maneuver"].to_numpy()
    model = fit_structure(best, columns, y, settings.selection, prior_degree=prior_degree,
                          provenance={"coefficient": c, **({"source": source}
                                                            if source else {})})
    refits = _fold_models(best, columns, y, mans, settings, prior_degree)
    if prior_scores:
        model.provenance["prior"]["cv_rms_by_degree"] = {str(d): v for d, v in
                                                          prior_scores.items()}
    pred_v = model.predict(valid)
    truth_v = valid[f"true_{c}"].to_numpy() if has_truth else None
    truth_i = ident[f"true_{c}"].to_numpy() if has_truth else None
    # against the truth: the model at the instantaneous regressors (None: those of pred_v)
    at_truth_v = None if instant is None or not has_truth else model.predict(instant[1])
    covered = _covered(model, valid, coverage.valid_covered)
    measured, predicted = valid[c].to_numpy(dtype=float), pred_v
    v_mans = valid["maneuver"].to_numpy()
    types = valid["maneuver_type"].to_numpy() if "maneuver_type" in valid.columns else None
    v_scores = scores_by_coverage(measured, predicted, covered, truth=truth_v,
                                  maneuvers=v_mans, truth_model=at_truth_v)
    excited = _excitation_where_covered(c, measured, predicted, covered, v_mans,
                                        v_scores["r2"], types)
    # barely excited where it is validated: the maneuver that excites it, left out
    left = None if left_out_maneuver is None or excited["excited"] else \
        _left_out_prediction(best, columns, y, mans, left_out_maneuver, settings,
                             prior_degree)
    if left is not None:
        mine, lo_model = left
        pred_lo = lo_model.predict(ident.loc[mine], outside="hold")
        at_truth_lo = None if at_truth_v is None else \
            lo_model.predict(instant[0].loc[mine], outside="hold")
        shared = {k: v_scores[k] for k in ("rms", "rrms", "r2", "n", "coverage", "rms_true",
                                           "noise_rms", "rms_true_over_noise")
                  if k in v_scores}
        lo_scores = scores(y[mine], pred_lo, truth=None if truth_i is None
                           else truth_i[mine], max_lag=0, truth_model=at_truth_lo)
        lo_scores.pop("autocorrelation", None)
        # the left-out maneuver is scored whole: nothing else excites the coefficient, so
        # the model identified without it meets it beyond the rest of the data
        measured, predicted = np.r_[measured, y[mine]], np.r_[predicted, pred_lo]
        covered = np.r_[covered, np.ones(int(mine.sum()), dtype=bool)]
        v_mans = np.r_[v_mans, mans[mine]]
        truth_v = None if truth_v is None else np.r_[truth_v, truth_i[mine]]
        at_truth_v = None if at_truth_v is None else np.r_[at_truth_v, at_truth_lo]
        if types is not None:
            types = np.r_[types, ident["maneuver_type"].to_numpy()[mine]]
        v_scores = scores_by_coverage(measured, predicted, covered, truth=truth_v,
                                      maneuvers=v_mans, truth_model=at_truth_v)
        v_scores["left_out"] = {"maneuver": _plain_id(left_out_maneuver), **lo_scores}
        v_scores["shared"] = shared
        kind = "" if types is None else f" ({types[-1]})"
        notes.append(f"{c}: the validation maneuvers barely excite it (R^2 "
                     f"{shared['r2']:.2f}) and none that does could be spared; maneuver "
                     f"{left_out_maneuver}{kind}, which excites it most, is validated by "
                     f"leaving it out: a model of the same structure identified without it "
                     f"predicts it (R^2 {lo_scores['r2']:.2f}; with the validation maneuvers "
                     f"{v_scores['r2']:.2f}), and the model delivered is identified with it "
                     f"('left_out' and 'shared' in summary.json)")
        excited = _excitation_where_covered(c, measured, predicted, covered, v_mans,
                                            v_scores["r2"], types)
    pred_i = model.predict(ident)
    i_scores = scores(y, pred_i, truth=truth_i, maneuvers=mans, max_lag=0,
                      truth_model=None if instant is None or truth_i is None
                      else model.predict(instant[0]))
    if excited["message"]:
        notes.append(excited["message"])
    if v_scores["coverage"] < MIN_VALIDATION_COVERAGE:
        msg = _extrapolation_note(c, v_scores, valid["maneuver"].to_numpy(), covered)
        notes.append(msg)
        warn.append(msg)
    inputs = [v for v in best.inputs if v in columns]
    separation = collinearity(columns, inputs, y - pred_i,
                              v_scores.get("autocorrelation"))
    tangled = [d for d in separation if not d["separable"]]
    if tangled:
        notes.append(f"{c}: the identification data cannot separate the effects of "
                     + "; ".join(f"{d['variable']} (VIF {d['vif']:.0f}, correlation "
                                 f"{d['correlation']:+.2f} with {d['partner']})"
                                 for d in tangled)
                     + ": derivatives along them are uncertain (summary.json, "
                       "'diagnostics'); fly maneuvers that move them independently")
    left_out = _flow_angle_left_out(c, columns, inputs, y - pred_i,
                                    v_scores.get("autocorrelation"))
    if left_out is not None:
        msg = (f"{c}: the model does not take {left_out['variable']}, which the "
               f"identification data cannot tell from its variables (VIF "
               f"{left_out['vif']:.0f}, correlation {left_out['correlation']:+.2f} with "
               f"{left_out['partner']}): its derivative along {left_out['variable']} is not "
               f"identified (the model's is 0), not zero; fly maneuvers that move "
               f"{left_out['variable']} independently")
        notes.append(msg)
        warn.append(msg)
        # in the model file too: the derivatives command names the slope it cannot give
        model.provenance["not_identified"] = {left_out["variable"]: {
            k: left_out[k] for k in ("vif", "partner", "correlation")}}
    held = model.provenance.get("held_terms")
    if held:
        notes.append(_held_note(c, held, model.structure.variables))
    gaps = model.provenance.get("held_gaps")
    if gaps:
        notes.append(_gap_note(c, gaps))
    counts = np.asarray(model.provenance["counts"])
    thin = np.nonzero(counts < settings.thin_factor * best.ncoef_per_simplex)[0]
    if len(thin):
        limit = int(settings.thin_factor * best.ncoef_per_simplex)
        there = ("it follows the coarse prior model there" if "prior" in model.provenance
                 else "the model is poorly supported there")
        msg = (f"{c}: {len(thin)} of {len(counts)} simplices hold fewer than "
               f"{settings.thin_factor:g} x K d_hat = {limit} samples (fewest: "
               f"{int(counts.min())}); {there}")
        notes.append(msg)
        warn.append(msg)
    # with compute slots, the time it computed (not the time it waited for a slot)
    busy = busy_seconds()
    seconds = (time.perf_counter() - t0 if busy is None or busy0 is None
               else busy - busy0)
    diagnostics = {"excitation": excited, "collinearity": separation}
    if left_out is not None:
        diagnostics["flow_angle_left_out"] = left_out
    result = CoefficientResult(model, v_scores, i_scores, history, counts, thin, seconds,
                               diagnostics, refits)
    return result, pred_v, notes, warn


def _fold_models(best: Structure, columns: Mapping, y: np.ndarray, mans: np.ndarray,
                 settings: IdentificationSettings, prior_degree: int) -> list:
    """The structure ``best`` identified again without each fold of the identification
    maneuvers (:attr:`CoefficientResult.fold_models`). The folds depend only on the
    maneuvers and the seed, so every coefficient's are the same: a derivative that two
    models make (``CL_alpha`` from CX and CZ) is taken from refits on the same data.

    The refits use every k-th sample, at most ``max_samples`` of them, as the search's
    cross-validation does: at 100 Hz neighbouring samples carry nearly the same
    information, and the main job's five refits per coefficient on all 190,562 samples
    took it from 77.0 to 87.1 s (81.6 s with the cap). The standard error is then that
    of the estimator on those samples, which can only be less precise than the delivered
    model's: if anything, it errs large."""
    step = subsample_step(len(y), settings.selection.max_samples)
    cols = {v: np.asarray(x)[::step] for v, x in columns.items()}
    ys, ms = np.asarray(y)[::step], np.asarray(mans)[::step]
    k = min(settings.derivative_folds, int(np.unique(ms).size))
    if k < MIN_FOLDS:
        return []
    folds = fold_by_maneuver(ms, k, seed=settings.seed)
    out = []
    for f in range(k):
        keep = folds != f
        try:
            out.append(fit_structure(best, {v: x[keep] for v, x in cols.items()},
                                     ys[keep], settings.selection, prior_degree=prior_degree))
        except (SimplexSplineError, np.linalg.LinAlgError, ValueError, FloatingPointError):
            out.append(None)       # a fold the structure cannot be fitted without: it
                                   # does not count (an auxiliary result: never a crash)
    return out


def _derivative_errors(results: Mapping, ident) -> tuple:
    """:attr:`Identification.derivatives` (None without fold models, or where the
    jackknife fails) and a note ('' unless it failed)."""
    k = max((len(r.fold_models) for r in results.values()), default=0)
    if k < MIN_FOLDS:
        return None, ""
    models = {c: r.model for c, r in results.items()}
    folds = [{c: (r.fold_models[f] if f < len(r.fold_models) else None)
              for c, r in results.items()} for f in range(k)]
    try:
        return jackknife_derivatives(models, folds,
                                     reference=reference_conditions(models, ident)), ""
    except (SimplexSplineError, ValueError) as exc:   # the models stand without them
        return None, (f"the derivatives' standard errors could not be computed ({exc}); "
                      "the models are not affected")


#: A primary derivative's sign counts as undetermined when zero lies within this many
#: jackknife standard errors of it.
SIGN_SIGMAS = 2.0


def _sign_note(table) -> str:
    """The note naming the primary derivatives (``Cm_alpha``, ``Cl_p``, ...) whose sign
    the data do not determine, or ''."""
    rows = primary_derivatives(table)
    bad = rows[np.abs(rows["value"]) < SIGN_SIGMAS * rows["standard_error"]]
    if bad.empty:
        return ""
    parts = [f"{n} {r.value:+.3g} +- {r.standard_error:.2g} {r.unit}" for n, r in bad.iterrows()]
    return ("the data do not determine the sign of " + "; ".join(parts)
            + f" (at the reference condition; jackknife standard errors over "
              f"{table.attrs['folds']} folds of identification maneuvers, zero within "
              f"{SIGN_SIGMAS:g} of them; summary.json 'derivatives'): fly maneuvers that "
              "move these variables on their own, or treat the values as unknown")


def _excitation_where_covered(c: str, measured, predicted, covered, maneuvers, r2: float,
                              types) -> dict:
    """:func:`~simplexspline.aero.selection.diagnostics.excitation` of the validation
    samples that count (all of them when none is covered)."""
    inside = covered if covered.any() else slice(None)
    return excitation(c, measured[inside], (measured - predicted)[inside],
                      maneuvers[inside], r2, None if types is None else types[inside])


def _plain_id(m):
    """A maneuver id as a plain int or str (for JSON)."""
    return int(m) if np.issubdtype(type(m), np.integer) else str(m)


def _left_out_prediction(best: Structure, columns: Mapping, y: np.ndarray,
                         mans: np.ndarray, maneuver, settings: IdentificationSettings,
                         prior_degree: int) -> tuple | None:
    """The left-out validation of one maneuver (:attr:`Identification.left_out_validation`):
    its rows in the identification data (mask) and a model of structure ``best``
    identified on the other identification maneuvers, to predict them with
    ``outside='hold'``; None when that model cannot be fitted (the rest too thin). On a
    flight-test course with one elevator input per test
    point (global5000, six test points, no maneuver list), Cm was validated on stationary
    segments, aileron inputs and turns (R^2 -0.50: the noise against a bias); left out,
    the elevator input that excites it is predicted to R^2 0.92.

    Where the maneuver goes beyond the others, the model holds its coefficients at the
    edge of their data and keeps its terms linear in their multipliers
    (:meth:`AeroModel.predict` with ``outside='hold'``). Until stop 47 the edge simplex's
    polynomial was extrapolated: on a 737 course in light turbulence
    (`bench_whole_flight.py --aircraft 737 --design eigenmotion --turns --maneuvers 12
    --seed 22`) the last elevator doublet, flown at the slowest test point 12 % beyond
    the others' angles of attack, was predicted by ``Cm(alpha:3 | 1, qhat, de,
    alphadot_hat, mach)`` to R^2 -2.84 (its cubics turned beyond their data); held, 0.79.
    Clamping every input as ``predict`` does by default gave 0.80 there but saturates
    the multipliers: on the global5000 course of six test points the left-out Cm went
    0.98 -> 0.65 with it (held: 0.98)."""
    mine = mans == maneuver
    if not mine.any() or mine.all():
        return None
    try:
        model = fit_structure(best, {k: v[~mine] for k, v in columns.items()}, y[~mine],
                              settings.selection, prior_degree=prior_degree)
    except SimplexSplineError:
        return None
    return mine, model


def _held_note(c: str, held: Mapping, variables) -> str:
    """The note on a model's terms held outside where the data excite them."""
    parts = []
    for term, box in held.items():
        ranges = ", ".join(f"{v} {lo:.4g}..{hi:.4g}" for v, lo, hi in
                           zip(variables, box["lower"], box["upper"]))
        parts.append(f"{term} ({ranges})")
    return (f"{c}: the data excite some terms only in part of the envelope; their "
            f"derivatives are held at their values there beyond it: {'; '.join(parts)} "
            "(model provenance 'held_terms'); fly those inputs at more test points to "
            "measure them")


def _gap_note(c: str, gaps: Mapping) -> str:
    """The note on a model's terms interpolated across where the data do not excite them
    between where they do (model provenance ``held_gaps``)."""
    parts = []
    for term, where in gaps.items():
        ranges = ", ".join(f"{v} " + ", ".join(f"{lo:.4g}..{hi:.4g}" for lo, hi in runs)
                           for v, runs in where.items())
        parts.append(f"{term} ({ranges})")
    return (f"{c}: some terms are not excited between the conditions where they are; their "
            f"derivatives there are interpolated between those conditions: "
            f"{'; '.join(parts)} (model provenance 'held_gaps'); fly those inputs there to "
            "measure them")


def _flow_angle_left_out(c: str, columns: Mapping, inputs: list, residual: np.ndarray,
                         autocorrelation) -> dict | None:
    """The coefficient's flow angle (:data:`~simplexspline.aero.variables.FLOW_ANGLES`)
    when the model does not take it but the identification data cannot tell it from the
    model's variables (its VIF among them above the limit): the collinearity entry, else
    None. On a still-air Cessna course CZ's model took Mach, the elevator and the fuel
    flow instead of alpha (all collinear along the stationary series) and predicted the
    validation to 1.5x the noise: its lift-curve slope was 0, and only the slope, not the
    model, was wrong."""
    angle = FLOW_ANGLES.get(c)
    if angle is None or angle in inputs or angle not in columns or not inputs:
        return None
    entry = next((d for d in collinearity(columns, [*inputs, angle], residual,
                                          autocorrelation) if d["variable"] == angle), None)
    return None if entry is None or entry["separable"] else entry


def _covered(model: AeroModel, valid, in_cells: np.ndarray) -> np.ndarray:
    """The validation samples whose score counts: in a covered envelope cell, in a simplex
    of the model that held identification data, and inside the identified box of every
    input (a sample beyond the identification data's range is clamped by ``predict``: an
    extrapolation)."""
    return in_cells & model.inside(valid) & model.in_box(valid)


def _drop_zero_multipliers(s: Structure, columns: Mapping, notes: list,
                           warn: list) -> Structure:
    """A varying-coefficient structure without the multipliers that are zero throughout
    the identification data (e.g. a flap that never moved): they cannot be identified
    (said in ``notes`` and ``warn``)."""
    if not s.varying:
        return s
    x = np.column_stack([np.asarray(columns[v], dtype=float) for v in s.inputs])
    m = multiplier_values(s, x)
    zero = [name for name, col in zip(s.multipliers, m.T) if not np.any(col != 0)]
    if not zero:
        return s
    kept = tuple(name for name in s.multipliers if name not in zero)
    if not kept:
        raise InputError(f"every multiplier of {s.label()} is zero throughout the "
                         "identification data")
    msg = (f"{s.coefficient}: multiplier(s) {zero} are zero throughout the identification "
           "data and were left out of the structure")
    notes.append(msg)
    warn.append(msg)
    return s.with_(multipliers=kept)


class _NoBar:
    def update(self, _n):
        pass

    def close(self):
        pass


def _bar(total: int, progress: bool):
    if not progress:
        return _NoBar()
    try:
        from tqdm.auto import tqdm
    except ImportError:  # pragma: no cover - tqdm is in the aero extra
        return _NoBar()
    return tqdm(total=total, desc="models", unit="coef")
