"""The ``sse-fairing`` step: squared error + strain energy by descent on S^3 (004)."""

from __future__ import annotations

from ..filters.fairing import MAX_ITERATIONS, MAX_WEIGHT, sse_fairing, sse_fairing_positions
from .base import Param, StepData, StepSpec, cut_param


def _run_sse_fairing(data: StepData, params: dict) -> StepData:
    shared = {"epsilon": params["epsilon"], "max_iterations": params["max_iterations"]}
    data.rotations = sse_fairing(data.rotations, beta=params["beta"], **shared)
    if data.translations is not None:
        data.translations = sse_fairing_positions(
            data.translations, alpha=params["alpha"], **shared
        )
    return data


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
    cuts_at_flips=True,
)
