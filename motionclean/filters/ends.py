"""Displacements beyond a signal's ends by reflection about a fitted end pose.

Eq. 26 of 000 mirrors the displacements at an end (``w_{-i} = w_i``), which keeps a
constant angular velocity a fixed point of every mask filter but holds the end sample
nearly where it was: a symmetric mask sums a sample's neighbours in pairs that the mirror
makes cancel, so the first and last frames keep most of their noise (white noise under
``B^9``: 0.88 of it at the first frame against 0.44 inside the clip), a pop where a clip
starts and ends. Here the signal is continued past each end by its point reflection
about the end pose that a least-squares polynomial of degree :data:`FIT_DEGREE` through
the samples near that end gives (``q_{-i} = p q_i^-1 p`` on S^3, ``p_{-i} = 2 p - p_i``
for vectors): a constant angular or linear velocity is still continued exactly (the fit
passes through it), so it stays a fixed point, and a symmetric mask now pulls the end
sample towards the fitted pose instead of keeping it. Rotations are fitted as the sums of
the displacements from the end sample (``sum_{j<i} w_j``, each in its own sample's frame,
exact on a constant angular velocity and free of the logarithm's wrap at half a turn over
a long fit), so the continuation is coordinate invariant on both sides: a change of frame
on the left leaves the displacements as they are, one on the right turns them all alike.

Arrays are time-major ``(F, C, 4)`` quaternions ``(w, x, y, z)`` (sign-continuous) or
``(F, C, 3)`` vectors.
"""

from __future__ import annotations

import numpy as np

from ..core import quat

#: Degree of the polynomial fitted to the samples near an end (a line: a quadratic, or a
#: fit over a low-pass mask's side lobes, was measured worse at the clip's ends).
FIT_DEGREE = 1


def end_weights(kernel: np.ndarray) -> np.ndarray:
    """``(n,)`` weights ``h`` whose sum ``sum_i h_i x_i`` over samples ``i = 0 .. n-1``
    is the weighted least-squares polynomial of :data:`FIT_DEGREE` (less when fewer
    samples ask for it), sample ``i`` weighted by ``kernel[i] >= 0``, evaluated at
    ``i = 0``; they sum to one and reproduce polynomials of that degree exactly."""
    n = kernel.size
    degree = min(FIT_DEGREE, n - 1)
    t = np.arange(n, dtype=np.float64) / max(n - 1, 1)
    basis = np.vander(t, degree + 1, increasing=True) * np.sqrt(kernel)[:, None]
    return np.linalg.pinv(basis)[0] * np.sqrt(kernel)


def fit_kernel(mask: np.ndarray, n_frames: int) -> np.ndarray:
    """The end fit's kernel for a column filtered there by ``mask``: its main lobe from
    the centre to the first tap that is not positive (a low-pass or Savitzky-Golay mask's
    outer lobes are left out), cut to the clip."""
    half = mask[mask.size // 2 :]
    lobe = int(np.argmax(half <= 0.0)) if np.any(half <= 0.0) else half.size
    return half[: max(min(lobe, n_frames), 1)]


def reflect(about: np.ndarray, x: np.ndarray, rotations: bool) -> np.ndarray:
    """The point reflection of samples ``x`` about ``about``: ``a x^-1 a`` for unit
    quaternions, ``2 a - x`` for positions (a constant angular or linear velocity through
    ``about`` goes on exactly; it commutes with rotating the signal from either side and
    with rigid motions of positions)."""
    if rotations:
        return quat.multiply(quat.multiply(about, quat.conjugate(x)), about)
    return 2.0 * about - x


def _from_end(x: np.ndarray, count: int, rotations: bool) -> np.ndarray:
    """Samples ``0 .. count-1`` counted from the end at row 0 of ``x``; where ``count``
    exceeds its length, the signal is continued past its far end by its point reflection
    about its last sample, as often as needed (a mask wider than the clip: a constant
    angular or linear velocity goes on exactly, where Eq. 26's mirror turned it back)."""
    if x.shape[0] == 1:  # one sample: it holds
        return np.repeat(x, count, axis=0)
    while x.shape[0] < count:
        x = np.concatenate([x, reflect(x[-1], x[-2::-1], rotations)])
        if rotations:
            x = quat.make_continuous(x, axis=0)
    return x[:count]


def _pivots(x: np.ndarray, kernels: list[np.ndarray], which: np.ndarray, rotations: bool):
    """``(C, D)`` fitted end pose of each column of ``x`` (row 0 the end sample): column
    ``c`` fitted under ``kernels[which[c]]`` (-1: the end sample itself)."""
    longest = max((k.size for k in kernels), default=1)
    near = x[: min(longest, x.shape[0])]
    if rotations:  # the turns from the end sample, summed step by step: no wrap
        values = np.concatenate([np.zeros_like(near[:1, ..., :3]), quat.displacements(near)])
        np.cumsum(values, axis=0, out=values)
    else:
        values = near - near[:1]
    base = np.zeros((near.shape[0], which.size))
    for m in np.unique(which[which >= 0]).tolist():  # one weight vector per kernel used
        h = end_weights(kernels[m][: near.shape[0]])
        base[: h.size, which == m] = h[:, None]
    offset = np.einsum("ic,icd->cd", base, values)
    if rotations:
        return quat.multiply(near[0], quat.exp(offset))
    return near[0] + offset


def reflected_displacements(
    x: np.ndarray, kernels: list[np.ndarray], which: np.ndarray, count: int, rotations: bool
) -> np.ndarray:
    """``(count, C, D')`` displacements at positions ``-count .. -1`` before row 0 of
    ``x`` ``(F, C, D)``: those of the signal continued by its point reflection about the
    fitted end pose of each column (module docstring), column ``c`` fitted under
    ``kernels[which[c]]`` (-1: reflected about its end sample). Reverse ``x`` (and negate
    the result, reversed) for the other end."""
    if count == 0:
        return np.zeros((0, *x.shape[1:-1], 3 if rotations else x.shape[-1]))
    pivot = _pivots(x, kernels, which, rotations)
    beyond = _from_end(x, count + 1, rotations)[1:][::-1]  # samples count .. 1
    virtual = reflect(pivot, beyond, rotations)
    if rotations:
        chain = quat.make_continuous(np.concatenate([virtual, x[:1]]), axis=0)
        return quat.displacements(chain)
    return np.diff(np.concatenate([virtual, x[:1]]), axis=0)


class Padded:
    """Rows of displacements ``(n, C, D)`` (an array, or rows computed when sliced) with
    ``before`` rows ahead and ``after`` rows behind them: row ``r`` of the padded signal
    is position ``r - len(before)`` of the displacements."""

    def __init__(self, inside, before: np.ndarray, after: np.ndarray):
        self.inside, self.before, self.after = inside, before, after
        self.lead = before.shape[0]
        self.shape = (self.lead + inside.shape[0] + after.shape[0], *inside.shape[1:])

    def __getitem__(self, rows: slice) -> np.ndarray:
        start, stop, _ = rows.indices(self.shape[0])
        n = self.inside.shape[0]
        a, b = start - self.lead, max(start, stop) - self.lead  # in the inside's positions
        parts = [
            self.before[max(a + self.lead, 0) : max(min(b, 0) + self.lead, 0)],
            self.inside[max(a, 0) : max(min(b, n), 0)] if b > 0 and a < n else None,
            self.after[max(a - n, 0) : max(b - n, 0)],
        ]
        return np.concatenate([p for p in parts if p is not None and p.shape[0]] or [parts[0]])
