"""The ``footlock`` step: feet that stand stay planted.

Contacts are found in world space (:mod:`motionclean.core.contacts`). During each contact
whose ankle slides, the legs are planted by the least weighted change of the joints from
the root down to the knee, and the toes too (``toes``, on by default) by the same joints
and the ankle's own rotation and the toe joints while each toe point is planted itself
(:func:`motionclean.filters.footlock.plant`): each joint is weighted by the error the
``auto`` step before it expects in it (its notes' ``expected_error``; without ``auto``, by
the noise estimated on the clip), so a joint ``auto`` found clean barely moves and a clip
it found clean is left as it is. Only those joints change, and only around the contacts
held; a clip with no ground contact is left as it is.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..core import contacts as found
from ..core import kinematics, quat
from ..core.motion import Motion
from ..core.rates import whole_frames
from ..core.words import plural
from ..filters.auto import estimate_noise, estimate_position_noise
from ..filters.footlock import TOE_TOLERANCE, Leg, Prior, held_toes, hinge_axis, plant
from .base import (
    UP_PARAM,
    Param,
    StepData,
    StepSpec,
    crop_runs,
    format_runs,
    given_up,
    held_at_mean,
    shift_runs,
)

#: A contact starts below this many times the ankle's expected position error, per second
#: (:func:`noise_aware`), when that is above the step's ``speed`` ... (6 had been set while
#: CMU's fixed hip joints, which ``auto`` now holds at their means, added their masks'
#: error to the legs': at 30 fps it then found 10 % fewer contact frames, the toes 29 of
#: 36 walks within 1.2 of their capture's skate against 35; 7: 34, at 120 fps the same)
NOISE_SPEED = 7.0
#: ... but never above this many times ``speed``.
NOISE_SPEED_CAP = 2.0
#: A solved joint that turned by no more than this anywhere (radians, 6e-7 degrees; a foot
#: planted moves its leg by thousandths of a degree at least) keeps its input rotations:
#: the solve's round-off on a joint the noise model calls exact (video2bvh's
#: never-rotating joints turned by 4e-8 degrees) would rewrite its full-precision text.
NEGLIGIBLE_TURN = 1e-8


def contact_params(params: dict) -> found.ContactParams:
    """The step's parameters as contact thresholds (body heights, seconds)."""
    return found.ContactParams.starting_at(params["height"], params["speed"], params["min_seconds"])


def find_contacts(motion: Motion, params: dict) -> tuple[found.FootScene, np.ndarray, float]:
    """The scene of ``motion``'s feet (world positions of every joint and end site, turned
    :func:`~motionclean.core.kinematics.upright`), their contacts ``(F, n_feet)`` under the
    step's parameters and the ground height (along the up axis, or above a tilted floor
    the contacts were found above: :class:`~motionclean.core.contacts.Ground`)."""
    given = given_up(params)
    feet, up, height = found.skeleton_feet(motion, params["feet"], given)
    scene = found.FootScene.of_motion(motion, feet, up, height, given)
    standing = found.find_ground(scene, contact_params(params))
    return scene, standing.contacts, standing.height


def _leg_points(
    motion: Motion, params: dict
) -> tuple[list[found.Foot], found.FootScene, np.ndarray]:
    """The feet, and the scene of the points the step reads alone: each foot's points and
    the joints from the root down to its knee, their world positions ``(F, n, 3)`` (turned
    :func:`~motionclean.core.kinematics.upright`) and the feet on them; and the point ->
    column map ``(P,)`` (-1: not kept)."""
    given = given_up(params)
    feet, up, height = found.skeleton_feet(motion, params["feet"], given)
    used = sorted({p for f in feet for p in (*f.points, *_chain(motion.parents, f.knee))})
    used_points = np.array(used, dtype=np.intp)
    positions = kinematics.upright_positions(motion, given, only=used_points)
    column = np.full(motion.n_joints + len(motion.end_sites), -1, dtype=np.intp)
    column[used_points] = np.arange(used_points.size)
    on_columns = [
        replace(
            f,
            hip=int(column[f.hip]),
            knee=int(column[f.knee]),
            ankle=int(column[f.ankle]),
            points=tuple(int(column[p]) for p in f.points),
        )
        for f in feet
    ]
    scene = found.FootScene.of_motion(motion, on_columns, up, height, given, positions)
    return feet, scene, column


