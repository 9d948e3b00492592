"""SMPL parameters in pickles: WHAM-style joblib files, exact round trips, and pickles
that would run code refused without running it."""

from __future__ import annotations

import os
import pickle
import struct
import subprocess
import sys

import numpy as np
import pytest
from helpers import ROOT, run_cli

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.io import safepickle
from motionclean.io.smpl_model import SMPL

#: Written by joblib 1.6 (numpy 1.26) like WHAM's demo: two people, person 3 seen on
#: frames 0-2 and 5-7 only; the second copy compressed (joblib.dump(..., compress=3)).
WHAM = ROOT / "tests" / "data" / "wham_output.pkl"
WHAM_ZLIB = ROOT / "tests" / "data" / "wham_output_zlib.pkl"


def test_wham_output_reads_the_world_motion_of_the_longest_track():
    motion = mc.load(WHAM)
    assert motion.names == list(SMPL.names) and motion.n_frames == 24
    notes = kinematics.source_notes(motion)
    assert "2 people in the file: '0' read (the most frames)" in notes
    assert any(
        note.startswith(
            "the world motion (pose_world, trans_world) is read and written; the "
            "camera frame's pose, trans"
        )
        for note in notes
    )
    assert any("30 fps assumed" in note for note in notes)
    record = safepickle.loads(WHAM.read_bytes(), WHAM)[0]
    expected = quat.exp(0.5 * record["pose_world"].astype(np.float64).reshape(24, 24, 3))
    assert np.abs(np.abs(np.einsum("fji,fji->fj", motion.rotations, expected)) - 1).max() < 1e-12
    assert np.array_equal(motion.translations[:, 0], record["trans_world"].astype(np.float64))
    compressed = mc.load(WHAM_ZLIB)
    assert np.array_equal(compressed.rotations, motion.rotations)


def test_the_rate_of_a_pickle_without_one_is_given_by_input_fps(tmp_path, capsys):
    """A video's 60 fps given to a WHAM pickle (which states no rate: 30 assumed, and the
    filters' cutoffs in Hz and the world speeds a factor of two off): taken, said, written
    into the AMASS .npz; a file's own rate is taken over the option, in every command that
    reads (batch's workers too)."""
    with pytest.raises(ValueError, match="frame_rate must be from 0.000277778 to 1e\\+06, got 0"):
        mc.load(WHAM, frame_rate=0.0)  # (it had divided by zero)
    clip = mc.load(WHAM, frame_rate=60.0)
    assert clip.frame_time == 1 / 60
    assert "no frame rate in the file; 60 fps as given" in kinematics.source_notes(clip)
    code, out, err = run_cli(capsys, "convert", WHAM, tmp_path / "w.npz", "--input-fps", "60")
    assert (code, err) == (0, "") and float(np.load(tmp_path / "w.npz")["mocap_framerate"]) == 60
    assert "note: no frame rate in the file; 60 fps as given" in out  # convert says it too
    code, out, _ = run_cli(capsys, "info", tmp_path / "w.npz", "--input-fps", "25")
    assert code == 0 and "rate: 60 fps" in out and "60 fps taken, not 25 as given" in out
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "w.pkl").write_bytes(WHAM.read_bytes())
    code, _, _ = run_cli(
        capsys, "batch", tmp_path / "in", "-o", tmp_path / "out", "--input-fps", "60",
        "--report-dir", tmp_path / "pages",
    )  # fmt: skip
    assert code == 0 and mc.load(tmp_path / "out" / "w.pkl", frame_rate=60.0).n_frames == 24
    page = (tmp_path / "pages" / "w.pkl.html").read_text()
    assert "at 60 fps" in page and "at 30 fps" not in page


def test_round_trips_byte_and_value_exact(tmp_path):
    motion = mc.load(WHAM)
    mc.save(motion, tmp_path / "same.pkl")
    assert (tmp_path / "same.pkl").read_bytes() == WHAM.read_bytes()
    q = motion.rotations.copy()
    q[3:6, 7] = quat.multiply(q[3:6, 7], quat.exp(np.array([0.0, 0.03, 0.0])))
    mc.save(motion.replace(rotations=q), tmp_path / "edited.pkl")
    before = safepickle.loads(WHAM.read_bytes(), WHAM)
    with open(tmp_path / "edited.pkl", "rb") as f:
        after = pickle.load(f)  # a plain pickle anyone can read
    assert sorted(after) == sorted(before) and list(after[0]) == list(before[0])
    for key, value in before[0].items():
        assert after[0][key].dtype == value.dtype and after[0][key].shape == value.shape
        if key != "pose_world":
            assert np.array_equal(after[0][key], value)
    for key, value in before[3].items():
        assert np.array_equal(after[3][key], value)
    changed = np.argwhere(after[0]["pose_world"] != before[0]["pose_world"])
    assert set(changed[:, 0]) == {3, 4, 5} and set(changed[:, 1]) <= {21, 22, 23}
    again = mc.load(tmp_path / "edited.pkl")
    assert np.abs(again.rotations - q).max() < 1e-6  # float32 arrays


