"""Optimisation-based smoothers: motion fairing (001) and energy + SSE fairing (004).

* :func:`fairing` / :func:`fairing_positions` -- Lee & Shin's fixed-point fairing (001):
  damped order-``m`` fairing operators (Eq. 16-18) iterated while every sample stays within
  ``epsilon_r`` / ``epsilon_t`` of the input (Eq. 19-20) and every step lowers the fairing
  energy (Eq. 13). The result is the last iterate inside the bounds, so no output sample is
  farther than epsilon from its input sample, and its energy is at most the input's.
* :func:`sse_fairing` / :func:`sse_fairing_positions` -- Hsieh et al.'s objective (004):
  minimise ``D + beta E`` (orientations, Eq. 19, 21, 23) or ``D + alpha E`` (positions,
  Eq. 16, 20, 22) by gradient descent, the gradient taken in the tangent space at each
  ``q_i`` (Eq. 24-25) and the update ``q_i exp(-lambda grad_i)``, with a line search that
  makes the objective fall at every step. Time step h = 1 frame.

Units follow the papers: ``exp(v) = (cos|v|, v/|v| sin|v|)``, so an angle on S^3 such as
``|log(q0^-1 q)|`` or ``acos|q0 . q|`` (001 Eq. 19) is HALF the rotation angle; ``epsilon_r``
and the orientation ``tol`` and ``epsilon`` are in these radians. Position quantities are in
the caller's length unit.

Arrays are time-major, ``(F, ..., 4)`` quaternions ``(w, x, y, z)`` or ``(F, ..., 3)``
vectors. Every trailing element (joint, ...) is an independent signal: all signals iterate
together, each with its own stopping rule, and a signal that has stopped stays frozen.
Internally signals are held as component planes ``(C, F, N)`` (time on axis 1, signals
last) and run through the plane kernels of :mod:`motionclean.core.quat`.
"""

from __future__ import annotations

import math

import numpy as np

from ..core import checks, quat
from ..core.threads import in_parts
from .linear import MAX_ITERATIONS

__all__ = [
    "fairing",
    "fairing_energy",
    "fairing_energy_positions",
    "fairing_positions",
    "sse_fairing",
    "sse_fairing_positions",
    "sse_gradient",
    "sse_gradient_positions",
    "sse_objective",
    "sse_objective_positions",
]

#: Fairing orders implemented (001 Eq. 16 and Eq. 18).
ORDERS = (2, 3)
#: Largest damping accepted per order, rotations (``lam_r``) and positions (``lam_t``):
#: just below where the iteration ``I + lam (rho_m - I)`` of Eq. 17, with the end rows of
#: Eq. 16/18, gets an eigenvalue of modulus above 1 on a long signal (n >= 30), so that a
#: mode grows every iteration. m = 2 (both): 8/9, from the end mode ``r^i``, r = -1/2, of
#: eigenvalue ``1 - 9 lam / 4`` (the interior alone allows 1). m = 3 positions: 0.620 (the
#: interior alone allows 3/4). m = 3 rotations, linearised: 0.454 (the interior operator's
#: gain is 3/2 the position operator's, and Eq. 18's row n-2 differs). Found numerically
#: (``tests/filters/test_fairing.py`` checks them); shorter signals have lower limits
#: (0.845 for m = 2 at 5 frames), where the energy rule of :func:`_run_fairing` stops them.
MAX_LAM_R = {2: 0.88, 3: 0.45}
MAX_LAM_T = {2: 0.88, 3: 0.6}
#: Armijo constant of the line search: accept a step when the objective falls by at least
#: this fraction of the decrease predicted by the gradient.
ARMIJO = 1e-4
#: Halvings tried before a signal is declared stationary (no step lowers the objective).
MAX_BACKTRACKS = 40
#: A signal whose step needed halving and then lowered the objective by less than this
#: fraction has stalled at the precision of its evaluation or at a kink of the objective
#: (the shortest-arc logs are not differentiable at half turns).
STALL = 1e-12
#: Samples (frames x signals) solved together at most: the iterations hold about a dozen
#: copies of their signals, so a long clip is solved a few signals at a time, one group
#: after the other (each signal stops on its own: the result is each signal's, within
#: rounding for ``sse-fairing``, whose sums then run in another order), and memory stays a
#: few times the clip's. (Groups on threads would hold a dozen copies each at once, and
#: iterations on signals this long are bound by memory, not by the processor.)
GROUP_SAMPLES = 1 << 18


# --------------------------------------------------------------------------- layout


