"""Clean Actions (the panel's button) and Open Report.

Clean Actions reads every chosen action over the chosen frames, runs the pipeline on each
(everything is read and cleaned before anything is written, so a failure changes nothing),
then writes the results: into a copy named after the action ("Walk.clean", assigned in its
place; the original is kept with a fake user), or into the action itself. It is one undo
step. Reading and writing are :mod:`motionclean.io.blender_action`; cleaning and the report
are what ``motionclean clean`` does (:func:`motionclean.run.jobs.clean_motion`).
"""

from __future__ import annotations

import re
import shlex
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import bpy
import numpy as np
from bpy.props import StringProperty
from bpy.types import Operator

from .motionclean.core.errors import MotionError, UsageError
from .motionclean.core.rates import same_rate
from .motionclean.io import write_together
from .motionclean.io.blender_action import ActionClip, key_frames, read_action, write_action
from .motionclean.report.terminal import format_table
from .motionclean.run.jobs import CleanedClip, clean_motion, pattern_warnings, render_report
from .motionclean.steps.pipeline import Pipeline
from .motionclean.steps.ranges import FrameRange

#: Where the HTML reports go.
REPORTS = Path(tempfile.gettempdir()) / "motionclean-reports"
#: Lines of the report's text kept for the panel: repairs and feet.
FIGURE_LINES = ("repaired ", "foot ")
#: Frames at each end of a range over which its cleaning is blended in and out.
RANGE_BLEND = 5


def pipeline_of(settings: Any) -> Pipeline:
    """The pipeline the panel names: the default, a TOML file or steps typed in."""
    if settings.pipeline == "FILE":
        if not settings.pipeline_file:
            raise UsageError("choose a pipeline file (or another pipeline)")
        return Pipeline.from_toml(bpy.path.abspath(settings.pipeline_file))
    if settings.pipeline == "STEPS":
        try:
            words = shlex.split(settings.steps)
        except ValueError as error:
            raise UsageError(f"steps: {error}") from None
        steps = [word for word in words if word not in ("-f", "--filter")]
        if not steps:
            raise UsageError("type the steps in (e.g. -f lee-shin:k=2 -f bilateral:sigma_t=1)")
        return Pipeline.from_inline(steps)
    return Pipeline.default()


