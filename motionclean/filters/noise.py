"""Noise model of a captured signal: AR(1) in frequency, a level that changes over time.

A captured orientation is ``y_i = s_i exp(e_i)`` (positions ``y_i = s_i + e_i``): the true
motion times noise ``e_i`` in ``R^3`` (log units, ``|e|`` = half the rotation angle). Each
column (joint) has its own noise, modelled per component as a first-order autoregressive
process, ``e_i = rho e_{i-1} + u_i``, whose variance ``sigma^2(t)`` may change slowly
along the clip. Its power spectrum (cycles per frame ``f``) is

    S(f) = sigma^2 (1 - rho^2) / |1 - rho exp(-2 pi i f)|^2,

white for ``rho = 0``, concentrated at low frequencies (the jitter of video pose estimators,
of smoothing trackers) for ``rho > 0``.

**Estimate** (:func:`fit`). The displacements ``w_i = log(y_i^-1 y_{i+1})`` (000 Eq. 12;
``y_{i+1} - y_i`` for positions) carry the noise with gain ``|2 sin(pi f)|^2`` plus the
motion's velocity, which at capture rates lives below a few Hz. They are cut into Hann
windows of ``window_seconds`` (half overlapping, mirrored at the ends by 000 Eq. 26, and
never longer than the clip), and each window's periodogram is taken over a fast FFT length.
Above ``BAND_HZ`` (at most 0.3 cycles per frame) the spectrum is the noise's: there ``rho``
is fitted per column by the Whittle likelihood over all windows (each window with its own
level), no more than ``RHO_MARGIN`` above the fit on the band above ``SHAPE_BAND_HZ``, which
motion hardly reaches (motion leaking into a band looks like correlation; this narrower fit
also weighs the evidence of all the clip's joints, as one capture system shapes their noise
alike); below about
57 fps even that band holds motion and the noise is taken as white. Each window's level is
the median ratio of its periodogram to the fitted shape over the band (robust to the bins
where motion leaks in), and no more than the level read from the upper quartile of the
noise's third differences over the window's frames (robust to sparse events: a repaired
flip fills a window's spectrum, not a quarter of its frames). Over the clip, a column's
level is also no more than the noise that its mean spectrum over the band shows beside a
motion falling like ``f^-s`` (``s >= 2``, :func:`_beside_motion`): at 24-30 fps, and in a
fast joint at any rate, the band still holds motion, which white noise (rising across the
band) does not resemble. Below the band the model
extrapolates the AR(1) shape: the noise that hides under the motion is accounted for,
which an estimate from the top of the spectrum alone cannot do.

**Band-limited noise** (:func:`fit_band_limited`, rotations only). Noise that went through a
low-pass filter (a tracker's or a solver's smoothing, at an edge of a few Hz) leaves nothing
above ``BAND_HZ`` for the AR(1) fit to see. Below its edge it adds to the displacements a
spectrum rising like ``(2 sin pi f)^2`` (a flat spectrum of ``e``), above the edge it falls
off a cliff: a *bump*, which neither motion (falling) nor white or AR(1) noise (rising up to
Nyquist) makes. Where the clip's joints show one (:func:`bump_statistic`), a second noise
term ``e'`` is fitted: per component variance ``sigma_b^2`` per column, spectrum
``sigma_b^2 |H(f)|^4``, ``|H|^2 = 1 / (1 + (f / f_c)^(2 order))`` (white noise through a
Butterworth filter run forward and backward, normalised to unit variance), edge ``f_c`` and
``order`` shared by all the columns (one capture system), on the part of the spectrum the
AR(1) fit leaves unexplained.

**Noise in the motion's band** (:func:`motion_slope`). Which frequencies are motion no
single joint's spectrum tells; what the clip's joints together tell is how steeply their
spectrum falls where it stands above the fitted noise: human motion falls (the clean
captures measured: slopes of -1.46 or steeper over 2-8 Hz for the median joint), the noise
of markerless and video pose estimators wanders flat over the band in every joint (-0.5 to
+0.5). ``auto`` reads it to choose its noise model (:func:`fit_coloured` when flat).

The level shown to users is the RMS rotation angle of one sample's noise, ``2 sqrt(3) sigma``
(degrees; ``sqrt(3) sigma`` in length units for positions), per window and over the clip.
Everything is vectorised over windows and columns; the windows are processed in blocks, so
the working set is a few times the clip's own size at any length.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..core.rates import frames_floor, in_band
from ..core.threads import in_parts, run_parts
from .linear import Rows, mirror_indices, row_span, take_rows

try:
    _trapezoid = np.trapezoid
except AttributeError:  # numpy 1.26, as in Blender's Python (the Blender extension)
    _trapezoid = np.trapz  # type: ignore[attr-defined]  # noqa: NPY201

__all__ = [
    "BAND_HZ",
    "BandLimited",
    "Coloured",
    "MotionSlope",
    "NoiseModel",
    "bump_statistic",
    "correlation_fitted",
    "fit_band_limited",
    "fit_coloured",
    "WINDOW_SECONDS",
    "fast_length",
    "fit",
    "hann_windows",
    "motion_slope",
]

#: Window length of the local estimate and of the local choice, in seconds.
WINDOW_SECONDS = 2.0
#: Lower edge of the band where the noise is fitted, in Hz (capped at 0.3 cycles per frame).
BAND_HZ = 10.0
#: Highest lower edge of the band, in cycles per frame (Nyquist is 0.5).
MAX_BAND_EDGE = 0.3
#: Median of a chi-square variable with 2 d degrees of freedom over 2 d (d = 1, 2, 3): a
#: periodogram bin of d Gaussian components over its mean.
CHI2_MEDIAN = {1: 0.6931471805599453, 2: 0.8391734950083306, 3: 0.8913534379078530}
#: How far the lower band's rho may exceed the upper band's.
RHO_MARGIN = 0.15
#: Upper quartile of the chi law with d degrees of freedom (norm of a standard d-dimensional
#: normal): robust to events on under a quarter of a window's frames, and a window half
#: quiet, half loud still reads as loud.
CHI_QUARTILE = {1: 1.1503493803760083, 2: 1.6651092223153954, 3: 2.026905260645478}
#: Lower edge of the upper band where the noise's spectral shape (rho) is fitted, in Hz; at
#: frame rates where it lies above MAX_SHAPE_EDGE cycles per frame the noise is taken as white.
SHAPE_BAND_HZ = 20.0
MAX_SHAPE_EDGE = 0.35

#: Shortest window, in frames: below it a clip is one window (or too short to estimate).
MIN_WINDOW = 8
#: Slopes ``s`` of the motion's displacement spectrum ``f^-s`` over the noise band that
#: the noise level is fitted beside (:func:`_beside_motion`): motion falls there.
NOISE_BAND_MOTION_SLOPES = np.arange(2.0, 12.01, 0.5)
#: AR(1) coefficients tried by the Whittle fit.
RHO_GRID = np.round(np.arange(-0.5, 0.901, 0.025), 3)
#: Values (windows x frequencies x columns) of periodogram computed per block.
BLOCK_VALUES = 1 << 18

#: Band-limited noise: peaks of a bump are sought between these frequencies (Hz) ...
BUMP_PEAK_HZ = (2.0, 9.0)
#: ... rising at least this much (nats of power, from the lowest point between a third and
#: 0.8 of the peak frequency: motion falls there, band-limited noise rises like f^2) ...
BUMP_RISE = 0.3
#: ... and the fall (nats) from the peak to the highest power between 1.75 and 2.25 times
#: its frequency that the median column must show for the clip to have band-limited noise
#: (a 4th-order Butterworth edge falls by 3-6 nats there; white or AR(1) noise rises).
BUMP_GATE = 0.6
#: Fewest columns and windows (8: about 7 s at 2 s windows) the bump is judged on: a median
#: over joints, of periodograms averaged over enough windows (a 2.5 s clean capture passed
#: the gate with 4).
BUMP_MIN_COLUMNS = 8
BUMP_MIN_WINDOWS = 8
#: Edges (Hz) and orders of the band-limited noise tried (a zero-phase Butterworth filter's).
SHELF_EDGES_HZ = np.round(np.arange(2.5, 10.01, 0.25), 2)
SHELF_ORDERS = (2, 4)
#: Points of the fine frequency grid on which the band-limited noise's autocovariance is taken.
FINE_GRID = 4096
#: The motion and noise shapes are one (a collinear fit: each level fitted alone) where
#: their Gram determinant is below this fraction of the product of their norms (1 - cos^2).
COLLINEAR = 1e-12
#: The fit's band (Hz, at most 0.45 cycles per frame), where motion is taken as a power law
#: ``(f / MOTION_FROM_HZ)^-slope`` in the displacements' spectrum, a slope of this grid.
MOTION_FROM_HZ = 1.5
FIT_TO_HZ = 20.0
MOTION_SLOPES = np.arange(0.0, 8.01, 0.5)


def correlation_fitted(frame_time: float) -> bool:
    """Whether the noise's AR(1) correlation is fitted at ``frame_time`` seconds per frame
    (the band above :data:`SHAPE_BAND_HZ` lies below :data:`MAX_SHAPE_EDGE` cycles per
    frame: about 57 fps and up); below, the noise is taken as white."""
    return SHAPE_BAND_HZ * frame_time <= MAX_SHAPE_EDGE


class NoiseModel(NamedTuple):
    """What :func:`fit` finds, per column ``c`` and window ``w``.

    ``sigma2`` (W, C): per-component noise variance (log units, or length units squared);
    ``rho`` (C,): AR(1) coefficient; ``power`` (W, F, C): the windows' periodograms of the
    displacements (summed over the 3 components, one-sided, weights in ``weights``);
    ``freqs`` (F,): cycles per frame; ``weights`` (F,): one-sided weights, summing to 1;
    ``window``: frames per window (even); ``starts`` (W,): first frame of each window;
    ``n_frames``: frames of the clip.
    """

    sigma2: np.ndarray
    rho: np.ndarray
    power: np.ndarray
    freqs: np.ndarray
    weights: np.ndarray
    window: int
    starts: np.ndarray
    n_frames: int

    def shape(self) -> np.ndarray:
        """(F, C) unit-variance AR(1) spectrum ``S(f) / sigma^2`` of each column's noise."""
        return ar1_spectrum(self.freqs, self.rho)

    def coverage(self) -> np.ndarray:
        """(W,) frames of the clip each window stands for (its taper summed inside the clip)."""
        return window_coverage(self.n_frames, self.window)

    def clip_sigma2(self) -> np.ndarray:
        """(C,) noise variance over the clip: windows weighted by the frames they cover."""
        return self.coverage() @ self.sigma2 / max(self.n_frames, 1)


