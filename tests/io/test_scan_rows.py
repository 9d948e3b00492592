"""The token scan of rows in the exporters' layout against the general scan."""

from __future__ import annotations

import numpy as np
import pytest

from motionclean.io.text import scan_rows, scan_tokens


def _rows(rng, n_rows: int, n_cols: int, eol: bytes, spoil: str | None) -> bytes:
    tokens = [[b"%.*f" % (int(rng.integers(0, 6)), rng.normal(0, 90)) for _ in range(n_cols)]]
    tokens += [[t for t in row] for row in tokens * (n_rows - 1)]
    lines = [b" ".join(row) for row in tokens]
    at = int(rng.integers(0, n_rows))
    if spoil == "tab":
        lines[at] = lines[at].replace(b" ", b"\t", 1)
    elif spoil == "two spaces":
        lines[at] = lines[at].replace(b" ", b"  ", 1)
    elif spoil == "trailing space":
        lines[at] += b" "
    elif spoil == "leading space":
        lines[at] = b" " + lines[at]
    elif spoil == "blank line":
        lines.insert(at, b"")
    elif spoil == "control byte":
        lines[at] = lines[at][:3] + b"\x01" + lines[at][3:]
    elif spoil == "other line end":
        lines[at] += b"\r" if eol == b"\n" else b""
    text = eol.join(lines)
    return text + (b"\r" if eol == b"\r\n" and rng.random() < 0.5 else b"")


SPOILS = [
    None,
    "tab",
    "two spaces",
    "trailing space",
    "leading space",
    "blank line",
    "control byte",
    "other line end",
]


@pytest.mark.parametrize("eol", [b"\n", b"\r\n"])
@pytest.mark.parametrize("spoil", SPOILS)
def test_scan_rows_is_the_token_scan_or_declines(eol, spoil):
    """Whatever the layout, the fast scan finds the same tokens or leaves the rows to the
    general scan; rows in the exporters' layout it always scans."""
    rng = np.random.default_rng(len(SPOILS) * len(eol) + SPOILS.index(spoil))
    for n_rows, n_cols in [(1, 1), (1, 7), (5, 1), (40, 13), (300, 96)]:
        text = _rows(rng, n_rows, n_cols, eol, spoil)
        buf = np.frombuffer(text, dtype=np.uint8)
        found = scan_rows(buf, n_rows, n_cols)
        starts, ends = scan_tokens(buf)
        if found is None:
            assert spoil is not None or eol == b"\r\n" and not text.endswith(b"\r")
            continue
        np.testing.assert_array_equal(found[0], starts)
        np.testing.assert_array_equal(found[1], ends)
        assert found[0].dtype == starts.dtype
