"""Tests for motionclean.filters.fairing: motion fairing (001) and energy + SSE fairing (004)."""

from __future__ import annotations

import importlib
import math
import re
import tracemalloc

import numpy as np
import pytest
from helpers import CORPUS_NAMES, corpus_clip

import motionclean
from motionclean.core import quat
from motionclean.filters.fairing import (
    MAX_LAM_R,
    MAX_LAM_T,
    _displacements,
    _fair_r,
    _rho_t,
    fairing,
    fairing_energy,
    fairing_energy_positions,
    fairing_positions,
    sse_fairing,
    sse_fairing_positions,
    sse_gradient,
    sse_gradient_positions,
    sse_objective,
    sse_objective_positions,
)


def s3_dist(a, b):
    """001 Eq. 19: angle on S^3 between a and +-b (half the rotation angle)."""
    return 0.5 * quat.angle_between(a, b)


def random_rotation(rng, shape=()):
    return quat.normalize(rng.normal(size=(*shape, 4)))


def noisy_rotations(rng, frames, joints=(), noise=0.05, speed=0.05):
    """A smooth random rotation signal with per-sample noise (S^3 radians)."""
    shape = (frames, *joints)
    vel = np.cumsum(rng.normal(scale=0.01, size=(*shape, 3)), axis=0) + rng.normal(
        scale=speed, size=(1, *joints, 3)
    )
    q = np.empty((*shape, 4))
    q[0] = random_rotation(rng, joints)
    steps = quat.exp(vel)
    for i in range(1, frames):  # test data only
        q[i] = quat.multiply(q[i - 1], steps[i])
    return quat.multiply(q, quat.exp(rng.normal(scale=noise, size=(*shape, 3))))


def noisy_positions(rng, frames, joints=(), noise=0.3):
    t = np.linspace(0.0, 4.0 * np.pi, frames)
    base = np.stack([10.0 * np.sin(t), 5.0 * np.cos(0.5 * t), t], axis=-1)
    base = base.reshape(frames, *([1] * len(joints)), 3) + rng.normal(size=(1, *joints, 3))
    return base + rng.normal(scale=noise, size=(frames, *joints, 3))


def uniform_rotation(frames, a, b, v):
    """``a exp(i v) b``: constant angular velocity, a fixed point of both fairing orders."""
    i = np.arange(frames)[:, None]
    return quat.multiply(quat.multiply(a, quat.exp(i * v)), b)


def corpus_motion(name="131_02.bvh"):
    return motionclean.load(corpus_clip(name))


# ------------------------------------------------------------------ 001: bounds (Eq. 19-20)


@pytest.mark.parametrize("order", [2, 3])
@pytest.mark.parametrize("lam_r", [0.1, 0.4])
@pytest.mark.parametrize("epsilon_r", [0.02, 0.06])
def test_fairing_stays_within_epsilon_r_random(order, lam_r, epsilon_r):
    rng = np.random.default_rng(order * 100 + int(lam_r * 10) + int(epsilon_r * 1000))
    q = noisy_rotations(rng, 150, (3, 2), noise=0.002)
    out, iterations = fairing(
        q,
        order=order,
        lam_r=lam_r,
        epsilon_r=epsilon_r,
        tol=0.0,
        max_iterations=400,
        return_iterations=True,
    )
    assert out.shape == q.shape and iterations.shape == (3, 2)
    assert np.all(s3_dist(q, out) < epsilon_r)
    assert np.all(iterations > 0)  # the bound was reached by moving, not by standing still
    assert np.all(iterations < 400)  # and it is what stopped every joint here


@pytest.mark.parametrize("order", [2, 3])
@pytest.mark.parametrize("epsilon_t", [0.05, 0.5])
def test_fairing_positions_stay_within_epsilon_t_random(order, epsilon_t):
    rng = np.random.default_rng(7 + order)
    p = noisy_positions(rng, 200, (4,), noise=0.002)
    out, iterations = fairing_positions(
        p,
        order=order,
        lam_t=0.5,
        epsilon_t=epsilon_t,
        tol=0.0,
        max_iterations=3000,
        return_iterations=True,
    )
    assert np.all(np.linalg.norm(out - p, axis=-1) < epsilon_t)
    assert np.all((iterations > 0) & (iterations < 3000))


