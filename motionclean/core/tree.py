"""Skeleton trees as parent arrays: ``parents[j]`` is joint ``j``'s parent, -1 for a root."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

__all__ = ["Cycle", "ancestor_jumps"]


class Cycle(ValueError):
    """Parents that are no tree: ``joint`` (the first such) is its own ancestor or below
    one that is."""

    def __init__(self, joint: int):
        super().__init__("parents contain a cycle")
        self.joint = joint


def ancestor_jumps(parents: np.ndarray) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Pointer jumping over the tree: yields ``(rows, above)`` steps in which each joint
    ``rows[i]`` takes over the ancestor ``above[i]`` (whose own pointer it then follows),
    until every pointer has reached a root. ``log2(depth) + 1`` steps, each whole-array:
    ``O(J log depth)`` however deep the tree (no loop over its levels). Raises
    :class:`Cycle` for a cycle."""
    up = np.array(parents, dtype=np.intp)
    for _ in range(max(int(up.size).bit_length(), 1) + 1):
        rows = np.flatnonzero(up >= 0)
        if rows.size == 0:
            return
        above = up[rows]
        yield rows, above
        up[rows] = up[above]  # the gather is a copy: every pointer jumps at once
    if (up >= 0).any():
        raise Cycle(int(np.flatnonzero(up >= 0)[0]))
