"""Shared test helpers: sample and corpus paths, the CLI runner, clip cutting, angles.

Corpus clips are named here (from ``../shared/corpus/README.md``) rather than globbed, so a
test parametrised over them is collected and skipped with a reason when the corpus is absent,
instead of vanishing.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from motionclean import quat
from motionclean.cli import main

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_data" / "131_02_cut.bvh"
NOISY = ROOT / "sample_data" / "131_02_noisy.bvh"
CORPUS = ROOT.parent / "shared" / "corpus" / "cmu"
CORPUS_NAMES = ("131_01.bvh", "131_02.bvh", "131_03.bvh")
CORPUS_CLIPS = sorted(CORPUS.glob("*.bvh")) if CORPUS.is_dir() else []
NO_CORPUS = f"CMU corpus not found at {CORPUS} (see ../shared/corpus/README.md)"

needs_corpus = pytest.mark.skipif(not CORPUS_CLIPS, reason=NO_CORPUS)


def corpus_clip(name: str = "131_02.bvh") -> Path:
    """The path of corpus clip ``name``; skips the calling test when it is missing."""
    path = CORPUS / name
    if not path.is_file():
        pytest.skip(NO_CORPUS if not CORPUS.is_dir() else f"corpus clip {path} not found")
    return path


def degrees_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle between quaternions ``a`` and ``b`` (..., 4), degrees."""
    return np.degrees(quat.angle_between(a, b))


def max_degrees(a: np.ndarray, b: np.ndarray) -> float:
    """Largest rotation angle between ``a`` and ``b``, degrees."""
    return float(degrees_between(a, b).max())


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
