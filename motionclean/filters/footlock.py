"""Foot lock: feet that stand stay planted, by the least weighted change of the leg joints.

Pure functions on arrays. Rotations are unit quaternions ``(w, x, y, z)`` (Hamilton
product, ``v' = q v q^-1``), local to the parent joint; positions are in the file's length
unit. Points are the skeleton's joints followed by its end sites (``tips``).

Per frame, :func:`plant` finds the smallest change of the joints from the root down to
the knee (the root's translation, every rotation on the way, the knee as a hinge), each
weighted by the error expected in it, that puts the ankle on its target within a
tolerance: its horizontal position on a straight line through the contact, the height left
free, but not below the floor during a contact. Where the foot has toes, a second solve
holds them too, resuming where the first left every frame it changed: every toe point on
its own path while it is planted (the path of the toe once the ankles stand, smoothed),
the ankle on its line, by the same joints and the ankle's own rotation and the toe
joints. Each is a Gauss-Newton solve of

    min  sum_v |d_v|^2 / s_v^2  +  sum_r w_r (J_r d - e_r)^2 / tol_r^2

(``d_v`` the change of variable ``v`` as a rotation vector in world axes, radians, or a
translation; ``s_v`` its expected RMS error per component; ``e_r`` the residual of row
``r``; ``w_r`` its weight: the Huber weight times the hold's weight, which eases from 0 to
1 into a contact, or to :data:`STILL_FIRMNESS` into a stance held still), all frames at
once. The rows are vectors of world space and the prior is isotropic per joint, so the
result turns with the clip: it is coordinate invariant.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..core import quat
from ..core.kinematics import depths, forward_arrays, hung_on

#: Gauss-Newton iterations (the change is small: a third one moves no point of a noisy
#: walk by more than 0.005 mm on a body 1.7 m tall).
ITERATIONS = 2
#: Iterations of the ankles' solve where a toe is held, so that the toes' solve goes on
#: from it and iterates the ankles' rows again (:data:`ITERATIONS` where none is): the
#: toes' paths, taken from the legs it leaves, are smoothed.
ANKLE_ITERATIONS_BEFORE_TOES = 1
#: The most a joint turns in one iteration of the solve (radians; about 6 degrees): with
#: a tolerance near zero its prior stops bounding the linearised step, which had turned a
#: toe by 176 degrees at ``tolerance=1e-9`` (the defaults' steps stay far below it).
MAX_TURN = 0.1
#: Gauss-Newton iterations of the toes' solve, which starts where the ankles' left the
#: legs: one iteration had left a toe's end up to 10 tolerances below the floor during a
#: contact, where the bound is :data:`FLOOR_FIRMNESS` of one (the floor's row is
#: linearised once).
TOE_ITERATIONS = 2
#: Frames solved at a time (bounds the per-frame systems' memory).
BLOCK_FRAMES = 4096
#: A point this far below the floor (fraction of the tolerance) is on it: a sole that
#: defines the floor is not pushed by the rounding of its own height.
FLOOR_SLACK = 1e-6
#: The toes keep above the floor within this fraction of the ankle's tolerance: the foot's
#: short levers would otherwise trade a toe under the floor against its rotation's change.
FLOOR_FIRMNESS = 0.01
#: The toes follow their paths this many times more loosely than the ankle its line (the
#: default of ``plant``'s ``toe_tolerance``): on walks with 3 degrees of noise on every
#: joint, 1.5 turns the legs 0.8 % further from the truth than the default without a foot
#: lock, 1.7 lets the toes slide 1.2 times the capture's own (bench/footlock.py).
TOE_TOLERANCE = 1.6
#: A toe's path is its motion smoothed by a kernel of this standard deviation, as a
#: fraction of the hold window (``hold_frames``).
TOE_SMOOTHING = 0.5
#: A held line's slope (a foot's drift) is halved where it stands this many standard
#: errors clear of the scatter about it, kept nearly whole well beyond, dropped well within
#: (:func:`held_lines`).
DRIFT_SIGNIFICANCE = 8.0
#: A still contact (:func:`held_lines`) strays from its line by at most this many times
#: the noise's reach over any hold window: the wander a filter leaves reaches 1.5-2 times
#: its RMS over half a second, and a heel rising at a long stance's end (4 reaches over its
#: last 5 %) goes further there while hardly moving the whole contact's RMS.
WINDOW_REACH = 2.0
#: A contact is held on one line (:func:`held_lines`' ``still_within``) only where it lasts
#: this many hold windows: a stance, along whose windows' lines a filter's wander would
#: slide the foot. A walking step's contact is shorter; held on one line, the heel's move
#: within the noise's reach was taken out and the knee bent for it (GAMES-105's turns, 3
#: degrees of noise: knee flexion error 1.011-1.018 of the pipeline without footlock on 4
#: of 6 runs, 0.979-1.009 with it; bench/footlock.py's legs as close or closer).
STILL_MIN_WINDOWS = 1.5
#: A stance held on one line (:func:`held_lines`' ``still_within``) is held this many times
#: as firmly (its rows' precision: the tolerance divided by its square root), eased into and
#: out of from there: the line is fitted to the whole stance, which the noise moves far less
#: than a window's, and the tolerance's share of the noise had stayed as jitter of a standing
#: foot. Measured with 3 degrees of noise, three seeds each (skate / the capture's own, at 1
#: -> 4 -> 9): a LaFAN1 run's first 5 s standing at 30 fps, ankles 2.0-3.7 -> 0.7-1.4 ->
#: 0.3-0.9; GAMES-105's idle stance 11-20 -> 4.3-7.2 -> 2.1-3.5; MocapBank's standing clip's
#: left ankle 1.40-1.55 -> 0.48-0.53 -> 0.23-0.25; the legs' rotation error within 0.0015
#: of before (CMU walks, LaFAN1, GAMES-105), the walks' skate as it was; the toes, on their
#: paths, slide 9-31 % more on those stances (held still as well, they slid half as far,
#: but the CMU walks' legs turned up to 0.9 % further from the truth).
STILL_FIRMNESS = 9.0
#: A knee's hinge angle is changed as if its expected error were half what the prior says
#: (its variance times this): the ankle's correction leans on the hip, whose longer lever
#: reaches the target with less turn, and the knee's flexion, which the eye follows, keeps
#: closer to the capture. Measured with 3 degrees of noise, three seeds each (knee flexion
#: error / the pipeline without footlock, at 1 -> here): five Bandai Namco walks at 30 fps
#: 1.022 -> 1.003 at most, GAMES-105's 1 s walk at 100 fps 1.061 -> 1.015, its turns
#: 1.009 -> 0.998, the corpus at 30 fps 1.011 -> 0.996; the legs' rotation error within
#: 0.002 of what it was, the feet's skate the same but a standing clip's, 5 % higher
#: (README, "Feet on the ground"). The Huber weights and the step's contacts keep the
#: whole prior: scaling it there had slid a 30 fps walk's ankle 2.3 times further.
HINGE_SHARE = 0.25
#: Smallest expected error of a variable (radians, or length units for the root's
#: translation): a joint the noise model calls exact barely moves.
MIN_SIGMA = 1e-6


@dataclass(frozen=True)
class Leg:
    """One leg to plant.

    ``joints`` may turn to hold the ankle and the toes (from the root down to the knee,
    root first); ``knee`` turns only about ``hinge`` (unit, in the knee's parent frame);
    ``points`` are the ankle, then the toe points (joints or end sites below it); ``foot``
    may turn to hold the toes (the ankle and joints below it; none: the toes are not held
    and the ankle keeps its own rotation).
    """

    joints: tuple[int, ...]
    knee: int
    hinge: np.ndarray
    points: tuple[int, ...]
    foot: tuple[int, ...] = ()


def held_toes(legs: list[Leg]) -> list[tuple[int, int]]:
    """``(leg, point)`` of every toe point held: the toe points of the legs with a ``foot``,
    in order (the columns of :func:`plant`'s ``toe_contacts``)."""
    return [(k, p) for k, leg in enumerate(legs) if leg.foot for p in leg.points[1:]]


@dataclass(frozen=True)
class Prior:
    """What each variable may move: ``sigma`` ``(J,)`` the expected RMS rotation error per
    joint (radians of rotation angle; 0 for a joint that does not move) and ``root``
    ``(3,)`` the root translation's expected RMS error along each axis (length units; 0
    for an axis without a position channel)."""

    sigma: np.ndarray
    root: np.ndarray


def hinge_axis(knee: np.ndarray) -> np.ndarray:
    """The axis ``(3,)`` a knee bends about, in its parent's frame: the principal axis of
    the rotation vectors of its local rotations ``(F, 4)`` relative to their mean.
    Coordinate invariant; defined where the leg is straight too."""
    q = quat.continuous(knee)
    mean = q.sum(axis=0)
    mean /= max(float(np.linalg.norm(mean)), 1e-300)
    v = quat.log(quat.multiply(q, quat.conjugate(mean)))
    _, vectors = np.linalg.eigh(v.T @ v)
    return vectors[:, -1]


def _window_sums(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Sums of ``x`` over the frame windows ``lo[i] .. hi[i]-1`` (cumulative sums)."""
    total = np.concatenate([np.zeros((1, *x.shape[1:])), np.cumsum(x, axis=0)])
    return total[hi] - total[lo]


def _run_bounds(contacts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame ``(F,)``: the first and last frame of its contact (itself outside one)."""
    n = len(contacts)
    index = np.arange(n)
    starts = contacts & ~np.r_[False, contacts[:-1]]
    ends = contacts & ~np.r_[contacts[1:], False]
    first = np.maximum.accumulate(np.where(starts, index, 0))
    last = np.minimum.accumulate(np.where(ends, index, n)[::-1])[::-1]
    return np.where(contacts, first, index), np.where(contacts, last, index)


def held_lines(
    points: np.ndarray, contacts: np.ndarray, hold_frames: float, still_within: float = 0.0
) -> np.ndarray:
    """``(F, ..., 3)``: on contact frames, the least-squares straight line of ``points``
    through a window of ``hold_frames`` frames centred on the frame and cut to its contact,
    evaluated at the frame (``inf``: the contact's mean); elsewhere the points themselves.
    The line's slope is shrunk toward 0 by ``s^2 / (s^2 + (k e)^2)``, ``s`` its length, ``e``
    its standard error from the points' scatter about it (as many points as scatter
    independently, :func:`_independent_share`), ``k`` :data:`DRIFT_SIGNIFICANCE` (both
    summed over the axes: the shrinkage turns with the clip). A contact no longer than one
    window is held on one line through it, shrunk the same way (the windows cut to it fit
    their lines on fewer points: at 30 fps a step's contact of 12 frames, whose windows'
    slopes followed the noise a filter leaves). A stance (a contact of at least
    :data:`STILL_MIN_WINDOWS` windows) that stays within ``still_within`` of one line is
    held on it (:func:`_still_stances`).

    Jitter and the sliding it causes go, and so does the slope that jitter alone fits over a
    short window; a steady drift (a pivot) that stands clear of the jitter stays.
    """
    return _held_lines(points, contacts, hold_frames, still_within)[0]


def _held_lines(
    points: np.ndarray, contacts: np.ndarray, hold_frames: float, still_within: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`held_lines`, and the frames ``(F,)`` of the stances it holds on one line."""
    none = np.zeros(len(points), dtype=bool)
    if not np.isfinite(hold_frames):
        first, last = _run_bounds(contacts)  # held still: the contact's mean position
        shape = (-1,) + (1,) * (points.ndim - 1)
        origin = points[first]  # place from each contact's first frame: the sums stay small
        points = points - origin
        mean = _window_sums(points, first, last + 1) / (last + 1 - first).reshape(shape)
        return origin + np.where(contacts.reshape(shape), mean, points), none
    half = int(min(hold_frames, 2 * len(points)) // 2)
    held = _local_lines(points, contacts, half, 1, DRIFT_SIGNIFICANCE)
    if not contacts.any():
        return held, none
    whole = _local_lines(points, contacts, len(points), 1, DRIFT_SIGNIFICANCE)
    bounds = _run_bounds(contacts)
    first, last = bounds
    short = contacts & (last + 1 - first <= 2 * half + 1)  # a contact within one window
    held = np.where(short.reshape((-1,) + (1,) * (points.ndim - 1)), whole, held)
    still = _still_stances(points, contacts, whole, bounds, still_within, half)
    return np.where(still.reshape((-1,) + (1,) * (points.ndim - 1)), whole, held), still


def held_paths(points: np.ndarray, contacts: np.ndarray, sigma_frames: float) -> np.ndarray:
    """``(F, ..., 3)``: on contact frames, the straight line fitted to ``points`` around
    the frame by least squares weighted with a smooth kernel of standard deviation
    ``sigma_frames`` frames (three box averages of ``2 h + 1`` frames, ``h (h + 1) =
    sigma^2``), cut to its contact, evaluated at the frame; elsewhere the points.

    A local linear smoother: jitter goes, a toe's slow roll stays, and the contact's ends
    are not pulled toward its middle. Each box is a running sum: cost per frame is flat.
    """
    half = int(round((np.sqrt(1.0 + 4.0 * min(sigma_frames, len(points)) ** 2) - 1.0) / 2.0))
    if half == 0 or not contacts.any():
        return points.copy()
    return _local_lines(points, contacts, half, 3)


def _still_stances(
    points: np.ndarray,
    contacts: np.ndarray,
    whole: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray],
    within: float,
    half: int,
) -> np.ndarray:
    """``(F,)``: the frames of each contact of at least :data:`STILL_MIN_WINDOWS` windows
    whose ``points`` ``(F, ..., 3)`` stay within ``within`` (length units; 0: none) of one
    line through the whole contact (``whole``, its slope shrunk as :func:`held_lines`
    shrinks it; ``bounds``: each frame's contact, :func:`_run_bounds`): within it in RMS
    over the contact (each frame's farthest point), and within :data:`WINDOW_REACH` times
    it over every window of ``2 half + 1`` frames, so a move at one end of a long stance
    (a heel rising) is not averaged away. A window's line follows the slow wander that
    smoothing leaves in noise, along which a foot standing for seconds would slide; a
    stance that moves no more than the noise could make it is held as standing (the
    noise's reach, ``within``, is what ``auto`` expects of the point: bench/footlock.py)."""
    starts = np.flatnonzero(contacts & ~np.r_[False, contacts[:-1]])
    if within <= 0.0 or not starts.size:
        return np.zeros(len(points), dtype=bool)
    off = np.sum((points - whole) ** 2, axis=-1).reshape(len(points), -1).max(axis=1)
    index = np.arange(len(points))
    first, last = bounds
    lo, hi = np.maximum(first, index - half), np.minimum(last, index + half) + 1
    spread = _window_sums(off, lo, hi) / (hi - lo)  # each frame's window
    mean = _window_sums(off, first, last + 1) / (last + 1 - first)  # its whole contact
    inside = np.flatnonzero(contacts)
    worst = np.maximum.reduceat(spread[inside], np.searchsorted(inside, starts))
    contact = np.searchsorted(starts, first)  # each contact frame's contact (from its start)
    calm = (
        (mean <= within * within)
        & (worst[np.minimum(contact, starts.size - 1)] <= ((WINDOW_REACH * within) ** 2))
        & (last + 1 - first >= STILL_MIN_WINDOWS * (2 * half + 1))
    )
    return contacts & calm


def _local_lines(
    points: np.ndarray,
    contacts: np.ndarray,
    half: int,
    passes: int,
    significance: float | None = None,
) -> np.ndarray:
    """:func:`held_lines` and :func:`held_paths`: on contact frames, the least-squares line
    through ``points`` weighted by ``passes`` averages over ``2 half + 1`` frames cut to the
    contact, evaluated at the frame; with ``significance``, its slope shrunk by its standard
    error (and none through fewer than three points); elsewhere the points. Time and place
    are taken from each contact's first frame: the running sums stay small."""
    index = np.arange(len(points))
    first, last = _run_bounds(contacts)
    lo = np.maximum(first, index - half)
    hi = np.minimum(last, index + half) + 1
    shape = (-1,) + (1,) * (points.ndim - 1)
    count = (hi - lo).astype(np.float64)

    def average(x: np.ndarray) -> np.ndarray:  # cut box averages: a kernel's weights
        for _ in range(passes):
            x = _window_sums(x, lo, hi) / count.reshape((-1,) + (1,) * (x.ndim - 1))
        return x

    origin = points[first]
    points = points - origin
    t = (index - first).astype(np.float64)
    t_mean, p_mean = average(t), average(points)
    t_var = average(t * t) - t_mean**2
    cov = average(t.reshape(shape) * points) - t_mean.reshape(shape) * p_mean
    steady = t_var > 1e-9
    if significance is not None:  # a slope needs a third point to be told from the scatter
        steady &= count > 2.0
    spread = np.maximum(t_var, 1e-9).reshape(shape)
    slope = np.where(steady.reshape(shape), cov / spread, 0.0)
    if significance is not None:
        p_var = average(points * points) - p_mean**2
        scatter = np.sum(np.maximum(p_var - slope * cov, 0.0), axis=-1, keepdims=True)
        error2 = scatter / (np.maximum(count - 2.0, 1.0).reshape(shape) * spread)
        length2 = np.sum(slope * slope, axis=-1, keepdims=True)
        error2 /= _independent_share(points, lo, hi, scatter, length2, count.reshape(shape))
        slope *= length2 / np.maximum(length2 + significance**2 * error2, 1e-300)
    line = p_mean + slope * (t - t_mean).reshape(shape)
    return origin + np.where(contacts.reshape(shape), line, points)


def _independent_share(
    points: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    scatter: np.ndarray,
    length2: np.ndarray,
    count: np.ndarray,
) -> np.ndarray:
    """The share of a window's ``count`` points that scatter independently about its line:
    the variance of the residuals' frame-to-frame steps over twice their variance
    (``scatter``; ``length2`` the slope's squared length, per frame^2), between ``1 /
    count`` and 1. White scatter gives 1; scatter a filter smoothed (a wander) gives the
    few independent points it holds, for which a slope's standard error is as wide as
    that many points make it: the wander's slope is not taken for a drift."""
    step = np.diff(points, axis=0, append=points[-1:])
    steps2 = np.sum(step * step, axis=-1, keepdims=True)
    pairs = np.maximum(hi - lo - 1, 1).astype(np.float64).reshape(count.shape)
    residual2 = np.maximum(_window_sums(steps2, lo, np.maximum(hi - 1, lo)) / pairs - length2, 0.0)
    share = residual2 / np.maximum(2.0 * scatter, np.finfo(float).tiny)
    return np.clip(share, 1.0 / np.maximum(count, 1.0), 1.0)


def _eases(
    contacts: np.ndarray, blend_frames: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per frame ``(F,)``: the last contact frame at or before it (-1: none), the next at
    or after it (F: none), and the smoothstep weights easing out of the one and into the
    other over ``blend_frames`` frames."""
    n = len(contacts)
    index = np.arange(n)
    last_in = np.maximum.accumulate(np.where(contacts, index, -1))
    next_in = np.minimum.accumulate(np.where(contacts, index, n)[::-1])[::-1]
    width = max(float(blend_frames), 1.0)

    def ease(distance: np.ndarray) -> np.ndarray:
        x = np.clip(1.0 - distance / (width + 1.0), 0.0, 1.0)
        return x * x * (3.0 - 2.0 * x)

    w_prev = np.where(last_in >= 0, ease(index - last_in), 0.0)
    w_next = np.where(next_in < n, ease(next_in - index), 0.0)
    return last_in, next_in, w_prev, w_next


def lock_targets(
    points: np.ndarray,
    contacts: np.ndarray,
    blend_frames: float,
    hold_frames: float = np.inf,
    path: bool = False,
    still_within: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Where one foot's points ``(F, k, 3)`` should be on each frame, and how strongly:
    ``(F, k, 3)`` and ``(F,)``.

    During a contact the target is :func:`held_lines` with weight 1 (a still contact's
    line within ``still_within``, length units, with weight :data:`STILL_FIRMNESS`; with
    ``path``, :func:`held_paths` with a kernel of :data:`TOE_SMOOTHING` times
    ``hold_frames``, or the contact's mean where that is infinite). Within
    ``blend_frames`` frames before a contact starts or after it ends, the weight eases from
    0 to the contact's (smoothstep) and the target moves from the points toward the
    contact's first or last target; where the ramps of two contacts overlap, the target is
    their weighted mean. Weight 0 elsewhere.
    """
    n = len(points)
    if not contacts.any():
        return points.copy(), np.zeros(n)
    if path and np.isfinite(hold_frames):
        held = held_paths(points, contacts, TOE_SMOOTHING * hold_frames)
        still = np.zeros(n, dtype=bool)
    else:
        held, still = _held_lines(points, contacts, hold_frames, still_within)
    last_in, next_in, w_prev, w_next = _eases(contacts, blend_frames)
    total = w_prev + w_next
    shape = (-1,) + (1,) * (points.ndim - 1)
    wp, wn = w_prev.reshape(shape), w_next.reshape(shape)
    prev_at, next_at = last_in.clip(0, n - 1), next_in.clip(0, n - 1)
    lock_prev, lock_next = held[prev_at], held[next_at]
    outside = np.where(
        (total > 1.0).reshape(shape),
        (wp * lock_prev + wn * lock_next) / np.maximum(total, 1e-300).reshape(shape),
        points + wp * (lock_prev - points) + wn * (lock_next - points),
    )
    target = np.where(contacts.reshape(shape), held, outside)
    # a stance held still is held more firmly, and eased into and out of from that
    firm = np.where(still, STILL_FIRMNESS, 1.0)
    eased = (w_prev * firm[prev_at] + w_next * firm[next_at]) / np.maximum(total, 1e-300)
    return target, np.where(contacts, firm, np.minimum(total, 1.0) * eased)


@dataclass(frozen=True)
class _Part:
    """The joints of a skeleton that a solve needs, as a skeleton of their own.

    ``index`` ``(Jc,)`` the joints (ascending, so parents come first), ``parents`` theirs
    within the part (-1 for its root), ``tips`` the part joints with an end site
    (ascending) and ``tip_offsets`` their offsets. The part's points are its joints, then
    those end sites.
    """

    index: np.ndarray
    parents: np.ndarray
    tips: np.ndarray
    tip_offsets: np.ndarray

    @classmethod
    def of(cls, parents: np.ndarray, tips: dict[int, np.ndarray], points: list[int]) -> _Part:
        """The joints ``points`` (joints, then the end sites of ``tips``' joints, ascending)
        hang on, and every joint above them."""
        index = hung_on(parents, sorted(tips), np.asarray(points, dtype=np.intp))
        rank = {j: c for c, j in enumerate(index.tolist())}
        local = np.array([rank.get(int(parents[j]), -1) for j in index.tolist()], dtype=np.intp)
        tip_joints = [j for j in sorted(tips) if j in rank]
        return cls(
            index=index,
            parents=local,
            tips=np.array([rank[j] for j in tip_joints], dtype=np.intp),
            tip_offsets=np.array([tips[j] for j in tip_joints], dtype=np.float64).reshape(-1, 3),
        )

    def joint(self, joint: int) -> int:
        """The part's number of a joint of the whole skeleton (one of :attr:`index`)."""
        return int(np.searchsorted(self.index, joint))

    def point(self, point: int, n_joints: int, tip_joints: list[int]) -> int:
        """The part's number of a point of the whole skeleton (``n_joints`` joints, then
        end sites on ``tip_joints``, ascending)."""
        if point < n_joints:
            return self.joint(point)
        joint = self.joint(tip_joints[point - n_joints])
        return self.index.size + int(np.searchsorted(self.tips, joint))

    def arrays(
        self, rotations: np.ndarray, translations: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The part's local rotations and translations ``(F, Jc, ...)`` taken from the
        whole skeleton's ``(F, J, ...)``."""
        return rotations[:, self.index], translations[:, self.index]

    def write_back(
        self,
        into: tuple[np.ndarray, np.ndarray],
        frames: np.ndarray,
        solved: tuple[np.ndarray, np.ndarray],
        reference: np.ndarray,
    ) -> None:
        """Put the part's solved rotations and root translation ``solved`` of ``frames``
        into the whole skeleton's rotations ``(F, J, 4)`` and root translations ``(F, 3)``
        ``into``, each rotation on the sign of ``reference`` ``(F, J, 4)``."""
        q, t = solved
        into[0][frames[:, None], self.index] = quat.same_sign(
            q, reference[frames[:, None], self.index]
        )
        into[1][frames] = t[:, 0]


@dataclass(frozen=True)
class _Problem:
    """The fixed parts of a solve on a part: variables, held points and what moves what."""

    joints: np.ndarray  # (V,) part joints that turn
    hinge: np.ndarray  # (V,) bool: turns about a hinge (1 column) instead of freely (3)
    hinges: np.ndarray  # (V, 3) hinge axis in the parent's frame (unused for free joints)
    columns: np.ndarray  # (V,) first column of each joint's change
    axes: np.ndarray  # (T,) root translation axes that move
    n_columns: int
    prior: np.ndarray  # (n_columns,) 1 / the variance a column's change is weighed by
    expected: np.ndarray  # (n_columns,) the expected variance of each column's error
    points: np.ndarray  # (K,) held points of the part (joints, then end sites)
    point_joint: np.ndarray  # (K,) the part joint each point hangs on (itself for a joint)
    moves: np.ndarray  # (K, V) bool: joint v's rotation moves point k


def _problem(
    part: _Part,
    turns: set[int],
    hinges: dict[int, np.ndarray],
    points: list[int],
    sigma: np.ndarray,
    root: np.ndarray,
) -> _Problem:
    """Holding the part's ``points`` by turning its joints ``turns`` (``hinges``: joint ->
    axis, for those that turn about one), each with the expected RMS error ``sigma``
    ``(Jc,)`` (radians; a hinge's change weighed by :data:`HINGE_SHARE` of its variance),
    and moving the part's first root along the axes where ``root`` ``(3,)`` (its expected
    error per axis, length units) is not 0."""
    depth = depths(part.parents)
    # columns: the root's axes, then the free joints' (3 each), then the hinges' (1 each)
    used = sorted(turns, key=lambda j: (j in hinges, depth[j], j))
    hinge = np.array([j in hinges for j in used], dtype=bool)
    axes = np.flatnonzero(root > 0.0)
    widths = np.where(hinge, 1, 3)
    columns = axes.size + np.concatenate([[0], np.cumsum(widths)[:-1]]).astype(np.intp)
    variance = (
        np.concatenate([root[axes] ** 2, np.repeat(sigma[used] ** 2, widths)]) / 3.0
    )  # per component of a 3-D error
    share = np.concatenate(
        [np.ones(axes.size), np.repeat(np.where(hinge, HINGE_SHARE, 1.0), widths)]
    )
    held = np.array(points, dtype=np.intp)
    n_joints = part.index.size
    point_joint = np.where(
        held < n_joints, held, part.tips[np.maximum(held - n_joints, 0)] if part.tips.size else 0
    )
    rank = {j: v for v, j in enumerate(used)}
    moves = np.zeros((held.size, len(used)), dtype=bool)
    for k, (point, joint) in enumerate(zip(held.tolist(), point_joint.tolist(), strict=True)):
        j = joint if point >= n_joints else int(part.parents[joint])
        while j >= 0:  # the joints above the point (and its own, for an end site)
            if j in rank:
                moves[k, rank[j]] = True
            j = int(part.parents[j])
    return _Problem(
        joints=np.array(used, dtype=np.intp),
        hinge=hinge,
        hinges=np.array([hinges.get(j, np.zeros(3)) for j in used]).reshape(-1, 3),
        columns=columns,
        axes=axes,
        n_columns=int(axes.size + widths.sum()),
        prior=1.0 / np.maximum(variance * share, MIN_SIGMA**2),
        expected=np.maximum(variance, MIN_SIGMA**2),
        points=held,
        point_joint=point_joint,
        moves=moves,
    )


@dataclass(frozen=True)
class _Rows:
    """What a solve asks of its held points, per frame ``F`` and point ``K``: the horizontal
    position on ``targets`` ``(F, K, 3)`` with weight ``hold_weight`` ``(F, K)`` (the blend
    of :func:`lock_targets`, 0 to 1, :data:`STILL_FIRMNESS` on a still stance: the rows'
    precision grows with it, so a point eases into its hold instead of being pinned from
    the ramp's first frame), within ``tolerance``
    ``(K,)`` (length units); not below the floor ``(normal, offset)`` where ``grounded``,
    within ``floor_tolerance`` ``(K,)``. ``up`` is the up axis; a target further from a
    point than ``robust`` times the error the prior predicts for it is followed less
    (Huber weights)."""

    targets: np.ndarray
    hold_weight: np.ndarray
    grounded: np.ndarray
    tolerance: np.ndarray
    floor_tolerance: np.ndarray
    floor: tuple[np.ndarray, float]
    up: int
    robust: float

    def take(self, frames: np.ndarray | slice) -> _Rows:
        """The rows of ``frames``."""
        return replace(
            self,
            targets=self.targets[frames],
            hold_weight=self.hold_weight[frames],
            grounded=self.grounded[frames],
        )


def plant(
    rotations: np.ndarray,
    translations: np.ndarray,
    parents: np.ndarray,
    tips: dict[int, np.ndarray],
    legs: list[Leg],
    contacts: np.ndarray,
    prior: Prior,
    up: int,
    floor: tuple[np.ndarray, float],
    tolerance: float,
    blend_frames: float,
    hold_frames: float = np.inf,
    toe_contacts: np.ndarray | None = None,
    toe_tolerance: float = TOE_TOLERANCE,
    robust: float = 3.0,
    still_within: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations ``(F, J, 4)`` and root translations ``(F, 3)`` with every leg planted
    during its ``contacts`` ``(F, n_legs)``, and the toes of each leg with a ``foot`` held
    during ``toe_contacts`` ``(F, n_toes)`` (a column per toe point of those legs, in
    order; default: their leg's contacts).

    ``translations`` ``(F, J, 3)`` are the local translations (offsets where a joint has
    no position channel, :func:`motionclean.core.kinematics.local_translations`);
    ``tips`` joint -> end-site offset; ``up`` the up axis (0, 1, 2); ``floor`` ``(n, d)``:
    a point ``p`` is below the floor where ``n . p < d``; ``tolerance`` (length units) how
    closely the ankle follows its target and keeps above the floor (the toes follow theirs
    ``toe_tolerance`` times as loosely, and keep above the floor :data:`FLOOR_FIRMNESS`
    times as closely, while their leg or the toe itself is in contact); a target further
    from a point than ``robust`` times the error the prior predicts for it is taken as
    motion, not noise, and followed less (Huber weights). ``still_within`` ``(n_legs,)``
    (length units): a stance (a contact of at least :data:`STILL_MIN_WINDOWS` hold
    windows) whose ankle stays that close to one line through it is held on that line,
    :data:`STILL_FIRMNESS` times as firmly (:func:`held_lines`; default: none is). Frames
    where nothing is held, and every joint that does not turn, are returned bit for bit;
    the root (the first joint of the legs) moves only along ``prior.root``'s non-zero axes.
    """
    out_q = rotations.copy()
    if not legs:
        return out_q, translations[:, 0].copy()
    ankles = [leg.points[0] for leg in legs]
    part = _Part.of(parents, tips, ankles)
    out_t = translations[:, part.index[0]].copy()  # the part's first joint: the legs' root
    problem = _problem(
        part,
        {part.joint(j) for leg in legs for j in leg.joints},
        {part.joint(leg.knee): leg.hinge for leg in legs},
        [part.joint(a) for a in ankles],
        prior.sigma[part.index],
        prior.root,
    )
    q, t = part.arrays(rotations, translations)
    start = forward_arrays(part.parents, q, t)[0][:, problem.points]
    targets = np.empty_like(start)
    weights = np.zeros(contacts.shape)
    stills = np.zeros(len(legs)) if still_within is None else np.asarray(still_within, float)
    for k in range(len(legs)):  # a leg at a time, vectorised over frames
        targets[:, k], weights[:, k] = lock_targets(
            start[:, k], contacts[:, k], blend_frames, hold_frames, still_within=stills[k]
        )
    rows = _Rows(
        targets,
        weights,
        contacts,
        np.full(len(legs), tolerance),
        np.full(len(legs), tolerance),
        floor,
        up,
        robust,
    )
    frames = np.flatnonzero(rows.hold_weight.any(axis=1))
    q, t = q[frames], t[frames]
    toe_legs = [k for k, _ in held_toes(legs)]
    toes_held = contacts[:, toe_legs] if toe_contacts is None else toe_contacts
    # where a toe is held, the toes' solve goes on from this one with the ankles' rows too
    iterations = ANKLE_ITERATIONS_BEFORE_TOES if toes_held.any() else ITERATIONS
    total = _solve_frames(q, t, part, problem, rows.take(frames), iterations)
    part.write_back((out_q, out_t), frames, (q, t), rotations)
    if toe_legs:
        toes = _Toes(toes_held, tolerance * toe_tolerance, toe_legs)
        out_q, out_t = _hold_toes(
            (rotations, translations),
            _Planted(out_q, out_t, frames, total, _column_keys(part, problem)),
            parents,
            tips,
            legs,
            rows,
            toes,
            prior,
            blend_frames,
            hold_frames,
        )
    return out_q, out_t


def _column_keys(part: _Part, problem: _Problem) -> list[tuple[int, int]]:
    """Each column's variable, the same in any part: ``(-1, axis)`` for the root's
    translation, ``(joint, component)`` for a free joint's change (``joint`` of the
    skeleton), ``(joint, -1)`` for a hinge's angle."""
    keys: list[tuple[int, int]] = [(-1, int(a)) for a in problem.axes]
    for v, joint in enumerate(part.index[problem.joints].tolist()):
        assert problem.columns[v] == len(keys)  # columns in the order of the joints
        keys += [(joint, -1)] if problem.hinge[v] else [(joint, c) for c in range(3)]
    return keys


@dataclass(frozen=True)
class _Planted:
    """The ankles' solve: rotations ``(F, J, 4)`` and root translations ``(F, 3)``, the
    frames it changed, its change on them ``(n, C)`` and each column's variable
    (:func:`_column_keys`)."""

    rotations: np.ndarray
    root: np.ndarray
    frames: np.ndarray
    total: np.ndarray
    keys: list[tuple[int, int]]


@dataclass(frozen=True)
class _Toes:
    """The toe points' contacts ``(F, n_toes)``, how closely they follow their paths
    (length units) and each toe point's leg (its index in the legs planted)."""

    contacts: np.ndarray
    tolerance: float
    legs: list[int]


def _hold_toes(
    given: tuple[np.ndarray, np.ndarray],
    planted: _Planted,
    parents: np.ndarray,
    tips: dict[int, np.ndarray],
    legs: list[Leg],
    ankle_rows: _Rows,
    toes: _Toes,
    prior: Prior,
    blend_frames: float,
    hold_frames: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The rotations and root translations of ``planted`` (the ankles' solve of ``given``,
    its local rotations and translations ``(F, J, ...)``; written in place) with the toes
    held too: the ankles' rows of :func:`plant` (``ankle_rows``) and, for each toe point of
    the legs with a ``foot``, its own path while it is planted (its track once the ankles
    stand, :func:`held_paths`; the contact's mean with an infinite ``hold_frames``), by the
    legs' joints and their ``foot`` joints; the prior stays centred on ``given``, the solve
    starts where the ankles' left it, on every frame the ankles' solve changed and every
    frame that holds a toe or finds one below the floor; the others keep ``planted``."""
    rotations, translations = given
    n_joints = len(parents)
    tip_joints = sorted(tips)
    ankles = [leg.points[0] for leg in legs]
    toe_points = [p for _, p in held_toes(legs)]
    part = _Part.of(parents, tips, [*ankles, *toe_points])
    problem = _problem(
        part,
        {part.joint(j) for leg in legs for j in (*leg.joints, *leg.foot)},
        {part.joint(leg.knee): leg.hinge for leg in legs},
        [part.point(p, n_joints, tip_joints) for p in (*ankles, *toe_points)],
        prior.sigma[part.index],
        prior.root,
    )
    q, t = part.arrays(planted.rotations, translations)
    t[:, 0] = planted.root  # the part's first joint is the legs' root
    track = _points(*forward_arrays(part.parents, q, t), problem, part.tip_offsets)
    track = track[:, len(ankles) :]
    targets = np.empty_like(track)
    weights = np.zeros(toes.contacts.shape)
    for k in range(len(toe_points)):  # a point at a time, vectorised over frames
        targets[:, k], weights[:, k] = lock_targets(
            track[:, k], toes.contacts[:, k], blend_frames, hold_frames, path=True
        )
    # the toes keep above the floor while their leg or they themselves stand
    grounded = toes.contacts | ankle_rows.grounded[:, toes.legs]
    normal, level = ankle_rows.floor
    tolerance = ankle_rows.tolerance[0]
    toe_floor = tolerance * FLOOR_FIRMNESS
    below = _below_floor(track @ normal - level, toe_floor, grounded)
    # every frame the ankles' solve changed too: each gets the same iterations (no step
    # where the toes' hold begins; a toe held somewhere asks for some frame: no early out)
    asked = ((weights > 0.0) | below).any(axis=1)
    if not asked.any():
        return planted.rotations, planted.root
    asked[planted.frames] = True
    frames = np.flatnonzero(asked)
    n_ankles, n_toes = len(ankles), len(toe_points)
    rows = _Rows(
        np.concatenate([ankle_rows.targets, targets], axis=1),
        np.concatenate([ankle_rows.hold_weight, weights], axis=1),
        np.concatenate([ankle_rows.grounded, grounded], axis=1),
        np.r_[np.full(n_ankles, tolerance), np.full(n_toes, toes.tolerance)],
        np.r_[np.full(n_ankles, tolerance), np.full(n_toes, toe_floor)],
        ankle_rows.floor,
        ankle_rows.up,
        ankle_rows.robust,
    ).take(frames)
    # warm start: the ankles' change, placed in this solve's columns
    column = {key: c for c, key in enumerate(_column_keys(part, problem))}
    into = np.array([column[key] for key in planted.keys], dtype=np.intp)
    total = np.zeros((frames.size, problem.n_columns))
    total[np.ix_(np.searchsorted(frames, planted.frames), into)] = planted.total  # (a subset)
    q, t = q[frames], t[frames]
    _solve_frames(q, t, part, problem, rows, TOE_ITERATIONS, total)
    # plant's own arrays, written in place
    part.write_back((planted.rotations, planted.root), frames, (q, t), rotations)
    return planted.rotations, planted.root


def _points(
    positions: np.ndarray, world: np.ndarray, problem: _Problem, tip_offsets: np.ndarray
) -> np.ndarray:
    """``(F, K, 3)`` world positions of the held points from joint positions and world
    rotations ``(F, Jc, ...)`` of a part."""
    n_joints = positions.shape[1]
    out = positions[:, problem.point_joint].copy()
    tip = problem.points >= n_joints
    if tip.any():
        offsets = tip_offsets[problem.points[tip] - n_joints]
        out[:, tip] += quat.rotate(world[:, problem.point_joint[tip]], offsets)
    return out


def _solve_frames(
    q: np.ndarray,
    t: np.ndarray,
    part: _Part,
    problem: _Problem,
    rows: _Rows,
    iterations: int = ITERATIONS,
    total: np.ndarray | None = None,
) -> np.ndarray:
    """:func:`_solve` over blocks of :data:`BLOCK_FRAMES` frames (bounds the per-frame
    systems' memory): ``q`` and ``t`` are solved in place; returns the change made ``(F,
    C)`` (``total``, if given, updated in place)."""
    total = np.zeros((len(q), problem.n_columns)) if total is None else total
    for at in range(0, len(q), BLOCK_FRAMES):
        block = slice(at, at + BLOCK_FRAMES)
        frames = np.arange(at, min(at + BLOCK_FRAMES, len(q)))
        _solve(q[block], t[block], part, problem, rows.take(frames), iterations, total[block])
    return total


def _solve(
    q: np.ndarray,
    t: np.ndarray,
    part: _Part,
    problem: _Problem,
    rows: _Rows,
    iterations: int,
    total: np.ndarray,
) -> None:
    """The Gauss-Newton solve of :func:`plant` on a block of frames of a part, in place:
    local rotations and translations ``(F, Jc, ...)`` and the change they hold ``(F, C)``
    (each variable's column; zero, or a warm start: the prior stays centred where they
    were before it)."""
    parents = part.parents
    normal, level = rows.floor
    directions = np.stack([np.eye(3)[a] for a in range(3) if a != rows.up] + [normal])
    n_frames, n_points = rows.targets.shape[:2]
    scale = np.stack([rows.tolerance, rows.tolerance, rows.floor_tolerance], axis=-1)
    scale = 1.0 / scale.ravel() ** 2  # per row: two along the ground, one off the floor
    huber = None
    below = np.zeros((n_frames, n_points), dtype=bool)
    free = ~problem.hinge
    spread = 1.0 / problem.prior  # the variance each column's change is weighed by
    for _ in range(iterations):
        positions, world = forward_arrays(parents, q, t)
        points = _points(positions, world, problem, part.tip_offsets)  # (F, K, 3)
        residual = np.einsum("fkc,dc->fkd", rows.targets - points, directions)  # (F, K, 3)
        height = points @ normal - level
        # a point found below the floor is held on it from then on (the active set only
        # grows: it cannot flip back and forth between iterations)
        below = below | _below_floor(height, rows.floor_tolerance, rows.grounded)
        residual[..., 2] = np.where(below, -height, 0.0)
        active = np.concatenate(
            [np.repeat(rows.hold_weight[..., None], 2, axis=-1), below[..., None]], axis=-1
        ).reshape(n_frames, -1)
        # rows no frame of the block asks for (a floor no point went below) are left out
        asked = np.flatnonzero(active.any(axis=0))
        jac = _jacobian(positions, world, points, parents, problem, directions, asked)
        # the residual seen from the prior's centre (the input), linearised here
        from_input = residual.reshape(n_frames, -1)[:, asked] + (jac @ total[..., None])[..., 0]
        if huber is None:  # from the input: a target far beyond the noise is motion
            predicted = np.zeros((n_frames, n_points * 3))
            predicted[:, asked] = np.sqrt((jac * jac) @ problem.expected)
            off = np.zeros((n_frames, n_points * 3))
            off[:, asked] = from_input
            # per point, along the ground (a sum over both horizontal rows: invariant)
            spread_h = np.sqrt(np.sum(predicted.reshape(n_frames, n_points, 3)[..., :2] ** 2, -1))
            off_h = np.sqrt(np.sum(off.reshape(n_frames, n_points, 3)[..., :2] ** 2, -1))
            weight = np.ones((n_frames, n_points, 3))  # the floor rows keep 1: no guess
            weight[..., :2] = np.minimum(1.0, rows.robust * spread_h / np.maximum(off_h, 1e-300))[
                ..., None
            ]
            huber = weight.reshape(n_frames, -1)
        # the solve in the rows' space (at most 3 per held point, fewer than the columns):
        # z = P^-1 A^T (I + A P^-1 A^T)^-1 b with A = sqrt(M) J, b = sqrt(M) (e + J total)
        root_precision = np.sqrt(active[:, asked] * huber[:, asked] * scale[asked])
        a = jac * root_precision[..., None]
        spread_rows = a * spread
        gram = spread_rows @ a.transpose(0, 2, 1)
        gram[:, np.arange(gram.shape[1]), np.arange(gram.shape[1])] += 1.0
        target = root_precision * from_input
        mixed = np.linalg.solve(gram, target[..., None])
        step = (spread_rows.transpose(0, 2, 1) @ mixed)[..., 0] - total
        step *= _step_share(step, problem)[:, None]
        total += step
        t[:, 0, problem.axes] += step[:, : problem.axes.size]
        change = np.zeros((n_frames, problem.joints.size, 3))
        starts = problem.columns
        change[:, free] = step[:, starts[free, None] + np.arange(3)]
        parent_world = np.where(
            (parents[problem.joints] >= 0)[None, :, None],
            world[:, np.maximum(parents[problem.joints], 0)],
            quat.identity(),
        )
        change[:, free] = quat.rotate(quat.conjugate(parent_world[:, free]), change[:, free])
        change[:, problem.hinge] = (
            step[:, starts[problem.hinge], None] * problem.hinges[problem.hinge]
        )
        turned = quat.normalize(quat.multiply(quat.exp(0.5 * change), q[:, problem.joints]))
        moved = np.any(step != 0.0, axis=1)[:, None, None]  # a frame nothing asks of: as it was
        q[:, problem.joints] = np.where(moved, turned, q[:, problem.joints])


def _step_share(step: np.ndarray, problem: _Problem) -> np.ndarray:
    """``(F,)``: the share of each frame's Gauss-Newton ``step`` ``(F, C)`` taken, so that
    no joint turns by more than :data:`MAX_TURN` radians in one iteration (the solve is
    linearised: a longer step lands far from where it aimed)."""
    starts = problem.columns
    free = ~problem.hinge
    turns = np.zeros((len(step), problem.joints.size))
    turns[:, free] = np.linalg.norm(step[:, starts[free, None] + np.arange(3)], axis=-1)
    turns[:, problem.hinge] = np.abs(step[:, starts[problem.hinge]])
    largest = turns.max(axis=1, initial=0.0)
    return MAX_TURN / np.maximum(largest, MAX_TURN)  # (1 where no joint turns past it)


def _jacobian(
    positions: np.ndarray,
    world: np.ndarray,
    points: np.ndarray,
    parents: np.ndarray,
    problem: _Problem,
    directions: np.ndarray,
    rows: np.ndarray,
) -> np.ndarray:
    """``(F, R, C)``: how each held point moves along a row direction per column, for the
    ``rows`` ``(R,)`` asked (ascending; row ``3 k + d`` is point ``k`` along ``directions[d]``).

    A rotation ``w`` (world axes) of joint ``v`` moves a point below it by ``w x (p -
    p_v)``: along ``u`` by ``w . ((p - p_v) x u)``; a hinge's column is that along its
    world axis ``h``, ``(p - p_v) . (u x h)``; a root translation column moves every point
    by its axis."""
    n_frames, n_points = points.shape[:2]
    n_axes, n_columns = problem.axes.size, problem.n_columns
    at = np.full(n_points * 3, -1)  # each row's place among those asked
    at[rows] = np.arange(rows.size)
    jac = np.zeros((n_frames, rows.size, n_columns))
    jac[..., :n_axes] = directions[rows % 3][:, problem.axes]
    point, joint = np.nonzero(problem.moves)  # the pairs (k, v) where v moves k
    arm = points[:, point] - positions[:, problem.joints[joint]]  # (F, P, 3)
    place = at[point[:, None] * 3 + np.arange(3)]  # (P, 3): each pair's rows' places
    flat = jac.reshape(n_frames, -1)
    hinge = problem.hinge[joint]
    if not hinge.all():
        free = ~hinge
        columns = problem.columns[joint[free], None, None] + np.arange(3)  # (Pf, 1, 3)
        into = (place[free][..., None] * n_columns + columns).ravel()  # (Pf * 9,)
        kept = np.repeat(place[free].ravel() >= 0, 3)
        values = np.cross(arm[:, free, None, :], directions).reshape(n_frames, -1)
        flat[:, into[kept]] = values[:, kept]
    if hinge.any():
        hinged = problem.joints[joint[hinge]]
        axis = quat.rotate(world[:, parents[hinged]], problem.hinges[joint[hinge]])  # (F, Ph, 3)
        across = np.cross(directions[None, None], axis[:, :, None])  # (F, Ph, 3, 3): u x h
        into = (place[hinge] * n_columns + problem.columns[joint[hinge], None]).ravel()
        kept = place[hinge].ravel() >= 0
        values = np.einsum("fpc,fpdc->fpd", arm[:, hinge], across).reshape(n_frames, -1)
        flat[:, into[kept]] = values[:, kept]
    return jac


def _below_floor(height: np.ndarray, floor_tolerance: np.ndarray, grounded: np.ndarray):
    """Points ``(F, K)`` held on the floor: under it (``height``, length units) by more
    than :data:`FLOOR_SLACK` times their ``floor_tolerance`` ``(K,)`` while ``grounded``."""
    return (height < -FLOOR_SLACK * floor_tolerance) & grounded
