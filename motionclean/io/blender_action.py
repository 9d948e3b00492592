"""Blender armature actions <-> :class:`~motionclean.core.motion.Motion`.

The functions here take Blender's own objects (an armature object, an action and its slot)
and never import ``bpy``: the Blender extension and :mod:`.fbx` both hand them in.

Conventions. A pose bone's rotation (a quaternion, Euler angles in any of Blender's six
orders, or an axis and angle) turns the bone from its rest orientation ``B`` (the rotation
of ``bone.matrix_local``, armature space). A :class:`Motion` holds rotations local to the
parent in axes that do not turn with the rest, as BVH does, so ``R = B q B^-1`` with ``q``
the pose bone's rotation: the rotation of the bone from rest, in armature axes, relative to
its parent's. Offsets are rest head positions relative to the parent's head (armature
units and axes); a bone with location curves gets position channels holding
``offset + B location``, as a BVH position channel holds the joint's place in its parent.
Blender's Euler mode ``"XYZ"`` applies X first, ``R = Rz Ry Rx``: the BVH channel order
``Zrotation Yrotation Xrotation`` (the mode's letters reversed).

Curves store float32 values: what is read is exact, what is written is rounded to float32
(about 1e-5 degrees for an Euler angle near 180 degrees, 7e-6 degrees for a quaternion).
Layered actions (Blender 4.4 and later: ``action.layers[..].strips[..].channelbag(slot)``)
and legacy ones (``action.fcurves``, before 4.4) are both read and written.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core import quat
from ..core.errors import MotionError
from ..core.motion import Motion, continuous_euler, same_rotations

__all__ = [
    "ActionClip",
    "BoneTrack",
    "WriteSummary",
    "action_fcurves",
    "all_fcurves",
    "key_frames",
    "key_range",
    "new_fcurve",
    "read_action",
    "rest_quaternions",
    "write_action",
]

#: Rotation property of each pose-bone rotation mode, and its number of values.
ROTATION_PROPERTIES = {
    "QUATERNION": ("rotation_quaternion", 4),
    "AXIS_ANGLE": ("rotation_axis_angle", 4),
}
EULER_MODES = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")
#: A keyed (not baked) curve keeps its keys over frames whose rotation moved by less than
#: this (degrees) ...
KEEP_DEGREES = 1e-4
#: ... and whose location moved by less than this fraction of the skeleton's size (the sum
#: of its bones' offsets).
KEEP_LENGTH = 1e-6

#: A still leaf bone whose name ends so, in any case, is an exporter's tip (Blender's FBX
#: export adds one per leaf, Mixamo's ``HeadTop_End``): its parent's end site, not a joint.
TIP_SUFFIX = "_end"
#: A bone property saying its end site lies on its head: a bone cannot end where it starts,
#: so its tail (and the tip an exporter adds there) lies further on; the flag brings the
#: end site back to where the file had it (Bandai's, MotionBuilder's and Mixamo's leaves).
END_SITE_AT_HEAD = "motionclean_end_site_at_head"
#: A bone property naming the joint's channels, as a BVH lists them (``"Xposition
#: Yposition Zposition Zrotation Xrotation Yrotation"``), which motionclean writes on the
#: bones of a clip it writes to FBX: a joint whose channels never move keeps them (the same
#: clip is then cleaned the same from its FBX as from its BVH), in their order.
CHANNELS_PROPERTY = "motionclean_channels"
#: Location curves within this fraction of the skeleton's size of zero are the rest.
REST_LOCATION = 1e-6

#: Shared key times within this fraction of their spacing of an even grid are one (float32
#: times: 3e-5 frames at frame 300 against a spacing of 0.2 or more).
GRID_TOLERANCE = 1e-3
#: A key this close to a whole frame (frames) is on it: Blender's FBX importer keys frame 32
#: at 31.999998, its float32 rounding.
ON_FRAME = 1e-3

_BONE_PATH = re.compile(r'^pose\.bones\["((?:[^"\\]|\\.)*)"\]\.(\w+)$')


def _rotation_property(mode: str) -> tuple[str, int]:
    return ROTATION_PROPERTIES.get(mode, ("rotation_euler", 3))


def bone_path(name: str, prop: str) -> str:
    """The data path of a pose bone's property, as Blender writes it."""
    escaped = name.replace("\\", "\\\\").replace('"', '\\"')
    return f'pose.bones["{escaped}"].{prop}'


