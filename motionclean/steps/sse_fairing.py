"""The ``sse-fairing`` step: squared error + strain energy by descent on S^3 (004)."""

from __future__ import annotations

import numpy as np

from ..filters.fairing import (
    MAX_ITERATIONS,
    MAX_WEIGHT,
    sse_fairing,
    sse_fairing_positions,
    sse_gradient,
    sse_gradient_positions,
)
from .base import Param, StepData, StepSpec, cut_param


def _run_sse_fairing(data: StepData, params: dict) -> StepData:
    shared = {
        "epsilon": params["epsilon"],
        "max_iterations": params["max_iterations"],
        "return_iterations": True,
    }
    given = data.rotations
    data.rotations, iterations = sse_fairing(given, beta=params["beta"], **shared)
    limit = params["max_iterations"]
    gradient = _gradient_norms(
        sse_gradient, data.rotations, given, params["beta"], iterations == limit
    )
    for column in range(data.rotations.shape[1]):
        data.rotation_notes[column] = {"sse-fairing": _note(iterations, gradient, column, params)}
    if data.translations is not None:
        given = data.translations
        data.translations, iterations = sse_fairing_positions(
            given, alpha=params["alpha"], **shared
        )
        gradient = _gradient_norms(
            sse_gradient_positions, data.translations, given, params["alpha"], iterations == limit
        )
        for column in range(data.translations.shape[1]):
            note = _note(iterations, gradient, column, params)
            data.translation_notes[column] = {"sse-fairing": note}
    return data


def _gradient_norms(gradient, values, given, weight: float, limited) -> np.ndarray:
    """``(C,)``: the norm over all frames of the objective's gradient at the result (what
    ``epsilon`` is compared with: S^3 radians, or the file's length unit), in the columns
    ``limited`` ``(C,)`` marks (those that ran to the iteration limit; NaN elsewhere)."""
    out = np.full(values.shape[1], np.nan)
    capped = np.flatnonzero(limited) if values.shape[0] > 2 else np.zeros(0, dtype=np.intp)
    if capped.size:
        grad = gradient(values[:, capped], given[:, capped], weight)
        out[capped] = np.sqrt(np.einsum("fcd,fcd->c", grad, grad))
    return out


def _note(iterations: np.ndarray, gradient: np.ndarray, column: int, params: dict) -> dict:
    """A column's note: its iterations, and whether it stopped at ``max_iterations`` with
    its gradient norm still at or above ``epsilon`` (not converged), and that norm."""
    count, norm = int(iterations[column]), float(gradient[column])
    limited = count == params["max_iterations"] > 0 and norm >= params["epsilon"]
    return {"iterations": count, "at_limit": bool(limited), "gradient": norm if limited else None}


def _merge_note(parts: list[tuple[dict, int]]) -> dict:
    """A column's note from parts run on their own (takes, stretches between flips): the
    most iterations any took, at the limit where one was, the largest gradient left."""
    left = [note["gradient"] for note, _ in parts if note["at_limit"]]
    return {
        "iterations": max(note["iterations"] for note, _ in parts),
        "at_limit": bool(left),
        "gradient": max(left) if left else None,
    }


STEP = StepSpec(
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
            maximum=MAX_WEIGHT,
        ),
        Param(
            "alpha",
            "float",
            1.0,
            "the same weight for translation channels",
            minimum=0.0,
            maximum=MAX_WEIGHT,
        ),
        Param(
            "epsilon",
            "float",
            1e-6,
            "stop when the gradient norm (over all frames) is below this: log units (half "
            "the rotation angle, rad) for orientations, file length unit for positions",
            minimum=0.0,
        ),
        Param(
            "max_iterations",
            "int",
            200,
            "iteration cap (about 80 per unit of beta to converge)",
            minimum=0,
            maximum=MAX_ITERATIONS,
        ),
        cut_param("004's descent as printed"),
    ),
    run=_run_sse_fairing,
    column_wise=True,
    merge_note=_merge_note,
    cuts_at_flips=True,
)
