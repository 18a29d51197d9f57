"""The compiled filter (numba) against the Python path it replaces, in one run.

Reconstructs a campaign (default: the 12-maneuver F-16 campaign, seed 0) with one worker,
alternately with the compiled kernels and with the Python reference path
(``filter_kernels.HAVE_NUMBA`` off, as ``SIMPLEXSPLINE_NO_NUMBA=1``), and prints per path the
median wall and CPU time of ``reconstruct``, the time inside the forward passes
(``run_filter``) and the smoother (``rts_smooth``) with their cost per filter step, and the
factors; then the largest difference between the two results (biases in units of their
sigma, coefficients relative to their range).

Usage::

    python benchmarks/bench_filter.py                    # 12 maneuvers, 3 runs per path
    python benchmarks/bench_filter.py --maneuvers 4 --repeats 1
    python benchmarks/bench_filter.py --input campaign.parquet
"""

from __future__ import annotations

import argparse
import importlib
import os
import time

import numpy as np

from simplexspline.aero import reconstruct
from simplexspline.aero.data.flight_data import read_flight_data
from simplexspline.aero.reconstruction import filter_kernels
from simplexspline.sim import Campaign

#: The per-maneuver driver module (the package exports a function of the same name).
driver = importlib.import_module("simplexspline.aero.reconstruction.reconstruct")

COEF = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")


class _Timed:
    """Wraps a function of the driver module, summing its wall time and counting calls."""

    def __init__(self, name: str):
        self.name, self.inner = name, getattr(driver, name)
        self.seconds, self.calls, self.steps = 0.0, 0, 0

    def __call__(self, *args, **kwargs):
        t = time.perf_counter()
        out = self.inner(*args, **kwargs)
        self.seconds += time.perf_counter() - t
        self.calls += 1
        self.steps += len(args[1]) if self.name == "run_filter" else len(args[0]["x_filt"])
        return out


def _run(df, compiled: bool) -> dict:
    filter_kernels.HAVE_NUMBA = compiled
    timers = {name: _Timed(name) for name in ("run_filter", "rts_smooth")}
    for name, timer in timers.items():
        setattr(driver, name, timer)
    try:
        t, c = time.perf_counter(), time.process_time()
        rec = reconstruct(df, workers=1)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
    finally:
        for name, timer in timers.items():
            setattr(driver, name, timer.inner)
    return {"rec": rec, "wall": wall, "cpu": cpu, "load": os.getloadavg()[0],
            **{name: (tm.seconds, tm.steps) for name, tm in timers.items()}}


def _differences(a, b) -> tuple[float, float]:
    """Largest bias difference / sigma and coefficient difference / range."""
    bias = 0.0
    for m, ra in a.maneuvers.items():
        for ch, (value, _) in ra["biases"].items():
            ref, sigma = b.maneuvers[m]["biases"][ch]
            bias = max(bias, abs(value - ref) / max(sigma, 1e-300))
    coef = 0.0
    for c in COEF:
        x, y = a.data[c].to_numpy(), b.data[c].to_numpy()
        ok = np.isfinite(y)
        coef = max(coef, float(np.max(np.abs(x[ok] - y[ok])) / np.ptp(y[ok])))
    return bias, coef


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maneuvers", type=int, default=12)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--input", help="a flight-data file instead of the simulation")
    args = ap.parse_args()
    if not filter_kernels.HAVE_NUMBA:
        raise SystemExit("numba is not installed (or SIMPLEXSPLINE_NO_NUMBA is set)")
    if args.input:
        df, _ = read_flight_data(args.input, nan="ignore")
    else:
        df = Campaign("f16", maneuvers=args.maneuvers, seed=args.seed).run(workers=1,
                                                                           progress=False)
    print(f"{df['maneuver'].nunique()} maneuvers, {len(df):,} samples; "
          f"{args.repeats} run(s) per path, alternating")
    _run(df, True)                         # numba's cache loaded, imports done
    runs: dict = {True: [], False: []}
    for _ in range(args.repeats):
        for compiled in (True, False):
            runs[compiled].append(_run(df, compiled))
    filter_kernels.HAVE_NUMBA = True
    med = {k: {q: float(np.median([r[q] if q in ("wall", "cpu", "load") else r[q][0]
                                   for r in v]))
               for q in ("wall", "cpu", "load", "run_filter", "rts_smooth")}
           for k, v in runs.items()}
    steps = {q: runs[True][0][q][1] for q in ("run_filter", "rts_smooth")}
    print(f"\n| path | reconstruct wall (s) | CPU (s) | run_filter (s) | us per step "
          f"| rts_smooth (s) | us per step | load |\n|---|---|---|---|---|---|---|---|")
    for k, label in ((False, "Python"), (True, "numba")):
        m = med[k]
        print(f"| {label} | {m['wall']:.2f} | {m['cpu']:.2f} | {m['run_filter']:.2f} | "
              f"{m['run_filter'] / steps['run_filter'] * 1e6:.1f} | {m['rts_smooth']:.2f} | "
              f"{m['rts_smooth'] / steps['rts_smooth'] * 1e6:.1f} | {m['load']:.2f} |")
    f = {q: med[False][q] / med[True][q] for q in ("wall", "cpu", "run_filter", "rts_smooth")}
    print(f"| factor | {f['wall']:.1f}x | {f['cpu']:.1f}x | {f['run_filter']:.1f}x | | "
          f"{f['rts_smooth']:.1f}x | | |")
    print(f"\nfilter steps {steps['run_filter']:,}, smoothed samples {steps['rts_smooth']:,}")
    bias, coef = _differences(runs[True][-1]["rec"], runs[False][-1]["rec"])
    print(f"largest difference: biases {bias:.2g} sigma, coefficients {coef:.2g} of their "
          "range")


if __name__ == "__main__":
    main()
