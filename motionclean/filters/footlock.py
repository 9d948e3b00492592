"""Foot lock: hold each foot where it stands during ground contacts, by two-bone leg IK.

Pure functions on arrays. World positions ``(F, P, 3)`` and world rotations ``(F, J, 4)``
come from :func:`motionclean.core.kinematics.forward`; rotations are unit quaternions
``(w, x, y, z)`` (Hamilton product, ``v' = q v q^-1``). Only the hip, knee and ankle local
rotations of a leg change, and only on frames where its lock weight is positive; every other
value is returned bit for bit.
"""

from __future__ import annotations

import numpy as np

from ..core import quat
from ..core.contacts import Foot

#: The leg never straightens past this fraction of its length (keeps the knee bendable).
MAX_REACH = 0.9999


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(norm > 0.0, norm, 1.0), norm[..., 0]


def _between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Shortest-arc rotation taking direction ``u`` to direction ``v`` (both ``(..., 3)``)."""
    u, _ = _unit(u)
    v, _ = _unit(v)
    q = np.concatenate([1.0 + np.sum(u * v, axis=-1, keepdims=True), np.cross(u, v)], axis=-1)
    return quat.normalize(q)


def _bend_axes(hip: np.ndarray, knee: np.ndarray, ankle: np.ndarray, hip_world: np.ndarray):
    """Unit normal of each frame's leg plane ``(F, 3)``.

    Where the leg is straight the plane is undefined: the normal of the nearest frame with a
    bent knee is used, carried in the hip's frame so it turns with the thigh; a leg straight
    on every frame bends about an axis perpendicular to it.
    """
    thigh = knee - hip
    normal, size = _unit(np.cross(thigh, ankle - knee))
    bent = size > 1e-6 * np.sum(thigh * thigh, axis=-1)
    if bent.all():
        return normal
    n = len(normal)
    if not bent.any():
        side = np.cross(thigh, np.eye(3)[np.argmin(np.abs(thigh), axis=-1)])
        return _unit(side)[0]
    local = quat.rotate(quat.conjugate(hip_world), normal)
    index = np.arange(n)
    before = np.maximum.accumulate(np.where(bent, index, -1))
    after = np.minimum.accumulate(np.where(bent, index, n)[::-1])[::-1]
    use_before = (before >= 0) & ((after >= n) | (index - before <= after - index))
    source = np.where(use_before, before, after)
    carried = quat.rotate(hip_world, local[source])
    return np.where(bent[:, None], normal, _unit(carried)[0])


def two_bone_ik(
    hip: np.ndarray,
    knee: np.ndarray,
    ankle: np.ndarray,
    target: np.ndarray,
    hip_world: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """World rotation deltas at the hip and the knee that put the ankle on ``target``.

    ``hip``, ``knee``, ``ankle``, ``target`` are world positions ``(F, 3)``; ``hip_world`` the
    hip joint's world rotations ``(F, 4)``. Returns ``(hip_delta, knee_delta)`` ``(F, 4)``:
    rotating the shin about the knee by ``knee_delta`` and then the whole leg about the hip by
    ``hip_delta`` moves the ankle exactly onto ``target`` when it is reachable; otherwise onto
    the nearest reachable point on the line from the hip to the target (reach clamped between
    ``|thigh - shin|`` and ``MAX_REACH`` of ``thigh + shin``). The knee bends in its current
    plane (law of cosines), then the leg swings by the shortest arc.
    """
    thigh, l1 = _unit(knee - hip)
    shin, l2 = _unit(ankle - knee)
    _, reach = _unit(target - hip)
    reach = np.clip(reach, np.abs(l1 - l2) * (1.0 + 1e-9), MAX_REACH * (l1 + l2))
    bend_now = np.arctan2(
        np.linalg.norm(np.cross(thigh, shin), axis=-1), np.sum(thigh * shin, axis=-1)
    )
    cos_inner = (l1 * l1 + l2 * l2 - reach * reach) / (2.0 * l1 * l2)
    bend_new = np.pi - np.arccos(np.clip(cos_inner, -1.0, 1.0))
    axis = _bend_axes(hip, knee, ankle, hip_world)
    knee_delta = quat.from_axis_angle(axis, bend_new - bend_now)
    bent_ankle = knee + quat.rotate(knee_delta, ankle - knee)
    hip_delta = _between(bent_ankle - hip, target - hip)
    return hip_delta, knee_delta


def _window_sums(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Sums of ``x`` over the frame windows ``lo[i] .. hi[i]-1`` (cumulative sums)."""
    total = np.concatenate([np.zeros((1, *x.shape[1:])), np.cumsum(x, axis=0)])
    return total[hi] - total[lo]


