"""Euler angles of changed samples that rejoin the input without a jump the input lacks.

The write-back (:meth:`motionclean.core.motion.Motion.channel_values`) continues each run of
changed samples from the sample before it (an Euler filter). Where the run ends at an
unchanged sample, whose original values are kept bit for bit, the continued curve may
arrive on another representation of the same rotation: a whole turn off on a channel, or
on the other Euler solution. That happens when the cleaned motion turns a joint a full turn
against the input (smoothing across half-turn flips that nothing repaired, over a frame
range, does: two flips become one full turn), and it wrote a step of 257 to 478 degrees
where no input channel stepped more than 186; and where the input wraps by a whole turn
inside a changed run (the filter continues the curve across the wrap, and comes back a
turn off at the next unchanged sample, stepping 360 degrees where the input stepped 0).

:func:`rejoin` finds such steps (over 180 degrees and larger than the input's own step
between the same frames by more than :data:`JUMP_MARGIN`: where the input itself flips by
half a turn, the cleaned curve flips with it, a few degrees more or less) and rewrites the
run they are in, between its fixed neighbours. Each frame may take either Euler solution
``(a, b, c)`` / ``(a + 180, 180 - b, c + 180)``, each angle within a whole turn of the
input's own (a curve the filter carried turns away comes back); a bottleneck shortest path
over the run's frames picks the representations whose largest step beyond the larger of
:data:`SEEN_DEG` and the input's step plus :data:`JUMP_MARGIN` is least (every step over a
quarter turn the input lacks counts, not only those over half a turn), and
among those the ones whose steps go least beyond what the input's own allow (least sum of
squares, :func:`_excess`: a switch of Euler solution and back, steps of 175-178 degrees
where the input stepped 5, costs 170 degrees twice), then nearest the input's angles. The
rewritten curve does not copy the input's representation where that costs a step: it
goes on through gimbal lock rather than switch solution with the input's pair of half
turns, and does not take up the input's wraps, so its values may lie whole turns or the
other Euler solution from the input's. Every rotation stays the same; unchanged samples
are not touched; a clip without such a step is returned as it is, bit for bit.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = [
    "JUMP_DEG",
    "JUMP_MARGIN",
    "MAX_RUN",
    "ON_TURN_DEG",
    "SEEN_DEG",
    "follow_wraps",
    "rejoin",
    "settle",
    "unwrap_turns",
]

#: A written step larger than this (degrees) where the input's is smaller by more than
#: :data:`JUMP_MARGIN` is a jump to undo.
JUMP_DEG = 180.0
#: Degrees a written step over :data:`JUMP_DEG` may exceed the input's own step between the
#: same frames and still be that step (a half-turn flip the input makes, continued a few
#: degrees further by the cleaned rotations), not a new turn: another representation of a
#: rotation lies a whole turn away on a channel, or half a turn on two.
JUMP_MARGIN = 45.0
#: A written step is judged in the rewrite by how far it goes beyond the larger of this
#: (degrees) and the input's own step plus :data:`JUMP_MARGIN`: any step over a quarter turn
#: that the input does not make spins a tool that interpolates the channels, whether it
#: passes half a turn or not, so the rewrite does not trade one step over 180 degrees for
#: two of 179 (a MediaPipe estimate's forearm had been switched to the other Euler solution
#: and back, 180-degree sweeps where the rotation turned 3 degrees, to arrive a turn off at
#: the run's end and make a 155-degree step there the shorter way).
SEEN_DEG = 90.0
#: A written sample lies on a whole turn of its read value (:func:`follow_wraps`) when within
#: this (degrees) of it: cleaning moves a sample a few degrees from the read one, a repaired
#: flip or the other Euler solution puts it half a turn off on a channel (178.7 to 180.1
#: degrees on a despiked flip), where noise decides which whole turn is nearest.
ON_TURN_DEG = 90.0
#: Frames of a run rewritten at most (around the jump; longer runs keep the rest).
MAX_RUN = 4096
#: Whole turns a candidate may add to each channel of a representation ...
_WHOLE_TURNS = np.array([-360.0, 0.0, 360.0])
#: ... and every combination of them over the three channels.
_TURNS = np.array(list(itertools.product(_WHOLE_TURNS, repeat=3)))  # (27, 3)
#: Steps within this of the least largest step (degrees) are as good as it.
ALLOWANCE = 1e-6
#: Rows scanned for jumps at a time (temporaries stay small on long clips).
_SCAN_ROWS = 8192
#: Joints :func:`follow_wraps` reads at a time (temporaries stay small on long clips).
_WRAP_JOINTS = 8


def _jumps(written: np.ndarray, source: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``(row, k)`` pairs where the step from ``row`` to ``row + 1`` of ``written``'s
    column ``columns[k]`` exceeds :data:`JUMP_DEG` and the step of ``source`` between the
    same rows by :data:`JUMP_MARGIN` (the columns gathered a block of rows at a time)."""
    found = []
    n = written.shape[0]
    for at in range(0, max(n - 1, 0), _SCAN_ROWS):
        rows = slice(at, min(at + _SCAN_ROWS, n - 1) + 1)
        out = np.abs(np.diff(written[rows].take(columns, axis=1), axis=0))
        hit = np.argwhere(out > JUMP_DEG)  # few: the input's steps are read there alone
        row, column = hit[:, 0] + at, columns[hit[:, 1]]
        inp = np.abs(source[row + 1, column] - source[row, column])
        hit = hit[out[hit[:, 0], hit[:, 1]] > inp + JUMP_MARGIN]
        hit[:, 0] += at
        found.append(hit)
    return np.concatenate(found) if found else np.zeros((0, 2), dtype=np.intp)


