"""A clip at a new frame rate (:func:`resample_motion`), and a resampled clip brought back onto
its input's frames for comparison (:func:`on_input_frames`).

Rotations and positions are resampled by :mod:`motionclean.filters.resample` (C2 spline on
the sphere, anti-aliasing low-pass when the rate goes down). A sample is missing after
resampling when an input sample it is interpolated from was missing. Rest-pose frames (a
T-pose before or after the motion, :mod:`motionclean.core.restpose`) are never blended into
the motion and keep their time: the new frames that fall within them (at least one) repeat
the rest pose, and every other new frame samples the motion at its own time in the file.
"""

from __future__ import annotations

import os

import numpy as np

from ..core import checks, quat
from ..core.errors import MotionError
from ..core.motion import Motion, as_motion, hold_missing, joint_major_zeros
from ..core.rates import same_rate
from ..core.restpose import rest_frames, splice, trim
from ..core.takes import take_spans, take_starts
from ..core.words import plural
from ..filters.gaps import fill_gaps
from ..filters.resample import (
    resample_continuous,
    resample_positions,
    resampled_length,
    sample_positions,
)
from .base import fps_text

#: Bytes a resampled clip's arrays and their text are bounded by per new frame and value
#: (7 per joint, one per channel): twice the most measured, the resampling's own peak
#: (tracemalloc) growing 12.7 bytes per value over new frames of a BVH clip, 12.8 of an
#: SMPL one, 14.7 of an OpenSim .mot (the command's peak RSS grows 9.3, 9.6 and 11.7:
#: 2.85 KiB per frame of a 31-joint BVH written as BVH, CSV or glb alike). It had been 96,
#: which refused 425,000 frames a 24 GB machine resamples at 1.3 GB.
BYTES_PER_VALUE = 32
#: Most new frames made per frame read (120 -> 120,000 fps): more interpolates nothing a
#: capture holds, and costs time and disk by the option, not the data (1e6 fps of a
#: 240-frame tracker CSV wrote a gigabyte in over a minute).
MAX_UPSAMPLING = 1000


def _memory_bytes() -> int:
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # no sysconf: assume 8 GB
        return 8 << 30


def new_length(motion: Motion, frame_time: float) -> int:
    """Frames ``motion`` has at ``frame_time`` seconds per frame: the same duration to
    within half a new frame. Raises :class:`MotionError` when that leaves fewer than two
    frames, would not fit in half of this machine's memory, or makes more than
    :data:`MAX_UPSAMPLING` frames per frame read (the message says how many frames), for
    every format alike."""
    fps = f"{fps_text(frame_time)} fps"
    if motion.n_frames < 2:
        raise MotionError(
            f"a clip of {plural(motion.n_frames, 'frame')} cannot be resampled; at least two "
            "are needed",
            motion.path,
        )
    n_new = resampled_length(motion.n_frames, frame_time / motion.frame_time)
    if n_new < 2:
        raise MotionError(
            f"resampling {motion.n_frames} frames ({motion.duration:.6g} s) to {fps} leaves "
            "1 frame; at least two are needed",
            motion.path,
        )
    values = motion.n_joints * 7 + motion.layout.n_channels
    fits = _memory_bytes() // 2 // (values * BYTES_PER_VALUE)
    if n_new > fits:
        raise MotionError(
            f"resampling to {fps} makes {n_new:,} frames; at most {fits:,} fit in memory",
            motion.path,
        )
    if n_new > MAX_UPSAMPLING * motion.n_frames:
        raise MotionError(
            f"resampling {motion.n_frames:,} frames to {fps} makes {n_new:,} frames; at most "
            f"{MAX_UPSAMPLING:,} per frame read ({MAX_UPSAMPLING * motion.n_frames:,}) are "
            f"made, a rate of up to {MAX_UPSAMPLING * motion.frame_rate:.6g} fps",
            motion.path,
        )
    return n_new


def _resampled_missing(
    missing: np.ndarray, ratio: float, n_new: int, first: int = 0, shift: int = 0
) -> np.ndarray:
    """New frames interpolated from a missing input sample are missing."""
    index, u = sample_positions(n_new, ratio, first, shift)
    index = np.clip(index, 0, missing.shape[0] - 1)
    padded = np.concatenate([missing, missing[-1:]])
    return padded[index] | (padded[index + 1] & (u > 0.0)[:, None])


