"""The ``fill-gaps`` step: tracker dropouts bridged by a smooth coordinate-invariant fill."""

from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from ..core.rates import frames_floor
from ..filters.gaps import fill_gaps
from .base import Param, StepSpec, brief_runs, page_runs, shift_runs

#: Default longest gap filled, seconds: about what an occluded marker set is lost for when
#: an arm passes in front of the body; longer gaps are left to the user.
MAX_GAP_SECONDS = 0.5


def _runs(first: np.ndarray, stop: np.ndarray) -> list[list[int]]:
    return [[int(a), int(b)] for a, b in zip(first, stop, strict=True)]


def _run(motion: Motion, params: dict) -> tuple[Motion, dict[str, dict]]:
    if motion.missing is None:
        return motion, {}
    longest = params["max_gap"] / motion.frame_time  # (inf: every gap)
    max_frames = motion.n_frames if longest >= motion.n_frames else frames_floor(longest)
    result = fill_gaps(
        motion.rotations,
        motion.translations,
        motion.missing,
        max_frames,
        motion.layout.has_position,
        donors=params["donors"],
    )
    gaps = result.gaps
    notes: dict[str, dict] = {}
    for joint in np.unique(gaps.joint):
        mine = gaps.joint == joint
        filled, left = mine & result.filled, mine & ~result.filled
        helpers = sorted({motion.names[d] for d in result.donor[:, filled].ravel() if d >= 0})
        notes[motion.names[joint]] = {
            "fill-gaps": {
                "gaps": int(mine.sum()),
                "longest": int(gaps.lengths[mine].max()),
                "filled": _runs(gaps.first[filled], gaps.stop[filled]),
                "missing": _runs(gaps.first[left], gaps.stop[left]),
                "donors": helpers,
            }
        }
    return motion.replace(
        rotations=result.rotations, translations=result.translations, missing=result.missing
    ), notes


def _format_note(note: dict, positions: bool, runs=page_runs) -> str:
    """Gaps found, filled (where, from which donors) and left missing (the page's first
    :data:`~.base.PAGE_RUNS` runs of a long list)."""
    filled, missing = note["filled"], note["missing"]
    count = note["gaps"]
    longest = note["longest"]
    parts = [
        f"{count} gap{'' if count == 1 else 's'}, longest {longest} frame"
        + ("" if longest == 1 else "s")
    ]
    if filled:
        parts.append(f"filled {runs(filled)}")
    if note["donors"]:
        parts.append("following " + ", ".join(note["donors"]))
    if missing:
        parts.append(f"left missing {runs(missing)} ({note.get('why', 'longer than max_gap')})")
    return "; ".join(parts)


def _shift(note: dict, frames: int, _: float) -> dict:
    return {
        **note,
        "filled": shift_runs(note["filled"], frames),
        "missing": shift_runs(note["missing"], frames),
    }


STEP = StepSpec(
    name="fill-gaps",
    smooths=False,
    summary="tracker dropouts bridged by a C1 cubic in displacements, following the "
    "smoothest other body (pattern fill), each bridge checked on gaps planted beside it "
    "(the straight line, smoothed edges or a smoothing spline where they do better)",
    paper="cubic of 003 Eq. 17 made C1; displacements 000 Eq. 19; Whittaker smoothing "
    "spline under noise",
    params=(
        Param(
            "max_gap",
            "float",
            MAX_GAP_SECONDS,
            "longest gap filled, seconds; longer ones stay missing (blank in CSV) and are reported",
            minimum=0.0,
            infinite_ok=True,
        ),
        Param(
            "donors",
            "bool",
            True,
            "follow another body tracked through the gap where its relative pose is "
            "smoother (false: bridge each body on its own)",
        ),
    ),
    run_motion=_run,
    format_note=_format_note,
    format_brief=lambda note, positions: _format_note(note, positions, brief_runs),
    lists_repairs=True,
    shift_note=_shift,
)
