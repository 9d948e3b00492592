"""World space: forward kinematics against bvhio and a per-joint loop, rigid moves of the
root, the up axis and the body height."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import CORPUS_NAMES, SAMPLE, corpus_clip, exporter_bvh, z_up_copy

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.core.restpose import rest_frames
from motionclean.io.bvh import parse_bvh

bvhio = pytest.importorskip("bvhio", reason="bvhio is the test oracle for world positions")


def bvhio_positions(path, n_joints, frames) -> np.ndarray:
    """World positions of the joints, in file order, at ``frames`` as bvhio computes them
    (float32)."""
    root = bvhio.readAsHierarchy(str(path))
    joints = [joint for joint, _, _ in root.layout()]
    assert len(joints) == n_joints
    out = []
    for frame in frames:
        root.loadPose(int(frame))
        out.append([list(joint.PositionWorld) for joint in joints])
    return np.array(out)


def loop_forward(motion: mc.Motion) -> np.ndarray:
    """World positions by a plain loop over joints in float64 (parents before children)."""
    local = kinematics.local_translations(motion)
    pos = np.zeros_like(local)
    rot = np.zeros_like(motion.rotations)
    for j, parent in enumerate(motion.parents):
        if parent < 0:
            pos[:, j], rot[:, j] = local[:, j], motion.rotations[:, j]
        else:
            rot[:, j] = quat.multiply(rot[:, parent], motion.rotations[:, j])
            pos[:, j] = pos[:, parent] + quat.rotate(rot[:, parent], local[:, j])
    return pos


@pytest.mark.parametrize("name", CORPUS_NAMES)
def test_world_positions_match_bvhio_on_the_corpus(name, tmp_path):
    path = corpus_clip(name)
    motion = mc.load(path)
    frames = np.linspace(0, motion.n_frames - 1, 5).astype(int)
    ours, _ = kinematics.forward(motion)
    # bvhio reads those frames' rows alone, as written (its reader would take seconds over
    # the whole take)
    lines = path.read_text().splitlines(keepends=True)
    at = next(i for i, line in enumerate(lines) if line.startswith("Frames:"))
    rows = lines[at + 2 :]
    picked = tmp_path / name
    picked.write_text(
        "".join(lines[:at])
        + f"Frames: {frames.size}\n"
        + lines[at + 1]
        + "".join(rows[f] for f in frames)
    )
    theirs = bvhio_positions(picked, motion.n_joints, range(frames.size))
    height = kinematics.body_height(motion)
    assert np.abs(ours[frames] - theirs).max() < 1e-5 * height


@pytest.mark.parametrize("seed", range(6))
def test_every_rotation_order_and_position_channels_on_any_joint(seed, tmp_path):
    """Random exporters' files: all six orders, position channels on any joint (the axes
    they name replace the OFFSET's), values up to 400 degrees."""
    data, _ = exporter_bvh(seed, "lf", False, "  ", False, 60, False)
    path = tmp_path / "x.bvh"
    path.write_bytes(data)
    motion = parse_bvh(data, str(path))
    ours, _ = kinematics.forward(motion)
    theirs = bvhio_positions(path, motion.n_joints, range(motion.n_frames))
    scale = max(1.0, float(np.abs(ours).max()))
    assert np.abs(ours - theirs).max() < 2e-5 * scale
    np.testing.assert_allclose(ours, loop_forward(motion), rtol=0, atol=1e-9 * scale)


def random_forest(seed: int, n_joints: int = 12, n_frames: int = 40) -> mc.Motion:
    """A clip with several roots, joints listed after their parents, position channels on
    some joints."""
    rng = np.random.default_rng(seed)
    parents = [-1 if j in (0, 5) else int(rng.integers(0, j)) for j in range(n_joints)]
    channels = [
        ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
        if j % 4 == 0
        else ("Yrotation", "Xrotation", "Zrotation")
        for j in range(n_joints)
    ]
    values = rng.uniform(-180, 180, (n_frames, sum(len(c) for c in channels)))
    return mc.Motion.from_channel_values(
        [f"j{j}" for j in range(n_joints)],
        parents,
        rng.normal(size=(n_joints, 3)),
        channels,
        1 / 30,
        values,
    )


