"""Gap filling: our fill against slerp / linear and a plain cubic Hermite, on real motion.

Run ``python bench/gaps.py``. Rigid bodies are the world transforms (position and
orientation) of every joint of each corpus clip, as an optical tracker would see them.
Gaps of 3 to 60 frames (120 fps) are planted at seeded random places, three times over (one
per body per 240 frames, none at the clip's ends: about 1,000 gaps per length) and filled by

- ours (``fill-gaps``: each gap's bridge checked on gaps planted beside it: the C1 cubic
  with velocities fitted to several known frames on each side, the straight line, or under
  noise the same from smoothed edges or a smoothing spline),
- slerp for rotations and linear interpolation for positions between the edge samples,
- a plain cubic Hermite with Catmull-Rom tangents from the one frame beside each edge,

and compared with the truth on the missing frames: RMS angle (degrees) and RMS distance
(file units), with the ratios ours / slerp (linear for positions) and ours / the better of
the two peers. With ``--noise DEG ...`` (default 0, 0.5 and 2) the tracker data get white
noise first (degrees per rotation-vector component, and the same in thousandths of the
body height per position component) and the truth is the noise-free motion.
"""

from __future__ import annotations

import argparse

import numpy as np
from common import corpus_clips

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.core.restpose import rest_frames, trim
from motionclean.filters.gaps import Gaps, fill_gaps
from motionclean.filters.interpolate import end_tangent, hermite_positions, hermite_rotations

LENGTHS = (3, 6, 12, 24, 40, 60)
#: Independent plantings per clip (about 1,000 gaps per length in all).
PLANTINGS = 3
MAX_STEP_DEG = 15.0


def rigid_bodies(clip: mc.Motion) -> tuple[np.ndarray, np.ndarray]:
    """World orientations ``(F, B, 4)`` and positions ``(F, B, 3)`` of every joint whose
    world rotation never turns more than :data:`MAX_STEP_DEG` in one frame (the corpus's
    RThumb flips by half turns: a defect, not motion), rest-pose frames left out."""
    lead, trail = rest_frames(clip)
    positions, rotations = kinematics.forward(trim(clip, lead, trail))
    rotations = quat.make_continuous(rotations)
    steps = np.degrees(quat.angle_between(rotations[1:], rotations[:-1])).max(axis=0)
    smooth = steps <= MAX_STEP_DEG
    return rotations[:, smooth], positions[:, smooth]


def plant(n_frames: int, n_bodies: int, length: int, rng) -> np.ndarray:
    """A missing mask with gaps of ``length`` frames, one per body per 240 frames."""
    missing = np.zeros((n_frames, n_bodies), dtype=bool)
    for start in range(10, n_frames - length - 10, 240):
        for body in range(n_bodies):
            at = start + int(rng.integers(0, max(240 - length - 20, 1)))
            if at + length < n_frames - 10:
                missing[at : at + length, body] = True
    return missing


def peers(q: np.ndarray, p: np.ndarray, gaps: Gaps, catmull: bool):
    """Slerp / linear (``catmull`` False) or the plain Catmull-Rom Hermite fill."""
    q_out, p_out = q.copy(), p.copy()
    for j, first, stop in zip(gaps.joint, gaps.first, gaps.stop, strict=True):
        a, b = first - 1, stop
        u = (np.arange(first, stop) - a) / (b - a)
        step = quat.log_shortest(quat.multiply(quat.conjugate(q[a, j]), q[b, j]))
        if catmull:
            before = quat.log_shortest(quat.multiply(quat.conjugate(q[a - 1, j]), q[a, j]))
            after = quat.log_shortest(quat.multiply(quat.conjugate(q[b, j]), q[b + 1, j]))
            span = b - a
            v0, v1 = before * span, after * span
            q_out[first:stop, j] = hermite_rotations(
                np.broadcast_to(q[a, j], (u.size, 4)),
                np.broadcast_to(step, (u.size, 3)),
                np.broadcast_to(v0, (u.size, 3)),
                np.broadcast_to(end_tangent(step, v1), (u.size, 3)),
                u,
            )
            p_out[first:stop, j] = hermite_positions(
                p[a, j], (p[a, j] - p[a - 1, j]) * span, p[b, j], (p[b + 1, j] - p[b, j]) * span, u
            )
        else:
            q_out[first:stop, j] = quat.multiply(q[a, j], quat.exp(step * u[:, None]))
            p_out[first:stop, j] = p[a, j] + (p[b, j] - p[a, j]) * u[:, None]
    return q_out, p_out


def errors(q, p, truth_q, truth_p, missing) -> tuple[float, float]:
    angle = np.degrees(quat.angle_between(q[missing], truth_q[missing]))
    distance = np.linalg.norm(p[missing] - truth_p[missing], axis=-1)
    return float(np.sqrt(np.mean(angle**2))), float(np.sqrt(np.mean(distance**2)))


def table(noise_deg: float) -> str:
    rows = [
        "| gap (frames) | rotation: ours | slerp | Hermite | / slerp | / best | position: ours "
        "| linear | Hermite | / linear | / best |",
        "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    rng = np.random.default_rng(14)
    clips = [rigid_bodies(mc.load(path)) for path in corpus_clips()]
    worst, worst_line = 0.0, 0.0
    for length in LENGTHS:
        sums = np.zeros((3, 2))
        for truth_q, truth_p in clips * PLANTINGS:
            q, p = truth_q, truth_p
            if noise_deg:
                height = float(np.ptp(truth_p[..., 1]))
                q = quat.make_continuous(
                    quat.multiply(q, quat.exp(rng.normal(size=p.shape) * np.radians(noise_deg) / 2))
                )
                p = p + rng.normal(size=p.shape) * noise_deg * 1e-3 * height
            missing = plant(q.shape[0], q.shape[1], length, rng)
            gaps = Gaps.of(missing)
            filled = fill_gaps(q, p, missing, max_gap=length)
            ours = filled.rotations, filled.translations
            for row, (fq, fp) in enumerate(
                (ours, peers(q, p, gaps, False), peers(q, p, gaps, True))
            ):
                rot, pos = errors(fq, fp, truth_q, truth_p, missing)
                sums[row] += np.array([rot, pos]) ** 2
        rms = np.sqrt(sums / (len(clips) * PLANTINGS))
        line = rms[0] / rms[1]
        best = rms[0] / rms[1:].min(axis=0)
        worst, worst_line = max(worst, *best), max(worst_line, *line)
        rows.append(
            f"| {length} | {rms[0, 0]:.3f} | {rms[1, 0]:.3f} | {rms[2, 0]:.3f} | {line[0]:.2f} "
            f"| {best[0]:.2f} | {rms[0, 1]:.4f} | {rms[1, 1]:.4f} | {rms[2, 1]:.4f} "
            f"| {line[1]:.2f} | {best[1]:.2f} |"
        )
    rows.append(
        f"\nworst ratio: {worst_line:.2f} to slerp / linear, {worst:.2f} to the better peer"
    )
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--noise", type=float, nargs="*", default=[0.0, 0.5, 2.0])
    for noise in parser.parse_args().noise:
        print(f"Gaps in the world transforms of the corpus clips, noise {noise:g} deg")
        print(table(noise))
        print()


if __name__ == "__main__":
    main()
