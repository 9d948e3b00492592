"""World positions as CSV, for plotting and learning code (``convert --world``).

Columns: ``time`` (seconds from the first frame), then ``<point>.x,<point>.y,<point>.z`` for
every joint and end site (``<joint>_end``) in the order of
:func:`motionclean.kinematics.forward` with end sites; values in the file's length unit with
nine significant digits; blank where a point's place depends on a missing sample (a
tracker dropout).
"""

from __future__ import annotations

import csv
import io

import numpy as np

from .. import kinematics
from ..motion import Motion


def format_world_csv(motion: Motion) -> bytes:
    """The world-position table of ``motion`` as UTF-8 CSV bytes (LF line ends)."""
    positions, _ = kinematics.forward(motion, end_sites=True)
    names = list(motion.names) + kinematics.end_site_names(motion)
    header = io.StringIO()
    csv.writer(header, lineterminator="\n").writerow(
        ["time", *(f"{name}.{axis}" for name in names for axis in kinematics.AXES)]
    )
    times = np.arange(motion.n_frames) * motion.frame_time
    unknown = kinematics.missing_points(motion)
    if unknown is not None:  # a point whose place depends on a dropout is left blank
        positions = np.where(unknown[..., None], np.nan, positions)
    table = np.column_stack([times, positions.reshape(motion.n_frames, -1)])
    body = io.StringIO()
    np.savetxt(body, table, fmt="%.9g", delimiter=",")
    text = body.getvalue()
    if unknown is not None:  # every other value is finite: "nan" marks the blanks only
        text = text.replace("nan", "")
    return (header.getvalue() + text).encode("utf-8")
