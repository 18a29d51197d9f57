"""C99 export of splines: compiled with the system C compiler, the generated code locates
points exactly as Triangulation.locate and matches SimplexSpline.predict / gradient to 1e-12
of the coefficient scale, inside, on facets and vertices, and outside (every policy)."""

from __future__ import annotations

import ctypes
import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from simplexspline import InputError, SimplexSpline, Triangulation
from simplexspline.spline.formats.c_export import generate_c, reference_evaluate
from simplexspline.spline.formats.c_templates import domain_box

from . import reference as ref
from .cases import delaunay_points, seeded

CC = shutil.which("cc") or ("/usr/bin/cc" if Path("/usr/bin/cc").exists() else None)
FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2"]
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
RTOL = 1e-12
POLICY = {"nan": 0, "clamp": 1, "extrapolate": 2}


def _fitted(tri, d, r, rng, npts=None):
    n = tri.ndim
    x, _ = ref.points_in_simplices(tri.vertices, tri.simplices, 2 * math.comb(d + n, n), rng)
    y = np.sin(x @ np.linspace(1.0, 2.0, n)) + 0.3 * (x**2).sum(axis=1)
    return SimplexSpline.fit(x, y, tri, d, r)


def _random(tri, d, r, rng, scale=1.0):
    coef = scale * rng.standard_normal((tri.nsimplex, math.comb(d + tri.ndim, tri.ndim)))
    return SimplexSpline(tri, d, r, coef)


def _cases():
    rng = seeded("export-cases")
    out = {}
    out["g1"] = _fitted(Triangulation.grid([-1.0], [2.0], 5), 4, 2, rng)
    out["g2"] = _fitted(Triangulation.grid([0.0, -1.0], [1.0, 2.0], (3, 4)), 3, 1, rng)
    x2 = rng.uniform(0, 1, (400, 2))
    x2 = x2[np.hypot(x2[:, 0] - 0.5, x2[:, 1] - 0.5) < 0.5]
    out["f2"] = _random(Triangulation.fit(x2, (4, 4), min_points=3), 2, 1, rng, 1e3)
    out["d2"] = _random(Triangulation.delaunay(rng.uniform(-1, 1, (30, 2))), 2, 0, rng)
    out["b2"] = _random(Triangulation.delaunay(rng.uniform(0, 3, (300, 2))), 1, 0, rng)
    out["c0"] = _random(Triangulation.grid([0, 0], [1, 1], (2, 2)), 0, -1, rng)
    V, S = ref.star_triangulation(3, rng)
    out["e3"] = _random(Triangulation(V, S), 3, 2, rng)
    x3 = rng.uniform(-1, 1, (600, 3))
    x3 = x3[x3.sum(axis=1) < 0.8]
    tri3 = Triangulation.fit(x3, (2, 2, 2), min_points=8)
    out["f3"] = _fitted(tri3, 3, 1, rng)
    out["d3"] = _random(Triangulation.delaunay(delaunay_points(3, rng)), 1, 0, rng)
    out["g4"] = _random(Triangulation.grid(np.zeros(4), np.arange(1.0, 5.0), (2, 1, 1, 2)),
                        2, 1, rng)
    out["d4"] = _random(Triangulation.delaunay(delaunay_points(4, rng)), 3, 1, rng, 10.0)
    out["g5"] = _random(Triangulation.grid(-np.ones(5), np.ones(5), 1), 3, 1, rng)
    out["d5"] = _random(Triangulation.delaunay(delaunay_points(5, rng)), 2, 1, rng)
    return out


CASES = _cases()
DEFAULTS = {"f3": "clamp", "d4": "extrapolate"}  # compiled-in default policies


class Lib:
    """ctypes front end of the compiled cases."""

    def __init__(self, path):
        self.lib = ctypes.CDLL(str(path))

    def _fn(self, name, restype):
        f = getattr(self.lib, name)
        f.restype = restype
        return f

    def points(self, prefix, x, policy):
        x = np.ascontiguousarray(x, dtype=float)
        n = x.shape[1]
        v, g = np.empty(len(x)), np.empty((len(x), n))
        ptr = ctypes.c_void_p
        count = self._fn(f"{prefix}_eval_points", ctypes.c_long)(
            ctypes.c_long(len(x)), ptr(x.ctypes.data), ctypes.c_int(policy),
            ptr(v.ctypes.data), ptr(g.ctypes.data))
        return v, g, count

    def one(self, prefix, x, policy=None):
        x = np.ascontiguousarray(x, dtype=float)
        v, g = ctypes.c_double(), (ctypes.c_double * len(x))()
        xp = x.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        if policy is None:
            status = self._fn(f"{prefix}_eval", ctypes.c_int)(xp, ctypes.byref(v), g)
        else:
            status = self._fn(f"{prefix}_eval_policy", ctypes.c_int)(
                xp, ctypes.c_int(policy), ctypes.byref(v), g)
        return status, v.value, np.array(g[:])

    def locate(self, prefix, x):
        f = self._fn(f"{prefix}_locate", ctypes.c_long)
        x = np.ascontiguousarray(x, dtype=float)
        return np.array([f(row.ctypes.data_as(ctypes.POINTER(ctypes.c_double))) for row in x])


