"""World space: forward kinematics on a long clip against one Lee-Shin pass of the same array.

Run: ``python bench/world.py``. 131_02 repeated to 100,000 frames x 31 joints; prints the
time of :func:`motionclean.kinematics.forward` (joints and end sites) and its ratio to one
5-tap Lee-Shin pass over the clip's rotations (target: under 1).
"""

from __future__ import annotations

import numpy as np
from common import best_of, corpus_clips

import motionclean as mc
from motionclean import kinematics
from motionclean.filters import lee_shin
from motionclean.filters.masks import binomial

FRAMES = 100_000


def main() -> None:
    clip = mc.load(next(p for p in corpus_clips() if p.name == "131_02.bvh"))
    repeats = -(-FRAMES // clip.n_frames)
    index = np.tile(np.arange(clip.n_frames), repeats)[:FRAMES]
    long = clip.replace(
        rotations=clip.rotations[index], translations=clip.translations[index], source_values=None
    )
    rotations = long.rotations
    fk = best_of(lambda: kinematics.forward(long, end_sites=True), 3, warm_up=True)
    pass_ = best_of(lambda: lee_shin(rotations, binomial(2)), 3, warm_up=True)
    print(f"{FRAMES} frames x {clip.n_joints} joints")
    print(f"forward (joints + end sites) {fk * 1e3:8.1f} ms")
    print(f"one Lee-Shin pass (5 taps)   {pass_ * 1e3:8.1f} ms")
    print(f"ratio forward / pass         {fk / pass_:8.2f}  (target < 1)")


if __name__ == "__main__":
    main()
