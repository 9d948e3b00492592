"""The Euler write-back keeps its promise with frame ranges: a ranged Lee-Shin over
RThumb's half-turn flips, nothing repaired, turns the joint a full turn against the input
inside the range; the written channels rejoin the untouched frames after it without a step
larger than 180 degrees where the input's own step is smaller by more than JUMP_MARGIN."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import CMU_01_01_START, NOISY, SAMPLE, max_degrees, with_t_pose

import motionclean as mc
from motionclean.core import quat
from motionclean.core.eulerjoin import JUMP_DEG, JUMP_MARGIN
from motionclean.core.motion import FILTER_BLOCK_FRAMES
from motionclean.steps.pipeline import Pipeline


def rows(path: Path) -> np.ndarray:
    text = path.read_text().split("Frame Time:")[1].splitlines()[1:]
    return np.array([r.split() for r in text if r.strip()], dtype=float)


@pytest.mark.parametrize(
    ("source", "step"),
    [
        (SAMPLE, "lee-shin:k=2,iterations=5,frames=[40,60],blend=5"),  # wrote 478 degrees
        (SAMPLE, "lee-shin:k=2,iterations=5,frames=[45,52],blend=12"),  # 514
        (SAMPLE, "lee-shin:k=2,iterations=5,frames=[0,120],blend=0"),  # 362
        (NOISY, "lee-shin:k=2,iterations=5,frames=[40,60],blend=5"),  # 315
    ],
)
def test_a_ranged_smoothing_over_flips_rejoins_the_input_without_a_new_jump(source, step, tmp_path):
    clip = mc.load(source)
    out, _ = Pipeline.from_inline([step]).run(clip)
    target = tmp_path / "out.bvh"
    mc.save(out, target)
    read, written = rows(source), rows(target)
    step_in = np.abs(np.diff(read, axis=0))
    step_out = np.abs(np.diff(written, axis=0))
    new_jumps = (step_out > JUMP_DEG) & (step_out > step_in + JUMP_MARGIN)
    assert not new_jumps.any(), np.argwhere(new_jumps)[:5]
    # the same rotations, and every frame outside the range as it was, byte for byte
    assert max_degrees(mc.load(target).rotations, out.rotations) < 1e-4
    first, last = (int(v) for v in step.split("frames=[")[1].split("]")[0].split(","))
    blend = int(step.rsplit("blend=", 1)[1])
    lines_in = source.read_text().splitlines()
    lines_out = target.read_text().splitlines()
    head = lines_in.index(next(line for line in lines_in if line.startswith("Frame Time")))
    for frame in (*range(0, max(first - blend, 0)), *range(last + blend + 1, clip.n_frames)):
        assert lines_out[head + 1 + frame] == lines_in[head + 1 + frame]


@pytest.mark.parametrize("frames", [1, 2, 3])
def test_a_run_changed_from_frame_0_joins_the_kept_frame_after_it(frames, tmp_path):
    """CMU 01_01's reference frame 0 (and frames after it) repaired to frame ``frames``'s
    rotation, as a repair at the clip's start leaves it: the changed run has no kept
    frame before it and is written back from the kept one after it. Started from frame
    0's original angles, LeftForeArm's run was written on the other Euler solution,
    (-25.65, -143.14, 68.68), and stepped by 180, 106 and 180 degrees into frame
    ``frames`` (154.35, -36.86, -111.32) where the input turned by 0.06-0.08."""
    clip = mc.load(CMU_01_01_START)
    q = clip.rotations.copy()
    q[:frames] = q[frames]
    target = tmp_path / "out.bvh"
    mc.save(clip.replace(rotations=q), target)
    read, written = rows(CMU_01_01_START), rows(target)
    excess = np.abs(np.diff(written, axis=0)) - np.abs(np.diff(read, axis=0))
    assert excess.max() < 1e-9
    fore = clip.layout.rotation_columns[clip.names.index("LeftForeArm")]
    np.testing.assert_array_equal(written[:frames, fore], read[[frames] * frames][:, fore])
    assert max_degrees(mc.load(target).rotations, q) < 1e-4


@pytest.mark.parametrize("frames", [1, 2])
@pytest.mark.parametrize("reverse", [False, True])
def test_a_run_after_a_kept_frame_far_from_it_joins_the_kept_frame_after_it(
    frames, reverse, tmp_path
):
    """CMU 01_01's cut with a T-pose before its reference frame, the reference frame (and
    ``frames - 1`` frames after it) repaired to the next frame's rotation: the changed run
    lies between the kept T-pose, 136 degrees from it on LeftForeArm, and the kept frame
    it was repaired to. It is written on that frame's Euler solution, the step into the
    T-pose the only one the input lacks (the rotation turns there). Continued from the
    T-pose, LeftForeArm's run was written (-25.59, -143.20, 68.64) and stepped 180, 106
    and 180 degrees into (154.41, -36.80, -111.36) where the input turned by under a
    degree. Reversed (the T-pose after the run), the run continues from the kept frame
    before it, as it did."""
    source = with_t_pose(CMU_01_01_START, tmp_path / "t.bvh")
    if reverse:
        lines = source.read_text().splitlines(keepends=True)
        head = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
        source.write_text("".join(lines[:head] + lines[head:][::-1]))
    clip = mc.load(source)
    q = clip.rotations[::-1].copy() if reverse else clip.rotations.copy()
    q[1 : 1 + frames] = q[1 + frames]
    q = q[::-1] if reverse else q
    target = tmp_path / "out.bvh"
    mc.save(clip.replace(rotations=q), target)
    read, written = rows(source), rows(target)
    if reverse:
        read, written = read[::-1], written[::-1]
    excess = np.abs(np.diff(written, axis=0)) - np.abs(np.diff(read, axis=0))
    assert excess[1:].max() < 1e-9  # every step but the one from the T-pose
    fore = clip.layout.rotation_columns[clip.names.index("LeftForeArm")]
    np.testing.assert_array_equal(
        written[1 : 1 + frames, fore], read[[1 + frames] * frames][:, fore]
    )
    assert max_degrees(mc.load(target).rotations, q) < 1e-4


def test_an_identity_write_stays_byte_for_byte(tmp_path):
    clip = mc.load(SAMPLE)
    mc.save(clip, tmp_path / "same.bvh")
    assert (tmp_path / "same.bvh").read_bytes() == SAMPLE.read_bytes()


def test_the_step_floor_is_the_least_overshoot_between_representations_bit_for_bit():
    """A run whose own largest overshoot (its steps beyond the larger of 90 degrees and
    the input's plus 45) is no larger than the floor is left without a solve: the floor is, at its
    worst step, the least overshoot any two representations take there (the same bits as
    the (54, 54) comparison), so no solve can do better than it; with no overshoot just
    above it, the solve within it is the full solve's answer."""
    from motionclean.core import eulerjoin

    rng = np.random.default_rng(3)
    for trial in range(60):
        n = int(rng.integers(1, 30))
        angles = np.cumsum(rng.normal(0.0, rng.choice([1.0, 30.0, 120.0]), (n, 3)), axis=0)
        angles[:, 1] = np.clip(angles[:, 1], -95.0, 95.0)
        read = angles + rng.normal(0.0, 2.0, (n, 3)) + 360.0 * rng.integers(-2, 3, (n, 3))
        before = None if trial % 4 == 0 else angles[0] + rng.normal(0.0, 100.0, 3)
        after = None if trial % 5 == 0 else angles[-1] + rng.normal(0.0, 100.0, 3)
        steps = rng.normal(0.0, rng.choice([20.0, 200.0]), (n + 1, 3)) * (trial % 3 > 0)
        run = eulerjoin._Run(angles, read, before, after, steps)
        cand = eulerjoin._candidates(run.centred)

        limits = np.maximum(np.abs(steps) + eulerjoin.JUMP_MARGIN, eulerjoin.SEEN_DEG)

        def overshoot(a, b, limit):
            return np.maximum((np.abs(a - b) - limit).max(axis=-1), 0.0)

        least = [
            overshoot(cand[i][None], cand[i - 1][:, None], limits[i]).min() for i in range(1, n)
        ]
        if before is not None:
            least.append(overshoot(cand[0], before, limits[0]).min())
        if after is not None:
            least.append(overshoot(cand[-1], after, limits[-1]).min())
        floor, alone = eulerjoin._step_floor(run)
        assert floor == max(least, default=0.0)
        best = eulerjoin._least_overshoot(run)
        assert run.largest_overshoot(best) >= floor
        if alone:  # the solve sought within the floor first finds the same representations
            assert np.array_equal(eulerjoin._least_overshoot(run, floor), best)


def test_a_curve_carried_whole_turns_away_rejoins_where_the_input_wraps():
    """The input wraps from +170 to -170 degrees (a step of 340 on its own); the written
    curve, continued by the Euler filter, went on to 190 and further, two turns away from
    the input by the end, and would step back by whole turns into the next unchanged
    sample. The solve puts the written curve's wrap where the input's is: no step beyond
    the input's own by more than the cleaning's change."""
    from motionclean.core import eulerjoin

    n = 40
    read = np.zeros((n + 1, 3))
    read[:, 0] = np.linspace(150.0, 230.0, n + 1)
    read[:, 0] -= 360.0 * (read[:, 0] > 180.0)  # wraps once, as a file stores it
    written = read.copy()
    written[:n, 0] = np.linspace(150.0, 230.0, n + 1)[:n] + 0.3 + 720.0 * (np.arange(n) > 30)
    written[n] = read[n]  # the unchanged sample the run ends at
    values, source = written.copy(), read.copy()
    eulerjoin.rejoin(values, source, np.array([[0, 1, 2]]))
    step_out = np.abs(np.diff(values, axis=0))
    step_in = np.abs(np.diff(source, axis=0))
    assert (step_out <= step_in + 1.0).all(), np.argwhere(step_out > step_in + 1.0)
    assert np.allclose(np.mod(values - written + 180.0, 360.0) - 180.0, 0.0)  # same angles


def test_a_run_ending_in_a_large_real_step_is_not_switched_solution_elsewhere():
    """A MediaPipe forearm: held still, then smoothing moved the last changed frame so far
    from the glitchy input that the step into the unchanged frame after the run turns 155
    degrees (written 204.7 on its third channel). A whole turn there would be carried in
    by switching Euler solution and back while the joint stands still (steps of 179.5
    degrees, each under half a turn, where the input stepped 0), as the rewrite did when
    only steps over 180 counted. Now no step over 90 degrees is written where the input
    stepped less by 45, but that real step into the unchanged frame."""
    from motionclean.core import eulerjoin

    read = np.tile([30.4, -48.4, -33.4], (40, 1))
    read[30:39] = np.linspace([30.4, -48.4, -33.4], [89.4, -6.8, -85.0], 9)
    read[39] = [101.1, -1.6, -172.1]
    written = read.copy()
    written[:39] += np.random.default_rng(1).normal(0.0, 0.5, (39, 3))  # changed, smoothed
    written[30:39, 2] = np.linspace(-33.4, 32.6, 9)  # the glitch smoothed away
    written[0] = read[0]  # the run begins after an unchanged frame
    values, source = written.copy(), read.copy()
    eulerjoin.rejoin(values, source, np.array([[0, 1, 2]]))
    step_out = np.abs(np.diff(values, axis=0))
    step_in = np.abs(np.diff(source, axis=0))
    seen = np.argwhere((step_out > 90.0) & (step_out > step_in + 45.0))
    assert seen.tolist() == [[38, 2]], seen
    assert np.allclose(np.mod(values - written + 180.0, 360.0) - 180.0, 0.0)  # same angles


def test_the_inputs_own_half_turn_flips_are_written_as_flips_not_solved(tmp_path):
    """Every rotation turned by half a degree: RThumb's captured half-turn flips are
    written as flips a few degrees longer or shorter than the input's (within
    JUMP_MARGIN), and no step is added or removed above 30 degrees on any channel."""
    from motionclean.core import eulerjoin, quat

    clip = mc.load(SAMPLE)
    turn = quat.from_axis_angle(np.array([0.48, 0.6, 0.64]), np.deg2rad(0.5))
    target = tmp_path / "turned.bvh"
    mc.save(clip.replace(rotations=quat.multiply(clip.rotations, turn)), target)
    step_in = np.abs(np.diff(rows(SAMPLE), axis=0))
    step_out = np.abs(np.diff(rows(target), axis=0))
    assert (step_in > JUMP_DEG).any()  # the sample flips: the case is exercised
    assert np.array_equal(step_out > 30.0, step_in > 30.0)
    assert (step_out[step_in > 30.0] <= step_in[step_in > 30.0] + eulerjoin.JUMP_MARGIN).all()


def test_a_noisy_joint_changed_on_every_frame_keeps_its_branch_before_a_far_rest_pose(
    tmp_path,
):
    """The noisy sample with four poses after it (arms out, a tilt, CMU's reference pose,
    all zeros; the last kept as a rest frame, the others repaired): every frame of
    RightElbow changed, and the run from frame 0 had been written backward from the rest
    frame, 132 degrees away, on the other Euler solution (its channels 180 degrees off the
    input's on all 300 frames). A run from frame 0 joins the kept frame after it only where
    frame 0 itself moved further than the rotation turns into that frame."""
    clip = mc.load(NOISY)
    columns = {}
    for joint, channels in zip(clip.names, clip.channels, strict=True):
        for channel in channels:
            columns[(joint, channel)] = len(columns)
    lines = NOISY.read_text().splitlines(keepends=True)
    at = next(i for i, line in enumerate(lines) if line.startswith("Frames:"))
    body = lines[at + 2 :]
    last = body[-1].split()
    poses = []
    for turns in (
        {("LeftShoulder", "Zrotation"): -60, ("RightShoulder", "Zrotation"): 60},
        {("Hips", "Xrotation"): 30},
        {("LeftHip", "Zrotation"): -17, ("RightHip", "Zrotation"): 17},
        {},
    ):
        values = last[:3] + ["0"] * (len(last) - 3)
        for key, degrees in turns.items():
            values[columns[key]] = str(degrees)
        poses.append(" ".join(values) + "\n")
    rows_ = body + poses
    source = tmp_path / "posed.bvh"
    source.write_text(
        "".join(lines[:at]) + f"Frames: {len(rows_)}\n" + lines[at + 1] + "".join(rows_)
    )
    target = tmp_path / "out.bvh"
    mc.save(Pipeline.default().run(mc.load(source))[0], target)
    elbow = [columns[("RightElbow", c)] for c in clip.channels[clip.names.index("RightElbow")]]
    before, after = rows(source)[:300, elbow], rows(target)[:300, elbow]
    off = np.abs(after - before)
    off = np.minimum(off % 360.0, 360.0 - off % 360.0)
    assert off.max() < 30.0


@pytest.mark.parametrize("at", [25, FILTER_BLOCK_FRAMES, FILTER_BLOCK_FRAMES + 1])
def test_a_changed_run_switches_solution_where_the_input_does(tmp_path, at):
    """A file may switch Euler solution mid-curve, (a, b, c) to (a + 180, 180 - b, c + 180),
    the same rotation (exporters do near gimbal lock: assimp's Boxing_Toes hip, b near
    -90). A run changed by a tenth of a degree across that switch is written switching
    where the input does, also on the first frame of a block the write-back works in;
    continued through from the kept frame before, it had arrived at the kept frames after
    on the other solution and switched at the run's start instead, stepping 167 degrees
    where the input stepped 13."""
    n = at + 35
    t = np.linspace(0.0, 1.0, n)[:, None]
    read = np.hstack([-20.0 - 100.0 * t, -70.0 + 20.0 * t, -30.0 - 90.0 * t])
    read[at:] = read[at:] * [1.0, -1.0, 1.0] + [180.0, 180.0, 180.0]  # the other solution
    read = (read + 180.0) % 360.0 - 180.0  # each angle within half a turn, as files hold
    rows = "\n".join(" ".join(f"{v:.6f}" for v in (0.0, 0.0, 0.0, *angles)) for angles in read)
    path = tmp_path / "hip.bvh"
    path.write_text(
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n"
        " CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
        " End Site\n {\n  OFFSET 0 10 0\n }\n}\n"
        f"MOTION\nFrames: {n}\nFrame Time: 0.01\n{rows}\n"
    )
    clip = mc.load(path)
    nudge = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(0.1))
    q = clip.rotations.copy()
    q[at - 20 : at + 25, 0] = quat.multiply(q[at - 20 : at + 25, 0], nudge)  # the rest kept
    values = clip.replace(rotations=q).channel_values()[:, 3:]
    step_in = np.abs(np.diff(clip.source_values[:, 3:], axis=0))
    step_out = np.abs(np.diff(values, axis=0))
    assert step_in[at - 1].max() > 90.0  # the input switches at frame ``at`` ...
    assert not ((step_out > 90.0) & (step_out > step_in + JUMP_MARGIN)).any()  # ... and so do we
    assert max_degrees(quat.from_euler(values, "ZXY")[:, None], q) < 1e-9


