"""Tracker dropouts: the fill-gaps filter and step, and steps on clips with missing samples."""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest
from helpers import (
    REALNOISE,
    ROOT,
    SAMPLE,
    corpus_clip,
    degrees_between,
    max_degrees,
    needs_realnoise,
    run_cli,
    smooth_synthetic,
)

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.core.errors import MotionError
from motionclean.filters import lee_shin, masks
from motionclean.filters.gaps import (
    EDGE_FRAMES,
    SPLINE,
    VELOCITY_WEIGHTS,
    Gaps,
    _edge_gain,
    _edge_weights,
    _pooled_for_untried,
    fill_gaps,
)
from motionclean.io.bvh import format_bvh
from motionclean.steps.pipeline import Pipeline

sys.path.insert(0, str(ROOT / "bench"))
from gaps import errors, peers, rigid_bodies  # noqa: E402  (the bench's own peers and measure)


def planted(n_frames: int, n_bodies: int, length: int, seed: int) -> np.ndarray:
    """One gap of ``length`` frames per body, at a seeded place away from the ends."""
    rng = np.random.default_rng(seed)
    missing = np.zeros((n_frames, n_bodies), dtype=bool)
    for body in range(n_bodies):
        at = int(rng.integers(20, n_frames - length - 20))
        missing[at : at + length, body] = True
    return missing


@pytest.fixture(scope="module")
def bodies():
    return rigid_bodies(mc.load(corpus_clip("131_02.bvh")))


@pytest.mark.parametrize("length", [1, 3, 12, 30, 60])
def test_fill_beats_slerp_linear_and_cubic_hermite_on_real_motion(bodies, length):
    q, p = bodies
    missing = planted(q.shape[0], q.shape[1], length, seed=length)
    gaps = Gaps.of(missing)
    filled = fill_gaps(q, p, missing, max_gap=length)
    assert not filled.missing.any() and filled.filled.all()
    ours = errors(filled.rotations, filled.translations, q, p, missing)
    slerp = errors(*peers(q, p, gaps, catmull=False), q, p, missing)
    hermite = errors(*peers(q, p, gaps, catmull=True), q, p, missing)
    assert ours[0] < min(slerp[0], hermite[0])
    assert ours[1] < min(slerp[1], hermite[1])


def with_tracker_noise(q, p, noise_deg: float, seed: int):
    """White noise as bench/gaps.py plants it: ``noise_deg`` degrees per rotation-vector
    component and as many thousandths of the body height per position component."""
    rng = np.random.default_rng(seed)
    height = float(np.ptp(p[..., 1]))
    noisy_q = quat.multiply(q, quat.exp(rng.normal(size=p.shape) * np.radians(noise_deg) / 2))
    return quat.make_continuous(noisy_q), p + rng.normal(size=p.shape) * noise_deg * 1e-3 * height


@pytest.mark.parametrize(("noise_deg", "length"), [(0.5, 3), (0.5, 12), (2.0, 3), (2.0, 12)])
def test_under_tracker_noise_the_fill_beats_slerp_and_the_straight_line(bodies, noise_deg, length):
    """With white noise on the tracked data the edge samples are off by the noise: the fill
    (pooled over five seeds, against the noise-free motion) is clearly better than slerp for
    rotations and the straight line for positions, which pass through them (the bridges
    from the noisy edges' velocities were up to 1.03 of them at 2 degrees)."""
    q, p = bodies
    squares = np.zeros((2, 2))
    for seed in range(5):
        noisy_q, noisy_p = with_tracker_noise(q, p, noise_deg, seed=100 + seed)
        missing = planted(q.shape[0], q.shape[1], length, seed=seed)
        filled = fill_gaps(noisy_q, noisy_p, missing, max_gap=length)
        ours = errors(filled.rotations, filled.translations, q, p, missing)
        line = errors(*peers(noisy_q, noisy_p, Gaps.of(missing), catmull=False), q, p, missing)
        squares += np.array([ours, line]) ** 2
    ours, line = np.sqrt(squares)
    assert ours[0] <= 0.95 * line[0]  # rotations: slerp
    assert ours[1] <= 0.95 * line[1]  # positions: linear


@pytest.mark.parametrize("length", [6, 24])
def test_on_clean_smooth_motion_the_cubic_fill_beats_slerp_clearly(length):
    """Without noise the edge velocities are the motion's: the cubic fill's error is a
    fraction of slerp's and the straight line's (pooled over five seeds)."""
    squares = np.zeros((2, 2))
    for seed in range(5):
        q = smooth_synthetic(frames=400, joints=6, seed=seed)
        p = 0.1 * quat.log(smooth_synthetic(frames=400, joints=6, seed=50 + seed))
        missing = planted(400, 6, length, seed=seed)
        filled = fill_gaps(q, p, missing, max_gap=length, donors=False)
        ours = errors(filled.rotations, filled.translations, q, p, missing)
        line = errors(*peers(q, p, Gaps.of(missing), catmull=False), q, p, missing)
        squares += np.array([ours, line]) ** 2
    ours, line = np.sqrt(squares)
    assert ours[0] <= 0.2 * line[0]
    assert ours[1] <= 0.2 * line[1]


