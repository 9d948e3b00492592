"""OptiTrack Motive CSV exports (format 1.2x): rigid bodies read as joints, the rest carried.

A Motive export starts with ``Format Version,`` (after an optional UTF-8 byte-order mark)::

    Format Version,1.23,Take Name,walk,...,Export Frame Rate,120.000000,...,Rotation Type,...

    ,Type,Rigid Body,Rigid Body,...,Rigid Body,Marker,Marker,Marker
    ,Name,head,head,...,head,M1,M1,M1
    ,ID,1,1,...,1,2,2,2
    ,,Rotation,Rotation,Rotation,Rotation,Position,Position,Position,Mean Marker Error,...
    Frame,Time (Seconds),X,Y,Z,W,X,Y,Z,,X,Y,Z
    0,0.000000,0.011302,-0.050931,0.007001,0.998611,0.012345,1.621002,0.034015,0.0002,0.1,1.7,0
    1,0.008333,,,,,,,,,0.1,1.7,0

(eight ``Rigid Body`` cells per body: Rotation X Y Z W, Position X Y Z, Mean Marker Error).
Line 1 holds ``key,value`` pairs; ``Rotation Type`` must be ``Quaternion`` (an Euler
export is refused) and ``Export Frame Rate`` gives the frame rate, which the ``Time``
column must follow (uniform within 10 % of a frame, as in :mod:`motionclean.io.csv`; a
column written in coarser steps, whole milliseconds at 240 fps, to within its steps over
consecutive frames: :func:`_coarse_times`).
Then come the ``,Type``, ``,Name`` and optional ``,ID`` and ``,Parent`` rows (Motive 3,
format 1.25, writes the latter), the property row (its first two cells empty) and the axis
row ``Frame,Time (Seconds),...``. The header rows may
appear in any order; a header row shorter than the axis row counts as ending in empty cells.
Motive 1.21 may leave out the labels (``,,Rigid Body,...``): four unlabelled rows are read
by their places as Type, Name, ID and property (:func:`_by_position`). A row of commas
alone is blank (Excel and LibreOffice save a blank line so).

Every ``Rigid Body`` becomes a joint: an independent root (parent -1, no offset) whose
rotation is the quaternion of its ``Rotation`` columns, read as X Y Z W into our
``(w, x, y, z)`` (renormalised, sign-continuous in time), and whose translation is its
``Position`` columns in the export's ``Length Units`` (said as ``m``, ``cm`` or ``mm``
where they are Meters, Centimeters or Millimeters); as BVH it gets the channels of a
rigid-body CSV body. The clip is Y up (:data:`UP`: Motive's default, which its header does
not state). A rigid body needs exactly Rotation over X, Y, Z, W and Position over
X, Y, Z; a property row that says otherwise is refused naming its line. Every other column
(markers, rigid-body markers, Mean Marker Error, Marker Quality, skeleton ``Bone`` columns,
unknown types) is carried through as text and never parsed; the bones are named in a note
(an export of bones alone is refused saying they are not read). Blank cells are
occlusions: a rigid body whose seven cells are blank (or NaN) on a row is missing on that
frame (``Motion.missing``); a partly blank one is an error. The Frame and Time cells are
never blank. The rows must be as many as ``Total Exported Frames`` says (a file cut at a
line end is refused, as BVH is).

Writing a clip read from a Motive export (``save(motion, "out.csv")``): with the same
frames, bodies and frame rate, the input text is reused (header rows byte for byte,
carried columns untouched, unchanged values with their text, changed ones in shortest
round-trip repr, missing samples blank), so an untouched export is written back byte for
byte. When the frame count or rate changed (a resampled clip), the old carried columns no
longer describe the frames: the file is written with its rigid bodies only, the metadata
line keeping every field but ``Export Frame Rate`` and ``Total Exported Frames``.
"""

from __future__ import annotations

import csv as _csv
import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import NoReturn

import numpy as np

from ..core.errors import MotionError
from ..core.motion import MAX_FRAME_TIME, MIN_FRAME_TIME, RATES_ACCEPTED, Motion
from ..core.words import plural
from .bvh import BOM
from .csv import (
    RIGID_CHANNELS,
    Cells,
    CsvText,
    check_filled,
    format_fields,
    format_header,
    parse_body,
    rewrite_rigid,
    rigid_arrays,
    rigid_values,
    tracked_bodies,
    value_cells,
)
from .files import refuse_binary
from .text import ascii_float, stated_count, table_pieces
from .timegrid import TIME_TOLERANCE, uniform_frame_time, written_step

