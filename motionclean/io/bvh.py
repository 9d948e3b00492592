"""BVH read and write, with an exact identity round trip.

The HIERARCHY section is parsed line by line (it is small) and kept as bytes, so it is
written back byte for byte. The MOTION block is parsed with numpy in one pass: token
boundaries and per-line counts come from a vectorised scan of the bytes, values from a
vectorised decimal conversion (the same correctly rounded result as ``float``). Accepted:
any rotation order per joint, position channels on any joint, tabs and odd spacing, CRLF,
LF and mixed line endings, a UTF-8 byte-order mark, joint names with spaces or colons.

On write, values equal to the ones read (within 1e-9) keep the input's own text; changed
values are printed with six decimals (``%.6f``) in place of the old ones, so spacing, line
endings and every unchanged number stay as they were. An unchanged motion writes the input
bytes exactly.

The vectorised text helpers at the end of this module (:func:`scan_tokens`,
:func:`parse_numbers`, :func:`format_fixed6`, :func:`pack_texts`, :func:`gather`) are shared
with :mod:`motionclean.io.csv`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import MotionError
from ..motion import (
    KNOWN_CHANNELS,
    ROTATION_CHANNELS,
    UNCHANGED_TOLERANCE,
    Motion,
)

BOM = b"\xef\xbb\xbf"


@dataclass(frozen=True, eq=False)
class BvhText:
    """The bytes of a BVH file that a writer reuses verbatim.

    ``starts``/``ends`` are the ``(F, C)`` byte offsets in ``raw`` of each frame value's
    text, in the order of ``Motion.source_values``.
    """

    raw: bytes  # the whole file as read
    hierarchy: bytes  # everything before the MOTION line (BOM included)
    motion_header: bytes  # MOTION, Frames and Frame Time lines with their line endings
    body_start: int  # offset of the first byte after the Frame Time line
    starts: np.ndarray  # (F, C) int64
    ends: np.ndarray  # (F, C) int64
    frame_time: float  # the Frame Time value as read
    eol: bytes  # line ending of the MOTION header, used for regenerated headers

    @property
    def n_frames(self) -> int:
        return int(self.starts.shape[0])

    @classmethod
    def hierarchy_only(cls, text: BvhText) -> BvhText:
        """The hierarchy of ``text`` without its frames (a skeleton template)."""
        empty = np.zeros((0, text.starts.shape[1]), dtype=np.int64)
        return cls(b"", text.hierarchy, b"", 0, empty, empty, text.frame_time, text.eol)


def _fail(message: str, path, line: int | None = None):
    raise MotionError(message, path, None if line is None else int(line))


def _decode(raw: bytes, path, line: int) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        _fail("not a text file (bytes that are not UTF-8)", path, line)


def _number(token: str, what: str, path, line: int) -> float:
    try:
        value = float(token)
    except ValueError:
        _fail(f"{what} is not a number: {token[:40]!r}", path, line)
    if not math.isfinite(value):
        _fail(f"{what} is not finite: {token[:40]!r}", path, line)
    return value


class _Lines:
    """Iterates the lines of a byte string with 1-based numbers and byte offsets."""

    def __init__(self, data: bytes, path):
        self.data, self.path = data, path
        self.pos, self.number = 0, 0

    def next(self) -> tuple[int, int, bytes] | None:
        """``(line number, start offset, line bytes)`` of the next line, or None at EOF."""
        if self.pos >= len(self.data):
            return None
        start = self.pos
        end = self.data.find(b"\n", start)
        self.pos = len(self.data) if end < 0 else end + 1
        self.number += 1
        return self.number, start, self.data[start : self.pos]

    def next_tokens(self) -> tuple[int, int, list[str], str] | None:
        """Next non-blank line as ``(number, start, tokens, stripped text)``."""
        while (item := self.next()) is not None:
            number, start, raw = item
            text = _decode(raw, self.path, number).strip()
            if text:
                return number, start, text.split(), text
        return None


def _check_channels(listed: list[str], path, number: int) -> None:
    for name in listed:
        if name not in KNOWN_CHANNELS:
            _fail(f"unknown channel {name[:40]!r} (expected X/Y/Z position or rotation)",
                  path, number)
    if len(set(listed)) != len(listed):
        _fail("CHANNELS lists a channel twice", path, number)
    rotations = sum(name in ROTATION_CHANNELS for name in listed)
    if rotations not in (0, 3):
        _fail(f"CHANNELS has {rotations} rotation channels; a joint needs all three "
              "(Xrotation, Yrotation, Zrotation) or none", path, number)


def _parse_hierarchy(lines: _Lines, path):
    """Parse HIERARCHY up to the MOTION line; return the skeleton and MOTION's offset."""
    first = lines.next_tokens()
    if first is None:
        _fail("empty file", path)
    number, _, tokens, _ = first
    if tokens[0] != "HIERARCHY":
        _fail(f"not a BVH file: expected HIERARCHY, found {tokens[0][:40]!r}", path, number)

    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float] | None] = []
    channels: list[tuple[str, ...]] = []
    end_sites: dict[int, np.ndarray] = {}
    stack: list[tuple[str, int]] = []  # ("joint", index) or ("end", parent index)
    expect_open = False

    while True:
        item = lines.next_tokens()
        if item is None:
            if stack or not names:
                _fail("truncated hierarchy: the file ends inside the HIERARCHY section", path,
                      lines.number)
            _fail("missing MOTION section", path, lines.number)
        number, start, tokens, text = item
        keyword = tokens[0]
        if expect_open and keyword != "{":
            _fail(f"expected '{{' after the joint header, found {keyword[:40]!r}", path, number)
        if keyword in ("ROOT", "JOINT"):
            name = text[len(keyword):].strip()
            if not name:
                _fail(f"{keyword} without a name", path, number)
            if keyword == "ROOT" and stack:
                _fail("ROOT inside another joint", path, number)
            if keyword == "JOINT" and (not stack or stack[-1][0] != "joint"):
                _fail("JOINT outside a joint", path, number)
            parents.append(stack[-1][1] if stack else -1)
            names.append(name)
            offsets.append(None)
            channels.append(())
            stack.append(("joint", len(names) - 1))
            expect_open = True
        elif keyword == "End":
            if not stack or stack[-1][0] != "joint":
                _fail("End Site outside a joint", path, number)
            stack.append(("end", stack[-1][1]))
            expect_open = True
        elif keyword == "{":
            if not expect_open or len(tokens) > 1:
                _fail("unexpected '{'", path, number)
            expect_open = False
        elif keyword == "}":
            if not stack:
                _fail("unbalanced '}'", path, number)
            kind, index = stack.pop()
            if kind == "joint" and offsets[index] is None:
                _fail(f"joint {names[index]!r} has no OFFSET", path, number)
        elif keyword == "OFFSET":
            if not stack:
                _fail("OFFSET outside a joint", path, number)
            if len(tokens) != 4:
                _fail(f"OFFSET needs 3 numbers, found {len(tokens) - 1}", path, number)
            offset = [_number(t, "OFFSET value", path, number) for t in tokens[1:]]
            kind, index = stack[-1]
            if kind == "end":
                end_sites[index] = np.array(offset)
            else:
                offsets[index] = offset
        elif keyword == "CHANNELS":
            if not stack or stack[-1][0] != "joint":
                _fail("CHANNELS outside a joint", path, number)
            if len(tokens) < 2 or not tokens[1].isdigit():
                _fail("CHANNELS needs a count followed by channel names", path, number)
            count, listed = int(tokens[1]), tokens[2:]
            if count != len(listed):
                _fail(f"CHANNELS says {count} but names {len(listed)}", path, number)
            _check_channels(listed, path, number)
            channels[stack[-1][1]] = tuple(listed)
        elif keyword == "MOTION":
            if stack:
                _fail("truncated hierarchy: MOTION before the joints are closed", path, number)
            if not names:
                _fail("no joints before MOTION", path, number)
            if len(tokens) > 1:
                _fail("unexpected text after MOTION", path, number)
            return names, parents, offsets, channels, end_sites, start
        else:
            _fail(f"unexpected {keyword[:40]!r} in HIERARCHY", path, number)


