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
4. predict throughput (n = 5, d = 3, benchmark 1's spline) and single-point latency (also
   of the gradient).
5. Dask: benchmark 2's data in 20 partitions of a Dask array, generated and persisted on a
   2-worker ``dask.distributed.LocalCluster`` (processes, one thread each), fitted by
   ``simplexspline.spline.distributed.fit_dask``: time (cluster start-up and data generation not
   counted) and the max coefficient difference from benchmark 2's in-memory fit.
6. Off the grid (issue 17): benchmarks 1, 3 and 4 on Delaunay triangulations, located by
   the compiled walk. 6a: ``Triangulation.delaunay`` of 11 random 5-D vertices (37
   simplices), 200,000 points, S^1_3: fit time, the block-product floor, and point location
   against scipy's ``Delaunay.find_simplex`` on the same points. 6b: predict throughput and
   single-point latency of 6a's spline. 6c: the SimplexBSplines peer's task (Delaunay of a
   3^3 grid with its centre vertex perturbed, S^1_3, 200,000 points).
7. 3-D, d = 4, Delaunay of 850 random vertices (5,347 simplices), 2,000,000 points
   (``on_insufficient='minnorm'``: slivers without data): normal equations and the first
   solve (which orders and factorises; the target's figure), then a second solve on the
   same space (the ordering cached), and the continuity residual.
8. The sparse Cholesky's ordering off the grid: the condensed KKT matrix of a 3-D S^1_4 fit
   on a Delaunay triangulation of 200 random vertices (1,161 simplices, 200,000 points),
   factorised by the project's multifrontal Cholesky in its nested-dissection order (cuts
   through simplex centroids, and through the B-net points as before issue 17) and by
   scipy's SuperLU (symmetric mode, no pivoting) with minimum degree on A'+A, COLAMD and
   reverse Cuthill-McKee: nonzeros of L and factorisation time (ordering included).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from simplexspline import SplineSpace, Triangulation
from simplexspline.spline import kernels
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

    def products():  # one BLAS thread, as inside the fit (spinning threads on a loaded
        with kernels.one_blas_thread():  # machine made this floor 100x slower)
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


#: Benchmarks 2 and 5: the data come in this many partitions (generated per partition, so
#: that the in-memory and the Dask fits see the same numbers).
NPARTS = 20


def _large_part(i: int, size: int):
    """Partition i of benchmark 2's data: (x, y)."""
    rng = np.random.default_rng([2, i])
    x = rng.random((size, 5))
    return x, target(x) + 0.01 * rng.standard_normal(size)


def _large_space() -> SplineSpace:
    return SplineSpace(Triangulation.grid(np.zeros(5), np.ones(5), (2, 2, 2, 1, 1)), 3, 1)


