"""The open, versioned model file format (JSON or npz; no pickled objects).

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
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from simplexspline.errors import ModelFileError, SimplexSplineError

__all__ = ["save_spline", "load_spline", "FORMAT", "VERSION", "atomic_write"]

FORMAT = "simplexspline.model"
VERSION = 1
#: Format identifier of varying-coefficient models (coefficients of shape (J, K, d_hat));
#: readers that know only FORMAT refuse these files instead of misreading them.
VARYING_FORMAT = "simplexspline.varying-model"

#: npz array names of the optional statistics section start with this.
STATS_PREFIX = "statistics_"


def atomic_write(path, write) -> None:
    """Call ``write(tmp_path)`` for a temporary file next to ``path``, then rename it.

    A failed or interrupted write never leaves a partial file at ``path`` (nor the
    temporary file).
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _write_bytes(data: bytes):
    def write(tmp):
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    return write


def _header(spline) -> dict:
    from simplexspline._version import __version__

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
        json.dumps(header["metadata"])
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"metadata must be JSON-serialisable: {exc}") from None
    unc = getattr(spline, "_uncertainty", None) if statistics else None
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
        atomic_write(path, _write_bytes(data))
    else:
        arrays["coefficients"] = spline.coefficients
        arrays.update({f"{STATS_PREFIX}{k}": v for k, v in stats_arrays.items()})
        arrays["header"] = np.array(json.dumps(header, allow_nan=False))
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        atomic_write(path, _write_bytes(buf.getvalue()))
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


def _load_statistics(spline, section, arrays: dict, path: Path):
    """The optional statistics section as an Uncertainty (ModelFileError if invalid)."""
    from simplexspline.spline.uncertainty.intervals import Uncertainty

    if not isinstance(section, dict):
        raise ModelFileError(f"{path}: the statistics section must be an object")
    try:
        stats_arrays = {k[len(STATS_PREFIX):]: v for k, v in arrays.items()
                        if k.startswith(STATS_PREFIX)}
        return Uncertainty.from_state(spline.space, section, stats_arrays)
    except (SimplexSplineError, KeyError, TypeError, ValueError) as exc:
        raise ModelFileError(f"{path}: invalid statistics section: {exc}") from None


def load_spline(path):
    """Read a model file written by :func:`save_spline`."""
    from simplexspline.spline.function import SimplexSpline
    from simplexspline.spline.geometry.triangulation import Triangulation

    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"model file {str(path)!r} does not exist")
    try:
        if path.suffix.lower() == ".npz":
            with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
                doc = json.loads(str(z["header"]))
                _check_header(doc, path)
                arrays = {k: z[k] for k in z.files if k != "header"}
        else:
            doc = json.loads(path.read_text(encoding="utf-8"))
            _check_header(doc, path)
            arrays = {k: np.asarray(v) for k, v in doc["triangulation"].items()}
            arrays["coefficients"] = np.asarray(doc["coefficients"], dtype=float)
            if isinstance(doc.get("statistics"), dict):
                from simplexspline.spline.uncertainty.intervals import ARRAYS

                for k in ARRAYS:
                    if k in doc["statistics"]:
                        arrays[STATS_PREFIX + k] = np.asarray(doc["statistics"][k])
        tri_data = {k: v for k, v in arrays.items()
                    if k != "coefficients" and not k.startswith(STATS_PREFIX)}
        tri_data["kind"] = doc.get("triangulation_kind", "explicit")
        tri = Triangulation.from_arrays(tri_data)
        if doc["format"] == VARYING_FORMAT:
            from simplexspline.spline.varying import VaryingCoefficientSpline

            coef = np.asarray(arrays["coefficients"], dtype=float)
            shape = (tri.nsimplex, int(doc["nterms"]), int(doc["nbasis"]))
            if coef.shape != shape:
                raise ModelFileError(f"{path}: coefficients of shape {coef.shape}, expected "
                                     f"{shape}")
            return VaryingCoefficientSpline(tri, doc["degree"], doc["continuity"], coef,
                                            metadata=doc.get("metadata") or {})
        spline = SimplexSpline(tri, doc["degree"], doc["continuity"],
                               arrays["coefficients"], metadata=doc.get("metadata") or {})
        if "statistics" in doc:
            spline._uncertainty = _load_statistics(spline, doc["statistics"], arrays, path)
        return spline
    except ModelFileError:
        raise
    except SimplexSplineError as exc:
        raise ModelFileError(f"{path}: invalid model contents: {exc}") from None
    except (OSError, ValueError, KeyError, TypeError, zipfile.BadZipFile,
            json.JSONDecodeError, EOFError) as exc:
        raise ModelFileError(f"{path}: corrupt or unreadable model file "
                             f"({type(exc).__name__}: {exc})") from None