def test_frames_a_person_was_not_seen_in_are_missing(tmp_path):
    record = safepickle.loads(WHAM.read_bytes(), WHAM)[3]
    with open(tmp_path / "one.pkl", "wb") as f:
        pickle.dump(
            {
                "pose": record["pose"],
                "trans": record["trans"],
                "frame_ids": record["frame_ids"] + 40,
                "fps": 25,
            },
            f,
        )
    motion = mc.load(tmp_path / "one.pkl")
    assert motion.n_frames == 8 and motion.frame_rate == 25.0
    assert motion.missing is not None and np.flatnonzero(motion.missing[:, 0]).tolist() == [3, 4]
    mc.save(motion, tmp_path / "same.pkl")
    assert (tmp_path / "same.pkl").read_bytes() == (tmp_path / "one.pkl").read_bytes()
    filled, _ = mc.Pipeline.from_inline(["fill-gaps"]).run(motion)
    q = filled.rotations.copy()
    q[6, 2] = quat.multiply(q[6, 2], quat.exp(np.array([0.01, 0.0, 0.0])))
    mc.save(filled.replace(rotations=q), tmp_path / "edited.pkl")
    with open(tmp_path / "edited.pkl", "rb") as f:
        out = pickle.load(f)
    assert out["pose"].shape == record["pose"].shape  # the rows of the frames seen only
    assert np.flatnonzero((out["pose"] != record["pose"]).any(axis=1)).tolist() == [4]


@pytest.mark.parametrize("ids", [np.arange(5), np.arange(100), np.arange(0, 10, 2)])
def test_frame_ids_not_one_per_row_of_poses_are_refused(tmp_path, ids):
    """Ids without gaps (0-4, 0-99 for 60 rows) had been accepted and ignored; only gapped
    ones were refused."""
    record = {"pose": np.zeros((60, 72)), "trans": np.zeros((60, 3)), "fps": 30}
    with open(tmp_path / "ids.pkl", "wb") as f:
        pickle.dump({**record, "frame_ids": ids}, f)
    with pytest.raises(mc.MotionError, match=f"frame_ids has {ids.size} entries for 60 frames"):
        mc.load(tmp_path / "ids.pkl")
    with open(tmp_path / "every.pkl", "wb") as f:
        pickle.dump({**record, "frame_ids": np.arange(60) + 7}, f)
    every = mc.load(tmp_path / "every.pkl")
    assert every.n_frames == 60 and every.missing is None


class _RunsCode:
    def __init__(self, command: str):
        self.command = command

    def __reduce__(self):
        return (os.system, (self.command,))


def test_a_pickle_that_would_run_code_is_refused_without_running_it(tmp_path, capsys):
    marker = tmp_path / "ran"
    hostile = {"pose": np.zeros((2, 72)), "x": _RunsCode(f"touch {marker}")}
    path = tmp_path / "hostile.pkl"
    path.write_bytes(pickle.dumps(hostile, protocol=2))
    code, out, err = run_cli(capsys, "info", path)
    assert code == 1 and out == "" and err.count("\n") == 1
    assert (
        "refused: the pickle asks for posix.system" in err
        or "refused: the pickle asks for nt.system" in err
    )
    assert not marker.exists()
    trailing = tmp_path / "trailing.pkl"  # a byte after its STOP: refused all the same
    trailing.write_bytes(path.read_bytes() + b"x")
    code, _, err = run_cli(capsys, "info", trailing)
    assert code == 1 and "refused: the pickle asks for" in err and not marker.exists()
    # the same file through Python's own pickle does run it: the test would catch a leak
    subprocess.run(
        [sys.executable, "-c", f"import pickle; pickle.load(open({str(path)!r}, 'rb'))"], check=True
    )
    assert marker.exists()


@pytest.mark.parametrize(
    "payload",
    [
        b"cbuiltins\neval\n(S'1'\ntR.",  # protocol 0 GLOBAL + REDUCE
        b"\x80\x04\x95\x1c\x00\x00\x00\x00\x00\x00\x00\x8c\x08builtins\x94\x8c\x04exec\x94\x93\x94.",
        b"c__builtin__\ngetattr\n.",
        b"\x80\x02cnumpy.core.multiarray\n_reconstruct\ncos\nsystem\nK\x00\x85C\x01b\x87R.",
        b"\x80\x02ccopyreg\n_reconstructor\n.",
    ],
)
def test_globals_outside_the_list_are_refused(payload):
    with pytest.raises(mc.MotionError, match="refused: the pickle asks for"):
        safepickle.loads(payload, "x.pkl")


