"""SMPL-family parameters in .npz (AMASS layouts): trees, exact round trips, joint
positions from a body model or a rig, and refusals."""

from __future__ import annotations

import io
import json
import pickle
import re
import zipfile

import numpy as np
import pytest
from helpers import ROOT, run_cli

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.io import smpl_model
from motionclean.io.smpl_model import SMPL, SMPLH, SMPLX

RNG = np.random.default_rng(7)


def smooth_poses(frames: int, joints: int, seed: int = 0, scale: float = 0.4) -> np.ndarray:
    """Axis-angle rows ``(F, 3 J)`` that move slowly (radians)."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None] / 60.0
    phase, speed = rng.uniform(0, 6, (1, 3 * joints)), rng.uniform(0.5, 2, (1, 3 * joints))
    return scale * np.sin(speed * t + phase)


def amass_h(path, frames: int = 40, dtype=np.float64, rate_key="mocap_framerate"):
    """An AMASS SMPL-H file (``poses`` of 156 values, Z-up root)."""
    poses = smooth_poses(frames, 52).astype(dtype)
    poses[:, :3] += np.array([np.pi / 2, 0, 0], dtype=dtype)  # stands the Y-up body along Z
    np.savez(
        path,
        trans=(RNG.normal(0, 0.1, (frames, 3)) + [0, 0, 0.9]).astype(dtype),
        gender=np.array("female"),
        **{rate_key: np.array(120.0)},
        betas=RNG.normal(0, 1, 16),
        dmpls=RNG.normal(0, 1, (frames, 8)),
        poses=poses,
    )
    return path


def amass_x(path, frames: int = 30):
    """An AMASS SMPL-X N file: ``poses`` (165) and the same pose split by body part."""
    poses = smooth_poses(frames, 55, seed=3)
    split = {
        "root_orient": poses[:, :3],
        "pose_body": poses[:, 3:66],
        "pose_jaw": poses[:, 66:69],
        "pose_eye": poses[:, 69:75],
        "pose_hand": poses[:, 75:],
    }
    np.savez(
        path,
        gender=np.array("neutral"),
        surface_model_type=np.array("smplx"),
        mocap_frame_rate=np.array(60.0),
        trans=np.zeros((frames, 3)),
        poses=poses,
        betas=np.zeros(16),
        **split,
    )
    return path


#: Rest offsets (metres, Y up, facing +Z) of a made-up T-pose, by joint name (left side;
#: the right mirrors it), for fake body models whose joints stand like a body.
T_POSE = {
    "pelvis": (0, 0.95, 0),
    "hip": (0.09, -0.08, 0),
    "knee": (0, -0.4, 0),
    "ankle": (0, -0.4, 0),
    "foot": (0, -0.06, 0.12),
    "spine1": (0, 0.11, 0),
    "spine2": (0, 0.12, 0),
    "spine3": (0, 0.12, 0),
    "neck": (0, 0.2, 0),
    "head": (0, 0.12, 0.03),
    "collar": (0.07, 0.11, 0),
    "shoulder": (0.11, 0.02, 0),
    "elbow": (0.26, 0, 0),
    "wrist": (0.25, 0, 0),
    "hand": (0.08, 0, 0),
    "jaw": (0, -0.03, 0.06),
    "eye_smplhf": (0.03, 0.05, 0.08),
}


def t_pose_joints(tree) -> np.ndarray:
    """``(J, 3)`` rest joint positions of :data:`T_POSE` (each finger joint 3 cm on)."""
    joints = np.zeros((tree.n_joints, 3))
    for k, (name, parent) in enumerate(zip(tree.names, tree.parents, strict=True)):
        part = name.removeprefix("left_").removeprefix("right_")
        finger = part[:-1] in ("index", "middle", "pinky", "ring", "thumb")
        offset = np.array((0.03, 0, 0) if finger else T_POSE[part], dtype=float)
        if name.startswith("right_"):
            offset[0] = -offset[0]
        joints[k] = offset + (joints[parent] if parent >= 0 else 0.0)
    return joints


def fake_body_model(tree, extra: int = 40, shapes: int = 4, seed: int = 1):
    """A small made-up body model whose joints stand as :data:`T_POSE`: the template's first
    vertices are the joints (the regressor picks them, with a little of the others) and
    shape directions move everything a little; returns the arrays."""
    rng = np.random.default_rng(seed)
    joints = t_pose_joints(tree)
    template = np.concatenate([joints, rng.normal(0, 0.2, (extra, 3)) + [0, 0.9, 0]])
    regressor = np.zeros((tree.n_joints, len(template)))
    regressor[:, : tree.n_joints] = 0.9 * np.eye(tree.n_joints)
    regressor[:, tree.n_joints :] = 0.1 / extra
    return {
        "v_template": template,
        "J_regressor": regressor,
        "shapedirs": rng.normal(0, 0.01, (len(template), 3, shapes)),
        "kintree_table": np.array([tree.parents, range(tree.n_joints)]),
    }


def rodrigues(r: np.ndarray) -> np.ndarray:
    """Rotation matrices of axis-angle vectors, written independently of motionclean."""
    angle = np.linalg.norm(r, axis=-1)[..., None, None]
    k = r / np.maximum(np.linalg.norm(r, axis=-1, keepdims=True), 1e-300)
    kx = np.zeros(r.shape[:-1] + (3, 3))
    kx[..., 0, 1], kx[..., 0, 2], kx[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    kx -= np.swapaxes(kx, -1, -2)
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def smpl_joints(poses, trans, joints_rest, parents) -> np.ndarray:
    """World joint positions by SMPL's own definition (its forward kinematics)."""
    frames, n = len(poses), len(parents)
    rot = rodrigues(poses.reshape(frames, n, 3))
    world_r = np.empty_like(rot)
    world_p = np.empty((frames, n, 3))
    for k, p in enumerate(parents):
        if p < 0:
            world_r[:, k], world_p[:, k] = rot[:, k], joints_rest[k]
        else:
            world_r[:, k] = world_r[:, p] @ rot[:, k]
            world_p[:, k] = world_p[:, p] + world_r[:, p] @ (joints_rest[k] - joints_rest[p])
    return world_p + trans[:, None]


