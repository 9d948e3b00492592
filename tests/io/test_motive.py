"""OptiTrack Motive CSV exports: rigid bodies read as joints (X Y Z W quaternions into
(w, x, y, z)), every other column carried through as text, header rows written back byte for
byte, blank cells as missing samples, and one clear error line for what is not read."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from helpers import ROOT, run_cli

import motionclean as mc
from motionclean.core import quat
from motionclean.core.errors import MotionError
from motionclean.io.csv import format_csv
from motionclean.io.motive import MotiveText, parse_motive

MOTIVE_SAMPLE = ROOT / "sample_data" / "131_02_motive.csv"


def export(
    n_frames: int = 12,
    rate: float = 120.0,
    rotation_type: str = "Quaternion",
    mean_marker_error: bool = True,
    gaps: dict | None = None,
    eol: str = "\r\n",
    seed: int = 0,
    rotations: np.ndarray | None = None,
) -> tuple[str, np.ndarray, np.ndarray]:
    """A Motive 1.23 export of two rigid bodies (with rigid-body markers), one unlabeled
    marker; returns its text and the truth: rotations (F, 2, 4) (w, x, y, z), positions.
    ``gaps`` maps (frame, body) to the cells written for that body's 7 values ("" blanks)."""
    rng = np.random.default_rng(seed)
    times = np.arange(n_frames) / rate
    if rotations is None:
        axes = quat.normalize(rng.normal(size=(2, 3)))
        rotations = quat.from_axis_angle(axes, times[:, None] * 3.0 + [0.3, 1.2])
    positions = rng.normal(size=(2, 3)) + times[:, None, None] * [0.5, 0.1, -0.2]
    width = 8 if mean_marker_error else 7
    meta = (
        "Format Version,1.23,Take Name,Take 2024-05-01 10.00.00 AM,Take Notes,,"
        f"Capture Frame Rate,{rate:.6f},Export Frame Rate,{rate:.6f},"
        "Capture Start Time,2024-05-01 10.00.00.000 AM,Capture Start Frame,1200,"
        f"Total Frames in Take,{n_frames},Total Exported Frames,{n_frames},"
        f"Rotation Type,{rotation_type},Length Units,Meters,Coordinate Space,Global"
    )
    types, names, ids, props, axes_row = [], [], [], [], []
    for b, name in enumerate(("Wand", "Head Band")):
        types += ["Rigid Body"] * width + ["Rigid Body Marker"] * 4
        names += [name] * width + [f"{name}:Marker1"] * 4
        ids += [str(b + 1)] * width + [f"{b + 1}:1"] * 4
        props += ["Rotation"] * 4 + ["Position"] * 3
        props += ["Mean Marker Error"] * (width - 7) + ["Position"] * 3 + ["Marker Quality"]
        axes_row += ["X", "Y", "Z", "W", "X", "Y", "Z"] + [""] * (width - 7) + ["X", "Y", "Z", ""]
    types += ["Marker"] * 3
    names += ["Unlabeled 2001"] * 3
    ids += ["Unlabeled 2001"] * 3
    props += ["Position"] * 3
    axes_row += ["X", "Y", "Z"]
    lines = [meta, "", ",Type," + ",".join(types), ",Name," + ",".join(names)]
    lines += [",ID," + ",".join(ids), ",," + ",".join(props)]
    lines += ["Frame,Time (Seconds)," + ",".join(axes_row)]
    for f in range(n_frames):
        cells = [str(f), f"{times[f]:.6f}"]
        for b in range(2):
            w, x, y, z = rotations[f, b]
            body = [f"{v:.6f}" for v in (x, y, z, w, *positions[f, b])]
            body = (gaps or {}).get((f, b), body)
            blank = all(c == "" for c in body)
            cells += body + ["" if blank else "0.000312"] * (width - 7)
            marker = positions[f, b] + 0.05
            cells += ["" if blank else f"{v:.6f}" for v in marker] + ["" if blank else "1.0000"]
        cells += ["", "", ""] if f % 5 == 3 else [f"{0.2 + 0.01 * f:.6f}", "1.500000", "0.000000"]
        lines.append(",".join(cells))
    return eol.join(lines) + eol, rotations, positions


