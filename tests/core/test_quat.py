"""Quaternion algebra: Hamilton's rules, exp/log, angles, slerp, sign continuity, Euler."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from motionclean.core import quat

ORDERS = ["".join(p) for p in itertools.permutations("XYZ")]
AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}


def random_unit(rng, shape) -> np.ndarray:
    return quat.normalize(rng.normal(size=(*shape, 4)))


def elementary_matrix(axis: str, deg: np.ndarray) -> np.ndarray:
    """Right-handed rotation matrix about a coordinate axis, built from cos/sin directly."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    one, zero = np.ones_like(c), np.zeros_like(c)
    rows = {
        "X": [[one, zero, zero], [zero, c, -s], [zero, s, c]],
        "Y": [[c, zero, s], [zero, one, zero], [-s, zero, c]],
        "Z": [[c, -s, zero], [s, c, zero], [zero, zero, one]],
    }[axis]
    return np.moveaxis(np.array(rows), (0, 1), (-2, -1))


# ----------------------------------------------------------------------------- products


def test_hamilton_rules_on_basis():
    # 000 Eq. 6: i^2 = j^2 = k^2 = ijk = -1, ij = k, jk = i, ki = j (and the reverses negate).
    one, i, j, k = np.eye(4)
    for a, b, c in [(i, j, k), (j, k, i), (k, i, j)]:
        np.testing.assert_array_equal(quat.multiply(a, b), c)
        np.testing.assert_array_equal(quat.multiply(b, a), -c)
    for a in (i, j, k):
        np.testing.assert_array_equal(quat.multiply(a, a), -one)
    np.testing.assert_array_equal(quat.multiply(quat.multiply(i, j), k), -one)


@pytest.mark.parametrize(
    ("shape_p", "shape_q"),
    [((4,), (7, 4)), ((3, 1, 4), (1, 5, 4)), ((4,), (4,)), ((3, 9000, 4), (9000, 4))],
)
def test_multiply_bilinear_broadcasting_and_blocks(shape_p, shape_q):
    # Bilinearity on the basis expansion, checked element by element against broadcasting
    # (the last case spans several internal blocks).
    rng = np.random.default_rng(0)
    p, q = rng.normal(size=shape_p), rng.normal(size=shape_q)
    basis = np.eye(4)
    table = np.array([[quat.multiply(a, b) for b in basis] for a in basis])  # (4, 4, 4)
    expected = np.einsum("...i,...j,ijc->...c", p, q, table)
    out = quat.multiply(p, q)
    assert out.shape == np.broadcast_shapes(p.shape, q.shape)
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-13)


def test_associative_norm_multiplicative_and_inverse():
    rng = np.random.default_rng(1)
    p, q, r = (rng.normal(size=(50, 4)) for _ in range(3))
    np.testing.assert_allclose(
        quat.multiply(quat.multiply(p, q), r), quat.multiply(p, quat.multiply(q, r)), atol=1e-12
    )
    np.testing.assert_allclose(
        np.linalg.norm(quat.multiply(p, q), axis=-1),
        np.linalg.norm(p, axis=-1) * np.linalg.norm(q, axis=-1),
        rtol=1e-13,
    )
    np.testing.assert_allclose(quat.multiply(p, quat.inverse(p)), quat.identity((50,)), atol=1e-14)
    u = quat.normalize(p)
    np.testing.assert_allclose(quat.conjugate(u), quat.inverse(u), atol=1e-15)


def test_multiply_planes_conjugate_matches_multiply():
    rng = np.random.default_rng(2)
    p, q = random_unit(rng, (30,)), random_unit(rng, (30,))
    out = np.empty((4, 30))
    quat.multiply_planes(out, p.T, q.T, np.empty((2, 30)), conjugate_p=True)
    np.testing.assert_allclose(out.T, quat.multiply(quat.conjugate(p), q), atol=1e-15)


@pytest.mark.parametrize(("shape_p", "shape_q"), [((30, 4), (30, 4)), ((3, 9000, 4), (9000, 4))])
def test_relative_is_the_product_with_the_conjugate_bit_for_bit(shape_p, shape_q):
    # small inputs (whole-array path) and several blocks (plane path)
    rng = np.random.default_rng(4)
    p, q = random_unit(rng, shape_p[:-1]), random_unit(rng, shape_q[:-1])
    np.testing.assert_array_equal(quat.relative(p, q), quat.multiply(quat.conjugate(p), q))
    np.testing.assert_allclose(quat.relative(p, p), quat.identity(shape_p[:-1]), rtol=0, atol=1e-15)