def _solutions(angles: np.ndarray) -> np.ndarray:
    """``(n, 2, 3)``: both Euler solutions of the rotations written as ``angles`` ``(n, 3)``
    (the other nearest them, whole turns aside)."""
    other = np.stack([angles[:, 0] + 180.0, 180.0 - angles[:, 1], angles[:, 2] + 180.0], axis=1)
    other -= 360.0 * np.round((other - angles) / 360.0)
    return np.stack([angles, other], axis=1)


def _candidates(angles: np.ndarray) -> np.ndarray:
    """``(n, 54, 3)`` representations of the rotations written as ``angles`` ``(n, 3)``:
    both Euler solutions, each angle moved by -1, 0 or +1 whole turns."""
    both = _solutions(angles)
    return (both[:, :, None, :] + _TURNS[None, None]).reshape(angles.shape[0], -1, 3)


#: Weight of a representation's distance from the input's own angles (squared degrees) in
#: the smoothest path, against its squared excess steps: it decides between paths whose
#: steps are alike (both Euler solutions step alike), never against a degree of excess.
_NEAR_INPUT = 1e-9
#: Frames whose ``(54, 54)`` steps are made at once in :func:`_least_overshoot`
#: (their temporaries stay in cache).
_STEP_FRAMES = 16


@dataclass
class _Run:
    """A run of written angles between its fixed neighbours, with the input's own steps.

    ``angles`` and ``read`` ``(n, 3)``: the written and the read angles of the run's frames
    (degrees); ``before`` / ``after`` ``(3,)``: the written neighbours (None at the clip's
    ends); ``steps`` ``(n + 1, 3)``: the input's step into each frame of the run and out of
    its last (row 0 from ``before``'s frame, row ``n`` to ``after``'s; rows without a
    neighbour unused).

    A written step's *excess* (:func:`_excess`) is how far it goes beyond what the input's
    step between the same frames allows, on the channel where that is most (0 if none); its
    *overshoot*, how far beyond the larger of :data:`SEEN_DEG` and the input's step plus
    :data:`JUMP_MARGIN` (a step a tool would spin through that the input does not make;
    :func:`rejoin` rewrites the runs where one goes over :data:`JUMP_DEG`)."""

    angles: np.ndarray
    read: np.ndarray
    before: np.ndarray | None
    after: np.ndarray | None
    steps: np.ndarray

    @classmethod
    def of(cls, written: np.ndarray, source: np.ndarray, first: int, stop: int) -> _Run:
        """The run ``[first, stop)`` of columns ``written`` / ``source`` ``(F, 3)``."""
        n = written.shape[0]
        lo, hi = max(first - 1, 0), min(stop + 1, n)
        steps = np.zeros((stop - first + 1, 3))
        at = 0 if first > 0 else 1  # row 0 is the step from before's frame
        steps[at : at + hi - lo - 1] = np.diff(source[lo:hi], axis=0)
        return cls(
            written[first:stop],
            source[first:stop],
            written[first - 1] if first > 0 else None,
            written[stop] if stop < n else None,
            steps,
        )

    @property
    def centred(self) -> np.ndarray:
        """The written angles, each moved by whole turns to within half a turn of the read
        angle (the same rotations): the centre of the representations tried, so a curve
        the Euler filter carried whole turns away from the input's can come back."""
        return self.angles - 360.0 * np.round((self.angles - self.read) / 360.0)

    @property
    def limits(self) -> np.ndarray:
        """``(n + 1, 3)``: the steps beyond which a written step overshoots."""
        return np.maximum(np.abs(self.steps) + JUMP_MARGIN, SEEN_DEG)

    def largest_overshoot(self, angles: np.ndarray) -> float:
        """The largest overshoot of ``angles`` written over the run (from ``before`` to
        ``after``)."""
        first = [] if self.before is None else [self.before[None]]
        last = [] if self.after is None else [self.after[None]]
        rows = np.concatenate([*first, angles, *last])
        used = self.limits[(0 if self.before is not None else 1) :][: len(rows) - 1]
        return float((np.abs(np.diff(rows, axis=0)) - used).max(initial=0.0))


