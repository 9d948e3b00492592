"""CSV read and write (placeholder until the CSV formats land)."""

from __future__ import annotations

from ..errors import MotionError


def parse_csv(data: bytes, path=None, skeleton=None):
    raise MotionError("CSV reading is not available yet", path)


def format_csv(motion) -> bytes:
    raise MotionError("CSV writing is not available yet")
