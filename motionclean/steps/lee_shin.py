"""The ``lee-shin`` step: any filter mask as a coordinate-invariant orientation filter."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.errors import UsageError
from ..filters import design, masks
from ..filters.linear import lee_shin, lee_shin_positions
from .base import Param, StepData, StepSpec, cut_param

SAVGOL_HALF_WIDTH = 3  # frames, when a savgol mask gives none


@dataclass(frozen=True)
class MaskKind:
    """A mask the step can build: its name, the parameters it takes and its builder
    (``build(params, frame_rate)``, frame rate in Hz, needed by ``lowpass`` only)."""

    name: str
    params: tuple[str, ...]
    build: Callable[[dict, float | None], np.ndarray]


def _rate(fps: float | None) -> float:
    if fps is None:
        raise ValueError("mask=lowpass needs the clip's frame rate")
    return fps


#: A file's frame time is rounded (BVH ``.0083333`` is 120.0005 fps): a cutoff within this
#: fraction of half the rate is taken as at the Nyquist frequency, not below it.
NYQUIST_ROUNDING = 1e-4


def _above_nyquist(cutoff_hz: float, fps: float) -> str | None:
    """What is wrong with a cutoff (Hz) for a clip of ``fps`` frames per second, or None:
    it must lie below half the rate, a cutoff at half the rounded rate included."""
    nyquist = fps / 2.0
    if cutoff_hz < nyquist * (1.0 - NYQUIST_ROUNDING):
        return None
    return (
        f"cutoff_hz must be below the Nyquist frequency {nyquist:.5g} Hz (half the "
        f"frame rate of {fps:.5g} fps), got {cutoff_hz:g}"
    )


def _lowpass(cutoff_hz: float, fps: float, half_width: int | None) -> np.ndarray:
    """``design.lowpass`` for a clip: a cutoff at half its rounded rate is refused too."""
    problem = _above_nyquist(cutoff_hz, fps)
    if problem is not None:
        raise ValueError(problem)
    return design.lowpass(cutoff_hz, fps, half_width)


def _check_rate(params: dict, frame_time: float, where: str) -> None:
    """The pipeline's check of a step against the clip's frame time (s), before any step
    runs: a low-pass cutoff at or above the Nyquist frequency is a usage error."""
    if params["mask"] == "lowpass":
        problem = _above_nyquist(params["cutoff_hz"], 1.0 / frame_time)
        if problem is not None:
            raise UsageError(f"{where}: {problem}")


MASK_KINDS = {
    kind.name: kind
    for kind in (
        MaskKind("binomial", ("k",), lambda p, fps: masks.binomial(p["k"])),
        MaskKind("smoothing", ("lam",), lambda p, fps: masks.smoothing(p["lam"])),
        MaskKind("high-boost", ("lam",), lambda p, fps: masks.high_boost(p["lam"])),
        MaskKind("gaussian", ("sigma_t",), lambda p, fps: masks.gaussian(p["sigma_t"])),
        MaskKind(
            "savgol",
            ("half_width", "degree"),
            lambda p, fps: design.savgol(p["half_width"], p["degree"]),
        ),
        MaskKind(
            "lowpass",
            ("cutoff_hz", "half_width"),
            lambda p, fps: _lowpass(p["cutoff_hz"], _rate(fps), p["half_width"]),
        ),
        MaskKind("reduction", (), lambda p, fps: masks.reduction()),
        MaskKind("custom", ("coefficients",), lambda p, fps: masks.custom(p["coefficients"])),
    )
}


def _mask_from(params: dict, frame_time: float | None = None) -> np.ndarray:
    """The mask a lee-shin step describes; ``frame_time`` (s) is needed by mask=lowpass."""
    return MASK_KINDS[params["mask"]].build(
        params, None if frame_time is None else 1.0 / frame_time
    )


def _resolve_lee_shin(params: dict, at: Callable[..., str]) -> None:
    if params["mask"] == "custom" and params["coefficients"] is None:
        raise UsageError(
            f"{at('mask')}: mask=custom needs coefficients, e.g. coefficients=[0.25,0.5,0.25]"
        )
    if params["mask"] == "lowpass":
        if params["cutoff_hz"] is None:
            raise UsageError(f"{at('mask')}: mask=lowpass needs cutoff_hz, e.g. cutoff_hz=8")
        return  # the Nyquist check needs the clip's frame rate: _check_rate, on the clip
    if params["mask"] == "savgol" and params["half_width"] is None:
        params["half_width"] = SAVGOL_HALF_WIDTH
    try:
        _mask_from(params)
    except masks.MaskError as error:  # (about the mask's own parameters, as given)
        raise UsageError(f"{at(*MASK_KINDS[params['mask']].params, 'mask')}: {error}") from None


def _lee_shin_relevant(params: dict) -> tuple[str, ...]:
    return ("mask", *MASK_KINDS[params["mask"]].params, "iterations", "cut_deg")


def _run_lee_shin(data: StepData, params: dict) -> StepData:
    if params["mask"] == "lowpass" and params["half_width"] is None:
        # two periods of the cutoff, but no longer than the clip (the time and memory of a
        # cutoff near 0 Hz follow the clip, not the cutoff)
        longest = max(1, min(data.rotations.shape[0], masks.MAX_HALF_WIDTH))
        most = design.default_lowpass_half_width(
            params["cutoff_hz"], 1.0 / data.frame_time, longest
        )
        params = {**params, "half_width": most}
    mask = _mask_from(params, data.frame_time)
    cut_above = math.radians(params["cut_deg"])
    data.rotations = lee_shin(data.rotations, mask, params["iterations"], cut_above)
    if data.translations is not None:
        data.translations = lee_shin_positions(data.translations, mask, params["iterations"])
    return data


STEP = StepSpec(
    name="lee-shin",
    summary="any filter mask as a coordinate-invariant orientation filter",
    paper="000 Eq. 19-20 (masks Eq. 21-25, boundary Eq. 26)",
    params=(
        Param("mask", "str", "binomial", "filter mask", choices=tuple(MASK_KINDS)),
        Param(
            "k",
            "int",
            2,
            "binomial half-width: a mask of 2k+1 taps (000 Eq. 23)",
            minimum=0,
            maximum=masks.MAX_HALF_WIDTH,
        ),
        Param(
            "lam",
            "float",
            0.5,
            "damping of mask=smoothing (000 Eq. 22) or gain of mask=high-boost (Eq. 25)",
            minimum=0.0,
            maximum=10.0,
        ),
        Param(
            "sigma_t",
            "float",
            1.0,
            "mask=gaussian width in frames (truncated at 3 sigma_t)",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=50.0,
        ),
        Param(
            "half_width",
            "int",
            None,
            "mask=savgol: half-width in frames (default 3); "
            "mask=lowpass: mask half-width (default ceil(2 fps / cutoff_hz), at most the "
            "clip's frame count)",
            minimum=0,
            maximum=masks.MAX_HALF_WIDTH,
        ),
        Param(
            "degree",
            "int",
            2,
            "mask=savgol: degree of the local polynomial (<= 2 half_width)",
            minimum=0,
            maximum=20,
        ),
        Param(
            "cutoff_hz",
            "float",
            None,
            "mask=lowpass: -6 dB cutoff in Hz, below half the "
            "frame rate (a windowed sinc, zero phase)",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        Param("coefficients", "floats", None, "mask=custom: odd-length list summing to 1"),
        Param("iterations", "int", 1, "number of passes", minimum=1, maximum=1000),
        cut_param("000's filter as printed"),
    ),
    run=_run_lee_shin,
    column_wise=True,
    resolve=_resolve_lee_shin,
    check_rate=_check_rate,
    relevant=_lee_shin_relevant,
)
