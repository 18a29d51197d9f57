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
    assert multiplier_parts("|beta|*qhat") == (("beta", True), ("qhat", False))
    assert multiplier_parts("1") == ()
    assert normal_multiplier(" | de | * qhat ") == "|de|*qhat"
    s = parse_structure("CX(alpha:2, de | 1, |beta|, |de|*qhat) S^1_2")
    assert s.inputs == ("alpha", "de", "beta", "qhat")
    assert s.label() == "CX(alpha:2, de | 1, |beta|, |de|*qhat) S^1_2"
    assert parse_structure(s.label()) == s
    for bad in ("||", "|be|ta|"):
        with pytest.raises(InputError, match="absolute values"):
            parse_structure(f"CX(alpha | 1, {bad}) S^1_2")
    assert {"|beta|", "|de|"} <= set(VARYING_PRESET["CX"].multipliers)


def test_absolute_value_values_and_jacobian():
    s = parse_structure("CX(alpha:2, de | 1, |beta|, |de|*qhat) S^1_2")
    rng = np.random.default_rng(3)
    x = rng.uniform(-0.3, 0.3, (50, 4))
    m = multiplier_values(s, x)
    np.testing.assert_allclose(m[:, 1], np.abs(x[:, 2]))
    np.testing.assert_allclose(m[:, 2], np.abs(x[:, 1]) * x[:, 3])
    jac = multiplier_jacobian(s, x)
    h = 1e-7
    for i in range(4):
        e = np.zeros(4)
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