def test_trees_are_the_models():
    assert (SMPL.n_joints, SMPLH.n_joints, SMPLX.n_joints) == (24, 52, 55)
    assert SMPLX.names[22:25] == ("jaw", "left_eye_smplhf", "right_eye_smplhf")
    assert SMPLH.names[22] == SMPLX.names[25] == "left_index1"
    for tree in (SMPL, SMPLH, SMPLX):
        assert all(p < k for k, p in enumerate(tree.parents))  # parents come first
        assert tree.parents[tree.names.index("left_ankle")] == tree.names.index("left_knee")
    assert SMPLX.parents[SMPLX.names.index("right_thumb3")] == SMPLX.names.index("right_thumb2")


def test_axis_angle_becomes_the_same_rotation(tmp_path):
    path = amass_h(tmp_path / "a.npz")
    motion = mc.load(path)
    poses = np.load(path)["poses"]
    assert motion.names == list(SMPLH.names) and motion.frame_rate == 120.0
    expected = rodrigues(poses.reshape(len(poses), 52, 3))
    assert np.abs(quat.as_matrix(motion.rotations) - expected).max() < 1e-12
    assert np.all(np.einsum("fji,fji->fj", motion.rotations[1:], motion.rotations[:-1]) >= 0)


def test_untouched_clip_is_written_byte_for_byte(tmp_path):
    path = amass_h(tmp_path / "a.npz")
    mc.save(mc.load(path), tmp_path / "b.npz")
    assert (tmp_path / "b.npz").read_bytes() == path.read_bytes()


def test_half_precision_poses_read_without_a_warning(tmp_path):
    """float16 poses (the bound on magnitudes had been cast to float16: inf, and a numpy
    overflow warning on stderr, an error under this suite's warning filter)."""
    half = mc.load(amass_h(tmp_path / "a.npz", dtype=np.float16))
    single = mc.load(amass_h(tmp_path / "b.npz", dtype=np.float32))
    assert np.abs(half.rotations - single.rotations).max() < 5e-3


def test_changed_joints_only_are_rewritten_keys_and_dtypes_kept(tmp_path):
    path = amass_h(tmp_path / "a.npz", dtype=np.float32)
    motion = mc.load(path)
    changed = motion.rotations.copy()
    changed[5:9, 4] = quat.multiply(changed[5:9, 4], quat.exp(np.array([0.0, 0.05, 0.0])))
    edited = motion.replace(rotations=changed)
    mc.save(edited, tmp_path / "b.npz")
    before, after = np.load(path), np.load(tmp_path / "b.npz")
    assert list(after.keys()) == list(before.keys())
    for key in before:
        assert after[key].dtype == before[key].dtype and after[key].shape == before[key].shape
        if key != "poses":
            assert np.array_equal(after[key], before[key])
    differs = before["poses"] != after["poses"]
    assert set(np.flatnonzero(differs.any(axis=0))) <= {12, 13, 14}  # joint 4's columns
    assert set(np.flatnonzero(differs.any(axis=1))) == {5, 6, 7, 8}
    again = mc.load(tmp_path / "b.npz")
    assert np.abs(again.rotations - edited.rotations).max() < 1e-6  # float32 file
    with zipfile.ZipFile(tmp_path / "b.npz") as archive:
        assert [i.filename for i in archive.infolist()] == [
            "trans.npy",
            "gender.npy",
            "mocap_framerate.npy",
            "betas.npy",
            "dmpls.npy",
            "poses.npy",
        ]


def test_an_angle_past_a_half_turn_keeps_its_branch(tmp_path):
    poses = np.zeros((3, 72))
    poses[:, 3:6] = [[0, 0, 3.5], [0, 0, 3.6], [0, 0, 3.7]]  # > pi: the long way round
    np.savez(tmp_path / "a.npz", poses=poses, mocap_framerate=30)
    motion = mc.load(tmp_path / "a.npz")
    nudged = motion.rotations.copy()
    nudged[1, 1] = quat.multiply(nudged[1, 1], quat.exp(np.array([0, 0, 0.001])))
    mc.save(motion.replace(rotations=nudged), tmp_path / "b.npz")
    out = np.load(tmp_path / "b.npz")["poses"]
    assert out[1, 5] == pytest.approx(3.602, abs=1e-9)  # not 3.602 - 2 pi
    assert np.array_equal(out[[0, 2]], poses[[0, 2]])


def test_smplx_n_layout_reads_poses_and_writes_every_form(tmp_path):
    path = amass_x(tmp_path / "x.npz")
    motion = mc.load(path)
    assert motion.names == list(SMPLX.names) and motion.frame_rate == 60.0
    split_only = dict(np.load(path))
    del split_only["poses"]
    np.savez(tmp_path / "split.npz", **split_only)
    assert np.abs(mc.load(tmp_path / "split.npz").rotations - motion.rotations).max() < 1e-15
    q = motion.rotations.copy()
    q[:, 23] = quat.multiply(q[:, 23], quat.exp(np.array([0.02, 0, 0])))  # left eye
    mc.save(motion.replace(rotations=q), tmp_path / "out.npz")
    out = np.load(tmp_path / "out.npz")
    assert np.array_equal(out["poses"][:, 69:72], out["pose_eye"][:, :3])
    assert not np.array_equal(out["poses"][:, 69:72], np.load(path)["poses"][:, 69:72])
    for key in ("pose_body", "pose_hand", "pose_jaw", "root_orient"):
        assert np.array_equal(out[key], np.load(path)[key])


