"""BVH read/write: exact identity round trips on real and synthetic files from other
exporters, minimal rewrites after an edit, and the Euler conventions against bvhio."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import CORPUS_NAMES, ORDERS, ROOT, SAMPLE, corpus_clip, exporter_bvh, run_cli
from hypothesis import given, settings
from hypothesis import strategies as st

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.core.errors import MotionError
from motionclean.io.bvh import format_bvh, parse_bvh
from motionclean.io.text import format_fixed6, parse_numbers, scan_tokens

SAMPLES = sorted((ROOT / "sample_data").glob("*.bvh"))


def frame_rows(data: bytes) -> list[bytes]:
    """The frame rows of BVH bytes, each with its line ending."""
    body = data[data.index(b"Frame Time") :].split(b"\n", 1)[1]
    return [row for row in body.splitlines(keepends=True) if row.strip()]


def line_endings(data: bytes) -> list[bytes]:
    return re.findall(rb"\r?\n", data) + [b"" if data.endswith(b"\n") else b"open"]


# ----------------------------------------------------------------------------- real files


@pytest.mark.parametrize("name", CORPUS_NAMES)
def test_corpus_identity_round_trip(name, tmp_path):
    path = corpus_clip(name)
    mc.save(mc.load(path), tmp_path / name)
    assert (tmp_path / name).read_bytes() == path.read_bytes()


@pytest.mark.parametrize("path", SAMPLES, ids=lambda p: p.name)
def test_sample_identity_round_trip(path, tmp_path):
    clip = mc.load(path)
    assert clip.n_frames > 0 and clip.source_values.shape[1] == clip.layout.n_channels
    mc.save(clip, tmp_path / path.name)
    assert (tmp_path / path.name).read_bytes() == path.read_bytes()
    # A copy of the arrays (no longer the same objects) still writes the input bytes.
    copy = clip.replace(rotations=clip.rotations.copy(), translations=clip.translations.copy())
    assert format_bvh(copy) == path.read_bytes()


def test_sample_values_match_float():
    path = SAMPLES[0]
    clip = mc.load(path)
    expected = [[float(t) for t in row.split()] for row in frame_rows(path.read_bytes())]
    np.testing.assert_array_equal(clip.source_values, np.array(expected))


# ----------------------------------------------------------------------------- other exporters


EXPORTERS = dict(
    seed=st.integers(0, 2**31 - 1),
    eol=st.sampled_from(["lf", "crlf", "mixed"]),
    bom=st.booleans(),
    indent=st.sampled_from(["\t", "  ", "    "]),
    trailing=st.booleans(),
    fps=st.sampled_from([24, 25, 30, 50, 60, 100, 120]),
    open_end=st.booleans(),
)


@settings(max_examples=40, deadline=None)
@given(**EXPORTERS)
def test_exporter_identity_round_trip(seed, eol, bom, indent, trailing, fps, open_end):
    data, (names, parents, channels, values) = exporter_bvh(
        seed, eol, bom, indent, trailing, fps, open_end
    )
    clip = parse_bvh(data, "x.bvh")
    assert clip.names == names
    assert clip.parents.tolist() == parents
    assert clip.channels == channels
    np.testing.assert_array_equal(clip.source_values, values)
    assert format_bvh(clip) == data
    # Rotations are the channel values' quaternions, in each joint's own order.
    layout = clip.layout
    for j, order in enumerate(layout.rotation_orders):
        if order is not None:
            expected = quat.from_euler(values[:, layout.rotation_columns[j]], order)
            dots = np.abs(np.sum(clip.rotations[:, j] * expected, axis=-1))
            np.testing.assert_allclose(dots, 1.0, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(
    **EXPORTERS,
    axis=st.lists(st.floats(-1, 1), min_size=3, max_size=3),
    degrees=st.floats(0.01, 40),
)
def test_exporter_edit_one_joint(seed, eol, bom, indent, trailing, fps, open_end, axis, degrees):
    data, _ = exporter_bvh(seed, eol, bom, indent, trailing, fps, open_end)
    clip = parse_bvh(data, "x.bvh")
    layout = clip.layout
    rotating = np.flatnonzero(layout.has_rotation)
    j = int(rotating[seed % rotating.size])
    axis = np.asarray(axis) + [0.0, 0.0, 1e-3]
    turn = quat.from_axis_angle(axis / np.linalg.norm(axis), np.deg2rad(degrees))
    rotations = clip.rotations.copy()
    rotations[:, j] = quat.multiply(rotations[:, j], turn)
    out = format_bvh(clip.replace(rotations=rotations))
    again = parse_bvh(out, "y.bvh")

    # Everything but the edited joint's rotation values is the same text.
    edited = set(layout.rotation_columns[j].tolist())
    assert out[: out.index(b"MOTION")] == data[: data.index(b"MOTION")]
    assert line_endings(out) == line_endings(data)
    for row_in, row_out in zip(frame_rows(data), frame_rows(out), strict=True):
        parts_in, parts_out = re.split(rb"(\s+)", row_in), re.split(rb"(\s+)", row_out)
        assert len(parts_in) == len(parts_out)
        for k, (a, b) in enumerate(zip(parts_in, parts_out, strict=True)):
            if not (k % 2 == 0 and k // 2 in edited and a.strip()):
                assert a == b
    others = np.setdiff1d(np.arange(layout.n_channels), sorted(edited))
    np.testing.assert_array_equal(again.source_values[:, others], clip.source_values[:, others])
    # The edited joint is the written quaternion to printing precision (1e-6 degrees; near
    # gimbal lock the rounding of the outer angles adds up to about 1e-5).
    error = np.rad2deg(quat.angle_between(again.rotations[:, j], rotations[:, j]))
    assert np.max(error) < 2e-5
    # ... and written as a curve: no channel jumps by more than half a turn between frames
    # unless the input did there, or the rotation itself turns more than 90 degrees.
    cols = layout.rotation_columns[j]
    jump_out = np.any(np.abs(np.diff(again.source_values[:, cols], axis=0)) > 180.0, axis=1)
    jump_in = np.any(np.abs(np.diff(clip.source_values[:, cols], axis=0)) > 180.0, axis=1)
    leap = quat.angle_between(rotations[:-1, j], rotations[1:, j]) > np.pi / 2
    assert not np.any(jump_out & ~jump_in & ~leap)


def test_exporter_file_agrees_with_bvhio(tmp_path):
    bvhio = pytest.importorskip("bvhio")
    data, (names, _, _, _) = exporter_bvh(11, "crlf", False, "\t", True, 30, False)
    data = data.replace(b"Left Up Leg", b"LeftUpLeg").replace(b"R:Arm 2", b"R:Arm2")
    data = data.replace(b"Bip01 L Thigh", b"Bip01_L_Thigh")
    (tmp_path / "x.bvh").write_bytes(data)
    clip = mc.load(tmp_path / "x.bvh")
    theirs = bvhio.readAsBvh(str(tmp_path / "x.bvh"))
    joints, stack = {}, [theirs.Root]
    while stack:
        joint = stack.pop()
        joints[joint.Name] = joint
        stack.extend(joint.Children)
    assert sorted(joints) == sorted(clip.names)
    for j, name in enumerate(clip.names):
        if not clip.layout.has_rotation[j]:
            continue
        q = np.array(
            [
                [k.Rotation.w, k.Rotation.x, k.Rotation.y, k.Rotation.z]
                for k in joints[name].Keyframes
            ]
        )
        assert np.max(np.rad2deg(quat.angle_between(clip.rotations[:, j], q))) < 1e-3


# ----------------------------------------------------------------------------- Euler angles


def bvhio_quaternion(angles: np.ndarray, order: str) -> np.ndarray:
    """bvhio's intrinsic Euler conversion; ``angles[n]`` is about axis ``order[n]``."""
    glm = pytest.importorskip("glm")
    euler = pytest.importorskip("SpatialTransform").Euler
    xyz = [0.0, 0.0, 0.0]
    for axis, angle in zip(order, angles.tolist(), strict=True):
        xyz["XYZ".index(axis)] = angle
    q = euler.toQuatFrom(glm.radians(glm.vec3(*xyz)), order=order, extrinsic=False)
    return np.array([q.w, q.x, q.y, q.z])


