"""`simplexspline export`: a model file as C code and/or a lookup table."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from simplexspline.aero.export.c_code import generate_aero_c, load_exportable
from simplexspline.aero.export.lookup_tables import lookup_table, model_variables, parse_grid
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.errors import InputError
from simplexspline.spline.formats.c_export import generate_c
from simplexspline.spline.geometry.outside import EXPORT_POLICIES


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the command's parser to ``sub``; :func:`run` executes it."""
    p = sub.add_parser(
        "export",
        help="export a model as dependency-free C99 code (value and gradient) and/or a "
             "lookup table (CSV, npz, JSBSim XML)",
        description="Export MODEL (an aerodynamic model from 'simplexspline identify' or "
        "any spline model file, .json or .npz) as C99 code evaluating the model and its "
        "gradient (--c DIR), and/or as a table of values on a grid of breakpoints "
        "(--table OUT with one --grid per variable; OUT ends in .csv or .npz, written with "
        "a OUT.json sidecar, or .xml for a JSBSim <function>/<table> of 1-3 varying "
        "variables). Files are written atomically. See docs/export.md.",
        epilog="example: simplexspline export models/CZ.json --c build/ --table cz.xml "
        "--grid alpha=-0.1:0.4:26 --grid de=-0.2,0,0.2 --grid mach=0.6",
    )
    p.add_argument("model", type=Path, metavar="MODEL", help="model file (.json or .npz)")
    p.add_argument("--c", dest="c_dir", type=Path, default=None, metavar="DIR",
                   help="write PREFIX.h and PREFIX.c into DIR (created if missing)")
    p.add_argument("--prefix", default=None,
                   help="C identifier prefix and file name (default: the coefficient in "
                   "lower case, e.g. 'cz', or the model file name)")
    p.add_argument("--single-header", action="store_true",
                   help="one stb-style header PREFIX.h instead of .h + .c")
    p.add_argument("--table", type=Path, default=None, metavar="OUT",
                   help="write a lookup table: OUT.csv or OUT.npz (+ OUT.json sidecar) or "
                   "OUT.xml (JSBSim)")
    p.add_argument("--grid", action="append", default=[], metavar="NAME=SPEC",
                   help="breakpoints of one variable for --table: NAME=START:STOP:NUM "
                   "(NUM values, ends included) or NAME=V1,V2,... or NAME=V (fixed); "
                   "one per model variable")
    p.add_argument("--outside", choices=EXPORT_POLICIES, default=None,
                   help="outside-domain policy: the C default and the table's (default: "
                   "clamp for aerodynamic models, nan for plain splines)")
    p.add_argument("--property", action="append", default=[], metavar="NAME=PROP",
                   help="JSBSim property of a variable for .xml tables (e.g. "
                   "qhat=aero/qhat), repeatable")
    p.add_argument("--function-name", default=None,
                   help="name of the JSBSim <function> (aero/coefficient/<C>)")
    p.add_argument("-q", "--quiet", action="store_true", help="no output")
    return p


def _default_prefix(model, path: Path) -> str:
    stem = model.coefficient.lower() if isinstance(model, AeroModel) else path.stem
    name = re.sub(r"[^A-Za-z0-9_]", "_", stem).strip("_") or "model"
    return name if name[0].isalpha() else f"m_{name}"


def _pairs(items, option: str) -> dict:
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise InputError(f"{option} {item!r}: expected NAME=VALUE")
        out[name.strip()] = value.strip()
    return out


def _grid(args, variables) -> dict:
    grid = {}
    for spec in args.grid:
        name, values = parse_grid(spec)
        if name in grid:
            raise InputError(f"--grid {name} is given twice")
        if name not in variables:
            raise InputError(f"--grid {name}: the model has no variable {name!r}; its "
                             f"variables are {list(variables)}")
        grid[name] = values
    missing = [v for v in variables if v not in grid]
    if missing:
        raise InputError(f"--table needs a --grid for every model variable; missing "
                         f"{missing} (variables: {list(variables)})")
    return grid


def run(args: argparse.Namespace) -> int:
    """Run ``simplexspline export`` with the parsed arguments; returns the exit code."""
    if args.c_dir is None and args.table is None:
        raise InputError("nothing to export: give --c DIR and/or --table OUT")
    if args.table is None and (args.grid or args.property or args.function_name):
        raise InputError("--grid, --property and --function-name need --table")
    if args.table is not None and args.table.suffix.lower() != ".xml" and (
            args.property or args.function_name):
        raise InputError("--property and --function-name apply to JSBSim tables (.xml)")
    if args.table is not None and args.table.suffix.lower() not in (".csv", ".npz", ".xml"):
        raise InputError(f"--table {str(args.table)!r}: the file must end in .csv, .npz "
                         "or .xml")
    model = load_exportable(args.model)
    aero = isinstance(model, AeroModel)
    log = (lambda msg: None) if args.quiet else print
    written = []
    if args.table is not None:  # check the grid before writing anything
        table = lookup_table(model, _grid(args, model_variables(model)),
                             outside=args.outside)
        xml_opts = {}
        if args.table.suffix.lower() == ".xml":
            xml_opts = {"properties": _pairs(args.property, "--property"),
                        "function_name": args.function_name}
            table.to_jsbsim(**xml_opts)  # validates before any C file is written
    if args.c_dir is not None:
        prefix = args.prefix or _default_prefix(model, args.model)
        if aero:
            code = generate_aero_c(model, prefix, outside=args.outside or "clamp",
                                   single_header=args.single_header)
        else:
            code = generate_c(model, prefix, outside=args.outside or "nan",
                              single_header=args.single_header)
        written += code.write(args.c_dir)
    if args.table is not None:
        written += table.save(args.table, **xml_opts)
        nout = int(table.outside.sum())
        if nout:
            log(f"note: {nout} of {table.values.size} grid points lie outside the model's "
                f"domain (outside policy: {table.policy})")
    for path in written:
        log(f"wrote {path}")
    return 0

