"""The evaluation core of the C99 code exported for a spline.

:func:`c_core` writes the part of the generated code that does the work: the
``static const`` tables of the spline (B-coefficients, the simplices' barycentric maps,
centroids, the domain box and the point-location tables) and the ``static`` functions that
locate a point, evaluate one polynomial piece with its gradient and apply the outside
policy. :mod:`simplexspline.spline.formats.c_export` wraps it into a public API (header and source);
:mod:`simplexspline.aero.export.c_code` wraps it with the variable scaling of an aerodynamic
model.

* Point location follows :meth:`Triangulation.locate` rule for rule: a Kuhn grid by a floor
  and the sorting permutation, any other triangulation by the buckets of
  :class:`~simplexspline.spline.geometry.location.BucketLocator`.
* ``'extrapolate'`` uses the polynomial of :meth:`Triangulation.nearest` (the least-outside
  simplex among the :data:`NEAREST_K` with the nearest centroids); ``'clamp'`` first clamps
  to :func:`domain_box`.
* The value and gradient come from one de Casteljau step: with
  ``g_i = sum_{|k| = d-1} c_{k + e_i} B^{d-1}_k(b)`` the value is ``sum_i b_i g_i`` and
  ``ds/db_i = d g_i``; the chain rule with the simplex's (constant) barycentric Jacobian
  gives the Cartesian gradient.

Also the helpers that write C text: :func:`c_array` (numbers in Python's shortest
round-trip representation, so the compiled tables hold exactly the model's doubles) and
:func:`c_comment`.
"""

from __future__ import annotations

import math
import re

import numpy as np

from simplexspline.errors import InputError
from simplexspline.spline import kernels
from simplexspline.spline.bform import step_table, num_basis
from simplexspline.spline.geometry.location import INSIDE_TOL, BucketLocator, GridLocator

__all__ = ["NEAREST_K", "c_array", "c_comment", "c_core", "domain_box"]

#: Candidates of the nearest-simplex search (as :meth:`Triangulation.nearest`).
NEAREST_K = 8


def domain_box(triangulation) -> tuple[np.ndarray, np.ndarray]:
    """The box of the ``'clamp'`` policy: the grid box of grid/fit triangulations, else the
    bounding box of the vertices; two arrays of shape (n,)."""
    loc = triangulation._locator
    if isinstance(loc, GridLocator):
        return loc.lower.copy(), loc.upper.copy()
    return triangulation.vertices.min(axis=0), triangulation.vertices.max(axis=0)


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


def c_string(text: str) -> str:
    r"""``text`` as a C string literal that any C compiler reads back as the same bytes.

    Printable ASCII stays as it is except ``"``, ``\`` and ``?`` (trigraphs such as
    ``??/`` would otherwise become a backslash); those, control characters and the UTF-8
    bytes of non-ASCII characters are written as three-digit octal escapes, which never
    absorb a following character.

    >>> print(c_string('a"b??/'))
    "a\042b\077\077/"
    """
    out = []
    for byte in str(text).encode("utf-8"):
        char = chr(byte)
        out.append(char if 32 <= byte < 127 and char not in '"\\?' else f"\\{byte:03o}")
    return '"' + "".join(out) + '"'


def c_comment(text: str, *, width: int = 88) -> str:
    """A C block comment holding ``text``: ASCII, with no comment terminator and no trigraph
    (``??`` becomes ``? ?``) left in it."""
    text = (text.encode("ascii", "backslashreplace").decode().replace("*/", "* /")
            .replace("??", "? ?").replace("??", "? ?"))
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


def fill_template(template: str, **subs) -> str:
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
    step = step_table(n, d)  # (d_hat(d-1), n+1): position of kappa + e_i
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
        return fill_template("""
static void @T@_piece(long j, const double x[], double *value, double grad[])
{
    int k;
    (void)x;
    if (value) *value = @T@_coef[j];
    if (grad) for (k = 0; k < @N@; ++k) grad[k] = 0.0;
}
""", N=n)
    levels = "".join(f" q{lv}[{num_basis(n, lv)}]," for lv in range(2, d))
    return fill_template("""
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

static void @T@fill_template(double *value, double grad[], double v)
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
        @T@fill_template(value, grad, NAN);
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
        @T@fill_template(value, grad, NAN);
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
    # the C code locates with the Kuhn grid or the bucket grid (not the compiled walk)
    loc = tri._locator if isinstance(tri._locator, GridLocator) else tri._buckets
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
        locate = fill_template(_GRID_LOCATE, LOOKUP=lookup, N=n)
    elif isinstance(loc, BucketLocator):
        tol = INSIDE_TOL * (loc.upper - loc.lower + 1.0)
        parts += [c_array("double", f"{tag}_inlo", loc.lower - tol),
                  c_array("double", f"{tag}_inhi", loc.upper + tol),
                  c_array("double", f"{tag}_blower", loc.lower),
                  c_array("double", f"{tag}_bwidth", loc.width),
                  c_array("long", f"{tag}_nb", loc.nb),
                  c_array("long", f"{tag}_bptr", loc.indptr),
                  c_array("long", f"{tag}_bidx", loc.indices)]
        locate = fill_template(_BUCKET_LOCATE, N=n, TOL=_num(INSIDE_TOL))
    else:  # pragma: no cover - no other locator exists
        raise InputError(f"cannot export a triangulation located by {type(loc).__name__}")
    helpers = fill_template(_HELPERS, N=n, NN=n * n, K=min(NEAREST_K, nsimp), J=nsimp)
    parts += ["\n/* ---- evaluation */\n", _piece(n, d, dhat), helpers, locate,
              fill_template(_CORE, N=n)]
    return "".join(parts).replace("@T@", tag)
