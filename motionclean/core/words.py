"""Words every message shares."""

from __future__ import annotations

import unicodedata

import numpy as np

__all__ = [
    "UNSAID_LENGTH",
    "columns",
    "last_columns",
    "length_word",
    "pad",
    "percent",
    "plural",
    "significant",
]

#: The ``unit`` of a step note's lengths (``auto``, ``despike``, ``ground``) where the format
#: does not say theirs: the file's own (its notes on rotations say ``"deg"``).
UNSAID_LENGTH = "length"


def plural(count: int, noun: str) -> str:
    """``"1 frame"``, ``"2 frames"``, ``"1,672 flips"``: a count with its noun."""
    return f"{count:,} {noun}{'' if count == 1 else 's'}"


def length_word(unit: str | None) -> str:
    """What lengths are said in: their unit where the format fixes one (``"m"``), else
    ``"units"`` (the file's own: a BVH's centimetres or inches, unsaid; ``unit`` None or
    :data:`UNSAID_LENGTH`)."""
    return "units" if unit in (None, UNSAID_LENGTH) else unit


def significant(value: float, digits: int = 2) -> str:
    """A number in ``digits`` significant figures, without an exponent: "0.078",
    "0.000087", "1140" (three)."""
    return str(np.format_float_positional(float(f"{value:.{digits}g}"), trim="-"))


def percent(share: float) -> str:
    """``0.26`` as ``"26 %"``: a share in whole percent, a space before the sign."""
    return whole_percent(share).replace("%", " %")


def whole_percent(share: float) -> str:
    """``0.26`` as ``"26%"``: a share in whole percent; one that rounds to nothing reads
    ``"0%"``, not ``"-0%"`` (a rounding's sign)."""
    return f"{round(share, 2) + 0.0:.0%}"


def columns(text: str) -> int:
    """How many terminal columns ``text`` takes: wide and full-width characters (CJK) two,
    combining marks none, every other character one."""
    return sum(map(_columns, text))


def _columns(c: str) -> int:
    """The terminal columns of one character (:func:`columns`)."""
    return 0 if unicodedata.combining(c) else 2 if unicodedata.east_asian_width(c) in "WF" else 1


def pad(text: str, width: int) -> str:
    """``text`` padded with spaces to ``width`` terminal columns (:func:`columns`), as
    ``f"{text:<{width}}"`` pads one column per character."""
    return text + " " * max(width - columns(text), 0)


def last_columns(text: str, width: int) -> str:
    """The end of ``text`` that fits in ``width`` terminal columns (:func:`columns`): its
    characters from the last back, up to the first that would overflow."""
    used = 0
    for start in range(len(text) - 1, -1, -1):
        used += _columns(text[start])
        if used > width:
            return text[start + 1 :]
    return text
