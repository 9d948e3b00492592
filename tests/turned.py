"""A clip turned as a whole, for the tests and the Blender session alike (no pytest here:
the session runs in Blender's Python, which has none)."""

from __future__ import annotations

import numpy as np

import motionclean as mc
from motionclean.core import quat


def turned_copy(motion: mc.Motion, turn: np.ndarray) -> mc.Motion:
    """The clip turned by the quaternion ``turn`` as a whole (offsets, end sites,
    translations turned, local rotations conjugated): every world point turns the same."""
    return motion.replace(
        offsets=quat.rotate(turn, motion.offsets),
        end_sites={j: quat.rotate(turn, v) for j, v in motion.end_sites.items()},
        rotations=quat.multiply(turn, quat.multiply(motion.rotations, quat.conjugate(turn))),
        translations=quat.rotate(turn, motion.translations),
        source=None,
        source_values=None,
        source_rotations=None,
    )
