"""`motionclean blend` as a user runs it: the weights act, the order of the clips does not
matter, bad options and mismatched clips are one-line errors that write nothing."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import NOISY, SAMPLE, max_degrees, run_cli

import motionclean as mc
from motionclean.core import quat
from motionclean.filters import multires

#: What survives printing a clip: six decimals of degrees and of length units.
PRINTED_DEG = 1e-4
PRINTED_LENGTH = 1e-4
FRAMES = 150


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    """Two different 150-frame windows of the sample (frames 0-149 and 150-299)."""
    folder = tmp_path_factory.mktemp("blend")
    motion = mc.load(SAMPLE)
    paths = []
    for name, window in (("a.bvh", slice(0, FRAMES)), ("b.bvh", slice(FRAMES, 2 * FRAMES))):
        path = folder / name
        mc.save(
            motion.replace(
                rotations=motion.rotations[window],
                translations=motion.translations[window],
                source_values=None,
                source_rotations=None,
            ),
            path,
        )
        paths.append(path)
    return tuple(paths)


def max_deg(x: mc.Motion, y: mc.Motion) -> float:
    return max_degrees(x.rotations, y.rotations)


def max_length(x: mc.Motion, y: mc.Motion) -> float:
    return float(np.abs(x.translations - y.translations).max())


def blend(capsys, out, first, second, *options) -> mc.Motion:
    code, _, err = run_cli(capsys, "blend", first, second, "-o", out, *options)
    assert code == 0, err
    return mc.load(out)


def test_the_two_windows_differ(clips):
    a, b = (mc.load(p) for p in clips)
    assert a.n_frames == b.n_frames == FRAMES
    assert max_deg(a, b) > 10.0 and max_length(a, b) > 1.0


@pytest.mark.parametrize(("weight", "which"), [("0", 0), ("1", 1), ("0.0", 0)])
def test_weight_zero_gives_first_and_one_gives_second(clips, tmp_path, capsys, weight, which):
    out = blend(capsys, tmp_path / "x.bvh", *clips, "--weight", weight)
    expected = mc.load(clips[which])
    assert max_deg(out, expected) < PRINTED_DEG
    assert max_length(out, expected) < PRINTED_LENGTH
    assert out.names == expected.names and out.channels == expected.channels
    assert out.frame_time == pytest.approx(expected.frame_time, rel=1e-6)


def test_intermediate_weight_lies_between_and_matches_the_library(clips, tmp_path, capsys):
    out = blend(capsys, tmp_path / "x.bvh", *clips, "--weight", "0.3", "--levels", "3")
    a, b = (mc.load(p) for p in clips)
    q, p = multires.blend(a.rotations, b.rotations, 3, 0.3, None, a.translations, b.translations)
    assert float(np.degrees(quat.angle_between(out.rotations, q)).max()) < PRINTED_DEG
    assert float(np.abs(out.translations - p).max()) < PRINTED_LENGTH
    assert max_deg(out, a) > 1.0 and max_deg(out, b) > 1.0


@pytest.mark.parametrize(
    ("forward", "backward"),
    [
        (["--weight", "0.3"], ["--weight", "0.7"]),
        (["--weight", "0.8", "--levels", "2"], ["--weight", "0.2", "--levels", "2"]),
        (
            ["--weight", "0.25", "--detail-weights", "0,1,0.4"],
            ["--weight", "0.75", "--detail-weights", "1,0,0.6"],
        ),
    ],
)
def test_blend_is_symmetric_in_the_clips(clips, tmp_path, capsys, forward, backward):
    ab = blend(capsys, tmp_path / "ab.bvh", clips[0], clips[1], *forward)
    ba = blend(capsys, tmp_path / "ba.bvh", clips[1], clips[0], *backward)
    assert max_deg(ab, ba) < PRINTED_DEG
    assert max_length(ab, ba) < PRINTED_LENGTH


def test_detail_weights_are_read_finest_first(clips, tmp_path, capsys):
    a, b = (mc.load(p) for p in clips)
    plain = blend(capsys, tmp_path / "plain.bvh", *clips, "--weight", "0")
    assert max_deg(plain, a) < PRINTED_DEG
    # only the finest band comes from B: near A, yet not A
    finest = blend(
        capsys, tmp_path / "finest.bvh", *clips, "--weight", "0", "--detail-weights", "1"
    )
    q, _ = multires.blend(a.rotations, b.rotations, 4, 0.0, [1.0], a.translations, b.translations)
    assert float(np.degrees(quat.angle_between(finest.rotations, q)).max()) < PRINTED_DEG
    assert max_deg(finest, a) > 0.1
    # spaces around the numbers are accepted; listed levels override --weight
    listed = blend(
        capsys,
        tmp_path / "listed.bvh",
        *clips,
        "--weight",
        "1",
        "--detail-weights",
        "0, 0.5,1 ,0",
        "--levels",
        "4",
    )
    q, p = multires.blend(
        a.rotations, b.rotations, 4, 1.0, [0.0, 0.5, 1.0, 0.0], a.translations, b.translations
    )
    assert float(np.degrees(quat.angle_between(listed.rotations, q)).max()) < PRINTED_DEG
    assert float(np.abs(listed.translations - p).max()) < PRINTED_LENGTH
    assert max_deg(listed, b) > 0.1


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("a,b", "--detail-weights: expected numbers, got 'a,b'"),
        ("0.5,", "--detail-weights: expected numbers"),
    ],
)
def test_bad_detail_weights_exit_2_with_one_line(clips, tmp_path, capsys, value, message):
    out = tmp_path / "x.bvh"
    code, _, err = run_cli(capsys, "blend", *clips, "-o", out, "--detail-weights", value)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("motionclean: error: ") and message in err
    assert not out.exists()


def test_more_detail_weights_than_levels_is_a_usage_error(clips, tmp_path, capsys):
    out = tmp_path / "x.bvh"
    code, _, err = run_cli(
        capsys, "blend", *clips, "-o", out, "--levels", "2", "--detail-weights", "0,0,0"
    )
    assert code == 2 and err == (
        "motionclean: error: --detail-weights: 3 weights for --levels 2: give at most one "
        "per level\n"
    )
    assert not out.exists()


def test_mismatched_channels_or_frame_time_exit_1_with_one_line(clips, tmp_path, capsys):
    text = clips[1].read_text()
    first_joint = "\tJOINT LHipJoint\n\t{\n\t\tOFFSET 0 0 0\n\t\tCHANNELS 3 Zrotation Yrotation "
    assert text.count(first_joint + "Xrotation") == 1
    swapped = tmp_path / "swapped.bvh"
    swapped.write_text(
        text.replace(
            first_joint + "Xrotation",
            first_joint.replace("Zrotation Yrotation ", "Xrotation Yrotation ") + "Zrotation",
        )
    )
    frame_time = next(line for line in text.splitlines() if line.startswith("Frame Time:"))
    slower = tmp_path / "slower.bvh"
    slower.write_text(text.replace(frame_time, "Frame Time: 0.0333333"))
    for other, message in ((swapped, "channels differ"), (slower, "frame time 0.0333333 s")):
        assert mc.load(other).n_frames == FRAMES  # a valid clip on its own
        out = tmp_path / "x.bvh"
        code, _, err = run_cli(capsys, "blend", clips[0], other, "-o", out)
        assert code == 1, err
        assert err.count("\n") == 1 and err.startswith("motionclean: error: ")
        assert message in err and str(other) in err
        assert not out.exists()


def test_one_rate_written_to_other_precisions_blends_and_stitches(clips, tmp_path, capsys):
    """A Frame Time of 0.008333 s is the 0.0083333 s of the other clip (120 fps), as
    ``resample --fps`` writes it to other precisions: the clips blend and stitch, into the
    first clip's rate (a relative tolerance of 1e-6 had refused them)."""
    text = clips[1].read_text()
    frame_time = next(line for line in text.splitlines() if line.startswith("Frame Time:"))
    rounded = tmp_path / "rounded.bvh"
    rounded.write_text(text.replace(frame_time, "Frame Time: 0.008333"))
    ntsc = tmp_path / "ntsc.bvh"  # 119.88 fps: 0.1 % slower, another rate
    ntsc.write_text(text.replace(frame_time, "Frame Time: 0.00834168"))
    for command in ("blend", "stitch"):
        out = tmp_path / f"{command}.bvh"
        code, _, err = run_cli(capsys, command, clips[0], rounded, "-o", out)
        assert code == 0, err
        assert mc.load(out).frame_time == mc.load(clips[0]).frame_time
        code, _, err = run_cli(capsys, command, clips[0], ntsc, "-o", out.with_suffix(".n.bvh"))
        assert code == 1 and "frame time 0.00834168 s differs" in err