def smooth_body(n_frames: int = 120):
    t = np.arange(n_frames, dtype=float)[:, None]
    axis = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    q = quat.exp((0.4 * np.sin(t / 15.0))[..., None] * axis)
    p = np.concatenate([np.sin(t / 11.0), np.cos(t / 17.0), t / 50.0], axis=1)[:, None]
    return q, p


def test_velocity_is_continuous_at_both_edges():
    """No kink where the fill meets the data: the second differences at the edges stay of
    the size the smooth motion has, where slerp / linear bends by far more."""
    q, p = smooth_body()
    missing = np.zeros((120, 1), dtype=bool)
    missing[50:75] = True
    filled = fill_gaps(q, p, missing, max_gap=25, donors=False)
    slerp_q, linear_p = peers(q, p, Gaps.of(missing), catmull=False)

    def bend(x: np.ndarray, rotations: bool) -> np.ndarray:
        steps = quat.displacements(x[:, 0]) if rotations else np.diff(x[:, 0], axis=0)
        return np.linalg.norm(np.diff(steps, axis=0), axis=-1)  # at frames 1 .. F-2

    edges = [48, 49, 73, 74]  # second differences centred on frames 49, 50, 74, 75
    for rotations, ours, peer in (
        (True, filled.rotations, slerp_q),
        (False, filled.translations, linear_p),
    ):
        truth = bend(q if rotations else p, rotations).max()
        assert bend(ours, rotations)[edges].max() < 1.5 * truth
        assert bend(peer, rotations)[edges].max() > 5 * truth


@pytest.mark.parametrize("count", range(1, EDGE_FRAMES + 1))
def test_the_edge_gain_is_the_variance_of_a_velocity_fitted_to_white_noise(count):
    """``sum w_k (x_k - x_0)`` over samples of white noise of variance 1 (the edge sample
    ``x_0`` noisy too) has the variance :func:`_edge_gain` gives, within 2 % over 10^5
    draws (4 standard errors)."""
    weights = _edge_weights(count)
    x = np.random.default_rng(count).normal(size=(100_000, count + 1))
    velocity = (x[:, 1:] - x[:, :1]) @ weights
    assert abs(np.var(velocity) / _edge_gain(weights) - 1.0) < 0.02


def test_a_constant_angular_velocity_is_filled_exactly():
    w = np.array([0.01, -0.03, 0.02])
    q = quat.exp(np.arange(80)[:, None, None] * w)
    p = np.arange(80)[:, None, None] * np.array([0.1, 0.0, -0.2])
    missing = np.zeros((80, 1), dtype=bool)
    missing[30:52] = True
    filled = fill_gaps(q, p, missing, max_gap=60)
    assert max_degrees(filled.rotations, q) < 1e-9
    np.testing.assert_allclose(filled.translations, p, atol=1e-12)


def _filled_and_turned(q, p, missing, seed):
    """The fill of ``q``, ``p`` and the fill of the same bodies with the world turned by a
    random rotation and each body's own frame by another: ``(base, turned, world, own)``."""
    rng = np.random.default_rng(seed)
    world = quat.normalize(rng.normal(size=4))
    own = quat.normalize(rng.normal(size=(q.shape[1], 4)))
    base = fill_gaps(q, p, missing, max_gap=30)
    turned = fill_gaps(
        quat.multiply(quat.multiply(world, q), own), quat.rotate(world, p), missing, max_gap=30
    )
    return base, turned, world, own


def test_fill_is_coordinate_invariant(bodies):
    """A fixed rotation of the world, and of each body's own frame, commutes with the fill
    (donors chosen the same way)."""
    q, p = (x[:400, :8] for x in bodies)
    base, turned, world, own = _filled_and_turned(q, p, planted(400, 8, 25, seed=3), seed=5)
    np.testing.assert_array_equal(turned.donor, base.donor)
    expected = quat.multiply(quat.multiply(world, base.rotations), own)
    assert max_degrees(turned.rotations, expected) < 1e-9
    np.testing.assert_allclose(
        turned.translations, quat.rotate(world, base.translations), atol=1e-9
    )


@pytest.mark.parametrize("length", [4, 25])
def test_fill_under_noise_is_coordinate_invariant(bodies, length):
    """With tracker noise the smoothed bridges (edges from a local fit, the smoothing spline)
    fill some gaps; they too commute with a fixed rotation of the world and of each body's
    own frame."""
    q, p = with_tracker_noise(*(x[:400, :8] for x in bodies), 2.0, seed=9)
    base, turned, world, own = _filled_and_turned(q, p, planted(400, 8, length, seed=4), seed=6)
    expected = quat.multiply(quat.multiply(world, base.rotations), own)
    assert max_degrees(turned.rotations, expected) < 1e-8
    np.testing.assert_allclose(
        turned.translations, quat.rotate(world, base.translations), atol=1e-9
    )


