"""Stability and control derivatives from the exact gradients of identified models.

The partial derivatives of an :class:`~simplexspline.aero.modelling.model.AeroModel` are exact: the
B-form gradient of the spline in the unit box, times the inverse spans of the variable
scaling (the chain rule through :class:`~simplexspline.aero.modelling.structure.Scaling`). This
module turns them into the classical derivatives (``Cm_alpha``, ``Cl_beta``, ``Cn_dr``,
``Cm_q`` ...) at any flight conditions, as a table (:func:`derivatives`, wide or long, see
:func:`long_table`). The plots across the envelope are in
:mod:`~simplexspline.aero.derivatives.plots`.

Conventions (docs/derivatives.md):

* A derivative ``<C>_<v>`` is the partial derivative of coefficient ``C`` with respect to
  variable ``v`` holding the model's other variables fixed, in SI units: per radian for
  angles and surface deflections (``Cm_alpha`` [1/rad]), per unit Mach for ``mach``.
* Rates: ``phat = p b / 2V``, ``qhat = q cbar / 2V``, ``rhat = r b / 2V`` (as computed by
  :func:`~simplexspline.aero.data.coefficients.aerodynamic_coefficients`). ``Cl_p``, ``Cm_q``,
  ``Cn_r`` are per non-dimensional rate (the classical convention); ``Cl_p_dim``,
  ``Cm_q_dim``, ``Cn_r_dim`` are per rad/s, ``dC/dq = dC/dqhat * cbar / 2V``.
* A variable the model does not depend on gives exactly 0 (marked ``in_model = False``)
  wherever the model is defined; outside its domain every derivative of the model follows
  the ``outside`` policy (NaN by default; never the derivative at a clamped point).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simplexspline.aero.data.flight_data import without_metadata
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.aero.variables import CANDIDATE_VARIABLES, COEFFICIENTS, UNITS
from simplexspline.errors import InputError, ModelFileError, OutsideDomainError
from simplexspline.spline.geometry.outside import SPLINE_POLICIES

__all__ = [
    "RATE_CONVENTIONS",
    "condition_grid",
    "derivative_name",
    "derivative_unit",
    "derivatives",
    "load_models",
    "long_table",
    "reference_conditions",
]

#: How rate derivatives are reported: as the model has them, per non-dimensional rate
#: (classical ``Cm_q``), or per rad/s.
RATE_CONVENTIONS = ("native", "nondimensional", "dimensional")

#: Rate variables: name -> (axis, non-dimensional?).
_RATES = {"phat": ("p", True), "qhat": ("q", True), "rhat": ("r", True),
          "p": ("p", False), "q": ("q", False), "r": ("r", False)}
#: Reference length of each rate axis: ``xhat = x * length / (2 V)``.
_LENGTH = {"p": "b", "q": "cbar", "r": "b"}
#: Variables whose trim-like reference value is 0 (symmetric flight, no rates).
_ZERO = ("beta", "da", "dr", "phat", "qhat", "rhat", "p", "q", "r")
#: Derivative name suffix of a variable (default: the variable's name).
_SUFFIX = {"phat": "p", "qhat": "q", "rhat": "r", "p": "p_dim", "q": "q_dim", "r": "r_dim"}


# ---------------------------------------------------------------------------- names
def derivative_name(coefficient: str, variable: str) -> str:
    """Standard name of ``d coefficient / d variable``.

    Examples
    --------
    >>> derivative_name("Cm", "alpha"), derivative_name("Cm", "qhat")
    ('Cm_alpha', 'Cm_q')
    >>> derivative_name("Cm", "q"), derivative_name("Cn", "dr")
    ('Cm_q_dim', 'Cn_dr')
    """
    return f"{coefficient}_{_SUFFIX.get(variable, variable)}"


def derivative_unit(variable: str) -> str:
    """Unit of a (non-dimensional) coefficient's derivative with respect to ``variable``."""
    unit = UNITS.get(variable, "?")
    if unit == "-" or unit.startswith("- "):
        return "-"
    return {"rad": "1/rad", "rad/s": "s/rad", "m/s": "s/m", "rad/s^2": "s^2/rad"}.get(
        unit, f"1/({unit})" if "/" in unit or "^" in unit else f"1/{unit}")


