"""Flip and spike repair: planted defects on a real clip at 120 and 30 fps, genuine fast
motion kept at any frame rate, corpus limits."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import (
    CMU_01_01_JITTER,
    CMU_01_01_START,
    CORPUS_CLIPS,
    ROOT,
    SAMPLE,
    degrees_between,
    needs_corpus,
)

import motionclean as mc
from motionclean.core import quat
from motionclean.filters.despike import (
    DespikeReport,
    _lagrange,
    despike,
    despike_positions,
    despike_positions_with_report,
    despike_with_report,
)

# Joints of the sample clip with real motion and no defect (RThumb has real flips).
CLEAN = [
    "Hips",
    "LeftHip",
    "LeftKnee",
    "RightAnkle",
    "Chest",
    "Head",
    "LeftShoulder",
    "RightElbow",
    "RightWrist",
]


@pytest.fixture(scope="module")
def clip():
    return mc.load(SAMPLE)


@pytest.fixture(scope="module")
def corpus():
    """The corpus clips by file name, loaded once."""
    return {path.name: mc.load(path) for path in CORPUS_CLIPS}


def clean_columns(m, every=1):
    """The CLEAN joints' rotations, keeping every ``every``-th frame (sign-continuous)."""
    cols = [m.names.index(n) for n in CLEAN]
    return quat.make_continuous(m.rotations[::every, cols], axis=0), cols


