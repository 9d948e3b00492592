"""Resampling: quality against per-channel Euler cubic resampling, and cost per Lee-Shin pass.

Run ``python bench/resample.py``. Two tables:

1. Restoring a 4x subsampled clip to its rate. Every corpus clip (and a copy whose root is
   turned by a fixed rotation, so its root's Euler channels wrap and pass near gimbal lock,
   written the way a DCC tool writes angles: each in (-180, 180]) keeps every 4th frame
   (120 -> 30 fps), is resampled back to 120 fps and compared with the original frames it
   lost: RMS angle over every rotating joint (degrees), over the joints without capture
   defects (no step above 30 degrees at 120 fps: RThumb's flips left out), and over the
   root. The peer is what users do today: scipy's natural cubic spline
   (``CubicSpline(bc_type="natural")``) on each Euler channel as stored, run in the same
   process; the per-channel Catmull-Rom cubic (``euler_cubic``) is kept as a second peer.
   Ratios are ours / peer (below 1: ours is closer).
2. Cost: resampling a 100,000-frame, 31-joint clip (131_02 repeated) to several rates,
   against one 5-tap Lee-Shin pass over the same clip, best of 3, same process.
"""

from __future__ import annotations

import numpy as np
from common import best_of, corpus_clips

import motionclean as mc
from motionclean.core import quat
from motionclean.filters import lee_shin, masks
from motionclean.filters.interpolate import catmull_rom_tangents, hermite_positions
from motionclean.steps.resampling import resample_motion

STEP = 4


