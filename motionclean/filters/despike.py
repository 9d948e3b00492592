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
   ``q f``), which keeps the real motion within a flipped run.
2. **Interpolate.** What remains (short spikes, ragged transitions) is replaced by
   interpolation between the good neighbours. A step is a *jump* when its angle exceeds

       T = clip(median(s) + threshold * 1.4826 * MAD(s),  min_deg_per_s dt,  max_deg_per_s dt)

   where ``s`` are the joint's frame-to-frame rotation angles and ``1.4826 MAD`` is the
   robust standard deviation (``dt`` the frame time). Frames ``a+1 .. a+L`` form a
   *spike* when all of these hold:

   * it is brief: ``L dt <= max_spike_s`` (whole frames, at least one; also ``L <=
     max_run`` when given). A defect is brief; the same excursion lasting longer may be
     genuine (a toe flexing out and back within 100 ms spans 12 frames at 120 fps but 3
     at 30 fps, where its steps are four times larger);
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
     not (a neighbour at a clip end is not predicted).

   Finally no step may exceed the absolute cap ``max_deg_per_s dt`` (no human joint
   turns that fast): the two frames of a step above the cap join the interpolated set,
   and every gap whose interpolated steps still exceed the cap widens by one frame per
   side and pass (at most as many passes as the longest spike has frames). A spike
   touching the first or last frame has no good frame on one side and is only caught by
   the cap. ``T`` comes from the steps as read, before un-flipping (the median and MAD
   are not moved by a few dozen flips); all limits are in degrees per second, so they
   keep their meaning at any frame rate.

The interpolant is the cubic of the four-point subdivision scheme (Eq. 15-17 of 003)
through the two good frames on each side of a gap, on their actual (non-uniform) knots,
written in the form of 003 Eq. 16: ``slerp_{c2+c3}(q_l, q_r) exp(-c0 w_0 + c3 w_2)`` with
``c`` the cubic Lagrange weights, ``w_0 = log(q_{l-1}^-1 q_l)`` and
``w_2 = log(q_r^-1 q_{r+1})``; at the uniform midpoint it is exactly Eq. 16, and it
reproduces a constant angular velocity exactly. Where an outer neighbour is missing (clip
end or another gap) it falls back to slerp; a gap touching a clip end holds the nearest
good frame.

Arrays are time-major, ``(F, ..., 4)`` quaternions ``(w, x, y, z)`` or ``(F, ..., 3)``
vectors; every trailing index (joint column) is treated independently and at once.
Columns without defects are returned bit for bit. Angles given to or reported by this
module are in degrees of rotation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import quat

__all__ = [
    "DespikeReport",
    "despike",
    "despike_positions",
    "despike_positions_with_report",
    "despike_with_report",
]

#: Consistency constant turning a median absolute deviation into a standard deviation.
MAD_TO_SIGMA = 1.4826

#: Share of the scatter of the flip-step axes that the half-turn axis must explain (1 when
#: all flip steps turn about the same axis) for a joint to be un-flipped.
FLIP_AXIS_SHARE = 0.9


@dataclass(frozen=True)
class DespikeReport:
    """What :func:`despike_with_report` changed, per frame and trailing index (column).

    ``unflipped`` and ``interpolated`` are ``(F, ...)`` boolean masks (a frame can be
    both: un-flipped, then interpolated). ``threshold`` is the jump threshold ``T`` per
    column (degrees for rotations, length units for positions; per frame, not per
    second). ``max_step_before`` / ``max_step_after`` are each column's largest
    frame-to-frame step before and after repair, in the same units.
    """

    unflipped: np.ndarray
    interpolated: np.ndarray
    threshold: np.ndarray
    max_step_before: np.ndarray
    max_step_after: np.ndarray

    @property
    def repaired(self) -> np.ndarray:
        """``(F, ...)`` bool: frames changed by either repair."""
        return self.unflipped | self.interpolated

    def counts(self, kind: str = "repaired") -> np.ndarray:
        """Frames changed per column, shape ``(...)``; ``kind`` is ``"repaired"``,
        ``"unflipped"`` or ``"interpolated"``."""
        return self._mask(kind).sum(axis=0)

    def runs(self, index, kind: str = "repaired") -> list[tuple[int, int]]:
        """Maximal runs of changed frames of one column as half-open ``(start, stop)``
        frame ranges. ``index`` is an int or a tuple into the trailing shape."""
        column = self._mask(kind)[(slice(None), *np.atleast_1d(index))]
        edges = np.diff(np.concatenate([[0], column.astype(np.int8), [0]]))
        return list(zip(np.flatnonzero(edges == 1).tolist(),
                        np.flatnonzero(edges == -1).tolist(), strict=True))

    def summary(self, index) -> dict:
        """JSON-ready figures of one column: frames repaired, the un-flipped and the
        interpolated runs (``[start, stop)`` frames), the jump threshold and the largest
        step before and after."""
        return {
            "frames_repaired": int(self.counts()[index]),
            "unflipped": [list(r) for r in self.runs(index, "unflipped")],
            "interpolated": [list(r) for r in self.runs(index, "interpolated")],
            "threshold": float(self.threshold[index]),
            "max_step": {"before": float(self.max_step_before[index]),
                         "after": float(self.max_step_after[index])},
        }

    def _mask(self, kind: str) -> np.ndarray:
        if kind not in ("repaired", "unflipped", "interpolated"):
            raise ValueError(f"kind must be repaired, unflipped or interpolated, got {kind!r}")
        return getattr(self, kind)


