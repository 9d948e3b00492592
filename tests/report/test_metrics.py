"""Metric units from closed forms: constant angular and linear acceleration, fixed offsets,
planted steps; the report carries the same numbers.

A rotation ``q(t) = exp(v(t))`` with ``v = (a t^2 / 4) u`` (``|v|`` is half the rotation
angle) turns about the fixed axis ``u`` by ``a t^2 / 2`` rad: angular velocity ``a t`` and
angular acceleration ``a`` rad/s^2, which the metric reports as ``degrees(a)`` deg/s^2 at
every interior frame and at any frame rate (000 Sec. VI-B).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionclean.core import quat
from motionclean.core.motion import Motion
from motionclean.report.summary import build_report, metrics

RATES = [pytest.param(1 / 24, id="24fps"), pytest.param(1 / 120, id="120fps")]


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_rotation(rng, shape=()) -> np.ndarray:
    return quat.normalize(rng.normal(size=(*shape, 4)))


def accelerating(a: np.ndarray, axes: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``(F, C, 4)``: ``exp((a_c t^2 / 4) u_c)``, rotation angle ``a_c t^2 / 2`` rad."""
    return quat.exp((a[None, :, None] * t[:, None, None] ** 2 / 4.0) * axes[None])


@pytest.mark.parametrize("dt", RATES)
def test_angular_acceleration_of_a_uniformly_accelerated_turn(dt):
    rng = np.random.default_rng(1)
    frames = 48
    t = -0.3 * frames * dt + dt * np.arange(frames)  # passes through zero velocity
    duration = np.abs(t).max()
    a = np.array([0.5, 2.0, 7.0]) / duration**2  # rad/s^2: at most 3.5 rad of turn
    axes = unit(rng.normal(size=(3, 3)))
    q = accelerating(a, axes, t)
    # coordinate invariance (a fixed rotation on either side) and sign independence
    left, right = random_rotation(rng, (3,)), random_rotation(rng, (3,))
    q = quat.multiply(quat.multiply(left[None], q), right[None])
    q[rng.random(q.shape[:-1]) < 0.3] *= -1.0
    acc = metrics.angular_acceleration(q, dt)
    assert acc.shape == (frames - 2, 3)
    np.testing.assert_allclose(acc, np.broadcast_to(np.degrees(a), acc.shape), rtol=1e-9)


def test_angular_acceleration_scales_with_the_frame_time():
    """The same samples read at another frame rate: (dt1 / dt2)^2 times the figure."""
    t = np.arange(30) / 30.0
    q = accelerating(np.array([3.0]), np.array([[0.0, 0.0, 1.0]]), t)
    slow, fast = metrics.angular_acceleration(q, 1 / 30), metrics.angular_acceleration(q, 1 / 60)
    np.testing.assert_allclose(fast, 4.0 * slow, rtol=1e-12)
    np.testing.assert_allclose(slow, math.degrees(3.0), rtol=1e-9)


def test_uniform_rotation_has_no_angular_acceleration():
    t = np.arange(40) / 120.0
    q = quat.exp(0.5 * 3.0 * t[:, None] * unit([1.0, 2.0, 2.0]))  # 3 rad/s about one axis
    assert metrics.angular_acceleration(q, 1 / 120).max() < 1e-6
    assert metrics.angular_acceleration(q[:2], 1 / 120).shape == (0,)


@pytest.mark.parametrize("dt", RATES)
def test_linear_acceleration_of_a_uniformly_accelerated_point(dt):
    rng = np.random.default_rng(2)
    frames = 40
    t = dt * np.arange(frames)
    a = rng.normal(size=(4, 3)) * 50.0  # length units / s^2
    p0, v0 = rng.normal(size=(4, 3)) * 10.0, rng.normal(size=(4, 3))
    p = p0 + v0 * t[:, None, None] + 0.5 * a * t[:, None, None] ** 2
    acc = metrics.linear_acceleration(p, dt)
    assert acc.shape == (frames - 2, 4)
    np.testing.assert_allclose(
        acc, np.broadcast_to(np.linalg.norm(a, axis=-1), acc.shape), rtol=1e-7
    )
    assert metrics.linear_acceleration(p0 + v0 * t[:, None, None], dt).max() < 1e-9


