"""Motion: equality on copies, joint look-up."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SAMPLE

import motionclean as mc
from motionclean.core.errors import MotionError


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