# ----------------------------------------------------------------------------- exp / log


def test_exp_matches_definition_and_is_unit():
    # 000 Eq. 9: exp(v) = (cos|v|, v/|v| sin|v|), including |v| beyond pi.
    rng = np.random.default_rng(3)
    v = rng.normal(size=(2000, 3)) * rng.choice([1e-9, 1e-3, 0.5, 2.0, 9.0], size=(2000, 1))
    t = np.linalg.norm(v, axis=-1)
    expected = np.concatenate([np.cos(t)[:, None], v * (np.sin(t) / t)[:, None]], axis=-1)
    e = quat.exp(v)
    np.testing.assert_allclose(e, expected, rtol=0, atol=2e-15)
    np.testing.assert_allclose(np.linalg.norm(e, axis=-1), 1.0, atol=1e-15)
    np.testing.assert_array_equal(quat.exp(np.zeros(3)), [1.0, 0.0, 0.0, 0.0])


@pytest.mark.parametrize(
    "norm", [0.0, 1e-300, 1e-12, 1e-6, 0.3, 1.5, np.pi / 2, np.pi - 1e-6, np.pi - 1e-10]
)
def test_log_inverts_exp(norm):
    # log(exp(v)) = v for |v| < pi (the domain where log is the inverse, 000 Sec. III-B),
    # accurate near the identity and near |v| = pi (a quaternion near -1).
    rng = np.random.default_rng(4)
    axis = quat.normalize(rng.normal(size=(20, 3)))
    v = axis * norm
    np.testing.assert_allclose(quat.log(quat.exp(v)), v, rtol=0, atol=1e-15 * max(1.0, norm))


