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
once, the only Python loops run over window offsets and passes.
"""

from __future__ import annotations

import math

import numpy as np

from .. import quat
from .linear import mirror_indices, mirrored_displacements

__all__ = ["bilateral", "bilateral_positions", "window_radius"]


def window_radius(sigma_t: float, radius: int | None = None) -> int:
    """Validated half-width ``k`` of the window: ``radius`` or ``ceil(3 sigma_t)`` frames."""
    if not (math.isfinite(sigma_t) and sigma_t > 0):
        raise ValueError(f"sigma_t must be a positive number of frames, got {sigma_t}")
    if radius is None:
        return math.ceil(3.0 * sigma_t)
    if int(radius) != radius or radius < 0:
        raise ValueError(f"radius must be a non-negative whole number of frames, got {radius}")
    return int(radius)


def _check_sigma(name: str, value: float) -> float:
    value = float(value)
    if not value > 0:  # also rejects nan; inf means "no range weighting"
        raise ValueError(f"{name} must be positive (inf disables range weighting), got {value}")
    return value


def _check_iterations(iterations: int) -> int:
    if int(iterations) != iterations or iterations < 0:
        raise ValueError(f"iterations must be a non-negative whole number, got {iterations}")
    return int(iterations)


def _extend_rotations(q: np.ndarray, rel: np.ndarray, k: int) -> np.ndarray:
    """Samples ``q_{-k} .. q_{n-1+k}`` of the signal whose displacements are mirrored by Eq. 26.

    ``rel[m] = q_m^-1 q_{m+1} = exp(w_m)``. The actual samples are kept inside; outside,
    the mirrored relative rotations are cumulated outward from the end samples.
    """
    n = q.shape[0]
    ext = np.empty((n + 2 * k, *q.shape[1:]))
    ext[k : k + n] = q
    idx = mirror_indices(n - 1, k, k)  # displacement positions -k .. n-2+k
    inv = quat.conjugate(rel[idx[:k]])  # exp(w_{-j})^-1 for positions -k .. -1
    fwd = rel[idx[k + n - 1 :]]  # exp(w_{n-2+j}) for positions n-1 .. n-2+k
    for j in range(1, k + 1):  # loop over window offsets only
        ext[k - j] = quat.multiply(ext[k - j + 1], inv[k - j])
        ext[k + n - 1 + j] = quat.multiply(ext[k + n - 2 + j], fwd[j - 1])
    return ext


def _extend_positions(p: np.ndarray, disp: np.ndarray, k: int) -> np.ndarray:
    """Positions ``p_{-k} .. p_{n-1+k}`` cumulated from the mirrored displacements (Eq. 26)."""
    n = p.shape[0]
    ext_d = mirrored_displacements(disp, k, k)  # positions -k .. n-2+k
    before = p[0] - np.cumsum(ext_d[:k][::-1], axis=0)  # p_{-1}, p_{-2}, ..., p_{-k}
    after = p[-1] + np.cumsum(ext_d[k + n - 1 :], axis=0)  # p_n, ..., p_{n-1+k}
    return np.concatenate([before[::-1], p, after], axis=0)


def _squared_angular_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``arccos(|a . b|)^2``: squared half rotation angle between paired quaternions."""
    c = np.einsum("...i,...i->...", a, b)
    np.abs(c, out=c)
    np.minimum(c, 1.0, out=c)
    np.arccos(c, out=c)
    return np.square(c, out=c)


def _squared_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``|b - a|^2`` over the last axis."""
    diff = b - a
    return np.einsum("...i,...i->...", diff, diff)


def _bilateral_sums(ext, disp, k, sigma_t, sigma_g, sq_dist) -> np.ndarray:
    """``s_i = sum_m b_m^(i) disp_{i+m}`` with ``b^(i)`` from the normalised weights W(i, r).

    ``ext`` holds the samples at positions ``-k .. n-1+k`` and ``disp`` the ``n-1``
    displacements. Un-normalised weights are summed into the Eq. 20 coefficients
    (``B_m = sum_{j>m} W_j``, ``B_m = -sum_{j<=m} W_j``) and the total divided by
    ``sum_r W(i, r)`` once, which is Eq. 20 applied to the normalised mask.
    """
    n = ext.shape[0] - 2 * k
    dext = mirrored_displacements(disp, k, k)  # positions -k .. n-2+k
    inv_g = 0.5 / sigma_g**2
    # e[r][j + r] = W(j, r) for j in -r .. n-1: row i of W(i, +r) is e[r][r + i],
    # row i of W(i, -r) = W(i - r, r) is e[r][i].
    e = [None]
    for r in range(1, k + 1):
        x = sq_dist(ext[k - r : k + n], ext[k : k + n + r])
        x *= -inv_g
        x -= r * r / (2.0 * sigma_t**2)
        e.append(np.exp(x, out=x))
    total = np.zeros((n, *disp.shape[1:]))
    tmp = np.empty_like(total)
    tail = np.zeros(total.shape[:-1])
    head = np.zeros(total.shape[:-1])
    for m in range(k - 1, -1, -1):  # B_m = sum_{j=m+1}^{k} W_j, m = k-1 .. 0
        tail += e[m + 1][m + 1 : m + 1 + n]
        np.multiply(dext[k + m : k + m + n], tail[..., None], out=tmp)
        total += tmp
    for m in range(-k, 0):  # B_m = -sum_{j=-k}^{m} W_j, m = -k .. -1
        head += e[-m][:n]
        np.multiply(dext[k + m : k + m + n], head[..., None], out=tmp)
        total -= tmp
    den = head
    den += tail
    den += 1.0  # W(i, 0) = 1
    total /= den[..., None]
    return total


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
    iterations = _check_iterations(iterations)
    out = quat.make_continuous(q, axis=0)
    if out.shape[0] < 2 or k == 0:
        return out
    for n_pass in range(iterations):
        if n_pass:
            out = quat.make_continuous(out, axis=0)
        rel = quat.multiply(quat.conjugate(out[:-1]), out[1:])  # exp(w_i)
        w = quat.log(rel)
        ext = _extend_rotations(out, rel, k)
        s = _bilateral_sums(ext, w, k, sigma_t, sigma_g, _squared_angular_distance)
        out = quat.multiply(out, quat.exp(s))
    return out


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
    iterations = _check_iterations(iterations)
    out = np.array(p, dtype=np.float64, copy=True)
    if out.shape[0] < 2 or k == 0:
        return out
    for _ in range(iterations):
        disp = np.diff(out, axis=0)
        ext = _extend_positions(out, disp, k)
        out = out + _bilateral_sums(ext, disp, k, sigma_t, sigma_p, _squared_distance)
    return out