def test_smplx_style_keys_and_smpl_body(tmp_path):
    frames = 12
    poses = smooth_poses(frames, 24, seed=5).astype(np.float32)
    np.savez(
        tmp_path / "s.npz",
        global_orient=poses[:, :3],
        body_pose=poses[:, 3:].reshape(frames, 23, 3),
        transl=np.zeros((frames, 3), dtype=np.float32),
    )
    motion = mc.load(tmp_path / "s.npz")
    assert motion.names == list(SMPL.names)
    assert motion.frame_rate == 30.0
    assert any("30 fps assumed" in note for note in kinematics.source_notes(motion))
    mc.save(motion, tmp_path / "t.npz")
    assert (tmp_path / "t.npz").read_bytes() == (tmp_path / "s.npz").read_bytes()


def test_joint_positions_from_a_body_model_follow_smpl(tmp_path):
    path = amass_h(tmp_path / "a.npz", frames=20)
    model = fake_body_model(SMPLH)
    np.savez(tmp_path / "model.npz", **model)
    motion = mc.load(path, body_model=tmp_path / "model.npz")
    data = np.load(path)
    betas = data["betas"][:4]
    rest = model["J_regressor"] @ (model["v_template"] + model["shapedirs"] @ betas)
    expected = smpl_joints(data["poses"], data["trans"], rest, SMPLH.parents)
    positions, _ = kinematics.forward(motion)
    assert np.abs(positions - expected).max() < 1e-12
    # the body stands along Z (AMASS's root turns the Y-up model): found from the motion
    assert kinematics.up_axis(motion) == 2
    assert 1.3 < kinematics.body_height(motion) < 1.9
    assert kinematics.world_note(motion) is None
    mc.save(motion, tmp_path / "b.npz")
    assert (tmp_path / "b.npz").read_bytes() == path.read_bytes()


def test_a_filtered_clip_keeps_world_positions_consistent(tmp_path):
    path = amass_h(tmp_path / "a.npz", frames=60)
    np.savez(tmp_path / "model.npz", **fake_body_model(SMPLH))
    motion = mc.load(path, body_model=tmp_path / "model.npz")
    smoothed = motion.replace(
        rotations=mc.filters.lee_shin(motion.rotations, mc.filters.masks.binomial(2))
    )
    mc.save(smoothed, tmp_path / "b.npz")
    back = mc.load(tmp_path / "b.npz", body_model=tmp_path / "model.npz")
    positions, _ = kinematics.forward(back)
    expected, _ = kinematics.forward(smoothed)
    assert np.abs(positions - expected).max() < 1e-9


def test_joint_positions_from_a_rig_by_name_or_order(tmp_path):
    frames = 10
    np.savez(tmp_path / "s.npz", poses=smooth_poses(frames, 24), trans=np.zeros((frames, 3)))
    offsets = RNG.normal(0, 0.1, (24, 3))
    names = ["m_avg_" + ("L_" + n[5:] if n.startswith("left_") else n).title() for n in SMPL.names]
    rig = mc.Motion(
        names=names,
        parents=np.array(SMPL.parents),
        offsets=offsets,
        channels=[("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")]
        + [("Zrotation", "Yrotation", "Xrotation")] * 23,
        frame_time=1 / 30,
        rotations=np.tile([1.0, 0, 0, 0], (1, 24, 1)),
        translations=np.zeros((1, 24, 3)),
    )
    mc.save(rig, tmp_path / "rig.bvh")
    by_name = mc.load(tmp_path / "s.npz", skeleton=mc.load(tmp_path / "rig.bvh"))
    assert np.allclose(by_name.offsets, offsets, atol=1e-6)
    shuffled = rig.replace(names=[f"j{k}" for k in range(24)])
    mc.save(shuffled, tmp_path / "order.bvh")
    by_order = mc.load(tmp_path / "s.npz", skeleton=mc.load(tmp_path / "order.bvh"))
    assert np.array_equal(by_order.offsets, by_name.offsets)
    other = rig.at_frames(slice(None))
    other = mc.Motion(
        names=names[:5],
        parents=np.array(SMPL.parents[:5]),
        offsets=offsets[:5],
        channels=rig.channels[:5],
        frame_time=1 / 30,
        rotations=rig.rotations[:, :5],
        translations=rig.translations[:, :5],
    )
    mc.save(other, tmp_path / "small.bvh")
    with pytest.raises(mc.MotionError, match="no joint for 19 of the SMPL joints"):
        mc.load(tmp_path / "s.npz", skeleton=mc.load(tmp_path / "small.bvh"))


def test_without_positions_world_figures_are_skipped_and_bvh_asks_for_a_skeleton(tmp_path, capsys):
    path = amass_h(tmp_path / "a.npz", frames=30)
    code, out, _ = run_cli(capsys, "info", path)
    assert code == 0 and "world: skipped (SMPL parameters hold no joint positions" in out
    code, _, err = run_cli(capsys, "convert", path, tmp_path / "a.bvh")
    assert code == 1 and err.count("\n") == 1
    assert "to write BVH give a skeleton (--skeleton rig.bvh) or a body model" in err
    assert not (tmp_path / "a.bvh").exists()
    np.savez(tmp_path / "model.npz", **fake_body_model(SMPLH))
    code, _, _ = run_cli(
        capsys, "convert", path, tmp_path / "a.bvh", "--body-model", tmp_path / "model.npz"
    )
    assert code == 0
    as_bvh = mc.load(tmp_path / "a.bvh")
    with_model = mc.load(path, body_model=tmp_path / "model.npz")
    positions_bvh, _ = kinematics.forward(as_bvh)  # (a BVH lists the joints depth first)
    positions, _ = kinematics.forward(with_model)
    positions = positions[:, [with_model.names.index(name) for name in as_bvh.names]]
    assert np.abs(positions_bvh - positions).max() < 1e-4  # BVH's six decimals
    code, out, _ = run_cli(capsys, "clean", path, "-o", tmp_path / "c.npz")
    assert code == 0 and "world: skipped" in out
    assert list(np.load(tmp_path / "c.npz").keys()) == list(np.load(path).keys())


