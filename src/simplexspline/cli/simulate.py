"""`simplexspline simulate`: fly a simulated flight-test campaign on JSBSim, write Parquet/CSV."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from simplexspline.cli import arguments
from simplexspline.aero.data.flight_data import write_flight_data
from simplexspline.errors import InputError
from simplexspline.sim import (TURBULENCE_SEVERITY, Campaign, ConditionGrid, FlightProtocol,
                               SensorModel, Wind, available_aircraft, write_channel_record)


def _floats(text: str) -> list[float]:
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated numbers, got {text!r}") from None


def _mix(text: str) -> dict[str, float]:
    out = {}
    for item in text.split(","):
        name, sep, weight = item.partition("=")
        if not sep:
            raise argparse.ArgumentTypeError(
                f"expected FAMILY=WEIGHT pairs such as 3211=0.5,sum-of-sines=0.3, got {text!r}")
        try:
            out[name.strip()] = float(weight)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"weight of {name!r} is not a number: {weight!r}") from None
    return out


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the command's parser to ``sub``; :func:`run` executes it."""
    p = sub.add_parser(
        "simulate",
        help="simulate a flight-test campaign on JSBSim and write it in the flight-data schema",
        description="Simulate a flight-test campaign (3211s, doublets and sum-of-sines "
        "maneuvers over a grid of altitudes and airspeeds) on a JSBSim aircraft and write "
        "one table in the flight-data schema (docs/flight-data-schema.md). Needs the 'sim' "
        "extra: pip install 'simplexspline[sim]'.",
    )
    p.add_argument("--aircraft", default="f16",
                   help=f"aircraft profile: {', '.join(available_aircraft())} (f16)")
    p.add_argument("--maneuvers", type=arguments.count, default=250,
                   help="number of maneuvers (250)")
    p.add_argument("--per-condition", type=arguments.count, default=None, metavar="N",
                   help="N maneuvers at every usable flight condition instead of --maneuvers")
    p.add_argument("--seed", type=arguments.seed, default=0, help="random seed (0)")
    p.add_argument("--altitudes", type=_floats, default=None, metavar="H1,H2,...",
                   help="altitudes of the condition grid [m] (the aircraft's default grid)")
    p.add_argument("--airspeeds", type=_floats, default=None, metavar="V1,V2,...",
                   help="true airspeeds of the condition grid [m/s] (the aircraft's default)")
    p.add_argument("--conditions", choices=("grid", "between"), default="grid",
                   help="'between': the midpoints of the aircraft's default grid, conditions "
                        "the project was not developed on (grid); --altitudes/--airspeeds win")
    p.add_argument("--protocol", choices=("paper", "alternative", "eigenmotion"),
                   default="paper",
                   help="'alternative': 3211s and sum-of-sines of another excitation design "
                        "(other pulse units and band, low-peak-factor multisines) flown by a "
                        "relaxed pilot; 'eigenmotion': a flight-test course's single pulses "
                        "and doublets with long free responses (phugoid, short period, "
                        "aperiodic roll, Dutch roll) (paper)")
    p.add_argument("--mix", type=_mix, default=None, metavar="FAMILY=W,...",
                   help="relative frequency of 3211, doublet, pulse and sum-of-sines "
                        "maneuvers (3211=0.45,doublet=0.2,sum-of-sines=0.35; alternative "
                        "protocol: 3211=0.5,sum-of-sines=0.5; eigenmotion: pulse=0.5,"
                        "doublet=0.5)")
    p.add_argument("--turn-fraction", type=arguments.share, default=0.5,
                   help="fraction of sum-of-sines maneuvers flown in a level turn instead of "
                        "straight and level (0.5)")
    p.add_argument("--noise-scale", type=arguments.non_negative_number, default=1.0,
                   help="factor on the default sensor noise (1.0)")
    p.add_argument("--bias-scale", type=arguments.non_negative_number, default=1.0,
                   help="factor on the default sensor biases (1.0)")
    p.add_argument("--ideal-sensors", action="store_true",
                   help="perfect sensors: measured channels equal the true ones")
    p.add_argument("--real-like", action="store_true",
                   help="sensor geometry of a real installation (vane boom, scale errors, IMU "
                        "lever arm, air-data lags: SensorModel.real_like) and, unless --wind "
                        "is given, a 3-12 m/s wind with light turbulence")
    p.add_argument("--wind", type=_floats, default=None, metavar="LOW,HIGH",
                   help="steady wind speed range [m/s], a new speed and direction per maneuver "
                        "(still air)")
    p.add_argument("--turbulence", choices=tuple(TURBULENCE_SEVERITY), default=None,
                   help="JSBSim MIL-F-8785C turbulence on top of the wind (none; light with "
                        "--real-like)")
    p.add_argument("--workers", type=arguments.count, default=None,
                   help="worker processes (number of CPUs)")
    p.add_argument("--format", choices=("table", "channels"), default="table",
                   help="'channels': a real-format record in the directory -o, one text file "
                        "per channel at 10 Hz in aviation units (deg, knots, ft, g, degC, lbs "
                        "of fuel used), no sideslip vane, an empty heading, GPS latitude and "
                        "longitude only, with maneuvers.csv, mapping.toml and truth.csv (table)")
    p.add_argument("-o", "--output", type=Path, required=True,
                   help="output file, .parquet (preferred) or .csv (+ .csv.json metadata); "
                        "a new directory with --format channels")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``simplexspline simulate`` with the parsed arguments; returns the exit code."""
    if args.format == "table" and args.output.suffix.lower() not in (".parquet", ".pq", ".csv"):
        raise InputError(f"output {str(args.output)!r} must end in .parquet or .csv")
    if not args.output.parent.is_dir():
        raise InputError(f"output directory {str(args.output.parent)!r} does not exist")
    if args.noise_scale < 0 or args.bias_scale < 0:
        raise InputError("--noise-scale and --bias-scale must be non-negative")
    if args.ideal_sensors and args.real_like:
        raise InputError("--ideal-sensors and --real-like contradict each other: choose one")
    sensors = (SensorModel.ideal() if args.ideal_sensors
               else (SensorModel.real_like() if args.real_like else SensorModel())
               .scaled(noise=args.noise_scale, bias=args.bias_scale))
    wind = None
    if args.wind is not None or args.turbulence is not None or args.real_like:
        speeds = args.wind if args.wind is not None else ((3.0, 12.0) if args.real_like
                                                          else (0.0, 0.0))
        if len(speeds) == 1:
            speeds = speeds * 2
        if len(speeds) != 2:
            raise InputError(f"--wind takes LOW,HIGH [m/s], got {args.wind!r}")
        turbulence = args.turbulence or ("light" if args.real_like else "none")
        wind = Wind(tuple(speeds), turbulence)
    grid = (ConditionGrid.between(args.aircraft) if args.conditions == "between"
            else ConditionGrid())
    grid = ConditionGrid(args.altitudes or grid.altitudes_m, args.airspeeds or grid.airspeeds_mps)
    protocol = {"turn_fraction": args.turn_fraction}
    if args.mix is not None:
        protocol["mix"] = args.mix
    protocol = {"paper": FlightProtocol, "alternative": FlightProtocol.alternative,
                "eigenmotion": FlightProtocol.eigenmotion}[args.protocol](**protocol)
    campaign = Campaign(args.aircraft, maneuvers=args.maneuvers,
                        maneuvers_per_condition=args.per_condition, seed=args.seed,
                        grid=grid, protocol=protocol, sensors=sensors, wind=wind)
    t0 = time.perf_counter()
    df = campaign.run(workers=args.workers,
                      progress=(not args.quiet) and sys.stderr.isatty())
    t1 = time.perf_counter()
    if args.format == "channels":
        write_channel_record(df, args.output)
    else:
        write_flight_data(df, args.output)
    t2 = time.perf_counter()
    if not args.quiet:
        s = df.attrs["summary"]
        print(f"{args.output}: {s['maneuvers_kept']} of {s['maneuvers_planned']} maneuvers kept "
              f"({s['complete']} complete, {s['cut']} cut at the envelope, {s['dropped']} "
              f"dropped, {s['trim-failed']} trim failures), {s['samples']:,} samples "
              f"({s['flight_time_s']:,.0f} s of flight); simulated in {t1 - t0:.1f} s, "
              f"written in {t2 - t1:.1f} s")
    return 0
