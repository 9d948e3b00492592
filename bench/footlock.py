"""Foot contacts after cleaning: skate, foot position error and cost of the footlock step.

Run: ``python bench/footlock.py``. Each corpus walk gets 3 degrees RMS of white rotation
noise on every joint (seeded). Contacts are found on the clean capture (the truth) with the
footlock step's thresholds; skate is the mean horizontal ankle speed during them, in body
heights per second. Compared: the truth itself, the default cleaning (despike, auto), and the
default followed by ``footlock``. Also: mean ankle position error against the truth (% of
body height), per-joint rotation RMSE against the truth (degrees; RThumb left out, its flips
are repaired by despike), and the cost of footlock in Lee-Shin passes of the same clip.
"""

from __future__ import annotations

import numpy as np
from common import best_of, corpus_clips

import motionclean as mc
from motionclean.core import contacts as found
from motionclean.core import kinematics, quat
from motionclean.filters import lee_shin
from motionclean.filters.masks import binomial
from motionclean.steps import footlock
from motionclean.steps.pipeline import Pipeline

NOISE_DEG = 3.0


def with_noise(motion: mc.Motion, degrees: float, seed: int) -> mc.Motion:
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(*motion.rotations.shape[:2], 3)) * np.radians(degrees) / 2 / np.sqrt(3)
    rotating = motion.layout.has_rotation
    q = motion.rotations.copy()
    q[:, rotating] = quat.multiply(q[:, rotating], quat.exp(v[:, rotating]))
    return motion.replace(rotations=q)


def main() -> None:
    params = {p.name: p.default for p in footlock.STEP.params}
    default = Pipeline.from_inline(["despike", "auto"])
    lock = Pipeline.from_inline(["footlock"])
    print(f"white noise {NOISE_DEG} deg RMS on every joint; skate in body heights/s")
    print(
        "| clip | skate truth | default | + footlock | ankle error default | + footlock |"
        " rotation RMSE default | + footlock | footlock cost (Lee-Shin passes) |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for path in corpus_clips():
        truth = mc.load(path)
        feet, contacts, truth_pos, _, up, height, _ = footlock.find_contacts(truth, params)
        ankles = [f.ankle for f in feet]
        cleaned, _ = default.run(with_noise(truth, NOISE_DEG, 1))
        locked, _ = lock.run(cleaned)
        keep = truth.layout.has_rotation & (np.array(truth.names) != "RThumb")
        row = [path.stem]
        skates, errors, rmses = [], [], []
        for clip in (truth, cleaned, locked):
            pos, _ = kinematics.forward(clip, end_sites=True)
            skates.append(
                np.nanmean(found.skate(pos, feet, contacts, up, truth.frame_time)) / height
            )
            errors.append(
                np.linalg.norm(pos[:, ankles] - truth_pos[:, ankles], axis=-1).mean() / height
            )
            dev = np.degrees(quat.angle_between(clip.rotations, truth.rotations))[:, keep]
            rmses.append(float(np.sqrt(np.mean(dev**2))))
        cost = best_of(lambda c=cleaned: lock.run(c), 3, warm_up=True)
        one_pass = best_of(lambda c=cleaned: lee_shin(c.rotations, binomial(2)), 3, warm_up=True)
        row += [f"{s:.3f}" for s in skates]
        row += [f"{100 * e:.2f} %" for e in errors[1:]]
        row += [f"{r:.3f}" for r in rmses[1:]]
        row.append(f"{cost / one_pass:.1f}")
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
