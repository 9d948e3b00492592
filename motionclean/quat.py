"""Vectorised unit-quaternion algebra on ``(..., 4)`` float64 arrays.

Conventions (used everywhere in motionclean):

* components are ``(w, x, y, z)``; scipy's ``(x, y, z, w)`` is never used;
* the product is Hamilton's; ``q`` rotates column vectors as ``v' = q v q^-1``;
* ``exp(v) = (cos|v|, v/|v| sin|v|)`` as in the papers, so ``|log q|`` is HALF the
  rotation angle of ``q`` (Eq. 7-8 of 000);
* Euler angles are in degrees, intrinsic, applied in the listed order: order ``"ZXY"``
  means ``R = Rz(a0) Rx(a1) Ry(a2)``, exactly as BVH channel lists are read.

Every function broadcasts over leading axes and never loops in Python over samples.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "angle",
    "angle_between",
    "as_matrix",
    "conjugate",
    "exp",
    "from_axis_angle",
    "from_euler",
    "identity",
    "inverse",
    "log",
    "make_continuous",
    "multiply",
    "normalize",
    "rotate",
    "slerp",
    "to_euler",
]

AXES = "XYZ"


def identity(shape: tuple[int, ...] = ()) -> np.ndarray:
    """Identity quaternions ``(1, 0, 0, 0)`` of shape ``shape + (4,)``."""
    q = np.zeros((*shape, 4))
    q[..., 0] = 1.0
    return q


def multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p q`` (apply ``q`` first, then ``p``), broadcasting."""
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(np.broadcast_shapes(p.shape, q.shape))
    out[..., 0] = pw * qw - px * qx - py * qy - pz * qz
    out[..., 1] = pw * qx + px * qw + py * qz - pz * qy
    out[..., 2] = pw * qy - px * qz + py * qw + pz * qx
    out[..., 3] = pw * qz + px * qy - py * qx + pz * qw
    return out


def conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate ``(w, -x, -y, -z)``; the inverse of a unit quaternion."""
    out = np.array(q, dtype=np.float64, copy=True)
    out[..., 1:] *= -1.0
    return out


def inverse(q: np.ndarray) -> np.ndarray:
    """Inverse ``q* / |q|^2`` (equal to the conjugate for unit quaternions)."""
    q = np.asarray(q, dtype=np.float64)
    return conjugate(q) / np.sum(q * q, axis=-1, keepdims=True)


def normalize(q: np.ndarray) -> np.ndarray:
    """Scale each quaternion to unit length."""
    q = np.asarray(q, dtype=np.float64)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def exp(v: np.ndarray) -> np.ndarray:
    """Exponential map R^3 -> S^3: ``(cos|v|, v/|v| sin|v|)`` (000 Eq. 7).

    ``v`` has shape ``(..., 3)``; ``|v|`` is half the rotation angle in radians.
    """
    v = np.asarray(v, dtype=np.float64)
    theta = np.sqrt(np.einsum("...i,...i->...", v, v))
    out = np.empty((*v.shape[:-1], 4))
    out[..., 0] = np.cos(theta)
    out[..., 1:] = v * np.sinc(theta / np.pi)[..., None]
    return out


def log(q: np.ndarray) -> np.ndarray:
    """Logarithm S^3 -> R^3, the inverse of :func:`exp` with ``|log q|`` in ``[0, pi]``.

    Uses ``atan2(|v|, w)``, accurate near the identity and near a half turn. For ``w < 0``
    the result has norm above ``pi/2`` (a rotation of more than 180 degrees in S^3); make a
    signal sign-continuous first when displacements between samples are wanted.
    """
    q = np.asarray(q, dtype=np.float64)
    v = q[..., 1:]
    s = np.sqrt(np.einsum("...i,...i->...", v, v))
    w = q[..., 0]
    theta = np.arctan2(s, w)
    # theta / s -> 1 / w as s -> 0 (w > 0); the branch avoids 0/0 at the identity.
    small = s < 1e-12
    ratio = np.where(small, 1.0 / np.where(small, w, 1.0), theta / np.where(small, 1.0, s))
    return v * ratio[..., None]


def angle(q: np.ndarray) -> np.ndarray:
    """Rotation angle of ``q`` in radians, in ``[0, pi]``, independent of the sign of ``q``.

    ``2 atan2(|v|, |w|)``: accurate near 0 and near a half turn, unlike ``2 acos(w)``.
    """
    q = np.asarray(q, dtype=np.float64)
    s = np.sqrt(np.einsum("...i,...i->...", q[..., 1:], q[..., 1:]))
    return 2.0 * np.arctan2(s, np.abs(q[..., 0]))


def angle_between(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Geodesic distance in SO(3) between ``p`` and ``q``: rotation angle of ``p^-1 q``, rad."""
    return angle(multiply(conjugate(p), q))


