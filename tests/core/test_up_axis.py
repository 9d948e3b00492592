"""Up axis, body height and feet from the motion: other exporters' skeletons (T- and A-pose
rests, Mixamo, MotionBuilder, Rokoko and SMPL names, video estimators, Z-up), real files
and the sample retargeted, and ``--up`` on the commands."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import (
    NAMINGS,
    ROOT,
    SAMPLE,
    arc,
    bending_hand,
    restposed,
    run_cli,
    turned_copy,
    walking_dog,
    z_up_copy,
)

import motionclean as mc
from motionclean.core import contacts as found
from motionclean.core import kinematics, quat
from motionclean.core.errors import InvalidMotion

EXPORTERS = ROOT / "tests" / "data" / "exporters"
#: Real files of other exporters (tests/data/exporters/README.md): up axis, body height
#: (file units, the standing rest pose's), the ankles' names.
REAL = {
    "mixamo_tpose.bvh": ("y", 178.4, {"mixamorig:LeftFoot", "mixamorig:RightFoot"}),
    "pymo_walk_tpose.bvh": ("y", 60.6, {"LeftFoot", "RightFoot"}),
    "tpose_rest_only.bvh": ("y", 23.9, {"LeftFoot", "RightFoot"}),
    "mocapbank_walk.bvh": ("y", 167.3, {"LeftAnkle", "RightAnkle"}),
    "video2bvh_zup.bvh": ("z", 1544.8, {"LeftFoot", "RightFoot"}),
    "video_estimate_cmu_names.bvh": ("y", 23.9, {"LeftFoot", "RightFoot"}),
}
#: +90 degrees about x (y up becomes z up) and -90 degrees about z (y up becomes x up).
TO_Z = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi / 2)
TO_X = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), -np.pi / 2)


def _world(motion: mc.Motion):
    feet, up, height = found.skeleton_feet(motion)
    return {f.name for f in feet}, kinematics.AXES[up], height


@pytest.mark.parametrize("name", sorted(REAL))
def test_real_exports_stand_up_and_find_their_feet(name):
    motion = mc.load(EXPORTERS / name)
    up, height, ankles = REAL[name]
    feet, found_up, found_height = _world(motion)
    assert found_up == up
    assert found_height == pytest.approx(height, abs=0.05)
    assert feet == ankles


@pytest.mark.parametrize("name", ["mixamo_tpose.bvh", "tpose_rest_only.bvh"])
def test_a_t_pose_whose_arm_span_outspans_its_height_is_not_lying_on_its_side(name):
    motion = mc.load(EXPORTERS / name)
    rest = kinematics.rest_positions(motion)
    assert np.argmax(np.ptp(rest, axis=0)) == 0  # the rest pose's widest axis is x
    assert kinematics.up_axis(motion) == 1


@pytest.mark.parametrize("name", sorted(REAL))
def test_the_same_answer_on_turned_copies_of_real_exports(name):
    motion = mc.load(EXPORTERS / name)
    feet, up, height = _world(motion)
    axes = np.eye(3)
    for target in "xyz":
        if target == up:
            continue
        turn = arc(axes[kinematics.AXES.index(up)], axes[kinematics.AXES.index(target)])
        assert _world(turned_copy(motion, turn)) == (feet, target, pytest.approx(height))


@pytest.mark.parametrize("pose", ["T", "A"])
@pytest.mark.parametrize("naming", sorted(NAMINGS))
def test_retargeted_rests_and_names_give_the_same_world(pose, naming):
    motion = mc.load(SAMPLE)
    other = restposed(motion, pose, naming)
    np.testing.assert_allclose(
        kinematics.forward(other, end_sites=True)[0],
        kinematics.forward(motion, end_sites=True)[0],
        atol=1e-9,
    )
    feet, up, height = _world(other)
    assert up == "y" and len(feet) == 2
    assert height == pytest.approx(np.ptp(kinematics.rest_positions(other)[:, 1]))
    for turn, axis in ((TO_Z, "z"), (TO_X, "x")):
        assert _world(turned_copy(other, turn)) == (feet, axis, pytest.approx(height))
    params = found.ContactParams()
    contacts = [
        found.detect(
            found.FootScene(
                kinematics.forward(clip, end_sites=True)[0],
                found.skeleton_feet(clip)[0],
                1,
                height,  # the same scale: the sample's own rest pose has its legs apart
                clip.frame_time,
            ),
            params,
        )[0]
        for clip in (motion, other)
    ]
    assert contacts[0].any()
    np.testing.assert_array_equal(contacts[0], contacts[1])


def test_a_rest_that_lays_every_bone_along_another_axis_gives_no_height():
    """Bandai Namco's rest lays every bone along x and its clips stand along y: the
    rest's x extent (a body and a half) had been taken for the height."""
    motion = mc.load(SAMPLE)
    line = restposed(motion, "line")
    rest = kinematics.rest_positions(line)
    assert np.argmax(np.ptp(rest, axis=0)) == 0
    standing = kinematics.body_height(motion)
    assert np.ptp(rest[:, 0]) > 1.3 * standing  # what had been taken
    feet, up, height = _world(line)
    assert up == "y" and len(feet) == 2
    assert height == pytest.approx(standing, rel=0.1)
    assert _world(turned_copy(line, TO_Z)) == (feet, "z", pytest.approx(height))


