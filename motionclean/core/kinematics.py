"""World space: forward kinematics, end sites, the up axis and the body height.

Conventions: quaternions ``(w, x, y, z)``, Hamilton product, rotating column vectors. A
joint's local translation is its OFFSET with the axes it has position channels for replaced
by the channel values (how bvhio and most tools read BVH). Its world transform is its
parent's world transform applied to that local translation and rotation:

    R_j = R_parent q_j,    p_j = p_parent + R_parent t_j

Positions are in the file's length unit. Everything is vectorised over frames; the only
loop is over the depth of the tree (all joints of one depth at once).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from . import checks, quat
from .motion import UP_AXES, Motion, as_motion
from .restpose import rest_frames
from .tree import ancestor_jumps

__all__ = [
    "AXES",
    "CONTRADICTED_SHARE",
    "BodyParts",
    "MotionUp",
    "axis_index",
    "body_parts",
    "body_split",
    "motion_up",
    "on_all_fours",
    "up_contradiction",
    "up_direction",
    "up_name",
    "upright",
    "body_height",
    "end_effectors",
    "end_site_names",
    "forward",
    "forward_arrays",
    "hung_on",
    "local_translations",
    "point_parents",
    "reaches",
    "rest_pose",
    "rest_positions",
    "rest_rotations",
    "turned",
    "sample_poses",
    "trunk_split",
    "up_axis",
]

AXES = "xyz"


def world_note(motion: Motion) -> str | None:
    """Why ``motion`` has no world positions (its format holds no joint positions, e.g. SMPL
    parameters read without a skeleton: ``source.no_world``), or None when it has them."""
    return getattr(motion.source, "no_world", None)


def length_unit(motion: Motion | None) -> str | None:
    """The unit of the clip's lengths where its format fixes one (``"m"``: OpenSim
    coordinates, SMPL parameters; ``source.length_unit``), else None: the file's own, which
    it does not say (BVH, CSV)."""
    return getattr(getattr(motion, "source", None), "length_unit", None)


def source_notes(motion: Motion) -> tuple[str, ...]:
    """What the reader had to assume or choose (``source.notes``: a frame rate taken, one
    person of several read ...), to show beside the clip's figures."""
    return tuple(getattr(motion.source, "notes", ()))


def depths(parents: np.ndarray) -> np.ndarray:
    """Depth of every joint in the tree (0 for a root), by pointer jumping.

    Raises ValueError for a parent index out of range or a cycle.
    """
    parents = np.asarray(parents, dtype=np.intp)
    n = parents.size
    if np.any((parents < -1) | (parents >= n)):
        raise ValueError(f"parents must lie in [-1, {n - 1}]")
    depth = (parents >= 0).astype(np.intp)
    for rows, above in ancestor_jumps(parents):
        depth[rows] += depth[above]  # the right side is gathered before it is added
    return depth


def depth_levels(parents: np.ndarray) -> list[np.ndarray]:
    """Joint indices grouped by depth in the tree (roots first), each group ascending.

    Raises ValueError for a parent index out of range or a cycle.
    """
    depth = depths(parents)
    if depth.size == 0:
        return [depth]
    order = np.argsort(depth, kind="stable")
    counts = np.bincount(depth)
    return np.split(order, np.cumsum(counts)[:-1])


