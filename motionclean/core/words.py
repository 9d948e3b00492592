"""Words every message shares."""

from __future__ import annotations

__all__ = ["plural"]


def plural(count: int, noun: str) -> str:
    """``"1 frame"``, ``"2 frames"``, ``"1,672 flips"``: a count with its noun."""
    return f"{count:,} {noun}{'' if count == 1 else 's'}"
