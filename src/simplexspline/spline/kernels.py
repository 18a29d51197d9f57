"""Optional compiled kernels (numba) for the hot loops, with numpy fallbacks.

Installed with ``pip install 'simplexspline[fast]'``. Every kernel has a pure-numpy
equivalent elsewhere in the package, and the tests check that both give the same numbers;
``SIMPLEXSPLINE_NO_NUMBA=1`` in the environment forces the numpy paths. The README records
the measured factor that earns numba its place.

Kernels
-------
* :func:`grid_locate`: Kuhn-grid point location (cell by floor, simplex by sorting the local
  coordinates), one pass per point.
* :func:`walk_locate`: point location in any triangulation, a visibility walk from a seed
  simplex per cell of a uniform grid, with the lowest-index rule for points on shared faces.
* :func:`basis_cols`: B-form basis values (d_hat, N), level by level over blocks of points.
* :func:`evaluate`: barycentric coordinates, basis and the dot product with the simplex's
  coefficients fused, without materialising the basis matrix.
* :func:`gradient`: the same for gradients (the degree d-1 basis, one de Casteljau step
  per barycentric direction, the chain rule through the simplex's affine map).
* :func:`walk_evaluate`: the walk and the evaluation fused (the walk's barycentric
  coordinates feed the basis).
* :func:`extend_add`: the scatter-add of a child's update matrix into its parent's frontal
  matrix in the sparse Cholesky of :mod:`simplexspline.spline.fit.constrained` (lower triangles).
"""

from __future__ import annotations

import contextlib
import os
from functools import lru_cache

import numpy as np

from simplexspline.spline.bform import monomial_plan, scale_factors, step_table
from simplexspline.errors import InputError

__all__ = ["HAVE_NUMBA", "one_blas_thread", "thread_count", "in_parallel", "basis_plan",
           "grid_locate", "walk_plan", "walk_locate", "walk_evaluate", "basis_cols",
           "sorted_design_t", "evaluate", "gradient", "extend_add", "gram_blocks",
           "fused_normal"]

try:  # pragma: no cover - exercised where numba is installed
    if os.environ.get("SIMPLEXSPLINE_NO_NUMBA"):
        raise ImportError
    import numba

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    numba = None
    HAVE_NUMBA = False


_CONTROLLER: list = []

#: Evaluation and location calls with at least this many points run on several threads
#: (the compiled kernels release the GIL); below, thread start-up costs more than it saves.
PARALLEL_MIN_POINTS = 200_000