@pytest.mark.parametrize("bow", [60.0, 90.0])
def test_a_kneeling_bow_with_the_hands_forward_still_stands_up(bow):
    """Fingers are most of a Mixamo upper body's points: reaching forward in a kneeling bow
    (OpenCollar's display pose), their centroid is ahead of the legs, not above them; the
    spine and head are still above (the up axis had come out x). Also on a Z-up copy."""
    motion = mc.load(EXPORTERS / "mixamo_tpose.bvh")
    q = motion.rotations.copy()

    def turn(joint: str, axis: int, degrees: float) -> None:
        j = motion.names.index(f"mixamorig:{joint}")
        q[:, j] = quat.multiply(q[:, j], quat.from_axis_angle(np.eye(3)[axis], np.radians(degrees)))

    turn("Spine", 0, bow)
    turn("LeftArm", 1, -90.0)
    turn("RightArm", 1, 90.0)
    for side in ("Left", "Right"):
        turn(f"{side}UpLeg", 0, -20.0)
        turn(f"{side}Leg", 0, 110.0)
    kneeling = motion.replace(rotations=q, source_values=None, source_rotations=None)
    world = kinematics.world_positions(kneeling)[0]
    reach = world[motion.names.index("mixamorig:LeftHand")] - world[0]
    assert np.hypot(reach[0], reach[2]) > 20.0  # the hands well ahead of the hips
    assert kinematics.up_name(kneeling) == "y"
    assert kinematics.up_name(z_up_copy(kneeling)) == "z"


def test_a_hand_or_legs_alone_have_no_trunk_and_stand_by_their_extent():
    motion = mc.load(SAMPLE)
    assert kinematics.trunk_split(kinematics.point_parents(motion)) is not None
    hand = np.array([-1, 0, 1, 2, 0, 4, 5, 0, 7, 8])  # a wrist and three fingers
    assert kinematics.trunk_split(hand) is None
    legs = np.array([-1, 0, 1, 2, 0, 4, 5])  # a pelvis and two legs
    assert kinematics.trunk_split(legs) is None
    assert kinematics.trunk_split(np.array([-1, -1, -1])) is None  # tracked bodies


def test_a_declared_up_axis_wins_and_a_bad_one_is_refused():
    motion = mc.load(SAMPLE)
    assert kinematics.up_axis(motion.replace(up="z")) == 2
    assert kinematics.up_axis(motion.replace(up="z"), "x") == 0
    with pytest.raises(InvalidMotion, match="up: expected one of x, y, z"):
        motion.replace(up="w")
    with pytest.raises(ValueError, match="x, y, z, -x, -y or -z"):
        kinematics.up_axis(motion, "w")
    assert kinematics.up_direction(motion.replace(up="-y")) == (1, -1.0)
    assert kinematics.up_direction(motion, "-Z") == (2, -1.0)
    assert kinematics.up_direction(motion) == (1, 1.0)
    # as README's "World space" says: --up's counterpart is up_direction; up_axis drops the sign
    assert kinematics.up_direction(motion, "-y") == (1, -1.0)
    assert kinematics.up_axis(motion, "-y") == kinematics.up_axis(motion, "y") == 1
    for bad in ("--y", "-w", "y-"):
        with pytest.raises(ValueError, match="x, y, z, -x, -y or -z"):
            kinematics.up_axis(motion, bad)