def fast_length(n: int) -> int:
    """Smallest ``2^a 3^b 5^c >= n``: an FFT length without large prime factors."""
    best = 1 << max(0, math.ceil(math.log2(max(n, 1))))
    five = 1
    while five < best:
        odd = five
        while odd < best:
            length = odd
            while length < n:
                length *= 2
            best = min(best, length)
            odd *= 3
        five *= 5
    return best


def ar1_spectrum(freqs: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """(F, ...) spectrum of a unit-variance AR(1) process: ``(1 - rho^2) / |1 - rho e^{-iw}|^2``."""
    rho = np.asarray(rho, dtype=np.float64)
    cos = np.cos(2.0 * np.pi * np.asarray(freqs)).reshape((-1,) + (1,) * rho.ndim)
    return (1.0 - rho**2) / (1.0 - 2.0 * rho * cos + rho**2)


def window_frames(n_frames: int, frame_time: float, window_seconds: float) -> int:
    """Frames per window: the fewest whole frames that last longer than ``window_seconds``
    (the frame time's rounding aside, :func:`motionclean.core.rates.frames_floor`: 240
    frames + 1 at 0.0083333 s as at 1/120 s), no more than the clip's frames + 1, rounded
    up to an even FFT-friendly length (:func:`fast_length`)."""
    wanted = window_seconds / frame_time if frame_time > 0 else math.inf
    longer = frames_floor(wanted) + 1 if wanted < 1e9 else 10**9
    length = fast_length(min(longer, n_frames + 1))
    return max(MIN_WINDOW, length + length % 2)


def hann_windows(n_frames: int, window: int) -> tuple[np.ndarray, np.ndarray]:
    """Window starts (first frame, from ``-window/2``, hop ``window/2``) and the periodic
    Hann taper; the tapers of the windows sum to exactly 1 on every frame."""
    hop = window // 2
    starts = np.arange(-hop, n_frames, hop)
    taper = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(window) / window)
    return starts, taper