#: What every Motive export starts with (after an optional byte-order mark).
SIGNATURE = b"Format Version,"
#: Rotation Type values of Euler exports (refused: their angles need the export's order).
EULER_TYPES = frozenset(("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"))
#: A rigid body's ``(property, axis)`` cells in the order of ``csv.RIGID_SUFFIXES``.
BODY_CELLS = (
    ("Position", "X"),
    ("Position", "Y"),
    ("Position", "Z"),
    ("Rotation", "W"),
    ("Rotation", "X"),
    ("Rotation", "Y"),
    ("Rotation", "Z"),
)
#: Motive's own column order of a rigid body: Rotation X Y Z W, Position X Y Z (indices
#: into :data:`BODY_CELLS`).
WRITE_ORDER = (4, 5, 6, 3, 0, 1, 2)
#: Labels of the header rows above the axis row (``""``: the property row; ``Parent``:
#: Motive 3's, format 1.25, empty for rigid bodies).
HEADER_ROWS = ("Type", "Name", "ID", "Parent", "")
#: The header rows of a Motive 1.21 export that labels none of them (``,,Rigid Body,...``),
#: by position.
UNLABELLED_ROWS = ("Type", "Name", "ID", "")
#: Motive's world is Y up (its default; an export's header does not say): the clip's
#: declared up axis (``Motion.up``, ``--up`` overrides it).
UP = "y"
#: The ``Length Units`` of Motive's exports, as lengths are said (``core.words.length_word``);
#: another value leaves the positions in the file's units, unsaid.
LENGTH_UNITS = {"meters": "m", "centimeters": "cm", "millimeters": "mm"}
#: Header lines read at most before the axis row must have appeared.
MAX_HEADER_LINES = 64


def is_motive(data: bytes) -> bool:
    """True when ``data`` starts like a Motive export (``Format Version,``)."""
    return data.removeprefix(BOM).startswith(SIGNATURE)


@dataclass(frozen=True, eq=False)
class MotiveText(CsvText):
    """A Motive export as read: :class:`~motionclean.io.csv.CsvText` (``layout="motive"``,
    ``columns`` ``(B, 7)`` in the order of
    :data:`~motionclean.io.csv.RIGID_SUFFIXES`) plus what a fresh write needs:
    the metadata fields of line 1 (``key, value, key, value, ...``), the header rows' labels
    in file order, the cells of each header row and of the axis row over each body's seven
    columns in Motive's order (by body name) and the axis row's first two cells."""

    metadata: tuple[str, ...] = ()
    row_labels: tuple[str, ...] = ()
    unlabelled: bool = False  # (header rows without their labels: Motive 1.21)
    notes: tuple[str, ...] = ()  # what the reader assumed (``core.kinematics.source_notes``)
    #: The up axis the clip declares (:data:`UP`, None once the user gives one:
    #: :func:`motionclean.io.declare_up`) and where it comes from (``info`` says it).
    assumed_up: str | None = UP
    up_source = "Motive's default; the export does not say: --up gives another"
    body_cells: tuple[dict[str, tuple[str, ...]], ...] = ()
    axis_head: tuple[str, ...] = ("Frame", "Time (Seconds)")
    #: The positions' unit as the metadata's ``Length Units`` says it (:data:`LENGTH_UNITS`),
    #: else None (``core.kinematics.length_unit``).
    length_unit: str | None = None


def _fail(message: str, path, line: int | None = None) -> NoReturn:
    raise MotionError(message, path, None if line is None else int(line))


def _fields(line: bytes, number: int, path) -> list[str]:
    try:
        text = line.decode("utf-8")
    except UnicodeDecodeError:
        _fail("not a text file (bytes that are not UTF-8)", path, number)
    try:
        fields = next(_csv.reader([text.rstrip("\r\n")], strict=True), [])
    except _csv.Error as error:
        _fail(f"bad header: {error}", path, number)
    for k, field in enumerate(fields):
        if "\x00" in field:  # (a NUL in the first 4,096 bytes: already "binary data")
            _fail(f"bad header: column {k + 1} ({field[:40]!r}) holds a NUL byte", path, number)
    return fields


