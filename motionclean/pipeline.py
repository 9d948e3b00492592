"""Pipelines: the step registry, TOML and inline parsing, validation, and running a Motion.

A pipeline is an ordered list of steps. Each step names a filter from :data:`REGISTRY`, its
parameters, the joints it applies to (fnmatch patterns, ``!`` excludes) and whether
translation channels are filtered too. This module is the only place that maps joint names
to array columns; filters only ever see arrays.

Everything is validated before any clip is read: an unknown filter, an unknown or missing
parameter, a wrong type or a value out of range raises :class:`UsageError` naming the step,
the key and what is allowed.
"""

from __future__ import annotations

import fnmatch
import math
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import multires
from .errors import MotionError, UsageError
from .filters import design, masks
from .filters.auto import FAMILIES, auto, auto_positions
from .filters.bilateral import bilateral, bilateral_positions
from .filters.despike import despike_positions_with_report, despike_with_report
from .filters.fairing import fairing, fairing_positions, sse_fairing, sse_fairing_positions
from .filters.linear import lee_shin, lee_shin_positions
from .motion import Motion

REQUIRED = object()


@dataclass(frozen=True)
class Param:
    """One step parameter: its type, default, allowed range and a help line with units."""

    name: str
    type: str  # "int", "float", "bool", "str", "floats" (list of numbers), "strs"
    default: Any
    help: str
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False
    choices: tuple[str, ...] | None = None
    infinite_ok: bool = False

    def allowed(self) -> str:
        """What values are allowed, for error messages and the catalogue."""
        if self.choices:
            return "one of " + ", ".join(self.choices)
        kind = {
            "int": "an integer",
            "float": "a number",
            "bool": "true or false",
            "str": "a string",
            "floats": "a list of numbers",
            "strs": "a list of strings",
        }[self.type]
        bounds = []
        if self.minimum is not None:
            bounds.append(f"{'>' if self.exclusive_minimum else '>='} {self.minimum:g}")
        if self.maximum is not None:
            bounds.append(f"<= {self.maximum:g}")
        text = kind + (" " + " and ".join(bounds) if bounds else "")
        return text + (" (inf allowed)" if self.infinite_ok else "")

    def coerce(self, value: Any, where: str) -> Any:
        """Check ``value`` against the type and range; return it in canonical form."""
        bad = UsageError(f"{where}: {self.name} must be {self.allowed()}, got {value!r}")
        if self.type == "bool":
            if not isinstance(value, bool):
                raise bad
            return value
        if self.type in ("str", "strs"):
            if self.type == "strs" and isinstance(value, str):
                value = [value]
            items = value if self.type == "strs" else [value]
            if not isinstance(items, list) or not all(isinstance(v, str) for v in items):
                raise bad
            if self.choices and value not in self.choices:
                raise bad
            return value
        if self.type == "floats":
            if not isinstance(value, list) or not all(_is_number(v) for v in value):
                raise bad
            if not all(self._in_range(float(v)) for v in value):
                raise bad
            return [float(v) for v in value]
        if not _is_number(value):
            raise bad
        if self.type == "int":
            if not float(value).is_integer():
                raise bad
            value = int(value)
        else:
            value = float(value)
        if not self._in_range(value):
            raise bad
        return value

    def _in_range(self, value: float) -> bool:
        if math.isnan(value) or (math.isinf(value) and not (self.infinite_ok and value > 0)):
            return False
        below = self.minimum is not None and (
            value < self.minimum or (self.exclusive_minimum and value == self.minimum)
        )
        return not below and (self.maximum is None or value <= self.maximum)


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


@dataclass
class StepData:
    """What a step sees: the selected joints' arrays and the clip's frame time (s)."""

    rotations: np.ndarray  # (F, Jr, 4)
    translations: np.ndarray | None  # (F, Jp, 3), None when positions are off or absent
    frame_time: float
    # Per selected column (index into rotations / translations): notes for the report.
    rotation_notes: dict[int, dict] = field(default_factory=dict)
    translation_notes: dict[int, dict] = field(default_factory=dict)


@dataclass(frozen=True)
class StepSpec:
    """A registered filter: its pipeline name, parameters and how to run it on arrays."""

    name: str
    summary: str
    paper: str
    params: tuple[Param, ...]
    run: Callable[[StepData, dict], StepData]
    positions_default: bool = True
    # Cross-parameter rules; may fill defaults that depend on other parameters.
    resolve: Callable[[dict, str], None] | None = None
    # Names of the parameters that matter for these values (default: all of them).
    relevant: Callable[[dict], tuple[str, ...]] | None = None


