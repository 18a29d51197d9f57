"""Model structures, scaling, config files and the structure text format."""

from __future__ import annotations

import numpy as np
import pytest

from simplexspline.aero.config import load_config, parse_structure, settings_from_config
from simplexspline.aero.identify import IdentificationSettings
from simplexspline.aero.modelling.presets import AUTO_PRESET, PAPER_PRESET, preset
from simplexspline.aero.modelling.structure import Scaling, Structure
from simplexspline.errors import InputError


def test_paper_preset_is_the_papers_structures():
    p = preset("paper")
    assert p["CX"].variables == ("alpha", "de", "mach")
    assert p["CZ"].variables == ("alpha", "de", "mach")
    assert p["Cm"].variables == ("alpha", "qhat", "de")
    assert p["Cl"].variables == ("alpha", "beta", "da", "phat", "rhat")
    assert p["Cn"].variables == ("alpha", "beta", "dr")
    assert all(s.degree == 3 and s.continuity == 1 for s in p.values())
    assert set(p) == {"CX", "CY", "CZ", "Cl", "Cm", "Cn"}
    with pytest.raises(InputError, match="unknown structure preset 'nasa'"):
        preset("nasa")


def test_structure_sizes_and_label():
    s = Structure("CZ", ("alpha", "de", "mach"), 3, 1, (2, 1, 1))
    assert s.nbasis == 20 and s.nsimplex_max == 12
    assert s.label() == "CZ(alpha:2, de, mach) S^1_3"
    assert Structure.from_dict(s.to_dict()) == s


@pytest.mark.parametrize("kwargs, match", [
    ({"variables": ()}, "no variables"),
    ({"variables": ("alpha", "alpha")}, "repeated variable"),
    ({"variables": ("alpha",), "resolution": (1, 2)}, "one cell count per variable"),
    ({"variables": ("alpha",), "resolution": (0,)}, "positive integers"),
    ({"variables": ("alpha",), "degree": -1}, "degree must be"),
    ({"variables": ("alpha",), "degree": 2, "continuity": 2}, "continuity must satisfy"),
])
def test_bad_structures_are_refused(kwargs, match):
    with pytest.raises(InputError, match=match):
        Structure("CZ", **kwargs)


@pytest.mark.parametrize("text, expected", [
    ("CZ(alpha:3, de, mach) S^1_3", Structure("CZ", ("alpha", "de", "mach"), 3, 1, (3, 1, 1))),
    ("Cm(alpha, qhat) S^0_2", Structure("Cm", ("alpha", "qhat"), 2, 0)),
    ("Cl = alpha, beta:2", Structure("Cl", ("alpha", "beta"), 3, 1, (1, 2))),
    ("CY(beta)", Structure("CY", ("beta",))),
])
def test_parse_structure(text, expected):
    assert parse_structure(text) == expected
    assert parse_structure(expected.label()) == expected


@pytest.mark.parametrize("text, match", [
    ("CQ(alpha)", "unknown coefficient 'CQ'"),
    ("CZ alpha", "cannot read the model structure"),
    ("CZ(alpha:x)", "bad grid cell count"),
])
def test_parse_structure_errors(text, match):
    with pytest.raises(InputError, match=match):
        parse_structure(text)


def test_scaling_round_trip_and_flat_variable():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(100, 2)) * [0.1, 30.0] + [0.05, 200.0]
    s = Scaling.from_data(x, ("alpha", "tas"))
    u = s.transform(x)
    assert u.min() == 0.0 and u.max() == 1.0
    np.testing.assert_allclose(s.inverse(u), x, rtol=1e-14, atol=1e-12)
    assert s.transform(x + 100, clip=True).max() == 1.0
    assert Scaling.from_dict(s.to_dict()) == s
    with pytest.raises(InputError, match=r"\['tas'\] do not vary"):
        Scaling.from_data(np.c_[x[:, 0], np.ones(100)], ("alpha", "tas"))


def test_config_file(tmp_path):
    path = tmp_path / "id.toml"
    path.write_text("""
[identify]
coefficients = ["CZ", "Cm"]
validation_fraction = 0.3
select = false
derivative_folds = 4

[selection]
max_rounds = 2
candidates = ["alpha", "qhat"]

[models.CZ]
variables = ["alpha", "de", "qhat"]
degree = 4
resolution = 2
""")
    s = load_config(path)
    assert s.coefficients == ("CZ", "Cm") and s.validation_fraction == 0.3 and not s.select
    assert s.derivative_folds == 4
    assert s.selection.max_rounds == 2 and s.selection.candidates == ("alpha", "qhat")
    cz = s.starting_structures()["CZ"]
    assert cz == Structure("CZ", ("alpha", "de", "qhat"), 4, 1, (2, 2, 2))
    assert s.starting_structures()["Cm"] == AUTO_PRESET["Cm"]        # the default preset


@pytest.mark.parametrize("config, match", [
    ({"identfy": {}}, r"unknown key\(s\) \['identfy'\] in \[top level\]"),
    ({"identify": {"folds": 3}}, r"unknown key\(s\) \['folds'\] in \[identify\]"),
    ({"selection": {"rounds": 3}}, r"unknown key\(s\) \['rounds'\] in \[selection\]"),
    ({"models": {"CQ": {"variables": ["alpha"]}}}, "unknown coefficient 'CQ'"),
    ({"models": {"CZ": {"degree": 3}}}, "'variables' is missing"),
    ({"models": {"CZ": {"variables": ["alpha"], "order": 3}}}, r"unknown key\(s\) \['order'\]"),
    ({"identify": {"coefficients": ["CW"]}}, r"unknown coefficient\(s\) \['CW'\]"),
    ({"identify": {"derivative_folds": 1}}, "derivative_folds must be 0"),
])
def test_config_errors_name_the_key(config, match):
    with pytest.raises(InputError, match=match):
        settings_from_config(config)


def test_config_file_errors(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        load_config(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[identify\n")
    with pytest.raises(InputError, match="not valid TOML"):
        load_config(bad)


def test_settings_validation():
    with pytest.raises(InputError, match="validation_fraction"):
        IdentificationSettings(validation_fraction=1.0)
    with pytest.raises(InputError, match="reconstruct must be"):
        IdentificationSettings(reconstruct="sometimes")
