"""Knowledge-free model structures: where the structure search starts on any aircraft, and
which terms it may try.

Nothing here knows an aircraft. The starting structures are the generic varying-coefficient
form of aerodynamic models, ``C = sum_k m_k s_k(alpha, mach)``: coefficients that vary over
the flight envelope (angle of attack and Mach number), multiplying the rates and controls
that the data hold. The one piece of physics used is the mirror symmetry of aircraft about
their x-z plane: the longitudinal coefficients (CX, CZ, Cm) are even in the lateral
variables (beta, p, r, aileron, rudder), the lateral ones (CY, Cl, Cn) odd. So a
longitudinal coefficient may get ``beta*beta`` or ``|beta|`` but not ``beta``, and a
lateral coefficient gets the lateral variables linearly, their dependence on the
longitudinal state coming from the scheduling. Which terms stay, which variables schedule
the coefficients and how finely is decided by cross-validation
(:mod:`simplexspline.aero.selection.search`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from simplexspline.aero.modelling.notation import (format_multiplier, multiplier_factors,
                                                  split_multiplier)
from simplexspline.aero.modelling.structure import Structure
from simplexspline.aero.variables import (
    CANDIDATE_VARIABLES,
    COEFFICIENTS,
    LATERAL_COEFFICIENTS,
    LATERAL_VARIABLES,
    THRUST_VARIABLES,
)
from simplexspline.errors import InputError

__all__ = ["AUTO_PRESET", "EVEN_LATERAL", "SCHEDULING_CANDIDATES", "breaks_symmetry",
           "candidate_terms", "linear_start", "restrict_to_data"]

#: Lateral variables whose even terms (``v*v`` and ``|v|``) a longitudinal coefficient may
#: get: the sideslip and the lateral controls (drag grows with the size of each).
EVEN_LATERAL: tuple[str, ...] = ("beta", "da", "dr")

#: Variables that may schedule the coefficients (be a dimension of the triangulation): the
#: continuous flight state and controls, and the thrust coefficient or its fuel-flow stand-in
#: (a control's effectiveness growing with the slipstream). The rates enter linearly (small-perturbation
#: derivatives vary with the state, not with the rate itself).
SCHEDULING_CANDIDATES: tuple[str, ...] = ("alpha", "mach", "beta", "de", "da", "dr", "flap",
                                          *THRUST_VARIABLES)

_LONGITUDINAL_START = ("1", "qhat", "de")
_LATERAL_START = ("1", "beta", "phat", "rhat", "da", "dr")


def _start(coefficient: str) -> Structure:
    mult = _LATERAL_START if coefficient in LATERAL_COEFFICIENTS else _LONGITUDINAL_START
    return Structure(coefficient, ("alpha", "mach"), 3, 1, (3, 1), mult)


#: Starting structures of the knowledge-free search (preset ``'auto'``, the default):
#: varying-coefficient S^1_3 splines over alpha (3 grid cells) and Mach, multiplying the
#: constant, ``qhat`` and the elevator (CX, CZ, Cm) or sideslip, roll and yaw rates and the
#: lateral controls (CY, Cl, Cn). Columns the data lack are left out
#: (:func:`restrict_to_data`).
AUTO_PRESET: dict[str, Structure] = {c: _start(c) for c in COEFFICIENTS}


def linear_start(structure: Structure, constant: bool = False) -> Structure:
    """``structure``'s terms with constant multipliers: a linear model in its terms and in
    its scheduling variables (one cell of degree 0 over its first variable, no knots; the
    scheduling variables of the coefficient's own parity join the multipliers). A
    structure without multipliers (a plain spline) becomes one linear polynomial over its
    variables.

    Where the structure search starts when its cross-validation cannot score any of the
    maneuvers that move the coefficient (``identify``): a scheduled term must then earn
    its place on the maneuvers that are scored, instead of being kept because nothing
    could test it. The scheduling variables stay as linear terms: a pitching moment
    ``Cm0 + Cm_q qhat + Cm_de de`` without the angle of attack has no pitch stiffness,
    and on a flight-test course its elevator derivative took the trim curve (the
    elevator and alpha move together between stationary points), so the search dropped
    the elevator too and the model's Cm_alpha was 0. The lateral coefficients do not get
    alpha or Mach (their linear terms are odd in the lateral variables).

    Examples
    --------
    >>> s = linear_start(AUTO_PRESET["Cn"])
    >>> (s.variables, s.degree, s.resolution, s.multipliers)
    (('alpha',), 0, (1,), ('1', 'beta', 'phat', 'rhat', 'da', 'dr'))
    >>> linear_start(AUTO_PRESET["Cm"]).multipliers
    ('1', 'qhat', 'de', 'alpha', 'mach')
    >>> linear_start(AUTO_PRESET["Cm"], constant=True).multipliers
    ('1', 'qhat[]', 'de[]', 'alpha[]', 'mach[]')

    With ``constant``, every term but the constant keeps a constant coefficient when the
    search later refines or schedules the structure (``[]``,
    :mod:`~simplexspline.aero.modelling.notation`); terms without dimensions or
    breakpoints of their own only. ``identify`` starts so where its cross-validation
    scores none of the maneuvers that excite the coefficient: how a derivative changes
    across the envelope is what such a search cannot test. On a six-test-point course of
    a straight-wing jet whose one elevator doublet moved alpha with the elevator, a model
    scheduled on three alpha cells let the elevator's coefficient vary with alpha, and in
    the middle cell, where the turns' trim changes moved alpha and elevator together, it
    took the trim curve: Cm_de -0.04 against the doublet's -0.56 by least squares (the
    simulator's -0.96), and Cm_alpha 0.01 (truth -0.70).
    """
    if not structure.multipliers:
        n = len(structure.variables)
        return Structure(structure.coefficient, structure.variables, degree=1, continuity=0,
                         resolution=(1,) * n, cellwise=True)
    lateral = structure.coefficient in LATERAL_COEFFICIENTS
    own = tuple(v for v in structure.variables if (v in LATERAL_VARIABLES) == lateral
                and v not in structure.multipliers)
    terms = structure.multipliers + own
    if constant:
        terms = tuple(m if m == "1" or "[" in m or "{" in m else format_multiplier(m, ())
                      for m in terms)
    return Structure(structure.coefficient, structure.variables[:1], degree=0, continuity=-1,
                     resolution=(1,), multipliers=terms)


def candidate_terms(coefficient: str, available: Sequence[str],
                    allowed: Sequence[str] = CANDIDATE_VARIABLES) -> tuple[str, ...]:
    """The multipliers the search may add to a varying-coefficient model of ``coefficient``.

    Parameters
    ----------
    coefficient : str
        ``'CX'``, ..., ``'Cn'``.
    available : sequence of str
        Columns present (and varying) in the identification data.
    allowed : sequence of str
        Variables the user lets the search use (:class:`SelectionSettings.candidates`).

    Returns
    -------
    tuple of str
        Linear terms of the variables of the coefficient's own parity (lateral variables
        for CY, Cl, Cn; the others for CX, CZ, Cm); for a longitudinal coefficient also
        ``v*v`` and ``|v|`` of the sideslip and lateral controls. The thrust coefficient
        and its stand-ins (:data:`~simplexspline.aero.variables.THRUST_VARIABLES`) are
        offered to every coefficient: a propeller's torque and swirl break the airframe's
        mirror symmetry. On a Cessna 172 course of six test points with a maneuver list
        the roll moment's model went from 9.27x to 4.99x the noise against the truth
        (its stationary validation holds Cl at zero while the aileron trims the torque).

    Examples
    --------
    >>> candidate_terms("Cm", ["alpha", "qhat", "de", "beta"])
    ('alpha', 'qhat', 'de', 'beta*beta', '|beta|')
    >>> candidate_terms("Cn", ["alpha", "qhat", "beta", "rhat", "dr", "tc_ff"])
    ('beta', 'rhat', 'dr', 'tc_ff')
    """
    have = [v for v in allowed if v in set(available)]
    lateral = coefficient in LATERAL_COEFFICIENTS
    out = [v for v in have if (v in LATERAL_VARIABLES) == lateral
           or (lateral and v in THRUST_VARIABLES)]
    if not lateral:
        for v in EVEN_LATERAL:
            if v in have:
                out += [f"{v}*{v}", f"|{v}|"]
    return tuple(out)


def breaks_symmetry(coefficient: str, multiplier: str) -> bool:
    """Whether the term ``multiplier`` of a model of ``coefficient`` breaks the mirror
    symmetry of the airframe: a term of a lateral coefficient (CY, Cl, Cn) without a
    lateral factor, other than its constant (a thrust coefficient, or a kink of one).

    Such a term is physics of some aircraft only (a propeller's torque and swirl), so the
    structure search asks more of it than of the others
    (:attr:`~simplexspline.aero.selection.search.SelectionSettings.asymmetry_improvement`).

    Parameters
    ----------
    coefficient : str
        ``'CX'``, ..., ``'Cn'``.
    multiplier : str
        A multiplier in the notation of :mod:`simplexspline.aero.modelling.notation`.

    Examples
    --------
    >>> breaks_symmetry("Cl", "tc_ff"), breaks_symmetry("Cl", "tc*|beta|")
    (True, False)
    >>> breaks_symmetry("Cl", "1"), breaks_symmetry("Cm", "tc")
    (False, False)
    """
    if coefficient not in LATERAL_COEFFICIENTS or multiplier == "1":
        return False
    return not any(f in LATERAL_VARIABLES for f in multiplier_factors(multiplier))


def restrict_to_data(structure: Structure, columns: Mapping) -> tuple[Structure, list]:
    """``structure`` without what the data cannot support: scheduling variables and
    multiplier columns that are missing or constant in ``columns``.

    Parameters
    ----------
    structure : Structure
    columns : mapping of str to ndarray
        Identification data by column.

    Returns
    -------
    structure : Structure
        The restricted structure (unchanged when nothing is missing).
    dropped : dict of str to str
        What was left out (a variable or a multiplier) and why.

    Raises
    ------
    simplexspline.errors.InputError
        No scheduling variable varies (nothing can be identified).
    """
    def varies(v):
        if v not in columns:
            return False
        x = np.asarray(columns[v], dtype=float)
        return bool(np.all(np.isfinite(x)) and np.ptp(x) > 0)

    def why(v):
        return "constant in the data" if v in columns else "not in the data"

    dropped = {}
    keep = [i for i, v in enumerate(structure.variables) if varies(v)]
    for i, v in enumerate(structure.variables):
        if i not in keep:
            dropped[v] = why(v)
    if not keep:
        raise InputError(f"none of the variables {list(structure.variables)} of "
                         f"{structure.coefficient} varies in the identification data")
    variables = tuple(structure.variables[i] for i in keep)
    mult = []
    for m in structure.multipliers:
        dims = split_multiplier(m)[1]
        factors = [f for f in multiplier_factors(m) if f not in variables]
        bad = [f for f in factors if not varies(f)]
        if bad or (dims is not None and any(d not in variables for d in dims)):
            dropped[m] = why(bad[0]) if bad else "its variables were left out"
            continue
        mult.append(m)
    if not dropped:
        return structure, {}
    if structure.multipliers and not mult:
        mult = ["1"]
    knots = tuple((v, k) for v, k in structure.knots if v in variables)
    return structure.with_(variables=variables,
                           resolution=tuple(structure.resolution[i] for i in keep),
                           multipliers=tuple(mult), knots=knots), dropped
