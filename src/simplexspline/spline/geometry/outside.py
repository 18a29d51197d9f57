"""What evaluation does at points outside a triangulation: the ``outside=`` vocabulary.

One set of names for every evaluating API (splines, varying-coefficient splines,
uncertainty bounds, the scikit-learn estimator, aerodynamic models, exported C):

- ``'nan'``: NaN at outside points;
- ``'raise'``: :class:`~simplexspline.errors.OutsideDomainError` naming the points;
- ``'extrapolate'``: the polynomial piece of the nearest simplex;
- ``'clamp'``: the value at the nearest point of the domain's bounding box (an estimator's
  and an exported model's choice: inputs are clipped to the data's box).

Each API accepts a subset of these, stated in its ``*_POLICIES`` constant below.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from simplexspline.errors import InputError, OutsideDomainError

__all__ = ["AERO_POLICIES", "EXPORT_POLICIES", "OUTSIDE_POLICIES", "SPLINE_POLICIES",
           "check_policy", "locate", "located_data", "resolve_outside"]

#: Every outside policy of the project.
OUTSIDE_POLICIES: tuple[str, ...] = ("nan", "raise", "extrapolate", "clamp")

#: Policies of :meth:`SimplexSpline.predict` and its derivatives.
SPLINE_POLICIES: tuple[str, ...] = ("nan", "raise", "extrapolate")

#: Policies of aerodynamic models and the scikit-learn estimator.
AERO_POLICIES: tuple[str, ...] = ("clamp", "nan", "extrapolate")

#: Policies of exported C code and lookup tables.
EXPORT_POLICIES: tuple[str, ...] = ("nan", "clamp", "extrapolate")


def check_policy(policy: str, allowed: Sequence[str] = SPLINE_POLICIES, *,
                 name: str = "outside") -> str:
    """``policy`` if it is one of ``allowed``, else an :class:`InputError` listing them.

    Parameters
    ----------
    policy : str
        The policy asked for.
    allowed : sequence of str
        The policies of the calling API (a subset of :data:`OUTSIDE_POLICIES`).
    name : str
        The argument's name in the message.
    """
    if policy not in allowed:
        raise InputError(f"{name} must be one of {tuple(allowed)}, got {policy!r}")
    return policy


def located_data(triangulation, points: np.ndarray) -> np.ndarray:
    """The simplex of every data point of a fit, which must all lie inside.

    Parameters
    ----------
    triangulation : Triangulation
    points : ndarray, shape (N, n)
        Checked, finite points.

    Returns
    -------
    ndarray of int64, shape (N,)

    Raises
    ------
    OutsideDomainError
        Naming the rows outside the triangulation.
    """
    sid = triangulation.locate(points)
    out = np.nonzero(sid < 0)[0]
    if len(out):
        raise OutsideDomainError(
            f"{len(out)} of {len(points)} points lie outside the triangulation (first rows: "
            f"{out[:5].tolist()}); drop them or enlarge the triangulation", out)
    return sid


def locate(triangulation, points: np.ndarray, outside: str = "nan"
           ) -> tuple[np.ndarray, np.ndarray]:
    """The simplex of each point under an outside policy of :data:`SPLINE_POLICIES`.

    The one place where evaluating APIs (splines, varying-coefficient splines, uncertainty
    bounds) turn point location and an ``outside=`` policy into simplex indices.

    Parameters
    ----------
    triangulation : Triangulation
    points : ndarray, shape (N, n)
        Checked, finite points.
    outside : {'nan', 'raise', 'extrapolate'}, default 'nan'
        ``'nan'``: outside points get simplex -1 and ``valid`` False; ``'raise'``:
        :class:`~simplexspline.errors.OutsideDomainError` naming them; ``'extrapolate'``:
        the nearest simplex (every point valid).

    Returns
    -------
    simplices : ndarray of int64, shape (N,)
    valid : ndarray of bool, shape (N,)
        Points that have a simplex.
    """
    check_policy(outside, SPLINE_POLICIES)
    return resolve_outside(triangulation, points, triangulation._locate_checked(points),
                           outside)


def resolve_outside(triangulation, points: np.ndarray, sid: np.ndarray, outside: str = "nan"
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The outside policy applied to located points (the second half of :func:`locate`,
    for callers that located the points themselves).

    Parameters
    ----------
    triangulation : Triangulation
    points : ndarray, shape (N, n)
        Checked, finite points.
    sid : ndarray of int64, shape (N,)
        Their simplices, -1 outside; changed in place under ``'extrapolate'``.
    outside : {'nan', 'raise', 'extrapolate'}, default 'nan'
        As in :func:`locate` (checked by the caller).

    Returns
    -------
    simplices : ndarray of int64, shape (N,)
    valid : ndarray of bool, shape (N,)
    """
    valid = sid >= 0
    if not valid.all():
        bad = np.nonzero(~valid)[0]
        if outside == "raise":
            raise OutsideDomainError(
                f"{len(bad)} of {len(points)} points lie outside the triangulation (first "
                f"rows: {bad[:5].tolist()}); use outside='nan' or 'extrapolate'", bad)
        if outside == "extrapolate":
            sid[bad] = triangulation.nearest(points[bad])
            valid[:] = True
    return sid, valid
