"""OpenSim .mot/.sto: coordinates as rotations about a fixed axis and positions along one,
byte-exact write-back, degrees and radians, and the real-noise data cleaned as through the
channel CSV."""

from __future__ import annotations

import csv
import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest
from helpers import ROOT, run_cli

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.io.opensim import is_translational

REALNOISE = ROOT.parent / "shared" / "realnoise"
NO_REALNOISE = f"real-noise data not found at {REALNOISE} (see ../shared/realnoise/README.md)"

IK = """Coordinates
version=1
nRows=6
nColumns=6
inDegrees=yes

Units are S.I. units (second, meters, Newtons, ...)
If the header above contains a line with 'inDegrees', this indicates whether rotational \
values are in degrees (yes) or radians (no).

endheader
time\tpelvis_rotation\tpelvis_tx\tpelvis_ty\tknee_angle_r\tknee_angle_r_force
      0.00000000\t    170.00000000\t      0.10000000\t      0.93000000\t     -5.00000000\tn/a
      0.01000000\t    175.00000000\t      0.11000000\t      0.93100000\t     -6.50000000\tn/a
      0.02000000\t    180.50000000\t      0.12000000\t      0.93200000\t     -8.00000000\t1.5
      0.03000000\t    186.00000000\t      0.13000000\t      0.93100000\t     -9.50000000\t2.5
      0.04000000\t    191.00000000\t      0.14000000\t      0.93000000\t    -11.00000000\t3.5
      0.05000000\t    196.00000000\t      0.15000000\t      0.92900000\t    -12.50000000\t4.5
"""


def write(tmp_path, text: str, name: str = "ik.mot"):
    path = tmp_path / name
    path.write_bytes(text.encode())
    return path


@pytest.mark.parametrize(
    ("label", "axis"),
    [
        ("pelvis_tx", 0),
        ("sh_ty_r", 1),  # OpenCap's shoulder translations, the side after the axis
        ("tib_tz_l", 2),
        ("pat_ty_r", 1),
        ("/jointset/ground_pelvis/pelvis_tz/value", 2),
        ("knee_angle_r", -1),
        ("tx", -1),  # a word alone names no coordinate's axis
        ("lumbar_extension", -1),
    ],
)
def test_translational_coordinates_are_found_with_their_side_after_the_axis(label, axis):
    """``sh_tx_r`` (OpenCap's model) is a translation along x in metres: read as a rotation
    in degrees, the reports counted 38 joints and 3 translations where there are 32 and 9."""
    assert is_translational(label) == axis


def test_coordinates_become_rotations_about_z_and_positions_along_their_axis(tmp_path):
    motion = mc.load(write(tmp_path, IK), exclude=["*_force"])
    assert motion.names == ["pelvis_rotation", "pelvis_tx", "pelvis_ty", "knee_angle_r"]
    assert motion.channels[1] == ("Xposition",) and motion.channels[2] == ("Yposition",)
    assert motion.frame_time == pytest.approx(0.01)
    angle = np.deg2rad([170, 175, 180.5, 186, 191, 196])
    z_turn = np.stack([np.cos(angle / 2), 0 * angle, 0 * angle, np.sin(angle / 2)], axis=-1)
    assert np.abs(np.abs(np.einsum("fi,fi->f", motion.rotations[:, 0], z_turn)) - 1).max() < 1e-15
    assert np.array_equal(motion.translations[:, 1, 0], [0.1, 0.11, 0.12, 0.13, 0.14, 0.15])
    assert np.array_equal(motion.translations[:, 2, 1], [0.93, 0.931, 0.932, 0.931, 0.93, 0.929])
    assert kinematics.world_note(motion) is not None


def test_untouched_file_is_written_byte_for_byte(tmp_path):
    path = write(tmp_path, IK.replace("\n", "\r\n"))
    mc.save(mc.load(path, exclude=["*_force"]), tmp_path / "out.mot")
    assert (tmp_path / "out.mot").read_bytes() == path.read_bytes()


def test_a_changed_coordinate_keeps_header_other_columns_and_its_branch(tmp_path):
    path = write(tmp_path, IK)
    motion = mc.load(path, exclude=["*_force"])
    q = motion.rotations.copy()
    q[2:4, 0] = quat.multiply(q[2:4, 0], quat.exp(np.array([0.0, 0.0, np.deg2rad(0.5) / 2])))
    mc.save(motion.replace(rotations=q), tmp_path / "out.mot")
    before = path.read_text().splitlines()
    after = (tmp_path / "out.mot").read_text().splitlines()
    assert after[:11] == before[:11]  # header and labels
    for row in (0, 1, 4, 5):
        assert after[11 + row] == before[11 + row]
    for row, value in ((2, 181.0), (3, 186.5)):  # past 180: the branch read is kept
        old, new = before[11 + row].split("\t"), after[11 + row].split("\t")
        assert new[:1] + new[2:] == old[:1] + old[2:]
        assert float(new[1]) == pytest.approx(value, abs=1e-9)


def test_a_changed_value_is_written_with_the_files_decimals(tmp_path):
    """A changed value had been written in shortest round-trip form, 16-17 digits where
    the file writes 8 decimals (Gait2354's IK grew from 30 to 38 KB): written with the
    decimals the file's coordinates use; a file of 20 decimals (Gait2392's) gets the
    value's own digits padded, no float noise past them; a file that writes exponents
    keeps the shortest round-trip form."""
    path = write(tmp_path, IK)
    motion = mc.load(path, exclude=["*_force"])
    q = motion.rotations.copy()
    turn = quat.exp(np.array([0.0, 0.0, np.deg2rad(1 / 3) / 2]))
    q[2:4, 3] = quat.multiply(q[2:4, 3], turn)
    mc.save(motion.replace(rotations=q), tmp_path / "out.mot")
    rows = (tmp_path / "out.mot").read_text().splitlines()[11:]
    assert [row.split("\t")[4].strip() for row in rows[2:4]] == ["-7.66666667", "-9.16666667"]
    assert len((tmp_path / "out.mot").read_bytes()) == len(path.read_bytes())
    long = IK.replace("    170.00000000", "170.12345678901234560000")
    motion = mc.load(write(tmp_path, long, "long.mot"), exclude=["*_force"])
    mc.save(motion.replace(rotations=q), tmp_path / "long_out.mot")
    knee = (tmp_path / "long_out.mot").read_text().splitlines()[13].split("\t")[4].strip()
    assert knee == "-7.66666666666666700000"  # (repr: -7.666666666666667)
    sci = IK.replace("    170.00000000", "1.7e2")
    motion = mc.load(write(tmp_path, sci, "sci.mot"), exclude=["*_force"])
    mc.save(motion.replace(rotations=q), tmp_path / "sci_out.mot")
    knee = float((tmp_path / "sci_out.mot").read_text().splitlines()[13].split("\t")[4])
    assert knee == float(repr(knee)) and abs(knee + 23 / 3) < 1e-12


