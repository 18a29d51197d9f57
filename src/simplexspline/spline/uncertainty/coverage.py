"""Data coverage of a triangulation: where is a simplex spline supported by data?

A simplex's coefficients are estimated from its Gram block ``Q_t = sum_i w_i B(b_i) B(b_i)'``
(the normal-equation block). How well the data determine them is measured by the block's
smallest eigenvalue, normalised two ways:

- ``information_t = lambda_min(Q_t / wsum_t) / lambda_min(G)``, with G the Gram matrix of
  the Bernstein basis on a unit-volume simplex: the expected block of one point drawn
  uniformly from the simplex. It is 0 for data on a
  lower-dimensional set (or in too few points), about 1 for many well spread points, and
  independent of the simplex's size and of the scale of the weights.
- ``effective_points_t = counts_t * information_t``: the number of ideally (uniformly in
  expectation) spread points that would give the same worst-direction information. The
  worst-determined coefficient combination has variance ``sigma^2 /
  (effective_points_t * lambda_min(G))``.

Rule: a simplex is *supported* when ``counts_t >= d_hat`` and ``effective_points_t >=
min_effective * d_hat`` (default ``min_effective = 0.5``). Calibration (measured, 200 draws
each, for (n, d) = (2, 3), (3, 3), (5, 3)): N uniformly random points in a simplex give
``effective_points / d_hat`` with median 0.6, 0.4, 0.3 for N = 3 d_hat; median 1.9, 1.2,
1.04 and 10 % quantile 0.95, 0.74, 0.75 for N = 5 d_hat; median 5.9, 4.5, 3.6 for
N = 10 d_hat. So simplices with at least about 5 d_hat well spread points are supported;
points crowded along a facet or into a corner give small values whatever their number.

The rule is per simplex: coefficients of an unsupported simplex may still be fixed by
continuity with its neighbours, but the spline there is an extrapolation of their data
(the divergence at thinly sampled envelope edges; see :mod:`simplexspline.spline.fit.penalty`
for the remedy).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simplexspline._files import atomic_write
from simplexspline.errors import InputError
from simplexspline.spline.bform import num_basis
from simplexspline.spline.fit.normal_equations import NormalEquations
from simplexspline.spline.fit.penalty import bernstein_gram
from simplexspline.spline.inputs import as_points

__all__ = ["Coverage", "coverage", "DEFAULT_MIN_EFFECTIVE"]

#: Default of ``min_effective``: a supported simplex carries at least the information of
#: d_hat / 2 ideally spread points.
DEFAULT_MIN_EFFECTIVE = 0.5


@dataclass
class Coverage:
    """Per-simplex data coverage (see the module docstring for the definitions).

    Attributes
    ----------
    triangulation : Triangulation
    degree : int
    counts : ndarray of int, shape (J,)
        Data points per simplex.
    weight : ndarray, shape (J,)
        Sum of the sample weights per simplex.
    information : ndarray, shape (J,)
        Normalised smallest eigenvalue of the simplex's Gram block (0 for empty simplices).
    effective_points : ndarray, shape (J,)
        ``counts * information``.
    supported : ndarray of bool, shape (J,)
        The rule ``counts >= d_hat and effective_points >= min_effective * d_hat``.
    min_effective : float
        The rule's threshold, in units of d_hat.
    """

    triangulation: object
    degree: int
    counts: np.ndarray
    weight: np.ndarray
    information: np.ndarray
    effective_points: np.ndarray
    supported: np.ndarray
    min_effective: float = DEFAULT_MIN_EFFECTIVE
    _volumes: np.ndarray = field(default=None, repr=False)

    @property
    def nbasis(self) -> int:
        """d_hat, coefficients per simplex."""
        return num_basis(self.triangulation.ndim, self.degree)

    @property
    def rule(self) -> str:
        """The supported-simplex rule in words."""
        return (f"counts >= d_hat ({self.nbasis}) and effective points >= "
                f"{self.min_effective:g} * d_hat")

    def summary(self) -> dict:
        """Totals: simplices, supported simplices, fractions of volume and of data in
        supported simplices, empty simplices, quantiles of the information.

        Returns
        -------
        dict
            JSON-serialisable.
        """
        vol = self._volumes if self._volumes is not None else self.triangulation.volumes()
        nonempty = self.counts > 0
        info = self.information[nonempty]
        npts = int(self.counts.sum())
        return {
            "simplices": int(len(self.counts)),
            "supported": int(self.supported.sum()),
            "empty": int((~nonempty).sum()),
            "points": npts,
            "volume_fraction_supported": float(vol[self.supported].sum() / vol.sum()),
            "data_fraction_supported": (float(self.counts[self.supported].sum() / npts)
                                        if npts else 0.0),
            "information_min": float(info.min()) if len(info) else 0.0,
            "information_median": float(np.median(info)) if len(info) else 0.0,
            "rule": self.rule,
        }

    def __str__(self) -> str:
        s = self.summary()
        return (f"coverage: {s['supported']} of {s['simplices']} simplices supported "
                f"({100 * s['volume_fraction_supported']:.1f} % of the volume, "
                f"{100 * s['data_fraction_supported']:.1f} % of the data), {s['empty']} "
                f"empty; rule: {s['rule']}")

    def supported_at(self, x) -> np.ndarray:
        """Whether points lie in supported simplices.

        Parameters
        ----------
        x : array_like, shape (N, n)

        Returns
        -------
        ndarray of bool, shape (N,)
            False outside the triangulation and in unsupported simplices.
        """
        sid = self.triangulation.locate(as_points(x, name="x", ndim=self.triangulation.ndim))
        out = np.zeros(len(sid), dtype=bool)
        inside = sid >= 0
        out[inside] = self.supported[sid[inside]]
        return out

    def plot(self, dims=(0, 1), *, ax=None, points=None, path=None, labels=None):
        """Map of the coverage on a 2-D projection (needs matplotlib).

        For n = 2 the simplices are drawn, coloured by ``log10(effective_points / d_hat)``,
        unsupported ones outlined in red; for n > 2 the simplices' centroids are projected
        on the chosen two variables (o supported, x unsupported; projections overlap).

        Parameters
        ----------
        dims : (int, int)
            The two variables shown.
        ax : matplotlib Axes, optional
            Draw into these axes; otherwise a new figure is made.
        points : array_like, shape (N, n), optional
            Data points to overlay (projected; at most 20,000 drawn).
        path : str or Path, optional
            Write the figure as PNG (atomically).
        labels : (str, str), optional
            Axis labels.

        Returns
        -------
        matplotlib.figure.Figure
        """
        try:
            from matplotlib.collections import PolyCollection
            from matplotlib.figure import Figure
        except ImportError:  # pragma: no cover - matplotlib is an optional extra
            raise ImportError("Coverage.plot needs matplotlib: pip install matplotlib") from None
        tri = self.triangulation
        n = tri.ndim
        dims = tuple(int(k) for k in dims)
        if n < 2 or len(dims) != 2 or dims[0] == dims[1] or min(dims) < 0 or max(dims) >= n:
            raise InputError(f"dims must be two different variables in 0..{n - 1}, got {dims}")
        if ax is None:
            fig = Figure(figsize=(6.0, 4.8), dpi=100)
            ax = fig.add_subplot(1, 1, 1)
        else:
            fig = ax.figure
        level = np.log10(np.maximum(self.effective_points / self.nbasis, 1e-3))
        vmin, vmax = -3.0, max(2.0, float(level.max()))
        if n == 2:
            polys = np.asarray(tri.corners)[:, :, list(dims)]
            pc = PolyCollection(polys, array=level, cmap="viridis", edgecolors="0.6",
                                linewidths=0.3)
            pc.set_clim(vmin, vmax)
            ax.add_collection(pc)
            bad = polys[~self.supported]
            if len(bad):
                ax.add_collection(PolyCollection(bad, facecolors="none", edgecolors="red",
                                                 linewidths=1.0))
            mappable = pc
            ax.autoscale_view()
        else:
            cen = tri.centroids()[:, list(dims)]
            ok = self.supported
            mappable = ax.scatter(cen[ok, 0], cen[ok, 1], c=level[ok], cmap="viridis",
                                  vmin=vmin, vmax=vmax, marker="o", s=18)
            ax.scatter(cen[~ok, 0], cen[~ok, 1], c=level[~ok], cmap="viridis", vmin=vmin,
                       vmax=vmax, marker="x", s=24)
        if points is not None:
            p = as_points(points, name="points", ndim=n)
            if len(p) > 20000:
                p = p[np.random.default_rng(0).choice(len(p), 20000, replace=False)]
            ax.plot(p[:, dims[0]], p[:, dims[1]], ",", color="k", alpha=0.5)
        fig.colorbar(mappable, ax=ax, label="log10(effective points / d_hat)")
        lab = labels or (f"x{dims[0]}", f"x{dims[1]}")
        ax.set_xlabel(lab[0])
        ax.set_ylabel(lab[1])
        s = self.summary()
        ax.set_title(f"{s['supported']}/{s['simplices']} simplices supported "
                     f"(red/x: not)", fontsize=9)
        if path is not None:
            atomic_write(Path(path), lambda tmp: fig.savefig(tmp, format="png"))
        return fig


def coverage(normal_equations, *, min_effective: float = DEFAULT_MIN_EFFECTIVE) -> Coverage:
    """Per-simplex coverage of accumulated data.

    Parameters
    ----------
    normal_equations : NormalEquations
        Accumulated data (``SplineSpace.normal_equations(x, y)``; y may be zeros).
    min_effective : float, default 0.5
        Threshold of the supported rule, in units of d_hat.

    Returns
    -------
    Coverage

    Examples
    --------
    >>> import numpy as np
    >>> from simplexspline import Triangulation, SplineSpace
    >>> rng = np.random.default_rng(0)
    >>> x = rng.uniform(0, 1, (4000, 2)) * [0.5, 1.0]          # data only where x0 < 0.5
    >>> space = SplineSpace(Triangulation.grid([0, 0], [1, 1], (4, 4)), 2, 1)
    >>> cov = coverage(space.normal_equations(x, np.zeros(len(x))))
    >>> cov.supported_at([[0.2, 0.5], [0.9, 0.5]]).tolist()
    [True, False]
    """
    if not isinstance(normal_equations, NormalEquations):
        raise InputError("coverage() takes a NormalEquations accumulator "
                         "(from SplineSpace.normal_equations)")
    if not np.isfinite(min_effective) or min_effective < 0:
        raise InputError(f"min_effective must be a finite number >= 0, got {min_effective!r}")
    ne = normal_equations
    tri = ne.triangulation
    dh = num_basis(tri.ndim, ne.degree)
    lam0 = float(np.linalg.eigvalsh(bernstein_gram(tri.ndim, ne.degree))[0])
    info = np.zeros(tri.nsimplex)
    ok = ne.wsum > 0
    if np.any(ok):
        lmin = np.linalg.eigvalsh(ne.XtWX[ok] / ne.wsum[ok][:, None, None])[:, 0]
        info[ok] = np.maximum(lmin, 0.0) / lam0
    eff = ne.counts * info
    supported = (ne.counts >= dh) & (eff >= min_effective * dh)
    return Coverage(tri, ne.degree, ne.counts.copy(), ne.wsum.copy(), info, eff, supported,
                    float(min_effective), tri.volumes())