def random_axes(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# Planted defects per column c (the last column stays clean): (start, length) pairs at
# 120 fps, and on the same clip kept at every 4th frame (30 fps, 75 frames).
FLIPS = {
    1: lambda c: ((40 + 23 * c, 1 + c % 4), (200 + 7 * c, 4 - c % 4)),
    4: lambda c: ((5 + 3 * c, 1 + c % 4), (40 + 3 * c, 4 - c % 4)),
}
# Spikes last at most max_spike_s (70 ms): up to 4 frames at 120 fps, 2 at 30 fps. At
# 30 fps a joint's own steps reach 30 degrees, so the kicks there are larger.
SPIKES = {
    1: (lambda c: ((30 + 17 * c, 1 + c % 4), (170 + 11 * c, 1 + (c + 2) % 4)), 40.0),
    4: (lambda c: ((6 + 3 * c, 1 + c % 2), (40 + 3 * c, 2 - c % 2)), 60.0),
}


@pytest.mark.parametrize("every", [1, 4], ids=["120fps", "30fps"])
@pytest.mark.parametrize("side", ["parent", "own"])
def test_planted_flips_are_undone_and_nothing_else_moves(clip, side, every):
    truth, _ = clean_columns(clip, every)
    rng = np.random.default_rng(7)
    q = truth.copy()
    planted = np.zeros(q.shape[:2], dtype=bool)
    half_turns = quat.from_axis_angle(random_axes(rng, q.shape[1]), np.pi)
    for c in range(q.shape[1] - 1):  # the last column stays clean
        for start, length in FLIPS[every](c):
            planted[start : start + length, c] = True
    f = np.broadcast_to(half_turns, q.shape)
    flipped = quat.multiply(f, q) if side == "parent" else quat.multiply(q, f)
    q = np.where(planted[..., None], flipped, q)

    out, report = despike_with_report(q, clip.frame_time * every)

    np.testing.assert_array_equal(report.unflipped, planted)
    assert not report.interpolated.any()
    # The half-turn axis is estimated from the flip steps, which also hold a frame of
    # genuine motion: four times more of it at 30 fps.
    assert degrees_between(out, truth).max() < 3.0 * every**0.5
    np.testing.assert_array_equal(out[:, -1], q[:, -1])  # bit for bit


@pytest.mark.parametrize("every", [1, 4], ids=["120fps", "30fps"])
def test_planted_spikes_are_interpolated_close_to_the_truth(clip, every):
    truth, _ = clean_columns(clip, every)
    places, smallest = SPIKES[every]
    rng = np.random.default_rng(11)
    q = truth.copy()
    planted = np.zeros(q.shape[:2], dtype=bool)
    for c in range(q.shape[1] - 1):
        for start, length in places(c):
            rows = slice(start, start + length)
            kick = quat.from_axis_angle(
                random_axes(rng, length), np.deg2rad(rng.uniform(smallest, 120.0, size=length))
            )
            q[rows, c] = quat.multiply(q[rows, c], kick)
            planted[rows, c] = True

    out, report = despike_with_report(q, clip.frame_time * every)

    np.testing.assert_array_equal(report.interpolated, planted)
    assert not report.unflipped.any()
    assert degrees_between(out, truth).max() < 3.0
    np.testing.assert_array_equal(out[:, -1], q[:, -1])
    assert report.counts().tolist() == planted.sum(axis=0).tolist()


def kicked(fps, length, start):
    """A 30 deg/s turn for 3 s, and the same with ``length`` frames kicked by 28 degrees
    from ``start`` on, as ``(F, 1, 4)``."""
    omega = np.deg2rad(30.0) / fps * np.array([0.0, 0.6, 0.8])
    base = quat.exp(0.5 * np.arange(3 * fps)[:, None] * omega)[:, None]
    q = base.copy()
    rows = slice(start, start + length)
    q[rows] = quat.multiply(q[rows], quat.from_axis_angle([1.0, 0.0, 0.0], np.deg2rad(28.0)))
    return base, q


@pytest.mark.parametrize("fps, longest", [(120, 8), (60, 4), (30, 2), (24, 1)])
def test_the_longest_spike_is_a_duration(fps, longest):
    """``max_spike_s`` (70 ms) is 8 frames at 120 fps and 2 at 30 fps: a 28 degree kick
    that long is a spike, one frame longer it is left alone (its steps stay under the
    cap) unless ``max_spike_s`` allows it; ``max_run`` can only shorten the limit."""
    start, dt = fps, 1 / fps
    base, q = kicked(fps, longest, start)
    out, report = despike_with_report(q, dt)
    assert report.runs(0) == [(start, start + longest)]
    assert degrees_between(out, base).max() < 1e-9  # constant angular velocity, rebuilt
    if longest > 1:
        assert not despike_with_report(q, dt, max_run=longest - 1)[1].repaired.any()

    _, q = kicked(fps, longest + 1, start)
    out, report = despike_with_report(q, dt)
    assert not report.repaired.any()
    np.testing.assert_array_equal(out, q)
    report = despike_with_report(q, dt, max_spike_s=(longest + 1) * dt)[1]
    assert report.runs(0) == [(start, start + longest + 1)]


def bump(fps, sigma_s):
    """70 degrees out and back as a Gaussian of ``sigma_s`` seconds, on a slow swing."""
    t = np.arange(-fps, fps) / fps
    angle = np.deg2rad(70.0) * np.exp(-0.5 * (t / sigma_s) ** 2) + np.deg2rad(20.0) * np.sin(
        np.pi * t
    )
    return quat.from_axis_angle([0.6, 0.0, 0.8], angle)[:, None]


@pytest.mark.parametrize(
    "fps, sigma_ms",
    [(120, 20), (120, 30), (60, 20), (60, 30), (30, 30), (30, 40), (24, 30), (24, 40)],
)
def test_fast_genuine_excursion_is_left_untouched_at_any_rate(fps, sigma_ms):
    """A joint flexing 70 degrees out and back within about 100 ms (peak 1000-2100 deg/s,
    like a toe at push-off) is motion, not a spike: at 30 fps it spans 3 to 5 frames, with
    steps of up to 35 degrees."""
    q = bump(fps, sigma_ms / 1000)
    out, report = despike_with_report(q, 1 / fps)
    assert not report.repaired.any()
    np.testing.assert_array_equal(out, q)


def test_the_trend_and_the_duration_tell_motion_from_spikes():
    """What keeps the excursions above: at 120 fps the local trend (without it the jump
    tests alone take the 20 ms bump for a 7-frame spike), at 30 fps also the duration
    (the 30 ms bump would be a 3-frame spike, 100 ms)."""
    report = despike_with_report(bump(120, 0.02), 1 / 120, trend_ratio=0.0)[1]
    assert report.counts()[0] == 7
    q = bump(30, 0.03)
    assert despike_with_report(q, 1 / 30, trend_ratio=0.0, max_spike_s=0.1)[1].counts()[0] == 3
    assert not despike_with_report(q, 1 / 30, trend_ratio=0.0)[1].repaired.any()


def test_without_unflip_short_flips_are_interpolated(clip):
    truth, _ = clean_columns(clip)
    q = truth.copy()
    half_turn = quat.from_axis_angle([0.0, 0.8, 0.6], np.pi)
    q[100:103] = quat.multiply(half_turn, q[100:103])
    out, report = despike_with_report(q, clip.frame_time, unflip=False)
    assert not report.unflipped.any()
    assert report.runs(0, "interpolated") == [(100, 103)]
    assert degrees_between(out, truth).max() < 3.0


def test_steps_above_the_cap_are_spread_until_under_it():
    """A ragged transition: 150 degrees in 3 frames that never comes back."""
    angle = np.deg2rad(
        np.concatenate(
            [
                np.arange(100) * 0.5,
                49.5 + np.array([40.0, 95.0, 150.0]),
                199.5 + np.arange(97) * 0.5,
            ]
        )
    )
    q = quat.from_axis_angle([1.0, 0.0, 0.0], angle)[:, None]
    out, report = despike_with_report(q, 1 / 120, max_deg_per_s=2400.0)
    steps = degrees_between(out[:-1], out[1:])
    assert steps.max() <= 20.0 + 1e-9 < report.max_step_before[0]
    changed = np.flatnonzero(degrees_between(out, q)[:, 0] > 0)
    assert report.runs(0) == [(changed[0], changed[-1] + 1)]
    assert not report.unflipped.any()


def test_a_step_over_the_cap_that_never_comes_back_is_told_capped_not_a_spike():
    """An Xsens toe snapping flat at 240 fps (0, 3.8, 8.9, 31.4, 46.0, 53.5 degrees: one
    step of 22.6 degrees, 5,420 deg/s) had been counted a spike: the cap interpolates it as
    before, and the report tells its run apart as ``capped``; a spike kicked into the
    column beside it (away for 2 frames and back) stays a spike."""
    fps = 240
    base, kicked_q = kicked(fps, 2, 300)  # (a slow turn, and the same with a spike)
    snap = np.zeros(len(base))
    snap[401:] = 53.5
    snap[396:401] = [3.8, 8.9, 31.4, 46.0, 53.5]
    toe = quat.multiply(base[:, 0], quat.from_axis_angle([1.0, 0.0, 0.0], np.deg2rad(snap)))
    q = np.concatenate([toe[:, None], kicked_q], axis=1)
    out, report = despike_with_report(q, 1 / fps)
    np.testing.assert_array_equal(out, despike(q, 1 / fps))  # the same repair
    (capped,) = report.runs(0, "capped")
    assert report.runs(0) == [capped] and capped[0] <= 398 < 399 <= capped[1]
    assert report.runs(1, "interpolated") == [(300, 302)] and not report.capped[:, 1].any()
    assert not (report.capped & ~report.interpolated).any()
    assert report.summary(0)["capped"] == [list(capped)] == report.summary(0)["interpolated"]
    assert report.summary(1)["capped"] == []


def test_a_jump_above_the_cap_at_a_clip_end_repairs_the_end_frames_alone():
    """CMU 01_01's reference frame 0 steps by 41-136 degrees into frame 1 on five joints,
    above the cap (30 degrees a frame at 120 fps): frame 0 is held at frame 1, which is
    real motion (its step to frame 2 is 0.08-0.45 degrees) and stays as read; the same
    at the clip's last frames, reversed, and for a two-frame piece."""
    clip = mc.load(CMU_01_01_START)
    q = clip.rotations
    out, report = despike_with_report(q, clip.frame_time)
    repaired = np.flatnonzero(report.counts())
    assert [clip.names[j] for j in repaired] == [
        "LeftArm",
        "LeftForeArm",
        "LeftFingerBase",
        "RightArm",
        "RThumb",
    ]
    assert all(report.runs(j) == [(0, 1)] for j in repaired)
    np.testing.assert_array_equal(out[1:], q[1:])
    np.testing.assert_array_equal(out[0, repaired], q[1, repaired])
    last = len(q) - 1
    back, report = despike_with_report(q[::-1], clip.frame_time)
    assert all(report.runs(j) == [(last, last + 1)] for j in repaired)
    np.testing.assert_array_equal(back[:-1], q[::-1][:-1])
    twice = np.concatenate([q[:1], q])  # the reference pose held two frames
    out, report = despike_with_report(twice, clip.frame_time)
    assert all(report.runs(j) == [(0, 2)] for j in repaired)
    np.testing.assert_array_equal(out[2:], q[1:])


def test_a_glitch_that_starts_a_few_frames_into_the_clip_is_not_copied_onto_them():
    """A joint turned 90 degrees on frames 3-39 (a marker swap): the jump at frame 3 lies
    within a spike's length of the clip's start, but frames 0-2 move with the motion (no
    reference pose), so they are not held at the glitch (they had been turned 90 degrees
    with it); the step is repaired as elsewhere, by a gap that widens until its steps fit
    under the cap. A pose held on frames 0-2 is held at frame 3 whatever else the column
    does later (the same turn on frames 50-60, an offset from frame 150 on)."""
    clip = mc.load(SAMPLE)
    joint = clip.names.index("LeftElbow")
    q = clip.rotations.copy()
    turn = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.pi / 2)
    q[3:40, joint] = quat.multiply(q[3:40, joint], turn)
    out, _ = despike_with_report(q, clip.frame_time)
    np.testing.assert_array_equal(out[0, joint], q[0, joint])
    moved = np.degrees(quat.angle_between(out[:3, joint], clip.rotations[:3, joint]))
    assert moved.max() < 45.0
    offset = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi / 3)
    for later in ((50, 61), (150, None)):
        q = clip.rotations.copy()
        q[:3, joint] = quat.multiply(q[0, joint], turn)  # a reference pose, held
        q[later[0] : later[1], joint] = quat.multiply(q[later[0] : later[1], joint], offset)
        out, report = despike_with_report(q, clip.frame_time)
        np.testing.assert_array_equal(out[:3, joint], np.repeat(q[3:4, joint], 3, axis=0))
        np.testing.assert_array_equal(out[3, joint], q[3, joint])


