"""Written Euler curves stay continuous: a changed sample continues the curve from the last
unchanged one (an Euler filter), unchanged samples keep their text, every pose is kept."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import CORPUS_NAMES, corpus_clip, degrees_between

import motionclean as mc
from motionclean.core import quat
from motionclean.steps.pipeline import Pipeline


def rotation_columns(motion: mc.Motion) -> np.ndarray:
    layout = motion.layout
    return np.concatenate([layout.rotation_columns[j] for j in np.flatnonzero(layout.has_rotation)])


@pytest.mark.parametrize("name", CORPUS_NAMES)
def test_no_written_channel_jumps_a_half_turn_where_the_input_did_not(name, tmp_path):
    source = corpus_clip(name)
    clip = mc.load(source)
    cleaned, _ = Pipeline.default().run(clip)
    mc.save(cleaned, tmp_path / "out.bvh")
    written = mc.load(tmp_path / "out.bvh")
    cols = rotation_columns(clip)
    step_in = np.abs(np.diff(clip.source_values[:, cols], axis=0))
    step_out = np.abs(np.diff(written.source_values[:, cols], axis=0))
    assert not ((step_out > 180.0) & (step_in <= 180.0)).any()
    # nor does it switch Euler solution (about a half turn on the outer angles) where the
    # input kept on (131_03's root passes a middle angle of 90 degrees)
    assert (step_out - step_in).max() < 90.0
    # the poses are those of the cleaned clip, to the file's six decimals
    assert degrees_between(written.rotations, cleaned.rotations).max() < 1e-4


def test_a_spin_written_over_changed_frames_is_unwrapped():
    """A joint turning 700 degrees about Z over changed frames is written as one rising
    curve, not wrapped back to (-180, 180]."""
    n = 120
    angles = np.zeros((n, 3))
    motion = mc.Motion.from_channel_values(
        ["a"], [-1], np.zeros((1, 3)), [("Zrotation", "Xrotation", "Yrotation")], 1 / 30, angles
    )
    spin = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.linspace(0, np.radians(700.0), n))
    rotations = motion.rotations.copy()
    rotations[10:, 0] = spin[10:]  # frames 0-9 keep their original (zero) angles
    values = motion.replace(rotations=rotations).channel_values()
    z = values[:, 0]
    assert np.all(np.abs(np.diff(z)) < 180.0)
    np.testing.assert_allclose(
        z[10:], np.degrees(np.linspace(0, np.radians(700.0), n))[10:], atol=1e-9
    )
    np.testing.assert_array_equal(values[:10], angles[:10])


def test_a_middle_angle_that_passes_a_quarter_turn_goes_on_past_it():
    """The input's middle angle rises through 90 degrees (as CMU's root does when the actor
    turns); every frame is changed a little. The written curve stays on the solution nearest
    the frame before instead of switching to the principal one (a jump of about 180 degrees
    on the outer angles where the input has none)."""
    n = 121
    angles = np.stack(
        [np.linspace(-20.0, 20.0, n), np.linspace(60.0, 119.0, n), np.linspace(10.0, -30.0, n)],
        axis=1,
    )
    motion = mc.Motion.from_channel_values(
        ["a"], [-1], np.zeros((1, 3)), [("Zrotation", "Yrotation", "Xrotation")], 1 / 30, angles
    )
    nudge = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(0.01))
    rotations = quat.multiply(motion.rotations, nudge)  # every sample changed
    values = motion.replace(rotations=rotations).channel_values()
    assert np.abs(np.diff(values, axis=0)).max() < 5.0
    assert values[-1, 1] > 90.0
    assert (
        degrees_between(
            mc.Motion.from_channel_values(
                ["a"],
                [-1],
                np.zeros((1, 3)),
                [("Zrotation", "Yrotation", "Xrotation")],
                1 / 30,
                values,
            ).rotations,
            rotations,
        ).max()
        < 1e-9
    )


def test_unchanged_samples_are_found_as_the_full_comparison_finds_them():
    """The write-back finds the samples that are still the rotation read (whose angles it
    keeps bit for bit) with a shortcut on the middle angle's sine: it finds exactly the
    samples the comparison of every sample's quaternion finds, at gimbal lock, on the
    other Euler solution, a whole turn away, and a rounding's width either side of
    :data:`motionclean.core.motion.SAME_ROTATION`."""
    from motionclean.core.motion import SAME_ROTATION, _same_as_angles, same_rotations

    rng = np.random.default_rng(5)
    for order in ("XYZ", "ZXY", "YZX", "ZYX"):
        angles = rng.uniform(-180, 180, size=(400, 5, 3))
        angles[:80, :, 1] = rng.choice([-90.0, 90.0, 89.999999, -89.9999999], (80, 5))
        angles[80:160] += 360.0 * rng.integers(-2, 3, size=(80, 5, 3))
        other = angles[160:240] + np.array([180.0, 0.0, 180.0])
        other[..., 1] = 180.0 - angles[160:240, :, 1]
        angles[160:240] = other
        q = quat.from_euler(angles, order) * rng.choice([-1.0, 1.0], size=(400, 5, 1))
        # per component: kept, just inside, just outside the tolerance, clearly changed
        scale = rng.choice([0.0, 0.5, 0.99, 1.01, 2.0, 1e3, 1e9], size=(400, 5, 1))
        q = q + scale * SAME_ROTATION * rng.choice([-1.0, 1.0], size=q.shape)
        q[::7] = quat.multiply(q[::7], quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), 1e-3))
        expected = same_rotations(q, quat.from_euler(angles, order))
        assert expected.any() and not expected.all()
        np.testing.assert_array_equal(_same_as_angles(q, order, angles), expected)


@pytest.mark.parametrize("order", ["ZXY", "ZYX", "YXZ"])
def test_new_frames_continue_the_curve_through_a_middle_angle_of_90_degrees(order):
    """Resampled frames have no original to follow: each continues the frame before, so a
    middle angle that rises through 90 degrees goes on past it (the principal angles jumped
    by half a turn on the outer two), and the frame a slerp puts on the lock is split as
    the frame before it (the principal split wrote 83 and -87 degrees between 2 and -5);
    every pose is kept to 1e-4 degrees."""
    n = 30
    t = np.arange(n) / 30.0
    angles = np.column_stack(
        [10.0 * np.sin(2 * np.pi * t), np.linspace(80.0, 100.0, n), 5.0 * np.cos(2 * np.pi * t)]
    )
    clip = mc.Motion.from_channel_values(
        ["a"], [-1], np.zeros((1, 3)), [tuple(f"{a}rotation" for a in order)], 1 / 30, angles
    )
    resampled, _ = Pipeline.from_inline(["resample:fps=60"]).run(clip)
    assert not resampled.has_source_frames()
    values = resampled.channel_values()
    assert np.abs(np.diff(values, axis=0)).max() < np.abs(np.diff(angles, axis=0)).max() + 0.5
    assert values[-1, 1] > 90.0
    back = mc.Motion.from_channel_values(
        ["a"], [-1], np.zeros((1, 3)), clip.channels, 1 / 60, values
    )
    assert degrees_between(back.rotations, resampled.rotations).max() < 1e-4


def test_new_frames_carry_no_whole_turn_past_a_leap_of_over_a_quarter_turn():
    """New frames (another format's rotations) of a Z turn unwrapped past 180 degrees, then
    one step of 100 degrees (a cut, a flip nothing repaired): the chain restarts there on
    the principal angles instead of carrying the turn (307 onwards, written as -53); every
    pose is kept."""
    angle = np.r_[150.0 + 3.0 * np.arange(20), 307.0 + 3.0 * np.arange(20)]
    channels = [("Zrotation", "Xrotation", "Yrotation")]
    base = mc.Motion.from_channel_values(
        ["a"], [-1], np.zeros((1, 3)), channels, 1 / 30, np.zeros((2, 3))
    )
    q = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(angle))[:, None]
    fresh = base.replace(rotations=q, translations=np.zeros((angle.size, 1, 3)))
    assert not fresh.has_source_frames()
    values = fresh.channel_values()
    np.testing.assert_allclose(values[:20, 0], angle[:20], atol=1e-9)  # unwrapped up to it
    np.testing.assert_allclose(values[20:, 0], angle[20:] - 360.0, atol=1e-9)
    back = mc.Motion.from_channel_values(["a"], [-1], np.zeros((1, 3)), channels, 1 / 30, values)
    assert degrees_between(back.rotations, q).max() < 1e-9
