"""Coordinate-invariant multiresolution motion analysis (paper 003, Lee & Shin 2001).

A motion signal is a sequence of rigid frames ``(q_i, p_i)`` (003 Eq. 1): unit quaternions
``(F, ..., 4)`` ``(w, x, y, z)`` and, optionally, positions ``(F, ..., 3)`` of the same
leading shape (one frame per trailing signal, e.g. per joint). Time is axis 0 and every
trailing axis is processed at once. Functions return rotations first: ``(q, p)``, and
displacements angular first: ``(v, u)``.

Displacements (Eq. 2-3), measured in the body frame of the reference frame ``(q, p)``::

    (q', p') = (q, p) (+) (v, u) = (q exp(v), p + q u q^-1)
    (v, u)   = (q', p') (-) (q, p) = (log(q^-1 q'), q^-1 (p' - p) q)

``|v|`` is HALF the rotation angle (radians), ``u`` is in the positions' length unit. The
logarithm takes the shorter arc (``q^-1 q'`` with ``w >= 0``), so ``|v| <= pi/2``. Without
rotations, position displacements are plain differences ``u = p' - p``.

Pyramid (Eq. 7-9): ``m^(n) = R m^(n+1)``, ``d^(n) = m^(n+1) (-) E m^(n)``, and back
``m^(n+1) = E m^(n) (+) d^(n)``. Reduction ``R = D o H^R`` (Eq. 10-13) applies the mask
``(-1, 4, 18, 4, -1)/24`` as a Lee-Shin orientation filter (Eq. 5, mirrored ends as in Eq. 6)
and as a vector filter, then keeps every other frame. Expansion ``E = H^E o U`` (Eq. 14-16)
keeps the coarse frames and inserts the frames between them with the 4-point interpolatory
subdivision: ``slerp_1/2(q_i, q_{i+1}) exp((w_{i-1} - w_{i+1})/16)`` and
``(-p_{i-1} + 9 p_i + 9 p_{i+1} - p_{i+2})/16`` in the interior; near the ends the mask comes
from the cubic through the four nearest coarse frames (end of Sec. 3.4; Lagrange weights,
Eq. 17), with fewer nodes when the coarse level has fewer than four frames.

Any length (not only ``2^N k + 1``): a level of ``L`` frames keeps the frames
``phase, phase + 2, ...`` (``phase`` 0 or 1, stored with each detail level), so the coarser
level has ``ceil(L/2)`` frames. The expansion rebuilds exactly ``L`` frames from them: it
interpolates between coarse frames and extrapolates at most one frame at each end (before
the first kept frame when ``phase = 1``, after the last when ``L - phase`` is even) with the
same cubic through the four nearest coarse frames, as an Eq. 5 mask centred on the end
frame. ``decompose`` uses ``phase = 0`` (frame 0 survives to the base) unless
``align="end"`` (the last frame survives; used by :func:`stitch`); :func:`edit` and its
counterparts first continue the clip past its last frame by reflection to ``2^N k + 1``
frames, so that both ends survive and no frame of the clip is extrapolated (an
extrapolated end frame carries most of its level's detail, and dropping that detail had
moved a clip's last frames far). Every detail map has
exactly as many samples as its level has frames, and reconstruction adds them back to the
same expansion, so it returns the input to floating-point precision for every length.
Quaternion signs are reproduced too: each level is made sign-continuous and anchored on the
frame the coarser level keeps, in decomposition and reconstruction alike.
A clip of ``F`` frames admits ``ceil(log2 F)`` levels (down to a single base frame); larger
``levels`` requests are clamped to that.

Aliasing (003's reduction and expansion themselves): detail band ``k`` (finest = 1) is the
correction to an expansion of samples ``2^k`` frames apart, whose displacements take the
shorter arc, so they cannot hold a turn of more than half a turn (180 degrees of rotation)
between two samples. A joint that turns by more than that within ``2^k`` frames is still
decomposed and reconstructed exactly, but scaling band ``k`` or a coarser one scales the
correction that holds the turn's direction: with the band removed the joint turns the
other way. A constant angular velocity, a fixed point otherwise (error 2e-13 degrees), comes
out 180 degrees off at 11.5 degrees/frame with band 4 removed (11.5 x 16 = 184) and at 91
degrees/frame with band 1 removed; CMU 131_03's Hips resampled to 30 fps (313 degrees in
1.6 s, 191 in one 16-frame step) turned back by up to 169 degrees under
``edit(q, 4, [0, 0, 0, 0])`` (10 with 3 levels). Keep ``2^k`` frames of the deepest band
scaled shorter than the fastest half turn of the joints edited.

Coordinate invariance (Sec. 4): left-multiplying all orientations by ``r`` and moving the
positions by ``p -> r p r^-1 + t`` leaves every detail map unchanged (Theorem 4.1) and
moves the base by the same transform (Corollary 4.1).
"""