@pytest.mark.parametrize("degrees", [0.5, 10.0, 90.0, 135.0, 179.0])
def test_deviation_of_a_fixed_rotation_is_its_angle(degrees):
    rng = np.random.default_rng(3)
    before = random_rotation(rng, (25, 2))
    offset = quat.from_axis_angle(unit(rng.normal(size=3)), math.radians(degrees))
    after_right = quat.multiply(before, offset)
    after_left = -quat.multiply(offset, before)  # the sign of a quaternion does not matter
    for after in (after_right, after_left):
        dev = metrics.deviation_deg(before, after)
        assert dev.shape == (25, 2)
        np.testing.assert_allclose(dev, degrees, rtol=1e-9)
    assert np.all(metrics.deviation_deg(before, before) < 1e-6)


def test_largest_steps_find_a_planted_step():
    frames, dt, omega = 60, 1 / 120, 2.0  # a steady 2 rad/s turn
    at = np.array([7, 31, 59])  # frame each column's step ends at
    jump = np.radians([25.0, 60.0, 170.0])
    axes = unit([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0], [1.0, 2.0, 3.0]])
    i = np.arange(frames)[:, None]
    angle = omega * dt * i + np.where(i >= at, jump, 0.0)  # rotation angle, rad
    q = quat.from_axis_angle(axes[None], angle)
    steps, frame = metrics.largest_steps(q)
    np.testing.assert_array_equal(frame, at)
    np.testing.assert_allclose(steps, np.degrees(omega * dt + jump), rtol=1e-9)
    all_steps = metrics.step_deg(q)
    assert all_steps.shape == (frames - 1, 3)
    others = np.ones(all_steps.shape, dtype=bool)
    others[at - 1, np.arange(3)] = False
    np.testing.assert_allclose(all_steps[others], np.degrees(omega * dt), rtol=1e-6)


@pytest.mark.parametrize("block", [1, 2, 7, 4096])
def test_largest_steps_in_blocks_find_the_first_largest_step(monkeypatch, block):
    """Blocks of frames give the whole-clip answer: the largest step and the first frame
    it ends at (ties across blocks keep the earlier), missing samples left out."""
    rng = np.random.default_rng(4)
    q = quat.normalize(rng.normal(size=(40, 3, 4)))
    q[:, 1] = quat.identity((40,))  # column 1: four equal 30-degree steps, the first at frame 10
    q[[10, 26], 1] = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(30.0))
    missing = np.zeros((40, 3), dtype=bool)
    missing[17, 2] = True
    whole = metrics.largest_steps(q, missing)
    monkeypatch.setattr(metrics, "BLOCK_FRAMES", block)
    blocked = metrics.largest_steps(q, missing)
    np.testing.assert_array_equal(blocked[0], whole[0])
    np.testing.assert_array_equal(blocked[1], whole[1])
    assert whole[1][1] == 10  # the first of two equal largest steps


# ----------------------------------------------------------------------------- report

ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")


def synthetic(
    dt: float, a_root: float, a_arm: float, hand_deg: float, b: np.ndarray, frames: int = 30
) -> Motion:
    """Root turning about Z with ``a_root`` rad/s^2 and moving with acceleration ``b``; an
    arm turning about X with ``a_arm``; a hand held at ``hand_deg`` about Y."""
    t = dt * np.arange(frames)
    values = np.zeros((frames, 12))
    values[:, 0:3] = [1.0, 90.0, -3.0] + 0.5 * b * t[:, None] ** 2
    values[:, 3] = np.degrees(a_root * t**2 / 2)
    values[:, 7] = np.degrees(a_arm * t**2 / 2)  # the arm's Xrotation
    values[:, 11] = hand_deg  # the hand's Yrotation
    return Motion.from_channel_values(
        ["Root", "Arm", "Hand"],
        [-1, 0, 1],
        np.zeros((3, 3)),
        [
            ROOT_CHANNELS,
            ("Zrotation", "Xrotation", "Yrotation"),
            ("Zrotation", "Xrotation", "Yrotation"),
        ],
        dt,
        values,
        path="synthetic.bvh",
    )