def test_gaps_at_the_ends_hold_the_edge_sample_and_longer_ones_stay_missing():
    q, p = smooth_body()
    missing = np.zeros((120, 1), dtype=bool)
    missing[:10] = missing[110:] = True
    missing[40:90] = True  # longer than max_gap
    filled = fill_gaps(q, p, missing, max_gap=20, donors=False)
    assert max_degrees(filled.rotations[:10, 0], q[10, 0]) < 1e-12
    assert max_degrees(filled.rotations[110:, 0], q[109, 0]) < 1e-12
    np.testing.assert_array_equal(filled.translations[:10, 0], np.broadcast_to(p[10, 0], (10, 3)))
    np.testing.assert_array_equal(filled.missing[:, 0], np.isin(np.arange(120), np.arange(40, 90)))
    np.testing.assert_array_equal(filled.rotations[40:90], q[40:90])  # untouched


@pytest.mark.parametrize("length", [3, 9])
def test_short_gaps_follow_a_donor_where_it_helps(bodies, length):
    """Gaps shorter than the stretch donors are judged on had bridged their rotation in the
    world frame whatever a donor would do: on 131_02's clean bodies a donor fills them
    closer to the truth, and they take one."""
    q, p = bodies
    missing = planted(q.shape[0], q.shape[1], length, seed=10)
    filled = fill_gaps(q, p, missing, max_gap=length)
    alone = fill_gaps(q, p, missing, max_gap=length, donors=False)
    assert (filled.donor[0] >= 0).any()
    ours = errors(filled.rotations, filled.translations, q, p, missing)[0]
    assert ours < 0.95 * errors(alone.rotations, alone.translations, q, p, missing)[0]


def test_all_bodies_missing_on_the_same_frames_are_filled_without_donors(bodies):
    q, p = (x[:300] for x in bodies)
    missing = np.zeros(q.shape[:2], dtype=bool)
    missing[100:108] = True
    filled = fill_gaps(q, p, missing, max_gap=10)
    assert (filled.donor == -1).all() and not filled.missing.any()
    assert np.sqrt(np.mean(degrees_between(filled.rotations[100:108], q[100:108]) ** 2)) < 1.0


@pytest.mark.parametrize("gap", [slice(80, 130), slice(150, 200)], ids=["inside", "at_end"])
def test_a_follower_body_is_filled_from_its_donor(gap):
    """A body rigidly attached to another (a marker cluster on the forearm) is filled
    exactly by following it, however the two move, a gap at the clip's end too."""
    rng = np.random.default_rng(8)
    steps = quat.exp(rng.normal(size=(200, 3)) * 0.03)
    carrier = np.cumprod(np.ones(200))[:, None] * 0  # placeholder shape helper
    carrier_q = np.empty((200, 4))
    carrier_q[0] = [1, 0, 0, 0]
    for i in range(1, 200):
        carrier_q[i] = quat.multiply(carrier_q[i - 1], steps[i])
    carrier_p = np.cumsum(rng.normal(size=(200, 3)) * 0.05, axis=0) + carrier
    offset_q, offset_p = quat.normalize(np.array([0.9, 0.1, -0.3, 0.2])), np.array([0.1, 0.4, 0.0])
    q = np.stack([carrier_q, quat.multiply(carrier_q, offset_q)], axis=1)
    p = np.stack([carrier_p, carrier_p + quat.rotate(carrier_q, offset_p)], axis=1)
    missing = np.zeros((200, 2), dtype=bool)
    missing[gap, 1] = True
    filled = fill_gaps(q, p, missing, max_gap=60)
    assert filled.donor.tolist() == [[0], [0]]
    assert max_degrees(filled.rotations, quat.make_continuous(q)) < 1e-9
    np.testing.assert_allclose(filled.translations, p, atol=1e-12)


def test_a_squeezed_gap_keeps_its_donor_when_the_joints_other_gap_has_none():
    """A body rigidly attached to another, its gap squeezed between dropouts (no room for
    a trial) and its other gap of that length where the carrier is missing too (no donor
    there): the squeezed gap still follows its carrier, exactly. Judging it on the other
    gap's options had dropped the donor (a walk's shin 0 -> 1.05 units off)."""
    rng = np.random.default_rng(8)
    n = 400
    carrier_q = quat.make_continuous(
        quat.exp(np.cumsum(rng.normal(size=(n, 3)) * 0.03, axis=0) / 2.0)
    )
    carrier_p = np.cumsum(rng.normal(size=(n, 3)) * 0.05, axis=0)
    offset_q, offset_p = quat.normalize(np.array([0.9, 0.1, -0.3, 0.2])), np.array([0.1, 0.4, 0.0])
    q = np.stack([carrier_q, quat.multiply(carrier_q, offset_q)], axis=1)
    p = np.stack([carrier_p, carrier_p + quat.rotate(carrier_q, offset_p)], axis=1)
    missing = np.zeros((n, 2), dtype=bool)
    missing[100:120, 1] = True  # squeezed: the dropouts around it leave no room for a trial
    for first in (76, 90, 130, 150):
        missing[first : first + 4, 1] = True
    missing[300:320] = True  # the other gap of that length: the carrier is missing too
    filled = fill_gaps(q, p, missing, max_gap=30)
    gap = slice(100, 120)
    assert max_degrees(filled.rotations[gap, 1], quat.make_continuous(q)[gap, 1]) < 1e-6
    np.testing.assert_allclose(filled.translations[gap, 1], p[gap, 1], atol=1e-9)