def test_spikes_that_chain_on_beyond_the_longest_spike_are_jitter():
    """CMU 01_01's left hand jitters by +-5 degrees about its X axis (steps of 5-14 degrees)
    over frames 62-91 of this cut. Frames 62-68, 69-71 and 72-77 each pass as a spike, each
    read against neighbours that the next one replaces: together 16 frames, longer than a
    spike (8 at 120 fps), and left as read (they were rebuilt as a ramp from -7 to +8
    degrees). The 4-frame spike at 82-85, between good frames, is still repaired."""
    clip = mc.load(CMU_01_01_JITTER)
    hand = clip.names.index("LeftHand")
    out, report = despike_with_report(clip.rotations, clip.frame_time)
    assert report.runs(hand) == [(82, 86)]
    np.testing.assert_array_equal(out[:82, hand], clip.rotations[:82, hand])


def test_constant_angular_velocity_is_rebuilt_exactly_across_a_spike():
    n = 60
    omega = np.deg2rad(4.0) * np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    q = quat.multiply(
        quat.from_euler([10.0, -20.0, 30.0], "ZXY"), quat.exp(0.5 * np.arange(n)[:, None] * omega)
    )
    spiked = q.copy()
    spiked[30:33] = quat.multiply(spiked[30:33], quat.from_axis_angle([1.0, 0.0, 0.0], 1.2))
    for method in ("cubic", "slerp"):
        out = despike(spiked[:, None], 1 / 120, method=method)[:, 0]
        assert degrees_between(out, q).max() < 1e-9


