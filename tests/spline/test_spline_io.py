"""Versioned model files: .json and .npz round trips bit for bit, and clear errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from simplexspline import ModelFileError, SimplexSpline, SimplexSplineError, Triangulation

from . import reference as ref
from .cases import data_in_simplices, make_triangulation, seeded, smooth_function


@pytest.fixture(scope="module", params=["delaunay", "grid", "explicit", "fit"])
def spline(request):
    rng = seeded("io", request.param)
    tri = make_triangulation(request.param, 3, rng)
    x, _ = data_in_simplices(tri, 25, rng)
    return SimplexSpline.fit(x, smooth_function(x), tri, 2, 1)


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_round_trip_bit_for_bit(spline, tmp_path, suffix):
    path = tmp_path / f"model{suffix}"
    spline.save(path)
    back = SimplexSpline.load(path)
    assert back.degree == spline.degree and back.continuity == spline.continuity
    np.testing.assert_array_equal(back.coefficients, spline.coefficients)
    assert back.coefficients.dtype == spline.coefficients.dtype
    np.testing.assert_array_equal(back.triangulation.vertices, spline.triangulation.vertices)
    np.testing.assert_array_equal(back.triangulation.simplices, spline.triangulation.simplices)
    rng = seeded("io-pred")
    x, _ = data_in_simplices(spline.triangulation, 5, rng)
    np.testing.assert_array_equal(back.predict(x), spline.predict(x))
    np.testing.assert_array_equal(back.gradient(x), spline.gradient(x))
    # saving the loaded model again gives the same bytes of content
    path2 = tmp_path / f"again{suffix}"
    back.save(path2)
    again = SimplexSpline.load(path2)
    np.testing.assert_array_equal(again.coefficients, spline.coefficients)


def test_round_trip_extreme_values(tmp_path):
    # values that a naive text format would round: subnormals, many digits, huge
    tri = Triangulation.grid([0, 0], [1, 1], (1, 1))
    coef = np.array([[np.pi, -1 / 3, 5e-324], [1e300, -0.1, 2.0 ** -1074 * 3]])
    s = SimplexSpline(tri, 1, -1, coef)
    for suffix in (".json", ".npz"):
        s.save(tmp_path / f"m{suffix}")
        back = SimplexSpline.load(tmp_path / f"m{suffix}")
        np.testing.assert_array_equal(back.coefficients, coef)


def test_json_header(spline, tmp_path):
    path = tmp_path / "model.json"
    spline.save(path)
    doc = json.loads(path.read_text())
    assert doc["format"] == "simplexspline.model"
    assert doc["version"] == 1


def test_npz_header_and_no_pickle(spline, tmp_path):
    path = tmp_path / "model.npz"
    spline.save(path)
    with np.load(path, allow_pickle=False) as z:
        header = json.loads(str(z["header"][()]) if z["header"].ndim == 0 else str(z["header"]))
    assert header["format"] == "simplexspline.model"
    assert header["version"] == 1


@pytest.mark.parametrize("version", [2, 0, "1", None])
def test_unknown_version_json(spline, tmp_path, version):
    path = tmp_path / "model.json"
    spline.save(path)
    doc = json.loads(path.read_text())
    doc["version"] = version
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match="(?i)version"):
        SimplexSpline.load(path)


def test_unknown_version_npz(spline, tmp_path):
    path = tmp_path / "model.npz"
    spline.save(path)
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    raw = arrays["header"]
    header = json.loads(str(raw[()]) if raw.ndim == 0 else str(raw))
    header["version"] = 99
    arrays["header"] = np.array(json.dumps(header))
    np.savez(path, **arrays)
    with pytest.raises(ModelFileError, match="(?i)version"):
        SimplexSpline.load(path)


def test_wrong_format_tag(spline, tmp_path):
    path = tmp_path / "model.json"
    spline.save(path)
    doc = json.loads(path.read_text())
    doc["format"] = "something.else"
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match="(?i)format|simplexspline"):
        SimplexSpline.load(path)


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_corrupt_files(spline, tmp_path, suffix):
    path = tmp_path / f"model{suffix}"
    spline.save(path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])  # truncated
    with pytest.raises(ModelFileError, match="(?i)corrupt|unreadable|invalid"):
        SimplexSpline.load(path)
    path.write_bytes(b"\x00\xffgarbage" * 10)
    with pytest.raises(ModelFileError, match="(?i)corrupt|unreadable|invalid"):
        SimplexSpline.load(path)


def test_inconsistent_content(spline, tmp_path):
    path = tmp_path / "model.json"
    spline.save(path)
    text = path.read_text()
    doc = json.loads(text)
    x, _ = data_in_simplices(spline.triangulation, 3, seeded("io-keys"))
    # dropping any top-level key: a ModelFileError, or (for optional keys) the same model;
    # never a KeyError/AttributeError from deep inside
    for key in [k for k in doc if k not in ("format", "version")]:
        broken = json.loads(text)
        del broken[key]
        path.write_text(json.dumps(broken))
        try:
            back = SimplexSpline.load(path)
        except ModelFileError as err:
            assert str(path) in str(err)  # the message names the file
            continue
        assert key not in ("degree", "continuity", "coefficients", "triangulation"), key
        np.testing.assert_array_equal(back.predict(x), spline.predict(x))
    # coefficients of the wrong size
    broken = json.loads(text)
    broken["coefficients"] = np.zeros((spline.triangulation.nsimplex, 3)).tolist()
    path.write_text(json.dumps(broken))
    with pytest.raises(ModelFileError, match="(?i)coefficients|shape|degree"):
        SimplexSpline.load(path)
    # a degree that does not match the coefficients
    broken = json.loads(text)
    broken["degree"] = spline.degree + 1
    path.write_text(json.dumps(broken))
    with pytest.raises(ModelFileError, match="(?i)coefficients|shape|degree"):
        SimplexSpline.load(path)


def test_wrong_suffix_content(spline, tmp_path):
    npz = tmp_path / "model.npz"
    spline.save(npz)
    fake = tmp_path / "model.json"
    fake.write_bytes(npz.read_bytes())  # an npz file with a .json name
    with pytest.raises(ModelFileError, match="(?i)corrupt|unreadable|invalid|format"):
        SimplexSpline.load(fake)
    js = tmp_path / "other.json"
    spline.save(js)
    fake2 = tmp_path / "other.npz"
    fake2.write_bytes(js.read_bytes())
    with pytest.raises(ModelFileError, match="(?i)corrupt|unreadable|invalid|format"):
        SimplexSpline.load(fake2)


def test_path_as_string(spline, tmp_path):
    path = str(tmp_path / "model.json")
    spline.save(path)
    np.testing.assert_array_equal(SimplexSpline.load(path).coefficients, spline.coefficients)


def test_missing_file(tmp_path):
    with pytest.raises(ModelFileError, match="(?i)not found|no such|missing|exist"):
        SimplexSpline.load(tmp_path / "nope.json")


def test_unknown_suffix(spline, tmp_path):
    with pytest.raises(SimplexSplineError, match="(?i)suffix|json|npz"):
        spline.save(tmp_path / "model.txt")


def test_constructed_spline_validates_coefficients():
    tri = Triangulation.grid([0, 0], [1, 1], (1, 1))
    from simplexspline import InputError

    with pytest.raises(InputError, match="(?i)coefficients|shape"):
        SimplexSpline(tri, 2, 1, np.zeros((2, ref.num_basis(2, 2) + 1)))


@pytest.mark.parametrize("kind", ["grid", "fit"])
@pytest.mark.parametrize("damage", ["repeat a simplex", "move a vertex"])
def test_damaged_grid_triangulations_are_refused_on_load(tmp_path, kind, damage):
    """A repeated simplex or a moved vertex in a grid model file would evaluate the wrong
    pieces in part of the domain: loading refuses it (issue 18, item 3)."""
    import json

    from simplexspline import ModelFileError, SimplexSpline, SplineSpace, Triangulation

    rng = np.random.default_rng(3)
    x = rng.uniform(0, 1, (3000, 2))
    x = x[x[:, 0] + x[:, 1] < 1.4]                       # the fitted grid drops a corner
    tri = (Triangulation.grid([0, 0], [1, 1], (3, 3)) if kind == "grid"
           else Triangulation.fit(x, (3, 3)))
    spline = SplineSpace(tri, 2, 1).fit(x, x[:, 0] * x[:, 1], on_insufficient="minnorm")
    path = spline.save(tmp_path / "m.json")
    np.testing.assert_array_equal(SimplexSpline.load(path).coefficients, spline.coefficients)
    doc = json.loads(path.read_text())
    if damage == "repeat a simplex":
        doc["triangulation"]["simplices"][1] = doc["triangulation"]["simplices"][0]
    else:
        doc["triangulation"]["vertices"][4][0] += 0.05
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match=f"the {kind} triangulation's vertices or "
                                             "simplices are not those of its grid"):
        SimplexSpline.load(path)


@pytest.mark.parametrize("value", [float("nan"), float("inf"), {1, 2}])
def test_unwritable_metadata_is_a_clear_error_and_writes_nothing(tmp_path, value):
    from simplexspline import ModelFileError, SimplexSpline, Triangulation

    spline = SimplexSpline(Triangulation.grid([0], [1], (2,)), 1, 0, np.zeros((2, 2)),
                           metadata={"note": value})
    with pytest.raises(ModelFileError, match="metadata must be JSON-serialisable, without "
                                             "NaN or infinity"):
        spline.save(tmp_path / "m.json")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("text", [
    '{"format": "simplexspline.model", "version": 1, "degree": 1, "continuity": 0, '
    '"triangulation": [1, 2], "coefficients": [[0, 0]]}',
    '{"format": "simplexspline.model", "version": 1, "metadata": '
    + "[" * 100_000 + "]" * 100_000 + "}",
])
def test_malformed_json_structure_is_a_model_file_error(tmp_path, text):
    """Wrong JSON shapes and JSON nested 100k deep: ModelFileError, never AttributeError or
    RecursionError."""
    from simplexspline import ModelFileError, SimplexSpline

    path = tmp_path / "m.json"
    path.write_text(text)
    with pytest.raises(ModelFileError, match="corrupt or unreadable model file"):
        SimplexSpline.load(path)


def test_an_npz_header_claiming_huge_arrays_is_a_model_file_error(tmp_path):
    """A crafted npz whose array header claims 1e13 floats: no MemoryError traceback."""
    import io
    import zipfile

    from simplexspline import ModelFileError, SimplexSpline

    header = ("{'descr': '<f8', 'fortran_order': False, 'shape': (10000000000000,), }"
              .ljust(117) + "\n")
    npy = b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode()
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("header.npy",
                   _npy_of(np.array('{"format": "simplexspline.model", "version": 1}')))
        z.writestr("coefficients.npy", npy + b"\0" * 64)
        z.writestr("vertices.npy", npy + b"\0" * 64)
    path = tmp_path / "bomb.npz"
    path.write_bytes(buf.getvalue())
    with pytest.raises(ModelFileError, match=r"bomb.npz: (the model file declares arrays too "
                                             r"large|corrupt or unreadable)"):
        SimplexSpline.load(path)


def _npy_of(array) -> bytes:
    import io

    out = io.BytesIO()
    np.save(out, array)
    return out.getvalue()
