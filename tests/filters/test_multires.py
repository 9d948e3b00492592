"""Multiresolution analysis (paper 003): exact pyramids, invariance, editing, blend, stitch."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import corpus_clip
from hypothesis import given, settings
from hypothesis import strategies as st

import motionclean
from motionclean.core import quat
from motionclean.filters import multires as mr
from motionclean.filters.linear import lee_shin, lee_shin_positions
from motionclean.filters.masks import reduction


def load_corpus(name: str):
    return motionclean.load(corpus_clip(name))


def smooth_rotations(
    frames: int, shape: tuple[int, ...], seed: int, speed: float = 1.0
) -> np.ndarray:
    """Smooth unit quaternions ``(frames, *shape, 4)``: ``a exp(v(t))``, ``v`` a sum of sines."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames, dtype=np.float64).reshape(-1, *([1] * len(shape)), 1)
    v = np.zeros((frames, *shape, 3))
    for _ in range(3):
        amp = rng.uniform(-0.4, 0.4, size=(*shape, 3))
        freq = speed * rng.uniform(0.005, 0.05, size=(*shape, 3))
        v += amp * np.sin(freq * t + rng.uniform(0, 2 * np.pi, size=(*shape, 3)))
    start = quat.normalize(rng.normal(size=(*shape, 4)))
    return quat.make_continuous(quat.multiply(start, quat.exp(v)))