def _header_lines(data: bytes, path) -> tuple[list[tuple[int, list[str]]], int, bytes]:
    """The header lines ``(number, fields)`` up to the axis row (blank ones left out), the
    offset of the first data line and the line ending."""
    pos = len(BOM) if data.startswith(BOM) else 0
    lines: list[tuple[int, list[str]]] = []
    for number in range(1, MAX_HEADER_LINES + 1):
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end + 1
        line, pos = data[pos:end], end
        if line.translate(None, b", \t\r\n"):  # (a row of commas: blank, as Excel saves it)
            fields = _fields(line, number, path)
            lines.append((number, fields))
            if number > 1 and fields[:1] == ["Frame"]:
                return lines, pos, b"\r\n" if line.endswith(b"\r\n") else b"\n"
            if number > 1 and fields[:1] != [""]:
                break
        if pos >= len(data):
            break
    _fail(
        "no axis row 'Frame,Time (Seconds),X,Y,...' after the ',Type' / ',Name' / ',ID' / "
        "property rows (not a Motive CSV export)",
        path,
        number,
    )


def _frame_rate(metadata: dict[str, str], path) -> float:
    """The frame time (s) from the metadata line; Quaternion exports only."""
    rotation = metadata.get("Rotation Type")
    if rotation is None:
        _fail(
            "no Rotation Type in the metadata line (export with Rotation Type Quaternion)", path, 1
        )
    if rotation.strip().upper() in EULER_TYPES:
        _fail(
            f"Rotation Type {rotation.strip()} is Euler angles, which are not read; export "
            "with Rotation Type Quaternion",
            path,
            1,
        )
    if rotation.strip() != "Quaternion":
        _fail(f"unknown Rotation Type {rotation[:40]!r} (expected Quaternion)", path, 1)
    text = metadata.get("Export Frame Rate")
    if text is None:
        _fail("no Export Frame Rate in the metadata line", path, 1)
    try:
        rate = ascii_float(text.strip(" "))
    except ValueError:
        _fail(f"Export Frame Rate is not a number: {text[:40]!r}", path, 1)
    if not (math.isfinite(rate) and 1.0 / MAX_FRAME_TIME <= rate <= 1.0 / MIN_FRAME_TIME):
        _fail(
            f"Export Frame Rate {text[:40]} is no usable frame rate ({RATES_ACCEPTED})",
            path,
            1,
        )
    return 1.0 / rate


def _by_position(header: list[tuple[int, list[str]]], path) -> list[tuple[int, list[str]]]:
    """The header rows with the labels of their places when more than one has no label in
    its second cell (``,,Rigid Body,...``, as Motive 1.21 may write them): the four rows of
    :data:`UNLABELLED_ROWS`, the first holding no property and the last some; else refused."""
    bare = [number for number, fields in header if fields[1:2] in ([], [""])]
    if len(bare) < 2:
        return header
    if len(bare) < len(header):
        _fail(
            f"a second header row without a label (first at line {bare[0]}): only the "
            "property row (',,Rotation,...') goes without one; label the others ',Type', "
            "',Name', ',ID' or ',Parent'",
            path,
            bare[1],
        )
    words = ({"Rotation", "Position"} & {c.strip() for c in fields} for _, fields in header)
    said = [bool(w) for w in words]
    if len(header) != len(UNLABELLED_ROWS) or said[0] or not said[-1]:
        _fail(
            f"{len(header)} header rows without a label (',,...'): the rows of a Motive 1.21 "
            "export without labels are read by their places only as the four rows Type, "
            "Name, ID and property (',,Rotation,...'), in that order; label the rows "
            "(',Type,...', ',Name,...', ',ID,...')",
            path,
            bare[0],
        )
    return [
        (number, ["", label, *fields[2:]])
        for (number, fields), label in zip(header, UNLABELLED_ROWS, strict=True)
    ]


def _header_rows(lines, path) -> tuple[dict[str, tuple[int, list[str]]], tuple[str, ...]]:
    """The rows above the axis row by label (``Type``, ``Name``, ``ID``, ``Parent``, ``""``;
    unlabelled rows by their places, :func:`_by_position`), each as ``(line, fields)``
    padded to the axis row's width, and the labels in file order."""
    axis_line, axis = lines[-1]
    if len(axis) == 2 and axis[1].startswith("Time"):
        _fail(
            "no rigid body or marker columns: the export holds frames and times only",
            path,
            axis_line,
        )
    if len(axis) < 3 or not axis[1].startswith("Time"):
        _fail("the axis row must start with 'Frame,Time (Seconds),'", path, axis_line)
    rows: dict[str, tuple[int, list[str]]] = {}
    order: list[str] = []
    for number, fields in _by_position(lines[1:-1], path):
        label = fields[1] if len(fields) > 1 else ""
        if label not in HEADER_ROWS or (label == "" and len(fields) < 3):
            _fail(
                f"unexpected header row {','.join(fields)[:60]!r} (expected ',Type,...', "
                "',Name,...', ',ID,...', ',Parent,...' or the property row ',,Rotation,...')",
                path,
                number,
            )
        if label in rows:
            _fail(
                f"a second {label or 'property'} row (first at line {rows[label][0]})", path, number
            )
        if len(fields) > len(axis):
            _fail(
                f"header row has {len(fields)} columns, the axis row has {len(axis)}", path, number
            )
        rows[label] = (number, fields + [""] * (len(axis) - len(fields)))
        order.append(label)
    for label in ("Type", "Name", ""):
        if label not in rows:
            what = f"',{label},...' row" if label else "property row (',,Rotation,...')"
            _fail(f"no {what} above the axis row", path, axis_line)
    return rows, tuple(order)


