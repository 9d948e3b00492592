"""Missing samples (tracker dropouts) in the data model: the mask, placeholders, BVH refusal."""

import re

import numpy as np
import pytest
from helpers import SAMPLE

import motionclean as mc
from motionclean.core.errors import InvalidMotion, MotionError
from motionclean.core.motion import hold_missing
from motionclean.core.restpose import rest_frames


def test_hold_missing_takes_the_last_known_sample_or_the_first_one_after_a_leading_gap():
    values = np.arange(12.0).reshape(6, 2, 1)
    missing = np.zeros((6, 2), dtype=bool)
    missing[0, 0] = missing[3:5, 0] = True
    missing[:, 1] = True  # never known: kept as it is
    held = hold_missing(values, missing)[..., 0]
    np.testing.assert_array_equal(held[:, 0], [2, 2, 4, 4, 4, 10])
    np.testing.assert_array_equal(held[:, 1], values[:, 1, 0])


def test_motion_checks_the_mask_and_drops_an_empty_one():
    clip = mc.load(SAMPLE)
    assert clip.missing is None and not clip.has_gaps
    assert clip.replace(missing=np.zeros((clip.n_frames, clip.n_joints), bool)).missing is None
    with pytest.raises(InvalidMotion, match=r"missing: expected a bool array of shape"):
        clip.replace(missing=np.zeros((clip.n_frames, 2), bool))
    with pytest.raises(InvalidMotion, match=r"missing: expected a bool array"):
        clip.replace(missing=np.zeros((clip.n_frames, clip.n_joints)))


def test_a_clip_with_gaps_is_not_equal_to_the_same_arrays_without_and_has_no_rest_frames():
    clip = mc.load(SAMPLE)
    missing = np.zeros((clip.n_frames, clip.n_joints), dtype=bool)
    missing[:5, 3] = True  # a held placeholder looks like a held pose
    gappy = clip.replace(missing=missing)
    assert gappy != clip and gappy.has_gaps
    assert rest_frames(gappy) == (0, 0)


def test_bvh_output_refuses_missing_samples_naming_the_joint_and_frames(tmp_path):
    clip = mc.load(SAMPLE)
    missing = np.zeros((clip.n_frames, clip.n_joints), dtype=bool)
    missing[10:14, 5] = missing[40, 5] = True
    out = tmp_path / "out.bvh"
    with pytest.raises(MotionError, match=rf"'{clip.names[5]}' is missing on frames 10-13, 40"):
        mc.save(clip.replace(missing=missing), out)
    assert not out.exists()


@pytest.mark.parametrize(
    ("joints", "also"),
    [
        ([7], "; J7 has gaps too,"),
        ([7, 8, 9, 10, 11, 12], "; J7, J8, J9, J10 and 2 more have gaps too,"),
    ],
)
def test_bvh_output_refusal_names_every_joint_with_gaps(tmp_path, joints, also):
    """All the joints with gaps are named at once: a user fixing one would otherwise meet
    the next on every run."""
    clip = mc.load(SAMPLE)
    clip = clip.replace(names=tuple(f"J{j}" for j in range(clip.n_joints)))
    missing = np.zeros((clip.n_frames, clip.n_joints), dtype=bool)
    missing[10:14, 5] = True
    missing[60:62, joints] = True
    with pytest.raises(
        MotionError, match=re.escape(f"'J5' is missing on frames 10-13 (frames from 0){also}")
    ):
        mc.save(clip.replace(missing=missing), tmp_path / "out.bvh")
