"""Orientation filters: pure functions from ``(F, ..., 4)`` quaternion arrays to new arrays.

Each filter takes the rotation array first and returns a new array; position counterparts
(suffix ``_positions``) take ``(F, ..., 3)``. Filters never see files or joint names.
"""

from .auto import auto, auto_positions
from .bilateral import bilateral, bilateral_positions
from .despike import (
    despike,
    despike_positions,
    despike_positions_with_report,
    despike_with_report,
)
from .fairing import fairing, fairing_positions, sse_fairing, sse_fairing_positions
from .linear import lee_shin, lee_shin_positions

__all__ = [
    "auto",
    "auto_positions",
    "bilateral",
    "bilateral_positions",
    "despike",
    "despike_positions",
    "despike_positions_with_report",
    "despike_with_report",
    "fairing",
    "fairing_positions",
    "lee_shin",
    "lee_shin_positions",
    "sse_fairing",
    "sse_fairing_positions",
]
