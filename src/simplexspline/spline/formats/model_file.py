"""The open, versioned model file format (JSON or npz; no pickled objects).

This module is the file: it writes a spline's arrays and header (:func:`save_spline`) and
reads them back as a :class:`ModelRecord` (:func:`read_model`), checking format and
version; the classes build themselves from a record (``SimplexSpline.load``,
``VaryingCoefficientSpline.load``, or :func:`~simplexspline.spline.formats.loading.load_spline`
for either kind).

A model file holds one :class:`~simplexspline.SimplexSpline`:

JSON (``.json``)::

    {"format": "simplexspline.model", "version": 1,
     "degree": d, "continuity": r, "ndim": n, "nbasis": d_hat, "nsimplex": J,
     "triangulation_kind": "explicit" | "delaunay" | "grid" | "fit",
     "triangulation": {"vertices": [[...]], "simplices": [[...]],
                       "grid_lower": [...], "grid_upper": [...],     # grid/fit only
                       "grid_shape": [...], "grid_table": [...]},
     "coefficients": [[...]],                          # (J, d_hat), Eq. 11 order
     "metadata": {...}}

Varying-coefficient splines use ``"format": "simplexspline.varying-model"``, a header key
``"nterms": K`` and coefficients of shape (J, K, d_hat). See docs/model-format.md.

Floats are written with Python's shortest round-trip representation, so a loaded model
predicts bit for bit what the saved one did.

npz (``.npz``): the arrays ``vertices``, ``simplices``, ``coefficients`` (and ``grid_*``)
plus ``header``, a unicode scalar holding the JSON above without the arrays. Loaded with
``allow_pickle=False``.

Optional section ``"statistics"`` (still format version 1; files without it load as
before): what confidence bounds need (:mod:`simplexspline.spline.uncertainty.intervals`), with its own
``format``/``version``; the packed Gram blocks and point counts are in it (JSON) or in the
arrays ``statistics_gram``, ``statistics_counts`` and (penalised fits)
``statistics_penalty`` (npz).

Both are written atomically: to a temporary file in the target directory, then renamed.
"""

from __future__ import annotations

import io
import json
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import numpy as np

from simplexspline._files import write_bytes
from simplexspline._version import __version__
from simplexspline.errors import ModelFileError, SimplexSplineError
from simplexspline.spline.geometry.triangulation import Triangulation

T = TypeVar("T")

__all__ = ["FORMAT", "STATS_PREFIX", "VARYING_FORMAT", "VERSION", "ModelRecord", "read_model",
           "save_spline"]

FORMAT = "simplexspline.model"
VERSION = 1
#: Format identifier of varying-coefficient models (coefficients of shape (J, K, d_hat));
#: readers that know only FORMAT refuse these files instead of misreading them.
VARYING_FORMAT = "simplexspline.varying-model"

#: npz array names of the optional statistics section start with this.
STATS_PREFIX = "statistics_"


@dataclass(frozen=True)
class ModelRecord:
    """The contents of a model file, before any object is built from them.

    Attributes
    ----------
    path : Path
        The file read (for messages).
    header : dict
        The JSON header: ``format``, ``version``, ``degree``, ``continuity``, ``ndim``,
        ``nbasis``, ``nsimplex``, ``triangulation_kind``, ``metadata`` (and ``nterms`` for
        varying-coefficient models).
    triangulation : dict of str to ndarray
        The arrays of :meth:`Triangulation.from_arrays` plus ``"kind"``.
    coefficients : ndarray, shape (J, d_hat) or (J, K, d_hat)
    statistics : dict or None
        The optional statistics section (JSON scalars and, in JSON files, its arrays).
    statistics_arrays : dict of str to ndarray
        The statistics arrays of npz files (names without :data:`STATS_PREFIX`).
    """

    path: Path
    header: dict
    triangulation: dict
    coefficients: np.ndarray
    statistics: dict | None
    statistics_arrays: dict
    has_statistics: bool = False

    @property
    def varying(self) -> bool:
        """True for a varying-coefficient model (:data:`VARYING_FORMAT`)."""
        return self.header["format"] == VARYING_FORMAT

    def error(self, message: str) -> ModelFileError:
        """A :class:`ModelFileError` about this file."""
        return ModelFileError(f"{self.path}: {message}")

    def build(self, make: Callable[[Triangulation], T]) -> T:
        """``make(triangulation)`` with the file's triangulation: the object the file holds.

        Errors in the contents (an invalid triangulation, coefficients of the wrong shape,
        missing keys) become a :class:`ModelFileError` naming the file.
        """
        try:
            return make(Triangulation.from_arrays(self.triangulation))
        except ModelFileError:
            raise
        except SimplexSplineError as exc:
            raise self.error(f"invalid model contents: {exc}") from None
        except (KeyError, TypeError, ValueError) as exc:
            raise self.error(f"corrupt or unreadable model file ({type(exc).__name__}: "
                             f"{exc})") from None


