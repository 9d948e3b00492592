"""Filling tracker dropouts: a smooth, coordinate-invariant bridge across each gap.

A gap of joint ``j`` is a run of missing frames between known frames ``a`` and ``b``. What is
bridged is the joint's pose relative to a *donor*: another joint tracked throughout, or the
world frame (no donor). With donor rotation ``d`` and position ``c``, the relative pose is
``r = d^-1 q`` and ``s = d^-1 (p - c) d`` (``p`` rotated into the donor's frame); a hand
seen from its forearm moves far less than in the world, so its bridge follows the forearm
through the gap, as a pattern fill does. Per gap the rotation's donor is the one whose
relative rotation is smoothest (least squared second differences) over
:data:`DONOR_FRAMES` frames on each side, and the position's the one whose relative
position is (over :data:`POSITION_DONOR_FRAMES`), at any gap length: whether it helps is
checked on the joint's own data, as the bridge is (below).

The relative pose is bridged by the C1 cubic of :mod:`.interpolate` from frame ``a`` to
frame ``b`` (``r_a exp(h(u))``, ``u = (f - a) / (b - a)``; positions the matching Hermite
cubic): position and velocity continuous at both edges. Edge velocities come from a
least-squares quadratic through the edge sample and up to :data:`EDGE_FRAMES` known frames
beside it (in the tangent space at the edge sample), pulled toward the chord across the gap
by as much as noise explains of one edge's departure (James-Stein, :func:`_shrunk`) and,
for rotations, to each joint's Wiener share of their departure from it (motion over motion
and noise, measured on the joint's own frames taken as edges, :func:`_velocity_keep`) or
the weight that fills its own gaps of that length best, whichever is larger
(:func:`_fill_share`). The
noise is the joint's white noise, estimated from its third differences
(:func:`noise_and_motion_variance`). Only displacements between samples of the same
joint, and poses relative to another joint, enter: the fill commutes with a fixed rotation
of the world (and of each body's own frame).

Under tracker noise the edge samples themselves are off by the noise, and every bridge
through them (slerp too) carries it into the gap. Two smoothed bridges leave them: the
same cubic between the edges where a local fit puts them (a smoothing spline with a
third-difference penalty, a local quadratic, over the edge and :data:`SPLINE_FRAMES`
frames beyond; :func:`_smoothed_edge`), and for gaps of up to :data:`SPLINE_MAX_GAP`
frames the discrete cubic smoothing spline through :data:`SPLINE_FRAMES` known frames on
each side (Whittaker-Henderson, second differences, ``lambda`` the noise variance over
the motion's; :func:`_spline_bridge`). Their departure from the edge samples is of the
size of the noise.

Which bridge fills a gap, and whether the donor helps at all, is checked on the joint's
own data (:func:`_validated`): gaps of the same length are planted in the known frames
beside each gap (up to :data:`TRIALS_PER_SIDE` on each side) and bridged every way, with
the donors and without (the rotation and the position each choose), with the edge
velocities' departure from the chord weighted by each of :data:`VELOCITY_WEIGHTS` (0: the
straight line, geodesic at constant angular velocity).
The one of least error there fills the gap, the straight line unless another (or the
donor) beats it by :data:`LINE_MARGIN`; then its smoothed-edge twin, and the smoothing
spline, where they do better on the gap's trials and on those of the joint's other gaps
of similar length. A clean optical capture keeps its velocities and its edge samples
(they predict its gaps well); a markerless estimate, whose edge velocities are mostly its
noise, gets the straight line; a tracker with white noise gets smoothed bridges; a joint
that does not move with its would-be donor (a hip and an elbow, a hand and the head) is
bridged on its own, and so is one that moves with it beside the gap but not over the
clip (:func:`_moving_with`). A gap with no room for a trial takes what fills the joint's
other gaps of similar length best, unless it has a donor (:func:`_pooled_for_untried`).

A gap at the start or end of the clip has one edge: the relative pose at that edge is held
(with no donor: the edge sample itself; extrapolating a rotation at its edge velocity for
half a second could spin it anywhere). Its donors are checked as a bridge's are, on gaps of
the same length planted beside it and held from the same side (:func:`_held_donors`): a
donor is kept only where it holds them :data:`LINE_MARGIN` better than the edge sample
(under tracker noise a donor adds its own noise to every held frame).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..core import checks, quat
from ..core.motion import mask_runs, missing_before
from .interpolate import end_tangent, hermite_positions, hermite_rotations

#: Known frames beside an edge that its velocity is fitted to ...
EDGE_FRAMES = 3
#: ... and that donors are judged on, for the rotation and for the position.
DONOR_FRAMES = 10
POSITION_DONOR_FRAMES = 8
#: Median of a chi-squared variable with three degrees of freedom.
CHI2_3_MEDIAN = 2.3660
#: Gaps handled at a time when choosing donors (temporaries stay small).
GAP_BLOCK = 256
#: Most steps a joint's motion with a would-be donor is measured on (spread over the clip),
#: and the steps of all pairs measured at a time (temporaries stay small).
MOVING_WITH_STEPS = 1024
PAIR_BLOCK = 1 << 18
#: Frames taken as edges when weighing a joint's edge velocities against its noise, and the
#: key of a (joint, gap length class) pair, ``joint * KEY + length``; gap lengths are
#: weighed in classes a factor ``2 ** (1 / LENGTH_CLASSES)`` apart.
KEEP_SAMPLES = 1024
KEY = 1 << 32
LENGTH_CLASSES = 2
#: Edge-velocity weights a gap's bridge may take (0: the straight line, 1: the edges'
#: fitted velocities), chosen per gap on gaps of its length planted beside it ...
VELOCITY_WEIGHTS = (0.0, 0.5, 1.0)
#: ... up to this many on each side. A bridge using the edge velocities, or the donor, must
#: beat the straight line by this share of its error there to be taken (the trials are few,
#: and beside a real dropout the tracker was already losing the body).
TRIALS_PER_SIDE = 2
LINE_MARGIN = 0.2
#: The "weight" that stands for the smoothing-spline bridge among the options
#: (:func:`_bridge`) ...
SPLINE = -1.0
#: ... fitted to up to this many known frames beside each edge (and the edge), as the local
#: fit of the smoothed edges is, for gaps of up to :data:`SPLINE_MAX_GAP` frames (under
#: noise it beats slerp on short gaps; on longer ones the edge velocities or the straight
#: line do better, and its system grows with the gap).
SPLINE_FRAMES = 8
SPLINE_MAX_GAP = 32
#: The smoothing spline's ``lambda`` stays within these bounds (a clean signal: nearly an
#: interpolating spline; pure noise: nearly the least-squares line through the window).
SPLINE_LAMBDA = (1e-6, 1e4)
#: The spline replaces the chosen bridge where it does better on the gap's own trials and
#: this share better (geometric mean) on those of the joint's gaps of similar length.
SPLINE_MARGIN = 0.1


@dataclass(frozen=True)
class Gaps:
    """Runs of missing frames: ``joint``, ``first`` and ``stop`` (frames ``first ..
    stop-1``) per gap, in joint-major order."""

    joint: np.ndarray
    first: np.ndarray
    stop: np.ndarray

    @classmethod
    def of(cls, missing: np.ndarray) -> Gaps:
        """The gaps of a ``(F, J)`` bool mask."""
        return cls(*mask_runs(missing))

    @property
    def lengths(self) -> np.ndarray:
        return self.stop - self.first

    def select(self, keep: np.ndarray) -> Gaps:
        return Gaps(self.joint[keep], self.first[keep], self.stop[keep])


@dataclass(frozen=True)
class _Stats:
    """What the bridges of one signal (rotations or positions) need to know of each joint:
    per-sample ``noise`` variance and the second differences' variance ``motion`` per
    component (:func:`noise_and_motion_variance`), and the share ``keep`` of the fitted edge
    velocities' departure from the chord kept, per joint and gap length (``key``: ``joint *
    KEY + length``, sorted): the Wiener share of it that is motion rather than noise
    (:func:`_velocity_keep`) or, if larger, the weight that fills the joint's own gaps of
    that length best (:func:`_fill_share`). Positions keep all of it (their per-edge
    shrinkage only): measured on the corpus with tracker noise, the Wiener share cost their
    fills of 12-60 frames up to 7 %, while it spares rotations the noisy velocities of long
    gaps."""

    noise: np.ndarray
    motion: np.ndarray
    key: np.ndarray
    keep: np.ndarray

    @classmethod
    def of(
        cls, x: np.ndarray, missing: np.ndarray, seen: np.ndarray, rotations: bool, gaps: Gaps
    ) -> _Stats:
        """``seen``: :func:`~motionclean.core.motion.missing_before` of ``missing``."""
        noise, motion = noise_and_motion_variance(x, missing, rotations)
        key = np.unique(gaps.joint * KEY + _length_class(gaps.lengths))
        keep = np.ones(key.size)
        if rotations:
            joint, length = key // KEY, key % KEY
            keep = np.maximum(
                _velocity_keep(x, missing, seen, rotations, noise, joint, length),
                _fill_share(x, seen, rotations, noise, joint, length),
            )
        return cls(noise, motion, key, keep)

    def keep_of(self, joint: np.ndarray, length: np.ndarray) -> np.ndarray:
        wanted = joint * KEY + _length_class(length)
        at = np.minimum(np.searchsorted(self.key, wanted), self.key.size - 1)
        return np.where(self.key[at] == wanted, self.keep[at], 1.0)


def _length_class(length: np.ndarray) -> np.ndarray:
    """The gap length standing for ``length``'s class (:data:`LENGTH_CLASSES`)."""
    exponent = np.round(LENGTH_CLASSES * np.log2(np.maximum(length, 1)))
    return np.round(2.0 ** (exponent / LENGTH_CLASSES)).astype(np.int64)