def test_clean_with_a_body_model_finds_the_feet(tmp_path, capsys):
    path = amass_h(tmp_path / "a.npz", frames=60)
    np.savez(tmp_path / "model.npz", **fake_body_model(SMPLH))
    code, out, _ = run_cli(capsys, "info", path, "--body-model", tmp_path / "model.npz")
    assert code == 0 and "up axis: z (found from the motion)" in out
    assert "foot left_ankle" in out and "foot right_ankle" in out


def test_lengths_are_said_in_metres_unless_a_rig_gives_the_offsets(tmp_path, capsys):
    """SMPL's trans and a body model's joints are metres: the lines said "units" ("body
    height 1.58 units"). With a rig (--skeleton) the offsets are in the rig's own units,
    which the clip does not know: "units" there."""
    path = amass_h(tmp_path / "a.npz", frames=60)
    np.savez(tmp_path / "model.npz", **fake_body_model(SMPLH))
    report = tmp_path / "r.json"
    code, out, _ = run_cli(
        capsys, "clean", path, "-o", tmp_path / "c.npz", "--body-model", tmp_path / "model.npz",
        "--report", report,
    )  # fmt: skip
    assert code == 0 and json.loads(report.read_text())["length_unit"] == "m"
    world = next(line for line in out.splitlines() if line.startswith("world:"))
    height = kinematics.body_height(mc.load(path, body_model=tmp_path / "model.npz"))
    assert re.search(
        rf"body height {height:.4g} m; largest end-effector deviation \S+ \S+ m ", world
    )
    assert "units" not in out
    joints, parents = t_pose_joints(SMPLH), np.array(SMPLH.parents)
    rig = mc.Motion(
        names=list(SMPLH.names),
        parents=parents,
        offsets=joints - np.where(parents[:, None] >= 0, joints[parents], 0.0),
        channels=[("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")]
        + [("Zrotation", "Yrotation", "Xrotation")] * (SMPLH.n_joints - 1),
        frame_time=1 / 30,
        rotations=np.tile([1.0, 0, 0, 0], (1, SMPLH.n_joints, 1)),
        translations=np.zeros((1, SMPLH.n_joints, 3)),
    )
    mc.save(rig, tmp_path / "rig.bvh")
    code, out, _ = run_cli(capsys, "info", path, "--skeleton", tmp_path / "rig.bvh")
    assert code == 0 and re.search(r"body height: [0-9.]+ units", out)


def bad_npz(tmp_path, name: str, **arrays) -> str:
    np.savez(tmp_path / name, **arrays)
    return str(tmp_path / name)


@pytest.mark.parametrize(
    ("arrays", "message"),
    [
        ({"poses": np.zeros((4, 70))}, "holds no axis-angle vectors"),
        ({"poses": np.zeros((4, 30))}, "10 joints per frame; SMPL has 24"),
        ({"poses": np.full((4, 72), np.nan)}, "not a finite number of at most 1e+12 in size"),
        ({"poses": np.full((4, 72), 1e200)}, "poses: a value that is not a finite number"),
        (
            {"poses": np.zeros((4, 72)), "trans": np.eye(4, 3) * 1e13},
            "trans: a value that is not a finite number of at most 1e+12 in size at frame 0",
        ),
        ({"poses": np.zeros((4, 72)), "trans": np.zeros((4, 3), complex)}, "(complex128)"),
        ({"poses": np.zeros((4, 72)), "trans": np.zeros((4, 3), "U3")}, "not an array of real"),
        ({"poses": np.zeros((4, 72)), "trans": np.zeros((5, 3))}, "different frame counts"),
        ({"betas": np.zeros(10)}, "no SMPL pose"),
        ({"poses": np.zeros((4, 72)), "mocap_framerate": np.array(0.0)}, "frame rate"),
        ({"root_orient": np.zeros((4, 3))}, "without a body pose"),
        (
            {
                "root_orient": np.zeros((4, 3)),
                "pose_body": np.zeros((4, 63)),
                "pose_hand": np.zeros((4, 12)),
            },
            "PCA components",
        ),
    ],
)
def test_bad_layouts_are_one_line(tmp_path, capsys, arrays, message):
    path = bad_npz(tmp_path, "bad.npz", **arrays)
    code, _, err = run_cli(capsys, "info", path)
    assert code == 1 and err.count("\n") == 1 and message in err
    assert err.startswith(f"motionclean: error: {path}: ")


def matrix_pose(tmp_path, orient: np.ndarray) -> str:
    """A .npz whose global_orient is ``orient`` on each of 4 frames, as (J, 3, 3) matrices."""
    return bad_npz(
        tmp_path,
        "mats.npz",
        global_orient=np.tile(orient, (4, 1, 1)),
        body_pose=np.zeros((4, 23, 3)),
    )