def test_cubic_weights_are_the_four_point_scheme():
    """003 Eq. 15: halfway between uniform knots the weights are (-1, 9, 9, -1) / 16."""
    w = _lagrange(np.array([0.5]), np.array([0]), np.array([1]))
    np.testing.assert_allclose(np.concatenate(w), np.array([-1, 9, 9, -1]) / 16, atol=1e-15)
    # Non-uniform knots (a gap): the weights still reproduce cubic polynomials.
    t, left, right = np.array([3, 4, 5]), np.array([2, 2, 2]), np.array([6, 6, 6])
    c = _lagrange(t, left, right)
    knots = [left - 1, left, right, right + 1]
    for power in range(4):
        np.testing.assert_allclose(
            sum(cj * k**power for cj, k in zip(c, knots, strict=True)), t**power, rtol=1e-12
        )


@pytest.mark.parametrize("profile", ["constant", "smooth"])
def test_fast_smooth_turn_is_left_untouched(clip, profile):
    """180 degrees in 20 frames at 120 fps (1080 deg/s), on top of real motion."""
    base, _ = clean_columns(clip)
    s = np.clip((np.arange(base.shape[0]) - 100) / 20.0, 0.0, 1.0)
    if profile == "smooth":
        s = s * s * (3 - 2 * s)  # peak 1620 deg/s
    turn = quat.from_axis_angle([0.0, 0.6, 0.8], np.pi * s)[:, None]
    q = quat.make_continuous(quat.multiply(turn, base))
    out, report = despike_with_report(q, 1 / 120)
    assert not report.repaired.any()
    np.testing.assert_array_equal(out, q)


