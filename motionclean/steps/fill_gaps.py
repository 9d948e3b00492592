"""The ``fill-gaps`` step: tracker dropouts bridged by a smooth coordinate-invariant fill.

Dropouts are the clip's missing samples (blank cells) and the poses a recorder held
(:mod:`~motionclean.core.holds`: the last sample repeated until the data returned)."""

from __future__ import annotations

import numpy as np

from ..core.holds import held_samples
from ..core.motion import Motion, run_labels
from ..core.rates import frames_floor
from ..filters.gaps import Gaps, fill_gaps
from .base import Param, StepSpec, brief_runs, page_runs, shift_runs

#: Default longest gap filled, seconds: about what an occluded marker set is lost for when
#: an arm passes in front of the body; longer gaps are left to the user.
MAX_GAP_SECONDS = 0.5


def _runs(first: np.ndarray, stop: np.ndarray) -> list[list[int]]:
    return [[int(a), int(b)] for a, b in zip(first, stop, strict=True)]


def _held_runs(motion: Motion, max_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """The samples of ``motion``'s held poses that are bridged (runs of at most
    ``max_frames``) and those left as held (longer runs), each ``(F, J)`` bool."""
    held = held_samples(motion)
    labels = run_labels(held)
    long = np.bincount(labels.ravel())[labels] > max_frames
    return held & ~long, held & long


def _run(motion: Motion, params: dict) -> tuple[Motion, dict[str, dict]]:
    longest = params["max_gap"] / motion.frame_time  # (inf: every gap)
    max_frames = motion.n_frames if longest >= motion.n_frames else frames_floor(longest)
    held, held_left = _held_runs(motion, max_frames)
    missing = held if motion.missing is None else motion.missing | held
    if not missing.any() and not held_left.any():
        return motion, {}
    result = fill_gaps(
        motion.rotations,
        motion.translations,
        missing,
        max_frames,
        motion.layout.has_position,
        donors=params["donors"],
    )
    gaps = result.gaps
    from_held = held[gaps.first, gaps.joint]
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
        held_here = mine & from_held & result.filled
        if held_here.any():
            notes[motion.names[joint]]["fill-gaps"]["held"] = _runs(
                gaps.first[held_here], gaps.stop[held_here]
            )
    as_captured = Gaps.of(held_left)
    for joint in np.unique(as_captured.joint):
        note = notes.setdefault(motion.names[joint], {}).setdefault(
            "fill-gaps", {"gaps": 0, "longest": 0, "filled": [], "missing": [], "donors": []}
        )
        mine = as_captured.joint == joint
        note["held_left"] = _runs(as_captured.first[mine], as_captured.stop[mine])
    # a held pose's samples are data: what the fill left of them stays as captured
    still_missing = result.missing & ~held
    if motion.missing is None and not still_missing.any():
        still_missing = None
    return motion.replace(
        rotations=result.rotations, translations=result.translations, missing=still_missing
    ), notes


def _format_note(note: dict, positions: bool, runs=page_runs) -> str:
    """Gaps found, filled (where, from which donors) and left missing (the page's first
    :data:`~.base.PAGE_RUNS` runs of a long list)."""
    filled, missing = note["filled"], note["missing"]
    count = note["gaps"]
    longest = note["longest"]
    held = len(note.get("held", []))
    parts = []
    if count:
        parts.append(
            f"{count} gap{'' if count == 1 else 's'}, longest {longest} frame"
            + ("" if longest == 1 else "s")
            + _held_words(held, count)
        )
    if note.get("held_left"):
        parts.append(
            f"a pose the capture held left as captured {runs(note['held_left'])} (longer "
            "than max_gap)"
        )
    if filled:
        parts.append(f"filled {runs(filled)}")
    if note["donors"]:
        parts.append("following " + ", ".join(note["donors"]))
    if missing:
        parts.append(f"left missing {runs(missing)} ({note.get('why', 'longer than max_gap')})")
    return "; ".join(parts)


def _held_words(held: int, count: int) -> str:
    """ " (a pose the capture held)", " (2 of them poses the capture held)" or ""."""
    if not held:
        return ""
    if held == count:
        return " (a pose the capture held)" if held == 1 else " (poses the capture held)"
    return f" ({held} of them {'a pose' if held == 1 else 'poses'} the capture held)"


def _shift(note: dict, frames: int, _: float) -> dict:
    return {
        **note,
        "filled": shift_runs(note["filled"], frames),
        "missing": shift_runs(note["missing"], frames),
    } | {key: shift_runs(note[key], frames) for key in ("held", "held_left") if key in note}


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
