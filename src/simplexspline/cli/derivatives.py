"""`simplexspline derivatives`: stability and control derivatives of identified models.

Reads the models of an identification (``OUTDIR`` or model files), evaluates the exact
derivatives (``Cm_alpha``, ``Cl_beta``, ``Cm_q`` ...) along alpha at a few Mach numbers, on
an alpha x Mach map, or at given flight conditions, and writes a CSV table (with a
``.csv.json`` description of its columns) and optionally a plot. docs/derivatives.md.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import warnings
from pathlib import Path

import numpy as np

from simplexspline._files import atomic_write, jsonable, write_text
from simplexspline._version import __version__
from simplexspline.aero.derivatives.jackknife import (
    FOLD_DIR,
    PRIMARY,
    load_fold_models,
    with_standard_errors,
)
from simplexspline.aero.derivatives.plots import plot_derivative_map, plot_derivatives
from simplexspline.aero.derivatives.stability import derivatives, load_models, long_table
from simplexspline.aero.variables import UNITS
from simplexspline.errors import InputError
from simplexspline.spline.geometry.outside import SPLINE_POLICIES

_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(deg/s|deg|rad/s|rad)?"
                     r"\s*$")


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the command's parser to ``sub``; :func:`run` executes it."""
    p = sub.add_parser(
        "derivatives",
        help="stability and control derivatives (Cm_alpha, Cl_beta, Cm_q, ...) of identified "
             "models across the envelope: CSV table and plot",
        description="Exact partial derivatives of identified aerodynamic models (the spline "
        "gradients through the variable scaling), in SI units per rad, at flight conditions "
        "along alpha at a few Mach numbers (default), on an alpha x Mach map (--map), or at "
        "the rows of a conditions file (--points). Variables not swept are held at "
        "trim-like reference values (0 for beta, da, dr and the rates; the identification "
        "data's centre for the others) unless given with --at. Numbers are SI (radians, "
        "m/s); angles may carry a 'deg' suffix: --alpha=-5:20:26deg, --at beta=2deg. "
        "Writes OUT.csv and OUT.csv.json (units and meaning of every column).",
    )
    p.add_argument("models", type=Path, nargs="+",
                   help="output directory of 'simplexspline identify' or model files")
    p.add_argument("-o", "--output", type=Path, required=True, help="output table (.csv)")
    p.add_argument("--plot", type=Path, default=None,
                   help="also plot the derivatives (.png, .pdf or .svg): lines per Mach "
                   "along alpha, or maps with --map")
    p.add_argument("--alpha", default=None, metavar="SPEC",
                   help="alpha values: START:STOP:NUM or V1,V2,..., radians unless suffixed "
                   "'deg' (e.g. --alpha=-5:20:26deg); default the models' alpha range, 41 "
                   "points")
    p.add_argument("--mach", default=None, metavar="SPEC",
                   help="Mach numbers (one line each; the map's axis with --map): V1,V2,... "
                   "or START:STOP:NUM; default 3 values across the models' Mach range (21 "
                   "with --map)")
    p.add_argument("--map", action="store_true",
                   help="a 2-D alpha x Mach grid (maps instead of lines in --plot)")
    p.add_argument("--points", type=Path, default=None,
                   help="flight conditions file (.csv or .parquet, SI units): derivatives at "
                   "its rows instead of a sweep")
    p.add_argument("--at", action="append", default=[], metavar="VAR=VALUE,...",
                   help="values of variables not swept, e.g. --at mach=0.5,beta=0,tas=170 "
                   "(repeatable)")
    p.add_argument("--wrt", default=None, metavar="VARS",
                   help="differentiate only with respect to these variables (comma-separated"
                   " column names, e.g. alpha,beta,qhat)")
    p.add_argument("--coefficients", default=None, help="comma-separated subset, e.g. Cm,Cn")
    p.add_argument("--rates", choices=("native", "nondimensional", "dimensional"),
                   default="native",
                   help="rate derivatives as the models have them (native, default), per "
                   "non-dimensional rate (Cm_q, per q cbar/2V) or per rad/s (Cm_q_dim); "
                   "conversions need tas (--at tas=...) and --geometry")
    p.add_argument("--geometry", default=None, metavar="b=...,cbar=...",
                   help="wing span b and mean aerodynamic chord cbar [m] for rate conversions")
    p.add_argument("--outside", choices=SPLINE_POLICIES, default="nan",
                   help="conditions outside a model's domain: NaN (default), the nearest "
                   "simplex's polynomial (flagged in inside_<C>), or an error")
    p.add_argument("--long", action="store_true",
                   help="long table: one row per condition and derivative")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    # let '--alpha -5:20:26deg' read as a value (argparse takes only plain negative numbers
    # for values; '--alpha=-5:20:26deg' works everywhere)
    if hasattr(p, "_negative_number_matcher"):
        p._negative_number_matcher = re.compile(r"^-\.?\d")
    return p


