"""The ``fairing`` step: iterative fairing within a bound of the input (001)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..core.errors import UsageError
from ..filters.fairing import MAX_ITERATIONS, MAX_LAM_R, MAX_LAM_T, fairing, fairing_positions
from .base import Param, StepData, StepSpec, cut_param


def _resolve_fairing(params: dict, at: Callable[..., str]) -> None:
    """Refuse a damping above its order's stability limit (the iteration diverges there)."""
    order = params["order"]
    for name, limits in (("lam_r", MAX_LAM_R), ("lam_t", MAX_LAM_T)):
        if params[name] > limits[order]:
            raise UsageError(
                f"{at(name, 'order')}: {name} must be at most {limits[order]:g} with "
                f"order={order} (above it the iteration diverges), got {params[name]:g}"
            )


def _run_fairing(data: StepData, params: dict) -> StepData:
    shared = {
        "order": params["order"],
        "tol": params["tol"],
        "max_iterations": params["max_iterations"],
    }
    given = data.rotations
    data.rotations, iterations = fairing(
        given,
        lam_r=params["lam_r"],
        epsilon_r=params["epsilon_r"],
        return_iterations=True,
        **shared,
    )
    held = _held_by_bound(given, iterations, params)
    for column, count in enumerate(iterations.tolist()):  # what the report says of it
        note = {"iterations": count, "held_by_bound": bool(held[column])}
        data.rotation_notes[column] = {"fairing": note}
    if data.translations is not None:
        data.translations = fairing_positions(
            data.translations, lam_t=params["lam_t"], epsilon_t=params["epsilon_t"], **shared
        )
    return data


def _held_by_bound(given: np.ndarray, iterations: np.ndarray, params: dict) -> np.ndarray:
    """``(C,)``: the joints that took no iteration because their first step would leave the
    bound ``epsilon_r`` (one step without the bound: it takes one), not because it would
    raise their energy or the clip is too short to fair."""
    held = np.zeros(iterations.shape, dtype=bool)
    stuck = np.flatnonzero(iterations == 0)
    could = params["max_iterations"] > 0 and given.shape[0] > params["order"]
    if not could or not stuck.size or not math.isfinite(params["epsilon_r"]):
        return held
    _, free = fairing(
        given[:, stuck],
        order=params["order"],
        lam_r=params["lam_r"],
        epsilon_r=math.inf,
        tol=0.0,
        max_iterations=1,
        return_iterations=True,
    )
    held[stuck] = free > 0
    return held


def _merge_note(parts: list[tuple[dict, int]]) -> dict:
    """A joint's note from parts run on their own (takes, known stretches, stretches
    between flips): the most iterations any took; held by the bound where none took one
    and the bound held some (a part too short to fair takes none either)."""
    iterations = max(note["iterations"] for note, _ in parts)
    held = any(note["held_by_bound"] for note, _ in parts)
    return {"iterations": iterations, "held_by_bound": held and iterations == 0}


STEP = StepSpec(
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
            "damping of each orientation step (slerp toward the fairing operator, Eq. 17); "
            f"at most {MAX_LAM_R[3]:g} for order 3 (the iteration diverges above)",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=max(MAX_LAM_R.values()),
        ),
        Param(
            "lam_t",
            "float",
            0.5,
            "damping of each position step (Eq. 17); at most "
            f"{MAX_LAM_T[3]:g} for order 3 (the iteration diverges above)",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=max(MAX_LAM_T.values()),
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
            "stop when no sample moves this much in one iteration: log units (half the "
            "rotation angle, rad) for orientations, file length unit for positions",
            minimum=0.0,
        ),
        Param("max_iterations", "int", 100, "iteration cap", minimum=0, maximum=MAX_ITERATIONS),
        cut_param("001's fairing as printed"),
    ),
    run=_run_fairing,
    merge_note=_merge_note,
    column_wise=True,
    cuts_at_flips=True,
    resolve=_resolve_fairing,
)
