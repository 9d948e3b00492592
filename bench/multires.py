"""Multiresolution analysis (paper 003): coordinate invariance of Sec. 5.2 / Fig. 10-11, cost.

Run ``python bench/multires.py``. Prints markdown tables:

1. 003 Sec. 5.2: the root (pelvis) trajectory of a corpus clip, rotated about the vertical
   axis (Y in the CMU clips) in steps of pi/12. For each rotation ``T`` two errors, as the
   largest geodesic distance over frames (Eq. 22, shown in degrees of rotation):
   * edit: ``edit(T m)`` against ``T edit(m)`` for the same per-level gains;
   * Sec. 5.2 protocol: the pyramid of ``m`` with its base moved by ``T`` and its details
     kept, reconstructed, against ``T m``.
   "ours" is :mod:`motionclean.filters.multires` (quaternions, body-frame displacements); "Euler" is
   the conventional method of [1] in 003: the same pyramid (same reduction mask, same 4-point
   expansion) run per channel on unwrapped Euler angles in the joint's channel order.
2. Attenuation: removing the finest levels of a whole clip, RMS angular acceleration of all
   joints (deg/s^2, as in reports) and largest deviation from the input. Each level halves
   the sampling rate, so removing ``k`` levels keeps roughly the band below
   ``Nyquist / 2^k``.
3. Cost of decomposition + reconstruction of a 31-joint, 10,000-frame clip (best of 5), with
   the per-channel Euler pyramid on the same frames as a peer.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from common import CORPUS, ROOT, best_of

sys.path.insert(0, str(ROOT))

import motionclean as mc  # noqa: E402
from motionclean.core import quat
from motionclean.filters import multires as mr
from motionclean.report.summary import metrics

UP = np.array([0.0, 1.0, 0.0])  # the vertical axis of the CMU clips


def to_euler_channels(q: np.ndarray, order: str) -> np.ndarray:
    """Unwrapped Euler angles in radians, one continuous channel per axis."""
    return np.unwrap(np.radians(quat.to_euler(q, order)), axis=0)


def from_euler_channels(angles: np.ndarray, order: str) -> np.ndarray:
    return quat.from_euler(np.degrees(angles), order)


def euler_edit(q: np.ndarray, levels: int, gains, order: str) -> np.ndarray:
    """The conventional method: the same pyramid, per channel, on Euler angles."""
    return from_euler_channels(mr.edit_positions(to_euler_channels(q, order), levels, gains), order)


def euler_moved_base(q: np.ndarray, rot: np.ndarray, levels: int, order: str) -> np.ndarray:
    """Sec. 5.2 with Euler angles: transform the base signal, keep the details, reconstruct."""
    pyramid = mr.decompose_positions(to_euler_channels(q, order), levels)
    base_q = quat.multiply(rot, from_euler_channels(pyramid.positions, order))
    reference = np.degrees(pyramid.positions)
    moved = np.radians(quat.to_euler(base_q, order, reference=reference))
    _, angles = mr.reconstruct(mr.Pyramid(None, moved, pyramid.details))
    return from_euler_channels(angles, order)


def degrees(a: np.ndarray, b: np.ndarray) -> float:
    """Largest Eq. 22 distance, as a rotation angle in degrees."""
    return float(np.degrees(quat.angle_between(a, b)).max())


def invariance_table(m: mc.Motion, levels: int, gains: list[float]) -> str:
    order = m.layout.rotation_orders[0]
    q, p = m.rotations[:, 0], m.translations[:, 0]
    ours_q, ours_p = mr.edit_frames(q, p, levels, gains)
    theirs = euler_edit(q, levels, gains, order)
    pyramid = mr.decompose(q, levels, p)
    lines = [
        "| rotation about Y | edit, ours (deg) | edit, Euler (deg) | edit, ours, root position "
        "| Sec. 5.2, ours (deg) | Sec. 5.2, Euler (deg) |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for k in range(9):
        rot = quat.from_axis_angle(UP, k * np.pi / 12)
        tq, tp = quat.multiply(rot, q), quat.rotate(rot, p)
        edited_q, edited_p = mr.edit_frames(tq, tp, levels, gains)
        base_q = quat.multiply(rot, pyramid.rotations)
        base_p = quat.rotate(rot, pyramid.positions)
        moved_q, _ = mr.reconstruct(mr.Pyramid(base_q, base_p, pyramid.details))
        cells = [
            f"{degrees(edited_q, quat.multiply(rot, ours_q)):.2e}",
            f"{degrees(euler_edit(tq, levels, gains, order), quat.multiply(rot, theirs)):.2e}",
            f"{np.abs(edited_p - quat.rotate(rot, ours_p)).max():.2e}",
            f"{degrees(moved_q, tq):.2e}",
            f"{degrees(euler_moved_base(q, rot, levels, order), tq):.2e}",
        ]
        lines.append(f"| {k} pi/12 ({15 * k} deg) | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def attenuation_table(m: mc.Motion, levels: int) -> str:
    """RThumb is left out of the deviation: its half-turn toggles (corpus README) dominate."""
    dt = m.frame_time
    keep = np.array([name != "RThumb" for name in m.names])
    lines = [
        "| finest levels removed | band removed (Hz) | RMS angular accel (deg/s^2) | ratio "
        "| max deviation, RThumb excluded (deg) |",
        "|---:|---:|---:|---:|---:|",
    ]
    before = float(metrics.rms(metrics.angular_acceleration(m.rotations, dt).ravel()))
    nyquist = 0.5 / dt
    for k in range(levels + 1):
        out = mr.edit(m.rotations, levels, [0.0] * k)
        accel = float(metrics.rms(metrics.angular_acceleration(out, dt).ravel()))
        dev = float(metrics.deviation_deg(m.rotations[:, keep], out[:, keep]).max())
        band = f"above ~{nyquist / 2**k:.1f}" if k else "none"
        lines.append(f"| {k} | {band} | {accel:,.0f} | {accel / before:.3f} | {dev:.2f} |")
    return "\n".join(lines)


def timing_table(m: mc.Motion, frames: int, repeats: int) -> str:
    reps = -(-frames // m.n_frames)
    q = quat.make_continuous(np.concatenate([m.rotations] * reps)[:frames])
    p = np.concatenate([m.translations] * reps)[:frames]
    order = m.layout.rotation_orders[0]
    angles = to_euler_channels(q, order)
    n_levels = mr.max_levels(frames)
    pyramid = mr.decompose(q, n_levels)
    rows = [
        (f"decompose, {n_levels} levels", lambda: mr.decompose(q, n_levels)),
        (f"reconstruct, {n_levels} levels", lambda: mr.reconstruct(pyramid)),
        (
            f"decompose + reconstruct, {n_levels} levels",
            lambda: mr.reconstruct(mr.decompose(q, n_levels)),
        ),
        ("edit(levels=4, gains=[0])", lambda: mr.edit(q, 4, [0.0])),
        (
            f"edit_frames with translations, {n_levels} levels, gains=[0]",
            lambda: mr.edit_frames(q, p, n_levels, [0.0]),
        ),
        (
            f"peer: Euler per-channel pyramid, {n_levels} levels (decompose + reconstruct)",
            lambda: mr.reconstruct(mr.decompose_positions(angles, n_levels)),
        ),
    ]
    lines = [
        f"| {q.shape[1]} joints x {frames} frames | best of {repeats} (s) | frames/s |",
        "|---|---:|---:|",
    ]
    for name, fn in rows:
        t = best_of(fn, repeats)
        lines.append(f"| {name} | {t:.3f} | {frames / t:,.0f} |")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clip", default="131_03.bvh", help="corpus clip for tables 1-2")
    parser.add_argument("--levels", type=int, default=5)
    parser.add_argument("--gains", type=float, nargs="*", default=[0.0, 0.0, 1.5, 1.5])
    parser.add_argument("--frames", type=int, default=10_000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    path = CORPUS / args.clip
    if not path.is_file():
        print(f"corpus clip {path} not found: nothing to measure", file=sys.stderr)
        return 1
    m = mc.load(path)
    print(
        f"## Coordinate invariance (003 Sec. 5.2): {args.clip} root, {m.n_frames} frames, "
        f"levels={args.levels}, gains={args.gains}\n"
    )
    print(invariance_table(m, args.levels, args.gains))
    print(f"\n## Attenuation: {args.clip}, all {m.n_joints} joints, levels={args.levels}\n")
    print(attenuation_table(m, args.levels))
    print(f"\n## Cost: {args.clip} tiled to {args.frames} frames\n")
    print(timing_table(m, args.frames, args.repeats))
    return 0


if __name__ == "__main__":
    sys.exit(main())