def test_a_trip_through_csv_keeps_the_files_numbers(tmp_path, capsys):
    """.mot -> CSV -> .mot had come back with float noise (-1.8867664799999997 for
    -1.88676648): the CSV of an OpenSim clip gets the file's decimals, and a .mot made
    from a channel CSV gets the CSV's."""
    path = write(tmp_path, IK)
    code, _, _ = run_cli(capsys, "convert", path, tmp_path / "c.csv", "--exclude", "*_force")
    assert code == 0
    first = (tmp_path / "c.csv").read_text().splitlines()[1].split(",")
    assert first[2:6] == ["170.00000000", "0.00000000", "0.00000000", "0.10000000"]
    code, _, _ = run_cli(capsys, "convert", tmp_path / "c.csv", tmp_path / "back.mot")
    assert code == 0
    back = [row.split("\t")[1:] for row in (tmp_path / "back.mot").read_text().splitlines()[7:]]
    original = [row.split("\t")[1:5] for row in IK.splitlines()[11:]]
    assert back == [[cell.strip() for cell in row] for row in original]


def at_60_fps(text: str) -> str:
    """``text`` (IK's layout) with its rows 1/60 s apart, times in eight decimals."""
    head, body = text.split("endheader\n")
    lines = body.splitlines()
    rows = [f"{i / 60:16.8f}\t" + r.split("\t", 1)[1] for i, r in enumerate(lines[1:])]
    return head + "endheader\n" + "\n".join([lines[0], *rows]) + "\n"


def test_a_trip_through_csv_keeps_the_time_column_s_text(tmp_path, capsys):
    """The time column had been printed from the frame time measured (0.01666667 came back
    as 0.0166666666722 in the CSV, 0.01666666667 in the .mot): while the frames are the
    file's, every writer keeps its times' text, and a resampled clip's are printed."""
    path = write(tmp_path, at_60_fps(IK))
    read = [row.split("\t")[0].strip() for row in path.read_text().splitlines()[11:]]
    assert read[1] == "0.01666667"
    code, _, err = run_cli(capsys, "convert", path, tmp_path / "c.csv", "--exclude", "*_force")
    assert code == 0, err
    with open(tmp_path / "c.csv") as fh:
        assert [row["time"] for row in csv.DictReader(fh)] == read
    code, _, err = run_cli(capsys, "convert", tmp_path / "c.csv", tmp_path / "back.mot")
    assert code == 0, err
    assert [
        row.split("\t")[0] for row in (tmp_path / "back.mot").read_text().splitlines()[7:]
    ] == read
    code, _, err = run_cli(
        capsys, "resample", tmp_path / "c.csv", tmp_path / "r.mot", "--fps", "30"
    )
    assert code == 0, err
    times = [row.split("\t")[0] for row in (tmp_path / "r.mot").read_text().splitlines()[7:]]
    assert times[1] == "0.0333333333333"


def repeated_last_row(text: str) -> str:
    """``text`` with its last row written twice, as OpenSim's RRA ends its results."""
    return text + text.splitlines(keepends=True)[-1]


def test_a_last_row_repeated_byte_for_byte_is_read_as_one_frame(tmp_path, capsys):
    """RRA ends its *_Kinematics_q.sto and *_states.sto with the last row written twice,
    which had been refused ("the same time twice"), by resample too: read as one frame, it
    is written back after the last row, repeating it as written, and left out of a file
    written afresh. A repeat that differs in a digit is still refused."""
    path = write(tmp_path, repeated_last_row(IK.replace("nRows=6", "nRows=7")))
    clip = mc.load(path, exclude=["*_force"])
    assert clip.n_frames == 6 and clip.frame_time == pytest.approx(0.01)
    assert any(note.startswith("the last row repeats the one before") for note in clip.source.notes)
    mc.save(clip, tmp_path / "same.mot")
    assert (tmp_path / "same.mot").read_bytes() == path.read_bytes()
    q = clip.rotations.copy()
    q[-1, 3] = quat.multiply(q[-1, 3], quat.exp(np.array([0.0, 0.0, np.deg2rad(0.5) / 2])))
    mc.save(clip.replace(rotations=q), tmp_path / "changed.mot")
    rows = (tmp_path / "changed.mot").read_text().splitlines()
    assert "nRows=7" in rows and rows[-1] == rows[-2] != path.read_text().splitlines()[-1]
    assert float(rows[-1].split("\t")[4]) == pytest.approx(-12.0, abs=1e-9)
    assert mc.load(tmp_path / "changed.mot", exclude=["*_force"]).n_frames == 6
    code, _, err = run_cli(
        capsys, "resample", path, tmp_path / "r.mot", "--fps", "50", "--exclude", "*_force"
    )
    assert code == 0, err
    resampled = (tmp_path / "r.mot").read_text()
    times = [
        float(row.split("\t")[0]) for row in resampled.split("endheader\n")[1].splitlines()[1:]
    ]
    assert times == pytest.approx([0.0, 0.02, 0.04]) and "nRows=3\n" in resampled
    write(tmp_path, repeated_last_row(IK)[:-2] + "1\n", "near.mot")  # -12.50000001
    code, _, err = run_cli(capsys, "info", tmp_path / "near.mot", "--exclude", "*_force")
    assert code == 1 and "(the same time twice: delete the repeated row)" in err


def test_a_file_cut_inside_its_last_value_says_so(tmp_path, capsys):
    """A file cut inside its last number (no line end, nRows saying more rows) is read with
    the rows it holds, as the BVH and CSV readers read a last row cut so; the note shows
    the cut value, and the output says the rows it holds."""
    text = IK.replace("nRows=6", "nRows=600")
    path = write(tmp_path, text[: text.rindex("\t") + 3])  # 4.5 cut to 4.
    code, out, err = run_cli(
        capsys, "clean", path, "-o", tmp_path / "c.mot", "--exclude", "*_force"
    )
    assert code == 0, err
    assert (
        "nRows=600 but the file holds 6 rows and ends inside the last one, with no line end" in out
    )
    assert "its last value ('knee_angle_r_force': 4.) perhaps cut too" in out
    assert "nRows=6\n" in (tmp_path / "c.mot").read_text()


