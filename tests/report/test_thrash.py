"""Joints of a cleaned clip that thrash (turn fast back and forth, kept up): a twist the
tracker lost is a reason to look, whatever the frame rate; clean captures' fast moves are
not."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import ROOT, corpus_clip, every, run_cli

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.report.summary import _in_motion
from motionclean.report.thrash import THRASH_DEG_PER_S, thrash_frames
from motionclean.report.verdict import LOOK_THRASH_S, build_verdict
from motionclean.run.jobs import clean_motion
from motionclean.steps.pipeline import Pipeline
from motionclean.steps.resampling import resample_motion

EXPORTERS = ROOT / "tests" / "data" / "exporters"
#: The planted twist: on these frames of the clip at 30 fps (8 s of its 10.4 s).
PLANTED = slice(30, 270)


def bone(clip: mc.Motion, joint: int) -> np.ndarray:
    """The unit direction, in ``joint``'s frame at rest, to the farthest point below it."""
    rest = kinematics.rest_positions(clip)
    above = kinematics.point_parents(clip)
    below = [p for p in range(rest.shape[0]) if joint in _chain(above, clip.parents, p)]
    far = max(below, key=lambda p: np.linalg.norm(rest[p] - rest[joint]))
    axis = rest[far] - rest[joint]
    return axis / np.linalg.norm(axis)


def _chain(above: np.ndarray, parents: np.ndarray, point: int) -> list[int]:
    """The joints above ``point`` (of ``kinematics.point_parents``), nearest first."""
    chain, at = [], int(above[point])
    while at >= 0:
        chain.append(at)
        at = int(parents[at])
    return chain


def twisted(clip: mc.Motion, joint: str, frames: slice, seed: int = 0) -> mc.Motion:
    """``clip`` with ``joint`` twisted about its bone by 40 to 90 degrees on every other
    frame of ``frames`` (back to its own rotation between): a twist a tracker lost,
    turning 1,200-2,700 deg/s at 30 fps one way and at once back."""
    rng = np.random.default_rng(seed)
    j = clip.names.index(joint)
    count = len(range(*frames.indices(clip.n_frames)))
    angles = np.radians(rng.uniform(40.0, 90.0, count)) * (np.arange(count) % 2)
    twist = quat.from_axis_angle(bone(clip, j), angles[:, None])[:, 0]
    rotations = clip.rotations.copy()
    rotations[frames, j] = quat.multiply(rotations[frames, j], twist)
    return clip.replace(rotations=rotations, source_values=None, source_rotations=None)


def thrashing(clip: mc.Motion, joint: str) -> np.ndarray:
    """``(F,)`` bool: the frames of ``joint`` of ``clip`` a thrash covers (nothing left out)."""
    q = clip.rotations[:, [clip.names.index(joint)]]
    return thrash_frames(q, clip.frame_time, np.ones((clip.n_frames - 1, 1), dtype=bool))[:, 0]


@pytest.fixture(scope="module")
def walk30() -> mc.Motion:
    """CMU 131_02 at 30 fps (every 4th frame), 312 frames."""
    return every(mc.load(corpus_clip("131_02.bvh")), 4)


def test_a_wrist_twisting_back_and_forth_needs_a_look(walk30, tmp_path, capsys):
    """A wrist twisted back and forth by 40-90 degrees a frame over 8 s of a 30 fps corpus
    walk: under the speed limit (3,600 deg/s), no half turn for despike, and the noise model
    leaves it; the line had read "clean capture, repaired: 13 flips repaired on RThumb,
    otherwise left as it was". Now it needs a look, on the planted frames of the written
    clip, and says the cleaning left the wrist as it was."""
    source, target = tmp_path / "twist.bvh", tmp_path / "out.bvh"
    mc.save(twisted(walk30, "LeftWrist", PLANTED), source)
    report = tmp_path / "r.json"
    code, out, _ = run_cli(capsys, "clean", source, "-o", target, "--report", report)
    line = next(line for line in out.splitlines() if line.startswith("verdict: "))
    written = mc.load(target)
    found = np.flatnonzero(thrashing(written, "LeftWrist"))
    frames = found.size
    assert code == 0 and frames >= 0.95 * (PLANTED.stop - PLANTED.start)
    assert found.min() >= PLANTED.start - 2 and found.max() < PLANTED.stop + 2
    seconds = frames * written.frame_time
    assert line.startswith(
        "verdict: needs a look: LeftWrist thrashes (turns back and forth at over "
        f"{THRASH_DEG_PER_S:,.0f} deg/s) on {frames} frames ({seconds:.1f} s), left as it was."
    ), line
    verdict = json.loads(report.read_text())["verdict"]
    assert verdict["status"] == "needs a look" and verdict["text"] == line[len("verdict: ") :]
    assert verdict["thrash"] == {
        "LeftWrist": {"frames": frames, "window_seconds": pytest.approx(seconds)}
    }
    assert verdict["too_fast"] == {}  # (told as thrash: it turns slower than a body can)


