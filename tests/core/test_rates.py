"""Frame counts and frequency bands from frame times as files round them: the same clip is
counted, windowed and cleaned the same whatever digits its frame time was written with."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import NOISY, plant, smooth_synthetic

import motionclean as mc
from motionclean.core import quat
from motionclean.core.errors import UsageError
from motionclean.core.rates import frames_ceil, frames_floor, in_band, same_rate, whole_frames
from motionclean.filters.auto import auto
from motionclean.filters.noise import window_frames
from motionclean.steps.pipeline import Pipeline
from motionclean.steps.ranges import FrameRange

#: 1/120 s as files write it: exactly, to 11, 7 and 6 decimals.
WRITTEN_120 = (1 / 120, 0.00833333333, 0.0083333, 0.008333)


@pytest.mark.parametrize("frame_time", WRITTEN_120)
def test_seconds_count_the_frames_the_rate_meant(frame_time):
    assert frames_ceil(1.0 / frame_time) == 120  # read literally: 121 at 0.0083333
    assert frames_floor(0.5 / frame_time) == 60
    assert frames_floor(0.5 / 0.008334) == 60  # read literally: 59
    assert window_frames(10_000, frame_time, 2.0) == window_frames(10_000, 1 / 120, 2.0)


def test_only_counts_near_a_whole_number_are_snapped():
    assert whole_frames(120.3) == 120.3
    assert frames_ceil(120.3) == 121
    assert frames_floor(119.7) == 119
    # a long span's rounding moves it by no more than a quarter of a frame
    assert whole_frames(1_000_000.4) == 1_000_000.4
    assert whole_frames(1_000_000.2) == 1_000_000
    assert math.isinf(whole_frames(math.inf))


def test_one_rate_written_to_other_digits_is_the_same_rate_and_ntsc_is_another():
    # 1/60 s as files write it, to 7 decimals, 6 and 4 significant digits
    for written in (0.0166667, 0.016667, 0.01667):
        assert same_rate(1 / 60, written) and same_rate(written, 1 / 60)
    assert same_rate(1 / 120, 0.008333)
    # NTSC's 59.94 and 29.97 fps are 1e-3 from 60 and 30: other rates, either way round
    for ntsc, rate in ((1001 / 60000, 60), (1001 / 30000, 30)):
        assert not same_rate(1 / rate, ntsc) and not same_rate(ntsc, 1 / rate)


def test_bands_hold_their_lower_edge_and_their_upper_one_only_when_closed():
    hz = np.array([1.9999, 2.0, 4.0, 7.9999, 8.0, 8.1])
    assert in_band(hz, 2.0, 8.0).tolist() == [True, True, True, False, False, False]
    assert in_band(hz, 2.0, 8.0, closed=True).tolist() == [True] * 5 + [False]
    assert in_band(hz, 4.0).tolist() == [False, False, True, True, True, True]


@pytest.mark.parametrize("frame_time", WRITTEN_120[1:])
def test_auto_cleans_a_clip_the_same_whatever_digits_its_frame_time_has(frame_time):
    """The noise model's windows and bands follow the rate the file meant: the same choices
    and, but for the low-pass masks' rate, the same output (before: a window of 240 frames
    at 1/120 s and 244 at 0.0083333 s, other choices and up to a few tenths of a degree)."""
    truth = smooth_synthetic(frames=1200, joints=8, seed=5)
    noisy = plant(truth, 2.0, seed=6)
    exact = auto(noisy, 1 / 120)
    written = auto(noisy, frame_time)
    assert [c.params() for c in written.choices] == [c.params() for c in exact.choices]
    assert [c.loud for c in written.choices] == [c.loud for c in exact.choices]
    moved = np.degrees(quat.angle_between(written.values, exact.values))
    assert moved.max() < 1e-3


@pytest.mark.parametrize("frame_time", WRITTEN_120)
def test_a_range_in_seconds_starts_on_the_frame_of_its_time(frame_time):
    span = FrameRange.from_params(None, [1.0, 2.0], 0, "test").frame_span(600, frame_time, "t")
    assert span == (120, 240)


def test_the_default_cleans_a_file_the_same_whatever_digits_its_frame_time_has():
    """The noisy sample (written 0.0083333 s) and the same clip at exactly 1/120 s: the
    default, footlock included, moves no joint more than 1e-3 degrees apart (before:
    0.14 degrees on the legs, a blend of 12.00005 frames easing one more frame into a
    contact than a blend of 12)."""
    written = mc.load(NOISY)
    exact = written.replace(frame_time=1 / 120)
    assert written.frame_time != exact.frame_time
    a = Pipeline.default().run(written)[0].rotations
    b = Pipeline.default().run(exact)[0].rotations
    assert np.degrees(quat.angle_between(a, b)).max() < 1e-3


def test_a_range_past_the_clip_says_so_in_seconds_at_any_writing():
    """2 s of a 240-frame clip (0-1.9917 s) is past its end whether the frame time reads
    0.008334 or 1/120: the seconds are what the error names (before, at 0.008334 the check
    let 239.98 frames through and the frames check then refused frame 240)."""
    for written in (1 / 120, 0.008334):
        with pytest.raises(UsageError, match="the range ends at 2 s"):
            FrameRange.from_params(None, [0.0, 2.0], 0, "t").frame_span(240, written, "t")
