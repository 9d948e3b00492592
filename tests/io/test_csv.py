"""CSV formats: the channel CSV mirrors the BVH MOTION block and converts back exactly with
the original as skeleton; the rigid-body CSV keeps quaternions as they are and round-trips
bit for bit."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from helpers import CORPUS_NAMES, NOISY, ROOT, SAMPLE, corpus_clip, cut_bvh, max_degrees, run_cli
from hypothesis import given, settings
from hypothesis import strategies as st

import motionclean as mc
from motionclean.cli.main import main
from motionclean.core import quat
from motionclean.core.errors import MotionError
from motionclean.io.csv import RIGID_SUFFIXES, format_csv, parse_csv


def convert(*args: str) -> None:
    with pytest.raises(SystemExit) as done:
        main(["convert", *map(str, args)])
    assert done.value.code == 0


def read_table(path: Path) -> tuple[list[str], np.ndarray]:
    """Header and values of a CSV file, read with the standard library (independent)."""
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r]
    return rows[0], np.array([[float(v) for v in r] for r in rows[1:]])


def bvh_rows(path: Path) -> list[list[str]]:
    """The frame rows of a BVH file as token lists."""
    lines = Path(path).read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
    return [line.split() for line in lines[start:] if line.strip()]


# ----------------------------------------------------------------------------- channel CSV


def test_channel_csv_mirrors_the_motion_block(tmp_path):
    clip = mc.load(SAMPLE)
    convert(SAMPLE, tmp_path / "clip.csv")
    header, table = read_table(tmp_path / "clip.csv")
    expected = [
        f"{name}.{ch}"
        for name, chans in zip(clip.names, clip.channels, strict=True)
        for ch in chans
    ]
    assert header == ["frame", "time", *expected]
    assert header[2] == "Hips.Xposition"
    np.testing.assert_array_equal(table[:, 0], np.arange(clip.n_frames))
    np.testing.assert_allclose(
        table[:, 1], np.arange(clip.n_frames) * clip.frame_time, rtol=1e-11, atol=1e-12
    )
    np.testing.assert_array_equal(table[:, 2:], clip.source_values)
    # Unchanged values keep the BVH text, so each cell reads exactly like the BVH token.
    with open(tmp_path / "clip.csv", newline="") as f:
        cells = [r[2:] for r in csv.reader(f)][1:]
    assert cells == bvh_rows(SAMPLE)


@pytest.mark.parametrize("name", ["sample", *CORPUS_NAMES])
def test_bvh_csv_bvh_with_skeleton_is_byte_identical(name, tmp_path):
    clip_path = SAMPLE if name == "sample" else corpus_clip(name)
    convert(clip_path, tmp_path / "clip.csv")
    convert(tmp_path / "clip.csv", tmp_path / "back.bvh", "--skeleton", clip_path)
    assert (tmp_path / "back.bvh").read_bytes() == clip_path.read_bytes()


def test_csv_with_full_precision_values_converts_exactly(tmp_path):
    """A CSV written by another tool (repr values, 4-decimal times) still gives the template."""
    clip = mc.load(SAMPLE)
    rows = [
        "time,"
        + ",".join(f"{n}.{c}" for n, cs in zip(clip.names, clip.channels, strict=True) for c in cs)
    ]
    for i, values in enumerate(clip.source_values.tolist()):
        rows.append(f"{i * clip.frame_time:.4f}," + ",".join(map(repr, values)))
    (tmp_path / "clip.csv").write_text("\r\n".join(rows) + "\r\n")
    moved = mc.load(tmp_path / "clip.csv", skeleton=clip)
    assert moved.frame_time == clip.frame_time  # the template's, since the times fit it
    mc.save(moved, tmp_path / "back.bvh")
    assert (tmp_path / "back.bvh").read_bytes() == SAMPLE.read_bytes()


def test_edited_csv_changes_only_the_edited_values(tmp_path):
    clip = mc.load(SAMPLE)
    convert(SAMPLE, tmp_path / "clip.csv")
    header, table = read_table(tmp_path / "clip.csv")
    rng = np.random.default_rng(3)
    edits = [
        (int(rng.integers(clip.n_frames)), int(rng.integers(2, len(header)))) for _ in range(25)
    ]
    lines = (tmp_path / "clip.csv").read_text().splitlines()
    for frame, column in edits:
        cells = lines[frame + 1].split(",")
        table[frame, column] += rng.uniform(-20, 20)
        cells[column] = repr(float(table[frame, column]))
        lines[frame + 1] = ",".join(cells)
    (tmp_path / "clip.csv").write_text("\n".join(lines) + "\n")
    convert(tmp_path / "clip.csv", tmp_path / "back.bvh", "--skeleton", SAMPLE)

    back = mc.load(tmp_path / "back.bvh")
    np.testing.assert_allclose(back.source_values, table[:, 2:], atol=1e-6)
    before, after = bvh_rows(SAMPLE), bvh_rows(tmp_path / "back.bvh")
    edited = {(f, c - 2) for f, c in edits}
    for f, (row_before, row_after) in enumerate(zip(before, after, strict=True)):
        for c, (a, b) in enumerate(zip(row_before, row_after, strict=True)):
            if (f, c) not in edited:
                assert a == b
    # Everything outside the frame rows is the template's text.
    text = SAMPLE.read_bytes()
    assert (tmp_path / "back.bvh").read_bytes().startswith(text[: text.index(b"Frame Time")])


def test_modified_motion_via_csv_equals_direct_bvh(tmp_path):
    clip = mc.load(SAMPLE)
    tilt = quat.from_axis_angle(np.array([0.0, 0.6, 0.8]), np.deg2rad(7.0))
    shift = np.where(clip.layout.has_position[:, None], 0.25, 0.0)
    moved = clip.replace(
        rotations=quat.multiply(clip.rotations, tilt), translations=clip.translations + shift
    )
    mc.save(moved, tmp_path / "direct.bvh")
    mc.save(moved, tmp_path / "moved.csv")
    back = mc.load(tmp_path / "moved.csv", skeleton=clip)
    np.testing.assert_allclose(back.translations, moved.translations, atol=1e-12)
    assert np.max(np.rad2deg(quat.angle_between(back.rotations, moved.rotations))) < 1e-9
    mc.save(back, tmp_path / "via_csv.bvh")
    direct = mc.load(tmp_path / "direct.bvh").source_values
    via_csv = mc.load(tmp_path / "via_csv.bvh").source_values
    np.testing.assert_allclose(via_csv, direct, atol=1.5e-6)


def test_channel_csv_without_skeleton_has_no_world_figures(tmp_path, capsys):
    """Without offsets its joints have no world places: info and the report say world
    figures are skipped and why, instead of an up axis and a body height of 0; given a
    skeleton, they are back."""
    mc.save(mc.load(SAMPLE), tmp_path / "clip.csv")
    code, out, err = run_cli(capsys, "info", tmp_path / "clip.csv")
    assert code == 0, err
    assert "world: skipped (a channel CSV holds no skeleton" in out
    assert "body height" not in out
    code, out, err = run_cli(capsys, "info", tmp_path / "clip.csv", "--skeleton", SAMPLE)
    assert code == 0, err
    assert "world: skipped" not in out and "body height: 24.27" in out


def test_channel_csv_without_skeleton_is_a_flat_clip(tmp_path):
    clip = mc.load(SAMPLE)
    mc.save(clip, tmp_path / "clip.csv")
    flat = mc.load(tmp_path / "clip.csv")
    assert flat.names == clip.names
    assert flat.channels == clip.channels
    assert np.all(flat.parents == -1)
    assert np.all(flat.offsets == 0)
    assert flat.frame_time == clip.frame_time
    np.testing.assert_array_equal(flat.rotations, clip.rotations)
    np.testing.assert_array_equal(flat.translations, clip.translations)
    # CSV to CSV keeps the file; a changed clip rewrites what changed, exactly (a value that
    # moved by rounding alone, within 1e-9, keeps its text)
    mc.save(flat, tmp_path / "same.csv")
    assert (tmp_path / "same.csv").read_bytes() == (tmp_path / "clip.csv").read_bytes()
    turned = flat.replace(
        rotations=quat.multiply(flat.rotations, quat.from_axis_angle(np.array([1.0, 0, 0]), 0.3))
    )
    mc.save(turned, tmp_path / "turned.csv")
    again = mc.load(tmp_path / "turned.csv")
    written = turned.channel_values()
    moved = np.abs(written - flat.source_values) > 1e-9
    np.testing.assert_array_equal(again.source_values[moved], written[moved])
    np.testing.assert_array_equal(again.source_values[~moved], flat.source_values[~moved])
    header, _ = read_table(tmp_path / "turned.csv")
    assert header == read_table(tmp_path / "clip.csv")[0]
    with pytest.raises(MotionError, match="--skeleton"):
        mc.save(flat, tmp_path / "flat.bvh")
    with pytest.raises(MotionError, match="pass a BVH file") as error:
        mc.load(tmp_path / "clip.csv", skeleton=flat)
    assert error.value.path == str(tmp_path / "clip.csv")


def test_clean_command_on_a_channel_csv(tmp_path):
    mc.save(mc.load(SAMPLE), tmp_path / "clip.csv")
    with pytest.raises(SystemExit) as done:
        main(["clean", str(tmp_path / "clip.csv"), "-o", str(tmp_path / "clean.csv"), "-q"])
    assert done.value.code == 0
    before, after = read_table(tmp_path / "clip.csv"), read_table(tmp_path / "clean.csv")
    assert before[0] == after[0]
    np.testing.assert_array_equal(before[1][:, :2], after[1][:, :2])
    assert not np.array_equal(before[1], after[1])


@pytest.mark.parametrize("suffix", [".csv", ".bvh"])
def test_a_csv_of_another_take_read_into_a_template_keeps_its_own_values(tmp_path, suffix):
    """A channel CSV read with a skeleton template of the same length but other values (the
    rig's own take) is written with the CSV's values, in either format: only cells equal
    to the template's keep its text (a CSV written back had taken the template's values)."""
    clip = mc.load(SAMPLE)
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(5.0))
    take = clip.replace(rotations=quat.multiply(clip.rotations, turn), source_values=None)
    mc.save(take, tmp_path / "take.csv")
    read = mc.load(tmp_path / "take.csv", skeleton=clip)
    mc.save(read, tmp_path / f"out{suffix}")
    back = mc.load(tmp_path / f"out{suffix}", skeleton=clip)
    assert max_degrees(back.rotations, take.rotations) < 1e-4
    np.testing.assert_allclose(back.translations, take.translations, atol=1e-6)
    read.offsets[1] += 100.0  # the clip's skeleton is its own: the template keeps its own
    np.testing.assert_array_equal(clip.offsets, mc.load(SAMPLE).offsets)
    again = mc.load(tmp_path / "take.csv", skeleton=str(SAMPLE))
    np.testing.assert_array_equal(again.offsets, mc.load(SAMPLE).offsets)


def test_a_skeleton_read_once_is_read_again_when_its_file_changes(tmp_path):
    """ReadOptions keeps the skeleton between clips, but never a copy its file no longer
    holds: a rig edited (even to the same size) gives the next clip its new offsets."""
    shutil.copy(SAMPLE, tmp_path / "rig.bvh")
    mc.save(mc.load(SAMPLE), tmp_path / "clip.csv")
    read = mc.io.ReadOptions(skeleton=str(tmp_path / "rig.bvh"))
    first, again = read.load(tmp_path / "clip.csv"), read.load(tmp_path / "clip.csv")
    np.testing.assert_array_equal(first.offsets, again.offsets)
    text = (tmp_path / "rig.bvh").read_text()
    assert "OFFSET 1.24777 " in text
    (tmp_path / "rig.bvh").write_text(text.replace("OFFSET 1.24777 ", "OFFSET 9.99999 ", 1))
    edited = read.load(tmp_path / "clip.csv")
    assert not np.array_equal(edited.offsets, first.offsets)
    np.testing.assert_array_equal(edited.offsets, mc.load(tmp_path / "rig.bvh").offsets)


def test_frame_time_change_rewrites_the_time_column(tmp_path):
    mc.save(mc.load(SAMPLE), tmp_path / "clip.csv")
    flat = mc.load(tmp_path / "clip.csv")
    mc.save(flat.replace(frame_time=0.02), tmp_path / "slow.csv")
    _, table = read_table(tmp_path / "slow.csv")
    np.testing.assert_allclose(table[:, 1], np.arange(flat.n_frames) * 0.02, rtol=1e-12)
    assert mc.load(tmp_path / "slow.csv").frame_time == 0.02


def test_channel_csv_text_variants(tmp_path):
    """BOM, CRLF, spaces, blank lines, no frame column and a quoted name with a comma."""
    text = (
        '\ufefftime, "Hip,s.Xposition", "Hip,s.Zrotation","Hip,s.Xrotation",'
        '"Hip,s.Yrotation"\r\n'
        "0, 1.5, 10, 20, 30\r\n\r\n"
        " 0.25 ,1.5e0,11,21,31\r\n"
        "0.5,1.5,12,22,32\r\n\r\n"
    )
    path = tmp_path / "clip.csv"
    path.write_bytes(text.encode("utf-8"))
    clip = mc.load(path)
    assert clip.names == ["Hip,s"]
    assert clip.channels == [("Xposition", "Zrotation", "Xrotation", "Yrotation")]
    assert clip.frame_time == 0.25
    np.testing.assert_array_equal(clip.source_values[:, 1], [10, 11, 12])
    mc.save(clip, tmp_path / "same.csv")
    assert (tmp_path / "same.csv").read_bytes() == path.read_bytes()
    expected = quat.from_euler(np.array([[10.0, 20, 30], [11, 21, 31], [12, 22, 32]]), "ZXY")
    np.testing.assert_allclose(clip.rotations[:, 0], expected, atol=1e-15)


def test_uniform_time_tolerance(tmp_path):
    rng = np.random.default_rng(0)
    times = np.arange(200) / 90.0 + rng.uniform(-0.04, 0.04, 200) / 90.0  # 4% jitter
    rows = ["time,a.Xposition"] + [f"{t!r},{i}" for i, t in enumerate(times.tolist())]
    (tmp_path / "ok.csv").write_text("\n".join(rows) + "\n")
    clip = mc.load(tmp_path / "ok.csv")
    assert abs(clip.frame_time - 1 / 90) < 1e-5
    drifting = np.cumsum(np.linspace(1.0, 1.08, 200)) / 90.0  # steps within 10%, drifting
    rows = ["time,a.Xposition"] + [f"{t!r},{i}" for i, t in enumerate(drifting.tolist())]
    (tmp_path / "drift.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(MotionError, match="off the uniform grid") as error:
        mc.load(tmp_path / "drift.csv")
    assert error.value.line is not None and error.value.line > 2
    # rows a tracker dropped at its fixed rate: said as missing rows, not as an uneven rate
    dropped = np.delete(np.arange(200) / 90.0, [150, 160, 161, 162])
    rows = ["time,a.Xposition"] + [f"{t!r},{i}" for i, t in enumerate(dropped.tolist())]
    (tmp_path / "dropped.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(MotionError, match="4 rows missing at a fixed rate of 90 fps") as error:
        mc.load(tmp_path / "dropped.csv")
    assert "(1 frame skipped) and 1 other gap: give every frame its row" in error.value.message
    assert error.value.line == 152  # header line 1, frame 151 (0-based) on line 152
    # times written to whole milliseconds (0.017 s for 60 fps): the rate the span holds
    rounded = np.delete(np.arange(300) / 60.0, [100, 101])
    rows = ["time,a.Xposition"] + [f"{t:.3f},{i}" for i, t in enumerate(rounded.tolist())]
    (tmp_path / "rounded.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(MotionError, match="2 rows missing at a fixed rate of 60 fps"):
        mc.load(tmp_path / "rounded.csv")
    # frames numbered on through uneven times: no row is missing, the times are uneven
    rows = ["frame,time,a.Xposition"] + [f"{i},{t!r},{i}" for i, t in enumerate(dropped.tolist())]
    (tmp_path / "numbered.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(MotionError, match="not uniformly sampled"):
        mc.load(tmp_path / "numbered.csv")


@pytest.mark.parametrize("jump", [1e9, 1000.0])
def test_time_jump_is_named_at_its_line(tmp_path, jump):
    """A clock jump in a CSV `convert` wrote (a frame column numbering on) is refused at
    the row after it, with the times on either side and the median step, not at line 3
    against a mean step the jump drags (1e9 s over 300 rows had said "a time step of
    3.3e+06 s gives no usable frame rate"); without the frame column, at the same line."""
    convert(cut_bvh(SAMPLE, tmp_path / "cut.bvh", 300), tmp_path / "clip.csv")
    lines = (tmp_path / "clip.csv").read_text().splitlines()
    cells = [line.split(",") for line in lines]
    at = 150  # the row the jump lands on: line 152
    for row in cells[1 + at :]:
        row[1] = repr(float(row[1]) + jump)
    step = float(cells[2][1]) - float(cells[1][1])
    numbered = tmp_path / "numbered.csv"
    numbered.write_text("\n".join(",".join(row) for row in cells) + "\n")
    with pytest.raises(MotionError, match="not uniformly sampled") as error:
        mc.load(numbered)
    assert error.value.line == at + 2
    said = error.value.message
    assert f"(frame {at - 1}, then frame {at})" in said and "mean" not in said
    assert f"median step of {step:.6g} s" in said
    after = float(said.split(" is followed by ")[1].split(" s")[0])
    assert abs(after - float(cells[1 + at][1])) < 1e-6 * after
    plain = tmp_path / "plain.csv"  # the same times without the frame column
    plain.write_text("\n".join(",".join(row[1:]) for row in cells) + "\n")
    with pytest.raises(MotionError) as error:
        mc.load(plain)
    assert error.value.line == at + 2


def test_unix_milliseconds_are_refused_naming_the_column_and_the_unit(tmp_path):
    """Times written as Unix milliseconds (1.7e12) pass the 1e12 every value is held to:
    the error names the time column and the date they read as in milliseconds (it had
    said only "value ... is out of range"); divided by 1000, as it says, they read at the
    clip's rate."""
    import datetime

    convert(cut_bvh(SAMPLE, tmp_path / "cut.bvh", 60), tmp_path / "clip.csv")
    rate = mc.load(tmp_path / "clip.csv").frame_rate
    lines = (tmp_path / "clip.csv").read_text().splitlines()
    cells = [line.split(",") for line in lines]
    start = 1_700_000_000.0
    for row in cells[1:]:
        row[1] = repr((start + float(row[1])) * 1000.0)
    stamped = tmp_path / "stamped.csv"
    stamped.write_text("\n".join(",".join(row) for row in cells) + "\n")
    with pytest.raises(MotionError) as error:
        mc.load(stamped)
    day = datetime.datetime.fromtimestamp(start, datetime.UTC).strftime("%Y-%m-%d")
    said = error.value.message
    assert error.value.line == 2 and "in column 'time'" in said
    assert f"Unix time in milliseconds ({day}" in said and "divide the column by 1,000" in said
    for row in cells[1:]:
        row[1] = repr(float(row[1]) / 1000.0)
    stamped.write_text("\n".join(",".join(row) for row in cells) + "\n")
    assert mc.load(stamped).frame_rate == pytest.approx(rate, rel=1e-6)


# ----------------------------------------------------------------------------- rigid bodies


def rigid_table(n_frames: int, n_bodies: int, seed: int, frame_time: float = 1 / 90):
    """Smooth random rigid-body tracks: times, positions, and quaternions of random
    norm and random sign (as some trackers emit them)."""
    rng = np.random.default_rng(seed)
    steps = quat.from_axis_angle(
        quat.normalize(rng.normal(size=(n_frames, n_bodies, 3))),
        rng.uniform(0, 0.2, (n_frames, n_bodies)),
    )
    q = np.empty((n_frames, n_bodies, 4))
    q[0] = quat.normalize(rng.normal(size=(n_bodies, 4)))
    for i in range(1, n_frames):  # a test fixture, not a hot path
        q[i] = quat.multiply(q[i - 1], steps[i])
    q *= rng.choice([-1.0, 1.0], (n_frames, n_bodies, 1)) * rng.uniform(
        0.5, 2, (n_frames, n_bodies, 1)
    )
    p = np.cumsum(rng.normal(scale=0.01, size=(n_frames, n_bodies, 3)), axis=0)
    return np.arange(n_frames) * frame_time, p, q


def write_rigid(path: Path, times, p, q, names=None, order=None) -> None:
    n_bodies = p.shape[1]
    names = names or [f"tracker_{b}" for b in range(n_bodies)]
    columns = [(b, s) for b in range(n_bodies) for s in range(7)]
    if order is not None:
        columns = [columns[k] for k in order]
    header = ["time"] + [f"{names[b]}.{RIGID_SUFFIXES[s]}" for b, s in columns]
    values = np.concatenate([p, q], axis=-1)
    rows = [",".join(header)]
    for f, t in enumerate(times.tolist()):
        rows.append(",".join([repr(t)] + [repr(float(values[f, b, s])) for b, s in columns]))
    path.write_text("\n".join(rows) + "\n")


def test_rigid_csv_reads_quaternions_directly(tmp_path):
    times, p, q = rigid_table(120, 3, seed=1)
    write_rigid(tmp_path / "tracks.csv", times, p, q, names=["head", "hand l", "mixamorig:x"])
    clip = mc.load(tmp_path / "tracks.csv")
    assert clip.names == ["head", "hand l", "mixamorig:x"]
    assert np.all(clip.parents == -1)
    assert clip.frame_time == float(f"{1 / 90:.12g}")
    np.testing.assert_array_equal(clip.translations, p)
    unit = q / np.linalg.norm(q, axis=-1, keepdims=True)
    dots = np.sum(clip.rotations * unit, axis=-1)
    np.testing.assert_allclose(np.abs(dots), 1.0, atol=1e-15)  # same rotation, either sign
    np.testing.assert_allclose(np.linalg.norm(clip.rotations, axis=-1), 1.0, atol=1e-15)
    assert np.all(np.sum(clip.rotations[1:] * clip.rotations[:-1], axis=-1) >= 0)


def test_rigid_columns_in_any_order(tmp_path):
    times, p, q = rigid_table(30, 2, seed=2)
    write_rigid(tmp_path / "a.csv", times, p, q)
    write_rigid(tmp_path / "b.csv", times, p, q, order=np.random.default_rng(0).permutation(14))
    a, b = mc.load(tmp_path / "a.csv"), mc.load(tmp_path / "b.csv")
    np.testing.assert_array_equal(a.rotations, b.rotations)
    np.testing.assert_array_equal(a.translations, b.translations)
    mc.save(b, tmp_path / "b2.csv")
    assert (tmp_path / "b2.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


@settings(max_examples=15, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_frames=st.integers(2, 40),
    n_bodies=st.integers(1, 4),
    changed=st.floats(0.0, 1.0),
)
def test_rigid_round_trip_is_exact(tmp_path_factory, seed, n_frames, n_bodies, changed):
    folder = tmp_path_factory.mktemp("rigid")
    times, p, q = rigid_table(n_frames, n_bodies, seed)
    write_rigid(folder / "in.csv", times, p, q)
    clip = mc.load(folder / "in.csv")
    mc.save(clip, folder / "same.csv")
    assert (folder / "same.csv").read_bytes() == (folder / "in.csv").read_bytes()

    rng = np.random.default_rng(seed)
    pick = rng.uniform(size=(n_frames, n_bodies)) < changed
    turn = quat.from_axis_angle(
        quat.normalize(rng.normal(size=(n_frames, n_bodies, 3))),
        rng.uniform(0, 3, (n_frames, n_bodies)),
    )
    rotations = np.where(pick[..., None], quat.multiply(clip.rotations, turn), clip.rotations)
    moved = clip.replace(
        rotations=quat.make_continuous(rotations),
        translations=np.where(pick[..., None], clip.translations * 1.1 + 0.3, clip.translations),
    )
    mc.save(moved, folder / "moved.csv")
    back = mc.load(folder / "moved.csv")
    np.testing.assert_array_equal(back.rotations, moved.rotations)
    np.testing.assert_array_equal(back.translations, moved.translations)
    assert back.frame_time == moved.frame_time
    # Rows whose bodies were all left alone keep their text.
    kept = ~pick.any(axis=1)
    before = (folder / "in.csv").read_text().splitlines()[1:]
    after = (folder / "moved.csv").read_text().splitlines()[1:]
    assert [a for a, k in zip(after, kept, strict=True) if k] == [
        b for b, k in zip(before, kept, strict=True) if k
    ]
    # And a second save of the re-read clip is byte-identical.
    mc.save(back, folder / "again.csv")
    assert (folder / "again.csv").read_bytes() == (folder / "moved.csv").read_bytes()


def test_rigid_csv_to_bvh_and_back(tmp_path):
    times, p, q = rigid_table(60, 2, seed=5)
    write_rigid(tmp_path / "tracks.csv", times, p, q)
    clip = mc.load(tmp_path / "tracks.csv")
    convert(tmp_path / "tracks.csv", tmp_path / "tracks.bvh")
    bvh = mc.load(tmp_path / "tracks.bvh")
    assert bvh.names == clip.names
    assert np.all(bvh.parents == -1)
    assert bvh.frame_time == clip.frame_time
    # Six printed decimals: within 1e-6 degrees per angle, 0.5e-6 per position.
    assert np.max(np.rad2deg(quat.angle_between(bvh.rotations, clip.rotations))) < 4e-6
    np.testing.assert_allclose(bvh.translations, clip.translations, atol=5e-7 + 1e-12)
    text = format_csv(bvh, layout="rigid")
    again = parse_csv(text, "tracks.csv")
    np.testing.assert_array_equal(again.rotations, bvh.rotations)
    np.testing.assert_array_equal(again.translations, bvh.translations)


def test_rigid_layout_needs_independent_bodies():
    clip = mc.load(SAMPLE)
    with pytest.raises(MotionError, match="joint hierarchy"):
        format_csv(clip, layout="rigid")


def test_save_picks_the_layout_of_the_source(tmp_path):
    times, p, q = rigid_table(10, 1, seed=4)
    write_rigid(tmp_path / "t.csv", times, p, q)
    clip = mc.load(tmp_path / "t.csv")
    moved = clip.replace(translations=clip.translations + 1.0)
    mc.save(moved, tmp_path / "moved.csv")
    header, table = read_table(tmp_path / "moved.csv")
    assert header == ["time"] + [f"tracker_0.{s}" for s in RIGID_SUFFIXES]
    np.testing.assert_array_equal(table[:, 1:4], p[:, 0] + 1.0)
    shutil.copyfile(SAMPLE, tmp_path / "clip.bvh")
    mc.save(mc.load(tmp_path / "clip.bvh"), tmp_path / "clip.csv")
    assert read_table(tmp_path / "clip.csv")[0][:2] == ["frame", "time"]


@pytest.mark.parametrize("block", [1, 7])
def test_csv_written_afresh_row_block_by_row_block_is_the_same_bytes(monkeypatch, block):
    """Fresh CSV text is made a block of rows at a time (no clip-long arrays of pieces):
    any block size gives the same bytes, kept BVH texts, blank cells and all."""
    import importlib

    text_module = importlib.import_module("motionclean.io.text")
    clip = mc.load(NOISY)
    turned = clip.rotations.copy()
    turned[::3, 4] = quat.multiply(turned[::3, 4], quat.from_axis_angle([0.0, 1.0, 0.0], 0.2))
    edited = clip.replace(rotations=turned)
    bodies = mc.load(ROOT / "sample_data" / "131_02_motive.csv")
    missing = np.zeros((bodies.n_frames, bodies.n_joints), dtype=bool)
    missing[10:14, 1] = True
    rigid = bodies.replace(source=None, missing=missing)
    whole = [format_csv(edited), format_csv(rigid, "rigid")]
    monkeypatch.setattr(text_module, "ROW_BLOCK", block)
    assert [format_csv(edited), format_csv(rigid, "rigid")] == whole
    assert b",," in whole[1]  # the dropout is written blank


def test_a_clean_rigid_body_comes_back_byte_for_byte(tmp_path, capsys):
    """A body moving at constant speed, written with six decimals, has only the text's
    rounding for noise (2.9e-7 units RMS): the default leaves it as it is (auto had smoothed
    the rounding, rewriting 83 rows by 1e-7 while the verdict said "left as it was")."""
    t = np.arange(240) / 120.0
    rows = [f"{x:.6f},{x:.6f},1.600000,0.000000,1.000000,0.000000,0.000000,0.000000" for x in t]
    source = tmp_path / "rigid.csv"
    source.write_text("\n".join(["time,b.px,b.py,b.pz,b.qw,b.qx,b.qy,b.qz", *rows]) + "\n")
    code, out, _ = run_cli(capsys, "clean", source, "-o", tmp_path / "out.csv")
    assert code == 0 and "left as it was" in out
    assert (tmp_path / "out.csv").read_bytes() == source.read_bytes()
    jittered = np.array([[x, x, 1.6] for x in t]) + np.random.default_rng(1).normal(
        0.0, 1e-3, (240, 3)
    )  # noise of a millimetre in metres is still smoothed
    source.write_text(
        "\n".join(
            ["time,b.px,b.py,b.pz,b.qw,b.qx,b.qy,b.qz"]
            + [
                f"{s:.6f},{p[0]:.6f},{p[1]:.6f},{p[2]:.6f},1,0,0,0"
                for s, p in zip(t, jittered, strict=True)
            ]
        )
        + "\n"
    )
    code, _, _ = run_cli(capsys, "clean", source, "-o", tmp_path / "out.csv", "-q")
    assert code == 0 and (tmp_path / "out.csv").read_bytes() != source.read_bytes()


def test_a_pipeline_that_changes_nothing_writes_every_csv_back_byte_for_byte(tmp_path, capsys):
    """multires with every gain 1 moves quaternions by rounding (1e-16): a channel, rigid-body
    or Motive CSV keeps every cell's text, as BVH does (the CSV writers compared exactly and
    rewrote every quaternion cell of the Motive sample)."""
    channel = tmp_path / "channel.csv"
    assert run_cli(capsys, "convert", SAMPLE, channel)[0] == 0
    t = np.arange(100) / 100.0
    rigid = tmp_path / "rigid.csv"
    rigid.write_text(
        "time,b.px,b.py,b.pz,b.qw,b.qx,b.qy,b.qz\n"
        + "".join(f"{s:.6f},{np.sin(s):.6f},1.6,0,{np.cos(s):.6f},0,{np.sin(s):.6f},0\n" for s in t)
    )
    for source in (channel, rigid, ROOT / "sample_data" / "131_02_motive.csv"):
        out = tmp_path / "out.csv"
        code, _, err = run_cli(
            capsys, "clean", source, "-o", out, "-q", "-f", "multires:levels=4,gains=[1,1,1,1]"
        )
        assert code == 0, err
        assert out.read_bytes() == source.read_bytes(), source.name


def test_a_lone_carriage_return_is_named_as_the_cause_of_a_long_row(tmp_path, capsys):
    """A CR alone in a file of LF lines runs two rows together: the column count alone
    ('row has 15 columns, the header has 8') did not say why."""
    rows = ["time,a.px,a.py,a.pz,a.qw,a.qx,a.qy,a.qz"]
    rows += [f"{f / 120:.6f},{f * 0.01:.2f},1,0,1,0,0,0" for f in range(6)]
    text = "\n".join(rows[:3]) + "\r" + "\n".join(rows[3:]) + "\n"
    path = tmp_path / "one_cr.csv"
    path.write_bytes(text.encode())
    code, _, err = run_cli(capsys, "info", path)
    assert code == 1
    assert err.splitlines() == [
        f"motionclean: error: {path}:3: row has 15 columns, the header has 8 (a carriage "
        "return (CR) alone inside this line, not followed by a line feed: two rows ran "
        "together; save the file with one kind of line end)"
    ]
    short = tmp_path / "short.csv"
    short.write_bytes(("\n".join(rows[:3]) + "\n1,2\n").encode())
    code, _, err = run_cli(capsys, "info", short)
    assert code == 1 and err.strip().endswith("row has 2 columns, the header has 8")


@pytest.mark.parametrize("frame", [True, False])
def test_a_channel_csv_written_afresh_keeps_its_columns(tmp_path, frame):
    """Resampled (its rows written afresh), a channel CSV keeps the columns it was read
    with: one without a frame column had gained one."""
    clip = mc.load(SAMPLE)
    mc.save(clip, tmp_path / "clip.csv")
    header, table = read_table(tmp_path / "clip.csv")
    assert header[:2] == ["frame", "time"]
    if not frame:
        lines = (tmp_path / "clip.csv").read_text().splitlines()
        text = "\n".join(line.split(",", 1)[1] for line in lines) + "\n"
        (tmp_path / "clip.csv").write_text(text)
    read = mc.load(tmp_path / "clip.csv")
    half = read.replace(
        rotations=read.rotations[::2],
        translations=read.translations[::2],
        frame_time=2 * read.frame_time,
    )
    mc.save(half, tmp_path / "half.csv")
    written, _ = read_table(tmp_path / "half.csv")
    assert written == (header if frame else header[1:])


@pytest.mark.parametrize("frame", [True, False])
def test_a_rigid_csv_resampled_keeps_its_columns(tmp_path, capsys, frame):
    """A tracker CSV resampled (rows written afresh) keeps its frame column, numbered
    from 0, or stays without one; the bodies' values are the resampled clip's."""
    times, p, q = rigid_table(60, 2, seed=4)
    write_rigid(tmp_path / "tracks.csv", times, p, q)
    if frame:
        lines = (tmp_path / "tracks.csv").read_text().splitlines()
        rows = [f"{'frame' if k == 0 else k + 100}," + line for k, line in enumerate(lines)]
        (tmp_path / "tracks.csv").write_text("\n".join(rows) + "\n")
    out = tmp_path / "half.csv"
    code, _, err = run_cli(capsys, "resample", tmp_path / "tracks.csv", out, "--fps", "45")
    assert code == 0, err
    header, table = read_table(out)
    assert header[:2] == (["frame", "time"] if frame else ["time", "tracker_0.px"])
    if frame:
        np.testing.assert_array_equal(table[:, 0], np.arange(len(table)))
    back = mc.load(out)
    assert back.frame_time == pytest.approx(1.0 / 45.0) and back.n_frames == len(table)


def test_a_take_of_another_length_read_into_a_rig_keeps_its_own_text(tmp_path, capsys):
    """One rig, many takes: a channel CSV of 120 frames read with a 300-frame rig comes back
    byte for byte through a pipeline that changes nothing (its values had been written
    afresh: '0.0000' as '0.0'), and written as BVH it keeps the rig's hierarchy text."""
    take = tmp_path / "take.csv"
    convert(cut_bvh(SAMPLE, tmp_path / "take.bvh", 120), take)
    take.write_text(take.read_text().replace(".000000", ".0000"))  # its own formatting
    out = tmp_path / "same.csv"
    code, _, err = run_cli(
        capsys, "clean", take, "-o", out, "--skeleton", SAMPLE, "-f", "lee-shin:joints=['None']"
    )
    assert code == 0, err
    assert out.read_bytes() == take.read_bytes()
    mc.save(mc.load(take, skeleton=mc.load(SAMPLE)), tmp_path / "take_out.bvh")
    head = SAMPLE.read_text().split("MOTION")[0]
    assert (tmp_path / "take_out.bvh").read_text().startswith(head)


def test_column_names_in_another_case_are_read(tmp_path):
    """`Time`, `FRAME` and `XROTATION` (trackers' and Vicon-like headers) are the columns
    `time`, `frame` and `Xrotation`: read as such, the header written back as it was (a
    `Time` column had been refused as "not <joint>.<channel>")."""
    rows = "".join(f"{i},{i / 100:.2f},{i * 0.5:.1f},{i * 0.25:.2f},0\n" for i in range(30))
    plain = tmp_path / "plain.csv"
    plain.write_text("frame,time,hip.Zrotation,hip.Xrotation,hip.Yrotation\n" + rows)
    odd = tmp_path / "odd.csv"
    header = "FRAME,Time,hip.zrotation,hip.XROTATION,hip.Yrotation\n"
    odd.write_text(header + rows)
    a, b = mc.load(plain), mc.load(odd)
    assert a.channels == b.channels and np.array_equal(a.rotations, b.rotations)
    edited = b.replace(rotations=quat.normalize(b.rotations + 0.01))
    mc.save(edited, tmp_path / "out.csv")
    assert (tmp_path / "out.csv").read_text().splitlines()[0] == header.strip()
    # the same column twice in two cases is a column twice (the later had won in silence)
    for twice, shown in (("time,Time", "'Time'"), ("hip.Zrotation,hip.ZROTATION", "'hip.ZR")):
        (tmp_path / "twice.csv").write_text(f"frame,{twice},x\n")
        with pytest.raises(MotionError, match=f"column {shown}.* appears twice"):
            mc.load(tmp_path / "twice.csv")


@pytest.mark.parametrize("fps", ["30", "60", "120"])
def test_a_tracker_csv_stamped_in_unix_time_resamples_to_times_it_reads_back(tmp_path, capsys, fps):
    """A tracker CSV whose times are Unix times (1.7e9 s at 90 fps) resampled: its times had
    been written to 12 significant digits, 1700000000.02, .03, ..., which read back as
    "not uniformly sampled" (or repeated at 120 fps). Each written time is the first plus
    whole frames to within a float's resolution there (about 1e-5 of a frame; asserted to
    1e-3); a repeated time's error says which times."""
    times, p, q = rigid_table(300, 2, seed=5)
    write_rigid(tmp_path / "tracks.csv", 1.7e9 + times, p, q)
    out = tmp_path / "out.csv"
    code, _, err = run_cli(capsys, "resample", tmp_path / "tracks.csv", out, "--fps", fps)
    assert code == 0, err
    back = mc.load(out)
    assert back.frame_time == pytest.approx(1.0 / float(fps), rel=1e-6)  # (float times)
    _, table = read_table(out)
    frames = (table[:, 0] - 1.7e9) * float(fps)
    assert np.abs(frames - np.arange(len(table))).max() < 1e-3  # (a float's 2.4e-7 s at 1.7e9)
    lines = (tmp_path / "tracks.csv").read_text().splitlines()
    (tmp_path / "twice.csv").write_text("\n".join(lines[:11] + lines[10:]) + "\n")
    code, _, err = run_cli(capsys, "info", tmp_path / "twice.csv")
    assert code == 1 and "time does not increase (1700000000.1 s after 1700000000.1 s)" in err


@pytest.mark.parametrize("fps", [60, 120, 144, 240])
@pytest.mark.parametrize("rounding", [np.round, np.floor])
def test_a_tracker_csv_stamped_in_whole_milliseconds_reads_at_its_rate(tmp_path, fps, rounding):
    """Times written in whole milliseconds at 144 or 240 fps step by 4 or 5 ms for 4.17
    (20 % off the mean step) and had been refused as not uniformly sampled, though every
    time is its frame's to within the millisecond, rounded or cut: read at the rate (at 60
    and 120 fps, within the step's tolerance, they had read 120.098 fps). A time 3 ms off
    its frame is still refused, with its line (at 144 and 240 fps)."""
    times, p, q = rigid_table(fps // 2, 2, seed=6, frame_time=1.0 / fps)  # (0.5 s)
    stamped = rounding(times * 1000.0) / 1000.0
    write_rigid(tmp_path / "ms.csv", stamped, p, q)
    clip = mc.load(tmp_path / "ms.csv")
    assert clip.frame_time == pytest.approx(1.0 / fps, rel=1e-9)  # (the whole rate)
    if fps < 144:  # (a step 3 ms off is one over 10 % of 8.3 ms: refused as any CSV's)
        return
    stamped[20] += 0.003
    write_rigid(tmp_path / "off.csv", stamped, p, q)
    with pytest.raises(mc.MotionError, match="not uniformly sampled") as error:
        mc.load(tmp_path / "off.csv")
    assert ":22: not uniformly sampled: time" in str(error.value) and "ms off" in str(error.value)


def test_a_time_column_in_milliseconds_is_noted(tmp_path, capsys):
    """A tracker CSV whose times are milliseconds (0, 11.111, ... at 90 fps) is read in
    seconds, 0.09 fps, as a BVH's `Frame Time: 30` is read: `info` and `clean` say so
    and what the rate would be (they had said nothing, and clean smoothed it as 0.09 fps)."""
    times, p, q = rigid_table(120, 1, seed=7)
    write_rigid(tmp_path / "ms.csv", times * 1000.0, p, q)
    clip = mc.load(tmp_path / "ms.csv")
    assert clip.frame_time == pytest.approx(1000.0 / 90.0)
    code, out, err = run_cli(capsys, "info", tmp_path / "ms.csv")
    assert code == 0, err
    assert "note: time steps of 11.1111 s per row, 0.09 fps" in out and "the clip is 90 fps" in out
    write_rigid(tmp_path / "s.csv", times, p, q)
    code, out, _ = run_cli(capsys, "info", tmp_path / "s.csv")
    assert code == 0 and "note:" not in out


def test_a_tracker_csv_whose_positions_lose_their_jitter_says_so(tmp_path, capsys):
    """Trackers on the sample's head, hands, feet and hips, their positions with 0.3 % of
    the body's height of noise, their rotations with 0.4 degrees: the default removes less of
    the rotations' jitter and most of the positions', and the line gives both (it had
    given the rotations' 6 % alone, the positions' 46 % only in the JSON)."""
    from motionclean.core.kinematics import forward

    clip = mc.load(SAMPLE)
    p, q = forward(clip)
    bodies = [clip.names.index(n) for n in ("Head", "lhand", "rhand", "LeftAnkle")]
    bodies += [clip.names.index(n) for n in ("RightAnkle", "Hips")]
    height = float(np.ptp(p[0], axis=0).max())
    rng = np.random.default_rng(8)
    noisy = p[:, bodies] + rng.normal(size=p[:, bodies].shape) * 0.003 * height
    turned = quat.multiply(q[:, bodies], quat.exp(rng.normal(size=noisy.shape) * 0.002))
    times = np.arange(clip.n_frames) * clip.frame_time
    write_rigid(tmp_path / "t.csv", times, noisy, turned)
    code, out, err = run_cli(capsys, "clean", tmp_path / "t.csv", "-o", tmp_path / "c.csv")
    assert code == 0, err
    line = [row for row in out.splitlines() if row.startswith("verdict:")][0]
    assert "of the jitter removed" in line and "of the position jitter removed" in line


def test_a_trackers_punch_is_no_position_jump(tmp_path, capsys):
    """A head and two hand trackers at 30 fps, the hands punching 0.3 m out in 0.15 s (3
    m/s at most, 10 times their range of travel per second), held and drawn back: no
    position jump (such punches had been flagged as a tracker's teleport against the 0.4 m
    extent of the three taken for a body's height); a hand that teleports 0.5 m and back
    0.5 s later is one."""
    n, fps = 150, 30.0
    t = np.arange(n) / fps
    p = np.zeros((n, 3, 3))
    p[:, 0] = [0.0, 1.7, 0.0]
    p[:, 1:, 1] = 1.3
    p[:, 1, 0], p[:, 2, 0] = -0.2, 0.2
    out = np.clip((t - 2.0) / 0.15, 0.0, 1.0) - np.clip((t - 2.35) / 0.15, 0.0, 1.0)
    punch = 0.3 * (1.0 - np.cos(np.pi * out)) / 2.0
    p[:, 1:, 2] += punch[:, None]
    p[..., 0] += 0.05 * np.sin(2 * np.pi * 0.5 * t)[:, None]  # (a sway: no still frames)
    q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 3, 1))
    for name, moved in (("punch", p), ("teleport", p.copy())):
        if name == "teleport":
            moved[30:45, 2, 2] += 0.5  # (out and back, 0.5 s later)
        write_rigid(tmp_path / f"{name}.csv", t, moved, q, names=["head", "hand_l", "hand_r"])
        code, out, err = run_cli(
            capsys,
            "clean",
            tmp_path / f"{name}.csv",
            "-o",
            tmp_path / "c.csv",
            "--report",
            tmp_path / "r.json",
        )
        assert code == 0, err
        jumps = json.loads((tmp_path / "r.json").read_text())["verdict"]["position_jumps"]
        assert (jumps == {}) is (name == "punch"), out