def _moves(channels: np.ndarray, rows: slice, work: np.ndarray) -> np.ndarray:
    """``(m, 3, 54, 54)``: for each frame ``i`` of ``rows`` (from 1), the step from each
    representation of frame ``i - 1`` (rows) to each of frame ``i`` (columns), channels
    first; ``channels`` are the representations ``(n, 3, 54)``, channels first, and
    ``work`` a scratch of at least ``(m, 3, 54, 54)`` (the result is a view of it)."""
    d = work[: rows.stop - rows.start]
    return np.subtract(
        channels[rows][:, :, None, :], channels[rows.start - 1 : rows.stop - 1][..., None], out=d
    )


def _steps(channels: np.ndarray, bound: np.ndarray, rows: slice, work: np.ndarray) -> np.ndarray:
    """``(m, 54, 54)``: how far each step of :func:`_moves` goes beyond ``bound[i - 1]``
    ``(3,)`` on its worst channel (0 if nowhere)."""
    d = np.abs(_moves(channels, rows, work), out=work[: rows.stop - rows.start])
    d -= bound[rows.start - 1 : rows.stop - 1][:, :, None, None]
    return _worst_channel(d)


def _excess(step: np.ndarray, read: np.ndarray, spare: np.ndarray) -> np.ndarray:
    """``step`` ``(..., 3, a, b)`` (written steps, channels on axis -3), in place: how far
    each goes beyond what the input's step ``read`` ``(..., 3)`` allows, on its worst
    channel (0 if nowhere). Where the input steps by at most :data:`SEEN_DEG`, any step as
    long as the input's or shorter; where it steps further (a wrap, a flip, a switch of
    Euler solution), one within a quarter turn, or the input's own, sign included (where
    the input switched solution at gimbal lock by two outer half turns that cancel, one had
    been written the other way, -189 and -171 degrees where the input stepped -202 and
    +201: a tool interpolating the channels is half a turn off between the frames).
    ``spare``: a scratch of ``step``'s shape."""
    big = np.abs(read) > SEEN_DEG
    followed = None
    if big.any():  # (most frames: none)
        followed = np.abs(np.subtract(step, read[..., None, None], out=spare), out=spare)
    np.abs(step, out=step)
    step -= np.minimum(np.abs(read), SEEN_DEG)[..., None, None]  # longer than allowed
    if followed is not None:
        where = np.broadcast_to(big[..., None, None], step.shape)
        np.minimum(step, followed, out=step, where=where)
    return _worst_channel(step)


