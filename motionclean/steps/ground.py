"""The ``ground`` step: the floor the feet stand on, level and at height 0.

The floor is found from the ground contacts (:func:`motionclean.core.contacts.fit_floor`:
the plane through each contact's sole, its height and tilt). The step turns and shifts
the whole clip so that plane becomes level and lies at height 0 along the up axis, by
moving the root alone (its rotation and position channels): every other channel is kept
bit for bit, and the motion relative to the floor is unchanged. Video estimates put feet
below the floor or in the air and tilt it with the camera; after ``ground`` the feet
stand on ``up = 0``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..core import contacts as found
from ..core import kinematics, quat
from ..core.errors import UsageError
from ..core.motion import Motion
from ..core.words import length_word
from .base import UP_PARAM, Param, StepData, StepSpec, given_up


class FoundFloor(NamedTuple):
    """The floor of a clip (None without ground contacts), the soles ``(n, 3)`` it rests
    on, and whether it is the ground's own slope (:func:`~motionclean.core.contacts.terrain`:
    stairs or a ramp under an upright body) rather than the capture's tilt."""

    floor: found.Floor | None
    soles: np.ndarray
    terrain: bool


def floor_of(motion: Motion, up: str | None = None) -> FoundFloor:
    """The floor of ``motion``, found as the report finds it
    (:func:`~motionclean.core.contacts.find_ground`: a short walk up a slope included),
    as the figure turned :func:`~motionclean.core.kinematics.upright` has it."""
    feet, axis, height = found.skeleton_feet(motion, None, up)
    if not feet:
        return FoundFloor(None, np.zeros((0, 3)), False)
    unknown = found.feet_unknown(kinematics.missing_points(motion), feet)
    scene = found.FootScene.of_motion(motion, feet, axis, height, up, unknown=unknown)
    standing = found.find_ground(scene)
    floor = standing.floor
    body = kinematics.upright_body_up(motion, up)
    return FoundFloor(floor, standing.soles, floor is not None and found.terrain(floor, body))


def _leveller(floor: found.Floor, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The turn ``(4,)`` and shift ``(3,)`` taking ``x`` to ``turn x + shift``: the floor
    level and at height 0, the point of it below ``centre`` kept in place horizontally."""
    up = np.eye(3)[floor.up]
    normal = floor.normal
    turn = np.concatenate([[1.0 + normal @ up], np.cross(normal, up)])
    turn /= np.linalg.norm(turn)
    on_floor = centre - floor.above(centre) * normal  # the centre dropped onto the floor
    kept = on_floor.copy()
    kept[floor.up] = 0.0
    return turn, kept - quat.rotate(turn, on_floor)


def _run(data: StepData, params: dict) -> StepData:
    motion = data.motion
    assert motion is not None
    given = given_up(params)
    floor, soles, terrain = floor_of(motion, given)
    if floor is None:
        return data
    centre = soles.mean(axis=0)
    note = {
        "height": floor.height_at(centre),
        "tilt_deg": floor.tilt_deg,
        "normal": [float(v) for v in floor.normal],
        "levelled": bool(params["level"]) and not terrain,
        "terrain": terrain,
    }
    unit = kinematics.length_unit(motion)  # (said where the format fixes it)
    note |= {"unit": unit} if unit else {}
    if terrain:  # stairs or a slope: the lowest contact's sole at height 0, nothing turned
        lowest = float(soles[:, floor.up].min())
        note["height"] = lowest
        floor = found.Floor.level(lowest, floor.up)
    elif not params["level"]:
        floor = found.Floor.level(floor.height_at(centre), floor.up)
    turn, shift = _leveller(floor, centre)
    axis, sign = kinematics.up_direction(motion, given)
    if sign < 0.0:  # found on the figure turned upright: the same move in its own frame
        half = kinematics.upright_turn(axis)
        turn = quat.multiply(half, quat.multiply(turn, quat.conjugate(half)))
        shift = kinematics.upright(shift, axis, sign)
    roots = np.flatnonzero(motion.parents < 0)
    rotated = {int(j): c for c, j in enumerate(data.rotation_joints)}
    moved = {int(j): c for c, j in enumerate(data.translation_joints)}
    has_axis = motion.layout.position_columns >= 0
    tilted = floor.tilt_deg > 0.0
    for root in roots.tolist():
        where = motion.names[root]
        if tilted and root not in rotated:
            _refuse(
                where,
                "rotation",
                "to level",
                bool(np.all(motion.layout.rotation_columns[root] >= 0)),
            )
        needed = np.ones(3, dtype=bool) if tilted else np.eye(3, dtype=bool)[floor.up]
        if root not in moved or not has_axis[root][needed].all():
            _refuse(where, "position", "to move", bool(has_axis[root][needed].all()))
    data.rotations = data.rotations.copy()
    assert data.translations is not None  # every root has position channels
    data.translations = data.translations.copy()
    local = kinematics.local_translations(motion)  # (F, J, 3), once for every root
    for root in roots.tolist():
        if tilted:
            column = rotated[root]
            data.rotations[:, column] = quat.make_continuous(
                quat.multiply(turn, data.rotations[:, column])
            )
        placed = quat.rotate(turn, local[:, root]) + shift
        column = moved[root]
        data.translations[:, column, has_axis[root]] = placed[:, has_axis[root]]
    data.translation_notes.setdefault(moved[int(roots[0])], {})["ground"] = note
    return data


def _format_note(note: dict, positions: bool) -> str:
    unit = length_word(note.get("unit"))
    if note.get("terrain"):
        return (
            f"floor tilted {note['tilt_deg']:.2f} deg, rising under an upright body: stairs "
            f"or a slope; the lowest contact's sole moved from height {note['height']:.4g} "
            f"{unit} to 0, the tilt kept"
        )
    kept = "levelled" if note.get("levelled", True) else "its tilt kept"
    return (
        f"floor at height {note['height']:.4g} {unit}, tilted {note['tilt_deg']:.2f} deg: "
        f"moved to height 0, {kept}"
    )


STEP = StepSpec(
    name="ground",
    smooths=False,
    summary="put the floor the feet stand on at height 0 and level it, moving the root only",
    paper="the plane through the ground contacts' soles (least squares, slope prior)",
    params=(
        UP_PARAM,
        Param(
            "level",
            "bool",
            True,
            "also level a tilted floor (turn the clip about the contacts' centre); false "
            "only moves it along the up axis",
        ),
    ),
    run=_run,
    format_note=_format_note,
    sees_missing=True,  # one rigid move of the whole clip: dropouts elsewhere stay as they are
)


def _refuse(root: str, kind: str, purpose: str, in_file: bool) -> None:
    """Why ``ground`` cannot move the root: its ``kind`` channels are not selected (a
    usage error: ``joints`` or ``positions=false`` left them out), or the file has none."""
    if in_file:
        raise UsageError(
            f"the root {root!r} is not selected ({kind} channels {purpose}): its joints "
            "must include the root, and positions must be true"
        )
    raise ValueError(f"ground: the root {root!r} has no {kind} channels {purpose}")