def _parse_motion_header(lines: _Lines, path) -> tuple[int, float]:
    item = lines.next_tokens()
    if item is None or item[2][0] != "Frames:" or len(item[2]) != 2:
        _fail("expected 'Frames: N' after MOTION", path, lines.number)
    number, _, tokens, _ = item
    if not tokens[1].isdigit():
        _fail(f"frame count is not a non-negative integer: {tokens[1][:40]!r}", path, number)
    n_frames = int(tokens[1])
    item = lines.next_tokens()
    if item is None or item[2][:2] != ["Frame", "Time:"] or len(item[2]) != 3:
        _fail("expected 'Frame Time: SECONDS' after Frames", path, lines.number)
    number, _, tokens, _ = item
    frame_time = _number(tokens[2], "Frame Time", path, number)
    if frame_time <= 0:
        _fail(f"Frame Time must be positive, got {tokens[2][:40]}", path, number)
    return n_frames, frame_time


def _parse_rows(buf: np.ndarray, body_start: int, n_frames: int, n_channels: int,
                first_line: int, path):
    """Parse the frame rows: ``(F, C)`` values and the ``(F, C)`` token starts and ends."""
    starts, ends = scan_tokens(buf, body_start)
    newlines = np.flatnonzero(buf[body_start:] == 10) + body_start
    counts = np.diff(np.searchsorted(starts, newlines), prepend=0, append=starts.size)
    row_lines = np.flatnonzero(counts)
    bad = np.flatnonzero(counts[row_lines] != n_channels)
    if bad.size and bad[0] < n_frames:
        line = row_lines[bad[0]]
        _fail(f"frame row has {counts[line]} values, expected {n_channels}", path,
              first_line + line)
    if row_lines.size < n_frames:
        _fail(f"the file ends after {row_lines.size} frame rows but Frames: says {n_frames}",
              path, first_line + (row_lines[-1] if row_lines.size else -1))
    if row_lines.size > n_frames:
        _fail(f"more frame rows than Frames: {n_frames}", path, first_line + row_lines[n_frames])
    values, bad_token = parse_numbers(buf, starts, ends)
    if bad_token >= 0:
        token = buf[starts[bad_token]:ends[bad_token]].tobytes()
        _fail(_bad_number_message("frame value", token), path,
              first_line + np.searchsorted(newlines, starts[bad_token]))
    shape = (n_frames, n_channels)
    return values.reshape(shape), starts.reshape(shape), ends.reshape(shape)


