"""OpenSim motion and storage files (``.mot``, ``.sto``): joint coordinates over time.

::

    Coordinates
    version=1
    nRows=3
    nColumns=4
    inDegrees=yes
    endheader
    time	pelvis_tilt	pelvis_tx	knee_angle_r
        0.00000000	-2.44998000	0.12000000	3.51000000
    ...

A header of any lines up to ``endheader``, then a line of column labels and one row of
whitespace-separated numbers per sample; the first column is ``time`` (seconds, uniformly
sampled: a step more than 10 % off the mean is refused, resample first). ``inDegrees=yes``
says rotational coordinates are in degrees, ``no`` in radians; without the line they are
read as radians, as OpenSim does (a note says so).

Each coordinate becomes a root joint of the clip named after its column. A translational
coordinate (named ``*_tx``, ``*_ty``, ``*_tz``, as OpenSim names them) is a position along
that axis (``Xposition`` ...; metres); any other is a rotation by its angle about a fixed
axis, the joint's Z axis (``Zrotation Xrotation Yrotation``, the two others zero): filters
on that quaternion signal act on the angle itself, and it stays a rotation about Z.
In a states file only the coordinates' values are read (:func:`coordinate_name`); marker
positions (:func:`is_marker`), speeds, muscle states and controls (:func:`is_other_state`),
and columns of forces (:data:`LOADS`) and errors (:data:`ERRORS`) are carried as text (a
file of nothing else is refused), as are those the user excludes (``exclude``: fnmatch
patterns), never parsed: carried columns may share a name (two force plates' columns),
coordinates may not. ``NaN`` cells (any case) are missing samples (``Motion.missing``).
Tables of OpenSim's tools and analyses that hold no coordinate values are refused, saying
what they hold: speeds, accelerations, tracking errors, actuator forces, controls ... by
their title (:data:`NOT_COORDINATES`), a table of actuators by its residual or reserve
actuators' columns (:data:`ACTUATORS`; of those not excluded), bodies' kinematics by their
columns.

Writing a clip read from such a file keeps the header and every cell that did not change
byte for byte (excluded columns included; a value that moved by at most 1e-9 of its unit
counts as unchanged, as for BVH); a changed value is written with the decimals the file's
coordinates use (the most any cell has; shortest round-trip form for a file that writes
exponents), in the file's unit and on the branch (whole turns) nearest the value read.
A file written afresh gives its values the decimals of the ``.mot``, ``.sto`` or channel
CSV the clip was read from, and its time column's text while the frames are the file's
(:func:`.text.read_times`). When the frame count changed (resampled), the rows are written
afresh and ``nRows`` is updated. ``nRows`` is never trusted: the rows present are read, a
count that differs is said in a note and written as the true one (in an otherwise
untouched file too). A last row that repeats the one before it byte for byte (RRA's) is
no frame: written back after the last row, repeating it as written, or left out of a file
written afresh.
"""

from __future__ import annotations

import fnmatch
import functools
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import numpy as np

from ..core import quat
from ..core.errors import MotionError
from ..core.motion import UNCHANGED_TOLERANCE, Motion, hold_missing, joint_major_zeros
from ..core.regrid import grid_refusal, regridded
from ..core.words import plural
from .csv import Cells, CsvText, format_repr, format_values
from .files import pieces, refuse_binary
from .text import (
    bad_number_message,
    decimals_of,
    line_ends,
    parse_values,
    read_times,
    scan_tokens,
    splice_cells,
    start_time,
    stated_count,
    table_pieces,
)
from .timegrid import off_grid, uniform_frame_time

#: Channels of a rotational coordinate (a rotation about Z) and of a translational one.
ROTATIONAL = ("Zrotation", "Xrotation", "Yrotation")
TRANSLATIONAL = {"tx": ("Xposition",), "ty": ("Yposition",), "tz": ("Zposition",)}
#: Header lines read at most before ``endheader``.
MAX_HEADER_LINES = 1000


