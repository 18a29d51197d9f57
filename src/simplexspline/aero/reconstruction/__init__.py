"""Flight path reconstruction: kinematics, IEKF + RTS smoother, per-maneuver runs.

:mod:`~simplexspline.aero.reconstruction.kinematics` (state model and Jacobians),
:mod:`~simplexspline.aero.reconstruction.iekf` (the filter and smoother of one maneuver; compiled
by numba in :mod:`~simplexspline.aero.reconstruction.filter_kernels`) and
:mod:`~simplexspline.aero.reconstruction.reconstruct` (all maneuvers, in parallel).
"""

from simplexspline.aero.reconstruction.reconstruct import (
    ESSENTIAL_MEASUREMENTS,
    Reconstruction,
    ReconstructionSettings,
    innovation_statistics,
    reconstruct,
    reconstruct_maneuver,
)

__all__ = [
    "ESSENTIAL_MEASUREMENTS",
    "Reconstruction",
    "ReconstructionSettings",
    "innovation_statistics",
    "reconstruct",
    "reconstruct_maneuver",
]
