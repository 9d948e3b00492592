"""Rest-pose frames at the ends of a clip: kept bit for bit, left out of every step and of
the report's figures."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import (
    CMU_01_01_START,
    CORPUS_NAMES,
    NOISY,
    ROOT,
    SAMPLE,
    corpus_clip,
    degrees_between,
    run_cli,
    with_t_pose,
)

import motionclean as mc
from motionclean.core.restpose import rest_frames, trim


@pytest.mark.parametrize(("frames", "at_end"), [(1, False), (3, False), (1, True)])
def test_rest_frames_are_found(tmp_path, frames, at_end):
    clip = mc.load(with_t_pose(NOISY, tmp_path / "t.bvh", frames, at_end))
    assert rest_frames(clip) == ((0, frames) if at_end else (frames, 0))
    assert rest_frames(mc.load(NOISY)) == (0, 0)


def test_a_t_pose_first_frame_is_kept_bit_for_bit_and_out_of_the_figures(tmp_path, capsys):
    posed = with_t_pose(NOISY, tmp_path / "t.bvh")
    out, report = tmp_path / "out.bvh", tmp_path / "r.json"
    code, text, _ = run_cli(capsys, "clean", posed, "-o", out, "--report", report)
    assert code == 0 and "rest pose: frame 0 kept" in text
    rows_in = posed.read_text().splitlines()
    rows_out = out.read_text().splitlines()
    start = next(i for i, line in enumerate(rows_in) if line.startswith("Frame Time")) + 1
    assert rows_out[start] == rows_in[start]  # the T-pose frame, byte for byte
    # The motion after it is cleaned as without the T-pose (the same poses; the Euler
    # branch of a changed sample may follow the frame before it).
    plain = tmp_path / "plain.bvh"
    run_cli(capsys, "clean", NOISY, "-o", plain, "--report", tmp_path / "p.json")
    assert degrees_between(mc.load(out).rotations[1:], mc.load(plain).rotations).max() < 1e-4
    figures = json.loads(report.read_text())
    reference = json.loads((tmp_path / "p.json").read_text())
    assert figures["rest_frames"] == {"leading": 1, "trailing": 0}
    assert figures["summary"]["noise_reduction"] == pytest.approx(
        reference["summary"]["noise_reduction"], rel=1e-9
    )
    despike = figures["joints"]["RThumb"]["despike"]
    expected = reference["joints"]["RThumb"]["despike"]
    assert despike["unflipped"] == [[a + 1, b + 1] for a, b in expected["unflipped"]]
    assert np.isclose(figures["world"]["body_height"], reference["world"]["body_height"])


def test_a_reference_pose_out_of_which_most_joints_move_once_is_found():
    """A Rokoko export's first frame sets its fingers (40 of its 53 moving joints), which
    hold one pose for the rest of the clip: the step out of the reference frame was each
    finger's only move, so it was its typical step and no jump, and the frame was taken
    for motion (the fingers smoothed by up to 83 degrees, the verdict "needs a look"). The
    typical steps are those of the frames within the rest poses: here the sample with two
    thirds of its moving joints held after a posed first frame."""
    from motionclean.core import quat
    from motionclean.steps.pipeline import Pipeline

    clip = mc.load(SAMPLE)
    q = clip.rotations.copy()
    moving = np.flatnonzero(np.any(q != q[:1], axis=(0, 2)))
    held = moving[: 2 * moving.size // 3]
    q[:, held] = q[:1, held]  # still after the reference frame, as the export's fingers
    turn = quat.from_axis_angle(np.array([0.0, 0.6, 0.8]), np.radians(30.0))
    reference = quat.multiply(q[:1], turn)  # every joint posed 30 degrees off
    rows = np.concatenate([reference, q])
    t = np.concatenate([clip.translations[:1], clip.translations])
    posed = clip.replace(rotations=rows, translations=t, source_values=None, source_rotations=None)
    motion = clip.replace(rotations=q, source_values=None, source_rotations=None)
    assert rest_frames(posed) == (1, 0) and rest_frames(motion) == (0, 0)
    out, _ = Pipeline.default().run(posed)
    np.testing.assert_array_equal(out.rotations[0], rows[0])
    alone, _ = Pipeline.default().run(motion)
    assert degrees_between(out.rotations[1:], alone.rotations).max() < 1e-6


def with_held_pose(source, target, frames: int, at_end: bool = False):
    """``source`` with its first (or last) frame repeated to ``frames`` identical frames, as
    exports padded with a held pose are."""
    lines = source.read_text().splitlines(keepends=True)
    at = next(i for i, line in enumerate(lines) if line.startswith("Frames:"))
    body = lines[at + 2 :]
    rows = body + [body[-1]] * (frames - 1) if at_end else [body[0]] * (frames - 1) + body
    target.write_text(
        "".join(lines[:at]) + f"Frames: {len(rows)}\n" + lines[at + 1] + "".join(rows)
    )
    return target


@pytest.mark.parametrize(("frames", "at_end"), [(3, False), (10, False), (4, True)])
def test_a_held_pose_at_either_end_is_kept_bit_for_bit(tmp_path, capsys, frames, at_end):
    """Identical frames at an end are a held pose even when the motion leaves it smoothly:
    no step smooths the hold into a ramp."""
    held = with_held_pose(NOISY, tmp_path / "h.bvh", frames, at_end)
    assert rest_frames(mc.load(held)) == ((0, frames) if at_end else (frames, 0))
    out = tmp_path / "out.bvh"
    code, text, _ = run_cli(capsys, "clean", held, "-o", out)
    n = mc.load(held).n_frames
    span = f"{n - frames}-{n - 1}" if at_end else f"0-{frames - 1}"
    assert code == 0 and f"rest pose: frames {span} kept" in text
    rows_in, rows_out = held.read_text().splitlines(), out.read_text().splitlines()
    assert len(rows_in) == len(rows_out)
    start = next(i for i, line in enumerate(rows_in) if line.startswith("Frame Time")) + 1
    held_rows = slice(len(rows_in) - frames, None) if at_end else slice(start, start + frames)
    assert rows_out[held_rows] == rows_in[held_rows]
    assert rows_out[start + frames] != rows_in[start + frames]  # the motion is cleaned


def test_a_single_repeated_frame_is_no_rest_pose(tmp_path):
    assert rest_frames(mc.load(with_held_pose(NOISY, tmp_path / "h.bvh", 2))) == (0, 0)


@pytest.mark.parametrize("name", CORPUS_NAMES)
def test_a_t_pose_is_found_on_every_corpus_clip_and_nothing_else(tmp_path, name):
    """CMU skeletons carry joints that never rotate (hip joints, collars, hands): they take
    no part in the vote (counted in, 131_03's leading T-pose and 131_02's trailing one fell
    just short of half the joints)."""
    source = corpus_clip(name)
    assert rest_frames(mc.load(source)) == (0, 0)
    assert rest_frames(mc.load(with_t_pose(source, tmp_path / "a.bvh"))) == (1, 0)
    assert rest_frames(mc.load(with_t_pose(source, tmp_path / "b.bvh", at_end=True))) == (0, 1)


def _keyed(frames: np.ndarray, hold: int, scale: float) -> np.ndarray:
    """Rotations of a hand-keyed clip: every ``hold``-th frame of ``frames`` (F, J, 4) a key,
    held until the next, each rotation's angle scaled by ``scale`` (small poses)."""
    from motionclean.core import quat

    keys = frames[::hold]
    small = quat.exp(scale * quat.log(keys))
    return np.repeat(small, hold, axis=0)[: frames.shape[0]]