def test_up_on_the_commands_is_used_and_recorded(tmp_path, capsys):
    lying = turned_copy(mc.load(EXPORTERS / "mixamo_tpose.bvh"), TO_Z)
    clip = tmp_path / "lying.bvh"
    mc.save(lying, clip)
    code, out, _ = run_cli(capsys, "info", str(clip))
    assert code == 0 and "up axis: z (found from the motion)" in out
    shown = "the motion's trunk points along +z on 100 % of frames"  # (used all the same)
    code, out, _ = run_cli(capsys, "info", str(clip), "--up", "X")
    assert code == 0 and f"up axis: x (given; {shown})" in out
    report = tmp_path / "r.json"
    code, out, _ = run_cli(capsys, "report", str(clip), "--up", "y", "--json", str(report))
    assert code == 0 and f"up axis y (given; {shown})" in out
    world = json.loads(report.read_text())["world"]
    assert (world["up_axis"], world["up_axis_source"]) == ("y", "given")
    page = tmp_path / "r.html"
    code, _, _ = run_cli(
        capsys, "clean", str(clip), "-o", str(tmp_path / "c.bvh"), "--report", str(page), "-q"
    )
    assert code == 0 and "up axis z (found from the motion)" in page.read_text()
    code, _, err = run_cli(capsys, "info", str(clip), "--up", "w")
    assert code == 2 and "--up" in err


def test_z_up_sample_keeps_its_feet_and_height():
    motion = mc.load(SAMPLE)
    assert _world(z_up_copy(motion))[1:] == ("z", pytest.approx(_world(motion)[2]))


@pytest.mark.parametrize("name", ["xy", "yz", "", "-", "--y", "w"])
def test_an_up_axis_that_is_no_axis_is_refused(name):
    """Only x, y, z and their negatives name an up axis (a substring test had let "xy",
    "" and "-" through as x)."""
    with pytest.raises(ValueError, match="up axis must be"):
        kinematics.axis_index(name)
    assert [kinematics.axis_index(n) for n in ("x", "-Y", "z", "-z")] == [0, 1, 2, 2]


#: Half a turn about z: y up becomes -y (a camera's y-down coordinates).
HEAD_DOWN = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.pi)
DIRECTIONS = ("x", "y", "z", "-x", "-y", "-z")


@pytest.mark.parametrize("turn", [0.0, 2.0 * np.pi])
def test_a_quadruped_stands_on_its_four_limbs(turn):
    """A dog's trunk lies along the way it faces, its legs and forelegs hang below it: the
    trunk rule had found -x for a dog trotting along -x (as for the MANN dog D1_007, which
    walks 9.2 m along -x). Also turning a full turn as it goes, Z-up and head down."""
    dog = walking_dog(turn=turn)
    world = kinematics.world_positions(dog)
    names = dog.names + kinematics.end_site_names(dog)
    ahead = world[:, names.index("Head_end")] - world[:, names.index("Hips")]
    assert np.all(np.hypot(ahead[:, 0], ahead[:, 2]) > 2.0 * np.abs(ahead[:, 1]))  # level
    assert kinematics.up_name(dog) == "y"
    assert kinematics.up_name(z_up_copy(dog)) == "z"
    assert kinematics.up_name(turned_copy(dog, HEAD_DOWN)) == "-y"
    shown = kinematics.motion_up(dog)
    assert (shown.axis, shown.sign, shown.by) == (1, 1.0, "limbs")
    assert shown.share >= kinematics.CONTRADICTED_SHARE


@pytest.mark.parametrize("name", sorted(REAL))
def test_the_motion_contradicts_every_up_axis_but_its_own(name):
    """Other exporters' bipeds (T- and A-pose rests, Z-up) show their up axis on every
    frame sampled: an axis given is contradicted unless it is that one, sign and all."""
    motion = mc.load(EXPORTERS / name)
    assert motion.up is None
    shown = kinematics.motion_up(motion)
    assert shown.by == "trunk" and shown.share >= kinematics.CONTRADICTED_SHARE
    contradicted = {
        given: kinematics.up_contradiction(motion.replace(up=given)) for given in DIRECTIONS
    }
    own = kinematics.up_name(motion)
    assert contradicted.pop(own) is None
    assert set(contradicted.values()) == {shown}