def euler_cubic(values: np.ndarray, step: int) -> np.ndarray:
    """Channel values ``(F, C)`` known every ``step`` frames, filled by the per-channel
    Catmull-Rom cubic (the peer), at every frame up to the last known one."""
    known = values[::step]
    tangents = catmull_rom_tangents(np.diff(known, axis=0))
    index = np.arange((known.shape[0] - 1) * step + 1)
    i, u = (
        np.minimum(index // step, known.shape[0] - 2),
        (index / step) - np.minimum(index // step, known.shape[0] - 2),
    )
    return hermite_positions(known[i], tangents[i], known[i + 1], tangents[i + 1], u)


def natural_cubic(values: np.ndarray, step: int) -> np.ndarray:
    """Channel values ``(F, C)`` known every ``step`` frames, filled by scipy's natural cubic
    spline per channel (the peer), at every frame up to the last known one."""
    from scipy.interpolate import CubicSpline  # bench dependency only

    known = values[::step]
    frames = np.arange(known.shape[0]) * step
    return CubicSpline(frames, known, axis=0, bc_type="natural")(np.arange(frames[-1] + 1))


def turned(clip: mc.Motion, rotation: np.ndarray) -> mc.Motion:
    """``clip`` with its root turned by ``rotation`` (world frame), its channel values
    rewritten as a DCC tool writes them (each angle in (-180, 180])."""
    rotations = clip.rotations.copy()
    rotations[:, 0] = quat.multiply(rotation, rotations[:, 0])
    translations = clip.translations.copy()
    translations[:, 0] = quat.rotate(rotation, translations[:, 0])
    values = clip.source_values.copy()
    layout = clip.layout
    order = layout.rotation_orders[0]
    values[:, layout.rotation_columns[0]] = quat.to_euler(rotations[:, 0], order)
    cols = layout.position_columns[0]
    values[:, cols[cols >= 0]] = translations[:, 0, cols >= 0]
    return mc.Motion.from_channel_values(
        clip.names, clip.parents, clip.offsets, clip.channels, clip.frame_time, values
    )


def restore_errors(
    clip: mc.Motion, joints: np.ndarray | None = None, peer=euler_cubic
) -> tuple[float, float]:
    """RMS angle (degrees) of ours and of ``peer`` (a per-channel Euler interpolant, default
    the Catmull-Rom cubic) on the frames a 4x subsample lost, over ``joints`` (default:
    every rotating joint)."""
    n = (clip.n_frames - 1) // STEP * STEP + 1
    rows = np.arange(n)
    lost = rows % STEP != 0
    rot = np.flatnonzero(clip.layout.has_rotation) if joints is None else joints
    sub = clip.replace(
        rotations=clip.rotations[:n:STEP],
        translations=clip.translations[:n:STEP],
        frame_time=clip.frame_time * STEP,
        source_values=None,
        source_rotations=None,
    )
    ours = resample_motion(sub, clip.frame_time).rotations[:n]
    values = peer(clip.source_values[:n], STEP)
    theirs = mc.Motion.from_channel_values(
        clip.names, clip.parents, clip.offsets, clip.channels, clip.frame_time, values
    ).rotations
    truth = clip.rotations[:n]

    def rms(q: np.ndarray) -> float:
        angles = np.degrees(quat.angle_between(q[lost][:, rot], truth[lost][:, rot]))
        return float(np.sqrt(np.mean(angles**2)))

    return rms(ours), rms(theirs)


def smooth_joints(clip: mc.Motion) -> np.ndarray:
    """Rotating joints without capture defects: no step above 30 degrees at the clip's rate."""
    steps = np.degrees(quat.angle_between(clip.rotations[:-1], clip.rotations[1:]))
    return np.flatnonzero(clip.layout.has_rotation & (steps.max(axis=0) < 30.0))


def quality_table() -> str:
    rows = [
        "| clip | ours, all joints | natural spline | ratio | Catmull-Rom | ratio "
        "| ratio, smooth joints | ours, root | natural, root | ratio, root |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    pooled = {"plain": np.zeros(7), "turned": np.zeros(7), "wrapping": np.zeros(7)}
    up = np.array([0.0, 1.0, 0.0])
    rotations = {  # the root's Euler channels are Z Y X: Y (heading) near +-90 is gimbal lock
        "facing +x (gimbal)": quat.from_axis_angle(up, np.pi / 2),
        "facing -x (gimbal)": quat.from_axis_angle(up, -np.pi / 2),
        "facing back (wraps)": quat.from_axis_angle(up, np.pi),
    }
    root = np.array([0])
    for path in corpus_clips():
        clip = mc.load(path)
        smooth = smooth_joints(clip)
        variants = [(path.stem, "plain", clip)]
        variants += [
            (f"{path.stem} {name}", "turned", turned(clip, r)) for name, r in rotations.items()
        ]
        for name, kind, variant in variants:
            ours, natural = restore_errors(variant, peer=natural_cubic)
            _, catmull = restore_errors(variant)
            ours_s, natural_s = restore_errors(variant, smooth, natural_cubic)
            ours_r, natural_r = restore_errors(variant, root, natural_cubic)
            errors = np.array([ours, natural, catmull, ours_s, natural_s, ours_r, natural_r])
            pooled[kind] += errors**2
            if "wraps" in name:
                pooled["wrapping"] += errors**2
            rows.append(
                f"| {name} | {ours:.3f} | {natural:.3f} | {ours / natural:.2f} | {catmull:.3f} "
                f"| {ours / catmull:.2f} | {ours_s / natural_s:.2f} | {ours_r:.3f} "
                f"| {natural_r:.3f} | {ours_r / natural_r:.3f} |"
            )
    for kind, sums in pooled.items():
        e = np.sqrt(sums)
        rows.append(
            f"| pooled, {kind} | | | {e[0] / e[1]:.2f} | | {e[0] / e[2]:.2f} | {e[3] / e[4]:.2f} "
            f"| | | {e[5] / e[6]:.3f} |"
        )
    return "\n".join(rows)


def cost_table(frames: int = 100_000) -> str:
    clip = mc.load(corpus_clips("131_02.bvh")[0])
    reps = -(-frames // clip.n_frames)
    long = clip.replace(
        rotations=np.tile(clip.rotations, (reps, 1, 1))[:frames],
        translations=np.tile(clip.translations, (reps, 1, 1))[:frames],
        source_values=None,
        source_rotations=None,
    )
    long = long.replace(rotations=quat.make_continuous(long.rotations))
    mask = masks.binomial(2)
    base = best_of(lambda: lee_shin(long.rotations, mask), 3, warm_up=True)
    rows = [
        f"one 5-tap Lee-Shin pass on ({frames:,}, {clip.n_joints}, 4): {base * 1000:.0f} ms",
        "",
        "| 120 fps -> | frames out | time (ms) | / Lee-Shin pass |",
        "| --- | ---: | ---: | ---: |",
    ]
    for fps in (240.0, 100.0, 60.0, 30.0, 24.0):
        seconds = best_of(lambda fps=fps: resample_motion(long, 1.0 / fps), 3)
        n = resample_motion(long, 1.0 / fps).n_frames
        rows.append(f"| {fps:g} fps | {n:,} | {seconds * 1000:.0f} | {seconds / base:.2f} |")
    return "\n".join(rows)


def main() -> None:
    print("Restoring a 4x subsampled clip (120 -> 30 -> 120 fps), error on the lost frames")
    print(quality_table())
    print()
    print("Cost of resampling a long clip")
    print(cost_table())


if __name__ == "__main__":
    main()