def test_object_arrays_and_huge_claims_are_refused():
    with pytest.raises(mc.MotionError, match="an array of Python objects"):
        safepickle.loads(pickle.dumps({"pose": np.array([None, 1], dtype=object)}), "x.pkl")
    huge = pickle.dumps(np.zeros(3)).replace(b"K\x03\x85", b"J\x00\xe1\xf5\x05\x85")
    with pytest.raises(mc.MotionError):
        safepickle.loads(huge, "x.pkl")


@pytest.mark.parametrize("cut", [10, 500, 1000, 5000, 27000, -1000])
def test_a_cut_joblib_file_is_one_line(tmp_path, capsys, cut):
    """Said to end early wherever it is cut: inside an array, the array's bytes read as
    opcodes had asked for a class and the line had called it a security refusal."""
    (tmp_path / "cut.pkl").write_bytes(WHAM.read_bytes()[:cut])
    code, _, err = run_cli(capsys, "info", tmp_path / "cut.pkl")
    assert code == 1 and err.count("\n") == 1 and err.startswith("motionclean: error: ")
    assert "the file ends before its pickle does" in err


def _py2_str(text: bytes) -> bytes:
    """A Python 2 ``str`` as its pickles hold it (SHORT_BINSTRING, or BINSTRING)."""
    if len(text) < 256:
        return b"U" + bytes([len(text)]) + text
    return b"T" + struct.pack("<i", len(text)) + text


def _py2_array(a: np.ndarray) -> bytes:
    """A float64 array as Python 2's numpy pickles it (protocol 2: its bytes a ``str``)."""
    shape = b"".join(b"K" + bytes([n]) for n in a.shape) + {1: b"\x85", 2: b"\x86"}[a.ndim]
    return (
        b"cnumpy.core.multiarray\n_reconstruct\ncnumpy\nndarray\nK\x00\x85"
        + _py2_str(b"b")
        + b"\x87R(K\x01"
        + shape
        + b"cnumpy\ndtype\n"
        + _py2_str(b"f8")
        + b"K\x00K\x01\x87R(K\x03"
        + _py2_str(b"<")
        + b"NNNJ\xff\xff\xff\xffJ\xff\xff\xff\xffK\x00tb\x89"
        + _py2_str(a.astype("<f8").tobytes())
        + b"tb"
    )


def test_a_python_2_pickle_is_read(tmp_path):
    """Python 2's pickles hold arrays' bytes as ``str``, which Python 3 reads as ASCII by
    default: a real one (MANO's model) had failed with "UnicodeDecodeError: 'ascii' codec
    can't decode byte 0xd5". Read as latin-1, as numpy asks, the arrays are the ones
    written."""
    poses = np.linspace(-1.0, 1.0, 3 * 72).reshape(3, 72)
    record = b"}(" + _py2_str(b"poses") + _py2_array(poses)
    record += _py2_str(b"gender") + _py2_str(b"neutral") + b"u."
    source = tmp_path / "py2.pkl"
    source.write_bytes(b"\x80\x02" + record)
    with pytest.raises(UnicodeDecodeError):
        pickle.loads(source.read_bytes())  # (Python's default)
    clip = mc.load(source)
    expected = quat.exp(0.5 * poses.reshape(3, 24, 3))
    assert np.abs(np.abs(np.einsum("fji,fji->fj", clip.rotations, expected)) - 1).max() < 1e-12


#: The head of an OpenSim .mot, named .pkl.
OPENSIM_HEAD = (
    b"Coordinates\nversion=1\nnRows=73\nnColumns=24\ninDegrees=yes\n\nUnits are S.I. units "
    b"(second, meters, Newtons, ...)\nAngles are in degrees.\n\nendheader\ntime\tpelvis_tilt\n"
)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"", "empty file"),
        (pickle.dumps({"pose": np.zeros((4, 72))}, protocol=4)[:-40], "the file ends before"),
        (OPENSIM_HEAD, "not a pickle, or a damaged one"),
        (b"x\x9c not zlib at all", "starts as zlib-compressed data but does not decompress"),
    ],
)
def test_an_unreadable_pickle_is_said_in_words(tmp_path, capsys, content, message):
    """Python's exceptions had been the message ("(EOFError: )", "(IndexError: pop from
    empty list)" for an OpenSim file named .pkl)."""
    (tmp_path / "x.pkl").write_bytes(content)
    code, out, err = run_cli(capsys, "info", tmp_path / "x.pkl")
    assert code == 1 and out == "" and err.count("\n") == 1
    assert err.startswith(f"motionclean: error: {tmp_path / 'x.pkl'}: {message}")
    assert "Error" not in err


