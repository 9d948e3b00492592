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

The vectorised text work (token scan, number parsing, ``%.6f`` formatting, splicing) is in
:mod:`motionclean.io.text`, shared with :mod:`motionclean.io.csv`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import NoReturn

import numpy as np

from ..core.errors import MotionError
from ..core.motion import (
    CHANNEL_SPELLING,
    KNOWN_CHANNELS,
    MAX_FRAME_TIME,
    MIN_FRAME_TIME,
    RATES_ACCEPTED,
    ROTATION_CHANNELS,
    UNCHANGED_TOLERANCE,
    Motion,
)
from ..core.threads import in_parts, run_parts
from ..core.words import plural
from .files import FileBytes, pieces, refuse_binary
from .text import (
    ASCII_NUMBER,
    MAX_MAGNITUDE,
    ascii_digits,
    bad_number_message,
    check_finite,
    fixed6_rows,
    format_decimals,
    format_fixed6,
    join_rows,
    line_ends,
    parse_values,
    regular_rows,
    scan_rows,
    scan_tokens,
    splice_cells,
)

BOM = b"\xef\xbb\xbf"


@dataclass(frozen=True, eq=False)
class BvhText:
    """The bytes of a BVH file that a writer reuses verbatim.

    Where each frame value's text lies in ``raw`` is kept compactly: ``row_starts`` (F,)
    is the byte offset of each row's first value, and ``(F, C)`` ``gaps`` and ``lengths``
    count the bytes between a value and the one before it in its row (0 for the first)
    and the value's own bytes (uint8 unless some count is larger); :meth:`cells` gives
    the offsets of any rows.
    """

    raw: bytes | FileBytes  # the whole file as read (a large one is read again from disk)
    hierarchy: bytes  # everything before the MOTION line (BOM included)
    motion_header: bytes  # MOTION, Frames and Frame Time lines with their line endings
    body_start: int  # offset of the first byte after the Frame Time line
    row_starts: np.ndarray  # (F,) int64
    gaps: np.ndarray  # (F, C) unsigned
    lengths: np.ndarray  # (F, C) unsigned
    frame_time: float  # the Frame Time value as read
    eol: bytes  # line ending of the MOTION header, used for regenerated headers
    #: (F, C) bool: cells whose text is not the value the clip read (a channel CSV read
    #: into this file as its template), written afresh; None: every text is the value read.
    other_text: np.ndarray | None = None
    #: What the reader noticed and says beside the clip's figures (``note: ...``).
    notes: tuple[str, ...] = ()

    @property
    def n_frames(self) -> int:
        return int(self.row_starts.size)

    @property
    def n_channels(self) -> int:
        return int(self.lengths.shape[1])

    def cells(self, rows: slice) -> tuple[np.ndarray, np.ndarray]:
        """``(starts, ends)``, each ``(len, C)`` int64: the byte offsets in ``raw`` of the
        value texts of frames ``rows``."""
        lengths = self.lengths[rows].astype(np.int64)
        steps = self.gaps[rows].astype(np.int64)
        steps[:, 1:] += lengths[:, :-1]
        starts = np.cumsum(steps, axis=1)
        starts += self.row_starts[rows, None]
        return starts, starts + lengths

    @classmethod
    def hierarchy_only(cls, text: BvhText) -> BvhText:
        """The hierarchy of ``text`` without its frames (a skeleton template)."""
        empty = np.zeros((0, text.n_channels), dtype=np.uint8)
        return cls(
            b"",
            text.hierarchy,
            b"",
            0,
            np.zeros(0, dtype=np.int64),
            empty,
            empty,
            text.frame_time,
            text.eol,
        )


def _gaps_and_lengths(starts: np.ndarray, ends: np.ndarray, dtype=None):
    """``(gaps, lengths)`` of ``(R, C)`` token offsets (see :class:`BvhText`), in ``dtype``
    or the narrowest unsigned type that holds them; None when ``dtype`` is too narrow."""
    lengths = ends - starts
    gaps = np.zeros_like(starts)
    gaps[:, 1:] = starts[:, 1:] - ends[:, :-1]
    largest = max(int(lengths.max(initial=0)), int(gaps.max(initial=0)))
    if dtype is None:
        dtype = np.min_scalar_type(largest)
    elif largest > np.iinfo(dtype).max:
        return None
    return gaps.astype(dtype), lengths.astype(dtype)


#: Values per part of the frame rows read on a thread of its own.
_PART_VALUES = 1 << 19