# ---------------------------------------------------------------------------- parsing
def parse_value(var: str, text: str, default_unit: str | None = None) -> float:
    """One value of ``var`` in SI units from text with an optional unit suffix."""
    m = _NUMBER.match(text)
    if not m:
        raise InputError(f"cannot read {text!r} as a value of {var} (a number with optional "
                         "suffix deg or rad)")
    value, suffix = float(m.group(1)), m.group(2) or default_unit
    unit = UNITS.get(var, "")
    if suffix in ("deg", "deg/s"):
        if unit not in ("rad", "rad/s") or (suffix == "deg/s") != (unit == "rad/s"):
            raise InputError(f"{var} [{unit or 'no unit'}] cannot take a {suffix!r} value "
                             f"({text!r})")
        return math.radians(value)
    if suffix in ("rad", "rad/s") and unit != suffix:
        raise InputError(f"{var} [{unit or 'no unit'}] cannot take a {suffix!r} value "
                         f"({text!r})")
    if unit == "rad" and abs(value) > math.pi / 2:
        raise InputError(f"{var} = {value:g} rad is not a plausible angle; values are SI "
                         f"(radians): for degrees write {m.group(1)}deg")
    return value


def parse_axis(var: str, text: str) -> np.ndarray:
    """Values of an axis: ``START:STOP:NUM`` or ``V1,V2,...``; a unit suffix at the end
    applies to every value (``-5:20:26deg``), or each value carries its own."""
    text = text.strip()
    m = re.search(r"(deg/s|deg|rad/s|rad)$", text)
    unit = m.group(1) if m else None
    body = text[:m.start()] if m else text
    if ":" in body:
        parts = body.split(":")
        if len(parts) != 3:
            raise InputError(f"{var} range {text!r} must be START:STOP:NUM")
        try:
            num = int(parts[2])
        except ValueError:
            raise InputError(f"{var} range {text!r}: NUM must be an integer count") from None
        if num < 1:
            raise InputError(f"{var} range {text!r}: NUM must be >= 1")
        lo, hi = (parse_value(var, p, unit) for p in parts[:2])
        return np.linspace(lo, hi, num)
    values = [parse_value(var, p, unit) for p in body.split(",") if p.strip()]
    if not values:
        raise InputError(f"no values of {var} in {text!r}")
    return np.asarray(values)


def parse_assignments(texts, *, what: str = "--at") -> dict:
    """``VAR=VALUE,...`` (repeatable) -> {var: SI value}."""
    out: dict = {}
    for text in texts:
        for item in (s for s in text.split(",") if s.strip()):
            if "=" not in item:
                raise InputError(f"{what} expects VAR=VALUE pairs, got {item!r}")
            k, v = (s.strip() for s in item.split("=", 1))
            out[k] = parse_value(k, v)
    return out


def _geometry(text: str | None) -> dict:
    if not text:
        return {}
    out = {}
    for item in (s for s in text.split(",") if s.strip()):
        if "=" not in item:
            raise InputError(f"--geometry expects b=...,cbar=... in metres, got {item!r}")
        k, v = (s.strip() for s in item.split("=", 1))
        try:
            out[k] = float(v)
        except ValueError:
            raise InputError(f"--geometry {k}: {v!r} is not a number of metres") from None
    return out


