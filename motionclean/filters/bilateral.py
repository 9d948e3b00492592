"""Bilateral orientation filter (paper 002) and its vector counterpart.

Each sample ``i`` gets its own mask over the offsets ``r = -k .. k`` (002 Eq. 4-5,
Algorithm 1, with SQUARED distances as in the linear bilateral filter):

    W(i, r) = exp(-r^2 / 2 sigma_t^2) exp(-d(i, i+r)^2 / 2 sigma_g^2),
    a_r^(i) = W(i, r) / sum_r' W(i, r'),

turned into displacement coefficients ``b_m^(i)`` by 002 Eq. 3 (= 000 Eq. 20) and applied
as in 000 Eq. 19: ``H(q_i) = q_i exp(sum_{m=-k}^{k-1} b_m^(i) w_{i+m})``.

Distance. ``d(i, j) = |log(q_i^-1 q_j)|`` (002 Eq. 5) in the papers' log units, i.e. HALF
the rotation angle in radians, taken sign-independently: ``d = arccos |q_i . q_j|`` in
``[0, pi/2]`` (the scalar part of ``q_i^-1 q_j`` is the 4-D dot product, and ``q`` and
``-q`` are the same rotation). This is the geodesic distance of SO(3) over two; it is
invariant under ``q -> a q b`` (left and right products are isometries of R^4), which gives
002 Prop. 1, and it needs one dot product per pair instead of a product and a log. Its
square is accurate to ~1e-16 near zero (``d^2 ~ 2 (1 - |c|)``). The band of distances is
symmetric, ``d(i, i-r) = d(i-r, i)``, so each offset ``r > 0`` is evaluated once and used
for both ``+r`` and ``-r`` (the band matrix of 002 Fig. 1).

Boundaries. Displacements beyond the ends are mirrored by 000 Eq. 26 exactly as in
:func:`motionclean.filters.lee_shin`. The neighbours ``q_{i+r}`` beyond the ends are the
samples of the signal those mirrored displacements describe: ``q_{-j} = q_{-j+1}
exp(w_{-j})^-1`` and ``q_{n-1+j} = q_{n-2+j} exp(w_{n-2+j})``, cumulated outward from the
first and last sample (``exp(w_m)`` is ``q_m^-1 q_{m+1}`` itself, so no exp is needed).
Inside the clip these products reproduce the actual samples, so ``d(i, i+r)`` always
measures the same path that the filter's displacements ``w`` describe. Consequences: a
constant-angular-velocity signal extends to the same signal, its weights are symmetric in
``r`` for every sample, ``sum_m b_m^(i) = sum_r r a_r^(i) = 0``, and it is a fixed point,
first and last frames included. ``sigma_g = inf`` gives the Lee-Shin filter of
``masks.gaussian(sigma_t, radius)`` exactly.

Positions use ``d(i, j) = |p_j - p_i|`` (``sigma_p`` in the file's length unit), linear
displacements mirrored by the same rule and ``p_i + sum_m b_m^(i) (p_{i+m+1} - p_{i+m})``.

Arrays are time-major, ``(F, ..., 4)`` or ``(F, ..., 3)``; all trailing axes are filtered at
once, the only Python loops run over blocks of frames, window offsets and passes.

Implementation: like :func:`motionclean.filters.lee_shin`, a pass runs over blocks of about
``quat.BLOCK_SAMPLES`` samples on contiguous component planes of one reused work area of
about ``(17 + k) x quat.BLOCK_SAMPLES`` doubles (the plane kernels of :mod:`motionclean.core.quat`):
per block the samples, the relative rotations and their logs, the weights of the offsets
``r = 1 .. k``, the weighted sums, ``exp`` and the product. Memory is the result (plus a
second buffer when iterating) and the work stays in cache; a pass costs about 1.5-2 Lee-Shin
passes with the same window (``python bench/bilateral.py``).
"""