def write(tmp_path: Path, text: str, name: str = "take.csv") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8"))
    return path


def cells_of(path: Path) -> list[list[str]]:
    return [line.split(",") for line in path.read_text().splitlines()]


BLANK = [""] * 7


@pytest.mark.parametrize(
    ("rate", "mme", "eol", "bom"),
    [(120.0, True, "\r\n", False), (240.0, False, "\n", True), (240.0, True, "\n", False)],
)
def test_an_untouched_export_is_written_back_byte_for_byte(tmp_path, rate, mme, eol, bom):
    text, rotations, positions = export(
        rate=rate, mean_marker_error=mme, eol=eol, gaps={(4, 1): BLANK, (5, 1): BLANK}
    )
    source = write(tmp_path, ("\ufeff" if bom else "") + text)
    clip = mc.load(source)
    assert isinstance(clip.source, MotiveText)
    assert clip.names == ["Wand", "Head Band"] and list(clip.parents) == [-1, -1]
    assert clip.frame_time == 1.0 / rate
    np.testing.assert_array_equal(np.flatnonzero(clip.missing[:, 1]), [4, 5])
    assert not clip.missing[:, 0].any()
    mc.save(clip, tmp_path / "same.csv")
    assert (tmp_path / "same.csv").read_bytes() == source.read_bytes()


def test_quaternions_are_read_as_x_y_z_w_into_w_x_y_z(tmp_path):
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.pi / 2)  # 90 deg about +Y
    rotations = np.broadcast_to(turn, (12, 2, 4)).copy()
    text, _, positions = export(rotations=rotations)
    clip = mc.load(write(tmp_path, text))
    # The Wand's cells read "0.000000,0.707107,0.000000,0.707107" (X Y Z W).
    assert cells_of(tmp_path / "take.csv")[7][2:6] == [
        "0.000000",
        "0.707107",
        "0.000000",
        "0.707107",
    ]
    np.testing.assert_allclose(clip.rotations[:, 0], [[0.5**0.5, 0, 0.5**0.5, 0]] * 12, atol=1e-15)
    # +X turned 90 degrees about +Y is -Z.
    np.testing.assert_allclose(
        quat.rotate(clip.rotations[0, 0], [1.0, 0, 0]), [0, 0, -1], atol=1e-12
    )
    np.testing.assert_allclose(clip.translations, np.round(positions, 6), atol=1e-15)


def test_values_match_the_truth_within_the_printed_precision(tmp_path):
    text, rotations, positions = export(n_frames=30, rate=240.0, seed=3)
    clip = mc.load(write(tmp_path, text))
    assert np.degrees(quat.angle_between(clip.rotations, rotations)).max() < 2e-4
    np.testing.assert_allclose(clip.translations, positions, atol=5e-7)


def test_clean_keeps_header_rows_and_carried_columns_and_changes_the_bodies(tmp_path, capsys):
    text, _, _ = export(n_frames=60, gaps={(f, 0): BLANK for f in range(20, 26)})
    source = write(tmp_path, text)
    out = tmp_path / "clean.csv"
    code, _, err = run_cli(capsys, "clean", source, "-o", out, "-f", "lee-shin", "-q")
    assert code == 0, err
    before, after = cells_of(source), cells_of(out)
    head = source.read_bytes().split(b"\r\nFrame,")[0]
    assert out.read_bytes().startswith(head + b"\r\nFrame,")  # header rows byte for byte
    assert after[:7] == before[:7]
    bodies = [2, 3, 4, 5, 6, 7, 8, 14, 15, 16, 17, 18, 19, 20]  # rotation and position cells
    carried = [k for k in range(len(before[7])) if k not in bodies]
    assert [[r[k] for k in carried] for r in after[7:]] == [
        [r[k] for k in carried] for r in before[7:]
    ]
    changed = [r[k] != s[k] for r, s in zip(after[7:], before[7:], strict=True) for k in bodies]
    assert any(changed)
    for f in range(20, 26):  # the missing Wand stays blank
        assert after[7 + f][2:10] == [""] * 8
    back = mc.load(out)
    np.testing.assert_array_equal(back.missing, mc.load(source).missing)


