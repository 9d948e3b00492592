"""Resampling orientation and position signals to a new frame rate.

New frame ``k`` sits at time ``k * new_frame_time`` from the first frame, i.e. at
``t_k = k * ratio`` old frames with ``ratio = new_frame_time / old_frame_time`` (or
``k * ratio - shift`` for a part of a clip that starts ``shift`` old frames in, see
:func:`sample_positions`). Between old samples the signal is the C2 interpolating spline of
:mod:`.spline` (rotations: the cumulative B-spline on the sphere solved through the samples,
cut at jumps; positions: the natural cubic spline), exact at old samples the new grid hits
(``u = 0``; a ratio within 1e-4 of a fraction with a small denominator is taken as that
fraction, :func:`nominal_ratio`) and exact on constant angular or linear velocity. The clip
is continued past its last sample at its last velocity, so the new clip covers the old
duration (``F`` frames x frame time) to within half a new frame: ``round(F / ratio)`` new
frames.

When the new rate is lower (``ratio > 1``), what it cannot carry is removed first: a
zero-phase low-pass at :data:`ANTIALIAS_CUTOFF` times the new Nyquist frequency
(:func:`.design.lowpass`, a mask of :data:`ANTIALIAS_PERIODS` periods of the cutoff on each
side: gain below 1e-2 from the new Nyquist frequency up, about 1 below 0.4 of it), run as
000's orientation filter (Eq. 19-20) and its vector counterpart, so the result does not
alias; on rotations it is cut where the spline is (a step over
:data:`motionclean.core.jumps.JUMP_DEG`, a half-turn flip): each stretch between such steps is
filtered on its own (:func:`.linear.lee_shin_between`), so a flip left in the clip stays a flip.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from ..core import checks, quat
from ..core.jumps import jump_steps
from .design import lowpass
from .linear import displacement_coefficients, lee_shin_between, lee_shin_positions
from .spline import evaluate, evaluate_positions, position_spline, rotation_spline

#: The anti-aliasing low-pass cuts (-6 dB) at this share of the new Nyquist frequency ...
ANTIALIAS_CUTOFF = 0.7
#: ... with a mask this many periods of the cutoff long on each side.
ANTIALIAS_PERIODS = 2.5
#: Old samples x columns whose spline is solved and evaluated at a time (temporaries stay
#: small on long clips): columns (joints) go in groups of about this many samples.
BLOCK_SAMPLES = 1 << 20
#: A ratio of frame times this close to a fraction ``p/q`` with ``q <= MAX_DENOMINATOR`` is
#: that fraction (frame times in files are rounded: 0.008333 s is 120 fps).
NOMINAL = 1e-4
MAX_DENOMINATOR = 25


def resampled_length(n_frames: int, ratio: float) -> int:
    """Frames after resampling ``n_frames`` by ``ratio`` (new frame time / old): the
    duration ``n_frames x frame time`` kept to within half a new frame (measured with the
    nominal ratio, :func:`nominal_ratio`, when there is one)."""
    fraction = nominal_ratio(ratio)
    if fraction is not None:
        return max(
            (2 * n_frames * fraction.denominator + fraction.numerator) // (2 * fraction.numerator),
            1,
        )
    return max(int(math.floor(n_frames / ratio + 0.5)), 1)


def nominal_ratio(ratio: float) -> Fraction | None:
    """``ratio`` as a fraction ``p/q`` (``q <= MAX_DENOMINATOR``) when it is one within
    :data:`NOMINAL` (a Frame Time of 0.008333 s resampled to 60 fps is 2/1, so every other
    frame is hit exactly), else None."""
    fraction = Fraction(ratio).limit_denominator(MAX_DENOMINATOR)
    return fraction if abs(float(fraction) - ratio) <= NOMINAL * ratio else None


def sample_positions(
    n_new: int, ratio: float, first: int = 0, shift: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Where new frames ``first .. first + n_new - 1`` fall among old ones, the old frames
    counted from ``shift`` (a part of a clip that starts ``shift`` old frames in): ``(index,
    u)`` with new frame ``k`` at old time ``k * ratio - shift = index + u``, ``0 <= u < 1``
    (``index`` may be -1 just before the part). A nominal ratio (:func:`nominal_ratio`) is
    used exactly, so the new grid hits old frames (``u = 0``) where it should."""
    fraction = nominal_ratio(ratio)
    k = np.arange(first, first + n_new, dtype=np.int64)
    if fraction is not None:
        whole, rest = np.divmod(
            k * fraction.numerator - shift * fraction.denominator, fraction.denominator
        )
        return whole.astype(np.intp), rest / fraction.denominator
    times = k * ratio - shift
    index = np.floor(times).astype(np.intp)
    return index, times - index