from __future__ import annotations

import operator
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..core import checks, quat
from . import ends
from .linear import apply_displacement_sums, displacement_coefficients, mirrored_displacements
from .masks import reduction

__all__ = [
    "Detail",
    "Pyramid",
    "blend",
    "decompose",
    "decompose_positions",
    "edit",
    "edit_frames",
    "edit_positions",
    "level_gains",
    "max_levels",
    "ominus",
    "oplus",
    "reconstruct",
    "scale",
    "stitch",
    "stitch_levels",
    "transfer",
]


@dataclass(frozen=True)
class Detail:
    """One displacement map ``d^(n)`` (003 Eq. 8): a ``(v, u)`` pair per frame of its level.

    Attributes
    ----------
    angular : (L, ..., 3) array or None
        ``v_i``, body-frame angular displacements in log units (``|v|`` = half the angle).
    linear : (L, ..., 3) array or None
        ``u_i``, linear displacements in the positions' unit; body frame when the pyramid
        has rotations, plain differences otherwise.
    phase : int
        The level's frames ``phase, phase + 2, ...`` are the next coarser level's frames.
    """

    angular: np.ndarray | None
    linear: np.ndarray | None
    phase: int

    @property
    def n_frames(self) -> int:
        """Number of frames ``L`` of the level this map refines."""
        part = self.angular if self.angular is not None else self.linear
        assert part is not None  # a map holds angular or linear details, or both
        return part.shape[0]


@dataclass(frozen=True)
class Pyramid:
    """Multiresolution representation ``(m^(0), d^(0), ..., d^(N-1))`` (003 Sec. 3.3).

    Attributes
    ----------
    rotations : (K, ..., 4) array or None
        Base signal orientations ``m^(0)``.
    positions : (K, ..., 3) array or None
        Base signal positions ``m^(0)``.
    details : tuple of Detail
        FINEST FIRST: ``details[0]`` is the paper's ``d^(N-1)`` (as many samples as the
        clip has frames), ``details[-1]`` is ``d^(0)``. Gains use the same order.
    """

    rotations: np.ndarray | None
    positions: np.ndarray | None
    details: tuple[Detail, ...]

    @property
    def n_levels(self) -> int:
        """Number ``N`` of detail levels."""
        return len(self.details)

    @property
    def n_frames(self) -> int:
        """Frames of the reconstructed signal."""
        if self.details:
            return self.details[0].n_frames
        base = self.rotations if self.rotations is not None else self.positions
        assert base is not None  # a pyramid holds rotations or positions, or both
        return base.shape[0]


# --------------------------------------------------------------------------- validation


def _rotations(q, name: str = "rotations") -> np.ndarray:
    return quat.continuous(checks.unit_quaternions(q, name, min_frames=1))  # no copy if so


def _positions(p, lead: tuple[int, ...] | None, name: str = "positions") -> np.ndarray:
    p = checks.vectors(p, name, min_frames=1)
    if lead is not None and p.shape[:-1] != lead:
        raise ValueError(
            f"{name} {p.shape} do not match the rotations {lead + (4,)}: each position needs "
            "the orientation of the same frame"
        )
    return p


def _levels(levels) -> int:
    try:
        n = operator.index(levels)
    except TypeError:
        raise ValueError(f"levels must be a non-negative integer, got {levels!r}") from None
    if n < 0:
        raise ValueError(f"levels must be a non-negative integer, got {n}")
    return n


def _per_level(values, levels: int, name: str) -> np.ndarray:
    """A finest-first list of per-level factors as a float array (at most ``levels`` long)."""
    if isinstance(values, str | bytes):  # ("0" had been read as a list of one gain)
        raise TypeError(f"{name} must be a list of numbers, got {type(values).__name__}")
    arr = np.atleast_1d(np.asarray(values, dtype=np.float64))
    if arr.ndim != 1 or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be a list of finite numbers, got {values!r}")
    if arr.size > levels:
        raise ValueError(f"{name} has {arr.size} entries but only {levels} levels were requested")
    return arr


def max_levels(n_frames: int) -> int:
    """Largest useful number of levels for ``n_frames`` frames: ``ceil(log2 n_frames)``.

    Each reduction maps ``L`` frames to ``ceil(L/2)``; the last one leaves a single frame.
    """
    if n_frames < 1:
        raise ValueError(f"a clip needs at least one frame, got {n_frames}")
    return int(n_frames - 1).bit_length()


# ------------------------------------------------------------------ displacements (Eq. 2-3)