@pytest.mark.parametrize("seed", range(4))
def test_several_roots_match_a_per_joint_loop(seed):
    motion = random_forest(seed)
    ours, world = kinematics.forward(motion)
    np.testing.assert_allclose(ours, loop_forward(motion), rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(world, axis=-1), 1.0, atol=1e-12)


def test_blocks_of_frames_agree_with_the_loop(monkeypatch):
    """Clips longer than one block (here blocks of 256 frames and a shorter last one)."""
    motion = random_forest(7, n_frames=700)
    monkeypatch.setattr(kinematics, "BLOCK_ELEMENTS", 1)
    ours, world = kinematics.forward(motion)
    np.testing.assert_allclose(ours, loop_forward(motion), rtol=0, atol=1e-9)
    monkeypatch.undo()
    whole = kinematics.forward(motion)
    assert np.array_equal(ours, whole[0]) and np.array_equal(world, whole[1])


def test_joints_in_any_order_give_the_same_world_points():
    """forward_arrays takes parents listed after their children too."""
    motion = random_forest(3)
    rng = np.random.default_rng(3)
    perm = rng.permutation(motion.n_joints)  # new joint i is old joint perm[i]
    where = np.argsort(perm)
    parents = np.where(motion.parents[perm] >= 0, where[motion.parents[perm]], -1)
    local = kinematics.local_translations(motion)
    ours, world = kinematics.forward_arrays(parents, motion.rotations[:, perm], local[:, perm])
    expected, expected_world = kinematics.forward(motion)
    np.testing.assert_allclose(ours, expected[:, perm], rtol=0, atol=1e-12)
    np.testing.assert_allclose(world, expected_world[:, perm], rtol=0, atol=1e-15)


def test_a_5000_deep_chain_works():
    n = 5000
    motion = mc.Motion.from_channel_values(
        [f"j{j}" for j in range(n)],
        np.arange(-1, n - 1),
        np.tile([0.0, 1.0, 0.0], (n, 1)),
        [("Zrotation", "Xrotation", "Yrotation")] * n,
        1 / 30,
        np.zeros((2, 3 * n)),
    )
    positions, _ = kinematics.forward(motion)
    np.testing.assert_allclose(positions[:, -1], [[0.0, float(n), 0.0]] * 2)  # root offset too


def test_a_chain_deeper_than_the_level_loop_matches_the_per_joint_loop():
    """Past :data:`kinematics.LEVEL_LOOP_DEPTH` levels the chain is composed by pointer
    jumping: with random rotations at every level it gives what a parent-first loop does."""
    n = kinematics.LEVEL_LOOP_DEPTH + 36
    rng = np.random.default_rng(5)
    motion = mc.Motion.from_channel_values(
        [f"j{j}" for j in range(n)],
        np.arange(-1, n - 1),
        rng.normal(size=(n, 3)),
        [("Zrotation", "Xrotation", "Yrotation")] * n,
        1 / 30,
        rng.uniform(-40.0, 40.0, (3, 3 * n)),
    )
    positions, _ = kinematics.forward(motion)
    np.testing.assert_allclose(positions, loop_forward(motion), rtol=0, atol=1e-9)


def test_a_rigid_move_of_the_root_moves_every_point_rigidly():
    motion = mc.load(SAMPLE)
    turn = quat.from_axis_angle(np.array([0.3, 0.9, -0.2]) / np.linalg.norm([0.3, 0.9, -0.2]), 1.1)
    shift = np.array([12.0, -3.0, 40.0])
    rotations = motion.rotations.copy()
    translations = motion.translations.copy()
    rotations[:, 0] = quat.multiply(turn, rotations[:, 0])
    translations[:, 0] = quat.rotate(turn, translations[:, 0]) + shift
    moved = motion.replace(rotations=rotations, translations=translations)
    before, _ = kinematics.forward(motion, end_sites=True)
    after, _ = kinematics.forward(moved, end_sites=True)
    np.testing.assert_allclose(after, quat.rotate(turn, before) + shift, atol=1e-9)