def approx(x):
    return pytest.approx(x, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("dt", RATES)
def test_report_carries_the_closed_form_figures(dt):
    frames = 30
    t = dt * np.arange(frames)
    span = t[-1] ** 2
    a_root, a_arm, a_root2, a_arm2 = 4.0 / span, 2.0 / span, 1.0 / span, 0.5 / span
    b, b2 = np.array([30.0, -4.0, 12.0]), np.array([3.0, 0.0, 2.0])
    before = synthetic(dt, a_root, a_arm, 0.0, b)
    after = synthetic(dt, a_root2, a_arm2, 12.5, b2)
    report = build_report(before, after, [{"filter": "x"}], None)
    assert report["file"] == "synthetic.bvh" and report["frames"] == frames
    assert report["frame_time"] == dt and report["pipeline"] == [{"filter": "x"}]
    joints = report["joints"]

    for name, a1, a2 in (("Root", a_root, a_root2), ("Arm", a_arm, a_arm2), ("Hand", 0.0, 0.0)):
        entry = joints[name]
        assert entry["angular_accel_rms"] == {
            "before": approx(math.degrees(a1)),
            "after": approx(math.degrees(a2)),
        }
        assert entry["angular_accel_max"] == {
            "before": approx(math.degrees(a1)),
            "after": approx(math.degrees(a2)),
        }
    for name, a1, a2 in (("Root", a_root, a_root2), ("Arm", a_arm, a_arm2)):
        dev = np.degrees(abs(a1 - a2) * t**2 / 2)
        assert joints[name]["deviation_deg"] == {
            "rms": approx(np.sqrt(np.mean(dev**2))),
            "max": approx(dev.max()),
        }
    assert joints["Hand"]["deviation_deg"] == {"rms": approx(12.5), "max": approx(12.5)}

    root = joints["Root"]
    assert root["linear_accel_rms"]["before"] == pytest.approx(np.linalg.norm(b), rel=1e-7)
    assert root["linear_accel_rms"]["after"] == pytest.approx(np.linalg.norm(b2), rel=1e-7)
    assert root["linear_accel_max"]["before"] == pytest.approx(np.linalg.norm(b), rel=1e-7)
    shift = np.linalg.norm(b - b2) * t**2 / 2
    assert root["deviation_length"]["rms"] == pytest.approx(np.sqrt(np.mean(shift**2)), rel=1e-9)
    assert root["deviation_length"]["max"] == pytest.approx(shift.max(), rel=1e-9)
    assert "linear_accel_rms" not in joints["Arm"] and "deviation_length" not in joints["Hand"]

    summary = report["summary"]
    total = math.degrees(math.sqrt((a_root**2 + a_arm**2) / 3))  # over all three joints
    total2 = math.degrees(math.sqrt((a_root2**2 + a_arm2**2) / 3))
    assert summary["angular_accel_rms"] == {"before": approx(total), "after": approx(total2)}
    assert summary["noise_reduction"] == approx(1.0 - total2 / total)
    assert summary["deviation_deg_max"] == approx(
        max(12.5, math.degrees(abs(a_root - a_root2) * span / 2))
    )


def test_single_clip_report_has_before_figures_only():
    before = synthetic(1 / 60, 3.0, 1.0, 0.0, np.array([0.0, 9.8, 0.0]))
    report = build_report(before)
    assert report["joints"]["Root"]["angular_accel_rms"] == {
        "before": pytest.approx(math.degrees(3.0), rel=1e-9),
        "after": None,
    }
    assert report["joints"]["Root"]["linear_accel_rms"] == {
        "before": pytest.approx(9.8, rel=1e-7),
        "after": None,
    }
    assert "deviation_deg" not in report["joints"]["Arm"]
    assert report["summary"]["noise_reduction"] is None


@pytest.mark.parametrize("block", [1, 3, 4096])
def test_linear_figures_in_blocks_of_frames_are_the_same_bits(monkeypatch, block):
    """Accelerations and distances are computed a block of frames at a time (no clip-long
    temporaries); any block size gives the whole-array figures exactly."""
    rng = np.random.default_rng(3)
    p, q = rng.normal(size=(50, 4, 3)) * 40, rng.normal(size=(50, 4, 3)) * 40
    accel = np.linalg.norm(np.diff(p, n=2, axis=0), axis=-1) / 0.01**2
    apart = np.linalg.norm(q - p, axis=-1)
    monkeypatch.setattr(metrics, "BLOCK_FRAMES", block)
    assert np.array_equal(metrics.linear_acceleration(p, 0.01), accel)
    assert np.array_equal(metrics.distance(p, q), apart)
    missing = np.zeros((50, 4), dtype=bool)
    missing[20, 1] = True
    held = metrics.linear_acceleration(p, 0.01, missing)
    assert np.isnan(held[18:21, 1]).all() and np.array_equal(held[:18], accel[:18])
