"""How the spline fit scales, on Kuhn grids and on Delaunay triangulations (issue 17).

Four sweeps, each on both triangulation kinds:

* N, the number of data points (n = 3, d = 3, r = 1, about 150 simplices);
* J, the number of simplices (n = 2, d = 3, r = 1, 200,000 points or 40 per simplex);
* n, the dimension (d = 2, r = 1, about 100-720 simplices, 200,000 points);
* d, the degree (n = 2, r = 1, about 200 simplices, 200,000 points).

Every point records where the fit's time goes: point location (``Triangulation.locate``),
basis (barycentric coordinates and B-form basis values of all points, as the fused
accumulation forms them: timed as the compiled evaluation with zero coefficients), accumulation (the
rest of the normal equations: sorting and the per-simplex products) and the constrained
solve. r = 1 (r = 0 for d = 1). Run with ``SIMPLEXSPLINE_THREADS=1`` for one-thread
figures. Writes a table with the log-log slope of the fit time along each sweep (least
squares over the sweep's points) and a log-log plot (matplotlib, Agg). Usage::

    python benchmarks/bench_scaling.py --quick            # smaller sweeps, about a minute
    python benchmarks/bench_scaling.py --out-dir docs     # the full sweeps (N to 1e7,
                                                          # J to 1e5: tens of minutes)
    python benchmarks/bench_scaling.py --max-points 1000000 --max-simplices 10000
                                                          # the full sweeps without their
                                                          # largest points
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from simplexspline import SplineSpace, Triangulation
from simplexspline._files import atomic_write, write_text
from simplexspline.spline import kernels

PARTS = ("locate", "basis", "accumulate", "solve")


def _median(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _in_simplices(tri, npts: int, rng) -> np.ndarray:
    vol = tri.volumes()
    j = rng.choice(tri.nsimplex, npts, p=vol / vol.sum())
    b = rng.dirichlet(np.ones(tri.ndim + 1), npts)
    return np.einsum("ik,ikn->in", b, np.asarray(tri.corners)[j])


def make_triangulation(kind: str, n: int, nsimplex: int, rng) -> Triangulation:
    """A grid or Delaunay triangulation of the unit cube with about ``nsimplex`` simplices."""
    if kind == "grid":
        cells = max(1.0, nsimplex / math.factorial(n))
        side = max(1, round(cells ** (1.0 / n)))
        return Triangulation.grid(np.zeros(n), np.ones(n), (side,) * n)
    # random Delaunay triangulations have a roughly fixed number of simplices per vertex
    nverts = n + 2
    for _ in range(12):
        tri = Triangulation.delaunay(rng.random((nverts, n)))
        if tri.nsimplex >= 0.8 * nsimplex:
            return tri
        nverts = max(nverts + 1, int(nverts * min(4.0, 1.05 * nsimplex / tri.nsimplex)))
    return tri


def measure(kind: str, n: int, nsimplex: int, d: int, npts: int, repeats: int) -> dict:
    """Time the parts of one fit (seconds, medians)."""
    tri = make_triangulation(kind, n, nsimplex, np.random.default_rng([n, nsimplex]))
    rng = np.random.default_rng([n, nsimplex, d, npts])
    x = _in_simplices(tri, npts, rng)
    y = np.sin(2.0 * x[:, 0]) * np.exp(-x[:, -1]) + 0.01 * rng.standard_normal(npts)
    space = SplineSpace(tri, d, min(1, d - 1))
    space.system  # noqa: B018 (set-up: cached per space, not part of a fit)
    tri.locate(x[:10])
    t_loc = _median(lambda: tri.locate(x), repeats)
    sid = tri.locate(x)
    # the basis as the fused accumulation forms it (barycentric coordinates and monomials
    # in cache-sized blocks, never stored): the compiled evaluation with zero coefficients
    zero = np.zeros((tri.nsimplex, space.nbasis))
    t_basis = _median(lambda: kernels.evaluate(x, sid, tri._origin, tri._tinv, zero, d),
                      repeats)
    ne = space.normal_equations(x, y)
    t_ne = _median(lambda: space.normal_equations(x, y), repeats)
    space.solve(ne, on_insufficient="minnorm")
    t_solve = _median(lambda: space.solve(ne, on_insufficient="minnorm"), repeats)
    # the fused accumulation forms the basis inside its pass: basis is its share, the rest
    # of the normal equations (sorting, products) is the accumulation
    t_acc = max(t_ne - t_loc - t_basis, 0.0)
    return {"kind": kind, "n": n, "J": tri.nsimplex, "d": d, "N": npts,
            "locate": t_loc, "basis": t_basis, "accumulate": t_acc, "solve": t_solve,
            "fit": t_ne + t_solve}


def sweeps(quick: bool) -> dict:
    """Sweep name -> (swept key, list of (n, J, d, N))."""
    if quick:
        return {
            "N": ("N", [(3, 150, 3, N) for N in (10_000, 100_000, 1_000_000)]),
            "J": ("J", [(2, J, 3, 100_000) for J in (10, 100, 1_000)]),
            "n": ("n", [(n, 120, 2, 100_000) for n in (2, 3, 4, 5)]),
            "d": ("d", [(2, 200, d, 100_000) for d in (1, 2, 3, 4, 5)]),
        }
    return {
        "N": ("N", [(3, 150, 3, N) for N in (10_000, 100_000, 1_000_000, 10_000_000)]),
        "J": ("J", [(2, J, 3, max(200_000, 40 * J))
                    for J in (10, 100, 1_000, 10_000, 100_000)]),
        "n": ("n", [(n, 720 if n == 6 else 120, 2, 200_000) for n in (2, 3, 4, 5, 6)]),
        "d": ("d", [(2, 200, d, 200_000) for d in (1, 2, 3, 4, 5)]),
    }


def slope(xs, ys) -> float:
    """Least-squares slope of log(y) against log(x)."""
    lx, ly = np.log(np.asarray(xs, float)), np.log(np.asarray(ys, float))
    return float(np.polyfit(lx, ly, 1)[0]) if len(lx) > 1 else float("nan")


def table(results: dict) -> str:
    lines = ["| sweep | kind | values | fit time (s) | slope | largest point: locate / basis / "
             "accumulate / solve (s) |", "|---|---|---|---|---|---|"]
    for name, per_kind in results.items():
        for kind, rows in per_kind.items():
            key = rows[0]["key"]
            xs = [r[key] for r in rows]
            fits = [r["fit"] for r in rows]
            last = rows[-1]
            parts = " / ".join(f"{last[p]:.3g}" if last[p] > 0 else "~0" for p in PARTS)
            lines.append(f"| {name} | {kind} | {', '.join(f'{v:,}' for v in xs)} | "
                         f"{', '.join(f'{t:.3g}' for t in fits)} | {slope(xs, fits):.2f} | "
                         f"{parts} |")
    return "\n".join(lines)


def plot(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = ("grid", "delaunay")
    fig, axes = plt.subplots(len(kinds), len(results), figsize=(4 * len(results), 7),
                             squeeze=False)
    styles = {"fit": ("k", "-"), "locate": ("C0", "--"), "basis": ("C1", "--"),
              "accumulate": ("C2", "--"), "solve": ("C3", "--")}
    for col, (name, per_kind) in enumerate(results.items()):
        for row, kind in enumerate(kinds):
            ax = axes[row][col]
            rows = per_kind.get(kind, [])
            if not rows:
                continue
            key = rows[0]["key"]
            xs = [r[key] for r in rows]
            for part, (colour, ls) in styles.items():
                # accumulate is a difference of medians: at or below zero it is within
                # the timers' noise and is left out of the log plot (not drawn at 1e-6)
                ys = [r[part] if r[part] > 0 else np.nan for r in rows]
                label = (f"fit (slope {slope(xs, ys):.2f})" if part == "fit" else part)
                ax.loglog(xs, ys, color=colour, linestyle=ls, marker="o", ms=3, label=label)
            ax.set_title(f"{kind}: sweep over {name}", fontsize=9)
            ax.set_xlabel(name)
            ax.set_ylabel("time (s)")
            ax.legend(fontsize=7)
            ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=90, format="png"))
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller sweeps (about a minute)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--max-points", type=int, default=None,
                    help="leave out sweep points with more data points than this")
    ap.add_argument("--max-simplices", type=int, default=None,
                    help="leave out sweep points with more simplices than this")
    ap.add_argument("--out-dir", type=Path, default=Path("."),
                    help="where scaling.png and scaling.md are written")
    args = ap.parse_args(argv)
    results: dict = {}
    for name, (key, points) in sweeps(args.quick).items():
        results[name] = {}
        for kind in ("grid", "delaunay"):
            rows = []
            for n, J, d, N in points:
                if (args.max_points and N > args.max_points) or (
                        args.max_simplices and J > args.max_simplices):
                    continue
                r = measure(kind, n, J, d, N, 1 if N >= 1_000_000 else args.repeats)
                r["key"] = key
                rows.append(r)
                print(f"{name:>2} {kind:>8}: n={n} J={r['J']:,} d={d} N={N:,}: fit "
                      f"{r['fit']:.3g} s (" + ", ".join(f"{p} {r[p]:.3g}" for p in PARTS)
                      + ")", file=sys.stderr, flush=True)
            results[name][kind] = rows
    args.out_dir.mkdir(parents=True, exist_ok=True)
    text = table(results)
    write_text(args.out_dir / "scaling.md", text + "\n")
    plot(results, args.out_dir / "scaling.png")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