def parse_bvh(data: bytes, path=None) -> Motion:
    """Parse BVH bytes into a :class:`Motion`; errors name ``path`` and the line."""
    if not data.strip():
        _fail("empty file", path)
    if b"\x00" in data[:4096]:
        _fail("not a text file (binary data)", path)
    lines = _Lines(data, path)
    lines.pos = len(BOM) if data.startswith(BOM) else 0
    names, parents, offsets, channels, end_sites, motion_start = _parse_hierarchy(lines, path)
    n_frames, frame_time = _parse_motion_header(lines, path)
    body_start = lines.pos
    header = data[motion_start:body_start]
    eol = b"\r\n" if header.split(b"\n", 1)[0].endswith(b"\r") else b"\n"
    n_channels = sum(len(c) for c in channels)
    buf = np.frombuffer(data, dtype=np.uint8)
    values, starts, ends = _parse_rows(buf, body_start, n_frames, n_channels,
                                       lines.number + 1, path)
    text = BvhText(data, data[:motion_start], header, body_start, starts, ends, frame_time,
                   eol)
    try:
        return Motion.from_channel_values(
            names, parents, offsets, channels, frame_time, values,
            end_sites=end_sites, source=text, path=None if path is None else str(path),
        )
    except MotionError as error:
        raise MotionError(error.message, path) from None


def read_bvh(path) -> Motion:
    """Read a BVH file (see :func:`parse_bvh`)."""
    with open(path, "rb") as f:
        return parse_bvh(f.read(), path)


