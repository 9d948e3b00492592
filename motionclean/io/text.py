"""Vectorised text helpers shared by the BVH and CSV formats.

Tokens are found by a byte scan (no Python loop per value), decimal numbers are converted
with the same correctly rounded result as ``float``, and ``%.6f`` fields are formatted and
spliced into the original bytes so that everything not changed keeps its exact text.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Callable, Iterator
from typing import Protocol

import numpy as np

from ..core.checks import MAX_MAGNITUDE
from ..core.errors import MotionError
from ..core.motion import Motion
from ..core.threads import in_parts, run_parts, thread_count


def start_time(motion: Motion) -> float:
    """Seconds at the clip's first frame as its file stated them (the first time of a
    CSV's or OpenSim file's time column: a trial cut from 0.4 s on starts there), 0 for
    a source without times. Writers of timed formats count their times from it."""
    return float(getattr(motion.source, "start_time", 0.0))


#: The cells of a slice of rows as ``(buffer, starts, lengths)``, for ``Cells.add``.
RowCells = Callable[[slice], tuple[np.ndarray, np.ndarray, np.ndarray]]


def read_times(motion: Motion) -> RowCells | None:
    """The time cells of the file the clip was read from (a channel CSV's or OpenSim
    file's: its source's ``time_cells``, the frame time read and the ``(F,)`` byte ranges),
    by slices of rows, where they still give its frames (as many, as far apart); else None.
    Writers of timed formats keep them (``0.01666667``, not ``0.0166666666722``)."""
    src = motion.source
    cells = getattr(src, "time_cells", None)
    if cells is None or cells[1].size != motion.n_frames or cells[0] != motion.frame_time:
        return None
    _, starts, ends = cells
    raw = sliceable(src.raw)

    def texts(rows: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        first, last = starts[rows], ends[rows]
        low, high = int(first.min()), int(last.max())
        return np.frombuffer(raw[low:high], np.uint8), first - low, last - first

    return texts


def check_finite(motion: Motion, values: np.ndarray, widths=None) -> None:
    """Refuse to write NaN or inf: name the first joint and frame that has one.

    ``values`` is ``(F, K)`` with ``widths[j]`` columns per joint (default: its channels).
    """
    bad = ~np.isfinite(values)
    if bad.any():
        frame, column = np.argwhere(bad)[0]
        widths = [len(c) for c in motion.channels] if widths is None else widths
        joint = np.searchsorted(np.cumsum(widths), column, side="right")
        raise MotionError(
            f"cannot write: joint {motion.names[joint]!r} has a non-finite value at frame {frame}"
        )


#: Work on arrays in pieces of this many items (or bytes) so temporaries stay in cache.
_CHUNK_ITEMS = 32768
_CHUNK_BYTES = 131072
#: Items (or bytes) per part run on a thread of its own (:mod:`motionclean.core.threads`); a
#: part's cell offsets and texts are its working set, as many at once as there are threads.
_PART_ITEMS = 4 * _CHUNK_ITEMS
_PART_BYTES = 32 * _CHUNK_BYTES
#: Decimal powers, exact in float64 up to 1e22.
_POW10_FLOAT = 10.0 ** np.arange(23)


#: Buffers at least this long get 64-bit offsets.
_INT32_LIMIT = 2**31 - 1


def scan_tokens(buf: np.ndarray, start: int = 0, separators: bytes = b"") -> tuple:
    """Byte offsets ``(starts, ends)`` of the tokens of ``buf[start:]``, two contiguous
    arrays.

    Tokens are runs of bytes that are neither ASCII whitespace nor one of ``separators``.
    Offsets are int32 for buffers under 2 GiB (half the memory of a long clip's offsets).
    """
    dtype = np.int32 if buf.size < _INT32_LIMIT else np.intp
    table = np.zeros(256, dtype=np.int8)  # 1: a byte between tokens
    table[[9, 10, 11, 12, 13, 32, *separators]] = 1

    def edges(span: slice) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """The token starts and ends in ``span`` (a token may begin before it)."""
        starts, ends = [], []
        before = table[buf[span.start - 1]] if span.start > start else np.int8(1)
        parity = 0 if before else 1  # inside a token: the first edge is an end
        for at in range(span.start, span.stop, _CHUNK_BYTES):
            gap = table.take(buf[at : min(at + _CHUNK_BYTES, span.stop)])
            found = (np.flatnonzero(np.diff(gap, prepend=before)) + at).astype(dtype)
            starts.append(found[parity::2])
            ends.append(found[1 - parity :: 2])
            parity = (parity + found.size) % 2
            before = gap[-1]
        return starts, ends

    parts = run_parts(edges, in_parts(buf.size, _PART_BYTES, start))
    starts = [s for part, _ in parts for s in part]
    ends = [e for _, part in parts for e in part]
    if buf.size > start and table[buf[-1]] == 0:  # a token runs to the end of the buffer
        ends.append(np.array([buf.size], dtype=dtype))
    empty = np.zeros(0, dtype=dtype)
    return np.concatenate(starts or [empty]), np.concatenate(ends or [empty])


def scan_rows(buf: np.ndarray, n_rows: int, n_cols: int) -> tuple | None:
    """:func:`scan_tokens` of ``buf`` when it is ``n_rows`` lines of ``n_cols`` tokens in
    the layout exporters write (one space between tokens, every line but the last ended by
    the same LF or CRLF, the last by nothing after LFs or by its CR after CRLFs), else
    None: one pass for the bytes up to the space, one reshape and a check of the bytes
    found."""
    if n_rows < 1 or n_cols < 1:
        return None
    dtype = np.int32 if buf.size < _INT32_LIMIT else np.intp
    found = [  # spaces, line ends, any control byte (in chunks: small temporaries)
        (np.flatnonzero(buf[at : at + _CHUNK_BYTES] <= 32) + at).astype(dtype)
        for at in range(0, buf.size, _CHUNK_BYTES)
    ]
    found.append(np.array([buf.size], dtype=dtype))  # the last line's end
    # n_cols or n_cols + 1 a line
    width = sum(part.size for part in found) - n_rows * n_cols
    if width not in (0, n_rows):
        return None
    width = n_cols + width // n_rows
    ends: np.ndarray = np.concatenate(found)
    grid = ends.reshape(n_rows, width)
    spaces = buf.take(grid[:, : n_cols - 1]) == 32
    if width == n_cols:  # LF
        line_end = buf.take(grid[:-1, -1]) == 10
        starts = np.empty_like(ends)
        starts[0], starts[1:] = 0, ends[:-1] + 1
    else:  # CRLF: the CR ends the last token, the LF follows it
        line_end = (buf.take(grid[:, -2]) == 13).all() and (buf.take(grid[:-1, -1]) == 10).all()
        line_end &= bool((grid[:, -1] == grid[:, -2] + 1).all())
        starts = np.empty_like(grid)
        starts[:, 1:] = grid[:, :-1] + 1
        starts[0, 0] = 0
        starts[1:, 0] = grid[:-1, -1] + 1
        starts, ends = starts[:, :n_cols].ravel(), grid[:, :n_cols].ravel()
    if not (spaces.all() and np.all(line_end) and (ends > starts).all()):
        return None
    return starts, ends


def line_ends(buf: np.ndarray, start: int = 0) -> np.ndarray:
    """Offsets of the LF bytes of ``buf[start:]`` (parts run on threads)."""

    def found(span: slice) -> np.ndarray:
        return np.flatnonzero(buf[span] == 10) + span.start

    parts = run_parts(found, in_parts(buf.size, _PART_BYTES, start))
    return np.concatenate(parts) if parts else np.zeros(0, dtype=np.intp)


#: Byte classes for :func:`scan_cells`: 1 a line end, 2 a space or tab, 3 CR.
_CELL_CLASS = np.zeros(256, dtype=np.uint8)
_CELL_CLASS[10] = 1
_CELL_CLASS[[9, 11, 12, 32]] = 2
_CELL_CLASS[13] = 3


def scan_cells(buf: np.ndarray, start: int = 0, separator: int = 44) -> tuple:
    """The cells of the lines of ``buf[start:]`` split at ``separator`` (a byte, default
    comma), empty cells included.

    Returns ``(starts, ends, tokens, line_starts)``: per cell in file order, the byte
    range of its text without the surrounding whitespace (for an empty cell, the empty
    range just after the separator or line start before it) and its number of tokens (0:
    an empty cell, 2 or more: several values in one cell, see :func:`scan_tokens`); per
    line (from the one at ``start``), the index of its first cell. A line of ``n``
    separators has ``n + 1`` cells; a blank line has one empty cell.
    """
    table = _CELL_CLASS.copy()
    table[separator] = 1
    seps, n_spaces, n_returns = [], 0, 0
    for at in range(start, buf.size, _CHUNK_BYTES):
        kind = table.take(buf[at : at + _CHUNK_BYTES])
        seps.append(np.flatnonzero(kind == 1) + at)
        if kind.max(initial=0) >= 2:  # whitespace: rare in machine-written CSV
            n_spaces += int(np.count_nonzero(kind == 2))
            n_returns += int(np.count_nonzero(kind == 3))
    boundaries = np.concatenate(seps) if seps else np.zeros(0, dtype=np.intp)
    at_newline = buf[boundaries] == 10
    before_newline = np.flatnonzero(at_newline)  # the cells that end at a LF
    line_starts = np.concatenate([[0], before_newline + 1])
    starts = np.empty(boundaries.size + 1, dtype=np.intp)
    starts[0] = start
    starts[1:] = boundaries + 1
    ends = np.empty_like(starts)
    ends[:-1] = boundaries
    ends[-1] = buf.size
    newlines = boundaries[before_newline]
    crlf = before_newline[(newlines > start) & (buf[np.maximum(newlines - 1, 0)] == 13)]
    if n_spaces == 0 and n_returns == crlf.size:
        # No whitespace but CR before LF: a cell is the bytes between its separators.
        ends[crlf] -= 1
        return starts, ends, (ends > starts).view(np.int8), line_starts
    token_starts, token_ends = scan_tokens(buf, start, bytes([separator]))
    cell_of_token = np.searchsorted(boundaries, token_starts)
    tokens = np.bincount(cell_of_token, minlength=boundaries.size + 1)
    first = np.cumsum(tokens) - tokens  # index of each cell's first token
    ends[:] = starts  # an empty cell: just after the separator before it
    filled = np.flatnonzero(tokens)
    starts[filled] = token_starts[first[filled]]
    ends[filled] = token_ends[first[filled] + tokens[filled] - 1]
    return starts, ends, tokens, line_starts


def parse_numbers(
    buf: np.ndarray, starts: np.ndarray, ends: np.ndarray, index=None, limit: float = math.inf
):
    """Convert the tokens ``buf[starts[i]:ends[i]]`` to float64, exactly like ``float``.

    Plain decimals (optional sign, digits with at most one point, at most 15 digits) are
    converted in bulk, one character column at a time across all tokens, as
    ``mantissa / 10**k``: both are exact in float64, so the one division is correctly
    rounded, i.e. bit-identical to ``float``. Anything else (exponents, longer mantissas)
    goes through ``float`` one token at a time. Returns ``(values, bad)`` with ``bad`` the
    index of the first token that is not a finite number of magnitude at most ``limit``
    (``-1`` when all are). With ``index`` (sorted ints), only the tokens ``index[i]`` are
    converted, in that order (gathered chunk by chunk, so no full copy of the offsets is
    made). Parts of the tokens run on threads (:mod:`motionclean.core.threads`).
    """
    n = starts.size if index is None else index.size
    values = np.empty(n)

    def convert(span: slice) -> list[np.ndarray]:
        """Convert the plain tokens of ``span``; return the indices of the others."""
        others = []
        for at in range(span.start, span.stop, _CHUNK_ITEMS):  # chunks stay in cache
            part = slice(at, min(at + _CHUNK_ITEMS, span.stop))
            if index is None:
                found, simple = _parse_plain(buf, starts[part], ends[part])
            else:
                chosen = index[part]
                found, simple = _parse_plain(buf, starts.take(chosen), ends.take(chosen))
            values[part] = found
            simple &= np.abs(found) <= limit
            if not simple.all():
                others.append(np.flatnonzero(~simple) + at)
        return others

    others = [i for part in run_parts(convert, in_parts(n, _PART_ITEMS)) for i in part]
    bad = -1
    for i in np.concatenate(others).tolist() if others else []:
        k = i if index is None else int(index[i])
        token = buf[starts[k] : ends[k]].tobytes()
        try:
            value = float(token) if b"_" not in token else math.nan
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and abs(value) <= limit):
            bad = i
            break
        values[i] = value
    return values, bad


def parse_values(buf: np.ndarray, starts: np.ndarray, ends: np.ndarray, index=None):
    """:func:`parse_numbers` for a clip's values: a token beyond :data:`MAX_MAGNITUDE` is
    bad too."""
    return parse_numbers(buf, starts, ends, index, limit=MAX_MAGNITUDE)


def _parse_plain(buf: np.ndarray, starts: np.ndarray, ends: np.ndarray):
    """Values of the plain decimal tokens and a mask of which tokens are plain decimals.

    One pass per character column (at most 17) across all tokens: digits build the
    mantissa, a point is counted and its column kept."""
    length = ends - starts
    mantissa = np.zeros(starts.size)  # exact: integers below 2**53
    n_digits = np.zeros(starts.size, dtype=np.int8)
    n_dots = np.zeros(starts.size, dtype=np.int8)
    dot_column = np.zeros(starts.size, dtype=np.int8)
    for column in range(int(min(length.max(), 17))):
        digit = buf.take(starts + column, mode="clip") - np.uint8(48)  # "." becomes 254
        inside = length > column
        is_digit = digit < 10
        is_digit &= inside
        is_dot = digit == np.uint8(254)
        is_dot &= inside
        mantissa *= np.where(is_digit, 10.0, 1.0)
        mantissa += digit * is_digit
        n_digits += is_digit
        n_dots += is_dot
        np.copyto(dot_column, column, where=is_dot)
    lead = buf[starts]
    signed = (lead == 45) | (lead == 43)
    simple = (
        (n_digits >= 1) & (n_digits <= 15) & (n_dots <= 1) & (n_digits + n_dots + signed == length)
    )
    decimals = np.where(simple & (n_dots == 1), length - 1 - dot_column, 0)
    values = mantissa / _POW10_FLOAT[decimals]
    values[lead == 45] *= -1.0
    return values, simple


#: A number as capture files write it: ASCII digits with an optional sign, point and
#: exponent, or inf / nan (then refused as not finite). ``float`` also takes ``1_000``, digits
#: of any script (``١٢٠``) and surrounding whitespace, none of which is a number here.
ASCII_NUMBER = re.compile(
    r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan)",
    re.ASCII | re.IGNORECASE,
)


def ascii_digits(token: str) -> bool:
    """A non-negative integer in ASCII digits (``str.isdigit`` also takes '²' and '٣',
    which ``int`` refuses)."""
    return token.isascii() and token.isdigit()


def stated_count(text: str | None) -> int | None:
    """A header's count (``Frames:``, ``nRows``, ``Total Exported Frames``) as a number:
    ASCII digits, spaces around them allowed; None for anything else or no text."""
    token = "" if text is None else text.strip()
    return int(token) if ascii_digits(token) else None


def ascii_float(text: str) -> float:
    """``float(text)`` for a text that is all :data:`ASCII_NUMBER`; ValueError otherwise."""
    if not ASCII_NUMBER.fullmatch(text):
        raise ValueError(f"not a number: {text[:40]!r}")
    return float(text)


def bad_number_message(what: str, token: bytes) -> str:
    text = token.decode("utf-8", "replace")[:40]
    try:
        value = ascii_float(text)
    except ValueError:
        return f"{what} is not a number: {text!r}"
    if math.isfinite(value):
        return f"{what} is out of range (more than {MAX_MAGNITUDE:g} in size): {text!r}"
    return f"{what} is not finite: {text!r}"


#: ``%.6f`` texts are made in fields of 4-byte lanes (native uint32 holding the bytes in
#: memory order) taken from digit tables, NUL where a field has no character; removing the
#: NULs joins the texts. A field is a sign lane (``-`` or NUL, then the integer digits above
#: the 4-digit groups, leading zeros as NUL), ``k`` lanes of 4 integer digits, a ``.ddd``
#: lane and a ``ddd`` + separator lane.
_LANE = 4
#: Integer 4-digit groups per field for values below each bound (``k`` = 0 .. 3).
_GROUP_BOUNDS = (1e3, 1e7, 1e11, 9e12)
#: Printed by numpy at most this magnitude: ``|v| * 1e6`` and its exact rounding fit int64.
_FIXED6_LIMIT = _GROUP_BOUNDS[-1]
#: 2**52: from here on ``|v| * 1e6`` in float64 is a whole number.
_WHOLE_PRODUCT = 2.0**52
#: Veltkamp's splitter for float64 (2**27 + 1): splits a value into two 26-bit halves.
_SPLITTER = 134217729.0


def _lanes(texts: list[bytes]) -> np.ndarray:
    return np.frombuffer(b"".join(texts), dtype=np.uint32)


def _digits(number: int, width: int, lead: bool, last: bool) -> bytes:
    """``number`` in ``width`` digits; with ``lead`` its leading zeros are NUL (all of them
    for 0 unless ``last``: then a single ``0`` is kept)."""
    text = b"%0*d" % (width, number)
    if lead:
        shown = text.lstrip(b"0") or (b"0" if last else b"")
        text = shown.rjust(width, b"\0")
    return text


#: 4-digit groups (10,000 entries each): full digits, leading zeros as NUL (0 is all NUL),
#: leading zeros as NUL with the units digit always shown.
_GROUPS = _lanes(
    [
        _digits(i, 4, lead, last)
        for lead, last in ((False, False), (True, False), (True, True))
        for i in range(10_000)
    ]
)
#: Sign lanes (1,000 entries each): NUL or ``-``, then 3 digits with leading zeros as NUL;
#: for the "units" tables the last digit is always shown.
_SIGNS = _lanes(
    [
        sign + _digits(i, 3, True, last)
        for last in (False, True)
        for sign in (b"\0", b"-")
        for i in range(1000)
    ]
)
#: ``.ddd``: a point and the first three decimals.
_POINT_DECIMALS = _lanes([b".%03d" % i for i in range(1000)])


@functools.cache
def _last_decimals(sep: int) -> np.ndarray:
    """``ddd`` + the byte ``sep`` (NUL: none): the last three decimals and a separator."""
    return _lanes([b"%03d" % i + bytes([sep]) for i in range(1000)])


def _microunits(v: np.ndarray) -> np.ndarray:
    """``|v| * 10**6`` rounded half to even, exactly as ``%.6f`` rounds (int64), for
    ``|v| < _FIXED6_LIMIT``.

    The float product ``x`` is within half an ulp of the exact one, so below 2**52 its
    nearest integer is the answer unless ``x`` is exactly half way; there, and above 2**52
    (where ``x`` is whole), the product's rounding error (exact, from Dekker's product with
    Veltkamp's split: 1e6 has 14 significant bits) decides."""
    a = np.abs(v).ravel()
    x = a * 1e6
    n = np.rint(x)
    out = n.astype(np.int64).reshape(v.shape)
    whole = x.size > 0 and x.max() >= _WHOLE_PRODUCT
    np.subtract(x, n, out=n)
    if not (whole or (x.size > 0 and np.abs(n, out=n).max() == 0.5)):
        return out  # (the common case: two maxima instead of a mask)
    at = np.flatnonzero((np.abs(n) == 0.5) | (x >= _WHOLE_PRODUCT))
    a, x, n = a[at], x[at], out.reshape(-1)[at]
    split = a * _SPLITTER
    high = split - (split - a)
    error = (high * 1e6 - x) + (a - high) * 1e6  # a * 1e6 == x + error, exactly
    half = x - np.rint(x)
    n += (half == 0.5) & (error > 0.0)
    n -= (half == -0.5) & (error < 0.0)
    whole = x >= _WHOLE_PRODUCT  # x is a whole number and error picks the neighbour
    below = np.floor(error)
    rest = error - below
    step = below.astype(np.int64)
    step += (rest > 0.5) | ((rest == 0.5) & ((n + step) % 2 == 1))
    n[whole] += step[whole]
    out.reshape(-1)[at] = n
    return out


def _fill_fixed6(v: np.ndarray, n: np.ndarray, groups: int, out: np.ndarray, sep: int) -> None:
    """Write the ``%.6f`` fields of ``v`` (any shape) into ``out`` (``v.shape`` + lanes:
    ``groups + 3``), given ``n`` = :func:`_microunits` of ``v``; the last lane ends with
    the byte ``sep``."""
    whole = n // 1_000_000
    decimals = (n - whole * 1_000_000).astype(np.int32)
    if groups == 0:
        head = whole.astype(np.int32) + 1000 * (2 + ((v < 0) & (n > 0)))
    else:
        rest = whole
        lanes = []
        for _ in range(groups):
            above = rest // 10_000
            lanes.append(rest - above * 10_000)
            rest = above
        head = rest.astype(np.int32)
        shown = head > 0  # a higher digit is not zero
        for lane, group in enumerate(reversed(lanes), start=1):
            kind = np.where(shown, 0, 1 if lane < groups else 2)
            out[..., lane] = _GROUPS.take(group.astype(np.int32) + 10_000 * kind)
            shown |= group > 0
        head += 1000 * ((v < 0) & (n > 0))
    out[..., 0] = _SIGNS.take(head)
    first = decimals // 1000
    out[..., groups + 1] = _POINT_DECIMALS.take(first)
    out[..., groups + 2] = _last_decimals(sep).take(decimals - first * 1000)


def format_fixed6(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``%.6f`` text of each value, as ``(buffer, starts, lengths)`` (see :func:`gather`).

    Exactly what ``b"%.6f" % value`` prints (:func:`_microunits`), except that a value
    that prints as zero is written ``0.000000``, never ``-0.000000``. Vectorised below
    :data:`_FIXED6_LIMIT` (readers refuse values over 1e12); larger values are printed by
    Python.
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    texts, lengths = [], np.empty(v.size, dtype=np.int64)
    large = ~(np.abs(v) < _FIXED6_LIMIT)
    for at in range(0, v.size, _CHUNK_ITEMS):  # chunks stay in cache
        part = slice(at, at + _CHUNK_ITEMS)
        chunk = np.where(large[part], 0.0, v[part])
        text, lengths[part] = _fixed6_chunk(chunk)
        texts.append(text)
    starts = np.cumsum(lengths) - lengths
    slow = np.flatnonzero(large)
    if slow.size:  # printed by Python after the others (their zero texts stay unused)
        extra = [_fixed6(x) for x in v[slow].tolist()]
        lengths[slow] = [len(t) for t in extra]
        starts[slow] = sum(map(len, texts)) + np.cumsum(lengths[slow]) - lengths[slow]
        texts += extra
    chars = np.frombuffer(b"".join(texts), dtype=np.uint8)
    return chars, starts, lengths


def _fixed6_chunk(v: np.ndarray) -> tuple[bytes, np.ndarray]:
    """The joined ``%.6f`` texts of ``v`` (``|v| <`` :data:`_FIXED6_LIMIT`) and their
    lengths."""
    n = _microunits(v)
    groups = _groups(n)
    field = np.empty((v.size, groups + 3), dtype=np.uint32)
    _fill_fixed6(v, n, groups, field, 0)
    whole = n // 1_000_000
    lengths = ((v < 0) & (n > 0)).astype(np.int64)  # the sign
    lengths += 8  # a digit, the point, six decimals
    power = 10
    for _ in range(3 + 4 * groups - 1):
        lengths += whole >= power
        power *= 10
    return field.tobytes().translate(None, b"\0"), lengths


def fixed6_rows(
    values: np.ndarray, sep: bytes, eol: bytes, kept=None, last_eol: bool = True
) -> bytes | None:
    """Rows of ``(R, K)`` ``values`` as :func:`format_fixed6` texts joined by the byte
    ``sep``, each row ended by ``eol`` (the last one too unless ``last_eol`` is False),
    made as fields of digit-table lanes (no per-byte offsets).

    With ``kept`` = ``(source, starts, ends, mask)`` the cells where the ``(R, K)`` bool
    ``mask`` is True are the bytes ``source[starts:ends]`` instead. None when a value is
    :data:`_FIXED6_LIMIT` or more or a kept text longer than 27 bytes (use the general
    path: :func:`format_fixed6` and :func:`join_rows`).
    """
    n_rows, n_cols = values.shape
    if not (len(sep) == 1 and 0 < len(eol) <= _LANE and n_cols and sep != b"\0"):
        return None
    words = None if kept is None else _words(kept[0])
    out = []
    block = max(1, _CHUNK_ITEMS // n_cols)
    for at in range(0, n_rows, block):
        rows = slice(at, min(at + block, n_rows))
        shown = None if kept is None else (words, kept[1][rows], kept[2][rows], kept[3][rows])
        text = _fixed6_block(values[rows], sep[0], eol, shown, last_eol or rows.stop < n_rows)
        if text is None:
            return None
        out.append(text)
    return b"".join(out)


#: Lanes of a kept text in a field at most (27 bytes and the separator).
_MAX_LANES = 7
#: Masks keeping the first 0 .. 4 bytes of a lane.
_FIRST_BYTES = _lanes([b"\xff" * n + b"\0" * (_LANE - n) for n in range(_LANE + 1)])


def _words(source: np.ndarray) -> np.ndarray:
    """The 4-byte words of ``source`` at every byte offset ``s``, as ``words[(s % 4) * n +
    s // 4]`` (four copies of the bytes, each shifted by one; NUL past the end)."""
    n = source.size // _LANE + _MAX_LANES + 1
    padded = np.zeros(_LANE * n + _LANE, dtype=np.uint8)
    padded[: source.size] = source
    return np.concatenate(
        [padded[k : k + _LANE * n].view(np.uint32) for k in range(_LANE)]  # (copies: aligned)
    )


def _fixed6_block(values, sep: int, eol: bytes, kept, last_eol: bool) -> bytes | None:
    """:func:`fixed6_rows` of a block of rows; ``kept`` holds :func:`_words` of the source
    instead of its bytes."""
    mask = None if kept is None or not kept[3].any() else kept[3]
    v = values if mask is None else np.where(mask, 0.0, values)
    if v.size and not np.abs(v).max() < _FIXED6_LIMIT:
        return None
    n = _microunits(v)
    lanes = _groups(n) + 3
    if mask is not None:
        words, starts, ends, _ = kept
        at = np.flatnonzero(mask)  # kept cells, row-major
        first = starts.ravel().take(at)
        length = ends.ravel().take(at) - first
        lanes = max(lanes, -(-(int(length.max()) + 1) // _LANE))
        if lanes > _MAX_LANES:
            return None
    n_rows, n_cols = v.shape
    width = lanes * _LANE
    field = np.empty((n_rows, n_cols * lanes + 1), dtype=np.uint32)  # every lane written
    cells = field[:, :-1].reshape(n_rows, n_cols, lanes)
    _fill_fixed6(v, n, lanes - 3, cells, sep)
    chars = field.view(np.uint8)
    chars[:, n_cols * width - 1] = 0  # no separator after the last cell
    field[:, -1] = np.frombuffer(eol.ljust(_LANE, b"\0"), dtype=np.uint32)[0]
    if not last_eol:
        field[-1, -1] = 0
    if mask is not None:  # each kept cell's text a lane at a time, then its separator
        row, col = np.divmod(at, n_cols)
        place = row * field.shape[1] + col * lanes
        word = (first % _LANE) * (words.size // _LANE) + first // _LANE
        ends_row = col == n_cols - 1
        after = _lanes([b"\0\0\0" + bytes([sep])])[0]  # the separator's lane (uint32)
        for lane in range(lanes):
            text = words.take(word + lane)
            text &= _FIRST_BYTES.take(np.clip(length - _LANE * lane, 0, _LANE))
            if lane == lanes - 1:  # (uint32 on both sides: numpy 1 widens a bare 0)
                text |= np.where(ends_row, np.uint32(0), after)
            field.put(place + lane, text)
    return field.tobytes().translate(None, b"\0")


def _groups(n: np.ndarray) -> int:
    """4-digit integer groups a field needs for the :func:`_microunits` ``n``."""
    largest = int(n.max(initial=0))
    return next(k for k, bound in enumerate(_GROUP_BOUNDS) if largest < bound * 1e6)


def _fixed6(x: float) -> bytes:
    text = b"%.6f" % x
    return text[1:] if text.startswith(b"-") and text.strip(b"-0.") == b"" else text


def _gather(buf: np.ndarray, starts: np.ndarray, lengths: np.ndarray) -> bytes:
    """Concatenate the non-empty pieces ``buf[starts[i] : starts[i] + lengths[i]]``."""
    out_ends = np.cumsum(lengths)
    dtype = np.int32 if buf.size < 2**31 and out_ends[-1] < 2**31 else np.int64
    # byte k of piece i comes from buf[starts[i] + k]: its output offset plus a shift
    index: np.ndarray = np.arange(int(out_ends[-1]), dtype=dtype)
    index += np.repeat((starts - (out_ends - lengths)).astype(dtype), lengths)
    return buf.take(index).tobytes()


def gather(buf: np.ndarray, starts: np.ndarray, lengths: np.ndarray) -> bytes:
    """The pieces ``buf[starts[i] : starts[i] + lengths[i]]``, joined."""
    lengths = np.asarray(lengths, dtype=np.int64).ravel()
    used = lengths > 0
    starts = np.asarray(starts, dtype=np.int64).ravel()[used]
    lengths = lengths[used]
    out = []
    for at in range(0, lengths.size, _CHUNK_ITEMS):  # chunks stay in cache
        part = slice(at, at + _CHUNK_ITEMS)
        out.append(_gather(buf, starts[part], lengths[part]))
    return b"".join(out)


class Bytes(Protocol):
    """Bytes, or a file's bytes read again when sliced (``io.files.FileBytes``)."""

    def __len__(self) -> int: ...

    def __getitem__(self, key: slice, /) -> bytes: ...


def sliceable(raw: Bytes) -> Bytes | memoryview:
    """``raw`` to take parts of without copies: a memoryview of bytes (a file's bytes on
    disk are read part by part anyway)."""
    return memoryview(raw) if isinstance(raw, bytes) else raw


def decimals_of(raw: Bytes, starts: np.ndarray, ends: np.ndarray) -> int | None:
    """The most digits after a decimal point among the numbers at ``starts`` to ``ends``
    ``(F, K)`` of ``raw``, read a block of rows at a time; None when none has a point or one
    has an exponent (no fixed-point layout to follow)."""
    whole = sliceable(raw)
    most = 0
    for rows in in_parts(starts.shape[0], ROW_BLOCK):
        first, last = starts[rows].ravel(), ends[rows].ravel()
        if not first.size:
            continue
        low = int(first.min())
        region = np.frombuffer(whole[low : int(last.max())], dtype=np.uint8)
        first, last = first - low, last - low
        if _inside(np.flatnonzero((region | 32) == ord("e")), first, last).any():
            return None
        dots = np.flatnonzero(region == ord("."))
        inside = _inside(dots, first, last)
        if inside.any():
            dot = dots[np.searchsorted(dots, first[inside])]
            most = max(most, int((last[inside] - dot - 1).max()))
    return most or None


def _inside(marks: np.ndarray, first: np.ndarray, last: np.ndarray) -> np.ndarray:
    """Per span ``first[i]:last[i]``, whether one of the sorted offsets ``marks`` is in it."""
    if not marks.size:
        return np.zeros(first.shape, dtype=bool)
    at = np.searchsorted(marks, first)
    return (at < marks.size) & (marks[np.minimum(at, marks.size - 1)] < last)


#: Significant digits a double holds without noise: more decimals than this are padding.
_PLAIN_DIGITS = 15


def format_decimals(values: np.ndarray, decimals: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each value in fixed point with ``decimals`` digits after the point, as ``(buffer,
    starts, lengths)`` (see :func:`gather`): ``%.*f`` (one C-level call), or, where so many
    digits pass a double's precision (:data:`_PLAIN_DIGITS`), its shortest round-trip
    digits padded with zeros (no float noise); a value that prints as zero has no sign,
    NaN is ``nan``."""
    v = np.asarray(values, dtype=np.float64).ravel()
    finite = np.abs(v[np.isfinite(v)])
    largest = float(finite.max()) if finite.size else 0.0
    whole_digits = max(math.floor(math.log10(largest)) + 1, 1) if largest else 1
    if decimals + whole_digits <= _PLAIN_DIGITS:
        pairs = [decimals, 0.0] * v.size
        pairs[1::2] = v.tolist()
        text = b" ".join([b"%.*f"] * v.size) % tuple(pairs)
    else:
        text = " ".join(_padded(d, decimals) for d in v.tolist()).encode()
    buf = np.frombuffer(text, dtype=np.uint8)
    starts, ends = scan_tokens(buf)
    digits = np.flatnonzero((buf >= ord("1")) & (buf <= ord("9")))
    signed_zero = (buf[starts] == ord("-")) & ~_inside(digits, starts, ends)
    return buf, starts + signed_zero, ends - starts - signed_zero


def _padded(value: float, decimals: int) -> str:
    """``value``'s shortest round-trip digits rounded to ``decimals`` places, in fixed point,
    padded with zeros to that many."""
    text = np.format_float_positional(value, precision=decimals, unique=True, trim="k")
    point = text.find(".")
    if point < 0:  # (nan)
        return text
    return text + "0" * (decimals - (len(text) - point - 1)) if decimals else text[:point]


def splice_cells(
    raw: Bytes,
    row_starts: np.ndarray,
    cells: Callable[[slice], tuple[np.ndarray, np.ndarray]],
    mask: np.ndarray,
    texts,
    start: int = 0,
    prefix: bytes = b"",
    rows_text: Callable[[slice, np.ndarray, np.ndarray, np.ndarray], bytes | None] | None = None,
) -> Iterator[bytes | memoryview]:
    """The pieces of ``prefix + raw[start:]`` (bytes to join or write in turn, made as they
    are asked for) with the cells of ``(F, C)`` rows (in file order, at or after ``start``)
    replaced where ``mask`` is True. ``row_starts`` (F,) is the byte offset of each row's
    first cell; ``cells(rows)`` gives ``(starts, ends)``, the ``(len, C)`` byte ranges of
    the cells of a slice of rows.

    ``texts(rows)`` (a slice of rows) returns ``chunk(a, b)``, which gives ``(buffer, starts,
    lengths)`` of the new texts of that part's replacements ``a`` to ``b - 1`` (row-major).
    ``rows_text(rows, source, starts, ends)``, when given, may make a part's rows itself
    (see :func:`fixed6_rows`): from the bytes ``source`` (uint8) of the part and the
    ``(len, C)`` cell ranges in them, the text from its first cell to its last, or None to
    splice the part the general way. Parts of rows run on threads, as many at a time as
    there are threads, and each slices only its own rows' bytes from ``raw`` and works on
    them in chunks: no array or text the size of the clip is made.
    """
    whole = sliceable(raw)
    n_rows = row_starts.size
    spans = in_parts(n_rows, max(1, _PART_ITEMS // max(1, mask.shape[1])))

    def spliced(rows: slice) -> list[bytes | memoryview]:
        """The output from the first cell of row ``rows.start`` (or ``start``) to the first
        cell of row ``rows.stop`` (or the end of ``raw``)."""
        low = start if rows.start == 0 else int(row_starts[rows.start])
        high = len(raw) if rows.stop == n_rows else int(row_starts[rows.stop])
        text = whole[low:high]
        chosen = mask[rows]
        if not chosen.any():
            return [text]
        source = np.frombuffer(text, dtype=np.uint8)
        row_cells = cells(rows)
        if rows_text is not None:
            starts, ends = row_cells[0] - low, row_cells[1] - low
            made = rows_text(rows, source, starts, ends)
            if made is not None:
                return [text[: starts[0, 0]], made, text[ends[-1, -1] :]]
        old_starts, old_ends = row_cells[0][chosen] - low, row_cells[1][chosen] - low
        chunk = texts(rows)
        out: list[bytes | memoryview] = []
        pos = 0
        for at in range(0, old_starts.size, _CHUNK_ITEMS):
            stop = min(at + _CHUNK_ITEMS, old_starts.size)
            kept_starts = np.empty(stop - at, dtype=np.int64)  # kept text before each one
            kept_starts[0], kept_starts[1:] = pos, old_ends[at : stop - 1]
            buf, new_starts, new_lengths = chunk(at, stop)
            out.append(
                _interleave(source, kept_starts, old_starts[at:stop], buf, new_starts, new_lengths)
            )
            pos = int(old_ends[stop - 1])
        out.append(text[pos:])
        return out

    yield prefix
    batch = thread_count()
    for first in range(0, len(spans), batch):
        for part in run_parts(spliced, spans[first : first + batch]):
            yield from part


def regular_rows(source: np.ndarray, starts: np.ndarray, ends: np.ndarray, sep: bytes):
    """The line end (LF or CRLF) between the ``(R, C)`` cells ``source[starts:ends]`` of
    consecutive rows when every row ends with that same one and the cells within a row are
    separated by the one byte ``sep`` (cells never hold ``sep``, CR or LF), else None (LF
    for a single row)."""
    if starts.size == 0 or not (starts[:, 1:] == ends[:, :-1] + 1).all():
        return None
    row_ends = ends[:-1, -1]
    eol = b"\n" if not row_ends.size else source[row_ends[0] : starts[1, 0]].tobytes()
    if eol not in (b"\n", b"\r\n") or not (starts[1:, 0] - row_ends == len(eol)).all():
        return None
    if not all((source[row_ends + k] == byte).all() for k, byte in enumerate(eol)):
        return None
    region = source[starts[0, 0] : ends[-1, -1]]
    spaces = np.count_nonzero(region == sep[0])
    return eol if spaces == starts.shape[0] * (starts.shape[1] - 1) else None


def _interleave(source, kept_starts, kept_ends, buf, new_starts, new_lengths) -> bytes:
    """``source[kept_starts[i]:kept_ends[i]]`` followed by new text ``i`` (of ``buf``), for
    every ``i``."""
    low, high = int(kept_starts[0]), int(kept_ends[-1])
    region = source[low:high]
    n = kept_starts.size
    pieces = np.empty(2 * n, dtype=np.int64)
    lengths = np.empty(2 * n, dtype=np.int64)
    pieces[0::2] = kept_starts - low
    lengths[0::2] = kept_ends - kept_starts
    pieces[1::2] = np.asarray(new_starts) + region.size
    lengths[1::2] = new_lengths
    used = lengths > 0
    if not used.any():
        return b""
    return _gather(np.concatenate([region, buf]), pieces[used], lengths[used])


#: Rows per piece when a table is written afresh (no clip-long arrays of cell texts).
ROW_BLOCK = 4096


def table_pieces(n_rows: int, cells, sep: bytes, eol: bytes, head: bytes = b"") -> Iterator[bytes]:
    """``head``, then the rows of a table written afresh, :data:`ROW_BLOCK` rows per piece,
    each made when it is asked for: ``cells(rows)`` gives ``(buffer, starts, lengths)`` of
    the ``(len, K)`` cells of a slice of rows (see :func:`join_rows`)."""
    yield head
    for rows in in_parts(n_rows, ROW_BLOCK):
        buf, starts, lengths = cells(rows)
        yield join_rows(buf, starts, lengths, sep, eol)


def join_rows(
    buf: np.ndarray, starts: np.ndarray, lengths: np.ndarray, sep: bytes, eol: bytes
) -> bytes:
    """Rows of ``(F, K)`` cells (pieces ``buf[starts : starts + lengths]``) joined by
    ``sep``, each row ended by ``eol``."""
    shape = starts.shape
    n_rows, n_cols = shape
    tail = buf.size
    both = np.concatenate([buf, np.frombuffer(sep + eol, dtype=np.uint8)])
    piece_starts = np.full((n_rows, 2 * n_cols), tail, dtype=np.int64)
    piece_lengths = np.full((n_rows, 2 * n_cols), len(sep), dtype=np.int64)
    piece_starts[:, ::2] = np.asarray(starts).reshape(shape)
    piece_lengths[:, ::2] = np.asarray(lengths).reshape(shape)
    piece_starts[:, -1], piece_lengths[:, -1] = tail + len(sep), len(eol)
    return gather(both, piece_starts, piece_lengths)