def test_exp_inverts_log_for_both_signs():
    rng = np.random.default_rng(5)
    q = random_unit(rng, (500,))
    q[:5] = quat.normalize(
        np.array(
            [
                [-1.0, 1e-13, 0.0, 0.0],
                [-1.0, 0.0, 2e-9, 0.0],
                [1.0, 1e-13, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [-1.0, 0.0, 0.0, 0.0],
            ]
        )
    )
    w = quat.log(q)
    assert np.all(np.linalg.norm(w, axis=-1) <= np.pi + 1e-15)
    np.testing.assert_allclose(quat.exp(w[:4]), q[:4], atol=1e-15)
    np.testing.assert_allclose(quat.exp(w[5:]), q[5:], atol=1e-15)
    # near -1 the log has norm ~ pi (not a tiny vector): exp brings back -1, not +1
    np.testing.assert_allclose(np.linalg.norm(w[:2], axis=-1), np.pi, atol=1e-8)


# ----------------------------------------------------------------------------- angles


@pytest.mark.parametrize("theta", [1e-12, 1e-9, 1e-5, 1.0, np.pi - 1e-5, np.pi - 1e-9])
def test_angle_accurate_near_0_and_180_degrees(theta):
    # Exact construction: w = cos(theta/2) = sin(delta) with delta = (pi - theta)/2 written
    # without cancellation, v = axis cos(delta) = axis sin(theta/2).
    rng = np.random.default_rng(6)
    axis = quat.normalize(rng.normal(size=(10, 3)))
    half = theta / 2.0
    w = np.sin((np.pi - theta) / 2.0) if theta > 1.0 else np.cos(half)
    q = np.concatenate([np.full((10, 1), w), axis * np.sin(half)], axis=-1)
    exact = 2.0 * np.arctan2(np.sin(half), w)
    for sign in (1.0, -1.0):
        np.testing.assert_allclose(quat.angle(sign * q), exact, rtol=1e-14, atol=0)
    if theta < 1e-8:
        # the usual 2 acos(w) loses it completely: cos(theta/2) rounds to 1
        assert abs(2.0 * np.arccos(np.clip(w, -1, 1)) - theta) > 0.5 * theta


def test_angle_between_is_a_metric_on_rotations():
    rng = np.random.default_rng(7)
    p, q = random_unit(rng, (100,)), random_unit(rng, (100,))
    d = quat.angle_between(p, q)
    np.testing.assert_allclose(d, quat.angle_between(q, p), atol=1e-15)
    np.testing.assert_allclose(quat.angle_between(p, -q), d, atol=1e-15)
    assert np.all(quat.angle_between(p, -p) < 1e-15)
    # angle_between(p, p exp(v)) = 2 |v| for |v| <= pi/2, and it is left-invariant
    v = rng.normal(size=(100, 3))
    v *= rng.uniform(0, np.pi / 2, size=(100, 1)) / np.linalg.norm(v, axis=-1, keepdims=True)
    moved = quat.multiply(p, quat.exp(v))
    np.testing.assert_allclose(
        quat.angle_between(p, moved), 2 * np.linalg.norm(v, axis=-1), atol=1e-13
    )
    a = random_unit(rng, ())
    np.testing.assert_allclose(
        quat.angle_between(quat.multiply(a, p), quat.multiply(a, q)), d, atol=1e-13
    )


# ----------------------------------------------------------------------------- slerp


def test_slerp_endpoints_midpoint_and_shortest_arc():
    rng = np.random.default_rng(8)
    p, q = random_unit(rng, (200,)), random_unit(rng, (200,))
    assert np.all(quat.angle_between(quat.slerp(p, q, 0.0), p) < 1e-14)
    assert np.all(quat.angle_between(quat.slerp(p, q, 1.0), q) < 1e-7)
    d = quat.angle_between(p, q)
    mid = quat.slerp(p, q, 0.5)
    np.testing.assert_allclose(quat.angle_between(p, mid), d / 2, atol=1e-12)
    np.testing.assert_allclose(quat.angle_between(mid, q), d / 2, atol=1e-12)
    # antipodal q is the same rotation: the shorter arc gives the same midpoint
    assert np.all(quat.angle_between(quat.slerp(p, -q, 0.5), mid) < 1e-12)
    # per-sample t broadcasts
    t = rng.uniform(size=200)
    np.testing.assert_allclose(quat.angle_between(p, quat.slerp(p, q, t)), t * d, atol=1e-12)


# ----------------------------------------------------------------------------- continuity


@pytest.mark.parametrize("axis", [0, 1])
def test_make_continuous_undoes_random_flips(axis):
    rng = np.random.default_rng(9)
    steps = quat.exp(rng.normal(scale=0.1, size=(60, 3, 3)))
    smooth = np.empty((60, 3, 4))
    smooth[0] = random_unit(rng, (3,))
    for i in range(1, 60):  # building test data only
        smooth[i] = quat.multiply(smooth[i - 1], steps[i])
    signs = rng.choice([-1.0, 1.0], size=(60, 3, 1))
    signs[0] = 1.0
    flipped = smooth * signs
    fixed = quat.make_continuous(np.moveaxis(flipped, 0, axis), axis=axis)
    np.testing.assert_array_equal(np.moveaxis(fixed, axis, 0), smooth)
    assert np.all(np.sum(smooth[1:] * smooth[:-1], axis=-1) > 0)  # data really is smooth


# ----------------------------------------------------------------------------- matrices


def test_as_matrix_rotate_and_composition():
    rng = np.random.default_rng(10)
    q, p = random_unit(rng, (100,)), random_unit(rng, (100,))
    v = rng.normal(size=(100, 3))
    m = quat.as_matrix(q)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", m, v), quat.rotate(q, v), atol=1e-13)
    np.testing.assert_allclose(
        m @ np.swapaxes(m, -1, -2), np.broadcast_to(np.eye(3), m.shape), atol=1e-14
    )
    np.testing.assert_allclose(np.linalg.det(m), 1.0, atol=1e-13)
    # apply q first, then p: R(p q) = R(p) R(q); and q, -q give the same rotation
    np.testing.assert_allclose(
        quat.as_matrix(quat.multiply(p, q)), quat.as_matrix(p) @ m, atol=1e-13
    )
    np.testing.assert_allclose(quat.as_matrix(-q), m, atol=1e-15)
    # right-handed, column vectors: +90 degrees about z takes x to y
    rz = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.pi / 2)
    np.testing.assert_allclose(quat.rotate(rz, np.array([1.0, 0.0, 0.0])), [0, 1, 0], atol=1e-15)


# ----------------------------------------------------------------------------- Euler