def window_coverage(n_frames: int, window: int) -> np.ndarray:
    """(W,) frames of a clip of ``n_frames`` each window of :func:`hann_windows` stands for
    (its taper summed over the frames inside the clip)."""
    starts, taper = hann_windows(n_frames, window)
    frames = starts[:, None] + np.arange(window)
    return np.sum(taper * ((frames >= 0) & (frames < n_frames)), axis=1)


def periodograms(disp: Rows, window: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Windowed periodograms of ``disp`` (n, C, d): ``(power (W, F, C), freqs, weights)``.

    Window ``w`` takes the displacements at positions ``starts[w] .. starts[w] + window - 1``
    (mirrored outside the clip), less their tapered mean (the motion's mean velocity, which
    no symmetric mask moves), tapered by Hann, over an FFT of :func:`fast_length`. The
    power is summed over the ``d`` components and normalised so that ``weights @ power`` is
    the taper-weighted mean square of the window.
    """
    n, n_cols = disp.shape[:2]
    starts, taper = hann_windows(n + 1, window)
    size = fast_length(window)
    freqs = np.fft.rfftfreq(size)
    weights = np.full(freqs.size, 2.0 / size)
    weights[0] = 1.0 / size
    if size % 2 == 0:
        weights[-1] = 1.0 / size
    index = mirror_indices(n, window, window + 2 * window)  # positions -window .. n + 3 window
    power = np.empty((starts.size, freqs.size, n_cols))
    scale = 1.0 / np.sum(taper**2)
    step = max(1, BLOCK_VALUES // max(1, freqs.size * n_cols * disp.shape[2]))

    def block(windows: slice) -> None:  # blocks of windows bound the memory
        rows = starts[windows, None] + np.arange(window) + window
        segment = take_rows(disp, index[rows])  # (b, window, C, d)
        segment -= np.einsum("t,btcd->bcd", taper / taper.sum(), segment)[:, None]
        segment *= taper[:, None, None]
        spec = np.fft.rfft(segment, n=size, axis=1)
        power[windows] = np.sum(spec.real**2 + spec.imag**2, axis=-1) * scale

    run_parts(block, in_parts(starts.size, step))
    return power, freqs, weights


def _whittle_rho(power, weights, shapes, band, pool=None) -> np.ndarray:
    """(C,) AR(1) coefficient of least Whittle deviance on ``band``, a level per window."""
    wb = weights[band] / weights[band].sum()
    scaled = wb / shapes[:, band]  # (R, B)
    tiny = np.finfo(np.float64).tiny
    n_windows, n_cols = power.shape[0], power.shape[2]
    whittle = np.zeros((scaled.shape[0], n_cols))
    step = max(1, BLOCK_VALUES // max(1, scaled.size * n_cols))
    for w0 in range(0, n_windows, step):  # blocks of windows: no (R, W, C) array
        levels = np.einsum("rf,wfc->rwc", scaled, power[w0 : w0 + step][:, band])
        whittle += np.log(np.maximum(levels, tiny, out=levels), out=levels).sum(axis=1)
    whittle /= n_windows
    whittle += (np.log(shapes[:, band]) @ wb)[:, None]
    if pool is not None:
        # each joint's evidence, plus as much again from all the joints of the clip (one
        # capture system shapes all its joints' noise alike), weighted by ``pool`` (C,),
        # their power in the band, so that joints without noise count for little
        whittle += (whittle @ pool / max(float(pool.sum()), tiny))[:, None]
    return RHO_GRID[np.argmin(whittle, axis=0)]


def fit(disp: Rows, frame_time: float, window_seconds: float = WINDOW_SECONDS) -> NoiseModel:
    """Fit the noise model (module docstring) to displacements ``disp`` (n, C, d), n >= 1:
    an array, or rows computed when sliced (:class:`motionclean.core.quat.Displacements`).

    ``d`` is 3 (rotations in log units, or positions); ``frame_time`` in seconds sets the
    band (``BAND_HZ``) and, with ``window_seconds``, the window length (capped by the clip).
    """
    n, n_cols, dim = disp.shape
    window = window_frames(n + 1, frame_time, window_seconds)
    power, freqs, weights = periodograms(disp, window)
    starts, _ = hann_windows(n + 1, window)
    gain = 4.0 * np.sin(np.pi * freqs) ** 2  # displacement = difference of the noise
    shapes = gain * ar1_spectrum(freqs, RHO_GRID).T  # (R, F)
    # rho: Whittle likelihood (each window with its own level) on the band above BAND_HZ,
    # and on the band above SHAPE_BAND_HZ, which motion hardly reaches; motion leaking into
    # the lower band can only look like more correlation, so the first may exceed the
    # second by at most RHO_MARGIN.
    # Below about 57 fps even the upper band holds motion: the noise is taken as white.
    if not correlation_fitted(frame_time):
        rho = np.zeros(n_cols)
    else:
        upper = in_band(freqs, SHAPE_BAND_HZ * frame_time)
        pool = np.einsum("f,wfc->c", weights[upper], power[:, upper])
        rho = np.minimum(
            _whittle_rho(power, weights, shapes, in_band(freqs, BAND_HZ * frame_time)),
            _whittle_rho(power, weights, shapes, upper, pool) + RHO_MARGIN,
        ).round(3)
    # level of each window: median ratio of its periodogram to the shape over the band
    # (robust to the few bins where motion leaks in), chi-square median corrected
    band = in_band(freqs, min(BAND_HZ * frame_time, MAX_BAND_EDGE))
    shape = gain[band, None] * ar1_spectrum(freqs[band], rho)  # (B, C)
    sigma2 = _band_medians(power, band, shape) / (CHI2_MEDIAN[dim] * dim)
    # ... over the clip no more than the noise fitted beside a motion that falls across the
    # band (which at low frame rates, or in a fast joint, still holds motion) ...
    clip = window_coverage(n + 1, window) @ sigma2 / (n + 1)
    tiny = np.finfo(np.float64).tiny
    sigma2 = sigma2 * np.minimum(
        1.0, _beside_motion(power, band, shape, freqs) / dim / np.maximum(clip, tiny)
    )
    # ... and never above the level read, robustly in time, from the noise's third
    # differences (the displacements' second): sparse events (a repaired flip, a swing past
    # gimbal lock) fill a window's spectrum like noise but not the quartile over its frames.
    return NoiseModel(
        np.minimum(sigma2, _third_difference_level(disp, window, rho)),
        rho,
        power,
        freqs,
        weights,
        window,
        starts,
        n + 1,
    )


def _beside_motion(power, band, shape, freqs) -> np.ndarray:
    """(C,) noise level (``sigma^2`` times the components) that the windows' mean
    periodogram ``P`` over the ``band`` bins shows beside motion: ``P ~ a (f / f_0)^-s +
    c shape`` (``shape`` (B, C) the noise's unit spectrum, ``f_0`` the band's first bin,
    ``s`` in ``NOISE_BAND_MOTION_SLOPES``, ``a, c >= 0``) fitted per column by Whittle's
    likelihood (least squares weighted by the fitted spectrum, reweighted three times),
    the slope of least deviance kept; ``c`` is returned. White or AR(1) noise fills the
    band and keeps its level; motion that falls across the band (a fast joint, a low frame
    rate) is not taken for noise."""
    mean = power[:, band].mean(axis=0)  # (B, C)
    tiny = np.finfo(np.float64).tiny
    unit = np.maximum(mean.max(axis=0), tiny)
    y = mean / unit
    f = freqs[band]
    motion = ((f / f[0]) ** -NOISE_BAND_MOTION_SLOPES[:, None])[:, :, None]  # (K, B, 1)
    top = np.maximum(shape.max(axis=0), tiny)
    noise = (shape / top)[None]  # (1, B, C)
    fitted = np.broadcast_to(y, (NOISE_BAND_MOTION_SLOPES.size, *y.shape))  # (K, B, C)
    for _ in range(3):
        w = 1.0 / np.maximum(fitted, 1e-12) ** 2
        smm, snn = (motion**2 * w).sum(1), (noise**2 * w).sum(1)
        smn = (motion * noise * w).sum(1)
        rm, rn = (motion * w * y).sum(1), (noise * w * y).sum(1)
        det = smm * snn - smn**2
        ok = det > 1e-12 * smm * snn
        a = np.where(ok, (snn * rm - smn * rn) / np.where(ok, det, 1.0), -1.0)
        c = np.where(ok, (smm * rn - smn * rm) / np.where(ok, det, 1.0), -1.0)
        both = (a >= 0) & (c >= 0)
        # one term alone where both cannot be positive: the one that explains more
        a_only = np.maximum(rm / np.maximum(smm, tiny), 0.0)
        c_only = np.maximum(rn / np.maximum(snn, tiny), 0.0)
        noise_only = c_only * rn >= a_only * rm
        a = np.where(both, a, np.where(noise_only, 0.0, a_only))
        c = np.where(both, c, np.where(noise_only, c_only, 0.0))
        fitted = np.maximum(a[:, None] * motion + c[:, None] * noise, 1e-12)
    deviance = (np.log(fitted) + y / fitted).sum(axis=1)  # (K, C)
    best = np.argmin(deviance, axis=0)
    return np.take_along_axis(c, best[None], 0)[0] * unit / top


def _band_medians(power: np.ndarray, band: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """(W, C) median over the ``band`` bins of ``power / shape`` ((W, F, C) over (B, C)),
    in blocks of windows (no copy of the whole band)."""
    out = np.empty((power.shape[0], power.shape[2]))
    step = max(1, BLOCK_VALUES // max(1, shape.size))
    for w0 in range(0, power.shape[0], step):
        windows = slice(w0, w0 + step)
        out[windows] = np.median(power[windows][:, band] / shape, axis=1)
    return out


def _third_difference_level(disp: Rows, window: int, rho: np.ndarray) -> np.ndarray:
    """(W, C) per-component variance of AR(1) noise ``rho`` from the upper quartile of the
    norms of the displacements' second differences in each window (chi law with ``d``
    degrees of freedom; variance gain of the third difference on the AR(1) spectrum)."""
    n, n_cols, dim = disp.shape
    starts, _ = hann_windows(n + 1, window)
    if n < 3:
        return np.full((starts.size, n_cols), np.inf)
    index = mirror_indices(n - 2, window, 3 * window)
    out = np.empty((starts.size, n_cols))
    step = max(1, BLOCK_VALUES // max(1, window * n_cols))

    def block(windows: slice) -> None:  # blocks of windows bound the memory
        rows = index[starts[windows, None] + np.arange(window) + window - 1]
        low, high = row_span(rows)
        d = disp[low : high + 2]  # the norms of this block's rows only
        norms = np.linalg.norm(d[2:] - 2.0 * d[1:-1] + d[:-2], axis=-1)
        out[windows] = np.quantile(norms[rows - low], 0.75, axis=1)

    run_parts(block, in_parts(starts.size, step))
    grid = np.linspace(0.0, 0.5, 2049)
    # once per distinct rho (a few values of a grid), not per column: a (2049, C) table was
    # 16 kB a column whatever the clip's length (7 GB for a CSV of a million columns)
    values, which = np.unique(rho, return_inverse=True)
    gain = (
        _trapezoid(
            (2.0 * np.sin(np.pi * grid))[:, None] ** 6 * ar1_spectrum(grid, values), grid, axis=0
        )
        * 2.0
    )
    return (out / CHI_QUARTILE[dim]) ** 2 / gain[which.reshape(rho.shape)]


class BandLimited(NamedTuple):
    """Band-limited noise found by :func:`fit_band_limited`, in addition to the AR(1) model.

    ``edge_hz``: the edge ``f_c`` (Hz, where the power is a quarter of the plateau's);
    ``order``: the Butterworth order, spectrum ``(1 + (f / f_c)^(2 order))^-2`` (white noise
    through the filter run forward and backward); ``shape`` (F,):
    that spectrum at the model's ``freqs``, scaled so that ``weights @ shape == 1`` (unit
    variance per component); ``sigma2`` (C,): per-component variance of each column's
    band-limited noise (log units); ``bump``: the clip's :func:`bump_statistic` (nats).
    """

    edge_hz: float
    order: int
    shape: np.ndarray
    sigma2: np.ndarray
    bump: float


def bump_statistic(power: np.ndarray, freqs_hz: np.ndarray) -> np.ndarray:
    """(C,) how clearly each column's mean displacement spectrum ``power`` (F, C) has a bump.

    The spectrum is smoothed over 3 bins and taken in logs (nats). A peak at ``f_p`` in
    ``BUMP_PEAK_HZ`` counts when it stands ``BUMP_RISE`` above the lowest point between
    ``f_p / 3`` and ``0.8 f_p``; its score is its fall to the highest point between
    ``1.75 f_p`` and ``2.25 f_p`` (``freqs_hz`` in Hz). The statistic is the largest score
    (0 without a peak). Motion falls with frequency (no rise), white and AR(1) noise make
    the displacements' spectrum rise up to Nyquist (no fall), noise low-passed at an edge
    ``f_c`` peaks near ``0.88 f_c`` and falls by several nats an octave above.
    """
    smooth = power.copy()
    smooth[1:-1] = (power[:-2] + power[1:-1] + power[2:]) / 3.0
    logs = np.log(np.maximum(smooth, np.finfo(np.float64).tiny))
    best = np.zeros(power.shape[1])
    for i in np.flatnonzero(in_band(freqs_hz, *BUMP_PEAK_HZ, closed=True)):
        peak = freqs_hz[i]
        below = in_band(freqs_hz, peak / 3.0, 0.8 * peak, closed=True)
        above = in_band(freqs_hz, 1.75 * peak, 2.25 * peak, closed=True)
        if below.any() and above.any():
            rise = logs[i] - logs[below].min(axis=0)
            fall = logs[i] - logs[above].max(axis=0)
            np.maximum(best, np.where(rise >= BUMP_RISE, fall, 0.0), out=best)
    return best


def fit_band_limited(model: NoiseModel, frame_time: float) -> BandLimited | None:
    """Band-limited noise (module docstring) of a rotation model, or None without a bump.

    Gate: the median over the columns of :func:`bump_statistic` of the windows' mean
    periodogram is at least ``BUMP_GATE`` nats (and the clip has ``BUMP_MIN_COLUMNS``
    columns, ``BUMP_MIN_WINDOWS`` windows). Fit, on the part of the mean periodogram ``P``
    the AR(1) model leaves, ``R = max(P - N_AR1, 0)``, between ``MOTION_FROM_HZ`` and
    ``FIT_TO_HZ``: per column ``R ~ a m(f) + b n(f)``, ``m`` motion as a power law (slopes
    ``MOTION_SLOPES``), ``n`` what band-limited noise of unit variance (edge of
    ``SHELF_EDGES_HZ``, order of ``SHELF_ORDERS``) makes of the mean periodogram through
    the Hann taper, ``a, b >= 0`` by least squares in relative error (weights ``1 / P^2``:
    close to a log fit, in closed form). The edge and order of least error summed over the
    columns are kept, each column with its best slope; ``b = 3 sigma_b^2``, capped by the
    median column's (a joint whose motion fits the noise's shape would read it as noise).
    Cost: a few hundred vectorised (bins x columns) products, whatever the clip's length.
    """
    n_windows, _, n_cols = model.power.shape
    if n_cols < BUMP_MIN_COLUMNS or n_windows < BUMP_MIN_WINDOWS or frame_time <= 0:
        return None
    hz = model.freqs / frame_time
    mean = model.power.mean(axis=0)  # (F, C)
    bump = float(np.median(bump_statistic(mean, hz)))
    if not bump >= BUMP_GATE:
        return None
    gain = 4.0 * np.sin(np.pi * model.freqs) ** 2
    ar1 = 3.0 * model.clip_sigma2() * gain[:, None] * model.shape()  # (F, C)
    left = np.maximum(mean - ar1, 0.0)
    tiny = np.finfo(np.float64).tiny
    # the windows' periodograms see a spectrum through the Hann taper's kernel (its leakage
    # fills the cliff): E P(f) = sum_m gamma(m) c(m) cos(2 pi f m) / c(0), gamma the
    # displacements' autocovariance (from a fine grid), c the taper's autocorrelation
    _, taper = hann_windows(model.n_frames, model.window)
    lags = np.arange(model.window)
    corr = np.correlate(taper, taper, mode="full")[taper.size - 1 :]  # lags 0 .. window - 1
    corr[1:] *= 2.0
    kernel = np.cos(2.0 * np.pi * np.outer(model.freqs, lags)) * (corr / corr[0])  # (F, L)
    fine = np.fft.rfftfreq(FINE_GRID)
    fine_gain = 4.0 * np.sin(np.pi * fine) ** 2
    # one band for every candidate: from MOTION_FROM_HZ to FIT_TO_HZ (and 0.45 cycles/frame)
    band = in_band(hz, MOTION_FROM_HZ, min(FIT_TO_HZ, 0.45 / frame_time))
    unit = np.maximum(mean[band].max(axis=0, initial=0.0), tiny)  # (C,) scale of each column
    y = left[band] / unit  # (B, C)
    w = 1.0 / np.maximum(mean[band] / unit, 1e-12) ** 2  # relative errors: a log fit
    motion = (hz[band] / MOTION_FROM_HZ) ** -MOTION_SLOPES[:, None]  # (K, B)
    s_mm, r_m, wyy = motion**2 @ w, motion @ (w * y), np.sum(w * y * y, axis=0)
    best = None
    for order in SHELF_ORDERS:
        for edge in SHELF_EDGES_HZ.tolist():
            if in_band(edge, 0.4 / frame_time):  # at or above 0.4 cycles per frame
                continue
            spectrum = (1.0 + (fine / (edge * frame_time)) ** (2 * order)) ** -2.0
            autocov = np.fft.irfft(spectrum * fine_gain, FINE_GRID)[: model.window]
            n = kernel[band] @ autocov / np.fft.irfft(spectrum, FINE_GRID)[0]  # (B,) per unit
            s_nn, r_n, s_mn = n**2 @ w, n @ (w * y), (motion * n) @ w  # (C,), (C,), (K, C)
            det = s_mm * s_nn - s_mn**2
            # a design whose two columns are (nearly) one: each level fitted alone
            collinear = ~(det > COLLINEAR * s_mm * s_nn)
            det = np.where(collinear, 1.0, det)
            a = (s_nn * r_m - s_mn * r_n) / det  # (K, C) motion, noise (3 sigma_b^2) levels
            b = (s_mm * r_n - s_mn * r_m) / det
            alone = (a < 0) | (b < 0) | collinear
            a_only = np.maximum(r_m / np.maximum(s_mm, tiny), 0.0)
            b_only = np.maximum(r_n / np.maximum(s_nn, tiny), 0.0)
            use_a = a_only * r_m >= b_only * r_n  # the larger drop of the deviance alone
            a = np.where(alone, np.where(use_a, a_only, 0.0), a)
            b = np.where(alone, np.where(use_a, 0.0, b_only), b)
            dev = wyy - 2 * (a * r_m + b * r_n) + a * a * s_mm + 2 * a * b * s_mn + b * b * s_nn
            k = np.argmin(dev, axis=0)
            score = float(np.take_along_axis(dev, k[None], 0).sum())
            if best is None or score < best[0]:
                shape = (1.0 + (hz / edge) ** (2 * order)) ** -2.0
                level = np.take_along_axis(b, k[None], 0)[0] * unit
                best = (score, edge, order, shape / (model.weights @ shape), level)
    if best is None:
        return None
    _, edge, order, shape, level = best
    return BandLimited(edge, order, shape, np.minimum(level, np.median(level)) / 3.0, bump)


#: Evidence of noise in the motion's band (:func:`motion_slope`): the band (Hz, capped at
#: 0.4 cycles per frame) where each column's displacement spectrum is read as a power law ...
SLOPE_BAND_HZ = (2.0, 8.0)
#: ... on the bins where it stands this many times above the fitted noise (AR(1), plus any
#: band-limited noise): the motion's own spectrum there, not the noise the optical model
#: already explains ...
SLOPE_OVER = 4.0
#: ... for the columns whose such bins (at least SLOPE_MIN_BINS) reach up to this
#: frequency (Hz): the slope of 2 to 4 Hz alone is flat in clean fast motion.
SLOPE_REACH_HZ = 6.0
SLOPE_MIN_BINS = 4
#: Fewest columns with a slope for the clip to have one.
SLOPE_MIN_COLUMNS = 3


class MotionSlope(NamedTuple):
    """What :func:`motion_slope` measures: ``slope`` the clip's (nan: too few columns with
    one), ``slopes`` (C,) each column's (nan: none), ``columns`` how many have one."""

    slope: float
    slopes: np.ndarray
    columns: int