@dataclass(frozen=True, eq=False)
class OpenSimText:
    """A ``.mot``/``.sto`` as read: its bytes, the header's end (where the labels line
    starts), the labels, the unit of angles, the ``(F, K)`` byte ranges of the cells and
    values of the coordinate columns (NaN where missing), and which columns the clip's
    joints are (``columns[j]``)."""

    raw: bytes
    body: int
    labels: tuple[str, ...]
    in_degrees: bool
    row_starts: np.ndarray
    starts: np.ndarray
    ends: np.ndarray
    values: np.ndarray
    columns: np.ndarray
    eol: bytes
    notes: tuple[str, ...] = ()
    stated_rows: str | None = None  # the header's nRows as written (None: no such line)
    regridded: bool = False  # rows put on a uniform grid: the file's cells are not the clip's
    stated_columns: str | None = None  # the header's nColumns as written (None: no such line)
    frame_time: float = math.nan  # seconds, as read
    #: The last row repeats the one before it (RRA's): its cells are the last row of
    #: ``row_starts``, ``starts`` and ``ends``, which hold one row more than ``values``.
    repeated: bool = False

    @property
    def time_cells(self) -> tuple[float, np.ndarray, np.ndarray] | None:
        """The frame time and the byte ranges of the time cells, which writers keep
        (:func:`.text.read_times`); None for rows put on a grid (not the clip's)."""
        if self.regridded:
            return None
        return self.frame_time, self.starts[: self.n_frames, 0], self.ends[: self.n_frames, 0]

    @property
    def stale_counts(self) -> bool:
        """Whether the header's nRows or nColumns miss what the file holds (any output
        then says the counts it writes)."""
        rows, columns = self.stated_rows, self.stated_columns
        return (rows is not None and stated_count(rows) != self.n_rows) or (
            columns is not None and stated_count(columns) != len(self.labels)
        )

    @property
    def n_frames(self) -> int:
        return int(self.values.shape[0])

    @property
    def n_rows(self) -> int:
        """The rows of numbers the file holds: the frames, and a repeated last row."""
        return int(self.starts.shape[0])

    @property
    def start_time(self) -> float:
        """Seconds at the first row (:func:`.text.start_time`); 0 without rows."""
        return float(self.values[0, 0]) if self.values.shape[0] else 0.0

    @functools.cached_property
    def decimals(self) -> int | None:
        """The most digits after the point among the coordinates' cells: the decimals every
        writer gives the clip's values (None: written in shortest round-trip form)."""
        return decimals_of(self.raw, self.starts[:, self.columns], self.ends[:, self.columns])

    #: Why world-space figures are skipped (``core.kinematics.world_note``).
    no_world = "OpenSim coordinates are joint angles without the model's bodies"
    #: Translational coordinates are metres, OpenSim's unit (``core.kinematics.length_unit``).
    length_unit = "m"
    #: Coordinates make no skeleton: BVH output is refused with this message.
    needs_skeleton = True
    no_skeleton_message = (
        "OpenSim coordinates have no skeleton (the model's bodies are not in the file); "
        "write .mot, .sto or CSV"
    )


def _fail(message: str, path, line: int | None = None) -> NoReturn:
    raise MotionError(message, path, line)


def _header(data: bytes, path) -> tuple[int, int, dict[str, tuple[str, int]], bytes]:
    """The offset after ``endheader``, its line number, the ``key=value`` pairs (each value
    with its line number) and the line ending."""
    pos, number = 0, 0
    pairs: dict[str, tuple[str, int]] = {}
    eol = b"\r\n" if b"\r\n" in data[:4096] else b"\n"
    while pos < len(data):
        number += 1
        if number > MAX_HEADER_LINES:
            break
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end + 1
        line = data[pos:end].strip()
        pos = end
        if line.lower() == b"endheader":
            return pos, number, pairs, eol
        key, eq, value = line.partition(b"=")
        if eq:
            text = value.strip().decode("utf-8", "replace")
            pairs[key.strip().decode("utf-8", "replace").lower()] = (text, number)
    within = f" in the first {MAX_HEADER_LINES} lines" if number > MAX_HEADER_LINES else ""
    _fail(f"no 'endheader' line{within}: not an OpenSim .mot/.sto", path)


def _in_degrees(pairs: dict[str, tuple[str, int]], path) -> tuple[bool, str | None]:
    if "indegrees" not in pairs:
        return False, "no inDegrees line: angles read as radians, as OpenSim does"
    value, line = pairs["indegrees"]
    if value.lower() in ("yes", "true", "1"):
        return True, None
    if value.lower() in ("no", "false", "0"):
        return False, None
    _fail(f"inDegrees={value[:20]!r}: expected yes or no", path, line)


def coordinate_name(label: str) -> str:
    """The coordinate a column label names: ``pelvis_tx`` of an OpenSim 4 state path
    ``/jointset/ground_pelvis/pelvis_tx/value``, else the label itself."""
    parts = label.split("/")
    return parts[-2] if len(parts) > 2 and parts[-1] == "value" else label


def is_translational(label: str) -> int:
    """The axis (0-2) of a translational coordinate's column, else -1: a name one of whose
    words after the first (split at ``_``) is ``tx``, ``ty`` or ``tz``, as OpenSim models
    name them (``pelvis_tx``; ``sh_tx_r``, ``tib_tx_r``, ``pat_ty_r`` with the side after
    it), also as a state path (``.../pelvis_tx/value``); the last such word."""
    words = [word.lower() for word in coordinate_name(label).split("_")[1:]]
    axes = [word for word in words if word in TRANSLATIONAL]
    return "xyz".index(axes[-1][1]) if axes else -1


def is_other_state(label: str, labels: set[str]) -> bool:
    """Whether a states file's column is a state other than a coordinate's value: a speed
    or a muscle's state (activation, fiber length ...), named as OpenSim 4 names state
    paths (``.../pelvis_tilt/speed``, ``/forceset/soleus/activation``: any path not ending
    in ``/value``) or as earlier versions did (``pelvis_tilt_u`` beside ``pelvis_tilt``,
    ``soleus.activation``)."""
    if "/" in label:
        return label.rsplit("/", 1)[-1] != "value"
    return "." in label or (label.endswith("_u") and label[:-2] in labels)


