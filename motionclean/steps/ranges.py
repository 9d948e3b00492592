"""Frame ranges: a step applied to a stretch of the clip, blended in and out.

A range is ``frames = [first, last]`` (0-based, inclusive, as ``info`` and the reports number
frames) or ``seconds = [t0, t1]`` (from the first frame), with ``blend`` frames on each side
over which the output moves from the step's input to its result along the geodesic (slerp for
rotations, a straight line for positions) with a smoothstep weight. Outside, every value is
the step's input, bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core import quat
from ..core.errors import UsageError
from ..core.rates import frames_ceil, frames_floor, whole_frames

#: Default blend width, frames.
DEFAULT_BLEND = 5
#: Largest frame number a range's end is said by: ``frames`` are read as floats, exact up to
#: 2^53 (``9223372036854775807`` had been said as ...808, ``1e308`` with 309 digits).
EXACT_FRAMES = 2**53


@dataclass(frozen=True)
class FrameRange:
    """Where a step applies: ``frames`` or ``seconds`` (one of them), and ``blend`` frames."""

    frames: tuple[int, int] | None = None
    seconds: tuple[float, float] | None = None
    blend: int = DEFAULT_BLEND

    @classmethod
    def from_params(cls, frames, seconds, blend, where: str) -> FrameRange | None:
        """Validate the step parameters (lists already type-checked); None without a range."""
        if frames is None and seconds is None:
            return None
        if frames is not None and seconds is not None:
            raise UsageError(f"{where}: give either frames or seconds, not both")
        pair = frames if frames is not None else seconds
        if len(pair) != 2:
            raise UsageError(f"{where}: a range is two values [first, last], got {pair}")
        first, last = pair
        if first > last:
            raise UsageError(f"{where}: the range [{first:g}, {last:g}] is reversed")
        if frames is not None:
            if not all(float(v).is_integer() and v >= 0 for v in frames):
                raise UsageError(f"{where}: frames are whole numbers from 0, got {frames}")
            return cls(frames=(int(first), int(last)), blend=blend)
        if first < 0 or not math.isfinite(last):
            raise UsageError(f"{where}: seconds must lie in [0, the clip's length], got {pair}")
        return cls(seconds=(float(first), float(last)), blend=blend)

    def frame_span(self, n_frames: int, frame_time: float, where: str) -> tuple[int, int]:
        """``(first, last)`` frames of this range in a clip of ``n_frames``; UsageError when
        it lies outside the clip."""
        if self.frames is not None:
            first, last = self.frames
        else:
            assert self.seconds is not None
            t0, t1 = self.seconds
            end = (n_frames - 1) * frame_time
            if whole_frames(t1 / frame_time) >= n_frames:
                raise UsageError(
                    f"{where}: the range ends at {t1:g} s, but the clip's last frame is at "
                    f"{end:g} s ({n_frames} frames of {frame_time:g} s)"
                )
            first = frames_ceil(t0 / frame_time)
            last = frames_floor(t1 / frame_time)
            if first > last:
                raise UsageError(f"{where}: seconds [{t0:g}, {t1:g}] hold no frame")
        if self.blend >= n_frames:
            raise UsageError(
                f"{where}: blend={self.blend} frames does not fit a clip of {n_frames} frames"
            )
        if last >= n_frames:
            ends = (
                f"at frame {last}, but the clip has"
                if last <= EXACT_FRAMES
                else "beyond the clip's"
            )
            raise UsageError(f"{where}: the range ends {ends} {n_frames} frames (0-{n_frames - 1})")
        return first, last

    def describe(self) -> dict:
        out: dict = {"frames": list(self.frames)} if self.frames else {}
        if self.seconds is not None:
            out["seconds"] = list(self.seconds)
        out["blend"] = self.blend
        return out


def weights(n_frames: int, first: int, last: int, blend: int) -> np.ndarray:
    """``(F,)`` share of the step's result per frame: 1 on ``first..last``, easing to 0 over
    ``blend`` frames on each side (smoothstep), 0 beyond."""
    index = np.arange(n_frames)
    distance = np.maximum(first - index, index - last).clip(0)
    x = np.clip(1.0 - distance / (blend + 1.0), 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def blend_rotations(start: np.ndarray, result: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``slerp(start, result, w)`` per frame ``(F, J, 4)``; frames of weight 0 and 1 are
    ``start`` and ``result`` bit for bit."""
    out = start.copy()
    full = w >= 1.0
    out[full] = result[full]
    part = (w > 0.0) & ~full
    if part.any():
        mixed = quat.slerp(
            start[part], result[part], np.broadcast_to(w[part, None], start[part].shape[:-1])
        )
        same = np.sum(mixed * start[part], axis=-1, keepdims=True) >= 0.0
        out[part] = np.where(same, mixed, -mixed)
    return out


def blend_positions(start: np.ndarray, result: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``start + w (result - start)`` per frame; weights 0 and 1 exact."""
    out = start.copy()
    full = w >= 1.0
    out[full] = result[full]
    part = (w > 0.0) & ~full
    out[part] = start[part] + w[part, None, None] * (result[part] - start[part])
    return out
