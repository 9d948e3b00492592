"""C2 interpolating cubic B-spline of orientations (and its vector counterpart).

The curve is the cumulative-basis cubic B-spline quaternion curve of Kim, Kim and Shin
(SIGGRAPH 1995, Eq. 8): with control points ``c_k`` and their displacements
``v_k = log(c_k^-1 c_{k+1})`` (half-angle units, as 000 Eq. 19), on ``t = i + u``, ``u`` in
[0, 1),

    q(t) = c_{i-1} exp(B1(u) v_{i-1}) exp(B2(u) v_i) exp(B3(u) v_{i+1})

with the cumulative uniform cubic basis ``B1 = (5 + 3u - 3u^2 + u^3) / 6``, ``B2 = (1 + 3u +
3u^2 - 2u^3) / 6``, ``B3 = u^3 / 6``. It is C2 (angular velocity and acceleration are
continuous), built from displacements only, so it commutes with a fixed rotation on either
side (coordinate invariant), and with constant angular velocity (``c = q``) it is exactly
``q_0 exp(t w)``.

It is made interpolating (``q(i) = q_i`` at every sample) by solving for the control points.
At the knots ``q(i) = c_{i-1} exp(5/6 v_{i-1}) exp(1/6 v_i)``, whose linearisation is the
B-spline's tridiagonal system ``(d_{i-1} + 4 d_i + d_{i+1}) / 6 = e_i``. Starting from
``c = q``, each pass measures the residuals ``e_i = log(q(i)^-1 q_i)`` and moves ``c_i`` by
``exp(d_i)``, ``d`` the solution of that system for every joint and frame at once
(:func:`solve_tridiagonal`, parallel cyclic reduction), until the residuals are below
:data:`TOLERANCE`; each pass cuts them by a factor of about a fifth of the rotation between
samples in radians (the linearisation leaves out the exponential's Jacobian), so a capture
at 120 fps needs three or four passes and 30 fps samples of fast motion six to eight; a
column whose residual a pass would raise takes that pass back and halves its next step. The
ends are natural: ghost control points ``c_{-1} = c_0 exp(-v_0)`` and ``c_F = c_{F-1}
exp(v_{F-2})`` continue the control polygon geodesically, which makes ``c_0 = q_0``,
``c_{F-1} = q_{F-1}`` and the second derivative zero there, as a natural cubic spline's;
past either end the curve goes on at the end's angular velocity.

A step between samples larger than :data:`JUMP_DEG` (a half-turn flip, a capture glitch)
is no motion a smooth curve can follow: the spline is cut there, each side its own natural
spline, and across the step the curve is the geodesic between the two samples (slerp), so
a flip does not ring through its neighbours. The vector counterpart (positions) is the
natural cubic spline itself, solved in one pass, never cut.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..core import quat
from ..core.jumps import JUMP_DEG, jump_steps

__all__ = [
    "JUMP_DEG",
    "MAX_PASSES",
    "TOLERANCE",
    "PositionSpline",
    "RotationSpline",
    "evaluate",
    "evaluate_positions",
    "position_spline",
    "rotation_spline",
    "solve_knots",
    "solve_tridiagonal",
]

#: Passes of the control point solve at most, and the residual (radians, half-angle; about
#: 1e-7 degrees, below the six decimals a BVH file is written with) at which it stops.
MAX_PASSES = 100
TOLERANCE = 1e-9
#: Parallel cyclic reduction stops once every coupling left is below this (relative to the
#: diagonal, about 1): four levels. The passes correct what it leaves.
COUPLING = 1e-9


def solve_tridiagonal(free: np.ndarray, e: np.ndarray, coupling: float = 1e-18) -> np.ndarray:
    """``d`` with ``(d_{i-1} + 4 d_i + d_{i+1}) / 6 = e_i`` on the ``free`` rows of each
    column and ``d_i = 0`` on the others (and outside), ``free`` ``(F, C)``, ``e`` ``(F, C,
    K)``: every run of free rows is the B-spline's interpolation system with its ends held.

    Parallel cyclic reduction: each level eliminates the neighbours ``s`` rows away, all rows
    and columns at once, and the couplings left shrink like ``(2 - sqrt 3)^(2s)``: the matrix
    is strictly diagonally dominant, so a few levels (not ``log F``) bring them below
    ``coupling`` (relative to the diagonal; the default is below rounding: five levels),
    whatever the clip's length.
    """
    a = free / 6.0  # couplings to the rows before and after
    c = a.copy()
    b = np.where(free, 4.0 / 6.0, 1.0)
    d = np.where(free[..., None], e, 0.0)
    s = 1
    while s < b.shape[0] and max(np.abs(a).max(initial=0.0), np.abs(c).max(initial=0.0)) > coupling:
        alpha = -a[s:] / b[:-s]  # rows s.. eliminate the row s before them
        gamma = -c[:-s] / b[s:]  # rows ..-s eliminate the row s after them
        d_next = d.copy()
        d_next[s:] += alpha[..., None] * d[:-s]
        d_next[:-s] += gamma[..., None] * d[s:]
        b_next = b.copy()
        b_next[s:] += alpha * c[:-s]
        b_next[:-s] += gamma * a[s:]
        a_next, c_next = np.zeros_like(a), np.zeros_like(c)
        a_next[s:] = alpha * a[:-s]
        c_next[:-s] = gamma * c[s:]
        a, b, c, d = a_next, b_next, c_next, d_next
        s *= 2
    return d / b[..., None]


def solve_knots(e: np.ndarray) -> np.ndarray:
    """``d`` with ``(d_{i-1} + 4 d_i + d_{i+1}) / 6 = e_i`` for ``i = 0 .. m-1`` and
    ``d_{-1} = d_m = 0``, along axis 0 of ``e`` ``(m, ...)``: :func:`solve_tridiagonal` with
    every row free."""
    flat = e.reshape(e.shape[0], 1, -1)
    return solve_tridiagonal(np.ones(flat.shape[:2], dtype=bool), flat).reshape(e.shape)


class RotationSpline(NamedTuple):
    """What :func:`evaluate` needs per piece ``[i, i+1)``, ``i = 0 .. F-1`` (the last piece
    continues past the last sample): the control point ``c_{i-1}`` (ghost at a cut or an end)
    ``(F, ..., 4)``, the displacements ``v_{i-1}``, ``v_i``, ``v_{i+1}`` ``(F, ..., 3)``, the
    pieces that cross a jump ``(F, ...)`` and the samples ``(F, ..., 4)``; all with the
    columns in one axis, ``(F, C, ...)``, and ``shape`` the samples' own."""

    base: np.ndarray
    left: np.ndarray
    step: np.ndarray
    right: np.ndarray
    jump: np.ndarray
    samples: np.ndarray
    shape: tuple[int, ...] = ()


