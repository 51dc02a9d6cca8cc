"""Shared fixtures."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    """Seeded random generator (tests never use the global RNG)."""
    return np.random.default_rng(20261122)
