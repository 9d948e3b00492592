"""Reports: per-joint noise and deviation figures, their plot series and the JSON report.

The JSON schema is described in the README ("Conventions", "World space"). Joints with
rotation channels get angular figures (degrees of rotation per s^2, degrees); joints with
position channels get ``linear_accel_rms`` / ``linear_accel_max`` (length units per s^2)
and ``deviation_length`` (length units). ``summary.noise_reduction`` is the fraction of the
RMS angular acceleration removed, ``1 - after / before``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from ..core import contacts as found
from ..core import kinematics, quat
from ..core.jumps import JUMP_DEG, jump_steps
from ..core.motion import Motion, run_labels
from ..core.rates import frames_floor
from ..core.restpose import rest_frames, trim
from ..core.takes import MAX_DEG_PER_S, MIN_DEG_PER_S, take_starts
from ..core.threads import run_parts
from ..core.words import plural
from ..filters.auto import estimate_noise
from ..steps.base import fps_text
from . import metrics
from .html_world import world_series
from .metrics import known, pair, rms_and_max
from .thrash import thrash_frames, worst_window
from .traces import Trace, traces
from .verdict import (
    CLEAN_CHANGE_DEG,
    FAST_BODY_HEIGHTS_PER_S,
    FAST_DEG_PER_S,
    JUMP_OVER_AROUND,
    PAIR_BRIEF_S,
    PAIR_REPAIR_DEG,
    UNCHANGED_DEG,
    build_verdict,
    listed,
)
from .world import (
    contact_figures,
    figure_points,
    figure_positions,
    steps_up_contradicted,
    world_figures,
)

__all__ = ["build_report", "build_series", "noise_figures", "to_json"]


#: Joints :func:`pair_repairs` reads at a time (the deviation table of that many joints).
_PAIR_BLOCK = 8


class PairRepairs(NamedTuple):
    """What a pair of clips shows repaired, without a step's notes (:func:`pair_repairs`):
    per joint, ``masks`` ``(F,)`` of the frames the figures leave out, and ``notes``: its
    ``turned`` runs (over :data:`~motionclean.report.verdict.PAIR_REPAIR_DEG`, with the
    brief run of changed frames around) and its ``brief_change`` runs (``runs``,
    ``max_deg``: changed on at most :data:`~motionclean.report.verdict.PAIR_BRIEF_S` in a
    row, as a repair), ``[start, stop)`` frames."""

    masks: dict[str, np.ndarray]
    notes: dict[str, dict]


def pair_repairs(before: Motion, after: Motion) -> PairRepairs:
    """The frames of each joint that ``after`` repaired, read from the two clips: the runs
    it changed (by more than :data:`~motionclean.report.verdict.UNCHANGED_DEG`; samples
    missing in either clip are no change) on no more than
    :data:`~motionclean.report.verdict.PAIR_BRIEF_S` in a row, a frame known and unchanged
    on each side, turned where they hold a frame turned by more than
    :data:`~motionclean.report.verdict.PAIR_REPAIR_DEG` (as are such frames in any run:
    un-flipped), else brief changes where the input shows a repair in them (:func:`_brief`);
    and brief changes that stand out of the changes around them where the input was a spike
    (:func:`_standing_out`: a spike taken out of a joint smoothed all along)."""
    rotating = np.flatnonzero(before.layout.has_rotation)
    longest = max(1, frames_floor(PAIR_BRIEF_S / before.frame_time))
    missing = _missing(before, after, rotating)
    masks: dict[str, np.ndarray] = {}
    notes: dict[str, dict] = {}
    for at in range(0, rotating.size, _PAIR_BLOCK):
        cols = rotating[at : at + _PAIR_BLOCK]
        change = metrics.deviation_deg(
            before.rotations[:, cols],
            after.rotations[:, cols],
            None if missing is None else missing[:, at : at + _PAIR_BLOCK],
        )
        steps = metrics.step_deg(before.rotations[:, cols])
        far, brief = _brief(change, steps / before.frame_time, longest)
        brief |= _standing_out(change, before.rotations[:, cols], steps, longest) & ~far
        turned_runs = found.contact_runs(far)
        brief_runs = found.contact_runs(brief)
        for k in np.flatnonzero((far | brief).any(axis=0)).tolist():
            name = before.names[cols[k]]
            masks[name] = far[:, k] | brief[:, k]
            notes[name] = {}
            if turned_runs[k]:
                notes[name]["turned"] = {"runs": [list(run) for run in turned_runs[k]]}
            if brief_runs[k]:
                peak = float(change[brief[:, k], k].max())
                runs = [list(run) for run in brief_runs[k]]
                notes[name]["brief_change"] = {"runs": runs, "max_deg": peak}
    return PairRepairs(masks, notes)


def _brief(change: np.ndarray, speed: np.ndarray, longest: int) -> tuple[np.ndarray, np.ndarray]:
    """``(F, C)`` each, from ``change`` (degrees, NaN where missing) and the input's steps
    ``speed`` ``(F-1, C)`` (degrees per second): the frames turned (over ``PAIR_REPAIR_DEG``,
    with the short bounded run of changed frames around them) and the brief changes.

    A run of changed frames is short with at most ``longest`` frames, bounded with a frame
    known and unchanged on each side (a clip end is none), and shows a repair where the
    input steps into and out of it faster than ``MIN_DEG_PER_S`` (a spike's jumps) or
    inside it faster than ``MAX_DEG_PER_S`` (a capped step): :data:`.verdict.PAIR_BRIEF_S`."""
    changed = change > UNCHANGED_DEG
    far = change > PAIR_REPAIR_DEG
    run = run_labels(changed)
    size = np.bincount(run.ravel(), minlength=1)
    first, last = changed.copy(), changed.copy()
    first[1:] &= ~changed[:-1]
    last[:-1] &= ~changed[1:]
    kept = change <= UNCHANGED_DEG  # (False where missing: NaN)
    # per frame, of the frame before and the step from it; of the frame after and the step
    # to it (none at the clip's ends)
    kept_before, kept_after = np.zeros_like(kept), np.zeros_like(kept)
    kept_before[1:], kept_after[:-1] = kept[:-1], kept[1:]
    jump_in, jump_out = np.zeros_like(kept), np.zeros_like(kept)
    jump_in[1:] = jump_out[:-1] = speed > MIN_DEG_PER_S
    bounded = _per_run(run, first, kept_before, size.size)
    bounded &= _per_run(run, last, kept_after, size.size)
    jumps = _per_run(run, first, jump_in, size.size) & _per_run(run, last, jump_out, size.size)
    inner = changed[:-1] & changed[1:] & (speed > MAX_DEG_PER_S)
    capped = np.bincount(run[:-1][inner], minlength=size.size) > 0
    holds_far = np.bincount(run[far], minlength=size.size) > 0
    short = (size <= longest) & bounded
    short[0] = False  # (label 0: outside every run)
    return far | (short & holds_far)[run], (short & ~holds_far & (jumps | capped))[run]


#: A run of frames stands out of the changes around it when every frame of it changed by
#: more than this many times the frames just before and after it (and the joint's median
#: change): a spike taken out (a step's repair, or a smoother's) in a joint smoothed all
#: along, which leaves no frame unchanged beside it.
STANDOUT = 3.0


def _standing_out(change: np.ndarray, q: np.ndarray, steps: np.ndarray, longest: int) -> np.ndarray:
    """``(F, C)``: the frames of spikes the cleaning took out while it changed the frames
    around them too (a joint smoothed all along leaves no frame unchanged beside a repair:
    20 degrees on the Head of a noisy walk, its neighbours moved by under 1), told as brief
    changes, not as motion taken for noise. A run of at most ``longest`` frames (no clip
    end) each changed by more than :data:`STANDOUT` times the frames just outside it and
    the column's median change, and over ``UNCHANGED_DEG`` (``change`` ``(F, C)`` degrees,
    NaN where missing; a joint left as it was changes by rounding alone), where the
    input ``q`` ``(F, C, 4)`` was a spike: it steps into and out of the run (``steps`` ``(F-1,
    C)`` degrees) by at least half the run's largest change and each step at least twice
    the turn between the frames outside the run, and the run's largest change is most of
    those steps (:data:`TAKEN_OUT`): the spike was taken out, not rounded off."""
    n_frames = change.shape[0]
    if n_frames < 3:
        return np.zeros(change.shape, dtype=bool)
    known_change = np.where(np.isnan(change), 0.0, change)
    floor = np.maximum(STANDOUT * np.median(known_change, axis=0, keepdims=True), UNCHANGED_DEG)
    big = known_change > floor
    big[[0, -1]] = False  # (a clip end is no bound)
    run = run_labels(big)
    n_runs = int(run.max()) + 1
    size = np.bincount(run.ravel(), minlength=n_runs)
    least, peak = np.full(n_runs, np.inf), np.zeros(n_runs)
    np.minimum.at(least, run[big], known_change[big])
    np.maximum.at(peak, run[big], known_change[big])
    first, last = big.copy(), big.copy()
    first[1:] &= ~big[:-1]
    last[:-1] &= ~big[1:]
    # (column by column, as run_labels numbers them: the k-th start and end are one run's)
    starts, ends = np.nonzero(first.T)[::-1], np.nonzero(last.T)[::-1]
    labels = run[starts]
    around = np.maximum(change[starts[0] - 1, starts[1]], change[ends[0] + 1, ends[1]])
    step_in, step_out = steps[starts[0] - 1, starts[1]], steps[ends[0], ends[1]]
    across = np.degrees(quat.angle_between(q[starts[0] - 1, starts[1]], q[ends[0] + 1, ends[1]]))
    jump = np.minimum(step_in, step_out)
    stands = np.zeros(n_runs, dtype=bool)
    stands[labels] = (
        (size[labels] <= longest)
        & (least[labels] > STANDOUT * np.nan_to_num(around, nan=np.inf))
        & (jump >= 0.5 * peak[labels])
        & (peak[labels] >= TAKEN_OUT * jump)
        & (jump >= 2.0 * across)
    )
    return stands[run]


#: ... and where the cleaning took out most of the excursion: its largest change at least
#: this share of the smaller step into or out of it (a spike taken out goes back onto its
#: neighbours' chord; a Butterworth on a running knee's sharp flexion at 30 fps, steps of
#: 9-13 degrees, lowers its peak by 5.8 and had been told as a brief change).
TAKEN_OUT = 0.75


def _per_run(run: np.ndarray, at: np.ndarray, values: np.ndarray, n_runs: int) -> np.ndarray:
    """``(n_runs,)`` bool: per label of ``run`` ``(F, C)``, ``values`` at its frame ``at``
    (each run's one True frame of ``at``); False for label 0 and runs without one."""
    per_run = np.zeros(n_runs, dtype=bool)
    per_run[run[at]] = values[at]
    return per_run


def build_series(
    before: Motion,
    after: Motion | None = None,
    repairs: dict[str, np.ndarray] | None = None,
    position_repairs: dict[str, np.ndarray] | None = None,
    level_turn: np.ndarray | None = None,
) -> dict[str, Any]:
    """Per-frame figures behind the report, per joint with rotation channels, reduced to
    what the HTML report plots and the figures the report reads. ``level_turn`` (a unit
    quaternion ``(w, x, y, z)``, or None) is the turn of the world the ``ground`` step gave
    the roots to level the floor: the roots' rotation change is measured from the input
    turned by it (levelling is no smoothing; the report says it apart).

    Returns ``{"frame_time": dt, "joints": {name: {"accel_before": Trace, "accel_after":
    Trace or None, "deviation": Trace or None}}, "figures": {...}, ...}``: the
    :class:`~motionclean.report.traces.Trace` of the angular acceleration magnitude in degrees of
    rotation per s^2 at frames 1..F-2 (000 Sec. VI-B) and of the rotation angle between
    input and output in degrees at every frame; 0 where a missing sample (tracker dropout)
    is involved. ``figures`` holds each figure's RMS and maximum per joint and over all
    joints, without the rows that involve the clip's rest-pose frames, and ``figures
    ["outside_repairs"]`` the same figures of the joints in ``repairs`` (joint name: ``(F,)``
    mask of the frames a repairing step changed, :func:`.verdict.repaired_frames`) without the
    rows that involve a repaired frame, and the accelerations of every joint without the rows
    that involve a step of the input over :data:`~motionclean.core.jumps.JUMP_DEG` that no
    step repaired (:func:`unrepaired_jumps`: a flip or glitch left in place is no jitter;
    the deviation keeps those frames, where a smoothing that crossed the flip moved the
    joint). ``unrepaired_jumps``: per joint name, how many such steps. ``fast_steps``: per
    joint whose rotation in ``after`` turns faster than a body can (:func:`fast_steps`),
    how many such steps and how many steps it has within the motion. ``thrash``: per joint
    whose rotation in ``after`` (``before`` without one) thrashes
    (:func:`~motionclean.report.thrash.thrash_frames`, within the motion), on how many
    frames and on how many seconds of its worst
    :data:`~motionclean.report.thrash.THRASH_WINDOW_S`. ``reaches``: per
    joint with rotation channels, :func:`~motionclean.core.kinematics.reaches`. No per-frame table
    of the joints is kept: each is reduced as soon as it is made (the feet's heights,
    ``(F,)`` per foot, are).

    ``figures["positions"]`` (None for a single clip or a clip without position channels)
    holds the same of the joints with position channels, outside the frames
    ``position_repairs`` marks (:func:`.verdict.repaired_positions`): their linear
    acceleration (length units/s^2) and the distance each moved (length units), per
    position joint ``(sum of squares, count, max)``, their ``names`` and ``travel``, the
    largest extent of any of their paths along an axis (length units).
    """
    dt = before.frame_time
    clips = (before, after)
    # World positions of the points the contact and world figures read (found once, on the
    # input), once per clip (the world rotations and the other points are not kept), let
    # go of before the per-frame tables are made.
    skipped = kinematics.world_note(before)
    # (no joint positions: no contact or world figure means anything)
    used = None if skipped is not None else figure_points(before)
    up = None if used is None else kinematics.up_name(before)  # the input's, for both clips
    points = (
        [None, None]
        if used is None
        else run_parts(
            lambda clip: None if clip is None else figure_positions(clip, used, up),
            clips,
            before.rotations.size,
        )
    )
    lead, trail = rest_frames(before)
    core = slice(lead, before.n_frames - trail)
    if skipped is not None:
        contacts, figures = None, {"skipped": skipped}
        feet: dict = {}
    else:
        contacts, feet = contact_figures(before, after, points, used)
        figures = world_figures(
            trim(before, lead, trail),
            None if after is None else trim(after, lead, trail),
            [None if p is None else p[core] for p in points],
            used,
            take_starts(before) - lead,
        )
    del points
    rotating = before.layout.has_rotation
    rot = np.flatnonzero(rotating)
    cols = slice(None) if rotating.all() else rot  # every joint: the arrays, not copies
    repairs = repairs or {}
    repaired = {
        n: repairs[before.names[j]] for n, j in enumerate(rot) if before.names[j] in repairs
    }
    accel_rows = {n: mask[:-2] | mask[1:-1] | mask[2:] for n, mask in repaired.items()}
    outside: dict[str, dict[int, tuple[float, int, float]] | None] = {}
    missing = _missing(before, after, cols)
    starts = take_starts(before)
    # a flip or glitch the input makes and no step repaired is no jitter either
    jumps = unrepaired_jumps(before.rotations[:, cols], repaired, missing, starts, lead, trail)
    unrepaired = {}  # joint name: how many
    near_jumps = {}  # column: its frames within NEAR_JUMP_S of such a step
    reach = max(int(round(NEAR_JUMP_S / dt)), 1)
    for n in np.flatnonzero(jumps.any(axis=0)).tolist():
        rows = jumps[:-1, n] | jumps[1:, n]
        accel_rows[n] = accel_rows[n] | rows if n in accel_rows else rows
        unrepaired[before.names[rot[n]]] = int(jumps[:, n].sum())
        touched = np.r_[jumps[:, n], False] | np.r_[False, jumps[:, n]]
        near_jumps[n] = _within(touched, reach)
        near_jumps[n][:lead] = False  # (rest frames: as the largest change leaves them out)
        near_jumps[n][near_jumps[n].size - trail :] = False
    del jumps

    def acceleration(clip: Motion | None, key: str) -> _Reduced | None:
        if clip is None:
            outside[key] = None
            return None
        # (rows across a cut between takes: left out, drawn as gaps)
        table = metrics.angular_acceleration(clip.rotations[:, cols], dt, missing, starts)
        outside[key] = _outside(table, lead, trail, accel_rows)
        return _reduced(table, lead, trail)

    # one clip after the other (each on threads): one clip-long table at a time
    acc_b, acc_a = acceleration(before, "accel_before"), acceleration(after, "accel_after")
    assert acc_b is not None
    dev = None
    outside["deviation"] = None
    changed_near: dict[str, float] = {}  # joint name: its largest change near such a step
    fast: dict[str, tuple[int, int]] = {}  # joint name: its steps too fast for a body, of all
    if after is not None:
        table = metrics.deviation_deg(before.rotations[:, cols], after.rotations[:, cols], missing)
        if level_turn is not None:
            _discount_turn(table, before, after, rot, level_turn, missing)
        outside["deviation"] = _outside(table, lead, trail, repaired)
        # (and away from the steps no step repaired: a smoother across a flip moves every
        # frame near it, which says nothing of what it took for noise elsewhere)
        away = {n: repaired[n] | near if n in repaired else near for n, near in near_jumps.items()}
        outside["deviation_away"] = _outside(table, lead, trail, repaired | away)
        changed_near = {
            before.names[rot[n]]: _largest(
                table[:, n], near & ~repaired[n] if n in repaired else near
            )
            for n, near in near_jumps.items()
        }
        dev = _reduced(table, lead, trail)
        del table
        counts, measured = fast_steps(after.rotations[:, cols], dt, missing, starts, lead, trail)
        fast = {
            before.names[rot[n]]: (int(counts[n]), int(measured[n]))
            for n in np.flatnonzero(counts).tolist()
        }
    # the cleaned clip's thrash, or the input's where it is reported on its own
    clip = before if after is None else after
    names = [before.names[j] for j in rot]
    thrash = _thrash(clip.rotations[:, cols], dt, missing, starts, (lead, trail), names)
    positions = (
        None
        if after is None
        else _position_series(before, after, position_repairs or {}, (lead, trail), starts)
    )
    joints = {}
    for n, j in enumerate(rot):
        joints[before.names[j]] = {
            "accel_before": acc_b.traces[n],
            "accel_after": None if acc_a is None else acc_a.traces[n],
            "deviation": None if dev is None else dev.traces[n],
        }
    return {
        "frame_time": dt,
        "joints": joints,
        "figures": {
            "accel_before": acc_b,
            "accel_after": acc_a,
            "deviation": dev,
            "outside_repairs": outside,
            "positions": positions,
        },
        "contacts": contacts,
        "feet": feet,
        "rest_frames": (lead, trail),
        "unrepaired_jumps": unrepaired,
        "changed_near_jumps": changed_near,
        "fast_steps": fast,
        "thrash": thrash,
        "reaches": kinematics.reaches(before)[rot],
        "world": {} if skipped is not None else world_series(before, after),
        "world_figures": figures,
    }


def _position_series(
    before: Motion,
    after: Motion,
    repairs: dict[str, np.ndarray],
    rest: tuple[int, int],
    starts: np.ndarray,
) -> dict[str, Any] | None:
    """:func:`build_series`' ``figures["positions"]``: per joint with position channels,
    ``(sum of squares, count, max)`` of its linear acceleration in either clip and of the
    distance it moved, over the rows outside the rest frames, the missing samples and the
    frames in ``repairs`` (joint name: ``(F,)`` mask); None without position channels."""
    joints = np.flatnonzero(before.layout.has_position)
    if joints.size == 0:
        return None
    lead, trail = rest
    dt = before.frame_time
    missing = _missing(before, after, joints)
    none = np.zeros(before.n_frames, dtype=bool)
    masks = {n: repairs.get(before.names[j], none) for n, j in enumerate(joints)}
    rows = {n: mask[:-2] | mask[1:-1] | mask[2:] for n, mask in masks.items()}
    figures: dict[str, Any] = {"names": [before.names[j] for j in joints]}
    for key, clip in (("accel_before", before), ("accel_after", after)):
        table = metrics.linear_acceleration(clip.translations[:, joints], dt, missing, starts)
        figures[key] = _outside(table, lead, trail, rows)
    moved = metrics.distance(before.translations[:, joints], after.translations[:, joints], missing)
    figures["deviation"] = _outside(moved, lead, trail, masks)
    path = before.translations[lead : before.n_frames - trail, joints]
    if missing is not None:
        path = np.where(missing[lead : before.n_frames - trail, :, None], np.nan, path)
    seen = ~np.isnan(path).all(axis=(0, 2))  # (a joint missing throughout: no path)
    path = path[:, seen]
    figures["travel"] = (
        float(np.max(np.nanmax(path, axis=0) - np.nanmin(path, axis=0))) if path.size else math.nan
    )
    figures["scale"], figures["scale_of"] = _jump_scale(before, figures["travel"])
    limit = FAST_BODY_HEIGHTS_PER_S * figures["scale"] if figures["scale"] > 0 else math.inf
    figures["fast"] = _position_jumps(
        after.translations[:, joints], dt, missing, starts, rest, limit
    )
    return figures


#: A body's height where lengths are metres but the clip has no body (SMPL parameters
#: without a body model, trackers in metres): the scale of position jumps.
METRES_BODY = 1.75


def _jump_scale(clip: Motion, travel: float) -> tuple[float, str]:
    """The length position jumps are measured in, and its words: the body height; without a
    body, :data:`METRES_BODY` where lengths are metres (a walk's range of travel, 10 m,
    would let any teleport under 3 m at 30 fps pass), else the positions' range of travel."""
    height = kinematics.body_height(clip) if found.has_body(clip) else 0.0
    if height > 0:  # (trackers' "height" is a frame's extent: a head and two hands, 0.4 m)
        return height, "body height"
    if kinematics.length_unit(clip) == "m":
        return METRES_BODY, f"body height ({METRES_BODY:g} m)"
    return (travel if math.isfinite(travel) else 0.0), "the positions' range of travel"


def _position_jumps(p, dt: float, missing, starts: np.ndarray, rest: tuple[int, int], limit):
    """Per column of the positions ``p`` ``(F, C, 3)`` (frame time ``dt`` s), over its steps
    within the motion (:func:`_in_motion`): how many jump (faster than ``limit`` length
    units per second and :data:`JUMP_OVER_AROUND` times the step before and the step after
    it: a step out of a still pose, as a teleport's; a punch's steps rise and fall), the
    fastest jump's speed (units/s, 0 without one) and the frame it steps into, ``(C,)``
    each."""
    n_cols = p.shape[1]
    speed = np.linalg.norm(np.diff(p, axis=0), axis=-1) / dt  # (F-1, C)
    speed = np.where(_in_motion(speed.shape, missing, starts, *rest), speed, 0.0)
    steps, cols = np.nonzero(speed > limit)  # (few: judged one by one, all at once)
    last = max(speed.shape[0] - 1, 0)
    beside = np.maximum(
        speed[np.maximum(steps - 1, 0), cols], speed[np.minimum(steps + 1, last), cols]
    )
    jump = speed[steps, cols] > JUMP_OVER_AROUND * beside
    steps, cols = steps[jump], cols[jump]
    count = np.bincount(cols, minlength=n_cols)
    fastest, at = np.zeros(n_cols), np.zeros(n_cols, dtype=np.intp)
    np.maximum.at(fastest, cols, speed[steps, cols])
    first = np.flatnonzero(speed[steps, cols] == fastest[cols])
    at[cols[first[::-1]]] = steps[first[::-1]] + 1  # (the first such step of a column)
    return count, fastest, at


#: Frames within this many seconds of a step the input makes over
#: :data:`~motionclean.core.jumps.JUMP_DEG` are near it: what smoothing moves there it moved
#: across the step.
NEAR_JUMP_S = 0.5


def _within(mask: np.ndarray, reach: int) -> np.ndarray:
    """``mask`` ``(F,)`` widened by ``reach`` rows on each side."""
    total = np.concatenate([[0], np.cumsum(mask)])
    index = np.arange(mask.size)
    low, high = np.maximum(index - reach, 0), np.minimum(index + reach + 1, mask.size)
    return total[high] > total[low]


def _largest(values: np.ndarray, rows: np.ndarray) -> float:
    """The largest of ``values`` at ``rows`` (a mask), NaN left out; 0 without any."""
    picked = values[rows]
    picked = picked[~np.isnan(picked)]
    return float(picked.max()) if picked.size else 0.0


def unrepaired_jumps(
    q: np.ndarray,
    repaired: dict[int, np.ndarray],
    missing: np.ndarray | None,
    starts: np.ndarray,
    lead: int,
    trail: int,
) -> np.ndarray:
    """``(F-1, C)`` bool: the steps between frames of the input's rotations ``q`` ``(F, C,
    4)`` over :data:`~motionclean.core.jumps.JUMP_DEG` that no step repaired (``repaired``:
    column -> ``(F,)`` frames a repairing step changed), within the motion
    (:func:`_in_motion`)."""
    jumps = jump_steps(q)
    jumps &= _in_motion(jumps.shape, missing, starts, lead, trail)
    for column, frames in repaired.items():
        jumps[:, column] &= ~(frames[:-1] | frames[1:])
    return jumps


def _in_motion(
    shape: tuple[int, ...], missing: np.ndarray | None, starts: np.ndarray, lead: int, trail: int
) -> np.ndarray:
    """``shape`` ``(F-1, C)`` bool (a read-only broadcast where nothing is missing): the
    steps between frames within the motion, not into a rest frame (``lead`` / ``trail`` at
    the ends), a ``missing`` sample ``(F, C)``, or across a cut between takes (``starts``:
    each new take's first frame)."""
    n = shape[0]
    rows = np.ones(n, dtype=bool)
    rows[:lead] = False
    rows[max(n - trail, 0) :] = False
    rows[starts[(starts >= 1) & (starts <= n)] - 1] = False
    if missing is None:
        return np.broadcast_to(rows[:, None], shape)
    return rows[:, None] & ~(missing[:-1] | missing[1:])


def fast_steps(
    q: np.ndarray,
    dt: float,
    missing: np.ndarray | None,
    starts: np.ndarray,
    lead: int,
    trail: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Per column of the rotations ``q`` ``(F, C, 4)`` (frame time ``dt`` s): how many of its
    steps within the motion (:func:`_in_motion`) turn faster than
    :data:`~motionclean.report.verdict.FAST_DEG_PER_S` degrees per second or by more than
    :data:`~motionclean.core.jumps.JUMP_DEG` degrees, and how many steps it has there:
    ``(C,)`` int each."""
    fast = jump_steps(q, min(FAST_DEG_PER_S * dt, JUMP_DEG))
    measured = _in_motion(fast.shape, missing, starts, lead, trail)
    fast &= measured
    return fast.sum(axis=0), measured.sum(axis=0)


def _thrash(
    q: np.ndarray,
    dt: float,
    missing: np.ndarray | None,
    starts: np.ndarray,
    rest: tuple[int, int],
    names: list[str],
) -> dict[str, tuple[int, float]]:
    """Per column (of ``names``) of the rotations ``q`` ``(F, C, 4)`` that thrashes within
    the motion (:func:`_in_motion`; ``rest``: the leading and trailing rest frames), its
    thrash frames and their seconds in its worst
    :data:`~motionclean.report.thrash.THRASH_WINDOW_S`."""
    shape = (max(q.shape[0] - 1, 0), q.shape[1])
    frames = thrash_frames(q, dt, _in_motion(shape, missing, starts, *rest))
    counts, worst = frames.sum(axis=0), worst_window(frames, dt)
    return {
        names[n]: (int(counts[n]), float(worst[n] * dt)) for n in np.flatnonzero(counts).tolist()
    }


def _discount_turn(
    table: np.ndarray,
    before: Motion,
    after: Motion,
    rot: np.ndarray,
    turn: np.ndarray,
    missing: np.ndarray | None,
) -> None:
    """The rotation change ``table`` ``(F, len(rot))`` (degrees) of the roots measured from
    ``before``'s turned by ``turn`` (written in place)."""
    roots = np.flatnonzero(before.parents[rot] < 0)
    if not roots.size:
        return
    turned = quat.multiply(turn, before.rotations[:, rot[roots]])
    table[:, roots] = metrics.deviation_deg(
        turned, after.rotations[:, rot[roots]], None if missing is None else missing[:, roots]
    )


def _missing(before: Motion, after: Motion | None, cols) -> np.ndarray | None:
    """``(F, C)``: the samples of the joints ``cols`` missing in either clip (None when
    neither misses any). The figures of both clips leave out every row that involves one,
    rotations and positions alike."""
    if before.missing is None and (after is None or after.missing is None):
        return None
    missing = before.missing_mask()[:, cols]
    return missing if after is None else missing | after.missing_mask()[:, cols]


def noise_figures(motion: Motion) -> _Reduced:
    """The angular acceleration figures (deg/s^2) ``report`` gives of ``motion`` alone, per
    joint with rotation channels and over all of them (:func:`build_series`' rules: rest
    frames and rows next to a missing sample left out)."""
    cols = np.flatnonzero(motion.layout.has_rotation)
    table = metrics.angular_acceleration(
        motion.rotations[:, cols],
        motion.frame_time,
        _missing(motion, None, cols),
        take_starts(motion),
    )
    return _reduced(table, *rest_frames(motion), drawn=False)


class _Reduced(NamedTuple):
    """A ``(N, R)`` table of one figure reduced: each joint's :class:`Trace` (none where
    not drawn), and over the rows without the rest-pose frames, each joint's RMS and max
    and the RMS and max of all."""

    traces: list[Trace]
    rms: np.ndarray
    max: np.ndarray
    total_rms: float
    total_max: float
    counts: np.ndarray | None = None


def _reduced(table: np.ndarray, lead: int, trail: int, drawn: bool = True) -> _Reduced:
    """:class:`_Reduced` of ``table``, whose values it overwrites (with their squares, for
    the RMS: no temporary as large as the table). The rows that involve a rest-pose frame
    and the NaN rows (missing samples) are left out of the figures and drawn as gaps, the
    same in every clip; ``drawn`` False: no traces (figures only)."""
    stop = table.shape[0] - trail
    table[:lead] = np.nan
    table[max(stop, lead) :] = np.nan
    shown = traces(table) if drawn else []
    core = table[lead:stop]
    known = ~np.isnan(core)
    counts = known.sum(axis=0)
    none = counts == 0  # every row of the column involves a missing sample
    if none.all():
        unknown = np.full(table.shape[1], np.nan)
        return _Reduced(shown, unknown, unknown, math.nan, math.nan, counts)
    largest = np.fmax.reduce(core, axis=0)  # NaN (missing) left out: the traces' peaks
    largest[none] = np.nan
    total_max = float(np.nanmax(largest))
    squares = np.square(core, out=core)
    squares[~known] = 0.0
    sums = squares.sum(axis=0)
    rms = np.where(none, np.nan, np.sqrt(sums / np.maximum(counts, 1)))
    total = float(np.sqrt(sums.sum() / counts.sum()))
    return _Reduced(shown, rms, largest, total, total_max, counts)


def _outside(
    table: np.ndarray, lead: int, trail: int, masks: dict[int, np.ndarray]
) -> dict[int, tuple[float, int, float]]:
    """Per column ``n`` of ``table`` in ``masks``: the sum of squares, count and max of its
    rows between the rest frames where ``masks[n]`` (rows of the table) is false."""
    found = {}
    stop = table.shape[0] - trail
    for n, mask in masks.items():
        values = table[lead:stop, n][~mask[lead:stop]]
        values = values[~np.isnan(values)]
        peak = float(values.max()) if values.size else 0.0
        found[n] = (float(np.dot(values, values)), int(values.size), peak)
    return found


def _per_joint(
    figures: dict, key: str, outside: str | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per joint, the sum of squares, count and max of the figure ``key`` of
    :func:`build_series`' ``figures``, outside the rows its ``outside_repairs`` leave out
    (under ``outside``, default ``key``)."""
    reduced = figures[key]
    counts = np.array(reduced.counts, dtype=np.float64)
    squares = np.nan_to_num(np.square(reduced.rms)) * counts  # (NaN: no row measured)
    largest = np.nan_to_num(np.array(reduced.max, dtype=np.float64))
    left = figures["outside_repairs"].get(outside or key) or {}
    for n, (square, count, peak) in left.items():
        squares[n], counts[n], largest[n] = square, count, peak
    return squares, counts, largest


def _input_noise(series: dict) -> dict[str, Any]:
    """The noise of a clip reported alone: its RMS angular acceleration (deg/s^2, each
    joint weighted by its reach, :func:`_reach_weights`; None where no three frames in a
    row are known) without the rows that involve a step of the input over
    :data:`~motionclean.core.jumps.JUMP_DEG` (a flip or glitch is no jitter, as in a
    cleaned clip's verdict), and how many such steps each joint makes."""
    squares, rows, _ = _per_joint(series["figures"], "accel_before")
    weights, weighting = _reach_weights(series.get("reaches"), squares, rows)
    known = float(rows.sum())
    return {
        "noise_before": math.sqrt(float(weights @ squares) / known) if known else None,
        "noise_weighting": weighting,
        "unrepaired_jumps": series.get("unrepaired_jumps", {}),
        "thrash": series.get("thrash", {}),
    }


def _reach_weights(
    reaches: np.ndarray | None, squares: np.ndarray, rows: np.ndarray
) -> tuple[np.ndarray, str]:
    """Per rotation joint, the weight of its squared angular acceleration in the verdict's
    noise and jitter removed, and which weighting it is (``"reach"`` or ``"equal"``): its
    reach squared (:func:`~motionclean.core.kinematics.reaches`, how far its jitter moves
    the body: a shoulder's an arm, a fingertip's a centimetre) over their mean over the
    joints' ``rows`` (acceleration rows measured), so the weighted RMS stays in deg/s^2
    and equals the plain one where every joint reaches as far; all ones (``"equal"``)
    where no joint with jitter (``squares`` > 0) has a reach (tracked bodies)."""
    if reaches is None or not np.any(reaches[squares > 0] > 0):
        return np.ones_like(squares), "equal"
    weights = np.square(reaches)
    return weights * (rows.sum() / max(float(weights @ rows), np.finfo(float).tiny)), "reach"


def _smoothing(series: dict, names: list[str]) -> dict[str, Any] | None:
    """The figures of smoothing alone (None for a single clip): the RMS angular acceleration
    before and after (deg/s^2, each joint's squared acceleration weighted by its reach,
    :func:`_reach_weights`) and the fraction of it removed, and the largest and RMS
    rotation change (degrees, and the joint of the largest) over every joint and frame,
    leaving out the rows that involve a frame a repairing step changed
    (:func:`build_series`' ``outside_repairs``)."""
    figures = series["figures"]
    if figures["accel_after"] is None or figures["deviation"] is None:
        return None
    before, rows, _ = _per_joint(figures, "accel_before")
    after, _, _ = _per_joint(figures, "accel_after")
    squares, counts, largest = _per_joint(figures, "deviation")
    away_squares, away_counts, _ = _per_joint(figures, "deviation", "deviation_away")
    weights, weighting = _reach_weights(series.get("reaches"), before, rows)
    total_before, total_after = float(weights @ before), float(weights @ after)
    removed = 1.0 - math.sqrt(total_after / total_before) if total_before > 0 else 0.0
    worst = int(np.argmax(largest)) if largest.size else 0
    known = float(rows.sum())  # (0: no three frames in a row known: no noise measured)
    return {
        "noise_before": math.sqrt(total_before / known) if known else None,
        "noise_after": math.sqrt(total_after / known) if known else None,
        "noise_removed": removed if known else None,
        "noise_weighting": weighting,
        "change_deg_max": float(largest[worst]) if largest.size else 0.0,
        "change_deg_rms": math.sqrt(float(squares.sum()) / max(float(counts.sum()), 1.0)),
        # (the same, away from the input's steps that nothing repaired)
        "change_deg_rms_away": math.sqrt(
            float(away_squares.sum()) / max(float(away_counts.sum()), 1.0)
        ),
        "change_joint": names[worst] if names else None,
        # each joint's largest change outside repairs (degrees): the verdict's own reading
        "joint_changes": dict(zip(names, largest.tolist(), strict=False)),
        "unrepaired_jumps": series.get("unrepaired_jumps", {}),
        "changed_near_jumps": series.get("changed_near_jumps", {}),
        "fast_steps": series.get("fast_steps", {}),
        "thrash": series.get("thrash", {}),
    } | _position_smoothing(figures.get("positions"))


def _position_smoothing(positions: dict | None) -> dict[str, Any]:
    """:func:`_smoothing`'s figures of the position channels: the RMS linear acceleration
    before and after (length units/s^2) and the fraction of it removed, the largest and RMS
    distance a joint moved (length units, and the joint of the largest), the joints that
    moved at all (``position_moved``: by more than nothing, largest first) and the
    ``travel`` of the positions (:func:`_position_series`); None each without position
    channels."""
    if positions is None:
        return dict.fromkeys(
            (
                "position_noise_before",
                "position_noise_after",
                "position_noise_removed",
                "change_length_max",
                "change_length_rms",
                "change_length_joint",
                "position_moved",
                "travel",
                "fast_positions",
                "fast_positions_per",
            )
        )
    names = positions["names"]

    def total(key: str) -> tuple[float, float]:
        found = positions[key]
        return sum(found[n][0] for n in found), sum(found[n][1] for n in found)

    before, rows = total("accel_before")
    after, _ = total("accel_after")
    squares, counts = total("deviation")
    peaks = [positions["deviation"][n][2] for n in range(len(names))]
    worst = int(np.argmax(peaks))
    moved = sorted((n for n, peak in enumerate(peaks) if peak > 0.0), key=lambda n: -peaks[n])
    removed = 1.0 - math.sqrt(after / before) if before > 0 else 0.0
    jumps, fastest, at = positions["fast"]
    scale = positions["scale"]
    return {
        "position_noise_before": math.sqrt(before / rows) if rows else None,
        "position_noise_after": math.sqrt(after / rows) if rows else None,
        "position_noise_removed": removed if rows else None,
        "change_length_max": float(peaks[worst]),
        "change_length_rms": math.sqrt(squares / max(counts, 1.0)),
        "change_length_joint": names[worst],
        "position_moved": [(names[n], peaks[n]) for n in moved],
        "travel": positions["travel"],
        # per joint stepping faster than FAST_BODY_HEIGHTS_PER_S: steps, fastest (in
        # body heights, or of the positions' travel, per second), the frame of the fastest
        "fast_positions": {
            names[n]: (int(jumps[n]), float(fastest[n] / scale), int(at[n]))
            for n in np.flatnonzero(jumps).tolist()
        },
        "fast_positions_per": positions["scale_of"],
    }


def _rotation_figures(series: dict, names: list[str], cleaned: bool) -> dict:
    """Per joint with rotation channels: angular acceleration RMS/max (deg/s^2) before and
    after, and the deviation from the input (degrees) when cleaned."""
    before, after, dev = (
        series["figures"][k] for k in ("accel_before", "accel_after", "deviation")
    )
    figures = {}
    for n, name in enumerate(names):
        entry = figures[name] = {
            "angular_accel_rms": pair(before.rms[n], after.rms[n] if cleaned else None),
            "angular_accel_max": pair(before.max[n], after.max[n] if cleaned else None),
        }
        if cleaned:
            entry["deviation_deg"] = {"rms": known(dev.rms[n]), "max": known(dev.max[n])}
    return figures


def _position_figures(
    before: Motion, after: Motion | None, joints: np.ndarray, starts: np.ndarray
) -> dict:
    """Per joint with position channels: linear acceleration RMS/max (length units/s^2)
    before and after, and the deviation from the input (length units) when cleaned; rows
    that involve a missing sample of either clip, or lie across a cut between takes
    (``starts``), are left out of both, as for rotations."""
    dt = before.frame_time
    missing = _missing(before, after, joints)
    lrms_b, lmax_b = rms_and_max(
        metrics.linear_acceleration(before.translations[:, joints], dt, missing, starts)
    )
    if after is not None:
        lrms_a, lmax_a = rms_and_max(
            metrics.linear_acceleration(after.translations[:, joints], dt, missing, starts)
        )
        moved = metrics.distance(
            before.translations[:, joints], after.translations[:, joints], missing
        )
        ldev_rms, ldev_max = rms_and_max(moved)
    figures = {}
    for n, j in enumerate(joints):
        a = after is not None
        entry = figures[before.names[j]] = {
            "linear_accel_rms": pair(lrms_b[n], lrms_a[n] if a else None),
            "linear_accel_max": pair(lmax_b[n], lmax_a[n] if a else None),
        }
        if a:
            entry["deviation_length"] = {"rms": known(ldev_rms[n]), "max": known(ldev_max[n])}
    return figures


def _summary(series: dict, cleaned: bool) -> dict[str, Any]:
    """Clip totals: RMS angular acceleration over all joints and frames, the fraction of it
    removed and the largest deviation (None for a single clip)."""
    figures = series["figures"]
    total_b = figures["accel_before"].total_rms
    summary: dict[str, Any] = {
        "angular_accel_rms": pair(total_b, None),
        "noise_reduction": None,
        "deviation_deg_max": None,
    }
    if cleaned:
        total_a = figures["accel_after"].total_rms
        summary["angular_accel_rms"]["after"] = known(total_a)
        if math.isnan(total_b):  # no row without a missing sample: nothing measured
            summary["noise_reduction"] = None
        else:
            summary["noise_reduction"] = 1.0 - total_a / total_b if total_b > 0 else 0.0
        summary["deviation_deg_max"] = known(figures["deviation"].total_max)
    return summary


def gap_notes(before: Motion, after: Motion | None = None) -> dict[str, dict]:
    """Per joint with samples missing in ``before``, the ``fill-gaps`` note a cleaning
    would have written, read from the two clips: its gaps, the runs missing in ``before``
    and known in ``after`` (``filled``) and those still missing in ``after`` (``missing``,
    with ``why``), ``[start, stop)`` frames. For two clips compared without the steps that
    made one, or ``before`` alone (no ``after``: nothing filled)."""
    after = before if after is None else after
    if before.missing is None:
        return {}
    joints = np.flatnonzero(before.missing.any(axis=0))
    was = before.missing[:, joints]
    still = np.zeros_like(was) if after.missing is None else after.missing[:, joints]
    runs = [found.contact_runs(mask) for mask in (was, was & ~still, still)]
    notes = {}
    for k, j in enumerate(joints):
        gaps, filled, left = ([list(run) for run in each[k]] for each in runs)
        note = {
            "gaps": len(gaps),
            "longest": max(b - a for a, b in gaps),
            "filled": filled,
            "missing": left,
            "donors": [],  # (not known from the two clips)
        }
        if left:
            note["why"] = "not filled"  # (no max_gap is known either)
        notes[before.names[j]] = {"fill-gaps": note}
    return notes


def build_report(
    before: Motion,
    after: Motion | None = None,
    pipeline: list[dict] | None = None,
    notes: dict[str, dict] | None = None,
    file: str | None = None,
    series: dict | None = None,
    wander: dict[str, float] | None = None,
) -> dict[str, Any]:
    """Figures for ``before`` alone, or before/after a cleaning when ``after`` is given.

    ``series`` is :func:`build_series` of the same clips when the caller already has it;
    ``wander`` (joint -> degrees) the markerless model's wander the capture source found in
    each joint, counted in the noise where no ``auto`` note gives one (two clips compared).
    """
    series = build_series(before, after) if series is None else series
    cleaned = after is not None
    frames = before.n_frames
    lead, trail = series["rest_frames"]
    core_before = trim(before, lead, trail)
    core_after = None if after is None else trim(after, lead, trail)
    joints = _rotation_figures(series, list(series["joints"]), cleaned)
    positions = _position_figures(
        core_before,
        core_after,
        np.flatnonzero(before.layout.has_position),
        take_starts(before) - lead,
    )
    for name, entry in positions.items():
        joints.setdefault(name, {}).update(entry)
    for name, note in (notes or {}).items():
        joints.setdefault(name, {}).update(note)
    report = {
        "file": file if file is not None else before.path,
        "frames": frames,
        "frame_time": before.frame_time,
        "pipeline": pipeline or [],
        "joints": joints,
        "summary": _summary(series, cleaned),
        "world": _world_section(series["world_figures"], core_before, pipeline or []),
        "contacts": series["contacts"],
        # per body with dropouts, its fill-gaps note (the same object as under joints)
        "gaps": {n: entry["fill-gaps"] for n, entry in joints.items() if "fill-gaps" in entry},
        "rest_frames": {"leading": lead, "trailing": trail},
        "take_starts": take_starts(before).tolist(),
    }
    unit = kinematics.length_unit(before)  # only where the format fixes it ("m")
    if unit:
        report["length_unit"] = unit
    said = [
        *kinematics.source_notes(before),
        *_step_notes(joints, pipeline or []),
    ]  # only when there is any
    if said:
        report["notes"] = said
    smoothing = _smoothing(series, list(series["joints"]))
    if smoothing is not None:  # (estimated only where the verdict may need it)
        changed = smoothing["change_deg_rms"] >= CLEAN_CHANGE_DEG
        smoothing["noise_level"] = (
            _noise_level(core_before, joints, wander or {}) if changed else None
        )
    alone = _input_noise(series) if smoothing is None else None  # (a clip reported alone)
    report["verdict"] = build_verdict(report, smoothing, alone)
    return report


def _noise_level(before: Motion, joints: dict[str, dict], wander: dict[str, float]) -> float | None:
    """RMS over the rotating joints of the input's per-sample rotation noise (degrees):
    the ``auto`` step's estimate where it noted one (the markerless model's wander
    included), else the optical model's on the input (:func:`estimate_noise`) with the
    ``wander`` (joint -> degrees) a markerless capture source finds added in quadrature;
    None without a rotating joint or a frame to tell it from."""
    rotating = np.flatnonzero(before.layout.has_rotation)
    if not rotating.size or before.n_frames == 0:
        return None
    notes = [joints.get(before.names[j], {}).get("auto", {}) for j in rotating.tolist()]
    levels = np.array(
        [
            n["noise"] if n.get("unit") == "deg" and n.get("noise") is not None else np.nan
            for n in notes
        ]
    )  # (NaN: no auto note, estimated below)
    guessed = np.isnan(levels)
    if guessed.any():  # (every joint: the clip's own array, no copy of it)
        cols = rotating[guessed]
        q = before.rotations if cols.size == before.n_joints else before.rotations[:, cols]
        extra = np.array([wander.get(before.names[j], 0.0) for j in cols])
        levels[guessed] = np.hypot(estimate_noise(q, before.frame_time), extra)
    return float(np.sqrt(np.mean(levels**2)))


def _world_section(figures: dict, before: Motion, pipeline: list[dict]) -> dict:
    """The ``world`` section: ``figures`` and, where steps were given an up axis of their
    own that the motion contradicts, ``steps_up_contradicted``
    (:func:`~motionclean.report.world.steps_up_contradicted`)."""
    steps = steps_up_contradicted(before, pipeline)
    return figures | {"steps_up_contradicted": steps} if steps else figures


def _step_notes(joints: dict[str, dict], pipeline: Sequence[dict]) -> list[str]:
    """What the steps' notes say a user should know: the joints ``fairing`` left before its
    first iteration (its first step would have moved a sample past ``epsilon_r``), those
    ``sse-fairing`` stopped at its iteration limit before converging."""
    said = []
    stopped = [n for n, entry in joints.items() if entry.get("fairing", {}).get("held_by_bound")]
    if stopped:
        left = (
            f"{plural(len(stopped), 'joint')} as {'it was' if len(stopped) == 1 else 'they were'}"
        )
        said.append(
            f"fairing left {left} ({listed(stopped, 3)}): its first step would move a sample "
            "beyond epsilon_r; a larger epsilon_r lets it smooth them"
        )
    return said + _unconverged(joints, pipeline)


def _unconverged(joints: dict[str, dict], pipeline: Sequence[dict]) -> list[str]:
    """``sse-fairing``'s joints (rotations) that ran to ``max_iterations`` with the
    objective's gradient norm still above ``epsilon``: how many, and how far off."""
    left = {
        n: entry["sse-fairing"]["gradient"]
        for n, entry in joints.items()
        if (entry.get("sse-fairing") or {}).get("at_limit")
    }
    if not left:
        return []
    step = next(s for s in pipeline if s.get("filter") == "sse-fairing")
    worst = sorted(left, key=left.__getitem__, reverse=True)
    return [
        f"sse-fairing stopped at its iteration limit ({step['max_iterations']}) before "
        f"converging on {plural(len(left), 'joint')} ({listed(worst, 3)}): gradient norm up "
        f"to {left[worst[0]]:.2g} where it stops at {step['epsilon']:g}; it smooths less than "
        "asked there: a larger max_iterations finishes it (about 80 per unit of beta)"
    ]


def json_safe(value: Any) -> Any:
    """``value`` with every non-finite number as None, JSON's null (strict JSON has none):
    an infinite step parameter, which a pipeline reads back as inf (``Param.coerce``)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    return value


def same_pipeline(stored: Any, tables: Sequence[dict]) -> bool:
    """Whether ``stored``, a pipeline read back from JSON (a baseline, a batch's page), is
    ``tables``; one written before infinite parameters were null holds them as "inf"."""
    if isinstance(stored, list):
        stored = [_inf_as_null(step) for step in stored]
    return stored == json_safe(list(tables))


def _inf_as_null(step: Any) -> Any:
    """A step table with its parameters written as "inf" as null."""
    if not isinstance(step, dict):
        return step
    return {key: None if value == "inf" else value for key, value in step.items()}


def to_json(report: dict) -> bytes:
    """UTF-8 JSON text, indented, strict (no ``Infinity`` / ``NaN`` tokens)."""
    return (json.dumps(json_safe(report), indent=2, allow_nan=False) + "\n").encode("utf-8")


def noisiest(report: dict) -> list[str]:
    """Joint names with angular figures, noisiest (largest RMS acceleration before) first,
    those with nothing measured (every sample missing) last."""
    rows = [
        (v["angular_accel_rms"]["before"], k)
        for k, v in report["joints"].items()
        if "angular_accel_rms" in v
    ]
    return [name for _, name in sorted(rows, key=lambda r: math.inf if r[0] is None else -r[0])]


def translations(report: dict) -> int:
    """How many entries have position channels alone (OpenSim's ``pelvis_tx`` ...): no
    joint row of the tables shows them."""
    return sum("angular_accel_rms" not in entry for entry in report["joints"].values())


def joint_count(report: dict) -> str:
    """ "31 joints", "34 joints and 3 translations": the joints with angular figures, and
    the :func:`translations`."""
    moving = translations(report)
    rotating = plural(len(report["joints"]) - moving, "joint")
    return rotating + (f" and {plural(moving, 'translation')}" if moving else "")


def was_cleaned(report: dict) -> bool:
    """Whether ``report`` compares a clip with its cleaned output (not one clip alone)."""
    return any("deviation_deg" in entry for entry in report["joints"].values()) or (
        report["summary"].get("noise_reduction") is not None
    )


def resampled_to(report: dict) -> str:
    """ ", written as N frames at R fps" for a resampled clip (figures compare on the
    input's frames), else ""."""
    output = report.get("output")
    if not output:
        return ""
    return (
        f", written as {output['frames']} frames at {fps_text(output['frame_time'])} fps "
        "(figures on the input's frames)"
    )


def repaired_joints(report: dict) -> dict[str, dict[str, int]]:
    """The verdict's repairs of the joints a step repaired frames of (none without step
    notes): where the table's and the page's totals include repairs."""
    repairs = (report.get("verdict") or {}).get("repairs") or {}
    return {name: counts for name, counts in repairs.items() if counts["frames"]}


def median_joint(values: list[float]) -> float:
    """The median joint's value (of an even count, the upper of the middle two)."""
    return sorted(values)[len(values) // 2]
