"""A large input's text stays on disk between reading and writing (``io.files.FileBytes``):
the written bytes are the ones a text held in memory gives, whatever happens to the path
meanwhile, and a file changed in place is refused instead of being spliced into the
output."""

from __future__ import annotations

import os
import pickle
import shutil
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from helpers import NOISY, SAMPLE, run_cli

import motionclean as mc
from motionclean.core import quat
from motionclean.core.errors import MotionError
from motionclean.io import files
from motionclean.io.files import FileBytes


def turned_right_side(clip: mc.Motion) -> mc.Motion:
    """The clip with its Right* joints turned by 2 degrees (other rotations unchanged)."""
    q = clip.rotations.copy()
    right = [j for j, name in enumerate(clip.names) if name.startswith("Right")]
    turn = quat.from_axis_angle(np.array([0.0, 0.6, 0.8]), np.deg2rad(2.0))
    q[:, right] = quat.multiply(q[:, right], turn)
    return clip.replace(rotations=q)


@pytest.fixture
def copied(tmp_path: Path) -> Path:
    return Path(shutil.copy(NOISY, tmp_path / "take.bvh"))


@pytest.fixture
def on_disk(monkeypatch):
    """Every BVH file read is left on disk, whatever its size."""
    monkeypatch.setattr(files, "KEEP_ON_DISK_BYTES", 0)


def written(clip: mc.Motion, path: Path) -> bytes:
    mc.save(clip, path)
    return path.read_bytes()


def test_text_left_on_disk_writes_the_bytes_a_text_in_memory_writes(copied, monkeypatch):
    in_memory = mc.load(copied)
    monkeypatch.setattr(files, "KEEP_ON_DISK_BYTES", 0)
    kept = mc.load(copied)
    assert isinstance(kept.source.raw, FileBytes) and isinstance(in_memory.source.raw, bytes)
    out = copied.parent
    assert written(kept, out / "same.bvh") == copied.read_bytes()
    edited = written(turned_right_side(kept), out / "a.bvh")
    assert edited != copied.read_bytes()
    assert edited == written(turned_right_side(in_memory), out / "b.bvh")
    # CSV output keeps the BVH's text of unchanged values too
    assert written(turned_right_side(kept), out / "a.csv") == written(
        turned_right_side(in_memory), out / "b.csv"
    )


def test_the_path_replaced_or_removed_after_reading_changes_nothing(copied, on_disk, tmp_path):
    expected = written(turned_right_side(mc.load(copied)), tmp_path / "expected.bvh")
    clip = mc.load(copied)
    other = tmp_path / "other.bvh"
    other.write_bytes(SAMPLE.read_bytes())
    os.replace(other, copied)  # what `clean --in-place` does to the input
    assert written(turned_right_side(clip), tmp_path / "replaced.bvh") == expected
    copied.unlink()
    assert written(turned_right_side(clip), tmp_path / "removed.bvh") == expected


def test_clean_in_place_of_a_file_left_on_disk(copied, on_disk, tmp_path, capsys):
    code, _, err = run_cli(capsys, "clean", copied, "-o", tmp_path / "beside.bvh", "-q")
    assert code == 0 and not err
    code, _, err = run_cli(capsys, "clean", copied, "--in-place", "-q")
    assert code == 0 and not err
    assert copied.read_bytes() == (tmp_path / "beside.bvh").read_bytes()


