"""Poses a capture held (the last sample repeated through a dropout): found where a moving
joint stops dead and jumps on, bridged by the default; keyframed holds, stepped keys,
duplicated frames and quantised values left alone."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import ROOT, corpus_clip, degrees_between

import motionclean as mc
from motionclean.core.holds import held_samples
from motionclean.core.takes import take_starts
from motionclean.report.html import render_html
from motionclean.report.verdict import held_poses
from motionclean.run.jobs import clean_motion
from motionclean.steps.pipeline import Pipeline

FROZEN = slice(400, 412)  # 12 frames (0.1 s at 120 fps) repeating frame 399


@pytest.fixture(scope="module")
def truth() -> mc.Motion:
    return mc.load(corpus_clip("131_02.bvh"))


def frozen(motion: mc.Motion, frames: slice, joints=slice(None)) -> mc.Motion:
    """``motion`` with ``joints`` holding frame ``frames.start - 1`` over ``frames``."""
    rotations, translations = motion.rotations.copy(), motion.translations.copy()
    rotations[frames, joints] = rotations[frames.start - 1, joints]
    translations[frames, joints] = translations[frames.start - 1, joints]
    return motion.replace(rotations=rotations, translations=translations)


def moving_near(motion: mc.Motion, frames: slice) -> np.ndarray:
    """``(J,)``: joints turning or moving on every step within 4 frames of ``frames``."""
    q, t = motion.rotations, motion.translations
    around = np.r_[frames.start - 5 : frames.start, frames.stop : frames.stop + 5]
    turning = degrees_between(q[around[1:]], q[around[1:] - 1]) > 0
    moving = np.linalg.norm(t[around[1:]] - t[around[1:] - 1], axis=-1) > 0
    return (turning | moving).all(axis=0)


def test_a_whole_pose_held_is_found_on_the_joints_that_move(truth):
    held = held_samples(frozen(truth, FROZEN))
    assert np.array_equal(np.flatnonzero(held.any(axis=1)), np.arange(400, 412))
    moving = moving_near(truth, FROZEN)
    assert np.array_equal(held.any(axis=0), moving)  # still joints repeat anyway
    assert moving.sum() >= 20
    assert not held_samples(truth).any()  # the capture itself holds nothing
    assert not take_starts(frozen(truth, FROZEN)).size  # its step out is no cut of takes


def test_the_default_bridges_a_held_pose_close_to_the_capture(truth):
    clip = frozen(truth, FROZEN)
    result = clean_motion(clip, Pipeline.default(), "frozen.bvh")
    moving = moving_near(truth, FROZEN)
    smooth = moving & (np.array(truth.names) != "RThumb")  # (RThumb flips: despike's)
    before = degrees_between(clip.rotations[FROZEN], truth.rotations[FROZEN])[:, smooth]
    after = degrees_between(result.after.rotations[FROZEN], truth.rotations[FROZEN])[:, smooth]
    assert before.max() > 10.0
    assert after.max() < before.max() / 5
    root_before = np.abs(clip.translations[FROZEN, 0] - truth.translations[FROZEN, 0]).max()
    root_after = np.abs(result.after.translations[FROZEN, 0] - truth.translations[FROZEN, 0])
    assert root_after.max() < root_before / 5
    text = result.report["verdict"]["text"]
    assert f"1 held pose bridged on {moving.sum()} joints" in text, text
    assert not held_samples(result.after).any()  # cleaning again bridges nothing more


def test_one_joint_held_is_bridged_alone(truth):
    elbow = truth.names.index("LeftElbow")
    speed = degrees_between(truth.rotations[1:, elbow], truth.rotations[:-1, elbow])
    start = 100 + int(np.argmax(speed[100:-100]))  # where it turns fastest
    lost_frames = slice(start, start + 6)
    clip = frozen(truth, lost_frames, elbow)
    held = held_samples(clip)
    assert np.array_equal(np.argwhere(held), [[f, elbow] for f in range(start, start + 6)])
    result = clean_motion(clip, Pipeline.default(), "elbow.bvh")
    note = result.report["joints"]["LeftElbow"]["fill-gaps"]
    assert note["held"] == [[start, start + 6]]
    error = degrees_between(
        result.after.rotations[lost_frames, elbow], truth.rotations[lost_frames, elbow]
    )
    lost = degrees_between(clip.rotations[lost_frames, elbow], truth.rotations[lost_frames, elbow])
    assert error.max() < lost.max() / 3


@pytest.mark.parametrize(
    "kind", ["at the end", "at the start", "one repeat", "duplicated frames", "on threes"]
)
def test_repeats_that_are_not_dropouts_are_left(truth, kind):
    n = truth.n_frames
    if kind == "at the end":
        clip = frozen(truth, slice(n - 12, n))
    elif kind == "at the start":  # frames 0..11 all hold frame 12's pose (a rest lead-in)
        clip = frozen(truth.at_frames(np.r_[np.full(12, 12), 12:n]), slice(1, 13))
    elif kind == "one repeat":  # a frame doubled, as rate conversions do
        clip = truth.at_frames(np.r_[:400, 399, 400:n])
    elif kind == "duplicated frames":
        clip = truth.at_frames(np.repeat(np.arange(300), 2))
    else:  # animation "on threes": each pose held three frames, every pose
        clip = truth.at_frames(np.repeat(np.arange(0, n, 3), 3))
    assert not held_samples(clip).any()


def test_one_repeated_frame_is_no_held_pose_and_two_are(truth):
    """The same step out, from frame 99's pose into frame 102's (three steps' worth), after
    one repeat of frame 99 and after two: a held pose only from two repeated frames on (a
    single repeat is how a rate conversion duplicates a frame)."""
    n = truth.n_frames
    once = held_samples(truth.at_frames(np.r_[:100, 99, 102:n]))
    twice = held_samples(frozen(truth, slice(100, 102)))
    assert not once.any()
    assert np.array_equal(np.flatnonzero(twice.any(axis=1)), [100, 101])


def test_stepped_keys_of_an_exporter_are_left():
    """Mixamo's export keys a finger in steps: it holds, jumps, holds (no motion between)."""
    clip = mc.load(ROOT / "tests" / "data" / "exporters" / "mixamo_tpose.bvh")
    q = clip.rotations
    repeats = np.all(q[1:] == q[:-1], axis=-1)
    assert (repeats.sum(axis=0) >= 10).any()  # it does hold values
    assert not held_samples(clip).any()


def test_values_quantised_by_a_writer_are_left(tmp_path, truth):
    """Channels written to 0.5 (degrees, units): slow joints hold and step by a quantum."""
    text = corpus_clip("131_02.bvh").read_text()
    head, _, frames = text.partition("Frame Time:")
    time_line, _, rows = frames.partition("\n")

    def half(match: re.Match) -> str:
        return f"{round(float(match.group()) * 2) / 2:g}"

    rows = re.sub(r"-?\d+\.\d+(e-?\d+)?", half, rows)
    path = tmp_path / "quantised.bvh"
    path.write_text(head + "Frame Time:" + time_line + "\n" + rows)
    clip = mc.load(path)
    q = clip.rotations
    assert np.all(q[1:] == q[:-1], axis=-1).sum() > 1000  # many exact repeats
    assert not held_samples(clip).any()


def test_a_held_pose_longer_than_max_gap_is_left_and_needs_a_look(truth):
    """100 frames (0.83 s) held: over fill-gaps' max_gap of 0.5 s, left as captured
    (every joint but the flipping thumb bit for bit), noted and told in the verdict."""
    clip = frozen(truth, slice(400, 500))
    result = clean_motion(clip, Pipeline.default(), "long.bvh")
    kept = np.array(truth.names) != "RThumb"
    assert np.array_equal(result.after.rotations[400:500, kept], clip.rotations[400:500, kept])
    assert result.report["joints"]["LeftKnee"]["fill-gaps"]["held_left"] == [[400, 500]]
    verdict = result.report["verdict"]
    assert verdict["status"] == "needs a look"
    assert "a pose the capture held left as captured on" in verdict["text"]
    assert "frames 400-499 (longer than fill-gaps' max_gap)" in verdict["text"]


def test_held_poses_are_counted_as_the_distinct_runs_held(truth):
    """Two holds at different times on two joints: two held poses, on the line and the
    page alike; a whole pose held: one, on every joint that holds it."""
    elbow, knee = truth.names.index("LeftElbow"), truth.names.index("RightKnee")
    speed = degrees_between(truth.rotations[1:], truth.rotations[:-1])
    starts = [100 + int(np.argmax(speed[100:600, j])) for j in (elbow, knee)]
    clip = frozen(
        frozen(truth, slice(starts[0], starts[0] + 6), elbow), slice(starts[1], starts[1] + 6), knee
    )
    result = clean_motion(clip, Pipeline.default(), "two.bvh")
    text = result.report["verdict"]["text"]
    assert "2 held poses bridged on 2 joints" in text, text
    assert held_poses(result.report["joints"]) == 2
    whole = clean_motion(frozen(truth, FROZEN), Pipeline.default(), "one.bvh")
    assert held_poses(whole.report["joints"]) == 1
    assert "1 held pose" in render_html(whole.report, whole.series)
