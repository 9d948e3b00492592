"""The Blender session the Blender tests read: run in Blender's Python (``bpy``), once.

    .venv-blender/bin/python tests/blender/session.py EXTENSION_ZIP CLIP WORK_DIR [operator]

Installs the built extension with Blender's own extension installer, cleans armatures
imported from CLIP (a corpus BVH) by Blender's BVH importer with the panel's operator, and
(unless ``operator`` is given: the bpy 4.5 run of ``make test-blender45``) takes FBX files
written by Blender's FBX exporter through the ``motionclean`` command line and loads the results
back with Blender's FBX importer. Nothing is asserted here: WORK_DIR receives
``results.json`` (figures, names, flags), the BVH files the command line is to clean and
``.npy`` arrays of what Blender holds, which ``test_blender.py`` compares. Run with
``BLENDER_USER_RESOURCES`` set to an empty folder, so the extension installs there.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import os
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import bpy
import numpy as np

import motionclean as mc
from motionclean.cli import main as cli_main
from motionclean.core import kinematics, quat
from motionclean.io.blender_action import (
    CHANNELS_PROPERTY,
    action_fcurves,
    key_range,
    new_fcurve,
    read_action,
)
from motionclean.io.fbx import fbx_frames, mend_importer
from motionclean.run.jobs import clean_motion
from motionclean.steps.pipeline import Pipeline

EXTENSION = "bl_ext.user_default.motionclean"
#: Rigs: name -> the BVH importer's rotate_mode (AXIS_ANGLE: quaternion curves turned into
#: axis-angle ones after the import).
RIGS = {"quaternion": "QUATERNION", "euler": "NATIVE", "euler_yxz": "YXZ", "axis": "AXIS_ANGLE"}
KNEES = ("LeftKnee", "RightKnee")


# ----------------------------------------------------------------------------- helpers


def clear_scene() -> None:
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for action in list(bpy.data.actions):
        bpy.data.actions.remove(action)
    for armature in list(bpy.data.armatures):
        bpy.data.armatures.remove(armature)


def import_rig(clip: Path, mode: str) -> Any:
    clear_scene()
    bpy.ops.import_anim.bvh(
        filepath=str(clip),
        update_scene_fps=True,
        update_scene_duration=True,
        rotate_mode="QUATERNION" if mode == "AXIS_ANGLE" else mode,
    )
    obj = bpy.context.view_layer.objects.active
    if mode == "AXIS_ANGLE":
        to_axis_angle(obj)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = rig_keys(obj)
    bpy.ops.ed.undo_push(message="Import rig")  # as the import from the menu would
    return obj


def to_axis_angle(obj: Any) -> None:
    """Replace every bone's quaternion curves with axis-angle ones, frame by frame."""
    data = obj.animation_data
    fcurves = action_fcurves(data.action, data.action_slot)
    for pose_bone in obj.pose.bones:
        path = f'pose.bones["{pose_bone.name}"].rotation_quaternion'
        curves = [fcurves.find(path, index=i) for i in range(4)]
        pose_bone.rotation_mode = "AXIS_ANGLE"
        if curves[0] is None:
            continue
        co = [keys(c) for c in curves]
        q = np.stack([c[:, 1] for c in co], axis=-1)
        q /= np.linalg.norm(q, axis=-1, keepdims=True)
        sine = np.linalg.norm(q[:, 1:], axis=-1)
        axis = np.where(
            sine[:, None] > 1e-12, q[:, 1:] / np.maximum(sine, 1e-12)[:, None], [0, 1, 0]
        )
        values = np.concatenate([2 * np.arctan2(sine, q[:, 0])[:, None], axis], axis=-1)
        for curve in curves:
            fcurves.remove(curve)
        target = f'pose.bones["{pose_bone.name}"].rotation_axis_angle'
        for i in range(4):
            curve = new_fcurve(fcurves, target, i, pose_bone.name)
            curve.keyframe_points.add(len(values))
            flat = np.empty(2 * len(values), dtype=np.float32)
            flat[0::2], flat[1::2] = co[0][:, 0], values[:, i]
            curve.keyframe_points.foreach_set("co", flat)
            curve.update()


def keys(curve: Any) -> np.ndarray:
    co = np.empty(2 * len(curve.keyframe_points), dtype=np.float32)
    curve.keyframe_points.foreach_get("co", co)
    return co.reshape(-1, 2)