def _resampled(
    motion: Motion, ratio: float, n_new: int, antialias: bool, first: int = 0, shift: int = 0
) -> tuple:
    layout = motion.layout
    rot, pos = np.flatnonzero(layout.has_rotation), np.flatnonzero(layout.has_position)
    where = (first, shift)
    if rot.size == motion.n_joints:
        rotations = resample_continuous(motion.rotations, ratio, n_new, antialias, *where)
    else:
        rotations = np.empty((n_new, motion.n_joints, 4))
        rotations[:] = motion.rotations[0]
        rotations[:, rot] = resample_continuous(
            motion.rotations[:, rot], ratio, n_new, antialias, *where
        )
    translations = joint_major_zeros(n_new, motion.n_joints)
    if pos.size:
        translations[:, pos] = resample_positions(
            motion.translations[:, pos], ratio, n_new, antialias, *where
        )
    return rotations, translations


def rest_rows(n_frames: int, lead: int, trail: int, ratio: float, n_new: int) -> tuple[int, int]:
    """How many of ``n_new`` new frames (``ratio`` old frames apart) fall within a clip's
    ``lead`` leading and ``trail`` trailing rest frames of its ``n_frames``: those at an old
    time before ``lead`` and from ``n_frames - trail`` on, at least one each where there are
    rest frames, and at least two left for the motion."""
    index, u = sample_positions(n_new, ratio)
    times = index + u
    new_lead = max(int(np.count_nonzero(times < lead)), 1) if lead else 0
    new_trail = max(int(np.count_nonzero(times >= n_frames - trail)), 1) if trail else 0
    if n_new - new_lead - new_trail < 2:
        new_lead, new_trail = min(lead, 1), min(trail, 1)
    return new_lead, new_trail


def _with_rest(motion: Motion, frame_time: float, n_new: int, lead: int, trail: int) -> Motion:
    """``motion`` resampled around its rest frames (module docstring)."""
    ratio = frame_time / motion.frame_time
    new_lead, new_trail = rest_rows(motion.n_frames, lead, trail, ratio, n_new)
    core = trim(motion, lead, trail)
    n_core = n_new - new_lead - new_trail
    rotations, translations = _resampled(core, ratio, n_core, True, new_lead, lead)
    first = np.zeros(new_lead, dtype=np.intp)
    last = np.full(new_trail, motion.n_frames - 1, dtype=np.intp)

    def around(rest: np.ndarray, middle: np.ndarray) -> np.ndarray:
        return np.concatenate([rest[first], middle, rest[last]])

    missing = None
    if motion.missing is not None:
        gaps = _resampled_missing(core.missing_mask(), ratio, n_core, new_lead, lead)
        missing = around(motion.missing, gaps)
    return motion.replace(
        rotations=around(motion.rotations, rotations),
        translations=around(motion.translations, translations),
        frame_time=float(frame_time),
        source_values=None,
        source_rotations=None,
        missing=missing,
    )


def resample_motion(motion: Motion, frame_time: float) -> Motion:
    """``motion`` at ``frame_time`` seconds per frame (any ratio, up or down).

    The same rate (:func:`~motionclean.core.rates.same_rate`) gives ``motion`` itself.
    Otherwise every rotation and position is resampled (module docstring) and the first
    frame keeps its time; rest-pose frames at either end keep theirs (:func:`rest_rows`);
    the skeleton and channels stay, the writer keeps the hierarchy text and writes the
    frames anew. :func:`new_length` says
    how many frames and refuses too few or too many. TypeError for a ``motion`` that is no
    :class:`Motion` or a ``frame_time`` that is no number, ValueError for one outside
    :data:`~motionclean.core.checks.FRAME_TIME_RANGE` (zero, negative, NaN).
    """
    motion = as_motion(motion)
    frame_time = checks.frame_time(frame_time)
    if same_rate(motion.frame_time, frame_time):
        return motion
    n_new = new_length(motion, frame_time)
    ratio = frame_time / motion.frame_time
    lead, trail = rest_frames(motion)
    bridged = _bridged(motion)
    out = (
        _with_rest(bridged, frame_time, n_new, lead, trail)
        if lead or trail
        else _plain(bridged, frame_time, n_new, ratio)
    )
    return _placeholders(out)


def _placeholders(out: Motion) -> Motion:
    """``out`` with its missing samples given placeholders again, as every clip holds them
    (the nearest known sample)."""
    if out.missing is None:
        return out
    return out.replace(
        rotations=quat.make_continuous(hold_missing(out.rotations, out.missing), axis=0),
        translations=hold_missing(out.translations, out.missing),
    )


