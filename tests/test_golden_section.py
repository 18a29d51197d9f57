"""Golden-section search: narrows onto the minimum, by tolerance or by steps."""

from __future__ import annotations

import math

import pytest

from simplexspline._golden_section import golden_section


def _recording(fun):
    seen = {}

    def f(x):
        seen[x] = fun(x)
        return seen[x]
    return f, seen


def test_golden_section_narrows_onto_the_minimum_to_the_tolerance():
    f, seen = _recording(lambda x: (x - 0.3) ** 2)
    golden_section(f, -1.0, 2.0, tol=1e-6)
    assert min(seen, key=seen.get) == pytest.approx(0.3, abs=1e-6)


def test_golden_section_takes_the_given_number_of_steps():
    f, seen = _recording(lambda x: abs(x - 1.7))
    golden_section(f, 0.0, 4.0, steps=5)
    assert len(seen) == 2 + 5
    # each step shrinks the bracket by the golden ratio: within 4 * 0.618^6 of the minimum
    assert abs(min(seen, key=seen.get) - 1.7) < 4 * ((math.sqrt(5) - 1) / 2) ** 6


def test_golden_section_needs_a_stopping_rule_and_always_stops():
    with pytest.raises(ValueError, match="tol or steps"):
        golden_section(lambda x: x, 0.0, 1.0)
    with pytest.raises(ValueError, match="tol must be positive"):
        golden_section(lambda x: x, 0.0, 1.0, tol=0.0)
    # a tolerance below the floating-point spacing: it stops when the bracket cannot shrink
    f, seen = _recording(lambda x: (x - 1e6 - 0.3) ** 2)
    golden_section(f, 1e6, 1e6 + 1.0, tol=1e-300)
    assert len(seen) < 200 and min(seen, key=seen.get) == pytest.approx(1e6 + 0.3, abs=1e-6)