def test_blank_cells_of_the_sample_survive_a_clean(tmp_path, capsys):
    source = tmp_path / "sample.csv"
    source.write_bytes(MOTIVE_SAMPLE.read_bytes())
    out = tmp_path / "clean.csv"
    code, _, err = run_cli(capsys, "clean", source, "-o", out, "-f", "lee-shin", "-q")
    assert code == 0, err
    clip, cleaned = mc.load(source), mc.load(out)
    assert clip.missing is not None
    np.testing.assert_array_equal(cleaned.missing, clip.missing)
    gap = np.flatnonzero(clip.missing.any(axis=1))
    for f in gap:
        line = out.read_text().splitlines()[7 + f].split(",")
        rows = np.flatnonzero(clip.missing[f])
        assert all(line[2 + 20 * b : 2 + 20 * b + 8] == [""] * 8 for b in rows)


def test_a_resampled_clip_is_written_with_its_rigid_bodies_only(tmp_path):
    text, _, _ = export(n_frames=20, gaps={(6, 1): BLANK})
    clip = mc.load(write(tmp_path, text))
    half = clip.replace(
        rotations=clip.rotations[::2],
        translations=clip.translations[::2],
        missing=clip.missing[::2],
        frame_time=clip.frame_time * 2,
    )
    mc.save(half, tmp_path / "half.csv")
    rows = cells_of(tmp_path / "half.csv")
    meta = dict(zip(rows[0][0::2], rows[0][1::2], strict=False))
    assert meta["Export Frame Rate"] == "60.000000" and meta["Total Exported Frames"] == "10"
    assert meta["Capture Frame Rate"] == "120.000000" and meta["Take Name"].startswith("Take")
    assert rows[2] == ["", "Type"] + ["Rigid Body"] * 14
    assert rows[3] == ["", "Name"] + ["Wand"] * 7 + ["Head Band"] * 7
    assert rows[5] == ["", ""] + (["Rotation"] * 4 + ["Position"] * 3) * 2
    assert rows[6] == ["Frame", "Time (Seconds)"] + ["X", "Y", "Z", "W", "X", "Y", "Z"] * 2
    back = mc.load(tmp_path / "half.csv")
    assert back.frame_time == 1 / 60
    np.testing.assert_array_equal(back.missing, half.missing)
    known = ~half.missing
    np.testing.assert_array_equal(back.translations[known], half.translations[known])
    np.testing.assert_array_equal(back.rotations[known], half.rotations[known])


def test_csv_extension_is_sniffed(tmp_path):
    text, _, _ = export()
    clip = mc.load(write(tmp_path, "\ufeff" + text))
    assert isinstance(clip.source, MotiveText)
    rigid = format_csv(clip, layout="rigid")  # the same clip as a rigid-body CSV
    again = mc.load(write(tmp_path, rigid.decode(), "rigid.csv"))
    assert not isinstance(again.source, MotiveText)
    np.testing.assert_array_equal(again.rotations, clip.rotations)
    np.testing.assert_array_equal(again.translations, clip.translations)


def test_a_clip_without_gaps_converts_to_bvh(tmp_path, capsys):
    text, _, _ = export()
    source = write(tmp_path, text)
    code, _, err = run_cli(capsys, "convert", source, tmp_path / "take.bvh")
    assert code == 0, err
    bvh = mc.load(tmp_path / "take.bvh")
    assert bvh.names == ["Wand", "Head Band"]
    assert np.degrees(quat.angle_between(bvh.rotations, mc.load(source).rotations)).max() < 1e-5


def test_a_clip_with_gaps_converts_to_bvh_once_they_are_filled(tmp_path, capsys):
    """BVH has no blank values: ``convert`` (no step runs) says how to fill the sample's
    dropout; ``clean`` with fill-gaps writes the BVH."""
    source, target = ROOT / "sample_data" / "131_02_motive.csv", tmp_path / "take.bvh"
    code, _, err = run_cli(capsys, "convert", source, target)
    assert code == 1 and err.count("\n") == 1 and not target.exists()
    assert "'hand_l' is missing on frames 40-47" in err and "fill-gaps step" in err, err
    code, _, err = run_cli(capsys, "clean", source, "-o", target, "-f", "fill-gaps")
    assert code == 0, err
    assert not np.isnan(mc.load(target).rotations).any()


