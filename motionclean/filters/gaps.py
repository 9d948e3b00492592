"""Filling tracker dropouts: a smooth, coordinate-invariant bridge across each gap.

A gap of joint ``j`` is a run of missing frames between known frames ``a`` and ``b``. What is
bridged is the joint's pose relative to a *donor*: another joint tracked throughout, or the
world frame (no donor). With donor rotation ``d`` and position ``c``, the relative pose is
``r = d^-1 q`` and ``s = d^-1 (p - c) d`` (``p`` rotated into the donor's frame); a hand
seen from its forearm moves far less than in the world, so its bridge follows the forearm
through the gap, as a pattern fill does. Per gap the rotation's donor is the one whose
relative rotation is smoothest (least squared second differences) over
:data:`DONOR_FRAMES` frames on each side, and the position's the one whose relative
position is (over :data:`POSITION_DONOR_FRAMES`). A gap no longer than
:data:`DONOR_FRAMES` bridges its rotation in the world frame: its own edge velocities say
enough, and a donor only adds the donor's noise.

The relative pose is bridged by the C1 cubic of :mod:`.interpolate` from frame ``a`` to
frame ``b`` (``r_a exp(h(u))``, ``u = (f - a) / (b - a)``; positions the matching Hermite
cubic): position and velocity continuous at both edges. Edge velocities come from a
least-squares quadratic through the edge sample and up to :data:`EDGE_FRAMES` known frames
beside it (in the tangent space at the edge sample), so one noisy edge frame does not steer
the bridge. Only displacements between samples of the same joint, and poses relative to
another joint, enter: the fill commutes with a fixed rotation of the world (and of each
body's own frame).

How much of the edge velocities a bridge follows, and whether the donor helps at all, is
checked on the joint's own data (:func:`_validated`): gaps of the same length are planted
in the known frames beside each gap (up to :data:`TRIALS_PER_SIDE` on each side) and
bridged with the donor and without, with the edge velocities' departure from the chord
weighted by each of :data:`VELOCITY_WEIGHTS` (0: the straight line, geodesic at constant
angular velocity); the one of least error there fills the gap, the straight line unless
another beats it by :data:`LINE_MARGIN`. A clean optical capture keeps its velocities
(they predict its gaps well); a markerless estimate, whose edge velocities are mostly its
noise, gets the straight line; a joint that does not move with its would-be donor (a hip
and an elbow, say) is bridged on its own.

A gap at the start or end of the clip has one edge: the relative pose at that edge is held
(with no donor: the edge sample itself; extrapolating a rotation at its edge velocity for
half a second could spin it anywhere).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..core import quat
from .interpolate import end_tangent, hermite_positions, hermite_rotations

#: Known frames beside an edge that its velocity is fitted to ...
EDGE_FRAMES = 3
#: ... and that donors are judged on, for the rotation and for the position.
DONOR_FRAMES = 10
POSITION_DONOR_FRAMES = 8
#: Median of a chi-squared variable with three degrees of freedom.
CHI2_3_MEDIAN = 2.3660
#: Gaps handled at a time when choosing donors (temporaries stay small).
GAP_BLOCK = 256
#: Edge-velocity weights a gap's bridge may take (0: the straight line, 1: the edges'
#: fitted velocities), chosen per gap on gaps of its length planted beside it ...
VELOCITY_WEIGHTS = (0.0, 0.5, 1.0)
#: ... up to this many on each side. A bridge using the edge velocities must beat the
#: straight line by this share of its error there to be taken (the trials are few, and
#: beside a real dropout the tracker was already losing the body).
TRIALS_PER_SIDE = 2
LINE_MARGIN = 0.2


@dataclass(frozen=True)
class Gaps:
    """Runs of missing frames: ``joint``, ``first`` and ``stop`` (frames ``first ..
    stop-1``) per gap, in joint-major order."""

    joint: np.ndarray
    first: np.ndarray
    stop: np.ndarray

    @classmethod
    def of(cls, missing: np.ndarray) -> Gaps:
        """The gaps of a ``(F, J)`` bool mask."""
        padded = np.zeros((missing.shape[0] + 2, missing.shape[1]), dtype=np.int8)
        padded[1:-1] = missing
        change = np.diff(padded, axis=0).T  # (J, F + 1): +1 where a gap starts, -1 after
        joint, first = np.nonzero(change == 1)
        _, stop = np.nonzero(change == -1)
        return cls(joint, first, stop)

    @property
    def lengths(self) -> np.ndarray:
        return self.stop - self.first

    def select(self, keep: np.ndarray) -> Gaps:
        return Gaps(self.joint[keep], self.first[keep], self.stop[keep])


@dataclass(frozen=True)
class Filled:
    """What :func:`fill_gaps` did: the arrays with the gaps filled, the mask of what is
    still missing, the gaps found, which were filled and each filled gap's donors ``(2, G)``
    for its rotation and its position (-1: the world frame)."""

    rotations: np.ndarray
    translations: np.ndarray
    missing: np.ndarray
    gaps: Gaps
    filled: np.ndarray
    donor: np.ndarray


# ----------------------------------------------------------------------------- bridging


def _edge_weights(count: int) -> np.ndarray:
    """Weights ``w_k`` (``k = 1 .. count``) with ``sum w_k x_k`` the slope at ``k = 0`` of
    the least-squares quadratic through ``(0, 0)`` and ``(k, x_k)`` (a line for one point)."""
    k = np.arange(1, count + 1, dtype=np.float64)
    basis = np.stack([k, k * k], axis=1) if count >= 2 else k[:, None]
    return np.linalg.pinv(basis)[0]


def _rotation_log(base: np.ndarray, other: np.ndarray) -> np.ndarray:
    return quat.log_shortest(quat.relative(base, other))


def _position_log(base: np.ndarray, other: np.ndarray) -> np.ndarray:
    return other - base


def _edge_velocity(x, edge, room, direction, log_of) -> tuple[np.ndarray, np.ndarray]:
    """Velocity per frame at rows ``edge`` of the flat signal ``x``, fitted to up to
    :data:`EDGE_FRAMES` of the ``room`` known rows on the side away from the gap
    (``direction`` -1: before the edge, +1: after), and the factor that turns the per-sample
    noise variance into that velocity's (zero where there is no room)."""
    out, gain = np.zeros((edge.size, 3)), np.zeros(edge.size)
    count = np.minimum(room, EDGE_FRAMES)
    for n in np.unique(count[count > 0]):  # a few distinct counts
        at = np.flatnonzero(count == n)
        base = x[edge[at]]
        slope = np.zeros((at.size, 3))
        weights = _edge_weights(int(n))
        for k, weight in enumerate(weights, 1):
            slope += weight * log_of(base, x[edge[at] + direction * k])
        out[at] = direction * slope
        gain[at] = np.sum(weights**2) + np.sum(weights) ** 2  # the edge sample is noisy too
    return out, gain


