"""Rest-pose frames at the ends of a clip: a T-pose or bind pose before (or after) the motion.

Many exports start with such a frame (CMU conversions for MotionBuilder, Mixamo), or with a
run of identical frames. Every step would take the jump into the motion for a spike; the
pipeline leaves these frames and the transition out of every step, and the report leaves them
out of its figures.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import quat
from .motion import Motion, sparse_concatenate
from .threads import in_parts

#: A transition is a jump on a joint when its rotation step exceeds this many times the
#: joint's typical step ...
JUMP_TIMES_MEDIAN = 8.0
#: ... and a rest frame when that happens on at least this share of the rotating joints, one
#: of them by more than this many degrees (no noise, however small its typical steps, turns a
#: joint that far between two frames while most others jump with it).
MOST_JOINTS = 0.5
JUMP_DEG = 15.0
#: A frame whose every rotation is within this of the skeleton's rest (zero channels,
#: degrees) is a reference pose when the step out of it is a jump on most of the joints it
#: leaves, whatever their size once one is over :data:`JUMP_DEG` (Second Life's frame 0
#: before a hand-keyed clip, whose joints hold still between keys: their median step is 0).
ZERO_POSE_DEG = 2.0
#: A run of at least this many identical frames is a held pose whether or not a jump follows
#: (no capture repeats every channel exactly; padding does).
HELD_FRAMES = 3
#: Different rest poses at most at either end (a T-pose, then a reference frame: each one
#: steps into the next as a rest frame steps into the motion).
REST_POSES = 4
#: Noise raises every joint's typical step past the jump rules above (3 degrees of it on a
#: 30 fps walk: a median step of 7 degrees), but it never makes a whole-body step (RMS
#: over the moving joints) this many times the clip's 99th percentile of them, as the
#: step out of a rest frame into the motion is (25 degrees against 9.6 there) ...
BODY_JUMP = 1.5
#: ... from a frame near the skeleton's rest: its moving joints within this many times
#: the joints' median step of it (or :data:`ZERO_POSE_DEG`), as noise leaves it ...
NOISY_ZERO_STEPS = 1.5
#: ... this share of them at least: a T-pose with its arms lowered (an A-pose) or a
#: reference pose setting a few joints (CMU's, at 30 or 24 fps, where the joints' typical
#: steps have grown past the jump rule: 74 % of its moving joints at the rest) is the
#: skeleton's rest but for those joints.
MOSTLY_AT_REST = 2.0 / 3.0


#: Steps sampled per joint for its typical (median) step on long clips (evenly spaced), so
#: the cost does not grow with the clip.
TYPICAL_SAMPLES = 4096
#: Steps measured at a time.
STEP_BLOCK = 1024


def _identical_run(rotations: np.ndarray, translations: np.ndarray) -> int:
    """How many frames from the first one are exactly equal to it (at least 1); looks at
    growing chunks, so a short run costs little on a long clip."""
    n_frames, at, size = rotations.shape[0], 1, 64
    while at < n_frames:
        stop = min(at + size, n_frames)
        same = np.all(rotations[at:stop] == rotations[:1], axis=(1, 2)) & np.all(
            translations[at:stop] == translations[:1], axis=(1, 2)
        )
        if not same.all():
            return at + int(np.argmin(same))
        at, size = stop, size * 2
    return n_frames


class Typical(NamedTuple):
    """A clip's typical rotation steps (degrees): each joint's median step, its median
    step while it moves (of its steps between rotations that differ: a hand-keyed joint
    holds still between keys; 0 for a joint that never moves), and the 99th percentile of
    the whole-body step (RMS over the moving joints)."""

    median: np.ndarray
    while_moving: np.ndarray
    body: float


def _typical_steps(q: np.ndarray, moving: np.ndarray) -> Typical:
    """:class:`Typical` of rotations ``q`` ``(F, J, 4)`` whose joints ``moving`` ``(J,)``
    ever change, over the clip or :data:`TYPICAL_SAMPLES` evenly spaced steps of a longer
    clip."""
    n_steps = q.shape[0] - 1
    at = np.arange(n_steps)
    if n_steps > TYPICAL_SAMPLES:
        at = np.unique(np.linspace(0, n_steps - 1, TYPICAL_SAMPLES).round().astype(np.intp))
    steps = np.empty((at.size, *q.shape[1:-1]))
    held = np.empty(steps.shape, dtype=bool)
    for part in in_parts(at.size, STEP_BLOCK):  # small temporaries
        rows = at[part]
        steps[part] = np.degrees(quat.angle_between(q[rows], q[rows + 1]))
        held[part] = np.all(q[rows] == q[rows + 1], axis=-1)
    median = np.median(steps, axis=0)
    # the whole-body step: RMS over the moving joints (none: 0)
    body = np.sqrt(np.mean(np.square(steps[:, moving]), axis=1)) if moving.any() else [0.0]
    steps[held] = np.nan
    moves = ~np.isnan(steps).all(axis=0)
    while_moving = np.zeros(steps.shape[1:])
    while_moving[moves] = np.nanmedian(steps[:, moves], axis=0)
    return Typical(median, while_moving, float(np.percentile(body, 99.0)))


def _moving_joints(q: np.ndarray) -> np.ndarray:
    """``(J,)``: the joints of rotations ``q`` ``(F, J, 4)`` whose rotation ever changes
    (read in blocks of frames, each joint until it is found to move)."""
    moving = np.zeros(q.shape[1], dtype=bool)
    for at in range(0, q.shape[0], 4096):
        still = np.flatnonzero(~moving)  # (the others are known to: not read again)
        if not still.size:
            break
        moving[still] = np.any(q[at : at + 4096, still] != q[:1, still], axis=(0, 2))
    return moving


def _jumps(steps: np.ndarray, typical: np.ndarray) -> np.ndarray:
    """Which ``steps`` (degrees) are jumps: over :data:`JUMP_TIMES_MEDIAN` times the
    joint's ``typical`` step."""
    return steps > JUMP_TIMES_MEDIAN * typical