COMMON_PARAMS = (
    Param("joints", "strs", ["*"], "fnmatch patterns on joint names; a leading '!' excludes"),
    Param("positions", "bool", True, "also filter translation channels (vector counterpart)"),
)

# ----------------------------------------------------------------------------- lee-shin

SAVGOL_HALF_WIDTH = 3  # frames, when a savgol mask gives none
MASKS = (
    "binomial",
    "smoothing",
    "high-boost",
    "gaussian",
    "savgol",
    "lowpass",
    "reduction",
    "custom",
)


def _mask_from(params: dict, frame_time: float | None = None) -> np.ndarray:
    """The mask a lee-shin step describes; ``frame_time`` (s) is needed by mask=lowpass."""
    kind = params["mask"]
    if kind == "savgol":
        return design.savgol(params["half_width"], params["degree"])
    if kind == "lowpass":
        return design.lowpass(params["cutoff_hz"], 1.0 / frame_time, params["half_width"])
    if kind == "binomial":
        return masks.binomial(params["k"])
    if kind == "smoothing":
        return masks.smoothing(params["lam"])
    if kind == "high-boost":
        return masks.high_boost(params["lam"])
    if kind == "gaussian":
        return masks.gaussian(params["sigma_t"])
    if kind == "reduction":
        return masks.reduction()
    return masks.custom(params["coefficients"])


def _resolve_lee_shin(params: dict, where: str) -> None:
    if params["mask"] == "custom" and params["coefficients"] is None:
        raise UsageError(
            f"{where}: mask=custom needs coefficients, e.g. coefficients=[0.25,0.5,0.25]"
        )
    if params["mask"] != "custom" and params["coefficients"] is not None:
        raise UsageError(f"{where}: coefficients only apply to mask=custom")
    if params["mask"] == "lowpass":
        if params["cutoff_hz"] is None:
            raise UsageError(f"{where}: mask=lowpass needs cutoff_hz, e.g. cutoff_hz=8")
        return  # the Nyquist check needs the clip's frame rate: done when the step runs
    if params["cutoff_hz"] is not None:
        raise UsageError(f"{where}: cutoff_hz only applies to mask=lowpass")
    if params["mask"] == "savgol" and params["half_width"] is None:
        params["half_width"] = SAVGOL_HALF_WIDTH
    try:
        _mask_from(params)
    except masks.MaskError as error:
        raise UsageError(f"{where}: {error}") from None


MASK_PARAMS = {
    "binomial": ("k",),
    "smoothing": ("lam",),
    "high-boost": ("lam",),
    "gaussian": ("sigma_t",),
    "savgol": ("half_width", "degree"),
    "lowpass": ("cutoff_hz", "half_width"),
    "reduction": (),
    "custom": ("coefficients",),
}


def _lee_shin_relevant(params: dict) -> tuple[str, ...]:
    return ("mask", *MASK_PARAMS[params["mask"]], "iterations")


def _run_lee_shin(data: StepData, params: dict) -> StepData:
    mask = _mask_from(params, data.frame_time)
    data.rotations = lee_shin(data.rotations, mask, params["iterations"])
    if data.translations is not None:
        data.translations = lee_shin_positions(data.translations, mask, params["iterations"])
    return data


LEE_SHIN = StepSpec(
    name="lee-shin",
    summary="any filter mask as a coordinate-invariant orientation filter",
    paper="000 Eq. 19-20 (masks Eq. 21-25, boundary Eq. 26)",
    params=(
        Param("mask", "str", "binomial", "filter mask", choices=MASKS),
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
            "mask=lowpass: mask half-width (default ceil(2 fps / cutoff_hz))",
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
    ),
    run=_run_lee_shin,
    resolve=_resolve_lee_shin,
    relevant=_lee_shin_relevant,
)

# ----------------------------------------------------------------------------- bilateral


def _run_bilateral(data: StepData, params: dict) -> StepData:
    window = {
        "sigma_t": params["sigma_t"],
        "radius": params["radius"],
        "iterations": params["iterations"],
    }
    data.rotations = bilateral(data.rotations, sigma_g=params["sigma_g"], **window)
    if data.translations is not None:
        sigma_p = math.inf if params["sigma_p"] is None else params["sigma_p"]
        data.translations = bilateral_positions(data.translations, sigma_p=sigma_p, **window)
    return data


