"""Filter masks: validation and the masks of paper 000 (Eq. 21-25) and 003 (Eq. 13)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from motionclean.filters import lee_shin
from motionclean.filters.design import lowpass, savgol
from motionclean.filters.masks import (
    EXACT_BINOMIAL_K,
    MAX_HALF_WIDTH,
    MaskError,
    binomial,
    custom,
    gaussian,
    high_boost,
    reduction,
    smoothing,
    validate_mask,
)


def correlate(p: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``sum_m a_m p_{i+m}`` on the samples whose window lies inside ``p`` (000 Eq. 15)."""
    return np.convolve(p, mask[::-1], mode="valid")


@pytest.mark.parametrize(
    ("mask", "needle"),
    [
        ([0.5, 0.5], "odd length"),
        ([0.25, 0.25, 0.25, 0.25], "odd length"),
        ([0.2, 0.3, 0.2], "sum to 0.7"),
        ([0.25, 0.5, 0.25 + 2e-9], "sum to 1.000000002"),
        ([], "non-empty"),
        ([[0.5, 0.5]], "shape"),
        ([0.5, np.nan, 0.5], "finite"),
    ],
)
def test_invalid_masks_are_rejected_with_a_clear_message(mask, needle):
    with pytest.raises(MaskError, match=needle.replace(".", r"\.")):
        validate_mask(mask)
    with pytest.raises(MaskError):
        custom(mask)
    with pytest.raises(MaskError):  # and no filter runs with it
        lee_shin(np.tile([1.0, 0.0, 0.0, 0.0], (8, 1)), mask)


def test_sum_tolerance_is_1e_9():
    validate_mask([0.25, 0.5, 0.25 + 5e-10])
    with pytest.raises(MaskError, match="sum to"):
        validate_mask([0.25, 0.5, 0.25 + 5e-9])
    np.testing.assert_array_equal(custom([0.25, 0.5, 0.25]), [0.25, 0.5, 0.25])
    np.testing.assert_array_equal(custom([1]), [1.0])


@pytest.mark.parametrize("k", range(8))
def test_binomial_matches_eq_23(k):
    # B_i^{2k+1} = (2k)! / ((k-i)! (k+i)!) / 2^{2k}, -k <= i <= k
    expected = [
        math.factorial(2 * k) / (math.factorial(k - i) * math.factorial(k + i)) / 4**k
        for i in range(-k, k + 1)
    ]
    mask = binomial(k)
    np.testing.assert_allclose(mask, expected, rtol=1e-15)
    validate_mask(mask)
    np.testing.assert_array_equal(mask, mask[::-1])


def test_binomial_b5_and_bad_half_widths():
    np.testing.assert_array_equal(binomial(2), np.array([1, 4, 6, 4, 1]) / 16)
    for bad in (-1, 1.5):
        with pytest.raises(MaskError, match="non-negative integer"):
            binomial(bad)


@pytest.mark.parametrize("lam", [0.1, 0.5, 1.0])
def test_smoothing_is_one_fourth_order_fairing_step(lam):
    # 000 Eq. 21: p_i <- p_i - (lam / 24) * (4th central difference of p at i), the update
    # whose mask is (-lam, 4 lam, 24 - 6 lam, 4 lam, -lam) / 24.
    p = np.random.default_rng(0).normal(size=40)
    mask = smoothing(lam)
    validate_mask(mask)
    np.testing.assert_allclose(correlate(p, mask), p[2:-2] - lam / 24 * np.diff(p, 4), atol=1e-13)


@pytest.mark.parametrize("lam", [0.25, 1.0, 2.0])
def test_high_boost_is_original_plus_lam_high_pass(lam):
    # 000 Sec. V-C: high-boost = original + lam (original - B^5 original)
    p = np.random.default_rng(1).normal(size=40)
    mask = high_boost(lam)
    validate_mask(mask)
    blurred = correlate(p, binomial(2))
    np.testing.assert_allclose(correlate(p, mask), p[2:-2] + lam * (p[2:-2] - blurred), atol=1e-13)


