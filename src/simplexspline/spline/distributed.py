"""Distributed fitting on a Dask cluster (optional extra: ``pip install 'simplexspline[dask]'``).

Each partition of the data produces its per-simplex normal-equation blocks (the sufficient
statistics of the least-squares problem); the blocks are summed in a tree on the workers
and the constrained solve happens once, on the client. Only the triangulation's arrays and
the blocks travel between processes, never the data.

Point it at an existing cluster the usual Dask way: create a client before calling
:func:`fit_dask` (``from dask.distributed import Client; Client("tcp://scheduler:8786")``),
or pass ``scheduler=`` (a client, or a scheduler name such as ``"threads"``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from simplexspline.errors import InputError
from simplexspline.spline.fit.normal_equations import NormalEquations
from simplexspline.spline.space import SplineSpace
from simplexspline.spline.geometry.triangulation import Triangulation

__all__ = ["fit_dask", "normal_equations_dask"]

_FIELDS = ("XtWX", "XtWy", "ytWy", "wsum", "counts")


def _partition_blocks(tri_arrays: dict, degree: int, x, y, w) -> dict:
    """Normal-equation blocks of one partition, as plain arrays."""
    tri = Triangulation.from_arrays(tri_arrays, check=False)
    ne = NormalEquations(tri, degree)
    x = np.asarray(x, dtype=float)
    if len(x):
        # one thread per task: the cluster's workers already share the cores
        ne.add(x, np.asarray(y, dtype=float).ravel(),
               None if w is None else np.asarray(w, dtype=float).ravel(), threads=1)
    return {k: getattr(ne, k) for k in _FIELDS}


def _frame_blocks(tri_arrays: dict, degree: int, frame, columns, target, weight) -> dict:
    w = None if weight is None else frame[weight].to_numpy()
    return _partition_blocks(tri_arrays, degree, frame[list(columns)].to_numpy(),
                             frame[target].to_numpy(), w)


def _sum_blocks(*parts: dict) -> dict:
    out = {k: parts[0][k].copy() if isinstance(parts[0][k], np.ndarray) else parts[0][k]
           for k in _FIELDS}
    for part in parts[1:]:
        for k in _FIELDS:
            out[k] = out[k] + part[k]
    return out


def normal_equations_dask(space: SplineSpace, data, *, columns: Sequence[str] | None = None,
                          target: str | None = None, weight: str | None = None, y=None,
                          weights=None, split_every: int = 8, scheduler=None) -> NormalEquations:
    """Accumulate normal equations from Dask collections on a cluster.

    Parameters
    ----------
    space : SplineSpace
    data : dask.dataframe.DataFrame or dask.array.Array
        A DataFrame (with ``columns``, ``target`` and optional ``weight`` names), or an
        array of points of shape (N, n) chunked along rows only (with ``y`` and optional
        ``weights`` dask arrays chunked like it).
    split_every : int, default 8
        Fan-in of the tree reduction of the blocks.
    scheduler : optional
        Passed to ``dask.compute`` (a ``distributed.Client``, or e.g. ``"threads"``); by
        default the current client, if any.

    Returns
    -------
    NormalEquations
    """
    import dask

    tri_arrays = space.triangulation.to_arrays()
    deg = space.degree
    if hasattr(data, "to_delayed") and hasattr(data, "columns"):
        if columns is None or target is None:
            raise InputError("with a Dask DataFrame, give columns=[...] (the n input "
                             "variables) and target='...' (the output column)")
        missing = [c for c in [*columns, target] + ([weight] if weight else [])
                   if c not in data.columns]
        if missing:
            raise InputError(f"columns {missing} are not in the DataFrame (it has "
                             f"{list(data.columns)})")
        if len(columns) != space.ndim:
            raise InputError(f"{len(columns)} columns given for a {space.ndim}-D spline space")
        parts = [dask.delayed(_frame_blocks)(tri_arrays, deg, part, tuple(columns), target,
                                             weight)
                 for part in data.to_delayed()]
    elif hasattr(data, "to_delayed") and hasattr(data, "chunks"):
        if y is None:
            raise InputError("with a Dask array of points, give y= (a Dask array of values)")
        if data.ndim != 2 or data.shape[1] != space.ndim or len(data.chunks[1]) != 1:
            raise InputError(f"the points must be a 2-D Dask array of shape (N, {space.ndim}) "
                             f"chunked along rows only, got shape {data.shape}")
        if y.chunks[0] != data.chunks[0] or (weights is not None
                                             and weights.chunks[0] != data.chunks[0]):
            raise InputError("y (and weights) must be chunked like the points along rows")
        xs = data.to_delayed().ravel()
        ys = y.to_delayed().ravel()
        ws = weights.to_delayed().ravel() if weights is not None else [None] * len(xs)
        parts = [dask.delayed(_partition_blocks)(tri_arrays, deg, xp, yp, wp)
                 for xp, yp, wp in zip(xs, ys, ws)]
    else:
        raise InputError("data must be a dask.dataframe.DataFrame or a dask.array.Array")
    if not parts:
        raise InputError("the Dask collection has no partitions")
    split_every = max(2, int(split_every))
    while len(parts) > 1:
        parts = [dask.delayed(_sum_blocks)(*parts[i:i + split_every])
                 for i in range(0, len(parts), split_every)]
    kwargs = {} if scheduler is None else {"scheduler": scheduler}
    (total,) = dask.compute(parts[0], **kwargs)
    ne = NormalEquations(space.triangulation, deg)
    for k in _FIELDS:
        setattr(ne, k, total[k] if isinstance(total[k], np.ndarray) else float(total[k]))
    return ne


def fit_dask(space: SplineSpace, data, *, on_insufficient: str = "raise",
             ridge: float | None = None, **kwargs):
    """Fit a spline to data held in Dask collections (see :func:`normal_equations_dask`).

    Returns
    -------
    SimplexSpline
        Equal (to round-off) to ``space.fit`` on the same data in memory.

    Examples
    --------
    >>> from dask.distributed import Client, LocalCluster            # doctest: +SKIP
    >>> client = Client(LocalCluster(n_workers=2))                    # doctest: +SKIP
    >>> spline = fit_dask(space, ddf, columns=["alpha", "de", "mach"],
    ...                   target="CZ")                                # doctest: +SKIP
    """
    ne = normal_equations_dask(space, data, **kwargs)
    return space.solve(ne, on_insufficient=on_insufficient, ridge=ridge)