def test_where_the_motion_cannot_tell_a_given_up_axis_is_not_contradicted():
    """A hand (no trunk) and a figure lying on the floor and turning about the vertical as it
    lies (its trunk along each horizontal way in turn) show no up axis of their own; a dog
    shows its own, which its given up axis agrees with."""
    hand = bending_hand()
    assert kinematics.motion_up(hand).share is None
    assert all(kinematics.up_contradiction(hand.replace(up=g)) is None for g in DIRECTIONS)
    lying = turned_copy(mc.load(EXPORTERS / "mixamo_tpose.bvh"), TO_Z)  # the head along +z
    spin = quat.from_axis_angle(np.eye(3)[1], np.linspace(0.0, 2.0 * np.pi, lying.n_frames))
    q = lying.rotations.copy()
    q[:, 0] = quat.multiply(spin, q[:, 0])
    turning = lying.replace(rotations=q, translations=np.zeros_like(lying.translations))
    assert kinematics.motion_up(turning).share < kinematics.CONTRADICTED_SHARE
    assert kinematics.up_contradiction(turning.replace(up="y")) is None
    # lying still, its head always toward +z, it is a figure standing along z to its motion
    still = kinematics.up_contradiction(lying.replace(up="y"))
    assert (still.axis, still.sign) == (2, 1.0)
    dog = walking_dog()
    assert kinematics.up_contradiction(dog.replace(up="y")) is None
    assert kinematics.up_contradiction(dog.replace(up="x")).by == "limbs"


def test_an_up_axis_the_motion_contradicts_is_used_and_every_report_says_so(tmp_path, capsys):
    """``--up x`` on a Y-up walk: the axis is used (feet, contacts, figures along x), and
    ``info``, the terminal, the JSON and the page say what the motion shows, the verdict
    asks for a look; nothing on stderr. An axis the motion agrees with adds nothing."""
    clip = EXPORTERS / "pymo_walk_tpose.bvh"
    told = "the motion's trunk points along +y on 100 % of frames"
    code, out, err = run_cli(capsys, "info", str(clip), "--up", "x")
    assert (code, err) == (0, "") and f"up axis: x (given; {told})   body height" in out
    data, page = tmp_path / "c.json", tmp_path / "c.html"
    code, out, err = run_cli(
        capsys, "clean", str(clip), "-o", str(tmp_path / "c.bvh"), "--up", "x",
        "--report", str(data), "--report", str(page),
    )  # fmt: skip
    look = "needs a look: the up axis given (x) contradicts the motion (y)"
    assert (code, err) == (0, "")
    assert f"world: up axis x (given; {told}), body height" in out
    assert f"verdict: {look}. " in out
    report = json.loads(data.read_text())
    assert (report["world"]["up_axis"], report["contacts"]["up_axis"]) == ("x", "x")
    assert report["world"]["up_axis_contradicted"] == {"up_axis": "y", "by": "trunk", "share": 1.0}
    assert report["verdict"]["status"] == "needs a look"
    assert report["verdict"]["text"].startswith(look)
    text = page.read_text()
    assert f"up axis x (given; {told})" in text and look in text
    code, out, err = run_cli(capsys, "report", str(clip), "--up", "-y")
    assert (code, err) == (0, "") and "up axis -y (given; the motion's trunk points" in out
    assert "; needs a look: the up axis given (-y) contradicts the motion (y)" in out
    code, out, _ = run_cli(capsys, "report", str(clip), "--up", "y", "--json", str(data))
    assert "world: up axis y (given), body height" in out and "contradicts" not in out
    assert json.loads(data.read_text())["world"]["up_axis_contradicted"] is None