def noise_aware(params: dict, positions, legs, prior: Prior, column, height: float):
    """The contact thresholds for a clip whose legs ``prior`` expects wrong: a contact
    starts below the step's ``speed`` or, when it is higher, the speed at which the
    ankles' expected position error alone (:func:`_expected_error` over the clip, the
    worst leg's) makes a standing foot seem to move (:data:`NOISE_SPEED` times it, at most
    :data:`NOISE_SPEED_CAP` times ``speed``): 3 degrees of noise at 30 fps leave a standing
    ankle moving at 0.15-0.2 body heights/s after ``auto``, and most of its contact was
    missed."""
    every = np.ones(positions.shape[0], dtype=bool)
    worst = max((_expected_error(positions, every, leg, prior, column) for leg in legs), default=0)
    speed = min(NOISE_SPEED * worst / height, NOISE_SPEED_CAP * params["speed"])
    if speed <= params["speed"]:
        return contact_params(params)
    return found.ContactParams.starting_at(params["height"], speed, params["min_seconds"])


def _captured(data: StepData, params: dict, column: np.ndarray) -> np.ndarray | None:
    """The points the step reads (``column``: point -> column of :func:`_leg_points`) as
    the clip entered the pipeline, turned upright as the clip now is, where the steps
    before changed the clip (None: they did not, or remade its frames). Not the entered
    clip's own feet and up: its dropouts can show it another up axis, or no feet, than the
    clip they were filled in (an IndexError on a tracker CSV with a gap)."""
    entered, motion = data.entered, data.motion
    assert motion is not None
    if entered is None or (
        np.array_equal(entered.rotations, motion.rotations)
        and np.array_equal(entered.translations, motion.translations)
    ):
        return None
    axis, sign = kinematics.up_direction(motion, given_up(params))
    used = np.flatnonzero(column >= 0)  # (in column order: columns were given in order)
    positions = kinematics.world_positions(entered, True, used)
    return kinematics.upright(positions, axis, sign)


def _sign(motion: Motion, params: dict) -> float:
    """+1.0, or -1.0 where the figure stands head down along its up axis."""
    return kinematics.up_direction(motion, given_up(params))[1]


def _chain(parents: np.ndarray, joint: int) -> list[int]:
    """``joint`` and its ancestors, root first."""
    chain = []
    while joint >= 0:
        chain.append(joint)
        joint = int(parents[joint])
    return chain[::-1]


def _legs(
    motion: Motion, feet: list[found.Foot], turns: set[int], toes: bool
) -> list[tuple[int, Leg]]:
    """The legs to plant, with their feet's indices: for each foot whose hip, knee and
    ankle may turn (are in ``turns``), the joints of ``turns`` from the root down to the
    knee, the knee's hinge, and the points held: the ankle, then with ``toes`` every joint
    and end site below it, held by turning the ankle and the joints of ``turns`` below it
    on the way to them."""
    hangs_on = kinematics.point_parents(motion)
    legs = []
    for k, foot in enumerate(feet):
        if not {foot.hip, foot.knee, foot.ankle} <= turns:
            continue
        points = foot.points if toes else (foot.ankle,)
        above = set(_chain(motion.parents, foot.ankle))
        below = {j for p in points[1:] for j in _chain(motion.parents, int(hangs_on[p]))}
        foot_joints = tuple(sorted(((below - above) | {foot.ankle}) & turns)) if toes else ()
        joints = set(_chain(motion.parents, foot.knee)) & turns
        hinge = hinge_axis(motion.rotations[:, foot.knee])
        legs.append((k, Leg(tuple(sorted(joints)), foot.knee, hinge, tuple(points), foot_joints)))
    return legs


