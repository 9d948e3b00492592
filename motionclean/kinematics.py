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

import numpy as np

from . import checks, quat
from .motion import Motion

__all__ = [
    "AXES",
    "body_height",
    "end_effectors",
    "end_site_names",
    "forward",
    "forward_arrays",
    "local_translations",
    "point_parents",
    "rest_positions",
    "up_axis",
]

AXES = "xyz"


def depth_levels(parents: np.ndarray) -> list[np.ndarray]:
    """Joint indices grouped by depth in the tree (roots first), each group ascending.

    Raises ValueError for a parent index out of range or a cycle.
    """
    parents = np.asarray(parents, dtype=np.intp)
    n = parents.size
    if np.any((parents < -1) | (parents >= n)):
        raise ValueError(f"parents must lie in [-1, {n - 1}]")
    depth = np.full(n, -1)
    depth[parents < 0] = 0
    level = 0
    while (depth < 0).any():
        newly = (depth < 0) & (depth[parents] == level) & (parents >= 0)
        if not newly.any():
            raise ValueError("parents contain a cycle")
        level += 1
        depth[newly] = level
    order = np.argsort(depth, kind="stable")
    counts = np.bincount(depth, minlength=level + 1)
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
    world_p, world_q = _forward_planes(
        np.asarray(parents, dtype=np.intp),
        np.ascontiguousarray(rotations.transpose(2, 1, 0)),
        np.ascontiguousarray(translations.transpose(2, 1, 0)),
    )
    return world_p.transpose(2, 1, 0), world_q.transpose(2, 1, 0)


def _forward_planes(
    parents: np.ndarray, local_q: np.ndarray, local_t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Forward kinematics on component planes, joint-major: ``local_q`` (4, J, F) and
    ``local_t`` (3, J, F) in, world planes of the same shapes out. A level's joints (and
    their parents) are gathered as whole contiguous rows; the arithmetic runs on planes."""
    world_q = np.empty_like(local_q)
    world_p = np.empty_like(local_t)
    for level, joints in enumerate(depth_levels(parents)):
        if level == 0:
            world_q[:, joints] = local_q[:, joints]
            world_p[:, joints] = local_t[:, joints]
            continue
        up = parents[joints]
        parent_q = world_q[:, up]
        product = np.empty_like(parent_q)
        scratch = np.empty((2, *product.shape[1:]))
        quat.multiply_planes(product, parent_q, local_q[:, joints], scratch)
        world_q[:, joints] = product
        world_p[:, joints] = world_p[:, up] + _rotate_planes(parent_q, local_t[:, joints])
    return world_p, world_q


def _cross_planes(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.empty_like(b)
    np.subtract(a[1] * b[2], a[2] * b[1], out=out[0])
    np.subtract(a[2] * b[0], a[0] * b[2], out=out[1])
    np.subtract(a[0] * b[1], a[1] * b[0], out=out[2])
    return out


def _rotate_planes(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``q v q^-1`` on planes (unit ``q`` (4, ...), ``v`` (3, ...)) as ``v + 2 (w c + u x c)``
    with ``c = u x v`` (``u`` the vector part): two cross products, no quaternion products."""
    u = q[1:]
    c = _cross_planes(u, v)
    c2 = _cross_planes(u, c)
    c *= q[0]
    c += c2
    c *= 2.0
    c += v
    return c


def local_translations(motion: Motion) -> np.ndarray:
    """``(F, J, 3)`` local translations: OFFSET with channel axes replaced by their values."""
    has_axis = motion.layout.position_columns >= 0  # (J, 3)
    return np.where(has_axis, motion.translations, motion.offsets)


def end_site_names(motion: Motion) -> list[str]:
    """Names of the end sites, ``<joint>_end``, in joint order."""
    return [f"{motion.names[j]}_end" for j in sorted(motion.end_sites)]