@dataclass(frozen=True)
class Filled:
    """What :func:`fill_gaps` did: the arrays with the gaps filled, the mask of what is
    still missing, the gaps found, which were filled and each filled gap's donors ``(2, G)``
    for its rotation and its position (-1: the world frame)."""

    rotations: np.ndarray
    translations: np.ndarray
    missing: np.ndarray
    gaps: Gaps
    filled: np.ndarray
    donor: np.ndarray


# ----------------------------------------------------------------------------- bridging


def _edge_weights(count: int) -> np.ndarray:
    """Weights ``w_k`` (``k = 1 .. count``) with ``sum w_k x_k`` the slope at ``k = 0`` of
    the least-squares quadratic through ``(0, 0)`` and ``(k, x_k)`` (a line for one point)."""
    k = np.arange(1, count + 1, dtype=np.float64)
    basis = np.stack([k, k * k], axis=1) if count >= 2 else k[:, None]
    return np.linalg.pinv(basis)[0]


def _rotation_log(base: np.ndarray, other: np.ndarray) -> np.ndarray:
    return quat.log_shortest(quat.relative(base, other))


def _position_log(base: np.ndarray, other: np.ndarray) -> np.ndarray:
    return other - base


def _edge_velocity(x, edge, room, direction, log_of) -> tuple[np.ndarray, np.ndarray]:
    """Velocity per frame at rows ``edge`` of the flat signal ``x``, fitted to up to
    :data:`EDGE_FRAMES` of the ``room`` known rows on the side away from the gap
    (``direction`` -1: before the edge, +1: after), and the factor that turns the per-sample
    noise variance into that velocity's (zero where there is no room)."""
    out, gain = np.zeros((edge.size, 3)), np.zeros(edge.size)
    count = np.minimum(room, EDGE_FRAMES)
    for n in np.unique(count[count > 0]):  # a few distinct counts
        at = np.flatnonzero(count == n)
        weights = _edge_weights(int(n))
        slope = _slope_sum(x, x[edge[at]], edge[at], slice(None), direction, log_of, weights)
        out[at] = direction * slope
        gain[at] = _edge_gain(weights)
    return out, gain


def _edge_gain(weights: np.ndarray) -> float:
    """The factor that turns the per-sample noise variance into that of a velocity fitted
    with ``weights`` (:func:`_edge_weights`; the edge sample is noisy too)."""
    return float(np.sum(weights**2) + np.sum(weights) ** 2)