def _toe_contacts(
    scene: found.FootScene,
    point_column: np.ndarray,
    legs: list[Leg],
    contacts: np.ndarray,
    standing: found.Ground,
    thresholds: found.ContactParams,
) -> np.ndarray:
    """``(F, n_toes)``: for each toe point of the legs whose toes are held, the frames of
    its leg's ``contacts`` where the point is planted itself (its own height above the
    ground ``standing`` gives, and speed under ``thresholds``: the step's own, not raised
    for noise, which cost the knees more than it took off the toes;
    :func:`motionclean.core.contacts.point_contacts`); ``point_column`` maps a point to
    its column of the ``scene``'s positions."""
    held = held_toes(legs)
    columns = [int(point_column[p]) for _, p in held]
    floor = standing.floor if standing.tilted else None
    own = found.point_contacts(scene, columns, thresholds, standing.height, floor)
    return own & contacts[:, [k for k, _ in held]]


def _expected_error(
    positions: np.ndarray,
    contacts: np.ndarray,
    leg: Leg,
    prior: Prior,
    column: np.ndarray | None = None,
) -> float:
    """RMS over a leg's contact frames of the position error of its ankle that ``prior``
    predicts (length units): each joint's rotation error times its lever arm to the ankle,
    and the root's translation error. ``column`` ``(P,)``: each point's column of
    ``positions`` (default: its own index)."""
    joints = list(leg.joints)
    at = np.arange(positions.shape[1]) if column is None else column
    held = positions[contacts]
    lever = held[:, [at[leg.points[0]]]] - held[:, at[joints]]
    spread = np.sum(np.sum(lever**2, axis=-1) * prior.sigma[joints] ** 2, axis=-1)
    return float(np.sqrt(np.mean(spread) + np.sum(prior.root**2)))


def _noted_error(note: dict) -> float:
    """The error an ``auto`` note expects of its column (degrees, or length units), 0 where
    it held the column at its mean (kept still: no motion above the noise) or every sample
    was missing (nothing to move)."""
    return 0.0 if held_at_mean(note) else float(note["expected_error"] or 0.0)


def _prior(data: StepData, legs: list[Leg], root: int) -> Prior:
    """Each joint's expected RMS rotation error (radians) and the root translation's
    (length units per axis) from ``auto``'s notes, or estimated from the clip without
    them; 0 (fixed) for joints and axes the step was not given."""
    motion = data.motion
    assert motion is not None
    names = motion.names
    sigma = np.zeros(motion.n_joints)
    joints = sorted({j for leg in legs for j in (*leg.joints, *leg.foot)})
    noted = [j for j in joints if "auto" in data.earlier.get(names[j], {})]
    for j in noted:
        sigma[j] = math.radians(_noted_error(data.earlier[names[j]]["auto"]))
    guessed = [j for j in joints if j not in noted]
    if guessed:
        sigma[guessed] = np.radians(estimate_noise(motion.rotations[:, guessed], motion.frame_time))
    root_sigma = np.zeros(3)
    position = motion.layout.position_columns[root] >= 0
    if position.any() and root in set(data.translation_joints.tolist()):
        note = data.earlier.get(names[root], {}).get("position_auto")
        if note is not None:
            level = _noted_error(note)
        else:
            level = float(
                estimate_position_noise(motion.translations[:, [root]], motion.frame_time)[0]
            )
        root_sigma[position] = level
    return Prior(sigma, root_sigma)