def _in_radians(text: str) -> str:
    """``text`` (the IK fixture) with its rotational columns in radians, inDegrees=no."""
    head, _, body = text.partition("endheader\n")
    labels, *rows = body.splitlines()
    out = []
    for row in rows:
        cells = row.split("\t")
        for k in (1, 4):  # pelvis_rotation, knee_angle_r
            cells[k] = f"{math.radians(float(cells[k])):16.8f}"
        out.append("\t".join(cells))
    return (
        head.replace("inDegrees=yes", "inDegrees=no")
        + "endheader\n"
        + labels
        + "\n"
        + ("\n".join(out) + "\n")
    )


def test_radians_and_a_missing_inDegrees_line(tmp_path):
    radians = _in_radians(IK)
    motion = mc.load(write(tmp_path, radians, "r.mot"), exclude=["*_force"])
    assert not kinematics.source_notes(motion)
    angle = np.array([float(r.split("\t")[4]) for r in radians.splitlines()[11:]])
    z = 2 * np.arctan2(motion.rotations[:, 3, 3], motion.rotations[:, 3, 0])
    assert np.abs(np.angle(np.exp(1j * (z - angle)))).max() < 1e-12
    mc.save(motion, tmp_path / "same.mot")
    assert (tmp_path / "same.mot").read_text() == radians
    bare_text = radians.replace("inDegrees=no\n", "")
    bare = mc.load(write(tmp_path, bare_text, "b.sto"), exclude=["*_force"])
    assert any("read as radians" in note for note in kinematics.source_notes(bare))
    assert np.array_equal(bare.rotations, motion.rotations)


def test_degrees_under_a_radians_header_are_read_as_degrees_and_said(tmp_path):
    """OpenSim's CMC writes its *_q.sto with inDegrees=no over values in degrees (a knee at
    -69, hips at 20): read as radians they turn whole turns between frames and every
    smooth curve looks like spikes. Most coordinates past half a turn, or faster than 60
    rad/s: read as degrees, a note says why, and the file is written back as it was (its
    header too), a changed value in degrees."""
    text = IK.replace("inDegrees=yes", "inDegrees=no")
    motion = mc.load(write(tmp_path, text, "q.sto"), exclude=["*_force"])
    assert any("read as degrees" in note for note in kinematics.source_notes(motion))
    same = mc.load(write(tmp_path, IK, "d.mot"), exclude=["*_force"])
    assert np.array_equal(motion.rotations, same.rotations)
    mc.save(motion, tmp_path / "back.sto")
    assert (tmp_path / "back.sto").read_text() == text
    q = motion.rotations.copy()
    q[2, 3] = quat.multiply(q[2, 3], quat.exp(np.array([0.0, 0.0, np.deg2rad(1.0) / 2])))
    mc.save(motion.replace(rotations=q), tmp_path / "moved.sto")
    row = (tmp_path / "moved.sto").read_text().splitlines()[13].split("\t")
    assert float(row[4]) == pytest.approx(-7.0, abs=1e-9)  # -8 degrees turned by 1
    # without an inDegrees line the one note says so (it had said "read as radians" and
    # "the header says radians (inDegrees=no)", a line the file does not have)
    bare = mc.load(write(tmp_path, IK.replace("inDegrees=yes\n", ""), "b.mot"), exclude=["*_force"])
    (said,) = kinematics.source_notes(bare)
    assert said.startswith("angles read as degrees: no inDegrees line, but most")


def test_nan_cells_are_missing_samples_and_stay_so(tmp_path):
    text = IK.replace("     -8.00000000", "NaN").replace("     -9.50000000", "nan")
    path = write(tmp_path, text)
    motion = mc.load(path, exclude=["*_force"])
    assert np.flatnonzero(motion.missing[:, 3]).tolist() == [2, 3]
    mc.save(motion, tmp_path / "same.mot")
    assert (tmp_path / "same.mot").read_bytes() == path.read_bytes()
    filled, _ = mc.Pipeline.from_inline(["fill-gaps"]).run(motion)
    mc.save(filled, tmp_path / "filled.mot")
    knee = np.genfromtxt(tmp_path / "filled.mot", skip_header=11, usecols=4)
    # the knee turns at a constant rate: the bridge over the gap continues it
    assert np.abs(knee - [-5.0, -6.5, -8.0, -9.5, -11.0, -12.5]).max() < 1e-9


def shifted(text: str, seconds: float) -> str:
    """``text`` (IK's layout) with every time ``seconds`` later."""
    head, body = text.split("endheader\n")
    lines = body.splitlines()
    rows = [
        f"{float(r.split(chr(9))[0]) + seconds:16.8f}\t" + r.split("\t", 1)[1] for r in lines[1:]
    ]
    return head + "endheader\n" + "\n".join([lines[0], *rows]) + "\n"


@pytest.mark.parametrize("start", [0.0, 0.4])
def test_convert_to_csv_and_back(tmp_path, capsys, start):
    """A trial cut from 0.4 s on stays there through CSV (it lines up with its forces)."""
    path = write(tmp_path, shifted(IK, start))
    code, _, _ = run_cli(capsys, "convert", path, tmp_path / "c.csv", "--exclude", "*_force")
    assert code == 0
    code, _, _ = run_cli(capsys, "convert", tmp_path / "c.csv", tmp_path / "back.mot")
    assert code == 0
    with open(tmp_path / "c.csv") as fh:
        assert float(list(csv.DictReader(fh))[0]["time"]) == start
    back = np.genfromtxt(tmp_path / "back.mot", skip_header=7)
    original = np.genfromtxt(path, skip_header=11, usecols=range(5))
    assert np.abs(back - original).max() < 1e-9
    code, _, err = run_cli(
        capsys, "convert", ROOT / "sample_data" / "131_02_cut.bvh", tmp_path / "x.mot"
    )
    assert code == 1 and "an OpenSim file holds independent coordinates" in err


@pytest.mark.parametrize(
    ("text", "message", "line"),
    [
        ("version=1\ntime\ta\n0\t1\n", "no 'endheader' line", None),
        (IK.replace("\t1.5\n", "\n"), "5 values on this row, expected 6", 14),
        (
            IK.replace("-6.50000000", "x6.5"),
            "column 'knee_angle_r' is not a number: 'x6.5'",
            13,
        ),
        (
            IK.replace("-6.50000000", "-1e13"),
            "column 'knee_angle_r' is out of range (more than 1e+12 in size): '-1e13'",
            13,
        ),
        (  # (the row out of line with both neighbours, not the one after it)
            IK.replace("      0.02000000", "      0.05000000"),
            "time 0.05 s is out of order (the row before has 0.01 s, the next 0.03 s)",
            14,
        ),
        (IK.replace("      0.02000000", "      0.01000000"), "time does not increase", 14),
        (IK.replace("pelvis_ty", "pelvis_tx"), "column 'pelvis_tx' appears twice", 11),
        (IK.replace("time\t", "frame\t"), "the first column is 'frame'", 11),
        (IK.replace("inDegrees=yes", "inDegrees=maybe"), "inDegrees='maybe'", 5),
        (IK.split("endheader")[0] + "endheader\n", "no column labels", 11),
        (
            IK.replace("\t     -6.50000000", "\t"),
            "an empty cell in column 'knee_angle_r' (two tabs in a row)",
            13,
        ),
        (IK.replace("\tpelvis_ty", "\t"), "column 4 has no name (two tabs in a row)", 11),
    ],
)
def test_bad_files_are_one_line(tmp_path, capsys, text, message, line):
    path = write(tmp_path, text)
    code, out, err = run_cli(capsys, "info", path, "--exclude", "*_force")
    assert code == 1 and out == "" and err.count("\n") == 1 and message in err
    where = f"{path}:{line}: " if line else f"{path}: "
    assert err.startswith(f"motionclean: error: {where}")