@pytest.mark.parametrize(
    ("frames", "reach"), [(400, 12), (1000, 100)], ids=["beside_the_gap", "around_the_gap"]
)
def test_a_body_that_moves_with_the_gapped_one_only_near_the_gap_is_no_donor(frames, reach):
    """Body 1 moves exactly with body 0 for ``reach`` frames on each side of body 0's
    40-frame gap and does its own thing elsewhere, inside the gap too. Within 12 frames (the
    stretch donors are judged on) the fill, checked on gaps planted further out, does not
    follow it; within 100, where the planted trials lie too and cannot tell, body 1 does not
    move with body 0 over the whole clip (its steps relative to it are larger than body 0's
    own), and no donor is taken (a markerless dance's shoulder and elbow had followed the
    ankle and the knee)."""
    first = frames // 2 - 20
    gap = slice(first, first + 40)
    truth = smooth_synthetic(frames=frames, joints=2, seed=31)
    other = truth[:, 1].copy()
    near = slice(first - reach, first + 40 + reach)
    other[near] = truth[near, 0]  # with body 0 around the gap ...
    bump = quat.exp(np.sin(np.linspace(0.0, np.pi, 40))[:, None] * np.array([0.0, 0.6, 0.0]))
    other[gap] = quat.multiply(truth[gap, 0], bump)  # ... but not inside it
    q = quat.make_continuous(np.stack([truth[:, 0], other], axis=1))
    missing = np.zeros((frames, 2), dtype=bool)
    missing[gap, 0] = True
    filled = fill_gaps(q, np.zeros((frames, 2, 3)), missing, max_gap=60)
    assert (filled.donor == -1).all()
    assert max_degrees(filled.rotations[gap, 0], q[gap, 0]) < 10.0  # 69 following it


def test_a_gap_without_room_for_a_trial_is_filled_as_the_joints_other_gaps_are():
    """A gap squeezed between dropouts has no room for the gaps planted beside it that
    choose its bridge; it had taken the full edge velocities, which a noisy capture's
    edges make up. It now takes what fills the joint's other gaps best, and comes out as
    close to the truth as when the dropouts around it are not there (1 degree of
    wandering noise on 12 joints: 1.42 times further before)."""
    n, joints = 900, 12
    truth = quat.make_continuous(smooth_synthetic(frames=n, joints=joints, seed=4))
    rng = np.random.default_rng(4)
    white = rng.normal(size=(n + 4, joints, 3))
    wander = sum(white[i : i + n] for i in range(5)) / 5.0  # a 5-frame moving average
    q = quat.make_continuous(
        quat.multiply(truth, quat.exp(wander * np.radians(1.0) / 2.0 / wander.std()))
    )
    free = np.zeros((n, joints), dtype=bool)
    for first in (100, 300, 470, 700):
        free[first : first + 20] = True
    squeezed = free.copy()
    for first in (446, 460, 500, 520):  # no room left for a trial on either side of 470-490
        squeezed[first : first + 4] = True
    errors = []
    for missing in (free, squeezed):
        filled = fill_gaps(q, np.zeros((n, joints, 3)), missing, max_gap=30)
        angles = degrees_between(filled.rotations[470:490], truth[470:490])
        errors.append(np.sqrt(np.mean(angles**2)))
    assert errors[1] <= 1.1 * errors[0]