def _pieces(c: np.ndarray, jump: np.ndarray) -> RotationSpline:
    """The pieces of the curve through control points ``c`` ``(F, ..., 4)`` cut at ``jump``
    (``(F-1, ...)``), with ghosts at the cuts and the ends."""
    v = quat.displacements(c)
    v[jump] = 0.0
    n = c.shape[0]
    step = np.concatenate([v, v[-1:]])  # the last piece continues at the last velocity
    cut = np.concatenate([jump, np.zeros((1, *jump.shape[1:]), dtype=bool)])
    step[-1][cut[-2]] = 0.0  # ... unless the last sample stands alone: it is held
    # the left neighbour of piece i: step i-1 unless i is the first or follows a cut
    has_left = np.ones(cut.shape, dtype=bool)
    has_left[0] = False
    has_left[1:] &= ~cut[:-1]
    left = np.where(has_left[..., None], np.concatenate([step[:1], step[:-1]]), step)
    base = np.concatenate([c[:1], c[:-1]])
    ghost = quat.multiply(c, quat.exp(-step))
    base = np.where(has_left[..., None], base, ghost)
    # the right neighbour of piece i: step i+1 unless piece i+1 is a cut or past the end
    has_right = np.ones(cut.shape, dtype=bool)
    has_right[n - 2 :] = False
    has_right[: n - 2] &= ~cut[1 : n - 1]
    right = np.where(has_right[..., None], np.concatenate([step[1:], step[-1:]]), step)
    return RotationSpline(base, left, step, right, cut, c)