def _shown(names: list[str]) -> str:
    """The first three of ``names`` for a message."""
    return ", ".join(name[:40] for name in names[:3]) + (" ..." if len(names) > 3 else "")


def _bodies(rows, axis: list[str], path):
    """Body names, their ``(B, 7)`` columns in :data:`BODY_CELLS` order and the names of
    the skeleton bones (``Bone`` columns: not read)."""
    types, names = rows["Type"][1], rows["Name"][1]
    ids = rows["ID"][1] if "ID" in rows else [""] * len(axis)
    properties = rows[""][1]
    cells: dict[str, dict[tuple[str, str], int]] = {}
    body_ids: dict[str, str] = {}
    bones: dict[str, None] = {}  # (skeleton bones, in order: carried, not read)
    for k in range(2, len(axis)):
        if types[k].strip() == "Bone":
            bones[names[k]] = None
        if types[k].strip() != "Rigid Body":
            continue
        name = names[k]
        if not name:
            _fail(f"rigid body column {k + 1} has no name", path, rows["Name"][0])
        if body_ids.setdefault(name, ids[k]) != ids[k]:
            _fail(
                f"two rigid bodies named {name[:60]!r} (IDs {body_ids[name][:20]} and "
                f"{ids[k][:20]})",
                path,
                rows["ID"][0],
            )
        key = (properties[k].strip(), axis[k].strip())
        own = cells.setdefault(name, {})
        if key in own and key[0] in ("Rotation", "Position"):
            _fail(
                f"rigid body {name[:60]!r} has its columns twice ({' '.join(key)} in columns "
                f"{own[key] + 1} and {k + 1}): two rigid bodies with the same name and ID? "
                "Rename one in Motive",
                path,
                rows["Name"][0],
            )
        own[key] = k
    if not cells and bones:
        _fail(
            "no rigid bodies: skeleton (Bone) data is not read, only rigid bodies (the Type "
            f"row has {plural(len(bones), 'bone')}, {_shown(list(bones))}, and no 'Rigid Body' "
            "column)",
            path,
            rows["Type"][0],
        )
    if not cells:
        _fail("no rigid bodies (no 'Rigid Body' column in the Type row)", path, rows["Type"][0])
    columns = np.empty((len(cells), len(BODY_CELLS)), dtype=np.intp)
    for b, (name, own) in enumerate(cells.items()):
        found = [own.get(key, -1) for key in BODY_CELLS]
        used = sum(p in ("Rotation", "Position") for p, _ in own)
        if min(found) < 0 or used != len(BODY_CELLS):
            said = {
                p: ",".join(a or "(none)" for q, a in own if q == p) or "no column"
                for p in ("Rotation", "Position")
            }
            _fail(
                f"the property row does not match the axis row: rigid body {name[:60]!r} has "
                f"Rotation over {said['Rotation']} and Position over {said['Position']} (a "
                "rigid body needs Rotation over X, Y, Z, W and Position over X, Y, Z)",
                path,
                rows[""][0],
            )
        columns[b] = found
    return list(cells), columns, list(bones)


def _check_count(stated: str | None, lines: np.ndarray, path) -> None:
    """Refuse rows not as many as ``Total Exported Frames`` says (a file cut at a line end,
    or rows added), as a BVH whose ``Frames:`` is not its rows is refused."""
    if stated is None:
        return
    count = stated_count(stated)
    if count is None:
        _fail(f"Total Exported Frames is not a whole number: {stated[:40]!r}", path, 1)
    if lines.size < count:
        _fail(
            f"the file ends after {plural(int(lines.size), 'frame row')} but Total Exported "
            "Frames says "
            f"{count} (the file is cut short)",
            path,
            int(lines[-1]),
        )
    if lines.size > count:
        _fail(f"more frame rows than Total Exported Frames {count}", path, int(lines[count]))