BILATERAL = StepSpec(
    name="bilateral",
    summary="edge-preserving smoothing: Gaussian in time and in rotation distance",
    paper="002 Eq. 2-5, Algorithm 1 (boundary 000 Eq. 26)",
    params=(
        Param(
            "sigma_t",
            "float",
            1.0,
            "temporal Gaussian width, frames",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=50.0,
        ),
        Param(
            "sigma_g",
            "float",
            0.1,
            "range width in log units (half the rotation angle, "
            "rad; 0.1 is about 11.5 degrees); inf gives the Gaussian Lee-Shin filter",
            minimum=0.0,
            exclusive_minimum=True,
            infinite_ok=True,
        ),
        Param(
            "radius",
            "int",
            None,
            "window half-width in frames (default ceil(3 sigma_t))",
            minimum=0,
            maximum=150,
        ),
        Param(
            "iterations",
            "int",
            1,
            "number of passes (weights recomputed each pass)",
            minimum=1,
            maximum=1000,
        ),
        Param(
            "sigma_p",
            "float",
            None,
            "range width for translation channels, file length "
            "unit (default inf: a plain Gaussian on positions)",
            minimum=0.0,
            exclusive_minimum=True,
            infinite_ok=True,
        ),
    ),
    run=_run_bilateral,
)

# ----------------------------------------------------------------------------- multires


MULTIRES_GAINS = (0.0,)  # without gains or level: remove the finest band


def _multires_gains(params: dict) -> list[float]:
    if params["level"] is not None:
        return multires.level_gains(params["levels"], params["level"])
    return params["gains"]


def _resolve_multires(params: dict, where: str) -> None:
    if params["level"] is not None and params["gains"] is not None:
        raise UsageError(f"{where}: give either gains or level, not both")
    if params["level"] is None and params["gains"] is None:
        params["gains"] = list(MULTIRES_GAINS)
    if params["gains"] is not None and len(params["gains"]) > params["levels"]:
        raise UsageError(f"{where}: {len(params['gains'])} gains for {params['levels']} levels")
    if params["level"] is not None and params["level"] > params["levels"]:
        raise UsageError(f"{where}: level must lie in [0, levels={params['levels']}]")


def _run_multires(data: StepData, params: dict) -> StepData:
    gains = _multires_gains(params)
    data.rotations = multires.edit(data.rotations, params["levels"], gains)
    if data.translations is not None:
        data.translations = multires.edit_positions(data.translations, params["levels"], gains)
    return data


MULTIRES = StepSpec(
    name="multires",
    summary="multiresolution pyramid of displacement maps, detail levels scaled by gains",
    paper="003 Eq. 7-16, editing Sec. 5.1",
    params=(
        Param(
            "levels",
            "int",
            4,
            "pyramid depth N (each level halves the frame rate; cut to what the clip allows)",
            minimum=1,
            maximum=30,
        ),
        Param(
            "gains",
            "floats",
            None,
            "detail gains, finest level first; unlisted levels "
            "keep 1; 0 removes a band, <1 attenuates, >1 enhances (default [0]: the finest "
            "band removed)",
            minimum=0.0,
            maximum=10.0,
        ),
        Param(
            "level",
            "float",
            None,
            "fractional level n+alpha counted from the base "
            "(levels = the original); replaces gains",
            minimum=0.0,
            maximum=30.0,
        ),
    ),
    run=_run_multires,
    resolve=_resolve_multires,
)

# ----------------------------------------------------------------------------- despike


def _resolve_despike(params: dict, where: str) -> None:
    if params["min_deg_per_s"] > params["max_deg_per_s"]:
        raise UsageError(f"{where}: min_deg_per_s must not exceed max_deg_per_s")
    if params["min_units_per_s"] > params["max_units_per_s"]:
        raise UsageError(f"{where}: min_units_per_s must not exceed max_units_per_s")


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
        **shared,
    )
    for column in np.flatnonzero(report.counts()):
        data.rotation_notes[int(column)] = {"despike": report.summary(column)}
    if data.translations is not None:
        data.translations, report = despike_positions_with_report(
            data.translations,
            data.frame_time,
            method="linear" if params["method"] == "slerp" else "cubic",
            min_units_per_s=params["min_units_per_s"],
            max_units_per_s=params["max_units_per_s"],
            **shared,
        )
        for column in np.flatnonzero(report.counts()):
            data.translation_notes[int(column)] = {"despike": report.summary(column)}
    return data