def _split(text: str | None):
    return None if text is None else [s.strip() for s in text.split(",") if s.strip()]


def _box(models, var: str):
    los = [m.scaling.lower[m.variables.index(var)] for m in models.values()
           if var in m.variables]
    his = [m.scaling.upper[m.variables.index(var)] for m in models.values()
           if var in m.variables]
    return (min(los), max(his)) if los else None


# ---------------------------------------------------------------------------- writing
def describe(table, sources) -> dict:
    """The ``.csv.json`` description of a derivative table's columns."""
    attrs = table.attrs
    info = attrs.get("derivatives", {})
    cols = {}
    for c in table.columns:
        if c in info:
            cols[c] = {"kind": "derivative", **info[c]}
        elif c.startswith("inside_"):
            cols[c] = {"kind": "flag", "unit": "-", "meaning": f"the condition lies in the "
                       f"domain of the {c[7:]} model (a simplex with identification data)"}
        elif c.startswith("se_") and c[3:] in info:
            cols[c] = {"kind": "standard_error", "unit": info[c[3:]]["unit"],
                       "meaning": f"jackknife standard error of {c[3:]} over "
                       f"{attrs.get('jackknife_folds')} refits without a fold of "
                       "identification maneuvers each (models/jackknife of the output)"}
        elif c.startswith("samples_"):
            cols[c] = {"kind": "support", "unit": "-", "meaning": "identification samples "
                       f"in the simplex of the {c[8:]} model holding the condition"}
        else:
            cols[c] = {"kind": "condition", "unit": UNITS.get(c, "?")}
    return jsonable({
        "format": "simplexspline.derivatives", "version": 1,
        "software": f"simplexspline {__version__}",
        "convention": "partial derivatives holding the model's other variables fixed; SI "
                      "units (per rad); Cl_p, Cm_q, Cn_r per non-dimensional rate (phat = p "
                      "b/2V, qhat = q cbar/2V, rhat = r b/2V); *_dim per rad/s; 0 for "
                      "variables a model does not depend on (in_model false); NaN outside a "
                      "model's domain with outside='nan'",
        "rates": attrs.get("rates"), "outside": attrs.get("outside"),
        "reference": attrs.get("reference"), "geometry": attrs.get("geometry"),
        "models": attrs.get("models"), "sources": [str(s) for s in sources],
        "columns": cols})


def _write_table(table, path: Path, sources, long: bool) -> None:
    meta = describe(table, sources)
    out = table
    if long:
        cond = [c for c, d in meta["columns"].items() if d["kind"] == "condition"]
        out = long_table(table, cond)
        meta["layout"] = "long"
        meta["long_columns"] = {"point": "row of the conditions", "value": "the derivative",
                                "in_model": "the model depends on the variable",
                                "inside": "the condition lies in the model's domain"}
    else:
        meta["layout"] = "wide"
    atomic_write(path, lambda p: out.to_csv(p, index=False, float_format="%.10g"))
    write_text(path.with_name(path.name + ".json"), json.dumps(meta, indent=1) + "\n")


