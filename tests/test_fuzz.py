"""Fuzz suite of issue 18: hostile and broken input through the public API and the CLI.

Each case asserts the exception type and its message, or for the CLI exit code 2 with a
single line on stderr and no traceback; that nothing outside the output was touched; and
that the output is complete or absent. Properties are drawn by hypothesis (few examples:
this runs in the default suite); the cases that already held before issue 18 stay here
so that they keep holding.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from simplexspline import (
    DegenerateSimplexError,
    InputError,
    ModelFileError,
    SimplexSpline,
    SplineSpace,
    Triangulation,
    TriangulationError,
)
from simplexspline.aero.report.document import Alert, BulletList, Heading, Paragraph, Table
from simplexspline.aero.report.document import to_html, to_markdown
from simplexspline.spline.formats.c_export import generate_c
from simplexspline.spline.formats.c_templates import c_string

FEW = settings(max_examples=25, deadline=None,
               suppress_health_check=[HealthCheck.function_scoped_fixture])


def _snapshot(root: Path) -> dict:
    return {str(p.relative_to(root)): (None if p.is_dir() else p.read_bytes())
            for p in sorted(root.rglob("*"))}


def _cli_fails(args: list, cwd: Path, match: str) -> None:
    """The CLI exits 2 with one matching line on stderr, no traceback (run in this process,
    as the console script runs it: an exception escaping ``main`` fails the test;
    tests/test_kill.py and tests/test_cli.py run the installed command)."""
    import contextlib
    import io
    import os

    from simplexspline.cli import main

    err, here = io.StringIO(), os.getcwd()
    try:
        os.chdir(cwd)
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(args)
    finally:
        os.chdir(here)
    lines = err.getvalue().strip().splitlines()
    assert code == 2, err.getvalue()
    assert len(lines) == 1 and "Traceback" not in err.getvalue(), err.getvalue()
    assert re.search(match, lines[0]), lines[0]


@pytest.fixture(scope="module")
def spline():
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, (400, 2))
    return SplineSpace(Triangulation.grid([0, 0], [1, 1], 2), 2, 1).fit(
        x, np.sin(3 * x[:, 0]) + x[:, 1])


# ---------------------------------------------------------------------------- arrays
@FEW
@given(st.sampled_from([np.nan, np.inf, -np.inf]), st.integers(0, 49), st.integers(0, 2))
def test_nan_and_inf_are_refused(bad, row, where):
    rng = np.random.default_rng(1)
    x, y, w = rng.uniform(0, 1, (50, 2)), rng.normal(size=50), np.ones(50)
    (x[row] if where == 0 else (y if where == 1 else w))[row if where else 0] = bad
    space = SplineSpace(Triangulation.grid([0, 0], [1, 1], 1), 1, 0)
    name = ("x", "y", "weights")[where]
    with pytest.raises(InputError, match=rf"{name} contains NaN or inf in 1 row"):
        space.fit(x, y, weights=w)


@pytest.mark.parametrize("x, y, w, match", [
    (np.zeros((10, 2, 1)), np.zeros(10), None, r"x must have shape \(N, n\), got \(10, 2, 1\)"),
    (np.zeros((10, 3)), np.zeros(10), None, "x has 3 columns but the triangulation is 2-dim"),
    (np.zeros((10, 2)), np.zeros((10, 2)), None, "fit one output at a time"),
    (np.zeros((10, 2)), np.zeros(9), None, r"y must have shape \(10,\) to match x"),
    (np.zeros((10, 2)), 1.0, None, r"y must hold one value per point, shape \(10,\); got a "
                                   "single number"),
    (np.zeros((10, 2)), np.zeros(10), np.ones(3), r"weights must have shape \(10,\)"),
    (np.zeros((10, 2)), np.zeros(10), -1.0, "weights must be >= 0; 10 are negative"),
    (np.full((10, 2), "a"), np.zeros(10), None, "x must be a numeric array"),
    (np.zeros((10, 2)) + 1j, np.zeros(10), None, "x is complex: give real numbers"),
    (np.zeros((10, 2)), np.zeros(10, dtype=complex), None, "y is complex"),
])
def test_shapes_and_dtypes_are_refused(x, y, w, match):
    space = SplineSpace(Triangulation.grid([0, 0], [1, 1], 1), 1, 0)
    with pytest.raises(InputError, match=match):
        space.fit(x, y, weights=w)


def test_scalar_weight_is_every_sample_s_weight():
    """A single number weighs every sample alike (as scikit-learn's sample_weight): the
    fit equals the unweighted one (issue 18, item 9: it was refused as 'fit one output
    at a time')."""
    rng = np.random.default_rng(2)
    x = rng.uniform(0, 1, (300, 2))
    y = np.cos(2 * x[:, 0]) * x[:, 1]
    space = SplineSpace(Triangulation.grid([0, 0], [1, 1], 2), 2, 1)
    np.testing.assert_allclose(space.fit(x, y, weights=3.0).coefficients,
                               space.fit(x, y).coefficients, rtol=1e-10, atol=1e-12)


@FEW
@given(st.integers(-300, 300))
def test_any_coordinate_scale_reproduces_a_linear_function(exponent):
    """From 1e-300 to 1e+300 the grid is valid (it was 'degenerate' below about 1e-160 and
    silently unfitted above 1e+160, where det T under- or overflowed) and a linear function
    is reproduced to rounding (issue 18, item 9)."""
    s = 10.0 ** exponent
    tri = Triangulation.grid([0.0, 0.0], [s, s], 2)
    rng = np.random.default_rng(3)
    u = rng.uniform(0, 1, (200, 2))
    y = 1.0 + 2.0 * u[:, 0] - 3.0 * u[:, 1]
    spline = SplineSpace(tri, 1, 0).fit(u * s, y)
    np.testing.assert_allclose(spline.predict(u * s), y, rtol=0, atol=1e-9)


def test_degenerate_and_overlapping_triangulations():
    with pytest.raises(DegenerateSimplexError, match=r"1 simplices have zero volume "
                                                     r"\(degenerate\): \[0\]"):
        Triangulation([[0, 0], [1, 1], [2, 2]], [[0, 1, 2]])
    with pytest.raises(DegenerateSimplexError, match="repeat a vertex"):
        Triangulation([[0, 0], [1, 0], [0, 1]], [[0, 1, 1]])
    with pytest.raises(TriangulationError, match="overlap"):
        Triangulation([[0, 0], [1, 0], [0, 1], [1, 1]], [[0, 1, 2], [0, 1, 3]])
    tiny = 1e-300                             # scale alone never makes a simplex degenerate
    assert Triangulation([[0, 0], [tiny, 0], [0, tiny]], [[0, 1, 2]]).nsimplex == 1


# ---------------------------------------------------------------------------- model files
@pytest.mark.parametrize("suffix", [".json", ".npz"])
@FEW
@given(cut=st.floats(0.0, 0.999))
def test_truncated_model_files_are_refused(spline, tmp_path_factory, suffix, cut):
    d = tmp_path_factory.mktemp("trunc")
    path = spline.save(d / f"m{suffix}") or d / f"m{suffix}"
    data = Path(path).read_bytes()
    Path(path).write_bytes(data[: int(cut * len(data))])
    with pytest.raises(ModelFileError):
        SimplexSpline.load(path)


@FEW
@given(st.binary(max_size=300))
def test_foreign_bytes_are_refused(tmp_path_factory, blob):
    d = tmp_path_factory.mktemp("foreign")
    for name in ("x.json", "x.npz"):
        (d / name).write_bytes(blob)
        with pytest.raises(ModelFileError):
            SimplexSpline.load(d / name)


def test_pickled_npz_is_never_unpickled(tmp_path):
    path = tmp_path / "evil.npz"
    np.savez(path, header=np.array([{"__reduce__": "os.system"}], dtype=object))
    with pytest.raises(ModelFileError, match="(?i)pickle"):
        SimplexSpline.load(path)


# ---------------------------------------------------------------------------- names
@FEW
@given(st.text(max_size=40))
def test_c_strings_read_back_as_the_same_bytes(text):
    """Whatever the text, the literal is printable ASCII with no quote, backslash or '?'
    left bare (no trigraph), and C's escape rules give back its UTF-8 bytes."""
    lit = c_string(text)
    body = lit[1:-1]
    assert lit[0] == lit[-1] == '"' and all(32 <= ord(ch) < 127 for ch in body)
    assert not re.search(r'(?<!\\)"|\?', body.replace("\\\\", ""))
    back = re.sub(rb"\\([0-7]{3})", lambda m: bytes([int(m.group(1), 8)]), body.encode())
    assert back == text.encode("utf-8")


@pytest.mark.parametrize("prefix", ["../evil", "a/b", "x y", "_x", "int", "", "cz;"])
def test_c_prefixes_that_are_paths_or_not_identifiers_are_refused(spline, prefix):
    with pytest.raises(InputError, match="is not a usable C identifier"):
        generate_c(spline, prefix)


def test_path_traversal_through_names_writes_nothing(tmp_path, spline):
    """A prefix or a coefficient that is a path is refused by the CLI before anything is
    written, and nothing outside the output changes."""
    model = tmp_path / "m.json"
    spline.save(model)
    before = _snapshot(tmp_path)
    _cli_fails(["export", str(model), "--c", "out", "--prefix", "../../evil"], tmp_path,
               r"^simplexspline export: error: prefix '\.\./\.\./evil' is not a usable C "
               "identifier")
    _cli_fails(["identify", str(model), "-o", "out", "--coefficients", "../x"], tmp_path,
               r"^simplexspline identify: error: unknown coefficient\(s\) \['\.\./x'\]")
    assert _snapshot(tmp_path) == before


TEXT = st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=30)


@FEW
@given(TEXT)
def test_markdown_report_text_makes_no_markup(text):
    """Any text in any block renders (CommonMark) as that block's elements alone."""
    markdown_it = pytest.importorskip("markdown_it")
    blocks = [Heading(2, text), Paragraph(text), BulletList([text]), Alert(text),
              Table(["h"], [[text]])]
    page = markdown_it.MarkdownIt("commonmark").render(to_markdown(blocks))
    tags = re.findall(r"<([a-z0-9]+)[\s>/]", page)
    counts = {t: tags.count(t) for t in set(tags)}
    # an empty text makes an empty paragraph vanish; nothing else may appear
    assert set(counts) <= {"h2", "p", "ul", "li", "blockquote", "strong"}, page
    assert counts["h2"] == counts["ul"] == counts["li"] == counts["blockquote"] \
        == counts["strong"] == 1 and counts["p"] <= 3, page


@FEW
@given(TEXT)
def test_html_report_text_makes_no_markup(text):
    page = to_html([Heading(2, text, anchor=text), Paragraph(text), Alert(text)], title=text)
    body = page.split("<body>", 1)[1]
    assert re.findall(r"<([a-z0-9]+)", body) == ["h2", "p", "div"]


# ---------------------------------------------------------------------------- JSBSim XML
@pytest.fixture(scope="module")
def cz_table():
    from simplexspline.aero.export.lookup_tables import lookup_table
    from simplexspline.aero.modelling.model import AeroModel
    from simplexspline.aero.modelling.structure import Scaling, Structure

    rng = np.random.default_rng(4)
    structure = Structure("CZ", ("alpha", "de", "mach"), 2, 1)
    x = rng.uniform([-0.1, -0.2, 0.4], [0.4, 0.1, 0.7], (3000, 3))
    scaling = Scaling.from_data(x, structure.variables)
    u = scaling.transform(x)
    tri = Triangulation.fit(u, structure.resolution)
    spline = SplineSpace(tri, 2, 1).fit(u, -4.5 * x[:, 0] - 0.5 * x[:, 1] + 0.1 * x[:, 2])
    model = AeroModel(structure, scaling, spline, {})
    return lookup_table(model, {"alpha": np.linspace(-0.1, 0.4, 4), "de": [-0.2, 0.1],
                                "mach": [0.4, 0.7]})


@FEW
@given(label=TEXT)
def test_jsbsim_xml_is_well_formed_with_any_label(cz_table, label):
    """Whatever the model's label (it comes from the model file), the export parses as
    XML with exactly one function, one table, three independent variables and two
    tableData elements."""
    from dataclasses import replace

    table = replace(cz_table, info={**cz_table.info, "label": label})
    root = ET.fromstring(table.to_jsbsim())
    tags = [e.tag for e in root.iter()]
    assert tags.count("function") == 1 and tags.count("table") == 1
    assert tags.count("independentVar") == 3 and tags.count("tableData") == 2
    assert len(tags) == 1 + 1 + 1 + 3 + 2


@pytest.mark.parametrize("prop", ["a<b", "x\x01", 'q"><evil/>', "a b", ""])
def test_jsbsim_properties_that_are_not_property_names_are_refused(cz_table, prop):
    with pytest.raises(InputError, match="not a JSBSim property name"):
        cz_table.to_jsbsim(properties={"alpha": prop})
    with pytest.raises(InputError, match="not a JSBSim property name"):
        cz_table.to_jsbsim(function_name=prop)


# ---------------------------------------------------------------------------- flight data
def _flight_data(n: int = 400):
    """A small, valid flight-data table (straight and level) and its metadata."""
    import pandas as pd

    from simplexspline.aero.data.flight_data import SCHEMA_VERSION

    t = np.arange(n) * 0.01
    cols = {"maneuver": np.zeros(n, dtype=int), "t": t, "alpha": 0.05 + 0.01 * np.sin(t),
            "beta": np.zeros(n), "tas": np.full(n, 150.0), "mach": np.full(n, 0.45),
            "h": np.full(n, 3000.0), "rho": np.full(n, 0.909), "p": np.zeros(n),
            "q": np.zeros(n), "r": np.zeros(n), "phi": np.zeros(n), "theta": np.full(n, 0.05),
            "psi": np.full(n, 0.1), "ax": np.zeros(n), "ay": np.zeros(n),
            "az": np.full(n, -9.81), "de": np.zeros(n), "da": np.zeros(n), "dr": np.zeros(n),
            "mass": np.full(n, 9000.0), "Ixx": np.full(n, 12875.0),
            "Iyy": np.full(n, 75674.0), "Izz": np.full(n, 85552.0), "Ixz": np.full(n, 1331.0)}
    meta = {"schema": SCHEMA_VERSION, "aircraft": "test", "S": 27.87, "b": 9.14,
            "cbar": 3.45}
    return pd.DataFrame(cols), meta


@pytest.mark.parametrize("case, match", [
    ("parquet-truncated", r"cannot read Parquet file 'in\.parquet'"),
    ("csv-truncated", r"in\.csv"),
    ("csv-without-sidecar", r"need their metadata sidecar 'in\.csv\.json'; it does not exist"),
    ("degrees", r"column 'alpha' has value .* impossible in radians .*check its unit"),
])
def test_broken_flight_data_through_the_cli(tmp_path, case, match):
    """reconstruct on a truncated Parquet or CSV file, a CSV without its sidecar, or angles
    in degrees: exit 2, one line naming the file or the column, no output, nothing else
    touched."""
    from simplexspline.aero.data.flight_data import write_flight_data

    df, meta = _flight_data()
    suffix = ".csv" if case.startswith("csv") else ".parquet"
    path = tmp_path / f"in{suffix}"
    write_flight_data(df, path, meta)
    if case.endswith("truncated"):
        data = path.read_bytes()
        keep = len(data) // 2
        path.write_bytes(data[:keep] if suffix == ".parquet"
                         else data[:data.rindex(b"\n", 0, keep) + 1] + b"0.1,0.2,x\n")
    elif case == "csv-without-sidecar":
        (tmp_path / "in.csv.json").unlink()
    elif case == "degrees":
        df["alpha"] = np.degrees(df["alpha"])
        path.write_bytes(b"")
        path.unlink()
        import pyarrow as pa
        import pyarrow.parquet as pq

        pq.write_table(pa.Table.from_pandas(df, preserve_index=False), path)
        other = tmp_path / "ok.parquet"
        write_flight_data(_flight_data()[0], other, meta)   # borrow valid metadata
        table = pq.read_table(other)
        pq.write_table(pa.Table.from_pandas(df, preserve_index=False).replace_schema_metadata(
            table.schema.metadata), path)
        other.unlink()
    before = _snapshot(tmp_path)
    _cli_fails(["reconstruct", path.name, "-o", "out.parquet", "--workers", "1", "-q"],
               tmp_path, rf"^simplexspline reconstruct: error: .*{match}")
    assert _snapshot(tmp_path) == before                  # no output, nothing touched