def test_fast_oscillation_is_left_untouched():
    """+-60 degrees at 2.5 Hz (peak 940 deg/s) goes out and back, smoothly: not a spike."""
    t = np.arange(240) / 120
    angle = np.deg2rad(60) * np.sin(2 * np.pi * 2.5 * t)
    q = quat.from_axis_angle([0.0, 0.0, 1.0], angle)[:, None]
    out, report = despike_with_report(q, 1 / 120)
    assert not report.repaired.any()
    np.testing.assert_array_equal(out, q)


def test_sign_and_layout_do_not_matter(clip):
    q = clip.rotations
    out, report = despike_with_report(q, clip.frame_time)
    rng = np.random.default_rng(3)
    signs = rng.choice([-1.0, 1.0], size=q.shape[:2])[..., None]
    out_signed = despike(q * signs, clip.frame_time)
    assert degrees_between(out_signed, out).max() < 1e-9
    clean = ~report.repaired.any(axis=0)
    np.testing.assert_array_equal(out_signed[:, clean], (q * signs)[:, clean])
    # Columns are independent and trailing axes are only a layout.
    pairs = q[:, :30].reshape(q.shape[0], 15, 2, 4)
    np.testing.assert_array_equal(
        despike(pairs, clip.frame_time).reshape(q.shape[0], 30, 4), out[:, :30]
    )
    thumb = clip.names.index("RThumb")
    np.testing.assert_array_equal(despike(q[:, [thumb]], clip.frame_time)[:, 0], out[:, thumb])


def test_report_runs_and_counts():
    mask = np.zeros((10, 2, 3), dtype=bool)
    mask[2:4, 1, 2] = mask[7:10, 1, 2] = True
    zero = np.zeros((2, 3))
    report = DespikeReport(mask, np.zeros_like(mask), zero, zero, zero)
    assert report.runs((1, 2)) == [(2, 4), (7, 10)]
    assert report.runs((0, 0), "interpolated") == []
    assert report.counts("unflipped")[1, 2] == 5
    assert report.counts().sum() == 5
    with pytest.raises(ValueError, match="kind"):
        report.counts("smoothed")


def test_report_summary_is_json_ready(clip):
    import json

    thumb = clip.names.index("RThumb")
    report = despike_with_report(clip.rotations, clip.frame_time)[1]
    summary = report.summary(thumb)
    assert json.loads(json.dumps(summary)) == summary
    assert summary["frames_repaired"] == sum(b - a for a, b in summary["unflipped"])
    assert summary["max_step"]["before"] > 179.0 > 15.0 > summary["max_step"]["after"]


def test_sample_thumb_flips_are_unflipped(clip):
    """The real RThumb half-turn runs of the sample: each run starts and ends with a
    one-frame step above 150 degrees (the flip threshold), and nothing else is that fast."""
    thumb = clip.names.index("RThumb")
    steps = degrees_between(clip.rotations[:-1, thumb], clip.rotations[1:, thumb])
    edges = (np.flatnonzero(steps > 150.0) + 1).tolist()  # frames the flip steps end at
    assert len(edges) >= 6 and len(edges) % 2 == 0
    expected = list(zip(edges[0::2], edges[1::2], strict=True))
    out, report = despike_with_report(clip.rotations, clip.frame_time)
    runs = report.runs(thumb, "unflipped")
    assert runs == expected
    assert report.runs(thumb) == expected  # un-flipped, nothing interpolated
    # un-flipping turns each frame of a run by a half turn, and no other frame
    turned = np.flatnonzero(degrees_between(out[:, thumb], clip.rotations[:, thumb]) > 90.0)
    assert turned.tolist() == [f for start, stop in expected for f in range(start, stop)]
    assert report.max_step_before[thumb] > 179.0
    assert report.max_step_after[thumb] < 15.0
    others = np.arange(len(clip.names)) != thumb
    np.testing.assert_array_equal(out[:, others], clip.rotations[:, others])


