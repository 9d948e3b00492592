"""The C2 interpolating spline on the sphere (resampling's interpolant): exact at the samples,
C2, cut at jumps, and closer to the motion than a natural cubic spline on each Euler channel."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import CORPUS_CLIPS, NO_CORPUS, SAMPLE, max_degrees

import motionclean as mc
from motionclean.core import quat
from motionclean.filters.spline import (
    evaluate,
    evaluate_positions,
    position_spline,
    rotation_spline,
    solve_knots,
    solve_tridiagonal,
)

RNG = np.random.default_rng(7)


def natural_spline(y: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The natural cubic spline through ``y`` ``(n, C)`` at unit knots, at times ``t``:
    second derivatives from the textbook tridiagonal system, solved densely (the peer)."""
    n = y.shape[0]
    a = np.zeros((n, n))
    rhs = np.zeros_like(y)
    a[0, 0] = a[-1, -1] = 1.0
    for i in range(1, n - 1):
        a[i, i - 1 : i + 2] = (1.0, 4.0, 1.0)
        rhs[i] = 6.0 * (y[i + 1] - 2.0 * y[i] + y[i - 1])
    m = np.linalg.solve(a, rhs)
    i = np.clip(np.floor(t).astype(int), 0, n - 2)
    u = (t - i)[:, None]
    return (
        (1 - u) * y[i]
        + u * y[i + 1]
        + ((1 - u) ** 3 - (1 - u)) * m[i] / 6.0
        + (u**3 - u) * m[i + 1] / 6.0
    )


def at(spline, t: np.ndarray) -> np.ndarray:
    index = np.floor(t).astype(np.intp)
    return evaluate(spline, index, t - index)


def test_knot_solve_is_the_tridiagonal_solve():
    e = RNG.normal(size=(37, 2, 3))
    m = np.diag(np.full(37, 4.0)) + np.diag(np.ones(36), 1) + np.diag(np.ones(36), -1)
    expected = np.linalg.solve(m / 6.0, e.reshape(37, -1)).reshape(e.shape)
    np.testing.assert_allclose(solve_knots(e), expected, atol=1e-12)
    free = np.ones((400, 2), dtype=bool)
    free[[0, 10, 11, 39, 41, 300], 0] = False  # runs of 9, 27, 1, 258 and 99 rows
    free[[5], 1] = False
    e = RNG.normal(size=(400, 2, 3))
    d = solve_tridiagonal(free, e)
    assert not d[~free].any()
    for col in range(2):  # the same, solved densely with the held rows as identity rows
        m = np.diag(np.where(free[:, col], 4.0, 6.0))
        for i in np.flatnonzero(free[:, col]):
            m[i, [k for k in (i - 1, i + 1) if 0 <= k < 400]] = 1.0
        rhs = np.where(free[:, col, None], e[:, col], 0.0)
        np.testing.assert_allclose(d[:, col], np.linalg.solve(m / 6.0, rhs), atol=1e-13)


def test_positions_are_the_natural_cubic_spline():
    p = RNG.normal(size=(23, 3))
    t = np.linspace(0.0, 22.0, 177)
    index = np.minimum(np.floor(t).astype(np.intp), 22)
    ours = evaluate_positions(position_spline(p), index, t - index)
    np.testing.assert_allclose(ours, natural_spline(p, t), atol=1e-12)


def test_hits_the_samples_and_is_c2():
    rng = np.random.default_rng(3)  # steps of 10-50 degrees between samples: no jump
    q = quat.make_continuous(quat.normalize(rng.normal(size=(30, 3, 4)) * 0.15 + [1, 0, 0, 0]))
    steps = np.degrees(quat.angle_between(q[:-1], q[1:]))
    assert 40.0 < steps.max() < 90.0
    spline = rotation_spline(q)
    assert max_degrees(at(spline, np.arange(30.0)), q) < 1e-6  # below a BVH's six decimals
    # angular velocity and acceleration continuous across the knots (central differences
    # either side of each knot agree to the differences' own error)
    h = 1e-3
    for knot in (5.0, 12.0, 21.0):
        t = knot + h * np.arange(-3, 4)
        curve = at(spline, t)
        w = quat.log_shortest(quat.relative(curve[:-1], curve[1:])) / h  # 6 velocities
        acc_left, acc_right = (w[1] - w[0]) / h, (w[5] - w[4]) / h
        assert np.abs(w[2] - w[3]).max() < 20 * h
        np.testing.assert_allclose(acc_left, acc_right, atol=0.05 * np.abs(acc_left).max() + 0.05)