@pytest.mark.parametrize(
    ("clip", "step"),
    [
        ("131_02.bvh", 4),  # the planted clip, as captured
        ("131_03.bvh", 1),  # the corpus' fastest wrist, through a hop
        ("131_03.bvh", 5),  # ... at 24 fps, where it thrashes most: 2.0 s
        (EXPORTERS / "video2bvh_zup.bvh", 1),  # video estimates: noisy, slow
        (EXPORTERS / "video_estimate_cmu_names.bvh", 1),
        (EXPORTERS / "mocapbank_walk.bvh", 1),
    ],
    ids=lambda value: getattr(value, "name", str(value)),
)
def test_clean_captures_do_not_thrash(clip, step):
    """The default cleaning of clean captures and video estimates at 24 to 120 fps leaves
    no joint thrashing on more than two thirds of the time that needs a look."""
    path = corpus_clip(clip) if isinstance(clip, str) else clip
    result = clean_motion(every(mc.load(path), step), Pipeline.default(), path.name)
    assert result.report["verdict"]["thrash"] == {}
    assert "thrash" not in result.report["verdict"]["text"]
    worst = [seconds for _, seconds in result.series["thrash"].values()]
    assert max(worst, default=0.0) < LOOK_THRASH_S / 1.5


def test_the_same_thrash_at_30_and_120_fps_is_flagged_alike(walk30):
    """The planted twist resampled to 120 fps (a 15 Hz swing, no longer from frame to frame
    but over four) thrashes on as many seconds as at 30 fps: both need a look, within 5 %."""
    slow = twisted(walk30, "LeftWrist", PLANTED)
    fast = resample_motion(slow, 1.0 / 120.0)
    found = [clean_motion(c, Pipeline.default(), "x.bvh").report["verdict"] for c in (slow, fast)]
    assert [list(verdict["thrash"]) for verdict in found] == [["LeftWrist"], ["LeftWrist"]]
    at30, at120 = (verdict["thrash"]["LeftWrist"] for verdict in found)
    assert at120["window_seconds"] == pytest.approx(at30["window_seconds"], rel=0.05)
    assert at30["window_seconds"] > LOOK_THRASH_S and at120["frames"] > 3.5 * at30["frames"]


@pytest.mark.parametrize("fps", [24, 25, 30, 50, 60, 100, 120])
def test_thrash_is_a_time_at_any_rate(fps):
    """A joint swinging 40 degrees either way at 6 Hz (960 deg/s) for 2 s of 4 thrashes on
    2 s of frames at every rate, whether its turns fall on frames or between them; one
    swinging 30 degrees at 5 Hz (600 deg/s, under the limit) on none."""
    dt = 1.0 / fps
    t = np.arange(4 * fps) * dt
    swinging = (t >= 1.0) & (t < 3.0)
    measured = np.ones((t.size - 1, 1), dtype=bool)
    for degrees, hertz, expected in ((40.0, 6.0, 2.0), (30.0, 5.0, 0.0)):
        angle = np.radians(degrees) * 2.0 / np.pi * np.arcsin(np.sin(2.0 * np.pi * hertz * t))
        q = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), (angle * swinging)[:, None])
        seconds = thrash_frames(q, dt, measured).sum() * dt
        assert seconds == pytest.approx(expected, abs=0.05), (degrees, hertz)


def test_thrash_is_measured_within_the_motion():
    """Spans over a step that does not count (a rest frame, a cut between takes, a missing
    sample) are left out: a swing thrashing on every frame but the last, cut between frames
    59 and 60, loses frame 59 alone (its turn lies across the cut)."""
    dt = 1.0 / 30.0
    t = np.arange(120) * dt
    angle = np.radians(40.0) * 2.0 / np.pi * np.arcsin(np.sin(2.0 * np.pi * 6.0 * t))
    q = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), angle[:, None])
    shape = (t.size - 1, 1)
    whole = thrash_frames(q, dt, _in_motion(shape, None, np.zeros(0, dtype=np.intp), 0, 0))
    cut = thrash_frames(q, dt, _in_motion(shape, None, np.array([60]), 0, 0))
    assert whole[:-1].all() and np.flatnonzero(~cut[:-1]).tolist() == [59]