def _check_frame_numbers(frames: np.ndarray, lines: np.ndarray, path) -> None:
    """Refuse a Frame column that does not count the rows one by one from its first
    number (Motive numbers every exported frame: a row lost, repeated or edited)."""
    if frames.size and not float(frames[0]).is_integer():
        _fail(f"frame number {frames[0]:g} is not a whole number", path, int(lines[0]))
    wrong = np.flatnonzero(np.diff(frames) != 1.0)
    if wrong.size:
        at = int(wrong[0]) + 1
        _fail(
            f"frame {frames[at]:.10g} follows frame {frames[at - 1]:.10g}: the Frame column "
            "must count the rows one by one (a row lost, repeated or edited: export the take "
            "again)",
            path,
            int(lines[at]),
        )


def _coarse_times(times: np.ndarray, frames: np.ndarray, frame_time: float) -> tuple[float, int]:
    """The step of a Time column written coarser than a tenth of a frame (whole milliseconds
    at 240 fps: Motive 1.23 writes 0.004, 0.008, 0.012, 0.016, ... for 1/240 s steps), and
    -1 when its times are those of the frames at ``frame_time`` to within that step, rounded
    or cut (the times less ``(frame - first frame) * frame_time`` spread by one step at
    most; the frames are consecutive, :func:`_check_frame_numbers`), else the row furthest
    off; ``(0, -1)`` for any other time column (checked as in a CSV)."""
    if times.size < 2:
        return 0.0, -1
    step = written_step(times)
    if not TIME_TOLERANCE * frame_time < step < frame_time:
        return 0.0, -1
    off = times - (frames - frames[0]) * frame_time
    if float(off.max() - off.min()) <= step + 1e-9 * max(1.0, float(np.abs(times).max())):
        return step, -1
    return step, int(np.argmax(np.abs(off - np.median(off))))


def parse_motive(data: bytes, path=None) -> Motion:
    """Parse a Motive CSV export (see the module docstring); errors name ``path`` and the
    line."""
    refuse_binary(data, path)
    lines, body_start, eol = _header_lines(data, path)
    first = lines[0][1]
    pairs = zip(first[0::2], first[1::2], strict=False)
    metadata = {key.strip(): value for key, value in reversed(list(pairs))}  # first one wins
    frame_time = _frame_rate(metadata, path)
    rows, order = _header_rows(lines, path)
    axis_line, axis = lines[-1]
    bodies, columns, bones = _bodies(rows, axis, path)
    cells = parse_body(
        data, body_start, len(axis), axis_line + 1, path, parsed=[0, 1, *columns.ravel()]
    )
    _check_count(metadata.get("Total Exported Frames"), cells.lines, path)
    check_filled(cells, 0, "Frame", path)
    check_filled(cells, 1, "Time", path)
    _check_frame_numbers(cells.values[:, 0], cells.lines, path)
    times = cells.values[:, 1]
    notes: list[str] = []
    if bones:
        notes.append(
            f"{plural(len(bones), 'skeleton bone')} ({_shown(bones)}: Bone columns) carried as "
            "they are, not read: only rigid bodies are"
        )
    on_grid = np.abs(times - times[0] - np.arange(times.size) * frame_time)
    coarse, worst = 0.0, -1
    if not np.all(on_grid <= TIME_TOLERANCE * frame_time):
        coarse, worst = _coarse_times(times, cells.values[:, 0], frame_time)
    if worst >= 0:
        _fail(
            f"the Time column does not follow Export Frame Rate {metadata['Export Frame Rate']}"
            f" and the Frame column: time {times[worst]:.6g} s is off its frame's time by more "
            f"than the column's steps of {coarse:g} s (the frames' times differ by more than "
            "their rounding: not uniformly sampled: export the take again)",
            path,
            cells.lines[worst],
        )
    if coarse:
        notes.append(
            f"the Time column is in steps of {coarse:g} s, coarser than a tenth of a frame: "
            f"the frames are timed by Export Frame Rate {metadata['Export Frame Rate']} and "
            "the Frame column (the times agree with them to their last digit)"
        )
    elif uniform_frame_time(times, cells.lines, path, frame_time) != frame_time:
        grid = times[0] + np.arange(times.size) * frame_time
        off = int(np.argmax(np.abs(times - grid) > TIME_TOLERANCE * frame_time))
        _fail(
            f"the Time column does not follow Export Frame Rate {metadata['Export Frame Rate']}:"
            f" time {times[off]:.6g} s is more than {TIME_TOLERANCE:.0%} of a frame off the "
            f"grid of {frame_time:.6g} s steps",
            path,
            cells.lines[off],
        )
    labels = [f"{rows[''][1][k]} {axis[k]} (column {k + 1})".strip() for k in range(len(axis))]
    rotations, translations, missing = rigid_arrays(cells, data, columns, bodies, labels, path)
    channels: list[tuple[str, ...]] = [RIGID_CHANNELS] * len(bodies)
    in_order = columns[:, list(WRITE_ORDER)]  # (B, 7) columns in Motive's order
    body_cells = tuple(
        {name: tuple(fields[k] for k in own) for name, own in zip(bodies, in_order, strict=True)}
        for fields in [rows[label][1] for label in order] + [axis]
    )
    text = MotiveText(
        "motive",
        data,
        cells.starts,
        cells.ends,
        cells.values,
        columns,
        1,
        (tuple(bodies), tuple(channels)),
        frame_time,
        eol,
        blank=cells.blank,
        metadata=tuple(first),
        row_labels=order,
        unlabelled=sum(fields[1:2] in ([], [""]) for _, fields in lines[1:-1]) > 1,
        body_cells=body_cells,
        axis_head=tuple(axis[:2]),
        notes=tuple(notes),
        length_unit=LENGTH_UNITS.get(metadata.get("Length Units", "").strip().lower()),
    )
    return tracked_bodies(
        bodies, channels, frame_time, rotations, translations, text, path, missing, up=UP
    )