@dataclass(frozen=True)
class BoneTrack:
    """How one bone's motion is stored: its rotation mode and which properties have curves."""

    name: str
    mode: str  # QUATERNION, AXIS_ANGLE or an Euler order such as "XYZ"
    rotation: bool  # the Motion has rotation channels for it
    location: bool  # ... and position channels


@dataclass
class ActionClip:
    """An action read over some frames: the Motion and what writing it back needs."""

    motion: Motion
    frames: np.ndarray  # (F,) scene frames of the motion's frames
    rest: np.ndarray  # (J, 4) rest orientations B
    tracks: list[BoneTrack]
    rotation_values: list[np.ndarray]  # per bone (F, n): the rotation property's values read
    location_values: list[np.ndarray]  # per bone (F, 3)


@dataclass
class WriteSummary:
    """What :func:`write_action` changed."""

    keys_set: int = 0  # existing keys given new values
    keys_added: int = 0  # keys set on frames that had none (a stretch keyed per frame)
    curves_created: int = 0  # curves made for bones that had none


# ----------------------------------------------------------------------------- curves


def action_fcurves(action: Any, slot: Any, create: bool = False) -> Any:
    """The F-curves of ``action`` that animate ``slot``: the channelbag's of a layered
    action, ``action.fcurves`` of a legacy one (Blender before 4.4); None when there are
    none and ``create`` is false."""
    layers = getattr(action, "layers", None)
    if layers is not None and (len(layers) or not hasattr(action, "fcurves") or create):
        for layer in layers:
            for strip in layer.strips:
                bag = strip.channelbag(slot) if slot is not None else None
                if bag is not None:
                    return bag.fcurves
        if not create or slot is None:
            return None
        layer = layers[0] if len(layers) else layers.new("Layer")
        strip = layer.strips[0] if len(layer.strips) else layer.strips.new(type="KEYFRAME")
        return strip.channelbags.new(slot).fcurves
    return getattr(action, "fcurves", None)


def new_fcurve(fcurves: Any, data_path: str, index: int, group: str) -> Any:
    """A new F-curve in the bone's group (Blender 4.5's channelbags take no group name:
    there the curve is left ungrouped)."""
    try:
        return fcurves.new(data_path, index=index, group_name=group)
    except TypeError:
        return fcurves.new(data_path, index=index)


def all_fcurves(action: Any) -> list[Any]:
    """Every F-curve of ``action``: those of all its channelbags, or ``action.fcurves``."""
    layers = getattr(action, "layers", None)
    if layers is not None and len(layers):
        return [
            curve
            for layer in layers
            for strip in layer.strips
            for bag in strip.channelbags
            for curve in bag.fcurves
        ]
    return list(getattr(action, "fcurves", ()))


def _bone_curves(fcurves: Any) -> dict[str, dict[str, dict[int, Any]]]:
    """bone name -> property -> array index -> F-curve."""
    found: dict[str, dict[str, dict[int, Any]]] = {}
    for curve in fcurves or ():
        match = _BONE_PATH.match(curve.data_path)
        if match:
            name = re.sub(r"\\(.)", r"\1", match.group(1))
            found.setdefault(name, {}).setdefault(match.group(2), {})[curve.array_index] = curve
    return found


def key_range(action: Any, slot: Any) -> tuple[int, int] | None:
    """First and last whole frames of the bone keys of ``action`` for ``slot``; None
    without any."""
    first, last = np.inf, -np.inf
    for props in _bone_curves(action_fcurves(action, slot)).values():
        for curves in props.values():
            for curve in curves.values():
                co = _keys(curve)
                if len(co):
                    first, last = min(first, co[0, 0]), max(last, co[-1, 0])
    if first > last:
        return None
    return int(np.ceil(first - 1e-6)), int(np.floor(last + 1e-6))