def _fail(message: str, path, line: int | None = None) -> NoReturn:
    raise MotionError(message, path, None if line is None else int(line))


def _decode(raw: bytes, path, line: int) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        _fail("not a text file (bytes that are not UTF-8)", path, line)


def _number(token: str, what: str, path, line: int) -> float:
    if not token.isascii() or "_" in token:  # float() takes '1_000' and Unicode digits
        _fail(f"{what} is not a number: {token[:40]!r}", path, line)
    try:
        value = float(token)
    except ValueError:
        _fail(f"{what} is not a number: {token[:40]!r}", path, line)
    if not math.isfinite(value):
        _fail(f"{what} is not finite: {token[:40]!r}", path, line)
    if abs(value) > MAX_MAGNITUDE:
        _fail(
            f"{what} is out of range (more than {MAX_MAGNITUDE:g} in size): {token[:40]!r}",
            path,
            line,
        )
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
            _fail(
                f"unknown channel {name[:40]!r} (expected X/Y/Z position or rotation)", path, number
            )
    if len(set(listed)) != len(listed):
        _fail("CHANNELS lists a channel twice", path, number)
    rotations = sum(name in ROTATION_CHANNELS for name in listed)
    if rotations not in (0, 3):
        _fail(
            f"CHANNELS has {rotations} rotation channels; a joint needs all three "
            "(Xrotation, Yrotation, Zrotation) or none",
            path,
            number,
        )


class _Hierarchy:
    """The skeleton read so far from the HIERARCHY lines, one method per keyword."""

    def __init__(self, path):
        self.path = path
        self.first_line: dict[str, int] = {}  # joint name -> line of its header
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[list[float] | None] = []
        self.channels: list[tuple[str, ...]] = []
        self.end_sites: dict[int, np.ndarray] = {}
        self.stack: list[tuple[str, int]] = []  # ("joint", index) or ("end", parent index)
        self.expect_open = False

    def _in_joint(self) -> bool:
        return bool(self.stack) and self.stack[-1][0] == "joint"

    def joint(self, tokens: list[str], text: str, number: int) -> None:
        keyword = tokens[0]
        name = text[len(keyword) :].strip()
        if not name:
            _fail(f"{keyword} without a name", self.path, number)
        if "\x00" in name:
            _fail(f"joint name {name[:40]!r} holds a NUL byte", self.path, number)
        if keyword == "ROOT" and self.stack:
            _fail("ROOT inside another joint", self.path, number)
        if keyword == "JOINT" and not self._in_joint():
            _fail("JOINT outside a joint", self.path, number)
        if name in self.first_line:
            _fail(
                f"joint name {name!r} used twice (first at line {self.first_line[name]})",
                self.path,
                number,
            )
        self.first_line[name] = number
        self.parents.append(self.stack[-1][1] if self.stack else -1)
        self.names.append(name)
        self.offsets.append(None)
        self.channels.append(())
        self.stack.append(("joint", len(self.names) - 1))
        self.expect_open = True

    def end_site(self, tokens: list[str], text: str, number: int) -> None:
        if not self._in_joint():
            _fail("End Site outside a joint", self.path, number)
        self.stack.append(("end", self.stack[-1][1]))
        self.expect_open = True

    def open(self, tokens: list[str], text: str, number: int) -> None:
        if not self.expect_open or len(tokens) > 1:
            _fail("unexpected '{'", self.path, number)
        self.expect_open = False

    def close(self, tokens: list[str], text: str, number: int) -> None:
        if not self.stack:
            _fail("unbalanced '}'", self.path, number)
        kind, index = self.stack.pop()
        if kind == "joint" and self.offsets[index] is None:
            _fail(f"joint {self.names[index]!r} has no OFFSET", self.path, number)

    def offset(self, tokens: list[str], text: str, number: int) -> None:
        if not self.stack:
            _fail("OFFSET outside a joint", self.path, number)
        if len(tokens) != 4:
            _fail(f"OFFSET needs 3 numbers, found {len(tokens) - 1}", self.path, number)
        offset = [_number(t, "OFFSET value", self.path, number) for t in tokens[1:]]
        kind, index = self.stack[-1]
        if kind == "end":
            self.end_sites[index] = np.array(offset)
        else:
            self.offsets[index] = offset

    def channel_list(self, tokens: list[str], text: str, number: int) -> None:
        if not self._in_joint():
            _fail("CHANNELS outside a joint", self.path, number)
        if len(tokens) < 2 or not ascii_digits(tokens[1]):
            _fail("CHANNELS needs a count followed by channel names", self.path, number)
        joint = self.stack[-1][1]
        if self.channels[joint]:
            _fail(f"a second CHANNELS line for joint {self.names[joint]!r}", self.path, number)
        count, listed = int(tokens[1]), tokens[2:]
        if count != len(listed):
            _fail(f"CHANNELS says {count} but names {len(listed)}", self.path, number)
        listed = [CHANNEL_SPELLING.get(name.lower(), name) for name in listed]
        _check_channels(listed, self.path, number)
        self.channels[joint] = tuple(listed)

    def motion(self, tokens: list[str], number: int) -> None:
        """Check that the hierarchy is complete where the MOTION line starts."""
        if self.stack:
            _fail("truncated hierarchy: MOTION before the joints are closed", self.path, number)
        if not self.names:
            _fail("no joints before MOTION", self.path, number)
        if len(tokens) > 1:
            _fail("unexpected text after MOTION", self.path, number)

    def ended(self, number: int) -> NoReturn:
        """The file ended before the MOTION line."""
        if self.stack or not self.names:
            _fail(
                "truncated hierarchy: the file ends inside the HIERARCHY section", self.path, number
            )
        _fail("missing MOTION section", self.path, number)


