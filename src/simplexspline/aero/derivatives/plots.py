"""Plots of stability and control derivatives: lines along a variable, maps over two.

Both take the wide table of :func:`~simplexspline.aero.derivatives.stability.derivatives` (its
``attrs`` describe each derivative; ``inside_<C>`` and ``samples_<C>`` give the domain and
the data support of each model) and return a matplotlib Figure (no pyplot is used):

* :func:`plot_derivatives`: derivatives along ``x`` with one line per value of ``by``;
* :func:`plot_derivative_map`: maps of derivatives over a grid of ``x`` and ``y``.

Angles are shown in degrees on the axes; derivatives stay in SI units (per rad).
docs/derivatives.md.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from simplexspline.aero.variables import UNITS
from simplexspline.errors import InputError

__all__ = ["plot_derivative_map", "plot_derivatives"]


def _display(var: str) -> tuple[str, float]:
    unit = UNITS.get(var, "")
    if unit == "rad":
        return "deg", 180.0 / math.pi
    if unit == "rad/s":
        return "deg/s", 180.0 / math.pi
    return ("-" if unit.startswith("-") else unit), 1.0


def _names(table, names) -> list:
    info = table.attrs.get("derivatives") or {}
    if names is None:
        return [k for k, d in info.items() if d["in_model"]]
    bad = [k for k in names if k not in table.columns]
    if bad:
        raise InputError(f"unknown derivative(s) {bad}; the table has {list(info)}")
    return list(names)


def _spans(x: np.ndarray, mask: np.ndarray) -> list:
    """Contiguous [lo, hi] intervals of sorted ``x`` where ``mask`` holds (to midpoints)."""
    if not mask.any():
        return []
    edges = np.concatenate([[x[0]], 0.5 * (x[1:] + x[:-1]), [x[-1]]])
    out, start = [], None
    for i, m in enumerate(mask):
        if m and start is None:
            start = i
        if (not m or i == len(mask) - 1) and start is not None:
            stop = i if m else i - 1
            out.append((edges[start], edges[stop + 1]))
            start = None
    return out


def _figure(n: int, ncols: int, fig, w: float = 3.6, h: float = 2.8):
    from matplotlib.figure import Figure  # optional dependency (the 'aero' extra)

    ncols = max(1, min(ncols, n))
    nrows = math.ceil(n / ncols)
    if fig is None:    # fixed margins in inches (no layout engine: faster)
        width, height = w * ncols, h * nrows
        fig = Figure(figsize=(width, height))
        # (after construction: Figure() resets ``subplotpars`` given to it, matplotlib 3.11)
        fig.subplots_adjust(left=0.75 / width, right=1 - 0.2 / width, bottom=0.5 / height,
                            top=1 - 0.3 / height, wspace=0.35,
                            hspace=0.55)
    axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False)).ravel()
    for ax in axes[n:]:
        ax.set_visible(False)
    return fig, axes[:n]


def plot_derivatives(table, names: Sequence[str] | None = None, *, x: str = "alpha",
                     by: str | None = "mach", ncols: int = 3, thin_factor: float = 2.0,
                     fig=None):
    """Derivatives along ``x`` with one line per value of ``by`` (a matplotlib Figure).

    Parameters
    ----------
    table : DataFrame
        Wide output of :func:`derivatives` on a grid of ``x`` (and ``by``).
    names : sequence of str, optional
        Derivative columns (default every derivative in its model).
    x, by : str
        Abscissa and line variable (angles shown in degrees; derivatives stay per rad).
        ``by=None`` or a column the table lacks: one line.
    ncols : int
    thin_factor : float
        Dashed where the simplex holding the condition has fewer than ``thin_factor *
        d_hat`` identification samples (``samples_<C>``; as the identification's thin
        simplices).
    fig : matplotlib.figure.Figure, optional
        Drawn into (default a new Figure; no pyplot is used).

    Returns
    -------
    matplotlib.figure.Figure
        Solid where the condition lies in the model's domain (dashed in thinly covered
        simplices; shaded +- 2 standard errors where the table has ``se_<name>``
        columns, :func:`~simplexspline.aero.derivatives.jackknife.with_standard_errors`),
        dotted where the values are
        extrapolated (``outside='extrapolate'``), a bar in the line's colour along the
        bottom where that line is outside the domain, grey where every line is. A model
        that does not depend on ``by`` gets one black line.
    """
    names = _names(table, names)
    if x not in table.columns:
        raise InputError(f"the table has no column {x!r} to plot along")
    if not names:
        raise InputError("no derivative to plot: the models do not depend on the variables")
    info = table.attrs.get("derivatives") or {}
    variables = table.attrs.get("variables") or {}
    groups = ([(None, np.ones(len(table), dtype=bool))] if by is None or by not in table
              or table[by].nunique() < 2 else
              [(val, (table[by] == val).to_numpy()) for val in np.unique(table[by])])
    fig, axes = _figure(len(names), ncols, fig)
    xunit, xf = _display(x)
    from matplotlib import colormaps  # optional dependency (the 'aero' extra)

    cmap = colormaps["viridis"]
    xall = table[x].to_numpy(dtype=float) * xf
    for ax, name in zip(axes, names):
        d = info.get(name, {})
        coef = d.get("coefficient", name.split("_")[0])
        flag = table.get(f"inside_{coef}")
        inside = (np.ones(len(table), bool) if flag is None else flag.to_numpy(dtype=bool))
        yall = table[name].to_numpy(dtype=float)
        support = (table[f"samples_{coef}"].to_numpy(dtype=float)
                   if f"samples_{coef}" in table.columns else np.full(len(table), np.inf))
        limit = thin_factor * (table.attrs.get("nbasis") or {}).get(coef, 0)
        mine = groups
        if len(groups) > 1 and coef in variables and by not in variables[coef]:
            mine = groups[:1]    # the model does not depend on ``by``: one line
        bar = 0.035
        for k, (val, sel) in enumerate(mine):
            colour = "k" if mine is not groups else cmap(0.9 * k / max(1, len(groups) - 1))
            order = np.argsort(xall[sel], kind="stable")
            xs, ys, ins = xall[sel][order], yall[sel][order], inside[sel][order]
            label = (None if val is None else f"any {by}" if mine is not groups
                     else f"{by} = {val:.3g}" + ("" if ins.any() else " (outside)"))
            thin = ins & (support[sel][order] < limit)
            ax.plot(xs, np.where(ins & ~thin, ys, np.nan), "-", color=colour, lw=1.5,
                    label=label)
            if f"se_{name}" in table.columns:    # +- 2 jackknife standard errors
                se = table[f"se_{name}"].to_numpy(dtype=float)[sel][order]
                band = ins & np.isfinite(se)
                ax.fill_between(xs, np.where(band, ys - 2 * se, np.nan),
                                np.where(band, ys + 2 * se, np.nan), color=colour,
                                alpha=0.15, lw=0)
            if thin.any():    # in a simplex with few samples: dashed, joined to the line
                near = thin | np.r_[thin[1:], False] | np.r_[False, thin[:-1]]
                ax.plot(xs, np.where(near & ins, ys, np.nan), "--", color=colour, lw=1.0)
            out = ~ins
            if np.isfinite(ys[out]).any():    # extrapolated: dotted, joined to the line
                near = out | np.r_[out[1:], False] | np.r_[False, out[:-1]]
                ax.plot(xs, np.where(near, ys, np.nan), ":", color=colour, lw=1.0)
            for lo, hi in _spans(xs, out):    # a bar at the bottom per line outside
                ax.axvspan(lo, hi, ymin=k * bar, ymax=(k + 1) * bar, color=colour,
                           alpha=0.6, lw=0)
        order = np.argsort(xall, kind="stable")
        nowhere = np.array([not inside[xall == v].any() for v in xall[order]])
        for lo, hi in _spans(xall[order], nowhere):
            ax.axvspan(lo, hi, color="#999", alpha=0.2, lw=0)
        ax.axhline(0.0, color="#888", lw=0.5)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel(f"{x} [{xunit}]", fontsize=8)
        ax.set_ylabel(f"[{d.get('unit', '')}]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        if len(mine) > 1 or (mine is not groups and len(groups) > 1):
            ax.legend(fontsize=6, loc="best")
    return fig


def plot_derivative_map(table, names: Sequence[str] | None = None, *, x: str = "alpha",
                        y: str = "mach", ncols: int = 3, thin_factor: float = 2.0,
                        fig=None):
    """Maps of derivatives over a 2-D grid of ``x`` and ``y`` (a matplotlib Figure).

    Grey where the derivative is NaN (outside the model's domain with ``outside='nan'``);
    hatched where the simplex holding the condition has fewer than ``thin_factor * d_hat``
    identification samples; with extrapolated values, a dashed contour marks the domain
    boundary. The colour scale spans the 2-98 % percentiles of the thickly supported
    values (arrows on the colour bar: values beyond).
    """
    names = _names(table, names)
    for v in (x, y):
        if v not in table.columns:
            raise InputError(f"the table has no column {v!r} for the map")
    if not names:
        raise InputError("no derivative to plot: the models do not depend on the variables")
    xs, ys = np.unique(table[x].to_numpy(float)), np.unique(table[y].to_numpy(float))
    if len(xs) * len(ys) != len(table) or len(xs) < 2 or len(ys) < 2:
        raise InputError(f"a map needs the table of a full {x} x {y} grid (condition_grid "
                         f"with both as axes); got {len(table)} rows for {len(xs)} x "
                         f"{len(ys)} values")
    ix = np.searchsorted(xs, table[x].to_numpy(float))
    iy = np.searchsorted(ys, table[y].to_numpy(float))
    info = table.attrs.get("derivatives") or {}
    fig, axes = _figure(len(names), ncols, fig, w=4.2, h=3.2)
    (xu, xf), (yu, yf) = _display(x), _display(y)

    def grid(values):
        out = np.full((len(ys), len(xs)), np.nan)
        out[iy, ix] = values
        return out

    for ax, name in zip(axes, names):
        coef = info.get(name, {}).get("coefficient", name.split("_")[0])
        z = grid(table[name].to_numpy(float))
        limit = thin_factor * (table.attrs.get("nbasis") or {}).get(coef, 0)
        thin = (grid(table[f"samples_{coef}"].to_numpy(float)) < limit
                if f"samples_{coef}" in table.columns else np.zeros(z.shape, bool))
        ins = (grid(table[f"inside_{coef}"].to_numpy(float))
               if f"inside_{coef}" in table.columns else np.ones(z.shape))
        ax.set_facecolor("#d9d9d9")
        good = z[np.isfinite(z) & ~(thin & (ins > 0))]
        good = good if good.size else z[np.isfinite(z)]
        lo, hi = (np.percentile(good, [2, 98]) if good.size else (-1.0, 1.0))
        lo, hi = float(lo), float(hi)
        if hi - lo < 1e-6 * max(abs(lo), abs(hi), 1e-12):    # constant up to rounding
            mid = 0.5 * (lo + hi)
            lo, hi = mid - max(0.01 * abs(mid), 1e-9), mid + max(0.01 * abs(mid), 1e-9)
        mesh = ax.pcolormesh(xs * xf, ys * yf, np.ma.masked_invalid(z), shading="nearest",
                             cmap="viridis", vmin=lo, vmax=hi)
        finite = z[np.isfinite(z)]
        extend = ("both" if finite.min() < lo and finite.max() > hi else "min"
                  if finite.min() < lo else "max" if finite.max() > hi else "neither") \
            if finite.size else "neither"
        bar = fig.colorbar(mesh, ax=ax, shrink=0.9, extend=extend)
        bar.formatter.set_useOffset(False)
        bar.ax.tick_params(labelsize=7)
        marked = thin & (ins > 0)
        if marked.any():
            ax.contourf(xs * xf, ys * yf, marked.astype(float), levels=[0.5, 1.5],
                        colors="none", hatches=["////"])
        if 0 < ins.sum() < ins.size and np.isfinite(z[ins == 0]).any():
            ax.contour(xs * xf, ys * yf, ins, levels=[0.5], colors="k", linestyles="--",
                       linewidths=0.8)
        ax.set_title(f"{name} [{info.get(name, {}).get('unit', '')}]", fontsize=9)
        ax.set_xlabel(f"{x} [{xu}]", fontsize=8)
        ax.set_ylabel(f"{y} [{yu}]", fontsize=8)
        ax.tick_params(labelsize=7)
    return fig