def _shrunk(velocity, gain, chord, noise_var) -> np.ndarray:
    """The fitted edge velocity pulled toward the chord's by as much as noise explains of
    their difference (James-Stein shrinkage; noise-free data keep the fit)."""
    spread = 3.0 * noise_var * gain  # expected |velocity error|^2 (three components)
    apart = np.sum((velocity - chord) ** 2, axis=-1)
    keep = np.clip(1.0 - spread / np.maximum(apart, 1e-300), 0.0, 1.0)
    keep[gain == 0.0] = 0.0  # no room beside the gap: the chord
    return chord + keep[:, None] * (velocity - chord)


def _bridge(
    x, a, b, room_a, room_b, rows, gap_of, rotations: bool, noise_var, weight
) -> np.ndarray:
    """The C1 cubic across each gap of the flat signal ``x`` (rows ``a`` and ``b`` known,
    ``room_*`` known rows beyond them, per-sample noise variance ``noise_var`` per gap and
    component), at ``rows`` (gap ``gap_of``); each gap's edge velocities are the chord's
    plus ``weight`` (G,) times their difference from it (0: the straight line)."""
    log_of = _rotation_log if rotations else _position_log
    span = (b - a).astype(np.float64)[:, None]
    step = log_of(x[a], x[b])
    chord = step / span
    keep = weight[:, None]
    v_a = _shrunk(*_edge_velocity(x, a, room_a, -1, log_of), chord, noise_var)
    v_b = _shrunk(*_edge_velocity(x, b, room_b, +1, log_of), chord, noise_var)
    v_a = (chord + keep * (v_a - chord)) * span
    v_b = (chord + keep * (v_b - chord)) * span
    u = (rows - a[gap_of]) / span[gap_of, 0]
    g = gap_of
    if rotations:
        return hermite_rotations(x[a][g], step[g], v_a[g], end_tangent(step, v_b)[g], u)
    return hermite_positions(x[a][g], v_a[g], x[b][g], v_b[g], u)