DESPIKE = StepSpec(
    name="despike",
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
            3.0,
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
            150.0,
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
            "positions: steps slower than this are never jumps, length units per s",
            minimum=0.0,
        ),
        Param(
            "max_units_per_s",
            "float",
            math.inf,
            "positions: absolute cap, length units per s",
            minimum=0.0,
            exclusive_minimum=True,
            infinite_ok=True,
        ),
    ),
    run=_run_despike,
    resolve=_resolve_despike,
)

# ----------------------------------------------------------------------------- fairing


def _run_fairing(data: StepData, params: dict) -> StepData:
    shared = {
        "order": params["order"],
        "tol": params["tol"],
        "max_iterations": params["max_iterations"],
    }
    data.rotations = fairing(
        data.rotations, lam_r=params["lam_r"], epsilon_r=params["epsilon_r"], **shared
    )
    if data.translations is not None:
        data.translations = fairing_positions(
            data.translations, lam_t=params["lam_t"], epsilon_t=params["epsilon_t"], **shared
        )
    return data


FAIRING = StepSpec(
    name="fairing",
    summary="iterative fairing of order 2 or 3 within a bound of the input",
    paper="001 Eq. 11-20, Fig. 1",
    params=(
        Param(
            "order",
            "int",
            3,
            "order m of the fairing energy: 2 = constant angular "
            "velocity, 3 = constant angular acceleration",
            minimum=2,
            maximum=3,
        ),
        Param(
            "lam_r",
            "float",
            0.1,
            "damping of each orientation step (slerp toward the "
            "fairing operator, Eq. 17); keep below 0.5 for order 3",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=1.0,
        ),
        Param(
            "lam_t",
            "float",
            0.5,
            "damping of each position step (Eq. 17)",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=1.0,
        ),
        Param(
            "epsilon_r",
            "float",
            0.02,
            "bound: no orientation moves farther than this, log "
            "units (half the rotation angle, rad; 0.02 is 2.29 degrees)",
            minimum=0.0,
            infinite_ok=True,
        ),
        Param(
            "epsilon_t",
            "float",
            1.0,
            "bound: no position moves farther than this, file length unit",
            minimum=0.0,
            infinite_ok=True,
        ),
        Param(
            "tol",
            "float",
            1e-7,
            "stop when no sample moves this much in one iteration",
            minimum=0.0,
        ),
        Param("max_iterations", "int", 100, "iteration cap", minimum=0, maximum=100000),
    ),
    run=_run_fairing,
)


def _run_sse_fairing(data: StepData, params: dict) -> StepData:
    shared = {"epsilon": params["epsilon"], "max_iterations": params["max_iterations"]}
    data.rotations = sse_fairing(data.rotations, beta=params["beta"], **shared)
    if data.translations is not None:
        data.translations = sse_fairing_positions(
            data.translations, alpha=params["alpha"], **shared
        )
    return data


SSE_FAIRING = StepSpec(
    name="sse-fairing",
    summary="minimise squared error + weighted strain energy by gradient descent on S^3",
    paper="004 Eq. 13-25",
    params=(
        Param(
            "beta",
            "float",
            1.0,
            "weight of the angular-acceleration energy against the "
            "squared distance, per frame (h = 1); 0 leaves the input",
            minimum=0.0,
            maximum=1e6,
        ),
        Param(
            "alpha",
            "float",
            1.0,
            "the same weight for translation channels",
            minimum=0.0,
            maximum=1e6,
        ),
        Param("epsilon", "float", 1e-6, "stop when the gradient norm is below this", minimum=0.0),
        Param(
            "max_iterations",
            "int",
            200,
            "iteration cap (about 80 per unit of beta to converge)",
            minimum=0,
            maximum=100000,
        ),
    ),
    run=_run_sse_fairing,
)

# ----------------------------------------------------------------------------- auto


def _auto_note(result, column: int, unit: str) -> dict:
    choice = result.choices[column]
    return {
        "noise": float(result.noise.reshape(-1)[column]),
        "unit": unit,
        "filter": choice.params(),
        "expected_error": choice.expected_error,
    }


def _run_auto(data: StepData, params: dict) -> StepData:
    families = FAMILIES if params["mask"] == "any" else (params["mask"],)
    shared = {
        "strength": params["strength"],
        "max_seconds": params["max_seconds"],
        "families": families,
    }
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


