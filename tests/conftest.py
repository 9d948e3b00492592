"""Shared fixtures: paths to the bundled samples and the CMU corpus."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from motionclean.cli import main

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


def run_cli(capsys, *args) -> tuple[int, str, str]:
    """Run the console entry point; return (exit code, stdout, stderr)."""
    with pytest.raises(SystemExit) as done:
        main([os.fspath(a) for a in args])
    captured = capsys.readouterr()
    return done.value.code, captured.out, captured.err


def cut_bvh(source: Path, target: Path, frames: int) -> Path:
    """Copy the first ``frames`` frames of a BVH file, every value's text kept."""
    lines = source.read_text().splitlines(keepends=True)
    at = next(i for i, line in enumerate(lines) if line.startswith("Frames:"))
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(
        "".join(lines[:at])
        + f"Frames: {frames}\n"
        + lines[at + 1]
        + "".join(lines[at + 2 : at + 2 + frames])
    )
    return target
