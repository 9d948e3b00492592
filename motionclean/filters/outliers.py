"""Lone outliers: single samples that leave a joint's noise and come straight back.

A sample ``q_t`` is measured against the chord of its neighbours, the rotation halfway
between ``q_(t-1)`` and ``q_(t+1)``: its deviation ``d_t`` (rotation vector, radians). Noise
of RMS rotation angle ``s`` leaves ``|d_t|`` at about ``sqrt(1.5) s``; smooth motion moves the
chords of neighbouring samples alike, and a turn that changes speed at one sample (an
impact) leaves its neighbours on their chords. A lone outlier pulls both neighbours' chords
the other way, by half its own deviation each. :func:`lone_outliers` finds the samples
whose deviation exceeds :data:`LONE_SIGMAS` times ``sqrt(1.5) s`` with both neighbours'
deviations pointing back by over :data:`PULLED_BACK` of it; :func:`replaced` puts each on the
chord. Where ``auto`` filters a joint, a smoothing mask only spreads such a sample over its
neighbours (a binomial k=1 keeps half of it): judged against the noise ``auto`` found, it
is taken out first (see :mod:`motionclean.steps.auto`). A good sample between two outliers
pulls its neighbours back by its whole deviation, not half of it, and is no outlier.
"""

from __future__ import annotations

import numpy as np

from ..core import quat

__all__ = [
    "LONE_SIGMAS",
    "PULLED_BACK",
    "chord_deviations",
    "chord_noise",
    "lone_outliers",
    "replaced",
]

#: A lone outlier leaves its neighbours' chord by more than this many times the deviation
#: noise alone gives there (``sqrt(1.5)`` times the RMS noise): on 21 and 29 coordinates of
#: two OpenSim walks and runs with 2.5 degrees of noise and three 15-30 degree one-frame
#: spikes each, 4 flags 32 of the walk's 54 spikes and 16 samples of noise, 5 flags 31 and
#: 3, 6 flags 25 and 1. Gaussian noise of one degree of freedom passes 5 once in 10^6
#: samples before the neighbours' test.
LONE_SIGMAS = 5.0
#: ... and each neighbour's deviation points back along it by this share of it (a lone
#: outlier's pull is half of it, its noise aside; an impact's neighbours stay on their
#: chords, a good sample between two outliers pulls them back by all of it).
PULLED_BACK = (0.25, 0.75)


def _off_chord(before: np.ndarray, sample: np.ndarray, after: np.ndarray) -> np.ndarray:
    """``(..., 3)``: ``sample``'s rotation from the chord of ``before`` and ``after`` (their
    normalised sum: halfway between them), as a rotation vector in radians; unit
    quaternions ``(..., 4)``, signs continuous."""
    mid = quat.normalize(before + after)
    return 2.0 * quat.log(quat.multiply(quat.conjugate(mid), sample))


def _chord_deviations(q: np.ndarray) -> np.ndarray:
    """``(F - 2, C, 3)``: :func:`_off_chord` of each inner sample of ``q`` ``(F, C, 4)``."""
    return _off_chord(q[:-2], q[1:-1], q[2:])


