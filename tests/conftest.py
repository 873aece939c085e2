"""Shared fixtures and tolerances of the test suite."""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "rsmbench", max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "rsmbench"))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(123)