@pytest.mark.parametrize("order", ORDERS)
def test_euler_agrees_with_bvhio(order):
    rng = np.random.default_rng(ORDERS.index(order))
    angles = rng.uniform(-360, 360, (150, 3))
    ours = quat.from_euler(angles, order)
    theirs = np.array([bvhio_quaternion(a, order) for a in angles])
    assert np.max(np.rad2deg(quat.angle_between(ours, theirs))) < 2e-4  # bvhio is float32


@pytest.mark.parametrize("order", ORDERS)
def test_euler_round_trip(order):
    rng = np.random.default_rng(10 + ORDERS.index(order))
    principal = np.stack(
        [
            rng.uniform(-180, 180, 5000),
            rng.uniform(-89.9, 89.9, 5000),
            rng.uniform(-180, 180, 5000),
        ],
        axis=-1,
    )
    back = quat.to_euler(quat.from_euler(principal, order), order)
    np.testing.assert_allclose(back, principal, rtol=0, atol=1e-9)
    # Any triple, also beyond +-180, comes back exactly when it is its own reference.
    wide = rng.uniform(-720, 720, (5000, 3))
    wide[:, 1] = np.where(np.abs(np.cos(np.deg2rad(wide[:, 1]))) < 1e-3, 0.0, wide[:, 1])
    back = quat.to_euler(quat.from_euler(wide, order), order, reference=wide)
    np.testing.assert_allclose(back, wide, rtol=0, atol=1e-9)