def bench_large_n(rows: list, quick: bool, coef_file: str) -> None:
    """Benchmark 2 in a child process, to measure its peak memory alone."""
    npts = 1_000_000 if quick else 10_000_000
    out = subprocess.run([sys.executable, __file__, "--child-large", str(npts), coef_file],
                         capture_output=True, text=True, check=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    rows.append(("2 large N: n=5 d=3 r=1", f"J={res['nsimplex']}, N={npts:,}",
                 f"fit {res['fit']:.2f} s (data generation {res['gen']:.2f} s not counted)",
                 f"peak RSS {res['rss_mb']:.0f} MB (data alone {res['data_mb']:.0f} MB)",
                 "fit <= 15 s, RSS <= 2 GB"))


def _child_large(npts: int, coef_file: str | None) -> None:
    t0 = time.perf_counter()
    size = npts // NPARTS
    x = np.empty((size * NPARTS, 5))
    y = np.empty(size * NPARTS)
    for i in range(NPARTS):
        x[i * size:(i + 1) * size], y[i * size:(i + 1) * size] = _large_part(i, size)
    t1 = time.perf_counter()
    space = _large_space()
    spline = space.fit(x, y)
    t2 = time.perf_counter()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    if coef_file:
        np.save(coef_file, spline.coefficients)
    print(json.dumps({"nsimplex": space.triangulation.nsimplex, "fit": t2 - t1,
                      "gen": t1 - t0, "rss_mb": rss,
                      "data_mb": (x.nbytes + y.nbytes) / 2**20}))


def bench_dask(rows: list, quick: bool, coef_file: str, repeats: int) -> None:
    """Benchmark 5 in a child process (its own cluster)."""
    npts = 1_000_000 if quick else 10_000_000
    out = subprocess.run([sys.executable, __file__, "--child-dask", str(npts), coef_file,
                          str(repeats)], capture_output=True, text=True, check=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    rows.append(("5 Dask: 2-worker LocalCluster", f"N={npts:,} in {NPARTS} partitions",
                 (f"fit_dask {res['fit']:.2f} s (cluster start {res['start']:.1f} s, data "
                  "generation on the workers not counted)"),
                 (f"max abs. coefficient difference from in-memory {res['diff']:.1e} "
                  f"(coefficients up to {res['cmax']:.1f})"), "equal to round-off"))


def _child_dask(npts: int, coef_file: str, repeats: int) -> None:
    import dask
    import dask.array as da
    from dask.distributed import Client, LocalCluster, wait

    from simplexspline.spline.distributed import fit_dask

    size = npts // NPARTS
    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=40)
    client = Client(cluster)
    t1 = time.perf_counter()
    parts = [dask.delayed(_large_part, nout=2)(i, size) for i in range(NPARTS)]
    x = da.concatenate([da.from_delayed(p[0], (size, 5), float) for p in parts])
    y = da.concatenate([da.from_delayed(p[1], (size,), float) for p in parts])
    x, y = client.persist([x, y])
    wait([x, y])
    space = _large_space()
    space.system  # noqa: B018 (set-up, as in benchmark 2's space.fit: cached per space)
    t_fit, spline = median_time(lambda: fit_dask(space, x, y=y), repeats)
    if os.path.exists(coef_file):
        ref = np.load(coef_file)
    else:  # benchmark 2 not run: the in-memory fit of the same data here
        xs, ys = zip(*(_large_part(i, size) for i in range(NPARTS)))
        ref = space.fit(np.concatenate(xs), np.concatenate(ys)).coefficients
    client.close()
    cluster.close()
    print(json.dumps({"fit": t_fit, "start": t1 - t0,
                      "diff": float(np.abs(spline.coefficients - ref).max()),
                      "cmax": float(np.abs(ref).max())}))


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


def single_point_time(fn, points: np.ndarray, n: int) -> float:
    """Median wall time [s] of ``fn`` on one point, over the first ``n`` points (after one
    warm-up call)."""
    fn(points[:1])
    times = []
    for i in range(n):
        t0 = time.perf_counter()
        fn(points[i:i + 1])
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def bench_predict(rows: list, spline, x: np.ndarray, repeats: int, quick: bool,
                  label: str = "4 predict: n=5 d=3") -> None:
    rng = np.random.default_rng(4)
    npts = 100_000 if quick else 1_000_000
    xe = x[rng.integers(0, len(x), npts)]
    t_batch, _ = median_time(lambda: spline.predict(xe), repeats)
    t_one = single_point_time(spline.predict, xe, 200 if quick else 2000)
    t_gone = single_point_time(spline.gradient, xe, 200 if quick else 2000)
    t_grad, _ = median_time(lambda: spline.gradient(xe), repeats)
    rows.append((label, f"J={spline.triangulation.nsimplex}, N={npts:,}",
                 f"{npts / t_batch / 1e6:.2f} M points/s; gradient {npts / t_grad / 1e6:.2f} "
                 "M points/s",
                 f"single point {t_one * 1e6:.0f} us (gradient "
                 f"{t_gone * 1e6:.0f} us)", ">= 5 M/s, <= 50 us"))


def in_simplices(tri, npts: int, rng: np.random.Generator) -> np.ndarray:
    """Points uniform in the union of the simplices (volume-weighted, Dirichlet inside)."""
    vol = tri.volumes()
    j = rng.choice(tri.nsimplex, npts, p=vol / vol.sum())
    b = rng.dirichlet(np.ones(tri.ndim + 1), npts)
    return np.einsum("ik,ikn->in", b, np.asarray(tri.corners)[j])


def bench_delaunay(rows: list, repeats: int, quick: bool) -> None:
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(12)  # a seed whose Delaunay has the paper's 37 simplices
    npts = 20_000 if quick else 200_000
    verts = rng.random((11, 5))
    tri = Triangulation.delaunay(verts)
    x = in_simplices(tri, npts, rng)
    y = target(x) + 0.01 * rng.standard_normal(npts)
    space = _space_setup(tri, 3, 1)
    t_fit, spline = median_time(lambda: space.fit(x, y), repeats)
    floor = gram_floor(space, x, repeats)
    tri.locate(x[:10])
    t_loc, _ = median_time(lambda: tri.locate(x), repeats)
    qhull = Delaunay(verts)
    t_qh, _ = median_time(lambda: qhull.find_simplex(x), repeats)
    rows.append(("6a paper on Delaunay: n=5 d=3 r=1", f"J={tri.nsimplex}, N={npts:,}",
                 f"fit {t_fit:.3f} s; locate {t_loc * 1e3:.1f} ms (qhull find_simplex "
                 f"{t_qh * 1e3:.1f} ms)",
                 f"fit/floor = {t_fit / floor:.2f} (floor {floor * 1e3:.1f} ms); "
                 f"locate/qhull = {t_loc / t_qh:.2f}",
                 "fit <= 0.1 s, ratio <= 3; locate <= 1.5x qhull"))
    bench_predict(rows, spline, x, repeats, quick, label="6b predict on Delaunay: n=5 d=3")
    g = np.stack(np.meshgrid(*[np.linspace(0, 1, 3)] * 3, indexing="ij"), -1).reshape(-1, 3)
    g[13] += 0.1 * rng.uniform(-1, 1, 3)  # the centre vertex
    peer = Triangulation.delaunay(g)
    xp = in_simplices(peer, npts, rng)
    yp = np.sin(3 * xp[:, 0]) * np.cos(2 * xp[:, 1]) + xp[:, 2] ** 2
    pspace = _space_setup(peer, 3, 1)
    t_peer, _ = median_time(lambda: pspace.fit(xp, yp), repeats)
    pfloor = gram_floor(pspace, xp, repeats)
    rows.append(("6c peer task (Delaunay of perturbed 3^3 grid) S^1_3",
                 f"J={peer.nsimplex}, N={npts:,}", f"fit {t_peer:.3f} s",
                 f"fit/floor = {t_peer / pfloor:.2f} (floor {pfloor * 1e3:.1f} ms)",
                 "fit <= 0.064 s"))


def _delaunay_3d(nverts: int, npts: int):
    """Delaunay triangulation of random 3-D vertices, points in it and a smooth function."""
    rng = np.random.default_rng(7)
    tri = Triangulation.delaunay(rng.random((nverts, 3)))
    x = in_simplices(tri, npts, rng)
    return tri, x, np.sin(3 * x[:, 0]) * np.cos(2 * x[:, 1]) + x[:, 2] ** 3


def bench_delaunay_large(rows: list, repeats: int, quick: bool) -> None:
    nverts, npts = (200, 200_000) if quick else (850, 2_000_000)
    tri, x, y = _delaunay_3d(nverts, npts)
    t_setup, space = median_time(lambda: _space_setup(tri, 4, 1), 1)
    cpu = time.process_time()
    t_ne, ne = median_time(lambda: space.normal_equations(x, y), 1)
    t_solve, spline = median_time(lambda: space.solve(ne, on_insufficient="minnorm"), 1)
    cpu = time.process_time() - cpu  # all threads: what an idle machine's wall time is at most
    t_again, _ = median_time(lambda: space.solve(ne, on_insufficient="minnorm"), 1)
    c = spline.coefficients.ravel()
    resid = np.abs(space.H_full @ c).max() / np.abs(c).max()
    rows.append(("7 large Delaunay: n=3 d=4 r=1", f"J={tri.nsimplex:,}, N={npts:,}",
                 f"fit {t_ne + t_solve:.2f} s (normal eq. {t_ne:.2f} s, first solve "
                 f"{t_solve:.2f} s; again {t_again:.2f} s; CPU time of the fit {cpu:.2f} s); "
                 f"space set-up {t_setup:.2f} s",
                 f"{space.system.nglobal:,} C^0-reduced coefficients; continuity residual "
                 f"{resid:.0e}", "fit <= 20 s"))


def bench_ordering(rows: list, repeats: int, quick: bool) -> None:
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    from simplexspline.spline.bform import bnet_points
    from simplexspline.spline.fit import constrained
    from simplexspline.spline.fit.cholesky import SparseCholesky

    nverts, npts = (80, 50_000) if quick else (200, 200_000)
    tri, x, y = _delaunay_3d(nverts, npts)
    space = _space_setup(tri, 4, 1)
    system = space.system
    ne = space.normal_equations(x, y)
    M = system.nglobal
    Qg = constrained._assemble_gram(ne.XtWX, system.gather, M, None)
    scale = float(Qg.diagonal().mean())
    A = system.A_all
    rn = np.sqrt(np.asarray(A.multiply(A).sum(axis=1)).ravel())
    A = sp.diags(scale / np.where(rn > 0, rn, 1.0)) @ A
    P = (Qg + constrained.KKT_SIGMA * scale * sp.eye(M)
         + (A.T @ A) / (constrained.KKT_DELTA_TIGHT * scale)).tocsr()
    centroids = constrained.global_points(tri, 4, system.gather, M)
    bnet = np.zeros((M, 3))
    bnet[system.gather] = bnet_points(tri.vertices[tri.simplices], 4).reshape(-1, 3)
    out = {}
    with kernels.one_blas_thread():
        SparseCholesky(P, centroids)  # compile the kernels
        for name, pos in (("ND centroids", centroids), ("ND B-net points", bnet)):
            t, chol = median_time(lambda pos=pos: SparseCholesky(P, pos), repeats)
            out[name] = (t, sum((e - s) * (e - s + 1) // 2 + (e - s) * len(U)
                                for s, e, _, _, U in chol.factors))
        opts = {"diag_pivot_thresh": 0.0, "options": {"SymmetricMode": True}}
        for spec in ("MMD_AT_PLUS_A", "COLAMD", "RCM"):
            def factor(spec=spec):
                if spec == "RCM":
                    perm = reverse_cuthill_mckee(P, symmetric_mode=True)
                    return spla.splu(P[perm][:, perm].tocsc(), permc_spec="NATURAL", **opts)
                return spla.splu(P.tocsc(), permc_spec=spec, **opts)
            t, lu = median_time(factor, 1)
            out[f"SuperLU {spec}"] = (t, lu.L.nnz)
    base = out["ND centroids"][0]
    rows.append(("8 ordering: 3-D d=4 r=1 Delaunay KKT", f"J={tri.nsimplex:,}, M={M:,}",
                 "; ".join(f"{k} {t:.2f} s" for k, (t, _) in out.items()),
                 "nnz(L) " + ", ".join(f"{k.split()[-1]} {n:.2e}" for k, (_, n) in out.items())
                 + "; time / ND centroids " + ", ".join(f"{t / base:.1f}"
                                                       for t, _ in out.values()), ""))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", type=int, nargs="*", default=None)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--child-large", nargs="+", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--child-dask", nargs="+", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child_large is not None:
        _child_large(int(args.child_large[0]), args.child_large[1]
                     if len(args.child_large) > 1 else None)
        return 0
    if args.child_dask is not None:
        _child_dask(int(args.child_dask[0]), args.child_dask[1], int(args.child_dask[2]))
        return 0
    only = set(args.only or [1, 2, 3, 4, 5, 6, 7, 8])
    tmp = tempfile.TemporaryDirectory()
    coef_file = os.path.join(tmp.name, "large_coef.npy")
    rows: list = []
    spline = x = None
    if only & {1, 4}:
        spline, x = bench_paper(rows, args.repeats, args.quick)
    if 2 in only:
        bench_large_n(rows, args.quick, coef_file)
    if 3 in only:
        bench_large_tri(rows, args.repeats, args.quick)
    if 4 in only:
        bench_predict(rows, spline, x, args.repeats, args.quick)
    if 5 in only:
        bench_dask(rows, args.quick, coef_file, max(1, args.repeats // 2))
    if 6 in only:
        bench_delaunay(rows, args.repeats, args.quick)
    if 7 in only:
        bench_delaunay_large(rows, args.repeats, args.quick)
    if 8 in only:
        bench_ordering(rows, max(1, args.repeats // 2), args.quick)
    tmp.cleanup()
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
