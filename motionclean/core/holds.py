"""Poses a capture held: dropouts written as the last sample repeated.

Many recorders do not leave a lost body blank: an inertial suit that loses packets, a
video estimator that loses the person, a solver whose markers are occluded write the
last pose again until the data returns, then the body jumps to where it had moved. Such
a *held run* is a dropout like a blank cell, and is bridged as one (``fill-gaps``).

A held run of a joint is a run of frames whose every channel (the rotation, and the
position where the joint has position channels) repeats the frame before it bit for bit.
Exact repeats also come from still joints, keyframed holds, stepped keys and values
quantised by a writer, so a run counts as held only where the joint moves on both sides
and leaves it by a jump:

- at least :data:`MIN_HELD_FRAMES` repeated frames, with a frame before and after (a run
  reaching the clip's start or end is the edge pose a fill would hold anyway);
- no repeat among the :data:`MOVING_STEPS` steps on each side (a joint keyed in steps or
  quantised repeats there too);
- the step out of it more than :data:`JUMP_RATIO` times the median step around it (the
  body moved on while its pose was held), and for a rotation at least
  :data:`MIN_JUMP_DEG` (a value quantised to a fraction of a degree steps out of its holds
  by one quantum) and at most :data:`MAX_JUMP_DEG` (a half-turn out of a hold is a flip,
  ``despike``'s).

A run held by joints that do not jump out of it (a still spine while the arms catch up)
counts too where another joint holds exactly the same frames and does: one recorder
dropped those frames for the whole body.
"""

from __future__ import annotations

import numpy as np

from .motion import Motion

#: Fewest repeated frames in a held run (three equal samples): a single repeat is how a
#: rate conversion duplicates frames.
MIN_HELD_FRAMES = 2
#: Steps on each side of a held run that must all move (at most this many, at least
#: :data:`MIN_MOVING_STEPS` where the clip's end is nearer).
MOVING_STEPS = 4
MIN_MOVING_STEPS = 2
#: The step out of a held run over the median step around it.
JUMP_RATIO = 3.0
#: Smallest and largest rotation step out of a held run, degrees.
MIN_JUMP_DEG = 1.0
MAX_JUMP_DEG = 150.0

__all__ = ["held_samples"]


def held_samples(motion: Motion) -> np.ndarray:
    """``(F, J)`` bool: the samples of ``motion`` that repeat a pose the capture held
    (module docstring), False elsewhere and on its missing samples (a blank cell's
    placeholder repeats the last known sample too); frames ``a+1 .. b`` of a run whose
    frames all repeat frame ``a``."""
    repeats = _repeats(motion)
    first, stop, column = _runs(repeats)  # step indices: step i joins frames i and i + 1
    n_steps = repeats.shape[0]
    keep = (stop - first >= MIN_HELD_FRAMES) & (first > 0) & (stop < n_steps)
    first, stop, column = first[keep], stop[keep], column[keep]
    if not first.size:
        return np.zeros((motion.n_frames, motion.n_joints), dtype=bool)
    before = _window(first - MOVING_STEPS, first, 0, n_steps)
    after = _window(stop + 1, stop + 1 + MOVING_STEPS, 0, n_steps)
    around = np.concatenate([before, after], axis=1)  # (runs, 2 MOVING_STEPS) or -1
    valid = around >= 0
    counted = (before >= 0).sum(1), (after >= 0).sum(1)
    index = np.where(valid, around, 0), column[:, None]
    moving = ~(repeats[index] & valid).any(1)
    moving &= (counted[0] >= MIN_MOVING_STEPS) & (counted[1] >= MIN_MOVING_STEPS)
    turns = _rotation_steps(motion.rotations, index)
    exit_turn = _rotation_steps(motion.rotations, (stop, column))
    jumps = _jumps(turns, valid, exit_turn) & (exit_turn >= np.radians(MIN_JUMP_DEG))
    jumps &= exit_turn <= np.radians(MAX_JUMP_DEG)
    has_position = motion.layout.has_position[column]
    if has_position.any():
        moves = _position_steps(motion.translations, index)
        exit_move = _position_steps(motion.translations, (stop, column))
        jumps |= has_position & _jumps(moves, valid, exit_move)
    jumped = moving & jumps
    # the same frames held by another joint that jumps out of them: one dropout
    event = first * (n_steps + 1) + stop
    held_run = moving & np.isin(event, event[jumped])
    edges = np.zeros((motion.n_frames + 1, motion.n_joints), dtype=np.int64)
    np.add.at(edges, (first[held_run] + 1, column[held_run]), 1)
    np.add.at(edges, (stop[held_run] + 1, column[held_run]), -1)
    held = np.cumsum(edges[:-1], axis=0) > 0
    return held if motion.missing is None else held & ~motion.missing  # (blanks: missing)


def _repeats(motion: Motion) -> np.ndarray:
    """``(F-1, J)``: the steps whose frame repeats the frame before exactly: its rotation
    (sign-continuous: the same rotation read twice is the same quaternion) and, where the
    joint has position channels, its position."""
    q, t = motion.rotations, motion.translations
    repeats = np.all(q[1:] == q[:-1], axis=-1)
    has_position = motion.layout.has_position
    if has_position.any():
        repeats[:, has_position] &= np.all(t[1:, has_position] == t[:-1, has_position], axis=-1)
    return repeats


def _rotation_steps(q: np.ndarray, index) -> np.ndarray:
    """The angles (radians) of the steps ``index`` (step ``i`` joins frames ``i``, ``i + 1``;
    a pair of arrays of step and column)."""
    steps, columns = index
    dots = np.abs(np.sum(q[steps + 1, columns] * q[steps, columns], axis=-1))
    return 2.0 * np.arccos(np.minimum(dots, 1.0))


def _position_steps(t: np.ndarray, index) -> np.ndarray:
    """The lengths of the position steps ``index`` (as :func:`_rotation_steps`)."""
    steps, columns = index
    return np.linalg.norm(t[steps + 1, columns] - t[steps, columns], axis=-1)


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``first``, ``stop`` (row indices, ``[first, stop)``) and column of every run of True
    rows of ``mask`` ``(R, C)``."""
    n_rows, n_cols = mask.shape
    padded = np.zeros((n_cols, n_rows + 2), dtype=np.int8)
    padded[:, 1:-1] = mask.T
    edges = np.diff(padded, axis=1)
    start_col, start = np.nonzero(edges == 1)
    _, stop = np.nonzero(edges == -1)
    return start, stop, start_col


def _window(first: np.ndarray, stop: np.ndarray, low: int, high: int) -> np.ndarray:
    """``(runs, stop - first)`` indices ``first .. stop - 1`` per run, -1 outside
    ``[low, high)``."""
    index = first[:, None] + np.arange(stop[0] - first[0])
    return np.where((index >= low) & (index < high), index, -1)


def _jumps(around: np.ndarray, valid: np.ndarray, exit_step: np.ndarray) -> np.ndarray:
    """Per run: its ``exit_step`` over :data:`JUMP_RATIO` times the median of the moving
    steps ``around`` it (``(runs, n)``, where ``valid``); False where none moves."""
    around = np.where(valid & (around > 0.0), around, np.nan)
    has = ~np.isnan(around).all(1)
    typical = np.full(len(exit_step), np.inf)
    typical[has] = np.nanmedian(around[has], axis=1)
    return exit_step > JUMP_RATIO * typical
