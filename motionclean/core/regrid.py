"""Scalar samples at uneven times, put on a uniform grid.

A simulation's output (OpenSim's CMC and forward tools write their states at the
integrator's own steps, 3-12 ms apart) is not a clip: every filter here reads frames a
fixed time apart. :func:`regridded` puts such columns on a grid of about their median
step from their first time to their last, by a C1 cubic through the samples that
reproduces a parabola exactly (so smooth kinematics keep their shape and a grid time that
meets a sample gives it back).
"""

from __future__ import annotations

import numpy as np

from .motion import MAX_FRAME_TIME, MIN_FRAME_TIME

__all__ = ["at_times", "grid_refusal", "hermite", "regridded"]


def _slopes(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``(F, C)`` change per second at each sample: that of the parabola through it and
    its neighbours (at an end, the next two); the secant with two samples."""
    steps = np.diff(times)[:, None]
    secants = np.diff(values, axis=0) / steps
    slopes = np.empty_like(values)
    slopes[0], slopes[-1] = secants[0], secants[-1]
    if times.size > 2:
        before, after = steps[:-1], steps[1:]
        slopes[1:-1] = (after * secants[:-1] + before * secants[1:]) / (before + after)
        for end, near, far in ((0, 0, 1), (-1, -1, -2)):
            h0, h1 = steps[near], steps[far]
            slopes[end] = ((2 * h0 + h1) * secants[near] - h0 * secants[far]) / (h0 + h1)
    return slopes


def at_times(times: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``values`` ``(F, C)`` sampled at increasing ``times`` ``(F,)`` (seconds, ``F >= 2``),
    evaluated at ``at`` ``(N,)`` within ``[times[0], times[-1]]`` by the cubic Hermite
    through the samples with :func:`_slopes`. ``(N, C)``."""
    slopes = _slopes(times, values)
    piece = np.clip(np.searchsorted(times, at, side="right") - 1, 0, times.size - 2)
    span = (times[piece + 1] - times[piece])[:, None]
    u = (at - times[piece]) / span[:, 0]
    rise = values[piece + 1] - values[piece]
    return values[piece] + hermite(rise, slopes[piece] * span, slopes[piece + 1] * span, u)


def hermite(p1: np.ndarray, m0: np.ndarray, m1: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The cubic from 0 (rate ``m0``) at ``u = 0`` to ``p1`` (rate ``m1``) at ``u = 1``, at
    ``u`` ``(...)``; ``p1``, ``m0``, ``m1`` ``(..., D)``."""
    u = u[..., None]
    u2 = u * u
    u3 = u2 * u
    return (3.0 * u2 - 2.0 * u3) * p1 + (u3 - 2.0 * u2 + u) * m0 + (u3 - u2) * m1


#: A grid holds at most this many frames per sample read: steps so uneven that the median
#: one would make more (a few rows 0.1 us apart and the rest seconds apart) are refused,
#: so time and memory follow the data, not its smallest step.
MOST_FRAMES_PER_ROW = 8


def grid_refusal(times: np.ndarray) -> str | None:
    """Why :func:`regridded` refuses increasing ``times`` (seconds): a median step no clip
    may have, or a grid of more than :data:`MOST_FRAMES_PER_ROW` frames per row (a gap of
    rows long beside the take); None where it puts them on a grid."""
    median = float(np.median(np.diff(times)))
    if not MIN_FRAME_TIME <= median <= MAX_FRAME_TIME:
        return f"a median time step of {median:.6g} s gives no usable frame rate"
    length = times[-1] - times[0]
    span = length / median
    if span > MOST_FRAMES_PER_ROW * times.size:
        return (
            f"time steps too uneven to put on a grid: the median step, {median:.6g} s, "
            f"over {length:.6g} s would make {span:,.0f} frames of {times.size} rows"
        )
    return None


def regridded(times: np.ndarray, values: np.ndarray) -> tuple[float, np.ndarray]:
    """The frame time and ``values`` ``(F, C)`` at ``times[0] + k`` frame times up to
    ``times[-1]`` (:func:`at_times`): the step nearest the median that divides the take's
    span in whole frames, to 12 significant digits, so the grid ends on the last sample
    (the median step itself had ended a forward simulation's states 0.8 ms short of it).
    ValueError where :func:`grid_refusal` says why not."""
    refusal = grid_refusal(times)
    if refusal is not None:
        raise ValueError(refusal)
    median = float(np.median(np.diff(times)))
    length = times[-1] - times[0]
    span = length / median
    steps = max(1, round(span))
    frame_time = float(f"{length / steps:.12g}")
    grid = times[0] + frame_time * np.arange(steps + 1)
    return frame_time, at_times(times, values, np.minimum(grid, times[-1]))
