"""Takes joined end to end in one clip: the frames where a new take starts.

Game engines' FBX files often hold several clips one after the other in one take (Unity's
``HumanoidRun``: a run, then the run turned round, with held frames between), and so do
their conversions. Where one take ends and the next begins most joints jump at once, the
root often by half a turn: no flip, spike or noise does that. The pipeline runs its steps
on each take (nothing smooths, un-flips or interpolates across a cut) and the report leaves
the rows across a cut out of its figures.

A step is a cut where at least :data:`CUT_SHARE` of the joints that move at all (and at least
:data:`CUT_MIN_COLUMNS`) step beyond their jump threshold at once (the ``despike``
default's: the median step plus 8 robust deviations, within 600-3600 degrees per second),
with takes longer than the longest spike (0.07 s) on both sides: a whole-body glitch comes
back within a spike's length, and a pose at a clip's end is a rest pose
(:mod:`.restpose`).
"""

from __future__ import annotations

import warnings

import numpy as np

from . import quat
from .holds import held_samples
from .motion import Motion
from .rates import frames_floor
from .restpose import rest_frames
from .threads import in_parts

__all__ = [
    "cut_steps",
    "jump_thresholds",
    "median_rows",
    "robust_thresholds",
    "take_spans",
    "take_starts",
]

#: Consistency constant turning a median absolute deviation into a standard deviation.
MAD_TO_SIGMA = 1.4826
#: The jump threshold: a step beyond the median by this many robust deviations, ...
JUMP_THRESHOLD = 8.0
#: ... within these bounds (degrees per second), ...
MIN_DEG_PER_S = 600.0
MAX_DEG_PER_S = 3600.0
#: ... and the longest spike (seconds), as ``despike``'s defaults.
LONGEST_SPIKE_S = 0.07
#: Share of the moving columns, and fewest of them, that jump at once at a cut (Unity's
#: HumanoidRun: 24 and 34 of its 51 joints, 0.47 and 0.67, at its two cuts; real captures
#: at 24-120 fps, the corpus, eight exporters' files, 19 Bandai Namco clips: at most 0.26;
#: a markerless estimate's glitch moves 4-5 of its 9 coordinates at once: too few to be a
#: skeleton's cut).
CUT_SHARE = 0.4
CUT_MIN_COLUMNS = 8
#: Columns compared with their thresholds at a time, and frames whose steps are taken.
CUT_BLOCK = 64
STEP_BLOCK = 4096


def median_rows(a: np.ndarray) -> np.ndarray:
    """``np.median(a, axis=1)`` of ``a`` (C, n), ``n >= 1``, by one partial selection that
    reorders ``a`` in place (NaN where a row holds one, as numpy's)."""
    n = a.shape[1]
    half = n // 2
    a.partition((half, n - 1) if n % 2 else (half - 1, half, n - 1), axis=1)
    med = a[:, half].copy() if n % 2 else (a[:, half - 1] + a[:, half]) / 2.0
    med[np.isnan(a[:, -1])] = np.nan
    return med


def robust_thresholds(steps: np.ndarray, threshold: float, low: float, high: float):
    """``clip(median + threshold * 1.4826 MAD, low, high)`` per row of ``steps`` (C, F-1),
    which is overwritten."""
    med = median_rows(steps)
    deviation = np.subtract(steps, med[:, None], out=steps)
    mad = median_rows(np.abs(deviation, out=deviation))
    return np.clip(med + threshold * MAD_TO_SIGMA * mad, low, high)


