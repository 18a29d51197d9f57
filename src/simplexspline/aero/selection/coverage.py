"""Where the identification data are: coverage of the flight envelope, so that neither the
cross-validation of the structure search nor the validation rewards (or punishes)
extrapolation.

The envelope (angle of attack, sideslip, Mach number: :data:`~simplexspline.aero.variables.
ENVELOPE_VARIABLES`, those that vary) is cut into cells of equal width over the range of
the identification data, a few per variable. A sample is *covered* when its cell holds at
least :func:`threshold` samples of the data it is judged against (the training folds in
cross-validation, the identification set in validation): a share of the mean number of
samples per occupied cell, so that the rule does not depend on the sample rate or the
length of the record. Equal widths matter: cells at
data quantiles are widest where the data are thinnest, and a lone high-alpha maneuver then
shares its cell with many low-alpha samples (seen on a simulated F-16 campaign: one
sum-of-sines reaching 24 deg of alpha passed as covered and carried most of the validation
error).

A model is judged on covered samples; samples outside the coverage are reported on their
own (an extrapolation is a different question from a fit).

The structure search of a lateral coefficient (CY, Cl, Cn) judges coverage on the cells
without the sideslip (:func:`search_cells`): there the sideslip is the excitation, not the
flight condition.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from simplexspline.aero.variables import (
    ENVELOPE_VARIABLES,
    LATERAL_COEFFICIENTS,
    LATERAL_VARIABLES,
)
from simplexspline.errors import InputError

__all__ = ["COVERAGE_BINS", "COVERAGE_MIN_COUNT", "COVERAGE_SHARE", "EnvelopeCells",
           "covered_in_folds", "search_cells", "threshold"]

#: Cells per envelope variable.
COVERAGE_BINS = 8
#: A cell covers its samples when it holds this share of the mean number of reference
#: samples per occupied cell ...
COVERAGE_SHARE = 0.05
#: ... and at least this many.
COVERAGE_MIN_COUNT = 5


@dataclass(frozen=True)
class EnvelopeCells:
    """A grid of equal-width cells over the envelope variables.

    Attributes
    ----------
    variables : tuple of str
        The envelope variables that vary in the reference data.
    edges : tuple of ndarray
        Interior cell edges per variable (physical units), increasing, equally spaced.
    """

    variables: tuple
    edges: tuple

    @classmethod
    def from_data(cls, columns: Mapping, variables: Sequence[str] = ENVELOPE_VARIABLES,
                  bins: int = COVERAGE_BINS) -> EnvelopeCells:
        """Cells of equal width over the range of ``columns`` (the identification data).

        Parameters
        ----------
        columns : mapping of str to ndarray, shape (N,)
        variables : sequence of str
            Candidates; those missing from ``columns`` or constant there are left out.
        bins : int
            Cells per variable.
        """
        if bins < 1:
            raise InputError(f"bins must be >= 1, got {bins!r}")
        used, edges = [], []
        for v in variables:
            if v not in columns:
                continue
            x = np.asarray(columns[v], dtype=float)
            x = x[np.isfinite(x)]
            if x.size == 0 or np.ptp(x) == 0:
                continue
            inner = np.linspace(x.min(), x.max(), bins + 1)[1:-1]
            used.append(v)
            edges.append(inner)
        return cls(tuple(used), tuple(edges))

    def without(self, variables: Sequence[str]) -> EnvelopeCells:
        """The same grid with ``variables`` left out (their cells merged)."""
        keep = [(v, e) for v, e in zip(self.variables, self.edges) if v not in variables]
        return EnvelopeCells(tuple(v for v, _ in keep), tuple(e for _, e in keep))

    @property
    def ncells(self) -> int:
        """Number of cells of the grid."""
        return int(np.prod([len(e) + 1 for e in self.edges])) if self.edges else 1

    def cell(self, columns: Mapping) -> np.ndarray:
        """Cell index per sample, shape (N,) int (0 .. ncells - 1).

        Raises
        ------
        InputError
            An envelope variable of the grid is missing from ``columns``.
        """
        missing = [v for v in self.variables if v not in columns]
        if missing:
            raise InputError(f"envelope variable(s) {missing} missing from the data")
        if not self.variables:
            n = len(next(iter(columns.values()))) if columns else 0
            return np.zeros(n, dtype=np.int64)
        idx = np.zeros(len(np.asarray(columns[self.variables[0]])), dtype=np.int64)
        for v, e in zip(self.variables, self.edges):
            idx = idx * (len(e) + 1) + np.searchsorted(e, np.asarray(columns[v], float),
                                                       side="right")
        return idx

    def counts(self, cells: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        """Samples per cell, shape (ncells,), of the samples selected by ``mask``."""
        c = np.asarray(cells) if mask is None else np.asarray(cells)[np.asarray(mask, bool)]
        return np.bincount(c, minlength=self.ncells)

    def covered(self, cells: np.ndarray, reference_counts: np.ndarray) -> np.ndarray:
        """Whether each sample's cell holds at least :func:`threshold` reference samples."""
        counts = np.asarray(reference_counts)
        return counts[np.asarray(cells)] >= threshold(counts)