def replace_line(text: str, number: int, old: str, new: str) -> str:
    lines = text.split("\r\n")
    assert old in lines[number - 1]
    lines[number - 1] = lines[number - 1].replace(old, new, 1)
    return "\r\n".join(lines)


def check_error(tmp_path, capsys, text: str, line: int, fragment: str) -> None:
    source = write(tmp_path, text)
    with pytest.raises(MotionError, match=re.escape(fragment)) as error:
        parse_motive(source.read_bytes(), source)
    assert error.value.line == line
    code, _, err = run_cli(capsys, "convert", source, tmp_path / "out.csv")
    assert code == 1
    assert err.splitlines() == [f"motionclean: error: {source}:{line}: {error.value.message}"]
    assert not (tmp_path / "out.csv").exists()


@pytest.mark.parametrize("kind", ["XYZ", "ZYX"])
def test_euler_exports_are_refused(tmp_path, capsys, kind):
    text, _, _ = export(rotation_type=kind)
    check_error(tmp_path, capsys, text, 1, f"Rotation Type {kind} is Euler angles")


def test_an_unknown_rotation_type_is_refused(tmp_path, capsys):
    text, _, _ = export(rotation_type="Matrix")
    check_error(tmp_path, capsys, text, 1, "unknown Rotation Type 'Matrix' (expected Quaternion)")


def test_a_property_row_that_does_not_match_the_axis_row_is_refused(tmp_path, capsys):
    text, _, _ = export()
    # The Wand loses its W column: Rotation over X, Y, Z and a Position over W.
    shifted = replace_line(
        text, 6, ",,Rotation,Rotation,Rotation,Rotation,", ",,Rotation,Rotation,Rotation,Position,"
    )
    check_error(
        tmp_path,
        capsys,
        shifted,
        6,
        "the property row does not match the axis row: rigid body 'Wand' has Rotation over "
        "X,Y,Z and Position over W,X,Y,Z",
    )
    no_w = replace_line(text, 7, "Frame,Time (Seconds),X,Y,Z,W,", "Frame,Time (Seconds),X,Y,Z,,")
    check_error(tmp_path, capsys, no_w, 6, "rigid body 'Wand' has Rotation over X,Y,Z,(none)")


def test_a_partly_blank_rigid_body_is_refused(tmp_path, capsys):
    text, _, _ = export(gaps={(3, 1): ["0.1", "0.2", "0.3", "", "1.0", "2.0", "3.0"]})
    check_error(
        tmp_path,
        capsys,
        text,
        11,
        "body 'Head Band' is partly blank: empty value in Rotation W (column 18)",
    )


def test_the_time_column_must_follow_the_export_frame_rate(tmp_path, capsys):
    text, _, _ = export(rate=120.0)
    text = replace_line(text, 1, "Export Frame Rate,120.000000", "Export Frame Rate,240.000000")
    check_error(
        tmp_path, capsys, text, 9, "the Time column does not follow Export Frame Rate 240.000000"
    )


def test_the_header_must_have_its_rows(tmp_path, capsys):
    text, _, _ = export()
    no_axis = "\r\n".join(line for line in text.split("\r\n") if not line.startswith("Frame,"))
    check_error(tmp_path, capsys, no_axis, 7, "no axis row 'Frame,Time (Seconds),X,Y,...'")
    no_name = "\r\n".join(line for line in text.split("\r\n") if not line.startswith(",Name,"))
    check_error(tmp_path, capsys, no_name, 6, "no ',Name,...' row above the axis row")
    blank_time = replace_line(text, 10, "2,0.016667,", "2,,")
    check_error(tmp_path, capsys, blank_time, 10, "the Time column is blank")