def test_a_skeleton_with_its_joints_in_another_order_is_said_so(clips, tmp_path, capsys):
    """The same joints, their legs' subtrees swapped in the file: refused, naming a joint
    and where each clip has it (the line had said only "joints or hierarchy")."""
    motion = mc.load(clips[1])
    parents = motion.parents

    def subtree(root: int) -> list[int]:
        inside = [root]
        for j in range(root + 1, motion.n_joints):
            if parents[j] in inside:
                inside.append(j)
        return inside

    left, right = subtree(1), subtree(1 + len(subtree(1)))
    order = [0, *right, *left, *range(1 + len(left) + len(right), motion.n_joints)]
    place = np.argsort(order)
    swapped = motion.replace(
        names=[motion.names[j] for j in order],
        parents=np.array([place[parents[j]] if parents[j] >= 0 else -1 for j in order]),
        offsets=motion.offsets[order],
        channels=[motion.channels[j] for j in order],
        rotations=motion.rotations[:, order],
        translations=motion.translations[:, order],
        end_sites={int(place[j]): site for j, site in motion.end_sites.items()},
        source_values=None,
        source_rotations=None,
    )
    path = tmp_path / "swapped.bvh"
    mc.save(swapped, path)
    code, _, err = run_cli(capsys, "stitch", clips[0], path, "-o", tmp_path / "o.bvh")
    moved = motion.names[1]  # the first joint the two orders place apart
    assert code == 1 and err.count("\n") == 1
    assert (
        f"the same joints in another order: {moved} is joint {int(place[1]) + 1} here, 2 there"
    ) in err