from __future__ import annotations

import math

import numpy as np

from ..core import checks, quat
from .linear import (
    check_iterations,
    continuity_signs,
    fill_mirrored_ends,
    mirror_position,
    run_passes,
    work_area,
)
from .masks import NARROWEST

__all__ = ["bilateral", "bilateral_positions", "window_radius"]


#: Widest window half-width in frames: the work area holds ``17 + k`` planes per block.
MAX_RADIUS = 3000


def window_radius(sigma_t: float, radius: int | None = None) -> int:
    """Validated half-width ``k`` of the window: ``radius`` or ``ceil(3 sigma_t)`` frames, at
    most :data:`MAX_RADIUS`."""
    sigma_t = checks.number(sigma_t, "sigma_t")
    if not (math.isfinite(sigma_t) and sigma_t > 0):
        raise ValueError(f"sigma_t must be a positive number of frames, got {sigma_t}")
    if radius is None:
        if 3.0 * sigma_t > MAX_RADIUS:
            raise ValueError(
                f"sigma_t must be at most {MAX_RADIUS // 3} frames (window half-width "
                f"{MAX_RADIUS}), got {sigma_t:g}"
            )
        return math.ceil(3.0 * sigma_t)
    return checks.whole(radius, "radius", 0, MAX_RADIUS)


#: A range width (sigma_g, log units; sigma_p, length units) below this weighs as this one
#: does: only identical samples count, every other weight is exp(-huge) = 0 (its square
#: would underflow to 0 and divide by zero; a finite factor keeps a distance of 0 at weight
#: 1, where inf would make 0 * inf).
SMALLEST_RANGE_WIDTH = 1e-150


def _half_inverse_square(width: float) -> float:
    """``1 / (2 width^2)`` of a range width: 0 where the square would overflow (no range
    weighting, as ``inf``), that of :data:`SMALLEST_RANGE_WIDTH` below it."""
    width = max(width, SMALLEST_RANGE_WIDTH)
    return 0.5 / width / width


def _check_sigma(name: str, value: float) -> float:
    value = checks.number(value, name)
    if not value > 0:  # also rejects nan; inf means "no range weighting"
        raise ValueError(f"{name} must be positive (inf disables range weighting), got {value}")
    return value


def _weighted_sums(weights, disp, out, tail, head, tmp) -> None:
    """``out_i = sum_m b_m^(i) disp_{i+m}`` for a block of ``L`` samples (time on axis 1).

    ``weights[r-1, t] = W(f0-k+t, r)`` for ``t = 0 .. L+k-1`` (so ``W(i, -r) = W(i-r, r)``
    is read from the same rows) and ``disp[:, t]`` is the displacement at position
    ``f0-k+t``. Un-normalised weights are summed into the Eq. 20 coefficients
    (``B_m = sum_{j>m} W_j``, ``B_m = -sum_{j<=m} W_j``) and the total divided by ``sum_r
    W(i, r)`` once, which is Eq. 20 applied to the normalised mask. ``tail`` and ``head``
    are ``(L, ...)`` scratch, ``tmp`` is shaped like ``out``.
    """
    k = weights.shape[0]
    n_out = out.shape[1]
    for m in range(k - 1, -1, -1):  # B_m = sum_{j=m+1}^{k} W_j, m = k-1 .. 0
        w_next = weights[m, k : k + n_out]  # W(i, m+1)
        src = disp[:, k + m : k + m + n_out]
        if m == k - 1:
            np.copyto(tail, w_next)
            np.multiply(src, tail, out)
        else:
            tail += w_next
            np.multiply(src, tail, tmp)
            out += tmp
    for m in range(-k, 0):  # B_m = -sum_{j=-k}^{m} W_j, m = -k .. -1
        w_here = weights[-m - 1, k + m : k + m + n_out]  # W(i, m) = W(i+m, -m)
        if m == -k:
            np.copyto(head, w_here)
        else:
            head += w_here
        np.multiply(disp[:, k + m : k + m + n_out], head, tmp)
        out -= tmp
    head += tail
    head += 1.0  # W(i, 0) = 1
    out /= head