#: Mean periodogram power (squared radians of displacement per frame) below which a column
#: does not move: a rotation held still varies by its float64 rounding alone (1e-15 rad).
STILL_POWER = 1e-20
#: ... nor one whose mean power over the slope's band is below this share of the 90th
#: percentile of the columns': a joint that varies by its file's text rounding alone (a
#: Mixamo clip's 22 finger columns, 1e-11 to 7e-10 of it; the slowest moving joint of the
#: clean captures measured, 3e-3), whose rounding, resampled to a higher rate, is as flat
#: as a pose estimator's noise and had made the clip read markerless.
STILL_SHARE = 1e-6


def motion_slope(
    model: NoiseModel, frame_time: float, band_limited: BandLimited | None = None
) -> MotionSlope:
    """How steeply the clip's displacement spectrum falls where motion shows above the noise.

    Per column, the windows' mean periodogram ``P`` less the model's noise spectrum ``N``
    (AR(1), plus ``band_limited`` when given) is fitted as ``f^slope`` by least squares in
    logs over the bins of ``SLOPE_BAND_HZ`` where ``P > SLOPE_OVER N``; a column has a slope
    when at least ``SLOPE_MIN_BINS`` such bins reach up to ``SLOPE_REACH_HZ`` (else the
    noise hides its motion there). The clip's slope is the median over the columns that
    move (power in the band above :data:`STILL_POWER` and above :data:`STILL_SHARE` of the
    columns' 90th percentile: a joint held still, as an AMASS clip's SMPL-H fingers or a
    Mixamo clip's, has only rounding there, as flat as noise), those without a slope
    counted as steep: flatter than a
    value only when more than half of them are. With fewer than ``SLOPE_MIN_COLUMNS``
    slopes it is nan (the clip cannot tell).

    Human motion's angular velocity falls with frequency: in the clean captures measured
    (CMU 131 at 24-120 fps, Bandai Namco clips at 30 fps, marker-based truths at 60 Hz,
    exporters' files) the clip's slope is -1.46 or steeper; its fastest joints alone may be
    flat, which is why the median is taken, and over all the moving joints (noise hides
    the steep ones first). The noise of markerless and video pose estimators wanders over
    the whole band in every joint, flat up to a solver's cliff: a slope near 0 (-0.53 to
    +0.49 on the markerless takes of ../shared/realnoise whose noise wanders). The band
    starts at 2 Hz, above the leakage of a slow move's own frequency through the 2 s
    windows. White and AR(1) noise are in ``N``. Cost: one pass over the (F, C) mean
    periodogram.
    """
    n_cols = model.power.shape[2]
    none = MotionSlope(math.nan, np.full(n_cols, np.nan), 0)
    if frame_time <= 0 or model.power.shape[0] == 0:
        return none
    hz = model.freqs / frame_time
    band = in_band(hz, SLOPE_BAND_HZ[0], min(SLOPE_BAND_HZ[1], 0.4 / frame_time))
    if np.count_nonzero(band) < SLOPE_MIN_BINS:
        return none
    mean = model.power.mean(axis=0)[band]  # (B, C)
    gain = 4.0 * np.sin(np.pi * model.freqs[band]) ** 2
    noise = 3.0 * model.clip_sigma2() * gain[:, None] * ar1_spectrum(model.freqs[band], model.rho)
    if band_limited is not None:
        noise = noise + 3.0 * band_limited.sigma2 * gain[:, None] * band_limited.shape[band, None]
    seen = mean > SLOPE_OVER * noise
    tiny = np.finfo(np.float64).tiny
    x = np.log(hz[band])[:, None]
    y = np.log(np.maximum(mean - noise, tiny))
    count = seen.sum(axis=0)
    x_mean = np.sum(seen * x, axis=0) / np.maximum(count, 1)
    y_mean = np.sum(seen * y, axis=0) / np.maximum(count, 1)
    sxx = np.sum(seen * (x - x_mean) ** 2, axis=0)
    sxy = np.sum(seen * (x - x_mean) * (y - y_mean), axis=0)
    reach = np.max(np.where(seen, hz[band][:, None], 0.0), axis=0)
    power = mean.mean(axis=0)  # (C,); no column: none moves
    loud = np.quantile(power, 0.9) if power.size else np.inf
    moving = np.any(mean > STILL_POWER, axis=0) & (power > STILL_SHARE * loud)
    has = moving & (count >= SLOPE_MIN_BINS) & (sxx > 0) & in_band(reach, SLOPE_REACH_HZ)
    slopes = np.where(has, sxy / np.where(has, sxx, 1.0), np.nan)
    columns = int(has.sum())
    if columns < SLOPE_MIN_COLUMNS:
        return MotionSlope(math.nan, slopes, columns)
    votes = np.where(has, slopes, -np.inf)[moving]
    return MotionSlope(float(np.median(votes)), slopes, columns)