def test_blending_clips_that_face_other_ways_says_so(clips, tmp_path, capsys):
    """A clip blended with itself turned half a turn about the up axis: the blend's root
    turns between the two (13 degrees in one frame on a tester's clips, where the inputs
    turn at most 1.3), a note says so and how to avoid it; two clips facing alike get none."""
    from motionclean.core import kinematics

    motion = mc.load(clips[1])
    turn = quat.from_axis_angle(np.eye(3)[kinematics.up_axis(motion)], np.pi)
    rotations = motion.rotations.copy()
    rotations[:, 0] = quat.multiply(turn, rotations[:, 0])
    turned = tmp_path / "turned.bvh"
    mc.save(motion.replace(rotations=rotations, source_values=None, source_rotations=None), turned)
    code, out, err = run_cli(capsys, "blend", clips[1], turned, "-o", tmp_path / "b.bvh")
    assert code == 0, err
    assert f"note: {turned}: its root is turned 180 degrees from {clips[1]}'s" in out
    code, out, err = run_cli(capsys, "blend", clips[0], clips[1], "-o", tmp_path / "c.bvh")
    assert code == 0 and "its root is turned" not in out + err


def test_stitch_aligns_the_second_roots_position_and_heading(tmp_path, capsys):
    """Two takes joined: the second starts where the first ends (horizontal position and
    heading about the up axis), so the root does not slide across the room at the seam."""
    from helpers import corpus_clip

    from motionclean.core import kinematics

    first, second = corpus_clip("131_01.bvh"), corpus_clip("131_02.bvh")
    a = mc.load(first)
    for flag, aligned in ((), True), (("--no-align",), False):
        out = tmp_path / f"s{aligned}.bvh"
        code, _, err = run_cli(capsys, "stitch", first, second, "-o", out, *flag)
        assert code == 0, err
        clip = mc.load(out)
        root = kinematics.local_translations(clip)[:, 0]
        seam = a.n_frames - 1
        speed = np.linalg.norm(np.diff(root[:, [0, 2]], axis=0), axis=1) / clip.frame_time
        own = np.linalg.norm(
            np.diff(kinematics.local_translations(a)[:, 0, [0, 2]], axis=0), axis=1
        )
        own_max = own.max() / a.frame_time
        near = speed[seam - 30 : seam + 30].max()
        if aligned:
            assert near < 2.0 * own_max
            turn = quat.angle_between(clip.rotations[seam - 1, 0], clip.rotations[seam + 1, 0])
            assert np.degrees(turn) < 5.0
            assert root[seam + 5, 1] == pytest.approx(
                kinematics.local_translations(mc.load(second))[5, 0, 1], abs=0.5
            )
        else:
            assert near > 3.0 * own_max  # the old behaviour: a slide at the seam