def ranged(pipeline: Pipeline, first: int, last: int) -> Pipeline:
    """``pipeline`` with every step that takes a frame range (and was given none) run on
    clip frames ``first..last``, blended in and out over the range's first and last
    :data:`RANGE_BLEND` frames, so nothing outside changes and nothing jumps at its ends."""
    blend = max(0, min(RANGE_BLEND, (last - first) // 4))
    span = FrameRange(frames=(first + blend, last - blend), blend=blend)
    steps = [
        replace(step, span=span) if step.spec.run_motion is None and step.span is None else step
        for step in pipeline.steps
    ]
    return Pipeline(steps, pipeline.origin)


def frames_of(
    scene: Any, settings: Any, action: Any, slot: Any
) -> tuple[np.ndarray, float, int, int]:
    """The frames read (:func:`~motionclean.io.blender_action.key_frames`: the action's
    whole frames from its first key to its last, or the times of its keys where an importer
    baked them between frames), their spacing, and the first and last of them to clean
    (clip frame numbers): those in the chosen range."""
    frames, step = key_frames(action, slot)
    if not frames.size:
        raise MotionError("no bone keys to clean", action.name)
    if settings.frames == "SCENE":
        first, last = scene.frame_start, scene.frame_end
    elif settings.frames == "PREVIEW":
        if not scene.use_preview_range:
            raise UsageError("the preview range is off: turn it on, or clean another range")
        first, last = scene.frame_preview_start, scene.frame_preview_end
    else:
        first, last = frames[0], frames[-1]
    inside = np.flatnonzero((frames >= first - 1e-6) & (frames <= last + 1e-6))
    if inside.size < 2:
        raise MotionError(
            f"frames {_frame_text(first)}-{_frame_text(last)}: fewer than 2 frames of the "
            f"action's keys ({_frame_text(frames[0])}-{_frame_text(frames[-1])}) in the range",
            action.name,
        )
    return frames, step, int(inside[0]), int(inside[-1])


@dataclass
class Plan:
    """One action to clean, the armatures that play it, and what cleaning it gave."""

    objects: list[Any]
    action: Any
    slot: Any
    clip: ActionClip | None = None
    result: CleanedClip | None = None
    span: str = ""  # the range cleaned, scene frames
    page: Path | None = None  # its HTML report


def plans_of(context: Any) -> list[Plan]:
    """The actions of the selected armatures (or the active one), each once."""
    chosen = [obj for obj in context.selected_objects if obj.type == "ARMATURE"]
    if not chosen and context.active_object and context.active_object.type == "ARMATURE":
        chosen = [context.active_object]
    plans: dict[tuple[int, str], Plan] = {}  # (a local and a linked action may share a name)
    for obj in chosen:
        data = obj.animation_data
        if data is not None and data.use_tweak_mode:
            # (the action plays through its strip's frame mapping, and Blender lets no
            # other action be assigned until tweak mode is left)
            raise UsageError(
                "in NLA tweak mode: leave it (Tab in the NLA editor) to clean the action",
                obj.name,
            )
        if data is None or data.action is None:
            continue
        slot = getattr(data, "action_slot", None)
        key = (data.action.as_pointer(), getattr(slot, "identifier", ""))
        if key in plans:
            plans[key].objects.append(obj)
        else:
            plans[key] = Plan([obj], data.action, slot)
    if not plans:
        raise UsageError("select an armature that plays an action")
    return list(plans.values())


def check_editable(plans: list[Plan], in_place: bool) -> None:
    """UsageError for a change that saving would lose: a linked (library) action changed
    in place, a linked armature given the cleaned copy."""
    for plan in plans:
        if in_place and (plan.action.library is not None or not plan.action.is_editable):
            raise UsageError(
                "linked action: turn In Place off or make it local", plan.action.name_full
            )
        for obj in plan.objects:
            if not in_place and (obj.library is not None or not obj.is_editable):
                raise UsageError(
                    "linked armature: make it local (or a library override), or clean its "
                    "action's library file",
                    obj.name_full,
                )


def write_pages(plans: list[Plan], in_place: bool) -> None:
    """Write every plan's HTML report into :data:`REPORTS`, all or none, before anything
    in Blender changes; MotionError (one line) when the folder cannot be made or written
    (a file of that name, another user's folder)."""
    pages: dict[Path, bytes] = {}
    for plan in plans:
        assert plan.result is not None
        result = plan.action.name if in_place else f"{plan.action.name}.clean"
        name = f"{_file_name(plan.objects[0].name)}-{_file_name(result)}"
        page = REPORTS / f"{name}.html"
        for number in range(2, len(plans) + 2):  # (two actions of one name)
            if page not in pages:
                break
            page = REPORTS / f"{name}-{number}.html"
        pages[page] = render_report(plan.result.report, page, plan.result.series)
        plan.page = page
    try:
        REPORTS.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise MotionError(f"cannot make the reports folder: {error.strerror}", REPORTS) from None
    write_together(pages)


def _same_slot(action: Any, slot: Any) -> Any:
    if slot is None or not hasattr(action, "slots"):
        return None
    for candidate in action.slots:
        if candidate.identifier == slot.identifier:
            return candidate
    return None


def _frame_text(frame: float) -> str:
    """A scene frame as the panel shows it: 150, or 2.001 for a key between frames."""
    return str(np.format_float_positional(round(float(frame), 3), trim="-"))


def _file_name(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._") or "action"


class MOTIONCLEAN_OT_clean(Operator):
    """Clean the selected armatures' actions with the panel's pipeline"""

    bl_idname = "motionclean.clean"
    bl_label = "Clean Actions"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context: Any) -> bool:
        return context.scene is not None and context.mode in {"OBJECT", "POSE"}

    def execute(self, context: Any) -> set[str]:
        scene = context.scene
        settings = scene.motionclean
        frame_time = scene.render.fps_base / scene.render.fps
        try:
            pipeline = pipeline_of(settings)
            plans = plans_of(context)
            check_editable(plans, settings.in_place)
            for plan in plans:  # everything is cleaned before anything is written
                frames, step, first, last = frames_of(scene, settings, plan.action, plan.slot)
                plan.span = f"{_frame_text(frames[first])}-{_frame_text(frames[last])}" + (
                    # (the lines below and the report number the action's keys from 0)
                    f" (0 below: frame {_frame_text(frames[0])})" if frames[0] else ""
                )
                plan.clip = read_action(
                    plan.objects[0], plan.action, plan.slot, frames, step * frame_time
                )
                whole = (first, last) == (0, len(frames) - 1)
                steps = pipeline if whole else ranged(pipeline, first, last)
                plan.result = clean_motion(plan.clip.motion, steps, plan.action.name)
                if plan.result.after.n_frames != plan.clip.motion.n_frames:
                    raise UsageError(
                        "the pipeline changes the frame count (resample): an action keeps "
                        "its frames; change the scene's frame rate instead",
                        plan.action.name,
                    )
            write_pages(plans, settings.in_place)
        except MotionError as error:
            self.report({"ERROR"}, f"motionclean: {error}")
            return {"CANCELLED"}
        settings.results.clear()
        for plan in plans:
            self._write(plan, settings)
            for warning in pattern_warnings(plan.action.name, plan.result.logs):
                self.report({"WARNING"}, warning)
        # (each action at its keys' rate: a 30 fps glTF import in a 24 fps scene is 30)
        times = [p.clip.motion.frame_time for p in plans if p.clip is not None]
        if all(same_rate(frame_time, t) for t in times):
            said, whose = f"{1.0 / frame_time:.4g}", "the scene's frame rate"
        else:
            said = ", ".join(sorted({f"{1.0 / t:.4g}" for t in times}))
            whose = f"its keys' rate; the scene's is {1.0 / frame_time:.4g}"
        self.report({"INFO"}, f"motionclean: cleaned {len(plans)} action(s) at {said} fps, {whose}")
        return {"FINISHED"}

    def _write(self, plan: Plan, settings: Any) -> None:
        assert plan.clip is not None and plan.result is not None
        target, slot = plan.action, plan.slot
        if not settings.in_place:
            target = plan.action.copy()
            target.name = f"{plan.action.name}.clean"
            target.use_fake_user = False
            plan.action.use_fake_user = True  # the original stays in the file
            slot = _same_slot(target, plan.slot)
        written = write_action(plan.clip, plan.result.after, target, slot)
        if target is not plan.action:
            for obj in plan.objects:
                obj.animation_data.action = target
                if slot is not None:
                    obj.animation_data.action_slot = slot
        report = plan.result.report
        entry = settings.results.add()
        entry.objects = ", ".join(obj.name for obj in plan.objects)
        entry.source, entry.result = plan.action.name_full, target.name
        entry.frames = plan.span
        entry.noise_removed = report["summary"].get("noise_reduction") or 0.0
        entry.deviation_max = report["summary"].get("deviation_deg_max") or 0.0
        entry.keys = f"Keys: {written.keys_set:,} changed, {written.keys_added:,} added" + (
            f", {written.curves_created} curves made" if written.curves_created else ""
        )
        entry.lines = "\n".join(_figure_lines(report))
        entry.report = str(plan.page)


def _figure_lines(report: dict) -> list[str]:
    """The terminal report's repair and foot lines, as ``motionclean clean`` prints them."""
    lines = format_table(report).splitlines()
    return [line for line in lines if line.startswith(FIGURE_LINES)]


class MOTIONCLEAN_OT_open_report(Operator):
    """Open a cleaning report in the web browser"""

    bl_idname = "motionclean.open_report"
    bl_label = "Open Report"
    bl_options = {"INTERNAL"}

    path: StringProperty(name="Report", subtype="FILE_PATH", options={"SKIP_SAVE"})

    def execute(self, context: Any) -> set[str]:
        page = Path(self.path)
        if not page.is_file():
            self.report({"ERROR"}, f"motionclean: {page}: no such report (clean again)")
            return {"CANCELLED"}
        bpy.ops.wm.url_open(url=page.as_uri())
        self.report({"INFO"}, f"motionclean: opened {page}")
        return {"FINISHED"}
