"""Feet on the ground: the default pipeline with its footlock step against the same pipeline
without it, on real walks with planted noise.

Run: ``python bench/footlock.py`` (needs scipy, the ``bench`` extra, for the shared noise
of ``quality.py``). For each corpus clip, 3 degrees RMS of white rotation noise on every
joint (three seeds, as ``quality.py`` plants it); contacts found on the clean capture (the
truth) with the step's thresholds. Printed, per clip and seed:

* skate (mean horizontal speed during the truth's contacts) of the ankle and of every
  point below it (toe joint, toe end site), as a ratio to the capture's own skate, for
  the default with footlock (target <= 1.2), and the mean over the foot's points;
* leg rotation RMSE (every joint from the root's children down to the toes, degrees),
  knee flexion error (RMS of the thigh-shin angle's error, degrees) and the largest knee
  step between frames, with footlock over without (target: within 1 %);
* the cost of footlock: the step's time on the cleaned clip over the time of the default
  without it on the noisy clip, process CPU time, the median of 9 such pairs each timed
  back to back (target <= 1.5 default runs; ``MOTIONCLEAN_THREADS=1`` for single-threaded
  figures);
* the change footlock makes to the clip as captured (legs, RMS and max, degrees; target RMS
  < 0.3) and to the clip smoothed by 20 passes of B^3 (all joints, RMS; target < 0.05);
* the quality benchmark's default error (geodesic RMSE over the scored joints, 120 and
  30 fps, 1/3/6 degrees) with footlock over without: the change of its default/tuned
  ratios, whose tuned methods do not move (target: within 2 %);
* the same figures (but cost and the clean clips') on walks the targets were not set on:
  the corpus at 30 fps (every 4th frame) and the exporters' walks of tests/data/exporters
  (PyMO's T-pose walk, MocapBank's walk) at their own rates;
* a flying clip and a hand-only skeleton: unchanged bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from common import corpus_clips, cpu_ratio
from quality import NOISE_DEG, SUBSAMPLE, clean_base, plant_rotation_noise, rmse_deg, scored_joints

import motionclean as mc
from motionclean.core import contacts as found
from motionclean.core import kinematics, quat
from motionclean.filters import lee_shin
from motionclean.filters.masks import binomial
from motionclean.steps import footlock
from motionclean.steps.pipeline import DEFAULT_STEPS, Pipeline

NOISE = 3.0
SEEDS = (1, 2, 3)
EXPORTERS = Path(__file__).resolve().parent.parent / "tests" / "data" / "exporters"
EXPORTER_WALKS = ("pymo_walk_tpose", "mocapbank_walk")
PARAMS = {p.name: p.default for p in footlock.STEP.params}
WITH = Pipeline.from_tables(DEFAULT_STEPS, "default")
WITHOUT = Pipeline.from_tables([s for s in DEFAULT_STEPS if s["filter"] != "footlock"], "without")
LOCK = Pipeline.from_inline(["footlock"])


def noisy(motion: mc.Motion, degrees: float, seed) -> mc.Motion:
    rng = np.random.default_rng(seed)
    return motion.replace(rotations=plant_rotation_noise(motion.rotations, degrees, rng))


def chain(parents: np.ndarray, joint: int) -> list[int]:
    out = []
    while joint >= 0:
        out.append(joint)
        joint = int(parents[joint])
    return out


def flexion(positions: np.ndarray, foot: found.Foot) -> np.ndarray:
    thigh = positions[:, foot.knee] - positions[:, foot.hip]
    shin = positions[:, foot.ankle] - positions[:, foot.knee]
    cos = np.sum(thigh * shin, -1) / np.linalg.norm(thigh, axis=-1) / np.linalg.norm(shin, axis=-1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def figures(clip, truth, feet, contacts, up, height, legs, knees, truth_pos):
    positions, _ = kinematics.forward(clip, end_sites=True)
    skates = np.array(
        [
            found.skate(
                positions,
                [found.Foot(f.name, f.hip, f.knee, p, f.points)],
                contacts[:, [k]],
                up,
                clip.frame_time,
            )[0]
            / height
            for k, f in enumerate(feet)
            for p in f.points
        ]
    )
    dev = np.degrees(quat.angle_between(clip.rotations[:, legs], truth.rotations[:, legs]))
    flex = np.concatenate([flexion(positions, f) - flexion(truth_pos, f) for f in feet])
    steps = quat.angle_between(clip.rotations[1:, knees], clip.rotations[:-1, knees])
    return {
        "skate": skates,
        "rmse": float(np.sqrt(np.mean(dev**2))),
        "flexion": float(np.sqrt(np.mean(flex**2))),
        "knee_step": float(np.degrees(steps.max())),
    }


@dataclass(frozen=True)
class Walk:
    """A clean walk as scored: the capture, its feet, contacts, up axis, body height, leg
    joints, knees and world positions (``args`` of :func:`figures`), the capture's own
    figures and which foot points are ankles."""

    args: tuple
    own: dict
    ankles: list[int]
    toes: list[int]

    @property
    def truth(self) -> mc.Motion:
        return self.args[0]

    @property
    def legs(self) -> list[int]:
        return self.args[5]

    @classmethod
    def of(cls, truth: mc.Motion) -> Walk:
        scene, contacts, _ = footlock.find_contacts(truth, PARAMS)
        feet, truth_pos, up, height = scene.feet, scene.positions, scene.up, scene.height
        joints = np.array([p for f in feet for p in f.points if p < truth.n_joints])
        legs = [int(j) for j in kinematics.hung_on(truth.parents, [], joints) if j != 0]
        knees = [f.knee for f in feet]
        args = (truth, feet, contacts, up, height, legs, knees, truth_pos)
        points = [(k, p) for k, f in enumerate(feet) for p in f.points]
        ankles = [i for i, (k, p) in enumerate(points) if p == feet[k].ankle]
        toes = [i for i in range(len(points)) if i not in ankles]
        return cls(args, figures(truth, *args), ankles, toes)

    def with_noise(self, seed: int, with_: Pipeline):
        """The noisy clip (``seed``), the default without footlock's clip, and the figures
        without and with ``with_``; the skate ratios' ankle and toe columns."""
        planted = noisy(self.truth, NOISE, seed)
        cleaned = WITHOUT.run(planted)[0]
        without = figures(cleaned, *self.args)
        locked = figures(with_.run(planted)[0], *self.args)
        ratio = locked["skate"] / self.own["skate"]
        locked["foot_mean"] = locked["skate"].mean() / self.own["skate"].mean()
        return planted, cleaned, locked, without, ratio[self.ankles], ratio[self.toes]