def point_parents(motion: Motion) -> np.ndarray:
    """Parent of every point of ``forward(motion, end_sites=True)``: joints, then end sites
    (each end site's parent is its joint)."""
    return np.concatenate([motion.parents, np.array(sorted(motion.end_sites), dtype=np.intp)])


def forward(motion: Motion, end_sites: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """World positions ``(F, P, 3)`` (file units) and rotations ``(F, J, 4)`` of ``motion``.

    ``P = J`` joints, or with ``end_sites`` the joints followed by the end sites in the
    order of :func:`end_site_names` (an end site has its joint's world rotation).
    """
    n_joints, n_frames = motion.n_joints, motion.n_frames
    local_t = np.empty((3, n_joints, n_frames))
    local_t[...] = motion.offsets.T[:, :, None]
    columns = motion.layout.position_columns
    for axis in range(3):  # channel values replace the OFFSET's axes that have a channel
        joints = np.flatnonzero(columns[:, axis] >= 0)
        local_t[axis, joints] = motion.translations[:, joints, axis].T
    local_q = np.ascontiguousarray(motion.rotations.transpose(2, 1, 0))
    world_p, world_q = _forward_planes(motion.parents, local_q, local_t)
    if end_sites and motion.end_sites:
        joints = np.array(sorted(motion.end_sites), dtype=np.intp)
        offsets = np.stack([motion.end_sites[int(j)] for j in joints]).astype(np.float64)
        tips = world_p[:, joints] + _rotate_planes(
            world_q[:, joints], np.broadcast_to(offsets.T[:, :, None], (3, joints.size, n_frames))
        )
        world_p = np.concatenate([world_p, tips], axis=1)
    return world_p.transpose(2, 1, 0), world_q.transpose(2, 1, 0)


def end_effectors(motion: Motion) -> tuple[np.ndarray, list[str]]:
    """The points that end a chain (hands, feet, head, fingers): every end site and every
    leaf joint without one. Returns their indices into ``forward(motion, end_sites=True)``
    positions and their names (``<joint>_end`` for an end site)."""
    has_child = np.zeros(motion.n_joints, dtype=bool)
    has_child[motion.parents[motion.parents >= 0]] = True
    bare_leaves = [j for j in np.flatnonzero(~has_child) if j not in motion.end_sites]
    tips = range(motion.n_joints, motion.n_joints + len(motion.end_sites))
    index = np.array([*bare_leaves, *tips], dtype=np.intp)
    names = [motion.names[j] for j in bare_leaves] + end_site_names(motion)
    return index, names


def rest_positions(motion: Motion) -> np.ndarray:
    """``(P, 3)`` rest-pose positions of joints and end sites: offsets only, no rotation."""
    positions, _ = forward_arrays(
        motion.parents, quat.identity((1, motion.n_joints)), motion.offsets[None]
    )
    if motion.end_sites:
        joints = sorted(motion.end_sites)
        tips = positions[0, joints] + np.stack([motion.end_sites[j] for j in joints])
        return np.concatenate([positions[0], tips])
    return positions[0]


def up_axis(motion: Motion, override: str | int | None = None) -> int:
    """The up axis (0 = x, 1 = y, 2 = z): the axis along which the rest pose is tallest,
    or ``override`` (``"x"``, ``"y"``, ``"z"`` or 0-2)."""
    if override is not None:
        if isinstance(override, str):
            if override.lower() not in AXES:
                raise ValueError(f"up axis must be x, y or z, got {override!r}")
            return AXES.index(override.lower())
        if override not in (0, 1, 2):
            raise ValueError(f"up axis must be 0, 1 or 2, got {override!r}")
        return int(override)
    rest = rest_positions(motion)
    return int(np.argmax(np.ptp(rest, axis=0)))


def body_height(motion: Motion, up: int | None = None) -> float:
    """Height of the rest pose along the up axis, in file units (the scale of every
    threshold relative to the body)."""
    axis = up_axis(motion) if up is None else up
    return float(np.ptp(rest_positions(motion)[:, axis]))
