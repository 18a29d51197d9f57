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
rendering to PNG in :mod:`~simplexspline.aero.report.render`, the shared units, labels,
number formatting and escaping in :mod:`~simplexspline.aero.report.markup`, and the document
model with its HTML and Markdown renderers in :mod:`~simplexspline.aero.report.document`.
This module builds the document one section at a time (run, validation table, flight
data, one section per coefficient, derivatives) and writes both files from it.
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

from simplexspline.aero.data.flight_data import without_metadata
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
from simplexspline.aero.report.document import (
    Alert,
    BulletList,
    Code,
    CodeSpan,
    Emph,
    Footer,
    Heading,
    Nav,
    Paragraph,
    Strong,
    Table,
    to_html,
    to_markdown,
)
from simplexspline.aero.report.markup import _column, _fmt, _pct, _unit
from simplexspline.aero.report.render import _render, _Renderer
from simplexspline.aero.selection.validation import PAPER_TABLE2
from simplexspline._files import write_text

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


@dataclass(frozen=True)
class _Pending:
    """Place of a figure in the document, filled once the figures are rendered."""

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


# ---------------------------------------------------------------------------- sections
#: A figure of a section, queued for rendering: ``slot(label, figure function, *args)``
#: returns the placeholder block that the rendered :class:`Figure` replaces.
Slot = Callable[..., "_Pending"]


def _header_section(identification, ident, valid, types: dict) -> list:
    """Title, navigation and the run: data, provenance, reconstruction, metadata,
    settings and warnings."""
    meta = dict(identification.metadata or {})
    prov = dict(identification.provenance or {})
    settings = identification.settings
    aircraft = meta.get("aircraft") or "unknown aircraft"
    n_id, n_va = int(ident["maneuver"].nunique()), int(valid["maneuver"].nunique())
    vtypes = _maneuver_types(valid)
    data_rows = [["identification", f"{n_id}", f"{len(ident):,}"],
                 ["validation", f"{n_va}", f"{len(valid):,}"]]
    type_rows = [[t, str(len(types.get(t, []))), str(len(vtypes.get(t, [])))]
                 for t in sorted(set(types) | set(vtypes))]
    prov_rows = [[k, str(v)] for k, v in prov.items()
                 if k != "reconstruction" and not isinstance(v, (dict, list))]
    short_meta, long_meta = _metadata_items(meta)
    rec_lines = _reconstruction_lines(identification)
    settings_dict = settings.to_dict() if hasattr(settings, "to_dict") else {}
    warnings = list(identification.warnings)

    out: list = [Heading(1, _title(identification)),
                 Nav([("table", "validation table"), ("data", "data")]
                     + [(f"coef-{c}", c) for c in identification.results]
                     + [("derivatives", "derivatives")]),
                 Heading(2, "Run", "header", only="html"),
                 Heading(3, "Data", only="html"),
                 Table(["set", "maneuvers", "samples"], data_rows, left=(0,), only="html")]
    if type_rows:
        out.append(Table(["maneuver type", "identification", "validation"], type_rows,
                         left=(0,), only="html"))
    out += [Heading(3, "Provenance", only="html"),
            Table(["key", "value"], prov_rows, left=(0, 1), only="html")]
    if rec_lines:
        out += [Heading(3, "Reconstruction", only="html"),
                Code("\n".join(rec_lines), only="html")]
    out += [Heading(3, "Metadata", only="html"),
            Table(["key", "value"], short_meta, left=(0, 1), only="html")]
    out += [Code(_short_json(v), summary=f"{k} ({_describe(v)})", only="html")
            for k, v in long_meta]
    out += [Heading(3, "Settings", only="html"),
            Code(_short_json(settings_dict, 20000), summary="identification settings",
                 only="html")]
    if warnings:
        out += [Heading(3, "Warnings", only="html")] + [Alert(w, only="html")
                                                          for w in warnings]

    # the Markdown summary of the run
    out.append(Paragraph(["Aircraft: ", Strong(str(aircraft)),
                          f". Identification: {n_id} maneuvers ({len(ident):,} samples); "
                          f"validation: {n_va} maneuvers ({len(valid):,} samples)."],
                         only="md"))
    if prov_rows:
        out.append(BulletList([f"{k}: {v}" for k, v in prov_rows], only="md"))
    if rec_lines:
        out += [Paragraph("Reconstruction:", only="md"),
                Code("\n".join(rec_lines), only="md")]
    out.append(Paragraph("Settings:", only="md"))
    if settings_dict:
        out.append(BulletList([[f"{k}: ", CodeSpan(json.dumps(v, default=str)[:2000])]
                               for k, v in settings_dict.items()], only="md"))
    if warnings:
        out += [Paragraph("Warnings:", only="md"), BulletList(warnings, only="md")]
    return out


def _table_section(identification) -> list:
    """The validation table next to the paper's Table 2."""
    head, rows = _rows_table2(identification)
    truth = (" The truth columns compare the model with the true (simulated) coefficients; ",
             Emph("noise RMS"), " is the RMS of measured - true.") \
        if identification.has_truth else ()
    intro = ["Scores of each model on the held-out validation maneuvers. Relative RMS is "
             "RMS / (max - min) of the measured coefficient (the paper's Eq. 55 with the "
             "square root); ", Emph("paper"), " is the Cessna Citation II result of the "
             "paper's Table 2.", *truth,
             " Green: better than the paper / below the measurement noise; red: not."]
    return [Heading(2, "Validation (Table 2 style)", "table"),
            Paragraph(intro, only="html"),
            Table(head, rows, left=(0, 1)),
            Code(identification.table(), summary="plain text", only="html")]


