"""Thrash: a joint turning fast one way and at once fast back, over and over.

A tracker or retarget that loses a joint's twist (LaFAN1's `dance1_subject2`: its hands'
solve glitches for minutes) swings it back and forth by tens of degrees a frame for
minutes: too slow for ``despike`` (no half turn, no step over its cap), too long-lived for
a spike, and the noise model takes it for motion. A joint thrashes where its rotation
over a span into a frame and over a span out of it (``log(q_{i-k}^-1 q_i)`` and
``log(q_i^-1 q_{i+k})``, rotation vectors in the joint's local frame) both turn faster
than :data:`THRASH_DEG_PER_S` and point against each other (more than 90 degrees apart).

The figure is a time, the same at any frame rate: spans are measured up to
:data:`THRASH_SPAN_S` seconds (one frame at 24 and 30 fps, up to five at 120), the span out
may start a frame later (a turn that falls between two frames leaves them alike), and a
thrash counts every frame its two spans cover. A joint swinging 40 degrees either way at
6 Hz for 2 s (960 deg/s) thrashes on 2.0 s of frames at 24, 25, 30, 50, 60, 100 and 120 fps
alike (counting only the frames at the turns, without a pause, had made it 0.6 s at 120
fps and 1.0 s at 24, and missed a 45-degree 5 Hz swing at 30 fps whose turns fall between
frames); one swinging 30 degrees at 5 Hz (600 deg/s) on none.

Real fast moves reverse like that too (a wrist flapping through a hop, a dog's foreleg at
each stride), but in bursts: what tells the glitch is that it is kept up
(:data:`THRASH_WINDOW_S`, and the verdict's
:data:`~motionclean.report.verdict.LOOK_THRASH_S`).
"""

from __future__ import annotations

import math

import numpy as np

from ..core import quat
from ..core.rates import whole_frames
from ..core.threads import in_parts, run_parts

__all__ = ["THRASH_DEG_PER_S", "THRASH_SPAN_S", "THRASH_WINDOW_S", "thrash_frames", "worst_window"]

#: A joint thrashes where it turns faster than this (degrees per second) over a span into a
#: frame and back as fast over a span out of it. At 700 deg/s (23 degrees a frame at 30
#: fps) the default's outputs of clean captures thrash on at most 2.0 s of any half minute
#: (CMU 131_03's RightWrist through its hop at 24 fps; 1.5-1.8 s at 30 to 120 fps; MANN
#: dogs' front legs 1.9 s, LaFAN1's walk 0.4 s), a glitching optical take's wrists
#: (LaFAN1's dance1_subject2 at 30 fps) on 6.1 and 10.1 s of theirs: 3.0 times apart;
#: 2.4 times at 600 deg/s (a dog's front paw 3.0 s against 7.3), 3.1 at 800 (131_03's
#: wrist 1.7 s against 5.2).
THRASH_DEG_PER_S = 700.0
#: The longest span (seconds) a turn is measured over, shorter spans measured too: one
#: frame at 24 and 30 fps (the frame-to-frame steps), two at 50 and 60, five at 120.
#: Measured up to two frames at 30 fps (1/15 s), a clean dog's front leg thrashes at each
#: stride, on 3.8 s of a half minute: within 1.8 times of the glitching wrists.
THRASH_SPAN_S = 0.04
#: A thrash may pause this many frames at its turn: a turn that falls between two frames
#: leaves them alike (a 45-degree swing at 5 Hz sampled at 30 fps).
PAUSE_FRAMES = 1
#: A joint's thrash is judged by the most of it within any this many seconds: a long take
#: thrashing now and then (a dog wagging its tail for minutes) gathers no more of it in a
#: half minute than a short one, a glitch kept up does (the glitching take's wrists
#: thrash through most of its 131 s).
THRASH_WINDOW_S = 30.0
#: Frames of output a part of :func:`thrash_frames` makes (temporaries stay small).
_BLOCK = 4096


def _lags(dt: float) -> np.ndarray:
    """The spans (frames) a turn is measured over: 1 to :data:`THRASH_SPAN_S`, about 1.4
    times apart (1 at 24 and 30 fps, 1 and 2 at 60, 1 to 5 at 120)."""
    top = max(1, round(whole_frames(THRASH_SPAN_S / dt)))
    count = 1 + math.ceil(2.0 * math.log2(top))
    return np.unique(np.rint(np.geomspace(1.0, top, count)).astype(np.intp))