def test_the_line_names_the_joints_that_thrash_most():
    """Several joints thrashing: each with its frames and seconds, most first, three named;
    joints under the time that needs a look, or told as too fast, are not named; "left as
    they were" only where the cleaning changed none of them."""
    unchanged = {"deviation_deg": {"rms": 0.0, "max": 0.0}}
    report = {
        "frames": 3945,
        "frame_time": 1.0 / 30.0,
        "joints": {name: unchanged for name in ("RightHand", "LeftHand", "Head", "Hips")},
        "summary": {},
        "contacts": None,
    }
    smoothing = {
        "noise_removed": 0.01,
        "change_deg_max": 0.02,
        "change_deg_rms": 0.01,
        "change_joint": "Head",
        "fast_steps": {"Chest": (900, 3944)},  # too fast: told so, not as thrash
        "thrash": {
            "LeftHand": (268, 6.1),
            "RightHand": (465, 10.1),
            "Neck": (300, LOOK_THRASH_S),  # (exactly the limit: not more)
            "Head": (150, 3.6),
            "Hips": (120, 4.0),
            "Chest": (900, 30.0),
            "Spine": (30, 1.0),
        },
    }
    verdict = build_verdict(report, smoothing)
    assert verdict["status"] == "needs a look"
    assert list(verdict["thrash"]) == ["RightHand", "LeftHand", "Head", "Hips"]
    assert verdict["thrash"]["Head"] == {"frames": 150, "window_seconds": 3.6}
    assert (
        "RightHand (465 frames, 15.5 s), LeftHand (268, 8.9 s), Head (150, 5.0 s) and 1 more "
        "joint thrash (turn back and forth at over 700 deg/s), left as they were."
    ) in verdict["text"], verdict["text"]
    for name in ("Neck", "Spine"):
        assert name not in verdict["text"]
    report["joints"]["Hips"] = {"deviation_deg": {"rms": 0.5, "max": 2.0}}
    assert "left as they were" not in build_verdict(report, smoothing)["text"]


@pytest.mark.parametrize("fps", [30.0, 120.0])
def test_thrash_frames_match_the_definition_span_by_span(fps):
    """Every span of every joint checked one by one, as the module states the rule (the
    turn into a frame and the turn out of it, a frame's pause allowed, both faster than
    the limit and more than 90 degrees apart), gives the frames thrash_frames finds: the
    joints it passes over (no frame step over the limit) cannot thrash over longer
    spans either."""
    from motionclean.report.thrash import PAUSE_FRAMES, _lags

    rng = np.random.default_rng(3)
    frames, dt = 80, 1.0 / fps
    speeds = np.radians([200.0, 650.0, 900.0, 2000.0]) * dt  # per-frame turn, radians
    steps = rng.normal(size=(frames - 1, speeds.size, 3)) * speeds[:, None] / np.sqrt(3)
    steps[20:40] *= np.where(np.arange(20) % 2, 1.0, -1.0)[:, None, None]  # back and forth
    q = np.zeros((frames, speeds.size, 4))
    q[0, :, 0] = 1.0
    for t in range(1, frames):  # each frame turned from the last by its step (half-angles)
        q[t] = quat.multiply(q[t - 1], quat.exp(steps[t - 1] / 2))
    found = thrash_frames(q, dt, np.ones((frames - 1, speeds.size), dtype=bool))
    expected = np.zeros_like(found)
    limit = np.radians(THRASH_DEG_PER_S) * dt / 2.0
    for k in _lags(dt).tolist():
        turn = quat.log_relative(q[:-k], q[k:])
        for pause in range(PAUSE_FRAMES + 1):
            for r in range(frames - 2 * k - pause):
                into, out = turn[r], turn[r + k + pause]
                hit = (
                    (np.linalg.norm(into, axis=-1) > limit * k)
                    & (np.linalg.norm(out, axis=-1) > limit * k)
                    & (np.einsum("ci,ci->c", into, out) < 0.0)
                )
                expected[r : r + 2 * k + pause + 1] |= hit
    np.testing.assert_array_equal(found, expected)
    assert found[:, 3].any() and not found[:, 0].any()


def test_a_clip_reported_on_its_own_names_its_thrashing_joints(walk30, tmp_path, capsys):
    """`report IN` alone had said only the input's noise: a clip whose wrist thrashes for
    8 s reads "needs a look" there too, and its JSON verdict lists the joint; the clip
    without the planted twist does not."""
    planted = twisted(walk30, "LeftWrist", PLANTED)
    for clip, flagged in ((planted, True), (walk30, False)):
        path, report = tmp_path / "in.bvh", tmp_path / "r.json"
        mc.save(clip, path)
        code, out, _ = run_cli(capsys, "report", str(path), "--json", str(report))
        verdict = json.loads(report.read_text())["verdict"]
        assert code == 0 and verdict["status"] == "input only"
        assert bool(verdict["thrash"]) is flagged
        assert ("needs a look" in out and "thrash" in out) is flagged