def is_marker(label: str) -> bool:
    """Whether a column is a marker's position along an axis, as SIMM motion files name
    markers (``R.ASIS_tx``: a dotted name ending ``_tx``, ``_ty`` or ``_tz``)."""
    return "/" not in label and "." in label and is_translational(label) >= 0


#: Column names of external loads (ground reaction forces, their points of application
#: and torques, as OpenSim names them): not coordinates, carried as text.
LOADS = ("*force*", "*torque*", "*moment*", "*_p[xyz]")
#: Column names of errors (inverse kinematics' ``_ik_marker_errors.sto``:
#: ``total_squared_error``, ``marker_error_RMS``, ``marker_error_max``): not coordinates.
ERRORS = ("*error*",)
#: Rotational coordinates of a file that says radians hold degrees (OpenSim's CMC writes
#: its ``*_q.sto`` with ``inDegrees=no``) where the median column reaches beyond this many
#: radians (half a turn: no joint angle does, most stay within a quarter) ...
DEGREES_IN_RADIANS = math.pi
#: ... or moves faster than this (radians per second, the 99th percentile of its steps:
#: a kick's knee reaches about 30).
DEGREES_IN_RADIANS_PER_S = 60.0


#: The kinds of columns carried as text, never parsed, in the order they are told apart:
#: what a note calls them, and what a file of nothing else is said to hold (None: errors,
#: which the message names).
CARRIED: dict[str, str | None] = {
    "marker positions": "marker positions",
    "states or controls other than coordinate values (speeds, muscles)": (
        "speeds and muscle states"
    ),
    "forces, torques or points of application": (
        "forces, torques and points of application (an external loads file, or inverse "
        "dynamics' generalized forces)"
    ),
    "errors (not coordinates)": None,
}


def _sorted_columns(
    labels: list[str], columns: list[int]
) -> tuple[list[int], dict[str, list[int]]]:
    """The coordinates among ``columns`` and the others, by kind (:data:`CARRIED`)."""
    every = set(labels)
    tests = (  # (in the order of CARRIED)
        is_marker,
        lambda label: is_other_state(label, every),
        lambda label: any(fnmatch.fnmatchcase(label.lower(), p) for p in LOADS),
        lambda label: any(fnmatch.fnmatchcase(label.lower(), p) for p in ERRORS),
    )
    carried: dict[str, list[int]] = {kind: [] for kind in CARRIED}
    kept: list[int] = []
    for c in columns:
        kind = next((k for k, test in zip(CARRIED, tests, strict=True) if test(labels[c])), None)
        (kept if kind is None else carried[kind]).append(c)
    return kept, carried


def _check_coordinates(
    labels: list[str], kept: list[int], carried: dict[str, list[int]], path, line: int
) -> None:
    """Refuse a file without coordinates (saying what it holds instead) and a coordinate
    named twice; carried columns may share a name (two force plates' ``ground_force_vx``)."""
    if not kept:
        kind = next(kind for kind, columns in carried.items() if columns)
        what = CARRIED[kind] or (
            f"errors ({', '.join(labels[c][:40] for c in carried[kind][:3])}: inverse "
            "kinematics' marker errors, not angles)"
        )
        _fail(f"no coordinate columns: {what} are no motion to clean", path, line)
    names = [labels[c] for c in [0, *kept]]
    if len(set(names)) != len(names):
        twice = next(name for name in names if names.count(name) > 1)
        _fail(
            f"coordinate column {twice[:60]!r} appears twice: rename one, or carry both as "
            "text (--exclude)",
            path,
            line,
        )


#: What a refusal of a table that holds no coordinates says is read instead.
READ_INSTEAD = (
    "only coordinate values are read (an inverse kinematics .mot, a *_Kinematics_q.sto, a "
    "states .sto)"
)


def _refuse_data_type(pairs: dict[str, tuple[str, int]], path) -> None:
    """OpenSim 4 tables of vectors or rotations (``DataType=Vec3``, ``Quaternion``, ...)
    hold no coordinates."""
    kind, line = pairs.get("datatype", ("double", 0))
    if kind.lower() not in ("double", "float"):
        _fail(
            f"DataType={kind[:20]}: a table of {kind[:20]} values per column (markers, "
            f"forces or IMU orientations), not coordinates; {READ_INSTEAD}",
            path,
            line,
        )


