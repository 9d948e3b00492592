"""``mc.load`` and ``mc.save`` check their arguments where they enter: TypeError naming the
parameter, never an AttributeError from deep inside a reader or a string read character
by character."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SAMPLE, cut_bvh

import motionclean as mc

IK = """Coordinates
version=1
nRows=2
nColumns=3
inDegrees=yes
endheader
time\tpelvis_rotation\tpelvis_residual
0.00\t10.0\t1.0
0.01\t11.0\t2.0
"""


def _npz_without_rate(path):
    rng = np.random.default_rng(0)
    np.savez(path, poses=rng.normal(0, 0.1, (5, 72)), trans=np.zeros((5, 3)))
    return path


def test_a_skeleton_given_as_a_path_is_read_as_a_clip(tmp_path):
    """skeleton="rig.bvh" had raised AttributeError: 'str' object has no attribute 'names'."""
    rig = cut_bvh(SAMPLE, tmp_path / "rig.bvh", 10)
    mc.save(mc.load(rig), tmp_path / "clip.csv")
    by_path = mc.load(tmp_path / "clip.csv", skeleton=str(rig))
    by_clip = mc.load(tmp_path / "clip.csv", skeleton=mc.load(rig))
    assert by_path.names == by_clip.names
    assert np.array_equal(by_path.rotations, by_clip.rotations)
    mc.load(tmp_path / "clip.csv", skeleton=rig)  # a Path too


@pytest.mark.parametrize("skeleton", [3, b"rig.bvh", ["rig.bvh"]])
def test_a_skeleton_of_another_type_is_refused_by_name(tmp_path, skeleton):
    with pytest.raises(TypeError, match=r"^skeleton: expected a Motion or a file path, got "):
        mc.load(SAMPLE, skeleton=skeleton)


def test_exclude_as_one_string_is_refused_not_split(tmp_path):
    """exclude="*_residual" had been read as the patterns '*', '_', 'r', ..."""
    (tmp_path / "ik.mot").write_text(IK)
    with pytest.raises(TypeError, match=r"^exclude: expected a list of patterns, got a single"):
        mc.load(tmp_path / "ik.mot", exclude="*_residual")
    motion = mc.load(tmp_path / "ik.mot", exclude=["*_residual"])
    assert motion.names == ["pelvis_rotation"]
    assert mc.load(tmp_path / "ik.mot", exclude=("*_residual",)).names == motion.names


@pytest.mark.parametrize("exclude", [[1], None, 5])
def test_exclude_of_other_types_is_refused_by_name(tmp_path, exclude):
    with pytest.raises(TypeError, match=r"^exclude: "):
        mc.load(SAMPLE, exclude=exclude)


@pytest.mark.parametrize("rate", ["60", [60], True])
def test_a_frame_rate_that_is_not_a_number_is_refused_by_name(tmp_path, rate):
    with pytest.raises(TypeError, match=r"^frame_rate: expected a number, got "):
        mc.load(_npz_without_rate(tmp_path / "x.npz"), frame_rate=rate)


@pytest.mark.parametrize("rate", [0, -5, float("nan"), 1e9])
def test_a_frame_rate_out_of_range_is_refused_by_name(tmp_path, rate):
    with pytest.raises(ValueError, match=r"^frame_rate must be from "):
        mc.load(SAMPLE, frame_rate=rate)


def test_a_frame_rate_of_numpy_type_is_taken(tmp_path):
    motion = mc.load(_npz_without_rate(tmp_path / "x.npz"), frame_rate=np.float32(60))
    assert motion.frame_rate == pytest.approx(60)


@pytest.mark.parametrize("path", [3, None, b"clip.bvh"])
def test_load_and_save_name_a_path_of_another_type(tmp_path, path):
    with pytest.raises(TypeError, match=r"^path: expected a file path"):
        mc.load(path)
    with pytest.raises(TypeError, match=r"^path: expected a file path"):
        mc.save(mc.load(SAMPLE), path)


def test_a_body_model_of_another_type_is_refused_by_name(tmp_path):
    with pytest.raises(TypeError, match=r"^body_model: expected a file path"):
        mc.load(_npz_without_rate(tmp_path / "x.npz"), body_model=3)


def test_save_names_a_motion_of_another_type(tmp_path):
    with pytest.raises(TypeError, match=r"^motion: save takes a Motion, got dict"):
        mc.save({}, tmp_path / "x.bvh")