AUTO = StepSpec(
    name="auto",
    summary="estimate each joint's noise and pick the Lee-Shin mask and strength for it",
    paper="000 Eq. 19-20, 23, 26; noise from third differences; choice by SURE",
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
)

REGISTRY: dict[str, StepSpec] = {
    spec.name: spec for spec in (LEE_SHIN, BILATERAL, FAIRING, SSE_FAIRING, MULTIRES, DESPIKE, AUTO)
}


# ----------------------------------------------------------------------------- steps


@dataclass(frozen=True)
class Step:
    """A validated pipeline step: the filter, its parameters, joints and positions flag."""

    spec: StepSpec
    params: dict
    joints: tuple[str, ...]
    positions: bool

    def describe(self) -> dict:
        """The step as a plain dict (report and TOML form), defaults filled in."""
        out = {"filter": self.spec.name}
        names = self.spec.relevant(self.params) if self.spec.relevant else tuple(self.params)
        out.update({k: v for k, v in self.params.items() if v is not None and k in names})
        out["joints"] = list(self.joints)
        out["positions"] = self.positions
        return out


def make_step(table: dict, where: str) -> Step:
    """Validate one step table (``{"filter": ..., params...}``) into a :class:`Step`."""
    if not isinstance(table, dict):
        raise UsageError(f"{where}: a step must be a table of key = value pairs")
    table = dict(table)
    name = table.pop("filter", None)
    if name is None:
        raise UsageError(f"{where}: missing 'filter'; one of {', '.join(REGISTRY)}")
    spec = REGISTRY.get(name)
    if spec is None:
        raise UsageError(f"{where}: unknown filter {name!r}; one of {', '.join(REGISTRY)}")
    where = f"{where} ({name})"
    allowed = spec.params + COMMON_PARAMS
    params: dict[str, Any] = {}
    for key, value in table.items():
        param = next((p for p in allowed if p.name == key), None)
        if param is None:
            raise UsageError(
                f"{where}: unknown parameter {key!r}; allowed: "
                + ", ".join(p.name for p in allowed)
            )
        params[key] = param.coerce(value, where)
    for param in spec.params:
        if param.name not in params:
            if param.default is REQUIRED:
                raise UsageError(f"{where}: missing parameter {param.name!r} ({param.help})")
            params[param.name] = param.default
    joints = tuple(params.pop("joints", ["*"]))
    positions = params.pop("positions", spec.positions_default)
    if spec.resolve is not None:
        spec.resolve(params, where)
    return Step(spec, params, joints, positions)


def parse_value(text: str) -> Any:
    """An inline value read as TOML (numbers, booleans, lists); bare words are strings."""
    text = text.strip()
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        pass
    if text.startswith("[") and text.endswith("]"):
        return [parse_value(item) for item in _split_top(text[1:-1]) if item.strip()]
    return text


def _split_top(text: str) -> list[str]:
    """Split on commas outside brackets and quotes."""
    parts, depth, quote, start = [], 0, None, 0
    for i, ch in enumerate(text):
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def parse_inline(text: str) -> dict:
    """``"bilateral:sigma_t=1,sigma_g=0.1"`` -> ``{"filter": "bilateral", ...}``."""
    name, _, rest = text.partition(":")
    table: dict[str, Any] = {"filter": name.strip()}
    for item in _split_top(rest) if rest.strip() else []:
        key, eq, value = item.partition("=")
        if not eq or not key.strip():
            raise UsageError(f"-f {text!r}: expected key=value, got {item.strip()!r}")
        if key.strip() in table:
            raise UsageError(f"-f {text!r}: {key.strip()!r} is given twice")
        table[key.strip()] = parse_value(value)
    return table


def select_joints(names: list[str], patterns: tuple[str, ...]) -> np.ndarray:
    """``(J,)`` bool: joints matched by the patterns, applied in order.

    A pattern adds the joints it matches (``fnmatch``, case sensitive); ``!pattern`` removes
    them. When every pattern is an exclusion, selection starts from all joints.
    """
    selected = np.full(len(names), all(p.startswith("!") for p in patterns))
    for pattern in patterns:
        exclude = pattern.startswith("!")
        hits = np.array([fnmatch.fnmatchcase(n, pattern[exclude:]) for n in names], dtype=bool)
        selected = selected & ~hits if exclude else selected | hits
    return selected