def _same_axis(v: str, w: str) -> bool:
    """Model variable ``v`` contributes to the derivative with respect to ``w``."""
    return v == w or (v in _RATES and w in _RATES and _RATES[v][0] == _RATES[w][0])


def _axis(variable: str, rates: str) -> str:
    """The output variable that ``variable`` is reported as under ``rates``."""
    if variable not in _RATES or rates == "native":
        return variable
    axis, _ = _RATES[variable]
    return axis + "hat" if rates == "nondimensional" else axis


# ---------------------------------------------------------------------------- models
def load_models(sources, coefficients: Sequence[str] | None = None) -> dict:
    """Load aerodynamic models from identification output directories or model files.

    Parameters
    ----------
    sources : path or sequence of paths
        ``OUTDIR`` of ``simplexspline identify`` (its ``models/`` are read), a directory of
        model files, or model files (``.json`` / ``.npz``).
    coefficients : sequence of str, optional
        Keep only these coefficients (each must be present).

    Returns
    -------
    dict of str to AeroModel
        In the order CX, CY, CZ, Cl, Cm, Cn (others after).

    Raises
    ------
    ModelFileError
        A path that does not exist, a directory without model files, an unreadable file.
    InputError
        Two models of one coefficient, or a requested coefficient that is missing.
    """
    if isinstance(sources, (str, Path)):
        sources = [sources]
    files: list = []
    for src in map(Path, sources):
        if src.is_dir():
            folder = src / "models" if (src / "models").is_dir() else src
            found = sorted(p for p in folder.iterdir()
                           if p.suffix.lower() in (".json", ".npz") and p.is_file()
                           and p.name not in ("summary.json",))
            if not found:
                raise ModelFileError(f"no model files (*.json, *.npz) in {str(folder)!r}: "
                                     "give the output directory of 'simplexspline identify' "
                                     "or model files")
            files += found
        elif src.is_file():
            files.append(src)
        else:
            raise ModelFileError(f"{str(src)!r} does not exist: give the output directory of "
                                 "'simplexspline identify' or model files")
    models: dict = {}
    for f in files:
        m = AeroModel.load(f)
        if m.coefficient in models:
            raise InputError(f"two models of {m.coefficient}: {models[m.coefficient][1]} and "
                             f"{f}; give one model per coefficient")
        models[m.coefficient] = (m, f)
    if coefficients is not None:
        missing = [c for c in coefficients if c not in models]
        if missing:
            raise InputError(f"no model of {missing} among the given files (found "
                             f"{sorted(models)})")
        models = {c: models[c] for c in coefficients}
    return {c: models[c][0] for c in _ordered(models)}


def _ordered(names) -> list:
    return ([c for c in COEFFICIENTS if c in names]
            + [c for c in names if c not in COEFFICIENTS])


def _as_models(models) -> dict:
    """AeroModel, sequence or mapping of them, an Identification, or paths -> dict."""
    if isinstance(models, AeroModel):
        return {models.coefficient: models}
    if hasattr(models, "results") and isinstance(getattr(models, "results"), Mapping):
        return {c: r.model for c, r in models.results.items()}
    if isinstance(models, (str, Path)):
        return load_models(models)
    if isinstance(models, Mapping):
        items = list(models.values())
    else:
        items = list(models)
    if items and all(isinstance(m, (str, Path)) for m in items):
        return load_models(items)
    out: dict = {}
    for m in items:
        if not isinstance(m, AeroModel):
            raise InputError(f"expected AeroModel objects or model files, got "
                             f"{type(m).__name__}")
        if m.coefficient in out:
            raise InputError(f"two models of {m.coefficient}; give one per coefficient")
        out[m.coefficient] = m
    if not out:
        raise InputError("no models given")
    return {c: out[c] for c in _ordered(out)}


def _variables(models: Mapping) -> list:
    seen = [v for m in models.values() for v in m.variables]
    order = [v for v in CANDIDATE_VARIABLES if v in seen]
    return order + [v for v in dict.fromkeys(seen) if v not in order]