def test_an_unparsed_column_is_an_error_unless_excluded(tmp_path, capsys):
    other = IK.replace("knee_angle_r_force", "knee_angle_r_state")
    code, _, err = run_cli(capsys, "info", write(tmp_path, other))
    assert code == 1 and "knee_angle_r_state' is not a number: 'n/a'" in err


def test_force_torque_and_point_columns_are_carried_and_a_loads_file_refused(tmp_path, capsys):
    """A motion's force column (and ground reaction forces, torques, centres of pressure:
    OpenSim's names) is no coordinate: carried as text with a note, without --exclude. A
    file of nothing else (an external loads .mot) is refused in one line."""
    motion = mc.load(write(tmp_path, IK))
    assert motion.names == ["pelvis_rotation", "pelvis_tx", "pelvis_ty", "knee_angle_r"]
    assert any("forces, torques or points" in n for n in kinematics.source_notes(motion))
    mc.save(motion, tmp_path / "same.mot")
    assert (tmp_path / "same.mot").read_text() == IK
    loads = "\n".join(
        ["version=1", "nRows=3", "nColumns=4", "endheader",
         "time\tground_force_vx\tground_force_px\tground_torque_y",
         "0.0\t1.0\t0.1\t2.0", "0.01\t171.1\t0.2\t3.0", "0.02\t525.0\t0.3\t4.0", ""]
    )  # fmt: skip
    code, _, err = run_cli(capsys, "info", write(tmp_path, loads, "grf.mot"))
    assert code == 1 and "external loads file" in err and len(err.strip().splitlines()) == 1


def test_carried_columns_may_share_a_name_and_markers_are_said_to_be_markers(tmp_path, capsys):
    """opensim-models' Gait2392 subject01_walk1_ik.mot holds two force plates' columns under
    the same names (ground_force_vx ... twice) and markers as SIMM names them (R.ASIS_tx):
    the file had been refused ('appears twice'), and the markers called speeds and muscle
    states. Carried columns are text: duplicates are read and written back byte for byte;
    a coordinate named twice is still refused."""
    rows = [
        f"{0.01 * f:.8f}\t{5 + f:.8f}\t{0.1 * f:.8f}\t{1.5 + f:.8f}\t{2.5 + f:.8f}"
        f"\t{3.5 - f:.8f}\t{0.2 * f:.8f}\t{0.3 * f:.8f}"
        for f in range(8)
    ]
    text = "\n".join(
        ["first trial", "nRows=8", "nColumns=8", "inDegrees=yes", "endheader",
         "time\tknee_angle_r\tR.ASIS_tx\tground_force_vx\tground_force_py\tground_force_vx"
         "\tground_force_py\tpelvis_tx", *rows, ""]
    )  # fmt: skip
    path = write(tmp_path, text, "two_plates.mot")
    motion = mc.load(path)
    assert motion.names == ["knee_angle_r", "pelvis_tx"]
    notes = kinematics.source_notes(motion)
    assert (
        "1 column of marker positions carried as text (R.ASIS_tx): written back only to an "
        "OpenSim file at the clip's own frames (not by convert to another format, nor by "
        "resample)"
    ) in notes
    assert not any("muscles" in note for note in notes)
    mc.save(motion, tmp_path / "same.mot")
    assert (tmp_path / "same.mot").read_bytes() == path.read_bytes()
    q = motion.rotations.copy()
    q[3, 0] = quat.multiply(q[3, 0], quat.exp(np.array([0.0, 0.0, np.deg2rad(0.5) / 2])))
    mc.save(motion.replace(rotations=q), tmp_path / "moved.mot")
    before = [line.split("\t") for line in text.splitlines()[6:]]
    after = [line.split("\t") for line in (tmp_path / "moved.mot").read_text().splitlines()[6:]]
    assert [row[2:7] for row in after] == [row[2:7] for row in before]
    twice = text.replace("pelvis_tx", "knee_angle_r")
    code, _, err = run_cli(capsys, "info", write(tmp_path, twice, "twice.mot"))
    assert code == 1 and err.count("\n") == 1
    assert "coordinate column 'knee_angle_r' appears twice: rename one" in err


def states_file(naming: str, frames: int = 120) -> str:
    """A states .sto (radians) of a knee swinging with a one-frame spike, its speed (the
    derivative, smooth through zero), the pelvis's forward position and a muscle's
    activation, named as OpenSim 4 (state paths) or earlier versions name states."""
    t = np.arange(frames) * 0.01
    knee = 0.6 * np.sin(2 * np.pi * t)
    knee[60] += 0.3
    columns = {
        "knee": knee,
        "knee_u": 0.6 * 2 * np.pi * np.cos(2 * np.pi * t),
        "tx": 1.2 * t,
        "act": 0.2 + 0.1 * np.sin(6 * t),
    }
    labels = {
        "4": {
            "knee": "/jointset/knee_r/knee_angle_r/value",
            "knee_u": "/jointset/knee_r/knee_angle_r/speed",
            "tx": "/jointset/ground_pelvis/pelvis_tx/value",
            "act": "/forceset/soleus_r/activation",
        },
        "3": {
            "knee": "knee_angle_r",
            "knee_u": "knee_angle_r_u",
            "tx": "pelvis_tx",
            "act": "soleus_r.activation",
        },
    }[naming]
    rows = ["inDegrees=no", "endheader", "\t".join(["time", *labels.values()])]
    rows += ["\t".join(f"{v:.10f}" for v in row) for row in zip(t, *columns.values(), strict=True)]
    return "\n".join(rows) + "\n"


