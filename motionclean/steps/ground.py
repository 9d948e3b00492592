"""The ``ground`` step: the floor the feet stand on, level and at height 0.

The floor is found from the ground contacts (:func:`motionclean.core.contacts.fit_floor`:
the plane through each contact's sole, its height and tilt). The step turns and shifts
the whole clip so that plane becomes level and lies at height 0 along the up axis, by
moving the root alone (its rotation and position channels): every other channel is kept
bit for bit, and the motion relative to the floor is unchanged. Video estimates put feet
below the floor or in the air and tilt it with the camera; after ``ground`` the feet
stand on ``up = 0``. A floor whose soles stand at fewer than three places (a stance) is
not levelled, stairs neither, and a body resting below its feet (lying down) is put on
the floor by its lowest point; a clip without a floor is left, its note saying why.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..core import contacts as found
from ..core import kinematics, quat
from ..core.errors import UsageError
from ..core.motion import Motion
from ..core.words import UNSAID_LENGTH, length_word, plural
from .base import UP_PARAM, Param, StepData, StepSpec, given_up


class FoundFloor(NamedTuple):
    """The floor of a clip (None without ground contacts), the soles ``(n, 3)`` it rests
    on, whether it is the ground's own slope (:func:`~motionclean.core.contacts.terrain`:
    stairs or a ramp under an upright body) rather than the capture's tilt, the scene it
    was found on (None without feet) and, without a floor, why (``"no foot in contact
    found"``)."""

    floor: found.Floor | None
    soles: np.ndarray
    terrain: bool
    scene: found.FootScene | None = None
    why: str = ""


def floor_of(motion: Motion, up: str | None = None) -> FoundFloor:
    """The floor of ``motion``, found as the report finds it
    (:func:`~motionclean.core.contacts.find_ground`: a short walk up a slope included),
    as the figure turned :func:`~motionclean.core.kinematics.upright` has it."""
    feet, axis, height = found.skeleton_feet(motion, None, up)
    if not feet:
        return FoundFloor(None, np.zeros((0, 3)), False, why=found.no_feet_words(motion))
    unknown = found.feet_unknown(kinematics.missing_points(motion), feet)
    scene = found.FootScene.of_motion(motion, feet, axis, height, up, unknown=unknown)
    standing = found.find_ground(scene)
    floor = standing.floor
    if floor is None:
        why = "no foot in contact found"
        if motion.n_frames < 2:
            why = f"too short: {plural(motion.n_frames, 'frame')}"
        return FoundFloor(None, standing.soles, False, scene, why)
    body = kinematics.upright_body_up(motion, up)
    return FoundFloor(floor, standing.soles, found.terrain(floor, body), scene)


#: The floor's tilt is applied where its soles stand at this many places or more
#: (:func:`~motionclean.core.contacts.sole_places`; closer soles share one): through two
#: (a stance held: two feet, however often set down again) a plane's slope is the
#: difference of two soles' heights, a heel raised or a foot lifted as much as a slope.
#: 131_02's first frame held (the right foot 0.05 body heights up) read a floor tilted 3.0
#: degrees, levelled, a toe left 0.49 units under it. Walks and turns stand on 3-200
#: (narrow ones along a line too: their slope along it is read from three or more).
TILT_PLACES = 2.5
#: A body rests below its feet where a point of it other than the feet lies, on most
#: frames (its median), more than this (body heights) under the floor through the feet's
#: soles: more than a foot may stand above the ground and be on it
#: (``ContactParams.height``). Its feet's floor is then no floor it stands on. A figure
#: lying on its back (131_02's first frame laid down, its heels the contacts): its elbow
#: 0.099 under. The lowest such point of a frame, median over frames, on every walk, run,
#: dance and stance measured (the corpus, the exporters', LaFAN1, Bandai Namco,
#: GAMES-105): 0.20-0.35 above (the knees); LaFAN1's takes on the ground 0.02 under, a
#: dog's forepaws 0.008 under (any one point's median is no lower).
RESTING_BELOW = 0.06


def _body_rests_below(where: FoundFloor, motion: Motion) -> tuple[str, float] | None:
    """The point of the body other than its feet that lies deepest under the floor through
    the feet on most frames, and how far (length units, the median over frames), where the
    body rests there (:data:`RESTING_BELOW`); None where it stands on its feet or has no
    trunk."""
    scene, floor = where.scene, where.floor
    split = kinematics.body_split(kinematics.point_parents(motion))
    if scene is None or floor is None or split is None:
        return None
    feet = [p for foot in scene.feet for p in foot.points]
    points = np.setdiff1d(np.r_[split[1], split[2]], feet)
    depth = -np.median(floor.above(scene.positions[:, points]), axis=0)  # (n,)
    deepest = int(np.argmax(depth))
    if depth[deepest] <= RESTING_BELOW * scene.height:
        return None
    names = [*motion.names, *kinematics.end_site_names(motion)]
    return names[int(points[deepest])], float(depth[deepest])


def _lowest(scene: found.FootScene, motion: Motion) -> float:
    """The height along the up axis where the body lies: the 5th percentile over frames of
    the lowest of its points (:func:`~motionclean.core.contacts.estimate_ground`)."""
    split = kinematics.body_split(kinematics.point_parents(motion))
    assert split is not None  # (a body rests below its feet only where it has a trunk)
    points = np.r_[split[1], split[2]]
    return found.estimate_ground(scene.positions[:, points, scene.up].min(axis=1)[:, None])


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
    where = floor_of(motion, given)
    roots = np.flatnonzero(motion.parents < 0)
    moved = {int(j): c for c, j in enumerate(data.translation_joints)}
    if where.floor is None:  # said, not moved (footlock's "no foot in contact found")
        # on the root's positions, else the first joint's with some (an OpenSim clip's
        # coordinates are all roots, its translations pelvis_tx ...)
        told = next(
            (moved[int(j)] for j in roots if int(j) in moved), min(moved.values(), default=None)
        )
        if told is not None:
            data.translation_notes.setdefault(told, {})["ground"] = {"why": where.why}
        return data
    floor, note = _target(where, motion, bool(params["level"]))
    turn, shift = _leveller(floor, where.soles.mean(axis=0))
    note["unit"] = kinematics.length_unit(motion) or UNSAID_LENGTH
    axis, sign = kinematics.up_direction(motion, given)
    if sign < 0.0:  # found on the figure turned upright: the same move in its own frame
        half = kinematics.upright_turn(axis)
        turn = quat.multiply(half, quat.multiply(turn, quat.conjugate(half)))
        shift = kinematics.upright(shift, axis, sign)
    rotated = {int(j): c for c, j in enumerate(data.rotation_joints)}
    has_axis = motion.layout.position_columns >= 0
    tilted = floor.tilt_deg > 0.0
    for root in roots.tolist():
        name = motion.names[root]
        if tilted and root not in rotated:
            _refuse(
                name,
                "rotation",
                "to level",
                bool(np.all(motion.layout.rotation_columns[root] >= 0)),
            )
        needed = np.ones(3, dtype=bool) if tilted else np.eye(3, dtype=bool)[floor.up]
        if root not in moved or not has_axis[root][needed].all():
            _refuse(name, "position", "to move", bool(has_axis[root][needed].all()))
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
    if tilted:  # (the report measures the roots' change from the input turned by it)
        note["turn"] = [float(c) for c in turn]
    data.translation_notes.setdefault(moved[int(roots[0])], {})["ground"] = note
    return data


def _target(where: FoundFloor, motion: Motion, level: bool) -> tuple[found.Floor, dict]:
    """The plane ``ground`` puts level at height 0 and its note: the floor found, where its
    soles stand at :data:`TILT_PLACES` or more (tilted where ``level``, else its height
    below their centre); where they stand at fewer, or on stairs (the slope kept), the
    lowest sole (nothing under it); for a body resting below its feet
    (:func:`_body_rests_below`) its lowest point."""
    floor, soles, scene = where.floor, where.soles, where.scene
    assert floor is not None and scene is not None
    places = found.sole_places(soles, floor.up, scene.height)
    supported = places >= TILT_PLACES
    resting = _body_rests_below(where, motion)
    height = floor.height_at(soles.mean(axis=0))
    if resting is not None:  # its feet's floor is none it stands on: its lowest point to 0
        height = _lowest(scene, motion)
    elif where.terrain or not supported:  # the lowest sole at 0, nothing turned
        height = float(soles[:, floor.up].min())
    levelled = level and supported and not where.terrain and resting is None
    note = {
        "height": height,
        "tilt_deg": floor.tilt_deg,
        "normal": [float(v) for v in floor.normal],
        "levelled": levelled,
        "terrain": where.terrain,
        "places": places,
        "unsupported": not supported,
        "resting": None if resting is None else {"point": resting[0], "below": resting[1]},
    }
    return (floor if levelled else found.Floor.level(height, floor.up)), note


def _format_note(note: dict, positions: bool) -> str:
    unit = length_word(note.get("unit"))
    if "why" in note:
        return f"the clip not moved: no floor ({note['why']})"
    if note.get("terrain"):
        return (
            f"floor tilted {note['tilt_deg']:.2f} deg, rising under an upright body: stairs "
            f"or a slope; the lowest contact's sole moved from height {note['height']:.4g} "
            f"{unit} to 0, the tilt kept"
        )
    resting = note.get("resting")
    if resting:
        return (
            f"the body rests below its feet ({resting['point']} {resting['below']:.3g} {unit} "
            "under the floor through their soles on most frames): its lowest point moved "
            f"from height {note['height']:.4g} {unit} to 0, not levelled"
        )
    if note.get("unsupported"):
        return (
            f"floor tilted {note['tilt_deg']:.2f} deg through soles at {note['places']:.2g} "
            "places (a tilt needs three): not levelled; the lowest contact's sole moved from "
            f"height {note['height']:.4g} {unit} to 0"
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