# ---------------------------------------------------------------------------- conditions
def reference_conditions(models, data=None, overrides: Mapping | None = None) -> dict:
    """Trim-like reference values of every model variable (SI units).

    Parameters
    ----------
    models : AeroModel, sequence or mapping of AeroModel, or model paths
    data : DataFrame, optional
        Identification data: its medians are used.
    overrides : mapping, optional
        Values given by the user (they win; may add variables such as ``tas``).

    Returns
    -------
    dict of str to float
        Without ``data``: 0 for ``beta, da, dr`` and the rates (when 0 lies in every
        model's box), otherwise the sample-weighted mean of the simplex centroids of the
        identification data (``provenance['counts']``), i.e. about the data's mean; a
        model's ``provenance['medians']`` wins when it has them.
    """
    models = _as_models(models)
    out: dict = {}
    for v in _variables(models):
        having = [m for m in models.values() if v in m.variables]
        col = None if data is None or v not in getattr(data, "columns", ()) else \
            np.asarray(data[v], dtype=float)
        meds = [m.provenance.get("medians", {}).get(v) for m in having]
        meds = [float(x) for x in meds if isinstance(x, (int, float))]
        if col is not None and np.isfinite(col).any():
            out[v] = float(np.nanmedian(col))
        elif meds:
            out[v] = float(np.mean(meds))
        elif v in _ZERO and all(m.scaling.lower[m.variables.index(v)] <= 0.0
                                <= m.scaling.upper[m.variables.index(v)] for m in having):
            out[v] = 0.0
        else:
            out[v] = float(np.mean([_centre(m, v) for m in having]))
    for k, val in (overrides or {}).items():
        out[str(k)] = float(val)
    return out


def _centre(model: AeroModel, variable: str) -> float:
    """Sample-weighted mean of the simplex centroids along ``variable`` (physical); for a
    multiplier that is not a triangulation variable, the middle of its range."""
    if variable not in model.schedule:
        i = model.variables.index(variable)
        return 0.5 * (model.scaling.lower[i] + model.scaling.upper[i])
    tri = model.spline.triangulation
    cen = model.schedule_scaling.inverse(np.asarray(tri.vertices)[np.asarray(tri.simplices)]
                                         .mean(axis=1))[:, model.schedule.index(variable)]
    w = np.asarray(model.provenance.get("counts", ()), dtype=float)
    if w.shape != cen.shape or not w.sum() > 0:
        w = np.ones_like(cen)
    return float(np.sum(w * cen) / np.sum(w))


def condition_grid(models, axes: Mapping, reference: Mapping | None = None):
    """Flight conditions on the outer product of ``axes``, the rest at reference values.

    Parameters
    ----------
    models : AeroModel, sequence or mapping of AeroModel, or model paths
    axes : mapping of str to scalar or 1-D array
        Values per variable (SI units); arrays span the grid (the first varies slowest),
        scalars are fixed.
    reference : mapping, optional
        Values of the other variables (default :func:`reference_conditions`).

    Returns
    -------
    pandas.DataFrame
        One row per grid point, columns: the axes, then every other model variable.
    """
    import pandas as pd  # optional dependency (the 'aero' extra)

    models = _as_models(models)
    ref = reference_conditions(models) if reference is None else dict(reference)
    names = list(axes)
    values = [np.atleast_1d(np.asarray(axes[k], dtype=float)) for k in names]
    for k, v in zip(names, values):
        if v.ndim != 1 or not v.size or not np.all(np.isfinite(v)):
            raise InputError(f"grid values of {k!r} must be finite numbers, got {v!r}")
    mesh = np.meshgrid(*values, indexing="ij") if values else []
    table = {k: m.ravel() for k, m in zip(names, mesh)}
    nrow = len(next(iter(table.values()))) if table else 1
    for v in [*_variables(models), *ref]:
        if v in table or v not in ref or (v in _RATES and _twin(v) in names):
            continue    # a rate whose twin is an axis is derived from it, not fixed
        table[v] = np.full(nrow, float(ref[v]))
    return pd.DataFrame(table)


