"""Export a :class:`SimplexSpline` as dependency-free C99 source code.

The generated code evaluates the spline and its exact gradient at one point without
Python: point location, barycentric coordinates, the B-form. It needs only ``<math.h>``
(link with ``-lm``), allocates nothing, and keeps every number in ``static const`` tables
written with Python's shortest round-trip representation, so the compiled tables hold
exactly the model's doubles.

Point location follows :meth:`Triangulation.locate` rule for rule, so C and Python pick the
same simplex, also for points on shared facets and vertices:

* grid and fit (Kuhn) triangulations: the cell by a floor, the simplex by the permutation
  that sorts the local coordinates (ties by axis order), O(1) per point;
* other triangulations: the uniform bucket grid of
  :class:`~simplexspline.spline.locate.BucketLocator` (the same buckets, the same candidate
  order, the same tolerance), so each point tests only its bucket's few simplices.

Outside policies (chosen per call; a default is compiled in):

* ``'nan'``: NaN value and gradient (as :meth:`SimplexSpline.predict`);
* ``'clamp'``: the point is clamped to the domain box (the grid box of grid/fit
  triangulations, the vertices' bounding box otherwise), then evaluated like
  ``'extrapolate'`` (a clamped point can still lie outside the simplices);
* ``'extrapolate'``: the polynomial of :meth:`Triangulation.nearest` (the least-outside
  simplex among the 8 with the nearest centroids, found by a scan of all centroids).

:func:`reference_evaluate` is the same computation in Python (numpy), for tables and tests.

The value and gradient come from one de Casteljau step: with
``g_i = sum_{|k| = d-1} c_{k + e_i} B^{d-1}_k(b)`` the value is ``sum_i b_i g_i`` and
``ds/db_i = d g_i``; the chain rule with the simplex's (constant) barycentric Jacobian gives
the Cartesian gradient.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simplexspline.errors import InputError
from simplexspline.spline import kernels
from simplexspline.spline.bform import _step_table, num_basis
from simplexspline.spline.locate import INSIDE_TOL, BucketLocator, GridLocator

__all__ = ["CSource", "POLICIES", "generate_c", "reference_evaluate", "domain_box",
           "c_identifier"]

#: Outside policies of the generated code, with their C codes 0, 1, 2.
POLICIES = ("nan", "clamp", "extrapolate")

#: Candidates of the nearest-simplex search (as :meth:`Triangulation.nearest`).
NEAREST_K = 8

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

#: C99 keywords and <math.h> macros a generated identifier must not be.
RESERVED = frozenset("""
auto break case char const continue default do double else enum extern float for goto if
inline int long register restrict return short signed sizeof static struct switch typedef
union unsigned void volatile while _Bool _Complex _Imaginary NAN INFINITY HUGE_VAL HUGE_VALF
HUGE_VALL FP_NAN FP_INFINITE FP_ZERO FP_SUBNORMAL FP_NORMAL math_errhandling MATH_ERRNO
MATH_ERREXCEPT
""".split())


def c_identifier(name: str, *, what: str = "prefix") -> str:
    """Check that ``name`` is usable as a C identifier prefix; returns it.

    Raises
    ------
    InputError
        Not ``[A-Za-z_][A-Za-z0-9_]*``, a C keyword or a ``<math.h>`` macro, or starting
        with an underscore (reserved).
    """
    if not isinstance(name, str) or not _IDENT.match(name) or name.startswith("_") \
            or name in RESERVED:
        raise InputError(f"{what} {name!r} is not a usable C identifier: use letters, digits "
                         "and underscores, starting with a letter (e.g. 'cz_model'), and no "
                         "C keyword")
    return name


@dataclass(frozen=True)
class CSource:
    """Generated C code: a header and a source file, or a single header.

    Attributes
    ----------
    prefix : str
        The prefix of every public identifier (functions ``<prefix>_*``, macros
        ``<PREFIX>_*``); also the file name stem.
    header : str
        Text of ``<prefix>.h``.
    source : str or None
        Text of ``<prefix>.c``; ``None`` for a single header (define
        ``<PREFIX>_IMPLEMENTATION`` in exactly one file before including it).
    """

    prefix: str
    header: str
    source: str | None

    @property
    def files(self) -> dict:
        """File name -> text."""
        out = {f"{self.prefix}.h": self.header}
        if self.source is not None:
            out[f"{self.prefix}.c"] = self.source
        return out

    def write(self, directory) -> list[Path]:
        """Write the file(s) into ``directory`` (created if missing; each file atomically).

        Returns
        -------
        list of Path
        """
        from simplexspline.spline.io import atomic_write

        directory = Path(directory)
        if directory.exists() and not directory.is_dir():
            raise InputError(f"{str(directory)!r} exists and is not a directory")
        if not directory.parent.is_dir():
            raise InputError(f"the parent of output directory {str(directory)!r} does not "
                             "exist")
        directory.mkdir(exist_ok=True)
        paths = []
        for name, text in self.files.items():
            path = directory / name

            def write(tmp, text=text):
                with open(tmp, "w", encoding="ascii", newline="\n") as fh:
                    fh.write(text)
            atomic_write(path, write)
            paths.append(path)
        return paths


# ---------------------------------------------------------------------- Python twin
def domain_box(triangulation) -> tuple[np.ndarray, np.ndarray]:
    """The box of the ``'clamp'`` policy: the grid box of grid/fit triangulations, else the
    bounding box of the vertices; two arrays of shape (n,)."""
    loc = triangulation._locator
    if isinstance(loc, GridLocator):
        return loc.lower.copy(), loc.upper.copy()
    return triangulation.vertices.min(axis=0), triangulation.vertices.max(axis=0)


def reference_evaluate(spline, x, *, outside: str = "nan", gradient: bool = True):
    """Evaluate a spline exactly as the generated C code does (numpy).

    Parameters
    ----------
    spline : SimplexSpline
    x : array_like, shape (N, n)
        Finite points.
    outside : {'nan', 'clamp', 'extrapolate'}
        See the module docstring.
    gradient : bool
        Also return the gradient.

    Returns
    -------
    values : ndarray, shape (N,)
    gradients : ndarray, shape (N, n), or None
    outside : ndarray of bool, shape (N,)
        The point lies outside the triangulation (whatever the policy).
    """
    from simplexspline.spline.validation import as_points

    _check_policy(outside)
    tri = spline.triangulation
    pts = as_points(x, name="x", ndim=tri.ndim)
    out = tri.locate(pts) < 0
    if outside == "clamp":
        lo, hi = domain_box(tri)
        pts = np.clip(pts, lo, hi)
    policy = "nan" if outside == "nan" else "extrapolate"
    values = spline.predict(pts, outside=policy)
    grads = spline.gradient(pts, outside=policy) if gradient else None
    return values, grads, out


def _check_policy(outside: str) -> int:
    if outside not in POLICIES:
        raise InputError(f"outside must be one of {POLICIES}, got {outside!r}")
    return POLICIES.index(outside)


# ---------------------------------------------------------------------- C text helpers
def _num(v) -> str:
    """A double literal that converts back to exactly ``v``."""
    v = float(v)
    if not math.isfinite(v):
        raise InputError(f"cannot export the non-finite number {v!r}")
    return repr(v)


def c_array(ctype: str, name: str, values, *, per_line: int | None = None) -> str:
    """``static const <ctype> name[N] = {...};`` for a 1-D sequence (flattened)."""
    flat = np.asarray(values).ravel()
    if ctype == "double":
        items = [_num(v) for v in flat.tolist()]
        per_line = per_line or 4
    else:
        items = [str(int(v)) for v in flat.tolist()]
        per_line = per_line or 12
    if not items:
        raise AssertionError(f"empty C array {name}")  # ISO C has no empty arrays
    lines = [", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line)]
    body = ",\n    ".join(lines)
    return f"static const {ctype} {name}[{len(items)}] = {{\n    {body}\n}};\n"


def c_comment(text: str, *, width: int = 88) -> str:
    """A C block comment holding ``text`` (ASCII, no comment terminators)."""
    text = text.encode("ascii", "backslashreplace").decode().replace("*/", "* /")
    out = ["/*"]
    for para in text.splitlines():
        if not para.strip():
            out.append(" *")
            continue
        indent = len(para) - len(para.lstrip())
        line = ""
        for word in para.split():
            if line and len(line) + 1 + len(word) > width - 3:
                out.append(" * " + line)
                line = " " * indent
            line = (line + " " + word) if line.strip() else (" " * indent + word)
        out.append(" * " + line)
    out.append(" */")
    return "\n".join(out) + "\n"


def _fill(template: str, **subs) -> str:
    """Replace ``@KEY@`` placeholders (``@T@``, the internal tag, may stay for later)."""
    for key, val in subs.items():
        template = template.replace(f"@{key}@", str(val))
    left = set(re.findall(r"@([A-Z0-9]+)@", template)) - {"T"}
    if left:
        raise AssertionError(f"unfilled placeholders {sorted(left)}")
    return template


# ---------------------------------------------------------------------- the core
def _piece_body(n: int, d: int) -> str:
    """Statements computing g[0..n] (see the module docstring) from b and c."""
    step = _step_table(n, d)  # (d_hat(d-1), n+1): position of kappa + e_i
    m = d - 1
    lines = [f"    for (i = 0; i < {n + 1}; ++i) g[i] = 0.0;"]
    if m == 0:
        basis = ["1.0"]
    else:
        parents, firsts, offsets, scale = kernels.basis_plan(n, m)
        prev = "b"
        for level in range(len(offsets) - 1):
            s, e = offsets[level], offsets[level + 1]
            name = f"q{level + 2}"
            lines.append(f"    {{ double *w = {name};")
            for k in range(e - s):
                lines.append(f"      w[{k}] = {prev}[{parents[s + k]}] * b[{firsts[s + k]}];")
            lines.append("    }")
            prev = name
        basis = [f"{_num(sc)} * {prev}[{k}]" if sc != 1.0 else f"{prev}[{k}]"
                 for k, sc in enumerate(scale.tolist())]
    for k, bk in enumerate(basis):
        terms = " ".join(f"g[{i}] += c[{int(step[k, i])}] * s;" for i in range(n + 1))
        lines.append(f"    s = {bk}; {terms}")
    return "\n".join(lines)


def _piece(n: int, d: int, dhat: int) -> str:
    if d == 0:
        return _fill("""