@pytest.mark.parametrize("change", ["one digit, times set back", "cut short"])
def test_a_file_changed_in_place_after_reading_is_refused(copied, on_disk, tmp_path, change):
    clip = turned_right_side(mc.load(copied))
    info = copied.stat()
    data = bytearray(copied.read_bytes())
    if change == "cut short":
        data = data[: len(data) // 2]
    else:  # the same size and, once set back, the same times: only the bytes tell
        last = data.rindex(b".", 0, len(data) - 1) + 1
        data[last] = ord("1") if data[last] != ord("1") else ord("2")
    with open(copied, "r+b") as f:  # the same file, written over
        f.write(data)
        f.truncate()
    os.utime(copied, ns=(info.st_atime_ns, info.st_mtime_ns))
    target = tmp_path / "out" / "cleaned.bvh"
    target.parent.mkdir()
    with pytest.raises(MotionError, match="changed on disk after it was read"):
        mc.save(clip, target)
    assert list(target.parent.iterdir()) == []  # no output, no temporary file


def test_bytes_appended_after_reading_do_not_change_what_is_written(copied, on_disk, tmp_path):
    """The clip is what was read: a file that grew since (a capture still being written)
    is written from the bytes read, which are still there."""
    expected = written(turned_right_side(mc.load(copied)), tmp_path / "expected.bvh")
    clip = turned_right_side(mc.load(copied))
    with open(copied, "ab") as f:
        f.write(b"0 " * 96 + b"\n")
    assert written(clip, tmp_path / "grown.bvh") == expected


def test_a_failed_read_leaves_no_file_open(copied, on_disk):
    data = copied.read_bytes()
    copied.write_bytes(data.replace(b"Frame Time:", b"Frame Tyme:"))
    descriptors = len(os.listdir("/proc/self/fd")) if Path("/proc/self/fd").exists() else None
    errors = []
    for _ in range(5):
        try:
            mc.load(copied)
        except MotionError as error:
            errors.append(error)  # the tracebacks are kept
    assert len(errors) == 5 and "Frame Time" in str(errors[0])
    if descriptors is not None:
        assert len(os.listdir("/proc/self/fd")) == descriptors


def test_a_pickled_clip_carries_its_text(copied, on_disk, tmp_path):
    clip = mc.load(copied)
    again = pickle.loads(pickle.dumps(clip))
    copied.unlink()
    assert isinstance(again.source.raw, bytes)
    assert written(turned_right_side(again), tmp_path / "a.bvh") == written(
        turned_right_side(clip), tmp_path / "b.bvh"
    )


def test_a_large_file_is_not_held_in_memory_once_read(tmp_path):
    """A file of KEEP_ON_DISK_BYTES or more: what the clip keeps is its values (1x), float64
    rotations (4/3x), translations (1x as tracemalloc counts them) and a byte of gap and of
    length per value (1/4x); its text (about 1.2x) would push it past 3.8x."""
    text = SAMPLE.read_bytes()
    head, _, rest = text.partition(b"Frame Time:")
    time_line, _, body = rest.partition(b"\n")
    rows = [row for row in body.splitlines(keepends=True) if row.strip()]
    copies = files.KEEP_ON_DISK_BYTES // len(b"".join(rows)) + 1
    head = head.replace(b"Frames: %d" % len(rows), b"Frames: %d" % (copies * len(rows)))
    path = tmp_path / "long.bvh"
    path.write_bytes(head + b"Frame Time:" + time_line + b"\n" + b"".join(rows * copies))
    assert path.stat().st_size >= files.KEEP_ON_DISK_BYTES
    tracemalloc.start()
    clip = mc.load(path)
    kept = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    assert isinstance(clip.source.raw, FileBytes)
    assert kept < 3.8 * clip.source_values.nbytes
    assert written(clip, tmp_path / "same.bvh") == path.read_bytes()


def test_csv_files_left_on_disk_write_the_bytes_a_text_in_memory_writes(tmp_path, monkeypatch):
    """A channel CSV (with its BVH skeleton and without) and a Motive export: the same bytes
    from text held in memory and from the file read again, edited or not."""
    root = Path(__file__).resolve().parents[2] / "sample_data"
    channel = tmp_path / "take.csv"
    mc.save(mc.load(NOISY), channel)
    motive = Path(shutil.copy(root / "131_02_motive.csv", tmp_path / "motive.csv"))
    template = mc.load(NOISY)
    cases = [(channel, None), (channel, template), (motive, None)]
    for path, skeleton in cases:
        in_memory = mc.load(path, skeleton=skeleton)
        monkeypatch.setattr(files, "KEEP_ON_DISK_BYTES", 0)
        kept = mc.load(path, skeleton=skeleton)
        monkeypatch.undo()
        kept_raw = getattr(kept.source, "raw", b"")
        assert isinstance(kept_raw, FileBytes) == (skeleton is None)  # a template's text stays
        for clip, name in ((kept, "a"), (in_memory, "b")):
            q = clip.rotations.copy()
            q[10:20] = quat.multiply(q[10:20], quat.from_axis_angle(np.array([1.0, 0, 0]), 0.1))
            suffix = path.suffix if skeleton is None else ".bvh"
            mc.save(clip, tmp_path / f"same_{name}{suffix}")
            mc.save(clip.replace(rotations=q), tmp_path / f"edit_{name}{suffix}")
        for kind in ("same", "edit"):
            a, b = (tmp_path / f"{kind}_{n}{suffix}" for n in "ab")
            assert a.read_bytes() == b.read_bytes(), (path.name, skeleton is None, kind)
        if skeleton is None:
            assert (tmp_path / f"same_a{suffix}").read_bytes() == path.read_bytes()
