"""Units of imported records: pint unit strings converted to the schema's SI units.

A flight-test record names its units as people write them ('deg', 'knot', 'ft', 'g0' for
standard gravity, 'degC', 'lb', 'slug ft^2', 'deg/s'); :func:`conversion` turns one into a
function that maps values to the schema's unit, refusing a unit pint does not know or one of
another dimension. Offset units (degC, degF) are converted as absolute temperatures. The pint
registry is built once per process (about 1-2 s; it is the only cost of using pint).

>>> f = conversion("knot", "m/s")
>>> round(float(f(100.0)), 4)
51.4444
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


#: Schema unit tags that pint spells differently.
_SCHEMA_TAGS = {"-": "dimensionless", "": "dimensionless"}


@lru_cache(maxsize=1)
def registry():
    """The process's pint :class:`~pint.UnitRegistry` (built on first use)."""
    import pint  # optional dependency (the 'aero' extra); slow to import, so only when used

    return pint.UnitRegistry()


def _unit(text: str):
    import pint  # optional dependency (the 'aero' extra), already loaded by registry()

    ureg = registry()
    spelled = _SCHEMA_TAGS.get(text.strip(), text)
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
    src, dst = _unit(unit), _unit(target)
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