def test_fairing_returns_the_last_iterate_inside_the_bound():
    """001 Fig. 1 stops after the bound is broken; we return the iterate before that one."""
    rng = np.random.default_rng(3)
    q = noisy_rotations(rng, 80, (4,), noise=0.005)
    eps = 0.02
    out, iterations = fairing(
        q,
        order=3,
        lam_r=0.2,
        epsilon_r=eps,
        tol=0.0,
        max_iterations=400,
        return_iterations=True,
    )
    for j in range(q.shape[1]):
        k = int(iterations[j])
        assert 0 < k < 400
        free_k = fairing(q[:, j], 3, 0.2, math.inf, 0.0, k)
        free_next = fairing(q[:, j], 3, 0.2, math.inf, 0.0, k + 1)
        np.testing.assert_allclose(out[:, j], free_k, atol=1e-12)
        assert s3_dist(q[:, j], free_k).max() < eps <= s3_dist(q[:, j], free_next).max()


@pytest.mark.parametrize("clip", CORPUS_NAMES)
def test_fairing_corpus_clip_within_bounds(clip):
    m = corpus_motion(clip)
    q, p = m.rotations, m.translations
    eps_r = 0.01
    out, iterations = fairing(q, epsilon_r=eps_r, return_iterations=True)
    assert np.all(np.isfinite(out))
    assert np.all(s3_dist(q, out) < eps_r)  # RThumb's half-turn flips included
    moving = np.ptp(q, axis=0).max(axis=-1) > 1e-6
    assert np.mean(iterations[moving] > 0) > 0.8  # a joint with flips may stop at once
    eps_t = 0.1
    out_p = fairing_positions(p, epsilon_t=eps_t, max_iterations=300)
    assert np.all(np.linalg.norm(out_p - p, axis=-1) < eps_t)
    assert np.abs(out_p - p).max() > 0.1 * eps_t


# ------------------------------------------------------------------ 001: operators, energy


@pytest.mark.parametrize("order", [2, 3])
def test_fairing_energy_falls_with_small_damping(order):
    rng = np.random.default_rng(11 + order)
    q = noisy_rotations(rng, 60, (3,), noise=0.05)
    p = noisy_positions(rng, 60, (3,))
    checkpoints = [0, 1, 2, 5, 10, 20, 40, 80]
    e_r = [fairing_energy(fairing(q, order, 0.05, math.inf, 0.0, k), order) for k in checkpoints]
    e_t = [
        fairing_energy_positions(fairing_positions(p, order, 0.05, math.inf, 0.0, k), order)
        for k in checkpoints
    ]
    for energies in (np.array(e_r), np.array(e_t)):
        assert np.all(np.diff(energies, axis=0) < 0.0)
        assert np.all(energies[-1] < 0.5 * energies[0])


def iteration_matrix(operator: np.ndarray, lam: float) -> np.ndarray:
    """``I + lam (R - I)``: one damped step of 001 Eq. 17 on a linear operator ``R``."""
    return np.eye(len(operator)) + lam * (operator - np.eye(len(operator)))


def operator_matrix(kind: str, order: int, n: int) -> np.ndarray:
    """``rho_m`` as an ``n x n`` matrix: the position operator, or the rotational one
    linearised about the identity (tiny rotations about z, one signal per unit vector)."""
    if kind == "t":
        return _rho_t(np.eye(n)[None], order)[0]
    q = np.moveaxis(quat.exp(1e-7 * np.eye(n)[..., None] * [0.0, 0.0, 1.0]), -1, 0)
    return _fair_r(q, _displacements(q), order, 1.0)[3] / 1e-7


def spectral_radius(matrix: np.ndarray) -> float:
    return float(np.abs(np.linalg.eigvals(matrix)).max())


