"""Multipliers with absolute values, ``|beta|`` and ``|de|``: notation, values, exact
gradients, and recovery of a drag-like truth that is linear in the size of the
sideslip (a table through zero with a kink there)."""

from __future__ import annotations

import numpy as np
import pytest

from simplexspline import InputError
from simplexspline.aero.config import parse_structure
from simplexspline.aero.modelling.notation import multiplier_parts, normal_multiplier
from simplexspline.aero.modelling.presets import VARYING_PRESET
from simplexspline.aero.selection.search import fit_structure
from simplexspline.aero.modelling.structure import multiplier_jacobian, multiplier_values

from .test_varying import campaign


def test_absolute_value_factors():
    assert multiplier_parts("|beta|*qhat") == (("beta", True, 0.0), ("qhat", False, 0.0))
    assert multiplier_parts("1") == ()
    assert normal_multiplier(" | de | * qhat ") == "|de|*qhat"
    s = parse_structure("CX(alpha:2, de | 1, |beta|, |de|*qhat) S^1_2")
    assert s.inputs == ("alpha", "de", "beta", "qhat")
    assert s.label() == "CX(alpha:2, de | 1, |beta|, |de|*qhat) S^1_2"
    assert parse_structure(s.label()) == s
    for bad in ("||", "|be|ta|", "|mach-x|", "|mach--1|", "|-0.5|", "|ma ch|"):
        with pytest.raises(InputError, match="absolute values"):
            parse_structure(f"CX(alpha | 1, {bad}) S^1_2")
    assert {"|beta|", "|de|"} <= set(VARYING_PRESET["CX"].multipliers)


def test_breakpoint_factors_read_and_write_back():
    """``|v-k|``: the distance from a breakpoint (a kink at k), in the column's units."""
    assert multiplier_parts("dr*|mach-0.62|[alpha]") == (("dr", False, 0.0),
                                                         ("mach", True, 0.62))
    assert multiplier_parts("|alpha+0.05|") == (("alpha", True, -0.05),)
    assert multiplier_parts("|de-1.5e-2|") == (("de", True, 0.015),)     # 'de' ends in e
    assert normal_multiplier(" beta * | mach - 0.6 | ") == "beta*|mach-0.6|"
    assert normal_multiplier("|h-1e+03|") == "|h-1000|"
    assert normal_multiplier("|beta+0|") == "|beta|"
    s = parse_structure("Cl(alpha:2, mach | 1, beta, beta*|mach-0.6|[alpha], "
                        "da*|alpha+0.1|[mach]) S^1_2")
    assert s.inputs == ("alpha", "mach", "beta", "da")
    assert parse_structure(s.label()) == s
    assert s.term_dims[2] == (0,) and s.term_dims[3] == (1,)


def test_breakpoint_factor_values_and_jacobian():
    s = parse_structure("Cl(alpha:2, mach | 1, beta*|mach-0.6|, |alpha+0.1|*|mach-0.7|) "
                        "S^1_2")
    rng = np.random.default_rng(4)
    x = np.column_stack([rng.uniform(-0.2, 0.3, 60), rng.uniform(0.3, 0.9, 60),
                         rng.uniform(-0.1, 0.1, 60)])
    m = multiplier_values(s, x)
    np.testing.assert_allclose(m[:, 1], x[:, 2] * np.abs(x[:, 1] - 0.6))
    np.testing.assert_allclose(m[:, 2], np.abs(x[:, 0] + 0.1) * np.abs(x[:, 1] - 0.7))
    _check_jacobian(s, x)


def test_absolute_value_values_and_jacobian():
    s = parse_structure("CX(alpha:2, de | 1, |beta|, |de|*qhat) S^1_2")
    rng = np.random.default_rng(3)
    x = rng.uniform(-0.3, 0.3, (50, 4))
    m = multiplier_values(s, x)
    np.testing.assert_allclose(m[:, 1], np.abs(x[:, 2]))
    np.testing.assert_allclose(m[:, 2], np.abs(x[:, 1]) * x[:, 3])
    _check_jacobian(s, x)


def _check_jacobian(s, x, h=1e-7):
    """multiplier_jacobian against central differences of multiplier_values."""
    jac = multiplier_jacobian(s, x)
    for i in range(x.shape[1]):
        e = np.zeros(x.shape[1])
        e[i] = h
        fd = (multiplier_values(s, x + e) - multiplier_values(s, x - e)) / (2 * h)
        np.testing.assert_allclose(jac[:, :, i], fd, atol=1e-6)


def test_a_kink_at_zero_sideslip_is_recovered():
    """A drag-like force with 0.19 |beta| (JSBSim's global5000 tabulates its sideslip drag
    linearly through zero): with the |beta| term the fit reaches the noise-free truth, with
    beta*beta alone it cannot."""
    df = campaign(n=20, seed=2)
    rng = np.random.default_rng(8)
    truth = 0.03 + 0.1 * df["alpha"] ** 2 + 0.19 * np.abs(df["beta"]) - 0.3 * df["beta"] ** 2
    cols = {c: df[c].to_numpy() for c in df.columns if c != "maneuver_type"}
    y = truth.to_numpy() + 2e-4 * rng.standard_normal(len(df))
    test = campaign(n=5, seed=12)
    want = 0.03 + 0.1 * test["alpha"] ** 2 + 0.19 * np.abs(test["beta"]) \
        - 0.3 * test["beta"] ** 2
    errs = {}
    for mult in ("1, beta*beta", "1, beta*beta, |beta|"):
        model = fit_structure(parse_structure(f"CX(alpha:2, mach | {mult}) S^1_3"), cols, y)
        errs[mult] = np.sqrt(np.mean((model.predict(test) - want.to_numpy()) ** 2))
    assert errs["1, beta*beta, |beta|"] < 5e-5
    assert errs["1, beta*beta"] > 1e-3