def test_a_body_whose_position_does_not_follow_another_is_filled_on_its_own():
    """The position's donor is checked on planted gaps as the rotation's is: body 1 sits at
    a fixed offset from body 0 for 12 frames on each side of body 1's gap (its relative
    position is the smoothest there), but inside the gap body 0 swerves and body 1 does
    not. Following body 0 would swerve with it; bridged on its own, body 1 stays close."""
    n = 400
    t = np.arange(n) / 120.0
    q = quat.make_continuous(smooth_synthetic(frames=n, joints=2, seed=5))
    q[:, 0] = [1.0, 0.0, 0.0, 0.0]  # body 0 translates only: offsets stay put in its frame
    p = np.zeros((n, 2, 3))
    p[:, 0] = np.stack([np.sin(2.1 * t), 0.3 * np.cos(1.3 * t), 0.2 * t], axis=1)
    p[:, 1] = np.stack([0.5 * np.cos(0.9 * t), np.sin(1.7 * t + 1.0), -0.1 * t], axis=1)
    near, inside = slice(168, 232), slice(180, 220)
    p[near, 1] = p[near, 0] + np.array([0.2, 0.1, 0.0])  # with body 0 around the gap ...
    swerve = np.sin(np.linspace(0.0, np.pi, 40))[:, None] * np.array([0.0, 0.0, 0.3])
    p[inside, 0] += swerve  # ... but not inside it
    missing = np.zeros((n, 2), dtype=bool)
    missing[inside, 1] = True
    filled = fill_gaps(q, p, missing, max_gap=60)
    assert filled.donor[1].tolist() == [-1]
    error = np.linalg.norm(filled.translations[inside, 1] - p[inside, 1], axis=-1).max()
    assert error < 0.1 * np.abs(swerve).max()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda q, p, m: (2.0 * q, p, m, 30), "rotations: not a unit quaternion"),
        (lambda q, p, m: (q, p[..., :2], m, 30), "translations: expected shape"),
        (
            lambda q, p, m: (q, p, m[:, :1], 30),
            r"missing: expected a bool array of shape \(80, 2\)",
        ),
        (lambda q, p, m: (q, p, m.astype(int), 30), "missing: expected a bool array"),
        (lambda q, p, m: (q, p, m, -1), "max_gap: expected a whole number >= 0"),
        (lambda q, p, m: (q, p, m, "x"), "max_gap: expected a number"),
    ],
)
def test_fill_gaps_refuses_bad_arguments_naming_them(change, message):
    """As every other filter does: quaternions of norm 2 had come out of norm 2, a mask of
    the wrong shape had failed deep in numpy, a negative max_gap filled nothing."""
    q = quat.make_continuous(smooth_synthetic(frames=80, joints=2, seed=2))
    missing = np.zeros((80, 2), dtype=bool)
    missing[30:40, 0] = True
    with pytest.raises((TypeError, ValueError), match=message):
        fill_gaps(*change(q, np.zeros((80, 2, 3)), missing))


@pytest.mark.parametrize("at_end", [True, False])
def test_a_gap_at_a_clip_end_follows_a_donor_only_where_that_holds_better(at_end):
    """A gap at a clip end is held, relative to a donor only where that holds the gaps
    planted beside it better than the edge sample: body 0 turns exactly with body 1 for
    the 20 frames beside body 1's gap (their relative rotation is the smoothest there),
    and swings away from it elsewhere, inside the gap too. Body 1 is held still, as it
    is; following body 0 would swing it by up to 40 degrees."""
    n, length = 400, 40
    t = np.arange(n) / 120.0
    own = quat.exp(0.002 * np.sin(37.0 * t)[:, None] * np.array([1.0, 0.0, 0.0]))
    swing = np.radians(20.0) * (1.0 - np.cos(2 * np.pi * 0.8 * t))  # 0 to 40 degrees
    edge = slice(n - length - 20, n - length) if at_end else slice(length, length + 20)
    swing[edge] = 0.0
    swing = np.convolve(np.pad(swing, 6, mode="edge"), np.ones(13) / 13, mode="valid")
    swing[edge] = 0.0
    body0 = quat.multiply(own, quat.exp(swing[:, None] / 2 * np.array([0.0, 0.0, 1.0])))
    q = quat.make_continuous(np.stack([body0, own], axis=1))
    missing = np.zeros((n, 2), dtype=bool)
    gap = slice(n - length, n) if at_end else slice(0, length)
    missing[gap, 1] = True
    filled = fill_gaps(q, np.zeros((n, 2, 3)), missing, max_gap=60)
    assert filled.donor[0].tolist() == [-1]
    assert max_degrees(filled.rotations[gap, 1], q[gap, 1]) < 1.0