def _run(data: StepData, params: dict) -> StepData:
    motion = data.motion
    assert motion is not None
    if motion.n_frames < 2:  # no contact without a ground, none without two frames
        return data
    feet, scene, point_column = _leg_points(motion, params)
    positions, up, height = scene.positions, scene.up, scene.height
    column = {int(j): c for c, j in enumerate(data.rotation_joints)}
    every_leg = _legs(motion, feet, set(column), params["toes"])
    if not every_leg:
        return data
    root = _chain(motion.parents, every_leg[0][1].knee)[0]
    prior = _prior(data, [leg for _, leg in every_leg], root)
    thresholds = noise_aware(
        params, positions, [leg for _, leg in every_leg], prior, point_column, height
    )
    standing = found.find_ground(scene, thresholds)
    captured = _captured(data, params, point_column)
    contacts = found.sliding_contacts(
        scene, standing.contacts, params["min_skate"] * height, before=captured
    )
    held: np.ndarray = np.asarray(contacts.any(axis=0))
    chosen = [(k, leg) for k, leg in every_leg if held[k]]
    if not chosen:
        return data
    # a leg whose ankle auto expects within the tolerance of the truth is left as it is
    # (a clip auto found clean: nothing there to correct)
    limit = params["tolerance"] * height
    expected = {
        k: _expected_error(positions, contacts[:, k], leg, prior, point_column) for k, leg in chosen
    }
    for k in (k for k, _ in chosen if expected[k] < limit):  # said in the joint's note
        data.rotation_notes.setdefault(column[feet[k].ankle], {})["footlock"] = {
            "contacts": [],
            "frames": 0,
            "left": f"its sliding contacts left as they are: the ankle's expected error "
            f"(auto's, else the noise estimated on the clip) is {expected[k] / height:.2g} "
            f"body heights, under the tolerance {params['tolerance']:g} (a lower one holds "
            "them)",
        }
    chosen = [(k, leg) for k, leg in chosen if expected[k] >= limit]
    if not chosen:
        return data
    kept, legs = [k for k, _ in chosen], [leg for _, leg in chosen]
    # the floor under every sole (those the fit leaves out too): no foot is pushed through
    # it while it stands, none is lifted that stood below it; but not below every sole as
    # captured, where the steps before pushed the feet down (smoothing an Axis Studio
    # sit-stand's ankles had sunk a toe 1.2 units under any the capture held)
    floor, soles = found.floor_of_contacts(scene.of_feet(kept), contacts[:, kept], 0.0)
    floor = floor or found.Floor.level(-np.inf, up)
    lowest = float(floor.above(soles).min(initial=0.0))
    if captured is not None:
        as_captured = replace(scene, positions=captured).of_feet(kept)
        captured_soles = found.contact_soles(as_captured, contacts[:, kept])
        if captured_soles.size:
            lowest = max(lowest, float(floor.above(captured_soles).min()))
    floor = replace(floor, offset=floor.offset + lowest)
    # the floor as the clip's own coordinates have it (the positions were turned upright)
    normal = kinematics.upright(floor.normal, up, _sign(motion, params))
    rotations, root_translation = plant(
        motion.rotations,
        kinematics.local_translations(motion),
        motion.parents,
        motion.end_sites,
        legs,
        contacts[:, kept],
        prior,
        up,
        (normal, floor.offset),
        params["tolerance"] * height,
        whole_frames(params["blend_seconds"] / motion.frame_time),
        hold_frames=whole_frames(params["hold_seconds"] / motion.frame_time),
        toe_contacts=_toe_contacts(
            scene, point_column, legs, contacts[:, kept], standing, contact_params(params)
        ),
        toe_tolerance=params["toe_tolerance"],
        still_within=np.array([expected[k] for k in kept]),  # the noise's reach
    )
    data.rotations = data.rotations.copy()  # the input may be the clip's own array
    solved = sorted({j for leg in legs for j in (*leg.joints, *leg.foot)})
    turned = np.max(quat.angle_between(rotations[:, solved], motion.rotations[:, solved]), axis=0)
    changed = [j for j, angle in zip(solved, turned, strict=True) if angle > NEGLIGIBLE_TURN]
    data.rotations[:, [column[j] for j in changed]] = rotations[:, changed]
    if prior.root.any() and data.translations is not None:
        at = int(np.flatnonzero(data.translation_joints == root)[0])
        data.translations = data.translations.copy()
        axes = motion.layout.position_columns[root] >= 0
        data.translations[:, at, axes] = root_translation[:, axes]
    for k in kept:
        foot = feet[k]
        runs = found.contact_runs(contacts[:, [k]])[0]
        data.rotation_notes.setdefault(column[foot.ankle], {})["footlock"] = {
            "contacts": [list(run) for run in runs],
            "frames": int(contacts[:, k].sum()),
        }
    return data