_MUSCLES = "muscle quantities, a column per muscle (the MuscleAnalysis' output)"
#: Bytes of the first line read for a title.
MAX_TITLE = 4096
#: Titles (the header's first line) of the tables OpenSim's tools and analyses write that
#: hold no coordinate values, though their columns may bear the coordinates' names (speeds,
#: tracking errors) or the muscles' (forces), and what each holds. Matched with case and
#: spaces aside (fnmatch patterns: a MuscleAnalysis moment table is titled after its
#: coordinate); any other title is free text (IK writes ``Coordinates``, as does the
#: Kinematics analysis for its ``*_q.sto``; states files the trial's name) and says nothing.
NOT_COORDINATES: dict[str, str] = {
    "Speeds": "the coordinates' speeds (the Kinematics analysis' *_Kinematics_u.sto)",
    "Accelerations": "the coordinates' accelerations (the Kinematics analysis' *_dudt.sto)",
    "PositionErrors": "CMC's or RRA's errors in tracking the coordinates (*_pErr.sto)",
    "VelocityErrors": "CMC's or RRA's errors in tracking the coordinates' speeds",
    "ActuatorForces": "actuator forces, a column per muscle or actuator (*_Actuation_force.sto)",
    "ActuatorSpeeds": "actuator speeds, a column per muscle or actuator (*_Actuation_speed.sto)",
    "ActuatorPowers": "actuator powers, a column per muscle or actuator (*_Actuation_power.sto)",
    "controls": "controls, a column per muscle or actuator (CMC's *_controls.sto)",
    "Static Optimization": "muscle activations or forces (StaticOptimization's output)",
    "ModelForces": "the model's forces (the ForceReporter's output)",
    "ModelProbes": "probe values, e.g. metabolic rates (the ProbeReporter's output)",
    "Joint Reaction Loads": "joint reaction loads (the JointReaction analysis' output)",
    "PointPosition": "a point's position in the ground frame (the PointKinematics analysis)",
    "PointVelocity": "a point's velocity in the ground frame (the PointKinematics analysis)",
    "PointAcceleration": "a point's acceleration (the PointKinematics analysis)",
    "Model Marker Locations from IK": "the model's marker positions (inverse kinematics)",
    **{
        title: _MUSCLES
        for title in (
            "Length", "FiberLength", "NormalizedFiberLength", "TendonLength",
            "FiberVelocity", "NormFiberVelocity", "PennationAngle",
            "PennationAngularVelocity", "TendonForce", "FiberForce", "ActiveFiberForce",
            "PassiveFiberForce", "ActiveFiberForceAlongTendon",
            "PassiveFiberForceAlongTendon", "FiberActivePower", "FiberPassivePower",
            "TendonPower", "MuscleActuatorPower", "MomentArm_*", "Moment_*",
        )
    },
}  # fmt: skip
#: Column names of actuators no coordinate bears, as OpenSim's CMC and RRA examples name
#: them: the residual forces and moments on the pelvis and the reserve actuators of each
#: coordinate (``hip_flexion_r_reserve``; ``reserve_...`` as OpenSim 4 scripts add them).
#: A table with one holds a value per actuator and muscle (its forces, speeds, powers or
#: controls), whatever its title.
ACTUATORS = ("FX", "FY", "FZ", "MX", "MY", "MZ", "*_reserve", "reserve_*")


def _plain_title(title: str) -> str:
    """A title with case and spaces aside (``Static Optimization``: ``staticoptimization``)."""
    return "".join(title.split()).lower()


def _title(data: bytes) -> str:
    """The header's first line when it is a title (not ``key=value`` nor ``endheader``),
    else ""."""
    line = data[:MAX_TITLE].partition(b"\n")[0].strip().decode("utf-8", "replace")
    return "" if "=" in line or line.lower() == "endheader" else line


def _refuse_results(title: str, columns: list[str], path, line: int) -> None:
    """Refuse a table that holds no coordinate values: one of :data:`NOT_COORDINATES` by
    its title (the file's line 1), or one with :data:`ACTUATORS` among the ``columns`` (those
    read: the labels on ``line`` the user did not exclude), saying what it holds."""
    plain = _plain_title(title)
    known = next((k for k in NOT_COORDINATES if fnmatch.fnmatchcase(plain, _plain_title(k))), None)
    if known is not None:
        _fail(
            f"titled {title[:40]!r}: {NOT_COORDINATES[known]}, not coordinate values; "
            + READ_INSTEAD,
            path,
            1,
        )
    actuators = [c for c in columns if any(fnmatch.fnmatchcase(c, p) for p in ACTUATORS)]
    if actuators:
        shown = ", ".join(a[:40] for a in actuators[:3]) + (" ..." if len(actuators) > 3 else "")
        _fail(
            f"actuator columns ({shown}): a value per muscle or actuator (forces, speeds, "
            "powers or controls of CMC, RRA or the Actuation analysis), not coordinate values; "
            f"{READ_INSTEAD}; --exclude leaves such columns out of a table of coordinates "
            f"(--exclude {actuators[0][:40]})",
            path,
            line,
        )


#: What OpenSim's BodyKinematics analysis names each body's columns: its centre of mass's
#: position and its body-fixed X-Y-Z Euler angles in the ground frame.
BODY_KINEMATICS = ("_X", "_Y", "_Z", "_Ox", "_Oy", "_Oz")


def _refuse_body_kinematics(labels: list[str], path, line: int) -> None:
    """A BodyKinematics table (every column after ``time`` one of a body's six,
    :data:`BODY_KINEMATICS`, some body with all six; the whole body's ``center_of_mass``
    has its position alone) holds bodies' poses in the ground frame, not coordinates:
    refused, naming the file to clean instead."""
    columns = set(labels[1:])
    bodies = {c[: -len(end)] for c in columns for end in BODY_KINEMATICS if c.endswith(end)}
    whole = any(all(body + end in columns for end in BODY_KINEMATICS) for body in bodies)
    if whole and all(c.endswith(BODY_KINEMATICS) for c in columns):
        _fail(
            "body kinematics (each body's position _X/_Y/_Z and orientation _Ox/_Oy/_Oz in "
            "the ground frame, OpenSim's BodyKinematics output), not coordinates: clean the "
            "inverse kinematics' .mot of the trial instead",
            path,
            line,
        )


