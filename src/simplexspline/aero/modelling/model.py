"""An identified aerodynamic coefficient model: a simplex spline on scaled, named variables.

:class:`AeroModel` wraps a :class:`~simplexspline.SimplexSpline` fitted in the unit box of
:class:`~simplexspline.aero.modelling.structure.Scaling` with the model structure, units and
provenance, and evaluates on a DataFrame with named columns. A varying-coefficient structure
(``C = sum_k m_k s_k(variables)``, :mod:`simplexspline.spline.varying`) wraps a
:class:`~simplexspline.spline.varying.VaryingCoefficientSpline` instead; the multipliers
enter divided by their scale (RMS over the identification data) so that the terms are of
comparable size. Either is saved in the open model format (docs/model-format.md): the spline
file, with the aerodynamic description under the metadata key ``aero``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simplexspline.aero.modelling.structure import (
    multiplier_jacobian,
    multiplier_values,
    Scaling,
    Structure,
)
from simplexspline.aero.variables import UNITS
from simplexspline.errors import InputError, ModelFileError
from simplexspline.spline.space import SimplexSpline
from simplexspline.spline.varying import VaryingCoefficientSpline
from simplexspline.spline.formats.loading import load_spline
from simplexspline.spline.geometry.outside import AERO_POLICIES

__all__ = ["AERO_FORMAT", "AERO_VERSION", "AeroModel"]

AERO_FORMAT = "simplexspline.aeromodel"
AERO_VERSION = 1

#: Outside policies of :meth:`AeroModel.predict` and :meth:`AeroModel.gradient`: those of
#: the project's aerodynamic models, and ``'hold'``, which holds a varying-coefficient
#: model's coefficients at the box's edge and keeps its terms linear in their multipliers.
OUTSIDE = (*AERO_POLICIES, "hold")


@dataclass
class AeroModel:
    """A coefficient model ``C = s(u(x))``, or ``C = sum_k (m_k / scale_k) s_k(u(x))``.

    Attributes
    ----------
    structure : Structure
    scaling : Scaling
        Physical ranges of every input (``structure.inputs``) in the identification data
        (the model's domain box); the spline's variables are ``structure.variables``.
    spline : SimplexSpline or VaryingCoefficientSpline
        The spline in scaled coordinates (unit box).
    provenance : dict
        Input file hash, settings, package version, data counts (JSON-serialisable).
    multiplier_scale, multiplier_offset : tuple of float
        Varying-coefficient models: term k multiplies ``(m_k - offset_k) / scale_k``. With a
        constant term (``'1'``: offset 0, scale 1) the other multipliers are centred on
        their identification-data mean (a multiplier far from zero, such as the mass, is
        otherwise nearly collinear with the constant) and scaled by their standard
        deviation; without one they are only scaled (by their RMS).
    """

    structure: Structure
    scaling: Scaling
    spline: SimplexSpline | VaryingCoefficientSpline
    provenance: dict = field(default_factory=dict)
    multiplier_scale: tuple = ()
    multiplier_offset: tuple = ()

    def __post_init__(self):
        if self.structure.varying:
            k = self.structure.nterms
            if len(self.multiplier_scale) != k:
                self.multiplier_scale = (1.0,) * k
            if len(self.multiplier_offset) != k:
                self.multiplier_offset = (0.0,) * k
            self.multiplier_scale = tuple(float(v) for v in self.multiplier_scale)
            self.multiplier_offset = tuple(float(v) for v in self.multiplier_offset)

    @property
    def coefficient(self) -> str:
        return self.structure.coefficient

    @property
    def variables(self) -> tuple:
        """Every input column, in the order of :meth:`inputs` and :meth:`gradient`."""
        return self.structure.inputs

    @property
    def schedule(self) -> tuple:
        """The variables of the triangulation (``structure.variables``)."""
        return self.structure.variables

    @property
    def schedule_scaling(self) -> Scaling:
        """The scaling of the triangulation's variables."""
        return self.scaling.subset(self.schedule)

    @property
    def varying(self) -> bool:
        return self.structure.varying

    def __repr__(self) -> str:
        return (f"AeroModel({self.structure.label()}, {self.spline.triangulation.nsimplex} "
                "simplices)")

    # ------------------------------------------------------------------ evaluation
    def inputs(self, data) -> np.ndarray:
        """The (N, n) physical inputs from a DataFrame / mapping of columns or an array."""
        if hasattr(data, "columns") or isinstance(data, dict):
            cols = list(data.columns) if hasattr(data, "columns") else list(data)
            missing = [v for v in self.variables if v not in cols]
            if missing:
                raise InputError(f"{self.coefficient} model needs column(s) {missing}; the "
                                 f"data have {sorted(cols)[:30]}")
            x = np.column_stack([np.asarray(data[v], dtype=float) for v in self.variables])
        else:
            x = np.asarray(data, dtype=float)
            if x.ndim == 1 and x.size == len(self.variables):
                x = x[None, :]
            if x.ndim != 2 or x.shape[1] != len(self.variables):
                raise InputError(f"{self.coefficient} model takes an array of shape (N, "
                                 f"{len(self.variables)}) in the order {list(self.variables)}"
                                 f", got shape {x.shape}")
        if not np.all(np.isfinite(x)):
            bad = np.nonzero(~np.all(np.isfinite(x), axis=1))[0]
            raise InputError(f"{len(bad)} input row(s) of the {self.coefficient} model hold "
                             f"NaN or inf (first rows {bad[:5].tolist()}); drop or fill them")
        return x

    def _check_outside(self, outside: str) -> str:
        if outside not in OUTSIDE:
            raise InputError(f"outside must be one of {OUTSIDE}, got {outside!r}")
        return "nan" if outside == "nan" else "extrapolate"

    def split(self, x: np.ndarray, *, clip: bool = False, hold: bool = False):
        """Physical inputs (N, len(variables)) -> the spline's arguments: scaled
        scheduling variables ``z`` (N, n) and, for varying-coefficient models, the scaled
        multipliers ``m`` (N, K) (None otherwise). ``clip`` clamps every input to the
        identified range first; ``hold`` clamps the scheduling variables only (the
        multipliers are taken where the inputs are)."""
        if clip:
            x = np.clip(x, self.scaling.lower, self.scaling.upper)
        n = len(self.schedule)
        sched = x[:, :n]
        if hold:
            sched = np.clip(sched, np.asarray(self.scaling.lower[:n], dtype=float),
                            np.asarray(self.scaling.upper[:n], dtype=float))
        z = self.schedule_scaling.transform(sched)
        if not self.varying:
            return z, None
        m = multiplier_values(self.structure, x) - np.asarray(self.multiplier_offset)
        return z, m / np.asarray(self.multiplier_scale)

    def in_box(self, data) -> np.ndarray:
        """Which rows lie inside the identified box: every input (scheduling variables and
        multiplier columns) within the identification data's range, so that
        :meth:`predict` does not clamp them (compare :meth:`inside`: in a kept simplex).

        Parameters
        ----------
        data : DataFrame, mapping of column -> array, or array of shape (N, n)
            As in :meth:`predict`.

        Returns
        -------
        ndarray of bool, shape (N,)
        """
        x = self.inputs(data)
        lower, upper = np.asarray(self.scaling.lower), np.asarray(self.scaling.upper)
        return np.all((x >= lower) & (x <= upper), axis=1)

    def predict(self, data, *, outside: str = "clamp") -> np.ndarray:
        """Evaluate the coefficient.

        Parameters
        ----------
        data : DataFrame, mapping of column -> array, or array of shape (N, n)
            Inputs in physical units (SI, radians) named as ``variables``.
        outside : {'clamp', 'nan', 'extrapolate', 'hold'}
            Inputs outside the identified box are clamped to it (like simulator tables,
            default), give NaN, or are evaluated with the nearest simplex's polynomial.
            ``'hold'``: the scheduling variables are clamped to the box, so that every
            coefficient (derivative) keeps its value at the box's edge, and the terms stay
            linear in their multipliers where they are (``Cm_de(alpha) * de`` beyond the
            identified alpha and elevator: ``Cm_de`` at the edge alpha times the elevator
            flown); for a model without multipliers it is ``'clamp'``. The polynomial of
            the edge simplex can turn anywhere beyond its data; a derivative held there
            cannot (the left-out validation of :func:`~simplexspline.aero.identify.identify`
            predicts a maneuver beyond the others so).
            Inside the box, points in a dropped (data-free) simplex use the nearest one
            unless ``outside='nan'``.

        Returns
        -------
        ndarray, shape (N,)
        """
        policy = self._check_outside(outside)
        z, m = self.split(self.inputs(data), clip=outside == "clamp", hold=outside == "hold")
        if m is None:
            return self.spline.predict(z, outside=policy)
        return self.spline.predict(z, m, outside=policy)

    __call__ = predict

    def gradient(self, data, *, outside: str = "clamp") -> np.ndarray:
        """Exact partial derivatives with respect to the physical inputs, shape
        (N, len(variables)) (e.g. Cm_alpha in 1/rad); ``outside`` as in :meth:`predict`
        (with ``'hold'`` the derivative along a scheduling variable beyond the box is 0:
        the coefficients are held there)."""
        policy = self._check_outside(outside)
        x = self.inputs(data)
        if outside == "clamp":
            x = np.clip(x, self.scaling.lower, self.scaling.upper)
        n = len(self.schedule)
        z, m = self.split(x, hold=outside == "hold")
        sched = x[:, :n]
        if outside == "hold":
            lo = np.asarray(self.scaling.lower[:n], dtype=float)
            hi = np.asarray(self.scaling.upper[:n], dtype=float)
            held = (sched < lo) | (sched > hi)
            sched = np.clip(sched, lo, hi)
        jac = self.schedule_scaling.jacobian(sched)
        if outside == "hold":
            jac = np.where(held, 0.0, jac)
        out = np.zeros((len(x), len(self.variables)))
        if m is None:
            out[:, :n] = self.spline.gradient(z, outside=policy) * jac
            return out
        gz, gm = self.spline.gradient(z, m, outside=policy)
        out[:, :n] = gz * jac
        dm = multiplier_jacobian(self.structure, x) / np.asarray(self.multiplier_scale)[:, None]
        return out + np.einsum("nk,nki->ni", gm, dm)

    def locate(self, data) -> np.ndarray:
        """The simplex of each input (-1 outside the kept simplices), shape (N,)."""
        z, _ = self.split(self.inputs(data))
        return self.spline.triangulation.locate(z)

    def inside(self, data) -> np.ndarray:
        """Boolean mask: the scheduling variables lie in a kept simplex of the identified
        domain (one that held identification data; compare :meth:`in_box`)."""
        return self.locate(data) >= 0

    # ------------------------------------------------------------------ files
    def metadata(self) -> dict:
        meta = {
            "format": AERO_FORMAT, "version": AERO_VERSION,
            "structure": self.structure.to_dict(),
            "scaling": self.scaling.to_dict(),
            "units": {v: UNITS.get(v, "?") for v in (*self.variables, self.coefficient)},
            "provenance": self.provenance,
        }
        if self.varying:
            meta["multiplier_scale"] = list(self.multiplier_scale)
            meta["multiplier_offset"] = list(self.multiplier_offset)
        return meta

    def save(self, path) -> Path:
        """Write the model (``.json`` or ``.npz``, atomically)."""
        s = self.spline
        meta = {**s.metadata, "aero": self.metadata()}
        if self.varying:
            out = VaryingCoefficientSpline(s.triangulation, s.degree, s.continuity,
                                           s.coefficients, metadata=meta)
        else:
            out = SimplexSpline(s.triangulation, s.degree, s.continuity, s.coefficients,
                                metadata=meta)
            out._uncertainty = getattr(s, "_uncertainty", None)
        return out.save(path)

    @classmethod
    def load(cls, path) -> AeroModel:
        """Read a model written by :meth:`save`."""
        spline = load_spline(path)
        meta = dict(spline.metadata)
        aero = meta.pop("aero", None)
        if not isinstance(aero, dict) or aero.get("format") != AERO_FORMAT:
            raise ModelFileError(f"{path}: a spline model file without an aerodynamic model "
                                 "description (metadata 'aero'); load it with "
                                 "SimplexSpline.load")
        if aero.get("version") != AERO_VERSION:
            raise ModelFileError(f"{path}: aerodynamic model version {aero.get('version')!r}"
                                 f" is not supported (this simplexspline reads "
                                 f"{AERO_VERSION}); upgrade simplexspline")
        try:
            structure = Structure.from_dict(aero["structure"])
            scaling = Scaling.from_dict(aero["scaling"])
            mscale = tuple(float(v) for v in aero.get("multiplier_scale", ()))
            moffset = tuple(float(v) for v in aero.get("multiplier_offset", (0.0,) * len(mscale)))
            if not (all(np.isfinite(v) and v > 0 for v in mscale)
                    and all(np.isfinite(v) for v in moffset)):
                raise InputError("multiplier scales must be finite and > 0, offsets finite")
        except (KeyError, TypeError, ValueError, InputError) as exc:
            raise ModelFileError(f"{path}: invalid aerodynamic model description: {exc}") \
                from None
        varying = isinstance(spline, VaryingCoefficientSpline)
        if (scaling.variables != structure.inputs or spline.ndim != structure.ndim
                or varying != structure.varying
                or (varying and (spline.nterms != structure.nterms
                                 or len(mscale) != structure.nterms
                                 or len(moffset) != structure.nterms))):
            raise ModelFileError(f"{path}: the structure, scaling and spline disagree on the "
                                 "variables or terms")
        spline.metadata = meta
        return cls(structure, scaling, spline, dict(aero.get("provenance") or {}), mscale,
                   moffset)

    # ------------------------------------------------------------------ statistics
    def _plain(self, what: str) -> None:
        if self.varying:
            raise InputError(f"{what} is available for plain spline models; "
                             f"{self.structure.label()} is a varying-coefficient model")

    def standard_error(self, data, *, outside: str = "clamp") -> np.ndarray:
        """Standard error of the predicted coefficient, shape (N,) (see
        :meth:`SimplexSpline.standard_error`); the spline needs statistics
        (``spline.with_statistics(ne)``). ``outside`` as in :meth:`predict`."""
        self._plain("standard_error")
        policy = self._check_outside(outside)
        u, _ = self.split(self.inputs(data), clip=outside == "clamp")
        return self.spline.standard_error(u, outside=policy)

    def confidence_interval(self, data, level: float = 0.95, *, kind: str = "confidence",
                            weights=None, outside: str = "clamp"):
        """Pointwise ``(lower, upper)`` bounds of the coefficient (``kind='confidence'``)
        or of a new measurement of it (``'prediction'``), see
        :meth:`SimplexSpline.confidence_interval`; ``outside`` as in :meth:`predict`."""
        self._plain("confidence_interval")
        policy = self._check_outside(outside)
        u, _ = self.split(self.inputs(data), clip=outside == "clamp")
        return self.spline.confidence_interval(u, level, kind=kind, weights=weights,
                                               outside=policy)