def _ominus(q_to, q_from, p_to, p_from):
    """``(q_to, p_to) (-) (q_from, p_from)`` (Eq. 3), shortest arc; either part may be None."""
    v = u = None
    if q_from is not None:
        rel = quat.relative(q_from, q_to)
        v = quat.log_shortest(rel)
    if p_from is not None:
        u = p_to - p_from
        if q_from is not None:
            u = quat.rotate(quat.conjugate(q_from), u)
    return v, u


def _oplus(q, p, v, u):
    """``(q, p) (+) (v, u)`` (Eq. 2); either part may be None."""
    q_out = None if q is None else quat.multiply(q, quat.exp(v))
    p_out = None
    if p is not None:
        p_out = p + (u if q is None else quat.rotate(q, u))
    return q_out, p_out


def oplus(q, v, p=None, u=None):
    """Apply a displacement: ``(q exp(v), p + q u q^-1)`` (003 Eq. 2).

    ``q`` ``(..., 4)``, ``v`` ``(..., 3)`` in log units; ``p``, ``u`` ``(..., 3)`` optional
    (``u`` measured in the body frame ``q``). Returns ``(q', p')`` (``p'`` None without ``p``).
    """
    q = np.asarray(q, dtype=np.float64)
    if p is None:
        return _oplus(q, None, np.asarray(v, dtype=np.float64), None)
    return _oplus(
        q,
        np.asarray(p, dtype=np.float64),
        np.asarray(v, dtype=np.float64),
        np.asarray(u, dtype=np.float64),
    )


def ominus(q_to, q_from, p_to=None, p_from=None):
    """Displacement from frame ``from`` to frame ``to`` in the body frame of ``from`` (Eq. 3).

    Returns ``(v, u)`` with ``v = log(q_from^-1 q_to)`` (shorter arc, ``|v| <= pi/2``) and
    ``u = q_from^-1 (p_to - p_from) q_from`` (None without positions), so that
    ``oplus(q_from, v, p_from, u)`` gives back ``(q_to, p_to)`` (``q_to`` up to sign).
    """
    q_to = np.asarray(q_to, dtype=np.float64)
    q_from = np.asarray(q_from, dtype=np.float64)
    if p_to is None or p_from is None:
        if (p_to is None) != (p_from is None):
            raise ValueError("give positions for both frames or for neither")
        return _ominus(q_to, q_from, None, None)
    return _ominus(
        q_to, q_from, np.asarray(p_to, dtype=np.float64), np.asarray(p_from, dtype=np.float64)
    )


# ------------------------------------------------------- reduction and expansion (Eq. 10-17)


def _anchor_signs(q: np.ndarray, index: int, ref: np.ndarray) -> np.ndarray:
    """Make ``q`` sign-continuous, then flip whole signals so ``q[index] . ref >= 0``.

    Decomposition and reconstruction both anchor each level's signs on the frame that the
    coarser level keeps (index ``phase``, against the coarse frame 0), so a reconstructed
    level has the signs of the decomposed one, not only the same rotations.
    """
    q = quat.continuous(q)
    flip = np.einsum("...i,...i->...", q[index], ref) < 0.0
    return np.where(flip[None, ..., None], -q, q)


def _kept_sums(w: np.ndarray, phase: int, length: int) -> np.ndarray:
    """``sum_m b_m w_{i+m}`` of the reduction mask at the kept frames ``i = phase, phase+2, ..``.

    ``b`` from 000 Eq. 20, displacements mirrored at the ends (Eq. 6 / 000 Eq. 26); ``w`` are
    the ``length - 1`` angular or linear displacements of the level.
    """
    b = displacement_coefficients(reduction())
    k = b.size // 2
    ext = mirrored_displacements(w, k, k)
    total = np.zeros((len(range(phase, length, 2)),) + w.shape[1:])
    for tap, coeff in enumerate(b):  # loop over mask taps only
        total += coeff * ext[tap + phase : tap + length : 2]
    return total


def _reduce(q, w, p, phase: int):
    """``R = D o H^R`` (Eq. 10-13): the Lee-Shin filter of ``(-1, 4, 18, 4, -1)/24``.

    Evaluated only at the frames ``phase::2`` that ``D`` keeps; equal to
    ``lee_shin(q, reduction())[phase::2]`` and ``lee_shin_positions(p, ...)[phase::2]``.
    ``w`` are the angular displacements of the (sign-continuous) ``q``.
    """
    qc = pc = None
    length = (q if q is not None else p).shape[0]
    if q is not None:
        kept = q[phase::2]
        qc = apply_displacement_sums(kept, _kept_sums(w, phase, length))
        qc = _anchor_signs(qc, 0, q[phase])
    if p is not None:
        pc = p[phase::2] + _kept_sums(np.diff(p, axis=0), phase, length)
    return qc, pc