def _format_hierarchy(motion: Motion) -> bytes:
    """A tab-indented HIERARCHY section for a motion that has no source text."""
    children: dict[int, list[int]] = {}
    for j, parent in enumerate(motion.parents):
        children.setdefault(int(parent), []).append(j)
    out: list[str] = ["HIERARCHY"]

    def offset(values) -> str:
        return " ".join(f"{v:.6f}" for v in values)

    def joint(j: int, depth: int) -> None:
        pad = "\t" * depth
        out.append(f"{pad}{'ROOT' if motion.parents[j] < 0 else 'JOINT'} {motion.names[j]}")
        out.append(f"{pad}{{")
        out.append(f"{pad}\tOFFSET {offset(motion.offsets[j])}")
        if motion.channels[j]:
            out.append(f"{pad}\tCHANNELS {len(motion.channels[j])} {' '.join(motion.channels[j])}")
        for child in children.get(j, []):
            joint(child, depth + 1)
        if j in motion.end_sites or j not in children:
            site = motion.end_sites.get(j, np.zeros(3))
            out.extend([f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET {offset(site)}",
                        f"{pad}\t}}"])
        out.append(f"{pad}}}")

    for root in children.get(-1, []):
        joint(root, 0)
    return ("\n".join(out) + "\n").encode("utf-8")


def _unchanged(motion: Motion) -> bool:
    """True when rotations and translations are bit for bit the ones read."""
    if not motion.has_source_frames() or motion.source_rotations is None:
        return False
    if not np.array_equal(motion.rotations, motion.source_rotations):
        return False
    cols = motion.layout.position_columns
    has = cols >= 0
    return np.array_equal(motion.translations[:, has], motion.source_values[:, cols[has]])


def format_bvh(motion: Motion) -> bytes:
    """Serialise ``motion`` as BVH bytes.

    With source text and the same frames, only changed values are rewritten (``%.6f``) and an
    unchanged motion returns the input bytes exactly. A motion read from a channel CSV
    without a skeleton cannot be written as BVH (it has no real hierarchy).
    """
    if getattr(motion.source, "needs_skeleton", False):
        raise MotionError(
            "this clip has no skeleton (a channel CSV read without one); to write BVH, read "
            "it with a skeleton template (motionclean convert CLIP.csv OUT.bvh --skeleton "
            "TEMPLATE.bvh)", motion.path)
    src = motion.source if isinstance(motion.source, BvhText) else None
    if src is None:
        hierarchy, eol = _format_hierarchy(motion), b"\n"
    else:
        hierarchy, eol = src.hierarchy, src.eol
    same_frame_time = src is not None and motion.frame_time == src.frame_time
    same_frames = (src is not None and motion.has_source_frames()
                   and src.n_frames == motion.n_frames > 0
                   and src.starts.shape[1] == motion.layout.n_channels)
    if same_frames and same_frame_time and _unchanged(motion):
        return src.raw
    values = motion.channel_values()
    check_finite(motion, values)
    keep_header = same_frame_time and bool(src.motion_header) and src.n_frames == motion.n_frames
    if keep_header:
        motion_header = src.motion_header
    else:
        motion_header = (
            b"MOTION" + eol + b"Frames: %d" % motion.n_frames + eol
            + b"Frame Time: " + repr(float(motion.frame_time)).encode() + eol
        )
    if motion.n_frames == 0:
        return hierarchy + motion_header
    if same_frames:
        changed = np.abs(values - motion.source_values) > UNCHANGED_TOLERANCE
        if not changed.any() and same_frame_time:
            return src.raw
        new = values[changed]
        if keep_header:  # the file up to the rows is unchanged
            start, prefix = 0, b""
        else:
            start, prefix = src.body_start, hierarchy + motion_header
        return splice(src.raw, src.starts[changed], src.ends[changed],
                      lambda a, b: format_fixed6(new[a:b]), start, prefix)
    return join_rows(*format_fixed6(values), values.shape, b" ", eol,
                     hierarchy + motion_header)


def check_finite(motion: Motion, values: np.ndarray, widths=None) -> None:
    """Refuse to write NaN or inf: name the first joint and frame that has one.

    ``values`` is ``(F, K)`` with ``widths[j]`` columns per joint (default: its channels).
    """
    bad = ~np.isfinite(values)
    if bad.any():
        frame, column = np.argwhere(bad)[0]
        widths = [len(c) for c in motion.channels] if widths is None else widths
        joint = np.searchsorted(np.cumsum(widths), column, side="right")
        raise MotionError(f"cannot write: joint {motion.names[joint]!r} has a non-finite "
                          f"value at frame {frame}")


# ----------------------------------------------------------------------------------------
# Vectorised text helpers, shared with io.csv.

