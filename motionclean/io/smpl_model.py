"""The SMPL family's kinematic trees, rotation conversions and the rest skeleton of a body.

SMPL (24 joints), SMPL-H (52) and SMPL-X (55) share their first 22 joints (pelvis to
wrists). SMPL ends with two hand joints; SMPL-H adds 15 finger joints per hand; SMPL-X
adds the jaw and both eyes before the same fingers. Joint names follow the ``smplx``
package (``pelvis``, ``left_hip``, ...). Each joint's parameter is an axis-angle vector
``r`` (radians, ``|r|`` the angle, rotation about ``r / |r|``) of the joint's rotation
relative to its parent, about the joint's position in the rest pose (all rotations
identity: a T-pose, Y up, facing +Z).

Joint positions depend on the body model (its template and joint regressor) and shape
(``betas``): they come from a body model file the user has (:func:`model_offsets`) or a
skeleton the user gives (:func:`skeleton_offsets`); no model ships with motionclean.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..core import quat
from ..core.checks import MAX_MAGNITUDE, within_magnitude
from ..core.errors import MotionError
from ..core.motion import Motion

#: The 22 joints every model has, with their parents.
BODY = (
    ("pelvis", -1),
    ("left_hip", 0),
    ("right_hip", 0),
    ("spine1", 0),
    ("left_knee", 1),
    ("right_knee", 2),
    ("spine2", 3),
    ("left_ankle", 4),
    ("right_ankle", 5),
    ("spine3", 6),
    ("left_foot", 7),
    ("right_foot", 8),
    ("neck", 9),
    ("left_collar", 9),
    ("right_collar", 9),
    ("head", 12),
    ("left_shoulder", 13),
    ("right_shoulder", 14),
    ("left_elbow", 16),
    ("right_elbow", 17),
    ("left_wrist", 18),
    ("right_wrist", 19),
)
FINGERS = ("index", "middle", "pinky", "ring", "thumb")


def _hand(side: str, wrist: str) -> tuple[tuple[str, str], ...]:
    """The 15 finger joints of one hand (MANO order) with their parents' names."""
    joints = []
    for finger in FINGERS:
        parent = wrist
        for k in (1, 2, 3):
            joints.append((f"{side}_{finger}{k}", parent))
            parent = f"{side}_{finger}{k}"
    return tuple(joints)


_BODY_NAMED = tuple((name, BODY[p][0] if p >= 0 else "") for name, p in BODY)
_HANDS = _hand("left", "left_wrist") + _hand("right", "right_wrist")
_FACE = (("jaw", "head"), ("left_eye_smplhf", "head"), ("right_eye_smplhf", "head"))


@dataclass(frozen=True)
class Tree:
    """A model's joints in parameter order: ``names`` and ``parents`` (-1 for the root)."""

    model: str
    names: tuple[str, ...]
    parents: tuple[int, ...]

    @property
    def n_joints(self) -> int:
        return len(self.names)


def _tree(model: str, joints: tuple[tuple[str, str], ...]) -> Tree:
    names = tuple(name for name, _ in joints)
    parents = tuple(names.index(parent) if parent else -1 for _, parent in joints)
    return Tree(model, names, parents)


SMPL = _tree("SMPL", _BODY_NAMED + (("left_hand", "left_wrist"), ("right_hand", "right_wrist")))
SMPLH = _tree("SMPL-H", _BODY_NAMED + _HANDS)
SMPLX = _tree("SMPL-X", _BODY_NAMED + _FACE + _HANDS)
#: The body without hands (22 joints, e.g. a ``poses`` of 66 values).
SMPL_BODY = _tree("SMPL body", _BODY_NAMED)
#: Trees by joint count, for a ``poses`` array of ``3 J`` values.
TREES = {tree.n_joints: tree for tree in (SMPL, SMPLH, SMPLX, SMPL_BODY)}


# ----------------------------------------------------------------------------- rotations