def _to_planes(x, width: int, what: str) -> tuple[np.ndarray, tuple[int, ...]]:
    """``(F, ..., width)`` -> contiguous planes ``(width, F, N)`` and the trailing shape."""
    x = checks.unit_quaternions(x, what) if width == 4 else checks.vectors(x, what)
    flat = x.reshape(x.shape[0], math.prod(x.shape[1:-1]), width)
    return np.ascontiguousarray(np.moveaxis(flat, -1, 0)), x.shape[1:-1]


def _quaternions(q) -> np.ndarray:
    """``q`` as float64, checked to be ``(F, ..., 4)`` before its signs are made continuous."""
    return checks.unit_quaternions(q)


def _from_planes(planes: np.ndarray, trailing: tuple[int, ...]) -> np.ndarray:
    """Planes ``(C, F, N)`` -> a new ``(F, *trailing, C)`` array."""
    c, f = planes.shape[:2]
    return np.ascontiguousarray(np.moveaxis(planes, 0, -1)).reshape(f, *trailing, c)


def _sq(x: np.ndarray) -> np.ndarray:
    """Sum of squares per signal of planes ``(C, T, N)``: shape ``(N,)``."""
    return np.einsum("ctn,ctn->n", x, x)


def _sq_each(x: np.ndarray) -> np.ndarray:
    """Squared norm of every sample of planes ``(C, T, N)``: shape ``(T, N)``."""
    return np.einsum("ctn,ctn->tn", x, x)


# --------------------------------------------------------------------------- plane algebra


def _qmul(p: np.ndarray, q: np.ndarray, conjugate_p: bool = False) -> np.ndarray:
    """Hamilton product ``p q`` (or ``p^-1 q``) of quaternion planes ``(4, ...)``."""
    out = np.empty((4, *np.broadcast_shapes(p.shape[1:], q.shape[1:])))
    quat.multiply_planes(out, p, q, np.empty((2, *out.shape[1:])), conjugate_p=conjugate_p)
    return out


def _qexp(v: np.ndarray) -> np.ndarray:
    """``exp(v)`` of vector planes ``(3, ...)``: quaternion planes ``(4, ...)``."""
    out = np.empty((4, *v.shape[1:]))
    quat.exp_planes(out, v, np.empty((3, *v.shape[1:])))
    return out