def equivalent_triples(principal: np.ndarray) -> np.ndarray:
    """Both Euler solutions of each triple shifted by every whole turn in -3..3."""
    second = principal * [1, -1, 1] + [180.0, 180.0, 180.0]
    turns = np.stack(np.meshgrid(*[np.arange(-3, 4)] * 3, indexing="ij"), -1).reshape(-1, 3)
    both = np.stack([principal, second], axis=-2)  # (..., 2, 3)
    return (both[..., None, :] + 360.0 * turns).reshape(*principal.shape[:-1], -1, 3)


@settings(max_examples=30, deadline=None)
@given(order=st.sampled_from(ORDERS), seed=st.integers(0, 2**31 - 1))
def test_to_euler_picks_the_nearest_triple(order, seed):
    rng = np.random.default_rng(seed)
    q = quat.normalize(rng.normal(size=(64, 4)))
    reference = rng.uniform(-540, 540, (64, 3))
    got = quat.to_euler(q, order, reference=reference)
    assert np.all(np.rad2deg(quat.angle_between(quat.from_euler(got, order), q)) < 1e-9)
    candidates = equivalent_triples(quat.to_euler(q, order))
    best = np.min(np.sum((candidates - reference[:, None]) ** 2, axis=-1), axis=-1)
    assert np.all(np.sum((got - reference) ** 2, axis=-1) <= best + 1e-6)


@pytest.mark.parametrize("order", ORDERS)
def test_to_euler_keeps_the_reference_split_at_gimbal_lock(order):
    rng = np.random.default_rng(20 + ORDERS.index(order))
    angles = rng.uniform(-180, 180, (200, 3))
    angles[:, 1] = rng.choice([-90.0, 90.0], 200)
    q = quat.from_euler(angles, order)
    reference = angles + rng.uniform(-30, 30, (200, 3)) * [1, 0, 1]
    got = quat.to_euler(q, order, reference=reference)
    np.testing.assert_allclose(got[:, 0], reference[:, 0], atol=1e-9)
    np.testing.assert_allclose(got[:, 1], angles[:, 1], atol=1e-6)
    assert np.all(np.rad2deg(quat.angle_between(quat.from_euler(got, order), q)) < 1e-6)
    # The original triple is its own nearest: written back unchanged.
    np.testing.assert_allclose(quat.to_euler(q, order, reference=angles), angles, atol=1e-6)


# ----------------------------------------------------------------------------- number text


def test_parse_numbers_is_float():
    rng = np.random.default_rng(0)
    values = rng.standard_normal(3000) * 10.0 ** rng.integers(-12, 12, 3000)
    texts = (
        [repr(v) for v in values.tolist()]
        + [f"{v:.6f}" for v in values.tolist()]
        + [f"{v:.3e}" for v in values.tolist()]
        + [
            "-0",
            "+5",
            ".5",
            "5.",
            "-.25",
            "007",
            "123456789012345",
            "1234567890123456789",
            "0.1000000000000000055511151231257827",
            "1E5",
            "-0.0000",
        ]
    )
    text = " \t".join(texts).encode()
    buf = np.frombuffer(text, dtype=np.uint8)
    starts, ends = scan_tokens(buf)
    got, bad = parse_numbers(buf, starts, ends)
    assert bad == -1
    expected = np.array([float(t) for t in texts])
    np.testing.assert_array_equal(got, expected)
    assert np.array_equal(np.signbit(got), np.signbit(expected))


