"""Rest-pose frames at a clip's ends are left out of the feet's figures, as of every other:
a T-pose header frame far off the floor (ShaderMotion writes the hips 1,460 units away)
counts no contact and no depth below the ground."""

from __future__ import annotations

import numpy as np
from helpers import SAMPLE

import motionclean as mc
from motionclean.core.restpose import rest_frames
from motionclean.report.world import contact_figures

LEAD = 3


def header_framed(tmp_path, drop: float):
    """The sample with ``LEAD`` T-pose frames first, its root ``drop`` units lower."""
    lines = SAMPLE.read_text().splitlines(keepends=True)
    at = next(i for i, line in enumerate(lines) if line.startswith("Frames:"))
    body = lines[at + 2 :]
    first = body[0].split()
    root = [first[0], f"{float(first[1]) - drop:.6f}", first[2]]
    t_pose = " ".join(root + ["0.000000"] * (len(first) - 3)) + "\n"
    rows = [t_pose] * LEAD + body
    path = tmp_path / "framed.bvh"
    path.write_text("".join(lines[:at]) + f"Frames: {len(rows)}\n" + lines[at + 1] + "".join(rows))
    return mc.load(path)


def test_header_frames_under_the_floor_add_no_depth_and_no_contact(tmp_path):
    plain, framed = mc.load(SAMPLE), header_framed(tmp_path, drop=1460.0)
    assert rest_frames(framed) == (LEAD, 0)
    own, own_series = contact_figures(plain)
    got, series = contact_figures(framed)
    assert own is not None and got is not None
    assert got["feet"].keys() == own["feet"].keys()
    for name, foot in got["feet"].items():
        assert foot["penetration"] == own["feet"][name]["penetration"]  # not 1,460
        assert foot["contacts"] == [[a + LEAD, b + LEAD] for a, b in own["feet"][name]["contacts"]]
        heights = series[name]["height_before"]
        assert heights.shape == (framed.n_frames,) and np.isnan(heights[:LEAD]).all()
        np.testing.assert_array_equal(heights[LEAD:], own_series[name]["height_before"])