def threshold(counts: np.ndarray) -> float:
    """Reference samples a cell needs to cover its samples:
    ``max(COVERAGE_MIN_COUNT, COVERAGE_SHARE * mean count of the occupied cells)``."""
    counts = np.asarray(counts, dtype=float)
    occupied = counts[counts > 0]
    mean = float(occupied.mean()) if occupied.size else 0.0
    return max(float(COVERAGE_MIN_COUNT), COVERAGE_SHARE * mean)


def covered_in_folds(cells: np.ndarray, folds: np.ndarray, ncells: int) -> np.ndarray:
    """Samples whose envelope cell holds at least :func:`threshold` samples of the
    *other* folds: the held-out samples a cross-validation scores.

    Parameters
    ----------
    cells : ndarray of int, shape (N,)
        :meth:`EnvelopeCells.cell` of each sample.
    folds : ndarray of int, shape (N,)
    ncells : int

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    cells = np.asarray(cells)
    folds = np.asarray(folds)
    k = int(folds.max()) + 1
    table = np.zeros((k, ncells))
    np.add.at(table, (folds, cells), 1.0)
    others = table.sum(axis=0)[None, :] - table            # (k, ncells)
    limits = np.array([threshold(row) for row in others])
    return others[folds, cells] >= limits[folds]


def search_cells(envelope: EnvelopeCells, coefficient: str, columns: Mapping) -> np.ndarray:
    """The envelope cell of each sample as the structure search of ``coefficient`` judges
    coverage: ``envelope``'s cells, without the lateral variables (the sideslip) for a
    lateral coefficient.

    A lateral coefficient is odd in the sideslip, and its lateral inputs are what make it
    move; they are its excitation, not its flight condition. With the sideslip among the
    cells, a lateral maneuver's samples count only where the other folds reached the same
    sideslip at the same angle of attack and Mach number: a rudder input flown once per
    test point is never scored, and neither is much of a turn or an aileron pulse. On a
    still-air course with one input per axis the cross-validation scored 24 % of a turn
    and 77 % of an aileron pulse (100 % of both without the sideslip), and the search
    scheduled CY on alpha and Mach: 12.95x the noise at a held-out turn, 0.83x with these
    cells. The longitudinal coefficients keep the sideslip: judged without it, CX reached
    9-10x the noise on two such courses.

    Parameters
    ----------
    envelope : EnvelopeCells
        The cells of the identification data.
    coefficient : str
    columns : mapping of str to ndarray, shape (N,)
        The samples (holding ``envelope``'s variables).

    Returns
    -------
    ndarray of int, shape (N,)
    """
    if coefficient in LATERAL_COEFFICIENTS:
        envelope = envelope.without(LATERAL_VARIABLES)
    return envelope.cell(columns)
