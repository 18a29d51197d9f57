"""Benchmark: the default identification on aircraft, conditions and maneuvers it was not
developed on (issue 19).

    python benchmarks/bench_generalization.py [--quick] [--aircraft f16,c172p]
        [--variants paper-gps,alternative-nogps] [--maneuvers 40] [--seed 101]
        [--workers 2] [--out benchmarks/results/generalization]

For every aircraft and data variant it simulates a campaign at the midpoints of the
aircraft's default condition grid (:meth:`ConditionGrid.between`: conditions not used in
development) with a seed other than 0, runs the **default** identification
(:func:`simplexspline.aero.identify` with no settings, as ``simplexspline identify DATA``)
and prints one row per coefficient:

* ``true/noise``: RMS of the validation model against the true coefficient, divided by the
  RMS of the reconstructed coefficient's error against the truth (the noise identify
  reports). Targets: <= 1 with GPS, <= 1.5 without;
* ``@truth`` (``at true inputs / noise``): the same with the model evaluated at the true
  inputs (a diagnostic: the part of ``true/noise`` that the noise of the measured inputs,
  e.g. control-surface positions, causes whatever the model);
* ``rel. RMS`` and ``R2`` on the validation maneuvers, against the paper's Table 2
  (``PAPER_TABLE2``): target within Table 2 wherever the coefficient is excited (R2 well
  above 0);
* the seconds of the simulation and of the identification.

Variants: ``paper`` or ``alternative`` (the other excitation design and pilot:
:meth:`FlightProtocol.alternative`), each ``-gps`` (GPS position and velocity columns kept)
or ``-nogps`` (dropped). One campaign per aircraft and design serves both GPS variants.
The table is also written as JSON and Markdown under ``--out``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from simplexspline._files import jsonable, write_text
from simplexspline.aero import identify
from simplexspline.aero.config import load_config
from simplexspline.aero.data.angle_rates import angle_rates
from simplexspline.aero.selection.validation import PAPER_TABLE2
from simplexspline.sim import Campaign, ConditionGrid, FlightProtocol, available_aircraft

GPS_COLUMNS = ("x_gps", "y_gps", "z_gps", "vn_gps", "ve_gps", "vd_gps")
VARIANTS = ("paper-gps", "paper-nogps", "alternative-gps", "alternative-nogps")
#: rms_true / noise targets per GPS variant (issue 19)
TARGET = {"gps": 1.0, "nogps": 1.5}


def campaign(aircraft: str, design: str, maneuvers: int, seed: int, workers: int):
    """Simulate one campaign of ``design`` ('paper' or 'alternative'); (table, seconds)."""
    protocol = FlightProtocol.alternative() if design == "alternative" else FlightProtocol()
    t0 = time.perf_counter()
    df = Campaign(aircraft, maneuvers=maneuvers, seed=seed, grid=ConditionGrid.between(aircraft),
                  protocol=protocol).run(workers=workers, progress=False)
    return df, time.perf_counter() - t0


def true_inputs(valid, variables, metadata) -> dict:
    """The model inputs ``variables`` of the validation samples as the simulator had them
    (``true_*`` columns; the non-dimensional rates, flow-angle rates and the thrust
    coefficient recomputed from true values); columns without a truth are taken as they
    are (mass, flap, thrust: not corrupted by the sensor model). The body rates are those
    relative to the air (``true_p_aero`` ..) where the campaign flew in wind: in
    turbulence the aerodynamics see them, not the inertial rates the gyros measure."""
    true = {v: valid[f"true_{v}"].to_numpy(dtype=float) if f"true_{v}" in valid.columns
            else None for v in ("alpha", "beta", "tas", "rho", "p", "q", "r")}
    for axis in "pqr":
        if f"true_{axis}_aero" in valid.columns:
            true[axis] = valid[f"true_{axis}_aero"].to_numpy(dtype=float)
    length = {"phat": ("p", "b"), "qhat": ("q", "cbar"), "rhat": ("r", "b")}
    frame = valid[["maneuver", "t"]].copy()
    for v in ("alpha", "beta", "tas"):
        frame[v] = true[v] if true[v] is not None else valid[v].to_numpy(dtype=float)
    rates = angle_rates(frame, metadata)
    out = {}
    for v in variables:
        if f"true_{v}" in valid.columns:
            out[v] = valid[f"true_{v}"].to_numpy(dtype=float)
        elif v in length and true[length[v][0]] is not None:
            axis, ref = length[v]
            out[v] = true[axis] * float(metadata[ref]) / (2.0 * frame["tas"].to_numpy())
        elif v in rates:
            out[v] = rates[v]
        elif v == "tc" and true["rho"] is not None:
            qbar = 0.5 * true["rho"] * frame["tas"].to_numpy() ** 2
            out[v] = valid["thrust_x"].to_numpy(dtype=float) / (qbar * float(metadata["S"]))
        else:
            out[v] = valid[v].to_numpy(dtype=float)
    return out


def rms_at_true_inputs(result, c: str) -> float:
    """RMS of coefficient ``c``'s identified model at the validation samples' true inputs
    (:func:`true_inputs`) against the true coefficient, over the samples inside the
    identification data's coverage: the model's own error, without that of the
    reconstructed states it is evaluated at."""
    valid = result.validation
    model = result.results[c].model
    cols = true_inputs(valid, model.variables, result.metadata)   # whole maneuvers
    keep = valid[f"inside_{c}"].to_numpy(dtype=bool) & np.all(
        np.isfinite(np.column_stack(list(cols.values()))), axis=1)
    if not keep.any():
        return float("nan")
    pred = model.predict({v: x[keep] for v, x in cols.items()})
    err = pred - valid.loc[keep, f"true_{c}"].to_numpy(dtype=float)
    return float(np.sqrt(np.mean(err ** 2)))


def identify_variant(df, gps: bool, settings=None) -> tuple[list[dict], float, list[str]]:
    """Default identification with or without the GPS columns; rows, seconds, warnings.

    Besides identify's own score (the model at the reconstructed inputs against the true
    coefficient, ``rms_true``), each row has ``rms_true_inputs``: the model at the true
    inputs against the true coefficient, which leaves out the noise of the measured inputs
    (control-surface positions, flow angles) that a model evaluated on measured data
    carries whatever its form. ``settings`` (optional): the identification's settings
    (``--config``); the defaults otherwise."""
    data = df if gps else df.drop(columns=[c for c in GPS_COLUMNS if c in df.columns])
    data.attrs = df.attrs
    t0 = time.perf_counter()
    result = identify(data, settings=settings)
    seconds = time.perf_counter() - t0
    rows = []
    for c, entry in result.summary()["coefficients"].items():
        at_truth = rms_at_true_inputs(result, c)
        # against the truth: the delivered model on the validation maneuvers (not the
        # model identified without a left-out maneuver, which only R2 and rel. RMS hold)
        truth = entry.get("shared", entry)
        noise = truth.get("noise_rms")
        rows.append({"coefficient": c, "rms_true": truth.get("rms_true"),
                     "noise_rms": noise,
                     "true_over_noise": truth.get("rms_true_over_noise"),
                     "rms_true_inputs": at_truth,
                     "true_inputs_over_noise": at_truth / noise if noise else None,
                     "rrms": entry["rrms"], "r2": entry["r2"], "paper_rrms": PAPER_TABLE2.get(c),
                     "label": entry["label"]})
    return rows, seconds, list(result.warnings)


def _fmt(x, spec: str) -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def markdown(rows: list[dict]) -> str:
    """The table as Markdown (one row per aircraft, variant and coefficient)."""
    head = ("| aircraft | variant | coefficient | rms_true | noise_rms | true/noise | target | "
            "at true inputs / noise | rel. RMS | Table 2 | R2 | sim s | identify s |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        paper = r["paper_rrms"]
        lines.append(
            f"| {r['aircraft']} | {r['variant']} | {r['coefficient']} | "
            f"{_fmt(r['rms_true'], '.2e')} | {_fmt(r['noise_rms'], '.2e')} | "
            f"{_fmt(r['true_over_noise'], '.2f')} | {r['target']:.1f} | "
            f"{_fmt(r.get('true_inputs_over_noise'), '.2f')} | "
            f"{100 * r['rrms']:.2f} % | {'-' if paper is None else f'{100 * paper:.2f} %'} | "
            f"{r['r2']:.3f} | {r['sim_s']:.0f} | {r['identify_s']:.0f} |")
    return "\n".join(lines)


def _write(out: Path, settings: dict, runs: list, rows: list) -> None:
    """The tables so far as JSON and Markdown (rewritten after every identification)."""
    write_text(out / "generalization.json",
               json.dumps(jsonable({"settings": settings, "runs": runs, "rows": rows}),
                          indent=1) + "\n")
    write_text(out / "generalization.md",
               f"Command: `{settings['command']}`\n\n{markdown(rows)}\n")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help="smoke run: f16 and c172p, 16 maneuvers, the alternative design")
    ap.add_argument("--aircraft", default=None,
                    help="comma-separated aircraft (default: f16,global5000,c172p,A4,737,T37)")
    ap.add_argument("--variants", default=None,
                    help=f"comma-separated variants from {','.join(VARIANTS)} (default: all)")
    ap.add_argument("--maneuvers", type=int, default=None, help="maneuvers per campaign (40)")
    ap.add_argument("--seed", type=int, default=101, help="campaign seed (101; never 0)")
    ap.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1),
                    help="simulation worker processes (2)")
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results"
                    / "generalization", help="directory of the JSON and Markdown tables")
    ap.add_argument("--config", type=Path, default=None,
                    help="identify's TOML config (docs/identification.md) to measure an "
                         "option; the defaults otherwise (write to another --out)")
    args = ap.parse_args(argv)
    aircraft = (args.aircraft.split(",") if args.aircraft else ["f16", "c172p"] if args.quick
                else ["f16", "global5000", "c172p", "A4", "737", "T37"])
    variants = (args.variants.split(",") if args.variants
                else ["alternative-gps", "alternative-nogps"] if args.quick else list(VARIANTS))
    maneuvers = args.maneuvers or (16 if args.quick else 40)
    for a in aircraft:
        if a not in available_aircraft():
            ap.error(f"unknown aircraft {a!r}: choose from {available_aircraft()}")
    for v in variants:
        if v not in VARIANTS:
            ap.error(f"unknown variant {v!r}: choose from {list(VARIANTS)}")
    if args.seed == 0:
        ap.error("seed 0 is the development seed: choose another")

    id_settings = None if args.config is None else load_config(args.config)
    rows, runs = [], []
    args.out.mkdir(parents=True, exist_ok=True)
    settings = {"aircraft": aircraft, "variants": variants, "maneuvers": maneuvers,
                "seed": args.seed, "conditions": "ConditionGrid.between (grid midpoints)",
                "command": "python benchmarks/bench_generalization.py "
                           + " ".join(sys.argv[1:] if argv is None else argv)}
    print(f"{'aircraft':<11} {'variant':<18} {'C':<3} {'rms_true':>9} {'noise':>9} "
          f"{'true/noise':>10} {'target':>6} {'@truth':>6} {'rel.RMS':>8} {'Table2':>7} "
          f"{'R2':>6} {'sim s':>6} {'id s':>6}", flush=True)
    for a in aircraft:
        for design in ("paper", "alternative"):
            wanted = [v for v in variants if v.startswith(design + "-")]
            if not wanted:
                continue
            df, sim_s = campaign(a, design, maneuvers, args.seed, args.workers)
            s = df.attrs["summary"]
            for v in wanted:
                gps = v.endswith("-gps")
                coeff_rows, id_s, warnings = identify_variant(df, gps, id_settings)
                runs.append({"aircraft": a, "variant": v, "sim_s": sim_s, "identify_s": id_s,
                             "maneuvers_kept": s["maneuvers_kept"], "samples": s["samples"],
                             "warnings": warnings})
                for r in coeff_rows:
                    r.update(aircraft=a, variant=v, target=TARGET["gps" if gps else "nogps"],
                             sim_s=sim_s, identify_s=id_s)
                    rows.append(r)
                    paper = r["paper_rrms"]
                    print(f"{a:<11} {v:<18} {r['coefficient']:<3} "
                          f"{_fmt(r['rms_true'], '9.2e')} {_fmt(r['noise_rms'], '9.2e')} "
                          f"{_fmt(r['true_over_noise'], '10.2f')} {r['target']:>6.1f} "
                          f"{_fmt(r['true_inputs_over_noise'], '6.2f')} "
                          f"{100 * r['rrms']:>7.2f}% "
                          f"{'-' if paper is None else f'{100 * paper:.2f}%':>7} "
                          f"{r['r2']:>6.3f} {sim_s:>6.0f} {id_s:>6.0f}", flush=True)
                _write(args.out, settings, runs, rows)  # a long run keeps what it measured
    meets = [r for r in rows if r["true_over_noise"] is not None
             and r["true_over_noise"] <= r["target"]]
    print(f"\n{len(meets)} of {len(rows)} coefficient models at or below their rms_true/noise "
          "target", flush=True)
    print(f"written {args.out / 'generalization.json'} and generalization.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