def _rest_run(
    q: np.ndarray,
    translations: np.ndarray,
    typical: Typical,
    moving: np.ndarray,
    held: bool,
) -> int:
    """The run of frames equal to the first, when it is a rest pose: a held pose (when
    ``held``), or the step out of it a jump on most joints at once, or out of the
    skeleton's rest pose, or (noise raising every joint's typical step) a whole-body jump
    out of a pose near it; else 0. ``typical``: :func:`_typical_steps`."""
    run = _identical_run(q, translations)
    if run >= len(q) - 2:
        return 0
    if held and run >= HELD_FRAMES:
        return run
    if not moving.any():
        return 0
    out = np.degrees(quat.angle_between(q[run - 1], q[run]))[moving]
    median, while_moving = typical.median[moving], typical.while_moving[moving]
    jump = _jumps(out, while_moving)
    if jump.mean() >= MOST_JOINTS and out[jump].max() > JUMP_DEG:
        return run
    if out.max() <= JUMP_DEG:
        return 0
    # a zero pose (the skeleton's rest) before a pose: the joints that leave it jump
    if _zero_pose(q[run - 1], moving):
        posed = np.degrees(quat.angle(q[run, moving])) > ZERO_POSE_DEG
        leaves = _jumps(out[posed], median[posed])
        if posed.any() and leaves.mean() >= MOST_JOINTS:
            return run
    # ... or a pose mostly at it (an A-pose; noise or a low rate raising the joints'
    # typical steps) out of which the whole body jumps
    near = max(ZERO_POSE_DEG, NOISY_ZERO_STEPS * float(np.median(median)))
    at_rest = np.degrees(quat.angle(q[run - 1, moving])) <= near
    body_out = float(np.sqrt(np.mean(np.square(out))))
    if at_rest.mean() >= MOSTLY_AT_REST and body_out > BODY_JUMP * typical.body:
        return run
    return 0


def _zero_pose(frame: np.ndarray, moving: np.ndarray, within: float = ZERO_POSE_DEG) -> bool:
    """Whether every moving joint of ``frame`` ``(J, 4)`` is within ``within`` degrees of
    the skeleton's rest (the identity rotation)."""
    return bool(np.degrees(quat.angle(frame[moving])).max(initial=0.0) <= within)


def _leading(
    q: np.ndarray,
    translations: np.ndarray,
    typical: Typical,
    moving: np.ndarray,
) -> int:
    """Leading rest frames: up to :data:`REST_POSES` runs of identical frames from the
    first frame inward while each is a rest pose (:func:`_rest_run`; a held pose only at
    the first frame: after a rest frame, a run of identical frames is the motion's own, as
    a hand-keyed clip's first key). A run in the zero pose counts too when a rest pose
    follows it (a T-pose before a reference frame steps only on the joints that pose
    sets)."""
    lead = zero = 0  # rest frames found, and zero-pose frames after them awaiting a rest pose
    for _ in range(REST_POSES):
        at = lead + zero
        run = _rest_run(q[at:], translations[at:], typical, moving, held=at == 0)
        if run:
            lead, zero = at + run, 0
        elif zero or not _zero_pose(q[at], moving):
            break
        else:
            zero = _identical_run(q[at:], translations[at:])
    return lead