def axis_angle_to_quaternion(r: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` (w, x, y, z) of axis-angle vectors ``r`` ``(..., 3)``
    (radians): ``exp(r / 2)`` in the papers' convention (``|log q|`` is half the angle)."""
    return quat.exp(0.5 * np.asarray(r, dtype=np.float64))


def quaternion_to_axis_angle(q: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Axis-angle vectors ``(..., 3)`` of unit quaternions ``q``: of the equivalent vectors
    (angle ``a + 2 pi k`` about the axis ``n``, any whole ``k``), the one nearest to
    ``reference`` ``(..., 3)`` (the values read), so a curve keeps its branch."""
    r = 2.0 * quat.log_shortest(q)  # angle a in [0, pi] about n
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    ref_norm = np.linalg.norm(reference, axis=-1, keepdims=True)
    turning = angle > 0.0
    axis = np.where(
        turning, r / np.where(turning, angle, 1.0), reference / np.maximum(ref_norm, 1e-300)
    )
    along = np.sum(reference * axis, axis=-1, keepdims=True)
    turns = np.round((along - angle) / (2.0 * np.pi))
    return np.where(turns == 0.0, r, (angle + 2.0 * np.pi * turns) * axis)


def matrix_to_quaternion(m: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` of rotation matrices ``(..., 3, 3)`` (column vectors),
    by the largest of the four squared components (Shepperd): accurate everywhere. Matrices
    that are not quite orthonormal give the quaternion of their nearest rotation's
    symmetric part, renormalised."""
    m = np.asarray(m, dtype=np.float64)
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    squares = np.stack(
        [1 + m00 + m11 + m22, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22],
        axis=-1,
    )
    pick = np.argmax(squares, axis=-1)
    s = np.sqrt(np.maximum(np.take_along_axis(squares, pick[..., None], -1)[..., 0], 1e-300))
    d21, d02, d10 = (
        m[..., 2, 1] - m[..., 1, 2],
        m[..., 0, 2] - m[..., 2, 0],
        m[..., 1, 0] - m[..., 0, 1],
    )
    s21, s02, s10 = (
        m[..., 2, 1] + m[..., 1, 2],
        m[..., 0, 2] + m[..., 2, 0],
        m[..., 1, 0] + m[..., 0, 1],
    )
    candidates = np.stack(
        [
            np.stack([s * s, d21, d02, d10], axis=-1),
            np.stack([d21, s * s, s10, s02], axis=-1),
            np.stack([d02, s10, s * s, s21], axis=-1),
            np.stack([d10, s02, s21, s * s], axis=-1),
        ],
        axis=-2,
    )
    q = np.take_along_axis(candidates, pick[..., None, None], -2)[..., 0, :] / (2.0 * s[..., None])
    return quat.normalize(q)


# ----------------------------------------------------------------------------- skeletons


def offsets_from_positions(joints: np.ndarray, parents: tuple[int, ...]) -> np.ndarray:
    """``(J, 3)`` offsets (root: its position) of rest joint positions ``(J, 3)``."""
    parent = np.asarray(parents)
    offsets = joints.copy()
    child = parent >= 0
    offsets[child] = joints[child] - joints[parent[child]]
    return offsets


#: Arrays a body model file must hold, and the optional one.
MODEL_KEYS = ("J_regressor", "v_template")


def model_offsets(arrays: dict[str, np.ndarray], tree: Tree, betas, path) -> np.ndarray:
    """``(J, 3)`` rest offsets of ``tree``'s joints from a body model's arrays:
    ``J = J_regressor (v_template + shapedirs betas)``, ``J_regressor`` ``(K, V)`` with at
    least the tree's joints (its first rows), ``v_template`` ``(V, 3)``, optional
    ``shapedirs`` ``(V, 3, S)`` with ``betas`` ``(B,)`` (the first ``min(S, B)`` used)."""
    for key in MODEL_KEYS:
        if key not in arrays:
            raise MotionError(
                f"not a body model: no {key!r} array (needs J_regressor and v_template)", path
            )
    regressor = np.asarray(arrays["J_regressor"], dtype=np.float64)
    template = np.asarray(arrays["v_template"], dtype=np.float64)
    if template.ndim != 2 or template.shape[1] != 3:
        raise MotionError(
            f"body model: v_template has shape {template.shape}, expected (V, 3)", path
        )
    vertices = template.shape[0]
    if regressor.ndim != 2 or regressor.shape[1] != vertices or regressor.shape[0] < tree.n_joints:
        raise MotionError(
            f"body model: J_regressor has shape {regressor.shape}, expected (at least "
            f"{tree.n_joints}, {vertices}) for {tree.model}",
            path,
        )
    _check_model_tree(arrays, regressor.shape[0], tree, path)
    shaped = template
    if "shapedirs" in arrays and betas is not None:
        dirs = np.asarray(arrays["shapedirs"], dtype=np.float64)
        betas = np.asarray(betas, dtype=np.float64).ravel()
        if dirs.ndim != 3 or dirs.shape[:2] != (vertices, 3):
            raise MotionError(
                f"body model: shapedirs has shape {dirs.shape}, expected (V, 3, S)", path
            )
        n = min(dirs.shape[2], betas.size)
        shaped = template + dirs[:, :, :n] @ betas[:n]
    joints = regressor[: tree.n_joints] @ shaped
    if not within_magnitude(joints):  # NaN too
        raise MotionError(
            f"body model: joint positions are not finite numbers of at most {MAX_MAGNITUDE:g} "
            "in size",
            path,
        )
    return offsets_from_positions(joints, tree.parents)


def depth_first(parents: tuple[int, ...]) -> np.ndarray:
    """The joints in depth-first order (children in index order), as a BVH lists them."""
    children: list[list[int]] = [[] for _ in parents]
    roots: list[int] = []
    for k, p in enumerate(parents):
        (children[p] if p >= 0 else roots).append(k)
    order, stack = [], roots[::-1]
    while stack:
        k = stack.pop()
        order.append(k)
        stack.extend(children[k][::-1])
    return np.array(order, dtype=np.intp)


def _check_model_tree(arrays: dict, rows: int, tree: Tree, path) -> None:
    """Refuse a body model of another family than the clip's (a SMPL-H model for a SMPL
    clip gives wrong joints silently): its joint count, and its ``kintree_table`` when it
    has one, must be the tree's (the 22-joint body fits any of the three)."""
    fits = rows == tree.n_joints or (tree is SMPL_BODY and rows in TREES and rows != 22)
    table = arrays.get("kintree_table")
    if fits and isinstance(table, np.ndarray) and table.ndim == 2 and table.shape[0] == 2:
        parents = table[0, : tree.n_joints].astype(np.int64)
        parents = np.where(parents >= rows, -1, parents)  # the root's entry: -1 or 2**32 - 1
        fits = parents.tolist() == list(tree.parents)
    if not fits:
        family = TREES[rows].model if rows in TREES else f"a {rows}-joint model"
        raise MotionError(
            f"body model is {family} ({rows} joints), the clip {tree.model} "
            f"({tree.n_joints} joints): give the model of the clip's family",
            path,
        )


