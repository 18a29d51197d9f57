"""Thin-edge demonstration: GCV-regularised fitting stops the divergence of a simplex spline
at a thinly sampled edge of the data (the failure of the paper's CX model).

    python benchmarks/bench_edge.py                      # 2-D, 5 seeds
    python benchmarks/bench_edge.py --dim 3              # 3-D
    python benchmarks/bench_edge.py --png edge.png       # also a figure (coverage map, cut)
    python benchmarks/bench_edge.py --cost [--large]     # cost of the GCV search

A smooth function with curvature, dense noisy data (sigma = 0.05) where x0 < 0.75 (2-D:
3,000 points; 3-D: 20,000) and a few noisy points where x0 > 0.75 (2-D: 20; 3-D: 60); an
S^1_3 spline on a Kuhn grid (2-D: 6 x 6 cells, 72 triangles; 3-D: 3 x 3 x 3 cells, 162
tetrahedra). Fits: unregularised (minimum-norm where data and continuity leave directions
undetermined) and with a penalty whose weight GCV chooses. Printed: validation RMS against
the true function on 20,000 uniform points, in the thin region (x0 > 0.75), the dense
region and overall; the chosen relative weight, the effective degrees of freedom and the
fitting time.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from simplexspline import SplineSpace, Triangulation
from simplexspline.spline.uncertainty.coverage import coverage

EDGE = 0.75


def truth(x: np.ndarray) -> np.ndarray:
    out = np.sin(3 * x[:, 0] + 1) * np.cos(2.5 * x[:, 1]) + 0.5 * x[:, 0] ** 2
    if x.shape[1] > 2:
        out = out + 0.3 * np.sin(3 * x[:, 2]) * x[:, 1]
    return out


def problem(dim: int, seed: int, nthin: int | None):
    rng = np.random.default_rng(seed)
    ndense, nthin = (3000, nthin or 20) if dim == 2 else (20000, nthin or 60)
    scale = np.r_[EDGE, np.ones(dim - 1)]
    xd = rng.uniform(0, 1, (ndense, dim)) * scale
    xt = rng.uniform(0, 1, (nthin, dim)) * np.r_[1 - EDGE, np.ones(dim - 1)]
    xt[:, 0] += EDGE
    x = np.vstack([xd, xt])
    y = truth(x) + 0.05 * rng.standard_normal(len(x))
    xv = rng.uniform(0, 1, (20000, dim))
    return x, y, xv


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--nthin", type=int, default=None, help="points in the thin region")
    ap.add_argument("--penalties", default="energy,membrane,ridge")
    ap.add_argument("--png", default=None, help="write a figure (seed 0) to this path")
    ap.add_argument("--cost", action="store_true",
                    help="instead: time the GCV search, exact vs Hutchinson")
    ap.add_argument("--large", action="store_true",
                    help="with --cost: add a 15,625-coefficient case (minutes)")
    args = ap.parse_args(argv)
    if args.cost:
        return cost(args.large)
    dim = args.dim
    shape = (6, 6) if dim == 2 else (3, 3, 3)
    tri = Triangulation.grid([0] * dim, [1] * dim, shape)
    space = SplineSpace(tri, 3, 1)
    kinds = [k for k in args.penalties.split(",") if k]
    print(f"{dim}-D thin edge, S^1_3 on {tri.nsimplex} simplices, "
          f"{space.system.nglobal} C^0-reduced coefficients; validation RMS vs truth")
    head = (f"{'seed':>4} {'fit':<14} {'thin RMS':>9} {'dense RMS':>9} {'all RMS':>9} "
            f"{'smoothing':>9} {'edf':>7} {'time s':>7}")
    print(head)
    print("-" * len(head))
    rows: dict = {}
    fig_data = None
    for seed in range(args.seeds):
        x, y, xv = problem(dim, seed, args.nthin)
        fv = truth(xv)
        thin = xv[:, 0] > EDGE
        ne = space.normal_equations(x, y)
        fits = [("none", {})] + [(k, {"smoothing": "gcv", "penalty": k}) for k in kinds]
        for name, kw in fits:
            t = time.perf_counter()
            s = space.solve(ne, on_insufficient="minnorm", **kw)
            dt = time.perf_counter() - t
            e = s.predict(xv) - fv
            r = [float(np.sqrt(np.mean(e[m] ** 2))) for m in (thin, ~thin, slice(None))]
            reg = getattr(s.info, "regularization", None)
            sm = f"{reg.smoothing:9.3g}" if reg else f"{'-':>9}"
            edf = (f"{reg.edf:7.1f}" if reg else
                   f"{space.dimension - s.info.n_undetermined:7d}")
            label = "unregularised" if name == "none" else f"gcv {name}"
            print(f"{seed:>4} {label:<14} {r[0]:9.4f} {r[1]:9.4f} {r[2]:9.4f} {sm} {edf} "
                  f"{dt:7.2f}")
            rows.setdefault(label, []).append(r)
            if seed == 0:
                fig_data = fig_data or {"x": x, "ne": ne, "fits": {}}
                fig_data["fits"][label] = s
    print("-" * len(head))
    print(f"median over {args.seeds} seeds:")
    for label, rs in rows.items():
        med = np.median(np.array(rs), axis=0)
        print(f"{'':>4} {label:<14} {med[0]:9.4f} {med[1]:9.4f} {med[2]:9.4f}")
    cov = coverage(fig_data["ne"])
    print(f"seed 0 {cov}")
    if args.png:
        write_figure(args.png, fig_data, cov, dim)
        print(f"figure written to {args.png}")
    return 0


def cost(large: bool) -> int:
    """Time of the GCV search (energy penalty), exact and by Hutchinson (32 probes)."""
    from simplexspline.spline.fit.penalty import DENSE_MAX, choose_smoothing, penalty_blocks

    cases = [(2, 3, (6, 6), 3000), (3, 3, (3, 3, 3), 20000), (5, 3, (1,) * 5, 100000),
             (3, 4, (3, 3, 3), 20000)] + ([(3, 4, (6, 6, 6), 300000)] if large else [])
    head = (f"{'space':<22} {'M':>6} {'plain s':>8} {'blocks s':>8} {'exact s':>8} "
            f"{'cached s':>8} {'hutch s':>8} {'edf exact':>9} {'edf hutch':>14} "
            f"{'w exact':>8} {'w hutch':>8}")
    print(head)
    print("-" * len(head))
    for n, d, shape, npts in cases:
        rng = np.random.default_rng(0)
        x = rng.uniform(0, 1, (npts, n))
        y = np.sin(3 * x[:, 0]) * np.cos(2 * x[:, -1]) + 0.05 * rng.standard_normal(npts)
        tri = Triangulation.grid([0] * n, [1] * n, shape)
        space = SplineSpace(tri, d, 1)
        ne = space.normal_equations(x, y)
        space.solve(ne)
        t = time.perf_counter()
        space.solve(ne)
        plain = time.perf_counter() - t
        t = time.perf_counter()
        P = penalty_blocks(tri, d, "energy")
        blocks = time.perf_counter() - t
        M = space.system.nglobal
        cells = [f"{f'n={n} d={d} J={tri.nsimplex}':<22} {M:>6} {plain:8.2f} {blocks:8.3f}"]
        ex = None
        if M <= max(DENSE_MAX, 2500):
            times = []
            for _ in range(2):
                t = time.perf_counter()
                ex = choose_smoothing(ne, space.system, P, method="exact")
                times.append(time.perf_counter() - t)
            cells.append(f"{times[0]:8.2f} {times[1]:8.2f}")
        else:
            cells.append(f"{'-':>8} {'-':>8}")
        t = time.perf_counter()
        hu = choose_smoothing(ne, space.system, P, method="hutchinson")
        th = time.perf_counter() - t
        edf_h = f"{hu.edf:.1f} +- {hu.edf_std:.1f}"
        cells.append(f"{th:8.2f} {ex.edf if ex else float('nan'):9.1f} {edf_h:>14} "
                     f"{ex.smoothing if ex else float('nan'):8.3g} {hu.smoothing:8.3g}")
        print(" ".join(cells), flush=True)
    return 0


def write_figure(path: str, data: dict, cov, dim: int) -> None:
    from matplotlib.figure import Figure

    from simplexspline._files import atomic_write

    fig = Figure(figsize=(11.0, 4.2), dpi=100)
    ax1 = fig.add_subplot(1, 2, 1)
    cov.plot(dims=(0, 1), ax=ax1, points=data["x"], labels=("x0", "x1"))
    ax2 = fig.add_subplot(1, 2, 2)
    t = np.linspace(0, 1, 801)
    cut = np.column_stack([t] + [np.full_like(t, 0.5)] * (dim - 1))
    ax2.axvspan(EDGE, 1.0, color="0.9", label="thin region")
    ax2.plot(t, truth(cut), "k-", lw=2, label="truth")
    styles = {"unregularised": "r--", "gcv energy": "b-", "gcv membrane": "g-.",
              "gcv ridge": "m:"}
    for label, s in data["fits"].items():
        ax2.plot(t, s.predict(cut), styles.get(label, "-"), label=label)
    lo, hi = truth(cut).min(), truth(cut).max()
    ax2.set_ylim(lo - 0.5 * (hi - lo), hi + 0.5 * (hi - lo))
    ax2.set_xlabel("x0 (other variables 0.5)")
    ax2.set_title("cut through the thin edge (seed 0)", fontsize=9)
    ax2.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, format="png"))


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