@pytest.mark.parametrize("naming", ["4", "3"])
def test_a_states_file_cleans_its_coordinates_and_carries_speeds_and_muscles(
    tmp_path, capsys, naming
):
    """Speeds and muscle states are no coordinates: carried byte for byte (the default's
    despike had rewritten a speed running smoothly through zero), with a note; a
    translational coordinate named as a state path (``.../pelvis_tx/value``) is a position
    (it had been read as an angle in radians)."""
    source = write(tmp_path, states_file(naming), "states.sto")
    motion = mc.load(source)
    tx = next(j for j, name in enumerate(motion.names) if "tx" in name)
    assert motion.n_joints == 2 and motion.channels[tx] == ("Xposition",)
    assert any("speeds, muscles" in n for n in kinematics.source_notes(motion))
    out = tmp_path / "clean.sto"
    code, _, err = run_cli(capsys, "clean", source, "-o", out, "-q")
    assert (code, err) == (0, "")
    before = [line.split("\t") for line in source.read_text().splitlines()[3:]]
    after = [line.split("\t") for line in out.read_text().splitlines()[3:]]
    assert [r[2] for r in before] == [r[2] for r in after]  # the speed
    assert [r[4] for r in before] == [r[4] for r in after]  # the activation
    assert before[60][1] != after[60][1]  # the knee's spike was repaired


def test_translations_are_said_in_metres_and_a_channel_csv_of_them_in_units(tmp_path, capsys):
    """OpenSim's translational coordinates are metres: the verdict and despike's line said
    "units" ("largest position change 0.0095 units on pelvis_tx"). A channel CSV of the
    same values says nothing of its unit: "units" there. (A walk: 4 mm of jitter and a
    spike of 30 cm on pelvis_tx.)"""
    rng = np.random.default_rng(3)
    t = np.arange(240) / 60.0
    tx = 1.2 * t + rng.normal(0, 0.004, t.size)
    tx[100] += 0.3
    columns = (t, 30.0 * np.sin(2 * np.pi * 0.8 * t), tx)
    rows = ["walk", "inDegrees=yes", "endheader", "time\tknee_angle_r\tpelvis_tx"]
    rows += ["\t".join(f"{v:.8f}" for v in row) for row in zip(*columns, strict=True)]
    source = write(tmp_path, "\n".join(rows) + "\n", "walk.mot")
    report = tmp_path / "r.json"
    code, out, _ = run_cli(capsys, "clean", source, "-o", tmp_path / "out.mot", "--report", report)
    said = r"largest step [0-9.]+ -> [0-9.]+ {0}\n.*largest position change [0-9.]+ {0} on"
    assert code == 0 and re.search(said.format("m"), out) and "units" not in out
    notes = json.loads(report.read_text())["joints"]["pelvis_tx"]
    assert notes["position_despike"]["unit"] == notes["position_auto"]["unit"] == "m"
    assert run_cli(capsys, "convert", source, tmp_path / "walk.csv")[0] == 0
    code, out, _ = run_cli(
        capsys, "clean", tmp_path / "walk.csv", "-o", tmp_path / "out.csv", "--report", report
    )
    assert code == 0 and re.search(said.format("units"), out)
    notes = json.loads(report.read_text())["joints"]["pelvis_tx"]
    assert notes["position_despike"]["unit"] == notes["position_auto"]["unit"] == "length"


def test_a_body_kinematics_table_is_refused_in_one_line(tmp_path, capsys):
    """OpenSim's BodyKinematics output (each body's position and body-fixed Euler angles
    in the ground frame, the whole body's centre of mass by position alone, at a
    simulation's uneven steps) had been sent to `resample` and then read as coordinates."""
    bodies = [
        f"{b}_{end}" for b in ("pelvis", "femur_r") for end in ("X", "Y", "Z", "Ox", "Oy", "Oz")
    ]
    labels = ["time", *bodies, "center_of_mass_X", "center_of_mass_Y", "center_of_mass_Z"]
    rows = [[t, *np.linspace(0.1, 1.0, len(labels) - 1)] for t in (0.83, 0.8365, 0.843, 0.85)]
    text = "Positions\nversion=1\ninDegrees=no\nendheader\n" + "\t".join(labels) + "\n"
    text += "".join("\t".join(f"{v:.6f}" for v in row) + "\n" for row in rows)
    path = write(tmp_path, text, "walk_BodyKinematics_pos_global.sto")
    code, out, err = run_cli(capsys, "info", path)
    assert code == 1 and out == "" and err.count("\n") == 1
    assert err.startswith(f"motionclean: error: {path}:5: body kinematics")


#: The first rows of opensim-models' Gait2392 CMC *_Kinematics_u.sto
#: (Pipelines/Gait2392_Simbody/OutputReference/ResultsCMC/subject01_walk1_Kinematics_u.sto,
#: three of its 23 columns), under a title put in at the top.
CMC_SPEEDS = """{title}
version=1
nRows=5
nColumns=4
inDegrees=no
endheader
time\tpelvis_tx\tpelvis_tilt\tknee_angle_r
      0.53000000\t     -0.05183383\t     -7.15426501\t    322.44147368
      0.53100000\t     -0.05131170\t     -7.44896624\t    318.56817666
      0.53200000\t     -0.05081387\t     -7.85939931\t    314.55773851
      0.53300000\t     -0.05034873\t     -8.42508003\t    310.36201794
      0.53400000\t     -0.04988360\t     -8.99076075\t    306.16629738
"""
#: The first rows of the same CMC's *_Actuation_force.sto (subject01_walk1_Actuation_force.sto:
#: 2 of its 92 muscles, a residual and a reserve actuator of its 115 columns).
CMC_FORCES = """{title}
version=1
nRows=4
nColumns=5
inDegrees=no
endheader
time\tvas_lat_r\tsoleus_r\tFX\tknee_angle_r_reserve
      0.53000000\t      1.84674771\t    106.48614553\t      0.24599357\t     -0.00773272
      0.53100000\t      1.84627672\t    106.74557087\t      0.22105876\t     -0.01206783
      0.53200000\t      1.84594051\t    107.03402003\t      0.19612395\t     -0.01206783
      0.53300000\t      1.84578661\t    107.36166432\t      0.17118914\t     -0.01206783
"""