def _empty_cell(data: bytes, line_start: np.ndarray, line: int) -> int | None:
    """The column (0-based) of the first empty tab-separated cell of the body's ``line``
    (two tabs in a row, or a tab that starts it; tabs that end a line end no cell), or
    None."""
    end = int(line_start[line + 1]) if line + 1 < line_start.size else len(data)
    cells = data[int(line_start[line]) : end].rstrip(b"\r\n\t ").split(b"\t")
    empty = [i for i, cell in enumerate(cells) if not cell.strip()]
    return empty[0] if empty else None


def parse_opensim(data: bytes, path, exclude: Iterable[str] = (), regrid: bool = False) -> Motion:
    """A clip of an OpenSim ``.mot``/``.sto`` file's bytes (see the module). ``regrid``:
    rows at uneven times (a simulation's) are put on a uniform grid, not refused."""
    refuse_binary(data, path)
    body, header_lines, pairs, eol = _header(data, path)
    _refuse_data_type(pairs, path)
    in_degrees, note = _in_degrees(pairs, path)
    buf = np.frombuffer(data, dtype=np.uint8)
    newlines = line_ends(buf, body)
    line_start = np.concatenate([[body], newlines + 1])
    line_start = line_start[line_start < len(data)]
    starts, ends = scan_tokens(buf, body)
    line_of = np.searchsorted(line_start, starts, side="right") - 1
    counts = np.bincount(line_of, minlength=line_start.size)
    used = np.flatnonzero(counts)  # lines with tokens (blank lines skipped)
    if used.size == 0:
        _fail("no column labels after endheader", path, header_lines + 1)
    first_token = np.cumsum(counts) - counts
    label_line = used[0]
    k = int(counts[label_line])
    labels_at = slice(int(first_token[label_line]), int(first_token[label_line]) + k)
    try:
        labels = [
            bytes(buf[a:b]).decode("utf-8")
            for a, b in zip(starts[labels_at], ends[labels_at], strict=True)
        ]
    except UnicodeDecodeError:
        _fail("column labels are not UTF-8 text", path, header_lines + 1 + label_line)
    number_of = lambda line: header_lines + 1 + int(line)  # noqa: E731  (file line numbers)
    if labels[0].lower() != "time":
        _fail(
            f"the first column is {labels[0][:40]!r}, expected 'time'", path, number_of(label_line)
        )
    _refuse_body_kinematics(labels, path, number_of(label_line))
    patterns = list(exclude)
    kept = [c for c in range(1, k) if not any(fnmatch.fnmatchcase(labels[c], p) for p in patterns)]
    _refuse_results(_title(data), [labels[c] for c in kept], path, number_of(label_line))
    empty = _empty_cell(data, line_start, label_line)
    if empty is not None:
        _fail(f"column {empty + 1} has no name (two tabs in a row)", path, number_of(label_line))
    rows = used[1:]
    bad = rows[counts[rows] != k]
    if bad.size:
        line = int(bad[0])
        empty = _empty_cell(data, line_start, line)
        if empty is not None and empty < k:
            _fail(
                f"an empty cell in column {labels[empty][:60]!r} (two tabs in a row): write a "
                "number, or NaN for a missing sample",
                path,
                number_of(line),
            )
        _fail(
            f"{int(counts[line])} values on this row, expected {k} (one per column)",
            path,
            number_of(line),
        )
    if rows.size < 2:
        _fail("fewer than two rows of data", path)
    stated = pairs.get("nrows", (None, 0))[0]
    cell = (first_token[rows][:, None] + np.arange(k)).astype(np.intp)  # (F, K) token index
    cell_starts, cell_ends = starts[cell], ends[cell]
    if k == 1:
        _fail("only a time column: no coordinates to clean", path, number_of(label_line))
    if not kept:
        _fail("no coordinate columns (all excluded)", path, number_of(label_line))
    kept, carried = _sorted_columns(labels, kept)
    _check_coordinates(labels, kept, carried, path, number_of(label_line))
    notes = [] if note is None else [note]
    stated_columns = pairs.get("ncolumns", (None, 0))[0]
    if stated_columns is not None and stated_count(stated_columns) != k:
        notes.append(
            f"nColumns={stated_columns[:20]} but the file holds {k} columns: any output says "
            f"nColumns={k}"
        )
    if stated is not None and stated_count(stated) != rows.size:
        last = bytes(buf[cell_starts[-1, -1] : cell_ends[-1, -1]]).decode("utf-8", "replace")
        notes.append(_rows_note(stated, rows.size, data.endswith(b"\n"), last, labels[-1]))
    repeated = _repeats_last(data, line_start, rows)
    if repeated:
        notes.append(
            f"the last row repeats the one before it byte for byte (as RRA ends its results): "
            f"read as one frame, {rows.size - 1} in all; written back after the last row, "
            "repeating it as written (a file written afresh leaves it out)"
        )
    for what, columns in carried.items():
        if columns:
            shown = ", ".join(labels[c] for c in columns[:3])
            more = " ..." if len(columns) > 3 else ""
            notes.append(
                f"{plural(len(columns), 'column')} of {what} carried as text ({shown}{more}): "
                "written back only to an OpenSim file at the clip's own frames (not by "
                "convert to another format, nor by resample)"
            )
    parsed = np.array([0, *kept], dtype=np.intp)
    nan = _nan_cells(buf, cell_starts[:, parsed], cell_ends[:, parsed])
    if nan[:, 0].any():
        _fail("the time is NaN", path, number_of(rows[int(np.argmax(nan[:, 0]))]))
    flat = np.flatnonzero(~nan.ravel())
    values = np.full(nan.shape, np.nan)
    found, bad_at = parse_values(
        buf, cell_starts[:, parsed].ravel(), cell_ends[:, parsed].ravel(), flat
    )
    if bad_at >= 0:
        f, c = divmod(int(flat[bad_at]), parsed.size)
        token = bytes(buf[cell_starts[f, parsed[c]] : cell_ends[f, parsed[c]]])
        _fail(
            bad_number_message(f"column {labels[parsed[c]][:60]!r}", token),
            path,
            number_of(rows[f]),
        )
    values.ravel()[flat] = found
    values = values[: rows.size - repeated]  # (the repeated row is no frame)
    times, coords = values[:, 0], values[:, 1:]
    regrid_rows = regrid and bool(np.all(np.diff(times) > 0)) and off_grid(times)
    if regrid_rows:
        frame_time, coords = _on_grid(times, coords, path)
        notes.append(
            f"time steps of {np.diff(times).min():.3g}-{np.diff(times).max():.3g} s (a "
            f"simulation's integrator steps): put on a grid of about the median step, "
            f"{frame_time:.6g} s, by a cubic through the samples"
        )
    else:
        lines = np.array([number_of(r) for r in rows[: times.size]])
        advice = _uneven_advice(times, coords)
        frame_time = uniform_frame_time(times, lines, path, None, advice, advice)
    missing = np.isnan(coords)
    names = [labels[c] for c in kept]
    axes = np.array([is_translational(name) for name in names], dtype=np.intp)
    if not in_degrees and _holds_degrees(coords[:, axes < 0], frame_time):
        in_degrees = True
        said = "the header says radians (inDegrees=no)" if note is None else "no inDegrees line"
        notes = [n for n in notes if n != note]  # (no "read as radians" left beside it)
        notes.append(
            f"angles read as degrees: {said}, but most "
            "rotational coordinates reach beyond half a turn or move faster than "
            f"{DEGREES_IN_RADIANS_PER_S:g} rad/s read so (OpenSim's CMC writes its *_q.sto "
            "that way)"
        )
    text = OpenSimText(
        data,
        int(line_start[label_line]),
        tuple(labels),
        in_degrees,
        line_start[rows].astype(np.int64),
        cell_starts,
        cell_ends,
        values,
        np.array(kept, dtype=np.intp),
        eol,
        tuple(notes),
        stated,
        regrid_rows,
        stated_columns,
        frame_time,
        repeated,
    )
    return coordinates_motion(names, axes, coords, frame_time, in_degrees, missing, text, path)


