"""World space: forward kinematics on a long clip against one Lee-Shin pass of the same array.

Run: ``python bench/world.py``. 131_02 repeated to 100,000 frames x 31 joints; prints the
time of :func:`motionclean.core.kinematics.forward` (joints and end sites) and its ratio to one
5-tap Lee-Shin pass over the clip's rotations (target: under 1), best of 5 in wall-clock and
in the process's CPU time (both single-threaded; CPU time is steadier on a busy machine).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from common import best_of, corpus_clips

import motionclean as mc
from motionclean.core import kinematics
from motionclean.filters import lee_shin
from motionclean.filters.masks import binomial

FRAMES = 100_000


def best_cpu(fn: Callable[[], object], repeats: int) -> float:
    """Shortest process CPU time of ``repeats`` calls ``fn()`` after one untimed call."""
    fn()
    times = []
    for _ in range(repeats):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return min(times)


def main() -> None:
    clip = mc.load(next(p for p in corpus_clips() if p.name == "131_02.bvh"))
    repeats = -(-FRAMES // clip.n_frames)
    index = np.tile(np.arange(clip.n_frames), repeats)[:FRAMES]
    long = clip.replace(
        rotations=clip.rotations[index], translations=clip.translations[index], source_values=None
    )
    rotations = long.rotations

    def forward() -> object:
        return kinematics.forward(long, end_sites=True)

    def one_pass() -> object:
        return lee_shin(rotations, binomial(2))

    print(f"{FRAMES} frames x {clip.n_joints} joints        wall      CPU")
    fk = (best_of(forward, 5, warm_up=True), best_cpu(forward, 5))
    pass_ = (best_of(one_pass, 5, warm_up=True), best_cpu(one_pass, 5))
    print(f"forward (joints + end sites) {fk[0] * 1e3:8.1f} ms {fk[1] * 1e3:8.1f} ms")
    print(f"one Lee-Shin pass (5 taps)   {pass_[0] * 1e3:8.1f} ms {pass_[1] * 1e3:8.1f} ms")
    print(
        f"ratio forward / pass         {fk[0] / pass_[0]:8.2f}    {fk[1] / pass_[1]:8.2f}"
        "     (target < 1)"
    )


if __name__ == "__main__":
    main()