def smooth_positions(frames: int, shape: tuple[int, ...], seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(frames, dtype=np.float64).reshape(-1, *([1] * len(shape)), 1)
    return 20.0 * np.sin(rng.uniform(0.01, 0.05, size=(*shape, 3)) * t) + rng.normal(
        scale=5.0, size=(*shape, 3)
    )


def add_noise(q: np.ndarray, sigma: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return quat.multiply(q, quat.exp(rng.normal(scale=sigma, size=q.shape[:-1] + (3,))))


def angular_accel_rms(q: np.ndarray) -> float:
    """RMS of ``|w_{i+1} - w_i|`` over frames and signals (log units per frame^2)."""
    w = quat.displacements(quat.make_continuous(q))
    return float(np.sqrt(np.mean(np.sum(np.diff(w, axis=0) ** 2, axis=-1))))


def rigid(q, p, a, t):
    """003 Eq. 18: ``(a p a^-1 + t, a q)``."""
    return quat.multiply(a, q), None if p is None else quat.rotate(a, p) + t


def zero_detail(n_frames: int, shape: tuple[int, ...], phase: int) -> mr.Detail:
    return mr.Detail(np.zeros((n_frames, *shape, 3)), None, phase)


# ------------------------------------------------------------------ exact reconstruction


def test_exact_reconstruction_every_length_up_to_300():
    # 003 Eq. 9 inverts Eq. 7-8 for every length, not only 2^N k + 1, both alignments.
    q_all = smooth_rotations(300, (2,), seed=1)
    p_all = smooth_positions(300, (2,), seed=2)
    worst_q = worst_p = 0.0
    for frames in range(1, 301):
        q, p = q_all[:frames], p_all[:frames]
        align = "start" if frames % 2 else "end"
        pyramid = mr.decompose(q, 12, p, align=align)
        assert pyramid.n_levels == mr.max_levels(frames)
        assert pyramid.rotations.shape[0] == 1
        q2, p2 = mr.reconstruct(pyramid)
        worst_q = max(worst_q, np.abs(q2 - q).max())
        worst_p = max(worst_p, np.abs(p2 - p).max() / np.abs(p).max())
    assert worst_q < 1e-13
    assert worst_p < 1e-13


@settings(max_examples=60, deadline=None)
@given(
    frames=st.integers(2, 300),
    levels=st.integers(0, 10),
    align=st.sampled_from(["start", "end"]),
    rough=st.booleans(),
    seed=st.integers(0, 2**16),
)
def test_exact_reconstruction_random(frames, levels, align, rough, seed):
    if rough:  # independent random orientations: large, arbitrary details
        rng = np.random.default_rng(seed)
        q = quat.make_continuous(quat.normalize(rng.normal(size=(frames, 3, 4))))
    else:
        q = smooth_rotations(frames, (3,), seed)
    pyramid = mr.decompose(q, levels)
    assert pyramid.n_levels == min(levels, mr.max_levels(frames))
    assert [d.n_frames for d in pyramid.details][:1] == ([frames] if pyramid.n_levels else [])
    q2, p2 = mr.reconstruct(pyramid)
    assert p2 is None
    assert np.abs(q2 - q).max() < 1e-12
    p = np.random.default_rng(seed).normal(size=(frames, 3, 3)).cumsum(axis=0)
    _, p3 = mr.reconstruct(mr.decompose_positions(p, levels, align=align))
    assert np.abs(p3 - p).max() < 1e-12 * max(1.0, np.abs(p).max())


def test_unit_gains_reproduce_input_and_constant_positions_stay_bit_exact():
    q = smooth_rotations(123, (4,), seed=3)
    p = np.broadcast_to(np.array([1.5, -2.25, 7.0]), (123, 4, 3)).copy()
    q2, p2 = mr.edit_frames(q, p, 5, [1.0, 1.0])
    assert np.abs(q2 - q).max() < 1e-13
    assert np.array_equal(p2, p)
    # Edited orientations still leave constant channels untouched.
    q3, p3 = mr.edit_frames(q, p, 5, [0.0, 0.3, 2.0])
    assert quat.angle_between(q3, q).max() > 1e-3
    assert np.array_equal(p3, p)


# ------------------------------------------------------------- reduction and expansion


@pytest.mark.parametrize("frames", [9, 40, 41])
def test_reduction_is_lee_shin_filter_then_downsampling(frames):
    # 003 Eq. 10-13: R = D o H^R with the mask (-1, 4, 18, 4, -1)/24 as a Lee-Shin filter.
    q = add_noise(smooth_rotations(frames, (3,), seed=4), 0.05, seed=5)
    p = smooth_positions(frames, (3,), seed=6)
    filtered, filtered_p = lee_shin(q, reduction()), lee_shin_positions(p, reduction())
    for align in ("start", "end"):
        pyramid = mr.decompose(q, 1, p, align=align)
        phase = pyramid.details[0].phase
        assert phase == (0 if align == "start" else (frames - 1) % 2)
        assert quat.angle_between(pyramid.rotations, filtered[phase::2]).max() < 1e-12
        assert np.abs(pyramid.positions - filtered_p[phase::2]).max() < 1e-12


def test_expansion_interior_is_eq16_and_eq15():
    coarse = smooth_rotations(12, (2,), seed=7)
    p = smooth_positions(12, (2,), seed=8)
    pyramid = mr.Pyramid(coarse, p, (mr.Detail(np.zeros((23, 2, 3)), np.zeros((23, 2, 3)), 0),))
    fine, fine_p = mr.reconstruct(pyramid)
    assert quat.angle_between(fine[0::2], coarse).max() < 1e-14
    w = quat.displacements(coarse)
    i = np.arange(1, 9)  # interior intervals: nodes i-1 .. i+2 exist
    eq16 = quat.multiply(
        quat.slerp(coarse[i], coarse[i + 1], 0.5), quat.exp((w[i - 1] - w[i + 1]) / 16.0)
    )
    assert quat.angle_between(fine[2 * i + 1], eq16).max() < 1e-14
    eq15 = (-p[i - 1] + 9 * p[i] + 9 * p[i + 1] - p[i + 2]) / 16.0
    assert np.abs(fine_p[2 * i + 1] - eq15).max() < 1e-12
    # Left boundary (end of Sec. 3.4): the cubic through the four left-most frames.
    assert np.abs(fine_p[1] - (5 * p[0] + 15 * p[1] - 5 * p[2] + p[3]) / 16).max() < 1e-12


@pytest.mark.parametrize(
    ("coarse_frames", "fine_frames", "phase"),
    [(4, 7, 0), (4, 8, 0), (4, 8, 1), (4, 9, 1), (9, 18, 1), (2, 4, 1)],
)
def test_expansion_reproduces_cubics_and_geodesics_at_both_ends(coarse_frames, fine_frames, phase):
    # Interpolatory subdivision with cubic end handling reproduces cubic polynomials exactly,
    # including the extrapolated end frames of odd/even lengths; the orientation version
    # reproduces constant angular velocity (any mask summing to one does, 000 Sec. VI-A).
    shape = (fine_frames, 1, 3)
    t_fine = (np.arange(fine_frames) - phase) / 2.0
    coeffs = np.array([[0.3, -1.0, 2.0], [0.05, 0.4, -0.2], [-0.01, 0.02, 0.1], [1.0, 2.0, 3.0]])
    degree = min(coarse_frames - 1, 3)
    cubic = sum(coeffs[d] * t_fine[:, None] ** d for d in range(degree + 1))[:, None, :]
    omega = np.array([0.07, -0.03, 0.05])
    start = quat.normalize(np.array([0.3, -0.5, 0.2, 0.7]))
    geodesic = quat.multiply(start, quat.exp(t_fine[:, None, None] * omega))
    kept = slice(phase, None, 2)
    pyramid = mr.Pyramid(
        geodesic[kept], cubic[kept], (mr.Detail(np.zeros(shape), np.zeros(shape), phase),)
    )
    assert pyramid.rotations.shape[0] == coarse_frames
    q, p = mr.reconstruct(pyramid)
    assert np.abs(p - cubic).max() < 1e-12
    assert quat.angle_between(q, geodesic).max() < 1e-13


def test_trailing_axes_are_independent_signals():
    q = smooth_rotations(77, (2, 3), seed=9)
    p = smooth_positions(77, (2, 3), seed=10)
    whole = mr.decompose(q, 4, p)
    single = mr.decompose(q[:, 1, 2], 4, p[:, 1, 2])
    assert np.abs(whole.rotations[:, 1, 2] - single.rotations).max() < 1e-15
    for a, b in zip(whole.details, single.details, strict=True):
        assert np.abs(a.angular[:, 1, 2] - b.angular).max() < 1e-15
        assert np.abs(a.linear[:, 1, 2] - b.linear).max() < 1e-12


# ------------------------------------------------------------- coordinate invariance (Sec. 4)


@pytest.mark.parametrize("align", ["start", "end"])
def test_details_invariant_and_base_moves_rigidly(align):
    # Theorem 4.1 and Corollary 4.1: M(T m) = (T m^(0), d^(0), ..., d^(N-1)).
    rng = np.random.default_rng(11)
    q = add_noise(smooth_rotations(150, (5,), seed=12), 0.02, seed=13)
    p = smooth_positions(150, (5,), seed=14)
    a, t = quat.normalize(rng.normal(size=4)), rng.normal(scale=30.0, size=3)
    qt, pt = rigid(q, p, a, t)
    plain, moved = mr.decompose(q, 5, p, align=align), mr.decompose(qt, 5, pt, align=align)
    for d0, d1 in zip(plain.details, moved.details, strict=True):
        assert np.abs(d0.angular - d1.angular).max() < 1e-12
        assert np.abs(d0.linear - d1.linear).max() < 1e-11
    base_q, base_p = rigid(plain.rotations, plain.positions, a, t)
    assert quat.angle_between(base_q, moved.rotations).max() < 1e-12
    assert np.abs(base_p - moved.positions).max() < 1e-11
    # Sec. 5.2: reconstructing from the transformed base and the same details gives T m.
    q2, p2 = mr.reconstruct(mr.Pyramid(base_q, base_p, plain.details))
    assert quat.angle_between(q2, qt).max() < 1e-12
    assert np.abs(p2 - pt).max() < 1e-11


def test_edits_commute_with_rigid_transforms():
    rng = np.random.default_rng(15)
    q = add_noise(smooth_rotations(201, (3,), seed=16), 0.03, seed=17)
    p = smooth_positions(201, (3,), seed=18)
    a, t = quat.normalize(rng.normal(size=4)), rng.normal(scale=30.0, size=3)
    gains = [0.0, 0.5, 1.8]
    qt, pt = rigid(q, p, a, t)
    e_q, e_p = mr.edit_frames(q, p, 6, gains)
    m_q, m_p = mr.edit_frames(qt, pt, 6, gains)
    r_q, r_p = rigid(e_q, e_p, a, t)
    assert quat.angle_between(m_q, r_q).max() < 1e-12
    assert np.abs(m_p - r_p).max() < 1e-11
    assert (
        quat.angle_between(mr.edit(qt, 6, gains), quat.multiply(a, mr.edit(q, 6, gains))).max()
        < 1e-12
    )
    moved_p = mr.edit_positions(quat.rotate(a, p) + t, 6, gains)
    assert np.abs(moved_p - (quat.rotate(a, mr.edit_positions(p, 6, gains)) + t)).max() < 1e-11


# ----------------------------------------------------------------------- editing (Sec. 5.1)


def test_removing_fine_levels_lowers_acceleration_monotonically():
    q = add_noise(smooth_rotations(400, (6,), seed=19), 0.01, seed=20)
    # Levels whose coarse signal still has at least 16 frames (400 -> 200 -> ... -> 25).
    accel = [angular_accel_rms(mr.edit(q, 8, [0.0] * k)) for k in range(5)]
    assert np.all(np.diff(accel) < 0.0), accel
    assert accel[-1] < 0.05 * accel[0]


def test_corpus_removing_levels_lowers_acceleration_monotonically():
    m = load_corpus("131_01.bvh")
    q = m.rotations[:, :8]  # hips and left leg chain
    accel = [angular_accel_rms(mr.edit(q, 6, [0.0] * k)) for k in range(7)]
    assert np.all(np.diff(accel) < 0.0), accel


@pytest.mark.parametrize("frames", [64, 65, 100])
def test_gain_zero_on_finest_level_is_expanded_reduction(frames):
    # gains[0] is the finest level; levels with gain 1 are rebuilt exactly, so removing the
    # finest level of any deeper pyramid gives E(R m) of the clip edit works on: the clip
    # continued past its last frame by the reflection q_e q_(e-j)^-1 q_e to 2^N k + 1 frames
    # (built here from quaternion products, not by the module).
    q = add_noise(smooth_rotations(frames, (3,), seed=50), 0.02, seed=51)
    for levels in (1, 3, 6):
        pad = -(frames - 1) % 2**levels
        end = q[-1]
        back = q[-2 : -2 - pad : -1] if pad else q[:0]
        longer = quat.make_continuous(
            np.concatenate([q, quat.multiply(quat.multiply(end, quat.conjugate(back)), end)])
        )
        one = mr.decompose(longer, 1)
        zero = zero_detail(longer.shape[0], (3,), 0)
        expected, _ = mr.reconstruct(mr.Pyramid(one.rotations, None, (zero,)))
        got = mr.edit(q, levels, [0.0])
        assert quat.angle_between(got, expected[:frames]).max() < 1e-12
    assert quat.angle_between(mr.edit(q, 6, [1.0, 0.0]), got).max() > 1e-3


@pytest.mark.parametrize("frames", [64, 100, 196, 1064])
def test_dropping_fine_levels_moves_the_last_frames_about_as_the_first(frames):
    """Both ends survive every reduction: a smooth turn's last frames move about as much as
    the first frames of the clip played backwards (the expansion had extrapolated them,
    5-6 times as far on this turn and 35 degrees on a still foot at a real walk's end)."""
    t = np.arange(frames)[:, None]
    angle = np.radians(40.0) * np.sin(2.0 * np.pi * t / 60.0 + 0.7)
    q = quat.exp(angle[..., None] * np.array([0.0, 0.0, 0.5]))
    gains = mr.level_gains(4, 2.0)
    moved = np.degrees(quat.angle_between(mr.edit(q, 4, gains), q))
    backwards = np.degrees(quat.angle_between(mr.edit(q[::-1], 4, gains), q[::-1]))
    assert moved[-4:].max() < 3.0 * backwards[:4].max()


def test_fractional_levels():
    assert mr.level_gains(4, 4) == [1.0, 1.0, 1.0, 1.0]
    assert mr.level_gains(4, 2.5) == [0.0, 0.5, 1.0, 1.0]
    assert mr.level_gains(3, 0) == [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="level"):
        mr.level_gains(3, 3.5)
    q = add_noise(smooth_rotations(300, (4,), seed=21), 0.01, seed=22)
    assert np.abs(mr.edit(q, 8, mr.level_gains(8, 8)) - q).max() < 1e-13
    # A continuous path between levels: detail-rich to smooth as the level goes down.
    accel = [
        angular_accel_rms(mr.edit(q, 8, mr.level_gains(8, x))) for x in np.arange(8.0, 3.9, -0.25)
    ]
    assert np.all(np.diff(accel) < 0.0), accel


def test_gains_validation_and_short_clips():
    q = smooth_rotations(50, (2,), seed=23)
    with pytest.raises(ValueError, match="3 entries but only 2 levels"):
        mr.edit(q, 2, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="finite"):
        mr.edit(q, 3, [np.nan])
    with pytest.raises(ValueError, match="levels"):
        mr.edit(q, -1, [])
    with pytest.raises(ValueError, match=r"\(F, \.\.\., 4\)"):
        mr.edit(q[..., :3], 2, [0.0])
    # A 3-frame clip has 2 levels: the gains of missing coarser levels are dropped.
    short = q[:3]
    assert np.abs(mr.edit(short, 6, [1, 1, 1, 1, 0.0]) - short).max() < 1e-14
    assert mr.edit(q[:1], 4, [0.0]).shape == (1, 2, 4)
    assert quat.angle_between(mr.edit(short, 6, [0.0]), short).max() > 0.0


# --------------------------------------------------------------- blending (Eq. 20)


def test_blend_end_points_self_blend_and_equivariance():
    rng = np.random.default_rng(24)
    qa, qb = smooth_rotations(90, (3,), seed=25), smooth_rotations(90, (3,), seed=26)
    pa, pb = smooth_positions(90, (3,), seed=27), smooth_positions(90, (3,), seed=28)
    q0, p0 = mr.blend(qa, qb, 4, weight=0.0, p_a=pa, p_b=pb)
    q1, p1 = mr.blend(qa, qb, 4, weight=1.0, p_a=pa, p_b=pb)
    assert quat.angle_between(q0, qa).max() < 1e-12 and np.abs(p0 - pa).max() < 1e-11
    assert quat.angle_between(q1, qb).max() < 1e-12 and np.abs(p1 - pb).max() < 1e-11
    qs, _ = mr.blend(qa, qa, 4, weight=0.3, detail_weights=[0.9, -0.5])
    assert quat.angle_between(qs, qa).max() < 1e-12
    # Band-wise: A's coarse shape with B's finest band differs from both.
    qm, _ = mr.blend(qa, qb, 4, weight=0.0, detail_weights=[1.0])
    assert quat.angle_between(qm, qa).max() > 1e-4 and quat.angle_between(qm, qb).max() > 1e-2
    a, t = quat.normalize(rng.normal(size=4)), rng.normal(size=3)
    ta, tb = rigid(qa, pa, a, t), rigid(qb, pb, a, t)
    qh, ph = mr.blend(qa, qb, 4, weight=0.4, detail_weights=[0.1, 0.7], p_a=pa, p_b=pb)
    qt, pt = mr.blend(ta[0], tb[0], 4, weight=0.4, detail_weights=[0.1, 0.7], p_a=ta[1], p_b=tb[1])
    moved = rigid(qh, ph, a, t)
    assert quat.angle_between(qt, moved[0]).max() < 1e-12
    assert np.abs(pt - moved[1]).max() < 1e-11


def test_transfer_eq20_identities():
    a, b, c = (smooth_rotations(70, (2,), seed=s) for s in (29, 30, 31))
    pa, pb, pc = (smooth_positions(70, (2,), seed=s) for s in (32, 33, 34))
    q, p = mr.transfer(a, a, c, 4, pa, pa, pc)  # no change of shape: the detail clip
    assert quat.angle_between(q, c).max() < 1e-12 and np.abs(p - pc).max() < 1e-11
    q, p = mr.transfer(a, b, a, 4, pa, pb, pa)  # details relative to themselves: the shape
    assert quat.angle_between(q, b).max() < 1e-12 and np.abs(p - pb).max() < 1e-11
    q, _ = mr.transfer(a, b, c, 4)
    assert quat.angle_between(q, b).max() > 1e-3 and quat.angle_between(q, c).max() > 1e-3


def test_blend_shape_errors():
    qa, qb = smooth_rotations(40, (3,), seed=35), smooth_rotations(41, (3,), seed=36)
    with pytest.raises(ValueError, match="equal shape"):
        mr.blend(qa, qb, 3)
    with pytest.raises(ValueError, match="equal shape"):
        mr.blend(qa, qa[:, :2], 3)
    with pytest.raises(ValueError, match="both clips or for neither"):
        mr.blend(qa, qa, 3, p_a=np.zeros((40, 3, 3)))
    with pytest.raises(ValueError, match="do not match the rotations"):
        mr.blend(qa, qa, 3, p_a=np.zeros((40, 3)), p_b=np.zeros((40, 3)))
    with pytest.raises(ValueError, match="equal shape"):
        mr.transfer(qa, qa, qb, 3)


# ----------------------------------------------------------------- stitching (Eq. 21)


@pytest.mark.parametrize(
    ("frames_a", "frames_b", "levels"),
    [(100, 90, 3), (101, 77, 4), (64, 65, 2), (30, 1, 3), (47, 60, 4), (64, 64, 4), (65, 80, 4)],
)
def test_stitch_changes_only_the_seam_region(frames_a, frames_b, levels):
    """Each band joined over its own width: frames beyond 3 (2^N - 1) of the seam are the
    clips' own, the far ends too, with N clamped so that each clip's coarsest level keeps
    five samples (a deeper pyramid, (47, 60, 4) or (64, 64, 4), had moved the far ends;
    (65, 80, 4) keeps its 4 levels)."""
    qa, qb = smooth_rotations(frames_a, (2,), seed=37), smooth_rotations(frames_b, (2,), seed=38)
    pa, pb = smooth_positions(frames_a, (2,), seed=39), smooth_positions(frames_b, (2,), seed=40)
    q, p = mr.stitch(qa, qb, levels, pa, pb)
    assert q.shape == (frames_a + frames_b - 1, 2, 4) and p.shape == (frames_a + frames_b - 1, 2, 3)
    seam = frames_a - 1
    n = mr.stitch_levels(frames_a, frames_b, levels)
    assert n <= min(levels, mr.max_levels(frames_a), mr.max_levels(frames_b))
    assert 4 * 2**n <= min(frames_a, frames_b) - 1 or n == 0
    assert n == levels or 4 * 2 ** (n + 1) > min(frames_a, frames_b) - 1  # the most that fit
    reach = 3 * (2**n - 1)
    assert quat.angle_between(q[: seam - reach], qa[: seam - reach]).max(initial=0) < 1e-12
    assert np.abs(p[: seam - reach] - pa[: seam - reach]).max(initial=0) < 1e-11
    assert quat.angle_between(q[seam + reach + 1 :], qb[reach + 1 :]).max(initial=0) < 1e-12
    # The seam frame is a blend of both ends, not either of them.
    assert quat.angle_between(q[seam], qa[-1]).min() > 1e-6


def test_stitch_without_levels_is_eq21_on_the_frames():
    qa, qb = smooth_rotations(20, (2,), seed=42), smooth_rotations(15, (2,), seed=43)
    pa, pb = smooth_positions(20, (2,), seed=44), smooth_positions(15, (2,), seed=45)
    q, p = mr.stitch(qa, qb, 0, pa, pb)
    assert quat.angle_between(q[:19], qa[:19]).max() < 1e-15
    assert quat.angle_between(q[20:], qb[1:]).max() < 1e-15
    assert quat.angle_between(q[19], quat.slerp(qa[-1], qb[0], 0.5)).max() < 1e-15
    assert np.abs(p[19] - 0.5 * (pa[-1] + pb[0])).max() < 1e-15


@pytest.mark.parametrize(("frames_a", "frames_b", "levels"), [(60, 47, 3), (33, 80, 5)])
def test_stitch_is_symmetric_in_time(frames_a, frames_b, levels):
    # Symmetric masks, symmetric end rules and symmetric seam averages: stitching A to B and
    # reversing gives B reversed stitched to A reversed.
    qa, qb = smooth_rotations(frames_a, (3,), seed=46), smooth_rotations(frames_b, (3,), seed=47)
    pa, pb = smooth_positions(frames_a, (3,), seed=48), smooth_positions(frames_b, (3,), seed=49)
    q, p = mr.stitch(qa, qb, levels, pa, pb)
    rq, rp = mr.stitch(qb[::-1], qa[::-1], levels, pb[::-1], pa[::-1])
    assert quat.angle_between(q, rq[::-1]).max() < 1e-12
    assert np.abs(p - rp[::-1]).max() < 1e-11


def test_stitch_shape_errors():
    qa = smooth_rotations(40, (3,), seed=41)
    with pytest.raises(ValueError, match="same joints"):
        mr.stitch(qa, qa[:, :2], 3)
    with pytest.raises(ValueError, match="both clips or for neither"):
        mr.stitch(qa, qa, 3, p_b=np.zeros((40, 3, 3)))


def seam_jump(q: np.ndarray, seam: int, half_width: int) -> float:
    """Largest joint-summed ``|w_{i+1} - w_i|`` for frames within ``half_width`` of ``seam``."""
    w = quat.displacements(quat.make_continuous(q))
    jumps = np.linalg.norm(np.diff(w, axis=0), axis=-1).sum(axis=1)  # jumps[i]: frame i + 1
    lo, hi = max(seam - 1 - half_width, 0), min(seam + half_width, jumps.shape[0])
    return float(jumps[lo:hi].max())


def test_corpus_stitch_smaller_velocity_jump_than_concatenation():
    a, b = load_corpus("131_01.bvh"), load_corpus("131_02.bvh")
    levels = 4
    q, p = mr.stitch(a.rotations, b.rotations, levels, a.translations, b.translations)
    assert q.shape[0] == a.n_frames + b.n_frames - 1 and p.shape == q.shape[:-1] + (3,)
    concatenated = np.concatenate([a.rotations, b.rotations])
    plain = seam_jump(concatenated, a.n_frames, 1)
    # The whole stitched transition region against the one concatenation seam.
    stitched = seam_jump(q, a.n_frames - 1, 3 * (2**levels - 1))
    assert stitched < 0.25 * plain, (stitched, plain)


def test_oplus_undoes_ominus_for_rotations_and_positions():
    """003 Eq. 2-3: ``from (+) (to (-) from) = to``, positions in the body frame of ``from``."""
    rng = np.random.default_rng(11)
    q_from, q_to = quat.normalize(rng.normal(size=(2, 50, 4)))
    p_from, p_to = rng.normal(size=(2, 50, 3))
    v, u = mr.ominus(q_to, q_from, p_to, p_from)
    assert np.all(np.linalg.norm(v, axis=-1) <= np.pi / 2 + 1e-12)  # shorter arc
    q_back, p_back = mr.oplus(q_from, v, p_from, u)
    np.testing.assert_allclose(np.abs(np.sum(q_back * q_to, axis=-1)), 1.0, atol=1e-12)
    np.testing.assert_allclose(p_back, p_to, atol=1e-12)
    # u is measured in the body frame: rotating both frames rotates p but not u.
    turn = quat.from_axis_angle([0.0, 0.0, 1.0], 0.7)
    v2, u2 = mr.ominus(
        quat.multiply(turn, q_to),
        quat.multiply(turn, q_from),
        quat.rotate(turn, p_to),
        quat.rotate(turn, p_from),
    )
    np.testing.assert_allclose(u2, u, atol=1e-12)
    np.testing.assert_allclose(v2, v, atol=1e-12)
    with pytest.raises(ValueError, match="both frames or for neither"):
        mr.ominus(q_to, q_from, p_to, None)


@pytest.mark.parametrize(
    ("q", "gains", "error", "message"),
    [
        (None, [0.0], TypeError, "q: expected an array of numbers, got NoneType"),
        ("abc", [0.0], TypeError, "q: expected an array of numbers, got str"),
        (np.zeros((0, 3)), [0.0], ValueError, r"q: expected shape \(F, \.\.\., 4\)"),
        (quat.identity((40, 2)), "0", TypeError, "gains must be a list of numbers, got str"),
    ],
)
def test_edit_refuses_bad_arguments_naming_them(q, gains, error, message):
    """The empty-clip shortcut had run before the check (IndexError for None), and a
    string of gains had been read as a list of one."""
    with pytest.raises(error, match=message):
        mr.edit(q, 3, gains)