def _format_note(note: dict, positions: bool) -> str:
    """The contacts held (``[first, stop)`` frame runs), shown as frames ``first-last``, or
    why the foot's were left."""
    if "left" in note:
        return note["left"]
    shown = format_runs(note["contacts"][:6])
    more = len(note["contacts"]) - 6
    held = f"held {plural(len(note['contacts']), 'contact')} ({plural(note['frames'], 'frame')})"
    return f"{held}: {shown}" + (f" and {more} more" if more > 0 else "")


def _merge_note(parts: list[tuple[dict, int]]) -> dict:
    """A foot's note from parts run on their own (takes, known stretches): frames held
    summed; left for the tolerance only where no part held a contact (None drops it)."""
    held = any(note["contacts"] for note, _ in parts)
    left = next((note["left"] for note, _ in parts if "left" in note), None)
    return {"frames": sum(note["frames"] for note, _ in parts), "left": None if held else left}


def _crop_note(note: dict, start: int, stop: int) -> dict | None:
    """The contacts held within frames ``[start, stop)``."""
    contacts = crop_runs(note["contacts"], start, stop)
    if not contacts:
        return None
    return {**note, "contacts": contacts, "frames": sum(b - a for a, b in contacts)}


STEP = StepSpec(
    name="footlock",
    smooths=False,
    name_patterns=("feet",),
    summary="plant each foot that slides during a ground contact, ankle and toes, by the "
    "least change of the leg joints weighted by the error auto expects in each",
    paper="contacts in world space; weighted least-change solve (Gauss-Newton, knee as a "
    "hinge), lines whose slope is shrunk by its standard error, smoothstep blends",
    params=(
        Param(
            "feet",
            "strs",
            None,
            "ankle joints to lock, fnmatch patterns (default: found from the skeleton's "
            "bones and the clip's poses: the leg chains above the lowest leaves)",
        ),
        UP_PARAM,
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
            "toes",
            "bool",
            True,
            "also hold each toe point (the joints and end sites below the ankle) while it is "
            "planted itself, on its own smoothed path, by the leg's joints and the ankle's "
            "own rotation and the toe joints; false holds the ankle alone and keeps the "
            "foot's rotations",
        ),
        Param(
            "toe_tolerance",
            "float",
            TOE_TOLERANCE,
            "the toes follow their paths this many times more loosely than the ankle its "
            "line (lower: less toe slide, the leg's rotations further from the capture)",
            minimum=0.1,
            maximum=1000.0,
        ),
        Param(
            "tolerance",
            "float",
            0.002,
            "how closely the ankle follows its target, body heights; the change of each "
            "joint is weighed against it",
            minimum=1e-9,  # (the solve weighs by its inverse square: finite down to here)
            maximum=1.0,
        ),
        Param(
            "min_skate",
            "float",
            0.1,
            "only contacts whose ankle slides faster than this over some 0.3 s of them are "
            "fixed, body heights per second (a capture's own feet slide 0.02-0.08); 0 fixes "
            "every contact",
            minimum=0.0,
        ),
        Param(
            "hold_seconds",
            "float",
            0.5,
            "the ankle follows its least-squares straight line over this window, the toes "
            "their path smoothed by a kernel whose standard deviation is half of it, both cut "
            "to the contact: jitter and sliding go, a steady drift (pivot) stays; a contact "
            "within one window is held on one line through it, and a stance (a contact of "
            "1.5 windows or more) whose ankle stays within the noise's reach of one line "
            "through it all is held on that line; inf holds every contact still at its mean "
            "position",
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
    format_note=_format_note,
    crop_note=_crop_note,
    merge_note=_merge_note,
    shift_note=lambda note, frames, _: {**note, "contacts": shift_runs(note["contacts"], frames)},
)
