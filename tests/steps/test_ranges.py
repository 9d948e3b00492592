"""Frame ranges with blend on any step: untouched frames byte for byte, the range equal to
the full run, no jump at the edges, clear errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import NOISY, degrees_between, run_cli

import motionclean as mc
from motionclean.steps import REGISTRY, StepSpec
from motionclean.steps.base import crop_runs
from motionclean.steps.pipeline import Pipeline

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
        ("frames=[1e308,1e308]", "the range ends beyond the clip's 300 frames (0-299)"),
        ("frames=[0,9223372036854775807]", "the range ends beyond the clip's 300 frames"),
        ("frames=[10,20],seconds=[0,1]", "either frames or seconds"),
        ("frames=[10,20],blend=400", "does not fit a clip of 300 frames"),
        ("seconds=[0.01,0.015]", "hold no frame"),
        ("frames=[1.5,20]", "whole numbers"),
        ("seconds=[1,1e300]", "ends at 1e+300 s, but the clip's last frame is at"),
        ("blend=3", "blend is used only with frames or seconds"),
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
    entry = json.loads(report.read_text())["pipeline"][0]
    assert entry["frames"] == [FIRST, LAST] and entry["touched"] == [FIRST - 3, LAST + 4]


def test_a_range_in_seconds_is_reported_as_its_frames_too(tmp_path, capsys):
    """seconds=[1,2] at 120 fps is frames 120-240: the report's pipeline entry lists them
    beside the seconds given (it had only seconds and touched)."""
    report = tmp_path / "r.json"
    code, _, err = run_cli(
        capsys, "clean", NOISY, "-o", tmp_path / "o.bvh", "-q", "--report", report,
        "-f", "lee-shin:seconds=[1,2],blend=0",
    )  # fmt: skip
    assert code == 0, err
    entry = json.loads(report.read_text())["pipeline"][0]
    assert entry["seconds"] == [1.0, 2.0] and entry["blend"] == 0
    assert entry["frames"] == [120, 240] and entry["touched"] == [120, 241]
    _, logs = Pipeline.from_inline(["lee-shin:seconds=[1,2],blend=0"]).run(mc.load(NOISY))
    assert logs[0].frames == (120, 240) and logs[0].touched == (120, 241)


def changed_frames(before: np.ndarray, after: np.ndarray, column: int) -> set[int]:
    return set(np.flatnonzero(degrees_between(before[:, column], after[:, column]) > 1e-9))


def test_a_ranged_despike_reports_only_the_repairs_it_made():
    """The note lists the runs within the touched frames, each listed frame changed, and the
    count is theirs; a range without repairs leaves no note."""
    clip = mc.load(NOISY)
    _, full_logs = Pipeline.from_inline(["despike"]).run(clip)
    (joint,) = [j for j, n in full_logs[0].notes.items() if n.get("despike", {}).get("unflipped")]
    full_runs = full_logs[0].notes[joint]["despike"]["unflipped"]
    assert len(full_runs) > 1
    (a, b) = full_runs[0]
    out, logs = Pipeline.from_inline([f"despike:frames=[{a - 5},{b + 2}],blend=2"]).run(clip)
    first, stop = logs[0].touched
    assert (first, stop) == (a - 7, b + 5)
    note = logs[0].notes[joint]["despike"]
    listed = {f for x, y in note["unflipped"] + note["interpolated"] for f in range(x, y)}
    assert listed and all(first <= f < stop for f in listed)
    assert note["frames_repaired"] == len(listed) and "max_step" not in note
    column = clip.names.index(joint)
    assert listed <= changed_frames(clip.rotations, out.rotations, column)
    assert changed_frames(clip.rotations, out.rotations, column) <= set(range(first, stop))

    quiet = Pipeline.from_inline([f"despike:frames=[{b + 1},{b + 1}],blend=0"])
    _, logs = quiet.run(clip)
    assert joint not in logs[0].notes or "despike" not in logs[0].notes[joint]


def test_a_ranged_footlock_reports_only_the_contacts_it_held():
    clip = mc.load(NOISY)
    _, logs = Pipeline.from_inline([f"footlock:min_skate=0,frames=[{FIRST},{LAST}]"]).run(clip)
    first, stop = logs[0].touched
    notes = [n["footlock"] for n in logs[0].notes.values() if "footlock" in n]
    assert notes
    for note in notes:
        assert all(first <= a < b <= stop for a, b in note["contacts"])
        assert note["frames"] == sum(b - a for a, b in note["contacts"])


@pytest.mark.parametrize(
    ("runs", "expected"),
    [
        ([[0, 5], [8, 12], [20, 30]], [[3, 5], [8, 11]]),
        ([[0, 3]], []),
        ([[0, 4]], [[3, 4]]),
        ([[11, 14]], []),
    ],
)
def test_crop_runs(runs, expected):
    assert crop_runs(runs, 3, 11) == expected


def test_a_range_after_a_whole_clip_step_counts_that_steps_frames(monkeypatch):
    """Ranges are checked against the clip up front, and after a step that changes the
    frame count against the clip it made; a whole-clip step itself takes no range."""
    clip = mc.load(NOISY)

    def halve(motion: mc.Motion, params: dict):
        return motion.replace(
            rotations=motion.rotations[::2],
            translations=motion.translations[::2],
            frame_time=2 * motion.frame_time,
            source_values=None,
            source_rotations=None,
        ), {}

    monkeypatch.setitem(REGISTRY, "halve", StepSpec("halve", "test", "-", (), run_motion=halve))
    with pytest.raises(mc.MotionError, match="takes no frame range"):
        Pipeline.from_tables([{"filter": "halve", "frames": [0, 10]}], "t")
    late = [{"filter": "halve"}, {"filter": "lee-shin", "frames": [10, 200]}]
    with pytest.raises(mc.MotionError, match="the clip has 150 frames"):
        Pipeline.from_tables(late, "t").run(clip)
    late[1]["frames"] = [10, 140]
    out, logs = Pipeline.from_tables(late, "t").run(clip)
    assert out.n_frames == 150 and logs[1].touched == (5, 146)


def test_ranges_are_checked_before_any_step_runs(monkeypatch):
    clip = mc.load(NOISY)
    ran = []

    def record(data, params):
        ran.append(True)
        return data

    monkeypatch.setitem(REGISTRY, "record", StepSpec("record", "test", "-", (), run=record))
    tables = [{"filter": "record"}, {"filter": "lee-shin", "frames": [10, 300]}]
    with pytest.raises(mc.MotionError, match="the clip has 300 frames"):
        Pipeline.from_tables(tables, "t").run(clip)
    assert not ran