def figure_cells(locked: dict, without: dict, ankles: np.ndarray, toes: np.ndarray) -> str:
    return (
        f"| {', '.join(f'{r:.2f}' for r in ankles)} | {', '.join(f'{r:.2f}' for r in toes)} "
        f"| {locked['foot_mean']:.2f} "
        f"| {locked['rmse'] / without['rmse']:.4f} "
        f"| {locked['flexion'] / without['flexion']:.4f} "
        f"| {locked['knee_step'] / without['knee_step']:.4f} "
    )


def walks(with_: Pipeline, lock: Pipeline, label: str) -> None:
    print(f"## Real walks, {NOISE:g} degrees of white noise on every joint: {label}\n")
    print(
        "| clip | seed | skate / capture's: ankles | toes and toe ends | mean of foot points "
        "| leg RMSE with / without | knee flexion error | largest knee step | cost (default "
        "runs) | clean capture's legs changed (RMS, max deg) | smoothed clip changed (RMS "
        "deg) |"
    )
    print("| --- | ---: | --- | --- | ---: | ---: | ---: | ---: | ---: | --- | ---: |")
    for path in corpus_clips():
        walk = Walk.of(mc.load(path))
        truth, legs = walk.truth, walk.legs
        clean_a, clean_b = with_.run(truth)[0], WITHOUT.run(truth)[0]
        moved = np.degrees(
            quat.angle_between(clean_a.rotations[:, legs], clean_b.rotations[:, legs])
        )
        smooth = truth.replace(rotations=lee_shin(truth.rotations, binomial(3), iterations=20))
        smooth_a, smooth_b = with_.run(smooth)[0], WITHOUT.run(smooth)[0]
        smoothed = np.degrees(quat.angle_between(smooth_a.rotations, smooth_b.rotations))
        for seed in SEEDS:
            planted, cleaned, locked, without, ankles, toes = walk.with_noise(seed, with_)
            cost = cpu_ratio(lambda c=planted: WITHOUT.run(c), lambda c=cleaned: lock.run(c), 9)
            print(
                f"| {path.stem} | {seed} {figure_cells(locked, without, ankles, toes)}"
                f"| {cost:.2f} "
                f"| {math.sqrt(np.mean(moved**2)):.4f}, {moved.max():.3f} "
                f"| {math.sqrt(np.mean(smoothed**2)):.5f} |"
            )
    print()


