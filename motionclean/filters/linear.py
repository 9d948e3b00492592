"""Lee-Shin orientation filters: any mask as a coordinate-invariant orientation filter.

Paper 000 (Lee & Shin 2002). For a mask ``(a_-k .. a_k)`` summing to one,

    H(q_i) = q_i exp( sum_{m=-k}^{k-1} b_m w_{i+m} ),   w_i = log(q_i^-1 q_{i+1})   (Eq. 19)

with ``b_m`` the partial sums of Eq. 20. Displacements beyond the ends are mirrored as in
Eq. 26. The vector counterpart uses linear displacements ``d_i = p_{i+1} - p_i`` and is
ordinary convolution with the mask in the interior.

Arrays are time-major: ``(F, ..., 4)`` quaternions ``(w, x, y, z)`` or ``(F, ..., 3)``
vectors; every trailing axis (joints, ...) is filtered at once.
"""

from __future__ import annotations

import numpy as np

from .. import quat
from .masks import validate_mask

__all__ = [
    "angular_displacements",
    "apply_displacement_sums",
    "displacement_coefficients",
    "lee_shin",
    "lee_shin_positions",
    "mirror_indices",
    "mirrored_displacements",
]


def displacement_coefficients(mask) -> np.ndarray:
    """Coefficients ``(b_-k, ..., b_{k-1})`` of 000 Eq. 20 for a mask ``(a_-k, ..., a_k)``.

    ``b_m = sum_{j>m} a_j`` for ``m >= 0`` and ``b_m = -sum_{j<=m} a_j`` for ``m < 0``.
    """
    a = validate_mask(mask)
    k = a.size // 2
    tail = np.cumsum(a[::-1])[::-1]  # tail[n] = sum_{idx >= n} a[idx]
    head = np.cumsum(a)  # head[n] = sum_{idx <= n} a[idx]
    b = np.empty(2 * k)
    b[:k] = -head[:k]  # m = -k .. -1  -> idx = m + k
    b[k:] = tail[k + 1 :]  # m = 0 .. k-1 -> sum over idx >= m + 1 + k
    return b


def mirror_indices(n: int, before: int, after: int) -> np.ndarray:
    """Indices into ``n`` displacements for positions ``-before .. n-1+after`` (000 Eq. 26).

    ``w_i = w_{-i}`` for ``i < 0`` and ``w_i = w_{2n-i-2}`` for ``i >= n``: reflection about
    the first and the last displacement, repeated as often as a short signal needs.
    """
    j = np.arange(-before, n + after)
    if n == 1:
        return np.zeros_like(j)
    period = 2 * (n - 1)
    j = np.mod(j, period)
    return np.where(j > n - 1, period - j, j)


def angular_displacements(q: np.ndarray) -> np.ndarray:
    """``w_i = log(q_i^-1 q_{i+1})`` along axis 0: shape ``(F-1, ..., 3)``.

    ``q`` must be sign-continuous (:func:`motionclean.quat.make_continuous`), so that each
    ``|w_i| <= pi/2``.
    """
    return quat.log(quat.multiply(quat.conjugate(q[:-1]), q[1:]))


def mirrored_displacements(w: np.ndarray, before: int, after: int) -> np.ndarray:
    """Displacements extended by Eq. 26 of 000 to positions ``-before .. n-1+after``."""
    return w[mirror_indices(w.shape[0], before, after)]


def _weighted_window_sum(w: np.ndarray, b: np.ndarray, n_out: int) -> np.ndarray:
    """``s_i = sum_m b_m w_{i+m}`` for ``i = 0 .. n_out-1`` and ``m = -k .. k-1``."""
    k = b.size // 2
    ext = mirrored_displacements(w, k, k + n_out - w.shape[0] - 1)
    total = np.zeros((n_out, *w.shape[1:]))
    for tap, coeff in enumerate(b):  # loop over mask taps only
        if coeff != 0.0:
            total += coeff * ext[tap : tap + n_out]
    return total


def apply_displacement_sums(q: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``q_i exp(s_i)``: move each sample by a tangent vector measured in its own frame."""
    return quat.multiply(q, quat.exp(s))


def lee_shin(q: np.ndarray, mask, iterations: int = 1) -> np.ndarray:
    """Apply the orientation filter of ``mask`` ``iterations`` times (000 Eq. 19-20, 26).

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions ``(w, x, y, z)``, time along axis 0. Signs are made continuous
        first (000 Sec. VI-A), so antipodal flips in the input do not matter.
    mask : sequence of float
        Odd-length mask summing to one, e.g. :func:`masks.binomial` ``(2)``.
    iterations : int
        Number of passes.

    Returns
    -------
    (F, ..., 4) array
        Filtered unit quaternions, sign-continuous. Coordinate invariant on both sides
        (Prop. 1), time invariant (Prop. 2) and symmetric for symmetric masks (Prop. 3).
    """
    b = displacement_coefficients(mask)
    out = quat.make_continuous(q, axis=0)
    if out.shape[0] < 2 or b.size == 0:
        return out
    for _ in range(int(iterations)):
        w = angular_displacements(out)
        out = apply_displacement_sums(out, _weighted_window_sum(w, b, out.shape[0]))
    return out


def lee_shin_positions(p: np.ndarray, mask, iterations: int = 1) -> np.ndarray:
    """Vector counterpart of :func:`lee_shin` on ``(F, ..., 3)`` positions.

    ``p_i + sum_m b_m d_{i+m}`` with ``d_i = p_{i+1} - p_i`` mirrored by Eq. 26: plain
    convolution with the mask in the interior, the same boundary rule as orientations.
    """
    b = displacement_coefficients(mask)
    out = np.array(p, dtype=np.float64, copy=True)
    if out.shape[0] < 2 or b.size == 0:
        return out
    for _ in range(int(iterations)):
        d = np.diff(out, axis=0)
        out = out + _weighted_window_sum(d, b, out.shape[0])
    return out