@pytest.mark.parametrize("order", ORDERS)
def test_from_euler_is_intrinsic_product_in_listed_order(order):
    rng = np.random.default_rng(11)
    angles = rng.uniform(-180, 180, size=(50, 3))
    q = quat.from_euler(angles, order)
    r0, r1, r2 = (elementary_matrix(axis, angles[:, n]) for n, axis in enumerate(order))
    expected = r0 @ r1 @ r2
    np.testing.assert_allclose(quat.as_matrix(q), expected, atol=1e-13)
    # a single channel is a rotation about that axis
    axis = np.eye(3)[AXIS_INDEX[order[1]]]
    single = quat.from_euler(np.array([0.0, 30.0, 0.0]), order)
    np.testing.assert_allclose(single, quat.from_axis_angle(axis, np.radians(30.0)), atol=1e-15)


@pytest.mark.parametrize("order", ORDERS)
def test_to_euler_round_trip_and_reference(order):
    rng = np.random.default_rng(12)
    angles = np.column_stack(
        [rng.uniform(-179, 179, 200), rng.uniform(-89, 89, 200), rng.uniform(-179, 179, 200)]
    )
    q = quat.from_euler(angles, order)
    np.testing.assert_allclose(quat.to_euler(q, order), angles, atol=1e-9)
    # with a reference, the equivalent triple nearest to it: whole turns are kept
    shifted = angles + np.array([360.0, -360.0, 720.0])
    np.testing.assert_allclose(quat.to_euler(q, order, reference=shifted), shifted, atol=1e-9)
    # the other Euler solution (a + 180, 180 - b, c + 180) is chosen when it is nearer
    other = angles + np.array([180.0, 0.0, 180.0])
    other[:, 1] = 180.0 - angles[:, 1]
    np.testing.assert_allclose(quat.to_euler(q, order, reference=other), other, atol=1e-9)


@pytest.mark.parametrize("order", ORDERS)
def test_to_euler_at_gimbal_lock_reproduces_rotation(order):
    rng = np.random.default_rng(13)
    angles = np.column_stack(
        [rng.uniform(-170, 170, 20), np.full(20, 90.0), rng.uniform(-170, 170, 20)]
    )
    angles[10:, 1] = -90.0
    q = quat.from_euler(angles, order)
    principal = quat.to_euler(q, order)
    assert np.all(quat.angle_between(quat.from_euler(principal, order), q) < 1e-7)
    kept = quat.to_euler(q, order, reference=angles)
    np.testing.assert_allclose(kept[:, 0], angles[:, 0], atol=1e-9)  # the original split
    assert np.all(quat.angle_between(quat.from_euler(kept, order), q) < 1e-7)


@pytest.mark.parametrize("order", ORDERS)
def test_keep_first_at_lock_keeps_the_rotation_within_its_bound(order):
    """At lock the re-split rotation is the same; a middle angle delta short of it moves
    the rotation by at most |change of the first angle| * delta (radians), for either sign
    of the middle angle and every order."""
    rng = np.random.default_rng(5)
    for short_deg in (0.0, 1e-5, 1e-3):
        middle = np.where(rng.random(40) < 0.5, 90.0, -90.0)
        middle -= np.sign(middle) * short_deg
        angles = np.column_stack([rng.uniform(-170, 170, 40), middle, rng.uniform(-170, 170, 40)])
        first = rng.uniform(-170, 170, 40)
        split = quat.keep_first_at_lock(angles, order, first)
        np.testing.assert_array_equal(split[:, 0], first)
        moved = quat.angle_between(quat.from_euler(split, order), quat.from_euler(angles, order))
        bound = np.radians(np.abs(first - angles[:, 0])) * np.radians(short_deg)
        assert np.all(moved <= bound + 1e-12)


@pytest.mark.parametrize("order", ORDERS)
def test_euler_middle_sine_is_the_same_for_every_triple_of_a_rotation(order):
    rng = np.random.default_rng(14)
    angles = rng.uniform(-180, 180, size=(300, 3))
    angles[:30, 1] = rng.choice([-90.0, 90.0], 30)  # gimbal lock
    other = angles + np.array([180.0, 0.0, 180.0])
    other[:, 1] = 180.0 - angles[:, 1]
    turned = angles + 360.0 * rng.integers(-3, 4, size=angles.shape)
    expected = np.sin(np.deg2rad(angles[:, 1]))
    for triple in (angles, other, turned):
        q = quat.from_euler(triple, order)
        for sign in (1.0, -1.0):
            got = quat.euler_middle_sine(sign * q, order)
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-14)
    # as well conditioned as the quaternion: a change of d per component moves it by <= 4 d
    q = quat.from_euler(angles, order)
    d = 1e-6 * rng.choice([-1.0, 1.0], size=q.shape)
    moved = np.abs(quat.euler_middle_sine(q + d, order) - quat.euler_middle_sine(q, order))
    assert moved.max() <= 4e-6 * (1 + 1e-9)