def _conditions(models: Mapping, at, reference: Mapping | None):
    import pandas as pd  # optional dependency (the 'aero' extra)

    given = {str(k): float(v) for k, v in (reference or {}).items()}
    ref = {**reference_conditions(models), **given}
    for v in _RATES:    # a user-given rate wins over the default of its twin
        if v in given and _twin(v) not in given:
            ref.pop(_twin(v), None)
    if at is None:
        return pd.DataFrame({k: [v] for k, v in ref.items()}), ref
    if isinstance(at, Mapping):
        return condition_grid(models, at, ref), ref
    if not hasattr(at, "columns"):
        raise InputError("at must be a DataFrame of flight conditions, a mapping of grid "
                         f"values or None, got {type(at).__name__}")
    return without_metadata(at), ref


# ---------------------------------------------------------------------------- derivatives
def derivatives(models, at=None, *, wrt: Sequence[str] | None = None,
                rates: str = "native", outside: str = "nan",
                geometry: Mapping | None = None, reference: Mapping | None = None,
                layout: str = "wide"):
    """Stability and control derivatives of identified models at flight conditions.

    Parameters
    ----------
    models : AeroModel, sequence or mapping of AeroModel, Identification, or model paths
    at : DataFrame, mapping or None
        Flight conditions: a DataFrame (one row per condition; columns it lacks are taken
        from ``reference``), a mapping ``variable -> values`` spanning a grid (see
        :func:`condition_grid`), or None (the reference condition only). SI units.
    wrt : sequence of str, optional
        Variables to differentiate with respect to (flight-data column names; default the
        union of the models' variables). A variable a model does not depend on gives 0.
    rates : {'native', 'nondimensional', 'dimensional'}
        Rate derivatives per the model's own rate variable; per non-dimensional rate
        (``Cm_q``, converted from a model in q [rad/s] with ``2 V / cbar``); or per rad/s
        (``Cm_q_dim``). Conversions need ``tas`` [m/s] (column or reference) and the
        ``geometry``.
    outside : {'nan', 'extrapolate', 'raise'}
        Conditions outside a model's domain (its kept simplices) give NaN derivatives of
        that model, the nearest simplex's polynomial's derivatives (flagged by
        ``inside_<C>``), or raise :class:`~simplexspline.OutsideDomainError`.
    geometry : mapping, optional
        ``b`` (span) and ``cbar`` (mean chord) [m] for rate conversions; default a model's
        ``provenance['geometry']``.
    reference : mapping, optional
        Values of variables missing from ``at`` (default :func:`reference_conditions`).
    layout : {'wide', 'long'}
        'wide': one row per condition: the conditions, one column per derivative and an
        ``inside_<C>`` flag per model; ``attrs['derivatives']`` describes each derivative
        (coefficient, variable, unit, in_model); ``samples_<C>`` counts the model's
        identification samples in the simplex holding the condition (when the model's
        provenance lists them; a coarse measure of data support). 'long': one row per
        condition and derivative with columns ``point, <conditions>, coefficient,
        variable, derivative, value, unit, in_model, inside, samples``.

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    InputError
        Unknown ``wrt`` variable, bad option, missing ``tas`` or geometry for a conversion.
    OutsideDomainError
        With ``outside='raise'``: conditions outside a model's domain.
    """
    models = _as_models(models)
    _check_options(rates, outside, layout)
    known = _variables(models)
    out_vars = _output_variables(known, wrt, rates)
    cond, ref = _conditions(models, at, reference)
    geo = _geometry(models, geometry)
    parts = {c: _model_derivatives(model, cond, ref, geo, out_vars, outside)
             for c, model in models.items()}
    parts.update(_wind_axis(models, parts, cond, ref, geo, out_vars, outside))
    shown = set(known) | set(out_vars) | {"tas"} | (set(at) if isinstance(at, Mapping) else set())
    table, cond_cols = _assemble(cond, parts, shown)
    table.attrs = {"derivatives": {k: v for p in parts.values() for k, v in p.info.items()},
                   "rates": rates, "outside": outside, "reference": ref, "geometry": geo,
                   "models": {c: m.structure.label() for c, m in models.items()},
                   "variables": {c: list(m.variables) for c, m in models.items()},
                   "nbasis": {c: m.structure.nbasis for c, m in models.items()}}
    return table if layout == "wide" else long_table(table, cond_cols)


