"""Lookup tables of identified models: a model evaluated on a tensor grid of breakpoints.

:func:`lookup_table` evaluates an :class:`~simplexspline.aero.modelling.model.AeroModel` (or a plain
:class:`~simplexspline.SimplexSpline`) at every point of a grid of breakpoints per variable,
with an outside policy, into a :class:`LookupTable`. :meth:`LookupTable.save` writes it as

* a CSV or npz n-D table with a JSON sidecar (:data:`TABLE_FORMAT`), or
* a JSBSim ``<function>`` holding a ``<table>`` (1-3 varying variables, the others fixed;
  properties from :data:`JSBSIM_PROPERTIES`), see :meth:`LookupTable.to_jsbsim`.

:func:`parse_grid` reads the command line's grid specifications and
:func:`model_variables` names a model's inputs. See docs/export.md.
"""

from __future__ import annotations

import io
import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from simplexspline._files import write_text, write_together
from simplexspline._version import __version__
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.aero.variables import UNITS
from simplexspline.errors import InputError
from simplexspline.spline.formats.c_export import reference_evaluate
from simplexspline.spline.space import SimplexSpline
from simplexspline.spline.geometry.outside import EXPORT_POLICIES, check_policy

__all__ = ["JSBSIM_PROPERTIES", "MAX_TABLE_POINTS", "TABLE_FORMAT", "TABLE_VERSION",
           "LookupTable", "lookup_table", "model_variables", "parse_grid"]

TABLE_FORMAT = "simplexspline.table"
TABLE_VERSION = 1

#: Largest number of grid points :func:`lookup_table` evaluates.
MAX_TABLE_POINTS = 20_000_000

#: JSBSim properties of the flight-data variables whose JSBSim units are ours (SI/rad).
#: Variables without one get ``simplexspline/<name>`` (define it, e.g. in a <system>).
JSBSIM_PROPERTIES = {
    "alpha": "aero/alpha-rad", "beta": "aero/beta-rad", "mach": "velocities/mach",
    "de": "fcs/elevator-pos-rad", "da": "fcs/aileron-pos-rad", "dr": "fcs/rudder-pos-rad",
    "p": "velocities/p-aero-rad_sec", "q": "velocities/q-aero-rad_sec",
    "r": "velocities/r-aero-rad_sec", "phi": "attitude/phi-rad",
    "theta": "attitude/theta-rad",
}


#: A JSBSim property path: names of letters, digits, '_' and '-' joined by '/', each with
#: an optional [index] (e.g. ``fcs/elevator-pos-rad``, ``propulsion/engine[0]/thrust-lbs``).
_PROPERTY = re.compile(r"[A-Za-z_][\w-]*(\[\d+\])?(/[A-Za-z_][\w-]*(\[\d+\])?)*", re.ASCII)

#: Characters XML 1.0 cannot hold at all, not even escaped.
_NOT_XML = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def _property(name, what: str) -> str:
    """``name`` checked as a JSBSim property path (it goes into the XML as it is)."""
    if not isinstance(name, str) or not _PROPERTY.fullmatch(name):
        raise InputError(f"{what} {name!r} is not a JSBSim property name: use names of "
                         "letters, digits, '_' and '-' joined by '/' (e.g. aero/qhat)")
    return name


def _xml_text(text) -> str:
    """Text an XML 1.0 document can hold (characters it cannot become U+FFFD)."""
    return _NOT_XML.sub("\ufffd", str(text))