def _rows_note(stated: str, n_rows: int, line_ended: bool, last: str, label: str) -> str:
    """The note on ``nRows=stated`` over the ``n_rows`` rows a file holds; one that holds
    fewer and ends without a line end was cut inside its last row, perhaps inside its last
    value (``last``, of column ``label``), which the note shows."""
    said = f"nRows={stated[:20]} but the file holds {n_rows} rows"
    read = f"the {n_rows} are read, and any output says nRows={n_rows}"
    if (stated_count(stated) or 0) <= n_rows:
        return f"{said}: {read}"
    if line_ended:
        return f"{said} (cut short?): {read}"
    return (
        f"{said} and ends inside the last one, with no line end: cut short, its last value "
        f"({label[:40]!r}: {last[:40]}) perhaps cut too; {read}"
    )


def _repeats_last(data: bytes, line_start: np.ndarray, rows: np.ndarray) -> bool:
    """Whether the last of three or more ``rows`` (line indices) repeats the row before it
    byte for byte (its line end aside), as OpenSim's RRA ends its results."""
    if rows.size < 3:
        return False
    ends = np.append(line_start[1:], len(data))
    last, before = (data[line_start[r] : ends[r]].rstrip(b"\r\n") for r in rows[-2:][::-1])
    return last == before


#: What an unevenly sampled OpenSim file is told to do (it is read so by ``resample``).
SIMULATION_ADVICE = (
    "`motionclean resample FILE OUT --fps N` puts it on a uniform grid (a simulation's "
    "states, written at its integrator's steps)"
)


def _uneven_advice(times: np.ndarray, coords: np.ndarray) -> str:
    """What a file whose rows are not a fixed time apart is told: :data:`SIMULATION_ADVICE`
    where ``resample`` puts its rows on a grid, else what would (a gap of 100 s in 10 s of
    rows had been sent to ``resample``, which refuses more than 8 frames per row)."""
    why = grid_refusal(times) if times.size > 1 else None
    if why is None and not np.isnan(coords).any():
        return SIMULATION_ADVICE
    return (
        "give every frame its row at a fixed rate (nan cells mark a dropout, which the "
        "fill-gaps step fills), or cut the file at a gap into takes of their own; "
        f"`motionclean resample` would refuse it: {why or 'some cells are missing'}"
    )


