"""CSV read and write: a channel layout mirroring BVH, and a rigid-body layout for trackers.

Both layouts are comma-separated with one header line, then one row per frame. A UTF-8
byte-order mark, CRLF or LF line endings, spaces around values and blank lines are
accepted; header fields may be quoted (RFC 4180) when a name contains a comma. Values are
decimal numbers (exponents allowed); inf is an error. The layout is detected from the header.

Blank cells (empty, or the literal NaN in any case, signed or not: ``-nan`` as glibc's
printf writes it) are tracker dropouts: a joint or body whose cells are all blank on a row is
missing on that frame (``Motion.missing``; its arrays hold the nearest known sample, see
:func:`motionclean.core.motion.hold_missing`). A partly blank
joint or body is an error naming the line and its blank columns; the time and frame
columns are never blank.

Channel CSV: the BVH MOTION block with named columns::

    frame,time,Hips.Xposition,Hips.Yposition,Hips.Zposition,Hips.Zrotation,Hips.Yrotation,...
    0,0,4.9520,17.0575,-18.0767,-4.9118,41.8207,...
    1,0.0083333,4.9551,17.0583,-18.0681,-4.9005,41.6923,...

``frame`` is optional, ``time`` (seconds) is required; every other column is
``<joint>.<channel>`` with the joint name before the last dot and a BVH channel name after it
(``Xposition`` ... ``Zrotation``; angles in degrees). A joint's columns are adjacent and its
rotation columns (all three or none) give its Euler order, as in BVH ``CHANNELS``.

- With a skeleton template (``motionclean convert clip.csv out.bvh --skeleton clip.bvh``,
  or ``load(path, skeleton=motion)``), columns are matched to the template's channels by
  name (any column order; all of them must be present and no others; a joint's rotation
  columns must follow the template's order). The clip takes the template's hierarchy. It is
  an edit of the template: values equal to the template's keep its text, so an unchanged
  CSV gives back the template file byte for byte, and changed values are written like any
  edited BVH value (six decimals). The values read are the CSV's: a written angle
  continues the CSV's own Euler curve, never the template's (another take of the rig). A
  template of other frames (another take's length or rate) gives the hierarchy only: the
  CSV's own text is the clip's source, written back byte for byte where nothing changed.
- Without a template, the skeleton is flat: each joint becomes a root with a zero offset
  and the channels of its columns. ``info``, ``clean`` and ``report`` work and CSV output
  keeps the columns, but writing BVH needs ``--skeleton`` (a clear error says so): the
  offsets and parents a BVH needs are not in the CSV.

Rigid-body CSV, as trackers and VR devices record it::

    time,head.px,head.py,head.pz,head.qw,head.qx,head.qy,head.qz,hand_l.px,...
    0,0.012,1.621,0.034,0.9987,0.0132,-0.0481,0.0071,0.251,...
    0.0111111,0.012,1.622,0.034,0.9986,0.0135,-0.0483,0.0070,0.253,...

``frame`` optional, ``time`` (seconds), then for each body the seven columns
``<body>.px .py .pz`` (position, any length unit) and ``<body>.qw .qx .qy .qz`` (the
orientation as a scalar-first Hamilton quaternion rotating body-frame vectors into the
world frame), in any column order. Each body becomes an independent root joint
(parent -1, no offset) whose rotation is the quaternion itself (no Euler angles involved),
renormalised where its norm is not 1 (a norm under 1e-6 is an error) and made
sign-continuous in time. For BVH output a body gets the channels ``Xposition Yposition
Zposition Yrotation Xrotation Zrotation``.

Time: the rows must be uniformly sampled. Times must increase, each step must be within
10% of the mean step and each time within 10% of a frame of the uniform grid; otherwise the
error names the row (and says to export the clip at a fixed rate). The frame time is the
mean step rounded to 12 significant digits, or the template's frame time when the time
column fits it. A clip without a template needs at least two rows.

Writing (``save(motion, "out.csv")``): a clip read from a rigid-body CSV is written as a
rigid-body CSV, every other clip as a channel CSV (``format_csv(motion, layout=...)``
chooses). Values equal to the ones read keep the input's text (the BVH text for a clip read
from BVH), other values are written with Python's shortest round-trip repr and times with
12 significant digits (a channel CSV's or OpenSim file's own time text while the frames are
its own: :func:`.text.read_times`), so reading the file back gives the same numbers bit for
bit and an unchanged clip writes the input bytes exactly. Missing samples are written as
empty cells (a sample missing in the input too keeps its text, e.g. ``NaN``), so a clip
with gaps reads back with the same mask and the same known values.
"""

from __future__ import annotations

import csv as _csv
import io as _io
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple, NoReturn

import numpy as np

from ..core import quat
from ..core.errors import MotionError
from ..core.motion import (
    CHANNEL_SPELLING,
    KNOWN_CHANNELS,
    ROTATION_CHANNELS,
    UNCHANGED_TOLERANCE,
    Motion,
    hold_missing,
    same_rotations,
)
from .bvh import BOM, BvhText
from .files import FileBytes, pieces, refuse_binary
from .text import (
    MAX_MAGNITUDE,
    ascii_float,
    check_finite,
    format_decimals,
    parse_values,
    read_times,
    scan_cells,
    scan_tokens,
    sliceable,
    splice_cells,
    start_time,
    table_pieces,
)
from .timegrid import slow_time_notes, time_format, uniform_frame_time, unix_hint

#: Column suffixes of a rigid body, in the order they are written.
RIGID_SUFFIXES = ("px", "py", "pz", "qw", "qx", "qy", "qz")
#: BVH channels given to a rigid body.
RIGID_CHANNELS = ("Xposition", "Yposition", "Zposition", "Yrotation", "Xrotation", "Zrotation")
#: Quaternions with a smaller norm are rejected.
MIN_QUAT_NORM = 1e-6


