"""Bad input through the command line: exit code 1, one error line naming FILE[:LINE], no
traceback, no output file. The files live in tests/io/malformed/."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from helpers import SAMPLE, run_cli

from motionclean import load, save
from motionclean.core.errors import MotionError

MALFORMED = Path(__file__).resolve().parent / "malformed"

# file name -> (line number or None, a fragment of the message)
CASES = {
    "empty.bvh": (None, "empty file"),
    "blank.bvh": (None, "empty file"),
    "not_bvh.bvh": (1, "not a BVH file"),
    "binary.bvh": (None, "not a text file"),
    "latin1.bvh": (2, "not a text file"),
    "truncated_hierarchy.bvh": (9, "truncated hierarchy"),
    "missing_motion.bvh": (15, "missing MOTION"),
    "motion_line_missing.bvh": (16, "'Frames:' in HIERARCHY (a 'MOTION' line must come before"),
    "unknown_channel.bvh": (9, "unknown channel 'Wrotation'"),
    "tab_separated.csv": (1, "the columns are tab-separated; CSV is read comma-separated"),
    "motive_no_columns.csv": (7, "no rigid body or marker columns"),
    "repeated_time.mot": (6, "the same time twice: delete the repeated row"),
    "keyword_case.bvh": (2, "unexpected 'Root' in HIERARCHY (keywords are case-sensitive: ROOT)"),
    "channel_count.bvh": (9, "CHANNELS says 4 but names 3"),
    "two_rotation_channels.bvh": (9, "2 rotation channels"),
    "short_row.bvh": (20, "frame row has 8 values, expected 9"),
    "long_row.bvh": (19, "frame row has 10 values, expected 9"),
    "few_rows.bvh": (20, "ends after 2 frame rows but Frames: says 3"),
    "extra_rows.bvh": (21, "more frame rows than Frames: 2"),
    "text_after_rows.bvh": (21, "Frames: 2 rows ('this file was exported by a to'...): not a"),
    "non_numeric.bvh": (20, "is not a number: 'abc'"),
    "nan.bvh": (19, "is not finite: 'nan'"),
    "inf.bvh": (20, "is not finite: '-inf'"),
    "frame_time_zero.bvh": (18, "Frame Time must be positive"),
    "frame_time_negative.bvh": (18, "Frame Time must be positive"),
    "frame_count_text.bvh": (17, "frame count is not a non-negative integer"),
    "offset_nan.bvh": (8, "OFFSET value is not finite"),
    "duplicate_joint_name.bvh": (15, "joint name 'Arm' used twice (first at line 6)"),
    "mac_line_ends.bvh": (None, "lines end in carriage returns alone (classic Mac OS)"),
    "empty.csv": (None, "empty file"),
    "binary.csv": (None, "not a text file"),
    "header_only.csv": (1, "no data rows"),
    "no_header.csv": (1, "bad header"),
    "no_time.csv": (1, "no 'time' column"),
    "unknown_suffix.csv": (1, "unknown suffix 'Wrotation'"),
    "duplicate_column.csv": (1, "'Hips.Xrotation' appears twice"),
    "mixed_layouts.csv": (1, "mixes BVH channel columns and rigid-body columns"),
    "split_joint.csv": (1, "columns of joint 'Hips' are not next to each other"),
    "missing_body_column.csv": (1, "no column head.qz"),
    "wrong_columns.csv": (3, "row has 7 columns, the header has 8"),
    "extra_column.csv": (4, "row has 9 columns, the header has 8"),
    "empty_value.csv": (3, "empty value"),
    "two_values_in_cell.csv": (2, "two values in one column"),
    "non_numeric.csv": (4, "'twelve' in column 'Hips.Zrotation' is not a number"),
    "nan.csv": (3, "'NaN' is not finite"),
    "inf.csv": (4, "'inf' in column 'Hips.Yrotation' is not finite"),
    "time_not_increasing.csv": (4, "time does not increase"),
    "frame_time_huge.bvh": (18, "Frame Time is out of range"),
    "frame_time_inf.bvh": (18, "Frame Time is not finite"),
    "frame_time_subnormal.bvh": (18, "gives no usable frame rate"),
    "frames_unicode_digit.bvh": (17, "frame count is not a non-negative integer: '²'"),
    "channels_unicode_digit.bvh": (9, "CHANNELS needs a count followed by channel names"),
    "underscore_number.bvh": (19, "is not a number: '1_000'"),
    "second_channels.bvh": (10, "a second CHANNELS line for joint 'Chest'"),
    "nul_in_name.bvh": (None, "not a text file"),
    "time_span_huge.csv": (2, "is out of range"),
    "huge_value.bvh": (19, "is out of range"),
    "non_uniform_time.csv": (4, "not uniformly sampled"),  # the 0.0667 s step, line 4
    "trailing_comma.csv": (1, "column 4 has no name (a comma ends the header: remove it"),
    "quoted_decimal_comma.csv": (2, "row has 4 columns, the header has 3 (quoted cells"),
    "single_row.csv": (2, "at least two rows"),
    "zero_quaternion.csv": (4, "quaternion of norm 0"),
    "partly_blank_body.csv": (4, "body 'head' is partly blank: empty value in head.pz"),
    "blank_time.csv": (3, "the time column is blank"),
    "motive_euler.csv": (1, "Rotation Type XYZ is Euler angles, which are not read"),
    "motive_unknown_rotation.csv": (1, "unknown Rotation Type 'Matrix'"),
    "motive_property_row.csv": (6, "the property row does not match the axis row"),
    "motive_partly_blank.csv": (9, "body 'Wand' is partly blank: empty value in Rotation X"),
}


def assert_one_error(err: str, path: str, line: int | None, fragment: str) -> None:
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    where = f"{path}:{line}" if line is not None else path
    assert lines[0].startswith(f"motionclean: error: {where}: "), lines[0]
    if line is None:  # no line number at all
        assert not re.match(rf"motionclean: error: {re.escape(path)}:\d+:", lines[0])
    assert fragment in lines[0]


def test_every_file_is_covered():
    assert sorted(p.name for p in MALFORMED.iterdir()) == sorted(CASES)


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_file(name, tmp_path, capsys):
    line, fragment = CASES[name]
    source = tmp_path / name
    shutil.copyfile(MALFORMED / name, source)
    before = source.read_bytes()
    for target in (tmp_path / "out.bvh", tmp_path / "out.csv"):
        code, out, err = run_cli(capsys, *["convert", str(source), str(target)])
        assert code == 1
        assert_one_error(err, str(source), line, fragment)
        assert sorted(p.name for p in tmp_path.iterdir()) == [name]  # no output, no temp file
    code, _, err = run_cli(capsys, *["info", str(source)])
    assert code == 1
    assert_one_error(err, str(source), line, fragment)
    assert source.read_bytes() == before


def test_missing_path(tmp_path, capsys):
    for name in ("nothing.bvh", "nothing.csv"):
        path = str(tmp_path / name)
        code, _, err = run_cli(capsys, *["convert", path, str(tmp_path / "out.bvh")])
        assert code == 1
        assert_one_error(err, path, None, "no such file")
    assert list(tmp_path.iterdir()) == []


def test_directory(tmp_path, capsys):
    for name in ("clips.bvh", "clips.csv", "clips"):  # without a suffix too
        folder = tmp_path / name
        folder.mkdir()
        code, _, err = run_cli(capsys, *["info", str(folder)])
        assert code == 1
        assert_one_error(err, str(folder), None, "is a directory, not a clip")
        with pytest.raises(MotionError, match="is a directory, not a clip"):
            load(folder)
        code, _, err = run_cli(capsys, *["clean", str(folder), "-o", str(tmp_path / "o.bvh")])
        assert code == 1
        assert_one_error(err, str(folder), None, "not a clip; `motionclean batch` cleans a folder")


def test_directory_as_target(tmp_path, capsys):
    source = tmp_path / "clip.bvh"
    shutil.copyfile(SAMPLE, source)
    target = tmp_path / "out.bvh"
    target.mkdir()
    code, _, err = run_cli(capsys, *["convert", str(source), str(target)])
    assert code == 2  # refused before the clip is read
    assert_one_error(err, str(target), None, "is a directory")
    assert list(target.iterdir()) == []


def test_channel_csv_to_bvh_needs_skeleton(tmp_path, capsys):
    source = tmp_path / "clip.csv"
    source.write_text(
        "frame,time,Hips.Xposition,Hips.Zrotation,Hips.Xrotation,Hips.Yrotation\n"
        "0,0,1,2,3,4\n1,0.5,1,2,3,4\n"
    )
    target = tmp_path / "out.bvh"
    code, _, err = run_cli(capsys, *["convert", str(source), str(target)])
    assert code == 1
    assert_one_error(err, str(source), None, "--skeleton")
    assert not target.exists()


@pytest.mark.parametrize(
    ("header", "fragment"),
    [
        (
            "frame,time,Hips.Xposition,Hips.Yposition,Hips.Zposition,Hips.Zrotation,Hips.Xrotation",
            "column Hips.Yrotation of the skeleton is missing",
        ),
        (
            "frame,time,Hips.Xposition,Hips.Yposition,Hips.Zposition,Hips.Zrotation,"
            "Hips.Xrotation,Hips.Yrotation,Tail.Xposition",
            "Tail.Xposition is not a channel",
        ),
        (
            "frame,time,Hips.Xposition,Hips.Yposition,Hips.Zposition,Hips.Xrotation,"
            "Hips.Yrotation,Hips.Zrotation",
            "rotation columns in order XYZ",
        ),
    ],
)
def test_csv_not_matching_the_skeleton(header, fragment, tmp_path, capsys):
    skeleton = tmp_path / "skeleton.bvh"
    skeleton.write_text(
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition "
        "Yposition Zposition Zrotation Xrotation Yrotation\n End Site\n {\n"
        "  OFFSET 0 1 0\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.5\n"
        "0 0 0 0 0 0\n"
    )
    n = header.count(",") - 1
    source = tmp_path / "clip.csv"
    source.write_text(header + "\n" + "".join(f"{i},{i * 0.5}" + ",1" * n + "\n" for i in range(3)))
    target = tmp_path / "out.bvh"
    code, _, err = run_cli(capsys, "convert", source, target, "--skeleton", skeleton)
    assert code == 1
    assert_one_error(err, str(source), 1, fragment)
    assert not target.exists()


def test_unwritable_target(tmp_path, capsys):
    source = tmp_path / "clip.bvh"
    shutil.copyfile(SAMPLE, source)
    target = tmp_path / "missing" / "out.csv"
    code, _, err = run_cli(capsys, *["convert", str(source), str(target)])
    assert code == 2  # refused before any work: a usage error
    assert_one_error(err, str(target), None, "no folder")
    assert not target.parent.exists()


@pytest.mark.parametrize("suffix", [".bvh", ".csv"])
def test_non_finite_motion_is_not_written(suffix, tmp_path):
    clip = load(SAMPLE)
    clip.rotations[7, 3] = np.nan  # in place: construction refuses it (test_motion_checks)
    target = tmp_path / f"out{suffix}"
    with pytest.raises(
        MotionError, match=f"joint '{clip.names[3]}' has a non-finite value at frame 7"
    ) as error:
        save(clip, target)
    assert error.value.path == str(target)
    assert not target.exists()
