"""The ``auto`` step: per-joint noise estimate and the Lee-Shin mask chosen for it."""

from __future__ import annotations

from ..filters.auto import FAMILIES, auto, auto_positions
from .base import Param, StepData, StepSpec, format_params


def _auto_note(result, column: int, unit: str) -> dict:
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
    return note


def _run_auto(data: StepData, params: dict) -> StepData:
    families = FAMILIES if params["mask"] == "any" else (params["mask"],)
    shared = {
        "strength": params["strength"],
        "max_seconds": params["max_seconds"],
        "families": families,
    }
    shared["overwrite"] = data.owned
    result = auto(data.rotations, data.frame_time, noise=params["noise_deg"], **shared)
    data.rotations = result.values
    for column in range(data.rotations.shape[1]):
        data.rotation_notes[column] = {"auto": _auto_note(result, column, "deg")}
    if data.translations is not None:
        result = auto_positions(
            data.translations, data.frame_time, noise=params["position_noise"], **shared
        )
        data.translations = result.values
        for column in range(data.translations.shape[1]):
            data.translation_notes[column] = {"auto": _auto_note(result, column, "length")}
    return data


def _format_note(note: dict, positions: bool) -> str:
    """What auto found for one joint: the noise (level, correlation, loud stretches), the
    choice and its expected error."""
    unit = "deg" if note["unit"] == "deg" else "units"
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
    # a report leaves rho out where it says nothing about the joint (the clip's own is shown)
    said = f"AR(1) rho {note['rho']:.2f}{band}{where}" if "rho" in note else f"{band}{where}"[2:]
    return (
        f"estimated noise {note['noise']:.3g} {unit}{f' ({said})' if said else ''}; "
        f"chose {format_params(note['filter'])}{along}; expected error {error} {unit}"
    )


STEP = StepSpec(
    name="auto",
    summary="model each joint's noise (level along the clip, AR(1) correlation) and pick "
    "the Lee-Shin mask and strength for it, window by window",
    paper="000 Eq. 19-20, 23, 26; AR(1) noise fitted on the displacements' spectrum; "
    "choice by a risk estimate valid for correlated noise",
    params=(
        Param(
            "strength",
            "float",
            1.0,
            "multiplies the noise used for the choice: 0 leaves "
            "the clip unchanged, 2 smooths as if the noise were twice the estimate",
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
    format_note=_format_note,
)
