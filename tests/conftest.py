"""Shared pytest configuration for the whole test suite."""

from __future__ import annotations

import os
import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

# Deterministic property tests in CI: same examples every run, no example database on disk.
settings.register_profile(
    "ci",
    derandomize=True,
    database=None,
    deadline=None,
    max_examples=20,
    suppress_health_check=[HealthCheck.too_slow],
    print_blob=True,
)
settings.register_profile(
    "dev",
    database=None,
    deadline=None,
    max_examples=100,
    suppress_health_check=[HealthCheck.too_slow],
    print_blob=True,
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture
def rng(request) -> np.random.Generator:
    """A random generator seeded from the test's node id: reproducible per test."""
    return np.random.default_rng(zlib.crc32(request.node.nodeid.encode()))