def test_reduction_is_the_lambda_one_fairing_mask():
    # 003 Eq. 13's reduction mask (-1, 4, 18, 4, -1) / 24 is 000's smoothing mask at lam = 1.
    validate_mask(reduction())
    np.testing.assert_allclose(reduction(), smoothing(1.0), rtol=0, atol=1e-16)
    np.testing.assert_allclose(reduction() * 24, [-1, 4, 18, 4, -1], rtol=1e-15)


@pytest.mark.parametrize(("sigma_t", "radius"), [(0.5, None), (1.0, None), (2.5, 4)])
def test_gaussian_mask(sigma_t, radius):
    mask = gaussian(sigma_t, radius)
    validate_mask(mask)
    r = math.ceil(3 * sigma_t) if radius is None else radius
    assert mask.size == 2 * r + 1
    offsets = np.arange(-r, r + 1)
    np.testing.assert_allclose(mask / mask[r], np.exp(-(offsets**2) / (2 * sigma_t**2)), rtol=1e-14)
    with pytest.raises(MaskError, match="positive"):
        gaussian(0.0)


@pytest.mark.parametrize(
    ("radius", "error", "message"),
    [
        ("3", TypeError, "radius: expected a number, got str"),
        (True, TypeError, "radius: expected a number, got bool"),
        (-1, MaskError, "radius must be a non-negative whole number of frames, got -1"),
        (2.7, MaskError, "got 2.7"),
        (math.nan, MaskError, "got nan"),
        (math.inf, MaskError, "got inf"),
    ],
)
def test_gaussian_refuses_a_radius_that_is_no_whole_number_of_frames(radius, error, message):
    """As binomial's k: '3' had given 7 taps, 2.7 five and -1 an empty mask."""
    with pytest.raises(error, match=re.escape(message)):
        gaussian(1.0, radius)
    assert gaussian(1.0, 2.0).size == gaussian(1.0, np.int64(2)).size == 5
    assert np.array_equal(gaussian(1.0, 0), [1.0])


def test_wide_binomial_masks_do_not_overflow():
    # 4^k and C(2k, k) overflow float64 beyond k ~ 511; the mask must not
    exact = binomial(EXACT_BINOMIAL_K)
    for k in (EXACT_BINOMIAL_K + 1, 600, MAX_HALF_WIDTH):
        b = binomial(k)
        assert np.all(np.isfinite(b)) and abs(b.sum() - 1.0) < 1e-12
        assert np.array_equal(b, b[::-1]) and b.argmax() == k
    # the two constructions agree where they meet: B^{2k+3} = B^{2k+1} * (1/4, 1/2, 1/4)
    stepped = np.convolve(exact, [0.25, 0.5, 0.25])
    np.testing.assert_allclose(binomial(EXACT_BINOMIAL_K + 1), stepped, rtol=1e-10, atol=1e-300)


@pytest.mark.parametrize(
    ("make", "what"),
    [
        (lambda: binomial(10**9), "a binomial mask of half-width 1000000000 frames"),
        (lambda: savgol(10**9), "a Savitzky-Golay mask of half-width 1000000000 frames"),
        (lambda: lowpass(5.0, 30.0, 10**9), "a low-pass mask of half-width 1000000000 frames"),
        (lambda: custom([0.0] * 5001 + [1.0] + [0.0] * 5001), "a mask of half-width 5001"),
    ],
)
def test_a_mask_wider_than_the_widest_is_refused_before_it_is_made(make, what):
    """binomial(10**9) had filled 24 GB before the kernel ended it; a pipeline's custom
    coefficients had no bound (a million taps ran in 1.2 GB)."""
    with pytest.raises(MaskError, match=f"^{what}.*: at most {MAX_HALF_WIDTH}$"):
        make()
    assert custom([0.0] * 5000 + [1.0] + [0.0] * 5000).size == 2 * MAX_HALF_WIDTH + 1