@pytest.mark.parametrize(
    ("orient", "message"),
    [
        (2.0 * np.eye(3), "differs from the identity by 3, determinant 8)"),
        (np.diag([1.0, 1.0, -1.0]), "differs from the identity by 0, determinant -1)"),
    ],
)
def test_pose_matrices_that_are_no_rotation_are_refused(tmp_path, capsys, orient, message):
    """(J, 3, 3) pose matrices: a scale or a mirror had been read as the nearest rotation,
    and a changed joint written back without it."""
    path = matrix_pose(tmp_path, orient)
    code, _, err = run_cli(capsys, "info", path)
    assert code == 1 and err.count("\n") == 1
    assert err.startswith(f"motionclean: error: {path}: global_orient: frame 0, matrix 0 ")
    assert err.rstrip().endswith(message)


def test_pose_matrices_that_are_rotations_are_read(tmp_path, capsys):
    code, _, err = run_cli(capsys, "info", matrix_pose(tmp_path, np.eye(3)))
    assert code == 0 and err == ""


def test_a_long_take_held_in_one_pose_is_no_zip_bomb(tmp_path, capsys):
    """20,000 frames of one SMPL pose compress 200 times (12 MB of arrays in 59 kB; 100,000
    frames, 60 MB in 287 kB, as many times): an idle or calibration take, read (it had been
    refused as a zip bomb)."""
    pose = np.random.default_rng(0).normal(0.0, 0.3, 72)
    np.savez_compressed(
        tmp_path / "still.npz",
        poses=np.tile(pose, (20_000, 1)),
        trans=np.tile([0.0, 0.9, 0.0], (20_000, 1)),
        betas=np.zeros(10),
        mocap_framerate=np.array(120.0),
    )
    assert (tmp_path / "still.npz").stat().st_size * 100 < 12_000_000
    code, out, err = run_cli(capsys, "info", tmp_path / "still.npz")
    assert code == 0 and err == "" and "20000" in out.replace(",", "")


def test_hostile_archives_are_refused(tmp_path, capsys):
    np.savez(tmp_path / "objects.npz", poses=np.array([{"x": 1}], dtype=object))
    code, _, err = run_cli(capsys, "info", tmp_path / "objects.npz")
    assert code == 1 and "holds Python objects" in err
    bomb = io.BytesIO()
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as archive:
        header = io.BytesIO()
        np.lib.format.write_array_header_1_0(
            header, {"descr": "<f8", "fortran_order": False, "shape": (4_000_000, 3)}
        )
        archive.writestr("poses.npy", header.getvalue() + bytes(96_000_000))
    # the central directory made to declare 4 GiB - 1 (the member is the same 96 MB)
    data = bytearray(bomb.getvalue())
    entry = data.rindex(b"PK\x01\x02")
    data[entry + 24 : entry + 28] = (2**32 - 1).to_bytes(4, "little")
    (tmp_path / "bomb.npz").write_bytes(data)
    code, _, err = run_cli(capsys, "info", tmp_path / "bomb.npz")
    assert code == 1 and "more than 100 times its size and over 1 GiB" in err
    (tmp_path / "cut.npz").write_bytes(amass_h(tmp_path / "ok.npz").read_bytes()[:-700])
    code, _, err = run_cli(capsys, "info", tmp_path / "cut.npz")
    assert code == 1 and err.count("\n") == 1 and "not a readable .npz" in err
    liar = io.BytesIO()
    with zipfile.ZipFile(liar, "w") as archive:
        header = io.BytesIO()
        np.lib.format.write_array_header_1_0(
            header, {"descr": "<f8", "fortran_order": False, "shape": (10**9, 72)}
        )
        archive.writestr("poses.npy", header.getvalue() + bytes(72 * 8))
    (tmp_path / "liar.npz").write_bytes(liar.getvalue())
    code, _, err = run_cli(capsys, "info", tmp_path / "liar.npz")
    assert code == 1 and "needs 576000000000 bytes" in err


def test_a_negative_dimension_is_said_to_be_no_shape(tmp_path, capsys):
    """It had been "shape (-1, 156) of float64 needs -1248 bytes, the member has 0"."""
    made = io.BytesIO()
    with zipfile.ZipFile(made, "w") as archive:
        header = io.BytesIO()
        np.lib.format.write_array_header_1_0(
            header, {"descr": "<f8", "fortran_order": False, "shape": (-1, 156)}
        )
        archive.writestr("poses.npy", header.getvalue())
    path = tmp_path / "negative.npz"
    path.write_bytes(made.getvalue())
    code, _, err = run_cli(capsys, "info", path)
    assert code == 1
    assert err == (
        f"motionclean: error: {path}: member 'poses.npy': (-1, 156) is not an array shape "
        "(a negative dimension)\n"
    )


def test_axis_angle_conversions_are_inverse():
    r = RNG.normal(0, 1.5, (500, 3))
    q = smpl_model.axis_angle_to_quaternion(r)
    back = smpl_model.quaternion_to_axis_angle(q, r)
    assert np.abs(back - r).max() < 1e-12
    m = rodrigues(r)
    assert (
        np.abs(np.abs(np.einsum("ni,ni->n", smpl_model.matrix_to_quaternion(m), q)) - 1).max()
        < 1e-12
    )


def test_a_body_model_of_another_family_is_refused(tmp_path, capsys):
    np.savez(tmp_path / "s.npz", poses=smooth_poses(5, 24), trans=np.zeros((5, 3)))
    np.savez(tmp_path / "model.npz", **fake_body_model(SMPLH))
    code, _, err = run_cli(
        capsys, "info", tmp_path / "s.npz", "--body-model", tmp_path / "model.npz"
    )
    assert code == 1 and "body model is SMPL-H (52 joints), the clip SMPL (24 joints)" in err
    wrong_tree = fake_body_model(SMPL)
    wrong_tree["kintree_table"] = np.array([[2**32 - 1] + [0] * 23, range(24)])
    np.savez(tmp_path / "flat.npz", **wrong_tree)
    code, _, err = run_cli(
        capsys, "info", tmp_path / "s.npz", "--body-model", tmp_path / "flat.npz"
    )
    assert code == 1 and "body model is SMPL (24 joints)" in err
    np.savez(tmp_path / "smpl.npz", **fake_body_model(SMPL))
    code, _, _ = run_cli(capsys, "info", tmp_path / "s.npz", "--body-model", tmp_path / "smpl.npz")
    assert code == 0