def _robust_threshold(steps: np.ndarray, threshold: float, low: float, high: float):
    """``clip(median + threshold * 1.4826 MAD, low, high)`` per column of ``steps`` (F-1, C)."""
    med = np.median(steps, axis=0)
    mad = np.median(np.abs(steps - med), axis=0)
    return np.clip(med + threshold * MAD_TO_SIGMA * mad, low, high)


def _flip_axes(q, step, col, cols):
    """Half-turn axis of each column in ``cols``, whether it acts on the left (parent
    frame), and whether the flip steps (``step``, ``col``: sparse indices) agree on it.

    Principal eigenvector of ``sum v v^T`` over the flip steps, for the axes ``v`` of
    ``q_{i+1} q_i^-1`` (parent frame) and of ``q_i^-1 q_{i+1}`` (own frame); the frame
    whose largest eigenvalue takes the larger share of the trace wins, and the axis is
    trusted when that share is at least :data:`FLIP_AXIS_SHARE`.
    """
    a, b = q[step, col], q[step + 1, col]
    a_inv = quat.conjugate(a)
    rel = _product(np.concatenate([b, a_inv]), np.concatenate([a_inv, b]))[:, 1:]
    v = rel / np.maximum(_norm(rel), 1e-300)[:, None]
    outer = (v[:, :, None] * v[:, None, :]).reshape(2, step.size, 9)
    one_hot = (col[:, None] == cols).astype(np.float64)  # (steps, columns)
    scatter = np.einsum("sc,fsk->fck", one_hot, outer).reshape(2, cols.size, 3, 3)
    values, vectors = np.linalg.eigh(scatter)  # frames: 0 parent, 1 own
    share = values[..., -1] / np.maximum(values.sum(axis=-1), 1e-300)
    left = share[0] >= share[1]
    axis = np.where(left[:, None], vectors[0, :, :, -1], vectors[1, :, :, -1])
    return axis, left, share.max(axis=0) >= FLIP_AXIS_SHARE


def _half_turn(q, frame, slot, cols, axis, left):
    """``f q`` (parent frame) or ``q f`` (own frame) at the samples ``(frame, cols[slot])``
    with ``f = (0, axis[slot])``."""
    f = np.concatenate([np.zeros((slot.size, 1)), axis[slot]], axis=-1)
    qs = q[frame, cols[slot]]
    on_left = left[slot][:, None]
    return _product(np.where(on_left, f, qs), np.where(on_left, qs, f))


def _flip_toggles(q: np.ndarray, steps: np.ndarray, flip_rad: float):
    """Where the half-turn parity toggles, and the half-turn of each flipping column.

    Returns ``(F-1, C)`` toggles and ``(cols, axis, left)``: the columns that may toggle
    (those with a step of at least ``flip_rad`` whose flip steps agree on a half-turn
    axis), their axes and sides (see :func:`_half_turn`). A step toggles when it exceeds
    90 degrees and undoing the half-turn leaves a step under both the step itself and
    ``pi - flip_rad`` (30 degrees by default).
    """
    toggles = np.zeros(steps.shape, dtype=bool)
    step, col = np.nonzero(steps >= flip_rad)
    cols = np.unique(col)
    if cols.size == 0:
        return toggles, (cols, None, None)
    axis, left, agreed = _flip_axes(q, step, col, cols)
    cols, axis, left = cols[agreed], axis[agreed], left[agreed]
    step, slot = np.nonzero(steps[:, cols] > 0.5 * np.pi)
    residual = _rotation_distance(_half_turn(q, step, slot, cols, axis, left),
                                  q[step + 1, cols[slot]])
    big = steps[step, cols[slot]]
    toggles[step, cols[slot]] = (residual < big) & (residual <= np.pi - flip_rad)
    return toggles, (cols, axis, left)