def compile_shared(sources, out: Path) -> Path:
    res = subprocess.run([CC, *FLAGS, "-fPIC", "-shared", "-o", str(out), *map(str, sources),
                          "-lm"], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[:4000]
    return out


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    if CC is None:
        pytest.skip("no C compiler ('cc') on this machine")
    root = tmp_path_factory.mktemp("cexport")
    sources = []
    for prefix, spline in CASES.items():
        code = generate_c(spline, prefix, outside=DEFAULTS.get(prefix, "nan"))
        paths = code.write(root / prefix)
        sources.append(next(p for p in paths if p.suffix == ".c"))
    return Lib(compile_shared(sources, root / "libcases.so"))


# ---------------------------------------------------------------------- test points
def sample_points(spline, rng):
    """Inside, on vertices, on shared and boundary facets, on Kuhn-cell diagonals (ties of
    the local coordinates), on the box faces, and outside."""
    tri = spline.triangulation
    n = tri.ndim
    x_in, _ = ref.points_in_simplices(tri.vertices, tri.simplices, 6, rng)
    parts = [x_in, tri.vertices]
    corners = np.asarray(tri.corners)
    for i in range(n + 1):  # the facet opposite local vertex i of every simplex
        facet = np.delete(corners, i, axis=1)
        w = rng.dirichlet(np.ones(n), size=len(facet))
        parts += [facet.mean(axis=1), np.einsum("jk,jkn->jn", w, facet)]
    lo, hi = domain_box(tri)
    span = hi - lo
    loc = tri._locator
    if hasattr(loc, "step"):  # cell diagonals: several equal local coordinates
        cell = rng.integers(0, loc.shape, size=(200, n))
        t = rng.uniform(0, 1, (200, 1))
        local = np.where(rng.uniform(size=(200, n)) < 0.6, t, rng.uniform(0, 1, (200, n)))
        parts.append(loc.lower + (cell + local) * loc.step)
    face = rng.uniform(lo, hi, (100, n))
    axis = rng.integers(0, n, 100)
    face[np.arange(100), axis] = np.where(rng.uniform(size=100) < 0.5, lo[axis], hi[axis])
    parts.append(face)
    parts.append(face + rng.choice([-1e-13, 1e-13], size=face.shape) * span)
    parts.append(rng.uniform(lo - 0.3 * span, hi + 0.3 * span, (600, n)))
    return np.vstack(parts)


def error_scale(spline, x, sid):
    """Bounds of |value| and |gradient| computed from the B-form terms: max|c| (sum|b|)^d
    (1 inside a simplex) and its derivative; rounding errors are relative to these."""
    tri = spline.triangulation
    b = tri.barycentric(x, sid)
    cmax = np.abs(spline.coefficients[sid]).max(axis=1)
    s = np.abs(b).sum(axis=1)
    d = spline.degree
    vscale = cmax * s**d
    jac = np.abs(tri._tinv[sid]).sum(axis=1).max(axis=1) * 2  # |d b_i / dx| summed
    gscale = d * cmax * s ** max(d - 1, 0) * jac
    return vscale, gscale


def used_simplex(spline, x, outside):
    tri = spline.triangulation
    if outside == "clamp":
        lo, hi = domain_box(tri)
        x = np.clip(x, lo, hi)
    sid = tri.locate(x)
    bad = sid < 0
    if np.any(bad):
        sid[bad] = tri.nearest(x[bad])
    return x, sid


def assert_close(spline, x, outside, v, g, rv, rg):
    np.testing.assert_array_equal(np.isnan(v), np.isnan(rv))
    np.testing.assert_array_equal(np.isnan(g), np.isnan(rg))
    ok = ~np.isnan(rv)
    xe, sid = used_simplex(spline, x[ok], outside)
    vs, gs = error_scale(spline, xe, sid)
    assert np.all(np.abs(v[ok] - rv[ok]) <= RTOL * vs), np.max(np.abs(v[ok] - rv[ok]) / vs)
    err = np.abs(g[ok] - rg[ok]).max(axis=1)
    assert np.all(err <= RTOL * np.maximum(gs, 1e-300)), np.max(err / gs)


# ---------------------------------------------------------------------- the tests
@needs_cc
@pytest.mark.parametrize("prefix", list(CASES))
def test_c_matches_python_everywhere(lib, prefix, rng):
    spline = CASES[prefix]
    tri = spline.triangulation
    x = sample_points(spline, rng)
    sid = tri.locate(x)
    # the same simplex, also on facets, vertices and ties
    np.testing.assert_array_equal(lib.locate(prefix, x), sid)
    assert np.any(sid < 0) and np.any(sid >= 0)
    # policy nan: exactly SimplexSpline.predict / gradient
    v, g, count = lib.points(prefix, x, POLICY["nan"])
    assert count == int(np.sum(sid < 0))
    assert_close(spline, x, "nan", v, g, spline.predict(x), spline.gradient(x))
    for outside in ("clamp", "extrapolate"):
        v, g, count = lib.points(prefix, x, POLICY[outside])
        rv, rg, out = reference_evaluate(spline, x, outside=outside)
        assert count == int(out.sum())
        assert not np.any(np.isnan(v))
        assert_close(spline, x, outside, v, g, rv, rg)


@needs_cc
def test_extrapolate_is_predict_extrapolate_and_clamp_is_clipping(lib, rng):
    spline = CASES["g2"]
    lo, hi = domain_box(spline.triangulation)
    x = rng.uniform(lo - 0.5, hi + 0.5, (300, 2))
    v, g, _ = lib.points("g2", x, POLICY["extrapolate"])
    assert_close(spline, x, "extrapolate", v, g, spline.predict(x, outside="extrapolate"),
                 spline.gradient(x, outside="extrapolate"))
    v, g, _ = lib.points("g2", x, POLICY["clamp"])
    xc = np.clip(x, lo, hi)  # a full grid: clamped points are inside
    assert_close(spline, x, "clamp", v, g, spline.predict(xc), spline.gradient(xc))


@needs_cc
def test_status_codes_default_policy_and_bad_input(lib, rng):
    spline = CASES["f3"]  # compiled with the clamp default
    tri = spline.triangulation
    x = sample_points(spline, rng)[::7]
    rv, rg, out = reference_evaluate(spline, x, outside="clamp")
    assert 0 < out.sum() < len(x)
    for k in range(len(x)):
        status, v, g = lib.one("f3", x[k])
        assert status == int(out[k])
        assert abs(v - rv[k]) <= 1e-12 * np.abs(spline.coefficients).max()
        status2, v2, g2 = lib.one("f3", x[k], POLICY["clamp"])
        assert (status2, v2) == (status, v) and np.array_equal(g2, g)
    inside = x[tri.locate(x) >= 0][0]
    for bad in (np.nan, np.inf, -np.inf):
        p = inside.copy()
        p[1] = bad
        status, v, g = lib.one("f3", p)
        assert status == -1 and np.isnan(v) and np.all(np.isnan(g))
    status, v, g = lib.one("f3", inside, 7)  # unknown policy
    assert status == -1 and np.isnan(v)
    assert lib.points("f3", x[:3], 3)[2] == -1
    assert lib.locate("f3", np.array([[np.nan, 0.0, 0.0]]))[0] == -1


@needs_cc
def test_degree_zero_and_one(lib, rng):
    """Piecewise constants have zero gradient; degree 1 is the piecewise linear
    interpolant of its vertex coefficients."""
    x = rng.uniform(0, 1, (200, 2))
    v, g, _ = lib.points("c0", x, POLICY["nan"])
    sid = CASES["c0"].triangulation.locate(x)
    np.testing.assert_array_equal(v, CASES["c0"].coefficients[sid, 0])
    np.testing.assert_array_equal(g, 0.0)
    spline = CASES["d3"]
    tri = spline.triangulation
    x, where = ref.points_in_simplices(tri.vertices, tri.simplices, 3, rng)
    v, g, _ = lib.points("d3", x, POLICY["nan"])
    b = tri.barycentric(x, tri.locate(x))
    expect = np.einsum("ij,ij->i", b, spline.coefficients[tri.locate(x)])
    np.testing.assert_allclose(v, expect, rtol=0, atol=1e-13)


def test_tables_hold_the_exact_doubles():
    """The C literals convert back to the model's doubles bit for bit."""
    spline = CASES["f3"]
    src = generate_c(spline, "m").source

    def table(name):
        body = re.search(rf"{name}\[\d+\] = \{{(.*?)\}};", src, re.S).group(1)
        return np.array([float(v) for v in body.replace("\n", " ").split(",")])

    np.testing.assert_array_equal(table("m_impl_coef"), spline.coefficients.ravel())
    np.testing.assert_array_equal(table("m_impl_tinv"), spline.triangulation._tinv.ravel())
    np.testing.assert_array_equal(table("m_impl_origin"), spline.triangulation._origin.ravel())
    assert generate_c(spline, "m").source == src  # deterministic
    assert "malloc" not in src and "#include <math.h>" in src
    assert set(re.findall(r"#include <([^>]+)>", src)) == {"math.h"}


@needs_cc
def test_single_header_executable(tmp_path, rng):
    """The stb-style single header in a small program built with cc; results printed as
    hex floats match Python."""
    spline = CASES["g4"]
    code = generate_c(spline, "tab4", single_header=True, outside="extrapolate")
    assert list(code.files) == ["tab4.h"]
    code.write(tmp_path)
    x = sample_points(spline, rng)[::5]
    pts = ",\n".join("{" + ", ".join(repr(float(v)) for v in row) + "}" for row in x)
    (tmp_path / "main.c").write_text(f"""
#include <stdio.h>
#define TAB4_IMPLEMENTATION
#include "tab4.h"
#include "tab4.h"
static const double pts[{len(x)}][TAB4_NDIM] = {{{pts}}};
int main(void)
{{
    int i, k, s;
    double v, g[TAB4_NDIM];
    for (i = 0; i < {len(x)}; ++i) {{
        s = tab4_eval(pts[i], &v, g);
        printf("%d %a", s, v);
        for (k = 0; k < TAB4_NDIM; ++k) printf(" %a", g[k]);
        printf("\\n");
    }}
    return 0;
}}
""")
    exe = tmp_path / "prog"
    res = subprocess.run([CC, *FLAGS, "-o", str(exe), str(tmp_path / "main.c"), "-lm"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr[:4000]
    rows = [line.split() for line in subprocess.run(
        [str(exe)], capture_output=True, text=True, timeout=60, check=True).stdout.splitlines()]
    status = np.array([int(r[0]) for r in rows])
    v = np.array([float.fromhex(r[1]) for r in rows])
    g = np.array([[float.fromhex(t) for t in r[2:]] for r in rows])
    rv, rg, out = reference_evaluate(spline, x, outside="extrapolate")
    np.testing.assert_array_equal(status, out.astype(int))
    assert_close(spline, x, "extrapolate", v, g, rv, rg)


def test_reference_evaluate_policies(rng):
    spline = CASES["f2"]
    tri = spline.triangulation
    lo, hi = domain_box(tri)
    x = rng.uniform(lo - 0.2, hi + 0.2, (300, 2))
    v, g, out = reference_evaluate(spline, x, outside="nan")
    np.testing.assert_array_equal(out, tri.locate(x) < 0)
    np.testing.assert_array_equal(np.isnan(v), out)
    v, g, out = reference_evaluate(spline, x, outside="clamp")
    np.testing.assert_array_equal(v, spline.predict(np.clip(x, lo, hi), outside="extrapolate"))
    assert g.shape == (300, 2) and not np.any(np.isnan(g))
    assert reference_evaluate(spline, x, outside="extrapolate", gradient=False)[1] is None


def test_errors(tmp_path):
    spline = CASES["g1"]
    for bad in ("1abc", "int", "_x", "a-b", "NAN", ""):
        with pytest.raises(InputError, match="not a usable C identifier"):
            generate_c(spline, bad)
    with pytest.raises(InputError, match="outside must be one of"):
        generate_c(spline, "ok", outside="raise")
    with pytest.raises(InputError, match="outside must be one of"):
        reference_evaluate(spline, [[0.0]], outside="zero")
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match="is not a directory"):
        generate_c(spline, "ok").write(tmp_path / "file")
    with pytest.raises(InputError, match="does not exist"):
        generate_c(spline, "ok").write(tmp_path / "no" / "such")
    paths = generate_c(spline, "ok").write(tmp_path / "new")
    assert sorted(p.name for p in paths) == ["ok.c", "ok.h"]
    assert sorted(p.name for p in (tmp_path / "new").iterdir()) == ["ok.c", "ok.h"]
