"""Model structures: which variables, degree, continuity and triangulation per coefficient.

A :class:`Structure` names the explanatory variables of one aerodynamic coefficient (flight
data column names), the polynomial degree ``d``, the continuity order ``r`` and the
triangulation resolution: the number of grid cells along each (scaled) variable of a Kuhn
triangulation of the identification data's bounding box (each cell is split into ``n!``
simplices; simplices without enough data are dropped, the paper's Fig. 5 idea).

Variables are scaled to the unit box by :class:`Scaling` so that simplices are well shaped
whatever the physical units.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from simplexspline.aero.modelling.notation import (
    format_knots,
    multiplier_factors,
    multiplier_parts,
    normal_multiplier,
    parse_knots,
    parse_multiplier,
    split_multiplier,
)
from simplexspline.aero.variables import CANDIDATE_VARIABLES, COEFFICIENTS, UNITS
from simplexspline.errors import InputError

__all__ = [
    "KNOT_MARGIN",
    "Scaling",
    "Structure",
    "multiplier_jacobian",
    "multiplier_values",
    "structures_from_config",
]

@dataclass(frozen=True)
class Structure:
    """The structure of one coefficient's spline model.

    Parameters
    ----------
    coefficient : str
        The modelled column, e.g. ``'CZ'``.
    variables : tuple of str
        Explanatory variables (flight-data columns), e.g. ``('alpha', 'de', 'mach')``.
    degree : int
        Polynomial degree ``d`` (>= 0).
    continuity : int
        Continuity order ``r`` between simplices (-1 <= r < d).
    resolution : tuple of int
        Grid cells along each variable (same length as ``variables``; default all 1).
    multipliers : tuple of str, optional
        Terms of a varying-coefficient structure (see :mod:`simplexspline.aero.modelling.notation`).
    knots : tuple of (str, tuple of float), optional
        Interior breakpoints per variable (physical units): the grid lines.
    cellwise : bool, default False
        One polynomial per grid cell: the simplices of a cell are joined C^d (the Kuhn
        diagonals are no breaks), the cells C^r across the grid planes. Piecewise
        multilinear tables on the grid still lie in the space (for d >= number of
        variables that a table couples), with far fewer coefficients.
    """

    coefficient: str
    variables: tuple
    degree: int = 3
    continuity: int = 1
    resolution: tuple = field(default=())
    multipliers: tuple = field(default=())
    knots: tuple = field(default=())
    cellwise: bool = False

    def __post_init__(self):
        variables = tuple(str(v) for v in self.variables)
        object.__setattr__(self, "variables", variables)
        if not variables:
            raise InputError(f"structure of {self.coefficient}: no variables given")
        if len(set(variables)) != len(variables):
            raise InputError(f"structure of {self.coefficient}: repeated variable in "
                             f"{list(variables)}")
        mult = tuple(normal_multiplier(m) for m in self.multipliers)
        if len(set(mult)) != len(mult) or any(
                not f for m in mult for f in split_multiplier(m)[0].split("*")):
            raise InputError(f"structure of {self.coefficient}: repeated or empty multiplier "
                             f"in {list(mult)}")
        for m in mult:
            multiplier_parts(m)      # factors: columns, '|column|' or '|column-k|'
            dims = split_multiplier(m)[1]
            if dims is not None and any(v not in variables for v in dims):
                raise InputError(f"structure of {self.coefficient}: the term {m!r} may only "
                                 f"depend on variables of the model {list(variables)}")
        object.__setattr__(self, "multipliers", mult)
        object.__setattr__(self, "cellwise", bool(self.cellwise))
        knots = dict(self.knots) if not isinstance(self.knots, Mapping) else self.knots
        for m in mult:
            bad = [v for v in parse_multiplier(m)[2] if v not in knots]
            if bad:
                raise InputError(f"structure of {self.coefficient}: the term {m!r} gives "
                                 f"breakpoints of {bad}, which have none in the model "
                                 f"(breakpoints: {sorted(knots)}); a term's breakpoints "
                                 "are a subset of the model's")
        clean = []
        for v, ks in knots.items():
            if v not in variables:
                raise InputError(f"structure of {self.coefficient}: knots given for {v!r}, "
                                 f"which is not one of the variables {list(variables)}")
            try:
                arr = tuple(float(k) for k in ks)
            except (TypeError, ValueError):
                raise InputError(f"structure of {self.coefficient}: knots of {v!r} must be "
                                 f"numbers, got {ks!r}") from None
            if not arr or not all(np.isfinite(arr)) or any(b <= a for a, b in
                                                           zip(arr, arr[1:])):
                raise InputError(f"structure of {self.coefficient}: knots of {v!r} must be "
                                 f"finite and strictly increasing, got {list(arr)}")
            clean.append((v, arr))
        object.__setattr__(self, "knots", tuple(sorted(clean, key=lambda t: variables.index(
            t[0]))))
        res = tuple(self.resolution) if len(self.resolution) else (1,) * len(variables)
        if len(res) != len(variables):
            raise InputError(f"structure of {self.coefficient}: resolution {list(res)} must "
                             f"give one cell count per variable {list(variables)}")
        if any(int(k) != k or k < 1 for k in res):
            raise InputError(f"structure of {self.coefficient}: resolution must be positive "
                             f"integers, got {list(res)}")
        object.__setattr__(self, "resolution", tuple(int(k) for k in res))
        if int(self.degree) != self.degree or self.degree < 0:
            raise InputError(f"structure of {self.coefficient}: degree must be a "
                             f"non-negative integer, got {self.degree!r}")
        if int(self.continuity) != self.continuity or not -1 <= self.continuity < self.degree:
            raise InputError(f"structure of {self.coefficient}: continuity must satisfy "
                             f"-1 <= r < d (d = {self.degree}), got {self.continuity!r}")
        object.__setattr__(self, "degree", int(self.degree))
        object.__setattr__(self, "continuity", int(self.continuity))

    @property
    def ndim(self) -> int:
        """Number of (scheduling) variables of the triangulation."""
        return len(self.variables)

    @property
    def varying(self) -> bool:
        """A varying-coefficient structure ``C = sum_k m_k s_k(variables)``."""
        return bool(self.multipliers)

    @property
    def nterms(self) -> int:
        """Number of spline terms (1 for a plain structure)."""
        return max(1, len(self.multipliers))

    @property
    def term_dims(self) -> list:
        """Per term, the indices of the variables it depends on (None: all of them), from
        multipliers written ``'phat[alpha]'`` or ``'da[alpha/beta]'``."""
        out = []
        for m in self.multipliers:
            dims = split_multiplier(m)[1]
            out.append(None if dims is None else tuple(self.variables.index(v)
                                                       for v in dims))
        return out

    @property
    def term_knots(self) -> list:
        """Per term, its own breakpoints (variable -> tuple; empty: the model's), from
        multipliers written ``'dr{beta@-30:30:10deg}'``."""
        return [parse_multiplier(m)[2] for m in self.multipliers]

    @property
    def inputs(self) -> tuple:
        """Every data column the model reads: the variables, then the columns of the
        multipliers that are not variables (``'1'``, the constant, is no column; a
        multiplier ``'beta*beta'`` or ``'qhat*flap'`` is a product of columns)."""
        extra = []
        for m in self.multipliers:
            for f in multiplier_factors(m):
                if f not in self.variables and f not in extra:
                    extra.append(f)
        return (*self.variables, *extra)

    @property
    def knots_of(self) -> dict:
        """Interior breakpoints per variable (physical units), for those that have them."""
        return dict(self.knots)

    @property
    def cells(self) -> tuple:
        """Grid cells per variable at most: the resolution, or the number of intervals of
        the breakpoints (fewer when some lie outside the data)."""
        knots = self.knots_of
        return tuple(len(knots[v]) + 1 if v in knots else k
                     for v, k in zip(self.variables, self.resolution))

    @property
    def nsimplex_max(self) -> int:
        """Simplices of the full grid (before empty ones are dropped)."""
        return math.factorial(self.ndim) * int(np.prod(self.cells))

    def size(self, ranges: Mapping | None = None) -> int:
        """Upper bound of the number of B-coefficients; with ``ranges`` (variable ->
        (lower, upper) of the data) only the breakpoints :meth:`Scaling.from_data` would
        use count."""
        cells = list(self.cells)
        for i, v in enumerate(self.variables):
            if ranges is not None and v in self.knots_of and v in ranges:
                lo, hi = ranges[v]
                margin = KNOT_MARGIN * (hi - lo)
                cells[i] = 1 + sum(lo + margin < k < hi - margin for k in self.knots_of[v])
        return math.factorial(self.ndim) * int(np.prod(cells)) * self.ncoef_per_simplex

    @property
    def nbasis(self) -> int:
        """B-coefficients per simplex and term, ``d_hat = C(d + n, n)``."""
        return math.comb(self.degree + self.ndim, self.ndim)

    @property
    def ncoef_per_simplex(self) -> int:
        """B-coefficients per simplex over all terms, ``K d_hat``."""
        return self.nterms * self.nbasis

    def label(self) -> str:
        """Compact text, e.g. ``CZ(alpha:2, de, mach) S^1_3`` or, varying-coefficient with
        breakpoints, ``Cl(alpha@-5:20:5deg, beta | 1, phat, da) S^0_2``."""
        knots = self.knots_of
        parts = []
        for v, k in zip(self.variables, self.resolution):
            if v in knots:
                parts.append(f"{v}@{format_knots(v, knots[v])}")
            else:
                parts.append(v if k == 1 else f"{v}:{k}")
        text = ", ".join(parts)
        if self.multipliers:
            text += " | " + ", ".join(self.multipliers)
        cw = " cellwise" if self.cellwise else ""
        return f"{self.coefficient}({text}) S^{self.continuity}_{self.degree}{cw}"

    def with_(self, **changes) -> Structure:
        """A copy with some fields changed (validated)."""
        return replace(self, **changes)

    def to_dict(self) -> dict:
        out = {"coefficient": self.coefficient, "variables": list(self.variables),
               "degree": self.degree, "continuity": self.continuity,
               "resolution": list(self.resolution)}
        if self.multipliers:
            out["multipliers"] = list(self.multipliers)
        if self.knots:
            out["knots"] = {v: list(k) for v, k in self.knots}
        if self.cellwise:
            out["cellwise"] = True
        return out

    @classmethod
    def from_dict(cls, data: Mapping, coefficient: str | None = None) -> Structure:
        """Build from a mapping with keys ``variables`` and optional ``degree``,
        ``continuity``, ``resolution`` (an int applies to every variable),
        ``multipliers`` (list of columns, ``'1'`` for the constant term) and ``knots``
        (variable -> interior breakpoints, physical units) and ``cellwise`` (bool)."""
        allowed = {"coefficient", "variables", "degree", "continuity", "resolution",
                   "multipliers", "knots", "cellwise"}
        coef = str(data.get("coefficient", coefficient))
        unknown = sorted(set(data) - allowed)
        if unknown:
            raise InputError(f"structure of {coef}: unknown key(s) {unknown}; allowed: "
                             f"{sorted(allowed)}")
        if "variables" not in data:
            raise InputError(f"structure of {coef}: 'variables' is missing")
        variables = data["variables"]
        if isinstance(variables, str):
            variables = [v.strip() for v in variables.split(",") if v.strip()]
        res = data.get("resolution", ())
        if isinstance(res, (int, np.integer)):
            res = (int(res),) * len(variables)
        mult = data.get("multipliers", ())
        if isinstance(mult, str):
            mult = [m.strip() for m in mult.split(",") if m.strip()]
        knots = data.get("knots", {})
        if not isinstance(knots, Mapping):
            raise InputError(f"structure of {coef}: 'knots' must map variables to lists of "
                             f"breakpoints, got {knots!r}")
        return cls(coef, tuple(variables), int(data.get("degree", 3)),
                   int(data.get("continuity", 1)), tuple(res), tuple(mult),
                   tuple(knots.items()), _flag(data.get("cellwise", False), coef))


def _flag(value, coef: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise InputError(f"structure of {coef}: 'cellwise' must be true or false, got "
                         f"{value!r}")
    return bool(value)


def multiplier_values(structure: Structure, x: np.ndarray) -> np.ndarray:
    """The multipliers (N, K) from inputs ``x`` (N, len(structure.inputs))."""
    idx = {v: i for i, v in enumerate(structure.inputs)}
    out = np.ones((len(x), structure.nterms))
    for k, name in enumerate(structure.multipliers):
        for f, absolute, shift in multiplier_parts(name):
            out[:, k] *= np.abs(x[:, idx[f]] - shift) if absolute else x[:, idx[f]]
    return out


def multiplier_jacobian(structure: Structure, x: np.ndarray) -> np.ndarray:
    """d(multiplier k)/d(input i) at the points, shape (N, K, len(structure.inputs))
    (``|v - k|`` factors: ``sign(v - k)``, 0 at the breakpoint)."""
    idx = {v: i for i, v in enumerate(structure.inputs)}
    out = np.zeros((len(x), structure.nterms, len(structure.inputs)))
    for k, name in enumerate(structure.multipliers):
        parts = multiplier_parts(name)
        for j, (f, absolute, shift) in enumerate(parts):
            rest = np.sign(x[:, idx[f]] - shift) if absolute else np.ones(len(x))
            for g, gabs, gshift in parts[:j] + parts[j + 1:]:
                rest = rest * (np.abs(x[:, idx[g]] - gshift) if gabs else x[:, idx[g]])
            out[:, k, idx[f]] += rest
    return out


def structures_from_config(config: Mapping, base: Mapping | None = None) -> dict:
    """Structures from a config mapping (the ``[models]`` table of a TOML file).

    ``config`` maps coefficient names to tables with ``variables`` and optional ``degree``,
    ``continuity`` and ``resolution``; missing coefficients come from ``base`` (default:
    the paper preset).
    """
    out = dict(preset() if base is None else base)
    for coef, table in config.items():
        if coef not in COEFFICIENTS:
            raise InputError(f"unknown coefficient {coef!r} in the model structures; "
                             f"known: {list(COEFFICIENTS)}")
        if not isinstance(table, Mapping):
            raise InputError(f"models.{coef} must be a table with 'variables', got "
                             f"{table!r}")
        out[coef] = Structure.from_dict(table, coef)
    return out


#: Breakpoints closer than this fraction of a variable's data range to its ends are not
#: used (see :meth:`Scaling.from_data`).
KNOT_MARGIN = 0.05


@dataclass(frozen=True)
class Scaling:
    """Map of physical variables to the unit box, per variable: affine,
    ``u = (x - lower) / (upper - lower)``, or piecewise linear through breakpoints
    ``lower = k_0 < k_1 < ... < k_m = upper`` with ``u(k_i) = i / m``, so that a Kuhn grid
    of m cells along that variable has its cell boundaries exactly at the breakpoints
    (for models of table-based data with kinks there).

    Parameters
    ----------
    variables : tuple of str
    lower, upper : tuple of float
        The identification data's range per variable (physical units).
    knots : tuple of tuple of float, optional
        Per variable, all breakpoints including ``lower`` and ``upper``, or ``()`` for an
        affine map.
    """

    variables: tuple
    lower: tuple
    upper: tuple
    knots: tuple = ()

    def __post_init__(self):
        if not self.knots:
            object.__setattr__(self, "knots", ((),) * len(self.variables))
        n = len(self.variables)
        if not (len(self.lower) == len(self.upper) == len(self.knots) == n):
            raise InputError(f"the scaling has {len(self.lower)} lower and {len(self.upper)} "
                             f"upper bounds and {len(self.knots)} breakpoint lists for {n} "
                             f"variables {list(self.variables)}")
        lo = np.asarray(self.lower, dtype=float)
        hi = np.asarray(self.upper, dtype=float)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
            raise InputError(f"the scaling needs finite bounds with upper > lower for every "
                             f"variable, got lower={list(self.lower)}, upper={list(self.upper)}")

    @classmethod
    def from_data(cls, x: np.ndarray, variables: Sequence[str],
                  knots: Mapping | None = None) -> Scaling:
        """The bounding box of ``x`` (N, n); raises if a variable does not vary.

        ``knots`` maps variables to interior breakpoints (physical units): those inside
        the data range, farther than :data:`KNOT_MARGIN` of the range from its ends, are
        used (a breakpoint just inside the data's end would make a cell without data).
        """
        x = np.asarray(x, dtype=float)
        lo, hi = x.min(axis=0), x.max(axis=0)
        flat = [v for v, a, b in zip(variables, lo, hi) if not b > a]
        if flat:
            raise InputError(f"variable(s) {flat} do not vary in the identification data: "
                             "remove them from the model structure")
        full = []
        for v, a, b in zip(variables, lo, hi):
            ks = np.asarray((knots or {}).get(v, ()), dtype=float)
            if len(ks) == 0:
                full.append(())
                continue
            margin = KNOT_MARGIN * (b - a)
            inner = ks[(ks > a + margin) & (ks < b - margin)]
            full.append((float(a), *(float(k) for k in inner), float(b)))
        return cls(tuple(variables), tuple(float(v) for v in lo), tuple(float(v) for v in hi),
                   tuple(full))

    @property
    def cells(self) -> tuple:
        """Grid cells implied by the breakpoints per variable (None where affine)."""
        return tuple(len(k) - 1 if k else None for k in self.knots)

    def transform(self, x: np.ndarray, *, clip: bool = False) -> np.ndarray:
        """Physical (N, n) -> unit box (N, n); ``clip`` clamps to [0, 1]."""
        lo, hi = np.asarray(self.lower), np.asarray(self.upper)
        x = np.asarray(x, dtype=float)
        u = (x - lo) / (hi - lo)
        for i, ks in enumerate(self.knots):
            if ks:
                k = np.asarray(ks)
                # np.interp is piecewise linear inside; beyond the ends continue linearly
                # with the end cells' slopes
                xi = x[..., i]
                ui = np.interp(xi, k, np.linspace(0.0, 1.0, len(k)))
                m = len(k) - 1
                ui = np.where(xi < k[0], (xi - k[0]) / (m * (k[1] - k[0])), ui)
                ui = np.where(xi > k[-1], 1.0 + (xi - k[-1]) / (m * (k[-1] - k[-2])), ui)
                u[..., i] = ui
        return np.clip(u, 0.0, 1.0) if clip else u

    def inverse(self, u: np.ndarray) -> np.ndarray:
        """Unit box (N, n) -> physical (N, n)."""
        lo, hi = np.asarray(self.lower), np.asarray(self.upper)
        u = np.asarray(u, dtype=float)
        x = lo + u * (hi - lo)
        for i, ks in enumerate(self.knots):
            if ks:
                k = np.asarray(ks)
                m = len(k) - 1
                ui = u[..., i]
                xi = np.interp(ui, np.linspace(0.0, 1.0, len(k)), k)
                xi = np.where(ui < 0, k[0] + ui * m * (k[1] - k[0]), xi)
                xi = np.where(ui > 1, k[-1] + (ui - 1) * m * (k[-1] - k[-2]), xi)
                x[..., i] = xi
        return x

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """``du/dx`` per variable at the points, shape (N, n) (constant where affine; the
        slope of the cell holding the point where piecewise linear)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        out = np.broadcast_to(1.0 / self.span, x.shape).copy()
        for i, ks in enumerate(self.knots):
            if ks:
                k = np.asarray(ks)
                m = len(k) - 1
                cell = np.clip(np.searchsorted(k, x[:, i], side="right") - 1, 0, m - 1)
                out[:, i] = 1.0 / (m * np.diff(k)[cell])
        return out

    @property
    def span(self) -> np.ndarray:
        return np.asarray(self.upper) - np.asarray(self.lower)

    @property
    def affine(self) -> bool:
        """True when no variable has breakpoints."""
        return not any(self.knots)

    def subset(self, variables: Sequence[str]) -> Scaling:
        """The scaling of some of the variables."""
        idx = [self.variables.index(v) for v in variables]
        return Scaling(tuple(variables), tuple(self.lower[i] for i in idx),
                       tuple(self.upper[i] for i in idx), tuple(self.knots[i] for i in idx))

    def to_dict(self) -> dict:
        out = {"variables": list(self.variables), "lower": list(self.lower),
               "upper": list(self.upper)}
        if not self.affine:
            out["knots"] = [list(k) for k in self.knots]
        return out

    @classmethod
    def from_dict(cls, data: Mapping) -> Scaling:
        knots = tuple(tuple(float(v) for v in k) for k in data.get("knots", ()))
        return cls(tuple(data["variables"]), tuple(float(v) for v in data["lower"]),
                   tuple(float(v) for v in data["upper"]), knots)