def test_the_rotational_operator_is_the_positions_one_to_first_order():
    """For tiny rotations about one axis ``rho_m`` on the rotations is the position operator
    on their angles: every row for m = 2, the end rows for m = 3 (its interior is Eq. 18's
    one-sided form, the positions' a symmetric one); both keep every quadratic."""
    n = 12
    np.testing.assert_allclose(operator_matrix("r", 2, n), operator_matrix("t", 2, n), atol=1e-6)
    r, t = operator_matrix("r", 3, n), operator_matrix("t", 3, n)
    np.testing.assert_allclose(r[[0, -1]], t[[0, -1]], atol=1e-6)
    quadratic = np.vander(np.linspace(-1.0, 1.0, n), 3)
    np.testing.assert_allclose(r @ quadratic, quadratic, atol=1e-6)


@pytest.mark.parametrize(
    ("kind", "order", "limit"), [("r", 2, 8 / 9), ("r", 3, 0.454), ("t", 2, 8 / 9), ("t", 3, 0.620)]
)
def test_damping_limits_are_where_the_iteration_starts_to_diverge(kind, order, limit):
    """The largest accepted damping keeps every mode of a long signal from growing, and the
    limit the docstrings derive is where one starts to: 8/9 (m = 2), 0.620 (positions,
    m = 3; the interior alone would allow 3/4), 0.454 (rotations, m = 3)."""
    cap = (MAX_LAM_R if kind == "r" else MAX_LAM_T)[order]
    operator = operator_matrix(kind, order, 60)
    assert cap < limit  # (eigenvalue 1: the polynomials of degree < m, kept)
    assert spectral_radius(iteration_matrix(operator, cap)) < 1.0 + 1e-9
    assert spectral_radius(iteration_matrix(operator, limit - 0.001)) < 1.0 + 1e-9
    assert spectral_radius(iteration_matrix(operator, limit + 0.001)) > 1.0 + 1e-4


@pytest.mark.parametrize(("order", "lam_r", "lam_t"), [(2, 0.88, 0.88), (3, 0.45, 0.6)])
def test_energy_never_rises_at_the_largest_damping_on_a_real_clip(order, lam_r, lam_t):
    """001 Eq. 13 at the edges of the accepted range, no bound, every joint of 131_02
    (RThumb's half-turn flips included, where a step had raised the energy)."""
    m = corpus_motion()
    q, p = m.rotations[:300], m.translations[:300, :1]
    e_r = [fairing_energy(fairing(q, order, lam_r, math.inf, 0.0, k), order) for k in range(25)]
    e_t = [
        fairing_energy_positions(fairing_positions(p, order, lam_t, math.inf, 0.0, k), order)
        for k in range(25)
    ]
    for energies in (np.array(e_r), np.array(e_t)):
        assert np.all(np.diff(energies, axis=0) <= 1e-12 * energies[:-1])
        moving = energies[0] > 0.0  # RThumb's first step would raise it: it stays
        assert np.mean(energies[-1][moving] < 0.9 * energies[0][moving]) > 0.9


def test_a_step_that_would_raise_the_energy_is_not_taken():
    """Below the divergence limit a step can still raise the energy of some signals: the
    worst one for m = 3 at lam_t = 0.6, and any 5-frame signal at m = 2, lam 0.88 (its own
    limit is 0.845). Such a signal stops where its energy would rise, and stays bounded."""
    n, order = 40, 3
    d = np.diff(np.eye(n), n=order, axis=0)
    gain = (
        d @ iteration_matrix(operator_matrix("t", order, n), MAX_LAM_T[order]) @ np.linalg.pinv(d)
    )
    _, singular, right = np.linalg.svd(gain)
    assert singular[0] > 1.0  # that signal's energy would rise in one step
    worst = np.repeat((np.linalg.pinv(d) @ right[0])[:, None, None], 3, axis=-1)
    out, iterations = fairing_positions(worst, order, 0.6, math.inf, return_iterations=True)
    assert iterations == 0 and np.array_equal(out, worst)
    short = np.random.default_rng(3).normal(size=(5, 20, 3))
    assert spectral_radius(iteration_matrix(operator_matrix("t", 2, 5), 0.88)) > 1.0
    out = fairing_positions(short, 2, 0.88, math.inf, 0.0, 2000)
    assert np.all(fairing_energy_positions(out, 2) <= fairing_energy_positions(short, 2))
    assert np.abs(out - short).max() < 10.0 * np.abs(short).max()
    q = quat.exp(0.3 * short)
    out_q = fairing(q, 2, 0.88, math.inf, 0.0, 2000)
    assert np.all(fairing_energy(out_q, 2) <= fairing_energy(q, 2) * (1 + 1e-12))