def _window_samples(src, qs, rel, scratch, base: int, lo: int, hi: int, end: int) -> None:
    """Fill a block's window: samples ``qs`` at positions ``base .. end-1`` and the relative
    rotations ``rel = q_m^-1 q_{m+1}`` (planes ``[w, *displacement slots]``) inside it.

    Samples ``lo .. hi`` lie inside the signal ``src``; those beyond its ends are cumulated
    outward from the mirrored relative rotations (000 Eq. 26, see the module docstring).
    """
    n_frames = src.shape[0]
    n = n_frames - 1
    np.copyto(qs[:, lo - base : hi + 1 - base], src[lo : hi + 1].transpose(2, 0, 1))
    inside = rel[:, lo - base : hi - base]
    quat.multiply_planes(
        inside,
        qs[:, lo - base : hi - base],
        qs[:, lo + 1 - base : hi + 1 - base],
        scratch[:2, : hi - lo],
        True,
    )
    tmp = scratch[:2, 0]
    for pos in range(-1, base - 1, -1):  # loop over window offsets only
        inv = rel[:, mirror_position(pos, n) - base] * [[1.0], [-1.0], [-1.0], [-1.0]]
        quat.multiply_planes(qs[:, pos - base], qs[:, pos + 1 - base], inv, tmp)
    for pos in range(n_frames, end):
        step = rel[:, mirror_position(pos - 1, n) - base].copy()
        quat.multiply_planes(qs[:, pos - base], qs[:, pos - 1 - base], step, tmp)


def _time_term(r: int, sigma_t: float) -> float:
    """``r^2 / 2 sigma_t^2``, infinite (a zero weight) for a sigma_t so small that it is
    (where ``sigma_t**2`` would underflow to 0 and the division fail)."""
    return r * r / (2.0 * sigma_t**2) if sigma_t >= NARROWEST else math.inf


def _range_weights(qs, weights, dot, sigma_t: float, inv_g: float) -> None:
    """``weights[r-1, t] = W(base+t, r) = exp(-r^2 / 2 sigma_t^2 - arccos(|q . q_{+r}|)^2
    inv_g)`` for ``r = 1 .. k`` and every row ``t`` of ``weights`` (002 Eq. 4-5);
    ``inv_g = 1 / (2 sigma_g^2)``, ``dot`` one scratch row."""
    rows = weights.shape[1]
    for r in range(1, weights.shape[0] + 1):
        x = weights[r - 1]
        np.multiply(qs[0, :rows], qs[0, r : r + rows], x)
        for c in range(1, 4):
            np.multiply(qs[c, :rows], qs[c, r : r + rows], dot)
            x += dot
        np.abs(x, out=x)
        np.minimum(x, 1.0, out=x)
        np.arccos(x, out=x)
        np.square(x, out=x)
        x *= -inv_g
        x -= _time_term(r, sigma_t)
        np.exp(x, out=x)


