"""Export of aerodynamic models: C code with named physical inputs (compiled with cc and
compared with AeroModel.predict / gradient), lookup tables (CSV, npz, JSBSim XML checked by
JSBSim itself) and the `simplexspline export` command."""

from __future__ import annotations

import ctypes
import json
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from simplexspline import InputError, SimplexSpline, SplineSpace, Triangulation
from simplexspline.aero.export.c_code import generate_aero_c, load_exportable, parameter_names
from simplexspline.aero.export.lookup_tables import lookup_table, parse_grid
from simplexspline.aero.modelling.model import AeroModel
from simplexspline.aero.modelling.structure import Scaling, Structure
from simplexspline.cli import main

CC = shutil.which("cc") or ("/usr/bin/cc" if Path("/usr/bin/cc").exists() else None)
FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2"]
EXE = str(Path(sys.executable).with_name("simplexspline"))
POLICY = {"nan": 0, "clamp": 1, "extrapolate": 2}


def make_model(structure: Structure, lower, upper, seed: int, cut: float = 0.3) -> AeroModel:
    """A model identified on data that leave a corner of the box empty (dropped
    simplices), as the identification pipeline builds it (fitspace._space)."""
    rng = np.random.default_rng(seed)
    n = structure.ndim
    x = rng.uniform(lower, upper, (4000, n))
    u0 = (x - lower) / (np.asarray(upper) - lower)
    x = x[u0[:, 0] + u0[:, 1] < 2 - cut]
    scaling = Scaling.from_data(x, structure.variables)
    u = scaling.transform(x)
    tri = Triangulation.fit(u, structure.resolution, min_points=10)
    y = -4 * x[:, 0] + 0.5 * x[:, 1] ** 2 + np.sin(3 * x[:, -1]) * x[:, 0]
    keep = tri.locate(u) >= 0  # points in dropped simplices do not take part
    spline = SplineSpace(tri, structure.degree, structure.continuity).fit(u[keep], y[keep])
    return AeroModel(structure, scaling, spline,
                     {"source": "synthetic", "counts": list(range(40)), "note": "a */ b --"})


@pytest.fixture(scope="module")
def cz():
    return make_model(Structure("CZ", ("alpha", "de", "mach"), 3, 1, (2, 1, 2)),
                      [-0.1, -0.3, 0.3], [0.4, 0.2, 0.8], seed=1)


@pytest.fixture(scope="module")
def cl():
    return make_model(Structure("Cl", ("alpha", "beta", "da", "phat", "rhat"), 2, 1),
                      [-0.1, -0.15, -0.3, -0.05, -0.05], [0.4, 0.15, 0.3, 0.05, 0.05], seed=2)


class Lib:
    def __init__(self, path):
        self.lib = ctypes.CDLL(str(path))

    def fn(self, name, restype, argtypes=None):
        f = getattr(self.lib, name)
        f.restype = restype
        if argtypes is not None:
            f.argtypes = argtypes
        return f

    def points(self, prefix, x, policy):
        x = np.ascontiguousarray(x, dtype=float)
        v, g = np.empty(len(x)), np.empty(x.shape)
        ptr = ctypes.c_void_p
        count = self.fn(f"{prefix}_eval_points", ctypes.c_long)(
            ctypes.c_long(len(x)), ptr(x.ctypes.data), ctypes.c_int(policy),
            ptr(v.ctypes.data), ptr(g.ctypes.data))
        return v, g, count