@pytest.mark.parametrize(
    ("text", "holds"),
    [
        (CMC_SPEEDS.format(title="Speeds"), "the coordinates' speeds"),
        (CMC_SPEEDS.format(title="Accelerations"), "the coordinates' accelerations"),
        (CMC_SPEEDS.format(title="PositionErrors"), "CMC's or RRA's errors in tracking"),
        (CMC_FORCES.format(title="ActuatorForces"), "actuator forces, a column per muscle"),
        (CMC_FORCES.format(title="ActuatorPowers"), "actuator powers"),
        (CMC_FORCES.format(title="controls"), "controls, a column per muscle"),
        (CMC_SPEEDS.format(title="Static Optimization"), "muscle activations or forces"),
        (CMC_SPEEDS.format(title="MomentArm_knee_angle_r"), "muscle quantities"),
    ],
)
def test_result_tables_of_no_coordinates_are_refused_by_their_title(tmp_path, capsys, text, holds):
    """CMC's and the analyses' tables of speeds, accelerations, tracking errors, actuator
    forces and controls had been read as joint angles: `clean` of an *_Actuation_force.sto
    changed muscle forces by up to 180 N (taken as steps of a turn) and exited 0. Their
    title (line 1) says what they hold, whatever their columns are named."""
    path = write(tmp_path, text, "cmc.sto")
    code, out, err = run_cli(capsys, "clean", path, "-o", tmp_path / "out.sto")
    assert code == 1 and out == "" and not (tmp_path / "out.sto").exists()
    title = text.splitlines()[0]
    assert err.startswith(f"motionclean: error: {path}:1: titled {title!r}: {holds}")
    assert err.count("\n") == 1 and "only coordinate values are read" in err


def test_a_table_of_actuators_is_refused_whatever_its_title(tmp_path, capsys):
    """An actuator table under a title of the user's: its residual (FX) and reserve
    (``*_reserve``) actuators name no coordinate; its muscles' columns are no angles."""
    path = write(tmp_path, CMC_FORCES.format(title="walk1 forces"), "forces.sto")
    code, _, err = run_cli(capsys, "info", path)
    assert code == 1 and err.count("\n") == 1
    assert err.startswith(
        f"motionclean: error: {path}:7: actuator columns (FX, knee_angle_r_reserve): a value "
        "per muscle or actuator"
    )


def test_an_actuator_column_the_user_excludes_does_not_refuse_the_table(tmp_path, capsys):
    """Coordinates beside a residual force's column (FX): refused as an actuator table,
    saying that --exclude leaves it out, and read with it excluded (an excluded column is
    never parsed; `--exclude FX` had still been refused), FX written back as it was."""
    head, _, table = CMC_SPEEDS.format(title="Coordinates").partition("endheader\n")
    labels, *rows = table.splitlines()
    forces = "".join(f"{row}\t{i * 0.25:.8f}\n" for i, row in enumerate(rows))
    text = head.replace("nColumns=4", "nColumns=5") + f"endheader\n{labels}\tFX\n{forces}"
    path = write(tmp_path, text, "ik_fx.sto")
    code, _, err = run_cli(capsys, "info", path)
    assert code == 1 and f"{path}:7: actuator columns (FX): a value per muscle" in err
    assert err.endswith("leaves such columns out of a table of coordinates (--exclude FX)\n")
    code, _, err = run_cli(capsys, "info", path, "--exclude", "FX")
    assert code == 0, err
    motion = mc.load(path, exclude=["FX"])
    assert motion.names == ["pelvis_tx", "pelvis_tilt", "knee_angle_r"]
    mc.save(motion, tmp_path / "out.sto")
    assert (tmp_path / "out.sto").read_text() == text


@pytest.mark.parametrize("title", ["Coordinates", "subject01_walk1_states", "first trial"])
def test_the_same_columns_under_a_coordinates_or_free_title_are_read(tmp_path, title):
    """Kinematics' *_q.sto (titled Coordinates) and files titled by their trial are read:
    a title is evidence only where it is one of OpenSim's result tables."""
    motion = mc.load(write(tmp_path, CMC_SPEEDS.format(title=title), "q.sto"))
    assert motion.names == ["pelvis_tx", "pelvis_tilt", "knee_angle_r"]
    mc.save(motion, tmp_path / "same.sto")
    assert (tmp_path / "same.sto").read_text() == CMC_SPEEDS.format(title=title)


def test_a_file_of_times_alone_says_so(tmp_path, capsys):
    """CMC's *_pseudo.sto holds a time column alone: it had been said to have had all its
    columns excluded, with no --exclude given."""
    text = "subject01_walk1_pseudo\nversion=1\nnRows=2\nnColumns=1\nendheader\ntime\n0.53\n0.54\n"
    path = write(tmp_path, text, "pseudo.sto")
    code, _, err = run_cli(capsys, "info", path)
    assert code == 1
    assert err == f"motionclean: error: {path}:6: only a time column: no coordinates to clean\n"


def test_a_quaternion_table_is_refused_in_one_line(tmp_path, capsys):
    text = "DataType=Quaternion\nversion=3\nendheader\ntime\ttorso_imu\n0\t1,0,0,0\n0.01\t1,0,0,0\n"
    code, _, err = run_cli(capsys, "info", write(tmp_path, text, "imu.sto"))
    assert code == 1 and "DataType=Quaternion" in err and "not coordinates" in err


@pytest.fixture(scope="module")
def realnoise_take(tmp_path_factory):
    if not REALNOISE.is_dir():
        pytest.skip(NO_REALNOISE)
    folder = tmp_path_factory.mktemp("realnoise")
    source = REALNOISE / "estimates" / "theia3d" / "gait_participant_01.csv"
    channel = folder / "gait.csv"
    subprocess.run(
        [sys.executable, str(REALNOISE / "to_channel_csv.py"), str(source), str(channel)],
        check=True,
    )
    rows = list(csv.reader(channel.open()))
    columns = [k for k, name in enumerate(rows[0]) if name.endswith(".Zrotation")]
    names = [rows[0][k].rsplit(".", 1)[0] for k in columns]
    head = f"gait\nversion=1\nnRows={len(rows) - 1}\nnColumns={len(names) + 1}\n"
    lines = ["time\t" + "\t".join(names)]
    for row in rows[1:]:
        lines.append("\t".join([row[0]] + [row[k] or "NaN" for k in columns]))
    degrees = folder / "gait.mot"
    degrees.write_text(head + "inDegrees=yes\nendheader\n" + "\n".join(lines) + "\n")
    estimate = list(csv.reader(source.open(encoding="utf-8-sig")))
    keep = [estimate[0].index(name) for name in names]
    radian_lines = ["time\t" + "\t".join(names)]
    for row in estimate[1:]:
        radian_lines.append("\t".join([row[0]] + [row[k] or "NaN" for k in keep]))
    radians = folder / "gait_radians.sto"
    radians.write_text(head + "inDegrees=no\nendheader\n" + "\n".join(radian_lines) + "\n")
    return channel, degrees, radians, names