def thrash_frames(q: np.ndarray, dt: float, measured: np.ndarray) -> np.ndarray:
    """``(F, C)`` bool: the frames of the rotations ``q`` ``(F, C, 4)`` (frame time ``dt``
    s) that a thrash covers: the frames ``i - k`` to ``i + p + k`` where both
    ``log(q_{i-k}^-1 q_i)`` and ``log(q_{i+p}^-1 q_{i+p+k})`` turn faster than
    :data:`THRASH_DEG_PER_S` and their dot product is negative (``k``: :func:`_lags`;
    ``p``: up to :data:`PAUSE_FRAMES`). ``measured`` ``(F-1, C)`` bool: the steps that
    count (within the motion); spans over any other are left out. Made in parts of frames,
    each from the frames around it."""
    q = np.asarray(q, dtype=np.float64)
    frames = q.shape[0]
    out = np.zeros(q.shape[:2], dtype=bool)
    lags = _lags(dt)
    reach = 2 * int(lags[-1]) + PAUSE_FRAMES  # (frames a thrash covers, less one)

    def part(rows: slice) -> None:
        low, high = max(rows.start - reach, 0), min(rows.stop + reach, frames)
        # unmeasured steps before each frame of the part: spans from r to s hold none
        # where the counts at both are equal
        unmeasured = np.zeros((high - low, q.shape[1]), dtype=np.int32)
        np.cumsum(~measured[low : high - 1], axis=0, dtype=np.int32, out=unmeasured[1:])
        covered = _covered(q[low:high], unmeasured, lags, dt)
        out[rows] = covered[rows.start - low : rows.stop - low]

    run_parts(part, in_parts(frames, _BLOCK), q.size)
    return out


def _covered(q: np.ndarray, unmeasured: np.ndarray, lags: np.ndarray, dt: float) -> np.ndarray:
    """:func:`thrash_frames` of the frames ``q`` ``(n, C, 4)`` alone (``unmeasured``: their
    rows of its count of unmeasured steps)."""
    n = q.shape[0]
    edges = np.zeros((n + 1, q.shape[1]), dtype=np.int64)  # +1 where a cover starts, -1 after
    active = np.arange(q.shape[1])  # columns that may turn fast over some span
    for k in lags[2 * lags < n].tolist():
        if active.size == 0:
            break
        # turn[r]: frame r to r + k, half-angle radians
        turn = quat.log_relative(q[:-k, active], q[k:, active])
        floor = math.radians(THRASH_DEG_PER_S) * k * dt / 2.0
        fast = np.einsum("...i,...i->...", turn, turn) > floor * floor
        if k == 1:  # a span turns no faster than its fastest frame step: the others wait
            moving = fast.any(axis=0)
            active, turn, fast = active[moving], turn[:, moving], fast[:, moving]
            unmeasured = unmeasured[:, moving]
        for pause in range(min(PAUSE_FRAMES, n - 2 * k - 1) + 1):
            # into frame r + k: turn[r]; out of frame r + k + pause: turn[r + k + pause]
            count, out_of = n - 2 * k - pause, slice(k + pause, n - k)
            back = np.einsum("...i,...i->...", turn[:count], turn[out_of]) < 0.0
            hit = back & fast[:count] & fast[out_of]
            span = 2 * k + pause  # frames r to r + span, its steps all measured
            hit &= unmeasured[span : span + count] == unmeasured[:count]
            edges[:count, active] += hit
            edges[span + 1 : span + 1 + count, active] -= hit
    return np.cumsum(edges[:-1], axis=0) > 0


def worst_window(frames: np.ndarray, dt: float) -> np.ndarray:
    """``(C,)``: the most frames ``frames`` ``(F, C)`` marks within any
    :data:`THRASH_WINDOW_S` seconds (the whole clip where shorter)."""
    count, columns = frames.shape
    if count == 0:
        return np.zeros(columns, dtype=np.int64)
    width = min(max(1, round(whole_frames(THRASH_WINDOW_S / dt))), count)
    total = np.zeros((count + 1, columns), dtype=np.int64)
    np.cumsum(frames, axis=0, out=total[1:])
    return (total[width:] - total[:-width]).max(axis=0)
