"""The ``footlock`` step: feet that stand stay planted.

Contacts are found in world space (:mod:`motionclean.core.contacts`); during each one the
ankle is held at the median of its positions by two-bone leg IK (:mod:`motionclean.filters.
footlock`), eased in and out. Only the hip, knee and ankle rotations of a leg change, and
only around its contacts; a clip with no ground contact is left as it is.
"""

from __future__ import annotations

import math

from ..core import contacts as found
from ..core import kinematics
from ..core.motion import Motion
from ..filters.footlock import lock_feet
from .base import Param, StepData, StepSpec, crop_runs, plural, shift_runs


def contact_params(params: dict) -> found.ContactParams:
    """The step's parameters as contact thresholds (body heights, seconds)."""
    return found.ContactParams.starting_at(params["height"], params["speed"], params["min_seconds"])


def find_contacts(motion: Motion, params: dict):
    """Feet, contacts ``(F, n_feet)``, world positions and rotations of joints and end
    sites, up axis, body height and ground height of ``motion`` under the step's
    parameters."""
    up = None if params["up"] == "auto" else params["up"]
    feet, up, height = found.skeleton_feet(motion, params["feet"], up)
    positions, world = kinematics.forward(motion, end_sites=True)
    contacts, ground = found.detect(
        positions, feet, up, height, motion.frame_time, contact_params(params)
    )
    return feet, contacts, positions, world, up, height, ground


def _run(data: StepData, params: dict) -> StepData:
    motion = data.motion
    assert motion is not None
    feet, contacts, positions, world, up, height, _ = find_contacts(motion, params)
    contacts = found.sliding_contacts(
        positions, feet, contacts, up, motion.frame_time, params["min_skate"] * height
    )
    column = {int(j): c for c, j in enumerate(data.rotation_joints)}
    usable = [k for k, f in enumerate(feet) if {f.hip, f.knee, f.ankle} <= column.keys()]
    if not usable or not contacts[:, usable].any():
        return data
    blend_frames = params["blend_seconds"] / motion.frame_time
    local = lock_feet(
        motion.rotations,
        motion.parents,
        positions,
        world,
        [feet[k] for k in usable],
        contacts[:, usable],
        blend_frames,
        up if params["horizontal"] else None,
        params["hold_seconds"] / motion.frame_time,
    )
    data.rotations = data.rotations.copy()  # the input may be the clip's own array
    for k in usable:
        foot = feet[k]
        for joint in (foot.hip, foot.knee, foot.ankle):
            data.rotations[:, column[joint]] = local[:, joint]
        runs = found.contact_runs(contacts[:, [k]])[0]
        data.rotation_notes.setdefault(column[foot.ankle], {})["footlock"] = {
            "contacts": [[a, b] for a, b in runs],
            "frames": int(contacts[:, k].sum()),
        }
    return data


def _format_note(note: dict, positions: bool) -> str:
    shown = ", ".join(f"{a}-{b}" for a, b in note["contacts"][:6])
    more = len(note["contacts"]) - 6
    held = f"held {plural(len(note['contacts']), 'contact')} ({plural(note['frames'], 'frame')})"
    return f"{held}: {shown}" + (f" and {more} more" if more > 0 else "")


def _crop_note(note: dict, first: int, last: int) -> dict | None:
    """The contacts held within frames ``first..last``."""
    contacts = crop_runs(note["contacts"], first, last, stop_exclusive=False)
    if not contacts:
        return None
    return {**note, "contacts": contacts, "frames": sum(b - a + 1 for a, b in contacts)}


STEP = StepSpec(
    name="footlock",
    summary="hold each foot where it stands during ground contacts (two-bone leg IK)",
    paper="contacts in world space; analytic two-bone IK (law of cosines), smoothstep blends",
    params=(
        Param(
            "feet",
            "strs",
            None,
            "ankle joints to lock, fnmatch patterns (default: found from the rest pose: "
            "the chains above the lowest leaves)",
        ),
        Param("up", "str", "auto", "up axis", choices=("auto", "x", "y", "z")),
        Param(
            "height",
            "float",
            found.ContactParams.height,
            "a contact starts with the foot's lowest point this close to the ground, "
            "body heights (stays up to 4/3 of it)",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=1.0,
        ),
        Param(
            "speed",
            "float",
            found.ContactParams.speed,
            "... and the ankle slower than this, body heights per second (stays up to 5/3)",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=100.0,
        ),
        Param(
            "min_seconds",
            "float",
            found.ContactParams.min_duration,
            "shorter contacts are ignored, seconds",
            minimum=0.0,
            maximum=math.inf,
            infinite_ok=True,
        ),
        Param(
            "horizontal",
            "bool",
            True,
            "hold only the horizontal position (the ankle keeps its height: heel roll); "
            "false holds all three axes",
        ),
        Param(
            "min_skate",
            "float",
            0.1,
            "only contacts whose ankle slides faster than this are fixed, body heights per "
            "second (a capture's own feet slide 0.02-0.08); 0 fixes every contact",
            minimum=0.0,
        ),
        Param(
            "hold_seconds",
            "float",
            0.5,
            "the ankle follows its least-squares straight line over this window, cut to the "
            "contact: jitter and sliding go, a steady drift (pivot) stays; inf holds every "
            "contact still at its mean position",
            minimum=0.0,
            exclusive_minimum=True,
            infinite_ok=True,
        ),
        Param(
            "blend_seconds",
            "float",
            0.1,
            "ease in before and out after each contact, seconds",
            minimum=0.0,
            maximum=10.0,
        ),
    ),
    run=_run,
    positions_default=False,
    format_note=_format_note,
    crop_note=_crop_note,
    shift_note=lambda note, frames: {**note, "contacts": shift_runs(note["contacts"], frames)},
)
