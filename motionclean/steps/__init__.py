"""The step registry: each step is a module of its own, imported here and listed once in
:data:`REGISTRY`."""

from __future__ import annotations

from . import (
    auto,
    bilateral,
    despike,
    fairing,
    fill_gaps,
    footlock,
    ground,
    lee_shin,
    multires,
    resample,
    sse_fairing,
)
from .base import COMMON_PARAMS, Param, StepData, StepSpec

__all__ = ["COMMON_PARAMS", "REGISTRY", "Param", "StepData", "StepSpec"]

REGISTRY: dict[str, StepSpec] = {
    step.name: step
    for step in (
        lee_shin.STEP,
        bilateral.STEP,
        fairing.STEP,
        sse_fairing.STEP,
        multires.STEP,
        despike.STEP,
        auto.STEP,
        footlock.STEP,
        ground.STEP,
        resample.STEP,
        fill_gaps.STEP,
    )
}
