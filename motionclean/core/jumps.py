"""Steps between frames too large for motion: half-turn flips and capture glitches.

No joint turns by more than :data:`JUMP_DEG` between two frames of a capture at any rate a
clip is taken at (a quarter turn in 1/24 s is 2,160 degrees per second); a step that large is
a defect. The spline of ``resample`` is cut there, the smoothing steps (``lee-shin``,
``bilateral``, ``fairing``, ``sse-fairing``, ``multires``: their ``cut_deg``) smooth each
side on its own, and the report counts no such step as jitter.
"""

from __future__ import annotations

import math

import numpy as np

from .threads import in_parts, run_parts

__all__ = ["JUMP_DEG", "jump_steps"]

#: Degrees of rotation between two frames beyond which a step is no motion.
JUMP_DEG = 90.0
#: Frames compared at a time (temporaries stay in cache on long clips).
_BLOCK = 4096


def jump_steps(q: np.ndarray, degrees: float = JUMP_DEG) -> np.ndarray:
    """``(F-1, ...)`` bool: the steps between consecutive frames of unit quaternions ``q``
    ``(F, ..., 4)`` that turn by more than ``degrees`` (on the shorter arc: the signs of
    ``q`` do not matter), block by block."""
    q = np.asarray(q, dtype=np.float64)
    out = np.empty((max(q.shape[0] - 1, 0), *q.shape[1:-1]), dtype=bool)
    floor = math.cos(math.radians(degrees) / 2.0)  # |q_i . q_i+1| of that step

    def block(rows: slice) -> None:
        part = q[rows.start : rows.stop + 1]
        np.less(np.abs(np.einsum("...i,...i->...", part[:-1], part[1:])), floor, out=out[rows])

    run_parts(block, in_parts(out.shape[0], _BLOCK), q.size)
    return out
