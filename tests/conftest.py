"""Shared fixtures: paths to the bundled samples and the CMU corpus."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_data" / "131_02_cut.bvh"
NOISY = ROOT / "sample_data" / "131_02_noisy.bvh"
CORPUS = ROOT.parent / "shared" / "corpus" / "cmu"
CORPUS_CLIPS = sorted(CORPUS.glob("*.bvh")) if CORPUS.is_dir() else []

needs_corpus = pytest.mark.skipif(
    not CORPUS_CLIPS, reason=f"CMU corpus not found at {CORPUS} (see ../shared/corpus/README.md)"
)


@pytest.fixture
def sample_path() -> Path:
    return SAMPLE


@pytest.fixture
def noisy_path() -> Path:
    return NOISY