def slerp(p: np.ndarray, q: np.ndarray, t) -> np.ndarray:
    """Spherical linear interpolation ``p exp(t log(p^-1 q))``, shortest arc.

    ``t`` broadcasts against the leading shape; ``t = 0`` gives ``p``, ``t = 1`` gives ``q``
    (up to sign).
    """
    p = np.asarray(p, dtype=np.float64)
    rel = multiply(conjugate(p), q)
    rel = np.where(rel[..., :1] < 0.0, -rel, rel)
    t = np.asarray(t, dtype=np.float64)[..., None]
    return multiply(p, exp(t * log(rel)))


def make_continuous(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip signs along ``axis`` so that consecutive samples have a non-negative dot product.

    Sec. VI-A of 000: the first sample keeps its sign; sample ``i`` is negated when it lies
    more than pi/2 (in S^3) from sample ``i-1`` after that one's correction.
    """
    q = np.moveaxis(np.asarray(q, dtype=np.float64), axis, 0)
    if q.shape[0] < 2:
        return np.moveaxis(q.copy(), 0, axis)
    dots = np.einsum("...i,...i->...", q[1:], q[:-1])
    flips = np.concatenate([np.ones_like(dots[:1]), np.where(dots < 0.0, -1.0, 1.0)])
    signs = np.cumprod(flips, axis=0)
    return np.moveaxis(q * signs[..., None], 0, axis)


def from_axis_angle(axis: np.ndarray, angle_rad) -> np.ndarray:
    """Rotation by ``angle_rad`` (radians) about the unit vector ``axis`` ``(..., 3)``."""
    axis = np.asarray(axis, dtype=np.float64)
    half = 0.5 * np.asarray(angle_rad, dtype=np.float64)
    out = np.empty(np.broadcast_shapes(axis.shape[:-1], half.shape) + (4,))
    out[..., 0] = np.cos(half)
    out[..., 1:] = axis * np.sin(half)[..., None]
    return out


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v`` ``(..., 3)`` by ``q``: ``q v q^-1``."""
    v = np.asarray(v, dtype=np.float64)
    pure = np.concatenate([np.zeros((*v.shape[:-1], 1)), v], axis=-1)
    return multiply(multiply(q, pure), conjugate(q))[..., 1:]


def as_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of unit quaternions (column-vector convention)."""
    q = np.asarray(q, dtype=np.float64)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    m = np.empty((*q.shape[:-1], 3, 3))
    m[..., 0, 0] = 1 - 2 * (y * y + z * z)
    m[..., 0, 1] = 2 * (x * y - w * z)
    m[..., 0, 2] = 2 * (x * z + w * y)
    m[..., 1, 0] = 2 * (x * y + w * z)
    m[..., 1, 1] = 1 - 2 * (x * x + z * z)
    m[..., 1, 2] = 2 * (y * z - w * x)
    m[..., 2, 0] = 2 * (x * z - w * y)
    m[..., 2, 1] = 2 * (y * z + w * x)
    m[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return m


def _order_axes(order: str) -> tuple[int, int, int]:
    order = order.upper()
    if len(order) != 3 or sorted(order) != ["X", "Y", "Z"]:
        raise ValueError(f"Euler order must be a permutation of 'XYZ', got {order!r}")
    i, j, k = (AXES.index(c) for c in order)
    return i, j, k


def from_euler(angles_deg: np.ndarray, order: str) -> np.ndarray:
    """Quaternions from intrinsic Euler angles in degrees, ``(..., 3)`` in ``order``.

    ``angles_deg[..., n]`` is the angle about axis ``order[n]``; the rotation is
    ``R = R_order[0](a0) R_order[1](a1) R_order[2](a2)`` (BVH channel order).
    """
    angles = np.asarray(angles_deg, dtype=np.float64)
    axes = _order_axes(order)
    half = np.deg2rad(angles) * 0.5
    c, s = np.cos(half), np.sin(half)
    out = None
    for n, ax in enumerate(axes):
        f = np.zeros((*angles.shape[:-1], 4))
        f[..., 0] = c[..., n]
        f[..., 1 + ax] = s[..., n]
        out = f if out is None else multiply(out, f)
    return out


def _nearest_turn(angle_rad: np.ndarray, ref_rad: np.ndarray) -> np.ndarray:
    """``angle_rad + 2 pi n`` with ``n`` chosen to land nearest ``ref_rad``."""
    return angle_rad + 2.0 * np.pi * np.round((ref_rad - angle_rad) / (2.0 * np.pi))


#: cos(middle angle) below which the first and last Euler angles are treated as locked.
GIMBAL_EPS = 1e-9


def to_euler(q: np.ndarray, order: str, reference: np.ndarray | None = None) -> np.ndarray:
    """Intrinsic Euler angles in degrees ``(..., 3)`` for ``order`` (see :func:`from_euler`).

    Without ``reference`` the principal triple is returned (first and last angles in
    ``(-180, 180]``, middle in ``[-90, 90]``). With ``reference`` (degrees, broadcastable)
    the result is the equivalent triple nearest to it: of the two Euler solutions, each
    shifted by whole turns toward the reference, the one with the smaller squared distance.
    At gimbal lock (middle angle +-90 degrees) only a sum or difference of the outer angles
    is determined; the reference's first angle is kept and the last absorbs the rest.
    """
    i, j, k = _order_axes(order)
    parity = 1.0 if (j - i) % 3 == 1 else -1.0
    m = as_matrix(q)
    sin_b = np.clip(parity * m[..., i, k], -1.0, 1.0)
    cos_b = np.hypot(m[..., i, i], m[..., i, j])
    b = np.arctan2(sin_b, cos_b)
    a = np.arctan2(-parity * m[..., j, k], m[..., k, k])
    c = np.arctan2(-parity * m[..., i, j], m[..., i, i])
    locked = cos_b < GIMBAL_EPS
    # At the lock R = R_i(a + s c) R_j(+-90 deg) with s = parity * sign(sin b).
    theta = np.arctan2(parity * m[..., k, j], m[..., j, j])
    lock_sign = parity * np.where(sin_b >= 0.0, 1.0, -1.0)
    if reference is None:
        a = np.where(locked, theta, a)
        c = np.where(locked, 0.0, c)
        return np.rad2deg(np.stack([a, b, c], axis=-1))

    ref = np.deg2rad(np.broadcast_to(np.asarray(reference, dtype=np.float64), a.shape + (3,)))
    ra, rb, rc = ref[..., 0], ref[..., 1], ref[..., 2]
    first = np.stack([_nearest_turn(a, ra), _nearest_turn(b, rb), _nearest_turn(c, rc)], -1)
    second = np.stack(
        [
            _nearest_turn(a + np.pi, ra),
            _nearest_turn(np.pi - b, rb),
            _nearest_turn(c + np.pi, rc),
        ],
        axis=-1,
    )
    d1 = np.sum((first - ref) ** 2, axis=-1)
    d2 = np.sum((second - ref) ** 2, axis=-1)
    best = np.where((d2 < d1)[..., None], second, first)
    # Gimbal lock: keep the reference's first angle, give the rest to the last one.
    lock_b = _nearest_turn(b, rb)
    lock_c = _nearest_turn(lock_sign * (theta - ra), rc)
    locked_triple = np.stack([ra, lock_b, lock_c], axis=-1)
    best = np.where(locked[..., None], locked_triple, best)
    return np.rad2deg(best)