@pytest.mark.parametrize(
    ("time", "message"),
    [
        ("nan", "the Time column holds NaN, not a number"),
        ("5.0", "time 5 s is out of order (the row before has 0.008333 s, the next 0.025 s)"),
        ("0.0", "time does not increase (0 s after 0.008333 s)"),
    ],
)
def test_a_time_that_is_no_number_or_out_of_order_is_said_on_its_row(
    tmp_path, capsys, time, message
):
    """A NaN time had been "blank", and a time above both its neighbours' had been named on
    the row after it ("0.025 s after 5 s")."""
    text, _, _ = export()
    check_error(tmp_path, capsys, replace_line(text, 10, "2,0.016667,", f"2,{time},"), 10, message)


def with_parent_row(text: str) -> str:
    """``text`` as Motive 3 (format 1.25) writes it: a ``,Parent,...`` row after the ID row
    (empty over rigid bodies, the body's name over its markers)."""
    lines = text.split("\r\n")
    types, names = lines[2].split(",")[2:], lines[3].split(",")[2:]
    parents = [
        n.split(":")[0] if t == "Rigid Body Marker" else ""
        for t, n in zip(types, names, strict=True)
    ]
    lines.insert(5, ",Parent," + ",".join(parents))
    lines[0] = lines[0].replace("Format Version,1.23", "Format Version,1.25")
    return "\r\n".join(lines)


def test_a_motive_3_export_with_a_parent_row_is_read_and_written_back(tmp_path, capsys):
    text, rotations, _ = export(n_frames=40, gaps={(6, 1): BLANK})
    source = write(tmp_path, with_parent_row(text))
    clip = mc.load(source)
    assert clip.names == ["Wand", "Head Band"]
    np.testing.assert_array_equal(clip.rotations, mc.load(write(tmp_path, text, "x.csv")).rotations)
    mc.save(clip, tmp_path / "same.csv")
    assert (tmp_path / "same.csv").read_bytes() == source.read_bytes()
    out = tmp_path / "clean.csv"
    code, _, err = run_cli(capsys, "clean", source, "-o", out, "-f", "lee-shin", "-q")
    assert code == 0, err
    head = source.read_bytes().split(b"\r\nFrame,")[0]
    assert out.read_bytes().startswith(head + b"\r\nFrame,")  # the Parent row byte for byte
    assert out.read_bytes() != source.read_bytes()


def test_a_resampled_motive_3_export_keeps_its_rows_over_each_body(tmp_path):
    text, _, _ = export(n_frames=20)
    clip = mc.load(write(tmp_path, with_parent_row(text)))
    half = clip.replace(
        rotations=clip.rotations[::2],
        translations=clip.translations[::2],
        frame_time=clip.frame_time * 2,
    )
    mc.save(half, tmp_path / "half.csv")
    rows = cells_of(tmp_path / "half.csv")
    assert rows[4] == ["", "ID"] + ["1"] * 7 + ["2"] * 7
    assert rows[5] == ["", "Parent"] + [""] * 14  # (a rigid body has no parent)
    assert rows[6] == ["", ""] + (["Rotation"] * 4 + ["Position"] * 3) * 2
    assert rows[7] == ["Frame", "Time (Seconds)"] + ["X", "Y", "Z", "W", "X", "Y", "Z"] * 2
    assert mc.load(tmp_path / "half.csv").frame_time == 1 / 60


MOTIVE_1_21 = ROOT / "tests" / "data" / "motive" / "hmv_sample_take_1.21.csv"


def labelled(text: str) -> str:
    """``text`` (header rows without labels) with ``Type``, ``Name``, ``ID`` put in."""
    lines = text.split("\r\n")
    for number, label in ((3, "Type"), (4, "Name"), (5, "ID")):
        assert lines[number - 1].startswith(",,")
        lines[number - 1] = f",{label}," + lines[number - 1][2:]
    return "\r\n".join(lines)