def test_a_pickle_without_smpl_is_one_line(tmp_path, capsys):
    (tmp_path / "other.pkl").write_bytes(pickle.dumps({"a": [1, 2], "b": np.zeros(3)}))
    code, _, err = run_cli(capsys, "info", tmp_path / "other.pkl")
    assert code == 1 and "no SMPL record in the pickle" in err


def test_clean_and_convert(tmp_path, capsys):
    code, out, _ = run_cli(capsys, "clean", WHAM, "-o", tmp_path / "clean.pkl")
    assert code == 0 and "note: 2 people in the file" in out
    code, _, _ = run_cli(capsys, "convert", WHAM, tmp_path / "w.npz")
    assert code == 0
    amass = np.load(tmp_path / "w.npz")  # AMASS's keys, not the pickle's
    assert set(amass.files) == {"poses", "trans", "mocap_framerate", "betas"}
    assert amass["poses"].shape == (24, 72) and amass["mocap_framerate"] == 30.0
    npz = mc.load(tmp_path / "w.npz")
    assert "fps assumed" not in " ".join(kinematics.source_notes(npz))
    np.testing.assert_allclose(npz.rotations, mc.load(WHAM).rotations, atol=1e-15)
    code, _, _ = run_cli(capsys, "convert", WHAM, tmp_path / "w.csv")
    assert code == 0 and mc.load(tmp_path / "w.csv").n_joints == 24


#: Laid out as 4D-Humans' tracker (PHALP) writes it, with joblib compress=3: one entry per
#: video frame with its detections (tid, smpl rotation matrices, bbox, mask, ...); track 1
#: is lost on frames 2-3, track 2 on frames 4, 5 and 9.
PHALP = ROOT / "tests" / "data" / "phalp_output.pkl"


def test_4d_humans_tracks_read_the_longest_track_with_its_gaps(tmp_path):
    motion = mc.load(PHALP)
    assert motion.names == list(SMPL.names) and motion.n_frames == 12
    notes = " ".join(kinematics.source_notes(motion))
    assert "2 tracks in the file: track 1 read (seen on 10 frames)" in notes
    # the frames not seen are missing, and filled ones cannot be written back into a .pkl
    # (it keeps an entry for each frame seen): the note says so ("24 gaps filled" and the
    # input's bytes written had read as a contradiction)
    assert "not seen on 2 frames between: missing, and a .pkl written back keeps" in notes
    assert np.flatnonzero(motion.missing[:, 0]).tolist() == [2, 3]
    tree = safepickle.loads(PHALP.read_bytes(), PHALP)
    first = tree["frame_000000.jpg"]["smpl"][0]
    assert np.abs(quat.as_matrix(motion.rotations[0, 1]) - first["body_pose"][0]).max() < 1e-6
    mc.save(motion, tmp_path / "same.pkl")
    assert (tmp_path / "same.pkl").read_bytes() == PHALP.read_bytes()
    filled, _ = mc.Pipeline.from_inline(["fill-gaps"]).run(motion)
    q = filled.rotations.copy()
    q[6, 5] = quat.multiply(q[6, 5], quat.exp(np.array([0.0, 0.0, 0.02])))
    mc.save(filled.replace(rotations=q), tmp_path / "edited.pkl")
    with open(tmp_path / "edited.pkl", "rb") as f:
        out = pickle.load(f)
    assert list(out) == list(tree)
    for key, frame in tree.items():
        for index, params in enumerate(frame["smpl"]):
            new = out[key]["smpl"][index]
            assert new["body_pose"].dtype == np.float32 and new["body_pose"].shape == (23, 3, 3)
            same = key != "frame_000006.jpg" or frame["tid"][index] != 1
            assert np.array_equal(new["body_pose"], params["body_pose"]) == same
        assert out[key]["mask"] == frame["mask"] and out[key]["tid"] == frame["tid"]
    assert np.abs(mc.load(tmp_path / "edited.pkl").rotations[6, 5] - q[6, 5]).max() < 1e-6