@pytest.fixture(scope="module")
def lib(cz, cl, tmp_path_factory):
    if CC is None:
        pytest.skip("no C compiler ('cc') on this machine")
    root = tmp_path_factory.mktemp("aeroc")
    generate_aero_c(cz).write(root)  # cz.h + cz.c, default policy clamp
    generate_aero_c(cl, "cl_model", outside="nan", single_header=True).write(root)
    (root / "cl_impl.c").write_text('#define CL_MODEL_IMPLEMENTATION\n#include "cl_model.h"\n')
    out = root / "libaero.so"
    res = subprocess.run([CC, *FLAGS, "-fPIC", "-shared", "-o", str(out), str(root / "cz.c"),
                          str(root / "cl_impl.c"), "-lm"], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr[:4000]
    return Lib(out)


def probe(model, rng, npts=3000):
    """Physical inputs inside, on the box faces, in the empty corner and outside."""
    lo, hi = np.asarray(model.scaling.lower), np.asarray(model.scaling.upper)
    span = hi - lo
    x = rng.uniform(lo - 0.3 * span, hi + 0.3 * span, (npts, len(lo)))
    face = rng.uniform(lo, hi, (200, len(lo)))
    face[:, 0] = np.where(rng.uniform(size=200) < 0.5, lo[0], hi[0])
    return np.vstack([x, face, model.scaling.inverse(model.spline.triangulation.vertices)])


def close(a, b, scale):
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
    ok = ~np.isnan(b)
    assert np.all(np.abs(a[ok] - b[ok]) <= 1e-12 * scale), np.max(np.abs(a[ok] - b[ok]))


# ---------------------------------------------------------------------- C code
@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
@pytest.mark.parametrize("name", ["cz", "cl"])
def test_c_matches_aero_model(request, lib, name, rng):
    model = request.getfixturevalue(name)
    prefix = {"cz": "cz", "cl": "cl_model"}[name]
    x = probe(model, rng)
    inside = model.inside(x)
    assert 0 < inside.sum() < len(x)
    cscale = np.abs(model.spline.coefficients).max()
    for outside, code in POLICY.items():
        v, g, count = lib.points(prefix, x, code)
        assert count == int((~inside).sum())
        rv = model.predict(x, outside=outside)
        rg = model.gradient(x, outside=outside)
        # values within 1e-12 of the coefficient scale; gradients in physical units
        # scale with the simplex Jacobian / span (and with the distance when extrapolating)
        grow = 1.0 if outside != "extrapolate" else 10.0 ** model.spline.degree
        close(v, rv, cscale * grow)
        gscale = cscale * grow * model.spline.degree * 8 * np.max(
            np.abs(model.spline.triangulation._tinv).sum(axis=1)) / model.scaling.span
        for k in range(x.shape[1]):
            close(g[:, k], rg[:, k], gscale[k])


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
def test_named_inputs_and_metadata(lib, cz, rng):
    dbl = ctypes.c_double
    ev = lib.fn("cz_eval", dbl, [dbl, dbl, dbl])
    evg = lib.fn("cz_eval_grad", ctypes.c_int,
                 [dbl, dbl, dbl, ctypes.POINTER(dbl), ctypes.POINTER(dbl)])
    x = probe(cz, rng, 50)
    values = cz.predict(x)  # default policy clamp in both
    grads = cz.gradient(x)
    out = ~cz.inside(x)
    cscale = np.abs(cz.spline.coefficients).max()
    for k, (a, d, m) in enumerate(x):
        assert abs(ev(a, d, m) - values[k]) <= 1e-12 * cscale
        v, g = dbl(), (dbl * 3)()
        assert evg(a, d, m, ctypes.byref(v), g) == int(out[k])
        assert abs(v.value - values[k]) <= 1e-12 * cscale
        np.testing.assert_allclose(g[:], grads[k], rtol=1e-10, atol=1e-12 * cscale)
    assert np.isnan(ev(np.nan, 0.0, 0.5))
    assert evg(0.1, np.inf, 0.5, None, None) == -1  # NULL outputs allowed
    names = (ctypes.c_char_p * 3).in_dll(lib.lib, "cz_variables")
    assert [s.decode() for s in names] == ["alpha", "de", "mach"]
    assert list((dbl * 3).in_dll(lib.lib, "cz_lower")) == list(cz.scaling.lower)
    assert list((dbl * 3).in_dll(lib.lib, "cz_upper")) == list(cz.scaling.upper)


def test_generated_header_documents_the_model(cz):
    code = generate_aero_c(cz)
    assert sorted(code.files) == ["cz.c", "cz.h"]
    h = code.header
    assert "CZ(alpha:2, de, mach:2) S^1_3" in h
    assert "alpha [rad] in [" in h and "mach [-] in [" in h and "Output: CZ [-]" in h
    assert "Default outside policy: clamp" in h
    assert "source: \"synthetic\"" in h and "counts: \"<40 values>\"" in h
    assert "a * / b" in h  # no comment terminator from the provenance
    assert "double cz_eval(double alpha, double de, double mach);" in h
    assert "#define CZ_VAR_MACH 2" in h and "#define CZ_POLICY_DEFAULT CZ_POLICY_CLAMP" in h
    for bad in ("9cz", "", "x y"):
        with pytest.raises(InputError, match="not a usable C identifier"):
            generate_aero_c(cz, bad)
    with pytest.raises(InputError, match="outside must be one of"):
        generate_aero_c(cz, outside="raise")
    with pytest.raises(InputError, match="needs an AeroModel"):
        generate_aero_c(cz.spline)


def test_parameter_names_are_valid_and_unique():
    assert parameter_names(["alpha", "de"]) == ["alpha", "de"]
    assert parameter_names(["a-b", "a_b", "2x", "int", "value", "_p"]) == [
        "a_b", "a_b_", "v2x", "int_", "value_", "v_p"]


# ---------------------------------------------------------------------- tables
def test_lookup_table_values_and_files(cz, tmp_path):
    grid = {"alpha": np.linspace(-0.1, 0.4, 6), "de": [-0.2, 0.0], "mach": [0.4, 0.6, 0.9]}
    t = lookup_table(cz, grid)
    assert t.shape == (6, 2, 3) and t.policy == "clamp"
    mesh = np.stack(np.meshgrid(*grid.values(), indexing="ij"), axis=-1).reshape(-1, 3)
    np.testing.assert_array_equal(t.values.ravel(), cz.predict(mesh))
    np.testing.assert_array_equal(t.outside.ravel(), ~cz.inside(mesh))
    assert t.outside[:, :, 2].all()  # mach 0.9 beyond the identified 0.8
    paths = t.save(tmp_path / "cz.csv")
    assert [p.name for p in paths] == ["cz.csv", "cz.csv.json"]
    lines = (tmp_path / "cz.csv").read_text().splitlines()
    assert lines[0] == "alpha,de,mach,CZ,outside"
    rows = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    np.testing.assert_array_equal(rows[:, :3], mesh)  # C order: mach fastest
    np.testing.assert_array_equal(rows[:, 3], t.values.ravel())  # exact (repr)
    np.testing.assert_array_equal(rows[:, 4], t.outside.ravel())
    side = json.loads((tmp_path / "cz.csv.json").read_text())
    assert side["format"] == "simplexspline.table" and side["version"] == 1
    assert side["outside_policy"] == "clamp" and side["outside_points"] == int(t.outside.sum())
    assert "clamped" in side["outside_note"] and side["shape"] == [6, 2, 3]
    assert side["breakpoints"]["mach"] == [0.4, 0.6, 0.9]
    assert side["units"] == {"alpha": "rad", "de": "rad", "mach": "-", "CZ": "-"}
    assert side["model"]["label"] == cz.structure.label()
    t.save(tmp_path / "cz.npz")
    with np.load(tmp_path / "cz.npz", allow_pickle=False) as z:
        np.testing.assert_array_equal(z["values"], t.values)
        np.testing.assert_array_equal(z["outside"], t.outside)
        np.testing.assert_array_equal(z["breakpoints_2"], grid["mach"])
        assert json.loads(str(z["header"]))["variables"] == ["alpha", "de", "mach"]
    assert (tmp_path / "cz.npz.json").is_file()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    nan = lookup_table(cz, grid, outside="nan")
    np.testing.assert_array_equal(np.isnan(nan.values), nan.outside)


def test_table_and_sidecar_are_written_as_a_pair(cz, tmp_path, monkeypatch):
    """A sidecar that cannot be written leaves the old table and sidecar, not a mixed pair."""
    import os

    t = lookup_table(cz, {"alpha": [0.0, 0.1], "de": [0.0], "mach": [0.5]})
    t.save(tmp_path / "cz.csv")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    t2 = lookup_table(cz, {"alpha": [0.0, 0.2, 0.3], "de": [0.0], "mach": [0.5]})
    real, calls = os.fdopen, []

    def disk_full_on_the_second_file(fd, *args, **kwargs):
        calls.append(fd)
        if len(calls) == 2:
            os.close(fd)
            raise OSError(28, "No space left on device")
        return real(fd, *args, **kwargs)

    monkeypatch.setattr(os, "fdopen", disk_full_on_the_second_file)
    with pytest.raises(OSError, match="No space left"):
        t2.save(tmp_path / "cz.csv")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_lookup_table_of_a_plain_spline():
    tri = Triangulation.grid([0.0, 0.0], [1.0, 1.0], (2, 2))
    s = SplineSpace(tri, 1, 0).fit(np.random.default_rng(0).uniform(0, 1, (200, 2)),
                                   np.zeros(200) + 2.0)
    t = lookup_table(s, [[0.0, 0.5, 1.5], [0.25]])
    assert t.variables == ("x0", "x1") and t.policy == "nan" and t.output == "y"
    np.testing.assert_allclose(t.values[:2, 0], 2.0)
    assert np.isnan(t.values[2, 0]) and t.outside[2, 0]
    t = lookup_table(s, [[0.0, 1.5], [0.25]], outside="clamp")
    np.testing.assert_allclose(t.values, 2.0)


def _xml_table(text):
    root = ET.fromstring(text[text.index("<function"):])
    table = root.find("table")
    lookups = [(v.get("lookup"), v.text) for v in table.findall("independentVar")]
    data = [(d.get("breakPoint"), np.array([[float(v) for v in line.split()] for line in
                                            d.text.strip().splitlines()], dtype=object))
            for d in table.findall("tableData")]
    return root, lookups, data


def test_jsbsim_xml_structure(cz):
    bp = {"alpha": np.linspace(-0.1, 0.4, 4), "de": [-0.2, 0.1], "mach": [0.4, 0.7]}
    text = lookup_table(cz, bp).to_jsbsim()
    root, lookups, data = _xml_table(text)
    assert root.get("name") == "aero/coefficient/CZ"
    assert lookups == [("row", "aero/alpha-rad"), ("column", "fcs/elevator-pos-rad"),
                       ("table", "velocities/mach")]
    assert [float(b) for b, _ in data] == [0.4, 0.7]
    vals = lookup_table(cz, bp).values
    for t, (_, rows) in enumerate(data):
        assert [float(v) for v in rows[0]] == [-0.2, 0.1]  # column breakpoints
        assert [float(r[0]) for r in rows[1:]] == list(bp["alpha"])
        np.testing.assert_array_equal(np.array([r[1:] for r in rows[1:]], dtype=float),
                                      vals[:, :, t])
    assert "Outside policy: clamp" in text and "- -" not in text.split("-->")[1]
    # one varying variable, the others fixed; custom property and name
    one = lookup_table(cz, {"alpha": bp["alpha"], "de": [0.0], "mach": [0.5]})
    text = one.to_jsbsim(properties={"alpha": "my/alpha"}, function_name="a/b")
    root, lookups, data = _xml_table(text)
    assert root.get("name") == "a/b" and lookups == [("row", "my/alpha")]
    assert "Fixed: de = 0.0 [rad]" in text and "Fixed: mach = 0.5 [-]" in text
    np.testing.assert_array_equal(np.array(data[0][1], dtype=float)[:, 1], one.values[:, 0, 0])


def test_jsbsim_xml_errors(cz, cl):
    with pytest.raises(InputError, match="JSBSim tables cannot hold NaN"):
        lookup_table(cz, {"alpha": [0.0, 1.0], "de": [0.0], "mach": [0.5]},
                     outside="nan").to_jsbsim()
    grid = {v: [lo, hi] for v, lo, hi in zip(cl.variables, cl.scaling.lower,
                                            cl.scaling.upper)}
    with pytest.raises(InputError, match="1 to 3 varying variables, this grid varies 5"):
        lookup_table(cl, grid).to_jsbsim()
    t = lookup_table(cl, {**grid, "da": [0.0], "phat": [0.0]})
    with pytest.raises(InputError, match=r"unknown variable\(s\) \['q'\]"):
        t.to_jsbsim(properties={"q": "x"})
    text = t.to_jsbsim()
    assert "simplexspline/rhat" in text and "Define the properties" in text


@pytest.fixture(scope="module")
def jsbsim_root(tmp_path_factory):
    pytest.importorskip("jsbsim")
    return tmp_path_factory.mktemp("jsbsim")


AIRCRAFT = """<?xml version="1.0"?>
<fdm_config name="{name}" version="2.0" release="ALPHA">
  <metrics>
    <wingarea unit="FT2"> 100 </wingarea> <wingspan unit="FT"> 10 </wingspan>
    <chord unit="FT"> 10 </chord>
    <location name="AERORP" unit="IN"><x>0</x><y>0</y><z>0</z></location>
  </metrics>
  <mass_balance>
    <ixx unit="SLUG*FT2"> 100 </ixx> <iyy unit="SLUG*FT2"> 100 </iyy>
    <izz unit="SLUG*FT2"> 100 </izz> <emptywt unit="LBS"> 1000 </emptywt>
    <location name="CG" unit="IN"><x>0</x><y>0</y><z>0</z></location>
  </mass_balance>
  <ground_reactions/>
  <system name="inputs">
    <property value="0">test/a</property> <property value="0">test/b</property>
    <property value="0">test/c</property>
  </system>
  <aerodynamics>
{function}
  </aerodynamics>
</fdm_config>
"""


@pytest.mark.parametrize("fixed", [("de", "mach"), ("mach",), ()])
def test_jsbsim_evaluates_the_table(cz, jsbsim_root, fixed, rng):
    """JSBSim reads the snippet and returns the table values at the breakpoints and
    multilinear interpolation between them."""
    import jsbsim
    from scipy.interpolate import RegularGridInterpolator

    full = {"alpha": np.linspace(-0.1, 0.4, 5), "de": np.array([-0.2, 0.0, 0.15]),
            "mach": np.array([0.35, 0.55, 0.75])}
    grid = {v: (b[1:2] if v in fixed else b) for v, b in full.items()}
    table = lookup_table(cz, grid)
    vary = [v for v in cz.variables if v not in fixed]
    props = dict(zip(vary, ("test/a", "test/b", "test/c")))
    name = f"tbl{len(vary)}"
    (jsbsim_root / "aircraft" / name).mkdir(parents=True)
    (jsbsim_root / "aircraft" / name / f"{name}.xml").write_text(AIRCRAFT.format(
        name=name, function=table.to_jsbsim(properties=props, function_name="test/out")))
    fdm = jsbsim.FGFDMExec(str(jsbsim_root), None)
    fdm.set_debug_level(0)
    assert fdm.load_model(name)
    vals = table.values[tuple(slice(None) if v in vary else 0 for v in cz.variables)]
    interp = RegularGridInterpolator([grid[v] for v in vary], vals)
    corners = np.stack(np.meshgrid(*[grid[v] for v in vary], indexing="ij"),
                       axis=-1).reshape(-1, len(vary))
    lo = [grid[v][0] for v in vary]
    hi = [grid[v][-1] for v in vary]
    pts = np.vstack([corners, rng.uniform(lo, hi, (20, len(vary)))])
    fdm["ic/h-sl-ft"] = 10000.0
    fdm["ic/vt-kts"] = 100.0
    fdm.run_ic()
    for p in pts:
        for v, val in zip(vary, p):
            fdm[props[v]] = float(val)
        fdm.run()
        assert fdm["test/out"] == pytest.approx(float(interp(p)[0]), rel=1e-12, abs=1e-14)


def test_parse_grid():
    assert parse_grid("alpha=-0.1:0.4:26")[1].tolist() == np.linspace(-0.1, 0.4, 26).tolist()
    assert parse_grid(" de = 0 ")[1].tolist() == [0.0]
    assert parse_grid("mach=0.3,0.5,0.7")[1].tolist() == [0.3, 0.5, 0.7]
    for bad, msg in [("alpha", "expected NAME"), ("alpha=", "expected NAME"),
                     ("a=1:2", "three fields"), ("a=1:2:0", "positive integer"),
                     ("a=1:2:x", "positive integer"), ("a=1,x", "could not convert"),
                     ("a=0.3,0.2", "increase strictly"), ("a=1,nan", "finite")]:
        with pytest.raises(InputError, match=msg):
            parse_grid(bad)


def test_lookup_table_errors(cz):
    with pytest.raises(InputError, match=r"missing \['mach'\]"):
        lookup_table(cz, {"alpha": [0.0], "de": [0.0]})
    with pytest.raises(InputError, match=r"unknown \['beta'\]"):
        lookup_table(cz, {"alpha": [0.0], "de": [0.0], "mach": [0.5], "beta": [0.0]})
    with pytest.raises(InputError, match="needs 3 breakpoint lists"):
        lookup_table(cz, [[0.0]])
    with pytest.raises(InputError, match="increase strictly"):
        lookup_table(cz, [[0.0, 0.0], [0.0], [0.5]])
    with pytest.raises(InputError, match="outside must be one of"):
        lookup_table(cz, [[0.0], [0.0], [0.5]], outside="raise")
    with pytest.raises(InputError, match="at most"):
        lookup_table(cz, [np.arange(3000.0)] * 3)
    t = lookup_table(cz, [[0.0], [0.0], [0.5]])
    with pytest.raises(InputError, match="end in .csv, .npz or .xml"):
        t.save("table.txt")


# ---------------------------------------------------------------------- CLI
@pytest.fixture(scope="module")
def model_file(cz, tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "CZ.json"
    cz.save(path)
    return path


def test_cli_c_and_table(model_file, tmp_path, capsys):
    code = main(["export", str(model_file), "--c", str(tmp_path / "c"), "--table",
                 str(tmp_path / "cz.xml"), "--grid", "alpha=-0.1:0.4:6", "--grid", "de=0",
                 "--grid", "mach=0.4,0.6", "--property", "alpha=my/alpha"])
    out = capsys.readouterr().out
    assert code == 0
    assert sorted(p.name for p in (tmp_path / "c").iterdir()) == ["cz.c", "cz.h"]
    assert "wrote" in out and "cz.xml" in out
    assert (tmp_path / "c" / "cz.h").read_text() == generate_aero_c(
        load_exportable(model_file)).header
    assert "my/alpha" in (tmp_path / "cz.xml").read_text()
    code = main(["export", str(model_file), "--c", str(tmp_path / "c2"), "--prefix", "zz",
                 "--single-header", "--outside", "nan", "-q"])
    assert code == 0 and capsys.readouterr().out == ""
    assert [p.name for p in (tmp_path / "c2").iterdir()] == ["zz.h"]
    assert "#define ZZ_POLICY_DEFAULT ZZ_POLICY_NAN" in (tmp_path / "c2" / "zz.h").read_text()
    assert not [p for p in tmp_path.rglob(".*")]


def test_cli_plain_spline(tmp_path, capsys):
    tri = Triangulation.grid([0.0, 0.0], [1.0, 1.0], (2, 2))
    s = SimplexSpline(tri, 1, 0, np.ones((8, 3)), metadata={"variables": ["u", "v"]})
    s.save(tmp_path / "1-my model.npz")
    assert main(["export", str(tmp_path / "1-my model.npz"), "--c", str(tmp_path),
                 "--table", str(tmp_path / "t.csv"), "--grid", "u=0,1", "--grid",
                 "v=0.5,2", "-q"]) == 0
    assert (tmp_path / "m_1_my_model.c").is_file()
    assert (tmp_path / "t.csv").read_text().splitlines()[1:] == [
        "0.0,0.5,1.0,0", "0.0,2.0,nan,1", "1.0,0.5,1.0,0", "1.0,2.0,nan,1"]


@pytest.mark.parametrize("args, msg", [
    ([], "nothing to export"),
    (["--c", "D", "--grid", "alpha=0"], "need --table"),
    (["--table", "t.csv", "--grid", "alpha=0", "--grid", "de=0", "--grid", "mach=0.5",
      "--property", "alpha=x"], r"apply to JSBSim tables \(.xml\)"),
    (["--table", "t.txt"], "must end in .csv, .npz or .xml"),
    (["--table", "t.csv", "--grid", "alpha=0"], r"missing \['de', 'mach'\]"),
    (["--table", "t.csv", "--grid", "alpha=0", "--grid", "alpha=1"], "given twice"),
    (["--table", "t.csv", "--grid", "beta=0"], "has no variable 'beta'"),
    (["--table", "t.xml", "--grid", "alpha=0", "--grid", "de=0", "--grid", "mach=0.5",
      "--property", "alpha"], "expected NAME=VALUE"),
    (["--c", "D", "--prefix", "9x"], "not a usable C identifier"),
])
def test_cli_errors_are_one_line(model_file, tmp_path, capsys, monkeypatch, args, msg):
    monkeypatch.chdir(tmp_path)
    assert main(["export", str(model_file), *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("simplexspline export: error: ") and err.count("\n") == 1
    assert re.search(msg, err), err
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_cli_missing_model(tmp_path, capsys):
    assert main(["export", str(tmp_path / "none.json"), "--c", str(tmp_path)]) == 2
    assert "does not exist" in capsys.readouterr().err


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
def test_installed_command_builds_c_that_compiles(model_file, tmp_path):
    res = subprocess.run([EXE, "export", str(model_file), "--c", str(tmp_path), "--table",
                          str(tmp_path / "cz.npz"), "--grid", "alpha=0:0.3:4",
                          "--grid", "de=-0.1,0.1", "--grid", "mach=0.5"],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert f"wrote {tmp_path / 'cz.c'}" in res.stdout
    (tmp_path / "main.c").write_text("""
#include <stdio.h>
#include "cz.h"
int main(void)
{
    double g[CZ_NVAR], v;
    int s = cz_eval_grad(0.1, 0.0, 0.5, &v, g);
    printf("%d %a %a %a %a\\n", s, v, g[0], g[1], g[2]);
    return 0;
}
""")
    exe = tmp_path / "prog"
    build = subprocess.run([CC, *FLAGS, "-o", str(exe), str(tmp_path / "main.c"),
                            str(tmp_path / "cz.c"), "-lm"], capture_output=True, text=True,
                           timeout=300)
    assert build.returncode == 0, build.stderr[:3000]
    fields = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60,
                            check=True).stdout.split()
    model = AeroModel.load(model_file)
    x = np.array([[0.1, 0.0, 0.5]])
    assert fields[0] == "0"
    assert float.fromhex(fields[1]) == pytest.approx(model.predict(x)[0], rel=1e-12)
    np.testing.assert_allclose([float.fromhex(f) for f in fields[2:]], model.gradient(x)[0],
                               rtol=1e-11)
    with np.load(tmp_path / "cz.npz", allow_pickle=False) as z:
        assert z["values"].shape == (4, 2, 1)


# --------------------------------------------------------------------------- hostile names
HOSTILE = ["x??/", ",0}; int injected = 42; //", "a\"b\\c", "ctl\x01\x1b[0m", "é*/ /*"]


def test_hostile_variable_names_are_refused_by_the_aero_export(cz):
    from dataclasses import replace

    names = ("alpha", ",0}; int injected = 42; //", "mach")
    bad = AeroModel(replace(cz.structure, variables=names),
                    replace(cz.scaling, variables=names), cz.spline, dict(cz.provenance))
    with pytest.raises(InputError, match=r"variable name ',0\}; int injected = 42; //' of "
                                         r"the CZ model is not a plain name"):
        generate_aero_c(bad)


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
def test_c_string_literals_read_back_the_same_bytes(tmp_path):
    """Every hostile string, through c_string, compiles and prints back byte for byte."""
    from simplexspline.spline.formats.c_templates import c_string

    body = "".join(f'    fputs({c_string(s)}, stdout); fputc(0, stdout);\n' for s in HOSTILE)
    src = tmp_path / "strings.c"
    src.write_text("#include <stdio.h>\nint main(void)\n{\n" + body + "    return 0;\n}\n")
    exe = tmp_path / "strings"
    res = subprocess.run([CC, *FLAGS, "-trigraphs", "-o", str(exe), str(src)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    out = subprocess.run([str(exe)], capture_output=True, timeout=60).stdout
    assert out.split(b"\0")[:-1] == [s.encode("utf-8") for s in HOSTILE]


@pytest.mark.skipif(CC is None, reason="no C compiler ('cc') on this machine")
def test_hostile_names_in_a_spline_export_stay_inside_its_comment(tmp_path):
    """Names from a model file's metadata go into the generated comment: with trigraphs on,
    the C still compiles and defines no symbol but the spline's own."""
    from simplexspline.spline.formats.c_export import generate_c

    tri = Triangulation.grid([0, 0], [1, 1], (1, 1))
    x = np.random.default_rng(0).uniform(0, 1, (200, 2))
    spline = SplineSpace(tri, 2, 1).fit(x, x[:, 0] * x[:, 1])
    spline.metadata["variables"] = HOSTILE[:2]
    generate_c(spline, "hostile").write(tmp_path)
    obj = tmp_path / "hostile.o"
    res = subprocess.run([CC, *FLAGS, "-trigraphs", "-c", "-o", str(obj),
                          str(tmp_path / "hostile.c")], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    nm = shutil.which("nm")
    if nm:
        symbols = subprocess.run([nm, str(obj)], capture_output=True, text=True).stdout
        assert "injected" not in symbols
    text = (tmp_path / "hostile.c").read_text() + (tmp_path / "hostile.h").read_text()
    assert "??" not in text


@pytest.mark.parametrize("change, match", [
    (lambda a: a["scaling"].__setitem__("lower", a["scaling"]["lower"][:1]),
     "the scaling has 1 lower and 3 upper bounds"),
    (lambda a: a["scaling"].__setitem__("upper", a["scaling"]["lower"]),
     "finite bounds with upper > lower"),
    (lambda a: a["scaling"]["upper"].__setitem__(1, float("nan")),
     "finite bounds with upper > lower"),
])
def test_damaged_aero_scaling_is_refused_on_load(cz, tmp_path, change, match):
    """Scaling arrays that disagree with the variables, or empty or NaN ranges, are refused
    when the file is read, not met later as an IndexError or a C file with lower = 0."""
    from simplexspline import ModelFileError

    path = cz.save(tmp_path / "cz.json")
    doc = json.loads(path.read_text())
    change(doc["metadata"]["aero"])
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match=match):
        AeroModel.load(path)