def _expansion_rule(k: int, length: int, phase: int):
    """Coefficients of the frames that ``E`` inserts into a level of ``length`` frames.

    The ``k`` coarse frames sit at fine indices ``phase + 2 j``; a new frame at fine index
    ``f`` sits at coarse time ``t = (f - phase)/2`` (half-integer). Its value is the cubic
    (fewer nodes if ``k < 4``) through the nearest coarse nodes ``s .. s+n-1`` at ``t``
    (Eq. 15, 17 and end of Sec. 3.4), written as displacements from a reference node ``r``:
    ``x_r + sum_m b_m (x_{s+m+1} - x_{s+m})``. Returns ``(fine indices, r, mid, s, b)``; ``mid``
    marks interior frames whose reference is the slerp midpoint of ``r`` and ``r + 1``.
    """
    t = (np.arange(length) - phase)[(np.arange(length) - phase) % 2 == 1] / 2.0
    n = min(4, k)
    s = np.clip(np.floor(t).astype(np.int64) - 1, 0, k - n)
    interior = (t > 0) & (t < k - 1)
    r = np.where(interior, np.floor(t).astype(np.int64), np.where(t < 0, 0, k - 1))
    x = t - s  # position of t in the window's local node coordinates 0 .. n-1
    a = np.ones((t.size, n))
    for j in range(n):  # Lagrange cardinal functions, loops over <= 4 nodes
        for m in range(n):
            if m != j:
                a[:, j] *= (x - m) / (j - m)
    rho = (r - s)[:, None]
    node = np.arange(n)[None, :]
    b = np.empty((t.size, max(n - 1, 0)))
    for m in range(n - 1):  # path from node r to node j, in displacements x_{s+m} -> x_{s+m+1}
        sign = ((rho <= m) & (m < node)).astype(np.float64) - ((node <= m) & (m < rho))
        b[:, m] = np.sum(a * sign, axis=1)
    fine = (phase + 2.0 * t).astype(np.int64)
    return fine, r, interior, s, b


def _column(c: np.ndarray, ndim: int) -> np.ndarray:
    return c.reshape(c.shape + (1,) * (ndim - 1))


def _expand(q, w, p, length: int, phase: int):
    """``E = H^E o U`` (Eq. 14-16): ``length`` frames whose ``phase::2`` frames are the input.

    ``q`` must be sign-continuous and ``w`` its angular displacements. A new interior frame
    is ``u exp(sum_m b_m w_{s+m} - w_r / 2)`` with ``u = slerp_1/2(q_r, q_{r+1})`` (computed
    as the normalised sum ``(q_r + q_{r+1}) / |q_r + q_{r+1}|``, the same point for
    continuous signs), which is Eq. 16 in the interior; an extrapolated end frame is
    ``q_r exp(sum_m b_m w_{s+m})``.
    """
    k = (q if q is not None else p).shape[0]
    fine, r, mid, s, b = _expansion_rule(k, length, phase)
    q_out = p_out = None
    if q is not None:
        q_out = np.empty((length,) + q.shape[1:])
        q_out[phase::2] = q
        if fine.size:
            total = np.zeros((fine.size,) + w.shape[1:])
            for m in range(b.shape[1]):  # <= 3 displacements per new frame
                total += _column(b[:, m], w.ndim) * w[s + m]
            ref = q[r]
            if k > 1:  # U: the slerp midpoint, then H^E relative to it
                nxt = np.minimum(r + 1, k - 1)
                ref = quat.normalize(ref + _column(mid * 1.0, q.ndim) * q[nxt])
                total -= _column(mid * 0.5, w.ndim) * w[nxt - 1]
            q_out[fine] = apply_displacement_sums(ref, total)
    if p is not None:
        p_out = np.empty((length,) + p.shape[1:])
        p_out[phase::2] = p
        if fine.size:
            d = np.diff(p, axis=0)
            total = p[r].copy()
            for m in range(b.shape[1]):
                total += _column(b[:, m], d.ndim) * d[s + m]
            p_out[fine] = total
    return q_out, p_out


# ------------------------------------------------------------------ pyramid (Eq. 7-9)


def _decompose(q, p, levels: int, align: str) -> Pyramid:
    if align not in ("start", "end"):
        raise ValueError(f"align must be 'start' or 'end', got {align!r}")
    n = min(_levels(levels), max_levels((q if q is not None else p).shape[0]))
    w = None if q is None else quat.displacements(q)
    details = []
    for _ in range(n):  # loop over levels only
        length = (q if q is not None else p).shape[0]
        phase = 0 if align == "start" else (length - 1) % 2
        qc, pc = _reduce(q, w, p, phase)
        wc = None if qc is None else quat.displacements(qc)
        qe, pe = _expand(qc, wc, pc, length, phase)
        v, u = _ominus(q, qe, p, pe)
        details.append(Detail(v, u, phase))
        q, w, p = qc, wc, pc
    return Pyramid(q, p, tuple(details))


