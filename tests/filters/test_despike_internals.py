"""Despike internals: columns are independent, and the fast sparse helpers compute what the
closed forms and the quaternion module compute."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SAMPLE

import motionclean as mc
from motionclean.core import quat
from motionclean.core.takes import median_rows
from motionclean.filters.despike import (
    _TABLE_SIZE,
    _lagrange,
    _weights,
    despike_positions_with_report,
    despike_with_report,
)


def planted(q: np.ndarray, seed: int) -> np.ndarray:
    """``q`` (F, C, 4) with half-turn flips (both sides) and spikes in every other column."""
    rng = np.random.default_rng(seed)
    q = q.copy()
    for c in range(0, q.shape[1], 2):
        axis = rng.normal(size=3)
        f = quat.from_axis_angle(axis / np.linalg.norm(axis), np.pi)
        start = 20 + 13 * c
        rows = slice(start, start + 1 + c % 3)
        q[rows, c] = quat.multiply(f, q[rows, c]) if c % 4 else quat.multiply(q[rows, c], f)
        kick = quat.from_axis_angle([0.0, 0.6, 0.8], np.deg2rad(70.0))
        q[start + 40 : start + 42, c] = quat.multiply(q[start + 40 : start + 42, c], kick)
    return q


@pytest.mark.parametrize("every", [1, 4])
def test_columns_are_repaired_independently(every):
    # Despike works on the columns with jumps, flips or gaps only; each column's result and
    # report must be those of the column alone (to rounding: numpy's vectorised tan and
    # arctan2 may round the last bit differently for arrays of different lengths).
    m = mc.load(SAMPLE)
    q = planted(quat.make_continuous(m.rotations[::every], axis=0), seed=every)
    dt = m.frame_time * every
    out, report = despike_with_report(q, dt)
    assert report.counts("unflipped").any() and report.counts("interpolated").any()
    for c in range(q.shape[1]):
        alone, alone_report = despike_with_report(q[:, c : c + 1], dt)
        np.testing.assert_allclose(out[:, c], alone[:, 0], rtol=0, atol=1e-15)
        for kind in ("unflipped", "interpolated"):
            np.testing.assert_array_equal(
                getattr(report, kind)[:, c], getattr(alone_report, kind)[:, 0]
            )
        assert report.threshold[c] == alone_report.threshold[0]
        assert report.max_step_after[c] == alone_report.max_step_after[0]

    p = np.cumsum(np.random.default_rng(3).normal(size=(q.shape[0], 4, 3)), axis=0)
    p[30:32, 1] += 40.0
    p[60, 3] -= 40.0
    moved, moved_report = despike_positions_with_report(p, dt, max_units_per_s=2000.0)
    assert moved_report.counts()[[1, 3]].all()
    for c in range(p.shape[1]):
        alone, _ = despike_positions_with_report(p[:, c : c + 1], dt, max_units_per_s=2000.0)
        np.testing.assert_allclose(moved[:, c], alone[:, 0], rtol=0, atol=1e-12)


@pytest.mark.parametrize("n", [1, 2, 7, 8, 501])
def test_median_rows_is_the_numpy_median(n):
    rng = np.random.default_rng(n)
    a = rng.exponential(size=(6, n))
    a[1, 0] = np.inf
    a[2, n // 2] = np.nan
    a[3] = 0.25  # ties
    expected = np.median(a, axis=1)
    np.testing.assert_array_equal(median_rows(a.copy()), expected)


def test_tabulated_weights_are_the_closed_form():
    a, b = np.meshgrid(np.arange(0, 40), np.arange(1, 40))
    a, span = a.ravel(), (a + b).ravel()
    short = span < _TABLE_SIZE
    for part in (short, ~short):  # looked up, and computed for a long gap
        looked_up = _weights(a[part], span[part])
        for got, want in zip(looked_up, _lagrange(a[part], 0, span[part]), strict=True):
            np.testing.assert_array_equal(got, want)
    # The four-point weights reproduce cubics, e.g. 1 and the frame number itself.
    c0, c1, c2, c3 = _weights(a[short], span[short])
    np.testing.assert_allclose(c0 + c1 + c2 + c3, 1.0, atol=1e-12)
    np.testing.assert_allclose(-c0 + c2 * span[short] + c3 * (span[short] + 1), a[short], atol=1e-9)


def test_shortest_log_is_the_wrapped_half_angle_about_the_axis():
    """``log_shortest(exp(theta/2 n))`` is ``wrap(theta)/2 n`` with ``wrap`` into
    ``[-pi, pi]``: the closed form of the shorter arc, whatever the sign of the input."""
    rng = np.random.default_rng(5)
    axis = rng.normal(size=(200, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    theta = rng.uniform(-1.99 * np.pi, 1.99 * np.pi, 200)
    q = quat.from_axis_angle(axis, theta) * rng.choice([-1.0, 1.0], (200, 1))
    wrapped = np.angle(np.exp(1j * theta))
    np.testing.assert_allclose(quat.log_shortest(q), 0.5 * wrapped[:, None] * axis, atol=1e-12)


@pytest.mark.parametrize("block", [1, 5, 1 << 15])
def test_dot_products_in_blocks_are_the_same_bits(monkeypatch, block):
    import importlib

    despike_module = importlib.import_module("motionclean.filters.despike")
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(40, 3, 4)), rng.normal(size=(40, 3, 4))
    whole = np.einsum("...i,...i->...", a, b)
    monkeypatch.setattr(despike_module, "DOT_BLOCK", block)
    assert np.array_equal(despike_module._dot(a, b), whole)
    assert np.array_equal(despike_module._dot(a[0, 0], b[0, 0]), whole[0, 0])
    assert np.array_equal(despike_module._dot(a[:1], b), np.einsum("...i,...i->...", a[:1], b))
