"""An identified aerodynamic coefficient model: a simplex spline on scaled, named variables.

:class:`AeroModel` wraps a :class:`~simplexspline.SimplexSpline` fitted in the unit box of
:class:`~simplexspline.aero.structure.Scaling` with the model structure, units and
provenance, and evaluates on a DataFrame with named columns. It is saved in the open model
format (docs/model-format.md): the spline file, with the aerodynamic description under the
metadata key ``aero``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simplexspline.aero.structure import UNITS, Scaling, Structure
from simplexspline.errors import InputError, ModelFileError
from simplexspline.spline.spline import SimplexSpline

__all__ = ["AERO_FORMAT", "AERO_VERSION", "AeroModel"]

AERO_FORMAT = "simplexspline.aeromodel"
AERO_VERSION = 1

OUTSIDE = ("clamp", "nan", "extrapolate")


@dataclass
class AeroModel:
    """A coefficient model ``C = s(u(x))`` with ``u`` the scaled variables.

    Attributes
    ----------
    structure : Structure
    scaling : Scaling
        Physical variable ranges of the identification data (the model's domain box).
    spline : SimplexSpline
        The spline in scaled coordinates (unit box).
    provenance : dict
        Input file hash, settings, package version, data counts (JSON-serialisable).
    """

    structure: Structure
    scaling: Scaling
    spline: SimplexSpline
    provenance: dict = field(default_factory=dict)

    @property
    def coefficient(self) -> str:
        return self.structure.coefficient

    @property
    def variables(self) -> tuple:
        return self.structure.variables

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

    def predict(self, data, *, outside: str = "clamp") -> np.ndarray:
        """Evaluate the coefficient.

        Parameters
        ----------
        data : DataFrame, mapping of column -> array, or array of shape (N, n)
            Inputs in physical units (SI, radians) named as ``structure.variables``.
        outside : {'clamp', 'nan', 'extrapolate'}
            Inputs outside the identified box are clamped to it (like simulator tables,
            default), give NaN, or are evaluated with the nearest simplex's polynomial.
            Inside the box, points in a dropped (data-free) simplex use the nearest one
            unless ``outside='nan'``.

        Returns
        -------
        ndarray, shape (N,)
        """
        if outside not in OUTSIDE:
            raise InputError(f"outside must be one of {OUTSIDE}, got {outside!r}")
        u = self.scaling.transform(self.inputs(data), clip=outside == "clamp")
        return self.spline.predict(u, outside="nan" if outside == "nan" else "extrapolate")

    __call__ = predict

    def gradient(self, data, *, outside: str = "clamp") -> np.ndarray:
        """Exact partial derivatives with respect to the physical variables, shape (N, n)
        (e.g. Cm_alpha in 1/rad)."""
        if outside not in OUTSIDE:
            raise InputError(f"outside must be one of {OUTSIDE}, got {outside!r}")
        u = self.scaling.transform(self.inputs(data), clip=outside == "clamp")
        g = self.spline.gradient(u, outside="nan" if outside == "nan" else "extrapolate")
        return g / self.scaling.span

    def inside(self, data) -> np.ndarray:
        """Boolean mask: the inputs lie in a kept simplex of the identified domain."""
        u = self.scaling.transform(self.inputs(data))
        return self.spline.triangulation.locate(u) >= 0

    # ------------------------------------------------------------------ files
    def metadata(self) -> dict:
        return {
            "format": AERO_FORMAT, "version": AERO_VERSION,
            "structure": self.structure.to_dict(),
            "scaling": self.scaling.to_dict(),
            "units": {v: UNITS.get(v, "?") for v in (*self.variables, self.coefficient)},
            "provenance": self.provenance,
        }

    def save(self, path) -> Path:
        """Write the model (``.json`` or ``.npz``, atomically)."""
        spline = SimplexSpline(self.spline.triangulation, self.spline.degree,
                               self.spline.continuity, self.spline.coefficients,
                               metadata={**self.spline.metadata, "aero": self.metadata()})
        return spline.save(path)

    @classmethod
    def load(cls, path) -> AeroModel:
        """Read a model written by :meth:`save`."""
        spline = SimplexSpline.load(path)
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
        except (KeyError, TypeError, ValueError, InputError) as exc:
            raise ModelFileError(f"{path}: invalid aerodynamic model description: {exc}") \
                from None
        if scaling.variables != structure.variables or spline.ndim != structure.ndim:
            raise ModelFileError(f"{path}: the structure, scaling and spline disagree on the "
                                 "variables")
        spline.metadata = meta
        return cls(structure, scaling, spline, dict(aero.get("provenance") or {}))

    # ------------------------------------------------------------------ statistics
    def standard_error(self, data, *, outside: str = "clamp") -> np.ndarray:
        """Standard error of the predicted coefficient, shape (N,) (see
        :meth:`SimplexSpline.standard_error`); the spline needs statistics
        (``spline.with_statistics(ne)``). ``outside`` as in :meth:`predict`."""
        if outside not in OUTSIDE:
            raise InputError(f"outside must be one of {OUTSIDE}, got {outside!r}")
        u = self.scaling.transform(self.inputs(data), clip=outside == "clamp")
        return self.spline.standard_error(u, outside="nan" if outside == "nan"
                                          else "extrapolate")

    def confidence_interval(self, data, level: float = 0.95, *, kind: str = "confidence",
                            weights=None, outside: str = "clamp"):
        """Pointwise ``(lower, upper)`` bounds of the coefficient (``kind='confidence'``)
        or of a new measurement of it (``'prediction'``), see
        :meth:`SimplexSpline.confidence_interval`; ``outside`` as in :meth:`predict`."""
        if outside not in OUTSIDE:
            raise InputError(f"outside must be one of {OUTSIDE}, got {outside!r}")
        u = self.scaling.transform(self.inputs(data), clip=outside == "clamp")
        return self.spline.confidence_interval(
            u, level, kind=kind, weights=weights,
            outside="nan" if outside == "nan" else "extrapolate")
