"""The ``auto`` step: per-joint noise estimate and the Lee-Shin mask chosen for it."""

from __future__ import annotations

import math

import numpy as np

from ..core import kinematics, quat
from ..core.motion import Motion, hold_missing
from ..core.words import length_word, plural
from ..filters.auto import FAMILIES, SOURCES, SourceFound, auto, auto_positions, found_source
from ..filters.gaps import fill_gaps
from ..filters.outliers import chord_deviations, chord_noise, lone_outliers, replaced
from .base import (
    Param,
    StepData,
    StepSpec,
    brief_runs,
    crop_runs,
    format_params,
    held_at_mean,
    page_runs,
    shift_runs,
)

#: What a note says of a column whose every sample is missing.
UNMEASURED = "nothing to measure: no three frames in a row known"
#: Lone outliers of a joint that ``auto``, run again without them, leaves unfiltered are
#: put back when they leave their chord by less than this (degrees): a clean capture's own
#: zigzags (a 30 fps hip's 3.2 degrees, MocapBank's wrist 0.7-0.9) stay as captured, while
#: 15-20 degree spikes on a clean clip at 24-30 fps, which had made it read as markerless
#: and noisy in the first pass, stay repaired (87 of them had been put back).
KEPT_BELOW_DEG = 5.0


#: A moving joint's noise under this (degrees, or length units) reads as none measurable
#: beside its motion: the motion fills the band the noise is read in (exactly 0 there).
UNMEASURABLE_NOISE = 1e-9


def still_columns(values: np.ndarray) -> np.ndarray:
    """``(C,)``: the columns of ``values`` ``(F, C, d)`` that hold one value throughout."""
    if values.shape[0] == 0:
        return np.ones(values.shape[1], dtype=bool)
    return np.all(values == values[:1], axis=(0, 2))


def _auto_note(
    result, column: int, unit: str, unmeasured: bool = False, still: bool = False
) -> dict:
    """The report note of ``column``: the noise found and the filter chosen for it; with
    ``unmeasured`` (:func:`_unmeasured`) no figures (None), no filter and why; ``still``:
    the column holds one value throughout (said so, not as a noise of 0)."""
    choice = result.choices[column]
    note = {
        "noise": float(result.noise.reshape(-1)[column]),
        "unit": unit,
        "rho": choice.rho,
        "loud": [list(stretch) for stretch in choice.loud],
        "filter": choice.params(),
        "share": choice.share,
        "expected_error": choice.expected_error,
    }
    if choice.band_hz is not None:  # noise low-passed at this edge (Hz), counted in "noise"
        note["band_hz"] = choice.band_hz
    if unit == "deg":  # the capture system assumed, asked for, and the clip's evidence
        note["model"] = choice.model
        note["source"] = choice.source
        slope = choice.motion_slope
        note["motion_slope"] = None if slope is None or not math.isfinite(slope) else slope
        note["source_measured"] = slope is not None
    if choice.model == "markerless":  # noise reaching into the motion's band, in "noise"
        note["wander"] = choice.wander
        note["wander_edge_hz"] = choice.wander_edge_hz
    if still:
        note["still"] = True
    if unmeasured:
        note.pop("band_hz", None)
        unknown = ("noise", "rho", "share", "expected_error", "wander", "wander_edge_hz")
        note.update({key: None for key in unknown if key in note}, loud=[], why=UNMEASURED)
        note["filter"] = {"mask": "none"}
    return note


def _bridged(values, motion: Motion | None, joints, rotations: bool):
    """``values`` with the clip's dropouts in ``joints`` bridged as ``fill-gaps`` would
    bridge them, whatever their length and on each joint's own (checked against a straight
    line on gaps planted beside them), so the filter runs across them; and their mask (None
    without dropouts). The bridges are a neutral support, not a fill: the samples are
    missing again afterwards."""
    if values is None or motion is None or motion.missing is None:
        return values, None
    missing = motion.missing[:, joints]
    if not missing.any():
        return values, None
    n_frames = values.shape[0]
    if rotations:
        other = np.zeros(values.shape[:-1] + (3,))
        return fill_gaps(values, other, missing, n_frames, donors=False).rotations, missing
    other = np.broadcast_to(quat.identity(values.shape[1:-1]), values.shape[:-1] + (4,))
    return fill_gaps(other, values, missing, n_frames, donors=False).translations, missing