#: A pickle as the official SMPL and MANO .pkl models begin (protocol 2, a dict whose
#: arrays are chumpy objects): ``{"v_template": chumpy.ch.Ch()}``, written by hand so the
#: test needs no chumpy; never unpickled.
CHUMPY_PICKLE = (
    b"\x80\x02}q\x00X\n\x00\x00\x00v_templateq\x01cchumpy.ch\nCh\nq\x02)\x81q\x03}q\x04bs."
)


@pytest.mark.parametrize("name", ["SMPLH_MALE.pkl", "model.npz"])
def test_a_pickled_body_model_is_refused_saying_npz_models_are_read(tmp_path, capsys, name):
    """The official .pkl body model had been refused as 'not a readable .npz archive (a zip
    of .npy arrays): File is not a zip file', which tells nothing of what to give. A pickle
    is told by its first bytes (under any name) and by a .pkl suffix."""
    np.savez(tmp_path / "s.npz", poses=smooth_poses(5, 52), trans=np.zeros((5, 3)))
    (tmp_path / name).write_bytes(CHUMPY_PICKLE)
    code, out, err = run_cli(capsys, "info", tmp_path / "s.npz", "--body-model", tmp_path / name)
    assert code == 1 and out == ""
    assert err == (
        f"motionclean: error: {tmp_path / name}: a pickled body model: only .npz body models "
        "are read (the SMPL-X and AMASS SMPL+H downloads have one; or save the .pkl's arrays "
        "with numpy.savez)\n"
    )


def test_a_resampled_clip_is_written_with_its_new_frames(tmp_path, capsys):
    path = amass_h(tmp_path / "a.npz", frames=121)
    code, _, err = run_cli(capsys, "resample", path, tmp_path / "b.npz", "--fps", "60")
    assert code == 0, err
    before, after = np.load(path), np.load(tmp_path / "b.npz")
    assert list(after.keys()) == ["trans", "gender", "mocap_framerate", "betas", "poses"]
    assert after["poses"].shape == (61, 156) and after["mocap_framerate"] == 60.0
    assert np.array_equal(after["betas"], before["betas"])  # not per frame: carried
    every_other = mc.load(path).rotations[::2]
    assert (
        np.abs(
            np.abs(np.einsum("fji,fji->fj", mc.load(tmp_path / "b.npz").rotations, every_other)) - 1
        ).max()
        < 1e-6
    )


def test_the_html_report_says_why_it_has_no_player(tmp_path, capsys):
    path = amass_h(tmp_path / "a.npz", frames=20)
    code, _, _ = run_cli(
        capsys, "report", path, "--html", tmp_path / "r.html", "--json", tmp_path / "r.json"
    )
    assert code == 0
    page = (tmp_path / "r.html").read_text()
    assert "no skeleton player: SMPL parameters hold no joint positions" in page
    assert json.loads((tmp_path / "r.json").read_text())["world"] == {
        "skipped": "SMPL parameters hold no joint positions; give --skeleton or --body-model"
    }