@pytest.mark.parametrize(
    ("order", "name", "value"), [(3, "lam_r", 0.49), (2, "lam_r", 0.9), (3, "lam_t", 0.7)]
)
def test_a_damping_past_its_order_s_limit_is_refused(order, name, value):
    """The dampings that had diverged on 131_02 (lam_t = 0.7 moved its root by 5.3e6
    units; lam_r = 0.49 raised the order-3 energy of 13 joints up to 288 times)."""
    p = corpus_motion().translations[:100, :1]
    call = fairing_positions if name == "lam_t" else fairing
    with pytest.raises(ValueError, match=rf"^{name} must be in \(0, 0\.\d+\] for order {order}"):
        call(quat.exp(1e-3 * p) if name == "lam_r" else p, order, value)


def test_order2_interior_operator_is_the_geodesic_midpoint():
    """One step half-way (lam 1/2) toward q_1 -> slerp_1/2(q_0, q_2), the analogue of
    (p_0 + p_2) / 2."""
    rng = np.random.default_rng(5)
    q = quat.make_continuous(noisy_rotations(rng, 3, (6,), noise=0.3))
    out = fairing(q, order=2, lam_r=0.5, epsilon_r=math.inf, tol=0.0, max_iterations=1)
    mid = quat.slerp(q[0], q[2], 0.5)
    assert s3_dist(out[1], quat.slerp(q[1], mid, 0.5)).max() < 1e-12
    # the ends extrapolate: q_0 -> q_1 q_2^-1 q_1 (001 Eq. 16)
    end = quat.multiply(quat.multiply(q[1], quat.conjugate(q[2])), q[1])
    assert s3_dist(out[0], quat.slerp(q[0], end, 0.5)).max() < 1e-12
    p = rng.normal(size=(3, 6, 3))
    out_p = fairing_positions(p, order=2, lam_t=0.5, epsilon_t=math.inf, max_iterations=1)
    np.testing.assert_allclose(out_p[1], 0.5 * p[1] + 0.25 * (p[0] + p[2]))


def test_fairing_fixed_points():
    """W^m = 0 signals stay put: uniform rotation (m = 2, 3), constant acceleration (m = 3)."""
    rng = np.random.default_rng(9)
    a, b = random_rotation(rng), random_rotation(rng)
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    uniform = uniform_rotation(40, a, b, 0.07 * axis)
    for order in (2, 3):
        out = fairing(uniform, order, 0.3, math.inf, 0.0, 50)
        assert s3_dist(uniform, out).max() < 1e-10
    i = np.arange(40)[:, None]
    accel = quat.multiply(quat.multiply(a, quat.exp((0.02 * i + 0.003 * i * i) * axis)), b)
    assert s3_dist(accel, fairing(accel, 3, 0.3, math.inf, 0.0, 50)).max() < 1e-9
    assert s3_dist(accel, fairing(accel, 2, 0.3, math.inf, 0.0, 50)).max() > 1e-3
    quadratic = 1.0 + 0.5 * i - 0.02 * i * i + np.zeros((1, 3))
    np.testing.assert_allclose(fairing_positions(quadratic, 3, 0.5, math.inf), quadratic)