def thread_count(npoints: int, threads: int | None = None,
                 min_points: int | None = None) -> int:
    """Worker threads for a compiled pass over ``npoints`` points.

    ``threads`` given: that many (at most one per 1,000 points). Otherwise 1 below
    ``min_points`` points, else ``SIMPLEXSPLINE_THREADS`` or the CPUs this process may use
    (at most 8).
    """
    if threads is not None:
        if int(threads) < 1:
            raise InputError(f"threads must be >= 1, got {threads!r}")
        return max(1, min(int(threads), npoints // 1000 or 1))
    if npoints < (PARALLEL_MIN_POINTS if min_points is None else min_points):
        return 1
    env = os.environ.get("SIMPLEXSPLINE_THREADS")
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            raise InputError(f"SIMPLEXSPLINE_THREADS must be an integer, got {env!r}") from None
    try:
        ncpu = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        ncpu = os.cpu_count() or 1
    return max(1, min(ncpu, 8))


def in_parallel(npoints: int, work) -> None:
    """Call ``work(start, stop)`` on contiguous slices of ``range(npoints)``, on
    :func:`thread_count` threads (``work`` writes its own slice of a preallocated output)."""
    nthreads = thread_count(npoints)
    if nthreads == 1:
        work(0, npoints)
        return
    from concurrent.futures import ThreadPoolExecutor

    bounds = np.linspace(0, npoints, nthreads + 1).astype(np.int64)
    with ThreadPoolExecutor(nthreads) as pool:
        list(pool.map(lambda i: work(bounds[i], bounds[i + 1]), range(nthreads)))


def one_blas_thread():
    """Context limiting BLAS to one thread (a no-op without threadpoolctl).

    Used around many small or medium BLAS/LAPACK calls (per-simplex products, small
    frontal matrices, triangular solves): threads gain little there, and on a loaded
    machine (or under Dask workers sharing the cores) OpenBLAS's spinning threads make
    them several times slower.
    """
    if not _CONTROLLER:
        try:
            from threadpoolctl import ThreadpoolController

            _CONTROLLER.append(ThreadpoolController())
        except (ImportError, OSError, RuntimeError):  # pragma: no cover - no threadpoolctl
            _CONTROLLER.append(None)
    ctl = _CONTROLLER[0]
    if ctl is None:  # pragma: no cover
        return contextlib.nullcontext()
    return ctl.limit(limits=1, user_api="blas")


@lru_cache(maxsize=64)
def basis_plan(n: int, d: int):
    """Flattened monomial plan for degree d: (parents, firsts, offsets, scale), cached per
    (n, d) (shared arrays: do not modify)."""
    parents, firsts, offsets = [], [], [0]
    for k in range(2, d + 1):
        p, f = monomial_plan(n, k)
        parents.append(p)
        firsts.append(f)
        offsets.append(offsets[-1] + len(p))
    cat = (lambda a: np.concatenate(a).astype(np.int64)) if parents else (
        lambda a: np.zeros(0, dtype=np.int64))
    return cat(parents), cat(firsts), np.asarray(offsets, dtype=np.int64), np.asarray(
        scale_factors(n, d), dtype=float)


if HAVE_NUMBA:  # pragma: no cover - compiled

    @numba.njit(cache=True, nogil=True)
    def _grid_locate(x, lower, step, shape, table, nfact, tol, out):
        npts, n = x.shape
        rel = np.empty(n)
        lo = np.empty(n)
        hi = np.empty(n)
        fact = np.empty(n, dtype=np.int64)  # fact[k] = (n - 1 - k)!
        for k in range(n):
            lo[k] = -tol * shape[k]
            hi[k] = shape[k] * (1.0 + tol)
            f = 1
            for q in range(2, n - k):
                f *= q
            fact[k] = f
        pos = np.empty(n, dtype=np.int64)
        perm = np.empty(n, dtype=np.int64)
        for i in range(npts):
            inside = True
            flat = 0
            for k in range(n):
                r = (x[i, k] - lower[k]) / step[k]
                inside = inside & (r >= lo[k]) & (r <= hi[k])
                c = min(max(int(np.floor(r)), 0), shape[k] - 1)
                rel[k] = r - c
                flat = flat * shape[k] + c
            if not inside:
                out[i] = -1
                continue
            # Stable descending argsort of the local coordinates, branch-free: the rank of
            # each coordinate, then the permutation's Lehmer code.
            for a in range(n):
                p = 0
                ra = rel[a]
                for b in range(n):
                    rb = rel[b]
                    p += (rb > ra) | ((rb == ra) & (b < a))
                pos[a] = p
            for a in range(n):
                perm[pos[a]] = a
            rank = 0
            for k in range(n - 1):
                smaller = 0
                pk = perm[k]
                for q in range(k + 1, n):
                    smaller += perm[q] < pk
                rank += smaller * fact[k]
            out[i] = table[flat * nfact + rank]
        return out

    BLOCK = 256

    #: Points per block of the evaluation kernels: the monomial scratch (d_hat x 32
    #: doubles, twice) stays in L1 cache. 256 points per block made evaluation 2.5x
    #: slower (5-D, d = 3, 1,000,000 points: 187 against 75 ms of CPU time, one run).
    EVAL_BLOCK = 32

    @numba.njit(cache=True, nogil=True)
    def _block_monomials(bt, i0, i1, parents, firsts, offsets, s1, s2):
        """Degree-d monomials of points i0..i1 (columns of bt), level by level, into
        scratch arrays s1/s2 (inner loops over points: contiguous, vectorisable).
        Returns the array holding the last level."""
        np1 = bt.shape[0]
        w = i1 - i0
        prev = s1
        for k in range(np1):
            for i in range(w):
                prev[k, i] = bt[k, i0 + i]
        cur = s2
        for level in range(offsets.shape[0] - 1):
            s = offsets[level]
            m = offsets[level + 1] - s
            for k in range(m):
                p = parents[s + k]
                f = firsts[s + k]
                for i in range(w):
                    cur[k, i] = prev[p, i] * bt[f, i0 + i]
            prev, cur = cur, prev
        return prev

    @numba.njit(cache=True, nogil=True)
    def _basis_cols(bt, parents, firsts, offsets, scale, out):
        npts = bt.shape[1]
        m = scale.shape[0]
        s1 = np.empty((max(m, bt.shape[0]), BLOCK))
        s2 = np.empty((max(m, bt.shape[0]), BLOCK))
        for i0 in range(0, npts, BLOCK):
            i1 = min(i0 + BLOCK, npts)
            mono = _block_monomials(bt, i0, i1, parents, firsts, offsets, s1, s2)
            for k in range(m):
                sc = scale[k]
                for i in range(i1 - i0):
                    out[k, i0 + i] = mono[k, i] * sc
        return out

    @numba.njit(cache=True, nogil=True)
    def _block_barycentric(x, sid, i0, i1, origin, tinv, bt):
        """Barycentric coordinates of points i0..i1 in their simplices into bt[:, :i1-i0]
        (a negative simplex id, i.e. outside, uses simplex 0: the caller masks it)."""
        n = x.shape[1]
        for i in range(i1 - i0):
            j = max(sid[i0 + i], 0)
            total = 0.0
            for k in range(n):
                acc = 0.0
                for q in range(n):
                    acc += tinv[j, k, q] * (x[i0 + i, q] - origin[j, q])
                bt[k + 1, i] = acc
                total += acc
            bt[0, i] = 1.0 - total

    @numba.njit(cache=True, nogil=True)
    def _dot_block(mono, sid, i0, w, coef, scale, out):
        """out[i0 + i] = sum_k mono[k, i] * (coef[j, k] * scale[k]) for the w points of a
        block (j = sid[i0 + i]; NaN where j < 0). The product coef * scale is rounded as
        the precomputed scaled coefficients were, so values do not depend on the path."""
        m = coef.shape[1]
        m4 = m - m % 4
        for i in range(w):
            j = sid[i0 + i]
            if j < 0:
                out[i0 + i] = np.nan
                continue
            # four partial sums: independent dependency chains
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            a3 = 0.0
            for k in range(0, m4, 4):
                a0 += mono[k, i] * (coef[j, k] * scale[k])
                a1 += mono[k + 1, i] * (coef[j, k + 1] * scale[k + 1])
                a2 += mono[k + 2, i] * (coef[j, k + 2] * scale[k + 2])
                a3 += mono[k + 3, i] * (coef[j, k + 3] * scale[k + 3])
            for k in range(m4, m):
                a0 += mono[k, i] * (coef[j, k] * scale[k])
            out[i0 + i] = (a0 + a1) + (a2 + a3)

    @numba.njit(cache=True, nogil=True)
    def _evaluate(x, sid, origin, tinv, coef, scale, parents, firsts, offsets, out):
        """Values at points x in simplices sid of the B-form with coefficients coef (the
        multinomial factors ``scale`` folded in term by term)."""
        npts, n = x.shape
        m = coef.shape[1]
        bt = np.empty((n + 1, EVAL_BLOCK))
        s1 = np.empty((max(m, n + 1), EVAL_BLOCK))
        s2 = np.empty((max(m, n + 1), EVAL_BLOCK))
        for i0 in range(0, npts, EVAL_BLOCK):
            i1 = min(i0 + EVAL_BLOCK, npts)
            _block_barycentric(x, sid, i0, i1, origin, tinv, bt)
            mono = _block_monomials(bt, 0, i1 - i0, parents, firsts, offsets, s1, s2)
            _dot_block(mono, sid, i0, i1 - i0, coef, scale, out)
        return out

    @numba.njit(cache=True, nogil=True)
    def _gradient(x, sid, origin, tinv, coef, table, scale, parents, firsts, offsets, d,
                  out):
        """Gradients at points x in simplices sid (NaN rows where sid < 0): with the
        degree d-1 basis B_k (monomials times ``scale``) and the step table (positions of
        kappa_k + e_a), ds/db_a = d sum_k c[table[k, a]] B_k, then the chain rule through
        the simplex's affine map, db_a/dx_q = tinv[a-1, q] (a >= 1) and db_0 = -sum."""
        npts, n = x.shape
        m = table.shape[0]
        bt = np.empty((n + 1, EVAL_BLOCK))
        s1 = np.empty((max(m, n + 1), EVAL_BLOCK))
        s2 = np.empty((max(m, n + 1), EVAL_BLOCK))
        g = np.empty(n + 1)
        for i0 in range(0, npts, EVAL_BLOCK):
            i1 = min(i0 + EVAL_BLOCK, npts)
            _block_barycentric(x, sid, i0, i1, origin, tinv, bt)
            mono = _block_monomials(bt, 0, i1 - i0, parents, firsts, offsets, s1, s2)
            for i in range(i1 - i0):
                j = sid[i0 + i]
                if j < 0:
                    for q in range(n):
                        out[i0 + i, q] = np.nan
                    continue
                for a in range(n + 1):
                    g[a] = 0.0
                for k in range(m):
                    v = scale[k] if m == 1 else mono[k, i] * scale[k]  # m == 1: d = 1
                    for a in range(n + 1):
                        g[a] += v * coef[j, table[k, a]]
                for q in range(n):
                    acc = 0.0
                    for a in range(n):
                        acc += (g[a + 1] - g[0]) * tinv[j, a, q]
                    out[i0 + i, q] = d * acc
        return out

    @numba.njit(cache=True, nogil=True)
    def _sorted_design_t(x, sid, pos, origin, tinv, parents, firsts, offsets, scale, out,
                         perm):
        """Basis values (d_hat, N) in simplex-sorted column order: a counting sort, then
        blocks of sorted points (barycentric coordinates, monomials) written contiguously
        along the rows of ``out``. pos[j] is the first column of simplex j (advanced in
        place); perm receives the sorted position of each point."""
        npts, n = x.shape
        m = scale.shape[0]
        src = np.empty(npts, dtype=np.int64)
        for i in range(npts):
            j = sid[i]
            r = pos[j]
            pos[j] = r + 1
            perm[i] = r
            src[r] = i
        bt = np.empty((n + 1, BLOCK))
        s1 = np.empty((max(m, n + 1), BLOCK))
        s2 = np.empty((max(m, n + 1), BLOCK))
        xs = np.empty((BLOCK, n))
        ss = np.empty(BLOCK, dtype=np.int64)
        for i0 in range(0, npts, BLOCK):
            i1 = min(i0 + BLOCK, npts)
            for i in range(i1 - i0):
                p = src[i0 + i]
                ss[i] = sid[p]
                for q in range(n):
                    xs[i, q] = x[p, q]
            _block_barycentric(xs, ss, 0, i1 - i0, origin, tinv, bt)
            mono = _block_monomials(bt, 0, i1 - i0, parents, firsts, offsets, s1, s2)
            for k in range(m):
                sc = scale[k]
                for i in range(i1 - i0):
                    out[k, i0 + i] = mono[k, i] * sc
        return out

    @numba.njit(cache=True, nogil=True)
    def _gram_blocks(cols, ws, wy, ends, counts, js, gram, rhs):
        """gram[j] += X_j' W X_j and rhs[j] += X_j' W y for the simplices js, with the basis
        columns X_j' = cols[:, ends[j]-counts[j]:ends[j]] (ws of length 0: unit weights)."""
        m = cols.shape[0]
        weighted = ws.shape[0] > 0
        cap = 0
        for jj in range(js.shape[0]):
            cap = max(cap, counts[js[jj]])
        rows = np.empty((cap, m))  # the block transposed: each point's values contiguous
        acc = np.empty((m, m))
        for jj in range(js.shape[0]):
            j = js[jj]
            s = ends[j] - counts[j]
            c = counts[j]
            for k in range(m):
                for p in range(c):
                    rows[p, k] = cols[k, s + p]
            acc[:, :] = 0.0
            for p in range(c):
                w = ws[s + p] if weighted else 1.0
                yw = wy[s + p]
                for k in range(m):
                    rk = rows[p, k] * w
                    for q in range(m):  # full rows: fixed length, vectorised
                        acc[k, q] += rk * rows[p, q]
                    rhs[j, k] += rows[p, k] * yw
            for k in range(m):
                for q in range(m):
                    gram[j, k, q] += acc[k, q]

    @numba.njit(cache=True, nogil=True)
    def _fused_normal(dsyrk, x, sid, pos, ws, wy, origin, tinv, parents, firsts, offsets,
                      scale, gram, rhs):
        """See :func:`fused_normal`; dsyrk is BLAS dsyrk as a ctypes function (passed as an
        argument, not a global, so that numba can cache the compiled kernel on disk)."""
        npts, n = x.shape
        m = scale.shape[0]
        nsimp = pos.shape[0] - 1
        weighted = ws.shape[0] > 0
        # counting sort of the points by simplex (pos: first slot of each simplex)
        fill = pos[:-1].copy()
        src = np.empty(npts, dtype=np.int64)
        for i in range(npts):
            j = sid[i]
            src[fill[j]] = i
            fill[j] += 1
        tile = np.empty((m, TILE))
        bt = np.empty((n + 1, BLOCK))
        s1 = np.empty((max(m, n + 1), BLOCK))
        s2 = np.empty((max(m, n + 1), BLOCK))
        xs = np.empty((BLOCK, n))
        ss = np.empty(BLOCK, dtype=np.int64)
        sw = np.empty(BLOCK)
        wyb = np.empty(BLOCK)
        uplo = np.array([ord("U")], dtype=np.uint8)  # the C-order lower triangle
        trans = np.array([ord("T")], dtype=np.uint8)
        n_ = np.array([m], dtype=np.int32)
        k_ = np.zeros(1, dtype=np.int32)
        lda = np.array([TILE], dtype=np.int32)
        one = np.ones(1)
        for j in range(nsimp):
            if pos[j + 1] == pos[j]:
                continue
            g = gram[j]
            for t0 in range(pos[j], pos[j + 1], TILE):
                tw = min(TILE, pos[j + 1] - t0)
                for b0 in range(0, tw, BLOCK):
                    i0 = t0 + b0
                    w = min(BLOCK, tw - b0)
                    for i in range(w):
                        p = src[i0 + i]
                        ss[i] = j
                        wyb[i] = wy[p]
                        for q in range(n):
                            xs[i, q] = x[p, q]
                    _block_barycentric(xs, ss, 0, w, origin, tinv, bt)
                    mono = _block_monomials(bt, 0, w, parents, firsts, offsets, s1, s2)
                    for k in range(m):
                        sc = scale[k]
                        acc = 0.0
                        for i in range(w):
                            v = mono[k, i] * sc
                            tile[k, b0 + i] = v
                            acc += v * wyb[i]
                        rhs[j, k] += acc
                    if weighted:  # W^(1/2) X_j: then dsyrk gives X_j' W X_j
                        for i in range(w):
                            sw[i] = np.sqrt(ws[src[i0 + i]])
                        for k in range(m):
                            for i in range(w):
                                tile[k, b0 + i] *= sw[i]
                k_[0] = tw
                dsyrk(uplo.ctypes, trans.ctypes, n_.ctypes, k_.ctypes, one.ctypes,
                      tile.ctypes, lda.ctypes, one.ctypes, g.ctypes, n_.ctypes)
            for k in range(m):
                for q in range(k):
                    g[q, k] = g[k, q]
        return gram

    @numba.njit(cache=True, nogil=True, inline="always")
    def _bary_min(x, i, j, origin, tinv, b):
        """Barycentric coordinates of point x[i] in simplex j into b; returns the index of
        the smallest."""
        n = x.shape[1]
        total = 0.0
        for k in range(n):
            acc = 0.0
            for q in range(n):
                acc += tinv[j, k, q] * (x[i, q] - origin[j, q])
            b[k + 1] = acc
            total += acc
        b[0] = 1.0 - total
        imin = 0
        bmin = b[0]
        for k in range(1, n + 1):  # branch-free: the comparisons are unpredictable
            lt = b[k] < bmin
            imin = k if lt else imin
            bmin = b[k] if lt else bmin
        return imin

    #: Simplices remembered by the tie search of :func:`_walk` (per point).
    TIE_CAP = 4096

    @numba.njit(cache=True, nogil=True)
    def _lowest_containing(x, i, s, origin, tinv, neighbors, tol, b, stack, seen):
        """The lowest index among the simplices containing point x[i] (within tol) that
        are reached from s, which contains it, through facets within tol of the point; b
        receives the point's barycentric coordinates in that simplex."""
        n = x.shape[1]
        cap = stack.shape[0]
        best = s
        top = 1
        nseen = 1
        stack[0] = s
        seen[0] = s
        while top > 0 and nseen < cap:
            top -= 1
            t = stack[top]
            _bary_min(x, i, t, origin, tinv, b)
            for k in range(n + 1):
                if b[k] > tol:
                    continue
                nb = neighbors[t, k]
                if nb < 0:
                    continue
                dup = False
                for q in range(nseen):
                    if seen[q] == nb:
                        dup = True
                        break
                if dup or nseen >= cap:
                    continue
                seen[nseen] = nb
                nseen += 1
                bm = _bary_min(x, i, nb, origin, tinv, b)
                if b[bm] >= -tol:
                    if nb < best:
                        best = nb
                    stack[top] = nb
                    top += 1
                _bary_min(x, i, t, origin, tinv, b)
        _bary_min(x, i, best, origin, tinv, b)
        return best

    @numba.njit(cache=True, nogil=True)
    def _walk(x, origin, tinv, neighbors, lower, inv_width, shape, seeds, convex, tol,
              box_tol, maxsteps, coef, scale, parents, firsts, offsets, sid, out):
        """Visibility walks from seed simplices (see :func:`walk_locate`) into ``sid``: -1
        outside, -2 for points the walk could not settle (the caller locates them
        otherwise). With coefficients (``coef`` of shape (J, d_hat), d_hat > 0) the spline
        is evaluated too, into ``out`` (NaN where sid < 0), from the walk's barycentric
        coordinates of the containing simplex: the numbers :func:`_block_barycentric`
        would recompute. One kernel for both, so the walk exists once (written out: as an
        inlined function it ran 1.3x slower). Returns the number of points with
        sid < 0."""
        npts, n = x.shape
        m = coef.shape[1]
        b = np.empty(n + 1)
        stack = np.empty(TIE_CAP, dtype=np.int64)
        seen = np.empty(TIE_CAP, dtype=np.int64)
        bt = np.empty((n + 1, EVAL_BLOCK))
        s1 = np.empty((max(m, n + 1), EVAL_BLOCK))
        s2 = np.empty((max(m, n + 1), EVAL_BLOCK))
        nout = 0
        for i0 in range(0, npts, EVAL_BLOCK):
            w = min(EVAL_BLOCK, npts - i0)
            for ib in range(w):
                i = i0 + ib
                # seed: the simplex recorded for the point's cell of the seed grid
                flat = 0
                inbox = True
                for k in range(n):
                    r = (x[i, k] - lower[k]) * inv_width[k]
                    inbox &= (r >= -box_tol[k]) & (r <= shape[k] + box_tol[k])
                    c = int(min(max(r, 0.0), shape[k] - 1.0))  # the floor, in the grid
                    flat = flat * shape[k] + c
                found = -1
                if inbox:
                    found = -2
                    s = seeds[flat]
                    for _ in range(maxsteps):
                        imin = _bary_min(x, i, s, origin, tinv, b)
                        if b[imin] >= -tol:
                            found = s
                            break
                        s = neighbors[s, imin]
                        if s < 0:
                            found = -1 if convex else -2
                            break
                    # Ties: a point within tol of a facet may lie in the simplices across
                    # it too (rare: a separate function keeps this loop small)
                    if found >= 0 and b[imin] <= tol:
                        found = _lowest_containing(x, i, found, origin, tinv, neighbors,
                                                   tol, b, stack, seen)
                sid[i] = found
                nout += found < 0
                if m > 0:
                    for k in range(n + 1):
                        bt[k, ib] = b[k] if found >= 0 else 0.0
            if m > 0:
                mono = _block_monomials(bt, 0, w, parents, firsts, offsets, s1, s2)
                _dot_block(mono, sid, i0, w, coef, scale, out)
        return nout

    @numba.njit(cache=True, nogil=True)
    def _extend_add(front, idx, upd):
        m = idx.shape[0]
        for j in range(m):
            jj = idx[j]
            for i in range(j, m):
                front[idx[i], jj] += upd[i, j]


#: Points per dsyrk call in :func:`fused_normal` (the tile of basis values stays in cache).
TILE = 1024

_DSYRK: list = []


def _dsyrk():
    """BLAS dsyrk from scipy's Cython BLAS as a ctypes function, or None."""
    if not _DSYRK:
        try:
            import ctypes

            from numba.extending import get_cython_function_address

            ptr = ctypes.c_void_p
            _DSYRK.append(ctypes.CFUNCTYPE(None, *([ptr] * 10))(
                get_cython_function_address("scipy.linalg.cython_blas", "dsyrk")))
        except (ImportError, AttributeError, OSError, TypeError, ValueError):  # pragma: no cover
            _DSYRK.append(None)
    return _DSYRK[0]


def fused_normal(x, sid, counts, w, wy, origin, tinv, d: int, gram, rhs) -> bool:
    """Accumulate ``gram[j] += X_j' W X_j`` and ``rhs[j] += X_j' W y`` for points located in
    simplices ``sid`` (all >= 0) in one compiled pass: points sorted by simplex, basis
    values formed in cache-sized tiles and multiplied by BLAS ``dsyrk`` straight into the
    blocks; the design matrix is never stored. ``wy`` is ``w * y`` (or ``y``). Returns False
    (nothing done) when the kernel is unavailable."""
    if not HAVE_NUMBA or d == 0:
        return False
    dsyrk = _dsyrk()
    if dsyrk is None:  # pragma: no cover
        return False
    parents, firsts, offsets, scale = basis_plan(x.shape[1], d)
    pos = np.zeros(len(counts) + 1, dtype=np.int64)
    np.cumsum(counts, out=pos[1:])
    ws = np.zeros(0) if w is None else np.ascontiguousarray(w, dtype=float)
    _fused_normal(dsyrk, np.ascontiguousarray(x), sid, pos, ws,
                  np.ascontiguousarray(wy, dtype=float), origin, tinv, parents, firsts,
                  offsets, scale, gram, rhs)
    return True


def gram_blocks(cols, ws, wy, ends, counts, js, gram, rhs) -> None:
    """Accumulate the normal-equation blocks of simplices ``js`` in place from the basis
    columns (d_hat, N) of :func:`sorted_design_t` (compiled; see
    :meth:`NormalEquations._add_located` for the BLAS path used for large blocks)."""
    _gram_blocks(cols, np.zeros(0) if ws is None else ws, wy, ends, counts,
                 js.astype(np.int64), gram, rhs)


def extend_add(front: np.ndarray, idx: np.ndarray, upd: np.ndarray) -> None:
    """``front[idx[i], idx[j]] += upd[i, j]`` for ``i >= j`` (idx increasing, so the lower
    triangle of ``upd`` lands in the lower triangle of ``front``), in place."""
    if HAVE_NUMBA:
        _extend_add(front, idx, upd)
    else:
        front[np.ix_(idx, idx)] += np.tril(upd)


def grid_locate(x, lower, step, shape, table, nfact, tol) -> np.ndarray:
    """Compiled Kuhn-grid location (see :class:`~simplexspline.spline.geometry.location.GridLocator`)."""
    out = np.empty(len(x), dtype=np.int64)
    in_parallel(len(x), lambda s, e: _grid_locate(x[s:e], lower, step, shape, table, nfact,
                                                 tol, out[s:e]))
    return out


def walk_plan(origin, tinv, neighbors, lower, width, shape, seeds, convex: bool,
              tol: float) -> tuple:
    """The arguments of the walk kernels (:func:`walk_locate`, :func:`walk_evaluate`),
    prepared once per triangulation so that a call on a few points costs no set-up.

    Parameters
    ----------
    origin, tinv : ndarray, shapes (J, n) and (J, n, n)
        The simplices' affine maps.
    neighbors : ndarray of int, shape (J, n + 1)
        Neighbour across the facet opposite each local vertex, -1 on the boundary.
    lower, width : ndarray, shape (n,)
        Lower corner and cell widths of the seed grid.
    shape : ndarray of int, shape (n,)
        Cells of the seed grid per axis.
    seeds : ndarray of int, shape (prod(shape),)
        Seed simplex of every cell (flat, C order).
    convex : bool
        A walk stopped by a boundary facet proves the point outside.
    tol : float
        A point with barycentric coordinates >= -tol is inside.
    """
    shape = np.ascontiguousarray(shape, dtype=np.int64)
    return (np.ascontiguousarray(origin, dtype=float), np.ascontiguousarray(tinv, dtype=float),
            np.ascontiguousarray(neighbors, dtype=np.int64),
            np.ascontiguousarray(lower, dtype=float),
            1.0 / np.asarray(width, dtype=float), shape,
            np.ascontiguousarray(seeds, dtype=np.int64), bool(convex), float(tol),
            np.full(len(shape), 1e-9) * shape, int(64 + 8 * shape.max()))


def walk_locate(x, plan: tuple) -> np.ndarray:
    """Compiled point location in any triangulation by a visibility walk.

    Each point starts in the seed simplex of its cell of a uniform seed grid and steps
    across the facet opposite its most negative barycentric coordinate until all are
    >= ``-tol``. Points on (or within ``tol`` of) shared faces get the lowest-index simplex
    containing them.

    Parameters
    ----------
    x : ndarray, shape (N, n)
    plan : tuple
        From :func:`walk_plan`.

    Returns
    -------
    ndarray of int64, shape (N,)
        The simplex, -1 outside (beyond the seed grid's box, or, when the plan is
        ``convex``, beyond a boundary facet), -2 where the walk stopped at a boundary facet
        of a non-convex triangulation or took too many steps (to be located by other
        means).
    """
    out = np.empty(len(x), dtype=np.int64)
    if len(x) == 0:
        return out
    x = np.ascontiguousarray(x, dtype=float)
    # no coefficients: location only
    coef, none, empty = np.zeros((0, 0)), np.zeros(0), np.zeros(0, dtype=np.int64)
    in_parallel(len(x), lambda s, e: _walk(x[s:e], *plan, coef, none, empty, empty, empty,
                                           out[s:e], none))
    return out


def walk_evaluate(x, plan: tuple, coef, d: int) -> tuple[np.ndarray, np.ndarray, int]:
    """:func:`walk_locate` and :func:`evaluate` in one compiled pass: the walk's barycentric
    coordinates of the containing simplex feed the basis directly.

    Parameters
    ----------
    x : ndarray, shape (N, n)
    plan : tuple
        From :func:`walk_plan`.
    coef : ndarray, shape (J, d_hat)
        B-coefficients.
    d : int
        Degree.

    Returns
    -------
    sid : ndarray of int64, shape (N,)
        As :func:`walk_locate` returns it.
    values : ndarray, shape (N,)
        The spline's values, NaN where ``sid < 0`` (the same numbers as :func:`evaluate`
        gives at the located simplices).
    unlocated : int
        The number of points with ``sid < 0`` (outside or unsettled).
    """
    if d == 0:
        sid = walk_locate(x, plan)
        values = np.where(sid >= 0, coef[np.maximum(sid, 0), 0], np.nan)
        return sid, values, int(np.count_nonzero(sid < 0))
    parents, firsts, offsets, scale = basis_plan(x.shape[1], d)
    sid = np.empty(len(x), dtype=np.int64)
    out = np.empty(len(x))
    if len(x) == 0:
        return sid, out, 0
    x = np.ascontiguousarray(x, dtype=float)
    coef = np.ascontiguousarray(coef, dtype=float)   # as walk_locate's empty one: one type
    counts: list = []  # one per slice (list.append is atomic under the GIL)
    in_parallel(len(x), lambda s, e: counts.append(_walk(
        x[s:e], *plan, coef, scale, parents, firsts, offsets, sid[s:e], out[s:e])))
    return sid, out, int(sum(counts))


def basis_cols(bt: np.ndarray, d: int) -> np.ndarray:
    """Basis values (d_hat, N) of barycentric coordinates bt (n+1, N), compiled."""
    parents, firsts, offsets, scale = basis_plan(bt.shape[0] - 1, d)
    out = np.empty((len(scale), bt.shape[1]))
    if d == 0:
        out[:] = 1.0
        return out
    return _basis_cols(np.ascontiguousarray(bt), parents, firsts, offsets, scale, out)


def _frozen(a) -> np.ndarray:
    """``a`` as a read-only, C-contiguous float array (a view where it already is one).

    numba compiles a kernel once per argument type, and an array's type includes its
    layout and whether it is writeable: the triangulations' geometry and the coefficients
    reach the kernels as read-only arrays, strided views and plain copies, and the main job
    compiled ``_evaluate`` five times, ``_block_barycentric`` four times and ``_gradient``
    three times (each compile some seconds on an empty cache, and each loaded from the
    cache again in every worker process). One type per argument makes one compile."""
    a = np.ascontiguousarray(a, dtype=float)
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a


def sorted_design_t(x, sid, counts, origin, tinv, d: int):
    """Basis values (d_hat, N) of points located in simplices ``sid`` (all >= 0), columns in
    simplex-sorted order (simplex j's columns contiguous, in input order), and the sorted
    position of every input point."""
    parents, firsts, offsets, scale = basis_plan(x.shape[1], d)
    out = np.empty((len(scale), len(x)))
    perm = np.empty(len(x), dtype=np.int64)
    pos = (np.cumsum(counts) - counts).astype(np.int64)
    if d == 0:
        perm[:] = np.argsort(sid, kind="stable").argsort()
        out[:] = 1.0
        return out, perm
    _sorted_design_t(np.ascontiguousarray(x), sid, pos, _frozen(origin), _frozen(tinv),
                     parents, firsts,
                     offsets, scale, out, perm)
    return out, perm


@lru_cache(maxsize=64)
def _step_table(n: int, d: int) -> np.ndarray:
    return step_table(n, d)


def gradient(x, sid, origin, tinv, coef, d: int) -> np.ndarray:
    """Spline gradients (N, n) at points x (N, n) in simplices sid (N,; -1 gives NaN rows),
    compiled; d >= 1."""
    parents, firsts, offsets, scale = basis_plan(x.shape[1], d - 1)
    out = np.empty(x.shape)
    x = np.ascontiguousarray(x)
    origin, tinv, coef = _frozen(origin), _frozen(tinv), _frozen(coef)
    table = _step_table(x.shape[1], d)
    in_parallel(len(x), lambda s, e: _gradient(x[s:e], sid[s:e], origin, tinv, coef, table,
                                               scale, parents, firsts, offsets, float(d),
                                               out[s:e]))
    return out


def evaluate(x, sid, origin, tinv, coef, d: int) -> np.ndarray:
    """Spline values at points x (N, n) in simplices sid (N,; -1 gives NaN), compiled."""
    parents, firsts, offsets, scale = basis_plan(x.shape[1], d)
    out = np.empty(len(x))
    if d == 0:
        out[:] = np.where(sid >= 0, coef[np.maximum(sid, 0), 0], np.nan)
        return out
    x = np.ascontiguousarray(x)
    origin, tinv, coef = _frozen(origin), _frozen(tinv), _frozen(coef)
    in_parallel(len(x), lambda s, e: _evaluate(x[s:e], sid[s:e], origin, tinv, coef, scale,
                                               parents, firsts, offsets, out[s:e]))
    return out