@dataclass(frozen=True, eq=False)
class CsvText:
    """A CSV file as read, for writers that reuse its text.

    ``starts``/``ends`` are the ``(F, K)`` byte offsets of the cells in ``raw`` and
    ``values`` their numbers. ``columns`` maps the clip to CSV columns: ``(C,)`` per
    channel for the channel layout, ``(B, 7)`` per body and :data:`RIGID_SUFFIXES` entry
    for the rigid-body layout.
    """

    layout: str  # "channel" or "rigid"
    raw: bytes | FileBytes  # (a large file is read again from disk)
    starts: np.ndarray
    ends: np.ndarray
    values: np.ndarray
    columns: np.ndarray
    time_column: int
    skeleton: tuple  # (names, channels) the columns were mapped to
    frame_time: float
    eol: bytes
    needs_skeleton: bool = False
    blank: np.ndarray | None = None  # (F, K) bool: empty or NaN cells
    frame_column: bool = True  # a "frame" column (channel layout: rows written afresh keep it)
    #: The BVH template's hierarchy (no frames) a channel CSV was read into when the
    #: template's frames are not the CSV's: what a BVH written from the clip keeps.
    bvh_template: BvhText | None = None
    #: What the reader noticed and says beside the clip's figures (``note: ...``).
    notes: tuple[str, ...] = ()

    @property
    def start_time(self) -> float:
        """Seconds at the first row (:func:`.text.start_time`); 0 without rows."""
        return float(self.values[0, self.time_column]) if self.values.shape[0] else 0.0

    @property
    def time_cells(self) -> tuple[float, np.ndarray, np.ndarray] | None:
        """A channel CSV's frame time and the byte ranges of its time cells, which
        writers keep (:func:`.text.read_times`); None for another layout."""
        if self.layout != "channel":
            return None
        return self.frame_time, self.starts[:, self.time_column], self.ends[:, self.time_column]

    @classmethod
    def of(cls, layout, raw, cells, columns, time_column, skeleton, frame_time, eol, **rest):
        """The text of a file read into ``cells`` (:class:`BodyCells`: offsets, numbers and
        blank cells), the other fields as the class's (``rest``: its optional ones)."""
        return cls(
            layout,
            raw,
            cells.starts,
            cells.ends,
            cells.values,
            columns,
            time_column,
            skeleton,
            frame_time,
            eol,
            blank=cells.blank,
            notes=slow_time_notes(frame_time),
            **rest,
        )

    @property
    def n_frames(self) -> int:
        return int(self.values.shape[0])

    @property
    def no_world(self) -> str | None:
        """Why world-space figures are skipped (``core.kinematics.world_note``): a channel
        CSV read without a skeleton has no offsets, so its joints have no world places."""
        if self.layout == "channel" and self.needs_skeleton:
            return "a channel CSV holds no skeleton: --skeleton rig.bvh gives one"
        return None

    def matches(self, motion: Motion) -> bool:
        """True when ``motion`` still has the frames and joints this text describes."""
        return self.n_frames == motion.n_frames and self.skeleton == (
            tuple(motion.names),
            tuple(motion.channels),
        )


class BodyCells(NamedTuple):
    """The data rows of a CSV: ``(F, K)`` ``values`` (NaN where blank or not parsed),
    ``blank`` (an empty cell or NaN, any case), the cells' byte offsets
    ``starts``/``ends`` and each row's line number ``lines`` ``(F,)``."""

    values: np.ndarray
    blank: np.ndarray
    starts: np.ndarray
    ends: np.ndarray
    lines: np.ndarray


def _fail(message: str, path, line: int | None = None) -> NoReturn:
    raise MotionError(message, path, None if line is None else int(line))


# ----------------------------------------------------------------------------- reading


def _split_header(data: bytes, path) -> tuple[list[str], int, int]:
    """The header fields, its line number and the offset of the line after it."""
    pos = len(BOM) if data.startswith(BOM) else 0
    number = 0
    while pos < len(data):
        end = data.find(b"\n", pos)
        while end >= 0 and data.count(b'"', pos, end) % 2:  # a newline inside quotes
            end = data.find(b"\n", end + 1)
        end = len(data) if end < 0 else end + 1
        line = data[pos:end]
        number += 1 + line.count(b"\n", 0, max(len(line) - 1, 0))  # the header's last line
        pos = end
        if line.strip():
            try:
                text = line.decode("utf-8")
            except UnicodeDecodeError:
                _fail("not a text file (bytes that are not UTF-8)", path, number)
            limit = _csv.field_size_limit()
            try:  # a field may be as long as the line (a joint name of megabytes)
                _csv.field_size_limit(max(limit, len(text) + 1))
                fields = next(
                    _csv.reader([text.rstrip("\r\n")], strict=True, skipinitialspace=True)
                )
            except _csv.Error as error:
                _fail(f"bad header: {error}", path, number)
            finally:
                _csv.field_size_limit(limit)
            return [f.strip() for f in fields], number, pos
    _fail("empty file", path)


#: Channel and body suffixes as the readers spell them, by their lower-case spelling.
_SUFFIX_SPELLING = CHANNEL_SPELLING | {name.lower(): name for name in RIGID_SUFFIXES}


