"""Noise and deviation figures, in the units users read: degrees of rotation and seconds.

Angular acceleration follows 000 Sec. VI-B: with ``w_i = log(q_i^-1 q_{i+1})`` the estimate
at frame ``i`` is ``|w_i - w_{i-1}| / dt^2``; it is reported in degrees of rotation per s^2,
i.e. twice the log norm converted to degrees. Linear acceleration is the second difference of
the position channels in length units per s^2. All functions take time-major arrays and work
on every joint at once. A figure that involves a missing sample (a tracker dropout's
placeholder, which is no motion) is NaN: left out of the RMS and max, drawn as a gap.
"""

from __future__ import annotations

import numpy as np

from ..core import quat
from ..core.threads import in_parts, run_parts

__all__ = [
    "angular_acceleration",
    "deviation_deg",
    "distance",
    "known",
    "largest_steps",
    "left_out",
    "linear_acceleration",
    "rms",
    "rms_and_max",
    "rows_across_cuts",
    "step_deg",
]


def rms(x: np.ndarray, axis=0) -> np.ndarray:
    """Root mean square along ``axis`` (0 for an empty axis)."""
    x = np.asarray(x, dtype=np.float64)
    if x.shape[axis] == 0:
        return np.zeros(np.delete(x.shape, axis))
    return np.sqrt(np.mean(x * x, axis=axis))


#: Frames computed at a time (temporaries stay in cache on long clips).
BLOCK_FRAMES = 1024


def angular_acceleration(
    q: np.ndarray,
    frame_time: float,
    missing: np.ndarray | None = None,
    starts: np.ndarray | None = None,
) -> np.ndarray:
    """``(F-2, ...)`` angular acceleration magnitudes in degrees of rotation per s^2.

    ``2 |w_i - w_{i-1}| / dt^2`` for interior frames ``i = 1 .. F-2`` (000 Sec. VI-B), with
    ``w_i`` the shorter-arc displacement ``log(+-q_i^-1 q_{i+1})`` (the signs of ``q`` do not
    matter), computed block by block; NaN where the three frames include a ``missing``
    ``(F, ...)`` sample or lie on both sides of a cut (:func:`left_out`).
    """
    q = np.asarray(q, dtype=np.float64)
    n = q.shape[0]
    out = np.empty((max(n - 2, 0), *q.shape[1:-1]))
    scale = 2.0 / frame_time**2

    def block(rows: slice) -> None:  # blocks on threads; no clip-sized temporaries
        part = q[rows.start : rows.stop + 2]
        w = quat.log_relative(part[:-1], part[1:])
        change = w[1:] - w[:-1]
        here = out[rows]
        np.sqrt(np.einsum("...i,...i->...", change, change), out=here)
        here *= scale
        np.degrees(here, out=here)

    run_parts(block, in_parts(out.shape[0], BLOCK_FRAMES), q.size)
    return left_out(out, missing, starts)


def linear_acceleration(
    p: np.ndarray,
    frame_time: float,
    missing: np.ndarray | None = None,
    starts: np.ndarray | None = None,
) -> np.ndarray:
    """``(F-2, ...)`` magnitudes of ``(p_{i+1} - 2 p_i + p_{i-1}) / dt^2`` (length units/s^2);
    NaN where the three frames include a ``missing`` ``(F, ...)`` sample or lie on both
    sides of a cut (:func:`left_out`)."""
    p = np.asarray(p, dtype=np.float64)
    if p.shape[0] < 3:
        return np.zeros((0, *p.shape[1:-1]))
    out = np.empty((p.shape[0] - 2, *p.shape[1:-1]))

    def block(rows: slice) -> None:  # blocks on threads, as angular_acceleration's
        second = np.diff(p[rows.start : rows.stop + 2], n=2, axis=0)
        out[rows] = np.linalg.norm(second, axis=-1)
        out[rows] /= frame_time**2

    run_parts(block, in_parts(out.shape[0], BLOCK_FRAMES), p.size)
    return left_out(out, missing, starts)


def _pairwise(measure, a: np.ndarray, b: np.ndarray, missing: np.ndarray | None) -> np.ndarray:
    """``(F, ...)`` ``measure(a[rows], b[rows])`` of matching samples ``(F, ..., n)``, block
    by block on threads (no clip-sized temporaries); NaN where a sample is ``missing``."""
    out = np.empty(np.shape(a)[:-1])

    def block(rows: slice) -> None:
        out[rows] = measure(a[rows], b[rows])

    run_parts(block, in_parts(len(out), BLOCK_FRAMES), out.size)
    if missing is not None:
        out[missing] = np.nan
    return out


