"""Benchmark: a 250-maneuver F-16 flight-test campaign (about 10,000 s of flight, ~1e6 samples).

    python benchmarks/bench_sim.py [--maneuvers 250] [--repeats 3] [--workers 2] [--write]

Prints one row per run (wall time, samples, flight time, speed-up over real time), the
median, and a floor measured in the same process: the bare cost of JSBSim's ``run()`` for the
same number of samples spread over the same number of workers (what a campaign would cost
with no pilot, actuators, sensors or bookkeeping). Then the campaign's envelope coverage.
The machine is shared and noisy: compare the ratio to the floor, not only the seconds.
"""

from __future__ import annotations

import argparse
import collections
import os
import resource
import statistics
import sys
import tempfile
import time

from simplexspline.aero.data.flight_data import write_flight_data
from simplexspline.sim import Campaign, envelope_coverage, get_aircraft
from simplexspline.sim.fdm import quiet_scratch, trim_fdm


def bare_run_cost(aircraft: str = "f16", steps: int = 20000) -> float:
    """Seconds per JSBSim ``run()`` of a trimmed aircraft (no Python work per step)."""
    with quiet_scratch():
        fdm = trim_fdm(get_aircraft(aircraft), 5000.0, 200.0)
        run = fdm.run
        t0 = time.perf_counter()
        for _ in range(steps):
            run()
        return (time.perf_counter() - t0) / steps


def _cpu() -> float:
    """CPU seconds of this process plus its finished child processes."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--aircraft", default="f16")
    parser.add_argument("--maneuvers", type=int, default=250)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--write", action="store_true", help="also time writing Parquet")
    args = parser.parse_args(argv)

    workers = args.workers or len(os.sched_getaffinity(0))
    print(f"{args.aircraft}: {args.maneuvers} maneuvers, seed {args.seed}, {workers} workers, "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    print(f"{'run':>4} {'wall s':>8} {'CPU s':>8} {'samples':>10} {'flight s':>9} "
          f"{'x real time':>12} {'floor s':>8} {'/floor':>7} {'write s':>8}")
    walls, cpus, df = [], [], None
    for i in range(args.repeats):
        floor_per_step = bare_run_cost(args.aircraft)
        cpu0 = _cpu()
        t0 = time.perf_counter()
        df = Campaign(args.aircraft, maneuvers=args.maneuvers, seed=args.seed).run(
            workers=workers, progress=False)
        wall = time.perf_counter() - t0
        cpu = _cpu() - cpu0
        walls.append(wall)
        cpus.append(cpu)
        write = float("nan")
        if args.write:
            with tempfile.TemporaryDirectory() as tmp:
                t1 = time.perf_counter()
                write_flight_data(df, os.path.join(tmp, "campaign.parquet"))
                write = time.perf_counter() - t1
        n = len(df)
        floor = n * floor_per_step / workers
        print(f"{i + 1:>4} {wall:>8.1f} {cpu:>8.1f} {n:>10,} {n * 0.01:>9,.0f} "
              f"{n * 0.01 / wall:>12.0f} {floor:>8.1f} {wall / floor:>7.1f} {write:>8.1f}")
    med = statistics.median(walls)
    print(f"median CPU time {statistics.median(cpus):.1f} s (this process and its workers): "
          f"about {statistics.median(cpus) / workers:.1f} s of wall time on {workers} idle "
          f"cores")
    print(f"median wall time {med:.1f} s for {len(df):,} samples "
          f"({len(df) * 0.01 / med:,.0f}x real time); peak RSS of this process "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:,.0f} MB")
    s = df.attrs["summary"]
    print(f"maneuvers: {s['maneuvers_kept']} kept of {s['maneuvers_planned']} "
          f"({s['complete']} complete, {s['cut']} cut, {s['dropped']} dropped, "
          f"{s['trim-failed']} trim failures); conditions used "
          f"{sum(c['trimmed'] for c in df.attrs['conditions'])} of "
          f"{len(df.attrs['conditions'])}")
    reasons = collections.Counter(
        lg["reason"].split(" ")[0] + (" " + lg["reason"].split(" ")[1]
                                      if lg["reason"].startswith("load") else "")
        for lg in df.attrs["maneuvers"] if lg["status"] != "complete")
    if reasons:
        print("cut/dropped by limit: " + ", ".join(f"{k} {v}" for k, v in reasons.items()))
    print("envelope coverage (true values):")
    print(envelope_coverage(df).round(2).to_string())
    return 0


if __name__ == "__main__":
    sys.exit(main())