def seen_rotations(motion: Motion) -> np.ndarray:
    """The rotations of every joint with rotation channels of ``motion`` as this step sees
    them: ``(F, Jr, 4)``, dropouts bridged."""
    joints = np.flatnonzero(motion.layout.has_rotation)
    return _bridged(motion.rotations[:, joints], motion, joints, True)[0]


def measured_source(motion: Motion, source: str) -> SourceFound:
    """:func:`~motionclean.filters.auto.found_source` of :func:`seen_rotations`: the noise
    model this step would use for ``source``, the motion slope it would measure and the
    wander it would find in each joint with rotation channels."""
    return found_source(seen_rotations(motion), motion.frame_time, source)


def _unmeasured(shape: tuple[int, ...], missing: np.ndarray | None) -> np.ndarray:
    """``(C,)``: the columns of ``(F, C, ...)`` values (``missing`` ``(F, C)`` or None)
    without three frames in a row known, where no noise can be measured."""
    if missing is None:
        return np.full(shape[1], shape[0] < 3)
    known = ~missing
    return ~np.any(known[:-2] & known[1:-1] & known[2:], axis=0)


def _run_auto(data: StepData, params: dict) -> StepData:
    families = FAMILIES if params["mask"] == "any" else (params["mask"],)
    shared = {
        "strength": params["strength"],
        "max_seconds": params["max_seconds"],
        "families": families,
    }
    rotations, missing_r = _bridged(data.rotations, data.motion, data.rotation_joints, True)
    rotations = quat.continuous(rotations)  # (once: the outliers' judgement reads it too)
    translations, missing_p = _bridged(
        data.translations, data.motion, data.translation_joints, False
    )
    result = auto(
        rotations,
        data.frame_time,
        noise=params["noise_deg"],
        source=params["source"],
        **(shared | {"overwrite": False}),  # (the input is judged for lone outliers below)
    )
    lone = _lone(rotations, result, missing_r, data.frame_time)
    if lone.any():  # taken out, and the clip cleaned again without them
        result = auto(
            replaced(rotations, lone),
            data.frame_time,
            noise=params["noise_deg"],
            source=params["source"],
            **(shared | {"overwrite": True}),
        )
        lone &= ~_put_back(rotations, result, lone)
    data.rotations = result.values
    if missing_r is not None:  # the bridges go: placeholders held again
        data.rotations = quat.make_continuous(hold_missing(result.values, missing_r), axis=0)
    unseen = _unmeasured(data.rotations.shape, missing_r)
    still = still_columns(rotations)
    for column in range(data.rotations.shape[1]):
        note = _auto_note(result, column, "deg", unseen[column], still[column])
        if lone[:, column].any():
            note["outliers"] = [[int(f), int(f) + 1] for f in np.flatnonzero(lone[:, column])]
        data.rotation_notes[column] = {"auto": note}
    if translations is not None:
        shared["overwrite"] = data.owned or missing_p is not None
        still = still_columns(translations)  # (before auto_positions may write into them)
        result = auto_positions(
            translations, data.frame_time, noise=params["position_noise"], **shared
        )
        data.translations = result.values
        if missing_p is not None:
            data.translations = hold_missing(result.values, missing_p)
        unseen = _unmeasured(translations.shape, missing_p)
        unit = kinematics.length_unit(data.motion) or "length"  # ("m" where the format says)
        for column in range(data.translations.shape[1]):
            note = _auto_note(result, column, unit, unseen[column], still[column])
            data.translation_notes[column] = {"auto": note}
    return data


def _unfiltered(result) -> np.ndarray:
    """``(C,)``: the columns an ``auto`` ``result`` leaves as they are on every frame."""
    return np.array([c.mask == "none" and c.share >= 1.0 for c in result.choices], dtype=bool)


