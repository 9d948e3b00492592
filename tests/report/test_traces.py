"""Plot traces against the figures taken from the table itself, column by column."""

from __future__ import annotations

import numpy as np
import pytest

from motionclean.report.traces import COLUMNS, ENVELOPE_COLUMNS, ROBUST_QUANTILE, trace, traces


@pytest.mark.parametrize(
    "shape", [(0, 3), (1, 1), (300, 1), (COLUMNS, 4), (COLUMNS + 1, 1), (9001, 5)]
)
def test_traces_are_each_columns_envelope_peak_and_quantile(shape):
    rng = np.random.default_rng(shape[0])
    table = rng.gamma(2.0, 50.0, shape)
    before = table.copy()
    drawn = traces(table)
    np.testing.assert_array_equal(table, before)  # the caller's table is not reordered
    n = shape[0]
    columns = COLUMNS if n <= COLUMNS else ENVELOPE_COLUMNS
    for c, got in enumerate(drawn):
        column = before[:, c]
        assert got.size == n
        if n <= columns:
            np.testing.assert_array_equal(got.low, column)
            np.testing.assert_array_equal(got.high, column)
        else:
            edges = (np.arange(columns + 1) * n) // columns
            parts = [column[a:b] for a, b in zip(edges[:-1], edges[1:], strict=True)]
            np.testing.assert_array_equal(got.low, [p.min() for p in parts])
            np.testing.assert_array_equal(got.high, [p.max() for p in parts])
            np.testing.assert_array_equal(got.position, (edges[:-1] + edges[1:] - 1) / 2.0)
        assert got.peak == (column.max() if n else 0.0)
        assert got.robust == (np.quantile(column, ROBUST_QUANTILE) if n else 0.0)


def test_a_series_keeps_its_values():
    values = np.random.default_rng(3).normal(size=200)
    kept = values.copy()
    assert trace(values).peak == kept.max()
    np.testing.assert_array_equal(values, kept)