def rest_frames(motion: Motion) -> tuple[int, int]:
    """Numbers of leading and trailing rest-pose frames of ``motion`` (0 when none).

    A rest frame (or a run of identical frames) at either end counts when the step from it
    into the motion is a jump on at least half of the joints that move at all (a joint whose
    rotation never changes says nothing) at once: larger than 8 times the joint's median
    step while it moves (over the frames within the ends' rest poses, :func:`_inner_span`:
    a joint that moves only out of the rest pose has none), one of them by more than 15
    degrees. No noise makes most joints jump
    on the same frame; a pose held before the capture does, however small its turn on some
    joints (the reference frame of CMU conversions turns many by less than 15 degrees). A
    frame in the skeleton's rest pose (every rotation within :data:`ZERO_POSE_DEG` of zero)
    counts when the joints that leave it jump (more than 8 times their median step) and one
    by more than 15 degrees: a reference frame before a hand-keyed clip. In a noisy capture,
    whose noise raises every joint's median step past those rules (so does a low frame
    rate), a frame with two thirds of its moving joints (:data:`MOSTLY_AT_REST`: an A-pose
    lowers only the arms) within :data:`NOISY_ZERO_STEPS` times the joints' median step of
    the rest counts when the whole body's step out of it (RMS over the moving joints) is
    over :data:`BODY_JUMP` times the clip's 99th percentile of such steps (which holds that
    step too: a clip of under about 100 frames needs a larger one). A run of at least 3
    identical frames (every channel, positions too) counts in any case: a held pose. Up to
    :data:`REST_POSES` such frames or runs of different poses count from either end inward,
    each stepping into the next as a rest frame steps into the motion (a T-pose, then CMU's
    reference frame), or a zero pose before a rest frame; a held pose only at the clip's
    very end. A clip with missing samples (tracker dropouts, held placeholders) has none:
    trackers do not record a rest pose.
    """
    return motion.derived("rest_frames", _rest_frames)  # (asked a dozen times a clean)


def _rest_frames(motion: Motion) -> tuple[int, int]:
    rotating = motion.layout.has_rotation
    if motion.n_frames < 8 or not rotating.any() or motion.has_gaps:
        return 0, 0
    q = motion.rotations if rotating.all() else motion.rotations[:, rotating]
    p = motion.translations
    moving = _moving_joints(q)
    first, stop = _inner_span(q, p)
    typical = _typical_steps(q[first:stop], moving)
    lead = _leading(q, p, typical, moving)
    trail = _leading(q[::-1], p[::-1], typical, moving)
    if lead + trail >= motion.n_frames - 4:
        return 0, 0
    return lead, trail


def _inner_span(q: np.ndarray, translations: np.ndarray) -> tuple[int, int]:
    """``(first, stop)``: the frames of rotations ``q`` ``(F, J, 4)`` within the first and
    last :data:`REST_POSES` runs of identical frames (the most rest poses either end may
    hold), over which the joints' typical steps are measured: the steps out of rest poses
    are the ones judged, and a joint that moves only there (a T-pose's fingers, held for
    the rest of a Rokoko clip) had made its typical step that jump itself. The whole clip
    where too little lies between."""
    first = stop = 0
    for _ in range(REST_POSES):
        if first < len(q):
            first += _identical_run(q[first:], translations[first:])
        if stop < len(q):
            stop += _identical_run(q[::-1][stop:], translations[::-1][stop:])
    stop = len(q) - stop
    return (first, stop) if stop - first >= 2 else (0, len(q))


def trim(motion: Motion, lead: int, trail: int) -> Motion:
    """``motion`` without its first ``lead`` and last ``trail`` frames."""
    if lead == 0 and trail == 0:
        return motion
    rows = slice(lead, motion.n_frames - trail)
    source = {}
    if motion.has_source_frames():
        assert motion.source_values is not None
        read = motion.source_rotations
        source = {
            "source_values": motion.source_values[rows],
            "source_rotations": None if read is None else read[rows],
        }
    return motion.replace(
        rotations=motion.rotations[rows],
        translations=motion.translations[rows],
        missing=None if motion.missing is None else motion.missing[rows],
        **source,
    )


