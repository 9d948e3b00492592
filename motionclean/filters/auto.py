"""Automatic cleaning: estimate each joint's noise from the clip, then pick its filter.

Most users never tune a parameter, and the best strength of any smoother moves with the
noise level and with how fast each joint moves. This module measures both from the clip.

**Noise model.** A captured orientation is ``y_i = s_i exp(e_i)``: the true motion ``s_i``
times independent noise ``e_i`` in ``R^3`` (log units, ``|e|`` = half the rotation angle)
with per-component standard deviation ``sigma``. The noise level reported to users is the
RMS rotation angle of one sample's noise, ``N = 2 sqrt(3) sigma`` (radians, shown in
degrees). Positions: ``y_i = s_i + n_i`` and ``N = sqrt(3) sigma`` (RMS length of ``n_i``).

**Noise estimate** (:func:`estimate_noise`). With ``w_i = log(y_i^-1 y_{i+1})``
(000 Eq. 12), ``w_i ~ v_i + e_{i+1} - e_i``, so the second difference of the displacements
``d_i = w_{i+2} - 2 w_{i+1} + w_i`` is the third difference of the noise, variance
``20 sigma^2`` per component (``1 + 9 + 9 + 1``), plus the third difference of the motion,
which is small and sparse (contacts, quick turns) at capture rates. Its robust size is the
median of ``|d_i|``; for Gaussian noise ``|d| / (sqrt(20) sigma)`` follows a chi law with 3
degrees of freedom, whose median is ``1.53817``. Hence
``sigma = median |d| / (1.53817 sqrt(20))`` per joint. The constant is exact for Gaussian
noise (checked against planted noise in the tests). Genuine motion adds to the estimate
where the frame rate is low for the motion: on the corpus walks as captured it reads about
0.01 degrees at 120 fps but 0.2 (up to 0.8 for fast joints) at 30 fps.

**Choice of filter** (:func:`auto`). Candidates are Lee-Shin filters (000 Eq. 19-20, one
pass) of binomial masks ``B^{2k+1}`` (000 Eq. 23) and degree-2 Savitzky-Golay masks
(:func:`motionclean.filters.design.savgol`) with half-widths on a geometric ladder (ratio
1.35) up to ``max_seconds`` of frames, low-pass masks
(:func:`motionclean.filters.design.lowpass`) with cutoffs on the same ladder from
``2 / max_seconds`` Hz (the cutoff whose mask is that wide) to 0.45 times the frame rate,
and the identity. For each joint the candidate
with the smallest Stein unbiased risk estimate (SURE) of the mean squared error is kept:

    R = sum_i |log(y_i^-1 H(y)_i)|^2 - 3 F sigma^2 + 2 * 3 sigma^2 tr(L),

``F`` frames, ``tr(L)`` the trace of the mask's linear filter including the mirrored
boundary of 000 Eq. 26 (``F a_0`` in the interior). The first term is how far the filter
moved the clip, the last two correct it into an estimate of how far the result is from the
(unknown) true motion. A joint whose estimated noise is zero is left unchanged, and a
joint moving fast keeps a narrower mask than a slow one at the same noise. ``strength``
scales ``sigma`` in this choice (2 chooses as if the noise were twice the estimate).

The residual term needs no filtering: one pass moves sample ``i`` by ``s_i = sum_m b_m
w_{i+m}`` (000 Eq. 19), so it is ``sum_i |s_i|^2``, and for all candidates at once it
follows from one FFT of the mirrored displacements (Parseval; see
:func:`_residual_energies`). Only the winners are run: the joints that chose the same
mask are filtered together by one vectorised :func:`lee_shin` call, so there is no loop
over joints or frames (about 40 ms for 31 joints x 1250 frames at 120 fps).
:func:`auto_positions` does the same for translations with the vector filters.

Arrays are time-major: ``(F, ..., 4)`` quaternions ``(w, x, y, z)`` or ``(F, ..., 3)``
vectors; every trailing index (column) is estimated and filtered on its own.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .. import checks, quat
from .design import lowpass, savgol
from .linear import (
    displacement_coefficients,
    lee_shin,
    lee_shin_positions,
    mirror_indices,
)
from .masks import MAX_HALF_WIDTH, binomial

__all__ = [
    "FAMILIES",
    "AutoChoice",
    "AutoResult",
    "auto",
    "auto_positions",
    "candidates",
    "estimate_noise",
    "estimate_position_noise",
]

#: Median of the chi distribution with 3 degrees of freedom (norm of a standard 3-D normal).
CHI3_MEDIAN = 1.5381722544550522
#: Variance gain of the third difference (1, -3, 3, -1) on white noise.
THIRD_DIFFERENCE_GAIN = 20.0
#: Ratio between successive candidate half-widths.
LADDER_RATIO = 1.35
#: Largest block (values) of the spectrum of the mirrored displacements taken at once.
SPECTRUM_BLOCK = 1 << 22
#: Mask families auto may choose from.
FAMILIES = ("binomial", "savgol", "lowpass")
#: Highest candidate cutoff, as a fraction of the frame rate (the Nyquist limit is 0.5).
TOP_CUTOFF = 0.45


@dataclass(frozen=True)
class AutoChoice:
    """The filter chosen for one column.

    ``mask`` is ``"none"``, ``"binomial"`` (``value`` = k of 000 Eq. 23), ``"savgol"``
    (``value`` = half_width in frames, degree 2) or ``"lowpass"`` (``value`` = cutoff_hz,
    default mask length); ``expected_error`` is the SURE estimate of the RMS error left
    after filtering (degrees of rotation, or length units for positions).
    """

    mask: str
    value: float
    expected_error: float

    def params(self) -> dict:
        """The choice as Lee-Shin step parameters, e.g. ``{"mask": "binomial", "k": 3}``."""
        if self.mask == "binomial":
            return {"mask": "binomial", "k": int(self.value)}
        if self.mask == "savgol":
            return {"mask": "savgol", "half_width": int(self.value), "degree": 2}
        if self.mask == "lowpass":
            return {"mask": "lowpass", "cutoff_hz": self.value}
        return {"mask": "none"}


class AutoResult(NamedTuple):
    """What :func:`auto` returns: unpacks as ``(values, noise, choices)``."""

    values: np.ndarray  # (F, ..., 4) or (F, ..., 3) cleaned signal
    noise: np.ndarray  # (...) estimated per-sample noise (degrees or length units)
    choices: list[AutoChoice]  # one per column, C order of the trailing shape


def _robust_sigma(d: np.ndarray) -> np.ndarray:
    """Per-component noise deviation from third differences ``d`` (n, C, 3): chi-3 median."""
    if d.shape[0] == 0:  # fewer than 4 frames
        return np.zeros(d.shape[1:-1])
    norms = np.linalg.norm(d, axis=-1)
    return np.median(norms, axis=0) / (CHI3_MEDIAN * math.sqrt(THIRD_DIFFERENCE_GAIN))


def _columns(x: np.ndarray, width: int, what: str) -> np.ndarray:
    x = checks.unit_quaternions(x, what) if width == 4 else checks.vectors(x, what)
    return x.reshape(x.shape[0], math.prod(x.shape[1:-1]), width)


def estimate_noise(q: np.ndarray) -> np.ndarray:
    """Per-sample rotation noise of each column, RMS rotation angle in degrees.

    ``q`` is ``(F, ..., 4)``; returns shape ``(...)``. Uses the median norm of the second
    differences of ``w_i = log(q_i^-1 q_{i+1})`` (module docstring); clips of fewer than 4
    frames give 0. The estimate does not depend on the frame rate: it is per sample.
    """
    w = quat.displacements(quat.make_continuous(_columns(q, 4, "rotations"), axis=0))
    return _rotation_noise(w).reshape(np.shape(q)[1:-1])


def _rotation_noise(w: np.ndarray) -> np.ndarray:
    """``(C,)`` noise in degrees from the ``(F-1, C, 3)`` angular displacements."""
    sigma = _robust_sigma(np.diff(w, n=2, axis=0))
    return np.degrees(2.0 * math.sqrt(3.0) * sigma)


def estimate_position_noise(p: np.ndarray) -> np.ndarray:
    """Per-sample position noise of each column: RMS length of the noise vector.

    ``p`` is ``(F, ..., 3)`` in the file's length unit; returns shape ``(...)``, from the
    median norm of the third differences of ``p`` (clips under 4 frames give 0).
    """
    cols = _columns(p, 3, "positions")
    sigma = _robust_sigma(np.diff(cols, n=3, axis=0))
    return (math.sqrt(3.0) * sigma).reshape(np.shape(p)[1:-1])


def candidates(
    frame_time: float,
    max_seconds: float = 1.0,
    families: tuple[str, ...] = FAMILIES,
    n_frames: int | None = None,
) -> list[tuple[str, float, np.ndarray]]:
    """The candidate masks ``(family, value, mask)``.

    Binomial k and Savitzky-Golay half-widths ``1.35^n`` (rounded, unique) up to
    ``max_seconds / frame_time`` frames (at least 2, at most ``MAX_HALF_WIDTH`` and, when
    ``n_frames`` is given, at most the clip's length); low-pass cutoffs (Hz, 2 decimals)
    from ``2 / max_seconds`` (and no lower than ``2 fps / MAX_HALF_WIDTH`` nor
    ``2 fps / n_frames``) up to 0.45 times the frame rate by the same ratio. So the work
    follows the clip, never the frame time alone.
    """
    if not (math.isfinite(frame_time) and frame_time > 0):
        raise ValueError(f"frame_time must be a positive number of seconds, got {frame_time}")
    if not (math.isfinite(max_seconds) and max_seconds > 0):
        raise ValueError(f"max_seconds must be a positive number of seconds, got {max_seconds}")
    unknown = set(families) - set(FAMILIES)
    if unknown or not families:
        raise ValueError(f"families must be a non-empty subset of {FAMILIES}, got {families}")
    widest = MAX_HALF_WIDTH if n_frames is None else max(2, min(MAX_HALF_WIDTH, int(n_frames)))
    top = min(max(2, round(max_seconds / frame_time)), widest)
    count = math.ceil(math.log(top) / math.log(LADDER_RATIO)) + 1
    ladder = np.unique(np.round(np.geomspace(1, top, count)).astype(int)).tolist()
    out = []
    if "binomial" in families:
        out += [("binomial", k, binomial(k)) for k in ladder]
    if "savgol" in families:
        out += [("savgol", h, savgol(h, 2)) for h in ladder if h >= 2]
    rate = 1.0 / frame_time
    # the default low-pass half-width 2 fps / cutoff stays within MAX_HALF_WIDTH
    low, high = max(2.0 / max_seconds, 2.0 * rate / widest), TOP_CUTOFF * rate
    if "lowpass" in families and low < high:
        count = math.ceil(math.log(high / low) / math.log(LADDER_RATIO)) + 1
        cutoffs = sorted({round(c, 2) for c in np.geomspace(low, high, count).tolist()})
        out += [("lowpass", c, lowpass(c, rate)) for c in cutoffs]
    return out


def _trace(mask: np.ndarray, n_frames: int) -> float:
    """Trace of the vector filter of ``mask`` on ``n_frames`` samples, mirrored boundary
    (000 Eq. 26) included: ``a_0`` per interior frame; at the ``k`` frames of each end,
    ``1 + sum_m b_m ([j(i+m) = i-1] - [j(i+m) = i])`` with ``j`` the mirrored index of the
    displacement ``d_j = p_{j+1} - p_j`` read at position ``i + m``."""
    b = displacement_coefficients(mask)
    k = b.size // 2
    ends = np.unique(np.r_[0 : min(k, n_frames), max(n_frames - k, 0) : n_frames])
    index = mirror_indices(n_frames - 1, k, k)[ends[:, None] + np.arange(2 * k)]
    frame = ends[:, None]
    diag = 1.0 + np.sum(b * ((index == frame - 1).astype(float) - (index == frame)), axis=1)
    return float(mask[k] * (n_frames - ends.size) + diag.sum())


def _power_spectrum(disp: np.ndarray) -> np.ndarray:
    """``sum_xyz |DFT|^2`` over one period of the mirrored displacements (000 Eq. 26).

    ``disp`` is ``(n, C, 3)`` with ``n >= 2``; the mirrored sequence is periodic with period
    ``P = 2 (n - 1)`` and this is its one-sided power spectrum, shape ``(P/2 + 1, C)``,
    computed over blocks of columns to bound memory.
    """
    period = mirror_indices(disp.shape[0], 0, disp.shape[0] - 2)
    out = np.empty((period.size // 2 + 1, disp.shape[1]))
    step = max(1, SPECTRUM_BLOCK // (period.size * disp.shape[2]))
    for c0 in range(0, disp.shape[1], step):  # blocks of columns, not single joints
        spec = np.fft.rfft(disp[period, c0 : c0 + step], axis=0)
        out[:, c0 : c0 + step] = np.sum(spec.real**2 + spec.imag**2, axis=-1)
    return out


def _residual_energies(disp: np.ndarray, masks: list[np.ndarray]) -> np.ndarray:
    """``sum_i |s_i|^2`` per mask and column, ``s_i = sum_m b_m d_{i+m}`` (000 Eq. 19-20).

    ``s_i`` is how far one pass of the mask's filter moves sample ``i`` (its tangent vector
    for orientations), so this is the residual of every candidate without running it. For
    a symmetric mask ``b_{-m-1} = -b_m``, so on the mirrored displacements ``s_{1-i} =
    -s_i`` and ``s_{2F-3-i} = -s_i``: the ``F`` outputs hold half a period of ``|s|^2``
    plus ``s_1`` and ``s_{F-2}`` once more (``s_0 = -s_1``, ``s_{F-1} = -s_{F-2}``). By
    Parseval the period's energy is ``(1/P) sum_f |B_f|^2 |D_f|^2``: one FFT of the data,
    then a matrix product over all masks. ``disp`` is ``(F-1, C, 3)`` with ``F >= 3``;
    returns ``(len(masks), C)``.
    """
    n = disp.shape[0]
    period = 2 * (n - 1)
    power = _power_spectrum(disp)
    weight = np.full(power.shape[0], 2.0)  # one-sided spectrum of a real sequence
    weight[0] = weight[-1] = 1.0
    k_max = max(mask.size // 2 for mask in masks)
    mirrored = mirror_indices(n, k_max, k_max)  # positions -k_max .. n-1+k_max
    gains = np.empty((len(masks), power.shape[0]))
    ends = np.empty((len(masks), disp.shape[1]))
    for row, mask in enumerate(masks):  # loop over candidate masks only
        b = displacement_coefficients(mask)
        k = b.size // 2
        kernel = np.zeros(period)
        np.add.at(kernel, np.arange(-k, k) % period, b)
        gains[row] = np.abs(np.fft.rfft(kernel)) ** 2 * weight
        offsets = np.arange(-k, k) + k_max
        s_first = np.einsum("k,k...->...", b, disp[mirrored[1 + offsets]])
        s_last = np.einsum("k,k...->...", b, disp[mirrored[n - 1 + offsets]])
        ends[row] = np.sum(s_first**2, axis=-1) + np.sum(s_last**2, axis=-1)
    # einsum, not a matrix product: no threaded BLAS for these small products
    return np.einsum("mf,fc->mc", gains, power) / (2.0 * period) + ends


def _select(x, disp, sigma2, cands, apply: Callable, to_rms: Callable):
    """Filter each column of ``x`` (F, C, d) by its candidate of least SURE.

    ``disp`` are the (F-1, C, 3) displacements of ``x``; ``sigma2`` (C,) the per-component
    noise variance in the same units. Columns sharing a winner are filtered by one
    vectorised ``apply(x[:, cols], mask)`` call. Returns the result and the choices.
    """
    n_frames = x.shape[0]
    risk = 3.0 * n_frames * sigma2  # the identity: no residual, trace F
    winner = np.full(sigma2.shape, -1)
    out = x.copy()
    if n_frames >= 3 and np.any(sigma2 > 0) and cands:
        masks = [mask for _, _, mask in cands]
        traces = np.array([_trace(mask, n_frames) for mask in masks])
        sure = _residual_energies(disp, masks) + 3.0 * sigma2 * (2.0 * traces[:, None] - n_frames)
        best = np.argmin(sure, axis=0)
        better = (sure[best, np.arange(best.size)] < risk) & (sigma2 > 0)
        winner = np.where(better, best, -1)
        risk = np.where(better, sure[best, np.arange(best.size)], risk)
        for index in np.unique(winner[winner >= 0]).tolist():  # one call per chosen mask
            cols = np.flatnonzero(winner == index)
            out[:, cols] = apply(x[:, cols], masks[index])
    error = to_rms(np.maximum(risk, 0.0) / max(n_frames, 1))
    choices = [
        AutoChoice("none", 0, float(e)) if i < 0 else AutoChoice(cands[i][0], cands[i][1], float(e))
        for i, e in zip(winner.tolist(), error.tolist(), strict=True)
    ]
    return out, choices


def _check(strength: float, noise, shape) -> np.ndarray | None:
    if not (math.isfinite(strength) and strength >= 0):
        raise ValueError(f"strength must be a non-negative number, got {strength}")
    if noise is None:
        return None
    noise = np.broadcast_to(np.asarray(noise, dtype=np.float64), shape)
    if not np.all(np.isfinite(noise) & (noise >= 0)):
        raise ValueError("noise must be non-negative and finite")
    return noise


def auto(
    q: np.ndarray,
    frame_time: float,
    strength: float = 1.0,
    max_seconds: float = 1.0,
    families: tuple[str, ...] = FAMILIES,
    noise=None,
) -> AutoResult:
    """Clean orientations with a filter chosen per column from the estimated noise.

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions ``(w, x, y, z)``, time along axis 0 (signs made continuous).
    frame_time : float
        Seconds per frame; sets the widest candidate mask (``max_seconds``).
    strength : float
        Multiplies the noise level used for the choice: 0 leaves the clip unchanged,
        above 1 smooths more. Default 1 (the SURE optimum).
    max_seconds : float
        Largest candidate half-width, in seconds (default 1: 120 frames at 120 fps).
    families : tuple of str
        Mask families to choose from: any of ``"binomial"``, ``"savgol"``, ``"lowpass"``.
    noise : float or array, optional
        Per-sample rotation noise in degrees (RMS rotation angle), broadcast over the
        columns, used instead of :func:`estimate_noise`.

    Returns
    -------
    AutoResult
        ``(values, noise, choices)``: the cleaned ``(F, ..., 4)`` rotations (a copy when
        nothing is filtered), the noise level per column in degrees (estimated or given)
        and one :class:`AutoChoice` per column.
    """
    shape = np.shape(q)[1:-1]
    given = _check(strength, noise, shape)
    cols = quat.make_continuous(_columns(q, 4, "rotations"), axis=0)
    w = quat.displacements(cols)
    level = _rotation_noise(w).reshape(shape) if given is None else given
    sigma = np.radians(level.reshape(-1)) / (2.0 * math.sqrt(3.0)) * strength
    values, choices = _select(
        cols,
        w,
        sigma**2,
        candidates(frame_time, max_seconds, families, cols.shape[0]),
        lee_shin,
        lambda mse: np.degrees(2.0 * np.sqrt(mse)),
    )
    return AutoResult(values.reshape(np.shape(q)), np.array(level, dtype=np.float64), choices)


def auto_positions(
    p: np.ndarray,
    frame_time: float,
    strength: float = 1.0,
    max_seconds: float = 1.0,
    families: tuple[str, ...] = FAMILIES,
    noise=None,
) -> AutoResult:
    """Vector counterpart of :func:`auto` on ``(F, ..., 3)`` translations.

    The noise (:func:`estimate_position_noise`, or ``noise`` in length units) and the
    choice work as in :func:`auto`, with :func:`lee_shin_positions` as the filter and
    squared distances as residuals; ``expected_error`` is in length units.
    """
    shape = np.shape(p)[1:-1]
    given = _check(strength, noise, shape)
    level = estimate_position_noise(p) if given is None else given
    cols = _columns(p, 3, "positions")
    sigma = level.reshape(-1) / math.sqrt(3.0) * strength
    values, choices = _select(
        cols,
        np.diff(cols, axis=0),
        sigma**2,
        candidates(frame_time, max_seconds, families, cols.shape[0]),
        lee_shin_positions,
        np.sqrt,
    )
    return AutoResult(values.reshape(np.shape(p)), np.array(level, dtype=np.float64), choices)