def _bilateral_pass(src, dst, k: int, sigma_t: float, sigma_g: float) -> None:
    """One pass of 002 Algorithm 1 from ``src`` to ``dst``, both ``(F, M, 4)``, ``F >= 2``.

    Each block of output frames ``f0 .. f1-1`` needs the samples at positions ``f0-k ..
    f1-1+k`` and the displacements at ``f0-k .. f1+k-2``: those inside the signal are
    computed from the block's samples, the rest extended by Eq. 26 (see the module
    docstring). Relative rotations take the shorter arc, so the displacements are those of
    the sign-continuous signal ``sigma_i q_i`` (000 Sec. VI-A), ``d`` is sign independent,
    and the output is ``sigma_i q_i exp(s_i)``: the filter of the sign-continuous input.
    """
    n_frames = src.shape[0]
    n = n_frames - 1  # displacements
    inv_g = _half_inverse_square(sigma_g)
    # Work planes: 0-3 samples, 4 w of q_i^-1 q_{i+1}, 5-7 displacements, 8-10 scratch,
    # 11-13 the sums s_i (then the vector part of exp(s_i)), 14 the w of exp(s_i),
    # 15-16 the running coefficient sums, 17.. the weights of the offsets 1 .. k.
    blocks, planes = work_area(n_frames, src.shape[1], k, 17 + k)
    carry = None
    for f0, f1 in blocks:
        length = f1 - f0
        base = f0 - k  # position of the first sample and displacement in the window
        lo, hi = max(base, 0), min(f1 + k - 1, n)  # samples lo .. hi lie inside the signal
        qs = planes(0, 4, length + 2 * k)
        rel = planes(4, 4, length + 2 * k - 1)  # [w, *displacements]
        scratch = planes(8, 3, length + 2 * k)
        _window_samples(src, qs, rel, scratch, base, lo, hi, f1 + k)
        weights = planes(17, k, length + k)
        _range_weights(qs, weights, scratch[0, : length + k], sigma_t, inv_g)

        # w_i = log(+-q_i^-1 q_{i+1}), in place, then Eq. 26 beyond the ends.
        inside = rel[:, lo - base : hi - base]
        quat.log_planes(inside[1:], inside, scratch[:2, : hi - lo], shortest=True)
        disp = rel[1:]
        fill_mirrored_ends(disp, base, lo, hi, n)
        signs, carry = continuity_signs(rel[0, k : min(k + length, hi - base)], length, carry)

        sums = planes(11, 3, length)
        tail, head = planes(15, 2, length)
        _weighted_sums(weights, disp, sums, tail, head, scratch[:, :length])
        e = [planes(14, 1, length)[0], *sums]  # exp(s) in place of s
        quat.exp_planes(e, sums, scratch[:, :length])
        if signs is not None:
            for plane in e:
                plane *= signs
        body = qs[:, k : k + length]
        quat.multiply_planes([dst[f0:f1, :, c] for c in range(4)], body, e, scratch[:2, :length])


def _bilateral_positions_pass(src, dst, k: int, sigma_t: float, sigma_p: float) -> None:
    """One pass of the vector bilateral filter from ``src`` to ``dst``, both ``(F, M, 3)``.

    Blocked as :func:`_bilateral_pass`; samples beyond the ends are ``p_{-j} = p_{-j+1} -
    d_{-j}`` and ``p_{n-1+j} = p_{n-2+j} + d_{n-2+j}`` with the displacements mirrored by
    000 Eq. 26.
    """
    n_frames, n_sig = src.shape[:2]
    n = n_frames - 1
    inv_p = _half_inverse_square(sigma_p)
    # Work planes: 0-2 samples, 3-5 displacements, 6-8 scratch, 9-11 sums, 12-13 the
    # running coefficient sums, 14.. the weights of the offsets 1 .. k.
    blocks, planes = work_area(n_frames, n_sig, k, 14 + k)
    for f0, f1 in blocks:
        length = f1 - f0
        base = f0 - k
        lo, hi = max(base, 0), min(f1 + k - 1, n)
        ps = planes(0, 3, length + 2 * k)
        np.copyto(ps[:, lo - base : hi + 1 - base], src[lo : hi + 1].transpose(2, 0, 1))
        disp = planes(3, 3, length + 2 * k - 1)
        np.subtract(
            ps[:, lo + 1 - base : hi + 1 - base],
            ps[:, lo - base : hi - base],
            disp[:, lo - base : hi - base],
        )
        fill_mirrored_ends(disp, base, lo, hi, n)
        for pos in range(-1, base - 1, -1):  # loop over window offsets only
            np.subtract(ps[:, pos + 1 - base], disp[:, pos - base], ps[:, pos - base])
        for pos in range(n_frames, f1 + k):
            np.add(ps[:, pos - 1 - base], disp[:, pos - 1 - base], ps[:, pos - base])

        rows = length + k
        weights = planes(14, k, rows)
        scratch = planes(6, 3, length + 2 * k)
        diff = scratch[0, :rows]
        for r in range(1, k + 1):
            x = weights[r - 1]
            for c in range(3):
                np.subtract(ps[c, r : r + rows], ps[c, :rows], diff)
                if c:
                    np.square(diff, out=diff)
                    x += diff
                else:
                    np.square(diff, out=x)
            x *= -inv_p
            x -= _time_term(r, sigma_t)
            np.exp(x, out=x)

        sums = planes(9, 3, length)
        tail, head = planes(12, 2, length)
        _weighted_sums(weights, disp, sums, tail, head, scratch[:, :length])
        for c in range(3):
            np.add(ps[c, k : k + length], sums[c], dst[f0:f1, :, c])


