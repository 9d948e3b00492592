"""Foot lock: feet that stand stay planted, by the least weighted change of the leg joints.

Pure functions on arrays. Rotations are unit quaternions ``(w, x, y, z)`` (Hamilton
product, ``v' = q v q^-1``), local to the parent joint; positions are in the file's length
unit. Points are the skeleton's joints followed by its end sites (``tips``).

Per frame, :func:`plant` finds the smallest change of the joints from the root down to
the knee (the root's translation, every rotation on the way, the knee as a hinge), each
weighted by the error expected in it, that puts the ankle on its target within a
tolerance: its horizontal position on a straight line through the contact, the height left
free, but not below the floor during a contact. Then, where the foot has toes, the
smallest change of the ankle's own rotation (and of the toe joints) that holds each toe
point on its own line while that point is planted: the ankle stays where the first solve
put it, so the hip and knee keep their change. Each is a Gauss-Newton solve of

    min  sum_v |d_v|^2 / s_v^2  +  sum_r w_r (J_r d - e_r)^2 / tol^2

(``d_v`` the change of variable ``v`` as a rotation vector in world axes, radians, or a
translation; ``s_v`` its expected RMS error per component; ``e_r`` the residual of row
``r``), all frames at once. The rows are vectors of world space and the prior is isotropic
per joint, so the result turns with the clip: it is coordinate invariant.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..core import quat
from ..core.kinematics import depths, forward_arrays

#: Gauss-Newton iterations (the change is small: the second one leaves millimetres).
ITERATIONS = 3
#: ... and of the toes' solve (its levers are short and its start close: one more finds a
#: toe the first put below the floor).
TOE_ITERATIONS = 2
#: Frames solved at a time (bounds the per-frame systems' memory).
BLOCK_FRAMES = 4096
#: A point this far below the floor (fraction of the tolerance) is on it: a sole that
#: defines the floor is not pushed by the rounding of its own height.
FLOOR_SLACK = 1e-6
#: The toes keep above the floor within this fraction of the ankle's tolerance: the foot's
#: short levers would otherwise trade a toe under the floor against its rotation's change.
FLOOR_FIRMNESS = 0.01
#: Smallest expected error of a variable (radians, or length units for the root's
#: translation): a joint the noise model calls exact barely moves.
MIN_SIGMA = 1e-6


@dataclass(frozen=True)
class Leg:
    """One leg to plant.

    ``joints`` may turn to hold the ankle (from the root down to the knee, root first);
    ``knee`` turns only about ``hinge`` (unit, in the knee's parent frame); ``points`` are
    the ankle, then the toe points (joints or end sites below it); ``foot`` may turn to
    hold the toes (the ankle and joints below it; none: the toes are not held and the
    ankle keeps its own rotation).
    """

    joints: tuple[int, ...]
    knee: int
    hinge: np.ndarray
    points: tuple[int, ...]
    foot: tuple[int, ...] = ()


@dataclass(frozen=True)
class Prior:
    """What each variable may move: ``sigma`` ``(J,)`` the expected RMS rotation error per
    joint (radians of rotation angle; 0 for a joint that does not move) and ``root``
    ``(3,)`` the root translation's expected RMS error along each axis (length units; 0
    for an axis without a position channel)."""

    sigma: np.ndarray
    root: np.ndarray


def hinge_axis(knee: np.ndarray) -> np.ndarray:
    """The axis ``(3,)`` a knee bends about, in its parent's frame: the principal axis of
    the rotation vectors of its local rotations ``(F, 4)`` relative to their mean.
    Coordinate invariant; defined where the leg is straight too."""
    q = quat.continuous(knee)
    mean = q.sum(axis=0)
    mean /= max(float(np.linalg.norm(mean)), 1e-300)
    v = quat.log(quat.multiply(q, quat.conjugate(mean)))
    _, vectors = np.linalg.eigh(v.T @ v)
    return vectors[:, -1]


def _window_sums(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Sums of ``x`` over the frame windows ``lo[i] .. hi[i]-1`` (cumulative sums)."""
    total = np.concatenate([np.zeros((1, *x.shape[1:])), np.cumsum(x, axis=0)])
    return total[hi] - total[lo]