def forward_arrays(
    parents: np.ndarray, rotations: np.ndarray, translations: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """World positions ``(F, J, 3)`` and rotations ``(F, J, 4)`` from local ones.

    ``parents`` ``(J,)`` (-1 for a root), ``rotations`` ``(F, J, 4)`` local unit quaternions,
    ``translations`` ``(F, J, 3)`` local translations (:func:`local_translations`). Roots
    are placed by their own translation and rotation. The results are views of
    joint-major arrays.
    """
    rotations = checks.shaped(rotations, 4, "rotations", signal=True)
    translations = checks.shaped(translations, 3, "translations", signal=True)
    world_p, world_q = _forward_planes(np.asarray(parents, dtype=np.intp), rotations, translations)
    assert world_q is not None
    return world_p.transpose(2, 1, 0), world_q.transpose(2, 1, 0)


#: Frames per block times points: a block's planes stay in the processor's cache.
BLOCK_ELEMENTS = 1 << 15


def _forward_planes(
    parents: np.ndarray,
    rotations: np.ndarray,
    translations: np.ndarray,
    channel_axes: np.ndarray | None = None,
    offsets: np.ndarray | None = None,
    tips: dict[int, np.ndarray] | None = None,
    keep_rotations: bool = True,
    only: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Forward kinematics of frame-major ``rotations`` (F, J, 4) and ``translations``
    (F, J, 3) into joint-major world planes: positions (3, P, F), rotations (4, J, F) (None
    unless ``keep_rotations``).

    With ``channel_axes`` (J, 3 bools) the local translation takes ``translations`` where
    it is True and ``offsets`` (J, 3) elsewhere. ``tips`` (joint -> offset) adds end sites
    after the joints (``P = J + len(tips)``, in ascending joint order). Runs over blocks of
    frames (cache-sized, :data:`BLOCK_ELEMENTS`, with workspaces reused from block to
    block); within a block the joints are sorted by depth, so that each level of the tree is
    one contiguous run of rows computed at once from its parents' rows. ``only`` (indices
    of points) keeps the positions of those points alone, in that order; without
    ``keep_rotations`` only the joints they hang on and those above them are computed (a
    joint's transform is made of its ancestors' alone: the same values).
    """
    n_frames, n_all = rotations.shape[:2]
    tips = tips or {}
    all_tips = sorted(tips)
    tips = {j: tips[j] for j in all_tips}  # (in joint order from here on)
    depth = depths(parents)
    computed = np.arange(n_all)
    if only is not None and not keep_rotations:
        computed = hung_on(parents, all_tips, np.asarray(only, dtype=np.intp))
        kept = set(computed.tolist())
        tips = {j: tips[j] for j in all_tips if j in kept}
    n_joints = computed.size
    order = computed[np.argsort(depth[computed], kind="stable")]  # depth levels, in turn
    rank = np.full(n_all, -1, dtype=np.intp)
    rank[order] = np.arange(n_joints)
    sorted_parents = np.where(parents[order] >= 0, rank[parents[order]], -1)
    sizes = np.bincount(depth[order], minlength=1).tolist()
    tip_rows = rank[np.array(list(tips), dtype=np.intp)]
    tip_offsets = np.array(list(tips.values()), dtype=np.float64).reshape(-1, 3).T
    if channel_axes is not None and offsets is not None:
        sorted_axes, sorted_offsets = (
            channel_axes[order].T[:, :, None],
            offsets[order].T[:, :, None],
        )
        # rows with a position channel (the others are their offsets alone), their joints
        channel_rows = np.flatnonzero(channel_axes[order].any(axis=1))
        channel_joints = order[channel_rows]
    n_points = n_joints + tip_rows.size
    widest = max(*sizes, tip_rows.size)
    world_q = np.empty((4, n_joints, n_frames)) if keep_rotations else None
    stored = np.arange(n_points) if only is None else np.asarray(only, dtype=np.intp)
    world_p = np.empty((3, stored.size, n_frames))
    # p's rows of the points: joints by rank, then the end sites computed (in joint order)
    tip_row = {j: n_joints + k for k, j in enumerate(tips)}
    point_rows = np.concatenate([rank, [tip_row.get(j, -1) for j in all_tips]]).astype(np.intp)
    sorted_rows = point_rows[stored]
    block = max(BLOCK_ELEMENTS // max(n_points, 1), 256)
    work: dict[str, np.ndarray] = {}
    for start in range(0, n_frames, block):
        frames = slice(start, min(start + block, n_frames))
        width = frames.stop - start
        if not work or work["q"].shape[2] != width:  # the first and the last block
            work = {
                "in_q": np.empty((width, n_joints, 4)),
                "in_t": np.empty((width, n_joints, 3) if channel_axes is None else 0),
                "q": np.empty((4, n_joints, width)),  # local, then world rotations
                "t": np.empty((3, n_joints, width)),  # local translations
                "p": np.empty((3, n_points, width)),  # world positions
                "flat": np.empty(20 * widest * width),  # per-level scratch
            }
        np.take(rotations[frames], order, axis=1, out=work["in_q"], mode="clip")
        q, t, p = work["q"], work["t"], work["p"]
        np.copyto(q, work["in_q"].transpose(2, 1, 0))
        if channel_axes is None:
            np.take(translations[frames], order, axis=1, out=work["in_t"], mode="clip")
            np.copyto(t, work["in_t"].transpose(2, 1, 0))
        else:  # the translations of the joints with a position channel alone are read
            np.copyto(t, sorted_offsets)
            if channel_rows.size:
                read = translations[frames].take(channel_joints, axis=1).transpose(2, 1, 0)
                t[:, channel_rows] = np.where(
                    sorted_axes[:, channel_rows], read, sorted_offsets[:, channel_rows]
                )
        _forward_block(sorted_parents, sizes, q, t, p, work["flat"])
        if tip_rows.size:
            scratch = _Scratch(work["flat"], tip_rows.size, width)
            pq, pp = scratch.take(q, tip_rows, 4), scratch.take(p, tip_rows, 3)
            v = scratch.planes(3)
            np.copyto(v, tip_offsets[:, :, None])
            _rotate_into(pp, pq, v, scratch)
            np.copyto(p[:, n_joints:], pp)
        if world_q is not None:
            world_q[:, order, frames] = q
        world_p[:, :, frames] = p[:, sorted_rows]
    return world_p, world_q


def hung_on(parents: np.ndarray, tip_joints: list[int], points: np.ndarray) -> np.ndarray:
    """The joints (ascending) that ``points`` (joints, then the end sites of
    ``tip_joints``, ascending) hang on, and every joint above them."""
    n_joints = parents.size
    keep = np.zeros(n_joints, dtype=bool)
    for point in points.tolist():  # a walk up the tree per point, each joint once
        j = point if point < n_joints else tip_joints[point - n_joints]
        while j >= 0 and not keep[j]:
            keep[j] = True
            j = int(parents[j])
    return np.flatnonzero(keep)


class _Scratch:
    """Contiguous ``(k, rows, frames)`` planes carved in turn from one flat buffer."""

    def __init__(self, flat: np.ndarray, rows: int, frames: int):
        self.flat, self.rows, self.frames, self.used = flat, rows, frames, 0

    def planes(self, k: int) -> np.ndarray:
        size = k * self.rows * self.frames
        out = self.flat[self.used : self.used + size].reshape(k, self.rows, self.frames)
        self.used += size
        return out

    def take(self, source: np.ndarray, rows: np.ndarray, k: int) -> np.ndarray:
        """Rows ``rows`` of ``source`` (k, R, frames) gathered into new planes."""
        out = self.planes(k)
        np.take(source, rows, axis=1, out=out, mode="clip")
        return out


def _forward_block(
    parents: np.ndarray,
    sizes: list[int],
    q: np.ndarray,
    t: np.ndarray,
    p: np.ndarray,
    flat: np.ndarray,
) -> None:
    """One block of :func:`_forward_planes`, joints sorted by depth (``sizes`` joints per
    level, ``parents`` in that order): ``q`` local rotations become world rotations in
    place; world positions go to ``p[:, :J]``; ``flat`` is scratch."""
    frames = q.shape[2]
    p[:, : sizes[0]] = t[:, : sizes[0]]
    start = sizes[0]
    for size in sizes[1 : LEVEL_LOOP_DEPTH + 1]:
        rows = slice(start, start + size)
        start += size
        scratch = _Scratch(flat, size, frames)
        up = parents[rows]
        pq, pp = scratch.take(q, up, 4), scratch.take(p, up, 3)
        local_q = scratch.planes(4)
        np.copyto(local_q, q[:, rows])
        quat.multiply_planes(q[:, rows], pq, local_q, scratch.planes(2))
        _rotate_into(pp, pq, t[:, rows], scratch)
        np.copyto(p[:, rows], pp)
    if start < q.shape[1]:
        _forward_jumps(parents, start - sizes[LEVEL_LOOP_DEPTH], start, q, t, p)


def _forward_jumps(
    parents: np.ndarray, top: int, first: int, q: np.ndarray, t: np.ndarray, p: np.ndarray
) -> None:
    """The rows from ``first`` on of :func:`_forward_block`, below the level at rows
    ``top:first`` (already world), by pointer jumping: each row's transform relative to an
    ancestor is composed with that ancestor's, ``log2(depth)`` whole-array steps in all
    (a level at a time would cost a step per level, however few joints it holds)."""
    n_joints, frames = q.shape[1], q.shape[2]
    p[:, first:n_joints] = t[:, first:n_joints]  # relative to the parent, for now
    up = parents[top:n_joints] - top
    up[: first - top] = -1  # the top level is already world
    for rows, above in ancestor_jumps(up):
        rows, above = rows + top, above + top
        # frames at a time: scratch of at most 27 x 16 values per joint, not per frame
        width = max(16, BLOCK_ELEMENTS // rows.size)
        flat = np.empty(27 * rows.size * min(width, frames))
        for at in range(0, frames, width):
            part = slice(at, min(at + width, frames))
            qs, ps = q[:, :, part], p[:, :, part]
            scratch = _Scratch(flat, rows.size, part.stop - at)
            aq, ap = scratch.take(qs, above, 4), scratch.take(ps, above, 3)
            local_q, local_p = scratch.take(qs, rows, 4), scratch.take(ps, rows, 3)
            world_q = scratch.planes(4)
            quat.multiply_planes(world_q, aq, local_q, scratch.planes(2))
            qs[:, rows] = world_q
            _rotate_into(ap, aq, local_p, scratch)
            ps[:, rows] = ap


#: Tree levels computed one after the other in :func:`_forward_block` (every level of any
#: real skeleton); deeper ones are composed by pointer jumping (:func:`_forward_jumps`).
LEVEL_LOOP_DEPTH = 64


def _cross_into(out: np.ndarray, a: np.ndarray, b: np.ndarray, tmp: np.ndarray) -> None:
    """``out = a x b`` on planes (3, ...); ``tmp`` one scratch plane; ``out`` not ``a``/``b``."""
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        np.multiply(a[j], b[k], out[i])
        np.multiply(a[k], b[j], tmp)
        np.subtract(out[i], tmp, out[i])


def _rotate_into(p: np.ndarray, q: np.ndarray, v: np.ndarray, scratch: _Scratch) -> None:
    """``p += q v q^-1`` on planes (unit ``q`` (4, ...), ``v`` (3, ...)) as
    ``v + 2 (w c + u x c)`` with ``c = u x v`` (``u`` the vector part): two cross products,
    no quaternion products."""
    u = q[1:]
    c, c2, tmp = scratch.planes(3), scratch.planes(3), scratch.planes(1)[0]
    _cross_into(c, u, v, tmp)
    _cross_into(c2, u, c, tmp)
    c *= q[0]
    c += c2
    c *= 2.0
    c += v
    p += c


def local_translations(motion: Motion) -> np.ndarray:
    """``(F, J, 3)`` local translations: OFFSET with channel axes replaced by their values."""
    as_motion(motion)
    has_axis = motion.layout.position_columns >= 0  # (J, 3)
    return np.where(has_axis, motion.translations, motion.offsets)


def end_site_names(motion: Motion) -> list[str]:
    """Names of the end sites, ``<joint>_end``, in joint order."""
    as_motion(motion)
    return [f"{motion.names[j]}_end" for j in sorted(motion.end_sites)]


def point_parents(motion: Motion) -> np.ndarray:
    """Parent of every point of ``forward(motion, end_sites=True)``: joints, then end sites
    (each end site's parent is its joint)."""
    as_motion(motion)
    return np.concatenate([motion.parents, np.array(sorted(motion.end_sites), dtype=np.intp)])


def forward(motion: Motion, end_sites: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """World positions ``(F, P, 3)`` (file units) and rotations ``(F, J, 4)`` of ``motion``.

    ``P = J`` joints, or with ``end_sites`` the joints followed by the end sites in the
    order of :func:`end_site_names` (an end site has its joint's world rotation).
    """
    as_motion(motion)
    world_p, world_q = _motion_planes(motion, end_sites, keep_rotations=True)
    assert world_q is not None
    return world_p.transpose(2, 1, 0), world_q.transpose(2, 1, 0)


def _motion_planes(motion: Motion, end_sites: bool, keep_rotations: bool, only=None):
    """:func:`_forward_planes` of a clip: its offsets where it has no position channel."""
    return _forward_planes(
        motion.parents,
        motion.rotations,
        motion.translations,
        channel_axes=motion.layout.position_columns >= 0,
        offsets=motion.offsets,
        tips=motion.end_sites if end_sites else None,
        keep_rotations=keep_rotations,
        only=only,
    )


def missing_points(motion: Motion) -> np.ndarray | None:
    """``(F, P)`` bool: the points of ``forward(motion, end_sites=True)`` whose world
    position is unknown (their joint, or one above it, is missing); None when nothing is."""
    if motion.missing is None:
        return None
    joints = motion.missing.copy()
    for rows, above in ancestor_jumps(motion.parents):  # log2(depth) steps
        joints[:, rows] |= joints[:, above]  # the right side is gathered first
    tips = np.array(sorted(motion.end_sites), dtype=np.intp)
    return np.concatenate([joints, joints[:, tips]], axis=1)


def world_positions(motion: Motion, end_sites: bool = True, only=None) -> np.ndarray:
    """The positions of :func:`forward` alone, ``(F, P, 3)`` (world rotations are not kept:
    the work stays in blocks of frames); with ``only`` (indices of points, joints then end
    sites), ``(F, len(only), 3)``: the positions of those points alone."""
    world_p, _ = _motion_planes(motion, end_sites, keep_rotations=False, only=only)
    return world_p.transpose(2, 1, 0)


def end_effectors(motion: Motion) -> tuple[np.ndarray, list[str]]:
    """The points that end a chain (hands, feet, head, fingers): every end site and every
    leaf joint without one. Returns their indices into ``forward(motion, end_sites=True)``
    positions and their names (``<joint>_end`` for an end site)."""
    as_motion(motion)
    has_child = np.zeros(motion.n_joints, dtype=bool)
    has_child[motion.parents[motion.parents >= 0]] = True
    bare_leaves = [j for j in np.flatnonzero(~has_child) if j not in motion.end_sites]
    tips = range(motion.n_joints, motion.n_joints + len(motion.end_sites))
    index = np.array([*bare_leaves, *tips], dtype=np.intp)
    names = [motion.names[j] for j in bare_leaves] + end_site_names(motion)
    return index, names


def rest_positions(motion: Motion) -> np.ndarray:
    """``(P, 3)`` rest-pose positions of joints and end sites: offsets only, no rotation."""
    as_motion(motion)
    positions, _ = forward_arrays(
        motion.parents, quat.identity((1, motion.n_joints)), motion.offsets[None]
    )
    if motion.end_sites:
        joints = sorted(motion.end_sites)
        tips = positions[0, joints] + np.stack([motion.end_sites[j] for j in joints])
        return np.concatenate([positions[0], tips])
    return positions[0]


def rest_rotations(motion: Motion) -> np.ndarray:
    """``(J, 4)`` local rest rotations (w, x, y, z): where the format poses its rest with
    them (a glTF node's ``rotation``: ``source.rest_rotations``), those, else identities
    (a BVH's or an FBX's rest is its offsets alone)."""
    as_motion(motion)
    held = getattr(motion.source, "rest_rotations", None)
    if held is not None and np.shape(held) == (motion.n_joints, 4):
        return np.asarray(held, dtype=np.float64)
    return quat.identity((motion.n_joints,))


def rest_pose(motion: Motion) -> np.ndarray:
    """``(P, 3)`` world positions of joints and end sites in the skeleton's rest pose:
    :func:`rest_positions` with each joint turned by its :func:`rest_rotations` (a glTF
    rig whose bones all lie along their nodes' y stands folded on its offsets alone:
    CesiumMan's 1.17 m read 0.27). The body's parts and feet are read on it."""
    as_motion(motion)
    rest_q = rest_rotations(motion)
    if not np.any(rest_q[:, 1:]):
        return rest_positions(motion)
    rotations = np.broadcast_to(rest_q, (1, *rest_q.shape))
    positions, world_q = forward_arrays(motion.parents, rotations, motion.offsets[None])
    if not motion.end_sites:
        return positions[0]
    joints = sorted(motion.end_sites)
    tips = quat.rotate(world_q[0, joints], np.stack([motion.end_sites[j] for j in joints]))
    return np.concatenate([positions[0], positions[0, joints] + tips])


def turned(motion: Motion, turn: np.ndarray) -> Motion:
    """The clip turned as a whole by the unit quaternion ``turn`` ``(w, x, y, z)``: offsets,
    end sites and translations turned, every local rotation conjugated (``turn q turn^-1``),
    so every world point turns the same; the file text it was read from is dropped (its
    values no longer describe it)."""
    as_motion(motion)
    return motion.replace(
        offsets=quat.rotate(turn, motion.offsets),
        end_sites={j: quat.rotate(turn, v) for j, v in motion.end_sites.items()},
        rotations=quat.multiply(turn, quat.multiply(motion.rotations, quat.conjugate(turn))),
        translations=quat.rotate(turn, motion.translations),
        source=None,
        source_values=None,
        source_rotations=None,
    )


def reaches(motion: Motion) -> np.ndarray:
    """``(J,)``: how far each joint's rotation reaches, the largest rest-pose distance
    (file units) from the joint to a point below it (joints and end sites of its subtree);
    0 for a joint with nothing below it (a tracked body, a leaf without an end site). A
    rotation's jitter of ``a`` (angular acceleration) moves those points by up to ``a``
    times it."""
    rest = rest_positions(motion)
    reach = np.zeros(motion.n_joints)
    points = np.arange(rest.shape[0])
    above = point_parents(motion)
    while points.size:  # one pass per level of the deepest chain
        has = above >= 0
        points, above = points[has], above[has]
        np.maximum.at(reach, above, np.linalg.norm(rest[points] - rest[above], axis=-1))
        above = motion.parents[above]
    return reach


#: Frames (evenly spaced) of a clip whose poses give its up axis and body height.
POSE_SAMPLES = 256
#: A rest pose stands upright when its trunk points within this cosine of an axis ...
UPRIGHT_COSINE = 0.9
#: ... and its legs reach at least this share of its height below the trunk's lowest point.
LEGS_BELOW = 0.25


def axis_index(axis: str | int) -> int:
    """``"x"``, ``"y"``, ``"z"`` (any case, a leading ``-`` allowed) or 0-2 as an axis
    index; ValueError otherwise."""
    if isinstance(axis, str):
        if axis.lower() not in UP_AXES:
            raise ValueError(f"up axis must be x, y, z, -x, -y or -z, got {axis!r}")
        return AXES.index(axis.lower()[-1])
    if axis not in (0, 1, 2):
        raise ValueError(f"up axis must be 0, 1 or 2, got {axis!r}")
    return int(axis)


def up_axis(motion: Motion, override: str | int | None = None) -> int:
    """The up axis of :func:`up_direction` without its sign: 0 = x, 1 = y, 2 = z (``"-y"``
    and ``"y"`` both give 1). ``override`` as :func:`up_direction` takes it; use
    :func:`up_direction` for which way along the axis the head points (``--up -y``)."""
    return up_direction(motion, override)[0]


def up_direction(motion: Motion, override: str | int | None = None) -> tuple[int, float]:
    """The up direction as ``(axis, sign)``: the axis (0 = x, 1 = y, 2 = z) and its sign
    (+1.0: the head toward the axis; -1.0: toward its negative side, as a camera's y-down
    coordinates have it), e.g. ``(1, -1.0)`` for ``"-y"``; the Python counterpart of
    ``--up x|y|z|-x|-y|-z``. ``override`` (``"x"`` ... ``"-z"`` or 0-2, an index meaning
    the positive side) gives it, else what the clip declares (:attr:`Motion.up`), else it
    is found from its motion (:func:`motion_up`).
    """
    as_motion(motion)
    if override is None:
        override = motion.up
    if override is not None:
        negative = isinstance(override, str) and override.startswith("-")
        return axis_index(override), -1.0 if negative else 1.0
    found = motion_up(motion)
    return found.axis, found.sign


@dataclass(frozen=True)
class MotionUp:
    """The up direction a clip's motion shows (:func:`motion_up`), whatever it declares.

    ``axis`` (0 = x, 1 = y, 2 = z) and ``sign`` as :func:`up_direction` gives them; ``by``
    what showed it: ``"trunk"`` (a body standing on its legs), ``"limbs"`` (on all fours)
    or ``"extent"`` (no trunk, or no sampled frame with the points the rules read known:
    the axis of the largest extent, which tells nothing of the body); ``share`` the share
    of the sampled frames (:func:`sample_poses`; those with those points known) on which
    the trunk points, or the limbs stand, along that direction with the feet below the
    head (None by extent).
    """

    axis: int
    sign: float
    by: str
    share: float | None


def motion_up(motion: Motion) -> MotionUp:
    """The up direction the motion of ``motion`` shows, whatever the clip declares: found from
    the poses of up to :data:`POSE_SAMPLES` evenly spaced frames, never from the rest pose
    alone (a T-pose's arm span equals its height).

    Where the skeleton has a trunk (:func:`body_parts`: an upper body above the legs), the
    axis the vector from the legs' centroid to the spine and head (no arm or finger) is
    along on average (the feet are below the head), and which way; a body on all fours on
    more than half of those frames (:func:`on_all_fours`: a quadruped, whose trunk lies
    along the way it faces) stands on its limbs instead: up is the way its legs and
    forelegs point from, on average. Otherwise the axis of the largest median extent of a
    frame's points (sign +1: nothing tells which end is up). Each is the same answer on a
    turned copy of the clip (a Z-up export of a Y-up one). Kept with the clip (every
    world-space stage asks for it).
    """
    as_motion(motion)
    return motion.derived("motion_up", _motion_up)


def _motion_up(motion: Motion) -> MotionUp:
    """:func:`motion_up`, computed."""
    poses, known = sample_poses(motion)
    if poses.shape[0] == 0:
        poses, known = rest_pose(motion)[None], None
    parts = _parts_of(motion)
    if parts is not None and known is not None:
        # the poses whose points the rules read are known (a tracker's dropouts on some
        # frames): the extent of all of them had laid a walk along z (its root at rest at
        # the origin, below the walking hips; one hand's gap of 4 frames)
        read = np.r_[parts.spine, parts.lower, parts.head, parts.legs[0], parts.legs[1]]
        read = np.r_[read, parts.arms[0], parts.arms[1], parts.chest, parts.pelvis]
        whole = _known_poses(poses, known, read)
        poses, known = (whole, None) if whole.shape[0] else (poses, known)
    if parts is not None and known is None:
        by = "limbs" if np.mean(on_all_fours(poses, parts)) > 0.5 else "trunk"
        pointing = _limbs_up(poses, parts) if by == "limbs" else _trunk_up(poses, parts)
        mean = pointing.mean(axis=0)
        if np.abs(mean).max() > 0.0:
            axis = int(np.argmax(np.abs(mean)))
            sign = -1.0 if mean[axis] < 0.0 else 1.0
            along = np.argmax(np.abs(pointing), axis=-1) == axis
            along &= pointing[:, axis] * sign > 0.0
            feet = parts.legs[1] if by == "trunk" else np.r_[parts.legs[1], parts.arms[1]]
            height = poses[..., axis] * sign
            along &= height[:, feet].max(axis=1) < height[:, parts.head].min(axis=1)
            return MotionUp(axis, sign, by, float(np.mean(along)))
    return MotionUp(int(np.argmax(_median_extent(poses, known))), 1.0, "extent", None)


def body_up(motion: Motion) -> np.ndarray | None:
    """``(3,)`` unit, in the clip's own axes: the way a body's trunk points on average over
    the sampled poses (:func:`sample_poses`), from its legs' centroid to its spine and
    head's (a walk's forward lean included: 1.5-9 degrees off the up axis on the exporters'
    clips and the corpus, 6.5 on a run), over the poses whose trunk and leg points are all
    known (a tracker's dropouts); None without a trunk (:func:`body_parts`) or such a
    pose."""
    standing = _standing_poses(motion)
    if standing is None:
        return None
    poses, parts = standing
    mean = _trunk_up(poses, parts).mean(axis=0)
    length = float(np.linalg.norm(mean))
    return mean / length if length > 0.0 else None


def upright_body_up(motion: Motion, up: str | int | None = None) -> np.ndarray | None:
    """:func:`body_up` turned :func:`upright` by the clip's :func:`up_direction` (``up``:
    the override), as floors and contacts are measured."""
    body = body_up(motion)
    return None if body is None else upright(body, *up_direction(motion, up))


def sideways_lean(motion: Motion, up: str | int | None = None) -> np.ndarray | None:
    """``(3,)``, in the clip turned :func:`upright` (``up``: the override): how far the
    body leans along its hips' left-right axis (horizontal), as a vector along that axis
    (its length the sine of the lean), averaged over the sampled poses where the trunk and
    legs are known: the lesser of the trunk's lean (:func:`body_up`'s direction) and the
    legs' (from their tips' midpoint to the hips'), where both lean the same way, else
    none. A body stands upright sideways (a walk's lean is forward), so a lean of trunk
    and legs alike is the capture's tilt (a camera rolled about the way the body faces);
    a bend at the waist leans the trunk alone, a side kick the legs. None without a trunk
    on two legs or such a pose."""
    standing = _standing_poses(motion)
    if standing is None or standing[1].legs[0].size != 2:
        return None
    poses, parts = standing
    axis, sign = up_direction(motion, up)
    poses = upright(poses, axis, sign)
    roots, tips = parts.legs
    parents, rest = point_parents(motion), rest_pose(motion)
    hips = [_hip(parents, rest, parts.pelvis, r, t) for r, t in zip(roots, tips, strict=True)]
    across = poses[:, hips[1]] - poses[:, hips[0]]
    across[:, axis] = 0.0
    across = _unit(across)
    legs = _unit(poses[:, hips].mean(axis=1) - poses[:, tips].mean(axis=1))
    trunk, legs = (
        np.einsum("sk,sk->s", way, across) @ across / poses.shape[0]
        for way in (_trunk_up(poses, parts), legs)
    )
    if float(trunk @ legs) <= 0.0:
        return np.zeros(3)
    return trunk if np.linalg.norm(trunk) <= np.linalg.norm(legs) else legs


def _parts_of(motion: Motion) -> BodyParts | None:
    """:func:`body_parts` of ``motion``'s skeleton, kept with the clip (the up direction,
    the trunk's direction and the sideways lean each ask for it)."""
    return motion.derived("body_parts", lambda m: body_parts(point_parents(m), rest_pose(m)))


def _standing_poses(motion: Motion) -> tuple[np.ndarray, BodyParts] | None:
    """The sampled poses ``(S, P, 3)`` (:func:`sample_poses`) whose trunk and leg points
    are all known (a tracker's dropouts), and the body's parts; None without a trunk
    (:func:`body_parts`) or such a pose."""
    parts = _parts_of(motion)
    if parts is None:
        return None
    poses = _known_poses(*sample_poses(motion), np.r_[parts.spine, parts.lower])
    return (poses, parts) if poses.shape[0] else None


def _known_poses(poses: np.ndarray, known: np.ndarray | None, points) -> np.ndarray:
    """The ``poses`` ``(S, P, 3)`` whose ``points`` are all known (``known`` ``(S, P)``;
    None: every point is)."""
    return poses if known is None else poses[known[:, points].all(axis=1)]


def _hip(parents: np.ndarray, rest: np.ndarray, pelvis: int, root: int, tip: int) -> int:
    """The hip of the leg from ``root`` to ``tip``: the first point on the way that stands
    apart from the ``pelvis`` in the ``rest`` pose (CMU's LHipJoint sits on its Hips)."""
    chain = [int(tip)]
    while chain[-1] != root:
        chain.append(int(parents[chain[-1]]))
    scale = float(np.ptp(rest, axis=0).max()) or 1.0
    for point in reversed(chain):
        if np.linalg.norm(rest[point] - rest[pelvis]) > 1e-3 * scale:
            return point
    return int(root)


#: A declared up direction is contradicted by the motion where the motion shows another one
#: (:func:`motion_up`) on at least this share of its sampled frames: 0.94-1.00 on every
#: biped measured (the exporters' clips, the CMU corpus, walks, runs, turns, jumps and stairs
#: at 24-120 fps, Y-up, Z-up and head down), 0.99-1.00 on the MANN dogs; a kneeling bow with
#: the trunk level shows its up on none (its trunk points along no one axis).
CONTRADICTED_SHARE = 0.9


def up_contradiction(motion: Motion) -> MotionUp | None:
    """The up direction the motion shows (:func:`motion_up`) where the clip declares another
    (:attr:`Motion.up`: ``--up``, a file that states it) and the motion shows its own on at
    least :data:`CONTRADICTED_SHARE` of the frames; None otherwise (nothing declared, the
    same direction, or a motion that cannot tell: a hand, a figure lying and turning on the
    floor, points unknown on some frames). The declared direction is still the one used."""
    as_motion(motion)
    if motion.up is None:
        return None
    shown = motion_up(motion)
    if shown.share is None or shown.share < CONTRADICTED_SHARE:
        return None
    declared = up_direction(motion)
    if (shown.axis, shown.sign) == declared:
        return None
    if shown.by == "trunk" and _limbs_share(motion, *declared) > 0.5:
        return None  # a four-legged body's limbs stand it along the axis declared
    return shown


def _limbs_share(motion: Motion, axis: int, sign: float) -> float:
    """The share of the sampled poses on which the body's legs and forelegs point the same
    way (within :data:`ALL_FOURS_COSINE`), away from the direction ``sign * e_axis``, those
    points known; 0.0 without both. A quadruped read by its trunk (a fox's gallop, on all
    fours on 45 % of its frames; a cat whose feet are IK targets apart from its legs, its
    hind legs at 128 degrees from its spine) stands on its limbs along a Y up its file
    states."""
    parts = _parts_of(motion)
    if parts is None or parts.arms[0].size == 0 or parts.legs[0].size == 0:
        return 0.0
    ends = np.r_[parts.legs[0], parts.legs[1], parts.arms[0], parts.arms[1]]
    poses = _known_poses(*sample_poses(motion), ends)
    if poses.shape[0] == 0:
        return 0.0
    legs, arms = _pointing(poses, parts.legs), _pointing(poses, parts.arms)
    pointing = _unit(-(legs + arms))
    along = np.argmax(np.abs(pointing), axis=-1) == axis
    along &= np.einsum("sk,sk->s", arms, legs) > ALL_FOURS_COSINE  # (a T-pose's arms: none)
    return float(np.mean(along & (pointing[:, axis] * sign > 0.0)))


def up_name(motion: Motion, override: str | int | None = None) -> str:
    """:func:`up_direction` as text: ``"y"``, or ``"-y"`` for a figure standing head down."""
    return axis_name(*up_direction(motion, override))


def axis_name(axis: int, sign: float = 1.0) -> str:
    """An axis (0, 1, 2) and its sign as text: ``"y"``, ``"-z"``."""
    return ("-" if sign < 0.0 else "") + AXES[axis]


def upright(positions: np.ndarray, axis: int, sign: float) -> np.ndarray:
    """World positions ``(..., 3)`` as a figure standing toward ``+axis`` sees them: for a
    figure head down (``sign`` -1) turned by half a turn about the next axis (a rotation,
    not a mirror: every distance, speed and side kept), else ``positions`` themselves.
    Feet, floors and heights are measured on these; :func:`upright` again turns back."""
    if sign > 0.0:
        return positions
    turned = -positions
    across = (axis + 1) % 3
    turned[..., across] = positions[..., across]
    return turned


def upright_turn(axis: int) -> np.ndarray:
    """The rotation ``(4,)`` (w, x, y, z) :func:`upright` applies to a figure standing head
    down along ``axis``: half a turn about the next axis."""
    return quat.from_axis_angle(np.eye(3)[(axis + 1) % 3], np.pi)


def turn_up_onto(axis: int, sign: float, onto: int) -> np.ndarray | None:
    """The rotation ``(4,)`` (w, x, y, z) turning a skeleton's up (``axis``, ``sign``: the
    direction ``sign * e_axis``) onto ``+e_onto`` by the least angle: a quarter turn for
    another axis, half a turn about the axis before ``onto`` for its opposite (-Y onto +Y:
    about X); None where it is ``+e_onto`` already. glTF stands figures on +Y, Blender on
    +Z."""
    if axis == onto:
        return None if sign > 0 else quat.from_axis_angle(np.eye(3)[(onto + 2) % 3], np.pi)
    return quat.normalize(
        np.concatenate([[1.0], np.cross(sign * np.eye(3)[axis], np.eye(3)[onto])])
    )


def upright_positions(
    motion: Motion, up: str | int | None = None, end_sites: bool = True, only=None
) -> np.ndarray:
    """:func:`world_positions` of ``motion`` turned :func:`upright` by its
    :func:`up_direction` (``up``: the override, e.g. ``"-y"``)."""
    return upright(world_positions(motion, end_sites, only), *up_direction(motion, up))


def sample_poses(motion: Motion) -> tuple[np.ndarray, np.ndarray | None]:
    """World positions ``(S, P, 3)`` of joints and end sites on up to
    :data:`POSE_SAMPLES` evenly spaced frames between the clip's rest-pose frames
    (:func:`~motionclean.core.restpose.rest_frames`, left out of every figure; all frames
    where nothing else is left), and ``(S, P)`` True where a point is known (None when
    every point is: no tracker dropouts). Kept with the clip (the up direction, the body
    height and the feet ask for them), read-only."""
    as_motion(motion)
    return motion.derived("sample_poses", _sample_poses)


def _sample_poses(motion: Motion) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`sample_poses`, computed."""
    lead, trail = rest_frames(motion)
    first, last = lead, motion.n_frames - 1 - trail
    if last < first:
        first, last = 0, motion.n_frames - 1
    count = min(last - first + 1, POSE_SAMPLES)
    frames = np.unique(np.linspace(first, last, count))
    frames = frames.round().astype(np.intp)
    poses = world_positions(motion.at_frames(frames))
    poses.flags.writeable = False
    unknown = missing_points(motion)
    if unknown is None:
        return poses, None
    known = ~unknown[frames]
    known.flags.writeable = False
    return poses, known


def _median_extent(poses: np.ndarray, known: np.ndarray | None) -> np.ndarray:
    """``(3,)`` median over frames of the extent of a frame's (known) points per axis."""
    if known is None:
        return np.median(np.ptp(poses, axis=1), axis=0)
    seen = known[..., None]
    top = np.where(seen, poses, -np.inf).max(axis=1)
    bottom = np.where(seen, poses, np.inf).min(axis=1)
    usable = known.sum(axis=1) >= 2
    if not usable.any():
        return np.zeros(3)
    return np.median(top[usable] - bottom[usable], axis=0)


def trunk_split(parents: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The upper body and the legs of a skeleton, from its tree alone (any names, any
    pose): ``(upper, lower)`` point indices, or None when it has no trunk.

    ``parents`` ``(P,)`` are the points' parents (joints then end sites, -1 for the root).
    From the root down to the first point with several children (the pelvis; a
    floor-level root above it is passed), the upper body is the child subtree with the
    most points, holding at least three leaves (head and hands) and more points than any
    other; the legs are the other subtrees. Of several roots, the first with a trunk, the
    ones with the most points below them first (the first of equals: a body beside a prop,
    or beside another body); a point whose largest child subtree and another have trunks
    of their own holds several bodies (a ``World`` root with two performers), read as
    several roots are. A hand, a pair of legs alone or independent tracked bodies have
    none.
    """
    found = body_split(parents)
    return None if found is None else found[1:]


def body_split(parents: np.ndarray) -> tuple[int, np.ndarray, np.ndarray] | None:
    """:func:`trunk_split` with the point the body hangs from: ``(top, upper, lower)``,
    ``top`` the root, or the child of a point holding several bodies, whose subtree is the
    body with whatever stands above its pelvis (a floor-level root)."""
    parents = np.asarray(parents, dtype=np.intp)
    children = child_lists(parents)
    body = _first_body(children, [int(r) for r in np.flatnonzero(parents < 0)])
    return None if body is None else (body.top, body.upper, body.lower)


class _Body(NamedTuple):
    """A trunk found below ``top``: the ``pelvis``, the ``upper`` body's points and the
    ``lower`` ones (the legs)."""

    top: int
    pelvis: int
    upper: np.ndarray
    lower: np.ndarray


def _first_body(children: list[list[int]], tops: list[int]) -> _Body | None:
    """The trunk below the first of ``tops`` that has one, those with the most points below
    them first (the first of equals)."""
    for top in sorted(tops, key=lambda r: -len(subtree(children, r))):  # (stable)
        body = _trunk_below(children, top)
        if body is not None:
            return body
    return None


def _trunk_below(children: list[list[int]], root: int) -> _Body | None:
    """:func:`trunk_split` of the tree below ``root`` (``children``: each point's)."""
    pelvis = root
    while len(children[pelvis]) == 1:
        pelvis = children[pelvis][0]
    if len(children[pelvis]) < 2:
        return None
    subtrees = [subtree(children, c) for c in children[pelvis]]
    sizes = [len(t) for t in subtrees]
    top = int(np.argmax(sizes))
    if _holds_bodies(children, children[pelvis], top):
        return _first_body(children, children[pelvis])
    if not _paired([s for k, s in enumerate(sizes) if k != top]):
        below = children[pelvis][top]  # legs part further down, under a tail or IK targets
        body = _trunk_below(children, below) if _two_legged(children, below) else None
        if body is not None:
            return body._replace(top=root)
    leaves = sum(1 for p in subtrees[top] if not children[p])
    if leaves < 3 or sizes.count(sizes[top]) > 1:
        return None
    lower = [p for k, t in enumerate(subtrees) if k != top for p in t]
    upper = np.array(subtrees[top], dtype=np.intp)
    return _Body(root, pelvis, upper, np.array(lower, dtype=np.intp))


#: A leg holds at least this many points (hip, knee, ankle): a twist or helper bone beside
#: a bone, with its end site, holds 2 (MotionBuilder's ``*_RIGMESH`` bones of the MASS
#: clips, one on each thigh, shin and foot, give a leg a trunk of its own).
LEG_POINTS = 3


def _holds_bodies(children: list[list[int]], starts: list[int], largest: int) -> bool:
    """Whether the subtrees from ``starts`` are several bodies (a ``World`` root with two
    performers), not a pelvis's legs and upper body: the largest (index ``largest``) and
    at least one other are :func:`_two_legged`."""
    if not _two_legged(children, starts[largest]):
        return False
    return any(_two_legged(children, s) for k, s in enumerate(starts) if k != largest)


def _two_legged(children: list[list[int]], start: int) -> bool:
    """Whether the tree from ``start`` has a trunk whose legs include two of one size, each
    of at least :data:`LEG_POINTS` points (a body's mirrored legs: a leg whose helper bones
    make it a trunk has one bone beside it, a spine's upper body arms, not legs)."""
    body = _trunk_below(children, start)
    if body is None:
        return False
    legs = [len(subtree(children, c)) for c in children[body.pelvis]]
    legs.remove(body.upper.size)
    return _paired(legs)


def _paired(sizes: list[int]) -> bool:
    """Whether subtree ``sizes`` (points) include two of one size, each of at least
    :data:`LEG_POINTS` points: a pair of legs (a tail, IK targets hung beside the body's
    root, or a leg with a helper bone beside it are none)."""
    legs = [n for n in sizes if n >= LEG_POINTS]
    return len(legs) > len(set(legs))


def spine(parents: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The spine and head of an upper body (:func:`trunk_split`), whose places no arm or
    finger moves: its points from the one below the pelvis down the single-child chain to
    the first with several children (the chest, where the neck and arms part), and the
    smallest of the chest's branches when one is smaller than every other (the neck and
    head: an arm holds at least a shoulder, elbow and wrist). Point indices."""
    children = child_lists(parents)
    chain = _trunk_chain(parents, upper, children)
    branches = sorted((subtree(children, c) for c in children[chain[-1]]), key=len)
    if len(branches) >= 2 and len(branches[0]) < len(branches[1]):
        chain += branches[0]
    return np.array(chain, dtype=np.intp)


def _trunk_chain(parents: np.ndarray, upper: np.ndarray, children: list[list[int]]) -> list[int]:
    """The upper body's points from the pelvis's child in ``upper`` (the trunk's first
    point) up the single-child chain to the chest, the first with several children (or
    none)."""
    inside = set(upper.tolist())
    point = next(p for p in upper.tolist() if parents[p] not in inside)
    chain = [point]
    while len(children[point]) == 1:
        point = children[point][0]
        chain.append(point)
    return chain


def limbs(parents: np.ndarray) -> list[list[int]]:
    """The limbs of a skeleton with a trunk (:func:`trunk_split`), any names: the subtrees
    that part at the chest (the neck and head, the arms) and the legs, the pelvis's other
    subtrees. Point indices (ascending) per limb; none without a trunk."""
    parents = np.asarray(parents, dtype=np.intp)
    split = trunk_split(parents)
    if split is None:
        return []
    children = child_lists(parents)
    chain = _trunk_chain(parents, split[0], children)
    pelvis = int(parents[chain[0]])
    starts = children[chain[-1]] + [c for c in children[pelvis] if c != chain[0]]
    return [subtree(children, start) for start in starts]


#: A leg or foreleg reaches at least this share of the farthest of its kind (the pelvis's
#: subtrees, or the chest's branches but the head), in the rest pose: a dog's tail (0.67
#: of its legs) or a short bone beside the hips (0.14 of a leg) is none.
LIMB_REACH = 0.8
#: On all fours (:func:`on_all_fours`) the forelegs point the legs' way within this cosine
#: (60 degrees: the MANN dogs' at 20-40 on 80 % of frames, a biped's arms hanging beside
#: its legs too) and both hang across the spine, their cosine with it under this in size
#: (60-120 degrees: the dogs' legs at 75-115; a biped's at 135-180 on most frames, down to
#: 107 in MocapBank's squat, on all fours on 43 % of its frames).
ALL_FOURS_COSINE = 0.5


@dataclass(frozen=True)
class BodyParts:
    """The parts of a skeleton with a trunk (:func:`body_parts`), point indices (joints,
    then end sites): ``upper`` and ``lower`` as :func:`trunk_split`, ``spine`` as
    :func:`spine`, ``pelvis`` and ``chest`` (the trunk's ends, where the legs part and
    where the neck and arms part), ``head`` (the neck and head: the chest's smallest
    branch, or the chest alone), and the roots and tips of the ``legs`` and ``arms`` (the
    forelegs of a quadruped): each limb's first point and its point farthest from it in the
    rest pose, limbs reaching less than :data:`LIMB_REACH` of their longest left out."""

    upper: np.ndarray
    lower: np.ndarray
    spine: np.ndarray
    pelvis: int
    chest: int
    head: np.ndarray
    legs: tuple[np.ndarray, np.ndarray]
    arms: tuple[np.ndarray, np.ndarray]


def body_parts(parents: np.ndarray, rest: np.ndarray) -> BodyParts | None:
    """The :class:`BodyParts` of a skeleton from its tree (``parents`` of its points) and
    its rest pose ``rest`` ``(P, 3)`` (how far each limb reaches, whatever way it lies);
    None without a trunk (:func:`trunk_split`)."""
    split = trunk_split(parents)
    if split is None:
        return None
    upper, lower = split
    children = child_lists(parents)
    chain = _trunk_chain(parents, upper, children)
    pelvis, chest = int(parents[chain[0]]), chain[-1]
    back = spine(parents, upper)
    head = [p for p in back.tolist() if p not in chain] or [chest]
    legs = [c for c in children[pelvis] if c != chain[0]]
    arms = [c for c in children[chest] if c not in head]
    return BodyParts(
        upper,
        lower,
        back,
        pelvis,
        chest,
        np.array(head, dtype=np.intp),
        _limb_ends(legs, children, rest),
        _limb_ends(arms, children, rest),
    )


def _limb_ends(
    starts: list[int], children: list[list[int]], rest: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Roots and tips (point indices) of the limbs that start at ``starts``: each one's
    point farthest from its start in the ``rest`` pose, limbs reaching less than
    :data:`LIMB_REACH` of the farthest left out."""
    tips, reach, sizes = [], [], []
    for start in starts:
        points = subtree(children, start)
        far = np.linalg.norm(rest[points] - rest[start], axis=-1)
        tips.append(points[int(np.argmax(far))])
        reach.append(float(far.max()))
        sizes.append(len(points))
    paired = _mirrored(np.array(sizes), np.array(reach))
    candidates = np.flatnonzero(paired) if paired.any() else np.arange(len(starts))
    longest = max((reach[k] for k in candidates), default=0.0)
    kept = [k for k in candidates.tolist() if reach[k] >= LIMB_REACH * longest]
    return (
        np.array([starts[k] for k in kept], dtype=np.intp),
        np.array([tips[k] for k in kept], dtype=np.intp),
    )


#: Two limbs of as many points whose rest reaches differ by at most this share of the
#: longer are a left and right pair.
PAIR_REACH = 0.1


def _mirrored(sizes: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """``(n,)`` bool: the limbs (``sizes`` points, ``reach`` in the rest pose) that have a
    left or right twin, as many points and as long within :data:`PAIR_REACH`. Where any
    pair up, the others are no legs: a tail down the middle (a cat's reaches 2.2 times its
    legs), the head among an elephant's forelegs."""
    same = (sizes[:, None] == sizes[None, :]) & (
        np.abs(reach[:, None] - reach[None, :])
        <= PAIR_REACH * np.maximum(reach[:, None], reach[None, :])
    )
    np.fill_diagonal(same, False)
    return same.any(axis=1)


def _unit(vectors: np.ndarray) -> np.ndarray:
    """``vectors`` ``(..., 3)`` scaled to length 1 (zero ones kept zero)."""
    length = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors / np.where(length > 0.0, length, 1.0)


def _pointing(poses: np.ndarray, ends: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``(S, 3)``: the way limbs (``ends``: roots and tips) point in ``poses``
    ``(S, P, 3)``, the mean of each one's unit direction from root to tip, made unit."""
    roots, tips = ends
    return _unit(_unit(poses[:, tips] - poses[:, roots]).sum(axis=1))


def on_all_fours(poses: np.ndarray, parts: BodyParts) -> np.ndarray:
    """``(S,)`` bool: the body of :class:`BodyParts` ``parts`` stands on all fours in
    ``poses`` ``(S, P, 3)``: its forelegs point the way its legs do and both hang across its
    spine (pelvis to chest), within :data:`ALL_FOURS_COSINE` (a quadruped, or a biped bent
    level, arms hanging). False throughout for a body without forelegs or legs."""
    if parts.arms[0].size == 0 or parts.legs[0].size == 0:
        return np.zeros(poses.shape[0], dtype=bool)
    legs, arms = _pointing(poses, parts.legs), _pointing(poses, parts.arms)
    back = _unit(poses[:, parts.chest] - poses[:, parts.pelvis])
    along = np.einsum("sk,sk->s", arms, legs) > ALL_FOURS_COSINE
    across = np.abs(np.einsum("sk,sk->s", back, legs)) < ALL_FOURS_COSINE
    return along & across & (np.abs(np.einsum("sk,sk->s", back, arms)) < ALL_FOURS_COSINE)


def _trunk_up(poses: np.ndarray, parts: BodyParts) -> np.ndarray:
    """``(S, 3)`` unit: from the legs' centroid to the spine and head's, per pose."""
    return _unit(poses[:, parts.spine].mean(axis=1) - poses[:, parts.lower].mean(axis=1))


def _limbs_up(poses: np.ndarray, parts: BodyParts) -> np.ndarray:
    """``(S, 3)`` unit: the way the legs and forelegs point from, per pose."""
    return _unit(-(_pointing(poses, parts.legs) + _pointing(poses, parts.arms)))


def child_lists(parents: np.ndarray) -> list[list[int]]:
    """Each point's children (point indices, ascending), from ``parents`` (-1 for a root)."""
    children: list[list[int]] = [[] for _ in parents]
    for child, parent in enumerate(np.asarray(parents).tolist()):
        if parent >= 0:
            children[parent].append(child)
    return children


def subtree(children: list[list[int]], start: int) -> list[int]:
    """``start`` and every point below it (ascending), from :func:`child_lists`."""
    found, stack = [], [start]
    while stack:
        point = stack.pop()
        found.append(point)
        stack.extend(children[point])
    return sorted(found)


def body_height(motion: Motion, up: int | None = None) -> float:
    """The body's standing height in file units (the scale of every threshold relative to
    the body).

    Where the rest pose stands upright (its trunk, :func:`trunk_split`, within
    :data:`UPRIGHT_COSINE` of an axis and every leg hanging below it: a T- or A-pose,
    whichever way the clip turns it), its extent along that axis; otherwise the median
    over frames of the extent of a frame's points along the up axis (``up``, default
    :func:`up_axis`): a clip whose rest pose is not a standing pose (a quadruped's, its
    legs across its trunk), a rest posed by rotations (:func:`rest_rotations`: a glTF's
    nodes), and independent tracked bodies.
    """
    as_motion(motion)
    # asked by despike, footlock and the report's stages of one clean, with or without up
    return motion.derived(f"body_height {up}", lambda clip: _body_height(clip, up))


def _body_height(motion: Motion, up: int | None = None) -> float:
    rest = rest_pose(motion)
    parents = point_parents(motion)
    split = body_split(parents)
    parts = _parts_of(motion)
    # a rest posed by rotations (a glTF's nodes: a bind pose the exporter chose, often
    # without end sites) is no measure: the frames are
    posed = bool(np.any(rest_rotations(motion)[:, 1:]))
    if split is not None and parts is not None and not posed:
        top, upper, lower = split
        trunk = rest[upper].mean(axis=0) - rest[lower].mean(axis=0)
        length = float(np.linalg.norm(trunk))
        axis = int(np.argmax(np.abs(trunk)))
        if (
            _legs_hang(rest, parts, axis, trunk[axis])
            and length > 0.0
            and abs(trunk[axis]) >= UPRIGHT_COSINE * length
        ):
            heights = rest[:, axis] * np.sign(trunk[axis])
            # the body's points alone where others stand beside it (a prop, a figure)
            body = subtree(child_lists(parents), top)
            extent = float(np.ptp(heights[body]))
            # standing, the legs hang below the trunk (a rest that stacks every bone along
            # one axis, as the glTF of a Blender rig does, points them up: no height), all
            # of them (Bandai Namco's rest lays every bone along x, one leg up the trunk's
            # way, the other down: its 184 units along x are no height of a body of 137)
            legs_below = heights[lower].min() <= heights[upper].min() - LEGS_BELOW * extent
            if legs_below and heights[lower].max() < heights[upper].mean():
                return extent
    axis = up_axis(motion) if up is None else up
    poses, known = sample_poses(motion)
    if poses.shape[0] == 0:
        return float(np.ptp(rest[:, axis]))
    return float(_median_extent(poses, known)[axis])


def _legs_hang(rest: np.ndarray, parts: BodyParts, axis: int, trunk: float) -> bool:
    """Whether the legs of ``parts`` point down the trunk's ``axis`` in the ``rest`` pose
    ``(P, 3)`` (``trunk`` the trunk's component along it): a four-legged rest lies along
    the way it faces, its legs across that way and its tail below the trunk."""
    legs = _pointing(rest[None], parts.legs)[0]
    return int(np.argmax(np.abs(legs))) == axis and legs[axis] * trunk < 0.0