@pytest.mark.parametrize("away", [10.0, 40.0])
def test_a_prop_or_a_second_figure_beside_the_body_leaves_its_up_axis(away):
    """A second root (a prop moving 40 units off, its rest 30 below the body's; a copy of
    the figure 10 units off; a chain of more points than the body) had made the skeleton
    treeless to the trunk test, and the widest extent had laid the body on its side (up
    x, no feet found, footlock off): the body is the first root with a trunk below it,
    and its up axis and height are the body's alone."""
    body = mc.load(SAMPLE)
    up, height = kinematics.up_axis(body), kinematics.body_height(body)
    n = body.n_joints
    frames = np.arange(body.n_frames) * body.frame_time
    prop = np.stack([np.full(body.n_frames, away), 5 + np.sin(3 * frames), 0 * frames], 1)
    with_prop = mc.Motion(
        names=[*body.names, "Prop"],
        parents=np.r_[body.parents, -1],
        offsets=np.r_[body.offsets, [[away, -30.0, 0.0]]],  # (its rest below the body's)
        channels=[*body.channels, ("Xposition", "Yposition", "Zposition", "Zrotation",
                                   "Xrotation", "Yrotation")],
        frame_time=body.frame_time,
        rotations=np.concatenate([body.rotations, quat.identity((body.n_frames, 1))], axis=1),
        translations=np.concatenate([body.translations, prop[:, None]], axis=1),
        end_sites={**body.end_sites, n: np.array([0.0, 1.0, 0.0])},
    )  # fmt: skip
    assert kinematics.up_axis(with_prop) == up
    assert kinematics.body_height(with_prop) == pytest.approx(height, rel=1e-9)
    twice = mc.Motion(
        names=[*body.names, *(f"B_{name}" for name in body.names)],
        parents=np.r_[body.parents, np.where(body.parents < 0, -1, body.parents + n)],
        offsets=np.r_[body.offsets, body.offsets],
        channels=[*body.channels, *body.channels],
        frame_time=body.frame_time,
        rotations=np.concatenate([body.rotations, body.rotations], axis=1),
        translations=np.concatenate(
            [body.translations, body.translations + np.array([away, 0.0, 0.0])], axis=1
        ),
        end_sites={**body.end_sites, **{j + n: e for j, e in body.end_sites.items()}},
    )
    assert kinematics.up_axis(twice) == up
    assert kinematics.body_height(twice) == pytest.approx(height, rel=1e-9)
    links = 40  # a chain of more points than the body: no trunk below it, the body's found
    chain = mc.Motion(
        names=[*body.names, *(f"Link{k}" for k in range(links))],
        parents=np.r_[body.parents, -1, n + np.arange(links - 1)],
        offsets=np.r_[body.offsets, [[away, 0.0, 0.0]], np.tile([[0.0, 1.0, 0.0]], (links - 1, 1))],
        channels=[*body.channels, *[("Zrotation", "Xrotation", "Yrotation")] * links],
        frame_time=body.frame_time,
        rotations=np.concatenate([body.rotations, quat.identity((body.n_frames, links))], 1),
        translations=np.concatenate(
            [body.translations, np.zeros((body.n_frames, links, 3))], axis=1
        ),
        end_sites=body.end_sites,
    )
    assert kinematics.up_axis(chain) == up
    assert kinematics.body_height(chain) == pytest.approx(height, rel=1e-9)


SIX = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")


def _under_world(*bodies: mc.Motion) -> mc.Motion:
    """``bodies`` (clips of one length and rate) as one clip under a still ``World`` root at
    the origin, each a child of it, names prefixed A_, B_ ..."""
    shift, parents, end_sites = 1, [-1], {}
    for body in bodies:
        parents += np.where(body.parents < 0, 0, body.parents + shift).tolist()
        end_sites |= {j + shift: e for j, e in body.end_sites.items()}
        shift += body.n_joints
    first = bodies[0]
    return mc.Motion(
        names=["World"] + [f"{'AB'[k]}_{n}" for k, b in enumerate(bodies) for n in b.names],
        parents=np.array(parents),
        offsets=np.concatenate([np.zeros((1, 3)), *(b.offsets for b in bodies)]),
        channels=[SIX, *(c for b in bodies for c in b.channels)],
        frame_time=first.frame_time,
        rotations=np.concatenate(
            [quat.identity((first.n_frames, 1)), *(b.rotations for b in bodies)], axis=1
        ),
        translations=np.concatenate(
            [np.zeros((first.n_frames, 1, 3)), *(b.translations for b in bodies)], axis=1
        ),
        end_sites=end_sites,
    )