def test_a_changed_curve_wraps_where_the_input_wraps_to_the_clips_end(tmp_path):
    """The hips' yaw turns past 180 degrees and the file wraps it to -180, as exporters
    write it; smoothing changes every frame after the wrap, so no kept sample follows to
    rejoin. The written yaw stays on the input's own turn (it had gone on past 180 and
    stayed a turn off, 181-540, on 184 of a Bandai Namco walk's 212 frames)."""
    lines = SAMPLE.read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
    frames = [line.split() for line in lines[head:] if line.strip()]
    yaw = 150.0 + 80.0 * np.arange(len(frames)) / len(frames)  # Yrotation, the 5th channel
    for row, value in zip(frames, yaw, strict=True):
        row[4] = f"{(value + 180.0) % 360.0 - 180.0:.5f}"
    source = tmp_path / "wrapped.bvh"
    source.write_text("\n".join(lines[:head] + [" ".join(r) for r in frames]) + "\n")
    clip = mc.load(source)
    out, _ = Pipeline.from_inline(["lee-shin:k=2,iterations=5"]).run(clip)
    target = tmp_path / "out.bvh"
    mc.save(out, target)
    read, written = rows(source), rows(target)
    assert np.abs(read[:, 4]).max() <= 180.0 and (np.diff(read[:, 4]) < -300.0).sum() == 1
    assert np.abs(written[:, 4] - read[:, 4]).max() < 5.0  # the same turn as the input's
    changed = written[:, 4] != read[:, 4]
    assert changed[len(frames) // 2 :].all()  # changed to the clip's end: nothing to rejoin
    assert max_degrees(mc.load(target).rotations, out.rotations) < 1e-4


def test_a_curve_half_a_turn_from_the_input_is_not_moved_by_whole_turns():
    """A written channel 170-190 degrees from the read one (a repaired flip, the other Euler
    solution) would move by a whole turn wherever its difference crosses 180, stepping 360
    where the input does not: it is left as written."""
    from motionclean.core import eulerjoin

    rng = np.random.default_rng(3)
    read = np.zeros((60, 3))
    read[:, 0] = np.linspace(-20.0, 20.0, 60)
    written = read.copy()
    written[:, 0] += 180.0 + rng.uniform(-10.0, 10.0, 60)
    values = written.copy()
    eulerjoin.follow_wraps(values, read, np.array([[0, 1, 2]]))
    assert np.array_equal(values, written)


def test_a_repaired_flip_is_not_moved_by_whole_turns_around_it():
    """A yaw runs from -2 to 250 degrees, written continued to the clip's end (a turn off
    the input's after its wrap at 180) with a 12-frame half-turn flip repaired near 0,
    where the input reads about 180 and noise wraps it back and forth. Noise decided
    which whole turn the repaired frames were nearest: a despiked flip's Xrotation had been
    written -1.01, 0.03, -358.93, -357.89, 3.15 where the input stepped by 181 into the
    last frame. Each of 60 joints: the written curve takes the input's turn outside the flip
    and steps over SEEN_DEG only where the input wraps there."""
    from motionclean.core import eulerjoin

    joints, frames, flip = 60, 100, slice(14, 26)
    rng = np.random.default_rng(5)
    written = np.zeros((frames, 3 * joints))
    written[:, ::3] = np.interp(np.arange(frames), [0, 40, frames], [-2.0, 2.0, 250.0])[:, None]
    read = written + rng.normal(scale=0.5, size=written.shape)
    read[flip, ::3] += 180.0
    read = (read + 180.0) % 360.0 - 180.0  # within half a turn, as files hold
    values = written.copy()
    eulerjoin.follow_wraps(values, read, np.arange(3 * joints).reshape(joints, 3))
    assert np.abs(read[flip, ::3]).min() > 170.0  # the flip half a turn off ...
    wraps = (np.diff(np.sign(read[flip, ::3]), axis=0) != 0).sum(axis=0)
    assert wraps.min() >= 1 and (wraps >= 2).any()  # ... wrapping inside, back and forth
    turns = (values - written) / 360.0
    assert np.array_equal(turns, np.round(turns))  # the same angles
    outside = np.ones(frames, dtype=bool)
    outside[flip] = False
    assert np.abs(values[outside] - read[outside]).max() < 5.0  # the input's own turn
    jumps = np.abs(np.diff(values, axis=0)) > eulerjoin.SEEN_DEG
    wrap = (np.abs(np.diff(read, axis=0)) > 300.0) & (outside[1:] & outside[:-1])[:, None]
    assert wrap.any(axis=0)[::3].all() and np.array_equal(jumps, wrap)  # its wraps alone


def test_a_despiked_flip_is_written_continuing_its_neighbours(tmp_path):
    """Joints of all six orders, middle angle about 31 degrees, 0.2 degrees of noise, each
    flipped by half a turn about one of its axes over frames 300-302 (the flipped channel
    near 180, wrapping inside the flip). The default pipeline un-flips them; no written
    channel steps over SEEN_DEG around the flip, where a tool interpolating the channels
    had spun the arm a full turn (written -1.01, 0.03, -358.93, -357.89, 3.15: ZYX, about
    X), and the written rotations are the cleaned ones."""
    from motionclean.core import eulerjoin

    frames, orders = 600, ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"]
    rng = np.random.default_rng(1)
    t = np.arange(frames)[:, None] / 120.0
    joints, text = [], []
    for k in range(36):
        order, axis = orders[k % 6], (k // 6) % 3
        angles = np.hstack(
            [60.0 * np.sin(1.9 * t + k), 31.0 + np.sin(3.1 * t), 50.0 * np.sin(2.5 * t + k)]
        )
        q = quat.multiply(
            quat.from_euler(angles, order), quat.exp(rng.normal(scale=0.0017, size=(frames, 3)))
        )
        q[300:303] = quat.multiply(q[300:303], quat.from_axis_angle(np.eye(3)[axis], np.pi))
        text.append(quat.to_euler(q, order))
        joints.append(
            f"JOINT J{k}\n{{\nOFFSET 0 10 0\nCHANNELS 3 "
            + " ".join(f"{c}rotation" for c in order)
            + "\nEnd Site\n{\nOFFSET 0 10 0\n}\n}\n"
        )
    read = np.hstack([np.zeros((frames, 6)), *text])
    path = tmp_path / "flips.bvh"
    path.write_text(
        "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\n"
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
        + "".join(joints)
        + f"}}\nMOTION\nFrames: {frames}\nFrame Time: 0.0083333\n"
        + "".join(" ".join(f"{v:.6f}" for v in row) + "\n" for row in read)
    )
    out, _ = Pipeline.default().run(mc.load(path))
    target = tmp_path / "out.bvh"
    mc.save(out, target)
    read, written = rows(path)[:, 6:], rows(target)[:, 6:]
    flips = np.abs(np.diff(read[297:305], axis=0)).reshape(7, -1, 3).max(axis=(0, 2))
    assert flips.min() > 150.0  # each joint's channels step as the rotation flips
    assert np.abs(np.diff(written[297:305], axis=0)).max() < eulerjoin.SEEN_DEG
    assert max_degrees(mc.load(target).rotations, out.rotations) < 1e-4


def test_a_root_turning_about_its_middle_axis_gains_no_spin_where_the_input_has_none(tmp_path):
    """CMU's layout (ZYX, Y up): the hips turn 5 times about Y, the middle angle, written
    as an exporter does (each frame nearest the principal angles unwrapped, so the outer
    channels switch Euler solution by a pair of half turns that cancel at each passage of
    gimbal lock), 0.2 degrees of noise. Smoothed, the rewrite had written switches with
    the other sign on one channel (-189 and -171 degrees where the input stepped -202 and
    +201), a tool interpolating the channels half a turn off between the frames (here at
    frames 149 and 209). No frame pair is interpolated more than 90 degrees off
    (mid-frame, against the slerp) where the input's is not."""
    frames, rng = 600, np.random.default_rng(1)
    t = np.arange(frames) / 120.0
    yaw = np.deg2rad(1800.0 * t / t[-1])
    sway = np.deg2rad(10.0 * np.sin(2.0 * np.pi * t))
    q = quat.multiply(
        quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), yaw),
        quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), sway),
    )
    principal = np.unwrap(quat.to_euler(q, "ZYX"), period=360.0, axis=0)
    q = quat.multiply(q, quat.exp(rng.normal(scale=np.deg2rad(0.2) / 2.0, size=(frames, 3))))
    read = quat.to_euler(q, "ZYX", reference=principal)
    path = tmp_path / "turning.bvh"
    path.write_text(
        "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\n"
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
        f"End Site\n{{\nOFFSET 0 10 0\n}}\n}}\nMOTION\nFrames: {frames}\nFrame Time: 0.0083333\n"
        + "".join(" ".join(f"{v:.6f}" for v in (0, 35, 0, *row)) + "\n" for row in read)
    )
    out, _ = Pipeline.from_inline(["lee-shin:k=3,iterations=3"]).run(mc.load(path))
    target = tmp_path / "out.bvh"
    mc.save(out, target)

    def mid_frame_error(angles: np.ndarray) -> np.ndarray:
        q = quat.from_euler(angles, "ZYX")
        halfway = quat.from_euler((angles[1:] + angles[:-1]) / 2.0, "ZYX")
        return np.rad2deg(quat.angle_between(halfway, quat.slerp(q[:-1], q[1:], 0.5)))

    read, written = rows(path)[:, 3:], rows(target)[:, 3:]
    assert (np.abs(np.diff(read, axis=0)) > 180.0).any(axis=1).sum() >= 5  # switches
    spins = (mid_frame_error(written) > 90.0) & (mid_frame_error(read) < 90.0)
    assert not spins.any(), np.flatnonzero(spins)
    assert max_degrees(mc.load(target).rotations, out.rotations) < 1e-4