def _parity(toggles: np.ndarray) -> np.ndarray:
    """``(F, C)`` flipped frames: the parity of the toggles so far, the minority state."""
    parity = np.zeros((toggles.shape[0] + 1, toggles.shape[1]), dtype=bool)
    parity[1:] = np.cumsum(toggles, axis=0) % 2 == 1
    return parity ^ (parity.sum(axis=0) > parity.shape[0] / 2)


def _spike_runs(x, steps, jump, max_len, trend_ratio, dist, velocity, interpolate):
    """Runs of frames ``a+1 .. a+L`` (``L <= max_len``) entered and left by abrupt jumps
    that come back off the local trend, as arrays ``(first frame a+1, length L, column)``.

    ``steps`` (F-1, C) are the distances between consecutive frames of ``x``, ``jump``
    (C,) the jump threshold, ``dist(x, y)`` the distance between samples,
    ``velocity(x, i, c)`` the displacement vectors of steps ``i`` in columns ``c`` (their
    norms are the steps) and ``interpolate`` the gap interpolant. Step ``a`` into the run
    and step ``a+L`` out of it must both exceed ``jump`` and differ from the step on their
    outer side by more than ``jump`` (an abrupt change of velocity, which a smooth
    reversal of direction is not), ``dist(x_a, x_{a+L+1})`` must be under both jumps, and
    the run must stand off the trend (:func:`_off_trend`). Only the sparse jumps are
    examined.
    """
    n_steps = steps.shape[0]
    is_jump = steps > jump
    start, col = np.nonzero(is_jump)
    a = np.repeat(start, max_len)
    c = np.repeat(col, max_len)
    run = np.tile(np.arange(1, max_len + 1), start.size)
    keep = a + run < n_steps
    a, c, run = a[keep], c[keep], run[keep]
    keep = is_jump[a + run, c]
    a, c, run = a[keep], c[keep], run[keep]
    back = dist(x[a, c], x[a + run + 1, c])
    keep = back < np.minimum(steps[a, c], steps[a + run, c])
    a, c, run = a[keep], c[keep], run[keep]
    # Abrupt: the velocity changes by more than the threshold into and out of the run.
    b = a + run
    n = a.size
    v = velocity(x, np.concatenate([np.maximum(a - 1, 0), a, b, np.minimum(b + 1, n_steps - 1)]),
                 np.tile(c, 4))
    limit = jump[c]
    abrupt_in = (a == 0) | (_norm(v[n:2 * n] - v[:n]) > limit)
    abrupt_out = (b == n_steps - 1) | (_norm(v[2 * n:3 * n] - v[3 * n:]) > limit)
    keep = abrupt_in & abrupt_out
    a, c, run = a[keep], c[keep], run[keep]
    if trend_ratio > 0 and a.size:
        keep = _off_trend(x, a, run, c, trend_ratio, dist, interpolate)
        a, c, run = a[keep], c[keep], run[keep]
    return a + 1, run, c


def _off_trend(x, a, run, c, trend_ratio, dist, interpolate):
    """Whether the runs ``a+1 .. a+L`` (``L = run``) of columns ``c`` leave the local trend.

    ``P``: the cubic through the good neighbours ``a-1, a`` and ``b, b+1`` (``b = a+L+1``;
    003 Eq. 17, the repair's own interpolant). The run's first and last frames must both
    be further from ``P`` than ``trend_ratio`` times the error ``e`` of the same cubic
    at the neighbours: ``x_a`` predicted across the gap from ``a-2, a-1`` to ``b, b+1``
    and ``x_b`` from ``a-1, a`` to ``b+1, b+2`` (a neighbour at a clip end is not
    predicted; with neither, ``e = 0``). See the module docstring.
    """
    n_frames = x.shape[0]
    b = a + run + 1
    predict_a, predict_b = a >= 1, b + 1 < n_frames
    frame = np.concatenate([a + 1, a + run, a, b])
    left = np.concatenate([a, a, np.maximum(a - 1, 0), a])
    right = np.concatenate([b, b, b, np.minimum(b + 1, n_frames - 1)])
    cols = np.tile(c, 4)
    off = dist(x[frame, cols], interpolate(x, _Knots.around(frame, cols, left, right, n_frames),
                                           "cubic")).reshape(4, a.size)
    error = np.maximum(np.where(predict_a, off[2], 0.0), np.where(predict_b, off[3], 0.0))
    return np.minimum(off[0], off[1]) > trend_ratio * error