def test_a_cut_between_takes_is_no_flip(clip):
    """Two takes joined end to end (a game engine's FBX of several clips): the second
    starts with the root turned 170 degrees and most joints elsewhere. No single joint's
    half-turn there is a flip (the root's had been \"un-flipped\" to the end of the clip);
    the cut is reported, and the thumb's real flips in either take are still undone."""
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(170.0))
    second = clip.rotations[225:].copy()
    second[:, 0] = quat.multiply(turn, second[:, 0])
    joined = np.concatenate([clip.rotations[:150], second])
    out, report = despike_with_report(joined, clip.frame_time)
    assert report.cuts.tolist() == [150]
    assert not report.repaired[:, 0].any()
    np.testing.assert_array_equal(out[:, 0], joined[:, 0])
    thumb = clip.names.index("RThumb")
    alone, first = despike_with_report(clip.rotations[:150], clip.frame_time)
    assert report.runs(thumb, "unflipped")[:2] == first.runs(thumb, "unflipped")
    assert len(report.runs(thumb, "unflipped")) > 2  # and those of the second take
    one = despike_with_report(joined[:, [0]], clip.frame_time)[1]  # a joint alone: no cut
    assert one.cuts.size == 0


def test_planted_position_jumps_are_repaired(clip):
    p = clip.translations.copy()  # root moves, other joints have no position channels
    truth = p.copy()
    p[100:103, 0] += [20.0, -5.0, 3.0]  # a marker swap: the root jumps away and back
    p[200, 0] -= [0.0, 8.0, 0.0]
    out, report = despike_positions_with_report(p, clip.frame_time)
    assert report.runs(0) == [(100, 103), (200, 201)]
    assert np.linalg.norm(out - truth, axis=-1).max() < 0.05
    np.testing.assert_array_equal(out[:, 1:], p[:, 1:])
    np.testing.assert_array_equal(despike_positions(truth, clip.frame_time), truth)


def test_position_cap_spreads_a_permanent_jump():
    p = np.zeros((50, 1, 3))
    p[:, 0, 0] = np.arange(50) * 0.1
    p[25:, 0, 0] += 3.0  # a step that never comes back: only the cap catches it
    assert not despike_positions_with_report(p, 0.01)[1].repaired.any()
    out, report = despike_positions_with_report(p, 0.01, max_units_per_s=100.0)
    assert np.abs(np.diff(out[:, 0, 0])).max() <= 1.0 + 1e-12
    assert report.max_step_after[0] <= 1.0 + 1e-12 < report.max_step_before[0]


@pytest.mark.parametrize(
    "bad",
    [
        dict(threshold=-1.0),
        dict(max_deg_per_s=0.0),
        dict(min_deg_per_s=5000.0),
        dict(max_run=0),
        dict(max_run=2.5),
        dict(flip_deg=80.0),
        dict(method="linear"),
        dict(max_spike_s=0.0),
        dict(max_spike_s=np.nan),
        dict(trend_ratio=-1.0),
    ],
)
def test_invalid_parameters_are_refused(bad):
    with pytest.raises(ValueError):
        despike(quat.identity((5, 1)), 1 / 120, **bad)


def test_invalid_inputs_are_refused():
    with pytest.raises(ValueError, match="frame_time"):
        despike(quat.identity((5, 1)), 0.0)
    with pytest.raises(ValueError, match="shape"):
        despike(np.zeros((5, 3)), 1 / 120)
    with pytest.raises(ValueError, match="method"):
        despike_positions(np.zeros((5, 1, 3)), 1 / 120, method="slerp")


def test_short_clips():
    for n in (0, 1, 2):
        q = quat.identity((n, 2))
        np.testing.assert_array_equal(despike(q, 1 / 120), q)


@needs_corpus
@pytest.mark.parametrize("name", ["131_01.bvh", "131_02.bvh", "131_03.bvh"])
def test_corpus_steps_are_bounded_and_clean_joints_untouched(corpus, name):
    """After despike no joint turns more than 30 degrees in a frame. The corpus defects
    are the RThumb flips (corpus README) and the RightWrist steps of up to 55 degrees
    per frame in 131_01 and 131_03; every other joint comes back bit for bit."""
    m = corpus[name]
    out, report = despike_with_report(m.rotations, m.frame_time)
    steps = degrees_between(out[:-1], out[1:])
    assert steps.max() <= 30.0
    np.testing.assert_allclose(report.max_step_after, steps.max(axis=0), atol=1e-5)
    changed = {m.names[j] for j in np.flatnonzero(report.repaired.any(axis=0))}
    assert "RThumb" in changed and changed <= {"RThumb", "RightWrist"}
    untouched = [j for j, n in enumerate(m.names) if n not in changed]
    np.testing.assert_array_equal(out[:, untouched], m.rotations[:, untouched])
    root = despike_positions(m.translations, m.frame_time)
    np.testing.assert_array_equal(root, m.translations)


