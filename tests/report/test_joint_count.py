"""One joint count everywhere: an OpenSim clip's translations (``pelvis_tx`` ...) are told
apart from its joints in the page's header, its figures heading and the terminal table."""

from __future__ import annotations

import re

import numpy as np
from helpers import run_cli

ROTATIONS = [f"angle_{k}" for k in range(12)]
TRANSLATIONS = ["pelvis_tx", "pelvis_ty", "pelvis_tz"]


def write_mot(path, frames: int = 60) -> None:
    """An IK .mot of 12 rotational and 3 translational coordinates, slow waves with noise."""
    rng = np.random.default_rng(0)
    t = np.arange(frames)[:, None] / 60.0
    names = ROTATIONS + TRANSLATIONS
    waves = 20.0 * np.sin(2.0 * np.pi * 0.8 * t + np.arange(len(names)))
    waves[:, len(ROTATIONS) :] *= 0.01  # metres
    values = waves + rng.normal(0.0, 0.3, waves.shape) * (np.arange(len(names)) < len(ROTATIONS))
    head = f"Coordinates\nversion=1\nnRows={frames}\nnColumns={len(names) + 1}\ninDegrees=yes\n"
    rows = ["\t".join(f"{v:.8f}" for v in (i / 60.0, *row)) for i, row in enumerate(values)]
    text = head + "endheader\n" + "\t".join(["time", *names]) + "\n" + "\n".join(rows) + "\n"
    path.write_text(text)


def test_the_header_the_figures_and_the_table_count_alike(tmp_path, capsys):
    """The page's header had said 15 joints, its figures heading 12, the terminal table
    10 and "... 2 more joints": the translations were counted in one place only."""
    clip, page = tmp_path / "ik.mot", tmp_path / "ik.html"
    write_mot(clip)
    code, out, _ = run_cli(capsys, "clean", clip, "-o", tmp_path / "out.mot", "--report", page)
    assert code == 0
    text = page.read_text()
    counted = "12 joints and 3 translations"
    assert re.search(rf"60 frames at 60 fps \([\d.]+ s\), {counted}; ", text)
    assert f"Figures of all {counted}, noisiest first" in text
    lines = out.splitlines()
    assert f"60 frames at 60 fps, {counted}, numbered from 0" in lines[0]
    assert "... 2 more joints" in lines
