"""The identification report's figures of the paper's kinds (de Visser et al., AIAA 2010-7950).

The identification data's 2-D and 3-D projections with their convex hull (Fig. 7), one
example maneuver of each type (Fig. 8-11) and, per coefficient, the structure-selection
history, 3-D slices through the model along a third variable (Fig. 12-20), validation time
series of measured vs model output and the error (Fig. 13-21), the residual
autocorrelation with the identification samples per simplex, and the triangulation
projected on two variables over the data. Each ``_fig_*`` function takes the
:class:`~simplexspline.aero.report.render._Renderer` first and returns a
:class:`~simplexspline.aero.report.document.Figure`, or None when there is nothing to show.
"""

from __future__ import annotations

import math
from itertools import combinations

import numpy as np

from simplexspline.aero.report.markup import _NAMES, _column, _disp, _fmt, _label, _unit
from simplexspline.aero.report.document import Figure

#: Most points drawn in a scatter / along a time series line.
_MAX_SCATTER = 4000
_MAX_LINE = 2000

#: Pairs of variables shown in the data projections (Fig. 7 style), when in the data.
_PROJECTIONS = (("alpha", "de"), ("alpha", "mach"), ("alpha", "beta"), ("alpha", "qhat"),
                ("beta", "dr"), ("beta", "da"), ("phat", "da"), ("rhat", "dr"))


def _subsample(n: int, k: int, seed: int = 0) -> np.ndarray:
    if n <= k:
        return np.arange(n)
    return np.sort(np.random.default_rng(seed).choice(n, size=k, replace=False))


def _decimate(n: int, k: int = _MAX_LINE) -> slice:
    return slice(None, None, max(1, math.ceil(n / k)))


def _varies(df, name: str) -> bool:
    v = _column(df, name)
    return v is not None and len(v) > 1 and bool(np.all(np.isfinite(v))) and np.ptp(v) > 0