def noise_variance(x: np.ndarray, missing: np.ndarray, rotations: bool) -> np.ndarray:
    """Per-sample noise variance per component of each joint of ``x`` ``(F, J, 4|3)``
    (rotations: of the half-angle log), from the median squared length of the third
    differences over the known frames (white noise of variance s^2 per component gives
    third differences of variance 20 s^2 per component, and their squared length a median
    of :data:`CHI2_3_MEDIAN` times that): rotation invariant. ``(J,)``; 0 for short clips."""
    if x.shape[0] < 5:
        return np.zeros(x.shape[1])
    steps = np.empty((x.shape[0] - 1, x.shape[1], 3))
    for at in range(0, steps.shape[0], 4096):  # temporaries stay small
        rows = slice(at, min(at + 4096, steps.shape[0]))
        a, b = x[rows], x[rows.start + 1 : rows.stop + 1]
        steps[rows] = _rotation_log(a, b) if rotations else b - a
    third = steps[2:] - 2.0 * steps[1:-1] + steps[:-2]
    known = ~(missing[:-3] | missing[1:-2] | missing[2:-1] | missing[3:])
    squares = np.where(known, np.einsum("fjc,fjc->fj", third, third), np.nan)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a joint with no known run: NaN
        median = np.nanmedian(squares, axis=0)
    return np.nan_to_num(median / CHI2_3_MEDIAN / 20.0)


# ----------------------------------------------------------------------------- donors


def _frame_of(q, p, donor, frames):
    """Rotation and position of ``donor`` (-1: the world) at ``frames`` (same shapes)."""
    world = donor < 0
    d = np.where(world[..., None], quat.identity(()), q[frames, np.maximum(donor, 0)])
    c = np.where(world[..., None], 0.0, p[frames, np.maximum(donor, 0)])
    return d, c


def _relative(q, p, joint, donors, frames):
    """Pose of ``joint`` at ``frames`` relative to ``donors = (rotation donor, position
    donor)`` (-1: the world; same shapes): ``d^-1 q`` and ``e^-1 (p - c) e`` for the
    rotation donor's ``d`` and the position donor's rotation ``e`` and position ``c``."""
    d, _ = _frame_of(q, p, donors[0], frames)
    e, c = _frame_of(q, p, donors[1], frames)
    rel_q = quat.relative(d, q[frames, joint])
    return rel_q, quat.rotate(quat.conjugate(e), p[frames, joint] - c)


def _roughness(x: np.ndarray, rotations: bool) -> np.ndarray:
    """Sum of squared second differences along axis 1 of ``(G, W, C, n)`` windows."""
    if rotations:
        steps = quat.log_shortest(quat.relative(x[:, :-1], x[:, 1:]))
    else:
        steps = np.diff(x, axis=1)
    return np.sum(np.diff(steps, axis=1) ** 2, axis=(1, 3))