@pytest.mark.parametrize("up", ["y", "z"])
@pytest.mark.parametrize("degrees", [90.0, -35.0])
def test_a_take_cut_turned_and_stitched_again_walks_on_as_it_did(tmp_path, capsys, up, degrees):
    """A walk cut in two, its second half turned about the up axis and moved across the
    room, then stitched to its first half: aligned, the second half faces and stands where
    the take had it again, so past the transition every joint is back where it was. (The
    heading's sign had been reversed: the turn was doubled, and a 90-degree turn walked
    off the other way.) The same on a Z-up copy."""
    from helpers import corpus_clip, z_up_copy

    from motionclean.core import kinematics

    take = mc.load(corpus_clip("131_02.bvh"))
    take = z_up_copy(take) if up == "z" else take
    axis = np.eye(3)[kinematics.up_axis(take)]
    cut = take.n_frames // 2
    first, second = (
        take.at_frames(np.arange(cut)),
        take.at_frames(np.arange(cut - 1, take.n_frames)),
    )
    turn = quat.from_axis_angle(axis, np.radians(degrees))
    moved = second.translations.copy()
    moved[:, 0] = quat.rotate(turn, moved[:, 0]) + 300.0 * np.cross(axis, [1.0, 1.0, 1.0])
    rotations = second.rotations.copy()
    rotations[:, 0] = quat.multiply(turn, rotations[:, 0])
    paths = tmp_path / "a.bvh", tmp_path / "b.bvh", tmp_path / "ab.bvh"
    mc.save(first, paths[0])
    mc.save(second.replace(rotations=rotations, translations=moved), paths[1])
    code, _, err = run_cli(capsys, "stitch", paths[0], paths[1], "-o", paths[2], "--levels", "2")
    assert code == 0, err
    joined, height = mc.load(paths[2]), kinematics.body_height(take)
    after = slice(cut + 3 * (2**2 - 1) + 1, None)  # past the transition
    np.testing.assert_allclose(
        kinematics.forward(joined)[0][after],
        kinematics.forward(take)[0][after],
        atol=0.01 * height,
    )


def test_stitch_refuses_another_skeleton(tmp_path, capsys):
    moved = tmp_path / "moved.bvh"
    text = SAMPLE.read_text()
    assert "OFFSET 1.24777 -1.64261 0.71711" in text
    moved.write_text(text.replace("OFFSET 1.24777 -1.64261", "OFFSET 790 -1.64261", 1))
    code, _, err = run_cli(capsys, "stitch", SAMPLE, moved, "-o", tmp_path / "o.bvh")
    assert code == 1 and "another OFFSET" in err and not (tmp_path / "o.bvh").exists()


def test_blend_and_stitch_carry_positions_only_where_a_joint_has_some():
    """Rotations go through the pyramids for every joint and positions only for joints
    that have any: the same clip as one call on every joint's rotations and positions,
    including a joint without position channels whose translations are not zero."""
    from motionclean.run.jobs import blend_clips, stitch_clips

    a = mc.load(SAMPLE)
    b = a.replace(rotations=quat.multiply(a.rotations, quat.from_axis_angle([0.0, 0.0, 1.0], 0.3)))
    moved = a.translations.copy()
    moved[:, 5] = np.linspace(0.0, 2.0, a.n_frames)[:, None]  # joint 5 has no position channel
    a = a.replace(translations=moved)
    q, p = multires.blend(a.rotations, b.rotations, 3, 0.4, None, a.translations, b.translations)
    blended = blend_clips(a, b, levels=3, weight=0.4)
    assert np.array_equal(blended.rotations, q) and np.array_equal(blended.translations, p)
    assert blended.translations[:, 5].any()
    q, p = multires.stitch(a.rotations, b.rotations, 3, a.translations, b.translations)
    joined = stitch_clips(a, b, levels=3, align=False)
    assert np.array_equal(joined.rotations, q) and np.array_equal(joined.translations, p)


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (["--weight", "nan"], "Invalid value for '--weight': nan is not in the range 0.0<=x<=1.0."),
        (
            ["--detail-weights", "1e308"],
            "--detail-weights: each weight must be from 0 (FIRST's detail) to 1 (SECOND's), "
            "got 1e+308",
        ),
        (["--detail-weights", "0,-1"], "to 1 (SECOND's), got -1"),
        (["--detail-weights", "1e6"], "to 1 (SECOND's), got 1e+06"),
        (["--detail-weights", "0.5,nan"], "to 1 (SECOND's), got nan"),
    ],
)
def test_blend_weights_outside_0_to_1_are_usage_errors(tmp_path, capsys, option, message):
    out = tmp_path / "bl.bvh"
    code, _, err = run_cli(capsys, "blend", SAMPLE, NOISY, "-o", out, *option)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1
    assert lines[0].startswith("motionclean: error: ") and lines[0].endswith(message)
    assert not out.exists()