#: Work on arrays in pieces of this many items (or bytes) so temporaries stay in cache.
_CHUNK_ITEMS = 16384
_CHUNK_BYTES = 131072
#: Bytes per formatted ``%.6f`` field.
_FIELD = 16
#: Decimal powers, exact in float64 up to 1e22.
_POW10_FLOAT = 10.0 ** np.arange(23)
#: Two-character groups "00" .. "99" and "0." .. "9." as native uint16 (byte pairs).
_PAIRS = np.frombuffer(b"".join(b"%02d" % i for i in range(100)), dtype=np.uint16)
_DIGIT_POINT = np.frombuffer(b"".join(b"%d." % i for i in range(10)), dtype=np.uint16)


def scan_tokens(buf: np.ndarray, start: int = 0, separators: bytes = b"") -> tuple:
    """Byte offsets ``(starts, ends)`` of the tokens of ``buf[start:]``.

    Tokens are runs of bytes that are neither ASCII whitespace nor one of ``separators``.
    """
    edges = []
    before = np.int8(1)  # a gap before the first byte
    for at in range(start, buf.size, _CHUNK_BYTES):
        part = buf[at:at + _CHUNK_BYTES]
        gap = (part == 32) | ((part >= 9) & (part <= 13))
        for byte in separators:
            gap |= part == byte
        gap = gap.view(np.int8)
        edges.append(np.flatnonzero(np.diff(gap, prepend=before)) + at)
        before = gap[-1]
    if before == 0:  # a token runs to the end of the buffer
        edges.append(np.array([buf.size]))
    edges = np.concatenate(edges) if edges else np.zeros(0, dtype=np.intp)
    return edges[0::2], edges[1::2]


def parse_numbers(buf: np.ndarray, starts: np.ndarray, ends: np.ndarray):
    """Convert the tokens ``buf[starts[i]:ends[i]]`` to float64, exactly like ``float``.

    Plain decimals (optional sign, digits with at most one point, at most 15 digits) are
    converted in bulk, one character column at a time across all tokens, as
    ``mantissa / 10**k``: both are exact in float64, so the one division is correctly
    rounded, i.e. bit-identical to ``float``. Anything else (exponents, longer mantissas)
    goes through ``float`` one token at a time. Returns ``(values, bad)`` with ``bad`` the
    index of the first token that is not a finite number (``-1`` when all are).
    """
    n = starts.size
    values = np.empty(n)
    simple = np.empty(n, dtype=bool)
    for at in range(0, n, _CHUNK_ITEMS):  # chunks stay in cache
        part = slice(at, at + _CHUNK_ITEMS)
        values[part], simple[part] = _parse_plain(buf, starts[part], ends[part])

    bad = -1
    for i in np.flatnonzero(~simple).tolist():
        token = buf[starts[i]:ends[i]].tobytes()
        try:
            value = float(token) if b"_" not in token else math.nan
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            bad = i
            break
        values[i] = value
    return values, bad


def _parse_plain(buf: np.ndarray, starts: np.ndarray, ends: np.ndarray):
    """Values of the plain decimal tokens and a mask of which tokens are plain decimals."""
    length = ends - starts
    mantissa = np.zeros(starts.size)  # exact: integers below 2**53
    n_digits = np.zeros(starts.size, dtype=np.int8)
    for column in range(int(min(length.max(), 17))):
        digit = buf.take(starts + column, mode="clip") - np.uint8(48)
        is_digit = digit < 10
        is_digit &= length > column
        mantissa *= np.where(is_digit, 10.0, 1.0)
        mantissa += digit * is_digit
        n_digits += is_digit
    first, last = int(starts[0]), int(ends[-1])
    is_dot = buf[first:last] == 46
    before_dot = np.zeros(last - first + 1, dtype=np.int32)
    np.cumsum(is_dot, out=before_dot[1:])
    dot_index = before_dot[starts - first]
    n_dots = before_dot[ends - first] - dot_index
    dots = np.flatnonzero(is_dot) + first
    dot_at = dots[np.minimum(dot_index, dots.size - 1)] if dots.size else ends
    lead = buf[starts]
    signed = (lead == 45) | (lead == 43)
    simple = ((n_digits >= 1) & (n_digits <= 15) & (n_dots <= 1)
              & (n_digits + n_dots + signed == length))
    decimals = np.where(simple & (n_dots == 1), ends - 1 - dot_at, 0)
    values = mantissa / _POW10_FLOAT[decimals]
    values[lead == 45] *= -1.0
    return values, simple