static void @T@_piece(long j, const double x[], double *value, double grad[])
{
    int k;
    (void)x;
    if (value) *value = @T@_coef[j];
    if (grad) for (k = 0; k < @N@; ++k) grad[k] = 0.0;
}
""", N=n)
    levels = "".join(f" q{lv}[{num_basis(n, lv)}]," for lv in range(2, d))
    return _fill("""
static void @T@_piece(long j, const double x[], double *value, double grad[])
{
    const double *o = @T@_origin + j * @N@;
    const double *t = @T@_tinv + j * @NN@;
    const double *c = @T@_coef + j * @DH@;
    double b[@N1@], g[@N1@],@LEVELS@ acc, s, total = 0.0;
    int i, k;
    for (i = 0; i < @N@; ++i) {
        acc = 0.0;
        for (k = 0; k < @N@; ++k) acc += t[i * @N@ + k] * (x[k] - o[k]);
        b[i + 1] = acc;
        total += acc;
    }
    b[0] = 1.0 - total;
@BODY@
    if (value) {
        acc = 0.0;
        for (i = 0; i < @N1@; ++i) acc += b[i] * g[i];
        *value = acc;
    }
    if (grad) {
        for (k = 0; k < @N@; ++k) {
            acc = 0.0;
            for (i = 0; i < @N@; ++i) acc += t[i * @N@ + k] * (g[i + 1] - g[0]);
            grad[k] = @D@ * acc;
        }
    }
}
""", N=n, NN=n * n, N1=n + 1, DH=dhat, D=_num(d), LEVELS=levels, BODY=_piece_body(n, d))


_GRID_LOCATE = """
static long @T@_locate(const double x[])
{
    double rel[@N@], r;
    long flat = 0, c, rank = 0;
    int k, a, q, p, pos[@N@], perm[@N@];
    for (k = 0; k < @N@; ++k) {
        r = (x[k] - @T@_glower[k]) / @T@_gstep[k];
        if (!(r >= @T@_glo[k] && r <= @T@_ghi[k])) return -1;
        c = (long)floor(r);
        if (c < 0) c = 0;
        if (c > @T@_gshape[k] - 1) c = @T@_gshape[k] - 1;
        rel[k] = r - (double)c;
        flat = flat * @T@_gshape[k] + c;
    }
    /* the permutation sorting rel descending (ties: lower axis first), then its rank */
    for (a = 0; a < @N@; ++a) {
        p = 0;
        for (q = 0; q < @N@; ++q) p += (rel[q] > rel[a]) || (rel[q] == rel[a] && q < a);
        pos[a] = p;
    }
    for (a = 0; a < @N@; ++a) perm[pos[a]] = a;
    for (k = 0; k < @N@ - 1; ++k) {
        p = 0;
        for (q = k + 1; q < @N@; ++q) p += perm[q] < perm[k];
        rank += p * @T@_fact[k];
    }
    return @LOOKUP@;
}
"""

_BUCKET_LOCATE = """
static long @T@_locate(const double x[])
{
    long bucket = 0, c, p;
    int k;
    for (k = 0; k < @N@; ++k)
        if (!(x[k] >= @T@_inlo[k] && x[k] <= @T@_inhi[k])) return -1;
    for (k = 0; k < @N@; ++k) {
        c = (long)floor((x[k] - @T@_blower[k]) / @T@_bwidth[k]);
        if (c < 0) c = 0;
        if (c > @T@_nb[k] - 1) c = @T@_nb[k] - 1;
        bucket = bucket * @T@_nb[k] + c;
    }
    for (p = @T@_bptr[bucket]; p < @T@_bptr[bucket + 1]; ++p)
        if (@T@_bmin(@T@_bidx[p], x) >= -@TOL@) return @T@_bidx[p];
    return -1;
}
"""

_HELPERS = """
/* smallest barycentric coordinate of x in simplex j */
static double @T@_bmin(long j, const double x[])
{
    const double *o = @T@_origin + j * @N@;
    const double *t = @T@_tinv + j * @NN@;
    double acc, low = HUGE_VAL, total = 0.0;
    int i, k;
    for (i = 0; i < @N@; ++i) {
        acc = 0.0;
        for (k = 0; k < @N@; ++k) acc += t[i * @N@ + k] * (x[k] - o[k]);
        total += acc;
        if (acc < low) low = acc;
    }
    acc = 1.0 - total;
    return acc < low ? acc : low;
}