def _header(spline) -> dict:
    varying = spline.coefficients.ndim == 3
    head = {
        "format": VARYING_FORMAT if varying else FORMAT,
        "version": VERSION,
        "software": f"simplexspline {__version__}",
        "degree": spline.degree,
        "continuity": spline.continuity,
        "ndim": spline.ndim,
        "nbasis": int(spline.coefficients.shape[-1]),
        "nsimplex": int(spline.coefficients.shape[0]),
        "metadata": spline.metadata,
    }
    if varying:
        head["nterms"] = int(spline.coefficients.shape[1])
    return head


def save_spline(spline, path, *, statistics: bool = True) -> Path:
    """Write ``spline`` to ``path`` (``.json`` or ``.npz``) atomically.

    ``statistics``: include the spline's statistics (if it has them, see
    :meth:`SimplexSpline.with_statistics`) in the optional ``statistics`` section.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".json", ".npz"):
        raise ModelFileError(f"model files end in .json or .npz, got {path.name!r}")
    if not path.parent.exists():
        raise ModelFileError(f"directory {str(path.parent)!r} does not exist")
    header = _header(spline)
    tri = spline.triangulation.to_arrays()
    arrays = {k: np.asarray(v) for k, v in tri.items() if k != "kind"}
    header["triangulation_kind"] = tri["kind"]
    try:
        json.dumps(header["metadata"], allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"metadata must be JSON-serialisable, without NaN or infinity "
                             f"(store those as None or strings): {exc}") from None
    unc = getattr(spline, "uncertainty", None) if statistics else None
    stats_arrays = {}
    if unc is not None:
        header["statistics"], stats_arrays = unc.state()
    if suffix == ".json":
        doc = dict(header)
        doc["triangulation"] = {k: v.tolist() for k, v in arrays.items()}
        doc["coefficients"] = spline.coefficients.tolist()
        if unc is not None:
            doc["statistics"] = dict(header["statistics"],
                                     **{k: v.tolist() for k, v in stats_arrays.items()})
        data = json.dumps(doc, allow_nan=False).encode()
        write_bytes(path, data)
    else:
        arrays["coefficients"] = spline.coefficients
        arrays.update({f"{STATS_PREFIX}{k}": v for k, v in stats_arrays.items()})
        arrays["header"] = np.array(json.dumps(header, allow_nan=False))
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        write_bytes(path, buf.getvalue())
    return path


def _check_header(doc: dict, path: Path) -> None:
    if not isinstance(doc, dict) or doc.get("format") not in (FORMAT, VARYING_FORMAT):
        raise ModelFileError(f"{path}: not a simplexspline model file (no format "
                             f"{FORMAT!r} or {VARYING_FORMAT!r} header)")
    version = doc.get("version")
    if version != VERSION:
        raise ModelFileError(
            f"{path}: model file version {version!r} is not supported by this simplexspline "
            f"(which reads version {VERSION}); upgrade simplexspline or re-save the model")


def read_model(path) -> ModelRecord:
    """Read a model file (either format, either kind) into a :class:`ModelRecord`.

    Checks the format and version header; builds no objects (the classes do:
    :meth:`SimplexSpline.load`, :meth:`VaryingCoefficientSpline.load`,
    :func:`~simplexspline.spline.formats.loading.load_spline`).

    Raises
    ------
    ModelFileError
        Missing, corrupt or foreign file, or an unsupported version.
    """
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"model file {str(path)!r} does not exist")
    try:
        stats_arrays = {}
        if path.suffix.lower() == ".npz":
            with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
                doc = json.loads(str(z["header"]))
                _check_header(doc, path)
                arrays = {k: z[k] for k in z.files if k != "header"}
            stats_arrays = {k[len(STATS_PREFIX):]: v for k, v in arrays.items()
                            if k.startswith(STATS_PREFIX)}
            coefficients = arrays["coefficients"]
            tri = {k: v for k, v in arrays.items()
                   if k != "coefficients" and not k.startswith(STATS_PREFIX)}
        else:
            doc = json.loads(path.read_text(encoding="utf-8"))
            _check_header(doc, path)
            tri = {k: np.asarray(v) for k, v in doc["triangulation"].items()}
            coefficients = np.asarray(doc["coefficients"], dtype=float)
        tri["kind"] = doc.get("triangulation_kind", "explicit")
        statistics = doc.get("statistics")
        header = {k: v for k, v in doc.items()
                  if k not in ("triangulation", "coefficients", "statistics")}
        return ModelRecord(path, header, tri, coefficients, statistics, stats_arrays,
                           has_statistics="statistics" in doc)
    except ModelFileError:
        raise
    except (OSError, ValueError, KeyError, TypeError, AttributeError, IndexError,
            zipfile.BadZipFile, EOFError, RecursionError) as exc:
        raise ModelFileError(f"{path}: corrupt or unreadable model file "
                             f"({type(exc).__name__}: {str(exc)[:200]})") from None
    except MemoryError:
        raise ModelFileError(f"{path}: the model file declares arrays too large for this "
                             "machine's memory: it is damaged or hostile") from None
