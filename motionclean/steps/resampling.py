"""A clip at a new frame rate (:func:`resample_motion`), and a resampled clip brought back onto
its input's frames for comparison (:func:`on_input_frames`).

Rotations and positions are resampled by :mod:`motionclean.filters.resample` (C1 cubic in
angular displacements, anti-aliasing low-pass when the rate goes down). A sample is missing
after resampling when an input sample it is interpolated from was missing. The pipeline
leaves rest-pose frames (a T-pose before the motion) out of every step, so a resample step
keeps them one for one and does not blend them into the motion.
"""

from __future__ import annotations

import os

import numpy as np

from ..core.errors import MotionError
from ..core.motion import Motion, joint_major_zeros
from ..core.restpose import rest_frames, splice, trim
from ..filters.resample import (
    resample_continuous,
    resample_positions,
    resampled_length,
    sample_positions,
)

#: Rates within this relative difference are the same rate (a Frame Time of 0.008333 s is
#: 120 fps): the clip is left as it is.
SAME_RATE = 1e-3
#: Bytes the resampled arrays and their text take per new frame and channel value, about.
BYTES_PER_VALUE = 96
#: Most new frames made per frame read (120 -> 120,000 fps): more interpolates nothing a
#: capture holds, and costs time and disk by the option, not the data (1e6 fps of a
#: 240-frame tracker CSV wrote a gigabyte in over a minute).
MAX_UPSAMPLING = 1000


def same_rate(frame_time: float, new_frame_time: float) -> bool:
    """True when two frame times (seconds) are within :data:`SAME_RATE` of each other."""
    return abs(new_frame_time - frame_time) <= SAME_RATE * frame_time


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
    fps = f"{1.0 / frame_time:.6g} fps"
    if motion.n_frames < 2:
        raise MotionError(
            f"a clip of {motion.n_frames} frame cannot be resampled; at least two are needed",
            motion.path,
        )
    n_new = resampled_length(motion.n_frames, frame_time / motion.frame_time)
    if n_new < 2:
        raise MotionError(
            f"resampling {motion.n_frames} frames of {motion.duration:.6g} s to {fps} leaves "
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


def _resampled_missing(missing: np.ndarray, ratio: float, n_new: int) -> np.ndarray:
    """New frames interpolated from a missing input sample are missing."""
    index, u = sample_positions(n_new, ratio)
    padded = np.concatenate([missing, missing[-1:]])
    return padded[index] | (padded[index + 1] & (u > 0.0)[:, None])


def _resampled(motion: Motion, ratio: float, n_new: int, antialias: bool) -> tuple:
    layout = motion.layout
    rot, pos = np.flatnonzero(layout.has_rotation), np.flatnonzero(layout.has_position)
    if rot.size == motion.n_joints:
        rotations = resample_continuous(motion.rotations, ratio, n_new, antialias)
    else:
        rotations = np.empty((n_new, motion.n_joints, 4))
        rotations[:] = motion.rotations[0]
        rotations[:, rot] = resample_continuous(motion.rotations[:, rot], ratio, n_new, antialias)
    translations = joint_major_zeros(n_new, motion.n_joints)
    if pos.size:
        translations[:, pos] = resample_positions(
            motion.translations[:, pos], ratio, n_new, antialias
        )
    return rotations, translations


def resample_motion(motion: Motion, frame_time: float) -> Motion:
    """``motion`` at ``frame_time`` seconds per frame (any ratio, up or down).

    The same rate (:func:`same_rate`) gives ``motion`` itself. Otherwise every rotation and
    position is resampled (module docstring) and the first frame keeps its time; the
    skeleton and channels stay, the writer keeps the hierarchy text and writes the frames
    anew. :func:`new_length` says how many frames and refuses too few or too many.
    """
    if same_rate(motion.frame_time, frame_time):
        return motion
    n_new = new_length(motion, frame_time)
    ratio = frame_time / motion.frame_time
    rotations, translations = _resampled(motion, ratio, n_new, antialias=True)
    missing = None
    if motion.missing is not None:
        missing = _resampled_missing(motion.missing, ratio, n_new)
    return motion.replace(
        rotations=rotations,
        translations=translations,
        frame_time=float(frame_time),
        source_values=None,
        source_rotations=None,
        missing=missing,
    )


def on_input_frames(before: Motion, after: Motion) -> Motion:
    """``after`` (``before`` resampled, possibly cleaned too) brought back onto ``before``'s
    frames with the same interpolant and no low-pass, so the two compare frame by frame;
    ``after`` itself when it already has ``before``'s frames. Rest-pose frames of
    ``before`` (kept one for one by the pipeline) are matched one for one."""
    if after.n_frames == before.n_frames and after.frame_time == before.frame_time:
        return after
    lead, trail = rest_frames(before)
    core = trim(after, lead, trail)
    n_core = before.n_frames - lead - trail
    rotations, translations = _resampled(core, before.frame_time / after.frame_time, n_core, False)
    middle = before.replace(
        rotations=rotations,
        translations=translations,
        source_values=None,
        source_rotations=None,
        missing=None,
    )
    return splice(before.replace(missing=None), middle, lead, trail)
