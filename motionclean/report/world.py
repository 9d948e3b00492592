"""World-space figures of a report: end effectors (``world``) and feet on the ground
(``contacts``), with their terminal lines. Positions in file units; speeds in units/s and in
body heights per second. The lines say lengths in ``unit``: "units" (the file's own), or
"m" where the format fixes metres (``core.words.length_word``)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core import contacts as found
from ..core import kinematics
from ..core.motion import Motion
from ..core.restpose import rest_frames, trim
from ..core.takes import take_spans, take_starts
from ..core.words import percent, plural
from . import metrics
from .metrics import known, pair, rms_and_max


def format_world(world: dict, unit: str = "units") -> str:
    """One line: up axis, body height and the end effector that moved most (or why the
    clip has no world figures)."""
    if "skipped" in world:
        return f"world: skipped ({world['skipped']})"
    given = {"given": " (given)", "assumed": " (assumed: the format's default)"}.get(
        str(world.get("up_axis_source")), ""
    )
    shown = contradiction_words(world)
    if shown:
        given = f"{given[:-1]}; {shown})"
    text = f"world: up axis {world['up_axis']}{given}, {size_words(world, unit)}"
    worst = world.get("worst_deviation")
    if worst is not None:
        text += f"; largest end-effector deviation {worst['effector']} {worst['max']:.3g} {unit}"
        if worst["max_percent"] is not None:  # (null: no body height)
            of = "body height" if world.get("has_body", True) else "size"
            text += f" ({worst['max_percent']:.2g} % of {of})"
    return text


def size_words(world: dict, unit: str = "units") -> str:
    """ "body height 24.27 units", or for a skeleton that is no body (``has_body`` false: a
    hand, a head, a camera) "size 14.63 units (no body)"; "no body height (no skeleton)"
    for a lone tracked body (null). Lengths in ``unit``."""
    height = world["body_height"]
    if height is None:
        return "no body height (no skeleton)"
    if not world.get("has_body", True):  # (absent from older reports)
        return f"size {height:.4g} {unit} (no body)"
    return f"body height {height:.4g} {unit}"


def figure_points(motion: Motion) -> np.ndarray:
    """The points (joints, then end sites; sorted) whose world positions
    :func:`world_figures` and :func:`contact_figures` read: the end effectors and every
    point of each foot."""
    index, _ = kinematics.end_effectors(motion)
    feet, _, _ = found.skeleton_feet(motion)
    feet_points = [p for foot in feet for p in (foot.ankle, *foot.points)]
    return np.union1d(index, feet_points).astype(np.intp)  # (an int array also when empty)


def figure_positions(
    motion: Motion, used: np.ndarray | None = None, up: str | None = None
) -> np.ndarray:
    """``(F, len(used), 3)`` world positions of the points ``used`` (default: the
    :func:`figure_points` of ``motion``), turned
    :func:`~motionclean.core.kinematics.upright` where the figure stands head down (along
    ``up``, e.g. ``"-y"``; default: found on ``motion``)."""
    only = figure_points(motion) if used is None else used
    return kinematics.upright_positions(motion, up, only=only)


def _positions(motion: Motion, given: np.ndarray | None, used: np.ndarray) -> np.ndarray:
    return figure_positions(motion, used) if given is None else given


def _feet_on(feet: list[found.Foot], used: np.ndarray) -> list[found.Foot]:
    """``feet`` with their ankle and points numbered as columns of positions of the points
    ``used`` (sorted; the IK joints ``hip`` and ``knee`` are not looked up)."""
    column = {int(p): c for c, p in enumerate(used.tolist())}
    return [
        dataclasses.replace(f, ankle=column[f.ankle], points=tuple(column[p] for p in f.points))
        for f in feet
    ]


def _unknown(motion: Motion, index: np.ndarray) -> np.ndarray:
    """``(F, len(index))``: points whose world position is unknown (tracker dropouts)."""
    points = kinematics.missing_points(motion)
    if points is None:
        return np.zeros((motion.n_frames, index.size), dtype=bool)
    return points[:, index]


def _effectors(
    accel: np.ndarray, columns: np.ndarray, unknown: np.ndarray, starts: np.ndarray | None
):
    """RMS and max over frames of the ``columns`` of ``(F-2, P)`` accelerations, leaving
    out the rows whose three frames include an ``unknown`` ``(F, len(columns))`` position
    or lie across a cut between takes (``starts``, :func:`metrics.left_out`)."""
    accel = accel.take(columns, axis=1)  # C order, as the sums below expect
    return rms_and_max(metrics.left_out(accel, unknown, starts))


def world_figures(
    before: Motion,
    after: Motion | None = None,
    points: list | None = None,
    used: np.ndarray | None = None,
    starts: np.ndarray | None = None,
) -> dict[str, Any]:
    """The report's ``world`` section: up axis (and whether it was ``"given"`` with the clip,
    :attr:`Motion.up`, or ``"found"`` from its motion; :func:`up_contradicted`: what the
    motion shows against a given one), body height (file units) and, per end
    effector (end sites and bare leaf joints, keyed by name), the RMS and max linear
    acceleration before/after (units/s^2) and, when cleaned, the deviation from the input
    (RMS and max, file units and % of body height), plus the worst effector. ``points``
    holds both clips' :func:`figure_positions` of the points ``used`` (default: the
    :func:`figure_points` of ``before``) when the caller has them; the accelerations across
    a cut between takes (``starts``: each new take's first frame) are left out."""
    up = kinematics.up_axis(before)
    height = kinematics.body_height(before, up)
    index, names = kinematics.end_effectors(before)
    used = figure_points(before) if used is None else used
    columns = np.searchsorted(used, index)
    dt = before.frame_time
    points = points or [None, None]
    # every figure point's figures, then the effectors' columns: no copy of their positions
    # rows that involve a point unknown in either clip are left out of both
    unknown = _unknown(before, index)
    if after is not None:
        unknown |= _unknown(after, index)
    points_b = _positions(before, points[0], used)
    rms_b, max_b = _effectors(metrics.linear_acceleration(points_b, dt), columns, unknown, starts)
    if after is not None:
        points_a = _positions(after, points[1], used)
        rms_a, max_a = _effectors(
            metrics.linear_acceleration(points_a, dt), columns, unknown, starts
        )
        moved = metrics.distance(points_b, points_a).take(columns, axis=1)
        moved[unknown] = np.nan
        dev_rms, dev_max = rms_and_max(moved)
    scale = 100.0 / height if height > 0 else math.nan
    effectors: dict[str, dict] = {}
    for n, name in enumerate(names):
        a = after is not None
        entry = effectors[name] = {
            "linear_accel_rms": pair(rms_b[n], rms_a[n] if a else None),
            "linear_accel_max": pair(max_b[n], max_a[n] if a else None),
        }
        if a:
            entry["deviation"] = {
                "rms": known(dev_rms[n]),
                "max": known(dev_max[n]),
                "rms_percent": known(dev_rms[n] * scale),
                "max_percent": known(dev_max[n] * scale),
            }
    worst = None
    if after is not None and names and not np.isnan(dev_max).all():
        n = int(np.nanargmax(dev_max))
        worst = {
            "effector": names[n],
            "max": float(dev_max[n]),
            "max_percent": known(dev_max[n] * scale),
        }
    return {
        "up_axis": kinematics.up_name(before),
        "up_axis_source": _up_source(before),
        "up_axis_contradicted": up_contradicted(before),
        "body_height": height if height > 0 else None,
        "has_body": found.has_body(before),
        "effectors": effectors,
        "worst_deviation": worst,
    }


def up_contradicted(motion: Motion) -> dict | None:
    """The up direction the motion of ``motion`` shows against the one it declares
    (:func:`~motionclean.core.kinematics.up_contradiction`): ``up_axis`` (``"y"``, ``"-y"``),
    ``by`` (``"trunk"``, or ``"limbs"``: on all fours) and ``share`` (of the frames
    sampled); None where the motion does not contradict it."""
    shown = kinematics.up_contradiction(motion)
    if shown is None:
        return None
    return {
        "up_axis": kinematics.axis_name(shown.axis, shown.sign),
        "by": shown.by,
        "share": shown.share,
    }


def steps_up_contradicted(motion: Motion, pipeline: list[dict]) -> list[dict]:
    """The up axes steps were given as their own ``up`` (``ground``, ``footlock``) that the
    motion of ``motion`` contradicts, as :func:`up_contradicted` judges ``--up``: per
    such step ``filter``, ``up_axis`` (given) and ``shown`` (what the motion shows). An
    ``up`` that is the clip's own (``--up``, a file's) is judged as the clip's."""
    out = []
    for step in pipeline:
        given = step.get("up")
        if given in (None, "auto") or given == motion.up:
            continue
        shown = up_contradicted(motion.replace(up=given))
        if shown is not None:
            out.append({"filter": step.get("filter"), "up_axis": given, "shown": shown})
    return out


def contradiction_words(world: dict) -> str:
    """What the motion shows against the declared up axis (the ``world`` section's
    ``up_axis_contradicted``), in words ("the motion's trunk points along +y on 97 % of
    frames"), or ``""``."""
    shown = world.get("up_axis_contradicted")
    if not shown:
        return ""
    way = shown["up_axis"] if shown["up_axis"].startswith("-") else f"+{shown['up_axis']}"
    share = percent(shown["share"])
    what = "'s trunk points" if shown["by"] == "trunk" else " stands on all fours"
    return f"the motion{what} along {way} on {share} of frames"


def _up_source(motion: Motion) -> str:
    """Where the clip's up axis comes from: ``"found"`` from the motion, ``"given"`` (by
    ``--up`` or a file that declares it, as glTF's y) or ``"assumed"``: a format's default
    its file does not state (a Motive export's y, its text's ``assumed_up``)."""
    if motion.up is None:
        return "found"
    assumed = getattr(motion.source, "assumed_up", None)
    return "assumed" if assumed is not None and motion.up == assumed else "given"


def contact_figures(
    before: Motion,
    after: Motion | None = None,
    points: list | None = None,
    used: np.ndarray | None = None,
) -> tuple[dict | None, dict]:
    """The report's ``contacts`` section and the per-foot plot series.

    Contacts are found on ``before`` with the footlock step's default thresholds (on
    ``after``, with its ground and floor, where ``before`` shows none, its noise or
    dropouts hiding them: ``found_on`` ``"cleaned"``, else ``"input"``); per foot
    (keyed by ankle joint name): the contacts (``[first, stop)`` frame runs), skate (mean
    horizontal ankle speed during contacts, units/s and body heights/s) and ground
    penetration (deepest point below each clip's own ground, units) before and after, over
    the whole clip (``penetration``: a landing heel's impact a frame before its contact
    counts) and during the contacts (``penetration_during_contacts``, what ``footlock``
    answers for; None for a foot without contacts).
    ``None`` and no series for a clip without feet. The series hold each foot's lowest
    point above its clip's ground per frame, before and after. ``floor`` is the plane
    through the contacts' soles (:func:`~motionclean.core.contacts.fit_floor`): its height
    along the up axis at their centre, its tilt from level (degrees), normal and offset (a
    point ``p`` stands ``normal . p - offset`` above it, units; the clip turned upright),
    and how many contacts it rests on (None without contacts); ``floor_after`` the cleaned
    clip's (:func:`_floor_after`; None for one clip). ``points`` and ``used`` as in
    :func:`world_figures`.

    Rest-pose frames at the clip's ends (:func:`~motionclean.core.restpose.rest_frames`)
    are left out, as from every figure: no contact, depth or ground is found on them, and
    the height series hold NaN there (a T-pose header frame can stand far off the floor).
    """
    lead, trail = rest_frames(before)
    if not lead and not trail:
        return _contact_figures(before, after, points, used)
    core = slice(lead, before.n_frames - trail)
    section, series = _contact_figures(
        trim(before, lead, trail),
        None if after is None else trim(after, lead, trail),
        [None if p is None else p[core] for p in (points or [None, None])],
        used,
    )
    if section is None:
        return section, series
    for foot in section["feet"].values():
        foot["contacts"] = [[first + lead, stop + lead] for first, stop in foot["contacts"]]
    for data in series.values():
        data["contacts"] = [(first + lead, stop + lead) for first, stop in data["contacts"]]
        for key in ("height_before", "height_after"):
            if data[key] is not None:
                padded = np.full(before.n_frames, np.nan)
                padded[core] = data[key]
                data[key] = padded
    return section, series


def _contact_figures(
    before: Motion,
    after: Motion | None,
    points: list | None,
    used: np.ndarray | None,
) -> tuple[dict | None, dict]:
    """:func:`contact_figures` of a clip without rest-pose frames."""
    skeleton_feet, up, height = found.skeleton_feet(before)
    if not skeleton_feet:
        return None, {}
    used = figure_points(before) if used is None else used
    feet = _feet_on(skeleton_feet, used)
    points = points or [None, None]
    positions = _positions(before, points[0], used)
    dt = before.frame_time
    params = found.ContactParams()

    def standing_on(clip: Motion, where: np.ndarray) -> tuple[found.FootScene, found.Ground]:
        unknown = found.feet_unknown(kinematics.missing_points(clip), skeleton_feet)
        scene = found.FootScene.of_motion(clip, feet, up, height, None, where, unknown)
        return scene, found.find_ground(scene, params)

    scene, standing = standing_on(before, positions)
    after_positions = None if after is None else _positions(after, points[1], used)
    hidden = False  # the contacts, ground and floor are the cleaned clip's
    if after is not None and after_positions is not None and not standing.contacts.any():
        # an input can show no contact where the cleaned clip does (a body swung by a noisy
        # root metres from it): the cleaned clip's, on which both clips are measured
        cleaned, found_there = standing_on(after, after_positions)
        if found_there.contacts.any():
            hidden, scene, standing = True, cleaned, found_there
    contacts, ground = standing.contacts, standing.height
    tilted = standing.floor if standing.tilted else None  # heights above it, else along up
    # a clip of several takes: each take's own contacts (a foot that teleports at a cut is
    # no contact ending there), on the clip's ground
    starts = take_starts(before)
    takes = take_spans(starts, before.n_frames)
    if starts.size and not math.isnan(ground):
        where = scene.positions
        contacts = np.concatenate(
            [
                found.detect(
                    found.FootScene(where[take], feet, up, height, dt), params, ground, tilted
                )[0]
                for take in takes
            ]
        )
    upward = kinematics.up_name(before)
    after_floor, after_soles = (  # the cleaned clip's floor, where there are both
        (None, None)
        if after is None or after_positions is None or standing.floor is None
        else (standing.floor, standing.soles)
        if hidden  # (found on it)
        else _floor_under(after, after_positions, scene, standing.resting, upward)
    )
    # fewer than 2 frames find no ground: no contacts, and the skate, the depth below the
    # ground and the heights above it absent (None), not NaN
    grounded = not math.isnan(ground)
    absent = {"before": None, "after": None}
    clips = [positions] if after_positions is None else [positions, after_positions]
    skate = [found.skate(p, feet, contacts, up, dt, starts, found.DRIFT_SECONDS) for p in clips]
    if grounded:
        # each clip against its own ground: the cleaned clip's is the input's moved by how
        # far its feet moved during contacts (the median: a step that moves the whole clip,
        # as ground does, moves its ground; one that sinks a few frames does not); heights
        # above a tilted floor where contacts were found so, the cleaned clip's above its
        # own (floor_after, through its soles: levelled by ground, it is level)
        planes = [tilted, after_floor if tilted is not None else None]
        lowest = [found.lowest_points(p, feet, up, q) for p, q in zip(clips, planes, strict=False)]
        grounds = [ground]
        if len(clips) > 1:
            moved = lowest[1][contacts] - lowest[0][contacts]
            shift = float(np.median(moved)) if moved.size else 0.0
            # (the ground found on the cleaned clip: the input's is it moved back)
            grounds = [ground - shift, ground] if hidden else [ground, ground + shift]
        depth = [found.penetration(low, g) for low, g in zip(lowest, grounds, strict=True)]
        held = [  # during the contacts alone
            found.penetration(np.where(contacts, low, np.inf), g)
            for low, g in zip(lowest, grounds, strict=True)
        ]
        low = [points - g for points, g in zip(lowest, grounds, strict=True)]
    per_take = [found.contact_runs(contacts[take]) for take in takes]  # none across a cut
    runs = [
        [
            (take.start + first, take.start + stop)
            for take, found_runs in zip(takes, per_take, strict=True)
            for first, stop in found_runs[k]
        ]
        for k in range(len(feet))
    ]
    floor, soles = standing.floor, standing.soles
    section: dict[str, Any] = {
        "up_axis": upward,
        "found_on": "cleaned" if hidden else "input",
        "ground": ground if grounded else None,
        "floor": None
        if floor is None
        else {
            **_plane(floor, soles),
            "contacts": int(soles.shape[0]),
            "contacts_found_above_it": standing.tilted,
            "terrain": found.terrain(floor, kinematics.upright_body_up(before)),
        },
        "floor_after": None
        if floor is None or after_floor is None or after_soles is None
        else _floor_after(floor, after_floor, after_soles, height),
        "feet": {},
    }
    series: dict[str, dict] = {}
    for k, foot in enumerate(feet):
        a = after_positions is not None
        skated = (  # undefined for a foot that never touches the ground: null in JSON
            pair(skate[0][k], skate[1][k] if a else None)
            if math.isfinite(skate[0][k])
            else dict(absent)
        )
        section["feet"][foot.name] = {
            "contacts": [list(run) for run in runs[k]],
            "frames": int(contacts[:, k].sum()),
            "skate": skated,
            "skate_body_heights": {
                key: None if value is None else value / height for key, value in skated.items()
            },
            "penetration": pair(depth[0][k], depth[1][k] if a else None)
            if grounded
            else dict(absent),
            "penetration_during_contacts": pair(held[0][k], held[1][k] if a else None)
            if grounded and contacts[:, k].any()
            else dict(absent),
        }
        series[foot.name] = {
            "height_before": low[0][:, k] if grounded else None,
            "height_after": low[1][:, k] if grounded and a else None,
            "contacts": runs[k],
        }
    return section, series


def _floor_under(
    after: Motion,
    positions: np.ndarray,
    before: found.FootScene,
    resting: np.ndarray,
    upward: str,
) -> tuple[found.Floor | None, np.ndarray]:
    """The cleaned clip's floor and the soles ``(n, 3)`` it rests on: the plane through
    ``after``'s soles (``positions``, turned upright along the input's ``upward``, e.g.
    ``"-y"``, of the feet of the input's scene ``before``) of the contacts the input's
    floor rests on (``resting``), fitted as the input's, the prior following ``after``'s
    own trunk: the input's plane where the clip is the input's, moved with it where a step
    (``ground``) moved it."""
    up = kinematics.axis_index(upward)
    scene = found.FootScene.of_motion(after, before.feet, up, before.height, upward, positions)
    return found.floor_of_contacts(scene, resting)


#: The cleaned clip's floor is the input's (the page draws one line, the terminal names one
#: floor) where the two planes lie at most this far apart (body heights) below every sole
#: of the cleaned clip: closer than the feet stand to their own floor (the lowest points
#: of contacts 0.006-0.027 off it on tilted walks, stairs and ramps). The default pipeline
#: leaves the floor within 0.024 (footlock on noisy stairs; video estimates 0.011, clean
#: captures 0); ``ground`` moves it by 0.32-0.42 on walks tilted 8-10 degrees, by
#: 0.05-0.5 on level captures off height 0 (by 0.003-0.027 on those already near it).
FLOOR_KEPT = 0.03


def _plane(floor: found.Floor, soles: np.ndarray) -> dict[str, Any]:
    """A floor's entry in the report: its height along the up axis below the centre of its
    ``soles`` ``(n, 3)``, tilt (degrees), normal and offset."""
    return {
        "height": floor.height_at(soles.mean(axis=0)),
        "tilt_deg": floor.tilt_deg,
        "normal": [float(v) for v in floor.normal],
        "offset": float(floor.offset),
    }


def _floor_after(
    floor: found.Floor, after: found.Floor, soles: np.ndarray, height: float
) -> dict[str, Any]:
    """The ``contacts.floor_after`` entry: the cleaned clip's ``after`` floor (its height
    at the centre of its ``soles``, tilt, normal and offset, as ``contacts.floor``), how
    far apart the two planes lie below those soles (``apart``, units) and whether that is
    within :data:`FLOOR_KEPT` body heights (``same``: the input's floor kept)."""
    apart = float(np.abs(after.heights_at(soles) - floor.heights_at(soles)).max())
    return {
        **_plane(after, soles),
        "apart": apart,
        "same": apart <= FLOOR_KEPT * height,
    }


def format_floor(section: dict, unit: str = "units") -> str | None:
    """The floor's line of a contacts section (None without a floor): its height along the
    up axis, tilt and the contacts it rests on; then the cleaned clip's height and tilt
    where its floor is not the input's (``floor_after``, :data:`FLOOR_KEPT`)."""
    floor = section.get("floor")
    if not floor:
        return None
    slope = ", rising under an upright body: stairs or a slope" if floor.get("terrain") else ""
    moved = section.get("floor_after")  # (absent from older reports)
    after = (
        ""
        if not moved or moved["same"]
        else f" -> height {_as_precise(moved['height'], floor['height'])}, "
        f"tilt {moved['tilt_deg']:.2f} deg after"
    )
    return (
        f"floor: height {floor['height']:.4g} {unit}, tilt {floor['tilt_deg']:.2f} deg{slope} "
        f"(through the soles of {plural(floor['contacts'], 'contact')}){after}"
    )


def _as_precise(value: float, given: float) -> str:
    """``value`` to the decimals that ``given`` shows at 4 significant digits: the cleaned
    floor's height put at 0 by ``ground`` reads 0, not its fit's 1e-15."""
    digits = max(0, 3 - math.floor(math.log10(abs(given)))) if given else 4
    return f"{round(value, digits) + 0.0:.4g}"


def depth_text(foot: dict, arrow: str, number: Callable[[float], str], unit: str = "units") -> str:
    """A foot's depth below the ground, before ``arrow`` after: during its contacts (what
    ``footlock`` answers for), then at any frame (a landing heel's impact before its
    contact starts, a swing smoothed down); at any frame alone for a foot without
    contacts."""

    def change(depth: dict) -> str:
        after = "" if depth["after"] is None else f" {arrow} {number(depth['after'])}"
        return number(depth["before"]) + after

    anywhere = change(foot["penetration"])
    standing = foot.get("penetration_during_contacts")  # (absent from older reports)
    if standing is None or standing["before"] is None:
        return f"{anywhere} {unit}"
    return f"during contacts {change(standing)} {unit} (at any frame {anywhere})"


def found_on_cleaned(section: dict | None) -> bool:
    """Whether a report's ``contacts`` section was found on the cleaned clip (the input's
    noise or dropouts hid every contact; ``found_on`` is absent from older reports)."""
    return (section or {}).get("found_on") == "cleaned"


def format_contacts(section: dict, joints: dict | None = None, unit: str = "units") -> list[str]:
    """One terminal line for the floor, then one per foot: contacts, skate before/after,
    penetration, and whether ``footlock`` left its sliding contacts (``joints``: the
    report's, whose ankle notes say so)."""
    floor = format_floor(section, unit)
    lines = [] if floor is None else [floor]
    if found_on_cleaned(section):
        lines.append("contacts: none found in the input; those of the cleaned clip, on its ground")
    for name, foot in section["feet"].items():
        skate = foot["skate_body_heights"]
        text = (
            f"foot {name}: {plural(len(foot['contacts']), 'contact')} "
            f"({plural(foot['frames'], 'frame')})"
        )
        if skate["before"] is not None and not math.isnan(skate["before"]):
            text += f", skate {skate['before']:.3f}"
            if skate["after"] is not None:
                text += f" -> {skate['after']:.3f}"
            text += " body heights/s"
        pen = foot["penetration"]
        if pen["before"] is None:
            lines.append(text + ", ground not found (needs at least 2 frames)")
            continue
        text += f", below ground {depth_text(foot, '->', lambda v: f'{v:.3g}', unit)}"
        if "left" in ((joints or {}).get(name) or {}).get("footlock", {}):
            text += "; footlock left it (the error it expects at the ankle is under its tolerance)"
        lines.append(text)
    return lines