@needs_realnoise
@pytest.mark.parametrize("task", ["dance", "exotic"])
def test_real_coordinates_that_do_not_move_together_are_no_donors(tmp_path, task):
    """theia-biorbd loses the trunk and arm coordinates while the legs are tracked: the
    fill follows no leg coordinate (it once bridged the trunk after the hip, the shoulder
    after the knee) and is no worse than a straight line against the truth."""
    estimate = REALNOISE / "estimates" / "theia-biorbd" / f"{task}_participant_01.csv"
    truth_file = REALNOISE / "truth" / f"{task}_participant_01.csv"
    header = estimate.read_text().splitlines()[0].split(",")
    x = np.genfromtxt(estimate, delimiter=",", skip_header=1)
    keep = [j for j in range(1, len(header)) if np.mean(~np.isnan(x[:, j])) > 0.5]
    angles = np.degrees(x[:, keep])
    missing = np.isnan(angles)
    held = np.where(missing, 0.0, angles)
    half = np.radians(held)[..., None] / 2.0 * np.array([0.0, 0.0, 1.0])  # about z
    q = quat.make_continuous(quat.exp(half), axis=0)
    filled = fill_gaps(q, np.zeros(q.shape[:-1] + (3,)), missing, max_gap=30)
    assert (filled.donor == -1).all()
    truth_header = truth_file.read_text().splitlines()[0].split(",")
    t = np.genfromtxt(truth_file, delimiter=",", skip_header=1)
    names = [header[j] for j in keep]
    y = np.stack([np.interp(x[:, 0], t[:, 0], t[:, truth_header.index(n)]) for n in names], 1)
    done = missing & ~filled.missing
    frames = np.arange(len(x))
    line = np.stack(
        [
            np.interp(frames, frames[~missing[:, c]], held[~missing[:, c], c])
            for c in range(len(keep))
        ],
        axis=1,
    )
    ours = np.degrees(2.0 * quat.log(filled.rotations)[..., 2])
    bias = np.nanmean(np.where(missing, np.nan, angles - np.degrees(y)), axis=0)

    def error(values):
        d = (values - np.degrees(y) - bias + 180.0) % 360.0 - 180.0
        return np.sqrt(np.mean(d[done] ** 2))

    assert error(ours) <= 1.01 * error(line)


def with_gap(clip: mc.Motion, joint: int, frames: slice) -> mc.Motion:
    missing = np.zeros((clip.n_frames, clip.n_joints), dtype=bool)
    missing[frames, joint] = True
    return clip.replace(missing=missing)


def test_step_fills_short_gaps_reports_them_and_leaves_long_ones():
    clip = mc.load(SAMPLE)
    wrist = clip.names.index("RightWrist")
    gappy = with_gap(clip, wrist, slice(100, 112))
    gappy.missing[200:290, wrist] = True  # 0.75 s: longer than the default 0.5 s
    out, logs = Pipeline.from_inline(["fill-gaps"]).run(gappy)
    note = logs[0].notes["RightWrist"]["fill-gaps"]
    assert note["gaps"] == 2 and note["longest"] == 90
    assert note["filled"] == [[100, 112]] and note["missing"] == [[200, 290]]
    assert out.missing is not None and out.missing[:, wrist].sum() == 90
    # within 4 degrees: beside the gap the donor the wrist would follow (RThumb) flips by
    # half turns, so the trials bridge it on its own (2.0 degrees with RThumb, 3.7 without)
    assert max_degrees(out.rotations[100:112, wrist], clip.rotations[100:112, wrist]) < 4.0
    with pytest.raises(MotionError, match=r"'RightWrist' is missing on frames 200-289"):
        format_bvh(out)
    filled_all, _ = Pipeline.from_inline(["fill-gaps:max_gap=1"]).run(gappy)
    assert filled_all.missing is None


def test_other_steps_filter_each_known_stretch_on_its_own():
    clip = mc.load(SAMPLE)
    wrist = clip.names.index("RightWrist")
    gappy = with_gap(clip, wrist, slice(100, 190))
    out, _ = Pipeline.from_inline(["lee-shin:k=3"]).run(gappy)
    mask, cut = masks.binomial(3), math.radians(90.0)  # (the step's default cut_deg)
    for rows in (slice(0, 100), slice(190, None)):
        expected = lee_shin(clip.rotations[rows, wrist], mask, 1, cut)
        assert max_degrees(out.rotations[rows, wrist], expected) < 1e-12
    np.testing.assert_array_equal(out.rotations[100:190, wrist], gappy.rotations[100:190, wrist])
    others = [j for j in range(clip.n_joints) if j != wrist]
    whole = lee_shin(clip.rotations[:, others], mask, 1, cut)
    assert max_degrees(out.rotations[:, others], whole) < 1e-12


def test_despike_notes_of_several_stretches_are_joined_in_clip_frames():
    clip = mc.load(SAMPLE.with_name("131_02_noisy.bvh"))
    thumb = clip.names.index("RThumb")
    gappy = with_gap(clip, thumb, slice(150, 160))
    _, logs = Pipeline.from_inline(["despike"]).run(gappy)
    _, whole_logs = Pipeline.from_inline(["despike"]).run(clip)
    runs = logs[0].notes["RThumb"]["despike"]["unflipped"]
    assert runs and all(b <= 150 or a >= 160 for a, b in runs)
    whole = whole_logs[0].notes["RThumb"]["despike"]["unflipped"]
    assert [r for r in whole if r[1] <= 150 or r[0] >= 160] == runs


