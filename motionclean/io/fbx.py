"""FBX files through Blender: its own importer and exporter, run in ``bpy``.

``bpy`` (Blender as a Python module) is the optional ``[blender]`` extra; without it, reading
or writing an FBX file is a :class:`~motionclean.core.errors.UsageError` naming the extra.
Each load or save starts from Blender's factory settings with an empty scene, so nothing of
the user's Blender setup takes part (and it is refused in a Blender with windows, whose
scene is someone's work).

Reading imports the file (keys at ``time x fps``, no frame offset), takes its one armature
and the action it plays, and maps the pose bones to a Motion as :mod:`.blender_action`
does: joints named after the bones, parents, rest offsets, rotations local to the parent in
the BVH sense, translations of the bones whose location is animated. Writing a clip read
from an FBX file imports that file again, writes the clip into its action (curves the clip
did not change keep their keys) and exports the scene; any other clip becomes an armature
built from its skeleton, turned so its up axis is Blender's, with a quaternion curve per
rotating joint and location curves where it has position channels. The exporter writes the
rest pose as the bones' own transforms (the action plays from an NLA strip, which is off at
the frame exported as the rest) and a key on every frame; a frame time within 1e-4 of a
whole frame rate (BVH's ``0.0083333``) is written as that rate. Custom properties are
written; a file whose armature has several takes is refused (naming them).
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core import kinematics, quat
from ..core.errors import MotionError, UsageError
from ..core.motion import Motion
from .blender_action import (
    CHANNELS_PROPERTY,
    END_SITE_AT_HEAD,
    ActionClip,
    BoneTrack,
    action_fcurves,
    all_fcurves,
    key_grid,
    key_range,
    read_action,
    rest_quaternions,
    write_action,
)
from .files import read_regular_file

__all__ = ["EXTRA", "FbxSource", "fbx_bytes", "load_fbx", "mend_importer"]

#: How to get ``bpy``: named in the error when it is missing.
EXTRA = "pip install 'motionclean[blender]'"
#: Longest object name looked for before an FBX class name (bytes).
MAX_NAME_BYTES = 1024
#: A line of a Python traceback naming the exception raised (``AttributeError: ...``).
PYTHON_ERROR = re.compile(r"^\s*[A-Za-z_][\w.]*(Error|Exception): ")
#: Frame rates within this relative distance of a whole number are written as that number.
WHOLE_RATE = 1e-4
#: Importer and exporter settings: keys at FBX time x fps, a key on every frame, no take
#: per action (tip bones added to a new armature only, :func:`fbx_bytes`).
IMPORT_OPTIONS = {"anim_offset": 0.0}
EXPORT_OPTIONS = {
    "bake_anim": True,
    "bake_anim_use_all_bones": True,
    "bake_anim_use_nla_strips": False,
    "bake_anim_use_all_actions": False,
    "bake_anim_force_startend_keying": True,
    "bake_anim_simplify_factor": 0.0,
    "add_leaf_bones": False,
    "use_custom_props": True,  # (the exporter's default drops them: Unity's attributes too)
    "path_mode": "COPY",  # images embedded in the file (a Mixamo character's skin) ...
    "embed_textures": True,  # ... stay embedded (the default wrote a path to nothing)
}


@dataclass(frozen=True, repr=False)
class FbxSource:
    """The FBX file a clip was read from (its bytes as read): written again with the new
    motion, so that everything else in it (meshes, rest pose, other curves) stays."""

    data: bytes
    armature: str
    notes: tuple[str, ...] = ()


def _bpy(doing: str, path: str | os.PathLike | None) -> Any:
    """The ``bpy`` module, or a UsageError naming the extra that brings it."""
    try:
        with _quiet():
            import bpy
    except ImportError:
        raise UsageError(f"{doing} FBX needs Blender's bpy module: {EXTRA}", path) from None
    if not bpy.app.background:  # a Blender with windows: its scene is the user's work
        raise UsageError(
            f"{doing} FBX starts Blender from an empty scene, which would replace the open "
            "one; inside Blender use File > Import/Export and the motionclean panel",
            path,
        )
    return bpy


@contextlib.contextmanager
def _quiet() -> Iterator[list[str]]:
    """Send what Blender prints (C-level stdout and stderr) to a temporary file for the
    duration; the list yielded holds its lines afterwards (for an error's reason)."""
    printed: list[str] = []
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile(mode="w+b") as sink:
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield printed
        finally:
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            sink.seek(0)
            printed.extend(sink.read().decode("utf-8", "replace").splitlines())


def _reason(printed: list[str], error: BaseException | None = None) -> str:
    """The last error Blender printed (or raised), on one line: of a Python traceback in
    it (an add-on's failure), its last line, the exception."""
    lines = [line.strip() for line in printed if "error" in line.lower()]
    text = str(error) if error is not None else (lines[-1] if lines else "")
    raised = [line.strip() for line in text.splitlines() if PYTHON_ERROR.match(line)]
    if "Traceback (most recent call last)" in text and raised:
        text = f"Blender's add-on failed: {raised[-1]}"
    return " ".join(text.strip().removeprefix("Error:").split()) or "Blender's importer gave up"


def mend_importer(bpy: Any) -> None:
    """Blender 5.0's FBX importer sets ``cycles.cast_shadow`` on each light it reads, a
    property Cycles no longer has: every file with a light failed. Given back as a plain
    property (nothing reads it) where it is missing, until the next factory reset."""
    light = bpy.data.lights.new("motionclean-probe", "POINT")
    try:
        settings: Any = type(getattr(light, "cycles", None))
        if hasattr(settings, "bl_rna") and "cast_shadow" not in settings.bl_rna.properties:
            settings.cast_shadow = bpy.props.BoolProperty(default=True)
    finally:
        bpy.data.lights.remove(light)


def _empty_scene(bpy: Any) -> None:
    with _quiet():
        bpy.ops.wm.read_factory_settings(use_empty=True)


def _import(bpy: Any, file: Path, path: str | os.PathLike | None) -> Any:
    """Import FBX ``file`` into an empty scene; its one armature object (errors name
    ``path``)."""
    _empty_scene(bpy)
    mend_importer(bpy)
    with _quiet() as printed:
        failure: BaseException | None = None
        try:
            done = bpy.ops.import_scene.fbx(filepath=str(file), **IMPORT_OPTIONS)
        except (RuntimeError, ValueError, TypeError, KeyError, IndexError) as error:
            done, failure = None, error
    if failure is not None or "FINISHED" not in done:
        reason = _reason(printed, failure).replace(f"'{file}'", "").replace(str(file), "")
        raise MotionError(f"cannot read FBX: {' '.join(reason.split())}", path)
    armatures = [obj for obj in bpy.context.scene.objects if obj.type == "ARMATURE"]
    if not armatures:
        raise MotionError("no armature (skeleton) in the FBX file", path)
    if len(armatures) > 1:
        names = ", ".join(repr(obj.name) for obj in armatures[:4])
        raise MotionError(
            f"{len(armatures)} armatures ({names}); FBX files with one are read", path
        )
    obj = armatures[0]
    data = obj.animation_data
    if data is None or data.action is None:
        raise MotionError(f"armature {obj.name!r} has no animation", path)
    _whole_frames(bpy)
    return obj


def _whole_frames(bpy: Any) -> None:
    """Put the keys of a file with a fractional frame rate back on the file's frames.

    Blender's importer sets the scene to the file's rate (``fps / fps_base``, e.g. 120 /
    0.999996 for 120.00048 fps) but places keys at ``time x fps``, so frame ``k`` of the
    file lands at ``k x fps_base`` (the exporter writes frame ``k`` at ``k x fps_base /
    fps``, as the scene plays it). Keys are moved back to ``time x fps / fps_base``: whole
    frames, the same times as the file when written again."""
    base = float(bpy.context.scene.render.fps_base)
    if base == 1.0:
        return
    for action in bpy.data.actions:
        for curve in all_fcurves(action):
            points = curve.keyframe_points
            for name in ("co", "handle_left", "handle_right"):
                flat = np.empty(2 * len(points), dtype=np.float64)
                points.foreach_get(name, flat)
                frames = flat[0::2] / base
                if name == "co":  # keys on whole frames (float32 rounding aside)
                    whole = np.round(frames)
                    frames = np.where(np.abs(frames - whole) < 1e-3, whole, frames)
                flat[0::2] = frames
                points.foreach_set(name, flat)
            curve.update()


def _frame_time(scene: Any) -> float:
    return float(scene.render.fps_base) / float(scene.render.fps)


def _read(
    bpy: Any, data: bytes, path: str | os.PathLike | None
) -> tuple[Any, ActionClip, tuple[str, ...]]:
    """Import FBX ``data`` (the file at ``path``, named in errors); the armature, its
    action read over the key frames (:func:`fbx_frames`) and what the reading notes."""
    with tempfile.TemporaryDirectory(prefix="motionclean-fbx-") as folder:
        copy = Path(folder) / "clip.fbx"
        copy.write_bytes(data)
        obj = _import(bpy, copy, path)
    takes = _takes(data, obj, bpy.data.actions)
    if len(takes) > 1:  # (the armature plays one; the others would not be written again)
        names = ", ".join(repr(take) for take in takes[:4]) + (", ..." if len(takes) > 4 else "")
        raise MotionError(
            f"{len(takes)} takes (AnimStacks: {names}); FBX files with one take are read: "
            "export each take to a file of its own",
            path,
        )
    animation = obj.animation_data
    frames, step, notes = fbx_frames(animation.action, animation.action_slot)
    if not frames.size:
        raise MotionError(f"armature {obj.name!r} has no keys", path)
    clip = read_action(
        obj,
        animation.action,
        animation.action_slot,
        frames,
        step * _frame_time(bpy.context.scene),
    )
    return obj, clip, notes


def fbx_frames(action: Any, slot: Any) -> tuple[np.ndarray, float, tuple[str, ...]]:
    """The frames an FBX file's action is read at and their spacing (scene frames), as the
    panel reads an action (:func:`~.blender_action.key_frames`), and a note where that
    cannot be: keys between frames that the bone curves do not share evenly spaced (a
    Mixamo export's 0.1-frame keys on some curves) are read on the whole frames from the
    first key to the last, as Blender plays them; the file is written back baked on whole
    frames, as every FBX written is."""
    grid = key_grid(action, slot)
    if not isinstance(grid, float):
        return (*grid, ())
    span = key_range(action, slot)
    assert span is not None  # (a key off the grid: there are keys)
    note = (
        "keys between frames that the bone curves do not share evenly spaced: read on "
        "whole frames, as Blender plays them (written back baked on them)"
    )
    return np.arange(span[0], span[1] + 1.0), 1.0, (note,)


def load_fbx(path: str | os.PathLike) -> Motion:
    """Read the animation of the one armature in an FBX file (see the module notes).

    A path that names no regular file is said first (MotionError: no extra would read
    it); then, before anything is said of the file's content (an empty file too), a
    missing ``bpy`` (UsageError naming the ``[blender]`` extra: exit code 2)."""
    data, _ = read_regular_file(Path(path))
    bpy = _bpy("reading", path)
    if not data:  # (Blender's importer calls an empty file ASCII FBX)
        raise MotionError("empty file", path)
    obj, clip, notes = _read(bpy, data, path)
    motion = clip.motion
    motion.path = os.fspath(path)
    motion.source = FbxSource(data, obj.name, notes)
    return motion


def fbx_bytes(motion: Motion) -> bytes:
    """The FBX file of ``motion``, written by Blender's exporter (see the module notes)."""
    bpy = _bpy("writing", None)
    source = motion.source
    if isinstance(source, FbxSource):
        obj, clip, _ = _read(bpy, source.data, motion.path)
        take = _take_name(source.data, obj)
        if clip.motion.names != motion.names:
            raise MotionError(f"the clip's joints are not the bones of {motion.path}")
        if clip.motion.n_frames == motion.n_frames and np.isclose(
            clip.motion.frame_time, motion.frame_time, rtol=1e-9, atol=0.0
        ):
            animation = obj.animation_data
            write_action(clip, motion, animation.action, animation.action_slot)
        else:  # resampled: new frames and rate
            _clear_bone_curves(obj)
            _write_new(bpy, obj, motion, clip.frames[0] if clip.frames.size else 1.0)
    else:
        _empty_scene(bpy)
        obj = _build_armature(bpy, motion)
        _write_new(bpy, obj, motion, 0.0)
        take = obj.name
    bpy.context.scene.name = take  # the exporter names the take (AnimStack) after the scene
    with tempfile.TemporaryDirectory(prefix="motionclean-fbx-") as folder:
        target = Path(folder) / "clip.fbx"
        # a new armature's end sites go out as tip bones (FBX has no bone tails; read back,
        # a tip is its parent's end site); a file's own armature keeps the bones it has
        _export(bpy, obj, target, tips=not isinstance(source, FbxSource))
        return target.read_bytes()


def _take_name(data: bytes, obj: Any) -> str:
    """The take (FBX AnimStack: Unity's ``Take 001``, Mixamo's ``mixamo.com``) the armature
    ``obj`` imported from ``data`` plays: of the stacks the file names, the one Blender's
    importer named its action after (``OBJECT|STACK`` or ``OBJECT|STACK|LAYER``; the
    longest, as names may hold ``|``); the object's name where none is."""
    played = _takes(data, obj, [obj.animation_data.action])
    return max(played, key=len) if played else obj.name


def _takes(data: bytes, obj: Any, actions: Any) -> list[str]:
    """The takes of FBX file ``data`` that animate the armature ``obj`` imported from it:
    those the importer named one of ``actions`` after (``OBJECT|STACK[|LAYER]``)."""
    names = [action.name for action in actions]
    return [
        stack
        for stack in dict.fromkeys(_anim_stacks(data))
        if any(
            name == f"{obj.name}|{stack}" or name.startswith(f"{obj.name}|{stack}|")
            for name in names
        )
    ]


def _anim_stacks(data: bytes) -> list[str]:
    """The names of a binary FBX file's AnimStack objects: each is a string property
    ``S``, its length (uint32, little-endian) and ``NAME\\x00\\x01AnimStack``."""
    names = []
    for found in re.finditer(rb"\x00\x01AnimStack", data):
        for start in range(found.start(), max(found.start() - MAX_NAME_BYTES, 5) - 1, -1):
            size = int.from_bytes(data[start - 4 : start], "little")
            if data[start - 5 : start - 4] == b"S" and size == found.end() - start:
                names.append(data[start : found.start()].decode("utf-8", "replace"))
                break
    return names


def _set_rate(scene: Any, frame_time: float) -> None:
    rate = 1.0 / frame_time
    whole = round(rate)
    if whole >= 1 and abs(rate - whole) <= WHOLE_RATE * rate:
        scene.render.fps, scene.render.fps_base = int(whole), 1.0
    else:
        scene.render.fps = max(1, int(np.ceil(rate)))
        scene.render.fps_base = scene.render.fps * frame_time


def _clear_bone_curves(obj: Any) -> None:
    data = obj.animation_data
    fcurves = action_fcurves(data.action, data.action_slot)
    for curve in [c for c in fcurves or () if c.data_path.startswith("pose.bones[")]:
        fcurves.remove(curve)


def _write_new(bpy: Any, obj: Any, motion: Motion, first_frame: float) -> None:
    """Key ``motion`` frame by frame from ``first_frame`` into the armature's action (made
    when it has none), every rotating bone in quaternion mode."""
    scene = bpy.context.scene
    _set_rate(scene, motion.frame_time)
    data = obj.animation_data_create()
    if data.action is None:
        action = bpy.data.actions.new(obj.name)
        data.action = action
        slots = getattr(action, "slots", None)
        if slots is not None and data.action_slot is None:
            data.action_slot = slots.new(obj.id_type, obj.name)
    layout = motion.layout
    tracks = []
    for j, name in enumerate(motion.names):
        pose_bone = obj.pose.bones[name]
        if layout.has_rotation[j]:
            pose_bone.rotation_mode = "QUATERNION"
        tracks.append(
            BoneTrack(
                name,
                pose_bone.rotation_mode,
                bool(layout.has_rotation[j]),
                bool(layout.has_position[j]),
            )
        )
    frames = first_frame + np.arange(motion.n_frames, dtype=np.float64)
    rest = rest_quaternions(obj, motion.names)
    basis = quat.multiply(quat.multiply(quat.conjugate(rest), motion.rotations), rest)
    # What the action held before: the rest pose (identity rotations, joints at their
    # offsets), so every channel of the clip is new; its own rotations guide the signs.
    at_rest = np.zeros_like(motion.rotations)
    at_rest[..., 0] = 1.0
    before = ActionClip(
        motion=motion.replace(
            rotations=at_rest,
            translations=np.broadcast_to(motion.offsets, motion.translations.shape).copy(),
            source_values=None,
            source_rotations=None,
        ),
        frames=frames,
        rest=rest,
        tracks=tracks,
        rotation_values=[basis[:, j] for j in range(motion.n_joints)],
        location_values=[np.zeros((motion.n_frames, 3)) for _ in motion.names],
    )
    write_action(before, motion, data.action, data.action_slot)
    scene.frame_start, scene.frame_end = int(frames[0]), int(np.ceil(frames[-1]))


def _build_armature(bpy: Any, motion: Motion) -> Any:
    """An armature of ``motion``'s skeleton at rest: a bone per joint from its head to its
    first child's (or its end site; a short bone along the parent's where they coincide),
    standing on Blender's ground (the clip's up axis turned to Z by the object). No tail
    lies on the head of a child with position channels: Blender's FBX importer connects a
    bone whose head is on its parent's tail, and a connected bone's location is ignored
    (a run's travel on ``Hips`` under a still ``joint_Root`` had played in place)."""
    name = Path(motion.path).stem if motion.path else "motion"
    armature = bpy.data.armatures.new(name)
    obj = bpy.data.objects.new(name, armature)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    heads = np.zeros((motion.n_joints, 3))
    for j, parent in enumerate(motion.parents):
        heads[j] = motion.offsets[j] + (heads[parent] if parent >= 0 else 0.0)
    lengths = np.linalg.norm(motion.offsets, axis=-1)
    short = 0.05 * (float(lengths.max()) if lengths.size and lengths.max() > 0 else 1.0)
    tails = heads.copy()
    reach = float(lengths.sum()) or 1.0
    # joints whose position channels leave their offset (constant ones at it, to the text's
    # precision, may connect: there is nothing to hide)
    moving = np.zeros(motion.n_joints, dtype=bool)
    placed = np.flatnonzero(motion.layout.has_position)  # (only these: few, as a rule)
    axes = motion.layout.position_columns[placed] >= 0
    away = np.abs(motion.translations[:, placed] - motion.offsets[placed]) * axes
    moving[placed] = away.max(axis=(0, 2), initial=0.0) > 1e-6 * reach
    for j in range(motion.n_joints):
        children = np.flatnonzero(motion.parents == j)
        ends = [
            motion.offsets[c]
            for c in children
            if np.linalg.norm(motion.offsets[c]) > 0 and not moving[c]
        ]
        if j in motion.end_sites and np.linalg.norm(motion.end_sites[j]) > 0:
            ends.append(motion.end_sites[j])
        if ends:
            tails[j] = heads[j] + ends[0]
        else:
            parent = motion.parents[j]
            along = motion.offsets[j] if np.linalg.norm(motion.offsets[j]) > 0 else (0.0, 1.0, 0.0)
            if parent >= 0 and np.linalg.norm(tails[parent] - heads[parent]) > 0:
                along = tails[parent] - heads[parent]
            tails[j] = heads[j] + short * np.asarray(along) / np.linalg.norm(along)
    with _quiet():
        bpy.ops.object.mode_set(mode="EDIT")
        bones = []
        for j, joint in enumerate(motion.names):
            bone = armature.edit_bones.new(joint)
            bone.head, bone.tail = heads[j].tolist(), tails[j].tolist()
            bones.append(bone)
        for j, parent in enumerate(motion.parents):
            if parent >= 0:
                bones[j].parent = bones[parent]
        bpy.ops.object.mode_set(mode="OBJECT")
    names = [bone.name for bone in armature.bones]
    if sorted(names) != sorted(motion.names):
        raise MotionError(
            "joint names that Blender cannot keep as bone names (too long or repeated)"
        )
    for j, site in motion.end_sites.items():
        if not np.any(site):
            armature.bones[motion.names[j]][END_SITE_AT_HEAD] = True
    for name, channels in zip(motion.names, motion.channels, strict=True):
        armature.bones[name][CHANNELS_PROPERTY] = " ".join(channels)
    # (its up, signed, onto Blender's +Z: a clip standing head down along -y had been
    # written upside down, its up's sign dropped)
    turn = kinematics.turn_up_onto(*kinematics.up_direction(motion), 2)
    if turn is not None:
        obj.rotation_mode = "QUATERNION"
        obj.rotation_quaternion = turn.tolist()
    return obj


def _export(bpy: Any, obj: Any, target: Path, tips: bool) -> None:
    """Export the scene with the action on an NLA strip that plays only over its frames,
    and the scene's current frame outside them: the bones' own transforms are the rest.
    ``tips``: a leaf bone's tail written as a bone of its own (``*_end``)."""
    scene = bpy.context.scene
    data = obj.animation_data
    action, slot = data.action, data.action_slot
    first, last = key_range(action, slot) or (scene.frame_start, scene.frame_end)
    scene.frame_start, scene.frame_end = first, max(last, first)
    track = data.nla_tracks.new()
    strip = track.strips.new(action.name, first, action)
    if slot is not None and hasattr(strip, "action_slot"):
        strip.action_slot = slot
    strip.extrapolation = "NOTHING"
    data.action = None
    for pose_bone in obj.pose.bones:
        pose_bone.matrix_basis.identity()
    scene.frame_set(first - 10)
    with _quiet() as printed:
        try:
            options = {**EXPORT_OPTIONS, "add_leaf_bones": tips}
            done = bpy.ops.export_scene.fbx(filepath=str(target), **options)
        except RuntimeError as error:
            raise MotionError(f"cannot write FBX: {_reason(printed, error)}") from None
    if "FINISHED" not in done or not target.is_file():
        raise MotionError(f"cannot write FBX: {_reason(printed)}")