def key_frames(action: Any, slot: Any) -> tuple[np.ndarray, float]:
    """The frames to read and write the bone curves of ``action`` for ``slot`` at, and
    their spacing (scene frames), :func:`key_grid`'s; MotionError where no one grid holds
    the keys (read on whole frames, cleaning would add keys beside them and leave them as
    they were); an empty array without bone keys."""
    grid = key_grid(action, slot)
    if isinstance(grid, float):
        raise MotionError(
            f"keys between frames (at {grid:.9g}) that the bone curves do not share evenly "
            "spaced: bake the action on whole frames (Pose > Animation > Bake Action) first",
            getattr(action, "name", None),
        )
    return grid


def key_grid(action: Any, slot: Any) -> tuple[np.ndarray, float] | float:
    """The frames the bone curves of ``action`` for ``slot`` are keyed on, and their spacing
    (scene frames): each whole frame from the first key to the last when every key is on a
    whole frame; else the key times all bone curves share when they are evenly spaced (an
    importer's bake at another rate than the scene's: a 29.97 fps FBX file, a BVH file
    imported with Scale FPS), the other curves' keys among them (a constant keyed at the
    ends alone). Otherwise the time of a key off every such grid (a float);
    an empty array without bone keys."""
    times = [
        _keys(curve)[:, 0]
        for props in _bone_curves(action_fcurves(action, slot)).values()
        for curves in props.values()
        for curve in curves.values()
    ]
    times = [t for t in times if len(t)]
    if not times:
        return np.zeros(0), 1.0
    first = min(float(t[0]) for t in times)
    last = max(float(t[-1]) for t in times)
    if all(_on_frames(t) for t in times):
        return np.arange(round(first), round(last) + 1.0), 1.0
    # the densest curve's keys, evenly spaced from the first key to the last, where every
    # curve's keys lie on them (Blender's glTF importer keys a constant location or scale
    # at the ends alone, beside rotations on every sample of a 30 fps file in a 24 fps
    # scene: those had been refused)
    shared = max(times, key=len)
    if len(shared) > 1 and shared[0] == first and shared[-1] == last:
        step = (last - first) / (len(shared) - 1)
        grid = first + step * np.arange(len(shared))
        on_grid = all(
            np.abs(
                t - grid[np.clip(np.rint((t - first) / step).astype(int), 0, grid.size - 1)]
            ).max()
            <= GRID_TOLERANCE * step
            for t in times
        )
        if np.abs(shared - grid).max() <= GRID_TOLERANCE * step and on_grid:
            return shared, step
    return next(float(t[np.abs(t - np.round(t)) > ON_FRAME][0]) for t in times if not _on_frames(t))


def _on_frames(times: np.ndarray) -> bool:
    """Whether every key time of ``times`` is on a whole frame (within :data:`ON_FRAME`)."""
    return bool(np.all(np.abs(times - np.round(times)) <= ON_FRAME))


def _keys(curve: Any) -> np.ndarray:
    """``(n, 2)`` float64 (frame, value) of a curve's keys, in frame order."""
    points = curve.keyframe_points
    co = np.empty(2 * len(points), dtype=np.float32)
    points.foreach_get("co", co)
    return co.reshape(-1, 2).astype(np.float64)


def _baked_at(keys: np.ndarray, frames: np.ndarray) -> np.ndarray | None:
    """Indices of the keys at ``frames`` when there is a key at every one of them."""
    if not len(keys):
        return None
    at = np.minimum(np.searchsorted(keys[:, 0], frames - ON_FRAME), len(keys) - 1)
    return at if np.all(np.abs(keys[at, 0] - frames) <= ON_FRAME) else None


def _sample(curve: Any, frames: np.ndarray, where: str) -> np.ndarray:
    """A curve's values at ``frames``: the keys' own values where it has a key at every
    frame, else Blender's evaluation frame by frame (interpolation and handles applied)."""
    if any(modifier.type != "CYCLES" for modifier in curve.modifiers):
        kinds = ", ".join(sorted({m.type.title() for m in curve.modifiers}))
        raise MotionError(
            f"{where}: curve {curve.data_path}[{curve.array_index}] has modifiers ({kinds}); "
            "apply or remove them before cleaning"
        )
    keys = _keys(curve)
    at = _baked_at(keys, frames)
    if at is not None:
        return keys[at, 1]
    return np.array([curve.evaluate(frame) for frame in frames.tolist()])


# ----------------------------------------------------------------------------- rotations