def test_a_zero_pose_before_a_hand_keyed_clip_is_its_reference_frame():
    """Second Life's convention: frame 0 is the skeleton's rest (every channel 0, one joint
    at 1 degree) before keys held for 6 frames each, whose joints mostly sit within 15
    degrees of zero. Frame 0 is a rest frame; the keys alone, or a smooth clip that starts
    at the zero pose and leaves it slowly, have none."""
    from motionclean.core import quat

    clip = mc.load(NOISY)
    q = _keyed(clip.rotations, 6, 0.35)[:296]  # the last key held 2 frames (3: a held pose)
    zero = np.zeros_like(q[:1])
    zero[..., 0] = 1.0
    zero[0, 3] = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.deg2rad(1.0))
    rows = np.concatenate([zero, q])
    t = np.repeat(clip.translations[:1], rows.shape[0], axis=0)
    keyed = clip.replace(rotations=rows, translations=t, source_values=None, source=None)
    assert rest_frames(keyed) == (1, 0)
    # the same keys from a key held 2 frames (3 would be a held pose), no zero frame: none
    keys_only = keyed.replace(rotations=q[4:], translations=t[5:])
    assert rest_frames(keys_only) == (0, 0)
    ramp = np.linspace(0.0, 1.0, 200)[:, None, None]
    smooth = quat.exp(ramp * quat.log(clip.rotations[150:151]))  # leaves zero slowly
    rising = clip.replace(rotations=smooth, translations=t[:200], source_values=None, source=None)
    assert rest_frames(rising) == (0, 0)