def distance(a: np.ndarray, b: np.ndarray, missing: np.ndarray | None = None) -> np.ndarray:
    """``(F, ...)`` distances between matching points ``(F, ..., 3)``; NaN where a point
    is ``missing`` ``(F, ...)`` (in either clip)."""
    return _pairwise(lambda p, q: np.linalg.norm(q - p, axis=-1), a, b, missing)


def left_out(
    accel: np.ndarray, missing: np.ndarray | None, starts: np.ndarray | None = None
) -> np.ndarray:
    """``accel`` ``(F-2, ...)`` with NaN (in place) where its three frames include a
    ``missing`` ``(F, ...)`` sample or lie on both sides of a cut between takes (``starts``:
    each new take's first frame)."""
    if missing is not None and accel.shape[0]:
        accel[missing[:-2] | missing[1:-1] | missing[2:]] = np.nan
    if starts is not None and starts.size:
        accel[rows_across_cuts(starts, accel.shape[0] + 2)] = np.nan
    return accel


def deviation_deg(
    before: np.ndarray, after: np.ndarray, missing: np.ndarray | None = None
) -> np.ndarray:
    """``(F, ...)`` rotation angle between matching samples, in degrees; NaN where a sample
    is ``missing`` ``(F, ...)`` (in either clip)."""
    before, after = np.asarray(before, dtype=np.float64), np.asarray(after, dtype=np.float64)
    return _pairwise(lambda p, q: np.degrees(quat.angle_between(p, q)), before, after, missing)


def step_deg(q: np.ndarray) -> np.ndarray:
    """``(F-1, ...)`` rotation angle between consecutive frames, in degrees."""
    return np.degrees(quat.angle_between(q[:-1], q[1:]))


def largest_steps(
    q: np.ndarray, missing: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Per trailing index, the largest frame-to-frame step (degrees) and the frame it ends at
    (the first such frame); steps into or out of a ``missing`` sample (``(F, ...)`` bool) do
    not count. Block by block: no clip-long array of steps."""
    shape = q.shape[1:-1]
    largest, at = np.zeros(shape), np.zeros(shape, dtype=np.intp)
    for start in range(0, q.shape[0] - 1, BLOCK_FRAMES):
        rows = slice(start, start + BLOCK_FRAMES + 1)
        steps = step_deg(q[rows])
        if missing is not None:
            steps[missing[rows][:-1] | missing[rows][1:]] = 0.0
        first = np.argmax(steps, axis=0)
        best = np.take_along_axis(steps, first[None], axis=0)[0]
        better = best > largest
        if start == 0:
            better[:] = True
        largest = np.where(better, best, largest)
        at = np.where(better, first + start + 1, at)
    return largest, at


def known(value: float | None) -> float | None:
    """``value`` as a float, None where nothing was measured (None or NaN)."""
    return None if value is None or np.isnan(value) else float(value)


def pair(before: float, after: float | None) -> dict:
    """A report figure before and after cleaning (``after`` None for a single clip); each
    None where nothing was measured (NaN: every row involves a missing sample)."""
    return {"before": known(before), "after": known(after)}


def rms_and_max(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """RMS and max over axis 0 of ``(N, ...)`` figures (magnitudes, >= 0), NaN values left
    out (NaN where none is left: nothing was measured)."""
    nan = np.isnan(values)
    measured = np.where(nan, 0.0, values)
    counts = values.shape[0] - np.count_nonzero(nan, axis=0)
    none = counts == 0
    rms = np.sqrt(np.square(measured).sum(axis=0) / np.maximum(counts, 1))
    return np.where(none, np.nan, rms), np.where(none, np.nan, measured.max(axis=0, initial=0.0))


def rows_across_cuts(starts: np.ndarray, n_frames: int) -> np.ndarray:
    """The rows of an acceleration table (row ``r``: frames ``r .. r+2``) whose
    frames lie on both sides of a cut between takes (``starts``: each new take's first
    frame)."""
    rows = np.concatenate([starts - 2, starts - 1])
    return np.unique(rows[(rows >= 0) & (rows < n_frames - 2)])