def chord_deviations(q: np.ndarray, frames: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``(N,)``: the angles (degrees) of the samples ``(frames, columns)`` of ``q`` ``(F, C,
    4)``, sign-continuous, from the chords of their neighbours (inner frames only)."""
    return np.degrees(np.linalg.norm(_deviations_at(q, frames, columns), axis=-1))


#: The median chord deviation over the RMS noise angle that leaves it: 0.826 for noise of
#: one degree of freedom (a coordinate), 1.088 for noise isotropic in three; the smaller
#: gives the larger estimate (:func:`chord_noise`), an outlier's threshold never too low.
MEDIAN_CHORD_PER_NOISE = 0.826
#: Seconds of frames whose median chord deviation gives the noise there (noise that
#: changes along the clip: 0.5 degrees for half of it, 5 for the other).
NOISE_SECONDS = 2.0


def chord_noise(q: np.ndarray, frame_time: float) -> np.ndarray:
    """``(F, C)``: the RMS noise angle (degrees) that the median chord deviation of each
    column of ``q`` ``(F, C, 4)``, sign-continuous, over stretches of :data:`NOISE_SECONDS`
    would leave alone (motion adds to it: an upper estimate, unmoved by a few outliers,
    which the spectral one is not: one 15 degree spike had raised a 30 fps arm's from 0.93
    to 4.22 degrees); the first and last frames take their neighbours'."""
    n_frames = q.shape[0]
    out = np.zeros(q.shape[:2])
    if n_frames < 3:
        return out
    size = np.linalg.norm(_chord_deviations(q), axis=-1)  # (F - 2, C)
    span = min(max(3, int(round(NOISE_SECONDS / frame_time))), size.shape[0])
    whole = size.shape[0] // span  # stretches of ``span``; the rest joins the last
    medians = np.median(size[: whole * span].reshape(whole, span, -1), axis=1)
    if whole * span < size.shape[0]:
        medians[-1] = np.median(size[(whole - 1) * span :], axis=0)
    out[1:-1] = np.repeat(
        medians, np.r_[np.full(whole - 1, span), size.shape[0] - (whole - 1) * span], axis=0
    )
    out[0], out[-1] = out[1], out[-2]
    return np.degrees(out) / MEDIAN_CHORD_PER_NOISE


#: Frames judged at a time (the chord deviations' temporaries stay small on long clips).
BLOCK_FRAMES = 16384


def lone_outliers(
    q: np.ndarray, noise_deg: np.ndarray, known: np.ndarray | None = None
) -> np.ndarray:
    """``(F, C)`` bool: the lone outliers of sign-continuous unit quaternions ``q`` ``(F, C,
    4)`` under noise of RMS rotation angle ``noise_deg`` ``(C,)`` or ``(F, C)`` degrees (a
    column whose noise is not finite or is 0 somewhere has none, and is not read). With
    ``known`` ``(F, C)`` bool, a sample is judged only where it and its two neighbours on
    each side are known. The
    first and last two frames are never outliers (their neighbours' chords are not all
    measured); of two in a row, the one further from its chord is."""
    out = np.zeros(q.shape[:2], dtype=bool)
    level = np.radians(np.broadcast_to(np.asarray(noise_deg, dtype=np.float64), out.shape))
    judged = np.flatnonzero(np.all(np.isfinite(level) & (level > 0), axis=0))
    if q.shape[0] < 5 or judged.size == 0:
        return out
    limit = LONE_SIGMAS * np.sqrt(1.5) * level[:, judged]
    for start in range(2, q.shape[0] - 2, BLOCK_FRAMES):
        stop = min(start + BLOCK_FRAMES, q.shape[0] - 2)
        out[start:stop, judged] = _pulled_far(q[start - 2 : stop + 2, judged], limit[start:stop])
    if known is not None:
        out[2:-2] &= known[:-4] & known[1:-3] & known[2:-2] & known[3:-1] & known[4:]
    # an outlier pulls its neighbours' chords by half its own deviation: where one of them
    # passes too, the larger deviation is the outlier
    frames, columns = np.nonzero(out)
    size = np.linalg.norm(_deviations_at(q, frames, columns), axis=-1)
    for side in (-1, 1):
        twin = out[frames + side, columns]
        if twin.any():
            other = np.linalg.norm(_deviations_at(q, frames[twin] + side, columns[twin]), axis=-1)
            out[frames[twin][other > size[twin]], columns[twin][other > size[twin]]] = False
    return out


def _pulled_far(q: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """``(F - 4, C)``: the inner samples of ``q`` ``(F, C, 4)`` (all but two at each end)
    further than ``limit`` ``(F - 4, C)`` radians from their chord, both neighbours' deviations
    pointing back along theirs by :data:`PULLED_BACK` of it."""
    d = _chord_deviations(q)
    size = np.linalg.norm(d, axis=-1)
    unit = d / np.maximum(size, np.finfo(np.float64).tiny)[..., None]
    centre = size[1:-1]
    low, high = PULLED_BACK[0] * centre, PULLED_BACK[1] * centre
    before = -np.sum(d[:-2] * unit[1:-1], axis=-1)
    after = -np.sum(d[2:] * unit[1:-1], axis=-1)
    pulled = (before > low) & (before < high) & (after > low) & (after < high)
    return pulled & (centre > limit)


def _deviations_at(q: np.ndarray, frames: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``(N, 3)``: the chord deviations (:func:`_chord_deviations`) of the samples
    ``(frames, columns)`` of ``q``, inner frames only."""
    return _off_chord(q[frames - 1, columns], q[frames, columns], q[frames + 1, columns])


def replaced(q: np.ndarray, outliers: np.ndarray) -> np.ndarray:
    """A copy of ``q`` ``(F, C, 4)`` with each sample of ``outliers`` ``(F, C)`` (never the
    first or last frame, nor two in a row) on the chord of its neighbours."""
    out = q.copy()
    frames, columns = np.nonzero(outliers)
    out[frames, columns] = quat.normalize(q[frames - 1, columns] + q[frames + 1, columns])
    return out