def _mark(first, length, col, shape) -> np.ndarray:
    """Boolean ``shape`` mask with rows ``first .. first+length-1`` set in each ``col``."""
    mask = np.zeros(shape, dtype=bool)
    cols, slot = np.unique(col, return_inverse=True)
    marks = np.zeros((shape[0] + 1, cols.size), dtype=np.int64)
    np.add.at(marks, (first, slot), 1)
    np.add.at(marks, (first + length, slot), -1)
    mask[:, cols] = np.cumsum(marks[:-1], axis=0) > 0
    return mask


def _runs(mask: np.ndarray):
    """Maximal runs of ``True`` along axis 0 of ``mask`` (F, C): arrays ``(start, stop,
    col)`` with ``stop`` exclusive, ordered by column then frame."""
    cols = np.flatnonzero(mask.any(axis=0))
    edge = np.diff(mask[:, cols].astype(np.int8), axis=0, prepend=0, append=0).T
    slot, start = np.nonzero(edge == 1)
    stop = np.nonzero(edge == -1)[1]
    return start, stop, cols[slot]


@dataclass(frozen=True)
class _Knots:
    """Samples to interpolate: per sample its ``frame`` and ``col``, the good frames
    ``left`` and ``right`` around its gap (``-1`` / ``F`` at a clip end) and the next good
    frames outward ``left2`` and ``right2`` (``-1`` when missing)."""

    frame: np.ndarray
    col: np.ndarray
    left: np.ndarray
    right: np.ndarray
    left2: np.ndarray
    right2: np.ndarray

    @classmethod
    def around(cls, frame, col, left, right, n_frames: int) -> _Knots:
        """Knots for gaps ``left+1 .. right-1`` with every frame outside them good."""
        return cls(frame, col, left, right, np.where(left >= 1, left - 1, -1),
                   np.where(right + 1 < n_frames, right + 1, -1))


class _Gaps:
    """The masked samples of ``mask`` (F, C) with the good frames around their gap.

    ``knots`` (:class:`_Knots`) holds, per masked sample, the gap's good neighbours and
    the next frames outward when they are good; ``run`` is the sample's gap number and
    ``start``, ``stop``, ``gap_col`` describe the gaps.
    """

    def __init__(self, mask: np.ndarray):
        n_frames = mask.shape[0]
        self.start, self.stop, self.gap_col = _runs(mask)
        length = self.stop - self.start
        self.run = np.repeat(np.arange(length.size), length)
        offset = np.arange(self.run.size) - np.repeat(np.cumsum(length) - length, length)
        frame = self.start[self.run] + offset
        col = self.gap_col[self.run]
        left, right = frame - offset - 1, self.stop[self.run]
        left2, right2 = left - 1, right + 1
        ok = (left2 >= 0) & ~mask[np.maximum(left2, 0), col]
        left2 = np.where(ok, left2, -1)
        ok = (right2 < n_frames) & ~mask[np.minimum(right2, n_frames - 1), col]
        self.knots = _Knots(frame, col, left, right, left2, np.where(ok, right2, -1))

    def widen(self, mask: np.ndarray, runs: np.ndarray) -> None:
        """Add one frame on each side of the gaps numbered ``runs`` to ``mask``."""
        start, stop, col = self.start[runs], self.stop[runs], self.gap_col[runs]
        mask[np.maximum(start - 1, 0), col] = True
        mask[np.minimum(stop, mask.shape[0] - 1), col] = True


