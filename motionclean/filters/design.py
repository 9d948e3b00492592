"""Masks designed the way users think: a local polynomial fit, or a cutoff frequency in Hz.

Both return an odd-length, symmetric mask summing to one (checked by
:func:`motionclean.filters.masks.validate_mask`), so 000's construction (Eq. 19-20) turns it
into a coordinate-invariant orientation filter with :func:`motionclean.filters.lee_shin`,
and :func:`motionclean.filters.lee_shin_positions` applies it to translations.

* :func:`savgol` -- Savitzky-Golay smoothing: the value at the centre of the least-squares
  polynomial of degree ``degree`` fitted to ``2 half_width + 1`` samples. As a vector
  filter it reproduces every polynomial of that degree exactly (away from the ends), so it
  keeps peaks that a binomial or Gaussian mask of the same noise reduction flattens.
* :func:`lowpass` -- a zero-phase low-pass filter with a cutoff in Hz: the ideal low-pass
  impulse response ``2 f_c sinc(2 f_c m)`` (``f_c`` = cutoff / frame rate, in cycles per
  frame) under a Blackman window. Its gain is 1/2 (-6 dB) at the cutoff, like the zero-phase
  (forward-backward) second-order Butterworth filter animators set with a cutoff in Hz,
  and about 1 below half the cutoff and below 1e-2 above 1.5 times the cutoff.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.rates import frames_ceil
from .masks import MAX_HALF_WIDTH, MaskError, checked_half_width, validate_mask

__all__ = ["default_lowpass_half_width", "lowpass", "savgol"]

#: Default length of the low-pass mask: this many periods of the cutoff on each side.
LOWPASS_PERIODS = 2.0


def _whole(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not float(value).is_integer() or value < minimum:
        raise MaskError(f"{name} must be a whole number >= {minimum}, got {value}")
    return int(value)


def savgol(half_width: int, degree: int = 2) -> np.ndarray:
    """Savitzky-Golay smoothing mask: ``2 half_width + 1`` taps, local polynomial ``degree``.

    ``a_m`` is the weight of sample ``i + m`` in the value at ``i`` of the least-squares
    polynomial of degree ``degree`` through samples ``i - half_width .. i + half_width``.
    The mask is symmetric, so an odd degree gives the same mask as the even degree below
    it; ``degree = 0`` is the moving average and ``degree = 2 half_width`` the identity.

    Raises :class:`MaskError` unless ``half_width >= 0`` and ``0 <= degree <= 2 half_width``.
    """
    h = checked_half_width("a Savitzky-Golay mask", _whole("savgol half_width", half_width, 0))
    d = _whole("savgol degree", degree, 0)
    if d > 2 * h:
        raise MaskError(
            f"a degree-{d} Savitzky-Golay mask needs half_width >= {math.ceil(d / 2)}, got {h}"
        )
    x = np.arange(-h, h + 1, dtype=np.float64) / max(h, 1)  # scaled: well conditioned
    vandermonde = x[:, None] ** np.arange(d + 1)[None, :]
    coeffs = np.linalg.pinv(vandermonde)[0]  # row 0: the fitted value at x = 0
    return validate_mask(coeffs / coeffs.sum())


def default_lowpass_half_width(
    cutoff_hz: float, frame_rate: float, most: int = MAX_HALF_WIDTH
) -> int:
    """``ceil(2 frame_rate / cutoff_hz)`` frames: two periods of the cutoff on each side,
    and no more than ``most`` (default :data:`~.masks.MAX_HALF_WIDTH`): the mask of a cutoff
    near 0 Hz would otherwise be as long as its period, whatever the clip's length."""
    return frames_ceil(min(LOWPASS_PERIODS * frame_rate / cutoff_hz, most))


def lowpass(cutoff_hz: float, frame_rate: float, half_width: int | None = None) -> np.ndarray:
    """Zero-phase low-pass mask: Blackman-windowed sinc with its -6 dB point at ``cutoff_hz``.

    Parameters
    ----------
    cutoff_hz : float
        Cutoff frequency in Hz, ``0 < cutoff_hz < frame_rate / 2`` (the Nyquist frequency).
    frame_rate : float
        The clip's frame rate in frames per second (``1 / frame_time``).
    half_width : int, optional
        Mask half-width in frames; default :func:`default_lowpass_half_width` (two
        periods of the cutoff), which gives a transition from gain ~1 at half the cutoff
        to gain < 1e-2 at 1.5 times the cutoff. Shorter masks roll off more gently.

    Returns
    -------
    (2 half_width + 1,) array
        ``a_m = 2 f_c sinc(2 f_c m) w(m)`` with ``f_c = cutoff_hz / frame_rate`` and the
        Blackman window ``w(m) = 0.42 + 0.5 cos(pi m / (h+1)) + 0.08 cos(2 pi m / (h+1))``,
        normalised to sum to one.
    """
    cutoff_hz, frame_rate = float(cutoff_hz), float(frame_rate)
    if not (math.isfinite(frame_rate) and frame_rate > 0):
        raise MaskError(
            f"frame_rate must be a positive number of frames per second, got {frame_rate}"
        )
    nyquist = frame_rate / 2.0
    if not (math.isfinite(cutoff_hz) and 0.0 < cutoff_hz < nyquist):
        raise MaskError(
            f"cutoff_hz must be above 0 and below the Nyquist frequency "
            f"{nyquist:g} Hz (half the frame rate), got {cutoff_hz:g}"
        )
    if half_width is None:
        h = default_lowpass_half_width(cutoff_hz, frame_rate)
    else:
        h = checked_half_width("a low-pass mask", _whole("lowpass half_width", half_width, 0))
    fc = cutoff_hz / frame_rate
    m = np.arange(-h, h + 1, dtype=np.float64)
    phase = np.pi * m / (h + 1)
    window = 0.42 + 0.5 * np.cos(phase) + 0.08 * np.cos(2.0 * phase)
    coeffs = 2.0 * fc * np.sinc(2.0 * fc * m) * window
    return validate_mask(coeffs / coeffs.sum())