def smplx_layouts(poses: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
    """The same SMPL-X motion in every layout the readers take."""
    frames = len(poses)
    return {
        "poses": {"poses": poses},
        "amass split": {
            "root_orient": poses[:, :3],
            "pose_body": poses[:, 3:66],
            "pose_jaw": poses[:, 66:69],
            "pose_eye": poses[:, 69:75],
            "pose_hand": poses[:, 75:],
        },
        "smplx keys": {
            "global_orient": poses[:, :3],
            "body_pose": poses[:, 3:66].reshape(frames, 21, 3),
            "jaw_pose": poses[:, 66:69],
            "leye_pose": poses[:, 69:72],
            "reye_pose": poses[:, 72:75],
            "left_hand_pose": poses[:, 75:120],
            "right_hand_pose": poses[:, 120:],
        },
        "matrices": {"fullpose": rodrigues(poses.reshape(frames, 55, 3))},
    }


@pytest.mark.parametrize("layout", ["poses", "amass split", "smplx keys", "matrices"])
def test_every_layout_reads_the_same_motion_and_writes_back_exactly(tmp_path, layout):
    poses = smooth_poses(9, 55, seed=9)
    arrays = smplx_layouts(poses)[layout]
    np.savez(tmp_path / "x.npz", mocap_frame_rate=np.array(50.0), **arrays)
    motion = mc.load(tmp_path / "x.npz")
    expected = smpl_model.axis_angle_to_quaternion(poses.reshape(9, 55, 3))
    assert motion.names == list(SMPLX.names) and motion.frame_rate == 50.0
    assert np.abs(np.abs(np.einsum("fji,fji->fj", motion.rotations, expected)) - 1).max() < 1e-12
    q = motion.rotations.copy()
    q[4, 40] = quat.multiply(q[4, 40], quat.exp(np.array([0.0, 0.01, 0.0])))  # right_index1
    mc.save(motion.replace(rotations=q), tmp_path / "y.npz")
    before, after = np.load(tmp_path / "x.npz"), np.load(tmp_path / "y.npz")
    changed = [key for key in before if not np.array_equal(before[key], after[key])]
    where = {"poses": "poses", "amass split": "pose_hand", "smplx keys": "right_hand_pose"}
    assert changed == [where.get(layout, "fullpose")]
    assert (
        np.abs(np.abs(np.einsum("fji,fji->fj", mc.load(tmp_path / "y.npz").rotations, q)) - 1).max()
        < 1e-12
    )


def test_the_body_alone_is_22_joints(tmp_path):
    np.savez(tmp_path / "b.npz", poses=smooth_poses(5, 22), trans=np.zeros((5, 3)))
    motion = mc.load(tmp_path / "b.npz")
    assert motion.names == list(SMPLX.names[:22]) and motion.parents.tolist() == list(
        SMPLX.parents[:22]
    )


def test_smpl_to_bvh_and_back(tmp_path, capsys):
    path = amass_h(tmp_path / "a.npz", frames=30)
    np.savez(tmp_path / "model.npz", **fake_body_model(SMPLH))
    model = ("--body-model", tmp_path / "model.npz")
    assert run_cli(capsys, "convert", path, tmp_path / "a.bvh", *model)[0] == 0
    code, _, err = run_cli(capsys, "convert", tmp_path / "a.bvh", tmp_path / "back.npz")
    assert code == 0, err
    before, after = np.load(path), np.load(tmp_path / "back.npz")
    q_before = smpl_model.axis_angle_to_quaternion(before["poses"].reshape(30, 52, 3))
    q_after = smpl_model.axis_angle_to_quaternion(after["poses"].reshape(30, 52, 3))
    dots = np.abs(np.einsum("fji,fji->fj", q_before, q_after))
    assert np.degrees(2 * np.arccos(np.clip(dots.min(), 0, 1))) < 1e-3  # BVH's six decimals
    assert np.abs(after["trans"] - before["trans"]).max() < 1e-5
    assert after["mocap_framerate"] == pytest.approx(120.0, rel=1e-5)
    code, _, err = run_cli(
        capsys, "convert", ROOT / "sample_data" / "131_02_cut.bvh", tmp_path / "x.npz"
    )
    assert code == 1 and "SMPL output needs the joints of SMPL, SMPL-H or SMPL-X" in err


def test_a_clip_without_frames_is_refused_and_one_frame_is_read(tmp_path, capsys):
    """A SMPL record of 0 rows had been read as a clip of 0 frames and written again
    (clean exit 0, a BVH of 'Frames: 0'); glTF, CSV and OpenSim refuse a clip they cannot
    time or play. Refused in one line, .npz and .pkl, and never written; one frame is a
    clip (its rate is the file's)."""
    empty = {"poses": np.zeros((0, 156)), "trans": np.zeros((0, 3)), "mocap_framerate": 120.0}
    np.savez(tmp_path / "zero.npz", **empty)
    (tmp_path / "zero.pkl").write_bytes(pickle.dumps(empty, protocol=4))
    for name in ("zero.npz", "zero.pkl"):
        code, out, err = run_cli(capsys, "clean", tmp_path / name, "-o", tmp_path / f"c_{name}")
        assert code == 1 and out == "" and not (tmp_path / f"c_{name}").exists()
        assert err == (
            f"motionclean: error: {tmp_path / name}: no frames: 'poses' has 0 rows; a SMPL "
            "clip needs at least one frame\n"
        )
    one = amass_h(tmp_path / "one.npz", frames=1)
    clip = mc.load(one)
    assert clip.n_frames == 1 and clip.frame_time == 1 / 120
    code, _, err = run_cli(capsys, "clean", one, "-o", tmp_path / "c1.npz", "-q")
    assert code == 0 and err == "" and (tmp_path / "c1.npz").read_bytes() == one.read_bytes()
    none = clip.replace(rotations=clip.rotations[:0], translations=clip.translations[:0])
    for name in ("none.npz", "none.pkl"):
        with pytest.raises(mc.MotionError, match="SMPL parameters need at least one frame"):
            mc.save(none, tmp_path / name)


@pytest.mark.parametrize("placement", [(0.5, 0.2, 1.0), (0.0, 0.0, 0.0)])
def test_a_fixed_placement_survives_a_trip_through_gltf(tmp_path, placement):
    """A clip whose trans never changes (a body placed once) comes back from glTF with its
    trans: the root's constant translation track is its position channels (it had become
    the root's offset, and the .npz written from it had no trans: the body at the origin)."""
    path = amass_h(tmp_path / "a.npz", frames=30)
    record = dict(np.load(path))
    record["trans"] = np.tile(placement, (30, 1))
    np.savez(path, **record)
    np.savez(tmp_path / "model.npz", **fake_body_model(SMPLH))
    clip = mc.load(path, body_model=tmp_path / "model.npz")
    mc.save(clip, tmp_path / "a.glb")
    mc.save(mc.load(tmp_path / "a.glb"), tmp_path / "back.npz")
    back = np.load(tmp_path / "back.npz")
    assert "trans" in back.files
    np.testing.assert_allclose(back["trans"], record["trans"], atol=1e-6)


def test_a_channel_csv_of_smpl_joints_goes_back_to_npz(tmp_path):
    """SMPL -> channel CSV (to edit in a spreadsheet) -> .npz: the CSV read without a
    skeleton has every joint a root, and the model's tree is known from its names (it had
    been refused: "the joints are SMPL-H's but not its tree")."""
    clip = mc.load(amass_h(tmp_path / "a.npz"))
    mc.save(clip, tmp_path / "a.csv")
    mc.save(mc.load(tmp_path / "a.csv"), tmp_path / "b.npz")
    back = mc.load(tmp_path / "b.npz")
    assert back.names == clip.names and np.array_equal(back.parents, clip.parents)
    assert np.degrees(quat.angle_between(back.rotations, clip.rotations)).max() < 1e-6
    before, after = np.load(tmp_path / "a.npz"), np.load(tmp_path / "b.npz")
    assert np.abs(after["trans"] - before["trans"]).max() < 1e-6


def test_a_record_with_two_rates_says_which_it_took_and_writes_both(tmp_path, capsys):
    """An npz with `mocap_framerate` 60 and `fps` 30: read at 60 fps (the first rate key),
    with a note of the other (it had been silent), and resampled to 120 fps every rate key
    says 120 (`fps` 30 had been left beside `mocap_framerate` 120)."""
    path = amass_h(tmp_path / "two.npz", frames=60, rate_key="mocap_framerate")
    record = dict(np.load(path))
    record["mocap_framerate"], record["fps"] = np.array(60.0), np.array(30.0)
    np.savez(path, **record)
    code, out, err = run_cli(capsys, "info", path)
    assert code == 0, err
    assert (
        "rate: 60 fps" in out
        and "note: mocap_framerate 60 fps taken; the file also says fps 30" in out
    )
    out_path = tmp_path / "120.npz"
    code, _, err = run_cli(capsys, "resample", path, out_path, "--fps", "120")
    assert code == 0, err
    written = np.load(out_path)
    assert float(written["mocap_framerate"]) == float(written["fps"]) == 120.0


@pytest.mark.parametrize(
    ("rate", "read"),
    [(10**400, None), (True, None), (np.array(30.0 + 0j), None), ("abc", None), (60, 60.0)],
)
def test_a_rate_that_is_no_number_of_frames_per_second_is_refused_in_one_line(
    tmp_path, capsys, rate, read
):
    """`mocap_framerate` too large for a float (an OverflowError had ended in "internal
    error"), a boolean (read as 1 fps), a complex number or text: one line naming the key,
    exit 1. A second rate key that is no number is noted as such beside the one taken (it
    had ended in an internal error)."""
    record = dict(np.load(amass_h(tmp_path / "a.npz", frames=30)))
    record["mocap_framerate"] = rate
    if isinstance(rate, int) and not isinstance(rate, bool):  # (an int no array holds)
        source = tmp_path / "r.pkl"
        with open(source, "wb") as out:
            pickle.dump(record, out)
    else:
        source = tmp_path / "r.npz"
        np.savez(source, **record)
    code, out, err = run_cli(capsys, "info", source)
    if read is None:
        assert code == 1 and err.count("\n") == 1
        assert (
            "mocap_framerate: frame rate" in err and "is not a number of frames per second" in err
        )
        return
    assert code == 0 and f"rate: {read:g} fps" in out
    record["fps"] = "abc"
    np.savez(tmp_path / "s.npz", **record)
    code, out, err = run_cli(capsys, "info", tmp_path / "s.npz")
    assert code == 0, err
    assert "the file also says fps (not a number of frames per second)" in out


@pytest.mark.parametrize("rate", [1e6, 1 / 3600, 2e6, 1e12, 1e-4])
def test_a_stated_rate_is_taken_as_a_bvh_takes_its_frame_time(tmp_path, capsys, rate):
    """SMPL rates are held to the range every format's are (1/3600 to 1e6 fps: a 1e6 fps
    npz had been refused where a BVH of `Frame Time: 0.000001` is read), and a refused one
    is said as a number ("frame rate 1e+12", not "[1000000000000.0]")."""
    record = dict(np.load(amass_h(tmp_path / "a.npz", frames=30)))
    record["mocap_framerate"] = np.array(rate)
    np.savez(tmp_path / "r.npz", **record)
    text = (ROOT / "sample_data" / "131_02_cut.bvh").read_text()
    stated = next(line for line in text.splitlines() if line.startswith("Frame Time:"))
    (tmp_path / "r.bvh").write_text(text.replace(stated, f"Frame Time: {1.0 / rate!r}"))
    code, out, err = run_cli(capsys, "info", tmp_path / "r.npz")
    bvh_code, _, bvh_err = run_cli(capsys, "info", tmp_path / "r.bvh")
    assert code == bvh_code, (err, bvh_err)
    if code == 0:
        assert f"frame time: {1.0 / rate:g} s" in out
    else:
        assert f"frame rate {rate:g} is not a number" in err and "[" not in err


def test_a_npy_header_holding_an_expression_is_refused_in_plain_words(tmp_path, capsys):
    """An .npz member whose .npy header holds a call, not a literal: refused in one line
    without numpy's parser objects ("<ast.Call object at 0x7f...>" had been shown)."""
    header = "{'descr': open(), 'fortran_order': False, 'shape': (3,), }"
    header += " " * (63 - len(header) % 64) + "\n"
    member = b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode()
    with zipfile.ZipFile(tmp_path / "h.npz", "w") as archive:
        archive.writestr("poses.npy", member + b"\x00" * 24)
    code, _, err = run_cli(capsys, "info", tmp_path / "h.npz")
    assert code == 1 and err.count("\n") == 1
    assert "member 'poses.npy': not a .npy array" in err and " object at 0x" not in err


@pytest.mark.parametrize("rate", [True, 60j])
def test_a_pickled_rate_of_true_or_a_complex_number_is_refused(tmp_path, capsys, rate):
    """A pickle whose `mocap_framerate` is Python's True or 60j had read "no frame rate in
    the file; 30 fps assumed" (the value dropped as no number): refused as the npz's is."""
    record = dict(np.load(amass_h(tmp_path / "a.npz", frames=30)))
    record["mocap_framerate"] = rate
    with open(tmp_path / "r.pkl", "wb") as out:
        pickle.dump(record, out)
    code, _, err = run_cli(capsys, "info", tmp_path / "r.pkl")
    assert code == 1 and "mocap_framerate: frame rate" in err and "is not a number" in err