def decompose(q, levels: int, positions=None, align: str = "start") -> Pyramid:
    """Multiresolution representation of an orientation signal (003 Eq. 7-8).

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions ``(w, x, y, z)``, time along axis 0; signs are made continuous first.
    levels : int
        Number ``N`` of detail levels; clamped to :func:`max_levels` ``(F)``.
    positions : (F, ..., 3) array, optional
        Positions of the same frames (e.g. translation channels); their details are measured
        in the body frame of the expanded orientation (Eq. 3), which makes every detail map
        invariant under rigid transforms of the clip (Theorem 4.1).
    align : {"start", "end"}
        Which end frame survives every reduction (see the module docstring).

    Returns
    -------
    Pyramid
        Base ``(ceil(F / 2^N), ..., 4)`` and ``N`` detail maps, finest first.
    """
    q = _rotations(q)
    p = None if positions is None else _positions(positions, q.shape[:-1])
    return _decompose(q, p, levels, align)


def decompose_positions(p, levels: int, align: str = "start") -> Pyramid:
    """Vector counterpart of :func:`decompose` for ``(F, ..., 3)`` positions alone.

    Details are plain differences ``p - E p``; the construction commutes with every affine
    map of space (the masks sum to one), so edits are equivariant under rigid transforms.
    """
    return _decompose(None, _positions(p, None), levels, align)


def reconstruct(pyramid: Pyramid):
    """Signal from its representation (003 Eq. 9): ``m^(n+1) = E m^(n) (+) d^(n)``.

    Returns ``(q, p)``: ``(F, ..., 4)`` sign-continuous unit quaternions and ``(F, ..., 3)``
    positions, each None when the pyramid has no such part. With unchanged coefficients the
    result equals the decomposed signal to floating-point precision, for every length.
    """
    q, p = pyramid.rotations, pyramid.positions
    if q is not None:
        q = quat.continuous(q)
    for level in reversed(pyramid.details):  # coarse to fine
        w = None if q is None else quat.displacements(q)
        qe, pe = _expand(q, w, p, level.n_frames, level.phase)
        fine, p = _oplus(qe, pe, level.angular, level.linear)
        q = None if q is None else _anchor_signs(fine, level.phase, q[0])
    return q, p


# ---------------------------------------------------------------- editing (Sec. 5.1)


def _scaled(level: Detail, g: float) -> Detail:
    return Detail(
        None if level.angular is None else g * level.angular,
        None if level.linear is None else g * level.linear,
        level.phase,
    )


def scale(pyramid: Pyramid, gains: Sequence[float] | np.ndarray) -> Pyramid:
    """Multiply each detail map by its gain (003 Sec. 5.1, enhancement / attenuation).

    ``gains[0]`` scales the finest level; levels without an entry keep gain 1. Gains may be
    any finite numbers (0 removes a level, between 0 and 1 attenuates, above 1 enhances).
    """
    g = _per_level(gains, pyramid.n_levels, "gains")
    details = tuple(
        _scaled(level, float(g[i])) if i < g.size else level
        for i, level in enumerate(pyramid.details)
    )
    return Pyramid(pyramid.rotations, pyramid.positions, details)


def level_gains(levels: int, level: float) -> list[float]:
    """Gains (finest first) that give the paper's fractional level ``n + alpha`` (Sec. 5.1).

    Level ``n`` (``0 <= n <= levels``) keeps the details ``d^(0) .. d^(n-1)`` and drops the
    finer ones; ``n + alpha`` also keeps ``d^(n)`` scaled by ``alpha``. So ``level = levels``
    is the original signal and ``level = 0`` the expanded base signal.
    """
    n_levels = _levels(levels)
    level = float(level)
    if not 0.0 <= level <= n_levels:
        raise ValueError(f"level must lie in [0, {n_levels}], got {level}")
    coarse_first = np.clip(level - np.arange(n_levels), 0.0, 1.0)
    return [float(x) for x in coarse_first[::-1]]


def _clamped_gains(gains, levels: int, n_available: int) -> np.ndarray:
    # Gains for levels that a short clip does not have are dropped (no coefficients left).
    return _per_level(gains, _levels(levels), "gains")[:n_available]


def _end_pad(n_frames: int, levels: int) -> tuple[int, int]:
    """The levels ``N`` a clip of ``n_frames`` frames is edited on (``levels`` clamped to
    :func:`max_levels`) and the frames that continue it to ``2^N k + 1``, a length whose
    every level keeps both end frames: fewer than ``2^N`` (and than the clip's frames), so
    the cost follows the levels edited (the last frames then depend a little on ``N``)."""
    n = min(_levels(levels), max_levels(n_frames))
    return n, -(n_frames - 1) % (1 << n)


