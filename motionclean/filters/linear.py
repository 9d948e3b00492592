"""Lee-Shin orientation filters: any mask as a coordinate-invariant orientation filter.

Paper 000 (Lee & Shin 2002). For a mask ``(a_-k .. a_k)`` summing to one,

    H(q_i) = q_i exp( sum_{m=-k}^{k-1} b_m w_{i+m} ),   w_i = log(q_i^-1 q_{i+1})   (Eq. 19)

with ``b_m`` the partial sums of Eq. 20. Displacements beyond the ends are mirrored as in
Eq. 26. The vector counterpart uses linear displacements ``d_i = p_{i+1} - p_i`` and is
ordinary convolution with the mask in the interior.

Arrays are time-major: ``(F, ..., 4)`` quaternions ``(w, x, y, z)`` or ``(F, ..., 3)``
vectors; every trailing axis (joints, ...) is filtered at once.

Implementation: a pass costs one logarithm and one exponential per sample (Sec. VII-D),
fused with the two quaternion products. It runs over blocks of frames on component planes
(:func:`motionclean.core.quat.log_planes`, ...) in one reused work area of about 15 x
``quat.BLOCK_SAMPLES`` doubles, so memory is the result (plus a second buffer when
iterating) and the work stays in cache; only displacements beyond the two ends are
mirrored (copied). Cut at steps too large for motion (:func:`lee_shin_between`), the
frames beside a cut are summed again over their mirrored windows: one displacement per
sample of the columns with cuts more.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from ..core import checks, quat
from ..core.jumps import jump_steps
from .masks import validate_mask

__all__ = [
    "Rows",
    "apply_displacement_sums",
    "check_iterations",
    "continuity_signs",
    "displacement_coefficients",
    "fill_mirrored_ends",
    "frame_blocks",
    "lee_shin",
    "lee_shin_positions",
    "mirror_indices",
    "mirror_position",
    "mirrored_displacements",
    "row_span",
    "run_passes",
    "take_rows",
    "work_area",
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


def mirror_position(positions, n):
    """Index in ``0 .. n-1`` of the displacement that 000 Eq. 26 puts at each position
    (an int or an int array) of a signal of ``n`` displacements (an int, or an int array
    broadcasting with ``positions``: each position's own signal; ``n >= 1``)."""
    period = np.maximum(2 * (np.asarray(n) - 1), 1)
    j = np.mod(positions, period)
    return np.where(j > n - 1, period - j, j)


def mirror_indices(n: int, before: int, after: int) -> np.ndarray:
    """Indices into ``n`` displacements for positions ``-before .. n-1+after`` (000 Eq. 26).

    ``w_i = w_{-i}`` for ``i < 0`` and ``w_i = w_{2n-i-2}`` for ``i >= n``: reflection about
    the first and the last displacement, repeated as often as a short signal needs.
    """
    return mirror_position(np.arange(-before, n + after), n)


class Rows(Protocol):
    """A signal sliced by rows: an array, or rows computed when sliced."""

    @property
    def shape(self) -> tuple[int, ...]: ...

    def __getitem__(self, rows: slice, /) -> np.ndarray: ...


def take_rows(signal: Rows, index: np.ndarray) -> np.ndarray:
    """``signal[index]`` for an array of row numbers, asking ``signal`` (an array, or rows
    computed when sliced such as :class:`motionclean.core.quat.Displacements`) only for the
    span of rows the index covers."""
    low, high = row_span(index)
    return signal[low:high][index - low]


def row_span(index: np.ndarray) -> tuple[int, int]:
    """``(low, high)``: the rows ``index`` (a non-empty array of row numbers) spans."""
    return int(index.min()), int(index.max()) + 1


def mirrored_displacements(w: np.ndarray, before: int, after: int) -> np.ndarray:
    """Displacements extended by Eq. 26 of 000 to positions ``-before .. n-1+after``."""
    return w[mirror_indices(w.shape[0], before, after)]


def apply_displacement_sums(q: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``q_i exp(s_i)``: move each sample by a tangent vector measured in its own frame."""
    return quat.multiply(q, quat.exp(s))


def _window_sums(ext: np.ndarray, b: np.ndarray, out: np.ndarray, tmp: np.ndarray) -> None:
    """``out[:, r] = sum_t b_t ext[:, r + t]`` (Eq. 19's sum; time is axis 1).

    ``ext`` holds the displacements at positions ``i - k .. i + k - 1 + L - 1`` for the
    ``L = out.shape[1]`` outputs; ``tmp`` is scratch shaped like ``out``.
    """
    n_out = out.shape[1]
    first = True
    for tap, coeff in enumerate(b):  # loop over mask taps only
        if coeff == 0.0:
            continue
        src = ext[:, tap : tap + n_out]
        if first:
            np.multiply(src, coeff, out)
            first = False
        else:
            np.multiply(src, coeff, tmp)
            np.add(out, tmp, out)
    if first:
        out[...] = 0.0


def fill_mirrored_ends(ext: np.ndarray, start: int, lo: int, hi: int, n: int) -> None:
    """Fill the positions of ``ext`` (axis 1, first position ``start``) outside ``lo .. hi-1``.

    ``ext`` is a window of the displacement positions of a signal of ``n`` displacements
    and already holds displacements ``lo .. hi-1``; the others are copied by 000 Eq. 26
    from inside the window.
    """
    for first, last in ((start, lo), (hi, start + ext.shape[1])):
        if last > first:
            src = mirror_position(np.arange(first, last), n)
            ext[:, first - start : last - start] = ext[:, src - start]


def frame_blocks(n_frames: int, rows: int) -> list[tuple[int, int]]:
    """Split frames ``0 .. n_frames-1`` into near-equal half-open runs ``(f0, f1)`` of
    about ``rows`` frames (at least one run)."""
    count = max(1, -(-n_frames // rows))
    edges = np.linspace(0, n_frames, count + 1).round().astype(int)
    return list(zip(edges[:-1].tolist(), edges[1:].tolist(), strict=True))


def work_area(n_frames: int, n_sig: int, k: int, n_planes: int):
    """Blocks of frames and a reused work area for one blocked pass of a windowed filter.

    A pass over ``(F, M, ...)`` signals (``F = n_frames``, ``M = n_sig``) with a window
    of ``k`` frames on each side works through :func:`frame_blocks` of about
    ``quat.BLOCK_SAMPLES`` samples each. With several blocks each has at least ``2k + 2``
    frames, so the displacements mirrored by Eq. 26 come from inside the block's own
    window (:func:`fill_mirrored_ends`); one block covers the whole signal. Returns the
    blocks and ``planes(first, count, length)``: ``count`` planes of the work area from
    plane ``first`` on, each viewed as ``(length, M)``, for any ``length`` up to the
    longest block plus ``2k``. The area holds ``n_planes`` planes.
    """
    blocks = frame_blocks(n_frames, max(quat.BLOCK_SAMPLES // n_sig, 4 * k + 4))
    span = max(f1 - f0 for f0, f1 in blocks) + 2 * k  # longest window, in frames
    work = np.empty((n_planes, span * n_sig))

    def planes(first: int, count: int, length: int) -> np.ndarray:
        return work[first : first + count, : length * n_sig].reshape(count, length, n_sig)

    return blocks, planes


def continuity_signs(dots: np.ndarray, length: int, carry):
    """Signs ``sigma_i`` making a block's samples sign-continuous (000 Sec. VI-A).

    ``sigma_{i+1} = sigma_i sign(q_i . q_{i+1})``. ``dots`` holds the scalar parts of
    ``q_i^-1 q_{i+1}`` (the 4-D dot products) for the block's steps ``f0 -> f0+1, ...``
    (``length`` of them, one fewer in the last block), shape ``(steps, M)``, and ``carry``
    the sign at ``f0`` (``None``: +1). Returns the ``(length, M)`` signs (``None`` when all
    are +1) and the carry for the next block.
    """
    flips = np.signbit(dots)
    if carry is None and not flips.any():
        return None, None
    step = np.where(flips, -1.0, 1.0)
    signs = np.empty((length, *dots.shape[1:]))
    signs[0] = 1.0 if carry is None else carry
    np.cumprod(step[: length - 1], axis=0, out=signs[1:])
    signs[1:] *= signs[0]
    carry = signs[-1] * step[-1] if step.shape[0] == length else None
    if carry is not None and np.all(carry > 0.0):
        carry = None
    return signs, carry


#: Most passes a filter accepts (more would only run for hours).
MAX_ITERATIONS = 10_000


def check_iterations(iterations) -> int:
    """``iterations`` as an int in ``[0, MAX_ITERATIONS]``; TypeError / ValueError otherwise."""
    return checks.whole(iterations, "iterations", 0, MAX_ITERATIONS)


def run_passes(one_pass, x: np.ndarray, iterations: int) -> np.ndarray:
    """Apply ``one_pass(src, dst)`` ``iterations >= 1`` times to ``x`` (F, ..., n).

    Each pass reads ``src`` and writes ``dst``, both ``(F, M, n)`` (the trailing axes
    flattened); the passes ping-pong between two output buffers, so ``x`` is never
    written. Returns the last output, shaped like ``x``.
    """
    cur = np.ascontiguousarray(x).reshape(x.shape[0], -1, x.shape[-1])
    buffers = [np.empty(cur.shape) for _ in range(min(iterations, 2))]
    for n in range(iterations):
        one_pass(cur, buffers[n % 2])
        cur = buffers[n % 2]
    return cur.reshape(x.shape)


def folded_taps(b: np.ndarray, n: int) -> tuple[np.ndarray, int]:
    """Displacement coefficients ``b`` ``(2k,)`` for a signal of ``n`` displacements, and
    how many of them lie before each frame's own position (``k``). A mask longer than the
    signal's mirrored period ``P = 2 (n - 1)`` (Eq. 26 repeats the displacements with that
    period) is folded onto ``P`` taps, each the sum of the taps a whole number of periods
    apart: the same sums (up to rounding), at a cost that follows the clip's length, not
    the mask's (``k = 5000`` on 1,000 frames had cost five times the clip's own width)."""
    k = b.size // 2
    period = max(2 * (n - 1), 1)
    if b.size <= period:
        return b, k
    before = k % period
    offsets = (np.arange(b.size) - k + before) % period
    return np.bincount(offsets, weights=b, minlength=period), before


def _lee_shin_pass(src: np.ndarray, dst: np.ndarray, b: np.ndarray) -> None:
    """One pass of Eq. 19 from ``src`` to ``dst``, both ``(F, M, 4)`` with ``F >= 2``.

    Each block of output frames ``f0 .. f1-1`` needs the displacements at positions
    ``f0-k .. f1+k-2``: those inside ``0 .. F-2`` are computed from the block's samples,
    the rest mirrored (Eq. 26). Displacements take the shorter arc (``log(+-q_i^-1
    q_{i+1})``), which are those of the sign-continuous signal ``sigma_i q_i`` with
    ``sigma_{i+1} = sigma_i sign(q_i . q_{i+1})`` (000 Sec. VI-A), and the output is
    ``sigma_i q_i exp(s_i)``: the filter of the sign-continuous input.
    """
    n_frames, n_sig = src.shape[:2]
    n = n_frames - 1  # displacements
    b, k = folded_taps(b, n)  # k: the taps before each frame's own position
    # Work planes: 0-3 samples, 4-6 displacement window, 7 w of q_i^-1 q_{i+1}, 8-10
    # scratch, 11-13 the sums s_i (then the vector part of exp(s_i)), 14 the w of exp(s_i).
    blocks, planes = work_area(n_frames, n_sig, -(-b.size // 2), 15)
    sigma = None  # sign of the continuous signal at the block's first frame, if any is -1
    for f0, f1 in blocks:
        length = f1 - f0
        start, stop = f0 - k, f1 - k + b.size - 1  # displacement positions the block needs
        lo, hi = max(start, 0), min(stop, n)  # ... of which these lie inside the signal
        qc = planes(0, 4, hi + 1 - lo)  # samples lo .. hi, component planes
        np.copyto(qc, src[lo : hi + 1].transpose(2, 0, 1))
        ext = planes(4, 3, stop - start)
        inside = ext[:, lo - start : hi - start]
        rel_w = planes(7, 1, hi - lo)[0]
        scratch = planes(8, 2, hi - lo)
        # w_i = log(+-q_i^-1 q_{i+1}), written straight into the block's displacement window.
        quat.multiply_planes([rel_w, *inside], qc[:, :-1], qc[:, 1:], scratch, True)
        quat.log_planes(inside, [rel_w, *inside], scratch, shortest=True)
        fill_mirrored_ends(ext, start, lo, hi, n)
        # Steps f0 -> f0+1, ..., (f1-1) -> f1 (one fewer in the last block).
        signs, sigma = continuity_signs(rel_w[f0 - lo : f1 - lo], length, sigma)

        sums = planes(11, 3, length)
        scratch = planes(8, 3, length)
        _window_sums(ext, b, sums, scratch)
        e = [planes(14, 1, length)[0], *sums]  # exp(s) in place of s
        quat.exp_planes(e, sums, scratch)
        if signs is not None:
            for plane in e:
                plane *= signs
        body = qc[:, f0 - lo : f1 - lo]
        quat.multiply_planes([dst[f0:f1, :, c] for c in range(4)], body, e, scratch[:2])


def lee_shin(
    q: np.ndarray, mask, iterations: int = 1, cut_above: float | None = None
) -> np.ndarray:
    """Apply the orientation filter of ``mask`` ``iterations`` times (000 Eq. 19-20, 26).

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions ``(w, x, y, z)``, time along axis 0. Signs are made continuous
        first (000 Sec. VI-A), so antipodal flips in the input do not matter.
    mask : sequence of float
        Odd-length mask summing to one, e.g. :func:`masks.binomial` ``(2)``.
    iterations : int
        Number of passes (a non-negative whole number).
    cut_above : float, optional
        Radians of rotation: a signal is cut at every step between two frames that turns
        by more than this (a half-turn flip, a glitch: no motion), and each stretch between
        cuts is filtered as a signal of its own, its ends mirrored by Eq. 26 (a stretch of
        one frame is kept), so a flip stays a flip instead of becoming a fast turn. None,
        or pi and above (no step turns further): 000's filter as printed.

    Returns
    -------
    (F, ..., 4) array
        Filtered unit quaternions, signs following the sign-continuous input. Coordinate
        invariant on both sides (Prop. 1), time invariant (Prop. 2) and symmetric for
        symmetric masks (Prop. 3), with or without cuts (a step's angle is invariant).
    """
    b = displacement_coefficients(mask)
    iterations = check_iterations(iterations)
    q = checks.unit_quaternions(q)
    if cut_above is not None:
        cut_above = checks.number(cut_above, "cut_above")
        if not cut_above > 0:
            raise ValueError(f"cut_above must be an angle in radians above 0, got {cut_above}")
    if q.shape[0] < 2 or b.size == 0 or iterations == 0 or q.size == 0:
        return quat.make_continuous(q, axis=0)

    if cut_above is None or cut_above >= math.pi:
        return run_passes(lambda src, dst: _lee_shin_pass(src, dst, b), q, iterations)
    q = quat.continuous(q)  # (no copy when it is)
    return lee_shin_between(q, b, jump_steps(q, math.degrees(cut_above)), iterations)


#: Frames whose samples beside a cut are summed again at a time (with a halo of ``2k``).
_STRETCH_FRAMES = 4096


def lee_shin_between(q: np.ndarray, b: np.ndarray, cuts: np.ndarray, iterations: int = 1):
    """:func:`lee_shin` (displacement coefficients ``b``, :func:`displacement_coefficients`)
    of each stretch of the sign-continuous ``q`` ``(F, ..., 4)`` between the steps ``cuts``
    ``(F-1, ...)`` as a signal of its own: a frame's window reads only its stretch's
    displacements, mirrored at the stretch's ends by Eq. 26 (a stretch of one frame is
    kept). Each pass is the plain pass, then the samples whose window reaches past their
    stretch's ends (within ``k`` frames of a cut) are summed again over their mirrored
    window, tap by tap, a block of frames at a time: memory is about two copies of the
    columns with cuts beyond the plain filter's. Signs follow ``q``'s."""
    shape = q.shape
    flat = q.reshape(shape[0], -1, 4)
    cuts = cuts.reshape(max(shape[0] - 1, 0), -1)
    cut = cuts.any(axis=0)

    def plain(x: np.ndarray, passes: int) -> np.ndarray:
        return run_passes(lambda src, dst: _lee_shin_pass(src, dst, b), x, passes)

    if not cut.any() or not b.size:
        return plain(q, iterations)
    every = bool(cut.all())
    columns = np.flatnonzero(cut)
    out = None if every else plain(q, iterations)
    source = flat if every else np.ascontiguousarray(flat[:, columns])
    first, count = _stretches(cuts if every else cuts[:, columns])
    x = source
    for _ in range(iterations):
        x = _mend_stretch_ends(plain(x, 1), x, b, first, count)
    x *= np.where(np.einsum("fcj,fcj->fc", x, source) < 0.0, -1.0, 1.0)[..., None]
    if out is None:
        return x.reshape(shape)
    out.reshape(shape[0], -1, 4)[:, columns] = x
    return out


def _stretches(cuts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame and column of a signal cut at ``cuts`` ``(F-1, C)``: the first frame of
    its stretch and the stretch's displacements (its frames less one), ``(F, C)`` each."""
    n_frames = cuts.shape[0] + 1
    frames = np.arange(n_frames, dtype=np.int32)[:, None]
    first = np.maximum.accumulate(np.where(_padded(cuts, before=True), frames, 0), axis=0)
    last = np.minimum.accumulate(
        np.where(_padded(cuts, before=False), frames, n_frames)[::-1], axis=0
    )[::-1]
    return first, last - first


def _padded(cuts: np.ndarray, before: bool) -> np.ndarray:
    """``(F, C)``: the frames that start a stretch (``before``: 0 and the frame after each
    cut) or end one (the frame before each cut and the last)."""
    marks = np.ones((cuts.shape[0] + 1, cuts.shape[1]), dtype=bool)
    if before:
        marks[1:] = cuts
    else:
        marks[:-1] = cuts
    return marks


def _mend_stretch_ends(filtered, x, b, first, count) -> np.ndarray:
    """``filtered`` (the plain pass of ``x`` ``(F, C, 4)``), with the samples whose window
    reaches past their stretch's ends (``first`` frame and ``count`` displacements of each
    sample's stretch, ``(F, C)``) summed over their window mirrored there (Eq. 26), a
    block of frames at a time; a stretch of one frame is kept."""
    n_frames, k = x.shape[0], b.size // 2
    for f0 in range(0, n_frames, _STRETCH_FRAMES):
        f1 = min(f0 + _STRETCH_FRAMES, n_frames)
        a, n = first[f0:f1], count[f0:f1]
        place = np.arange(f0, f1, dtype=np.int32)[:, None] - a
        rows, cols = np.nonzero((place < k) | (place > n - k))
        if not rows.size:
            continue
        a, n = a[rows, cols], n[rows, cols]
        frames = rows + f0
        alone = n == 0  # reads nothing (the gather reads row 0 of the halo): kept
        lo, hi = max(f0 - 2 * k, 0), min(f1 + 2 * k, n_frames)  # every window's reach
        w = quat.log_shortest(quat.relative(x[lo : hi - 1], x[lo + 1 : hi]))
        start, span = np.where(alone, lo, a), np.maximum(n, 1)
        s = np.zeros((rows.size, 3))
        for m, weight in enumerate(b.tolist()):  # tap by tap, as the plain pass sums
            s += weight * w[start - lo + mirror_position(frames + (m - k) - start, span), cols]
        moved = apply_displacement_sums(x[frames, cols], s)
        moved[alone] = x[frames[alone], cols[alone]]
        filtered[frames, cols] = moved
    return filtered


def lee_shin_positions(p: np.ndarray, mask, iterations: int = 1) -> np.ndarray:
    """Vector counterpart of :func:`lee_shin` on ``(F, ..., D)`` vectors, time along axis
    0 (positions: ``D = 3``, in their own length unit; any width is filtered alike, each
    component on its own: quaternions given here by mistake are filtered as 4-vectors,
    not as rotations).

    ``p_i + sum_m b_m d_{i+m}`` with ``d_i = p_{i+1} - p_i`` mirrored by Eq. 26: plain
    convolution with the mask in the interior, the same boundary rule as orientations.
    Returns a new float64 array of the same shape; TypeError or ValueError for values
    that are no finite numbers, a bad mask or iterations.
    """
    b = displacement_coefficients(mask)
    iterations = check_iterations(iterations)
    out = checks.bounded(checks.as_float_array(p, "p"), "p").copy()  # any trailing width
    if out.shape[0] < 2 or b.size == 0:
        return out
    n = out.shape[0] - 1
    b, k = folded_taps(b, n)
    ext = np.empty((1, n + b.size, *out.shape[1:]))  # displacement positions -k .. n-1+2k-k
    sums = np.empty((1, *out.shape))
    tmp = np.empty_like(sums)
    for _ in range(iterations):
        np.subtract(out[1:], out[:-1], ext[0, k : k + n])
        fill_mirrored_ends(ext, -k, 0, n, n)
        _window_sums(ext, b, sums, tmp)
        out += sums[0]
    return out
