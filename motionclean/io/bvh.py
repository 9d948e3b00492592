"""BVH read and write, with an exact identity round trip.

The HIERARCHY section is parsed line by line (it is small) and kept as bytes, so it is
written back byte for byte. The MOTION block is parsed with numpy in one pass: token
boundaries and per-line counts come from a vectorised scan of the bytes, values from one
bulk float conversion. Accepted: any rotation order per joint, position channels on any
joint, tabs and odd spacing, CRLF, LF and mixed line endings, a UTF-8 byte-order mark,
joint names with spaces or colons.

On write, values equal to the ones read (within 1e-9) keep the input's own text; changed
values are printed with six decimals. Line endings of the frame rows are preserved.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import MotionError
from ..motion import KNOWN_CHANNELS, UNCHANGED_TOLERANCE, Motion

BOM = b"\xef\xbb\xbf"
_WHITESPACE = np.zeros(256, dtype=bool)
_WHITESPACE[[9, 10, 11, 12, 13, 32]] = True


@dataclass(frozen=True)
class BvhText:
    """The bytes of a BVH file that a writer reuses verbatim."""

    raw: bytes  # the whole file as read
    hierarchy: bytes  # everything before the MOTION line (BOM included)
    motion_header: bytes  # MOTION, Frames and Frame Time lines with their line endings
    body: bytes  # the frame rows
    eol: bytes  # line ending of the MOTION header, used for regenerated headers
    row_eols: tuple[bytes, ...]  # line ending after each frame row ('' for a last open row)


def _fail(message: str, path, line: int | None = None):
    raise MotionError(message, path, line)


def _decode(raw: bytes, path, line: int) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        _fail("not a text file (bytes that are not UTF-8)", path, line)


def _number(token: str, what: str, path, line: int) -> float:
    try:
        value = float(token)
    except ValueError:
        _fail(f"{what} is not a number: {token!r}", path, line)
    if not math.isfinite(value):
        _fail(f"{what} is not finite: {token!r}", path, line)
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
            _fail(f"expected '{{' after the joint header, found {keyword!r}", path, number)
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
            for name in listed:
                if name not in KNOWN_CHANNELS:
                    _fail(f"unknown channel {name!r} (expected X/Y/Z position or rotation)",
                          path, number)
            channels[stack[-1][1]] = tuple(listed)
        elif keyword == "MOTION":
            if stack:
                _fail("truncated hierarchy: MOTION before the joints are closed", path, number)
            if not names:
                _fail("no joints before MOTION", path, number)
            return names, parents, offsets, channels, end_sites, start
        else:
            _fail(f"unexpected {keyword[:40]!r} in HIERARCHY", path, number)


def _parse_motion_header(lines: _Lines, path) -> tuple[int, float]:
    item = lines.next_tokens()
    if item is None or item[2][0] != "Frames:" or len(item[2]) != 2:
        _fail("expected 'Frames: N' after MOTION", path, lines.number)
    number, _, tokens, _ = item
    if not tokens[1].isdigit():
        _fail(f"frame count is not a non-negative integer: {tokens[1]!r}", path, number)
    n_frames = int(tokens[1])
    item = lines.next_tokens()
    if item is None or item[2][:2] != ["Frame", "Time:"] or len(item[2]) != 3:
        _fail("expected 'Frame Time: SECONDS' after Frames", path, lines.number)
    number, _, tokens, _ = item
    frame_time = _number(tokens[2], "Frame Time", path, number)
    if frame_time <= 0:
        _fail(f"Frame Time must be positive, got {tokens[2]}", path, number)
    return n_frames, frame_time


def _parse_rows(body: bytes, n_frames: int, n_channels: int, first_line: int, path):
    """Parse the frame rows: ``(F, C)`` float64 values and each row's line ending."""
    buf = np.frombuffer(body, dtype=np.uint8)
    space = _WHITESPACE[buf]
    newlines = np.flatnonzero(buf == 10)
    starts = np.flatnonzero(~space & np.concatenate(([True], space[:-1])))
    line_of_token = np.searchsorted(newlines, starts)
    counts = np.bincount(line_of_token, minlength=len(newlines) + 1)
    row_lines = np.flatnonzero(counts)
    bad = np.flatnonzero(counts[row_lines] != n_channels)
    if bad.size and bad[0] < n_frames:
        line = row_lines[bad[0]]
        _fail(f"frame row has {counts[line]} values, expected {n_channels}", path,
              first_line + line)
    if row_lines.size < n_frames:
        _fail(f"Frames: says {n_frames} but the file has {row_lines.size} frame rows", path,
              first_line + len(newlines))
    if row_lines.size > n_frames:
        _fail(f"more frame rows than Frames: {n_frames}", path, first_line + row_lines[n_frames])

    tokens = body.split()
    try:
        values = np.array(tokens).astype(np.float64)
    except ValueError:
        values = None
    if values is None or not np.all(np.isfinite(values)):
        index = next(i for i, t in enumerate(tokens) if not _is_finite_number(t))
        line = first_line + row_lines[index // n_channels] if n_channels else first_line
        token = tokens[index].decode("utf-8", "replace")[:40]
        _fail(f"frame value is not a finite number: {token!r}", path, line)
    values = values.reshape(n_frames, n_channels)

    open_row = row_lines >= len(newlines)
    if len(newlines):
        end = newlines[np.minimum(row_lines, len(newlines) - 1)]
        crlf = (end > 0) & (buf[np.maximum(end - 1, 0)] == 13)
    else:
        crlf = np.zeros(row_lines.shape, dtype=bool)
    eol_choices = np.array([b"\n", b"\r\n", b""], dtype=object)
    row_eols = eol_choices[np.where(open_row, 2, crlf.astype(np.intp))]
    return values, tuple(row_eols)


def _is_finite_number(token: bytes) -> bool:
    try:
        return math.isfinite(float(token))
    except ValueError:
        return False


def parse_bvh(data: bytes, path=None) -> Motion:
    """Parse BVH bytes into a :class:`Motion`; errors name ``path`` and the line."""
    if not data.strip():
        _fail("empty file", path)
    if b"\x00" in data[:4096]:
        _fail("not a text file (binary data)", path)
    offset = len(BOM) if data.startswith(BOM) else 0
    lines = _Lines(data, path)
    lines.pos = offset
    names, parents, offsets, channels, end_sites, motion_start = _parse_hierarchy(lines, path)
    n_frames, frame_time = _parse_motion_header(lines, path)
    header_end = lines.pos
    header = data[motion_start:header_end]
    eol = b"\r\n" if data[motion_start:header_end].split(b"\n", 1)[0].endswith(b"\r") else b"\n"
    n_channels = sum(len(c) for c in channels)
    body = data[header_end:]
    values, row_eols = _parse_rows(body, n_frames, n_channels, lines.number + 1, path)
    text = BvhText(data, data[:motion_start], header, body, eol, row_eols)
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


def format_bvh(motion: Motion) -> bytes:
    """Serialise ``motion`` as BVH bytes.

    With source text and the same frames, unchanged values keep their original text and an
    unchanged motion returns the input bytes exactly.
    """
    src = motion.source if isinstance(motion.source, BvhText) else None
    values = motion.channel_values()
    same_frames = src is not None and motion.has_source_frames() and len(src.row_eols) == len(
        values
    )
    if same_frames:
        changed = np.abs(values - motion.source_values) > UNCHANGED_TOLERANCE
        if not changed.any() and _same_frame_time(motion, src):
            return src.raw
    hierarchy = src.hierarchy if src is not None else _format_hierarchy(motion)
    eol = src.eol if src is not None else b"\n"
    if same_frames and _same_frame_time(motion, src):
        motion_header = src.motion_header
    else:
        motion_header = (
            b"MOTION" + eol + b"Frames: %d" % motion.n_frames + eol
            + b"Frame Time: " + repr(float(motion.frame_time)).encode() + eol
        )
    n_frames, n_channels = values.shape
    if n_frames == 0:
        return hierarchy + motion_header
    if same_frames:
        tokens = np.array(src.body.split(), dtype=object).reshape(n_frames, n_channels)
        if changed.any():
            tokens[changed] = _format_values(values[changed])
        row_eols = list(src.row_eols)
        if row_eols[-1] == b"":
            row_eols[-1] = eol
    else:
        tokens = np.array(_format_values(values.ravel()), dtype=object).reshape(values.shape)
        row_eols = [eol] * n_frames
    cells = np.empty((n_frames, n_channels + 1), dtype=object)
    cells[:, :n_channels] = tokens
    cells[:, n_channels] = row_eols
    row_format = b" ".join([b"%s"] * n_channels) + b"%s"
    return hierarchy + motion_header + (row_format * n_frames) % tuple(cells.ravel())


def _same_frame_time(motion: Motion, src: BvhText) -> bool:
    frame_time = float(src.motion_header.split()[-1])
    return motion.frame_time == frame_time


def _format_values(values: np.ndarray) -> list[bytes]:
    """Six-decimal text for each value (``-0.000000`` printed as ``0.000000``)."""
    values = np.where(np.abs(values) < 5e-7, 0.0, values)
    return (b" ".join([b"%.6f"] * values.size) % tuple(values.tolist())).split(b" ")
