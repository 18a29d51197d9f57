"""Comparison benchmark (issues 7 and 19): simplex splines against other model types.

Two modes.

``--candidates full`` (default, issue 19's honest comparison): on campaigns of several
aircraft (``--aircraft``, default the F-16 and the Cessna 172P), flown at conditions between
the aircraft's default grid points with seed 101 (``ConditionGrid.between``, as
``bench_generalization.py``), the **default** identification (``identify`` with no
settings: knowledge-free start, structure search) is run once per aircraft; every other
model type is then given the *same* full candidate variable set (every column of
``CANDIDATE_VARIABLES`` the data hold and that varies: alpha, beta, Mach, the rates, the
controls, alpha-dot and beta-dot, flap ...), trained on the same identification maneuvers
and scored on the same validation samples (those inside the identification data's
envelope, as ``identify`` scores them) against the true coefficients. Types:
``spline-default``, ``stepwise-cv``, ``mars`` (multivariate adaptive regression splines,
Friedman 1991, the classic adaptive-knot method: ``py-earth2``), ``tensor``, ``rbf``,
``mlp``, ``lightgbm`` (early stopping on held-out maneuvers) and ``ebm`` (``interpret``'s
explainable boosting machine); MARS and the last two come from the ``compare`` extra
(``pip install 'simplexspline[compare]'``).

``--candidates paper`` (issue 7): on a simulated F-16 flight-test campaign (JSBSim, reconstructed by the IEKF + RTS smoother,
exactly the data of ``simplexspline identify``), every coefficient CX..Cn is modelled from
the *same* explanatory variables (the paper preset, ``simplexspline.aero.modelling.structure``) by

* ``spline``: simplex spline of the paper preset (S^1_3, one grid cell per variable);
* ``spline-tuned``: simplex spline, degree and grid cells per variable chosen by the
  package's structure selection (3-fold CV over maneuvers), variables fixed;
* ``stepwise-cv`` / ``stepwise-F``: polynomial of total order <= 3 (``--poly-order``) with
  terms chosen by forward-backward stepwise regression, entry/removal by 3-fold CV over
  maneuvers or by the classical partial F-test;
* ``tensor``: cubic tensor-product B-spline, quantile knots, knot count by CV;
* ``rbf``: ``scipy.interpolate.RBFInterpolator`` (thin-plate spline) on a random subsample,
  smoothing chosen on held-out maneuvers;
* ``mlp``: ``sklearn.neural_network.MLPRegressor`` (64-64 ReLU, Adam, early stopping);

(the baselines are in ``benchmarks/baselines.py``) and scored on the held-out validation
maneuvers (the pipeline's split) against the simulator's true coefficients, with fit time,
evaluation throughput and single-point latency, and model size.

Usage::

    python benchmarks/bench_compare.py --out benchmarks/RESULTS-compare-full.md
    python benchmarks/bench_compare.py --candidates paper   # 120 maneuvers, ~10-15 min
    python benchmarks/bench_compare.py --data DIR --out RESULTS.md
    python benchmarks/bench_compare.py --quick              # smoke run (20 maneuvers)

The reconstructed campaign is cached in ``--data`` (default
``~/.cache/simplexspline/bench-compare``), so only the first run simulates (about 20 s for
120 maneuvers) and reconstructs (about 60 s) on an idle 2-core machine.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

COEFFICIENTS = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")
#: Columns kept from the reconstructed campaign (everything the benchmark uses).
KEEP = ("maneuver", "maneuver_type", "t", "alpha", "beta", "mach", "phat", "qhat", "rhat",
        "de", "da", "dr", *COEFFICIENTS, *(f"true_{c}" for c in COEFFICIENTS))


def default_cache() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "simplexspline" / "bench-compare"


def _atomic_parquet(df, path: Path, meta: dict) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    kv = dict(table.schema.metadata or {})
    kv[b"bench_compare"] = json.dumps(meta).encode()
    table = table.replace_schema_metadata(kv)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        pq.write_table(table, tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def campaign(maneuvers: int, seed: int, data_dir: Path, workers: int, log=print):
    """The reconstructed campaign (cached): DataFrame of :data:`KEEP` columns and a note."""
    import pandas as pd
    import pyarrow.parquet as pq

    data_dir.mkdir(parents=True, exist_ok=True)
    raw_path = data_dir / f"f16_m{maneuvers}_s{seed}.parquet"
    rec_path = data_dir / f"f16_m{maneuvers}_s{seed}_rec.parquet"
    if rec_path.is_file():
        table = pq.read_table(rec_path)
        note = json.loads(table.schema.metadata[b"bench_compare"])
        note["cached"] = str(rec_path)
        df = table.to_pandas()
        df.attrs = {}
        log(f"reconstructed campaign from the cache {rec_path}")
        return df, note
    from simplexspline.aero.data.flight_data import read_flight_data
    from simplexspline.aero.reconstruction.reconstruct import reconstruct

    note = {"maneuvers": maneuvers, "seed": seed}
    if raw_path.is_file():
        raw, meta = read_flight_data(raw_path, nan="ignore")
        log(f"raw campaign from the cache {raw_path}")
    else:
        from simplexspline.sim import simulate_campaign

        t0 = time.perf_counter()
        raw = simulate_campaign("f16", maneuvers=maneuvers, seed=seed, output=raw_path,
                                workers=workers, progress=False)
        meta = dict(raw.attrs)
        note["simulate_s"] = round(time.perf_counter() - t0, 1)
        log(f"simulated {raw['maneuver'].nunique()} maneuvers ({len(raw):,} samples) in "
            f"{note['simulate_s']} s -> {raw_path}")
    t0 = time.perf_counter()
    rec = reconstruct(raw, meta, workers=workers)
    note["reconstruct_s"] = round(time.perf_counter() - t0, 1)
    note["rejected"] = {str(k): v for k, v in rec.rejected.items()}
    note["raw_samples"] = len(raw)
    log(f"reconstructed in {note['reconstruct_s']} s ({len(rec.rejected)} maneuvers "
        "rejected)")
    df = pd.DataFrame({c: rec.data[c].to_numpy() for c in KEEP})
    df["maneuver_type"] = df["maneuver_type"].astype(str)
    _atomic_parquet(df, rec_path, note)
    return df, note


# ----------------------------------------------------------------------------- models
MODEL_TYPES = ("spline", "spline-tuned", "stepwise-cv", "stepwise-F", "tensor", "rbf", "mlp")
#: The model types of the full-candidate comparison (issue 19).
FULL_TYPES = ("spline-default", "stepwise-cv", "mars", "tensor", "rbf", "mlp", "lightgbm",
              "ebm")
LABELS = {
    "spline-default": "simplex spline, knowledge-free defaults (`identify`)",
    "mars": "MARS (py-earth), pairwise, GCV penalty by CV",
    "lightgbm": "LightGBM, early stopping",
    "ebm": "explainable boosting machine (interpret)",
    "spline": "simplex spline, paper preset",
    "spline-tuned": "simplex spline, degree + grid by CV",
    "stepwise-cv": "polynomial, stepwise (CV)",
    "stepwise-F": "polynomial, stepwise (F-test)",
    "tensor": "tensor-product cubic B-spline",
    "rbf": "thin-plate RBF (scipy)",
    "mlp": "MLP 64-64 (scikit-learn)",
}


@dataclass
class Fitted:
    """A fitted model of one type for one coefficient."""

    predict: object            # physical inputs (N, n) -> (N,)
    nparams: int
    save: object               # path stem -> saved file path
    note: str = ""
    skipped: str = ""
    fit_seconds: float | None = None   # the fit's time when it ran elsewhere (identify)


def _baselines():
    here = str(Path(__file__).resolve().parent)
    if here not in sys.path:
        sys.path.insert(0, here)
    import baselines

    return baselines


def fit_model(kind: str, structure, data: dict, args) -> Fitted:
    """Fit one model type on the identification data of one coefficient."""
    from simplexspline.aero.selection.search import SelectionSettings, fit_structure, select_structure

    B = _baselines()
    variables = structure.variables
    x, y, mans, folds, scaling = (data["x"], data["y"], data["maneuvers"], data["folds"],
                                  data["scaling"])
    columns = dict(zip(variables, x.T))
    if kind in ("spline", "spline-tuned"):
        s = structure
        note = ""
        if kind == "spline-tuned":
            settings = SelectionSettings(moves=("degree", "resolution"), folds=3)
            s, history = select_structure(structure, columns, y, mans, settings,
                                          seed=args.seed)
            note = f"{len(history)} structures scored; "
        model = fit_structure(s, columns, y)
        nsimp = model.spline.triangulation.nsimplex

        def save(stem):
            path = Path(f"{stem}.npz")
            model.save(path)
            return path

        return Fitted(model.predict, int(model.spline.coefficients.size), save,
                      note + f"{s.label()}, {nsimp} simplices", )

    return fit_baseline(kind, x, y, mans, folds, scaling, args)


def fit_baseline(kind: str, x: np.ndarray, y: np.ndarray, mans: np.ndarray,
                 folds: np.ndarray, scaling, args) -> Fitted:
    """Fit one of the other model types on physical inputs ``x`` (N, n), scaled to the
    identification data's unit box (``scaling``) and clamped to it."""
    B = _baselines()
    n = x.shape[1]
    u = scaling.transform(x)

    def wrap(m):
        return lambda xx: m.predict(scaling.transform(xx, clip=True))

    def saver(m):
        def save(stem):
            return m.save(Path(f"{stem}.npz"))
        return save

    if kind in ("stepwise-cv", "stepwise-F"):
        crit = "cv" if kind == "stepwise-cv" else "F"
        res = B.stepwise_regression(u, y, folds, order=args.poly_order, criterion=crit)
        m = res.model
        nterms = B.monomial_exponents(n, args.poly_order).shape[0]
        return Fitted(wrap(m), m.nparams, saver(m),
                      f"{m.nparams} of {nterms} terms (order <= {args.poly_order})")
    if kind == "tensor":
        # Normal equations cost 2 * 4^(2n) flops per sample: subsample beyond the budget.
        cap = max(1000, int(args.tensor_flops / (2 * 4 ** (2 * n))))
        step = max(1, -(-len(y) // cap))
        m, history = B.select_tensor_bspline(u[::step], y[::step], folds[::step],
                                             max_coefficients=args.tensor_max_coefficients)
        if m is None:
            return Fitted(None, 0, None, skipped=(
                f"even 4^{n} = {4 ** n} coefficients exceed the budget "
                f"({args.tensor_max_coefficients} coefficients, 20 samples each)"))
        best = min(history, key=lambda h: h["cv_rms"])
        by_q = {}
        for h in history:
            by_q[h["interior"]] = min(by_q.get(h["interior"], np.inf), h["cv_rms"])
        tried = ", ".join(f"{q}: {v:.2e}" for q, v in by_q.items())
        empty = f", {best['empty_basis']} basis functions without data" \
            if best["empty_basis"] else ""
        sub = f"; fitted on every {step}th sample ({len(y[::step]):,})" if step > 1 else ""
        return Fitted(wrap(m), m.nparams, saver(m),
                      f"{best['interior']} interior knots per variable, "
                      f"{'x'.join(map(str, m.shape))} coefficients{empty}, difference "
                      f"penalty {best['penalty']:g} (best CV RMS by knots {tried}){sub}")
    if kind == "rbf":
        m = B.fit_rbf(u, y, mans, points=args.rbf_points, seed=args.seed)
        return Fitted(wrap(m), m.nparams, saver(m),
                      f"{m.ncentres:,} random centres, smoothing {m.smoothing:g} (of "
                      f"{len(m.history)} tried on held-out maneuvers)")
    if kind == "mlp":
        m = B.fit_mlp(u, y, max_iter=args.mlp_epochs, max_samples=args.mlp_samples,
                      seed=args.seed)
        r = m.regressor
        return Fitted(wrap(m), m.nparams, saver(m),
                      f"{m.samples:,} random training samples, {r.n_iter_} epochs"
                      f"{' (limit)' if r.n_iter_ >= args.mlp_epochs else ''}")
    if kind == "mars":
        m = B.fit_mars(u, y, folds, max_samples=args.mars_samples, seed=args.seed)
        tried = ", ".join(f"{h['penalty']:g}: {h['cv_rms']:.2e}" for h in m.history)
        return Fitted(wrap(m), m.nparams, m.save,
                      f"{m.terms} basis functions, GCV penalty {m.penalty:g} (CV RMS by "
                      f"penalty {tried}), {m.samples:,} random training samples")
    if kind == "lightgbm":
        m = B.fit_lightgbm(u, y, mans, seed=args.seed)
        return Fitted(wrap(m), m.nparams, m.save,
                      f"{m.rounds} rounds (early stopping on 20 % of the maneuvers), "
                      f"{m.samples:,} training samples")
    if kind == "ebm":
        m = B.fit_ebm(u, y, max_samples=args.ebm_samples, seed=args.seed)
        names = list(m.regressor.term_names_)
        return Fitted(wrap(m), m.nparams, m.save,
                      f"{len(names)} terms ({sum(' & ' in t for t in names)} pairwise), "
                      f"{m.samples:,} random training samples")
    raise ValueError(f"unknown model type {kind!r}; known: {MODEL_TYPES + FULL_TYPES}")


def _median_time(fn, repeats: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def measure(kind: str, structure, data: dict, val: dict, args, workdir: Path,
            fit=None) -> dict:
    """Fit (median of up to ``args.repeats`` when a fit takes < 5 s), score, time, size.

    ``fit``: a callable returning the :class:`Fitted` (default: :func:`fit_model` of
    ``kind`` on ``structure`` and ``data``); ``structure`` may then be the coefficient's
    name."""
    from simplexspline.aero.selection.validation import scores

    fit = fit or (lambda: fit_model(kind, structure, data, args))
    t0 = time.perf_counter()
    fitted = fit()
    fit_s = [time.perf_counter() - t0 if fitted.fit_seconds is None else fitted.fit_seconds]
    if fitted.skipped:
        return {"model": kind, "skipped": fitted.skipped}
    while len(fit_s) < args.repeats and fit_s[0] < 5.0 and fitted.fit_seconds is None:
        t0 = time.perf_counter()
        fitted = fit()
        fit_s.append(time.perf_counter() - t0)
    xv = val["x"]
    pred = fitted.predict(xv)                       # also warms up JIT-compiled kernels
    sc = scores(val["y"], pred, truth=val["truth"], max_lag=0)
    once = time.perf_counter()
    fitted.predict(xv)
    once = time.perf_counter() - once
    batch_s, _ = _median_time(lambda: fitted.predict(xv), 3 if once < 5 else 1)
    batch_s = min(batch_s, once)
    one = xv[len(xv) // 2: len(xv) // 2 + 1]
    t0 = time.perf_counter()
    fitted.predict(one)
    first = time.perf_counter() - t0
    calls = int(min(300, max(5, 1.0 / max(first, 1e-6))))
    single = []
    for i in range(calls):
        p = xv[(i * 7919) % len(xv)][None, :]
        t0 = time.perf_counter()
        fitted.predict(p)
        single.append(time.perf_counter() - t0)
    name = getattr(structure, "coefficient", structure)
    path = fitted.save(workdir / f"{name}_{kind}")
    return {"model": kind, "rms_true": sc["rms_true"], "rrms_true": sc["rrms_true"],
            "rms": sc["rms"], "noise_rms": sc["noise_rms"],
            "fit_s": float(np.median(fit_s)), "fit_repeats": len(fit_s),
            "points_per_s": len(xv) / batch_s, "single_us": 1e6 * float(np.median(single)),
            "nparams": fitted.nparams, "bytes": os.path.getsize(path), "note": fitted.note}


# ----------------------------------------------------------------------------- report
def _fmt_rate(r: float) -> str:
    return f"{r / 1e6:.2f} M" if r >= 1e6 else f"{r / 1e3:.0f} k" if r >= 1e3 else f"{r:.0f}"


def _fmt_bytes(b: int) -> str:
    return f"{b / 1e6:.1f} MB" if b >= 1e6 else f"{b / 1e3:.1f} kB"


def markdown(results: dict, context: dict) -> str:
    """The report: context, the accuracy table, the cost table, per-coefficient details."""
    coefs = list(results)
    order = dict.fromkeys((*FULL_TYPES, *MODEL_TYPES) if context.get("full")
                          else (*MODEL_TYPES, *FULL_TYPES))
    kinds = [k for k in order if any(k in results[c] for c in coefs)]
    lines = [context.get("title", "# Model types compared on a simulated F-16 campaign"), "",
             f"Command: `{context['command']}`", ""]
    lines += [f"- {line}" for line in context["notes"]]
    lines += ["", "## Validation RMS against the true coefficient", "",
              "RMS of (model - true coefficient) on the validation maneuvers; in brackets "
              "relative to the range of the measured coefficient (as `identify` reports "
              "`rrms_true`). Best per coefficient in bold.", ""]
    shared = len({tuple(results[c]["_variables"]) for c in coefs}) == 1
    head = [c if shared and context.get("full") else
            f"{c}({', '.join(results[c]['_variables'])})" for c in coefs]
    lines.append("| model | " + " | ".join(head) + " |")
    lines.append("|---" * (len(coefs) + 1) + "|")
    best = {}
    for c in coefs:
        ok = [(r["rms_true"], k) for k, r in results[c].items()
              if not k.startswith("_") and "rms_true" in r]
        best[c] = min(ok)[1] if ok else None
    for k in kinds:
        cells = []
        for c in coefs:
            r = results[c].get(k)
            if r is None:
                cells.append("")
            elif "skipped" in r:
                cells.append("skipped")
            else:
                txt = f"{r['rms_true']:.2e} ({100 * r['rrms_true']:.2f} %)"
                cells.append(f"**{txt}**" if best[c] == k else txt)
        lines.append(f"| {LABELS[k]} | " + " | ".join(cells) + " |")
    noise = [next((r["noise_rms"] for kk, r in results[c].items()
                   if not kk.startswith("_") and "noise_rms" in r), float("nan"))
             for c in coefs]
    lines.append("| *noise RMS (measured - true)* | " +
                 " | ".join(f"*{v:.2e}*" for v in noise) + " |")
    lines += ["", "## RMS against the truth over the noise RMS", "",
              "The figure `identify` reports as `rms_true_over_noise`: below 1, the model "
              "is closer to the true coefficient than the measured coefficient is.", "",
              "| model | " + " | ".join(coefs) + " |", "|---" * (len(coefs) + 1) + "|"]
    for k in kinds:
        cells = []
        for c in coefs:
            r = results[c].get(k)
            ok = r is not None and "rms_true" in r and r["noise_rms"] > 0
            txt = f"{r['rms_true'] / r['noise_rms']:.2f}" if ok else \
                ("skipped" if r is not None else "")
            cells.append(f"**{txt}**" if ok and best[c] == k else txt)
        lines.append(f"| {LABELS[k]} | " + " | ".join(cells) + " |")
    lines += ["", "## Cost", "",
              "Fit: wall time on the identification set including each type's own tuning "
              "(structure search, term selection, knot count, smoothing, early stopping); "
              "sum over the coefficients. Throughput: points per second predicting the "
              "whole validation set (physical inputs, scaling included); single point: "
              "median latency of one-point calls. Both as min - max over the coefficients. "
              "Parameters: numbers needed to evaluate; bytes: the saved model (`.npz`, "
              "uncompressed).", "",
              "| model | fit, total | fit per coefficient | throughput (points/s) | "
              "single point (us) | parameters | saved size |",
              "|---|---|---|---|---|---|---|"]
    for k in kinds:
        rs = [results[c][k] for c in coefs if k in results[c] and "fit_s" in results[c][k]]
        if not rs:
            lines.append(f"| {LABELS[k]} | skipped | | | | | |")
            continue

        def rng(vals, f):
            lo, hi = min(vals), max(vals)
            return f(lo) if f(lo) == f(hi) else f"{f(lo)} - {f(hi)}"

        fit = [r["fit_s"] for r in rs]
        lines.append(
            f"| {LABELS[k]} | {sum(fit):.1f} s | {rng(fit, lambda v: f'{v:.2f} s')} | "
            f"{rng([r['points_per_s'] for r in rs], _fmt_rate)} | "
            f"{rng([r['single_us'] for r in rs], lambda v: f'{v:.0f}')} | "
            f"{rng([r['nparams'] for r in rs], lambda v: f'{v:,}')} | "
            f"{rng([r['bytes'] for r in rs], _fmt_bytes)} |")
    lines += ["", "## Per coefficient", ""]
    for c in coefs:
        lines += [f"### {head[coefs.index(c)]}", "",
                  "| model | RMS vs truth | rel. | fit | points/s | 1 point | parameters | "
                  "bytes | model chosen |", "|---|---|---|---|---|---|---|---|---|"]
        for k in kinds:
            r = results[c].get(k)
            if r is None:
                continue
            if "skipped" in r:
                lines.append(f"| {LABELS[k]} | skipped | | | | | | | {r['skipped']} |")
                continue
            lines.append(
                f"| {LABELS[k]} | {r['rms_true']:.3e} | {100 * r['rrms_true']:.3f} % | "
                f"{r['fit_s']:.2f} s | {_fmt_rate(r['points_per_s'])} | "
                f"{r['single_us']:.0f} us | {r['nparams']:,} | {_fmt_bytes(r['bytes'])} | "
                f"{r['note']} |")
        lines.append("")
    lines += ["## Ranking by RMS against the truth", ""]
    for c in coefs:
        ok = sorted((r["rms_true"], k) for k, r in results[c].items()
                    if not k.startswith("_") and "rms_true" in r)
        if not ok:
            continue
        spline = results[c].get("spline-default", results[c].get(
            "spline-tuned", results[c].get("spline", {}))).get("rms_true")
        order = ", ".join(
            f"{k} {v:.2e}" + (f" ({100 * (v / spline - 1):+.0f} %)" if spline else "")
            for v, k in ok)
        lines.append(f"- {c}: {order}")
    if any("spline-default" in results[c] for c in coefs):
        lines += ["", "(percentages relative to the simplex spline defaults)"]
    elif any("spline-tuned" in results[c] for c in coefs):
        lines.append("")
        lines.append("(percentages relative to the tuned simplex spline)")
    return "\n".join(lines) + "\n"


def _atomic_text(path: Path, text: str) -> None:
    """Write ``text`` atomically with the mode a plain file gets (the package's helper)."""
    from simplexspline._files import write_text

    write_text(path, text)


# ----------------------------------------------------------------------------- full
def full_campaign(aircraft: str, maneuvers: int, seed: int, design: str, data_dir: Path,
                  workers: int, log=print):
    """A reconstructed campaign of ``aircraft`` between its grid conditions (cached):
    (DataFrame, metadata, note)."""
    from simplexspline.aero.data.flight_data import read_flight_data, write_flight_data
    from simplexspline.aero.reconstruction.reconstruct import reconstruct
    from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol

    data_dir.mkdir(parents=True, exist_ok=True)
    path = data_dir / f"{aircraft}_{design}_between_m{maneuvers}_s{seed}_rec.parquet"
    if path.is_file():
        df, meta = read_flight_data(path, nan="ignore")
        log(f"reconstructed {aircraft} campaign from the cache {path}")
        return df, meta, {"cached": str(path)}
    protocol = FlightProtocol.alternative() if design == "alternative" else FlightProtocol()
    t0 = time.perf_counter()
    raw = Campaign(aircraft, maneuvers=maneuvers, seed=seed,
                   grid=ConditionGrid.between(aircraft), protocol=protocol
                   ).run(workers=workers, progress=False)
    note = {"simulate_s": round(time.perf_counter() - t0, 1)}
    t0 = time.perf_counter()
    rec = reconstruct(raw, raw.attrs, workers=workers)
    note["reconstruct_s"] = round(time.perf_counter() - t0, 1)
    note["rejected"] = len(rec.rejected)
    log(f"{aircraft}: simulated in {note['simulate_s']} s, reconstructed in "
        f"{note['reconstruct_s']} s ({note['rejected']} maneuvers rejected)")
    write_flight_data(rec.data, path, rec.data.attrs)
    df, meta = read_flight_data(path, nan="ignore")
    return df, meta, note


def full_variables(ident) -> list[str]:
    """The full candidate set: every candidate variable the identification data hold,
    finite and varying (what the default search may choose from)."""
    from simplexspline.aero.variables import CANDIDATE_VARIABLES

    out = []
    for v in CANDIDATE_VARIABLES:
        if v in ident.columns:
            x = ident[v].to_numpy(dtype=float)
            if np.all(np.isfinite(x)) and np.ptp(x) > 0:
                out.append(v)
    return out


def run_full(args, kinds: list, coefs: list, log) -> str:
    """Issue 19's comparison: per aircraft, the default identification and every other
    model type on the same full candidate set, split and validation samples."""
    from threadpoolctl import threadpool_limits

    import scipy
    import sklearn

    import simplexspline
    from simplexspline.aero import identify
    from simplexspline.aero.config import load_config
    from simplexspline.aero.identify import IdentificationSettings
    from simplexspline.aero.modelling.structure import Scaling
    from simplexspline.aero.selection.validation import fold_by_maneuver

    load0 = os.getloadavg()[0]
    t_start = time.perf_counter()
    sections = []
    for aircraft in args.aircraft:
        df, meta, note = full_campaign(aircraft, args.maneuvers, args.seed, args.design,
                                       args.data or default_cache(), args.workers, log)
        t0 = time.perf_counter()
        base = IdentificationSettings(coefficients=tuple(coefs), workers=args.workers,
                                      seed=args.seed)
        result = identify(df, meta, settings=base if args.config is None
                          else load_config(args.config, base))
        identify_s = time.perf_counter() - t0
        log(f"{aircraft}: default identification in {identify_s:.0f} s")
        ident, valid_all = result.identification, result.validation
        variables = full_variables(ident)
        x = ident[variables].to_numpy(dtype=float)
        mans = ident["maneuver"].to_numpy()
        folds = fold_by_maneuver(mans, 3, seed=args.seed)
        scaling = Scaling.from_data(x, variables)
        results = {}
        with tempfile.TemporaryDirectory(prefix="bench-compare-") as tmp, \
                threadpool_limits(limits=1, user_api="blas"):
            for c in result.results:
                y = ident[c].to_numpy(dtype=float)
                res = result.results[c]
                # the samples identify scores: covered cell, kept simplex, identified box
                valid = valid_all.loc[valid_all[f"inside_{c}"].to_numpy(dtype=bool)]
                val = {"y": valid[c].to_numpy(dtype=float),
                       "truth": valid[f"true_{c}"].to_numpy(dtype=float)}
                results[c] = {"_variables": variables}
                for k in kinds:
                    if k == "spline-default":
                        model = res.model

                        def fit(model=model, res=res):
                            return Fitted(model.predict, int(model.spline.coefficients.size),
                                          lambda stem, m=model: m.save(Path(f"{stem}.json")),
                                          f"{model.structure.label()}, "
                                          f"{model.spline.triangulation.nsimplex} simplices",
                                          fit_seconds=res.seconds)
                        v = {**val, "x": valid[list(model.variables)].to_numpy(dtype=float)}
                    else:
                        def fit(k=k, y=y):
                            return fit_baseline(k, x, y, mans, folds, scaling, args)
                        v = {**val, "x": valid[variables].to_numpy(dtype=float)}
                    t0 = time.perf_counter()
                    r = measure(k, c, None, v, args, Path(tmp), fit=fit)
                    results[c][k] = r
                    log(f"{aircraft} {c:>2} {k:<14} " + (
                        f"skipped: {r['skipped']}" if "skipped" in r else
                        f"RMS vs truth {r['rms_true']:.3e} ({r['rms_true'] / r['noise_rms']:.2f}"
                        f" x noise)  fit {r['fit_s']:.1f} s  [{time.perf_counter() - t0:.0f} s]"
                        f"  {r['note']}"))
        data_note = (f"cached ({note['cached']})" if "cached" in note else
                     f"simulated in {note['simulate_s']} s, reconstructed in "
                     f"{note['reconstruct_s']} s, {note['rejected']} maneuvers rejected")
        context = {
            "title": f"## {aircraft}", "full": True,
            "command": "python benchmarks/bench_compare.py " + " ".join(args.argv),
            "notes": [
                f"Data: {aircraft}, {args.maneuvers} maneuvers ({args.design} design), seed "
                f"{args.seed}, flown between the default grid's conditions "
                f"(`ConditionGrid.between`), reconstructed with the IEKF + RTS smoother "
                f"({data_note}).",
                f"Split and envelope as `identify` makes them: "
                f"{ident['maneuver'].nunique()} identification maneuvers "
                f"({len(ident):,} samples); scored on the validation samples `identify` "
                "scores (`inside_<C>`: in a covered envelope cell, a kept simplex and the "
                "identified box of the spline model): " + ", ".join(
                    f"{c} {int(valid_all[f'inside_{c}'].sum()):,}" for c in results)
                + f" of {len(valid_all):,}.",
                f"Inputs of every other type: the full candidate set {variables}, scaled to "
                "the identification data's unit box and clamped to it. The spline defaults "
                "choose their variables from the same set by their own search.",
                f"The default identification took {identify_s:.0f} s for all coefficients "
                f"(`--workers {args.workers}`); its per-coefficient fit time is the "
                "coefficient's search + fit (coefficients ran in parallel).",
            ],
        }
        sections.append(markdown(results, context).replace("\n## ", "\n### ")
                        .replace("\n### " + aircraft, "\n## " + aircraft))
        if args.out is not None:            # each aircraft's section as soon as it is done
            _atomic_text(args.out, "\n".join(sections))
    total = time.perf_counter() - t_start
    def version(dist: str) -> str:
        try:
            return importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            return "not installed"

    head = [
        "# Model types compared on the full candidate set (issue 19)", "",
        f"Command: `python benchmarks/bench_compare.py {' '.join(args.argv)}`", "",
        f"- Machine: {os.cpu_count()} cores, shared with other jobs (load average "
        f"{load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end); BLAS limited to "
        f"one thread for the baselines. Total run time {total / 60:.1f} min.",
        f"- Versions: simplexspline {simplexspline.__version__}, numpy {np.__version__}, "
        f"scipy {scipy.__version__}, scikit-learn {sklearn.__version__}, lightgbm "
        f"{version('lightgbm')}, py-earth2 {version('py-earth2')}, Python "
        f"{sys.version.split()[0]}; "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}.", ""]
    return "\n".join(head) + "\n" + "\n".join(sections)


# ----------------------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maneuvers", type=int, default=120)
    ap.add_argument("--seed", type=int, default=0, help="campaign, split and model seed")
    ap.add_argument("--data", type=Path, default=None,
                    help="cache directory of the campaign (default %(default)s: "
                         "~/.cache/simplexspline/bench-compare)")
    ap.add_argument("--out", type=Path, default=None, help="also write the Markdown here")
    ap.add_argument("--workers", type=int, default=2, help="processes for simulation and "
                    "reconstruction")
    ap.add_argument("--coefficients", default=",".join(COEFFICIENTS))
    ap.add_argument("--models", default=",".join(MODEL_TYPES))
    ap.add_argument("--repeats", type=int, default=3,
                    help="fits repeated (median) when one takes < 5 s")
    ap.add_argument("--poly-order", type=int, default=3)
    ap.add_argument("--tensor-max-coefficients", type=int, default=4096)
    ap.add_argument("--tensor-flops", type=float, default=1e11,
                    help="normal-equation budget of a tensor fit (subsample beyond)")
    ap.add_argument("--rbf-points", type=int, default=3000)
    ap.add_argument("--mlp-samples", type=int, default=100_000)
    ap.add_argument("--mlp-epochs", type=int, default=60)
    ap.add_argument("--ebm-samples", type=int, default=5_000)
    ap.add_argument("--mars-samples", type=int, default=20_000,
                    help="random training samples of MARS (20,000)")
    ap.add_argument("--candidates", choices=("full", "paper"), default="full",
                    help="full: every type on the full candidate set, several aircraft "
                         "(issue 19); paper: the paper preset's variables, F-16 (issue 7)")
    ap.add_argument("--aircraft", default="f16,c172p",
                    help="aircraft of the full comparison (%(default)s)")
    ap.add_argument("--design", choices=("paper", "alternative"), default="paper",
                    help="maneuver design of the full comparison's campaigns")
    ap.add_argument("--config", type=Path, default=None,
                    help="identify's TOML config (docs/identification.md) for the spline "
                         "row of the full comparison instead of the defaults (to measure "
                         "an option; the table's label stays spline-default)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke run: 20 maneuvers, small RBF and MLP, no repeats")
    args = ap.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    args.aircraft = [a.strip() for a in args.aircraft.split(",") if a.strip()]
    full = args.candidates == "full"
    if full:
        if "--maneuvers" not in args.argv:
            args.maneuvers = 40
        if "--seed" not in args.argv:
            args.seed = 101
        if "--models" not in args.argv:
            args.models = ",".join(FULL_TYPES)
    if args.quick:
        args.maneuvers = min(args.maneuvers, 20)
        args.rbf_points, args.mlp_samples, args.mlp_epochs, args.repeats = 500, 20_000, 5, 1
    coefs = [c.strip() for c in args.coefficients.split(",") if c.strip()]
    kinds = [k.strip() for k in args.models.split(",") if k.strip()]
    known = FULL_TYPES if full else MODEL_TYPES
    bad = [c for c in coefs if c not in COEFFICIENTS] + [k for k in kinds if k not in known]
    if bad:
        ap.error(f"unknown coefficient(s)/model type(s) {bad}; known: {list(COEFFICIENTS)}, "
                 f"{list(known)}")
    if full:
        def log(msg):
            print(msg, file=sys.stderr, flush=True)

        text = run_full(args, kinds, coefs, log)
        print(text)
        if args.out is not None:
            _atomic_text(args.out, text)
            log(f"written {args.out}")
        return 0

    from threadpoolctl import threadpool_limits

    import scipy
    import sklearn

    import simplexspline
    from simplexspline.aero.modelling.presets import PAPER_PRESET
    from simplexspline.aero.modelling.structure import Scaling
    from simplexspline.aero.selection.validation import fold_by_maneuver, split_by_maneuver

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    load0 = os.getloadavg()[0]
    t_start = time.perf_counter()
    df, note = campaign(args.maneuvers, args.seed, args.data or default_cache(),
                        args.workers, log)
    # The pipeline's split (simplexspline.aero.identify): 25 % of the maneuvers of every
    # maneuver type held out for validation.
    is_val = split_by_maneuver(df["maneuver"].to_numpy(), 0.25, seed=args.seed,
                               groups=df["maneuver_type"].to_numpy())
    ident, valid = df.loc[~is_val], df.loc[is_val]
    mans = ident["maneuver"].to_numpy()
    folds = fold_by_maneuver(mans, 3, seed=args.seed)
    results = {}
    with tempfile.TemporaryDirectory(prefix="bench-compare-") as tmp, \
            threadpool_limits(limits=1, user_api="blas"):
        for c in coefs:
            structure = PAPER_PRESET[c]
            variables = list(structure.variables)
            x = ident[variables].to_numpy(dtype=float)
            data = {"x": x, "y": ident[c].to_numpy(dtype=float), "maneuvers": mans,
                    "folds": folds, "scaling": Scaling.from_data(x, variables)}
            val = {"x": valid[variables].to_numpy(dtype=float),
                   "y": valid[c].to_numpy(dtype=float),
                   "truth": valid[f"true_{c}"].to_numpy(dtype=float)}
            results[c] = {"_variables": variables}
            for k in kinds:
                t0 = time.perf_counter()
                r = measure(k, structure, data, val, args, Path(tmp))
                results[c][k] = r
                log(f"{c:>2} {k:<12} " + (f"skipped: {r['skipped']}" if "skipped" in r else
                    f"RMS vs truth {r['rms_true']:.3e}  fit {r['fit_s']:.2f} s  "
                    f"{_fmt_rate(r['points_per_s'])} points/s  {r['single_us']:.0f} us  "
                    f"[{time.perf_counter() - t0:.0f} s]  {r['note']}"))
    total = time.perf_counter() - t_start
    data_note = (f"cached ({note['cached']})" if "cached" in note else
                 f"simulated in {note.get('simulate_s', '?')} s, reconstructed in "
                 f"{note['reconstruct_s']} s")
    context = {
        "command": "python benchmarks/bench_compare.py " + " ".join(
            sys.argv[1:] if argv is None else argv),
        "notes": [
            f"Data: F-16 campaign, {args.maneuvers} maneuvers, seed {args.seed} "
            f"(`simplexspline simulate --aircraft f16 --maneuvers {args.maneuvers} --seed "
            f"{args.seed}`), reconstructed with the IEKF + RTS smoother ({data_note}; "
            f"{len(note.get('rejected', {}))} maneuvers rejected).",
            f"Split as in `simplexspline identify`: {ident['maneuver'].nunique()} "
            f"identification maneuvers ({len(ident):,} samples), "
            f"{valid['maneuver'].nunique()} validation maneuvers ({len(valid):,} samples); "
            "tuning by 3-fold CV over identification maneuvers only.",
            "Inputs: the paper preset's variables per coefficient for every model type, "
            "scaled to the unit box of the identification data and clamped to it.",
            f"Machine: {os.cpu_count()} cores, shared with other jobs (load average "
            f"{load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end); BLAS limited "
            "to one thread for every model type (threadpoolctl). Total run time "
            f"{total / 60:.1f} min.",
            f"Versions: simplexspline {simplexspline.__version__}, numpy {np.__version__}, "
            f"scipy {scipy.__version__}, scikit-learn {sklearn.__version__}, Python "
            f"{sys.version.split()[0]}; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}.",
        ],
    }
    text = markdown(results, context)
    print(text)
    if args.out is not None:
        _atomic_text(args.out, text)
        log(f"written {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
