"""Scalar samples at uneven times on a uniform grid: a parabola kept, samples hit exactly."""

from __future__ import annotations

import numpy as np
import pytest

from motionclean.core.regrid import MOST_FRAMES_PER_ROW, at_times, regridded


def test_a_parabola_and_the_samples_themselves_come_back():
    rng = np.random.default_rng(3)
    times = np.sort(np.r_[0.0, rng.uniform(0.0, 1.0, 30), 1.0])
    values = np.stack([3 * times**2 - 2 * times + 1, 0.5 * times], axis=1)
    at = np.linspace(0.0, 1.0, 257)
    expected = np.stack([3 * at**2 - 2 * at + 1, 0.5 * at], axis=1)
    np.testing.assert_allclose(at_times(times, values, at), expected, atol=1e-12)
    np.testing.assert_array_equal(at_times(times, values, times), values)
    two = at_times(times[:2], values[:2], np.linspace(0.0, times[1], 5))
    np.testing.assert_allclose(two[:, 1], 0.5 * np.linspace(0.0, times[1], 5), atol=1e-15)


def test_the_grid_is_the_median_step_from_the_first_time():
    times = np.array([0.4, 0.401, 0.403, 0.41, 0.42, 0.425, 0.43])
    frame_time, values = regridded(times, np.sin(times)[:, None])
    assert frame_time == float(f"{np.median(np.diff(times)):.12g}")  # (0.005, not 0.0049999)
    assert values.shape == (int((0.43 - 0.4) / frame_time + 1e-9) + 1, 1)
    assert values[0, 0] == np.sin(0.4)


def test_a_grid_follows_the_rows_not_their_smallest_step():
    """A few rows 0.1 us apart and the rest seconds apart: the median step would make a
    grid of ten million frames; refused, as is a frame time no clip may have."""
    tiny = np.r_[np.arange(31) * 1e-7, 0.5, 1.0]
    with pytest.raises(ValueError, match="no usable frame rate"):
        regridded(tiny, np.zeros((tiny.size, 1)))
    sparse = np.r_[np.arange(30) * 1e-5, 4.0, 9.0]
    with pytest.raises(ValueError, match="too uneven"):
        regridded(sparse, np.zeros((sparse.size, 1)))
    fine = np.r_[np.arange(10) * 0.01, 0.1 + 0.01 * MOST_FRAMES_PER_ROW]
    assert regridded(fine, np.zeros((fine.size, 1)))[1].shape[0] <= MOST_FRAMES_PER_ROW * 11


def test_the_grid_ends_on_the_last_sample():
    """Integrator steps 0.5-1.5 ms apart over 0.25 s (an OpenSim forward simulation's
    states): the grid's step is within half a frame's share of the median and its last
    frame is the last sample's time, value for value (the median step itself had ended
    up to a step short of it)."""
    rng = np.random.default_rng(4)
    times = 0.83 + np.r_[0.0, np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 260))]
    times = 0.83 + (times - 0.83) * (0.25 / (times[-1] - 0.83))
    values = np.stack([np.sin(7.0 * times), times**2], axis=1)
    frame_time, grid = regridded(times, values)
    frames = grid.shape[0]
    assert abs(0.83 + (frames - 1) * frame_time - times[-1]) < 1e-9
    np.testing.assert_allclose(grid[-1], values[-1], atol=1e-12)
    median = np.median(np.diff(times))
    assert abs(frame_time - median) <= 0.5 * median / (frames - 1) + 1e-12