def _parse_hierarchy(lines: _Lines, path):
    """Parse HIERARCHY up to the MOTION line; return the skeleton and MOTION's offset."""
    first = lines.next_tokens()
    if first is None:
        _fail("empty file", path)
    number, _, tokens, _ = first
    if tokens[0] != "HIERARCHY":
        _fail(f"not a BVH file: expected HIERARCHY, found {tokens[0][:40]!r}", path, number)
    skeleton = _Hierarchy(path)
    handlers = {
        "ROOT": skeleton.joint,
        "JOINT": skeleton.joint,
        "End": skeleton.end_site,
        "{": skeleton.open,
        "}": skeleton.close,
        "OFFSET": skeleton.offset,
        "CHANNELS": skeleton.channel_list,
    }
    while (item := lines.next_tokens()) is not None:
        number, start, tokens, text = item
        keyword = tokens[0]
        if skeleton.expect_open and keyword != "{":
            _fail(f"expected '{{' after the joint header, found {keyword[:40]!r}", path, number)
        if keyword == "MOTION":
            skeleton.motion(tokens, number)
            s = skeleton
            return s.names, s.parents, s.offsets, s.channels, s.end_sites, start
        if keyword not in handlers:
            spelled = next((k for k in (*handlers, "MOTION") if k.lower() == keyword.lower()), None)
            hint = f" (keywords are case-sensitive: {spelled})" if spelled else ""
            if keyword in ("Frames:", "Frame"):  # the motion's header without its MOTION line
                hint = " (a 'MOTION' line must come before the frame count)"
            _fail(f"unexpected {keyword[:40]!r} in HIERARCHY{hint}", path, number)
        handlers[keyword](tokens, text, number)
    skeleton.ended(lines.number)


def _parse_motion_header(lines: _Lines, path) -> tuple[int, float]:
    item = lines.next_tokens()
    if item is None or item[2][0] != "Frames:" or len(item[2]) != 2:
        _fail("expected 'Frames: N' after MOTION", path, lines.number)
    number, _, tokens, _ = item
    if not ascii_digits(tokens[1]):
        _fail(f"frame count is not a non-negative integer: {tokens[1][:40]!r}", path, number)
    n_frames = int(tokens[1])
    item = lines.next_tokens()
    if item is None or item[2][:2] != ["Frame", "Time:"] or len(item[2]) != 3:
        _fail("expected 'Frame Time: SECONDS' after Frames", path, lines.number)
    number, _, tokens, _ = item
    frame_time = _number(tokens[2], "Frame Time", path, number)
    if frame_time <= 0:
        _fail(f"Frame Time must be positive, got {tokens[2][:40]}", path, number)
    if not (math.isfinite(1.0 / frame_time) and frame_time <= MAX_FRAME_TIME):
        _fail(
            f"Frame Time {tokens[2][:40]} s gives no usable frame rate ({RATES_ACCEPTED})",
            path,
            number,
        )
    if frame_time < MIN_FRAME_TIME:
        _fail(
            f"Frame Time {tokens[2][:40]} s is a rate over {1.0 / MIN_FRAME_TIME:g} fps",
            path,
            number,
        )
    return n_frames, frame_time