def _reflected(q, p, pad: int):
    """The frames continued ``pad`` frames past the last, ``e``, by the reflection about
    it: ``q_{e+j} = q_e q_{e-j}^-1 q_e`` and ``p_{e+j} = 2 p_e - p_{e-j}`` (``pad`` < the
    clip's frames). A constant angular and linear velocity goes on exactly; the reflection
    commutes with rotating the clip from either side and with rigid motions of the
    positions."""
    if not pad:
        return q, p
    back = slice(-2, -2 - pad, -1)  # frames e-1 .. e-pad
    if q is not None:
        # (normalised: a product of three quaternions a hair off unit length, as checks
        # accept them, would be three hairs off, beyond what the next check accepts)
        beyond = quat.normalize(ends.reflect(q[-1], q[back], rotations=True))
        q = quat.continuous(np.concatenate([q, beyond]))
    if p is not None:
        p = np.concatenate([p, ends.reflect(p[-1], p[back], rotations=False)])
    return q, p


def edit(q, levels: int, gains: Sequence[float]) -> np.ndarray:
    """Per-level scaling of the orientation details (003 Sec. 5.1).

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions, time along axis 0, any trailing shape (e.g. joints).
    levels : int
        Detail levels ``N`` of the decomposition (>= ``len(gains)``); clamped to
        :func:`max_levels` ``(F)``, and gains of levels a short clip lacks are dropped.
    gains : sequence of float
        ``gains[0]`` multiplies the finest detail map; unlisted levels keep gain 1. Use
        :func:`level_gains` for the fractional levels ``n + alpha``.

    Returns
    -------
    (F, ..., 4) array
        Sign-continuous unit quaternions on the input's hemisphere at frame 0. Unit gains
        reproduce the input to floating-point precision; ``edit(r q) = r edit(q)``.

    The clip is continued past its last frame by reflection (:func:`_reflected`) to
    ``2^N k + 1`` frames (:func:`_end_pad`), so both end frames survive every reduction
    and neither is extrapolated by the expansion (dropping fine levels had moved a clip's
    last frames by up to 35 degrees on a still foot); the first frames are as they were.
    """
    q = checks.shaped(q, 4, "q", signal=True)
    if q.shape[0] == 0:  # an empty clip has nothing to edit
        return q.copy()
    q = _rotations(q, "q")
    n, pad = _end_pad(q.shape[0], levels)
    pyramid = decompose(_reflected(q, None, pad)[0], n)
    g = _clamped_gains(gains, levels, pyramid.n_levels)
    out, _ = reconstruct(scale(pyramid, g))
    return _anchor_signs(out[: q.shape[0]], 0, q[0])


def edit_frames(q, positions, levels: int, gains: Sequence[float]):
    """:func:`edit` for rigid frames: orientations and positions of the same signals together.

    Position details are measured in the body frame of the orientations (Eq. 3), as in the
    paper's hierarchical displacement maps; ``positions`` has shape ``q.shape[:-1] + (3,)``.
    Constant position columns stay exactly constant. Returns ``(q', positions')``.
    """
    q = _rotations(q)
    p = _positions(positions, q.shape[:-1])
    n, pad = _end_pad(q.shape[0], levels)
    q_long, p_long = _reflected(q, p, pad)
    pyramid = decompose(q_long, n, p_long)
    g = _clamped_gains(gains, levels, pyramid.n_levels)
    q_out, p_out = reconstruct(scale(pyramid, g))
    f = q.shape[0]
    return _anchor_signs(q_out[:f], 0, q[0]), p_out[:f]


def edit_positions(p, levels: int, gains: Sequence[float]) -> np.ndarray:
    """:func:`edit` for ``(F, ..., 3)`` positions alone (plain vector details)."""
    if np.shape(p)[0] == 0:
        return np.array(p, dtype=np.float64)
    p = _positions(p, None)
    n, pad = _end_pad(p.shape[0], levels)
    pyramid = decompose_positions(_reflected(None, p, pad)[1], n)
    g = _clamped_gains(gains, levels, pyramid.n_levels)
    return reconstruct(scale(pyramid, g))[1][: p.shape[0]]


# ---------------------------------------------------- blending and stitching (Eq. 20-21)