def _knot_errors(c: np.ndarray, q: np.ndarray, free: np.ndarray) -> np.ndarray:
    """``log(q(i)^-1 q_i)`` at the ``free`` knots (no jump on either side) of the curve
    through control points ``c`` (0 elsewhere), ``(F, C, 3)``: there ``q(i) = c_{i-1}
    exp(5/6 v_{i-1}) exp(1/6 v_i)``, no ghost involved."""
    v = quat.displacements(c)
    knots = quat.multiply(
        quat.multiply(c[:-2], quat.exp(v[:-1] * (5.0 / 6.0))), quat.exp(v[1:] * (1.0 / 6.0))
    )
    error = np.zeros(q.shape[:-1] + (3,))
    error[1:-1] = quat.log_shortest(quat.relative(knots, q[1:-1]))
    error[~free] = 0.0
    return error


def _solve_controls(q: np.ndarray, free: np.ndarray) -> np.ndarray:
    """Control points ``(F, C, 4)`` whose curve passes through ``q`` at every knot (module
    docstring), found column by column: a column stops once its residual is at
    :data:`TOLERANCE`; a pass that would raise a column's residual is taken back and that
    column's next step halved (large steps between samples make the linearisation rough)."""
    c = q.copy()
    active = np.flatnonzero(free.any(axis=0))
    scale = np.ones(q.shape[1])
    error = _knot_errors(c[:, active], q[:, active], free[:, active])
    size = np.abs(error).max(axis=(0, 2), initial=0.0)
    for _ in range(MAX_PASSES):
        going = size > TOLERANCE
        if not going.any():
            break
        if not going.all():
            active, error, size = active[going], error[:, going], size[going]
        every = active.size == q.shape[1]  # no copies of the columns while all are at work
        c_now, q_now, free_now = (x if every else x[:, active] for x in (c, q, free))
        d = solve_tridiagonal(free_now, error, COUPLING)
        d *= scale[active][None, :, None]
        trial = quat.multiply(c_now, quat.exp(d))
        new_error = _knot_errors(trial, q_now, free_now)
        new_size = np.abs(new_error).max(axis=(0, 2), initial=0.0)
        better = new_size < size
        if better.all():
            if every:
                c = trial
            else:
                c[:, active] = trial
            error, size = new_error, new_size
        else:
            c[:, active[better]] = trial[:, better]
            error[:, better] = new_error[:, better]
            size = np.where(better, new_size, size)
        scale[active] = np.where(better, np.minimum(2.0 * scale[active], 1.0), 0.5 * scale[active])
    return c


def rotation_spline(q: np.ndarray) -> RotationSpline:
    """The interpolating curve through sign-continuous unit quaternions ``q`` ``(F, ..., 4)``,
    ``F >= 2`` (module docstring), ready for :func:`evaluate`."""
    shape = np.shape(q)
    q = np.asarray(q, dtype=np.float64).reshape(shape[0], -1, 4)
    jump = jump_steps(q)
    # knots whose both neighbouring steps are no jump are solved for; the others are fixed
    free = np.zeros(q.shape[:-1], dtype=bool)
    free[1:-1] = ~jump[:-1] & ~jump[1:]
    c = _solve_controls(q, free) if free.any() else q
    return _pieces(c, jump)._replace(samples=q, shape=shape)