def rigid_csv(path, clip: mc.Motion, blanks: dict[str, slice]) -> None:
    """A rigid-body CSV of some of ``clip``'s joints in world space, six decimals, with the
    bodies in ``blanks`` blank on those frames (a tracker losing them)."""
    positions, rotations = kinematics.forward(clip)
    names = ["Head", "LeftWrist", "RightWrist", "LeftAnkle", "RightAnkle"]
    columns = [f"{n}.{s}" for n in names for s in ("px", "py", "pz", "qw", "qx", "qy", "qz")]
    rows = ["time," + ",".join(columns)]
    for f in range(clip.n_frames):
        cells = [f"{f * clip.frame_time:.6f}"]
        for name in names:
            j = clip.names.index(name)
            gone = name in blanks and f in range(clip.n_frames)[blanks[name]]
            values = np.concatenate([positions[f, j], rotations[f, j]])
            cells += [""] * 7 if gone else [f"{v:.6f}" for v in values]
        rows.append(",".join(cells))
    path.write_text("\n".join(rows) + "\n")


def test_default_clean_fills_short_dropouts_and_keeps_long_ones_blank(tmp_path, capsys):
    source, out, report = tmp_path / "t.csv", tmp_path / "c.csv", tmp_path / "r.json"
    rigid_csv(
        source, mc.load(SAMPLE), {"LeftWrist": slice(100, 112), "RightWrist": slice(150, 250)}
    )
    code, stdout, err = run_cli(capsys, "clean", source, "-o", out, "--report", report)
    assert code == 0, err
    assert "LeftWrist: 1 gap, longest 12 frames; filled 100-111" in stdout
    assert "RightWrist: 1 gap, longest 100 frames; left missing 150-249" in stdout
    notes = json.loads(report.read_text())["joints"]
    assert notes["LeftWrist"]["fill-gaps"]["filled"] == [[100, 112]]
    assert notes["RightWrist"]["fill-gaps"]["missing"] == [[150, 250]]
    cleaned = mc.load(out)
    assert cleaned.missing is not None
    np.testing.assert_array_equal(
        np.flatnonzero(cleaned.missing.any(axis=0)), [cleaned.names.index("RightWrist")]
    )
    lines = out.read_text().splitlines()
    right = 1 + 7 * 2  # the RightWrist columns
    assert all(lines[1 + f].split(",")[right : right + 7] == [""] * 7 for f in range(150, 250))
    # The blank stretch counts as no motion: no spike from its held placeholder.
    whole, whole_report = tmp_path / "whole.csv", tmp_path / "whole.json"
    rigid_csv(whole, mc.load(SAMPLE), {})
    code, _, err = run_cli(
        capsys, "clean", whole, "-o", tmp_path / "w.csv", "--report", whole_report
    )
    full = json.loads(whole_report.read_text())["joints"]["RightWrist"]["angular_accel_rms"]
    accel = notes["RightWrist"]["angular_accel_rms"]["before"]
    assert code == 0 and accel < 1.5 * full["before"]


def test_default_clean_of_the_motive_sample_fills_the_occluded_hand(tmp_path, capsys):
    source, out = tmp_path / "take.csv", tmp_path / "clean.csv"
    source.write_bytes((ROOT / "sample_data" / "131_02_motive.csv").read_bytes())
    code, stdout, err = run_cli(capsys, "clean", source, "-o", out)
    assert code == 0, err
    assert "filled 40-47" in stdout
    assert out.read_bytes().splitlines()[:7] == source.read_bytes().splitlines()[:7]
    assert mc.load(out).missing is None


def test_the_page_breaks_a_missing_bodys_track_and_draws_bodies_without_bones(tmp_path):
    from motionclean.run.jobs import clean_clip, render_report

    source = tmp_path / "t.csv"
    rigid_csv(source, mc.load(SAMPLE), {"RightWrist": slice(150, 250)})
    result = clean_clip(source, None, Pipeline.default())
    page = render_report(result.report, tmp_path / "r.html", result.series).decode()
    card = page.split("<h3>RightWrist</h3>")[1].split("</section>")[0]
    assert card.count('data-series="before"') == 2 * 2  # two views, a break in each
    assert card.count('data-series="after"') == 2 * 2  # the long gap stays missing
    left = page.split("<h3>LeftWrist</h3>")[1].split("</section>")[0]
    assert left.count('data-series="before"') == 2
    player = page.split('id="mc-player"')[1].split("</svg>")[0]
    assert player.count('class="joint"') == 2 * 5 and 'class="bone"' not in player


def test_a_motive_dropout_longer_than_max_gap_stays_blank(tmp_path, capsys):
    source, out = tmp_path / "take.csv", tmp_path / "clean.csv"
    source.write_bytes((ROOT / "sample_data" / "131_02_motive.csv").read_bytes())
    code, stdout, err = run_cli(capsys, "clean", source, "-o", out, "-f", "fill-gaps:max_gap=0.05")
    assert code == 0, err
    assert "left missing 40-47 (longer than max_gap)" in stdout
    before, after = mc.load(source), mc.load(out)
    np.testing.assert_array_equal(after.missing, before.missing)
    assert out.read_bytes().splitlines()[:7] == source.read_bytes().splitlines()[:7]


