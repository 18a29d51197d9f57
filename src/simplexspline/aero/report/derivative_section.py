"""The identification report's section on stability and control derivatives.

The table of the models' partial derivatives
(:mod:`~simplexspline.aero.derivatives.stability`) at the identification data's median
condition, each model's partial derivatives along alpha at three Mach numbers, and the
alpha x Mach maps of the derivatives with respect to the angles and control surfaces;
:func:`_derivative_section` gives the section's blocks to
:func:`~simplexspline.aero.report.page.write_report`.
"""

from __future__ import annotations

import numpy as np

from simplexspline.aero.report.figures import _slice_values
from simplexspline.aero.report.document import Figure, Heading, Paragraph, Table
from simplexspline.aero.report.markup import _fmt, _unit
from simplexspline.aero.derivatives.jackknife import with_standard_errors
from simplexspline.aero.derivatives.plots import plot_derivative_map, plot_derivatives
from simplexspline.aero.derivatives.stability import derivatives, reference_conditions


def _sweep_axes(model, ident) -> dict:
    """Alpha (or the first variable) across the model's box; Mach lines at the 5/50/95 %
    quantiles of the identification data when the model has Mach."""
    x = "alpha" if "alpha" in model.variables else model.variables[0]
    i = model.variables.index(x)
    axes = {x: np.linspace(model.scaling.lower[i], model.scaling.upper[i], 41)}
    if "mach" in model.variables and x != "mach":
        axes["mach"] = np.round(_slice_values(model, ident, "mach"), 3)
    return axes


def _fig_derivatives(r, c: str, model, ident, ref: dict, folds=()) -> Figure | None:
    axes = _sweep_axes(model, ident)
    x = next(iter(axes))
    table = derivatives(model, axes, reference=ref, wrt=list(model.variables))
    mine = [{c: f} for f in folds if f is not None]
    if mine:                        # the jackknife's refits: +- 2 standard errors shaded
        table = with_standard_errors(table, mine, axes, wrt=list(model.variables))
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
                  "that line, grey: for all"
                  + ("; shaded: +- 2 jackknife standard errors" if mine else ""))


def _fig_derivative_maps(r, models: dict, ref: dict) -> Figure | None:
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


def _derivative_section(models: dict, ident, slot, jackknife=None,
                        folds: dict | None = None) -> list:
    """The 'Stability and control derivatives' section: a table at the reference
    condition and figures across the envelope (blocks of
    :mod:`~simplexspline.aero.report.document`; ``slot`` queues a figure). ``jackknife``:
    identify's table of the derivatives' standard errors
    (:attr:`~simplexspline.aero.identify.Identification.derivatives`), or None;
    ``folds``: per coefficient its jackknife refits (the figures' shaded errors)."""
    ref = reference_conditions(models, ident)
    at_ref = derivatives(models, None, reference=ref)
    rows = []
    for name, d in at_ref.attrs["derivatives"].items():
        if not d["in_model"]:
            continue
        value = float(at_ref[name].iloc[0])
        se = float(jackknife.loc[name, "standard_error"]) \
            if jackknife is not None and name in jackknife.index else float("nan")
        note = "" if bool(at_ref[f"inside_{d['coefficient']}"].iloc[0]) \
            else "outside the domain"
        if abs(value) < 2 * se:
            note = ", ".join(filter(None, (note, "sign not determined (zero within 2 "
                                                 "standard errors)")))
        rows.append([d["coefficient"], name, _fmt(value, ".4g"),
                     _fmt(se, ".2g") if np.isfinite(se) else "", d["unit"], note])
    cond = ", ".join(f"{v} = {_fmt(ref[v] * _unit(v)[1], '.3g')} {_unit(v)[0]}"
                     for v in ref)
    text = ("Exact partial derivatives of the identified models (spline gradients through "
            "the variable scaling), holding each model's other variables fixed: per rad for "
            "angles and surfaces, per unit Mach, and per non-dimensional rate for phat = "
            "pb/2V, qhat = qc/2V, rhat = rb/2V (the classical Cl_p, Cm_q, Cn_r). Variables "
            "a model does not have are left out (their derivatives are 0). Reference "
            f"condition (identification-data medians): {cond}. Standard errors: the "
            "delete-a-group jackknife over "
            + (f"{jackknife.attrs['folds']} folds" if jackknife is not None else "folds")
            + " of identification maneuvers (each model's structure identified again "
            "without each fold; conditional on the structure). docs/derivatives.md; "
            "'simplexspline derivatives OUTDIR' writes them as a table.")
    head = ["coefficient", "derivative", "at the reference", "standard error", "unit",
            "note"]
    return [Heading(2, "Stability and control derivatives", "derivatives"),
            Paragraph(text),
            Table(head, rows, left=(0, 1, 4, 5)),
            *(slot(f"{c} derivatives", _fig_derivatives, c, m, ident, ref,
                   tuple((folds or {}).get(c, ())))
              for c, m in models.items()),
            slot("derivative maps", _fig_derivative_maps, models, ref)]
