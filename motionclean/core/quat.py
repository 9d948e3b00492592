"""Vectorised unit-quaternion algebra on ``(..., 4)`` float64 arrays.

Conventions (used everywhere in motionclean):

* components are ``(w, x, y, z)``; scipy's ``(x, y, z, w)`` is never used;
* the product is Hamilton's; ``q`` rotates column vectors as ``v' = q v q^-1``;
* ``exp(v) = (cos|v|, v/|v| sin|v|)`` as in the papers, so ``|log q|`` is HALF the
  rotation angle of ``q`` (Eq. 7-8 of 000);
* Euler angles are in degrees, intrinsic, applied in the listed order: order ``"ZXY"``
  means ``R = Rz(a0) Rx(a1) Ry(a2)``, exactly as BVH channel lists are read.

Every function broadcasts over leading axes and never loops in Python over samples.
:func:`multiply`, :func:`exp` and :func:`log` run the plane kernels (:func:`multiply_planes`,
:func:`exp_planes`, :func:`log_planes`, for hot loops that keep components in separate
contiguous arrays) over cache-sized blocks, so they need no temporaries of the input's size.
"""

from __future__ import annotations

import numpy as np

from .checks import as_float_array, shaped
from .threads import in_parts, run_parts

__all__ = [
    "angle",
    "angle_between",
    "as_matrix",
    "conjugate",
    "relative",
    "Displacements",
    "displacements",
    "euler_middle_sine",
    "exp",
    "exp_planes",
    "from_axis_angle",
    "from_euler",
    "keep_first_at_lock",
    "identity",
    "inverse",
    "log",
    "log_planes",
    "log_shortest",
    "make_continuous",
    "multiply",
    "multiply_planes",
    "normalize",
    "rotate",
    "same_sign",
    "slerp",
    "to_euler",
]

AXES = "XYZ"


def identity(shape: tuple[int, ...] = ()) -> np.ndarray:
    """Identity quaternions ``(1, 0, 0, 0)`` of shape ``shape + (4,)``."""
    q = np.zeros((*shape, 4))
    q[..., 0] = 1.0
    return q


def _pair(p, q) -> tuple[np.ndarray, np.ndarray]:
    """``p`` and ``q`` as ``(..., 4)`` float64 arrays whose leading shapes broadcast, or
    ValueError naming both shapes."""
    p, q = shaped(p, 4, "p"), shaped(q, 4, "q")
    try:
        np.broadcast_shapes(p.shape, q.shape)
    except ValueError:
        raise ValueError(f"p {p.shape} and q {q.shape}: shapes that do not broadcast") from None
    return p, q


def multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p q`` (apply ``q`` first, then ``p``) of ``(..., 4)`` quaternions
    ``(w, x, y, z)``, broadcasting over the leading axes; a new float64 array. ValueError
    for a last axis other than 4 (naming ``p`` or ``q``) or shapes that do not broadcast."""
    p, q = _pair(p, q)
    if _is_small(p, q):
        return _sum_left_to_right(p[..., _PRODUCT_P] * _PRODUCT_SIGN * q[..., _PRODUCT_Q])
    return _blockwise(multiply_planes, (p, q), 4, 2)


def relative(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``p^-1 q`` for unit ``p`` (``conj(p) q``: the rotation from ``p`` to ``q`` in ``p``'s
    own frame), broadcasting; bit for bit ``multiply(conjugate(p), q)`` without the copy of
    ``p``."""
    p, q = _pair(p, q)
    if _is_small(p, q):
        return _sum_left_to_right(p[..., _PRODUCT_P] * _RELATIVE_SIGN * q[..., _PRODUCT_Q])
    return _blockwise(_relative_planes, (p, q), 4, 2)


def _relative_planes(out, p, q, tmp) -> None:
    multiply_planes(out, p, q, tmp, conjugate_p=True)


def conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate ``(w, -x, -y, -z)``; the inverse of a unit quaternion."""
    out = shaped(q, 4, "q").copy()
    out[..., 1:] *= -1.0
    return out


def inverse(q: np.ndarray) -> np.ndarray:
    """Inverse ``q* / |q|^2`` (equal to the conjugate for unit quaternions); ValueError for
    a zero quaternion or one whose squared norm is not a finite float64 (above ~1e154)."""
    q = shaped(q, 4, "q")
    with np.errstate(over="ignore"):
        norm2 = np.sum(q * q, axis=-1, keepdims=True)
    if not np.all((norm2 > 0.0) & (norm2 < np.inf)):
        raise ValueError("q: a zero, huge or non-finite quaternion has no inverse")
    return conjugate(q) / norm2


def normalize(q: np.ndarray) -> np.ndarray:
    """Scale each quaternion (or any vector along the last axis) to unit length.

    Safe for any finite magnitude: each is first divided by its largest component, so
    ``(1e200, 1e200, 0, 0)`` gives ``(0.7071, 0.7071, 0, 0)`` (no overflow). A zero one has
    no direction, a NaN or infinite one none either: ValueError.
    """
    q = as_float_array(q, "q")
    with np.errstate(over="ignore", under="ignore"):
        norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.all((norm > 1e-150) & (norm < 1e150)):  # the usual case: plain division
        return q / norm
    largest = np.max(np.abs(q), axis=-1, keepdims=True)
    if not np.all(largest < np.inf):  # NaN too
        raise ValueError("q: a vector or quaternion with a NaN or infinite component")
    if not np.all(largest > 0.0):
        raise ValueError("q: a zero vector or quaternion cannot be normalised")
    scaled = q / largest
    return scaled / np.linalg.norm(scaled, axis=-1, keepdims=True)


def exp(v: np.ndarray) -> np.ndarray:
    """Exponential map R^3 -> S^3: ``(cos|v|, v/|v| sin|v|)`` (000 Eq. 9).

    ``v`` has shape ``(..., 3)``; ``|v|`` is half the rotation angle in radians.
    """
    v = shaped(v, 3, "v")
    if _is_small(v):  # exp_planes on whole arrays, operation for operation
        t = np.sqrt(_sum_left_to_right(v * v))
        h = np.tan(t * 0.5)
        d = h * h
        out = np.empty((*v.shape[:-1], 4))
        np.subtract(1.0, d, out=out[..., 0])
        d += 1.0
        out[..., 0] /= d
        t = np.maximum(t, _TINY) * d
        h += h
        h /= t
        np.multiply(v, h[..., None], out=out[..., 1:])
        return out
    return _blockwise(exp_planes, (v,), 4, 3)


def log(q: np.ndarray) -> np.ndarray:
    """Logarithm S^3 -> R^3, the inverse of :func:`exp` with ``|log q|`` in ``[0, pi]``.

    Uses ``atan2(|v|, w)``, accurate near the identity and near a half turn. For ``w < 0``
    the result has norm above ``pi/2`` (a rotation of more than 180 degrees in S^3); make a
    signal sign-continuous first when displacements between samples are wanted.
    """
    q = shaped(q, 4, "q")
    if _is_small(q):  # log_planes on whole arrays, operation for operation
        v = q[..., 1:]
        norm = np.sqrt(_sum_left_to_right(v * v))
        ratio = np.arctan2(norm, q[..., 0]) / np.maximum(norm, _TINY)
        return v * ratio[..., None]
    return _blockwise(log_planes, (q,), 3, 2)


# ----------------------------------------------------------------------------- plane kernels
#
# The functions below work on quaternions stored as separate component arrays ("planes"):
# a sequence ``(w, x, y, z)`` of equally shaped float64 arrays (a vector is ``(x, y, z)``).
# They write into caller-supplied arrays and use caller-supplied scratch arrays of the same
# shape, so a hot loop can run them on contiguous, reused buffers without allocating. Output
# planes must not share memory with the inputs unless a kernel says otherwise.

#: Terms ``(p component, q component, sign)`` of each component of the Hamilton product.
_PRODUCT_TERMS = (
    ((0, 0, 1.0), (1, 1, -1.0), (2, 2, -1.0), (3, 3, -1.0)),
    ((0, 1, 1.0), (1, 0, 1.0), (2, 3, 1.0), (3, 2, -1.0)),
    ((0, 2, 1.0), (1, 3, -1.0), (2, 0, 1.0), (3, 1, 1.0)),
    ((0, 3, 1.0), (1, 2, 1.0), (2, 1, -1.0), (3, 0, 1.0)),
)

_TINY = np.finfo(np.float64).tiny

# The same terms as index and sign tables, for whole-array evaluation of small inputs.
_PRODUCT_P = np.array([[t[0] for t in terms] for terms in _PRODUCT_TERMS])
_PRODUCT_Q = np.array([[t[1] for t in terms] for terms in _PRODUCT_TERMS])
_PRODUCT_SIGN = np.array([[t[2] for t in terms] for terms in _PRODUCT_TERMS])
_RELATIVE_SIGN = np.where(_PRODUCT_P > 0, -_PRODUCT_SIGN, _PRODUCT_SIGN)  # conj(p) q

#: Inputs with fewer samples than this are evaluated on whole arrays at once, in the same
#: order of operations as the plane kernels (same bits): for a few hundred samples the
#: kernels' per-call overhead would cost more than the arithmetic.
SMALL_SAMPLES = 512


def _is_small(*arrays: np.ndarray) -> bool:
    return max(a.size // a.shape[-1] if a.ndim else 1 for a in arrays) < SMALL_SAMPLES


def _sum_left_to_right(terms: np.ndarray) -> np.ndarray:
    """``((t0 + t1) + t2) + t3`` over the last axis, in the plane kernels' order."""
    out = terms[..., 0] + terms[..., 1]
    for n in range(2, terms.shape[-1]):
        out += terms[..., n]
    return out