def _wind_axis(models: Mapping, parts: Mapping, cond, ref: Mapping, geo: Mapping,
               out_vars: Sequence[str], outside: str) -> dict:
    """The lift-curve and drag slopes ``CL_alpha``, ``CD_alpha`` [1/rad] from the body-axis
    CX and CZ models, when both exist and alpha is among the derivatives: with
    ``CL = CX sin(alpha) - CZ cos(alpha)`` and ``CD = -CX cos(alpha) - CZ sin(alpha)``
    (stability axes, zero sideslip),

        CL_alpha = CX_alpha sin(a) + CX cos(a) - CZ_alpha cos(a) + CZ sin(a)
        CD_alpha = -CX_alpha cos(a) + CX sin(a) - CZ_alpha sin(a) - CZ cos(a)

    the total derivatives along alpha of the two models (CD includes thrust where the
    coefficients do: records without thrust channels or a thrust model). Empty otherwise."""
    if "alpha" not in out_vars or not {"CX", "CZ"} <= set(models):
        return {}
    vals, slopes, inside = {}, {}, []
    for c in ("CX", "CZ"):
        m = models[c]
        x, _speed = _inputs(m, cond, ref, geo, [])
        vals[c] = m.predict(x, outside="extrapolate" if outside == "extrapolate" else "nan")
        slopes[c] = parts[c].columns[derivative_name(c, "alpha")]
        inside.append(parts[c].inside)
    alpha = (np.asarray(cond["alpha"], dtype=float) if "alpha" in cond.columns
             else np.full(len(cond), float(ref["alpha"])))
    sa, ca = np.sin(alpha), np.cos(alpha)
    cx, cz, dcx, dcz = vals["CX"], vals["CZ"], slopes["CX"], slopes["CZ"]
    both = inside[0] & inside[1]
    out = {}
    for name, val in (("CL", dcx * sa + cx * ca - dcz * ca + cz * sa),
                      ("CD", -dcx * ca + cx * sa - dcz * sa - cz * ca)):
        key = derivative_name(name, "alpha")
        out[name] = _ModelDerivatives(
            {key: val}, {key: {"coefficient": name, "variable": "alpha",
                               "unit": derivative_unit("alpha"), "in_model": True,
                               "model_variables": ["CX", "CZ"]}}, both, None, {})
    return out


def _check_options(rates: str, outside: str, layout: str) -> None:
    if rates not in RATE_CONVENTIONS:
        raise InputError(f"rates must be one of {RATE_CONVENTIONS}, got {rates!r}")
    if outside not in SPLINE_POLICIES:
        raise InputError(f"outside must be one of {SPLINE_POLICIES}, got {outside!r} "
                         "(clamped inputs would give the derivative at another condition)")
    if layout not in ("wide", "long"):
        raise InputError(f"layout must be 'wide' or 'long', got {layout!r}")


def _output_variables(known: Sequence[str], wrt, rates: str) -> list:
    """The variables to differentiate with respect to, as reported under ``rates``."""
    if wrt is None:
        return list(dict.fromkeys(_axis(v, rates) for v in known))
    if isinstance(wrt, str):
        wrt = [w.strip() for w in wrt.split(",") if w.strip()]
    bad = [w for w in wrt if (w not in UNITS or w in COEFFICIENTS) and w not in known]
    if bad or not wrt:
        raise InputError(f"unknown variable(s) {bad or '(none given)'} in wrt; the "
                         f"models depend on {known}")
    return list(dict.fromkeys(_axis(w, rates) for w in wrt))


@dataclass
class _ModelDerivatives:
    """The derivatives of one model at N conditions.

    Attributes
    ----------
    columns : dict of str to ndarray, shape (N,)
        Derivative name -> values (SI units of :func:`derivative_unit`).
    info : dict of str to dict
        Derivative name -> coefficient, variable, unit, in_model, model_variables.
    inside : ndarray of bool, shape (N,)
        The condition lies in the model's domain.
    support : ndarray of int64, shape (N,), or None
        Identification samples in the simplex holding each condition (None when the
        model's provenance does not count them).
    inputs : dict of str to ndarray, shape (N,)
        Model inputs the conditions did not give (reference values, converted rates).
    """

    columns: dict
    info: dict
    inside: np.ndarray
    support: np.ndarray | None
    inputs: dict