#: Coloured noise (:func:`fit_coloured`): the fit's band in Hz (capped at 0.45 cycles per
#: frame). Below 1 Hz the motion of every joint outweighs any capture's noise.
COLOURED_BAND_HZ = (1.0, 25.0)
#: Slopes of the motion's displacement spectrum ``f^-s`` in the band: the prior that human
#: joint motion falls at least like ``f^-2`` there (its angle like ``f^-4``), as in the
#: marker-based captures of the realnoise takes and the slow moves of the corpus clips.
COLOURED_MOTION_SLOPES = np.arange(2.0, 8.01, 0.5)
#: Slopes ``g`` of the noise's displacement spectrum ``f^-g`` below its edge: 0 is flat (a
#: wander, as markerless and video pose estimators make), 0.5 and 1 fall slower than any
#: motion, -2 rises (white angle noise, as through a solver's low-pass: the bump above).
COLOURED_NOISE_SLOPES = (0.0, 0.5, 1.0)
#: Edges (Hz; inf: none) and orders of the cliff above which the noise is gone (an
#: estimator's or solver's own low-pass), ``(1 + (f / edge)^(2 order))^-1``.
COLOURED_EDGES_HZ = (math.inf, *np.round(np.arange(3.0, 14.01, 0.5), 2).tolist())
COLOURED_ORDERS = (4, 8)
#: Fewest windows the coloured noise is fitted on (about 3 s at 2 s windows).
COLOURED_MIN_WINDOWS = 4