def test_the_reference_frame_of_a_cmu_conversion_is_a_rest_frame(tmp_path, capsys):
    """Frame 0 of CMU 01_01 as fairmotion ships it: every rotation 0 but the thighs at +-17
    degrees and the arms at +-5. Its step into the motion is a jump (over 8 times the median
    step) on 25 of the 27 moving joints, but only 13 turn by more than 15 degrees; the
    motion after it has no rest frame."""
    clip = mc.load(CMU_01_01_START)
    assert rest_frames(clip) == (1, 0)
    assert rest_frames(trim(clip, 1, 0)) == (0, 0)
    out = tmp_path / "out.bvh"
    code, text, _ = run_cli(capsys, "clean", CMU_01_01_START, "-o", out)
    assert code == 0 and "rest pose: frame 0 kept" in text
    rows_in, rows_out = CMU_01_01_START.read_text().splitlines(), out.read_text().splitlines()
    start = next(i for i, line in enumerate(rows_in) if line.startswith("Frame Time")) + 1
    assert rows_out[start] == rows_in[start]


def _reversed(source, target):
    """``source`` with its frames in reverse order (rows copied as text)."""
    lines = source.read_text().splitlines(keepends=True)
    at = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
    target.write_text("".join(lines[:at] + lines[at:][::-1]))
    return target


def _motion_rows(path, lead: int, trail: int) -> list[str]:
    lines = path.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1 + lead
    return lines[start : len(lines) - trail]


@pytest.mark.parametrize("at_end", [False, True])
def test_a_t_pose_before_a_reference_frame_is_kept_with_it(tmp_path, capsys, at_end):
    """CMU 01_01's reference frame with a T-pose before it (or, the clip reversed, after
    it): two rest frames of different poses, each jumping into the next. Both are kept
    byte for byte and left out of the figures, and the motion cleans to the same bytes as
    without the T-pose. Only the T-pose was found: the reference frame, taken for motion,
    was repaired to the next frame's rotation (LeftForeArm written on the other Euler
    solution, stepping 180/106/180 degrees where the input turned by under a degree)."""
    plain = _reversed(CMU_01_01_START, tmp_path / "r.bvh") if at_end else CMU_01_01_START
    posed = with_t_pose(plain, tmp_path / "t.bvh", at_end=at_end)
    found = rest_frames(mc.load(posed))
    assert found == ((0, 2) if at_end else (2, 0))
    outs = []
    for name, clip in (("plain", plain), ("posed", posed)):
        out, report = tmp_path / f"{name}.bvh", tmp_path / f"{name}.json"
        assert run_cli(capsys, "clean", clip, "-o", out, "--report", report)[0] == 0
        outs.append((out, json.loads(report.read_text())))
    (plain_out, plain_report), (posed_out, posed_report) = outs
    assert (
        _motion_rows(posed_out, 0, 0)[:: -1 if at_end else 1][:2]
        == _motion_rows(posed, 0, 0)[:: -1 if at_end else 1][:2]
    )
    extra = (0, 1) if at_end else (1, 0)
    assert _motion_rows(posed_out, *extra) == _motion_rows(plain_out, 0, 0)
    assert posed_report["rest_frames"] == {"leading": found[0], "trailing": found[1]}
    assert posed_report["summary"] == plain_report["summary"]


def test_a_zero_pose_counts_before_a_reference_frame_found_after_it():
    """A zero-pose frame before a reference frame that turns no joint by 15 degrees from
    it (01_01's reference frame with its thighs zeroed: the arms at +-5) is no rest frame on
    its own; the reference frame's jump into the motion makes both rest frames. Without
    the reference frame, the zero pose's jump into the motion makes it one alone."""
    clip = mc.load(CMU_01_01_START)
    q = clip.rotations.copy()
    q[0, [clip.names.index(name) for name in ("LeftUpLeg", "RightUpLeg")]] = [1, 0, 0, 0]
    zero = np.zeros_like(q[:1])
    zero[..., 0] = 1.0
    rows = np.concatenate([zero, q])
    t = np.repeat(clip.translations[:1], rows.shape[0], axis=0)
    posed = clip.replace(rotations=rows, translations=t, source_values=None, source=None)
    assert rest_frames(posed) == (2, 0)
    alone = posed.replace(rotations=np.delete(rows, 1, axis=0), translations=t[1:])
    assert rest_frames(alone) == (1, 0)


