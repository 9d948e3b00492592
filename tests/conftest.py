"""Fixtures shared by the tests; the helpers themselves live in ``helpers.py``."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import NOISY, SAMPLE


@pytest.fixture
def sample_path() -> Path:
    return SAMPLE


@pytest.fixture
def noisy_path() -> Path:
    return NOISY