def _fill(x, mask, dist, interpolate, method, cap, passes):
    """Interpolate the masked samples of ``x`` (F, C, n) in place, widening every gap
    whose interpolated steps exceed ``cap`` by a frame per side, at most ``passes``
    times. Steps away from the gaps are not looked at: the caller masked every step above
    the cap. Returns the final mask."""
    n_frames = x.shape[0]
    for done in range(passes + 1):
        gaps = _Gaps(mask)
        k = gaps.knots
        x[k.frame, k.col] = interpolate(x, k, method)
        if done == passes:
            break
        # The steps into and out of every interpolated sample.
        f = np.concatenate([k.frame[k.frame > 0] - 1, k.frame[k.frame < n_frames - 1]])
        c = np.concatenate([k.col[k.frame > 0], k.col[k.frame < n_frames - 1]])
        run = np.concatenate([gaps.run[k.frame > 0], gaps.run[k.frame < n_frames - 1]])
        over = dist(x[f, c], x[f + 1, c]) > cap
        if not over.any():
            break
        gaps.widen(mask, np.unique(run[over]))
    return mask


def _lagrange(frame, left, right):
    """Cubic Lagrange weights ``c0..c3`` at ``frame`` on the knots ``left-1, left, right,
    right+1`` (the non-uniform four-point scheme, Eq. 17 of 003), in closed form with
    ``a = frame - left``, ``b = right - frame`` and ``g = right - left``."""
    a = (frame - left).astype(np.float64)
    b = (right - frame).astype(np.float64)
    g = a + b
    outer, inner = (g + 1.0) * (g + 2.0), g * (g + 1.0)
    return (-a * b * (b + 1.0) / outer, (a + 1.0) * b * (b + 1.0) / inner,
            a * (a + 1.0) * (b + 1.0) / inner, -a * (a + 1.0) * b / outer)


def _interpolate_rotations(q: np.ndarray, knots: _Knots, method: str) -> np.ndarray:
    """Values ``(n, 4)`` for the samples of ``q`` (F, C, 4) described by ``knots``."""
    frame, col, left, right = knots.frame, knots.col, knots.left, knots.right
    n_frames = q.shape[0]
    has_l, has_r = left >= 0, right < n_frames
    ql = q[np.maximum(left, 0), col]
    qr = q[np.minimum(right, n_frames - 1), col]
    u = (frame - left) / (right - left)
    if method == "cubic":
        cubic = has_l & has_r & (knots.left2 >= 0) & (knots.right2 >= 0)
        c0, _, c2, c3 = _lagrange(frame, left, right)
        u = np.where(cubic, c2 + c3, u)
        # One product and log for the gap and both outer displacements w_0 and w_2.
        n = frame.size
        logs = _shorter_log(_product(np.concatenate([ql, q[knots.left2, col], qr]),
                                     np.concatenate([qr, ql, q[knots.right2, col]]),
                                     conjugate_p=True))
        gap, w0, w2 = logs[:n], logs[n:2 * n], logs[2 * n:]
        tangent = np.where(cubic[:, None], -c0[:, None] * w0 + c3[:, None] * w2, 0.0)
        moves = _exp(np.concatenate([u[:, None] * gap, tangent]))
        value = _product(_product(ql, moves[:n]), moves[n:])
    else:
        gap = _shorter_log(_product(ql, qr, conjugate_p=True))
        value = _product(ql, _exp(u[:, None] * gap))
    value = np.where((has_l & ~has_r)[:, None], ql, value)
    value = np.where((~has_l & has_r)[:, None], qr, value)
    return np.where((has_l | has_r)[:, None], value, q[frame, col])


def _interpolate_positions(p: np.ndarray, knots: _Knots, method: str) -> np.ndarray:
    """Vector counterpart of :func:`_interpolate_rotations` (003 Eq. 15, 17): ``(n, 3)``."""
    frame, col, left, right = knots.frame, knots.col, knots.left, knots.right
    n_frames = p.shape[0]
    has_l, has_r = left >= 0, right < n_frames
    pl = p[np.maximum(left, 0), col]
    pr = p[np.minimum(right, n_frames - 1), col]
    u = ((frame - left) / (right - left))[:, None]
    value = (1.0 - u) * pl + u * pr
    if method == "cubic":
        cubic = has_l & has_r & (knots.left2 >= 0) & (knots.right2 >= 0)
        c0, c1, c2, c3 = _lagrange(frame, left, right)
        curve = (c0[:, None] * p[knots.left2, col] + c1[:, None] * pl + c2[:, None] * pr
                 + c3[:, None] * p[knots.right2, col])
        value = np.where(cubic[:, None], curve, value)
    value = np.where((has_l & ~has_r)[:, None], pl, value)
    value = np.where((~has_l & has_r)[:, None], pr, value)
    return np.where((has_l | has_r)[:, None], value, p[frame, col])