def test_up_axis_and_body_height_follow_the_rest_pose():
    motion = mc.load(SAMPLE)
    assert kinematics.up_axis(motion) == 1
    height = kinematics.body_height(motion)
    rest = kinematics.rest_positions(motion)
    assert height == pytest.approx(np.ptp(rest[:, 1]))
    z_up = z_up_copy(motion)
    assert kinematics.up_axis(z_up) == 2
    assert kinematics.body_height(z_up) == pytest.approx(height, rel=1e-12)
    turn = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi / 2)
    np.testing.assert_allclose(
        kinematics.forward(z_up)[0], quat.rotate(turn, kinematics.forward(motion)[0]), atol=1e-9
    )
    assert kinematics.up_axis(motion, "z") == 2
    with pytest.raises(ValueError, match="x, y, z, -x, -y or -z"):
        kinematics.up_axis(motion, "w")


def test_a_cycle_in_parents_is_refused():
    with pytest.raises(ValueError, match="cycle"):
        kinematics.depth_levels(np.array([-1, 2, 1]))


def test_world_report_of_an_identity_is_zero_and_of_a_root_shift_is_the_shift():
    from motionclean.report.summary import build_report

    motion = mc.load(SAMPLE)
    same = build_report(motion, motion.replace(rotations=motion.rotations.copy()))["world"]
    assert same["up_axis"] == "y"
    assert same["body_height"] == pytest.approx(kinematics.body_height(motion))
    _, names = kinematics.end_effectors(motion)
    assert set(same["effectors"]) == set(names) and "Head_end" in names
    assert all(e["deviation"]["max"] == 0.0 for e in same["effectors"].values())
    shift = np.array([3.0, -4.0, 0.0])  # 5 units
    translations = motion.translations.copy()
    translations[:, 0] += shift
    moved = build_report(motion, motion.replace(translations=translations))["world"]
    for entry in moved["effectors"].values():
        assert entry["deviation"]["rms"] == pytest.approx(5.0, abs=1e-9)
        assert entry["deviation"]["max"] == pytest.approx(5.0, abs=1e-9)
        assert entry["deviation"]["max_percent"] == pytest.approx(500.0 / same["body_height"])
        before, after = entry["linear_accel_rms"]["before"], entry["linear_accel_rms"]["after"]
        assert after == pytest.approx(before, rel=1e-6)  # a constant shift adds no acceleration
    assert moved["worst_deviation"]["max"] == pytest.approx(5.0)


def test_convert_world_writes_every_joint_and_end_site(tmp_path, capsys):
    import csv

    from helpers import run_cli

    code, _, err = run_cli(capsys, "convert", SAMPLE, tmp_path / "w.csv", "--world")
    assert code == 0 and err == ""
    with open(tmp_path / "w.csv", newline="") as f:
        rows = list(csv.reader(f))
    motion = mc.load(SAMPLE)
    names = motion.names + kinematics.end_site_names(motion)
    assert rows[0] == ["time", *(f"{n}.{a}" for n in names for a in "xyz")]
    table = np.array(rows[1:], dtype=float)
    positions, _ = kinematics.forward(motion, end_sites=True)
    np.testing.assert_allclose(table[:, 0], np.arange(motion.n_frames) * motion.frame_time)
    np.testing.assert_allclose(table[:, 1:], positions.reshape(motion.n_frames, -1), rtol=1e-8)
    code, _, err = run_cli(capsys, "convert", SAMPLE, tmp_path / "w.bvh", "--world")
    assert code == 2 and "must end in .csv" in err and not (tmp_path / "w.bvh").exists()


def test_only_some_points_gives_those_exactly_in_the_order_asked():
    motion = mc.load(SAMPLE)
    full = kinematics.world_positions(motion)
    only = np.array([17, 0, motion.n_joints, full.shape[1] - 1, 4])
    assert np.array_equal(kinematics.world_positions(motion, only=only), full[:, only])
    # one chain alone (only the joints it hangs on are computed): the same bits
    for only in (np.array([full.shape[1] - 1]), np.array([motion.n_joints - 1, 2])):
        assert np.array_equal(kinematics.world_positions(motion, only=only), full[:, only])


