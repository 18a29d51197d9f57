"""The spline space of a model structure on given data: the variables' scaling, the
triangulation (a Kuhn grid on the scaled box, or on the breakpoints), the continuity
orders (``cellwise``, the terms' own breakpoints) and the normalised multipliers."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from simplexspline.aero.modelling.structure import Scaling, Structure, multiplier_values
from simplexspline.errors import InputError
from simplexspline.spline.continuity import cell_facets, plane_facets
from simplexspline.spline.space import SplineSpace
from simplexspline.spline.geometry.triangulation import Triangulation
from simplexspline.spline.varying import VaryingCoefficientSpace

__all__ = ["StructureSpace", "accumulate", "evaluate", "input_matrix"]


def input_matrix(columns: Mapping, variables: Sequence[str]) -> np.ndarray:
    """The data columns of ``variables`` side by side, shape (N, len(variables)).

    Raises
    ------
    InputError
        A variable the data do not have (the message lists the columns they have).
    """
    missing = [v for v in variables if v not in columns]
    if missing:
        raise InputError(f"unknown variable(s) {missing} in the model structure; the data "
                         f"have {sorted(columns)}")
    return np.column_stack([np.asarray(columns[v], dtype=float) for v in variables])


@dataclass(frozen=True)
class StructureSpace:
    """A model structure laid on data: what fitting it needs.

    Attributes
    ----------
    scaling : Scaling
        The inputs' box (and breakpoints) in physical units.
    scheduling : ndarray, shape (N, n)
        The scheduling variables scaled to the unit box.
    multipliers : ndarray, shape (N, K), or None
        The normalised multipliers of a varying-coefficient structure (None otherwise).
    multiplier_scaling : tuple of (tuple of float, tuple of float)
        The multipliers' (scales, offsets); empty tuples for a plain structure.
    space : SplineSpace or VaryingCoefficientSpace
        The spline space on the triangulation of the scaled box.
    """

    scaling: Scaling
    scheduling: np.ndarray
    multipliers: np.ndarray | None
    multiplier_scaling: tuple
    space: SplineSpace | VaryingCoefficientSpace

    @classmethod
    def build(cls, structure: Structure, x: np.ndarray, min_points: int) -> StructureSpace:
        """The space of ``structure`` fitted to inputs ``x``, shape (N, len(inputs)).

        ``min_points`` > 0 drops grid simplices with fewer data points; 0 keeps the whole
        grid (a prior must then determine the empty simplices).
        """
        scaling = Scaling.from_data(x, structure.inputs, structure.knots_of)
        n = structure.ndim
        u = scaling.subset(structure.variables).transform(x[:, :n])
        res = tuple(c if c is not None else r
                    for c, r in zip(scaling.cells[:n], structure.resolution))
        if min_points > 0:
            tri = Triangulation.fit(u, res, min_points=min_points)
        else:  # the whole grid, empty simplices included (a prior must determine them)
            tri = Triangulation.grid(np.zeros(n), np.ones(n), res)
        orders = np.where(cell_facets(tri), structure.degree, structure.continuity) \
            if structure.cellwise else None
        space = SplineSpace(tri, structure.degree, structure.continuity, orders)
        if not structure.varying:
            return cls(scaling, u, None, ((), ()), space)
        m = multiplier_values(structure, x)
        const = np.array([name == "1" for name in structure.multipliers])
        # with a constant term the others are centred (see AeroModel.multiplier_offset)
        offsets = np.where(const | (not const.any()), 0.0, m.mean(axis=0))
        scales = np.sqrt(np.mean((m - offsets) ** 2, axis=0))
        scales[const] = 1.0
        zero = [name for name, sc in zip(structure.multipliers, scales) if not sc > 0]
        if zero:
            raise InputError(f"multiplier(s) {zero} of {structure.coefficient} are "
                             "constant throughout the identification data: remove them")
        return cls(scaling, u, (m - offsets) / scales,
                   (tuple(float(v) for v in scales), tuple(float(v) for v in offsets)),
                   VaryingCoefficientSpace(space, structure.nterms, structure.term_dims,
                                           _term_facets(structure, scaling, tri)))


def _term_facets(structure: Structure, scaling: Scaling, tri) -> list | None:
    """Per term, None or (facets, stretched out-of-facet points): the facets on the grid
    planes of the model's breakpoints that the term's own breakpoints leave out, across
    which the term is one polynomial *in physical units* (the scaling's cells on the two
    sides of such a plane may differ in width: the out-of-facet vertex is moved by the
    ratio of the widths, see ``build_conditions``)."""
    if not any(structure.term_knots):
        return None
    sc = scaling.subset(structure.variables)
    facets = tri.facets
    verts = np.asarray(tri.vertices)
    sigma = verts[np.asarray(tri.simplices)[facets.simplices[:, 0], facets.out_positions[:, 0]]]
    out = []
    for own in structure.term_knots:
        mask, points = np.zeros(len(facets), dtype=bool), sigma.copy()
        for v, keep in own.items():
            i = structure.variables.index(v)
            used = np.asarray(sc.knots[i], dtype=float)      # ends and breakpoints in use
            m = len(used) - 1
            for j in range(1, m):
                if np.any(np.abs(np.asarray(keep) - used[j]) <= 1e-9 * (1 + abs(used[j]))):
                    continue
                on = plane_facets(tri, i, [j / m])
                below, above = used[j] - used[j - 1], used[j + 1] - used[j]
                du = sigma[on, i] - j / m                  # sigma's side of the plane
                ratio = np.where(du < 0, below / above, above / below)
                points[on, i] = j / m + du * ratio
                mask |= on
        out.append((mask, points) if mask.any() else None)
    return out


def accumulate(space, u, m, y, weights=None):
    """Normal equations of (u, m, y) on a plain (``m`` None) or varying-coefficient space."""
    if m is None:
        return space.normal_equations(u, y, weights)
    return space.normal_equations(u, m, y, weights)


def evaluate(spline, u, m, outside: str = "extrapolate") -> np.ndarray:
    """Values of a plain (``m`` None) or varying-coefficient spline at scaled points."""
    return spline.predict(u, outside=outside) if m is None else \
        spline.predict(u, m, outside=outside)
