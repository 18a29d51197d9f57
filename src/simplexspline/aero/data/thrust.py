"""A pluggable engine thrust model for records without thrust columns.

Real flight-test records rarely hold thrust; they hold fan speed (N1) or fuel flow. A
:class:`ThrustModel` turns one of them, the density and the Mach number into thrust along
body x and its pitching moment, for :func:`~simplexspline.aero.data.coefficients.
aerodynamic_coefficients` (argument ``thrust_model``; any callable ``f(df) -> mapping`` of
``thrust_*`` arrays works too)::

    T = engines * poly(x) * (rho / 1.225) ** density_exponent * (1 + mach_factor * mach)
    thrust_x = T * cos(tilt),  thrust_z = -T * sin(tilt),  thrust_m = T * z_thrust_m

with ``x`` the ``n1`` [fraction] or ``fuel_flow`` [kg/s] column and ``poly`` the polynomial
``c0 + c1 x + c2 x^2 + ...`` [N per engine]. The coefficients are the engine maker's or a
static test's: the defaults carry no knowledge of any engine (there are none).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from simplexspline.errors import FlightDataError, InputError

__all__ = ["ThrustModel"]

_RHO0 = 1.225          # ISA sea-level density [kg/m^3]


@dataclass(frozen=True)
class ThrustModel:
    """Thrust from fan speed or fuel flow, density and Mach (see the module docstring).

    Parameters
    ----------
    input : {'n1', 'fuel_flow'}
        The column that drives the thrust.
    coefficients : tuple of float
        ``c0, c1, ...`` of the per-engine thrust polynomial in the input [N].
    engines : int
        Number of engines (the input column is the mean over them for ``n1``, the total
        divided by ``engines`` for ``fuel_flow``).
    density_exponent : float
        Lapse with density (0.7 is a common turbofan value; 0 for none).
    mach_factor : float
        Linear Mach correction.
    tilt_rad : float
        Thrust line angle above body x [rad].
    z_thrust_m : float
        Thrust line below the c.g. along body z [m] (pitching moment T * z, nose up for a
        thrust line below the c.g.).

    Examples
    --------
    >>> model = ThrustModel("n1", coefficients=(0.0, 0.0, 30000.0), engines=2)
    >>> rec = reconstruct(df, thrust_model=model)            # doctest: +SKIP
    """

    input: str
    coefficients: tuple
    engines: int = 1
    density_exponent: float = 0.0
    mach_factor: float = 0.0
    tilt_rad: float = 0.0
    z_thrust_m: float = 0.0

    def __post_init__(self):
        if self.input not in ("n1", "fuel_flow"):
            raise InputError(f"thrust model input must be 'n1' or 'fuel_flow', got "
                             f"{self.input!r}")
        coef = tuple(float(c) for c in self.coefficients)
        if not coef or not all(math.isfinite(c) for c in coef):
            raise InputError("thrust model coefficients must be finite numbers [N], "
                             f"got {self.coefficients!r}")
        object.__setattr__(self, "coefficients", coef)
        if int(self.engines) != self.engines or self.engines < 1:
            raise InputError(f"engines must be a positive integer, got {self.engines!r}")
        for name in ("density_exponent", "mach_factor", "tilt_rad", "z_thrust_m"):
            if not math.isfinite(float(getattr(self, name))):
                raise InputError(f"thrust model {name} must be finite")

    @classmethod
    def from_config(cls, entry: Mapping) -> ThrustModel:
        """From a config table, e.g. ``[thrust] input = "n1", coefficients = [...]``."""
        if not isinstance(entry, Mapping):
            raise InputError("the thrust model config must be a table")
        unknown = set(entry) - {"input", "coefficients", "engines", "density_exponent",
                                "mach_factor", "tilt_rad", "z_thrust_m"}
        if unknown:
            raise InputError(f"thrust model config has unknown key(s) {sorted(unknown)}")
        if "input" not in entry or "coefficients" not in entry:
            raise InputError("thrust model config needs 'input' and 'coefficients'")
        return cls(**{k: (tuple(v) if k == "coefficients" else v) for k, v in entry.items()})

    def __call__(self, df) -> dict:
        """Thrust forces [N] and pitching moment [N m] per row of ``df``."""
        for c in (self.input, "rho", "mach"):
            if c not in df.columns or df[c].isna().all():
                raise FlightDataError(f"the thrust model needs column {c!r}; it is missing "
                                      "or empty")
        x = df[self.input].to_numpy(dtype=float)
        if self.input == "fuel_flow":
            x = x / self.engines
        per_engine = np.polynomial.polynomial.polyval(x, self.coefficients)
        T = (self.engines * per_engine
             * (df["rho"].to_numpy(dtype=float) / _RHO0) ** self.density_exponent
             * (1.0 + self.mach_factor * df["mach"].to_numpy(dtype=float)))
        return {"thrust_x": T * math.cos(self.tilt_rad),
                "thrust_z": -T * math.sin(self.tilt_rad),
                "thrust_m": T * self.z_thrust_m}
