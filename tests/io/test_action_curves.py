"""Blender action curves written back (:mod:`motionclean.io.blender_action`, without bpy):
the curves an armature imported from CMU 131_02 holds (Blender's importer writes Euler
curves continuous, past +-180 degrees, and quaternions with w >= 0), cleaned by the default
pipeline, whose repairs turn RThumb half a turn from the curve read over 13 runs."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import corpus_clip

import motionclean as mc
from motionclean.core import quat
from motionclean.io.blender_action import _basis_quaternions, _property_values
from motionclean.steps.pipeline import Pipeline


@pytest.fixture(scope="module")
def thumb():
    """RThumb's Blender mode, its curve as imported (radians, Blender's x, y, z) and its
    cleaned quaternions."""
    clip = mc.load(corpus_clip("131_02.bvh"))
    j = clip.names.index("RThumb")
    order = "".join(c[0] for c in clip.channels[j] if c.endswith("rotation"))
    at = ["XYZ".index(axis) for axis in order]
    read = np.unwrap(clip.source_values[:, clip.layout.rotation_columns[j]], period=360, axis=0)
    curve = np.empty_like(read)
    curve[:, at] = np.deg2rad(read)
    return order[::-1], curve, Pipeline.default().run(clip)[0].rotations[:, j]


def test_euler_curves_take_no_step_of_half_a_turn_through_the_repairs(thumb):
    """The written curve had stepped 360 degrees between keys where the bone turned 0.3
    (Blender interpolates the channels: the thumb spun between frames): every step is now
    under half a turn on every channel, the rotations are the cleaned ones, and a kept key
    moves by whole turns at most (bit for bit where by none)."""
    mode, curve, q = thumb
    written = _property_values(q, mode, curve)
    assert np.degrees(np.abs(np.diff(written, axis=0))).max() < 180.0
    assert np.degrees(quat.angle_between(_basis_quaternions(written, mode), q)).max() < 1e-9
    turns = (written - curve) / (2.0 * np.pi)
    kept = np.degrees(quat.angle_between(_basis_quaternions(curve, mode), q)) < 1e-9
    assert np.abs(turns[kept] - np.round(turns[kept])).max() < 1e-9
    assert np.array_equal(
        written[kept & (np.abs(turns) < 0.5).all(axis=1)],
        curve[kept & (np.abs(turns) < 0.5).all(axis=1)],
    )


def test_quaternion_curves_gain_no_sign_change(thumb):
    """The sign had been chosen frame by frame against the value read, a coin toss where a
    repair turned the frame far from it: 0 sign changes read, 127 written."""
    mode, curve, q = thumb
    read = _basis_quaternions(curve, mode)
    read *= np.where(read[:, :1] < 0.0, -1.0, 1.0)  # as Blender's importer writes them
    written = _property_values(q, "QUATERNION", read)

    def sign_changes(values):
        return int((np.einsum("fi,fi->f", values[1:], values[:-1]) < 0.0).sum())

    assert sign_changes(written) <= sign_changes(read)
    assert np.degrees(quat.angle_between(written, q)).max() < 1e-9


def test_a_small_edit_moves_no_other_key_of_a_curve_that_wraps():
    """A curve read with a whole-turn step of its own between two keys, and a 1-degree edit
    of one other key: only that key changes (unwrapping every step had moved each key after
    the curve's own wrap by a turn, a 365-degree step between an edited keyed curve's keys)."""
    frames = 30
    read = np.zeros((frames, 3))
    read[:, 2] = np.linspace(150.0, 200.0, frames)  # Z, continuous through 180 ...
    read[20:, 2] -= 360.0  # ... then written a turn down, as the curve's own step
    curve = np.deg2rad(read)
    q = _basis_quaternions(curve, "XYZ")
    q[8] = quat.multiply(q[8], quat.exp(np.array([np.radians(0.5), 0.0, 0.0])))  # 1 degree
    written = _property_values(q, "XYZ", curve)
    others = np.arange(frames) != 8
    assert np.array_equal(written[others], curve[others])
    assert np.degrees(np.abs(written[8] - curve[8])).max() < 1.5