def test_constant_angular_velocity_is_exact_between_and_past_the_samples():
    w = np.array([0.03, -0.05, 0.02])
    q = quat.exp(np.arange(12)[:, None] * w)
    t = np.array([-0.75, 0.3, 5.5, 10.9, 11.6])
    assert max_degrees(at(rotation_spline(q), t), quat.exp(t[:, None] * w)) < 1e-9  # c = q


def test_a_half_turn_cuts_the_spline_and_stays_local():
    """A flip at frame 20: the curve before it is the spline of the frames before it alone,
    and across it the geodesic between the two samples."""
    q = quat.make_continuous(quat.normalize(RNG.normal(size=(40, 4)) * 0.1 + [1, 0, 0, 0]))
    flipped = q.copy()
    flipped[20:] = quat.multiply(quat.from_axis_angle(np.array([1.0, 0, 0]), np.pi), q[20:])
    flipped = quat.make_continuous(flipped)
    t = np.linspace(0.0, 18.9, 50)
    assert max_degrees(at(rotation_spline(flipped), t), at(rotation_spline(q[:20]), t)) < 1e-6
    mid = at(rotation_spline(flipped), np.array([19.5]))[0]
    half = quat.multiply(
        q[19], quat.exp(0.5 * quat.log_shortest(quat.relative(q[19], flipped[20])))
    )
    assert max_degrees(mid, half) < 1e-9


def restore_errors(clip: mc.Motion, joints: np.ndarray | None = None) -> tuple[float, float]:
    """4x subsampled and restored: RMS angle (degrees) of ours and of the natural cubic
    spline on each Euler channel as stored, on the lost frames."""
    step = 4
    n = (clip.n_frames - 1) // step * step + 1
    lost = np.arange(n) % step != 0
    joints = np.flatnonzero(clip.layout.has_rotation) if joints is None else joints
    t = np.arange(n) / step
    ours = at(rotation_spline(quat.make_continuous(clip.rotations[:n:step])), t)
    values = natural_spline(clip.source_values[:n:step], t)
    theirs = mc.Motion.from_channel_values(
        clip.names, clip.parents, clip.offsets, clip.channels, clip.frame_time, values
    ).rotations

    def rms(r: np.ndarray) -> float:
        angles = np.degrees(
            quat.angle_between(r[lost][:, joints], clip.rotations[:n][lost][:, joints])
        )
        return float(np.sqrt(np.mean(angles**2)))

    return rms(ours), rms(theirs)


def test_closer_than_a_natural_spline_per_euler_channel_on_the_sample():
    ours, theirs = restore_errors(mc.load(SAMPLE))
    assert ours <= theirs


@pytest.mark.skipif(not CORPUS_CLIPS, reason=NO_CORPUS)
@pytest.mark.parametrize("path", CORPUS_CLIPS, ids=lambda p: p.stem)
def test_closer_than_a_natural_spline_per_euler_channel_on_the_corpus(path):
    import sys

    sys.path.insert(0, str(SAMPLE.parents[1] / "bench"))
    from resample import turned  # the bench's turned copy: the root's channels wrap

    clip = mc.load(path)
    ours, theirs = restore_errors(clip)
    assert ours <= theirs
    back = turned(clip, quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.pi))
    ours, theirs = restore_errors(back, np.array([0]))
    assert ours <= 0.5 * theirs
