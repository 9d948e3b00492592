"""The ``bilateral`` step: edge-preserving orientation smoothing (002)."""

from __future__ import annotations

import math

from ..filters.bilateral import bilateral, bilateral_positions
from .base import Param, StepData, StepSpec, cut_param


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


STEP = StepSpec(
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
        cut_param("002's filter as printed"),
    ),
    run=_run_bilateral,
    column_wise=True,
    cuts_at_flips=True,
)
