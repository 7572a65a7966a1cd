# Shared pytest fixtures for the trainctl test suite.
"""Fixtures: a headless matplotlib backend, a seeded random generator."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest


@pytest.fixture(autouse=True, scope="session")
def _matplotlib_agg() -> Iterator[None]:
    """Use the non-interactive Agg backend; pyplot is not imported here."""
    import matplotlib

    matplotlib.use("Agg")
    yield


@pytest.fixture
def rng() -> np.random.Generator:
    """A NumPy random generator with a fixed seed."""
    return np.random.default_rng(0)
