"""Fixtures shared by the tests; the helpers themselves live in ``helpers.py``."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from helpers import NOISY, ROOT, SAMPLE, Chromium
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


@pytest.fixture(scope="module")
def dask_scheduler() -> Iterator[str]:
    """The address of a real Dask scheduler with one in-process worker, shared by a test
    file's tests and closed after them: its threads draw from the ``random`` module, which
    Hypothesis takes for a strategy's draw if it happens during a later file's property
    test (the likely source of a deprecation warning in one CI run). Skips when the dask
    extra is missing."""
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=":0"
    ) as local:
        yield local.scheduler_address


#: Longest wait for the shared browser to answer (a page with a virtual-time budget:
#: about 0.3 s), seconds.
CHROMIUM_TIMEOUT_S = 90.0


@pytest.fixture(scope="session")
def chromium() -> Iterator[Chromium]:
    """One headless Chromium for the session's browser tests (skips, saying why, when there
    is none or it cannot run here)."""
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import screenshot_report
    finally:
        sys.path.pop(0)
    browser = screenshot_report.find_browser()
    if browser is None:
        pytest.skip("no Chromium on PATH (apt-get install chromium); browser check skipped")
    shared = Chromium(browser, screenshot_report.FLAGS, CHROMIUM_TIMEOUT_S)
    try:
        shared.send("Browser.getVersion")
    except (OSError, RuntimeError, TimeoutError) as error:
        shared.close()
        pytest.skip(f"Chromium could not run here: {error}")
    yield shared
    shared.close()