/* the simplex to extrapolate from: among the @K@ nearest centroids, the least outside */
static long @T@_nearest(const double x[])
{
    double dist[@K@], d2, diff, best, low;
    long cand[@K@], j, out;
    int k, filled = 0, at;
    for (j = 0; j < @J@; ++j) {
        d2 = 0.0;
        for (k = 0; k < @N@; ++k) {
            diff = x[k] - @T@_centroid[j * @N@ + k];
            d2 += diff * diff;
        }
        if (filled == @K@ && !(d2 < dist[@K@ - 1])) continue;
        at = filled < @K@ ? filled++ : @K@ - 1;
        while (at > 0 && dist[at - 1] > d2) {
            dist[at] = dist[at - 1];
            cand[at] = cand[at - 1];
            --at;
        }
        dist[at] = d2;
        cand[at] = j;
    }
    out = cand[0];
    best = -HUGE_VAL;
    for (k = 0; k < filled; ++k) {
        low = @T@_bmin(cand[k], x);
        if (low > best) {
            best = low;
            out = cand[k];
        }
    }
    return out;
}

static void @T@_fill(double *value, double grad[], double v)
{
    int k;
    if (value) *value = v;
    if (grad) for (k = 0; k < @N@; ++k) grad[k] = v;
}
"""

_CORE = """
/* status: 0 inside, 1 outside (value per policy), -1 bad input (NaN outputs) */
static int @T@_core(const double x[], int policy, double *value, double grad[])
{
    double y[@N@];
    long j;
    int k, moved = 0, missed;
    for (k = 0; k < @N@; ++k)
        if (!isfinite(x[k])) policy = -1;
    if (policy < 0 || policy > 2) {
        @T@_fill(value, grad, NAN);
        return -1;
    }
    if (policy == 1) { /* clamp to the domain box, then extrapolate if still outside */
        for (k = 0; k < @N@; ++k) {
            y[k] = x[k] < @T@_boxlo[k] ? @T@_boxlo[k] : (x[k] > @T@_boxhi[k] ? @T@_boxhi[k] : x[k]);
            moved |= y[k] != x[k];
        }
        j = @T@_locate(y);
        missed = j < 0;
        if (missed) j = @T@_nearest(y);
        @T@_piece(j, y, value, grad);
        return moved ? @T@_locate(x) < 0 : missed;
    }
    j = @T@_locate(x);
    if (j >= 0) {
        @T@_piece(j, x, value, grad);
        return 0;
    }
    if (policy == 0) {
        @T@_fill(value, grad, NAN);
        return 1;
    }
    @T@_piece(@T@_nearest(x), x, value, grad);
    return 1;
}
"""


def c_core(spline, tag: str) -> str:
    """C text of the evaluation core: ``static const`` tables and ``static`` functions
    named ``<tag>_*``, the entry point being
    ``static int <tag>_core(const double x[n], int policy, double *value, double grad[n])``
    (policy 0 nan, 1 clamp, 2 extrapolate; returns 0 inside, 1 outside, -1 bad input) and
    ``static long <tag>_locate(const double x[n])`` (simplex index or -1). Needs
    ``<math.h>``."""
    tri = spline.triangulation
    n, d, nsimp = tri.ndim, spline.degree, tri.nsimplex
    dhat = spline.coefficients.shape[1]
    loc = tri._locator
    box_lo, box_hi = domain_box(tri)
    parts = [
        f"/* ---- tables: {nsimp} simplices, degree {d}, {dhat} B-coefficients each */\n",
        c_array("double", f"{tag}_coef", spline.coefficients),
        c_array("double", f"{tag}_origin", tri._origin),
        c_array("double", f"{tag}_tinv", tri._tinv),
        c_array("double", f"{tag}_centroid", tri.centroids()),
        c_array("double", f"{tag}_boxlo", box_lo),
        c_array("double", f"{tag}_boxhi", box_hi),
    ]
    if isinstance(loc, GridLocator):
        shape = loc.shape
        nfact = math.factorial(n)
        fact = [math.factorial(n - 1 - k) for k in range(n)]
        # the bounds of kernels.grid_locate (the compiled path of Python's locate)
        glo = [-INSIDE_TOL * float(s) for s in shape]
        ghi = [float(s) * (1.0 + INSIDE_TOL) for s in shape]
        parts += [c_array("double", f"{tag}_glower", loc.lower),
                  c_array("double", f"{tag}_gstep", loc.step),
                  c_array("double", f"{tag}_glo", glo), c_array("double", f"{tag}_ghi", ghi),
                  c_array("long", f"{tag}_gshape", shape), c_array("long", f"{tag}_fact", fact)]
        full = np.array_equal(loc.table, np.arange(len(loc.table)))
        if full:
            lookup = f"flat * {nfact} + rank"
        else:
            parts.append(c_array("int", f"{tag}_gtable", loc.table))
            lookup = f"{tag}_gtable[flat * {nfact} + rank]"
        locate = _fill(_GRID_LOCATE, LOOKUP=lookup, N=n)
    elif isinstance(loc, BucketLocator):
        tol = INSIDE_TOL * (loc.upper - loc.lower + 1.0)
        parts += [c_array("double", f"{tag}_inlo", loc.lower - tol),
                  c_array("double", f"{tag}_inhi", loc.upper + tol),
                  c_array("double", f"{tag}_blower", loc.lower),
                  c_array("double", f"{tag}_bwidth", loc.width),
                  c_array("long", f"{tag}_nb", loc.nb),
                  c_array("long", f"{tag}_bptr", loc.indptr),
                  c_array("long", f"{tag}_bidx", loc.indices)]
        locate = _fill(_BUCKET_LOCATE, N=n, TOL=_num(INSIDE_TOL))
    else:  # pragma: no cover - no other locator exists
        raise InputError(f"cannot export a triangulation located by {type(loc).__name__}")
    helpers = _fill(_HELPERS, N=n, NN=n * n, K=min(NEAREST_K, nsimp), J=nsimp)
    parts += ["\n/* ---- evaluation */\n", _piece(n, d, dhat), helpers, locate,
              _fill(_CORE, N=n)]
    return "".join(parts).replace("@T@", tag)


# ---------------------------------------------------------------------- public API text
_SPLINE_DECLS = """
#define @U@_NDIM @N@                    /* number of inputs n */
#define @U@_NSIMPLEX @J@
#define @U@_INSIDE 0                    /* status codes */
#define @U@_OUTSIDE 1
#define @U@_BADINPUT (-1)
#define @U@_POLICY_NAN 0                /* outside policies */
#define @U@_POLICY_CLAMP 1
#define @U@_POLICY_EXTRAPOLATE 2
#define @U@_POLICY_DEFAULT @U@_POLICY_@DEFAULT@