def _parse_rows(
    buf: np.ndarray, body_start: int, n_frames: int, n_channels: int, first_line: int, path
):
    """Parse the frame rows: ``(F, C)`` values and ``(row_starts, gaps, lengths)``
    (:class:`BvhText`).

    Rows one per line (what every exporter writes) are scanned and converted in parts of
    lines, on threads, straight into the values (no clip-long arrays of byte offsets);
    anything else (blank lines between rows, a row that is too short) goes through
    :func:`_parse_tokens`, which also names a bad line.
    """
    newlines = line_ends(buf, body_start)
    found = _parse_row_lines(buf, body_start, newlines, n_frames, n_channels)
    if found is None:
        return _parse_tokens(buf, body_start, newlines, n_frames, n_channels, first_line, path)
    values, cells, bad = found
    if bad >= 0:
        row_starts = cells[0]
        row, column = divmod(bad, n_channels)
        line_end = newlines[row] if row < newlines.size else buf.size  # row r is line r
        row_text = buf[row_starts[row] : line_end]
        starts, ends = scan_tokens(row_text)
        token = row_text[starts[column] : ends[column]].tobytes()
        _fail(bad_number_message("frame value", token), path, first_line + row)
    return values, cells


def _parse_row_lines(buf, body_start: int, newlines, n_frames: int, n_channels: int):
    """``(values, (row_starts, gaps, lengths), bad)`` when the first ``n_frames`` lines
    after ``body_start`` hold ``n_channels`` values each and the rest is blank, else None
    (also when a value's text or the space before it is 256 bytes or longer). ``bad`` is
    the index of the first value that is not a number (``-1``: none)."""
    line_starts = np.concatenate([[body_start], newlines + 1])
    line_stops = np.concatenate([newlines, [buf.size]])
    if n_channels == 0 or n_frames == 0 or line_starts.size < n_frames:
        return None
    after = buf[line_starts[n_frames] :] if n_frames < line_starts.size else buf[:0]
    if after.size and not after.tobytes().isspace():  # more than blank lines after the rows
        return None
    values = np.empty((n_frames, n_channels))
    row_starts = np.empty(n_frames, dtype=np.int64)
    gaps = np.empty((n_frames, n_channels), dtype=np.uint8)
    lengths = np.empty((n_frames, n_channels), dtype=np.uint8)

    def part(rows: slice) -> int | None:
        """Scan and convert the lines ``rows``: the first bad value (-1: none), or None
        when they are not rows of ``n_channels`` values."""
        begin, end = int(line_starts[rows.start]), int(line_stops[rows.stop - 1])
        text = np.frombuffer(buf, np.uint8, end - begin, begin)
        found = scan_rows(text, rows.stop - rows.start, n_channels)
        starts, ends = scan_tokens(text) if found is None else found
        if starts.size != (rows.stop - rows.start) * n_channels:
            return None
        inside = (starts[::n_channels] >= line_starts[rows] - begin) & (
            ends[n_channels - 1 :: n_channels] <= line_stops[rows] - begin
        )
        shape = (rows.stop - rows.start, n_channels)
        counts = _gaps_and_lengths(starts.reshape(shape), ends.reshape(shape), np.uint8)
        if not inside.all() or counts is None:  # (a text or space of 256 bytes or more)
            return None
        gaps[rows], lengths[rows] = counts
        row_starts[rows] = starts[::n_channels] + np.int64(begin)
        found, bad = parse_values(text, starts, ends)
        values[rows] = found.reshape(-1, n_channels)
        return bad if bad < 0 else bad + rows.start * n_channels

    results = run_parts(part, in_parts(n_frames, max(1, _PART_VALUES // n_channels)), buf.size)
    if any(result is None for result in results):
        return None
    bad = [result for result in results if result is not None and result >= 0]
    return values, (row_starts, gaps, lengths), min(bad, default=-1)


def _parse_tokens(buf, body_start, newlines, n_frames, n_channels, first_line, path):
    """:func:`_parse_rows` for any layout of the rows: every token at once; refuses a file
    whose values do not make ``n_frames`` rows, naming the line."""
    starts, ends = scan_tokens(buf, body_start)
    if not _one_row_per_line(starts, ends, newlines, n_frames, n_channels):
        _check_row_lines(buf, starts, ends, newlines, (n_frames, n_channels), first_line, path)
    values, bad_token = parse_values(buf, starts, ends)
    if bad_token >= 0:
        token = buf[starts[bad_token] : ends[bad_token]].tobytes()
        _fail(
            bad_number_message("frame value", token),
            path,
            first_line + np.searchsorted(newlines, starts[bad_token]),
        )
    shape = (n_frames, n_channels)
    row_starts = starts[::n_channels] if n_channels else np.zeros(n_frames)
    counts = _gaps_and_lengths(starts.reshape(shape), ends.reshape(shape))
    assert counts is not None
    return values.reshape(shape), (row_starts.astype(np.int64), *counts)


def _one_row_per_line(starts, ends, newlines, n_frames: int, n_channels: int) -> bool:
    """True when the tokens are ``n_frames`` rows of ``n_channels``, each on a line of its
    own: no line end within a row, at least one between rows (only the rows' first and
    last tokens are looked up, not every token)."""
    if starts.size != n_frames * n_channels or n_channels == 0:
        return False
    inside = np.searchsorted(newlines, starts[::n_channels])
    after = np.searchsorted(newlines, ends[n_channels - 1 :: n_channels])
    return bool(np.array_equal(inside, after) and np.all(inside[1:] > after[:-1]))


def _check_row_lines(buf, starts, ends, newlines, shape, first_line, path) -> None:
    """Name the first line whose values do not make a frame row of ``shape`` ``(frames,
    channels)`` (the file's shape is wrong somewhere: a row too short or too long, too few
    or too many rows, text after the last)."""
    n_frames, n_channels = shape
    counts = np.diff(np.searchsorted(starts, newlines), prepend=0, append=starts.size)
    row_lines = np.flatnonzero(counts)
    bad = np.flatnonzero(counts[row_lines] != n_channels)
    if bad.size and bad[0] < n_frames:
        line = row_lines[bad[0]]
        _fail(
            f"frame row has {counts[line]} values, expected {n_channels}", path, first_line + line
        )
    if row_lines.size < n_frames:
        _fail(
            f"the file ends after {plural(int(row_lines.size), 'frame row')} but Frames: says "
            f"{n_frames}",
            path,
            first_line + (row_lines[-1] if row_lines.size else -1),
        )
    if row_lines.size > n_frames:
        line = row_lines[n_frames]
        first = int(np.searchsorted(starts, newlines[line - 1] if line else 0))
        token = buf[starts[first] : ends[first]].tobytes()
        if ASCII_NUMBER.fullmatch(token.decode("utf-8", "replace")) is None:
            stop = newlines[line] if line < newlines.size else buf.size
            text = buf[starts[first] : stop].tobytes().decode("utf-8", "replace").rstrip()
            shown = repr(text[:30]) + ("..." if len(text) > 30 else "")
            _fail(
                f"text after the last of the Frames: {n_frames} rows ({shown}): not a frame "
                "row; remove it",
                path,
                first_line + line,
            )
        _fail(f"more frame rows than Frames: {n_frames}", path, first_line + line)


def parse_bvh(data: bytes, path=None) -> Motion:
    """Parse BVH bytes into a :class:`Motion`; errors name ``path`` and the line."""
    if not data or data.isspace():  # (no copy of the file, unlike strip)
        _fail("empty file", path)
    refuse_binary(data, path)
    lines = _Lines(data, path)
    lines.pos = len(BOM) if data.startswith(BOM) else 0
    names, parents, offsets, channels, end_sites, motion_start = _parse_hierarchy(lines, path)
    n_frames, frame_time = _parse_motion_header(lines, path)
    body_start = lines.pos
    header = data[motion_start:body_start]
    eol = b"\r\n" if header.split(b"\n", 1)[0].endswith(b"\r") else b"\n"
    n_channels = sum(len(c) for c in channels)
    buf = np.frombuffer(data, dtype=np.uint8)
    values, (row_starts, gaps, lengths) = _parse_rows(
        buf, body_start, n_frames, n_channels, lines.number + 1, path
    )
    text = BvhText(
        data,
        data[:motion_start],
        header,
        body_start,
        row_starts,
        gaps,
        lengths,
        frame_time,
        eol,
        notes=_rate_notes(frame_time),
    )
    try:
        return Motion.from_channel_values(
            names,
            parents,
            offsets,
            channels,
            frame_time,
            values,
            end_sites=end_sites,
            source=text,
            path=None if path is None else str(path),
        )
    except MotionError as error:
        raise MotionError(error.message, path) from None


#: A Frame Time above this (seconds) is read as written, and said: no capture records a
#: frame a second or slower, and an exporter writing its rate there (``Frame Time: 120``)
#: would otherwise give a clip of 0.0083 fps without a word.
SLOW_FRAME_TIME = 1.0


def _rate_notes(frame_time: float) -> tuple[str, ...]:
    """The note on a ``frame_time`` (seconds) slower than :data:`SLOW_FRAME_TIME`."""
    if frame_time <= SLOW_FRAME_TIME:
        return ()
    return (
        f"Frame Time: {frame_time:g} s per frame, {1.0 / frame_time:.3g} fps: where "
        f"{frame_time:g} is the rate, the file should say Frame Time: "
        f"{1.0 / frame_time:.7f}",
    )


def _depth_first(motion: Motion) -> Motion:
    """``motion`` with its joints in the depth-first order a BVH lists them (children in
    joint order), so that each frame's values follow the hierarchy written; itself when
    they are already (a clip read from BVH, or independent bodies)."""
    children: dict[int, list[int]] = {}
    for j, parent in enumerate(motion.parents.tolist()):
        children.setdefault(parent, []).append(j)
    order: list[int] = []
    stack = list(reversed(children.get(-1, [])))
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(children.get(j, [])))
    if order == list(range(motion.n_joints)):
        return motion
    index = np.array(order, dtype=np.intp)
    position = np.argsort(index)
    parents = np.where(motion.parents[index] >= 0, position[motion.parents[index]], -1)
    return motion.replace(
        names=[motion.names[j] for j in order],
        parents=parents,
        offsets=motion.offsets[index],
        channels=[motion.channels[j] for j in order],
        end_sites={int(position[j]): site for j, site in motion.end_sites.items()},
        rotations=motion.rotations[:, index],
        translations=motion.translations[:, index],
        source_values=None,
        source_rotations=None,
        missing=None if motion.missing is None else motion.missing[:, index],
    )


def _format_hierarchy(motion: Motion) -> bytes:
    """A tab-indented HIERARCHY section for a motion that has no source text."""
    children: dict[int, list[int]] = {}
    for j, parent in enumerate(motion.parents):
        children.setdefault(int(parent), []).append(j)
    out: list[str] = ["HIERARCHY"]
    offsets = np.vstack([motion.offsets, *motion.end_sites.values()])
    decimals = _offset_decimals(offsets, getattr(motion.source, "float_digits", None))

    def offset(values) -> str:
        buf, starts, lengths = format_decimals(values, decimals)
        return join_rows(buf, starts[None], lengths[None], b" ", b"").decode()

    def close(j: int, pad: str) -> None:
        if j in motion.end_sites or j not in children:
            site = motion.end_sites.get(j, np.zeros(3))
            out.extend(
                [f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET {offset(site)}", f"{pad}\t}}"]
            )
        out.append(f"{pad}}}")

    # Depth first with a stack of its own (no recursion: a chain may be any depth); a
    # negative entry ~j closes joint j once its children are written.
    stack = [(root, 0) for root in reversed(children.get(-1, []))]
    while stack:
        j, depth = stack.pop()
        pad = "\t" * depth
        if j < 0:
            close(~j, pad)
            continue
        out.append(f"{pad}{'ROOT' if motion.parents[j] < 0 else 'JOINT'} {motion.names[j]}")
        out.append(f"{pad}{{")
        out.append(f"{pad}\tOFFSET {offset(motion.offsets[j])}")
        # (a joint without channels says so: Blender's importer and bvhio need the line)
        out.append(
            f"{pad}\tCHANNELS {' '.join([str(len(motion.channels[j])), *motion.channels[j]])}"
        )
        stack.append((~j, depth))
        stack.extend((child, depth + 1) for child in reversed(children.get(j, [])))
    return ("\n".join(out) + "\n").encode("utf-8")


#: Significant digits of a skeleton's size (its largest offset) a new hierarchy's OFFSETs
#: keep: a float32's for offsets that are float32 values (glTF's nodes), else twelve (past
#: any rig's precision, short of the noise of offsets computed in doubles).
FLOAT32_DIGITS, FLOAT64_DIGITS = 7, 12
#: The most decimals an OFFSET gets (a skeleton of offsets under 1e-12 stops there).
MAX_DECIMALS = 24


def _offset_decimals(offsets: np.ndarray, digits: int | None = None) -> int:
    """The decimals every OFFSET of a new hierarchy is written with: the fewest, six at
    least (BVH's usual), that keep each of ``offsets`` (any shape) to the source's
    precision: ``digits`` significant digits of the skeleton's size where the source says
    (a glTF's: float32), else :data:`FLOAT32_DIGITS` for float32 values and
    :data:`FLOAT64_DIGITS` for others."""
    size = float(np.abs(offsets).max()) if offsets.size else 0.0
    if digits is None:
        single = size < 1e38 and np.array_equal(offsets, offsets.astype(np.float32))
        digits = FLOAT32_DIGITS if single else FLOAT64_DIGITS
    tolerance = size * 10.0**-digits
    decimals = 6
    while (
        decimals < MAX_DECIMALS
        and np.abs(np.round(offsets, decimals) - offsets).max(initial=0) > tolerance
    ):
        decimals += 1
    return decimals


def _describes(text: BvhText, motion: Motion) -> bool:
    """True when ``text``'s hierarchy is ``motion``'s skeleton: names, parents, offsets,
    channels and end sites (an edited skeleton is written afresh, never dropped)."""
    data = text.hierarchy + b"MOTION\n"
    lines = _Lines(data, motion.path)
    lines.pos = len(BOM) if data.startswith(BOM) else 0
    names, parents, offsets, channels, end_sites, _ = _parse_hierarchy(lines, motion.path)
    return (
        names == list(motion.names)
        and channels == list(motion.channels)
        and np.array_equal(parents, motion.parents)
        and np.array_equal(np.asarray(offsets, dtype=np.float64), motion.offsets)
        and end_sites.keys() == motion.end_sites.keys()
        and all(np.array_equal(site, motion.end_sites[j]) for j, site in end_sites.items())
    )


#: A value this close to the one read may print, with six decimals, as that same number.
_SAME_PRINT = 6e-7


def _changed(values: np.ndarray, read: np.ndarray) -> np.ndarray:
    """``(F, C)`` bool: values further than :data:`UNCHANGED_TOLERANCE` from those read
    whose six-decimal text would not be the number read either (a joint a step moved by a
    hundred-millionth of a degree keeps the text it had, ``0.0000`` as it was), block by
    block (no clip-sized temporary)."""
    out = np.empty(values.shape, dtype=bool)
    for at in range(0, values.shape[0], 4096):
        rows = slice(at, at + 4096)
        gap = np.abs(values[rows] - read[rows])
        np.greater(gap, UNCHANGED_TOLERANCE, out=out[rows])
        close = out[rows] & (gap <= _SAME_PRINT)
        if close.any():  # (few: most changed values move by more)
            out[rows][close] = np.round(values[rows][close], 6) != read[rows][close]
    return out


def _unchanged(motion: Motion) -> bool:
    """True when rotations (up to sign) and translations are bit for bit the ones read."""
    if not motion.has_source_frames():
        return False
    assert motion.source_values is not None
    for at in range(0, motion.n_frames, 256):  # small blocks: a changed clip is seen early
        rows = slice(at, at + 256)
        q, read = motion.rotations[rows], motion.read_rotations(rows)
        if not (np.all(q == read, axis=-1) | np.all(q == -read, axis=-1)).all():
            return False
    cols = motion.layout.position_columns
    has = cols >= 0
    return np.array_equal(motion.translations[:, has], motion.source_values[:, cols[has]])


def _refuse_gaps(motion: Motion) -> None:
    """BVH has no blank values: a clip with missing samples cannot be written as BVH."""
    if motion.missing is None:
        return
    gapped = np.flatnonzero(motion.missing.any(axis=0))
    joint = int(gapped[0])
    frames = np.flatnonzero(motion.missing[:, joint])
    breaks = np.flatnonzero(np.diff(frames) > 1)
    runs = np.split(frames, breaks + 1)
    shown = ", ".join(f"{r[0]}-{r[-1]}" if r.size > 1 else f"{r[0]}" for r in runs[:3])
    more = f" and {len(runs) - 3} more gaps" if len(runs) > 3 else ""
    others = [motion.names[j] for j in gapped[1:]]
    also = (
        ""
        if not others
        else f"; {', '.join(others[:4])}"
        + (f" and {len(others) - 4} more" if len(others) > 4 else "")
        + (" has gaps too" if len(others) == 1 else " have gaps too")
    )
    raise MotionError(
        f"{motion.names[joint]!r} is missing on frames {shown}{more} (frames from 0){also}, "
        "and BVH has no blank values: fill them first (the fill-gaps step, in clean's "
        "default; -f 'fill-gaps:max_gap=SECONDS' for longer gaps) or write CSV",
        motion.path,
    )


def format_bvh(motion: Motion) -> bytes:
    """Serialise ``motion`` as BVH bytes (:func:`bvh_pieces` joined)."""
    return b"".join(bvh_pieces(motion))


def bvh_pieces(motion: Motion) -> Iterable[bytes | memoryview]:
    """``motion`` as BVH, in pieces to write one after the other (no copy of the whole file
    is made to join them; the spliced rows are made as they are written).

    With source text and the same frames, only changed values are rewritten (``%.6f``) and an
    unchanged motion returns the input bytes exactly. An edited skeleton (names, parents,
    offsets, channels, end sites other than the source text's) is written as a new
    hierarchy, the frames still spliced. A motion read from a channel CSV
    without a skeleton cannot be written as BVH (it has no real hierarchy).
    """
    if getattr(motion.source, "needs_skeleton", False):
        raise MotionError(
            getattr(
                motion.source,
                "no_skeleton_message",
                "this clip has no skeleton (a channel CSV read without one); to write BVH, "
                "read it with a skeleton template (motionclean convert CLIP.csv OUT.bvh "
                "--skeleton TEMPLATE.bvh; in Python mc.load(CLIP, skeleton=TEMPLATE))",
            ),
            motion.path,
        )
    _refuse_gaps(motion)
    src = motion.source if isinstance(motion.source, BvhText) else None
    if src is None:  # (a channel CSV read into a BVH template: that template's hierarchy)
        src = getattr(motion.source, "bvh_template", None)
    if src is None:
        motion = _depth_first(motion)
        hierarchy, eol = _format_hierarchy(motion), b"\n"
    elif _describes(src, motion):
        hierarchy, eol = src.hierarchy, src.eol
    else:  # an edited skeleton: a new hierarchy; the frames still keep their text
        hierarchy, eol = _format_hierarchy(motion), src.eol
    same_hierarchy = src is not None and hierarchy is src.hierarchy
    same_frame_time = src is not None and motion.frame_time == src.frame_time
    same_frames = (
        src is not None
        and motion.has_source_frames()
        and src.n_frames == motion.n_frames > 0
        and src.n_channels == motion.layout.n_channels
    )
    same_head = same_hierarchy and same_frame_time  # the file's text up to the rows
    if (
        src is not None
        and same_frames
        and same_head
        and src.other_text is None
        and _unchanged(motion)
    ):
        return pieces(src.raw)
    values = motion.channel_values()
    check_finite(motion, values)
    keep_header = (
        src is not None
        and same_frame_time
        and bool(src.motion_header)
        and src.n_frames == motion.n_frames
    )
    if src is not None and keep_header:
        motion_header = src.motion_header
    else:
        motion_header = (
            b"MOTION"
            + eol
            + b"Frames: %d" % motion.n_frames
            + eol
            + b"Frame Time: "
            + repr(float(motion.frame_time)).encode()
            + eol
        )
    if motion.n_frames == 0:
        return [hierarchy, motion_header]
    if src is not None and same_frames and motion.source_values is not None:
        changed = _changed(values, motion.source_values)
        if src.other_text is not None:
            changed |= src.other_text
        if not changed.any() and same_head:
            return pieces(src.raw)
        if keep_header and same_hierarchy:  # the file up to the rows is unchanged
            start, prefix = 0, b""
        else:
            start, prefix = src.body_start, hierarchy + motion_header

        def texts(rows: slice):
            new = values[rows][changed[rows]]  # only the changed values are printed
            return lambda a, b: format_fixed6(new[a:b])

        def rows_text(rows: slice, source: np.ndarray, starts: np.ndarray, ends: np.ndarray):
            """Rows of one space between values and the same line end after each: made
            afresh from fields of digits, the unchanged values' texts copied into theirs."""
            row_eol = regular_rows(source, starts, ends, b" ")
            if row_eol is None:
                return None
            kept = (source, starts, ends, ~changed[rows])
            return fixed6_rows(values[rows], b" ", row_eol, kept, last_eol=False)

        return splice_cells(
            src.raw, src.row_starts, src.cells, changed, texts, start, prefix, rows_text
        )
    return _table_pieces(values, eol, hierarchy + motion_header)


#: Rows per piece of a table written afresh.
_TABLE_ROWS = 4096


def _table_pieces(values: np.ndarray, eol: bytes, head: bytes) -> Iterable[bytes]:
    """``head``, then the ``(F, C)`` rows of values as ``%.6f`` texts joined by spaces, a
    block of rows per piece, each made when it is asked for."""
    yield head
    for at in range(0, values.shape[0], _TABLE_ROWS):
        block = values[at : at + _TABLE_ROWS]
        text = fixed6_rows(block, b" ", eol)
        if text is None:  # (a value of 9e12 or more)
            buf, starts, lengths = format_fixed6(block)
            text = join_rows(
                buf, starts.reshape(block.shape), lengths.reshape(block.shape), b" ", eol
            )
        yield text
