"""Fitting and evaluation benchmarks of the spline core (issue 3).

Prints a table of medians over repeated runs on this machine, and ratios to floors measured
in the same run. Usage::

    python benchmarks/bench_fit.py              # all benchmarks
    python benchmarks/bench_fit.py --only 1 4   # a subset
    python benchmarks/bench_fit.py --quick      # smaller sizes, for a smoke test

Benchmarks
----------
1. The paper's configuration: n = 5, d = 3, r = 1, about 37 simplices (a Kuhn triangulation of
   one 5-cube fitted to correlated, flight-data-like samples: the simplices with the fewest
   points are dropped until 37 remain, like the paper's cubes fitted inside the data hull),
   200,000 points. Fit time (normal equations + constrained solve), the space set-up time
   (continuity conditions, C^0 elimination), and the ratio of the fit time to the bare
   per-simplex Gram products X_j'X_j on the same data (the floor).
2. 10,000,000 points, n = 5, d = 3, r = 1, 960 simplices: fit time and peak resident memory
   (measured in a child process).
3. n = 3, d = 4, r = 1, 5,400 simplices, 2,000,000 points: fit time.
4. predict throughput (n = 5, d = 3, benchmark 1's spline) and single-point latency.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time

import numpy as np

from simplexspline import SplineSpace, Triangulation
from simplexspline.spline.bform import basis_values_t


def median_time(fn, repeats: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def flight_like(n: int, npts: int, rng: np.random.Generator) -> np.ndarray:
    """Correlated samples in [0, 1]^n, denser in the middle (like flight data)."""
    cov = 0.5 * np.eye(n) + 0.5 * np.ones((n, n)) * 0.6
    z = rng.multivariate_normal(np.zeros(n), cov, size=npts)
    return 1.0 / (1.0 + np.exp(-z))  # squash into (0, 1)


def target(x: np.ndarray) -> np.ndarray:
    return np.sin(2.0 * x[:, 0]) * np.exp(-x[:, 1]) + x[:, 2:].sum(axis=1) ** 2 * 0.1


def paper_case(npts: int, rng: np.random.Generator, nsimplex: int = 37):
    """Triangulation of benchmark 1 and npts points inside it."""
    n = 5
    pool = flight_like(n, 4 * npts, rng)
    full = Triangulation.fit(pool, 1)
    counts = np.bincount(full.locate(pool), minlength=full.nsimplex)
    threshold = np.sort(counts)[::-1][nsimplex - 1]
    tri = Triangulation.fit(pool, 1, min_points=int(threshold))
    inside = pool[tri.locate(pool) >= 0]
    x = inside[rng.choice(len(inside), npts, replace=len(inside) < npts)]
    return tri, x


def gram_floor(space: SplineSpace, x: np.ndarray, repeats: int) -> float:
    """Time of the bare per-simplex products X_j'X_j with X_j already formed and sorted."""
    tri = space.triangulation
    sid = tri.locate(x)
    order = np.argsort(sid, kind="stable")
    bt = basis_values_t(tri.barycentric(x[order], sid[order]).T, space.degree)
    counts = np.bincount(sid, minlength=tri.nsimplex)
    ends = np.cumsum(counts)
    blocks = [np.ascontiguousarray(bt[:, e - c:e]) for c, e in zip(counts, ends) if c]

    def products():
        return [b @ b.T for b in blocks]

    return median_time(products, repeats)[0]


def bench_paper(rows: list, repeats: int, quick: bool) -> object:
    rng = np.random.default_rng(1)
    npts = 20_000 if quick else 200_000
    tri, x = paper_case(npts, rng)
    y = target(x) + 0.01 * rng.standard_normal(len(x))
    t_setup, space = median_time(lambda: _space_setup(tri, 3, 1), repeats)
    t_fit, spline = median_time(lambda: space.fit(x, y), repeats)
    t_ne, _ = median_time(lambda: space.normal_equations(x, y), repeats)
    floor = gram_floor(space, x, repeats)
    rows.append(("1 paper: n=5 d=3 r=1", f"J={tri.nsimplex}, N={len(x):,}",
                 f"fit {t_fit:.3f} s (normal eq. {t_ne:.3f} s, solve {t_fit - t_ne:.3f} s); "
                 f"space set-up {t_setup:.3f} s",
                 f"fit/floor = {t_fit / floor:.2f} (floor {floor * 1e3:.1f} ms)",
                 "fit <= 0.1 s, ratio <= 3"))
    return spline, x