def test_fairing_joints_are_independent():
    """Each joint has its own stopping rule: together equals one at a time."""
    rng = np.random.default_rng(21)
    q = noisy_rotations(rng, 70, (5,), noise=0.004)
    q[:, 2] = q[0, 2]  # a constant joint stops at once
    together, iterations = fairing(q, 3, 0.2, 0.02, return_iterations=True)
    assert len(set(iterations.tolist())) > 2
    for j in range(5):
        np.testing.assert_allclose(together[:, j], fairing(q[:, j], 3, 0.2, 0.02), atol=1e-14)
    p = noisy_positions(rng, 70, (5,))
    together_p = fairing_positions(p, 3, 0.5, 0.2)
    for j in range(5):
        np.testing.assert_allclose(together_p[:, j], fairing_positions(p[:, j], 3, 0.5, 0.2))


@pytest.mark.parametrize("solver", [fairing, sse_fairing])
def test_a_long_clip_is_solved_a_few_signals_at_a_time(solver, monkeypatch):
    """Memory stays a few times the clip's: the iterations' dozen copies are made of a
    group of signals at a time, one group after the other even with threads to spare (here
    one signal: the groups shrunk to fit a short test clip), and the result is each
    signal's own."""
    module = importlib.import_module("motionclean.filters.fairing")  # not the function
    rng = np.random.default_rng(5)
    q = noisy_rotations(rng, 8200, (8,), noise=0.004)  # enough to be shared on threads
    whole = solver(q, max_iterations=5)
    monkeypatch.setenv("MOTIONCLEAN_THREADS", "4")  # groups one after the other all the same
    monkeypatch.setattr(module, "GROUP_SAMPLES", 8200)
    tracemalloc.start()
    try:
        grouped = solver(q, max_iterations=5)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 6 * q.nbytes
    np.testing.assert_allclose(grouped, whole, rtol=0, atol=1e-12)


# ------------------------------------------------------------------ invariance


@pytest.mark.parametrize("order", [2, 3])
def test_fairing_coordinate_invariance(order):
    rng = np.random.default_rng(30 + order)
    q = noisy_rotations(rng, 90, (3,), noise=0.05)
    a, b = random_rotation(rng), random_rotation(rng)
    out, it = fairing(q, order, 0.2, 0.03, return_iterations=True)
    moved, it_moved = fairing(
        quat.multiply(quat.multiply(a, q), b), order, 0.2, 0.03, return_iterations=True
    )
    np.testing.assert_array_equal(it, it_moved)
    assert s3_dist(moved, quat.multiply(quat.multiply(a, out), b)).max() < 1e-10


def test_fairing_positions_rigid_and_scale_invariance():
    rng = np.random.default_rng(40)
    p = noisy_positions(rng, 90, (3,))
    r = quat.as_matrix(random_rotation(rng))
    t = np.array([3.0, -7.0, 11.0])
    out = fairing_positions(p, 3, 0.5, 0.4)
    np.testing.assert_allclose(
        fairing_positions(p @ r.T + t, 3, 0.5, 0.4), out @ r.T + t, atol=1e-9
    )
    np.testing.assert_allclose(
        fairing_positions(25.0 * p, 3, 0.5, 25.0 * 0.4), 25.0 * out, rtol=1e-12, atol=1e-9
    )


def test_sse_fairing_coordinate_invariance():
    rng = np.random.default_rng(50)
    q = noisy_rotations(rng, 60, (3,), noise=0.05)
    a, b = random_rotation(rng), random_rotation(rng)
    out, it = sse_fairing(q, beta=2.0, epsilon=0.0, max_iterations=60, return_iterations=True)
    moved, it_moved = sse_fairing(
        quat.multiply(quat.multiply(a, q), b), 2.0, 0.0, 60, return_iterations=True
    )
    np.testing.assert_array_equal(it, 60)
    np.testing.assert_array_equal(it_moved, 60)
    assert s3_dist(moved, quat.multiply(quat.multiply(a, out), b)).max() < 1e-11


