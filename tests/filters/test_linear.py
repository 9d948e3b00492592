"""Lee-Shin filter (paper 000): Propositions 1-3, Sec. VII, Eq. 19-26, and the CLI on the corpus."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from helpers import CORPUS_NAMES, SAMPLE, corpus_clip

import motionclean as mc
from motionclean.cli.main import main
from motionclean.core import quat
from motionclean.filters.linear import (
    displacement_coefficients,
    lee_shin,
    lee_shin_between,
    lee_shin_positions,
    mirror_indices,
)
from motionclean.filters.masks import binomial, custom, gaussian, high_boost, reduction, smoothing

ASYMMETRIC = np.array([0.1, 0.3, 0.35, 0.2, 0.05])
SYMMETRIC_MASKS = {
    "binomial(1)": binomial(1),
    "binomial(2)": binomial(2),
    "binomial(3)": binomial(3),
    "smoothing(0.7)": smoothing(0.7),
    "high_boost(2)": high_boost(2.0),
    "gaussian(1.3)": gaussian(1.3),
    "reduction": reduction(),
}


def random_rotations(rng, shape) -> np.ndarray:
    return quat.normalize(rng.normal(size=(*shape, 4)))


def noisy_signal(frames: int, joints: int, seed: int, noise: float = 0.05) -> np.ndarray:
    """Smooth random rotations (exp of a random walk) times ``exp(n_i)`` noise (000 Sec. VI-B)."""
    rng = np.random.default_rng(seed)
    path = np.cumsum(rng.normal(scale=0.05, size=(frames, joints, 3)), axis=0)
    smooth = quat.multiply(random_rotations(rng, (joints,)), quat.exp(path))
    noisy = quat.multiply(smooth, quat.exp(rng.normal(scale=noise, size=(frames, joints, 3))))
    return quat.make_continuous(noisy, axis=0)


def constant_velocity(frames: int, omega: np.ndarray, start: np.ndarray) -> np.ndarray:
    """``q_i = start exp(i omega)`` for each trailing signal."""
    i = np.arange(frames, dtype=np.float64).reshape(-1, *([1] * omega.ndim))
    return quat.multiply(start, quat.exp(i * omega))


def displacements(q: np.ndarray) -> np.ndarray:
    return quat.log(quat.multiply(quat.conjugate(q[:-1]), q[1:]))


def max_angle(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(quat.angle_between(a, b)))


@pytest.fixture(scope="module")
def corpus_rotations() -> np.ndarray:
    return mc.load(corpus_clip("131_02.bvh")).rotations


@pytest.fixture(params=["random", "corpus"])
def signal(request) -> np.ndarray:
    if request.param == "corpus":
        return request.getfixturevalue("corpus_rotations")
    return noisy_signal(150, 5, seed=1)


# ----------------------------------------------------------------------------- Prop. 1-3


@pytest.mark.parametrize(
    "mask",
    [binomial(2), smoothing(0.5), high_boost(0.5), ASYMMETRIC],
    ids=["binomial", "smoothing", "high_boost", "asymmetric"],
)
@pytest.mark.parametrize("iterations", [1, 3])
def test_coordinate_invariance_both_sides(signal, mask, iterations):
    # 000 Prop. 1: H(a q b) = a H(q) b for a global a and a per-joint (local) b.
    rng = np.random.default_rng(2)
    a = random_rotations(rng, ())
    b = random_rotations(rng, (signal.shape[1],))
    out = lee_shin(signal, mask, iterations)
    moved = lee_shin(quat.multiply(quat.multiply(a, signal), b), mask, iterations)
    assert max_angle(moved, quat.multiply(quat.multiply(a, out), b)) < 1e-9
    assert max_angle(out, signal) > 1e-3  # the filter did change the signal


@pytest.mark.parametrize("mask", [binomial(2), ASYMMETRIC], ids=["binomial", "asymmetric"])
@pytest.mark.parametrize("iterations", [1, 2])
def test_time_invariance_in_the_interior(signal, mask, iterations):
    # 000 Prop. 2: dropping the first l frames (a shift) shifts the output, except within
    # iterations * k frames of the new start, where the Eq. 26 boundary differs.
    shift, reach = 7, iterations * (mask.size // 2)
    out = lee_shin(signal, mask, iterations)
    shifted = lee_shin(signal[shift:], mask, iterations)
    assert max_angle(shifted[reach:], out[shift + reach :]) < 1e-12
    assert max_angle(shifted[:reach], out[shift : shift + reach]) > 1e-6  # the boundary acts
    # and the same at the other end
    cut = lee_shin(signal[:-shift], mask, iterations)
    assert max_angle(cut[:-reach], out[: -shift - reach]) < 1e-12


def test_symmetry_for_symmetric_masks(signal):
    # 000 Prop. 3: reversing time commutes with the filter of a symmetric mask, at every
    # sample (the Eq. 26 mirror is symmetric too); an asymmetric mask becomes its reverse.
    for mask in (binomial(2), smoothing(0.8), high_boost(1.0)):
        forward = lee_shin(signal, mask, 2)
        backward = lee_shin(signal[::-1], mask, 2)[::-1]
        assert max_angle(forward, backward) < 1e-12
    reversed_input = lee_shin(signal[::-1], ASYMMETRIC)[::-1]
    assert max_angle(reversed_input, lee_shin(signal, ASYMMETRIC[::-1])) < 1e-12
    assert max_angle(reversed_input, lee_shin(signal, ASYMMETRIC)) > 1e-4


@pytest.mark.parametrize("block_samples", [None, 40])
def test_antipodal_sign_flips_do_not_change_the_output(signal, block_samples, monkeypatch):
    # 000 Sec. VI-A: q and -q are the same rotation; the filter sees the sign-continuous signal.
    if block_samples is not None:  # many small blocks: the running sign crosses block edges
        monkeypatch.setattr(quat, "BLOCK_SAMPLES", block_samples)
    rng = np.random.default_rng(3)
    signs = rng.choice([-1.0, 1.0], size=(*signal.shape[:-1], 1))
    flipped = signal * signs
    out = lee_shin(flipped, binomial(2), 2)
    assert max_angle(out, lee_shin(signal, binomial(2), 2)) < 1e-12
    assert np.all(np.sum(out[1:] * out[:-1], axis=-1) > 0.0)  # sign-continuous output
    assert np.all(np.sum(out[0] * flipped[0], axis=-1) > 0.0)  # ... from the first sample's sign


def test_block_size_does_not_change_the_result(signal, monkeypatch):
    reference = lee_shin(signal, gaussian(2.0), 3)
    monkeypatch.setattr(quat, "BLOCK_SAMPLES", 1)  # blocks of 4k + 4 frames
    np.testing.assert_array_equal(lee_shin(signal, gaussian(2.0), 3), reference)


# ----------------------------------------------------------------------------- Sec. VII


def test_fig6_singular_configuration_of_renormalisation():
    # 000 Sec. VII-A, Fig. 6: five samples evenly spaced on a great circle of S^3 under the
    # average mask (1/5, ..., 1/5). Their component-wise average is zero, so re-normalising
    # it is undefined; the Lee-Shin response is the middle sample (the displacements cancel).
    rng = np.random.default_rng(4)
    axis = quat.normalize(rng.normal(size=3))
    angles = np.arange(5) * 2 * np.pi / 5  # 72 degrees apart in S^3
    arc = np.concatenate([np.cos(angles)[:, None], np.sin(angles)[:, None] * axis], axis=-1)
    a, b = random_rotations(rng, ()), random_rotations(rng, ())
    for samples in (arc, quat.multiply(quat.multiply(a, arc), b)):  # any coordinate frame
        average = np.mean(samples, axis=0)
        assert np.linalg.norm(average) < 1e-12  # vs 1 for the samples: nothing to normalise
        out = lee_shin(samples, np.full(5, 0.2))
        assert max_angle(out[2], samples[2]) < 1e-12
    # Just off the singular spacing the naive result exists but depends on the signs chosen
    # for the samples (q and -q are one rotation); the Lee-Shin result does not.
    angles = np.arange(5) * 2 * np.pi / 5 * 0.9
    near = np.concatenate([np.cos(angles)[:, None], np.sin(angles)[:, None] * axis], axis=-1)
    flipped = near * np.array([1.0, -1.0, 1.0, 1.0, 1.0])[:, None]
    naive = [quat.normalize(np.mean(s, axis=0)) for s in (near, flipped)]
    assert quat.angle_between(naive[0], naive[1]) > 1.0
    assert max_angle(lee_shin(near, np.full(5, 0.2)), lee_shin(flipped, np.full(5, 0.2))) < 1e-12


def cumulative_filter(q: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """000 Eq. 28 (Fang et al.): q_0 prod_{j<i} exp(F(w_j)), the mask applied to displacements."""
    w = displacements(q)
    k = mask.size // 2
    ext = w[mirror_indices(w.shape[0], k, k)]
    filtered = sum(coeff * ext[tap : tap + w.shape[0]] for tap, coeff in enumerate(mask))
    out = [q[0]]
    for step in quat.exp(filtered):  # the cumulation is sequential by definition
        out.append(quat.multiply(out[-1], step))
    return np.stack(out)


@pytest.mark.parametrize("iterations", [1, 3])
def test_no_drift_a_local_change_stays_local(iterations):
    # 000 Sec. VII-C: H has the support of the mask, so perturbing q_j changes exactly the
    # outputs within iterations * k frames of j; the cumulative filter (Eq. 28) carries the
    # change to the end of the signal.
    q = noisy_signal(120, 3, seed=5)
    mask, j = binomial(2), 50
    reach = iterations * 2
    bumped = q.copy()
    bumped[j] = quat.multiply(q[j], quat.exp(np.array([0.05, -0.02, 0.03])))
    before, after = lee_shin(q, mask, iterations), lee_shin(bumped, mask, iterations)
    outside = np.r_[0 : j - reach, j + reach + 1 : q.shape[0]]
    np.testing.assert_array_equal(after[outside], before[outside])
    assert np.all(
        quat.angle_between(after[j - reach : j + reach + 1], before[j - reach : j + reach + 1])
        > 1e-9
    )
    drift = quat.angle_between(cumulative_filter(bumped, mask)[-1], cumulative_filter(q, mask)[-1])
    assert np.all(drift > 1e-3)


@pytest.mark.parametrize("name", list(SYMMETRIC_MASKS))
@pytest.mark.parametrize("frames", [2, 3, 6, 200])
def test_constant_angular_velocity_is_a_fixed_point(name, frames):
    # Eq. 26 mirrors equal displacements, and sum_m b_m = 0 for a symmetric mask: every
    # sample, the first and the last included, stays where it is.
    rng = np.random.default_rng(6)
    speeds = np.array([0.0, 1e-7, 0.05, 0.4, 1.4])  # |w| per frame, up to ~160 degrees
    omega = rng.normal(size=(5, 3))
    omega *= (speeds / np.linalg.norm(omega, axis=-1))[:, None]
    q = constant_velocity(frames, omega, random_rotations(rng, (5,)))
    out = lee_shin(q, SYMMETRIC_MASKS[name], 4)
    # The samples themselves carry ~1e-13 rad of rounding (exp of i * omega up to 280 rad),
    # which 4 passes of high_boost(2) amplify up to 3^4 times.
    assert max_angle(out, q) < 1e-10


# ----------------------------------------------------------------------------- Eq. 19-25


def explicit_filter(q: np.ndarray, coeffs, scale: float) -> np.ndarray:
    """``q_i exp(scale (c0 w_{i-2} + c1 w_{i-1} + c2 w_i + c3 w_{i+1}))``, Eq. 26 by np.pad."""
    w = displacements(q)
    ext = np.pad(w, [(2, 2), (0, 0), (0, 0)], mode="reflect")  # positions -2 .. n+1
    n = q.shape[0]
    s = sum(c * ext[tap : tap + n] for tap, c in enumerate(coeffs))
    return quat.multiply(q, quat.exp(scale * s))


@pytest.mark.parametrize("block_samples", [None, 64])
def test_general_filter_matches_eq_22_24_25(signal, block_samples, monkeypatch):
    if block_samples is not None:
        monkeypatch.setattr(quat, "BLOCK_SAMPLES", block_samples)
    lam = 0.6
    cases = [
        (smoothing(lam), (1, -3, 3, -1), lam / 24),  # Eq. 22, H^S
        (binomial(2), (-1, -5, 5, 1), 1 / 16),  # Eq. 24, H^B
        (high_boost(lam), (1, 5, -5, -1), lam / 16),  # Eq. 25, H^U
    ]
    for mask, coeffs, scale in cases:
        assert max_angle(lee_shin(signal, mask), explicit_filter(signal, coeffs, scale)) < 1e-12


def test_displacement_coefficients_eq_20():
    rng = np.random.default_rng(7)
    for k in (1, 2, 4):
        a = rng.uniform(-1, 1, size=2 * k + 1)
        a /= a.sum()
        expected = [-a[: m + k + 1].sum() if m < 0 else a[m + k + 1 :].sum() for m in range(-k, k)]
        np.testing.assert_allclose(displacement_coefficients(a), expected, atol=1e-15)
        # Eq. 17-19 on vectors: p_i + sum_m b_m d_{i+m} = sum_m a_m p_{i+m}
        p = rng.normal(size=30)
        d = np.diff(p)
        b = displacement_coefficients(a)
        gain = sum(b[m + k] * d[k + m : 30 - k + m] for m in range(-k, k))
        np.testing.assert_allclose(p[k:-k] + gain, np.convolve(p, a[::-1], "valid"), atol=1e-13)


@pytest.mark.parametrize(
    "mask", [binomial(2), ASYMMETRIC, gaussian(1.5)], ids=["binomial", "asymmetric", "gaussian"]
)
@pytest.mark.parametrize("iterations", [1, 2])
def test_vector_counterpart_is_convolution_in_the_interior(mask, iterations):
    rng = np.random.default_rng(8)
    p = np.cumsum(rng.normal(size=(90, 4, 3)), axis=0)
    out = lee_shin_positions(p, mask, iterations)
    expected = p
    for _ in range(iterations):
        expected = np.apply_along_axis(np.convolve, 0, expected, mask[::-1], "valid")
    reach = iterations * (mask.size // 2)
    np.testing.assert_allclose(out[reach:-reach], expected, atol=1e-12)
    # linear motion (affine invariance + Eq. 26) is kept at every sample for symmetric masks
    line = np.arange(40)[:, None] * rng.normal(size=3) + rng.normal(size=3)
    np.testing.assert_allclose(lee_shin_positions(line, binomial(3), 3), line, atol=1e-12)


# ----------------------------------------------------------------------------- edge cases


def test_shapes_short_signals_and_argument_checks():
    rng = np.random.default_rng(9)
    q = noisy_signal(40, 6, seed=10).reshape(40, 2, 3, 4)
    frozen = q.copy()
    out = lee_shin(q, binomial(2))
    np.testing.assert_array_equal(q, frozen)  # input untouched
    assert out.shape == q.shape
    np.testing.assert_array_equal(out.reshape(40, 6, 4), lee_shin(q.reshape(40, 6, 4), binomial(2)))
    np.testing.assert_array_equal(lee_shin(q[:, 0, 0], binomial(2)), out[:, 0, 0])  # (F, 4)
    strided = np.asfortranarray(q)[::2]
    np.testing.assert_array_equal(
        lee_shin(strided, binomial(1)), lee_shin(q[::2].copy(), binomial(1))
    )
    one = random_rotations(rng, (1, 3))
    np.testing.assert_array_equal(lee_shin(one, binomial(2)), one)
    np.testing.assert_array_equal(lee_shin(q, custom([1.0])), q)  # identity mask
    np.testing.assert_array_equal(lee_shin(q, binomial(2), iterations=0), q)
    for bad in (-1, 1.5):
        with pytest.raises(ValueError, match="iterations"):
            lee_shin(q, binomial(2), iterations=bad)
    with pytest.raises(ValueError, match="4"):
        lee_shin(q[..., :3], binomial(2))


# ----------------------------------------------------------------------------- CLI, corpus


def run_cli(*args: str) -> None:
    with pytest.raises(SystemExit) as done:
        main(list(args))
    assert done.value.code == 0


def motion_section(path: Path) -> bytes:
    data = path.read_bytes()
    return data[data.index(b"MOTION") :]


@pytest.mark.parametrize("name", CORPUS_NAMES)
@pytest.mark.parametrize("cut_deg", [90.0, 180.0])
def test_cli_clean_matches_lee_shin_on_corpus(name, cut_deg, tmp_path):
    """The step is the library's filter, cut at the step's cut_deg (180: 000's as printed;
    the corpus's RThumb flips by half turns, which a cut of 90 degrees leaves as flips)."""
    clip = corpus_clip(name)
    out_path = tmp_path / "clean.bvh"
    run_cli(
        "clean",
        str(clip),
        "-o",
        str(out_path),
        "-q",
        "-f",
        f"lee-shin:mask=binomial,k=2,iterations=5,cut_deg={cut_deg}",
    )
    source, cleaned = mc.load(clip), mc.load(out_path)
    has_rot = source.layout.has_rotation
    cut = math.radians(cut_deg)
    expected = lee_shin(source.rotations, binomial(2), 5, cut)
    error_deg = np.degrees(quat.angle_between(cleaned.rotations, expected))[:, has_rot]
    assert error_deg.max() < 1e-4  # only the file's 6 printed decimals
    assert np.degrees(max_angle(cleaned.rotations, source.rotations)) > 1.0  # it did filter
    has_pos = source.layout.has_position
    expected_pos = lee_shin_positions(source.translations[:, has_pos], binomial(2), 5)
    np.testing.assert_allclose(cleaned.translations[:, has_pos], expected_pos, atol=1e-5)


@pytest.mark.parametrize("name", ["sample", *CORPUS_NAMES])
def test_identity_step_writes_the_input_motion_unchanged(name, tmp_path):
    clip = SAMPLE if name == "sample" else corpus_clip(name)
    out_path = tmp_path / "same.bvh"
    run_cli(
        "clean", str(clip), "-o", str(out_path), "-q", "-f", "lee-shin:mask=custom,coefficients=[1]"
    )
    assert motion_section(out_path) == motion_section(clip)


@pytest.mark.parametrize("frames", [2, 3, 7, 60])
@pytest.mark.parametrize("k", [1, 40, 500])
def test_a_mask_longer_than_the_clip_is_eq_19_over_the_mirrored_clip(frames, k):
    """Eq. 19 summed tap by tap over the displacements extended by Eq. 26 (here, directly)
    is what the filter gives, whatever the mask's length against the clip's: a mask
    longer than the mirrored period is folded onto it (k = 5,000 on 300 frames: 13 times
    faster), the sums the same to rounding."""
    clip = mc.load(SAMPLE)
    q = quat.make_continuous(clip.rotations[:frames, :5], axis=0)
    p = clip.translations[:frames, :5]
    mask = binomial(k)
    b = displacement_coefficients(mask)
    half, n = b.size // 2, frames - 1
    around = mirror_indices(n, half, half)
    w = quat.log_shortest(quat.relative(q[:-1], q[1:]))[around]
    d = (p[1:] - p[:-1])[around]
    s = np.stack([np.tensordot(b, w[i : i + b.size], axes=(0, 0)) for i in range(frames)])
    moved = np.stack([np.tensordot(b, d[i : i + b.size], axes=(0, 0)) for i in range(frames)])
    expected = quat.multiply(q, quat.exp(s))
    assert np.degrees(quat.angle_between(lee_shin(q, mask), expected)).max() < 1e-12
    np.testing.assert_allclose(lee_shin_positions(p, mask), p + moved, rtol=0, atol=1e-12)


@pytest.mark.parametrize("k", [1, 3, 9])
@pytest.mark.parametrize("iterations", [1, 2])
def test_filtering_between_cuts_is_filtering_each_stretch_on_its_own(k, iterations):
    """lee_shin_between is lee_shin run on each stretch between its cuts, concatenated:
    the frames next to a cut included, stretches shorter than the mask (one frame: kept)
    too, each column cut at its own steps."""
    rng = np.random.default_rng(k + 10 * iterations)
    q = noisy_signal(40, 5, seed=k)
    cuts = rng.random((39, 5)) < 0.1
    cuts[:, 0] = False  # a column with no cut: the plain pass
    cuts[[12, 13, 30], 1] = True  # a stretch of one frame
    mask = binomial(k)
    out = lee_shin_between(q, displacement_coefficients(mask), cuts, iterations)
    for j in range(q.shape[1]):
        stretches = np.split(q[:, j], np.flatnonzero(cuts[:, j]) + 1)
        expected = np.concatenate([lee_shin(s, mask, iterations) for s in stretches])
        assert np.degrees(quat.angle_between(out[:, j], expected)).max() < 1e-9
