"""The one exception hierarchy of simplexspline.

Every error the package raises on purpose derives from :class:`SimplexSplineError`, so a
caller (or the CLI) can catch the whole family with one ``except``. Errors about a user's
input also derive from :class:`ValueError`, so code written against plain Python
conventions keeps working.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "SimplexSplineError",
    "InputError",
    "TriangulationError",
    "DegenerateSimplexError",
    "InsufficientDataError",
    "OutsideDomainError",
    "ModelFileError",
    "FlightDataError",
    "SimulationError",
]


class SimplexSplineError(Exception):
    """Base class of every error raised on purpose by simplexspline."""


class InputError(SimplexSplineError, ValueError):
    """Invalid user input: NaN/inf, wrong shapes, mismatched dimensions, bad parameters."""


class TriangulationError(SimplexSplineError, ValueError):
    """A triangulation that is not valid: overlapping, non-conforming or malformed."""


class DegenerateSimplexError(TriangulationError):
    """One or more simplices have (numerically) zero volume.

    Attributes
    ----------
    simplices : ndarray of int
        Indices of the degenerate simplices.
    """

    def __init__(self, message: str, simplices=()):
        super().__init__(message)
        self.simplices = np.asarray(simplices, dtype=np.intp)


class InsufficientDataError(SimplexSplineError):
    """The data do not determine the B-coefficients of some simplices.

    Attributes
    ----------
    simplices : ndarray of int
        Simplices whose coefficients are not determined by data and continuity.
    counts : ndarray of int
        Number of data points in each of those simplices.
    """

    def __init__(self, message: str, simplices=(), counts=()):
        super().__init__(message)
        self.simplices = np.asarray(simplices, dtype=np.intp)
        self.counts = np.asarray(counts, dtype=np.int64)


class OutsideDomainError(SimplexSplineError, ValueError):
    """Evaluation points lie outside the triangulation (with ``outside='raise'``).

    Attributes
    ----------
    indices : ndarray of int
        Row indices of the offending points.
    """

    def __init__(self, message: str, indices=()):
        super().__init__(message)
        self.indices = np.asarray(indices, dtype=np.intp)


class ModelFileError(SimplexSplineError):
    """A model file that is missing, corrupt, or of an unknown format version."""


class FlightDataError(SimplexSplineError, ValueError):
    """Flight data that do not satisfy the flight-data schema."""


class SimulationError(SimplexSplineError):
    """A flight simulation that could not be set up or run (e.g. a failed trim)."""