def test_sse_fairing_positions_rigid_and_scale_invariance():
    """004 Sec. 1: the formulation is invariant under uniform scaling of the positions."""
    rng = np.random.default_rng(51)
    p = noisy_positions(rng, 80, (2,))
    out, it = sse_fairing_positions(p, 3.0, 0.0, 40, return_iterations=True)
    scaled, it_scaled = sse_fairing_positions(40.0 * p, 3.0, 0.0, 40, return_iterations=True)
    np.testing.assert_array_equal(it, 40)
    np.testing.assert_array_equal(it_scaled, 40)
    np.testing.assert_allclose(scaled, 40.0 * out, rtol=1e-12, atol=1e-10)
    assert np.abs(out - p).max() > 0.1  # the test is not about an unchanged signal
    r = quat.as_matrix(random_rotation(rng))
    t = np.array([-2.0, 5.0, 1.0])
    np.testing.assert_allclose(
        sse_fairing_positions(p @ r.T + t, 3.0, 0.0, 40), out @ r.T + t, atol=1e-10
    )


# ------------------------------------------------------------------ 004: objective


@pytest.mark.parametrize("beta", [0.0, 0.5, 4.0])
def test_sse_gradient_matches_finite_differences(beta):
    rng = np.random.default_rng(60)
    q0 = noisy_rotations(rng, 9, (2,), noise=0.2, speed=0.4)  # displacements up to ~1 rad
    q = quat.multiply(q0, quat.exp(rng.normal(scale=0.2, size=q0.shape[:-1] + (3,))))
    grad = sse_gradient(q, q0, beta)
    h = 1e-6
    numeric = np.zeros_like(grad)
    for i in range(q.shape[0]):
        for c in range(3):
            e = np.zeros(q.shape[:-1] + (3,))
            e[i, :, c] = h
            up = sse_objective(quat.multiply(q, quat.exp(e)), q0, beta)
            down = sse_objective(quat.multiply(q, quat.exp(-e)), q0, beta)
            numeric[i, :, c] = (up - down) / (2 * h)
    np.testing.assert_allclose(grad, numeric, atol=1e-7 * (1 + np.abs(grad).max()))

    p0 = rng.normal(size=(7, 2, 3))
    p = p0 + rng.normal(scale=0.3, size=p0.shape)
    grad_p = sse_gradient_positions(p, p0, beta)
    numeric_p = np.zeros_like(grad_p)
    for i in range(7):
        for c in range(3):
            e = np.zeros_like(p)
            e[i, :, c] = h
            numeric_p[i, :, c] = (
                sse_objective_positions(p + e, p0, beta) - sse_objective_positions(p - e, p0, beta)
            ) / (2 * h)
    np.testing.assert_allclose(grad_p, numeric_p, atol=1e-6)


def test_sse_positions_reach_the_minimiser():
    """Eq. 22 is quadratic: the descent must end at the solution of (I + alpha D2^T D2) p = p0."""
    rng = np.random.default_rng(65)
    p0 = noisy_positions(rng, 40, (2,))
    alpha = 2.0
    d2 = np.diff(np.eye(40), n=2, axis=0)
    exact = np.linalg.solve(np.eye(40) + alpha * d2.T @ d2, p0.reshape(40, -1)).reshape(p0.shape)
    out = sse_fairing_positions(p0, alpha, epsilon=1e-9, max_iterations=5000)
    np.testing.assert_allclose(out, exact, atol=1e-6)  # value-based line search: ~sqrt(eps)
    assert np.abs(exact - p0).max() > 0.1


def test_sse_zero_weight_returns_the_input():
    rng = np.random.default_rng(70)
    q = noisy_rotations(rng, 50, (3,), noise=0.1)
    flipped = q.copy()
    flipped[10] *= -1.0  # same rotations; the input sign pattern must not matter
    out, it = sse_fairing(flipped, beta=0.0, return_iterations=True)
    np.testing.assert_array_equal(it, 0)
    np.testing.assert_array_equal(out, quat.make_continuous(flipped))
    p = noisy_positions(rng, 50, (3,))
    np.testing.assert_array_equal(sse_fairing_positions(p, alpha=0.0), p)