# ---------------------------------------------------------------------------- command
def run(args: argparse.Namespace) -> int:
    """Run ``simplexspline derivatives`` with the parsed arguments; returns the exit code."""
    out: Path = args.output
    if out.suffix.lower() != ".csv":
        raise InputError(f"output {str(out)!r} must end in .csv")
    for path in (out, args.plot):
        if path is not None and not path.resolve().parent.is_dir():
            raise InputError(f"the directory of {str(path)!r} does not exist")
    if args.plot is not None and args.plot.suffix.lower() not in (".png", ".pdf", ".svg"):
        raise InputError(f"--plot {str(args.plot)!r} must end in .png, .pdf or .svg")
    if args.points is not None and (args.alpha or args.mach or args.map):
        raise InputError("--points gives the conditions: it cannot be combined with "
                         "--alpha, --mach or --map")
    if args.points is not None and args.plot is not None:
        raise InputError("--plot draws a sweep (alpha, Mach); it cannot be used with --points")
    models = load_models(args.models, _split(args.coefficients))
    fixed = parse_assignments(args.at)
    geometry = _geometry(args.geometry)
    if args.points is not None:
        at = _read_points(args.points)
    else:
        at = {}
        alpha_box, mach_box = _box(models, "alpha"), _box(models, "mach")
        if args.alpha is not None:
            at["alpha"] = parse_axis("alpha", args.alpha)
        elif "alpha" in fixed:
            if args.plot is not None:
                raise InputError("--plot draws along alpha: sweep it (--alpha) instead of "
                                 "fixing it with --at")
        elif alpha_box is not None:
            at["alpha"] = np.linspace(*alpha_box, 41)
        else:
            raise InputError("the models do not depend on alpha: give --alpha values or "
                             "--points")
        if args.mach is not None:
            at["mach"] = parse_axis("mach", args.mach)
        elif mach_box is not None and "mach" not in fixed:
            lo, hi = mach_box
            at["mach"] = (np.linspace(lo, hi, 21) if args.map
                          else np.round(lo + (hi - lo) * np.array([0.2, 0.5, 0.8]), 3))
        if args.map and len(np.atleast_1d(at.get("mach", []))) < 2:
            raise InputError("--map needs at least two Mach numbers (--mach START:STOP:NUM)")
        for k in at:
            if k in fixed:
                raise InputError(f"{k} is swept; it cannot also be fixed with --at")
        at.update(fixed)
    table = derivatives(models, at, wrt=_split(args.wrt), rates=args.rates,
                        outside=args.outside, geometry=geometry, reference=fixed)
    folds = _fold_models(args.models, set(models))
    if folds:
        table = with_standard_errors(table, folds, at, wrt=_split(args.wrt),
                                     rates=args.rates, geometry=geometry)
    _write_table(table, out, args.models, args.long)
    if args.plot is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)    # constrained-layout squeezes
            fig = (plot_derivative_map(table, ncols=4) if args.map
                   else plot_derivatives(table, ncols=4))
            fmt = args.plot.suffix.lower()[1:]
            atomic_write(args.plot, lambda p: fig.savefig(p, format=fmt, dpi=100))
    if not args.quiet:
        _print_summary(models, table, out, args, fixed, geometry)
    return 0


def _read_points(path: Path):
    import pandas as pd  # optional dependency (the 'aero' extra)

    if not path.is_file():
        raise InputError(f"conditions file {str(path)!r} does not exist")
    try:
        if path.suffix.lower() in (".parquet", ".pq"):
            return pd.read_parquet(path)
        if path.suffix.lower() == ".csv":
            return pd.read_csv(path)
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read conditions file {str(path)!r}: {exc}") from None
    raise InputError(f"conditions file {str(path)!r} must be .csv or .parquet")


