"""Display helpers shared by the identification report's figures and pages.

The plot names and display units of the flight-data columns (angles in radians are shown
in degrees), reading a flight-data column as floats, number and percentage formatting,
HTML and Markdown escaping, and the HTML and Markdown tables of
:mod:`~simplexspline.aero.report.page`.
"""

from __future__ import annotations

import re
from simplexspline.aero.variables import UNITS

import html
import math

import numpy as np

#: Plot names of the flight-data columns (plain text, no mathtext: faster).
_NAMES = {
    "alpha": "\u03b1", "beta": "\u03b2", "de": "\u03b4e", "da": "\u03b4a", "dr": "\u03b4r",
    "mach": "M", "tas": "V", "h": "h", "p": "p", "q": "q", "r": "r",
    "phat": "pb/2V", "qhat": "qc/2V", "rhat": "rb/2V", "phi": "\u03c6", "theta": "\u03b8",
}

#: Display conversion of angular units (radians are shown in degrees).
_DISPLAY = {"rad": ("deg", 180.0 / math.pi), "rad/s": ("deg/s", 180.0 / math.pi),
            "rad/s^2": ("deg/s^2", 180.0 / math.pi)}


def _esc(value) -> str:
    return html.escape(str(value), quote=True)


def _md(value) -> str:
    """Text for a Markdown table cell (no HTML, no pipes, one line)."""
    return _md_text(value).replace("|", "\\|")


#: Characters that would make Markdown syntax out of data (code spans, emphasis, links).
_MD_SYNTAX = re.compile(r"([\\`*_\[\]])")

#: Line breaks of CommonMark (and the Unicode ones Python's splitlines knows).
_LINE_BREAKS = re.compile(r"[\r\n\v\f\x1c-\x1e\x85\u2028\u2029]+")


def _md_text(value) -> str:
    """Text for a Markdown paragraph: no raw HTML (``&`` and ``<`` as entities), no
    Markdown syntax from data (backslash, backtick, ``*``, ``_``, ``[``, ``]`` escaped) and
    no line break (one space: a paragraph reflows anyway, and a new line could start a
    heading, list or quote), so a hostile variable name renders as the text it is."""
    text = _LINE_BREAKS.sub(" ", str(value)).replace("&", "&amp;").replace("<", "&lt;")
    return _MD_SYNTAX.sub(r"\\\1", text)


def _md_code(value) -> str:
    """``value`` as one Markdown code span whose fence is longer than any run of backticks
    inside it (CommonMark), so data cannot close the span early."""
    text = _LINE_BREAKS.sub(" ", str(value))
    run = max((len(m) for m in re.findall(r"`+", text)), default=0)
    fence = "`" * (run + 1)
    pad = " " if run else ""
    return f"{fence}{pad}{text}{pad}{fence}"


def _unit(var: str) -> tuple[str, float]:
    """(display unit, factor from SI) of a flight-data column."""
    unit = UNITS.get(var, "")
    if unit in _DISPLAY:
        return _DISPLAY[unit]
    if var in ("phat", "qhat", "rhat") or unit.startswith("-"):
        return "-", 1.0
    return unit, 1.0


def _label(var: str) -> str:
    unit, _ = _unit(var)
    name = _NAMES.get(var, var)
    return f"{name} [{unit}]" if unit else name


def _disp(var: str, values) -> np.ndarray:
    return np.asarray(values, dtype=float) * _unit(var)[1]


def _fmt(x, spec: str = ".4g") -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return "" if x is None else str(x)
    if not math.isfinite(v):
        return "n/a" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return format(v, spec)


def _pct(x, digits: int = 2) -> str:
    s = _fmt(None if x is None else 100.0 * float(x), f".{digits}f")
    return s + " %" if s not in ("", "n/a", "inf", "-inf") else s


def _column(df, name: str) -> np.ndarray | None:
    if df is None or name not in df.columns:
        return None
    return df[name].to_numpy(dtype=float)


def _cell(x) -> tuple[str, str]:
    """(text, css class) of a table cell given as text or (text, class)."""
    return (str(x[0]), x[1]) if isinstance(x, tuple) else (str(x), "")
