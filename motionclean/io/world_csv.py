"""World positions as CSV, for plotting and learning code (``convert --world``).

Columns: ``time`` (seconds from the first frame), then ``<point>.x,<point>.y,<point>.z`` for
every joint and end site (``<joint>_end``) in the order of
:func:`motionclean.core.kinematics.forward` with end sites; values in the file's length unit with
nine significant digits; blank where a point's place depends on a missing sample (a
tracker dropout).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterator

import numpy as np

from ..core import kinematics
from ..core.motion import Motion
from ..core.threads import in_parts
from . import text


def world_csv_pieces(motion: Motion) -> Iterator[bytes]:
    """The world-position table of ``motion`` as UTF-8 CSV (LF line ends), in pieces of
    :data:`~motionclean.io.text.ROW_BLOCK` rows to write in turn."""
    positions = kinematics.world_positions(motion, end_sites=True)
    names = list(motion.names) + kinematics.end_site_names(motion)
    header = io.StringIO()
    csv.writer(header, lineterminator="\n").writerow(
        ["time", *(f"{name}.{axis}" for name in names for axis in kinematics.AXES)]
    )
    yield header.getvalue().encode("utf-8")
    unknown = kinematics.missing_points(motion)
    for rows in in_parts(motion.n_frames, text.ROW_BLOCK):
        block = positions[rows]
        if unknown is not None:  # a point whose place depends on a dropout is left blank
            block = np.where(unknown[rows, :, None], np.nan, block)
        times = np.arange(rows.start, rows.stop) * motion.frame_time
        body = io.StringIO()
        np.savetxt(body, np.column_stack([times, block.reshape(block.shape[0], -1)]), "%.9g", ",")
        lines = body.getvalue()
        if unknown is not None:  # every other value is finite: "nan" marks the blanks only
            lines = lines.replace("nan", "")
        yield lines.encode("utf-8")


def format_world_csv(motion: Motion) -> bytes:
    """The world-position table of ``motion`` as UTF-8 CSV bytes (:func:`world_csv_pieces`
    joined)."""
    return b"".join(world_csv_pieces(motion))
