"""The text notation of model structures: breakpoints and multipliers (terms).

Breakpoints: ``START:STOP:STEP`` or ``V1/V2/...``, optionally ending in ``deg`` (angles).

A multiplier (one term of a varying-coefficient structure) is an expression, the product
of data columns or their absolute values (``beta*beta``, ``|de|``; ``1`` for the constant
term), or the absolute value of a column's distance from a breakpoint (``|mach-0.62|``,
``|alpha+0.05|``, in the column's units: a kink there, the hinge ``max(0, v - k)`` of
adaptive regression splines up to a part linear in ``v``), optionally followed by

- ``[v1/v2]``: the scheduling variables the term depends on (constant along the others;
  ``[]``: a constant coefficient);
- ``{v@KNOTS; w@KNOTS}``: the term's own breakpoints, a subset of the model's breakpoints
  of those variables. Across the grid planes of the model's other breakpoints of ``v``
  the term is one polynomial (no kink there), e.g. ``dr{beta@-30:30:10deg}`` in a model on
  a 5 deg beta grid: a rudder derivative tabulated every 10 deg of sideslip.
"""

from __future__ import annotations

import re

import numpy as np

from simplexspline.aero.variables import UNITS
from simplexspline.errors import InputError

__all__ = ["format_knots", "format_multiplier", "multiplier_factors", "multiplier_parts",
           "normal_multiplier", "parse_knots", "parse_multiplier", "split_multiplier"]


def _is_angle(variable: str) -> bool:
    return UNITS.get(variable) == "rad"


def format_knots(variable: str, knots) -> str:
    """Breakpoints as label text: ``START:STOP:STEP`` when equally spaced (3 or more),
    else ``V1/V2/...``; angles in whole degrees get a ``deg`` suffix."""
    vals = np.asarray(knots, dtype=float)
    suffix = ""
    if _is_angle(variable):
        deg = np.degrees(vals)
        if np.allclose(deg, np.round(deg, 3), rtol=0, atol=1e-9):
            vals, suffix = np.round(deg, 3), "deg"

    def f(v):
        return f"{float(v):g}"

    steps = np.diff(vals)
    if len(vals) >= 3 and np.allclose(steps, steps[0], rtol=1e-9, atol=1e-12):
        return f"{f(vals[0])}:{f(vals[-1])}:{f(steps[0])}{suffix}"
    return "/".join(f(v) for v in vals) + suffix


def parse_knots(variable: str, text: str) -> tuple:
    """Inverse of :func:`format_knots`: ``'-10:25:5deg'`` or ``'0.6/0.8'`` -> radians or
    physical values."""
    spec = text.strip()
    scale = 1.0
    if spec.endswith("deg"):
        spec, scale = spec[:-3], np.pi / 180.0
    try:
        if ":" in spec:
            start, stop, step = (float(p) for p in spec.split(":"))
            if not step > 0 or stop < start:
                raise ValueError("STEP must be > 0 and STOP >= START")
            n = int(np.floor((stop - start) / step + 1e-9)) + 1
            vals = start + step * np.arange(n)
        else:
            vals = np.array([float(p) for p in spec.split("/") if p.strip()])
    except ValueError as exc:
        raise InputError(f"cannot read the breakpoints {text!r} of {variable!r} ({exc}); "
                         "write START:STOP:STEP or V1/V2/..., optionally ending in 'deg'") \
            from None
    return tuple(float(v) for v in vals * scale)


def parse_multiplier(name: str) -> tuple:
    """A multiplier's expression, the variables its term depends on (None: all) and its
    own breakpoints (variable -> tuple, physical units):
    ``'dr[alpha/beta]{beta@-30:30:10deg}'`` -> ('dr', ('alpha', 'beta'), {'beta': (...)}).
    """
    text = name.strip()
    knots = {}
    if text.endswith("}"):
        head, brace, spec = text[:-1].partition("{")
        if not brace or "{" in spec or "}" in spec:
            raise InputError(f"multiplier {name!r}: write the term's breakpoints as "
                             "'name{var@KNOTS; var2@KNOTS}'")
        for part in (p.strip() for p in spec.split(";")):
            var, at, ks = part.partition("@")
            var = var.strip()
            if not at or not var or var in knots:
                raise InputError(f"multiplier {name!r}: the term's breakpoints must be "
                                 "distinct 'var@KNOTS' entries separated by ';'")
            knots[var] = parse_knots(var, ks)
        text = head.strip()
    elif "{" in text or "}" in text:
        raise InputError(f"multiplier {name!r}: the term's breakpoints '{{...}}' come last")
    expr, bracket, rest = text.partition("[")
    if not bracket:
        return expr.strip(), None, knots
    if not rest.endswith("]"):
        raise InputError(f"multiplier {name!r}: write the term's variables as "
                         "'name[var1/var2]'")
    return expr.strip(), tuple(v.strip() for v in rest[:-1].split("/") if v.strip()), knots