def _bridged(motion: Motion) -> Motion:
    """``motion`` with its dropouts bridged as ``fill-gaps`` bridges them, on each joint's
    own and whatever their length (still marked missing): the spline and the anti-alias
    low-pass run across a smooth bridge, not across the held placeholder and the step at
    its end, which they had spread into the known frames beside a gap (8 degrees)."""
    if motion.missing is None:
        return motion
    filled = fill_gaps(
        motion.rotations,
        motion.translations,
        motion.missing,
        motion.n_frames,
        motion.layout.has_position,
        donors=False,
    )
    return motion.replace(rotations=filled.rotations, translations=filled.translations)


def _plain(
    motion: Motion, frame_time: float, n_new: int, ratio: float, first: int = 0, shift: int = 0
) -> Motion:
    """``motion`` (no rest frames) resampled to ``n_new`` frames ``frame_time`` apart: the
    new frames ``first ..`` of a clip it starts ``shift`` old frames into
    (:func:`~motionclean.filters.resample.sample_positions`)."""
    rotations, translations = _resampled(motion, ratio, n_new, True, first, shift)
    missing = None
    if motion.missing is not None:
        missing = _resampled_missing(motion.missing, ratio, n_new, first, shift)
    return motion.replace(
        rotations=rotations,
        translations=translations,
        frame_time=float(frame_time),
        source_values=None,
        source_rotations=None,
        missing=missing,
    )


def resample_takes(
    motion: Motion, frame_time: float, starts: np.ndarray
) -> tuple[Motion, np.ndarray]:
    """``motion`` (no rest frames) of several takes joined end to end (``starts``: where
    each after the first begins) at ``frame_time`` seconds per frame, each take on its
    own, all on the clip's one grid: new frame ``j`` at old time ``j x ratio`` belongs to
    the take it falls in, so the clip keeps its duration to within half a new frame and no
    take drifts (each rounded on its own, 802 takes of 1,247 frames to 60 fps had made 40
    frames too many). Also where each take after the first now begins."""
    n_new = new_length(motion, frame_time)
    ratio = frame_time / motion.frame_time
    index, u = sample_positions(n_new, ratio)
    firsts = np.searchsorted(index + u, starts, side="left")  # first new frame in each take
    bounds = np.concatenate([[0], firsts, [n_new]]).astype(np.intp)
    parts = []
    for take, first, stop in zip(
        take_spans(starts, motion.n_frames), bounds[:-1], bounds[1:], strict=True
    ):
        if stop <= first:
            continue  # a take shorter than a new frame: no new frame falls in it
        part = _bridged(motion.at_frames(take))
        parts.append(
            _placeholders(
                _plain(part, frame_time, int(stop - first), ratio, int(first), take.start)
            )
        )
    new_starts = np.unique(bounds[1:-1])
    return Motion.joined_frames(parts), new_starts[(new_starts > 0) & (new_starts < n_new)]


def on_input_frames(before: Motion, after: Motion) -> Motion:
    """``after`` (``before`` resampled, possibly cleaned too) brought back onto ``before``'s
    frames with the same interpolant and no low-pass, so the two compare frame by frame;
    ``after`` itself when it already has ``before``'s frames. Rest-pose frames of
    ``before`` are matched with the rest frames of ``after`` (:func:`rest_rows`), the
    motion at its own times; a clip of several takes, take by take
    (:func:`~motionclean.core.takes.take_starts` of both: the pipeline's output knows
    where it put them)."""
    if after.n_frames == before.n_frames and after.frame_time == before.frame_time:
        return after
    starts, remade = take_starts(before), take_starts(after)
    if starts.size and remade.size == starts.size:  # take by take, as they were made
        return Motion.joined_frames(
            [
                _on_input_frames(before.at_frames(old), after.at_frames(new))
                for old, new in zip(
                    take_spans(starts, before.n_frames),
                    take_spans(remade, after.n_frames),
                    strict=True,
                )
            ]
        )
    return _on_input_frames(before, after)


def _on_input_frames(before: Motion, after: Motion) -> Motion:
    """:func:`on_input_frames` of one take."""
    lead, trail = rest_frames(before)
    ratio = after.frame_time / before.frame_time
    new_lead, new_trail = rest_rows(before.n_frames, lead, trail, ratio, after.n_frames)
    core = trim(after, new_lead, new_trail)
    n_core = before.n_frames - lead - trail
    rotations, translations = _resampled(core, 1.0 / ratio, n_core, False, lead, new_lead)
    middle = before.replace(
        rotations=rotations,
        translations=translations,
        source_values=None,
        source_rotations=None,
        missing=None,
    )
    return splice(before.replace(missing=None), middle, lead, trail)