def held_lines(points: np.ndarray, contacts: np.ndarray, hold_frames: float) -> np.ndarray:
    """``(F, ..., 3)``: on contact frames, the least-squares straight line of ``points``
    through a window of ``hold_frames`` frames centred on the frame and cut to its contact,
    evaluated at the frame (``inf``: the contact's mean); elsewhere the points themselves.

    Jitter and the sliding it causes go; a slow, steady drift (a pivot) stays.
    """
    n = len(points)
    index = np.arange(n)
    starts = contacts & ~np.r_[False, contacts[:-1]]
    ends = contacts & ~np.r_[contacts[1:], False]
    first = np.maximum.accumulate(np.where(starts, index, 0))
    last = np.minimum.accumulate(np.where(ends, index, n)[::-1])[::-1]
    shape = (-1,) + (1,) * (points.ndim - 1)
    if not np.isfinite(hold_frames):  # held still: the contact's mean position
        lo, hi = np.where(contacts, first, 0), np.where(contacts, last + 1, 1)
        mean = _window_sums(points, lo, hi) / (hi - lo).reshape(shape)
        return np.where(contacts.reshape(shape), mean, points)
    half = int(min(hold_frames, 2 * n) // 2)
    lo = np.where(contacts, np.maximum(first, index - half), 0)
    hi = np.where(contacts, np.minimum(last, index + half) + 1, 1)
    t = (index - index[0]).astype(np.float64)
    count = (hi - lo).astype(np.float64)
    t_mean = _window_sums(t, lo, hi) / count
    p_mean = _window_sums(points, lo, hi) / count.reshape(shape)
    t_var = _window_sums(t * t, lo, hi) / count - t_mean**2
    cov = _window_sums(t.reshape(shape) * points, lo, hi) / count.reshape(shape)
    cov -= t_mean.reshape(shape) * p_mean
    steady = (t_var > 1e-9).reshape(shape)
    slope = np.where(steady, cov / np.maximum(t_var, 1e-9).reshape(shape), 0.0)
    line = p_mean + slope * (t - t_mean).reshape(shape)
    return np.where(contacts.reshape(shape), line, points)


def _eases(
    contacts: np.ndarray, blend_frames: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per frame ``(F,)``: the last contact frame at or before it (-1: none), the next at
    or after it (F: none), and the smoothstep weights easing out of the one and into the
    other over ``blend_frames`` frames."""
    n = len(contacts)
    index = np.arange(n)
    last_in = np.maximum.accumulate(np.where(contacts, index, -1))
    next_in = np.minimum.accumulate(np.where(contacts, index, n)[::-1])[::-1]
    width = max(float(blend_frames), 1.0)

    def ease(distance: np.ndarray) -> np.ndarray:
        x = np.clip(1.0 - distance / (width + 1.0), 0.0, 1.0)
        return x * x * (3.0 - 2.0 * x)

    w_prev = np.where(last_in >= 0, ease(index - last_in), 0.0)
    w_next = np.where(next_in < n, ease(next_in - index), 0.0)
    return last_in, next_in, w_prev, w_next


def lock_weights(contacts: np.ndarray, blend_frames: float) -> np.ndarray:
    """``(F,)``: the weight :func:`lock_targets` gives each frame (1 in a contact, easing
    to 0 over ``blend_frames`` frames either side of it)."""
    _, _, w_prev, w_next = _eases(contacts, blend_frames)
    return np.where(contacts, 1.0, np.minimum(w_prev + w_next, 1.0))


def lock_targets(
    points: np.ndarray, contacts: np.ndarray, blend_frames: float, hold_frames: float = np.inf
) -> tuple[np.ndarray, np.ndarray]:
    """Where one foot's points ``(F, k, 3)`` should be on each frame, and how strongly:
    ``(F, k, 3)`` and ``(F,)``.

    During a contact the target is :func:`held_lines` with weight 1. Within
    ``blend_frames`` frames before a contact starts or after it ends, the weight eases from
    0 to 1 (smoothstep) and the target moves from the points toward the contact's first or
    last target; where the ramps of two contacts overlap, the target is their weighted
    mean. Weight 0 elsewhere.
    """
    n = len(points)
    if not contacts.any():
        return points.copy(), np.zeros(n)
    held = held_lines(points, contacts, hold_frames)
    last_in, next_in, w_prev, w_next = _eases(contacts, blend_frames)
    total = w_prev + w_next
    shape = (-1,) + (1,) * (points.ndim - 1)
    wp, wn = w_prev.reshape(shape), w_next.reshape(shape)
    lock_prev = held[last_in.clip(0, n - 1)]
    lock_next = held[next_in.clip(0, n - 1)]
    outside = np.where(
        (total > 1.0).reshape(shape),
        (wp * lock_prev + wn * lock_next) / np.maximum(total, 1e-300).reshape(shape),
        points + wp * (lock_prev - points) + wn * (lock_next - points),
    )
    target = np.where(contacts.reshape(shape), held, outside)
    return target, np.where(contacts, 1.0, np.minimum(total, 1.0))


@dataclass(frozen=True)
class _Part:
    """The joints of a skeleton that a solve needs, as a skeleton of their own.

    ``index`` ``(Jc,)`` the joints (ascending, so parents come first), ``parents`` theirs
    within the part (-1 for a root of the part), ``mounted`` the part roots that hang on
    a joint outside the part (they are placed by their world transform), ``tips`` the
    part joints with an end site (ascending) and ``tip_offsets`` their offsets. The part's
    points are its joints, then those end sites.
    """

    index: np.ndarray
    parents: np.ndarray
    mounted: np.ndarray
    tips: np.ndarray
    tip_offsets: np.ndarray

    @classmethod
    def of(
        cls, parents: np.ndarray, tips: dict[int, np.ndarray], joints: set[int], cut: set[int]
    ) -> _Part:
        """``joints`` and every joint above them, up to a root or to a joint of ``cut``
        (which becomes a mounted root)."""
        keep: set[int] = set()
        for joint in joints:
            j = joint
            while j >= 0 and j not in keep:
                keep.add(j)
                j = -1 if j in cut else int(parents[j])
        index = np.array(sorted(keep), dtype=np.intp)
        rank = {j: c for c, j in enumerate(index.tolist())}
        local = np.array(
            [-1 if j in cut else rank.get(int(parents[j]), -1) for j in index.tolist()],
            dtype=np.intp,
        )
        tip_joints = [j for j in sorted(tips) if j in rank]
        return cls(
            index=index,
            parents=local,
            mounted=np.flatnonzero((local < 0) & (parents[index] >= 0)),
            tips=np.array([rank[j] for j in tip_joints], dtype=np.intp),
            tip_offsets=np.array([tips[j] for j in tip_joints], dtype=np.float64).reshape(-1, 3),
        )

    def point(self, point: int, n_joints: int, tip_joints: list[int]) -> int:
        """The part's number of a point of the whole skeleton (``n_joints`` joints, then
        end sites on ``tip_joints``, ascending)."""
        if point < n_joints:
            return int(np.searchsorted(self.index, point))
        joint = int(np.searchsorted(self.index, tip_joints[point - n_joints]))
        return self.index.size + int(np.searchsorted(self.tips, joint))

    def arrays(
        self,
        rotations: np.ndarray,
        translations: np.ndarray,
        mounts: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The part's local rotations and translations ``(F, Jc, ...)`` taken from the
        whole skeleton's ``(F, J, ...)``; ``mounts``: the world rotations ``(F, M, 4)`` of
        the mounted roots' parents and the roots' world positions ``(F, M, 3)``."""
        q, t = rotations[:, self.index], translations[:, self.index]
        if self.mounted.size:
            assert mounts is not None
            q[:, self.mounted] = quat.multiply(mounts[0], q[:, self.mounted])
            t[:, self.mounted] = mounts[1]
        return q, t

    def local(self, q: np.ndarray, mounts: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
        """The whole skeleton's local rotations of the part's joints from the part's own
        ``(F, Jc, 4)`` (undoing :meth:`arrays`' mounting)."""
        if self.mounted.size:
            assert mounts is not None
            q = q.copy()
            q[:, self.mounted] = quat.multiply(quat.conjugate(mounts[0]), q[:, self.mounted])
        return q


@dataclass(frozen=True)
class _Problem:
    """The fixed parts of a solve on a part: variables, held points and what moves what."""

    joints: np.ndarray  # (V,) part joints that turn
    hinge: np.ndarray  # (V,) bool: turns about a hinge (1 column) instead of freely (3)
    hinges: np.ndarray  # (V, 3) hinge axis in the parent's frame (unused for free joints)
    columns: np.ndarray  # (V,) first column of each joint's change
    axes: np.ndarray  # (T,) root translation axes that move
    n_columns: int
    prior: np.ndarray  # (n_columns,) 1 / expected variance of each column
    points: np.ndarray  # (K,) held points of the part (joints, then end sites)
    point_joint: np.ndarray  # (K,) the part joint each point hangs on (itself for a joint)
    moves: np.ndarray  # (K, V) bool: joint v's rotation moves point k


def _problem(
    part: _Part,
    turns: set[int],
    hinges: dict[int, np.ndarray],
    points: list[int],
    sigma: np.ndarray,
    root: np.ndarray,
) -> _Problem:
    """Holding the part's ``points`` by turning its joints ``turns`` (``hinges``: joint ->
    axis, for those that turn about one), each with the expected RMS error ``sigma``
    ``(Jc,)`` (radians), and moving the part's first root along the axes where ``root``
    ``(3,)`` (its expected error per axis, length units) is not 0."""
    depth = depths(part.parents)
    used = sorted(turns, key=lambda j: (depth[j], j))
    hinge = np.array([j in hinges for j in used], dtype=bool)
    axes = np.flatnonzero(root > 0.0)
    widths = np.where(hinge, 1, 3)
    columns = axes.size + np.concatenate([[0], np.cumsum(widths)[:-1]]).astype(np.intp)
    variance = (
        np.concatenate([root[axes] ** 2, np.repeat(sigma[used] ** 2, widths)]) / 3.0
    )  # per component of a 3-D error
    held = np.array(points, dtype=np.intp)
    n_joints = part.index.size
    point_joint = np.where(
        held < n_joints, held, part.tips[np.maximum(held - n_joints, 0)] if part.tips.size else 0
    )
    rank = {j: v for v, j in enumerate(used)}
    moves = np.zeros((held.size, len(used)), dtype=bool)
    for k, (point, joint) in enumerate(zip(held.tolist(), point_joint.tolist(), strict=True)):
        j = joint if point >= n_joints else int(part.parents[joint])
        while j >= 0:  # the joints above the point (and its own, for an end site)
            if j in rank:
                moves[k, rank[j]] = True
            j = int(part.parents[j])
    return _Problem(
        joints=np.array(used, dtype=np.intp),
        hinge=hinge,
        hinges=np.array([hinges.get(j, np.zeros(3)) for j in used]).reshape(-1, 3),
        columns=columns,
        axes=axes,
        n_columns=int(axes.size + widths.sum()),
        prior=1.0 / np.maximum(variance, MIN_SIGMA**2),
        points=held,
        point_joint=point_joint,
        moves=moves,
    )


@dataclass(frozen=True)
class _Rows:
    """What a solve asks of its held points, per frame ``F`` and point ``K``: the horizontal
    position on ``targets`` ``(F, K, 3)`` where ``horizontal``, within ``tolerance``
    (length units); not below the floor ``(normal, offset)`` where ``grounded``, within
    ``floor_tolerance``. ``up`` is the up axis; a target further from a point than
    ``robust`` times the error the prior predicts for it is followed less (Huber
    weights)."""

    targets: np.ndarray
    horizontal: np.ndarray
    grounded: np.ndarray
    tolerance: float
    floor_tolerance: float
    floor: tuple[np.ndarray, float]
    up: int
    robust: float

    def take(self, frames: np.ndarray | slice) -> _Rows:
        """The rows of ``frames``."""
        return replace(
            self,
            targets=self.targets[frames],
            horizontal=self.horizontal[frames],
            grounded=self.grounded[frames],
        )


def plant(
    rotations: np.ndarray,
    translations: np.ndarray,
    parents: np.ndarray,
    tips: dict[int, np.ndarray],
    legs: list[Leg],
    contacts: np.ndarray,
    prior: Prior,
    up: int,
    floor: tuple[np.ndarray, float],
    tolerance: float,
    blend_frames: float,
    hold_frames: float = np.inf,
    toe_contacts: np.ndarray | None = None,
    toe_tolerance: float = 2.0,
    robust: float = 3.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations ``(F, J, 4)`` and root translations ``(F, 3)`` with every leg planted
    during its ``contacts`` ``(F, n_legs)``, and the toes of each leg with a ``foot`` held
    during ``toe_contacts`` ``(F, n_toes)`` (a column per toe point of those legs, in
    order; default: their leg's contacts).

    ``translations`` ``(F, J, 3)`` are the local translations (offsets where a joint has
    no position channel, :func:`motionclean.core.kinematics.local_translations`);
    ``tips`` joint -> end-site offset; ``up`` the up axis (0, 1, 2); ``floor`` ``(n, d)``:
    a point ``p`` is below the floor where ``n . p < d``; ``tolerance`` (length units) how
    closely the ankle follows its target and keeps above the floor (the toes follow theirs
    ``toe_tolerance`` times as loosely, and keep above the floor :data:`FLOOR_FIRMNESS`
    times as closely, while their leg or the toe itself is in contact); a target further
    from a point than ``robust`` times the error the prior predicts for it is taken as
    motion, not noise, and followed less (Huber weights). Frames where nothing is held, and
    every joint that does not turn, are returned bit for bit; the root (the first joint of
    the legs) moves only along ``prior.root``'s non-zero axes.
    """
    out_q = rotations.copy()
    root = legs[0].knee if legs else 0
    while parents[root] >= 0:
        root = int(parents[root])
    out_t = translations[:, root].copy()
    if not legs:
        return out_q, out_t
    ankles = [leg.points[0] for leg in legs]
    part = _Part.of(parents, tips, set(ankles), set())
    rank = {int(j): c for c, j in enumerate(part.index)}
    problem = _problem(
        part,
        {rank[j] for leg in legs for j in leg.joints},
        {rank[leg.knee]: leg.hinge for leg in legs},
        [rank[a] for a in ankles],
        prior.sigma[part.index],
        prior.root,
    )
    q, t = part.arrays(rotations, translations)
    start = forward_arrays(part.parents, q, t)[0][:, problem.points]
    targets = np.empty_like(start)
    weights = np.zeros(contacts.shape)
    for k in range(len(legs)):  # a leg at a time, vectorised over frames
        targets[:, k], weights[:, k] = lock_targets(
            start[:, k], contacts[:, k], blend_frames, hold_frames
        )
    rows = _Rows(targets, weights > 0.0, contacts, tolerance, tolerance, floor, up, robust)
    frames = np.flatnonzero(rows.horizontal.any(axis=1))
    q, t = _solve_frames(q[frames], t[frames], part, problem, rows.take(frames))
    out_q[frames[:, None], part.index] = _same_sign(q, rotations[frames][:, part.index])
    out_t[frames] = t[:, 0]
    held = [k for k, leg in enumerate(legs) if leg.foot and len(leg.points) > 1]
    if held:
        feet = [legs[k] for k in held]
        moved = translations.copy()
        moved[:, root] = out_t
        columns = [k for k in held for _ in legs[k].points[1:]]
        toes = contacts[:, columns] if toe_contacts is None else toe_contacts
        rows = _Rows(
            np.empty((0, 0, 3)),
            np.empty((0, 0), dtype=bool),
            toes | contacts[:, columns],
            tolerance * toe_tolerance,
            tolerance * FLOOR_FIRMNESS,
            floor,
            up,
            robust,
        )
        out_q = _hold_toes(
            out_q, moved, parents, tips, feet, toes, prior, rows, blend_frames, hold_frames
        )
    return out_q, out_t


def _same_sign(q: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """``q`` with each quaternion's sign that of ``reference`` (the same rotation)."""
    return np.where(np.sum(q * reference, axis=-1, keepdims=True) >= 0.0, q, -q)


def _hold_toes(
    rotations: np.ndarray,
    translations: np.ndarray,
    parents: np.ndarray,
    tips: dict[int, np.ndarray],
    feet: list[Leg],
    toes: np.ndarray,
    prior: Prior,
    rows: _Rows,
    blend_frames: float,
    hold_frames: float,
) -> np.ndarray:
    """``rotations`` with the toe points of ``feet`` held on their lines during ``toes``
    ``(F, n_toes)`` by the least weighted change of each foot's joints: the ankle's own
    rotation and the toe joints, the ankles left in place. ``rows.grounded`` ``(F, n_toes)``
    are the frames where each toe point must stay above the floor."""
    n_joints = len(parents)
    tip_joints = sorted(tips)
    weights = np.stack(
        [lock_weights(toes[:, k], blend_frames) for k in range(toes.shape[1])], axis=1
    )
    frames = np.flatnonzero(((weights > 0.0) | rows.grounded).any(axis=1))
    if frames.size == 0:
        return rotations
    ankles = [leg.points[0] for leg in feet]
    above = _Part.of(parents, tips, set(ankles), set())
    q, t = above.arrays(rotations[frames], translations[frames])
    positions, world = forward_arrays(above.parents, q, t)
    at = np.searchsorted(above.index, ankles)
    mounts = (world[:, above.parents[at]], positions[:, at])
    toe_points = [p for leg in feet for p in leg.points[1:]]
    hangs_on = [p if p < n_joints else tip_joints[p - n_joints] for p in toe_points]
    part = _Part.of(parents, tips, set(hangs_on), set(ankles))
    problem = _problem(
        part,
        {int(np.searchsorted(part.index, j)) for leg in feet for j in leg.foot},
        {},
        [part.point(p, n_joints, tip_joints) for p in toe_points],
        prior.sigma[part.index],
        np.zeros(3),
    )
    q, t = part.arrays(rotations[frames], translations[frames], mounts)
    start = np.zeros((len(rotations), len(toe_points), 3))  # only contact frames are read
    start[frames] = _points(*forward_arrays(part.parents, q, t), problem, part.tip_offsets)
    targets = np.empty_like(start)
    for k in range(len(toe_points)):  # a point at a time, vectorised over frames
        targets[:, k] = lock_targets(start[:, k], toes[:, k], blend_frames, hold_frames)[0]
    # solved: the frames that hold a toe, or find one below the floor where it must not be
    normal, level = rows.floor
    below = (start[frames] @ normal - level < 0.0) & rows.grounded[frames]
    asked = (weights[frames] > 0.0).any(axis=1) | below.any(axis=1)
    frames, q, t = frames[asked], q[asked], t[asked]
    mounts = (mounts[0][asked], mounts[1][asked])
    rows = replace(rows, targets=targets, horizontal=weights > 0.0).take(frames)
    solved, _ = _solve_frames(q, t, part, problem, rows, TOE_ITERATIONS)
    changed = np.any(solved != q, axis=(1, 2))  # the others are left bit for bit
    frames, solved = frames[changed], solved[changed]
    mounts = (mounts[0][changed], mounts[1][changed])
    out = rotations.copy()
    out[frames[:, None], part.index] = _same_sign(
        part.local(solved, mounts), rotations[frames][:, part.index]
    )
    return out


def _points(
    positions: np.ndarray, world: np.ndarray, problem: _Problem, tip_offsets: np.ndarray
) -> np.ndarray:
    """``(F, K, 3)`` world positions of the held points from joint positions and world
    rotations ``(F, Jc, ...)`` of a part."""
    n_joints = positions.shape[1]
    out = positions[:, problem.point_joint].copy()
    tip = problem.points >= n_joints
    if tip.any():
        offsets = tip_offsets[problem.points[tip] - n_joints]
        out[:, tip] += quat.rotate(world[:, problem.point_joint[tip]], offsets)
    return out


def _solve_frames(
    q: np.ndarray,
    t: np.ndarray,
    part: _Part,
    problem: _Problem,
    rows: _Rows,
    iterations: int = ITERATIONS,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_solve` over blocks of :data:`BLOCK_FRAMES` frames (bounds the per-frame
    systems' memory)."""
    q, t = q.copy(), t.copy()
    for at in range(0, len(q), BLOCK_FRAMES):
        block = slice(at, at + BLOCK_FRAMES)
        frames = np.arange(at, min(at + BLOCK_FRAMES, len(q)))
        q[block], t[block] = _solve(
            q[block], t[block], part, problem, rows.take(frames), iterations
        )
    return q, t


def _solve(
    rotations: np.ndarray,
    translations: np.ndarray,
    part: _Part,
    problem: _Problem,
    rows: _Rows,
    iterations: int = ITERATIONS,
) -> tuple[np.ndarray, np.ndarray]:
    """The Gauss-Newton solve of :func:`plant` on a block of frames of a part: local
    rotations and translations ``(F, Jc, ...)`` in, the same out."""
    q, t = rotations.copy(), translations.copy()
    parents = part.parents
    normal, level = rows.floor
    directions = np.stack([np.eye(3)[a] for a in range(3) if a != rows.up] + [normal])
    n_frames, n_points = rows.targets.shape[:2]
    scale = np.array([1.0, 1.0, (rows.tolerance / rows.floor_tolerance) ** 2] * n_points)
    scale /= rows.tolerance**2
    total = np.zeros((n_frames, problem.n_columns))
    huber = None
    below = np.zeros((n_frames, n_points), dtype=bool)
    free = ~problem.hinge
    spread = 1.0 / problem.prior  # each column's expected variance
    for _ in range(iterations):
        positions, world = forward_arrays(parents, q, t)
        points = _points(positions, world, problem, part.tip_offsets)  # (F, K, 3)
        jac = _jacobian(positions, world, points, parents, problem, directions)
        residual = np.einsum("fkc,dc->fkd", rows.targets - points, directions)  # (F, K, 3)
        height = points @ normal - level
        # a point found below the floor is held on it from then on (the active set only
        # grows: it cannot flip back and forth between iterations)
        below = below | ((height < -FLOOR_SLACK * rows.floor_tolerance) & rows.grounded)
        residual[..., 2] = np.where(below, -height, 0.0)
        active = np.concatenate(
            [np.repeat(rows.horizontal[..., None], 2, axis=-1), below[..., None]], axis=-1
        ).astype(np.float64)
        jac = jac.reshape(n_frames, n_points * 3, problem.n_columns)
        residual = residual.reshape(n_frames, -1)
        if huber is None:  # from the input: a target far beyond the noise is motion
            predicted = np.sqrt((jac * jac) @ spread)
            # per point, along the ground (a sum over both horizontal rows: invariant)
            spread_h = np.sqrt(np.sum(predicted.reshape(n_frames, n_points, 3)[..., :2] ** 2, -1))
            off = np.sqrt(np.sum(residual.reshape(n_frames, n_points, 3)[..., :2] ** 2, -1))
            weight = np.ones((n_frames, n_points, 3))  # the floor rows keep 1: no guess
            weight[..., :2] = np.minimum(1.0, rows.robust * spread_h / np.maximum(off, 1e-300))[
                ..., None
            ]
            huber = weight.reshape(n_frames, -1)
        root_precision = np.sqrt(active.reshape(n_frames, -1) * huber * scale)
        # the solve in the rows' space (at most 3 per held point, fewer than the columns):
        # z = P^-1 A^T (I + A P^-1 A^T)^-1 b with A = sqrt(M) J, b = sqrt(M) (e + J total)
        a = jac * root_precision[..., None]
        spread_rows = a * spread
        gram = spread_rows @ a.transpose(0, 2, 1)
        gram[:, np.arange(gram.shape[1]), np.arange(gram.shape[1])] += 1.0
        target = root_precision * (residual + (jac @ total[..., None])[..., 0])
        mixed = np.linalg.solve(gram, target[..., None])
        step = (spread_rows.transpose(0, 2, 1) @ mixed)[..., 0] - total
        total += step
        t[:, 0, problem.axes] += step[:, : problem.axes.size]
        change = np.zeros((n_frames, problem.joints.size, 3))
        starts = problem.columns
        change[:, free] = step[:, starts[free, None] + np.arange(3)]
        parent_world = np.where(
            (parents[problem.joints] >= 0)[None, :, None],
            world[:, np.maximum(parents[problem.joints], 0)],
            quat.identity(),
        )
        change[:, free] = quat.rotate(quat.conjugate(parent_world[:, free]), change[:, free])
        change[:, problem.hinge] = (
            step[:, starts[problem.hinge], None] * problem.hinges[problem.hinge]
        )
        turned = quat.normalize(quat.multiply(quat.exp(0.5 * change), q[:, problem.joints]))
        moved = np.any(step != 0.0, axis=1)[:, None, None]  # a frame nothing asks of: as it was
        q[:, problem.joints] = np.where(moved, turned, q[:, problem.joints])
    return q, t


def _jacobian(
    positions: np.ndarray,
    world: np.ndarray,
    points: np.ndarray,
    parents: np.ndarray,
    problem: _Problem,
    directions: np.ndarray,
) -> np.ndarray:
    """``(F, K, 3, C)``: how each held point moves along each row direction per column.

    A rotation ``w`` (world axes) of joint ``v`` moves a point below it by ``w x (p -
    p_v)``: along ``u`` by ``w . ((p - p_v) x u)``; a hinge's column is that along its
    world axis; a root translation column moves every point by its axis."""
    n_frames, n_points = points.shape[:2]
    jac = np.zeros((n_frames, n_points, 3, problem.n_columns))
    jac[..., : problem.axes.size] = directions[:, problem.axes][None, None]
    arm = points[:, :, None, :] - positions[:, None, problem.joints, :]  # (F, K, V, 3)
    arm *= problem.moves[None, :, :, None]
    lever = np.cross(arm[:, :, None], directions[None, None, :, None, :])  # (F, K, 3, V, 3)
    free = np.flatnonzero(~problem.hinge)
    columns = problem.columns[free, None] + np.arange(3)
    jac[..., columns.ravel()] = lever[:, :, :, free].reshape(n_frames, n_points, 3, -1)
    hinged = np.flatnonzero(problem.hinge)
    if hinged.size:
        parent = parents[problem.joints[hinged]]
        axis = quat.rotate(world[:, parent], problem.hinges[hinged])  # (F, H, 3)
        jac[..., problem.columns[hinged]] = np.einsum(
            "fkdhc,fhc->fkdh", lever[:, :, :, hinged], axis
        )
    return jac