def _worst_channel(d: np.ndarray) -> np.ndarray:
    """The largest of ``d`` ``(..., 3, a, b)`` over its channels, 0 if less (a view)."""
    np.maximum(d[..., 0, :, :], d[..., 1, :, :], out=d[..., 0, :, :])
    np.maximum(d[..., 0, :, :], d[..., 2, :, :], out=d[..., 0, :, :])
    return np.maximum(d[..., 0, :, :], 0.0, out=d[..., 0, :, :])


def _end_steps(cand: np.ndarray, end: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """``(54,)``: how far the step between each representation ``cand`` ``(54, 3)`` and the
    fixed neighbour ``end`` goes beyond ``bound`` ``(3,)`` on its worst channel."""
    return np.maximum((np.abs(cand - end) - bound).max(axis=1), 0.0)


def _end_excess(step: np.ndarray, read: np.ndarray) -> np.ndarray:
    """``(54,)``: the :func:`_excess` of the steps ``step`` ``(54, 3)`` between the
    representations and a fixed neighbour, where the input stepped ``read`` ``(3,)``."""
    step = np.ascontiguousarray(step.T[:, None, :])  # (3, 1, 54)
    return _excess(step, read, np.empty_like(step))[0]


def _step_floor(run: _Run) -> tuple[float, bool]:
    """The least largest overshoot any representation of the run (:func:`_candidates`) can
    take at its worst step: the largest, over the steps from ``before``, between the rows
    and to ``after``, of the least overshoot between any two representations there (the
    values :func:`_least_overshoot` finds, bit for bit). A representation's turns are
    chosen channel by channel, so that least overshoot is, over the pairs of solutions, the
    largest over channels of each channel's least step over its turns less its limit: 36
    values per channel and frame instead of 54 x 54 x 3. Also whether no channel's
    overshoot lies above that floor within :data:`ALLOWANCE` (every overshoot of a path is
    one of them): then a path that keeps within the floor plus the allowance keeps within
    the floor."""
    limits = run.limits
    turned = _solutions(run.centred)[:, :, None, :] + _WHOLE_TURNS[:, None]  # (n, 2, 3, 3)
    ends = []
    if run.before is not None:
        ends.append(np.abs(turned[0] - run.before) - limits[0])
    if run.after is not None:
        ends.append(np.abs(turned[-1] - run.after) - limits[-1])
    # (n-1, solution, turn, solution, turn, channel)
    d = np.abs(turned[1:, None, None] - turned[:-1, :, :, None, None])
    d -= limits[1:-1, None, None, None, None, :]
    floor = 0.0
    for end in ends:  # per solution: each channel's nearest turn, the worst channel
        floor = max(floor, float(end.min(axis=1).max(axis=1).min()))
    if len(d):
        least = d.min(axis=(2, 4)).max(axis=-1)  # (n-1, 2, 2): turns, then channels
        floor = max(floor, float(least.min(axis=(1, 2)).max()))
    ceiling = floor + ALLOWANCE
    alone = not any(np.any((v > floor) & (v <= ceiling)) for v in (d, *ends))
    return floor, alone


def _least_overshoot(run: _Run, floor: float | None = None) -> np.ndarray:
    """The representations of the run's angles whose largest overshoot (from ``before``,
    between the rows, to ``after``) is least, and among those the one that follows the
    input best (least sum of squared :func:`_excess`, then nearest the input's own
    angles): a bottleneck shortest path over
    :func:`_candidates`, then a shortest path over the steps it allows (loops over the
    run's frames, each step one ``(54, 54)`` comparison; the steps made
    :data:`_STEP_FRAMES` frames at a time).

    ``floor``: a least largest overshoot no path can go below, with none just above it
    (:func:`_step_floor`): the shortest path is first sought within it (where one is found,
    it is the least largest overshoot, and the bottleneck pass is not needed)."""
    cand = _candidates(run.centred)
    n, k = cand.shape[:2]
    blocks = [slice(at, min(at + _STEP_FRAMES, n)) for at in range(1, n, _STEP_FRAMES)]
    channels = np.ascontiguousarray(cand.transpose(0, 2, 1))
    limits, inside = run.limits[1:-1], run.steps[1:-1]
    work, spare = np.empty((2, _STEP_FRAMES, 3, k, k))
    zeros = np.zeros(k)
    over_first = zeros if run.before is None else _end_steps(cand[0], run.before, run.limits[0])
    over_last = zeros if run.after is None else _end_steps(cand[-1], run.after, run.limits[-1])
    excess_first = zeros if run.before is None else _end_excess(cand[0] - run.before, run.steps[0])
    excess_last = zeros if run.after is None else _end_excess(run.after - cand[-1], run.steps[-1])
    near = _NEAR_INPUT * np.square(cand - run.read[:, None, :]).sum(axis=2)  # (n, 54)

    def smoothest(allowed: float) -> tuple[np.ndarray, bool]:
        """The path of least squared excess whose overshoot stays within ``allowed``, and
        whether there is one."""
        cost = np.where(over_first <= allowed, excess_first**2 + near[0], np.inf)
        back = np.zeros((n, k), dtype=np.intp)
        for rows in blocks:
            # an overshoot beyond what is allowed costs inf (as does any path through one)
            barred = _steps(channels, limits, rows, work) > allowed
            m = rows.stop - rows.start
            squares = _excess(
                _moves(channels, rows, work), inside[rows.start - 1 : rows.stop - 1], spare[:m]
            )
            squares *= squares
            squares[barred] = np.inf
            for i, square in enumerate(squares, rows.start):
                total = cost[:, None] + square
                back[i] = total.argmin(axis=0)
                cost = total.min(axis=0) + near[i]
        ending = np.where(over_last <= allowed, cost + excess_last**2, np.inf)
        choice = int(np.argmin(ending))
        found = bool(np.isfinite(ending[choice]))
        out = np.empty_like(run.angles)
        for i in range(n - 1, -1, -1):
            out[i] = cand[i, choice]
            choice = int(back[i, choice])
        return out, found

    if floor is not None:
        out, found = smoothest(float(floor) + ALLOWANCE)
        if found:
            return out
    cost = over_first  # the least largest overshoot ...
    for rows in blocks:
        for here in _steps(channels, limits, rows, work):
            cost = np.maximum(cost[:, None], here).min(axis=0)
    return smoothest(float(np.min(np.maximum(cost, over_last))) + ALLOWANCE)[0]  # ... followed


def rejoin(values: np.ndarray, source: np.ndarray, rotation_columns: np.ndarray) -> None:
    """Rewrite, in place, the runs of changed samples of ``values`` ``(F, C)`` (written
    channel values, degrees) that step by more than :data:`JUMP_DEG` where ``source`` (the
    values read) did not (module docstring). ``rotation_columns`` ``(J, 3)``: each joint's
    rotation columns, -1 for joints without rotation channels."""
    rotating = np.flatnonzero(rotation_columns[:, 0] >= 0)
    if not rotating.size or values.shape[0] < 2:
        return
    columns = rotation_columns[rotating].ravel()
    hits = _jumps(values, source, columns)
    if not hits.size:
        return
    done: set[tuple[int, int]] = set()
    n = values.shape[0]
    for row, column in hits.tolist():
        cols = rotation_columns[rotating[column // 3]]
        # the run of changed samples around the step, at most MAX_RUN // 2 frames each side,
        # read from a window with its neighbours (a clip-long copy per jump would cost more
        # than the solve)
        low, high = max(row - MAX_RUN // 2, 0), min(row + MAX_RUN // 2, n)
        lo, hi = max(low - 1, 0), min(high + 1, n)
        written, read = values[lo:hi, cols], source[lo:hi, cols]
        kept = np.all(written == read, axis=1)
        kept_before = np.flatnonzero(kept[low - lo : row - lo])
        kept_after = np.flatnonzero(kept[row + 1 - lo : high - lo])
        first = low + int(kept_before[-1]) + 1 if kept_before.size else low
        stop = row + 1 + int(kept_after[0]) if kept_after.size else high
        if kept[first - lo] and first == row:
            first += 1  # the step leaves a kept sample: the run starts after it
        if (int(cols[0]), first) in done or first >= stop:
            continue
        done.add((int(cols[0]), first))
        run = _Run.of(written, read, first - lo, stop - lo)
        largest = run.largest_overshoot(run.angles)
        floor, alone = _step_floor(run)
        if largest <= floor:
            continue  # no representation overshoots less (a full solve would find none)
        better = _least_overshoot(run, floor if alone else None)
        if run.largest_overshoot(better) < largest:
            values[first:stop, cols] = better


def follow_wraps(values: np.ndarray, source: np.ndarray, rotation_columns: np.ndarray) -> None:
    """Move, in place, the changed samples of ``values`` ``(F, C)`` (written channel values,
    degrees) that a continued curve carried whole turns from ``source`` (the values read)
    back onto the turn of the input's own, on every joint where that makes the written
    curve wrap where the input wraps and nowhere else.

    A changed run continues the curve from the sample before it; where the input wraps
    from +180 to -180 inside the run and the run ends at the clip's end (nothing kept after
    it to rejoin), the written curve went on past 180 and stayed a turn off the input's
    values to the end (a hip written 181 to 540 degrees on 184 of 212 frames where the
    rotation changed by 0.14). Each sample is moved by the whole turns ``k`` it lies from
    the read value (:func:`_turns_off`: a sample half a turn off, a repaired flip or the
    other Euler solution, takes those of the sample before); a joint's channels are moved
    only if at every frame where ``k`` changes on one of them, each channel's moved step is
    within :data:`JUMP_MARGIN` of the input's own (an input wrap, the written curve then
    stepping as the input does). A despiked flip's Xrotation had been written -1.01, 0.03,
    -358.93, -357.89, 3.15, a whole turn where the input stepped by 181 (the un-flip) and
    one where it wrapped inside the flip; and a channel moved alone had stepped 356
    degrees where the input stepped 322 on two channels that cancel at gimbal lock. Every
    rotation stays the same; kept samples (``k = 0``) are not touched.
    ``rotation_columns`` ``(J, 3)``: each joint's rotation columns, -1 for joints without
    rotation channels."""
    joints = rotation_columns[rotation_columns[:, 0] >= 0]
    if values.shape[0] < 2 or not joints.size:
        return
    joints = joints[_turned(values, source)[joints].any(axis=1)]  # (most clips: none)
    for at in range(0, len(joints), _WRAP_JOINTS):
        chosen = joints[at : at + _WRAP_JOINTS].ravel()
        written, read = values[:, chosen], source[:, chosen]
        turns = _turns_off(written, read)
        moved = written - 360.0 * turns
        per_joint = (-1, chosen.size // 3, 3)  # (F, joints, 3) views
        turns_j, moved_j, read_j = (a.reshape(per_joint) for a in (turns, moved, read))
        # few: where the input wraps inside a changed run
        row, joint = np.nonzero((turns_j[1:] != turns_j[:-1]).any(axis=2))
        step_moved = moved_j[row + 1, joint] - moved_j[row, joint]
        step_in = read_j[row + 1, joint] - read_j[row, joint]
        with np.errstate(invalid="ignore"):
            follows = (np.abs(step_moved - step_in) <= JUMP_MARGIN).all(axis=1)
        move = np.asarray(turns_j.any(axis=(0, 2)))
        move[joint[~follows]] = False
        if move.any():
            columns = np.repeat(move, 3)
            values[:, chosen[columns]] = moved[:, columns]


def _turns_off(written: np.ndarray, read: np.ndarray) -> np.ndarray:
    """``(F, C)``: the whole turns each sample of ``written`` lies from ``read``'s where it
    lies within :data:`ON_TURN_DEG` of them; a sample further off (half a turn: a repaired
    flip, the other Euler solution), whose nearest whole turn noise decides, takes the turns
    of the last sample before it that is not (the first after it at a column's start, 0
    where none is). Samples not finite: 0."""
    with np.errstate(invalid="ignore"):
        off = (written - read) / 360.0
        turns = np.round(off)
        away = np.abs(off - turns) > ON_TURN_DEG / 360.0
    np.copyto(turns, 0.0, where=~np.isfinite(turns) | away)
    from .motion import hold_missing  # (motion imports this module)

    return hold_missing(turns, away)


def _turned(values: np.ndarray, source: np.ndarray) -> np.ndarray:
    """``(C,)``: the columns where some sample of ``values`` lies more than half a turn from
    ``source``'s (read a block of rows at a time: contiguous, small temporaries)."""
    turned = np.zeros(values.shape[1], dtype=bool)
    for at in range(0, values.shape[0], _SCAN_ROWS):
        rows = slice(at, at + _SCAN_ROWS)
        with np.errstate(invalid="ignore"):
            turned |= (np.abs(values[rows] - source[rows]) > 180.0).any(axis=0)
    return turned


def settle(values: np.ndarray, source: np.ndarray, rotation_columns: np.ndarray) -> None:
    """:func:`rejoin` then :func:`follow_wraps`, in place: the changed samples of ``values``
    ``(F, C)`` written on the representations that make no step the read ``source`` lacks,
    on its whole turns where they then wrap where it wraps (elsewhere they may lie whole
    turns or the other Euler solution from its values), the unchanged ones as read (the
    files' write-back; Blender's curves, whose unchanged keys may move by whole turns, take
    their own way)."""
    rejoin(values, source, rotation_columns)
    follow_wraps(values, source, rotation_columns)


#: A channel of frames written afresh that steps by more than this (degrees, whole turns
#: aside) where the rotation itself leaps is written on the principal angles' own turns
#: there (:func:`unwrap_turns`): it jumps either way, and unwrapped it had kept every
#: turn the flips before it made (a thumb's channel within -124..84 degrees read, written
#: down to -1002 after a resample).
LEAP_STEP_DEG = 90.0


def unwrap_turns(angles: np.ndarray, carry: tuple | None, leaps: np.ndarray | None = None) -> tuple:
    """Move, in place, each channel of a block of written angles ``angles`` ``(F, ...)``
    (degrees) by the whole turns that keep every step within half a turn, continuing the
    block before it (``carry``: what this returns for it; None at the clip's first frame):
    :func:`numpy.unwrap` a block at a time. For frames written afresh (resampled, another
    format's rotations), whose chain restarts on the principal angles where the rotation
    itself leaps (a flip nothing repaired, a cut), which had stepped a channel 331 degrees
    where 29 would do. ``leaps`` ``(F, J)``: the frames where the rotation leaps; a channel
    that steps there by more than :data:`LEAP_STEP_DEG` even unwrapped keeps the turns it
    is written with (no turn carried past a jump, so flips add none). Returns the carry
    for the next block."""
    last, offset = (angles[0], np.zeros(angles.shape[1:])) if carry is None else carry
    steps = np.diff(np.concatenate([last[None], angles]), axis=0)
    steps /= 360.0
    turns = np.round(steps)
    total = np.cumsum(turns, axis=0)
    moved = offset - 360.0 * total
    if leaps is not None:
        reset = leaps[..., None] & (np.abs(steps - turns) > LEAP_STEP_DEG / 360.0)
        if reset.any():  # the turns since the last reset (or the block's start, with offset)
            frame = np.arange(angles.shape[0]).reshape((-1,) + (1,) * (angles.ndim - 1))
            since = np.maximum.accumulate(np.where(reset, frame, -1), axis=0)
            base = np.take_along_axis(total, np.maximum(since, 0), axis=0)
            moved = np.where(since >= 0, -360.0 * (total - base), moved)
    carry = (angles[-1].copy(), moved[-1])
    angles += moved
    return carry
