"""Flip and spike repair (despike): fix capture defects before any smoothing.

Real captures contain samples that no smoothing filter should be asked to fix: a joint
that toggles for a while into a state half a turn away (a *flip*), or a few samples that
jump away from their neighbours and come back (a *spike*). A linear filter smears either
one over its whole support. Two defects, two repairs:

1. **Un-flip.** A step of at least ``flip_deg`` between two frames (a genuine joint never
   turns that far in one frame) is taken as a half-turn flip. The half-turn axis ``a`` is
   estimated per joint from all such steps as the principal axis of the scatter matrix
   ``sum v v^T`` of their rotation axes ``v`` (sign free), measured in the parent frame
   (``q_{i+1} q_i^-1``) or in the joint's own frame (``q_i^-1 q_{i+1}``), whichever is the
   more concentrated; a joint whose flip steps do not agree on one axis is not un-flipped.
   With ``f = (0, a)`` the flip parity toggles at every step of more than 90 degrees that
   ``f`` explains: undoing the half-turn leaves a step smaller than the step itself and
   than ``180 - flip_deg`` degrees (each step's angle depends only on whether the parity
   changes there, so toggling wherever the half-turn shortens the step gives the least
   total path length). Toggles inside a spike (below) that is not itself entered and left
   by a toggle are dropped: the spike's ends share one state. The parity held by fewer
   frames is the flipped state; those frames are multiplied by ``f`` (``f q`` or
   ``q f``), which keeps the real motion within a flipped run. A run that reaches the
   clip's first or last frame (one toggle: the parity cannot see which side flipped) is
   left as it is where it agrees with the rest of the joint's frames as it is
   (:func:`_to_turn_back`): a capture that slid into half a turn off and snapped back in
   one step leaves its correct frames after the snap in the minority.
2. **Interpolate.** What remains (short spikes, ragged transitions) is replaced by
   interpolation between the good neighbours. A step is a *jump* when its angle exceeds

       T = clip(median(s) + threshold * 1.4826 * MAD(s),  min_deg_per_s dt,  max_deg_per_s dt)

   where ``s`` are the joint's frame-to-frame rotation angles and ``1.4826 MAD`` is the
   robust standard deviation (``dt`` the frame time). Frames ``a+1 .. a+L`` form a
   *spike* when all of these hold:

   * it is brief: ``L dt <= max_spike_s`` (whole frames, at least one; also ``L <=
     max_run`` when given), and so is the stretch it forms with the spikes it overlaps
     or touches (without a good frame between them, each spike's test read the other's
     frames as good: jitter of a hand over 16 frames at 120 fps chains into spikes of 7,
     3 and 6). A defect is brief; the same excursion lasting longer may be genuine (a toe
     flexing out and back within 100 ms spans 12 frames at 120 fps but 3 at 30 fps,
     where its steps are four times larger);
   * the steps into and out of the run are jumps, and abrupt: each differs by more than
     ``T`` from the step on its outer side, as a vector ``2 log(q_i^-1 q_{i+1})`` (a
     smooth reversal of direction is not abrupt);
   * the signal comes back: the rotation from frame ``a`` to frame ``b = a+L+1`` is
     smaller than both jumps (a turn in one direction, however fast, never comes back);
   * it leaves the local trend: with ``P`` the cubic through the good neighbours ``a-1,
     a`` and ``b, b+1`` (the interpolant below, i.e. the repair itself), the first and
     the last frame of the run are both further from ``P`` than ``trend_ratio`` times
     the error of that cubic at the neighbours, ``e = max(d(q_a, P'_a), d(q_b, P''_b))``
     with ``P'`` the cubic across the gap from ``a-2, a-1`` to ``b, b+1`` and ``P''``
     from ``a-1, a`` to ``b+1, b+2``. ``e`` measures how well a cubic follows this
     motion over a gap of ``L+1`` frames, so the test scales with the frame rate and
     with the motion's own smoothness: fast genuine motion that is sampled too coarsely
     to follow leaves the neighbours off the cubic too, a spike on a smooth signal does
     not. A run with a neighbour that cannot be predicted (within two frames of a clip
     end) has no trend on that side to be judged by: a clip cut inside a fast twist
     would lose the twist's tail. Only the cap below repairs it.

   Finally no step may exceed the absolute cap ``max_deg_per_s dt`` (no human joint
   turns that fast): the two frames of a step above the cap join the interpolated set,
   and every gap whose interpolated steps still exceed the cap widens by one frame per
   side and pass (at most as many passes as the longest spike has frames). A spike
   touching the first or last frame has no good frame on one side and is only caught by
   the cap: where no more frames than the longest spike lie between a step above the cap
   and a clip end and they hold one pose (a reference pose, which does not move with the
   motion), those frames alone are repaired (held at the frame past the step), never that
   frame, which is the motion's own (a reference pose at frame 0 does not take frame 1
   with it). The report tells these cap runs (those holding no spike's frame) apart as
   ``capped``: a step over the cap need not come back (an inertial suit's toe snapping flat
   in one direction is capped, not a spike). ``T`` comes
   from the steps as read, before un-flipping (the median and MAD are not moved by a few
   dozen flips); all limits are in degrees per second, so they keep their meaning at any
   frame rate.

The interpolant is the cubic of the four-point subdivision scheme (Eq. 15-17 of 003)
through the two good frames on each side of a gap, on their actual (non-uniform) knots,
written in the form of 003 Eq. 16: ``slerp_{c2+c3}(q_l, q_r) exp(-c0 w_0 + c3 w_2)`` with
``c`` the cubic Lagrange weights, ``w_0 = log(q_{l-1}^-1 q_l)`` and
``w_2 = log(q_r^-1 q_{r+1})``; at the uniform midpoint it is exactly Eq. 16, and it
reproduces a constant angular velocity exactly. Where an outer neighbour is missing (clip
end or another gap) it falls back to slerp; a gap touching a clip end holds the nearest
good frame.

Arrays are time-major, ``(F, ..., 4)`` quaternions ``(w, x, y, z)`` or ``(F, ..., 3)``
vectors; every trailing index (joint column) is treated independently and at once, but
for cuts between takes (:mod:`motionclean.core.takes`: a step where most columns jump at
once is no column's flip or spike, and nothing is repaired across it). Columns without
defects are returned bit for bit. Angles given to or reported by this
module are in degrees of rotation.

Implementation: the whole array is read for the steps (one dot product and ``acos`` per
pair), their median and MAD (partial selections, on the columns with a step above the
floor) and a few comparisons; everything else works on flat indices of the sparse jumps,
flip steps and gaps, and on the few columns that change, with small-array versions of the
quaternion product, ``log`` and ``exp`` (the terms of :mod:`motionclean.core.quat`'s kernels in
their order) and the four-point weights tabulated for short gaps. A call costs about one
Lee-Shin pass on the corpus clips (``python bench/despike.py``).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..core import checks, quat
from ..core.motion import hold_missing, missing_before, run_labels
from ..core.rates import frames_floor
from ..core.takes import (
    JUMP_THRESHOLD,
    LONGEST_SPIKE_S,
    MAX_DEG_PER_S,
    MIN_DEG_PER_S,
    cut_steps,
    jump_thresholds,
)

__all__ = [
    "DespikeReport",
    "despike",
    "despike_positions",
    "despike_positions_with_report",
    "despike_with_report",
]


#: A spike must leave the cubic trend of its good neighbours by this many times that
#: trend's own error there (``trend_ratio``; 0: no test).
TREND_RATIO = 3.0
#: The smallest one-frame step (degrees) taken as a half-turn flip (``flip_deg``).
FLIP_DEG = 150.0
#: Share of the scatter of the flip-step axes that the half-turn axis must explain (1 when
#: all flip steps turn about the same axis) for a joint to be un-flipped.
FLIP_AXIS_SHARE = 0.9


@dataclass(frozen=True)
class DespikeReport:
    """What :func:`despike_with_report` changed, per frame and trailing index (column).

    ``unflipped`` and ``interpolated`` are ``(F, ...)`` boolean masks (a frame can be
    both: un-flipped, then interpolated); ``capped`` (None: none) marks the interpolated
    runs that hold no spike, only a step over the cap (a turn too fast for a body, which
    need not come back: an inertial suit's toe snapping flat). ``threshold`` is the jump
    threshold ``T`` per column (degrees for rotations, length units for positions; per
    frame, not per second). ``max_step_before`` / ``max_step_after`` are each column's largest
    frame-to-frame step before and after repair, in the same units. ``cuts`` are the
    frames that start a new take (most moving columns jump into them at once): no flip or
    spike is repaired across them.
    """

    unflipped: np.ndarray
    interpolated: np.ndarray
    threshold: np.ndarray
    max_step_before: np.ndarray
    max_step_after: np.ndarray
    cuts: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    capped: np.ndarray | None = None

    @property
    def repaired(self) -> np.ndarray:
        """``(F, ...)`` bool: frames changed by either repair."""
        return self.unflipped | self.interpolated

    def counts(self, kind: str = "repaired") -> np.ndarray:
        """Frames changed per column, shape ``(...)``; ``kind`` is ``"repaired"``,
        ``"unflipped"``, ``"interpolated"`` or ``"capped"``."""
        return self._mask(kind).sum(axis=0)

    def runs(self, index, kind: str = "repaired") -> list[tuple[int, int]]:
        """Maximal runs of changed frames of one column as half-open ``(start, stop)``
        frame ranges. ``index`` is an int or a tuple into the trailing shape."""
        column = self._mask(kind)[(slice(None), *np.atleast_1d(index))]
        edges = np.diff(np.concatenate([[0], column.astype(np.int8), [0]]))
        return list(
            zip(
                np.flatnonzero(edges == 1).tolist(),
                np.flatnonzero(edges == -1).tolist(),
                strict=True,
            )
        )

    def summary(self, index) -> dict:
        """JSON-ready figures of one column: frames repaired, the un-flipped and the
        interpolated runs (``[start, stop)`` frames) and those of the latter that only
        capped a step, the jump threshold and the largest step before and after."""
        return {
            "frames_repaired": int(self.counts()[index]),
            "unflipped": [list(r) for r in self.runs(index, "unflipped")],
            "interpolated": [list(r) for r in self.runs(index, "interpolated")],
            "capped": [list(r) for r in self.runs(index, "capped")],
            "threshold": float(self.threshold[index]),
            "max_step": {
                "before": float(self.max_step_before[index]),
                "after": float(self.max_step_after[index]),
            },
        }

    def _mask(self, kind: str) -> np.ndarray:
        if kind not in ("repaired", "unflipped", "interpolated", "capped"):
            raise ValueError(
                f"kind must be repaired, unflipped, interpolated or capped, got {kind!r}"
            )
        if kind == "capped" and self.capped is None:
            return np.zeros_like(self.interpolated)
        return getattr(self, kind)


def _flip_axes(x, i, stride, col, cols):
    """Half-turn axis of each column in ``cols``, whether it acts on the left (parent
    frame), and whether the flip steps agree on it.

    The flip steps go from the rows ``i`` to ``i + stride`` of the samples ``x`` (N, 4)
    and lie in the columns ``col``. Principal eigenvector of ``sum v v^T`` over them, for
    the axes ``v`` of ``q_{i+1} q_i^-1`` (parent frame) and of ``q_i^-1 q_{i+1}`` (own
    frame); the frame whose largest eigenvalue takes the larger share of the trace wins,
    and the axis is trusted when that share is at least :data:`FLIP_AXIS_SHARE`.
    """
    a, b = x.take(i, axis=0), x.take(i + stride, axis=0)
    a_inv = quat.conjugate(a)
    rel = quat.multiply(np.concatenate([b, a_inv]), np.concatenate([a_inv, b]))[:, 1:]
    v = rel / np.maximum(_norm(rel), 1e-300)[:, None]
    outer = (v[:, :, None] * v[:, None, :]).reshape(2, i.size, 9)
    one_hot = (col[:, None] == cols).astype(np.float64)  # (steps, columns)
    scatter = np.einsum("sc,fsk->fck", one_hot, outer).reshape(2, cols.size, 3, 3)
    values, vectors = np.linalg.eigh(scatter)  # frames: 0 parent, 1 own
    share = values[..., -1] / np.maximum(values.sum(axis=-1), 1e-300)
    left = share[0] >= share[1]
    axis = np.where(left[:, None], vectors[0, :, :, -1], vectors[1, :, :, -1])
    return axis, left, share.max(axis=0) >= FLIP_AXIS_SHARE


def _half_turn(x, i, slot, axis, left):
    """``f q`` (parent frame) or ``q f`` (own frame) for the rows ``i`` of ``x`` (N, 4),
    with ``f = (0, axis[slot])`` and the side ``left[slot]``."""
    f = np.concatenate([np.zeros((slot.size, 1)), axis[slot]], axis=-1)
    q = x.take(i, axis=0)
    on_left = left[slot][:, None]
    return quat.multiply(np.where(on_left, f, q), np.where(on_left, q, f))


def _flip_toggles(x: np.ndarray, steps: np.ndarray, flip_rad: float, across=None):
    """Where the half-turn parity toggles, and the half-turn of each flipping column.

    ``x`` (F C, 4) are the samples, frame ``a`` of column ``c`` at row ``a C + c``, and
    ``steps`` (F-1, C) their steps. Returns ``cols``, the columns that may toggle (those
    with a step of at least ``flip_rad`` whose flip steps agree on a half-turn axis),
    their ``(F-1, cols)`` toggles, axes and sides (see :func:`_half_turn`). A step toggles
    when it exceeds 90 degrees and undoing the half-turn leaves a step under both the
    step itself and ``pi - flip_rad`` (30 degrees by default). ``across``
    (:class:`_Across`) marks the steps across dropouts: a half-turn residual may reach the
    ``slack`` the joint may turn meanwhile, but never half the step, and a step within the
    ``reach`` of its fastest turning over the frames spanned is motion, no toggle.
    """
    n_cols = steps.shape[1]
    i = (steps >= flip_rad).reshape(-1).nonzero()[0]  # also the row of the step's frame
    col = i % n_cols
    cols = np.bincount(col, minlength=n_cols).nonzero()[0]
    if cols.size:
        axis, left, agreed = _flip_axes(x, i, n_cols, col, cols)
        cols, axis, left = cols[agreed], axis[agreed], left[agreed]
    else:
        axis = left = None
    big = steps.take(cols, axis=1)
    toggles = np.zeros(big.shape, dtype=bool)
    k = (big > 0.5 * np.pi).reshape(-1).nonzero()[0]
    if k.size:
        step, slot = np.divmod(k, cols.size)
        i = step * n_cols + cols[slot]
        residual = _rotation_distance(
            _half_turn(x, i, slot, axis, left), x.take(i + n_cols, axis=0)
        )
        step = big.reshape(-1).take(k)
        limit = np.full(k.size, np.pi - flip_rad)
        if across is not None:  # steps across dropouts: what the joint may turn meanwhile
            slack = across.slack.take(cols, axis=1).reshape(-1).take(k)
            limit = np.where(slack > 0, np.maximum(limit, np.minimum(slack, 0.5 * step)), limit)
        toggles.reshape(-1)[k] = (residual < step) & (residual <= limit)
        if across is not None:
            _motion_across(toggles, big, across.reach.take(cols, axis=1))
    return cols, toggles, axis, left


def _motion_across(toggles: np.ndarray, steps: np.ndarray, reach: np.ndarray) -> None:
    """Clear, in place, the ``toggles`` (F-1, C) on steps across dropouts that the joint
    could have turned at its fastest (``steps`` within ``reach``, both (F-1, C)) in the
    columns whose other toggles (in view, or across a dropout too short to turn it) pair
    among themselves: a turn while occluded, with no flip to pair with. A half-turn run
    with such a step at one end keeps it as that end, its other end being an unpaired flip
    no motion explains."""
    plausible = (reach > 0) & (steps <= reach)
    unpaired = (toggles & ~plausible).sum(axis=0) % 2 == 1
    toggles &= ~(plausible & ~unpaired)


def _parity(toggles: np.ndarray, known: np.ndarray | None = None) -> np.ndarray:
    """``(F, C)`` flipped frames: the parity of the toggles so far, the state fewer frames
    hold (of the ``known`` (F, C) frames, when given)."""
    parity = np.zeros((toggles.shape[0] + 1, toggles.shape[1]), dtype=bool)
    parity[1:] = np.cumsum(toggles, axis=0) % 2 == 1
    if known is None:
        return parity ^ (parity.sum(axis=0) > parity.shape[0] / 2)
    return parity ^ ((parity & known).sum(axis=0) > known.sum(axis=0) / 2)


def _spike_runs(x, steps, jump, max_len, trend_ratio, dist, velocity, interpolate, toggles=None):
    """Runs of frames ``a+1 .. a+L`` (``L <= max_len``) entered and left by abrupt jumps
    that come back off the local trend, as arrays ``(first frame a+1, length L, column)``.

    ``x`` (F, C, n) is contiguous, ``steps`` (F-1, C) are the distances between its
    consecutive frames, ``jump`` (C,) the jump threshold, ``dist(x, y)`` the distance
    between samples, ``velocity(x, i, stride)`` the displacement vectors from the rows
    ``i`` to ``i + stride`` of ``x`` as ``(F C, n)`` (their norms are the steps) and
    ``interpolate`` the gap interpolant. Step ``a`` into the run and step ``a+L`` out of
    it must both exceed ``jump`` and differ from the step on their outer side by more than
    ``jump`` (an abrupt change of velocity, which a smooth reversal of direction is not),
    ``dist(x_a, x_{a+L+1})`` must be under both jumps, and the run must stand off the
    trend (:func:`_off_trend`). With ``toggles`` (F-1, C), only the runs whose steps
    ``a .. a+L`` hold a toggle and are not both entered and left by one are returned (the
    only ones that matter to un-flipping). Only the sparse jumps are examined.
    """
    n_cols = steps.shape[1]
    size = steps.size
    per_block = max(1, RUN_ENDS_PER_BLOCK // max_len)
    # The flat index a C + c is both step a and frame a of column c; the padding makes
    # every step a + L (L <= max_len) of a jump addressable.
    is_jump = np.zeros(size + max_len * n_cols, dtype=bool)
    np.greater(steps, jump, out=is_jump[:size].reshape(steps.shape))
    jumps = is_jump.nonzero()[0]
    held = None if toggles is None else np.cumsum(toggles, axis=0).reshape(-1)
    flat_x = x.reshape(size + n_cols, x.shape[-1])
    found = [
        _runs_from(
            jumps[at : at + per_block],
            is_jump,
            flat_x,
            steps,
            jump,
            max_len,
            trend_ratio,
            dist,
            velocity,
            interpolate,
            toggles,
            held,
        )
        for at in range(0, jumps.size, per_block)
    ]
    first = np.concatenate([f for f, _ in found]) if found else jumps
    last = np.concatenate([b for _, b in found]) if found else jumps
    a, c = np.divmod(first, n_cols)
    return a + 1, (last - first) // n_cols, c


#: Run ends (jumps x ``max_len``) examined together by :func:`_spike_runs`: the working set
#: stays small however many jumps a noisy clip has and however long a spike may be.
RUN_ENDS_PER_BLOCK = 4096 * 16


def _runs_from(
    first,
    is_jump,
    flat_x,
    steps,
    jump,
    max_len,
    trend_ratio,
    dist,
    velocity,
    interpolate,
    toggles,
    held,
):
    """:func:`_spike_runs` for the jumps ``first`` (flat indices): the rows of each kept
    run's first and last steps, ``(first, last)``."""
    n_cols = steps.shape[1]
    size = steps.size
    last = (first[:, None] + n_cols * np.arange(1, max_len + 1)).reshape(-1)  # step a + L
    first = np.repeat(first, max_len)
    keep = is_jump.take(last)
    first, last = first[keep], last[keep]
    if toggles is not None:
        flat = toggles.reshape(-1)
        at_first, at_last = flat.take(first), flat.take(last)
        keep = (held.take(last) - held.take(first) + at_first > 0) & ~(at_first & at_last)
        first, last = first[keep], last[keep]
    flat_steps = steps.reshape(-1)
    keep = dist(flat_x.take(first, axis=0), flat_x.take(last + n_cols, axis=0)) < np.minimum(
        flat_steps.take(first), flat_steps.take(last)
    )
    first, last = first[keep], last[keep]
    if first.size:
        # Abrupt: the velocity changes by more than the threshold into and out of the run.
        n = first.size
        at_start, at_end = first < n_cols, last + n_cols >= size
        v = velocity(
            flat_x,
            np.concatenate(
                [
                    np.where(at_start, first, first - n_cols),
                    first,
                    last,
                    np.where(at_end, last, last + n_cols),
                ]
            ),
            n_cols,
        )
        limit = jump.take(first % n_cols)
        keep = (at_start | (_norm(v[n : 2 * n] - v[:n]) > limit)) & (
            at_end | (_norm(v[2 * n : 3 * n] - v[3 * n :]) > limit)
        )
        first, last = first[keep], last[keep]
        if trend_ratio > 0 and first.size:
            keep = _off_trend(flat_x, n_cols, first, last, trend_ratio, dist, interpolate)
            first, last = first[keep], last[keep]
    return first, last


def _off_trend(x, stride, first, last, trend_ratio, dist, interpolate):
    """Whether the runs ``a+1 .. a+L`` leave the local trend.

    ``x`` (F C, n) holds frame ``a`` of a column at a row ``r`` and frame ``a + 1`` at
    ``r + stride``; the runs are given by the rows ``first`` of frame ``a`` and ``last``
    of frame ``a+L``. ``P``: the cubic through the good neighbours ``a-1, a`` and ``b,
    b+1`` (``b = a+L+1``; 003 Eq. 17, the repair's own interpolant). The run's first and
    last frames must both be further from ``P`` than ``trend_ratio`` times the error ``e``
    of the same cubic at the neighbours: ``x_a`` predicted across the gap from ``a-2,
    a-1`` to ``b, b+1`` and ``x_b`` from ``a-1, a`` to ``b+1, b+2``; a run with a
    neighbour that cannot be predicted (too near a clip end) never leaves it. See the
    module docstring.
    """
    n = first.size
    after = last + stride  # frame b
    predict_a, predict_b = first >= stride, after + stride < x.shape[0]
    at = np.concatenate([first + stride, last, first, after])
    lo = np.concatenate([first, first, np.where(predict_a, first - stride, first), first])
    hi = np.concatenate([after, after, after, np.where(predict_b, after + stride, after)])
    off = dist(
        x.take(at, axis=0), interpolate(x, _Knots.around(at, lo, hi, stride, x.shape[0]), "cubic")
    ).reshape(4, n)
    error = np.maximum(np.where(predict_a, off[2], 0.0), np.where(predict_b, off[3], 0.0))
    return (np.minimum(off[0], off[1]) > trend_ratio * error) & predict_a & predict_b


def _brief(first, length, col, n_frames: int, max_len: int):
    """The spike runs (first frame, length, column) whose stretch, with the runs of their
    column they overlap or touch, is at most ``max_len`` frames. Runs that chain on have
    no good frame between them (each one's cubic read the other's frames as good): a
    stretch that keeps leaving the trend for longer than a spike lasts is jitter or motion,
    not a brief defect."""
    if not first.size:
        return first, length, col
    order = np.lexsort((first, col))
    first, length, col = first[order], length[order], col[order]
    start = col * (n_frames + 1) + first  # frames as keys that sort by column, then frame
    stop = np.maximum.accumulate(start + length)  # the furthest stop of the runs so far
    new = np.ones(first.size, dtype=bool)
    new[1:] = start[1:] > stop[:-1]
    group = np.cumsum(new) - 1
    ends = np.append(np.flatnonzero(new)[1:] - 1, first.size - 1)  # each stretch's last run
    keep = (stop[ends] - start[new] <= max_len)[group]
    return first[keep], length[keep], col[keep]


def _mark(first, length, col, shape) -> np.ndarray:
    """Boolean ``shape`` mask with rows ``first .. first+length-1`` set in each ``col``."""
    mask = np.zeros(shape, dtype=bool)
    if first.size:
        offset = np.arange(length.sum()) - np.repeat(np.cumsum(length) - length, length)
        mask[np.repeat(first, length) + offset, np.repeat(col, length)] = True
    return mask


@dataclass(frozen=True)
class _Knots:
    """Samples to interpolate, as rows of the samples ``(F C, n)`` (frame ``a`` of a column
    at a row ``r``, frame ``a+1`` at ``r + stride``): per sample its row ``at``, the rows
    ``lo`` and ``hi`` of the good frames around its gap and ``lo2`` and ``hi2`` of the
    next good frames outward (``-1`` where missing: at a clip end or next to another gap),
    and its distances ``da`` and ``db`` in frames to ``lo`` and ``hi`` (with a positive
    sum, also where a neighbour is missing)."""

    at: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    lo2: np.ndarray
    hi2: np.ndarray
    da: np.ndarray
    db: np.ndarray

    @classmethod
    def around(cls, at, lo, hi, stride: int, size: int) -> _Knots:
        """Knots for gaps between the good rows ``lo`` and ``hi`` with every frame outside
        them good, in ``size`` rows."""
        return cls(
            at,
            lo,
            hi,
            np.where(lo >= stride, lo - stride, -1),
            np.where(hi + stride < size, hi + stride, -1),
            (at - lo) // stride,
            (hi - at) // stride,
        )


def _gap_knots(mask: np.ndarray) -> _Knots:
    """The knots (:class:`_Knots`) of the masked samples of ``mask`` (F, C), whose rows
    are ``a C + c``."""
    n_frames, n_cols = mask.shape
    at = mask.reshape(-1).nonzero()[0]
    frame, col = np.divmod(at, n_cols)
    # The good samples as sorted keys c F + a (with sentinels): a masked sample's
    # neighbours are the good keys just before and after its own, within its column.
    good = np.concatenate([[-1], (~mask).T.reshape(-1).nonzero()[0], [mask.size]])
    base = col * n_frames
    j = np.searchsorted(good, base + frame)
    lo, hi = good.take(j - 1) - base, good.take(j) - base  # frames
    has_l, has_r = lo >= 0, hi < n_frames
    # The next frames outward, when good (the keys next to the neighbours' own).
    lo2 = has_l & (lo >= 1) & (good.take(j - 2) == good.take(j - 1) - 1)
    hi2 = has_r & (hi + 1 < n_frames) & (good.take(j + 1, mode="clip") == good.take(j) + 1)
    lo, hi = lo * n_cols + col, hi * n_cols + col  # rows
    return _Knots(
        at,
        np.where(has_l, lo, -1),
        np.where(has_r, hi, -1),
        np.where(lo2, lo - n_cols, -1),
        np.where(hi2, hi + n_cols, -1),
        np.where(has_l, (at - lo) // n_cols, 1),
        np.where(has_r, (hi - at) // n_cols, 1),
    )


def _fill(x, mask, dist, interpolate, method, cap, passes):
    """Interpolate the masked samples of ``x`` (F, C, n, contiguous) in place, widening
    every gap whose interpolated steps exceed ``cap`` by a frame per side, at most
    ``passes`` times. Steps away from the gaps are not looked at: the caller masked every
    step above the cap. Returns the final mask."""
    n_cols = mask.shape[1]
    flat_x, flat_mask = x.reshape(mask.size, x.shape[-1]), mask.reshape(-1)
    for done in range(passes + 1):
        knots = _gap_knots(mask)
        flat_x[knots.at] = interpolate(flat_x, knots, method)
        if done == passes:
            break
        # The steps into and out of every interpolated sample, as the row of their first
        # frame; those above the cap.
        step = np.concatenate([knots.at - n_cols, knots.at])
        step = step[(step >= 0) & (step < mask.size - n_cols)]
        step = step[dist(flat_x.take(step, axis=0), flat_x.take(step + n_cols, axis=0)) > cap]
        if not step.size:
            break
        inside = np.where(flat_mask.take(step), step, step + n_cols)  # a frame of the gap
        k = np.searchsorted(knots.at, inside)
        lo, hi = knots.lo.take(k), knots.hi.take(k)
        flat_mask[np.where(lo >= 0, lo, inside)] = True
        flat_mask[np.where(hi >= 0, hi, inside)] = True
    return mask


def _lagrange(frame, left, right):
    """Cubic Lagrange weights ``c0..c3`` at ``frame`` on the knots ``left-1, left, right,
    right+1`` (the non-uniform four-point scheme, Eq. 17 of 003), in closed form with
    ``a = frame - left``, ``b = right - frame`` and ``g = right - left``."""
    a = np.subtract(frame, left, dtype=np.float64)
    b = np.subtract(right, frame, dtype=np.float64)
    g = a + b
    g1 = g + 1.0
    outer, inner = g1 * (g + 2.0), g * g1
    a1, b1, minus_a = a + 1.0, b + 1.0, -a
    return (
        minus_a * b * b1 / outer,
        a1 * b * b1 / inner,
        a * a1 * b1 / inner,
        minus_a * a1 * b / outer,
    )


#: Gaps shorter than this many frames get their weights from a table.
_TABLE_SIZE = 32


def _lagrange_table(size: int) -> np.ndarray:
    """:func:`_lagrange` ``a`` frames from the left inner knot and ``b`` from the right
    one, ``a, b < size``, in row ``a * size + b`` of a ``(size^2, 4)`` array (row 0, a
    gap of no frames, is not a number and never used)."""
    a, b = np.divmod(np.arange(size * size), size)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.stack(_lagrange(a, 0, a + b), axis=-1)


_LAGRANGE_TABLE = _lagrange_table(_TABLE_SIZE)


def _weights(a: np.ndarray, span: np.ndarray):
    """:func:`_lagrange` ``(a, 0, span)`` for a sample ``a`` frames into a gap between
    inner knots ``span`` frames apart (int arrays), looked up for short gaps."""
    if np.count_nonzero(span >= _TABLE_SIZE):
        return _lagrange(a, 0, span)
    w = _LAGRANGE_TABLE.take(a * (_TABLE_SIZE - 1) + span, axis=0)
    return w[:, 0], w[:, 1], w[:, 2], w[:, 3]


def _interpolate_rotations(q: np.ndarray, knots: _Knots, method: str) -> np.ndarray:
    """Values ``(n, 4)`` for the samples of ``q`` (F C, 4) described by ``knots``."""
    n = knots.at.size
    has_l, has_r = knots.lo >= 0, knots.hi >= 0
    span = knots.da + knots.db
    u = knots.da / span
    if method == "cubic":
        # Both outer knots present (hence both neighbours): the cubic, else slerp.
        cubic = (knots.lo2 >= 0) & (knots.hi2 >= 0)
        c0, _, c2, c3 = _weights(knots.da, span)
        g = q.take(np.concatenate([knots.lo, knots.lo2, knots.hi, knots.hi2]), axis=0)
        ql, qr = g[:n], g[2 * n : 3 * n]
        # One product and log for the gap and both outer displacements w_0 and w_2.
        logs = quat.log_shortest(quat.relative(g[: 3 * n], np.concatenate([qr, ql, g[3 * n :]])))
        gap, w0, w2 = logs[:n], logs[n : 2 * n], logs[2 * n :]
        tangent = -c0[:, None] * w0 + c3[:, None] * w2
        if np.count_nonzero(cubic) == n:
            u = c2 + c3
        else:
            u = np.where(cubic, c2 + c3, u)
            tangent = np.where(cubic[:, None], tangent, 0.0)
        moves = quat.exp(np.concatenate([u[:, None] * gap, tangent]))
        value = quat.multiply(quat.multiply(ql, moves[:n]), moves[n:])
    else:
        ql, qr = q.take(knots.lo, axis=0), q.take(knots.hi, axis=0)
        gap = quat.log_shortest(quat.relative(ql, qr))
        value = quat.multiply(ql, quat.exp(u[:, None] * gap))
    return _hold_ends(q, knots, value, ql, qr, has_l, has_r)


def _hold_ends(x, knots, value, left, right, has_l, has_r):
    """``value`` where both neighbours exist; a gap touching a clip end holds its one good
    neighbour, and a column without good frames keeps its samples."""
    if np.count_nonzero(has_l & has_r) == has_l.size:
        return value
    value = np.where((has_l & ~has_r)[:, None], left, value)
    value = np.where((~has_l & has_r)[:, None], right, value)
    return np.where((has_l | has_r)[:, None], value, x.take(knots.at, axis=0))


def _interpolate_positions(p: np.ndarray, knots: _Knots, method: str) -> np.ndarray:
    """Vector counterpart of :func:`_interpolate_rotations` (003 Eq. 15, 17): ``(n, 3)``."""
    has_l, has_r = knots.lo >= 0, knots.hi >= 0
    pl, pr = p.take(knots.lo, axis=0), p.take(knots.hi, axis=0)
    span = knots.da + knots.db
    u = (knots.da / span)[:, None]
    value = (1.0 - u) * pl + u * pr
    if method == "cubic":
        cubic = (knots.lo2 >= 0) & (knots.hi2 >= 0)
        c0, c1, c2, c3 = _weights(knots.da, span)
        curve = (
            c0[:, None] * p.take(knots.lo2, axis=0)
            + c1[:, None] * pl
            + c2[:, None] * pr
            + c3[:, None] * p.take(knots.hi2, axis=0)
        )
        value = np.where(cubic[:, None], curve, value)
    return _hold_ends(p, knots, value, pl, pr, has_l, has_r)


def _check(
    frame_time, threshold, low, high, max_spike_s, max_run, trend_ratio, method, methods, unit
) -> int:
    """Validate the shared parameters; return the longest spike in frames: ``max_spike_s``
    in whole frames (at least one), and at most ``max_run`` when given."""
    frame_time = checks.frame_time(frame_time)
    if not (math.isfinite(threshold) and threshold >= 0):
        raise ValueError(f"threshold must be a number of robust deviations >= 0, got {threshold}")
    if not (0 <= low <= high and high > 0):
        raise ValueError(
            f"need 0 <= min_{unit}_per_s <= max_{unit}_per_s and max_{unit}_per_s "
            f"> 0, got {low} and {high}"
        )
    if not (math.isfinite(max_spike_s) and max_spike_s > 0):
        raise ValueError(f"max_spike_s must be a positive number of seconds, got {max_spike_s}")
    if max_run is not None and (int(max_run) != max_run or max_run < 1):
        raise ValueError(f"max_run must be a whole number of frames >= 1, got {max_run}")
    if not (math.isfinite(trend_ratio) and trend_ratio >= 0):
        raise ValueError(f"trend_ratio must be a number >= 0, got {trend_ratio}")
    if method not in methods:
        raise ValueError(f"method must be one of {', '.join(methods)}, got {method!r}")
    # 8/120 s is 8 frames at 0.0083333 s as at 1/120 s (the frame time's rounding aside)
    frames = max(1, frames_floor(max_spike_s / frame_time))
    return frames if max_run is None else min(frames, int(max_run))


def _nonzero(mask: np.ndarray):
    """``np.nonzero`` of a 2-D mask (same row-major order), several times faster on a
    sparse mask of thousands of entries."""
    return np.divmod(mask.reshape(-1).nonzero()[0], mask.shape[1])


#: Quaternion pairs multiplied at a time in :func:`_dot` (no clip-sized product).
DOT_BLOCK = 1 << 15


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """4-D dot products of ``(..., 4)`` arrays, summed as ``(a0 b0 + a2 b2) + (a1 b1 +
    a3 b3)`` (the order of ``np.einsum``), without einsum's overhead on strided views;
    in blocks along the first axis."""
    shape = np.broadcast_shapes(a.shape, b.shape)
    a, b = np.broadcast_to(a, shape), np.broadcast_to(b, shape)  # views
    if a.ndim < 2:
        return _dot(a[None], b[None])[0]
    dot = np.empty(a.shape[:-1])
    rows = max(1, DOT_BLOCK // max(1, math.prod(dot.shape[1:])))
    for at in range(0, a.shape[0], rows):
        p = a[at : at + rows] * b[at : at + rows]
        part = dot[at : at + rows]
        np.add(p[..., 0], p[..., 2], out=part)
        part += p[..., 1] + p[..., 3]
    return dot


def _norm(v: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("...i,...i->...", v, v))


def _rotation_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle (rad) between unit quaternions, independent of their signs:
    ``2 acos |a . b|``, one dot product per pair (absolute error about 1e-8 rad near 0,
    far below any threshold in degrees)."""
    return _dot_angle(_dot(a, b))


def _dot_angle(dot: np.ndarray) -> np.ndarray:
    """``2 acos min(|dot|, 1)`` in place on ``dot``: the rotation angle (rad) between two
    unit quaternions with 4-D dot product ``dot``."""
    np.abs(dot, out=dot)
    np.minimum(dot, 1.0, out=dot)
    np.arccos(dot, out=dot)
    dot *= 2.0
    return dot


def _position_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return _norm(b - a)


def _rotation_velocity(q: np.ndarray, i: np.ndarray, stride: int) -> np.ndarray:
    """Rotation vectors ``2 log(q_i^-1 q_{i+stride})`` (rad) between rows of ``q`` (N, 4)."""
    return 2.0 * quat.log_shortest(quat.relative(q.take(i, axis=0), q.take(i + stride, axis=0)))


def _position_velocity(p: np.ndarray, i: np.ndarray, stride: int) -> np.ndarray:
    return p.take(i + stride, axis=0) - p.take(i, axis=0)


@dataclass(frozen=True)
class _Metric:
    """How samples are compared and gaps filled: rotations (radians) or positions."""

    rotations: bool
    dist: Callable
    velocity: Callable
    interpolate: Callable


_ROTATIONS = _Metric(True, _rotation_distance, _rotation_velocity, _interpolate_rotations)
_POSITIONS = _Metric(False, _position_distance, _position_velocity, _interpolate_positions)


@dataclass(frozen=True)
class _Limits:
    """The repair's settings: jump ``threshold`` (robust deviations), the clip of the jump
    threshold ``[low, high]`` per second (``high`` is also the cap), the longest spike
    ``max_len`` (frames), ``trend_ratio``, the gap ``method`` and the smallest flip
    ``flip_rad`` (None: no un-flipping)."""

    threshold: float
    low: float
    high: float
    max_len: int
    trend_ratio: float
    method: str
    flip_rad: float | None


def _cap_frames(over: np.ndarray, where, max_len: int, steps: np.ndarray) -> np.ndarray:
    """``(F, C)``: the frames that the steps above the cap ``over`` ``(F-1, C)`` repair
    (``where``: ``_nonzero(over)``; ``steps`` ``(F-1, C)``: the distances between
    consecutive frames).

    Both frames of a step, except where the frames between it and a clip end are at most
    ``max_len`` and hold one pose (a reference pose written before or after the capture,
    which does not move with the motion): then those frames alone (the shorter side), and
    the frame past the step, the motion's own, is kept. End frames that move (a glitch
    that follows the motion, or the motion itself before a glitch) are repaired as
    elsewhere."""
    n_frames, n_cols = over.shape[0] + 1, over.shape[1]
    step, col = where
    head, tail = step + 1, n_frames - 1 - step  # frames before and after the step
    still = steps <= HELD_POSE
    moves = ~still.all(axis=0)
    lead = np.where(moves, np.argmin(still, axis=0), n_frames - 1)  # still steps from the start
    trail = np.where(moves, np.argmin(still[::-1], axis=0), n_frames - 1)  # ... to the end
    to_start = (head <= max_len) & (head <= tail) & (lead[col] >= step)
    to_end = (tail <= max_len) & ~to_start & (trail[col] >= tail - 1)
    first = np.where(to_start, 0, np.where(to_end, step + 1, step))
    length = np.where(to_start, head, np.where(to_end, tail, 2))
    return _mark(first, length, col, (n_frames, n_cols))


#: Largest distance (radians, or length units) between the end frames before a step above
#: the cap for them to hold one pose: a pose written out repeats its text exactly, and the
#: distance of two equal rotations reads about 1e-8 rad.
HELD_POSE = 1e-6


#: Largest share of a column's frames that spike and cap repairs may cover (un-flipping is
#: not limited: a joint may be flipped for much of a clip).
MAX_SPIKE_SHARE = 0.25


def _repair(
    x: np.ndarray,
    frame_time: float,
    metric: _Metric,
    limits: _Limits,
    missing: np.ndarray | None = None,
):
    """Shared driver on ``x`` (F, C, 4|3): jump threshold, un-flip, spikes, cap passes.

    Spikes are at most ``limits.max_len`` frames long; the cap widens a gap at most that
    many times. Returns the repaired array (columns without repairs are ``x``'s own), the
    un-flipped and interpolated masks (F, C), the interpolated runs that hold no spike
    (only a step over the cap), the jump threshold and the largest step
    before and after (C,), all in radians or length units per frame, and the cuts (F-1,)
    (:func:`~motionclean.core.takes.cut_steps`: no toggle, spike or cap breach is taken
    there). Beyond the steps and their statistics, only the sparse jumps, the flipped
    joints and the gaps are worked on.

    ``missing`` (F, C) marks samples that are not data (tracker dropouts): they are held at
    the last known sample, so the step into the first known frame after a dropout carries
    the whole change across it. That step may toggle a flip like any other (the run that
    disagrees with the rest of the clip is the one turned back, whichever side of the
    dropout it lies on); no step touching a missing sample is a jump, spike or cap breach,
    or counts in the statistics; the flipped state is the one held by fewer known frames;
    missing samples come back held at the repaired known ones.
    """
    n_frames, n_cols = x.shape[:2]
    # No spike is longer than the clip, whatever the frame time says.
    limits = dataclasses.replace(limits, max_len=max(1, min(limits.max_len, n_frames - 2)))
    flipped = np.zeros((n_frames, n_cols), dtype=bool)
    if n_frames < 2:
        zeros = np.zeros(n_cols)
        none = np.zeros(0, dtype=bool)
        return x.copy(), flipped, flipped.copy(), flipped.copy(), zeros, zeros, zeros, none
    blind = None  # steps touching a missing sample
    if missing is not None and missing.any():
        x = hold_missing(x, missing)
        blind = missing[:-1] | missing[1:]
    steps = metric.dist(x[:-1], x[1:])
    seen = steps if blind is None else np.where(blind, 0.0, steps)
    cap = limits.high * frame_time
    jump, before = jump_thresholds(
        seen, limits.threshold, limits.low * frame_time, cap, None if blind is None else ~blind
    )
    cuts = cut_steps(seen, jump, np.flatnonzero(before > 0.0), limits.max_len)
    out = x.copy()
    turned = np.zeros(0, dtype=np.intp)  # the un-flipped columns
    if limits.flip_rad is not None:
        known = None if missing is None else ~missing
        across = None if blind is None else _across(missing, seen, blind, limits.low * frame_time)
        turned = _unflip(
            out,
            steps,
            seen,
            jump,
            flipped,
            metric,
            limits,
            limits.flip_rad,
            known,
            blind,
            across,
            cuts,
        )
    first, length, col = _spike_runs(
        out,
        seen,
        jump,
        limits.max_len,
        limits.trend_ratio,
        metric.dist,
        metric.velocity,
        metric.interpolate,
    )
    if blind is not None:  # a spike's cubic never reads a missing sample
        first, length, col = _clear_of(missing, first, length, col)
    first, length, col = _brief(first, length, col, n_frames, limits.max_len)
    if cuts.any():  # no spike's run is entered or left through a cut
        counted = np.concatenate([[0], np.cumsum(cuts)])  # cuts among the steps before each
        keep = (
            counted[np.minimum(first + length, n_frames - 1)] == counted[np.maximum(first - 1, 0)]
        )
        first, length, col = first[keep], length[keep], col[keep]
    mask = _mark(first, length, col, flipped.shape)
    spiked = mask.copy()  # (the cap's runs are told apart: they need not come back)
    over = seen > cap
    over[cuts] = False
    if over.any():
        over &= ~mask[:-1] & ~mask[1:]  # a step above the cap outside any spike
        where = _nonzero(over)
        mask |= _cap_frames(over, where, limits.max_len, seen)
        col = np.concatenate([col, where[1]])
    # A column whose "spikes" cover much of it has none: its steps do not fit the limits
    # (a wrong frame time, or another unit); it is left as it is rather than rebuilt.
    unfit = mask.mean(axis=0) > MAX_SPIKE_SHARE
    if unfit.any():
        mask[:, unfit] = False
        col = col[~unfit[col]]
    after = before.copy()
    changed = np.bincount(np.concatenate([turned, col]), minlength=n_cols).nonzero()[0]
    if changed.size:
        _fill_changed(out, mask, changed, after, metric, limits, cap)
        if missing is not None and blind is not None:
            _rehold(out, missing, blind, changed, after, metric)
    if missing is not None:
        flipped &= ~missing
        mask &= ~missing
    return out, flipped, mask, _without(mask, spiked), jump, before, after, cuts


def _without(mask: np.ndarray, marked: np.ndarray) -> np.ndarray:
    """``(F, C)``: the runs of ``mask`` (along frames, per column) with no ``marked`` frame."""
    run = run_labels(mask)
    touched = np.bincount(run[marked & mask], minlength=int(run.max(initial=0)) + 1) > 0
    return mask & ~touched[run]


#: Most the median angle of a joint's other frames to their principal rotation may be for
#: them to keep to a pose a flipped run can be judged against (a root turning evenly round
#: has 90 degrees; turning over half a turn, 45; a joint a few frames of whose rest are
#: themselves half a turn off still keeps to its pose).
REST_TYPICAL_RAD = math.radians(60.0)
#: A flipped run is left as it is only where, as it is, it keeps within this quantile of
#: the angles of the joint's other frames to their principal rotation (and turning it back
#: takes it further): it agrees with the rest of the clip.
REST_SPREAD_QUANTILE = 0.9
#: Quantile of a joint's known steps taken as how far it turns per frame during a dropout.
DROPOUT_STEP_QUANTILE = 0.9
#: Most a joint is taken to turn across a dropout when judging a half-turn there (radians).
DROPOUT_TURN_MAX = np.pi / 3.0
#: Quantile of a joint's known steps taken as the fastest it turns (per frame). A step
#: across a dropout that the joint could have turned in the frames it spans at that speed,
#: or at the speed under which despike takes no step for a jump (``min_deg_per_s``), may be
#: motion: a foot turning 157 degrees while occluded for 40 frames at 120 fps (471 degrees
#: per second) had been taken for a flip, and 207 known frames after it turned half a turn.
DROPOUT_REACH_QUANTILE = 0.99


class _Across(NamedTuple):
    """Steps into the first known frame after a dropout, ``(F-1, C)`` each, zero elsewhere
    (radians): ``slack``, how far the joint may turn across it when its step is judged a
    half-turn (its :data:`DROPOUT_STEP_QUANTILE` step per frame times the frames spanned,
    at most :data:`DROPOUT_TURN_MAX`); ``reach``, how far it may turn in those frames
    (:data:`DROPOUT_REACH_QUANTILE`): a step within it may be motion."""

    slack: np.ndarray
    reach: np.ndarray


def _across(missing, seen, blind, never_jump: float) -> _Across:
    """:class:`_Across` of the dropouts ``missing`` (F, C), from the known steps ``seen``
    (F-1, C; those touching a missing sample, ``blind``, not counted); ``never_jump``: the
    step per frame (radians) under which no step is a jump."""
    n_frames = missing.shape[0]
    frames = np.arange(n_frames)[:, None]
    last = np.maximum.accumulate(np.where(~missing, frames, -1), axis=0)  # last known so far
    across = missing[:-1] & ~missing[1:] & (last[:-1] >= 0)
    span = frames[1:] - last[:-1]  # frames from the last known one before the step's end
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a column without known steps
        typical, fastest = np.nan_to_num(
            np.nanquantile(
                np.where(blind, np.nan, seen),
                [DROPOUT_STEP_QUANTILE, DROPOUT_REACH_QUANTILE],
                axis=0,
            )
        )
    slack = np.minimum(typical * span, DROPOUT_TURN_MAX)
    reach = np.maximum(fastest, never_jump) * span
    return _Across(np.where(across, slack, 0.0), np.where(across, reach, 0.0))


def _clear_of(missing, first, length, col):
    """The spike runs (first frame, length, column) whose frames and the two good frames
    on each side, which the cubic reads, are all known."""
    n_frames = missing.shape[0]
    gappy = missing_before(missing)
    lo = np.clip(first - 2, 0, n_frames)
    hi = np.clip(first + length + 2, 0, n_frames)
    keep = gappy[hi, col] == gappy[lo, col]
    return first[keep], length[keep], col[keep]


def _rehold(out, missing, blind, changed, after, metric: _Metric) -> None:
    """Missing samples of the ``changed`` columns held again at their repaired known
    neighbours (sign-continuous for rotations), and their largest known step ``after``."""
    fixed = hold_missing(out.take(changed, axis=1), missing.take(changed, axis=1))
    if metric.rotations:
        fixed = quat.make_continuous(fixed, axis=0)
    out[:, changed] = fixed
    steps = metric.dist(fixed[:-1], fixed[1:])
    after[changed] = np.where(blind.take(changed, axis=1), 0.0, steps).max(axis=0)


def _unflip(
    out,
    steps,
    seen,
    jump,
    flipped,
    metric: _Metric,
    limits: _Limits,
    flip_rad: float,
    known=None,
    blind=None,
    across: _Across | None = None,
    cuts=None,
) -> np.ndarray:
    """Undo half-turn flips (steps of at least ``flip_rad``) in ``out`` (F, C, 4) in place;
    mark them in ``flipped`` and update ``steps`` (and ``seen``, the steps with those
    touching a missing sample, ``blind``, at zero) of the columns turned back, which are
    returned. The flipped state is the one fewer ``known`` frames hold (all by default),
    but for a run at an end of the clip that agrees with the rest as it is
    (:func:`_to_turn_back`); no step of ``cuts`` (F-1,) toggles it (a take that starts
    turned is no flip)."""
    n_frames, n_cols = out.shape[:2]
    flat = out.reshape(n_frames * n_cols, out.shape[-1])  # frame a of column c at row a C + c
    cols, toggles, axis, left = _flip_toggles(flat, steps, flip_rad, across)
    if cuts is not None and cuts.any():
        toggles[cuts] = False
    if not toggles.any():
        return np.zeros(0, dtype=np.intp)
    # Toggles on the steps of a spike that is not itself a clean flip (half-turn
    # both in and out) are artefacts of the spike: its ends share one state.
    first, length, slot = _spike_runs(
        out.take(cols, axis=1),
        seen.take(cols, axis=1),
        jump[cols],
        limits.max_len,
        limits.trend_ratio,
        metric.dist,
        metric.velocity,
        metric.interpolate,
        toggles,
    )
    toggles &= ~_mark(first - 1, length + 1, slot, toggles.shape)
    known_cols = None if known is None else known.take(cols, axis=1)
    parity = _parity(toggles, known_cols)
    frame, slot = _nonzero(parity)
    i = frame * n_cols + cols[slot]
    turned_back = _half_turn(flat, i, slot, axis, left)
    parity = _to_turn_back(out.take(cols, axis=1), parity, turned_back, frame, slot, known_cols)
    kept = parity[frame, slot]
    flat[i[kept]] = turned_back[kept]
    flipped[:, cols] = parity
    turned = cols[parity.any(axis=0)]
    samples = out.take(turned, axis=1)
    steps[:, turned] = metric.dist(samples[:-1], samples[1:])
    seen[:, turned] = (
        steps[:, turned] if blind is None else np.where(blind[:, turned], 0.0, steps[:, turned])
    )
    return turned


def _to_turn_back(samples, parity, turned_back, frame, slot, known=None) -> np.ndarray:
    """``(F, S)``: the flipped runs of ``parity`` (F, S) to turn back, every frame of such a
    run True: all but those that agree with the rest of the clip as they are.

    ``samples`` (F, S, 4) are the columns that flip, ``turned_back`` (N, 4) their flipped
    frames ``(frame, slot)`` turned back by the half-turn. The rest of a column is its
    frames outside the runs (``known`` (F, S) ones only, when given), summed up by their
    principal quaternion ``m`` (the largest eigenvector of ``sum q q^T``, sign-free). A run
    entered and left by half-turn steps is turned back. One that reaches the clip's first
    or last frame (one step toggles it: which side flipped, the parity cannot see) is left
    as it is when the rest keeps to a pose (the median angle to ``m`` at most
    :data:`REST_TYPICAL_RAD`; a root turning round has no mean heading), the run's known
    frames lie, as they are, within the rest's own spread about ``m`` (their mean angle to
    it at most the rest's :data:`REST_SPREAD_QUANTILE` quantile) and turning them back
    takes them further from it. A toggle found where a capture slides into a half-turn
    over several frames and snaps back in one (a markerless shoulder) leaves the correct
    run after the snap in the minority: it is left as it is. A genuine flip at an end of a
    joint held near its usual pose lies outside that spread, and is turned back.
    """
    runs = run_labels(parity)
    size = int(runs.max(initial=0)) + 1
    ends = np.zeros(size, dtype=bool)  # runs from the clip's first or to its last frame
    ends[runs[0]] = ends[runs[-1]] = True
    ends[0] = False
    if not ends.any():
        return parity
    seen = np.ones_like(parity) if known is None else known
    rest = ~parity & seen
    scatter = np.einsum("fs,fsi,fsj->sij", rest.astype(np.float64), samples, samples)
    m = np.linalg.eigh(scatter)[1][..., -1]  # (S, 4)
    typical, spread = _rest_angles(samples, rest, m)  # (S,) each, nan without rest frames
    keeps_to_a_pose = typical <= REST_TYPICAL_RAD
    label = runs[frame, slot]
    weight = seen[frame, slot].astype(np.float64)
    before = _rotation_distance(samples[frame, slot], m[slot])
    after = _rotation_distance(turned_back, m[slot])
    slot_of = np.zeros(size, dtype=np.intp)
    slot_of[label] = slot
    count = np.bincount(label, weight, size)
    further = np.bincount(label, weight * (after - before), size) > 0.0
    within = np.bincount(label, weight * before, size) <= count * spread[slot_of]
    left = ends & (count > 0) & keeps_to_a_pose[slot_of] & within & further
    return parity & ~left[runs]


def _rest_angles(samples: np.ndarray, rest: np.ndarray, m: np.ndarray):
    """The median and the :data:`REST_SPREAD_QUANTILE` quantile, ``(S,)`` each (radians;
    nan for a column without rest frames), of the angles of each column's ``rest`` (F, S)
    frames of ``samples`` (F, S, 4) to its principal quaternion ``m`` (S, 4)."""
    angle = _rotation_distance(samples, m[None])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a column without rest frames
        return np.nanquantile(np.where(rest, angle, np.nan), [0.5, REST_SPREAD_QUANTILE], axis=0)


def _fill_changed(out, mask, changed, after, metric: _Metric, limits: _Limits, cap) -> None:
    """Fill the gaps of the ``changed`` columns of ``out`` in place (widening ``mask``
    where the cap asks), make rotations sign-continuous and set their largest step
    ``after``."""
    fixed = out.take(changed, axis=1)
    gaps = mask.take(changed, axis=1)
    if gaps.any():
        mask[:, changed] = _fill(
            fixed, gaps, metric.dist, metric.interpolate, limits.method, cap, limits.max_len
        )
    if metric.rotations:
        # Sign continuity (000 Sec. VI-A, as quat.make_continuous) from the dot products
        # that also give the steps after repair.
        dots = _dot(fixed[:-1], fixed[1:])
        signs = np.ones(fixed.shape[:2])
        signs[1:][dots < 0.0] = -1.0
        np.cumprod(signs, axis=0, out=signs)
        fixed *= signs[..., None]  # in place: no second copy of the columns
        out[:, changed] = fixed
        after[changed] = _dot_angle(dots).max(axis=0)
    else:
        out[:, changed] = fixed
        after[changed] = metric.dist(fixed[:-1], fixed[1:]).max(axis=0)


def _columns(x: np.ndarray) -> np.ndarray:
    """``(F, ..., n)`` viewed as ``(F, C, n)``, also for empty arrays."""
    return x.reshape(x.shape[0], math.prod(x.shape[1:-1]), x.shape[-1])


def _missing_columns(missing, shape) -> np.ndarray | None:
    """The ``missing`` mask (``shape[:-1]``, bool) as ``(F, C)``, or None when nothing is."""
    if missing is None:
        return None
    missing = checks.bool_mask(missing, "missing", tuple(shape[:-1]))
    return missing.reshape(shape[0], -1) if missing.any() else None


def _report(
    shape, flipped, interpolated, capped, jump, before, after, cuts, scale
) -> DespikeReport:
    trailing = shape[1:-1]
    return DespikeReport(
        unflipped=flipped.reshape(shape[0], *trailing),
        interpolated=interpolated.reshape(shape[0], *trailing),
        threshold=scale(jump).reshape(trailing),
        max_step_before=scale(before).reshape(trailing),
        max_step_after=scale(after).reshape(trailing),
        cuts=np.flatnonzero(cuts) + 1,
        capped=capped.reshape(shape[0], *trailing),
    )


def despike_with_report(
    q: np.ndarray,
    frame_time: float,
    *,
    threshold: float = JUMP_THRESHOLD,
    min_deg_per_s: float = MIN_DEG_PER_S,
    max_deg_per_s: float = MAX_DEG_PER_S,
    max_spike_s: float = LONGEST_SPIKE_S,
    trend_ratio: float = TREND_RATIO,
    max_run: int | None = None,
    flip_deg: float = FLIP_DEG,
    unflip: bool = True,
    method: str = "cubic",
    missing: np.ndarray | None = None,
) -> tuple[np.ndarray, DespikeReport]:
    """:func:`despike` with a :class:`DespikeReport` of what it repaired.

    Parameters are :func:`despike`'s (the same names, units and defaults). Returns the
    repaired ``(F, ..., 4)`` rotations, as :func:`despike` returns them, and the report:
    the frames un-flipped and interpolated per column, the jump threshold and the largest
    step before and after, in degrees per frame.
    """
    max_len = _check(
        frame_time,
        threshold,
        min_deg_per_s,
        max_deg_per_s,
        max_spike_s,
        max_run,
        trend_ratio,
        method,
        ("cubic", "slerp"),
        "deg",
    )
    if not 90.0 < flip_deg <= 180.0:
        raise ValueError(f"flip_deg must be in (90, 180] degrees, got {flip_deg}")
    q = checks.unit_quaternions(q)
    limits = _Limits(
        threshold,
        np.deg2rad(min_deg_per_s),
        np.deg2rad(max_deg_per_s),
        max_len,
        trend_ratio,
        method,
        np.deg2rad(flip_deg) if unflip else None,
    )
    out, flipped, interpolated, capped, jump, before, after, cuts = _repair(
        _columns(q), frame_time, _ROTATIONS, limits, _missing_columns(missing, q.shape)
    )
    report = _report(q.shape, flipped, interpolated, capped, jump, before, after, cuts, np.rad2deg)
    return out.reshape(q.shape), report


def despike(
    q: np.ndarray,
    frame_time: float,
    *,
    threshold: float = JUMP_THRESHOLD,
    min_deg_per_s: float = MIN_DEG_PER_S,
    max_deg_per_s: float = MAX_DEG_PER_S,
    max_spike_s: float = LONGEST_SPIKE_S,
    trend_ratio: float = TREND_RATIO,
    max_run: int | None = None,
    flip_deg: float = FLIP_DEG,
    unflip: bool = True,
    method: str = "cubic",
    missing: np.ndarray | None = None,
) -> np.ndarray:
    """Repair half-turn flips and spikes in unit-quaternion signals (see the module
    docstring: the jump test, the spike tests and the repairs).

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions ``(w, x, y, z)``, time along axis 0; every trailing index (joint
        column) is repaired on its own.
    frame_time : float
        Seconds per frame; turns the per-second limits into per-frame angles.
    threshold : float
        Robust deviations (1.4826 MAD) above the median step for a step to be a jump
        (default 8).
    min_deg_per_s, max_deg_per_s : float
        The jump threshold is clipped to ``[min, max] * frame_time`` degrees of rotation.
        Steps faster than ``max_deg_per_s`` (default 3600: 30 degrees per frame at 120 fps)
        are always repaired; steps slower than ``min_deg_per_s`` (default 600: 5 degrees
        per frame at 120 fps) never count as jumps.
    max_spike_s : float
        Longest spike in seconds (whole frames, at least one: 8 frames at 120 fps, 2 at
        30 fps; default 0.07); also the most frames by which the cap widens a gap on each
        side.
    trend_ratio : float
        A spike's first and last frames must be further from the cubic trend through its
        good neighbours than ``trend_ratio`` times that trend's error at the neighbours
        (default 3; ``0`` skips the test).
    max_run : int or None
        Optional bound on the spike length in frames, on top of ``max_spike_s``.
    flip_deg : float
        Smallest single-frame step taken as a half-turn flip, degrees in (90, 180]
        (default 150).
    unflip : bool
        Undo half-turn flips before interpolating (default True; False interpolates short
        flips like spikes).
    method : str
        Interpolant for spikes: ``"cubic"`` (default: the four-point cubic of 003 Eq. 15,
        in its orientation form Eq. 16, on non-uniform knots as Eq. 17; "Eq. 15-17") or
        ``"slerp"``.
    missing : (F, ...) bool array, optional
        Samples that are not data (tracker dropouts), whatever their values: never part of
        a jump, spike or statistic; the change across a dropout may toggle a flip like any
        step (so the run on the wrong side of a half-turn is the one repaired, also when a
        dropout hides its start or end); they come back held at the repaired known samples
        (the last one before each, the first one after for a dropout at the start).

    Returns
    -------
    (F, ..., 4) array
        A new array of unit quaternions: repaired columns are sign-continuous, columns
        without defects are returned as given, bit for bit.
        :func:`despike_with_report` also says what was repaired.

    Raises
    ------
    TypeError, ValueError
        ``q`` not unit quaternions of that shape, or a parameter of the wrong type or out
        of range (naming it).
    """
    return despike_with_report(
        q,
        frame_time,
        threshold=threshold,
        min_deg_per_s=min_deg_per_s,
        max_deg_per_s=max_deg_per_s,
        max_spike_s=max_spike_s,
        trend_ratio=trend_ratio,
        max_run=max_run,
        flip_deg=flip_deg,
        unflip=unflip,
        method=method,
        missing=missing,
    )[0]


def despike_positions_with_report(
    p: np.ndarray,
    frame_time: float,
    *,
    threshold: float = JUMP_THRESHOLD,
    min_units_per_s: float = 0.0,
    max_units_per_s: float = np.inf,
    max_spike_s: float = LONGEST_SPIKE_S,
    trend_ratio: float = TREND_RATIO,
    max_run: int | None = None,
    method: str = "cubic",
    missing: np.ndarray | None = None,
) -> tuple[np.ndarray, DespikeReport]:
    """:func:`despike_positions` with a :class:`DespikeReport` of what it repaired.

    Parameters are :func:`despike_positions`'s (the same names, units and defaults).
    Returns the repaired ``(F, ..., 3)`` translations and the report (``unflipped`` all
    false; thresholds and steps in the file's length units per frame).
    """
    max_len = _check(
        frame_time,
        threshold,
        min_units_per_s,
        max_units_per_s,
        max_spike_s,
        max_run,
        trend_ratio,
        method,
        ("cubic", "linear"),
        "units",
    )
    p = checks.vectors(p)
    limits = _Limits(
        threshold, min_units_per_s, max_units_per_s, max_len, trend_ratio, method, None
    )
    out, flipped, interpolated, capped, jump, before, after, cuts = _repair(
        _columns(p), frame_time, _POSITIONS, limits, _missing_columns(missing, p.shape)
    )
    report = _report(p.shape, flipped, interpolated, capped, jump, before, after, cuts, np.asarray)
    return out.reshape(p.shape), report


def despike_positions(
    p: np.ndarray,
    frame_time: float,
    *,
    threshold: float = JUMP_THRESHOLD,
    min_units_per_s: float = 0.0,
    max_units_per_s: float = np.inf,
    max_spike_s: float = LONGEST_SPIKE_S,
    trend_ratio: float = TREND_RATIO,
    max_run: int | None = None,
    method: str = "cubic",
    missing: np.ndarray | None = None,
) -> np.ndarray:
    """Vector counterpart of :func:`despike` for ``(F, ..., 3)`` translations: spikes
    repaired (marker swaps make the root jump), no flip repair.

    Steps are Euclidean distances between consecutive frames in the file's length unit.
    The jump threshold is ``clip(median + threshold * 1.4826 MAD, min_units_per_s dt,
    max_units_per_s dt)``; spikes (at most ``max_spike_s`` long, off the local cubic trend
    by ``trend_ratio`` times its error at the neighbours) are interpolated, and steps above
    ``max_units_per_s`` are spread by widening the gap. As units differ between files,
    there is no absolute cap unless ``max_units_per_s`` is given.

    Parameters
    ----------
    p : (F, ..., 3) array
        Positions in the file's length unit, time along axis 0; finite, no component
        beyond 1e150.
    frame_time : float
        Seconds per frame.
    threshold : float
        Robust deviations (1.4826 MAD) above the median step for a step to be a jump
        (default 8).
    min_units_per_s, max_units_per_s : float
        The jump threshold is clipped to ``[min, max] * frame_time`` length units; steps
        faster than ``max_units_per_s`` are always repaired (default inf: no cap), steps
        slower than ``min_units_per_s`` never count as jumps (default 0).
    max_spike_s : float
        Longest spike in seconds (whole frames, at least one; default 0.07).
    trend_ratio : float
        As :func:`despike`'s (default 3; 0 skips the test).
    max_run : int or None
        Optional bound on the spike length in frames.
    method : str
        ``"cubic"`` (default: the four-point cubic of 003 Eq. 15 on non-uniform knots,
        Eq. 17) or ``"linear"``.
    missing : (F, ...) bool array, optional
        Dropouts, as in :func:`despike`.

    Returns
    -------
    (F, ..., 3) array
        A new array; columns without defects are returned as given, bit for bit.
        :func:`despike_positions_with_report` also says what was repaired.
    """
    return despike_positions_with_report(
        p,
        frame_time,
        threshold=threshold,
        min_units_per_s=min_units_per_s,
        max_units_per_s=max_units_per_s,
        max_spike_s=max_spike_s,
        trend_ratio=trend_ratio,
        max_run=max_run,
        method=method,
        missing=missing,
    )[0]
