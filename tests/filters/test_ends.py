"""A signal continued past its ends by reflection about a fitted end pose (auto's ends)."""

from __future__ import annotations

import numpy as np
import pytest

from motionclean.core import quat
from motionclean.filters.auto import auto, auto_positions
from motionclean.filters.ends import (
    Padded,
    end_weights,
    fit_kernel,
    reflected_displacements,
)
from motionclean.filters.masks import binomial


def constant_turn(frames: int, columns: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``(F, C, 4)`` turns at constant angular velocity and that velocity ``(1, C, 3)``
    (half-angle units per frame)."""
    rng = np.random.default_rng(seed)
    start = quat.exp(rng.normal(0.0, 1.0, (1, columns, 3)))
    omega = rng.normal(0.0, 0.05, (1, columns, 3))
    return quat.multiply(start, quat.exp(np.arange(frames)[:, None, None] * omega)), omega


KERNELS = [fit_kernel(binomial(k), 100) for k in (1, 3, 6)]


def test_end_weights_fit_a_line_and_sum_to_one():
    kernel = fit_kernel(binomial(5), 100)
    h = end_weights(kernel)
    t = np.arange(h.size)
    assert h.sum() == pytest.approx(1.0, abs=1e-12)
    assert h @ (3.0 - 0.7 * t) == pytest.approx(3.0, abs=1e-12)  # a line's value at 0
    assert h @ (t**2) != pytest.approx(0.0)  # (a curve is not)
    assert end_weights(np.ones(1)).tolist() == [1.0]  # one sample: itself


def test_fit_kernel_keeps_a_masks_main_lobe():
    from motionclean.filters.design import lowpass

    mask = lowpass(5.0 / 120.0, 1.0, 60)
    kernel = fit_kernel(mask, 1000)
    assert np.all(kernel > 0) and kernel.size < mask.size // 2
    assert mask[mask.size // 2 + kernel.size] <= 0.0  # cut at the lobe's end
    assert fit_kernel(binomial(6), 4).size == 4  # never longer than the clip


@pytest.mark.parametrize("which", [np.array([0, 1, 2, -1]), np.array([2, 2, 0, 1])])
def test_a_constant_velocity_is_continued_exactly(which):
    q, omega = constant_turn(40, 4, seed=1)
    for end, signal in ((0, q), (1, q[::-1])):
        w = reflected_displacements(signal, KERNELS, which, 9, rotations=True)
        expected = omega if end == 0 else -omega  # reversed, the turn runs backwards
        assert np.abs(w - expected).max() < 1e-12
    p = 2.0 + np.arange(40)[:, None, None] * np.array([0.3, -0.1, 0.05])
    p = np.repeat(p, 4, axis=1)
    d = reflected_displacements(p, KERNELS, which, 9, rotations=False)
    assert np.abs(d - [0.3, -0.1, 0.05]).max() < 1e-12


@pytest.mark.parametrize("frames", [5, 30, 60])
def test_a_mask_wider_than_the_clip_keeps_a_constant_velocity(frames):
    """A short clip gets the widest masks: a Savitzky-Golay mask of half-width 60 on 60
    frames reads 60 samples past each end, more than the clip holds; beyond its far end
    Eq. 26's mirror had turned the motion back (a constant turn's end frames moved 0.1-2
    degrees). Continued by point reflections, the turn and the line stay fixed points."""
    q, _ = constant_turn(frames, 3, seed=2)
    out = auto(q, 1 / 120, noise=3.0, families=("savgol",))
    assert all(c.mask == "savgol" and c.value >= frames - 1 for c in out.choices)
    assert np.degrees(quat.angle_between(out.values, q)).max() < 1e-9
    p = 2.0 + np.arange(frames)[:, None, None] * np.array([[0.3, -0.1, 0.05]] * 3)
    moved = auto_positions(p, 1 / 120, noise=0.5, families=("savgol",)).values - p
    assert np.abs(moved).max() < 1e-9


def test_the_reflection_is_coordinate_invariant():
    rng = np.random.default_rng(2)
    q, _ = constant_turn(30, 3, seed=3)
    q = quat.multiply(q, quat.exp(rng.normal(0.0, 0.05, q.shape[:-1] + (3,))))
    which = np.array([0, 1, 2])
    w = reflected_displacements(q, KERNELS, which, 8, rotations=True)
    g, h = (quat.exp(rng.normal(0.0, 1.0, 3)) for _ in range(2))
    left = reflected_displacements(quat.multiply(g, q), KERNELS, which, 8, rotations=True)
    right = reflected_displacements(quat.multiply(q, h), KERNELS, which, 8, rotations=True)
    assert np.abs(left - w).max() < 1e-12  # displacements are in each sample's own frame
    turned = quat.rotate(quat.conjugate(h), w)  # ... which a right change of frame turns
    assert np.abs(right - turned).max() < 1e-12


def test_auto_pulls_a_clips_end_frames_towards_the_motion():
    """Eq. 26's mirror kept the end frames with 0.8 of their noise (a symmetric mask's
    pairs cancel about the end sample); reflected about a fitted end pose, under 0.6."""
    frames, columns, deg = 240, 400, 3.0
    truth, _ = constant_turn(frames, columns, seed=4)
    rng = np.random.default_rng(5)
    sigma = np.radians(deg) / (2.0 * np.sqrt(3.0))
    noisy = quat.multiply(truth, quat.exp(rng.normal(0.0, sigma, (frames, columns, 3))))
    error = np.degrees(quat.angle_between(auto(noisy, 1 / 60).values, truth))
    rms = np.sqrt(np.mean(error**2, axis=1)) / deg
    assert rms[0] < 0.6 and rms[-1] < 0.6
    assert rms[60:-60].mean() < 0.3
    p = np.arange(frames)[:, None, None] * rng.normal(0.0, 0.1, (1, columns, 3))
    moved = auto_positions(p + rng.normal(0.0, 1.0, p.shape), 1 / 60).values
    rms = np.sqrt(np.mean(np.sum((moved - p) ** 2, axis=-1), axis=1) / 3.0)
    assert rms[0] < 0.6 and rms[-1] < 0.6


def test_padded_rows_read_as_one_array():
    inside = np.arange(30.0).reshape(10, 1, 3)
    before, after = -np.ones((3, 1, 3)), np.full((2, 1, 3), 99.0)
    padded = Padded(inside, before, after)
    whole = np.concatenate([before, inside, after])
    assert padded.shape == whole.shape
    for low in range(whole.shape[0] + 1):
        for high in range(low, whole.shape[0] + 1):
            assert np.array_equal(padded[low:high], whole[low:high])