def _lone(
    rotations: np.ndarray, first, missing: np.ndarray | None, frame_time: float
) -> np.ndarray:
    """``(F, C)``: the lone outliers (:func:`~motionclean.filters.outliers.lone_outliers`)
    of sign-continuous ``rotations`` in the columns ``auto`` filtered somewhere in its
    ``first`` pass, judged against the noise it found or was given there, or the one their
    chords show where that is less (the outliers themselves raise the first); none where it
    left a joint as it was (a clean capture's own single-frame glitches stay as captured)."""
    out = np.zeros(rotations.shape[:2], dtype=bool)
    filtered = np.flatnonzero(~_unfiltered(first))
    if filtered.size == 0:
        return out
    q = rotations[:, filtered]
    noise = np.minimum(first.noise.reshape(-1)[filtered], chord_noise(q, frame_time))
    known = None if missing is None else ~missing[:, filtered]
    out[:, filtered] = lone_outliers(q, noise, known)
    return out


def _put_back(rotations: np.ndarray, result, lone: np.ndarray) -> np.ndarray:
    """``(F, C)``: the ``lone`` outliers put back into ``result``'s values (in place) from
    ``rotations``: those under :data:`KEPT_BELOW_DEG` from their chord in the joints the
    pass without them leaves unfiltered."""
    back = lone & _unfiltered(result)[None, :]
    frames, columns = np.nonzero(back)
    small = chord_deviations(rotations, frames, columns) < KEPT_BELOW_DEG
    back[frames[~small], columns[~small]] = False
    if back.any():
        was, now = rotations[back], result.values[back]
        result.values[back] = quat.same_sign(was, now)
    return back


def _how(note: dict) -> str:
    """How auto came by the capture system of a rotation ``note``: found or given."""
    if note.get("source", "auto") != "auto":
        return f"as given: source={note['source']}"
    return "found from the clip" if note.get("source_measured") else "the noise level given"


def _format_note(note: dict, positions: bool, ranges=page_runs) -> str:
    """What auto found for one joint: the noise (level, correlation, loud stretches), the
    choice and its expected error; the lone outliers it took out first."""
    if note["noise"] is None:
        return UNMEASURED
    found = note.get("outliers") or []
    lone = (
        f"; took out {plural(len(found), 'lone outlier')} first ({ranges(found)})" if found else ""
    )
    return _found_and_chosen(note) + lone


def _format_brief(note: dict, positions: bool) -> str:
    """:func:`_format_note` with long frame lists summarised (the terminal form)."""
    return _format_note(note, positions, brief_runs)


def _crop_note(note: dict, start: int, stop: int) -> dict:
    """The note of a ranged auto: its lone outliers within frames ``[start, stop)``."""
    if "outliers" not in note:
        return note
    kept = crop_runs(note["outliers"], start, stop)
    return {k: v for k, v in note.items() if k != "outliers"} | ({"outliers": kept} if kept else {})


def _merge_note(parts: list[tuple[dict, int]]) -> dict:
    """The lone outliers of every part of the clip (takes, known stretches), in order."""
    runs = [run for note, _ in parts for run in note.get("outliers", [])]
    return {"outliers": runs} if runs else {}


def _shift_note(note: dict, frames: int, frame_time: float) -> dict:
    """The note with its lone outliers' frames moved by ``frames``, and its loud stretches
    (seconds) by as many frames of ``frame_time`` (a second take's had been given in its
    own seconds, the first take's repeated)."""
    seconds = frames * frame_time
    loud = [[round(a + seconds, 2), round(b + seconds, 2)] for a, b in note.get("loud") or []]
    moved = note | ({"loud": loud} if "loud" in note else {})
    if "outliers" not in note:
        return moved
    return moved | {"outliers": shift_runs(note["outliers"], frames)}