def _on_grid(times: np.ndarray, coords: np.ndarray, path) -> tuple[float, np.ndarray]:
    """The frame time and ``coords`` ``(F, C)`` sampled at uneven ``times`` put on a
    uniform grid (:func:`motionclean.core.regrid.regridded`); refused with a missing cell."""
    if np.isnan(coords).any():
        _fail("time steps are uneven and some cells are missing: nothing to put on a grid", path)
    try:
        return regridded(times, coords)
    except ValueError as error:
        _fail(str(error), path)


def _holds_degrees(angles: np.ndarray, frame_time: float) -> bool:
    """Whether rotational coordinates ``(F, C)`` said to be radians hold degrees: the median
    column's largest magnitude beyond :data:`DEGREES_IN_RADIANS`, or its fast steps beyond
    :data:`DEGREES_IN_RADIANS_PER_S`."""
    known = ~np.isnan(angles)
    seen = known.all(axis=0)  # (columns with dropouts left out)
    if not seen.any():  # (the reader has two rows at least)
        return False
    columns = angles[:, seen]
    largest = np.abs(columns).max(axis=0)
    speed = np.percentile(np.abs(np.diff(columns, axis=0)), 99, axis=0) / frame_time
    return bool(
        np.median(largest) > DEGREES_IN_RADIANS or np.median(speed) > DEGREES_IN_RADIANS_PER_S
    )


