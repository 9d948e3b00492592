"""Masks designed the way users think: Savitzky-Golay and a low-pass cutoff in Hz."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionclean.core import quat
from motionclean.filters.design import default_lowpass_half_width, lowpass, savgol
from motionclean.filters.linear import lee_shin, lee_shin_positions
from motionclean.filters.masks import MaskError, validate_mask

SAVGOL_CASES = [(1, 0), (2, 2), (3, 2), (5, 3), (7, 4), (12, 2), (20, 6)]
LOWPASS_CASES = [(8.0, 120.0), (2.0, 120.0), (14.0, 120.0), (5.0, 30.0), (12.0, 30.0)]


def response(mask: np.ndarray, n_fft: int = 1 << 14):
    """Gain |H(f)| of a centred mask at frequencies ``f`` in cycles per frame (np.fft)."""
    k = mask.size // 2
    padded = np.zeros(n_fft)
    padded[: k + 1] = mask[k:]  # taps 0..k at the start, taps -k..-1 wrapped to the end
    if k:
        padded[-k:] = mask[:k]
    return np.fft.rfftfreq(n_fft), np.abs(np.fft.rfft(padded))


def constant_velocity(frames: int) -> np.ndarray:
    start = quat.normalize(np.array([[0.3, -0.5, 0.7, 0.2], [0.9, 0.1, -0.2, 0.4]]))
    omega = np.array([[0.03, -0.02, 0.05], [-0.11, 0.04, 0.02]])  # log units per frame
    i = np.arange(frames, dtype=np.float64)[:, None, None]
    return quat.multiply(start, quat.exp(i * omega))


# ----------------------------------------------------------------------------- savgol


@pytest.mark.parametrize(("half_width", "degree"), SAVGOL_CASES)
def test_savgol_is_a_valid_symmetric_mask(half_width, degree):
    mask = savgol(half_width, degree)
    validate_mask(mask)
    assert mask.size == 2 * half_width + 1
    assert abs(mask.sum() - 1.0) < 1e-12
    np.testing.assert_allclose(mask, mask[::-1], atol=1e-13)


def test_savgol_matches_the_classical_tables():
    # Savitzky & Golay (1964): 5-point quadratic (-3, 12, 17, 12, -3) / 35,
    # 7-point quadratic (-2, 3, 6, 7, 6, 3, -2) / 21; degree 0 is the moving average.
    np.testing.assert_allclose(savgol(2, 2), np.array([-3, 12, 17, 12, -3]) / 35, atol=1e-14)
    np.testing.assert_allclose(savgol(3, 3), np.array([-2, 3, 6, 7, 6, 3, -2]) / 21, atol=1e-14)
    np.testing.assert_allclose(savgol(4, 0), np.full(9, 1 / 9), atol=1e-15)
    np.testing.assert_allclose(savgol(3, 6), np.eye(7)[3], atol=1e-12)  # interpolates


@pytest.mark.parametrize(("half_width", "degree"), [(2, 2), (5, 3), (7, 4), (12, 2), (9, 6)])
def test_savgol_reproduces_polynomials_of_its_degree_in_the_interior(half_width, degree):
    rng = np.random.default_rng(degree * 100 + half_width)
    t = (np.arange(60) - 30) / 10.0
    coeffs = rng.normal(size=(degree + 1, 3))
    p = sum(c * t[:, None] ** n for n, c in enumerate(coeffs))  # (60, 3), degree `degree`
    out = lee_shin_positions(p, savgol(half_width, degree))
    inner = slice(half_width, -half_width)
    np.testing.assert_allclose(out[inner], p[inner], rtol=0, atol=1e-10 * np.abs(p).max())
    # The next even degree is not reproduced: the mask does smooth.
    even_up = degree + 2 - degree % 2
    q = p + t[:, None] ** even_up
    assert np.abs(lee_shin_positions(q, savgol(half_width, degree))[inner] - q[inner]).max() > 1e-4


@pytest.mark.parametrize(("half_width", "degree"), [(1, 3), (0, 1), (-1, 0), (2.5, 2), (3, -1)])
def test_savgol_rejects_impossible_fits(half_width, degree):
    with pytest.raises(MaskError):
        savgol(half_width, degree)


# ----------------------------------------------------------------------------- lowpass


@pytest.mark.parametrize(("cutoff", "rate"), LOWPASS_CASES)
def test_lowpass_is_a_valid_symmetric_mask(cutoff, rate):
    mask = lowpass(cutoff, rate)
    validate_mask(mask)
    assert mask.size == 2 * default_lowpass_half_width(cutoff, rate) + 1
    assert default_lowpass_half_width(cutoff, rate) == math.ceil(2 * rate / cutoff)
    np.testing.assert_allclose(mask, mask[::-1], atol=1e-15)
    assert abs(mask.sum() - 1.0) < 1e-12


@pytest.mark.parametrize(("cutoff", "rate"), LOWPASS_CASES)
def test_lowpass_frequency_response(cutoff, rate):
    f, gain = response(lowpass(cutoff, rate))
    fc = cutoff / rate  # cycles per frame
    assert gain[0] == pytest.approx(1.0, abs=1e-12)
    assert np.all(np.abs(gain[f <= 0.5 * fc] - 1.0) < 0.02), "pass band"
    assert np.all(gain[f >= 1.5 * fc] < 0.02), "stop band"
    at_cutoff = np.interp(fc, f, gain)
    assert at_cutoff == pytest.approx(0.5, abs=0.03), "-6 dB at the cutoff"
    # monotone through the transition band (no bump before the cutoff)
    band = gain[(f >= 0.5 * fc) & (f <= 1.5 * fc)]
    assert np.all(np.diff(band) <= 1e-3)


def test_lowpass_shorter_mask_rolls_off_more_gently():
    f, long_gain = response(lowpass(8.0, 120.0))
    _, short_gain = response(lowpass(8.0, 120.0, half_width=8))
    fc = 8.0 / 120.0
    stop = f >= 1.5 * fc
    assert short_gain[stop].max() > long_gain[stop].max()
    assert short_gain[0] == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize(
    ("cutoff", "rate"),
    [(0.0, 120.0), (-1.0, 120.0), (60.0, 120.0), (20.0, 30.0), (5.0, 0.0), (math.nan, 30.0)],
)
def test_lowpass_rejects_cutoffs_outside_the_band(cutoff, rate):
    with pytest.raises(MaskError):
        lowpass(cutoff, rate)


def test_lowpass_on_orientations_means_a_cutoff_in_hz():
    # A rotation about a fixed axis: the orientation filter acts on the angle exactly as
    # the vector filter, so a slow component passes and a fast one is removed.
    rate, cutoff = 120.0, 6.0
    t = np.arange(600) / rate
    slow = 0.6 * np.sin(2 * np.pi * 1.5 * t)
    fast = 0.1 * np.sin(2 * np.pi * 18.0 * t)
    axis = np.array([0.48, -0.6, 0.64])
    q = quat.from_axis_angle(axis, slow + fast)
    out = lee_shin(q, lowpass(cutoff, rate))
    angle_out = 2.0 * np.einsum("fi,i->f", quat.log(out), axis)
    inner = slice(60, -60)
    assert np.abs(angle_out[inner] - slow[inner]).max() < 0.01 * 0.1
    assert np.abs(angle_out - slow).max() < 0.1  # ends: less than the removed component


# ----------------------------------------------------------------------------- with lee_shin


@pytest.mark.parametrize(
    "mask",
    [savgol(4, 2), savgol(10, 4), lowpass(8.0, 120.0), lowpass(5.0, 30.0)],
    ids=["sg4-2", "sg10-4", "lp8@120", "lp5@30"],
)
def test_constant_angular_velocity_is_a_fixed_point(mask):
    q = constant_velocity(90)
    out = lee_shin(q, mask, iterations=2)
    assert np.degrees(quat.angle_between(q, out)).max() < 1e-9


def test_designed_masks_through_lee_shin_stay_unit_and_smooth():
    rng = np.random.default_rng(5)
    q = quat.multiply(constant_velocity(200), quat.exp(rng.normal(scale=0.02, size=(200, 2, 3))))
    for mask in (savgol(6, 2), lowpass(10.0, 120.0)):
        out = lee_shin(q, mask)
        np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, atol=1e-12)
        err_in = quat.angle_between(q, constant_velocity(200))
        err_out = quat.angle_between(out, constant_velocity(200))
        assert np.sqrt(np.mean(err_out**2)) < 0.6 * np.sqrt(np.mean(err_in**2))