def _print_summary(models, table, out: Path, args, fixed: dict, geometry: dict) -> None:
    info = table.attrs["derivatives"]
    inmodel = [k for k, d in info.items() if d["in_model"]]
    print(f"{out}: {len(table)} conditions x {len(info)} derivatives ({len(inmodel)} in the "
          f"models, {len(info) - len(inmodel)} identically 0); {out}.json describes the "
          "columns" + (f"; {args.plot}" if args.plot else ""))
    for c, model in models.items():
        for v, why in (model.provenance.get("not_identified") or {}).items():
            print(f"  {c}_{v} is not identified: the identification data could not tell {v} "
                  f"from {why.get('partner')} (VIF {float(why.get('vif', math.nan)):.0f}), and "
                  f"the model does not take {v}; its 0 is not a measurement")
        for term, box in (model.provenance.get("held_terms") or {}).items():
            where = ", ".join(f"{v} {_show(v, lo)}..{_show(v, hi)}" for v, lo, hi in
                              zip(model.schedule, box["lower"], box["upper"]))
            print(f"  {c}: the derivatives of its {term} term were measured only at {where};"
                  " beyond, they are held at their values there")
        for term, gaps in (model.provenance.get("held_gaps") or {}).items():
            where = "; ".join(f"{v} " + ", ".join(f"{_show(v, lo)}..{_show(v, hi)}"
                                                  for lo, hi in runs)
                              for v, runs in gaps.items())
            print(f"  {c}: the derivatives of its {term} term were not measured at {where}, "
                  "between conditions where they were; there they are interpolated")
        frac = float(np.mean(table[f"inside_{c}"]))
        if frac < 1:
            print(f"  {c}: {100 * (1 - frac):.0f} % of the conditions lie outside the "
                  f"model's domain ({'NaN' if args.outside == 'nan' else 'extrapolated'})")
    ref = derivatives(models, None, wrt=_split(args.wrt), rates=args.rates,
                      outside="extrapolate", geometry=geometry, reference=fixed)
    cond = ", ".join(f"{k} = {_show(k, ref[k].iloc[0])}" for k in ref.columns
                     if k not in ref.attrs["derivatives"]
                     and not k.startswith(("inside_", "samples_")))
    print(f"at the reference condition ({cond}):")
    # the models' coefficients, then the wind-axis lift and drag slopes derived from CX, CZ
    for c in dict.fromkeys(d["coefficient"] for d in ref.attrs["derivatives"].values()):
        items = [f"{k} = {ref[k].iloc[0]:.4g} {d['unit']}"
                 for k, d in ref.attrs["derivatives"].items()
                 if d["coefficient"] == c and d["in_model"]]
        if items:
            flag = "" if bool(ref[f"inside_{c}"].iloc[0]) else "  (outside the domain)"
            print(f"  {c}: " + ", ".join(items) + flag)
    for line in _jackknife_lines(args.models, set(models)):
        print(line)


def _fold_models(paths, coefficients: set) -> list:
    """The jackknife refits of the identification output among ``paths`` (one output:
    the models' own), restricted to ``coefficients``; [] without them."""
    outputs = [Path(p) for p in paths if (Path(p) / "models" / FOLD_DIR).is_dir()]
    if len(outputs) != 1 or len(paths) != 1:
        return []
    folds = [{c: m for c, m in f.items() if c in coefficients}
             for f in load_fold_models(outputs[0])]
    return [f for f in folds if f]


def _jackknife_lines(paths, coefficients: set) -> list:
    """identify's jackknife standard errors (``summary.json`` of an identification output
    among ``paths``, ``derivatives``) of the primary derivatives of ``coefficients``."""
    for path in paths:
        summary = Path(path) / "summary.json"
        if not summary.is_file():
            continue
        try:
            block = json.loads(summary.read_text()).get("derivatives")
            if block is None:       # an output of before stop 57, or derivative_folds = 0
                return []
            values = block["values"]
            rows = [(n, v) for n in PRIMARY if (v := values.get(n)) and v["in_model"]
                    and (v["coefficient"] in coefficients
                         or v["coefficient"] in ("CL", "CD") and {"CX", "CZ"} <= coefficients)]
            ref = ", ".join(f"{k} = {_show(k, float(x))}" for k, x in block["reference"].items())
            folds = int(block["folds"])
        except (ValueError, KeyError, TypeError, AttributeError):
            return [f"  ({summary}: no readable jackknife standard errors)"]
        if not rows:
            return []
        return ([f"identify's jackknife standard errors over {folds} folds of maneuvers, at "
                 f"the identification data's medians ({ref}; {summary}):"]
                + [f"  {n} = {v['value']:.4g} +- {v['standard_error']:.2g} {v['unit']}"
                   for n, v in rows])
    return []


def _show(var: str, value: float) -> str:
    if UNITS.get(var) == "rad":
        return f"{math.degrees(value):.3g} deg"
    return f"{value:.4g}"