def _choose_donors(q, p, missing, gaps: Gaps) -> np.ndarray:
    """Per gap, ``(2, G)``: the donors (or -1) whose relative rotation, and relative
    position, are smoothest beside the gap among the joints known from
    :data:`DONOR_FRAMES` frames before it to as many after it."""
    n_frames, n_joints = missing.shape
    lo = np.maximum(gaps.first - 1 - DONOR_FRAMES, 0)
    hi = np.minimum(gaps.stop + DONOR_FRAMES, n_frames - 1)
    seen = np.concatenate([np.zeros((1, n_joints), int), np.cumsum(missing, axis=0)])
    donor = np.full((2, gaps.joint.size), -1)
    offsets = np.arange(-DONOR_FRAMES, 1)
    for at in range(0, gaps.joint.size, GAP_BLOCK):
        block = slice(at, at + GAP_BLOCK)
        joint = gaps.joint[block]
        tracked = (seen[hi[block] + 1] - seen[lo[block]]) == 0  # (G, J)
        tracked[np.arange(joint.size), joint] = False
        if not tracked.any():
            continue
        # Window frames: the known ones nearest each edge (clipped to the clip).
        before = np.clip(gaps.first[block, None] - 1 + offsets, 0, n_frames - 1)
        after = np.clip(gaps.stop[block, None] - offsets[::-1], 0, n_frames - 1)
        rough = np.zeros((2, joint.size, n_joints + 1))
        near = DONOR_FRAMES - POSITION_DONOR_FRAMES  # position windows: the frames nearest
        for frames, inner in ((before, slice(near, None)), (after, slice(None, -near or None))):
            frames = frames[:, :, None]  # (G, W, 1)
            candidates = np.arange(-1, n_joints)[None, None, :]  # -1: the world
            shape = (joint.size, frames.shape[1], n_joints + 1)
            candidate = np.broadcast_to(candidates, shape)
            rel_q, rel_p = _relative(
                q,
                p,
                np.broadcast_to(joint[:, None, None], shape),
                (candidate, candidate),
                np.broadcast_to(frames, shape),
            )
            rough[0] += _roughness(rel_q, True)
            rough[1] += _roughness(rel_p[:, inner], False)
        rough[:, :, 1:][:, ~tracked] = np.inf
        best = rough.min(axis=2, keepdims=True)  # ties (rigidly attached bodies): the first
        donor[:, block] = np.argmax(rough <= best + 1e-9 * (1.0 + best), axis=2) - 1
    return donor


# ----------------------------------------------------------------------------- filling


def _known_room(missing: np.ndarray, joint: np.ndarray, edge: np.ndarray, direction: int):
    """Known frames in a row beyond ``edge`` (excluded) going ``direction``, per gap."""
    n_frames = missing.shape[0]
    frames = np.arange(n_frames)[:, None]
    if direction < 0:
        last = np.maximum.accumulate(np.where(missing, frames, -1), axis=0)
        return edge - last[edge, joint] - 1
    following = np.minimum.accumulate(np.where(missing, frames, n_frames)[::-1], axis=0)[::-1]
    return following[edge, joint] - edge - 1


def fill_gaps(
    rotations: np.ndarray,
    translations: np.ndarray,
    missing: np.ndarray,
    max_gap: int,
    use_positions: np.ndarray | None = None,
    donors: bool = True,
) -> Filled:
    """Fill every gap of at most ``max_gap`` frames (module docstring).

    ``rotations`` ``(F, J, 4)`` unit quaternions ``(w, x, y, z)`` and ``translations``
    ``(F, J, 3)`` with placeholders where ``missing`` ``(F, J)`` is True;
    ``use_positions`` ``(J,)`` marks the joints whose translations are data (default all);
    ``donors`` False bridges every joint in the world frame. Longer gaps stay missing and
    untouched, and so does a joint never seen at all.
    """
    n_frames, n_joints = missing.shape
    use_positions = np.ones(n_joints, bool) if use_positions is None else use_positions
    gaps = Gaps.of(missing)
    fillable = gaps.lengths <= max_gap
    fillable &= (gaps.first > 0) | (gaps.stop < n_frames)  # a joint never seen stays so
    todo = gaps.select(fillable)
    q, p = rotations.copy(), translations.copy()
    still = missing.copy()
    donor = np.full((2, todo.joint.size), -1)
    if donors:
        donor = _choose_donors(rotations, translations, missing, todo)
        # A gap no longer than the stretch donors are judged on is bridged better by the
        # body's own rotation (its edge velocities say enough): donors for longer ones.
        donor[0, todo.lengths <= DONOR_FRAMES] = -1
    lengths = todo.lengths
    gap_of = np.repeat(np.arange(lengths.size), lengths)
    frame = todo.first[gap_of] + _ranks(lengths)
    joint = todo.joint[gap_of]
    still[frame, joint] = False
    # Bridge the relative poses; the edges, and the known rows beside them, come along.
    inner = (todo.first > 0) & (todo.stop < n_frames)
    a = np.where(todo.first > 0, todo.first - 1, todo.stop)  # one-sided: the edge
    rel_q, rel_p = _relative(rotations, translations, joint, donor[:, gap_of], frame)
    held = ~inner[gap_of]
    if held.any():
        edge_q, edge_p = _relative(rotations, translations, joint, donor[:, gap_of], a[gap_of])
        rel_q[held], rel_p[held] = edge_q[held], edge_p[held]
    if inner.any():
        noise = (
            noise_variance(rotations, missing, True),
            noise_variance(translations, missing, False),
        )
        two_sided = todo.select(inner)
        chosen, weight_q, weight_p = _validated(
            rotations, translations, missing, two_sided, donor[:, inner], noise
        )
        donor[0, inner] = chosen
        rel_q, rel_p = _relative(rotations, translations, joint, donor[:, gap_of], frame)
        if held.any():
            edge_q, edge_p = _relative(rotations, translations, joint, donor[:, gap_of], a[gap_of])
            rel_q[held], rel_p[held] = edge_q[held], edge_p[held]
        rel_q[~held], rel_p[~held] = _bridge_inner(
            rotations, translations, missing, two_sided, donor[:, inner], noise, weight_q, weight_p
        )
    d, _ = _frame_of(rotations, translations, donor[0, gap_of], frame)
    e, c = _frame_of(rotations, translations, donor[1, gap_of], frame)
    q[frame, joint] = quat.multiply(d, rel_q)
    moved = use_positions[joint]
    p[frame[moved], joint[moved]] = (c + quat.rotate(e, rel_p))[moved]
    q = quat.make_continuous(q, axis=0)
    return Filled(q, p, still, gaps, fillable, _spread(donor, fillable))