def provenance_summary(obj):
    """A model's provenance (JSON-like) shortened for a comment or a sidecar: lists of
    more than 8 values become ``'<n values>'``; mappings get string keys."""
    if isinstance(obj, Mapping):
        return {str(k): provenance_summary(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        if len(obj) > 8:
            return f"<{len(obj)} values>"
        return [provenance_summary(v) for v in obj]
    return obj


# ---------------------------------------------------------------------- lookup tables
def parse_grid(spec: str) -> tuple[str, np.ndarray]:
    """Parse a grid specification ``name=start:stop:num`` (``num`` equally spaced values
    from start to stop inclusive) or ``name=v1,v2,...`` (or a single value).

    Examples
    --------
    >>> parse_grid("alpha=0:0.5:3")[1].tolist()
    [0.0, 0.25, 0.5]
    >>> parse_grid("mach=0.3,0.5,0.7")
    ('mach', array([0.3, 0.5, 0.7]))
    """
    name, sep, rest = str(spec).partition("=")
    name = name.strip()
    if not sep or not name or not rest.strip():
        raise InputError(f"grid {spec!r}: expected NAME=START:STOP:NUM or NAME=V1,V2,...")
    try:
        if ":" in rest:
            parts = rest.split(":")
            if len(parts) != 3:
                raise ValueError("three fields START:STOP:NUM")
            start, stop, num = float(parts[0]), float(parts[1]), parts[2].strip()
            if not num.isdigit() or int(num) < 1:
                raise ValueError(f"NUM must be a positive integer, got {num!r}")
            values = np.linspace(start, stop, int(num))
        else:
            values = np.array([float(v) for v in rest.split(",")])
    except ValueError as exc:
        raise InputError(f"grid {spec!r}: {exc}") from None
    return name, _breakpoints(name, values)


def _breakpoints(name: str, values) -> np.ndarray:
    try:
        bp = np.atleast_1d(np.asarray(values, dtype=float))
    except (TypeError, ValueError):
        raise InputError(f"breakpoints of {name!r} must be numbers") from None
    if bp.ndim != 1 or len(bp) == 0:
        raise InputError(f"breakpoints of {name!r} must be a non-empty 1-D list")
    if not np.all(np.isfinite(bp)):
        raise InputError(f"breakpoints of {name!r} must be finite")
    if np.any(np.diff(bp) <= 0):
        raise InputError(f"breakpoints of {name!r} must increase strictly, got "
                         f"{bp.tolist()[:8]}")
    return bp


@dataclass
class LookupTable:
    """A model evaluated on a tensor grid of breakpoints.

    Attributes
    ----------
    variables : tuple of str
    breakpoints : tuple of ndarray
        Strictly increasing breakpoints per variable.
    values : ndarray, shape ``tuple(len(b) for b in breakpoints)``
        The model at every grid point (index ``[i0, i1, ...]``).
    outside : ndarray of bool, same shape
        The grid point lies outside the model's domain (its value follows ``policy``).
    output : str
        Name of the tabulated quantity (e.g. ``'CZ'``).
    policy : str
        The outside policy used.
    units : dict
        Units of variables and output.
    info : dict
        Model label and provenance (JSON-serialisable).
    """

    variables: tuple
    breakpoints: tuple
    values: np.ndarray
    outside: np.ndarray
    output: str
    policy: str
    units: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple:
        return tuple(len(b) for b in self.breakpoints)

    def header(self) -> dict:
        """The JSON description (sidecar of CSV/npz tables)."""
        nout = int(self.outside.sum())
        return {
            "format": TABLE_FORMAT, "version": TABLE_VERSION,
            "software": f"simplexspline {__version__}",
            "output": self.output, "variables": list(self.variables),
            "units": self.units,
            "shape": list(self.shape),
            "breakpoints": {v: b.tolist() for v, b in zip(self.variables, self.breakpoints)},
            "layout": "values[i0, i1, ...] at (breakpoints[var0][i0], ...); CSV rows in C "
                      "order (the last variable varies fastest)",
            "outside_policy": self.policy,
            "outside_points": nout,
            "outside_note": _outside_note(self.policy, nout, int(self.values.size)),
            "model": self.info,
        }

    def save(self, path, *, properties: Mapping | None = None,
             function_name: str | None = None) -> list[Path]:
        """Write the table by suffix: ``.csv`` or ``.npz`` (+ a ``<name>.json`` sidecar)
        or ``.xml`` (JSBSim snippet, see :meth:`to_jsbsim`). Each file is written
        atomically; a table and its sidecar together (both new or both old). Returns the
        paths written."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in (".csv", ".npz", ".xml"):
            raise InputError(f"table files end in .csv, .npz or .xml, got {path.name!r}")
        if not path.parent.is_dir():
            raise InputError(f"directory {str(path.parent)!r} does not exist")
        if suffix == ".xml":
            text = self.to_jsbsim(properties=properties, function_name=function_name)
            write_text(path, text)
            return [path]
        header = self.header()
        if suffix == ".csv":
            table = self._csv().encode("utf-8")
        else:
            arrays = {"values": self.values, "outside": self.outside,
                      "header": np.array(json.dumps(header, allow_nan=False))}
            for k, b in enumerate(self.breakpoints):
                arrays[f"breakpoints_{k}"] = b
            buf = io.BytesIO()
            np.savez(buf, **arrays)
            table = buf.getvalue()
        sidecar = path.with_name(path.name + ".json")
        # a table and its sidecar are one: both new, or (after a failure) both as they were
        return write_together({path: table, sidecar: _json_text(header).encode("utf-8")})

    def _csv(self) -> str:
        grids = np.meshgrid(*self.breakpoints, indexing="ij")
        cols = [g.ravel() for g in grids] + [self.values.ravel()]
        flags = self.outside.ravel()
        out = [",".join([*self.variables, self.output, "outside"])]
        for row, flag in zip(zip(*cols), flags.tolist()):
            out.append(",".join(repr(float(v)) for v in row) + f",{int(flag)}")
        return "\n".join(out) + "\n"

    def to_jsbsim(self, *, properties: Mapping | None = None,
                  function_name: str | None = None) -> str:
        """The table as a JSBSim ``<function>`` holding a ``<table>`` (XML text).

        Variables with one breakpoint are fixed (named in the comment); the others (1 to
        3) become the table's ``row``, ``column`` and ``table`` lookups in model order.
        JSBSim interpolates linearly between breakpoints and clamps at the edges.

        Parameters
        ----------
        properties : mapping of str to str, optional
            JSBSim property per variable (overrides :data:`JSBSIM_PROPERTIES`; variables
            without one get ``simplexspline/<name>``, which the simulation must define).
        function_name : str, optional
            Default ``aero/coefficient/<output>``.
        """
        if np.any(np.isnan(self.values)):
            raise InputError(
                f"{int(np.isnan(self.values).sum())} table values are NaN (grid points "
                "outside the model's domain with outside='nan'); JSBSim tables cannot hold "
                "NaN: use outside='clamp' or 'extrapolate', or a grid inside the domain")
        props = {**JSBSIM_PROPERTIES, **dict(properties or {})}
        for var, prop in dict(properties or {}).items():
            _property(prop, f"the property of {var!r}")
        if function_name is not None:
            _property(function_name, "the function name")
        unknown = sorted(set(dict(properties or {})) - set(self.variables))
        if unknown:
            raise InputError(f"properties given for unknown variable(s) {unknown}; the "
                             f"table's variables are {list(self.variables)}")
        vary = [k for k, b in enumerate(self.breakpoints) if len(b) > 1]
        fixed = [k for k, b in enumerate(self.breakpoints) if len(b) == 1]
        if not 1 <= len(vary) <= 3:
            raise InputError(
                f"a JSBSim table takes 1 to 3 varying variables, this grid varies "
                f"{len(vary)} ({[self.variables[k] for k in vary]}): give single values "
                "for the others (e.g. --grid mach=0.6)")
        vals = self.values[tuple(slice(None) if k in vary else 0
                                 for k in range(len(self.variables)))]
        name = function_name or f"aero/coefficient/{self.output}"
        nout = int(self.outside.sum())
        comment = [
            f"Generated by simplexspline {__version__} from {self.info.get('label', '')}"
            .rstrip(),
            f"Output: {self.output} [{self.units.get(self.output, '?')}]",
            *(f"Fixed: {self.variables[k]} = {float(self.breakpoints[k][0])!r} "
              f"[{self.units.get(self.variables[k], '?')}]" for k in fixed),
            *(f"{('row', 'column', 'table')[i]}: {self.variables[k]} "
              f"[{self.units.get(self.variables[k], '?')}] -> {_prop(props, self.variables[k])}"
              for i, k in enumerate(vary)),
            f"Outside policy: {self.policy}: "
            + _outside_note(self.policy, nout, int(self.values.size)),
            "JSBSim interpolates linearly between breakpoints and holds the edge values "
            "outside them.",
        ]
        missing = [self.variables[k] for k in vary if self.variables[k] not in props]
        if missing:
            comment.append(f"Define the properties {[_prop(props, v) for v in missing]} "
                           "in the simulation (e.g. with a <function> in a <system>).")
        # no '--' inside a comment, however many dashes in a row
        text = "\n     ".join(re.sub("-(?=-)", "- ", _xml_text(c)) for c in comment)
        lines = [f"<!-- {text}\n-->", f'<function name="{escape(name, {chr(34): "&quot;"})}">',
                 f"  <description>{escape(_xml_text(self.info.get('label', self.output)))} "
                 "(simplexspline)</description>", "  <table>"]
        for i, k in enumerate(vary):
            lines.append(f'    <independentVar lookup="{("row", "column", "table")[i]}">'
                         f"{escape(_prop(props, self.variables[k]))}</independentVar>")
        bps = [self.breakpoints[k] for k in vary]
        if len(vary) == 1:
            lines.append("    <tableData>")
            lines += [f"      {_f(a)}  {_f(v)}" for a, v in zip(bps[0], vals)]
            lines.append("    </tableData>")
        elif len(vary) == 2:
            lines += _table2d(bps[0], bps[1], vals, "    ", "")
        else:
            for t, bp in enumerate(bps[2]):
                lines += _table2d(bps[0], bps[1], vals[:, :, t], "    ",
                                  f' breakPoint="{_f(bp)}"')
        lines += ["  </table>", "</function>"]
        return "\n".join(lines) + "\n"


def _json_text(doc: dict) -> str:
    """Indented JSON with lists of scalars kept on one line."""
    text = json.dumps(doc, indent=1, allow_nan=False)
    return re.sub(r"\[\s*([^\[\]{}]*?)\s*\]",
                  lambda m: "[" + re.sub(r",\s+", ", ", m.group(1)) + "]", text) + "\n"


def _prop(props: Mapping, var: str) -> str:
    return str(props.get(var, f"simplexspline/{var}"))


def _f(v) -> str:
    return repr(float(v))


def _table2d(rows, cols, vals, indent: str, attr: str) -> list[str]:
    cells = [[_f(v) for v in row] for row in vals]
    rlab = [_f(r) for r in rows]
    width = max(len(s) for s in [*rlab, *(_f(c) for c in cols), *sum(cells, [])])
    pad = " " * (width + 2)
    out = [f"{indent}<tableData{attr}>",
           f"{indent}  {pad}" + "  ".join(_f(c).rjust(width) for c in cols)]
    for lab, row in zip(rlab, cells):
        out.append(f"{indent}  {lab.rjust(width)}  " + "  ".join(c.rjust(width) for c in row))
    out.append(f"{indent}</tableData>")
    return out


def _outside_note(policy: str, nout: int, total: int) -> str:
    what = {"clamp": "their inputs were clamped to the identified box (inside it, points "
                     "in data-free simplices use the nearest simplex)",
            "nan": "their values are NaN",
            "extrapolate": "their values extrapolate the nearest simplex's polynomial"}
    return (f"{nout} of {total} grid points lie outside the model's domain"
            + (f"; {what[policy]}" if nout else ""))


def model_variables(model) -> tuple:
    """Input names of an AeroModel, or of a SimplexSpline (``metadata['variables']`` when
    it names every input, else ``x0, x1, ...``)."""
    if isinstance(model, AeroModel):
        return tuple(model.variables)
    meta = model.metadata.get("variables")
    if isinstance(meta, (list, tuple)) and len(meta) == model.ndim:
        return tuple(str(v) for v in meta)
    return tuple(f"x{k}" for k in range(model.ndim))


def lookup_table(model, grid, *, outside: str | None = None) -> LookupTable:
    """Evaluate a model on a tensor grid of breakpoints.

    Parameters
    ----------
    model : AeroModel or SimplexSpline
        A SimplexSpline's variables are ``metadata['variables']`` when present, else
        ``x0, x1, ...``.
    grid : mapping of str to array_like, or sequence of array_like
        Strictly increasing breakpoints per variable (physical units), by name or in the
        model's variable order; every variable needs at least one value.
    outside : {'clamp', 'nan', 'extrapolate'}, optional
        Policy at grid points outside the model's domain (default: ``'clamp'`` for an
        AeroModel, as :meth:`AeroModel.predict`; ``'nan'`` for a SimplexSpline, as
        :meth:`SimplexSpline.predict`; the spline's 'clamp' box is described in
        :mod:`simplexspline.spline.formats.c_export`).

    Returns
    -------
    LookupTable
    """
    if isinstance(model, AeroModel):
        variables = tuple(model.variables)
        policy = outside or "clamp"
        output = model.coefficient
        units = {v: UNITS.get(v, "?") for v in (*variables, output)}
        info = {"label": model.structure.label(),
                "provenance": provenance_summary(model.provenance)}
    elif isinstance(model, SimplexSpline):
        variables = model_variables(model)
        policy = outside or "nan"
        output = str(model.metadata.get("output", "y"))
        units = dict(model.metadata.get("units") or {})
        info = {"label": repr(model)}
    else:
        raise InputError(f"lookup_table needs an AeroModel or SimplexSpline, got "
                         f"{type(model).__name__}")
    check_policy(policy, EXPORT_POLICIES)
    if isinstance(grid, Mapping):
        extra = sorted(set(grid) - set(variables))
        missing = [v for v in variables if v not in grid]
        if extra or missing:
            raise InputError(
                f"the grid must give breakpoints for exactly the model's variables "
                f"{list(variables)}" + (f"; missing {missing}" if missing else "")
                + (f"; unknown {extra}" if extra else ""))
        bps = tuple(_breakpoints(v, grid[v]) for v in variables)
    else:
        grid = list(grid)
        if len(grid) != len(variables):
            raise InputError(f"the grid needs {len(variables)} breakpoint lists (for "
                             f"{list(variables)}), got {len(grid)}")
        bps = tuple(_breakpoints(v, g) for v, g in zip(variables, grid))
    shape = tuple(len(b) for b in bps)
    if math.prod(shape) > MAX_TABLE_POINTS:
        raise InputError(f"a grid of shape {list(shape)} has {math.prod(shape)} points; at "
                         f"most {MAX_TABLE_POINTS} are tabulated")
    pts = np.stack([g.ravel() for g in np.meshgrid(*bps, indexing="ij")], axis=1)
    if isinstance(model, AeroModel):
        values = model.predict(pts, outside=policy)
        out = ~model.inside(pts)
    else:
        values, _, out = reference_evaluate(model, pts, outside=policy, gradient=False)
    return LookupTable(variables, bps, values.reshape(shape), out.reshape(shape), output,
                       policy, units, info)