@pytest.mark.parametrize("axis", [0, 2])
def test_two_performers_under_one_root_stand_as_two_roots_do(axis):
    """Two performers under one ``World`` root 40 units apart (the second playing the clip
    backwards) had been read as one body, the second person its legs: up along the line
    between them, a body height of their distance, no feet. Each reads as the body it is,
    as two roots do, and a lone performer under that root reads as without it."""
    body = mc.load(SAMPLE)
    up, height = kinematics.up_axis(body), kinematics.body_height(body)
    feet = {f.name for f in found.skeleton_feet(body)[0]}
    away = body.replace(
        rotations=body.rotations[::-1].copy(),
        translations=body.translations[::-1] + 40.0 * np.eye(3)[axis],
        source_values=None,
    )
    two = _under_world(body, away)
    two_feet, two_up, two_height = found.skeleton_feet(two)
    assert (two_up, two_height) == (up, pytest.approx(height, rel=1e-9))
    assert {f.name for f in two_feet} == {f"{p}_{n}" for p in "AB" for n in feet}
    alone = _under_world(body)
    assert kinematics.up_axis(alone) == up
    assert kinematics.body_height(alone) == pytest.approx(height, rel=1e-9)
    assert {f.name for f in found.skeleton_feet(alone)[0]} == {f"A_{n}" for n in feet}


def test_helper_bones_beside_a_body_s_bones_leave_its_trunk():
    """A bone with its end site beside every thigh, shin, foot and the spine (as
    MotionBuilder's ``*_RIGMESH`` bones are) makes each leg a trunk of its own (the shin's
    subtree the upper body): the pelvis is still one body's, not several bodies'."""
    body = mc.load(SAMPLE)
    parents = kinematics.point_parents(body)
    upper, lower = kinematics.trunk_split(parents)
    beside = [body.names.index(n) for n in ("LeftHip", "LeftKnee", "LeftAnkle", "RightHip",
                                            "RightKnee", "RightAnkle", "lowerback")]  # fmt: skip
    n, k = parents.size, len(beside)
    helpers = np.r_[parents, beside, n + np.arange(k)]  # a joint and its end site each
    added = np.r_[n : n + k][:, None] + [0, k]  # (k, 2): each helper and its end site
    on_legs = np.isin(beside, lower)
    upper_h, lower_h = kinematics.trunk_split(helpers)
    assert set(upper_h.tolist()) == set(upper.tolist()) | set(added[~on_legs].ravel().tolist())
    assert set(lower_h.tolist()) == set(lower.tolist()) | set(added[on_legs].ravel().tolist())


def _moved(row: str, by: float = 150.0) -> str:
    """A motion row of the sample with its root's x position (its first value) moved."""
    values = row.split()
    return " ".join([f"{float(values[0]) + by:.4f}", *values[1:]])


def _under_a_still_root(source, target) -> None:
    """``source`` (a BVH file) under a new root that stays at the origin, as Bandai Namco's
    `joint_Root` does below its walking hips: six channels, all 0; the old root 5 body
    heights away along x (Bandai Namco's walks go 8 m)."""
    text = source.read_text()
    head, motion = text.split("MOTION")
    body = head.replace("HIERARCHY", "", 1).replace("ROOT ", "JOINT ", 1)
    body = "\n".join("\t" + line for line in body.strip().splitlines())
    channels = "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"
    lines = motion.strip().splitlines()
    rows = [line for line in lines[2:] if line.strip()]
    target.write_text(
        f"HIERARCHY\nROOT joint_Root\n{{\n\tOFFSET 0 0 0\n\t{channels}\n{body}\n}}\nMOTION\n"
        + "\n".join(lines[:2] + ["0 0 0 0 0 0 " + _moved(row) for row in rows])
        + "\n"
    )