def _data_section(ident, valid, types: dict, slot: Slot) -> list:
    """The identification data's projections and one example maneuver of each type."""
    out = [Heading(2, "Flight data", "data"),
           slot("data projections", _fig_projections, ident, valid),
           slot("3-D data projection", _fig_projection_3d, ident)]
    for i, (mtype, ids) in enumerate(types.items()):
        out.append(slot(f"{mtype} time history", _fig_time_history, ident,
                        ids[len(ids) // 2], mtype, i))
    return out


def _coefficient_section(c: str, res, identification, ident, valid, slot: Slot) -> list:
    """One coefficient: its model, structure selection, slices, validation, diagnostics
    and triangulation."""
    model = res.model
    s = model.structure
    v = res.validation
    summary = (f"degree {s.degree}, continuity C^{s.continuity}, "
               f"{model.spline.triangulation.nsimplex} simplices, "
               f"{int(np.asarray(model.spline.coefficients).size)} B-coefficients, "
               f"{s.ncoef_per_simplex} per simplex; fitted in {_fmt(res.seconds, '.1f')} s. "
               f"Validation: RMS {_fmt(v.get('rms'), '.3e')}, relative RMS "
               f"{_pct(v.get('rrms'))}, R² {_fmt(v.get('r2'), '.4f')}, bias "
               f"{_fmt(v.get('bias'), '.2e')}, max |error| {_fmt(v.get('max_abs'), '.2e')}"
               + (f"; against the truth: RMS {_fmt(v.get('rms_true'), '.3e')} (measurement"
                  f" noise RMS {_fmt(v.get('noise_rms'), '.3e')})" if "rms_true" in v
                  else "") + "."
               + (f" These scores include maneuver {v['left_out']['maneuver']}, validated "
                  f"by leaving it out (a model of the same structure identified without it:"
                  f" R² {_fmt(v['left_out'].get('r2'), '.4f')} there); the validation "
                  f"maneuvers alone: R² {_fmt(v['shared'].get('r2'), '.4f')}."
                  if "left_out" in v else ""))
    shead, srows = _structure_rows(res, ident)
    mine = [w for w in identification.warnings if w.startswith(f"{c}:")]
    if len(res.thin) and not mine:
        mine = [f"{c}: {len(res.thin)} thinly covered simplices"]
    out = [Heading(2, f"{c}: {s.label()}", f"coef-{c}"),
           Paragraph(summary),
           Table(shead, srows, left=(0, 1)),
           *(Alert(w) for w in mine),
           Heading(3, "Structure selection")]
    if len(res.history) <= 1 and not any(np.isfinite(float(t.score)) for t in res.history):
        out.append(Paragraph("Structure fixed (automatic selection off)."))
    hhead, hrows, hclasses = _history_rows(res.history)
    truth = bool(identification.has_truth) and f"true_{c}" in valid.columns
    thin_factor = float(getattr(identification.settings, "thin_factor", 2.0))
    out += [Table(hhead, hrows, left=(2, 3, 9), classes=hclasses),
            slot(f"{c} selection history", _fig_selection, c, res.history),
            Heading(3, "Model and validation"),
            slot(f"{c} slices", _fig_slices, c, model, ident),
            slot(f"{c} validation", _fig_validation, c, valid, model, truth),
            slot(f"{c} diagnostics", _fig_diagnostics, c, res,
                 thin_factor * s.ncoef_per_simplex),
            slot(f"{c} triangulation", _fig_triangulation, c, model, ident, res.thin)]
    return out


def _title(identification) -> str:
    aircraft = (identification.metadata or {}).get("aircraft") or "unknown aircraft"
    return f"Aerodynamic model identification: {aircraft}"


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
    for six coefficients takes a few seconds. Both files are rendered from one list of
    blocks (:mod:`~simplexspline.aero.report.document`), one section at a time.
    """
    t0 = time.perf_counter()
    say = progress or (lambda _msg: None)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    if workers is None:
        workers = min(2, os.cpu_count() or 1)
    jobs: list = []

    def slot(label: str, fn: Callable, *args) -> _Pending:
        jobs.append((label, partial(fn, _Renderer, *args)))
        return _Pending(len(jobs) - 1)

    ident = without_metadata(identification.identification)
    valid = without_metadata(identification.validation)
    types = _maneuver_types(ident)
    blocks = _header_section(identification, ident, valid, types)
    blocks += _table_section(identification)
    blocks += _data_section(ident, valid, types, slot)
    for c, res in identification.results.items():
        blocks += _coefficient_section(c, res, identification, ident, valid, slot)
    blocks += _derivative_section({c: res.model for c, res in identification.results.items()},
                                  ident, slot, identification.derivatives,
                                  {c: res.fold_models
                                   for c, res in identification.results.items()})

    rendered = _render(jobs, workers, say)
    (outdir / "figures").mkdir(exist_ok=True)
    for f in rendered:
        if f is not None:
            (outdir / "figures" / f"{f.name}.png").write_bytes(f.png)
    count = sum(f is not None for f in rendered)
    blocks = [rendered[b.index] if isinstance(b, _Pending) else b for b in blocks]
    blocks = [b for b in blocks if b is not None]

    seconds = time.perf_counter() - t0
    software = (identification.provenance or {}).get("software", "simplexspline")
    blocks.append(Footer(f"Written by {software} in {seconds:.1f} s, {count} figures."))
    path = outdir / "report.html"
    write_text(path, to_html(blocks, title=_title(identification), css=_CSS))
    write_text(outdir / "report.md", to_markdown(blocks))
    say(f"report: {count} figures in {seconds:.1f} s")
    return path