def _model_derivatives(model: AeroModel, cond, ref: Mapping, geo: Mapping,
                       out_vars: Sequence[str], outside: str) -> _ModelDerivatives:
    """Locate the conditions in ``model``, take its gradient, scale it to ``out_vars``."""
    x, speed = _inputs(model, cond, ref, geo, out_vars)
    filled = {v: x[:, i] for i, v in enumerate(model.variables) if v not in cond.columns}
    sid = model.locate(x)
    ok = sid >= 0
    counts = np.asarray(model.provenance.get("counts", ()), dtype=np.int64)
    support = (np.where(ok, counts[np.maximum(sid, 0)], 0)
               if counts.shape == (model.spline.triangulation.nsimplex,) else None)
    if outside == "raise" and not ok.all():
        bad = np.nonzero(~ok)[0]
        raise OutsideDomainError(
            f"{len(bad)} of {len(cond)} conditions lie outside the domain of the "
            f"{model.structure.label()} model (first rows {bad[:5].tolist()}); use "
            "outside='nan' or 'extrapolate'", bad)
    g = model.gradient(x, outside="extrapolate" if outside == "extrapolate" else "nan")
    columns, info = _scaled(model, g, out_vars, speed, geo)
    return _ModelDerivatives(columns, info, ok, support, filled)


def _scaled(model: AeroModel, g: np.ndarray, out_vars: Sequence[str], speed, geo: Mapping):
    """The model's gradient ``g`` (N, n) as derivatives with respect to ``out_vars``: the
    columns of every model variable on the same axis, times d variable / d output variable
    (0 where the model is defined and depends on no such variable)."""
    c = model.coefficient
    defined = np.all(np.isfinite(g), axis=1)
    columns: dict = {}
    info: dict = {}
    for w in out_vars:
        name = derivative_name(c, w)
        val = np.where(defined, 0.0, np.nan)
        used = []
        for i, v in enumerate(model.variables):
            if _same_axis(v, w):
                val = val + g[:, i] * _factor(v, w, speed, geo, c)
                used.append(v)
        columns[name] = val
        info[name] = {"coefficient": c, "variable": w, "unit": derivative_unit(w),
                      "in_model": bool(used), "model_variables": used}
    return columns, info


def _assemble(cond, parts: Mapping, shown: set):
    """The wide table (without attrs) and its condition columns: the conditions (those
    among ``shown``, with the model inputs they lacked), the derivatives, ``inside_<C>`` and
    ``samples_<C>``."""
    import pandas as pd  # optional dependency (the 'aero' extra)

    extra: dict = {}
    for p in parts.values():
        for k, v in p.inputs.items():
            extra.setdefault(k, v)
    if extra:
        cond = cond.assign(**extra)
    cond_cols = [k for k in cond.columns if k in shown]
    table = pd.concat([cond[cond_cols].reset_index(drop=True),
                       pd.DataFrame({k: v for p in parts.values() for k, v in p.columns.items()}),
                       pd.DataFrame({f"inside_{c}": p.inside for c, p in parts.items()}),
                       pd.DataFrame({f"samples_{c}": p.support for c, p in parts.items()
                                     if p.support is not None}, index=range(len(cond)))],
                      axis=1)
    table.index = cond.index
    return table, cond_cols


def _geometry(models: Mapping, geometry: Mapping | None) -> dict:
    out: dict = {}
    for m in models.values():
        g = m.provenance.get("geometry")
        if isinstance(g, Mapping):
            out.update({k: float(g[k]) for k in ("b", "cbar") if k in g})
    for k, v in (geometry or {}).items():
        if k not in ("b", "cbar", "S"):
            raise InputError(f"unknown geometry key {k!r}; give b (span) and cbar (mean "
                             "aerodynamic chord) in metres")
        if not float(v) > 0:
            raise InputError(f"geometry {k} must be a positive length [m], got {v!r}")
        out[k] = float(v)
    return out