def unmatched_patterns(names: list[str], patterns: tuple[str, ...]) -> list[str]:
    """The include patterns (not ``!``) that match none of ``names``: likely typos."""
    return [
        p
        for p in patterns
        if not p.startswith("!") and not any(fnmatch.fnmatchcase(n, p) for n in names)
    ]


@dataclass
class StepLog:
    """What one step did: the step, the joints it touched, per-joint notes."""

    step: Step
    rotation_joints: list[str]
    translation_joints: list[str]
    notes: dict[str, dict]
    unmatched: list[str]  # include patterns that matched no joint of this clip


@dataclass
class Pipeline:
    """An ordered list of validated steps."""

    steps: list[Step]
    origin: str = "pipeline"

    @classmethod
    def from_tables(cls, tables: list, origin: str) -> Pipeline:
        if not tables:
            raise UsageError(f"{origin}: the pipeline has no steps")
        return cls([make_step(t, f"{origin}: step {i}") for i, t in enumerate(tables, 1)], origin)

    @classmethod
    def from_toml(cls, path: str | Path) -> Pipeline:
        """Read ``[[step]]`` tables from a TOML file."""
        path = Path(path)
        try:
            document = tomllib.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise UsageError(f"{path}: no such pipeline file") from None
        except (OSError, UnicodeDecodeError) as error:
            raise UsageError(f"{path}: cannot read pipeline: {error}") from None
        except tomllib.TOMLDecodeError as error:
            raise UsageError(f"{path}: invalid TOML: {error}") from None
        unknown = set(document) - {"step"}
        if unknown:
            raise UsageError(
                f"{path}: unknown top-level key {sorted(unknown)[0]!r}; steps are [[step]] tables"
            )
        steps = document.get("step", [])
        if not isinstance(steps, list):
            raise UsageError(f"{path}: 'step' must be an array of tables ([[step]])")
        return cls.from_tables(steps, str(path))

    @classmethod
    def from_inline(cls, texts: list[str]) -> Pipeline:
        """Steps given as ``-f NAME:key=value,...`` options, in order."""
        return cls.from_tables([parse_inline(t) for t in texts], "-f")

    @classmethod
    def default(cls) -> Pipeline:
        """The pipeline ``clean`` uses when none is given (see README, "Default pipeline")."""
        return cls.from_tables(DEFAULT_STEPS, "default pipeline")

    def describe(self) -> list[dict]:
        return [step.describe() for step in self.steps]

    def run(self, motion: Motion) -> tuple[Motion, list[StepLog]]:
        """Run every step on ``motion``; return the cleaned copy and what each step did."""
        layout = motion.layout
        rotations = motion.rotations.copy()
        translations = motion.translations.copy()
        logs: list[StepLog] = []
        for number, step in enumerate(self.steps, 1):
            chosen = select_joints(motion.names, step.joints)
            rot_idx = np.flatnonzero(chosen & layout.has_rotation)
            pos_idx = np.flatnonzero(chosen & layout.has_position) if step.positions else []
            data = StepData(
                rotations[:, rot_idx],
                translations[:, pos_idx] if len(pos_idx) else None,
                motion.frame_time,
            )
            try:
                data = step.spec.run(data, step.params)
            except (ValueError, FloatingPointError, np.linalg.LinAlgError) as error:
                raise MotionError(
                    f"step {number} ({step.spec.name}) failed: {error}", motion.path
                ) from None
            rotations[:, rot_idx] = data.rotations
            if data.translations is not None:
                translations[:, pos_idx] = data.translations
            notes: dict[str, dict] = {}
            for column, note in data.rotation_notes.items():
                notes.setdefault(motion.names[rot_idx[column]], {}).update(note)
            for column, note in data.translation_notes.items():
                notes.setdefault(motion.names[pos_idx[column]], {}).update(
                    {f"position_{k}": v for k, v in note.items()}
                )
            logs.append(
                StepLog(
                    step,
                    [motion.names[i] for i in rot_idx],
                    [motion.names[i] for i in pos_idx],
                    notes,
                    unmatched_patterns(motion.names, step.joints),
                )
            )
        return motion.replace(rotations=rotations, translations=translations), logs


#: The default pipeline (README, "Default pipeline").
DEFAULT_STEPS: list[dict] = [
    {"filter": "despike"},
    {"filter": "auto"},
]