def held_positions(ankle: np.ndarray, contacts: np.ndarray, hold_frames: float) -> np.ndarray:
    """``(F, 3)``: on contact frames, the ankle's least-squares straight line through a
    window of ``hold_frames`` frames centred on the frame and cut to its contact, evaluated
    at the frame; elsewhere the ankle itself.

    Jitter and the sliding it causes are removed while a slow, steady drift of the capture
    (a pivot, a deliberate slide) is kept; with ``hold_frames`` at least the contact's
    length the whole contact follows one line (``inf``: the foot held still at the mean).
    """
    n = len(ankle)
    index = np.arange(n)
    starts = contacts & ~np.r_[False, contacts[:-1]]
    ends = contacts & ~np.r_[contacts[1:], False]
    first = np.maximum.accumulate(np.where(starts, index, 0))
    last = np.minimum.accumulate(np.where(ends, index, n)[::-1])[::-1]
    inside = contacts
    if not np.isfinite(hold_frames):  # held still: the contact's mean position
        lo, hi = np.where(inside, first, 0), np.where(inside, last + 1, 1)
        mean = _window_sums(ankle, lo, hi) / (hi - lo)[:, None]
        return np.where(inside[:, None], mean, ankle)
    half = int(min(hold_frames, 2 * n) // 2)
    lo = np.where(inside, np.maximum(first, index - half), 0)
    hi = np.where(inside, np.minimum(last, index + half) + 1, 1)
    t = (index - index[0]).astype(np.float64)
    count = (hi - lo).astype(np.float64)
    t_mean = _window_sums(t, lo, hi) / count
    p_mean = _window_sums(ankle, lo, hi) / count[:, None]
    t_var = _window_sums(t * t, lo, hi) / count - t_mean**2
    cov = _window_sums(t[:, None] * ankle, lo, hi) / count[:, None] - t_mean[:, None] * p_mean
    slope = np.where(t_var[:, None] > 1e-9, cov / np.maximum(t_var, 1e-9)[:, None], 0.0)
    line = p_mean + slope * (t - t_mean)[:, None]
    return np.where(inside[:, None], line, ankle)


def lock_targets(
    ankle: np.ndarray, contacts: np.ndarray, blend_frames: float, hold_frames: float = np.inf
) -> tuple[np.ndarray, np.ndarray]:
    """Where one ankle should be on each frame, and how strongly: ``(F, 3)`` and ``(F,)``.

    During a contact the target is :func:`held_positions` with weight 1. Within
    ``blend_frames`` frames before a contact starts or after it ends, the weight eases from
    0 to 1 (smoothstep) toward the contact's first or last target; when the ramps of two
    contacts overlap, the target is their weighted mean. Weight 0 elsewhere.
    """
    n = len(ankle)
    weight = np.zeros(n)
    if not contacts.any():
        return ankle.copy(), weight
    held = held_positions(ankle, contacts, hold_frames)
    index = np.arange(n)
    last_in = np.maximum.accumulate(np.where(contacts, index, -1))
    next_in = np.minimum.accumulate(np.where(contacts, index, n)[::-1])[::-1]
    width = max(float(blend_frames), 1.0)

    def ease(distance: np.ndarray) -> np.ndarray:
        x = np.clip(1.0 - distance / (width + 1.0), 0.0, 1.0)
        return x * x * (3.0 - 2.0 * x)

    w_prev = np.where(last_in >= 0, ease(index - last_in), 0.0)
    w_next = np.where(next_in < n, ease(next_in - index), 0.0)
    lock_prev = held[last_in.clip(0, n - 1)]
    lock_next = held[next_in.clip(0, n - 1)]
    total = w_prev + w_next
    outside = np.where(
        (total > 1.0)[:, None],
        (w_prev[:, None] * lock_prev + w_next[:, None] * lock_next)
        / np.maximum(total, 1e-300)[:, None],
        ankle + w_prev[:, None] * (lock_prev - ankle) + w_next[:, None] * (lock_next - ankle),
    )
    target = np.where(contacts[:, None], held, outside)
    weight = np.where(contacts, 1.0, np.minimum(total, 1.0))
    return target, weight


def lock_feet(
    local: np.ndarray,
    parents: np.ndarray,
    positions: np.ndarray,
    world: np.ndarray,
    feet: list[Foot],
    contacts: np.ndarray,
    blend_frames: float,
    up: int | None = None,
    hold_frames: float = np.inf,
) -> np.ndarray:
    """Local rotations ``(F, J, 4)`` with every foot held during its contacts.

    With ``up`` (0, 1, 2) only the horizontal position is held and the ankle keeps its
    height from the input (the heel rises as it rolls off; only sliding is removed).

    ``local`` are the joints' local rotations, ``positions`` ``(F, P, 3)`` and ``world``
    ``(F, J, 4)`` their world positions and rotations, ``contacts`` ``(F, n_feet)``. Each leg's
    hip and knee turn by :func:`two_bone_ik` toward the :func:`lock_targets` of its ankle; the
    ankle's local rotation compensates so the foot keeps its world orientation (toes and heel
    follow rigidly). Frames of weight 0 are returned unchanged, bit for bit.
    """
    out = local.copy()
    for k, foot in enumerate(feet):  # one vectorised solve per leg
        target, weight = lock_targets(
            positions[:, foot.ankle], contacts[:, k], blend_frames, hold_frames
        )
        if up is not None:
            target[:, up] = positions[:, foot.ankle, up]
        rows = np.flatnonzero(weight > 0.0)
        if rows.size == 0:
            continue
        hip_world = world[rows, foot.hip]
        hip_delta, knee_delta = two_bone_ik(
            positions[rows, foot.hip],
            positions[rows, foot.knee],
            positions[rows, foot.ankle],
            target[rows],
            hip_world,
        )
        parent = parents[foot.hip]
        parent_world = world[rows, parent] if parent >= 0 else quat.identity((rows.size,))
        knee_world = world[rows, foot.knee]
        new_hip_world = quat.multiply(hip_delta, hip_world)
        new_knee_world = quat.multiply(hip_delta, quat.multiply(knee_delta, knee_world))
        hip_local = quat.relative(parent_world, new_hip_world)
        knee_local = quat.relative(new_hip_world, new_knee_world)
        ankle_local = quat.relative(new_knee_world, world[rows, foot.ankle])
        for joint, value in (
            (foot.hip, hip_local),
            (foot.knee, knee_local),
            (foot.ankle, ankle_local),
        ):
            # keep each signal sign-continuous with the frame it replaces
            same = np.sum(value * local[rows, joint], axis=-1, keepdims=True) >= 0.0
            out[rows, joint] = quat.normalize(np.where(same, value, -value))
    return out