def _bad_number_message(what: str, token: bytes) -> str:
    text = token.decode("utf-8", "replace")[:40]
    try:
        float(text)
    except ValueError:
        return f"{what} is not a number: {text!r}"
    return f"{what} is not finite: {text!r}"


def format_fixed6(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``%.6f`` text of each value, as ``(buffer, starts, lengths)`` (see :func:`gather`).

    Vectorised: each value is rounded to an integer count of 1e-6 (the float product
    ``|v| * 1e6`` is one rounding away from the exact one; values whose product lies too
    close to a half, and values of 1e7 or more, are printed by Python), then written as
    two-character groups into a 16-byte field. A value that prints as zero is written
    ``0.000000``, never ``-0.000000``.
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    field = np.empty((v.size, _FIELD // 2), dtype=np.uint16)
    starts = np.empty(v.size, dtype=np.int64)
    lengths = np.empty(v.size, dtype=np.int64)
    fast = np.empty(v.size, dtype=bool)
    for at in range(0, v.size, _CHUNK_ITEMS):  # chunks stay in cache
        part = slice(at, at + _CHUNK_ITEMS)
        starts[part], lengths[part], fast[part] = _fill_fixed6(v[part], field[part])
    starts += np.arange(v.size, dtype=np.int64) * _FIELD
    chars = field.view(np.uint8).ravel()
    slow = np.flatnonzero(~fast)
    if not slow.size:
        return chars, starts, lengths
    texts = [_fixed6(x) for x in v[slow].tolist()]
    extra, extra_starts, extra_lengths = pack_texts(texts)
    starts[slow] = extra_starts + chars.size
    lengths[slow] = extra_lengths
    return np.concatenate([chars, extra]), starts, lengths


def _fill_fixed6(v: np.ndarray, field: np.ndarray):
    """Write ``%.6f`` of ``v`` right-aligned into the rows of ``field`` (16 bytes each);
    return each text's offset in its row, its length and whether it was written."""
    a = np.abs(v)
    with np.errstate(invalid="ignore", over="ignore"):
        x = a * 1e6
        rounded = np.rint(x)
        fast = (a < 1e7) & (np.abs(np.abs(x - rounded) - 0.5) > 1e-15 * x)
    n = np.where(fast, rounded, 0.0)
    whole = np.floor(n / 1e6)  # exact: n is an integer below 1e13
    frac = (n - whole * 1e6).astype(np.int32)
    whole = whole.astype(np.int32)
    # Bytes 2..8 hold 7 integer digits, 9 the point, 10..15 the decimals; the sign, if
    # any, goes just before the first digit. (x - x // 100 * 100 is faster than x % 100.)
    rest = whole // 10
    field[:, 4] = _DIGIT_POINT.take(whole - rest * 10)
    for slot in (3, 2, 1):
        pair, rest = rest, rest // 100
        field[:, slot] = _PAIRS.take(pair - rest * 100)
    rest = frac // 100
    field[:, 7] = _PAIRS.take(frac - rest * 100)
    pair, rest = rest, rest // 100
    field[:, 6] = _PAIRS.take(pair - rest * 100)
    field[:, 5] = _PAIRS.take(rest)
    n_whole = np.ones(v.size, dtype=np.int8)
    for power in (10, 100, 1000, 10_000, 100_000, 1_000_000):
        n_whole += whole >= power
    minus = (v < 0) & (n > 0)
    lengths = n_whole + 7 + minus
    offsets = _FIELD - lengths
    rows = np.flatnonzero(minus)
    field.view(np.uint8)[rows, offsets[rows]] = ord("-")
    return offsets, lengths, fast


def _fixed6(x: float) -> bytes:
    text = b"%.6f" % x
    return text[1:] if text.startswith(b"-") and text.strip(b"-0.") == b"" else text


def pack_texts(texts: list[bytes]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(buffer, starts, lengths)`` of a list of byte strings (see :func:`gather`)."""
    lengths = np.fromiter(map(len, texts), dtype=np.int64, count=len(texts))
    starts = np.cumsum(lengths) - lengths
    return np.frombuffer(b"".join(texts), dtype=np.uint8), starts, lengths


def _gather(buf: np.ndarray, starts: np.ndarray, lengths: np.ndarray) -> bytes:
    """Concatenate the non-empty pieces ``buf[starts[i] : starts[i] + lengths[i]]``."""
    out_ends = np.cumsum(lengths)
    # index[k] = index[k - 1] + 1 inside a piece and jumps to the next piece's start.
    step = np.ones(int(out_ends[-1]), dtype=np.int32 if buf.size < 2**31 else np.int64)
    step[0] = starts[0]
    step[out_ends[:-1]] = starts[1:] - (starts[:-1] + lengths[:-1] - 1)
    return buf[np.cumsum(step, out=step)].tobytes()


def gather(buf: np.ndarray, starts: np.ndarray, lengths: np.ndarray, prefix: bytes = b"") -> bytes:
    """``prefix`` followed by the pieces ``buf[starts[i] : starts[i] + lengths[i]]``."""
    lengths = np.asarray(lengths, dtype=np.int64).ravel()
    used = lengths > 0
    starts = np.asarray(starts, dtype=np.int64).ravel()[used]
    lengths = lengths[used]
    out = [prefix]
    for at in range(0, lengths.size, _CHUNK_ITEMS):  # chunks stay in cache
        part = slice(at, at + _CHUNK_ITEMS)
        out.append(_gather(buf, starts[part], lengths[part]))
    return b"".join(out)


def splice(raw: bytes, starts: np.ndarray, ends: np.ndarray, texts, start: int = 0,
           prefix: bytes = b"") -> bytes:
    """``prefix + raw[start:]`` with the byte ranges ``[starts[i], ends[i])`` (sorted,
    disjoint, at or after ``start``) replaced by new texts.

    ``texts(a, b)`` returns ``(buffer, starts, lengths)`` of the texts of replacements
    ``a`` to ``b - 1``; it is called for consecutive chunks, so that every temporary array
    stays small.
    """
    source = np.frombuffer(raw, dtype=np.uint8)
    starts, ends = starts.ravel(), ends.ravel()
    out = [prefix]
    pos = start
    for at in range(0, starts.size, _CHUNK_ITEMS):
        old_starts = starts[at:at + _CHUNK_ITEMS] - pos
        old_ends = ends[at:at + _CHUNK_ITEMS] - pos
        buf, new_starts, new_lengths = texts(at, at + old_starts.size)
        region = source[pos:pos + int(old_ends[-1])]
        pieces = np.empty(2 * old_starts.size, dtype=np.int64)
        lengths = np.empty(2 * old_starts.size, dtype=np.int64)
        pieces[0], pieces[2::2] = 0, old_ends[:-1]  # kept text before each replacement
        lengths[0::2] = old_starts - pieces[0::2]
        pieces[1::2] = np.asarray(new_starts) + region.size
        lengths[1::2] = new_lengths
        used = lengths > 0
        if used.any():
            out.append(_gather(np.concatenate([region, buf]), pieces[used], lengths[used]))
        pos += int(old_ends[-1])
    out.append(raw[pos:])
    return b"".join(out)


def join_rows(buf: np.ndarray, starts: np.ndarray, lengths: np.ndarray, shape: tuple,
              sep: bytes, eol: bytes, prefix: bytes = b"") -> bytes:
    """``prefix`` followed by rows of ``shape = (F, K)`` cells (pieces of ``buf``) joined
    by ``sep``, each row ended by ``eol``."""
    n_rows, n_cols = shape
    tail = buf.size
    both = np.concatenate([buf, np.frombuffer(sep + eol, dtype=np.uint8)])
    piece_starts = np.full((n_rows, 2 * n_cols), tail, dtype=np.int64)
    piece_lengths = np.full((n_rows, 2 * n_cols), len(sep), dtype=np.int64)
    piece_starts[:, ::2] = np.asarray(starts).reshape(shape)
    piece_lengths[:, ::2] = np.asarray(lengths).reshape(shape)
    piece_starts[:, -1], piece_lengths[:, -1] = tail + len(sep), len(eol)
    return gather(both, piece_starts, piece_lengths, prefix)