#: A held pose at the end follows its motion's last frame where a step turned that frame by
#: more than this many degrees: a flipped run un-flipped (despike's flip step, 150 degrees:
#: the half-turn, then smoothed); a spike's repair or a cap turns it less (a MediaPipe
#: estimate's forearm capped by 121 degrees at its last frame keeps its held pose).
HALF_TURN_DEG = 150.0


def held_end_follows(original: Motion, cleaned: Motion, trail: int) -> Motion:
    """``cleaned`` (``original`` cleaned, its ``trail`` trailing rest frames kept) with a held
    pose at the end turned, joint by joint, as its motion's last frame was turned by more
    than :data:`HALF_TURN_DEG` (a half-turn run repaired up to the padding), where kept as
    it was the held pose would be further from that frame than the input stepped into it:
    the padding repeats a pose of the motion (a tracker that lost the person, a video
    estimator), and kept as it was it had made a new half-turn step into itself (a
    MediaPipe estimate's forearm: 6 -> 179.5 degrees; another's arm, which stepped 49
    degrees into the held pose, 49 -> 157). Only a pose the body steps into as it moves
    (the step into it a jump, as :func:`rest_frames` judges one, on fewer than half of the
    moving joints) is held motion: a T-pose or reference frames, entered by a jump of the
    whole body, come back bit for bit, as does a held pose whose joints were not so
    turned."""
    end = original.n_frames - trail
    if not trail or end < 1 or cleaned.n_frames != original.n_frames:
        return cleaned
    held = original.rotations[end:]
    if not np.array_equal(held, np.broadcast_to(held[:1], held.shape)):
        return cleaned  # (a T-pose or reference frames: kept whatever happens before them)
    last_in, last_out = original.rotations[end - 1], cleaned.rotations[end - 1]
    into = quat.angle_between(last_in, held[0])
    turned = quat.angle_between(last_in, last_out)
    follow = (turned > np.radians(HALF_TURN_DEG)) & (quat.angle_between(last_out, held[0]) > into)
    if not follow.any() or _entered_by_a_jump(original.rotations[:end], np.degrees(into)):
        return cleaned
    turn = quat.multiply(quat.conjugate(last_in[follow]), last_out[follow])  # (local)
    rotations = cleaned.rotations.copy()
    rotations[end:, follow] = quat.multiply(held[:, follow], turn)
    return cleaned.replace(rotations=rotations)


def _entered_by_a_jump(motion: np.ndarray, into: np.ndarray) -> bool:
    """Whether the steps ``into`` ``(J,)`` (degrees) from the last frame of ``motion``
    ``(F, J, 4)`` into a pose are a jump, as :func:`_rest_run` judges the step out of a
    rest pose: over :data:`JUMP_TIMES_MEDIAN` times the joint's median step while it moves
    on at least :data:`MOST_JOINTS` of the joints that move."""
    moving = _moving_joints(motion)
    if not moving.any():
        return True  # (no motion to tell a held pose of it from a reference)
    typical = _typical_steps(motion, moving)
    return bool(_jumps(into[moving], typical.while_moving[moving]).mean() >= MOST_JOINTS)


def splice(original: Motion, middle: Motion, lead: int, trail: int) -> Motion:
    """``original`` with its frames between the rest frames replaced by ``middle``'s, which
    may have another frame count and frame time (a resampled clip: the rest frames are
    kept one for one)."""
    if lead == 0 and trail == 0:
        return middle
    end = original.n_frames - trail
    ends = (slice(0, lead), slice(end, original.n_frames))

    def joined(field: str) -> np.ndarray:
        first, last = (getattr(original, field)[rows] for rows in ends)
        return np.concatenate([first, getattr(middle, field), last])

    missing = None
    if original.missing is not None or middle.missing is not None:
        missing = np.concatenate(
            [
                original.missing_mask()[ends[0]],
                middle.missing_mask(),
                original.missing_mask()[ends[1]],
            ]
        )
    resized = {}
    if middle.n_frames != end - lead:
        resized = {"source_values": None, "source_rotations": None}
    return original.replace(
        rotations=joined("rotations"),
        translations=sparse_concatenate(  # zeros of joints without positions: no memory
            [original.translations[ends[0]], middle.translations, original.translations[ends[1]]]
        ),
        frame_time=middle.frame_time,
        missing=missing,
        **resized,
    )
