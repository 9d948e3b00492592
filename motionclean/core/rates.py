"""Whole frames and frequency bands from a frame time as files write it.

Files round their frame time: 1/120 s is written 0.0083333 (120.0005 frames per second),
0.008333 or 0.00833333333; 1/60 s 0.01667. Read literally, one second is then 120.0005
frames (121 when rounded up) and a periodogram's bin at 8 Hz falls a hair above or below a
band that ends at 8 Hz, so the same clip would be windowed, counted and cleaned differently
for each way of writing its frame time. A count of frames (seconds over the frame time)
within :data:`FRAME_TIME_ROUNDING` of a whole number is that number, and a frequency within
it of a band's edge is on the edge. Bands hold their lower edge but not their upper one
(unless closed): files round their frame time down more often than not (0.0083333 s,
0.0333333 s), which puts every bin a hair above its frequency, in at a lower edge and out
at an upper one, and the noise model's rules were measured on such files.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "FRAME_TIME_ROUNDING",
    "MOST_SNAPPED",
    "frames_ceil",
    "frames_floor",
    "in_band",
    "same_rate",
    "whole_frames",
]

#: Relative rounding of a frame time as files write it (1/120 s to 7 decimals: 4e-6; to 4
#: significant digits, 0.01667 for 1/60 s: 2e-4).
FRAME_TIME_ROUNDING = 1e-3
#: Two frame times this close (relative) are one rate written to other precisions (1/60 s
#: as 0.016667 or 0.0166667 s; 0.01667, 4 significant digits, is 2e-4 off); NTSC's 59.94
#: fps is 1e-3 from 60, another rate (:func:`same_rate`).
SAME_RATE = 5e-4
#: Largest distance (frames) to a whole number that a count is snapped across, whatever
#: its length: a long span's rounding is no reason to move it by more.
MOST_SNAPPED = 0.25


def whole_frames(count: float) -> float:
    """``count`` (frames, from seconds over a frame time) as the whole number it stands
    for when within ``FRAME_TIME_ROUNDING`` of it (and :data:`MOST_SNAPPED`), else as is."""
    if not math.isfinite(count):
        return count
    nearest = round(count)
    near = abs(count - nearest) <= min(FRAME_TIME_ROUNDING * abs(count), MOST_SNAPPED)
    return float(nearest) if near else count


def same_rate(frame_time: float, other: float) -> bool:
    """True when frame time ``other`` (seconds) is ``frame_time``'s rate as another file
    writes it: within :data:`SAME_RATE` of it, relative. ``resample`` to the same rate
    leaves a clip as it is; clips joined (``stitch``, ``blend``) must share it."""
    return abs(other - frame_time) <= SAME_RATE * frame_time


def frames_ceil(count: float) -> int:
    """Fewest whole frames covering ``count`` frames (:func:`whole_frames` first)."""
    return math.ceil(whole_frames(count))


def frames_floor(count: float) -> int:
    """Most whole frames within ``count`` frames (:func:`whole_frames` first)."""
    return math.floor(whole_frames(count))


def in_band(
    freqs: np.ndarray, low: float, high: float = math.inf, closed: bool = False
) -> np.ndarray:
    """Whether each of ``freqs`` lies in ``[low, high)`` (``[low, high]`` when ``closed``;
    one unit for all three: Hz, or cycles per frame): a frequency within
    :data:`FRAME_TIME_ROUNDING` of an edge is on it."""
    freqs = np.asarray(freqs)
    above = freqs >= low - FRAME_TIME_ROUNDING * abs(low)
    if high == math.inf:
        return above
    if closed:
        return above & (freqs <= high + FRAME_TIME_ROUNDING * abs(high))
    return above & (freqs < high - FRAME_TIME_ROUNDING * abs(high))
