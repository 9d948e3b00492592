"""``save`` writes what the Motion holds or refuses it: a frame time no reader takes is an
error, and an edited skeleton (names, offsets, end sites) is written, never dropped for the
hierarchy text the clip was read with."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import SAMPLE, run_cli

import motionclean as mc
from motionclean.core.errors import InvalidMotion


@pytest.mark.parametrize("suffix", [".bvh", ".csv"])
@pytest.mark.parametrize("frame_time", [math.nan, 0.0, -1.0, math.inf, 1e-9, 3600.5, 1e5])
def test_save_refuses_a_frame_time_load_would_refuse(tmp_path, suffix, frame_time):
    """A frame time no reader takes is refused where the clip is made (a pipeline had
    then failed on it with ZeroDivisionError or a NaN conversion), and by ``save`` when
    it was set on the clip afterwards."""
    message = r"frame_time must be from 1e-06 s to 3600 s, got"
    with pytest.raises(ValueError, match=message):  # (InvalidMotion)
        mc.load(SAMPLE).replace(frame_time=frame_time)
    clip = mc.load(SAMPLE)
    clip.frame_time = frame_time
    with pytest.raises(ValueError, match=message):
        mc.save(clip, tmp_path / f"o{suffix}")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("suffix", [".bvh", ".csv"])
def test_the_rate_limits_are_taken_alike_everywhere(tmp_path, capsys, suffix):
    """An hour a frame (the slowest rate `resample` takes, 1/3600 fps) is a clip every
    reader takes too: `resample --frame-time 3600` had passed the option check, then failed
    as the clip was made ("under 3600 s"), and a file with that frame time was refused by a
    message whose own range held it."""
    clip = mc.load(SAMPLE)
    three = clip.replace(
        rotations=clip.rotations[:3], translations=clip.translations[:3], frame_time=1800.0
    )
    source = tmp_path / f"c{suffix}"
    mc.save(three.replace(source_values=None, source_rotations=None), source)
    out = tmp_path / f"slow{suffix}"
    code, _, err = run_cli(capsys, "resample", source, out, "--frame-time", "3600")
    assert code == 0, err
    assert mc.load(out).frame_time == 3600.0 and mc.load(out).n_frames == 2


def test_an_edited_skeleton_is_written_and_the_frames_keep_their_text(tmp_path):
    clip = mc.load(SAMPLE)
    names, offsets = list(clip.names), clip.offsets.copy()
    names[3] = "RenamedKnee"
    offsets[2] = [1.5, -2.25, 3.125]
    sites = {j: site.copy() for j, site in clip.end_sites.items()}
    first_site = min(sites)
    sites[first_site] = np.array([0.5, 0.25, -0.125])
    edited = clip.replace(names=names, offsets=offsets, end_sites=sites)
    mc.save(edited, tmp_path / "e.bvh")
    back = mc.load(tmp_path / "e.bvh")
    assert back.names == names and np.array_equal(back.offsets, offsets)
    assert np.array_equal(back.end_sites[first_site], sites[first_site])
    assert np.array_equal(back.rotations, clip.rotations)
    assert np.array_equal(back.translations, clip.translations)
    rows = SAMPLE.read_bytes().split(b"MOTION", 1)[1]
    assert (tmp_path / "e.bvh").read_bytes().split(b"MOTION", 1)[1] == rows  # frames as read
    mc.save(clip, tmp_path / "same.bvh")  # and an unedited clip is still the input's bytes
    assert (tmp_path / "same.bvh").read_bytes() == SAMPLE.read_bytes()


def test_an_edited_skeleton_with_edited_frames_is_written_too(tmp_path):
    clip = mc.load(SAMPLE)
    offsets = clip.offsets * 2.0
    rotations = clip.rotations.copy()
    rotations[:, 1] = rotations[::-1, 1]
    edited = clip.replace(offsets=offsets, rotations=rotations, frame_time=clip.frame_time / 2)
    mc.save(edited, tmp_path / "e.bvh")
    back = mc.load(tmp_path / "e.bvh")
    assert np.array_equal(back.offsets, offsets) and back.frame_time == clip.frame_time / 2
    assert np.degrees(mc.core.quat.angle_between(back.rotations, rotations)).max() < 1e-4


def _far_translation(clip):
    far = clip.translations.copy()
    far[7, 0, 0] = 1e13
    return clip.replace(translations=far)


def _far_offset(clip):
    offsets = clip.offsets.copy()
    offsets[3, 1] = -1e13
    return clip.replace(offsets=offsets)


def _far_end_site(clip):
    joint = sorted(clip.end_sites)[0]
    return clip.replace(end_sites={**clip.end_sites, joint: np.array([0.0, 2e13, 0.0])})


@pytest.mark.parametrize(
    ("where", "edit"),
    [("translations", _far_translation), ("offsets", _far_offset), ("end sites", _far_end_site)],
)
def test_a_value_no_reader_takes_back_is_not_written(tmp_path, where, edit):
    """A position, offset or end site beyond 1e12 units had been written (exit 0) to a file
    that every reader, motionclean's too, refuses."""
    clip = edit(mc.load(SAMPLE))
    for suffix in (".bvh", ".csv", ".glb"):
        with pytest.raises(InvalidMotion, match=f"far{suffix}: {where}: joint .* beyond 1e\\+12"):
            mc.save(clip, tmp_path / f"far{suffix}")
        assert not (tmp_path / f"far{suffix}").exists()