/* Value and gradient at x with the default outside policy. value and/or grad may be
   NULL. Returns @U@_INSIDE, @U@_OUTSIDE (the value follows the policy: NaN, clamped or
   extrapolated) or @U@_BADINPUT (NaN/inf input: NaN outputs). */
int @P@_eval(const double x[@U@_NDIM], double *value, double grad[@U@_NDIM]);

/* The same with a given policy (@U@_POLICY_*); @U@_BADINPUT for an unknown policy. */
int @P@_eval_policy(const double x[@U@_NDIM], int policy, double *value,
                    double grad[@U@_NDIM]);

/* Index of the simplex containing x (the same as Triangulation.locate), -1 outside. */
long @P@_locate(const double x[@U@_NDIM]);

/* npts points, row-major x[npts][@U@_NDIM]: values[npts] and grads[npts][@U@_NDIM]
   (either may be NULL). Returns the number of points not inside (outside or bad input),
   or -1 for an unknown policy. */
long @P@_eval_points(long npts, const double *x, int policy, double *values,
                     double *grads);
"""

_SPLINE_DEFS = """
/* ---- public API */
int @P@_eval(const double x[@U@_NDIM], double *value, double grad[@U@_NDIM])
{
    return @T@_core(x, @U@_POLICY_DEFAULT, value, grad);
}