def test_displacements_computed_when_sliced_are_the_whole_arrays_rows_bit_for_bit():
    rng = np.random.default_rng(7)
    q = quat.continuous(quat.exp(rng.normal(scale=0.2, size=(9000, 5, 3))))
    whole = quat.displacements(q)
    lazy = quat.Displacements(q)
    assert lazy.shape == whole.shape
    for rows in [slice(0, 9000), slice(0, 1), slice(4095, 4097), slice(8000, None), slice(3, 3)]:
        assert np.array_equal(lazy[rows], whole[rows])
    with pytest.raises(ValueError, match="consecutive"):
        lazy[::2]


@pytest.mark.parametrize("shape", [(3,), (7, 2), (5000, 31)])
def test_log_relative_is_log_shortest_of_relative_bit_for_bit(shape):
    rng = np.random.default_rng(len(shape))
    p = quat.normalize(rng.normal(size=(*shape, 4)))
    q = quat.normalize(rng.normal(size=(*shape, 4)))
    q[..., 0][rng.random(shape) < 0.1] = 0.0  # w = 0 and -0 after the product's signs
    expected = quat.log_shortest(quat.relative(p, q))
    got = quat.log_relative(p, q)
    np.testing.assert_array_equal(got.view(np.int64), expected.view(np.int64))


@pytest.mark.parametrize("order", ["XYZ", "ZXY", "YZX", "ZYX", "XZY", "YXZ"])
def test_euler_and_middle_sine_are_to_euler_and_euler_middle_sine(order):
    rng = np.random.default_rng(5)
    q = quat.normalize(rng.normal(size=(2000, 4)))
    q[:20] = quat.from_euler(np.array([[30.0, 90.0, 10.0]]), order)  # gimbal lock
    angles, sine = quat.euler_and_middle_sine(q, order)
    np.testing.assert_array_equal(angles, quat.to_euler(q, order))
    np.testing.assert_array_equal(sine, quat.euler_middle_sine(q, order))


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: quat.from_euler(np.array([10.0, 20, 30, 40]), "ZYX"), r"angles_deg: .*\(4,\)"),
        (lambda: quat.from_euler(np.zeros(2), "ZYX"), r"angles_deg: expected shape \(\.\.\., 3\)"),
        (lambda: quat.to_euler(np.array([0.5, 0.5, 0.5, 0.5, 7.0]), "ZYX"), r"q: .*\(5,\)"),
        (lambda: quat.to_euler(quat.identity(()), "ZYX", np.zeros(2)), r"reference: "),
    ],
)
def test_euler_conversions_refuse_a_wrong_width_naming_the_argument(call, message):
    """A fourth angle had been dropped silently and a fifth component ignored."""
    with pytest.raises(ValueError, match=message):
        call()


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda q: quat.multiply(q, q[:, :2]), r"p \(30, 5, 4\) and q \(30, 2, 4\): shapes"),
        (lambda q: quat.relative(q, q[:3]), r"p \(30, 5, 4\) and q \(3, 5, 4\): shapes"),
        (lambda q: quat.slerp(q, q, np.ones(7)), r"t \(7,\): does not broadcast"),
    ],
)
def test_shapes_that_do_not_broadcast_are_named(call, message):
    """numpy's own message had named neither argument ('objects cannot be broadcast')."""
    with pytest.raises(ValueError, match=message):
        call(quat.identity((30, 5)))


def test_a_lower_case_euler_order_is_refused_as_scipys_extrinsic():
    """scipy reads "zxy" as extrinsic; an order here is intrinsic: lower case had been read
    as upper case, silently another rotation for a scipy user. Refused, saying so."""
    with pytest.raises(ValueError, match="lower case: scipy reads that as extrinsic"):
        quat.from_euler(np.array([10.0, 20.0, 30.0]), "zxy")
