"""Blank cells in CSV (tracker dropouts): a body or joint whose cells are all blank (or NaN)
on a row is missing there; partly blank is an error; missing samples are written blank and
read back with the same mask and the same known values bit for bit."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from helpers import run_cli
from hypothesis import given, settings
from hypothesis import strategies as st

import motionclean as mc
from motionclean.core import quat
from motionclean.core.errors import MotionError
from motionclean.core.motion import Motion, hold_missing
from motionclean.io.csv import RIGID_SUFFIXES, format_csv, parse_body, parse_csv

HEADER = "time," + ",".join(f"{b}.{s}" for b in ("a", "b") for s in RIGID_SUFFIXES)


def rigid_rows(*rows: str) -> bytes:
    return (HEADER + "\n" + "\n".join(rows) + "\n").encode()


BODY_B = "4,5,6,0,1,0,0"
GAPPY = rigid_rows(
    f"0,1,2,3,1,0,0,0,{BODY_B}",
    f"0.1,,,,,,,,{BODY_B}",
    f"0.2,NaN, ,-nan,,NAN,+nAn,,{BODY_B}",  # (signed: C's printf writes -nan)
    f"0.3,1.5,2,3,0.5,0.5,0.5,0.5,{BODY_B}",
)


def test_a_blank_or_nan_body_is_missing_and_holds_the_last_known_sample():
    clip = parse_csv(GAPPY, "gappy.csv")
    np.testing.assert_array_equal(clip.missing, [[0, 0], [1, 0], [1, 0], [0, 0]])
    np.testing.assert_array_equal(clip.rotations[:3, 0], np.tile([1.0, 0, 0, 0], (3, 1)))
    np.testing.assert_array_equal(clip.translations[:3, 0], np.tile([1.0, 2, 3], (3, 1)))
    np.testing.assert_array_equal(clip.rotations[3, 0], [0.5, 0.5, 0.5, 0.5])
    np.testing.assert_array_equal(clip.rotations[:, 1], np.tile([0.0, 1, 0, 0], (4, 1)))
    assert format_csv(clip) == GAPPY  # untouched: the input bytes


def test_a_gap_at_the_start_holds_the_first_known_sample_and_a_body_never_seen_is_identity():
    clip = parse_csv(
        rigid_rows("0,,,,,,,,,,,,,,", "0.1,1,2,3,0,0,1,0,,,,,,,", "0.2,1,2,3,0,0,1,0,,,,,,,"),
        "start.csv",
    )
    np.testing.assert_array_equal(clip.missing, [[1, 1], [0, 1], [0, 1]])
    np.testing.assert_array_equal(clip.rotations[0, 0], [0.0, 0, 1, 0])
    np.testing.assert_array_equal(clip.rotations[:, 1], np.tile([1.0, 0, 0, 0], (3, 1)))
    np.testing.assert_array_equal(clip.translations[:, 1], 0.0)


@pytest.mark.parametrize(
    ("row", "message"),
    [
        (f"0.1,1,2,3,1,0,0,,{BODY_B}", "body 'a' is partly blank: empty value in a.qz"),
        (f"0.1,,2,,1,0,0,0,{BODY_B}", "body 'a' is partly blank: empty value in a.px, a.pz"),
        (f"0.1,1,2,3,NaN,0,0,0,{BODY_B}", "body 'a' is partly blank: value 'NaN' is not finite"),
        (f",1,2,3,1,0,0,0,{BODY_B}", "the time column is blank"),
        (f"nan,1,2,3,1,0,0,0,{BODY_B}", "the time column holds NaN, not a number"),
        (f"0.1,1 2,2,3,1,0,0,0,{BODY_B}", "two values in one column (column 2)"),
    ],
)
def test_partly_blank_bodies_and_blank_times_are_errors_naming_the_line(row, message):
    data = rigid_rows(f"0,1,2,3,1,0,0,0,{BODY_B}", row, f"0.2,1,2,3,1,0,0,0,{BODY_B}")
    with pytest.raises(MotionError, match=re.escape(message)) as error:
        parse_csv(data, "bad.csv")
    assert error.value.line == 3


def test_channel_csv_blank_joint_is_missing_and_partly_blank_joint_is_an_error():
    header = "frame,time,Hips.Xposition,Hips.Zrotation,Hips.Xrotation,Hips.Yrotation,Arm.Zrotation"
    header += ",Arm.Xrotation,Arm.Yrotation\n"
    data = (header + "0,0,1,10,20,30,1,2,3\n1,0.5,,,,,4,5,6\n2,1.0,2,11,21,31,,,\n").encode()
    clip = parse_csv(data, "c.csv")
    np.testing.assert_array_equal(clip.missing, [[0, 0], [1, 0], [0, 1]])
    np.testing.assert_array_equal(clip.source_values[1, :4], clip.source_values[0, :4])
    np.testing.assert_array_equal(clip.rotations[2, 1], clip.rotations[1, 1])
    assert format_csv(clip) == data
    for row, message in [
        ("1,0.5,,12,,,4,5,6", "joint 'Hips' is partly blank: empty value in Hips.Xposition, "),
        (",0.5,1,10,20,30,4,5,6", "the frame column is blank"),
    ]:
        bad = (header + f"0,0,1,10,20,30,1,2,3\n{row}\n").encode()
        with pytest.raises(MotionError, match=re.escape(message)) as error:
            parse_csv(bad, "c.csv")
        assert error.value.line == 3


def random_rigid_clip(rng: np.random.Generator, n_frames: int, n_bodies: int, gaps: float):
    q = quat.make_continuous(quat.normalize(rng.normal(size=(n_frames, n_bodies, 4))))
    p = rng.normal(size=(n_frames, n_bodies, 3))
    missing = rng.uniform(size=(n_frames, n_bodies)) < gaps
    return Motion(
        names=[f"body{b}" for b in range(n_bodies)],
        parents=np.full(n_bodies, -1),
        offsets=np.zeros((n_bodies, 3)),
        channels=[("Xposition", "Yposition", "Zposition", "Yrotation", "Xrotation", "Zrotation")]
        * n_bodies,
        frame_time=1 / 120,
        rotations=hold_missing(q, missing),
        translations=hold_missing(p, missing),
        missing=missing,
    )


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_frames=st.integers(2, 30),
    n_bodies=st.integers(1, 3),
    gaps=st.floats(0.0, 0.9),
    layout=st.sampled_from(["rigid", "channel"]),
)
def test_missing_samples_round_trip_with_the_same_mask_and_known_values(
    seed, n_frames, n_bodies, gaps, layout
):
    rng = np.random.default_rng(seed)
    clip = random_rigid_clip(rng, n_frames, n_bodies, gaps)
    text = format_csv(clip, layout=layout)
    back = parse_csv(text, "back.csv")
    mask = clip.missing_mask()
    np.testing.assert_array_equal(back.missing_mask(), mask)
    known = ~mask
    if layout == "rigid":
        np.testing.assert_array_equal(back.translations[known], clip.translations[known])
        same = np.all(back.rotations == clip.rotations, axis=-1)
        same |= np.all(back.rotations == -clip.rotations, axis=-1)
        assert same[known].all()
    else:  # Euler angles written with repr: the values read are the values written
        written = np.repeat(known, 6, axis=1)
        np.testing.assert_array_equal(back.source_values[written], clip.channel_values()[written])
    # Written blank: every cell of a missing sample is empty.
    rows = [line.split(",") for line in text.decode().splitlines()[1:]]
    first = 1 if layout == "rigid" else 2
    cells = np.array([r[first:] for r in rows]).reshape(n_frames, n_bodies, -1)
    assert np.all((cells == "") == mask[..., None])
    assert format_csv(back, layout=layout) == text  # read back, untouched: same bytes


def test_a_rewrite_blanks_new_gaps_and_fills_filled_ones():
    clip = parse_csv(GAPPY, "gappy.csv")
    missing = clip.missing.copy()
    missing[1, 0] = False  # filled: the held placeholder is now a value
    missing[3, 1] = True  # lost
    text = format_csv(clip.replace(missing=missing))
    assert text.decode().splitlines()[2:] == [
        f"0.1,1.0,2.0,3.0,1.0,0.0,0.0,0.0,{BODY_B}",
        f"0.2,NaN, ,-nan,,NAN,+nAn,,{BODY_B}",  # still missing: the source text is kept
        "0.3,1.5,2,3,0.5,0.5,0.5,0.5,,,,,,,",
    ]
    back = parse_csv(text, "back.csv")
    np.testing.assert_array_equal(back.missing, missing)


def test_clean_leaves_blank_cells_blank(tmp_path: Path, capsys):
    rng = np.random.default_rng(3)
    clip = random_rigid_clip(rng, 40, 2, 0.0)
    q = quat.make_continuous(
        quat.from_axis_angle(np.array([0.0, 0.6, 0.8]), np.linspace(0, 2, 40))[:, None]
        * np.ones((1, 2, 1))
    )
    missing = np.zeros((40, 2), dtype=bool)
    missing[10:14, 0] = missing[30, 1] = True
    clip = clip.replace(rotations=hold_missing(q, missing), missing=missing)
    (tmp_path / "in.csv").write_bytes(format_csv(clip, layout="rigid"))
    code, _, err = run_cli(
        capsys, "clean", tmp_path / "in.csv", "-o", tmp_path / "out.csv", "-f", "lee-shin", "-q"
    )
    assert code == 0, err
    before = (tmp_path / "in.csv").read_text().splitlines()
    after = (tmp_path / "out.csv").read_text().splitlines()
    assert after[0] == before[0] and after != before
    for f, line in enumerate(after[1:]):
        cells = line.split(",")[1:]
        assert [c == "" for c in cells] == np.repeat(missing[f], 7).tolist()
    np.testing.assert_array_equal(mc.load(tmp_path / "out.csv").missing, missing)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_rows=st.integers(1, 12),
    n_columns=st.integers(2, 6),
    eol=st.sampled_from(["\n", "\r\n"]),
    padded=st.booleans(),
    blank_lines=st.booleans(),
)
def test_cells_are_found_alike_with_or_without_whitespace(
    seed, n_rows, n_columns, eol, padded, blank_lines
):
    """The scan without whitespace (cells between separators) and the token scan used when
    there are spaces find the same cells, blanks and values."""
    rng = np.random.default_rng(seed)
    values = np.round(rng.normal(size=(n_rows, n_columns)) * 100, rng.integers(0, 7))
    empty = rng.uniform(size=values.shape) < 0.3
    cells = np.where(empty, "", values.astype(str))
    cells[rng.uniform(size=values.shape) < 0.1] = "NaN"
    pad = (lambda c: f" {c}\t") if padded else (lambda c: c)
    lines = [",".join(pad(c) for c in row) for row in cells.tolist()]
    if blank_lines:
        lines = [x for line in lines for x in (line, "")]
    data = ("head" + eol + eol.join(lines) + eol).encode()
    body = parse_body(data, len("head") + len(eol), n_columns, 2, "t.csv")
    blank = (cells == "") | (cells == "NaN")
    np.testing.assert_array_equal(body.blank, blank)
    np.testing.assert_array_equal(body.values[~blank], values[~blank])
    assert np.isnan(body.values[blank]).all()
    texts = [
        data[s:e].decode() for s, e in zip(body.starts.ravel(), body.ends.ravel(), strict=True)
    ]
    assert texts == cells.ravel().tolist()
    np.testing.assert_array_equal(body.lines, 2 + np.arange(n_rows) * (2 if blank_lines else 1))