def _basis(u: np.ndarray, ndim: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    u = u.reshape((-1,) + (1,) * (ndim - 1))
    u2 = u * u
    u3 = u2 * u
    first = (5.0 + 3.0 * u - 3.0 * u2 + u3) / 6.0
    return first, (1.0 + 3.0 * u + 3.0 * u2 - 2.0 * u3) / 6.0, u3 / 6.0


def evaluate(spline: RotationSpline, index: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The curve of :func:`rotation_spline` at ``t = index + u`` (``(n,)``, ``index`` in
    ``-1 .. F-1``, ``u`` in [0, 1)): ``(n, ..., 4)`` unit quaternions. Across a jump it is
    the geodesic between the two samples (slerp); before the first sample and past the last
    it goes on at the end's angular velocity."""
    out = _evaluate(spline, np.asarray(index), np.asarray(u, dtype=np.float64))
    return out.reshape(out.shape[:1] + spline.shape[1:])


def _evaluate(spline: RotationSpline, index: np.ndarray, u: np.ndarray) -> np.ndarray:
    back = index < 0
    if back.any():  # q_0 exp(t v_0): the natural end's constant velocity, backwards
        out = np.empty(index.shape + spline.samples.shape[1:])
        ahead = ~back
        out[ahead] = _evaluate(spline, index[ahead], u[ahead])
        t = (u[back] - 1.0).reshape((-1,) + (1,) * (spline.step.ndim - 1))
        out[back] = quat.multiply(spline.samples[:1], quat.exp(t * spline.left[:1]))
        return out
    b1, b2, b3 = _basis(u, spline.step.ndim)
    out = quat.multiply(spline.base[index], quat.exp(b1 * spline.left[index]))
    out = quat.multiply(out, quat.exp(b2 * spline.step[index]))
    out = quat.multiply(out, quat.exp(b3 * spline.right[index]))
    jump = spline.jump[index]
    if jump.any():
        n = spline.samples.shape[0]
        q0 = spline.samples[index][jump]
        q1 = spline.samples[np.minimum(index + 1, n - 1)][jump]
        share = np.broadcast_to(u.reshape((-1,) + (1,) * (jump.ndim - 1)), jump.shape)[jump]
        out[jump] = quat.multiply(
            q0, quat.exp(share[:, None] * quat.log_shortest(quat.relative(q0, q1)))
        )
    return out


class PositionSpline(NamedTuple):
    """Control points ``(F + 3, ..., D)`` of a natural cubic spline as a uniform B-spline:
    ``c_{-1} .. c_{F+1}`` (the last two continue at the last velocity)."""

    controls: np.ndarray


def position_spline(p: np.ndarray) -> PositionSpline:
    """The natural cubic spline through ``p`` ``(F, ..., D)``, ``F >= 2``."""
    c = np.array(p, dtype=np.float64)
    if c.shape[0] > 2:
        knots = (c[:-2] + 4.0 * c[1:-1] + c[2:]) / 6.0
        c[1:-1] += solve_knots(c[1:-1] - knots)
    first, last = 2.0 * c[:1] - c[1:2], 2.0 * c[-1:] - c[-2:-1]
    return PositionSpline(np.concatenate([first, c, last, 2.0 * last - c[-1:]]))


def evaluate_positions(spline: PositionSpline, index: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The spline of :func:`position_spline` at ``t = index + u`` (``index`` in ``-1 ..
    F-1``; before the first sample it goes on at the first one's velocity): ``(n, ..., D)``."""
    controls = spline.controls
    back = index < 0
    index = np.maximum(index, 0)
    u = np.where(back, u - 1.0, u)
    b1, b2, b3 = _basis(u, controls.ndim)
    c0, c1, c2, c3 = (controls[index + k] for k in range(4))
    out = c0 + b1 * (c1 - c0) + b2 * (c2 - c1) + b3 * (c3 - c2)
    if back.any():  # the natural end is straight: p_0 + t (c_1 - c_0) before it
        t = u[back].reshape((-1,) + (1,) * (controls.ndim - 1))
        out[back] = controls[1] + t * (controls[2] - controls[1])
    return out
