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
  :class:`~simplexspline.spline.geometry.location.BucketLocator` (the same buckets, the same candidate
  order, the same tolerance), so each point tests only its bucket's few simplices.

Outside policies (chosen per call; a default is compiled in):

* ``'nan'``: NaN value and gradient (as :meth:`SimplexSpline.predict`);
* ``'clamp'``: the point is clamped to the domain box (the grid box of grid/fit
  triangulations, the vertices' bounding box otherwise), then evaluated like
  ``'extrapolate'`` (a clamped point can still lie outside the simplices);
* ``'extrapolate'``: the polynomial of :meth:`Triangulation.nearest` (the least-outside
  simplex among the 8 with the nearest centroids, found by a scan of all centroids).

:func:`reference_evaluate` is the same computation in Python (numpy), for tables and tests.

The evaluation core (tables, point location, the B-form) is written by
:mod:`simplexspline.spline.formats.c_templates`; this module wraps it into the public API.

The value and gradient come from one de Casteljau step: with
``g_i = sum_{|k| = d-1} c_{k + e_i} B^{d-1}_k(b)`` the value is ``sum_i b_i g_i`` and
``ds/db_i = d g_i``; the chain rule with the simplex's (constant) barycentric Jacobian gives
the Cartesian gradient.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simplexspline._files import write_bytes
from simplexspline.errors import InputError
from simplexspline.spline.formats.c_templates import fill_template, c_comment, c_core, domain_box
from simplexspline.spline.geometry.location import INSIDE_TOL, GridLocator
from simplexspline.spline.geometry.outside import EXPORT_POLICIES, check_policy
from simplexspline.spline.inputs import as_points

__all__ = ["CSource", "RESERVED", "assemble", "c_identifier", "generate_c",
           "reference_evaluate"]


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
            write_bytes(path, text.encode("ascii"))
            paths.append(path)
        return paths



# ---------------------------------------------------------------------- Python twin
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
    """The C code of an outside policy: its position in ``EXPORT_POLICIES`` (0, 1, 2)."""
    return EXPORT_POLICIES.index(check_policy(outside, EXPORT_POLICIES))


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
    from simplexspline._version import __version__

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
    decls = fill_template(_SPLINE_DECLS, **subs)
    impl = c_core(spline, f"{prefix}_impl") + fill_template(_SPLINE_DEFS, **subs)
    return assemble(prefix, comment, decls, impl, single_header=single_header)


def _box_text(lo, hi) -> str:
    return ", ".join(f"[{float(a)!r}, {float(b)!r}]" for a, b in zip(lo, hi))