def _fig_projections(r, ident, valid) -> Figure | None:
    from scipy.spatial import ConvexHull, QhullError

    pairs = [p for p in _PROJECTIONS if _varies(ident, p[0]) and _varies(ident, p[1])][:6]
    if not pairs:
        return None
    ncol = min(3, len(pairs))
    nrow = math.ceil(len(pairs) / ncol)
    fig = r.new(3.6 * ncol, 3.0 * nrow, left=0.7, wspace=0.4, hspace=0.4)
    axes = np.atleast_1d(fig.subplots(nrow, ncol)).ravel()
    si = _subsample(len(ident), _MAX_SCATTER)
    sv = _subsample(len(valid), _MAX_SCATTER // 3, seed=1) if valid is not None else None
    for ax, (a, b) in zip(axes, pairs):
        x, y = _disp(a, _column(ident, a)), _disp(b, _column(ident, b))
        ax.scatter(x[si], y[si], s=1.5, c="#7a8db3", alpha=0.35, lw=0, rasterized=True,
                   label="identification")
        if sv is not None and _varies(valid, a) and _varies(valid, b):
            ax.scatter(_disp(a, _column(valid, a))[sv], _disp(b, _column(valid, b))[sv],
                       s=1.5, c="#e07b39", alpha=0.5, lw=0, label="validation")
        try:
            pts = np.column_stack([x, y])
            hull = ConvexHull(pts)
            ring = np.append(hull.vertices, hull.vertices[0])
            ax.plot(pts[ring, 0], pts[ring, 1], "k-", lw=1.2, label="convex hull")
        except (QhullError, ValueError):
            pass
        ax.set_xlabel(_label(a))
        ax.set_ylabel(_label(b))
    for ax in axes[len(pairs):]:
        ax.set_visible(False)
    axes[0].legend(loc="best", fontsize=7, markerscale=5)
    return r.save(fig, "data_projections",
                  "Fig. 7 style: 2-D projections of the identification data (blue) and the "
                  "validation data (orange) with the convex hull of the identification data")


def _fig_projection_3d(r, ident) -> Figure | None:
    from scipy.spatial import ConvexHull, QhullError

    names = [v for v in ("alpha", "de", "mach", "beta", "qhat") if _varies(ident, v)][:3]
    if len(names) < 3:
        return None
    pts = np.column_stack([_disp(v, _column(ident, v)) for v in names])
    try:
        hull = ConvexHull(pts)
    except (QhullError, ValueError):
        return None
    fig = r.new(6.0, 4.8, left=0.1, right=0.1, bottom=0.1, top=0.1)
    ax = fig.add_subplot(projection="3d")
    s = _subsample(len(pts), _MAX_SCATTER // 2)
    ax.scatter(pts[s, 0], pts[s, 1], pts[s, 2], s=2, c="#1f3d7a", alpha=0.6, lw=0,
               depthshade=False)
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    tri = Poly3DCollection(pts[hull.simplices], facecolor="#c9d3e0", edgecolor="#8899aa",
                           linewidths=0.15, alpha=0.08)
    ax.add_collection3d(tri)
    ax.set_xlabel(_label(names[0]))
    ax.set_ylabel(_label(names[1]))
    ax.set_zlabel(_label(names[2]))
    ax.view_init(elev=22, azim=-55)
    return r.save(fig, "data_projection_3d",
                  f"Fig. 7 style: 3-D projection of the identification data on "
                  f"({', '.join(names)}) with its convex hull ({len(hull.simplices)} facets)")


def _fig_time_history(r, df, maneuver, mtype: str, index: int) -> Figure:
    sel = df["maneuver"].to_numpy() == maneuver
    part = df.loc[sel]
    t = _column(part, "t")
    if t is None:
        t = np.arange(len(part), dtype=float)
    dec = _decimate(len(t))
    groups = [("control surfaces", ("de", "da", "dr")), ("air angles", ("alpha", "beta")),
              ("body rates", ("p", "q", "r")), ("moment coefficients", ("Cl", "Cm", "Cn"))]
    groups = [(g, [v for v in vs if v in part.columns]) for g, vs in groups]
    groups = [(g, vs) for g, vs in groups if vs]
    fig = r.new(8.0, 1.45 * len(groups) + 0.6, left=0.7, top=0.2, hspace=0.5)
    axes = np.atleast_1d(fig.subplots(len(groups), 1, sharex=True))
    for ax, (group, vs) in zip(axes, groups):
        for v in vs:
            ax.plot(t[dec], _disp(v, _column(part, v))[dec], lw=0.9, label=_NAMES.get(v, v))
        unit = _unit(vs[0])[0]
        ax.set_ylabel(f"[{unit}]" if unit else "", fontsize=8)
        ax.set_title(group, fontsize=8, loc="left")
        ax.legend(loc="upper right", fontsize=7, ncol=len(vs))
        ax.tick_params(labelsize=7)
    axes[-1].set_xlabel("t [s]")
    speed = _column(part, "mach")
    where = (f" at Mach {np.median(speed):.2f}" if speed is not None and len(speed) else "")
    return r.save(fig, f"maneuver_{index}",
                  f"Fig. 8-11 style: identification maneuver {maneuver} ({mtype}){where}: "
                  "control inputs, response and moment coefficients")


def _fig_selection(r, c: str, history: list) -> Figure | None:
    scores = np.array([float(t.score) for t in history])
    if not np.any(np.isfinite(scores)):
        return None
    fig = r.new(7.0, 3.0, right=0.1)
    ax = fig.subplots()
    n = np.arange(1, len(history) + 1)
    fin = np.isfinite(scores)
    rounds = np.array([t.round for t in history])
    ax.scatter(n[fin], scores[fin], c=rounds[fin], cmap="viridis", s=22, zorder=3,
               label="tried (colour: round)")
    acc = np.array([bool(t.accepted) for t in history]) & fin
    if acc.any():
        ax.plot(n[acc], scores[acc], "r*-", ms=11, lw=1, zorder=4, label="accepted")
        for k in np.nonzero(acc)[0]:
            ax.annotate(history[k].move, (n[k], scores[k]), xytext=(4, 6),
                        textcoords="offset points", fontsize=7, color="#b11")
    if (~fin).any():
        top = np.nanmax(scores[fin])
        ax.scatter(n[~fin], np.full((~fin).sum(), top), marker="x", c="k", s=25,
                   label="failed")
    ax.set_xlabel("trial")
    ax.set_ylabel(f"k-fold CV RMS of {_NAMES.get(c, c)} [-]")
    ax.set_yscale("log")
    from matplotlib.ticker import NullLocator

    ax.yaxis.set_minor_locator(NullLocator())
    ax.legend(fontsize=7, loc="best")
    ax.grid(alpha=0.3)
    return r.save(fig, f"{c}_selection",
                  f"{c}: cross-validation score of every tried structure (lower is better)")


def _slice_values(model, ident, var: str, k: int = 3) -> np.ndarray:
    i = model.variables.index(var)
    lo, hi = model.scaling.lower[i], model.scaling.upper[i]
    data = _column(ident, var)
    if data is not None and len(data):
        q = np.quantile(data, np.linspace(0.05, 0.95, k))
        if np.ptp(q) > 0:
            return q
    return lo + (hi - lo) * np.linspace(0.15, 0.85, k)


def _fig_slices(r, c: str, model, ident) -> Figure:
    names = list(model.variables)
    n = len(names)
    medians = {v: float(np.median(_column(ident, v))) if _column(ident, v) is not None
               else 0.5 * (model.scaling.lower[i] + model.scaling.upper[i])
               for i, v in enumerate(names)}
    ngrid = 30
    if n == 1:
        fig = r.new(5.5, 3.5, left=0.8)
        ax = fig.subplots()
        x = np.linspace(model.scaling.lower[0], model.scaling.upper[0], 200)
        ax.plot(_disp(names[0], x), model.predict(x[:, None], outside="nan"))
        ax.set_xlabel(_label(names[0]))
        ax.set_ylabel(_NAMES.get(c, c))
        return r.save(fig, f"{c}_slices", f"{c} model output")
    a, b = names[0], names[1]
    xa = np.linspace(model.scaling.lower[0], model.scaling.upper[0], ngrid)
    xb = np.linspace(model.scaling.lower[1], model.scaling.upper[1], ngrid)
    ga, gb = np.meshgrid(xa, xb)
    third = names[2] if n >= 3 else None
    values = _slice_values(model, ident, third) if third else [None]
    surfaces = []
    for val in values:
        x = np.empty((ga.size, n))
        for i, v in enumerate(names):
            x[:, i] = medians[v]
        x[:, 0], x[:, 1] = ga.ravel(), gb.ravel()
        if third:
            x[:, 2] = val
        surfaces.append(model.predict(x, outside="nan").reshape(ga.shape))
    finite = np.concatenate([s[np.isfinite(s)] for s in surfaces] or [np.zeros(1)])
    zlim = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    if zlim[1] <= zlim[0]:
        zlim = (zlim[0] - 1e-3, zlim[1] + 1e-3)
    fig = r.new(4.0 * len(values), 3.7, left=0.0, right=0.35, bottom=0.1, top=0.3,
                wspace=0.15)
    da, db = _disp(a, ga), _disp(b, gb)
    for k, (val, z) in enumerate(zip(values, surfaces)):
        ax = fig.add_subplot(1, len(values), k + 1, projection="3d")
        zm = np.ma.masked_invalid(z)
        ax.plot_surface(da, db, zm, cmap="viridis", vmin=zlim[0], vmax=zlim[1],
                        rstride=1, cstride=1, linewidth=0, antialiased=False)
        ax.set_zlim(*zlim)
        ax.set_xlabel(_label(a), fontsize=8)
        ax.set_ylabel(_label(b), fontsize=8)
        ax.set_zlabel(_NAMES.get(c, c), fontsize=8)
        ax.tick_params(labelsize=6)
        ax.view_init(elev=25, azim=-60)
        if third:
            unit, f = _unit(third)
            unit = "" if unit == "-" else f" {unit}"
            i3 = names.index(third)
            span = float(model.scaling.upper[i3] - model.scaling.lower[i3]) * f
            digits = max(0, 2 - math.floor(math.log10(span))) if span > 0 else 3
            shown = round(val * f, digits) + 0.0   # + 0.0: no '-0.0'
            ax.set_title(f"{_NAMES.get(third, third)} = {shown:.{digits}f}{unit}", fontsize=9)
    rest = [v for v in names[3:]]
    fixed = ("; " + ", ".join(f"{v} = {medians[v] * _unit(v)[1]:.3g} {_unit(v)[0]}"
                              for v in rest) + " (identification-data medians)") if rest else ""
    what = f"along the {third} axis" if third else ""
    return r.save(fig, f"{c}_slices",
                  f"Fig. 12-20 style: 3-D slices through the {model.structure.label()} model "
                  f"{what} (5/50/95 % quantiles of the data){fixed}; blank where the model "
                  "has no simplex")


def _pick_maneuvers(valid, c: str, k: int = 2) -> list:
    """Validation maneuvers with the largest excitation of ``c``, different types first."""
    mans = valid["maneuver"].to_numpy()
    y = valid[c].to_numpy(dtype=float)
    ids, inv = np.unique(mans, return_inverse=True)
    cnt = np.bincount(inv)
    mean = np.bincount(inv, y) / cnt
    std = np.sqrt(np.maximum(np.bincount(inv, y * y) / cnt - mean ** 2, 0.0))
    if "maneuver_type" in valid.columns:
        first = np.unique(inv, return_index=True)[1]
        types = valid["maneuver_type"].astype(str).to_numpy()[first]
    else:
        types = np.zeros(len(ids)).astype(str)
    order = np.argsort(-std)
    chosen, seen = [], set()
    for i in order:
        if std[i] < 0.25 * std[order[0]]:
            break
        if types[i] not in seen:
            chosen.append(i)
            seen.add(types[i])
        if len(chosen) == k:
            break
    for i in order:
        if len(chosen) == k:
            break
        if i not in chosen:
            chosen.append(i)
    return [(ids[i], str(types[i])) for i in chosen]


def _fig_validation(r, c: str, valid, model, truth: bool) -> Figure:
    picks = _pick_maneuvers(valid, c)
    fig = r.new(4.2 * len(picks), 4.6, left=0.8, top=0.3, wspace=0.25, hspace=0.12)
    axes = np.atleast_2d(fig.subplots(2, len(picks), sharex="col",
                                      gridspec_kw={"height_ratios": [2.2, 1]}))
    if axes.shape[0] != 2:
        axes = axes.T
    mans = valid["maneuver"].to_numpy()
    for j, (m, mtype) in enumerate(picks):
        part = valid.loc[mans == m]
        t = _column(part, "t")
        t = np.arange(len(part), dtype=float) if t is None else t
        y = _column(part, c)
        yhat = _column(part, f"model_{c}")
        if yhat is None:
            yhat = model.predict(part)
        dec = _decimate(len(t))
        top, bottom = axes[0, j], axes[1, j]
        top.plot(t[dec], y[dec], color="#888", lw=0.8, label="measured")
        if truth:
            top.plot(t[dec], _column(part, f"true_{c}")[dec], "k--", lw=0.8, label="true")
        top.plot(t[dec], yhat[dec], color="#d62728", lw=1.0, label="model")
        top.set_title(f"maneuver {m} ({mtype})", fontsize=9)
        bottom.plot(t[dec], (y - yhat)[dec], color="#1f77b4", lw=0.7,
                    label="measured - model")
        if truth:
            bottom.plot(t[dec], (_column(part, f"true_{c}") - yhat)[dec], color="k", lw=0.8,
                        label="true - model")
        bottom.axhline(0.0, color="#555", lw=0.5)
        bottom.set_xlabel("t [s]")
        for ax in (top, bottom):
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
        if j == 0:
            top.set_ylabel(f"{_NAMES.get(c, c)} [-]")
            bottom.set_ylabel("error [-]")
            top.legend(fontsize=7, loc="best")
            bottom.legend(fontsize=7, loc="best")
    return r.save(fig, f"{c}_validation",
                  f"Fig. 13-21 style: measured {c} and the output of {model.structure.label()} "
                  f"on validation maneuvers (top) and the error (bottom)")


def _fig_diagnostics(r, c: str, res, thin_limit: float) -> Figure:
    from matplotlib.ticker import NullLocator

    v = res.validation
    fig = r.new(10.0, 3.1, left=0.7, wspace=0.25)
    ax1, ax2 = fig.subplots(1, 2, width_ratios=[1, 1.4])
    ac = np.asarray(v.get("autocorrelation") or [1.0], dtype=float)
    lags = np.arange(len(ac))
    ax1.vlines(lags, 0, ac, color="#1f77b4", lw=1.2)
    ax1.plot(lags, ac, "o", ms=2.5, color="#1f77b4")
    band = 1.96 / math.sqrt(max(int(v.get("n", 1)), 1))
    ax1.axhspan(-band, band, color="#d62728", alpha=0.15, label="95 % band (white noise)")
    ax1.axhline(0.0, color="#555", lw=0.5)
    ax1.set_xlabel("lag [samples]")
    ax1.set_ylabel("autocorrelation [-]")
    ax1.set_title(f"validation residual, whiteness {_fmt(v.get('whiteness'), '.2f')}",
                  fontsize=9)
    ax1.legend(fontsize=7)
    counts = np.asarray(res.counts, dtype=float)
    thin = np.zeros(len(counts), dtype=bool)
    thin[np.asarray(res.thin, dtype=int)] = True
    if len(counts) <= 400:
        idx = np.arange(len(counts))
        lw = max(0.5, min(6.0, 400.0 / max(len(counts), 1)))
        floor = max(0.5, 0.5 * float(counts[counts > 0].min())) if (counts > 0).any() else 0.5
        ax2.vlines(idx[~thin], floor, np.maximum(counts[~thin], floor), color="#7a8db3",
                   lw=lw, label="simplices")
        if thin.any():
            ax2.vlines(idx[thin], floor, np.maximum(counts[thin], floor), color="#d62728",
                       lw=lw, label="thin")
        ax2.set_xlim(-1, len(counts))
        ax2.set_xlabel("simplex")
        ax2.set_yscale("log")
        ax2.yaxis.set_minor_locator(NullLocator())
        ax2.set_ylabel("identification samples")
        ax2.axhline(thin_limit, color="#d62728", lw=0.8, ls="--",
                    label=f"thin limit {thin_limit:g}")
    else:
        pos = np.maximum(counts, 1.0)
        bins = np.logspace(0, math.log10(pos.max() * 1.1 + 1), 40)
        ax2.hist(pos, bins=bins, color="#7a8db3", label="simplices")
        if thin.any():
            ax2.hist(pos[thin], bins=bins, color="#d62728", label="thin")
        ax2.set_xscale("log")
        ax2.xaxis.set_minor_locator(NullLocator())
        ax2.set_xlabel("identification samples per simplex")
        ax2.set_ylabel("simplices")
        ax2.axvline(thin_limit, color="#d62728", lw=0.8, ls="--",
                    label=f"thin limit {thin_limit:g}")
    ax2.set_title(f"{len(counts)} simplices, {int(thin.sum())} thinly covered", fontsize=9)
    ax2.legend(fontsize=7)
    return r.save(fig, f"{c}_diagnostics",
                  f"{c}: residual autocorrelation on the validation data (left) and "
                  "identification samples per simplex, thin simplices in red (right)")


def projected_edges(points: np.ndarray, simplices: np.ndarray) -> np.ndarray:
    """Unique 2-D segments (M, 2, 2) of the simplex edges projected on ``points``."""
    pairs = np.concatenate([simplices[:, [i, j]]
                            for i, j in combinations(range(simplices.shape[1]), 2)])
    pairs = np.unique(np.sort(pairs, axis=1), axis=0)
    seg = np.stack([points[pairs[:, 0]], points[pairs[:, 1]]], axis=1)
    swap = (seg[:, 0, 0] > seg[:, 1, 0]) | ((seg[:, 0, 0] == seg[:, 1, 0])
                                           & (seg[:, 0, 1] > seg[:, 1, 1]))
    seg[swap] = seg[swap][:, ::-1]
    scale = np.ptp(points, axis=0)
    scale[scale == 0] = 1.0
    key = np.round(seg / scale * 1e6).reshape(len(seg), 4)
    _, keep = np.unique(key, axis=0, return_index=True)
    seg = seg[np.sort(keep)]
    return seg[np.any(seg[:, 0] != seg[:, 1], axis=1)]


def _fig_triangulation(r, c: str, model, ident, thin) -> Figure | None:
    from matplotlib.collections import LineCollection

    names = list(model.schedule)
    if len(names) < 2:
        return None
    tri = model.spline.triangulation
    phys = model.schedule_scaling.inverse(np.asarray(tri.vertices, dtype=float))
    simplices = np.asarray(tri.simplices, dtype=int)
    centroids = phys[simplices].mean(axis=1)
    views = [(0, 1)] + ([(0, 2)] if len(names) >= 3 else [])
    fig = r.new(5.0 * len(views), 4.0, left=0.7, wspace=0.3)
    axes = np.atleast_1d(fig.subplots(1, len(views)))
    s = _subsample(len(ident), _MAX_SCATTER)
    for ax, (i, j) in zip(axes, views):
        a, b = names[i], names[j]
        pts = np.column_stack([_disp(a, phys[:, i]), _disp(b, phys[:, j])])
        xa, xb = _column(ident, a), _column(ident, b)
        if xa is not None and xb is not None:
            ax.scatter(_disp(a, xa)[s], _disp(b, xb)[s], s=1.5, c="#7a8db3", alpha=0.3,
                       lw=0, rasterized=True)
        ax.add_collection(LineCollection(projected_edges(pts, simplices), colors="k",
                                         linewidths=0.6, label="simplex edges"))
        if len(thin):
            cen = centroids[np.asarray(thin, dtype=int)]
            ax.scatter(_disp(a, cen[:, i]), _disp(b, cen[:, j]), marker="x", s=30,
                       c="#d62728", lw=1.2, zorder=4, label="centroids of thin simplices")
        ax.autoscale_view()
        ax.set_xlabel(_label(a))
        ax.set_ylabel(_label(b))
        if len(thin):
            ax.legend(fontsize=7, loc="upper right")
    return r.save(fig, f"{c}_triangulation",
                  f"{c}: the triangulation ({tri.nsimplex} simplices) projected on two "
                  "variables over the identification data" +
                  ("; red crosses: centroids of the thinly covered simplices" if len(thin) else ""))
