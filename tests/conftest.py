"""Fixtures shared by the tests; the helpers themselves live in ``helpers.py``."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import NOISY, SAMPLE
from hypothesis import settings

# The same examples on every run (CI included): a property test fails for a reason that can
# be reproduced, never by the luck of a seed.
settings.register_profile("deterministic", derandomize=True, deadline=None)
settings.load_profile("deterministic")


@pytest.fixture
def sample_path() -> Path:
    return SAMPLE


@pytest.fixture
def noisy_path() -> Path:
    return NOISY
