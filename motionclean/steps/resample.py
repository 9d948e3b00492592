"""The ``resample`` step: the clip at a new frame rate, any ratio up or down."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..core.errors import UsageError
from ..core.motion import MAX_FRAME_TIME, MIN_FRAME_TIME, Motion
from ..core.rates import same_rate
from ..filters.resample import ANTIALIAS_CUTOFF
from .base import Param, StepSpec, fps_text
from .resampling import new_length, resample_motion, resample_takes


def _resolve(params: dict, at: Callable[..., str]) -> None:
    if (params["fps"] is None) == (params["frame_time"] is None):
        raise UsageError(
            f"{at('frame_time', 'fps')}: give the new rate as either fps or frame_time, e.g. fps=60"
        )


def _frame_time(params: dict) -> float:
    return 1.0 / params["fps"] if params["fps"] is not None else params["frame_time"]


def _run(motion: Motion, params: dict) -> tuple[Motion, dict[str, dict]]:
    frame_time = _frame_time(params)
    if same_rate(motion.frame_time, frame_time):
        return motion, {}
    new_length(motion, frame_time)  # refuses too few or too many frames before any work
    return _noted(motion, resample_motion(motion, frame_time), frame_time)


def _run_takes(
    motion: Motion, params: dict, starts: np.ndarray
) -> tuple[Motion, dict[str, dict], np.ndarray]:
    """A clip of several takes at the new rate, the takes on the clip's one grid."""
    frame_time = _frame_time(params)
    if same_rate(motion.frame_time, frame_time):
        return motion, {}, starts
    resampled, new_starts = resample_takes(motion, frame_time, starts)
    return (*_noted(motion, resampled, frame_time), new_starts)


def _noted(motion: Motion, resampled: Motion, frame_time: float) -> tuple[Motion, dict[str, dict]]:
    """The resampled clip and its note (on the first joint)."""
    frames = motion.n_frames
    note = {
        "from_fps": motion.frame_rate,
        "to_fps": resampled.frame_rate,
        "frames": [frames, resampled.n_frames],
        "antialias_hz": None,
    }
    if frame_time > motion.frame_time:
        note["antialias_hz"] = ANTIALIAS_CUTOFF * 0.5 / frame_time
    return resampled, {name: {"resample": note} for name in motion.names[:1]}


def _format_note(note: dict, positions: bool) -> str:
    text = (
        f"{fps_text(1.0 / note['from_fps'])} -> {fps_text(1.0 / note['to_fps'])} fps, "
        f"{note['frames'][0]} -> {note['frames'][1]} frames"
    )
    if note["antialias_hz"] is not None:
        text += f", low-passed at {note['antialias_hz']:.3g} Hz first"
    return text


STEP = StepSpec(
    name="resample",
    smooths=False,
    summary="the clip at a new frame rate: C2 spline on the sphere through the samples, "
    "anti-aliased when the rate goes down",
    paper="cumulative B-spline of Kim, Kim and Shin 1995 solved to interpolate; "
    "low-pass 000 Eq. 19-20",
    params=(
        Param(
            "fps",
            "float",
            None,
            "new frame rate, frames per second (any ratio, up or down)",
            minimum=1.0 / MAX_FRAME_TIME,
            maximum=1.0 / MIN_FRAME_TIME,
        ),
        Param(
            "frame_time",
            "float",
            None,
            "or the new frame time, seconds",
            minimum=MIN_FRAME_TIME,
            maximum=MAX_FRAME_TIME,
        ),
    ),
    run_motion=_run,
    run_takes=_run_takes,
    keeps_rest=True,
    resolve=_resolve,
    format_note=_format_note,
    shift_note=lambda note, frames, _: note,
)