def test_a_track_with_gaps_is_not_written_as_an_amass_npz(tmp_path, capsys):
    """AMASS has no missing frames: refused in one line saying what to do, nothing written
    (the pickle's own keys, frame_ids included, had been written as the .npz)."""
    code, _, err = run_cli(capsys, "convert", PHALP, tmp_path / "p.npz")
    assert code == 1 and err.count("\n") == 1
    assert "an AMASS .npz has no missing frames, and 2 of this clip are" in err
    assert "clean it first (fill-gaps bridges them)" in err
    assert not (tmp_path / "p.npz").exists()
    code, _, _ = run_cli(capsys, "clean", PHALP, "-o", tmp_path / "p.npz", "-q")  # filled
    amass = np.load(tmp_path / "p.npz")  # a track without a translation: the root stays put
    assert code == 0 and np.array_equal(amass["trans"], np.zeros((12, 3)))


def test_an_aist_scaling_that_puts_the_body_beyond_every_reader_is_refused(tmp_path, capsys):
    """smpl_scaling 1e-300 had made translations of 6.5e297, refused by no reader until
    despike failed on them, or written to a CSV no reader would take back."""
    record = {"smpl_poses": np.zeros((4, 72)), "smpl_trans": np.ones((4, 3)) * 0.65}
    record["smpl_scaling"] = np.array([1e-300])
    source = tmp_path / "aist.pkl"
    source.write_bytes(pickle.dumps(record, protocol=4))
    code, out, err = run_cli(capsys, "convert", source, tmp_path / "a.csv")
    assert code == 1 and out == "" and not (tmp_path / "a.csv").exists()
    assert err == (
        f"motionclean: error: {source}: smpl_trans: beyond 1e+12 once divided by "
        "smpl_scaling 1e-300\n"
    )


def test_aist_translation_is_read_in_metres_and_written_in_its_scale(tmp_path, capsys):
    """AIST++ stores ``smpl_trans`` in units of ``smpl_scaling`` metres (its SMPL call
    divides by it): read in metres (it had been read 98 times too far, the body flying
    across a stage of 170 m), written back in the file's own scale."""
    frames = 90
    t = np.arange(frames) / 60
    trans = np.stack([50 * t, 90 + 0 * t, 10 * np.sin(t)], axis=-1).astype(np.float32)
    record = {
        "smpl_poses": (0.1 * np.sin(t)[:, None] * np.ones(72)).astype(np.float32),
        "smpl_trans": trans,
        "smpl_scaling": np.array([98.0], dtype=np.float32),
        "smpl_loss": 0.5,
    }
    source = tmp_path / "aist.pkl"
    source.write_bytes(pickle.dumps(record, protocol=4))
    clip = mc.load(source)
    np.testing.assert_allclose(clip.translations[:, 0], trans / 98.0, rtol=1e-7)
    assert any("smpl_scaling 98" in note for note in kinematics.source_notes(clip))
    mc.save(clip, tmp_path / "same.pkl")
    assert (tmp_path / "same.pkl").read_bytes() == source.read_bytes()
    moved = clip.translations.copy()
    moved[:, 0, 0] += 0.01  # 1 cm forward on every frame
    mc.save(clip.replace(translations=moved), tmp_path / "moved.pkl")
    written = pickle.loads((tmp_path / "moved.pkl").read_bytes())
    np.testing.assert_allclose(written["smpl_trans"][:, 0], trans[:, 0] + 0.98, rtol=1e-6)
    code, _, _ = run_cli(capsys, "convert", source, tmp_path / "a.npz", "--input-fps", "60")
    amass = np.load(tmp_path / "a.npz")
    assert code == 0 and np.allclose(amass["trans"], trans / 98.0, rtol=1e-7)


def test_aist_is_read_at_its_60_fps_unless_given_another_rate(tmp_path):
    """AIST++'s motions are 60 fps and its pickles do not say: a record recognised as
    AIST++'s (smpl_scaling) had been read at the 30 fps video estimators run at, its
    motion twice as slow."""
    record = {
        "smpl_poses": np.zeros((10, 72), dtype=np.float32),
        "smpl_trans": np.zeros((10, 3), dtype=np.float32),
        "smpl_scaling": np.array([98.0], dtype=np.float32),
    }
    source = tmp_path / "aist.pkl"
    source.write_bytes(pickle.dumps(record, protocol=4))
    clip = mc.load(source)
    assert clip.frame_time == 1 / 60
    assert "no frame rate in the file; 60 fps, AIST++'s rate (--input-fps gives another)" in (
        kinematics.source_notes(clip)
    )
    assert mc.load(source, frame_rate=50).frame_time == 1 / 50
    del record["smpl_scaling"]
    source.write_bytes(pickle.dumps(record, protocol=4))
    assert mc.load(source).frame_time == 1 / 30  # (not recognised: the default)
