"""Filter masks: odd-length coefficient arrays ``(a_-k, ..., a_0, ..., a_k)`` summing to one.

Any such mask is affine invariant on vectors, and 000's construction (Eq. 19-20) turns it
into a coordinate-invariant orientation filter (:func:`motionclean.filters.lee_shin`).
Masks are plain float64 numpy arrays; :func:`validate_mask` checks the two requirements.
"""

from __future__ import annotations

import math

import numpy as np

from ..core import checks

__all__ = [
    "MaskError",
    "binomial",
    "custom",
    "gaussian",
    "high_boost",
    "reduction",
    "smoothing",
    "validate_mask",
]

SUM_TOLERANCE = 1e-9
#: Widest mask half-width (frames) a pipeline step may ask for: 40 s at 120 fps.
MAX_HALF_WIDTH = 5000
#: Up to this half-width binomial masks are computed from exact integers (beyond it
#: C(2k, k) and 4^k overflow float64 and big-integer arithmetic gets slow).
EXACT_BINOMIAL_K = 512


class MaskError(ValueError):
    """A mask that cannot define an orientation filter (even length, wrong sum, ...)."""


def checked_half_width(name: str, half_width: int) -> int:
    """``half_width`` (frames) of the mask ``name``, at most :data:`MAX_HALF_WIDTH`
    (MaskError otherwise: a wider mask's coefficients alone would fill the memory)."""
    if half_width > MAX_HALF_WIDTH:
        raise MaskError(f"{name} of half-width {half_width} frames: at most {MAX_HALF_WIDTH}")
    return half_width


def validate_mask(mask) -> np.ndarray:
    """Return ``mask`` as a 1-D float64 array, or raise :class:`MaskError`.

    A mask must be one-dimensional, finite, of odd length (centred on the sample), no wider
    than :data:`MAX_HALF_WIDTH` each side, and sum to 1 within 1e-9, so that the vector
    filter is affine invariant (000 Eq. 15).
    """
    a = checks.as_float_array(mask, "mask")
    if a.ndim != 1 or a.size == 0:
        raise MaskError(f"a mask must be a non-empty list of numbers, got shape {a.shape}")
    checked_half_width("a mask", a.size // 2)
    if not np.all(np.isfinite(a)):
        raise MaskError("a mask must contain finite numbers only")
    if a.size % 2 == 0:
        raise MaskError(f"a mask must have odd length (centred), got {a.size} coefficients")
    with np.errstate(over="ignore"):  # a sum beyond float64 is refused as inf below
        total = float(np.sum(a))
    if abs(total - 1.0) > SUM_TOLERANCE:
        raise MaskError(f"mask coefficients must sum to 1, these sum to {total:.12g}")
    return a


def binomial(k: int) -> np.ndarray:
    """Binomial mask ``B^{2k+1}`` of half-width ``k`` (000 Eq. 23); ``binomial(2)`` is B^5."""
    checks.number(k, "k")  # TypeError for a str or None ('2' had been "got 2", as a number)
    if int(k) != k or k < 0:
        raise MaskError(f"binomial half-width k must be a non-negative integer, got {k}")
    k = checked_half_width("a binomial mask", int(k))
    if k <= EXACT_BINOMIAL_K:  # exact integers, correctly rounded quotients
        scale = 4**k
        return np.array([math.comb(2 * k, k + i) / scale for i in range(-k, k + 1)])
    # wider masks: from the centre C(2k, k) / 4^k by the ratios C(2k, k+i) / C(2k, k+i-1)
    i = np.arange(1, k + 1)
    log_centre = math.lgamma(2 * k + 1) - 2.0 * math.lgamma(k + 1) - 2 * k * math.log(2.0)
    side = np.exp(log_centre + np.cumsum(np.log((k - i + 1) / (k + i))))
    coeffs = np.concatenate([side[::-1], [math.exp(log_centre)], side])
    return coeffs / coeffs.sum()


def _finite(value, name: str) -> float:
    """``value`` as a finite float, or MaskError naming ``name``."""
    value = checks.number(value, name)
    if not math.isfinite(value):
        raise MaskError(f"{name} must be a finite number, got {value}")
    return value


def smoothing(lam: float) -> np.ndarray:
    """Smoothing mask ``(-lam, 4 lam, 24 - 6 lam, 4 lam, -lam) / 24`` (000 Eq. 21-22).

    One step of the fourth-order fairing update with damping ``lam``; values in (0, 1]
    smooth, larger ones over-shoot (the pipeline accepts up to 10 for experiments).
    """
    lam = _finite(lam, "lam")
    return np.array([-lam, 4 * lam, 24 - 6 * lam, 4 * lam, -lam], dtype=np.float64) / 24.0


def high_boost(lam: float) -> np.ndarray:
    """High-frequency boost ``original + lam (original - B^5 original)`` (000 Sec. V-C, Eq. 25)."""
    lam = _finite(lam, "lam")
    return np.array([-lam, -4 * lam, 16 + 10 * lam, -4 * lam, -lam], dtype=np.float64) / 16.0


def reduction() -> np.ndarray:
    """The reduction mask ``(-1, 4, 18, 4, -1) / 24`` of 003 Eq. 13."""
    return np.array([-1.0, 4.0, 18.0, 4.0, -1.0]) / 24.0


#: Below this sigma_t (frames) a neighbour's time weight exp(-r^2 / 2 sigma_t^2) is exactly 0
#: in float64 (exp(-1250) underflows), so a Gaussian window holds the sample alone.
NARROWEST = 0.02


def gaussian(sigma_t: float, radius: int | None = None) -> np.ndarray:
    """Gaussian ``exp(-r^2 / 2 sigma_t^2)`` truncated at ``radius`` frames and normalised.

    ``sigma_t`` is in frames; ``radius`` (a whole number of frames, 0 or more) defaults to
    ``ceil(3 sigma_t)``.
    """
    sigma_t = checks.number(sigma_t, "sigma_t")
    if not 0 < sigma_t < math.inf:  # NaN too
        raise MaskError(f"sigma_t must be a positive number of frames, got {sigma_t}")
    if radius is not None:  # ('3' had given 7 taps, 2.7 five, -1 an empty mask)
        value = checks.number(radius, "radius")
        if not (math.isfinite(value) and value == int(value) and value >= 0):
            raise MaskError(f"radius must be a non-negative whole number of frames, got {radius}")
    radius = math.ceil(3 * sigma_t) if radius is None else int(radius)
    if radius > MAX_HALF_WIDTH:
        raise MaskError(
            f"a Gaussian mask of radius {radius} frames: at most {MAX_HALF_WIDTH} "
            "(sigma_t up to a third of it)"
        )
    r = np.arange(-radius, radius + 1, dtype=np.float64)
    if sigma_t < NARROWEST:  # exp(-1 / 2 sigma_t^2) underflows to 0: the identity mask
        return (r == 0).astype(np.float64)
    w = np.exp(-(r**2) / (2.0 * sigma_t**2))
    return w / w.sum()


def custom(coefficients) -> np.ndarray:
    """A user mask, validated by :func:`validate_mask`."""
    return validate_mask(coefficients)