def key_state(action: Any, slot: Any) -> dict[str, np.ndarray]:
    """Every curve's keys and handles, exactly as stored."""
    state = {}
    for curve in action_fcurves(action, slot):
        points = curve.keyframe_points
        arrays = []
        for name in ("co", "handle_left", "handle_right"):
            flat = np.empty(2 * len(points), dtype=np.float32)
            points.foreach_get(name, flat)
            arrays.append(flat)
        state[f"{curve.data_path}[{curve.array_index}]"] = np.concatenate(arrays)
    return state


def key_co(state: dict[str, np.ndarray], name: str) -> np.ndarray:
    """``(n, 2)`` (frame, value) of a curve's keys in a :func:`key_state`."""
    flat = state[name]
    return flat[: flat.size // 3].reshape(-1, 2)


def same_state(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


def rig_keys(obj: Any) -> tuple[int, int]:
    """The first and last key frames of the armature's action."""
    data = obj.animation_data
    found = key_range(data.action, data.action_slot)
    assert found is not None
    return found


def frame_time() -> float:
    scene = bpy.context.scene
    return scene.render.fps_base / scene.render.fps


def read(obj: Any, first: int, last: int) -> mc.Motion:
    """The motion the armature's action gives over frames ``first`` to ``last``."""
    data = obj.animation_data
    frames = np.arange(first, last + 1, dtype=np.float64)
    return read_action(obj, data.action, data.action_slot, frames, frame_time()).motion


def save_motion(out: Path, name: str, motion: mc.Motion) -> None:
    np.save(out / f"{name}_rotations.npy", motion.rotations)
    np.save(out / f"{name}_translations.npy", np.asarray(motion.translations))


def clean(**settings: Any) -> set[str]:
    """Set the panel's settings and press Clean Actions (one undo step, as from the UI)."""
    panel = bpy.context.scene.motionclean
    defaults = {"pipeline": "DEFAULT", "steps": "", "frames": "SCENE", "in_place": False}
    for key, value in {**defaults, **settings}.items():
        setattr(panel, key, value)
    return bpy.ops.motionclean.clean("EXEC_DEFAULT", True)


def printed(call: Any) -> tuple[Any, str, str]:
    """``call()`` and what it printed on standard output and standard error, read at file
    descriptors 1 and 2: a headless Blender prints an operator's warning and info reports,
    and its C code anything it says, there (C stdio flushed around the call)."""
    libc = ctypes.CDLL(None)
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        libc.fflush(None)
        os.dup2(out.fileno(), 1)
        os.dup2(err.fileno(), 2)
        try:
            result = call()
        finally:
            for stream in (sys.stdout, sys.stderr):
                stream.flush()
            libc.fflush(None)
            for fd, copy in enumerate(saved, start=1):
                os.dup2(copy, fd)
                os.close(copy)
        out.seek(0)
        err.seek(0)
        return result, out.read().decode(), err.read().decode()


# ----------------------------------------------------------------------------- checks


class Recorder:
    """A stand-in for a panel's UILayout, which only Blender's drawing code can make (a
    headless Blender draws no regions): it records what the panel asks to draw and checks
    each property against the real settings' RNA and each operator against the registered
    ones."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        self.drawn: list[str] = []

    def column(self, **_: Any) -> Recorder:
        return self

    row = box = column

    def prop(self, data: Any, name: str, **_: Any) -> None:
        if name not in data.bl_rna.properties:
            self.problems.append(f"no property {name!r} on {data}")
        self.drawn.append(f"prop:{name}")

    def label(self, text: str = "", **_: Any) -> None:
        self.drawn.append(f"label:{text}")

    def operator(self, idname: str, **_: Any) -> Any:
        module, name = idname.split(".")
        operator_type = getattr(bpy.types, f"{module.upper()}_OT_{name}", None)
        if operator_type is None:
            self.problems.append(f"no operator {idname}")
            return SimpleNamespace()
        self.drawn.append(f"operator:{idname}")
        return SimpleNamespace(**{p.identifier: None for p in operator_type.bl_rna.properties})


def draw_panels() -> dict:
    """Draw both panels with each pipeline choice; what they drew and any problem."""
    problems: list[str] = []
    drawn = []
    panel_types = [bpy.types.MOTIONCLEAN_PT_graph, bpy.types.MOTIONCLEAN_PT_dopesheet]
    settings = bpy.context.scene.motionclean
    for pipeline in ("DEFAULT", "FILE", "STEPS"):
        settings.pipeline = pipeline
        for panel_type in panel_types:
            layout = Recorder(problems)
            try:
                panel_type.draw(SimpleNamespace(layout=layout), bpy.context)
            except Exception:
                problems.append(traceback.format_exc())
            drawn.append(layout.drawn)
    settings.pipeline = "DEFAULT"
    return {
        "problems": problems,
        "drawn": drawn,
        "spaces": [t.bl_space_type for t in panel_types],
        "regions": [t.bl_region_type for t in panel_types],
        "categories": [t.bl_category for t in panel_types],
    }


def operator_checks(clip: Path, out: Path, results: dict) -> None:
    """Each rig: Clean Actions with the defaults (a new action); the quaternion rig is
    undone and redone."""
    for rig, mode in RIGS.items():
        obj = import_rig(clip, mode)
        first, last = rig_keys(obj)
        original = obj.animation_data.action
        slot = obj.animation_data.action_slot
        before_state = key_state(original, slot)
        before = read(obj, first, last)
        mc.save(before, out / f"{rig}_in.bvh")  # what Blender holds, for the command line
        done = clean()
        cleaned = obj.animation_data.action
        save_motion(out, f"{rig}_out", read(obj, first, last))
        entry = {
            "done": sorted(done),
            "modes": sorted({b.rotation_mode for b in obj.pose.bones}),
            "original": original.name,
            "result": cleaned.name,
            "original_untouched": same_state(before_state, key_state(original, slot)),
            "original_kept": original.use_fake_user,
            "frames": [first, last],
            "panel": dict(bpy.context.scene.motionclean.results[0].items()),
        }
        if rig == "quaternion":  # one undo step restores everything
            name = obj.name  # (undo replaces every datablock: look them up again)
            entry["undo_poll"] = bpy.ops.ed.undo.poll()
            bpy.ops.ed.undo()
            obj = bpy.data.objects[name]
            entry["after_undo"] = {
                "action": obj.animation_data.action.name,
                "actions": sorted(a.name for a in bpy.data.actions),
                "results": len(bpy.context.scene.motionclean.results),
                "untouched": same_state(
                    before_state,
                    key_state(obj.animation_data.action, obj.animation_data.action_slot),
                ),
            }
            bpy.ops.ed.redo()
            obj = bpy.data.objects[name]
            entry["after_redo"] = {"action": obj.animation_data.action.name}
        results["rigs"][rig] = entry


def range_checks(clip: Path, out: Path, results: dict) -> None:
    """The preview range, in place: keys outside it stay, inside them the command line's
    result for the same steps limited to the range."""
    obj = import_rig(clip, "QUATERNION")
    scene = bpy.context.scene
    scene.use_preview_range = True
    scene.frame_preview_start, scene.frame_preview_end = 150, 250
    action, slot = obj.animation_data.action, obj.animation_data.action_slot
    first, last = rig_keys(obj)
    before_state = key_state(action, slot)
    mc.save(read(obj, first, last), out / "range_in.bvh")
    done = clean(frames="PREVIEW", in_place=True)
    after_state = key_state(action, slot)
    outside = {}
    for name in before_state:
        co, new = key_co(before_state, name), key_co(after_state, name)
        keep = (co[:, 0] < 150) | (co[:, 0] > 250)
        outside[name] = bool(np.array_equal(co[keep], new[keep]))
    save_motion(out, "range_out", read(obj, first, last))
    results["range"] = {
        "done": sorted(done),
        "action": obj.animation_data.action.name,
        "clip_range": [150 - first, 250 - first],  # the range in the clip's frames
        "panel_frames": bpy.context.scene.motionclean.results[0].frames,
        "outside_untouched": all(outside.values()),
        "curves": len(outside),
        "inside_changed": sum(
            not np.array_equal(before_state[k], after_state[k]) for k in before_state
        ),
    }
    scene.use_preview_range = False


def subframe_checks(clip: Path, out: Path, results: dict) -> None:
    """Keys between whole frames: the clip (120 fps) imported with Scale FPS into a 24 fps
    scene, a key every 0.2 frames (as a 29.97 fps FBX file imported by Blender's importer
    has a key every 1.001 frames)."""
    clear_scene()
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 24, 1.0
    bpy.ops.import_anim.bvh(
        filepath=str(clip), update_scene_fps=False, use_fps_scale=True, rotate_mode="QUATERNION"
    )
    obj = bpy.context.view_layer.objects.active
    data = obj.animation_data
    # a constant scale keyed at the ends alone, as Blender's glTF importer keys one (the
    # action had been refused: its keys were not the rotations' every key)
    state = key_state(data.action, data.action_slot)
    ends = key_co(state, next(iter(state)))[[0, -1], 0].tolist()
    for frame in ends:
        obj.pose.bones["Head"].keyframe_insert("scale", frame=frame)
    before = key_state(data.action, data.action_slot)
    done, said, _ = printed(lambda: clean(frames="ACTION"))
    data = obj.animation_data
    after = key_state(data.action, data.action_slot)
    times = key_co(before, next(iter(before)))[:, 0].astype(np.float64)
    step = (times[-1] - times[0]) / (len(times) - 1)
    motion = read_action(obj, data.action, data.action_slot, times, step * frame_time()).motion
    save_motion(out, "subframe_out", motion)
    results["subframe"] = {
        "done": sorted(done),
        "whole_keys": int(np.count_nonzero(times == np.round(times))),
        "keys": int(times.size),
        "same_times": before.keys() == after.keys()
        and all(np.array_equal(key_co(before, k)[:, 0], key_co(after, k)[:, 0]) for k in before),
        "panel_keys": bpy.context.scene.motionclean.results[0].keys,
        "said": said,
    }


def near_frame_checks(clip: Path, results: dict) -> None:
    """A baked action one of whose keys sits a float32 rounding off its frame (Blender's FBX
    importer keys frame 32 at 31.999998): cleaned on whole frames, the key kept where it is,
    none added beside it (it had been refused as "keys between frames (at 32)")."""
    obj = import_rig(clip, "QUATERNION")
    data = obj.animation_data
    curve = action_fcurves(data.action, data.action_slot)[0]
    point = curve.keyframe_points[31]
    point.co = (point.co[0] - 2e-6, point.co[1])
    curve.update()
    before = key_state(data.action, data.action_slot)
    done = sorted(clean(in_place=True))
    after = key_state(data.action, data.action_slot)
    results["near_frame"] = {
        "done": done,
        "off_frame": float(key_co(before, next(iter(before)))[31, 0]),
        "same_times": before.keys() == after.keys()
        and all(np.array_equal(key_co(before, k)[:, 0], key_co(after, k)[:, 0]) for k in before),
        "values_changed": any(
            not np.array_equal(key_co(before, k)[:, 1], key_co(after, k)[:, 1]) for k in before
        ),
    }


def off_grid_checks(clip: Path, results: dict) -> None:
    """An action with a key at frame 31.5 on one curve (as a Mixamo FBX file's 0.1-frame
    keys on some curves): the panel refuses it (it writes keys where they are), an FBX file
    is read on its whole frames with a note (it is written back baked on them)."""
    obj = import_rig(clip, "QUATERNION")
    data = obj.animation_data
    curve = action_fcurves(data.action, data.action_slot)[0]
    curve.keyframe_points.insert(31.5, curve.evaluate(31.5))
    frames, step, notes = fbx_frames(data.action, data.action_slot)
    results["off_grid"] = {
        "frames": [float(frames[0]), float(frames[-1]), int(frames.size)],
        "range": list(key_range(data.action, data.action_slot) or ()),
        "step": step,
        "notes": list(notes),
        "panel": refused(in_place=True),
    }


def refused(**settings: Any) -> dict:
    """Press Clean Actions; what it returned and the error it reported."""
    try:
        done = sorted(clean(**settings))
    except RuntimeError as error:  # what an error report raises in a headless Blender
        return {"done": ["CANCELLED"], "message": str(error).strip()}
    return {"done": done, "message": ""}


def error_checks(clip: Path, out: Path, results: dict) -> None:
    """A press that cannot clean says why in one line and changes nothing."""
    obj = import_rig(clip, "QUATERNION")
    data = obj.animation_data
    action, slot = data.action, data.action_slot
    before = key_state(action, slot)
    shown = len(bpy.context.scene.motionclean.results)  # (the last checks' figures)
    errors = {
        name: refused(**settings)
        for name, settings in {
            "unknown_step": {"pipeline": "STEPS", "steps": "-f lee-shim:k=2"},
            "no_steps": {"pipeline": "STEPS", "steps": ""},
            "preview_off": {"frames": "PREVIEW"},
            "resample": {"pipeline": "STEPS", "steps": "-f resample:fps=60"},
        }.items()
    }
    # the reports folder cannot be made (a file has its name)
    operators = sys.modules[f"{EXTENSION}.operators"]
    reports = operators.REPORTS
    operators.REPORTS = out / "reports-file"
    operators.REPORTS.write_text("")
    errors["reports_folder"] = refused()
    operators.REPORTS = reports
    # a linked action (from a library file), in place
    library = out / "library.blend"
    bpy.data.libraries.write(str(library), {action}, fake_user=True)
    with bpy.data.libraries.load(str(library), link=True) as (_, linked):
        linked.actions = [action.name]
    data.action = linked.actions[0]
    if slot is not None:
        data.action_slot = linked.actions[0].slots[0]
    linked_before = key_state(data.action, data.action_slot)
    errors["linked_in_place"] = refused(in_place=True)
    linked_untouched = same_state(linked_before, key_state(data.action, data.action_slot))
    data.action = action
    if slot is not None:
        data.action_slot = slot
    # the action on an NLA strip from frame 101, edited in tweak mode
    track = data.nla_tracks.new()
    track.strips.new("strip", 101, action)
    data.action = None
    data.use_tweak_mode = True
    errors["tweak"] = refused()
    errors["tweak_in_place"] = refused(in_place=True)
    data.use_tweak_mode = False
    data.nla_tracks.remove(track)
    data.action = action
    if slot is not None:
        data.action_slot = slot
    results["errors"] = {
        "runs": errors,
        "actions": sorted(a.name_full for a in bpy.data.actions),
        "fake_users": sorted(a.name for a in bpy.data.actions if a.use_fake_user and not a.library),
        "results_kept": shown > 0 and len(bpy.context.scene.motionclean.results) == shown,
        "untouched": same_state(before, key_state(action, slot)) and linked_untouched,
    }


def same_name_checks(clip: Path, out: Path, results: dict) -> None:
    """Two armatures playing two actions of one name: the rig's own and one linked from
    the library file :func:`error_checks` wrote."""
    obj = import_rig(clip, "QUATERNION")
    other = bpy.data.objects.new("Linked", obj.data)
    bpy.context.scene.collection.objects.link(other)
    with bpy.data.libraries.load(str(out / "library.blend"), link=True) as (_, linked):
        linked.actions = [obj.animation_data.action.name]
    other.animation_data_create().action = linked.actions[0]
    if obj.animation_data.action_slot is not None:
        other.animation_data.action_slot = linked.actions[0].slots[0]
    for each in (obj, other):
        each.select_set(True)
    done = clean(pipeline="STEPS", steps="-f lee-shin:k=2,iterations=1")
    results["same_name"] = {
        "done": sorted(done),
        "plays": [each.animation_data.action.name_full for each in (obj, other)],
        "results": sorted(
            (entry.objects, entry.source) for entry in bpy.context.scene.motionclean.results
        ),
    }


def keyed_checks(clip: Path, results: dict) -> None:
    """A keyed (not baked) bone: keys stay where nothing moved, per frame where it did."""
    obj = import_rig(clip, "QUATERNION")
    data = obj.animation_data
    fcurves = action_fcurves(data.action, data.action_slot)
    sparse = f'pose.bones["{KNEES[0]}"].rotation_quaternion'
    for i in range(4):  # LeftKnee keyed every 10 frames, Bezier
        curve = fcurves.find(sparse, index=i)
        points = curve.keyframe_points
        for at in reversed(range(len(points))):
            if at % 10:
                points.remove(points[at], fast=True)
        for point in points:
            point.interpolation = "BEZIER"
            point.handle_left_type = point.handle_right_type = "AUTO_CLAMPED"
        points[0].interpolation = "CONSTANT"  # a hold at the start (the others Bezier)
        curve.update()
    first, last = rig_keys(obj)
    knee = f'pose.bones["{KNEES[0]}"]'
    state0 = key_state(data.action, data.action_slot)
    # 1. a step on the other knee: the keyed knee's keys do not move
    # (with a second pattern that names no joint: warned of)
    done1, said1, _ = printed(
        lambda: clean(
            pipeline="STEPS",
            steps=f"-f lee-shin:k=3,iterations=4,joints=[{KNEES[1]},Nope]",
            in_place=True,
        )
    )
    state1 = key_state(data.action, data.action_slot)
    untouched_knee = all(np.array_equal(state0[k], state1[k]) for k in state0 if k.startswith(knee))
    other_changed = any(
        not np.array_equal(state0[k], state1[k]) for k in state0 if f'"{KNEES[1]}"' in k
    )
    # 2. a step on the keyed knee over frames 200-260: keys per frame only near there
    before = read(obj, first, last)
    steps = f"-f lee-shin:k=3,iterations=4,joints=[{KNEES[0]}],frames=[200,260],blend=5"
    expected = clean_motion(before, Pipeline.from_inline(steps.split()[1::2]), "x").after
    done2 = clean(pipeline="STEPS", steps=steps, in_place=True)
    state2 = key_state(data.action, data.action_slot)
    after = read(obj, first, last)
    j = before.names.index(KNEES[0])
    error = np.rad2deg(quat.angle_between(after.rotations[:, j], expected.rotations[:, j]))
    moved = np.rad2deg(quat.angle_between(before.rotations[:, j], expected.rotations[:, j]))
    key_frames = [key_co(state2, f"{sparse}[{i}]")[:, 0] for i in range(4)]
    old_frames = key_co(state0, f"{sparse}[0]")[:, 0]
    old = {}
    for i in range(4):
        name = f"{sparse}[{i}]"
        co0, co2 = key_co(state0, name), key_co(state2, name)
        far = (co0[:, 0] < 180) | (co0[:, 0] > 280)
        lookup = {float(f): v for f, v in co2}
        old[name] = all(lookup.get(float(f)) == v for f, v in co0[far])
    results["keyed"] = {
        "done": [sorted(done1), sorted(done2)],
        "said": said1,
        "untouched_knee": bool(untouched_knee),
        "other_changed": bool(other_changed),
        "keys_before": int(old_frames.size),
        "keys_after": [int(f.size) for f in key_frames],
        "new_key_frames": sorted(set(key_frames[0].tolist()) - set(old_frames.tolist())),
        "new_key_interpolations": sorted(
            {
                point.interpolation
                for point in fcurves.find(sparse, index=0).keyframe_points
                if float(point.co[0]) not in set(old_frames.tolist())
            }
        ),
        "far_keys_kept": all(old.values()),
        "error_deg_max": float(error.max()),
        "moved_deg_max": float(moved.max()),
        "frames_moved": int(np.count_nonzero(moved >= 1e-3)),
    }


def extension_checks(zip_path: Path, results: dict) -> None:
    """Install the zip with Blender's extension installer; what got registered."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    done = bpy.ops.extensions.package_install_files(
        filepath=str(zip_path), repo="user_default", enable_on_install=True
    )
    bpy.ops.ed.undo_push(message="start")  # a headless Blender starts without undo steps
    names = (
        "MOTIONCLEAN_OT_clean",
        "MOTIONCLEAN_OT_open_report",
        "MOTIONCLEAN_PT_graph",
        "MOTIONCLEAN_PT_dopesheet",
    )
    results["install"] = {
        "done": sorted(done),
        "enabled": EXTENSION in bpy.context.preferences.addons,
        "classes": [name for name in names if hasattr(bpy.types, name)],
        "scene_settings": hasattr(bpy.types.Scene, "motionclean"),
        "undo_option": sorted(bpy.types.MOTIONCLEAN_OT_clean.bl_options),
    }
    results["draw_empty"] = draw_panels()


def unregister_checks(results: dict) -> None:
    """Disable the extension (its unregister), see what is left, enable it again."""
    import addon_utils

    addon_utils.disable(EXTENSION, default_set=True)
    left = [n for n in dir(bpy.types) if n.startswith("MOTIONCLEAN_")]
    results["unregister"] = {
        "enabled": EXTENSION in bpy.context.preferences.addons,
        "classes_left": left,
        "scene_settings": hasattr(bpy.types.Scene, "motionclean"),
    }
    addon_utils.enable(EXTENSION, default_set=True)
    results["unregister"]["enabled_again"] = hasattr(bpy.types, "MOTIONCLEAN_OT_clean")


# ----------------------------------------------------------------------------- FBX


def run_here(args: list[str], folder: Path) -> dict:
    """``motionclean ARGS`` run in this session from ``folder`` through the command line's
    entry point: its exit code and what reached standard output and error (as a process
    of its own would show them, but for what it prints as it starts and exits)."""

    def call() -> Any:
        with contextlib.chdir(folder):
            try:
                cli_main(args)
            except SystemExit as done:  # (the entry point always exits)
                return done.code

    code, stdout, stderr = printed(call)
    return {"code": code, "stdout": stdout, "stderr": stderr}


def fbx_checks(clip: Path, out: Path, results: dict) -> None:
    """An FBX written by Blender's exporter (its defaults) through the command line, with a
    light in its scene (Blender 5.0's importer failed on lights)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=str(clip), update_scene_fps=True, update_scene_duration=True)
    rig = bpy.context.view_layer.objects.active
    rig["rig_version"] = 3  # custom properties (Unity reads its attributes so)
    rig.data.bones["Hips"]["bone_note"] = "root"
    light = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
    bpy.context.scene.collection.objects.link(light)
    takes = out / "takes"
    takes.mkdir()
    bpy.ops.export_scene.fbx(filepath=str(takes / "take.fbx"), use_custom_props=True)
    # a second take: an action per take
    walk = rig.animation_data.action
    walk.use_fake_user = True
    walk.copy().name = "Run"
    bpy.ops.export_scene.fbx(filepath=str(out / "two_takes.fbx"), bake_anim_use_all_actions=True)
    command = str(Path(sys.executable).with_name("motionclean"))
    runs = {
        "identity": [
            "clean",
            "takes/take.fbx",
            "-o",
            "identity.fbx",
            "-q",
            "-f",
            "lee-shin:mask=custom,coefficients=[1]",
        ],
        "batch": [
            "batch",
            "takes",
            "-o",
            "batch",
            "--glob",
            "*.fbx",
            "--jobs",
            "1",
            "--report-dir",
            "reports",
        ],
        "info": ["info", "takes/take.fbx"],
        "two_takes": ["info", "two_takes.fbx"],
        "not_binary": ["info", "ascii.fbx"],
        "empty": ["info", "empty.fbx"],
        "resample": ["resample", "takes/take.fbx", "r60.fbx", "--fps", "60"],
        "report": ["report", "takes/take.fbx", "identity.fbx", "--json", "report.json"],
        "to_bvh": ["convert", "takes/take.fbx", "take.bvh"],  # (before the two that read it)
        "from_bvh": ["convert", "take.bvh", "from_bvh.fbx"],
        # a BVH cleaned under bpy's numpy 1 (kept cells' text spliced in: an int64 had
        # been OR-ed into a uint32 array there, an internal error under numpy < 2)
        "bvh_clean": ["clean", "take.bvh", "-o", "take_clean.bvh", "-q"],
    }
    (out / "ascii.fbx").write_text("; FBX 7.4.0 project file\n")
    (out / "empty.fbx").write_bytes(b"")
    # two commands that read and write FBX files run as processes of their own (nothing
    # Blender prints as bpy is imported or as the process exits may reach the terminal
    # either); the others meanwhile here, through the same entry point
    started = {
        name: subprocess.Popen(
            [command, *runs[name]],
            cwd=out,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for name in ("identity", "batch")
    }
    later = {"report"}  # (it reads what identity writes)
    ran = {
        name: run_here(args, out) for name, args in runs.items() if name not in {*started, *later}
    }
    for name, process in started.items():
        stdout, stderr = process.communicate()
        ran[name] = {"code": process.returncode, "stdout": stdout, "stderr": stderr}
    ran.update((name, run_here(runs[name], out)) for name in later)
    results["fbx_runs"] = ran
    loaded = {}
    for name in ("takes/take.fbx", "identity.fbx", "batch/take.fbx", "from_bvh.fbx", "r60.fbx"):
        if (out / name).is_file():
            loaded[name] = load_back(out / name)
    results["fbx_loaded"] = loaded
    # what the default pipeline gives the clip read through the Python API (bpy in-process)
    motion = mc.load(out / "takes" / "take.fbx")
    cleaned, _ = Pipeline.default().run(motion)
    np.save(out / "fbx_expected_rotations.npy", cleaned.rotations)
    np.save(out / "fbx_input_rotations.npy", motion.rotations)
    results["fbx_names"] = motion.names
    if (out / "from_bvh.fbx").is_file():  # a new FBX's end sites, read back
        back = mc.load(out / "from_bvh.fbx")
        results["from_bvh_end_sites"] = {
            back.names[j]: site.tolist() for j, site in back.end_sites.items()
        }
    back = mc.load(out / "batch" / "take.fbx") if (out / "batch" / "take.fbx").is_file() else None
    if back is not None:
        np.save(out / "fbx_batch_rotations.npy", back.rotations)


def under_reference(bvh: str) -> str:
    """The BVH text ``bvh`` with a still ``Reference`` joint above its root (rotation
    channels that never move; the travel stays on the old root's position channels, as
    Bandai Namco's and MotionBuilder's files have it) and every end site at its joint."""
    head, motion = bvh.split("MOTION", 1)
    head = head.replace(
        "ROOT ",
        "ROOT Reference\n{\n\tOFFSET 0 0 0\n\tCHANNELS 3 Zrotation Yrotation Xrotation\n\tJOINT ",
        1,
    )
    sites = head.split("End Site")
    head = sites[0] + "".join(
        "End Site" + part.replace(part.split("OFFSET", 1)[1].split("\n", 1)[0], " 0 0 0", 1)
        for part in sites[1:]
    )
    lines = motion.strip("\n").split("\n")
    frames = [line for line in lines if line.strip() and not line.strip()[0].isalpha()]
    header = [line for line in lines if line not in frames]
    body = "\n".join(f"0 0 0 {line}" for line in frames)
    return head.rstrip("\n") + "\n}\nMOTION\n" + "\n".join(header) + "\n" + body + "\n"


def reference_checks(clip: Path, out: Path, results: dict) -> None:
    """A clip whose travel is on a joint under a still root, with end sites at their joints,
    written to FBX by motionclean: what Blender's importer plays (the moving joint not
    connected to its parent) and what motionclean reads back."""
    source = out / "under_reference.bvh"
    source.write_text(under_reference(clip.read_text()))
    mc.save(mc.load(source), out / "under_reference.fbx")
    mc.save(mc.load(out / "under_reference.fbx"), out / "under_reference_back.bvh")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mend_importer(bpy)
    bpy.ops.import_scene.fbx(filepath=str(out / "under_reference.fbx"))
    obj = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    results["reference_connected"] = {b.name: b.use_connect for b in obj.data.bones}
    # a bone whose written channels have no rotation, turning in the action (keyed since)
    obj.data.bones["Hips"][CHANNELS_PROPERTY] = "Xposition Yposition Zposition"
    first, last = (int(round(v)) for v in obj.animation_data.action.frame_range)
    since = read(obj, first, last)
    results["keyed_since"] = list(since.channels[since.names.index("Hips")])


def head_down_checks(clip: Path, out: Path, results: dict) -> None:
    """The clip turned half a turn about X (standing head down along -y, as a camera's
    y-down coordinates have it) written to FBX by motionclean and imported by Blender:
    the world heights (Blender's +Z) of its head and of its lowest ankle at the middle
    frame (its up's sign had been dropped: the figure stood on its head)."""
    turn = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi)
    down = kinematics.turned(mc.load(clip), turn)
    mc.save(down, out / "head_down.fbx")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mend_importer(bpy)
    bpy.ops.import_scene.fbx(filepath=str(out / "head_down.fbx"))
    obj = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    first, last = (int(round(v)) for v in obj.animation_data.action.frame_range)
    bpy.context.scene.frame_set((first + last) // 2)
    height = {b.name: (obj.matrix_world @ b.head).z for b in obj.pose.bones}
    results["head_down_heights"] = [height["Head"], min(height["LeftAnkle"], height["RightAnkle"])]


def load_back(path: Path) -> dict:
    """What Blender's FBX importer (default settings) makes of a file: bones, rest, rate,
    frame range and every bone curve at each frame."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mend_importer(bpy)  # (Blender 5.0's importer fails on lights without it)
    bpy.ops.import_scene.fbx(filepath=str(path))
    obj = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    data = obj.animation_data
    scene = bpy.context.scene
    first, last = (int(round(v)) for v in data.action.frame_range)
    frames = np.arange(first, last + 1, dtype=np.float64)
    curves = {}
    for curve in action_fcurves(data.action, data.action_slot):
        co = keys(curve).astype(np.float64)
        if all(point.interpolation == "LINEAR" for point in curve.keyframe_points):
            values = np.interp(frames, co[:, 0], co[:, 1])  # what evaluate() gives, at once
        else:
            values = np.array([curve.evaluate(f) for f in frames.tolist()])
        curves[f"{curve.data_path}[{curve.array_index}]"] = values.tolist()
    rest = np.array([np.array(b.matrix_local) for b in obj.data.bones])
    np.save(path.with_suffix(".rest.npy"), rest)
    return {
        "bones": [b.name for b in obj.data.bones],
        "parents": [b.parent.name if b.parent else None for b in obj.data.bones],
        "fps": [scene.render.fps, scene.render.fps_base],
        "frames": [first, last],
        "curves": curves,
        "action": data.action.name,  # OBJECT|TAKE|LAYER
        "properties": [obj.get("rig_version"), obj.data.bones["Hips"].get("bone_note")],
    }


def main() -> None:
    zip_path, clip, out = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    operator_only = sys.argv[4:] == ["operator"]
    results: dict = {"blender": bpy.app.version_string, "rigs": {}, "seconds": {}}
    start = time.perf_counter()

    def timed(name: str) -> None:
        nonlocal start
        now = time.perf_counter()
        results["seconds"][name] = round(now - start, 2)
        start = now

    extension_checks(zip_path, results)
    timed("install")
    operator_checks(clip, out, results)
    timed("operator")
    range_checks(clip, out, results)
    results["draw_results"] = draw_panels()  # with the figures of a run
    shown = bpy.context.scene.motionclean.results[0]
    removed, shown.noise_removed = shown.noise_removed, -0.001  # (a rounding's sign)
    results["draw_rounded"] = draw_panels()
    shown.noise_removed = removed
    keyed_checks(clip, results)
    near_frame_checks(clip, results)
    off_grid_checks(clip, results)
    subframe_checks(clip, out, results)
    error_checks(clip, out, results)
    same_name_checks(clip, out, results)
    unregister_checks(results)
    timed("range, keyed, unregister")
    if not operator_only:
        fbx_checks(clip, out, results)
        reference_checks(clip, out, results)
        head_down_checks(clip, out, results)
        timed("fbx")
    (out / "results.json").write_text(json.dumps(results, default=float))


if __name__ == "__main__":
    main()