def _classify(fields: list[str], path, line: int):
    """Split the header into frame/time columns and ``(name, suffix, column)`` entries."""
    expected = (
        "expected a header such as 'frame,time,Hips.Xposition,...' (channel CSV) "
        "or 'time,head.px,...,head.qz' (rigid-body CSV)"
    )
    seen: set[str] = set()
    special = {"frame": -1, "time": -1}
    entries: list[tuple[str, str, int]] = []
    kinds = set()
    if len(fields) == 1 and ("\t" in fields[0] or ";" in fields[0]):
        separator = "tab" if "\t" in fields[0] else "semicolon"
        _fail(
            f"bad header: the columns are {separator}-separated; CSV is read comma-separated",
            path,
            line,
        )
    for k, field in enumerate(fields):
        if not field:
            trailing = " (a comma ends the header: remove it from every line)" * (
                k == len(fields) - 1
            )
            _fail(f"bad header: column {k + 1} has no name{trailing}", path, line)
        if "\x00" in field:  # (a NUL in the first 4,096 bytes: already "binary data")
            _fail(f"bad header: column {k + 1} ({field[:40]!r}) holds a NUL byte", path, line)
        name, dot, suffix = field.rpartition(".")
        suffix = _SUFFIX_SPELLING.get(suffix.lower(), suffix)  # (XROTATION, QW)
        special_name = field.lower() if field.lower() in special else None  # (Time, FRAME)
        column = special_name or f"{name}{dot}{suffix}"  # (the column it names, any case)
        if column in seen:
            _fail(f"bad header: column {field[:60]!r} appears twice", path, line)
        seen.add(column)
        if special_name is not None:
            special[special_name] = k
            continue
        if not dot or not name:
            _fail(
                f"bad header: column {field[:60]!r} is not <joint>.<channel> or "
                f"<body>.<px|py|pz|qw|qx|qy|qz>; {expected}",
                path,
                line,
            )
        if suffix in KNOWN_CHANNELS:
            kinds.add("channel")
        elif suffix in RIGID_SUFFIXES:
            kinds.add("rigid")
        else:
            _fail(
                f"bad header: column {field[:60]!r} has an unknown suffix {suffix[:20]!r} "
                "(a BVH channel such as Xrotation, or px py pz qw qx qy qz)",
                path,
                line,
            )
        entries.append((name, suffix, k))
    if special["time"] < 0:
        _fail(f"bad header: no 'time' column; {expected}", path, line)
    if not entries:
        _fail(f"bad header: no channel or body columns; {expected}", path, line)
    if len(kinds) > 1:
        _fail("bad header: mixes BVH channel columns and rigid-body columns", path, line)
    return kinds.pop(), entries, special["time"]