def test_blending_clips_without_frames_is_a_data_error_naming_the_file(tmp_path, capsys):
    from helpers import cut_bvh

    empty = cut_bvh(SAMPLE, tmp_path / "empty.bvh", 0)
    out = tmp_path / "bl.bvh"
    code, _, err = run_cli(capsys, "blend", empty, empty, "-o", out)
    assert code == 1
    assert err.strip().splitlines() == [
        f"motionclean: error: {empty}: cannot blend a clip without frames"
    ]
    assert not out.exists()


@pytest.mark.parametrize("command", ["blend", "stitch"])
def test_blend_and_stitch_read_channel_csvs_with_their_skeleton(clips, tmp_path, capsys, command):
    """Channel CSVs hold no skeleton: `--skeleton` gives them one, as for clean; without it
    a BVH output is refused in one line and nothing is written."""
    csvs = []
    for clip in clips:
        csvs.append(tmp_path / f"{clip.stem}.csv")
        mc.save(mc.load(clip), csvs[-1])
    out = tmp_path / "out.bvh"
    code, _, err = run_cli(capsys, command, *csvs, "-o", out)
    assert code == 1 and "--skeleton" in err and err.count("\n") == 1 and not out.exists()
    code, _, err = run_cli(capsys, command, *csvs, "-o", out, "--skeleton", clips[0])
    assert code == 0, err
    with_rig = run_cli(capsys, command, *clips, "-o", tmp_path / "direct.bvh")
    assert with_rig[0] == 0
    assert out.read_bytes() == (tmp_path / "direct.bvh").read_bytes()


def test_blending_clips_of_other_lengths_says_they_must_be_as_long(tmp_path, capsys):
    from helpers import cut_bvh

    short = cut_bvh(SAMPLE, tmp_path / "short.bvh", 100)
    code, _, err = run_cli(capsys, "blend", SAMPLE, short, "-o", tmp_path / "bl.bvh")
    assert code == 1 and err == (
        f"motionclean: error: {short}: 100 frames, {SAMPLE} has 300: the clips must be as "
        "long (cut them to the frames they share, or join them with stitch)\n"
    )


def test_blend_at_weight_1_is_the_second_clip_byte_for_byte(tmp_path, capsys):
    """As weight 0 gives the first (its text kept); weight 1 had rewritten every value of
    the second clip's motion in the first's text."""
    out = tmp_path / "bl.bvh"
    code, _, err = run_cli(capsys, "blend", SAMPLE, NOISY, "-o", out, "--weight", "1")
    assert code == 0 and err == "" and out.read_bytes() == NOISY.read_bytes()
    code, _, err = run_cli(capsys, "blend", SAMPLE, NOISY, "-o", out, "--weight", "0")
    assert code == 0 and err == "" and out.read_bytes() == SAMPLE.read_bytes()
    from motionclean.run.jobs import blend_clips

    a, b = mc.load(SAMPLE), mc.load(NOISY)
    with pytest.raises(ValueError, match="levels"):  # (checked at weight 1 as at any)
        blend_clips(a, b, levels=-3, weight=1.0)
    assert blend_clips(a, b, weight=1.0).rotations is not b.rotations  # (a clip of its own)
