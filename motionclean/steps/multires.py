"""The ``multires`` step: scale the detail levels of a displacement-map pyramid (003)."""

from __future__ import annotations

from collections.abc import Callable

from ..core.errors import UsageError
from ..filters import multires
from .base import Param, StepData, StepSpec, cut_param

MULTIRES_GAINS = (0.0,)  # without gains or level: remove the finest band


def _multires_gains(params: dict) -> list[float]:
    if params["level"] is not None:
        return multires.level_gains(params["levels"], params["level"])
    return params["gains"]


def _resolve_multires(params: dict, at: Callable[..., str]) -> None:
    if params["level"] is not None and params["gains"] is not None:
        raise UsageError(f"{at('level', 'gains')}: give either gains or level, not both")
    if params["level"] is None and params["gains"] is None:
        params["gains"] = list(MULTIRES_GAINS)
    if params["gains"] is not None and len(params["gains"]) > params["levels"]:
        raise UsageError(
            f"{at('gains', 'levels')}: {len(params['gains'])} gains for {params['levels']} levels"
        )
    if params["level"] is not None and params["level"] > params["levels"]:
        raise UsageError(
            f"{at('level', 'levels')}: level must lie in [0, levels={params['levels']}]"
        )


def _run_multires(data: StepData, params: dict) -> StepData:
    gains = _multires_gains(params)
    data.rotations = multires.edit(data.rotations, params["levels"], gains)
    if data.translations is not None:
        data.translations = multires.edit_positions(data.translations, params["levels"], gains)
    return data


STEP = StepSpec(
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
        cut_param("003's pyramid as printed"),
    ),
    run=_run_multires,
    column_wise=True,
    cuts_at_flips=True,
    resolve=_resolve_multires,
)
