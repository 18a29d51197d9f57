"""`simplexspline reconstruct`: flight path reconstruction (IEKF + RTS) and coefficients."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from simplexspline.cli import arguments
from simplexspline.aero.data.flight_data import read_flight_data, write_flight_data
from simplexspline.aero.reconstruction.reconstruct import ReconstructionSettings, reconstruct
from simplexspline.errors import InputError


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the command's parser to ``sub``; :func:`run` executes it."""
    p = sub.add_parser(
        "reconstruct",
        help="reconstruct states and sensor biases (IEKF) and compute the aerodynamic "
             "coefficients (Eq. 43-48)",
        description="Flight path reconstruction of measured flight data (docs/"
        "reconstruction.md): an iterated extended Kalman filter with RTS smoother per "
        "maneuver estimates IMU biases and air-data errors from GPS, air-data and attitude "
        "measurements; the output has reconstructed alpha, beta, V, attitudes, "
        "bias-corrected specific forces and rates, and the coefficients CX..Cn and "
        "non-dimensional rates. Prints the biases found, innovation statistics and the "
        "maneuvers rejected with the reason.",
    )
    p.add_argument("input", type=Path, help="flight data, .parquet or .csv (+ .csv.json)")
    p.add_argument("-o", "--output", type=Path, required=True,
                   help="output file, .parquet (preferred) or .csv")
    p.add_argument("--workers", type=arguments.count, default=None,
                   help="worker processes (number of CPUs)")
    p.add_argument("--accelerations", choices=("auto", "measured", "differentiate"),
                   default="auto", help="source of pdot, qdot, rdot (auto: the columns if "
                   "present, else smoothed differentiation of the reconstructed rates)")
    p.add_argument("--no-smoother", action="store_true",
                   help="use the forward filter only (no RTS backward pass)")
    p.add_argument("--no-control-smoothing", action="store_true",
                   help="keep the control-surface positions as measured (default: smoothed "
                        "per maneuver where their sensor noise is found, docs/reconstruction.md)")
    p.add_argument("--latitude", type=float, default=None,
                   help="geodetic latitude of the flights [deg] (default: the data's "
                        "metadata latitude_deg, else 45, said in the summary)")
    p.add_argument("--min-duration", type=arguments.positive, default=2.0,
                   help="reject maneuvers shorter than this [s] (2.0)")
    p.add_argument("--gusts", type=_gusts, default="auto",
                   help="turbulence: 'auto' (default: gusts estimated where the still-air "
                   "model's air-data innovations show them, their intensity chosen by the "
                   "likelihood), 0 (still air), or a gust standard deviation [m/s]")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    return p


def _gusts(text: str) -> str | float:
    """'auto' or a gust standard deviation >= 0 [m/s]."""
    return "auto" if text == "auto" else arguments.non_negative_number(text)


def run(args: argparse.Namespace) -> int:
    """Run ``simplexspline reconstruct`` with the parsed arguments; returns the exit code."""
    if args.output.suffix.lower() not in (".parquet", ".pq", ".csv"):
        raise InputError(f"output {str(args.output)!r} must end in .parquet or .csv")
    if not args.output.parent.is_dir():
        raise InputError(f"output directory {str(args.output.parent)!r} does not exist")
    if args.output.resolve() == args.input.resolve():
        raise InputError("the output must not overwrite the input file; choose another -o")
    settings = ReconstructionSettings(accelerations=args.accelerations,
                                      smoother=not args.no_smoother,
                                      smooth_controls=not args.no_control_smoothing,
                                      latitude_deg=args.latitude,
                                      min_duration_s=args.min_duration,
                                      gust_std=args.gusts)
    t0 = time.perf_counter()
    df, meta = read_flight_data(args.input, nan="ignore")
    flight = float(df.groupby("maneuver")["t"].agg(lambda t: t.max() - t.min()).sum())
    rec = reconstruct(df, meta, settings=settings, workers=args.workers,
                      progress=(not args.quiet) and sys.stderr.isatty())
    write_flight_data(rec.data, args.output)
    elapsed = time.perf_counter() - t0
    if not args.quiet:
        print(rec.summary())
        print(f"{args.output}: {len(rec.data):,} samples written; {flight:,.0f} s of flight "
              f"in {elapsed:.1f} s ({flight / max(elapsed, 1e-9):.0f}x real time)")
    return 0
