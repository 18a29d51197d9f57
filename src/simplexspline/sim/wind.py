"""Wind for real-like campaigns: a steady wind per maneuver plus JSBSim's turbulence.

:class:`Wind` is plain settings; :meth:`Wind.draw` gives one maneuver's wind as plain data
(for the worker processes), and :func:`simplexspline.sim.fdm.set_wind` applies it to a
trimmed model without losing the trim: the air-relative state of the trim is kept and the
Earth-relative velocity becomes air velocity + wind.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from simplexspline.errors import InputError

__all__ = ["Wind", "TURBULENCE_SEVERITY"]

#: JSBSim's MIL-F-8785C turbulence (``atmosphere/turb-type`` 3): the probability-of-
#: exceedance index (``atmosphere/turbulence/milspec/severity``) of each named level.
TURBULENCE_SEVERITY = {"none": 0, "light": 3, "moderate": 4, "severe": 6}


@dataclass(frozen=True)
class Wind:
    """Steady wind and turbulence of a campaign (drawn per maneuver).

    Parameters
    ----------
    speed_mps : (float, float)
        Range of the steady horizontal wind speed [m/s]; the direction is uniform over the
        compass, a new speed and direction for every maneuver.
    turbulence : {'none', 'light', 'moderate', 'severe'}
        JSBSim's MIL-F-8785C (Dryden-form) turbulence on top of the steady wind, linear and
        rotational; seeded per maneuver, so the same campaign seed gives the same gusts.

    Examples
    --------
    >>> w = Wind((5.0, 10.0), "light").draw(np.random.default_rng(0))
    >>> 5.0 <= math.hypot(*w["ned_mps"][:2]) <= 10.0, w["severity"]
    (True, 3)
    """

    speed_mps: tuple = (0.0, 0.0)
    turbulence: str = "none"

    def __post_init__(self):
        try:
            lo, hi = (float(x) for x in self.speed_mps)
        except (TypeError, ValueError):
            lo, hi = math.nan, math.nan
        if not (0.0 <= lo <= hi <= 60.0):
            raise InputError(f"Wind.speed_mps must be (low, high) with 0 <= low <= high <= 60 "
                             f"m/s, got {self.speed_mps!r}")
        object.__setattr__(self, "speed_mps", (lo, hi))
        if self.turbulence not in TURBULENCE_SEVERITY:
            raise InputError(f"Wind.turbulence must be one of {list(TURBULENCE_SEVERITY)}, got "
                             f"{self.turbulence!r}")

    def draw(self, rng: np.random.Generator) -> dict:
        """One maneuver's wind: ``ned_mps`` (towards north, east, down) [m/s], ``severity``
        and the turbulence ``seed``."""
        speed = float(rng.uniform(*self.speed_mps))
        direction = float(rng.uniform(-math.pi, math.pi))
        return {"ned_mps": [speed * math.cos(direction), speed * math.sin(direction), 0.0],
                "severity": TURBULENCE_SEVERITY[self.turbulence],
                "seed": int(rng.integers(1, 2**31 - 1))}

    def to_dict(self) -> dict:
        """Plain-data form (metadata)."""
        return asdict(self)
