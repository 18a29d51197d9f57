"""`simplexspline identify`: the whole identification pipeline, and the main job.

With no DATA it simulates a small F-16 flight-test campaign on the fly (JSBSim), then runs
reconstruction, structure selection, validation and the report on it.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

from simplexspline.cli import arguments
from simplexspline.aero.config import load_config, parse_structure
from simplexspline.aero.data.flight_data import FlightDataWarning, read_flight_data
from simplexspline.aero.identify import (
    IdentificationSettings,
    ThinDataWarning,
    check_output_dir,
    file_hash,
    identify,
)
from simplexspline.errors import InputError
from simplexspline.sim import Campaign

#: The embedded default campaign of the main job (fits in about a minute on 2 cores).
DEFAULT_CAMPAIGN = {"aircraft": "f16", "maneuvers": 60, "seed": 0}


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the command's parser to ``sub``; :func:`run` executes it."""
    p = sub.add_parser(
        "identify",
        help="identify a global aerodynamic model (CX..Cn simplex splines) from flight data;"
             " without DATA: the main job on a simulated F-16 campaign",
        description="Flight data -> reconstruction (when the data are raw sensor channels) "
        "-> coefficients -> identification/validation split by maneuver -> automatic model "
        "structure selection (k-fold cross-validation by maneuver) -> fit -> validation -> "
        "OUTDIR/summary.json, OUTDIR/models/<C>.json, OUTDIR/report.html. Without DATA, a "
        "small F-16 campaign is simulated with JSBSim first (needs the 'sim' extra).",
    )
    p.add_argument("data", type=Path, nargs="?", default=None,
                   help="flight data, .parquet or .csv (+ .csv.json); raw or reconstructed")
    p.add_argument("-o", "--output", type=Path, default=Path("identification"),
                   help="output directory (replaced atomically when complete) "
                   "(./identification)")
    p.add_argument("--config", type=Path, default=None,
                   help="TOML file with [identify], [selection] and [models.<C>] tables "
                   "(docs/identification.md)")
    p.add_argument("--coefficients", default=None,
                   help="comma-separated subset of CX,CY,CZ,Cl,Cm,Cn")
    p.add_argument("--model", action="append", default=[], metavar="STRUCTURE",
                   help="starting structure, e.g. 'CZ(alpha:3, de, mach) S^1_3' or "
                   "'CZ=alpha,de,mach' (repeatable)")
    p.add_argument("--preset", choices=("auto", "paper", "varying", "f16"), default=None,
                   help="starting structures: knowledge-free varying-coefficient ones (auto, "
                   "the default), the paper's (paper), hand-picked varying-coefficient S^1_3 "
                   "(varying), or S^0_2 on the JSBSim F-16 table breakpoints (f16: prior "
                   "knowledge of one database)")
    p.add_argument("--no-select", action="store_true",
                   help="fit the given/preset structures as they are (no selection)")
    p.add_argument("--rounds", type=arguments.non_negative, default=None,
                   help="rounds of the structure selection (at most 12)")
    p.add_argument("--validation-fraction", type=arguments.fraction, default=None,
                   help="fraction of maneuvers held out for validation (0.25)")
    p.add_argument("--seed", type=arguments.seed, default=None, help="seed of split and folds (0)")
    p.add_argument("--workers", type=arguments.count, default=None,
                   help="processes for simulation and reconstruction (all CPUs)")
    p.add_argument("--overwrite", action="store_true",
                   help="write into a non-empty directory that is not a previous output "
                   "(its other files are kept; only the results' own entries are replaced)")
    p.add_argument("--format", choices=("json", "npz"), default="json",
                   help="model file format (json)")
    p.add_argument("--no-report", action="store_true", help="skip report.html / figures")
    p.add_argument("--maneuvers", type=arguments.count, default=None,
                   help=f"maneuvers of the simulated campaign without DATA "
                   f"({DEFAULT_CAMPAIGN['maneuvers']})")
    p.add_argument("--aircraft", default=None,
                   help="aircraft of the simulated campaign without DATA (f16)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    return p


def _settings(args):
    settings = IdentificationSettings()
    if args.config is not None:
        settings = load_config(args.config, settings)
    changes = {}
    if args.preset is not None:
        changes["preset"] = args.preset
    if args.coefficients:
        changes["coefficients"] = tuple(c.strip() for c in args.coefficients.split(",")
                                        if c.strip())
    if args.model:
        structures = dict(settings.structures or {})
        for text in args.model:
            s = parse_structure(text)
            structures[s.coefficient] = s
        changes["structures"] = structures
    if args.no_select:
        changes["select"] = False
    if args.validation_fraction is not None:
        changes["validation_fraction"] = args.validation_fraction
    if args.seed is not None:
        changes["seed"] = args.seed
    if args.workers is not None:
        changes["workers"] = args.workers
    if args.rounds is not None:
        changes["selection"] = replace(settings.selection, max_rounds=args.rounds)
    return replace(settings, **changes)


def _simulate(args, log):
    aircraft = args.aircraft or DEFAULT_CAMPAIGN["aircraft"]
    n = args.maneuvers or DEFAULT_CAMPAIGN["maneuvers"]
    seed = DEFAULT_CAMPAIGN["seed"] if args.seed is None else args.seed
    log(f"simulating a {aircraft} flight-test campaign: {n} maneuvers, seed {seed} (JSBSim)")
    campaign = Campaign(aircraft, maneuvers=n, seed=seed)
    df = campaign.run(workers=args.workers, progress=not args.quiet and sys.stderr.isatty())
    return df, dict(df.attrs), f"simulated {aircraft} campaign, {n} maneuvers, seed {seed}"


def run(args: argparse.Namespace) -> int:
    """Run ``simplexspline identify`` with the parsed arguments; returns the exit code."""
    t0 = time.perf_counter()
    log = (lambda msg: None) if args.quiet else (lambda msg: print(msg, flush=True))
    if args.data is not None and (args.aircraft or args.maneuvers):
        raise InputError("--aircraft and --maneuvers describe the simulated default "
                         "campaign; they cannot be used with DATA")
    settings = _settings(args)
    out = check_output_dir(args.output, overwrite=args.overwrite)  # before any work
    if args.data is None:
        df, meta, source = _simulate(args, log)
    else:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", FlightDataWarning)
            df, meta = read_flight_data(args.data, nan="warn")
        for w in caught:                 # NaN gaps: said on the console, not only in files
            if issubclass(w.category, FlightDataWarning):
                print(f"warning: {w.message}", file=sys.stderr)
            else:
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        source = f"{args.data.name} ({file_hash(args.data)})"
    progress = not args.quiet and sys.stderr.isatty()
    with warnings.catch_warnings():
        # thin-data warnings are printed after the table (result.warnings)
        warnings.simplefilter("ignore", ThinDataWarning)
        result = identify(df, meta, settings=settings, progress=progress, log=log,
                          source=source)
    log("writing models, summary and report")
    with warnings.catch_warnings():
        # matplotlib's 3-D projection overflows harmlessly on off-screen points
        warnings.filterwarnings("ignore", category=RuntimeWarning, module="mpl_toolkits")
        result.save(out, report=not args.no_report, model_format=args.format,
                    overwrite=args.overwrite)
    if not args.quiet:
        print()
        print(result.table())
        derivs = result.derivative_table()
        if derivs:
            print()
            print(derivs)
        rejected = (result.provenance.get("reconstruction") or {}).get("rejected") or {}
        if rejected:
            shown = "; ".join(f"maneuver {k}: {v}" for k, v in list(rejected.items())[:5])
            more = f" (and {len(rejected) - 5} more, see summary.json)" if len(rejected) > 5 \
                else ""
            print(f"warning: the reconstruction rejected {len(rejected)} maneuver(s): "
                  f"{shown}{more}")
        for w in result.warnings:
            print(f"warning: {w}")
        print(f"\n{out}/summary.json, {out}/models/, "
              + ("" if args.no_report else f"{out}/report.html ")
              + f"written in {time.perf_counter() - t0:.1f} s")
    return 0