def _pair(q_a, q_b, p_a, p_b, what: str):
    q_a, q_b = _rotations(q_a, "rotations of clip A"), _rotations(q_b, "rotations of clip B")
    if (p_a is None) != (p_b is None):
        raise ValueError(f"{what}: give positions for both clips or for neither")
    if p_a is not None:
        p_a = _positions(p_a, q_a.shape[:-1], "positions of clip A")
        p_b = _positions(p_b, q_b.shape[:-1], "positions of clip B")
    return q_a, q_b, p_a, p_b


def _same_shape(q_a, q_b, what: str) -> None:
    if q_a.shape != q_b.shape:
        raise ValueError(
            f"{what} needs clips of equal shape (frames, joints), got {q_a.shape[:-1]} and "
            f"{q_b.shape[:-1]}"
        )


def _combine(levels: Sequence[Detail], coeffs: Sequence[float]) -> Detail:
    """``sum_k c_k d_k`` of detail maps with identical layout."""

    def weighted(parts: list[np.ndarray | None]) -> np.ndarray | None:
        if parts[0] is None:
            return None
        return np.sum([c * np.asarray(p) for c, p in zip(coeffs, parts, strict=True)], axis=0)

    return Detail(
        weighted([lv.angular for lv in levels]),
        weighted([lv.linear for lv in levels]),
        levels[0].phase,
    )


def blend(
    q_a,
    q_b,
    levels: int,
    weight: float = 0.5,
    detail_weights: Sequence[float] | None = None,
    p_a=None,
    p_b=None,
):
    """Level-wise blend of two clips of the same shape (003 Eq. 20 with weights).

    The base signal moves from A toward B along the displacement map between them,
    ``m^(0) = m_A^(0) (+) weight (m_B^(0) (-) m_A^(0))`` (slerp / lerp), and each detail map
    is ``(1 - w_n) d_A^(n) + w_n d_B^(n)``.

    Parameters
    ----------
    q_a, q_b : (F, ..., 4) arrays
        Rotations of the two clips (e.g. ``(F, J, 4)``), time-aligned, identical shapes.
    levels : int
        Detail levels ``N`` (clamped to :func:`max_levels` ``(F)``).
    weight : float
        Weight of clip B for the base signal, and for detail levels without an entry in
        ``detail_weights`` (0 gives A, 1 gives B; outside [0, 1] extrapolates).
    detail_weights : sequence of float, optional
        Weight of B per detail level, finest first (at most ``levels`` entries).
    p_a, p_b : (F, ..., 3) arrays, optional
        Positions of the same frames (shape ``q.shape[:-1] + (3,)``), blended with them.

    Returns
    -------
    (q, p)
        Blended rotations ``(F, ..., 4)`` and positions (None without ``p_a``, ``p_b``).

    Raises
    ------
    ValueError
        When the clips' shapes differ or only one clip has positions.
    """
    q_a, q_b, p_a, p_b = _pair(q_a, q_b, p_a, p_b, "blend")
    _same_shape(q_a, q_b, "blend")
    weights = np.array([] if detail_weights is None else detail_weights, dtype=np.float64)
    weights = _per_level(weights, _levels(levels), "detail_weights")
    pa, pb = decompose(q_a, levels, p_a), decompose(q_b, levels, p_b)
    v, u = _ominus(pb.rotations, pa.rotations, pb.positions, pa.positions)
    w = float(weight)
    q0, p0 = _oplus(pa.rotations, pa.positions, w * v, None if u is None else w * u)
    details = []
    for i, (da, db) in enumerate(zip(pa.details, pb.details, strict=True)):
        wn = float(weights[i]) if i < weights.size else w
        details.append(_combine((da, db), (1.0 - wn, wn)))
    return reconstruct(Pyramid(q0, p0, tuple(details)))


def transfer(q_ref, q_shape, q_detail, levels: int, p_ref=None, p_shape=None, p_detail=None):
    """Motion analogy of 003 Eq. 20: the global shape of one clip with the details of another.

    With ``ref`` = straight walk, ``shape`` = turning walk, ``detail`` = straight limp, the
    result is a turning limp::

        m^(0) = m_detail^(0) (+) (m_shape^(0) (-) m_ref^(0))
        d^(n) = d_shape^(n) + (d_detail^(n) - d_ref^(n))

    All three clips must have the same shape ``(F, ..., 4)`` (positions ``(F, ..., 3)``
    optional, all or none). Returns ``(q, p)``; raises ValueError when shapes differ.
    """
    q_ref, q_shape, p_ref, p_shape = _pair(q_ref, q_shape, p_ref, p_shape, "transfer")
    q_ref, q_detail, p_ref, p_detail = _pair(q_ref, q_detail, p_ref, p_detail, "transfer")
    _same_shape(q_ref, q_shape, "transfer")
    _same_shape(q_ref, q_detail, "transfer")
    pr = decompose(q_ref, levels, p_ref)
    ps = decompose(q_shape, levels, p_shape)
    pd = decompose(q_detail, levels, p_detail)
    v, u = _ominus(ps.rotations, pr.rotations, ps.positions, pr.positions)
    q0, p0 = _oplus(pd.rotations, pd.positions, v, u)
    details = tuple(
        _combine((ds, dd, dr), (1.0, 1.0, -1.0))
        for ds, dd, dr in zip(ps.details, pd.details, pr.details, strict=True)
    )
    return reconstruct(Pyramid(q0, p0, details))


