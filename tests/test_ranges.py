"""Frame ranges with blend on any step: untouched frames byte for byte, the range equal to
the full run, no jump at the edges, clear errors."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import NOISY, degrees_between, run_cli

import motionclean as mc
from motionclean.pipeline import Pipeline

STEPS = [
    "lee-shin:k=2,iterations=3",
    "bilateral:sigma_t=2,sigma_g=0.2",
    "fairing:max_iterations=20",
    "sse-fairing:max_iterations=20",
    "multires:levels=3",
    "despike",
    "auto",
    "footlock:min_skate=0",
]
FIRST, LAST, BLEND = 100, 180, 6


def frame_rows(path) -> list[str]:
    lines = path.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
    return lines[start:]


@pytest.mark.parametrize("step", STEPS)
def test_a_step_on_a_range(step, tmp_path, capsys):
    ranged = f"{step}{',' if ':' in step else ':'}frames=[{FIRST},{LAST}],blend={BLEND}"
    out = tmp_path / "ranged.bvh"
    code, _, err = run_cli(capsys, "clean", NOISY, "-o", out, "-q", "-f", ranged)
    assert code == 0, err
    rows_in, rows_out = frame_rows(NOISY), frame_rows(out)
    outside = [f for f in range(len(rows_in)) if f < FIRST - BLEND or f > LAST + BLEND]
    assert all(rows_out[f] == rows_in[f] for f in outside)  # byte for byte

    clip = mc.load(NOISY)
    full, _ = Pipeline.from_inline([step]).run(clip)
    part, _ = Pipeline.from_inline([ranged]).run(clip)
    inside = slice(FIRST, LAST + 1)
    assert degrees_between(part.rotations[inside], full.rotations[inside]).max() < 1e-9
    np.testing.assert_allclose(part.translations[inside], full.translations[inside], atol=1e-9)
    # no jump at the edges larger than the clip's own motion there
    for edge in (FIRST - BLEND - 1, LAST + BLEND):
        window = slice(edge - BLEND - 2, edge + BLEND + 3)
        steps = degrees_between(part.rotations[window][:-1], part.rotations[window][1:])
        own = np.maximum(
            degrees_between(clip.rotations[window][:-1], clip.rotations[window][1:]),
            degrees_between(full.rotations[window][:-1], full.rotations[window][1:]),
        )
        # (the blend adds the rate of the result's departure from the input: a few %)
        assert np.all(steps <= 1.05 * own.max(axis=0) + 1e-9)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ("frames=[50,20]", "reversed"),
        ("frames=[10,400]", "the clip has 300 frames (0-299)"),
        ("frames=[10,20],seconds=[0,1]", "either frames or seconds"),
        ("frames=[10,20],blend=400", "does not fit a clip of 300 frames"),
        ("seconds=[0.01,0.015]", "hold no frame"),
        ("frames=[1.5,20]", "whole numbers"),
    ],
)
def test_bad_ranges_are_one_line_and_exit_2(extra, message, tmp_path, capsys):
    out = tmp_path / "o.bvh"
    code, _, err = run_cli(capsys, "clean", NOISY, "-o", out, "-f", f"lee-shin:{extra}")
    assert code == 2 and message in err and err.count("\n") == 1 and not out.exists()


def test_seconds_pick_the_same_frames_and_the_report_says_which(tmp_path, capsys):
    clip = mc.load(NOISY)
    a, _ = Pipeline.from_inline([f"lee-shin:frames=[{FIRST},{LAST}]"]).run(clip)
    t0, t1 = FIRST * clip.frame_time, LAST * clip.frame_time
    b, _ = Pipeline.from_inline([f"lee-shin:seconds=[{t0},{t1}]"]).run(clip)
    np.testing.assert_array_equal(a.rotations, b.rotations)
    report = tmp_path / "r.json"
    run_cli(
        capsys,
        "clean",
        NOISY,
        "-o",
        tmp_path / "o.bvh",
        "-q",
        "--report",
        report,
        "-f",
        f"lee-shin:frames=[{FIRST},{LAST}],blend=3",
    )
    import json

    entry = json.loads(report.read_text())["pipeline"][0]
    assert entry["frames"] == [FIRST, LAST] and entry["touched"] == [FIRST - 3, LAST + 3]