@pytest.mark.parametrize(
    "token",
    [
        "abc",
        "1.2.3",
        "--1",
        "1-2",
        "+",
        ".",
        "1_000",
        "nan",
        "inf",
        "-Infinity",
        "0x10",
        "1e",
        "1e400",
        "12a",
    ],
)
def test_parse_numbers_rejects(token):
    text = f"1.5 {token} 2.5".encode()
    buf = np.frombuffer(text, dtype=np.uint8)
    _, bad = parse_numbers(buf, *scan_tokens(buf))
    assert bad == 1


def test_format_fixed6_is_printf():
    rng = np.random.default_rng(1)
    values = np.concatenate(
        [
            rng.standard_normal(20000) * 10.0 ** rng.integers(-9, 10, 20000),
            np.arange(-3000, 3000) / 2e6,  # exact and near halves of the last digit
            [0.0078125, -0.0078125, -4e-7, -5e-7, 5e-7, -0.0, 1e300, -1e-300, 9999999.9999995],
        ]
    )
    buf, starts, lengths = format_fixed6(values)
    got = [buf[s : s + n].tobytes() for s, n in zip(starts.tolist(), lengths.tolist(), strict=True)]
    expected = [b"%.6f" % v for v in values.tolist()]
    expected = [e[1:] if e.startswith(b"-") and float(e) == 0 else e for e in expected]
    assert got == expected


def test_an_edit_in_place_is_written_and_the_rest_keeps_its_text(tmp_path):
    """The quaternions read are not kept for a BVH clip (they follow from the values read):
    a rotation changed in place must still be seen as changed, and every other value keep
    its text."""
    clip = mc.load(SAMPLE)
    joint = clip.names.index("LeftKnee")
    turn = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), 0.3)
    clip.rotations[40, joint] = quat.multiply(clip.rotations[40, joint], turn)
    out = tmp_path / "edited.bvh"
    mc.save(clip, out)
    rows_in = SAMPLE.read_text().split("Frame Time:")[1].splitlines()[1:]
    rows_out = out.read_text().split("Frame Time:")[1].splitlines()[1:]
    changed = [f for f, (a, b) in enumerate(zip(rows_in, rows_out, strict=True)) if a != b]
    assert changed == [40]
    back = mc.load(out)
    assert (
        np.degrees(quat.angle_between(back.rotations[40, joint], clip.rotations[40, joint])) < 1e-4
    )


def test_a_value_that_prints_as_the_number_read_keeps_its_text(tmp_path):
    """A rotation a step moved by a ten-millionth of a degree prints, with six decimals, as
    the number read: its text stays as the file wrote it (``0.0000`` is not rewritten as
    ``0.000000``), while a value moved by 1e-5 degrees is written anew."""
    text = SAMPLE.read_text()
    head, rows = text.split("Frame Time:")
    lines = rows.splitlines()
    first = lines[1].split()
    first[3:6] = ["0.0000", "0.0000", "-0.00"]  # the root's rotation, short texts
    source = tmp_path / "short.bvh"
    source.write_text(
        head + "Frame Time:" + "\n".join([lines[0], " ".join(first), *lines[2:]]) + "\n"
    )
    clip = mc.load(source)
    tiny = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.deg2rad(1e-7))
    clip.rotations[0, 0] = quat.multiply(clip.rotations[0, 0], tiny)
    clip.rotations[1, 0] = quat.multiply(clip.rotations[1, 0], tiny * [1, 100, 100, 100])
    out = tmp_path / "out.bvh"
    mc.save(clip.replace(rotations=quat.normalize(clip.rotations)), out)
    rows_out = out.read_text().split("Frame Time:")[1].splitlines()
    assert rows_out[1].split()[3:6] == ["0.0000", "0.0000", "-0.00"]
    assert rows_out[2] != lines[2]  # moved by 1e-5 degrees: printed anew


