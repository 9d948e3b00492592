"""Long clips are worked through in blocks of frames: the results do not depend on the
block size (bit for bit), so a long clip is cleaned exactly like a short one."""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pytest
from helpers import NOISY, SAMPLE, edited

import motionclean as mc
from motionclean.core import motion as motion_module
from motionclean.core import quat


@pytest.mark.parametrize("block", [1, 7, 64])
def test_euler_write_back_does_not_depend_on_the_block_size(monkeypatch, block):
    clip = edited(mc.load(NOISY), seed=block)
    whole = clip.channel_values()  # default blocks: longer than most runs of 1 to 64
    monkeypatch.setattr(motion_module, "BLOCK_FRAMES", block)
    monkeypatch.setattr(motion_module, "FILTER_BLOCK_FRAMES", block)
    assert np.array_equal(clip.channel_values(), whole)
    again = mc.Motion.from_channel_values(
        clip.names, clip.parents, clip.offsets, clip.channels, clip.frame_time, whole
    )
    monkeypatch.undo()
    reference = mc.Motion.from_channel_values(
        clip.names, clip.parents, clip.offsets, clip.channels, clip.frame_time, whole
    )
    assert np.array_equal(again.rotations, reference.rotations)


@pytest.mark.parametrize("block", [1, 7, 64])
def test_runs_without_anchors_continue_as_one_block_would(monkeypatch, block):
    """Every rotation turned, some far (the whole clip is one run after its first frame):
    blocks after the first have no anchor and take the short path, which must give the
    bits the general path gives when the clip is a single block."""
    clip = mc.load(NOISY)
    q = clip.rotations
    spin = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.linspace(0.0, 9.0, len(q)))
    turned = clip.replace(rotations=quat.multiply(q, spin[:, None]))
    monkeypatch.setattr(motion_module, "FILTER_BLOCK_FRAMES", len(q))
    whole = turned.channel_values()
    monkeypatch.setattr(motion_module, "FILTER_BLOCK_FRAMES", block)
    assert np.array_equal(turned.channel_values(), whole)


@pytest.mark.parametrize("block", [1, 40])  # run ends: 1 and 5 jumps at a time at 120 fps
def test_despike_does_not_depend_on_how_many_jumps_are_examined_together(monkeypatch, block):
    despike_module = importlib.import_module("motionclean.filters.despike")
    clip = mc.load(NOISY)
    noisy = clip.rotations.copy()
    rng = np.random.default_rng(block)
    for frame, joint in zip(
        rng.integers(5, 290, 60), rng.integers(0, clip.n_joints, 60), strict=True
    ):
        axis = rng.normal(size=3)
        turn = quat.from_axis_angle(
            axis / np.linalg.norm(axis), np.deg2rad(rng.choice([60.0, 180.0]))
        )
        noisy[frame : frame + 2, joint] = quat.multiply(noisy[frame : frame + 2, joint], turn)
    whole, report = despike_module.despike_with_report(noisy, clip.frame_time)
    assert report.interpolated.any()
    monkeypatch.setattr(despike_module, "RUN_ENDS_PER_BLOCK", block)
    blocked, again = despike_module.despike_with_report(noisy, clip.frame_time)
    assert np.array_equal(blocked, whole)
    assert np.array_equal(again.interpolated, report.interpolated)
    assert np.array_equal(again.unflipped, report.unflipped)


@pytest.mark.parametrize("frame_time", [1e-6, 1e-4])
def test_a_tiny_frame_time_does_not_blow_up_despike(frame_time):
    """A header claiming 1 MHz turns every step of real motion into a "spike" faster than
    any body moves: the working set still follows the clip (spikes are never longer than
    it) and the columns whose steps do not fit the limits are left as they are."""
    import tracemalloc

    from motionclean.filters.despike import despike_with_report

    q = mc.load(SAMPLE).rotations
    tracemalloc.start()
    out, report = despike_with_report(q, frame_time)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 40 * q.nbytes
    if frame_time == 1e-6:  # every step is "too fast": nothing is rebuilt
        assert not report.interpolated.any()
        unflipped = report.unflipped.any(axis=0)
        np.testing.assert_array_equal(out[:, ~unflipped], q[:, ~unflipped])


def resident_mib() -> int:
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) // 1024 for line in status if line.startswith("VmRSS:"))


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux /proc")
def test_translations_of_joints_without_position_channels_take_no_memory():
    """A 1,000,000-frame, 31-joint clip with a root-only position track: the zero columns
    are never touched (the array spans 744 MB, the root's 24 MB), and a copy that writes
    the root keeps that property while holding every value."""
    frames, joints = 1_000_000, 31
    start = resident_mib()
    translations = motion_module.joint_major_zeros(frames, joints)
    translations[:, 0] = np.arange(3.0 * frames).reshape(frames, 3)
    translations[::7, 5, 2] = 0.0  # written zeros are zeros
    copy = motion_module.sparse_copy(translations)
    assert resident_mib() - start < 200
    assert translations.shape == copy.shape == (frames, joints, 3)
    assert np.array_equal(copy, translations) and not np.shares_memory(copy, translations)
    assert not copy[:, 1:].any()


def test_a_loaded_clip_writes_the_position_channels_only():
    clip = mc.load(SAMPLE)
    has = clip.layout.has_position
    assert has[0] and not has[1:].any()
    values = clip.source_values
    assert np.array_equal(clip.translations[:, 0], values[:, clip.layout.position_columns[0]])
    assert not clip.translations[:, 1:].any()
    clip.translations[:, 3] = 1.0  # still an ordinary writable (F, J, 3) array
    assert clip.translations[5, 3].tolist() == [1.0, 1.0, 1.0]


def test_a_read_clip_holds_its_values_rotations_and_little_else():
    """What a BVH clip keeps once read, besides its text: the values (1x), float64
    rotations (4/3x), translations (1x as tracemalloc counts them, though only the root's
    pages are ever touched) and a byte of gap and of length per value (1/4x). No per-value
    offsets: int32 starts and ends would add 1x."""
    import tracemalloc

    from motionclean.io.bvh import parse_bvh

    text = SAMPLE.read_bytes()
    head, _, rest = text.partition(b"Frame Time:")
    time_line, _, body = rest.partition(b"\n")
    rows = [row for row in body.splitlines(keepends=True) if row.strip()]
    frames = 20 * len(rows)
    head = head.replace(b"Frames: %d" % len(rows), b"Frames: %d" % frames)
    data = head + b"Frame Time:" + time_line + b"\n" + b"".join(rows * 20)
    tracemalloc.start()
    clip = parse_bvh(data, "long.bvh")
    kept = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    assert clip.n_frames == frames
    values = clip.source_values.nbytes
    assert kept < 3.8 * values  # (the text was allocated before tracing began)