def other_walks() -> None:
    """The default on walks the targets were not set on: the corpus at 30 fps (every 4th
    frame) and the exporters' walks of tests/data/exporters at their own rates."""
    print(f"## Other walks and rates, {NOISE:g} degrees of white noise on every joint\n")
    print(
        "| clip | fps | seed | skate / capture's: ankles | toes and toe ends | mean of foot "
        "points | leg RMSE with / without | knee flexion error | largest knee step |"
    )
    print("| --- | ---: | ---: | --- | --- | ---: | ---: | ---: | ---: |")
    clips = [(p.stem, clean_base(mc.load(p), 4)) for p in corpus_clips()]
    clips += [(name, mc.load(EXPORTERS / f"{name}.bvh")) for name in EXPORTER_WALKS]
    for name, truth in clips:
        walk, fps = Walk.of(truth), round(1.0 / truth.frame_time)
        for seed in SEEDS:
            _, _, locked, without, ankles, toes = walk.with_noise(seed, WITH)
            print(f"| {name} | {fps} | {seed} {figure_cells(locked, without, ankles, toes)}|")
    print()


def quality() -> None:
    print("## The quality benchmark's default, with footlock over without\n")
    print("| clip | fps | " + " | ".join(f"{n:g} deg" for n in NOISE_DEG) + " |")
    print("| --- | ---: |" + " ---: |" * len(NOISE_DEG))
    for n_clip, path in enumerate(corpus_clips()):
        motion = mc.load(path)
        cols = scored_joints(motion)
        for sub in SUBSAMPLE:
            base = clean_base(motion, sub)
            cells = []
            for noise in NOISE_DEG:
                rng = np.random.default_rng([n_clip, sub, int(noise * 10)])
                clip = base.replace(rotations=plant_rotation_noise(base.rotations, noise, rng))
                a = rmse_deg(base.rotations, WITH.run(clip)[0].rotations, cols)
                b = rmse_deg(base.rotations, WITHOUT.run(clip)[0].rotations, cols)
                cells.append(f"{a / b:.4f}")
            print(f"| {path.stem} | {round(1 / base.frame_time)} | " + " | ".join(cells) + " |")
    print()


def untouched() -> None:
    motion = mc.load(corpus_clips()[1])
    height = kinematics.body_height(motion)
    translations = motion.translations.copy()
    translations[:, 0, 1] += height * np.arange(motion.n_frames) * motion.frame_time
    flying = noisy(motion.replace(translations=translations), NOISE, 2)
    same = np.array_equal(WITH.run(flying)[0].rotations, WITHOUT.run(flying)[0].rotations)
    print(f"flying clip (rising 1 body height per second): unchanged bit for bit: {same}")
    arm = [j for j, n in enumerate(motion.names) if n.startswith("RightShoulder")][0]
    keep = [arm, *[j for j in range(motion.n_joints) if arm in chain(motion.parents, j)[1:]]]
    index = {j: i for i, j in enumerate(keep)}
    hand = mc.Motion(
        names=[motion.names[j] for j in keep],
        parents=np.array([index.get(int(motion.parents[j]), -1) for j in keep]),
        offsets=motion.offsets[keep],
        channels=[motion.channels[j] for j in keep],
        frame_time=motion.frame_time,
        rotations=noisy(motion, NOISE, 3).rotations[:, keep],
        translations=np.zeros((motion.n_frames, len(keep), 3)),
        end_sites={index[j]: v for j, v in motion.end_sites.items() if j in index},
    )
    same = np.array_equal(WITH.run(hand)[0].rotations, WITHOUT.run(hand)[0].rotations)
    print(f"an arm alone (shoulder to fingers): unchanged bit for bit: {same}")


def main() -> None:
    walks(WITH, LOCK, "the default (ankles and toes held)")
    ankles = [*DEFAULT_STEPS[:-1], {"filter": "footlock", "toes": False}]
    walks(
        Pipeline.from_tables(ankles, "ankles"),
        Pipeline.from_inline(["footlock:toes=false"]),
        "footlock:toes=false (the ankles alone)",
    )
    other_walks()
    quality()
    untouched()


if __name__ == "__main__":
    main()
