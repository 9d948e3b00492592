"""The ``despike`` step: repair half-turn flips and spikes before smoothing."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..core import kinematics
from ..core.errors import UsageError
from ..core.holds import held_samples
from ..core.words import UNSAID_LENGTH, length_word, plural
from ..filters.despike import (
    FLIP_DEG,
    TREND_RATIO,
    despike_positions_with_report,
    despike_with_report,
)
from .base import (
    Param,
    StepData,
    StepSpec,
    brief_runs,
    crop_runs,
    page_runs,
    shift_runs,
)


def _resolve_despike(params: dict, at: Callable[..., str]) -> None:
    for unit in ("deg", "units"):
        low, high = f"min_{unit}_per_s", f"max_{unit}_per_s"
        if params[low] > params[high]:
            raise UsageError(f"{at(low, high)}: {low} must not exceed {high}")


#: Position steps slower than this many body heights per second are never jumps, whatever
#: the file's unit: rounding jitter of a clip in metres is not a spike.
POSITION_FLOOR_HEIGHTS_PER_S = 0.5


#: Position steps faster than this many body heights per second are always repaired on a
#: skeleton with a trunk and legs (garbage frames: a decoder wrote a root 820 body heights
#: away for five frames); nothing a body does, nor a golf club's head (about 30), comes near.
POSITION_CAP_HEIGHTS_PER_S = 100.0


def _position_cap(data: StepData, given: float, height: float) -> float:
    """The fastest position step left alone, in file units per second: ``given`` when set,
    else :data:`POSITION_CAP_HEIGHTS_PER_S` body heights (``height``) per second where the
    skeleton is a body (independent tracked bodies have no height to scale by: no cap)."""
    motion = data.motion
    if math.isfinite(given) or motion is None:
        return given
    if kinematics.world_note(motion) is not None:  # no joint positions: no height
        return given
    if kinematics.trunk_split(kinematics.point_parents(motion)) is None:
        return given
    return POSITION_CAP_HEIGHTS_PER_S * height if height > 0.0 else given


def _missing(data: StepData, joints) -> np.ndarray | None:
    """The dropouts of the given joints' columns, ``(F, len(joints))``, or None: missing
    samples and poses the capture held (no step in or out of one is a spike or a jump:
    ``fill-gaps`` bridges them)."""
    if data.motion is None:
        return None
    held = held_samples(data.motion)
    missing = held if data.motion.missing is None else data.motion.missing | held
    return missing[:, joints] if missing.any() else None


def _run_despike(data: StepData, params: dict) -> StepData:
    shared = {key: params[key] for key in ("threshold", "max_spike_s", "trend_ratio", "max_run")}
    data.rotations, report = despike_with_report(
        data.rotations,
        data.frame_time,
        method=params["method"],
        min_deg_per_s=params["min_deg_per_s"],
        max_deg_per_s=params["max_deg_per_s"],
        flip_deg=params["flip_deg"],
        unflip=params["unflip"],
        missing=_missing(data, data.rotation_joints),
        **shared,
    )
    for column in np.flatnonzero(report.counts()):
        data.rotation_notes[int(column)] = {"despike": report.summary(column) | {"unit": "deg"}}
    if data.translations is not None:
        height = 0.0 if data.motion is None else kinematics.body_height(data.motion)
        # the fastest position step left alone and the slowest that may be a jump: the
        # body's bounds where not given, a value given moving the other bound past it
        given_min = params["min_units_per_s"]
        top = max(_position_cap(data, params["max_units_per_s"], height), given_min)
        bottom = min(max(given_min, POSITION_FLOOR_HEIGHTS_PER_S * height), top)
        data.translations, report = despike_positions_with_report(
            data.translations,
            data.frame_time,
            method="linear" if params["method"] == "slerp" else "cubic",
            min_units_per_s=bottom,
            max_units_per_s=top,
            missing=_missing(data, data.translation_joints),
            **shared,
        )
        unit = kinematics.length_unit(data.motion) or UNSAID_LENGTH
        for column in np.flatnonzero(report.counts()):
            note = report.summary(column) | {"unit": unit}
            data.translation_notes[int(column)] = {"despike": note}
    return data


def spike_runs(note: dict) -> list[list[int]]:
    """The interpolated runs of a despike ``note`` that repaired a spike: those not only
    capping a step (``capped``, a subset; notes written before it have none)."""
    capped = note.get("capped") or []
    return [run for run in note["interpolated"] if run not in capped]


def _format_note(note: dict, positions: bool, ranges=page_runs) -> str:
    """What despike did to one joint: frames repaired, where (the page's first
    :data:`~.base.PAGE_RUNS` runs of a long list), and the largest step."""
    unit = length_word(note.get("unit")) if positions else "deg"
    parts = [f"{plural(note['frames_repaired'], 'frame')} repaired"]
    if note.get("unflipped"):
        parts.append(f"un-flipped {ranges(note['unflipped'])}")
    spikes = spike_runs(note)
    if spikes:
        parts.append(f"interpolated {ranges(spikes)}")
    if note.get("capped"):
        cap = "max_units_per_s" if positions else "max_deg_per_s"
        parts.append(f"capped {ranges(note['capped'])} (a step over {cap})")
    step = note.get("max_step")
    digits = ".1f" if not positions else ".3g"
    if step is not None:
        parts.append(f"largest step {step['before']:{digits}} -> {step['after']:{digits}} {unit}")
    return "; ".join(parts)


def _crop_note(note: dict, start: int, stop: int) -> dict | None:
    """The repairs within frames ``[start, stop)``; the whole-clip largest steps are left
    out (outside the range the clip keeps its input)."""
    unflipped = crop_runs(note["unflipped"], start, stop)
    interpolated = crop_runs(note["interpolated"], start, stop)
    if not unflipped and not interpolated:
        return None
    repaired = np.zeros(stop - start, dtype=bool)
    for a, b in unflipped + interpolated:
        repaired[a - start : b - start] = True
    kept = {key: value for key, value in note.items() if key != "max_step"}
    return kept | {
        "frames_repaired": int(repaired.sum()),
        "unflipped": unflipped,
        "interpolated": interpolated,
        "capped": crop_runs(note.get("capped") or [], start, stop),
    }


def _merge_note(parts: list[tuple[dict, int]]) -> dict:
    """What parts of the clip add up to (``(note, frames)``): frames repaired summed, the
    largest steps the largest of all."""
    merged = {"frames_repaired": sum(note["frames_repaired"] for note, _ in parts)}
    merged["unit"] = parts[0][0]["unit"]
    steps = [note["max_step"] for note, _ in parts if "max_step" in note]
    if steps:
        merged["max_step"] = {when: max(s[when] for s in steps) for when in ("before", "after")}
    return merged


def _format_brief(note: dict, positions: bool) -> str:
    """:func:`_format_note` with long frame lists summarised (the terminal form)."""
    return _format_note(note, positions, brief_runs)


STEP = StepSpec(
    name="despike",
    smooths=False,
    summary="repair half-turn flips (un-flip) and spikes (interpolate) before smoothing",
    paper="robust jump detection; interpolation by 003 Eq. 15-17",
    params=(
        Param(
            "threshold",
            "float",
            8.0,
            "a step is a jump above median + threshold * 1.4826 "
            "MAD of the joint's own steps (robust deviations)",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "min_deg_per_s",
            "float",
            600.0,
            "steps slower than this are never jumps, degrees of rotation per s",
            minimum=0.0,
        ),
        Param(
            "max_deg_per_s",
            "float",
            3600.0,
            "absolute cap: faster steps are always repaired, degrees of rotation per s",
            minimum=0.0,
            exclusive_minimum=True,
            infinite_ok=True,
        ),
        Param(
            "max_spike_s",
            "float",
            0.07,
            "longest spike, seconds (whole frames, at least "
            "one: 8 at 120 fps, 2 at 30 fps); also how far the cap may widen a gap",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=10.0,
        ),
        Param(
            "trend_ratio",
            "float",
            TREND_RATIO,
            "a spike must leave the cubic trend of its good "
            "neighbours by this many times that trend's own error there (0: no test)",
            minimum=0.0,
            maximum=1000.0,
        ),
        Param(
            "max_run",
            "int",
            None,
            "optional extra limit on spike length, frames",
            minimum=1,
            maximum=100000,
        ),
        Param(
            "flip_deg",
            "float",
            FLIP_DEG,
            "smallest one-frame step taken as a half-turn flip, degrees",
            minimum=90.0,
            exclusive_minimum=True,
            maximum=180.0,
        ),
        Param(
            "unflip",
            "bool",
            True,
            "undo half-turn flips; false interpolates short flips like spikes",
        ),
        Param("method", "str", "cubic", "interpolant for spikes", choices=("cubic", "slerp")),
        Param(
            "min_units_per_s",
            "float",
            0.0,
            "positions: steps slower than this are never jumps, length units per s (at "
            "least half the body height per s)",
            minimum=0.0,
        ),
        Param(
            "max_units_per_s",
            "float",
            math.inf,
            "positions: absolute cap, length units per s (default: 100 body heights per "
            "s on a skeleton with a trunk and legs, else none)",
            minimum=0.0,
            exclusive_minimum=True,
            infinite_ok=True,
        ),
    ),
    run=_run_despike,
    sees_missing=True,
    resolve=_resolve_despike,
    format_note=_format_note,
    format_brief=_format_brief,
    lists_repairs=True,
    crop_note=_crop_note,
    merge_note=_merge_note,
    shift_note=lambda note, frames, _: {
        **note,
        "unflipped": shift_runs(note["unflipped"], frames),
        "interpolated": shift_runs(note["interpolated"], frames),
        "capped": shift_runs(note.get("capped") or [], frames),
    },
)
