"""Units of imported records: pint unit strings converted to the schema's SI units.

A flight-test record names its units as people write them ('deg', 'knot', 'ft', 'g0' for
standard gravity, 'degC', 'lb', 'slug ft^2', 'deg/s'); :func:`conversion` turns one into a
function that maps values to the schema's unit, refusing a unit pint does not know or one of
another dimension. Offset units (degC, degF) are converted as absolute temperatures. The
spellings of flight-test channel lists are read as they mean: '[deg]' (brackets dropped),
'fpm', 'pph', 'mach', 'deg C', and, for an acceleration, 'g' (standard gravity, not the
gram) and, for a temperature, 'C' or 'F'. The pint
registry is built once per process (about 1-2 s; it is the only cost of using pint).

>>> f = conversion("knot", "m/s")
>>> round(float(f(100.0)), 4)
51.4444
>>> float(conversion("[g]", "m/s^2")(1.0))
9.80665
>>> round(quantity("322 ft^2", "m^2"), 3)
29.915
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache

import numpy as np

from simplexspline.errors import InputError

__all__ = ["registry", "conversion", "quantity", "UnitError"]


class UnitError(InputError):
    """A unit string that is unknown or of the wrong dimension (message names both)."""


#: Schema unit tags and flight-test spellings that pint spells differently (or not at
#: all): a record's channel list says 'fpm', 'pph', 'mach' or '[-]'.
_SCHEMA_TAGS = {"-": "dimensionless", "": "dimensionless", "none": "dimensionless",
                "mach": "dimensionless", "fpm": "ft/min", "pph": "lb/hour",
                "deg c": "degC", "deg_c": "degC", "deg f": "degF", "deg_f": "degF"}
#: Spellings that mean one thing for a quantity of one dimension: 'g' is a gram to pint but
#: the standard gravity on every accelerometer channel list; 'C' and 'F' are coulomb and
#: farad but Celsius and Fahrenheit on a temperature channel.
_BY_DIMENSION = {"[length] / [time] ** 2": {"g": "g0", "gs": "g0", "g's": "g0"},
                 "[temperature]": {"c": "degC", "f": "degF"}}


@lru_cache(maxsize=1)
def registry():
    """The process's pint :class:`~pint.UnitRegistry` (built on first use)."""
    import pint  # optional dependency (the 'aero' extra); slow to import, so only when used

    return pint.UnitRegistry()


def _spelling(text: str, dimension: str | None = None) -> str:
    """``text`` as pint spells it: enclosing brackets dropped ('[deg]' as channel lists
    write units), flight-test tags (:data:`_SCHEMA_TAGS`) and, for a quantity of
    ``dimension``, its own spellings (:data:`_BY_DIMENSION`) translated."""
    t = text.strip()
    while len(t) > 1 and (t[0], t[-1]) in (("[", "]"), ("(", ")")):
        t = t[1:-1].strip()
    key = t.lower()
    if dimension is not None and key in _BY_DIMENSION.get(dimension, {}):
        return _BY_DIMENSION[dimension][key]
    return _SCHEMA_TAGS.get(key, t)


def _unit(text: str, dimension: str | None = None):
    import pint  # optional dependency (the 'aero' extra), already loaded by registry()

    ureg = registry()
    spelled = _spelling(text, dimension)
    try:
        return ureg.Unit(spelled)
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError, ValueError,
            TypeError, AttributeError, AssertionError) as exc:
        raise UnitError(f"unknown unit {text!r} ({exc}); write it as pint spells it, e.g. "
                        "'deg', 'deg/s', 'knot', 'ft', 'g0', 'degC', 'lb', 'slug*ft^2'") from None


@lru_cache(maxsize=256)
def conversion(unit: str, target: str) -> Callable[[np.ndarray], np.ndarray]:
    """A function converting values in ``unit`` to ``target`` (both pint strings).

    Raises
    ------
    UnitError
        If either unit is unknown or the dimensions differ.
    """
    import pint  # optional dependency (the 'aero' extra), already loaded by registry()

    ureg = registry()
    dst = _unit(target)
    src = _unit(unit, str(dst.dimensionality))
    if src.dimensionality != dst.dimensionality:
        raise UnitError(f"unit {unit!r} is a {src.dimensionality} but {target!r} "
                        f"({dst.dimensionality}) is needed")
    try:
        ureg.Quantity(1.0, src).to(dst)
    except pint.errors.DimensionalityError as exc:  # pragma: no cover - checked above
        raise UnitError(str(exc)) from None

    def convert(values):
        return np.asarray(ureg.Quantity(np.asarray(values, dtype=float), src).to(dst).magnitude,
                          dtype=float)

    return convert


def quantity(text, target: str) -> float:
    """A scalar with its unit, e.g. ``'322 ft^2'``, in the ``target`` unit.

    A bare number is refused: an aircraft constant without a unit is the classic source of
    feet read as metres.
    """
    import pint  # optional dependency (the 'aero' extra), already loaded by registry()

    if isinstance(text, bool) or not isinstance(text, str):
        raise UnitError(f"{text!r} has no unit: write the value with its unit as a string, "
                        f"e.g. \"{text} {target}\"")
    ureg = registry()
    try:
        q = ureg.Quantity(text)
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError, ValueError,
            TypeError, AttributeError, AssertionError) as exc:
        raise UnitError(f"cannot read {text!r} as a value with a unit ({exc})") from None
    if not isinstance(q, ureg.Quantity) or q.unitless:
        raise UnitError(f"{text!r} has no unit: write the value with its unit, e.g. "
                        f"\"{text} {target}\"")
    target_unit = _unit(target)
    if q.dimensionality != target_unit.dimensionality:
        raise UnitError(f"{text!r} is a {q.dimensionality} but a {target_unit.dimensionality} "
                        f"({target}) is needed")
    value = float(q.to(target_unit).magnitude)
    if not np.isfinite(value):
        raise UnitError(f"{text!r} is not a finite number")
    return value
