"""Foot lock: feet that stand stay planted, by the least weighted change of the leg joints.

Pure functions on arrays. Rotations are unit quaternions ``(w, x, y, z)`` (Hamilton
product, ``v' = q v q^-1``), local to the parent joint; positions are in the file's length
unit. Points are the skeleton's joints followed by its end sites (``tips``).

Per frame, :func:`plant` finds the smallest change of the joints from the root down to
each held foot point (the root's translation, every rotation on the way, the knee as a
hinge), each weighted by the error expected in it, that puts the held points on their
targets within a tolerance: the horizontal position of the ankle (and of the toes where the
foot has them) on a straight line through the contact, the height left free, but no held
point below the floor during a contact. It is a Gauss-Newton solve of

    min  sum_v |d_v|^2 / s_v^2  +  sum_r w_r (J_r d - e_r)^2 / tol^2

(``d_v`` the change of variable ``v`` as a rotation vector in world axes, radians, or a
translation; ``s_v`` its expected RMS error per component; ``e_r`` the residual of row
``r``), all frames at once. The rows are vectors of world space and the prior is isotropic
per joint, so the result turns with the clip: it is coordinate invariant.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import quat
from ..core.kinematics import depths, forward_arrays

#: Gauss-Newton iterations (the change is small: the second one leaves millimetres).
ITERATIONS = 3
#: Frames solved at a time (bounds the per-frame systems' memory).
BLOCK_FRAMES = 4096
#: A point this far below the floor (fraction of the tolerance) is on it: a sole that
#: defines the floor is not pushed by the rounding of its own height.
FLOOR_SLACK = 1e-6
#: Smallest expected error of a variable (radians, or length units for the root's
#: translation): a joint the noise model calls exact barely moves.
MIN_SIGMA = 1e-6


@dataclass(frozen=True)
class Leg:
    """One leg to plant.

    ``joints`` may turn (every joint from the root down to the deepest held point's joint,
    root first); ``knee`` turns only about ``hinge`` (unit, in the knee's parent frame);
    ``points`` are held, the ankle first, then the toes (joints or end sites).
    """

    joints: tuple[int, ...]
    knee: int
    hinge: np.ndarray
    points: tuple[int, ...]


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
    index = np.arange(n)
    last_in = np.maximum.accumulate(np.where(contacts, index, -1))
    next_in = np.minimum.accumulate(np.where(contacts, index, n)[::-1])[::-1]
    width = max(float(blend_frames), 1.0)

    def ease(distance: np.ndarray) -> np.ndarray:
        x = np.clip(1.0 - distance / (width + 1.0), 0.0, 1.0)
        return x * x * (3.0 - 2.0 * x)

    w_prev = np.where(last_in >= 0, ease(index - last_in), 0.0)
    w_next = np.where(next_in < n, ease(next_in - index), 0.0)
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
class _Problem:
    """The fixed parts of a solve: variables, rows and what moves what."""

    joints: np.ndarray  # (V,) joints that turn
    hinge: np.ndarray  # (V,) bool: turns about a hinge (1 column) instead of freely (3)
    hinges: np.ndarray  # (V, 3) hinge axis in the parent's frame (unused for free joints)
    columns: np.ndarray  # (V,) first column of each joint's change
    axes: np.ndarray  # (T,) root translation axes that move
    n_columns: int
    prior: np.ndarray  # (n_columns,) 1 / expected variance of each column
    points: np.ndarray  # (K,) held points (joints, then end sites)
    point_joint: np.ndarray  # (K,) the joint each point hangs on (itself for a joint)
    point_leg: np.ndarray  # (K,) leg of each point
    toe: np.ndarray  # (K,) bool: not the ankle
    moves: np.ndarray  # (K, V) bool: joint v's rotation moves point k


def _problem(legs: list[Leg], parents: np.ndarray, tips: list[int], prior: Prior) -> _Problem:
    """The variables, rows and lever structure of planting ``legs``."""
    depth = depths(parents)
    used = sorted({j for leg in legs for j in leg.joints}, key=lambda j: (depth[j], j))
    knees = {leg.knee: leg.hinge for leg in legs}
    hinge = np.array([j in knees for j in used], dtype=bool)
    axes = np.flatnonzero(prior.root > 0.0)
    widths = np.where(hinge, 1, 3)
    columns = axes.size + np.concatenate([[0], np.cumsum(widths)[:-1]]).astype(np.intp)
    variance = (
        np.concatenate([prior.root[axes] ** 2, np.repeat(prior.sigma[used] ** 2, widths)]) / 3.0
    )  # per component of a 3-D error
    points = np.array([p for leg in legs for p in leg.points], dtype=np.intp)
    n_joints = len(parents)
    tip_joints = np.array(tips, dtype=np.intp)
    point_joint = np.where(
        points < n_joints, points, tip_joints[np.maximum(points - n_joints, 0)] if tips else points
    )
    rank = {j: v for v, j in enumerate(used)}
    moves = np.zeros((points.size, len(used)), dtype=bool)
    for k, (point, joint) in enumerate(zip(points.tolist(), point_joint.tolist(), strict=True)):
        j = joint if point >= n_joints else int(parents[joint])
        while j >= 0:  # the joints above the point (and its own, for an end site)
            if j in rank:
                moves[k, rank[j]] = True
            j = int(parents[j])
    return _Problem(
        joints=np.array(used, dtype=np.intp),
        hinge=hinge,
        hinges=np.array([knees.get(j, np.zeros(3)) for j in used]).reshape(-1, 3),
        columns=columns,
        axes=axes,
        n_columns=int(axes.size + widths.sum()),
        prior=1.0 / np.maximum(variance, MIN_SIGMA**2),
        points=points,
        point_joint=point_joint,
        point_leg=np.array([k for k, leg in enumerate(legs) for _ in leg.points], dtype=np.intp),
        toe=np.array([i > 0 for leg in legs for i in range(len(leg.points))], dtype=bool),
        moves=moves,
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
    toe_tolerance: float = 2.0,
    robust: float = 3.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations ``(F, J, 4)`` and root translations ``(F, 3)`` with every leg planted
    during its ``contacts`` ``(F, n_legs)``.

    ``translations`` ``(F, J, 3)`` are the local translations (offsets where a joint has
    no position channel, :func:`motionclean.core.kinematics.local_translations`);
    ``tips`` joint -> end-site offset; ``up`` the up axis (0, 1, 2); ``floor`` ``(n, d)``:
    a point ``p`` is below the floor where ``n . p < d``; ``tolerance`` (length units) how
    closely the ankle follows its target (the toes ``toe_tolerance`` times as loosely,
    during contacts only: they roll off the ground); a target further from a point than
    ``robust`` times the error the prior predicts for it is taken as motion, not noise, and
    followed less (Huber weights). Frames where no leg is locked, and every joint that no
    leg turns, are returned bit for bit; the root (the first joint of the legs) moves only
    along ``prior.root``'s non-zero axes.
    """
    out_q = rotations.copy()
    root = legs[0].knee if legs else 0
    while parents[root] >= 0:
        root = int(parents[root])
    out_t = translations[:, root].copy()
    if not legs:
        return out_q, out_t
    tip_joints = sorted(tips)
    problem = _problem(legs, parents, tip_joints, prior)
    tip_offsets = np.array([tips[j] for j in tip_joints], dtype=np.float64).reshape(-1, 3)
    start_points = _points(*forward_arrays(parents, rotations, translations), problem, tip_offsets)
    targets = np.empty_like(start_points)
    weights = np.zeros((len(rotations), len(legs)))
    for k in range(len(legs)):  # a leg at a time: its points' targets, vectorised
        mine = problem.point_leg == k
        targets[:, mine], weights[:, k] = lock_targets(
            start_points[:, mine], contacts[:, k], blend_frames, hold_frames
        )
    rows = np.flatnonzero((weights > 0.0).any(axis=1))
    for at in range(0, rows.size, BLOCK_FRAMES):
        block = rows[at : at + BLOCK_FRAMES]
        q, t = _solve(
            rotations[block],
            translations[block],
            parents,
            problem,
            tip_offsets,
            targets[block],
            weights[block],
            contacts[block],
            up,
            floor,
            tolerance,
            toe_tolerance,
            robust,
            root,
        )
        same = np.sum(q * rotations[block], axis=-1, keepdims=True) >= 0.0
        out_q[block] = np.where(same, q, -q)
        out_t[block] = t[:, root]
    return out_q, out_t


def _points(
    positions: np.ndarray, world: np.ndarray, problem: _Problem, tip_offsets: np.ndarray
) -> np.ndarray:
    """``(F, K, 3)`` world positions of the held points from joint positions and world
    rotations ``(F, J, ...)``."""
    n_joints = positions.shape[1]
    out = positions[:, problem.point_joint].copy()
    tip = problem.points >= n_joints
    if tip.any():
        offsets = tip_offsets[problem.points[tip] - n_joints]
        out[:, tip] += quat.rotate(world[:, problem.point_joint[tip]], offsets)
    return out


def _solve(
    rotations: np.ndarray,
    translations: np.ndarray,
    parents: np.ndarray,
    problem: _Problem,
    tip_offsets: np.ndarray,
    targets: np.ndarray,
    weights: np.ndarray,
    contacts: np.ndarray,
    up: int,
    floor: tuple[np.ndarray, float],
    tolerance: float,
    toe_tolerance: float,
    robust: float,
    root: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The Gauss-Newton solve of :func:`plant` on a block of frames that all lock a leg."""
    q, t = rotations.copy(), translations.copy()
    normal, level = floor
    directions = np.stack([np.eye(3)[a] for a in range(3) if a != up] + [normal])  # (3, 3)
    n_frames, n_points = targets.shape[:2]
    leg_weight = weights[:, problem.point_leg]  # (F, K)
    in_contact = contacts[:, problem.point_leg]
    # horizontal rows: the ankle on its eased target, the toes during contacts only
    horizontal = np.where(problem.toe, in_contact, leg_weight > 0.0)
    # precision of each row: toes looser along the ground, the floor as tight as the ankle
    scale = np.repeat(np.where(problem.toe, toe_tolerance**-2, 1.0)[:, None], 3, axis=1)
    scale[:, 2] = 1.0
    scale = scale.ravel() / tolerance**2
    total = np.zeros((n_frames, problem.n_columns))
    huber = None
    below = np.zeros((n_frames, n_points), dtype=bool)
    free = ~problem.hinge
    for _ in range(ITERATIONS):
        positions, world = forward_arrays(parents, q, t)
        points = _points(positions, world, problem, tip_offsets)  # (F, K, 3)
        jac = _jacobian(positions, world, points, parents, problem, directions)
        residual = np.einsum("fkc,dc->fkd", targets - points, directions)  # (F, K, 3)
        height = points @ normal - level
        # a point found below the floor is held on it from then on (the active set only
        # grows: it cannot flip back and forth between iterations)
        below = below | ((height < -FLOOR_SLACK * tolerance) & in_contact)
        residual[..., 2] = np.where(below, -height, 0.0)
        active = np.concatenate(
            [np.repeat(horizontal[..., None], 2, axis=-1), below[..., None]], axis=-1
        ).astype(np.float64)
        jac = jac.reshape(n_frames, n_points * 3, problem.n_columns)
        residual = residual.reshape(n_frames, -1)
        spread = 1.0 / problem.prior  # each column's expected variance
        if huber is None:  # from the input: a target far beyond the noise is motion
            predicted = np.sqrt((jac * jac) @ spread)
            # per point, along the ground (a sum over both horizontal rows: invariant)
            spread_h = np.sqrt(np.sum(predicted.reshape(n_frames, n_points, 3)[..., :2] ** 2, -1))
            off = np.sqrt(np.sum(residual.reshape(n_frames, n_points, 3)[..., :2] ** 2, -1))
            weight = np.ones((n_frames, n_points, 3))  # the floor rows keep 1: no guess
            weight[..., :2] = np.minimum(1.0, robust * spread_h / np.maximum(off, 1e-300))[
                ..., None
            ]
            huber = weight.reshape(n_frames, -1)
        root_precision = np.sqrt(active.reshape(n_frames, -1) * huber * scale)
        # the solve in the rows' space (at most 3 per held point, fewer than the columns):
        # z = P^-1 A^T (I + A P^-1 A^T)^-1 b with A = sqrt(M) J, b = sqrt(M) (e + J total)
        rows = jac * root_precision[..., None]
        spread_rows = rows * spread
        gram = spread_rows @ rows.transpose(0, 2, 1)
        gram[:, np.arange(gram.shape[1]), np.arange(gram.shape[1])] += 1.0
        target = root_precision * (residual + (jac @ total[..., None])[..., 0])
        mixed = np.linalg.solve(gram, target[..., None])
        step = (spread_rows.transpose(0, 2, 1) @ mixed)[..., 0] - total
        total += step
        t[:, root, problem.axes] += step[:, : problem.axes.size]
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
        q[:, problem.joints] = quat.normalize(
            quat.multiply(quat.exp(0.5 * change), q[:, problem.joints])
        )
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