@pytest.mark.parametrize("into_deg", [0.0, 50.0])
def test_a_held_end_follows_a_half_turn_repaired_up_to_it(into_deg):
    """A forearm half a turn off for its last 59 frames, then a pose held 12 frames more
    (padding: its last pose, or one the forearm stepped 50 degrees into, as a tracker that
    lost the person): despike un-flips the run, and the held frames turn with it (kept as
    they were, they had made a new half-turn step into themselves, as on MediaPipe
    estimates: 6 -> 179.5 and 49 -> 157 degrees); the step into them is the input's, and
    every other joint's held frames come back bit for bit."""
    from motionclean.core import quat
    from motionclean.steps.pipeline import Pipeline

    clip = mc.load(SAMPLE)
    elbow = clip.names.index("LeftElbow")
    q, t = clip.rotations.copy(), clip.translations.copy()
    q[240:, elbow] = quat.multiply(q[240:, elbow], quat.from_axis_angle(np.eye(3)[2], np.pi))
    last = q[-1:].copy()
    last[0, elbow] = quat.multiply(
        last[0, elbow], quat.from_axis_angle(np.eye(3)[0], np.radians(into_deg))
    )
    q = np.concatenate([q, np.repeat(last, 12, axis=0)])
    t = np.concatenate([t, np.repeat(t[-1:], 12, axis=0)])
    padded = clip.replace(rotations=q, translations=t, source_values=None, source_rotations=None)
    assert rest_frames(padded) == (0, 12 + (into_deg == 0.0))
    out, _ = Pipeline.default().run(padded)
    steps = np.degrees(quat.angle_between(out.rotations[1:, elbow], out.rotations[:-1, elbow]))
    into = np.degrees(quat.angle_between(q[299, elbow], q[300, elbow]))
    assert steps[300:].max() == 0.0 and abs(steps[299] - into) < 1e-6  # held, entered as read
    assert steps[:299].max() < 20.0  # the input's one flip repaired, and no new one
    others = [j for j in range(clip.n_joints) if j != elbow]
    np.testing.assert_array_equal(out.rotations[300:, others], q[300:, others])


def test_a_reference_pose_after_a_half_turn_repaired_up_to_it_is_kept():
    """The same forearm's run, then a reference pose the whole body jumps into (every joint
    at the skeleton's rest but the forearm, which holds the run's half-turned pose): no
    motion held, it comes back bit for bit, the forearm's too."""
    from motionclean.core import quat
    from motionclean.steps.pipeline import Pipeline

    clip = mc.load(SAMPLE)
    elbow = clip.names.index("LeftElbow")
    q, t = clip.rotations.copy(), clip.translations.copy()
    q[240:, elbow] = quat.multiply(q[240:, elbow], quat.from_axis_angle(np.eye(3)[2], np.pi))
    reference = quat.identity((3, clip.n_joints))
    reference[:, elbow] = q[-1, elbow]
    q = np.concatenate([q, reference])
    t = np.concatenate([t, np.repeat(t[-1:], 3, axis=0)])
    padded = clip.replace(rotations=q, translations=t, source_values=None, source_rotations=None)
    assert rest_frames(padded) == (0, 3)
    out, _ = Pipeline.default().run(padded)
    np.testing.assert_array_equal(out.rotations[300:], q[300:])
    turned = np.degrees(quat.angle_between(out.rotations[299, elbow], q[299, elbow]))
    assert turned > 150.0  # (the run was un-flipped up to it)