def test_realnoise_cleans_as_through_the_channel_csv(realnoise_take, tmp_path, capsys):
    channel, degrees, radians, names = realnoise_take
    for source, target in ((channel, "c.csv"), (degrees, "d.mot"), (radians, "r.sto")):
        code, _, err = run_cli(capsys, "clean", source, "-o", tmp_path / target, "-q")
        assert code == 0, err
    cleaned_csv = np.genfromtxt(tmp_path / "c.csv", delimiter=",", skip_header=1)[:, 1::3]
    cleaned_deg = np.genfromtxt(tmp_path / "d.mot", skip_header=7)[:, 1:]
    cleaned_rad = np.rad2deg(np.genfromtxt(tmp_path / "r.sto", skip_header=7)[:, 1:])
    assert cleaned_csv.shape == cleaned_deg.shape == (1200, len(names))
    assert np.isfinite(cleaned_deg).all()  # the dropouts were filled, as in the CSV
    # the same angles, written with the file's six decimals
    assert np.abs(cleaned_deg - cleaned_csv).max() <= 5e-7 + 1e-12
    first_row = (tmp_path / "d.mot").read_text().splitlines()[7].split("\t")
    assert all(len(cell.split(".")[1]) == 6 for cell in first_row[1:])
    # radians (9 significant digits) against degrees with six decimals: the same within
    # the rounding of the inputs
    assert np.abs(cleaned_rad - cleaned_csv).max() < 1e-4
    moved = np.abs(cleaned_deg - np.genfromtxt(degrees, skip_header=7)[:, 1:])
    assert np.nanmax(moved) > 0.1 and math.isfinite(np.nanmax(moved))


def test_coordinates_make_no_bvh_or_gltf(tmp_path, capsys):
    path = write(tmp_path, IK)
    for target, message in (
        ("x.bvh", "OpenSim coordinates have no skeleton"),
        ("x.glb", "glTF needs joint positions: OpenSim coordinates are joint angles"),
    ):
        code, _, err = run_cli(capsys, "convert", path, tmp_path / target, "--exclude", "*_f*")
        assert code == 1 and message in err and not (tmp_path / target).exists()


@pytest.mark.parametrize(("stated", "short"), [("100", True), ("1000000000", True), ("3", False)])
def test_rows_not_as_many_as_nrows_are_read_and_written_with_their_count(
    tmp_path, capsys, stated, short
):
    """OpenSim reads the rows a file holds whatever its nRows says (files cut or edited by
    hand keep a stale one): so does motionclean, saying so, and no output keeps the stale
    count, not even an untouched one."""
    source = write(tmp_path, IK.replace("nRows=6", f"nRows={stated}"))
    clip = mc.load(source, exclude=["*_force"])
    assert clip.n_frames == 6
    said = f"nRows={stated} but the file holds 6 rows{' (cut short?)' if short else ''}"
    assert any(note.startswith(said) for note in clip.source.notes)
    mc.save(clip, tmp_path / "same.mot")
    assert (tmp_path / "same.mot").read_bytes() == write(tmp_path, IK, "true.mot").read_bytes()
    code, out, err = run_cli(
        capsys, "clean", source, "-o", tmp_path / "clean.mot", "--exclude", "*_force"
    )
    assert code == 0 and err == "" and said in out
    cleaned = (tmp_path / "clean.mot").read_text()
    assert "nRows=6\n" in cleaned and f"nRows={stated}" not in cleaned
    half = clip.replace(
        rotations=clip.rotations[::2], translations=clip.translations[::2], frame_time=0.02
    )
    mc.save(half, tmp_path / "half.mot")
    assert "nRows=3\n" in (tmp_path / "half.mot").read_text()


def test_tabs_that_end_a_line_end_no_cell(tmp_path):
    """A label line (and rows) ending in a tab, as some tools write them: read as without
    it (the empty-cell check had refused the labels: "column 7 has no name")."""
    lines = IK.split("\n")
    at = lines.index(next(line for line in lines if line.startswith("time")))
    text = "\n".join(line + "\t" if i >= at and line else line for i, line in enumerate(lines))
    clip, plain = (
        mc.load(write(tmp_path, text), exclude=["*_force"]),
        mc.load(write(tmp_path, IK, "plain.mot"), exclude=["*_force"]),
    )
    assert clip.names == plain.names and np.array_equal(clip.rotations, plain.rotations)


def test_a_stale_ncolumns_is_said_and_no_output_keeps_it(tmp_path):
    """nColumns is told and corrected as nRows is (it had been kept silently)."""
    source = write(tmp_path, IK.replace("nColumns=6", "nColumns=4"))
    clip = mc.load(source, exclude=["*_force"])
    said = "nColumns=4 but the file holds 6 columns: any output says nColumns=6"
    assert said in clip.source.notes
    mc.save(clip, tmp_path / "same.mot")
    assert (tmp_path / "same.mot").read_bytes() == write(tmp_path, IK, "true.mot").read_bytes()
    assert not mc.load(write(tmp_path, IK, "right.mot"), exclude=["*_force"]).source.notes


@pytest.mark.parametrize("stated", ["6", "06"])
def test_a_file_whose_nrows_is_right_says_nothing_of_it(tmp_path, stated):
    source = write(tmp_path, IK.replace("nRows=6", f"nRows={stated}"))
    clip = mc.load(source, exclude=["*_force"])
    assert not any("nRows" in note for note in clip.source.notes)
    mc.save(clip, tmp_path / "same.mot")  # the count is the rows': the file as it was
    assert (tmp_path / "same.mot").read_bytes() == source.read_bytes()


def test_an_nrows_in_other_digits_is_read_as_no_count(tmp_path, capsys):
    """'²' passes str.isdigit but is no count: noted and written as the rows', never an
    internal error."""
    source = write(tmp_path, IK.replace("nRows=6", "nRows=\u00b2"))
    code, out, err = run_cli(capsys, "info", source, "--exclude", "*_force")
    assert code == 0 and err == "" and "but the file holds 6 rows" in out


MARKER_ERRORS = """Model Marker Errors from IK
version=1
nRows=4
nColumns=4
inDegrees=no
endheader
time\ttotal_squared_error\tmarker_error_RMS\tmarker_error_max
      0.01666667\t      0.02626894\t      0.03536809\t      0.09606109
      0.03333333\t      0.02601337\t      0.03519567\t      0.09541120
      0.05000000\t      0.02713012\t      0.03594307\t      0.09801543
      0.06666667\t      0.02590021\t      0.03511902\t      0.09499871
"""


def test_a_marker_errors_file_of_inverse_kinematics_is_refused(tmp_path, capsys):
    """OpenSim's _ik_marker_errors.sto (as Pose2Sim's demo holds it) has no coordinate: its
    errors had been cleaned as angles in radians ('71 % of the jitter removed')."""
    source = write(tmp_path, MARKER_ERRORS, "_ik_marker_errors.sto")
    code, out, err = run_cli(capsys, "clean", source, "-o", tmp_path / "out.sto")
    assert code == 1 and out == "" and not (tmp_path / "out.sto").exists()
    assert err.splitlines() == [
        f"motionclean: error: {source}:7: no coordinate columns: errors (total_squared_error, "
        "marker_error_RMS, marker_error_max: inverse kinematics' marker errors, not angles) "
        "are no motion to clean"
    ]