def bilateral(
    q: np.ndarray,
    sigma_t: float,
    sigma_g: float,
    radius: int | None = None,
    iterations: int = 1,
) -> np.ndarray:
    """Bilateral orientation filter of 002 (Eq. 2-5, Algorithm 1), ``iterations`` passes.

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions ``(w, x, y, z)``, time along axis 0. Made sign-continuous before
        every pass (000 Sec. VI-A).
    sigma_t : float
        Temporal standard deviation, in frames (> 0).
    sigma_g : float
        Range standard deviation in log units (``|log q|`` = half the rotation angle, rad;
        > 0). Neighbours further than ~``2 sigma_g`` from sample ``i`` barely count, which
        keeps fast genuine turns; ``inf`` reduces to the Gaussian Lee-Shin filter.
    radius : int, optional
        Window half-width ``k`` in frames; default ``ceil(3 sigma_t)``.
    iterations : int
        Number of passes (the weights are recomputed from each pass's output).

    Returns
    -------
    (F, ..., 4) array
        Filtered unit quaternions. Coordinate invariant on both sides (002 Prop. 1), time
        invariant away from the ends (Prop. 2); constant angular velocity is a fixed point.
    """
    k = window_radius(sigma_t, radius)
    sigma_g = _check_sigma("sigma_g", sigma_g)
    iterations = check_iterations(iterations)
    q = checks.unit_quaternions(q)
    if q.shape[0] < 2 or k == 0 or iterations == 0 or q.size == 0:
        return quat.make_continuous(q, axis=0)
    return run_passes(
        lambda src, dst: _bilateral_pass(src, dst, k, sigma_t, sigma_g), q, iterations
    )


def bilateral_positions(
    p: np.ndarray,
    sigma_t: float,
    sigma_p: float,
    radius: int | None = None,
    iterations: int = 1,
) -> np.ndarray:
    """Vector counterpart of :func:`bilateral` on ``(F, ..., 3)`` positions (002 Eq. 4).

    ``d(i, j) = |p_j - p_i|`` with ``sigma_p`` in the data's length unit (> 0, ``inf`` gives
    the Gaussian mask); ``sigma_t``, ``radius`` and ``iterations`` as in :func:`bilateral`.
    In the interior this is the classical bilateral filter of 002 Eq. 4; at the ends the
    neighbours are extended from displacements mirrored by 000 Eq. 26, so constant
    velocity is a fixed point.
    """
    k = window_radius(sigma_t, radius)
    sigma_p = _check_sigma("sigma_p", sigma_p)
    iterations = check_iterations(iterations)
    p = checks.vectors(p)
    if p.shape[0] < 2 or k == 0 or iterations == 0 or p.size == 0:
        return p.copy()
    return run_passes(
        lambda src, dst: _bilateral_positions_pass(src, dst, k, sigma_t, sigma_p), p, iterations
    )