def test_values_written_with_hundreds_of_digits_are_kept_and_spliced_around():
    """A 300-digit value is read exactly, kept byte for byte, and an edit next to it lands
    in place (the value texts are found again from the rows when the clip is written)."""
    long = b"0." + b"0" * 297 + b"1"  # 1e-298 written out
    data = (
        b"HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition "
        b"Zrotation Xrotation Yrotation\n\tEnd Site\n\t{\n\t\tOFFSET 0 1 0\n\t}\n}\n"
        b"MOTION\nFrames: 3\nFrame Time: 0.0333333\n"
        b"1.5 "
        + long
        + b" 2 10 20 30\n4 5 6 11"
        + b" " * 300
        + b"21 31\n7 8 9 12 22 "
        + long
        + b"\n"
    )
    clip = parse_bvh(data, "x.bvh")
    assert clip.source.lengths.dtype == clip.source.gaps.dtype == np.uint16  # widened
    assert clip.source_values[0, 1] == float(long) and clip.source_values[2, 5] == float(long)
    assert format_bvh(clip) == data
    rotations = clip.rotations.copy()
    rotations[1] = quat.multiply(rotations[1], quat.from_axis_angle([0, 0, 1], 0.1))
    out = format_bvh(clip.replace(rotations=rotations))
    rows = out.split(b"Frame Time: 0.0333333\n")[1].splitlines()
    assert rows[0] == data.splitlines()[-3] and rows[2] == data.splitlines()[-1]
    assert rows[1].split()[:3] == [b"4", b"5", b"6"] and rows[1].split()[3] != b"11"


@pytest.mark.parametrize("part_values", [1, 13, 1 << 19])
def test_rows_read_in_parts_of_lines_give_the_same_clip_and_name_the_bad_line(
    monkeypatch, part_values
):
    """Rows one per line are read in parts of lines (any part size: the same values and
    the same output); blank lines between rows take the general path, also exactly."""
    from motionclean.io import bvh as bvh_module

    data, (_, _, _, values) = exporter_bvh(11, "mixed", False, "\t", True, 120, False)
    monkeypatch.setattr(bvh_module, "_PART_VALUES", part_values)
    clip = parse_bvh(data, "x.bvh")
    np.testing.assert_array_equal(clip.source_values, values)
    assert format_bvh(clip) == data
    turned = quat.multiply(clip.rotations, quat.from_axis_angle([0.6, 0.0, 0.8], 0.2))
    edited = format_bvh(clip.replace(rotations=turned))
    monkeypatch.setattr(bvh_module, "_PART_VALUES", 1 << 19)
    assert edited == format_bvh(parse_bvh(data, "x.bvh").replace(rotations=turned))
    monkeypatch.setattr(bvh_module, "_PART_VALUES", part_values)

    head, body = data.split(b"Frame Time:", 1)
    time_line, rows = body.split(b"\n", 1)
    spaced = head + b"Frame Time:" + time_line + b"\n\n" + rows.replace(b"\n", b"\n \n", 2)
    gapped = parse_bvh(spaced + b"\n\n", "y.bvh")
    np.testing.assert_array_equal(gapped.source_values, values)
    assert format_bvh(gapped) == spaced + b"\n\n"

    lines = data.split(b"\n")
    last = len(lines) - 1 if lines[-1].strip() else len(lines) - 2
    lines[last] = lines[last].replace(lines[last].split()[0], b"1x", 1)
    with pytest.raises(MotionError, match=rf"x.bvh:{last + 1}: frame value is not a number"):
        parse_bvh(b"\n".join(lines), "x.bvh")


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    edits=st.lists(
        st.tuples(
            st.floats(0, 1),
            st.sampled_from([b" ", b"\t", b"\n", b"\r\n", b"7", b"x", b".", b"-", b"", b"\n\n"]),
        ),
        min_size=1,
        max_size=4,
    ),
)
def test_the_row_reader_agrees_with_the_general_one_on_damaged_rows(seed, edits):
    """Differential: rows read in parts of lines give what the every-token reader gives
    (values, kept texts and the written bytes), or the same one-line error."""
    from motionclean.io import bvh as bvh_module

    data, _ = exporter_bvh(seed, "mixed", False, "\t", True, 60, bool(seed % 2))
    body = data.index(b"Frame Time:")
    body = data.index(b"\n", body) + 1
    for where, text in edits:
        at = body + int(where * (len(data) - body))
        data = data[:at] + text + data[at + 1 :]

    def outcome(parse):
        try:
            clip = parse(data, "x.bvh")
        except MotionError as error:
            return str(error)
        src = clip.source
        return clip.source_values, src.cells(slice(None)), format_bvh(clip)

    fast = outcome(parse_bvh)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(bvh_module, "_parse_row_lines", lambda *args: None)
        general = outcome(parse_bvh)
    if isinstance(general, str) or isinstance(fast, str):
        assert fast == general
    else:
        np.testing.assert_array_equal(fast[0], general[0])
        np.testing.assert_array_equal(fast[1][0], general[1][0])
        np.testing.assert_array_equal(fast[1][1], general[1][1])
        assert fast[2] == general[2] == data


