"""C1 cubic interpolation of orientation and position samples, coordinate invariant.

Between samples ``q0`` and ``q1`` with angular displacement ``w = log(q0^-1 q1)`` (000 Eq. 19,
half-angle units) the orientation is ``q(u) = q0 exp(h(u))``, ``u`` in [0, 1], where ``h`` is
the cubic Hermite polynomial in the tangent space at ``q0`` with ``h(0) = 0``, ``h(1) = w``,
``h'(0) = v0`` and ``h'(1) = J(w)^-1 v1``. The tangents ``v0``, ``v1`` are angular
displacements per unit ``u`` in each sample's own body frame, and ``J(w)^-1`` (the inverse
right Jacobian of the exponential map, :func:`end_tangent`) turns ``v1`` into the rate of
``h`` that gives exactly that angular velocity at ``q1``: consecutive pieces join with
continuous angular velocity (C1), one exponential per sample.

Only displacements between samples enter, so the curve commutes with a fixed rotation on
either side (coordinate invariance, as for 003's Eq. 16-17 cubic), and with constant angular
velocity (``v0 = v1 = w``) it is exactly ``q0 exp(u w)``. Positions use the same Hermite
polynomial (the matching vector interpolant), exact on constant velocity.

Tangents through a sequence are Catmull-Rom: the mean of the displacements on either side
(the tangent of 003 Eq. 17's cubic through four samples at its knots).
"""

from __future__ import annotations

import numpy as np

from ..core import quat
from ..core.regrid import hermite


def catmull_rom_tangents(steps: np.ndarray) -> np.ndarray:
    """Tangents at ``F`` samples from their ``(F-1, ...)`` displacements ``steps`` (angular
    displacements ``log(q_i^-1 q_{i+1})`` or position differences): the mean of the two
    around each interior sample, the one-sided one at the ends. ``(F, ...)``."""
    out = np.empty((steps.shape[0] + 1, *steps.shape[1:]))
    out[0], out[-1] = steps[0], steps[-1]
    np.add(steps[:-1], steps[1:], out=out[1:-1])
    out[1:-1] *= 0.5
    return out


def end_tangent(step: np.ndarray, v1: np.ndarray) -> np.ndarray:
    """``J(w)^-1 v1``: the rate of ``h`` at ``h = w`` (``step``, ``(..., 3)``) for which
    ``q0 exp(h)`` moves with body angular displacement rate ``v1`` (``(..., 3)``).

    With ``phi = 2 w`` (the rotation vector) and ``theta = |w|``, the inverse right Jacobian
    of SO(3) is ``I + [phi]/2 + c [phi]^2`` with ``c = (1 - theta cot theta) / (4 theta^2)``
    (``1/12 + theta^2/180`` near 0) and ``[phi]^2 v = phi (phi . v) - |phi|^2 v``;
    half-angle units cancel, so it applies to ``v1`` as is.
    """
    sx, sy, sz = step[..., 0], step[..., 1], step[..., 2]
    vx, vy, vz = v1[..., 0], v1[..., 1], v1[..., 2]
    theta2 = sx * sx + sy * sy + sz * sz
    theta = np.sqrt(theta2)
    small = theta < 1e-4
    safe = np.where(small, 1.0, theta)
    coeff = np.where(
        small, 1.0 / 12.0 + theta2 / 180.0, (1.0 - safe / np.tan(safe)) / (4.0 * safe * safe)
    )
    along = 4.0 * coeff * (sx * vx + sy * vy + sz * vz)  # c phi (phi . v) = along * w
    keep = 1.0 - 4.0 * coeff * theta2  # 1 - c |phi|^2
    out = np.empty(np.broadcast_shapes(step.shape, v1.shape))
    out[..., 0] = keep * vx + along * sx + (sy * vz - sz * vy)  # + [phi] v / 2 = w x v
    out[..., 1] = keep * vy + along * sy + (sz * vx - sx * vz)
    out[..., 2] = keep * vz + along * sz + (sx * vy - sy * vx)
    return out


def hermite_rotations(
    q0: np.ndarray, step: np.ndarray, v0: np.ndarray, m1: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """``q0 exp(h(u))``: the C1 cubic from ``q0`` ``(..., 4)`` towards ``q0 exp(step)``.

    ``step`` ``(..., 3)`` is the displacement ``log(q0^-1 q1)``, ``v0`` the tangent at ``q0``
    and ``m1`` :func:`end_tangent` ``(step, v1)``; ``u`` ``(...)`` in [0, 1] (outside it
    extrapolates). Returns ``(..., 4)`` unit quaternions ``(w, x, y, z)``.
    """
    return quat.multiply(q0, quat.exp(hermite(step, v0, m1, u)))


def hermite_positions(
    p0: np.ndarray, v0: np.ndarray, p1: np.ndarray, v1: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """Cubic Hermite between points ``p0``, ``p1`` ``(..., D)`` with tangents ``v0``, ``v1``
    (change per unit ``u``) at parameter ``u`` ``(...)``; the vector counterpart of
    :func:`hermite_rotations`. ``u = 0`` gives ``p0`` exactly."""
    return p0 + hermite(p1 - p0, v0, v1, u)