def test_a_real_1_21_export_without_row_labels_is_read_by_the_rows_places(tmp_path, capsys):
    source = tmp_path / "take.csv"
    source.write_bytes(MOTIVE_1_21.read_bytes())
    clip = mc.load(source)
    said = mc.load(write(tmp_path, labelled(MOTIVE_1_21.read_bytes().decode()), "said.csv"))
    assert clip.names == said.names == ["Rigid Body 1"] and clip.n_frames == 250
    np.testing.assert_array_equal(clip.rotations, said.rotations)
    np.testing.assert_array_equal(clip.translations, said.translations)
    assert clip.frame_time == 1 / 120
    mc.save(clip, tmp_path / "same.csv")
    assert (tmp_path / "same.csv").read_bytes() == source.read_bytes()
    half = clip.replace(
        rotations=clip.rotations[::2], translations=clip.translations[::2], frame_time=1 / 60
    )
    mc.save(half, tmp_path / "half.csv")  # written afresh: the rows stay without labels
    rows = cells_of(tmp_path / "half.csv")
    assert [r[:3] for r in rows[2:7]] == [
        ["", "", "Rigid Body"],
        ["", "", "Rigid Body 1"],
        ["", "", "CF5107FCB3ED11E565670A50E6808782"],  # (quotes only where needed)
        ["", "", "Rotation"],
        ["Frame", "Time", "X"],
    ]
    assert mc.load(tmp_path / "half.csv").n_frames == 125


def test_a_row_of_commas_is_a_blank_row(tmp_path):
    """Excel and LibreOffice save the blank line 2 as ``,,,,...`` (every row as wide as the
    widest)."""
    text, _, _ = export()
    lines = text.split("\r\n")
    assert lines[1] == ""
    lines[1] = "," * (len(lines[2].split(",")) - 1)
    padded = write(tmp_path, "\r\n".join(lines), "padded.csv")
    clip = mc.load(padded)
    np.testing.assert_array_equal(clip.rotations, mc.load(write(tmp_path, text)).rotations)
    mc.save(clip, tmp_path / "same.csv")
    assert (tmp_path / "same.csv").read_bytes() == padded.read_bytes()


def test_header_rows_without_labels_that_cannot_be_placed_are_refused(tmp_path, capsys):
    text = MOTIVE_1_21.read_bytes().decode()
    no_id = "\r\n".join(line for k, line in enumerate(text.split("\r\n")) if k != 4)
    check_error(tmp_path, capsys, no_id, 3, "3 header rows without a label (',,...')")
    lines = labelled(text).split("\r\n")
    lines[3] = ",," + lines[3].removeprefix(",Name,")  # Type and ID said, Name not
    check_error(
        tmp_path,
        capsys,
        "\r\n".join(lines),
        6,
        "a second header row without a label (first at line 4): only the property row",
    )


def with_times(text: str, times) -> str:
    """``text`` with the Time cell of data row ``f`` replaced by ``times[f]``."""
    lines = text.split("\r\n")
    for f, time in enumerate(times):
        cells = lines[7 + f].split(",")
        cells[1] = time
        lines[7 + f] = ",".join(cells)
    return "\r\n".join(lines)


@pytest.mark.parametrize(("rate", "cut"), [(240.0, np.floor), (360.0, np.floor), (240.0, np.round)])
def test_times_in_whole_milliseconds_are_timed_by_the_export_frame_rate(
    tmp_path, capsys, rate, cut
):
    """Motive 1.23 (the Rofunc take) writes times cut to milliseconds: 0.008, 0.016, 0.025 at
    120 fps, 0.004, 0.008, 0.012 at 240 (refused before as not uniformly sampled)."""
    n = 60
    text, _, _ = export(n_frames=n, rate=rate)
    ms = [f"{cut(f / rate * 1000) / 1000:.6f}" for f in range(n)]
    source = write(tmp_path, with_times(text, ms))
    clip = mc.load(source)
    assert clip.frame_time == 1 / rate and clip.n_frames == n
    assert any("steps of 0.001 s" in note for note in clip.source.notes)
    mc.save(clip, tmp_path / "same.csv")
    assert (tmp_path / "same.csv").read_bytes() == source.read_bytes()
    out = tmp_path / "clean.csv"
    code, said, err = run_cli(capsys, "clean", source, "-o", out, "-f", "lee-shin")
    assert code == 0 and err == ""
    assert "note: the Time column is in steps of 0.001 s" in said
    assert [r[1] for r in cells_of(out)[7:]] == ms  # the time text as it was
    assert out.read_bytes() != source.read_bytes()