def test_sse_objective_falls_every_step():
    rng = np.random.default_rng(71)
    cases = [
        (noisy_rotations(rng, 60, (2,), noise=0.15), 3.0),
        (flipping_signal(np.random.default_rng(0), 60), 1.0),  # kinks: the line search works
        (flipping_signal(np.random.default_rng(1), 60), 3.0),
    ]
    for q, beta in cases:
        runs = [sse_fairing(q, beta, 0.0, k, return_iterations=True) for k in range(0, 20)]
        g = np.array([sse_objective(out, q, beta) for out, _ in runs])
        steps = np.diff([it for _, it in runs], axis=0)
        assert np.all(steps >= 0) and steps[:10].all()
        assert np.all(np.diff(g, axis=0)[steps > 0] < 0.0)
        assert np.all(np.diff(g, axis=0)[steps == 0] == 0.0)  # a stopped signal stays put
    p = noisy_positions(rng, 60, (2,))
    f = [
        sse_objective_positions(sse_fairing_positions(p, 3.0, 0.0, k), p, 3.0) for k in range(0, 25)
    ]
    assert np.all(np.diff(f, axis=0) < 0.0)


def test_sse_stops_on_the_gradient_norm():
    rng = np.random.default_rng(72)
    q = noisy_rotations(rng, 80, (3,), noise=0.05)
    out, it = sse_fairing(q, 1.0, epsilon=1e-7, max_iterations=2000, return_iterations=True)
    assert np.all((it > 0) & (it < 2000))
    grad = sse_gradient(out, q, 1.0)
    assert np.sqrt(np.einsum("fjc,fjc->j", grad, grad)).max() < 1e-7
    capped, it_capped = sse_fairing(q, 1.0, 1e-7, 5, return_iterations=True)
    np.testing.assert_array_equal(it_capped, 5)


def test_larger_beta_lower_energy_larger_deviation():
    rng = np.random.default_rng(80)
    q = noisy_rotations(rng, 60, (2,), noise=0.08)
    p = noisy_positions(rng, 60, (2,), noise=0.5)
    weights = [0.1, 0.3, 1.0, 3.0]
    energy, distance, energy_p, distance_p = [], [], [], []
    for w in weights:
        out = sse_fairing(q, w, 1e-10, 3000)
        energy.append(sse_objective(out, out, 1.0))  # E alone: D(out, out) = 0
        distance.append(sse_objective(out, q, 0.0))
        out_p = sse_fairing_positions(p, w, 1e-10, 3000)
        energy_p.append(sse_objective_positions(out_p, out_p, 1.0))
        distance_p.append(sse_objective_positions(out_p, p, 0.0))
    for e, d in ((energy, distance), (energy_p, distance_p)):
        assert np.all(np.diff(e, axis=0) < 0.0)
        assert np.all(np.diff(d, axis=0) > 0.0)
    assert np.all(energy[0] < sse_objective(q, q, 1.0))


def test_sse_corpus_clip():
    m = corpus_motion()
    q = m.rotations[:400]
    out, it = sse_fairing(q, beta=1.0, return_iterations=True)
    assert np.all(np.isfinite(out)) and np.all(it <= 200)
    g_in = sse_objective(q, q, 1.0)
    assert np.all(sse_objective(out, q, 1.0) <= g_in)
    moving = g_in > 0
    assert np.all(sse_objective(out, out, 1.0)[moving] < sse_objective(q, q, 1.0)[moving])


# ------------------------------------------------------------------ adversarial inputs


def flipping_signal(rng, frames=40):
    """Half-turn toggles (like the corpus's RThumb) and exact 180-degree steps."""
    q = noisy_rotations(rng, frames, (2,), noise=0.01)
    half_turn = quat.from_axis_angle(np.array([0.0, 0.6, 0.8]), np.pi)
    q[5:9, 0] = quat.multiply(q[5:9, 0], half_turn)
    q[20, 0] = quat.multiply(q[20, 0], half_turn)
    q[::2, 1] = quat.multiply(q[::2, 1], half_turn)  # every step a half turn
    q[7] *= -1.0
    return q


