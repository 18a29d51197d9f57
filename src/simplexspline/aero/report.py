"""The identification report: a self-contained HTML page and a Markdown summary.

:func:`write_report` renders an :class:`~simplexspline.aero.identify.Identification` with
the paper's kinds of figures (de Visser et al., AIAA 2010-7950):

* the validation table (Table 2 style) next to the paper's numbers, with the error against
  the true coefficients when the data are simulated;
* the identification data's 2-D and 3-D projections with their convex hull (Fig. 7) and
  one example maneuver of each type (Fig. 8-11);
* per coefficient: the model structure, the structure-selection history, 3-D slices
  through the model along a third variable (Fig. 12, 14, 16, 18, 20), validation time
  series of measured vs model output and the error (Fig. 13, 15, 17, 19, 21), the
  residual autocorrelation, the triangulation projected on two variables over the data
  and the identification samples per simplex with the thinly covered ones highlighted;
* stability and control derivatives (:mod:`~simplexspline.aero.derivatives`): a table at
  the identification data's median condition, each model's partial derivatives along alpha
  at three Mach numbers, and alpha x Mach maps.

Figures are PNG files made with matplotlib's object API (no pyplot, so the caller's
backend is left alone). ``report.html`` embeds them as base64 data URIs and needs no
other file; ``report.md`` links the copies in ``figures/``.
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from itertools import combinations
from pathlib import Path

import numpy as np

__all__ = ["write_report"]

#: Dots per inch of the PNG figures.
DPI = 90

#: Most points drawn in a scatter / along a time series line.
_MAX_SCATTER = 4000
_MAX_LINE = 2000

#: Pairs of variables shown in the data projections (Fig. 7 style), when in the data.
_PROJECTIONS = (("alpha", "de"), ("alpha", "mach"), ("alpha", "beta"), ("alpha", "qhat"),
                ("beta", "dr"), ("beta", "da"), ("phat", "da"), ("rhat", "dr"))

#: Plot names of the flight-data columns (plain text, no mathtext: faster).
_NAMES = {
    "alpha": "\u03b1", "beta": "\u03b2", "de": "\u03b4e", "da": "\u03b4a", "dr": "\u03b4r",
    "mach": "M", "tas": "V", "h": "h", "p": "p", "q": "q", "r": "r",
    "phat": "pb/2V", "qhat": "qc/2V", "rhat": "rb/2V", "phi": "\u03c6", "theta": "\u03b8",
}

#: Display conversion of angular units (radians are shown in degrees).
_DISPLAY = {"rad": ("deg", 180.0 / math.pi), "rad/s": ("deg/s", 180.0 / math.pi),
            "rad/s^2": ("deg/s^2", 180.0 / math.pi)}

_CSS = """
body{font-family:-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:1.5em auto;
max-width:1200px;padding:0 1em;color:#222;line-height:1.4}
h1{border-bottom:2px solid #345;padding-bottom:.2em}h2{border-bottom:1px solid #aab;
margin-top:2em}table{border-collapse:collapse;margin:.6em 0;font-size:.9em}
th,td{border:1px solid #ccd;padding:.25em .5em;text-align:right}
th{background:#eef0f5}td.l,th.l{text-align:left}tr.acc td{background:#e7f5e7;
font-weight:600}tr.fail td{color:#999}.warn{background:#fff4e0;border-left:4px solid #e90;
padding:.4em .8em;margin:.4em 0}.good{color:#171}.bad{color:#b11}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:.9em;color:#444}pre{background:#f6f6f8;padding:.6em;overflow-x:auto;
font-size:.85em}details{margin:.4em 0}nav a{margin-right:.8em}code{background:#f3f3f6}
"""


# ---------------------------------------------------------------------------- helpers
def _esc(value) -> str:
    return html.escape(str(value), quote=True)


def _md(value) -> str:
    """Text for a Markdown table cell (no HTML, no pipes, one line)."""
    return _md_text(value).replace("|", "\\|").replace("\n", " ")


def _md_text(value) -> str:
    """Text for a Markdown paragraph (no raw HTML: ``&`` and ``<`` escaped)."""
    return str(value).replace("&", "&amp;").replace("<", "&lt;")


def _unit(var: str) -> tuple[str, float]:
    """(display unit, factor from SI) of a flight-data column."""
    from simplexspline.aero.structure import UNITS

    unit = UNITS.get(var, "")
    if unit in _DISPLAY:
        return _DISPLAY[unit]
    if var in ("phat", "qhat", "rhat") or unit.startswith("-"):
        return "-", 1.0
    return unit, 1.0


def _label(var: str) -> str:
    unit, _ = _unit(var)
    name = _NAMES.get(var, var)
    return f"{name} [{unit}]" if unit else name


def _disp(var: str, values) -> np.ndarray:
    return np.asarray(values, dtype=float) * _unit(var)[1]


def _fmt(x, spec: str = ".4g") -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return "" if x is None else str(x)
    if not math.isfinite(v):
        return "n/a" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return format(v, spec)


def _pct(x, digits: int = 2) -> str:
    s = _fmt(None if x is None else 100.0 * float(x), f".{digits}f")
    return s + " %" if s not in ("", "n/a", "inf", "-inf") else s


def _subsample(n: int, k: int, seed: int = 0) -> np.ndarray:
    if n <= k:
        return np.arange(n)
    return np.sort(np.random.default_rng(seed).choice(n, size=k, replace=False))


def _decimate(n: int, k: int = _MAX_LINE) -> slice:
    return slice(None, None, max(1, math.ceil(n / k)))


def _column(df, name: str) -> np.ndarray | None:
    if df is None or name not in df.columns:
        return None
    return df[name].to_numpy(dtype=float)


def _plain(df):
    """A shallow copy of ``df`` without ``attrs``: pandas deep-copies ``attrs`` (which can
    hold megabytes of flight-data metadata) on every column access."""
    out = df.copy(deep=False)
    out.attrs = {}
    return out


def _write_text(path: Path, text: str) -> None:
    """Write a text file whole (temporary file + rename)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def _varies(df, name: str) -> bool:
    v = _column(df, name)
    return v is not None and len(v) > 1 and bool(np.all(np.isfinite(v))) and np.ptp(v) > 0


def _short_json(value, limit: int = 4000) -> str:
    try:
        text = json.dumps(value, indent=1, default=str, allow_nan=True)
    except (TypeError, ValueError):
        text = repr(value)
    if len(text) > limit:
        text = text[:limit] + f"\n... ({len(text) - limit:,} more characters)"
    return text


@dataclass
class _Figure:
    name: str
    caption: str
    png: bytes

    @property
    def path(self) -> str:
        return f"figures/{self.name}.png"

    def html(self) -> str:
        data = base64.b64encode(self.png).decode("ascii")
        return (f'<figure><img alt="{_esc(self.caption)}" src="data:image/png;base64,{data}">'
                f"<figcaption>{_esc(self.caption)}</figcaption></figure>")

    def md(self) -> str:
        return f"![{_md(self.caption)}]({self.path})"


class _Renderer:
    """Makes matplotlib figures (object API, no pyplot) and renders them to PNG bytes."""

    @staticmethod
    def new(width: float, height: float, *, left: float = 0.75, right: float = 0.2,
            bottom: float = 0.6, top: float = 0.3, wspace: float = 0.3,
            hspace: float = 0.35):
        """A figure with fixed margins in inches (no layout engine: twice as fast)."""
        from matplotlib.figure import Figure, SubplotParams

        pars = SubplotParams(left=left / width, right=1.0 - right / width,
                             bottom=bottom / height, top=1.0 - top / height,
                             wspace=wspace, hspace=hspace)
        return Figure(figsize=(width, height), dpi=DPI, subplotpars=pars)

    @staticmethod
    def save(fig, name: str, caption: str) -> _Figure:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=DPI, pil_kwargs={"compress_level": 2})
        return _Figure(name, caption, buf.getvalue())


@dataclass
class _Slot:
    """Place of a figure in the page, filled once the figures are rendered."""

    index: int


#: Figure jobs of the report being written; set before forking the rendering workers,
#: which inherit it (the jobs hold closures over the data, nothing is pickled).
_JOBS: list = []


def _run_job(index: int):
    return _JOBS[index][1]()


def _render(jobs: list, workers: int, say: Callable[[str], None]) -> list:
    """Run the figure jobs ``(label, callable)``; forked worker processes when
    ``workers > 1`` and the platform has ``fork``, else (or on pool failure) serially."""
    global _JOBS
    out: list = [None] * len(jobs)
    done = [False] * len(jobs)
    if workers > 1 and len(jobs) > 2:
        import multiprocessing
        import warnings
        from concurrent.futures import ProcessPoolExecutor, as_completed
        from concurrent.futures.process import BrokenProcessPool

        try:
            ctx = multiprocessing.get_context("fork")
        except ValueError:
            ctx = None
        if ctx is not None:
            _JOBS = jobs
            try:
                with warnings.catch_warnings():
                    # Python >= 3.12 warns about fork() in a multi-threaded process; the
                    # workers only run numpy and matplotlib
                    warnings.simplefilter("ignore", DeprecationWarning)
                    with ProcessPoolExecutor(min(workers, len(jobs)), mp_context=ctx) as pool:
                        futures = {pool.submit(_run_job, i): i for i in range(len(jobs))}
                        for fut in as_completed(futures):
                            i = futures[fut]
                            out[i], done[i] = fut.result(), True
                            say(f"report: figure {sum(done)}/{len(jobs)} ({jobs[i][0]})")
            except (BrokenProcessPool, OSError):
                pass  # render what is missing serially
            finally:
                _JOBS = []
    for i, (label, job) in enumerate(jobs):
        if not done[i]:
            out[i], done[i] = job(), True
            say(f"report: figure {sum(done)}/{len(jobs)} ({label})")
    return out


# ---------------------------------------------------------------------------- figures
def _fig_projections(r, ident, valid) -> _Figure | None:
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


def _fig_projection_3d(r, ident) -> _Figure | None:
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


def _maneuver_types(df) -> dict:
    """Maneuver type -> list of maneuver ids (in order of appearance)."""
    mans = df["maneuver"].to_numpy()
    ids, first = np.unique(mans, return_index=True)
    if "maneuver_type" in df.columns:
        types = df["maneuver_type"].astype(str).to_numpy()[first]
    else:
        types = np.array(["maneuver"] * len(ids))
    out: dict = {}
    for i in np.argsort(first):
        out.setdefault(str(types[i]), []).append(ids[i])
    return out


def _fig_time_history(r, df, maneuver, mtype: str, index: int) -> _Figure:
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


def _fig_selection(r, c: str, history: list) -> _Figure | None:
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


def _fig_slices(r, c: str, model, ident) -> _Figure:
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


def _fig_validation(r, c: str, valid, model, truth: bool) -> _Figure:
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


def _fig_diagnostics(r, c: str, res, thin_limit: float) -> _Figure:
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


def _projected_edges(points: np.ndarray, simplices: np.ndarray) -> np.ndarray:
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


def _fig_triangulation(r, c: str, model, ident, thin) -> _Figure | None:
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
        ax.add_collection(LineCollection(_projected_edges(pts, simplices), colors="k",
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


# ---------------------------------------------------------------------------- derivatives
def _sweep_axes(model, ident) -> dict:
    """Alpha (or the first variable) across the model's box; Mach lines at the 5/50/95 %
    quantiles of the identification data when the model has Mach."""
    x = "alpha" if "alpha" in model.variables else model.variables[0]
    i = model.variables.index(x)
    axes = {x: np.linspace(model.scaling.lower[i], model.scaling.upper[i], 41)}
    if "mach" in model.variables and x != "mach":
        axes["mach"] = np.round(_slice_values(model, ident, "mach"), 3)
    return axes


def _fig_derivatives(r, c: str, model, ident, ref: dict) -> _Figure | None:
    from simplexspline.aero.derivatives import derivatives, plot_derivatives

    axes = _sweep_axes(model, ident)
    x = next(iter(axes))
    table = derivatives(model, axes, reference=ref, wrt=list(model.variables))
    fig = plot_derivatives(table, x=x, by="mach" if "mach" in axes else None,
                           ncols=min(3, len(model.variables)))
    fixed = [v for v in model.variables if v not in axes]
    where = (", ".join(f"{v} = {ref[v] * _unit(v)[1]:.3g} {_unit(v)[0]}" for v in fixed)
             + " (identification-data medians)") if fixed else ""
    return r.save(fig, f"{c}_derivatives",
                  f"{c}: partial derivatives of {model.structure.label()} along {x}"
                  + (" at Mach = " + ", ".join(f"{m:.3g}" for m in axes["mach"])
                     + " (5/50/95 % data quantiles)" if "mach" in axes else "")
                  + (f"; {where}" if where else "") + ". Per rad (per non-dimensional rate "
                  "for p, q, r hat); bars at the bottom: outside the model's domain for "
                  "that line, grey: for all")


def _fig_derivative_maps(r, models: dict, ref: dict) -> _Figure | None:
    from simplexspline.aero.derivatives import derivatives, plot_derivative_map

    both = {c: m for c, m in models.items() if {"alpha", "mach"} <= set(m.variables)}
    if not both:
        return None
    lo = {v: min(m.scaling.lower[m.variables.index(v)] for m in both.values())
          for v in ("alpha", "mach")}
    hi = {v: max(m.scaling.upper[m.variables.index(v)] for m in both.values())
          for v in ("alpha", "mach")}
    table = derivatives(both, {"alpha": np.linspace(lo["alpha"], hi["alpha"], 31),
                               "mach": np.linspace(lo["mach"], hi["mach"], 21)},
                        reference=ref, wrt=["alpha", "beta", "de", "da", "dr"])
    names = [k for k, d in table.attrs["derivatives"].items() if d["in_model"]][:9]
    if not names:
        return None
    fig = plot_derivative_map(table, names, ncols=3)
    return r.save(fig, "derivative_maps",
                  "Derivatives with respect to the angles and surfaces over alpha x Mach "
                  "(models with both), other variables at the identification-data medians; "
                  "grey: outside the model's domain")


def _derivative_section(models: dict, ident, H: list, M: list, slot) -> None:
    """The 'Stability and control derivatives' section: a table at the reference
    condition and figures across the envelope."""
    from simplexspline.aero.derivatives import derivatives, reference_conditions

    ref = reference_conditions(models, ident)
    at_ref = derivatives(models, None, reference=ref)
    rows = []
    for name, d in at_ref.attrs["derivatives"].items():
        if not d["in_model"]:
            continue
        value = float(at_ref[name].iloc[0])
        rows.append([d["coefficient"], name, _fmt(value, ".4g"), d["unit"],
                     "" if bool(at_ref[f"inside_{d['coefficient']}"].iloc[0])
                     else "outside the domain"])
    cond = ", ".join(f"{v} = {_fmt(ref[v] * _unit(v)[1], '.3g')} {_unit(v)[0]}"
                     for v in ref)
    text = ("Exact partial derivatives of the identified models (spline gradients through "
            "the variable scaling), holding each model's other variables fixed: per rad for "
            "angles and surfaces, per unit Mach, and per non-dimensional rate for phat = "
            "pb/2V, qhat = qc/2V, rhat = rb/2V (the classical Cl_p, Cm_q, Cn_r). Variables "
            "a model does not have are left out (their derivatives are 0). Reference "
            f"condition (identification-data medians): {cond}. docs/derivatives.md; "
            "'simplexspline derivatives OUTDIR' writes them as a table.")
    head = ["coefficient", "derivative", "at the reference", "unit", "note"]
    H.append('<h2 id="derivatives">Stability and control derivatives</h2>')
    H.append(f"<p>{_esc(text)}</p>")
    H.append(_html_table(head, rows, left=(0, 1, 3, 4)))
    M += ["## Stability and control derivatives", "", _md_text(text), "",
          _md_table(head, rows), ""]
    figs = [slot(f"{c} derivatives", _fig_derivatives, c, m, ident, ref)
            for c, m in models.items()]
    figs.append(slot("derivative maps", _fig_derivative_maps, models, ref))
    H += figs
    M += figs


# ---------------------------------------------------------------------------- tables
def _rows_table2(ident_obj) -> tuple[list, list]:
    from simplexspline.aero.identify import PAPER_TABLE2

    truth = bool(ident_obj.has_truth)
    head = ["coefficient", "model", "simplices", "B-coefficients", "RMS", "rel. RMS",
            "R²", "paper rel. RMS", "ident. rel. RMS", "whiteness", "thin simplices"]
    if truth:
        head += ["RMS vs truth", "rel. RMS vs truth", "noise RMS", "RMS true / noise"]
    rows = []
    for c, res in ident_obj.results.items():
        v = res.validation
        paper = PAPER_TABLE2.get(c)
        rrms = v.get("rrms")
        vs_paper = "" if paper is None or rrms is None else (
            "good" if float(rrms) <= paper else "bad")
        row = [c, res.structure.label(), str(res.model.spline.triangulation.nsimplex),
               str(int(np.asarray(res.model.spline.coefficients).size)),
               _fmt(v.get("rms"), ".3e"), (_pct(rrms), vs_paper), _fmt(v.get("r2"), ".4f"),
               "" if paper is None else _pct(paper), _pct(res.identification.get("rrms")),
               _fmt(v.get("whiteness"), ".2f"), str(len(res.thin))]
        if truth:
            row += [_fmt(v.get("rms_true"), ".3e"), _pct(v.get("rrms_true"), 3),
                    _fmt(v.get("noise_rms"), ".3e")]
            ratio = v.get("rms_true_over_noise")
            ok = ratio is not None and math.isfinite(float(ratio))
            row.append((_fmt(ratio, ".3f"), ("good" if float(ratio) < 1 else "bad") if ok
                        else ""))
        rows.append(row)
    return head, rows


def _cell(x) -> tuple[str, str]:
    """(text, css class) of a table cell given as text or (text, class)."""
    return (str(x[0]), x[1]) if isinstance(x, tuple) else (str(x), "")


def _html_table(head: list, rows: list, *, left: tuple = (), classes: list | None = None) -> str:
    def cls(*names) -> str:
        names = " ".join(n for n in names if n)
        return f' class="{names}"' if names else ""

    out = ["<table><thead><tr>"]
    out += [f"<th{cls('l' if i in left else '')}>{_esc(h)}</th>" for i, h in enumerate(head)]
    out.append("</tr></thead><tbody>")
    for k, row in enumerate(rows):
        out.append(f"<tr{cls(classes[k] if classes else '')}>")
        for i, x in enumerate(row):
            text, c = _cell(x)
            out.append(f"<td{cls('l' if i in left else '', c)}>{_esc(text)}</td>")
        out.append("</tr>")
    out.append("</tbody></table>")
    return "".join(out)


def _md_table(head: list, rows: list) -> str:
    lines = ["| " + " | ".join(_md(h) for h in head) + " |",
             "|" + "|".join("---" for _ in head) + "|"]
    lines += ["| " + " | ".join(_md(_cell(x)[0]) for x in row) + " |" for row in rows]
    return "\n".join(lines)


def _history_rows(history: list) -> tuple[list, list, list]:
    head = ["#", "round", "move", "structure", "simplices", "B-coefficients", "CV RMS",
            "seconds", "accepted", "note"]
    rows, classes = [], []
    for i, t in enumerate(history, 1):
        rows.append([str(i), str(t.round), t.move, t.structure.label(),
                     str(t.nsimplex or ""), str(t.ncoefficients or ""), _fmt(t.score, ".5g"),
                     _fmt(t.seconds, ".2f"), "yes" if t.accepted else "", t.error])
        classes.append("acc" if t.accepted else ("fail" if t.error else ""))
    return head, rows, classes


def _structure_rows(res, ident) -> tuple[list, list]:
    model = res.model
    head = ["variable", "unit", "lower", "upper", "grid cells", "median (ident.)"]
    rows = []
    cells = model.scaling.cells
    for i, v in enumerate(model.variables):
        unit, f = _unit(v)
        col = _column(ident, v)
        if i >= len(model.schedule):
            grid = "multiplier"
        elif cells[i] is not None:
            grid = f"{cells[i]} (breakpoints)"
        else:
            grid = str(model.structure.resolution[i])
        rows.append([v, unit, _fmt(model.scaling.lower[i] * f), _fmt(model.scaling.upper[i] * f),
                     grid, "" if col is None else _fmt(float(np.median(col)) * f)])
    if model.varying:
        rows.append(["multipliers", "", "", "", ", ".join(model.structure.multipliers), ""])
    return head, rows


def _metadata_items(meta: dict) -> tuple[list, list]:
    """(short items as rows, long items as (key, json text))."""
    short, long = [], []
    for k, v in meta.items():
        if isinstance(v, (str, int, float, bool)) or v is None:
            text = str(v)
            if len(text) <= 300:
                short.append([str(k), text])
                continue
        long.append((str(k), v))
    return short, long


def _describe(value) -> str:
    if isinstance(value, dict):
        return f"{len(value)} entries"
    if isinstance(value, (list, tuple)):
        return f"{len(value)} items"
    return f"{len(str(value)):,} characters"


def _reconstruction_lines(ident_obj) -> list:
    lines = []
    note = (ident_obj.provenance or {}).get("reconstruction")
    if isinstance(note, dict):
        if note.get("reconstructed"):
            rej = note.get("rejected") or {}
            lines.append("Flight path reconstruction was run on the raw sensor data "
                         f"(thrust subtracted: {note.get('thrust_subtracted')}, angular "
                         f"accelerations: {note.get('accelerations')}, rejected maneuvers: "
                         f"{len(rej)}).")
            for m, why in list(rej.items())[:20]:
                lines.append(f"rejected maneuver {m}: {why}")
            if note.get("summary"):
                lines.append(str(note["summary"]))
        else:
            lines.append("No reconstruction in this run: the data already held the "
                         "coefficients CX..Cn and phat, qhat, rhat.")
    elif note:
        lines.append(str(note))
    meta_rec = (ident_obj.metadata or {}).get("reconstruction")
    if isinstance(meta_rec, dict):
        mans = meta_rec.get("maneuvers")
        lines.append("The input file was reconstructed earlier: "
                     f"{meta_rec.get('method', 'method not recorded')}; thrust subtracted: "
                     f"{meta_rec.get('thrust_subtracted')}; angular accelerations: "
                     f"{meta_rec.get('accelerations')}; "
                     f"{len(mans) if hasattr(mans, '__len__') else '?'} maneuvers, "
                     f"{len(meta_rec.get('rejected') or {})} rejected.")
    return lines


# ---------------------------------------------------------------------------- main
def write_report(identification, outdir, *, progress: Callable[[str], None] | None = None,
                 workers: int | None = None) -> Path:
    """Write the identification report: ``report.html``, ``report.md`` and ``figures/``.

    Parameters
    ----------
    identification : Identification
        The result of :func:`~simplexspline.aero.identify.identify`.
    outdir : str or Path
        Output directory (created when missing).
    progress : callable, optional
        Receives a short text line per step.
    workers : int, optional
        Processes rendering the figures (forked workers where the platform has ``fork``;
        default ``min(2, CPUs)``; 1 renders everything in this process).

    Returns
    -------
    Path
        The path of ``report.html``.

    Notes
    -----
    ``report.html`` is self-contained: its figures are PNG images embedded as base64 data
    URIs and its style sheet is inline. ``report.md`` links the same figures in
    ``outdir/figures``. Scatter plots and long time series are subsampled so that a report
    for six coefficients takes a few seconds.
    """
    t0 = time.perf_counter()
    say = progress or (lambda _msg: None)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    r = _Renderer
    if workers is None:
        workers = min(2, os.cpu_count() or 1)
    jobs: list = []

    def slot(label: str, fn: Callable, *args) -> _Slot:
        jobs.append((label, partial(fn, r, *args)))
        return _Slot(len(jobs) - 1)

    res_all = identification.results
    ident = _plain(identification.identification)
    valid = _plain(identification.validation)
    meta = dict(identification.metadata or {})
    prov = dict(identification.provenance or {})
    settings = identification.settings
    truth = bool(identification.has_truth)
    aircraft = meta.get("aircraft") or "unknown aircraft"
    title = f"Aerodynamic model identification: {aircraft}"
    thin_factor = float(getattr(settings, "thin_factor", 2.0))

    H: list = []   # html body parts
    M: list = []   # markdown lines

    # ---------------------------------------------------------------- header
    n_id, n_va = int(ident["maneuver"].nunique()), int(valid["maneuver"].nunique())
    types = _maneuver_types(ident)
    vtypes = _maneuver_types(valid)
    data_rows = [["identification", f"{n_id}", f"{len(ident):,}"],
                 ["validation", f"{n_va}", f"{len(valid):,}"]]
    type_rows = [[t, str(len(types.get(t, []))), str(len(vtypes.get(t, [])))]
                 for t in sorted(set(types) | set(vtypes))]
    prov_rows = [[k, str(v)] for k, v in prov.items()
                 if k != "reconstruction" and not isinstance(v, (dict, list))]
    short_meta, long_meta = _metadata_items(meta)
    rec_lines = _reconstruction_lines(identification)
    H.append(f"<h1>{_esc(title)}</h1>")
    nav = ['<a href="#table">validation table</a>', '<a href="#data">data</a>']
    nav += [f'<a href="#coef-{_esc(c)}">{_esc(c)}</a>' for c in res_all]
    nav.append('<a href="#derivatives">derivatives</a>')
    H.append("<nav>" + " ".join(nav) + "</nav>")
    H.append("<h2 id=\"header\">Run</h2>")
    H.append("<h3>Data</h3>" + _html_table(["set", "maneuvers", "samples"], data_rows,
                                           left=(0,)))
    if type_rows:
        H.append(_html_table(["maneuver type", "identification", "validation"], type_rows,
                             left=(0,)))
    H.append("<h3>Provenance</h3>" + _html_table(["key", "value"], prov_rows, left=(0, 1)))
    if rec_lines:
        H.append("<h3>Reconstruction</h3><pre>" + _esc("\n".join(rec_lines)) + "</pre>")
    H.append("<h3>Metadata</h3>" + _html_table(["key", "value"], short_meta, left=(0, 1)))
    for k, v in long_meta:
        H.append(f"<details><summary>{_esc(k)} ({_esc(_describe(v))})</summary><pre>"
                 f"{_esc(_short_json(v))}</pre></details>")
    settings_dict = settings.to_dict() if hasattr(settings, "to_dict") else {}
    H.append("<h3>Settings</h3><details><summary>identification settings</summary><pre>"
             f"{_esc(_short_json(settings_dict, 20000))}</pre></details>")
    if identification.warnings:
        H.append("<h3>Warnings</h3>" + "".join(f'<div class="warn">{_esc(w)}</div>'
                                                 for w in identification.warnings))

    M += [f"# {_md_text(title)}", "",
          (f"Aircraft: **{_md_text(aircraft)}**. Identification: {n_id} maneuvers "
          f"({len(ident):,} samples); validation: {n_va} maneuvers ({len(valid):,} samples)."),
          ""]
    M += [f"- {_md_text(k)}: {_md_text(v)}" for k, v in prov_rows]
    if rec_lines:
        M += ["", "Reconstruction:", "", "```", *rec_lines, "```"]
    M += ["", "Settings:", ""]
    M += [f"- {_md_text(k)}: `{json.dumps(v, default=str)[:2000]}`"
          for k, v in settings_dict.items()] + [""]
    if identification.warnings:
        M += ["Warnings:", ""] + [f"- {_md_text(w)}" for w in identification.warnings] + [""]

    # ---------------------------------------------------------------- table 2
    head, rows = _rows_table2(identification)
    H.append('<h2 id="table">Validation (Table 2 style)</h2>')
    H.append("<p>Scores of each model on the held-out validation maneuvers. Relative RMS is "
             "RMS / (max - min) of the measured coefficient (the paper's Eq. 55 with the "
             "square root); <em>paper</em> is the Cessna Citation II result of the paper's "
             "Table 2." + (" The truth columns compare the model with the true "
                           "(simulated) coefficients; <em>noise RMS</em> is the RMS of "
                           "measured - true." if truth else "")
             + " Green: better than the paper / below the measurement noise; red: not.</p>")
    H.append(_html_table(head, rows, left=(0, 1)))
    H.append("<details><summary>plain text</summary><pre>" + _esc(identification.table())
             + "</pre></details>")
    M += ["## Validation (Table 2 style)", "", _md_table(head, rows), ""]

    # ---------------------------------------------------------------- data
    H.append('<h2 id="data">Flight data</h2>')
    M += ["## Flight data", ""]
    figs = [slot("data projections", _fig_projections, ident, valid),
            slot("3-D data projection", _fig_projection_3d, ident)]
    for i, (mtype, ids) in enumerate(types.items()):
        figs.append(slot(f"{mtype} time history", _fig_time_history, ident,
                         ids[len(ids) // 2], mtype, i))
    H += figs
    M += figs

    # ---------------------------------------------------------------- coefficients
    for c, res in res_all.items():
        model = res.model
        s = model.structure
        v = res.validation
        H.append(f'<h2 id="coef-{_esc(c)}">{_esc(c)}: {_esc(s.label())}</h2>')
        M += [f"## {_md_text(c)}: {_md_text(s.label())}", ""]
        summary = (f"degree {s.degree}, continuity C^{s.continuity}, "
                   f"{model.spline.triangulation.nsimplex} simplices, "
                   f"{int(np.asarray(model.spline.coefficients).size)} B-coefficients, "
                   f"{s.ncoef_per_simplex} per simplex; fitted in {_fmt(res.seconds, '.1f')} s. "
                   f"Validation: RMS {_fmt(v.get('rms'), '.3e')}, relative RMS "
                   f"{_pct(v.get('rrms'))}, R² {_fmt(v.get('r2'), '.4f')}, bias "
                   f"{_fmt(v.get('bias'), '.2e')}, max |error| {_fmt(v.get('max_abs'), '.2e')}"
                   + (f"; against the truth: RMS {_fmt(v.get('rms_true'), '.3e')} (measurement"
                      f" noise RMS {_fmt(v.get('noise_rms'), '.3e')})" if "rms_true" in v
                      else "") + ".")
        H.append(f"<p>{_esc(summary)}</p>")
        M += [_md_text(summary), ""]
        shead, srows = _structure_rows(res, ident)
        H.append(_html_table(shead, srows, left=(0, 1)))
        M += [_md_table(shead, srows), ""]
        mine = [w for w in identification.warnings if w.startswith(f"{c}:")]
        if len(res.thin) and not mine:
            mine = [f"{c}: {len(res.thin)} thinly covered simplices"]
        H += [f'<div class="warn">{_esc(w)}</div>' for w in mine]
        M += [f"> **Warning:** {_md_text(w)}" for w in mine] + ([""] if mine else [])

        hhead, hrows, hclasses = _history_rows(res.history)
        H.append("<h3>Structure selection</h3>")
        M += ["### Structure selection", ""]
        if len(res.history) <= 1 and not any(np.isfinite(float(t.score))
                                             for t in res.history):
            note = "Structure fixed (automatic selection off)."
            H.append(f"<p>{_esc(note)}</p>")
            M += [note, ""]
        H.append(_html_table(hhead, hrows, left=(2, 3, 9), classes=hclasses))
        M += [_md_table(hhead, hrows), ""]
        sel = slot(f"{c} selection history", _fig_selection, c, res.history)
        H.append(sel)
        M.append(sel)
        H.append("<h3>Model and validation</h3>")
        M += ["### Model and validation", ""]
        figs = [slot(f"{c} slices", _fig_slices, c, model, ident),
                slot(f"{c} validation", _fig_validation, c, valid, model,
                     truth and f"true_{c}" in valid.columns),
                slot(f"{c} diagnostics", _fig_diagnostics, c, res, thin_factor * s.ncoef_per_simplex),
                slot(f"{c} triangulation", _fig_triangulation, c, model, ident, res.thin)]
        H += figs
        M += figs

    # ---------------------------------------------------------------- derivatives
    _derivative_section({c: res.model for c, res in res_all.items()}, ident, H, M, slot)

    # ---------------------------------------------------------------- render
    rendered = _render(jobs, workers, say)
    (outdir / "figures").mkdir(exist_ok=True)
    for f in rendered:
        if f is not None:
            (outdir / "figures" / f"{f.name}.png").write_bytes(f.png)
    count = sum(f is not None for f in rendered)

    def fill(part, kind: str):
        if not isinstance(part, _Slot):
            return part
        f = rendered[part.index]
        if f is None:
            return ""
        return f.html() if kind == "html" else f.md() + "\n"

    H = [fill(x, "html") for x in H]
    M = [fill(x, "md") for x in M]

    seconds = time.perf_counter() - t0
    foot = (f"Written by {prov.get('software', 'simplexspline')} in {seconds:.1f} s, "
            f"{count} figures.")
    H.append(f"<hr><p><small>{_esc(foot)}</small></p>")
    M += ["---", foot, ""]
    page = ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{_esc(title)}</title><style>{_CSS}</style></head><body>\n"
            + "\n".join(H) + "\n</body></html>\n")
    path = outdir / "report.html"
    _write_text(path, page)
    _write_text(outdir / "report.md", "\n".join(M))
    say(f"report: {count} figures in {seconds:.1f} s")
    return path