def motive_pieces(motion: Motion) -> Iterable[bytes | memoryview]:
    """A clip read from a Motive export as a Motive export (module docstring), in pieces to
    write one after the other."""
    src = motion.source
    if not isinstance(src, MotiveText):
        raise ValueError("motive_pieces writes clips read from a Motive export")
    values = rigid_values(motion)
    if (
        src.matches(motion)
        and motion.frame_time == src.frame_time
        and motion.source_rotations is not None
    ):
        return rewrite_rigid(src, motion)
    if motion.n_frames < 1:
        raise MotionError("a Motive export needs at least one frame", motion.path)
    n_frames, n_bodies = values.shape[:2]
    rate = b"%.6f" % motion.frame_rate
    changed = {"Export Frame Rate": rate.decode(), "Total Exported Frames": str(n_frames)}
    metadata = list(src.metadata)
    for at in range(0, len(metadata) - 1, 2):  # a few metadata fields
        metadata[at + 1] = changed.get(metadata[at].strip(), metadata[at + 1])
    # Each header row over a body's columns as read (a body the file did not hold: its
    # type, name, properties and axes, the rest empty).
    fallback = {
        "Type": lambda name: ["Rigid Body"] * len(BODY_CELLS),
        "Name": lambda name: [name] * len(BODY_CELLS),
        "": lambda name: [BODY_CELLS[i][0] for i in WRITE_ORDER],
        "axis": lambda name: [BODY_CELLS[i][1] for i in WRITE_ORDER],
    }
    header = [format_header(metadata, src.eol), src.eol]
    for label, read in zip([*src.row_labels, "axis"], src.body_cells, strict=True):
        written = "" if src.unlabelled else label
        fields = ["", written] if label != "axis" else list(src.axis_head)
        for name in motion.names:
            fields += read.get(name) or fallback.get(label, lambda name: [""] * 7)(name)
        header.append(format_header(fields, src.eol))

    ordered = values[:, :, list(WRITE_ORDER)].reshape(n_frames, -1)
    blank = np.repeat(motion.missing_mask(), len(BODY_CELLS), axis=1)
    first_frame, first_time = int(src.values[0, 0]), float(src.values[0, 1])

    def fill(rows: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        cells = Cells()
        starts, lengths = value_cells(cells, ordered[rows], blank[rows], 2)
        frames = np.arange(rows.start, rows.start + starts.shape[0])
        starts[:, 0], lengths[:, 0] = cells.add(
            *format_fields(b"%d", (first_frame + frames).tolist())
        )
        times = (first_time + frames * motion.frame_time).tolist()
        starts[:, 1], lengths[:, 1] = cells.add(*format_fields(b"%.6f", times))
        return cells.buffer(), starts, lengths

    return table_pieces(n_frames, fill, b",", src.eol, b"".join(header))