def _space_setup(tri, d, r):
    space = SplineSpace(tri, d, r)
    space.system  # noqa: B018 (build and cache the conditions)
    return space


def bench_large_n(rows: list, quick: bool) -> None:
    """Benchmark 2 in a child process, to measure its peak memory alone."""
    npts = 1_000_000 if quick else 10_000_000
    out = subprocess.run([sys.executable, __file__, "--child-large", str(npts)],
                         capture_output=True, text=True, check=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    rows.append(("2 large N: n=5 d=3 r=1", f"J={res['nsimplex']}, N={npts:,}",
                 f"fit {res['fit']:.2f} s (data generation {res['gen']:.2f} s not counted)",
                 f"peak RSS {res['rss_mb']:.0f} MB (data alone {res['data_mb']:.0f} MB)",
                 "fit <= 15 s, RSS <= 2 GB"))


def _child_large(npts: int) -> None:
    rng = np.random.default_rng(2)
    t0 = time.perf_counter()
    x = rng.random((npts, 5))
    y = target(x) + 0.01 * rng.standard_normal(npts)
    t1 = time.perf_counter()
    tri = Triangulation.grid(np.zeros(5), np.ones(5), (2, 2, 2, 1, 1))
    space = SplineSpace(tri, 3, 1)
    space.fit(x, y)
    t2 = time.perf_counter()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(json.dumps({"nsimplex": tri.nsimplex, "fit": t2 - t1, "gen": t1 - t0, "rss_mb": rss,
                      "data_mb": (x.nbytes + y.nbytes) / 2**20}))


def bench_large_tri(rows: list, repeats: int, quick: bool) -> None:
    rng = np.random.default_rng(3)
    shape = (5, 5, 4) if quick else (10, 10, 9)
    npts = 200_000 if quick else 2_000_000
    tri = Triangulation.grid(np.zeros(3), np.ones(3), shape)
    x = rng.random((npts, 3))
    y = np.sin(3 * x[:, 0]) * np.cos(2 * x[:, 1]) + x[:, 2] ** 3 + 0.01 * rng.standard_normal(npts)
    t_setup, space = median_time(lambda: _space_setup(tri, 4, 1), 1)
    t_fit, _ = median_time(lambda: space.fit(x, y), max(1, repeats // 2))
    rows.append(("3 large T: n=3 d=4 r=1", f"J={tri.nsimplex:,}, N={npts:,}",
                 f"fit {t_fit:.2f} s; space set-up {t_setup:.2f} s",
                 f"{space.dim_coefficients:,} coefficients", "fit <= 20 s"))


def bench_predict(rows: list, spline, x: np.ndarray, repeats: int, quick: bool) -> None:
    rng = np.random.default_rng(4)
    npts = 100_000 if quick else 1_000_000
    xe = x[rng.integers(0, len(x), npts)]
    t_batch, _ = median_time(lambda: spline.predict(xe), repeats)
    one = xe[:1]
    spline.predict(one)
    lat = []
    for i in range(200 if quick else 2000):
        t0 = time.perf_counter()
        spline.predict(xe[i:i + 1])
        lat.append(time.perf_counter() - t0)
    t_one = statistics.median(lat)
    t_grad, _ = median_time(lambda: spline.gradient(xe), repeats)
    rows.append(("4 predict: n=5 d=3", f"J={spline.triangulation.nsimplex}, N={npts:,}",
                 f"{npts / t_batch / 1e6:.2f} M points/s; gradient {npts / t_grad / 1e6:.2f} "
                 "M points/s",
                 f"single point {t_one * 1e6:.0f} us", ">= 5 M/s, <= 50 us"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", type=int, nargs="*", default=None)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--child-large", type=int, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child_large is not None:
        _child_large(args.child_large)
        return 0
    only = set(args.only or [1, 2, 3, 4])
    rows: list = []
    spline = x = None
    if only & {1, 4}:
        spline, x = bench_paper(rows, args.repeats, args.quick)
    if 2 in only:
        bench_large_n(rows, args.quick)
    if 3 in only:
        bench_large_tri(rows, args.repeats, args.quick)
    if 4 in only:
        bench_predict(rows, spline, x, args.repeats, args.quick)
    if 1 not in only:
        rows = [r for r in rows if not r[0].startswith("1 ")]
    print(f"simplexspline fit benchmarks ({os.cpu_count()} cores; medians of "
          f"{args.repeats} runs)")
    print("| benchmark | size | time | ratio / memory | target |")
    print("|---|---|---|---|---|")
    for r in rows:
        print("| " + " | ".join(r) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