def jump_thresholds(
    seen: np.ndarray, threshold: float, low: float, high: float, known: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Each column's jump threshold over its steps ``seen`` (F-1, C) (:func:`robust_thresholds`
    of the columns with a step above ``low``, ``low`` for the others; of the ``known``
    (F-1, C) steps only where given) and its largest step (C,)."""
    largest = seen.max(axis=0)
    jump = np.full(seen.shape[1], low)  # the floor: no jump where no step exceeds it
    fast = np.flatnonzero(largest > low)
    if known is None:
        jump[fast] = robust_thresholds(seen.T[fast], threshold, low, high)
    else:
        jump[fast] = _robust_thresholds_known(seen.T[fast], known.T[fast], threshold, low, high)
    return jump, largest


def _robust_thresholds_known(steps, known, threshold: float, low: float, high: float):
    """:func:`robust_thresholds` of the ``known`` steps of each row only (C, F-1)."""
    values = np.where(known, steps, np.nan)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a row without known steps
        med = np.nanmedian(values, axis=1)
        mad = np.nanmedian(np.abs(values - med[:, None]), axis=1)
    return np.nan_to_num(np.clip(med + threshold * MAD_TO_SIGMA * mad, low, high), nan=high)


def cut_steps(seen: np.ndarray, jump: np.ndarray, moving: np.ndarray, max_len: int) -> np.ndarray:
    """``(F-1,)`` steps of ``seen`` (F-1, C) that are cuts (see the module): at least
    :data:`CUT_SHARE` of the ``moving`` columns (indices), and :data:`CUT_MIN_COLUMNS`,
    beyond their ``jump`` (C,) at once, with more than ``max_len`` frames to the next cut
    or the clip's end on both sides."""
    cuts = np.zeros(seen.shape[0], dtype=bool)
    if moving.size < CUT_MIN_COLUMNS:
        return cuts
    jumping = np.zeros(seen.shape[0], dtype=np.intp)
    for part in in_parts(moving.size, CUT_BLOCK):  # (F-1, block) temporaries
        cols = moving[part]
        jumping += np.count_nonzero(seen[:, cols] > jump[cols], axis=1)
    found = np.flatnonzero(jumping >= max(CUT_MIN_COLUMNS, CUT_SHARE * moving.size))
    if found.size:
        takes = np.diff(np.concatenate([[-1], found, [seen.shape[0]]]))  # frames between
        cuts[found[(takes[:-1] > max_len) & (takes[1:] > max_len)]] = True
    return cuts


def take_spans(starts: np.ndarray, n_frames: int) -> list[slice]:
    """The frames of each take of a clip of ``n_frames`` whose takes after the first start
    at ``starts``."""
    bounds = [0, *np.asarray(starts).tolist(), n_frames]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def take_starts(motion: Motion) -> np.ndarray:
    """The frames of ``motion`` where a new take starts (see the module; ascending), looked
    for between its rest-pose frames (:func:`~.restpose.rest_frames`). A clip with missing
    samples (tracker dropouts) has none: trackers record one take; nor is the step out of a
    pose the capture held (:func:`~.holds.held_samples`) a cut: a dropout's."""
    return motion.derived("take_starts", _take_starts)


def _take_starts(motion: Motion) -> np.ndarray:
    none = np.zeros(0, dtype=np.intp)
    rotating = motion.layout.has_rotation
    lead, trail = rest_frames(motion)
    if motion.n_frames - lead - trail < 8 or not rotating.any() or motion.has_gaps:
        return none
    inner = slice(lead, motion.n_frames - trail)
    q = motion.rotations[inner] if rotating.all() else motion.rotations[inner][:, rotating]
    steps = np.empty((q.shape[0] - 1, q.shape[1]))
    for part in in_parts(steps.shape[0], STEP_BLOCK):  # small temporaries
        steps[part] = quat.angle_between(q[part], q[part.start + 1 : part.stop + 1])
    dt = motion.frame_time
    low, high = np.radians(MIN_DEG_PER_S) * dt, np.radians(MAX_DEG_PER_S) * dt
    jump, largest = jump_thresholds(steps, JUMP_THRESHOLD, low, high)
    moving = np.flatnonzero(largest > 0.0)  # every joint that moves has a say
    longest = max(1, min(frames_floor(LONGEST_SPIKE_S / dt), q.shape[0] - 2))
    starts = np.flatnonzero(cut_steps(steps, jump, moving, longest)) + 1 + lead
    # the step out of a pose the capture held is a dropout's (fill-gaps bridges it)
    return starts[~held_samples(motion)[starts - 1].any(axis=1)]