def _from_matrix(m: np.ndarray) -> np.ndarray:
    """Unit quaternions of rotation matrices ``(..., 3, 3)`` (Shepperd's method: the
    largest of ``1 + trace`` and the diagonal picks the well-conditioned formula)."""
    m = np.asarray(m, dtype=np.float64)
    t = np.trace(m, axis1=-2, axis2=-1)
    d0, d1, d2 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    a, b, c = m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]
    e, f, g = m[..., 0, 1] + m[..., 1, 0], m[..., 0, 2] + m[..., 2, 0], m[..., 1, 2] + m[..., 2, 1]
    candidates = np.stack(
        [
            np.stack([1 + t, a, b, c], axis=-1),
            np.stack([a, 1 + 2 * d0 - t, e, f], axis=-1),
            np.stack([b, e, 1 + 2 * d1 - t, g], axis=-1),
            np.stack([c, f, g, 1 + 2 * d2 - t], axis=-1),
        ],
        axis=-2,
    )
    which = np.argmax(np.stack([t, d0, d1, d2], axis=-1), axis=-1)
    q = np.take_along_axis(candidates, which[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return q * np.where(q[..., :1] < 0.0, -1.0, 1.0)


def _euler_order(mode: str) -> tuple[str, list[int]]:
    """The BVH order of a Blender Euler mode and where its angles sit in ``(x, y, z)``."""
    order = mode[::-1]
    return order, ["XYZ".index(axis) for axis in order]


def _basis_quaternions(values: np.ndarray, mode: str) -> np.ndarray:
    """Quaternions ``(F, 4)`` of a pose bone's rotation property values ``(F, n)``."""
    if mode == "QUATERNION":
        norm = np.linalg.norm(values, axis=-1, keepdims=True)
        return np.where(norm > 0.0, values / np.where(norm > 0.0, norm, 1.0), [1.0, 0, 0, 0])
    if mode == "AXIS_ANGLE":
        length = np.linalg.norm(values[:, 1:], axis=-1, keepdims=True)
        axis = np.where(length > 0.0, values[:, 1:] / np.where(length > 0.0, length, 1.0), 0.0)
        return quat.from_axis_angle(axis, np.where(length[:, 0] > 0.0, values[:, 0], 0.0))
    order, at = _euler_order(mode)
    return quat.from_euler(np.rad2deg(values[:, at]), order)


def _continued_signs(q: np.ndarray, before: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """Quaternion property values for ``q`` ``(F, 4)``: kept samples (``kept`` ``(F,)``) as
    read in ``before``; each run of changed ones sign-continuous, on the sign that meets the
    kept sample before it (else the one after it; a clip changed throughout, the first
    value read). Chosen per frame against the value read, the sign had been a coin toss
    where a repair turned a frame far from it (a thumb's curve: 13 sign changes read, 127
    written)."""
    c = quat.continuous(q)
    frame = np.arange(len(q))
    last = np.maximum.accumulate(np.where(kept, frame, -1))
    after = np.minimum.accumulate(np.where(kept, frame, len(q))[::-1])[::-1]
    ref = np.where(last >= 0, last, np.where(after < len(q), after, 0))
    sign = np.where(np.einsum("fi,fi->f", c[ref], before[ref]) < 0.0, -1.0, 1.0)
    return c * sign[:, None]


def _property_values(q: np.ndarray, mode: str, before: np.ndarray) -> np.ndarray:
    """A pose bone's rotation property values ``(F, n)`` for quaternions ``q`` ``(F, 4)``,
    continuing the values ``before`` ``(F, n)`` read: the quaternion sign nearest them, the
    Euler triple that continues their curve (samples whose rotation did not change keep
    their values bit for bit), the axis direction nearest theirs."""
    was = _basis_quaternions(before, mode)
    kept = same_rotations(q, was)
    if mode == "QUATERNION":
        out = _continued_signs(q, before, kept)
    elif mode == "AXIS_ANGLE":
        q = q * np.where(np.einsum("fi,fi->f", q, was) < 0.0, -1.0, 1.0)[:, None]
        sine = np.linalg.norm(q[:, 1:], axis=-1)
        old_axis = (
            before[:, 1:] / np.maximum(np.linalg.norm(before[:, 1:], axis=-1), 1e-300)[:, None]
        )
        axis = np.where(sine[:, None] > 0.0, q[:, 1:] / np.maximum(sine, 1e-300)[:, None], old_axis)
        angle = 2.0 * np.arctan2(sine, q[:, 0])
        flip = np.einsum("fi,fi->f", axis, old_axis) < 0.0
        out = np.concatenate(
            [np.where(flip, -angle, angle)[:, None], np.where(flip[:, None], -axis, axis)], axis=-1
        )
    else:
        order, at = _euler_order(mode)
        reference = np.rad2deg(before[:, at])
        angles = continuous_euler(q[:, None], order, reference[:, None], kept[:, None])[:, 0]
        # a curve, not a file's text: a step into or out of a changed sample takes the whole
        # turns that keep it within half a turn, a step between kept ones stays the curve
        # read's (a run that winds once more than it, through a repaired flip near gimbal
        # lock, moves the kept samples after it by a turn, never the pose)
        touched = (~kept[:-1] | ~kept[1:])[:, None]
        turns = np.where(touched, np.round(np.diff(angles, axis=0) / 360.0), 0.0)
        angles[1:] -= 360.0 * np.cumsum(turns, axis=0)
        out = np.empty_like(angles)
        out[:, at] = np.deg2rad(angles)
        turns = np.zeros_like(out)
        turns[:, at] = np.round((angles - reference) / 360.0)
        out[kept] = before[kept] + 2.0 * np.pi * turns[kept]  # (bit for bit where 0 turns)
        return out
    out[kept] = before[kept]
    return out


# ----------------------------------------------------------------------------- reading


def _bones_parents_first(armature: Any) -> list[Any]:
    order: list[Any] = []
    stack = [bone for bone in armature.bones if bone.parent is None][::-1]
    while stack:
        bone = stack.pop()
        order.append(bone)
        stack.extend(list(bone.children)[::-1])
    return order


def _rest_matrices(bones: list[Any]) -> np.ndarray:
    """``(J, 4, 4)`` rest matrices (``bone.matrix_local``: armature space)."""
    return np.array([np.array(b.matrix_local, dtype=np.float64) for b in bones]).reshape(-1, 4, 4)


def rest_quaternions(obj: Any, names: list[str]) -> np.ndarray:
    """``(J, 4)`` rest orientations ``B`` of the named bones of armature object ``obj``."""
    bones = [obj.data.bones[name] for name in names]
    return _from_matrix(_rest_matrices(bones)[:, :3, :3])


def _declared_channels(bone: Any) -> list[str]:
    """The BVH channels a bone's :data:`CHANNELS_PROPERTY` names (none when it has none,
    or names other than BVH's three positions and three rotations)."""
    declared = bone.get(CHANNELS_PROPERTY)
    names = declared.split() if isinstance(declared, str) else []
    known = {f"{axis}{kind}" for axis in "XYZ" for kind in ("position", "rotation")}
    return names if set(names) <= known and len(set(names)) == len(names) else []


def read_action(
    obj: Any, action: Any, slot: Any, frames: np.ndarray, frame_time: float
) -> ActionClip:
    """The motion ``action`` (animating ``slot`` of armature object ``obj``) gives its
    bones at scene ``frames``, ``frame_time`` seconds apart.

    A bone's rotation or location curves make its rotation or position channels, unless
    they stay at the rest (within :data:`KEEP_DEGREES`, :data:`REST_LOCATION`); the
    components of a property without a curve take the pose bone's current value. A bone
    without curves keeps its current pose (channels when it is not the rest). Bone
    scale, constraints and drivers are not read. MotionError when a curve has modifiers
    other than Cycles (the keys would not be what plays)."""
    frames = np.asarray(frames, dtype=np.float64)
    where = getattr(action, "name", "action")
    bones = _bones_parents_first(obj.data)
    names = [bone.name for bone in bones]
    index = {name: j for j, name in enumerate(names)}
    parents = np.array([index[b.parent.name] if b.parent else -1 for b in bones], dtype=np.intp)
    matrices = _rest_matrices(bones)
    heads = matrices[:, :3, 3]
    rest = _from_matrix(matrices[:, :3, :3])
    offsets = heads - np.where(parents[:, None] >= 0, heads[np.maximum(parents, 0)], 0.0)
    reach = float(np.linalg.norm(offsets, axis=-1).sum()) or 1.0
    curves = _bone_curves(action_fcurves(action, slot))
    n_frames, n_joints = len(frames), len(bones)
    basis = np.tile([1.0, 0.0, 0.0, 0.0], (n_frames, n_joints, 1))
    translations = np.zeros((n_frames, n_joints, 3))
    tracks, channels, rotation_values, location_values = [], [], [], []
    for j, bone in enumerate(bones):
        pose_bone = obj.pose.bones[bone.name]
        mode = pose_bone.rotation_mode
        prop, width = _rotation_property(mode)
        mine = curves.get(bone.name, {})
        values = _values(mine.get(prop, {}), getattr(pose_bone, prop), width, frames, where)
        location = _values(mine.get("location", {}), pose_bone.location, 3, frames, where)
        basis[:, j] = _basis_quaternions(values, mode)
        # (a bone that stays at its rest, keyed or not, as an FBX import keys leaf bones,
        # has no rotation channels; location curves that stay at the rest, as an FBX import
        # keys on every bone, make no channels)
        rotates = bool(np.rad2deg(quat.angle(basis[:, j])).max(initial=0.0) >= KEEP_DEGREES)
        moves = (
            "location" in mine
            and not bone.use_connect
            and bool(np.abs(location).max() > REST_LOCATION * reach)
        )
        # a clip motionclean wrote names its joint's own channels, kept where they do not
        # move; a rotation or location keyed since is read all the same
        declared = _declared_channels(bone)
        rotates = rotates or any(name.endswith("rotation") for name in declared)
        moves = moves or any(name.endswith("position") for name in declared)
        order = _euler_order(mode)[0] if mode in EULER_MODES else "ZYX"
        names_of = [n for n in declared if n.endswith("position")] if moves else []
        if moves and not names_of:
            names_of = ["Xposition", "Yposition", "Zposition"]
        if rotates:
            names_of += [n for n in declared if n.endswith("rotation")] or [
                f"{axis}rotation" for axis in order
            ]
        if not rotates:  # at the rest: unturned, as a joint without rotation channels is
            basis[:, j] = (1.0, 0.0, 0.0, 0.0)
        if moves:  # (a connected bone's location is not played: at its rest)
            turned = 0.0 if bone.use_connect else quat.rotate(rest[j], location)
            translations[:, j] = offsets[j] + turned
        channels.append(tuple(names_of))
        tracks.append(BoneTrack(bone.name, mode, rotates, moves))
        rotation_values.append(values)
        location_values.append(location)
    rotations = quat.multiply(quat.multiply(rest, basis), quat.conjugate(rest))
    # a still leaf bone named *_end (an exporter's tip: Blender's FBX export adds them) is
    # its parent's end site, at its head; other leaves end at their tails (an importer's
    # guess where a file has no tips)
    tip = np.array(
        [
            not bone.children
            and bone.parent is not None
            and bone.name.lower().endswith(TIP_SUFFIX)
            and not channels[j]
            for j, bone in enumerate(bones)
        ],
        dtype=bool,
    )
    end_sites = {int(parents[j]): offsets[j].copy() for j in np.flatnonzero(tip)}
    end_sites.update(
        {
            j: np.array(bone.tail_local, dtype=np.float64) - heads[j]
            for j, bone in enumerate(bones)
            if not bone.children and not tip[j]
        }
    )
    end_sites.update({j: np.zeros(3) for j in end_sites if bones[j].get(END_SITE_AT_HEAD)})
    keep = np.flatnonzero(~tip)
    number = np.cumsum(~tip) - 1  # each kept bone's joint number
    motion = Motion(
        names=[names[j] for j in keep],
        parents=np.where(parents[keep] >= 0, number[np.maximum(parents[keep], 0)], -1),
        offsets=offsets[keep],
        channels=[channels[j] for j in keep],
        frame_time=float(frame_time),
        rotations=quat.make_continuous(rotations[:, keep]) if n_frames else rotations[:, keep],
        translations=translations[:, keep],
        end_sites={int(number[j]): site for j, site in end_sites.items()},
        path=where,
    )
    return ActionClip(
        motion,
        frames,
        rest[keep],
        [tracks[j] for j in keep],
        [rotation_values[j] for j in keep],
        [location_values[j] for j in keep],
    )


def _values(
    curves: dict[int, Any], current: Any, width: int, frames: np.ndarray, where: str
) -> np.ndarray:
    out = np.empty((len(frames), width))
    for axis in range(width):
        curve = curves.get(axis)
        out[:, axis] = _sample(curve, frames, where) if curve is not None else current[axis]
    return out


# ----------------------------------------------------------------------------- writing


def write_action(clip: ActionClip, cleaned: Motion, action: Any, slot: Any) -> WriteSummary:
    """Write ``cleaned`` (the clip's motion after a pipeline, same skeleton and frames) into
    ``action`` (the clip's own, or a copy of it) for ``slot``.

    Baked curves (a key on every frame) get new key values, their handles moved with them.
    A keyed curve keeps its keys where the bone moved by less than :data:`KEEP_DEGREES`
    (:data:`KEEP_LENGTH` for locations); a key where it moved more takes the new value, and
    the stretch between two keys is keyed on every frame when a frame in it or a key at
    its ends moved. The keys that stay keep their handles (made free where recomputing
    the automatic ones would move them), so the curve plays what it played there. Curves
    are created, keyed on every frame, for bones that have none."""
    motion = clip.motion
    if cleaned.names != motion.names or cleaned.n_frames != motion.n_frames:
        raise MotionError("the cleaned clip has other joints or frames than the action", None)
    fcurves = action_fcurves(action, slot, create=True)
    existing = _bone_curves(fcurves)
    moved = np.rad2deg(quat.angle_between(cleaned.rotations, motion.rotations))
    reach = float(np.linalg.norm(motion.offsets, axis=-1).sum()) or 1.0
    shifted = np.linalg.norm(cleaned.translations - motion.translations, axis=-1)
    basis = quat.multiply(quat.multiply(quat.conjugate(clip.rest), cleaned.rotations), clip.rest)
    summary = WriteSummary()
    for j, track in enumerate(clip.tracks):
        jobs = []
        if track.rotation:
            prop, _ = _rotation_property(track.mode)
            values = _property_values(basis[:, j], track.mode, clip.rotation_values[j])
            # (a key moved by whole turns is written too: its pose is the same, its value not)
            turned = np.any(np.abs(values - clip.rotation_values[j]) > np.pi, axis=1)
            jobs.append(
                (prop, values, clip.rotation_values[j], (moved[:, j] >= KEEP_DEGREES) | turned)
            )
        if track.location:
            location = quat.rotate(
                quat.conjugate(clip.rest[j]), cleaned.translations[:, j] - motion.offsets[j]
            )
            same = np.all(cleaned.translations[:, j] == motion.translations[:, j], axis=-1)
            location[same] = clip.location_values[j][same]  # unchanged: the values read
            jobs.append(
                (
                    "location",
                    location,
                    clip.location_values[j],
                    shifted[:, j] >= KEEP_LENGTH * reach,
                )
            )
        for prop, values, before, changed in jobs:
            curves = existing.get(track.name, {}).get(prop, {})
            for axis in range(values.shape[1]):
                curve = curves.get(axis)
                if curve is None:
                    if not changed.any() and np.array_equal(values[:, axis], before[:, axis]):
                        continue
                    curve = new_fcurve(fcurves, bone_path(track.name, prop), axis, track.name)
                    summary.curves_created += 1
                    _write_keys(curve, clip.frames, values[:, axis], np.ones_like(changed), summary)
                else:
                    _write_keys(curve, clip.frames, values[:, axis], changed, summary)
    return summary


def _write_keys(
    curve: Any, frames: np.ndarray, values: np.ndarray, changed: np.ndarray, summary: WriteSummary
) -> None:
    """Write ``values`` at ``frames`` into ``curve`` (see :func:`write_action`); ``changed``
    marks the frames where the bone moved."""
    keys = _keys(curve)
    at = _baked_at(keys, frames)
    if at is not None:  # baked: new values in place
        new = keys[:, 1].copy()
        new[at] = values
        _set_values(curve, keys, new)
        summary.keys_set += int(np.count_nonzero(np.float32(new) != np.float32(keys[:, 1])))
        return
    if not len(keys):  # a new curve: a key on every frame
        _add_keys(curve, frames, values, ["LINEAR"] * len(frames))
        summary.keys_added += len(frames)
        curve.update()
        return
    # Keyed: a key that moved takes its new value; a stretch between two keys (or before
    # the first, after the last) is keyed on every frame when a frame in it or a key at
    # its ends moved. Elsewhere the keys and their handles stay as they were, so the curve
    # plays what it played (within the keep tolerance of the cleaned motion).
    key_frames = keys[:, 0]
    slot = np.searchsorted(key_frames, frames + ON_FRAME, side="right")  # keys at or before
    on_key = (slot > 0) & (np.abs(key_frames[np.maximum(slot - 1, 0)] - frames) <= ON_FRAME)
    update = on_key & changed
    moved_key = np.zeros(len(keys), dtype=bool)
    moved_key[slot[update] - 1] = True
    stretch = np.zeros(len(keys) + 1, dtype=bool)  # stretch s: between keys s-1 and s
    stretch[slot[changed & ~on_key]] = True
    stretch[1:] |= moved_key
    stretch[:-1] |= moved_key
    fill = ~on_key & stretch[slot]
    handles = [_handles(curve, side) for side in ("handle_left", "handle_right")]
    new = keys[:, 1].copy()
    new[slot[update] - 1] = values[update]
    _set_values(curve, keys, new)
    summary.keys_set += int(np.count_nonzero(np.float32(new) != np.float32(keys[:, 1])))
    if fill.any():
        # each added key plays as the key that starts its stretch (the first key before it)
        kinds = [point.interpolation for point in curve.keyframe_points]
        _add_keys(curve, frames[fill], values[fill], [kinds[max(k - 1, 0)] for k in slot[fill]])
        summary.keys_added += int(np.count_nonzero(fill))
        curve.update()
        _keep_handles(curve, key_frames[~moved_key], [h[~moved_key] for h in handles])


def _handles(curve: Any, side: str) -> np.ndarray:
    points = curve.keyframe_points
    flat = np.empty(2 * len(points), dtype=np.float32)
    points.foreach_get(side, flat)
    return flat.reshape(-1, 2)


def _keep_handles(curve: Any, frames: np.ndarray, handles: list[np.ndarray]) -> None:
    """Give the keys at ``frames`` their former handles where recomputing the automatic
    ones (their neighbours changed) moved them: as free handles, the Bezier stretches
    between unchanged keys keep their shape."""
    points = curve.keyframe_points
    now = _keys(curve)[:, 0]
    at = np.searchsorted(now, frames)
    for side, before in zip(("handle_left", "handle_right"), handles, strict=True):
        current = _handles(curve, side)
        for index, old in zip(
            at[np.any(current[at] != before, axis=1)].tolist(),
            before[np.any(current[at] != before, axis=1)],
            strict=True,
        ):
            point = points[index]
            point.handle_left_type = point.handle_right_type = "FREE"
            setattr(point, side, old.tolist())


def _add_keys(
    curve: Any, frames: np.ndarray, values: np.ndarray, interpolations: list[str]
) -> None:
    """Add keys at ``frames`` with ``values`` and ``interpolations`` (one per key; automatic
    clamped handles)."""
    points = curve.keyframe_points
    start = len(points)
    points.add(len(frames))
    co = np.empty(2 * len(points), dtype=np.float32)
    points.foreach_get("co", co)
    co[2 * start :: 2] = frames
    co[2 * start + 1 :: 2] = values
    points.foreach_set("co", co)
    for point, kind in zip(list(points)[start:], interpolations, strict=True):
        point.interpolation = kind
        point.handle_left_type = point.handle_right_type = "AUTO_CLAMPED"


def _set_values(curve: Any, keys: np.ndarray, new: np.ndarray) -> None:
    """Give a curve's keys the values ``new``, moving each key's handles with it."""
    points = curve.keyframe_points
    delta = (np.float32(new) - np.float32(keys[:, 1])).astype(np.float32)
    if not delta.any():
        return
    co = np.empty(2 * len(points), dtype=np.float32)
    points.foreach_get("co", co)
    co[1::2] = new
    points.foreach_set("co", co)
    for handle in ("handle_left", "handle_right"):
        xy = np.empty(2 * len(points), dtype=np.float32)
        points.foreach_get(handle, xy)
        xy[1::2] += delta
        points.foreach_set(handle, xy)
    curve.update()
