"""Foot lock: two-bone IK (exact when reachable, clamped when not, knee kept in its plane) and
lock targets (held during contacts, eased in and out, untouched elsewhere)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SAMPLE, cut_bvh, run_cli

from motionclean.core import quat
from motionclean.filters.footlock import MAX_REACH, lock_targets, two_bone_ik


def random_legs(n: int, seed: int):
    """Hips, knees, ankles of ``n`` random bent legs (thigh 4, shin 3.5) and hip rotations."""
    rng = np.random.default_rng(seed)
    hip = rng.normal(size=(n, 3))
    hip_world = quat.normalize(rng.normal(size=(n, 4)))
    thigh = quat.rotate(hip_world, np.array([0.0, -4.0, 0.0]))
    bend = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), rng.uniform(0.2, 2.0, n))
    shin = quat.rotate(quat.multiply(hip_world, bend), np.array([0.0, -3.5, 0.0]))
    return hip, hip + thigh, hip + thigh + shin, hip_world


def apply(hip, knee, ankle, hip_delta, knee_delta):
    new_knee = hip + quat.rotate(hip_delta, knee - hip)
    shin = quat.rotate(quat.multiply(hip_delta, knee_delta), ankle - knee)
    return new_knee, new_knee + shin


def test_reachable_targets_are_hit_exactly_with_bone_lengths_kept():
    hip, knee, ankle, hip_world = random_legs(500, 1)
    rng = np.random.default_rng(2)
    direction = rng.normal(size=(500, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    target = hip + direction * rng.uniform(1.0, 7.0, (500, 1))  # |4 - 3.5| < r < 7.5
    hip_delta, knee_delta = two_bone_ik(hip, knee, ankle, target, hip_world)
    new_knee, new_ankle = apply(hip, knee, ankle, hip_delta, knee_delta)
    np.testing.assert_allclose(new_ankle, target, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(new_knee - hip, axis=1), 4.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(new_ankle - new_knee, axis=1), 3.5, atol=1e-12)


def test_unreachable_targets_are_clamped_on_the_line_to_the_target():
    hip, knee, ankle, hip_world = random_legs(200, 3)
    direction = np.tile([0.3, -0.9, 0.1], (200, 1)) / np.linalg.norm([0.3, -0.9, 0.1])
    far = hip + 20.0 * direction
    near = hip + 0.1 * direction
    for target, reach in ((far, MAX_REACH * 7.5), (near, 0.5)):
        new_knee, new_ankle = apply(
            hip, knee, ankle, *two_bone_ik(hip, knee, ankle, target, hip_world)
        )
        np.testing.assert_allclose(new_ankle, hip + reach * direction, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(np.linalg.norm(new_ankle - new_knee, axis=1), 3.5, atol=1e-12)


def test_target_at_the_ankle_changes_nothing_and_knee_stays_in_its_plane():
    hip, knee, ankle, hip_world = random_legs(100, 4)
    hip_delta, knee_delta = two_bone_ik(hip, knee, ankle, ankle, hip_world)
    assert np.degrees(quat.angle(hip_delta)).max() < 1e-6
    assert np.degrees(quat.angle(knee_delta)).max() < 1e-6
    # Pull the ankle toward the hip: the knee moves within the plane of hip, knee and target.
    target = hip + 0.8 * (ankle - hip)
    new_knee, _ = apply(hip, knee, ankle, *two_bone_ik(hip, knee, ankle, target, hip_world))
    normal = np.cross(knee - hip, ankle - hip)
    off_plane = np.sum((new_knee - hip) * normal, axis=1) / np.linalg.norm(normal, axis=1)
    assert np.abs(off_plane).max() < 1e-9


def test_a_straight_leg_bends_about_its_neighbours_axis():
    hip, knee, ankle, hip_world = random_legs(20, 5)
    ankle[10] = knee[10] + 3.5 * (knee[10] - hip[10]) / 4.0  # straight on frame 10
    target = hip + 0.7 * (ankle - hip)
    hip_delta, knee_delta = two_bone_ik(hip, knee, ankle, target, hip_world)
    _, new_ankle = apply(hip, knee, ankle, hip_delta, knee_delta)
    np.testing.assert_allclose(new_ankle, target, atol=1e-9)
    assert np.all(np.isfinite(hip_delta)) and np.all(np.isfinite(knee_delta))


@pytest.mark.parametrize("blend", [0, 3, 10])
def test_targets_hold_contacts_and_ease_in_and_out(blend):
    n = 120
    ankle = np.cumsum(np.full((n, 3), 0.1), axis=0)
    contacts = np.zeros(n, dtype=bool)
    contacts[30:50] = True
    contacts[80:100] = True
    target, weight = lock_targets(ankle, contacts, blend)
    np.testing.assert_allclose(target[30:50], np.tile(ankle[30:50].mean(axis=0), (20, 1)))
    np.testing.assert_array_equal(weight[contacts], 1.0)
    width = max(blend, 1)
    assert np.all(weight[: 30 - width] == 0.0) and np.all(weight[100 + width :] == 0.0)
    np.testing.assert_array_equal(target[weight == 0.0], ankle[weight == 0.0])
    ramp_in = weight[30 - width : 30]
    assert np.all(np.diff(ramp_in) > 0.0) and np.all((ramp_in > 0.0) & (ramp_in < 1.0))


@pytest.mark.parametrize("value", ["inf", "1e308"])
def test_min_seconds_longer_than_any_clip_finds_no_contact(tmp_path, capsys, value):
    """inf is allowed by the catalogue: no contact is that long, so nothing is locked."""
    out = tmp_path / "o.bvh"
    step = f"footlock:min_seconds={value}"
    code, _, err = run_cli(capsys, "clean", SAMPLE, "-o", out, "-f", step, "-q")
    assert (code, err) == (0, "")
    assert out.read_bytes() == SAMPLE.read_bytes()  # no contact: the clip is unchanged
    toml = tmp_path / "p.toml"
    toml.write_text(f'[[step]]\nfilter = "footlock"\nmin_seconds = {value}\n')
    args = ("--baseline", tmp_path / "b.json", "--update")
    code, _, err = run_cli(capsys, "check", SAMPLE, "-p", toml, *args)
    assert (code, err) == (0, "")
    cut_bvh(SAMPLE, tmp_path / "in" / "c.bvh", 60)
    code, _, err = run_cli(capsys, "batch", tmp_path / "in", "-o", tmp_path / "b", "-p", toml, "-q")
    assert (code, err) == (0, "")