class Coloured(NamedTuple):
    """Noise that reaches down into the motion's band, found by :func:`fit_coloured`.

    Its displacements' spectrum is ``f^-slope`` below an edge ``edge_hz`` (inf: none) with
    a cliff of ``order`` above it; ``shape`` (F,) is its spectrum (of the rotation, not of
    the displacements) at the model's ``freqs``, held below the fit's band and scaled so
    that ``weights @ shape == 1``; ``level`` (C,) each column's noise variance with that
    shape (log units squared, the three components together); ``white`` (C,) the
    per-component variance of the white noise fitted beside it (log units squared);
    ``held`` (F,) the frequencies below the fit's band, where the shape is held and the
    clip cannot tell noise from motion (what users are told leaves them out).
    """

    edge_hz: float
    order: int
    slope: float
    shape: np.ndarray
    level: np.ndarray
    white: np.ndarray
    held: np.ndarray


def _nonnegative_fit(y, w, bases):
    """Weighted least squares ``y ~ sum_t c_t bases[t]`` with every ``c_t >= 0``, for each
    column of ``y`` (B, C) (weights ``w`` (B, C)) and each row ``k`` of the bases (``bases``
    a list of (K, B) or (B,) arrays): ``(deviance (K, C), coefficients (T, K, C))``. Every
    subset of the terms is solved in closed form and the best one without a negative
    coefficient kept (the exact non-negative solution, for the 2 or 3 terms used here)."""
    k = max(np.shape(b)[0] if np.ndim(b) == 2 else 1 for b in bases)
    terms = np.stack([np.broadcast_to(b, (k, y.shape[0])) for b in bases])  # (T, K, B)
    n_terms = terms.shape[0]
    gram = np.einsum("tkb,ukb,bc->kctu", terms, terms, w)  # (K, C, T, T)
    right = np.einsum("tkb,bc->kct", terms, w * y)  # (K, C, T)
    wyy = np.sum(w * y * y, axis=0)  # (C,)
    best_dev = np.full(right.shape[:2], np.inf)
    best = np.zeros((n_terms, *right.shape[:2]))
    for mask in range(1, 1 << n_terms):
        used = [t for t in range(n_terms) if mask >> t & 1]
        g = gram[..., used, :][..., used]
        r = right[..., used]
        det = np.linalg.det(g)
        ok = np.abs(det) > 1e-300
        g = np.where(ok[..., None, None], g, np.eye(len(used)))
        c = np.linalg.solve(g, r[..., None])[..., 0]  # (K, C, U)
        dev = wyy - np.einsum("kcu,kcu->kc", c, r)  # at the optimum: wyy - c . r
        feasible = ok & np.all(c >= 0.0, axis=-1) & (dev < best_dev)
        best_dev = np.where(feasible, dev, best_dev)
        for i, t in enumerate(used):
            best[t] = np.where(feasible, c[..., i], np.where(feasible, 0.0, best[t]))
        for t in set(range(n_terms)) - set(used):
            best[t] = np.where(feasible, 0.0, best[t])
    return np.maximum(best_dev, 0.0), best


