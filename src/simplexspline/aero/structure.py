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

from simplexspline.errors import InputError

__all__ = [
    "CANDIDATE_VARIABLES",
    "COEFFICIENTS",
    "PAPER_PRESET",
    "UNITS",
    "Scaling",
    "Structure",
    "preset",
    "structures_from_config",
]

#: The six body-axis force and moment coefficients (Eq. 43-48).
COEFFICIENTS = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")

#: Explanatory variables the automatic structure selection may add (when in the data).
CANDIDATE_VARIABLES = ("alpha", "beta", "mach", "phat", "qhat", "rhat", "de", "da", "dr")

#: Units of the variables and coefficients (SI, radians).
UNITS = {
    "alpha": "rad", "beta": "rad", "mach": "-", "tas": "m/s", "h": "m", "rho": "kg/m^3",
    "p": "rad/s", "q": "rad/s", "r": "rad/s", "phat": "- (p b / 2V)",
    "qhat": "- (q cbar / 2V)", "rhat": "- (r b / 2V)", "de": "rad", "da": "rad", "dr": "rad",
    "dte": "rad", "flap": "rad", "speedbrake": "rad", "gear": "-",
    "phi": "rad", "theta": "rad", "pdot": "rad/s^2", "qdot": "rad/s^2", "rdot": "rad/s^2",
    **{c: "-" for c in COEFFICIENTS},
}


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
    """

    coefficient: str
    variables: tuple
    degree: int = 3
    continuity: int = 1
    resolution: tuple = field(default=())

    def __post_init__(self):
        variables = tuple(str(v) for v in self.variables)
        object.__setattr__(self, "variables", variables)
        if not variables:
            raise InputError(f"structure of {self.coefficient}: no variables given")
        if len(set(variables)) != len(variables):
            raise InputError(f"structure of {self.coefficient}: repeated variable in "
                             f"{list(variables)}")
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
        return len(self.variables)

    @property
    def nsimplex_max(self) -> int:
        """Simplices of the full grid (before empty ones are dropped)."""
        return math.factorial(self.ndim) * int(np.prod(self.resolution))

    @property
    def nbasis(self) -> int:
        """B-coefficients per simplex, ``d_hat = C(d + n, n)``."""
        return math.comb(self.degree + self.ndim, self.ndim)

    def label(self) -> str:
        """Compact text, e.g. ``CZ(alpha:2, de, mach) S^1_3``."""
        parts = [v if k == 1 else f"{v}:{k}" for v, k in zip(self.variables, self.resolution)]
        return f"{self.coefficient}({', '.join(parts)}) S^{self.continuity}_{self.degree}"

    def with_(self, **changes) -> Structure:
        """A copy with some fields changed (validated)."""
        return replace(self, **changes)

    def to_dict(self) -> dict:
        return {"coefficient": self.coefficient, "variables": list(self.variables),
                "degree": self.degree, "continuity": self.continuity,
                "resolution": list(self.resolution)}

    @classmethod
    def from_dict(cls, data: Mapping, coefficient: str | None = None) -> Structure:
        """Build from a mapping with keys ``variables`` and optional ``degree``,
        ``continuity``, ``resolution`` (an int applies to every variable)."""
        allowed = {"coefficient", "variables", "degree", "continuity", "resolution"}
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
        return cls(coef, tuple(variables), int(data.get("degree", 3)),
                   int(data.get("continuity", 1)), tuple(res))


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


def preset(name: str = "paper") -> dict:
    """The named preset structures (``'paper'``), as a dict coefficient -> Structure."""
    if name != "paper":
        raise InputError(f"unknown structure preset {name!r}; available: 'paper'")
    return dict(PAPER_PRESET)


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


@dataclass(frozen=True)
class Scaling:
    """Affine map of physical variables to the unit box, ``u = (x - lower) / (upper - lower)``.

    Parameters
    ----------
    variables : tuple of str
    lower, upper : tuple of float
        The identification data's range per variable (physical units).
    """

    variables: tuple
    lower: tuple
    upper: tuple

    @classmethod
    def from_data(cls, x: np.ndarray, variables: Sequence[str]) -> Scaling:
        """The bounding box of ``x`` (N, n); raises if a variable does not vary."""
        x = np.asarray(x, dtype=float)
        lo, hi = x.min(axis=0), x.max(axis=0)
        flat = [v for v, a, b in zip(variables, lo, hi) if not b > a]
        if flat:
            raise InputError(f"variable(s) {flat} do not vary in the identification data: "
                             "remove them from the model structure")
        return cls(tuple(variables), tuple(float(v) for v in lo), tuple(float(v) for v in hi))

    def transform(self, x: np.ndarray, *, clip: bool = False) -> np.ndarray:
        """Physical (N, n) -> unit box (N, n); ``clip`` clamps to [0, 1]."""
        lo, hi = np.asarray(self.lower), np.asarray(self.upper)
        u = (np.asarray(x, dtype=float) - lo) / (hi - lo)
        return np.clip(u, 0.0, 1.0) if clip else u

    def inverse(self, u: np.ndarray) -> np.ndarray:
        """Unit box (N, n) -> physical (N, n)."""
        lo, hi = np.asarray(self.lower), np.asarray(self.upper)
        return lo + np.asarray(u, dtype=float) * (hi - lo)

    @property
    def span(self) -> np.ndarray:
        return np.asarray(self.upper) - np.asarray(self.lower)

    def to_dict(self) -> dict:
        return {"variables": list(self.variables), "lower": list(self.lower),
                "upper": list(self.upper)}

    @classmethod
    def from_dict(cls, data: Mapping) -> Scaling:
        return cls(tuple(data["variables"]), tuple(float(v) for v in data["lower"]),
                   tuple(float(v) for v in data["upper"]))