@needs_corpus
@pytest.mark.parametrize("every", [2, 4], ids=["60fps", "30fps"])
@pytest.mark.parametrize("name", ["131_01.bvh", "131_02.bvh", "131_03.bvh"])
def test_corpus_at_lower_rates_keeps_genuine_motion_bit_for_bit(corpus, name, every):
    """Kept at every 2nd or 4th frame, the fast genuine motion (RightToe flexing 70
    degrees out and back within 3 frames, RightWrist steps of up to 115 degrees at 30
    fps) comes back bit for bit. Only RThumb and joints with a step above the cap of
    3600 deg/s change (at 60 fps, the RightWrist twists of 131_01 and 131_03 that the
    120 fps test repairs too), and no step is left above the cap."""
    m = corpus[name]
    q = quat.make_continuous(m.rotations[::every], axis=0)
    dt = m.frame_time * every
    out, report = despike_with_report(q, dt)
    changed = np.flatnonzero(report.repaired.any(axis=0))
    thumb = m.names.index("RThumb")
    assert thumb in changed
    others = changed[changed != thumb]
    assert (report.max_step_before[others] > 3600.0 * dt).all(), [m.names[j] for j in others]
    untouched = np.setdiff1d(np.arange(len(m.names)), changed)
    np.testing.assert_array_equal(out[:, untouched], q[:, untouched])
    assert report.max_step_after.max() <= 3600.0 * dt


@needs_corpus
def test_corpus_flips_are_found_alike_at_any_rate(corpus):
    """131_02's RThumb has clean half-turn flips only: the frames un-flipped at 60, 30
    and 24 fps are those un-flipped at 120 fps, subsampled, and nothing is interpolated."""
    m = corpus["131_02.bvh"]
    thumb = m.rotations[:, [m.names.index("RThumb")]]
    full = despike_with_report(thumb, m.frame_time)[1]
    assert full.counts("unflipped")[0] > 200
    for every in (2, 4, 5):
        report = despike_with_report(thumb[::every], m.frame_time * every)[1]
        np.testing.assert_array_equal(report.unflipped, full.unflipped[::every])
        assert not report.interpolated.any()


@needs_corpus
@pytest.mark.parametrize("name", ["131_01.bvh", "131_02.bvh", "131_03.bvh"])
def test_corpus_cut_anywhere_keeps_genuine_motion_bit_for_bit(corpus, name):
    """Cuts of 12 and 40 frames at 60 and 30 fps, starting every third frame: a cut that
    starts or ends inside a fast twist (131_02's RightWrist turning 124 degrees in three
    frames at 30 fps) has no trend on that side to judge a spike by, so nothing but RThumb
    and steps above the cap changes (the twist's tail was once interpolated, 30 degrees)."""
    m = corpus[name]
    thumb = m.names.index("RThumb")
    for every in (2, 4):
        q = quat.make_continuous(m.rotations[::every], axis=0)
        dt = m.frame_time * every
        for length in (12, 40):
            for start in range(0, len(q) - length, 3):
                cut = q[start : start + length]
                out, report = despike_with_report(cut, dt)
                genuine = report.max_step_before <= 3600.0 * dt
                genuine[thumb] = False
                np.testing.assert_array_equal(out[:, genuine], cut[:, genuine], f"{every} {start}")


@pytest.mark.parametrize("at_end", [False, True])
@pytest.mark.parametrize("turns", [1.0, 2.0])
def test_a_flip_of_a_root_turning_round_at_an_end_is_repaired(turns, at_end):
    """A run at an end of the clip is left as it is where it agrees with the rest as it is;
    a root turning round keeps to no pose (its mean is any heading), and a half-turn flip
    about its own up axis over the clip's first or last 40 frames had been left in (180
    degrees off): there the parity rules."""
    rng = np.random.default_rng(0)
    n = 600
    yaw = np.linspace(0.0, 2.0 * np.pi * turns, n)
    truth = quat.multiply(
        quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), yaw),
        quat.exp(rng.normal(scale=0.005, size=(n, 3))),
    )
    q = truth.copy()
    run = slice(n - 40, n) if at_end else slice(0, 40)
    q[run] = quat.multiply(q[run], np.array([0.0, 0.0, 1.0, 0.0]))  # about up
    out = despike(q[:, None], 1.0 / 60.0)[:, 0]
    assert np.degrees(quat.angle_between(out, truth)).max() < 6.0