def _check(frame_time, threshold, low, high, max_spike_s, max_run, trend_ratio, method, methods,
           unit) -> int:
    """Validate the shared parameters; return the longest spike in frames: ``max_spike_s``
    in whole frames (at least one), and at most ``max_run`` when given."""
    if not (np.isfinite(frame_time) and frame_time > 0):
        raise ValueError(f"frame_time must be a positive number of seconds, got {frame_time}")
    if not (np.isfinite(threshold) and threshold >= 0):
        raise ValueError(f"threshold must be a number of robust deviations >= 0, got {threshold}")
    if not (0 <= low <= high and high > 0):
        raise ValueError(f"need 0 <= min_{unit}_per_s <= max_{unit}_per_s and max_{unit}_per_s "
                         f"> 0, got {low} and {high}")
    if not (np.isfinite(max_spike_s) and max_spike_s > 0):
        raise ValueError(f"max_spike_s must be a positive number of seconds, got {max_spike_s}")
    if max_run is not None and (int(max_run) != max_run or max_run < 1):
        raise ValueError(f"max_run must be a whole number of frames >= 1, got {max_run}")
    if not (np.isfinite(trend_ratio) and trend_ratio >= 0):
        raise ValueError(f"trend_ratio must be a number >= 0, got {trend_ratio}")
    if method not in methods:
        raise ValueError(f"method must be one of {', '.join(methods)}, got {method!r}")
    # The small tolerance keeps 8/120 s at 8 frames despite rounding.
    frames = max(1, int(np.floor(max_spike_s / frame_time * (1.0 + 1e-9))))
    return frames if max_run is None else min(frames, int(max_run))


def _norm(v: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("...i,...i->...", v, v))