@pytest.mark.parametrize("step", [1, 4])
@pytest.mark.parametrize("noise_deg", [1.0, 3.0])
def test_a_t_pose_before_a_noisy_capture_is_found(step, noise_deg):
    """A video estimate's noise raises every joint's typical step past the jump rules: a
    T-pose frame before a noisy walk (PyMO's T-pose skeleton, at 120 and 30 fps, 1 and 3
    degrees of noise on every joint, the T-pose frame exact or noisy too) had been taken
    for motion and smoothed into it. No noise makes the whole body step as far as out of
    a pose near the rest into the walk: it is found, and on the noisy walk alone none."""
    from motionclean.core import quat

    walk = mc.load(ROOT / "tests" / "data" / "exporters" / "pymo_walk_tpose.bvh")
    walk = walk.replace(
        rotations=walk.rotations[::step],
        translations=walk.translations[::step],
        frame_time=walk.frame_time * step,
        source_values=None,
    )
    rotations = np.concatenate([quat.identity((1, walk.n_joints)), walk.rotations])
    translations = np.concatenate([walk.translations[:1], walk.translations])
    rng = np.random.default_rng(7)
    noise = quat.exp(rng.normal(scale=np.radians(noise_deg) / 2, size=(*rotations.shape[:-1], 3)))
    for posed in (rotations, quat.multiply(rotations, noise)):
        noisy = quat.multiply(rotations, noise)
        noisy[0] = posed[0]
        clip = walk.replace(rotations=noisy, translations=translations, source_values=None)
        assert rest_frames(clip) == (1, 0)
        assert rest_frames(
            clip.replace(rotations=noisy[1:], translations=translations[1:], source_values=None)
        ) == (0, 0)


@pytest.mark.parametrize("facing_deg", [0.0, 170.0])
@pytest.mark.parametrize("arms_deg", [10.0, 40.0])
def test_an_a_pose_before_a_reference_frame_and_a_turned_clip_is_kept(
    tmp_path, capsys, facing_deg, arms_deg
):
    """An A-pose (every rotation 0 but the arms lowered) before CMU's reference frame and
    the motion, turned to face away from it: only the arms and the root step out of it, no
    jump rule held, and neither frame had been found (the clip's noise was estimated over
    them: a foot smoothed by 27 degrees; a turned root un-flipped on the A-pose). The
    skeleton's rest but for a few joints, out of which the whole body jumps, is a rest
    frame, and the reference frame after it is found as before."""
    from motionclean.core import quat

    clip = mc.load(CMU_01_01_START)
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(facing_deg))
    q = clip.rotations.copy()
    q[:, 0] = quat.multiply(turn, q[:, 0])
    pose = quat.identity((1, clip.n_joints))
    for name, sign in (("LeftArm", 1.0), ("RightArm", -1.0)):
        axis = np.array([0.0, 0.0, sign])
        pose[0, clip.names.index(name)] = quat.from_axis_angle(axis, np.radians(arms_deg))
    posed = clip.replace(
        rotations=np.concatenate([pose, q]),
        translations=np.concatenate([clip.translations[:1], clip.translations]),
        source_values=None,
    )
    assert rest_frames(posed) == (2, 0)
    source, out = tmp_path / "a_pose.bvh", tmp_path / "out.bvh"
    mc.save(posed, source)
    code, text, _ = run_cli(capsys, "clean", source, "-o", out)
    assert code == 0 and "rest pose: frames 0-1 kept" in text, text
    rows_in, rows_out = source.read_text().splitlines(), out.read_text().splitlines()
    start = next(i for i, line in enumerate(rows_in) if line.startswith("Frame Time")) + 1
    assert rows_out[start : start + 2] == rows_in[start : start + 2]


@pytest.mark.parametrize("step", [1, 4])
@pytest.mark.parametrize("noise_deg", [1.0, 3.0])
def test_the_reference_frame_of_a_noisy_cmu_conversion_is_found(step, noise_deg):
    """CMU's reference frame (every rotation 0 but the thighs and arms) with 1 or 3 degrees
    of noise on every joint, at 120 and 30 fps: the joints' typical steps grow past the jump
    rule, and it had been taken for motion; 74 % of the moving joints near the rest and the
    whole body's step out of it find it, and the motion after it has none."""
    from motionclean.core import quat

    clip = mc.load(CMU_01_01_START)
    rows = np.arange(0, clip.n_frames, step)
    rng = np.random.default_rng(3)
    sigma = np.radians(noise_deg) / (2.0 * np.sqrt(3.0))
    noise = quat.exp(rng.normal(scale=sigma, size=(rows.size, clip.n_joints, 3)))
    noisy = clip.replace(
        rotations=quat.multiply(clip.rotations[rows], noise),
        translations=clip.translations[rows],
        frame_time=clip.frame_time * step,
        source_values=None,
    )
    assert rest_frames(noisy) == (1, 0)
    assert rest_frames(trim(noisy, 1, 0)) == (0, 0)
