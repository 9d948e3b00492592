"""Fixtures shared by the tests; the helpers themselves live in ``helpers.py``."""

from __future__ import annotations

from collections.abc import Iterator
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


@pytest.fixture(scope="session")
def dask_scheduler() -> Iterator[str]:
    """The address of a real Dask scheduler with one in-process worker, shared by the
    session's tests (skips when the dask extra is missing)."""
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=":0"
    ) as local:
        yield local.scheduler_address