def _plain(name: str) -> str:
    """A joint name compared across rigs: no namespace (``mixamorig:``), no ``m_avg_``
    prefix, lower case, ``L_``/``R_`` spelled out."""
    name = name.rsplit(":", 1)[-1].lower()
    name = re.sub(r"^[mf]_avg_", "", name)
    return re.sub(r"^([lr])_", lambda m: "left_" if m.group(1) == "l" else "right_", name)


def skeleton_offsets(skeleton: Motion, tree: Tree, path) -> np.ndarray:
    """``(J, 3)`` rest offsets of ``tree``'s joints taken from a user's skeleton (a BVH
    rig in the model's rest pose): joints matched by name (case, namespaces, ``m_avg_``
    and ``L_``/``R_`` spellings aside), or else by order when the rig has the tree's
    joints and parents in the model's order or depth first (children in model order, as
    a BVH of the model lists them). The offsets are those of the rig's OFFSET
    lines (the root's too)."""
    rig = {_plain(name): j for j, name in enumerate(skeleton.names)}
    found = [rig.get(_plain(name)) for name in tree.names]
    if all(j is not None for j in found):
        return np.asarray(skeleton.offsets, dtype=np.float64)[np.array(found, dtype=np.intp)]
    for order in (np.arange(tree.n_joints), depth_first(tree.parents)):
        # the rig's joints in the model's order, or depth first as a BVH lists them
        position = np.argsort(order)
        parents = [int(position[tree.parents[k]]) if tree.parents[k] >= 0 else -1 for k in order]
        if skeleton.n_joints == tree.n_joints and skeleton.parents.tolist() == parents:
            return np.asarray(skeleton.offsets, dtype=np.float64)[position]
    missing = [name for name, j in zip(tree.names, found, strict=True) if j is None]
    raise MotionError(
        f"skeleton {skeleton.path}: no joint for {len(missing)} of the {tree.model} joints "
        f"({', '.join(missing[:4])}{', ...' if len(missing) > 4 else ''}), and its "
        f"{skeleton.n_joints} joints are not the model's {tree.n_joints} in order",
        path,
    )