def test_times_in_milliseconds_that_do_not_follow_the_frames_are_refused(tmp_path, capsys):
    rate, n = 240.0, 30
    text, _, _ = export(n_frames=n, rate=rate)
    ms = [np.floor(f / rate * 1000) / 1000 for f in range(n)]
    ms[9] += 0.002  # a sample 2 ms late: really off the grid, not rounding
    check_error(
        tmp_path,
        capsys,
        with_times(text, [f"{t:.6f}" for t in ms]),
        17,
        "the Time column does not follow Export Frame Rate 240.000000 and the Frame column: "
        "time 0.039 s is off its frame's time by more than the column's steps of 0.001 s",
    )
    ms = [np.floor(f / rate * 1000) / 1000 for f in range(n)]
    lines = with_times(text, [f"{t:.6f}" for t in ms]).split("\r\n")
    lines[7 + 5] = "6" + lines[7 + 5][1:]  # frame 5 numbered 6: the frames skip
    check_error(tmp_path, capsys, "\r\n".join(lines), 13, "frame 6 follows frame 4: the Frame")


@pytest.mark.parametrize(("row", "number"), [(5, "9999"), (5, "4"), (0, "0.5"), (9, "10")])
def test_a_frame_column_that_does_not_count_the_rows_is_refused(tmp_path, capsys, row, number):
    """Times at full precision do not stand for the Frame column: a frame number edited,
    repeated or skipped is a corrupt export, refused on its own row (exit 1)."""
    text, _, _ = export(n_frames=12)
    lines = text.split("\r\n")
    lines[7 + row] = number + lines[7 + row][lines[7 + row].index(",") :]
    source = write(tmp_path, "\r\n".join(lines))
    code, _, err = run_cli(capsys, "info", source)
    what = "is not a whole number" if row == 0 else "follows frame"
    assert code == 1 and err.startswith(f"motionclean: error: {source}:{8 + row}: ")
    assert what in err and err.count("\n") == 1


def test_rows_not_as_many_as_total_exported_frames_are_refused(tmp_path, capsys):
    """A file cut at a line end (or with rows added) is refused, as BVH is: its header's
    count would be stale in every output."""
    text, _, _ = export(n_frames=12)
    lines = text.split("\r\n")
    cut = "\r\n".join(lines[: 7 + 9]) + "\r\n"
    check_error(
        tmp_path,
        capsys,
        cut,
        16,
        "the file ends after 9 frame rows but Total Exported Frames says 12 (the file is cut "
        "short)",
    )
    huge = replace_line(text, 1, "Total Exported Frames,12", "Total Exported Frames,1000000000")
    check_error(tmp_path, capsys, huge, 19, "the file ends after 12 frame rows")
    fewer = replace_line(text, 1, "Total Exported Frames,12", "Total Exported Frames,10")
    check_error(tmp_path, capsys, fewer, 18, "more frame rows than Total Exported Frames 10")
    word = replace_line(text, 1, "Total Exported Frames,12", "Total Exported Frames,all")
    check_error(tmp_path, capsys, word, 1, "Total Exported Frames is not a whole number: 'all'")
    sup = replace_line(text, 1, "Total Exported Frames,12", "Total Exported Frames,\u00b2")
    check_error(tmp_path, capsys, sup, 1, "Total Exported Frames is not a whole number")


def as_bones(text: str, bodies: tuple[str, ...]) -> str:
    """``text`` with the columns of ``bodies`` typed ``Bone`` (a skeleton's, as Motive
    exports them) instead of ``Rigid Body``."""
    lines = text.split("\r\n")
    types, names = lines[2].split(","), lines[3].split(",")
    for k, name in enumerate(names):
        if name in bodies and types[k] == "Rigid Body":
            types[k] = "Bone"
    lines[2] = ",".join(types)
    return "\r\n".join(lines)


def test_skeleton_bones_are_carried_and_said_so(tmp_path, capsys):
    text, _, _ = export(n_frames=40)
    source = write(tmp_path, as_bones(text, ("Head Band",)))
    clip = mc.load(source)
    assert clip.names == ["Wand"]
    said = "1 skeleton bone (Head Band: Bone columns) carried as they are, not read"
    assert any(note.startswith(said) for note in clip.source.notes)
    mc.save(clip, tmp_path / "same.csv")
    assert (tmp_path / "same.csv").read_bytes() == source.read_bytes()
    code, out, err = run_cli(capsys, "clean", source, "-o", tmp_path / "clean.csv")
    assert code == 0 and err == "" and f"note: {said}" in out


