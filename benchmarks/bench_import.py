"""Benchmark: import of a whole-flight record (one text file per channel, 10 Hz).

    python benchmarks/bench_import.py [--tiles 36] [--repeats 4]

The real-format test record (tests/data/citation_like, 131 s, 20 channel files) is tiled
``--tiles`` times into one continuous record (36 tiles: 78.8 minutes, 47,304 samples, the
length of the flight in issue 16; the fuel used keeps growing, the ground segments repeat) and
imported with excitation detection. Prints the wall time of each ``import_record`` call, the
median, and a floor measured in the same process: reading the same files with
``numpy.loadtxt`` and nothing else.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from simplexspline.aero.data.record_import import import_record
from simplexspline.aero.data.units import registry

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "citation_like"


def tiled_record(directory: Path, tiles: int) -> Path:
    """Write the test record tiled ``tiles`` times into ``directory``; returns the mapping."""
    for f in DATA.glob("*.txt"):
        if f.stem == "heading":
            (directory / f.name).write_text("")
            continue
        if f.stem == "delta_e":
            np.savetxt(directory / f.name, np.tile(np.loadtxt(f), tiles), fmt="%.8g")
            continue
        a = np.loadtxt(f, skiprows=1)
        t = a[0, 0] + np.arange(len(a) * tiles) * 0.1
        v = np.tile(a[:, 1], tiles)
        if f.stem == "fuel_used":
            v = 0.35 * (t - t[0])
        np.savetxt(directory / f.name, np.column_stack([t, v]), fmt=["%.2f", "%.8g"],
                   header=f"time {f.stem}", comments="")
    text = (DATA / "mapping.toml").read_text().replace('method = "list"',
                                                       'method = "excitation"')
    mapping = directory / "mapping.toml"
    mapping.write_text(text.replace('list = "maneuvers.csv"', ""))
    return mapping


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tiles", type=int, default=36)
    ap.add_argument("--repeats", type=int, default=4)
    args = ap.parse_args()
    registry()  # the pint registry is built once per process; not part of an import
    with tempfile.TemporaryDirectory() as tmp:
        mapping = tiled_record(Path(tmp), args.tiles)
        times = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            result = import_record(mapping)
            times.append(time.perf_counter() - t0)
            print(f"import_record: {times[-1]:.2f} s")
        t0 = time.perf_counter()
        for f in Path(tmp).glob("*.txt"):
            if f.stat().st_size:
                np.loadtxt(f, skiprows=0 if f.stem == "delta_e" else 1)
        floor = time.perf_counter() - t0
    med = statistics.median(times)
    print(f"record: {result.record_duration_s / 60:.1f} min, "
          f"{int(round(result.record_duration_s * result.rate_hz)) + 1:,} samples, "
          f"{len(result.segments())} maneuvers found")
    print(f"median {med:.2f} s; floor (numpy.loadtxt of the files) {floor:.2f} s; "
          f"ratio {med / floor:.2f}")


if __name__ == "__main__":
    main()