def _speed(cond, ref: Mapping, model: AeroModel) -> np.ndarray:
    if "tas" in cond.columns:
        v = np.asarray(cond["tas"], dtype=float)
    elif "tas" in ref:
        v = np.full(len(cond), float(ref["tas"]))
    else:
        raise InputError(f"converting the rate derivatives of the {model.coefficient} model "
                         "needs the true airspeed: give a 'tas' column or reference value "
                         "[m/s] (CLI: --at tas=...)")
    if not np.all(np.isfinite(v) & (v > 0)):
        raise InputError("the true airspeed 'tas' must be positive and finite")
    return v


def _length(geo: Mapping, axis: str, coefficient: str) -> float:
    key = _LENGTH[axis]
    if key not in geo:
        raise InputError(f"converting {coefficient}'s {axis} rate derivatives needs the "
                         f"reference length {key} [m]: give geometry={{'b': ..., 'cbar': "
                         "...}} (CLI: --geometry b=...,cbar=...)")
    return geo[key]


def _inputs(model: AeroModel, cond, ref: Mapping, geo: Mapping, out_vars: Sequence[str]):
    """The model's (N, n) inputs from the conditions (rate twins converted), and V [m/s]
    when a rate must be converted (else None)."""
    needs_v = any(v in _RATES and (any(_same_axis(v, w) and v != w for w in out_vars)
                                   or (v not in cond.columns and _twin(v) in cond.columns))
                  for v in model.variables)
    speed = _speed(cond, ref, model) if needs_v else None
    cols = []
    for v in model.variables:
        if v in cond.columns:
            cols.append(np.asarray(cond[v], dtype=float))
        elif v in _RATES and _twin(v) in cond.columns:
            axis, nondim = _RATES[v]
            k = _length(geo, axis, model.coefficient) / (2.0 * speed)
            tw = np.asarray(cond[_twin(v)], dtype=float)
            cols.append(tw * k if nondim else tw / k)
        elif v in ref:
            cols.append(np.full(len(cond), float(ref[v])))
        else:
            raise InputError(f"no value of {v!r} for the {model.coefficient} model: add a "
                             "column or a reference value")
    return model.inputs(np.column_stack(cols)), speed


def _twin(v: str) -> str:
    axis, nondim = _RATES[v]
    return axis if nondim else axis + "hat"


def _factor(v: str, w: str, speed, geo: Mapping, coefficient: str):
    """d v / d w for a model variable ``v`` reported as output variable ``w``."""
    if v == w:
        return 1.0
    axis, nondim = _RATES[v]
    k = _length(geo, axis, coefficient) / (2.0 * speed)    # xhat = x * k
    return k if nondim else 1.0 / k    # dxhat/dx = k ; dx/dxhat = 1/k


def long_table(table, condition_columns: Sequence[str]):
    """The long layout of a wide derivative table: one row per condition and derivative.

    Parameters
    ----------
    table : pandas.DataFrame
        A wide table of :func:`derivatives` (N conditions, with its ``attrs``).
    condition_columns : sequence of str
        The columns of ``table`` that describe the conditions (kept in every row).

    Returns
    -------
    pandas.DataFrame
        N x (number of derivatives) rows, columns ``point, <conditions>, coefficient,
        variable, derivative, value, unit, in_model, inside`` (and ``samples`` and
        ``standard_error`` when the table has them: ``samples_<C>``, ``se_<name>``); the
        same ``attrs``.
    """
    import pandas as pd  # optional dependency (the 'aero' extra)

    info = table.attrs["derivatives"]
    parts = []
    for name, d in info.items():
        part = table[list(condition_columns)].copy()
        part.insert(0, "point", np.arange(len(table)))
        part["coefficient"] = d["coefficient"]
        part["variable"] = d["variable"]
        part["derivative"] = name
        part["value"] = table[name].to_numpy()
        part["unit"] = d["unit"]
        part["in_model"] = d["in_model"]
        part["inside"] = table[f"inside_{d['coefficient']}"].to_numpy()
        if f"samples_{d['coefficient']}" in table.columns:
            part["samples"] = table[f"samples_{d['coefficient']}"].to_numpy()
        if f"se_{name}" in table.columns:
            part["standard_error"] = table[f"se_{name}"].to_numpy()
        parts.append(part)
    out = pd.concat(parts, ignore_index=True)
    out.attrs = dict(table.attrs)
    return out