def test_a_skeleton_only_export_is_refused_saying_bones_are_not_read(tmp_path, capsys):
    text, _, _ = export()
    check_error(
        tmp_path,
        capsys,
        as_bones(text, ("Wand", "Head Band")),
        3,
        "no rigid bodies: skeleton (Bone) data is not read, only rigid bodies (the Type row "
        "has 2 bones, Wand, Head Band, and no 'Rigid Body' column)",
    )


def test_a_motive_take_is_y_up_as_motive_exports_are(tmp_path, capsys):
    """Motive's world is Y up and its header does not say: the take declares y (the real
    1.21 take, a small body on a table, was found x up and turned 90 degrees in glTF)."""
    source = tmp_path / "take.csv"
    source.write_bytes(MOTIVE_1_21.read_bytes())
    assert mc.load(source).up == "y"
    code, out, _ = run_cli(capsys, "info", source)
    assert code == 0 and "up axis: y (Motive's default; the export does not say" in out
    assert "body height: none (no skeleton)" in out  # (had read "0 units")
    code, out, _ = run_cli(capsys, "info", source, "--up", "z")
    assert code == 0 and "up axis: z (given)" in out
    # clean and its report say the same: assumed, not given (the user gave nothing)
    for up, said in ((None, "assumed"), ("z", "given"), ("y", "given")):
        report = tmp_path / f"{up}.json"
        extra = () if up is None else ("--up", up)
        code, out, _ = run_cli(
            capsys, "clean", source, "-o", tmp_path / "c.csv", "--report", report, *extra
        )
        world = json.loads(report.read_text())["world"]
        assert code == 0 and world["up_axis_source"] == said and world["body_height"] is None
        assert f"({said}" in out and "no body height (no skeleton)" in out
    code, _, err = run_cli(capsys, "convert", source, tmp_path / "take.glb")
    assert code == 0, err
    assert b"motionclean_up" not in (tmp_path / "take.glb").read_bytes()  # no node turning it
    assert mc.load(tmp_path / "take.glb").up == "y"


def test_a_body_named_twice_with_one_id_is_said_to_be_duplicated(tmp_path, capsys):
    """Two bodies of one name and ID had 'Rotation over X,Y,Z,W and Position over X,Y,Z (a
    rigid body needs Rotation over X, Y, Z, W and Position over X, Y, Z)'."""
    text, _, _ = export()
    twice = replace_line(text.replace("Head Band", "Wand"), 5, ",2,2,2,2,2,2,2,2,", ",1" * 8 + ",")
    check_error(
        tmp_path,
        capsys,
        twice,
        4,
        "rigid body 'Wand' has its columns twice (Rotation X in columns 3 and 15): two rigid "
        "bodies with the same name and ID? Rename one in Motive",
    )


@pytest.mark.parametrize(
    ("said", "unit"),
    [("Meters", "m"), ("Centimeters", "cm"), ("Millimeters", "mm"), ("Furlongs", None)],
)
def test_positions_are_in_the_length_units_the_export_names(tmp_path, capsys, said, unit):
    """The metadata's `Length Units` is the positions' unit: the report's `length_unit` and
    the steps' notes say it (`m`, `cm`, `mm`); a value not known leaves the file's own,
    unsaid ("units"; the notes' `"length"`)."""
    text = export()[0].replace("Length Units,Meters", f"Length Units,{said}")
    source = write(tmp_path, text)
    assert mc.kinematics.length_unit(mc.load(source)) == unit
    report = tmp_path / "r.json"
    code, _, err = run_cli(capsys, "clean", source, "-o", tmp_path / "c.csv", "--report", report)
    assert code == 0, err
    read = json.loads(report.read_text())
    assert read.get("length_unit") == unit
    notes = [joint["position_auto"] for joint in read["joints"].values()]
    assert notes and all(note["unit"] == (unit or "length") for note in notes)
