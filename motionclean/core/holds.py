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
- its step out judged against the joint's pace around it, the larger of the median steps
  before and after (a keyed ease into a hold slows the steps before it; the move out of
  one is no faster than the motion after it).

Joints holding exactly the same frames are one recorder's dropout, judged together: held
where their steps out sum to more than :data:`JUMP_RATIO` times their paces (rotations,
or positions; the body moved on while its pose was held: a joint that moved 10 frames'
worth steps out by about 11 of its steps, a pause that resumes where it stopped by one, and
the fast joints, whose steps stand above the noise, speak for the slow ones), some joint
turning out of them by at least :data:`MIN_JUMP_DEG` (a value quantised to a fraction of a
degree steps out of its holds by one quantum), and none further than :data:`MAX_PACE`
times what its pace covers over the run (a join of two takes, a teleport). A step out of
over :data:`MAX_JUMP_DEG` is a flip, ``despike``'s, and counts neither way.
"""

from __future__ import annotations

import numpy as np

from .motion import Motion, mask_runs

#: Fewest repeated frames in a held run (three equal samples): a single repeat is how a
#: rate conversion duplicates frames.
MIN_HELD_FRAMES = 2
#: Steps on each side of a held run that must all move (at most this many, at least
#: :data:`MIN_MOVING_STEPS` where the clip's end is nearer).
MOVING_STEPS = 4
MIN_MOVING_STEPS = 2
#: The steps out of held frames over the joints' paces around them ...
JUMP_RATIO = 3.0
#: ... no joint's step out over this many times its pace over the run and the step out.
MAX_PACE = 3.0
#: Smallest largest rotation step out of held frames, and a flip's, degrees.
MIN_JUMP_DEG = 1.0
MAX_JUMP_DEG = 150.0

__all__ = ["held_samples"]


def held_samples(motion: Motion) -> np.ndarray:
    """``(F, J)`` bool: the samples of ``motion`` that repeat a pose the capture held
    (module docstring), False elsewhere and on its missing samples (a blank cell's
    placeholder repeats the last known sample too); frames ``a+1 .. b`` of a run whose
    frames all repeat frame ``a``. Kept with the clip (despike, fill-gaps and the takes'
    cuts ask for it); not to be written to."""
    return motion.derived("held_samples", _held_samples)


def _held_samples(motion: Motion) -> np.ndarray:
    repeats = _repeats(motion)
    column, first, stop = mask_runs(repeats)  # step indices: step i joins frames i, i + 1
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
    span = (stop - first + 1).astype(np.float64)  # frames the motion went on for
    turns = _rotation_steps(motion.rotations, index)
    exit_turn = _rotation_steps(motion.rotations, (stop, column))
    # (a half-turn out of a hold is a flip: despike's, and no evidence either way)
    counted_turn = moving & (exit_turn <= np.radians(MAX_JUMP_DEG))
    turn_pace = _pace(turns, valid)
    # the joints that hold exactly the same frames: one dropout, judged together
    event = first * (n_steps + 1) + stop
    _, which = np.unique(event, return_inverse=True)
    jumped = _pooled(exit_turn, turn_pace, counted_turn, which) > JUMP_RATIO
    jumped &= _largest(np.where(counted_turn, exit_turn, 0.0), which) >= np.radians(MIN_JUMP_DEG)
    too_far = counted_turn & (exit_turn > MAX_PACE * span * turn_pace)
    has_position = motion.layout.has_position[column]
    if has_position.any():
        moves = _position_steps(motion.translations, index)
        exit_move = _position_steps(motion.translations, (stop, column))
        move_pace = _pace(moves, valid)
        counted_move = moving & has_position
        jumped |= _pooled(exit_move, move_pace, counted_move, which) > JUMP_RATIO
        too_far |= counted_move & (exit_move > MAX_PACE * span * move_pace)
    vetoed = _largest(too_far.astype(np.float64), which) > 0.0
    held_run = moving & (jumped & ~vetoed)[which]
    edges = np.zeros((motion.n_frames + 1, motion.n_joints), dtype=np.int8)  # (runs: apart)
    np.add.at(edges, (first[held_run] + 1, column[held_run]), 1)
    np.add.at(edges, (stop[held_run] + 1, column[held_run]), -1)
    held = np.cumsum(edges[:-1], axis=0, dtype=np.int8) > 0
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


def _window(first: np.ndarray, stop: np.ndarray, low: int, high: int) -> np.ndarray:
    """``(runs, stop - first)`` indices ``first .. stop - 1`` per run, -1 outside
    ``[low, high)``."""
    index = first[:, None] + np.arange(stop[0] - first[0])
    return np.where((index >= low) & (index < high), index, -1)


def _pace(around: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Per run, a joint's pace around it: the larger of the medians of its moving steps
    ``around`` it (``(runs, 2 n)``, ``n`` before then ``n`` after, where ``valid``); inf
    where a side has none (no evidence of a jump)."""
    around = np.where(valid & (around > 0.0), around, np.nan)
    half = around.shape[1] // 2
    sides = np.stack([around[:, :half], around[:, half:]])  # (2, runs, n)
    has = ~np.isnan(sides).all(axis=2).any(axis=0)
    pace = np.full(around.shape[0], np.inf)
    pace[has] = np.nanmax(np.nanmedian(sides[:, has], axis=2), axis=0)
    return pace


def _pooled(exit_step: np.ndarray, pace: np.ndarray, counted: np.ndarray, which) -> np.ndarray:
    """Per event (``which``: each run's), the sum of its ``counted`` joints' steps out over
    the sum of their paces (0 where none counts): the fast joints, whose steps out stand
    above the noise, speak for the event; one joint's chance step does not."""
    finite = counted & np.isfinite(pace)
    out = np.bincount(which, weights=np.where(finite, exit_step, 0.0))
    paces = np.bincount(which, weights=np.where(finite, pace, 0.0))
    return np.divide(out, paces, out=np.zeros_like(out), where=paces > 0.0)


def _largest(values: np.ndarray, which: np.ndarray) -> np.ndarray:
    """Per event (``which``: each run's), the largest of its runs' ``values`` (>= 0)."""
    largest = np.zeros(int(which.max()) + 1)
    np.maximum.at(largest, which, values)
    return largest