def _rel_log(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``log(a^-1 b)`` along the shorter arc (norm <= pi/2): the same for ``b`` and ``-b``."""
    rel = _qmul(a, b, conjugate_p=True)
    quat.log_planes(rel[1:], rel, np.empty((2, *rel.shape[1:])), shortest=True)
    return rel[1:]


def _step(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``q exp(v)``: move each sample by a tangent vector in its own frame."""
    return _qmul(q, _qexp(v))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of vector planes ``(3, ...)``."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    np.subtract(a[1] * b[2], a[2] * b[1], out[0])
    np.subtract(a[2] * b[0], a[0] * b[2], out[1])
    np.subtract(a[0] * b[1], a[1] * b[0], out[2])
    return out


def _renormalize(q: np.ndarray, iterations: np.ndarray) -> np.ndarray:
    """Remove rounding drift from the norm of signals that moved; others stay bit-exact."""
    moved = iterations > 0
    q[..., moved] /= np.sqrt(_sq_each(q[..., moved]))
    return q


def _solve(
    x0,
    trailing,
    min_frames: int,
    solve,
    return_iterations: bool,
    *,
    rotations: bool = False,
    continuous: bool = False,
):
    """Shared ending of the fairing functions, on the planes ``x0`` ``(width, F, N)``.

    ``solve(x0) -> (planes, iterations per signal)`` runs when the signals have at least
    ``min_frames`` frames, on :data:`GROUP_SAMPLES` samples' worth of signals at a time
    (one signal at least); shorter ones have no energy term
    and come back unchanged, after no iterations. With ``rotations`` the signals that
    moved lose the rounding drift of their norms (:func:`_renormalize`); with
    ``continuous`` the result is made sign-continuous. Returns the ``(F, ..., width)``
    result, and with ``return_iterations`` also the iterations, shape ``trailing``.
    """
    if x0.shape[1] < min_frames:
        out, iterations = x0, np.zeros(x0.shape[-1], dtype=np.int64)
    else:
        out, iterations = np.empty_like(x0), np.empty(x0.shape[-1], dtype=np.int64)
        group = max(GROUP_SAMPLES // x0.shape[1], 1)

        for signals in in_parts(x0.shape[-1], group):
            out[..., signals], iterations[signals] = solve(np.ascontiguousarray(x0[..., signals]))
        if rotations:
            out = _renormalize(out, iterations)
    out = _from_planes(out, trailing)
    if continuous:
        out = quat.make_continuous(out, axis=0)
    return (out, iterations.reshape(trailing)) if return_iterations else out


# --------------------------------------------------------------------------- validation


def _check_order(order) -> int:
    checks.number(order, "order")
    if order not in ORDERS:
        raise ValueError(f"order must be 2 or 3 (001 Eq. 16, 18), got {order!r}")
    return int(order)


def _check_damping(name: str, value, limit: float, order: int) -> float:
    """A damping of 001 Eq. 17 in ``(0, limit]``, the stability limit of ``order``."""
    value = checks.number(value, name)
    if not 0.0 < value <= limit:
        raise ValueError(
            f"{name} must be in (0, {limit:g}] for order {order} (damping of 001 Eq. 17; "
            f"above it the iteration diverges), got {value:g}"
        )
    return value


def _check_nonneg(name: str, value, *, finite: bool = True, rotation: bool = False) -> float:
    value = checks.number(value, name)
    if math.isnan(value) or value < 0.0 or (finite and math.isinf(value)):
        bound = ">= 0" if not finite else "finite and >= 0"
        hint = f" ({math.degrees(2.0 * value):g} degrees of rotation)" if rotation else ""
        raise ValueError(f"{name} must be {bound}, got {value:g}{hint}")
    return value


#: Largest weight of the energy term of :func:`sse_fairing` (``beta``, ``alpha``): the
#: iterations needed grow like ``1 + 16 beta``; far above it the gradient overflows (1e200
#: had printed numpy's "invalid value" and returned the input).
MAX_WEIGHT = 1e6


def _check_weight(name: str, value) -> float:
    value = _check_nonneg(name, value)
    if value > MAX_WEIGHT:
        raise ValueError(f"{name} must be at most {MAX_WEIGHT:g}, got {value:g}")
    return value


def _check_iterations(max_iterations) -> int:
    return checks.whole(max_iterations, "max_iterations", 0, MAX_ITERATIONS)


# --------------------------------------------------------------------------- 001: energy


def fairing_energy(q: np.ndarray, order: int) -> np.ndarray:
    """Order-``m`` rotational energy ``E_m^r = sum_i |W^m q_i|^2`` (001 Eq. 10-12).

    ``W^1 q_i = log(q_i^-1 q_{i+1})`` and ``W^m`` is its ``(m-1)``-th forward difference;
    ``i`` runs over every index where ``W^m q_i`` is defined. Returns one value per signal,
    shape ``q.shape[1:-1]``, in rad^2 (S^3 units); zero when ``F <= order``.
    """
    x, trailing = _to_planes(q, 4, "q")
    if x.shape[1] <= order:
        return np.zeros(trailing)
    return _sq(np.diff(_displacements(x), n=order - 1, axis=1)).reshape(trailing)


def fairing_energy_positions(p: np.ndarray, order: int) -> np.ndarray:
    """Order-``m`` translational energy ``E_m^t = sum_i |D^m p_i|^2`` (001 Eq. 8, 12)."""
    x, trailing = _to_planes(p, 3, "p")
    if x.shape[1] <= order:
        return np.zeros(trailing)
    return _sq(np.diff(x, n=order, axis=1)).reshape(trailing)


# --------------------------------------------------------------------------- 001: operators


def _displacements(q: np.ndarray) -> np.ndarray:
    """``w_i = log(q_i^-1 q_{i+1})`` of planes ``(4, n, N)``, shortest arc: ``(3, n-1, N)``."""
    return _rel_log(q[:, :-1], q[:, 1:])


def _rho_r_tangent(q: np.ndarray, w: np.ndarray, order: int):
    """Undamped rotational fairing operator ``rho_m^r`` on planes ``(4, n, N)``, ``n > m``,
    given their displacements ``w`` (:func:`_displacements`).

    Returns ``(segments, u)``: ``rho_m^r(Q)_i = q_a exp(u_i)`` where each segment
    ``(start, stop, a0)`` gives samples ``start .. stop-1`` the anchors ``a0, a0 + 1, ..``.
    With ``w_i = log(q_i^-1 q_{i+1})``:

    * m = 2 (001 Eq. 16), each line solving ``W^2 = 0`` for one sample: the ends extrapolate
      the neighbouring displacement, ``q_1 exp(-w_1) = q_1 q_2^-1 q_1`` and
      ``q_{n-2} exp(w_{n-3}) = q_{n-2} q_{n-3}^-1 q_{n-2}``; an interior sample moves to the
      geodesic midpoint ``slerp_1/2(q_{i-1}, q_{i+1}) = q_{i-1} exp(log(q_{i-1}^-1 q_{i+1})/2)``,
      the analogue of ``(p_{i-1} + p_{i+1}) / 2``. The printed ``q_{i+1} q_i^-1 q_{i-1}`` is a
      typo: to first order it is ``p_{i+1} - p_i + p_{i-1}``, the reflection of ``q_i``
      through that midpoint (same fixed points, twice the step, unstable undamped).
    * m = 3: Eq. 18 as printed (``W^3 = 0`` solved for one sample); the interior operator
      ``q_{i+1} exp(-(w_{i+1} + w_{i-1}) / 2)`` is one-sided (samples i-1 .. i+2).
    """
    n = q.shape[1]
    u = np.empty((3, *q.shape[1:]))
    if order == 2:
        u[:, 0] = -w[:, 1]
        u[:, 1:-1] = 0.5 * _rel_log(q[:, :-2], q[:, 2:])
        u[:, -1] = w[:, n - 3]
        return ((0, 1, 1), (1, n - 1, 0), (n - 1, n, n - 2)), u
    u[:, 0] = w[:, 2] - 2.0 * w[:, 1]
    u[:, 1 : n - 2] = -0.5 * (w[:, 2 : n - 1] + w[:, 0 : n - 3])
    u[:, n - 2] = 0.5 * (w[:, n - 2] + w[:, n - 4])
    u[:, n - 1] = 2.0 * w[:, n - 3] - w[:, n - 4]
    return ((0, 1, 1), (1, n - 2, 2), (n - 2, n - 1, n - 3), (n - 1, n, n - 2)), u


def _fair_r(q: np.ndarray, w: np.ndarray, order: int, lam: float) -> np.ndarray:
    """One damped step ``slerp(lam_r; Q, rho_m^r(Q))`` (001 Eq. 17) on planes, given the
    displacements ``w_i = log(q_i^-1 q_{i+1})`` (:func:`_displacements`)."""
    segments, u = _rho_r_tangent(q, w, order)
    e = _qexp(u)
    target = np.empty_like(q)
    tmp = np.empty((2, *q.shape[1:]))
    for start, stop, a0 in segments:
        quat.multiply_planes(
            target[:, start:stop],
            q[:, a0 : a0 + stop - start],
            e[:, start:stop],
            tmp[:, start:stop],
        )
    v = _rel_log(q, target)
    v *= lam
    return _step(q, v)


def _rho_t(p: np.ndarray, order: int) -> np.ndarray:
    """Undamped translational fairing operator ``rho_m^t`` (001 Eq. 16, 18) on planes."""
    n = p.shape[1]
    out = np.empty_like(p)
    if order == 2:
        out[:, 0] = 2.0 * p[:, 1] - p[:, 2]
        out[:, 1:-1] = 0.5 * (p[:, :-2] + p[:, 2:])
        out[:, -1] = 2.0 * p[:, -2] - p[:, -3]
    else:
        out[:, 0] = p[:, 3] - 3.0 * p[:, 2] + 3.0 * p[:, 1]
        out[:, 1 : n - 2] = p[:, 2 : n - 1] + (p[:, 0 : n - 3] - p[:, 3:n]) / 3.0
        out[:, n - 2] = p[:, n - 3] + (p[:, n - 1] - p[:, n - 4]) / 3.0
        out[:, n - 1] = p[:, n - 4] - 3.0 * p[:, n - 3] + 3.0 * p[:, n - 2]
    return out


def _sq_chord(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Squared chord ``min(|a - b|, |a + b|)^2 = (2 sin(dist / 2))^2`` per sample, ``(T, N)``.

    ``dist`` is 001 Eq. 19, the angle on S^3 between ``a`` and ``+-b`` (half the rotation
    angle); the chord is a monotone function of it that stays accurate for tiny angles.
    """
    c2 = _sq_each(a - b)
    return np.minimum(c2, 4.0 - c2)


def _sq_chord_of(angle: float) -> float:
    """``(2 sin(angle / 2))^2`` for an S^3 angle; above pi/2 no two rotations are as far."""
    return math.inf if angle > 0.5 * math.pi else (2.0 * math.sin(0.5 * angle)) ** 2


def _sq_euclidean(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return _sq_each(a - b)


def _run_fairing(x0, advance, parts, energy, sq_distance, sq_epsilon, sq_tol, max_iterations):
    """001 Fig. 1 on planes ``(C, F, N)``, per signal: iterate while inside the bound.

    ``advance(x, parts(x))`` is one damped step; ``energy(parts(x))`` the order-m energy
    per signal, the parts cached from one iteration to the next. ``sq_distance`` is a
    monotone function of the per-sample distance (squared chord or squared Euclidean),
    compared with the same function of epsilon and tol. A candidate iterate whose largest
    distance to the input reaches epsilon (Eq. 20), or whose energy exceeds the current one
    (a fairing operator lowers it, Eq. 13), is rejected and its signal stops, keeping the
    previous iterate; a signal also stops when no sample moved by tol or more, or after
    ``max_iterations``.
    """
    out = x0.copy()
    iterations = np.zeros(x0.shape[-1], dtype=np.int64)
    idx = np.arange(x0.shape[-1])  # the signals still iterating, held in ``cur``
    cur, ref = x0.copy(), x0
    cache = parts(cur)
    e_cur = energy(cache)
    for _ in range(max_iterations):
        if idx.size == 0:
            break
        cand = advance(cur, cache)
        cand_cache = parts(cand)
        e_cand = energy(cand_cache)
        ok = (np.max(sq_distance(ref, cand), axis=0) < sq_epsilon) & (e_cand <= e_cur)
        going = ok & (np.max(sq_distance(cur, cand), axis=0) >= sq_tol)
        iterations[idx[ok]] += 1
        if ok.all():
            cur, cache, e_cur = cand, cand_cache, e_cand
        else:
            cur[..., ok], cache[..., ok], e_cur[ok] = cand[..., ok], cand_cache[..., ok], e_cand[ok]
        if not going.all():
            out[..., idx[~going]] = cur[..., ~going]
            idx, cur, ref = idx[going], cur[..., going], ref[..., going]
            cache, e_cur = cache[..., going], e_cur[going]
    out[..., idx] = cur
    return out, iterations


def fairing(
    q: np.ndarray,
    order: int = 3,
    lam_r: float = 0.1,
    epsilon_r: float = 0.02,
    tol: float = 1e-7,
    max_iterations: int = 100,
    *,
    return_iterations: bool = False,
):
    """Lee-Shin motion fairing of orientations (001 Sec. 5, Fig. 1).

    Repeats ``Q <- slerp(lam_r; Q, rho_m^r(Q))`` (Eq. 17) with the order-``m`` fairing
    operator (Eq. 16 for m = 2, with the interior midpoint derived from ``W^2 = 0``; Eq. 18
    for m = 3), which lowers the order-``m`` energy :func:`fairing_energy` (Eq. 11) for a
    small enough ``lam_r``. Each signal (joint) stops on its own when the next iterate would
    put a sample ``epsilon_r`` or farther from its input (Eq. 19-20) or raise its energy
    (Eq. 13), when no sample moves by ``tol`` or more, or after ``max_iterations``; the last
    iterate kept is inside the bound, and its energy never above the input's.

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions ``(w, x, y, z)``, time along axis 0; made sign-continuous first.
    order : {2, 3}
        Order ``m`` of the energy and operator. 3 allows constant angular acceleration and
        stays closer to the data (001 Fig. 2); 2 pulls toward constant angular velocity.
        The m = 3 interior operator is one-sided, so its response is not zero-phase.
    lam_r : float in (0, MAX_LAM_R[order]]: (0, 0.88] for m = 2, (0, 0.45] for m = 3
        Damping ``lambda_r`` of Eq. 17 (paper: 0.1 to 0.3). The limits are the linearised
        iteration's, 8/9 and 0.454 on a long signal (:data:`MAX_LAM_R`); above them it
        diverges (the m = 3 interior operator's gain is 3/2 the position operator's).
    epsilon_r : float >= 0
        Bound on ``dist(q_i^(0), q_i)`` of Eq. 19, the S^3 angle ``acos|q0 . q|`` in radians,
        i.e. HALF the rotation angle: 0.02 allows 2.3 degrees of rotation. ``inf`` disables.
    tol : float >= 0
        Convergence: stop when no sample moved by ``tol`` (S^3 radians) or more.
    max_iterations : int >= 0
    return_iterations : bool
        Also return the accepted iterations per signal, shape ``q.shape[1:-1]``.

    Returns
    -------
    (F, ..., 4) array, sign-continuous, within ``epsilon_r`` of the input sample by sample;
    coordinate invariant (``fairing(a q b) = a fairing(q) b``). Signals with ``F <= order``
    have no energy to lower and are returned unchanged.
    """
    order = _check_order(order)
    lam = _check_damping("lam_r", lam_r, MAX_LAM_R[order], order)
    epsilon = _check_nonneg("epsilon_r", epsilon_r, finite=False, rotation=True)
    tol = _check_nonneg("tol", tol, rotation=True)
    iters_max = _check_iterations(max_iterations)
    x0, trailing = _to_planes(quat.make_continuous(_quaternions(q), axis=0), 4, "q")
    return _solve(
        x0,
        trailing,
        order + 1,
        lambda x: _run_fairing(
            x,
            lambda cur, w: _fair_r(cur, w, order, lam),
            _displacements,
            lambda w: _sq(np.diff(w, n=order - 1, axis=1)),
            _sq_chord,
            _sq_chord_of(epsilon),
            _sq_chord_of(tol),
            iters_max,
        ),
        return_iterations,
        rotations=True,
    )


def fairing_positions(
    p: np.ndarray,
    order: int = 3,
    lam_t: float = 0.5,
    epsilon_t: float = 1.0,
    tol: float = 1e-7,
    max_iterations: int = 100,
    *,
    return_iterations: bool = False,
):
    """Lee-Shin motion fairing of positions (001 Eq. 16-18, 20), the vector counterpart.

    Repeats ``P <- lam_t rho_m^t(P) + (1 - lam_t) P`` (Eq. 17). Each signal stops when the
    next iterate would move a sample ``epsilon_t`` or farther (Euclidean, the data's length
    unit) from its input, when no sample moves by ``tol`` or more, or after
    ``max_iterations``, or when the next iterate would raise its energy (Eq. 13); the last
    iterate inside the bound is returned. ``lam_t`` in (0, MAX_LAM_T[order]]: (0, 0.88] for
    m = 2, (0, 0.6] for m = 3 (paper: 0.5), below where the iteration diverges on a long
    signal, 8/9 and 0.620 (:data:`MAX_LAM_T`; Eq. 18's end rows lower the interior's 3/4).
    Affine operators, so the result commutes with rigid motions, and with uniform scaling
    when the bounds scale too. ``F <= order``: unchanged.
    """
    order = _check_order(order)
    lam = _check_damping("lam_t", lam_t, MAX_LAM_T[order], order)
    epsilon = _check_nonneg("epsilon_t", epsilon_t, finite=False)
    tol = _check_nonneg("tol", tol)
    iters_max = _check_iterations(max_iterations)
    x0, trailing = _to_planes(p, 3, "p")
    return _solve(
        x0,
        trailing,
        order + 1,
        lambda x: _run_fairing(
            x,
            lambda cur, _: cur + lam * (_rho_t(cur, order) - cur),
            lambda x: np.diff(x, n=order, axis=1),
            _sq,
            _sq_euclidean,
            epsilon * epsilon,
            tol * tol,
            iters_max,
        ),
        return_iterations,
    )


# --------------------------------------------------------------------------- 004: objective


def _log_jacobian_coefficient(t: np.ndarray) -> np.ndarray:
    """``(1 - t cot t) / t^2`` for ``t = |v|`` in ``[0, pi/2]``; series below 1e-2."""
    small = t < 1e-2
    ts = np.where(small, 1.0, t)
    direct = (1.0 - ts / np.tan(ts)) / (ts * ts)
    t2 = t * t
    series = 1.0 / 3.0 + t2 / 45.0 + 2.0 * t2 * t2 / 945.0
    return np.where(small, series, direct)


def _sse_parts(q: np.ndarray, q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distances ``d_i = log(q0_i^-1 q_i)`` and displacements ``w_i = log(q_i^-1 q_{i+1})``."""
    return _rel_log(q0, q), _rel_log(q[:, :-1], q[:, 1:])


def _sse_value(parts, beta: float) -> np.ndarray:
    d, w = parts
    return _sq(d) + beta * _sq(np.diff(w, axis=1))


def _sse_grad(parts, beta: float) -> np.ndarray:
    """004 Eq. 24-25 in closed form from :func:`_sse_parts` (``F >= 3``), planes ``(3, F, N)``.

    ``|d_i|^2`` has gradient ``2 d_i``. For ``q_i -> q_i exp(e)``,
    ``w_{i-1} -> w_{i-1} + J(w_{i-1}) e`` and ``w_i -> w_i - J(w_i)^T e`` to first order,
    with ``J(v) x = x + v x x + k(|v|) v x (v x x)``, ``k(t) = (1 - t cot t) / t^2`` (the
    inverse Jacobian of the paper's exp). So with ``g = dE/dw``,
    ``grad_i = 2 d_i + beta (J(w_{i-1})^T g_{i-1} - J(w_i) g_i)``.
    """
    d, w = parts
    e = 2.0 * np.diff(w, axis=1)  # dE/d(w_{i+1} - w_i)
    g = np.zeros_like(w)
    g[:, 1:] += e
    g[:, :-1] -= e
    k = _log_jacobian_coefficient(np.sqrt(_sq_each(w)))
    wg = _cross(w, g)
    sym = g + k * _cross(w, wg)
    grad = 2.0 * d
    grad[:, 1:] += beta * (sym - wg)
    grad[:, :-1] -= beta * (sym + wg)
    return grad


def _pos_parts(p: np.ndarray, p0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Offsets ``p_i - p0_i`` and second differences ``p_{i+1} - 2 p_i + p_{i-1}``."""
    return p - p0, np.diff(p, n=2, axis=1)


def _pos_value(parts, alpha: float) -> np.ndarray:
    r, e = parts
    return _sq(r) + alpha * _sq(e)


def _pos_grad(parts, alpha: float) -> np.ndarray:
    """``2 (p - p0) + 2 alpha D2^T D2 p`` (gradient of 004 Eq. 22)."""
    r, e = parts
    e = 2.0 * alpha * e
    grad = 2.0 * r
    grad[:, :-2] += e
    grad[:, 1:-1] -= 2.0 * e
    grad[:, 2:] += e
    return grad


def sse_objective(q: np.ndarray, q0: np.ndarray, beta: float) -> np.ndarray:
    """004 Eq. 23, ``G = D + beta E`` per signal, h = 1 frame, rad^2 (S^3 units).

    ``D = sum_i |log(q0_i^-1 q_i)|^2`` (Eq. 21) and
    ``E = sum_{i=1}^{n-2} |log(q_i^-1 q_{i+1}) - log(q_{i-1}^-1 q_i)|^2`` (Eq. 19); both
    logs along the shorter arc, so the value does not depend on quaternion signs.
    Returns shape ``q.shape[1:-1]``.
    """
    x, trailing = _to_planes(q, 4, "q")
    x0, _ = _to_planes(q0, 4, "q0")
    return _sse_value(_sse_parts(x, x0), float(beta)).reshape(trailing)


def sse_gradient(q: np.ndarray, q0: np.ndarray, beta: float) -> np.ndarray:
    """004 Eq. 24-25: ``dG/de_i`` at ``e = 0`` for ``q_i -> q_i exp(e_i)``, shape (F, ..., 3)."""
    x, trailing = _to_planes(q, 4, "q")
    x0, _ = _to_planes(q0, 4, "q0")
    parts = _sse_parts(x, x0)
    grad = 2.0 * parts[0] if x.shape[1] < 3 else _sse_grad(parts, float(beta))
    return _from_planes(grad, trailing)


def sse_objective_positions(p: np.ndarray, p0: np.ndarray, alpha: float) -> np.ndarray:
    """004 Eq. 22, ``F = D + alpha E`` per signal (Eq. 16, 20), h = 1 frame."""
    x, trailing = _to_planes(p, 3, "p")
    x0, _ = _to_planes(p0, 3, "p0")
    return _pos_value(_pos_parts(x, x0), float(alpha)).reshape(trailing)


def sse_gradient_positions(p: np.ndarray, p0: np.ndarray, alpha: float) -> np.ndarray:
    """Gradient of 004 Eq. 22 with respect to every ``p_i``, shape (F, ..., 3)."""
    x, trailing = _to_planes(p, 3, "p")
    x0, _ = _to_planes(p0, 3, "p0")
    return _from_planes(_pos_grad(_pos_parts(x, x0), float(alpha)), trailing)


# --------------------------------------------------------------------------- 004: descent


def _descend(x0, parts, value, gradient, move, weight, epsilon, max_iterations):
    """Gradient descent of 004 Sec. 3.3 per signal, with a backtracking line search.

    The first trial step is the minimiser along ``-grad`` of the quadratic model
    ``|dx|^2 + weight |D2 dx|^2`` (exact for positions); it is halved until the Armijo
    condition holds, so the objective falls at every accepted step. A signal stops when
    ``|grad| < epsilon`` (004 Step 3), after ``max_iterations``, or when it stalls: no step
    lowers it, or a halved step lowers it by less than a fraction ``STALL``. ``parts`` of
    the current iterates are cached between iterations.
    """
    out = x0.copy()
    iterations = np.zeros(x0.shape[-1], dtype=np.int64)
    idx = np.arange(x0.shape[-1])  # the signals still descending, held in ``x``
    x, ref = x0.copy(), x0
    cache = list(parts(x, ref))
    f = value(cache, weight)
    for _ in range(max_iterations):
        if idx.size == 0:
            break
        grad = gradient(cache, weight)
        g2 = _sq(grad)
        stop = (g2 == 0.0) | (np.sqrt(g2) < epsilon)
        pending = np.flatnonzero(~stop)
        lam = np.zeros(idx.size)
        curvature = g2[pending] + weight * _sq(np.diff(grad[..., pending], n=2, axis=1))
        lam[pending] = g2[pending] / (2.0 * curvature)
        for halvings in range(MAX_BACKTRACKS):
            if pending.size == 0:
                break
            full = pending.size == idx.size
            if full:
                xs, gs, rs = x, grad, ref
            else:
                xs, gs, rs = x[..., pending], grad[..., pending], ref[..., pending]
            cand = move(xs, -lam[pending] * gs)
            cand_parts = parts(cand, rs)
            fc = value(cand_parts, weight)
            fp = f[pending]
            ok = fc <= fp - ARMIJO * lam[pending] * g2[pending]
            accepted = pending[ok]
            if halvings:
                stop[accepted] = fp[ok] - fc[ok] <= STALL * np.abs(fp[ok])
            if full and ok.all():
                x, cache = cand, list(cand_parts)
            else:
                x[..., accepted] = cand[..., ok]
                for c, new in zip(cache, cand_parts, strict=True):
                    c[..., accepted] = new[..., ok]
            f[accepted] = fc[ok]
            iterations[idx[accepted]] += 1
            pending = pending[~ok]
            lam[pending] *= 0.5
        stop[pending] = True
        if stop.any():
            keep = ~stop
            out[..., idx[stop]] = x[..., stop]
            idx, x, ref, f = idx[keep], x[..., keep], ref[..., keep], f[keep]
            cache = [c[..., keep] for c in cache]
    out[..., idx] = x
    return out, iterations


def sse_fairing(
    q: np.ndarray,
    beta: float = 1.0,
    epsilon: float = 1e-6,
    max_iterations: int = 200,
    *,
    return_iterations: bool = False,
):
    """Energy + SSE fairing of orientations (004 Eq. 19, 21, 23-25).

    Minimises ``G = D + beta E`` (:func:`sse_objective`) by ``q_i <- q_i exp(-lam grad_i)``
    (004 Sec. 3.3, gradient :func:`sse_gradient` in the tangent space at each ``q_i``), with
    a line search on ``lam`` so that ``G`` falls at every step. Each signal stops when its
    gradient norm (over all frames) is below ``epsilon``, after ``max_iterations``, or when
    it stalls at floating-point precision.

    Parameters
    ----------
    q : (F, ..., 4) array
        Unit quaternions, time along axis 0; made sign-continuous first.
    beta : float, 0 to MAX_WEIGHT (1e6)
        Weight of the angular-acceleration energy against the squared distance, per frame
        (h = 1). 0 returns the input; larger is smoother and moves farther. The iterations
        needed grow roughly like ``1 + 16 beta`` (condition number of the problem).
    epsilon : float >= 0
        Gradient-norm tolerance in S^3 radians (004 Step 3).
    max_iterations : int >= 0
    return_iterations : bool
        Also return the accepted iterations per signal.

    Returns
    -------
    (F, ..., 4) array, sign-continuous. Coordinate invariant: ``H(a q b) = a H(q) b``.
    Fewer than 3 frames have no energy term and are returned unchanged.
    """
    beta = _check_weight("beta", beta)
    epsilon = _check_nonneg("epsilon", epsilon)
    iters_max = _check_iterations(max_iterations)
    x0, trailing = _to_planes(quat.make_continuous(_quaternions(q), axis=0), 4, "q")
    return _solve(
        x0,
        trailing,
        3,
        lambda x: _descend(x, _sse_parts, _sse_value, _sse_grad, _step, beta, epsilon, iters_max),
        return_iterations,
        rotations=True,
        continuous=True,
    )


def sse_fairing_positions(
    p: np.ndarray,
    alpha: float = 1.0,
    epsilon: float = 1e-6,
    max_iterations: int = 200,
    *,
    return_iterations: bool = False,
):
    """Energy + SSE fairing of positions (004 Eq. 16, 20, 22), the vector counterpart.

    Minimises ``F = D + alpha E`` (:func:`sse_objective_positions`) by steepest descent
    with an exact line search (the objective is quadratic), stopping per signal when the
    gradient norm is below ``epsilon`` (the data's length unit) or after ``max_iterations``.
    ``alpha`` >= 0, per frame (h = 1); 0 returns the input. The iterates commute with rigid
    motions and with uniform scaling (004 Sec. 1), up to the absolute ``epsilon`` stop.
    """
    alpha = _check_weight("alpha", alpha)
    epsilon = _check_nonneg("epsilon", epsilon)
    iters_max = _check_iterations(max_iterations)
    x0, trailing = _to_planes(p, 3, "p")
    return _solve(
        x0,
        trailing,
        3,
        lambda x: _descend(x, _pos_parts, _pos_value, _pos_grad, np.add, alpha, epsilon, iters_max),
        return_iterations,
    )