@pytest.mark.parametrize("at_end", [False, True])
def test_an_end_flip_of_a_joint_that_moved_far_from_its_usual_pose_is_repaired(at_end):
    """A joint that keeps near one pose, then over the clip's last (or first) 70 frames
    turns 120 degrees away, the 60 frames there flipped by half a turn: flipped, that pose
    lies nearer the usual one (turning it back takes it further), but outside the spread
    of the joint's other frames about it: it does not agree with them, and is repaired."""
    rng = np.random.default_rng(1)
    n = 600
    angle = np.zeros(n)
    angle[-70:] = np.radians(120.0) * np.minimum(np.arange(70) / 10.0, 1.0)
    truth = quat.multiply(
        quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), angle),
        quat.exp(rng.normal(scale=0.01, size=(n, 3))),
    )
    flip = np.array([0.0, 0.0, 0.0, 1.0])  # half a turn about z: 120 + 180, 60 from usual
    q = truth.copy()
    q[-60:] = quat.multiply(q[-60:], flip)
    usual = quat.identity(())  # the pose the joint keeps to, near the rest's principal one
    nearer = (
        quat.angle_between(q[-60:], usual).mean() < quat.angle_between(truth[-60:], usual).mean()
    )
    assert nearer  # as it is, the flipped run lies nearer the usual pose than its truth
    if not at_end:
        truth, q = truth[::-1].copy(), q[::-1].copy()
    out = despike(q[:, None], 1.0 / 60.0)[:, 0]
    assert np.degrees(quat.angle_between(out, truth)).max() < 15.0  # (180: left flipped)


@pytest.mark.parametrize("runs", [[(248, 328)], [(96, 235), (273, 288), (331, 364), (409, 422)]])
def test_a_flip_of_a_joint_held_far_from_its_usual_pose_is_repaired(runs):
    """MocapBank's walk: the left hip's pose over frames 248-327 lies about 100 degrees from
    the principal rotation of its other frames, so a half-turn about its own x brings it
    nearer that rotation. A run entered and left by half-turn steps is turned back whatever
    the rest looks like (the rest's agreement is asked only of a run at an end of the clip,
    which one step toggles): it had been left flipped, the ankle 98 units off."""
    clip = mc.load(ROOT / "tests" / "data" / "exporters" / "mocapbank_walk.bvh")
    hip = list(clip.names).index("LeftHip")
    truth = clip.rotations[:, hip]
    q = truth.copy()
    for first, stop in runs:
        q[first:stop] = quat.multiply(q[first:stop], np.array([0.0, 1.0, 0.0, 0.0]))
    out = despike(q[:, None], clip.frame_time)[:, 0]
    assert degrees_between(out, truth).max() < 2.0


def test_an_end_flip_inside_a_wide_rest_is_repaired_where_turning_it_back_brings_it_nearer():
    """A joint that keeps near one pose but spends a third of the clip 150 degrees away
    (its other frames spread widely about their principal rotation), its last 60 frames
    flipped by half a turn: as it is, the run lies within that spread, but turned back it
    lies nearer the rest: it is repaired (left as it is only where turning back takes it
    further)."""
    rng = np.random.default_rng(2)
    n = 600
    angle = np.zeros(n)
    angle[300:500] = np.radians(150.0)
    angle[-60:] = np.radians(-40.0)
    angle = np.convolve(np.pad(angle, 4, mode="edge"), np.ones(9) / 9.0, mode="valid")
    truth = quat.multiply(
        quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), angle),
        quat.exp(rng.normal(scale=0.01, size=(n, 3))),
    )
    q = truth.copy()
    q[-60:] = quat.multiply(q[-60:], np.array([0.0, 0.0, 0.0, 1.0]))
    out = despike(q[:, None], 1.0 / 60.0)[:, 0]
    assert np.degrees(quat.angle_between(out, truth)).max() < 15.0  # (180: left flipped)
