"""Bilateral orientation filter (paper 002): propositions, reductions and edge preservation."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import corpus_clip

from motionclean.core import quat
from motionclean.filters.bilateral import bilateral, bilateral_positions
from motionclean.filters.linear import (
    displacement_coefficients,
    lee_shin,
    lee_shin_positions,
    mirrored_displacements,
)
from motionclean.filters.masks import gaussian


def smooth_rotations(frames: int, joints: int, seed: int, speed: float = 0.05) -> np.ndarray:
    """A smooth random rotation signal ``(frames, joints, 4)`` (random walk in velocity)."""
    rng = np.random.default_rng(seed)
    vel = speed * np.cumsum(rng.normal(scale=0.3, size=(frames, joints, 3)), axis=0)
    vel = np.clip(vel, -0.3, 0.3)
    start = quat.normalize(rng.normal(size=(joints, 4)))
    out = [start]
    for v in vel[:-1]:  # building test data only
        out.append(quat.multiply(out[-1], quat.exp(v)))
    return np.stack(out)


def add_noise(q: np.ndarray, sigma: float, seed: int) -> np.ndarray:
    """``q_i exp(n_i)``, ``n_i ~ N(0, sigma^2 I_3)`` in log units (000 Sec. VI-B)."""
    rng = np.random.default_rng(seed)
    return quat.multiply(q, quat.exp(rng.normal(scale=sigma, size=q.shape[:-1] + (3,))))


def constant_velocity(frames: int, omega: np.ndarray, start: np.ndarray) -> np.ndarray:
    """``q_i = start exp(i omega)`` for each trailing signal."""
    i = np.arange(frames, dtype=np.float64).reshape(-1, *([1] * omega.ndim))
    return quat.multiply(start, quat.exp(i * omega))


@pytest.fixture(scope="module")
def noisy() -> np.ndarray:
    return add_noise(smooth_rotations(90, 4, seed=1), 0.04, seed=2)


@pytest.mark.parametrize(("sigma_t", "sigma_g", "iterations"), [(1.0, 0.1, 1), (2.0, 0.05, 3)])
def test_coordinate_invariance_both_sides(noisy, sigma_t, sigma_g, iterations):
    # 002 Prop. 1: H(a q b) = a H(q) b for any unit a (global) and b (local, per joint).
    rng = np.random.default_rng(3)
    a = quat.normalize(rng.normal(size=4))
    b = quat.normalize(rng.normal(size=(noisy.shape[1], 4)))
    moved = quat.multiply(quat.multiply(a, noisy), b)
    lhs = bilateral(moved, sigma_t, sigma_g, iterations=iterations)
    rhs = quat.multiply(
        quat.multiply(a, bilateral(noisy, sigma_t, sigma_g, iterations=iterations)), b
    )
    np.testing.assert_allclose(lhs, rhs, atol=1e-9)
    # and the filter did something data-dependent (not the identity)
    assert np.max(quat.angle_between(lhs, moved)) > 1e-3


def test_positions_rigid_invariance():
    # Distances and weighted averages commute with rotations and translations.
    rng = np.random.default_rng(4)
    p = np.cumsum(rng.normal(size=(70, 3, 3)), axis=0)
    rot = quat.as_matrix(quat.normalize(rng.normal(size=4)))
    shift = rng.normal(size=3) * 10
    lhs = bilateral_positions(p @ rot.T + shift, 1.5, 1.0, iterations=2)
    rhs = bilateral_positions(p, 1.5, 1.0, iterations=2) @ rot.T + shift
    np.testing.assert_allclose(lhs, rhs, atol=1e-9)


def test_time_invariance_interior(noisy):
    # 002 Prop. 2: shifting the input shifts the output, away from the ends' influence.
    sigma_t, iterations, shift = 1.0, 2, 11
    reach = iterations * 3  # radius ceil(3 sigma_t) per pass
    full = bilateral(noisy, sigma_t, 0.1, iterations=iterations)
    part = bilateral(noisy[shift:], sigma_t, 0.1, iterations=iterations)
    n = part.shape[0]
    interior = slice(reach, n - reach)
    np.testing.assert_allclose(part[interior], full[shift:][interior], atol=1e-12)
    # the ends do depend on where the clip starts (so the slice above is a real restriction)
    assert np.max(np.abs(part[0] - full[shift])) > 1e-6


def test_time_reversal_symmetry(noisy):
    # Symmetric weights and the Eq. 26 mirror at both ends: H commutes with time reversal.
    out = bilateral(noisy, 1.5, 0.1, iterations=2)
    rev = bilateral(noisy[::-1], 1.5, 0.1, iterations=2)[::-1]
    np.testing.assert_allclose(np.abs(np.sum(rev * out, axis=-1)), 1.0, atol=1e-12)


@pytest.mark.parametrize(
    ("sigma_t", "radius", "iterations"), [(1.0, None, 1), (0.7, 4, 3), (2.5, None, 2)]
)
@pytest.mark.parametrize("sigma_g", [np.inf, 1e6])
def test_large_sigma_g_is_gaussian_lee_shin(noisy, sigma_t, radius, iterations, sigma_g):
    got = bilateral(noisy, sigma_t, sigma_g, radius=radius, iterations=iterations)
    want = lee_shin(noisy, gaussian(sigma_t, radius), iterations=iterations)
    np.testing.assert_allclose(got, want, atol=1e-12)


def test_large_sigma_p_is_gaussian_lee_shin_positions():
    p = np.cumsum(np.random.default_rng(5).normal(size=(50, 2, 3)), axis=0)
    for sigma_t, radius, iterations in ((1.0, None, 1), (1.8, 3, 4)):
        got = bilateral_positions(p, sigma_t, np.inf, radius=radius, iterations=iterations)
        want = lee_shin_positions(p, gaussian(sigma_t, radius), iterations=iterations)
        np.testing.assert_allclose(got, want, atol=1e-12)


@pytest.mark.parametrize(
    ("frames", "sigma_t", "sigma_g", "radius"),
    [(40, 1.0, 0.1, None), (40, 2.0, 0.05, None), (7, 1.0, 0.1, 12), (2, 1.0, 0.1, None)],
)
def test_constant_angular_velocity_is_fixed_point(frames, sigma_t, sigma_g, radius):
    # Per-frame half angles 0.02 .. 0.15 make d(i, i+r) = |r omega| comparable to sigma_g,
    # so the weights vary strongly with r: neighbours that were reflected samples instead of
    # the cumulated Eq. 26 extension would break the symmetry at the first and last frames.
    rng = np.random.default_rng(6)
    omega = rng.normal(size=(5, 3))
    omega *= (np.linspace(0.02, 0.15, 5) / np.linalg.norm(omega, axis=-1))[:, None]
    q = constant_velocity(frames, omega, quat.normalize(rng.normal(size=(5, 4))))
    out = bilateral(q, sigma_t, sigma_g, radius=radius, iterations=3)
    np.testing.assert_allclose(out, q, atol=1e-12)

    p = np.arange(frames)[:, None, None] * rng.normal(size=(3, 3)) + rng.normal(size=(3, 3))
    np.testing.assert_allclose(bilateral_positions(p, sigma_t, 0.5, radius, 3), p, atol=1e-12)


def reference_bilateral(q: np.ndarray, sigma_t: float, sigma_g: float, k: int) -> np.ndarray:
    """One pass of 002 Algorithm 1, sample by sample, for a single signal ``(F, 4)``.

    Neighbours beyond the ends follow the mirrored displacements (000 Eq. 26): q_i^-1 q_{i+r}
    is the product of exp(w) along the window starting at sample i, and each sample's
    normalised mask goes through 000 Eq. 20 (``displacement_coefficients``).
    """
    w = quat.displacements(q)
    ext = mirrored_displacements(w, k, k)  # positions -k .. F-2+k
    out = np.empty_like(q)
    for i in range(q.shape[0]):  # reference only
        weights = np.empty(2 * k + 1)
        for r in range(-k, k + 1):
            rel = quat.identity()
            for j in range(min(0, r), max(0, r)):
                rel = quat.multiply(rel, quat.exp(ext[i + j + k]))
            if r < 0:
                rel = quat.conjugate(rel)
            d = np.linalg.norm(quat.log(rel if rel[0] >= 0 else -rel))
            weights[r + k] = np.exp(-(r**2) / (2 * sigma_t**2) - d**2 / (2 * sigma_g**2))
        b = displacement_coefficients(weights / weights.sum())
        s = sum(b[m + k] * ext[i + m + k] for m in range(-k, k))
        out[i] = quat.multiply(q[i], quat.exp(s))
    return out


@pytest.mark.parametrize(("frames", "sigma_t", "sigma_g"), [(30, 1.0, 0.1), (5, 1.5, 0.2)])
def test_matches_per_sample_algorithm_1(frames, sigma_t, sigma_g):
    # Per-sample masks, Eq. 20 coefficients and the end extension, against a plain loop;
    # the 5-frame case has windows (radius 5) reaching past both ends at once.
    q = add_noise(smooth_rotations(frames, 1, seed=10, speed=0.2), 0.05, seed=11)[:, 0]
    q = quat.make_continuous(q)
    k = int(np.ceil(3 * sigma_t))
    np.testing.assert_allclose(
        bilateral(q, sigma_t, sigma_g), reference_bilateral(q, sigma_t, sigma_g, k), atol=1e-12
    )


def test_positions_interior_is_classical_bilateral():
    # 002 Eq. 4: BF(x_i) = sum_r W(i, r) x_{i+r} / sum_r W(i, r), away from the ends.
    p = np.cumsum(np.random.default_rng(12).normal(size=(60, 2, 3)), axis=0)
    sigma_t, sigma_p, k = 1.2, 1.5, 4
    got = bilateral_positions(p, sigma_t, sigma_p)
    i = np.arange(k, 60 - k)
    num, den = 0.0, 0.0
    for r in range(-k, k + 1):
        dist2 = np.sum((p[i + r] - p[i]) ** 2, axis=-1, keepdims=True)
        weight = np.exp(-(r**2) / (2 * sigma_t**2) - dist2 / (2 * sigma_p**2))
        num, den = num + weight * p[i + r], den + weight
    np.testing.assert_allclose(got[i], num / den, atol=1e-12)


def test_positions_ends_are_bilateral_of_the_extension():
    # At the ends the neighbours are p_{-j} = p_0 - (d_{-1} + ... + d_{-j}) and p_{n-1+j} =
    # p_{n-1} + (d_{n-1} + ... + d_{n-2+j}) with d mirrored by 000 Eq. 26; on that extended
    # signal, Eq. 20 turns the output into 002 Eq. 4 for every frame, ends included.
    p = np.cumsum(np.random.default_rng(17).normal(size=(20, 2, 3)), axis=0)
    sigma_t, sigma_p, k = 1.2, 1.5, 4
    d = mirrored_displacements(np.diff(p, axis=0), k, k)  # positions -k .. n-2+k
    before = p[0] - np.cumsum(d[:k][::-1], axis=0)  # p_{-1} .. p_{-k}
    after = p[-1] + np.cumsum(d[k + p.shape[0] - 1 :], axis=0)  # p_n .. p_{n-1+k}
    ext = np.concatenate([before[::-1], p, after])
    i = np.arange(p.shape[0])
    num, den = 0.0, 0.0
    for r in range(-k, k + 1):
        dist2 = np.sum((ext[i + k + r] - p) ** 2, axis=-1, keepdims=True)
        weight = np.exp(-(r**2) / (2 * sigma_t**2) - dist2 / (2 * sigma_p**2))
        num, den = num + weight * ext[i + k + r], den + weight
    got = bilateral_positions(p, sigma_t, sigma_p)
    np.testing.assert_allclose(got, num / den, atol=1e-12)
    # the weights at the ends really see the extension (not merely Eq. 4 on the clip)
    assert np.max(np.abs(got[:k] - bilateral_positions(p, sigma_t, np.inf)[:k])) > 1e-3


def test_sign_flips_and_short_signals():
    q = add_noise(smooth_rotations(25, 2, seed=7), 0.05, seed=8)
    flipped = q * np.where(np.random.default_rng(9).random((25, 2, 1)) < 0.5, -1.0, 1.0)
    a, b = bilateral(q, 1.0, 0.1, iterations=2), bilateral(flipped, 1.0, 0.1, iterations=2)
    np.testing.assert_allclose(np.abs(np.sum(a * b, axis=-1)), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(a, axis=-1), 1.0, atol=1e-12)
    for frames in (1, 2, 3):
        short = bilateral(q[:frames], 2.0, 0.1, iterations=2)
        assert short.shape == (frames, 2, 4) and np.all(np.isfinite(short))
    np.testing.assert_array_equal(
        bilateral(flipped, 1.0, 0.1, radius=0), quat.make_continuous(flipped)
    )


@pytest.mark.parametrize(("sigma_t", "radius"), [(1.0, None), (0.7, 5)])
def test_blocks_do_not_change_the_result(monkeypatch, sigma_t, radius):
    # A pass works through blocks of about quat.BLOCK_SAMPLES samples; the smallest blocks
    # (4k + 4 frames) must give the same result as one block: windows, the Eq. 26 extension
    # at both ends and the sign continuity carried across block boundaries.
    q = add_noise(smooth_rotations(150, 3, seed=13, speed=0.2), 0.05, seed=14)
    q = q * np.where(np.random.default_rng(15).random((150, 3, 1)) < 0.3, -1.0, 1.0)
    p = np.cumsum(np.random.default_rng(16).normal(size=(150, 3, 3)), axis=0)
    whole = bilateral(q, sigma_t, 0.1, radius=radius, iterations=2)
    whole_p = bilateral_positions(p, sigma_t, 1.5, radius=radius, iterations=2)
    monkeypatch.setattr(quat, "BLOCK_SAMPLES", 1)
    np.testing.assert_allclose(
        bilateral(q, sigma_t, 0.1, radius=radius, iterations=2), whole, atol=1e-12
    )
    np.testing.assert_allclose(
        bilateral_positions(p, sigma_t, 1.5, radius=radius, iterations=2), whole_p, atol=1e-12
    )
    # the input really has sign flips, and the output is sign-continuous
    assert np.any(np.sum(q[1:] * q[:-1], axis=-1) < 0.0)
    assert np.all(np.sum(whole[1:] * whole[:-1], axis=-1) > 0.0)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"sigma_t": 0.0, "sigma_g": 0.1},
        {"sigma_t": 1.0, "sigma_g": 0.0},
        {"sigma_t": 1.0, "sigma_g": float("nan")},
        {"sigma_t": 1.0, "sigma_g": 0.1, "radius": -1},
        {"sigma_t": 1.0, "sigma_g": 0.1, "radius": 1.5},
        {"sigma_t": 1.0, "sigma_g": 0.1, "iterations": -2},
    ],
)
def test_invalid_parameters(kwargs):
    with pytest.raises(ValueError):
        bilateral(quat.identity((4,)), **kwargs)


def test_invalid_sigma_p():
    with pytest.raises(ValueError, match="sigma_p"):
        bilateral_positions(np.zeros((4, 3)), 1.0, -1.0)


def fast_turn(frames: int = 200, copies: int = 8) -> np.ndarray:
    """A slow drift with a genuine 90-degree turn over 6 frames (peak ~30 deg/frame)."""
    t = np.arange(frames, dtype=np.float64)
    burst = np.where(np.abs(t - 100) < 3, 1 + np.cos(2 * np.pi * (t - 100) / 6), 0.0)
    vel = 0.002 + np.deg2rad(90.0) * burst / burst.sum()  # rotation angle per frame, rad
    angle = np.concatenate([[0.0], np.cumsum(vel[:-1])])
    axis = np.array([0.3, 0.8, 0.5]) / np.linalg.norm([0.3, 0.8, 0.5])
    start = quat.normalize(np.array([0.9, 0.1, -0.3, 0.2]))
    q = quat.multiply(start, quat.from_axis_angle(axis, angle))
    return np.repeat(q[:, None], copies, axis=1)


def peak_velocity_deg(q: np.ndarray) -> np.ndarray:
    """Peak rotation per frame (degrees) around the turn, per copy."""
    return np.degrees(quat.angle_between(q[89:110], q[90:111])).max(axis=0)


@pytest.mark.parametrize("iterations", [1, 5])
def test_edge_preservation_fast_turn(iterations):
    # 8 noisy copies (noise 0.01 log units, ~2 deg rms) of a 90-degree turn peaking at
    # 30.1 deg/frame; sigma_t = 2 frames for both filters, sigma_g = 0.05.
    # Measured peak error |peak - 30.1| (deg/frame), worst copy, 1 / 5 passes:
    #   Gaussian 14.6 / 22.2 (never below 13.9), bilateral 2.1 / 2.0.
    # Measured rms deviation from the clean signal away from the turn (deg), 1 / 5 passes:
    #   noisy 1.89-2.04, Gaussian 0.70-0.80 / 0.43-0.58, bilateral 0.73-0.83 / 0.42-0.56.
    clean = fast_turn()
    noisy = add_noise(clean, 0.01, seed=7)
    gauss = lee_shin(noisy, gaussian(2.0), iterations=iterations)
    bil = bilateral(noisy, 2.0, 0.05, iterations=iterations)
    peak = peak_velocity_deg(clean)
    err_gauss = np.abs(peak_velocity_deg(gauss) - peak)
    err_bil = np.abs(peak_velocity_deg(bil) - peak)
    assert np.all(err_gauss > 10.0)
    assert np.all(err_bil < 5.0)
    assert np.all(err_bil < 0.3 * err_gauss)

    # ... while smoothing the noise about as well as the Gaussian away from the turn.
    flat = np.r_[10:90, 110:190]

    def rms_dev(q):
        return np.sqrt(np.mean(np.degrees(quat.angle_between(q, clean))[flat] ** 2, axis=0))

    assert np.all(rms_dev(bil) < 0.5 * rms_dev(noisy))
    assert np.all(rms_dev(bil) < 1.25 * rms_dev(gauss))


@pytest.fixture(scope="module")
def rthumb():
    import motionclean

    motion = motionclean.load(corpus_clip("131_02.bvh"))
    return motion.rotations[:, motion.names.index("RThumb")]


@pytest.mark.parametrize("iterations", [1, 5])
def test_corpus_rthumb_flips_are_not_smeared(rthumb, iterations):
    # 131_02 RThumb toggles by half-turns (26 steps > 90 deg; the largest other step is
    # 11.7 deg). Deviation from the input on frames within 3 of a flip (flip frames
    # included, 148 frames), sigma_t = 1, sigma_g = 0.1, measured mean (deg), 1 / 5 passes:
    #   Gaussian 22.7 / 47.9, bilateral 0.21 / 0.60.
    step = np.degrees(quat.angle_between(rthumb[:-1], rthumb[1:]))
    flips = np.flatnonzero(step > 90.0)
    assert flips.size >= 20
    near = np.unique((flips[:, None] + np.arange(-2, 4)).ravel())
    near = near[near < rthumb.shape[0]]
    gauss = lee_shin(rthumb, gaussian(1.0), iterations=iterations)
    bil = bilateral(rthumb, 1.0, 0.1, iterations=iterations)
    dev_gauss = np.degrees(quat.angle_between(gauss, rthumb))[near].mean()
    dev_bil = np.degrees(quat.angle_between(bil, rthumb))[near].mean()
    assert dev_gauss > 15.0
    assert dev_bil < 1.5
    assert dev_bil < 0.05 * dev_gauss


def test_range_widths_too_small_or_large_to_square_are_the_limits(noisy):
    """sigma_g or sigma_p below 1e-162 squares to 0 (it had divided by zero: an internal
    error from the command line): it weighs as the narrowest width does, only identical
    samples count, so the signal comes back as it was; above 1e154 the square overflowed
    (an OverflowError): such a width weighs as inf does, the Gaussian Lee-Shin filter."""
    out = bilateral(noisy, sigma_t=2.0, sigma_g=1e-170)
    assert np.degrees(quat.angle_between(out, noisy)).max() < 1e-9
    p = np.cumsum(np.random.default_rng(3).normal(size=(60, 2, 3)), axis=0)
    np.testing.assert_allclose(bilateral_positions(p, sigma_t=2.0, sigma_p=1e-170), p, atol=1e-12)
    for huge in (1e300, np.inf):
        assert np.array_equal(
            bilateral(noisy, sigma_t=2.0, sigma_g=huge),
            bilateral(noisy, sigma_t=2.0, sigma_g=np.inf),
        )
        assert np.array_equal(
            bilateral_positions(p, sigma_t=2.0, sigma_p=huge),
            bilateral_positions(p, sigma_t=2.0, sigma_p=np.inf),
        )