def antialias_mask(ratio: float) -> np.ndarray | None:
    """The low-pass mask (in old frames) run before resampling by ``ratio``; None when the
    new rate is not lower."""
    if ratio <= 1.0:
        return None
    cutoff = ANTIALIAS_CUTOFF * 0.5 / ratio  # cycles per old frame
    return lowpass(cutoff, 1.0, math.ceil(ANTIALIAS_PERIODS / cutoff))


def _at_times(
    x: np.ndarray, rotations: bool, ratio: float, n_new: int, first: int, shift: int
) -> np.ndarray:
    """``x`` ``(F, ..., D)`` at the new frames (:func:`sample_positions`): old samples where
    the grid hits them, else the spline of :mod:`.spline` through each column, solved and
    evaluated for groups of columns at a time."""
    index, u = sample_positions(n_new, ratio, first, shift)
    index = np.minimum(index, x.shape[0] - 1)  # the last piece continues the clip
    hits = u == 0.0
    if hits.all() and index.min(initial=0) >= 0:
        return x[index]
    columns = x.reshape(x.shape[0], -1, x.shape[-1])
    out = np.empty((n_new, *columns.shape[1:]))
    exact = hits & (index >= 0)
    out[exact] = columns[index[exact]]
    between = ~exact
    index, u = index[between], u[between]
    group = max(BLOCK_SAMPLES // max(x.shape[0], 1), 1)
    for at in range(0, columns.shape[1], group):
        part = columns[:, at : at + group]
        if rotations:
            out[between, at : at + group] = evaluate(rotation_spline(part), index, u)
        else:
            out[between, at : at + group] = evaluate_positions(position_spline(part), index, u)
    return out.reshape((n_new, *x.shape[1:]))


def resample_rotations(
    q: np.ndarray, ratio: float, n_new: int | None = None, antialias: bool = True
) -> np.ndarray:
    """Orientations ``q`` ``(F, ..., 4)`` (unit quaternions ``(w, x, y, z)``, time along axis
    0, ``F >= 2``) at ``n_new`` new frames (default :func:`resampled_length`) spaced
    ``ratio`` old frames apart. Low-passed first when ``ratio > 1`` and ``antialias``
    (module docstring). Returns ``(n_new, ..., 4)`` sign-continuous unit quaternions;
    coordinate invariant."""
    q = quat.make_continuous(checks.unit_quaternions(q), axis=0)
    return resample_continuous(q, ratio, n_new, antialias)


def resample_continuous(
    q: np.ndarray,
    ratio: float,
    n_new: int | None = None,
    antialias: bool = True,
    first: int = 0,
    shift: int = 0,
) -> np.ndarray:
    """:func:`resample_rotations` without the checks, for sign-continuous unit ``q``; the new
    frames are ``first ..`` of a clip whose ``q`` starts ``shift`` old frames in
    (:func:`sample_positions`)."""
    mask = antialias_mask(ratio) if antialias else None
    if mask is not None:  # cut where the spline is: a flip is not smeared into a turn
        q = lee_shin_between(q, displacement_coefficients(mask), jump_steps(q))
    n_new = resampled_length(q.shape[0], ratio) if n_new is None else n_new
    return _at_times(q, True, ratio, n_new, first, shift)


def resample_positions(
    p: np.ndarray,
    ratio: float,
    n_new: int | None = None,
    antialias: bool = True,
    first: int = 0,
    shift: int = 0,
) -> np.ndarray:
    """Positions ``p`` ``(F, ..., D)`` (``F >= 2``) resampled like :func:`resample_rotations`:
    low-passed first when ``ratio > 1`` and ``antialias``, then the natural cubic spline.
    ``(n_new, ..., D)``."""
    p = checks.bounded(checks.as_float_array(p, "p"), "p")
    mask = antialias_mask(ratio) if antialias else None
    if mask is not None:
        p = lee_shin_positions(p, mask)
    n_new = resampled_length(p.shape[0], ratio) if n_new is None else n_new
    return _at_times(p, False, ratio, n_new, first, shift)