def test_an_error_column_beside_coordinates_is_carried(tmp_path):
    text = IK.replace("knee_angle_r_force", "marker_error_RMS").replace("n/a", "0.01")
    motion = mc.load(write(tmp_path, text))
    assert motion.names == ["pelvis_rotation", "pelvis_tx", "pelvis_ty", "knee_angle_r"]
    assert any("1 column of errors" in n for n in kinematics.source_notes(motion))
    mc.save(motion, tmp_path / "same.mot")
    assert (tmp_path / "same.mot").read_text() == text


def uneven_states(tmp_path) -> tuple:
    """A states file at an integrator's uneven steps: a knee angle on a parabola in time
    and a pelvis height on a line (degrees, metres), 0.83-1.19 s."""
    rng = np.random.default_rng(4)
    times = np.sort(np.r_[0.83, rng.uniform(0.83, 1.19, 50), 1.19])
    knee = lambda t: -30.0 + 200.0 * (t - 1.0) ** 2  # noqa: E731
    height = lambda t: 0.9 + 0.1 * t  # noqa: E731
    rows = "".join(f"{t:.20f}\t{knee(t):.20f}\t{height(t):.20f}\n" for t in times)
    text = (
        f"states\nversion=1\nnRows={times.size}\nnColumns=3\ninDegrees=yes\nendheader\n"
        f"time\tknee_angle_r\tpelvis_ty\n{rows}"
    )
    return write(tmp_path, text, "cmc_states.sto"), knee, height


def test_a_simulations_uneven_steps_are_resampled_not_cleaned(tmp_path, capsys):
    """CMC and forward simulations write their states at the integrator's steps (1-11 ms
    apart): `clean` refuses them saying what does take them, and `resample` puts them on a
    uniform grid by a cubic that keeps a parabola, from their first time."""
    path, knee, height = uneven_states(tmp_path)
    code, _, err = run_cli(capsys, "clean", path, "-o", tmp_path / "c.sto")
    assert code == 1 and "not uniformly sampled" in err and "motionclean resample" in err
    target = tmp_path / "r.sto"
    code, out, err = run_cli(capsys, "resample", path, target, "--fps", "100")
    assert code == 0 and err == "" and "put on a grid of about the median step" in out
    back = np.genfromtxt(target, skip_header=7)
    np.testing.assert_allclose(np.diff(back[:, 0]), 0.01, atol=1e-9)
    assert back[0, 0] == pytest.approx(0.83) and back[-1, 0] <= 1.19
    np.testing.assert_allclose(back[:, 1], knee(back[:, 0]), atol=0.05)  # (100 fps: low-passed)
    np.testing.assert_allclose(back[:, 2], height(back[:, 0]), atol=1e-9)
    clip = mc.load(path, regrid=True)
    assert clip.frame_rate > 100 and any("integrator steps" in n for n in clip.source.notes)


@pytest.mark.parametrize("gap", [0.03, 100.0])
def test_rows_missing_are_sent_to_resample_only_where_it_bridges_them(tmp_path, capsys, gap):
    """A take at 100 fps with its second half ``gap`` s later: `clean` refuses it at the
    gap's line and advises `resample` only where resample then puts it on a grid (3 frames
    missing); a gap of 100 s beside 2 s of rows (which resample refuses, more than 8 frames
    per row) had been sent there too, and is now told to give the rows (nan cells) or cut
    the file, which `clean` then takes."""
    times = np.arange(200) / 100.0
    times[100:] += gap
    knee = -30.0 + 20.0 * np.sin(3.0 * times)
    head = "ik\nversion=1\nnRows=200\nnColumns=2\ninDegrees=yes\nendheader\n"
    head += "time\tknee_angle_r\n"
    rows = [f"{t:.8f}\t{k:.8f}" for t, k in zip(times, knee, strict=True)]
    path = write(tmp_path, head + "\n".join(rows) + "\n")
    code, _, err = run_cli(capsys, "clean", path, "-o", tmp_path / "c.mot")
    assert code == 1 and err.count("\n") == 1 and f"{path}:108:" in err
    advised = "`motionclean resample FILE OUT --fps N` puts it on a uniform grid" in err
    code, _, resampled = run_cli(capsys, "resample", path, tmp_path / "r.mot", "--fps", "100")
    assert advised == (code == 0) == (gap < 1.0), (err, resampled)
    if advised:
        return
    assert "give every frame its row" in err and "would refuse it" in err
    skipped = round(gap * 100.0)  # the advice taken: the missing rows given, nan cells
    filled = rows[:100] + [f"{1.0 + k / 100.0:.8f}\tnan" for k in range(skipped)]
    filled += [f"{1.0 + (skipped + k) / 100.0:.8f}\t{knee[100 + k]:.8f}" for k in range(100)]
    path = write(tmp_path, head + "\n".join(filled) + "\n", "filled.mot")
    code, _, err = run_cli(capsys, "clean", path, "-o", tmp_path / "c.mot", "-q")
    assert code == 0, err


def test_a_utf16_file_is_not_text_as_bvh_and_csv_say(tmp_path, capsys):
    """It had been "no 'endheader' line: not an OpenSim .mot/.sto"."""
    path = tmp_path / "ik.mot"
    path.write_bytes(IK.encode("utf-16"))
    code, out, err = run_cli(capsys, "info", path)
    assert (code, out) == (1, "")
    assert err == f"motionclean: error: {path}: not a text file (binary data)\n"


def test_ground_on_coordinates_says_it_has_no_joint_positions(tmp_path, capsys):
    """`-f ground` on an IK file (coordinates, no bodies) had changed nothing and said
    nothing ("not smoothed: nothing repaired"): the note on its first translation and the
    verdict say why no floor was looked for."""
    path = write(tmp_path, IK)
    code, out, _ = run_cli(capsys, "clean", path, "-o", tmp_path / "g.mot", "-f", "ground",
                           "--report", tmp_path / "g.json")  # fmt: skip
    assert code == 0 and (tmp_path / "g.mot").read_bytes() == path.read_bytes()
    why = "no joint positions (OpenSim coordinates are joint angles without the model's bodies)"
    assert f"not put on the floor: {why}" in out
    joints = json.loads((tmp_path / "g.json").read_text())["joints"]
    assert joints["pelvis_tx"]["position_ground"] == {"why": why}