def fit_coloured(model: NoiseModel, frame_time: float) -> Coloured | None:
    """Coloured noise of a rotation model (:class:`Coloured`), or None for a clip too short.

    The windows' mean periodogram ``P`` of the displacements, between the ends of
    ``COLOURED_BAND_HZ``, is fitted per column as ``a (f / 1 Hz)^-s + b n(f) + c (2 sin pi
    f)^2``: motion as a power law of slope ``s`` in ``COLOURED_MOTION_SLOPES`` (at least 2:
    the prior), the wander ``n(f) = f^-g (1 + (f / edge)^(2 order))^-1`` and white noise of
    the rotation, ``a, b, c >= 0`` by least squares in relative error (weights ``1 / P^2``,
    :func:`_nonnegative_fit`). The noise slope ``g`` (``COLOURED_NOISE_SLOPES``), edge and
    order are shared by all the columns (one capture system) and chosen for the least
    deviance summed over them; each column keeps its best motion slope. The white part is
    returned beside the wander (it replaces the AR(1) model). Whatever the motion cannot
    explain with a slope of 2 or more is noise: a flat floor under a falling spectrum, the
    signature of markerless and video capture. Which frequencies are motion is a prior,
    not something one clip can tell (a dance captured clean has a flat floor too), so the
    caller decides when this model applies (``auto(source=...)``).
    """
    n_windows, _, n_cols = model.power.shape
    if n_windows < COLOURED_MIN_WINDOWS or frame_time <= 0:
        return None
    hz = model.freqs / frame_time
    low, high = COLOURED_BAND_HZ
    band = in_band(hz, low, min(high, 0.45 / frame_time))
    if np.count_nonzero(band) < 4:
        return None
    mean = model.power.mean(axis=0)  # (F, C)
    gain = 4.0 * np.sin(np.pi * model.freqs) ** 2
    tiny = np.finfo(np.float64).tiny
    unit = np.maximum(mean[band].max(axis=0, initial=0.0), tiny)  # (C,) scale of each column
    y = mean[band] / unit
    w = 1.0 / np.maximum(y, 1e-12) ** 2  # relative errors: a log fit
    motion = (hz[band] / low) ** -COLOURED_MOTION_SLOPES[:, None]  # (K, B)
    white = gain[band] / gain[band].max()  # white noise of the rotation, in displacements
    floor = hz[1] if hz.size > 1 else low
    best = None
    for slope in COLOURED_NOISE_SLOPES:
        for order in COLOURED_ORDERS:
            for edge in COLOURED_EDGES_HZ:
                if math.isinf(edge) and order != COLOURED_ORDERS[0]:
                    continue  # no edge: the order does not matter
                shape = np.maximum(hz, floor) ** -slope / (1.0 + (hz / edge) ** (2 * order))
                dev, coef = _nonnegative_fit(y, w, [motion, shape[band], white])
                k = np.argmin(dev, axis=0)
                score = float(np.take_along_axis(dev, k[None], 0).sum())
                if best is None or score < best[0]:
                    pick = np.take_along_axis(coef, k[None, None], 1)[:, 0]  # (T, C)
                    best = (score, edge, order, slope, shape, pick[1] * unit, pick[2] * unit)
    assert best is not None
    _, edge, order, slope, shape, level, white_level = best
    # the rotation's spectrum (the displacements' over the gain), held below the band: the
    # clip says nothing of the noise there, where motion outweighs it (no candidate mask
    # removes much of it; ``below`` says how much of ``level`` it is)
    rotation = shape / np.maximum(gain, tiny)
    first = int(np.argmax(band))
    rotation[:first] = rotation[first]
    total = float(model.weights @ rotation)
    held = np.arange(hz.size) < first
    # white noise: displacements' level ``white_level / gain[band].max()`` times the gain,
    # i.e. a rotation spectrum of that level; per component over the three components
    white_sigma2 = white_level / gain[band].max() / 3.0
    return Coloured(
        float(edge), int(order), float(slope), rotation / total, level * total, white_sigma2, held
    )
