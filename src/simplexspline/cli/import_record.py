"""`simplexspline import`: a flight-test record (channel files, CSV, .mat, Parquet) -> schema."""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

from simplexspline.aero.data.flight_data import write_flight_data
from simplexspline.aero.data.mapping import SEGMENT_METHODS, read_mapping
from simplexspline.aero.data.record_import import import_record
from simplexspline.errors import FlightDataError, InputError


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the command's parser to ``sub``; :func:`run` executes it."""
    p = sub.add_parser(
        "import",
        help="import a flight-test record (channel files, CSV, .mat, Parquet) described by "
             "a TOML mapping file into the flight-data schema",
        description="Reads the record named in the mapping file (docs/import.md), converts "
        "units and signs, repairs and reports time-stamp glitches, puts the channels on one "
        "time base, derives Mach, true airspeed, density, mass and inertias, runs sanity "
        "checks (rate signs against attitude derivatives, specific force against kinematics, "
        "alpha against theta - gamma, units), drops ground samples and cuts the flight into "
        "maneuvers. Prints the sanity report and a summary. A failed sanity check (a "
        "sign-inverted channel) stops before writing unless --force.",
    )
    p.add_argument("mapping", type=Path, help="the TOML mapping file")
    p.add_argument("-o", "--output", type=Path, required=True,
                   help="output file, .parquet (preferred) or .csv")
    p.add_argument("--segments", choices=SEGMENT_METHODS, default=None,
                   help="how to cut the flight into maneuvers (default: the mapping's "
                        "[segments] method, else 'auto': the maneuver list if given, else "
                        "excitation detection, else every airborne stretch)")
    p.add_argument("--maneuver-list", type=Path, default=None,
                   help="maneuver time list (CSV start,end,type or TOML [[maneuver]]); "
                        "implies --segments list")
    p.add_argument("--force", action="store_true",
                   help="write the output even when a sanity check fails")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="print only failed or warning sanity checks")
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``simplexspline import`` with the parsed arguments; returns the exit code."""
    if args.output.suffix.lower() not in (".parquet", ".pq", ".csv"):
        raise InputError(f"output {str(args.output)!r} must end in .parquet or .csv")
    if not args.output.parent.is_dir():
        raise InputError(f"output directory {str(args.output.parent)!r} does not exist")
    t0 = time.perf_counter()
    mapping = read_mapping(args.mapping)
    seg = mapping.segments
    if args.maneuver_list is not None:
        seg = dataclasses.replace(seg, method="list", list=args.maneuver_list.resolve())
    elif args.segments is not None:
        if args.segments == "list" and seg.list is None:
            raise InputError("--segments list needs a maneuver list: --maneuver-list FILE or "
                             "[segments] list in the mapping")
        seg = dataclasses.replace(seg, method=args.segments)
    mapping = dataclasses.replace(mapping, segments=seg)
    result = import_record(mapping)
    sanity = result.sanity
    shown = sanity.problems if args.quiet else sanity.checks
    if shown:
        print("sanity checks:")
        print("\n".join(ln for ln, c in zip(sanity.text().splitlines(), sanity.checks)
                        if c in shown))
    if not args.quiet:
        print(result.summary())
    failed = sanity.failed()
    if failed and not args.force:
        raise FlightDataError(f"{len(failed)} sanity check(s) failed ({failed[0].message}); "
                              "nothing written: fix the mapping (sign, unit, offset) or pass "
                              "--force to write anyway")
    write_flight_data(result.data, args.output)
    if not args.quiet:
        n = len(result.data)
        print(f"{args.output}: {n:,} samples in {result.data['maneuver'].nunique()} "
              f"maneuver(s) written in {time.perf_counter() - t0:.1f} s")
    return 0