@pytest.mark.parametrize("block", [1, 7])
def test_a_clip_written_afresh_row_block_by_row_block_is_the_same_bytes(monkeypatch, block):
    from motionclean.io import text

    clip = mc.load(SAMPLE)
    fresh = clip.replace(source=None, source_values=None)  # nothing to splice into
    whole = format_bvh(fresh)
    monkeypatch.setattr(text, "ROW_BLOCK", block)
    assert format_bvh(fresh) == whole
    again = parse_bvh(whole, "x.bvh")
    np.testing.assert_allclose(again.source_values, fresh.channel_values(), atol=5e-7)


def test_a_joint_without_channels_is_written_with_channels_0(tmp_path):
    """A joint of no channels (an FBX's or glTF's fixed bone) gets `CHANNELS 0`: without the
    line Blender's BVH importer (IndexError) and bvhio (SyntaxError) refused the file."""
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")]
    channels += [(), ("Zrotation", "Xrotation", "Yrotation")]
    values = np.random.default_rng(0).normal(size=(5, 9))
    offsets = np.array([[0.0, 0, 0], [0, 1, 0], [0, 1, 0]])
    motion = mc.Motion.from_channel_values(
        ["root", "mid", "tip"], [-1, 0, 1], offsets, channels, 1 / 30, values
    )
    mc.save(motion, tmp_path / "c.bvh")
    text = (tmp_path / "c.bvh").read_text()
    assert "JOINT mid\n\t{\n\t\tOFFSET 0.000000 1.000000 0.000000\n\t\tCHANNELS 0\n" in text
    assert mc.load(tmp_path / "c.bvh").channels == channels
    bvhio = pytest.importorskip("bvhio")
    hierarchy = bvhio.readAsHierarchy(str(tmp_path / "c.bvh"))
    assert [joint.Name for joint, *_ in hierarchy.layout()] == ["root", "mid", "tip"]


def test_channel_names_in_another_case_are_read_as_bvh_spells_them(tmp_path):
    """``ZPosition`` and ``XROTATION`` (headers some exporters write) are the channels BVH
    spells ``Zposition`` and ``Xrotation``: read as such, and the header written back as it
    was read."""
    text = SAMPLE.read_text()
    odd = text.replace("Zposition", "ZPosition", 1).replace("Xrotation", "XROTATION", 1)
    assert odd != text
    source = tmp_path / "odd.bvh"
    source.write_text(odd)
    clip, plain = mc.load(source), mc.load(SAMPLE)
    assert clip.channels == plain.channels
    assert np.array_equal(clip.rotations, plain.rotations)
    assert np.array_equal(clip.translations, plain.translations)
    edited = clip.replace(rotations=quat.normalize(clip.rotations + 0.01))
    target = tmp_path / "out.bvh"
    mc.save(edited, target)
    written = target.read_text()
    assert written.split("MOTION")[0] == odd.split("MOTION")[0]


def test_a_frame_time_that_reads_as_a_rate_is_said(tmp_path, capsys):
    """``Frame Time: 120`` (an exporter writing its rate there) is read as written, 120 s
    a frame, but said, with the line it should have been (it had passed without a word:
    0.0083 fps, a 1,200 s clip); the sample's own .0083333 s says nothing."""
    text = SAMPLE.read_text()
    slow = tmp_path / "slow.bvh"
    slow.write_text(text.replace("Frame Time: .0083333", "Frame Time: 120", 1))
    note = (
        "Frame Time: 120 s per frame, 0.00833 fps: where 120 is the rate, the file should "
        "say Frame Time: 0.0083333"
    )
    assert kinematics.source_notes(mc.load(slow)) == (note,)
    assert kinematics.source_notes(mc.load(SAMPLE)) == ()
    code, out, _ = run_cli(capsys, "info", slow)
    assert code == 0 and f"note: {note}" in out


def test_the_noisy_sample_is_what_its_script_makes_of_the_clean_one(tmp_path):
    """sample_data/README.md: ``scripts/make_sample.py`` rebuilds the noisy sample, seeded,
    from the clean cut. It had ended in a traceback (position noise on joints without
    position channels, which saving refuses): it makes the bundled file byte for byte."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "make_sample", ROOT / "scripts" / "make_sample.py"
    )
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    made = tmp_path / "noisy.bvh"
    mc.save(script.add_noise(mc.load(SAMPLE), np.random.default_rng(script.SEED)), made)
    assert made.read_bytes() == (ROOT / "sample_data" / "131_02_noisy.bvh").read_bytes()