def _found_and_chosen(note: dict) -> str:
    """The noise auto found for one joint and the filter it chose."""
    given = note["unit"]  # "deg"; for positions "m" where the format fixes it, else "length"
    unit = given if given == "deg" else length_word(None if given == "length" else given)
    if note.get("still"):  # (under either model: a video estimate's fixed finger too)
        return "still throughout: nothing to filter"
    error = note["expected_error"]
    error = f"{error:.3g}" if error >= 0.01 else "< 0.01"  # SURE is rough near zero
    loud = note.get("loud", [])
    where = ""
    if loud:
        shown = ", ".join(f"{a:g}-{b:g} s" for a, b in loud[:3])
        where = f", loud at {shown}" + (f" and {len(loud) - 3} more" if len(loud) > 3 else "")
    share = note.get("share", 1.0)
    along = "" if share >= 0.995 else f" on {share:.0%} of the clip, varying along it"
    band = f", low-passed below {note['band_hz']:g} Hz" if "band_hz" in note else ""
    if held_at_mean(note):  # no mask: the clip's mean on every frame
        chose = "held it at its mean over the clip (no motion above the noise)"
    else:
        chose = f"chose {format_params(note['filter'])}{along}"
    if note.get("model") == "markerless":
        edge = note.get("wander_edge_hz")
        up_to = "up to the top" if edge is None else f"up to {edge:g} Hz"
        return (
            f"estimated noise {note['noise']:.3g} {unit}, {note['wander']:.3g} of it a wander "
            f"{up_to}, down where the motion is (markerless model, {_how(note)})"
            f"{where}; {chose}; expected error {error} {unit} (unfiltered {note['noise']:.3g})"
        )
    if note["noise"] < UNMEASURABLE_NOISE and note["filter"].get("mask") == "none":
        # (the motion fills the band the noise is read in: not "noise 0, error < 0.01",
        # which a wrist with 1.5 degrees of noise at 30 fps had read)
        return (
            "no noise measurable beside its motion (it fills the band the noise is read in: "
            "a fast joint, or a low frame rate); left as it was"
        )
    # a report leaves rho out where it says nothing about the joint (the clip's own is shown)
    said = f"AR(1) rho {note['rho']:.2f}{band}{where}" if "rho" in note else f"{band}{where}"[2:]
    source = f" (optical model, {_how(note)})" if "source" in note else ""
    return (
        f"estimated noise {note['noise']:.3g} {unit}{f' ({said})' if said else ''}; "
        f"{chose}; expected error {error} {unit}{source}"
    )


STEP = StepSpec(
    name="auto",
    summary="model each joint's noise (level along the clip, AR(1) correlation; for "
    "markerless and video captures also its wander below the motion's top frequencies) and "
    "pick the Lee-Shin mask and strength for it",
    paper="000 Eq. 19-20, 23, 26; AR(1) noise fitted on the displacements' spectrum, or "
    "motion, white noise and a wander fitted on it (markerless); choice by a risk estimate "
    "valid for correlated noise",
    params=(
        Param(
            "strength",
            "float",
            1.0,
            "multiplies the noise used for the choice: 0 leaves the clip unchanged, 0.5 "
            "smooths as if the noise were half the estimate (gently, or not at all where "
            "motion outweighs that), 2 as if it were twice; whether a joint is worth "
            "smoothing at all is judged at the estimate itself",
            minimum=0.0,
            maximum=10.0,
        ),
        Param(
            "max_seconds",
            "float",
            1.0,
            "widest candidate mask half-width, seconds",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=10.0,
        ),
        Param("mask", "str", "any", "mask families to choose from", choices=("any", *FAMILIES)),
        Param(
            "source",
            "str",
            "auto",
            "capture system: markerless or video (noise reaching into the motion's band), "
            "optical or inertial (noise above the motion), or auto (found from the clip: "
            "markerless when its joints' motion spectrum is flat over 2-8 Hz)",
            choices=SOURCES,
        ),
        Param(
            "noise_deg",
            "float",
            None,
            "assumed per-sample rotation noise (RMS rotation "
            "angle, degrees) instead of the estimate",
            minimum=0.0,
            maximum=180.0,
        ),
        Param(
            "position_noise",
            "float",
            None,
            "assumed per-sample translation noise (RMS, file length unit) instead of the estimate",
            minimum=0.0,
        ),
    ),
    run=_run_auto,
    sees_missing=True,
    format_note=_format_note,
    format_brief=_format_brief,
    crop_note=_crop_note,
    merge_note=_merge_note,
    shift_note=_shift_note,
)