def split_multiplier(name: str) -> tuple:
    """A multiplier's expression and the variables its term depends on (None: all):
    ``'phat[alpha]'`` -> ('phat', ('alpha',)), ``'da'`` -> ('da', None)."""
    return parse_multiplier(name)[:2]


def format_multiplier(expr: str, dims=None, knots=None) -> str:
    """The canonical text of a multiplier from its parts (see :func:`parse_multiplier`)."""
    text = "*".join(_format_factor(*_factor(f)) for f in expr.split("*"))
    if dims is not None:
        text += f"[{'/'.join(dims)}]"
    if knots:
        text += "{" + "; ".join(f"{v}@{format_knots(v, k)}" for v, k in knots.items()) + "}"
    return text


def normal_multiplier(name) -> str:
    """The canonical text of a multiplier (spaces removed, breakpoints reformatted)."""
    return format_multiplier(*parse_multiplier(str(name)))


#: ``column``, ``column-K`` or ``column+K`` inside ``|...|`` (K a decimal number).
_SHIFTED = re.compile(r"^\s*([^\s+\-|*]+?)\s*(?:([+-])\s*((?:\d+\.?\d*|\.\d+)"
                      r"(?:[eE][+-]?\d+)?))?\s*$")


def _factor(text: str) -> tuple:
    """One factor of a multiplier's expression: (column, absolute value?, breakpoint);
    ``'|mach-0.6|'`` -> ('mach', True, 0.6), ``'de'`` -> ('de', False, 0.0)."""
    f = text.strip()
    absolute = len(f) > 2 and f[0] == f[-1] == "|"
    if not absolute:
        return f, False, 0.0
    inner = f[1:-1]
    match = _SHIFTED.match(inner)
    if match is None:
        return inner.strip(), True, 0.0             # rejected by multiplier_parts
    col, sign, num = match.groups()
    shift = 0.0 if num is None else float(num) * (1.0 if sign == "-" else -1.0)
    return col, True, shift + 0.0                   # -0.0 -> 0.0


def _format_factor(col: str, absolute: bool, shift: float) -> str:
    if not absolute:
        return col
    if shift == 0:
        return f"|{col}|"
    return f"|{col}{'-' if shift > 0 else '+'}{abs(shift):.6g}|"


def multiplier_parts(name: str) -> tuple:
    """The factors of a multiplier as (data column, absolute value?, breakpoint)
    triples: ``'da'`` -> (('da', False, 0.0),), ``'|beta|*qhat'`` -> (('beta', True, 0.0),
    ('qhat', False, 0.0)), ``'dr*|mach-0.6|'`` -> (('dr', False, 0.0), ('mach', True,
    0.6)): the factor is ``|column - breakpoint|`` when absolute, else the column."""
    expr = split_multiplier(name)[0]
    if expr == "1":
        return ()
    out = []
    for f in expr.split("*"):
        col, absolute, shift = _factor(f)
        if not col or any(c in col for c in "|+- "):
            raise InputError(f"multiplier {name!r}: factors are data columns, their "
                             "absolute values '|beta|' or distances from a breakpoint "
                             "'|mach-0.6|'")
        out.append((col, absolute, shift))
    return tuple(out)


def multiplier_factors(name: str) -> tuple:
    """The data columns whose product a multiplier is: ``'1'`` -> (), ``'da'`` ->
    ('da',), ``'beta*beta'`` -> ('beta', 'beta'), ``'phat[alpha]'`` -> ('phat',),
    ``'|de|'`` -> ('de',) (the absolute value of the elevator deflection),
    ``'beta*|mach-0.6|'`` -> ('beta', 'mach')."""
    return tuple(col for col, _, _ in multiplier_parts(name))