def test_the_player_hides_a_body_while_it_is_missing(tmp_path):
    from motionclean.run.jobs import clean_clip, render_report

    source = tmp_path / "t.csv"
    rigid_csv(source, mc.load(SAMPLE), {"Head": slice(0, 40)})  # from the first frame on
    steps = Pipeline.from_inline(["fill-gaps:max_gap=0.1"])  # 40 frames stay missing
    result = clean_clip(source, None, steps)
    page = render_report(result.report, tmp_path / "r.html", result.series).decode()
    player = page.split('id="mc-player"')[1].split("</svg>")[0]
    assert player.count('class="joint"') == 2 * 4  # frame 0 without the head
    data = json.loads(page.split('id="mc-world">')[1].split("</script>")[0])
    head = result.before.names.index("Head")
    assert all(head in data["hidden"][0][f] for f in range(40))
    assert all(head not in data["hidden"][0][f] for f in range(40, 300))


def test_info_lists_dropouts_and_leaves_their_placeholders_out_of_the_figures(tmp_path, capsys):
    source = tmp_path / "t.csv"
    rigid_csv(source, mc.load(SAMPLE), {"RightWrist": slice(150, 250)})
    code, stdout, err = run_cli(capsys, "info", source)
    assert code == 0, err
    assert "dropouts: RightWrist missing on 100 frames: 150-249" in stdout
    row = next(line for line in stdout.splitlines() if line.strip().startswith("RightWrist"))
    assert int(row.split()[-3]) not in (150, 250)  # the largest step is no placeholder jump


def test_info_estimates_noise_across_a_dropout_as_auto_does(tmp_path, capsys):
    source, report = ROOT / "sample_data" / "131_02_motive.csv", tmp_path / "r.json"
    code, stdout, err = run_cli(capsys, "info", source)
    assert code == 0, err
    row = next(line for line in stdout.splitlines() if line.strip().startswith("hand_l"))
    out = tmp_path / "out.csv"
    code, _, err = run_cli(capsys, "clean", source, "-o", out, "-f", "auto", "--report", report)
    assert code == 0, err
    noise = json.loads(report.read_text())["joints"]["hand_l"]["auto"]["noise"]
    assert float(row.split()[-1]) == pytest.approx(noise, abs=0.005)  # info rounds to 0.01


def test_world_csv_leaves_a_missing_body_blank(tmp_path, capsys):
    source, world = tmp_path / "t.csv", tmp_path / "world.csv"
    rigid_csv(source, mc.load(SAMPLE), {"LeftWrist": slice(10, 20)})
    code, _, err = run_cli(capsys, "convert", source, world, "--world")
    assert code == 0, err
    rows = world.read_text().splitlines()
    column = rows[0].split(",").index("LeftWrist.x")
    assert all(rows[1 + f].split(",")[column : column + 3] == ["", "", ""] for f in range(10, 20))
    assert all(rows[1 + f].split(",")[column] != "" for f in (9, 20))


@pytest.mark.parametrize("command", ["stitch", "blend"])
def test_two_clip_commands_refuse_dropouts(tmp_path, capsys, command):
    source = tmp_path / "t.csv"
    rigid_csv(source, mc.load(SAMPLE), {"LeftWrist": slice(10, 20)})
    out = tmp_path / "out.csv"
    code, _, err = run_cli(capsys, command, source, source, "-o", out)
    assert code == 1 and "has missing samples (tracker dropouts): fill them first" in err
    assert not out.exists()


def test_a_squeezed_gap_too_long_for_the_spline_is_not_given_the_spline():
    """Gaps are pooled by octave of lengths: a squeezed 40-frame gap had been given the
    smoothing spline that won on its joint's 32-frame gap, which it cannot take (the
    spline bridges up to SPLINE_MAX_GAP frames): it fell back on the full edge
    velocities. A 20-frame squeezed gap of the same octave as 16-31 frames may take it."""
    kinds = [(w, smooth) for w in VELOCITY_WEIGHTS for smooth in (False, True)]
    options = [(w, smooth) for w, smooth in (*kinds, (SPLINE, False))]
    spline = np.array([w == SPLINE for w, _ in options])
    gaps = Gaps(np.zeros(4, int), np.array([100, 300, 500, 700]), np.array([132, 340, 516, 720]))
    error = np.full((2, len(options), 4), np.inf)
    error[:, :, 0] = np.where(spline, 0.3, 1.0)  # the spline best on the tried 32-frame gap
    error[:, :, 2] = np.where(spline, 0.3, 1.0)  # ... and on the tried 16-frame gap
    pooled = _pooled_for_untried(
        error, gaps, np.ones(len(options), bool), np.full((2, 4), -1), spline
    )
    assert np.isinf(pooled[:, spline, 1]).all() and np.isfinite(pooled[:, ~spline, 1]).all()
    assert np.isfinite(pooled[:, spline, 3]).all()  # 20 frames, pooled from the 16