#: Samples per block in :func:`_blockwise` and in a Lee-Shin pass: a block's dozen or so
#: planes (about 2 MB) stay in cache while numpy's per-call overhead stays small.
BLOCK_SAMPLES = 16384


def _blockwise(kernel, arrays, n_out: int, n_tmp: int) -> np.ndarray:
    """Apply a plane kernel ``kernel(out, *inputs, tmp)`` to ``(..., C)`` arrays, broadcasting.

    Works through blocks of the first axis: each block's inputs are copied into contiguous
    component planes, so memory beyond the ``(..., n_out)`` result stays a few hundred
    kilobytes and every operation runs on cache-resident, contiguous data.
    """
    arrays = [np.asarray(a, dtype=np.float64) for a in arrays]
    shape = np.broadcast_shapes(*(a.shape[:-1] for a in arrays))
    out = np.empty((*shape, n_out))
    if out.size == 0:
        return out
    lead = shape or (1,)
    views = [np.broadcast_to(a, (*shape, a.shape[-1])).reshape(*lead, a.shape[-1]) for a in arrays]
    flat_out = out.reshape(*lead, n_out)
    inner = int(np.prod(lead[1:]))
    rows = min(max(1, BLOCK_SAMPLES // max(inner, 1)), lead[0])
    widths = [a.shape[-1] for a in arrays]
    work = np.empty((sum(widths) + n_tmp, rows * inner))
    for r0 in range(0, lead[0], rows):
        r1 = min(r0 + rows, lead[0])
        size = (r1 - r0) * inner
        planes, first = [], 0
        for view, width in zip(views, widths, strict=True):
            block = work[first : first + width, :size]
            np.copyto(block.reshape(width, r1 - r0, *lead[1:]), np.moveaxis(view[r0:r1], -1, 0))
            planes.append(block)
            first += width
        dst = flat_out[r0:r1].reshape(size, n_out)
        kernel([dst[:, c] for c in range(n_out)], *planes, work[first:, :size])
    return out


def multiply_planes(out, p, q, tmp, conjugate_p: bool = False) -> None:
    """``out = p q`` (or ``conj(p) q`` with ``conjugate_p``) on planes; ``tmp``: two scratch.

    Each output plane is written once (its terms are summed in ``tmp``), so ``out`` may be
    strided views into an ``(..., 4)`` array at little cost. ``out`` must not overlap ``p``
    or ``q``. Broadcasting follows numpy's rules per plane.
    """
    acc, term = tmp
    for dst, terms in zip(out, _PRODUCT_TERMS, strict=True):
        i, j, _ = terms[0]  # the leading term is always +p_i q_j, also for conj(p)
        np.multiply(p[i], q[j], acc)
        for n, (i, j, sign) in enumerate(terms[1:], 2):
            np.multiply(p[i], q[j], term)
            if conjugate_p:
                sign = -sign
            (np.add if sign > 0.0 else np.subtract)(acc, term, dst if n == 4 else acc)


def log_planes(out, q, tmp, shortest: bool = False) -> None:
    """``out = log(q)`` on planes (3 out, 4 in); ``tmp``: two scratch planes.

    ``|log q| = atan2(|v|, w)`` as in :func:`log`; with ``shortest`` the sign of ``q`` is
    chosen so that ``w >= 0`` (``log(+-q)`` of the shorter arc, ``|log| <= pi/2``). ``out``
    may be the planes ``q[1:]`` themselves (in place).
    """
    w, x, y, z = q
    norm, ratio = tmp
    np.multiply(x, x, norm)
    np.multiply(y, y, ratio)
    np.add(norm, ratio, norm)
    np.multiply(z, z, ratio)
    np.add(norm, ratio, norm)
    np.sqrt(norm, norm)
    if shortest:
        np.abs(w, ratio)
        np.arctan2(norm, ratio, ratio)
    else:
        np.arctan2(norm, w, ratio)
    # atan2(|v|, w) / |v|: at |v| = 0 the vector part is zero, any finite ratio will do.
    np.maximum(norm, _TINY, out=norm)
    np.divide(ratio, norm, ratio)
    if shortest:
        np.copysign(ratio, w, ratio)
    for dst, src in zip(out, (x, y, z), strict=True):
        np.multiply(src, ratio, dst)


def exp_planes(out, v, tmp) -> None:
    """``out = exp(v)`` on planes (4 out, 3 in); ``tmp``: three scratch planes.

    With ``h = tan(|v|/2)``: ``cos|v| = (1 - h^2) / (1 + h^2)`` and ``sin|v| / |v| =
    2 h / ((1 + h^2) |v|)``, exact identities valid for every ``|v|`` (numpy's vectorised
    ``tan`` is several times faster than ``sin`` and ``cos``). ``out[1:]`` may be the planes
    ``v`` themselves (in place); ``out[0]`` must not overlap ``v``.
    """
    x, y, z = v
    t, h, d = tmp
    np.multiply(x, x, t)
    np.multiply(y, y, h)
    np.add(t, h, t)
    np.multiply(z, z, h)
    np.add(t, h, t)
    np.sqrt(t, t)  # |v|
    np.multiply(t, 0.5, h)
    np.tan(h, h)
    np.multiply(h, h, d)
    np.subtract(1.0, d, out[0])
    np.add(d, 1.0, d)  # 1 + h^2
    np.divide(out[0], d, out[0])  # cos|v|
    np.maximum(t, _TINY, out=t)  # at |v| = 0, h = 0 and the vector part is zero anyway
    np.multiply(t, d, t)
    np.add(h, h, h)
    np.divide(h, t, h)  # sin|v| / |v|
    for dst, src in zip(out[1:], v, strict=True):
        np.multiply(src, h, dst)


def angle(q: np.ndarray) -> np.ndarray:
    """Rotation angle of ``q`` in radians, in ``[0, pi]``, independent of the sign of ``q``.

    ``2 atan2(|v|, |w|)``: accurate near 0 and near a half turn, unlike ``2 acos(w)``.
    """
    q = shaped(q, 4, "q")
    s = np.sqrt(np.einsum("...i,...i->...", q[..., 1:], q[..., 1:]))
    return 2.0 * np.arctan2(s, np.abs(q[..., 0]))


def angle_between(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Geodesic distance in SO(3) between unit quaternions ``p`` and ``q`` ``(..., 4)``
    ``(w, x, y, z)``, broadcasting: the rotation angle of ``p^-1 q`` in radians, in
    ``[0, pi]`` (``q`` and ``-q`` are the same rotation), shape ``(...)``."""
    return angle(relative(p, q))


def slerp(p: np.ndarray, q: np.ndarray, t) -> np.ndarray:
    """Spherical linear interpolation ``p exp(t log(p^-1 q))``, shortest arc.

    ``t`` broadcasts against the leading shape; ``t = 0`` gives ``p``, ``t = 1`` gives ``q``
    (up to sign).
    """
    p, q = _pair(p, q)
    t = np.asarray(t, dtype=np.float64)
    try:
        np.broadcast_shapes(t.shape, p.shape[:-1], q.shape[:-1])
    except ValueError:
        raise ValueError(
            f"t {t.shape}: does not broadcast against the quaternions' {p.shape[:-1]}"
        ) from None
    return multiply(p, exp(t[..., None] * log_shortest(relative(p, q))))


def log_shortest(q: np.ndarray) -> np.ndarray:
    """:func:`log` of ``q`` or ``-q``, whichever has ``w >= 0``: the shorter arc, with
    ``|log| <= pi/2`` (half of a rotation of at most 180 degrees)."""
    q = shaped(q, 4, "q")
    return log(np.where(np.signbit(q[..., :1]), -q, q))


def log_relative(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``log_shortest(relative(p, q))`` bit for bit, in one pass of planes (no product
    array, no sign-flipped copy): the shorter-arc displacement from ``p`` to ``q``."""
    p, q = _pair(p, q)
    return _blockwise(_log_relative_planes, (p, q), 3, 6)


def _log_relative_planes(out, p, q, tmp) -> None:
    product, scratch = tmp[:4], tmp[4:]
    multiply_planes(product, p, q, scratch, conjugate_p=True)
    log_planes(out, product, scratch, shortest=True)


def displacements(q: np.ndarray) -> np.ndarray:
    """Angular displacements ``w_i = log(q_i^-1 q_{i+1})`` along axis 0 (000 Eq. 19):
    ``(F, ..., 4)`` -> ``(F-1, ..., 3)``, half-angle units.

    ``q`` must be sign-continuous (:func:`make_continuous`), so that each ``|w_i| <= pi/2``.
    """
    q = shaped(q, 4, "q", signal=True)
    out = np.empty((max(q.shape[0] - 1, 0), *q.shape[1:-1], 3))

    def block(rows: slice) -> None:  # temporaries stay small; blocks run on threads
        out[rows] = log(relative(q[rows], q[rows.start + 1 : rows.stop + 1]))

    run_parts(block, in_parts(len(out), DISPLACEMENT_BLOCK), q.size)
    return out


#: Frames per block in :func:`displacements`.
DISPLACEMENT_BLOCK = 4096


class Displacements:
    """:func:`displacements` of ``q`` ``(F, ..., 4)``, computed for the rows sliced:
    ``Displacements(q)[a:b]`` equals ``displacements(q)[a:b]`` bit for bit, and no array of
    every row is made. ``shape`` is ``(F-1, ..., 3)``. Rows are computed from ``q`` as it is
    when they are asked for: frames of rows still to be read must not have changed."""

    def __init__(self, q: np.ndarray):
        self.q = shaped(q, 4, "q", signal=True)
        self.shape = (max(self.q.shape[0] - 1, 0), *self.q.shape[1:-1], 3)

    def __getitem__(self, rows: slice) -> np.ndarray:
        start, stop, step = rows.indices(self.shape[0])
        if step != 1:
            raise ValueError("Displacements takes slices of consecutive rows")
        return displacements(self.q[start : max(start, stop) + 1])


def continuous(q: np.ndarray) -> np.ndarray:
    """``q`` itself when it is already sign-continuous along axis 0 (no copy), else
    :func:`make_continuous` of it."""
    q = shaped(q, 4, "q")
    for at in range(0, max(q.shape[0] - 1, 0), DISPLACEMENT_BLOCK):
        a, b = q[at : at + DISPLACEMENT_BLOCK], q[at + 1 : at + 1 + DISPLACEMENT_BLOCK]
        if np.any(np.einsum("...i,...i->...", a[: b.shape[0]], b) < 0.0):
            return make_continuous(q, axis=0)
    return q


def same_sign(q: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """``q`` with each quaternion on the sign of ``reference`` (broadcast against it): the
    same rotations, on the reference's hemisphere of S^3 (``q`` where the two are
    orthogonal)."""
    return np.where(np.sum(q * reference, axis=-1, keepdims=True) >= 0.0, q, -q)


def make_continuous(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip signs along ``axis`` so that consecutive samples have a non-negative dot product.

    Sec. VI-A of 000: the first sample keeps its sign; sample ``i`` is negated when it lies
    more than pi/2 (in S^3) from sample ``i-1`` after that one's correction.
    """
    q = np.moveaxis(shaped(q, 4, "q"), axis, 0)
    if q.shape[0] < 2:
        return np.moveaxis(q.copy(), 0, axis)
    dots = np.einsum("...i,...i->...", q[1:], q[:-1])
    flips = np.concatenate([np.ones_like(dots[:1]), np.where(dots < 0.0, -1.0, 1.0)])
    signs = np.cumprod(flips, axis=0)
    return np.moveaxis(q * signs[..., None], 0, axis)


def from_axis_angle(axis: np.ndarray, angle_rad) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` ``(w, x, y, z)`` of the rotation by ``angle_rad``
    (radians, right-handed) about the unit vector ``axis`` ``(..., 3)``, broadcasting the
    two. ValueError for an axis whose last axis is not 3."""
    axis = shaped(axis, 3, "axis")
    half = 0.5 * np.asarray(angle_rad, dtype=np.float64)
    out = np.empty(np.broadcast_shapes(axis.shape[:-1], half.shape) + (4,))
    out[..., 0] = np.cos(half)
    out[..., 1:] = axis * np.sin(half)[..., None]
    return out


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v`` ``(..., 3)`` by unit quaternions ``q`` ``(..., 4)`` ``(w, x, y,
    z)``: ``q v q^-1`` (column vectors, as :func:`as_matrix` ``@ v``), broadcasting."""
    v = shaped(v, 3, "v")
    pure = np.concatenate([np.zeros((*v.shape[:-1], 1)), v], axis=-1)
    return multiply(multiply(q, pure), conjugate(q))[..., 1:]


def as_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of unit quaternions ``(..., 4)`` ``(w, x, y, z)``,
    for column vectors (``R @ v`` equals :func:`rotate` ``(q, v)``)."""
    q = shaped(q, 4, "q")
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
    if not isinstance(order, str):
        raise TypeError(f"order: expected a string such as 'ZXY', got {type(order).__name__}")
    if len(order) == 3 and sorted(order) == ["x", "y", "z"]:  # (scipy's extrinsic)
        raise ValueError(
            f"Euler order {order!r} in lower case: scipy reads that as extrinsic; orders here "
            f"are intrinsic, in upper case ({order.upper()!r})"
        )
    if len(order) != 3 or sorted(order) != ["X", "Y", "Z"]:
        raise ValueError(f"Euler order must be a permutation of 'XYZ', got {order!r}")
    i, j, k = (AXES.index(c) for c in order)
    return i, j, k


def from_euler(angles_deg: np.ndarray, order: str) -> np.ndarray:
    """Quaternions from intrinsic Euler angles in degrees, ``(..., 3)`` in ``order``.

    ``angles_deg[..., n]`` is the angle about axis ``order[n]``; the rotation is
    ``R = R_order[0](a0) R_order[1](a1) R_order[2](a2)`` (BVH channel order). Evaluated in
    closed form: with half-angle cosines/sines ``c*, s*`` and ``p = +1`` for a cyclic order
    (XYZ, YZX, ZXY), ``-1`` otherwise, the product ``q_i(a) q_j(b) q_k(c)`` is
    ``w = ca cb cc - p sa sb sc``, ``v_i = sa cb cc + p ca sb sc``,
    ``v_j = ca sb cc - p sa cb sc``, ``v_k = p sa sb cc + ca cb sc``.
    """
    angles = shaped(angles_deg, 3, "angles_deg")
    i, j, k = _order_axes(order)
    p = 1.0 if (j - i) % 3 == 1 else -1.0
    half = np.deg2rad(angles) * 0.5
    cos, sin = np.cos(half), np.sin(half)
    ca, cb, cc = cos[..., 0], cos[..., 1], cos[..., 2]
    sa, sb, sc = sin[..., 0], sin[..., 1], sin[..., 2]
    cacb, sasb, sacb, casb = ca * cb, sa * sb, sa * cb, ca * sb
    out = np.empty((*angles.shape[:-1], 4))
    out[..., 0] = cacb * cc - p * sasb * sc
    out[..., 1 + i] = sacb * cc + p * casb * sc
    out[..., 1 + j] = casb * cc - p * sacb * sc
    out[..., 1 + k] = p * sasb * cc + cacb * sc
    return out


def _matrix_element(q: np.ndarray, r: int, c: int) -> np.ndarray:
    """Element ``(r, c)`` of :func:`as_matrix` ``(q)``, without building the matrix."""
    w, v = q[..., 0], (q[..., 1], q[..., 2], q[..., 3])
    if r == c:
        s, t = (a for a in range(3) if a != r)
        return 1.0 - 2.0 * (v[s] * v[s] + v[t] * v[t])
    sign = -1.0 if (c - r) % 3 == 1 else 1.0
    return 2.0 * (v[r] * v[c] + sign * w * v[3 - r - c])


def euler_middle_sine(q: np.ndarray, order: str) -> np.ndarray:
    """The sine of the middle Euler angle of ``q`` ``(..., 4)`` in ``order`` (see
    :func:`from_euler`): the same for every Euler triple of the rotation (``sin(180 - b) =
    sin b``, whole turns aside), and as well conditioned as ``q`` itself (a rotation matrix
    element: a change of ``d`` per component moves it by at most ``4 d``)."""
    i, j, k = _order_axes(order)
    parity = 1.0 if (j - i) % 3 == 1 else -1.0
    return parity * _matrix_element(np.asarray(q, dtype=np.float64), i, k)


def _nearest_turn(angle_rad: np.ndarray, ref_rad: np.ndarray) -> np.ndarray:
    """``angle_rad + 2 pi n`` with ``n`` chosen to land nearest ``ref_rad``."""
    return angle_rad + 2.0 * np.pi * np.round((ref_rad - angle_rad) / (2.0 * np.pi))


#: cos(middle angle) below which the first and last Euler angles are treated as locked.
GIMBAL_EPS = 1e-9


def euler_and_middle_sine(q: np.ndarray, order: str) -> tuple[np.ndarray, np.ndarray]:
    """:func:`to_euler` ``(q, order)`` (the principal triple, degrees) and
    :func:`euler_middle_sine` ``(q, order)``, computed together (the triple is made from
    that sine)."""
    angles, sine, _ = _principal(q, order)
    return angles, sine


def _principal(q: np.ndarray, order: str):
    """The principal triple of ``q`` in degrees, the middle sine (not clipped) and, for
    ``to_euler``'s other triples, ``(a, b, c, sin_b, cos_b)`` in radians."""
    i, j, k = _order_axes(order)
    parity = 1.0 if (j - i) % 3 == 1 else -1.0
    q = shaped(q, 4, "q")
    m_ii, m_ij = _matrix_element(q, i, i), _matrix_element(q, i, j)
    sine = parity * _matrix_element(q, i, k)
    sin_b = np.clip(sine, -1.0, 1.0)
    cos_b = np.hypot(m_ii, m_ij)
    b = np.arctan2(sin_b, cos_b)
    a = np.arctan2(-parity * _matrix_element(q, j, k), _matrix_element(q, k, k))
    c = np.arctan2(-parity * m_ij, m_ii)
    locked = cos_b < GIMBAL_EPS
    out = np.empty((*b.shape, 3))
    out[..., 0], out[..., 1], out[..., 2] = a, b, c
    if locked.any():  # R = R_i(a + s c) R_j(+-90 deg): report a + s c as the first angle
        out[locked, 0] = _locked_sum(q[locked], i, j, k, parity)
        out[locked, 2] = 0.0
    return np.rad2deg(out, out=out), sine, (a, b, c, sin_b, cos_b)


def to_euler(q: np.ndarray, order: str, reference: np.ndarray | None = None) -> np.ndarray:
    """Intrinsic Euler angles in degrees ``(..., 3)`` for ``order`` (see :func:`from_euler`).

    Without ``reference`` the principal triple is returned (first and last angles in
    ``(-180, 180]``, middle in ``[-90, 90]``). With ``reference`` (degrees, broadcastable)
    the result is the equivalent triple nearest to it: of the two Euler solutions, each
    shifted by whole turns toward the reference, the one with the smaller squared distance.
    At gimbal lock (middle angle +-90 degrees) only a sum or difference of the outer angles
    is determined; the reference's first angle is kept and the last absorbs the rest.
    """
    principal, _, (a, b, c, sin_b, cos_b) = _principal(q, order)
    if reference is None:
        return principal
    i, j, k = _order_axes(order)
    parity = 1.0 if (j - i) % 3 == 1 else -1.0
    q = np.asarray(q, dtype=np.float64)
    locked = cos_b < GIMBAL_EPS
    out = principal
    ref = np.deg2rad(np.broadcast_to(shaped(reference, 3, "reference"), out.shape))
    ra, rb, rc = ref[..., 0], ref[..., 1], ref[..., 2]
    a1, b1, c1 = _nearest_turn(a, ra), _nearest_turn(b, rb), _nearest_turn(c, rc)
    a2 = _nearest_turn(a + np.pi, ra)
    b2 = _nearest_turn(np.pi - b, rb)
    c2 = _nearest_turn(c + np.pi, rc)
    second = (a2 - ra) ** 2 + (b2 - rb) ** 2 + (c2 - rc) ** 2 < (
        (a1 - ra) ** 2 + (b1 - rb) ** 2 + (c1 - rc) ** 2
    )
    out[..., 0] = np.where(second, a2, a1)
    out[..., 1] = np.where(second, b2, b1)
    out[..., 2] = np.where(second, c2, c1)
    if locked.any():
        # Gimbal lock: only a + s c is determined (s = parity * sign(sin b)); keep the
        # reference's first angle and give the rest to the last one.
        theta = _locked_sum(q[locked], i, j, k, parity)
        s_lock = parity * np.where(sin_b[locked] >= 0.0, 1.0, -1.0)
        ra_l = ra[locked]
        out[locked] = np.stack(
            [ra_l, b1[locked], _nearest_turn(s_lock * (theta - ra_l), rc[locked])], axis=-1
        )
    return np.rad2deg(out, out=out)


def keep_first_at_lock(angles: np.ndarray, order: str, first: np.ndarray) -> np.ndarray:
    """Euler ``angles`` ``(..., 3)`` (degrees, ``order``) at or near gimbal lock, split
    again with ``first`` ``(...)`` as their first angle: the combination of the outer angles
    that the lock determines, ``a + s c`` (``s`` the order's parity times the sign of the
    middle angle's sine), is kept and the last angle takes the rest. At lock the rotation
    is the same; a middle angle ``delta`` (radians) short of +-90 degrees moves it by at
    most ``|change of a| delta`` radians. A new array."""
    i, j, _ = _order_axes(order)
    parity = 1.0 if (j - i) % 3 == 1 else -1.0
    out = np.array(angles, dtype=np.float64)
    s = parity * np.where(np.sin(np.deg2rad(out[..., 1])) >= 0.0, 1.0, -1.0)
    locked_sum = out[..., 0] + s * out[..., 2]
    out[..., 0] = first
    out[..., 2] = s * (locked_sum - first)
    return out


def _locked_sum(q: np.ndarray, i: int, j: int, k: int, parity: float) -> np.ndarray:
    """At gimbal lock ``R = R_i(theta) R_j(+-90 deg)``: the determined angle ``theta``, rad."""
    return np.arctan2(parity * _matrix_element(q, k, j), _matrix_element(q, j, j))