def _trial_spans(n_frames: int, joint: np.ndarray, length: np.ndarray, beyond: int):
    """Per distinct gap length of the ``(joint, length)`` pairs: ``span`` (the length + 1),
    the pairs' indices, the frames taken as a trial gap's first edge (room for
    :data:`EDGE_FRAMES` before it and ``beyond`` after the far edge, up to about
    :data:`KEEP_SAMPLES` of them spread over the clip) and the pairs' joints; lengths
    without room are left out."""
    for span in np.unique(length + 1):
        pairs = np.flatnonzero(length + 1 == span)
        edges = np.arange(EDGE_FRAMES, n_frames - span - beyond)
        if edges.size:
            yield span, pairs, edges[:: max(edges.size // KEEP_SAMPLES, 1)], joint[pairs]


def _slope_sum(x, base, rows, js, direction: int, log_of, weights) -> np.ndarray:
    """``sum_k weights[k-1] log_of(base, x[rows + direction k][:, js])``: ``direction``
    times the velocity at ``rows`` fitted on that side of them."""
    slope = np.zeros(base.shape[:-1] + (3,))
    for k, weight in enumerate(weights, 1):
        slope += weight * log_of(base, x[rows + direction * k][:, js])
    return slope


def _all_known(seen: np.ndarray, first: np.ndarray, stop: np.ndarray, js) -> np.ndarray:
    """Whether joints ``js`` miss no sample in the rows ``first .. stop - 1``, from the
    running count of missing samples ``seen`` ``(F + 1, J)``."""
    return seen[stop][:, js] == seen[first][:, js]


def _velocity_keep(x, missing, seen, rotations: bool, noise_var, joint, length) -> np.ndarray:
    """Per ``(joint, length)`` pair, the Wiener weight ``S / (S + N)`` of the fitted edge
    velocity's departure from the chord across a gap of that length: ``S + N`` the mean of
    ``|v - chord|^2`` over the joint's known frames taken as edges (up to
    :data:`KEEP_SAMPLES` of them), ``N`` what the noise alone puts there (the velocity's
    and the chord's noise variance). A clean capture keeps its velocities; a joint whose
    velocities are mostly noise keeps little of them, whatever one edge shows."""
    log_of = _rotation_log if rotations else _position_log
    out = np.ones(joint.size)
    weights = _edge_weights(EDGE_FRAMES)
    gain = _edge_gain(weights)
    for span, pairs, edges, js in _trial_spans(x.shape[0], joint, length, 0):
        base = x[edges][:, js]
        slope = -_slope_sum(x, base, edges, js, -1, log_of, weights)
        chord = log_of(base, x[edges + span][:, js]) / span
        known = ~missing[edges + span][:, js] & _all_known(seen, edges - EDGE_FRAMES, edges + 1, js)
        apart = np.where(known, np.sum((slope - chord) ** 2, axis=-1), 0.0)
        count = known.sum(axis=0)
        spread = 3.0 * noise_var[js] * (gain + 2.0 / span**2)
        with np.errstate(divide="ignore", invalid="ignore"):
            keep = 1.0 - spread * count / apart.sum(axis=0)
        out[pairs] = np.where(count > 0, np.clip(np.nan_to_num(keep, nan=1.0), 0.0, 1.0), 1.0)
    return out


def _fill_share(x, seen, rotations: bool, noise_var, joint, length) -> np.ndarray:
    """Per ``(joint, length)`` pair, the weight ``w`` of the (shrunk) edge velocities'
    departure from the chord that fills gaps of that length best on the joint's own data,
    in [0, 1]: at up to :data:`KEEP_SAMPLES` places in its known frames taken as gaps, the
    straight line's error ``e`` and the velocities' part ``d`` of the cubic give ``w = <e,
    d> / <d, d>`` (least squares, over up to 8 of each gap's frames; their noise does not
    bias it). It keeps more of the velocities than the Wiener share where their noise,
    anchored at a noisy edge sample, partly undoes that sample's."""
    log_of = _rotation_log if rotations else _position_log
    out = np.ones(joint.size)
    weights = _edge_weights(EDGE_FRAMES)
    gain = _edge_gain(weights)
    for span, pairs, edges, js in _trial_spans(x.shape[0], joint, length, EDGE_FRAMES):
        start, end = x[edges][:, js], x[edges + span][:, js]
        slope_a = -_slope_sum(x, start, edges, js, -1, log_of, weights)
        slope_b = _slope_sum(x, end, edges + span, js, 1, log_of, weights)
        step = log_of(start, end)
        chord = step / span
        flat = (-1, 3)
        var = np.broadcast_to(noise_var[js], chord.shape[:-1]).reshape(-1)
        gains = np.full(var.size, gain)
        d_a, d_b = (
            (_shrunk(v.reshape(flat), gains, chord.reshape(flat), var).reshape(chord.shape) - chord)
            * span
            for v in (slope_a, slope_b)
        )
        known = _all_known(seen, edges - EDGE_FRAMES, edges + span + EDGE_FRAMES + 1, js)
        along = np.zeros(chord.shape[:-1])
        squares = np.zeros(chord.shape[:-1])
        for i in np.unique(np.linspace(1, span - 1, min(span - 1, 8)).round().astype(int)):
            u = i / span
            line = log_of(start, x[edges + i][:, js]) - u * step
            bend = (u**3 - 2 * u**2 + u) * d_a + (u**3 - u**2) * d_b  # the Hermite's tangent part
            along += np.sum(line * bend, axis=-1)
            squares += np.sum(bend * bend, axis=-1)
        along, squares = (np.where(known, v, 0.0).sum(axis=0) for v in (along, squares))
        with np.errstate(divide="ignore", invalid="ignore"):
            share = along / squares
        out[pairs] = np.clip(np.nan_to_num(share, nan=1.0), 0.0, 1.0)
    return out


def _shrunk(velocity, gain, chord, noise_var) -> np.ndarray:
    """The fitted edge velocity pulled toward the chord's by as much as noise explains of
    their difference (James-Stein shrinkage; noise-free data keep the fit)."""
    spread = 3.0 * noise_var * gain  # expected |velocity error|^2 (three components)
    apart = np.sum((velocity - chord) ** 2, axis=-1)
    keep = np.clip(1.0 - spread / np.maximum(apart, 1e-300), 0.0, 1.0)
    keep[gain == 0.0] = 0.0  # no room beside the gap: the chord
    return chord + keep[:, None] * (velocity - chord)


def _edges(x, a, b, room_a, room_b, rotations: bool, noise_var) -> dict:
    """What every bridge option of :func:`_bridge` starts from, per gap of the flat signal
    ``x``: the edges ``x_a``, ``x_b`` and the step ``log(x_a^-1 x_b)`` between them, as
    sampled (``raw``) and where a local fit puts them (``smooth``, :func:`_smoothed_edge`),
    and the fitted edge velocities with their noise gains (``fit_a``, ``fit_b``,
    :func:`_edge_velocity`)."""
    log_of = _rotation_log if rotations else _position_log
    x_a, x_b = x[a], x[b]
    step = log_of(x_a, x_b)
    shift_a = _smoothed_edge(x, a, room_a, -1, log_of, noise_var)
    shift_b = _smoothed_edge(x, b, room_b, +1, log_of, noise_var)
    if rotations:
        s_a, s_b = quat.multiply(x_a, quat.exp(shift_a)), quat.multiply(x_b, quat.exp(shift_b))
        s_step = _log_near(quat.relative(s_a, s_b), step)
    else:
        s_a, s_b = x_a + shift_a, x_b + shift_b
        s_step = s_b - s_a
    return {
        "raw": (x_a, x_b, step),
        "smooth": (s_a, s_b, s_step),
        "fit_a": _edge_velocity(x, a, room_a, -1, log_of),
        "fit_b": _edge_velocity(x, b, room_b, +1, log_of),
    }


def _bridge(x, where, rotations: bool, stats, edges: dict, option) -> np.ndarray:
    """The C1 cubic across each gap of the flat signal ``x`` (``where``: rows ``a`` and
    ``b`` known, ``room_*`` known rows beyond them, gap rows ``rows`` of gap ``gap_of``).
    ``stats`` per gap: per-sample noise variance, second differences' variance
    (:func:`noise_and_motion_variance`) and the Wiener share of the edge velocities kept
    (:func:`_velocity_keep`); ``edges``: :func:`_edges`. ``option`` per gap: ``(weight,
    smooth)``: each gap's edge velocities are the chord's plus ``weight`` times the kept
    share of their difference from it (0: the straight line), between the edge samples or,
    where ``smooth``, where a local fit puts the edges; where ``weight`` is :data:`SPLINE`
    (and the gap no longer than :data:`SPLINE_MAX_GAP`) the bridge is the smoothing spline
    (:func:`_spline_bridge`)."""
    a, b, room_a, room_b, rows, gap_of = where
    noise_var, motion_var, keep = stats
    weight, smooth = option
    x_a, x_b, step = (
        np.where(smooth[:, None], smoothed, raw)
        for raw, smoothed in zip(edges["raw"], edges["smooth"], strict=True)
    )
    span = (b - a).astype(np.float64)[:, None]
    chord = step / span
    kept = (np.where(weight == SPLINE, 1.0, weight) * keep)[:, None]
    (fit_a, gain_a), (fit_b, gain_b) = edges["fit_a"], edges["fit_b"]
    v_a = _shrunk(fit_a, gain_a, chord, noise_var)
    v_b = _shrunk(fit_b, gain_b, chord, noise_var)
    v_a = (chord + kept * (v_a - chord)) * span
    v_b = (chord + kept * (v_b - chord)) * span
    u = (rows - a[gap_of]) / span[gap_of, 0]
    g = gap_of
    if rotations:
        out = hermite_rotations(x_a[g], step[g], v_a[g], end_tangent(step, v_b)[g], u)
    else:
        out = hermite_positions(x_a[g], v_a[g], x_b[g], v_b[g], u)
    spline = (weight == SPLINE) & ((b - a - 1) <= SPLINE_MAX_GAP)
    if spline.any():
        at = spline[gap_of]
        lam = spline_lambda(noise_var, motion_var)
        out[at] = _spline_bridge(x, a, b, room_a, room_b, spline, gap_of[at], rotations, lam)
    return out


def _log_near(q: np.ndarray, near: np.ndarray) -> np.ndarray:
    """The log of ``q`` (half-angle units) on the branch nearest ``near``: the shortest way
    or the other way round (a smoothed edge must not turn a bridge of nearly half a turn
    the other way)."""
    short = quat.log_shortest(q)
    angle = np.linalg.norm(short, axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        other = np.where(angle > 0, short * (1.0 - np.pi / angle), short)
    flip = np.sum((short - near) ** 2, axis=-1) > np.sum((other - near) ** 2, axis=-1)
    return np.where(flip[:, None], other, short)


def _smoothed_edge(x, edge, room, direction: int, log_of, noise_var) -> np.ndarray:
    """Where a local fit puts the edge: the discrete smoothing spline with a third-difference
    penalty (a local quadratic, so a curving motion does not pull the edge aside) through
    the edge row and up to :data:`SPLINE_FRAMES` of the ``room`` known rows beyond it
    (``direction`` -1: before it, +1: after), of parameter ``noise_var`` (G,) over the
    window's own third differences' variance (less the noise's, 20 times its variance);
    as a displacement from the edge sample (G, 3)."""
    k = np.arange(SPLINE_FRAMES + 1)
    rows = np.clip(edge[:, None] + direction * k, 0, x.shape[0] - 1)
    usable = k <= room[:, None]
    y = np.where(usable[..., None], log_of(x[edge][:, None], x[rows]), 0.0)
    ok = usable[:, 3:]
    jerks = np.sum(np.where(ok[..., None], np.diff(y, 3, axis=1) ** 2, 0.0), axis=(1, 2))
    jerk = jerks / np.maximum(3 * ok.sum(axis=1), 1)
    lam = spline_lambda(noise_var, jerk, noise_gain=20.0)
    third = np.diff(np.eye(k.size), 3, axis=0)
    system = lam[:, None, None] * (third.T @ third) + usable[:, :, None] * np.eye(k.size)
    return np.linalg.solve(system, y)[:, 0]


def _spline_bridge(x, a, b, room_a, room_b, chosen, gap_of, rotations: bool, lam) -> np.ndarray:
    """The discrete cubic smoothing spline (Whittaker-Henderson, second differences) through
    the known rows beside each ``chosen`` gap of the flat signal ``x`` (the edge and up to
    :data:`SPLINE_FRAMES` of the ``room_*`` known rows beyond it on each side), at the
    gaps' rows (``gap_of``: the gap of each, in order), in the tangent space at row ``a``.

    Each window's values ``z`` minimise ``sum_known |z_i - y_i|^2 + lambda sum |D2 z|^2``
    (``lambda`` per gap: the noise variance over the motion's second-difference variance,
    :func:`spline_lambda`): a cubic across the gap, which under noise leaves the noisy
    edge samples (by about their noise) for the motion the window shows."""
    log_of = _rotation_log if rotations else _position_log
    out = np.empty((gap_of.size, 4 if rotations else 3))
    edge_rows = np.arange(SPLINE_FRAMES + 1)
    for length in np.unique(b[chosen] - a[chosen] - 1):
        mine = np.flatnonzero(chosen & (b - a - 1 == length))
        n = 2 * (SPLINE_FRAMES + 1) + int(length)
        # window rows: SPLINE_FRAMES + 1 ending at a, the gap, as many starting at b
        before = a[mine, None] - edge_rows[::-1]
        after = b[mine, None] + edge_rows
        known = np.concatenate([before, after], axis=1)  # (G, 2K + 2)
        usable = np.concatenate(
            [edge_rows[::-1] <= room_a[mine, None], edge_rows <= room_b[mine, None]], axis=1
        )
        base = x[a[mine]]
        if rotations:  # the chart at the middle of the chord: least distortion
            base = quat.multiply(base, quat.exp(0.5 * log_of(base, x[b[mine]])))
        y = log_of(base[:, None], x[np.clip(known, 0, x.shape[0] - 1)])
        y[~usable] = 0.0
        second = np.diff(np.eye(n), 2, axis=0)
        penalty = second.T @ second
        index = np.concatenate([edge_rows, SPLINE_FRAMES + 1 + int(length) + edge_rows])
        weight = np.zeros((mine.size, n))
        weight[:, index] = usable
        system = lam[mine, None, None] * penalty + weight[:, :, None] * np.eye(n)
        rhs = np.zeros((mine.size, n, 3))
        rhs[:, index] = y
        scale = np.abs(system).max(axis=2, keepdims=True)  # rows equilibrated
        z = np.linalg.solve(system / scale, rhs / scale)
        inside = z[:, SPLINE_FRAMES + 1 : SPLINE_FRAMES + 1 + int(length)].reshape(-1, 3)
        at = np.flatnonzero(np.isin(gap_of, mine))  # rows in gap order, gaps in order
        if rotations:
            out[at] = quat.multiply(np.repeat(base, length, axis=0), quat.exp(inside))
        else:
            out[at] = np.repeat(base, length, axis=0) + inside
    return out


def noise_and_motion_variance(
    x: np.ndarray, missing: np.ndarray, rotations: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample noise variance per component of each joint of ``x`` ``(F, J, 4|3)``
    (rotations: of the half-angle log), from the median squared length of the third
    differences over the known frames (white noise of variance s^2 per component gives
    third differences of variance 20 s^2 per component, and their squared length a median
    of :data:`CHI2_3_MEDIAN` times that): rotation invariant; and the mean variance per
    component of the second differences there (motion and noise). Each ``(J,)``; 0 for
    short clips."""
    if x.shape[0] < 5:
        return np.zeros(x.shape[1]), np.zeros(x.shape[1])
    steps = np.empty((x.shape[0] - 1, x.shape[1], 3))
    for at in range(0, steps.shape[0], 4096):  # temporaries stay small
        rows = slice(at, min(at + 4096, steps.shape[0]))
        a, b = x[rows], x[rows.start + 1 : rows.stop + 1]
        steps[rows] = _rotation_log(a, b) if rotations else b - a
    second = np.diff(steps, axis=0)
    third = np.diff(second, axis=0)
    known = ~(missing[:-3] | missing[1:-2] | missing[2:-1] | missing[3:])
    squares = np.where(known, np.einsum("fjc,fjc->fj", third, third), np.nan)
    known_2 = ~(missing[:-2] | missing[1:-1] | missing[2:])
    bends = np.where(known_2, np.einsum("fjc,fjc->fj", second, second), np.nan)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a joint with no known run: NaN
        median = np.nanmedian(squares, axis=0)
        mean = np.nanmean(bends, axis=0)
    return np.nan_to_num(median / CHI2_3_MEDIAN / 20.0), np.nan_to_num(mean / 3.0)


# ----------------------------------------------------------------------------- donors


def _frame_of(q, p, donor, frames):
    """Rotation and position of ``donor`` (-1: the world) at ``frames`` (same shapes)."""
    world = donor < 0
    d = np.where(world[..., None], quat.identity(()), q[frames, np.maximum(donor, 0)])
    c = np.where(world[..., None], 0.0, p[frames, np.maximum(donor, 0)])
    return d, c


def _relative(q, p, joint, donors, frames):
    """Pose of ``joint`` at ``frames`` relative to ``donors = (rotation donor, position
    donor)`` (-1: the world; same shapes): :func:`_relative_rotation` and
    :func:`_relative_position`."""
    return (
        _relative_rotation(q, p, joint, donors[0], frames),
        _relative_position(q, p, joint, donors[1], frames),
    )


def _relative_rotation(q, p, joint, donor, frames):
    """``d^-1 q`` of ``joint`` at ``frames`` for the rotation ``d`` of ``donor`` (-1: the
    world; same shapes)."""
    d, _ = _frame_of(q, p, donor, frames)
    return quat.relative(d, q[frames, joint])


def _relative_position(q, p, joint, donor, frames):
    """``e^-1 (p - c) e`` of ``joint`` at ``frames`` for the rotation ``e`` and position
    ``c`` of ``donor`` (-1: the world; same shapes)."""
    e, c = _frame_of(q, p, donor, frames)
    return quat.rotate(quat.conjugate(e), p[frames, joint] - c)


def _roughness(x: np.ndarray, rotations: bool) -> np.ndarray:
    """Sum of squared second differences along axis 1 of ``(G, W, C, n)`` windows."""
    if rotations:
        steps = quat.log_shortest(quat.relative(x[:, :-1], x[:, 1:]))
    else:
        steps = np.diff(x, axis=1)
    return np.sum(np.diff(steps, axis=1) ** 2, axis=(1, 3))


def _choose_donors(q, p, seen, gaps: Gaps) -> np.ndarray:
    """Per gap, ``(2, G)``: the donors (or -1) whose relative rotation, and relative
    position, are smoothest beside the gap among the joints known from
    :data:`DONOR_FRAMES` frames before it to as many after it (``seen``: the running
    count of missing samples, :func:`~motionclean.core.motion.missing_before`)."""
    n_frames, n_joints = seen.shape[0] - 1, seen.shape[1]
    lo = np.maximum(gaps.first - 1 - DONOR_FRAMES, 0)
    hi = np.minimum(gaps.stop + DONOR_FRAMES, n_frames - 1)
    donor = np.full((2, gaps.joint.size), -1)
    offsets = np.arange(-DONOR_FRAMES, 1)
    for at in range(0, gaps.joint.size, GAP_BLOCK):
        block = slice(at, at + GAP_BLOCK)
        joint = gaps.joint[block]
        tracked = (seen[hi[block] + 1] - seen[lo[block]]) == 0  # (G, J)
        tracked[np.arange(joint.size), joint] = False
        if not tracked.any():
            continue
        # Window frames: the known ones nearest each edge (clipped to the clip).
        before = np.clip(gaps.first[block, None] - 1 + offsets, 0, n_frames - 1)
        after = np.clip(gaps.stop[block, None] - offsets[::-1], 0, n_frames - 1)
        rough = np.zeros((2, joint.size, n_joints + 1))
        near = DONOR_FRAMES - POSITION_DONOR_FRAMES  # position windows: the frames nearest
        for frames, inner in ((before, slice(near, None)), (after, slice(None, -near or None))):
            frames = frames[:, :, None]  # (G, W, 1)
            candidates = np.arange(-1, n_joints)[None, None, :]  # -1: the world
            shape = (joint.size, frames.shape[1], n_joints + 1)
            candidate = np.broadcast_to(candidates, shape)
            rel_q, rel_p = _relative(
                q,
                p,
                np.broadcast_to(joint[:, None, None], shape),
                (candidate, candidate),
                np.broadcast_to(frames, shape),
            )
            rough[0] += _roughness(rel_q, True)
            rough[1] += _roughness(rel_p[:, inner], False)
        rough[:, :, 1:][:, ~tracked] = np.inf
        best = rough.min(axis=2, keepdims=True)  # ties (rigidly attached bodies): the first
        donor[:, block] = np.argmax(rough <= best + 1e-9 * (1.0 + best), axis=2) - 1
    return donor


def _moving_with(q, p, missing, joint, donor) -> np.ndarray:
    """``donor`` (2, G) with each rotation and position donor of the gaps' ``joint`` (G,)
    kept only where the joint moves with it over the whole clip: its steps relative to the
    donor (:func:`_relative`) are smaller, in mean square over the steps where both are
    known, than its own steps in the world over the steps where it is known (at most
    :data:`MOVING_WITH_STEPS` of them, spread evenly); else the world (-1). A hand moves
    with its forearm; an elbow and an ankle that happened to move alike beside a gap of a
    dance do not (bridged on such donors, a markerless dance's arm gaps came out 1.5-2.5
    times further from the truth than a straight line). Pairs are measured
    :data:`PAIR_BLOCK` steps' worth at a time."""
    n_frames, n_joints = missing.shape
    if n_frames < 2 or (donor < 0).all():
        return donor
    count = min(n_frames - 1, MOVING_WITH_STEPS)
    steps = np.unique(np.linspace(0, n_frames - 2, count).astype(np.intp))
    known = ~(missing[steps] | missing[steps + 1])  # (S, J) steps known for each joint
    kept = donor.copy()
    for k in range(2):  # rotation donors, then position donors
        has = donor[k] >= 0
        if not has.any():
            continue
        pair, of_gap = np.unique(joint[has] * n_joints + donor[k, has], return_inverse=True)
        whose, helper = np.divmod(pair, n_joints)
        own = _mean_square_steps(q, p, steps, known, whose, None, k)
        with_it = np.empty(pair.size, dtype=bool)
        block = max(1, PAIR_BLOCK // steps.size)
        for at in range(0, pair.size, block):
            part = slice(at, at + block)
            relative = _mean_square_steps(q, p, steps, known, whose[part], helper[part], k)
            with_it[part] = relative < own[part]
        kept[k, has] = np.where(with_it[of_gap], donor[k, has], -1)
    return kept


def _mean_square_steps(q, p, steps, known, whose, helper, k: int) -> np.ndarray:
    """``(P,)``: the mean square, over the ``steps`` (S,) that ``known`` (S, J) marks for
    each joint ``whose`` (P,) (and for its ``helper``), of its steps from each step's frame
    to the next: of its rotation (``k`` 0; angle, radians) or position (1), in the world
    (``helper`` None) or relative to the helper (:func:`_relative_rotation`,
    :func:`_relative_position`)."""
    shape = (steps.size, whose.size)
    at = np.broadcast_to(steps[:, None], shape)
    joints = np.broadcast_to(whose, shape)
    if helper is None:  # in the world: the poses themselves
        seen = known[:, whose]
        before, after = ((q, p)[k][frames, joints] for frames in (at, at + 1))
    else:
        seen = known[:, whose] & known[:, helper]
        donor = np.broadcast_to(helper, shape)
        relative = _relative_rotation if k == 0 else _relative_position
        before, after = (relative(q, p, joints, donor, frames) for frames in (at, at + 1))
    if k == 0:
        step = quat.angle_between(before, after) ** 2
    else:
        step = np.sum((after - before) ** 2, axis=-1)
    total = np.where(seen, step, 0.0).sum(axis=0)
    return total / np.maximum(seen.sum(axis=0), 1)


# ----------------------------------------------------------------------------- filling


def _known_room(missing: np.ndarray, joint: np.ndarray, edge: np.ndarray, direction: int):
    """Known frames in a row beyond ``edge`` (excluded) going ``direction``, per gap."""
    n_frames = missing.shape[0]
    frames = np.arange(n_frames)[:, None]
    if direction < 0:
        last = np.maximum.accumulate(np.where(missing, frames, -1), axis=0)
        return edge - last[edge, joint] - 1
    following = np.minimum.accumulate(np.where(missing, frames, n_frames)[::-1], axis=0)[::-1]
    return following[edge, joint] - edge - 1


def fill_gaps(
    rotations: np.ndarray,
    translations: np.ndarray,
    missing: np.ndarray,
    max_gap: int,
    use_positions: np.ndarray | None = None,
    donors: bool = True,
) -> Filled:
    """Fill every gap of at most ``max_gap`` frames (module docstring).

    ``rotations`` ``(F, J, 4)`` unit quaternions ``(w, x, y, z)`` and ``translations``
    ``(F, J, 3)`` with placeholders where ``missing`` ``(F, J)`` is True;
    ``use_positions`` ``(J,)`` marks the joints whose translations are data (default all);
    ``donors`` False bridges every joint in the world frame. Longer gaps stay missing and
    untouched, and so does a joint never seen at all.

    Raises TypeError or ValueError naming the argument: rotations that are not finite
    unit quaternions ``(F, J, 4)``, translations not finite ``(F, J, 3)``, ``missing`` not
    a bool array ``(F, J)``, ``max_gap`` not a whole number of frames >= 0,
    ``use_positions`` not a bool array ``(J,)``.
    """
    rotations = checks.unit_quaternions(rotations, "rotations")
    translations = checks.vectors(translations, "translations")
    if rotations.ndim != 3 or translations.shape != rotations.shape[:2] + (3,):
        raise ValueError(
            f"rotations and translations: expected shapes (F, J, 4) and (F, J, 3), got "
            f"{rotations.shape} and {translations.shape}"
        )
    missing = checks.bool_mask(missing, "missing", rotations.shape[:2])
    max_gap = checks.whole(max_gap, "max_gap")
    if use_positions is not None:
        use_positions = checks.bool_mask(use_positions, "use_positions", rotations.shape[1:2])
    n_frames, n_joints = missing.shape
    use_positions = np.ones(n_joints, bool) if use_positions is None else use_positions
    gaps = Gaps.of(missing)
    fillable = gaps.lengths <= max_gap
    fillable &= (gaps.first > 0) | (gaps.stop < n_frames)  # a joint never seen stays so
    todo = gaps.select(fillable)
    q, p = rotations.copy(), translations.copy()
    still = missing.copy()
    seen = missing_before(missing)
    donor = np.full((2, todo.joint.size), -1)
    if donors:
        donor = _choose_donors(rotations, translations, seen, todo)
        donor = _moving_with(rotations, translations, missing, todo.joint, donor)
    inner = (todo.first > 0) & (todo.stop < n_frames)
    if donors and not inner.all():
        ends = todo.select(~inner)
        donor[:, ~inner] = _held_donors(rotations, translations, seen, ends, donor[:, ~inner])
    lengths = todo.lengths
    gap_of = np.repeat(np.arange(lengths.size), lengths)
    frame = todo.first[gap_of] + _ranks(lengths)
    joint = todo.joint[gap_of]
    still[frame, joint] = False
    # Bridge the relative poses; the edges, and the known rows beside them, come along.
    a = np.where(todo.first > 0, todo.first - 1, todo.stop)  # one-sided: the edge
    rel_q, rel_p = _relative(rotations, translations, joint, donor[:, gap_of], frame)
    held = ~inner[gap_of]
    if held.any():
        edge_q, edge_p = _relative(rotations, translations, joint, donor[:, gap_of], a[gap_of])
        rel_q[held], rel_p[held] = edge_q[held], edge_p[held]
    if inner.any():
        two_sided = todo.select(inner)
        noise = tuple(
            _Stats.of(x, missing, seen, rotations, two_sided)
            for x, rotations in ((rotations, True), (translations, False))
        )
        chosen, option_q, option_p = _validated(
            rotations, translations, missing, seen, two_sided, donor[:, inner], noise
        )
        donor[:, inner] = chosen
        rel_q, rel_p = _relative(rotations, translations, joint, donor[:, gap_of], frame)
        if held.any():
            edge_q, edge_p = _relative(rotations, translations, joint, donor[:, gap_of], a[gap_of])
            rel_q[held], rel_p[held] = edge_q[held], edge_p[held]
        windows = _Windows.of(rotations, translations, missing, two_sided, donor[:, inner], noise)
        rel_q[~held], rel_p[~held] = windows.bridged((option_q, option_p))
    d, _ = _frame_of(rotations, translations, donor[0, gap_of], frame)
    e, c = _frame_of(rotations, translations, donor[1, gap_of], frame)
    q[frame, joint] = quat.multiply(d, rel_q)
    moved = use_positions[joint]
    p[frame[moved], joint[moved]] = (c + quat.rotate(e, rel_p))[moved]
    q = quat.make_continuous(q, axis=0)
    return Filled(q, p, still, gaps, fillable, _spread(donor, fillable))


def _trials(seen, gaps: Gaps, donors: np.ndarray):
    """Gaps of the same length as each of ``gaps`` planted in known frames beside it, for
    :func:`_validated`: ``(trial gaps, index of the real gap of each)``. Up to
    :data:`TRIALS_PER_SIDE` on each side, spaced by their length plus one; a trial is kept
    when its frames, the :data:`EDGE_FRAMES` known frames around it and its edges lie in the
    clip, are all known for the joint and, where ``donors`` (2, G) (of the rotation and of
    the position) are joints, for them too (``seen``: the running count of missing
    samples)."""
    n_frames = seen.shape[0] - 1
    lengths = gaps.lengths
    k = np.arange(TRIALS_PER_SIDE)
    step = lengths[:, None] + 1
    left_stop = gaps.first[:, None] - 1 - EDGE_FRAMES - k * step  # (G, K)
    right_first = gaps.stop[:, None] + EDGE_FRAMES + 1 + k * step
    first = np.concatenate([left_stop - lengths[:, None], right_first], axis=1).reshape(-1)
    of = np.repeat(np.arange(lengths.size), 2 * TRIALS_PER_SIDE)
    stop = first + lengths[of]
    lo, hi = first - 1 - EDGE_FRAMES, stop + EDGE_FRAMES  # the frames read, inclusive
    ok = (lo >= 0) & (hi < n_frames)
    lo_c, hi_c = np.clip(lo, 0, n_frames - 1), np.clip(hi, 0, n_frames - 1)
    joint = gaps.joint[of]
    ok &= seen[hi_c + 1, joint] == seen[lo_c, joint]
    for helper in donors[:, of]:
        tracked = seen[hi_c + 1, np.maximum(helper, 0)] == seen[lo_c, np.maximum(helper, 0)]
        ok &= (helper < 0) | tracked
    return Gaps(joint[ok], first[ok], stop[ok]), of[ok]


def _held_donors(rotations, translations, seen, gaps: Gaps, donor: np.ndarray) -> np.ndarray:
    """Per gap at a clip end (held, one edge), the donors ``(2, G)`` kept: each of the
    rotation's and the position's where holding the pose relative to it fills the gaps of
    the same length planted beside the gap (:func:`_trials`, held from the same side) by
    :data:`LINE_MARGIN` better than holding the edge sample in the world; else the world
    (-1). Under tracker noise a donor adds its own noise to a held pose. A gap without room
    for a trial keeps its donors."""
    trials, of = _trials(seen, gaps, donor)
    if not of.size:
        return donor
    lengths = trials.lengths
    owner = np.repeat(of, lengths)
    frames = np.repeat(trials.first, lengths) + _ranks(lengths)
    joint = np.repeat(trials.joint, lengths)
    at_end = gaps.first[owner] > 0  # held from the frame before the gap, else after it
    edge = np.where(at_end, np.repeat(trials.first - 1, lengths), np.repeat(trials.stop, lengths))
    error = np.zeros((2, 2, gaps.joint.size))  # (world, donor), (rotation, position)
    for use, helpers in enumerate((np.full_like(donor, -1), donor)):
        held = _relative(rotations, translations, joint, helpers[:, owner], edge)
        d, _ = _frame_of(rotations, translations, helpers[0, owner], frames)
        e, c = _frame_of(rotations, translations, helpers[1, owner], frames)
        squares = (
            quat.angle_between(quat.multiply(d, held[0]), rotations[frames, joint]) ** 2,
            np.sum((c + quat.rotate(e, held[1]) - translations[frames, joint]) ** 2, axis=-1),
        )
        for k in range(2):
            error[use, k] = np.bincount(owner, weights=squares[k], minlength=gaps.joint.size)
    tried = np.bincount(of, minlength=gaps.joint.size) > 0
    better = error[1] < (1.0 - LINE_MARGIN) * error[0]
    return np.where(~tried | better, donor, -1)


def _validated(rotations, translations, missing, seen, gaps: Gaps, donor: np.ndarray, noise):
    """Per two-sided gap, the donors (the chosen ``donor`` (2, G) of the rotation and of
    the position, or the world, -1) and the bridge options ``(weight, smooth)``
    (:func:`_bridge`) of its rotation and of its position that fill best the gaps of the
    same length planted beside it in the joint's own known frames (least summed squared
    error there; :func:`_trials`), in three steps on the same trials, for the rotation and
    the position each: the donor and the edge velocities' weight
    (:data:`VELOCITY_WEIGHTS`; the straight line in the world frame, weight 0, taken unless
    another is :data:`LINE_MARGIN` better); the edges where a local fit puts them if that
    does better there; the smoothing spline if it is :data:`LINE_MARGIN` better still.
    Whatever a joint's motion and noise, its bridges are then no worse there than the
    straight line, and a donor that does not move with the joint (a hand with the head) is
    dropped. A gap without room for a trial and without a donor is judged on the joint's
    other gaps' trials (:func:`_pooled_for_untried`); one with a donor, or whose joint has
    no tried gap of the same octave of lengths, keeps its donors and the full edge
    velocities from its edge samples.
    Returns ``(donors (2, G), (weight, smooth) of the rotation,
    (weight, smooth) of the position)``, each array (G,)."""
    n_gaps = gaps.joint.size
    uses = (-1, 0) if (donor >= 0).any() else (-1,)  # 0: the chosen donors
    kinds = [(w, smooth) for w in VELOCITY_WEIGHTS for smooth in (False, True)]
    options = [(use, w, smooth) for use in uses for w, smooth in (*kinds, (SPLINE, False))]
    error = np.full((2, len(options), n_gaps), np.inf)  # rotations, positions
    trials, of = _trials(seen, gaps, donor)  # the same trials with the donors and without
    for use in uses if of.size else ():
        helpers = donor if use == 0 else np.full_like(donor, -1)
        windows = _Windows.of(rotations, translations, missing, trials, helpers[:, of], noise)
        lengths = trials.lengths
        owner = np.repeat(of, lengths)
        frames = np.repeat(trials.first, lengths) + _ranks(lengths)
        truth = _relative(
            rotations, translations, np.repeat(trials.joint, lengths), helpers[:, owner], frames
        )
        tried = np.bincount(of, minlength=n_gaps) > 0
        tried = np.stack([tried & (helpers[k] >= 0) if use == 0 else tried for k in range(2)])
        for i in (i for i, option in enumerate(options) if option[0] == use):
            _, w, smooth = options[i]
            option = (np.full(of.size, w), np.full(of.size, smooth))
            bridged = windows.bridged((option, option))
            squares = (
                quat.angle_between(bridged[0], truth[0]) ** 2,
                np.sum((bridged[1] - truth[1]) ** 2, axis=-1),
            )
            for k in range(2):
                ok = tried[k] & (gaps.lengths <= SPLINE_MAX_GAP) if w == SPLINE else tried[k]
                total = np.bincount(owner, weights=squares[k], minlength=n_gaps)
                error[k, i] = np.where(ok, total, np.inf)
    use_of, weight_of, smooth_of = (np.array(column) for column in zip(*options, strict=True))
    error = _pooled_for_untried(error, gaps, use_of < 0, donor, weight_of == SPLINE)
    spline = weight_of == SPLINE
    plain = ~smooth_of & ~spline
    # 1. donor and weight, from the edge samples: the straight line in the world wins
    # near-ties
    first = np.where(plain[:, None, None], error.transpose(1, 0, 2), np.inf)  # (O, 2, G)
    first[(weight_of != 0) | (use_of == 0)] /= 1.0 - LINE_MARGIN
    chosen = np.argmin(first, axis=0)  # (2, G)
    best = chosen.copy()
    columns = np.arange(n_gaps)
    row = {option: i for i, option in enumerate(options)}
    # each option's twin from smoothed edges, and the spline with its donor
    twin_of = np.array([row.get((use, w, True), i) for i, (use, w, _) in enumerate(options)])
    spline_of = np.array([row[(use, SPLINE, False)] for use, _, _ in options])
    for k in range(2):
        # 2. the same bridge from smoothed edges, where it does better
        twin = twin_of[chosen[k]]
        better = _better(error[k, twin, columns], error[k, chosen[k], columns], gaps, 0.0)
        chosen[k] = np.where(better, twin, chosen[k])
        # 3. the smoothing spline with the same donor, where it is clearly better
        curve = spline_of[best[k]]
        better = _better(
            error[k, curve, columns], error[k, chosen[k], columns], gaps, SPLINE_MARGIN
        )
        chosen[k] = np.where(better, curve, chosen[k])
    untried = ~np.isfinite(error.min(axis=1))  # (2, G)
    weights = np.where(untried, 1.0, weight_of[chosen])
    smoothed = np.where(untried, False, smooth_of[chosen])
    return (
        np.where(untried | (use_of[best] == 0), donor, -1),
        (weights[0], smoothed[0]),
        (weights[1], smoothed[1]),
    )


def _pooled_for_untried(
    error: np.ndarray, gaps: Gaps, world: np.ndarray, donor: np.ndarray, spline: np.ndarray
) -> np.ndarray:
    """``error`` (2, O, G) (rotation and position, option, gap; inf: not tried) with each
    gap that had no trial and no donor (``donor`` (2, G), -1) given, for each option in the
    world frame (``world`` (O,) bool), the geometric mean over the same joint's tried gaps
    of the same octave of lengths (:func:`_octaves`) of that option's error over their
    best world option's: the bridge that fills the joint's other gaps best. (Between two
    dropouts a dance's markerless shoulder had no room for a trial and took its full edge
    velocities, 1.8 times further from the truth than the straight line its other gaps
    chose.) A gap with a donor keeps it and the full edge velocities: the donor's options
    of other gaps are another donor's, or none. The smoothing spline (``spline`` (O,)
    bool) is pooled only into gaps of up to :data:`SPLINE_MAX_GAP` frames, the longest it
    bridges (a longer gap would take it and bridge on the full edge velocities)."""
    error = error.copy()
    finite = np.isfinite(error) & world[:, None]
    tried = np.isfinite(error).any(axis=1)  # (2, G)
    pick = ~tried & (donor < 0)  # (2, G)
    if not pick.any() or not tried.any():
        return error
    tiny = 1e-24  # squared radians or length units: nothing, and no 0 / 0
    best = np.where(finite.any(axis=1), np.min(np.where(finite, error, np.inf), axis=1), 1.0)
    ratio = (np.where(finite, error, 0.0) + tiny) / (best[:, None, :] + tiny)
    kinds, n_options = error.shape[:2]
    group = _octaves(gaps)
    n_groups = int(group.max()) + 1
    row = np.arange(kinds * n_options).reshape(kinds, n_options, 1)  # (kind, option)
    key = (row * n_groups + group).ravel()  # ... and group
    pooled = _geometric_means(ratio.ravel(), finite.ravel(), key, kinds * n_options * n_groups)
    pooled = np.nan_to_num(pooled, nan=np.inf).reshape(kinds, n_options, n_groups)
    for k in range(kinds):
        values = pooled[k][:, group[pick[k]]]  # (O, picked gaps)
        values[np.ix_(spline, gaps.lengths[pick[k]] > SPLINE_MAX_GAP)] = np.inf
        error[k][:, pick[k]] = values
    return error


def _octaves(gaps: Gaps) -> np.ndarray:
    """``(G,)`` labels ``0 ..``: the gaps of one joint whose lengths lie in one octave
    ``[2^n, 2^(n+1))`` frames share a label (the gaps of "similar length")."""
    octave = np.log2(gaps.lengths).astype(np.int64)
    return np.unique(gaps.joint.astype(np.int64) * KEY + octave, return_inverse=True)[1]


def _better(error: np.ndarray, chosen: np.ndarray, gaps: Gaps, margin: float) -> np.ndarray:
    """Per gap, whether a smoothed bridge of trial error ``error`` (G,) replaces the chosen
    one (``chosen``): where it does better on the gap's own trials, and by ``margin`` (the
    geometric mean of the ratios) on those of the joint's gaps of the same octave of
    lengths (:func:`_octaves`). One gap's few trials would pick a smoothed bridge by
    chance where it is not better: on clean captures, whose edge samples need no
    smoothing."""
    with np.errstate(divide="ignore", invalid="ignore"):  # inf / inf: neither was tried
        ratio = error / chosen
    key = _octaves(gaps)
    finite = np.isfinite(ratio) & (ratio > 0)
    pooled = _geometric_means(ratio, finite, key, int(key.max(initial=-1)) + 1)[key]
    return finite & (ratio < 1.0) & (pooled < 1.0 - margin)


def _geometric_means(values: np.ndarray, valid: np.ndarray, key: np.ndarray, size: int):
    """``(size,)``: the geometric mean of the positive ``values`` that ``valid`` marks, by
    ``key`` (all three the same shape, keys ``0 .. size-1``); nan for a key with none."""
    logs = np.log(np.where(valid, values, 1.0))
    total = np.bincount(key, weights=logs, minlength=size)  # log(1) = 0 where not valid
    count = np.bincount(key, weights=valid, minlength=size)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.exp(total / count)


def _ranks(lengths: np.ndarray) -> np.ndarray:
    """``0 .. n-1`` for each run of ``n`` in ``lengths``, end to end."""
    return np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths, lengths)


def _spread(values: np.ndarray, where: np.ndarray) -> np.ndarray:
    out = np.full((values.shape[0], where.size), -1)
    out[:, where] = values
    return out


@dataclass(frozen=True)
class _Windows:
    """Two-sided gaps' windows (known rows before, the gap, known rows after) laid end to
    end in one flat signal of relative rotations ``rel_q`` and positions ``rel_p``, with
    what :func:`_bridge` takes of them: rows ``a`` and ``b`` of each gap's edges, known
    ``room_*`` beyond them, the gap rows ``rows`` (of gap ``gap_of``), and per signal the
    ``stats`` (noise variance, second differences' variance, velocity share kept) per gap."""

    rel_q: np.ndarray
    rel_p: np.ndarray
    where: tuple
    stats: tuple
    edges: tuple

    @classmethod
    def of(cls, rotations, translations, missing, gaps: Gaps, donors, noise) -> _Windows:
        n_frames = missing.shape[0]
        a, b = gaps.first - 1, gaps.stop
        reach = max(EDGE_FRAMES, SPLINE_FRAMES)
        room_a = np.minimum(_known_room(missing, gaps.joint, a, -1), reach)
        room_b = np.minimum(_known_room(missing, gaps.joint, b, +1), reach)
        start, stop = a - room_a, b + room_b + 1  # each window's frames
        sizes = stop - start
        window_of = np.repeat(np.arange(sizes.size), sizes)
        frames = np.minimum(start[window_of] + _ranks(sizes), n_frames - 1)
        rel_q, rel_p = _relative(
            rotations, translations, gaps.joint[window_of], donors[:, window_of], frames
        )
        base = np.cumsum(sizes) - sizes  # flat row of each window's first frame
        flat_a = base + room_a
        lengths = gaps.lengths
        gap_of = np.repeat(np.arange(lengths.size), lengths)
        stats = []
        for signal, donor in zip(noise, donors, strict=True):
            var = signal.noise[gaps.joint]
            var = var + np.where(donor >= 0, signal.noise[np.maximum(donor, 0)], 0.0)
            stats.append((var, signal.motion[gaps.joint], signal.keep_of(gaps.joint, lengths)))
        rel_q = quat.make_continuous(rel_q, axis=0)
        flat_b = flat_a + (b - a)
        edges = tuple(
            _edges(x, flat_a, flat_b, room_a, room_b, rotation, var)
            for x, rotation, (var, _, _) in zip((rel_q, rel_p), (True, False), stats, strict=True)
        )
        rows = flat_a[gap_of] + 1 + _ranks(lengths)
        where = (flat_a, flat_b, room_a, room_b, rows, gap_of)
        return cls(rel_q, rel_p, where, tuple(stats), edges)

    def bridged(self, options) -> tuple[np.ndarray, np.ndarray]:
        """Relative poses across the gaps, gap frames in gap order; ``options``: the
        :func:`_bridge` options ``(weight, smooth)`` (arrays (G,)) of the rotations and of
        the positions."""
        return (
            _bridge(self.rel_q, self.where, True, self.stats[0], self.edges[0], options[0]),
            _bridge(self.rel_p, self.where, False, self.stats[1], self.edges[1], options[1]),
        )


def spline_lambda(noise_var: np.ndarray, data_var: np.ndarray, noise_gain: float = 6.0):
    """A smoothing spline's ``lambda`` (:func:`_spline_bridge`): the noise variance over
    the variance of the motion's own second differences (per component; white noise adds
    ``noise_gain`` = 6 times its variance to the data's ``data_var``; 20 for third
    differences), as for a cubic smoothing spline whose prior is acceleration as white
    noise; within :data:`SPLINE_LAMBDA`."""
    motion = np.maximum(data_var - noise_gain * noise_var, 1e-3 * data_var)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = noise_var / motion
    return np.clip(np.nan_to_num(lam, nan=0.0, posinf=SPLINE_LAMBDA[1]), *SPLINE_LAMBDA)
