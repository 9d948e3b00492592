"""Motion: equality on copies, joint look-up."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import SAMPLE

import motionclean as mc
from motionclean.core.errors import InvalidMotion, MotionError


def test_equal_to_a_deep_copy_and_not_to_a_changed_one():
    clip = mc.load(SAMPLE)
    copy = clip.replace(rotations=clip.rotations.copy(), translations=clip.translations.copy())
    assert copy == clip
    moved = clip.translations.copy()
    moved[3, 0, 1] += 1e-9
    assert clip.replace(translations=moved) != clip
    renamed = clip.replace(names=[*clip.names[:-1], "Other"])
    assert renamed != clip
    assert clip != "not a motion"


def test_joint_index_names_the_missing_joint():
    clip = mc.load(SAMPLE)
    assert clip.joint_index("LeftKnee") == clip.names.index("LeftKnee")
    with pytest.raises(MotionError, match="no joint named 'Tail'"):
        clip.joint_index("Tail")
    assert np.all(clip.parents[1:] < np.arange(1, clip.n_joints))  # parents come first


def test_consecutive_indices_become_a_slice_that_selects_the_same_items():
    from motionclean.core.motion import _as_slice

    table = np.arange(60.0).reshape(3, 20)
    for index in ([[4, 5, 6], [7, 8, 9]], [3], [[4, 5, 6], [8, 9, 10]], [5, 4], [2, 2]):
        index = np.array(index)
        chosen = _as_slice(index)
        consecutive = bool((np.diff(index.ravel()) == 1).all())
        assert isinstance(chosen, slice) == consecutive
        np.testing.assert_array_equal(table[:, chosen], table[:, index.ravel()])


def test_what_a_clip_derives_is_its_own_and_follows_edits_in_place():
    """Motion.derived: a shallow copy given other arrays keeps its own value without
    evicting the original's (they shared one cache: each asked again in turn), and a clip
    written into in place (as the pipeline's partial steps do) and marked edited is asked
    again, not answered with the value of its old contents."""
    import copy

    motion = mc.load(SAMPLE)
    calls = []

    def first_w(clip):
        calls.append(1)
        return float(clip.rotations[0, 0, 0])

    assert motion.derived("w", first_w) == motion.rotations[0, 0, 0]
    other = copy.copy(motion)
    other.rotations = -motion.rotations
    assert other.derived("w", first_w) == -motion.rotations[0, 0, 0]
    assert motion.derived("w", first_w) == motion.rotations[0, 0, 0]
    assert len(calls) == 2
    other.rotations[0, 0] = [0.0, 1.0, 0.0, 0.0]
    other.edited()
    assert other.derived("w", first_w) == 0.0
    assert len(calls) == 3


def test_a_clip_whose_array_is_replaced_derives_again_however_often():
    """What Motion.derived keeps goes when an array is replaced: arrays replaced twice
    between two questions (the second may take the freed id of the first's predecessor,
    so a key of ids could match a stale value) are derived again every time."""
    motion = mc.load(SAMPLE)
    calls = []

    def count(clip):
        calls.append(1)
        return len(calls)

    motion.rotations = motion.rotations.copy()
    for _ in range(50):
        before = motion.derived("n", count)
        for _ in range(2):
            motion.rotations = motion.rotations.copy()
        assert motion.derived("n", count) == before + 1


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda m: {"parents": np.r_[1, 0, m.parents[2:]]}, "is its own ancestor (a cycle)"),
        (lambda m: {"parents": np.arange(m.n_joints)}, "'Hips' is its own ancestor"),
        (lambda m: {"parents": np.r_[-1, [m.n_joints + 5] * (m.n_joints - 1)]}, "from 0 to 30"),
        (lambda m: {"parents": m.parents.astype(float)}, "expected 31 integers, got float64"),
        (lambda m: {"offsets": m.offsets[:3]}, "offsets: expected finite values of shape (31, 3)"),
        (lambda m: {"end_sites": {99: np.zeros(3)}}, "end_sites: 99 is not a joint"),
    ],
)
def test_a_skeleton_that_is_no_tree_of_the_joints_is_refused(change, message):
    """Such a clip had been accepted and saved as a BVH that does not read back ("no joints
    before MOTION"), or failed inside a writer (IndexError)."""
    motion = mc.load(SAMPLE)
    with pytest.raises(InvalidMotion, match=re.escape(message)):
        motion.replace(**change(motion))


def test_a_translation_no_channel_holds_is_refused_on_save(tmp_path):
    """A joint without position channels has no place in any file for its translation: it
    had been dropped without a word."""
    motion = mc.load(SAMPLE)
    translations = motion.translations.copy()
    translations[:, 5] += 1.0
    with pytest.raises(InvalidMotion, match="joint 'LeftToe' has no position channels"):
        mc.save(motion.replace(translations=translations), tmp_path / "x.bvh")
    assert not (tmp_path / "x.bvh").exists()


@pytest.mark.parametrize("suffix", ["bvh", "glb"])
def test_a_clip_without_joints_is_refused_when_built_and_when_saved(tmp_path, suffix):
    """It had been built, and save failed inside the writers (BVH: IndexError; glTF: numpy's
    "zero-size array to reduction operation")."""
    none = {"names": [], "parents": np.zeros(0, int), "offsets": np.zeros((0, 3))}
    arrays = {"rotations": np.zeros((5, 0, 4)), "translations": np.zeros((5, 0, 3))}
    with pytest.raises(InvalidMotion, match="^names: a clip needs at least one joint, got none"):
        mc.Motion(**none, **arrays, channels=[], frame_time=0.01)
    motion = mc.load(SAMPLE)
    motion.names = []  # (changed in place: save checks again)
    with pytest.raises(InvalidMotion, match="a clip needs at least one joint"):
        mc.save(motion, tmp_path / f"x.{suffix}")
    assert not (tmp_path / f"x.{suffix}").exists()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"channels": [("Zrotation", "Yrotation", "Xrotation")]}, "channels: expected 3 tuples"),
        ({"channels": [("Zrotation",), ("Zrotation",), 5]}, "channels: 'c''s are not a tuple"),
        ({"names": [1, 2, 3]}, "names: expected strings, got int 1"),
    ],
)
def test_a_clip_made_by_hand_is_checked_where_it_is_made(change, message):
    """Channels of the wrong count and names that are no strings had been accepted, then
    failed in `save` with IndexError or AttributeError."""
    fields = {
        "names": ["a", "b", "c"],
        "parents": np.array([-1, 0, 1]),
        "offsets": np.zeros((3, 3)),
        "channels": [("Zrotation", "Yrotation", "Xrotation")] * 3,
        "frame_time": 1 / 30,
        "rotations": np.tile([1.0, 0.0, 0.0, 0.0], (10, 3, 1)),
        "translations": np.zeros((10, 3, 3)),
    }
    with pytest.raises(InvalidMotion, match=re.escape(message)):
        mc.Motion(**(fields | change))


def test_at_frames_of_one_index_is_a_one_frame_clip():
    """`clip.at_frames(5)`, as numpy users pick a frame, is the clip at frame 5 (it had
    failed: the joint count read as the frame count)."""
    clip = mc.load(SAMPLE)
    one = clip.at_frames(5)
    assert one.n_frames == 1
    np.testing.assert_array_equal(one.rotations[0], clip.rotations[5])
    assert clip.at_frames(np.int64(5)).n_frames == 1