def parse_body(
    data: bytes,
    body_start: int,
    n_columns: int,
    first_line: int,
    path,
    parsed=None,
    fields: Sequence[str] = (),
    time_column: int = -1,
) -> BodyCells:
    """Parse the data rows: values of the ``parsed`` columns (all by default), which cells
    are blank, the cells' byte offsets and each row's line number (see :class:`BodyCells`).
    A value refused is said with its column's name, where ``fields`` names the columns
    (in the ``time_column``, with :func:`unix_hint`).
    """
    buf = np.frombuffer(data, dtype=np.uint8)
    starts, ends, tokens, line_starts = scan_cells(buf, body_start)
    cells_per_line = np.diff(line_starts, append=starts.size)
    is_row = (cells_per_line > 1) | (np.add.reduceat(tokens, line_starts, dtype=np.intp) > 0)
    rows = np.flatnonzero(is_row)
    if not rows.size:
        _fail("no data rows after the header", path, first_line - 1)
    bad = np.flatnonzero(cells_per_line[rows] != n_columns)
    if bad.size:
        row = rows[bad[0]]
        line = first_line + row
        first = int(line_starts[row])
        row_bytes = buf[int(starts[first]) : int(ends[first + cells_per_line[row] - 1])]
        why = ""
        if np.any(row_bytes == 13):
            why = (
                " (a carriage return (CR) alone inside this line, not followed by a line feed:"
                " two rows ran together; save the file with one kind of line end)"
            )
        elif np.any(row_bytes == ord('"')):
            why = (
                " (quoted cells: values are plain numbers with a decimal point, not quoted and"
                " without decimal commas)"
            )
        _fail(f"row has {cells_per_line[row]} columns, the header has {n_columns}{why}", path, line)
    shape = (rows.size, n_columns)
    if rows[-1] == rows.size - 1:  # no blank line but at the end: the first cells
        keep: slice | np.ndarray = slice(0, rows.size * n_columns)
    else:
        keep = np.repeat(is_row, cells_per_line)
    starts, ends, tokens = (a[keep].reshape(shape) for a in (starts, ends, tokens))
    lines = first_line + rows
    every = parsed is None
    columns = np.arange(n_columns) if every else np.unique(np.asarray(parsed, np.intp))
    flat_starts, flat_ends = starts.ravel(), ends.ravel()
    blank = (tokens == 0).ravel()
    three = np.flatnonzero(flat_ends - flat_starts == 3)  # NaN, any case: blank
    letters = buf[flat_starts[three, None] + np.arange(3)] | np.uint8(0x20)
    blank[three[np.all(letters == np.frombuffer(b"nan", dtype=np.uint8), axis=1)]] = True
    four = np.flatnonzero(flat_ends - flat_starts == 4)  # and signed, as C's printf writes it
    letters = buf[flat_starts[four, None] + np.arange(4)]
    signed = (letters[:, 0] == ord("-")) | (letters[:, 0] == ord("+"))
    nan = np.all(letters[:, 1:] | np.uint8(0x20) == np.frombuffer(b"nan", dtype=np.uint8), axis=1)
    blank[four[signed & nan]] = True
    # The parsed cells, as flat indices (None: all of them).
    chosen = None if every else (np.arange(0, starts.size, n_columns)[:, None] + columns).ravel()
    counts = tokens.ravel() if chosen is None else tokens.ravel().take(chosen)
    several = np.flatnonzero(counts > 1)
    if several.size:
        row, k = divmod(int(several[0]), columns.size)
        _fail(f"row has two values in one column (column {columns[k] + 1})", path, lines[row])
    chosen_blank = blank if chosen is None else blank.take(chosen)
    gaps = bool(chosen_blank.any())
    number = chosen
    if gaps:
        number = np.flatnonzero(~chosen_blank) if chosen is None else chosen[~chosen_blank]
    parsed_values, bad_token = parse_values(buf, flat_starts, flat_ends, number)
    if bad_token >= 0:
        at = bad_token if number is None else int(number[bad_token])
        text = buf[flat_starts[at] : flat_ends[at]].tobytes().decode("utf-8", "replace")[:40]
        column = at % n_columns
        where = f" in column {fields[column][:60]!r}" if column < len(fields) else ""
        try:
            value = ascii_float(text)
            problem = (
                "is not finite"
                if not math.isfinite(value)
                else f"is out of range (over {MAX_MAGNITUDE:g})"
            )
            if column == time_column and math.isfinite(value):
                problem += unix_hint(value)
        except ValueError:
            problem = "is not a number"
        _fail(f"value {text!r}{where} {problem}", path, lines[at // n_columns])
    if number is None:
        values = parsed_values.reshape(shape)
    else:
        values = np.full(shape, np.nan)
        values.ravel()[number] = parsed_values
    all_blank = blank.reshape(shape)
    offsets = np.int32 if buf.size < 2**31 else np.int64  # half the memory of a long take's
    return BodyCells(values, all_blank, starts.astype(offsets), ends.astype(offsets), lines)


def _channel_skeleton(entries, path, line):
    """Joint names and channel tuples, in column order, from channel column entries."""
    names: list[str] = []
    seen: set[str] = set()  # a set: a header of 100,000 columns is read in linear time
    channels: list[list[str]] = []
    columns: list[int] = []
    for name, suffix, k in entries:
        if not names or names[-1] != name:
            if name in seen:
                _fail(
                    f"bad header: the columns of joint {name[:60]!r} are not next to each other",
                    path,
                    line,
                )
            names.append(name)
            seen.add(name)
            channels.append([])
        channels[-1].append(suffix)
        columns.append(k)
    for name, joint_channels in zip(names, channels, strict=True):
        rotations = sum(c in ROTATION_CHANNELS for c in joint_channels)
        if rotations not in (0, 3):
            _fail(
                f"bad header: joint {name[:60]!r} has {rotations} rotation columns; a joint "
                "needs all three (Xrotation, Yrotation, Zrotation) or none",
                path,
                line,
            )
    return names, [tuple(c) for c in channels], np.array(columns, dtype=np.intp)


def _template_columns(entries, skeleton: Motion, path, line) -> np.ndarray:
    """CSV column of each of the template's channels, in the template's channel order."""
    where = {(name, suffix): k for name, suffix, k in entries}
    columns = []
    for name, joint_channels in zip(skeleton.names, skeleton.channels, strict=True):
        for channel in joint_channels:
            k = where.pop((name, channel), None)
            if k is None:
                _fail(f"column {name}.{channel} of the skeleton is missing", path, line)
            columns.append(k)
        csv_order = [s for n, s, _ in entries if n == name and s in ROTATION_CHANNELS]
        bvh_order = [c for c in joint_channels if c in ROTATION_CHANNELS]
        if csv_order != bvh_order:
            _fail(
                f"joint {name!r}: rotation columns in order {''.join(c[0] for c in csv_order)}"
                f" but the skeleton's order is {''.join(c[0] for c in bvh_order)}",
                path,
                line,
            )
    if where:
        name, suffix = next(iter(where))
        _fail(f"column {name}.{suffix} is not a channel of the skeleton", path, line)
    return np.array(columns, dtype=np.intp)


def check_filled(cells: BodyCells, column: int, what: str, path) -> None:
    """Refuse a blank cell (empty or NaN) in ``column`` (the time or frame column)."""
    blank = np.flatnonzero(cells.blank[:, column])
    if blank.size:
        row = blank[0]
        nan = cells.ends[row, column] > cells.starts[row, column]  # (an empty cell: no text)
        _fail(
            f"the {what} column holds NaN, not a number (it must hold a number on every row)"
            if nan
            else f"the {what} column is blank (it must hold a value on every row)",
            path,
            cells.lines[row],
        )


def missing_joints(
    cells: BodyCells, data: bytes, columns: np.ndarray, widths, names, labels, what: str, path
) -> np.ndarray:
    """``(F, J)`` bool: True where all of a joint's cells are blank (empty or NaN).

    Joint ``j`` owns ``widths[j]`` consecutive entries of ``columns`` (CSV columns);
    ``labels[k]`` names CSV column ``k``. A partly blank joint is an error naming the line,
    the joint (a ``what``) and its blank columns.
    """
    blank = cells.blank[:, columns]
    widths = np.asarray(widths, dtype=np.intp)
    if not blank.any():
        return np.zeros((blank.shape[0], widths.size), dtype=bool)
    offsets = np.cumsum(widths) - widths
    count = np.add.reduceat(blank, offsets, axis=1, dtype=np.intp)
    partial = np.argwhere((count > 0) & (count < widths))
    if partial.size:
        f, j = partial[0]
        own = columns[offsets[j] : offsets[j] + widths[j]]
        empty, nan = [], []
        for k in sorted(own[blank[f, offsets[j] : offsets[j] + widths[j]]].tolist()):
            text = data[cells.starts[f, k] : cells.ends[f, k]].decode("utf-8", "replace")
            if text:
                nan.append(f"value {text!r} is not finite ({labels[k]})")
            else:
                empty.append(labels[k])
        details = "; ".join(([f"empty value in {', '.join(empty)}"] if empty else []) + nan)
        _fail(
            f"{what} {names[j][:60]!r} is partly blank: {details} (a {what} is missing on a "
            f"row only when all its {widths[j]} cells are blank or NaN)",
            path,
            cells.lines[f],
        )
    return count == widths


def _held_channel_values(
    cells: BodyCells, data: bytes, columns, names, channels, fields, path
) -> tuple[np.ndarray, np.ndarray]:
    """``(F, C)`` channel values (missing samples held) and the ``(F, J)`` missing mask."""
    widths = [len(c) for c in channels]
    missing = missing_joints(cells, data, columns, widths, names, fields, "joint", path)
    values = cells.values[:, columns]
    if missing.any():
        per_channel = np.repeat(missing, widths, axis=1)
        values = hold_missing(values, per_channel)
        values[np.isnan(values)] = 0.0  # a joint never known: zero angles and positions
    return values, missing


def _channel_text(
    data, cells, columns, time_column, mapped, frame_time, eol, fields, template=None
) -> CsvText:
    """A channel CSV's own text as a clip's source: its cells mapped to ``mapped``
    ``(names, channels)``; ``template``, the skeleton clip it was read into (None: read
    without one, so writing BVH needs a skeleton), whose BVH hierarchy a BVH written keeps."""
    source = None if template is None else template.source
    return CsvText.of(
        "channel",
        data,
        cells,
        columns,
        time_column,
        (tuple(mapped[0]), tuple(mapped[1])),
        frame_time,
        eol,
        needs_skeleton=template is None,
        frame_column="frame" in fields,
        bvh_template=BvhText.hierarchy_only(source) if isinstance(source, BvhText) else None,
    )


def _frames(cells: BodyCells, fields: list[str]) -> np.ndarray | None:
    """The rows' numbers in a ``frame`` column, where the file has one."""
    return cells.values[:, fields.index("frame")] if "frame" in fields else None


def parse_csv(data: bytes, path=None, skeleton: Motion | None = None) -> Motion:
    """Parse a channel or rigid-body CSV (see the module docstring).

    ``skeleton`` is the template a channel CSV is read into; it is not used for a
    rigid-body CSV. Errors name ``path`` and the line.
    """
    if not data or data.isspace():  # (no copy of the file, unlike strip)
        _fail("empty file", path)
    refuse_binary(data, path)
    fields, header_line, body_start = _split_header(data, path)
    layout, entries, time_column = _classify(fields, path, header_line)
    cells = parse_body(
        data, body_start, len(fields), header_line + 1, path, fields=fields, time_column=time_column
    )
    check_filled(cells, time_column, "time", path)
    if "frame" in fields:
        check_filled(cells, fields.index("frame"), "frame", path)
    eol = b"\r\n" if data[:body_start].endswith(b"\r\n") else b"\n"
    path_text = None if path is None else str(path)
    times = cells.values[:, time_column]
    if layout == "rigid":
        return _rigid_motion(data, cells, entries, fields, time_column, eol, path, header_line)
    if skeleton is None:
        names, channels, columns = _channel_skeleton(entries, path, header_line)
        frame_time = uniform_frame_time(
            times, cells.lines, path, None, frames=_frames(cells, fields)
        )
        text = _channel_text(
            data, cells, columns, time_column, (names, channels), frame_time, eol, fields
        )
        values, missing = _held_channel_values(cells, data, columns, names, channels, fields, path)
        n = len(names)
        return Motion.from_channel_values(
            names,
            np.full(n, -1),
            np.zeros((n, 3)),
            channels,
            frame_time,
            values,
            source=text,
            path=path_text,
            missing=missing,
        )
    if getattr(skeleton.source, "needs_skeleton", False):
        _fail(
            "the skeleton template has no skeleton itself (a channel CSV); pass a BVH file",
            skeleton.path,
        )
    columns = _template_columns(entries, skeleton, path, header_line)
    frame_time = uniform_frame_time(
        times, cells.lines, path, skeleton.frame_time, frames=_frames(cells, fields)
    )
    values, missing = _held_channel_values(
        cells, data, columns, skeleton.names, skeleton.channels, fields, path
    )
    motion = Motion.from_channel_values(  # (copies: the clip shares nothing with its template)
        list(skeleton.names),
        skeleton.parents.copy(),
        skeleton.offsets.copy(),
        list(skeleton.channels),
        frame_time,
        values,
        end_sites={j: offset.copy() for j, offset in skeleton.end_sites.items()},
        path=path_text,
        missing=missing,
    )
    template = skeleton.source
    if isinstance(template, BvhText) and (
        skeleton.has_source_frames()
        and template.n_frames == motion.n_frames
        and frame_time == template.frame_time
    ):
        other_text = values != skeleton.source_values  # (an edit, or another clip)
        if other_text.any():  # the values read stay the clip's: its Euler branches
            motion.source = replace(template, other_text=other_text)
        else:
            motion.source = template
            motion.source_values = skeleton.source_values
            motion.source_rotations = skeleton.source_rotations
        return motion
    # the template's frames are not the CSV's (another take of the rig): the CSV's own text
    # is the clip's source (written back as CSV byte for byte where nothing changed), with
    # the template's hierarchy for BVH
    motion.source = _channel_text(
        data,
        cells,
        columns,
        time_column,
        (skeleton.names, skeleton.channels),
        frame_time,
        eol,
        fields,
        skeleton,
    )
    return motion


def rigid_arrays(
    cells: BodyCells, data: bytes, columns: np.ndarray, bodies: list[str], labels, path
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(rotations (F, B, 4), translations (F, B, 3), missing (F, B))`` of rigid bodies
    whose ``(B, 7)`` CSV ``columns`` follow :data:`RIGID_SUFFIXES`.

    A body is missing where its seven cells are blank (placeholders held, identity and
    zero for a body never seen); quaternions are renormalised (a norm under
    :data:`MIN_QUAT_NORM` is an error) and made sign-continuous in time.
    """
    n_bodies = len(bodies)
    missing = missing_joints(
        cells,
        data,
        columns.ravel(),
        [len(RIGID_SUFFIXES)] * n_bodies,
        bodies,
        labels,
        "body",
        path,
    )
    values = cells.values[:, columns]  # (F, B, 7)
    if missing.any():
        values = hold_missing(values, missing)
        never = missing.all(axis=0)
        values[:, never] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
    translations = values[..., :3]
    q = values[..., 3:]
    norm = np.sqrt(np.sum(q * q, axis=-1))
    tiny = norm < MIN_QUAT_NORM
    if tiny.any():
        f, b = np.argwhere(tiny)[0]
        _fail(
            f"body {bodies[b]!r}: quaternion of norm {norm[f, b]:.3g} (below "
            f"{MIN_QUAT_NORM:g}) is not a rotation",
            path,
            int(cells.lines[f]),
        )
    unit = np.abs(norm - 1.0) <= 4 * np.finfo(float).eps
    rotations = quat.make_continuous(np.where(unit[..., None], q, q / norm[..., None]), axis=0)
    return rotations, np.ascontiguousarray(translations), missing


def _rigid_motion(data, cells, entries, fields, time_column, eol, path, header_line) -> Motion:
    bodies: list[str] = []
    found: dict[str, dict[str, int]] = {}
    for name, suffix, k in entries:
        if name not in found:
            bodies.append(name)
            found[name] = {}
        found[name][suffix] = k
    columns = np.empty((len(bodies), len(RIGID_SUFFIXES)), dtype=np.intp)
    for b, name in enumerate(bodies):
        for s, suffix in enumerate(RIGID_SUFFIXES):
            if suffix not in found[name]:
                _fail(
                    f"bad header: body {name[:60]!r} has no column {name[:60]}.{suffix} "
                    "(a body needs px py pz qw qx qy qz)",
                    path,
                    header_line,
                )
            columns[b, s] = found[name][suffix]
    frame_time = uniform_frame_time(
        cells.values[:, time_column], cells.lines, path, None, frames=_frames(cells, fields)
    )
    rotations, translations, missing = rigid_arrays(cells, data, columns, bodies, fields, path)
    channels: list[tuple[str, ...]] = [RIGID_CHANNELS] * len(bodies)
    text = CsvText.of(
        "rigid",
        data,
        cells,
        columns,
        time_column,
        (tuple(bodies), tuple(channels)),
        frame_time,
        eol,
        frame_column="frame" in fields,
    )
    return tracked_bodies(
        bodies, channels, frame_time, rotations, translations, text, path, missing
    )


def tracked_bodies(
    bodies, channels, frame_time, rotations, translations, text, path, missing, up=None
) -> Motion:
    """A clip of independent tracked bodies (rigid-body CSV, Motive): each a root joint
    without offset, its rotation and translation as read, ``text`` for the writer, ``up``
    the up axis the format declares (None: found from the motion)."""
    n = len(bodies)
    return Motion(
        names=bodies,
        parents=np.full(n, -1, dtype=np.intp),
        offsets=np.zeros((n, 3)),
        channels=channels,
        frame_time=frame_time,
        rotations=rotations,
        translations=translations,
        source_rotations=rotations.copy(),
        source=text,
        path=None if path is None else str(path),
        missing=missing,
        up=up,
    )


# ----------------------------------------------------------------------------- writing


def format_repr(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shortest round-trip text (``repr``) of each value as ``(buffer, starts, lengths)``."""
    text = " ".join(map(repr, np.asarray(values, dtype=np.float64).ravel().tolist())).encode()
    buf = np.frombuffer(text, dtype=np.uint8)
    starts, ends = scan_tokens(buf)
    return buf, starts, ends - starts


def format_values(
    values: np.ndarray, decimals: int | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Texts of values as ``(buffer, starts, lengths)``: with ``decimals`` digits after the
    point (:func:`~.text.format_decimals`), or in shortest round-trip form where None."""
    return format_repr(values) if decimals is None else format_decimals(values, decimals)


def format_header(fields: list[str], eol: bytes) -> bytes:
    """The header line: fields quoted where they hold a comma, a quote, CR or LF."""
    out = _io.StringIO()
    _csv.writer(out, lineterminator="\r\n").writerow(fields)  # CR and LF then get quoted
    return out.getvalue()[:-2].encode("utf-8") + eol


class Cells:
    """Text pieces from several buffers, addressed in one concatenated buffer."""

    def __init__(self):
        self.parts: list[np.ndarray] = []
        self.size = 0

    def add(self, buf: np.ndarray, starts, lengths) -> tuple[np.ndarray, np.ndarray]:
        self.parts.append(buf)
        offset, self.size = self.size, self.size + buf.size
        return np.asarray(starts) + offset, np.asarray(lengths)

    def buffer(self) -> np.ndarray:
        return np.concatenate(self.parts) if self.parts else np.zeros(0, dtype=np.uint8)


def _rewrite(
    src: CsvText, motion: Motion, mask: np.ndarray, new: np.ndarray, missing: np.ndarray
) -> Iterable[bytes | memoryview]:
    """The source text, in pieces to write in turn, with the ``mask``ed ``(F, K)`` cells
    replaced by the values ``new`` of ``src.columns`` (blank where ``missing``, which
    broadcasts against ``new``; placed a block of rows at a time); the time column is
    rewritten too when the frame time changed."""
    is_time = np.zeros(mask.shape, dtype=bool)
    retimed = motion.frame_time != src.frame_time
    written = b"%.12g"
    if retimed:
        first = float(src.values[0, src.time_column])
        mask[:, src.time_column] = is_time[:, src.time_column] = True
        written = time_format(first, motion.frame_time, motion.n_frames)
    if not mask.any():
        return pieces(src.raw)

    def placed(rows: slice) -> np.ndarray:
        """The ``(len, K)`` values of the cells of a slice of rows (NaN: blank)."""
        out = np.zeros((new[rows].shape[0], mask.shape[1]))
        out[:, src.columns] = np.where(missing[rows], np.nan, new[rows])
        return out

    def texts(rows: slice):
        chosen = mask[rows]
        values = placed(rows)
        if retimed:
            frames = np.arange(rows.start, rows.start + values.shape[0])
            values[:, src.time_column] = first + frames * motion.frame_time
        replaced, replaced_is_time = values[chosen], is_time[rows][chosen]

        def chunk(a: int, b: int):
            """Texts of replacements ``a`` to ``b - 1``: times as :func:`time_format`,
            values their shortest round-trip text, NaN a blank cell."""
            values, timed = replaced[a:b], replaced_is_time[a:b]
            plain = ~timed & ~np.isnan(values)
            starts = np.zeros(values.size, dtype=np.int64)
            lengths = np.zeros(values.size, dtype=np.int64)
            cells = Cells()
            starts[plain], lengths[plain] = cells.add(*format_repr(values[plain]))
            if timed.any():
                times = format_fields(written, values[timed].tolist())
                starts[timed], lengths[timed] = cells.add(*times)
            return cells.buffer(), starts, lengths

        return chunk

    starts, ends = src.starts, src.ends
    row_starts = starts[:, 0] if starts.shape[1] else np.zeros(starts.shape[0], np.int64)

    def cells(rows: slice) -> tuple[np.ndarray, np.ndarray]:
        return starts[rows], ends[rows]

    return splice_cells(src.raw, row_starts, cells, mask, texts)


def _fresh(fields: list[str], eol: bytes, n_frames: int, cells) -> Iterable[bytes]:
    """The header and rows of a CSV written afresh, in pieces (:func:`table_pieces`)."""
    return table_pieces(n_frames, cells, b",", eol, format_header(fields, eol))


def _frame_and_time(motion: Motion, cells: Cells, rows: slice):
    """The frame-number and time cells of frames ``rows``, added to ``cells``."""
    first = start_time(motion)
    frames = np.arange(rows.start, rows.stop)
    numbers = cells.add(*format_fields(b"%d", frames.tolist()))
    read = read_times(motion)
    if read is not None:  # the frames read: their times' text
        return numbers, cells.add(*read(rows))
    written = time_format(first, motion.frame_time, motion.n_frames)
    times = cells.add(*format_fields(written, (first + frames * motion.frame_time).tolist()))
    return numbers, times


def format_fields(field: bytes, values) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``field % value`` for every value, as ``(buffer, starts, lengths)`` (one C-level
    formatting call for the whole column)."""
    values = tuple(values)
    text = b" ".join([field] * len(values)) % values
    buf = np.frombuffer(text, dtype=np.uint8)
    starts, ends = scan_tokens(buf)
    return buf, starts, ends - starts


def _format_channel(motion: Motion) -> Iterable[bytes | memoryview]:
    values = motion.channel_values()
    check_finite(motion, values)
    n_frames, n_channels = values.shape
    missing = np.repeat(motion.missing_mask(), [len(c) for c in motion.channels], axis=1)
    src = motion.source
    same = (
        motion.has_source_frames()
        and motion.source_values is not None
        and motion.source_values.shape[1] == n_channels
    )
    if isinstance(src, CsvText) and src.layout == "channel" and src.matches(motion) and same:
        mask = np.zeros(src.starts.shape, dtype=bool)
        moved = np.abs(values - motion.source_values) > UNCHANGED_TOLERANCE  # (NaN: blank)
        mask[:, src.columns] = _cells_to_write(moved, missing, _source_blank(src)[:, src.columns])
        return _rewrite(src, motion, mask, values, missing)

    keep_text = isinstance(src, BvhText) and same and src.n_frames == n_frames
    decimals = getattr(src, "decimals", None)  # an OpenSim file's (its values' layout)

    def fill(rows: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        cells = Cells()
        block = values[rows]
        starts = np.zeros((block.shape[0], n_channels + 2), dtype=np.int64)
        lengths = np.zeros_like(starts)
        fresh = ~missing[rows]
        if keep_text:  # unchanged values keep the BVH's text
            assert motion.source_values is not None
            kept = (block == motion.source_values[rows]) & fresh
            if src.other_text is not None:  # (a CSV read into another take: its own values)
                kept &= ~src.other_text[rows]
            fresh &= ~kept
            if kept.any():
                read_starts, read_ends = src.cells(rows)
                low, high = int(read_starts[kept].min()), int(read_ends[kept].max())
                region = np.frombuffer(sliceable(src.raw)[low:high], np.uint8)
                starts[:, 2:][kept], lengths[:, 2:][kept] = cells.add(
                    region, read_starts[kept] - low, (read_ends - read_starts)[kept]
                )
        starts[:, 2:][fresh], lengths[:, 2:][fresh] = cells.add(
            *format_values(block[fresh], decimals)
        )
        (starts[:, 0], lengths[:, 0]), (starts[:, 1], lengths[:, 1]) = _frame_and_time(
            motion, cells, rows
        )
        return cells.buffer(), starts[:, first:], lengths[:, first:]

    # a CSV read without a frame column is written without one (it had gained one)
    first = 1 if isinstance(src, CsvText) and not src.frame_column else 0
    fields = ["frame", "time"][first:] + [
        f"{motion.names[j]}.{channel}"
        for j in range(motion.n_joints)
        for channel in motion.channels[j]
    ]
    return _fresh(fields, _eol(src), n_frames, fill)


def _source_blank(src: CsvText) -> np.ndarray:
    return np.zeros(src.starts.shape, dtype=bool) if src.blank is None else src.blank


def _cells_to_write(changed: np.ndarray, missing: np.ndarray, was_blank: np.ndarray):
    """Cells to rewrite in the source text: a missing sample where the source had a value
    (it becomes blank), a known one where it changed or the source cell was blank. A
    sample missing in both keeps the source's text."""
    return np.where(missing, ~was_blank, changed | was_blank)


def _eol(source) -> bytes:
    return source.eol if isinstance(source, BvhText | CsvText) else b"\n"


def rewrite_rigid(src: CsvText, motion: Motion) -> Iterable[bytes | memoryview]:
    """``src``'s text, in pieces, with the values of ``motion`` (the same frames and
    bodies, read from ``src``) put in: unchanged values keep their text, missing samples
    are blank."""
    assert motion.source_rotations is not None
    q, t = motion.rotations, motion.translations
    read = src.values[:, src.columns]  # (F, B, 7) as in the file, NaN where blank
    read_q = motion.source_rotations  # q and -q are the same rotation; rounding is no change
    q_changed = ~same_rotations(q, read_q)
    t_changed = np.abs(t - read[..., :3]) > UNCHANGED_TOLERANCE  # (NaN: blank)
    sign = np.where(np.sum(q * read[..., 3:], axis=-1) < 0.0, -1.0, 1.0)
    new = np.concatenate([t, q * sign[..., None]], axis=-1)
    missing = motion.missing_mask()[..., None]
    changed = np.concatenate([t_changed, np.repeat(q_changed[..., None], 4, axis=-1)], axis=-1)
    mask = np.zeros(src.starts.shape, dtype=bool)
    mask[:, src.columns] = _cells_to_write(changed, missing, _source_blank(src)[:, src.columns])
    return _rewrite(src, motion, mask, new, missing)


def rigid_values(motion: Motion) -> np.ndarray:
    """``(F, B, 7)`` values in :data:`RIGID_SUFFIXES` order of a clip of independent
    bodies (an error for a joint hierarchy); finite (checked)."""
    q, t = motion.rotations, motion.translations
    values = np.concatenate([t, q], axis=-1)
    check_finite(motion, values.reshape(len(q), -1), [len(RIGID_SUFFIXES)] * motion.n_joints)
    if np.any(motion.parents >= 0):
        raise MotionError(
            "a rigid-body CSV holds independent bodies, but this clip has a "
            "joint hierarchy; write a channel CSV instead",
            motion.path,
        )
    return values


def value_cells(cells: Cells, block: np.ndarray, blank: np.ndarray, lead: int):
    """``(starts, lengths)`` ``(R, lead + K)`` of a block of ``(R, K)`` values printed
    (shortest round trip) into ``cells`` after ``lead`` columns left for the caller; the
    ``blank`` ``(R, K)`` cells empty."""
    starts = np.zeros((block.shape[0], block.shape[1] + lead), dtype=np.int64)
    lengths = np.zeros_like(starts)
    starts[:, lead:], lengths[:, lead:] = (
        a.reshape(block.shape) for a in cells.add(*format_repr(block))
    )
    lengths[:, lead:][blank] = 0
    return starts, lengths


def _format_rigid(motion: Motion) -> Iterable[bytes | memoryview]:
    src = motion.source
    values = rigid_values(motion)
    if (
        isinstance(src, CsvText)
        and src.layout == "rigid"
        and src.matches(motion)
        and motion.source_rotations is not None
    ):
        return rewrite_rigid(src, motion)
    n_frames, n_bodies = values.shape[:2]
    values = values.reshape(n_frames, 7 * n_bodies)
    blank = np.repeat(motion.missing_mask(), len(RIGID_SUFFIXES), axis=1)

    # a rigid-body CSV read with a frame column keeps one (renumbered from 0)
    lead = 2 if isinstance(src, CsvText) and src.layout == "rigid" and src.frame_column else 1

    def fill(rows: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        cells = Cells()
        starts, lengths = value_cells(cells, values[rows], blank[rows], lead)
        numbers, times = _frame_and_time(motion, cells, rows)
        starts[:, lead - 1], lengths[:, lead - 1] = times
        if lead == 2:
            starts[:, 0], lengths[:, 0] = numbers
        return cells.buffer(), starts, lengths

    fields = ["frame", "time"][2 - lead :]
    fields += [f"{name}.{s}" for name in motion.names for s in RIGID_SUFFIXES]
    return _fresh(fields, _eol(src), n_frames, fill)


def format_csv(motion: Motion, layout: str | None = None) -> bytes:
    """Serialise ``motion`` as CSV bytes (:func:`csv_pieces` joined)."""
    return b"".join(csv_pieces(motion, layout))


def csv_pieces(motion: Motion, layout: str | None = None) -> Iterable[bytes | memoryview]:
    """``motion`` as CSV, in pieces to write one after the other (made as they are asked
    for: no copy of the whole text): ``layout`` ``"channel"`` or ``"rigid"``.

    By default a clip read from a rigid-body CSV is written as one, every other clip as a
    channel CSV. Unchanged values keep the input's text (see the module docstring).
    """
    if motion.n_frames < 2:
        raise MotionError(
            f"a CSV needs at least two frames (its time column gives the frame time); "
            f"this clip has {motion.n_frames}",
            motion.path,
        )
    if layout is None:
        src = motion.source
        layout = src.layout if isinstance(src, CsvText) else "channel"
        layout = "rigid" if layout == "motive" else layout
    if layout == "rigid":
        return _format_rigid(motion)
    if layout == "channel":
        return _format_channel(motion)
    raise ValueError(f"layout must be 'channel' or 'rigid', got {layout!r}")
