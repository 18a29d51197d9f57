"""Opening a spline model file of either kind: plain or varying-coefficient."""

from __future__ import annotations

from pathlib import Path

from simplexspline.spline.formats.model_file import read_model
from simplexspline.spline.space import SimplexSpline
from simplexspline.spline.varying import VaryingCoefficientSpline

__all__ = ["load_spline"]


def load_spline(path: str | Path) -> SimplexSpline | VaryingCoefficientSpline:
    """The spline a model file holds, whichever kind it is.

    Parameters
    ----------
    path : path-like
        A ``.json`` or ``.npz`` file written by ``SimplexSpline.save``,
        ``VaryingCoefficientSpline.save`` or
        :func:`~simplexspline.spline.formats.model_file.save_spline`.

    Returns
    -------
    SimplexSpline or VaryingCoefficientSpline

    Raises
    ------
    ModelFileError
        Missing, corrupt, foreign or unsupported file, or invalid contents.
    """
    record = read_model(path)
    kind = VaryingCoefficientSpline if record.varying else SimplexSpline
    return kind.from_record(record)