def test_a_tracker_s_gap_does_not_lay_a_walk_down_by_its_still_root(tmp_path, capsys):
    """The sample walk under a root at rest at the origin (Bandai Namco's skeletons), as a
    channel CSV with one hand (lhand) blank on 4 frames: the up axis had been taken from the
    extent of every point (the trunk rule skipped wherever a point was unknown), which the
    still root below the walking hips made z: a body height of 228 units, no feet, and the
    default `clean` had failed with an internal IndexError (footlock read the clip as it
    entered with its own feet: none). The trunk rule now reads the frames whose points are
    known; the default cleans it, its feet found."""
    rig, table, gapped = tmp_path / "rig.bvh", tmp_path / "t.csv", tmp_path / "gap.csv"
    _under_a_still_root(SAMPLE, rig)
    assert run_cli(capsys, "convert", rig, table)[0] == 0
    lines = table.read_text().splitlines()
    header = lines[0].split(",")
    hand = [k for k, name in enumerate(header) if name.startswith("lhand.")]
    for row in range(101, 105):
        cells = lines[row].split(",")
        for k in hand:
            cells[k] = ""
        lines[row] = ",".join(cells)
    gapped.write_text("\n".join(lines) + "\n")
    whole = mc.load(rig)
    clip = mc.load(gapped, skeleton=rig)
    assert clip.missing is not None and clip.missing.any()
    assert kinematics.motion_up(clip) == kinematics.motion_up(whole)
    assert _world(clip) == _world(whole) and _world(whole)[1] == "y"
    code, out, err = run_cli(capsys, "clean", gapped, "--skeleton", rig, "-o", tmp_path / "c.csv")
    assert code == 0, err
    assert "1 gap filled on lhand" in out and "feet planted" in out


def _biped_rigged(dog: mc.Motion) -> mc.Motion:
    """``dog`` rigged as a 3ds Max Biped quadruped (a Truebones animal): its tail from a
    ``Pelvis`` below the root, its hind legs from the spine's first joint; five IK targets
    of one point each hung from the root beside it (a Sketchfab cat's); world positions
    as they were."""
    names = list(dog.names)
    spine, tail = names.index("Spine"), names.index("Tail")
    legs = [j for j, n in enumerate(names) if n.endswith(("UpLeg",))]
    parents, offsets = dog.parents.copy(), dog.offsets.copy()
    parents[legs] = spine
    offsets[legs] -= offsets[spine]  # (the spine's rest rotation is identity)
    parents[tail] = len(names)  # the Pelvis, added last at the root
    parents = np.r_[parents, 0, [0] * 5]
    offsets = np.r_[offsets, np.zeros((6, 3))]
    frames = dog.n_frames
    rotations = np.concatenate([dog.rotations, quat.identity((frames, 6))], axis=1)
    translations = np.concatenate([dog.translations, np.zeros((frames, 6, 3))], axis=1)
    return mc.Motion(
        names=[*names, "Pelvis", *(f"IK{k}" for k in range(5))],
        parents=parents,
        offsets=offsets,
        channels=[*dog.channels, *[("Zrotation", "Xrotation", "Yrotation")] * 6],
        frame_time=dog.frame_time,
        rotations=rotations,
        translations=translations,
        end_sites=dog.end_sites,
    )


def test_a_biped_rigged_quadruped_stands_on_its_legs_not_its_tail():
    """A Truebones elephant (3ds Max Biped: the tail from Bip01_Pelvis, the thighs from
    Bip01_Spine) had its tail read as its legs and its thighs in its upper body: up x (its
    length), a body height of 2.81 (its length, 1.8 tall), no feet, and ``--up y``
    contradicted. Below a pelvis whose other branches are no pair of legs (a tail, IK
    targets) the body is read where its legs part: the dog so rigged stands along y on its
    limbs with its height and hind feet, whatever way it is turned."""
    dog = walking_dog()
    rigged = _biped_rigged(dog)
    assert (
        np.abs(
            kinematics.world_positions(rigged)[:, : dog.n_joints]
            - kinematics.world_positions(dog)[:, : dog.n_joints]
        ).max()
        < 1e-12
    )
    names = rigged.names
    upper, lower = kinematics.trunk_split(kinematics.point_parents(rigged))
    assert {names[j] for j in lower if j < len(names)} == {
        f"{s}{b}" for s in ("Left", "Right") for b in ("UpLeg", "Leg", "Foot")
    }
    assert "Tail" not in {names[j] for j in upper if j < len(names)}
    shown = kinematics.motion_up(rigged)
    assert (shown.axis, shown.sign, shown.by) == (1, 1.0, "limbs")
    assert kinematics.up_name(z_up_copy(rigged)) == "z"
    assert kinematics.body_height(rigged) == pytest.approx(kinematics.body_height(dog))
    feet = {names[f.ankle] for f in found.skeleton_feet(rigged)[0]}
    assert feet == {f.name for f in found.skeleton_feet(dog)[0]}
    assert kinematics.up_contradiction(rigged.replace(up="y")) is None
