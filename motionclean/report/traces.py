"""Per-frame figures reduced to what a plot draws of them.

A report's plots draw a series of any length in :data:`COLUMNS` columns, so a series is
kept as its min/max envelope over those columns plus the two numbers that set the y axis
(the peak and the 99.5th percentile): a few kB per joint instead of the clip's length.
Samples that are NaN (rest-pose frames, missing samples) are left out: a column without any
other sample is NaN, drawn as a gap.
"""

from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np

__all__ = [
    "COLUMNS",
    "ENVELOPE_COLUMNS",
    "ROBUST_QUANTILE",
    "Trace",
    "envelope",
    "trace",
    "traces",
]

#: Plot columns of a panel: a series of at most this many samples is drawn one per column.
COLUMNS = 554
#: A longer series becomes a min/max envelope of this many columns (at most COLUMNS points
#: either way): the page size does not grow with the clip length.
ENVELOPE_COLUMNS = COLUMNS // 2
#: The quantile a plot's y axis may stop at when a few samples are far above the rest.
ROBUST_QUANTILE = 0.995


class Trace(NamedTuple):
    """One series as a plot draws it: ``low`` and ``high`` (K,), the min and max of the
    samples in each plot column, at ``position`` (K,), the columns' sample positions
    (fractional index); ``size`` samples in all, the largest ``peak`` and the
    :data:`ROBUST_QUANTILE` quantile ``robust`` (0 for an empty series)."""

    position: np.ndarray
    low: np.ndarray
    high: np.ndarray
    size: int
    peak: float
    robust: float


def envelope(values: np.ndarray, columns: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reduce ``values`` (N, ...) along axis 0 to at most ``columns`` plot columns.

    Returns ``(position, low, high)``: the sample position (fractional index) of each
    column and the min and max of the samples falling in it (``(K, ...)``), NaN samples
    left out (NaN where a column has no other). With ``N <= columns`` every sample is its
    own column (``low == high``).
    """
    values = np.asarray(values, dtype=np.float64)
    n = values.shape[0]
    if n <= columns:
        return np.arange(n, dtype=np.float64), values, values
    edges = (np.arange(columns + 1) * n) // columns  # strictly increasing since n > columns
    if values.ndim == 2 and values.T.flags.c_contiguous:  # each column's samples contiguous
        low = np.fmin.reduceat(values.T, edges[:-1], axis=1).T
        high = np.fmax.reduceat(values.T, edges[:-1], axis=1).T
    else:
        low = np.fmin.reduceat(values, edges[:-1], axis=0)
        high = np.fmax.reduceat(values, edges[:-1], axis=0)
    return (edges[:-1] + edges[1:] - 1) / 2.0, low, high


#: Table columns traced at a time (:func:`traces`' copy is of these alone).
TRACE_GROUP = 8


def traces(table: np.ndarray) -> list[Trace]:
    """The :class:`Trace` of each column of a ``(N, R)`` table of per-frame figures.

    Made :data:`TRACE_GROUP` columns at a time from a copy of them stored column by column:
    the envelope reduces each column's contiguous samples, the peak is the largest of the
    envelope's maxima and the quantile partitions the copy in place (the same figures as
    from the table itself)."""
    table = np.asarray(table, dtype=np.float64)
    n_cols = table.shape[1]
    quantile = np.nanquantile if np.isnan(table).any() else np.quantile
    return [
        found
        for at in range(0, n_cols, TRACE_GROUP)
        for found in _group_traces(table[:, at : at + TRACE_GROUP], quantile)
    ]


def _group_traces(table: np.ndarray, quantile) -> list[Trace]:
    n, n_cols = table.shape
    by_column = np.array(table.T, order="C")  # (R, N), a copy (the quantile reorders it)
    columns = COLUMNS if n <= COLUMNS else ENVELOPE_COLUMNS
    # (a short series is its own envelope: the table's, not the copy the quantile reorders)
    position, low, high = envelope(table if n <= columns else by_column.T, columns)
    if n and n_cols:
        with warnings.catch_warnings():  # a column of gaps only has no quantile: 0 below
            warnings.simplefilter("ignore", RuntimeWarning)
            peak = np.fmax.reduce(high, axis=0)
            robust = quantile(by_column, ROBUST_QUANTILE, axis=1, overwrite_input=True)
        peak, robust = np.nan_to_num(peak), np.nan_to_num(robust)
    else:
        peak = robust = np.zeros(n_cols)
    return [
        Trace(position, low[:, c].copy(), high[:, c].copy(), n, float(peak[c]), float(robust[c]))
        for c in range(n_cols)
    ]


def trace(values: np.ndarray) -> Trace:
    """The :class:`Trace` of one series ``(N,)``."""
    return traces(np.asarray(values, dtype=np.float64)[:, None])[0]