def _join(a: np.ndarray, b: np.ndarray, seam: np.ndarray) -> np.ndarray:
    return np.concatenate([a[:-1], seam[None], b[1:]], axis=0)


def stitch_levels(n_a: int, n_b: int, levels: int) -> int:
    """The detail levels :func:`stitch` uses for clips of ``n_a`` and ``n_b`` frames:
    ``levels``, at most as deep as the shorter clip allows, and no deeper than leaves each
    clip's coarsest level at least five samples, ``4 x 2^N + 1 <= F`` (65 frames for 4
    levels): the cubic of the far end's four nearest coarse samples then does not include
    the seam's, and every frame beyond ``3 (2^N - 1)`` of the seam comes back exactly (a
    deeper one moved the far end: a joint 999 frames from the seam of a take cut in two,
    stitched with 9 levels, had turned by 176 degrees; two 64-frame clips with 4 levels by
    51)."""
    fits = max(((min(n_a, n_b) - 1) // 4).bit_length() - 1, 0)  # largest N: 4 2^N <= F - 1
    return min(_levels(levels), max_levels(n_a), max_levels(n_b), fits)


def stitch_width(levels: int) -> int:
    """The frames either side of the seam :func:`stitch` changes on ``levels`` detail levels
    (:func:`stitch_levels`): ``3 (2^N - 1)``."""
    return 3 * (2**levels - 1)


def stitch(q_a, q_b, levels: int, p_a=None, p_b=None):
    """Join clip A's end to clip B's start level by level (003 Eq. 21).

    A is decomposed with its last frame kept at every level (``align="end"``), B with its
    first frame kept, so at every level the two coefficient sequences meet on one shared
    sample; that sample is the average of A's last and B's first coefficients (slerp_1/2 /
    midpoint for the base, mean for the detail maps) and the merged pyramid is
    reconstructed. Each frequency band is thereby joined over its own width, without
    estimating velocities: only the frames within ``3 (2^N - 1)`` of the seam differ from
    the input clips (``N`` the number of levels used), so more levels give a longer,
    smoother transition.

    Parameters
    ----------
    q_a, q_b : (F_A, ..., 4), (F_B, ..., 4) arrays
        Rotations of the two clips; trailing shapes (joints) must match, lengths may differ.
    levels : int
        Detail levels ``N``, clamped by :func:`stitch_levels` so the transition lies within
        the shorter clip.
    p_a, p_b : (F_A, ..., 3), (F_B, ..., 3) arrays, optional
        Positions of the same frames (e.g. all translation channels), stitched with them.

    Returns
    -------
    (q, p)
        ``F_A + F_B - 1`` frames (A's last and B's first frames merge into one); ``p`` None
        without positions.

    Raises
    ------
    ValueError
        When the trailing shapes differ or only one clip has positions.
    """
    q_a, q_b, p_a, p_b = _pair(q_a, q_b, p_a, p_b, "stitch")
    if q_a.shape[1:] != q_b.shape[1:]:
        raise ValueError(
            f"stitch needs clips with the same joints, got trailing shapes {q_a.shape[1:-1]} "
            f"and {q_b.shape[1:-1]}"
        )
    n = stitch_levels(q_a.shape[0], q_b.shape[0], levels)
    pa = decompose(q_a, n, p_a, align="end")
    pb = decompose(q_b, n, p_b, align="start")
    assert pa.rotations is not None and pb.rotations is not None
    q0 = _join(pa.rotations, pb.rotations, quat.slerp(pa.rotations[-1], pb.rotations[0], 0.5))
    p0 = None
    if pa.positions is not None and pb.positions is not None:
        p0 = _join(pa.positions, pb.positions, 0.5 * (pa.positions[-1] + pb.positions[0]))
    details = []
    for da, db in zip(pa.details, pb.details, strict=True):
        assert da.angular is not None and db.angular is not None
        ang = _join(da.angular, db.angular, 0.5 * (da.angular[-1] + db.angular[0]))
        lin = None
        if da.linear is not None and db.linear is not None:
            lin = _join(da.linear, db.linear, 0.5 * (da.linear[-1] + db.linear[0]))
        details.append(Detail(ang, lin, da.phase))
    return reconstruct(Pyramid(q0, p0, tuple(details)))