def _trials(missing, gaps: Gaps, donor: np.ndarray):
    """Gaps of the same length as each of ``gaps`` planted in known frames beside it, for
    :func:`_validated`: ``(trial gaps, index of the real gap of each)``. Up to
    :data:`TRIALS_PER_SIDE` on each side, spaced by their length plus one; a trial is kept
    when its frames, the :data:`EDGE_FRAMES` known frames around it and its edges lie in the
    clip, are all known for the joint and, where ``donor`` (G,) is a joint, for it too."""
    n_frames = missing.shape[0]
    lengths = gaps.lengths
    k = np.arange(TRIALS_PER_SIDE)
    step = lengths[:, None] + 1
    left_stop = gaps.first[:, None] - 1 - EDGE_FRAMES - k * step  # (G, K)
    right_first = gaps.stop[:, None] + EDGE_FRAMES + 1 + k * step
    first = np.concatenate([left_stop - lengths[:, None], right_first], axis=1).reshape(-1)
    of = np.repeat(np.arange(lengths.size), 2 * TRIALS_PER_SIDE)
    stop = first + lengths[of]
    lo, hi = first - 1 - EDGE_FRAMES, stop + EDGE_FRAMES  # the frames read, inclusive
    ok = (lo >= 0) & (hi < n_frames)
    seen = np.concatenate([np.zeros((1, missing.shape[1]), int), np.cumsum(missing, axis=0)])
    lo_c, hi_c = np.clip(lo, 0, n_frames - 1), np.clip(hi, 0, n_frames - 1)
    joint = gaps.joint[of]
    ok &= seen[hi_c + 1, joint] == seen[lo_c, joint]
    helper = donor[of]
    tracked = seen[hi_c + 1, np.maximum(helper, 0)] == seen[lo_c, np.maximum(helper, 0)]
    ok &= (helper < 0) | tracked
    return Gaps(joint[ok], first[ok], stop[ok]), of[ok]