def _nan_cells(buf: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """``(F, K)`` True where a cell reads ``nan`` in any case."""
    three = (ends - starts) == 3
    letters = [buf.take(starts + i, mode="clip") | np.uint8(32) for i in range(3)]
    return three & (letters[0] == ord("n")) & (letters[1] == ord("a")) & (letters[2] == ord("n"))


def coordinates_motion(names, axes, coords, frame_time, in_degrees, missing, text, path) -> Motion:
    """A clip of independent coordinates: rotational ones as rotations about Z (angles in
    degrees or radians), translational ones as positions along their axis."""
    n_frames, n = coords.shape
    if missing.any():
        coords = hold_missing(coords[..., None], missing)[..., 0]
        coords[:, missing.all(axis=0)] = 0.0
    rotational = axes < 0
    angles = coords[:, rotational] if in_degrees is False else np.deg2rad(coords[:, rotational])
    rotations = np.zeros((n_frames, n, 4))
    rotations[..., 0] = 1.0
    rotations[:, rotational, 0] = np.cos(0.5 * angles)
    rotations[:, rotational, 3] = np.sin(0.5 * angles)
    rotations = quat.continuous(rotations)
    translations = joint_major_zeros(n_frames, n)
    for axis in range(3):
        on = np.flatnonzero(axes == axis)
        translations[:, on, axis] = coords[:, on]
    channels: list[tuple[str, ...]] = [
        ROTATIONAL if a < 0 else TRANSLATIONAL["t" + "xyz"[a]] for a in axes
    ]
    return Motion(
        names=list(names),
        parents=np.full(n, -1, dtype=np.intp),
        offsets=np.zeros((n, 3)),
        channels=channels,
        frame_time=frame_time,
        rotations=rotations,
        translations=translations,
        source=text,
        path=None if path is None else str(path),
        missing=missing if missing.any() else None,
    )


def coordinate_values(motion: Motion, in_degrees: bool, reference: np.ndarray | None) -> np.ndarray:
    """``(F, J)`` coordinate values of a clip of independent coordinates: the angle of each
    rotational joint's rotation about its Z axis (its twist, in degrees or radians, on the
    whole turn nearest ``reference`` where given, else unwrapped along time) and each
    translational joint's position along its axis."""
    axes = _axes_of(motion)
    q = motion.rotations
    angle = 2.0 * np.arctan2(q[..., 3], q[..., 0])  # radians, the twist about Z
    turn = 2.0 * math.pi
    if reference is not None:
        ref = reference if not in_degrees else np.deg2rad(reference)
        ref = np.where(np.isnan(ref), angle, ref)
        angle = angle + turn * np.round((ref - angle) / turn)
    else:
        angle = np.unwrap(angle, axis=0)
    values = np.rad2deg(angle) if in_degrees else angle
    for axis in range(3):
        on = axes == axis
        values[:, on] = motion.translations[:, on, axis]
    return values


def _axes_of(motion: Motion) -> np.ndarray:
    """Per joint: the axis of its one position channel (a translational coordinate), else -1.
    Only clips of independent coordinates (one position channel, or three rotation channels
    with Z first) are written."""
    axes = np.full(motion.n_joints, -1, dtype=np.intp)
    for j, channels in enumerate(motion.channels):
        if len(channels) == 1 and channels[0].endswith("position"):
            axes[j] = "XYZ".index(channels[0][0])
        elif tuple(channels) != ROTATIONAL or motion.parents[j] >= 0:
            raise MotionError(
                "an OpenSim file holds independent coordinates (rotations about one axis, "
                f"positions along one); joint {motion.names[j]!r} has channels "
                f"{' '.join(channels)}",
                motion.path,
            )
    return axes


def opensim_pieces(motion: Motion) -> Iterable[bytes | memoryview]:
    """``motion`` as an OpenSim file: its own file with changed cells replaced (the input
    bytes when nothing changed), or written afresh (see the module)."""
    src = motion.source
    if (
        not isinstance(src, OpenSimText)
        or src.regridded
        or src.n_frames != motion.n_frames
        or src.columns.size != motion.n_joints
    ):
        return _fresh(motion, src if isinstance(src, OpenSimText) else None)
    reference = src.values[:, 1:]
    values = coordinate_values(motion, src.in_degrees, reference)
    missing = motion.missing_mask()
    # an angle read and turned into a quaternion comes back within 1e-14 of itself
    moved = np.abs(values - np.nan_to_num(reference)) > UNCHANGED_TOLERANCE
    was_missing = np.isnan(reference)
    changed = (moved & ~missing) | (was_missing != missing)
    stale = src.stale_counts
    if not changed.any() and not stale:
        return pieces(src.raw)
    new_text = np.where(missing, np.nan, values)
    if src.repeated:  # the repeated last row repeats the last row as written
        changed, new_text = (np.concatenate([a, a[-1:]]) for a in (changed, new_text))
    mask = np.zeros(src.starts.shape, dtype=bool)
    mask[:, src.columns] = changed

    def texts(rows: slice):
        chosen = new_text[rows][changed[rows]]

        def chunk(a: int, b: int):
            return format_values(chosen[a:b], src.decimals)

        return chunk

    return splice_cells(
        src.raw,
        src.row_starts,
        lambda rows: (src.starts[rows], src.ends[rows]),
        mask,
        texts,
        start=src.body if stale else 0,
        prefix=_counted(src.raw[: src.body], {b"nrows": src.n_rows, b"ncolumns": len(src.labels)})
        if stale
        else b"",
    )


def _counted(head: bytes, counts: dict[bytes, int]) -> bytes:
    """The header ``head`` with the ``key=value`` lines of ``counts`` (lower-case keys) saying
    those counts, every other byte kept."""

    def counted(line: bytes) -> bytes:
        key, eq, _ = line.partition(b"=")
        if not eq or key.strip().lower() not in counts:
            return line
        end = b"\r" if line.endswith(b"\r") else b""
        return key + b"=" + str(counts[key.strip().lower()]).encode() + end

    return b"\n".join(counted(line) for line in head.split(b"\n"))


def _fresh(motion: Motion, src: OpenSimText | None) -> Iterable[bytes]:
    """A new file: the source's header (``nRows`` and ``nColumns`` updated; its excluded
    columns, which no longer describe the frames, left out) or a plain one, then every
    row from the source's first time (or 0)."""
    in_degrees = True if src is None else src.in_degrees
    values = coordinate_values(motion, in_degrees, None)
    values[motion.missing_mask()] = np.nan
    times = start_time(motion) + np.arange(motion.n_frames) * motion.frame_time
    if times.size:  # 12 significant digits, as the CSV writer gives them
        largest = max(float(np.abs(times).max()), motion.frame_time)
        times = np.round(times, 12 - math.ceil(math.log10(largest)))
    eol = b"\n" if src is None else src.eol
    if src is None:
        head = (
            f"{Path(motion.path).stem if motion.path else 'motion'}\nversion=1\n"
            f"nRows={motion.n_frames}\n"
            f"nColumns={motion.n_joints + 1}\ninDegrees={'yes' if in_degrees else 'no'}\n"
            "endheader\n"
        ).encode()
    else:
        counts = {b"nrows": motion.n_frames, b"ncolumns": motion.n_joints + 1}
        head = _counted(src.raw[: src.body], counts)
    labels = "\t".join(["time", *motion.names]).encode("utf-8") + eol
    decimals = _decimals(motion.source)
    read = read_times(motion)  # the frames read: their times' text, else the times printed

    def cells(rows: slice):
        block = values[rows]
        out = Cells()
        starts = np.empty((block.shape[0], block.shape[1] + 1), dtype=np.int64)
        lengths = np.empty_like(starts)
        starts[:, 0], lengths[:, 0] = out.add(
            *(format_repr(times[rows]) if read is None else read(rows))
        )
        first, sizes = out.add(*format_values(block, decimals))
        starts[:, 1:], lengths[:, 1:] = first.reshape(block.shape), sizes.reshape(block.shape)
        return out.buffer(), starts, lengths

    return table_pieces(motion.n_frames, cells, b"\t", eol, head + labels)


def _decimals(source) -> int | None:
    """The decimals of the text a clip was read from, which a new file keeps: a ``.mot``
    or ``.sto``'s, or a channel CSV's values' (None: shortest round-trip form)."""
    if isinstance(source, OpenSimText):
        return source.decimals
    if isinstance(source, CsvText) and source.layout == "channel":
        columns = source.columns
        return decimals_of(source.raw, source.starts[:, columns], source.ends[:, columns])
    return None