def test_report_figures_from_the_figure_points_equal_those_from_every_point():
    """build_series keeps the world positions of the end effectors and feet only: the
    contacts, skate and end-effector figures are what every joint's positions give."""
    from motionclean.core import contacts as found
    from motionclean.report.summary import build_report, build_series

    motion = mc.load(corpus_clip(CORPUS_NAMES[0]))
    after, _ = mc.Pipeline.default().run(motion)
    report = build_report(motion, after, series=build_series(motion, after))
    full_b, full_a = (kinematics.world_positions(clip) for clip in (motion, after))
    feet, up, height = found.skeleton_feet(motion)
    params = found.ContactParams()
    contacts, _ = found.detect(found.FootScene(full_b, feet, up, height, motion.frame_time), params)
    skate = found.skate(full_a, feet, contacts, up, motion.frame_time, None, found.DRIFT_SECONDS)
    for k, foot in enumerate(feet):
        entry = report["contacts"]["feet"][foot.name]
        assert entry["contacts"] == [list(run) for run in found.contact_runs(contacts)[k]]
        held = np.zeros(motion.n_frames, dtype=bool)
        for first, stop in entry["contacts"]:
            held[first:stop] = True
        np.testing.assert_array_equal(held, contacts[:, k])
        assert entry["skate"]["after"] == skate[k]
    lead, trail = rest_frames(motion)
    core = slice(lead, motion.n_frames - trail)
    index, names = kinematics.end_effectors(motion)
    moved = np.linalg.norm(full_a[core][:, index] - full_b[core][:, index], axis=-1)
    for n, name in enumerate(names):
        assert report["world"]["effectors"][name]["deviation"]["max"] == moved[:, n].max()


@pytest.mark.parametrize("block", [1, 7])
def test_world_csv_row_block_by_row_block_is_the_same_bytes(monkeypatch, block):
    from helpers import ROOT

    from motionclean.io import text, world_csv

    clip = mc.load(SAMPLE)
    bodies = mc.load(ROOT / "sample_data" / "131_02_motive.csv")
    missing = np.zeros((bodies.n_frames, bodies.n_joints), dtype=bool)
    missing[10:14, 1] = True
    gappy = bodies.replace(missing=missing)
    whole = [world_csv.format_world_csv(clip), world_csv.format_world_csv(gappy)]
    monkeypatch.setattr(text, "ROW_BLOCK", block)
    assert [world_csv.format_world_csv(clip), world_csv.format_world_csv(gappy)] == whole
    assert b",," in whole[1] and b"nan" not in whole[1]


def test_poses_sampled_for_the_up_axis_and_height_leave_the_rest_frames_out(tmp_path):
    """The frames a clip's up axis and body height are read from lie between its rest-pose
    frames (which every figure leaves out), so `info`, the report and the steps measure
    the same body: 40 T-pose frames after the sample's motion are never sampled."""
    from helpers import with_t_pose

    clip = mc.load(with_t_pose(SAMPLE, tmp_path / "t.bvh", frames=40, at_end=True))
    lead, trail = rest_frames(clip)
    assert trail == 40
    poses, _ = kinematics.sample_poses(clip)
    t_pose = kinematics.world_positions(clip.at_frames(np.array([clip.n_frames - 1])))[0]
    distance = np.linalg.norm(poses - t_pose, axis=-1).max(axis=1)
    assert (distance > 1e-6).all()  # no sample is a rest frame
    motion = kinematics.world_positions(clip.at_frames(np.arange(clip.n_frames - trail)))
    assert poses.shape[0] == min(kinematics.POSE_SAMPLES, clip.n_frames - trail)
    assert np.allclose(poses[0], motion[0]) and np.allclose(poses[-1], motion[-1])


def test_kinematics_is_importable_by_its_public_name():
    import importlib

    module = importlib.import_module("motionclean.kinematics")
    from motionclean.kinematics import forward

    assert module is mc.kinematics and forward is mc.kinematics.forward


@pytest.mark.parametrize(
    "call",
    [
        kinematics.forward,
        kinematics.rest_positions,
        kinematics.end_effectors,
        kinematics.end_site_names,
        kinematics.point_parents,
        kinematics.local_translations,
        kinematics.sample_poses,
        kinematics.body_height,
        kinematics.up_axis,
        kinematics.up_direction,
        kinematics.up_name,
    ],
)
def test_the_public_functions_name_an_argument_that_is_no_motion(call):
    """``forward(None)`` had raised AttributeError ('NoneType' object has no attribute
    'parents')."""
    for value in (None, "clip.bvh"):
        with pytest.raises(
            TypeError, match=rf"^motion: expected a Motion, got {type(value).__name__}$"
        ):
            call(value)
