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
* stability and control derivatives (:mod:`~simplexspline.aero.derivatives.stability`): a table at
  the identification data's median condition, each model's partial derivatives along alpha
  at three Mach numbers, and alpha x Mach maps.

Figures are PNG files made with matplotlib's object API (no pyplot, so the caller's
backend is left alone). ``report.html`` embeds them as base64 data URIs and needs no
other file; ``report.md`` links the copies in ``figures/``.

The pieces live next to this module: the figures in :mod:`~simplexspline.aero.report.figures`
and :mod:`~simplexspline.aero.report.derivative_section` (with the derivatives section), their
rendering to PNG in :mod:`~simplexspline.aero.report.render`, and the shared units, labels,
number formatting and tables in :mod:`~simplexspline.aero.report.markup`. This module
assembles the HTML and Markdown documents.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np

from simplexspline.aero.report.derivative_section import _derivative_section
from simplexspline.aero.report.figures import (
    _fig_diagnostics,
    _fig_projection_3d,
    _fig_projections,
    _fig_selection,
    _fig_slices,
    _fig_time_history,
    _fig_triangulation,
    _fig_validation,
)
from simplexspline.aero.report.markup import (
    _md_code,
    _column,
    _esc,
    _fmt,
    _html_table,
    _md_table,
    _md_text,
    _pct,
    _unit,
)
from simplexspline.aero.report.render import _render, _Renderer
from simplexspline.aero.selection.validation import PAPER_TABLE2

__all__ = ["write_report"]

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


def _short_json(value, limit: int = 4000) -> str:
    try:
        text = json.dumps(value, indent=1, default=str, allow_nan=True)
    except (TypeError, ValueError):
        text = repr(value)
    if len(text) > limit:
        text = text[:limit] + f"\n... ({len(text) - limit:,} more characters)"
    return text


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


@dataclass
class _Slot:
    """Place of a figure in the page, filled once the figures are rendered."""

    index: int


# ---------------------------------------------------------------------------- tables
def _rows_table2(ident_obj) -> tuple[list, list]:
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
    M += [f"- {_md_text(k)}: {_md_code(json.dumps(v, default=str)[:2000])}"
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