def _rotation_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle (rad) between unit quaternions, independent of their signs:
    ``2 acos |a . b|``, one dot product per pair (absolute error about 1e-8 rad near 0,
    far below any threshold in degrees)."""
    dot = np.abs(np.einsum("...i,...i->...", a, b))
    return 2.0 * np.arccos(np.minimum(dot, 1.0))


def _position_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return _norm(b - a)


def _sample_kernel(kernel, width: int, n_tmp: int, *arrays, **options) -> np.ndarray:
    """Run one of :mod:`motionclean.quat`'s plane kernels on ``(n, k)`` sample arrays.

    The sparse samples handled here are a few dozen to a few thousand, where the blocking
    of :func:`quat.multiply` and friends costs more than the arithmetic.
    """
    out = np.empty((arrays[0].shape[0], width))
    kernel([out[:, c] for c in range(width)], *([a[:, c] for c in range(a.shape[1])]
                                                for a in arrays),
           [np.empty(out.shape[0]) for _ in range(n_tmp)], **options)
    return out


def _product(p: np.ndarray, q: np.ndarray, conjugate_p: bool = False) -> np.ndarray:
    """``p q`` (or ``p^-1 q``) of ``(n, 4)`` samples."""
    return _sample_kernel(quat.multiply_planes, 4, 2, p, q, conjugate_p=conjugate_p)


def _shorter_log(rel: np.ndarray) -> np.ndarray:
    """``log(+-rel)`` of the shorter arc (``|log| <= pi/2``) of ``(n, 4)`` samples."""
    return _sample_kernel(quat.log_planes, 3, 2, rel, shortest=True)


def _exp(v: np.ndarray) -> np.ndarray:
    """``exp(v)`` of ``(n, 3)`` samples."""
    return _sample_kernel(quat.exp_planes, 4, 3, v)


def _rotation_velocity(q: np.ndarray, step: np.ndarray, col: np.ndarray) -> np.ndarray:
    """Rotation vectors ``2 log(q_i^-1 q_{i+1})`` (rad) of steps ``i`` in columns ``c``."""
    return 2.0 * _shorter_log(_product(q[step, col], q[step + 1, col], conjugate_p=True))


def _position_velocity(p: np.ndarray, step: np.ndarray, col: np.ndarray) -> np.ndarray:
    return p[step + 1, col] - p[step, col]


def _repair(x, frame_time, rotations, threshold, low, high, max_len, trend_ratio, method,
            flip_rad):
    """Shared driver on ``x`` (F, C, 4|3): jump threshold, un-flip, spikes, cap passes.

    Spikes are at most ``max_len`` frames long; the cap widens a gap at most ``max_len``
    times. Returns the repaired array (columns without repairs are ``x``'s own), the
    un-flipped and interpolated masks (F, C), the jump threshold and the largest step
    before and after (C,), all in radians or length units per frame. Beyond the steps and their
    statistics, only the sparse jumps, the flipped joints and the gaps are worked on.
    """
    if rotations:
        dist, velocity, interpolate = (_rotation_distance, _rotation_velocity,
                                       _interpolate_rotations)
    else:
        dist, velocity, interpolate = (_position_distance, _position_velocity,
                                       _interpolate_positions)
    n_frames, n_cols = x.shape[:2]
    flipped = np.zeros((n_frames, n_cols), dtype=bool)
    if n_frames < 2:
        zeros = np.zeros(n_cols)
        return x.copy(), flipped, flipped.copy(), zeros, zeros, zeros
    steps = dist(x[:-1], x[1:])
    before = steps.max(axis=0)
    cap = high * frame_time
    jump = np.full(n_cols, low * frame_time)  # the floor: no jump where no step exceeds it
    moving = np.flatnonzero(before > jump)
    jump[moving] = _robust_threshold(steps[:, moving], threshold, low * frame_time, cap)
    out = x.copy()
    if flip_rad is not None:
        toggles, (cols, axis, left) = _flip_toggles(x, steps, flip_rad)
        if toggles.any():
            # Toggles on the steps of a spike that is not itself a clean flip (half-turn
            # both in and out) are artefacts of the spike: its ends share one state.
            first, length, col = _spike_runs(x, steps, jump, max_len, trend_ratio, dist,
                                             velocity, interpolate)
            spike = ~(toggles[first - 1, col] & toggles[first + length - 1, col])
            toggles &= ~_mark(first[spike] - 1, length[spike] + 1, col[spike], steps.shape)
            parity = _parity(toggles[:, cols])
            frame, slot = np.nonzero(parity)
            out[frame, cols[slot]] = _half_turn(x, frame, slot, cols, axis, left)
            flipped[:, cols] = parity
            steps[:, cols] = dist(out[:-1, cols], out[1:, cols])
    mask = _mark(*_spike_runs(out, steps, jump, max_len, trend_ratio, dist, velocity,
                              interpolate), flipped.shape)
    over = (steps > cap) & ~mask[:-1] & ~mask[1:]  # a step above the cap outside any spike
    mask[:-1] |= over
    mask[1:] |= over
    if mask.any():
        mask = _fill(out, mask, dist, interpolate, method, cap, max_len)
    changed = np.flatnonzero((flipped | mask).any(axis=0))
    if rotations:
        out[:, changed] = quat.make_continuous(out[:, changed], axis=0)
    after = before.copy()
    after[changed] = dist(out[:-1, changed], out[1:, changed]).max(axis=0)
    return out, flipped, mask, jump, before, after


def _columns(x: np.ndarray) -> np.ndarray:
    """``(F, ..., n)`` viewed as ``(F, C, n)``, also for empty arrays."""
    return x.reshape(x.shape[0], int(np.prod(x.shape[1:-1])), x.shape[-1])


def _report(shape, flipped, interpolated, jump, before, after, scale) -> DespikeReport:
    trailing = shape[1:-1]
    return DespikeReport(
        unflipped=flipped.reshape(shape[0], *trailing),
        interpolated=interpolated.reshape(shape[0], *trailing),
        threshold=scale(jump).reshape(trailing),
        max_step_before=scale(before).reshape(trailing),
        max_step_after=scale(after).reshape(trailing),
    )


def despike_with_report(
    q: np.ndarray,
    frame_time: float,
    *,
    threshold: float = 8.0,
    min_deg_per_s: float = 600.0,
    max_deg_per_s: float = 3600.0,
    max_spike_s: float = 0.07,
    trend_ratio: float = 3.0,
    max_run: int | None = None,
    flip_deg: float = 150.0,
    unflip: bool = True,
    method: str = "cubic",
) -> tuple[np.ndarray, DespikeReport]:
    """Repair half-turn flips and spikes in unit-quaternion signals (see module docstring).

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions ``(w, x, y, z)``, time along axis 0.
    frame_time : float
        Seconds per frame; turns the per-second limits into per-frame angles.
    threshold : float
        Robust deviations (1.4826 MAD) above the median step for a step to be a jump.
    min_deg_per_s, max_deg_per_s : float
        The jump threshold is clipped to ``[min, max] * frame_time`` degrees. Steps faster
        than ``max_deg_per_s`` (default 3600: 30 degrees per frame at 120 fps) are always
        repaired; steps slower than ``min_deg_per_s`` (default 600: 5 degrees per frame at
        120 fps) never count as jumps.
    max_spike_s : float
        Longest spike in seconds (whole frames, at least one: 8 frames at 120 fps, 2 at
        30 fps); also the most frames by which the cap widens a gap on each side.
    trend_ratio : float
        A spike's first and last frames must be further from the cubic trend through its
        good neighbours than ``trend_ratio`` times that trend's error at the neighbours
        (``0`` skips the test).
    max_run : int or None
        Optional bound on the spike length in frames, on top of ``max_spike_s``.
    flip_deg : float
        Smallest single-frame step taken as a half-turn flip, degrees in (90, 180].
    unflip : bool
        Undo half-turn flips before interpolating.
    method : str
        ``"cubic"`` (003 Eq. 16-17) or ``"slerp"``.

    Returns
    -------
    (F, ..., 4) array and :class:`DespikeReport`
        Repaired columns are sign-continuous; columns without defects are returned as given,
        bit for bit. Report angles are in degrees per frame.
    """
    max_len = _check(frame_time, threshold, min_deg_per_s, max_deg_per_s, max_spike_s, max_run,
                     trend_ratio, method, ("cubic", "slerp"), "deg")
    if not 90.0 < flip_deg <= 180.0:
        raise ValueError(f"flip_deg must be in (90, 180] degrees, got {flip_deg}")
    q = np.asarray(q, dtype=np.float64)
    if q.ndim < 2 or q.shape[-1] != 4:
        raise ValueError(f"q must have shape (F, ..., 4), got {q.shape}")
    out, *masks_and_steps = _repair(
        _columns(q), frame_time, True, threshold,
        np.deg2rad(min_deg_per_s), np.deg2rad(max_deg_per_s), max_len, trend_ratio, method,
        np.deg2rad(flip_deg) if unflip else None)
    return out.reshape(q.shape), _report(q.shape, *masks_and_steps, np.rad2deg)


def despike(q: np.ndarray, frame_time: float, **params) -> np.ndarray:
    """Repaired rotations of :func:`despike_with_report` (same parameters), no report."""
    return despike_with_report(q, frame_time, **params)[0]


def despike_positions_with_report(
    p: np.ndarray,
    frame_time: float,
    *,
    threshold: float = 8.0,
    min_units_per_s: float = 0.0,
    max_units_per_s: float = np.inf,
    max_spike_s: float = 0.07,
    trend_ratio: float = 3.0,
    max_run: int | None = None,
    method: str = "cubic",
) -> tuple[np.ndarray, DespikeReport]:
    """Vector counterpart of :func:`despike_with_report` for ``(F, ..., 3)`` translations.

    Steps are Euclidean distances between consecutive frames in the file's length unit
    (marker swaps make the root jump). The jump threshold is ``clip(median + threshold *
    1.4826 MAD, min_units_per_s dt, max_units_per_s dt)``; spikes (at most ``max_spike_s``
    long, off the local cubic trend by ``trend_ratio`` times its error at the neighbours)
    are interpolated with the cubic of 003 Eq. 15/17 (or ``"linear"``) and steps above
    ``max_units_per_s`` are spread by widening the gap. There is no flip repair and, as
    units differ between files, no absolute cap unless ``max_units_per_s`` is given.
    ``unflipped`` is all false.
    """
    max_len = _check(frame_time, threshold, min_units_per_s, max_units_per_s, max_spike_s,
                     max_run, trend_ratio, method, ("cubic", "linear"), "units")
    p = np.asarray(p, dtype=np.float64)
    if p.ndim < 2 or p.shape[-1] != 3:
        raise ValueError(f"p must have shape (F, ..., 3), got {p.shape}")
    out, *masks_and_steps = _repair(
        _columns(p), frame_time, False, threshold, min_units_per_s,
        max_units_per_s, max_len, trend_ratio, method, None)
    return out.reshape(p.shape), _report(p.shape, *masks_and_steps, np.asarray)


def despike_positions(p: np.ndarray, frame_time: float, **params) -> np.ndarray:
    """Repaired translations of :func:`despike_positions_with_report`, no report."""
    return despike_positions_with_report(p, frame_time, **params)[0]