@pytest.mark.parametrize(
    "smoother",
    [
        lambda q: fairing(q, 2, 0.3, 0.05),
        lambda q: fairing(q, 3, 0.1, math.inf, max_iterations=60),
        lambda q: sse_fairing(q, 2.0, max_iterations=60),
    ],
)
def test_adversarial_rotations_terminate_without_nan(smoother):
    rng = np.random.default_rng(90)
    cases = [
        flipping_signal(rng),
        np.tile(random_rotation(rng), (30, 3, 1)),  # constant
        random_rotation(rng, (2, 3)),  # two frames
        random_rotation(rng, (1, 3)),  # one frame
        np.zeros((0, 3, 4)) + [1.0, 0, 0, 0],  # no frames
        random_rotation(rng, (3, 3)),
        random_rotation(rng, (4, 3)),
        random_rotation(rng, (50,)),  # (F, 4): a single signal, noise only
    ]
    for q in cases:
        out = smoother(q)
        assert out.shape == q.shape
        assert np.all(np.isfinite(out))
        np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, atol=1e-12)


def test_short_and_constant_signals_are_returned_unchanged():
    rng = np.random.default_rng(91)
    for frames in (0, 1, 2):
        q = random_rotation(rng, (frames, 2))
        for out in (fairing(q, 2), fairing(q, 3), sse_fairing(q, 5.0)):
            assert s3_dist(out, q).size == 0 or s3_dist(out, q).max() < 1e-15
        p = rng.normal(size=(frames, 2, 3))
        for out in (fairing_positions(p, 2), sse_fairing_positions(p, 5.0)):
            np.testing.assert_array_equal(out, p)
    q3 = random_rotation(rng, (3, 2))
    np.testing.assert_array_equal(fairing(q3, 3), quat.make_continuous(q3))  # F <= order
    const = np.tile(random_rotation(rng), (20, 1))
    out, it = fairing(const, 3, return_iterations=True)
    assert s3_dist(out, const).max() < 1e-15 and it == 1  # converged: nothing moved
    flips = flipping_signal(rng)
    assert np.all(s3_dist(flips, fairing(flips, 3, 0.1, 0.05)) < 0.05)


def test_parameter_validation():
    q = np.tile([1.0, 0.0, 0.0, 0.0], (10, 1))
    with pytest.raises(ValueError, match="order"):
        fairing(q, order=4)
    with pytest.raises(ValueError, match="lam_r"):
        fairing(q, lam_r=0.0)
    with pytest.raises(ValueError, match="degrees of rotation"):
        fairing(q, epsilon_r=-0.1)
    with pytest.raises(ValueError, match="max_iterations"):
        fairing(q, max_iterations=-1)
    with pytest.raises(ValueError, match="beta"):
        sse_fairing(q, beta=math.inf)
    with pytest.raises(ValueError, match="alpha"):
        sse_fairing_positions(np.zeros((5, 3)), alpha=-1.0)
    with pytest.raises(ValueError, match=r"\(F, \.\.\., 4\)"):
        fairing(np.zeros((5, 3)))


@pytest.mark.parametrize("beta", [1e7, 1e200])
def test_an_energy_weight_past_its_bound_is_refused_without_a_warning(beta, recwarn):
    """`sse_fairing(q, beta=1e200)` had printed numpy's "invalid value encountered in
    divide" and returned the input: refused, as the step's parameter is, no warning."""
    from motionclean.filters.fairing import MAX_WEIGHT, sse_fairing

    q = quat.exp(np.random.default_rng(0).normal(size=(20, 2, 3)) * 0.1)
    with pytest.raises(ValueError, match=re.escape(f"beta must be at most {MAX_WEIGHT:g}")):
        sse_fairing(q, beta=beta)
    assert not recwarn.list
