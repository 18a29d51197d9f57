"""Preset model structures (``preset(name)``): the knowledge-free starting structures of the
search (``'auto'``, the default), the paper's, hand-picked varying-coefficient ones
(``'varying'``), and varying-coefficient ones on the JSBSim F-16 table breakpoints
(``'f16'``, prior knowledge of one aircraft's database: never a default)."""

from __future__ import annotations

import numpy as np

from simplexspline.aero.modelling.auto import AUTO_PRESET
from simplexspline.aero.modelling.structure import Structure
from simplexspline.errors import InputError

__all__ = ["AUTO_PRESET", "F16_PRESET", "PAPER_PRESET", "PRESETS", "VARYING_PRESET", "preset"]


#: The paper's model structures (Section IV.E), all S^1_3, plus CY which the paper could
#: not identify. ``qhat, phat, rhat`` are the non-dimensional rates.
PAPER_PRESET = {
    "CX": Structure("CX", ("alpha", "de", "mach")),
    "CY": Structure("CY", ("alpha", "beta", "dr")),
    "CZ": Structure("CZ", ("alpha", "de", "mach")),
    "Cl": Structure("Cl", ("alpha", "beta", "da", "phat", "rhat")),
    "Cm": Structure("Cm", ("alpha", "qhat", "de")),
    "Cn": Structure("Cn", ("alpha", "beta", "dr")),
}


def _vc(label_parts: dict, cellwise: bool = False) -> dict:
    """Varying-coefficient structures from (variables, multipliers, degree, continuity,
    resolution, knots) per coefficient."""
    out = {}
    for c, (variables, mult, d, r, res, knots) in label_parts.items():
        out[c] = Structure(c, variables, d, r, res or (), mult, tuple(knots.items()), cellwise)
    return out


_DEG = np.pi / 180.0
#: Breakpoints of the JSBSim F-16 aerodynamic tables (aircraft/f16/f16.xml): alpha every
#: 5 deg from -10 to 45, beta every 5 deg, elevator -25/-12.5/0/12.5/25 deg, and per
#: coefficient the Mach breakpoints of its Mach tables.
_F16_ALPHA = tuple(np.arange(-10.0, 46.0, 5.0) * _DEG)
_F16_BETA = tuple(np.arange(-30.0, 31.0, 5.0) * _DEG)
_F16_DE = tuple(np.array([-25.0, -12.5, 0.0, 12.5, 25.0]) * _DEG)

#: Varying-coefficient structures: ``C = sum_k m_k s_k(schedule)``, linear in the controls
#: and rates with coefficients that vary over the envelope (the form of most aerodynamic
#: databases), S^1_3 on uniform grids: for any aircraft. ``beta*beta`` carries the
#: sideslip's second-order effect on the body-axis X and Z forces (wind to body axes),
#: ``|beta|`` and ``|de|`` the kink at zero of drag tables that are linear in the size of
#: the sideslip and of the elevator deflection (the global5000's: its CX error against the
#: truth fell from 1.3e-3 to 2.1e-4), ``mass`` the moving centre of gravity (fuel burn) in
#: the pitching moment about it.
VARYING_PRESET = _vc({
    "CX": (("alpha", "de", "mach"), ("1", "qhat", "beta*beta", "|beta|", "|de|"), 3, 1,
           (3, 2, 2), {}),
    "CY": (("alpha", "mach"), ("1", "beta", "da", "dr", "phat", "rhat"), 3, 1, (3, 2), {}),
    "CZ": (("alpha", "de", "mach"), ("1", "qhat", "beta*beta", "|beta|", "|de|"), 3, 1,
           (3, 2, 2), {}),
    "Cl": (("alpha", "beta", "mach"), ("1", "phat", "rhat", "da", "dr"), 3, 1, (3, 2, 1), {}),
    "Cm": (("alpha", "de", "mach"), ("1", "qhat", "mass"), 3, 1, (3, 2, 2), {}),
    "Cn": (("alpha", "beta", "mach"), ("1", "phat", "rhat", "da", "dr"), 3, 1, (3, 2, 1), {}),
})

#: The varying-coefficient structures with grids on the breakpoints of the JSBSim F-16
#: tables (prior knowledge of the aerodynamic database's grid: its tables are piecewise
#: bilinear, so C^0 quadratics, one per grid cell, contain them; the aileron and rudder
#: derivatives of Cl are tabulated every 10 deg of sideslip, the rest every 5), the leading-edge flap
#: as a multiplier (the simulated FCS moves it in steps) and the mass in all three moments
#: (the fuel tanks sit below and behind the empty-weight centre of gravity, so fuel burn
#: moves the moment reference: Cl and Cn pick up the side force times the shift).
F16_PRESET = _vc({
    "CX": (("alpha", "de", "mach"), ("1", "qhat", "flap", "beta*beta", "qhat*flap"), 2, 0,
           None, {"alpha": _F16_ALPHA, "de": _F16_DE, "mach": (0.81,)}),
    "CY": (("alpha", "mach"), ("1", "beta", "da", "dr", "phat", "rhat"), 2, 0, None,
           {"alpha": _F16_ALPHA, "mach": (0.4,)}),
    "CZ": (("alpha", "de", "mach"), ("1", "qhat", "flap", "beta*beta"), 2, 0, None,
           {"alpha": _F16_ALPHA, "de": _F16_DE, "mach": (0.81,)}),
    "Cl": (("alpha", "beta", "mach"), ("1", "phat", "rhat", "da{beta@-30:30:10deg}",
                                         "dr{beta@-30:30:10deg}", "mass"), 2, 0, None,
           {"alpha": _F16_ALPHA, "beta": _F16_BETA, "mach": (0.6, 0.8)}),
    "Cm": (("alpha", "de", "mach"), ("1", "qhat", "flap", "mass"), 2, 0, None,
           {"alpha": _F16_ALPHA, "de": _F16_DE, "mach": (0.6, 0.8, 0.9)}),
    "Cn": (("alpha", "beta", "mach"), ("1", "phat", "rhat", "da", "dr", "mass"), 2, 0, None,
           {"alpha": _F16_ALPHA, "beta": _F16_BETA, "mach": (0.6, 0.7, 0.8, 0.9)}),
}, cellwise=True)

#: Named presets.
PRESETS = {"auto": AUTO_PRESET, "paper": PAPER_PRESET, "varying": VARYING_PRESET,
           "f16": F16_PRESET}


def preset(name: str = "auto") -> dict:
    """The named preset structures as a dict coefficient -> Structure: ``'auto'`` (the
    default: knowledge-free varying-coefficient starting structures, see
    :mod:`simplexspline.aero.modelling.auto`), ``'paper'`` (the paper's Section IV.E, plain
    S^1_3 splines), ``'varying'`` (hand-picked varying-coefficient S^1_3 on uniform grids)
    or ``'f16'`` (varying-coefficient S^0_2 on the JSBSim F-16 table breakpoints)."""
    if name not in PRESETS:
        raise InputError(f"unknown structure preset {name!r}; available: {sorted(PRESETS)}")
    return dict(PRESETS[name])