int @P@_eval_policy(const double x[@U@_NDIM], int policy, double *value,
                    double grad[@U@_NDIM])
{
    return @T@_core(x, policy, value, grad);
}

long @P@_locate(const double x[@U@_NDIM])
{
    return @T@_locate(x);
}

long @P@_eval_points(long npts, const double *x, int policy, double *values,
                     double *grads)
{
    long i, count = 0;
    if (policy < 0 || policy > 2) return -1;
    for (i = 0; i < npts; ++i)
        count += @P@_eval_policy(x + i * @U@_NDIM, policy, values ? values + i : (double *)0,
                                 grads ? grads + i * @U@_NDIM : (double *)0) != @U@_INSIDE;
    return count;
}
"""


def assemble(prefix: str, comment: str, decls: str, impl: str, *,
             single_header: bool) -> CSource:
    """Wrap declarations and implementation text into a :class:`CSource`."""
    upper = prefix.upper()
    guard = f"{upper}_H"
    head = (f"{comment}\n#ifndef {guard}\n#define {guard}\n\n#ifdef __cplusplus\n"
            f"extern \"C\" {{\n#endif\n{decls}\n#ifdef __cplusplus\n}}\n#endif\n\n"
            f"#endif /* {guard} */\n")
    body = f"#include <math.h>\n{impl}"
    if single_header:
        header = (f"{head}\n#ifdef {upper}_IMPLEMENTATION\n#ifndef {upper}_IMPLEMENTED\n"
                  f"#define {upper}_IMPLEMENTED\n{body}\n#endif\n#endif "
                  f"/* {upper}_IMPLEMENTATION */\n")
        return CSource(prefix, header, None)
    source = f"{comment}\n#include \"{prefix}.h\"\n{body}"
    return CSource(prefix, head, source)


def generate_c(spline, prefix: str = "spline", *, outside: str = "nan",
               single_header: bool = False, description: str | None = None) -> CSource:
    """Generate C99 code evaluating ``spline`` (value and exact gradient).

    Parameters
    ----------
    spline : SimplexSpline
    prefix : str
        Prefix of the public identifiers and file names: the functions
        ``<prefix>_eval``, ``<prefix>_eval_policy``, ``<prefix>_locate`` and
        ``<prefix>_eval_points`` (see the generated header).
    outside : {'nan', 'clamp', 'extrapolate'}
        The compiled-in default outside policy of ``<prefix>_eval``.
    single_header : bool
        One header file (stb style: define ``<PREFIX>_IMPLEMENTATION`` in one file before
        including it) instead of ``.h`` + ``.c``.
    description : str, optional
        Extra text for the header comment.

    Returns
    -------
    CSource

    Examples
    --------
    >>> from simplexspline import SimplexSpline, Triangulation
    >>> tri = Triangulation.grid([0.0], [1.0], 2)
    >>> s = SimplexSpline(tri, 1, 0, [[0.0, 1.0], [1.0, 3.0]])
    >>> code = generate_c(s, "ramp")
    >>> sorted(code.files)
    ['ramp.c', 'ramp.h']
    >>> "int ramp_eval(const double x[RAMP_NDIM]" in code.header
    True
    """
    from simplexspline import __version__

    prefix = c_identifier(prefix)
    _check_policy(outside)
    tri = spline.triangulation
    n = tri.ndim
    variables = spline.metadata.get("variables")
    if not (isinstance(variables, (list, tuple)) and len(variables) == n):
        variables = [f"x{k}" for k in range(n)]
    lo, hi = domain_box(tri)
    method = ("Kuhn grid, O(1)" if isinstance(tri._locator, GridLocator)
              else "bucket grid")
    text = (f"{prefix}: a simplex spline S^{spline.continuity}_{spline.degree} in {n} "
            f"variable(s), {tri.nsimplex} simplices ({tri.kind} triangulation), generated "
            f"by simplexspline {__version__}. Do not edit.\n\n"
            f"Inputs x[0..{n - 1}]: {', '.join(map(str, variables))}.\n"
            f"Domain box: {_box_text(lo, hi)}.\n"
            f"Point location: {method}, the same rule as Triangulation.locate (a point is "
            f"inside a simplex when its smallest barycentric coordinate is >= "
            f"-{INSIDE_TOL!r}).\n"
            f"Default outside policy: {outside}.\n"
            "C99, needs only <math.h> (link with -lm); no allocation, no state "
            "(thread-safe).")
    if description:
        text += "\n\n" + description
    comment = c_comment(text)
    subs = dict(P=prefix, U=prefix.upper(), N=n, J=tri.nsimplex, T=f"{prefix}_impl",
                DEFAULT=outside.upper())
    decls = _fill(_SPLINE_DECLS, **subs)
    impl = c_core(spline, f"{prefix}_impl") + _fill(_SPLINE_DEFS, **subs)
    return assemble(prefix, comment, decls, impl, single_header=single_header)


def _box_text(lo, hi) -> str:
    return ", ".join(f"[{float(a)!r}, {float(b)!r}]" for a, b in zip(lo, hi))