def _validated(rotations, translations, missing, gaps: Gaps, donor: np.ndarray, noise):
    """Per two-sided gap, the rotation donor (the chosen ``donor[0]`` or the world, -1) and
    the edge-velocity weights (:data:`VELOCITY_WEIGHTS`) of its rotation and of its position
    bridge that fill best the gaps of the same length planted beside it in the joint's own
    known frames (least summed squared error there, the straight line, weight 0, taken
    unless another is :data:`LINE_MARGIN` better; :func:`_trials`). Whatever a joint's
    motion and noise, its bridges are then no worse there than the straight line, and a
    donor that does not move with the joint is dropped. A gap without room for
    a trial keeps its donor and the full edge velocities. Returns ``(donor, weight of the
    rotation, weight of the position)``, each (G,)."""
    n_gaps = gaps.joint.size
    options = [(-1, w) for w in VELOCITY_WEIGHTS]
    if (donor[0] >= 0).any():
        options += [(0, w) for w in VELOCITY_WEIGHTS]  # 0: the chosen donor
    error = np.full((2, len(options), n_gaps), np.inf)  # rotations, positions
    for i, (use, w) in enumerate(options):
        helper = donor[0] if use == 0 else np.full(n_gaps, -1)
        trials, of = _trials(missing, gaps, np.where(helper >= 0, helper, donor[1]))
        if not of.size:
            continue
        both = np.stack([helper[of], donor[1, of]])
        bridged = _bridge_inner(
            rotations, translations, missing, trials, both, noise, np.full(of.size, w)
        )
        lengths = trials.lengths
        owner = np.repeat(of, lengths)
        frames = np.repeat(trials.first, lengths) + _ranks(lengths)
        truth = _relative(
            rotations,
            translations,
            np.repeat(trials.joint, lengths),
            np.stack([helper[owner], donor[1, owner]]),
            frames,
        )
        squares = (
            quat.angle_between(bridged[0], truth[0]) ** 2,
            np.sum((bridged[1] - truth[1]) ** 2, axis=-1),
        )
        tried = np.bincount(of, minlength=n_gaps) > 0
        if use == 0:
            tried &= donor[0] >= 0
        for k in range(2):
            total = np.bincount(owner, weights=squares[k], minlength=n_gaps)
            error[k, i] = np.where(tried, total, np.inf)
    weights = np.array([w for _, w in options])
    uses = np.array([u for u, _ in options])
    error[:, weights > 0] /= 1.0 - LINE_MARGIN  # the straight line wins near-ties
    # rotations: the donor and the weight together; positions: the weight, same donor
    best = np.argmin(error[0], axis=0)
    same = uses[:, None] == uses[best][None]
    position = np.argmin(np.where(same, error[1], np.inf), axis=0)
    untried = ~np.isfinite(error[0].min(axis=0))
    return (
        np.where(untried | (uses[best] == 0), donor[0], -1),
        np.where(untried, 1.0, weights[best]),
        np.where(untried, 1.0, weights[position]),
    )


def _ranks(lengths: np.ndarray) -> np.ndarray:
    """``0 .. n-1`` for each run of ``n`` in ``lengths``, end to end."""
    return np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths, lengths)


def _spread(values: np.ndarray, where: np.ndarray) -> np.ndarray:
    out = np.full((values.shape[0], where.size), -1)
    out[:, where] = values
    return out


def _bridge_inner(
    rotations, translations, missing, gaps: Gaps, donors: np.ndarray, noise, weight, weight_p=None
):
    """Relative poses across two-sided gaps, gap frames in gap order: each gap's window
    (known rows before, the gap, known rows after) laid end to end in one flat signal;
    ``weight`` (G,) scales the edge velocities' departure from the chord (:func:`_bridge`),
    ``weight_p`` the positions' (default: the same)."""
    n_frames = missing.shape[0]
    a, b = gaps.first - 1, gaps.stop
    room_a = np.minimum(_known_room(missing, gaps.joint, a, -1), EDGE_FRAMES)
    room_b = np.minimum(_known_room(missing, gaps.joint, b, +1), EDGE_FRAMES)
    start, stop = a - room_a, b + room_b + 1  # each window's frames
    sizes = stop - start
    window_of = np.repeat(np.arange(sizes.size), sizes)
    frames = np.minimum(start[window_of] + _ranks(sizes), n_frames - 1)
    rel_q, rel_p = _relative(
        rotations, translations, gaps.joint[window_of], donors[:, window_of], frames
    )
    rel_q = quat.make_continuous(rel_q, axis=0)
    base = np.cumsum(sizes) - sizes  # flat row of each window's first frame
    flat_a, flat_b = base + room_a, base + room_a + (b - a)
    lengths = gaps.lengths
    gap_of = np.repeat(np.arange(lengths.size), lengths)
    rows = flat_a[gap_of] + 1 + _ranks(lengths)
    var_q, var_p = (
        n[gaps.joint] + np.where(d >= 0, n[np.maximum(d, 0)], 0.0)
        for n, d in zip(noise, donors, strict=True)
    )
    bridged_q = _bridge(rel_q, flat_a, flat_b, room_a, room_b, rows, gap_of, True, var_q, weight)
    weight_p = weight if weight_p is None else weight_p
    bridged_p = _bridge(rel_p, flat_a, flat_b, room_a, room_b, rows, gap_of, False, var_p, weight_p)
    return bridged_q, bridged_p
